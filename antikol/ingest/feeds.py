"""Recorded logs of any supported format, recognised by name and content.

=============  ============================================================================
format         what it is
=============  ============================================================================
``csv``        the project's replay CSV (:mod:`antikol.ingest.replaylog`)
``nmea``       a directory of per-vehicle NMEA logs
``hfp``        HSL-style high-frequency positioning, JSON lines / array or CSV
               (:mod:`antikol.ingest.hfp`)
``gtfs-rt``    GTFS-realtime VehiclePositions, a ``FeedMessage`` file or a directory of
               them (:mod:`antikol.ingest.gtfsrt`)
=============  ============================================================================

:func:`detect_log_format` looks at the suffix and the first bytes; :func:`read_log` reads
any of them into a :class:`~antikol.ingest.replaylog.ReplayLog`. Every file of any format
may be compressed with gzip, bzip2, xz or zstd (:mod:`antikol.ingest.compressed`):
``positions.csv.gz`` is recognised and read as ``positions.csv``, ``t1.nmea.gz`` as the
NMEA log of ``t1``.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable
from pathlib import Path
from typing import Final, Literal

from antikol.errors import InputFileError, InvalidArgumentError
from antikol.ingest.compressed import logical_suffix, read_head
from antikol.ingest.feed_common import speed_unit_factor
from antikol.ingest.gtfsrt import GTFS_RT_SUFFIXES, read_gtfs_realtime
from antikol.ingest.hfp import looks_like_hfp_csv, read_hfp
from antikol.ingest.replaylog import (
    REPLAY_COLUMNS,
    ReplayLog,
    read_nmea_logs,
    read_replay_csv,
)

__all__ = ["LOG_FORMATS", "LogFormat", "detect_log_format", "read_log"]

LogFormat = Literal["csv", "nmea", "hfp", "gtfs-rt"]
#: The formats :func:`read_log` reads.
LOG_FORMATS: Final[tuple[LogFormat, ...]] = ("csv", "nmea", "hfp", "gtfs-rt")
_JSON_SUFFIXES: Final = (".json", ".jsonl", ".ndjson", ".hfp")


#: An MQTT dump line with the time of reception before the topic (HSL's dumps).
_TIMED_MQTT_LINE: Final = re.compile(r"[^\s/]+\s+/hfp/")


def detect_log_format(path: str | os.PathLike[str]) -> LogFormat:
    """The format of a recorded log, from its name and first bytes.

    Parameters
    ----------
    path : path-like
        A file, or a directory of NMEA logs or GTFS-realtime files.

    Returns
    -------
    {"csv", "nmea", "hfp", "gtfs-rt"}

    Raises
    ------
    InputFileError
        Missing, or not recognisable (the message says what was seen).
    """
    p = Path(path)
    if p.is_dir():
        names = [logical_suffix(f) for f in p.iterdir() if f.is_file()]
        if any(s in GTFS_RT_SUFFIXES for s in names):
            return "gtfs-rt"
        if any(s == ".nmea" for s in names) or not names:
            return "nmea"
        raise InputFileError(
            f"{p}: a directory with neither NMEA logs (.nmea) nor GTFS-realtime files "
            f"({', '.join(GTFS_RT_SUFFIXES)}); use --format"
        )
    if not p.is_file():
        raise InputFileError(f"{p}: no such file or directory")
    suffix = logical_suffix(p)  # a compressed log is named by its content's suffix
    if suffix in GTFS_RT_SUFFIXES:
        return "gtfs-rt"
    if suffix in _JSON_SUFFIXES:
        return "hfp"
    head = read_head(p, what="log")
    # the first line decides; a bad byte further on (a text log with one Latin-1 byte)
    # must not make the file look binary
    text = head.decode("utf-8-sig", errors="replace")
    first = text.lstrip().split("\n", 1)[0].strip()
    header = [h.strip() for h in first.split(",")]
    if tuple(header[: len(REPLAY_COLUMNS)]) == REPLAY_COLUMNS:
        return "csv"
    if looks_like_hfp_csv(header):
        return "hfp"
    try:
        head.decode("utf-8-sig")
    except UnicodeDecodeError:
        if suffix != ".csv":
            return "gtfs-rt"  # binary: a protobuf message
    if first.startswith(("{", "[", "/hfp")) or _TIMED_MQTT_LINE.match(first):
        return "hfp"
    if suffix == ".csv":
        return "csv"  # let the replay reader say what is wrong with the header
    raise InputFileError(
        f"{p}: not a recognised log (replay CSV, HFP JSON/CSV, GTFS-realtime); "
        f"first line {first[:60]!r}; use --format"
    )


def read_log(
    path: str | os.PathLike[str],
    *,
    log_format: str = "auto",
    strict: bool = False,
    speed_unit: str = "m/s",
    hfp_modes: Iterable[str] | None = None,
) -> ReplayLog:
    """Read a recorded log of any supported format.

    Parameters
    ----------
    path : path-like
    log_format : {"auto", "csv", "nmea", "hfp", "gtfs-rt"}
        ``auto`` detects it (:func:`detect_log_format`).
    strict : bool
        Stop at the first bad record (NMEA logs: ignored).
    speed_unit : {"m/s", "km/h", "kn", "mph"}
        Unit of the speed field of an HFP or GTFS-realtime log (a replay CSV's is m/s by
        its column's name, NMEA's by its sentences).
    hfp_modes : iterable of str, optional
        Transport modes read from an HFP log (``{"tram"}``: :func:`~antikol.ingest.hfp.read_hfp`'s
        ``modes``); None reads every mode.

    Returns
    -------
    ReplayLog

    Raises
    ------
    ValueError
        An unknown format name.
    InvalidArgumentError
        An unknown ``speed_unit``, or one other than m/s for a log whose unit is fixed;
        ``hfp_modes`` for a log that is not HFP.
    InputFileError, ReplayError
        As the format's reader raises them.
    """
    fmt = detect_log_format(path) if log_format == "auto" else log_format
    if speed_unit_factor(speed_unit) != 1.0 and fmt in ("csv", "nmea"):
        raise InvalidArgumentError(
            "speed_unit", speed_unit, f"a {fmt} log's speeds are in m/s or say their unit"
        )
    if hfp_modes is not None and fmt != "hfp":
        raise InvalidArgumentError("hfp_modes", hfp_modes, f"{path} is a {fmt} log, not HFP")
    if fmt == "csv":
        return read_replay_csv(path, strict=strict)
    if fmt == "nmea":
        return read_nmea_logs(path)
    if fmt == "hfp":
        return read_hfp(path, strict=strict, speed_unit=speed_unit, modes=hfp_modes)
    if fmt == "gtfs-rt":
        return read_gtfs_realtime(path, strict=strict, speed_unit=speed_unit)
    raise ValueError(
        f"unknown log format {log_format!r}; choose from auto, {', '.join(LOG_FORMATS)}"
    )
