"""Positions in hindsight (antikol.positioning.hindsight): the best connected path through
a log's track hypotheses."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely import LineString

from antikol.errors import InvalidArgumentError
from antikol.evaluation.consistency import disconnected_windows, in_hindsight, match_reports
from antikol.positioning.hindsight import hindsight_positions, reach_m, track_step_m
from antikol.positioning.matcher import Positioner
from antikol.positioning.records import Hypothesis, TrackPosition
from antikol.report import VehicleReport
from trackmap.synthetic import SyntheticNetwork

# a facing switch at x = 100 m: the main track runs on east, the branch beside it (4 m
# north) for 120 m before it turns away north
BRANCH = [(100.0, 0.0), (130.0, 4.0), (250.0, 4.0), (290.0, 30.0), (310.0, 100.0)]


@pytest.fixture(scope="module")
def branch_map():
    board = SyntheticNetwork()
    board.track([(0.0, 0.0), (100.0, 0.0)], oneway="yes")
    board.track([(100.0, 0.0), (700.0, 0.0)], oneway="yes")
    board.track(BRANCH, oneway="yes")
    return board, board.build()


def _edge_at(board, net, x: float, y: float) -> int:
    """The edge nearest a point of the drawing (m)."""
    return net.candidates(*board.lonlat(x, y), radius_m=10.0)[0].edge_id


def _branch_run(board, *, bias_north_m: float, course_deg: float | None):
    """A tram taking the branch at 8 m/s with its odometer, its fixes ``bias_north_m`` off
    (south when negative) while the branch runs beside the main track, its course there
    ``course_deg`` (None: the true one)."""
    route = LineString([(0.0, 0.0), *BRANCH[1:]])
    reports, truth = [], []
    for t in range(40):
        s = 20.0 + 8.0 * t
        p = route.interpolate(s)
        a, b = route.interpolate(max(s - 1.0, 0.0)), route.interpolate(s + 1.0)
        heading = (90.0 - math.degrees(math.atan2(b.y - a.y, b.x - a.x))) % 360.0
        beside = 110.0 < p.x < 260.0
        course = course_deg if beside and course_deg is not None else heading
        lon, lat = board.lonlat(p.x, p.y + (bias_north_m if beside else 0.0))
        reports.append(
            VehicleReport("T1", float(t), lat, lon, speed_mps=8.0, course_deg=course, odometer_m=s)
        )
        truth.append((p.x, p.y))
    return reports, truth


def test_a_branch_told_only_later_is_the_whole_way_in_hindsight(branch_map):
    board, net = branch_map
    # the fixes lie 3 m south, 1 m from the main track; the course reads straight on
    reports, truth = _branch_run(board, bias_north_m=-3.0, course_deg=90.0)
    online = match_reports(net, reports)
    later = in_hindsight(net, online)
    branch = _edge_at(board, net, 200.0, 4.0)
    past_switch = [k for k, (x, _) in enumerate(truth) if 120.0 < x < 250.0]
    # online, the tram is shown on the main track until the branch turns away ...
    assert sum(online[k].edge_id != branch for k in past_switch) >= 5
    # ... in hindsight on the branch all along, and every window connected
    assert [later[k].edge_id for k in past_switch] == [branch] * len(past_switch)
    assert disconnected_windows(net, later)[1] == 0
    assert disconnected_windows(net, online)[1] >= 1
    assert all(later[k].position.status == "confident" for k in past_switch[3:])


def test_hindsight_keeps_what_online_had_right(branch_map):
    board, net = branch_map
    reports, truth = _branch_run(board, bias_north_m=0.0, course_deg=None)
    online = match_reports(net, reports)
    later = in_hindsight(net, online)
    for a, b, (x, y) in zip(online, later, truth, strict=True):
        assert b.matched
        if a.matched and a.edge_id == _edge_at(board, net, x, y):
            assert (b.edge_id, b.direction) == (a.edge_id, a.direction)
            assert b.offset_m == pytest.approx(a.offset_m)
    assert disconnected_windows(net, later)[1] == 0


def test_a_vehicle_not_shown_yet_is_placed_in_hindsight(branch_map):
    board, net = branch_map
    reports = []
    for t in range(12):
        lon, lat = board.lonlat(400.0 + 6.0 * t, 0.5)
        reports.append(VehicleReport("T2", float(t), lat, lon, speed_mps=6.0, course_deg=90.0))
    pos = Positioner(net)
    online = [pos.update(r) for r in reports]
    # as the positioner gives a vehicle whose first fixes did not tell its track yet
    hidden = [
        replace(p, status="lost", edge_id=None, direction=None, offset_m=None) for p in online[:4]
    ]
    assert all(p.unplaced for p in hidden)
    later = hindsight_positions(net, reports, hidden + online[4:])
    main = _edge_at(board, net, 400.0, 0.0)
    assert all(p.edge_id == main and p.matched for p in later)
    assert [p.offset_m for p in later[4:]] == [p.offset_m for p in online[4:]]


def test_reports_and_positions_must_pair_up(branch_map):
    _, net = branch_map
    with pytest.raises(ValueError, match="one position per report"):
        hindsight_positions(net, [], [_position(net, 0.0, ())])


def test_each_vehicles_reports_must_come_in_time_order(branch_map):
    board, net = branch_map
    lon, lat = board.lonlat(400.0, 0.0)
    reports = [
        VehicleReport(v, t, lat, lon, speed_mps=0.0, course_deg=90.0)
        for v, t in (("T1", 5.0), ("T2", 1.0), ("T1", 5.0), ("T1", 4.0))
    ]
    positions = [replace(_position(net, r.t, ()), vehicle_id=r.vehicle_id) for r in reports]
    with pytest.raises(InvalidArgumentError, match=r"report 3 of 'T1'.*time order"):
        hindsight_positions(net, reports, positions)
    # the same time twice, and another vehicle's earlier report between, are in order
    assert hindsight_positions(net, reports[:3], positions[:3]) == positions[:3]


def test_a_report_without_hypotheses_keeps_its_online_position(branch_map):
    _, net = branch_map
    report = VehicleReport("T3", 0.0, 54.39, 18.64, 0.0, 0.0)
    lost = _position(net, 0.0, ())
    assert hindsight_positions(net, [report], [lost]) == [lost]


@settings(max_examples=40, deadline=None)
@given(p_first=st.floats(0.51, 0.99), first_on_branch=st.booleans())
def test_a_position_held_at_a_switch_and_its_hypothesis_are_one(
    branch_map, p_first, first_on_branch
):
    """A position held at the switch behind it stands for its first hypothesis, as does
    that hypothesis' own place past the switch: together they outweigh a second hypothesis
    with less probability (each alone has half; the second won when above the half)."""
    board, net = branch_map
    approach = _edge_at(board, net, 50.0, 0.0)
    main, branch = _edge_at(board, net, 300.0, 0.0), _edge_at(board, net, 200.0, 4.0)
    first, second = (branch, main) if first_on_branch else (main, branch)
    hyps = (
        Hypothesis(first, 1, 10.0, p_first, 10.0),
        Hypothesis(second, 1, 10.0, 1 - p_first, 10.0),
    )
    lon, lat = board.lonlat(110.0, 2.0)
    report = VehicleReport("T9", 0.0, lat, lon, speed_mps=5.0, course_deg=90.0)
    held = replace(
        _position(net, 0.0, hyps), edge_id=approach, direction=1, offset_m=net.edge_length(approach)
    )
    later = hindsight_positions(net, [report], [held])[0]
    assert later.edge_id in (approach, first)
    assert later.probability == pytest.approx(p_first)


def _position(net, t: float, hyps: tuple[Hypothesis, ...], *, shown: bool = True):
    first = hyps[0] if hyps else None
    return TrackPosition(
        "T9",
        t,
        "ambiguous" if first and shown else ("lost" if first else "unmatched"),
        first.edge_id if first and shown else None,
        first.direction if first and shown else None,
        first.offset_m if first and shown else None,
        18.64,
        54.39,
        None,
        8.0,
        first.probability if first else 0.0,
        None,
        hypotheses=hyps,
    )


def _assert_a_connected_path(net, later) -> None:
    """Successive places are connected by a permitted move; probabilities in [0, 1]."""
    for a, b in itertools.pairwise(later):
        step = track_step_m(
            net,
            (a.edge_id, a.offset_m, a.direction),
            (b.edge_id, b.offset_m, b.direction),
            cutoff_m=reach_m(b.t - a.t),
        )
        assert step is not None
    assert all(0.0 <= p.probability <= 1.0 for p in later)


@settings(max_examples=60, deadline=None)
@given(
    shares=st.lists(
        st.tuples(st.floats(0.01, 1.0), st.floats(0.01, 1.0), st.booleans()),
        min_size=2,
        max_size=25,
    )
)
def test_the_path_is_connected_wherever_the_hypotheses_connect(branch_map, shares):
    """Whatever the online probabilities of the two branches, successive places on the
    hindsight path are connected by a permitted move (every hypothesis on either branch
    descends from the one before on it)."""
    board, net = branch_map
    main, branch = _edge_at(board, net, 200.0, 0.0), _edge_at(board, net, 200.0, 4.0)
    reports, positions = [], []
    for k, (p_main, p_branch, main_first) in enumerate(shares):
        offset = 5.0 + 4.0 * k
        lon, lat = board.lonlat(100.0 + offset, 2.0)
        reports.append(VehicleReport("T9", float(k), lat, lon, speed_mps=4.0, course_deg=90.0))
        total = p_main + p_branch
        hyps = [
            Hypothesis(main, 1, offset, p_main / total, offset),
            Hypothesis(branch, 1, offset, p_branch / total, offset),
        ]
        positions.append(_position(net, float(k), tuple(hyps if main_first else hyps[::-1])))
    later = hindsight_positions(net, reports, positions)
    assert len({p.edge_id for p in later}) == 1  # the two branches never meet again
    _assert_a_connected_path(net, later)


@settings(max_examples=60, deadline=None)
@given(
    shares=st.lists(st.floats(0.01, 0.99), min_size=3, max_size=20),
    gap=st.tuples(st.integers(1, 18), st.integers(1, 6)),
)
def test_a_track_the_hypotheses_lost_for_a_while_is_bridged(branch_map, shares, gap):
    """Reports at which online kept only the main track's hypothesis, after reports that
    kept both (the branch's was dropped and taken up again afresh), are bridged along the
    branch when the path takes it: the path stays connected, every probability in [0, 1]."""
    board, net = branch_map
    main, branch = _edge_at(board, net, 200.0, 0.0), _edge_at(board, net, 200.0, 4.0)
    first, length = gap
    reports, positions = [], []
    for k, p_branch in enumerate(shares):
        offset = 5.0 + 4.0 * k
        lon, lat = board.lonlat(100.0 + offset, 2.0)
        reports.append(
            VehicleReport(
                "T9", float(k), lat, lon, speed_mps=4.0, course_deg=90.0, odometer_m=4.0 * k
            )
        )
        if first <= k < first + length:
            hyps = (Hypothesis(main, 1, offset, 1.0, offset),)
        else:
            hyps = (
                Hypothesis(branch, 1, offset, p_branch, offset),
                Hypothesis(main, 1, offset, 1.0 - p_branch, offset),
            )
        positions.append(_position(net, float(k), hyps))
    later = hindsight_positions(net, reports, positions)
    _assert_a_connected_path(net, later)
    if later[-1].edge_id == branch:
        assert all(p.edge_id == branch for p in later)
