"""Field parsers of the NMEA reader (:mod:`antikol.ingest.nmea`): time of day, date,
coordinates, speed and course of a parsed sentence, each rejecting doubtful values with
:class:`SkipSentence` (a reason of :data:`antikol.ingest.nmea.SKIP_REASONS`); and the
lines of a log file in bounded memory (:func:`log_lines`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from datetime import date, time
from typing import BinaryIO, Final, Literal

from pynmeagps import NMEAMessage

from antikol.ingest.nmea_spec import KMH_PER_MPS, KNOT_MPS
from antikol.report import MAX_SPEED_MPS

# Used by the reader only; public names so that it does not reach into private ones.
__all__ = [
    "LEAP_SECOND",
    "MAX_LINE_BYTES",
    "SkipSentence",
    "log_lines",
    "parse_coordinate",
    "parse_course",
    "parse_rmc_date",
    "parse_speed",
    "parse_time_of_day",
    "raw_field",
]

_HHMMSS = re.compile(r"\d{6}(?:\.\d{1,6})?")
_DDMMYY = re.compile(r"\d{6}")
LEAP_SECOND = re.compile(r"235960(?:\.(?P<frac>\d{1,6}))?")
_DDMM = re.compile(r"(?P<deg>\d{2,3})(?P<min>\d{2}\.\d+)")
#: A longer line is skipped as ``"too_long"``, bytes (or characters): a sentence has at
#: most 82 characters, so this leaves room for some 200 glued on one line.
MAX_LINE_BYTES: Final = 1 << 14
_LINE_END = re.compile(rb"\r\n|\r|\n")


class SkipSentence(Exception):
    """A sentence is rejected for ``reason`` (one of the reader's skip reasons)."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(detail)
        self.reason = reason
        self.detail = detail


def raw_field(msg: NMEAMessage, index: int) -> str:
    """The field at payload ``index`` as received (empty when the sentence is shorter)."""
    payload = msg.payload
    return str(payload[index]) if index < len(payload) else ""


def parse_time_of_day(msg: NMEAMessage) -> time | None:
    """UTC time of day of an RMC or GGA (first field ``hhmmss[.ss]``), ``None`` if invalid."""
    value = getattr(msg, "time", None)
    raw = raw_field(msg, 0)
    leap = LEAP_SECOND.fullmatch(raw)
    if leap is not None:  # 23:59:60.f: the last millisecond of the day (see *Midnight*)
        frac = leap["frac"] or "0"
        return time(23, 59, 59, 999000 + int(frac.ljust(6, "0")) // 1000)
    if not (isinstance(value, time) and _HHMMSS.fullmatch(raw)):
        return None
    return value


def parse_rmc_date(msg: NMEAMessage) -> date | None:
    """Date of an RMC (ninth field ``ddmmyy``), ``None`` if invalid."""
    value = getattr(msg, "date", None)
    if not (isinstance(value, date) and _DDMMYY.fullmatch(raw_field(msg, 8))):
        return None
    return value


def parse_coordinate(
    msg: NMEAMessage, index: int, name: str, hemi_name: str, limit: float
) -> float:
    """Signed degrees from the raw ``(d)ddmm.mmmm`` field at payload ``index``."""
    raw = raw_field(msg, index)
    hemi = getattr(msg, hemi_name, "")
    value = getattr(msg, name, "")
    match = _DDMM.fullmatch(raw)
    if match is None or not isinstance(value, float):
        raise SkipSentence("garbled", f"{name} {raw!r}")
    negative, positive = ("S", "N") if name == "lat" else ("W", "E")
    if hemi not in (negative, positive):
        raise SkipSentence("garbled", f"{hemi_name} {hemi!r}")
    # 60.0 is tolerated: some writers (pynmeagps's own ddd2dmm) round 59.999995 up to it.
    if float(match["min"]) > 60.0 or abs(value) > limit:
        raise SkipSentence("invalid_value", f"{name} {raw!r}")
    return -abs(value) if hemi == negative else abs(value)


def parse_speed(value: object, unit: Literal["kn", "km/h"], what: str) -> float | None:
    """Speed in m/s from a decoded field in knots or km/h (``None`` when empty).

    Knots are multiplied by 1852/3600, km/h divided by 3.6.
    """
    if value is None or value == "":
        return None
    if not (isinstance(value, float) and math.isfinite(value) and value >= 0.0):
        raise SkipSentence("invalid_value", f"{what} {value!r} {unit}")
    speed = value * KNOT_MPS if unit == "kn" else value / KMH_PER_MPS
    if speed > MAX_SPEED_MPS:
        raise SkipSentence("invalid_value", f"{what} {value!r} {unit} above {MAX_SPEED_MPS:g} m/s")
    return speed


def parse_course(value: object, what: str) -> float | None:
    """Course in degrees from a decoded field (``None`` when empty)."""
    if value is None or value == "":
        return None
    if not (isinstance(value, float) and 0.0 <= value <= 360.0):
        raise SkipSentence("invalid_value", f"{what} {value!r}")
    return 0.0 if value == 360.0 else value


def log_lines(
    stream: BinaryIO, limit: int = MAX_LINE_BYTES, *, chunk_bytes: int = 1 << 16
) -> Iterator[bytes]:
    """The lines of a binary stream without their ends (LF, CRLF or CR), in bounded memory.

    A line longer than ``limit`` bytes comes cut to its first ``limit + 1`` (so that the
    reader sees it is too long); the rest of it is read past, never held.

    Parameters
    ----------
    stream : binary file
    limit : int
        Longest line passed whole, bytes.
    chunk_bytes : int
        Bytes read at a time.

    Yields
    ------
    bytes
    """
    pending = b""  # the line in progress (unless it is too long: then head)
    head: bytes | None = None  # the start of a line in progress found too long
    while chunk := stream.read(chunk_bytes):
        data = pending + chunk
        hold = b""
        if data.endswith(b"\r"):  # maybe the first half of a CRLF split between reads
            data, hold = data[:-1], b"\r"
        parts = _LINE_END.split(data)
        pending = parts.pop() + hold
        for part in parts:
            yield (part if head is None else head)[: limit + 1]
            head = None
        if len(pending) - len(hold) > limit:
            head = pending[: limit + 1] if head is None else head
            pending = hold
    if head is not None or pending:  # a last line without its end (or ended by a CR)
        yield (pending.removesuffix(b"\r") if head is None else head)[: limit + 1]
