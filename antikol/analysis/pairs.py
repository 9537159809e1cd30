"""Every pair of one analysis time at once: the conflict rules over flat arrays.

The rules are those of :mod:`antikol.analysis.conflicts` — ``on_path`` when the other
vehicle stands on an own path, ``at_conflict`` when both vehicles' paths pass one conflict
point from different tracks — combined over the match hypotheses and zones as the analyser
documents:

* for each own hypothesis *h*, other hypothesis *g* and own path *p*: when *g* stands on *p*
  the pair is judged on that alone (rear-end or head-on; two bodies deeply inside each other
  judge nothing on *p*); otherwise on every conflict point of *p* that the other vehicle's
  paths pass, each of the other's ways through it weighted by the probability of that way;
* of each level the most probable finding counts, weighted by ``P(h)·P(g)·P(p)`` and summed
  over *h*, *g*, *p*; a warning needs the summed weight of warning-level findings to reach
  ``warning_probability`` (``emergency_probability`` for emergencies); the finding shown is
  the most severe, the first of equals in the order *h*, *g*, *p*, conflict point, way;
* a finding of an untrusted hypothesis (wrong way without sustained evidence) is at most an
  advisory; the alarm is held while trusted conflicts worth ``warning_probability`` close in.

Evaluated pair by pair in Python, a city's cycle costs tens of microseconds per conflict
point per hypothesis per pair. Here every such row of every pair is one element of numpy
arrays, and the reductions keep the pair-by-pair order: sums run in the order *h*, *g*, *p*
(:func:`numpy.bincount` adds sequentially) and ties keep the first row, so the outcome is
the same to the last bit as the scalar rules (``tests/test_pairs.py`` compares them).
"""

from __future__ import annotations

from collections.abc import Callable, Collection
from dataclasses import dataclass, fields
from operator import attrgetter
from typing import Any

import numpy as np
import numpy.typing as npt

from antikol.analysis.conflicts import Finding, RuleSettings
from antikol.analysis.runs import (
    expand_rows,
    first_least,
    group_of,
    max_of_runs,
    order_by,
    run_starts,
    severity_keys,
)
from antikol.analysis.views import CycleViews, VehicleView
from antikol.kinds import LEVELS, Level, ThreatKind
from trackmap import Path, TrackMap
from trackmap.records import positional

__all__ = ["PairEvaluator", "PairOutcome", "PairSettings"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

_NONE, _ADVISORY, _WARNING, _EMERGENCY = (LEVELS.index(x) for x in LEVELS)
_KINDS: tuple[ThreatKind, ...] = ("rear_end", "head_on", "merge", "crossing")
_REAR_END, _HEAD_ON, _MERGE, _CROSSING = range(4)


@dataclass(frozen=True, slots=True)
class PairSettings:
    """How findings combine into a pair's outcome (see :class:`~antikol.AnalyserConfig`).

    Attributes
    ----------
    warning_probability, emergency_probability : float
        Weight of warning-level (emergency-level) findings that raises an alarm.
    closing_speed_mps : float
        A trusted finding closing faster than this, m/s ...
    release_margin_m, release_time_s : float
        ... within ``release_margin_m + release_time_s x closing`` of its warning distance
        holds the pair's alarm (m, s).
    """

    warning_probability: float
    emergency_probability: float
    closing_speed_mps: float
    release_margin_m: float
    release_time_s: float


@dataclass(frozen=True, slots=True)
class PairOutcome:
    """What one pair's evaluation decided.

    Attributes
    ----------
    level : str
        ``none``, ``advisory``, ``warning`` or ``emergency``.
    finding : Finding
        The finding shown (the most severe alarm-level one when the level is an alarm).
    probability : float
        Weight of the findings behind the level.
    hold : bool
        Closing conflicts worth ``warning_probability`` keep an alarm on.
    ambiguous : bool
        The findings do not cover every combination of hypotheses and zones, or a
        position is ambiguous.
    """

    level: Level
    finding: Finding
    probability: float
    hold: bool
    ambiguous: bool


#: Findings and outcomes by position (every field in its order; a cycle of 1000 clustered
#: trams builds ~6,000 of each, and the recorded run checks every field of them).
_finding = positional(Finding)
_outcome = positional(PairOutcome)


@dataclass(slots=True)
class _Flat:
    """The views of one time as parallel arrays: vehicles, hypotheses, paths, approaches
    to conflict points, path-approach links and path steps."""

    views: list[VehicleView]
    paths: list[Path]
    veh: dict[str, Any]
    hyp: dict[str, Any]
    path: dict[str, Any]
    app: dict[str, Any]
    link: dict[str, Any]
    step: dict[str, Any]


@dataclass(slots=True)
class _Findings:
    """Rows of findings: who, where, which level, how far."""

    own: IntArray  # own vehicle
    other: IntArray  # other vehicle
    kind: IntArray
    rank: IntArray  # level after an untrusted alarm is capped to an advisory
    capped: BoolArray
    gap: FloatArray
    margin: FloatArray
    closing: FloatArray
    ttc: FloatArray  # nan: none


@dataclass(slots=True)
class _Summaries:
    """Per group of finding rows: the most probable weight of each kind and the most
    severe rows (-1: none)."""

    any: FloatArray
    alarm: FloatArray
    emergency: FloatArray
    hold: FloatArray
    worst: IntArray
    worst_alarm: IntArray


class PairEvaluator:
    """Evaluates every pair of one analysis time (see the module).

    Parameters
    ----------
    net : trackmap.TrackMap
    rules : RuleSettings
    settings : PairSettings
    """

    def __init__(self, net: TrackMap, rules: RuleSettings, settings: PairSettings) -> None:
        self.net = net
        self.rules = rules
        self.settings = settings
        # (conflict, from, to) -> fouling extent before and after the point (m) and the
        # branches of a merge taken (a code; -1: none or not a merge)
        self._ways: dict[tuple[int, int, int], tuple[float, float, int]] = {}
        self._branch_codes: dict[tuple[int, ...], int] = {}
        self._merges = np.array([c.kind == "merge" for c in net.conflicts], dtype=bool)

    def evaluate(
        self,
        cycle: CycleViews,
        traction_mps2: Callable[[str], float],
        owners: Collection[str] | None = None,
    ) -> dict[str, dict[str, PairOutcome]]:
        """The outcome of every pair with a finding.

        Parameters
        ----------
        cycle : CycleViews
        traction_mps2 : callable
            The traction acceleration of a vehicle (by id), m/s².
        owners : collection of str, optional
            The own vehicles to evaluate (default: every matched vehicle).

        Returns
        -------
        dict
            ``own id -> other id -> PairOutcome``; a pair without findings is absent.
        """
        flat = self._flatten(cycle, traction_mps2)
        nveh = len(flat.views)
        if nveh < 2:
            return {}
        is_owner = np.ones(nveh, dtype=bool)
        if owners is not None:
            wanted = set(owners)
            is_owner = np.array([v.vehicle_id in wanted for v in flat.views], dtype=bool)
        found, at_conflicts = self._conflict_findings(flat, is_owner)
        on_track, located = self._on_track(flat, is_owner)
        first_located = _append(found, on_track)
        # one severity order for every finding of the time: the summaries and the decision
        # compare rows of both kinds
        severity = severity_keys(found.rank, found.margin)
        path_rows = self._conflict_paths(flat, found, severity, at_conflicts)
        index = first_located + np.arange(len(on_track.rank))
        trusted = located.pop("trusted")
        located["summary"] = self._summaries(
            found, severity, np.ones(len(index)), trusted, None, rows=index
        )
        return self._decide(flat, found, severity, path_rows, located)

    # -- flat tables ---------------------------------------------------------------------
    def _way(self, conflict_id: int, frm: int, to: int) -> tuple[float, float, int]:
        key = (conflict_id, frm, to)
        known = self._ways.get(key)
        if known is not None:
            return known
        conflict = self.net.conflicts[conflict_id]
        if conflict.kind == "merge":
            branches = conflict.edges[1:]
            extent = dict(zip(conflict.edges, conflict.extents_m, strict=True))
            before = extent[frm] if frm in branches else 0.0
            after = extent[to] if to in branches else 0.0
            taken = tuple(sorted({frm, to} & set(branches)))
            code = self._branch_codes.setdefault(taken, len(self._branch_codes)) if taken else -1
        else:
            before = after = max(conflict.extents_m)
            code = -1
        known = self._ways[key] = (before, after, code)
        return known

    def _flatten(self, cycle: CycleViews, traction_mps2: Callable[[str], float]) -> _Flat:
        views: list[VehicleView] = []
        accel: list[float] = []
        merge_accel = self.rules.merge_accel_mps2
        for view in cycle.views.values():
            if view.hyps:
                views.append(view)
                accel.append(min(merge_accel, traction_mps2(view.vehicle_id)))
        hyps = [h for view in views for h in view.hyps]
        n_hyps_of = [len(view.hyps) for view in views]
        paths: list[Path] = [p for h in hyps for p in h.paths]
        n_paths_of = [len(h.paths) for h in hyps]
        approaches = [ap for h in hyps for ap in h.approaches]
        n_apps_of = np.array([len(h.approaches) for h in hyps], dtype=np.int64)
        path_apps = [ways for h in hyps for ways in h.path_approaches]
        n_links_of = [len(ways) for ways in path_apps]
        steps = [st for p in paths for st in p.steps]
        n_steps_of = [len(p.steps) for p in paths]
        p_hyp = _owner_of(n_paths_of)
        p_prob = np.array([pi for h in hyps for pi in h.path_probability], dtype=np.float64)
        if any(len(h.path_probability) != n or len(h.path_approaches) != n
               for h, n in zip(hyps, n_paths_of, strict=True)):  # fmt: skip
            raise ValueError("a hypothesis view's paths, probabilities and approaches differ")
        # links: each path's approaches, numbered over the whole time (hypothesis's first on)
        first_app = np.cumsum(n_apps_of) - n_apps_of
        l_path = _owner_of(n_links_of)
        l_app = np.array([k for ways in path_apps for k in ways], dtype=np.int64)
        l_app += first_app[p_hyp[l_path]]
        if len(l_app) and not bool(np.all(l_app < (first_app + n_apps_of)[p_hyp[l_path]])):
            raise ValueError("a path of a hypothesis view names an approach it does not have")
        # the probability of passing each approach: the sum over the paths through it. A
        # hypothesis' paths are exclusive alternatives (each takes its own branch at some
        # switch), so paths that part only after a conflict point all pass it: a crossing
        # just before a switch is passed whichever branch follows (the most probable path
        # alone halved it there). A nan probability counts as none; a planned route may
        # let several paths through, hence the clip.
        a_prob = np.zeros(len(approaches))
        finite = np.where(np.isfinite(p_prob), np.maximum(p_prob, 0.0), 0.0)
        np.add.at(a_prob, l_app, finite[l_path])
        np.minimum(a_prob, 1.0, out=a_prob)
        way = self._way
        ways = [way(ap.conflict_id, ap.from_edge, ap.to_edge) for ap in approaches]
        f8, i8 = np.float64, np.int64
        veh = {
            "speed": np.array([v.speed_mps for v in views], dtype=f8),
            "sigma": np.array([v.sigma_m for v in views], dtype=f8),
            "front": np.array([v.ends.front_m for v in views], dtype=f8),
            "rear": np.array([v.ends.rear_m for v in views], dtype=f8),
            "warning": np.array([v.warning_m for v in views], dtype=f8),
            "emergency": np.array([v.emergency_m for v in views], dtype=f8),
            "horizon": np.array([v.horizon_m for v in views], dtype=f8),
            "accel": np.array(accel, dtype=f8),
            "emergency_braking": np.array(
                [v.report.braking == "emergency" for v in views], dtype=bool
            ),
        }
        hyp = {
            "veh": _owner_of(n_hyps_of),
            "prob": np.array([h.probability for h in hyps], dtype=f8),
            "trusted": np.array([h.trusted for h in hyps], dtype=bool),
            "edge": np.array([h.edge_id for h in hyps], dtype=i8),
            "off": np.array([h.offset_m for h in hyps], dtype=f8),
            "dir": np.array([h.direction for h in hyps], dtype=i8),
        }
        app: dict[str, Any] = {
            "hyp": _owner_of(n_apps_of),
            "cid": _column(approaches, "conflict_id", i8),
            "from": _column(approaches, "from_edge", i8),
            "to": _column(approaches, "to_edge", i8),
            "prob": a_prob,
            "code": np.array([w[2] for w in ways], dtype=i8),
        }
        # the ways through the fouling areas (conflicts.approach) and the earliest
        # arrivals there (conflicts.earliest_arrival_s), with the scalar rules' operations
        av = hyp["veh"][app["hyp"]]
        front = _column(approaches, "distance_m", f8) - veh["front"][av]
        length = veh["front"][av] + veh["rear"][av]
        app["enter"] = front - np.array([w[0] for w in ways], dtype=f8)
        app["point"] = front
        app["clear"] = front + np.array([w[1] for w in ways], dtype=f8) + length
        app["arrival"] = _arrival_s(
            app["enter"],
            veh["speed"][av],
            veh["accel"][av],
            np.maximum(self.rules.merge_max_speed_mps, veh["speed"][av]),
        )
        app["veh"] = av
        # merges: a conflict point is a merge for every way through it
        app["merge"] = self._merges[app["cid"]]
        path_table = {"hyp": p_hyp, "prob": p_prob}
        link = {"path": l_path, "app": l_app}
        enter, exit_ = _column(steps, "enter_offset_m", f8), _column(steps, "exit_offset_m", f8)
        step = {
            "path": _owner_of(n_steps_of),
            "edge": _column(steps, "edge_id", i8),
            "enter": enter,
            "lo": np.minimum(enter, exit_),
            "hi": np.maximum(enter, exit_),
            "start": _column(steps, "start_m", f8),
            "dir": _column(steps, "direction", i8),
        }
        return _Flat(views, paths, veh, hyp, path_table, app, link, step)

    # -- merges and crossings ------------------------------------------------------------
    def _conflict_findings(
        self, flat: _Flat, is_owner: BoolArray
    ) -> tuple[_Findings, dict[str, Any]]:
        """Findings at conflict points, in the order (own approach, other approach), with
        each row's own approach, other hypothesis, weight of the other's way and trust."""
        app, hyp, veh, r = flat.app, flat.hyp, flat.veh, self.rules
        n_app = len(app["hyp"])
        rows = np.arange(n_app)
        # exact early exits of at_conflict: we have passed the point / they have cleared it
        mine = rows[is_owner[app["veh"]] & (app["point"] >= 0.0)]
        theirs = rows[app["clear"] > 0.0]
        theirs = theirs[np.argsort(app["cid"][theirs], kind="stable")]
        t_cid = app["cid"][theirs]
        lo = np.searchsorted(t_cid, app["cid"][mine], side="left")
        hi = np.searchsorted(t_cid, app["cid"][mine], side="right")
        a, b = expand_rows(mine, lo, hi, theirs)
        keep = app["veh"][a] != app["veh"][b]
        # conflict_kind: a merge between different branches, a crossing between lines
        # without a shared edge
        merge = app["merge"][a]
        ca, cb = app["code"][a], app["code"][b]
        fa, ta, fb, tb = app["from"][a], app["to"][a], app["from"][b], app["to"][b]
        shared = (fa == fb) | (fa == tb) | (ta == fb) | (ta == tb)
        keep &= np.where(merge, (ca >= 0) & (cb >= 0) & (ca != cb), ~shared)
        a, b, merge = _kept(keep, a, b, merge)
        ov, tv = app["veh"][a], app["veh"][b]
        v_own, v_other = veh["speed"][ov], veh["speed"][tv]
        standing = v_own < r.standing_speed_mps
        moving_own = np.where(standing, 1.0, v_own)  # a divisor only where it moves
        own_clear_s = np.where(standing, np.inf, app["clear"][a] / moving_own)
        keep = ~(app["arrival"][b] > own_clear_s + r.window_slack_s)
        moving_other = v_other >= r.standing_speed_mps
        other_latest_s = np.where(
            moving_other, app["clear"][b] / np.where(moving_other, v_other, 1.0), np.inf
        )
        own_arrival_s = np.maximum(app["enter"][a], 0.0) / moving_own
        too_late = (
            ~standing
            & (own_arrival_s > other_latest_s + r.window_slack_s)
            & np.isfinite(other_latest_s)
        )
        keep &= ~too_late
        a, b, merge, ov, tv, standing = _kept(keep, a, b, merge, ov, tv, standing)
        v_own = veh["speed"][ov]
        gap = np.maximum(app["enter"][a], 0.0)
        sigma = _pair_sigma(veh["sigma"][ov], veh["sigma"][tv])
        closing = np.where(standing, 0.0, v_own)
        gap_eff = gap - r.gap_margin_sigmas * sigma - closing * r.anticipation_s
        warning = veh["warning"][ov]
        rank = _rank(gap_eff, warning, veh["emergency"][ov], veh["horizon"][ov])
        # waiting at a junction, we are the obstacle: the other must act
        rank = np.where(standing & (rank >= _WARNING), _ADVISORY, rank)
        with np.errstate(divide="ignore", invalid="ignore"):
            ttc = np.where(standing | (closing <= 0.0), np.nan, gap / closing)
        trusted = hyp["trusted"][app["hyp"][a]] & hyp["trusted"][app["hyp"][b]]
        found = _findings(
            ov, tv, np.where(merge, _MERGE, _CROSSING), rank, trusted,
            gap, gap_eff - warning, closing, ttc,
        )  # fmt: skip
        return found, {"a": a, "g": app["hyp"][b], "weight": app["prob"][b], "trusted": trusted}

    def _conflict_paths(
        self, flat: _Flat, found: _Findings, severity: IntArray, rows: dict[str, Any]
    ) -> dict[str, Any]:
        """Summaries of the conflict findings (the first rows of ``found``) per (own path,
        other hypothesis)."""
        a, g = rows["a"], rows["g"]
        # per own approach and other hypothesis: the most probable way of each level
        starts = run_starts(a, g)
        summary = self._summaries(
            found, severity, rows["weight"], rows["trusted"], starts, rows=np.arange(len(a))
        )
        s_app, s_g = a[starts], g[starts]
        # ... per own path and other hypothesis: every approach of the path, in order
        link = flat.link
        order = np.argsort(s_app, kind="stable")  # already sorted by (approach, hyp)
        s_app_sorted = s_app[order]
        lo = np.searchsorted(s_app_sorted, link["app"], side="left")
        hi = np.searchsorted(s_app_sorted, link["app"], side="right")
        l_row, s_row = expand_rows(np.arange(len(link["app"])), lo, hi, order)
        l_path = link["path"][l_row]
        s_hyp = s_g[s_row]
        sort = order_by(
            [l_path, s_hyp, l_row],
            [len(flat.paths), len(flat.hyp["veh"]), len(link["app"])],
            unique=True,  # one row per link and summary row
        )
        l_path, s_hyp, s_row = l_path[sort], s_hyp[sort], s_row[sort]
        groups = run_starts(l_path, s_hyp)
        per_path = _combine(severity, summary, s_row, groups)
        return {"path": l_path[groups], "g": s_hyp[groups], "summary": per_path}

    # -- rear-end and head-on ----------------------------------------------------------
    def _on_track(self, flat: _Flat, is_owner: BoolArray) -> tuple[_Findings, dict[str, Any]]:
        """Other hypotheses standing on own paths: their findings, and for each the own
        path, the other hypothesis, whether the placements are possible and trust."""
        step, hyp, veh, r = flat.step, flat.hyp, flat.veh, self.rules
        s_hyp = flat.path["hyp"][step["path"]]
        mine = np.flatnonzero(is_owner[hyp["veh"][s_hyp]])
        by_edge = np.argsort(hyp["edge"], kind="stable")
        edges = hyp["edge"][by_edge]
        lo = np.searchsorted(edges, step["edge"][mine], side="left")
        hi = np.searchsorted(edges, step["edge"][mine], side="right")
        s, g = expand_rows(mine, lo, hi, by_edge)
        h = s_hyp[s]
        off = hyp["off"][g]
        keep = (
            (hyp["veh"][g] != hyp["veh"][h])
            & (step["lo"][s] - 1e-9 <= off)
            & (off <= step["hi"][s] + 1e-9)
        )
        s, g, h, off = _kept(keep, s, g, h, off)
        p = step["path"][s]
        # the first step of each path on the other's edge (path order)
        sort = order_by(
            [p, g, s], [len(flat.paths), len(hyp["veh"]), len(step["path"])], unique=True
        )
        s, g, h, p, off = s[sort], g[sort], h[sort], p[sort], off[sort]
        first = run_starts(p, g)
        s, g, h, p, off = s[first], g[first], h[first], p[first], off[first]
        distance = step["start"][s] + np.abs(off - step["enter"][s])
        same_way = step["dir"][s] == hyp["dir"][g]
        ov, tv = hyp["veh"][h], hyp["veh"][g]
        sigma = _pair_sigma(veh["sigma"][ov], veh["sigma"][tv])
        speed_own, speed_other = veh["speed"][ov], veh["speed"][tv]
        v_own = np.where(speed_own >= r.standing_speed_mps, speed_own, 0.0)
        v_other = np.where(speed_other >= r.standing_speed_mps, speed_other, 0.0)
        gap = np.where(
            same_way,
            distance - veh["front"][ov] - veh["rear"][tv],
            distance - veh["front"][ov] - veh["front"][tv],
        )
        closing = np.where(same_way, v_own - v_other, v_own + v_other)
        warning = np.where(same_way, veh["warning"][ov], veh["warning"][ov] + veh["warning"][tv])
        emergency = np.where(
            same_way, veh["emergency"][ov], veh["emergency"][ov] + veh["emergency"][tv]
        )
        if r.rear_end_model == "moving_leader":
            credit = 0.5 * speed_other**2 / 2.8
            credited = same_way & ~veh["emergency_braking"][tv]
            warning = np.where(credited, warning - credit, warning)
            emergency = np.where(credited, emergency - credit, emergency)
        # bodies deeply inside each other cannot be on one track: a placement is wrong
        possible = ~(gap < -(r.overlap_tolerance_m + r.gap_margin_sigmas * sigma))
        act = np.where(
            same_way,
            (v_own > 0.0) & (closing > -r.closing_speed_mps),
            closing > r.closing_speed_mps,
        )
        gap_eff = gap - r.gap_margin_sigmas * sigma - np.maximum(closing, 0.0) * r.anticipation_s
        rank = _rank(gap_eff, warning, emergency, veh["horizon"][ov])
        rank = np.where(~act & (rank >= _WARNING), _ADVISORY, rank)
        with np.errstate(divide="ignore", invalid="ignore"):
            ttc = np.where(closing > 0.0, np.maximum(gap, 0.0) / closing, np.nan)
        trusted = hyp["trusted"][h] & hyp["trusted"][g]
        rows = _findings(
            ov, tv, np.where(same_way, _REAR_END, _HEAD_ON), rank, trusted,
            gap, gap_eff - warning, closing, ttc,
        )  # fmt: skip
        return rows, {"path": p, "g": g, "possible": possible, "trusted": trusted}

    # -- combining -------------------------------------------------------------------------
    def _summaries(
        self,
        found: _Findings,
        severity: IntArray,
        weight: FloatArray,
        trusted: BoolArray,
        starts: IntArray | None,
        *,
        rows: IntArray,
    ) -> _Summaries:
        """Per group of the finding rows ``rows`` (``starts``; None: one row per group)."""
        st = self.settings
        idx = rows  # finding rows; the reductions return positions into them
        rank, margin, closing = found.rank[idx], found.margin[idx], found.closing[idx]
        alarm = rank >= _WARNING
        hold = (
            trusted
            & (closing > st.closing_speed_mps)
            & (margin <= st.release_margin_m + st.release_time_s * closing)
        )
        if starts is None or len(starts) == 0:
            if starts is not None:
                idx = idx[:0]
                weight, alarm, rank, hold = weight[:0], alarm[:0], rank[:0], hold[:0]
            return _Summaries(
                weight.copy(),
                np.where(alarm, weight, 0.0),
                np.where(rank == _EMERGENCY, weight, 0.0),
                np.where(hold, weight, 0.0),
                idx.copy(),
                np.where(alarm, idx, -1),
            )
        zero = np.zeros_like(weight)
        keys = severity[idx]
        worst = first_least(keys, starts)
        worst_alarm = first_least(keys, starts, alarm)
        return _Summaries(
            max_of_runs(weight, starts),
            max_of_runs(np.where(alarm, weight, zero), starts),
            max_of_runs(np.where(rank == _EMERGENCY, weight, zero), starts),
            max_of_runs(np.where(hold, weight, zero), starts),
            idx[worst],
            np.where(worst_alarm >= 0, idx[worst_alarm], -1),
        )

    def _decide(
        self,
        flat: _Flat,
        found: _Findings,
        severity: IntArray,
        conflict_rows: dict[str, Any],
        on_track: dict[str, Any],
    ) -> dict[str, dict[str, PairOutcome]]:
        st = self.settings
        n_hyp = len(flat.hyp["veh"])
        # a pair judged on a path by the other standing on it is judged by nothing else there
        located = on_track["path"] * n_hyp + on_track["g"]
        c_key = conflict_rows["path"] * n_hyp + conflict_rows["g"]
        free = np.flatnonzero(~_member(c_key, located))
        cs, ts = conflict_rows["summary"], on_track["summary"]
        possible = np.flatnonzero(on_track["possible"])
        path = np.concatenate([conflict_rows["path"][free], on_track["path"][possible]])
        g = np.concatenate([conflict_rows["g"][free], on_track["g"][possible]])
        parts = [_pick(cs, free), _pick(ts, possible)]
        summary = _Summaries(*(np.concatenate([getattr(x, f) for x in parts]) for f in _FIELDS))
        h = flat.path["hyp"][path]
        own, other = flat.hyp["veh"][h], flat.hyp["veh"][g]
        n_veh, n_path = len(flat.views), len(flat.paths)
        # (path, g) is unique: a pair located on a path is not also judged at its conflicts
        sort = order_by([own, other, h, g, path], [n_veh, n_veh, n_hyp, n_hyp, n_path], unique=True)
        path, g, h, own, other = path[sort], g[sort], h[sort], own[sort], other[sort]
        summary = _pick(summary, sort)
        if len(path) == 0:
            return {}
        starts = run_starts(own, other)
        group = group_of(len(path), starts)
        n_groups = len(starts)
        weight = flat.hyp["prob"][h] * flat.hyp["prob"][g] * flat.path["prob"][path]

        def total(x: FloatArray) -> FloatArray:
            return np.bincount(group, weights=weight * x, minlength=n_groups).astype(np.float64)

        any_w, alarm_w = total(summary.any), total(summary.alarm)
        emergency_w, hold_w = total(summary.emergency), total(summary.hold)
        worst_at, alarm_at = _most_severe(severity, summary, starts)
        # the shown row of each group: its most severe alarm-level finding when the alarm
        # weight is reached, else its most severe finding (shown as an advisory at most)
        raised = (alarm_at >= 0) & (
            (alarm_w >= st.warning_probability) | (emergency_w >= st.emergency_probability)
        )
        at = np.where(raised, alarm_at, worst_at)
        row = np.where(raised, summary.worst_alarm[at], summary.worst[at])
        level_code = np.where(
            raised, found.rank[row], np.where(found.rank[row] != _NONE, _ADVISORY, _NONE)
        )
        weight_shown = np.where(raised, alarm_w, any_w)
        unsure = np.array(
            [v.position is not None and v.position.status == "ambiguous" for v in flat.views],
            dtype=bool,
        )
        own_g, other_g = own[starts], other[starts]
        ambiguous = (any_w < 0.999) | unsure[own_g] | unsure[other_g]
        hold = hold_w >= st.warning_probability
        shown = _Shown.of(found, row)
        out: dict[str, dict[str, PairOutcome]] = {}
        views, paths = flat.views, flat.paths
        for k, (o, t, pth, lv, w, hd, amb) in enumerate(
            zip(
                own_g.tolist(),
                other_g.tolist(),
                path[at].tolist(),
                level_code.tolist(),
                weight_shown.tolist(),
                hold.tolist(),
                ambiguous.tolist(),
                strict=True,
            )
        ):
            other_view = views[t]
            level = LEVELS[lv]
            f = shown.finding(k, paths[pth].zone, other_view.vehicle_id, level)
            out.setdefault(views[o].vehicle_id, {})[other_view.vehicle_id] = _outcome(
                level, f, w, hd, amb
            )
        return out


_FIELDS = ("any", "alarm", "emergency", "hold", "worst", "worst_alarm")


def _member(keys: IntArray, among: IntArray) -> BoolArray:
    """Whether each key is one of ``among`` (:func:`numpy.isin` by a binary search in the
    sorted ``among``, which is cheaper when it is the shorter)."""
    if len(among) == 0:
        return np.zeros(len(keys), dtype=bool)
    ordered = np.sort(among)
    at = np.minimum(np.searchsorted(ordered, keys), len(ordered) - 1)
    return ordered[at] == keys


def _kept(keep: BoolArray, *columns: npt.NDArray[Any]) -> list[npt.NDArray[Any]]:
    """The rows of ``columns`` where ``keep`` holds (a take by the kept positions: numpy's
    boolean indexing of a large, mixed mask costs several times more)."""
    at = np.flatnonzero(keep)
    return [np.take(c, at, axis=0) for c in columns]


def _owner_of(counts: list[int] | IntArray) -> IntArray:
    """For consecutive runs of ``counts[k]`` rows, the run ``k`` of each row."""
    sizes = np.asarray(counts, dtype=np.int64)
    return np.repeat(np.arange(len(sizes)), sizes)


def _column(records: list[Any], name: str, dtype: type) -> npt.NDArray[Any]:
    """One attribute of every record as an array."""
    return np.fromiter(map(attrgetter(name), records), dtype=dtype, count=len(records))


def _pick(s: _Summaries, index: Any) -> _Summaries:
    return _Summaries(*(getattr(s, f)[index] for f in _FIELDS))


def _most_severe(
    severity: IntArray, parts: _Summaries, starts: IntArray
) -> tuple[IntArray, IntArray]:
    """Per group of summaries (``starts``) the position of the first with the most severe
    worst row, and of the first with the most severe alarm-level row (-1: none)."""
    worst_at = first_least(severity[parts.worst], starts)
    has_alarm = parts.worst_alarm >= 0
    alarm_keys = severity[np.where(has_alarm, parts.worst_alarm, 0)]
    return worst_at, first_least(alarm_keys, starts, has_alarm)


def _combine(severity: IntArray, parts: _Summaries, rows: IntArray, starts: IntArray) -> _Summaries:
    """Summaries of consecutive parts (``_Summary.add`` in order): maxima of the weights,
    the first most severe of the worst rows."""
    sel = _pick(parts, rows)
    worst_at, alarm_at = _most_severe(severity, sel, starts)
    return _Summaries(
        max_of_runs(sel.any, starts),
        max_of_runs(sel.alarm, starts),
        max_of_runs(sel.emergency, starts),
        max_of_runs(sel.hold, starts),
        sel.worst[worst_at],
        np.where(alarm_at >= 0, sel.worst_alarm[np.maximum(alarm_at, 0)], -1),
    )


def _findings(
    own: IntArray,
    other: IntArray,
    kind: IntArray,
    rank: IntArray,
    trusted: BoolArray,
    gap: FloatArray,
    margin: FloatArray,
    closing: FloatArray,
    ttc: FloatArray,
) -> _Findings:
    # an untrusted hypothesis (wrong way without sustained evidence) advises at most
    capped = ~trusted & (rank >= _WARNING)
    return _Findings(
        own, other, kind, np.where(capped, _ADVISORY, rank), capped, gap, margin, closing, ttc
    )


def _append(found: _Findings, more: _Findings) -> int:
    first = len(found.rank)
    for f in fields(_Findings):
        setattr(found, f.name, np.concatenate([getattr(found, f.name), getattr(more, f.name)]))
    return first


@dataclass(frozen=True, slots=True)
class _Shown:
    """The findings shown by the groups of a time, as lists (one row per group)."""

    kind: list[int]
    rank: list[int]
    capped: list[bool]
    gap: list[float]
    margin: list[float]
    closing: list[float]
    ttc: list[float]

    @classmethod
    def of(cls, found: _Findings, rows: IntArray) -> _Shown:
        return cls(
            found.kind[rows].tolist(),
            found.rank[rows].tolist(),
            found.capped[rows].tolist(),
            found.gap[rows].tolist(),
            found.margin[rows].tolist(),
            found.closing[rows].tolist(),
            found.ttc[rows].tolist(),
        )

    def finding(self, k: int, zone: str, other_id: str, level: Level) -> Finding:
        """The :class:`Finding` of group ``k``, shown at ``level``."""
        kind = _KINDS[self.kind[k]]
        gap = self.gap[k]
        if kind == "rear_end":
            detail = f"{other_id} ahead on the same track at {gap:.0f} m"
        elif kind == "head_on":
            detail = f"{other_id} ahead, running towards us at {gap:.0f} m"
        else:
            where = "switch" if kind == "merge" else "crossing"
            detail = f"{other_id} can reach the same {where} (we are {gap:.0f} m away)"
        if self.capped[k]:
            detail += " (unconfirmed)"
        ttc = self.ttc[k]
        return _finding(
            kind,
            level,
            gap,
            self.margin[k],
            self.closing[k],
            None if ttc != ttc else ttc,
            zone,
            detail,
        )


def _rank(
    gap_eff: FloatArray, warning: FloatArray, emergency: FloatArray, horizon: FloatArray
) -> IntArray:
    return np.where(
        gap_eff <= emergency,
        _EMERGENCY,
        np.where(gap_eff <= warning, _WARNING, np.where(gap_eff <= horizon, _ADVISORY, _NONE)),
    )


def _pair_sigma(a: FloatArray, b: FloatArray) -> FloatArray:
    # conflicts.pair_sigma_m, element by element
    return np.sqrt(a * a + b * b)


def _arrival_s(
    distance: FloatArray, speed: FloatArray, accel: FloatArray, vmax: FloatArray
) -> FloatArray:
    """conflicts.arrival_time_s element by element."""
    v = np.minimum(speed, vmax)
    with np.errstate(divide="ignore", invalid="ignore"):
        coast = np.where(v > 0.0, distance / v, np.inf)
        d_acc = (vmax * vmax - v * v) / (2.0 * accel)
        rising = (-v + np.sqrt(v * v + 2.0 * accel * distance)) / accel
        capped = (vmax - v) / accel + (distance - d_acc) / vmax
    out = np.where(accel <= 0.0, coast, np.where(distance <= d_acc, rising, capped))
    return np.where(distance <= 0.0, 0.0, out)
