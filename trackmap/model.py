"""The records of a track map and of the answers to its queries.

Map records (:class:`Edge`, :class:`Node`, :class:`ConflictPoint`, :class:`Stop`,
:class:`MapMetadata`, gathered in :class:`MapData`) are what a map file stores and what
:class:`trackmap.TrackMap` is built from. Query records (:class:`Candidate`,
:class:`CandidateBatch`, :class:`PathStep`, :class:`NodePass`, :class:`ConflictPass`,
:class:`Path`, :class:`RouteDistance`) are what its queries answer. All are frozen: a map
is shared read-only (see :func:`trackmap.load_default`).

Coordinates: every edge keeps its WGS84 vertices (the canonical form, written to the map
file) and their projection in the map's local metric frame (used for every computation).
Offsets along an edge are measured in metres from its first vertex.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import shapely

from trackmap.crs import LocalFrame
from trackmap.kinds import ConflictKind, Direction, NodeClass, PathEnd

__all__ = [
    "Candidate",
    "CandidateBatch",
    "ConflictPass",
    "ConflictPoint",
    "Edge",
    "FloatArray",
    "GradeSeparation",
    "IntArray",
    "MapData",
    "MapMetadata",
    "Node",
    "NodePass",
    "Path",
    "PathStep",
    "RouteDistance",
    "Stop",
    "TrackState",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


class TrackState(NamedTuple):
    """Running on an edge in a direction: a node of the traversal graphs.

    A tuple (networkx needs hashable nodes), so ``(edge_id, 1)`` finds the same node.
    """

    edge_id: int
    direction: Direction


class GradeSeparation(NamedTuple):
    """Two edges whose lines cross at different levels (a bridge or tunnel): no conflict.

    ``x``, ``y``: where the lines cross in the local frame, metres.
    """

    edge_a: int
    edge_b: int
    x: float
    y: float


# -- map records --------------------------------------------------------------------------
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
        ``preferred_direction``, ``oneway``, ``driving_side``, ``propagated`` or ``none``.
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
    cls : NodeClass
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
    kind : ConflictKind
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
    """A stop position snapped to the track.

    ``lon``, ``lat`` in degrees (OSM node ``stop_id``); ``edge_id`` and ``offset_m``
    (metres from the edge's first vertex) are None when no track lies within the build's
    ``stop_snap_m``.
    """

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
    direction: Direction
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
    """A junction node a path passes, with the move it makes there.

    ``distance_m`` is the distance from the path's origin, metres; ``choice`` names the
    branch taken at a facing switch (``straight``, ``left`` or ``right``), else None.
    """

    node_id: int
    cls: NodeClass
    distance_m: float
    from_edge: int
    to_edge: int
    choice: str | None


@dataclass(frozen=True, slots=True)
class ConflictPass:
    """A conflict point a path passes, ``distance_m`` metres from the path's origin."""

    conflict_id: int
    kind: ConflictKind
    distance_m: float
    edge_id: int


#: Node classes where a route picks a branch (``Path.switches``).
_SWITCH_CLASSES = frozenset({NodeClass.POINT_SWITCH, NodeClass.DOUBLE_SLIP})


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
    end : PathEnd
        ``horizon``, ``buffer_stop``, ``dead_end`` (no permitted move), or ``truncated``
        (too many branches).
    """

    zone: str
    steps: tuple[PathStep, ...]
    length_m: float
    nodes: tuple[NodePass, ...]
    conflicts: tuple[ConflictPass, ...]
    end: PathEnd

    @property
    def edges(self) -> tuple[int, ...]:
        """Edge ids in running order."""
        return tuple(s.edge_id for s in self.steps)

    @property
    def switches(self) -> tuple[NodePass, ...]:
        """The point switches and double slips passed."""
        return tuple(n for n in self.nodes if n.cls in _SWITCH_CLASSES)

    @property
    def crossings(self) -> tuple[ConflictPass, ...]:
        """The crossing conflict points passed (diamonds and at-grade crossings)."""
        return tuple(c for c in self.conflicts if c.kind != ConflictKind.MERGE)

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
    """Along-track distance between two positions and the direction of arrival.

    ``distance_m`` in metres; ``edges`` lists the edges run over, first to last.
    """

    distance_m: float
    arrival_direction: Direction
    edges: tuple[int, ...]


@dataclass(frozen=True)
class MapMetadata:
    """Provenance and build parameters kept with a map."""

    source: dict[str, Any] = field(default_factory=dict)
    build: dict[str, Any] = field(default_factory=dict)
    driving_side: str = "right"
    attribution: str = "© OpenStreetMap contributors, ODbL 1.0"
    created: str = ""

    def as_dict(self) -> dict[str, Any]:
        """The metadata as written to the map file header."""
        return {
            "source": self.source,
            "build": self.build,
            "driving_side": self.driving_side,
            "attribution": self.attribution,
            "created": self.created,
        }


@dataclass(frozen=True, slots=True)
class MapData:
    """Everything a map is made of: what a map file stores and a TrackMap is built from.

    Attributes
    ----------
    frame : LocalFrame
        The map's local metric frame.
    edges : tuple of Edge
        Edge ids are 0..n-1 in order.
    nodes : tuple of Node
    conflicts : tuple of ConflictPoint
    stops : tuple of Stop
    grade_separated : tuple of GradeSeparation
        Crossings of lines at different levels (not conflicts).
    metadata : MapMetadata
    """

    frame: LocalFrame
    edges: tuple[Edge, ...]
    nodes: tuple[Node, ...]
    conflicts: tuple[ConflictPoint, ...]
    stops: tuple[Stop, ...] = ()
    grade_separated: tuple[GradeSeparation, ...] = ()
    metadata: MapMetadata = field(default_factory=MapMetadata)
