"""Conflict points as the simulated drivers see them, and who gives way there.

With ``yield_at_conflicts`` (default) trams do not run through each other at merges,
diamond crossings and at-grade crossings: a tram claims a conflict point when it comes
within its braking distance plus 30 m of the fouling area; of two trams arriving on
different tracks the one that claimed first goes (a tram already in the fouling area
always goes; ties go to the tram earlier in the list) and the other stops at the fouling
point until the first has cleared it. Trams queued on the same track never compete. The
fouling extents are the map's, widened at diamond crossings to the clearance the crossing
angle needs (:func:`crossing_clearance_m`). This is a driver's give-way, not an
interlocking: trams running head-on into a single-track section can still meet and stop
nose to nose.

Before a run, :class:`ConflictIndex` and :func:`conflict_passes` find where each tram's
extended track passes a conflict point; during the run :class:`ConflictArbiter` settles,
every detection period, which trams have to yield and where they stop.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final, NamedTuple

import numpy as np
import numpy.typing as npt

from antikol.sim.track import Track
from trackmap import ConflictPoint, TrackMap

__all__ = [
    "ConflictArbiter",
    "ConflictIndex",
    "ConflictPass",
    "conflict_passes",
    "crossing_clearance_m",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

_CLAIM_MARGIN_M: Final = 30.0  # conflict claim distance beyond the braking distance
_OCCUPY_TOL_M: Final = 0.5  # a front this far into a fouling area occupies it


def crossing_clearance_m(angle_deg: float, *, width_m: float = 2.5, margin_m: float = 0.5) -> float:
    """Distance from a crossing point at which a tram clears a tram on the other track.

    Two tracks cross at ``angle_deg``. A tram whose front centre is ``d`` along its track
    from the crossing point is ``d·sin θ`` from the other track's centre line, and its
    front corners reach ``w/2·cos θ`` closer; it clears a vehicle of half width ``w/2`` on
    the other track, with ``margin_m``, when
    ``d >= (w/2·(1 + cos θ) + margin_m) / sin θ`` (1.75 m at 90°, 11 m at 15°).

    Parameters
    ----------
    angle_deg : float
        Crossing angle, degrees (folded into 0..90).
    width_m : float
        Vehicle width, metres.
    margin_m : float
        Lateral margin, metres.

    Returns
    -------
    float
        Metres along either track, at most 50.
    """
    theta = math.radians(abs(angle_deg) % 180.0)
    theta = min(theta, math.pi - theta)
    if theta < 1e-3:
        return 50.0
    need = (0.5 * width_m * (1.0 + math.cos(theta)) + margin_m) / math.sin(theta)
    return min(need, 50.0)


def _conflict_extents(net: TrackMap, c: ConflictPoint, *, width_m: float) -> tuple[float, ...]:
    """The map's conflict extents, widened at diamonds to the angle's clearance."""
    if c.kind != "diamond_crossing" or c.node_id is None or len(c.edges) != 4:
        return tuple(float(x) for x in c.extents_m)
    heads = []
    for e in c.edges:
        length = net.edge_length(e)
        at_start = net.edges[e].start_node == c.node_id
        px, py = net.point_at(e, 0.0 if at_start else length)
        qx, qy = net.point_at(e, min(8.0, length) if at_start else max(length - 8.0, 0.0))
        heads.append(math.atan2(qx - px, qy - py))  # leaving the crossing

    def off_straight(i: int, j: int) -> float:
        turn = (heads[i] - heads[j] + math.pi) % (2 * math.pi) - math.pi
        return abs(abs(turn) - math.pi)

    pairs = min(
        ((0, 1, 2, 3), (0, 2, 1, 3), (0, 3, 1, 2)),
        key=lambda p: off_straight(p[0], p[1]) + off_straight(p[2], p[3]),
    )
    angle = math.degrees(
        abs((heads[pairs[0]] - heads[pairs[2]] + math.pi) % (2 * math.pi) - math.pi)
    )
    clear = crossing_clearance_m(angle, width_m=width_m)
    return tuple(max(float(x), clear) for x in c.extents_m)


@dataclass(frozen=True)
class ConflictIndex:
    """A map's conflict points, indexed by where routes meet them.

    Attributes
    ----------
    at_node : dict of int to list of int
        Conflict ids at each node (merges, diamond crossings).
    on_edge : dict of int to list of (float, int)
        Offset (m from the edge's first vertex) and conflict id of the at-grade crossings
        on each edge.
    extents_m : dict of int to tuple of float
        Fouling extent along each of a conflict's edges, metres (widened at diamonds).
    conflicts : dict of int to ConflictPoint
    """

    at_node: dict[int, list[int]]
    on_edge: dict[int, list[tuple[float, int]]]
    extents_m: dict[int, tuple[float, ...]]
    conflicts: dict[int, ConflictPoint]

    @classmethod
    def of(cls, net: TrackMap, *, width_m: float) -> ConflictIndex:
        """Index the conflict points of ``net`` for vehicles ``width_m`` metres wide."""
        at_node: dict[int, list[int]] = {}
        on_edge: dict[int, list[tuple[float, int]]] = {}
        for c in net.conflicts:
            if c.node_id is not None:
                at_node.setdefault(c.node_id, []).append(c.conflict_id)
            else:
                for e, off in zip(c.edges, c.offsets_m, strict=True):
                    on_edge.setdefault(e, []).append((off, c.conflict_id))
        extents = {c.conflict_id: _conflict_extents(net, c, width_m=width_m) for c in net.conflicts}
        conflicts = {c.conflict_id: c for c in net.conflicts}
        return cls(at_node, on_edge, extents, conflicts)


class ConflictPass(NamedTuple):
    """One passage of a tram's extended track through a conflict point.

    Attributes
    ----------
    conflict_id : int
    distance_m : float
        Route distance of the conflict point, metres.
    extent_in_m, extent_out_m : float
        Fouling extent before and after it along the track, metres.
    entry : int
        Which track the tram arrives on (``2 · edge_id + (direction > 0)``): trams with the
        same entry queue behind each other and never compete.
    """

    conflict_id: int
    distance_m: float
    extent_in_m: float
    extent_out_m: float
    entry: int


def conflict_passes(track: Track, index: ConflictIndex) -> list[ConflictPass]:
    """Every conflict point a tram's extended track passes, in running order.

    Parameters
    ----------
    track : Track
    index : ConflictIndex

    Returns
    -------
    list of ConflictPass
        Sorted by route distance; a conflict point passed twice at the same distance
        (within 1 mm) is listed once.
    """
    tr = track
    out: dict[tuple[int, int], ConflictPass] = {}
    n = len(tr.edge)
    for k in range(n):
        e, d = int(tr.edge[k]), int(tr.dir[k])
        key = 2 * e + (1 if d > 0 else 0)
        for off, cid in index.on_edge.get(e, ()):
            dist = float(tr.b0[k] + (off if d > 0 else tr.len[k] - off))
            ext = index.extents_m[cid][index.conflicts[cid].edges.index(e)]
            out.setdefault((cid, round(dist * 1000)), ConflictPass(cid, dist, ext, ext, key))
        if k + 1 < n:
            node = int(tr.node_out[k])
            for cid in index.at_node.get(node, ()):
                c = index.conflicts[cid]
                e2 = int(tr.edge[k + 1])
                extents = index.extents_m[cid]
                ext_in = extents[c.edges.index(e)] if e in c.edges else 0.0
                ext_out = extents[c.edges.index(e2)] if e2 in c.edges else 0.0
                dist = float(tr.b1[k])
                out.setdefault(
                    (cid, round(dist * 1000)), ConflictPass(cid, dist, ext_in, ext_out, key)
                )
    return sorted(out.values(), key=lambda p: p.distance_m)


class ConflictArbiter:
    """Claims on conflict points and the resulting give-way of all trams (module notes).

    Parameters
    ----------
    passes : sequence of sequence of ConflictPass
        Each tram's passes, in tram order.
    length_m, plan_decel_mps2 : ndarray
        Each tram's length, metres, and planning deceleration, m/s².
    detect_every_s : float
        How often :meth:`settle` is called, s (a tram may cover that much more ground
        before the next settlement).
    """

    def __init__(
        self,
        passes: Sequence[Sequence[ConflictPass]],
        length_m: FloatArray,
        plan_decel_mps2: FloatArray,
        *,
        detect_every_s: float,
    ) -> None:
        f = np.array
        rows = [(i, *p) for i, of_tram in enumerate(passes) for p in of_tram]
        self.n_pass = len(rows)
        self.cp_tram = f([r[0] for r in rows], dtype=np.int64)
        self.cp_conf = f([r[1] for r in rows], dtype=np.int64)
        self.cp_dist = f([r[2] for r in rows], dtype=float)
        self.cp_in = f([r[3] for r in rows], dtype=float)
        self.cp_out = f([r[4] for r in rows], dtype=float)
        self.cp_entry = f([r[5] for r in rows], dtype=np.int64)
        self.length = length_m
        self.b_plan = plan_decel_mps2
        self.detect_every_s = detect_every_s
        self.claim = np.full(self.n_pass, np.inf)  # when each pass was claimed, s

    def settle(
        self,
        t: float,
        s: FloatArray,
        v: FloatArray,
        present: BoolArray,
        at_end: BoolArray,
        dwell_until: FloatArray,
        hold: BoolArray,
        yield_pos: FloatArray,
    ) -> None:
        """Update the claims at time ``t`` (s) and write where each tram has to stop.

        Parameters
        ----------
        t : float
            Simulation time, s.
        s, v : ndarray
            Route distance of each tram's front, metres, and speed, m/s.
        present, at_end : ndarray of bool
            In service; stopped at the route end for good.
        dwell_until : ndarray
            End of the current dwell, s (inf when not dwelling).
        hold : ndarray of bool
            Held by a script event.
        yield_pos : ndarray
            Output, overwritten: the route distance at which each tram has to stop to give
            way, metres (inf when it need not).
        """
        ct = self.cp_tram
        sp = s[ct]
        vp = v[ct]
        start = self.cp_dist - self.cp_in
        # a tram waiting at the fouling point (its yield target) does not occupy it
        occupying = (
            present[ct]
            & (sp > start + _OCCUPY_TOL_M)
            & (sp - self.length[ct] < self.cp_dist + self.cp_out)
        )
        reach = vp * vp / (2.0 * self.b_plan[ct]) + vp * self.detect_every_s + _CLAIM_MARGIN_M
        idle = np.isfinite(dwell_until[ct]) | hold[ct] | at_end[ct]
        approaching = (
            present[ct] & ~occupying & ~idle & (sp <= start + _OCCUPY_TOL_M) & (sp >= start - reach)
        )
        active = occupying | approaching
        newly = active & np.isinf(self.claim)
        self.claim[newly] = t
        self.claim[~active] = np.inf
        yield_pos[:] = np.inf
        idx = np.flatnonzero(active)
        if len(idx) < 2:
            return
        prio = np.where(occupying[idx], -1.0, self.claim[idx])
        order = np.lexsort((ct[idx], prio, self.cp_conf[idx]))
        p = idx[order]
        conf = self.cp_conf[p]
        entry = self.cp_entry[p]
        head = np.concatenate(([True], conf[1:] != conf[:-1]))
        group_start = np.maximum.accumulate(np.where(head, np.arange(len(p)), 0))
        diff = entry != entry[group_start]
        cs = np.cumsum(diff) - diff
        before = cs - cs[group_start]
        must_yield = (diff | (before > 0)) & ~occupying[p]
        # a tram on a loop may pass a conflict point twice: it never yields to itself
        starts = np.flatnonzero(head)
        trams = ct[p]
        alone = np.minimum.reduceat(trams, starts) == np.maximum.reduceat(trams, starts)
        must_yield &= ~alone[np.cumsum(head) - 1]
        if np.count_nonzero(must_yield):
            y = p[must_yield]
            np.minimum.at(yield_pos, ct[y], start[y])
