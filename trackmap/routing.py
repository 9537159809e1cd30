"""Routing on a track map: the traversal graphs, the routes ahead and along-track distances.

A vehicle on the track is in a :class:`~trackmap.model.TrackState`: an edge and a running
direction. The traversal graph has a node per state and an arc per move a vehicle can make
through a junction node, from the end of one edge onto the next. As networkx keeps its
algorithms apart from its graph classes, the searches here are plain functions of a map
(:func:`paths_ahead`, :func:`route_distance`, :func:`path_geometry`);
:class:`trackmap.TrackMap` calls them from its methods of the same names.

The functions need only the parts of a map listed by :class:`RoutableMap`, of which the
:class:`RoutingIndex` (graphs and look-up tables built once per map) does the work.

>>> import trackmap
>>> from trackmap import routing
>>> net = trackmap.load_default()
>>> cand = net.candidates(19.93260, 50.06306, radius_m=25.0)[0]
>>> paths = routing.paths_ahead(net, cand.edge_id, cand.offset_m, 1, 300.0)
>>> paths == net.paths_ahead(cand.edge_id, cand.offset_m, 1, 300.0)
True
"""

from __future__ import annotations

import heapq
import logging
import math
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

import networkx as nx
import numpy as np
import shapely
import shapely.ops

from trackmap.kinds import ConflictKind, Direction, NodeClass, PathEnd
from trackmap.model import (
    ConflictPass,
    ConflictPoint,
    Edge,
    FloatArray,
    Node,
    NodePass,
    Path,
    PathStep,
    RouteDistance,
    TrackState,
)
from trackmap.records import positional

__all__ = [
    "RoutableMap",
    "RoutingIndex",
    "facing_choices",
    "path_geometry",
    "paths_ahead",
    "route_distance",
    "traversal_graph",
]


logger = logging.getLogger(__name__)

#: A move between two states (TrackState or equal plain tuples): an arc of the traversal graph.
Move = tuple[tuple[int, int], tuple[int, int]]


# -- the graphs ---------------------------------------------------------------------------
def traversal_graph(
    edges: Sequence[Edge],
    nodes: Iterable[Node],
    lengths_m: FloatArray,
    *,
    respect_direction: bool,
) -> nx.DiGraph:
    """The graph of moves between track states.

    Parameters
    ----------
    edges : sequence of Edge
        The map's edges, ids 0..n-1 in order.
    nodes : iterable of Node
        The junction nodes with their allowed moves.
    lengths_m : ndarray
        Length of each edge, metres (stored on each state as ``length``).
    respect_direction : bool
        Keep only the states of permitted running directions (else every physical move).

    Returns
    -------
    networkx.DiGraph
        Nodes are :class:`TrackState`; each arc carries the junction's ``node`` id.
    """
    g = nx.DiGraph()
    # one TrackState per state, shared by the node and every arc: the successors are then
    # the very objects the graph is keyed by, and no named tuple is built twice
    states: dict[tuple[int, int], TrackState] = {}
    for e in edges:
        for d in (Direction.FORWARD, Direction.BACKWARD):
            if e.allows(d) or not respect_direction:
                states[(e.edge_id, d)] = state = TrackState(e.edge_id, d)
                g.add_node(state, length=lengths_m[e.edge_id])
    for node in nodes:
        for i, j in node.allowed:
            for a, b in ((i, j), (j, i)):
                ea, enda = node.ends[a]
                eb, endb = node.ends[b]
                # arriving at an edge's last vertex means running forward on it; leaving
                # from its first vertex, too
                arrive = states.get((ea, 1 if enda == 1 else -1))
                leave = states.get((eb, 1 if endb == 0 else -1))
                if arrive is not None and leave is not None:
                    g.add_edge(arrive, leave, node=node.node_id)
    return g


def facing_choices(
    graph: nx.DiGraph, geometries: Sequence[shapely.LineString], lengths_m: FloatArray
) -> dict[Move, str]:
    """Label the options at facing switches: ``straight``, ``left`` or ``right``.

    Parameters
    ----------
    graph : networkx.DiGraph
        A traversal graph (:func:`traversal_graph`).
    geometries : sequence of LineString
        Edge lines in the local frame, metres.
    lengths_m : ndarray
        Length of each edge, metres.

    Returns
    -------
    dict
        Label of each move out of a state with more than one successor. Where two moves
        would get the same label (e.g. three-way points), the label gains the edge id
        (``left:12``).
    """
    labels: dict[Move, str] = {}
    for u in graph.nodes:
        succ = list(graph.successors(u))
        if len(succ) < 2:
            continue
        heading_in = _end_heading(geometries, lengths_m, u, arriving=True)
        turns = []
        for v in succ:
            heading_out = _end_heading(geometries, lengths_m, v, arriving=False)
            turns.append((heading_out - heading_in + 180.0) % 360.0 - 180.0)
        straightest = int(np.argmin(np.abs(turns)))
        for k, v in enumerate(succ):
            if k == straightest and abs(turns[k]) < 0.5 * max(abs(t) for t in turns) + 1e-9:
                labels[(u, v)] = "straight"
            else:
                labels[(u, v)] = "left" if turns[k] < 0 else "right"
        if len(set(labels[(u, v)] for v in succ)) < len(succ):
            for v in succ:
                labels[(u, v)] = f"{labels[(u, v)]}:{v[0]}"
    return labels


def _end_heading(
    geometries: Sequence[shapely.LineString],
    lengths_m: FloatArray,
    state: TrackState,
    *,
    arriving: bool,
    probe_m: float = 10.0,
) -> float:
    """Grid heading of travel at the end of an edge a state arrives at or leaves from."""
    edge_id, direction = state
    geom = geometries[edge_id]
    length = lengths_m[edge_id]
    d = min(probe_m, length)
    if direction == 1:
        a, b = (length - d, length) if arriving else (0.0, d)
    else:
        a, b = (d, 0.0) if arriving else (length, length - d)
    p, q = geom.interpolate(a), geom.interpolate(b)
    return math.degrees(math.atan2(q.x - p.x, q.y - p.y)) % 360.0


@dataclass(frozen=True, slots=True, eq=False)
class RoutingIndex:
    """What routing looks up at every step, built once per map.

    Attributes
    ----------
    traversal : networkx.DiGraph
        Permitted moves between :class:`TrackState` nodes (respecting running directions).
    traversal_any : networkx.DiGraph
        Every physical move, ignoring running directions.
    lengths_m : ndarray
        Length of each edge, metres.
    choices : dict
        Label of each move at a facing switch (:func:`facing_choices`).
    crossings_by_edge : dict
        Unnoded crossings on each edge: sorted (offset_m, conflict_id) pairs.
    conflicts_by_node : dict
        Conflict ids at each junction node.
    edge_lengths_m : tuple of float
        ``lengths_m`` as Python floats (the searches' arithmetic on them is several times
        cheaper than on numpy scalars, with the same results).
    moves, moves_any : dict
        The successors of each state in ``traversal`` and ``traversal_any``, in the
        graphs' order, as tuples (a dict look-up; asking networkx costs several times it).
    node_conflicts : dict
        (conflict id, kind) of the conflicts at each junction node.
    """

    traversal: nx.DiGraph
    traversal_any: nx.DiGraph
    lengths_m: FloatArray
    choices: Mapping[Move, str]
    crossings_by_edge: Mapping[int, Sequence[tuple[float, int]]]
    conflicts_by_node: Mapping[int, Sequence[int]]
    edge_lengths_m: tuple[float, ...]
    moves: Mapping[TrackState, tuple[TrackState, ...]]
    moves_any: Mapping[TrackState, tuple[TrackState, ...]]
    node_conflicts: Mapping[int, tuple[tuple[int, ConflictKind], ...]]

    @classmethod
    def build(
        cls,
        edges: Sequence[Edge],
        nodes: Mapping[int, Node],
        conflicts: Sequence[ConflictPoint],
        lengths_m: FloatArray,
    ) -> RoutingIndex:
        """Index a map's records (edges with ids 0..n-1 in order, lengths in metres)."""
        traversal = traversal_graph(edges, nodes.values(), lengths_m, respect_direction=True)
        traversal_any = traversal_graph(edges, nodes.values(), lengths_m, respect_direction=False)
        crossings: dict[int, list[tuple[float, int]]] = defaultdict(list)
        at_node: dict[int, list[int]] = defaultdict(list)
        for c in conflicts:
            if c.node_id is None:
                for eid, off in zip(c.edges, c.offsets_m, strict=True):
                    crossings[eid].append((off, c.conflict_id))
            else:
                at_node[c.node_id].append(c.conflict_id)
        for lst in crossings.values():
            lst.sort()
        geometries = [e.geometry for e in edges]
        kinds = {c.conflict_id: c.kind for c in conflicts}
        return cls(
            traversal=traversal,
            traversal_any=traversal_any,
            lengths_m=lengths_m,
            choices=facing_choices(traversal_any, geometries, lengths_m),
            crossings_by_edge=dict(crossings),
            conflicts_by_node=dict(at_node),
            edge_lengths_m=tuple(lengths_m.tolist()),
            moves={s: tuple(traversal.successors(s)) for s in traversal},
            moves_any={s: tuple(traversal_any.successors(s)) for s in traversal_any},
            node_conflicts={
                node: tuple((cid, kinds[cid]) for cid in ids) for node, ids in at_node.items()
            },
        )

    def graph(self, *, respect_direction: bool) -> nx.DiGraph:
        """The traversal graph of permitted moves, or of every physical move."""
        return self.traversal if respect_direction else self.traversal_any


class RoutableMap(Protocol):
    """The parts of a map routing reads (:class:`trackmap.TrackMap` has them all)."""

    @property
    def edges(self) -> Sequence[Edge]: ...

    @property
    def nodes(self) -> Mapping[int, Node]: ...

    @property
    def conflicts(self) -> Sequence[ConflictPoint]: ...

    @property
    def routing_index(self) -> RoutingIndex: ...

    def edge(self, edge_id: int) -> Edge: ...


#: Running directions by value: a dict look-up costs a tenth of ``Direction(value)``.
_DIRECTIONS = {1: Direction.FORWARD, -1: Direction.BACKWARD}
#: The searches test ``direction is _FORWARD`` and add or subtract rather than compare or
#: multiply an IntEnum: arithmetic on an int subclass misses the interpreter's fast paths
#: and cost ~10 % of paths_ahead. Every state holds a Direction member, so identity works.
_FORWARD = Direction.FORWARD


def _direction(direction: int) -> Direction:
    """``direction`` as a :class:`Direction`; a ValueError names the wrong value."""
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    return _DIRECTIONS[direction]


# -- routes ahead -------------------------------------------------------------------------
def paths_ahead(
    net: RoutableMap,
    edge_id: int,
    offset_m: float,
    direction: int,
    horizon_m: float,
    *,
    max_paths: int = 64,
    respect_direction: bool = True,
) -> list[Path]:
    """Every route ahead of a track position up to a horizon, one per branch.

    Parameters
    ----------
    net : TrackMap
        The map.
    edge_id : int
    offset_m : float
        Position along the edge, metres from its first vertex.
    direction : Direction or int
        +1 along the edge's vertices, -1 against them.
    horizon_m : float
        Look-ahead distance, metres.
    max_paths : int
        Safety bound on branching; paths beyond it end with ``end='truncated'``.
    respect_direction : bool
        Follow only permitted running directions (default). ``False`` follows every
        physical move, e.g. for a vehicle running against the permitted direction.

    Returns
    -------
    list of Path
        One path per zone (a branch at each facing switch), in a stable order.

    Raises
    ------
    UnknownEdgeError
        ``edge_id`` is not in the map.
    ValueError
        ``direction`` is not +1/-1, or the horizon is negative.
    """
    edge = net.edge(edge_id)
    start_direction = _direction(direction)
    if not horizon_m >= 0:
        raise ValueError(f"horizon_m must be >= 0, got {horizon_m}")
    index = net.routing_index
    # locals: this loop is the hot path of the analyser
    moves = index.moves if respect_direction else index.moves_any
    lengths = index.edge_lengths_m
    choices = index.choices
    node_conflicts = index.node_conflicts
    crossings = index.crossings_by_edge
    edges = net.edges
    nodes = net.nodes
    offset = min(max(float(offset_m), 0.0), lengths[edge.edge_id])
    results: list[Path] = []
    # each stack item: (state, enter_offset, distance at entry, steps, nodes, conflicts, labels);
    # a state is a TrackState from the graph or, at the start, a plain tuple equal to one
    # (building the named tuple would cost more than the rest of a short search)
    stack: list[
        tuple[
            tuple[int, Direction],
            float,
            float,
            list[PathStep],
            list[NodePass],
            list[ConflictPass],
            list[str],
        ]
    ]
    stack = [((edge.edge_id, start_direction), offset, 0.0, [], [], [], [])]
    while stack:
        state, enter, start, steps, passed, conflicts, labels = stack.pop()
        e, d = state
        forward = d is _FORWARD
        elen = lengths[e]
        remaining = (elen - enter) if forward else enter
        budget = horizon_m - start
        if remaining >= budget:
            exit_off = enter + budget if forward else enter - budget
            steps = [*steps, _step(e, d, enter, exit_off, start, horizon_m)]
            if e in crossings:
                conflicts = conflicts + _crossings_on(index, e, enter, exit_off, start)
            results.append(_make_path(steps, passed, conflicts, labels, PathEnd.HORIZON))
            continue
        exit_off = elen if forward else 0.0
        end_m = start + remaining
        steps = [*steps, _step(e, d, enter, exit_off, start, end_m)]
        if e in crossings:
            conflicts = conflicts + _crossings_on(index, e, enter, exit_off, start)
        node_id = edges[e].end_node if forward else edges[e].start_node
        succ = moves.get(state, ())  # type: ignore[call-overload]  # a tuple equal to a state
        if not succ or len(results) + len(stack) >= max_paths:
            node = nodes.get(node_id)
            if succ:
                end = PathEnd.TRUNCATED
                logger.debug("paths_ahead: more than %d branches; truncated", max_paths)
            elif node and node.cls == NodeClass.BUFFER_STOP:
                end = PathEnd.BUFFER_STOP
            else:
                end = PathEnd.DEAD_END
            results.append(_make_path(steps, passed, conflicts, labels, end))
            continue
        cls = nodes[node_id].cls
        here = node_conflicts.get(node_id, ())
        branching = len(succ) > 1
        for nxt in reversed(succ):
            choice = choices.get((state, nxt)) if branching else None
            to_edge = nxt[0]
            npass = _node_pass(node_id, cls, end_m, e, to_edge, choice)
            stack.append(
                (
                    nxt,
                    0.0 if nxt[1] is _FORWARD else lengths[to_edge],
                    end_m,
                    steps,
                    [*passed, npass],
                    conflicts + [_conflict_pass(c, k, end_m, to_edge) for c, k in here]
                    if here
                    else conflicts,
                    [*labels, choice] if choice else labels,
                )
            )
    return results


def _crossings_on(
    index: RoutingIndex, edge_id: int, enter: float, exit_: float, start_m: float
) -> list[ConflictPass]:
    """Unnoded crossings between two offsets of an edge, nearest first (``start_m`` on)."""
    hits = index.crossings_by_edge.get(edge_id)
    if not hits:
        return []
    lo, hi = sorted((enter, exit_))
    out = []
    for off, cid in hits:
        if lo - 1e-9 <= off <= hi + 1e-9:
            out.append(
                _conflict_pass(cid, ConflictKind.CROSSING, start_m + abs(off - enter), edge_id)
            )
    out.sort(key=lambda c: c.distance_m)
    return out


def _make_path(
    steps: list[PathStep],
    nodes: list[NodePass],
    conflicts: list[ConflictPass],
    labels: list[str],
    end: PathEnd,
) -> Path:
    return _path(
        "/".join(labels) if labels else "main",
        tuple(steps),
        steps[-1].end_m if steps else 0.0,
        tuple(nodes),
        tuple(sorted(conflicts, key=_distance_of) if len(conflicts) > 1 else conflicts),
        end,
    )


def _distance_of(c: ConflictPass) -> float:
    return c.distance_m


_step = positional(PathStep)
_node_pass = positional(NodePass)
_conflict_pass = positional(ConflictPass)
_path = positional(Path)


def path_geometry(net: RoutableMap, path: Path) -> shapely.LineString:
    """A path as a line in the local frame, metres (for corridors and figures).

    Parameters
    ----------
    net : TrackMap
        The map the path was found on.
    path : Path

    Returns
    -------
    shapely.LineString
        In running order; a degenerate path gives a zero-length line.
    """
    coords: list[tuple[float, float]] = []
    for step in path.steps:
        lo, hi = sorted((step.enter_offset_m, step.exit_offset_m))
        part = shapely.ops.substring(net.edges[step.edge_id].geometry, lo, hi)
        xy = list(part.coords) if part.geom_type == "LineString" else [(part.x, part.y)] * 2
        if step.direction == -1:
            xy.reverse()
        if coords and xy and coords[-1] == xy[0]:
            xy = xy[1:]
        coords.extend(xy)
    if len(coords) < 2:
        coords = coords * 2 if coords else [(0.0, 0.0), (0.0, 0.0)]
    return shapely.LineString(coords)


# -- distances ----------------------------------------------------------------------------
def route_distance(
    net: RoutableMap,
    from_edge: int,
    from_offset_m: float,
    from_direction: int,
    to_edge: int,
    to_offset_m: float,
    *,
    cutoff_m: float = 2000.0,
    respect_direction: bool = True,
) -> RouteDistance | None:
    """Shortest distance along permitted moves from one track position to another.

    Parameters
    ----------
    net : TrackMap
        The map.
    from_edge, from_offset_m, from_direction
        Start position (edge, metres from its first vertex) and running direction (+1/-1).
    to_edge, to_offset_m
        Target position (either running direction), metres from the edge's first vertex.
    cutoff_m : float
        Give up beyond this distance, metres.
    respect_direction : bool
        Follow only permitted running directions (default), or every physical move.

    Returns
    -------
    RouteDistance or None
        None when the target cannot be reached within the cutoff.

    Raises
    ------
    UnknownEdgeError
        Either edge is not in the map.
    ValueError
        ``from_direction`` is not +1/-1.
    """
    net.edge(from_edge)
    net.edge(to_edge)
    start_direction = _direction(from_direction)
    index = net.routing_index
    graph = index.traversal if respect_direction else index.traversal_any
    lengths = index.lengths_m
    if respect_direction and not net.edges[from_edge].allows(start_direction):
        return None
    if from_edge == to_edge and (to_offset_m - from_offset_m) * start_direction >= 0:
        d = abs(to_offset_m - from_offset_m)
        return RouteDistance(d, start_direction, (from_edge,)) if d <= cutoff_m else None
    start = (from_edge, start_direction)  # equal to the graph's TrackState
    if start not in graph:
        return None
    remaining = (lengths[from_edge] - from_offset_m) if start_direction == 1 else from_offset_m
    # Dijkstra over track states; cost = distance to the state's entry point
    settled: dict[TrackState, TrackState | None] = {}
    heap: list[tuple[float, TrackState, TrackState | None]] = [
        (remaining, nxt, None) for nxt in graph.successors(start)
    ]
    heapq.heapify(heap)
    found: tuple[float, TrackState] | None = None
    while heap:
        cost, state, parent = heapq.heappop(heap)
        if cost > cutoff_m or (found is not None and cost >= found[0]):
            break
        if state in settled:
            continue
        settled[state] = parent
        e = state[0]  # unpacking a named tuple is slower than indexing it
        if e == to_edge:
            total = cost + (to_offset_m if state[1] is _FORWARD else lengths[e] - to_offset_m)
            if total <= cutoff_m and (found is None or total < found[0]):
                found = (total, state)
        nxt_cost = cost + lengths[e]
        for nxt in graph.successors(state):
            if nxt not in settled:
                heapq.heappush(heap, (nxt_cost, nxt, state))
    if found is None:
        return None
    chain: list[TrackState] = [found[1]]
    while (parent_state := settled.get(chain[-1])) is not None:
        chain.append(parent_state)
    route = (from_edge, *(s.edge_id for s in reversed(chain)))
    return RouteDistance(float(found[0]), found[1].direction, route)
