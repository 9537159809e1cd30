"""Fixes that are older than their reports' time stamp (issue 12: real feeds).

A vehicle-location unit that stamps a report when it sends it puts a fix in it that is a
second or two old, next to a current odometer: the fix lags the vehicle by speed × latency.
:mod:`antikol.positioning.latency` learns each vehicle's latency from its run.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import VehicleReport
from antikol.positioning import Positioner, PositioningConfig
from antikol.positioning.fleet import FleetState
from antikol.positioning.latency import MAX_LATENCY_S, learn_latency
from antikol.sim import GpsModel, Simulator, fleet
from tests._osm import FRAME, straight_fixture
from trackmap.synthetic import SyntheticNetwork


def _speed_profile(t: np.ndarray) -> np.ndarray:
    """Stop 10 s, speed up at 1 m/s² to 12 m/s, cruise 20 s, brake at 1 m/s²; again."""
    phase = t % 54.0
    return np.select(
        [phase < 10.0, phase < 22.0, phase < 42.0],
        [0.0, phase - 10.0, 12.0],
        np.maximum(54.0 - phase, 0.0),
    )


def _learn(tau: float, noise_m: float, seed: int, n: int = 400) -> float:
    rng = np.random.default_rng(seed)
    fleet = FleetState(k=1)
    fleet.grow(1)
    rows = np.array([0])
    t = np.arange(float(n))
    v = _speed_profile(t)
    run = np.cumsum(v)
    offset = 100.0 + np.cumsum(rng.normal(0.0, 0.2, n))  # a wandering along-track bias
    got = 0.0
    for k in range(n):
        progress = offset[k] + run[k] - v[k] * tau + rng.normal(0.0, noise_m)
        got = float(
            learn_latency(
                fleet,
                rows,
                np.array([v[k]]),
                np.array([run[k]]),
                np.array([progress]),
                np.array([max(noise_m, 0.5)]),
                np.array([k == 0]),
                prior=(0.0, 1.0),
                offset_rate_m2_s=0.2,
                dt_s=np.array([1.0]),
            )[0]
        )
    return got


@settings(max_examples=30, deadline=None)
@given(
    tau=st.floats(min_value=0.0, max_value=3.0),
    noise_m=st.floats(min_value=0.0, max_value=4.0),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
)
def test_the_latency_is_learnt_from_the_lag_growing_with_the_speed(tau, noise_m, seed):
    assert _learn(tau, noise_m, seed) == pytest.approx(tau, abs=0.2)


def test_a_new_lineage_keeps_the_latency_and_restarts_the_offset():
    fleet = FleetState(k=1)
    fleet.grow(1)
    rows = np.array([0])
    kwargs = {"prior": (0.0, 1.0), "offset_rate_m2_s": 0.2, "dt_s": np.array([1.0])}
    for k in range(200):
        v = float(_speed_profile(np.array([float(k)]))[0])
        learn_latency(
            fleet, rows, np.array([v]), np.array([10.0 * k]), np.array([10.0 * k - 1.5 * v]),
            np.array([3.0]), np.array([k == 0]), **kwargs,
        )  # fmt: skip
    learnt = float(fleet.lt[0])
    assert learnt == pytest.approx(1.5, abs=0.1)
    # the lineage restarts: its progress counts from 0 again
    got = learn_latency(
        fleet, rows, np.array([12.0]), np.array([2000.0]), np.array([0.0]), np.array([3.0]),
        np.array([True]), **kwargs,
    )  # fmt: skip
    assert float(got[0]) == pytest.approx(learnt)
    assert float(fleet.lc[0]) == pytest.approx(-2000.0 + 12.0 * learnt)


@settings(max_examples=50, deadline=None)
@given(
    speed=st.floats(min_value=1.0, max_value=20.0),
    progress=st.lists(st.floats(min_value=-60.0, max_value=60.0), min_size=2, max_size=8),
    sigma=st.floats(min_value=0.5, max_value=5.0),
)
def test_a_lineage_that_starts_running_learns_no_latency_until_the_speed_changes(
    speed, progress, sigma
):
    # the offset read off the first fix depends on the latency; at one speed a later fix
    # tells the offset, never the latency (it used to take a wrong lineage's jump for a
    # latency and keep it: the tram stood 20 m ahead of exact fixes until its next stop)
    fleet = FleetState(k=1)
    fleet.grow(1)
    rows = np.array([0])
    for k, z in enumerate(progress):
        got = learn_latency(
            fleet, rows, np.array([speed]), np.array([speed * k]), np.array([z]),
            np.array([sigma]), np.array([k == 0]), prior=(0.3, 1.0), offset_rate_m2_s=0.2,
            dt_s=np.array([1.0]),
        )  # fmt: skip
        assert float(got[0]) == pytest.approx(0.3, abs=1e-3)  # (it may drift)


def test_a_prior_without_spread_is_the_latency_used():
    fleet = FleetState(k=1)
    fleet.grow(1)
    got = learn_latency(
        fleet, np.array([0]), np.array([10.0]), np.array([0.0]), np.array([50.0]),
        np.array([3.0]), np.array([True]), prior=(9.0, 0.0), offset_rate_m2_s=0.2,
        dt_s=np.array([1.0]),
    )  # fmt: skip
    assert float(got[0]) == MAX_LATENCY_S  # kept within bounds
    assert np.isnan(fleet.lt[0])  # nothing learnt


# -- the positioner ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    return trackmap.build(straight_fixture().write_xml(tmp_path_factory.mktemp("s") / "s.osm"))


def _late_reports(latency_s: float, seconds: int) -> tuple[list[VehicleReport], np.ndarray]:
    """A tram on the straight line (offset = y + 500 m) in stop-and-go, its fixes (and
    GPS speed) ``latency_s`` old, its odometer current; and its true offsets."""
    fine = np.arange(0.0, seconds + 1.0, 0.1)
    s = 100.0 + np.concatenate([[0.0], np.cumsum(_speed_profile(fine[:-1]) * 0.1)])
    t = np.arange(float(seconds))
    true = np.interp(t, fine, s)
    seen = np.interp(t - latency_s, fine, s)
    reports = []
    for k, tk in enumerate(t):
        lon, lat = FRAME.to_lonlat(0.0, float(seen[k]) - 500.0)
        speed = float(_speed_profile(np.array([max(tk - latency_s, 0.0)]))[0])
        reports.append(
            VehicleReport(
                "V", float(tk), float(lat), float(lon), speed, 0.0,
                odometer_m=5000.0 + float(true[k]), fix_quality=1,
            )
        )  # fmt: skip
    return reports, true


@pytest.mark.parametrize("learn, worst_m", [(True, 2.0), (False, None)])
def test_a_tram_whose_fixes_are_a_second_late_is_placed_where_it_is(straight, learn, worst_m):
    # without learning the position lags 6-9 m whenever the tram runs at 12 m/s (the
    # fixes say 12 m; the odometer pulls the other way)
    config = PositioningConfig() if learn else PositioningConfig(fix_latency_sigma_s=0.0)
    reports, true = _late_reports(1.0, 160)
    pos = Positioner(straight, config)
    err = np.array([pos.update(r).offset_m - s for r, s in zip(reports, true, strict=True)])
    running = _speed_profile(np.arange(160.0)) >= 12.0
    late = np.abs(err[60:][running[60:]])
    if worst_m is None:
        assert np.median(late) > 5.0
    else:
        assert late.max() < worst_m


def test_the_simulated_receiver_reports_its_fix_a_second_late():
    net = trackmap.load_default()
    (spec,) = fleet(net, 1, 3)
    spec = dataclasses.replace(spec, max_speed_mps=10.0)
    on_time = Simulator(net, [spec], gps=GpsModel.urban(), seed=3).run(120.0)
    late = Simulator(net, [spec], gps=GpsModel.urban(latency_s=1.0), seed=3).run(120.0)
    a = {r.t: r for r in on_time.reports if r.fix_quality == 1}
    b = {r.t: r for r in late.reports if r.fix_quality == 1}
    shifted = [t for t in b if t - 1.0 in a and t in a]
    assert len(shifted) > 60
    for t in shifted:
        assert (b[t].lat, b[t].lon, b[t].speed_mps) == (
            a[t - 1.0].lat,
            a[t - 1.0].lon,
            a[t - 1.0].speed_mps,
        )
        assert b[t].odometer_m == a[t].odometer_m


def test_a_late_receiver_sends_nothing_until_its_first_fix_is_that_old():
    # it used to send its first observation for the length of the latency (at a start:
    # the position twice, with a random standing course), which a positioner reads as a
    # receiver holding its course at a standstill
    net = trackmap.load_default()
    (spec,) = fleet(net, 1, 3)
    on_time = Simulator(net, [spec], gps=GpsModel.urban(), seed=3).run(30.0)
    late = Simulator(net, [spec], gps=GpsModel.urban(latency_s=2.0), seed=3).run(30.0)
    first_on_time, first_late = on_time.reports[0], late.reports[0]
    assert first_late.t == first_on_time.t + 2.0
    assert (first_late.lat, first_late.lon) == (first_on_time.lat, first_on_time.lon)
    positions = [(r.lat, r.lon) for r in late.reports[:3]]
    assert len(set(positions)) == len(positions)


def test_a_course_reversed_for_the_first_reports_leaves_no_lasting_lead():
    # a tram setting off with its previous trip's course: the first fixes are matched to
    # the other track of a double track, then the course is right. Its place must be where
    # its (exact) fixes are from then on, not a latency learnt from the wrong track's jump
    board = SyntheticNetwork()
    board.track([(3.1, 0.0), (3.1, 3000.0)], oneway="yes")
    board.track([(0.0, 3000.0), (0.0, 0.0)], oneway="yes")
    net = board.build()
    pos = Positioner(net)
    errors = []
    for k in range(40):
        y = 100.0 + 12.0 * k
        lon, lat = board.lonlat(3.1, y)
        course = 180.0 if k < 2 else 0.0
        p = pos.update(VehicleReport("T1", float(k), lat, lon, 12.0, course, fix_quality=1))
        x_m, y_m = board.frame.to_local(p.lon, p.lat)
        if k >= 3:
            assert abs(float(x_m) - 3.1) < 0.5  # on the northbound track
        errors.append(float(y_m) - y)
    assert max(abs(e) for e in errors[3:]) < 2.0


def test_antikol_simulate_writes_a_late_receiver(tmp_path, capsys):
    from antikol.cli import main
    from antikol.ingest.replaylog import read_replay_csv

    base = ["simulate", "--trams", "2", "--minutes", "1", "--gps", "urban", "--seed", "3"]
    on_time, late = tmp_path / "on_time.csv", tmp_path / "late.csv"
    assert main([*base, "-o", str(on_time)]) == 0
    assert main([*base, "--latency", "1", "-o", str(late)]) == 0
    a = {(r.vehicle_id, r.t): r for r in read_replay_csv(on_time).reports if r.fix_quality == 1}
    b = {(r.vehicle_id, r.t): r for r in read_replay_csv(late).reports if r.fix_quality == 1}
    shifted = [(v, t) for v, t in b if (v, t - 1.0) in a]
    assert len(shifted) > 60
    assert all((b[k].lat, b[k].lon) == (a[(k[0], k[1] - 1.0)].lat, a[(k[0], k[1] - 1.0)].lon)
               for k in shifted)  # fmt: skip
    assert main(["simulate", "--latency", "1", "-o", str(tmp_path / "x.csv")]) == 2
    assert "--gps urban" in capsys.readouterr().err
