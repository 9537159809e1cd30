"""The paper's sector points along a course the vehicle's own run confirms (issue 12).

The sector rule (no map, or a vehicle the map cannot place) looked along the reported
course. A feed that reports a bidirectional tram's heading of its other end made it look
behind the tram, one that sends 0 for "no heading" made it look north: on the simulator's
street fleet the paper's rule then missed every required warning of the city scenario.
The course it keeps is now checked against the chords of the vehicle's own fixes.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from antikol import Analyser, VehicleReport
from antikol.analysis.coursekeeper import CourseKeeper
from antikol.positioning import PositioningConfig
from antikol.positioning.coursecheck import CourseUse
from tests._paths import GDANSK


def _report(vid: str, t: float, x: float, y: float, speed: float, course: float) -> VehicleReport:
    lon, lat = GDANSK.to_lonlat(x, y)
    return VehicleReport(vid, float(t), float(lat), float(lon), float(speed), course % 360.0)


def _run(heading_deg: float, speed: float, n: int, *, x0: float = 0.0, y0: float = 0.0):
    """(t, x, y) at 1 Hz of a straight run, m."""
    h = math.radians(heading_deg)
    return [(s, x0 + speed * s * math.sin(h), y0 + speed * s * math.cos(h)) for s in range(n)]


@settings(max_examples=40, deadline=None)
@given(
    heading=st.floats(0.0, 360.0),
    speed=st.floats(3.0, 20.0),
    bias=st.tuples(st.floats(-8.0, 8.0), st.floats(-8.0, 8.0)),
    noise=st.lists(st.floats(-3.0, 3.0), min_size=60, max_size=60),
)
def test_a_right_course_is_kept_as_reported(heading, speed, bias, noise):
    keeper = CourseKeeper()
    for t, x, y in _run(heading, speed, 30):
        report = _report(
            "T", t, x + bias[0] + 0.3 * noise[2 * t + 1], y + bias[1], speed, heading + noise[2 * t]
        )
        assert keeper.update(report) == report.course_deg
    assert keeper.use("T") == CourseUse.UNTESTED


@pytest.mark.parametrize("heading", [0.0, 75.0, 200.0])
def test_a_reversed_course_is_turned_round_and_one_stuck_at_0_replaced_by_the_run(heading):
    keeper = CourseKeeper()
    kept_reversed = [keeper.update(_report("R", t, x, y, 10.0, heading + 180.0))
                     for t, x, y in _run(heading, 10.0, 12)]  # fmt: skip
    assert keeper.use("R") == CourseUse.TURNED
    assert all(abs((k - heading + 180) % 360 - 180) < 1e-6 for k in kept_reversed[5:])
    kept_zero = [keeper.update(_report("Z", t, x, y, 10.0, 0.0))
                 for t, x, y in _run(heading + 60.0, 10.0, 12)]  # fmt: skip
    assert keeper.use("Z") == CourseUse.IGNORED
    # the course made good: the bearing of the newest chord, here exact
    assert all(abs((k - heading - 60) % 360 - 180) > 179 for k in kept_zero[6:])


def test_a_standing_vehicle_keeps_the_course_it_was_moving_on():
    keeper = CourseKeeper()
    run = _run(90.0, 10.0, 10)
    for t, x, y in run:
        keeper.update(_report("R", t, x, y, 10.0, 270.0))  # reversed
    _, x, y = run[-1]
    for t in range(10, 30):  # stands: its course is noise, and not tested
        kept = keeper.update(_report("R", t, x, y, 0.0, 37.0 * t))
    assert kept == pytest.approx(90.0)
    assert keeper.use("R") == CourseUse.TURNED


def test_the_check_can_be_switched_off():
    keeper = CourseKeeper(config=PositioningConfig(course_check=0))
    for t, x, y in _run(90.0, 10.0, 12):
        kept = keeper.update(_report("R", t, x, y, 10.0, 270.0))
    assert kept == 270.0
    assert keeper.use("R") == CourseUse.UNTESTED


def test_a_forgotten_vehicles_row_starts_afresh_for_the_next():
    keeper = CourseKeeper()
    for t, x, y in _run(90.0, 10.0, 12):
        keeper.update(_report("R", t, x, y, 10.0, 270.0))
    keeper.forget("R")
    assert keeper.course("R") is None and keeper.use("R") == CourseUse.UNTESTED
    for t, x, y in _run(0.0, 10.0, 3, x0=5000.0):  # reuses the row, far away
        kept = keeper.update(_report("N", 100 + t, x, y, 10.0, 0.0))
    assert kept == 0.0 and keeper.use("N") == CourseUse.UNTESTED


def _leader_ahead(course_fault: float, check: int = 1) -> list[str]:
    """A map-less analyser: tram A runs north at 10 m/s reporting its course plus
    ``course_fault``; tram B stands 150 m ahead of A's last fix. The kinds of A's threats
    at each second."""
    an = Analyser(None, positioning=PositioningConfig(course_check=check))
    kinds = []
    run = _run(0.0, 10.0, 12)
    for t, x, y in run:
        an.update(_report("A", t, x, y, 10.0, course_fault))
        an.update(_report("B", t, 0.0, run[-1][2] + 150.0, 0.0, 0.0))
        kinds.append(",".join(sorted(th.vehicle_id for th in an.assess("A", t=t).threats)))
    return kinds


def test_the_papers_sector_sees_ahead_of_a_tram_whose_course_is_reported_reversed():
    assert _leader_ahead(0.0)[-1] == "B"
    assert _leader_ahead(180.0)[-4:] == ["B"] * 4
    # unchecked, as before, the sector looks behind the tram: it never sees B
    assert _leader_ahead(180.0, check=0) == [""] * 12


def test_the_closing_speed_takes_the_others_course_as_checked():
    # A runs north at 10 m/s; B comes south at 8 m/s, its course reported reversed (north)
    an = Analyser(None)
    for t, x, y in _run(0.0, 10.0, 12):
        an.update(_report("A", t, x, y, 10.0, 0.0))
        an.update(_report("B", t, 0.0, 250.0 - 8.0 * t, 8.0, 0.0))
    (threat,) = an.assess("A", t=11.0).threats
    assert threat.closing_speed_mps == pytest.approx(18.0, abs=0.5)
    assert an.courses.use("B") == CourseUse.TURNED


@settings(max_examples=30, deadline=None)
@given(
    headings=st.lists(st.floats(0.0, 360.0), min_size=3, max_size=3),
    faults=st.lists(st.sampled_from([0.0, 180.0, None]), min_size=3, max_size=3),
    batch=st.integers(1, 7),
)
def test_reports_checked_in_batches_keep_the_courses_of_reports_checked_one_by_one(
    headings, faults, batch
):
    streams = []
    for k, (heading, fault) in enumerate(zip(headings, faults, strict=True)):
        for t, x, y in _run(heading, 8.0 + k, 20, x0=300.0 * k):
            course = 0.0 if fault is None else heading + fault
            streams.append(_report(f"V{k}", t, x, y, 8.0 + k, course))
    streams.sort(key=lambda r: r.t)
    one, many = CourseKeeper(), CourseKeeper()
    for i, r in enumerate(streams):
        one.update(r)
        many.add(r)
        if i % batch == batch - 1:  # several reports of one vehicle in a batch, too
            assert [many.course(f"V{k}") for k in range(3)] == [
                one.course(f"V{k}") for k in range(3)
            ]
    assert [many.use(f"V{k}") for k in range(3)] == [one.use(f"V{k}") for k in range(3)]


@settings(max_examples=60, deadline=None)
@given(
    rows=st.lists(
        st.tuples(
            st.sampled_from(["A", "B", "C"]),
            st.floats(-5.0, 100.0),  # times in any order, repeated too
            st.floats(-89.9, 89.9),
            st.floats(-180.0, 180.0),
            st.floats(0.0, 100.0),
            st.floats(0.0, 359.999),
        ),
        max_size=40,
    ),
    batch=st.integers(1, 5),
)
def test_any_reports_keep_a_course_in_range_or_none(rows, batch):
    keeper = CourseKeeper()
    for i, (vid, t, lat, lon, speed, course) in enumerate(rows):
        keeper.add(VehicleReport(vid, t, lat, lon, speed, course))
        if i % batch == 0:
            for v in ("A", "B", "C"):
                kept = keeper.course(v)
                assert kept is None or 0.0 <= kept < 360.0
        if i % 7 == 6:
            keeper.forget(vid)
