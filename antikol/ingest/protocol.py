"""Broadcast radio protocol: versioned, COBS-framed, CRC-protected vehicle reports.

Every on-board unit broadcasts its :class:`~antikol.report.VehicleReport` as one *frame*.
Receivers get one interleaved byte stream from many senders (radio, UDP, serial, a
replay file) and split it back into reports with :class:`StreamDecoder`.

Framing
-------
On the wire a frame is ``0x00 + COBS(body) + 0x00``. Consistent Overhead Byte Stuffing
(COBS) removes every ``0x00`` from the body at a cost of ``1 + n // 254`` bytes at most
(1 byte for any body under 254 bytes), so ``0x00`` is a pure frame delimiter: a receiver
that joins in the middle of a stream, or loses bytes, resynchronises at the next ``0x00``
and a damaged frame can never damage its neighbours. Both a leading
and a trailing delimiter are sent so that a frame cut short (its trailing ``0x00`` lost)
is still separated from the next frame.

Body (before COBS; all integers big-endian, ``n`` = vehicle id length in bytes):

======== ===== ======================================================================
offset   bytes field
======== ===== ======================================================================
0        1     major version (``PROTOCOL_MAJOR`` = 1); incompatible layouts change it
1        1     minor version (``PROTOCOL_MINOR`` = 1); only adds optional TLV types
2        2     ``L``: body length without the CRC trailer, bytes (uint16)
4        1     ``n``: vehicle id length, 1..32 bytes (uint8)
5        n     vehicle id, UTF-8
5+n      8     ``t``: time of the fix, seconds, IEEE 754 float64 (exact)
13+n     4     sequence number (uint32; senders wrap it with :func:`next_seq`)
17+n     4     latitude, int32, units of 1e-7 degree
21+n     4     longitude, int32, units of 1e-7 degree
25+n     2     speed over ground, uint16, cm/s (0..10000 = 0..100 m/s)
27+n     2     course over ground, uint16, 0.01 degree (0..35999)
29+n     ...   optional fields, TLV: type uint8, length uint16 (bytes), value
L        4     CRC-32 (``zlib.crc32``, IEEE 802.3) of bytes ``0 .. L-1``, uint32
======== ===== ======================================================================

Optional TLV fields (an absent TLV means the field is ``None``; absent braking means
``"none"``):

==== ====== ==========================================================================
type length value
==== ====== ==========================================================================
1    1      braking: uint8, 0 ``"none"``, 1 ``"service"``, 2 ``"emergency"``
2    4      length_m: uint32, millimetres
3    4      antenna_offset_m: uint32, millimetres
4    9      track_position: edge_id uint32, offset uint32 mm, direction int8 (+1/-1)
5    4*k    route: k = 0..255 edge ids, uint32 each, in running order
6    2      hdop: uint16, units of 0.01 (values above 655.35 are sent as 655.35)
7    1      fix_quality: uint8 (0: no position fix, the position is the last known one)
8    8      odometer_m: uint64, millimetres (minor version 1)
9    3+m    authentication (minor version 1), always the *last* TLV: scheme uint8,
            key id uint16, then the m-byte tag (see below)
==== ====== ==========================================================================

A report with a 6-byte id and no optional fields is a 39-byte body and a 42-byte frame
(an HMAC tag adds 38 bytes, an Ed25519 signature 70);
with every optional field and a 20-edge route it is 175 bytes. The largest possible frame
(32-byte id, every field, 255-edge route) is a 1138-byte body (1208 with an Ed25519
signature) and at most 1215 bytes on the wire.

Authentication
--------------
CRC-32 detects noise, not forgery: anyone can compute it. A sender with a key appends TLV 9,
whose tag covers the whole body before the tag: header (with the final ``L``), every field,
the TLV 9 header, scheme and key id. The CRC then covers the tag too. Schemes:

====== ============ ===== ================================================================
scheme name         m     tag
====== ============ ===== ================================================================
1      hmac-sha256  32    HMAC-SHA-256 (RFC 2104) with a fleet key chosen by the key id
2      ed25519      64    Ed25519 signature (RFC 8032) with the sending vehicle's own key
====== ============ ===== ================================================================

Keys, signers and verifiers are in :mod:`antikol.ingest.auth`. A decoder given a verifier
(:class:`FrameVerifier`) rejects frames without TLV 9 (``"unsigned"``), with a key it does
not know (``"unknown_key"``) or a tag that does not verify (``"bad_signature"``); without a
verifier TLV 9 is ignored (the paper's unauthenticated protocol). Replays of genuine frames
are a separate check (:mod:`antikol.ingest.guard`).

Versioning and compatibility
----------------------------
Invariant across *all* versions: COBS framing, byte 0 of the body is the major version,
and the last four bytes are the CRC-32 of everything before them. A receiver

* accepts every minor version of its major version; TLV types it does not know (added by
  a newer minor version) are skipped and counted in :attr:`DecoderStats.tlvs_skipped`;
* rejects a frame with an intact CRC and an unknown major version (reason
  ``"bad_version"``).

Known TLV types always keep their length; a newer minor version adds types, it never
extends existing ones. Each known type may appear at most once.

Why CRC-32
----------
Bodies are 34 to 1208 bytes. CRC-32 (IEEE 802.3 polynomial, ``zlib.crc32``, C speed,
standard library) detects every error of up to 3 flipped bits in bodies of this size,
every burst up to 32 bits, and lets random corruption (e.g. radio noise or garbage
between frames that happens to look like a frame) through with probability about
``2**-32``. A flip in a COBS data byte is a flip in the body; a flip in a COBS code byte
moves a zero byte and is caught by the COBS structure, the length field or the CRC.
CRC-16/CCITT (``binascii.crc_hqx``) would pass one random garbage stretch in 65536: with
ten noise stretches per second that is a CRC-valid false frame about every two hours
(before plausibility checks), too weak for a collision warning input. The four bytes are
~10 % of a typical frame.

Quantisation
------------
Decoded values are the encoded values rounded (half to even) to the wire resolution:

* ``t``: exact (float64).
* ``lat``, ``lon``: 1e-7 degree (at most 0.5e-7 degree, 5.6 mm, error).
* ``speed_mps``: 0.01 m/s. ``course_deg``: 0.01 degree; a course that rounds to 360.00
  is sent as 0.00.
* ``length_m``, ``antenna_offset_m``, ``track_position.offset_m``: 1 mm. A positive
  ``length_m`` below 0.5 mm is sent as 1 mm (it must stay positive). Values above
  4294967.295 m cannot be encoded (:class:`EncodeError`).
* ``hdop``: 0.01, saturating at 655.35.
* ``odometer_m``: 1 mm; values above 2**64 - 1 mm cannot be encoded (:class:`EncodeError`).
* ``vehicle_id``, ``seq``, ``braking``, ``route``, ``track_position.edge_id`` and
  ``direction``, ``fix_quality``: exact.

Rejections
----------
:class:`StreamDecoder` never raises on bytes input. Every non-empty stretch between
delimiters that is not a valid frame is counted once, by the first applicable reason
(see :data:`REJECT_REASONS`), and logged at DEBUG level:

``too_long``
    More than ``max_frame_bytes`` bytes without a delimiter; the decoder drops them and
    resynchronises at the next ``0x00``.
``cobs``
    The stretch contains ``0x00`` (only possible with :func:`decode_frame`).
``truncated``
    The frame ends before its COBS block or its length field says it should (a frame cut
    short; a bit flip in a COBS code byte or in the length field can look the same).
``crc``
    The CRC-32 does not match.
``bad_version``
    Intact frame of an unknown major version.
``bad_payload``
    Intact frame whose structure is inconsistent (length field, TLV bounds, a known TLV
    of the wrong size or repeated).
``unsigned``, ``unknown_key``, ``bad_signature``
    Only with a verifier: no authentication TLV, an unknown key or scheme, a tag that does
    not verify (see *Authentication*).
``invalid_value``
    Intact, well-formed frame whose values make no valid
    :class:`~antikol.report.VehicleReport` (e.g. latitude above 90 degrees).
``internal_error``
    A decoder bug (logged at ERROR level with the traceback); should always be 0.
"""

from __future__ import annotations

import logging
import struct
import zlib
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Final, Protocol

from antikol.errors import InvalidReportError, ProtocolError
from antikol.ingest.cobs import FrameError, cobs_decode, cobs_encode
from antikol.report import BRAKE_STATES, ReportedTrackPosition, VehicleReport

__all__ = [
    "AUTH_SCHEMES",
    "FRAME_DELIMITER",
    "MAX_FRAME_BYTES",
    "PROTOCOL_MAJOR",
    "PROTOCOL_MINOR",
    "REJECT_REASONS",
    "DecoderStats",
    "EncodeError",
    "FrameError",
    "FrameSigner",
    "FrameVerifier",
    "StreamDecoder",
    "cobs_decode",
    "cobs_encode",
    "decode_frame",
    "encode_report",
    "next_seq",
]

logger = logging.getLogger(__name__)

#: Major protocol version written and accepted by this module.
PROTOCOL_MAJOR: Final = 1
#: Minor protocol version written by this module (any minor version is accepted).
PROTOCOL_MINOR: Final = 1
#: The frame delimiter; it never occurs inside a COBS-encoded body.
FRAME_DELIMITER: Final = b"\x00"
#: Largest COBS-encoded body (delimiters excluded) accepted, bytes. This version produces at
#: most 1213 bytes; the margin is for optional fields added by newer minor versions.
MAX_FRAME_BYTES: Final = 2048
#: Authentication schemes of TLV 9: code -> (name, tag length in bytes).
AUTH_SCHEMES: Final = {1: ("hmac-sha256", 32), 2: ("ed25519", 64)}
#: Every reason a frame can be rejected for, in the order the checks are made.
REJECT_REASONS: Final = (
    "too_long",
    "cobs",
    "truncated",
    "crc",
    "bad_version",
    "bad_payload",
    "unsigned",
    "unknown_key",
    "bad_signature",
    "invalid_value",
    "internal_error",
)

_UINT32_MAX: Final = 0xFFFFFFFF
_UINT16_MAX: Final = 0xFFFF
_UINT64_MAX: Final = 0xFFFFFFFFFFFFFFFF
_HEADER = struct.Struct(">BBH")  # major, minor, L
_FIXED = struct.Struct(">dIiiHH")  # t, seq, lat, lon, speed, course
_TLV = struct.Struct(">BH")  # type, length
_CRC = struct.Struct(">I")
_U32 = struct.Struct(">I")
_U16 = struct.Struct(">H")
_U64 = struct.Struct(">Q")
_TRACK = struct.Struct(">IIb")  # edge id, offset mm, direction
_AUTH = struct.Struct(">BH")  # scheme, key id
_MIN_BODY: Final = _HEADER.size + _CRC.size

_T_BRAKING: Final = 1
_T_LENGTH: Final = 2
_T_ANTENNA: Final = 3
_T_TRACK: Final = 4
_T_ROUTE: Final = 5
_T_HDOP: Final = 6
_T_FIX: Final = 7
_T_ODOMETER: Final = 8
_T_AUTH: Final = 9
#: Value length of each known TLV type, bytes; 0 means "any multiple of 4" (the route);
#: -1 means "3 or more" (authentication).
_TLV_SIZES: Final = {
    _T_BRAKING: 1,
    _T_LENGTH: 4,
    _T_ANTENNA: 4,
    _T_TRACK: _TRACK.size,
    _T_ROUTE: 0,
    _T_HDOP: 2,
    _T_FIX: 1,
    _T_ODOMETER: 8,
    _T_AUTH: -1,
}
_BRAKE_CODES: Final = {state: code for code, state in enumerate(BRAKE_STATES)}


class FrameSigner(Protocol):
    """What :func:`encode_report` needs to authenticate a frame (see
    :mod:`antikol.ingest.auth` for the implementations)."""

    @property
    def scheme(self) -> int:
        """Scheme code, a key of :data:`AUTH_SCHEMES`."""
        ...

    @property
    def key_id(self) -> int:
        """Key id sent in the frame, 0..65535."""
        ...

    def sign(self, data: bytes) -> bytes:
        """The tag over ``data`` (as long as :data:`AUTH_SCHEMES` says)."""
        ...


class FrameVerifier(Protocol):
    """What :func:`decode_frame` and :class:`StreamDecoder` need to check a frame's tag."""

    def verify(
        self, vehicle_id: bytes, scheme: int, key_id: int, signed: bytes, tag: bytes
    ) -> str | None:
        """None if ``tag`` authenticates ``signed`` for this sender, else the reason
        (``"unknown_key"`` or ``"bad_signature"``)."""
        ...


class EncodeError(ProtocolError):
    """A report value cannot be represented in a frame.

    Parameters
    ----------
    field : str
        Name of the offending field (e.g. ``"seq"``).
    value : object
        The rejected value.
    reason : str
        Why it cannot be encoded.

    Attributes
    ----------
    field, value, reason
        As given.
    """

    def __init__(self, field: str, value: object, reason: str) -> None:
        self.field = field
        self.value = value
        self.reason = reason
        super().__init__(f"cannot encode {field}={value!r}: {reason}")


# --------------------------------------------------------------------------- encoding


def next_seq(seq: int) -> int:
    """Return the sequence number following ``seq``, wrapping from 2**32 - 1 to 0.

    Parameters
    ----------
    seq : int
        Current sequence number, ``0 .. 2**32 - 1``.

    Returns
    -------
    int
        ``(seq + 1) mod 2**32``.
    """
    return (seq + 1) & _UINT32_MAX


def _millimetres(field: str, value: float, limit: int = _UINT32_MAX) -> int:
    # compare before rounding: round() of a huge float is an OverflowError, not a value
    if not 0.0 <= value * 1000.0 <= limit + 0.5:
        raise EncodeError(field, value, f"outside 0..{limit / 1000.0:.3f} m (millimetres)")
    mm = round(value * 1000.0)
    if mm > limit:
        raise EncodeError(field, value, f"outside 0..{limit / 1000.0:.3f} m (millimetres)")
    return mm


def _tlv(out: bytearray, typ: int, value: bytes) -> None:
    out += _TLV.pack(typ, len(value))
    out += value


def encode_report(
    report: VehicleReport, *, seq: int | None = None, signer: FrameSigner | None = None
) -> bytes:
    """Encode one report as a complete frame, delimiters included.

    Parameters
    ----------
    report : VehicleReport
        The report to send. Values are quantised as described in the module docstring
        (lat/lon 1e-7 degree, speed 0.01 m/s, course 0.01 degree, lengths 1 mm).
    seq : int, optional
        Sequence number to send, ``0 .. 2**32 - 1``; by default ``report.seq``, or 0 if
        the report has none. Senders wrap it with :func:`next_seq`.
    signer : FrameSigner, optional
        Authenticates the frame (TLV 9, see *Authentication*); None sends it unsigned.

    Returns
    -------
    bytes
        ``0x00 + COBS(body) + 0x00``; 42 bytes for a 6-byte id without optional fields.

    Raises
    ------
    EncodeError
        (a :class:`~antikol.errors.ProtocolError`) if a value has no representation in
        the frame: ``seq`` outside uint32, ``antenna_offset_m`` /
        ``track_position.offset_m`` above 4294967.295 m, ``odometer_m`` above uint64
        millimetres, or a signer of an unknown scheme. The message names the field.
    """
    if seq is None:
        seq = report.seq if report.seq is not None else 0
        field = "seq"
    else:
        field = "seq (argument)"
    if isinstance(seq, bool) or not isinstance(seq, int) or not 0 <= seq <= _UINT32_MAX:
        raise EncodeError(field, seq, "must be an int in 0..2^32-1 (wrap with next_seq)")

    vid = report.vehicle_id.encode("utf-8")
    body = bytearray(_HEADER.size)
    body.append(len(vid))
    body += vid
    body += _FIXED.pack(
        float(report.t),
        seq,
        round(report.lat * 1e7),
        round(report.lon * 1e7),
        round(report.speed_mps * 100.0),
        round(report.course_deg * 100.0) % 36000,
    )
    if report.braking != "none":
        _tlv(body, _T_BRAKING, bytes((_BRAKE_CODES[report.braking],)))
    if report.length_m is not None:
        # Keep a positive length positive after rounding to millimetres.
        mm = max(1, _millimetres("length_m", report.length_m))
        _tlv(body, _T_LENGTH, _U32.pack(mm))
    if report.antenna_offset_m is not None:
        _tlv(body, _T_ANTENNA, _U32.pack(_millimetres("antenna_offset_m", report.antenna_offset_m)))
    tp = report.track_position
    if tp is not None:
        offset_mm = _millimetres("track_position.offset_m", tp.offset_m)
        _tlv(body, _T_TRACK, _TRACK.pack(tp.edge_id, offset_mm, tp.direction))
    if report.route is not None:
        _tlv(body, _T_ROUTE, struct.pack(f">{len(report.route)}I", *report.route))
    if report.hdop is not None:
        _tlv(body, _T_HDOP, _U16.pack(round(min(report.hdop * 100.0, _UINT16_MAX))))
    if report.fix_quality is not None:
        _tlv(body, _T_FIX, bytes((report.fix_quality,)))
    if report.odometer_m is not None:
        odo = _millimetres("odometer_m", report.odometer_m, _UINT64_MAX)
        _tlv(body, _T_ODOMETER, _U64.pack(odo))

    if signer is None:
        _HEADER.pack_into(body, 0, PROTOCOL_MAJOR, PROTOCOL_MINOR, len(body))
    else:
        scheme = AUTH_SCHEMES.get(signer.scheme)
        if scheme is None:
            raise EncodeError("signer.scheme", signer.scheme, f"not one of {sorted(AUTH_SCHEMES)}")
        if not 0 <= signer.key_id <= _UINT16_MAX:
            raise EncodeError("signer.key_id", signer.key_id, "outside 0..65535")
        tag_size = scheme[1]
        body += _TLV.pack(_T_AUTH, _AUTH.size + tag_size)
        body += _AUTH.pack(signer.scheme, signer.key_id)
        _HEADER.pack_into(body, 0, PROTOCOL_MAJOR, PROTOCOL_MINOR, len(body) + tag_size)
        tag = signer.sign(bytes(body))
        if len(tag) != tag_size:
            raise EncodeError("signer", len(tag), f"tag must be {tag_size} bytes")
        body += tag
    body += _CRC.pack(zlib.crc32(body))
    encoded = cobs_encode(body)
    if len(encoded) > MAX_FRAME_BYTES:  # pragma: no cover - impossible for valid reports
        raise EncodeError("report", report.vehicle_id, f"frame above {MAX_FRAME_BYTES} bytes")
    return b"\x00" + encoded + b"\x00"


# --------------------------------------------------------------------------- decoding


def decode_frame(
    frame_body: bytes | bytearray | memoryview, *, verifier: FrameVerifier | None = None
) -> VehicleReport:
    """Decode a single frame.

    Parameters
    ----------
    frame_body : bytes-like
        The COBS-encoded bytes between two delimiters. Leading and trailing ``0x00``
        delimiters are accepted and ignored, so the output of :func:`encode_report` can
        be passed as is.
    verifier : FrameVerifier, optional
        Require and check authentication (see *Authentication*); None accepts unsigned
        frames and ignores any tag.

    Returns
    -------
    VehicleReport
        The decoded report (quantised values, see the module docstring); ``seq`` is
        always set.

    Raises
    ------
    FrameError
        (a :class:`~antikol.errors.ProtocolError`) with ``reason`` one of
        :data:`REJECT_REASONS` and a detail message.
    """
    body = bytes(frame_body).strip(b"\x00")
    if len(body) > MAX_FRAME_BYTES:
        raise FrameError("too_long", f"{len(body)} bytes, limit {MAX_FRAME_BYTES}")
    return _decode_body(body, verifier)[0]


def _decode_body(
    encoded: bytes, verifier: FrameVerifier | None = None
) -> tuple[VehicleReport, int]:
    """Decode a COBS-encoded frame body; return the report and the skipped TLV count."""
    body = cobs_decode(encoded)
    n = len(body)
    if n < _MIN_BODY:
        raise FrameError("truncated", f"{n} bytes, header and CRC alone need {_MIN_BODY}")
    major, _minor, length = _HEADER.unpack_from(body, 0)
    (crc,) = _CRC.unpack_from(body, n - 4)
    if zlib.crc32(memoryview(body)[: n - 4]) != crc:
        if length + 4 > n:
            raise FrameError("truncated", f"length field says {length + 4} bytes, got {n}")
        raise FrameError("crc", f"CRC-32 mismatch over {n - 4} bytes")
    if major != PROTOCOL_MAJOR:
        raise FrameError("bad_version", f"major version {major}, expected {PROTOCOL_MAJOR}")
    if length != n - 4:
        raise FrameError("bad_payload", f"length field {length}, body has {n - 4} bytes")
    if length < _HEADER.size + 1:
        raise FrameError("bad_payload", "no vehicle id length byte")
    id_end = _HEADER.size + 1 + body[_HEADER.size]
    pos = id_end + _FIXED.size
    if pos > length:
        raise FrameError("bad_payload", f"fixed fields end at {pos}, beyond length {length}")
    t, seq, lat_e7, lon_e7, speed_cms, course_cdeg = _FIXED.unpack_from(body, id_end)

    # Collect the value offsets of known TLVs first, then interpret them.
    found: dict[int, int] = {}
    skipped = 0
    while pos < length:
        if _T_AUTH in found:
            raise FrameError("bad_payload", f"TLV after the authentication TLV at {pos}")
        if pos + 3 > length:
            raise FrameError("bad_payload", f"TLV header at {pos} runs past length {length}")
        typ, size = _TLV.unpack_from(body, pos)
        pos += 3
        end = pos + size
        if end > length:
            raise FrameError("bad_payload", f"TLV type {typ} at {pos} runs past length {length}")
        expected = _TLV_SIZES.get(typ)
        if expected is None:
            skipped += 1  # unknown type of a newer minor version
        elif typ in found:
            raise FrameError("bad_payload", f"TLV type {typ} repeated")
        elif expected == -1:
            if size < _AUTH.size:
                raise FrameError("bad_payload", f"authentication TLV of {size} bytes")
            found[typ] = pos
        elif size != expected and (expected or size % 4):
            raise FrameError("bad_payload", f"TLV type {typ} has bad length {size}")
        else:
            found[typ] = pos
        pos = end

    if verifier is not None:
        _verify(body, length, found.get(_T_AUTH), id_end, verifier)
    try:
        vehicle_id = body[_HEADER.size + 1 : id_end].decode("utf-8")
    except UnicodeDecodeError as exc:
        raise FrameError("invalid_value", f"vehicle_id is not UTF-8: {exc}") from None
    braking_code = body[found[_T_BRAKING]] if _T_BRAKING in found else 0
    if braking_code >= len(BRAKE_STATES):
        raise FrameError("invalid_value", f"braking code {braking_code} unknown")
    length_m = antenna_m = track = route = hdop = fix_quality = odometer = None
    if found:
        if _T_LENGTH in found:
            length_m = _U32.unpack_from(body, found[_T_LENGTH])[0] / 1000.0
        if _T_ANTENNA in found:
            antenna_m = _U32.unpack_from(body, found[_T_ANTENNA])[0] / 1000.0
        if _T_TRACK in found:
            edge, offset_mm, direction = _TRACK.unpack_from(body, found[_T_TRACK])
            track = (edge, offset_mm / 1000.0, direction)
        if _T_ROUTE in found:
            at = found[_T_ROUTE]
            edges = _U16.unpack_from(body, at - 2)[0] // 4  # from the TLV's length field
            route = struct.unpack_from(f">{edges}I", body, at)
        if _T_HDOP in found:
            hdop = _U16.unpack_from(body, found[_T_HDOP])[0] / 100.0
        if _T_FIX in found:
            fix_quality = body[found[_T_FIX]]
        if _T_ODOMETER in found:
            odometer = _U64.unpack_from(body, found[_T_ODOMETER])[0] / 1000.0
    try:
        report = VehicleReport(
            vehicle_id=vehicle_id,
            t=t,
            lat=lat_e7 / 1e7,
            lon=lon_e7 / 1e7,
            speed_mps=speed_cms / 100.0,
            course_deg=course_cdeg / 100.0,
            braking=BRAKE_STATES[braking_code],
            length_m=length_m,
            antenna_offset_m=antenna_m,
            route=route,
            track_position=None if track is None else ReportedTrackPosition(*track),
            seq=seq,
            hdop=hdop,
            fix_quality=fix_quality,
            odometer_m=odometer,
        )
    except InvalidReportError as exc:
        raise FrameError("invalid_value", str(exc)) from None
    return report, skipped


def _verify(
    body: bytes, length: int, auth_at: int | None, id_end: int, verifier: FrameVerifier
) -> None:
    """Check the authentication TLV of an intact body; raise FrameError if it fails."""
    if auth_at is None:
        raise FrameError("unsigned", "no authentication TLV")
    scheme, key_id = _AUTH.unpack_from(body, auth_at)
    known = AUTH_SCHEMES.get(scheme)
    tag_at = auth_at + _AUTH.size
    if known is None:
        raise FrameError("unknown_key", f"authentication scheme {scheme} unknown")
    if length - tag_at != known[1]:
        raise FrameError("bad_signature", f"{known[0]} tag of {length - tag_at} bytes")
    reason = verifier.verify(
        body[_HEADER.size + 1 : id_end], scheme, key_id, body[:tag_at], body[tag_at:length]
    )
    if reason is not None:
        if reason not in ("unknown_key", "bad_signature"):
            reason = "bad_signature"
        raise FrameError(reason, f"{known[0]} key {key_id}: {reason}")


# --------------------------------------------------------------------------- stream


@dataclass(frozen=True, slots=True)
class DecoderStats:
    """Snapshot of a :class:`StreamDecoder`'s counters.

    Attributes
    ----------
    frames_ok : int
        Frames decoded into reports.
    rejected : Mapping[str, int]
        Rejected frames by reason; has a key (possibly 0) for every one of
        :data:`REJECT_REASONS`.
    tlvs_skipped : int
        Optional fields of unknown type (newer minor version) skipped in accepted frames.
    bytes_pending : int
        Bytes of an incomplete frame currently buffered.
    """

    frames_ok: int
    rejected: Mapping[str, int]
    tlvs_skipped: int
    bytes_pending: int

    @property
    def rejected_total(self) -> int:
        """Total number of rejected frames, all reasons."""
        return sum(self.rejected.values())


class StreamDecoder:
    """Split an interleaved byte stream of frames from many senders into reports.

    Feed it chunks as they arrive, split anywhere; it buffers at most one incomplete
    frame. It never raises on bytes input: frames that cannot be decoded are counted by
    reason in :attr:`stats` and logged at DEBUG level.

    Parameters
    ----------
    max_frame_bytes : int, optional
        Longest COBS-encoded frame body accepted, bytes (default :data:`MAX_FRAME_BYTES`).
        It bounds the buffer: a longer run without a delimiter is dropped, counted once as
        ``"too_long"``, and decoding resumes after the next ``0x00``.
    verifier : FrameVerifier, optional
        Require authenticated frames and check their tags (see *Authentication*);
        None (default) is the paper's unauthenticated protocol.

    Examples
    --------
    >>> from antikol.report import VehicleReport
    >>> r = VehicleReport("T12", t=1.5, lat=50.1, lon=14.4, speed_mps=8.0, course_deg=90.0)
    >>> dec = StreamDecoder()
    >>> frame = encode_report(r, seq=7)
    >>> dec.feed(frame[:10]) + dec.feed(frame[10:])  # doctest: +ELLIPSIS
    [VehicleReport(vehicle_id='T12', t=1.5, lat=50.1, lon=14.4, ..., seq=7, ...)]
    >>> dec.stats.frames_ok
    1
    """

    def __init__(
        self, *, max_frame_bytes: int = MAX_FRAME_BYTES, verifier: FrameVerifier | None = None
    ) -> None:
        if isinstance(max_frame_bytes, bool) or not isinstance(max_frame_bytes, int):
            raise TypeError("max_frame_bytes must be an int")
        if max_frame_bytes < _MIN_BODY:
            raise ValueError(f"max_frame_bytes must be at least {_MIN_BODY}")
        self._max = max_frame_bytes
        self._buf = bytearray()
        self._skipping = False
        self._ok = 0
        self._rejected = dict.fromkeys(REJECT_REASONS, 0)
        self._tlvs_skipped = 0
        self._verifier = verifier

    @property
    def stats(self) -> DecoderStats:
        """Counters so far (a snapshot; later feeds do not change it)."""
        return DecoderStats(
            frames_ok=self._ok,
            rejected=MappingProxyType(dict(self._rejected)),
            tlvs_skipped=self._tlvs_skipped,
            bytes_pending=len(self._buf),
        )

    def feed(self, chunk: bytes | bytearray | memoryview) -> list[VehicleReport]:
        """Consume the next chunk of the stream.

        Parameters
        ----------
        chunk : bytes-like
            The next bytes of the stream, any length (empty is fine).

        Returns
        -------
        list of VehicleReport
            Reports of every frame completed by this chunk, in stream order.
        """
        if not chunk:
            return []
        parts = bytes(chunk).split(b"\x00")
        out: list[VehicleReport] = []
        head = parts[0]
        if len(parts) == 1:  # no delimiter: the current frame continues
            if not self._skipping:
                self._buf += head
                if len(self._buf) > self._max:
                    self._overflow(len(self._buf))
            return out
        if self._skipping:  # the over-long run ends here; it was counted already
            self._skipping = False
        elif self._buf:
            self._buf += head
            body = bytes(self._buf)
            self._buf.clear()
            self._frame(body, out)
        else:
            self._frame(head, out)
        for i in range(1, len(parts) - 1):
            self._frame(parts[i], out)
        tail = parts[-1]
        if len(tail) > self._max:
            self._overflow(len(tail))
        else:
            self._buf += tail
        return out

    def _overflow(self, size: int) -> None:
        self._buf.clear()
        self._skipping = True
        self._reject(FrameError("too_long", f"{size} bytes without a delimiter"))

    def _reject(self, error: FrameError) -> None:
        self._rejected[error.reason] += 1
        logger.debug("frame rejected: %s", error)

    def _frame(self, body: bytes, out: list[VehicleReport]) -> None:
        if not body:  # between two delimiters: nothing was sent
            return
        if len(body) > self._max:
            self._reject(FrameError("too_long", f"{len(body)} bytes, limit {self._max}"))
            return
        try:
            report, skipped = _decode_body(body, self._verifier)
        except FrameError as exc:
            self._reject(exc)
            return
        except Exception:  # a decoder bug must not stop the receiver
            self._rejected["internal_error"] += 1
            logger.exception("internal error decoding a %d-byte frame", len(body))
            return
        self._ok += 1
        self._tlvs_skipped += skipped
        out.append(report)
