"""GTFS-realtime VehiclePositions feeds: protobuf ``FeedMessage`` files.

A GTFS-realtime feed is fetched as one ``FeedMessage`` snapshot at a time; a recording is
a directory of such files (or a single one). Each ``FeedEntity`` with a ``vehicle``
(``VehiclePosition``) becomes a report:

==========================  ========================================================
``vehicle.vehicle.id``      vehicle id (else ``label``, else the entity id)
``vehicle.timestamp``       time, POSIX seconds (else the header's timestamp; 0, the
                            protobuf default, is no time)
``position.latitude``,      WGS84 degrees
``position.longitude``
``position.speed``          speed, m/s (missing: derived from the previous position)
``position.bearing``        course, degrees from north (missing: derived or kept)
``position.odometer``       odometer, metres — the report's ``odometer_m``
==========================  ========================================================

Files are read in name order; repeated snapshots of an unchanged vehicle (same timestamp)
are counted as ignored. A file that is not a ``FeedMessage`` (an empty file is none either:
a fetch that failed) and every unusable entity are reported with the file and the entity
number (:class:`~antikol.ingest.replaylog.RowProblem`), never fatal. Decoding uses Google's
``gtfs-realtime-bindings`` (``pip install 'antikol[feeds]'``).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, Final

from antikol.errors import InputFileError
from antikol.ingest.compressed import logical_suffix, read_input
from antikol.ingest.feed_common import (
    FeedCollector,
    FeedRecord,
    record_order,
    speed_unit_factor,
    time_problem,
)
from antikol.ingest.replaylog import ReplayLog

__all__ = [
    "GTFS_RT_SUFFIXES",
    "feed_message",
    "gtfs_realtime_files",
    "iter_gtfs_realtime_records",
    "read_gtfs_realtime",
    "write_feed_message",
]

#: File name suffixes taken for GTFS-realtime files in a directory.
GTFS_RT_SUFFIXES: Final = (".pb", ".pbf", ".bin", ".gtfsrt", ".proto")


def _bindings() -> Any:
    try:
        from google.transit import gtfs_realtime_pb2
    except ImportError as exc:  # pragma: no cover - the extra is installed in tests
        raise InputFileError(
            "reading GTFS-realtime needs the gtfs-realtime-bindings package "
            "(pip install 'antikol[feeds]')"
        ) from exc
    return gtfs_realtime_pb2


def feed_message(data: bytes) -> Any:
    """Decode a ``FeedMessage`` (raises ``google.protobuf.message.DecodeError``)."""
    msg = _bindings().FeedMessage()
    msg.ParseFromString(data)
    return msg


def write_feed_message(
    path: str | os.PathLike[str],
    vehicles: Iterable[dict[str, Any]],
    *,
    timestamp: int | None = None,
) -> Path:
    """Write one ``FeedMessage`` of vehicle positions (for tests and recordings).

    Parameters
    ----------
    path : path-like
    vehicles : iterable of dict
        Each with ``id`` and any of ``label``, ``timestamp`` (POSIX s), ``lat``, ``lon``,
        ``speed`` (m/s), ``bearing`` (degrees), ``odometer`` (m), ``route_id``.
    timestamp : int, optional
        The header's timestamp, POSIX seconds.

    Returns
    -------
    pathlib.Path
    """
    pb = _bindings()
    msg = pb.FeedMessage()
    msg.header.gtfs_realtime_version = "2.0"
    msg.header.incrementality = pb.FeedHeader.FULL_DATASET
    if timestamp is not None:
        msg.header.timestamp = int(timestamp)
    for k, v in enumerate(vehicles):
        ent = msg.entity.add()
        ent.id = str(v.get("entity_id", k + 1))
        vp = ent.vehicle
        if "id" in v:
            vp.vehicle.id = str(v["id"])
        if "label" in v:
            vp.vehicle.label = str(v["label"])
        if "route_id" in v:
            vp.trip.route_id = str(v["route_id"])
        if "timestamp" in v:
            vp.timestamp = int(v["timestamp"])
        if "lat" in v or "lon" in v:
            vp.position.latitude = float(v.get("lat", 0.0))
            vp.position.longitude = float(v.get("lon", 0.0))
            for name in ("speed", "bearing", "odometer"):
                if name in v:
                    setattr(vp.position, name, float(v[name]))
    p = Path(path)
    p.write_bytes(msg.SerializeToString())
    return p


def _entity_record(ent: Any, header_t: int | None, number: int, source: str) -> FeedRecord:
    vp = ent.vehicle
    vid = vp.vehicle.id or vp.vehicle.label or ent.id
    if not vid:
        raise ValueError("no vehicle id (vehicle.vehicle.id, label or entity id)")
    # 0 is the protobuf default, which a producer may write for a time it does not know:
    # missing, as the header's 0 is
    if vp.timestamp:
        name, stamp = "vehicle.timestamp", int(vp.timestamp)
    elif header_t:
        name, stamp = "header.timestamp", header_t
    else:
        raise ValueError("no timestamp (vehicle.timestamp or header.timestamp)")
    t = float(stamp)
    why = time_problem(t)
    if why is not None:
        raise ValueError(f"{name}={stamp}: {why}")
    if not vp.HasField("position"):
        raise ValueError("no position (vehicle.position)")
    pos = vp.position
    for name in ("latitude", "longitude"):
        if not pos.HasField(name):  # required in the schema, yet partial feeds exist
            raise ValueError(f"no position.{name}")
    return FeedRecord(
        record=number,
        source=source,
        vehicle_id=vid,
        t=t,
        lat=float(pos.latitude),
        lon=float(pos.longitude),
        speed_mps=float(pos.speed) if pos.HasField("speed") else None,
        course_deg=float(pos.bearing) if pos.HasField("bearing") else None,
        odometer_m=float(pos.odometer) if pos.HasField("odometer") else None,
    )


def read_gtfs_realtime(
    path: str | os.PathLike[str], *, strict: bool = False, speed_unit: str = "m/s"
) -> ReplayLog:
    """Read a GTFS-realtime VehiclePositions recording: one feed file or a directory.

    Parameters
    ----------
    path : path-like
        A ``FeedMessage`` file, or a directory of them (files with a suffix of
        :data:`GTFS_RT_SUFFIXES`, read in name order); each may be compressed with gzip,
        bzip2 or xz (``.pb.gz``; :mod:`antikol.ingest.compressed`).
    strict : bool
        Raise :class:`~antikol.errors.ReplayError` at the first bad file or entity.
    speed_unit : {"m/s", "km/h", "kn", "mph"}, keyword-only
        Unit of ``position.speed`` (default m/s, as the specification says; some producers
        send km/h; :data:`~antikol.ingest.feed_common.SPEED_UNITS`).

    Returns
    -------
    ReplayLog
        Reports in time order (``t`` in POSIX seconds); bad files (record 0) and
        entities (1-based entity number) with the file and reason; ignored counts
        (entities without a vehicle position, repeated snapshots).

    Raises
    ------
    InvalidArgumentError
        An unknown ``speed_unit``.
    InputFileError
        The path is missing, an empty directory, or the bindings are not installed.
    """
    out = FeedCollector(str(Path(path)), strict=strict, speed_factor=speed_unit_factor(speed_unit))
    files = gtfs_realtime_files(path)
    # (sorted in memory: the reports are held all the same; StreamedFeed sorts on disk)
    for rec in sorted(iter_gtfs_realtime_records(files, out), key=record_order):
        out.add(rec)
    return out.log()


def gtfs_realtime_files(path: str | os.PathLike[str]) -> list[Path]:
    """The feed files of a GTFS-realtime recording: the file itself, or a directory's files
    with a suffix of :data:`GTFS_RT_SUFFIXES` in name order.

    Raises
    ------
    InputFileError
        The path is missing, a directory without such files, or the GTFS-realtime
        bindings are not installed.
    """
    p = Path(path)
    if p.is_dir():
        files = sorted(f for f in p.iterdir() if logical_suffix(f) in GTFS_RT_SUFFIXES)
        if not files:
            raise InputFileError(
                f"{p}: no GTFS-realtime files ({', '.join(GTFS_RT_SUFFIXES)}) in the directory"
            )
    elif p.is_file():
        files = [p]
    else:
        raise InputFileError(f"{p}: no such file or directory")
    _bindings()
    return files


def iter_gtfs_realtime_records(
    files: Iterable[Path], collector: FeedCollector
) -> Iterator[FeedRecord]:
    """The vehicle positions of GTFS-realtime feed files, file by file (each file is read
    whole: one snapshot), not yet checked as reports.

    Parameters
    ----------
    files : iterable of Path
        :func:`gtfs_realtime_files`.
    collector : FeedCollector
        Gets the problems of the files and entities that give no record, and the counts of
        ignored entities; its ``strict`` applies.

    Yields
    ------
    FeedRecord
    """
    from google.protobuf.message import DecodeError

    out = collector
    for f in files:
        try:
            decoded = read_input(f, what="GTFS-realtime file")
            if decoded.problem is not None:  # a cut snapshot is no snapshot
                out.problem(0, str(f), decoded.problem)
                continue
            if not decoded.data:  # (would decode as a FeedMessage without a header)
                out.problem(0, str(f), "empty file: not a GTFS-realtime FeedMessage")
                continue
            msg = feed_message(decoded.data)
        except OSError as exc:
            out.problem(0, str(f), f"unreadable: {exc}")
            continue
        except DecodeError as exc:
            out.problem(0, str(f), f"not a GTFS-realtime FeedMessage: {exc}")
            continue
        header_t = int(msg.header.timestamp) if msg.header.HasField("timestamp") else None
        for number, ent in enumerate(msg.entity, start=1):
            if not ent.HasField("vehicle"):
                out.ignore("GTFS-realtime entity without a vehicle position")
                continue
            try:
                rec = _entity_record(ent, header_t, number, str(f))
            except ValueError as exc:
                out.problem(number, str(f), f"entity {ent.id or number}: {exc}")
            else:
                yield rec
