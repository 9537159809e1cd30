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

import csv
import io
import json
import math
import os
import re
from collections.abc import Iterable, Iterator, Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Final, NamedTuple

from antikol.errors import InputFileError, InvalidArgumentError, ReplayError
from antikol.ingest.compressed import logical_suffix, open_input, stream_problem
from antikol.ingest.feed_common import (
    FeedCollector,
    FeedRecord,
    speed_unit_factor,
    time_problem,
)
from antikol.ingest.replaylog import ReplayLog

__all__ = [
    "HFP_EVENT",
    "MAX_LINE_CHARS",
    "HfpRecordError",
    "hfp_fields",
    "hfp_record",
    "looks_like_hfp_csv",
    "read_hfp",
    "topic_mode",
    "topic_vehicle_id",
]

#: The HFP event type of vehicle positions.
HFP_EVENT: Final = "VP"
_NO_FIX_SOURCES: Final = frozenset({"ODO", "DR", "MAN", "N/A", "NA"})
_ESTIMATE_SOURCES: Final = frozenset({"ODO", "DR"})
#: A number in a string: ASCII decimal with an optional sign, point and exponent (float()
#: also reads "1_0", "١٢", "nan" and "infinity", none of which a feed means as a number).
_NUMBER: Final = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
#: What float() reads as NaN or an infinity.
_NON_FINITE: Final = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)
#: The start of an ISO 8601 calendar date and time of day (fromisoformat also reads a date
#: alone, as midnight, and week and ordinal dates).
_DATE_AND_TIME: Final = re.compile(r"[0-9]{4}-?[0-9]{2}-?[0-9]{2}[T ][0-9]{2}")
#: A vehicle or operator number with leading zeros, or written as a float: the number.
_WHOLE: Final = re.compile(r"0*([0-9]{1,19})(?:\.0*)?")
#: A CSV line whose quotes are in place: a field with a quote is quoted whole, its quotes
#: doubled (csv also reads a quote inside an unquoted field, and a field left open on into
#: the next lines).
_CSV_FIELD = r'(?:"[^"]*(?:""[^"]*)*"|[^",]*)'
_CSV_LINE: Final = re.compile(f"{_CSV_FIELD}(?:,{_CSV_FIELD})*")
#: The tokens that tell where a JSON value ends: strings, brackets, commas.
_JSON_TOKEN: Final = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"|[][{},]')


#: The names each field goes by in the archive forms, in order of preference (a CSV
#: header is read in lower case: HSL's raw dumps write ``vehicleNumber``, ``latitude``...;
#: the topic's ``topicLatitude`` is the geohash cell, not the fix, and is not read).
_UNIQUE_VEHICLE: Final = ("unique_vehicle_id", "uniquevehicleid")
_VEHICLE_NUMBER: Final = ("vehicle_number", "vehiclenumber")
_OWNER_OPERATOR: Final = (
    "owner_operator_id",
    "owneroperatorid",
    "vehicle_operator_id",
    "vehicleoperatorid",
    "operator_id",
    "operatorid",
)
_LATITUDE: Final = ("lat", "latitude")
_LONGITUDE: Final = ("long", "lon", "longitude")
_LOCATION_SOURCE: Final = ("loc", "locationqualitymethod", "location_quality_method")
_MODE: Final = ("mode", "transport_mode", "transportmode")


class HfpRecordError(ValueError):
    """An HFP record cannot be used (the message names the field)."""


def _shown(value: Any) -> str:
    """``value`` in a message: a list or an object by its type, a long value cut short."""
    if isinstance(value, Mapping):
        return "{...}"
    if isinstance(value, list | tuple):
        return "[...]"
    if isinstance(value, int) and value.bit_length() > 10_000:  # (repr refuses 4300 digits)
        return f"<an integer of {value.bit_length()} bits>"
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:30]}... ({len(text)} characters)"


def _number(fields: Mapping[str, Any], name: str, *, required: bool) -> float | None:
    value = fields.get(name)
    if value is None or (isinstance(value, str) and not value.strip()):
        if required:
            raise HfpRecordError(f"{name} is missing")
        return None
    if isinstance(value, str):
        text = value.strip()
        if _NUMBER.fullmatch(text) is None:
            kind = "a finite number" if _NON_FINITE.fullmatch(text) else "a number"
            raise HfpRecordError(f"{name}={_shown(value)} is not {kind}")
        number = float(text)  # ("1e400" is inf)
    elif isinstance(value, int | float) and not isinstance(value, bool):
        try:
            number = float(value)
        except OverflowError:  # an integer beyond a double (10**400)
            number = math.inf
    else:
        raise HfpRecordError(f"{name}={_shown(value)} is not a number")
    if not math.isfinite(number):
        raise HfpRecordError(f"{name}={_shown(value)} is not a finite number")
    return number


def _given(fields: Mapping[str, Any], names: tuple[str, ...]) -> str:
    """The first of a field's ``names`` that the record gives a value (not null, not an
    empty CSV field), else the first name (for the message of a missing field)."""
    for name in names:
        value = fields.get(name)
        if value is not None and not (isinstance(value, str) and not value.strip()):
            return name
    return names[0]


def _time(fields: Mapping[str, Any]) -> float:
    """The record's time, checked here, before the records are sorted by it."""
    tst = fields.get("tst")
    if tst is None or (isinstance(tst, str) and not tst.strip()):
        name, given = "tsi", fields.get("tsi")
        t = _number(fields, "tsi", required=False)
        if t is None:
            raise HfpRecordError("tst and tsi are missing")
    elif not isinstance(tst, str):
        raise HfpRecordError(f"tst={_shown(tst)} is not a time (an ISO 8601 string)")
    else:
        try:
            if _DATE_AND_TIME.match(tst.strip()) is None:
                raise ValueError(tst)
            when = datetime.fromisoformat(tst.strip())
        except ValueError:
            raise HfpRecordError(
                f"tst={_shown(tst)} is not an ISO 8601 date and time of day"
            ) from None
        if when.tzinfo is None:
            when = when.replace(tzinfo=UTC)  # HFP times are UTC
        name, given, t = "tst", tst, when.timestamp()
    why = time_problem(t)
    if why is not None:
        raise HfpRecordError(f"{name}={_shown(given)}: {why}")
    return t


def _plain(text: str) -> str:
    # "0412" and "412.0" -> "412"; only ASCII digits (int() also reads "²")
    text = text.strip()
    whole = _WHOLE.fullmatch(text)
    return whole.group(1) if whole else text


def _id_text(fields: Mapping[str, Any], name: str) -> str | None:
    """Identity field ``name`` as text, None when not given: a string, or a whole number
    (412.0 is vehicle 412, not another one); anything else is refused, not made an id."""
    value = fields.get(name)
    if value is None:
        return None
    if isinstance(value, str):
        return _plain(value) or None
    if isinstance(value, float) and value.is_integer():  # (False for NaN and infinities)
        value = int(value)
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) < 10**19:
        return str(value)
    raise HfpRecordError(f"{name}={_shown(value)} is not a whole number or a string")


def _first_id(fields: Mapping[str, Any], *names: str) -> str | None:
    for name in names:
        text = _id_text(fields, name)
        if text is not None:
            return text
    return None


def _owned_id(operator: str | None, vehicle: str) -> str:
    return f"{operator}/{vehicle}" if operator else vehicle


def _vehicle_id(fields: Mapping[str, Any]) -> str:
    unique = _first_id(fields, *_UNIQUE_VEHICLE)
    if unique is not None:
        return "/".join(_plain(part) for part in unique.split("/"))
    owner = _first_id(fields, *_OWNER_OPERATOR)
    number = _first_id(fields, *_VEHICLE_NUMBER)
    if number is not None:
        return _owned_id(owner, number)
    veh = _id_text(fields, "veh")
    if veh is None:
        raise HfpRecordError("veh is missing")
    # the trip's operator (oper) only where the record does not name the vehicle's owner
    return _owned_id(owner if owner is not None else _id_text(fields, "oper"), veh)


def _topic_operator_place(parts: list[str]) -> int | None:
    """Where the operator stands in a topic's parts (the mode just before it), or None."""
    try:
        at = parts.index("hfp")
    except ValueError:
        return None
    version = parts[at + 1] if len(parts) > at + 1 else ""
    first = {"v1": at + 5, "v2": at + 6}.get(version)
    if first is None or len(parts) <= first + 1:
        return None
    return first


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
    first = _topic_operator_place(parts)
    if first is None:
        return None
    operator, vehicle = _plain(parts[first]), _plain(parts[first + 1])
    if not (operator and vehicle) or "+" in (operator, vehicle):
        return None
    return _owned_id(operator, vehicle)


def topic_mode(topic: str) -> str | None:
    """The transport mode in an HFP MQTT topic, in lower case (``tram``, ``bus``,
    ``metro``...), or None for a topic of another form.

    >>> topic_mode("/hfp/v2/journey/ongoing/vp/tram/0040/00412/1006/1/Pasila")
    'tram'
    """
    parts = topic.strip().split("/")
    first = _topic_operator_place(parts)
    mode = parts[first - 1].strip().lower() if first is not None else ""
    return mode if mode and mode != "+" else None


def hfp_fields(
    fields: Mapping[str, Any], record: int, source: str, *, vehicle_id: str | None = None
) -> FeedRecord:
    """A :class:`~antikol.ingest.feed_common.FeedRecord` from the fields of a VP event.

    ``vehicle_id`` (keyword-only): the vehicle's id where the message's topic gives it
    (:func:`topic_vehicle_id`); else it comes from the fields (see the module).

    Raises
    ------
    HfpRecordError
        A required field is missing, a field is not a finite number (or the vehicle's
        number not a whole number or a string), or the time is unreadable or outside the
        years 1970 to 9999.
    """
    loc_name = _given(fields, _LOCATION_SOURCE)
    loc = fields.get(loc_name)
    if loc is not None and not isinstance(loc, str):
        raise HfpRecordError(f"{loc_name}={_shown(loc)} is not a location source (GPS, ODO, DR...)")
    source_kind = loc.strip().upper() if loc else "GPS"
    return FeedRecord(
        record=record,
        source=source,
        vehicle_id=vehicle_id if vehicle_id else _vehicle_id(fields),
        t=_time(fields),
        lat=_number(fields, _given(fields, _LATITUDE), required=False),
        lon=_number(fields, _given(fields, _LONGITUDE), required=False),
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
    mode: str | None = None  # the transport mode, from the MQTT topic, if any


#: A line is one message or one CSV row: HSL's are under 2 kB. A longer one is a problem
#: of its own, read past in bounded memory (a file without line breaks is not held whole).
MAX_LINE_CHARS: Final = 1 << 16

_Line = tuple[int, "str | HfpRecordError"]


def _lines(text: io.TextIOBase) -> Iterator[_Line]:
    """The numbered lines of a text stream opened with ``newline=None`` (ended by LF,
    CR LF or CR: not by the other line breaks of ``str.splitlines``, U+2028, U+0085...,
    which a JSON string or a CSV field may hold as they are), without their ending; a line
    of more than :data:`MAX_LINE_CHARS` characters is a problem in its place."""
    number = 0
    while True:
        line = text.readline(MAX_LINE_CHARS + 1)
        if not line:
            return
        number += 1
        if len(line) <= MAX_LINE_CHARS or line.endswith("\n"):
            yield number, line.rstrip("\n")
            continue
        length = len(line)
        while line and not line.endswith("\n"):  # the rest of the line, a piece at a time
            line = text.readline(MAX_LINE_CHARS)
            length += len(line)
        length -= line.endswith("\n")  # (its ending is no character of the line)
        yield (
            number,
            HfpRecordError(
                f"a line of {length:,} characters (more than {MAX_LINE_CHARS:,}: not a record)"
            ),
        )


def _unreadable(exc: ValueError | RecursionError) -> HfpRecordError:
    """The problem of a JSON text that ``json`` cannot read."""
    if isinstance(exc, json.JSONDecodeError):
        return HfpRecordError(f"unreadable JSON: {exc.msg} (column {exc.colno})")
    if isinstance(exc, RecursionError):
        return HfpRecordError("unreadable JSON: nested too deeply")
    # an integer of more digits than Python converts (sys.get_int_max_str_digits())
    return HfpRecordError(f"unreadable JSON: {str(exc).split(';')[0]}")


def _after_space(text: str, at: int) -> int:
    """The first index from ``at`` on that is no JSON white space."""
    while at < len(text) and text[at] in " \t\n\r":
        at += 1
    return at


def _value_end(text: str, at: int) -> int | None:
    """Where the JSON value starting at ``at`` ends, found without decoding it (a value
    nested too deeply for ``json``); None when the text ends first."""
    depth = 0
    for token in _JSON_TOKEN.finditer(text, at):
        char = token.group()[0]
        if char in "[{":
            depth += 1
        elif char in "]}":
            depth -= 1
            if depth <= 0:  # the value's own end, or the end of the array around it
                return token.end() if depth == 0 else token.start()
        elif char == "," and depth == 0:
            return token.start()
    return None


def _array_messages(text: str) -> Iterator[_Message]:
    """The messages of a JSON array, decoded one element after the other: an element
    ``json`` cannot read is a problem of its record, not of the whole file."""
    decoder = json.JSONDecoder()
    at = _after_space(text, text.index("[") + 1)
    if text.startswith("]", at):
        return
    number = 1
    while True:
        try:
            message, end = decoder.raw_decode(text, at)
        except json.JSONDecodeError as exc:  # the array's syntax is lost: no element after
            where = f"line {exc.lineno}, column {exc.colno}"
            yield _Message(number, HfpRecordError(f"unreadable JSON array: {exc.msg} ({where})"))
            return
        except (ValueError, RecursionError) as exc:
            yield _Message(number, _unreadable(exc))
            skipped = _value_end(text, at)
            if skipped is None:
                return
            end = skipped
        else:
            yield _Message(number, message)
        at = _after_space(text, end)
        if text.startswith("]", at):
            return
        if not text.startswith(",", at):
            yield _Message(number, HfpRecordError("unreadable JSON array: no ',' or ']' after it"))
            return
        at = _after_space(text, at + 1)
        number += 1


def _json_messages(lines: Iterable[_Line]) -> Iterator[_Message]:
    """The messages of a JSON-lines HFP file (or an MQTT dump)."""
    for number, line in lines:
        if isinstance(line, HfpRecordError):
            yield _Message(number, line)
            continue
        body = line.strip()
        if not body:
            continue
        vehicle_id = mode = None
        if not body.startswith("{") and " " in body:  # an MQTT dump line: topic payload
            # (a topic may hold spaces, in the headsign: the payload starts at the brace)
            brace = body.find(" {")
            topic, body = (body[:brace], body[brace:]) if brace > 0 else body.split(" ", 1)
            body = body.strip()
            vehicle_id, mode = topic_vehicle_id(topic), topic_mode(topic)
        try:
            message = json.loads(body)
        except (ValueError, RecursionError) as exc:  # (JSONDecodeError is a ValueError)
            yield _Message(number, _unreadable(exc))
        else:
            yield _Message(number, message, vehicle_id, mode)


#: Header names of a vehicle's identity in the CSV archive forms (lower case).
_VEHICLE_COLUMNS: Final = frozenset({"veh", *_VEHICLE_NUMBER, *_UNIQUE_VEHICLE})


def looks_like_hfp_csv(header: Iterable[str]) -> bool:
    """Whether a CSV header names the HFP fields: the vehicle (``veh``,
    ``vehicle_number`` or ``unique_vehicle_id``, in any case and with or without the
    underscores), ``tst`` or ``tsi``, and ``lat`` or ``latitude``.

    >>> looks_like_hfp_csv(["tst", "eventType", "ownerOperatorId", "vehicleNumber",
    ...                     "latitude", "longitude"])
    True
    >>> looks_like_hfp_csv(["time", "vehicle", "lat", "lon"])
    False
    """
    names = {h.strip().lstrip("\ufeff").strip('"').lower() for h in header}
    return (
        bool(names & _VEHICLE_COLUMNS)
        and bool(names.intersection(_LATITUDE))
        and bool(names & {"tst", "tsi"})
    )


def _csv_rows(lines: Iterable[_Line]) -> Iterator[tuple[int, list[str] | HfpRecordError]]:
    """The fields of each line: an HFP record never spans lines, so a quote left open is
    a problem of its own line, not a field running on through the rest of the file."""
    for number, line in lines:
        if isinstance(line, HfpRecordError):
            yield number, line
        elif '"' not in line:  # (what csv makes of a line without quotes, only faster)
            yield number, line.split(",")
        elif _CSV_LINE.fullmatch(line) is None:
            yield number, HfpRecordError("unreadable row: a quote out of place or left open")
        else:
            try:
                yield number, next(csv.reader((line,), strict=True))
            except csv.Error as exc:  # (a field beyond csv.field_size_limit())
                yield number, HfpRecordError(f"unreadable row: {exc}")


def _csv_records(lines: Iterable[_Line], path: Path) -> Iterator[_Message]:
    rows = _csv_rows(lines)
    first = next(rows, None)
    if first is None:
        raise ReplayError(f"{path}: empty file (expected an HFP header line)")
    if isinstance(first[1], HfpRecordError):
        raise ReplayError(f"{path}:1: unreadable HFP CSV header: {first[1]}")
    header = [h.strip().lstrip("\ufeff") for h in first[1]]
    if not looks_like_hfp_csv(header):
        raise ReplayError(
            f"{path}: not an HFP CSV header (needs veh, vehicle_number or "
            "unique_vehicle_id; tst or tsi; lat or latitude; long, lon or longitude); "
            f"got {','.join(header)}"
        )
    lower = [h.lower() for h in header]
    event_col = next((i for i, h in enumerate(lower) if h in ("event_type", "eventtype")), None)
    for number, row in rows:
        if isinstance(row, HfpRecordError):
            yield _Message(number, row)
            continue
        if all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            yield _Message(
                number, HfpRecordError(f"{len(row)} fields, the header has {len(header)}")
            )
            continue
        fields = dict(zip(lower, row, strict=True))
        event = row[event_col].strip().upper() if event_col is not None else HFP_EVENT
        yield _Message(number, {event or HFP_EVENT: fields})


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
    factor = speed_unit_factor(speed_unit)
    wanted = _modes(modes)
    p = Path(path)
    first = _first_line(p)
    is_csv = logical_suffix(p) == ".csv" or (
        not first.startswith(("{", "[", "/")) and looks_like_hfp_csv(first.split(","))
    )
    out = FeedCollector(str(p), strict=strict, speed_factor=factor)
    records: list[FeedRecord] = []
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
                messages = _csv_records(_lines(text), p)
            elif first.startswith("["):  # an array is one JSON text: read whole
                messages = _array_messages(text.read())
            else:
                messages = _json_messages(_lines(text))
            try:
                _collect(messages, p, out, records, wanted)
            except ReplayError:
                if not strict:  # (a CSV header without the HFP fields)
                    raise
                # a record cut short may be the cut's doing: the file's problem comes first
                while text.read(_SNIFF_BYTES):
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
    for rec in sorted(records, key=lambda r: r.t):
        out.add(rec)
    return out.log()


#: Bytes of a file's first line read to tell its form (CSV or JSON, lines or an array).
_SNIFF_BYTES: Final = 1 << 16


def _decoded(data: bytes) -> str:
    return data.decode("utf-8", errors="surrogateescape")


def _first_line(path: Path) -> str:
    """The start (up to :data:`_SNIFF_BYTES`) of the first line of a file's content that
    is not blank, "" when it has none.

    Raises
    ------
    InputFileError
        The file is missing or unreadable, or compressed and damaged from its start.
    """
    with open_input(path, what="HFP log") as stream:
        try:
            chunk = stream.read(_SNIFF_BYTES)
            cut = None if chunk else stream_problem(stream)
            text = _decoded(chunk).removeprefix("\ufeff")
            while text and not text.lstrip():  # white space, however much of it
                text = _decoded(stream.read(_SNIFF_BYTES))
            text = text.lstrip()
            if "\n" not in text and "\r" not in text:
                text += _decoded(stream.read(_SNIFF_BYTES))
        except OSError as exc:
            raise InputFileError(f"{path}: cannot read the HFP log: {exc.strerror or exc}") from exc
    if cut is not None:
        raise InputFileError(f"{path}: cannot read the HFP log: {cut}")
    return text.replace("\r", "\n").split("\n", 1)[0]


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


def _message_mode(message: Any, topic_mode: str | None) -> str | None:
    """A message's transport mode, in lower case: its topic's, else its payload's
    (``mode``, ``transport_mode``); None when it says none."""
    if topic_mode is not None:
        return topic_mode
    if isinstance(message, dict) and len(message) == 1:
        payload = next(iter(message.values()))
        if isinstance(payload, dict):
            for name in _MODE:
                value = payload.get(name)
                if isinstance(value, str) and value.strip():
                    return value.strip().lower()
    return None


def _collect(
    messages: Iterable[_Message],
    path: Path,
    out: FeedCollector,
    records: list[FeedRecord],
    modes: frozenset[str] | None,
) -> None:
    """Each message's vehicle-position record into ``records``; problems and other events
    counted in ``out``."""
    source = str(path)
    for number, message, vehicle_id, topic_mode in messages:
        mode = None if modes is None else _message_mode(message, topic_mode)
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
                    records.append(rec)
