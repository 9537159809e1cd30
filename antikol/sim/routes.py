"""Routes: paths through the track map along permitted moves.

A :class:`Route` is a sequence of ``(edge_id, direction)`` steps of which every
consecutive pair is an arc of ``net.traversal`` (a permitted move), with a start offset on
the first edge and an end offset on the last. Route distances are metres along a route
from its start position; track positions are ``(edge_id, offset_m, direction)`` as in
:mod:`trackmap.network`.

Random routes and routes through a list of edges are built in
:mod:`antikol.sim.route_building`.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt

from antikol.report import MAX_ROUTE_EDGES
from trackmap import Stop, TrackMap

__all__ = ["Route", "map_stops_on_route", "move_hint"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class Route:
    """A path through the track map along permitted moves.

    Build one with :meth:`from_steps`, :func:`~antikol.sim.route_building.random_route` or
    :func:`~antikol.sim.route_building.route_from_edges`, which check the steps against
    the map; the constructor itself checks only the internal consistency (it has no map).

    Route distances are metres from the start position (``start_offset_m`` on the first
    step's edge) along the steps, from 0 to :attr:`length_m`.

    Attributes
    ----------
    steps : tuple of (int, int)
        ``(edge_id, direction)`` in running order; direction +1 runs along the edge's
        vertices, -1 against them. Consecutive steps are arcs of ``net.traversal``.
    edge_lengths_m : tuple of float
        Length of each step's edge, metres.
    start_offset_m : float
        Start position on the first edge, metres from its first vertex.
    end_offset_m : float
        End position on the last edge, metres from its first vertex.
    wrong_way : bool
        The route may run against permitted directions (single-line working after a
        crossover): its moves are physical moves (``net.traversal_any``), not
        necessarily permitted ones.
    """

    steps: tuple[tuple[int, int], ...]
    edge_lengths_m: tuple[float, ...]
    start_offset_m: float
    end_offset_m: float
    wrong_way: bool = False

    def __post_init__(self) -> None:
        steps = tuple((int(e), int(d)) for e, d in self.steps)
        lengths = tuple(float(x) for x in self.edge_lengths_m)
        object.__setattr__(self, "steps", steps)
        object.__setattr__(self, "edge_lengths_m", lengths)
        object.__setattr__(self, "start_offset_m", float(self.start_offset_m))
        object.__setattr__(self, "end_offset_m", float(self.end_offset_m))
        if not steps:
            raise ValueError("a route needs at least one step")
        if len(lengths) != len(steps):
            raise ValueError(f"route has {len(steps)} steps but {len(lengths)} edge lengths")
        for k, ((edge_id, direction), length) in enumerate(zip(steps, lengths, strict=True)):
            if direction not in (1, -1):
                raise ValueError(f"route step {k} (edge {edge_id}): direction must be +1 or -1")
            if not (math.isfinite(length) and length > 0.0):
                raise ValueError(f"route step {k} (edge {edge_id}): length {length!r} m")
        tol = 1e-6
        if not -tol <= self.start_offset_m <= lengths[0] + tol:
            raise ValueError(
                f"start_offset_m={self.start_offset_m!r} is outside edge {steps[0][0]} "
                f"(0..{lengths[0]:.3f} m)"
            )
        if not -tol <= self.end_offset_m <= lengths[-1] + tol:
            raise ValueError(
                f"end_offset_m={self.end_offset_m!r} is outside edge {steps[-1][0]} "
                f"(0..{lengths[-1]:.3f} m)"
            )
        if self.length_m < -tol:
            raise ValueError(
                f"the route ends {-self.length_m:.3f} m before it starts on edge {steps[0][0]}"
            )

    # -- construction ------------------------------------------------------------------
    @classmethod
    def from_steps(
        cls,
        net: TrackMap,
        steps: Iterable[tuple[int, int]],
        *,
        start_offset_m: float | None = None,
        end_offset_m: float | None = None,
        wrong_way: bool = False,
    ) -> Route:
        """A route from ``(edge_id, direction)`` steps, checked against the map.

        Parameters
        ----------
        net : TrackMap
        steps : iterable of (int, int)
            ``(edge_id, direction)`` in running order.
        start_offset_m : float, optional
            Start on the first edge, metres from its first vertex; default the edge's
            entry end (0 for direction +1, its length for -1).
        end_offset_m : float, optional
            End on the last edge, metres from its first vertex; default its exit end.
        wrong_way : bool
            Allow running against permitted directions: check the steps against the
            physical moves (``net.traversal_any``) only.

        Returns
        -------
        Route

        Raises
        ------
        trackmap.UnknownEdgeError
            A step names an edge the map does not have.
        ValueError
            A step runs against the edge's permitted direction, two consecutive steps are
            not a permitted move (the message names the pair), or an offset is outside
            its edge.
        """
        steps = tuple((int(e), int(d)) for e, d in steps)
        if not steps:
            raise ValueError("a route needs at least one step")
        for k, (edge_id, direction) in enumerate(steps):
            edge = net.edge(edge_id)
            if direction not in (1, -1):
                raise ValueError(f"route step {k} (edge {edge_id}): direction must be +1 or -1")
            if not wrong_way and not edge.allows(direction):
                raise ValueError(
                    f"route step {k}: edge {edge_id} does not permit running direction "
                    f"{direction:+d} (permitted: {edge.direction:+d})"
                )
        graph = net.traversal_any if wrong_way else net.traversal
        for k, (a, b) in enumerate(itertools.pairwise(steps)):
            if not graph.has_edge(a, b):
                what = "physical" if wrong_way else "permitted"
                raise ValueError(
                    f"route steps {k} and {k + 1}: {a} -> {b} is not a {what} move"
                    + ("" if wrong_way else move_hint(net, a, b))
                )
        lengths = tuple(net.edge_length(e) for e, _ in steps)
        if start_offset_m is None:
            start_offset_m = 0.0 if steps[0][1] == 1 else lengths[0]
        if end_offset_m is None:
            end_offset_m = lengths[-1] if steps[-1][1] == 1 else 0.0
        return cls(steps, lengths, float(start_offset_m), float(end_offset_m), wrong_way=wrong_way)

    # -- basic facts -------------------------------------------------------------------
    @property
    def edge_ids(self) -> tuple[int, ...]:
        """Edge ids in running order."""
        return tuple(e for e, _ in self.steps)

    @cached_property
    def entry_m(self) -> FloatArray:
        """Route distance of each step's edge entry, metres (negative for the first step)."""
        lengths = np.asarray(self.edge_lengths_m, dtype=float)
        first_d = self.steps[0][1]
        behind = self.start_offset_m if first_d == 1 else lengths[0] - self.start_offset_m
        entry = np.concatenate(([0.0], np.cumsum(lengths[:-1]))) - behind
        return entry

    @property
    def length_m(self) -> float:
        """Length from the start to the end position, metres."""
        last_d = self.steps[-1][1]
        last_len = self.edge_lengths_m[-1]
        into_last = self.end_offset_m if last_d == 1 else last_len - self.end_offset_m
        return float(self.entry_m[-1] + into_last)

    def __len__(self) -> int:
        return len(self.steps)

    # -- conversions -------------------------------------------------------------------
    def locate(self, distance_m: float) -> tuple[int, float, int]:
        """Track position at a route distance.

        Parameters
        ----------
        distance_m : float
            Route distance, metres, in ``[0, length_m]``.

        Returns
        -------
        edge_id : int
        offset_m : float
            Metres from the edge's first vertex.
        direction : int
            Running direction on the edge (+1/-1).

        Raises
        ------
        ValueError
            The distance is outside the route.
        """
        e, o, d = self.locate_array(np.array([float(distance_m)]))
        return int(e[0]), float(o[0]), int(d[0])

    def locate_array(self, distances_m: npt.ArrayLike) -> tuple[IntArray, FloatArray, IntArray]:
        """Vectorised :meth:`locate`: arrays of edge ids, offsets (m) and directions.

        At a junction a distance maps to the start of the later step.
        """
        dist = np.asarray(distances_m, dtype=float)
        length = self.length_m
        bad = ~((dist >= -1e-6) & (dist <= length + 1e-6))
        if bad.any():
            raise ValueError(
                f"route distance {float(dist[bad].flat[0])!r} m is outside the route "
                f"(0..{length:.3f} m)"
            )
        return _locate(
            self.entry_m,
            np.asarray(self.edge_ids, dtype=np.int64),
            np.array([d for _, d in self.steps], dtype=np.int64),
            np.asarray(self.edge_lengths_m, dtype=float),
            dist,
        )

    def distance_of(self, edge_id: int, offset_m: float, *, after_m: float = 0.0) -> float | None:
        """Route distance of a track position, or None when the route does not pass it.

        Parameters
        ----------
        edge_id : int
        offset_m : float
            Metres from the edge's first vertex.
        after_m : float
            Return the first passage at or after this route distance, metres (routes may
            pass an edge twice); a negative one admits the first edge behind the route's
            start (a negative distance).

        Returns
        -------
        float or None
        """
        d = self.distances_of(np.array([edge_id]), np.array([offset_m]), after_m=after_m)
        return None if np.isnan(d[0]) else float(d[0])

    def distances_of(
        self, edge_ids: npt.ArrayLike, offsets_m: npt.ArrayLike, *, after_m: float = 0.0
    ) -> FloatArray:
        """Vectorised :meth:`distance_of`: route distances (m), NaN where not on the route."""
        e = np.atleast_1d(np.asarray(edge_ids, dtype=np.int64))
        o = np.atleast_1d(np.asarray(offsets_m, dtype=float))
        if e.shape != o.shape:
            raise ValueError(f"{e.shape[0]} edge ids but {o.shape[0]} offsets")
        route_e = np.asarray(self.edge_ids, dtype=np.int64)
        route_d = np.array([d for _, d in self.steps], dtype=np.int64)
        lengths = np.asarray(self.edge_lengths_m, dtype=float)
        match = e[:, None] == route_e[None, :]
        rel = np.where(route_d[None, :] > 0, o[:, None], lengths[None, :] - o[:, None])
        dist = self.entry_m[None, :] + rel
        ok = (
            match
            & (dist >= after_m - 1e-9)
            & (dist <= self.length_m + 1e-9)
            & (rel >= -1e-9)
            & (rel <= lengths[None, :] + 1e-9)
        )
        dist = np.where(ok, dist, np.inf)
        best = dist.min(axis=1, initial=np.inf)
        return np.where(np.isfinite(best), best, np.nan)

    def edges_ahead(self, distance_m: float, *, limit: int = MAX_ROUTE_EDGES) -> tuple[int, ...]:
        """Edge ids from the one at a route distance to the end, at most ``limit`` of them."""
        k = int(np.searchsorted(self.entry_m, float(distance_m), side="right") - 1)
        k = min(max(k, 0), len(self.steps) - 1)
        return self.edge_ids[k : k + limit]

    def xy(self, net: TrackMap, distances_m: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Local (x, y) of route distances, metres (shapely; not for inner loops)."""
        e, o, _ = self.locate_array(np.atleast_1d(np.asarray(distances_m, dtype=float)))
        x, y = net.points_at(e, o)
        return np.asarray(x, dtype=float), np.asarray(y, dtype=float)


def _locate(
    entry: FloatArray, edges: IntArray, dirs: IntArray, lengths: FloatArray, dist: FloatArray
) -> tuple[IntArray, FloatArray, IntArray]:
    k = np.clip(np.searchsorted(entry, dist, side="right") - 1, 0, len(entry) - 1)
    rel = dist - entry[k]
    off = np.where(dirs[k] > 0, rel, lengths[k] - rel)
    off = np.clip(off, 0.0, lengths[k])
    return edges[k], off, dirs[k]


def move_hint(net: TrackMap, a: tuple[int, int], b: tuple[int, int]) -> str:
    """Why the move ``a -> b`` between ``(edge_id, direction)`` states is not permitted.

    Returns
    -------
    str
        A parenthesised remark to append to an error message when the tracks connect but
        only against a permitted running direction, else ``""``.
    """
    try:
        physical = b in net.successors(a[0], a[1], respect_direction=False)
    except TypeError:  # an older TrackMap without respect_direction
        physical = False
    if physical:
        return " (the tracks connect, but only against a permitted running direction)"
    return ""


def map_stops_on_route(net: TrackMap, route: Route) -> tuple[tuple[float, Stop], ...]:
    """The map's stops the route passes, with their route distances, in order.

    A stop on an edge the route runs twice is listed twice.

    Parameters
    ----------
    net : TrackMap
    route : Route

    Returns
    -------
    tuple of (float, trackmap.Stop)
        Route distance of each stop, metres, and the stop.
    """
    by_edge: dict[int, list[Stop]] = {}
    for stop in net.stops:
        if stop.edge_id is not None and stop.offset_m is not None:
            by_edge.setdefault(stop.edge_id, []).append(stop)
    out: list[tuple[float, Stop]] = []
    entry = route.entry_m
    length = route.length_m
    for k, (edge_id, d) in enumerate(route.steps):
        for stop in by_edge.get(edge_id, ()):
            if stop.offset_m is None:  # pragma: no cover - only placed stops are indexed
                continue
            rel = stop.offset_m if d == 1 else route.edge_lengths_m[k] - stop.offset_m
            dist = float(entry[k] + rel)
            if -1e-9 <= dist <= length + 1e-9:
                out.append((dist, stop))
    out.sort(key=lambda item: item[0])
    return tuple(out)
