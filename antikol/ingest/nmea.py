"""NMEA 0183 ingest: turn a vehicle's own GPS receiver output into vehicle reports.

The sentences are parsed and checksum-validated by :mod:`pynmeagps`; this module decides
which sentences belong together, converts units and rejects everything doubtful, counting
every rejection by reason (:class:`NmeaStats`) and logging it at DEBUG level. Nothing read
from the stream ever raises out of :class:`NmeaReader`.

Sentences
---------
``RMC``
    Time, date, fix status, position, speed over ground (knots), course over ground. One
    report is produced per RMC *epoch* (one UTC time of day). Mode indicator ``E`` (the
    receiver's dead reckoning) gives ``fix_quality`` 6 where no GGA says otherwise.
``GGA``
    Fix quality and HDOP of the epoch with the same UTC time; they enrich the report
    (``fix_quality``, ``hdop``). The position of the report is always RMC's.
``VTG``
    Course and speed (knots and/or km/h) without a time; it belongs to the epoch in
    progress and fills RMC's empty course or speed fields (RMC's values win when present).

Talkers ``GP``, ``GN``, ``GL``, ``GA``, ``GB``, ``BD``, ``GQ`` and ``GI`` are accepted and
may be mixed; sentences of other talkers or types are skipped as ``"unsupported"``.

Decisions
---------
Time
    ``t`` is seconds since the Unix epoch, UTC, from RMC's date (``ddmmyy``, years
    1969–2068) and time of day; a report at midnight gets the new date from its own RMC, so
    the day rollover needs no special handling. GGA is matched to RMC by time of day.
    A report whose ``t`` equals the previous report's is skipped (``"duplicate"``, e.g. a
    GPRMC and a GNRMC of the same fix).
Time jumps
    A report is emitted when its ``t`` follows the previous report's by more than 0 and
    at most ``max_time_jump_s`` (60 s by default). A report earlier than the previous one
    (``"time_backwards"``) or later by more than that (``"time_jump"``: a sentence dated a
    year ahead, or the first fix after a long outage) is held back as the start of a new
    timeline; if the next report follows *it* within ``max_time_jump_s``, the receiver
    has really moved on (or back): that report is emitted, the new timeline adopted and
    the event counted in :attr:`NmeaStats.flagged` as ``"time_reset"``. So one sentence
    with a wrong date costs one epoch, never every later one; a genuine jump costs the
    first epoch after it.
Midnight
    A receiver that changes the date late (``000000`` still with yesterday's date) or
    early (``235959`` with tomorrow's) gets the date that makes the time follow the
    previous report's within two minutes (flagged ``"date_late"`` or ``"date_early"``).
    A leap second (``235960``) is kept: it is dated in the last millisecond of its day
    (``t`` = midnight - 1 ms + fraction / 1000), after every report of ``235959.x`` and
    before the next day's first, and flagged ``"leap_second"``.
Epoch closing
    The epoch in progress is closed, and its report emitted, at the first of:

    1. it is *complete*: its RMC has arrived, RMC gives both speed and course or a VTG of
       the epoch has arrived, and its GGA has arrived (or the stream has not carried any
       GGA so far). Most receivers thus yield the report on the last sentence of the
       epoch, with no extra latency;
    2. a sentence of another epoch arrives (an RMC or GGA with another time of day);
    3. :meth:`NmeaReader.flush` is called (end of the stream; :func:`read_nmea_file`
       calls it).

    Consequently the very first report of a stream may lack ``hdop``/``fix_quality``
    (the reader has not yet learnt that the receiver sends GGA); a VTG arriving after its
    epoch was closed is skipped as ``"unpaired"``; and an RMC with an empty speed or
    course field (a stopped vehicle) on a receiver without VTG is emitted one epoch late,
    when the next epoch starts.
Void fixes
    RMC status ``V``, an RMC/VTG mode indicator ``N`` or GGA quality 0 voids the whole
    epoch: all its sentences are skipped as ``"void_fix"``.
Missing course
    Receivers leave the course empty when standing still. When neither RMC nor VTG gives
    a course and the speed is below ``stopped_speed_mps`` (0.5 m/s by default), the report
    carries the last course this reader emitted (0.0 if none yet) and the event is counted
    in :attr:`NmeaStats.flagged` as ``"course_missing"`` (the analyser keeps the last valid
    course of a slow vehicle anyway). At or above that speed the epoch is skipped as
    ``"no_course"``; without any speed it is skipped as ``"no_speed"``.
Units
    Knots are converted with the exact factor 1852/3600 (:data:`KNOT_MPS`), km/h by
    dividing by 3.6.

Rejection reasons
-----------------
Counted per sentence in :attr:`NmeaStats.skipped` (a line without any ``$`` counts once;
the sentences of a skipped epoch all count under the epoch's reason):
``"empty"``, ``"not_nmea"``, ``"garbled"``, ``"checksum"``, ``"unsupported"``,
``"void_fix"``, ``"no_time"``, ``"invalid_value"``, ``"no_speed"``, ``"no_course"``,
``"unpaired"``, ``"duplicate"``, ``"time_backwards"``, ``"time_jump"``, ``"too_long"``
(see :data:`SKIP_REASONS`).

Writer
------
:func:`~antikol.ingest.nmea_writer.format_rmc`, ``format_gga`` and ``format_vtg`` live in
:mod:`antikol.ingest.nmea_writer`; they are re-exported here for existing callers.
"""

from __future__ import annotations

import logging
import math
import os
import re
from collections import Counter
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime, time
from pathlib import Path
from typing import Final

from pynmeagps import VALCKSUM, NMEAMessage, NMEAReader
from pynmeagps.exceptions import NMEAMessageError, NMEAParseError, NMEATypeError
from pynmeagps.nmeahelpers import calc_checksum, get_parts

from antikol.errors import InputFileError, InvalidReportError
from antikol.ingest.compressed import logical_stem, logical_suffix, open_input, stream_problem
from antikol.ingest.nmea_fields import (
    LEAP_SECOND,
    MAX_LINE_BYTES,
    SkipSentence,
    log_lines,
    parse_coordinate,
    parse_course,
    parse_rmc_date,
    parse_speed,
    parse_time_of_day,
    raw_field,
)
from antikol.ingest.nmea_spec import (
    GNSS_TALKERS,
    KMH_PER_MPS,
    KNOT_MPS,
    MAX_YEAR,
    MIN_YEAR,
    UNIX_EPOCH,
)
from antikol.ingest.nmea_writer import format_gga, format_rmc, format_vtg
from antikol.report import ESTIMATED_FIX_QUALITY, VehicleReport
from antikol.thresholds import STANDING_SPEED_MPS

# GNSS_TALKERS, KMH_PER_MPS and KNOT_MPS (nmea_spec) and the format_* writers (nmea_writer)
# are re-exported: they were defined here before the writer moved out.
__all__ = [
    "FILE_SUFFIXES",
    "GNSS_TALKERS",
    "KMH_PER_MPS",
    "KNOT_MPS",
    "SKIP_REASONS",
    "STOPPED_SPEED_MPS",
    "NmeaReader",
    "NmeaStats",
    "format_gga",
    "format_rmc",
    "format_vtg",
    "list_nmea_files",
    "read_nmea_directory",
    "read_nmea_file",
]

logger = logging.getLogger(__name__)

#: File name suffixes read by :func:`read_nmea_directory` (case-insensitive).
FILE_SUFFIXES: Final = (".nmea", ".txt", ".log")
#: Default speed below which a missing course is tolerated, m/s.
STOPPED_SPEED_MPS: Final = STANDING_SPEED_MPS

#: Why a line or sentence was skipped (keys of :attr:`NmeaStats.skipped`).
SKIP_REASONS: Final[dict[str, str]] = {
    "empty": "blank line",
    "not_nmea": "line without any '$' (text, binary data, a line cut before its '$')",
    "garbled": "truncated or malformed sentence, missing checksum, unparsable field",
    "checksum": "checksum does not match the sentence",
    "unsupported": "sentence type or talker not used (GSA, GSV, GLL, proprietary, ...)",
    "void_fix": "RMC status V, mode indicator N or GGA quality 0 (whole epoch)",
    "no_time": "RMC without a valid date and time, or GGA without a valid time",
    "invalid_value": "a value out of range or not finite (position, speed, course, HDOP)",
    "no_speed": "neither RMC nor VTG gives a speed",
    "no_course": "no course while moving at or above the stopped-speed threshold",
    "unpaired": "GGA or VTG whose epoch has no usable RMC, or that came after it closed",
    "duplicate": "second sentence of a kind in one epoch, or a report time repeated",
    "time_backwards": "report time earlier than the previous report's",
    "time_jump": "report time later than the previous report's by more than max_time_jump_s",
    "too_long": f"line longer than {MAX_LINE_BYTES} bytes (a sentence has at most 82)",
}

#: Sentence types used, with the fields they need at least (through date, HDOP, km/h unit).
_MIN_FIELDS: Final = {"RMC": 9, "GGA": 8, "VTG": 8}
_SENTENCE = re.compile(r"\$(?P<content>[^$*]*)\*(?P<checksum>[0-9A-Fa-f]{2})")
#: A late or early date change is recognised within this time of midnight, s.
_MIDNIGHT_S: Final = 120.0
_DAY_S: Final = 86400.0
_NOT_IN_FIELDS = re.compile(r"[\s_]")  # Python's float()/int() would tolerate them
_STRIP = " \t\r\n\x00"


@dataclass
class NmeaStats:
    """Counters of one NMEA stream.

    Attributes
    ----------
    lines : int
        Lines fed to the reader.
    accepted : int
        Reports emitted.
    used : int
        Sentences that went into emitted reports.
    skipped : collections.Counter of str
        Skipped sentences by reason (see :data:`SKIP_REASONS`). A line without a sentence
        counts once; the sentences of a skipped epoch all count under its reason. After
        :meth:`NmeaReader.flush`, ``used + total_skipped`` equals the number of lines when
        every line holds at most one ``$``.
    flagged : collections.Counter of str
        Emitted reports with a substituted value, by kind (``"course_missing"``).
    cut : str or None
        Why a compressed log ended early (its stream cut short or damaged), else None.
    """

    lines: int = 0
    accepted: int = 0
    used: int = 0
    skipped: Counter[str] = field(default_factory=Counter)
    flagged: Counter[str] = field(default_factory=Counter)
    cut: str | None = None

    @property
    def total_skipped(self) -> int:
        """Number of skipped sentences (and sentence-less lines), all reasons."""
        return sum(self.skipped.values())

    def as_dict(self) -> dict[str, object]:
        """Plain-dict copy, e.g. for JSON output."""
        return {
            "lines": self.lines,
            "accepted": self.accepted,
            "used": self.used,
            "skipped": dict(sorted(self.skipped.items())),
            "flagged": dict(sorted(self.flagged.items())),
        }


@dataclass(slots=True)
class _Rmc:
    t: float
    lat: float
    lon: float
    speed_mps: float | None
    course_deg: float | None
    estimated: bool = False  # mode indicator E: the receiver's dead reckoning


@dataclass(slots=True)
class _Vtg:
    speed_mps: float | None
    course_deg: float | None


@dataclass(slots=True)
class _Epoch:
    tod: time | None
    rmc: _Rmc | None = None
    gga_seen: bool = False
    fix_quality: int | None = None
    hdop: float | None = None
    vtg_seen: bool = False
    vtg: _Vtg | None = None
    void: bool = False
    held: int = 0  # sentences attached to the epoch, not yet counted


class NmeaReader:
    """Incremental reader of one vehicle's NMEA 0183 stream.

    Feed lines with :meth:`feed_line` or :meth:`feed`; each returns the reports whose
    epochs were closed by that input. Call :meth:`flush` at the end of the stream to get
    the epoch still in progress. See the module documentation for the epoch rules.

    Parameters
    ----------
    vehicle_id : str
        Identifier put in every report (1 to 32 UTF-8 bytes).
    length_m : float, optional
        Vehicle length put in every report, metres.
    antenna_offset_m : float, optional
        Distance from the vehicle front back to the antenna put in every report, metres.
    stopped_speed_mps : float, optional
        Below this speed (m/s) a missing course is tolerated (default 0.5).
    max_time_jump_s : float, optional
        Largest step between two reports taken without confirmation, s (default 60; see
        *Time jumps* in the module documentation).

    Raises
    ------
    InvalidReportError
        ``vehicle_id``, ``length_m`` or ``antenna_offset_m`` is invalid (names the field).
        Also raised, naming it, when ``stopped_speed_mps`` is negative or not finite.
    """

    def __init__(
        self,
        vehicle_id: str,
        *,
        length_m: float | None = None,
        antenna_offset_m: float | None = None,
        stopped_speed_mps: float = STOPPED_SPEED_MPS,
        max_time_jump_s: float = 60.0,
    ) -> None:
        # Validate the constant fields once, with the report's own rules.
        VehicleReport(
            vehicle_id,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            length_m=length_m,
            antenna_offset_m=antenna_offset_m,
        )
        if not (math.isfinite(stopped_speed_mps) and stopped_speed_mps >= 0.0):
            raise InvalidReportError(
                "stopped_speed_mps", stopped_speed_mps, "must be finite and >= 0 m/s"
            )
        self.vehicle_id = vehicle_id
        self.length_m = length_m
        self.antenna_offset_m = antenna_offset_m
        if not (math.isfinite(max_time_jump_s) and max_time_jump_s > 0.0):
            raise InvalidReportError("max_time_jump_s", max_time_jump_s, "must be finite and > 0 s")
        self.stopped_speed_mps = float(stopped_speed_mps)
        self.max_time_jump_s = float(max_time_jump_s)
        self._candidate_t: float | None = None
        self._stats = NmeaStats()
        self._pending: _Epoch | None = None
        self._stream_has_gga = False
        self._last_t: float | None = None
        self._last_tod: time | None = None
        self._last_course: float | None = None

    @property
    def stats(self) -> NmeaStats:
        """Live counters of this reader (:class:`NmeaStats`)."""
        return self._stats

    # ------------------------------------------------------------------ input
    def feed_line(self, line: str | bytes) -> list[VehicleReport]:
        """Process one line of receiver output.

        Parameters
        ----------
        line : str or bytes
            One line, with or without its CR/LF; bytes are decoded as ASCII (invalid bytes
            make the sentence containing them ``"garbled"``). Leading garbage before the
            ``$`` is ignored. Several sentences glued on one line are read one by one. A
            line longer than ``MAX_LINE_BYTES`` is skipped whole (``"too_long"``).

        Returns
        -------
        list of VehicleReport
            Reports of the epochs this line closed (usually zero or one).
        """
        self._stats.lines += 1
        out: list[VehicleReport] = []
        if isinstance(line, (bytes, bytearray, memoryview)):
            text = bytes(line).decode("ascii", errors="replace")
        elif isinstance(line, str):
            text = line
        else:
            self._skip("garbled", f"not a str or bytes line: {type(line).__name__}")
            return out
        if len(text) > MAX_LINE_BYTES:  # no receiver's line: not searched for sentences
            self._skip("too_long", f"a line of {len(text):,} characters")
            return out
        text = text.strip(_STRIP)
        if not text:
            self._skip("empty", "blank line")
            return out
        start = text.find("$")
        if start < 0:
            self._skip("not_nmea", repr(text[:80]))
            return out
        if start > 0:
            logger.debug("%s: ignored leading garbage %r", self.vehicle_id, text[:start][:80])
        for piece in text[start:].split("$")[1:]:
            self._feed_sentence("$" + piece.strip(_STRIP), out)
        return out

    def feed(self, lines: Iterable[str | bytes]) -> Iterator[VehicleReport]:
        """Process many lines, yielding reports as their epochs close.

        The epoch in progress at the end is *not* emitted: call :meth:`flush` when the
        stream has ended.

        Parameters
        ----------
        lines : iterable of str or bytes
            Lines of receiver output (see :meth:`feed_line`).

        Yields
        ------
        VehicleReport
            Reports in stream order.
        """
        for line in lines:
            yield from self.feed_line(line)

    def flush(self) -> list[VehicleReport]:
        """Close the epoch in progress (end of stream).

        Returns
        -------
        list of VehicleReport
            Its report, if it yields one (zero or one element).
        """
        out: list[VehicleReport] = []
        self._close(out)
        return out

    # --------------------------------------------------------------- sentences
    def _feed_sentence(self, sentence: str, out: list[VehicleReport]) -> None:
        try:
            msg_type, msg = self._parse(sentence)
            if msg_type == "RMC":
                self._on_rmc(msg, out)
            elif msg_type == "GGA":
                self._on_gga(msg, out)
            else:
                self._on_vtg(msg, out)
        except SkipSentence as skip:
            self._skip(skip.reason, f"{skip.detail}: {sentence[:100]!r}")

    def _parse(self, sentence: str) -> tuple[str, NMEAMessage]:
        match = _SENTENCE.fullmatch(sentence)
        if match is None:
            raise SkipSentence("garbled", "not a complete '$...*hh' sentence")
        content = match["content"]
        if not (content.isascii() and content.isprintable()):
            raise SkipSentence("garbled", "non-ASCII or control characters")
        if calc_checksum(content) != match["checksum"].upper():
            raise SkipSentence("checksum", f"checksum should be {calc_checksum(content)}")
        _, talker, msg_type, _, _ = get_parts(sentence)
        if msg_type not in _MIN_FIELDS:
            raise SkipSentence("unsupported", "sentence type not used")
        if talker not in GNSS_TALKERS:
            raise SkipSentence("unsupported", f"talker {talker} is not a GNSS receiver")
        if _NOT_IN_FIELDS.search(content):
            raise SkipSentence("garbled", "whitespace or '_' in a field")
        try:
            msg = NMEAReader.parse(sentence.encode("ascii"), validate=VALCKSUM)
        except NMEAParseError as err:  # pynmeagps's own checksum verdict
            raise SkipSentence("checksum", str(err)) from err
        except (NMEATypeError, NMEAMessageError, ValueError, IndexError, KeyError) as err:
            raise SkipSentence("garbled", f"unparsable field ({err})") from err
        if msg is None:
            raise SkipSentence("garbled", "badly formed")
        if len(msg.payload) < _MIN_FIELDS[msg_type]:
            raise SkipSentence("garbled", f"only {len(msg.payload)} fields")
        return msg_type, msg

    def _on_rmc(self, msg: NMEAMessage, out: list[VehicleReport]) -> None:
        status = getattr(msg, "status", "")
        mode = getattr(msg, "posMode", "")
        tod = parse_time_of_day(msg)
        if status not in ("A", "V"):
            raise SkipSentence("garbled", f"RMC status {status!r}")
        if status == "V" or mode == "N":
            self._void(tod, out, f"RMC status {status}, mode {mode or '-'}")
            return
        day = parse_rmc_date(msg)
        if tod is None or day is None:
            raise SkipSentence("no_time", "RMC without valid date and time")
        if not MIN_YEAR <= day.year <= MAX_YEAR:  # pragma: no cover - strptime %y range
            raise SkipSentence("no_time", f"RMC year {day.year}")
        t = (datetime.combine(day, tod, tzinfo=UTC) - UNIX_EPOCH).total_seconds()
        if tod.microsecond >= 999000 and LEAP_SECOND.fullmatch(raw_field(msg, 0)):
            self._stats.flagged["leap_second"] += 1
        t = self._midnight(t, tod)
        lat = parse_coordinate(msg, 2, "lat", "NS", 90.0)
        lon = parse_coordinate(msg, 4, "lon", "EW", 180.0)
        speed = parse_speed(getattr(msg, "spd", None), "kn", "RMC speed")
        course = parse_course(getattr(msg, "cog", None), "RMC course")
        if t == self._last_t:
            raise SkipSentence("duplicate", f"time {t} already reported")
        epoch = self._epoch_for(tod, out)
        if epoch.void:
            self._skip("void_fix", "RMC of a void epoch")
            return
        if epoch.rmc is not None:
            raise SkipSentence("duplicate", "second RMC of the epoch")
        epoch.rmc = _Rmc(t, lat, lon, speed, course, estimated=mode == "E")
        epoch.held += 1
        self._close_if_complete(out)

    def _on_gga(self, msg: NMEAMessage, out: list[VehicleReport]) -> None:
        self._stream_has_gga = True
        tod = parse_time_of_day(msg)
        quality = getattr(msg, "quality", "")
        if not isinstance(quality, int):
            raise SkipSentence("garbled", "GGA without fix quality")
        if quality == 0:
            self._void(tod, out, "GGA quality 0")
            return
        if tod is None:
            raise SkipSentence("no_time", "GGA without valid time")
        if not 0 < quality <= 9:
            raise SkipSentence("invalid_value", f"GGA quality {quality}")
        hdop = getattr(msg, "HDOP", "")
        if hdop == "":
            hdop = None
        elif not (isinstance(hdop, float) and math.isfinite(hdop) and hdop >= 0.0):
            raise SkipSentence("invalid_value", f"HDOP {hdop!r}")
        if self._pending is None and tod == self._last_tod:
            raise SkipSentence("unpaired", "GGA after its epoch was closed")
        epoch = self._epoch_for(tod, out)
        if epoch.void:
            self._skip("void_fix", "GGA of a void epoch")
            return
        if epoch.gga_seen:
            raise SkipSentence("duplicate", "second GGA of the epoch")
        epoch.gga_seen = True
        epoch.fix_quality = quality
        epoch.hdop = hdop
        epoch.held += 1
        self._close_if_complete(out)

    def _on_vtg(self, msg: NMEAMessage, out: list[VehicleReport]) -> None:
        for name, unit in (("cogtUnit", "T"), ("sognUnit", "N"), ("sogkUnit", "K")):
            if getattr(msg, name, "") not in ("", unit):
                raise SkipSentence("garbled", f"VTG {name} {getattr(msg, name)!r}")
        data: _Vtg | None = None  # None: void VTG (mode N)
        if getattr(msg, "posMode", "") != "N":
            course = parse_course(getattr(msg, "cogt", None), "VTG course")
            speed = parse_speed(getattr(msg, "sogn", None), "kn", "VTG speed")
            if speed is None:
                speed = parse_speed(getattr(msg, "sogk", None), "km/h", "VTG speed")
            data = _Vtg(speed, course)
        epoch = self._pending
        if epoch is None:
            raise SkipSentence("unpaired", "VTG with no epoch in progress")
        if epoch.void:
            self._skip("void_fix", "VTG of a void epoch")
            return
        if epoch.vtg_seen:
            raise SkipSentence("duplicate", "second VTG of the epoch")
        epoch.vtg_seen = True
        if data is None:
            self._skip("void_fix", "VTG mode N")
        else:
            epoch.vtg = data
            epoch.held += 1
        self._close_if_complete(out)

    # ------------------------------------------------------------------ epochs
    def _epoch_for(self, tod: time, out: list[VehicleReport]) -> _Epoch:
        """The epoch of time of day ``tod``, closing the pending one if it differs."""
        if self._pending is not None and self._pending.tod != tod:
            self._close(out)
        if self._pending is None:
            self._pending = _Epoch(tod)
        return self._pending

    def _void(self, tod: time | None, out: list[VehicleReport], detail: str) -> None:
        self._skip("void_fix", detail)
        if tod is None:
            return
        epoch = self._epoch_for(tod, out)
        epoch.void = True

    def _close_if_complete(self, out: list[VehicleReport]) -> None:
        epoch = self._pending
        if epoch is None or epoch.rmc is None:
            return
        motion_known = epoch.vtg_seen or (
            epoch.rmc.speed_mps is not None and epoch.rmc.course_deg is not None
        )
        if motion_known and (epoch.gga_seen or not self._stream_has_gga):
            self._close(out)

    def _close(self, out: list[VehicleReport]) -> None:
        epoch, self._pending = self._pending, None
        if epoch is None:
            return
        if epoch.rmc is not None or epoch.void:
            self._last_tod = epoch.tod
        try:
            report = self._report(epoch)
        except SkipSentence as skip:
            if epoch.held:
                self._skip(skip.reason, skip.detail, epoch.held)
            return
        self._stats.used += epoch.held
        self._stats.accepted += 1
        self._last_t = report.t
        out.append(report)

    def _report(self, epoch: _Epoch) -> VehicleReport:
        if epoch.void:
            raise SkipSentence("void_fix", f"epoch {epoch.tod} is void")
        rmc = epoch.rmc
        if rmc is None:
            raise SkipSentence("unpaired", f"epoch {epoch.tod} has no usable RMC")
        vtg = epoch.vtg or _Vtg(None, None)
        speed = rmc.speed_mps if rmc.speed_mps is not None else vtg.speed_mps
        course = rmc.course_deg if rmc.course_deg is not None else vtg.course_deg
        if speed is None:
            raise SkipSentence("no_speed", f"epoch {epoch.tod} has no speed")
        self._check_time(rmc.t)
        course_missing = course is None
        if course is None:
            if speed >= self.stopped_speed_mps:
                raise SkipSentence("no_course", f"epoch {epoch.tod}: no course at {speed:.2f} m/s")
            course = self._last_course if self._last_course is not None else 0.0
        try:
            report = VehicleReport(
                self.vehicle_id,
                rmc.t,
                rmc.lat,
                rmc.lon,
                speed,
                course,
                length_m=self.length_m,
                antenna_offset_m=self.antenna_offset_m,
                hdop=epoch.hdop,
                fix_quality=epoch.fix_quality
                if epoch.fix_quality is not None or not rmc.estimated
                else ESTIMATED_FIX_QUALITY,
            )
        except InvalidReportError as err:
            raise SkipSentence("invalid_value", str(err)) from err
        if course_missing:
            self._stats.flagged["course_missing"] += 1
            logger.debug("%s: course missing at t=%s, using %s", self.vehicle_id, rmc.t, course)
        else:
            self._last_course = report.course_deg
        return report

    def _midnight(self, t: float, tod: time) -> float:
        """Correct a date changed late or early at midnight (see *Midnight*)."""
        last = self._last_t
        if last is None or abs(t - last) < _DAY_S / 2:
            return t
        seconds = tod.hour * 3600 + tod.minute * 60 + tod.second
        if seconds < _MIDNIGHT_S and 0 < t + _DAY_S - last <= _MIDNIGHT_S:
            self._stats.flagged["date_late"] += 1
            return t + _DAY_S
        if seconds > _DAY_S - _MIDNIGHT_S and 0 < t - _DAY_S - last <= _MIDNIGHT_S:
            self._stats.flagged["date_early"] += 1
            return t - _DAY_S
        return t

    def _check_time(self, t: float) -> None:
        """Accept ``t`` as the next report time or raise (see *Time jumps*)."""
        last = self._last_t
        if last is None or 0.0 < t - last <= self.max_time_jump_s:
            self._candidate_t = None
            return
        if t == last:
            raise SkipSentence("duplicate", f"time {t} already reported")
        cand = self._candidate_t
        if cand is not None and 0.0 < t - cand <= self.max_time_jump_s:
            self._candidate_t = None
            self._stats.flagged["time_reset"] += 1
            logger.warning(
                "%s: receiver time moved from %.3f to %.3f and stayed there: adopted",
                self.vehicle_id,
                last,
                t,
            )
            return
        self._candidate_t = t
        if t < last:
            raise SkipSentence("time_backwards", f"time {t} before {last}")
        raise SkipSentence("time_jump", f"time {t} is {t - last:.1f} s after {last}")

    def _skip(self, reason: str, detail: str, count: int = 1) -> None:
        self._stats.skipped[reason] += count
        logger.debug("%s: skipped %d (%s): %s", self.vehicle_id, count, reason, detail)


# --------------------------------------------------------------------------- files
def read_nmea_file(
    path: str | os.PathLike[str],
    vehicle_id: str | None = None,
    *,
    length_m: float | None = None,
    antenna_offset_m: float | None = None,
) -> tuple[list[VehicleReport], NmeaStats]:
    """Read one vehicle's NMEA log.

    Parameters
    ----------
    path : str or os.PathLike
        The log file: one sentence per line (LF, CRLF or CR line ends). A line longer than
        ``MAX_LINE_BYTES`` is skipped as ``"too_long"`` and read past without being held.
    vehicle_id : str, optional
        Identifier of the vehicle; defaults to the file name without its suffix (and
        without a compression suffix: ``t1.nmea.gz`` is ``t1``).
    length_m, antenna_offset_m : float, optional
        Put in every report, metres (see :class:`NmeaReader`).

    Returns
    -------
    reports : list of VehicleReport
        The reports in file order (the reader is flushed at the end of the file).
    stats : NmeaStats
        Counters of accepted and skipped sentences.

    Raises
    ------
    InputFileError
        The file is missing or unreadable (also an ``OSError``); the message names it.
    InvalidReportError
        The vehicle identifier (e.g. a too long file name) or an option is invalid.
    """
    file = Path(path)
    reports: list[VehicleReport] = []
    with open_input(file, what="NMEA file") as stream:
        reader = NmeaReader(
            logical_stem(file) if vehicle_id is None else vehicle_id,
            length_m=length_m,
            antenna_offset_m=antenna_offset_m,
        )
        try:
            for line in log_lines(stream):  # an over-long line is not held, only its start
                reports.extend(reader.feed_line(line))
        except OSError as err:
            raise InputFileError(f"cannot read NMEA file {str(file)!r}: {err}") from err
        cut = stream_problem(stream)
    reports.extend(reader.flush())
    reader.stats.cut = cut
    return reports, reader.stats


def list_nmea_files(path: str | os.PathLike[str]) -> list[Path]:
    """The files of a directory that may be NMEA logs, sorted by name.

    Names ending in ``.nmea``, ``.txt`` or ``.log`` (any case), also followed by ``.gz``,
    ``.bz2`` or ``.xz``; not recursively.

    Raises
    ------
    InputFileError
        ``path`` is not a readable directory.
    """
    directory = Path(path)
    if not directory.is_dir():
        raise InputFileError(f"not a directory of NMEA files: {str(directory)!r}")
    try:
        return sorted(
            p for p in directory.iterdir() if logical_suffix(p) in FILE_SUFFIXES and p.is_file()
        )
    except OSError as err:
        raise InputFileError(f"cannot list directory {str(directory)!r}: {err}") from err


def read_nmea_directory(
    path: str | os.PathLike[str],
) -> tuple[dict[str, list[VehicleReport]], dict[str, NmeaStats]]:
    """Read a directory of NMEA logs, one file per vehicle.

    Files whose names end in ``.nmea``, ``.txt`` or ``.log`` (any case) are read, not
    recursively, each possibly compressed with gzip, bzip2, xz or zstd (``t1.nmea.gz``); each
    file's name without its suffixes is the vehicle identifier.

    Parameters
    ----------
    path : str or os.PathLike
        The directory.

    Returns
    -------
    reports : dict of str to list of VehicleReport
        Reports per vehicle identifier, in sorted identifier order.
    stats : dict of str to NmeaStats
        Counters per vehicle identifier.

    Raises
    ------
    InputFileError
        ``path`` is not a readable directory, holds no NMEA file, holds two files of the
        same vehicle (e.g. ``t1.nmea`` and ``t1.log``) or a file cannot be read.
    InvalidReportError
        A file name is not a valid vehicle identifier.
    """
    directory = Path(path)
    files = list_nmea_files(directory)
    if not files:
        raise InputFileError(
            f"no NMEA files ({', '.join('*' + s for s in FILE_SUFFIXES)}) in {str(directory)!r}"
        )
    by_vehicle: dict[str, Path] = {}
    for file in files:
        vehicle = logical_stem(file)
        if vehicle in by_vehicle:
            raise InputFileError(
                f"two files for vehicle {vehicle!r}: {by_vehicle[vehicle].name!r} and "
                f"{file.name!r} in {str(directory)!r}"
            )
        by_vehicle[vehicle] = file
    reports: dict[str, list[VehicleReport]] = {}
    stats: dict[str, NmeaStats] = {}
    for vehicle_id in sorted(by_vehicle):
        reports[vehicle_id], stats[vehicle_id] = read_nmea_file(by_vehicle[vehicle_id])
    return reports, stats
