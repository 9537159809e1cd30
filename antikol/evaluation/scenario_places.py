"""Finding the places a scenario needs on any track map, and routes through them.

Every finder returns *all* usable places, best first, so that a scenario can fall back to
the next one when the first lies too close to the edge of the map (an extract cut out of
a city ends in stubs). :func:`route_through` raises :class:`ScenarioUnavailable` when the
track around a place is shorter than a scenario needs; the message says how much is there.

States are ``(edge_id, direction)`` as in :mod:`trackmap.network`; offsets are metres from
an edge's first vertex.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import networkx as nx
import numpy as np

from antikol.sim import Route
from trackmap import TrackMap

__all__ = [
    "CrossingLines",
    "ScenarioUnavailable",
    "crossing_lines",
    "crossover_into",
    "curves",
    "double_track_pairs",
    "merge_switches",
    "route_through",
    "sharpest_curve",
    "single_tracks",
    "trim",
    "tunnels",
    "walk",
]

State = tuple[int, int]


class ScenarioUnavailable(ValueError):
    """The map lacks what a scenario needs (the message says what)."""


def main_state(net: TrackMap, state: State) -> bool:
    """Whether a state is main-line track run in a permitted direction."""
    e = net.edges[state[0]]
    return e.service is None and e.allows(state[1])


def _turn(net: TrackMap, a: State, b: State) -> float:
    la = net.edge_length(a[0])
    h_in = net.heading_at(a[0], la if a[1] == 1 else 0.0, a[1])
    h_out = net.heading_at(b[0], 0.0 if b[1] == 1 else net.edge_length(b[0]), b[1])
    return abs((h_out - h_in + 180.0) % 360.0 - 180.0)


def walk(
    net: TrackMap, state: State, length_m: float, *, forward: bool, physical: bool = False
) -> list[State]:
    """Steps following (or, backwards, leading into) ``state``, not included, about
    ``length_m`` long: main line first, then the straightest move.

    Parameters
    ----------
    net : TrackMap
    state : (int, int)
    length_m : float
        Wanted length, metres (less at a dead end).
    forward : bool
        Ahead of the state, or behind it.
    physical : bool
        Follow every physical move (``net.traversal_any``), not only permitted ones.
    """
    graph = net.traversal_any if physical else net.traversal
    steps: list[State] = []
    total = 0.0
    cur = state
    seen = {state}
    while total < length_m:
        if cur not in graph:
            break
        moves = graph.successors(cur) if forward else graph.predecessors(cur)
        options = [m for m in moves if m not in seen]
        if not options:
            break
        options.sort(
            key=lambda m: (
                not main_state(net, m),
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


def trim(net: TrackMap, route: Route, start_m: float, end_m: float) -> Route:
    """The part of a route between two route distances (metres, clamped to the route)."""
    start_m = min(max(start_m, 0.0), route.length_m)
    end_m = min(max(end_m, start_m), route.length_m)
    e0, o0, _ = route.locate(start_m)
    e1, o1, _ = route.locate(end_m)
    k0 = int(np.searchsorted(route.entry_m, start_m, side="right") - 1)
    k1 = int(np.searchsorted(route.entry_m, end_m, side="right") - 1)
    k0 = min(max(k0, 0), len(route.steps) - 1)
    k1 = min(max(k1, k0), len(route.steps) - 1)
    if route.steps[k0][0] != e0:  # at a junction locate() gives the later step
        k0 = next(k for k in range(k0, len(route.steps)) if route.steps[k][0] == e0)
    if route.steps[k1][0] != e1:
        k1 = next(k for k in range(k1, len(route.steps)) if route.steps[k][0] == e1)
    return Route.from_steps(
        net,
        route.steps[k0 : k1 + 1],
        start_offset_m=o0,
        end_offset_m=o1,
        wrong_way=route.wrong_way,
    )


def route_through(
    net: TrackMap,
    state: State,
    at_m: float,
    before_m: float,
    after_m: float,
    *,
    need_before_m: float | None = None,
    need_after_m: float | None = None,
    physical: bool = False,
) -> tuple[Route, float]:
    """A route passing ``at_m`` along ``state``'s edge, ``before_m`` before and ``after_m``
    after it (less where the track ends).

    Parameters
    ----------
    net : TrackMap
    state : (int, int)
    at_m : float
        Offset on the state's edge, metres.
    before_m, after_m : float
        Wanted track before and after the point, metres.
    need_before_m, need_after_m : float, optional
        Least acceptable track before and after, metres (default: all that is wanted).
    physical : bool
        Walk physical moves (a wrong-way route) rather than permitted ones.

    Returns
    -------
    (Route, float)
        The route and the route distance of the point.

    Raises
    ------
    ScenarioUnavailable
        Less track than needed around the point.
    """
    e, d = state
    length = net.edge_length(e)
    into = at_m if d == 1 else length - at_m
    back = walk(net, state, max(before_m - into, 0.0), forward=False, physical=physical)
    ahead = walk(net, state, max(after_m - (length - into), 0.0), forward=True, physical=physical)
    route = Route.from_steps(net, [*back, state, *ahead], wrong_way=physical)
    where = route.distance_of(e, at_m, after_m=route.entry_m[len(back)] if back else 0.0)
    if where is None:  # pragma: no cover - the point lies on the route by construction
        raise ScenarioUnavailable(f"edge {e} offset {at_m:.1f} m is not on its own route")
    need_b = before_m if need_before_m is None else need_before_m
    need_a = after_m if need_after_m is None else need_after_m
    have_b, have_a = where, route.length_m - where
    if have_b < need_b - 1e-6 or have_a < need_a - 1e-6:
        raise ScenarioUnavailable(
            f"only {have_b:.0f} m of track before and {have_a:.0f} m after edge {e} "
            f"(needs {need_b:.0f} m and {need_a:.0f} m)"
        )
    start = max(where - before_m, 0.0)
    return trim(net, route, start, min(where + after_m, route.length_m)), where - start


# -- curves --------------------------------------------------------------------------------
def _heading(g: object, s: float) -> float:
    a = g.interpolate(max(s - 1.0, 0.0))  # type: ignore[attr-defined]
    b = g.interpolate(min(s + 1.0, g.length))  # type: ignore[attr-defined]
    return math.atan2(b.x - a.x, b.y - a.y)


def min_radius(net: TrackMap, edge_id: int) -> tuple[float, float, float]:
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


def _in_short_loop(net: TrackMap, edge_id: int, within_m: float = 600.0) -> bool:
    """Whether the track ahead of an edge comes back to it within ``within_m`` (a turning
    loop, where "ahead" and "behind" meet)."""
    e = net.edges[edge_id]
    paths = net.paths_ahead(
        edge_id, 0.0 if e.direction >= 0 else e.length_m, e.direction or 1, within_m, max_paths=16
    )
    return any(edge_id in p.edges[1:] for p in paths)


def curves(net: TrackMap, *, min_radius_m: float = 10.0) -> list[tuple[State, float, float]]:
    """Main-line curves turning 25 degrees or more, sharpest first.

    Returns
    -------
    list of ((int, int), float, float)
        ``(state, offset m, radius m)`` of each curve's sharpest point.
    """
    found: list[tuple[float, int, float]] = []
    for e in net.edges:
        if e.service is not None or e.direction == 0:
            continue
        r, at, total = min_radius(net, e.edge_id)
        if min_radius_m <= r and total >= 25.0:
            found.append((r, e.edge_id, at))
    found.sort()
    return [
        ((edge_id, net.edges[edge_id].direction), at, r)
        for r, edge_id, at in found
        if not _in_short_loop(net, edge_id)
    ]


def sharpest_curve(net: TrackMap, *, min_radius_m: float = 10.0) -> tuple[State, float, float]:
    """The main-line state with the sharpest curve: ((edge, direction), offset m, radius m)."""
    found = curves(net, min_radius_m=min_radius_m)
    if not found:
        raise ScenarioUnavailable("the map has no main-line curve turning 25 degrees or more")
    return found[0]


# -- double and single track ---------------------------------------------------------------
def double_track_pairs(
    net: TrackMap, *, min_length_m: float = 300.0
) -> list[tuple[State, float, State, float]]:
    """Pairs of main-line tracks side by side running opposite ways, longest edge first.

    Returns
    -------
    list of ((int, int), float, (int, int), float)
        Each track's state and the offset of the pair's midpoint on it.
    """
    out = []
    for e in sorted(net.edges, key=lambda x: -x.length_m):
        if e.service is not None or e.direction == 0 or e.length_m < min_length_m:
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
                out.append(
                    ((e.edge_id, e.direction), mid, (c.edge_id, other.direction), c.offset_m)
                )
                break
    return out


def single_tracks(net: TrackMap, *, min_length_m: float = 300.0) -> list[tuple[int, float]]:
    """Main-line two-way (single-track) edges of ``min_length_m`` or more, longest first."""
    found = [
        (e.edge_id, e.length_m)
        for e in net.edges
        if e.direction == 0 and e.service is None and e.length_m >= min_length_m and not e.tunnel
    ]
    return sorted(found, key=lambda item: -item[1])


# -- junctions -----------------------------------------------------------------------------
def merge_switches(net: TrackMap) -> list[tuple[State, State, State]]:
    """Merging switches entered from both branches: (branch A, branch B, trunk) states."""
    out = []
    for c in sorted(net.conflicts, key=lambda c: c.conflict_id):
        if c.kind != "merge" or c.node_id is None:
            continue
        node = net.nodes[c.node_id]
        trunk, a, b = c.edges
        ends = dict(node.ends)
        states = [(e, 1 if ends[e] == 1 else -1) for e in (a, b)]  # arriving at the node
        t_state = (trunk, 1 if ends[trunk] == 0 else -1)
        if all(
            net.traversal.has_edge(s, t_state) and main_state(net, s) for s in states
        ) and main_state(net, t_state):
            out.append((states[0], states[1], t_state))
    return out


@dataclass(frozen=True, slots=True)
class CrossingLines:
    """Two main-line tracks crossing at grade, and where.

    Attributes
    ----------
    kind : str
        ``diamond_crossing`` (a shared node) or ``crossing`` (no shared node).
    a, b : (int, int)
        The state on each line that runs into (noded) or through (unnoded) the crossing.
    a_at_m, b_at_m : float
        Offset of the crossing point on each state's edge, metres.
    """

    kind: str
    a: State
    a_at_m: float
    b: State
    b_at_m: float


def crossing_lines(net: TrackMap) -> list[CrossingLines]:
    """At-grade crossings usable on both lines: diamond crossings (noded) first, then
    unnoded crossings (``ConflictPoint`` of kind ``crossing``)."""
    out: list[CrossingLines] = []
    for c in sorted(net.conflicts, key=lambda c: c.conflict_id):
        if c.kind != "diamond_crossing" or c.node_id is None:
            continue
        node = net.nodes[c.node_id]
        lines = []
        for i, j in node.allowed:
            (ea, enda), (eb, endb) = node.ends[i], node.ends[j]
            for (e1, x1), (e2, x2) in (((ea, enda), (eb, endb)), ((eb, endb), (ea, enda))):
                s_in = (e1, 1 if x1 == 1 else -1)
                s_out = (e2, 1 if x2 == 0 else -1)
                if net.traversal.has_edge(s_in, s_out) and main_state(net, s_in):
                    lines.append(s_in)
                    break
        if len(lines) == 2:
            (a, b) = lines
            at = [net.edge_length(s[0]) if s[1] == 1 else 0.0 for s in (a, b)]
            out.append(CrossingLines("diamond_crossing", a, at[0], b, at[1]))
    for c in sorted(net.conflicts, key=lambda c: c.conflict_id):
        if c.kind != "crossing" or len(c.edges) != 2:
            continue
        states = []
        for e in c.edges:
            edge = net.edges[e]
            d = edge.direction or 1
            if edge.service is None and edge.allows(d):
                states.append((e, d))
        if len(states) == 2:
            out.append(
                CrossingLines("crossing", states[0], c.offsets_m[0], states[1], c.offsets_m[1])
            )
    return out


def tunnels(net: TrackMap) -> list[State]:
    """Main-line one-way tunnel edges, longest first."""
    return [
        (e.edge_id, e.direction)
        for e in sorted(net.edges, key=lambda x: -x.length_m)
        if e.tunnel and e.direction != 0 and e.service is None
    ]


def crossover_into(net: TrackMap, state: State, *, within_m: float = 400.0) -> list[State] | None:
    """How a tram gets onto a wrong-way ``state`` from permitted track: the shortest chain
    of physical moves from a permitted main-line state into ``state``.

    Parameters
    ----------
    net : TrackMap
    state : (int, int)
        A state against its edge's permitted direction.
    within_m : float
        Search this far back, metres.

    Returns
    -------
    list of (int, int) or None
        The chain from the permitted state (first) to ``state`` (last), or None when no
        crossover leads there within ``within_m``.
    """
    graph: nx.DiGraph = net.traversal_any
    if state not in graph:
        return None
    parent: dict[State, State | None] = {state: None}
    queue: deque[tuple[State, float]] = deque([(state, 0.0)])
    while queue:
        cur, dist = queue.popleft()
        if cur != state and main_state(net, cur):
            chain = [cur]
            nxt = parent[cur]
            while nxt is not None:
                chain.append(nxt)
                nxt = parent[nxt]
            return chain
        if dist > within_m:
            continue
        for p in graph.predecessors(cur):
            if p not in parent:
                parent[p] = cur
                queue.append((p, dist + net.edge_length(p[0])))
    return None
