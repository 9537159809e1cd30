"""The :class:`TrackMap`: track edges, junction nodes, the traversal graph and queries.

Coordinates: every edge keeps its WGS84 vertices (the canonical form, written to the map
file) and their projection in the map's local metric frame (used for every computation).
Offsets along an edge are measured in metres from its first vertex; ``direction`` +1 means
travelling in the order of the vertices, -1 against it.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import math
import os
import pathlib
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import networkx as nx
import numpy as np
import numpy.typing as npt
import shapely
import shapely.ops

from trackmap.crs import LocalFrame
from trackmap.errors import UnknownEdgeError

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

NodeClass = Literal[
    "buffer_stop", "link", "point_switch", "diamond_crossing", "double_slip", "unknown"
]
ConflictKind = Literal["merge", "diamond_crossing", "double_slip", "crossing"]


# -- records ------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True, eq=False)
class Edge:
    """A track edge: a stretch of track between junction nodes.

    Attributes
    ----------
    edge_id : int
    start_node, end_node : int
        OSM ids of the junction nodes at the first and last vertex.
    node_ids : tuple of int
        OSM node ids of every vertex.
    lon, lat : tuple of float
        WGS84 vertices, degrees (canonical geometry).
    geometry : shapely.LineString
        Vertices in the map's local frame, metres.
    way_ids : tuple of int
        OSM ways the edge was built from, in order.
    kind : str
        ``railway=`` value (``tram``, ``light_rail``, ...).
    service : str or None
        ``yard``, ``siding``, ``spur`` or ``crossover`` for auxiliary tracks.
    layer : int
    bridge, tunnel : bool
    maxspeed_mps : float or None
        Speed limit from ``maxspeed``, m/s.
    direction : int
        Permitted running direction: +1 along the vertices, -1 against them, 0 both.
    direction_source : str
        ``preferred_direction``, ``oneway``, ``driving_side`` or ``none``.
    name : str or None
    """

    edge_id: int
    start_node: int
    end_node: int
    node_ids: tuple[int, ...]
    lon: tuple[float, ...]
    lat: tuple[float, ...]
    geometry: shapely.LineString
    way_ids: tuple[int, ...]
    kind: str
    service: str | None
    layer: int
    bridge: bool
    tunnel: bool
    maxspeed_mps: float | None
    direction: int
    direction_source: str
    name: str | None = None

    @property
    def length_m(self) -> float:
        """Length in the local frame, metres."""
        return float(self.geometry.length)

    def allows(self, direction: int) -> bool:
        """Whether running in ``direction`` (+1/-1) is permitted."""
        return self.direction == 0 or self.direction == direction

    def key(self) -> tuple[Any, ...]:
        """Everything that defines the edge (for equality of maps)."""
        return (
            self.edge_id,
            self.start_node,
            self.end_node,
            self.node_ids,
            self.lon,
            self.lat,
            self.way_ids,
            self.kind,
            self.service,
            self.layer,
            self.bridge,
            self.tunnel,
            self.maxspeed_mps,
            self.direction,
            self.direction_source,
            self.name,
        )

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Edge) and self.key() == other.key()

    def __hash__(self) -> int:
        return hash(self.edge_id)


@dataclass(frozen=True, slots=True)
class Node:
    """A junction node (where edges meet) with its class and allowed moves.

    Attributes
    ----------
    node_id : int
        OSM node id.
    lon, lat : float
        Degrees.
    x, y : float
        Local frame, metres.
    cls : str
        ``buffer_stop``, ``link``, ``point_switch``, ``diamond_crossing``, ``double_slip`` or
        ``unknown``.
    ends : tuple of (edge_id, end)
        The edge ends meeting here (end 0: the edge's first vertex, 1: its last).
    allowed : tuple of (i, j)
        Pairs of indices into ``ends`` a vehicle can pass between (both ways, subject to
        the edges' running directions).
    """

    node_id: int
    lon: float
    lat: float
    x: float
    y: float
    cls: NodeClass
    ends: tuple[tuple[int, int], ...]
    allowed: tuple[tuple[int, int], ...]


@dataclass(frozen=True, slots=True)
class ConflictPoint:
    """A place where two routes can collide from different tracks.

    Attributes
    ----------
    conflict_id : int
    kind : str
        ``merge`` (the fouling area of a point switch), ``diamond_crossing``, ``double_slip``
        or ``crossing`` (lines crossing at the same level without a shared node).
    x, y : float
        Local frame, metres.
    node_id : int or None
        The junction node for noded conflicts, None for unnoded crossings.
    edges : tuple of int
        Edges through the conflict. For ``merge``: (trunk, branch, branch).
    offsets_m : tuple of float
        Where the conflict point lies along each edge, metres from its first vertex.
    extents_m : tuple of float
        How far the conflict area reaches along each edge from the point, metres (for a
        merge: from the switch to the clearance point of each branch).
    angle_deg : float or None
        Crossing angle (crossings) or branch divergence.
    """

    conflict_id: int
    kind: ConflictKind
    x: float
    y: float
    node_id: int | None
    edges: tuple[int, ...]
    offsets_m: tuple[float, ...]
    extents_m: tuple[float, ...]
    angle_deg: float | None = None


@dataclass(frozen=True, slots=True)
class Stop:
    """A stop position snapped to the track."""

    stop_id: int
    name: str | None
    lon: float
    lat: float
    edge_id: int | None
    offset_m: float | None


@dataclass(frozen=True, slots=True)
class Candidate:
    """A possible projection of a position onto a track edge.

    Attributes
    ----------
    edge_id : int
    offset_m : float
        Distance of the projected point from the edge's first vertex, metres.
    lateral_m : float
        Signed distance from the track, metres; positive to the left of the edge's
        vertex order.
    heading_deg : float
        True heading of the track at the point, in the edge's vertex order, degrees
        clockwise from north.
    distance_m : float
        Distance from the position to the edge (|lateral| except beyond the edge ends).
    """

    edge_id: int
    offset_m: float
    lateral_m: float
    heading_deg: float
    distance_m: float


@dataclass(frozen=True, slots=True)
class CandidateBatch:
    """Candidates of many positions at once (parallel arrays).

    ``point`` holds the index of the query position each row belongs to.
    """

    point: IntArray
    edge_id: IntArray
    offset_m: FloatArray
    lateral_m: FloatArray
    heading_deg: FloatArray
    distance_m: FloatArray

    def __len__(self) -> int:
        return len(self.point)


@dataclass(frozen=True, slots=True)
class PathStep:
    """One edge of a path: where the path enters and leaves it.

    ``enter_offset_m`` and ``exit_offset_m`` are edge offsets (metres from its first
    vertex); ``start_m`` and ``end_m`` are distances from the path's origin.
    """

    edge_id: int
    direction: int
    enter_offset_m: float
    exit_offset_m: float
    start_m: float
    end_m: float

    def distance_to(self, offset_m: float) -> float | None:
        """Distance from the path origin to an offset on this edge, or None if outside."""
        lo, hi = sorted((self.enter_offset_m, self.exit_offset_m))
        if not lo - 1e-9 <= offset_m <= hi + 1e-9:
            return None
        return self.start_m + abs(offset_m - self.enter_offset_m)


@dataclass(frozen=True, slots=True)
class NodePass:
    """A junction node a path passes, with the move it makes there."""

    node_id: int
    cls: str
    distance_m: float
    from_edge: int
    to_edge: int
    choice: str | None  # 'straight' | 'left' | 'right' at a facing switch, else None


@dataclass(frozen=True, slots=True)
class ConflictPass:
    """A conflict point a path passes."""

    conflict_id: int
    kind: str
    distance_m: float
    edge_id: int


@dataclass(frozen=True, slots=True)
class Path:
    """One route ahead (one zone of the sensitivity area).

    Attributes
    ----------
    zone : str
        ``main`` when no facing switch was passed, else the choices at each facing switch
        joined by ``/`` (e.g. ``straight/left``).
    steps : tuple of PathStep
    length_m : float
    nodes : tuple of NodePass
        Junctions passed (switches, crossings and links are all listed).
    conflicts : tuple of ConflictPass
        Conflict points passed (merges, diamonds, at-grade crossings).
    end : str
        ``horizon``, ``buffer_stop``, ``dead_end`` (no permitted move), or ``truncated``
        (too many branches).
    """

    zone: str
    steps: tuple[PathStep, ...]
    length_m: float
    nodes: tuple[NodePass, ...]
    conflicts: tuple[ConflictPass, ...]
    end: str

    @property
    def edges(self) -> tuple[int, ...]:
        """Edge ids in running order."""
        return tuple(s.edge_id for s in self.steps)

    @property
    def switches(self) -> tuple[NodePass, ...]:
        """The point switches and double slips passed."""
        return tuple(n for n in self.nodes if n.cls in ("point_switch", "double_slip"))

    @property
    def crossings(self) -> tuple[ConflictPass, ...]:
        """The crossing conflict points passed (diamonds and at-grade crossings)."""
        return tuple(c for c in self.conflicts if c.kind != "merge")

    def locate(self, edge_id: int, offset_m: float) -> float | None:
        """Distance along the path to a track position, or None if the path misses it."""
        found = self.locate_step(edge_id, offset_m)
        return None if found is None else found[0]

    def locate_step(self, edge_id: int, offset_m: float) -> tuple[float, PathStep] | None:
        """Distance along the path to a track position and the step holding it."""
        for step in self.steps:
            if step.edge_id == edge_id:
                d = step.distance_to(offset_m)
                if d is not None:
                    return d, step
        return None


@dataclass(frozen=True, slots=True)
class RouteDistance:
    """Along-track distance between two positions and the direction of arrival."""

    distance_m: float
    arrival_direction: int
    edges: tuple[int, ...]


@dataclass
class MapMetadata:
    """Provenance and build parameters kept with a map."""

    source: dict[str, Any] = field(default_factory=dict)
    build: dict[str, Any] = field(default_factory=dict)
    driving_side: str = "right"
    attribution: str = "© OpenStreetMap contributors, ODbL 1.0"
    created: str = ""

    def as_dict(self) -> dict[str, Any]:
        return {
            "source": self.source,
            "build": self.build,
            "driving_side": self.driving_side,
            "attribution": self.attribution,
            "created": self.created,
        }


# -- the map ------------------------------------------------------------------------------
class TrackMap:
    """A rail network in a local metric frame, with spatial and routing queries.

    Build one with :func:`trackmap.build`, read one with :func:`trackmap.load` or
    :func:`trackmap.load_default`.
    """

    def __init__(
        self,
        *,
        frame: LocalFrame,
        edges: Sequence[Edge],
        nodes: Iterable[Node],
        conflicts: Sequence[ConflictPoint],
        stops: Sequence[Stop] = (),
        grade_separated: Sequence[tuple[int, int, float, float]] = (),
        metadata: MapMetadata | None = None,
    ) -> None:
        self.frame = frame
        self.edges: tuple[Edge, ...] = tuple(edges)
        for i, e in enumerate(self.edges):
            if e.edge_id != i:
                raise ValueError(f"edge ids must be 0..n-1 in order; edge {i} has {e.edge_id}")
        self.nodes: dict[int, Node] = {n.node_id: n for n in nodes}
        self.conflicts: tuple[ConflictPoint, ...] = tuple(conflicts)
        self.stops: tuple[Stop, ...] = tuple(stops)
        #: Crossings of grade-separated lines: (edge_a, edge_b, x, y); not conflicts.
        self.grade_separated: tuple[tuple[int, int, float, float], ...] = tuple(grade_separated)
        self.metadata = metadata or MapMetadata()
        self._geoms = np.array([e.geometry for e in self.edges], dtype=object)
        self._lengths = shapely.length(self._geoms).astype(float)
        self._tree = shapely.STRtree(self._geoms)
        mid = shapely.line_interpolate_point(self._geoms, 0.5, normalized=True)
        self._convergence = self.frame.grid_north_azimuth_deg(
            shapely.get_x(mid), shapely.get_y(mid)
        )
        #: Permitted moves: (edge, direction) states, respecting running directions.
        self.traversal = self._build_traversal(respect_direction=True)
        #: Physical moves: as ``traversal`` but ignoring running directions (for
        #: vehicles running against the permitted direction).
        self.traversal_any = self._build_traversal(respect_direction=False)
        self._edge_crossings: dict[int, list[tuple[float, int]]] = defaultdict(list)
        self._node_conflicts: dict[int, list[int]] = defaultdict(list)
        for c in self.conflicts:
            if c.node_id is None:
                for eid, off in zip(c.edges, c.offsets_m, strict=True):
                    self._edge_crossings[eid].append((off, c.conflict_id))
            else:
                self._node_conflicts[c.node_id].append(c.conflict_id)
        for lst in self._edge_crossings.values():
            lst.sort()
        self._choices = self._facing_choices()

    # -- construction helpers ------------------------------------------------------------
    def _build_traversal(self, *, respect_direction: bool) -> nx.DiGraph:
        g = nx.DiGraph()
        for e in self.edges:
            for d in (1, -1):
                if e.allows(d) or not respect_direction:
                    g.add_node((e.edge_id, d), length=self._lengths[e.edge_id])
        for node in self.nodes.values():
            for i, j in node.allowed:
                for a, b in ((i, j), (j, i)):
                    ea, enda = node.ends[a]
                    eb, endb = node.ends[b]
                    d_in = 1 if enda == 1 else -1  # arriving at the edge's end vertex: +1
                    d_out = 1 if endb == 0 else -1  # leaving from its first vertex: +1
                    if g.has_node((ea, d_in)) and g.has_node((eb, d_out)):
                        g.add_edge((ea, d_in), (eb, d_out), node=node.node_id)
        return g

    def _facing_choices(self) -> dict[tuple[tuple[int, int], tuple[int, int]], str]:
        """Label the options at facing switches: 'straight', 'left' or 'right'."""
        labels: dict[tuple[tuple[int, int], tuple[int, int]], str] = {}
        for u in self.traversal_any.nodes:
            succ = list(self.traversal_any.successors(u))
            if len(succ) < 2:
                continue
            edge_u, d_u = u
            heading_in = self._end_heading(edge_u, d_u, arriving=True)
            turns = []
            for v in succ:
                heading_out = self._end_heading(v[0], v[1], arriving=False)
                turn = (heading_out - heading_in + 180.0) % 360.0 - 180.0
                turns.append(turn)
            straightest = int(np.argmin(np.abs(turns)))
            for k, v in enumerate(succ):
                if k == straightest and abs(turns[k]) < 0.5 * max(abs(t) for t in turns) + 1e-9:
                    labels[(u, v)] = "straight"
                else:
                    labels[(u, v)] = "left" if turns[k] < 0 else "right"
            if len(set(labels[(u, v)] for v in succ)) < len(succ):
                for v in succ:  # e.g. three-way points: fall back to edge ids
                    labels[(u, v)] = f"{labels[(u, v)]}:{v[0]}"
        return labels

    def _end_heading(
        self, edge_id: int, direction: int, *, arriving: bool, probe_m: float = 10.0
    ) -> float:
        geom = self._geoms[edge_id]
        length = self._lengths[edge_id]
        d = min(probe_m, length)
        if direction == 1:
            a, b = (length - d, length) if arriving else (0.0, d)
        else:
            a, b = (d, 0.0) if arriving else (length, length - d)
        p, q = geom.interpolate(a), geom.interpolate(b)
        return math.degrees(math.atan2(q.x - p.x, q.y - p.y)) % 360.0

    # -- basic facts ---------------------------------------------------------------------
    def __repr__(self) -> str:
        s = self.stats()
        return (
            f"TrackMap({s['edges']} edges, {s['track_km']:.1f} km, {s['switches']} switches, "
            f"{s['diamond_crossings']} diamonds, driving_side={self.metadata.driving_side!r})"
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TrackMap):
            return NotImplemented
        return (
            self.frame.crs == other.frame.crs
            and self.edges == other.edges
            and self.nodes == other.nodes
            and self.conflicts == other.conflicts
            and self.stops == other.stops
            and self.grade_separated == other.grade_separated
            and self.metadata.driving_side == other.metadata.driving_side
        )

    __hash__ = None  # type: ignore[assignment]

    def save(self, path: str | os.PathLike[str]) -> pathlib.Path:
        """Write the map as a versioned GeoJSON map file (see :mod:`trackmap.mapfile`)."""
        from trackmap.mapfile import save

        return save(self, path)

    def edge(self, edge_id: int) -> Edge:
        """The edge with this id.

        Raises
        ------
        UnknownEdgeError
        """
        try:
            if edge_id < 0:
                raise IndexError
            return self.edges[edge_id]
        except (IndexError, TypeError):
            raise UnknownEdgeError(f"the map has no edge {edge_id!r}") from None

    def edge_length(self, edge_id: int) -> float:
        """Length of an edge, metres."""
        return float(self._lengths[self.edge(edge_id).edge_id])

    def stats(self) -> dict[str, Any]:
        """Summary figures of the network.

        Returns
        -------
        dict
            ``track_km``, ``edges``, ``nodes``, ``buffer_stops``, ``links``, ``switches``,
            ``diamond_crossings``, ``double_slips``, ``unknown_nodes``, ``components``,
            ``conflict_points``, ``unnoded_crossings``, ``grade_separated_crossings``,
            ``directed_edges`` (edges with one permitted direction), ``stops``.
        """
        classes: dict[str, int] = defaultdict(int)
        for n in self.nodes.values():
            classes[n.cls] += 1
        return {
            "track_km": float(self._lengths.sum()) / 1000.0,
            "edges": len(self.edges),
            "nodes": len(self.nodes),
            "buffer_stops": classes["buffer_stop"],
            "links": classes["link"],
            "switches": classes["point_switch"],
            "diamond_crossings": classes["diamond_crossing"],
            "double_slips": classes["double_slip"],
            "unknown_nodes": classes["unknown"],
            "components": len(self.components()),
            "conflict_points": len(self.conflicts),
            "unnoded_crossings": sum(1 for c in self.conflicts if c.kind == "crossing"),
            "grade_separated_crossings": len(self.grade_separated),
            "directed_edges": sum(1 for e in self.edges if e.direction != 0),
            "stops": len(self.stops),
        }

    def components(self) -> list[set[int]]:
        """Connected groups of edges (ignoring directions), largest first."""
        g = nx.Graph()
        g.add_nodes_from(range(len(self.edges)))
        for node in self.nodes.values():
            ids = [e for e, _ in node.ends]
            for a, b in itertools.pairwise(ids):
                g.add_edge(a, b)
        return sorted(nx.connected_components(g), key=len, reverse=True)

    # -- coordinates ---------------------------------------------------------------------
    def to_local(self, lon: Any, lat: Any) -> tuple[Any, Any]:
        """WGS84 degrees to local metres (x east, y north); scalars or arrays."""
        return self.frame.to_local(lon, lat)

    def to_lonlat(self, x: Any, y: Any) -> tuple[Any, Any]:
        """Local metres to WGS84 degrees (lon, lat); scalars or arrays."""
        return self.frame.to_lonlat(x, y)

    # -- spatial queries -----------------------------------------------------------------
    def candidates(self, lon: float, lat: float, radius_m: float = 25.0) -> list[Candidate]:
        """Track edges within ``radius_m`` of a position, nearest first.

        Parameters
        ----------
        lon, lat : float
            Position, degrees.
        radius_m : float
            Search radius, metres.

        Returns
        -------
        list of Candidate
        """
        x, y = self.to_local(lon, lat)
        return self.candidates_xy(x, y, radius_m)

    def candidates_xy(self, x: float, y: float, radius_m: float = 25.0) -> list[Candidate]:
        """:meth:`candidates` for a position in the local frame (metres)."""
        batch = self.candidates_batch_xy(np.array([x]), np.array([y]), radius_m)
        order = np.argsort(batch.distance_m, kind="stable")
        return [
            Candidate(
                edge_id=int(batch.edge_id[i]),
                offset_m=float(batch.offset_m[i]),
                lateral_m=float(batch.lateral_m[i]),
                heading_deg=float(batch.heading_deg[i]),
                distance_m=float(batch.distance_m[i]),
            )
            for i in order
        ]

    def candidates_batch(
        self, lon: npt.ArrayLike, lat: npt.ArrayLike, radius_m: float = 25.0
    ) -> CandidateBatch:
        """Vectorised :meth:`candidates` for many positions (degrees) at once."""
        x, y = self.to_local(np.asarray(lon, dtype=float), np.asarray(lat, dtype=float))
        return self.candidates_batch_xy(np.atleast_1d(x), np.atleast_1d(y), radius_m)

    def candidates_batch_xy(
        self, x: FloatArray, y: FloatArray, radius_m: float = 25.0
    ) -> CandidateBatch:
        """Vectorised candidates for local positions (metres); one STRtree query in all."""
        if not radius_m > 0:
            raise ValueError(f"radius_m must be positive, got {radius_m}")
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        finite = np.isfinite(x) & np.isfinite(y)
        pts = shapely.points(np.where(finite, x, 0.0), np.where(finite, y, 0.0))
        pts[~finite] = None
        p_idx, e_idx = self._tree.query(pts, predicate="dwithin", distance=radius_m)
        p_idx = p_idx.astype(np.int64)
        e_idx = e_idx.astype(np.int64)
        geoms = self._geoms[e_idx]
        qpts = pts[p_idx]
        offset = shapely.line_locate_point(geoms, qpts)
        length = self._lengths[e_idx]
        proj = shapely.line_interpolate_point(geoms, offset)
        ahead = shapely.line_interpolate_point(geoms, np.minimum(offset + 0.5, length))
        behind = shapely.line_interpolate_point(geoms, np.maximum(offset - 0.5, 0.0))
        tx = shapely.get_x(ahead) - shapely.get_x(behind)
        ty = shapely.get_y(ahead) - shapely.get_y(behind)
        dx = x[p_idx] - shapely.get_x(proj)
        dy = y[p_idx] - shapely.get_y(proj)
        tn = np.hypot(tx, ty)
        tn[tn == 0] = 1.0
        lateral = (tx * dy - ty * dx) / tn
        distance = np.hypot(dx, dy)
        heading = (np.degrees(np.arctan2(tx, ty)) + self._convergence[e_idx]) % 360.0
        return CandidateBatch(
            point=p_idx,
            edge_id=e_idx,
            offset_m=np.asarray(offset, dtype=float),
            lateral_m=lateral,
            heading_deg=heading,
            distance_m=distance,
        )

    def point_at(self, edge_id: int, offset_m: float) -> tuple[float, float]:
        """Local (x, y) of a track position, metres."""
        p = self.edge(edge_id).geometry.interpolate(offset_m)
        return float(p.x), float(p.y)

    def points_at(
        self, edge_ids: npt.ArrayLike, offsets_m: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """Vectorised :meth:`point_at`: local (x, y) arrays, metres."""
        idx = np.asarray(edge_ids, dtype=np.int64)
        pts = shapely.line_interpolate_point(self._geoms[idx], np.asarray(offsets_m, dtype=float))
        return shapely.get_x(pts), shapely.get_y(pts)

    def heading_at(self, edge_id: int, offset_m: float, direction: int = 1) -> float:
        """True heading of travel at a track position, degrees clockwise from north."""
        geom = self.edge(edge_id).geometry
        length = self._lengths[edge_id]
        p = geom.interpolate(max(offset_m - 0.5, 0.0))
        q = geom.interpolate(min(offset_m + 0.5, length))
        h = math.degrees(math.atan2(q.x - p.x, q.y - p.y)) + float(self._convergence[edge_id])
        if direction < 0:
            h += 180.0
        return h % 360.0

    # -- routing -------------------------------------------------------------------------
    def successors(
        self, edge_id: int, direction: int, *, respect_direction: bool = True
    ) -> list[tuple[int, int]]:
        """The (edge, direction) states reachable from the end of an edge."""
        graph = self.traversal if respect_direction else self.traversal_any
        state = (edge_id, direction)
        if state not in graph:
            return []
        return list(graph.successors(state))

    def paths_ahead(
        self,
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
        edge_id : int
        offset_m : float
            Position along the edge, metres from its first vertex.
        direction : int
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
        edge = self.edge(edge_id)
        if direction not in (1, -1):
            raise ValueError(f"direction must be +1 or -1, got {direction!r}")
        if not horizon_m >= 0:
            raise ValueError(f"horizon_m must be >= 0, got {horizon_m}")
        graph = self.traversal if respect_direction else self.traversal_any
        length = self._lengths[edge.edge_id]
        offset = min(max(float(offset_m), 0.0), length)
        results: list[Path] = []
        # each stack item: (state, enter_offset, distance at entry, steps, nodes, conflicts, labels)
        stack: list[
            tuple[
                tuple[int, int],
                float,
                float,
                list[PathStep],
                list[NodePass],
                list[ConflictPass],
                list[str],
            ]
        ]
        stack = [((edge.edge_id, direction), offset, 0.0, [], [], [], [])]
        while stack:
            state, enter, start, steps, nodes, conflicts, labels = stack.pop()
            e, d = state
            elen = self._lengths[e]
            remaining = (elen - enter) if d == 1 else enter
            budget = horizon_m - start
            if remaining >= budget:
                exit_off = enter + d * budget
                steps = [*steps, PathStep(e, d, enter, exit_off, start, horizon_m)]
                conflicts = conflicts + self._crossings_on(e, enter, exit_off, start)
                results.append(self._make_path(steps, nodes, conflicts, labels, "horizon"))
                continue
            exit_off = elen if d == 1 else 0.0
            end_m = start + remaining
            steps = [*steps, PathStep(e, d, enter, exit_off, start, end_m)]
            conflicts = conflicts + self._crossings_on(e, enter, exit_off, start)
            node_id = self.edges[e].end_node if d == 1 else self.edges[e].start_node
            succ = list(graph.successors(state)) if state in graph else []
            if not succ or len(results) + len(stack) >= max_paths:
                node = self.nodes.get(node_id)
                end = (
                    "truncated"
                    if succ
                    else ("buffer_stop" if node and node.cls == "buffer_stop" else "dead_end")
                )
                if succ:
                    logger.debug("paths_ahead: more than %d branches; truncated", max_paths)
                results.append(self._make_path(steps, nodes, conflicts, labels, end))
                continue
            node = self.nodes[node_id]
            for nxt in reversed(succ):
                choice = self._choices.get((state, nxt)) if len(succ) > 1 else None
                npass = NodePass(node_id, node.cls, end_m, e, nxt[0], choice)
                node_conf = [
                    ConflictPass(cid, self.conflicts[cid].kind, end_m, nxt[0])
                    for cid in self._node_conflicts.get(node_id, ())
                ]
                enter_next = 0.0 if nxt[1] == 1 else self._lengths[nxt[0]]
                stack.append(
                    (
                        nxt,
                        enter_next,
                        end_m,
                        steps,
                        [*nodes, npass],
                        conflicts + node_conf,
                        [*labels, choice] if choice else labels,
                    )
                )
        return results

    def _crossings_on(
        self, edge_id: int, enter: float, exit_: float, start_m: float
    ) -> list[ConflictPass]:
        hits = self._edge_crossings.get(edge_id)
        if not hits:
            return []
        lo, hi = sorted((enter, exit_))
        out = []
        for off, cid in hits:
            if lo - 1e-9 <= off <= hi + 1e-9:
                out.append(ConflictPass(cid, "crossing", start_m + abs(off - enter), edge_id))
        out.sort(key=lambda c: c.distance_m)
        return out

    @staticmethod
    def _make_path(
        steps: list[PathStep],
        nodes: list[NodePass],
        conflicts: list[ConflictPass],
        labels: list[str],
        end: str,
    ) -> Path:
        return Path(
            zone="/".join(labels) if labels else "main",
            steps=tuple(steps),
            length_m=steps[-1].end_m if steps else 0.0,
            nodes=tuple(nodes),
            conflicts=tuple(sorted(conflicts, key=lambda c: c.distance_m)),
            end=end,
        )

    def path_geometry(self, path: Path) -> shapely.LineString:
        """The path as a line in the local frame (for corridors and figures)."""
        coords: list[tuple[float, float]] = []
        for step in path.steps:
            lo, hi = sorted((step.enter_offset_m, step.exit_offset_m))
            part = shapely.ops.substring(self._geoms[step.edge_id], lo, hi)
            xy = list(part.coords) if part.geom_type == "LineString" else [(part.x, part.y)] * 2
            if step.direction == -1:
                xy.reverse()
            if coords and xy and coords[-1] == xy[0]:
                xy = xy[1:]
            coords.extend(xy)
        if len(coords) < 2:
            coords = coords * 2 if coords else [(0.0, 0.0), (0.0, 0.0)]
        return shapely.LineString(coords)

    def route_distance(
        self,
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
        from_edge, from_offset_m, from_direction
            Start position and running direction (+1/-1).
        to_edge, to_offset_m
            Target position (either running direction).
        cutoff_m : float
            Give up beyond this distance, metres.
        respect_direction : bool
            Follow only permitted running directions (default), or every physical move.

        Returns
        -------
        RouteDistance or None
            None when the target cannot be reached within the cutoff.
        """
        self.edge(from_edge)
        self.edge(to_edge)
        if from_direction not in (1, -1):
            raise ValueError(f"direction must be +1 or -1, got {from_direction!r}")
        graph = self.traversal if respect_direction else self.traversal_any
        if respect_direction and not self.edges[from_edge].allows(from_direction):
            return None
        if from_edge == to_edge and (to_offset_m - from_offset_m) * from_direction >= 0:
            d = abs(to_offset_m - from_offset_m)
            return RouteDistance(d, from_direction, (from_edge,)) if d <= cutoff_m else None
        start = (from_edge, from_direction)
        if start not in graph:
            return None
        remaining = (
            (self._lengths[from_edge] - from_offset_m) if from_direction == 1 else from_offset_m
        )
        # Dijkstra over (edge, direction) states; cost = distance to the state's entry point
        settled: dict[tuple[int, int], tuple[int, int] | None] = {}
        heap: list[tuple[float, tuple[int, int], tuple[int, int] | None]] = [
            (remaining, nxt, None) for nxt in graph.successors(start)
        ]
        heapq.heapify(heap)
        found: tuple[float, tuple[int, int]] | None = None
        while heap:
            cost, state, parent = heapq.heappop(heap)
            if cost > cutoff_m or (found is not None and cost >= found[0]):
                break
            if state in settled:
                continue
            settled[state] = parent
            e, d = state
            if e == to_edge:
                total = cost + (to_offset_m if d == 1 else self._lengths[e] - to_offset_m)
                if total <= cutoff_m and (found is None or total < found[0]):
                    found = (total, state)
            nxt_cost = cost + self._lengths[e]
            for nxt in graph.successors(state):
                if nxt not in settled:
                    heapq.heappush(heap, (nxt_cost, nxt, state))
        if found is None:
            return None
        chain: list[tuple[int, int]] = [found[1]]
        while (parent_state := settled.get(chain[-1])) is not None:
            chain.append(parent_state)
        edges = (from_edge, *(s[0] for s in reversed(chain)))
        return RouteDistance(float(found[0]), found[1][1], edges)
