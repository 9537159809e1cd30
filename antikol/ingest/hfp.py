"""HSL-style high-frequency positioning (HFP) feeds: vehicle positions as JSON or CSV.

Helsinki Region Transport publishes every vehicle's position about once a second as MQTT
messages whose payload is a JSON object keyed by the event type, ``{"VP": {...}}`` for a
vehicle position. The fields used here (HFP v2):

=========  ===================================================================
``oper``   operator id; with ``veh`` the vehicle id ``"<oper>/<veh>"`` where the
           vehicle's owner is not given (below)
``veh``    vehicle number within the operator (a whole number or a string: ``412``,
           ``412.0`` and ``"0412"`` are the same vehicle)
``tst``    UTC time, an ISO 8601 calendar date and time of day
           (``2023-12-14T08:00:01.123Z``); ``tsi`` (Unix seconds) when ``tst`` is
           missing; either in the years 1970 to 9999
``lat``,   WGS84 degrees (null when unknown); ``latitude`` and ``longitude``
``long``   (or ``lon``) in the archives that spell them out
``spd``    speed, m/s (null: derived from the previous record)
``hdg``    heading, degrees from north (null: derived, or the last one kept)
``odo``    odometer, metres — the report's ``odometer_m``
``loc``    location source (``locationQualityMethod`` in HSL's raw dumps): ``GPS``
           is a fix; ``ODO`` and ``DR`` are the vehicle's own estimates
           (``fix_quality`` 6: dead-reckoned, the position weighs the branches);
           ``MAN`` and ``N/A`` are no position (``fix_quality`` 0, the last known one
           is kept)
=========  ===================================================================

**Vehicle identity.** ``oper`` is the operator *running the trip*, which differs from
the operator owning the vehicle when a service is subcontracted: keyed by ``oper``, one
vehicle would split at every such trip, and two vehicles of the same number from different
owners would merge into one that jumps between them. So the vehicle's owner is used
wherever the record gives it: the MQTT topic's operator and vehicle number
(``/hfp/v2/journey/ongoing/vp/tram/0040/00412/...``: ``"40/412"``), else an archive's
``unique_vehicle_id`` (``"40/412"``), else the owner (``owner_operator_id``,
``vehicle_operator_id`` or ``operator_id``: the topic's operator) with
``vehicle_number`` or ``veh``, else ``oper`` with ``veh``. A vehicle number alone
(no operator at all) is the id: numbers repeat across operators, so a file of several
operators needs one of the operator fields.

A number is a JSON number or a string of a plain ASCII decimal number (``"8.2"``,
``"-1e3"``): ``"1_0"``, digits of other scripts, NaN and the infinities are refused, the
field named, as are values of other JSON types (a list, an object, ``true``).

Accepted forms, one message per record:

* **JSON lines** — one message per line (lines end at LF, CR LF or CR alone, not at the
  other line breaks of Unicode, which a JSON string may hold); a line may also be an MQTT
  dump line, ``<topic> <payload>`` (``mosquitto_sub -v``);
* a **JSON array** of messages (an element that cannot be read is a problem of its
  record; the elements after it are read on where the array's syntax allows);
* the **CSV archive** forms — a header naming the fields above, in any case, with or
  without underscores (the names are matched in lower case), optionally an event-type
  column (``event_type`` or ``eventType``; rows of other events are ignored); a record
  is one line (a quote left open is a problem of its line alone). Two of HSL's own
  forms are read as they come: the raw dumps of every message (``tst``, ``eventType``,
  ``ownerOperatorId``, ``vehicleNumber``, ``oper``, ``odo``, ``spd``, ``hdg``,
  ``locationQualityMethod``, ``longitude``, ``latitude``...; stored compressed with
  zstd, see :mod:`antikol.ingest.compressed`) and the HFP analytics API's export
  (``tst`` as PostgreSQL writes it, ``2023-05-02 07:00:01+00``; ``operator_id``,
  ``vehicle_number``, ``long``, ``lat``...).

Messages of other event types (``DUE``, ``ARR``, ``DEP``, ``DOO``...) are counted as
ignored. Bad records are reported with their line (or record) number and the field
(:class:`~antikol.ingest.replaylog.RowProblem`); see
:class:`~antikol.ingest.feed_common.FeedCollector` for what is derived.

>>> import json
>>> msg = {"VP": {"oper": 40, "veh": 412, "tst": "2023-12-14T08:00:01Z", "lat": 50.06,
...        "long": 19.94, "spd": 8.2, "hdg": 91, "odo": 123456, "loc": "GPS"}}
>>> rec = hfp_record(msg, 1, "feed.jsonl")
>>> rec.vehicle_id, rec.t, rec.odometer_m
('40/412', 1702540801.0, 123456.0)
"""

from __future__ import annotations

import io
import os
from collections.abc import Generator, Iterable, Iterator
from pathlib import Path
from typing import Any, Final

from antikol.errors import InputFileError, InvalidArgumentError, ReplayError
from antikol.ingest.compressed import logical_suffix, open_input, stream_problem
from antikol.ingest.feed_common import (
    FeedCollector,
    FeedRecord,
    record_order,
    speed_unit_factor,
)
from antikol.ingest.hfp_messages import (
    HFP_EVENT,
    HfpRecordError,
    hfp_fields,
    hfp_record,
    topic_mode,
    topic_vehicle_id,
)
from antikol.ingest.hfp_text import (
    MAX_LINE_CHARS,
    SNIFF_BYTES,
    Message,
    array_messages,
    csv_messages,
    first_line,
    json_messages,
    looks_like_hfp_csv,
    numbered_lines,
)
from antikol.ingest.replaylog import ReplayLog

__all__ = [
    "HFP_EVENT",
    "MAX_LINE_CHARS",
    "HfpRecordError",
    "hfp_fields",
    "hfp_record",
    "iter_hfp_records",
    "looks_like_hfp_csv",
    "read_hfp",
    "topic_mode",
    "topic_vehicle_id",
]

#: The names of a record's transport mode in the archive forms (lower case).
_MODE: Final = ("mode", "transport_mode", "transportmode")


def read_hfp(
    path: str | os.PathLike[str],
    *,
    strict: bool = False,
    speed_unit: str = "m/s",
    modes: Iterable[str] | None = None,
) -> ReplayLog:
    """Read an HFP log: JSON lines, a JSON array of messages, or the CSV archive form.

    Parameters
    ----------
    path : path-like
        ``.csv`` files (or files whose first line names the HFP fields) are read as CSV,
        anything else as JSON; either may be compressed with gzip, bzip2, xz or zstd
        (:mod:`antikol.ingest.compressed`: ``.csv.gz`` is read as CSV).
    strict : bool
        Raise :class:`~antikol.errors.ReplayError` at the first bad record.
    speed_unit : {"m/s", "km/h", "kn", "mph"}, keyword-only
        Unit of the speed field (default m/s, as the specification says;
        :data:`~antikol.ingest.feed_common.SPEED_UNITS`).
    modes : iterable of str, optional, keyword-only
        Transport modes to read (``{"tram"}``; any case), from the MQTT topic or the
        archive's ``mode`` (``transport_mode``) column: records of other modes are counted
        as ignored, unread (HSL's raw dumps hold every bus, metro and ferry as well). A
        record that names no mode is read. None (default): every mode.

    Returns
    -------
    ReplayLog
        Reports in time order (``t`` in Unix seconds), bad records with their line or
        record number and reason, and the counts of ignored events. A compressed file
        cut short gives the records before the cut and a problem at record 0.

    Raises
    ------
    InvalidArgumentError
        An unknown ``speed_unit``, or ``modes`` not a collection of non-empty strings.
    InputFileError
        The file is missing or unreadable (or compressed and damaged from its start).
    ReplayError
        A CSV header without the HFP fields, or a bad record in strict mode.
    """
    out = FeedCollector(str(Path(path)), strict=strict, speed_factor=speed_unit_factor(speed_unit))
    # (sorted in memory: the reports are held all the same; StreamedFeed sorts on disk)
    for rec in sorted(iter_hfp_records(path, out, modes=modes), key=record_order):
        out.add(rec)
    return out.log()


def iter_hfp_records(
    path: str | os.PathLike[str],
    collector: FeedCollector,
    *,
    modes: Iterable[str] | None = None,
) -> Iterator[FeedRecord]:
    """The vehicle-position records of an HFP log in file order, not yet checked as reports.

    What :func:`read_hfp` reads before it sorts the records by time
    (:func:`~antikol.ingest.feed_common.record_order`) and gives them to ``collector``.

    Parameters
    ----------
    path : path-like
        As for :func:`read_hfp`.
    collector : FeedCollector
        Gets the problems of the file and of the records that are none (a line that is no
        JSON, a bad field...) and the counts of ignored events; its ``strict`` applies.
    modes : iterable of str, optional, keyword-only
        As for :func:`read_hfp`.

    Yields
    ------
    FeedRecord

    Raises
    ------
    InvalidArgumentError, InputFileError, ReplayError
        As :func:`read_hfp` raises them (when the first record is asked for, or later).
    """
    wanted = _modes(modes)
    p = Path(path)
    first = first_line(p)
    is_csv = logical_suffix(p) == ".csv" or (
        not first.startswith(("{", "[", "/")) and looks_like_hfp_csv(first.split(","))
    )
    out = collector
    # a byte that is not UTF-8 stays in its record (as a lone surrogate): the record is
    # rejected if the byte is in a field it needs, the rest of the file is read as usual
    with (
        open_input(p, what="HFP log") as stream,
        io.TextIOWrapper(
            stream, encoding="utf-8-sig", errors="surrogateescape", newline=None
        ) as text,
    ):
        try:
            if is_csv:
                messages = csv_messages(numbered_lines(text), p)
            elif first.startswith("["):  # an array is one JSON text: read whole
                messages = array_messages(text.read())
            else:
                messages = json_messages(numbered_lines(text))
            try:
                unnamed = yield from _collect(messages, p, out, wanted)
            except ReplayError:
                if not out.strict:  # (a CSV header without the HFP fields)
                    raise
                # a record cut short may be the cut's doing: the file's problem comes first
                while text.read(SNIFF_BYTES):
                    pass
                cut = stream_problem(stream)
                if cut is not None:
                    out.problem(0, str(p), cut)
                raise
        except InputFileError:
            raise
        except OSError as exc:
            raise InputFileError(f"{p}: cannot read the HFP log: {exc.strerror or exc}") from exc
        cut = stream_problem(stream)
    if cut is not None:  # the records before the cut are read all the same
        out.problem(0, str(p), cut)
    if unnamed:
        out.problem(
            0,
            str(p),
            f"{unnamed:,} record(s) name no transport mode (no MQTT topic, no mode column): "
            "read whatever the modes asked for",
            kept=True,
        )


def _modes(modes: Iterable[str] | None) -> frozenset[str] | None:
    if modes is None:
        return None
    if isinstance(modes, str):  # ("tram" would be the modes t, r, a and m)
        modes = (modes,)
    try:
        given = list(modes)
    except TypeError:
        raise InvalidArgumentError("modes", modes, "not a collection of mode names") from None
    if not given or not all(isinstance(m, str) and m.strip() for m in given):
        raise InvalidArgumentError("modes", modes, "not a collection of mode names")
    return frozenset(m.strip().lower() for m in given)


def _message_mode(message: Any, mode_in_topic: str | None) -> str | None:
    """A message's transport mode, in lower case: its topic's, else its payload's
    (``mode``, ``transport_mode``); None when it says none."""
    if mode_in_topic is not None:
        return mode_in_topic
    if isinstance(message, dict) and len(message) == 1:
        payload = next(iter(message.values()))
        if isinstance(payload, dict):
            for name in _MODE:
                value = payload.get(name)
                if isinstance(value, str) and value.strip():
                    return value.strip().lower()
    return None


def _collect(
    messages: Iterable[Message],
    path: Path,
    out: FeedCollector,
    modes: frozenset[str] | None,
) -> Generator[FeedRecord, None, int]:
    """Each message's vehicle-position record; problems and other events counted in
    ``out``. Returns (as the generator's value) how many messages were read for naming no
    mode while ``modes`` were asked for."""
    source = str(path)
    unnamed = 0
    for number, message, vehicle_id, mode_in_topic in messages:
        mode = None if modes is None else _message_mode(message, mode_in_topic)
        unnamed += modes is not None and mode is None
        if isinstance(message, Exception):
            out.problem(number, source, str(message))
        elif mode is not None and mode not in (modes or ()):  # (before any field is read)
            out.ignore(f"HFP {mode} record (not a mode read)")
        else:
            try:
                rec = hfp_record(message, number, source, vehicle_id=vehicle_id)
            except HfpRecordError as exc:
                out.problem(number, source, str(exc))
            else:
                if isinstance(rec, str):
                    out.ignore(f"HFP {rec} event (not a vehicle position)")
                else:
                    yield rec
    return unnamed
