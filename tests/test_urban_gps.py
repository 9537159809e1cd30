"""The realistic street GPS model (issue 12): multipath bias, heavy tails, outages, odometer."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol.sim import GpsModel, Route, Simulator, TramSpec, UrbanGpsModel
from antikol.sim.places import double_track_share, on_double_track
from antikol.sim.urban_gps import canyon_factors
from tests._osm import FRAME, OsmBuilder


def _build(b: OsmBuilder, tmp_path_factory: pytest.TempPathFactory, name: str):
    return trackmap.build(b.write_xml(tmp_path_factory.mktemp(name) / f"{name}.osm"))


@pytest.fixture(scope="module")
def street(tmp_path_factory):
    """2 km of double track (3.8 m apart, right-hand running) then 2 km of single track
    in the open, then a 300 m tunnel and 700 m more, all running north."""
    b = OsmBuilder()
    a, c, d = b.node(0, 2000), b.node(0, 4000), b.node(0, 4300)
    b.line([(0, 0), (0, 1000), a], oneway="yes", maxspeed="50")
    b.line([(-3.8, 2000), (-3.8, 1000), (-3.8, 0)], oneway="yes")  # the other way
    b.line([a, (0, 3000), c], oneway="yes", maxspeed="60")
    b.line([c, d], oneway="yes", tunnel="yes")
    b.line([d, (0, 5000)], oneway="yes")
    return _build(b, tmp_path_factory, "street")


def _north_route(net: trackmap.TrackMap) -> Route:
    steps = []
    for y in (500.0, 2500.0, 4100.0, 4600.0):
        (cand,) = [c for c in net.candidates(*FRAME.to_lonlat(0.0, y), radius_m=1.0)]
        steps.append((cand.edge_id, 1 if net.edges[cand.edge_id].direction == 1 else -1))
    return Route.from_steps(net, steps)


@pytest.fixture(scope="module")
def run(street):
    """One tram driving the whole line at up to 10 m/s, 1 Hz urban fixes, six seeds."""
    spec = TramSpec("U", _north_route(street), stops=(), max_speed_mps=10.0)
    return [Simulator(street, [spec], gps=GpsModel.urban(), seed=k).run(560.0) for k in range(6)]


def test_double_track_is_found_and_is_the_canyon(street):
    share = double_track_share(street)
    route = _north_route(street)
    shares = [share[e] for e, _ in route.steps]
    assert shares[0] > 0.9 and shares[1] < 0.1 and shares[2] < 0.1
    x, y = street.to_local(*FRAME.to_lonlat(np.zeros(3), np.array([1000.0, 2500.0, 4600.0])))
    assert on_double_track(street, x, y).tolist() == [True, False, False]
    factors = canyon_factors(UrbanGpsModel(canyon_spread=0.0), street)
    assert factors[route.steps[0][0]] == pytest.approx(0.8)
    assert factors[route.steps[1][0]] == pytest.approx(0.2, abs=0.02)
    assert factors[route.steps[2][0]] == pytest.approx(0.2)  # tunnels: no multipath
    # a property of the place, the same for every run and tram
    assert np.array_equal(
        canyon_factors(UrbanGpsModel(), street), canyon_factors(UrbanGpsModel(), street)
    )


def test_multipath_bias_is_lateral_persistent_and_worst_in_the_canyon(run):
    logs = [r.fixes[v] for r in run for v in r.fixes]
    canyon = np.concatenate([f.canyon for f in logs])
    lateral = np.concatenate([f.bias_lateral_m for f in logs])
    bx = np.concatenate([f.bias_x_m for f in logs])
    high, low = canyon > 0.5, (canyon < 0.3) & (canyon > 0.0)
    assert high.sum() > 500 and low.sum() > 500
    # on a north-running line the lateral bias is the east-west one
    assert np.allclose(np.abs(lateral), np.abs(bx), atol=0.05 * np.abs(lateral).max())
    assert lateral[high].std() > 2.0 * lateral[low].std()
    assert lateral[high].std() > 2.0
    # persistent between jumps: one-second changes are small against the bias itself
    steps = np.concatenate([np.diff(f.bias_lateral_m)[~f.bias_jump[1:]] for f in logs])
    assert np.median(np.abs(steps)) < 0.2 * lateral[high].std()
    jumps = sum(int(f.bias_jump.sum()) for f in logs)
    assert 20 < jumps < 200  # mean interval 120 s / (1 + c) over ~5,600 epochs


def test_white_noise_has_heavy_tails(street):
    route = _north_route(street)
    spec = TramSpec("H", route, stops=(), max_speed_mps=10.0)
    open_sky = GpsModel.urban(
        bias_open_m=0.0,
        bias_canyon_lateral_m=0.0,
        bias_canyon_along_m=0.0,
        dropout_open_hz=0.0,
        dropout_canyon_hz=0.0,
        outlier_rate=0.0,
    )
    logs = [Simulator(street, [spec], gps=open_sky, seed=k).run(480.0).fixes["H"] for k in range(6)]
    e = np.concatenate([f.x_m - f.true_x_m for f in logs] + [f.y_m - f.true_y_m for f in logs])
    scale = 1.5
    # Student-t, 4 dof: std = scale * sqrt(2); far more beyond 4 scales than a normal
    assert e.std() == pytest.approx(scale * math.sqrt(2.0), rel=0.15)
    beyond = np.mean(np.abs(e) > 4.0 * scale)
    normal_same_std = math.erfc(4.0 / math.sqrt(2.0) / math.sqrt(2.0))
    assert beyond > 2.0 * normal_same_std


def test_outages_are_runs_and_come_in_the_canyon(run):
    logs = [r.fixes[v] for r in run for v in r.fixes]
    outage = np.concatenate([f.outage for f in logs])
    canyon = np.concatenate([f.canyon for f in logs])
    assert outage.any()
    # hazard 0.0081/s against 0.0024/s (noisy: a few dozen outages in all)
    assert outage[canyon > 0.5].mean() > 1.5 * outage[(canyon < 0.3) & (canyon > 0)].mean()
    lengths = [len(list(g)) for f in logs for k, g in itertools.groupby(f.outage.tolist()) if k]
    assert np.mean(lengths) > 2.0  # runs, not single misses


def test_odometer_and_no_fix_reports_in_the_tunnel(run, street):
    for result in run:
        (vid,) = result.truth
        reports = result.reports_of(vid)
        log = result.fixes[vid]
        truth = result.truth[vid]
        odo = np.array([r.odometer_m for r in reports])
        assert (np.diff(odo) >= 0).all()
        # the odometer measures the distance run with a small scale error
        t = np.array([r.t for r in reports])
        run_m = np.interp(t, truth.t_s, truth.distance_m)
        scale = (odo[-1] - odo[0]) / (run_m[-1] - run_m[0])
        assert scale == pytest.approx(1.0, abs=0.02)
        # in the tunnel: reports without a fix, at the last known position, with odometer
        no_fix = [r for r in reports if r.fix_quality == 0]
        inside = [r for r in no_fix if truth.at(r.t).in_tunnel]
        assert inside, vid
        assert all(r.fix_quality in (0, 1) for r in reports)
        assert len(reports) == int(log.available.sum() + log.no_fix_report.sum())
        for a, b in itertools.pairwise(reports):
            if b.fix_quality == 0:
                assert (b.lat, b.lon, b.course_deg) == (a.lat, a.lon, a.course_deg)
        assert not log.available[log.in_tunnel].any()


def test_course_is_good_when_moving_and_speed_within_a_fraction_of_a_metre(run):
    logs = [r.fixes[v] for r in run for v in r.fixes]
    for f in logs:
        fast = f.available & (f.true_speed_mps > 8.0)
        err = (f.course_deg[fast] - f.true_course_deg[fast] + 180.0) % 360.0 - 180.0
        assert np.std(err) < 4.0
        assert np.std(f.speed_mps[fast] - f.true_speed_mps[fast]) < 0.25


def test_urban_noise_is_reproducible_and_prefix_stable(street):
    route = _north_route(street)
    spec = TramSpec("R", route, stops=(), max_speed_mps=10.0)
    a = Simulator(street, [spec], gps=GpsModel.urban(), seed=4).run(200.0)
    b = Simulator(street, [spec], gps=GpsModel.urban(), seed=4).run(200.0)
    longer = Simulator(street, [spec], gps=GpsModel.urban(), seed=4).run(300.0)
    assert a.reports == b.reports
    assert longer.reports[: len(a.reports) - 1] == a.reports[:-1]


def test_the_white_noise_model_reports_neither_odometer_nor_fix_quality(street):
    route = _north_route(street)
    spec = TramSpec("W", route, stops=(), max_speed_mps=10.0)
    result = Simulator(street, [spec], gps=GpsModel(), seed=1).run(100.0)
    assert all(r.odometer_m is None and r.fix_quality is None for r in result.reports)
    assert result.fixes["W"].canyon is None


def test_a_feed_without_a_fix_quality_field_repeats_the_last_position_unflagged(street):
    # the same epochs and errors as the receiver that flags them, seen through a feed
    # that has no fix-quality field: the reports without a fix are there, unmarked
    spec = TramSpec("F", _north_route(street), stops=(), max_speed_mps=10.0)
    flagged = Simulator(street, [spec], gps=GpsModel.urban(), seed=2).run(560.0).reports
    gps = GpsModel.urban(fix_quality_field=False)
    feed = Simulator(street, [spec], gps=gps, seed=2).run(560.0).reports
    assert all(r.fix_quality is None for r in feed)
    assert [dataclasses.replace(r, fix_quality=None) for r in flagged] == list(feed)
    repeats = [b for a, b in itertools.pairwise(feed) if (a.lat, a.lon) == (b.lat, b.lon)]
    assert len(repeats) >= sum(r.fix_quality == 0 for r in flagged) > 0


def test_estimates_without_a_fix_follow_the_route_or_run_straight_on(street):
    """Reports without a fix carry the sender's estimate (``fix_quality`` 6) when asked:
    the last fix moved by the tram's true motion, or on along the last fix's heading."""
    spec = TramSpec("E", _north_route(street), stops=(), max_speed_mps=10.0)
    flagged = Simulator(street, [spec], gps=GpsModel.urban(), seed=2).run(560.0)
    plain = flagged.reports
    for option in ("estimates_along_route", "estimates_extrapolated"):
        gps = GpsModel.urban(**{option: True})
        result = Simulator(street, [spec], gps=gps, seed=2).run(560.0)
        # the same epochs, fixes and errors; only the reports without a fix differ
        assert [r.t for r in result.reports] == [r.t for r in plain]
        log = result.fixes["E"]
        last_fix = None
        moved = 0
        for r, before in zip(result.reports, plain, strict=True):
            k = int(np.searchsorted(log.t_s, r.t))
            if before.fix_quality == 1:
                assert r == before
                last_fix = k
                continue
            assert before.fix_quality == 0 and r.fix_quality == 6
            x, y = street.to_local(r.lon, r.lat)
            ran = math.hypot(log.true_x_m[k] - log.true_x_m[last_fix],
                             log.true_y_m[k] - log.true_y_m[last_fix])  # fmt: skip
            moved += ran > 1.0
            error = (x - log.true_x_m[k], y - log.true_y_m[k])
            fix_error = (log.x_m[last_fix] - log.true_x_m[last_fix],
                         log.y_m[last_fix] - log.true_y_m[last_fix])  # fmt: skip
            if option == "estimates_along_route":  # the last fix's error, carried on
                assert np.allclose(error, fix_error, atol=1e-6)
            else:  # on along the last heading at the last speed (the line runs north)
                expected = log.speed_mps[last_fix] * (r.t - log.t_s[last_fix])
                assert y - log.y_m[last_fix] == pytest.approx(expected, abs=0.05 * expected + 0.5)
        assert moved > 10
    with pytest.raises(ValueError, match="exclude"):
        UrbanGpsModel(estimates_along_route=True, estimates_extrapolated=True)


def test_bad_urban_parameters_are_rejected():
    with pytest.raises(ValueError, match="tail_dof"):
        UrbanGpsModel(tail_dof=2.0)
    with pytest.raises(ValueError, match="canyon_open"):
        UrbanGpsModel(canyon_open=1.5)
    with pytest.raises(ValueError, match="jump_interval_s"):
        UrbanGpsModel(jump_interval_s=0.0)


@pytest.mark.parametrize("period", [2.0, 5.0])
def test_an_odometer_read_every_few_seconds_holds_its_last_update(street, period):
    spec = TramSpec("U", _north_route(street), stops=(), max_speed_mps=10.0)
    gps = GpsModel.urban(odometer_period_s=period, odometer_scale_sigma=0.0)
    result = Simulator(street, [spec], gps=gps, seed=3).run(300.0)
    reports = result.reports_of("U")
    truth = result.truth["U"]
    t = np.array([r.t for r in reports])
    odo = np.array([r.odometer_m for r in reports])
    changes = np.flatnonzero(np.diff(odo) > 0.0) + 1
    # once per cycle at most, and held in between while the tram runs
    assert len(changes) <= 300.0 / period + 1
    assert np.diff(t[changes]).min() >= period - 1.0 - 1e-9
    assert (np.diff(odo) == 0.0).sum() >= (1.0 - 1.0 / period) * (len(odo) - 1) - 2
    # each changed reading is the distance at some moment since the report before
    run_m = odo - odo[0]
    before = np.interp(t[changes - 1], truth.t_s, truth.distance_m) - truth.distance_m[0]
    now = np.interp(t[changes], truth.t_s, truth.distance_m) - truth.distance_m[0]
    assert np.all(run_m[changes] >= before - 0.2) and np.all(run_m[changes] <= now + 0.2)


def test_street_settings_read_fields_and_name_the_bad_item():
    from antikol.errors import InvalidArgumentError
    from antikol.sim.urban_gps import street_settings

    got = street_settings(["bias_canyon_lateral_m=6", "odometer=false", "course_fault=zero"])
    assert got == {"bias_canyon_lateral_m": 6.0, "odometer": False, "course_fault": "zero"}
    assert UrbanGpsModel(**got).bias_canyon_lateral_m == 6.0
    for bad, says in (
        ("bias_lateral=6", "UrbanGpsModel field"),  # no such field
        ("sigma_m", "NAME=VALUE"),
        ("odometer=maybe", "true or false"),
        ("sigma_m=wide", "not a number"),
        ("sigma_m=-1", "sigma_m"),  # the model rejects it
    ):
        with pytest.raises(InvalidArgumentError, match=says) as err:
            street_settings([bad])
        assert isinstance(err.value, ValueError)


def test_antikol_simulate_takes_street_receiver_settings(tmp_path, capsys):
    # the same trams, seed and receiver but for a stronger multipath bias: other fixes
    from antikol.cli import main
    from antikol.ingest.replaylog import read_replay_csv

    base = ["simulate", "--trams", "2", "--minutes", "2", "--gps", "urban", "--seed", "3"]
    plain, harsh = tmp_path / "plain.csv", tmp_path / "harsh.csv"
    assert main([*base, "-o", str(plain)]) == 0
    assert (
        main([*base, "--gps-set", "bias_open_m=8", "bias_canyon_lateral_m=8", "-o", str(harsh)])
        == 0
    )
    a = {(r.vehicle_id, r.t): r for r in read_replay_csv(plain).reports if r.fix_quality == 1}
    b = {(r.vehicle_id, r.t): r for r in read_replay_csv(harsh).reports if r.fix_quality == 1}
    assert a.keys() & b.keys()
    assert any((a[k].lat, a[k].lon) != (b[k].lat, b[k].lon) for k in a.keys() & b.keys())
    capsys.readouterr()
    assert main(["simulate", "--gps-set", "sigma_m=2", "-o", str(tmp_path / "x.csv")]) == 2
    assert "--gps urban" in capsys.readouterr().err
    assert main([*base, "--gps-set", "sigma=2", "-o", str(tmp_path / "y.csv")]) == 2
    assert "sigma=2" in capsys.readouterr().err


@settings(max_examples=200, deadline=None)
@given(st.lists(st.text(max_size=40), max_size=3))
def test_street_settings_take_any_text_with_a_result_or_a_clear_error(items):
    from antikol.errors import InvalidArgumentError
    from antikol.sim.urban_gps import street_settings

    try:
        got = street_settings(items)
    except InvalidArgumentError as exc:
        assert "gps setting" in str(exc)
    else:
        UrbanGpsModel(**got)  # what it returns makes a valid model
