"""Recorded logs in the project's one replay format, and its only reader and writer.

A replay CSV has a header line. It starts with the required columns
``vehicle_id,t,lat,lon,speed_mps,course_deg`` (:data:`REPLAY_COLUMNS`, in this order).
Any of the optional columns ``braking``, ``length_m``, ``antenna_offset_m``, ``seq``,
``hdop``, ``fix_quality`` and ``odometer_m`` (:data:`REPLAY_OPTIONAL_COLUMNS`) may follow,
in any order; the reader puts them into the reports, and an empty cell means "not given"
(the report's default: ``braking="none"``, the others None). Other columns after the
required ones are ignored; an optional column named twice in the header is an error.
Units are those of :class:`~antikol.report.VehicleReport` (s, degrees, m/s, metres).
Numbers are plain ASCII decimals (``-12``, ``0.5``, ``1e3``; spaces around are ignored):
``1_0``, digits of other scripts or other white space are bad values, not 10.

The reader decodes the file line by line (:func:`iter_replay_csv`): a line that is not
UTF-8, not a CSV row, too short or holds a bad value is rejected with its line number and
the lines around it are read as usual; every data line is either a report or a
:class:`RowProblem`. A log too large to hold is scanned once (:func:`scan_replay_csv`) and
streamed in time order (:func:`stream_replay_csv`).

Recorded logs may also be a directory of per-vehicle NMEA logs (:func:`read_nmea_logs`).
"""

from __future__ import annotations

import csv
import logging
import math
import os
import re
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO, Final

from antikol.errors import InputFileError, InvalidReportError, ReplayError
from antikol.ingest.compressed import logical_stem, open_input, stream_problem
from antikol.ingest.spill import external_sort
from antikol.report import VehicleReport

__all__ = [
    "MAX_LINE_BYTES",
    "REPLAY_COLUMNS",
    "REPLAY_OPTIONAL_COLUMNS",
    "CsvScan",
    "ReplayLog",
    "RowProblem",
    "iter_replay_csv",
    "read_nmea_logs",
    "read_replay_csv",
    "scan_replay_csv",
    "stream_replay_csv",
    "write_replay_csv",
]

logger = logging.getLogger(__name__)

#: The required columns of a replay CSV, in order.
REPLAY_COLUMNS: Final = ("vehicle_id", "t", "lat", "lon", "speed_mps", "course_deg")
# Numbers are plain ASCII decimals: float() and int() alone would also read '1_0' as 10,
# digits of other scripts ('١٢' as 12) and Unicode spaces, which no writer of the format
# emits and which would turn a damaged cell into a wrong value. The words nan and inf are
# read so that the report refuses them naming the field, as it always did.
_FLOAT_SYNTAX: Final = re.compile(
    r"[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|nan|inf(?:inity)?)",
    re.ASCII | re.IGNORECASE,
)
_INT_SYNTAX: Final = re.compile(r"[+-]?[0-9]+")
# spaces around a cell are tolerated (hand-edited logs); other white space is not
_CELL_SPACE: Final = " \t"


def _plain_float(text: str) -> float:
    """``float(text)`` of a cell in plain decimal syntax; ValueError for anything else."""
    cell = text.strip(_CELL_SPACE)
    if _FLOAT_SYNTAX.fullmatch(cell) is None:
        raise ValueError(f"not a plain decimal number: {cell!r}")
    return float(cell)


def _plain_int(text: str) -> int:
    """``int(text)`` of a cell of plain decimal digits; ValueError for anything else."""
    cell = text.strip(_CELL_SPACE)
    if _INT_SYNTAX.fullmatch(cell) is None:
        raise ValueError(f"not a plain decimal integer: {cell!r}")
    return int(cell)  # ValueError too beyond Python's 4300 digits


# How the reader turns a non-empty cell of each optional column into a report field.
_OPTIONAL_PARSERS: Final[dict[str, Callable[[str], Any]]] = {
    "braking": str,
    "length_m": _plain_float,
    "antenna_offset_m": _plain_float,
    "seq": _plain_int,
    "hdop": _plain_float,
    "fix_quality": _plain_int,
    "odometer_m": _plain_float,
}
#: The optional columns that may follow the required ones, in any order.
REPLAY_OPTIONAL_COLUMNS: Final = tuple(_OPTIONAL_PARSERS)
#: A line longer than this is rejected without being held in memory, bytes.
MAX_LINE_BYTES: Final = 1 << 20
_CHUNK_BYTES: Final = 1 << 16
_BOM: Final = b"\xef\xbb\xbf"
# distinct vehicles counted by a scan before it stops collecting ids
_MAX_VEHICLES: Final = 100_000


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
    code : str
        The kind of problem, for counts by reason (``not UTF-8``, ``CSV syntax``,
        ``too few fields``, ``lat not a number``, ``invalid speed_mps``...); empty when the
        reader gives none (:attr:`category` then says ``invalid record``).
    """

    line: int
    reason: str
    source: str = ""
    kept: bool = False
    code: str = ""

    @property
    def category(self) -> str:
        """The kind of problem (:attr:`code`, or ``invalid record``)."""
        return self.code or "invalid record"

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
    rows : int or None
        Records read (replay CSV: data lines, blank lines not counted), when the reader
        counts them: ``rows == len(reports) + rejected``.
    """

    reports: list[VehicleReport]
    problems: list[RowProblem] = field(default_factory=list)
    source: str = ""
    ignored: dict[str, int] = field(default_factory=dict)
    rows: int | None = None

    @property
    def rejected(self) -> int:
        """Records dropped because they were bad."""
        return sum(not p.kept for p in self.problems)

    def rejected_by_reason(self) -> dict[str, int]:
        """Dropped records per kind of problem (:attr:`RowProblem.category`)."""
        return dict(Counter(p.category for p in self.problems if not p.kept))


# --------------------------------------------------------------------------- CSV reading
class _RowError(ValueError):
    """A data line that is not a report: ``code`` names the kind, the message the detail."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(message)
        self.code = code


def iter_replay_csv(
    path: str | os.PathLike[str], *, strict: bool = False
) -> Iterator[VehicleReport | RowProblem]:
    """Every data line of a replay CSV, in file order: its report, or why it has none.

    The file is streamed (constant memory) and decoded line by line: a line that is not
    UTF-8, has a quote that does not close, too few fields or a bad value is a
    :class:`RowProblem` with its line number; the lines around it are unaffected. Blank
    lines yield nothing. A log compressed with gzip, bzip2, xz or zstd is read as its content
    (:mod:`antikol.ingest.compressed`); one cut short ends in a :class:`RowProblem` after
    its last line.

    Parameters
    ----------
    path : path-like
        A replay CSV (see the module notes).
    strict : bool
        Raise :class:`~antikol.errors.ReplayError` at the first bad line instead.

    Yields
    ------
    VehicleReport or RowProblem

    Raises
    ------
    InputFileError
        The file is missing or unreadable.
    ReplayError
        The header is wrong (not UTF-8, required columns missing or out of order, an
        optional column named twice), or a line is bad in strict mode.
    """
    p = Path(path)
    number = 0
    with open_input(p, what="replay log") as fh:
        lines = _physical_lines(fh, p)
        optional: dict[str, int] | None = None
        for number, raw in lines:
            if optional is None:  # the header, after any blank lines
                optional = _header(raw, number, p)
                continue
            try:
                row = _split(raw)
                if row is None:
                    continue
                report = _row_report(row, optional)
            except _RowError as exc:
                if strict:
                    raise ReplayError(f"{p}:{number}: {exc}") from None
                logger.debug("%s:%d: skipped (%s)", p, number, exc)
                yield RowProblem(number, str(exc), code=exc.code)
                continue
            yield report
        cut = stream_problem(fh)
        if cut is not None:  # a compressed log cut short: the lines before it stand
            if strict or optional is None:
                raise ReplayError(f"{p}:{number + 1}: {cut}")
            yield RowProblem(number + 1, cut, code="compressed stream cut")
        if optional is None:
            raise ReplayError(f"{p}: empty file (expected a header line)")


def read_replay_csv(path: str | os.PathLike[str], *, strict: bool = False) -> ReplayLog:
    """Read a replay CSV log into memory (see :func:`iter_replay_csv` to stream one).

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
        Valid reports in file order and the bad rows (line number and reason);
        ``rows`` counts the data lines read.

    Raises
    ------
    InputFileError
        The file is missing or unreadable.
    ReplayError
        The header is wrong (not UTF-8, required columns missing or out of order, an
        optional column named twice), or a row is bad in strict mode.
    """
    log = ReplayLog([], [], str(path), rows=0)
    for item in iter_replay_csv(path, strict=strict):
        if isinstance(item, RowProblem):
            log.problems.append(item)
        else:
            log.reports.append(item)
    log.rows = len(log.reports) + len(log.problems)
    return log


def _physical_lines(fh: BinaryIO, path: Path) -> Iterator[tuple[int, bytes | None]]:
    """(line number, bytes without the line end) of a binary file; None for a line longer
    than :data:`MAX_LINE_BYTES` (skipped without holding it). Lines end in LF, CRLF or CR."""
    number = 0
    pending = b""
    too_long = False
    while True:
        try:
            chunk = fh.read(_CHUNK_BYTES)
        except OSError as exc:
            raise InputFileError(f"{path}: cannot read: {exc.strerror or exc}") from exc
        if not chunk:
            break
        data = pending + chunk
        hold = b""
        if data.endswith(b"\r"):  # maybe the first half of a CRLF split between chunks
            data, hold = data[:-1], b"\r"
        if b"\r" in data:
            data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
        parts = data.split(b"\n")
        pending = parts.pop() + hold
        for part in parts:
            number += 1
            yield number, None if too_long or len(part) > MAX_LINE_BYTES else part
            too_long = False
        if len(pending) > MAX_LINE_BYTES:
            too_long, pending = True, b""
    rest = pending[:-1] if pending.endswith(b"\r") else pending
    if rest or too_long:
        yield number + 1, None if too_long else rest


def _decode(raw: bytes | None) -> str:
    if raw is None:
        raise _RowError("line too long", f"a line longer than {MAX_LINE_BYTES} bytes")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _RowError(
            "not UTF-8",
            f"not UTF-8 text: byte 0x{raw[exc.start]:02x} at column {exc.start + 1}",
        ) from None


def _split(raw: bytes | None) -> list[str] | None:
    """The fields of one line, or None for a blank line."""
    text = _decode(raw)
    if '"' in text or "\x00" in text:
        try:
            rows = list(csv.reader([text], strict=True))
        except csv.Error as exc:
            raise _RowError("CSV syntax", f"not a CSV row: {exc}") from None
        row = rows[0] if rows else []
    else:
        row = text.split(",")
    if all(not c.strip() for c in row):
        return None
    return row


def _header(raw: bytes | None, number: int, path: Path) -> dict[str, int] | None:
    """The optional columns of the header line (None for a blank line before it)."""
    if number == 1 and raw is not None and raw.startswith(_BOM):
        raw = raw[len(_BOM) :]
    try:
        row = _split(raw)
    except _RowError as exc:
        raise ReplayError(f"{path}:{number}: unreadable header: {exc}") from None
    if row is None:
        return None
    header = [h.strip() for h in row]
    if tuple(header[: len(REPLAY_COLUMNS)]) != REPLAY_COLUMNS:
        shown = ",".join(header)
        shown = shown if len(shown) <= 120 else shown[:117] + "..."
        raise ReplayError(
            f"{path}:{number}: header must start with {','.join(REPLAY_COLUMNS)}; got {shown}"
        )
    return _optional_columns(header, path)


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
        raise _RowError(
            "too few fields", f"{len(row)} fields, expected at least {len(REPLAY_COLUMNS)}"
        )
    values: dict[str, Any] = {"vehicle_id": row[0].strip()}
    for name, text in zip(REPLAY_COLUMNS[1:], row[1:6], strict=True):
        try:
            values[name] = _plain_float(text)
        except ValueError:
            raise _RowError(
                f"{name} not a number",
                f"{name}={_short(text)} is not a number (plain ASCII decimal)",
            ) from None
    for name, index in optional.items():
        # a row shorter than the header leaves its last optional cells not given
        text = row[index].strip(_CELL_SPACE) if index < len(row) else ""
        if not text:
            continue
        parse = _OPTIONAL_PARSERS[name]
        try:
            values[name] = parse(text)
        except ValueError:
            kind = "an integer" if parse is _plain_int else "a number"
            raise _RowError(
                f"{name} not {kind}", f"{name}={_short(text)} is not {kind} (plain ASCII decimal)"
            ) from None
    try:
        return VehicleReport(**values)
    except InvalidReportError as exc:
        raise _RowError(f"invalid {exc.field}", str(exc)) from None


def _short(text: str, limit: int = 40) -> str:
    shown = repr(text)
    return shown if len(shown) <= limit else shown[: limit - 3] + "..."


# --------------------------------------------------------------------------- streaming
@dataclass
class CsvScan:
    """What one pass over a replay CSV found, in constant memory (:func:`scan_replay_csv`).

    Attributes
    ----------
    source : str
    rows : int
        Data lines read (blank lines not counted): ``rows == valid + rejected``.
    valid : int
        Lines that are reports.
    rejected_by_reason : dict of str to int
        Bad lines per kind of problem (:attr:`RowProblem.category`).
    problems : list of RowProblem
        The first ``keep_problems`` bad lines.
    in_time_order : bool
        The reports' times never decrease in file order (the log streams as it is).
    vehicles : int
        Distinct vehicle ids among the reports.
    """

    source: str
    rows: int = 0
    valid: int = 0
    rejected_by_reason: dict[str, int] = field(default_factory=dict)
    problems: list[RowProblem] = field(default_factory=list)
    in_time_order: bool = True
    vehicles: int = 0

    @property
    def rejected(self) -> int:
        """Bad lines, all reasons."""
        return sum(self.rejected_by_reason.values())


def scan_replay_csv(
    path: str | os.PathLike[str],
    *,
    strict: bool = False,
    keep_problems: int = 1000,
    on_problem: Callable[[RowProblem], None] | None = None,
) -> CsvScan:
    """Read a replay CSV once without keeping it: counts, problems, time order.

    Parameters
    ----------
    path : path-like
    strict : bool
        Raise :class:`~antikol.errors.ReplayError` at the first bad line.
    keep_problems : int
        How many bad lines :attr:`CsvScan.problems` keeps (all are counted).
    on_problem : callable, optional
        Called with every bad line (e.g. to write them all to a file).

    Returns
    -------
    CsvScan

    Raises
    ------
    InputFileError, ReplayError
        As :func:`iter_replay_csv`.
    """
    scan = CsvScan(str(path))
    reasons: Counter[str] = Counter()
    vehicles: set[str] = set()
    last_t = -math.inf
    for item in iter_replay_csv(path, strict=strict):
        scan.rows += 1
        if isinstance(item, RowProblem):
            reasons[item.category] += 1
            if len(scan.problems) < keep_problems:
                scan.problems.append(item)
            if on_problem is not None:
                on_problem(item)
            continue
        scan.valid += 1
        if len(vehicles) <= _MAX_VEHICLES:
            vehicles.add(item.vehicle_id)
        if item.t < last_t:
            scan.in_time_order = False
        last_t = max(last_t, item.t)
    scan.rejected_by_reason = dict(reasons)
    scan.vehicles = len(vehicles)
    return scan


def stream_replay_csv(
    path: str | os.PathLike[str], *, in_time_order: bool, run_size: int = 200_000
) -> Iterator[VehicleReport]:
    """The reports of a replay CSV in time order (then file order), in bounded memory.

    Parameters
    ----------
    path : path-like
    in_time_order : bool
        The file is known to be in time order (:attr:`CsvScan.in_time_order`): its
        reports stream as they are. Otherwise they are sorted in runs of ``run_size``
        written to temporary files and merged (memory for one run).
    run_size : int
        Reports per sorted run.

    Yields
    ------
    VehicleReport
    """
    reports = (r for r in iter_replay_csv(path) if isinstance(r, VehicleReport))
    if in_time_order:
        yield from reports
        return
    yield from external_sort(reports, key=_report_time, run_size=run_size)


def _report_time(r: VehicleReport) -> float:
    return r.t


# --------------------------------------------------------------------------- NMEA
def read_nmea_logs(path: str | os.PathLike[str]) -> ReplayLog:
    """Read a directory of per-vehicle NMEA logs (``<vehicle_id>.nmea``...) as one log.

    Files named ``*.nmea``, ``*.txt`` or ``*.log`` are read (not recursively), each possibly
    compressed with gzip, bzip2, xz or zstd (``t1.nmea.gz``; a log cut short keeps its sentences
    before the cut, and the cut is a problem of the file, also when no sentence came
    before it); each file's name without its suffixes is the vehicle id. An intact file
    in which no line holds an NMEA sentence (no ``$``: a ``README.txt``, notes) is not a
    vehicle's log: it is counted in :attr:`ReplayLog.ignored` under its name. Skipped
    sentences are reported per file.

    Raises
    ------
    InputFileError
        ``path`` is not a readable directory, holds no NMEA log (the message names the
        first files that could not be used, and why), or holds two logs of one vehicle
        (``t1.nmea`` and ``t1.log``).
    """
    from antikol.ingest.nmea import FILE_SUFFIXES, list_nmea_files, read_nmea_file

    directory = Path(path)
    files = list_nmea_files(directory)
    log = ReplayLog([], [], str(path))
    by_vehicle: dict[str, Path] = {}
    for file in files:
        try:
            reports, stats = read_nmea_file(file)
        except InvalidReportError as exc:
            log.problems.append(
                RowProblem(0, f"the file name is not a vehicle id: {exc}", str(file), code="file")
            )
            continue
        if not stats.used and set(stats.skipped) <= {"not_nmea", "empty", "too_long"}:
            if stats.cut is not None:  # damaged before any sentence: not a README
                log.problems.append(
                    RowProblem(
                        0,
                        f"no NMEA sentence before the damage: {stats.cut}",
                        str(file),
                        code="compressed stream cut",
                    )
                )
                continue
            reason = f"not an NMEA log (no sentence in {stats.lines} line(s)): {file.name}"
            log.ignored[reason] = log.ignored.get(reason, 0) + 1
            continue
        vehicle = logical_stem(file)
        if vehicle in by_vehicle:
            raise InputFileError(
                f"two files for vehicle {vehicle!r}: {by_vehicle[vehicle].name!r} and "
                f"{file.name!r} in {str(directory)!r}"
            )
        by_vehicle[vehicle] = file
        log.reports.extend(reports)
        if stats.total_skipped:
            log.problems.append(
                RowProblem(
                    0,
                    f"{vehicle}: {stats.total_skipped} NMEA sentence(s) skipped "
                    f"({dict(stats.skipped)})",
                    str(file),
                    code="NMEA sentences skipped",
                )
            )
        if stats.cut is not None:  # the sentences before the cut are read all the same
            log.problems.append(
                RowProblem(0, f"{vehicle}: {stats.cut}", str(file), code="compressed stream cut")
            )
    if not by_vehicle:
        # the problems (damaged files, bad names) are why, and would be lost with the log
        why = "".join(f"; {Path(p.source).name}: {p.reason}" for p in log.problems[:3])
        raise InputFileError(
            f"no NMEA logs ({', '.join('*' + s for s in FILE_SUFFIXES)} files with NMEA "
            f"sentences) in {str(directory)!r}{why}"
        )
    log.reports.sort(key=lambda r: (r.t, r.vehicle_id))
    return log


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
