"""The :class:`TrackMap`: a rail network in a local metric frame, with its queries.

A TrackMap holds the map's records (:mod:`trackmap.model`), a spatial index of its edges
for :meth:`TrackMap.candidates`, and the traversal graphs of :mod:`trackmap.routing` for
:meth:`TrackMap.paths_ahead` and :meth:`TrackMap.route_distance`.

Coordinates: every edge keeps its WGS84 vertices (the canonical form, written to the map
file) and their projection in the map's local metric frame (used for every computation).
Offsets along an edge are measured in metres from its first vertex; ``direction`` +1
(:attr:`Direction.FORWARD`) means travelling in the order of the vertices, -1 against it.
"""

from __future__ import annotations

import itertools
import math
import os
import pathlib
from collections import defaultdict
from collections.abc import Iterable, Sequence
from typing import Any

import networkx as nx
import numpy as np
import numpy.typing as npt
import shapely

from trackmap import mapfile, routing
from trackmap.crs import LocalFrame
from trackmap.errors import UnknownEdgeError
from trackmap.kinds import ConflictKind, NodeClass
from trackmap.linear import PackedLines
from trackmap.model import (
    Candidate,
    CandidateBatch,
    ConflictPoint,
    Edge,
    FloatArray,
    GradeSeparation,
    MapData,
    MapMetadata,
    Node,
    Path,
    RouteDistance,
    Stop,
)

__all__ = ["TrackMap"]


class TrackMap:
    """A rail network in a local metric frame, with spatial and routing queries.

    Build one with :func:`trackmap.build`, read one with :func:`trackmap.load` or
    :func:`trackmap.load_default`.

    Parameters
    ----------
    frame : LocalFrame
        The local metric frame of the map.
    edges : sequence of Edge
        Edge ids must be 0..n-1 in order.
    nodes : iterable of Node
    conflicts : sequence of ConflictPoint
    stops : sequence of Stop
    grade_separated : sequence of (edge_a, edge_b, x, y)
        Crossings of lines at different levels (not conflicts), metres.
    metadata : MapMetadata, optional

    Raises
    ------
    ValueError
        The edge ids are not 0..n-1 in order.
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
        #: Crossings of grade-separated lines; not conflicts.
        self.grade_separated: tuple[GradeSeparation, ...] = tuple(
            GradeSeparation(*g) for g in grade_separated
        )
        self.metadata = metadata or MapMetadata()
        self._geoms = np.array([e.geometry for e in self.edges], dtype=object)
        self._lengths = shapely.length(self._geoms).astype(float)
        #: The edges' vertices in flat arrays: points along many edges without a shapely
        #: object per point (the numbers of GEOS, see :mod:`trackmap.linear`).
        self._lines = PackedLines(self._geoms)
        mid = shapely.line_interpolate_point(self._geoms, 0.5, normalized=True)
        self._convergence = self.frame.grid_north_azimuth_deg(
            shapely.get_x(mid), shapely.get_y(mid)
        )
        #: Traversal graphs and look-up tables of :mod:`trackmap.routing`.
        self.routing_index = routing.RoutingIndex.build(
            self.edges, self.nodes, self.conflicts, self._lengths
        )
        #: Permitted moves: :class:`TrackState` nodes, respecting running directions.
        self.traversal: nx.DiGraph = self.routing_index.traversal
        #: Physical moves: as ``traversal`` but ignoring running directions (for
        #: vehicles running against the permitted direction).
        self.traversal_any: nx.DiGraph = self.routing_index.traversal_any

    @classmethod
    def from_data(cls, data: MapData) -> TrackMap:
        """A map from its records (as read from a map file by :mod:`trackmap.mapfile`)."""
        return cls(
            frame=data.frame,
            edges=data.edges,
            nodes=data.nodes,
            conflicts=data.conflicts,
            stops=data.stops,
            grade_separated=data.grade_separated,
            metadata=data.metadata,
        )

    @property
    def data(self) -> MapData:
        """The map's records (what a map file stores)."""
        return MapData(
            frame=self.frame,
            edges=self.edges,
            nodes=tuple(self.nodes.values()),
            conflicts=self.conflicts,
            stops=self.stops,
            grade_separated=self.grade_separated,
            metadata=self.metadata,
        )

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
        """Write the map as a versioned GeoJSON map file (see :mod:`trackmap.mapfile`).

        Returns the written file; raises :class:`trackmap.SourceError` if it cannot be
        written.
        """
        return mapfile.write(self.data, path, stats=self.stats())

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
            "buffer_stops": classes[NodeClass.BUFFER_STOP],
            "links": classes[NodeClass.LINK],
            "switches": classes[NodeClass.POINT_SWITCH],
            "diamond_crossings": classes[NodeClass.DIAMOND_CROSSING],
            "double_slips": classes[NodeClass.DOUBLE_SLIP],
            "unknown_nodes": classes[NodeClass.UNKNOWN],
            "components": len(self.components()),
            "conflict_points": len(self.conflicts),
            "unnoded_crossings": sum(1 for c in self.conflicts if c.kind == ConflictKind.CROSSING),
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
        """Vectorised candidates for local positions (metres), sorted by position, then edge.

        The edges within ``radius_m`` of each position and the nearest place on each
        (:meth:`trackmap.linear.PackedLines.nearest_within`: the numbers of
        :func:`shapely.line_locate_point`); a non-finite position has none.
        """
        if not radius_m > 0:
            raise ValueError(f"radius_m must be positive, got {radius_m}")
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        lines = self._lines
        p_idx, e_idx, offset = lines.nearest_within(x, y, radius_m)
        length = self._lengths[e_idx]
        # the projected point and half a metre either side, in one search
        n = len(e_idx)
        xs_, ys_ = lines.interpolate(
            np.concatenate((e_idx, e_idx, e_idx)),
            np.concatenate(
                (offset, np.minimum(offset + 0.5, length), np.maximum(offset - 0.5, 0.0))
            ),
        )
        proj_x, ahead_x, behind_x = xs_[:n], xs_[n : 2 * n], xs_[2 * n :]
        proj_y, ahead_y, behind_y = ys_[:n], ys_[n : 2 * n], ys_[2 * n :]
        tx = ahead_x - behind_x
        ty = ahead_y - behind_y
        dx = x[p_idx] - proj_x
        dy = y[p_idx] - proj_y
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
        return self._lines.interpolate(edge_ids, offsets_m)

    def headings_at(
        self, edge_ids: npt.ArrayLike, offsets_m: npt.ArrayLike, directions: npt.ArrayLike
    ) -> FloatArray:
        """Vectorised :meth:`heading_at`: true headings of travel, degrees (the same
        numbers, to the last bit, as one call per position)."""
        idx, off = np.broadcast_arrays(
            np.atleast_1d(np.asarray(edge_ids, dtype=np.int64)),
            np.atleast_1d(np.asarray(offsets_m, dtype=float)),
        )
        n = len(idx)
        # half a metre either side, in one search
        xs_, ys_ = self._lines.interpolate(
            np.concatenate((idx, idx)),
            np.concatenate((np.maximum(off - 0.5, 0.0), np.minimum(off + 0.5, self._lengths[idx]))),
        )
        dx = xs_[n:] - xs_[:n]
        dy = ys_[n:] - ys_[:n]
        # math.atan2 per element: numpy's SIMD arctan2 differs from the C library's in the
        # last bit for about 7 % of arguments, and heading_at uses the latter
        angle = np.fromiter(map(math.atan2, dx.tolist(), dy.tolist()), dtype=float, count=len(dx))
        h = np.degrees(angle) + self._convergence[idx]
        h = np.where(np.asarray(directions) < 0, h + 180.0, h)
        return np.asarray(h % 360.0, dtype=float)

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
        """The (edge, direction) states reachable from the end of an edge.

        Parameters
        ----------
        edge_id : int
        direction : Direction or int
            Running direction on the edge, +1/-1.
        respect_direction : bool
            Only permitted moves (default), or every physical move.

        Returns
        -------
        list of TrackState
            Empty when the state is not in the graph (e.g. against a one-way edge).
            Typed as plain ``(int, int)`` pairs, which they are, so that callers may mix
            them with their own tuples.
        """
        graph = self.routing_index.graph(respect_direction=respect_direction)
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

        ``offset_m`` is metres from the edge's first vertex, ``direction`` +1/-1 (a
        :class:`Direction`), ``horizon_m`` the look-ahead distance in metres. See
        :func:`trackmap.routing.paths_ahead` for the parameters, results and errors.
        """
        return routing.paths_ahead(
            self,
            edge_id,
            offset_m,
            direction,
            horizon_m,
            max_paths=max_paths,
            respect_direction=respect_direction,
        )

    def path_geometry(self, path: Path) -> shapely.LineString:
        """The path as a line in the local frame, metres (see :func:`routing.path_geometry`)."""
        return routing.path_geometry(self, path)

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

        Offsets and ``cutoff_m`` in metres, ``from_direction`` +1/-1; None when the target
        is out of reach. See :func:`trackmap.routing.route_distance` for the details.
        """
        return routing.route_distance(
            self,
            from_edge,
            from_offset_m,
            from_direction,
            to_edge,
            to_offset_m,
            cutoff_m=cutoff_m,
            respect_direction=respect_direction,
        )
