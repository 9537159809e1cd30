"""Track-selective positioning on synthetic maps: mechanics of the filter."""

from __future__ import annotations

import dataclasses
import itertools
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import VehicleReport
from antikol.errors import InvalidArgumentError
from antikol.positioning.candidates import find_candidates, loop_edges
from antikol.positioning.matcher import DiscreteFix, FixPoint, Positioner, PositioningConfig
from tests._osm import FRAME, STRAIGHT_LINE, OsmBuilder, straight_fixture, switch_fixture
from tests._paths import reports_along

LINE = STRAIGHT_LINE


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    return trackmap.build(straight_fixture().write_xml(tmp_path_factory.mktemp("s") / "s.osm"))


def drive(pos, reports):
    return [pos.update(r) for r in reports]


def test_confident_match_follows_the_vehicle(straight):
    pos = Positioner(straight)
    t = np.arange(0.0, 20.0, 1.0)
    out = drive(pos, reports_along("V", LINE, start_m=100.0, speed_mps=10.0, t=t, frame=FRAME))
    assert all(p.status == "confident" for p in out)
    assert [p.edge_id for p in out] == [0] * len(out)
    offsets = np.array([p.offset_m for p in out])
    assert np.allclose(offsets, 100.0 + 10.0 * t, atol=0.5)
    assert out[-1].speed_mps == pytest.approx(10.0, abs=0.2)
    assert out[-1].sigma_m < 3.0


def test_physically_impossible_reports_are_rejected(straight):
    pos = Positioner(straight)
    t = np.arange(0.0, 5.0, 1.0)
    good = reports_along("V", LINE, start_m=100.0, speed_mps=10.0, t=t, frame=FRAME)
    drive(pos, good)
    before = pos.position("V")
    lon, lat = FRAME.to_lonlat(0.0, -500.0 + 900.0)  # 450 m ahead one second later
    jump = VehicleReport("V", 5.0, lat, lon, 10.0, 0.0)
    after = pos.update(jump)
    assert pos.stats["rejected_jump"] == 1
    assert after.offset_m == pytest.approx(before.offset_m)
    fast = VehicleReport("V", 6.0, good[-1].lat, good[-1].lon, 60.0, 0.0)
    pos.update(fast)
    assert pos.stats["rejected_speed"] == 1
    # three implausible reports in a row: the vehicle is re-initialised from the evidence
    for k in range(3):
        pos.update(VehicleReport("V", 7.0 + k, lat, lon, 0.0, 0.0))
    assert pos.stats["reset_after_rejections"] == 1
    assert pos.position("V").offset_m == pytest.approx(900.0, abs=1.0)


def test_off_the_map_is_unmatched(straight):
    pos = Positioner(straight)
    lon, lat = FRAME.to_lonlat(200.0, 0.0)
    p = pos.update(VehicleReport("V", 0.0, lat, lon, 5.0, 0.0))
    assert p.status == "unmatched" and p.edge_id is None and p.lon == pytest.approx(lon)


def test_dead_reckoning_then_lost(straight):
    pos = Positioner(straight, PositioningConfig(dead_reckoning_s=20.0))
    t = np.arange(0.0, 10.0, 1.0)
    drive(pos, reports_along("V", LINE, start_m=100.0, speed_mps=10.0, t=t, frame=FRAME))
    p5 = pos.position("V", 14.0)
    assert p5.status == "confident" and p5.dead_reckoned_s == pytest.approx(5.0)
    assert p5.offset_m == pytest.approx(100.0 + 10.0 * 14.0, abs=1.0)
    p15 = pos.position("V", 24.0)
    assert p15.sigma_m > p5.sigma_m
    assert pos.position("V", 30.0).status == "lost"


def test_past_a_switch_the_position_waits_at_it_until_the_branch_is_decided(tmp_path):
    net = trackmap.build(switch_fixture().write_xml(tmp_path / "s.osm"))
    branch_pts = [
        (0.0, -200.0),
        (0.0, 0.0),
        (1.0, 10.0),
        (4.0, 20.0),
        (9.0, 30.0),
        (30.0, 55.0),
        (80.0, 80.0),
    ]
    pos = Positioner(net)
    t = np.arange(0.0, 14.0, 1.0)
    out = drive(pos, reports_along("V", branch_pts, start_m=170.0, speed_mps=6.0, t=t, frame=FRAME))
    branch = next(e.edge_id for e in net.edges if e.way_ids == (3,))
    straight = next(e.edge_id for e in net.edges if e.way_ids == (2,))
    trunk = next(e for e in net.edges if e.way_ids == (1,))
    # just past the switch, both branches alive and undecided: reported at the switch itself
    # (every branch starts there)
    held = [
        p
        for p in out
        if p.edge_id == trunk.edge_id
        and p.offset_m == pytest.approx(trunk.length_m)
        and {branch, straight} <= {h.edge_id for h in p.hypotheses}
    ]
    assert held
    # every position follows from the one before by a permitted move: no jump between branches
    for p, q in itertools.pairwise(out):
        if p.edge_id is not None and q.edge_id is not None and p.offset_m is not None:
            assert q.offset_m is not None and q.direction is not None
            step = net.route_distance(
                p.edge_id, p.offset_m, p.direction, q.edge_id, q.offset_m, cutoff_m=60.0
            )
            assert step is not None, (p, q)
    assert out[-1].edge_id == branch and out[-1].status == "confident"


def test_discrete_fixes_window_and_lost(straight):
    cfg = PositioningConfig(fix_window_base_m=2.0, fix_window_fraction=0.02)
    pos = Positioner(straight, cfg)
    t = np.arange(0.0, 10.0, 1.0)
    drive(pos, reports_along("V", LINE, start_m=100.0, speed_mps=10.0, t=t, frame=FRAME))
    # a fix 1.5 m ahead of the prediction: accepted, uncertainty collapses
    p = pos.fix("V", DiscreteFix(9.0, 0, 191.5, "B1"))
    assert pos.stats["fix_accepted"] == 1 and p.status == "confident"
    assert p.sigma_m < 0.6 and p.offset_m == pytest.approx(191.5, abs=0.1)
    # 100 m later the window is 2 + 0.02 * 100 = 4 m: a fix 10 m off is refused -> lost
    drive(
        pos,
        reports_along(
            "V", LINE, start_m=200.0, speed_mps=10.0, t=np.arange(10.0, 20.0, 1.0), frame=FRAME
        ),
    )
    p = pos.fix("V", DiscreteFix(19.0, 0, 290.0 + 10.0, "B2"))
    assert p.status == "lost" and pos.stats["fix_rejected"] == 1


def test_missed_expected_fixes_make_the_position_lost(straight):
    points = [FixPoint(f"L{k}", 0, 600.0 + 24.0 * k) for k in range(6)]
    pos = Positioner(straight, PositioningConfig(max_missed_fixes=2), fix_points=points)
    t = np.arange(0.0, 25.0, 1.0)
    out = drive(pos, reports_along("V", LINE, start_m=500.0, speed_mps=10.0, t=t, frame=FRAME))
    assert out[5].status == "confident"
    assert pos.stats["fix_missed"] >= 3
    assert out[-1].status == "lost"


def test_state_is_serialisable_and_restorable(straight):
    pos = Positioner(straight)
    t = np.arange(0.0, 6.0, 1.0)
    drive(pos, reports_along("V", LINE, start_m=100.0, speed_mps=10.0, t=t, frame=FRAME))
    state = json.loads(json.dumps(pos.state("V")))
    assert len(state["hypotheses"]) <= pos.config.max_hypotheses
    other = Positioner(straight)
    other.restore("V", state)
    assert other.position("V", 8.0) == pos.position("V", 8.0)


def test_a_turning_loop_is_followed_onto_the_track_it_leads_to():
    """Where a turning loop closes, its start and end lie metres apart: a fix there belongs
    to either. Kraków's loop (edge 1014) takes trams from the northbound track 582 back
    onto the southbound 1015; the matcher must follow it onto 1015, not run wrong way on
    582."""
    from antikol.sim import GpsModel, Simulator, TramSpec
    from antikol.sim.route_building import route_from_edges

    net = trackmap.load_default()
    loop = net.edges[1014]
    assert (
        net.edges[582].end_node == loop.start_node and loop.end_node == net.edges[1015].start_node
    )
    route = route_from_edges(net, [582, 1014, 1015], start_offset_m=700.0, end_offset_m=400.0)
    for seed in range(3):
        spec = TramSpec("L", route, initial_speed_mps=8.0, stops=())
        result = Simulator(net, [spec], gps=GpsModel(sigma_m=2.0, bias_sigma_m=1.5), seed=seed).run(
            200.0
        )
        pos = Positioner(net)
        out = [pos.update(r) for r in sorted(result.reports, key=lambda r: r.t)]
        after = [p for p in out if p.edge_id == 1015 or (p.edge_id == 582 and p.direction == -1)]
        assert after, "the tram must leave the loop within the run"
        wrong = [p for p in after if p.edge_id == 582]
        assert not wrong, f"seed {seed}: {len(wrong)} fixes running wrong way on 582"
        assert all(not p.wrong_way for p in out)


_KRAKOW = trackmap.load_default()
_LOOPS = loop_edges(_KRAKOW, 25.0)


@settings(max_examples=300, deadline=None)
@given(
    st.sampled_from(sorted(_LOOPS)),
    st.floats(min_value=0.0, max_value=1.0),
    st.floats(min_value=-14.0, max_value=14.0),
)
def test_a_fix_beside_a_turning_loop_has_a_candidate_there(edge_id, share, lateral_m):
    """A fix up to 14 m beside any place of a turning loop has a candidate on the loop
    near that place (within 6 m along it: the inside of a tight curve projects a little
    off), whichever part of the loop lies nearest. Where a loop closes, the fix beside
    its end lies nearer its start, and beyond it: the start was refused as an overshoot
    and the end, the loop's other half, was never looked at (Kraków's 1038 and 1035)."""
    loop = _LOOPS[edge_id].geometry
    along_m = 3.0 + share * (loop.length - 6.0)
    a, p, b = (loop.interpolate(along_m + d) for d in (-0.5, 0.0, 0.5))
    tx, ty = b.x - a.x, b.y - a.y
    norm = float(np.hypot(tx, ty))
    x, y = p.x - lateral_m * ty / norm, p.y + lateral_m * tx / norm  # (left positive)
    found = find_candidates(_KRAKOW, _LOOPS, np.array([x]), np.array([y]), np.array([25.0]))
    offsets = found.offset_m[found.edge_id == edge_id]
    assert np.any(np.abs(offsets - along_m) < 6.0), (along_m, offsets)
    heading = found.heading_deg[found.edge_id == edge_id]
    truth = [_KRAKOW.heading_at(edge_id, float(o)) for o in offsets]
    assert heading == pytest.approx(truth, abs=1e-9)  # (true north, as every candidate's)


def test_a_tram_leaving_a_loop_beside_its_start_is_not_restarted_wrong_way():
    # a harsher street receiver (10 m of lateral bias in canyons), an HFP log with an
    # odometer: 40/7 runs from 287 round the loop 1038 onto 1036, which runs beside 287 the
    # other way. Near the loop's end its fixes lay 12 m off 1038 and 5-6 m from 287, nearer
    # the loop's start than its end: 1038's nearest point was its start, refused as an
    # overshoot, and its other half was not searched, so the fixes were unreachable; three
    # in a row restarted the tram on 287, where it was shown running wrong way (11 fixes)
    from tests._recorded import assert_connected, replay_recorded

    out = replay_recorded(_KRAKOW, "a_fix_beyond_a_loop_start_beside_its_end.json", "40/7")
    shown = [p for p in out if p.edge_id is not None]
    path = [k for k, _ in itertools.groupby((p.edge_id, int(p.direction)) for p in shown)]
    assert path[-5:] == [(287, 1), (1038, 1), (1036, 1), (1037, 1), (781, 1)]
    assert not any(p.wrong_way for p in out)
    assert_connected(_KRAKOW, shown)


def test_a_start_between_the_two_sides_of_a_loop_is_not_shown_confident(tmp_path):
    # Synthville's loop line (edge 13, 901 m) goes out and comes back beside itself: its two
    # sides are one edge. A harsher street receiver (6 m of canyon bias), 40/7 appears
    # standing between them; the sides' hypotheses held 0.70 (the wrong one) and 0.29, but
    # counted as one place (one edge, one direction) they made 0.999: the tram was shown
    # confident on the wrong side and moved 218 m along the loop at the next fix, when its
    # course told the side (a window no route connects)
    from tests._recorded import assert_connected, replay_recorded
    from tests._synthville import synthville

    path = tmp_path / "synthville.osm"
    synthville().main(["-o", str(path), "--untagged-m", "0"])
    net = trackmap.build(path)
    out = replay_recorded(net, "a_start_between_the_two_sides_of_a_loop.json", "40/7")
    assert out[0].status == "ambiguous" and out[0].probability < 0.8  # (placed, not shown)
    moving = out[1:]
    assert all(p.status == "confident" and p.edge_id == 13 for p in moving)
    assert all(340.0 < p.offset_m < 460.0 for p in moving)
    assert_connected(net, moving)


def test_a_position_carried_past_a_switch_takes_the_branch_the_hypotheses_hold(tmp_path):
    # the estimate is moved from the trunk past the switch; without a route it used to take
    # the straight branch, confident, although the other hypotheses were on the diverging one
    from antikol.positioning.deadreckoning import advance

    net = trackmap.build(switch_fixture().write_xml(tmp_path / "s.osm"))
    trunk = next(e for e in net.edges if e.way_ids == (1,))
    branch = next(e.edge_id for e in net.edges if e.way_ids == (3,))
    straight = next(e.edge_id for e in net.edges if e.way_ids == (2,))
    toward_toe = 1  # the trunk is drawn from the south up to the switch
    start = trunk.length_m - 1.0
    plain = advance(net, trunk.edge_id, start, toward_toe, 4.0, None, wrong=False)
    assert plain.edge_id == straight and plain.branch_share == 1.0
    held = {(trunk.edge_id, 1): 0.5, (branch, 1): 0.3, (straight, 1): 0.2}
    moved = advance(net, trunk.edge_id, start, toward_toe, 4.0, None, wrong=False, edge_mass=held)
    assert moved.edge_id == branch
    assert moved.offset_m == pytest.approx(3.0, abs=0.5)
    assert moved.branch_share == pytest.approx(0.3 / 0.5)
    # a hypothesis running the other way on a branch is no vote for it
    against = {(trunk.edge_id, 1): 0.5, (branch, -1): 0.3, (straight, 1): 0.2}
    assert (
        advance(
            net, trunk.edge_id, start, toward_toe, 4.0, None, wrong=False, edge_mass=against
        ).edge_id
        == straight
    )
    # staying on the edge is no branch decision
    on_trunk = advance(net, trunk.edge_id, 10.0, toward_toe, 4.0, None, wrong=False, edge_mass=held)
    assert on_trunk.edge_id == trunk.edge_id and on_trunk.branch_share == 1.0


def _switch(tmp_path):
    """The switch fixture's map: its Arrivals, the trunk (an Edge) and the branch's and
    the straight track's edge ids."""
    from antikol.positioning.branching import Arrivals

    net = trackmap.build(switch_fixture().write_xml(tmp_path / "s.osm"))
    trunk = next(e for e in net.edges if e.way_ids == (1,))
    branch = next(e.edge_id for e in net.edges if e.way_ids == (3,))
    straight = next(e.edge_id for e in net.edges if e.way_ids == (2,))
    return Arrivals(net), trunk, branch, straight


def test_hold_at_switch_only_while_the_branch_is_open(tmp_path):
    from antikol.positioning.branching import hold_at_switch
    from antikol.positioning.records import Hypothesis

    arrivals, trunk, branch, straight = _switch(tmp_path)

    def hyps(p_branch: float, at_m: float) -> list[Hypothesis]:
        return [
            Hypothesis(branch, 1, at_m, p_branch, 0.0),
            Hypothesis(straight, 1, at_m, 1.0 - p_branch, 0.0),
        ]

    # undecided: at the switch on the trunk, 6 m more uncertain
    held = hold_at_switch(arrivals, hyps(0.6, 6.0), branch, 6.0, 1)
    assert held is not None
    assert held[:4] == (trunk.edge_id, trunk.length_m, 1, 6.0)
    assert hold_at_switch(arrivals, hyps(0.95, 6.0), branch, 6.0, 1) is None  # decided
    assert hold_at_switch(arrivals, hyps(0.6, 50.0), branch, 50.0, 1) is None  # far past it
    assert hold_at_switch(arrivals, hyps(1.0, 6.0)[:1], branch, 6.0, 1) is None  # no rival


def test_a_branch_is_decided_only_when_it_was_decided_at_the_fix_before(tmp_path):
    from antikol.positioning.branching import HypothesisBefore, hold_at_switch
    from antikol.positioning.records import Hypothesis

    arrivals, trunk, branch, straight = _switch(tmp_path)
    now = [Hypothesis(branch, 1, 6.0, 0.95, 0.0), Hypothesis(straight, 1, 6.0, 0.05, 0.0)]

    def before(p_branch: float, at_m: float = 3.0) -> list[HypothesisBefore]:
        return [
            HypothesisBefore(branch, 1, at_m, p_branch),
            HypothesisBefore(straight, 1, at_m, 1.0 - p_branch),
        ]

    def held(previous: list[HypothesisBefore]) -> bool:
        return hold_at_switch(arrivals, now, branch, 6.0, 1, before=previous) is not None

    assert not held([])  # not known (a fresh start): the share alone decides
    assert not held(before(0.92))  # decided then too
    assert held(before(0.6))  # one fix swung it: not yet
    assert held(before(0.05))  # it was on the other branch
    # it was still before the switch: the first fix past it decides nothing yet
    assert held([HypothesisBefore(trunk.edge_id, 1, trunk.length_m - 2.0, 1.0)])
    # once reported past the switch, a branch above the released share stays shown
    released = {trunk.end_node}
    rel = hold_at_switch(arrivals, now, branch, 12.0, 1, before=before(0.05), released=released)
    assert rel is None


def _switch_before_a_junction(tmp_path) -> tuple[trackmap.TrackMap, int, int, int, int]:
    """Trunk to a switch at (0, 0); its straight branch (the spur) runs 20 m into a
    junction where a line from the west joins, then on north; the other branch curves
    east. Returns the map, the switch's node and the trunk's, spur's and north line's
    edge ids."""
    b = OsmBuilder()
    toe, junction = b.node(0.0, 0.0), b.node(0.0, 20.0)
    b.line([(0.0, -300.0), toe], oneway="yes")
    b.line([toe, junction], oneway="yes")
    b.line([junction, (0.0, 300.0)], oneway="yes")
    b.line([(-40.0, -100.0), (-6.0, 0.0), (-1.5, 12.0), junction], oneway="yes")
    b.line([toe, (3.0, 10.0), (15.0, 30.0), (60.0, 80.0)], oneway="yes")
    net = trackmap.build(b.write_xml(tmp_path / "j.osm"))
    trunk, spur, north = (
        next(e.edge_id for e in net.edges if e.way_ids == (w,)) for w in (1, 2, 3)
    )
    return net, toe, trunk, spur, north


def test_the_way_back_to_a_switch_crosses_a_junction_the_track_alone_does_not(tmp_path):
    from antikol.positioning.branching import Arrivals

    net, toe, trunk, spur, north = _switch_before_a_junction(tmp_path)
    arrivals = Arrivals(net)
    # from the north line the track alone stops at the junction: two ways lead there
    assert arrivals.switches((north, 1)) == ()
    assert arrivals.merge_behind_m((north, 1)) == 0.0
    assert arrivals.nearest_switch_m(np.array([north]), np.array([1]))[0] == 0.0
    # the way a vehicle came finds the switch 20 m behind the entry of the north line
    found = arrivals.switches_along([(trunk, 1), (spur, 1), (north, 1)])
    assert [(node, state) for node, _, state in found] == [(toe, (spur, 1))]
    assert found[0][1] == pytest.approx(net.edge_length(spur))
    # on the spur itself the track alone finds it, and no junction stops the way back
    assert arrivals.switches((spur, 1)) == ((toe, 0.0, (spur, 1)),)
    assert arrivals.merge_behind_m((spur, 1)) == float("inf")


def test_a_switch_reported_past_stays_passed_beyond_a_junction(tmp_path):
    # a tram reported on the spur, then on the north line beyond the junction: the track's
    # way back from where it was reported stops at the junction, and the switch it had
    # been reported past was held at again (31 m back) when its branch's share dipped
    # (a simulated HFP log with a receiver 1 s late, seed 4)
    from antikol.positioning.branching import Arrivals, HypothesisBefore, hold_at_switch
    from antikol.positioning.placing import _released
    from antikol.positioning.records import Hypothesis

    net, toe, _, spur, north = _switch_before_a_junction(tmp_path)
    east = next(e.edge_id for e in net.edges if e.way_ids == (5,))
    arrivals = Arrivals(net)
    way = [(spur, 1), (north, 1)]
    assert arrivals.switches_behind((north, 1)) == frozenset()
    assert _released(arrivals, (north, 1), way) == {toe}
    assert _released(arrivals, (spur, 1), way) == {toe}
    assert _released(arrivals, None, way) == frozenset()
    hyps = [
        Hypothesis(north, 1, 4.0, 0.57, 0.0),
        Hypothesis(spur, 1, 19.0, 0.38, 0.0),
        Hypothesis(east, 1, 15.0, 0.05, 0.0),
    ]
    before = [HypothesisBefore(north, 1, 2.0, 0.87), HypothesisBefore(east, 1, 13.0, 0.13)]

    def held(released: frozenset[int]) -> bool:
        return (
            hold_at_switch(arrivals, hyps, north, 4.0, 1, released=released, way=way, before=before)
            is not None
        )

    assert held(arrivals.switches_behind((north, 1)))  # what it used to be given
    assert not held(_released(arrivals, (north, 1), way))


def test_a_restored_state_goes_on_as_the_original_past_a_switch(tmp_path):
    # the hold at a switch remembers where the vehicle was last reported: a state restored
    # in another process (fleet replay) carries it, and the vehicle goes on as the original
    net = trackmap.build(switch_fixture().write_xml(tmp_path / "s.osm"))
    pts = [(0.0, -200.0), (0.0, 0.0), (1.0, 10.0), (4.0, 20.0), (9.0, 30.0), (80.0, 80.0)]
    reports = reports_along(
        "V", pts, start_m=170.0, speed_mps=4.0, t=np.arange(0.0, 20.0, 1.0), frame=FRAME
    )
    for cut in range(3, len(reports) - 1):
        original = Positioner(net)
        last = drive(original, reports[: cut + 1])[-1]
        state = json.loads(json.dumps(original.state("V")))
        assert state["reported"] == [last.edge_id, last.direction]
        copy = Positioner(net)
        copy.restore("V", state)
        assert copy.state("V") == original.state("V")
        for r in reports[cut + 1 : cut + 4]:
            assert copy.update(r) == original.update(r)


@pytest.mark.parametrize("seed", [3, 4, 5, 6, 7])
def test_asking_a_position_changes_no_later_position(tmp_path, seed):
    # the switch hold remembers where the vehicle was placed at its reports, never where it
    # was asked for: the same question asked twice gets the same answer, and a positioner
    # asked ahead of time goes on as one never asked
    net = trackmap.build(switch_fixture().write_xml(tmp_path / "s.osm"))
    rng = np.random.default_rng(seed)
    reports = reports_along(
        "V", [(1.0, -200.0), (1.0, 200.0)], start_m=160.0, speed_mps=3.0,
        t=np.arange(0.0, 40.0, 1.0), frame=FRAME,
    )  # fmt: skip
    noisy = []
    for r in reports:
        x, y = FRAME.to_local(r.lon, r.lat)
        lon, lat = FRAME.to_lonlat(float(x) + rng.normal(0, 2.0), float(y) + rng.normal(0, 2.0))
        noisy.append(dataclasses.replace(r, lon=float(lon), lat=float(lat)))
    asked, quiet = Positioner(net), Positioner(net)
    for r in noisy:
        first = asked.update(r)
        asked.position("V", r.t + 15.0)  # somebody asks 15 s ahead
        assert asked.position("V", r.t) == first  # the same question again
        assert quiet.update(r) == first


@pytest.mark.parametrize("name", ["gps_sigma_m", "bias_tau_s", "standstill_evidence_s"])
@pytest.mark.parametrize("value", [0.0, -1.0])
def test_a_scale_of_the_config_must_be_positive(name, value):
    with pytest.raises(InvalidArgumentError, match=name):
        PositioningConfig(**{name: value})


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("confident_after", 0),
        ("max_hypotheses", 0),
        ("sure_probability", 1.5),
        ("gps_sigma_m", 10**400),  # an int beyond a double raised a bare OverflowError
    ],
)
def test_a_count_or_probability_of_the_config_out_of_range_is_refused(name, value):
    with pytest.raises(InvalidArgumentError, match=name):
        PositioningConfig(**{name: value})
