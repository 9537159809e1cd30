"""Replaying recorded reports through the analyser (the paper's field-test analysis).

Input: a :class:`~antikol.ingest.replaylog.ReplayLog` (any log format, in memory), a
:class:`StreamedLog` (a replay CSV streamed in time order, constant memory) or a
:class:`~antikol.ingest.feed_stream.StreamedFeed` (an HFP or GTFS-realtime log sorted on
disk, bounded memory).
Output: one event row per threat per vehicle per analysis cycle, and a summary that
accounts for every record: read, replayed, rejected by reason.
"""

from __future__ import annotations

import csv
import logging
import math
import os
from collections import defaultdict
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from antikol.analysis.analyser import Analyser
from antikol.analysis.assessment import Assessment, Threat
from antikol.errors import InputFileError, InvalidArgumentError
from antikol.ingest.feed_stream import StreamedFeed
from antikol.ingest.replaylog import CsvScan, ReplayLog, stream_replay_csv
from antikol.report import VehicleReport

__all__ = [
    "EVENT_COLUMNS",
    "EventWriter",
    "ReplaySummary",
    "StreamedLog",
    "csv_cell",
    "cycles",
    "event_values",
    "replay",
]

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


def event_values(a: Assessment, th: Threat) -> dict[str, Any]:
    """One threat of an assessment as the values of :data:`EVENT_COLUMNS` (SI units; None
    where the threat has no value)."""
    return {
        "t": a.t,
        "own_id": a.own_id,
        "other_id": th.vehicle_id,
        "level": th.level,
        "kind": th.kind,
        "distance_m": th.distance_m,
        "method": th.method,
        "zone": th.zone,
        "closing_speed_mps": th.closing_speed_mps,
        "ttc_s": th.ttc_s,
        "probability": th.probability,
    }


def cycles(
    reports: Iterable[VehicleReport], cycle_s: float, *, in_time_order: bool = False
) -> Iterator[tuple[float, list[VehicleReport]]]:
    """Group reports into analysis cycles.

    Yields ``(t_end, reports)`` for each cycle: every report with
    ``t_end - cycle_s < t <= t_end``; cycles without reports are skipped.

    Parameters
    ----------
    reports : iterable of VehicleReport
    cycle_s : float
        Analysis period, s.
    in_time_order : bool
        The reports come in time order (a stream): they are grouped as they come, one
        cycle in memory at a time. Otherwise they are sorted first (stable: equal times
        keep their order).

    Raises
    ------
    InvalidArgumentError
        ``cycle_s`` is not a positive finite number.
    """
    if not (isinstance(cycle_s, (int, float)) and 0 < cycle_s < math.inf):
        raise InvalidArgumentError("cycle_s", cycle_s, "a positive number of seconds")
    ordered: Iterable[VehicleReport] = (
        reports if in_time_order else sorted(reports, key=lambda r: r.t)
    )
    batch: list[VehicleReport] = []
    t_end = -math.inf
    for r in ordered:
        if batch and r.t > t_end + 1e-9:
            yield t_end, batch
            batch = []
        if not batch:
            t_end = math.ceil(r.t / cycle_s - 1e-9) * cycle_s
        batch.append(r)
    if batch:
        yield t_end, batch


@dataclass(frozen=True)
class StreamedLog:
    """A replay CSV replayed as a stream: scanned once, then read again in time order.

    Parameters
    ----------
    path : path-like
        The replay CSV.
    scan : CsvScan
        Its first pass (:func:`~antikol.ingest.replaylog.scan_replay_csv`): counts,
        problems and whether the file is in time order.
    """

    path: str | os.PathLike[str]
    scan: CsvScan

    @property
    def reports(self) -> Iterator[VehicleReport]:
        """The valid reports in time order (a new pass over the file on each use)."""
        return stream_replay_csv(self.path, in_time_order=self.scan.in_time_order)


@dataclass
class ReplaySummary:
    """Counts of a replay per own vehicle.

    Attributes
    ----------
    cycles : int
    vehicles : int
    reports : int
        Reports replayed.
    rejected_rows : int
        Records rejected as bad.
    rows_read : int or None
        Records read (replay CSV: data lines), when the reader counts them:
        ``rows_read == reports + rejected_rows``.
    rejected_by_reason : dict
        Rejected records per kind of problem.
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
    rows_read: int | None = None
    rejected_by_reason: dict[str, int] = field(default_factory=dict)
    table: dict[str, int] = field(default_factory=dict)
    lamp_cycles: dict[str, int] = field(default_factory=lambda: defaultdict(int))
    episodes: dict[str, int] = field(default_factory=lambda: defaultdict(int))
    by_method: dict[str, int] = field(default_factory=lambda: defaultdict(int))
    by_kind: dict[str, int] = field(default_factory=lambda: defaultdict(int))
    suppressed: int = 0


def replay(
    log: ReplayLog | StreamedLog | StreamedFeed,
    analyser: Analyser,
    *,
    cycle_s: float = 1.0,
    on_assessment: Callable[[Assessment], None] | None = None,
    progress: bool = False,
) -> ReplaySummary:
    """Run the analyser for every vehicle at every analysis cycle.

    Parameters
    ----------
    log : ReplayLog, StreamedLog or StreamedFeed
        Reports in memory (sorted by time here), a streamed replay CSV or a streamed
        operator's feed (:class:`~antikol.ingest.feed_stream.StreamedFeed`).
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

    Raises
    ------
    InvalidArgumentError
        ``cycle_s`` is not a positive number.
    """
    if isinstance(log, StreamedLog):
        summary = ReplaySummary(
            rejected_rows=log.scan.rejected,
            rows_read=log.scan.rows,
            rejected_by_reason=dict(log.scan.rejected_by_reason),
        )
        batches = cycles(log.reports, cycle_s, in_time_order=True)
    elif isinstance(log, StreamedFeed):
        summary = ReplaySummary(
            rejected_rows=log.rejected, rejected_by_reason=log.rejected_by_reason()
        )
        batches = cycles(log.reports, cycle_s, in_time_order=True)
    else:
        summary = ReplaySummary(
            rejected_rows=log.rejected,
            rows_read=log.rows,
            rejected_by_reason=log.rejected_by_reason(),
        )
        batches = cycles(log.reports, cycle_s)
    lamp_prev: dict[str, bool] = {}
    seen: set[str] = set()
    if progress:
        try:
            from tqdm import tqdm
        except ImportError:
            logger.warning("no progress bar: tqdm is not installed (pip install 'antikol[plot]')")
        else:
            batches = tqdm(batches, desc="replay", unit=" cycle", leave=False)
    for t_end, batch in batches:
        analyser.update_many(batch)
        summary.reports += len(batch)
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


#: Decimals of the numeric event columns in the CSV (seconds to ms, metres to cm).
_CSV_DECIMALS = {"t": 3, "distance_m": 2, "closing_speed_mps": 2, "ttc_s": 2, "probability": 3}


def csv_cell(value: Any, decimals: int | None = None) -> str:
    """A value as a CSV cell: empty for None, ``1``/``0`` for a bool, a number with
    ``decimals`` decimals when given, else ``str(value)``."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "1" if value else "0"
    if decimals is not None:
        return f"{value:.{decimals}f}"
    return str(value)


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
                [csv_cell(v, _CSV_DECIMALS.get(k)) for k, v in event_values(a, th).items()]
            )
            self.rows += 1

    def close(self) -> None:
        self._fh.close()

    def __enter__(self) -> EventWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
