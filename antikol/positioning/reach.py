"""Along-track distances between track positions, precomputed once per map.

Positioning asks, for every pair (previous hypothesis, candidate) of every vehicle at every
cycle, how far along the track one lies from the other. Walking the network for each pair
costs milliseconds; here the distances between every pair of **track states** (an edge and
a running direction) within ``reach_m`` are computed once with a compiled shortest-path
search (:func:`scipy.sparse.csgraph.dijkstra` with a distance limit), and each query is an
array lookup (:func:`numpy.searchsorted`), vectorised over any number of pairs.

A state id packs an edge and a running direction: ``2 * edge_id`` runs along the edge's
vertices (+1), ``2 * edge_id + 1`` against them (-1).

>>> import numpy as np, trackmap
>>> from antikol.positioning.reach import ReachTable
>>> net = trackmap.load_default()
>>> table = ReachTable.for_map(net, reach_m=400.0)
>>> s = np.array([0]); o = np.array([10.0])
>>> float(table.signed_distance(s, o, s, o + 25.0, physical=True)[0])
25.0
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt
import shapely
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from antikol.positioning.headings import HeadingProfile

__all__ = ["ReachTable", "enters_within", "state_direction", "state_edge", "state_id"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

#: Sources handled per Dijkstra call: its dense result is sources × all states (Kraków:
#: 5,312 states; at 256 sources 11 MB, copied once more on the way, the peak of every
#: positioner's construction; at 64 about a quarter, in the same time)
_CHUNK = 64


def state_id(edge_id: Any, direction: Any) -> Any:
    """State id of (edge, running direction); scalars or arrays."""
    return 2 * np.asarray(edge_id, dtype=np.int64) + (np.asarray(direction) < 0)


def state_edge(state: Any) -> Any:
    """Edge id of a state id; scalars or arrays."""
    return np.asarray(state, dtype=np.int64) >> 1


def state_direction(state: Any) -> Any:
    """Running direction (+1/-1) of a state id; scalars or arrays."""
    return 1 - 2 * (np.asarray(state, dtype=np.int64) & 1)


def enters_within(net: Any, origin: tuple[int, int], target: tuple[int, int], steps: int) -> bool:
    """Whether a vehicle on ``origin`` enters ``target`` within ``steps`` permitted moves
    from edge to edge (both ``(edge id, direction)``; ``origin`` itself does not count).

    Parameters
    ----------
    net : trackmap.TrackMap
    origin, target : (int, int)
        Track states: edge id and running direction (+1/-1).
    steps : int
        Edges entered at most.

    Returns
    -------
    bool
    """
    frontier = [origin]
    for _ in range(steps):
        frontier = [n for e, d in frontier for n in net.successors(e, d)]
        if target in frontier:
            return True
    return False


@dataclass(frozen=True, slots=True)
class _Distances:
    """Exit-to-entry distances ``keys = from * n_states + to`` (sorted) and their values."""

    keys: IntArray
    metres: FloatArray

    def lookup(self, frm: IntArray, to: IntArray, n_states: int) -> FloatArray:
        key = frm * n_states + to
        keys = self.keys
        if len(keys) == 0:
            return np.full(key.shape, np.inf)
        # (the array's own methods: np.searchsorted's dispatch costs more than a few keys)
        idx = np.minimum(keys.searchsorted(key), len(keys) - 1)
        return np.where(keys[idx] == key, self.metres[idx], np.inf)


class ReachTable:
    """Along-track distances between track states of one map, up to ``reach_m``.

    Parameters
    ----------
    track_map : trackmap.TrackMap
    reach_m : float
        Longest exit-to-entry distance kept, m.

    Notes
    -----
    Two tables are kept: over **physical** moves (any move the track geometry allows,
    whatever the permitted running direction — a vehicle may run the wrong way) and over
    **permitted** moves only.
    """

    # maps compare by content and are unhashable: key by identity, held weakly
    _cache: ClassVar[dict[int, tuple[weakref.ref[Any], dict[float, ReachTable]]]] = {}

    def __init__(self, track_map: Any, *, reach_m: float) -> None:
        self.reach_m = float(reach_m)
        edges = track_map.edges
        self.n_states = 2 * len(edges)
        self.lengths: FloatArray = np.asarray(
            shapely.length([e.geometry for e in edges]), dtype=float
        )
        self.allowed: npt.NDArray[np.bool_] = np.array(
            [e.allows(1 if k % 2 == 0 else -1) for e in edges for k in (0, 1)], dtype=bool
        )
        #: the track headings every metre (the course's comparison, built once with these)
        self.headings = HeadingProfile(track_map)
        self._physical = self._distances(track_map.traversal_any.edges())
        #: per state id: whether the track runs on to one state only at its end (no facing
        #: switch there), whatever the permitted directions
        self.unbranched_exit: npt.NDArray[np.bool_] = np.ones(self.n_states, dtype=bool)
        for (eu, du), n_out in track_map.traversal_any.out_degree():
            self.unbranched_exit[int(state_id(eu, du))] = n_out <= 1
        # the states each state is entered from (a trailing switch: several), -1 padded
        ways_in: list[list[int]] = [[] for _ in range(self.n_states)]
        for (eu, du), (ev, dv) in track_map.traversal_any.edges():
            ways_in[int(state_id(ev, dv))].append(int(state_id(eu, du)))
        width = max((len(w) for w in ways_in), default=0)
        self._ways_in = np.full((self.n_states, max(width, 1)), -1, dtype=np.int64)
        for k, w in enumerate(ways_in):
            self._ways_in[k, : len(w)] = w
        #: per state id: how many states it is entered from
        self.ways_in_count: IntArray = (self._ways_in >= 0).sum(axis=1)
        self._permitted = self._distances(track_map.traversal.edges())
        # steps back (a standing vehicle's fixes scatter around it) cross only nodes where
        # the track behind is unambiguous: stepping back from past a trailing switch onto
        # one of the tracks that join there would let a hypothesis change track without
        # moving (a tram waiting at a junction, placed on one joining track and the other)
        self._behind_physical = self._distances(_unbranched(track_map.traversal_any))
        self._behind_permitted = self._distances(_unbranched(track_map.traversal))

    @classmethod
    def for_map(cls, track_map: Any, *, reach_m: float) -> ReachTable:
        """The table of a map, computed once per map object and distance."""
        key = id(track_map)
        entry = cls._cache.get(key)
        if entry is None or entry[0]() is not track_map:
            entry = (weakref.ref(track_map, lambda _: cls._cache.pop(key, None)), {})
            cls._cache[key] = entry
        per_map = entry[1]
        table = per_map.get(reach_m)
        if table is None:
            table = per_map[reach_m] = cls(track_map, reach_m=reach_m)
        return table

    def _distances(self, moves: Any) -> _Distances:
        """Dijkstra over the moves between states (pairs of (edge, direction)), with an
        entry and an exit node per state.

        entry(s) -> exit(s) weighs the edge's length, exit(u) -> entry(v) is a move at a
        node (0 m), so the distance from exit(u) to entry(v) is the track between them.
        """
        n = self.n_states
        rows: list[int] = []
        cols: list[int] = []
        weights: list[float] = []
        for s in range(n):
            rows.append(s)  # entry(s) = s
            cols.append(n + s)  # exit(s) = n + s
            weights.append(max(float(self.lengths[s >> 1]), 1e-6))
        for (eu, du), (ev, dv) in moves:
            rows.append(n + int(state_id(eu, du)))
            cols.append(int(state_id(ev, dv)))
            weights.append(1e-9)  # csgraph drops explicit zeros
        matrix = csr_matrix((weights, (rows, cols)), shape=(2 * n, 2 * n))
        keys: list[IntArray] = []
        metres: list[FloatArray] = []
        for lo in range(0, n, _CHUNK):
            sources = np.arange(lo, min(lo + _CHUNK, n)) + n
            dist = dijkstra(matrix, directed=True, indices=sources, limit=self.reach_m + 1e-6)
            entry = dist[:, :n]
            src_local, to = np.nonzero(np.isfinite(entry))
            frm = sources[src_local] - n
            keep = frm != to
            keys.append(frm[keep].astype(np.int64) * n + to[keep])
            metres.append(np.round(entry[src_local[keep], to[keep]], 6))
        all_keys = np.concatenate(keys) if keys else np.zeros(0, np.int64)
        all_m = np.concatenate(metres) if metres else np.zeros(0)
        order = np.argsort(all_keys)
        return _Distances(all_keys[order], all_m[order])

    # -- queries -------------------------------------------------------------------------
    def remaining(self, state: IntArray, offset_m: FloatArray) -> FloatArray:
        """Distance from a position to the end of its edge in the state's direction, m."""
        length = self.lengths[state >> 1]
        forward = (state & 1) == 0
        return np.where(forward, length - offset_m, offset_m)

    def since_entry(self, state: IntArray, offset_m: FloatArray) -> FloatArray:
        """Distance from the start of the edge (in the state's direction) to a position, m."""
        length = self.lengths[state >> 1]
        forward = (state & 1) == 0
        return np.where(forward, offset_m, length - offset_m)

    def ahead(
        self,
        frm: IntArray,
        frm_offset_m: FloatArray,
        to: IntArray,
        to_offset_m: FloatArray,
        *,
        physical: bool = True,
    ) -> FloatArray:
        """Distance from one position running in state ``frm`` forward to another, m.

        ``inf`` where ``to`` is not reachable within ``reach_m`` (or lies behind on the
        same edge).
        """
        table = self._physical if physical else self._permitted
        return self._forward(table, frm, frm_offset_m, to, to_offset_m)

    def between(
        self, frm: IntArray, frm_offset_m: FloatArray, to: IntArray, to_offset_m: FloatArray
    ) -> FloatArray:
        """Signed distance along the track from one position to another, m: positive when
        ``to`` lies ahead in ``frm``'s running direction, negative behind (the nearer way
        when both are within ``reach_m``), ``inf`` when neither is."""
        fwd = self.ahead(frm, frm_offset_m, to, to_offset_m)
        back = self.ahead(to, to_offset_m, frm, frm_offset_m)
        return np.where(fwd <= back, fwd, -back)

    def adjacent(self, frm: IntArray, to: IntArray, *, physical: bool = True) -> BoolArray:
        """Whether state ``to`` is entered straight from the end of state ``frm`` (one node
        between them, no track)."""
        frm = np.asarray(frm, dtype=np.int64)
        to = np.asarray(to, dtype=np.int64)
        table = self._physical if physical else self._permitted
        return np.asarray(table.lookup(frm, to, self.n_states) < 1e-5)

    def way_in(self, frm: IntArray, to: IntArray, run_m: FloatArray) -> IntArray:
        """The state a run of ``run_m`` (m) from a place in state ``frm`` entered state
        ``to`` from: the one of the states ``to`` is entered from that such a run reaches
        (the track from the end of ``frm`` to its entry is no longer than the run), -1
        where none or several do."""
        frm = np.asarray(frm, dtype=np.int64)
        ways = self._ways_in[np.asarray(to, dtype=np.int64)]  # (n, width)
        reach = self._physical.lookup(
            np.repeat(frm[:, None], ways.shape[1], axis=1), np.maximum(ways, 0), self.n_states
        )
        near = (ways >= 0) & ((ways == frm[:, None]) | (reach <= np.asarray(run_m)[:, None]))
        one = near.sum(axis=1) == 1
        return np.where(one, ways[np.arange(len(ways)), np.argmax(near, axis=1)], -1)

    def behind(
        self,
        frm: IntArray,
        frm_offset_m: FloatArray,
        to: IntArray,
        to_offset_m: FloatArray,
        *,
        physical: bool = True,
    ) -> FloatArray:
        """Distance from one position running in state ``frm`` back to another of the same
        running direction, m: ``inf`` where ``to`` lies beyond a node at which several
        tracks join behind ``frm`` (a trailing switch: which of them the vehicle came by is
        not known from the states), ahead on the same edge, or beyond ``reach_m``.
        """
        table = self._behind_physical if physical else self._behind_permitted
        # back in one running direction is ahead in the other
        frm = np.asarray(frm, dtype=np.int64) ^ 1
        return self._forward(table, frm, frm_offset_m, np.asarray(to, np.int64) ^ 1, to_offset_m)

    def _forward(
        self,
        table: _Distances,
        frm: IntArray,
        frm_offset_m: FloatArray,
        to: IntArray,
        to_offset_m: FloatArray,
    ) -> FloatArray:
        """Distance ahead from ``frm`` to ``to`` over the moves of ``table``, m."""
        frm = np.asarray(frm, dtype=np.int64)
        to = np.asarray(to, dtype=np.int64)
        frm_offset_m = np.asarray(frm_offset_m, dtype=float)
        to_offset_m = np.asarray(to_offset_m, dtype=float)
        between = table.lookup(frm, to, self.n_states)
        # (remaining and since_entry inline: the same arithmetic, fewer calls)
        lengths = self.lengths
        frm_forward = (frm & 1) == 0
        out = (
            np.where(frm_forward, lengths[frm >> 1] - frm_offset_m, frm_offset_m)
            + between
            + np.where((to & 1) == 0, to_offset_m, lengths[to >> 1] - to_offset_m)
        )
        along = (to_offset_m - frm_offset_m) * np.where(frm_forward, 1.0, -1.0)
        return np.where((frm == to) & (along >= -1e-9), along, out)

    def signed_distance(
        self,
        frm: IntArray,
        frm_offset_m: FloatArray,
        to: IntArray,
        to_offset_m: FloatArray,
        *,
        physical: bool = True,
        expected_m: FloatArray | float = 0.0,
        came_from: IntArray | None = None,
    ) -> FloatArray:
        """Signed along-track distance from a position to a candidate of the same running
        direction: positive ahead, negative behind, m.

        When the candidate is both ahead (by going round) and behind, the one closer to
        ``expected_m`` is returned; ``inf`` when neither is within ``reach_m``. Behind is
        as :meth:`behind` (not back across a trailing switch), except onto ``came_from``:
        the state each position entered its own from, where known (-1: not known).
        """
        frm = np.asarray(frm, dtype=np.int64)
        to = np.asarray(to, dtype=np.int64)
        fwd = self.ahead(frm, frm_offset_m, to, to_offset_m, physical=physical)
        back = self.behind(frm, frm_offset_m, to, to_offset_m, physical=physical)
        if came_from is not None:
            # the track it came by: back across the switch the way it came
            home = np.broadcast_to(np.asarray(came_from, dtype=np.int64), to.shape) == to
            home &= ~np.isfinite(back)
            if home.any():
                fo = np.broadcast_to(np.asarray(frm_offset_m, dtype=float), to.shape)
                tof = np.broadcast_to(np.asarray(to_offset_m, dtype=float), to.shape)
                back = back.copy()
                back[home] = self.ahead(
                    frm[home] ^ 1, fo[home], to[home] ^ 1, tof[home], physical=physical
                )
        expected = np.asarray(expected_m, dtype=float)
        use_back = np.abs(-back - expected) < np.abs(fwd - expected)
        return np.where(use_back, -back, fwd)


def _unbranched(graph: Any) -> list[tuple[Any, Any]]:
    """The moves of a state graph from states with a single successor: reversed, the
    moves back across nodes where the track behind is unambiguous."""
    return [(u, v) for u, v in graph.edges() if graph.out_degree(u) == 1]
