"""The tram traffic simulator: routes, driving, car following, GPS model and outputs."""

from __future__ import annotations

import csv
import itertools
import math

import numpy as np
import pytest

import trackmap
from antikol.analysis.braking import load_profile, stopping_distance
from antikol.ingest.nmea import read_nmea_file
from antikol.ingest.replaylog import REPLAY_COLUMNS as CSV_HEADER
from antikol.sim import (
    DEFAULT_SPEED_MPS,
    GpsModel,
    Route,
    ScriptEvent,
    Simulator,
    StopCall,
    TramSpec,
    crossing_clearance_m,
    fleet,
    map_stops_on_route,
    random_route,
    route_from_edges,
)
from tests._osm import OsmBuilder, switch_fixture

TRAM = load_profile("tram")
TOL_MPS = 0.05  # speed tolerance against the profile
TOL_MPS2 = 1e-6  # acceleration tolerance against the limits


# -- maps ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def krakow() -> trackmap.TrackMap:
    return trackmap.load_default()


def _build(b: OsmBuilder, tmp_path_factory: pytest.TempPathFactory, name: str):
    path = tmp_path_factory.mktemp(name) / f"{name}.osm"
    return trackmap.build(b.write_xml(path))


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    """One 3 km one-way straight edge running north."""
    b = OsmBuilder()
    b.line([(0, 0), (0, 1500), (0, 3000)], oneway="yes")
    net = _build(b, tmp_path_factory, "straight")
    assert len(net.edges) == 1 and net.edges[0].direction == 1
    return net


@pytest.fixture(scope="module")
def tunnel_line(tmp_path_factory):
    """500 m open, 300 m tunnel, 1200 m open, one-way."""
    b = OsmBuilder()
    a, c = b.node(0, 500), b.node(0, 800)
    b.line([(0, 0), a], oneway="yes")
    b.line([a, c], oneway="yes", tunnel="yes")
    b.line([c, (0, 2000)], oneway="yes")
    net = _build(b, tmp_path_factory, "tunnel")
    assert [e.tunnel for e in net.edges] == [False, True, False]
    return net


@pytest.fixture(scope="module")
def curve(tmp_path_factory):
    """300 m straight, a quarter circle of 50 m radius, 600 m straight."""
    b = OsmBuilder()
    arc = b.arc(50, 300, 50, 180, 90, n=40)  # from (0, 300) turning right to (50, 350)
    b.line([(0, 0), *arc, (650, 350)], oneway="yes")
    return _build(b, tmp_path_factory, "curve")


@pytest.fixture(scope="module")
def merge(tmp_path_factory):
    """A symmetric Y: two one-way branches from the north join a trunk going south."""
    b = OsmBuilder()
    toe = b.node(0, 0)
    b.line([(-40, 300), (-10, 60), toe], oneway="yes")
    b.line([(40, 300), (10, 60), toe], oneway="yes")
    b.line([toe, (0, -150), (0, -300)], oneway="yes")
    net = _build(b, tmp_path_factory, "merge")
    assert [c.kind for c in net.conflicts] == ["merge"]
    return net


@pytest.fixture(scope="module")
def switch(tmp_path_factory):
    return _build(switch_fixture(), tmp_path_factory, "switch")


def straight_route(net, start_m=0.0, end_m=None):
    return Route.from_steps(net, [(0, 1)], start_offset_m=start_m, end_offset_m=end_m)


def one_way_edge(net):
    """A main-line edge of one running direction (+1), longer than 300 m."""
    return next(
        e.edge_id
        for e in net.edges
        if e.service is None and e.direction == 1 and e.length_m > 300.0 and not e.tunnel
    )


def step_is_permitted(net, a, b):
    return net.traversal.has_edge(a, b) and net.edges[a[0]].allows(a[1])


# -- routes -------------------------------------------------------------------------------
def test_random_routes_follow_permitted_moves(krakow):
    rng = np.random.default_rng(3)
    for _ in range(25):
        route = random_route(krakow, rng, length_m=3000.0)
        assert all(krakow.edges[e].allows(d) for e, d in route.steps)
        for a, b in itertools.pairwise(route.steps):
            assert step_is_permitted(krakow, a, b)
        assert route.length_m == pytest.approx(3000.0, abs=1e-6)  # main line: no dead end
        assert all(krakow.edges[e].service is None for e in route.edge_ids)
    e = one_way_edge(krakow)
    route = random_route(krakow, 5, length_m=50.0, start=(e, 100.0, 1))
    assert route.steps == ((e, 1),) and route.start_offset_m == 100.0
    assert route.end_offset_m == pytest.approx(150.0) and route.length_m == pytest.approx(50.0)
    with pytest.raises(ValueError, match="does not permit"):
        random_route(krakow, 5, length_m=50.0, start=(e, 100.0, -1))
    with pytest.raises(ValueError, match="length_m"):
        random_route(krakow, 5, length_m=0.0)


def test_random_route_stops_at_a_dead_end(straight):
    route = random_route(straight, 1, length_m=10_000.0, start=(0, 1000.0, 1))
    assert route.length_m == pytest.approx(2000.0, abs=0.1)
    assert route.end_offset_m == pytest.approx(straight.edge_length(0))


def test_a_place_behind_the_start_of_a_route_has_a_negative_distance_when_asked(straight):
    # a tram's first metres: its antenna lies behind the start of its route, and an
    # estimate there is on the route's track, not another (the positioning evaluation
    # counted such estimates as confident and wrong)
    route = random_route(straight, 1, length_m=500.0, start=(0, 1000.0, 1))
    assert route.distance_of(0, 997.0) is None
    assert route.distance_of(0, 997.0, after_m=-50.0) == pytest.approx(-3.0)
    assert route.distance_of(0, 1003.0, after_m=-50.0) == pytest.approx(3.0)
    assert route.distance_of(0, 900.0, after_m=-50.0) is None  # behind the asked bound


def test_route_distances_and_positions_round_trip(krakow):
    route = random_route(krakow, 11, length_m=2500.0)
    d = np.linspace(0.0, route.length_m, 301)
    edges, offsets, _ = route.locate_array(d)
    back = route.distances_of(edges, offsets)
    assert np.allclose(back, d, atol=1e-6)
    assert route.locate(0.0) == (route.steps[0][0], route.start_offset_m, route.steps[0][1])
    e, o, _ = route.locate(route.length_m)
    assert (e, o) == (route.steps[-1][0], pytest.approx(route.end_offset_m))
    assert route.distance_of(10**6 % len(krakow.edges), -5.0) is None
    assert route.edges_ahead(0.0)[0] == route.steps[0][0]
    assert route.edges_ahead(route.length_m) == (route.steps[-1][0],)
    assert len(route.edges_ahead(0.0, limit=3)) == min(3, len(route))
    x, y = route.xy(krakow, [0.0])
    assert (x[0], y[0]) == pytest.approx(krakow.point_at(*route.locate(0.0)[:2]))
    with pytest.raises(ValueError, match="outside the route"):
        route.locate(route.length_m + 1.0)


def test_route_from_edges_infers_directions(krakow):
    route = random_route(krakow, 21, length_m=4000.0)
    rebuilt = route_from_edges(
        krakow,
        route.edge_ids,
        start_offset_m=route.start_offset_m,
        end_offset_m=route.end_offset_m,
    )
    assert rebuilt == route
    ids = list(route.edge_ids)
    stranger = next(
        e.edge_id
        for e in krakow.edges
        if e.edge_id not in ids and not any(s[0] == e.edge_id for s in krakow.successors(ids[2], 1))
    )
    with pytest.raises(ValueError) as err:
        route_from_edges(krakow, [*ids[:3], stranger])
    message = str(err.value)
    assert f"edges {ids[2]} and {stranger}" in message and "positions 2 and 3" in message
    with pytest.raises(trackmap.UnknownEdgeError):
        route_from_edges(krakow, [ids[0], 10**7])


def test_route_from_steps_rejects_bad_moves(krakow, switch):
    with pytest.raises(ValueError, match="not a permitted move"):
        Route.from_steps(krakow, [(one_way_edge(krakow), 1)] * 2)
    # the switch fixture: trunk and branches meet at the toe; no move between branches
    assert Route.from_steps(switch, [(1, -1), (0, -1)]).length_m == pytest.approx(400.0, abs=0.1)
    with pytest.raises(ValueError, match=r"steps 0 and 1"):
        Route.from_steps(switch, [(1, -1), (2, 1)])
    with pytest.raises(ValueError, match="start_offset_m"):
        Route.from_steps(switch, [(0, 1)], start_offset_m=1e4)


# -- driving ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def city(krakow):
    specs = fleet(krakow, 8, 4, route_length_m=3000.0, headway_s=5.0)
    return specs, Simulator(krakow, specs, seed=4).run(400.0)


def test_city_speeds_and_accelerations_within_limits(krakow, city):
    specs, result = city
    for spec in specs:
        truth = result.truth[spec.vehicle_id]
        plan = result.plans[spec.vehicle_id]
        assert len(truth) > 100
        assert np.all(truth.speed_mps <= plan.limit_at(truth.distance_m) + TOL_MPS)
        assert np.all(truth.speed_mps <= spec.vmax_mps + TOL_MPS)
        assert np.all(np.diff(truth.distance_m) >= 0.0)
        assert np.all(truth.accel_mps2 <= spec.profile.traction_mps2 + TOL_MPS2)
        assert np.all(truth.accel_mps2 >= -spec.profile.emergency_decel_mps2 - TOL_MPS2)
        beyond = truth.accel_mps2 < -spec.profile.service_decel_mps2 - TOL_MPS2
        assert np.all(truth.braking[beyond] == "emergency")
        assert not np.any(truth.braking == "emergency")  # no events, no emergencies
        assert np.all(truth.braking[truth.accel_mps2 < -0.1] == "service")
        # the truth is consistent with the route geometry
        route = spec.route
        e, o, d = route.locate_array(truth.distance_m)
        assert np.array_equal(e, truth.edge_id) and np.array_equal(d, truth.direction)
        assert np.allclose(o, truth.offset_m, atol=1e-6)
        k = len(truth) // 2
        x, y = krakow.point_at(int(truth.edge_id[k]), float(truth.offset_m[k]))
        assert math.hypot(x - truth.x_m[k], y - truth.y_m[k]) < 1e-6
        h = krakow.heading_at(int(truth.edge_id[k]), float(truth.offset_m[k]))
        turn = (truth.heading_deg[k] - (h if truth.direction[k] > 0 else h + 180.0)) % 360.0
        assert min(turn, 360.0 - turn) < 1.0
        gap = np.hypot(truth.x_m - truth.antenna_x_m, truth.y_m - truth.antenna_y_m)
        assert np.all(gap <= spec.antenna_m + 1e-6)


def test_curve_speed_from_the_radius(curve):
    route = Route.from_steps(curve, [(0, 1)])
    spec = TramSpec("C1", route, stops=(), cruise_factor=1.0)
    sim = Simulator(curve, [spec], gps=GpsModel.exact())
    plan = sim.plans["C1"]
    arc_length = 0.5 * math.pi * 50.0
    mid = (plan.distance_m > 300.0 + 15.0) & (plan.distance_m < 300.0 + arc_length - 15.0)
    assert np.median(plan.curve_radius_m[mid]) == pytest.approx(50.0, rel=0.05)
    assert plan.limit_mps[mid].max() <= math.sqrt(1.0 * 50.0) * 1.06
    straight_part = plan.distance_m > 300.0 + arc_length + 60.0
    assert plan.limit_mps[straight_part & (plan.distance_m < 800)].min() == pytest.approx(
        DEFAULT_SPEED_MPS
    )
    truth = sim.run(150.0).truth["C1"]
    in_arc = (truth.distance_m > 300.0) & (truth.distance_m < 300.0 + arc_length)
    assert truth.speed_mps[in_arc].max() <= math.sqrt(50.0) * 1.06
    assert truth.speed_mps.max() > 12.0  # it speeds up again after the curve
    # the whole train keeps the curve speed until its rear has left the arc
    rear_in_arc = (truth.distance_m - 32.0 > 300.0) & (truth.distance_m - 32.0 < 330.0)
    assert truth.speed_mps[rear_in_arc].max() <= math.sqrt(50.0) * 1.06


def test_tram_stops_at_each_stop_for_the_dwell_time(straight):
    stops = (StopCall(300.0, 15.0, "A"), (900.0, 25.0), StopCall(1400.0, 0.0))
    spec = TramSpec("S1", straight_route(straight, 0.0, 2000.0), stops=stops)
    result = Simulator(straight, [spec], gps=GpsModel.exact()).run(400.0)
    truth = result.truth["S1"]
    plan = result.plans["S1"]
    assert [c.distance_m for c in plan.stops] == [300.0, 900.0, 1400.0]
    for call in plan.stops:
        here = (np.abs(truth.distance_m - call.distance_m) <= 0.1) & (truth.speed_mps == 0.0)
        standing = here.sum() * result.dt_s
        assert call.dwell_s <= standing <= call.dwell_s + 2 * result.dt_s
        first = np.flatnonzero(here)[0]
        assert abs(truth.distance_m[first] - call.distance_m) < 0.01
        # it really stopped there: slow just before, not merely passing
        assert truth.speed_mps[max(first - 20, 0)] < 3.0
    # and at the end of the route it stays
    assert truth.distance_m[-1] == pytest.approx(2000.0, abs=0.1)
    assert truth.speed_mps[-50:].max() == 0.0


def test_default_stops_are_the_map_stops_on_the_route(krakow):
    route = random_route(krakow, 8, length_m=2500.0)
    on_route = map_stops_on_route(krakow, route)
    assert len(on_route) >= 3, "a 2.5 km route in Kraków passes stops"
    for dist, stop in on_route:
        assert route.distance_of(stop.edge_id, stop.offset_m) == pytest.approx(dist)
    spec = TramSpec("K1", route, dwell_s=12.0)
    result = Simulator(krakow, [spec], gps=GpsModel.exact(), dt_s=0.2).run(600.0)
    plan = result.plans["K1"]
    assert [c.distance_m for c in plan.stops] == [d for d, _ in on_route if d > 1.0]
    assert all(c.dwell_s == 12.0 for c in plan.stops)
    truth = result.truth["K1"]
    for call in plan.stops:
        here = (np.abs(truth.distance_m - call.distance_m) <= 0.1) & (truth.speed_mps == 0.0)
        assert 12.0 <= here.sum() * result.dt_s <= 12.0 + 2 * result.dt_s
    no_stops = TramSpec("K2", route, stops=())
    assert Simulator(krakow, [no_stops]).plans["K2"].stops == ()


def gap_series(result, leader, follower):
    """Gap between the leader's rear and the follower's front (same route), metres."""
    lt, ft = result.truth[leader], result.truth[follower]
    t = np.intersect1d(np.round(lt.t_s, 6), np.round(ft.t_s, 6))
    li = np.searchsorted(np.round(lt.t_s, 6), t)
    fi = np.searchsorted(np.round(ft.t_s, 6), t)
    return t, lt.distance_m[li] - lt.length_m - ft.distance_m[fi]


def test_follower_never_closer_than_the_standstill_gap(straight):
    route = straight_route(straight)
    leader = TramSpec(
        "L",
        route,
        stops=((600.0, 30.0),),
        cruise_factor=0.6,
        script=(ScriptEvent.hold(90.0, 110.0), ("emergency_brake", 150.0, 170.0)),
    )
    follower = TramSpec("F", route, stops=(), cruise_factor=1.0, depart_s=10.0)
    result = Simulator(straight, [leader, follower], gps=GpsModel.exact()).run(260.0)
    _, gap = gap_series(result, "L", "F")
    assert gap.min() >= follower.standstill_gap_m - 0.05
    assert gap.min() <= follower.standstill_gap_m + 1.0  # it did close up behind the stops
    ft = result.truth["F"]
    assert ft.distance_m[-1] > 1500.0  # and followed on afterwards
    beyond = ft.accel_mps2 < -TRAM.service_decel_mps2 - TOL_MPS2
    assert np.all(ft.braking[beyond] == "emergency")
    lt = result.truth["L"]
    during = (lt.t_s >= 150.0) & (lt.t_s < 170.0)
    assert np.all(lt.braking[during] == "emergency") and lt.braking[lt.t_s > 171.0][0] != (
        "emergency"
    )
    assert np.all(lt.speed_mps[(lt.t_s > 91.0) & (lt.t_s < 110.0)] < 3.0)


def test_an_inattentive_driver_runs_into_the_leader(straight):
    route = straight_route(straight)
    leader = TramSpec("L", route, stops=((500.0, 60.0),))
    follower = TramSpec(
        "F", route, stops=(), depart_s=20.0, script=(ScriptEvent.inattentive(20.0),)
    )
    result = Simulator(straight, [leader, follower], gps=GpsModel.exact()).run(100.0)
    _, gap = gap_series(result, "L", "F")
    assert gap.min() < 0.0  # the simulator lets trams collide: ground truth for warnings


def test_emergency_brake_stopping_distance(straight):
    spec = TramSpec(
        "E", straight_route(straight), stops=(), script=(ScriptEvent.emergency_brake(60.0),)
    )
    truth = Simulator(straight, [spec], gps=GpsModel.exact()).run(100.0).truth["E"]
    k = truth.index_at(60.0)
    v0 = truth.speed_mps[k]
    assert v0 > 12.0
    travelled = truth.distance_m[-1] - truth.distance_m[k]
    expected = stopping_distance(v0, TRAM, brake="emergency") - TRAM.standstill_margin_m
    assert travelled == pytest.approx(expected, abs=0.05)
    assert np.all(truth.braking[k:] == "emergency")
    braking = truth.accel_mps2[k + 4 : k + 40]
    assert np.allclose(braking, -TRAM.emergency_decel_mps2)
    assert np.all(truth.accel_mps2[k : k + 3] == 0.0)  # build-up: traction cut, coasting


def test_speed_cap_event(straight):
    spec = TramSpec(
        "V", straight_route(straight), stops=(), script=(ScriptEvent.speed_cap(40.0, 5.0),)
    )
    truth = Simulator(straight, [spec], gps=GpsModel.exact()).run(80.0).truth["V"]
    later = truth.t_s > 40.0 + (truth.speed_mps[truth.index_at(40.0)] - 5.0) / 0.96 + 0.5
    assert truth.speed_mps[later].max() <= 5.0 + 1e-6
    assert truth.speed_mps[truth.t_s < 40.0].max() > 12.0


def test_trams_give_way_at_a_merge(merge):
    # two trams 100 m before the toe on either branch, arriving together
    toe = merge.edge_length(0)
    a = TramSpec("A", Route.from_steps(merge, [(0, 1), (2, 1)], start_offset_m=toe - 100.0))
    b = TramSpec("B", Route.from_steps(merge, [(1, 1), (2, 1)], start_offset_m=toe - 100.0))
    clear = merge.conflicts[0].extents_m[1]
    assert clear == merge.conflicts[0].extents_m[2] > 5.0

    def fouling(truth):  # front past the clearance point, rear not yet past the toe
        return (truth.distance_m > 100.0 - clear + 0.5) & (truth.distance_m - 32.0 < 100.0)

    result = Simulator(merge, [a, b], gps=GpsModel.exact()).run(90.0)
    ta, tb = result.truth["A"], result.truth["B"]
    assert fouling(ta).any() and fouling(tb).any()
    assert not np.any(fouling(ta) & fouling(tb))
    # A (first in the list) goes, B waits at its clearance point
    waiting = tb.speed_mps[50:] == 0.0
    assert waiting.any()
    assert tb.distance_m[50:][waiting].max() == pytest.approx(100.0 - clear, abs=0.05)
    assert ta.speed_mps[50:][ta.distance_m[50:] < 132.0].min() > 5.0  # A did not wait
    # on the trunk B follows A at a safe distance
    on_trunk = (ta.distance_m - 32.0 >= 100.0) & (tb.distance_m >= 100.0)
    assert on_trunk.any()
    assert np.all(ta.distance_m[on_trunk] - 32.0 - tb.distance_m[on_trunk] >= 10.0 - 0.05)
    assert not np.any(ta.braking == "emergency") and not np.any(tb.braking == "emergency")
    # without giving way they run into the merge together
    unyielding = Simulator(merge, [a, b], gps=GpsModel.exact(), yield_at_conflicts=False)
    ua, ub = (unyielding.run(90.0).truth[k] for k in ("A", "B"))
    assert np.any(fouling(ua) & fouling(ub))


def test_crossing_clearance_grows_at_shallow_angles():
    assert crossing_clearance_m(90.0) == pytest.approx(1.75)
    assert crossing_clearance_m(15.0) > 10.0
    assert crossing_clearance_m(0.0) == 50.0
    assert crossing_clearance_m(170.0) == pytest.approx(crossing_clearance_m(10.0))


def test_a_tram_waits_for_a_clear_start_and_can_exit(straight):
    route = straight_route(straight, 0.0, 1000.0)
    first = TramSpec("A", route, stops=(), exit_at_end=True)
    second = TramSpec("B", route, stops=(), depart_s=0.0)
    result = Simulator(straight, [first, second], gps=GpsModel.exact()).run(200.0)
    ta, tb = result.truth["A"], result.truth["B"]
    assert ta.t_s[0] == 0.0 and tb.t_s[0] > 5.0  # B appeared once A had moved away
    _, gap = gap_series(result, "A", "B")
    assert gap.min() >= 10.0 - 0.05
    # A leaves the simulation at its route end at speed; B stops there and stays
    assert ta.distance_m[-1] < 1000.0 and ta.speed_mps[-1] > 5.0 and ta.t_s[-1] < 150.0
    assert not any(r.vehicle_id == "A" and r.t > ta.t_s[-1] for r in result.reports)
    assert tb.distance_m[-1] == pytest.approx(1000.0, abs=0.1) and tb.speed_mps[-1] == 0.0


# -- GPS ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def standing(straight):
    """20 trams standing still for 20 minutes, 1 Hz fixes."""
    specs = [
        TramSpec(f"P{i:02d}", straight_route(straight, 100.0 * i + 50.0, 100.0 * i + 50.0))
        for i in range(20)
    ]
    gps = GpsModel(sigma_m=3.0, bias_sigma_m=1.5, bias_tau_s=60.0, missing_rate=0.2)
    return Simulator(straight, specs, gps=gps, dt_s=1.0, seed=9).run(1200.0)


def test_gps_position_noise_matches_the_model(straight, standing):
    logs = list(standing.fixes.values())
    ex = np.concatenate([f.x_m - f.true_x_m for f in logs])
    ey = np.concatenate([f.y_m - f.true_y_m for f in logs])
    bx = np.concatenate([f.bias_x_m for f in logs])
    by = np.concatenate([f.bias_y_m for f in logs])
    assert len(ex) == 20 * 1201
    white = np.concatenate([ex - bx, ey - by])
    assert abs(white.mean()) < 0.1
    assert white.std() == pytest.approx(3.0, rel=0.05)
    assert np.concatenate([bx, by]).std() == pytest.approx(1.5, rel=0.25)
    assert abs(ex.mean()) < 0.5 and abs(ey.mean()) < 0.5
    assert np.concatenate([ex, ey]).std() == pytest.approx(math.hypot(3.0, 1.5), rel=0.1)
    # the bias is a Gauss-Markov process: correlation exp(-1) after one time constant
    lag = 60
    corr = np.mean(
        [np.corrcoef(f.bias_x_m[:-lag], f.bias_x_m[lag:])[0, 1] for f in logs]
        + [np.corrcoef(f.bias_y_m[:-lag], f.bias_y_m[lag:])[0, 1] for f in logs]
    )
    assert corr == pytest.approx(math.exp(-1.0), abs=0.12)
    # the reports carry exactly the measured positions of the available fixes
    log = standing.fixes["P03"]
    reports = standing.reports_of("P03")
    rx, ry = straight.to_local(
        np.array([r.lon for r in reports]), np.array([r.lat for r in reports])
    )
    assert np.allclose(rx, log.x_m[log.available], atol=1e-3)
    assert np.allclose(ry, log.y_m[log.available], atol=1e-3)


def test_missing_fixes_and_sequence_numbers(standing):
    available = np.concatenate([f.available for f in standing.fixes.values()])
    assert available.mean() == pytest.approx(0.8, abs=0.02)
    assert len(standing.reports) == available.sum()
    for vid in ("P00", "P19"):
        reports = standing.reports_of(vid)
        assert [r.seq for r in reports] == list(range(len(reports)))
        assert all(a.t < b.t for a, b in itertools.pairwise(reports))
    times = [r.t for r in standing.reports]
    assert times == sorted(times)
    speeds = np.array([r.speed_mps for r in standing.reports])
    assert speeds.min() >= 0.0
    assert speeds.mean() == pytest.approx(0.1 * math.sqrt(math.pi / 2.0), rel=0.1)  # Rayleigh
    # standing still, the receiver holds its course
    courses = [r.course_deg for r in standing.reports_of("P05")]
    assert len(set(courses)) <= 3


def test_outliers(straight):
    spec = TramSpec("O", straight_route(straight, 10.0, 10.0))
    gps = GpsModel(outlier_rate=0.1, outlier_sigma_m=50.0, bias_sigma_m=0.0)
    log = Simulator(straight, [spec], gps=gps, dt_s=1.0, seed=2).run(2000.0).fixes["O"]
    assert log.outlier.mean() == pytest.approx(0.1, abs=0.02)
    err = np.hypot(log.x_m - log.true_x_m, log.y_m - log.true_y_m)
    assert np.median(err[log.outlier]) > 30.0 and np.median(err[~log.outlier]) < 5.0


def test_no_fixes_while_the_antenna_is_in_a_tunnel(tunnel_line):
    route = Route.from_steps(tunnel_line, [(0, 1), (1, 1), (2, 1)])
    spec = TramSpec("U", route, stops=())
    result = Simulator(tunnel_line, [spec], seed=1).run(200.0)
    truth = result.truth["U"]
    assert truth.in_tunnel.any() and not truth.in_tunnel.all()
    inside = {round(t, 6) for t in truth.t_s[truth.in_tunnel]}
    times = [round(r.t, 6) for r in result.reports]
    assert not inside.intersection(times)
    assert any(t < min(inside) for t in times) and any(t > max(inside) for t in times)
    log = result.fixes["U"]
    assert np.array_equal(log.available, ~log.in_tunnel)
    # the antenna, 16 m behind the front, enters the tunnel 16 m after the front
    first = np.flatnonzero(truth.in_tunnel)[0]
    assert truth.distance_m[first] - truth.antenna_offset_m == pytest.approx(500.0, abs=2.0)
    late = GpsModel(tunnel_reacquire_s=5.0)
    lagging = Simulator(tunnel_line, [spec], gps=late, seed=1).run(200.0).fixes["U"]
    # no fix for 5 s after the last epoch in the tunnel
    assert lagging.available.sum() == log.available.sum() - 4
    open_sky = Simulator(tunnel_line, [spec], gps=GpsModel(tunnel_dropout=False)).run(200.0)
    assert len(open_sky.reports) == len(open_sky.fixes["U"])


def test_course_noise_is_larger_at_low_speed(straight):
    stops = tuple((d, 5.0) for d in range(200, 2900, 250))
    spec = TramSpec("K", straight_route(straight), stops=stops)
    gps = GpsModel(rate_hz=5.0, course_hold_speed_mps=0.0, bias_sigma_m=0.0)
    log = Simulator(straight, [spec], gps=gps, seed=3, dt_s=0.2).run(600.0).fixes["K"]
    err = (log.course_deg - log.true_course_deg + 180.0) % 360.0 - 180.0
    slow = (log.true_speed_mps > 0.3) & (log.true_speed_mps < 1.5)
    fast = log.true_speed_mps > 10.0
    assert slow.sum() > 30 and fast.sum() > 300
    assert np.std(err[fast]) == pytest.approx(math.hypot(2.0, math.degrees(0.1 / 12)), rel=0.2)
    assert np.std(err[slow]) > 2.0 * np.std(err[fast])
    moving = log.true_speed_mps > 3.0
    assert np.abs(err[moving]).max() < 15.0
    # at standstill without static hold the course wanders at random
    standing = log.true_speed_mps == 0.0
    assert np.std(err[standing]) > 60.0


@pytest.mark.parametrize("model", ["white", "urban"])
def test_a_receiver_can_hold_the_course_it_had_before_the_trace(straight, model):
    """A trace cut from a service starts with the tram at a stop: a receiver with static
    hold reports the running way it measured on the way in, not its first fix's noise."""
    spec = TramSpec("S", straight_route(straight, 100.0), stops=())
    make = GpsModel if model == "white" else GpsModel.urban

    def courses(held: bool) -> list[float]:
        errors = []
        for seed in range(12):
            gps = make(course_hold_speed_mps=0.5, course_held_at_start=held)
            sim = Simulator(straight, [spec], gps=gps, seed=seed, dt_s=1.0)
            log = sim.run(30.0).fixes["S"]
            first = int(np.flatnonzero(log.available & (log.true_speed_mps == 0.0))[0])
            errors.append((log.course_deg[first] - log.true_course_deg[first] + 180) % 360 - 180)
        return errors

    held = courses(True)
    assert max(abs(e) for e in held) < 4.0 * 2.0  # the running way, with the course noise
    # a cold start holds its first fix's course: noise at a standstill
    assert np.std(courses(False)) > 30.0


# -- reproducibility ----------------------------------------------------------------------
def test_same_seed_same_reports_and_trams_are_independent(straight):
    one = TramSpec("T1", straight_route(straight, 1500.0), stops=((700.0, 10.0),))
    two = TramSpec("T2", straight_route(straight, 0.0, 1000.0))
    gps = GpsModel(outlier_rate=0.05, missing_rate=0.1)
    a = Simulator(straight, [one], gps=gps, seed=5).run(150.0)
    b = Simulator(straight, [one], gps=gps, seed=5).run(150.0)
    assert a.reports == b.reports and len(a.reports) > 100
    both = Simulator(straight, [two, one], gps=gps, seed=5).run(150.0)
    assert both.reports_of("T1") == a.reports_of("T1")
    assert both.reports_of("T2")
    other_seed = Simulator(straight, [one], gps=gps, seed=6).run(150.0)
    assert other_seed.reports != a.reports
    # a longer run extends the same noise
    longer = Simulator(straight, [one], gps=gps, seed=5).run(200.0)
    assert longer.reports_of("T1")[: len(a.reports)] == list(a.reports)


def test_truth_lookup(straight):
    spec = TramSpec("T", straight_route(straight), stops=(), depart_s=3.0)
    truth = Simulator(straight, [spec], gps=GpsModel.exact()).run(30.0).truth["T"]
    assert truth.t_s[0] == pytest.approx(3.0)
    state = truth.at(10.04)
    assert state.t_s == pytest.approx(10.0) and state.vehicle_id == "T"
    k = truth.index_at(10.0)
    mid = truth.at(10.05, interpolate=True)
    assert mid.distance_m == pytest.approx(0.5 * (truth.distance_m[k] + truth.distance_m[k + 1]))
    assert mid.edge_id == 0 and mid.braking == "none" and not mid.in_tunnel
    assert not truth.covers(1.0)
    with pytest.raises(ValueError, match="not in service"):
        truth.at(1.0)


# -- outputs ------------------------------------------------------------------------------
def test_csv_and_nmea_round_trip(krakow, tmp_path):
    specs = fleet(krakow, 3, 2, route_length_m=2000.0, headway_s=2.0, broadcast_route=True)
    result = Simulator(krakow, specs, seed=2).run(60.0)
    path = result.write_csv(tmp_path / "replay.csv")
    lines = path.read_text(encoding="utf-8").splitlines()
    assert lines[0] == ",".join(CSV_HEADER) == "vehicle_id,t,lat,lon,speed_mps,course_deg"
    assert len(lines) == len(result.reports) + 1
    with path.open(encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert rows[0]["vehicle_id"] == result.reports[0].vehicle_id
    assert float(rows[5]["lat"]) == pytest.approx(result.reports[5].lat, abs=1e-8)
    extra = result.write_csv(tmp_path / "extra.csv", extra_columns=("braking", "seq"))
    assert extra.read_text().splitlines()[0].endswith("course_deg,braking,seq")
    with pytest.raises(ValueError, match="unknown CSV column"):
        result.write_csv(tmp_path / "bad.csv", extra_columns=("colour",))

    files = result.write_nmea(tmp_path / "nmea")
    assert sorted(p.name for p in files) == sorted(f"{s.vehicle_id}.nmea" for s in specs)
    for spec, file in zip(specs, files, strict=True):
        mine = result.reports_of(spec.vehicle_id)
        read, stats = read_nmea_file(file)
        assert len(read) == len(mine) > 30
        for r, m in zip(read, mine, strict=True):
            assert r.t == pytest.approx(result.epoch_utc_s + m.t, abs=0.006)
            x0, y0 = krakow.to_local(m.lon, m.lat)
            x1, y1 = krakow.to_local(r.lon, r.lat)
            assert math.hypot(x1 - x0, y1 - y0) < 1.0
            assert r.speed_mps == pytest.approx(m.speed_mps, abs=0.01)
        # the reader emits the first fix on its RMC and skips its VTG and GGA
        assert sum(stats.skipped.values()) <= 2
    # every report announces the route ahead, starting with the front's edge
    report = result.reports_of(specs[0].vehicle_id)[10]
    truth = result.truth[specs[0].vehicle_id]
    assert report.route is not None and report.route[0] == truth.at(report.t).edge_id
    assert report.length_m == 32.0 and report.antenna_offset_m == 16.0


# -- validation ---------------------------------------------------------------------------
def test_specs_and_events_are_validated(straight):
    route = straight_route(straight)
    with pytest.raises(ValueError, match="antenna_offset_m"):
        TramSpec("X", route, antenna_offset_m=40.0)
    with pytest.raises(ValueError, match="cruise_factor"):
        TramSpec("X", route, cruise_factor=1.5)
    with pytest.raises(ValueError, match="vehicle_id"):
        TramSpec("", route)
    with pytest.raises(ValueError, match="outside its route"):
        TramSpec("X", route, stops=((5000.0, 10.0),))
    with pytest.raises(ValueError, match="two trams"):
        Simulator(straight, [TramSpec("X", route), TramSpec("X", route)])
    foreign = Route(((0, 1), (0, 1)), (3000.0, 3000.0), 0.0, 10.0)
    with pytest.raises(ValueError, match="does not permit"):
        Simulator(straight, [TramSpec("X", foreign)])
    with pytest.raises(ValueError, match="unknown script event"):
        ScriptEvent.parse(("teleport", 3.0))
    with pytest.raises(ValueError, match="speed_mps"):
        ScriptEvent("speed_cap", 1.0)
    with pytest.raises(ValueError, match="until_s"):
        ScriptEvent.hold(10.0, 5.0)
    with pytest.raises(ValueError, match="missing_rate"):
        GpsModel(missing_rate=1.5)
    spec = TramSpec("X", route, script=[("speed_cap", 5.0, 3.0), ("hold", 1.0, 2.0)])
    assert [e.kind for e in spec.script] == ["hold", "speed_cap"]
    assert spec.antenna_m == 16.0 and spec.vmax_mps == TRAM.max_speed_mps
    assert ScriptEvent.parse(("emergency_brake", 4.0)).until_s is None


def test_fleet(krakow):
    specs = fleet(krakow, 20, 12, route_length_m=3000.0, headway_s=15.0, dwell_s=10.0)
    assert len({s.vehicle_id for s in specs}) == 20 and specs[0].vehicle_id == "T01"
    assert [s.depart_s for s in specs] == [15.0 * i for i in range(20)]
    assert all(0.9 <= s.cruise_factor <= 1.0 and s.dwell_s == 10.0 for s in specs)
    for s in specs:
        assert all(krakow.edges[e].service is None for e in s.route.edge_ids)
        assert s.route.length_m == pytest.approx(3000.0, abs=1e-6)
    starts = np.array([krakow.point_at(*s.route.locate(0.0)[:2]) for s in specs])
    spacing = np.hypot(*(starts[:, None, :] - starts[None, :, :]).transpose(2, 0, 1))
    assert spacing[np.triu_indices(20, 1)].min() >= 300.0
    assert [s.route for s in fleet(krakow, 20, 12, route_length_m=3000.0)] == [
        s.route for s in specs
    ]
