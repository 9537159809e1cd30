"""A vehicle that starts afresh is shown on a track once its evidence tells the track
(issue 12: windows whose positions no permitted route connects at a tram's first fixes).

Its first fix, biased toward the other direction's track, with a standing receiver's
random course, put it on that track one start in four; when it moved off, the first
fixes with a course took it across: a jump no route connects. It is now ``lost`` without
an edge until it is confident, has sent two moving reports or holds a steady standing
course; the analysis weighs its hypotheses all the while, as before.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import Analyser, VehicleReport
from antikol.errors import InvalidArgumentError
from antikol.positioning import PositioningConfig
from antikol.positioning.fleet import FleetState
from antikol.positioning.matcher import Positioner
from antikol.positioning.showing import MOVING_EXTRA_REPORTS, note_showing_evidence, shown
from tests._osm import FRAME, OsmBuilder

SPACING_M = 3.8
STAND_S = 30
AT_ONCE = PositioningConfig(show_after_moving_reports=0)


@pytest.fixture(scope="module")
def double(tmp_path_factory):
    """Two one-way tracks 2 km long: northbound at x = 0, southbound 3.8 m west."""
    b = OsmBuilder()
    b.line([(0.0, 0.0), (0.0, 2000.0)], oneway="yes")
    b.line([(-SPACING_M, 2000.0), (-SPACING_M, 0.0)], oneway="yes")
    return trackmap.build(b.write_xml(tmp_path_factory.mktemp("double") / "double.osm"))


def _start(
    bias_m: float, seed: int, *, stand_s: int = STAND_S, vid: str = "T", y0: float = 500.0
) -> list[VehicleReport]:
    """A northbound tram standing at ``y0`` for ``stand_s`` s, then departing at 1 m/s²;
    its fixes ``bias_m`` west (toward the other track), its standing course random (a
    receiver without static hold)."""
    rng = np.random.default_rng(seed)
    y, v, out = y0, 0.0, []
    for k in range(stand_s + 30):
        if k >= stand_s:
            v = min(10.0, v + 1.0)
            y += v
        lon, lat = FRAME.to_lonlat(-bias_m + rng.normal(0.0, 0.5), y + rng.normal(0.0, 0.5))
        course = float(rng.uniform(0.0, 360.0)) if v == 0.0 else float(rng.normal(0.0, 2.0))
        out.append(VehicleReport(vid, float(k), float(lat), float(lon), v, course % 360.0))
    return out


def _jumps(net, positions) -> int:
    """Successive shown positions that no permitted route connects within 30 m plus
    25 m/s of the time between them (the window rule's reach)."""
    placed = [p for p in positions if p.edge_id is not None]
    n = 0
    for p, q in itertools.pairwise(placed):
        reach_m = 30.0 + 25.0 * (q.t - p.t)
        ahead = net.route_distance(
            p.edge_id, p.offset_m, p.direction, q.edge_id, q.offset_m, cutoff_m=reach_m
        )
        back = net.route_distance(
            q.edge_id, q.offset_m, q.direction, p.edge_id, p.offset_m, cutoff_m=10.0
        )
        n += ahead is None and back is None
    return n


@pytest.mark.parametrize("stand_s", [1, 3])
def test_a_start_beside_the_other_track_is_not_shown_there_and_moved_across(double, stand_s):
    """Shown at once, some of these starts jump across when the tram moves off; shown on
    evidence, none does, and the tram is shown from its second moving report on."""
    before = after = 0
    for seed in range(16):
        reports = _start(3.0, seed, stand_s=stand_s)
        at_once = Positioner(double, AT_ONCE)
        before += _jumps(double, [at_once.update(r) for r in reports])
        pos = Positioner(double)
        out = [pos.update(r) for r in reports]
        after += _jumps(double, out)
        standing = out[:stand_s]
        assert all(p.unplaced and p.status == "lost" and p.edge_id is None for p in standing)
        assert all(p.hypotheses and p.probability > 0.0 for p in standing)
        # the raw fix, not a track's point
        assert (standing[0].lon, standing[0].lat) == (reports[0].lon, reports[0].lat)
        assert all(p.edge_id is not None for p in out[stand_s + 1 :])
    assert before > 0
    assert after == 0


def test_a_long_stand_with_a_random_course_is_shown_within_a_few_reports(double):
    within = PositioningConfig().show_within_reports
    for seed in range(4):
        reports = _start(3.0, seed)
        pos = Positioner(double)
        out = [pos.update(r) for r in reports]
        assert all(p.unplaced for p in out[: within - 1])
        assert all(not p.unplaced and p.edge_id is not None for p in out[within - 1 :])
        # without the limit: hidden for the whole stand, and never moved across
        pos = Positioner(double, PositioningConfig(show_within_reports=0))
        out = [pos.update(r) for r in reports]
        assert all(p.unplaced for p in out[:STAND_S])
        assert _jumps(double, out) == 0


def test_moving_reports_show_a_vehicle_that_appears_at_speed(double):
    """A trace cut from a service: shown by the second report at the latest."""
    pos = Positioner(double)
    out = [pos.update(r) for r in _start(3.0, 1, stand_s=0)]
    assert out[1].edge_id is not None
    assert all(p.edge_id is not None for p in out[1:])


def test_a_gap_longer_than_the_reset_starts_the_vehicle_afresh(double):
    pos = Positioner(double)
    first = _start(1.0, 2, stand_s=0)
    for r in first:
        pos.update(r)
    gap = PositioningConfig().reset_gap_s + 5.0
    later = [
        VehicleReport(r.vehicle_id, r.t + first[-1].t + gap, r.lat, r.lon, r.speed_mps,
                      r.course_deg)
        for r in _start(3.0, 3, stand_s=5)
    ]  # fmt: skip
    out = [pos.update(r) for r in later]
    assert all(p.unplaced for p in out[:3])


def test_the_analysis_weighs_a_vehicle_before_it_is_shown(double):
    """The assessments are those of positions shown at once: showing changes what is
    reported, not what is weighed."""
    own = _start(0.5, 4, stand_s=0, vid="A", y0=300.0)
    ahead = _start(3.0, 5, vid="B", y0=420.0)
    runs = []
    for config in (AT_ONCE, PositioningConfig()):
        an = Analyser(track_map=double, positioning=config)
        levels, unplaced = [], []
        for a, b in zip(own[:25], ahead[:25], strict=True):
            an.update(a)
            an.update(b)
            got = an.assess("A", t=a.t)
            levels.append((got.level, [(t.vehicle_id, t.kind, t.method) for t in got.threats]))
            unplaced.append(an.position("B").unplaced)
            assert not an.position("B", as_placed=True).unplaced
        runs.append(levels)
        assert any(unplaced) is (config is not AT_ONCE)
    assert runs[0] == runs[1]
    assert any(threats for _, threats in runs[1])  # B is seen while unplaced


def test_a_position_source_that_gives_unplaced_positions_is_weighed_too(double):
    """A source without ``placed_positions`` (its own store, say) hands the analysis the
    positions as shown: an unplaced one is weighed over its hypotheses, not by the
    sector rule."""

    class ShownOnly:
        def __init__(self) -> None:
            self.inner = Positioner(double, PositioningConfig(show_within_reports=0))

        def update_many(self, reports, *, outputs=True):
            return self.inner.update_many(reports, outputs=outputs)

        def position(self, vehicle_id, t=None):
            return self.inner.position(vehicle_id, t)

        def forget(self, vehicle_id):
            self.inner.forget(vehicle_id)

    an = Analyser(track_map=double, position_source=ShownOnly())
    own = _start(0.5, 6, stand_s=0, vid="A", y0=300.0)
    ahead = _start(3.0, 7, vid="B", y0=420.0)
    methods = set()
    for a, b in zip(own[:10], ahead[:10], strict=True):
        an.update(a)
        an.update(b)
        assert an.position("B").unplaced
        methods |= {t.method for t in an.assess("A", t=a.t).threats}
    assert methods == {"track"}


def test_state_and_restore_keep_whether_a_vehicle_is_shown(double):
    pos = Positioner(double)
    for r in _start(3.0, 8, stand_s=10)[:3]:
        pos.update(r)
    state = pos.state("T")
    again = Positioner(double)
    again.restore("T", state)
    assert again.position("T").unplaced
    # a state saved before vehicles were shown later: shown, as it was then
    del state["vehicle"]["sp"]
    again.restore("T", state)
    assert not again.position("T").unplaced


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("show_after_moving_reports", -1),
        ("show_after_steady_course_reports", -2),
        ("show_within_reports", -1),
        ("toss_shown_probability", 1.5),
        ("show_moving_probability", -0.1),
    ],
)
def test_showing_settings_are_checked(name, value):
    with pytest.raises(InvalidArgumentError, match=name):
        PositioningConfig(**{name: value})


_REPORT = st.tuples(
    st.booleans(),  # fresh
    st.one_of(st.just(float("nan")), st.floats(0.0, 20.0)),  # speed, m/s
    st.floats(0.0, 359.9),  # course, degrees
    st.floats(0.0, 1.0),  # place probability
    st.integers(0, 4),  # confident run
)


@settings(max_examples=200, deadline=None)
@given(reports=st.lists(_REPORT, min_size=1, max_size=30))
def test_a_vehicle_is_shown_exactly_when_its_evidence_since_a_fresh_start_tells(reports):
    """Against a plain count over the reports since the last fresh start."""
    c = PositioningConfig()
    fleet = FleetState(k=4)
    fleet.grow(1)
    rows = np.array([0])
    since: list[tuple[float, float, float, int]] = []
    ever = False
    for fresh, speed, course, place, run in reports:
        fleet.place[0], fleet.confident_run[0] = place, run
        note_showing_evidence(
            fleet, rows, c, fresh=np.array([fresh]), speed_mps=np.array([speed]),
            course_deg=np.array([course]),
        )  # fmt: skip
        since = [(speed, course, place, run)] if fresh else [*since, (speed, course, place, run)]
        moving = sum(not speed < c.start_course_max_speed_mps for speed, *_ in since)
        confident = any(
            p >= c.confidence and (r >= c.confident_after or p >= c.sure_probability)
            for _, _, p, r in since
        )
        steady = 0
        for k, (speed, course, _, _) in enumerate(since):
            standing = speed < c.start_course_max_speed_mps
            prev = since[k - 1] if k else None
            held = (
                standing
                and prev is not None
                and prev[0] < c.start_course_max_speed_mps
                and abs((course - prev[1] + 180.0) % 360.0 - 180.0) <= 2.0
            )
            steady = steady + 1 if held else (1 if standing else 0)
            confident |= steady >= c.show_after_steady_course_reports
        now_moving = not since[-1][0] < c.start_course_max_speed_mps
        ever = (
            (not fresh and ever)
            or confident
            or (moving >= c.show_after_moving_reports and place >= c.show_moving_probability)
        )
        limit = c.show_within_reports + (MOVING_EXTRA_REPORTS if now_moving else 0)
        ever |= len(since) >= limit
        assert bool(shown(fleet, rows)[0]) == ever


@pytest.fixture(scope="module")
def facing_switch(tmp_path_factory):
    """A trunk running north to a facing switch at y = 500 m: branch A straight on,
    branch B bearing away to the east (7 m off A 70 m past the switch)."""
    b = OsmBuilder()
    switch = b.node(0.0, 500.0)
    b.line([(0.0, 0.0), switch], oneway="yes")
    b.line([switch, (0.0, 1500.0)], oneway="yes")
    b.line([switch, (10.0, 600.0), (60.0, 800.0)], oneway="yes")
    return trackmap.build(b.write_xml(tmp_path_factory.mktemp("switch") / "switch.osm"))


def _on_branch(run_m: float, branch: str) -> tuple[float, float, float]:
    """(x, y, course in degrees) ``run_m`` along the trunk and then branch A or B."""
    if branch == "A" or run_m <= 500.0:
        return 0.0, run_m, 0.0
    legs = [((0.0, 500.0), (10.0, 600.0)), ((10.0, 600.0), (60.0, 800.0))]
    left = run_m - 500.0
    for (x0, y0), (x1, y1) in legs:
        length = math.hypot(x1 - x0, y1 - y0)
        if left <= length or (x1, y1) == legs[-1][1]:
            f = left / length
            course = math.degrees(math.atan2(x1 - x0, y1 - y0))
            return x0 + f * (x1 - x0), y0 + f * (y1 - y0), course
        left -= length
    raise AssertionError("unreachable")  # pragma: no cover


def _through_an_outage(net, seed: int, config: PositioningConfig, branch: str = "A") -> list[tuple]:
    """A tram running on to ``branch`` at 10 m/s that loses its fix 10 m before the
    switch for 8 s: (shown, placed, in the outage) at each report."""
    rng = np.random.default_rng(seed)
    pos = Positioner(net, config)
    out, last = [], None
    for k in range(70):
        x, y, course = _on_branch(10.0 * k, branch)
        outage = 49 <= k < 57
        if not outage:
            last = FRAME.to_lonlat(x + rng.normal(0.0, 0.7), y + rng.normal(0.0, 0.7))
        lon, lat = last
        report = VehicleReport(
            "T", float(k), float(lat), float(lon), 10.0,
            float(course + rng.normal(0.0, 1.0)) % 360.0, fix_quality=0 if outage else 1,
        )  # fmt: skip
        shown_as = pos.update(report)
        out.append((shown_as, pos.placed_positions(["T"])[0], outage))
    return out


@pytest.mark.parametrize("branch", ["A", "B"])
@pytest.mark.parametrize("seed", range(3))
def test_a_coin_toss_past_a_switch_in_an_outage_is_not_shown(facing_switch, seed, branch):
    """Without a fix the tram's hypotheses split evenly over the branches; past the 40-m
    hold it was shown on one of them, and moved across when the fix came back on the other
    (``toss_shown_probability`` 0). It is not shown from there until a fix tells the
    branch, and no shown position jumps."""
    net = facing_switch
    run = _through_an_outage(net, seed, PositioningConfig(), branch)
    beyond = [(s, p) for s, p, outage in run if outage and s.edge_id != p.edge_id]
    # the outage ran the tram 70 m past the switch: beyond the hold, a coin toss
    assert beyond and all(s.unplaced and p.probability == pytest.approx(0.5) for s, p in beyond)
    assert _jumps(net, [s for s, _, _ in run]) == 0
    assert run[-1][0].status == "confident"
    # shown as placed: on a branch at 0.5, the wrong one for some seeds
    shown_all = _through_an_outage(net, seed, PositioningConfig(toss_shown_probability=0.0), branch)
    assert all(s == p for s, p, _ in shown_all)


def test_coin_tosses_shown_on_the_wrong_branch_jump_when_the_fix_comes_back(facing_switch):
    jumps = sum(
        _jumps(facing_switch, [s for s, _, _ in _through_an_outage(
            facing_switch, seed, PositioningConfig(toss_shown_probability=0.0), branch)])
        for seed in range(3) for branch in "AB"
    )  # fmt: skip
    assert jumps > 0


def _slow_departure(bias_m: float, seed: int) -> list[VehicleReport]:
    """A northbound tram that stands one report, its fixes ``bias_m`` west (on the other
    direction's track), then moves off: 1.7 m/s at its second report, 1.2 m/s² on, with a
    course good to a few degrees."""
    rng = np.random.default_rng(seed)
    y, v, out = 500.0, 0.0, []
    for k in range(25):
        if k:
            v = 1.7 if k == 1 else min(8.0, v + 1.2)
            y += v
        lon, lat = FRAME.to_lonlat(-bias_m + rng.normal(0.0, 0.3), y + rng.normal(0.0, 0.3))
        course = float(rng.uniform(0.0, 360.0)) if v == 0.0 else float(rng.normal(0.0, 4.0))
        out.append(VehicleReport("T", float(k), float(lat), float(lon), v, course % 360.0))
    return out


def test_a_slow_departure_is_placed_by_its_course_below_two_metres_a_second(double):
    """The course weighs from 1.5 m/s (``min_speed_for_course_mps``): a tram whose first
    fixes lie on or beyond the other direction's track is not shown there while it moves
    off below 2 m/s (with 2 m/s, 2 of these 48 starts were, and jumped across)."""
    for bias_m, seed in itertools.product((SPACING_M, 5.0, 6.0), range(16)):
        pos = Positioner(double)
        out = [pos.update(r) for r in _slow_departure(bias_m, seed)]
        shown_at = [p for p in out if p.edge_id is not None]
        assert len(shown_at) >= len(out) - 3
        assert all(abs((p.heading_deg + 180.0) % 360.0 - 180.0) < 45.0 for p in shown_at)
        assert _jumps(double, out) == 0
