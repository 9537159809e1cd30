"""Route building: random walks along permitted moves and routes through listed edges.

Random routes start uniformly along the track, preferably on the main line's largest
strongly connected part (:func:`start_table`, cached per map), so that fleets of trams
(:mod:`antikol.sim.fleet`) spread over the network and rarely run into dead ends.
"""

from __future__ import annotations

import logging
import math
import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import networkx as nx
import numpy as np
import numpy.typing as npt

from antikol.sim.routes import Route, move_hint
from trackmap import TrackMap

__all__ = [
    "StartTable",
    "as_generator",
    "random_route",
    "random_start",
    "route_from_edges",
    "start_table",
]

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class StartTable:
    """Running states random routes may start on, with their cumulative track length.

    Attributes
    ----------
    states : tuple of (int, int)
        ``(edge_id, direction)`` of the main line's largest strongly connected part.
    members : frozenset of (int, int)
        The same states, for membership tests.
    cum_m : ndarray
        Cumulative track length over ``states``, metres.
    all_states : tuple of (int, int)
        Every running state of the map.
    all_cum_m : ndarray
        Cumulative track length over ``all_states``, metres.
    """

    states: tuple[tuple[int, int], ...]
    members: frozenset[tuple[int, int]]
    cum_m: FloatArray
    all_states: tuple[tuple[int, int], ...]
    all_cum_m: FloatArray


_START_CACHE: dict[int, tuple[weakref.ref[TrackMap], StartTable]] = {}


def start_table(net: TrackMap) -> StartTable:
    """Where random routes may start (cached per map)."""
    hit = _START_CACHE.get(id(net))
    if hit is not None and hit[0]() is net:
        return hit[1]
    main = [s for s in net.traversal.nodes if net.edges[s[0]].service is None]
    comps: list[set[tuple[int, int]]] = list(
        nx.strongly_connected_components(net.traversal.subgraph(main))
    )
    best = sorted(comps[int(np.argmax([len(c) for c in comps]))]) if comps else []
    every = sorted(net.traversal.nodes)

    def cum(states: Sequence[tuple[int, int]]) -> FloatArray:
        return np.cumsum([net.edge_length(e) for e, _ in states], dtype=np.float64)

    table = StartTable(tuple(best), frozenset(best), cum(best), tuple(every), cum(every))
    _START_CACHE[id(net)] = (weakref.ref(net), table)
    return table


def as_generator(rng: np.random.Generator | int | None) -> np.random.Generator:
    """The generator itself, or a new one seeded with ``rng`` (an int or None)."""
    if isinstance(rng, np.random.Generator):
        return rng
    return np.random.default_rng(rng)


def random_start(
    net: TrackMap, gen: np.random.Generator, *, prefer_main: bool
) -> tuple[tuple[int, int], float]:
    """A random running position, uniform along the track.

    Parameters
    ----------
    net : TrackMap
    gen : numpy.random.Generator
    prefer_main : bool
        Draw from the main line's largest strongly connected part when the map has one.

    Returns
    -------
    state : (int, int)
        ``(edge_id, direction)``.
    offset_m : float
        Metres from the edge's first vertex.

    Raises
    ------
    ValueError
        The map has no track a tram may run on.
    """
    table = start_table(net)
    states, cum = (table.states, table.cum_m) if prefer_main else ((), np.zeros(0))
    if not states:
        states, cum = table.all_states, table.all_cum_m
    if not states:
        raise ValueError("the map has no track a tram may run on")
    u = float(gen.uniform(0.0, cum[-1]))
    k = min(int(np.searchsorted(cum, u, side="right")), len(states) - 1)
    edge_id, direction = states[k]
    length = net.edge_length(edge_id)
    offset = min(max(u - (cum[k] - length), 0.0), length)
    return (edge_id, direction), offset


def random_route(
    net: TrackMap,
    rng: np.random.Generator | int | None,
    *,
    length_m: float,
    start: tuple[int, float, int] | None = None,
    prefer_main: bool = True,
) -> Route:
    """A random walk along permitted moves.

    Parameters
    ----------
    net : TrackMap
    rng : numpy.random.Generator or int or None
        Random source (an int seeds a new generator).
    length_m : float
        Wanted route length, metres (> 0). The route is shorter only at a dead end.
    start : (edge_id, offset_m, direction), optional
        Start position; default a random position on the map, uniform along the track
        (on the main line's largest strongly connected part when ``prefer_main``).
    prefer_main : bool
        Avoid ``service`` tracks (yards, sidings, spurs, crossovers) and moves that leave
        the main line's strongly connected part (which lead to dead ends) whenever another
        branch is possible.

    Returns
    -------
    Route

    Raises
    ------
    ValueError
        ``length_m`` is not positive, or ``start`` is not a permitted running position.
    """
    if not (math.isfinite(length_m) and length_m > 0.0):
        raise ValueError(f"length_m must be a positive number of metres, got {length_m!r}")
    gen = as_generator(rng)
    if start is None:
        state, offset = random_start(net, gen, prefer_main=prefer_main)
    else:
        edge_id, offset, direction = int(start[0]), float(start[1]), int(start[2])
        edge = net.edge(edge_id)
        if direction not in (1, -1) or not edge.allows(direction):
            raise ValueError(
                f"start: edge {edge_id} does not permit running direction {direction!r} "
                f"(permitted: {edge.direction:+d})"
            )
        if not 0.0 <= offset <= net.edge_length(edge_id):
            raise ValueError(
                f"start offset {offset!r} m is outside edge {edge_id} "
                f"(0..{net.edge_length(edge_id):.3f} m)"
            )
        state = (edge_id, direction)
    main = start_table(net).members if prefer_main else frozenset()
    first_len = net.edge_length(state[0])
    ahead = first_len - offset if state[1] == 1 else offset
    steps = [state]
    remaining = length_m - ahead
    while remaining > 0.0:
        succ = sorted(net.successors(*steps[-1]))
        if prefer_main and succ:
            on_main = [s for s in succ if net.edges[s[0]].service is None]
            in_scc = [s for s in on_main if s in main]
            succ = in_scc or on_main or succ
        if not succ:
            logger.debug("random_route: dead end after %d steps", len(steps))
            remaining = 0.0
            break
        nxt = succ[int(gen.integers(len(succ)))]
        steps.append(nxt)
        remaining -= net.edge_length(nxt[0])
    last_e, last_d = steps[-1]
    last_len = net.edge_length(last_e)
    overshoot = -remaining  # how far the last edge extends beyond the wanted length
    if len(steps) == 1:
        end = offset + last_d * min(length_m, ahead)
    else:
        end = last_len - overshoot if last_d == 1 else overshoot
    end = min(max(end, 0.0), last_len)
    return Route.from_steps(net, steps, start_offset_m=offset, end_offset_m=end)


def route_from_edges(
    net: TrackMap,
    edge_ids: Sequence[int],
    *,
    start_offset_m: float | None = None,
    end_offset_m: float | None = None,
    direction: int | None = None,
) -> Route:
    """A route through a list of edges, the running directions inferred.

    Parameters
    ----------
    net : TrackMap
    edge_ids : sequence of int
        Edges in running order.
    start_offset_m, end_offset_m : float, optional
        Start on the first and end on the last edge, metres from their first vertex;
        default the whole edges.
    direction : int, optional
        Running direction on the first edge, for a one-edge route or when the edges can
        be run both ways; default: inferred (+1 when still ambiguous).

    Returns
    -------
    Route

    Raises
    ------
    trackmap.UnknownEdgeError
        An edge id is not in the map.
    ValueError
        Two consecutive edges are not connected by a permitted move (the message names the
        pair and their positions in the list), or ``direction`` is not permitted.
    """
    ids = [int(e) for e in edge_ids]
    if not ids:
        raise ValueError("route_from_edges needs at least one edge id")
    for e in ids:
        net.edge(e)
    if direction is not None and direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    first = net.edges[ids[0]]
    cand = [direction] if direction is not None else [d for d in (1, -1) if first.allows(d)]
    cand = [d for d in cand if first.allows(d)]
    if not cand:
        raise ValueError(
            f"edge {ids[0]} does not permit running direction {direction!r} "
            f"(permitted: {first.direction:+d})"
        )
    layers: list[dict[int, int | None]] = [{d: None for d in cand}]
    for k in range(1, len(ids)):
        cur: dict[int, int | None] = {}
        for d_prev in sorted(layers[-1], reverse=True):
            for e2, d2 in net.successors(ids[k - 1], d_prev):
                if e2 == ids[k] and d2 not in cur:
                    cur[d2] = d_prev
        if not cur:
            hint = ""
            for d_prev in layers[-1]:
                for d2 in (1, -1):
                    hint = hint or move_hint(net, (ids[k - 1], d_prev), (ids[k], d2))
            raise ValueError(
                f"edges {ids[k - 1]} and {ids[k]} (positions {k - 1} and {k} in the list) "
                f"are not connected by a permitted move{hint}"
            )
        layers.append(cur)
    d_last = 1 if 1 in layers[-1] else -1
    dirs = [d_last]
    for k in range(len(ids) - 1, 0, -1):
        prev = layers[k][dirs[-1]]
        if prev is None:  # pragma: no cover - every layer was built from a connected one
            raise RuntimeError(f"route direction lost at step {k}")
        dirs.append(prev)
    dirs.reverse()
    return Route.from_steps(
        net,
        list(zip(ids, dirs, strict=True)),
        start_offset_m=start_offset_m,
        end_offset_m=end_offset_m,
    )
