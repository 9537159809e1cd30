"""The pair-by-pair evaluation the analyser used before :mod:`antikol.analysis.pairs`.

Kept as the test oracle: plain loops over hypotheses, zones, conflict points and ways,
calling the scalar rules of :mod:`antikol.analysis.conflicts`. ``tests/test_pairs.py``
checks that the vectorised evaluation decides every pair exactly as this does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from antikol.analysis.conflicts import (
    Finding,
    RuleSettings,
    approach,
    at_conflict,
    conflict_kind,
    earliest_arrival_s,
    on_path,
)
from antikol.analysis.pairs import PairOutcome, PairSettings
from antikol.analysis.views import CycleViews, HypothesisView, VehicleView
from antikol.kinds import level_rank

_ALARM = ("warning", "emergency")


@dataclass
class _Summary:
    any: float = 0.0
    alarm: float = 0.0
    emergency: float = 0.0
    hold: float = 0.0
    worst: Finding | None = None
    worst_alarm: Finding | None = None

    def add(self, later: _Summary) -> None:
        if later.worst is None:
            return
        self.any = max(self.any, later.any)
        self.alarm = max(self.alarm, later.alarm)
        self.emergency = max(self.emergency, later.emergency)
        self.hold = max(self.hold, later.hold)
        if self.worst is None or _severity(later.worst) > _severity(self.worst):
            self.worst = later.worst
        if later.worst_alarm is not None and (
            self.worst_alarm is None or _severity(later.worst_alarm) > _severity(self.worst_alarm)
        ):
            self.worst_alarm = later.worst_alarm


def _severity(f: Finding) -> tuple[int, float]:
    return (level_rank(f.level), -f.margin_m)


def _summarise(findings, trusted: bool, st: PairSettings) -> _Summary:
    summary = _Summary()
    for f, weight in findings:
        if not trusted and f.level in _ALARM:
            f = replace(f, level="advisory", detail=f.detail + " (unconfirmed)")
        if summary.worst is None or _severity(f) > _severity(summary.worst):
            summary.worst = f
        summary.any = max(summary.any, weight)
        if f.level == "emergency":
            summary.emergency = max(summary.emergency, weight)
        if f.level in _ALARM:
            summary.alarm = max(summary.alarm, weight)
            if summary.worst_alarm is None or _severity(f) > _severity(summary.worst_alarm):
                summary.worst_alarm = f
        if (
            trusted
            and f.closing_mps > st.closing_speed_mps
            and f.margin_m <= st.release_margin_m + st.release_time_s * f.closing_mps
        ):
            summary.hold = max(summary.hold, weight)
    return summary


@dataclass(frozen=True)
class _Entry:
    """Another vehicle's hypothesis passing a conflict point one way, with the probability
    that it passes that way (the sum over its paths that do)."""

    hyp: int
    distance_m: float
    from_edge: int
    to_edge: int
    probability: float


_INDEX: dict[int, tuple[VehicleView, dict[int, list[_Entry]]]] = {}


def _entries(view: VehicleView, conflict_id: int) -> list[_Entry]:
    known = _INDEX.get(id(view))
    if known is None or known[0] is not view:
        if len(_INDEX) > 5000:
            _INDEX.clear()
        index: dict[int, list[_Entry]] = {}
        for h_idx, h in enumerate(view.hyps):
            passing: dict[int, float] = {}
            for p_idx, ways in enumerate(h.path_approaches):
                pi = h.path_probability[p_idx]
                pi = max(pi, 0.0) if math.isfinite(pi) else 0.0
                for a in ways:
                    passing[a] = passing.get(a, 0.0) + pi
            for a, total in passing.items():
                prob = min(total, 1.0)
                ap = h.approaches[a]
                index.setdefault(ap.conflict_id, []).append(
                    _Entry(h_idx, ap.distance_m, ap.from_edge, ap.to_edge, prob)
                )
        known = _INDEX[id(view)] = (view, index)
    return known[1].get(conflict_id, [])


def _located(h: HypothesisView, g: HypothesisView) -> dict[int, tuple[float, bool]]:
    out: dict[int, tuple[float, bool]] = {}
    steps = [(p_idx, st) for p_idx, p in enumerate(h.paths) for st in p.steps]
    for p_idx, step in (x for x in steps if x[1].edge_id == g.edge_id):
        if p_idx in out:
            continue
        d = step.distance_to(g.offset_m)
        if d is not None:
            out[p_idx] = (d, step.direction == g.direction)
    return out


def pair_outcome(
    net,
    cycle: CycleViews,
    own: VehicleView,
    other: VehicleView,
    rules: RuleSettings,
    st: PairSettings,
    traction_mps2: float,
) -> PairOutcome | None:
    """One pair, decided by loops over the scalar rules."""
    alarm_w = emergency_w = any_w = hold_w = 0.0
    worst = worst_alarm = None
    for h in own.hyps:
        for g_idx, g in enumerate(other.hyps):
            w = h.probability * g.probability
            trusted = h.trusted and g.trusted
            located = _located(h, g)
            for p_idx, pi in enumerate(h.path_probability):
                path = h.paths[p_idx]
                at = located.get(p_idx)
                if at is not None:
                    found = on_path(own, path, at[0], other, at[1], rules)
                    summary = _summarise([] if found is None else [(found, 1.0)], trusted, st)
                else:
                    summary = _Summary()
                    for k in h.path_approaches[p_idx]:
                        ap = h.approaches[k]
                        conflict = net.conflicts[ap.conflict_id]
                        mine = approach(own, conflict, ap.distance_m, ap.from_edge, ap.to_edge)
                        findings = []
                        for e in _entries(other, ap.conflict_id):
                            if e.hyp != g_idx:
                                continue
                            kind = conflict_kind(
                                conflict, ap.from_edge, ap.to_edge, e.from_edge, e.to_edge
                            )
                            if kind is None:
                                continue
                            theirs = approach(other, conflict, e.distance_m, e.from_edge, e.to_edge)
                            arrival = earliest_arrival_s(other, theirs, rules, traction_mps2)
                            f = at_conflict(own, kind, mine, other, theirs, arrival, rules)
                            if f is not None:
                                findings.append((f, e.probability))
                        summary.add(_summarise(findings, trusted, st))
                if summary.worst is None:
                    continue
                zoned = replace(summary.worst, zone=path.zone)
                if worst is None or _severity(summary.worst) > _severity(worst):
                    worst = zoned
                if summary.worst_alarm is not None and (
                    worst_alarm is None or _severity(summary.worst_alarm) > _severity(worst_alarm)
                ):
                    worst_alarm = replace(summary.worst_alarm, zone=path.zone)
                hold_w += w * pi * summary.hold
                alarm_w += w * pi * summary.alarm
                emergency_w += w * pi * summary.emergency
                any_w += w * pi * summary.any
    if worst is None:
        return None
    hold = hold_w >= st.warning_probability
    ambiguous = any_w < 0.999 or any(
        p is not None and p.status == "ambiguous" for p in (own.position, other.position)
    )
    if worst_alarm is not None and (
        alarm_w >= st.warning_probability or emergency_w >= st.emergency_probability
    ):
        return PairOutcome(worst_alarm.level, worst_alarm, alarm_w, hold, ambiguous)
    level = "advisory" if worst.level != "none" else "none"
    return PairOutcome(level, replace(worst, level=level), any_w, hold, ambiguous)
