"""NMEA 0183 writer: RMC, GGA and VTG sentences from vehicle reports.

For tests and the simulator's per-vehicle NMEA logs; :mod:`antikol.ingest.nmea` reads
them back. pynmeagps builds every sentence from typed fields
(:class:`pynmeagps.NMEAMessage`): it prints the time as ``hhmmss.ss``, the date as
``ddmmyy``, latitude and longitude as ``(d)ddmm.mmmmm`` with the hemisphere from the sign,
and appends the checksum. This module only rounds the values to the printed resolution
first — time 0.01 s, latitude/longitude 0.00001 arc minute, speed 0.001 kn (and 0.001
km/h), course 0.01 degree, HDOP 0.01, altitude 0.1 m — and decimal fields carry as many
decimals as they need (``22.4``, not ``22.400``).
"""

from __future__ import annotations

import math
from datetime import datetime, timedelta
from typing import Final, Literal

from pynmeagps import GET, NMEAMessage

from antikol.errors import ProtocolError
from antikol.ingest.nmea_spec import (
    GNSS_TALKERS,
    KMH_PER_MPS,
    KNOT_MPS,
    MAX_YEAR,
    MIN_YEAR,
    UNIX_EPOCH,
)
from antikol.report import VehicleReport

__all__ = ["format_gga", "format_rmc", "format_vtg"]

_POS_MODES: Final = {2: "D", 4: "R", 5: "F", 6: "E"}  # GGA quality -> RMC/VTG mode indicator
_UNITS_PER_DEGREE: Final = 60 * 100_000  # printed resolution: 0.00001 arc minute


def format_rmc(
    report: VehicleReport,
    *,
    talker: str = "GN",
    include_speed: bool = True,
    include_course: bool = True,
    void: bool = False,
) -> str:
    """Write an RMC sentence (NMEA 4.10 layout) for a report.

    Parameters
    ----------
    report : VehicleReport
        Time ``t`` (seconds since the Unix epoch, UTC, years 1969–2068), position
        (degrees), speed (m/s, printed in knots to 0.001 kn) and course (degrees, printed
        to 0.01).
    talker : str, optional
        Talker identifier, one of :data:`~antikol.ingest.nmea_spec.GNSS_TALKERS`
        (default ``"GN"``).
    include_speed, include_course : bool, optional
        Leave the speed or course field empty when false (as receivers do when stopped).
    void : bool, optional
        Write status ``V`` and mode ``N`` (no fix).

    Returns
    -------
    str
        The sentence ``$..RMC,...*hh`` without line terminator.

    Raises
    ------
    ProtocolError
        Unknown talker, or ``t`` outside the years a two-digit NMEA year can express.
    """
    stamp = _utc(report.t)
    status, mode = ("V", "N") if void else ("A", _POS_MODES.get(report.fix_quality or 1, "A"))
    return _sentence(
        talker,
        "RMC",
        time=stamp.time(),
        status=status,
        lat=_on_grid(report.lat),
        lon=_on_grid(report.lon),
        spd=_knots(report.speed_mps) if include_speed else "",
        cog=round(report.course_deg, 2) if include_course else "",
        date=stamp.date(),
        mv="",
        mvEW="",
        posMode=mode,
        navStatus="V",
    )


def format_gga(
    report: VehicleReport,
    *,
    talker: str = "GN",
    fix_quality: int | None = None,
    hdop: float | None = None,
    num_satellites: int = 12,
    altitude_m: float = 0.0,
) -> str:
    """Write a GGA sentence for a report.

    Parameters
    ----------
    report : VehicleReport
        Time ``t`` (seconds since the Unix epoch, UTC) and position (degrees).
    talker : str, optional
        Talker identifier, one of :data:`~antikol.ingest.nmea_spec.GNSS_TALKERS`
        (default ``"GN"``).
    fix_quality : int, optional
        Fix quality 0–9; default the report's ``fix_quality``, else 1 (GPS fix).
    hdop : float, optional
        Horizontal dilution of precision, printed to 0.01; default the report's ``hdop``,
        else 1.0.
    num_satellites : int, optional
        Satellites used, 0–99 (default 12).
    altitude_m : float, optional
        Antenna altitude above mean sea level, metres, printed to 0.1 (default 0).

    Returns
    -------
    str
        The sentence ``$..GGA,...*hh`` without line terminator.

    Raises
    ------
    ProtocolError
        Unknown talker, a value out of range, or ``t`` outside 1969–2068.
    """
    quality = fix_quality if fix_quality is not None else (report.fix_quality or 1)
    dop = hdop if hdop is not None else (report.hdop if report.hdop is not None else 1.0)
    if isinstance(quality, bool) or not isinstance(quality, int) or not 0 <= quality <= 9:
        raise ProtocolError(f"GGA fix quality must be an int 0..9, got {quality!r}")
    if not (math.isfinite(dop) and 0.0 <= dop < 1000.0):
        raise ProtocolError(f"GGA hdop must be in [0, 1000), got {dop!r}")
    if (
        isinstance(num_satellites, bool)
        or not isinstance(num_satellites, int)
        or not 0 <= num_satellites <= 99
    ):
        raise ProtocolError(f"GGA satellite count must be 0..99, got {num_satellites!r}")
    if not math.isfinite(altitude_m):
        raise ProtocolError(f"GGA altitude must be finite, got {altitude_m!r}")
    return _sentence(
        talker,
        "GGA",
        time=_utc(report.t).time(),
        lat=_on_grid(report.lat),
        lon=_on_grid(report.lon),
        quality=quality,
        numSV=num_satellites,
        HDOP=round(dop, 2),
        alt=round(altitude_m, 1),
        altUnit="M",
        sep=0.0,
        sepUnit="M",
        diffAge="",
        diffStation="",
    )


def format_vtg(
    report: VehicleReport,
    *,
    talker: str = "GN",
    include_course: bool = True,
    units: Literal["both", "knots", "kmh"] = "both",
) -> str:
    """Write a VTG sentence (course and speed) for a report.

    Parameters
    ----------
    report : VehicleReport
        Speed (m/s, printed to 0.001 kn and 0.001 km/h) and course (degrees, to 0.01).
    talker : str, optional
        Talker identifier, one of :data:`~antikol.ingest.nmea_spec.GNSS_TALKERS`
        (default ``"GN"``).
    include_course : bool, optional
        Leave the course field empty when false.
    units : {"both", "knots", "kmh"}, optional
        Which speed fields to fill (default both).

    Returns
    -------
    str
        The sentence ``$..VTG,...*hh`` without line terminator.

    Raises
    ------
    ProtocolError
        Unknown talker or units.
    """
    if units not in ("both", "knots", "kmh"):
        raise ProtocolError(f"VTG units must be 'both', 'knots' or 'kmh', got {units!r}")
    return _sentence(
        talker,
        "VTG",
        cogt=round(report.course_deg, 2) if include_course else "",
        cogtUnit="T",
        cogm="",
        cogmUnit="M",
        sogn=_knots(report.speed_mps) if units != "kmh" else "",
        sognUnit="N",
        sogk=round(report.speed_mps * KMH_PER_MPS, 3) if units != "knots" else "",
        sogkUnit="K",
        posMode=_POS_MODES.get(report.fix_quality or 1, "A"),
    )


def _sentence(talker: str, msg_id: str, **fields: object) -> str:
    """The checksummed sentence pynmeagps builds from typed fields (no line terminator)."""
    if talker not in GNSS_TALKERS:
        raise ProtocolError(f"talker must be one of {sorted(GNSS_TALKERS)}, got {talker!r}")
    # GET is pynmeagps's mode for what a receiver outputs; its SET mode only knows
    # configuration commands and would write RMC, GGA and VTG without any field.
    message = NMEAMessage(talker, msg_id, GET, **fields)
    return str(message.serialize().decode("ascii")).rstrip("\r\n")


def _utc(t: float) -> datetime:
    """Unix time ``t`` rounded to 0.01 s, as a UTC datetime in the two-digit NMEA years."""
    if not math.isfinite(t):
        raise ProtocolError(f"cannot write time t={t!r}")
    # whole centiseconds, so that pynmeagps's hhmmss.ss (which truncates) prints them exactly
    centis = round(t * 100.0)
    try:
        stamp = UNIX_EPOCH + timedelta(seconds=centis // 100, milliseconds=10 * (centis % 100))
    except OverflowError as err:
        raise ProtocolError(f"cannot write time t={t!r}: {err}") from err
    if not MIN_YEAR <= stamp.year <= MAX_YEAR:
        raise ProtocolError(
            f"t={t!r} is in {stamp.year}; NMEA two-digit years cover {MIN_YEAR}-{MAX_YEAR}"
        )
    return stamp


def _on_grid(degrees: float) -> float:
    """Degrees rounded to 0.00001 arc minute, the resolution pynmeagps prints.

    Rounding first keeps pynmeagps from printing ``60.00000`` minutes for a value just
    below a whole degree (it splits off the degrees before rounding the minutes).
    """
    return round(degrees * _UNITS_PER_DEGREE) / _UNITS_PER_DEGREE


def _knots(speed_mps: float) -> float:
    """Speed in knots rounded to 0.001 kn."""
    return round(speed_mps / KNOT_MPS, 3)
