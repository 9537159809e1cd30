"""An odometer that reads a few per cent long or short (issue 12: odometer input).

A worn wheel or a diameter set wrong scales every odometer step; the positioning trusts
those steps to a per cent, so before its scale was learnt a tram whose odometer read 5 %
long ran ahead of exact fixes by metres and out of a fix-less stretch tens of metres off.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import VehicleReport
from antikol.errors import InvalidArgumentError
from antikol.positioning import Positioner, PositioningConfig
from antikol.positioning.fleet import FleetState
from antikol.positioning.odometerscale import (
    MAX_SCALE_ERROR,
    corrected_odometers,
    learn_odometer_scale,
)
from tests._osm import FRAME, STRAIGHT_LINE, straight_fixture

_START_Y = STRAIGHT_LINE[0][1] + 50.0


def _fleet() -> FleetState:
    fleet = FleetState(k=1)
    fleet.grow(1)
    return fleet


def _learn(
    fleet: FleetState, raw: float, progress: float, *, restart: bool = False, usable: bool = True
) -> float:
    rows = np.array([0])
    odo = corrected_odometers(fleet, rows, np.array([raw]))
    learn_odometer_scale(
        fleet, rows, odo, np.array([progress]), np.array([4.0]), np.array([restart]),
        np.array([usable]), prior_sigma=0.03,
    )  # fmt: skip
    return float(odo[0])


@settings(max_examples=60, deadline=None)
@given(
    factor=st.floats(0.9, 1.1),
    speed=st.floats(3.0, 20.0),
    origin=st.floats(0.0, 1.0e6),
    seed=st.integers(0, 2**16),
)
def test_the_scale_is_learnt_from_noisy_fixes(factor, speed, origin, seed):
    """Fixes with 3 m white noise and a 2 m bias along the track; 3 km run."""
    rng = np.random.default_rng(seed)
    fleet = _fleet()
    bias = rng.normal(0.0, 2.0)
    steps = int(3000.0 / speed)
    for k in range(steps):
        _learn(fleet, origin + factor * speed * k, speed * k + bias + rng.normal(0.0, 3.0))
    assert fleet.oscale[0] == pytest.approx(1.0 / factor, abs=0.01)


@settings(max_examples=100, deadline=None)
@given(
    increments=st.lists(st.floats(-50.0, 50.0), min_size=2, max_size=30),
    scale=st.floats(1.0 - MAX_SCALE_ERROR, 1.0 + MAX_SCALE_ERROR),
)
def test_corrected_readings_step_by_the_scale_and_a_fall_stays_a_fall(increments, scale):
    fleet = _fleet()
    fleet.oscale[0] = scale
    rows = np.array([0])
    raw = 1000.0
    before = float(corrected_odometers(fleet, rows, np.array([raw]))[0])
    assert before == raw  # a vehicle's first reading is taken as it is
    for increment in increments:
        step = (raw + increment) - raw  # (as the readings give it)
        raw += increment
        now = float(corrected_odometers(fleet, rows, np.array([raw]))[0])
        assert now - before == pytest.approx(scale * step, abs=1e-6)
        assert (now < before) == (step < 0.0)
        before = now


def test_a_reading_missing_keeps_the_baseline():
    fleet = _fleet()
    rows = np.array([0])
    corrected_odometers(fleet, rows, np.array([100.0]))
    fleet.oscale[0] = 0.5
    assert math.isnan(float(corrected_odometers(fleet, rows, np.array([math.nan]))[0]))
    assert float(corrected_odometers(fleet, rows, np.array([120.0]))[0]) == pytest.approx(110.0)


def test_a_reset_or_a_new_lineage_breaks_the_run_and_teaches_nothing():
    fleet = _fleet()
    _learn(fleet, 5000.0, 0.0)
    _learn(fleet, 5010.0, 10.0)
    pooled = float(fleet.osum[0])
    _learn(fleet, 5040.0, 20.0, usable=False)  # a glitch the positioner found
    _learn(fleet, 0.0, 30.0)  # the trip's odometer starts again
    _learn(fleet, 10.0, 400.0, restart=True)  # another track's lineage
    assert fleet.osum[0] == pooled
    assert fleet.oscale[0] == pytest.approx(1.0, abs=1e-3)


def test_without_a_prior_the_odometer_is_taken_as_it_reads():
    fleet = _fleet()
    rows = np.array([0])
    for k in range(300):
        odo = corrected_odometers(fleet, rows, np.array([1.05 * 10.0 * k]))
        learn_odometer_scale(fleet, rows, odo, np.array([10.0 * k]), np.array([4.0]),
                             np.array([k == 0]), np.array([True]), prior_sigma=0.0)  # fmt: skip
    assert fleet.oscale[0] == 1.0


def test_the_prior_is_checked():
    with pytest.raises(InvalidArgumentError, match="odometer_scale_sigma"):
        PositioningConfig(odometer_scale_sigma=-0.01)


# -- the positioner ---------------------------------------------------------------------
@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    return trackmap.build(straight_fixture().write_xml(tmp_path_factory.mktemp("s") / "s.osm"))


def _run(
    net, factor: float, *, config: PositioningConfig | None = None, gap: tuple[int, int] = (0, 0)
) -> tuple[Positioner, list[float]]:
    """A tram north at 10 m/s for 150 s, fixes with 3 m white noise, odometer ``factor``
    times the distance run; no fix (fix quality 0) from ``gap[0]`` to ``gap[1]`` s.
    Returns the positioner and the along-track error of every estimate, m."""
    rng = np.random.default_rng(7)
    pos = Positioner(net, config=config)
    errors = []
    for k in range(150):
        y = _START_Y + 10.0 * k
        lon, lat = FRAME.to_lonlat(rng.normal(0.0, 3.0), y + rng.normal(0.0, 3.0))
        no_fix = gap[0] <= k < gap[1]
        report = VehicleReport(
            "T", float(k), float(lat), float(lon), speed_mps=10.0,
            course_deg=float(rng.normal(0.0, 2.0)) % 360.0, odometer_m=20_000.0 + factor * 10.0 * k,
            fix_quality=0 if no_fix else 1,
        )  # fmt: skip
        p = pos.update(report)
        _, y_est = FRAME.to_local(p.lon, p.lat)
        errors.append(float(y_est) - y)
    return pos, errors


@pytest.mark.parametrize("factor", [0.95, 1.05])
def test_an_odometer_off_in_scale_no_longer_pulls_the_estimate_off_the_fixes(straight, factor):
    _, learnt = _run(straight, factor)
    _, taken = _run(straight, factor, config=PositioningConfig(odometer_scale_sigma=0.0))
    late = slice(100, None)  # (1 km on)
    assert np.sqrt(np.mean(np.square(learnt[late]))) < 2.5
    # (what the odometer taken as it reads did, and the old positioner always: 11-13 m
    # off, to the side of the scale)
    assert abs(np.mean(taken[late])) > 8.0
    assert np.sign(np.mean(taken[late])) == np.sign(factor - 1.0)


def test_a_stretch_without_fixes_is_run_on_the_learnt_scale(straight):
    """300 m without a fix after 100 s of fixes: the odometer carries the tram."""
    gap = (100, 130)
    pos, errors = _run(straight, 1.05, gap=gap)
    assert pos.state("T")["vehicle"]["oscale"] == pytest.approx(1.0 / 1.05, abs=0.01)
    assert max(abs(e) for e in errors[gap[0] : gap[1]]) < 4.0
    _, taken = _run(straight, 1.05, config=PositioningConfig(odometer_scale_sigma=0.0), gap=gap)
    assert taken[gap[1] - 1] > 10.0


def test_the_scale_is_kept_in_the_saved_state(straight):
    pos, _ = _run(straight, 1.05)
    state = pos.state("T")
    again = Positioner(straight)
    again.restore("T", state)
    assert again.state("T")["vehicle"]["oscale"] == state["vehicle"]["oscale"] != 1.0
