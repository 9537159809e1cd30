"""One HFP message to a feed record: its fields, its time, its vehicle, its MQTT topic.

The fields an HFP vehicle position (``VP``) carries and how each is read are listed in
:mod:`antikol.ingest.hfp`, the reader of whole files; this module reads one message,
whatever form of file it came from (:mod:`antikol.ingest.hfp_text`).

>>> msg = {"VP": {"oper": 40, "veh": 412, "tst": "2023-12-14T08:00:01Z", "lat": 50.06,
...        "long": 19.94, "spd": 8.2, "hdg": 91, "odo": 123456, "loc": "GPS"}}
>>> rec = hfp_record(msg, 1, "feed.jsonl")
>>> rec.vehicle_id, rec.t, rec.odometer_m
('40/412', 1702540801.0, 123456.0)
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from datetime import UTC, datetime
from typing import Any, Final

from antikol.ingest.feed_common import FeedRecord, time_problem

__all__ = [
    "HFP_EVENT",
    "LATITUDE_FIELDS",
    "VEHICLE_FIELDS",
    "HfpRecordError",
    "hfp_fields",
    "hfp_record",
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

#: Field names (lower case) that name a vehicle in the archive forms: with a time and a
#: latitude, a CSV header naming one of them is an HFP header.
VEHICLE_FIELDS: Final = frozenset({"veh", *_VEHICLE_NUMBER, *_UNIQUE_VEHICLE})
#: Field names of the latitude, in order of preference.
LATITUDE_FIELDS: Final = _LATITUDE


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
