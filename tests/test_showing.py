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
from antikol.positioning.showing import note_showing_evidence, shown
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
    """Successive shown positions that no permitted route within 60 m connects."""
    placed = [p for p in positions if p.edge_id is not None]
    n = 0
    for p, q in itertools.pairwise(placed):
        ahead = net.route_distance(
            p.edge_id, p.offset_m, p.direction, q.edge_id, q.offset_m, cutoff_m=60.0
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
        ever = (not fresh and ever) or confident or moving >= c.show_after_moving_reports
        ever |= len(since) >= c.show_within_reports
        assert bool(shown(fleet, rows)[0]) == ever
