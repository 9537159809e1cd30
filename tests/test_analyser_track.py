"""The track-aware analyser against the paper's sector rule on the same trajectories."""

from __future__ import annotations

import functools
import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol.analysis import braking
from antikol.analysis.analyser import Analyser, AnalyserConfig
from tests._osm import FRAME, OsmBuilder, diamond_fixture, switch_fixture
from tests._paths import interleave, reports_along

TRAM = braking.load_profile("tram")
#: The bare rules: no margins for position uncertainty or anticipation.
BARE = AnalyserConfig(gap_margin_sigmas=0.0, anticipation_s=0.0)
#: Vehicles with reported ends: 20 m long, antenna in the middle.
ENDS = {"length_m": 20.0, "antenna_offset_m": 10.0}


@functools.cache
def _krakow() -> trackmap.TrackMap:
    return trackmap.load_default()


def build(b: OsmBuilder, tmp_path) -> trackmap.TrackMap:
    return trackmap.build(b.write_xml(tmp_path / "f.osm"))


def run(net, *streams, own="A", **kw):
    """Feed both analysers; return {t: (sector assessment, track assessment)} for ``own``."""
    sector, track = Analyser(), Analyser(track_map=net, **kw)
    out = {}
    merged = interleave(*streams)
    for r in merged:
        sector.update(r)
        track.update(r)
        if r.vehicle_id == own and len(sector.table) == len({x.vehicle_id for x in merged}):
            out[r.t] = (sector.assess(own), track.assess(own))
    return out, track


def curve_line():
    b = OsmBuilder()
    pts = [(0.0, -200.0), (0.0, 0.0), *b.arc(20.0, 0.0, 20.0, 180.0, 90.0, n=16)[1:], (220.0, 20.0)]
    b.line(pts, oneway="yes")
    return b, pts


def test_following_around_a_sharp_curve(tmp_path):
    b, pts = curve_line()
    net = build(b, tmp_path)
    t = np.arange(0.0, 12.0, 0.5)
    curve_len = math.pi * 20.0 / 2.0
    leader_at = 200.0 + curve_len + 10.0  # stopped 10 m past the curve
    leader = reports_along("B", pts, start_m=leader_at, speed_mps=0.0, t=t, frame=FRAME, **ENDS)
    follower = reports_along("A", pts, start_m=100.0, speed_mps=9.0, t=t, frame=FRAME, **ENDS)
    states, _ = run(net, leader, follower, config=BARE)
    warn = braking.warning_distance(9.0, TRAM)
    # the gap is between the follower's front and the leader's rear (10 m from each antenna)
    timely = [tt for tt, (_, tr) in states.items() if leader_at - (100 + 9 * tt) - 20 <= warn - 1]
    assert timely, "the scenario must reach the warning distance"
    for tt in timely:
        _sec, tr = states[tt]
        assert tr.lamp and tr.primary.kind == "rear_end" and tr.primary.method == "track"
        assert tr.primary.vehicle_id == "B"
        assert tr.primary.distance_m == pytest.approx(leader_at - (100 + 9 * tt) - 20, abs=1.0)
        assert (tr.primary.own_ends, tr.primary.other_ends) == ("reported", "reported")
    # before the curve the leader is 45 degrees off the course: the paper's rule is blind
    first = timely[0]
    assert not states[first][0].lamp


def double_track(oneway=True):
    b = OsmBuilder()
    tags = {"oneway": "yes"} if oneway else {}
    west = [(0.0, -100.0), (0.0, 1100.0)]
    east = [(3.8, -100.0), (3.8, 1100.0)]
    b.line(east, **tags)  # northbound (right-hand running)
    b.line(west[::-1], **tags)  # southbound
    return b, east, west


@pytest.mark.parametrize("oneway", [True, False])
def test_oncoming_on_the_adjacent_track_is_suppressed(tmp_path, oneway):
    b, east, west = double_track(oneway)
    net = build(b, tmp_path)
    t = np.arange(0.0, 75.0, 0.25)
    a = reports_along("A", east, start_m=0.0, speed_mps=8.0, t=t, frame=FRAME)
    bb = reports_along("B", west, start_m=0.0, speed_mps=8.0, t=t, frame=FRAME, reverse=True)
    states, _ = run(net, a, bb)
    sep = {tt: (1200.0 - 16.0 * tt) for tt in states}  # along-track separation
    sector_on = [sep[tt] for tt, (s, _) in states.items() if s.lamp]
    assert max(sector_on) == pytest.approx(300.0, abs=5.0)
    assert min(sector_on) == pytest.approx(3.8 / math.tan(math.radians(15.0)), abs=4.0)
    for tt, (s, tr) in states.items():
        assert tr.level == "none", f"false alarm at separation {sep[tt]:.0f} m"
        if s.lamp:
            assert [x.vehicle_id for x in tr.suppressed] == ["B"]
            assert tr.suppressed[0].reason == "parallel_track"


def test_head_on_on_single_track(tmp_path):
    b = OsmBuilder()
    line = [(0.0, -100.0), (0.0, 1100.0)]
    b.line(line)  # untagged single track: both directions
    net = build(b, tmp_path)
    t = np.arange(0.0, 58.0, 0.25)
    a = reports_along("A", line, start_m=50.0, speed_mps=10.0, t=t, frame=FRAME, **ENDS)
    bb = reports_along(
        "B", line, start_m=50.0, speed_mps=8.0, t=t, frame=FRAME, reverse=True, **ENDS
    )
    for own, v_own, v_other in (("A", 10.0, 8.0), ("B", 8.0, 10.0)):
        states, _ = run(net, a, bb, own=own, config=BARE)
        gap = {tt: 1100.0 - 18.0 * tt - 20.0 for tt in states}  # front to front
        warn = braking.head_on_distance(v_own, v_other, TRAM, TRAM)
        first_track = min(tt for tt, (_, tr) in states.items() if tr.lamp)
        assert gap[first_track] == pytest.approx(warn, abs=18.0 * 0.25 + 1.0)
        first_sector = min(tt for tt, (s, _) in states.items() if s.lamp)
        assert gap[first_sector] + 20.0 == pytest.approx(300.0, abs=2 * 18.0 * 0.25)
        th = states[first_track][1].primary
        assert th.kind == "head_on" and th.closing_speed_mps == pytest.approx(18.0, abs=0.5)
        assert th.ttc_s == pytest.approx(gap[first_track] / 18.0, abs=1.0)


def test_merge_at_a_switch_with_overlapping_arrivals(tmp_path):
    b = switch_fixture()
    net = build(b, tmp_path)
    straight = [(0.0, 200.0), (0.0, 0.0), (0.0, -200.0)]
    branch = [
        (80.0, 80.0),
        (30.0, 55.0),
        (9.0, 30.0),
        (4.0, 20.0),
        (1.0, 10.0),
        (0.0, 0.0),
        (0.0, -200.0),
    ]
    t = np.arange(0.0, 20.0, 0.5)
    a = reports_along("A", straight, start_m=100.0, speed_mps=8.0, t=t, frame=FRAME)
    blen = sum(math.dist(p, q) for p, q in itertools.pairwise(branch[:6]))  # to the switch
    bb = reports_along(
        "B", branch, start_m=blen - 100.0 * 7.0 / 8.0, speed_mps=7.0, t=t, frame=FRAME
    )
    states, _ = run(net, a, bb)
    kinds = {tr.primary.kind for _, tr in states.values() if tr.primary is not None}
    assert "merge" in kinds
    lamp_times = [tt for tt, (_, tr) in states.items() if tr.lamp]
    assert lamp_times, "the merge must raise a warning before the switch"
    th = states[lamp_times[0]][1].primary
    assert th.kind == "merge" and th.vehicle_id == "B" and th.distance_m > 0


def test_crossing_at_a_diamond_depends_on_arrival_windows(tmp_path):
    net = build(diamond_fixture(90.0), tmp_path)
    ns = [(0.0, -150.0), (0.0, 150.0)]
    we = [(-150.0, 0.0), (150.0, 0.0)]
    t = np.arange(0.0, 10.0, 0.5)
    a = reports_along("A", ns, start_m=80.0, speed_mps=8.0, t=t, frame=FRAME)
    together = reports_along("B", we, start_m=70.0, speed_mps=8.0, t=t, frame=FRAME)
    states, _ = run(net, a, together)
    crossing = [tr for _, tr in states.values() if tr.primary and tr.primary.kind == "crossing"]
    assert crossing and any(tr.lamp for tr in crossing)
    # at 12 m/s we have cleared the crossing in about 9 s; the other one, 150 m from it at
    # 2 m/s, cannot be there in less than about 16 s even accelerating: beyond the window
    # (AnalyserConfig.window_slack_s, 6 s), no conflict
    fast = reports_along("A", ns, start_m=80.0, speed_mps=12.0, t=t, frame=FRAME)
    late = reports_along("B", we, start_m=0.0, speed_mps=2.0, t=t, frame=FRAME)
    states, _ = run(net, fast, late)
    assert all(tr.level == "none" for _, tr in states.values())
    # at 8 m/s we clear it in about 13 s: the other could be there within the window
    states, _ = run(net, a, late)
    assert any(tr.primary and tr.primary.kind == "crossing" for _, tr in states.values())


def _crossing_before_switches() -> OsmBuilder:
    """A diamond at the origin (A's line south to north, B's west to east); 30 m past it
    B's line parts, and each branch parts again: four ways on, each taken at 0.25."""
    b = OsmBuilder()
    c = b.node(0.0, 0.0)
    b.line([(0.0, -250.0), c, (0.0, 250.0)], oneway="yes")
    first, south, north = b.node(30.0, 0.0), b.node(90.0, 0.0), b.node(110.0, 80.0)
    b.line([(-250.0, 0.0), c, first, south, (300.0, 0.0)], oneway="yes")
    bend = [(10.0, 1.0), (20.0, 4.0), (30.0, 9.0), (55.0, 30.0)]
    b.line([first, *[(30.0 + x, y) for x, y in bend], north], oneway="yes")
    b.line([south, *[(90.0 + x, -y) for x, y in bend], (170.0, -80.0)], oneway="yes")
    b.line([north, (140.0, 160.0), (150.0, 250.0)], oneway="yes")
    b.line([north, (160.0, 150.0), (250.0, 220.0)], oneway="yes")
    return b


def test_crossing_is_weighed_by_every_way_through_it(tmp_path):
    # B passes the diamond whichever of its four ways it takes: the crossing is certain,
    # not as probable as its likeliest single way (0.25, below warning_probability, kept
    # the lamp off until the emergency level; the referee's seed 5 missed such a crossing)
    net = build(_crossing_before_switches(), tmp_path)
    t = np.arange(0.0, 8.0, 0.5)
    a = reports_along(
        "A", [(0.0, -250.0), (0.0, 250.0)], start_m=150.0, speed_mps=8.0, t=t, frame=FRAME
    )
    b_ = reports_along(
        "B", [(-250.0, 0.0), (300.0, 0.0)], start_m=150.0, speed_mps=8.0, t=t, frame=FRAME
    )
    states, _ = run(net, a, b_, config=BARE)
    crossing = [
        tr.primary
        for _, tr in states.values()
        if tr.primary is not None and tr.primary.kind == "crossing"
    ]
    assert crossing
    assert all(th.probability == pytest.approx(1.0) for th in crossing)
    levels = [tr.level for _, (_, tr) in sorted(states.items())]
    assert "warning" in levels  # before the emergency, not straight to it
    if "emergency" in levels:
        assert levels.index("warning") < levels.index("emergency")


def test_branch_off_the_planned_route_is_advisory(tmp_path):
    net = build(switch_fixture(), tmp_path)
    trunk = next(e for e in net.edges if e.way_ids == (1,))
    straight = next(e for e in net.edges if e.way_ids == (2,))
    branch_pts = [(0.0, 0.0), (1.0, 10.0), (4.0, 20.0), (9.0, 30.0), (30.0, 55.0), (80.0, 80.0)]
    t = np.arange(0.0, 4.0, 0.5)
    # B moves slowly away from the switch on the branch: its direction is known
    stopped = reports_along("B", branch_pts, start_m=60.0, speed_mps=3.0, t=t, frame=FRAME)
    approach = [(0.0, -200.0), (0.0, 0.0)]
    for route, expected in (((trunk.edge_id, straight.edge_id), "advisory"), (None, "alarm")):
        a = reports_along(
            "A", approach, start_m=150.0, speed_mps=8.0, t=t, frame=FRAME, route=route
        )
        states, an = run(net, a, stopped)
        last = states[max(states)][1]
        # without a route the lamp is on while A can still take the branch at its speed
        assert any(tr.lamp for _, tr in states.values()) == (expected == "alarm")
        assert last.primary.zone == "right"
        roles = {z.label: z.role for z in an.zones("A")}
        assert roles == {"straight": "warning", "right": "advisory" if route else "warning"}


def test_vehicle_off_the_map_falls_back_to_the_sector_rule(tmp_path):
    b = OsmBuilder()
    b.line([(0.0, -200.0), (0.0, 600.0)], oneway="yes")
    net = build(b, tmp_path)
    t = np.arange(0.0, 3.0, 1.0)
    a = reports_along(
        "A", [(0.0, -200.0), (0.0, 600.0)], start_m=100.0, speed_mps=8.0, t=t, frame=FRAME
    )
    depot = reports_along(
        "D", [(40.0, 150.0), (40.0, 160.0)], start_m=0.0, speed_mps=0.0, t=t, frame=FRAME
    )
    states, an = run(net, a, depot)
    last = states[max(states)][1]
    assert an.position("D").status == "unmatched"
    assert last.primary.method == "sector" and last.primary.vehicle_id == "D"
    assert last.method == "track"  # the own vehicle is matched; only the pair falls back
    # own vehicle off the map: the sector rule throughout
    states, an = run(net, depot, a, own="D")
    assert an.position("D").status == "unmatched"
    assert states[max(states)][1].method == "sector"


def test_grade_separated_crossing_raises_no_alarm(tmp_path):
    b = OsmBuilder()
    b.line([(0.0, -300.0), (0.0, 600.0)], oneway="yes")
    b.line([(-300.0, 150.0), (300.0, 150.0)], bridge="yes", layer="1")
    net = build(b, tmp_path)
    t = np.arange(0.0, 5.0, 1.0)
    a = reports_along(
        "A", [(0.0, -300.0), (0.0, 600.0)], start_m=300.0, speed_mps=8.0, t=t, frame=FRAME
    )
    over = reports_along(
        "B", [(-300.0, 150.0), (300.0, 150.0)], start_m=290.0, speed_mps=2.0, t=t, frame=FRAME
    )
    states, _ = run(net, a, over)
    for s, tr in states.values():
        assert s.lamp  # the paper's rule sees a vehicle straight ahead
        assert tr.level == "none"
        assert [x.reason for x in tr.suppressed] == ["grade_separated"]


def test_ambiguous_match_raises_threat_with_its_probability(tmp_path):
    b = OsmBuilder()
    b.line([(0.0, -300.0), (0.0, 600.0)], oneway="yes")
    b.line([(3.8, -300.0), (3.8, 600.0)], oneway="yes")  # two parallel northbound tracks
    net = build(b, tmp_path)
    t = np.arange(0.0, 4.0, 1.0)
    a = reports_along(
        "A", [(0.0, -300.0), (0.0, 600.0)], start_m=300.0, speed_mps=8.0, t=t, frame=FRAME
    )
    mid = reports_along(
        "B", [(1.9, 0.0), (1.9, 600.0)], start_m=40.0, speed_mps=0.0, t=t, frame=FRAME
    )
    states, an = run(net, a, mid)
    assert an.position("B").status == "ambiguous"
    th = states[max(states)][1].primary
    assert th is not None and th.kind == "rear_end" and th.ambiguous
    assert 0.2 < th.probability < 0.8


def test_radio_stream_and_own_nmea_feed_the_same_analyser(tmp_path):
    from antikol.ingest.nmea import format_rmc
    from antikol.ingest.protocol import encode_report

    b, east, _ = double_track(True)
    net = build(b, tmp_path)
    t = np.arange(0.0, 4.0, 1.0)
    epoch = 1_700_000_000.0
    own = reports_along("A", east, start_m=300.0, speed_mps=8.0, t=t + epoch, frame=FRAME)
    other = reports_along("B", east, start_m=360.0, speed_mps=0.0, t=t + epoch, frame=FRAME)
    an = Analyser(track_map=net, own_id="A")
    frames = [encode_report(r, seq=k) for k, r in enumerate(other)]
    # a radio stream cut anywhere, with a broken frame between two intact ones
    noisy = frames[0] + b"\x00\x01garbage\x00" + b"".join(frames[1:])
    for k in range(0, len(noisy), 7):
        an.feed_bytes(noisy[k : k + 7])
    for r in own:
        an.feed_nmea(format_rmc(r))
    an.feed_nmea("$GPRMC,bad*00")
    assert an.decoder_stats.frames_ok == len(frames)
    assert an.decoder_stats.rejected_total >= 1
    a = an.assess()
    assert a.primary is not None and a.primary.vehicle_id == "B"
    assert a.primary.kind == "rear_end" and a.primary.method == "track"


@pytest.mark.parametrize("b_speed", [0.0, 2.0])
def test_a_diamond_fouled_by_the_others_body_warns(tmp_path, b_speed):
    """B's front has passed the diamond, its rear has not: A must not be told the way is
    clear. Paths ahead started at the antenna, so the diamond under B's rear half was no
    conflict of B's, and A got no warning until it ran into B's side."""
    net = build(diamond_fixture(90.0), tmp_path)
    ns = [(0.0, -150.0), (0.0, 150.0)]
    we = [(-150.0, 0.0), (150.0, 0.0)]
    ends = {"length_m": 30.0, "antenna_offset_m": 15.0}  # the rear 15 m behind the antenna
    t = np.arange(0.0, 10.5, 0.5)
    a = reports_along("A", ns, start_m=75.0, speed_mps=6.0, t=t, frame=FRAME, **ends)
    b_start = 140.0 if b_speed else 160.0  # standing: its antenna 10 m past the diamond
    b = reports_along("B", we, start_m=b_start, speed_mps=b_speed, t=t, frame=FRAME, **ends)
    states, _ = run(net, a, b)
    fouled = [
        tt
        for tt in states
        if 0.0 < b_start + b_speed * tt - 150.0 < 15.0 - 1.0  # rear still on the diamond
        and 0.0 < 60.0 - 6.0 * tt <= braking.warning_distance(6.0, TRAM)  # A's front nearing
    ]
    assert fouled, "the scenario must reach the fouled diamond within the warning distance"
    kinds = set()
    for tt in fouled:
        (threat,) = [th for th in states[tt][1].threats if th.vehicle_id == "B"]
        assert threat.level in ("warning", "emergency"), tt
        kinds.add(threat.kind)
    # (a standing B keeps a small chance of being on A's track: a rear-end threat first)
    assert "crossing" in kinds


def test_behind_a_tram_only_the_conflicts_up_to_where_the_tracks_part_count(tmp_path):
    """10 m past the joint of a crossover: the joint's switch is under the tram's body, by
    either track it came from; the crossover's far switch, on the other track, is not."""
    from antikol.analysis.views import _approaches, _tracks_behind

    b = OsmBuilder()
    joint, far = b.node(3.8, 440.0), b.node(0.0, 420.0)
    b.line([(3.8, 0.0), joint, (3.8, 1000.0)])
    b.line([(0.0, 1000.0), far, (0.0, 0.0)])
    b.line([far, joint])
    net = build(b, tmp_path)
    x_joint, y_joint = net.to_local(*FRAME.to_lonlat(3.8, 440.0))
    at_joint = {
        c.conflict_id for c in net.conflicts if math.dist((c.x, c.y), (x_joint, y_joint)) < 0.5
    }
    (north,) = [  # the track on from the joint, northwards
        e for e in net.edges
        if math.dist(e.geometry.coords[0], (x_joint, y_joint)) < 0.5 and e.length_m > 500.0
    ]  # fmt: skip
    behind = _tracks_behind(net, north.edge_id, 10.0, 1, 35.0)
    assert len(behind) == 2  # back along its own track, or back through the crossover
    ahead = tuple(net.paths_ahead(north.edge_id, 10.0, 1, 100.0))
    approaches, per_path = _approaches(ahead, behind)
    assert {a.conflict_id for a in approaches} == at_joint  # nothing ahead within 100 m
    assert all(a.distance_m == pytest.approx(-10.0) for a in approaches)
    assert len(approaches) == 2 and len({(a.from_edge, a.to_edge) for a in approaches}) == 2
    assert all(a.to_edge == north.edge_id for a in approaches)  # turned to running order
    assert per_path == ((0, 1),)  # every path ahead starts with them
    # 200 m from the joint nothing is looked up behind
    assert _tracks_behind(net, north.edge_id, 200.0, 1, 35.0) == ()


@settings(max_examples=80, deadline=None)
@given(
    edge=st.integers(0, 10_000),
    share=st.floats(0.0, 1.0),
    direction=st.sampled_from([1, -1]),
    rear_m=st.floats(0.0, 40.0),
)
def test_conflicts_behind_are_under_the_body_and_first_on_every_path(
    edge, share, direction, rear_m
):
    from antikol.analysis.views import BEHIND_REAR_M, _approaches, _tracks_behind

    net = _krakow()
    e = net.edges[edge % len(net.edges)]
    offset = share * e.length_m
    back_m = rear_m + BEHIND_REAR_M
    behind = _tracks_behind(net, e.edge_id, offset, direction, back_m)
    ahead = tuple(net.paths_ahead(e.edge_id, offset, direction, 150.0, respect_direction=False))
    approaches, per_path = _approaches(ahead, behind)
    under = [k for k, a in enumerate(approaches) if a.distance_m < 0.0]
    assert all(-back_m - 1e-6 <= approaches[k].distance_m for k in under)
    for mine in per_path:  # the body's conflict points first, the farthest behind first
        assert list(mine[: len(under)]) == sorted(under, key=lambda k: approaches[k].distance_m)
        assert all(approaches[k].distance_m >= 0.0 for k in mine[len(under) :])
