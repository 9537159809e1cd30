"""Scoring of analysers against the ground truth, and side-by-side comparisons.

An analyser's warning for a pair is any threat on that vehicle of level ``warning`` or
above (the paper's lamp). It is scored against :mod:`antikol.evaluation.groundtruth`:

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

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from antikol.analysis.analyser import Analyser
from antikol.evaluation.groundtruth import (
    CLEAR,
    REQUIRED,
    GroundTruth,
    analysis_times,
    ground_truth,
)
from antikol.kinds import level_rank
from antikol.sim import SimulationResult
from trackmap import TrackMap

__all__ = [
    "AlarmLog",
    "Comparison",
    "Score",
    "compare",
    "format_table",
    "run_analyser",
    "score",
]


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


@dataclass(frozen=True)
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


@dataclass(frozen=True)
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
