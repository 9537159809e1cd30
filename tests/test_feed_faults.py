"""Faults of a feed that no field flags (issue 12: real feeds).

An operator's feed keeps sending the last position when the receiver has no fix, with no
field to say so, and may report the distance run since the start of the trip (back to 0
at every trip). :mod:`antikol.positioning.feedfaults` recognises both; the
:class:`Positioner` dead-reckons over the repeats and runs the reset step on the speeds.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import trackmap
from antikol import VehicleReport
from antikol.positioning import Positioner
from antikol.positioning.feedfaults import (
    ODOMETER_BACK_M,
    odometer_glitches,
    odometer_resets,
    stale_fixes,
)
from antikol.positioning.fleet import FleetState
from tests._osm import FRAME, STRAIGHT_LINE, straight_fixture
from tests._paths import reports_along

_RUN_M = 2.0


def _one(now: VehicleReport, before: VehicleReport | None, *, t_fix: float, odo_fix: float):
    # the vehicle's state as the positioner keeps it: its last fix and speed before
    fleet = FleetState(k=1)
    fleet.grow(1)
    rows = np.array([0])
    fleet.t_fix[0], fleet.odo_fix[0] = t_fix, odo_fix
    fleet.v[0] = 0.0 if before is None else before.speed_mps
    speed = np.array([now.speed_mps])
    odometer = np.array([math.nan if now.odometer_m is None else now.odometer_m])
    ran = fleet.run_since_fix(rows, np.array([now.t]), speed, odometer)
    return bool(
        stale_fixes(np.array([now.lat]), np.array([now.lon]), [before], ran, run_m=_RUN_M)[0]
    )


_coord = st.floats(min_value=-80.0, max_value=80.0, allow_nan=False)
_speed = st.floats(min_value=0.0, max_value=25.0, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(
    lat=_coord,
    lon=_coord,
    run=st.floats(min_value=0.0, max_value=500.0, allow_nan=False),
    dt=st.floats(min_value=0.1, max_value=30.0, allow_nan=False),
    speed=_speed,
    with_odometer=st.booleans(),
)
# (20 m/s over 100.1 - 100.0 s is 1.9999... m: short of the 2 m, as the times give it)
@example(lat=0.0, lon=0.0, run=0.0, dt=0.1, speed=20.0, with_odometer=False)
def test_a_repeated_position_is_stale_exactly_when_the_vehicle_ran_on(
    lat, lon, run, dt, speed, with_odometer
):
    odo_fix = 1000.0 if with_odometer else math.nan
    before = VehicleReport(
        "V", 100.0, lat, lon, speed, 0.0, odometer_m=odo_fix if with_odometer else None
    )
    now = dataclasses.replace(
        before, t=100.0 + dt, odometer_m=1000.0 + run if with_odometer else None
    )
    # (the run as the readings give it, rounding and all: the odometer's difference, or
    # the speed over the difference of the report times)
    ran = (1000.0 + run) - 1000.0 if with_odometer else speed * ((100.0 + dt) - 100.0)
    assert _one(now, before, t_fix=100.0, odo_fix=odo_fix) == (ran >= _RUN_M)


@settings(max_examples=200, deadline=None)
@given(lat=_coord, lon=_coord, dlat=_coord, dlon=_coord, speed=_speed)
def test_a_new_position_never_is_stale(lat, lon, dlat, dlon, speed):
    before = VehicleReport("V", 100.0, lat, lon, speed, 0.0, odometer_m=1000.0)
    now = VehicleReport(
        "V", 101.0, lat + dlat * 1e-6, lon + dlon * 1e-6, speed, 0.0, odometer_m=1500.0
    )
    if (now.lat, now.lon) == (lat, lon):
        return  # the nudge vanished in rounding: that is a repeat
    assert not _one(now, before, t_fix=100.0, odo_fix=1000.0)


@settings(max_examples=200, deadline=None)
@given(
    before=st.one_of(st.just(math.nan), st.floats(0.0, 1e7)),
    change=st.floats(-1e7, 1e7),
    missing=st.booleans(),
)
def test_an_odometer_reset_is_a_reading_that_went_back(before, change, missing):
    now = math.nan if missing else before + change
    got = bool(odometer_resets(np.array([now]), np.array([before]))[0])
    assert got == (now <= before - ODOMETER_BACK_M)  # (False where either is NaN)


def test_no_previous_report_or_no_fix_yet_is_not_stale():
    r = VehicleReport("V", 100.0, 50.0, 20.0, 10.0, 0.0, odometer_m=1000.0)
    assert not _one(r, None, t_fix=math.nan, odo_fix=math.nan)
    later = dataclasses.replace(r, t=110.0, odometer_m=1100.0)
    assert not _one(later, r, t_fix=math.nan, odo_fix=math.nan)


# -- the positioner --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    return trackmap.build(straight_fixture().write_xml(tmp_path_factory.mktemp("s") / "s.osm"))


def _frozen_run(*, speed: float, odometer: bool, freeze: range) -> list[VehicleReport]:
    t = np.arange(0.0, 30.0, 1.0)
    reports = reports_along("V", STRAIGHT_LINE, start_m=100.0, speed_mps=speed, t=t, frame=FRAME)
    reports = [
        dataclasses.replace(r, odometer_m=5000.0 + speed * r.t if odometer else None)
        for r in reports
    ]
    held = reports[freeze.start - 1]
    for k in freeze:
        reports[k] = dataclasses.replace(reports[k], lat=held.lat, lon=held.lon)
    return reports


def _followed(net, reports: list[VehicleReport], speed: float) -> Positioner:
    """Position the reports of a tram running from 100 m at ``speed`` (m/s), one a
    second; every position must be confident and within 3 m of the truth."""
    pos = Positioner(net)
    for k, r in enumerate(reports):
        p = pos.update(r)
        assert p.status == "confident", k
        assert p.offset_m == pytest.approx(100.0 + speed * k, abs=3.0), k
    return pos


@pytest.mark.parametrize("odometer", [True, False])
def test_a_frozen_position_does_not_pull_a_running_tram_back(straight, odometer):
    # eight reports repeat the last fix while the tram runs on at 10 m/s: it used to be
    # reported 40-80 m behind, confident, then jump forward when the fixes came back
    speed = 10.0
    reports = _frozen_run(speed=speed, odometer=odometer, freeze=range(10, 18))
    pos = _followed(straight, reports, speed)
    assert pos.stats["stale_fix"] == 8
    assert pos.stats["reset_after_rejections"] == 0


def test_a_standing_tram_whose_receiver_holds_its_position_stays_matched(straight):
    # a receiver's static hold: the same coordinates for a minute while the tram stands
    t = np.arange(0.0, 70.0, 1.0)
    moving = reports_along("V", STRAIGHT_LINE, start_m=100.0, speed_mps=5.0, t=t[:5], frame=FRAME)
    last = moving[-1]
    standing = [
        dataclasses.replace(last, t=float(s), speed_mps=0.0, odometer_m=5020.0) for s in t[5:]
    ]
    reports = [dataclasses.replace(r, odometer_m=5000.0 + 5.0 * r.t) for r in moving] + standing
    pos = Positioner(straight)
    out = [pos.update(r) for r in reports]
    assert pos.stats["stale_fix"] == 0
    assert out[-1].status == "confident"
    assert out[-1].offset_m == pytest.approx(120.0, abs=3.0)


def test_the_run_by_speeds_adds_up_every_report_since_the_fix():
    # 10 m/s for 30 s, then 30 s at a standstill: 300 m by the speeds report by report;
    # one mean of the last fix's speed and the current one over the whole time said 300 m
    # or 0 m depending on the instant, and the gate below 1 m/s said nothing had run
    fleet = FleetState(k=1)
    fleet.grow(1)
    rows = np.array([0])
    fleet.t_fix[0], fleet.v[0] = 0.0, 10.0
    for t in range(1, 61):
        fleet.note_run_without_fix(0, float(t), 10.0 if t <= 30 else 0.0)
    ran = fleet.run_since_fix(rows, np.array([61.0]), np.array([0.0]), np.array([math.nan]))
    assert ran.distance_m[0] == pytest.approx(305.0)  # (the 30th-31st second: 5 m)
    assert not ran.by_odometer[0]
    fleet.note_fix(rows)
    fleet.t_fix[0], fleet.v[0] = 61.0, 0.0
    again = fleet.run_since_fix(rows, np.array([62.0]), np.array([0.0]), np.array([math.nan]))
    assert again.distance_m[0] == 0.0


def test_a_position_frozen_at_a_tunnel_portal_is_no_fix_when_the_tram_stops_inside(straight):
    # a feed without a fix-quality field or an odometer repeats the last position through
    # a tunnel; the tram runs 300 m on, then stands at an underground stop. Taken as a fix
    # once the speed fell under 1 m/s, the frozen position put the tram back at the portal,
    # confident, for the whole stop (Krakow's tunnel, the urban receiver seen through such
    # a feed: 72 confident estimates on the wrong place)
    speed = 10.0
    t = np.arange(0.0, 100.0, 1.0)
    truth = np.clip(100.0 + speed * t, None, 500.0) + speed * np.clip(t - 70.0, 0.0, None)
    reports = reports_along("V", STRAIGHT_LINE, start_m=100.0, speed_mps=speed, t=t, frame=FRAME)
    frozen = reports[9]
    for k in range(10, 70):  # the portal at t = 9 s; the stop from t = 40 s to 70 s
        reports[k] = dataclasses.replace(
            frozen, t=float(t[k]), speed_mps=speed if t[k] < 40.0 else 0.0
        )
    out_again = reports_along(
        "V", STRAIGHT_LINE, start_m=500.0, speed_mps=speed, t=t[70:] - 70.0, frame=FRAME
    )
    reports[70:] = [dataclasses.replace(r, t=r.t + 70.0) for r in out_again]
    pos = Positioner(straight)
    for k, r in enumerate(reports):
        p = pos.update(r)
        if p.status == "confident":
            assert p.offset_m == pytest.approx(truth[k], abs=15.0), (k, p)
        if k == 69:  # no fix for a minute, no odometer: carried on the reported speeds
            assert p.status != "lost"
            assert p.offset_m == pytest.approx(truth[k], abs=15.0)
    # (the reported speed drops from 10 m/s to 0 in a second, and back at the first fix:
    # carried on the speeds, the tram's speed is current, and physics rejects those jumps)
    assert pos.stats["stale_fix"] >= 58
    assert p.status == "confident"  # the fixes came back


@pytest.mark.parametrize("outage", [False, True])
def test_an_odometer_reset_to_zero_at_a_new_trip_leaves_the_position_where_it_is(straight, outage):
    # the feed's odometer counts from the start of the trip: 5100 m, then 3 m a second
    # later at 10 m/s; taken at face value the step was a standstill and the tram was
    # reported ~9 m behind, confident, for half a minute (with the tunnel after it, all
    # the way through)
    speed = 10.0
    t = np.arange(0.0, 40.0, 1.0)
    reports = reports_along("V", STRAIGHT_LINE, start_m=100.0, speed_mps=speed, t=t, frame=FRAME)
    reports = [
        dataclasses.replace(
            r,
            odometer_m=5000.0 + speed * r.t if r.t < 10.0 else 3.0 + speed * (r.t - 10.0),
            fix_quality=0 if outage and 12 <= k < 27 else 1,
        )
        for k, r in enumerate(reports)
    ]
    pos = _followed(straight, reports, speed)
    assert pos.stats["odometer_reset"] == 1


def test_a_late_report_rejected_for_its_time_keeps_the_odometer_baseline(straight):
    # an archive delivered a message late: its time and odometer are behind the last
    # report's. It is rejected for its time; its odometer once counted as a reset and
    # wiped the baseline, so the first report of the tunnel after it was not carried on
    # the odometer and the tram was reported a step (10 m) behind until the next fix
    speed = 10.0
    t = np.arange(0.0, 12.0, 1.0)
    reports = reports_along("V", STRAIGHT_LINE, start_m=100.0, speed_mps=speed, t=t, frame=FRAME)
    reports = [
        dataclasses.replace(r, odometer_m=5000.0 + speed * r.t, fix_quality=int(k < 6))
        for k, r in enumerate(reports)
    ]
    late = dataclasses.replace(reports[3], t=4.5, odometer_m=5000.0 + speed * 4.5)
    pos = Positioner(straight)
    for r in [*reports[:6], late]:
        pos.update(r)
    assert pos.stats["rejected_time"] == 1
    for k, r in enumerate(reports[6:], start=6):
        p = pos.update(r)
        assert p.offset_m == pytest.approx(100.0 + speed * k, abs=3.0), k
    assert pos.stats["odometer_reset"] == 0
    assert pos.stats["odometer_dead_reckoning"] == 6


def _odometer_fault(kind: str, k: int, t: float, speed: float) -> float:
    true = 5000.0 + speed * t
    if kind == "spike":  # one reading 100 m ahead
        return true + 100.0 if k == 12 else true
    if kind == "step":  # the count jumps 20 m ahead and goes on from there
        return true + 20.0 if k >= 12 else true
    if kind == "frozen":  # the counter stops for 15 s, then catches up
        return 5000.0 + speed * min(t, 12.0) if k < 27 else true
    return true / 1000.0  # kilometres


@pytest.mark.parametrize("kind", ["spike", "step", "frozen", "kilometres"])
def test_an_odometer_step_the_speeds_cannot_run_is_no_measurement(straight, kind):
    # taken at face value, one reading 100 m ahead put the tram 100 m and then 200 m
    # ahead, confident, and threw the right fixes out; a frozen counter kept it 20-30 m
    # behind; a count in kilometres stood the tram still
    speed = 10.0
    t = np.arange(0.0, 40.0, 1.0)
    reports = reports_along("V", STRAIGHT_LINE, start_m=100.0, speed_mps=speed, t=t, frame=FRAME)
    reports = [
        dataclasses.replace(r, odometer_m=_odometer_fault(kind, k, r.t, speed))
        for k, r in enumerate(reports)
    ]
    pos = _followed(straight, reports, speed)
    assert pos.stats["odometer_glitch"] >= 1


@settings(max_examples=300, deadline=None)
@given(
    v0=st.floats(min_value=0.0, max_value=25.0),
    accel=st.floats(min_value=-3.5, max_value=3.5),
    dt=st.floats(min_value=0.1, max_value=60.0),
    scale=st.floats(min_value=0.97, max_value=1.03),
)
def test_an_odometer_step_any_possible_run_makes_is_no_glitch(v0, accel, dt, scale):
    # a constant acceleration from v0 (stopping at 0), read by an odometer 3 % off
    stop_s = -v0 / accel if accel < 0 else math.inf
    run_s = min(dt, stop_s)
    v1 = v0 + accel * run_s
    if v1 > 30.0:
        return
    run = scale * (v0 * run_s + 0.5 * accel * run_s * run_s)
    glitch = odometer_glitches(
        np.array([run]), np.array([dt]), np.array([v0]), np.array([v1]),
        max_accel_mps2=3.5, max_speed_mps=30.0,
    )  # fmt: skip
    assert not glitch[0]


@pytest.mark.parametrize("feed_repeats_the_stop", [False, True])
def test_a_tram_leaving_a_stop_without_fixes_or_odometer_is_carried_on_its_speeds(
    straight, feed_repeats_the_stop
):
    # no odometer; the tram stands 20 s at 200 m, then leaves at 1 m/s² with no usable fix
    # for 12 s (an underground stop, or a feed that repeats the stop's position): it was
    # left at the stop, confident, 60 m behind the tram
    t = np.arange(0.0, 50.0, 1.0)
    run_s = np.clip(t - 20.0, 0.0, None)
    speed = np.minimum(run_s, 10.0)
    along = 200.0 + np.where(run_s <= 10.0, 0.5 * run_s**2, 50.0 + 10.0 * (run_s - 10.0))
    reports = []
    for k, tk in enumerate(t):
        (r,) = reports_along(
            "V", STRAIGHT_LINE, start_m=float(along[k]), speed_mps=1.0, t=np.array([tk]),
            frame=FRAME,
        )  # fmt: skip
        r = dataclasses.replace(r, speed_mps=float(speed[k]), odometer_m=None)
        reports.append(r)
    stop = reports[19]
    for k in range(21, 33):
        reports[k] = dataclasses.replace(
            reports[k],
            lat=stop.lat,
            lon=stop.lon,
            fix_quality=None if feed_repeats_the_stop else 0,
        )
    pos = Positioner(straight)
    for k, r in enumerate(reports):
        p = pos.update(r)
        assert p.offset_m == pytest.approx(along[k], abs=4.0), (k, p)
    assert pos.stats["speed_dead_reckoning"] >= 10


def test_a_tram_that_keeps_reporting_through_a_long_tunnel_is_not_lost(straight):
    # no odometer; 90 s without a fix at 10 m/s, each second a report with the wheel speed:
    # the tram is carried on those speeds, so it is not lost after 30 s (only a position
    # predicted 30 s past the last report is)
    pos = Positioner(straight)
    t = np.arange(0.0, 120.0, 1.0)
    along = 100.0 + 10.0 * t
    for k, tk in enumerate(t):
        (r,) = reports_along(
            "V", STRAIGHT_LINE, start_m=float(along[k]), speed_mps=10.0, t=np.array([tk]),
            frame=FRAME,
        )  # fmt: skip
        if 20 <= k < 110:
            r = dataclasses.replace(r, fix_quality=0)
        p = pos.update(r)
        assert p.status != "lost", (k, p)
        assert p.offset_m == pytest.approx(along[k], abs=10.0), (k, p)
    assert pos.position("V", t=float(t[-1]) + 31.0).status == "lost"
