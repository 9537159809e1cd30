"""An operator's archive as partitions: finding them, reading one, and the working copy.

An archive is one file, a list of files or a directory of them: Parquet files with the
replay columns (``vehicle_id, t, lat, lon, speed_mps, course_deg`` and any of the optional
ones), replay CSVs, HSL HFP logs or GTFS-realtime feed files. Every file is one partition.
Each partition is read once into the **working copy**: a Parquet file of valid reports
sorted by vehicle and time (so that the positioning stage reads one vehicle's rows
through row-group statistics), with the partition's counts of rejected records.

pyarrow is imported lazily: on-board use never needs it.
"""

from __future__ import annotations

import logging
import math
import os
from collections import Counter
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from antikol.errors import InputFileError, InvalidReportError
from antikol.ingest.replaylog import REPLAY_COLUMNS, ReplayLog
from antikol.report import VehicleReport

__all__ = [
    "REPORT_FIELDS",
    "PartitionData",
    "find_partitions",
    "read_partition",
    "read_working_copy",
    "write_parquet_archive",
    "write_working_copy",
]

logger = logging.getLogger(__name__)

#: Report fields kept in the working copy (scalars; ``route`` and ``track_position`` are
#: not carried: the archive formats have no place for them).
REPORT_FIELDS: tuple[str, ...] = (
    *REPLAY_COLUMNS,
    "braking",
    "length_m",
    "antenna_offset_m",
    "seq",
    "hdop",
    "fix_quality",
    "odometer_m",
)
_PARQUET_SUFFIXES = (".parquet", ".pq")
#: Rows per row group of the working copy (a vehicle's rows span few groups).
_ROW_GROUP = 16_384


@dataclass(frozen=True)
class PartitionData:
    """One partition read into memory.

    Attributes
    ----------
    name : str
        The partition's file.
    reports : list of VehicleReport
    rows : int or None
        Records read, when the reader counts them.
    rejected_by_reason : dict of str to int
        Records rejected as bad, by kind of problem.
    """

    name: str
    reports: list[VehicleReport]
    rows: int | None
    rejected_by_reason: dict[str, int] = field(default_factory=dict)


def find_partitions(
    paths: Sequence[str | os.PathLike[str]],
    *,
    exclude: Sequence[str | os.PathLike[str]] = (),
) -> list[Path]:
    """The partition files of an archive given as files and directories.

    A directory contributes its files (recursively, sorted by path; hidden files and
    ``_SUCCESS``-style markers skipped) — except a directory of NMEA logs, which is one
    partition. Files under a directory of ``exclude`` (a replay's output directory lying
    inside the archive) are skipped.

    Raises
    ------
    InputFileError
        A path does not exist, or nothing is found.
    """
    skipped = [Path(e).resolve() for e in exclude]

    def wanted(q: Path) -> bool:
        if not q.is_file() or q.name.startswith((".", "_")):
            return False
        r = q.resolve()
        return not any(r.is_relative_to(e) for e in skipped)

    out: list[Path] = []
    for raw in paths:
        p = Path(raw)
        if not p.exists():
            raise InputFileError(f"{p}: no such file or directory")
        if p.is_dir() and not any(q.suffix.lower() == ".nmea" for q in p.iterdir()):
            out.extend(q for q in sorted(p.rglob("*")) if wanted(q))
        else:
            out.append(p)
    if not out:
        raise InputFileError(f"no partition files in {', '.join(map(str, paths))}")
    return out


def read_partition(path: str | os.PathLike[str], *, log_format: str = "auto") -> PartitionData:
    """Read one partition (Parquet, or any log format :func:`antikol.ingest.feeds.read_log`
    reads).

    Raises
    ------
    InputFileError, ReplayError
        The file cannot be read as a log (the message names it).
    """
    p = Path(path)
    if log_format in ("auto", "parquet") and p.suffix.lower() in _PARQUET_SUFFIXES:
        return _read_parquet(p)
    if log_format == "parquet":
        raise InputFileError(f"{p}: not a Parquet file (name ends {p.suffix!r})")
    from antikol.ingest.feeds import read_log

    log: ReplayLog = read_log(p, log_format=log_format)
    return PartitionData(
        name=str(p), reports=log.reports, rows=log.rows, rejected_by_reason=log.rejected_by_reason()
    )


def _read_parquet(p: Path) -> PartitionData:
    import pyarrow.parquet as pq

    try:
        table = pq.read_table(p)
    except Exception as exc:  # pyarrow raises its own ArrowInvalid, OSError...
        raise InputFileError(f"{p}: cannot read as Parquet: {exc}") from exc
    missing = [c for c in REPLAY_COLUMNS if c not in table.column_names]
    if missing:
        raise InputFileError(f"{p}: Parquet file lacks the column(s) {', '.join(missing)}")
    columns = [c for c in REPORT_FIELDS if c in table.column_names]
    data = table.select(columns).to_pydict()
    reports: list[VehicleReport] = []
    problems: Counter[str] = Counter()
    for i in range(table.num_rows):
        values = {c: data[c][i] for c in columns}
        kwargs = {k: v for k, v in values.items() if v is not None}
        if "vehicle_id" in kwargs:
            kwargs["vehicle_id"] = str(kwargs["vehicle_id"])
        try:
            reports.append(VehicleReport(**kwargs))
        except (InvalidReportError, TypeError, ValueError) as exc:
            problems[_category(exc)] += 1
            if sum(problems.values()) <= 5:
                logger.warning("%s: row %d rejected: %s", p, i, exc)
    return PartitionData(
        name=str(p), reports=reports, rows=table.num_rows, rejected_by_reason=dict(problems)
    )


def _category(exc: Exception) -> str:
    """The reason a row was rejected, in the replay CSV reader's words (``invalid lat``,
    or ``invalid record`` when no field is named)."""
    field_name = getattr(exc, "field", None)
    return f"invalid {field_name}" if field_name else "invalid record"


def write_working_copy(reports: Iterable[VehicleReport], path: str | os.PathLike[str]) -> int:
    """Write reports as a working-copy Parquet file, sorted by vehicle then time.

    Returns
    -------
    int
        Rows written.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    rows = sorted(reports, key=lambda r: (r.vehicle_id, r.t))
    cols: dict[str, list[Any]] = {c: [getattr(r, c) for r in rows] for c in REPORT_FIELDS}
    schema = pa.schema(
        [
            ("vehicle_id", pa.string()),
            *[(c, pa.float64()) for c in ("t", "lat", "lon", "speed_mps", "course_deg")],
            ("braking", pa.string()),
            ("length_m", pa.float64()),
            ("antenna_offset_m", pa.float64()),
            ("seq", pa.int64()),
            ("hdop", pa.float64()),
            ("fix_quality", pa.int64()),
            ("odometer_m", pa.float64()),
        ]
    )
    table = pa.table(cols, schema=schema)
    pq.write_table(table, path, row_group_size=_ROW_GROUP)
    return len(rows)


def read_working_copy(
    paths: Sequence[str | os.PathLike[str]],
    *,
    vehicles: Iterable[str] | None = None,
    t_range: tuple[float, float] | None = None,
) -> list[VehicleReport]:
    """Reports from working-copy files, in time order (stable: file order, then vehicle).

    Parameters
    ----------
    paths : sequence of path-like
    vehicles : iterable of str, optional
        Only these vehicles.
    t_range : (float, float), optional
        Only ``lo < t <= hi``, s.
    """
    import pyarrow.parquet as pq

    filters: list[Any] = []
    if vehicles is not None:
        filters.append(("vehicle_id", "in", sorted(set(vehicles))))
    if t_range is not None:
        filters.extend([("t", ">", t_range[0]), ("t", "<=", t_range[1])])
    out: list[VehicleReport] = []
    for path in paths:
        table = pq.read_table(path, filters=filters or None)
        out.extend(_reports(table.to_pydict(), table.num_rows))
    out.sort(key=lambda r: (r.t, r.vehicle_id))
    return out


def _reports(data: dict[str, list[Any]], n: int) -> Iterator[VehicleReport]:
    for i in range(n):
        kwargs = {c: data[c][i] for c in REPORT_FIELDS if data[c][i] is not None}
        yield VehicleReport(**kwargs)


def write_parquet_archive(
    reports: Sequence[VehicleReport], directory: str | os.PathLike[str], *, chunk_s: float
) -> list[Path]:
    """Write reports as a partitioned Parquet archive: one file per ``chunk_s`` of time.

    For tests and benchmarks (an operator's archive written by the hour, say).

    Returns
    -------
    list of pathlib.Path
        The files, in time order.
    """
    if not chunk_s > 0:
        raise ValueError(f"chunk_s must be > 0, got {chunk_s!r}")
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    chunks: dict[int, list[VehicleReport]] = {}
    for r in reports:
        chunks.setdefault(math.floor(r.t / chunk_s), []).append(r)
    files = []
    for k in sorted(chunks):
        f = d / f"part-{k:06d}.parquet"
        write_working_copy(chunks[k], f)
        files.append(f)
    return files
