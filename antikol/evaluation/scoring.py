"""Ground truth from simulated true states, and scoring of analysers against it.

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

An analyser's warning for a pair is any threat on that vehicle of level ``warning`` or
above (the paper's lamp). The scores:

* required-warning episodes (maximal runs of "required" cycles of a pair): **timely** when
  the analyser warned at the episode's first cycle or in the 10 s before it, **late** when
  it warned only later in the episode, **missed** when it never did;
* **false-alarm episodes** — maximal runs of warnings on a clearly conflict-free pair, per
  vehicle-hour in service;
* **flicker** — on/off toggles of each vehicle's lamp per vehicle-hour;
* **mean warning lead** — for timely episodes, how long before the requirement began the
  warning was already on, s.
"""

from __future__ import annotations

import logging
import math
from collections import defaultdict
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from antikol.analysis import braking
from antikol.analysis.analyser import Analyser
from antikol.kinds import level_rank
from antikol.sim import Route, SimulationResult, TramSpec, Truth
from antikol.thresholds import MIN_HORIZON_M, STANDING_SPEED_MPS
from trackmap import TrackMap

logger = logging.getLogger(__name__)

REQUIRED, NEUTRAL, CLEAR = 2, 1, 0
#: A vehicle slower than this is standing: a leader pulling away needs no warning, m/s.
STOPPED_MPS = STANDING_SPEED_MPS


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


@dataclass
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


# -- scoring ------------------------------------------------------------------------------
@dataclass
class Score:
    """Scores of one analyser against the ground truth (see the module docstring)."""

    required: int = 0
    timely: int = 0
    late: int = 0
    missed: int = 0
    false_alarm_episodes: int = 0
    vehicle_hours: float = 0.0
    lamp_toggles: int = 0
    leads_s: list[float] = field(default_factory=list)
    missed_detail: list[tuple[str, str, float, str]] = field(default_factory=list)

    @property
    def false_alarms_per_vehicle_hour(self) -> float:
        return self.false_alarm_episodes / self.vehicle_hours if self.vehicle_hours else 0.0

    @property
    def flicker_per_vehicle_hour(self) -> float:
        return self.lamp_toggles / self.vehicle_hours if self.vehicle_hours else 0.0

    @property
    def mean_lead_s(self) -> float | None:
        return float(np.mean(self.leads_s)) if self.leads_s else None

    def as_dict(self) -> dict[str, Any]:
        return {
            "required_warnings": self.required,
            "timely": self.timely,
            "late": self.late,
            "missed": self.missed,
            "false_alarm_episodes": self.false_alarm_episodes,
            "false_alarms_per_vehicle_hour": round(self.false_alarms_per_vehicle_hour, 3),
            "flicker_per_vehicle_hour": round(self.flicker_per_vehicle_hour, 3),
            "mean_warning_lead_s": None if self.mean_lead_s is None else round(self.mean_lead_s, 2),
            "vehicle_hours": round(self.vehicle_hours, 3),
        }


@dataclass
class AlarmLog:
    """Warnings of one analyser per ordered pair and the lamp of each vehicle per cycle."""

    times_s: np.ndarray
    pair_warn: dict[tuple[str, str], np.ndarray]
    lamp: dict[str, np.ndarray]


def run_analyser(
    make: Callable[[], Analyser],
    result: SimulationResult,
    times: np.ndarray,
    *,
    progress: Any = None,
) -> AlarmLog:
    """Feed a run's reports to a fresh analyser and record its warnings every cycle.

    Parameters
    ----------
    make : callable
        Returns a new :class:`~antikol.analysis.analyser.Analyser`.
    result : SimulationResult
    times : ndarray
        Analysis times, s.
    progress : tqdm-like, optional
        Updated by one per cycle.
    """
    an = make()
    reports = list(result.reports)
    vids = list(result.truth)
    pair_warn = {(i, j): np.zeros(len(times), dtype=bool) for i in vids for j in vids if i != j}
    lamp = {v: np.zeros(len(times), dtype=bool) for v in vids}
    r = 0
    for k, t in enumerate(times):
        batch = []
        while r < len(reports) and reports[r].t <= t + 1e-9:
            batch.append(reports[r])
            r += 1
        if batch:
            an.update_many(batch)
        for own, a in an.assess_all(t=float(t)).items():
            if own not in lamp:
                continue
            lamp[own][k] = a.lamp
            for th in a.threats:
                if (
                    level_rank(th.level) >= level_rank("warning")
                    and (own, th.vehicle_id) in pair_warn
                ):
                    pair_warn[(own, th.vehicle_id)][k] = True
        if progress is not None:
            progress.update(1)
    return AlarmLog(times, pair_warn, lamp)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Maximal runs of True as (start, end_exclusive)."""
    if not mask.any():
        return []
    padded = np.concatenate([[False], mask, [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def score(
    truth: GroundTruth, log: AlarmLog, *, cycle_s: float = 1.0, lookback_s: float = 10.0
) -> Score:
    """Score an analyser's alarm log against the ground truth.

    A required-warning episode is timely when a warning was on at its first cycle or in
    the ``lookback_s`` before it (the driver had been warned before the gap fell below the
    required distance).
    """
    back = max(round(lookback_s / cycle_s), 0)
    sc = Score(vehicle_hours=truth.vehicle_hours())
    for pair, st in truth.state.items():
        warn = log.pair_warn.get(pair)
        if warn is None:
            continue
        for a, b in _runs(st == REQUIRED):
            sc.required += 1
            hits = np.flatnonzero(warn[a:b])
            before = np.flatnonzero(warn[max(a - back, 0) : a + 1])
            if len(before):
                sc.timely += 1
                first = max(a - back, 0) + int(before[0])
                while first > 0 and warn[first - 1]:
                    first -= 1
                sc.leads_s.append((a - first) * cycle_s)
            elif len(hits):
                sc.late += 1
            else:
                sc.missed += 1
                sc.missed_detail.append(
                    (pair[0], pair[1], float(truth.times_s[a]), truth.kind[pair][a])
                )
        sc.false_alarm_episodes += len(_runs(warn & (st == CLEAR)))
    for v, lamp in log.lamp.items():
        live = truth.in_service.get(v)
        if live is None:
            continue
        on = lamp & live
        sc.lamp_toggles += int(np.count_nonzero(np.diff(on.astype(np.int8))))
    return sc


@dataclass
class Comparison:
    """Side-by-side scores of the sector rule and the track-aware analyser on one run."""

    name: str
    sector: Score
    track: Score
    truth: GroundTruth
    logs: dict[str, AlarmLog]
    result: SimulationResult

    def as_dict(self) -> dict[str, Any]:
        return {
            "scenario": self.name,
            "vehicles": len(self.truth.vehicles),
            "duration_s": self.result.duration_s,
            "sector": self.sector.as_dict(),
            "track": self.track.as_dict(),
        }


def compare(
    net: TrackMap,
    result: SimulationResult,
    *,
    name: str = "run",
    cycle_s: float = 1.0,
    progress: bool = False,
    analyser_options: Mapping[str, Any] | None = None,
    off_map: Iterable[str] = (),
) -> Comparison:
    """Run the sector rule and the track-aware analyser on the same reports and score both.

    Parameters
    ----------
    net : TrackMap
    result : SimulationResult
    name : str
        Scenario name for the report.
    cycle_s : float
        Analysis period, s.
    progress : bool
        Show a progress bar.
    analyser_options : mapping, optional
        Extra keyword arguments for the track-aware :class:`Analyser`.
    """
    times = analysis_times(result, cycle_s)
    truth = ground_truth(net, result, cycle_s=cycle_s, off_map=off_map)
    profiles = {s.vehicle_id: s.profile for s in result.specs}
    opts = dict(analyser_options or {})
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=2 * len(times), desc=name, unit=" cycle", leave=False)
    try:
        sector_log = run_analyser(lambda: Analyser(profiles=profiles), result, times, progress=bar)
        track_log = run_analyser(
            lambda: Analyser(track_map=net, profiles=profiles, **opts),
            result,
            times,
            progress=bar,
        )
    finally:
        if bar is not None:
            bar.close()
    return Comparison(
        name=name,
        sector=score(truth, sector_log, cycle_s=cycle_s),
        track=score(truth, track_log, cycle_s=cycle_s),
        truth=truth,
        logs={"sector": sector_log, "track": track_log},
        result=result,
    )


def format_table(comparisons: Iterable[Comparison]) -> str:
    """A plain-text table of comparisons (one row per scenario and method)."""
    header = (
        f"{'scenario':<22} {'method':<7} {'required':>8} {'timely':>6} {'late':>4} "
        f"{'missed':>6} {'FA/veh-h':>9} {'flicker/veh-h':>13} {'lead s':>7}"
    )
    lines = [header, "-" * len(header)]
    for c in comparisons:
        for method, sc in (("sector", c.sector), ("track", c.track)):
            lead = "-" if sc.mean_lead_s is None else f"{sc.mean_lead_s:.1f}"
            lines.append(
                f"{c.name:<22} {method:<7} {sc.required:>8} {sc.timely:>6} {sc.late:>4} "
                f"{sc.missed:>6} {sc.false_alarms_per_vehicle_hour:>9.2f} "
                f"{sc.flicker_per_vehicle_hour:>13.2f} {lead:>7}"
            )
    return "\n".join(lines)


__all__ = [
    "AlarmLog",
    "Comparison",
    "GroundTruth",
    "Passage",
    "Score",
    "analysis_times",
    "compare",
    "format_table",
    "ground_truth",
    "run_analyser",
    "score",
]


# -- positioning accuracy -----------------------------------------------------------------
@dataclass
class PositioningScore:
    """Accuracy of track-selective positioning against the simulator's truth.

    Attributes
    ----------
    fixes : int
        Reports evaluated (matched or not).
    double_track_fixes, double_track_correct : int
        Fixes on double track (an opposite-direction track within 6 m) and those placed on
        the right track and running direction (within ``tolerance_m`` along the route).
    after_switch_fixes, after_switch_correct : int
        Fixes 40-60 m past a facing switch and those on the right branch.
    along_rmse_m, raw_along_rmse_m : float
        Along-track RMS error of the filtered position and of the raw fix projected on the
        true track, m.
    unmatched : int
        Fixes with no usable match.
    """

    fixes: int = 0
    double_track_fixes: int = 0
    double_track_correct: int = 0
    after_switch_fixes: int = 0
    after_switch_correct: int = 0
    along_rmse_m: float = math.nan
    raw_along_rmse_m: float = math.nan
    unmatched: int = 0

    @property
    def double_track_accuracy(self) -> float:
        return self.double_track_correct / max(self.double_track_fixes, 1)

    @property
    def branch_accuracy(self) -> float:
        return self.after_switch_correct / max(self.after_switch_fixes, 1)

    @property
    def rmse_reduction(self) -> float:
        """1 - filtered / raw along-track RMSE (0.33 means a third lower)."""
        return 1.0 - self.along_rmse_m / self.raw_along_rmse_m

    def as_dict(self) -> dict[str, Any]:
        return {
            "fixes": self.fixes,
            "double_track_accuracy": round(self.double_track_accuracy, 4),
            "double_track_fixes": self.double_track_fixes,
            "branch_accuracy_50m_after_switch": round(self.branch_accuracy, 4),
            "after_switch_fixes": self.after_switch_fixes,
            "along_track_rmse_m": round(self.along_rmse_m, 3),
            "raw_along_track_rmse_m": round(self.raw_along_rmse_m, 3),
            "rmse_reduction": round(self.rmse_reduction, 3),
            "unmatched": self.unmatched,
        }


def _facing_switch_distances(net: TrackMap, route: Route) -> list[float]:
    """Route distances of the facing switches a route takes (trunk -> branch)."""
    out = []
    merge_by_node = {c.node_id: c for c in net.conflicts if c.kind == "merge"}
    entry = -(
        route.start_offset_m
        if route.steps[0][1] == 1
        else route.edge_lengths_m[0] - route.start_offset_m
    )
    for k, (e, d) in enumerate(route.steps[:-1]):
        entry += route.edge_lengths_m[k]
        node = net.edges[e].end_node if d == 1 else net.edges[e].start_node
        c = merge_by_node.get(node)
        if c is not None and c.edges[0] == e and route.steps[k + 1][0] in c.edges[1:]:
            out.append(entry)
    return out


def positioning_accuracy(
    net: TrackMap,
    result: SimulationResult,
    *,
    config: Any = None,
    tolerance_m: float = 8.0,
) -> PositioningScore:
    """Run the positioning filter over a simulation's reports and score it against truth.

    Parameters
    ----------
    net : TrackMap
    result : SimulationResult
    config : PositioningConfig, optional
    tolerance_m : float
        An estimate counts as on the right track when it lies on the true route within
        this distance of the true antenna position, in the true running direction, m.
    """
    from antikol.positioning.matcher import Positioner

    specs = {s.vehicle_id: s for s in result.specs}
    pos = Positioner(net, config)
    sc = PositioningScore()
    errs: list[float] = []
    raw: list[float] = []
    rows: list[tuple[float, float, bool, bool]] = []  # true x, y, on-double?, after switch?
    checks: list[bool] = []
    by_time = sorted(result.reports, key=lambda r: r.t)
    switch_at = {v: _facing_switch_distances(net, specs[v].route) for v in specs}
    for r in by_time:
        spec = specs[r.vehicle_id]
        truth = result.truth[r.vehicle_id]
        est = pos.update(r)
        idx = truth.index_at(r.t)
        s_ant = float(truth.distance_m[idx]) - spec.antenna_m
        te, to, _ = spec.route.locate(max(s_ant, 0.0))
        sc.fixes += 1
        tx, ty = float(truth.antenna_x_m[idx]), float(truth.antenna_y_m[idx])
        after = any(40.0 <= s_ant - s0 <= 60.0 for s0 in switch_at[r.vehicle_id])
        if not est.matched or est.edge_id is None or est.offset_m is None:
            sc.unmatched += 1
            correct = False
        else:
            d = spec.route.distance_of(est.edge_id, est.offset_m, after_m=max(s_ant - 50.0, 0.0))
            correct = (
                d is not None
                and abs(d - s_ant) <= tolerance_m
                and spec.route.locate(d)[2] == est.direction
            )
            geom = net.edges[te].geometry
            ex, ey = net.point_at(est.edge_id, est.offset_m)
            import shapely

            p_est = shapely.Point(ex, ey)
            if geom.distance(p_est) <= tolerance_m:
                errs.append(float(geom.project(p_est)) - to)
            rx, ry = net.to_local(r.lon, r.lat)
            p_raw = shapely.Point(rx, ry)
            raw.append(float(geom.project(p_raw)) - to)
        rows.append((tx, ty, False, after))
        checks.append(correct)
    if rows:
        xs = np.array([row[0] for row in rows])
        ys = np.array([row[1] for row in rows])
        double = _on_double_track(net, xs, ys)
        for k, row in enumerate(rows):
            if double[k]:
                sc.double_track_fixes += 1
                sc.double_track_correct += int(checks[k])
            if row[3]:
                sc.after_switch_fixes += 1
                sc.after_switch_correct += int(checks[k])
    if errs:
        sc.along_rmse_m = float(np.sqrt(np.mean(np.square(errs))))
        sc.raw_along_rmse_m = float(np.sqrt(np.mean(np.square(raw))))
    return sc


def _on_double_track(net: TrackMap, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Whether each point lies on double track: two tracks 2.5-6 m apart, opposite ways."""
    batch = net.candidates_batch_xy(x, y, 6.5)
    out = np.zeros(len(x), dtype=bool)
    per: dict[int, list[int]] = defaultdict(list)
    for row in range(len(batch)):
        per[int(batch.point[row])].append(row)
    for k, rows_k in per.items():
        if len(rows_k) < 2:
            continue
        nearest = min(rows_k, key=lambda r: batch.distance_m[r])
        e0 = net.edges[int(batch.edge_id[nearest])]
        if e0.direction == 0:
            continue
        h0 = (float(batch.heading_deg[nearest]) + (0.0 if e0.direction == 1 else 180.0)) % 360.0
        for r in rows_k:
            e = net.edges[int(batch.edge_id[r])]
            if r == nearest or e.direction == 0:
                continue
            h = (float(batch.heading_deg[r]) + (0.0 if e.direction == 1 else 180.0)) % 360.0
            sep = abs(float(batch.lateral_m[r]) - float(batch.lateral_m[nearest]))
            if 2.5 <= sep <= 6.0 and abs((h - h0 + 180.0) % 360.0 - 180.0) > 150.0:
                out[k] = True
                break
    return out
