"""Replaying recorded reports through the analyser (the paper's field-test analysis).

Input: a :class:`~antikol.ingest.replaylog.ReplayLog` (CSV or NMEA directory).
Output: one event row per threat per vehicle per analysis cycle, and a summary.
"""

from __future__ import annotations

import csv
import logging
import math
import os
from collections import defaultdict
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from antikol.analysis.analyser import Analyser
from antikol.analysis.assessment import Assessment
from antikol.errors import InputFileError
from antikol.ingest.replaylog import ReplayLog
from antikol.report import VehicleReport

__all__ = ["EVENT_COLUMNS", "EventWriter", "ReplaySummary", "cycles", "replay"]

logger = logging.getLogger(__name__)

EVENT_COLUMNS = (
    "t",
    "own_id",
    "other_id",
    "level",
    "kind",
    "distance_m",
    "method",
    "zone",
    "closing_speed_mps",
    "ttc_s",
    "probability",
)


def cycles(
    reports: Sequence[VehicleReport], cycle_s: float
) -> Iterator[tuple[float, list[VehicleReport]]]:
    """Group time-ordered reports into analysis cycles.

    Yields ``(t_end, reports)`` for each cycle: every report with
    ``t_end - cycle_s < t <= t_end``; cycles without reports are skipped.
    """
    if not cycle_s > 0:
        raise ValueError(f"cycle_s must be positive, got {cycle_s}")
    ordered = sorted(reports, key=lambda r: r.t)
    i = 0
    while i < len(ordered):
        t_end = math.ceil(ordered[i].t / cycle_s - 1e-9) * cycle_s
        batch = []
        while i < len(ordered) and ordered[i].t <= t_end + 1e-9:
            batch.append(ordered[i])
            i += 1
        yield t_end, batch


@dataclass
class ReplaySummary:
    """Counts of a replay per own vehicle.

    Attributes
    ----------
    cycles : int
    vehicles : int
    reports : int
    rejected_rows : int
    table : dict
        Vehicle-table counters (stale, duplicate, expired...).
    lamp_cycles, episodes : dict
        Per vehicle: cycles with the lamp on (level warning or above) and separate alarm
        episodes.
    by_method, by_kind : dict
        Threat observations per method and per kind.
    """

    cycles: int = 0
    vehicles: int = 0
    reports: int = 0
    rejected_rows: int = 0
    table: dict[str, int] = field(default_factory=dict)
    lamp_cycles: dict[str, int] = field(default_factory=lambda: defaultdict(int))
    episodes: dict[str, int] = field(default_factory=lambda: defaultdict(int))
    by_method: dict[str, int] = field(default_factory=lambda: defaultdict(int))
    by_kind: dict[str, int] = field(default_factory=lambda: defaultdict(int))
    suppressed: int = 0


def replay(
    log: ReplayLog,
    analyser: Analyser,
    *,
    cycle_s: float = 1.0,
    on_assessment: Callable[[Assessment], None] | None = None,
    progress: bool = False,
) -> ReplaySummary:
    """Run the analyser for every vehicle at every analysis cycle.

    Parameters
    ----------
    log : ReplayLog
    analyser : Analyser
    cycle_s : float
        Analysis period, s (the paper: 1 s).
    on_assessment : callable, optional
        Called with every assessment (e.g. to write events).
    progress : bool
        Show a progress bar.

    Returns
    -------
    ReplaySummary
    """
    summary = ReplaySummary(rejected_rows=log.rejected, reports=len(log.reports))
    lamp_prev: dict[str, bool] = {}
    seen: set[str] = set()
    batches: Iterable[tuple[float, list[VehicleReport]]] = cycles(log.reports, cycle_s)
    if progress:
        from tqdm import tqdm

        batches = tqdm(list(batches), desc="replay", unit=" cycle", leave=False)
    for t_end, batch in batches:
        analyser.update_many(batch)
        summary.cycles += 1
        for own_id, a in analyser.assess_all(t=t_end).items():
            seen.add(own_id)
            if on_assessment is not None:
                on_assessment(a)
            for th in a.threats:
                summary.by_method[th.method] += 1
                summary.by_kind[th.kind] += 1
            summary.suppressed += len(a.suppressed)
            if a.lamp:
                summary.lamp_cycles[own_id] += 1
                if not lamp_prev.get(own_id, False):
                    summary.episodes[own_id] += 1
            lamp_prev[own_id] = a.lamp
    summary.vehicles = len(seen)
    summary.table = dict(analyser.table.stats)
    return summary


class EventWriter:
    """Writes one CSV row per threat of every assessment (see :data:`EVENT_COLUMNS`)."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        try:
            self._fh = self.path.open("w", newline="", encoding="utf-8")
        except OSError as exc:
            raise InputFileError(
                f"{self.path}: cannot write events: {exc.strerror or exc}"
            ) from exc
        self._w = csv.writer(self._fh)
        self._w.writerow(EVENT_COLUMNS)
        self.rows = 0

    def __call__(self, a: Assessment) -> None:
        for th in a.threats:
            self._w.writerow(
                [
                    f"{a.t:.3f}",
                    a.own_id,
                    th.vehicle_id,
                    th.level,
                    th.kind,
                    f"{th.distance_m:.2f}",
                    th.method,
                    th.zone or "",
                    f"{th.closing_speed_mps:.2f}",
                    "" if th.ttc_s is None else f"{th.ttc_s:.2f}",
                    "" if th.probability is None else f"{th.probability:.3f}",
                ]
            )
            self.rows += 1

    def close(self) -> None:
        self._fh.close()

    def __enter__(self) -> EventWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
