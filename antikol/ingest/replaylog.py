"""Recorded logs in the project's one replay format.

A CSV log with the header ``vehicle_id,t,lat,lon,speed_mps,course_deg`` (extra
columns after these are allowed and ignored), or a directory of per-vehicle NMEA logs.
"""

from __future__ import annotations

import csv
import logging
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from antikol.errors import InputFileError, InvalidReportError, ReplayError
from antikol.report import VehicleReport

logger = logging.getLogger(__name__)

REPLAY_COLUMNS = ("vehicle_id", "t", "lat", "lon", "speed_mps", "course_deg")


@dataclass(frozen=True, slots=True)
class RowProblem:
    """A rejected row of a replay log: its 1-based line number and the reason."""

    line: int
    reason: str


@dataclass
class ReplayLog:
    """Reports read from a log plus the rows that could not be used."""

    reports: list[VehicleReport]
    problems: list[RowProblem] = field(default_factory=list)
    source: str = ""


def read_replay_csv(path: str | os.PathLike[str], *, strict: bool = False) -> ReplayLog:
    """Read a replay CSV log.

    Parameters
    ----------
    path : path-like
        CSV with the header ``vehicle_id,t,lat,lon,speed_mps,course_deg``.
    strict : bool
        Raise :class:`~antikol.errors.ReplayError` at the first bad row instead of
        skipping it.

    Returns
    -------
    ReplayLog
        Valid reports and the bad rows (line number and reason).

    Raises
    ------
    InputFileError
        The file is missing or unreadable.
    ReplayError
        The header is wrong, or a row is bad in strict mode.
    """
    p = Path(path)
    try:
        fh = p.open(newline="", encoding="utf-8")
    except OSError as exc:
        raise InputFileError(f"{p}: cannot open the replay log: {exc.strerror or exc}") from exc
    log = ReplayLog([], [], str(p))
    with fh:
        reader = csv.reader(fh)
        try:
            header = next(reader)
        except StopIteration:
            raise ReplayError(f"{p}: empty file (expected a header line)") from None
        except (csv.Error, UnicodeDecodeError) as exc:
            raise ReplayError(f"{p}: unreadable header: {exc}") from exc
        header = [h.strip().lstrip("\ufeff") for h in header]
        if tuple(header[: len(REPLAY_COLUMNS)]) != REPLAY_COLUMNS:
            raise ReplayError(
                f"{p}: header must start with {','.join(REPLAY_COLUMNS)}; got {','.join(header)}"
            )
        line = 1
        while True:
            try:
                row = next(reader)
            except StopIteration:
                break
            except (csv.Error, UnicodeDecodeError) as exc:
                line += 1
                _problem(log, line, f"unreadable row: {exc}", strict, p)
                continue
            line = reader.line_num
            if not row or all(not c.strip() for c in row):
                continue
            try:
                log.reports.append(_row_report(row))
            except (ValueError, InvalidReportError) as exc:
                _problem(log, line, str(exc), strict, p)
    return log


def _problem(log: ReplayLog, line: int, reason: str, strict: bool, path: Path) -> None:
    if strict:
        raise ReplayError(f"{path}:{line}: {reason}")
    log.problems.append(RowProblem(line, reason))
    logger.debug("%s:%d: skipped (%s)", path, line, reason)


def _row_report(row: Sequence[str]) -> VehicleReport:
    if len(row) < len(REPLAY_COLUMNS):
        raise ValueError(f"{len(row)} fields, expected at least {len(REPLAY_COLUMNS)}")
    values: dict[str, Any] = {"vehicle_id": row[0].strip()}
    for name, text in zip(REPLAY_COLUMNS[1:], row[1:6], strict=True):
        try:
            values[name] = float(text)
        except ValueError:
            raise ValueError(f"{name}={text!r} is not a number") from None
    return VehicleReport(**values)


def read_nmea_logs(path: str | os.PathLike[str]) -> ReplayLog:
    """Read a directory of per-vehicle NMEA logs (``<vehicle_id>.nmea``...) as one log."""
    from antikol.ingest.nmea import read_nmea_directory

    per_vehicle, stats = read_nmea_directory(path)
    reports = [r for rs in per_vehicle.values() for r in rs]
    problems = [
        RowProblem(0, f"{vid}: {n} NMEA sentence(s) skipped ({dict(s.skipped)})")
        for vid, s in stats.items()
        if (n := s.total_skipped)
    ]
    return ReplayLog(sorted(reports, key=lambda r: (r.t, r.vehicle_id)), problems, str(path))


def write_replay_csv(path: str | os.PathLike[str], reports: Iterable[VehicleReport]) -> Path:
    """Write reports in the replay format (the columns of :data:`REPLAY_COLUMNS`)."""
    p = Path(path)
    with p.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(REPLAY_COLUMNS)
        for r in reports:
            w.writerow(
                [
                    r.vehicle_id,
                    repr(r.t),
                    f"{r.lat:.8f}",
                    f"{r.lon:.8f}",
                    f"{r.speed_mps:.3f}",
                    f"{r.course_deg:.2f}",
                ]
            )
    return p
