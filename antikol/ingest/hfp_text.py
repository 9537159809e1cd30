"""The text forms of an HFP file, as numbered messages: JSON lines (or an MQTT dump), a
JSON array, the CSV archive forms.

Each form gives :class:`Message` records, one per line or array element, in file order;
a line or element that cannot be read is a message whose body is the
:class:`~antikol.ingest.hfp_messages.HfpRecordError` saying why, so that one bad record
never stops the file. :func:`first_line` tells the forms apart from a file's start;
:func:`antikol.ingest.hfp.read_hfp` puts them together.
"""

from __future__ import annotations

import csv
import io
import json
import re
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, Final, NamedTuple

from antikol.errors import InputFileError, ReplayError
from antikol.ingest.compressed import open_input, stream_problem
from antikol.ingest.hfp_messages import (
    HFP_EVENT,
    LATITUDE_FIELDS,
    VEHICLE_FIELDS,
    HfpRecordError,
    topic_mode,
    topic_vehicle_id,
)

__all__ = [
    "MAX_LINE_CHARS",
    "SNIFF_BYTES",
    "Line",
    "Message",
    "array_messages",
    "csv_messages",
    "first_line",
    "json_messages",
    "looks_like_hfp_csv",
    "numbered_lines",
]

#: A CSV line whose quotes are in place: a field with a quote is quoted whole, its quotes
#: doubled (csv also reads a quote inside an unquoted field, and a field left open on into
#: the next lines).
_CSV_FIELD = r'(?:"[^"]*(?:""[^"]*)*"|[^",]*)'
_CSV_LINE: Final = re.compile(f"{_CSV_FIELD}(?:,{_CSV_FIELD})*")
#: The tokens that tell where a JSON value ends: strings, brackets, commas.
_JSON_TOKEN: Final = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"|[][{},]')


class Message(NamedTuple):
    """One message of an HFP file, in file order."""

    number: int  # line or record number
    body: Any  # the decoded message, or the error decoding it
    vehicle_id: str | None = None  # from the MQTT topic, if any
    mode: str | None = None  # the transport mode, from the MQTT topic, if any


#: A line is one message or one CSV row: HSL's are under 2 kB. A longer one is a problem
#: of its own, read past in bounded memory (a file without line breaks is not held whole).
MAX_LINE_CHARS: Final = 1 << 16

#: A numbered line, or the problem that stands in its place.
Line = tuple[int, "str | HfpRecordError"]


def numbered_lines(text: io.TextIOBase) -> Iterator[Line]:
    """The numbered lines of a text stream, read in bounded memory.

    Parameters
    ----------
    text : io.TextIOBase
        Opened with ``newline=None``: lines end at LF, CR LF or CR, not at the other line
        breaks of ``str.splitlines`` (U+2028, U+0085...), which a JSON string or a CSV
        field may hold as they are.

    Yields
    ------
    Line
        ``(number, line)`` from 1, the line without its ending; a line of more than
        :data:`MAX_LINE_CHARS` characters is an :class:`HfpRecordError` in its place,
        read past a piece at a time.
    """
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


def array_messages(text: str) -> Iterator[Message]:
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
            yield Message(number, HfpRecordError(f"unreadable JSON array: {exc.msg} ({where})"))
            return
        except (ValueError, RecursionError) as exc:
            yield Message(number, _unreadable(exc))
            skipped = _value_end(text, at)
            if skipped is None:
                return
            end = skipped
        else:
            yield Message(number, message)
        at = _after_space(text, end)
        if text.startswith("]", at):
            return
        if not text.startswith(",", at):
            yield Message(number, HfpRecordError("unreadable JSON array: no ',' or ']' after it"))
            return
        at = _after_space(text, at + 1)
        number += 1


def json_messages(lines: Iterable[Line]) -> Iterator[Message]:
    """The messages of a JSON-lines HFP file, one per line that is not blank.

    A line may also be an MQTT dump line, ``[<received at>] <topic> <payload>``
    (``mosquitto_sub -v``, HSL's dumps): the vehicle id and the transport mode then come
    from the topic (:func:`~antikol.ingest.hfp_messages.topic_vehicle_id`,
    :func:`~antikol.ingest.hfp_messages.topic_mode`). A line that is no JSON text is a
    message whose body is the problem.
    """
    for number, line in lines:
        if isinstance(line, HfpRecordError):
            yield Message(number, line)
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
            yield Message(number, _unreadable(exc))
        else:
            yield Message(number, message, vehicle_id, mode)


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
        bool(names & VEHICLE_FIELDS)
        and bool(names.intersection(LATITUDE_FIELDS))
        and bool(names & {"tst", "tsi"})
    )


def _csv_rows(lines: Iterable[Line]) -> Iterator[tuple[int, list[str] | HfpRecordError]]:
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


def csv_messages(lines: Iterable[Line], path: Path) -> Iterator[Message]:
    """The messages of an HFP CSV archive: its header, then one message per row.

    Each row is a message ``{event: {column: text}}`` keyed by the column names in lower
    case; the event is the row's ``event_type`` (``eventType``), ``VP`` where the archive
    has no such column. Blank rows are skipped; a row that cannot be read, or that has
    another number of fields than the header, is a message whose body is the problem.

    Raises
    ------
    ReplayError
        The file is empty, or its header is unreadable or does not name the HFP fields
        (:func:`looks_like_hfp_csv`); ``path`` is the file, for the message.
    """
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
            yield Message(number, row)
            continue
        if all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            yield Message(
                number, HfpRecordError(f"{len(row)} fields, the header has {len(header)}")
            )
            continue
        fields = dict(zip(lower, row, strict=True))
        event = row[event_col].strip().upper() if event_col is not None else HFP_EVENT
        yield Message(number, {event or HFP_EVENT: fields})


#: Bytes of a file's first line read to tell its form (CSV or JSON, lines or an array).
SNIFF_BYTES: Final = 1 << 16


def _decoded(data: bytes) -> str:
    return data.decode("utf-8", errors="surrogateescape")


def first_line(path: Path) -> str:
    """The start (up to :data:`SNIFF_BYTES`) of the first line of a file's content that
    is not blank, "" when it has none: what tells CSV from JSON, and JSON lines from an
    array. A compressed file is read as its content.

    Raises
    ------
    InputFileError
        The file is missing or unreadable, or compressed and damaged from its start.
    """
    with open_input(path, what="HFP log") as stream:
        try:
            chunk = stream.read(SNIFF_BYTES)
            cut = None if chunk else stream_problem(stream)
            text = _decoded(chunk).removeprefix("\ufeff")
            while text and not text.lstrip():  # white space, however much of it
                text = _decoded(stream.read(SNIFF_BYTES))
            text = text.lstrip()
            if "\n" not in text and "\r" not in text:
                text += _decoded(stream.read(SNIFF_BYTES))
        except OSError as exc:
            raise InputFileError(f"{path}: cannot read the HFP log: {exc.strerror or exc}") from exc
    if cut is not None:
        raise InputFileError(f"{path}: cannot read the HFP log: {cut}")
    return text.replace("\r", "\n").split("\n", 1)[0]
