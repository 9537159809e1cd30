"""ETSI C-ITS Cooperative Awareness Messages (CAM) for vehicle reports.

Units that must speak C-ITS can send a :class:`~antikol.report.VehicleReport` as a CAM
(ETSI EN 302 637-2, CAM version 2, with the ITS-Container data elements of ETSI
TS 102 894-2) and read one back. The messages are UPER-encoded (unaligned packed encoding
rules) with the CAM ASN.1 module as compiled by pycrate (``pycrate_asn1dir.ITS_CAM_2``).

pycrate is optional (``pip install 'antikol[cits]'``): it is imported on the first call,
so the on-board core never needs it; without it :func:`encode_cam` and :func:`decode_cam`
raise :class:`trackmap.errors.MissingDependencyError` (an ``ImportError``) naming the
extra. This module is *not* the project's radio protocol (:mod:`antikol.ingest.protocol`):
a CAM carries less (no route, no track position, no antenna offset, no odometer) and has
no CRC or authentication of its own (C-ITS signs at the security layer, below the CAM).

Field mapping
-------------
========================================= =================================================
CAM field                                 report field (unit conversion)
========================================= =================================================
``header.protocolVersion``                2 (:data:`CAM_PROTOCOL_VERSION`)
``header.messageID``                      2, cam (:data:`CAM_MESSAGE_ID`)
``header.stationID``                      the ``station_id`` argument (0 .. 2**32 - 1);
                                          decoded as ``vehicle_id`` unless one is given
``cam.generationDeltaTime``               ``t``: TimestampIts mod 65536 (see *Time*)
``basicContainer.stationType``            11, tram (:data:`STATION_TYPE_TRAM`)
``referencePosition.latitude``            ``lat``, units of 0.1 microdegree (1e-7 degree)
``referencePosition.longitude``           ``lon``, units of 0.1 microdegree (1e-7 degree)
``heading.headingValue``                  ``course_deg``, 0.1 degree from true north,
                                          0 .. 3599 (3601 unavailable)
``speed.speedValue``                      ``speed_mps``, 0.01 m/s (16383 unavailable)
``vehicleLength.vehicleLengthValue``      ``length_m``, 0.1 m, 1 .. 1021; 1022 is "out
                                          of range" (102.2 m or more); 1023 unavailable
``vehicleWidth``                          the ``width_m`` argument, 0.1 m, 1 .. 60; 61
                                          "out of range" (6.1 m or more), 62 unavailable
``accelerationControl``                   ``braking``: bit brakePedalEngaged for
                                          ``"service"``, emergencyBrakeEngaged for
                                          ``"emergency"``, no bit for ``"none"``
========================================= =================================================

Everything else a report does not know is sent as the standard's *unavailable* value:
position confidence ellipse (semi-axes 4095, orientation 3601), altitude (800001, confidence
``unavailable``), heading and speed confidence (127), drive direction (``unavailable``: a
report's course is the direction of motion and it does not say which cab leads),
longitudinal acceleration (161, confidence 102), curvature (1023, ``unavailable``),
curvature calculation mode and yaw rate (32767, ``unavailable``). A missing ``length_m``
is sent as 1023 with the length confidence indication ``unavailable``; a known one with
``noTrailerPresent`` (the length is the whole vehicle's). No low-frequency or special
vehicle container is sent.

Encoded values are the report's values rounded (half to even) to the CAM resolution, so a
round trip changes them by at most half a unit: 0.5e-7 degree of latitude and longitude,
0.05 degree of course, 0.005 m/s of speed, 0.05 m of length, 0.5 ms of time. A course that
rounds to 360.0 degrees is sent as 0. A positive length below 0.05 m is sent as 0.1 m (it
stays positive). Every other report value fits the CAM's ranges (the report's own
validation is narrower), except a length of about 102.15 m or more, which is clamped to the
standard's "out of range" code, and decoded back as 102.2 m, the least length that code
stands for (an under-estimate, never an unknown length).

Time
----
CAM time is ``TimestampIts``: milliseconds since 2004-01-01T00:00:00 UTC on the TAI scale,
so it counts the leap seconds inserted since (:data:`ITS_LEAP_SECONDS`, 5 since 2017). A
CAM carries only its lowest 16 bits, ``generationDeltaTime`` (it wraps every 65.536 s).
A report's ``t`` is seconds on any epoch; the caller says which with ``epoch_unix_s``, the
Unix time (UTC, seconds, leap seconds not counted) at which ``t`` is 0:

    TimestampIts = round((t + epoch_unix_s - ITS_EPOCH_UNIX_S + leap_seconds) * 1000)

The default ``epoch_unix_s = 0`` is for reports whose ``t`` is Unix time. A report before
2004 cannot be encoded. Decoding needs a time near the message's generation to undo the
wrap, ``t_reference`` (on the same scale as ``t``, usually the reception time): the decoded
``t`` is the one nearest to it, within 32.768 s, whose timestamp has the received 16 bits.
A reference more than that outside ``TimestampIts`` (before 2004 on the given epoch, as
for the relative times of a forgotten ``epoch_unix_s``) is refused.

Errors
------
:func:`encode_cam` raises :class:`~antikol.ingest.protocol.EncodeError` (a
:class:`~antikol.errors.ProtocolError`) naming the field for a value without a
representation. :func:`decode_cam` raises :class:`~antikol.ingest.cobs.FrameError` (also
a ``ProtocolError``) for every input it cannot turn into a report, never a pycrate
exception. Its reasons: ``truncated`` (the input ends before the message, as far as it
parses, does), ``bad_payload`` (not a valid UPER CAM, or bytes after it), ``bad_version``
(another message or protocol version) and ``invalid_value`` (a CAM whose values make no
report: an unavailable position, speed or heading, a speed above
:data:`~antikol.report.MAX_SPEED_MPS`, not a tram).
"""

from __future__ import annotations

import threading
from typing import Any, Final

from antikol.errors import InvalidArgumentError, InvalidReportError
from antikol.ingest.cobs import FrameError
from antikol.ingest.protocol import EncodeError
from antikol.kinds import BrakeState
from antikol.numeric import finite_float
from antikol.report import VehicleReport

__all__ = [
    "CAM_MESSAGE_ID",
    "CAM_PROTOCOL_VERSION",
    "ITS_EPOCH_UNIX_S",
    "ITS_LEAP_SECONDS",
    "STATION_TYPE_TRAM",
    "decode_cam",
    "encode_cam",
]

#: ``ItsPduHeader.messageID`` of a CAM.
CAM_MESSAGE_ID: Final = 2
#: ``ItsPduHeader.protocolVersion`` of CAM version 2 (ETSI EN 302 637-2 V1.4.1).
CAM_PROTOCOL_VERSION: Final = 2
#: ``StationType`` of a tram.
STATION_TYPE_TRAM: Final = 11
#: Unix time of the ITS epoch, 2004-01-01T00:00:00 UTC, seconds.
ITS_EPOCH_UNIX_S: Final = 1_072_915_200
#: Leap seconds inserted between the ITS epoch and now (TAI - UTC was 32 s in 2004 and is
#: 37 s since 2017-01-01); ``TimestampIts`` counts them, Unix time does not.
ITS_LEAP_SECONDS: Final = 5

_MAX_TIMESTAMP_ITS: Final = 4_398_046_511_103
_UINT32_MAX: Final = 0xFFFFFFFF
_WRAP_MS: Final = 65536

# "unavailable" and "out of range" codes of ITS-Container (TS 102 894-2)
_LAT_UNAVAILABLE: Final = 900_000_001
_LON_UNAVAILABLE: Final = 1_800_000_001
_HEADING_UNAVAILABLE: Final = 3601
_CONFIDENCE_UNAVAILABLE: Final = 127
_SPEED_UNAVAILABLE: Final = 16383
_LENGTH_OUT_OF_RANGE: Final = 1022
_LENGTH_UNAVAILABLE: Final = 1023
_WIDTH_OUT_OF_RANGE: Final = 61
_WIDTH_UNAVAILABLE: Final = 62

# AccelerationControl is a 7-bit BIT STRING; pycrate gives it as (value, 7), bit 0 first
_ACC_CONTROL_BITS: Final = 7
_BRAKE_PEDAL: Final = 1 << (_ACC_CONTROL_BITS - 1 - 0)
_EMERGENCY_BRAKE: Final = 1 << (_ACC_CONTROL_BITS - 1 - 2)

_EXTRA_HINT: Final = "pip install 'antikol[cits]' (or pip install pycrate)"

_lock = threading.Lock()  # pycrate's PDU object holds the value being coded: one at a time
_pycrate: tuple[Any, Any] | None = None


def _cam() -> tuple[Any, Any]:
    """pycrate's CAM PDU object and its bit reader class, imported on first use."""
    global _pycrate
    if _pycrate is None:
        try:
            from pycrate_asn1dir import ITS_CAM_2
            from pycrate_core.charpy import Charpy
        except ImportError as exc:
            from trackmap.errors import MissingDependencyError

            raise MissingDependencyError(
                f"C-ITS CAM encoding needs pycrate, which is not installed: {_EXTRA_HINT}"
            ) from exc
        _pycrate = (ITS_CAM_2.CAM_PDU_Descriptions.CAM, Charpy)
    return _pycrate


def _timestamp_its_ms(t: float, epoch_unix_s: float, leap_seconds: int) -> float:
    """``TimestampIts`` of a report time ``t``, ms (a float: not yet rounded or checked)."""
    return (t + epoch_unix_s - ITS_EPOCH_UNIX_S + leap_seconds) * 1000.0


def _time_arguments(epoch_unix_s: object, leap_seconds: object) -> tuple[float, int]:
    """Check the time-scale arguments shared by encoder and decoder."""
    epoch = finite_float(epoch_unix_s)
    if epoch is None:
        raise InvalidArgumentError("epoch_unix_s", epoch_unix_s, "not a finite number")
    if isinstance(leap_seconds, bool) or not isinstance(leap_seconds, int):
        raise InvalidArgumentError("leap_seconds", leap_seconds, "must be an int")
    if not -100 <= leap_seconds <= 100:
        raise InvalidArgumentError("leap_seconds", leap_seconds, "outside -100..100")
    return epoch, leap_seconds


def _length_units(length_m: float | None) -> int:
    if length_m is None:
        return _LENGTH_UNAVAILABLE
    return max(1, min(round(length_m * 10.0), _LENGTH_OUT_OF_RANGE))


def _width_units(width_m: float | None) -> int:
    if width_m is None:
        return _WIDTH_UNAVAILABLE
    width = finite_float(width_m)
    if width is None or width <= 0.0:
        raise EncodeError("width_m", width_m, "must be a positive, finite number of metres")
    return max(1, min(round(width * 10.0), _WIDTH_OUT_OF_RANGE))


def encode_cam(
    report: VehicleReport,
    *,
    station_id: int,
    epoch_unix_s: float = 0.0,
    leap_seconds: int = ITS_LEAP_SECONDS,
    width_m: float | None = None,
) -> bytes:
    """Encode a report as a UPER-encoded CAM of a tram (station type 11).

    Parameters
    ----------
    report : VehicleReport
        The report to send; fields and their CAM units are listed in the module docstring
        (position 1e-7 degree, course 0.1 degree, speed 0.01 m/s, length 0.1 m).
    station_id : int
        ``StationID`` of the sending unit, ``0 .. 2**32 - 1`` (C-ITS has no text ids).
    epoch_unix_s : float, optional
        Unix time, seconds, at which the report's ``t`` is 0; 0 (the default) when ``t``
        is Unix time.
    leap_seconds : int, optional
        Leap seconds between 2004 and the report (default :data:`ITS_LEAP_SECONDS`).
    width_m : float, optional
        Vehicle width, metres (0.1 m units, 6.1 m or more sent as "out of range"); by
        default unavailable.

    Returns
    -------
    bytes
        The CAM, about 40 bytes.

    Raises
    ------
    EncodeError
        (a :class:`~antikol.errors.ProtocolError`) naming the field: ``station_id``
        outside uint32, a ``t`` before 2004 or beyond ``TimestampIts`` on the given epoch
        (``t``), a ``width_m`` that is not a positive number.
    InvalidArgumentError
        ``epoch_unix_s`` is not a finite number or ``leap_seconds`` not an int in
        ``-100 .. 100``.
    trackmap.errors.MissingDependencyError
        pycrate is not installed (``pip install 'antikol[cits]'``).
    """
    if (
        isinstance(station_id, bool)
        or not isinstance(station_id, int)
        or not 0 <= station_id <= _UINT32_MAX
    ):
        raise EncodeError("station_id", station_id, "must be an int in 0..2^32-1")
    epoch, leap = _time_arguments(epoch_unix_s, leap_seconds)
    its_ms = _timestamp_its_ms(report.t, epoch, leap)
    if not -0.5 <= its_ms <= _MAX_TIMESTAMP_ITS:
        raise EncodeError(
            "t",
            report.t,
            f"TimestampIts {its_ms:.0f} ms outside 0..{_MAX_TIMESTAMP_ITS}"
            " (before 2004 on this epoch? pass epoch_unix_s)",
        )
    control = 0
    if report.braking == "service":
        control = _BRAKE_PEDAL
    elif report.braking == "emergency":
        control = _EMERGENCY_BRAKE
    length = _length_units(report.length_m)
    high_frequency = {
        "heading": {
            "headingValue": round(report.course_deg * 10.0) % 3600,
            "headingConfidence": _CONFIDENCE_UNAVAILABLE,
        },
        "speed": {
            "speedValue": round(report.speed_mps * 100.0),
            "speedConfidence": _CONFIDENCE_UNAVAILABLE,
        },
        "driveDirection": "unavailable",
        "vehicleLength": {
            "vehicleLengthValue": length,
            "vehicleLengthConfidenceIndication": (
                "unavailable" if length == _LENGTH_UNAVAILABLE else "noTrailerPresent"
            ),
        },
        "vehicleWidth": _width_units(width_m),
        "longitudinalAcceleration": {
            "longitudinalAccelerationValue": 161,
            "longitudinalAccelerationConfidence": 102,
        },
        "curvature": {"curvatureValue": 1023, "curvatureConfidence": "unavailable"},
        "curvatureCalculationMode": "unavailable",
        "yawRate": {"yawRateValue": 32767, "yawRateConfidence": "unavailable"},
        "accelerationControl": (control, _ACC_CONTROL_BITS),
    }
    value = {
        "header": {
            "protocolVersion": CAM_PROTOCOL_VERSION,
            "messageID": CAM_MESSAGE_ID,
            "stationID": station_id,
        },
        "cam": {
            "generationDeltaTime": round(its_ms) % _WRAP_MS,
            "camParameters": {
                "basicContainer": {
                    "stationType": STATION_TYPE_TRAM,
                    "referencePosition": {
                        "latitude": round(report.lat * 1e7),
                        "longitude": round(report.lon * 1e7),
                        "positionConfidenceEllipse": {
                            "semiMajorConfidence": 4095,
                            "semiMinorConfidence": 4095,
                            "semiMajorOrientation": _HEADING_UNAVAILABLE,
                        },
                        "altitude": {"altitudeValue": 800001, "altitudeConfidence": "unavailable"},
                    },
                },
                "highFrequencyContainer": ("basicVehicleContainerHighFrequency", high_frequency),
            },
        },
    }
    pdu, _ = _cam()
    with _lock:
        try:
            pdu.set_val(value)
            return bytes(pdu.to_uper())
        except Exception as exc:  # pragma: no cover - every value above is in range
            raise EncodeError("report", report.vehicle_id, f"pycrate: {exc}") from exc


def _parse(data: bytes) -> dict[str, Any]:
    """pycrate's decode of ``data``; any failure of it as a FrameError."""
    pdu, reader = _cam()
    with _lock:
        try:
            bits = reader(bytes(data))
            pdu.from_uper(bits)
            rest = bits.len_bit()
            value = pdu.get_val()
        except Exception as exc:  # pycrate raises many kinds on bad input; none escapes
            text = str(exc)
            # pycrate's bit reader says "bitlen overflow" when it runs out of input
            reason = "truncated" if not data or "overflow" in text else "bad_payload"
            raise FrameError(
                reason, f"not a UPER CAM ({type(exc).__name__}: {text[:200]})"
            ) from None
    if rest >= 8:
        raise FrameError("bad_payload", f"{rest // 8} byte(s) after the CAM")
    if not isinstance(value, dict):  # pragma: no cover - a SEQUENCE decodes to a dict
        raise FrameError("bad_payload", "not a UPER CAM")
    return value


def decode_cam(
    data: bytes | bytearray | memoryview,
    *,
    t_reference: float,
    vehicle_id: str | None = None,
    epoch_unix_s: float = 0.0,
    leap_seconds: int = ITS_LEAP_SECONDS,
    require_tram: bool = True,
) -> VehicleReport:
    """Decode a UPER-encoded CAM into a report.

    Parameters
    ----------
    data : bytes-like
        One CAM, exactly (no bytes after it).
    t_reference : float
        A time near the CAM's generation, seconds on the reports' scale (usually the time
        of reception): the 16-bit ``generationDeltaTime`` is resolved to the time nearest
        to it (within 32.768 s).
    vehicle_id : str, optional
        The report's ``vehicle_id``; by default the decimal ``stationID``.
    epoch_unix_s : float, optional
        Unix time, seconds, at which ``t`` is 0 (as given to :func:`encode_cam`).
    leap_seconds : int, optional
        Leap seconds between 2004 and the message (default :data:`ITS_LEAP_SECONDS`).
    require_tram : bool, optional
        Reject a CAM whose station type is not 11, tram (default); False accepts any.

    Returns
    -------
    VehicleReport
        ``lat``, ``lon`` (degrees), ``speed_mps``, ``course_deg``, ``t`` (seconds),
        ``braking`` and ``length_m`` (metres; None when unavailable) as described in the
        module docstring; the other optional fields are None.

    Raises
    ------
    FrameError
        (a :class:`~antikol.errors.ProtocolError`) with the reason ``truncated``,
        ``bad_payload``, ``bad_version`` or ``invalid_value`` (see the module docstring);
        the detail names the field.
    InvalidArgumentError
        ``t_reference`` or ``epoch_unix_s`` is not a finite number, ``leap_seconds`` not an
        int in ``-100 .. 100``, or ``t_reference`` on that epoch is more than half a wrap
        (32.768 s) outside ``TimestampIts`` (before 2004 or beyond its 42 bits).
    trackmap.errors.MissingDependencyError
        pycrate is not installed (``pip install 'antikol[cits]'``).
    """
    epoch, leap = _time_arguments(epoch_unix_s, leap_seconds)
    reference = finite_float(t_reference)
    if reference is None:
        raise InvalidArgumentError("t_reference", t_reference, "not a finite number")
    reference_ms = _timestamp_its_ms(reference, epoch, leap)
    # no TimestampIts lies within half a wrap of a reference outside this range, and a
    # huge one (1e306 s: infinite in ms) has no wrap count round() can give
    if not -_WRAP_MS / 2 <= reference_ms <= _MAX_TIMESTAMP_ITS + _WRAP_MS / 2:
        hint = " (before 2004 on this epoch? pass epoch_unix_s)" if reference_ms < 0 else ""
        raise InvalidArgumentError(
            "t_reference",
            t_reference,
            f"TimestampIts {reference_ms:.0f} ms with epoch_unix_s={epoch!r} is outside"
            f" 0..{_MAX_TIMESTAMP_ITS}{hint}",
        )
    value = _parse(bytes(data))
    try:
        header = value["header"]
        cam = value["cam"]
        params = cam["camParameters"]
        basic = params["basicContainer"]
        position = basic["referencePosition"]
        choice, high = params["highFrequencyContainer"]
    except (KeyError, TypeError, ValueError) as exc:  # pragma: no cover - schema-enforced
        raise FrameError("bad_payload", f"CAM without {exc}") from None
    if header["messageID"] != CAM_MESSAGE_ID:
        raise FrameError("bad_version", f"header.messageID={header['messageID']}, not a CAM")
    if header["protocolVersion"] != CAM_PROTOCOL_VERSION:
        raise FrameError(
            "bad_version",
            f"header.protocolVersion={header['protocolVersion']}, expected {CAM_PROTOCOL_VERSION}",
        )
    station_type = basic["stationType"]
    if require_tram and station_type != STATION_TYPE_TRAM:
        raise FrameError("invalid_value", f"stationType={station_type}, not a tram (11)")
    if choice != "basicVehicleContainerHighFrequency":
        raise FrameError("invalid_value", f"highFrequencyContainer is {choice}, not a vehicle's")
    lat, lon = position["latitude"], position["longitude"]
    heading = high["heading"]["headingValue"]
    speed = high["speed"]["speedValue"]
    for name, raw, unavailable in (
        ("latitude", lat, _LAT_UNAVAILABLE),
        ("longitude", lon, _LON_UNAVAILABLE),
        ("headingValue", heading, _HEADING_UNAVAILABLE),
        ("speedValue", speed, _SPEED_UNAVAILABLE),
    ):
        if raw == unavailable:
            raise FrameError("invalid_value", f"{name} unavailable: a report needs it")
    length_raw = high["vehicleLength"]["vehicleLengthValue"]
    length = None if length_raw == _LENGTH_UNAVAILABLE else length_raw / 10.0
    control, nbits = high.get("accelerationControl", (0, _ACC_CONTROL_BITS))
    control <<= max(0, _ACC_CONTROL_BITS - nbits)  # a shorter string lacks trailing bits
    braking: BrakeState = (
        "emergency"
        if control & _EMERGENCY_BRAKE
        else "service"
        if control & _BRAKE_PEDAL
        else "none"
    )

    delta = cam["generationDeltaTime"]
    wraps = round((reference_ms - delta) / _WRAP_MS)
    its_ms = delta + wraps * _WRAP_MS
    t = its_ms / 1000.0 - (epoch - ITS_EPOCH_UNIX_S + leap)
    try:
        return VehicleReport(
            vehicle_id=str(header["stationID"]) if vehicle_id is None else vehicle_id,
            t=t,
            lat=lat / 1e7,
            lon=lon / 1e7,
            speed_mps=speed / 100.0,
            course_deg=heading / 10.0,
            braking=braking,
            length_m=length,
        )
    except InvalidReportError as exc:
        raise FrameError("invalid_value", str(exc)) from None
