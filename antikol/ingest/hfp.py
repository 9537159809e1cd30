"""HSL-style high-frequency positioning (HFP) feeds: vehicle positions as JSON or CSV.

Helsinki Region Transport publishes every vehicle's position about once a second as MQTT
messages whose payload is a JSON object keyed by the event type, ``{"VP": {...}}`` for a
vehicle position. The fields used here (HFP v2):

=========  ===================================================================
``oper``   operator id; with ``veh`` the vehicle id ``"<oper>/<veh>"`` where the
           vehicle's owner is not given (below)
``veh``    vehicle number within the operator
``tst``    UTC time, ISO 8601 (``2023-12-14T08:00:01.123Z``); ``tsi`` (Unix
           seconds) when ``tst`` is missing
``lat``,   WGS84 degrees (null when unknown)
``long``
``spd``    speed, m/s (null: derived from the previous record)
``hdg``    heading, degrees from north (null: derived, or the last one kept)
``odo``    odometer, metres — the report's ``odometer_m``
``loc``    location source: ``GPS`` is a fix; ``ODO`` and ``DR`` are the
           vehicle's own estimates (``fix_quality`` 6: dead-reckoned, the position
           weighs the branches); ``MAN`` and ``N/A`` are no position (``fix_quality``
           0, the last known one is kept)
=========  ===================================================================

**Vehicle identity.** ``oper`` is the operator *running the trip*, which differs from
the operator owning the vehicle when a service is subcontracted: keyed by ``oper``, one
vehicle would split at every such trip, and two vehicles of the same number from different
owners would merge into one that jumps between them. So the vehicle's owner is used
wherever the record gives it: the MQTT topic's operator and vehicle number
(``/hfp/v2/journey/ongoing/vp/tram/0040/00412/...``: ``"40/412"``), else an archive's
``unique_vehicle_id`` (``"40/412"``), else its ``owner_operator_id`` with
``vehicle_number``, else ``oper`` with ``veh``.

Accepted forms, one message per record:

* **JSON lines** — one message per line; a line may also be an MQTT dump line,
  ``<topic> <payload>`` (``mosquitto_sub -v``);
* a **JSON array** of messages;
* the **CSV archive** form — a header with the same field names (``long`` or ``lon``),
  optionally an event-type column (``event_type`` or ``eventType``; rows of other events
  are ignored).

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

import csv
import io
import json
import os
from collections.abc import Iterable, Iterator, Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Final, NamedTuple

from antikol.errors import ReplayError
from antikol.ingest.compressed import logical_suffix, read_input
from antikol.ingest.feed_common import FeedCollector, FeedRecord, speed_unit_factor
from antikol.ingest.replaylog import ReplayLog

__all__ = [
    "HFP_EVENT",
    "HfpRecordError",
    "hfp_fields",
    "hfp_record",
    "looks_like_hfp_csv",
    "read_hfp",
    "topic_vehicle_id",
]

#: The HFP event type of vehicle positions.
HFP_EVENT: Final = "VP"
_NO_FIX_SOURCES: Final = frozenset({"ODO", "DR", "MAN", "N/A", "NA"})
_ESTIMATE_SOURCES: Final = frozenset({"ODO", "DR"})


class HfpRecordError(ValueError):
    """An HFP record cannot be used (the message names the field)."""


def _number(fields: Mapping[str, Any], name: str, *, required: bool) -> float | None:
    value = fields.get(name)
    if value is None or (isinstance(value, str) and not value.strip()):
        if required:
            raise HfpRecordError(f"{name} is missing")
        return None
    if isinstance(value, bool):
        raise HfpRecordError(f"{name}={value!r} is not a number")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise HfpRecordError(f"{name}={value!r} is not a number") from None


def _time(fields: Mapping[str, Any]) -> float:
    tst = fields.get("tst")
    if isinstance(tst, str) and tst.strip():
        try:
            when = datetime.fromisoformat(tst.strip())
        except ValueError:
            raise HfpRecordError(f"tst={tst!r} is not an ISO 8601 time") from None
        if when.tzinfo is None:
            when = when.replace(tzinfo=UTC)  # HFP times are UTC
        return when.timestamp()
    tsi = _number(fields, "tsi", required=False)
    if tsi is None:
        raise HfpRecordError("tst and tsi are missing")
    return tsi


def _plain(value: Any) -> str:
    text = str(value).strip()
    # "0412" -> "412"; only ASCII digits (int() also reads "²" and fails on 5000 digits)
    return str(int(text)) if text.isascii() and text.isdigit() and len(text) < 20 else text


def _given(value: Any) -> bool:
    return value is not None and str(value).strip() != ""


def _owned_id(operator: Any, vehicle: Any) -> str:
    return f"{_plain(operator)}/{_plain(vehicle)}" if _given(operator) else _plain(vehicle)


def _vehicle_id(fields: Mapping[str, Any]) -> str:
    unique = fields.get("unique_vehicle_id", fields.get("uniquevehicleid"))
    if _given(unique):
        return "/".join(_plain(part) for part in str(unique).split("/"))
    number = fields.get("vehicle_number", fields.get("vehiclenumber"))
    if _given(number):
        return _owned_id(fields.get("owner_operator_id", fields.get("owneroperatorid")), number)
    veh = fields.get("veh")
    if not _given(veh):
        raise HfpRecordError("veh is missing")
    return _owned_id(fields.get("oper"), veh)


def topic_vehicle_id(topic: str) -> str | None:
    """The vehicle id (``"<owner operator>/<vehicle number>"``) in an HFP MQTT topic.

    Parameters
    ----------
    topic : str
        ``/hfp/v2/<journey type>/<temporal type>/<event type>/<mode>/<operator>/<vehicle>/...``
        (HFP v1 topics have no event type).

    Returns
    -------
    str or None
        None for a topic of another form.

    >>> topic_vehicle_id("/hfp/v2/journey/ongoing/vp/bus/0018/00423/2159/2/Matinkylä")
    '18/423'
    """
    parts = topic.strip().split("/")
    try:
        at = parts.index("hfp")
    except ValueError:
        return None
    version = parts[at + 1] if len(parts) > at + 1 else ""
    first = {"v1": at + 5, "v2": at + 6}.get(version)  # the operator's place
    if first is None or len(parts) <= first + 1:
        return None
    operator, vehicle = parts[first], parts[first + 1]
    if not (_given(operator) and _given(vehicle)) or "+" in (operator, vehicle):
        return None
    return _owned_id(operator, vehicle)


def hfp_fields(
    fields: Mapping[str, Any], record: int, source: str, *, vehicle_id: str | None = None
) -> FeedRecord:
    """A :class:`~antikol.ingest.feed_common.FeedRecord` from the fields of a VP event.

    ``vehicle_id`` (keyword-only): the vehicle's id where the message's topic gives it
    (:func:`topic_vehicle_id`); else it comes from the fields (see the module).

    Raises
    ------
    HfpRecordError
        A required field is missing or not a number, or the time is unreadable.
    """
    loc = fields.get("loc")
    source_kind = loc.strip().upper() if isinstance(loc, str) else "GPS"
    return FeedRecord(
        record=record,
        source=source,
        vehicle_id=vehicle_id if vehicle_id else _vehicle_id(fields),
        t=_time(fields),
        lat=_number(fields, "lat", required=False),
        lon=_number(fields, "long", required=False)
        if fields.get("long") is not None
        else _number(fields, "lon", required=False),
        speed_mps=_number(fields, "spd", required=False),
        course_deg=_number(fields, "hdg", required=False),
        odometer_m=_number(fields, "odo", required=False),
        has_fix=source_kind not in _NO_FIX_SOURCES,
        estimated=source_kind in _ESTIMATE_SOURCES,
    )


def hfp_record(
    message: Any, record: int, source: str = "", *, vehicle_id: str | None = None
) -> FeedRecord | str:
    """The vehicle-position record of one HFP message, or the event type it has instead.

    Parameters
    ----------
    message : dict
        ``{"VP": {...}}`` (or another event type as the single key).
    record : int
        Line or record number, for messages.
    source : str
        The file.
    vehicle_id : str, optional, keyword-only
        The vehicle's id from the message's MQTT topic (:func:`topic_vehicle_id`).

    Returns
    -------
    FeedRecord or str
        The record of a ``VP`` message, else the message's event type.

    Raises
    ------
    HfpRecordError
        Not an HFP message, or a bad ``VP`` payload.
    """
    if not isinstance(message, dict) or not message:
        raise HfpRecordError("not an HFP message (a JSON object keyed by the event type)")
    (event, payload), *rest = message.items()
    if rest:
        raise HfpRecordError(f"an HFP message has one event key, got {sorted(message)}")
    if event != HFP_EVENT:
        return str(event)
    if not isinstance(payload, dict):
        raise HfpRecordError(f"the {event} payload is not a JSON object")
    return hfp_fields(payload, record, source, vehicle_id=vehicle_id)


class _Message(NamedTuple):
    number: int  # line or record number
    body: Any  # the decoded message, or the error decoding it
    vehicle_id: str | None = None  # from the MQTT topic, if any


def _json_messages(text: str) -> Iterator[_Message]:
    """The messages of a JSON HFP file."""
    if text.lstrip().startswith("["):
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            yield _Message(exc.lineno, HfpRecordError(f"unreadable JSON array: {exc.msg}"))
            return
        for number, message in enumerate(doc, start=1):
            yield _Message(number, message)
        return
    for number, line in enumerate(text.splitlines(), start=1):
        body = line.strip()
        if not body:
            continue
        vehicle_id = None
        if not body.startswith("{") and " " in body:  # an MQTT dump line: topic payload
            # (a topic may hold spaces, in the headsign: the payload starts at the brace)
            brace = body.find(" {")
            topic, body = (body[:brace], body[brace:]) if brace > 0 else body.split(" ", 1)
            body = body.strip()
            vehicle_id = topic_vehicle_id(topic)
        try:
            yield _Message(number, json.loads(body), vehicle_id)
        except json.JSONDecodeError as exc:
            yield _Message(
                number, HfpRecordError(f"unreadable JSON: {exc.msg} (column {exc.colno})")
            )


#: Header names of a vehicle's identity in the CSV archive forms (lower case).
_VEHICLE_COLUMNS: Final = frozenset(
    {"veh", "vehicle_number", "vehiclenumber", "unique_vehicle_id", "uniquevehicleid"}
)


def looks_like_hfp_csv(header: Iterable[str]) -> bool:
    """Whether a CSV header names the HFP fields (``veh`` or the vehicle's owner and
    number, ``tst`` or ``tsi``, ``lat``)."""
    names = {h.strip().lstrip("\ufeff").lower() for h in header}
    return bool(names & _VEHICLE_COLUMNS) and "lat" in names and bool(names & {"tst", "tsi"})


def _csv_records(fh: Any, path: Path) -> Iterator[_Message]:
    reader = csv.reader(fh)
    try:
        header = [h.strip().lstrip("\ufeff") for h in next(reader)]
    except StopIteration:
        raise ReplayError(f"{path}: empty file (expected an HFP header line)") from None
    if not looks_like_hfp_csv(header):
        raise ReplayError(
            f"{path}: not an HFP CSV header (needs veh or vehicle_number, tst or tsi, "
            "lat, long); "
            f"got {','.join(header)}"
        )
    lower = [h.lower() for h in header]
    event_col = next((i for i, h in enumerate(lower) if h in ("event_type", "eventtype")), None)
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            yield _Message(reader.line_num, HfpRecordError(f"unreadable row: {exc}"))
            continue
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            yield _Message(
                reader.line_num, HfpRecordError(f"{len(row)} fields, the header has {len(header)}")
            )
            continue
        fields = dict(zip(lower, row, strict=True))
        event = row[event_col].strip().upper() if event_col is not None else HFP_EVENT
        yield _Message(reader.line_num, {event or HFP_EVENT: fields})


def read_hfp(
    path: str | os.PathLike[str], *, strict: bool = False, speed_unit: str = "m/s"
) -> ReplayLog:
    """Read an HFP log: JSON lines, a JSON array of messages, or the CSV archive form.

    Parameters
    ----------
    path : path-like
        ``.csv`` files (or files whose first line names the HFP fields) are read as CSV,
        anything else as JSON; either may be compressed with gzip, bzip2 or xz
        (:mod:`antikol.ingest.compressed`: ``.csv.gz`` is read as CSV).
    strict : bool
        Raise :class:`~antikol.errors.ReplayError` at the first bad record.
    speed_unit : {"m/s", "km/h", "kn", "mph"}, keyword-only
        Unit of the speed field (default m/s, as the specification says;
        :data:`~antikol.ingest.feed_common.SPEED_UNITS`).

    Returns
    -------
    ReplayLog
        Reports in time order (``t`` in Unix seconds), bad records with their line or
        record number and reason, and the counts of ignored events. A compressed file
        cut short gives the records before the cut and a problem at record 0.

    Raises
    ------
    InvalidArgumentError
        An unknown ``speed_unit``.
    InputFileError
        The file is missing or unreadable (or compressed and damaged from its start).
    ReplayError
        A CSV header without the HFP fields, or a bad record in strict mode.
    """
    factor = speed_unit_factor(speed_unit)
    p = Path(path)
    decoded = read_input(p, what="HFP log")
    # a byte that is not UTF-8 stays in its record (as a lone surrogate): the record is
    # rejected if the byte is in a field it needs, the rest of the file is read as usual
    text = decoded.data.decode("utf-8-sig", errors="surrogateescape")
    first = text.lstrip().split("\n", 1)[0]
    is_csv = logical_suffix(p) == ".csv" or (
        not first.startswith(("{", "[", "/")) and looks_like_hfp_csv(first.split(","))
    )
    messages = _csv_records(io.StringIO(text, newline=""), p) if is_csv else _json_messages(text)
    out = FeedCollector(str(p), strict=strict, speed_factor=factor)
    if decoded.problem is not None:  # the records before the cut are read all the same
        out.problem(0, str(p), decoded.problem)
    records: list[FeedRecord] = []
    for number, message, vehicle_id in messages:
        if isinstance(message, Exception):
            out.problem(number, str(p), str(message))
            continue
        try:
            rec = hfp_record(message, number, str(p), vehicle_id=vehicle_id)
        except HfpRecordError as exc:
            out.problem(number, str(p), str(exc))
            continue
        if isinstance(rec, str):
            out.ignore(f"HFP {rec} event (not a vehicle position)")
        else:
            records.append(rec)
    for rec in sorted(records, key=lambda r: r.t):
        out.add(rec)
    return out.log()
