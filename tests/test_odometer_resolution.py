"""A coarse odometer (issue 12): steps in units of 10 m are no wheel measurement to 0.25 m.

A counter read out in 10-m units says 0 or 10 m of a tram's 8 m a second. Taken as a
wheel measurement good to a quarter of a metre, every step was a jump along the track:
the along-track error grew to 10 m and the branch past a switch became a coin toss.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol.positioning import Positioner, PositioningConfig
from antikol.positioning.fleet import FleetState
from antikol.positioning.odometerresolution import (
    COARSE_RESOLUTION_M,
    CONFIRMATIONS,
    glitch_margin,
    learn_odometer_resolution,
    odometer_resolution,
    quantisation_sigma,
    usable_readings,
)
from tests._osm import FRAME, STRAIGHT_LINE, straight_fixture
from tests._paths import reports_along


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    return trackmap.build(straight_fixture().write_xml(tmp_path_factory.mktemp("s") / "s.osm"))


def _learnt(readings: list[float]) -> float:
    fleet = FleetState(k=2)
    fleet.grow(1)
    rows = np.array([0])
    for before, now in itertools.pairwise(readings):
        learn_odometer_resolution(fleet, rows, np.array([now - before]))
    return float(odometer_resolution(fleet, rows)[0])


def test_a_counter_in_10_m_units_is_found_a_fine_one_is_not():
    run = np.cumsum(np.full(40, 8.0) + np.sin(np.arange(40)))  # 7-9 m a second
    assert _learnt(list(np.floor(run / 10.0) * 10.0)) == pytest.approx(10.0)
    assert _learnt(list(np.floor(run))) <= 1.0  # HSL's integer metres: fine
    fine = _learnt(list(np.round(run, 1)))
    assert np.isnan(fine) or fine < COARSE_RESOLUTION_M


@pytest.mark.parametrize(
    "readings",
    [
        [0.0, 10.0, 20.0, 130.0, 140.0, 150.0, 160.0],  # one reading 100 m ahead, kept
        [0.0, 10.0, 20.0, 30.0, 30.0, 30.0, 30.0, 30.0],  # a counter that froze
    ],
    ids=["jump", "frozen"],
)
def test_one_odd_step_is_no_resolution(readings):
    # a step unlike the others is a fault until its size recurs
    assert np.isnan(_learnt(readings))


@settings(max_examples=200, deadline=None)
@given(
    unit=st.sampled_from([0.1, 1.0, 5.0, 10.0, 20.0, 100.0]),
    speeds=st.lists(st.floats(0.0, 20.0), min_size=5, max_size=60),
    origin=st.floats(0.0, 1e5),
)
def test_the_resolution_is_never_coarser_than_the_unit(unit, speeds, origin):
    # every step of a counter in ``unit`` steps is a multiple of it, and so is every
    # difference of two steps: what is learnt is a multiple of the unit
    readings = list(np.floor((origin + np.cumsum(speeds)) / unit) * unit)
    learnt = _learnt(readings)
    if not np.isnan(learnt):
        units = learnt / unit
        assert units >= 1.0 - 1e-6
        assert abs(units - round(units)) < 1e-6 * max(units, 1.0) + 1e-9 * origin


def test_the_widening_is_zero_for_fine_counters():
    sigma = quantisation_sigma(np.array([np.nan, 0.1, 1.0, 5.0, 10.0]), step_sigma_m=0.25)
    assert sigma[:4].tolist() == [0.0, 0.0, 0.0, 0.0]
    assert sigma[4] == pytest.approx(math.sqrt(100.0 / 6.0 - 0.0625))
    margin = glitch_margin(np.array([np.nan, 1.0, 10.0]), margin_m=2.0)
    assert margin.tolist() == [0.0, 0.0, 8.0]


def test_a_counter_coarser_than_15_m_is_not_used():
    fleet = FleetState(k=2)
    fleet.grow(3)
    rows = np.array([0, 1, 2])
    # rows: a counter in 100-m units, one in 10-m units, a fine one
    for k in range(8):
        steps = [100.0 * (k % 2), 10.0 * (k % 2), 8.0 + 0.1 * (k % 3)]
        learn_odometer_resolution(fleet, rows, np.array(steps))
    learnt = odometer_resolution(fleet, rows)
    assert learnt[:2].tolist() == [100.0, 10.0]
    kept = usable_readings(fleet, rows, np.array([5000.0, 5010.0, 5000.3]))
    assert np.isnan(kept[0]) and kept[1:].tolist() == [5010.0, 5000.3]


def _run_with_odometer(unit: float, *, seconds: int = 80, speed: float = 8.0):
    """A tram at 8 m/s on a straight track from 100 m, fixes with 2 m white noise, and an
    odometer in ``unit`` steps."""
    rng = np.random.default_rng(7)
    t = np.arange(0.0, float(seconds), 1.0)
    reports = reports_along("V", STRAIGHT_LINE, start_m=100.0, speed_mps=speed, t=t, frame=FRAME)
    out = []
    for r in reports:
        x, y = FRAME.to_local(r.lon, r.lat)
        lon, lat = FRAME.to_lonlat(x + 2.0 * rng.standard_normal(), y + 2.0 * rng.standard_normal())
        reading = math.floor((5000.0 + speed * r.t) / unit) * unit
        out.append(dataclasses.replace(r, lat=float(lat), lon=float(lon), odometer_m=reading))
    return out


@pytest.mark.parametrize("unit", [10.0, 20.0, 100.0])
def test_a_tram_with_a_coarse_odometer_is_placed_within_metres(straight, unit):
    speed = 8.0
    pos = Positioner(straight, PositioningConfig())
    errors = []
    for k, r in enumerate(_run_with_odometer(unit, speed=speed)):
        p = pos.update(r)
        if k >= 20:  # (once the unit is learnt)
            errors.append(p.offset_m - (100.0 + speed * r.t))
    errors = np.array(errors)
    # without the resolution the along-track error ran to about the unit
    assert np.sqrt(np.mean(errors**2)) < 2.5
    assert np.abs(errors).max() < 6.0


def test_a_fine_odometer_is_used_as_before(straight):
    # 0.1-m steps: nothing confirmed coarse, nothing widened
    pos = Positioner(straight)
    for r in _run_with_odometer(0.1):
        pos.update(r)
    vehicle = pos.state("V")["vehicle"]
    assert vehicle["oqn"] < CONFIRMATIONS or vehicle["oq"] < COARSE_RESOLUTION_M
