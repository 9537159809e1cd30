"""Speeds a feed reports in km/h, knots or mph (issue 12: real feeds).

Nothing in a report says its speed's unit; :mod:`antikol.positioning.speedunits` tells it
from the vehicle's fixes, and the :class:`Positioner` converts the speeds from then on.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import VehicleReport
from antikol.positioning import Positioner
from antikol.positioning.fleet import FleetState
from antikol.positioning.speedunits import UNIT_FACTORS, learn_speed_units
from antikol.sim import GpsModel, Simulator, fleet
from tests._osm import FRAME, straight_fixture


def _learn(
    xy: np.ndarray, speed_mps: np.ndarray, unit: float, t: np.ndarray | None = None
) -> tuple[float, Counter[str]]:
    """Feed fixes (local m; at 1 Hz unless times ``t`` are given, s) with their true speeds
    reported in ``unit`` (m/s per unit); the scale learnt and the counts."""
    state, stats = FleetState(k=1), Counter[str]()
    state.grow(1)
    rows = np.array([0])
    times = np.arange(float(len(xy))) if t is None else t
    for k in range(len(xy)):
        reported = float(speed_mps[k]) / unit * float(state.uscale[0])  # as converted now
        learn_speed_units(
            state, stats, rows, np.array([times[k]]), np.array([reported]),
            np.array([xy[k, 0]]), np.array([xy[k, 1]]), np.array([True]),
        )  # fmt: skip
    return float(state.uscale[0]), stats


def _straight_run(seconds: int, speed_mps: float, noise_m: float, seed: int):
    rng = np.random.default_rng(seed)
    y = speed_mps * np.arange(float(seconds))
    xy = np.column_stack([np.zeros(seconds), y]) + rng.normal(0.0, noise_m, (seconds, 2))
    return xy, np.full(seconds, speed_mps)


@settings(max_examples=40, deadline=None)
@given(
    unit=st.sampled_from(sorted(UNIT_FACTORS)),
    speed=st.floats(min_value=3.0, max_value=20.0),
    noise_m=st.floats(min_value=0.0, max_value=4.0),
    seed=st.integers(min_value=0, max_value=2**16),
)
def test_the_unit_of_the_speeds_is_told_by_the_fixes(unit, speed, noise_m, seed):
    xy, v = _straight_run(120, speed, noise_m, seed)
    scale, stats = _learn(xy, v, UNIT_FACTORS[unit])
    assert scale == UNIT_FACTORS[unit]
    # counted once, and only when the speeds are converted
    assert sum(stats.values()) == (0 if unit == "m/s" else 1)


def test_standing_with_gps_noise_tells_nothing():
    xy, _ = _straight_run(600, 0.0, 3.0, 1)
    scale, stats = _learn(xy, np.zeros(600), 1.0)
    assert scale == 1.0
    assert not stats


@pytest.mark.parametrize("radius_m", [15.0, 25.0, 40.0])
def test_a_turning_loop_is_not_taken_for_slower_speeds(radius_m):
    # a terminus loop at 5 m/s (its chords are much shorter than its arcs), then a straight
    # run: speeds in m/s stay in m/s
    loop_s = int(2.0 * math.pi * radius_m / 5.0)
    a = 5.0 * np.arange(float(loop_s)) / radius_m
    loop = np.column_stack([radius_m * np.sin(a), radius_m * (1.0 - np.cos(a))])
    line = np.column_stack([np.zeros(60), 5.0 * np.arange(1.0, 61.0)])
    xy = np.vstack([loop, line])
    scale, stats = _learn(xy, np.full(len(xy), 5.0), 1.0)
    assert scale == 1.0
    assert not stats


def test_a_gap_in_the_reports_is_not_pooled():
    # 200 s without a report while the tram ran 2 km at 10 m/s along a route whose ends are
    # 1 km apart: the speeds at the gap's ends say nothing of the run between them (a
    # simulated tram at 70 km/h was taken to report knots)
    before = np.column_stack([np.zeros(30), 10.0 * np.arange(30.0)])
    after = before + np.array([0.0, 290.0 + 1000.0])
    xy = np.vstack([before, after])
    t = np.concatenate([np.arange(30.0), 229.0 + np.arange(30.0)])
    scale, stats = _learn(xy, np.full(60, 10.0), 1.0, t)
    assert scale == 1.0
    assert not stats


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    return trackmap.build(straight_fixture().write_xml(tmp_path_factory.mktemp("s") / "s.osm"))


def test_a_feed_in_km_h_is_placed_where_its_fixes_are_once_recognised(straight, caplog):
    # 8 m/s reported as 28.8: rejected as impossible speeds, and the along-track filter
    # ran 20-60 m ahead of exact fixes for as long as the feed lasted
    pos = Positioner(straight)
    errors, speeds = [], []
    for k in range(150):
        y = -400.0 + 8.0 * k
        lon, lat = FRAME.to_lonlat(0.0, y)
        p = pos.update(VehicleReport("V", float(k), lat, lon, 28.8, 0.0, fix_quality=1))
        errors.append(FRAME.to_local(p.lon, p.lat)[1] - y)
        speeds.append(p.speed_mps)
    assert pos.stats["speed_unit_km/h"] == 1
    assert "vehicle 'V'" in caplog.text and "km/h" in caplog.text  # named in the log
    assert not any(name.startswith("rejected_") for name in pos.stats)
    assert np.max(np.abs(errors[40:])) < 1.0
    assert speeds[-1] == pytest.approx(8.0, abs=0.1)


def test_a_simulated_fleet_in_m_s_keeps_its_speeds():
    # the embedded map's curves, loops and stops, street GPS: no unit is recognised
    net = trackmap.load_default()
    specs = fleet(net, 6, 4)
    sim = Simulator(net, specs, gps=GpsModel.urban(), seed=4).run(600.0)
    pos = Positioner(net)
    for r in sorted(sim.reports, key=lambda r: r.t):
        pos.update(r)
    assert not [name for name in pos.stats if name.startswith("speed_unit")]
