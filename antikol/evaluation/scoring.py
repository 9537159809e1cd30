"""Scoring of analysers against the ground truth, and side-by-side comparisons.

An analyser's warning for a pair is any threat on that vehicle of level ``warning`` or
above (the paper's lamp). It is scored against :mod:`antikol.evaluation.groundtruth`:

* **required-warning episodes** — runs of "required" cycles of a pair (gaps of up to
  ``bridge_s`` bridged). An episode is **timely** when the analyser warned in
  ``[start − lookback_s, start + grace_s]``; otherwise it is **missed**. A warning that
  comes only after ``start + grace_s`` is a miss: the gap had already fallen below the
  braking distance. Such misses are also counted as **late** (for information; ``missed``
  includes them);
* **alarm at start** — a warning in ``[start − 5 s, start + 1 s]`` (``at_start_window_s``):
  an alarm long before that went off again does not count;
* **lead time** — for timely episodes, how long before the start the warning that covered
  it was already on, s;
* **false-alarm episodes** — maximal runs of warnings on a clearly conflict-free pair, per
  vehicle-hour in service;
* **lamp toggles** — on/off switches of each vehicle's lamp per vehicle-hour;
* **nuisance lamp** — lamp-on vehicle-seconds farther than ``nuisance_before_s`` (10 s)
  before or ``nuisance_after_s`` (5 s) after any required second of that vehicle (a lamp
  left on "to be safe"), as a share of the vehicle-seconds in service (and of the lamp-on
  time).

>>> sc = Score(required=4, timely=3, missed=1, late=1, at_start=2, vehicle_hours=2.0)
>>> sc.missed_share, sc.alarm_at_start_rate
(0.25, 0.5)
"""

from __future__ import annotations

import itertools
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
    "MissedEpisode",
    "Score",
    "compare",
    "format_table",
    "run_analyser",
    "score",
]


@dataclass(frozen=True, slots=True)
class MissedEpisode:
    """A required-warning episode without a timely warning.

    Attributes
    ----------
    own, other : str
        The vehicle that needed the warning and the one it was about.
    start_s : float
        Time the requirement began, s.
    kind : str
        Conflict kind (``rear_end``, ``head_on``, ``merge``, ``crossing``).
    late_s : float or None
        How long after the start the first warning came, s (None: never).
    """

    own: str
    other: str
    start_s: float
    kind: str
    late_s: float | None


@dataclass(frozen=True)
class Score:
    """Scores of one analyser against the ground truth (see the module docstring).

    Attributes
    ----------
    required : int
        Required-warning episodes.
    timely : int
        Episodes warned in time.
    missed : int
        Episodes not warned in time (``required - timely``), late ones included.
    late : int
        Of the missed episodes, those warned only after the start (information).
    at_start : int
        Episodes with an alarm within the at-start window.
    false_alarm_episodes : int
    vehicle_hours : float
        Vehicle-hours in service.
    lamp_toggles : int
    lamp_on_s, nuisance_lamp_s : float
        Lamp-on vehicle-seconds in service, and those of them away from any need, s.
    leads_s : tuple of float
        Lead time of each timely episode, s.
    missed_detail : tuple of MissedEpisode
    """

    required: int = 0
    timely: int = 0
    missed: int = 0
    late: int = 0
    at_start: int = 0
    false_alarm_episodes: int = 0
    vehicle_hours: float = 0.0
    lamp_toggles: int = 0
    lamp_on_s: float = 0.0
    nuisance_lamp_s: float = 0.0
    leads_s: tuple[float, ...] = ()
    missed_detail: tuple[MissedEpisode, ...] = field(default=())

    @property
    def missed_share(self) -> float:
        """Missed episodes per required episode (0 when none was required)."""
        return self.missed / self.required if self.required else 0.0

    @property
    def alarm_at_start_rate(self) -> float | None:
        """Episodes with an alarm at their start per required episode (None if none)."""
        return self.at_start / self.required if self.required else None

    @property
    def false_alarms_per_vehicle_hour(self) -> float:
        return self.false_alarm_episodes / self.vehicle_hours if self.vehicle_hours else 0.0

    @property
    def lamp_toggles_per_vehicle_hour(self) -> float:
        return self.lamp_toggles / self.vehicle_hours if self.vehicle_hours else 0.0

    @property
    def nuisance_lamp_share(self) -> float:
        """Nuisance lamp time as a share of the vehicle time in service."""
        total = 3600.0 * self.vehicle_hours
        return self.nuisance_lamp_s / total if total else 0.0

    @property
    def nuisance_share_of_lamp(self) -> float:
        """Nuisance lamp time as a share of the lamp-on time."""
        return self.nuisance_lamp_s / self.lamp_on_s if self.lamp_on_s else 0.0

    @property
    def mean_lead_s(self) -> float | None:
        return float(np.mean(self.leads_s)) if self.leads_s else None

    def as_dict(self) -> dict[str, Any]:
        """The scores as plain JSON-ready values."""
        rate = self.alarm_at_start_rate
        return {
            "required_warnings": self.required,
            "timely": self.timely,
            "missed": self.missed,
            "late": self.late,
            "alarm_at_start_rate": None if rate is None else round(rate, 4),
            "mean_lead_s": None if self.mean_lead_s is None else round(self.mean_lead_s, 2),
            "false_alarm_episodes": self.false_alarm_episodes,
            "false_alarms_per_vehicle_hour": round(self.false_alarms_per_vehicle_hour, 3),
            "lamp_toggles_per_vehicle_hour": round(self.lamp_toggles_per_vehicle_hour, 3),
            "nuisance_lamp_share": round(self.nuisance_lamp_share, 5),
            "nuisance_share_of_lamp": round(self.nuisance_share_of_lamp, 4),
            "vehicle_hours": round(self.vehicle_hours, 3),
            "missed_episodes": [
                {
                    "own": m.own,
                    "other": m.other,
                    "start_s": m.start_s,
                    "kind": m.kind,
                    "late_s": m.late_s,
                }
                for m in self.missed_detail
            ],
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


def _bridged(mask: np.ndarray, gap: int) -> np.ndarray:
    """``mask`` with runs of False of at most ``gap`` cycles between True runs filled."""
    out = mask.copy()
    if gap <= 0:
        return out
    runs = _runs(mask)
    for (_, e0), (s1, _) in itertools.pairwise(runs):
        if s1 - e0 <= gap:
            out[e0:s1] = True
    return out


def score(
    truth: GroundTruth,
    log: AlarmLog,
    *,
    cycle_s: float = 1.0,
    lookback_s: float = 10.0,
    grace_s: float = 1.0,
    at_start_window_s: tuple[float, float] = (5.0, 1.0),
    bridge_s: float = 2.0,
    nuisance_before_s: float = 10.0,
    nuisance_after_s: float = 5.0,
) -> Score:
    """Score an analyser's alarm log against the ground truth (see the module notes).

    Parameters
    ----------
    truth : GroundTruth
    log : AlarmLog
    cycle_s : float
        Analysis period, s.
    lookback_s : float
        A warning this long before an episode's start is in time, s.
    grace_s : float
        A warning up to this long after the start is still in time (one cycle of
        latency), s; any later warning is a miss.
    at_start_window_s : (float, float)
        The alarm-at-start window: this long before and after the start, s.
    bridge_s : float
        Gaps of required cycles up to this long do not split an episode, s.
    nuisance_before_s, nuisance_after_s : float
        Lamp time within this long before or after a required second of the vehicle is
        not a nuisance, s.

    Returns
    -------
    Score
    """
    back = max(round(lookback_s / cycle_s), 0)
    grace = max(round(grace_s / cycle_s), 0)
    at_back = max(round(at_start_window_s[0] / cycle_s), 0)
    at_fwd = max(round(at_start_window_s[1] / cycle_s), 0)
    gap = max(round(bridge_s / cycle_s), 0)
    n_t = len(truth.times_s)
    required = timely = late = at_start = false_alarms = 0
    leads: list[float] = []
    missed: list[MissedEpisode] = []
    need: dict[str, np.ndarray] = {}
    for pair, st in truth.state.items():
        req = st == REQUIRED
        if req.any():
            own_need = need.setdefault(pair[0], np.zeros(n_t, dtype=bool))
            own_need |= req
        warn = log.pair_warn.get(pair)
        if warn is None:
            continue
        for a, b in _runs(_bridged(req, gap)):
            required += 1
            lo, hi = max(a - back, 0), min(a + grace + 1, n_t)
            in_time = np.flatnonzero(warn[lo:hi])
            if len(warn[max(a - at_back, 0) : min(a + at_fwd + 1, n_t)].nonzero()[0]):
                at_start += 1
            if len(in_time):
                timely += 1
                first = lo + int(in_time[0])
                while first > 0 and warn[first - 1]:
                    first -= 1
                leads.append(max(a - first, 0) * cycle_s)
                continue
            after = np.flatnonzero(warn[hi:b])
            late_s = None
            if len(after):
                late += 1
                late_s = float((hi + int(after[0]) - a) * cycle_s)
            missed.append(
                MissedEpisode(
                    pair[0], pair[1], float(truth.times_s[a]), truth.kind[pair][a], late_s
                )
            )
        false_alarms += len(_runs(warn & (st == CLEAR)))
    toggles = 0
    lamp_on = nuisance = 0
    before = max(round(nuisance_before_s / cycle_s), 0)
    after_n = max(round(nuisance_after_s / cycle_s), 0)
    for v, lamp in log.lamp.items():
        live = truth.in_service.get(v)
        if live is None:
            continue
        on = lamp & live
        toggles += int(np.count_nonzero(np.diff(on.astype(np.int8))))
        lamp_on += int(on.sum())
        near = _widened(need.get(v, np.zeros(n_t, dtype=bool)), before, after_n)
        nuisance += int((on & ~near).sum())
    return Score(
        required=required,
        timely=timely,
        missed=required - timely,
        late=late,
        at_start=at_start,
        false_alarm_episodes=false_alarms,
        vehicle_hours=truth.vehicle_hours(),
        lamp_toggles=toggles,
        lamp_on_s=lamp_on * cycle_s,
        nuisance_lamp_s=nuisance * cycle_s,
        leads_s=tuple(leads),
        missed_detail=tuple(missed),
    )


def _widened(mask: np.ndarray, before: int, after: int) -> np.ndarray:
    """Cycles within ``before`` cycles before or ``after`` cycles after a True cycle."""
    out = mask.copy()
    idx = np.flatnonzero(mask)
    if not len(idx):
        return out
    n = len(mask)
    delta = np.zeros(n + 1, dtype=np.int64)
    np.add.at(delta, np.clip(idx - before, 0, n), 1)
    np.add.at(delta, np.clip(idx + after + 1, 0, n), -1)
    return np.cumsum(delta[:n]) > 0


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
    """A plain-text table of comparisons (one row per scenario and method).

    ``missed`` includes the late warnings (``late`` says how many of them came late);
    ``start%`` is the alarm-at-start rate, ``lead s`` the mean lead of timely warnings,
    ``FA/vh`` false-alarm episodes and ``toggle/vh`` lamp toggles per vehicle-hour, and
    ``nuis%`` the nuisance lamp time as a share of the vehicle time in service.
    """
    header = (
        f"{'scenario':<22} {'method':<7} {'required':>8} {'timely':>6} {'missed':>6} "
        f"{'(late)':>6} {'start%':>6} {'lead s':>6} {'FA/vh':>7} {'toggle/vh':>9} "
        f"{'nuis%':>6}"
    )
    lines = [header, "-" * len(header)]
    for c in comparisons:
        for method, sc in (("sector", c.sector), ("track", c.track)):
            lead = "-" if sc.mean_lead_s is None else f"{sc.mean_lead_s:.1f}"
            rate = sc.alarm_at_start_rate
            start = "-" if rate is None else f"{100.0 * rate:.0f}"
            lines.append(
                f"{c.name:<22} {method:<7} {sc.required:>8} {sc.timely:>6} {sc.missed:>6} "
                f"{sc.late:>6} {start:>6} {lead:>6} {sc.false_alarms_per_vehicle_hour:>7.2f} "
                f"{sc.lamp_toggles_per_vehicle_hour:>9.2f} "
                f"{100.0 * sc.nuisance_lamp_share:>6.2f}"
            )
    return "\n".join(lines)
