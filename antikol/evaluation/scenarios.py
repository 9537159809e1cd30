"""Named, parameterised scenarios for comparing the sector rule and the track-aware analyser.

Every scenario is built on the map you give it: it looks for the place it needs (the
sharpest curve, a double-track pair, a single-track section, a merging switch, a diamond
crossing, a tunnel) and raises :class:`ScenarioUnavailable` when the map has none. The
synthetic demo network (:func:`trackmap.synthetic.demo_network`) has every feature; the
embedded Kraków map has all but a main-line single-track section long enough for a
head-on run.

==========================  ================================================================
name                        what happens
==========================  ================================================================
following_straight          a fast tram closes in on a slower one on straight track
following_curve             the same through the sharpest curve of the map
leader_behind_curve         a tram stands just past a sharp curve; another approaches
oncoming_double_track       two trams pass each other on the two tracks of a double track
single_track_head_on        two trams enter a single-track section from both ends
merge_at_switch             two trams reach a merging switch from both branches together
diamond_crossing            two trams reach a diamond crossing on crossing lines together
leader_emergency            a leader brakes with the emergency brake in front of a follower
depot_off_map               a tram moves in a depot that is not on the map, beside the line
tunnel_dropout              a follower closes in on a leader while its GPS is out in a tunnel
wrong_way_single_line       a tram runs the wrong way on double track towards an oncoming one
city                        N trams on random routes for T minutes
==========================  ================================================================
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np

from antikol.evaluation.scenario_places import (
    CrossingLines,
    ScenarioUnavailable,
    State,
    crossing_lines,
    crossover_into,
    curves,
    double_track_pairs,
    merge_switches,
    min_radius,
    route_through,
    sharpest_curve,
    single_tracks,
    trim,
    tunnels,
    walk,
)
from antikol.sim import (
    GpsModel,
    ReceiverModel,
    Route,
    ScriptEvent,
    SimulationResult,
    Simulator,
    TramSpec,
    fleet,
)
from trackmap import TrackMap

T = TypeVar("T")

__all__ = [
    "SCENARIOS",
    "Scenario",
    "ScenarioUnavailable",
    "build_scenario",
    "city",
    "default_gps",
    "depot_off_map",
    "diamond_crossing",
    "following_curve",
    "following_straight",
    "leader_behind_curve",
    "leader_emergency",
    "merge_at_switch",
    "needs_warning",
    "oncoming_double_track",
    "run_scenario",
    "sharpest_curve",
    "single_track_head_on",
    "tunnel_dropout",
    "wrong_way_single_line",
]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class Scenario:
    """A ready-to-run scenario.

    Attributes
    ----------
    name, description : str
    net : TrackMap
        The map (for simulation and analysis).
    specs : tuple of TramSpec
    gps : GpsModel or UrbanGpsModel
    duration_s : float
    seed : int
    off_map : dict of str to (TrackMap, TramSpec)
        Vehicles driving on tracks that are not on ``net`` (a depot), with their own map.
    focus : tuple of str
        Vehicles to draw in figures (all when empty).
    """

    name: str
    description: str
    net: TrackMap
    specs: tuple[TramSpec, ...]
    gps: ReceiverModel
    duration_s: float
    seed: int = 0
    off_map: dict[str, tuple[TrackMap, TramSpec]] = field(default_factory=dict)
    focus: tuple[str, ...] = ()


def default_gps() -> GpsModel:
    """The receiver model of the scenarios: sigma 3 m, a slowly varying bias of 1.5 m,
    5 % missing fixes, rare outliers, 1 Hz."""
    return GpsModel(
        sigma_m=3.0, bias_sigma_m=1.5, bias_tau_s=60.0, missing_rate=0.05, outlier_rate=0.002
    )


def run_scenario(scn: Scenario, *, progress: bool = False) -> SimulationResult:
    """Simulate a scenario (off-map vehicles on their own maps, merged into one result)."""
    result = Simulator(scn.net, list(scn.specs), gps=scn.gps, seed=scn.seed).run(
        scn.duration_s, progress=progress
    )
    for _vid, (depot, spec) in scn.off_map.items():
        extra = Simulator(depot, [spec], gps=scn.gps, seed=scn.seed).run(scn.duration_s)
        result = dataclasses.replace(
            result,
            truth={**result.truth, **extra.truth},
            reports=tuple(sorted(result.reports + extra.reports, key=lambda r: r.t)),
            fixes={**result.fixes, **extra.fixes},
            plans={**result.plans, **extra.plans},
            specs=result.specs + extra.specs,
        )
    return result


# -- scenario machinery --------------------------------------------------------------------
#: Places a scenario tries before it gives up on a map.
MAX_PLACES = 12


def _scenario(
    builder: Callable[..., Scenario],
    net: TrackMap,
    specs: tuple[TramSpec, ...],
    gps: ReceiverModel,
    duration_s: float,
    seed: int,
    *,
    off_map: dict[str, tuple[TrackMap, TramSpec]] | None = None,
    note: str = "",
    focus: tuple[str, ...] = (),
) -> Scenario:
    """A scenario named and described by the function that builds it."""
    doc = builder.__doc__ or ""
    return Scenario(
        builder.__name__,
        f"{doc} {note}".strip() if note else doc,
        net,
        specs,
        gps,
        duration_s,
        seed,
        off_map=off_map or {},
        focus=focus,
    )


def _spec(vid: str, route: Route, **kw: object) -> TramSpec:
    kw.setdefault("stops", ())
    return TramSpec(vehicle_id=vid, route=route, **kw)  # type: ignore[arg-type]


def _sub(net: TrackMap, route: Route, start_m: float) -> Route:
    if start_m > route.length_m - 1.0:
        raise ScenarioUnavailable(
            f"the route is {route.length_m:.0f} m long, too short to start a tram "
            f"{start_m:.0f} m along it"
        )
    return trim(net, route, start_m, route.length_m)


def _first_place(what: str, places: Iterable[T], build: Callable[[T], Scenario]) -> Scenario:
    """The scenario at the first of ``places`` that has room for it."""
    reasons: list[str] = []
    for place in itertools.islice(places, MAX_PLACES):
        try:
            return build(place)
        except ScenarioUnavailable as exc:
            reasons.append(str(exc))
    if not reasons:
        raise ScenarioUnavailable(f"the map has no {what}")
    raise ScenarioUnavailable(
        f"no {what} of the map has room for the scenario ({len(reasons)} tried; e.g. {reasons[0]})"
    )


def _required_times(scn: Scenario, vehicle_id: str) -> np.ndarray:
    """Times (s) at which ``vehicle_id`` needs a warning when the scenario runs with exact
    GPS (its ground truth from true states)."""
    from antikol.evaluation.groundtruth import REQUIRED, ground_truth

    result = Simulator(scn.net, list(scn.specs), gps=GpsModel.exact(), seed=scn.seed).run(
        scn.duration_s
    )
    truth = ground_truth(scn.net, result, off_map=scn.off_map.keys())
    need = np.zeros(len(truth.times_s), dtype=bool)
    for (own, _), st in truth.state.items():
        if own == vehicle_id:
            need |= st == REQUIRED
    return truth.times_s[need]


def needs_warning(scn: Scenario, vehicle_id: str, *, min_cycles: int = 3) -> bool:
    """Whether ``vehicle_id`` needs a warning for ``min_cycles`` or more cycles when the
    scenario runs with exact GPS (its ground truth from true states)."""
    return len(_required_times(scn, vehicle_id)) >= min_cycles


def _with_look_up(scn: Scenario, follower: str, until_s: float | None) -> Scenario:
    """The scenario with the follower's inattention ending at ``until_s``."""
    k = next(i for i, sp in enumerate(scn.specs) if sp.vehicle_id == follower)
    spec = scn.specs[k]
    script = tuple(
        ScriptEvent.inattentive(e.t_s, until_s) if e.kind == "inattentive" else e
        for e in spec.script
    )
    specs = list(scn.specs)
    specs[k] = dataclasses.replace(spec, script=script)
    return dataclasses.replace(scn, specs=tuple(specs))


def _calibrated(scn: Scenario, follower: str, *, late_s: float = 2.0) -> Scenario:
    """The scenario, with the follower's driver looking up later if need be.

    On another map the same script may let the driver look up long before the gap falls
    below the braking distance (a slow curve, a longer approach). Then the run is repeated
    with a driver who never looks up, and the look-up is set ``late_s`` after the first
    second that needs a warning there (checked once more; later still if need be).

    Raises
    ------
    ScenarioUnavailable
        Even a driver who never looks up does not need a warning in the run.
    """
    if needs_warning(scn, follower):
        return scn
    blind = _required_times(_with_look_up(scn, follower, None), follower)
    if not len(blind):
        raise ScenarioUnavailable(
            f"{scn.name}: the follower never comes within braking distance of the leader "
            "on this map, even when its driver never looks up"
        )
    until = float(blind[0]) + late_s
    while until < scn.duration_s:
        trial = _with_look_up(scn, follower, until)
        if needs_warning(trial, follower):
            return trial
        until += 3.0
    return _with_look_up(scn, follower, None)


# -- scenario builders --------------------------------------------------------------------
def _straight_states(net: TrackMap) -> list[State]:
    found = []
    for e in sorted(net.edges, key=lambda x: -x.length_m)[:40]:
        if e.service is not None or e.direction == 0:
            continue
        _, _, total = min_radius(net, e.edge_id)
        if total < 20.0:
            found.append((e.edge_id, e.direction))
    return found


def following_straight(net: TrackMap, *, seed: int = 0, gap_m: float = 150.0) -> Scenario:
    """A fast tram closes in on a slower one on the straightest stretch found."""

    def build(state: State) -> Scenario:
        length = net.edge_length(state[0])
        route, _ = route_through(
            net, state, length / 2.0, 300.0, 600.0, need_before_m=0.0, need_after_m=0.0
        )
        if route.length_m < gap_m + 250.0:
            raise ScenarioUnavailable(
                f"only {route.length_m:.0f} m of track around edge {state[0]} "
                f"(needs {gap_m + 250.0:.0f} m)"
            )
        leader = _spec("L", _sub(net, route, gap_m), script=(ScriptEvent.speed_cap(0.0, 4.0),))
        follower = _spec("F", route, script=(ScriptEvent.inattentive(0.0, 35.0),))
        return _scenario(following_straight, net, (leader, follower), default_gps(), 90.0, seed)

    return _first_place("long straight main-line edge", _straight_states(net), build)


def following_curve(net: TrackMap, *, seed: int = 0, gap_m: float = 120.0) -> Scenario:
    """A fast tram closes in on a slower one through the sharpest curve of the map."""

    def build(curve: tuple[State, float, float]) -> Scenario:
        state, at, _r = curve
        route, where = route_through(
            net, state, at, 250.0, 300.0, need_before_m=60.0 + 0.5 * gap_m, need_after_m=120.0
        )
        leader = _spec(
            "L", _sub(net, route, where - 60.0), script=(ScriptEvent.speed_cap(0.0, 3.0),)
        )
        follower = _spec(
            "F",
            _sub(net, route, max(where - 60.0 - gap_m, 0.0)),
            script=(ScriptEvent.inattentive(0.0, 12.0),),
        )
        scn = _scenario(following_curve, net, (leader, follower), default_gps(), 90.0, seed)
        return _calibrated(scn, "F")

    return _first_place("main-line curve turning 25 degrees or more", curves(net), build)


def leader_behind_curve(net: TrackMap, *, seed: int = 0) -> Scenario:
    """A tram stands just past the sharpest curve; another approaches from 250 m back."""

    def build(curve: tuple[State, float, float]) -> Scenario:
        state, at, _r = curve
        route, where = route_through(
            net, state, at, 280.0, 200.0, need_before_m=150.0, need_after_m=60.0
        )
        leader = _spec("L", _sub(net, route, where + 25.0), script=(ScriptEvent.hold(0.0, None),))
        # the driver looks away for the first 20 s and only then brakes for the standing tram
        follower = _spec("F", route, script=(ScriptEvent.inattentive(0.0, 20.0),))
        scn = _scenario(leader_behind_curve, net, (leader, follower), default_gps(), 80.0, seed)
        return _calibrated(scn, "F")

    return _first_place("main-line curve turning 25 degrees or more", curves(net), build)


def oncoming_double_track(net: TrackMap, *, seed: int = 0) -> Scenario:
    """Two trams pass each other on the two tracks of a double-track line."""

    def build(pair: tuple[State, float, State, float]) -> Scenario:
        a_state, a_at, b_state, b_at = pair
        ra, wa = route_through(net, a_state, a_at, 320.0, 320.0, need_before_m=150.0)
        rb, wb = route_through(net, b_state, b_at, 320.0, 320.0, need_before_m=150.0)
        approach = min(wa, wb)
        ra, rb = _sub(net, ra, wa - approach), _sub(net, rb, wb - approach)
        a = _spec("A", ra, initial_speed_mps=8.0, script=(ScriptEvent.speed_cap(0.0, 8.0),))
        b = _spec("B", rb, initial_speed_mps=8.0, script=(ScriptEvent.speed_cap(0.0, 8.0),))
        return _scenario(oncoming_double_track, net, (a, b), default_gps(), 70.0, seed)

    return _first_place("double-track pair of at least 300 m", double_track_pairs(net), build)


def single_track_head_on(net: TrackMap, *, seed: int = 0) -> Scenario:
    """Two trams enter a single-track section from its two ends."""

    def build(place: tuple[int, float]) -> Scenario:
        e, length = place
        ra, _ = route_through(net, (e, 1), 0.0, 150.0, length, need_before_m=0.0)
        rb, _ = route_through(net, (e, -1), length, 150.0, length, need_before_m=0.0)
        return _scenario(
            single_track_head_on, net, (_spec("A", ra), _spec("B", rb)), default_gps(), 100.0, seed
        )

    return _first_place(
        "main-line single-track (two-way) section of 300 m or more", single_tracks(net), build
    )


def _equal_approaches(
    net: TrackMap, routes: list[tuple[Route, float]], *, min_m: float = 100.0
) -> list[Route]:
    """The routes trimmed to the same distance before their common point, on separate
    tracks (an approach starts past the last track the two approaches share).

    Raises
    ------
    ScenarioUnavailable
        Less than ``min_m`` of separate approach.
    """
    (ra, wa), (rb, wb) = routes
    shared = set(ra.edge_ids[: _step_at(ra, wa) + 1]) & set(rb.edge_ids[: _step_at(rb, wb) + 1])
    starts = []
    for r, where in routes:
        after = [
            float(r.entry_m[k] + r.edge_lengths_m[k])
            for k, (e, _) in enumerate(r.steps)
            if e in shared and r.entry_m[k] < where
        ]
        starts.append(max([0.0, *after]))
    approach = min(wa - starts[0], wb - starts[1])
    if approach < min_m:
        raise ScenarioUnavailable(
            f"the two approaches run on separate tracks for only {approach:.0f} m "
            f"(needs {min_m:.0f} m)"
        )
    return [_sub(net, r, where - approach) for r, where in routes]


def _synchronised(scn: Scenario, at_m: float) -> Scenario:
    """The scenario with the earlier of its two trams departing later, so that both
    fronts reach route distance ``at_m`` (their common point) together; checked with exact
    GPS.

    Raises
    ------
    ScenarioUnavailable
        Even so neither tram needs a warning (the place does not make a conflict).
    """
    alone = Simulator(
        scn.net, list(scn.specs), gps=GpsModel.exact(), seed=scn.seed, yield_at_conflicts=False
    ).run(scn.duration_s)
    arrive = []
    for spec in scn.specs:
        tr = alone.truth[spec.vehicle_id]
        k = int(np.searchsorted(tr.distance_m, at_m))
        arrive.append(float(tr.t_s[k]) if k < len(tr.t_s) else math.inf)
    if not all(math.isfinite(t) for t in arrive):
        raise ScenarioUnavailable(f"{scn.name}: a tram does not reach the conflict point in time")
    first = int(np.argmin(arrive))
    delay = round(max(arrive) - min(arrive))
    specs = list(scn.specs)
    if delay > 0:
        specs[first] = dataclasses.replace(specs[first], depart_s=float(delay))
    out = dataclasses.replace(scn, specs=tuple(specs), duration_s=scn.duration_s + delay)
    if not any(needs_warning(out, sp.vehicle_id, min_cycles=1) for sp in out.specs):
        raise ScenarioUnavailable(f"{scn.name}: the two trams never need a warning here")
    return out


def _step_at(route: Route, distance_m: float) -> int:
    k = int(np.searchsorted(route.entry_m, distance_m, side="left") - 1)
    return min(max(k, 0), len(route.steps) - 1)


def merge_at_switch(net: TrackMap, *, seed: int = 0, approach_m: float = 250.0) -> Scenario:
    """Two trams reach a merging switch from its two branches at the same time."""

    def build(place: tuple[State, State, State]) -> Scenario:
        sa, sb, trunk = place
        approaches = []
        for s in (sa, sb):
            la = net.edge_length(s[0])
            approaches.append(
                route_through(
                    net, s, la if s[1] == 1 else 0.0, approach_m, 0.0, need_before_m=120.0
                )
            )
        ahead = walk(net, trunk, 150.0, forward=True)
        routes = [
            Route.from_steps(net, [*r.steps, trunk, *ahead], start_offset_m=r.start_offset_m)
            for r in _equal_approaches(net, approaches)
        ]
        a = _spec("A", routes[0], initial_speed_mps=7.0, script=(ScriptEvent.speed_cap(0.0, 7.0),))
        b = _spec("B", routes[1], initial_speed_mps=7.0, script=(ScriptEvent.speed_cap(0.0, 7.0),))
        scn = _scenario(merge_at_switch, net, (a, b), default_gps(), 80.0, seed)
        return _synchronised(scn, routes[0].entry_m[len(routes[0].steps) - len(ahead) - 1])

    return _first_place("merging switch enterable from both branches", merge_switches(net), build)


def diamond_crossing(net: TrackMap, *, seed: int = 0, approach_m: float = 250.0) -> Scenario:
    """Two trams reach an at-grade crossing (a diamond, or lines crossing without a shared
    node) on the crossing lines at the same time."""

    def build(place: CrossingLines) -> Scenario:
        approaches = [
            route_through(net, s, at, approach_m, 150.0, need_before_m=120.0, need_after_m=60.0)
            for s, at in ((place.a, place.a_at_m), (place.b, place.b_at_m))
        ]
        routes = _equal_approaches(net, approaches)
        specs = tuple(
            _spec(vid, r, initial_speed_mps=7.0, script=(ScriptEvent.speed_cap(0.0, 7.0),))
            for vid, r in zip(("A", "B"), routes, strict=True)
        )
        note = "(an unnoded crossing)" if place.kind == "crossing" else ""
        scn = _scenario(diamond_crossing, net, specs, default_gps(), 70.0, seed, note=note)
        point = routes[0].distance_of(place.a[0], place.a_at_m)
        return _synchronised(scn, routes[0].length_m - 150.0 if point is None else point)

    return _first_place("at-grade crossing usable on both lines", crossing_lines(net), build)


def leader_emergency(net: TrackMap, *, seed: int = 0) -> Scenario:
    """A leader brakes with the emergency brake 40 s in, 60 m ahead of its follower."""
    base = following_straight(net, seed=seed, gap_m=80.0)
    leader = dataclasses.replace(base.specs[0], script=(ScriptEvent.emergency_brake(40.0),))
    follower = dataclasses.replace(base.specs[1], script=())
    return dataclasses.replace(
        base,
        name="leader_emergency",
        description=leader_emergency.__doc__ or "",
        specs=(leader, follower),
        duration_s=80.0,
    )


def depot_off_map(net: TrackMap, *, seed: int = 0, offset_m: float = 45.0) -> Scenario:
    """A tram shunts in a depot that is not on the map, 45 m beside the line ahead."""
    from trackmap.synthetic import SyntheticNetwork

    base = following_straight(net, seed=seed)
    own = dataclasses.replace(base.specs[1], vehicle_id="A", script=())
    route = own.route
    ahead = min(220.0, route.length_m)
    e, off, d = route.locate(ahead)
    x, y = net.point_at(e, off)
    h = math.radians(net.heading_at(e, off, d))
    px, py = x + offset_m * math.cos(h), y - offset_m * math.sin(h)  # to the right
    if net.candidates_xy(px, py, 30.0):
        raise ScenarioUnavailable("no free space for an off-map depot beside the line")
    lon, lat = net.to_lonlat(px, py)
    depot = SyntheticNetwork(lon0=float(lon), lat0=float(lat))
    dx, dy = math.sin(h), math.cos(h)
    depot.track([(-80.0 * dx, -80.0 * dy), (80.0 * dx, 80.0 * dy)])
    depot_net = depot.build()
    d_route = Route.from_steps(depot_net, [(0, 1)])
    shunter = TramSpec(vehicle_id="D", route=d_route, stops=(), max_speed_mps=3.0)
    return _scenario(
        depot_off_map,
        net,
        (own,),
        default_gps(),
        60.0,
        seed,
        off_map={"D": (depot_net, shunter)},
    )


def tunnel_dropout(net: TrackMap, *, seed: int = 0) -> Scenario:
    """Two trams run through a tunnel without GPS; past the exit the follower, whose driver
    looked away in the tunnel, closes in on the leader standing 150 m beyond the portal."""

    def build(state: State) -> Scenario:
        length = net.edge_length(state[0])
        exit_offset = length if state[1] == 1 else 0.0
        route, exit_at = route_through(
            net,
            state,
            exit_offset,
            length + 250.0,
            400.0,
            need_before_m=length + 60.0,
            need_after_m=200.0,
        )
        entry = max(exit_at - length, 0.0)
        leader = _spec(
            "L", _sub(net, route, exit_at + 150.0), script=(ScriptEvent.hold(0.0, None),)
        )
        start = max(entry - 200.0, 0.0)
        looks_up = (exit_at - start + 20.0) / 12.0  # the driver looks up just past the portal
        follower = _spec(
            "F", _sub(net, route, start), script=(ScriptEvent.inattentive(0.0, looks_up),)
        )
        scn = _scenario(
            tunnel_dropout, net, (leader, follower), default_gps(), looks_up + 60.0, seed
        )
        return _calibrated(scn, "F")

    return _first_place("main-line tunnel", tunnels(net), build)


def wrong_way_single_line(
    net: TrackMap, *, seed: int = 0, gps: ReceiverModel | None = None
) -> Scenario:
    """A tram runs the wrong way on one track of a double track (single-line working after
    a crossover) towards a tram running the right way on it: a head-on conflict on what
    looks like an ordinary double track."""

    def build(place: tuple[tuple[State, float, State, float], list[State] | None]) -> Scenario:
        (_a_state, _a_at, b_state, b_at), chain = place
        wrong = (b_state[0], -b_state[1])
        if chain is not None:
            # over the crossover onto the wrong track; the trams meet 150 m past it
            back = walk(net, chain[0], 250.0, forward=False)
            ahead = walk(net, wrong, 400.0, forward=True, physical=True)
            full = Route.from_steps(net, [*back, *chain, *ahead], wrong_way=True)
            k_in = len(back) + next(
                k for k, st in enumerate(chain) if not net.edges[st[0]].allows(st[1])
            )
            meet = float(full.entry_m[k_in]) + 150.0
            if meet > full.length_m - 50.0:
                raise ScenarioUnavailable("the wrong-way track past the crossover is too short")
            e, off, d = full.locate(meet)
            if net.edges[e].allows(d):
                raise ScenarioUnavailable("the track 150 m past the crossover is not wrong way")
            rw, where_w = trim(net, full, 0.0, min(meet + 250.0, full.length_m)), meet
            o_state, o_at = (e, -d), off
            note = "(it enters over a crossover)"
        else:
            rw, where_w = route_through(
                net, wrong, b_at, 300.0, 250.0, need_before_m=150.0, physical=True
            )
            o_state, o_at = b_state, b_at
            note = "(it starts on the wrong track: no crossover leads there)"
        ro, where_o = route_through(net, o_state, o_at, 400.0, 250.0, need_before_m=150.0)
        approach = min(where_w, where_o, 400.0)
        rw, ro = _sub(net, rw, where_w - approach), _sub(net, ro, where_o - approach)
        cap = (ScriptEvent.speed_cap(0.0, 6.0),)
        w = _spec("W", rw, initial_speed_mps=6.0, script=cap)
        o = _spec("O", ro, initial_speed_mps=6.0, script=cap)
        return _scenario(
            wrong_way_single_line,
            net,
            (w, o),
            gps or default_gps(),
            approach / 6.0 + 25.0,
            seed,
            note=note,
            focus=("W", "O"),
        )

    pairs = double_track_pairs(net)
    chains = [crossover_into(net, (p[2][0], -p[2][1]), within_m=1500.0) for p in pairs[:60]]
    Place = tuple[tuple[State, float, State, float], list[State] | None]
    places: list[Place] = [(p, c) for p, c in zip(pairs, chains, strict=False) if c is not None]
    places += [(p, None) for p in pairs]  # no crossover: start on the wrong track
    return _first_place("double-track pair of at least 300 m", places, build)


def city(net: TrackMap, *, seed: int = 0, trams: int = 20, minutes: float = 30.0) -> Scenario:
    """``trams`` trams on random main-line routes for ``minutes`` minutes."""
    specs = fleet(net, trams, seed)
    return Scenario(
        "city",
        f"{trams} trams on random routes for {minutes:g} minutes",
        net,
        tuple(specs),
        default_gps(),
        60.0 * minutes,
        seed,
    )


SCENARIOS: dict[str, Callable[..., Scenario]] = {
    "following_straight": following_straight,
    "following_curve": following_curve,
    "leader_behind_curve": leader_behind_curve,
    "oncoming_double_track": oncoming_double_track,
    "single_track_head_on": single_track_head_on,
    "merge_at_switch": merge_at_switch,
    "diamond_crossing": diamond_crossing,
    "leader_emergency": leader_emergency,
    "depot_off_map": depot_off_map,
    "tunnel_dropout": tunnel_dropout,
    "wrong_way_single_line": wrong_way_single_line,
    "city": city,
}


def build_scenario(name: str, net: TrackMap, **params: object) -> Scenario:
    """Build a named scenario on a map.

    Raises
    ------
    ValueError
        Unknown scenario name (the message lists the names).
    ScenarioUnavailable
        The map lacks what the scenario needs.
    """
    try:
        builder = SCENARIOS[name]
    except KeyError:
        raise ValueError(f"unknown scenario {name!r}; choose from {', '.join(SCENARIOS)}") from None
    return builder(net, **params)
