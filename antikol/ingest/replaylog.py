"""Recorded logs in the project's one replay format, and its only reader and writer.

A replay CSV has a header line. It starts with the required columns
``vehicle_id,t,lat,lon,speed_mps,course_deg`` (:data:`REPLAY_COLUMNS`, in this order).
Any of the optional columns ``braking``, ``length_m``, ``antenna_offset_m``, ``seq``,
``hdop``, ``fix_quality`` and ``odometer_m`` (:data:`REPLAY_OPTIONAL_COLUMNS`) may follow,
in any order; the reader puts them into the reports, and an empty cell means "not given"
(the report's default: ``braking="none"``, the others None). Other columns after the
required ones are ignored; an optional column named twice in the header is an error.
Units are those of :class:`~antikol.report.VehicleReport` (s, degrees, m/s, metres).

Recorded logs may also be a directory of per-vehicle NMEA logs (:func:`read_nmea_logs`).
"""

from __future__ import annotations

import csv
import logging
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

from antikol.errors import InputFileError, InvalidReportError, ReplayError
from antikol.report import VehicleReport

__all__ = [
    "REPLAY_COLUMNS",
    "REPLAY_OPTIONAL_COLUMNS",
    "ReplayLog",
    "RowProblem",
    "read_nmea_logs",
    "read_replay_csv",
    "write_replay_csv",
]

logger = logging.getLogger(__name__)

#: The required columns of a replay CSV, in order.
REPLAY_COLUMNS: Final = ("vehicle_id", "t", "lat", "lon", "speed_mps", "course_deg")
# How the reader turns a non-empty cell of each optional column into a report field.
_OPTIONAL_PARSERS: Final[dict[str, Callable[[str], Any]]] = {
    "braking": str,
    "length_m": float,
    "antenna_offset_m": float,
    "seq": int,
    "hdop": float,
    "fix_quality": int,
    "odometer_m": float,
}
#: The optional columns that may follow the required ones, in any order.
REPLAY_OPTIONAL_COLUMNS: Final = tuple(_OPTIONAL_PARSERS)


@dataclass(frozen=True, slots=True)
class RowProblem:
    """A bad record of a log: where it is and why it could not be used (or was changed).

    Attributes
    ----------
    line : int
        1-based line number (text formats) or record number within its file (JSON
        arrays, GTFS-realtime entities); 0 when the whole file is concerned.
    reason : str
        What is wrong, naming the field.
    source : str
        The file, when a log spans several files (else empty).
    kept : bool
        The record was kept without the offending field (e.g. an odometer that went
        back), rather than dropped.
    """

    line: int
    reason: str
    source: str = ""
    kept: bool = False

    def where(self) -> str:
        """``file:line`` (or ``line N``, or the file alone for a whole-file problem)."""
        if self.source:
            return f"{self.source}:{self.line}" if self.line else self.source
        return f"line {self.line}" if self.line else "log"


@dataclass
class ReplayLog:
    """Reports read from a log plus the records that could not be used.

    Attributes
    ----------
    reports : list of VehicleReport
        In time order for the feed formats.
    problems : list of RowProblem
        Bad records (dropped unless ``kept``).
    source : str
    ignored : dict of str to int
        Valid records deliberately not turned into reports, by reason (e.g. HFP events
        other than vehicle positions, duplicate GTFS-realtime snapshots).
    """

    reports: list[VehicleReport]
    problems: list[RowProblem] = field(default_factory=list)
    source: str = ""
    ignored: dict[str, int] = field(default_factory=dict)

    @property
    def rejected(self) -> int:
        """Records dropped because they were bad."""
        return sum(not p.kept for p in self.problems)


def read_replay_csv(path: str | os.PathLike[str], *, strict: bool = False) -> ReplayLog:
    """Read a replay CSV log.

    Parameters
    ----------
    path : path-like
        CSV whose header starts ``vehicle_id,t,lat,lon,speed_mps,course_deg``, optionally
        followed by the columns of :data:`REPLAY_OPTIONAL_COLUMNS` in any order (see the
        module notes).
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
        The header is wrong (required columns missing or out of order, an optional column
        named twice), or a row is bad in strict mode.
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
        optional = _optional_columns(header, p)
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
                log.reports.append(_row_report(row, optional))
            except (ValueError, InvalidReportError) as exc:
                _problem(log, line, str(exc), strict, p)
    return log


def _problem(log: ReplayLog, line: int, reason: str, strict: bool, path: Path) -> None:
    if strict:
        raise ReplayError(f"{path}:{line}: {reason}")
    log.problems.append(RowProblem(line, reason))
    logger.debug("%s:%d: skipped (%s)", path, line, reason)


def _optional_columns(header: Sequence[str], path: Path) -> dict[str, int]:
    """Index of each optional column present in the header."""
    found: dict[str, int] = {}
    for index in range(len(REPLAY_COLUMNS), len(header)):
        name = header[index]
        if name not in _OPTIONAL_PARSERS:
            continue
        if name in found:
            raise ReplayError(f"{path}: column {name!r} appears twice in the header")
        found[name] = index
    return found


def _row_report(row: Sequence[str], optional: Mapping[str, int]) -> VehicleReport:
    if len(row) < len(REPLAY_COLUMNS):
        raise ValueError(f"{len(row)} fields, expected at least {len(REPLAY_COLUMNS)}")
    values: dict[str, Any] = {"vehicle_id": row[0].strip()}
    for name, text in zip(REPLAY_COLUMNS[1:], row[1:6], strict=True):
        try:
            values[name] = float(text)
        except ValueError:
            raise ValueError(f"{name}={text!r} is not a number") from None
    for name, index in optional.items():
        # a row shorter than the header leaves its last optional cells not given
        text = row[index].strip() if index < len(row) else ""
        if not text:
            continue
        parse = _OPTIONAL_PARSERS[name]
        try:
            values[name] = parse(text)
        except ValueError:
            kind = "an integer" if parse is int else "a number"
            raise ValueError(f"{name}={text!r} is not {kind}") from None
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


def write_replay_csv(
    path: str | os.PathLike[str],
    reports: Iterable[VehicleReport],
    *,
    extra_columns: Sequence[str] = (),
) -> Path:
    """Write reports as a replay CSV.

    The header is :data:`REPLAY_COLUMNS` followed by ``extra_columns``. ``t`` is written
    exactly (shortest round-trip repr), lat/lon with 8 decimals (about 1 mm), speed with
    3 and course with 2; optional columns as the report has them, empty where None.

    Parameters
    ----------
    path : str or path-like
    reports : iterable of VehicleReport
    extra_columns : sequence of str
        Optional columns to append, any of :data:`REPLAY_OPTIONAL_COLUMNS`, in the order
        given.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ValueError
        An unknown extra column, or one given twice.
    """
    extras = tuple(extra_columns)
    unknown = [c for c in extras if c not in _OPTIONAL_PARSERS]
    if unknown:
        raise ValueError(f"unknown CSV column(s) {unknown}; choose from {REPLAY_OPTIONAL_COLUMNS}")
    if len(set(extras)) != len(extras):
        raise ValueError(f"a CSV column is given twice in {list(extras)}")
    p = Path(path)
    with p.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow([*REPLAY_COLUMNS, *extras])
        for r in reports:
            row = [
                r.vehicle_id,
                repr(r.t),
                f"{r.lat:.8f}",
                f"{r.lon:.8f}",
                f"{r.speed_mps:.3f}",
                f"{r.course_deg:.2f}",
            ]
            for c in extras:
                value = getattr(r, c)
                row.append("" if value is None else str(value))
            w.writerow(row)
    return p
