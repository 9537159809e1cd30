"""Tests of the broadcast radio protocol (:mod:`antikol.ingest.protocol`)."""

from __future__ import annotations

import itertools
import logging
import math
import struct
import zlib
from collections import Counter

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from antikol.errors import AntikolError, InvalidReportError, ProtocolError
from antikol.ingest.protocol import (
    MAX_FRAME_BYTES,
    PROTOCOL_MAJOR,
    PROTOCOL_MINOR,
    REJECT_REASONS,
    EncodeError,
    FrameError,
    StreamDecoder,
    cobs_decode,
    cobs_encode,
    decode_frame,
    encode_report,
    next_seq,
)
from antikol.report import ReportedTrackPosition, VehicleReport

U32 = st.integers(min_value=0, max_value=2**32 - 1)

# --------------------------------------------------------------------------- helpers


def _utf8_len_ok(s: str) -> bool:
    # what VehicleReport accepts: printable, not blank, 1-32 UTF-8 bytes
    return s.isprintable() and bool(s.strip()) and 1 <= len(s.encode("utf-8")) <= 32


vehicle_ids = st.text(st.characters(codec="utf-8"), min_size=1, max_size=32).filter(_utf8_len_ok)


@st.composite
def reports(draw: st.DrawFn) -> VehicleReport:
    """Any valid VehicleReport whose values the protocol can carry."""
    length = draw(st.none() | st.floats(min_value=0.0, max_value=1000.0, exclude_min=True))
    antenna_max = 4_000_000.0 if length is None else length
    antenna = draw(st.none() | st.floats(min_value=0.0, max_value=antenna_max))
    track = draw(
        st.none()
        | st.builds(
            ReportedTrackPosition,
            U32,
            st.floats(min_value=0.0, max_value=4_000_000.0),
            st.sampled_from([1, -1]),
        )
    )
    return VehicleReport(
        vehicle_id=draw(vehicle_ids),
        t=draw(st.floats(allow_nan=False, allow_infinity=False)),
        lat=draw(st.floats(min_value=-90.0, max_value=90.0)),
        lon=draw(st.floats(min_value=-180.0, max_value=180.0)),
        speed_mps=draw(st.floats(min_value=0.0, max_value=100.0)),
        course_deg=draw(st.floats(min_value=0.0, max_value=360.0)),
        braking=draw(st.sampled_from(["none", "service", "emergency"])),
        length_m=length,
        antenna_offset_m=antenna,
        route=draw(st.none() | st.lists(U32, max_size=255).map(tuple)),
        track_position=track,
        seq=draw(st.none() | U32),
        hdop=draw(st.none() | st.floats(min_value=0.0, max_value=1000.0)),
        fix_quality=draw(st.none() | st.integers(min_value=0, max_value=9)),
        odometer_m=draw(st.none() | st.floats(min_value=0.0, max_value=1e15)),
    )


def _report(**kw: object) -> VehicleReport:
    base: dict[str, object] = {
        "vehicle_id": "T1",
        "t": 1000.25,
        "lat": 50.0755381,
        "lon": 14.4378005,
        "speed_mps": 12.5,
        "course_deg": 271.5,
    }
    base.update(kw)
    return VehicleReport(**base)  # type: ignore[arg-type]


def _tlv(typ: int, value: bytes) -> bytes:
    return struct.pack(">BH", typ, len(value)) + value


def _hand_body(
    *,
    major: int = 1,
    minor: int = PROTOCOL_MINOR,
    vid: bytes = b"T1",
    t: float = 1000.25,
    seq: int = 0,
    lat: int = 500755381,
    lon: int = 144378005,
    speed: int = 1250,
    course: int = 27150,
    tlvs: bytes = b"",
    length: int | None = None,
    crc: int | None = None,
) -> bytes:
    """Build a frame body from the layout documented in the module docstring."""
    payload = bytes([len(vid)]) + vid + struct.pack(">dIiiHH", t, seq, lat, lon, speed, course)
    payload += tlvs
    head = struct.pack(">BBH", major, minor, 4 + len(payload) if length is None else length)
    head += payload
    return head + struct.pack(">I", zlib.crc32(head) if crc is None else crc)


def _reseal(head: bytes | bytearray) -> bytes:
    """Append a correct CRC-32 to a hand-made body (everything before the CRC)."""
    return bytes(head) + struct.pack(">I", zlib.crc32(head))


def _with_byte(body: bytes, offset: int, value: int) -> bytes:
    """Change one byte of a body (not its length field) and re-seal the CRC."""
    head = bytearray(body[:-4])
    head[offset] = value
    return _reseal(head)


def _wire(body: bytes) -> bytes:
    return b"\x00" + cobs_encode(body) + b"\x00"


def _reason(frame: bytes) -> str:
    with pytest.raises(FrameError) as info:
        decode_frame(frame)
    assert isinstance(info.value, ProtocolError)
    assert info.value.reason in REJECT_REASONS
    return info.value.reason


def _feed_chunked(dec: StreamDecoder, stream: bytes, cuts: list[int]) -> list[VehicleReport]:
    out: list[VehicleReport] = []
    bounds = [0, *sorted(c % (len(stream) + 1) for c in cuts), len(stream)]
    for a, b in itertools.pairwise(bounds):
        out += dec.feed(stream[a:b])
    return out


def _assert_quantised(dec: VehicleReport, orig: VehicleReport, seq: int) -> None:
    assert dec.vehicle_id == orig.vehicle_id
    assert dec.t == orig.t
    assert dec.seq == seq
    assert dec.braking == orig.braking
    assert dec.route == orig.route
    assert dec.fix_quality == orig.fix_quality
    assert abs(dec.lat - orig.lat) <= 0.5e-7 + 1e-12
    assert abs(dec.lon - orig.lon) <= 0.5e-7 + 1e-12
    assert abs(dec.speed_mps - orig.speed_mps) <= 0.005 + 1e-12
    dcourse = abs(dec.course_deg - orig.course_deg) % 360.0
    assert min(dcourse, 360.0 - dcourse) <= 0.005 + 1e-9
    assert 0.0 <= dec.course_deg < 360.0
    for name in ("length_m", "antenna_offset_m"):
        d, o = getattr(dec, name), getattr(orig, name)
        assert (d is None) == (o is None)
        if o is not None:
            tiny_length = name == "length_m" and o < 0.0005 and d == 0.001
            assert tiny_length or abs(d - o) <= 0.0005 + 1e-9
    assert (dec.track_position is None) == (orig.track_position is None)
    if dec.track_position is not None and orig.track_position is not None:
        assert dec.track_position.edge_id == orig.track_position.edge_id
        assert dec.track_position.direction == orig.track_position.direction
        assert abs(dec.track_position.offset_m - orig.track_position.offset_m) <= 0.0005 + 1e-9
    assert (dec.odometer_m is None) == (orig.odometer_m is None)
    if dec.odometer_m is not None and orig.odometer_m is not None:
        assert abs(dec.odometer_m - orig.odometer_m) <= 0.0005 + 1e-12 * orig.odometer_m
    assert (dec.hdop is None) == (orig.hdop is None)
    if dec.hdop is not None and orig.hdop is not None:
        assert abs(dec.hdop - min(orig.hdop, 655.35)) <= 0.005 + 1e-9


# --------------------------------------------------------------------------- COBS


@given(st.binary(max_size=2000))
def test_cobs_round_trip_and_no_marker(data: bytes) -> None:
    enc = cobs_encode(data)
    assert b"\x00" not in enc
    assert len(data) + 1 <= len(enc) <= len(data) + 1 + len(data) // 254
    assert cobs_decode(enc) == data


@given(st.lists(st.binary(min_size=0, max_size=600).map(lambda b: b.replace(b"\x00", b"\x07"))))
def test_cobs_round_trip_long_zero_free_runs(runs: list[bytes]) -> None:
    data = b"\x00".join(runs)
    enc = cobs_encode(data)
    assert b"\x00" not in enc
    assert cobs_decode(enc) == data


@pytest.mark.parametrize(
    ("raw", "encoded"),
    [
        (b"", b"\x01"),
        (b"\x00", b"\x01\x01"),
        (b"\x00\x00", b"\x01\x01\x01"),
        (b"\x00\x11\x00", b"\x01\x02\x11\x01"),
        (b"\x11\x22\x00\x33", b"\x03\x11\x22\x02\x33"),
        (b"\x11\x22\x33\x44", b"\x05\x11\x22\x33\x44"),
        (b"\x11\x00\x00\x00", b"\x02\x11\x01\x01\x01"),
        (bytes(range(1, 255)), b"\xff" + bytes(range(1, 255))),
        (bytes(range(0, 255)), b"\x01\xff" + bytes(range(1, 255))),
        (bytes(range(1, 256)), b"\xff" + bytes(range(1, 255)) + b"\x02\xff"),
        (bytes(range(2, 256)) + b"\x00", b"\xff" + bytes(range(2, 256)) + b"\x01\x01"),
        (bytes(range(3, 256)) + b"\x00\x01", b"\xfe" + bytes(range(3, 256)) + b"\x02\x01"),
    ],
)
def test_cobs_known_vectors(raw: bytes, encoded: bytes) -> None:
    assert cobs_encode(raw) == encoded
    assert cobs_decode(encoded) == raw


def test_cobs_decode_errors() -> None:
    with pytest.raises(FrameError) as info:
        cobs_decode(b"\x03\x11\x00\x22")
    assert info.value.reason == "cobs"
    with pytest.raises(FrameError) as info:
        cobs_decode(b"\x05\x11\x22")
    assert info.value.reason == "truncated"
    with pytest.raises(FrameError) as info:
        cobs_decode(b"")
    assert info.value.reason == "truncated"


# --------------------------------------------------------------------------- round trip


@given(reports(), st.none() | U32)
def test_round_trip_any_valid_report(report: VehicleReport, seq: int | None) -> None:
    frame = encode_report(report, seq=seq)
    assert frame[0] == 0 and frame[-1] == 0
    assert b"\x00" not in frame[1:-1]
    assert len(frame) <= MAX_FRAME_BYTES + 2
    expected_seq = seq if seq is not None else (report.seq if report.seq is not None else 0)
    decoded = decode_frame(frame)
    _assert_quantised(decoded, report, expected_seq)
    assert decode_frame(frame[1:-1]) == decoded  # delimiters are optional here
    # Quantisation is idempotent: a decoded report encodes to the same frame.
    assert encode_report(decoded) == frame


def test_layout_matches_documentation() -> None:
    report = _report(
        vehicle_id="Tram-7ž",
        braking="service",
        length_m=31.4,
        antenna_offset_m=2.5,
        track_position=ReportedTrackPosition(77, 12.345, -1),
        route=(77, 78, 4000000000),
        hdop=0.9,
        fix_quality=4,
        odometer_m=123456.789,
    )
    tlvs = (
        _tlv(1, b"\x01")
        + _tlv(2, struct.pack(">I", 31400))
        + _tlv(3, struct.pack(">I", 2500))
        + _tlv(4, struct.pack(">IIb", 77, 12345, -1))
        + _tlv(5, struct.pack(">3I", 77, 78, 4000000000))
        + _tlv(6, struct.pack(">H", 90))
        + _tlv(7, b"\x04")
        + _tlv(8, struct.pack(">Q", 123456789))
    )
    body = _hand_body(vid="Tram-7ž".encode(), seq=41, tlvs=tlvs)
    assert encode_report(report, seq=41) == _wire(body)
    assert body[0] == PROTOCOL_MAJOR


def test_minimal_frame_size() -> None:
    frame = encode_report(_report(vehicle_id="TRAM06"))
    assert len(frame) == 42  # 39-byte body + 1 byte COBS + 2 delimiters
    assert frame == _wire(_hand_body(vid=b"TRAM06"))


def test_quantisation_edge_cases() -> None:
    r = decode_frame(encode_report(_report(course_deg=359.999, lat=90.0, lon=-180.0)))
    assert r.course_deg == 0.0
    assert encode_report(_report(course_deg=359.999)) == encode_report(_report(course_deg=0.0))
    assert (r.lat, r.lon) == (90.0, -180.0)
    assert decode_frame(encode_report(_report(length_m=1e-9))).length_m == 0.001
    assert decode_frame(encode_report(_report(hdop=999.0))).hdop == 655.35
    assert decode_frame(encode_report(_report(speed_mps=100.0))).speed_mps == 100.0
    assert decode_frame(encode_report(_report(route=()))).route == ()
    assert decode_frame(encode_report(_report(), seq=2**32 - 1)).seq == 2**32 - 1


def test_next_seq_wraps() -> None:
    assert next_seq(0) == 1
    assert next_seq(2**32 - 1) == 0


# --------------------------------------------------------------------------- encode errors


@pytest.mark.parametrize("seq", [2**32, -1])
def test_encode_seq_argument_out_of_range(seq: int) -> None:
    with pytest.raises(ProtocolError, match="seq") as info:
        encode_report(_report(), seq=seq)
    assert isinstance(info.value, EncodeError) and isinstance(info.value, AntikolError)
    assert info.value.field.startswith("seq")


def test_encode_report_seq_out_of_range() -> None:
    with pytest.raises(EncodeError, match="seq") as info:
        encode_report(_report(seq=2**40))
    assert info.value.field == "seq"


@pytest.mark.parametrize(
    ("kw", "field"),
    [
        ({"antenna_offset_m": 5e6}, "antenna_offset_m"),
        ({"track_position": ReportedTrackPosition(1, 5e6, 1)}, "track_position.offset_m"),
    ],
)
def test_encode_unrepresentable_value_names_field(kw: dict[str, object], field: str) -> None:
    with pytest.raises(ProtocolError, match=field.replace(".", r"\.")) as info:
        encode_report(_report(**kw))
    assert isinstance(info.value, EncodeError)
    assert info.value.field == field


# --------------------------------------------------------------------------- decode errors


def test_bad_crc_counted_as_crc() -> None:
    body = bytearray(_hand_body())
    body[-1] ^= 0x01
    frame = _wire(bytes(body))
    assert _reason(frame) == "crc"
    dec = StreamDecoder()
    assert dec.feed(frame + encode_report(_report(seq=5))) == [
        decode_frame(encode_report(_report(seq=5)))
    ]
    assert dec.stats.rejected["crc"] == 1
    assert dec.stats.frames_ok == 1


def test_flipped_payload_bit_counted_as_crc() -> None:
    body = bytearray(_hand_body())
    body[20] ^= 0x10  # inside the fixed fields, length field intact
    assert _reason(_wire(bytes(body))) == "crc"


def test_unknown_major_version_rejected() -> None:
    frame = _wire(_hand_body(major=PROTOCOL_MAJOR + 1))
    assert _reason(frame) == "bad_version"
    dec = StreamDecoder()
    assert dec.feed(frame) == []
    assert dec.stats.rejected["bad_version"] == 1
    assert dec.stats.rejected_total == 1


def test_newer_minor_version_unknown_tlv_skipped_and_counted() -> None:
    tlvs = _tlv(200, b"future") + _tlv(1, b"\x02") + _tlv(201, b"")
    frame = _wire(_hand_body(minor=7, tlvs=tlvs, seq=3))
    dec = StreamDecoder()
    (report,) = dec.feed(frame)
    assert report.braking == "emergency"
    assert report.seq == 3
    assert dec.stats.tlvs_skipped == 2
    assert dec.stats.rejected_total == 0


def test_every_truncation_counted_as_truncated() -> None:
    frame = encode_report(
        _report(route=tuple(range(1, 80)), length_m=30.0, track_position=None, hdop=1.2)
    )
    for cut in range(2, len(frame) - 1):  # keep >= 1 body byte, lose the trailing delimiter
        assert _reason(frame[:cut]) == "truncated", cut


def test_truncated_frame_in_stream_does_not_hide_next_frame() -> None:
    good = encode_report(_report(seq=9))
    dec = StreamDecoder()
    got = dec.feed(good[:20] + good)
    assert got == [decode_frame(good)]
    assert dec.stats.rejected["truncated"] == 1


def test_too_long_garbage_counted_once_and_decoder_recovers() -> None:
    good = encode_report(_report(seq=11))
    dec = StreamDecoder(max_frame_bytes=256)
    for _ in range(100):  # 10,000 bytes without a delimiter, in small chunks
        assert dec.feed(b"\x55" * 100) == []
        assert dec.stats.bytes_pending <= 256
    assert dec.feed(good) == [decode_frame(good)]
    assert dec.stats.rejected["too_long"] == 1
    assert dec.stats.rejected_total == 1
    # one huge chunk, and an over-long run closed inside the same chunk
    assert dec.feed(b"\x33" * 5000 + good + b"\x44" * 300 + good) == [decode_frame(good)] * 2
    assert dec.stats.rejected["too_long"] == 3
    # an over-long tail after a delimiter in one chunk is not buffered either
    assert dec.feed(good + b"\x66" * 5000) == [decode_frame(good)]
    assert dec.stats.bytes_pending == 0
    assert dec.stats.rejected["too_long"] == 4
    assert dec.feed(good) == [decode_frame(good)]


def test_decode_frame_too_long() -> None:
    assert _reason(b"\x01" * (MAX_FRAME_BYTES + 1)) == "too_long"


def test_zero_inside_body_is_cobs_error() -> None:
    frame = encode_report(_report())
    assert _reason(frame[:10] + b"\x00" + frame[10:]) == "cobs"


@pytest.mark.parametrize(
    "body",
    [
        _hand_body(lat=900_000_001),  # lat > 90 degrees
        _hand_body(lon=-1_800_000_001),
        _hand_body(speed=10_001),  # > 100 m/s
        _hand_body(course=36_001),
        _hand_body(vid=b""),
        _hand_body(vid=b"\xff\xfe"),  # not UTF-8
        _hand_body(vid=b"a\nb"),  # control character
        _hand_body(t=math.nan),
        _hand_body(tlvs=_tlv(1, b"\x03")),  # braking code unknown
        _hand_body(tlvs=_tlv(4, struct.pack(">IIb", 1, 2, 0))),  # direction 0
        _hand_body(tlvs=_tlv(2, struct.pack(">I", 0))),  # length 0 m
        _hand_body(tlvs=_tlv(2, struct.pack(">I", 10_000)) + _tlv(3, struct.pack(">I", 20_000))),
        _hand_body(tlvs=_tlv(7, b"\x0a")),  # fix quality 10
        _hand_body(tlvs=_tlv(5, bytes(4 * 256))),  # 256 route edges
        _hand_body(vid=b"x" * 33),  # id longer than 32 bytes
    ],
)
def test_invalid_values_counted_as_invalid_value(body: bytes) -> None:
    frame = _wire(body)
    assert _reason(frame) == "invalid_value"
    dec = StreamDecoder()
    assert dec.feed(frame) == []
    assert dec.stats.rejected["invalid_value"] == 1


def test_invalid_value_is_not_an_invalid_report_error() -> None:
    with pytest.raises(ProtocolError) as info:
        decode_frame(_wire(_hand_body(lat=900_000_001)))
    assert not isinstance(info.value, InvalidReportError)
    assert "lat" in str(info.value)


@pytest.mark.parametrize(
    ("body", "detail"),
    [
        (_hand_body(tlvs=_tlv(2, b"\x00\x01")), "bad length 2"),  # known TLV, wrong size
        (_hand_body(tlvs=_tlv(5, b"\x00\x01\x02")), "bad length 3"),  # route not 4*k bytes
        (_hand_body(tlvs=_tlv(7, b"\x01") + _tlv(7, b"\x01")), "repeated"),
        (_hand_body(tlvs=_tlv(9, b"abc")[:-1]), "TLV type 9"),  # value past the end
        (_hand_body(tlvs=b"\x09\x00"), "TLV header"),  # header past the end
        (_with_byte(_hand_body(), 4, 60), "fixed fields"),  # id length too large
        (_reseal(b"\x01\x00\x00\x04"), "vehicle id length"),  # header only
        (_hand_body(length=50), "length field 50"),  # disagrees with the body, CRC intact
    ],
)
def test_structural_errors_counted_as_bad_payload(body: bytes, detail: str) -> None:
    with pytest.raises(FrameError, match=detail) as info:
        decode_frame(_wire(body))
    assert info.value.reason == "bad_payload"


def test_rejections_logged_at_debug(caplog: pytest.LogCaptureFixture) -> None:
    dec = StreamDecoder()
    with caplog.at_level(logging.DEBUG, logger="antikol.ingest.protocol"):
        dec.feed(_wire(_hand_body(major=9)))
    assert any(
        rec.levelno == logging.DEBUG and "bad_version" in rec.getMessage() for rec in caplog.records
    )


def test_stats_snapshot_is_frozen_and_complete() -> None:
    dec = StreamDecoder()
    before = dec.stats
    dec.feed(encode_report(_report()) + b"\x00garbage\x00")
    assert before.frames_ok == 0 and before.rejected_total == 0
    assert set(dec.stats.rejected) == set(REJECT_REASONS)
    assert dec.stats.frames_ok == 1
    assert dec.stats.rejected_total == 1
    with pytest.raises(TypeError):
        dec.stats.rejected["crc"] = 5  # type: ignore[index]


def test_feed_accepts_bytes_like_and_keeps_partial_frame_pending() -> None:
    frame = encode_report(_report(seq=4))
    dec = StreamDecoder()
    assert dec.feed(bytearray(frame[:-1])) == []
    assert dec.stats.bytes_pending == len(frame) - 2
    assert dec.feed(memoryview(frame[-1:])) == [decode_frame(frame)]
    assert dec.stats.bytes_pending == 0
    assert dec.feed(b"") == []


def test_decoder_bug_is_counted_not_raised(monkeypatch: pytest.MonkeyPatch) -> None:
    import antikol.ingest.protocol as protocol

    def broken(body: bytes, verifier: object = None) -> tuple[VehicleReport, int]:
        raise RuntimeError("bug")

    monkeypatch.setattr(protocol, "_decode_body", broken)
    dec = StreamDecoder()
    assert dec.feed(encode_report(_report()) * 2) == []
    assert dec.stats.rejected["internal_error"] == 2


def test_invalid_max_frame_bytes() -> None:
    with pytest.raises(ValueError):
        StreamDecoder(max_frame_bytes=3)


def test_interleaved_senders_in_order() -> None:
    reports_sent = [
        _report(vehicle_id=f"V{k % 32:02d}", t=float(k), seq=k // 32, lat=50.0 + k * 1e-5)
        for k in range(32 * 10)
    ]
    stream = b"".join(encode_report(r) for r in reports_sent)
    dec = StreamDecoder()
    got = []
    for i in range(0, len(stream), 97):
        got += dec.feed(stream[i : i + 97])
    assert got == [decode_frame(encode_report(r)) for r in reports_sent]
    assert dec.stats.frames_ok == len(reports_sent)
    assert dec.stats.rejected_total == 0


# --------------------------------------------------------------------------- robustness


@given(st.binary(max_size=5000), st.lists(st.integers(min_value=0), max_size=30))
def test_random_bytes_never_raise(data: bytes, cuts: list[int]) -> None:
    dec = StreamDecoder(max_frame_bytes=512)
    out = _feed_chunked(dec, data, cuts)
    out += dec.feed(b"\x00")
    assert out == []  # random bytes do not pass CRC-32
    assert dec.stats.rejected["internal_error"] == 0
    assert dec.stats.bytes_pending == 0


@given(st.binary(max_size=3000))
def test_decode_frame_raises_only_frame_errors(data: bytes) -> None:
    with pytest.raises(FrameError):
        decode_frame(data)


@given(st.lists(st.binary(max_size=300) | reports().map(encode_report), max_size=12), st.data())
def test_mixed_garbage_and_frame_fragments_never_raise(
    pieces: list[bytes], data: st.DataObject
) -> None:
    # Fragments of real frames exercise the deeper decoder paths.
    stream = b"".join(p[: data.draw(st.integers(0, len(p)))] for p in pieces)
    dec = StreamDecoder()
    _feed_chunked(dec, stream + b"\x00", data.draw(st.lists(st.integers(min_value=0))))
    assert dec.stats.rejected["internal_error"] == 0


def _corrupt(data: st.DataObject, frame: bytes, kind: str) -> bytes:
    """Corrupt ``frame``'s body bytes (its delimiters stay intact, except truncation)."""
    b = bytearray(frame)
    if kind == "flip":
        for _ in range(data.draw(st.integers(1, 4))):
            pos = data.draw(st.integers(1, len(b) - 2))
            b[pos] ^= 1 << data.draw(st.integers(0, 7))
    elif kind == "truncate":  # keep the leading delimiter and >= 1 body byte
        b = b[: data.draw(st.integers(2, len(b) - 2))]
    elif kind == "insert":
        pos = data.draw(st.integers(1, len(b) - 1))
        b[pos:pos] = data.draw(st.binary(min_size=1, max_size=20))
    elif kind == "replace":
        pos = data.draw(st.integers(1, len(b) - 2))
        new = data.draw(st.integers(0, 255))
        assume(new != b[pos])
        b[pos] = new
    return bytes(b)


@given(st.lists(reports(), min_size=1, max_size=8), st.data())
def test_corrupted_stream_yields_untouched_frames_exactly_once(
    sent_reports: list[VehicleReport], data: st.DataObject
) -> None:
    frames = [encode_report(r, seq=i) for i, r in enumerate(sent_reports)]
    sent = [decode_frame(f) for f in frames]  # seq = index makes every report unique
    kinds = ["none", "none", "flip", "truncate", "insert", "replace"]
    stream = b""
    corrupted: set[int] = set()
    for i, frame in enumerate(frames):
        kind = data.draw(st.sampled_from(kinds))
        if kind != "none":
            corrupted.add(i)
            frame = _corrupt(data, frame, kind)
        if data.draw(st.booleans()):  # garbage between frames
            stream += b"\x00" + data.draw(st.binary(max_size=40)) + b"\x00"
        stream += frame
    stream += b"\x00"  # end of stream: close a truncated last frame

    dec = StreamDecoder()
    got = _feed_chunked(dec, stream, data.draw(st.lists(st.integers(min_value=0), max_size=25)))

    stats = dec.stats
    assert stats.frames_ok == len(got)
    assert stats.rejected["internal_error"] == 0
    assert set(got) <= set(sent)  # nothing that was never sent
    counts = Counter(r.seq for r in got)
    for i in range(len(frames)):
        if i not in corrupted:
            assert counts[i] == 1
    # Each corrupted frame leaves >= 1 non-empty stretch: it is yielded or rejected.
    lost = sum(1 for i in corrupted if counts[i] == 0)
    assert stats.rejected_total >= lost


@given(st.lists(reports(), min_size=1, max_size=6), st.data())
def test_bit_flips_anywhere_never_yield_unsent_reports(
    sent_reports: list[VehicleReport], data: st.DataObject
) -> None:
    frames = [encode_report(r, seq=i) for i, r in enumerate(sent_reports)]
    sent = {decode_frame(f) for f in frames}
    stream = bytearray(b"".join(frames))
    for _ in range(data.draw(st.integers(1, 8))):  # delimiters may be hit too
        stream[data.draw(st.integers(0, len(stream) - 1))] ^= 1 << data.draw(st.integers(0, 7))
    dec = StreamDecoder()
    got = _feed_chunked(dec, bytes(stream) + b"\x00", data.draw(st.lists(st.integers(0))))
    assert set(got) <= sent
    assert dec.stats.frames_ok == len(got)
    assert dec.stats.rejected["internal_error"] == 0
