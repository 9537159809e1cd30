"""Ground truth from simulated true states: which vehicle pairs need a warning, and when.

Ground truth is computed from the **true** states of the simulator, never from the noisy
reports. For every ordered pair (own, other) at every analysis time:

* **warning required** — the other vehicle is on the own vehicle's *actual* future route
  (the route it really drives) within the braking-model distance for that case (except a
  standing own vehicle whose leader pulls away): a
  leader's rear within :func:`~antikol.analysis.braking.rear_end_distance` (moving-leader rule, a
  leader braking hard counts as standing), an oncoming front within
  :func:`~antikol.analysis.braking.head_on_distance`; or both vehicles really pass the same merge or
  crossing conflict point from different tracks, within ``window_slack_s`` of each other,
  and the own vehicle is within its :func:`~antikol.analysis.braking.warning_distance` of the
  conflict area;
* **clearly conflict-free** — the other vehicle is not on the own future route within
  ``clear_factor`` x the own horizon (either way round), and the two share no conflict
  point they reach within their horizons;
* otherwise the pair is **neutral** (a conflict exists but no warning is yet required):
  neither a warning nor its absence is scored there.

Analysers are scored against it in :mod:`antikol.evaluation.scoring`.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Final

import numpy as np

from antikol.analysis import braking
from antikol.sim import Route, SimulationResult, TramSpec, Truth
from antikol.thresholds import MIN_HORIZON_M, STANDING_SPEED_MPS
from trackmap import TrackMap

__all__ = [
    "CLEAR",
    "NEUTRAL",
    "REQUIRED",
    "STOPPED_MPS",
    "GroundTruth",
    "Passage",
    "analysis_times",
    "ground_truth",
]

#: Pair states in :attr:`GroundTruth.state`: warning required, neutral, clearly conflict-free
#: (``-1``: one of the two vehicles is not in service).
REQUIRED: Final = 2
NEUTRAL: Final = 1
CLEAR: Final = 0
#: A vehicle slower than this is standing: a leader pulling away needs no warning, m/s.
STOPPED_MPS: Final = STANDING_SPEED_MPS


@dataclass(frozen=True, slots=True)
class Passage:
    """A route passing a conflict point: where, through which edges, and when (truth)."""

    conflict_id: int
    kind: str
    distance_m: float
    from_edge: int
    to_edge: int
    extent_in_m: float
    extent_out_m: float
    t_in_s: float
    t_out_s: float


@dataclass(frozen=True)
class GroundTruth:
    """Per analysis time, the state of every ordered pair.

    Attributes
    ----------
    times_s : ndarray
        Analysis times, s.
    vehicles : list of str
    state : dict of (own, other) to ndarray of int8
        ``2`` warning required, ``1`` neutral, ``0`` clearly conflict-free, ``-1`` one of
        the two not in service.
    kind : dict of (own, other) to list of str
        Conflict kind per time where required (``rear_end``, ``head_on``, ``merge``,
        ``crossing``) else ``""``.
    in_service : dict of str to ndarray of bool
    """

    times_s: np.ndarray
    vehicles: list[str]
    state: dict[tuple[str, str], np.ndarray]
    kind: dict[tuple[str, str], list[str]]
    in_service: dict[str, np.ndarray]

    def vehicle_hours(self) -> float:
        """Vehicle-hours in service over the analysis times."""
        dt = float(np.median(np.diff(self.times_s))) if len(self.times_s) > 1 else 1.0
        return sum(int(v.sum()) for v in self.in_service.values()) * dt / 3600.0


def analysis_times(result: SimulationResult, cycle_s: float = 1.0) -> np.ndarray:
    """Analysis times of a run: every ``cycle_s`` from the first cycle to the end, s."""
    return np.arange(cycle_s, result.duration_s + 1e-9, cycle_s)


def _route_passages(net: TrackMap, route: Route, truth: Truth, length_m: float) -> list[Passage]:
    conflicts_at_node: dict[int, list[int]] = defaultdict(list)
    on_edge: dict[int, list[tuple[float, int]]] = defaultdict(list)
    for c in net.conflicts:
        if c.node_id is not None:
            conflicts_at_node[c.node_id].append(c.conflict_id)
        else:
            for e, off in zip(c.edges, c.offsets_m, strict=True):
                on_edge[e].append((off, c.conflict_id))
    out: list[Passage] = []
    entry = 0.0
    steps = route.steps
    for k, (e, d) in enumerate(steps):
        length = route.edge_lengths_m[k]
        base = entry - (route.start_offset_m if d == 1 else length - route.start_offset_m) * (
            k == 0
        )
        for off, cid in on_edge.get(e, ()):
            dist = base + (off if d == 1 else length - off)
            if dist >= 0.0:
                c = net.conflicts[cid]
                ext = max(c.extents_m)
                out.append(_passage(truth, c.conflict_id, c.kind, dist, e, e, ext, ext, length_m))
        node = net.edges[e].end_node if d == 1 else net.edges[e].start_node
        if k + 1 < len(steps):
            nxt = steps[k + 1][0]
            for cid in conflicts_at_node.get(node, ()):
                c = net.conflicts[cid]
                extent = dict(zip(c.edges, c.extents_m, strict=True))
                at = base + length
                if c.kind == "merge":
                    branches = c.edges[1:]
                    ext_in = extent[e] if e in branches else 0.0
                    ext_out = extent[nxt] if nxt in branches else 0.0
                else:
                    ext_in = ext_out = max(c.extents_m)
                out.append(_passage(truth, cid, c.kind, at, e, nxt, ext_in, ext_out, length_m))
        entry = base + length
    return out


def _passage(
    truth: Truth,
    cid: int,
    kind: str,
    at: float,
    frm: int,
    to: int,
    ext_in: float,
    ext_out: float,
    length_m: float,
) -> Passage:
    return Passage(
        conflict_id=cid,
        kind=kind,
        distance_m=at,
        from_edge=frm,
        to_edge=to,
        extent_in_m=ext_in,
        extent_out_m=ext_out,
        t_in_s=_time_at(truth, at - ext_in),
        t_out_s=_time_at(truth, at + ext_out + length_m),
    )


def _time_at(truth: Truth, distance_m: float) -> float:
    """First time the front reaches a route distance (inf if never in the run)."""
    idx = int(np.searchsorted(truth.distance_m, distance_m, side="left"))
    if idx >= len(truth.t_s):
        return math.inf
    return float(truth.t_s[idx])


def ground_truth(
    net: TrackMap,
    result: SimulationResult,
    *,
    cycle_s: float = 1.0,
    window_slack_s: float = 5.0,
    clear_factor: float = 1.5,
    min_horizon_m: float = MIN_HORIZON_M,
    off_map: Iterable[str] = (),
    tolerance_m: float = 2.0,
) -> GroundTruth:
    """Label every ordered pair at every analysis time from the true states.

    Parameters
    ----------
    net : TrackMap
        The map the simulation ran on.
    result : SimulationResult
    cycle_s : float
        Analysis period, s.
    window_slack_s : float
        Arrivals at a merge or crossing this close in time are in conflict, s.
    clear_factor : float
        A pair is clearly conflict-free when no conflict lies within this many horizons.
    min_horizon_m : float
        Horizon floor (the analyser's default), m.
    off_map : iterable of str
        Vehicles driving on tracks apart from the network (a depot not in the map): they
        conflict with nobody.
    tolerance_m : float
        A warning is required once the gap is this much inside the required distance, so
        that decimetre grazes of a braking distance are not scored, m.

    Returns
    -------
    GroundTruth
    """
    times = analysis_times(result, cycle_s)
    specs = {s.vehicle_id: s for s in result.specs}
    vids = list(result.truth)
    apart = set(off_map)
    truths = result.truth
    passages = {
        v: [] if v in apart else _route_passages(net, specs[v].route, truths[v], specs[v].length_m)
        for v in vids
    }
    in_service = {v: _covers(truths[v], times) for v in vids}
    index_at = {v: _indices(truths[v], times) for v in vids}
    state = {(i, j): np.full(len(times), -1, dtype=np.int8) for i in vids for j in vids if i != j}
    kinds = {pair: [""] * len(times) for pair in state}
    for k, t in enumerate(times):
        live = [v for v in vids if in_service[v][k]]
        if len(live) < 2:
            continue
        snap = {v: _snapshot(truths[v], int(index_at[v][k])) for v in live}
        horizon, warn_m = _per_vehicle_distances(live, snap, specs, min_horizon_m)
        upcoming: dict[str, list[Passage]] = {}
        by_conflict: dict[int, list[tuple[str, Passage]]] = defaultdict(list)
        for v in live:
            reach = snap[v]["s"] + clear_factor * horizon[v]
            ups = [
                p for p in passages[v] if p.t_out_s > t and p.distance_m - p.extent_in_m <= reach
            ]
            upcoming[v] = ups
            if v not in apart:
                for p in ups:
                    by_conflict[p.conflict_id].append((v, p))
        for i in live:
            si = snap[i]
            others = [j for j in live if j != i]
            labels = {j: CLEAR for j in others}
            kind_of = {j: "" for j in others}
            if i in apart:
                for j in others:
                    state[(i, j)][k] = CLEAR
                continue
            prof_i = specs[i].profile
            route = specs[i].route
            fe = np.array([snap[j]["edge"] for j in others])
            fo = np.array([snap[j]["offset"] for j in others])
            re_ = np.array([snap[j]["rear_edge"] for j in others])
            ro = np.array([snap[j]["rear_offset"] for j in others])
            both = route.distances_of(
                np.concatenate([fe, re_]), np.concatenate([fo, ro]), after_m=si["s"]
            )
            d_front, d_rear = both[: len(others)], both[len(others) :]
            look = clear_factor * horizon[i]
            for n in np.flatnonzero(~(np.isnan(d_front) & np.isnan(d_rear))).tolist():
                j = others[n]
                if j in apart:
                    continue
                sj = snap[j]
                first = min(x for x in (d_front[n], d_rear[n]) if not math.isnan(x))
                if first - si["s"] > max(look, horizon[i] + horizon[j]):
                    continue
                same = route.locate(first)[2] == sj["dir"]
                if same:
                    edge_d = d_rear[n] if not math.isnan(d_rear[n]) else first
                    need = braking.rear_end_distance(
                        si["v"], sj["v"], prof_i, specs[j].profile, leader_braking=sj["braking"]
                    )
                    kind = "rear_end"
                else:
                    edge_d = d_front[n] if not math.isnan(d_front[n]) else first
                    need = braking.head_on_distance(si["v"], sj["v"], prof_i, specs[j].profile)
                    kind = "head_on"
                standing = si["v"] < STOPPED_MPS and (not same or sj["v"] >= si["v"])
                if edge_d - si["s"] <= need - tolerance_m and not (standing and same):
                    labels[j], kind_of[j] = REQUIRED, kind
                elif first - si["s"] <= clear_factor * horizon[i]:
                    labels[j] = NEUTRAL
            if upcoming[i]:
                warn = warn_m[i]
                for p in upcoming[i]:
                    to_entry = p.distance_m - p.extent_in_m - si["s"]
                    for j, q in by_conflict.get(p.conflict_id, ()):
                        if j == i or labels[j] == REQUIRED or not _different_tracks(p, q):
                            continue
                        overlap = (
                            p.t_in_s <= q.t_out_s + window_slack_s
                            and q.t_in_s <= p.t_out_s + window_slack_s
                        )
                        if overlap and to_entry <= warn - tolerance_m:
                            labels[j], kind_of[j] = REQUIRED, p.kind
                        elif labels[j] == CLEAR:
                            labels[j] = NEUTRAL
            for j in others:
                state[(i, j)][k] = labels[j]
                kinds[(i, j)][k] = kind_of[j] if labels[j] == REQUIRED else ""
    return GroundTruth(times, vids, state, kinds, in_service)


def _per_vehicle_distances(
    live: list[str],
    snap: dict[str, dict[str, Any]],
    specs: Mapping[str, TramSpec],
    min_horizon_m: float,
) -> tuple[dict[str, float], dict[str, float]]:
    """Horizon and warning distance of every live vehicle (vectorised per profile)."""
    horizon: dict[str, float] = {}
    warn: dict[str, float] = {}
    groups: dict[int, list[str]] = defaultdict(list)
    for v in live:
        groups[id(specs[v].profile)].append(v)
    for members in groups.values():
        prof = specs[members[0]].profile
        speeds = np.array([snap[v]["v"] for v in members])
        hs = braking.horizon_m(speeds, prof, minimum_m=min_horizon_m)
        ws = braking.warning_distance(speeds, prof)
        for v, h, w in zip(members, np.atleast_1d(hs), np.atleast_1d(ws), strict=True):
            horizon[v], warn[v] = float(h), float(w)
    return horizon, warn


def _covers(truth: Truth, times: np.ndarray) -> np.ndarray:
    if not len(truth.t_s):
        return np.zeros(len(times), dtype=bool)
    half = 0.5 * (float(truth.t_s[1] - truth.t_s[0]) if len(truth.t_s) > 1 else 0.1)
    return (times >= truth.t_s[0] - half) & (times <= truth.t_s[-1] + half)


def _indices(truth: Truth, times: np.ndarray) -> np.ndarray:
    if not len(truth.t_s):
        return np.zeros(len(times), dtype=np.int64)
    idx = np.searchsorted(truth.t_s, times)
    idx = np.clip(idx, 1, len(truth.t_s) - 1) if len(truth.t_s) > 1 else np.zeros_like(idx)
    if len(truth.t_s) > 1:
        left = truth.t_s[idx - 1]
        right = truth.t_s[idx]
        idx = np.where(np.abs(times - left) <= np.abs(right - times), idx - 1, idx)
    return idx.astype(np.int64)


def _different_tracks(p: Passage, q: Passage) -> bool:
    """Whether two passages of a conflict point come from different tracks."""
    mine, theirs = {p.from_edge, p.to_edge}, {q.from_edge, q.to_edge}
    if p.kind == "merge":
        return mine != theirs
    return not mine & theirs


def _snapshot(truth: Truth, idx: int) -> dict[str, Any]:
    return {
        "s": float(truth.distance_m[idx]),
        "v": float(truth.speed_mps[idx]),
        "edge": int(truth.edge_id[idx]),
        "offset": float(truth.offset_m[idx]),
        "dir": int(truth.direction[idx]),
        "rear_edge": int(truth.rear_edge_id[idx]),
        "rear_offset": float(truth.rear_offset_m[idx]),
        "braking": str(truth.braking[idx]),
    }
