"""Authenticated frames (HMAC-SHA-256, Ed25519), key files, and the replay guard."""

from __future__ import annotations

import logging
import os
import struct
import tracemalloc
import zlib
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from antikol.errors import InputFileError, InvalidArgumentError
from antikol.ingest.auth import (
    AuthConfigError,
    Ed25519Signer,
    Ed25519Verifier,
    HmacSigner,
    HmacVerifier,
    generate_key_files,
    load_key_file,
)
from antikol.ingest.cobs import cobs_decode, cobs_encode
from antikol.ingest.guard import GUARD_REASONS, ReplayGuard
from antikol.ingest.protocol import (
    PROTOCOL_MINOR,
    FrameError,
    StreamDecoder,
    decode_frame,
    encode_report,
)
from antikol.report import VehicleReport
from tests._memory import traced_peak

KEY = bytes(range(32))
R = VehicleReport("T1", 100.0, 50.06306, 19.93260, 8.0, 90.0, length_m=32.0, odometer_m=1234.5)


def body_of(frame: bytes) -> bytes:
    return cobs_decode(frame.strip(b"\x00"))


def wire(body: bytes) -> bytes:
    return b"\x00" + cobs_encode(body) + b"\x00"


def reseal(body: bytes) -> bytes:
    head = body[:-4]
    return head + struct.pack(">I", zlib.crc32(head))


def reason(frame: bytes, verifier: object) -> str:
    with pytest.raises(FrameError) as info:
        decode_frame(frame, verifier=verifier)  # type: ignore[arg-type]
    return info.value.reason


# --------------------------------------------------------------------------- frames


def test_hmac_frame_layout_round_trip_and_size() -> None:
    frame = encode_report(R, seq=9, signer=HmacSigner(KEY, 7))
    plain = encode_report(R, seq=9)
    body = body_of(frame)
    # the tag TLV (header 3, scheme and key id 3, tag 32) makes the body 38 bytes longer
    assert len(body) == len(body_of(plain)) + 38
    assert body[1] == PROTOCOL_MINOR
    tag_at = len(body) - 4 - 32
    assert body[tag_at - 6 : tag_at] == struct.pack(">BHBH", 9, 35, 1, 7)
    import hashlib
    import hmac

    assert body[tag_at:-4] == hmac.digest(KEY, body[:tag_at], hashlib.sha256)
    decoded = decode_frame(frame, verifier=HmacVerifier({7: KEY}))
    assert decoded == decode_frame(plain)
    assert decoded.odometer_m == 1234.5
    # a receiver without keys (the paper's protocol, or an old one) still reads it
    assert decode_frame(frame) == decoded


def test_ed25519_frame_verifies_only_with_the_senders_key() -> None:
    t1, t2 = Ed25519Signer(b"\x01" * 32), Ed25519Signer(b"\x02" * 32)
    verifier = Ed25519Verifier({"T1": t1.public_key(), "T2": t2.public_key()})
    frame = encode_report(R, signer=t1)
    assert len(body_of(frame)) == len(body_of(encode_report(R))) + 70
    assert decode_frame(frame, verifier=verifier).vehicle_id == "T1"
    # T2 signing a frame that claims to be T1: refused
    assert reason(encode_report(R, signer=t2), verifier) == "bad_signature"
    # a vehicle the fleet does not know
    assert reason(encode_report(replace(R, vehicle_id="X"), signer=t1), verifier) == "unknown_key"
    # an HMAC frame sent to an Ed25519 fleet
    assert reason(encode_report(R, signer=HmacSigner(KEY)), verifier) == "unknown_key"


@pytest.mark.parametrize("scheme", ["hmac", "ed25519"])
def test_every_tampering_is_refused(scheme: str) -> None:
    if scheme == "hmac":
        signer, verifier = HmacSigner(KEY, 1), HmacVerifier({1: KEY})
    else:
        signer = Ed25519Signer(b"\x03" * 32)
        verifier = Ed25519Verifier({"T1": signer.public_key()})
    body = body_of(encode_report(R, seq=5, signer=signer))
    assert reason(encode_report(R), verifier) == "unsigned"
    assert reason(encode_report(R, signer=HmacSigner(bytes(32), 1)), verifier) in (
        "bad_signature",
        "unknown_key",
    )
    # change any byte before the tag and fix the CRC, as a forger can: never accepted
    tag_start = len(body) - 4 - (32 if scheme == "hmac" else 64)
    for offset in range(tag_start):
        mutated = bytearray(body)
        mutated[offset] ^= 0x40
        with pytest.raises(FrameError) as info:
            decode_frame(wire(reseal(bytes(mutated))), verifier=verifier)
        assert info.value.reason in (
            "bad_signature",
            "unknown_key",
            "bad_payload",
            "bad_version",
            "unsigned",
            "invalid_value",
        )


def test_auth_tlv_must_be_last_and_well_sized() -> None:
    body = body_of(encode_report(R, signer=HmacSigner(KEY, 1)))
    head = body[:-4]
    # another TLV after the tag
    extra = head + struct.pack(">BH", 1, 1) + b"\x01"
    extra = extra[:2] + struct.pack(">H", len(extra)) + extra[4:]
    assert reason(wire(reseal(extra + b"\x00\x00\x00\x00")), None) == "bad_payload"
    # a tag TLV too short to hold scheme and key id
    short = bytearray(body_of(encode_report(R)))[:-4] + struct.pack(">BH", 9, 2) + b"\x01\x00"
    short[2:4] = struct.pack(">H", len(short))
    assert reason(wire(reseal(bytes(short) + b"\x00" * 4)), None) == "bad_payload"


def test_old_minor_version_frames_still_decode() -> None:
    body = bytearray(body_of(encode_report(replace(R, odometer_m=None))))
    body[1] = 0  # written by a version-1.0 sender
    assert decode_frame(wire(reseal(bytes(body)))).vehicle_id == "T1"


def test_stream_decoder_with_verifier_counts_rejections() -> None:
    dec = StreamDecoder(verifier=HmacVerifier({1: KEY}))
    good = encode_report(R, seq=1, signer=HmacSigner(KEY, 1))
    forged = encode_report(replace(R, lat=49.0), seq=2, signer=HmacSigner(bytes(16), 1))
    out = dec.feed(good + encode_report(R, seq=3) + forged + good)
    assert [r.seq for r in out] == [1, 1]
    assert dec.stats.rejected["unsigned"] == 1 and dec.stats.rejected["bad_signature"] == 1


# --------------------------------------------------------------------------- key files


def test_generated_hmac_key_file_round_trip(tmp_path: Path) -> None:
    files = generate_key_files(tmp_path, "hmac-sha256", ["T1", "T2"])
    assert files["T1"] == files["T2"]
    assert os.stat(files["T1"]).st_mode & 0o777 == 0o600
    keys = load_key_file(files["T1"])
    assert keys.scheme == "hmac-sha256" and keys.signer is not None
    frame = encode_report(R, signer=keys.signer)
    assert decode_frame(frame, verifier=keys.verifier).vehicle_id == "T1"
    assert "key=" not in repr(keys.signer)  # a key never shows up in logs


def test_generated_ed25519_key_files(tmp_path: Path) -> None:
    files = generate_key_files(tmp_path, "ed25519", ["T1", 'odd "id"'])
    t1 = load_key_file(files["T1"])
    other = load_key_file(files['odd "id"'])
    public = load_key_file(files[""])
    assert t1.owner == "T1" and public.signer is None
    frame = encode_report(R, signer=t1.signer)
    for keys in (t1, other, public):
        assert decode_frame(frame, verifier=keys.verifier).vehicle_id == "T1"
    assert reason(encode_report(R, signer=other.signer), public.verifier) == "bad_signature"


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ('scheme = "rot13"\n', "scheme"),
        ('scheme = "hmac-sha256"\n', "keys"),
        ('scheme = "hmac-sha256"\n[keys]\n1 = "abcd"\n', "keys.1"),
        ('scheme = "hmac-sha256"\n[keys]\n1 = "zz"\n', "keys.1"),
        ('scheme = "hmac-sha256"\nsend_key = 2\n[keys]\n1 = "' + "ab" * 16 + '"\n', "send_key"),
        ('scheme = "hmac-sha256"\n[keys]\nx = "' + "ab" * 16 + '"\n', "keys.x"),
        ('scheme = "ed25519"\n', "public_keys"),
        ('scheme = "ed25519"\n[public_keys]\nT1 = "abcd"\n', "public_keys.T1"),
        ("scheme = \n", "TOML"),
    ],
)
def test_bad_key_files_name_the_field(tmp_path: Path, text: str, field: str) -> None:
    path = tmp_path / "k.toml"
    path.write_text(text)
    with pytest.raises(AuthConfigError) as info:
        load_key_file(path)
    assert field in str(info.value)
    assert isinstance(info.value, ValueError)


HEX = "ab" * 16


@pytest.mark.parametrize(
    ("name", "shown"),
    [
        ('"²"', "keys.²"),  # isdigit() but no decimal digit: int() raised a bare ValueError
        ('"١"', "keys.١"),  # an Arabic-Indic one was read as key id 1
        ('"1١"', "keys.1١"),
        ('" 1"', "keys. 1"),
        ("65536", "keys.65536"),
        ('"' + "9" * 5000 + '"', "keys.9999"),  # beyond int()'s 4300 digits: a bare ValueError
    ],
)
def test_key_ids_are_ascii_integers_of_the_frames_range(
    tmp_path: Path, name: str, shown: str
) -> None:
    """Found by a probe: key ids were read with str.isdigit() and int()."""
    path = tmp_path / "k.toml"
    path.write_text(f'scheme = "hmac-sha256"\n[keys]\n{name} = "{HEX}"\n', encoding="utf-8")
    with pytest.raises(AuthConfigError, match="key ids are integers 0..65535") as info:
        load_key_file(path)
    assert str(path) in str(info.value) and shown in str(info.value)
    assert len(str(info.value)) < 300  # a huge id is not echoed whole


def test_key_ids_keep_their_leading_zeros_and_range(tmp_path: Path) -> None:
    path = tmp_path / "k.toml"
    path.write_text(
        f'scheme = "hmac-sha256"\nsend_key = 7\n[keys]\n0 = "{HEX}"\n"00007" = "{HEX}"\n'
        f'65535 = "{HEX}"\n'
        f'"{"0" * 5000}1" = "{HEX}"\n'
    )
    keys = load_key_file(path)
    assert keys.signer is not None and keys.signer.key_id == 7
    assert sorted(keys.verifier._keys) == [0, 1, 7, 65535]  # type: ignore[attr-defined]


def test_one_key_id_written_twice_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "k.toml"
    path.write_text(f'scheme = "hmac-sha256"\n[keys]\n1 = "{HEX}"\n"01" = "{"cd" * 16}"\n')
    with pytest.raises(AuthConfigError, match="key id 1") as info:
        load_key_file(path)
    assert str(path) in str(info.value) and "keys.01" in str(info.value)


@pytest.mark.parametrize(
    "value",
    ["[" * 100_000 + "]" * 100_000, "{a=" * 3000 + "1" + "}" * 3000, "9" * 5000],
)
def test_deeply_nested_toml_or_huge_integers_are_key_file_errors(
    tmp_path: Path, value: str
) -> None:
    """Found by a probe: tomllib's parser recursed until RecursionError, and let int()'s
    bare ValueError for more than 4300 digits out."""
    path = tmp_path / "k.toml"
    path.write_text(f'scheme = "hmac-sha256"\nx = {value}\n')
    with pytest.raises(AuthConfigError, match="not valid TOML") as info:
        load_key_file(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ('scheme = "hmac-sha256"\n[keys]\n1 = "abcd"\n', "keys.1"),
        ('scheme = "ed25519"\n[public_keys]\nT1 = "abcd"\n', "public_keys.T1"),
        (
            'scheme = "ed25519"\n[public_keys]\nT1 = "' + "00" * 32 + '"\n'
            '[private_key]\nvehicle_id = "T1"\nkey = "00"\n',
            "private_key.key",
        ),
    ],
)
def test_key_errors_of_the_signer_and_verifier_name_the_file(
    tmp_path: Path, text: str, field: str
) -> None:
    """AuthConfigError promises the file in its message; the signer and verifier classes,
    which check key lengths, know no file."""
    if "ed25519" in text:
        pytest.importorskip("cryptography")
    path = tmp_path / "k.toml"
    path.write_text(text)
    with pytest.raises(AuthConfigError) as info:
        load_key_file(path)
    assert info.value.field == f"{path}: {field}"


def test_private_key_must_match_its_public_key(tmp_path: Path) -> None:
    files = generate_key_files(tmp_path, "ed25519", ["T1", "T2"])
    text = files["T1"].read_text()
    t2_public = load_key_file(files["T2"]).signer.public_key()  # type: ignore[union-attr]
    lines = [ln for ln in text.splitlines() if not ln.startswith('"T1"')]
    lines.append(f'"T1" = "{t2_public.hex()}"')
    files["T1"].write_text("\n".join(lines) + "\n")
    with pytest.raises(AuthConfigError, match="does not match"):
        load_key_file(files["T1"])


def test_missing_key_file_and_readable_secret(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with pytest.raises(InputFileError):
        load_key_file(tmp_path / "missing.toml")
    path = tmp_path / "fleet.toml"
    path.write_text('scheme = "hmac-sha256"\n[keys]\n1 = "' + "ab" * 32 + '"\n')
    path.chmod(0o644)
    with caplog.at_level(logging.WARNING):
        load_key_file(path)
    assert "readable by other users" in caplog.text


def test_short_hmac_keys_are_refused() -> None:
    with pytest.raises(AuthConfigError):
        HmacSigner(b"short")
    with pytest.raises(AuthConfigError):
        HmacVerifier({})


# --------------------------------------------------------------------------- replay guard


def rep(seq: int, t: float, vid: str = "T2") -> VehicleReport:
    return VehicleReport(vid, t, 50.0, 19.9, 8.0, 90.0, seq=seq)


def test_guard_duplicates_reordering_and_replays() -> None:
    g = ReplayGuard(seq_window=8, max_age_s=5.0, max_ahead_s=2.0)
    assert g.check(rep(10, 100.0), 100.0) is None
    assert g.check(rep(10, 100.0), 100.1) == "duplicate"
    assert g.check(rep(12, 102.0), 102.0) is None
    assert g.check(rep(11, 101.0), 102.1) is None  # reordered, once
    assert g.check(rep(11, 101.0), 102.2) == "duplicate"
    assert g.check(rep(3, 101.5), 102.2) == "replay"  # below the window, not newer
    assert g.check(rep(13, 110.0), 102.2) == "future"
    assert g.check(rep(13, 96.0), 102.2) == "too_old"
    assert g.check(rep(13, 102.5), None) == "no_clock"
    assert g.stats["accepted"] == 3
    assert set(g.stats) - {"accepted", "resync"} <= set(GUARD_REASONS)


def test_guard_wraps_sequence_numbers_and_resyncs_a_restarted_sender() -> None:
    g = ReplayGuard()
    assert g.check(rep(2**32 - 2, 10.0), 10.0) is None
    assert g.check(rep(2**32 - 1, 11.0), 11.0) is None
    assert g.check(rep(0, 12.0), 12.0) is None  # wrapped
    assert g.check(rep(2**32 - 1, 11.0), 12.0) == "duplicate"
    # the sender restarts with a small number and a newer time: a new window
    assert g.check(rep(5_000_000, 13.0), 13.0) is None
    assert g.check(rep(7, 14.0), 14.0) is None
    assert g.stats["resync"] == 1
    assert g.check(rep(5_000_000, 13.0), 14.0) == "replay"


def test_guard_rejections_leave_its_state_unchanged() -> None:
    g = ReplayGuard()
    assert g.check(rep(100, 50.0), 50.0) is None
    # a far-future frame with a huge sequence number must not poison the window
    assert g.check(rep(2**31, 1e9), 50.0) == "future"
    assert g.check(rep(101, 51.0), 51.0) is None


def test_guard_keeps_a_bounded_number_of_senders() -> None:
    g = ReplayGuard(max_senders=100)
    for i in range(10_000):
        g.check(rep(1, 0.0, vid=f"V{i}"), 0.0)
    assert len(g) == 100


@settings(max_examples=50)
@given(st.lists(st.tuples(st.integers(0, 2**32 - 1), st.floats(-10, 10)), max_size=60))
def test_guard_never_accepts_the_same_frame_twice(frames: list[tuple[int, float]]) -> None:
    g = ReplayGuard()
    accepted = set()
    for seq, t in frames + frames:
        if g.check(rep(seq, t), 0.0) is None:
            assert (seq, t) not in accepted
            accepted.add((seq, t))


def test_guard_validates_its_arguments() -> None:
    with pytest.raises(InvalidArgumentError):
        ReplayGuard(seq_window=0)
    with pytest.raises(InvalidArgumentError):
        ReplayGuard(max_age_s=float("nan"))
    with pytest.raises(InvalidArgumentError):
        ReplayGuard(max_senders=0)


def test_analyser_feed_bytes_takes_only_authenticated_fresh_frames():
    """Radio bytes fed to an analyser with the fleet's keys and a replay guard: a forged
    frame, an unsigned one and a replayed copy never reach the vehicle table."""
    import antikol
    from antikol.ingest.protocol import encode_report

    key = bytes(range(32))
    an = antikol.Analyser(
        own_id="T1",
        verifier=antikol.HmacVerifier({3: key}),
        replay_guard=antikol.ReplayGuard(),
    )
    an.update(antikol.VehicleReport("T1", 100.0, 50.06, 19.93, 8.0, 90.0))
    other = antikol.VehicleReport("T2", 100.0, 50.06, 19.932, 8.0, 90.0)
    good = encode_report(other, seq=5, signer=antikol.HmacSigner(key, 3))
    forged = encode_report(
        antikol.VehicleReport("T3", 100.0, 50.06, 19.931, 0.0, 90.0),
        seq=1,
        signer=antikol.HmacSigner(bytes(32), 3),
    )
    unsigned = encode_report(antikol.VehicleReport("T4", 100.0, 50.06, 19.931, 0.0, 90.0))
    assert [u.accepted for u in an.feed_bytes(forged + unsigned + good)] == [True]
    assert an.feed_bytes(good) == []  # the same frame again: a replay
    assert sorted(r.vehicle_id for r in an.table) == ["T1", "T2"]
    rejected = an.decoder_stats.rejected
    assert rejected["bad_signature"] == 1 and rejected["unsigned"] == 1
    assert an.replay_guard.stats["duplicate"] == 1
    assert [t.vehicle_id for t in an.assess().threats] == ["T2"]


def test_guard_refuses_a_frame_of_before_a_restart_that_fits_the_new_window() -> None:
    """Found by the property above: after a sender restarts its numbers, a recorded frame
    from before the restart whose number falls in the new window was accepted again."""
    g = ReplayGuard()
    assert g.check(rep(64, 0.0), 0.0) is None
    assert g.check(rep(0, 1.0), 1.0) is None  # the sender restarted
    assert g.check(rep(65, 1.0), 1.0) is None
    assert g.check(rep(64, 0.0), 1.0) == "replay"
    assert g.check(rep(63, 1.0), 1.0) is None  # a late frame of the new numbering


def test_guard_cost_of_a_huge_sequence_jump_is_bounded_by_its_window() -> None:
    """Found by a probe: a number far ahead shifted the bitmap by the jump, up to 2**31
    bits (a 256 MB integer a frame, from a single unauthenticated frame); a jump beyond
    the window must start a fresh bitmap, at a cost bounded by the window alone."""
    g = ReplayGuard(seq_window=64)
    assert g.check(rep(0, 100.0), 100.0) is None
    tracemalloc.start()
    try:
        for i in range(1, 4):
            seq = i * (2**31 - 1) % 2**32  # each just under half the number space ahead
            assert g.check(rep(seq, 100.0 + i * 0.01), 100.1) is None
            assert g._senders["T2"].bitmap == 1  # every earlier number left the window
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 64 * 1024


def test_guard_jump_beyond_the_window_starts_a_fresh_window() -> None:
    g = ReplayGuard(seq_window=8)
    assert g.check(rep(10, 100.0), 100.0) is None
    assert g.check(rep(12, 100.1), 100.1) is None
    assert g.check(rep(1_000_000, 100.2), 100.2) is None  # frames lost: a fresh window
    assert g._senders["T2"].bitmap.bit_length() <= 8
    assert g.check(rep(1_000_000, 100.2), 100.2) == "duplicate"
    assert g.check(rep(999_995, 100.2), 100.2) is None  # in the new window, once
    assert g.check(rep(999_995, 100.2), 100.2) == "duplicate"
    assert g.check(rep(12, 100.1), 100.3) == "replay"  # the old window is gone
    assert g.stats["resync"] == 0
    # a jump of exactly the window leaves only the new number in it, as a shift would
    assert g.check(rep(1_000_008, 100.3), 100.3) is None
    assert g._senders["T2"].bitmap == 1


def test_receiver_without_verifier_survives_huge_sequence_jumps() -> None:
    """The probe's datagram: 30 frames of one sender, each about 2**31 numbers ahead."""
    from antikol.onboard.receiver import SecureReceiver

    rx = SecureReceiver(own_id="T1", verifier=None)
    now = 1_700_000_000.0
    datagram = b"".join(
        encode_report(rep(0, now + i * 1e-3, vid="X"), seq=i * (2**31 - 1) % 2**32)
        for i in range(30)
    )
    accepted, peak = traced_peak(lambda: rx.receive(datagram, now=now))
    assert len(accepted) == 30
    assert rx.guard._senders["X"].bitmap.bit_length() <= rx.guard.seq_window
    assert peak < 4 * 1024 * 1024
