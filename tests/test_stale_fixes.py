"""Reports that repeat the last position while the vehicle runs on (issue 12: real feeds).

An operator's feed keeps sending the last position when the receiver has no fix, with no
field to say so. :func:`antikol.positioning.stale.stale_fixes` tells those reports from
fixes; the :class:`Positioner` dead-reckons over them.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import VehicleReport
from antikol.positioning import Positioner
from antikol.positioning.stale import stale_fixes
from tests._osm import FRAME, STRAIGHT_LINE, straight_fixture
from tests._paths import reports_along

_RUN_M = 2.0


def _one(now: VehicleReport, before: VehicleReport | None, *, t_fix: float, odo_fix: float):
    return bool(
        stale_fixes(
            [now],
            [before],
            np.array([t_fix]),
            np.array([odo_fix]),
            np.array([0.0 if before is None else before.speed_mps]),
            run_m=_RUN_M,
        )[0]
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
    # (the odometer's run as the readings give it, rounding and all)
    ran = (1000.0 + run) - 1000.0 if with_odometer else (speed * dt if speed >= 1.0 else 0.0)
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


@pytest.mark.parametrize("odometer", [True, False])
def test_a_frozen_position_does_not_pull_a_running_tram_back(straight, odometer):
    # eight reports repeat the last fix while the tram runs on at 10 m/s: it used to be
    # reported 40-80 m behind, confident, then jump forward when the fixes came back
    speed = 10.0
    reports = _frozen_run(speed=speed, odometer=odometer, freeze=range(10, 18))
    pos = Positioner(straight)
    out = [pos.update(r) for r in reports]
    for k, p in enumerate(out):
        assert p.status == "confident", k
        assert p.offset_m == pytest.approx(100.0 + speed * k, abs=3.0), k
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
