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
city                        N trams on random routes for T minutes
==========================  ================================================================
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from antikol.sim import (
    GpsModel,
    Route,
    ScriptEvent,
    SimulationResult,
    Simulator,
    TramSpec,
    fleet,
)
from trackmap import TrackMap

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
    "oncoming_double_track",
    "run_scenario",
    "sharpest_curve",
    "single_track_head_on",
    "tunnel_dropout",
]

logger = logging.getLogger(__name__)


class ScenarioUnavailable(ValueError):
    """The map lacks what a scenario needs (the message says what)."""


@dataclass(frozen=True)
class Scenario:
    """A ready-to-run scenario.

    Attributes
    ----------
    name, description : str
    net : TrackMap
        The map (for simulation and analysis).
    specs : tuple of TramSpec
    gps : GpsModel
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
    gps: GpsModel
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


# -- finding places on a map --------------------------------------------------------------
def _main_state(net: TrackMap, state: tuple[int, int]) -> bool:
    e = net.edges[state[0]]
    return e.service is None and e.allows(state[1])


def _walk(
    net: TrackMap, state: tuple[int, int], length_m: float, *, forward: bool
) -> list[tuple[int, int]]:
    """Steps following (or, backwards, leading into) ``state``, not included, about
    ``length_m`` long: main line first, then the straightest move."""
    steps: list[tuple[int, int]] = []
    total = 0.0
    cur = state
    seen = {state}
    while total < length_m:
        moves = net.traversal.successors(cur) if forward else net.traversal.predecessors(cur)
        options = [m for m in moves if m not in seen]
        if not options:
            break
        options.sort(
            key=lambda m: (
                not _main_state(net, m),
                _turn(net, cur, m) if forward else _turn(net, m, cur),
                m,
            )
        )
        cur = options[0]
        seen.add(cur)
        if forward:
            steps.append(cur)
        else:
            steps.insert(0, cur)
        total += net.edge_length(cur[0])
    return steps


def _walk_back(net: TrackMap, state: tuple[int, int], length_m: float) -> list[tuple[int, int]]:
    return _walk(net, state, length_m, forward=False)


def _walk_ahead(net: TrackMap, state: tuple[int, int], length_m: float) -> list[tuple[int, int]]:
    return _walk(net, state, length_m, forward=True)


def _turn(net: TrackMap, a: tuple[int, int], b: tuple[int, int]) -> float:
    la = net.edge_length(a[0])
    h_in = net.heading_at(a[0], la if a[1] == 1 else 0.0, a[1])
    h_out = net.heading_at(b[0], 0.0 if b[1] == 1 else net.edge_length(b[0]), b[1])
    return abs((h_out - h_in + 180.0) % 360.0 - 180.0)


def _route_through(
    net: TrackMap, state: tuple[int, int], at_m: float, before_m: float, after_m: float
) -> tuple[Route, float]:
    """A route passing ``at_m`` along edge ``state`` with ``before_m`` before and ``after_m``
    after it; returns the route and the route distance of that point."""
    e, d = state
    length = net.edge_length(e)
    into = at_m if d == 1 else length - at_m
    back = _walk_back(net, state, max(before_m - into, 0.0))
    ahead = _walk_ahead(net, state, max(after_m - (length - into), 0.0))
    steps = [*back, state, *ahead]
    route = Route.from_steps(net, steps)
    where = route.distance_of(e, at_m)
    assert where is not None
    start = max(where - before_m, 0.0)
    trimmed = _trim(net, route, start, min(where + after_m, route.length_m))
    return trimmed, where - start


def _trim(net: TrackMap, route: Route, start_m: float, end_m: float) -> Route:
    e0, o0, _ = route.locate(start_m)
    e1, o1, _ = route.locate(end_m)
    k0 = next(k for k, (e, _) in enumerate(route.steps) if e == e0)
    k1 = max(k for k, (e, _) in enumerate(route.steps) if e == e1)
    return Route.from_steps(net, route.steps[k0 : k1 + 1], start_offset_m=o0, end_offset_m=o1)


def _min_radius(net: TrackMap, edge_id: int) -> tuple[float, float, float]:
    """(smallest radius m, where along the edge m, total turning deg) of an edge."""
    g = net.edges[edge_id].geometry
    length = g.length
    if length < 12.0:
        return math.inf, 0.0, 0.0
    s = np.arange(0.0, length, 2.0)
    headings = np.array([_heading(g, x) for x in s])
    turn = np.abs(np.angle(np.exp(1j * np.diff(headings))))  # radians per 2 m
    window = 5  # 10 m chords
    best = (math.inf, 0.0)
    for k in range(len(turn) - window):
        ang = float(turn[k : k + window].sum())
        if ang > math.radians(10.0):
            r = 2.0 * window / ang
            if r < best[0]:
                best = (r, float(s[k + window // 2]))
    return best[0], best[1], math.degrees(float(turn.sum()))


def _heading(g: object, s: float) -> float:
    a = g.interpolate(max(s - 1.0, 0.0))  # type: ignore[attr-defined]
    b = g.interpolate(min(s + 1.0, g.length))  # type: ignore[attr-defined]
    return math.atan2(b.x - a.x, b.y - a.y)


def sharpest_curve(
    net: TrackMap, *, min_radius_m: float = 10.0
) -> tuple[tuple[int, int], float, float]:
    """The main-line state with the sharpest curve: ((edge, direction), offset m, radius m)."""
    best: tuple[float, int, float] | None = None
    for e in net.edges:
        if e.service is not None or e.direction == 0 or _in_short_loop(net, e.edge_id):
            continue
        r, at, total = _min_radius(net, e.edge_id)
        if min_radius_m <= r and total >= 25.0 and (best is None or r < best[0]):
            best = (r, e.edge_id, at)
    if best is None:
        raise ScenarioUnavailable("the map has no main-line curve turning 25 degrees or more")
    radius, edge_id, where = best
    return (edge_id, net.edges[edge_id].direction), where, radius


def _in_short_loop(net: TrackMap, edge_id: int, within_m: float = 600.0) -> bool:
    """Whether the track ahead of an edge comes back to it within ``within_m`` (a turning
    loop, where "ahead" and "behind" meet)."""
    e = net.edges[edge_id]
    paths = net.paths_ahead(
        edge_id, 0.0 if e.direction >= 0 else e.length_m, e.direction or 1, within_m, max_paths=16
    )
    return any(edge_id in p.edges[1:] for p in paths)


def _double_track_pair(net: TrackMap) -> tuple[tuple[int, int], float, tuple[int, int], float]:
    best = None
    for e in sorted(net.edges, key=lambda x: -x.length_m):
        if e.service is not None or e.direction == 0 or e.length_m < 300.0:
            continue
        mid = e.length_m / 2.0
        x, y = net.point_at(e.edge_id, mid)
        h = net.heading_at(e.edge_id, mid, e.direction)
        for c in net.candidates_xy(x, y, 6.0):
            other = net.edges[c.edge_id]
            if c.edge_id == e.edge_id or other.direction == 0 or other.service is not None:
                continue
            oh = net.heading_at(c.edge_id, c.offset_m, other.direction)
            if abs((oh - h + 180.0) % 360.0 - 180.0) > 160.0 and 2.5 < abs(c.lateral_m) < 6.0:
                best = ((e.edge_id, e.direction), mid, (c.edge_id, other.direction), c.offset_m)
                break
        if best:
            return best
    raise ScenarioUnavailable("the map has no double-track pair of at least 300 m")


def _single_track(net: TrackMap) -> tuple[int, float]:
    best = None
    for e in net.edges:
        usable = e.direction == 0 and e.service is None and e.length_m >= 300.0 and not e.tunnel
        if usable and (best is None or e.length_m > net.edges[best].length_m):
            best = e.edge_id
    if best is None:
        raise ScenarioUnavailable(
            "the map has no main-line single-track (two-way) section of 300 m or more"
        )
    return best, net.edges[best].length_m


def _merge_switch(net: TrackMap) -> tuple[tuple[int, int], tuple[int, int], tuple[int, int]]:
    """A merging switch entered from both branches: (branch A state, branch B state, trunk)."""
    for c in sorted(net.conflicts, key=lambda c: c.conflict_id):
        if c.kind != "merge" or c.node_id is None:
            continue
        node = net.nodes[c.node_id]
        trunk, a, b = c.edges
        ends = dict(node.ends)
        states = []
        for e in (a, b):
            d = 1 if ends[e] == 1 else -1  # arriving at the node
            states.append((e, d))
        t_state = (trunk, 1 if ends[trunk] == 0 else -1)
        if all(
            net.traversal.has_edge(s, t_state) and _main_state(net, s) for s in states
        ) and _main_state(net, t_state):
            return states[0], states[1], t_state
    raise ScenarioUnavailable("the map has no merging switch enterable from both branches")


def _diamond(net: TrackMap) -> tuple[tuple[int, int], tuple[int, int]]:
    for c in net.conflicts:
        if c.kind != "diamond_crossing" or c.node_id is None:
            continue
        node = net.nodes[c.node_id]
        lines = []
        for i, j in node.allowed:
            (ea, enda), (eb, endb) = node.ends[i], node.ends[j]
            for (e1, x1), (e2, x2) in (((ea, enda), (eb, endb)), ((eb, endb), (ea, enda))):
                s_in = (e1, 1 if x1 == 1 else -1)
                s_out = (e2, 1 if x2 == 0 else -1)
                if net.traversal.has_edge(s_in, s_out) and _main_state(net, s_in):
                    lines.append(s_in)
                    break
        if len(lines) == 2:
            return lines[0], lines[1]
    raise ScenarioUnavailable("the map has no diamond crossing usable on both lines")


def _tunnel(net: TrackMap) -> tuple[int, int]:
    for e in sorted(net.edges, key=lambda x: -x.length_m):
        if e.tunnel and e.direction != 0 and e.service is None:
            return e.edge_id, e.direction
    raise ScenarioUnavailable("the map has no main-line tunnel")


# -- scenario builders --------------------------------------------------------------------
def _scenario(
    builder: Callable[..., Scenario],
    net: TrackMap,
    specs: tuple[TramSpec, ...],
    gps: GpsModel,
    duration_s: float,
    seed: int,
    *,
    off_map: dict[str, tuple[TrackMap, TramSpec]] | None = None,
) -> Scenario:
    """A scenario named and described by the function that builds it."""
    return Scenario(
        builder.__name__,
        builder.__doc__ or "",
        net,
        specs,
        gps,
        duration_s,
        seed,
        off_map=off_map or {},
    )


def _spec(vid: str, route: Route, **kw: object) -> TramSpec:
    kw.setdefault("stops", ())
    return TramSpec(vehicle_id=vid, route=route, **kw)  # type: ignore[arg-type]


def _sub(net: TrackMap, route: Route, start_m: float) -> Route:
    return _trim(net, route, start_m, route.length_m)


def following_straight(net: TrackMap, *, seed: int = 0, gap_m: float = 150.0) -> Scenario:
    """A fast tram closes in on a slower one on the straightest stretch found."""
    best = None
    for e in sorted(net.edges, key=lambda x: -x.length_m)[:40]:
        if e.service is not None or e.direction == 0:
            continue
        _, _, total = _min_radius(net, e.edge_id)
        if total < 20.0 and (best is None or e.length_m > best.length_m):
            best = e
    if best is None:
        raise ScenarioUnavailable("the map has no long straight main-line edge")
    state = (best.edge_id, best.direction)
    route, _ = _route_through(net, state, best.length_m / 2.0, 300.0, 600.0)
    leader = _spec("L", _sub(net, route, gap_m), script=(ScriptEvent.speed_cap(0.0, 4.0),))
    follower = _spec("F", route, script=(ScriptEvent.inattentive(0.0, 35.0),))
    return _scenario(
        following_straight,
        net,
        (leader, follower),
        default_gps(),
        90.0,
        seed,
    )


def following_curve(net: TrackMap, *, seed: int = 0, gap_m: float = 120.0) -> Scenario:
    """A fast tram closes in on a slower one through the sharpest curve of the map."""
    state, at, _r = sharpest_curve(net)
    route, where = _route_through(net, state, at, 250.0, 300.0)
    leader = _spec("L", _sub(net, route, where - 60.0), script=(ScriptEvent.speed_cap(0.0, 3.0),))
    follower = _spec(
        "F",
        _sub(net, route, max(where - 60.0 - gap_m, 0.0)),
        script=(ScriptEvent.inattentive(0.0, 12.0),),
    )
    return _scenario(
        following_curve,
        net,
        (leader, follower),
        default_gps(),
        90.0,
        seed,
    )


def leader_behind_curve(net: TrackMap, *, seed: int = 0) -> Scenario:
    """A tram stands just past the sharpest curve; another approaches from 250 m back."""
    state, at, _r = sharpest_curve(net)
    route, where = _route_through(net, state, at, 280.0, 200.0)
    leader = _spec("L", _sub(net, route, where + 25.0), script=(ScriptEvent.hold(0.0, None),))
    # the driver looks away for the first 20 s and only then brakes for the standing tram
    follower = _spec("F", route, script=(ScriptEvent.inattentive(0.0, 20.0),))
    return _scenario(
        leader_behind_curve,
        net,
        (leader, follower),
        default_gps(),
        80.0,
        seed,
    )


def oncoming_double_track(net: TrackMap, *, seed: int = 0) -> Scenario:
    """Two trams pass each other on the two tracks of a double-track line."""
    a_state, a_at, b_state, b_at = _double_track_pair(net)
    ra, _ = _route_through(net, a_state, a_at, 320.0, 320.0)
    rb, _ = _route_through(net, b_state, b_at, 320.0, 320.0)
    a = _spec("A", ra, initial_speed_mps=8.0, script=(ScriptEvent.speed_cap(0.0, 8.0),))
    b = _spec("B", rb, initial_speed_mps=8.0, script=(ScriptEvent.speed_cap(0.0, 8.0),))
    return _scenario(
        oncoming_double_track,
        net,
        (a, b),
        default_gps(),
        70.0,
        seed,
    )


def single_track_head_on(net: TrackMap, *, seed: int = 0) -> Scenario:
    """Two trams enter a single-track section from its two ends."""
    e, length = _single_track(net)
    ra, _ = _route_through(net, (e, 1), 0.0, 150.0, length)
    rb, _ = _route_through(net, (e, -1), length, 150.0, length)
    a = _spec("A", ra)
    b = _spec("B", rb)
    return _scenario(
        single_track_head_on,
        net,
        (a, b),
        default_gps(),
        100.0,
        seed,
    )


def merge_at_switch(net: TrackMap, *, seed: int = 0, approach_m: float = 250.0) -> Scenario:
    """Two trams reach a merging switch from its two branches at the same time."""
    sa, sb, trunk = _merge_switch(net)
    routes = []
    for s in (sa, sb):
        la = net.edge_length(s[0])
        route, _ = _route_through(net, s, la if s[1] == 1 else 0.0, approach_m, 0.0)
        steps = [*route.steps, trunk, *_walk_ahead(net, trunk, 150.0)]
        routes.append(Route.from_steps(net, steps, start_offset_m=route.start_offset_m))
    a = _spec("A", routes[0], initial_speed_mps=7.0, script=(ScriptEvent.speed_cap(0.0, 7.0),))
    b = _spec("B", routes[1], initial_speed_mps=7.0, script=(ScriptEvent.speed_cap(0.0, 7.0),))
    return _scenario(merge_at_switch, net, (a, b), default_gps(), 80.0, seed)


def diamond_crossing(net: TrackMap, *, seed: int = 0, approach_m: float = 250.0) -> Scenario:
    """Two trams reach a diamond crossing on the crossing lines at the same time."""
    sa, sb = _diamond(net)
    specs = []
    for vid, s in (("A", sa), ("B", sb)):
        la = net.edge_length(s[0])
        route, _ = _route_through(net, s, la if s[1] == 1 else 0.0, approach_m, 150.0)
        specs.append(
            _spec(vid, route, initial_speed_mps=7.0, script=(ScriptEvent.speed_cap(0.0, 7.0),))
        )
    return _scenario(
        diamond_crossing,
        net,
        tuple(specs),
        default_gps(),
        70.0,
        seed,
    )


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
    state = _tunnel(net)
    length = net.edge_length(state[0])
    exit_offset = length if state[1] == 1 else 0.0
    route, exit_at = _route_through(net, state, exit_offset, length + 250.0, 400.0)
    entry = max(exit_at - length, 0.0)
    leader = _spec("L", _sub(net, route, exit_at + 150.0), script=(ScriptEvent.hold(0.0, None),))
    start = max(entry - 200.0, 0.0)
    looks_up = (exit_at - start + 20.0) / 12.0  # the driver looks up just past the portal
    follower = _spec("F", _sub(net, route, start), script=(ScriptEvent.inattentive(0.0, looks_up),))
    return _scenario(
        tunnel_dropout,
        net,
        (leader, follower),
        default_gps(),
        looks_up + 60.0,
        seed,
    )


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
