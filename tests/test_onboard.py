"""The on-board unit's receiving side under attack and fuzzing (in one process), its CLI,
and the unit as a process (start, lamp events, clean stop, configuration errors)."""

from __future__ import annotations

import json
import random
import signal
import socket
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path

import pytest

import trackmap
from antikol import Analyser, VehicleReport
from antikol.ingest.auth import HmacSigner, HmacVerifier
from antikol.ingest.cobs import cobs_decode, cobs_encode
from antikol.ingest.protocol import encode_report
from antikol.onboard.attacker import ATTACK_KINDS, attack_frames
from antikol.onboard.inprocess import attack_in_process
from antikol.onboard.receiver import SecureReceiver
from antikol.onboard.transport import UdpTransport, parse_address
from antikol.table import VehicleTable

KEY = bytes(range(100, 132))


@pytest.fixture(scope="module")
def net() -> trackmap.TrackMap:
    return trackmap.load_default()


# --------------------------------------------------------------------------- under attack


def test_ten_thousand_frames_of_each_kind_are_rejected_and_counted(net) -> None:
    out = attack_in_process(net, count=10_000, scheme="hmac-sha256")
    assert set(out.per_kind) == set(ATTACK_KINDS)
    for kind, row in out.per_kind.items():
        assert row["accepted"] == 0, kind
        assert row["datagrams_rejected"] == 10_000, (kind, row)
        reasons = {k: v for k, v in row.items() if k not in ("sent", "accepted")}
        reasons.pop("datagrams_rejected")
        assert sum(reasons.values()) >= 10_000, (kind, row)  # a split frame counts twice
    assert out.per_kind["forged"]["bad_signature"] == 10_000
    assert out.per_kind["unsigned"]["unsigned"] == 10_000
    assert out.per_kind["own_id"]["own_id"] == 10_000
    assert out.foreign == 0  # no phantom, no vehicle moved, at any cycle
    assert out.lamps_attacked == out.lamps_clean  # the own unit kept assessing, unchanged
    assert out.assessments == len(out.lamps_clean) and any(out.lamps_clean)


def test_ed25519_fleet_rejects_every_kind_too(net) -> None:
    out = attack_in_process(net, count=300, scheme="ed25519", duration_s=20.0)
    for kind, row in out.per_kind.items():
        assert row["accepted"] == 0 and row["datagrams_rejected"] == 300, (kind, row)
    assert out.foreign == 0 and out.lamps_attacked == out.lamps_clean


def test_unauthenticated_mode_is_open_to_forgery_but_not_to_wrong_clocks() -> None:
    rx = SecureReceiver(own_id="A", verifier=None)
    an = Analyser(own_id="A")
    an.update(VehicleReport("A", 100.0, 50.06, 19.93, 8.0, 90.0))
    phantom = VehicleReport("PH", 100.0, 50.06, 19.9315, 0.0, 90.0)
    for r in rx.receive(encode_report(phantom, seq=1), now=100.1):
        an.update(r)
    assert an.assess().lamp  # the paper's protocol believes a forged frame
    wild = VehicleReport("W", 1e9, 50.06, 19.9312, 0.0, 90.0)
    assert rx.receive(encode_report(wild, seq=1), now=100.1) == []
    assert rx.rejected() == {"future": 1}
    assert an.update(wild).outcome == "out_of_window"  # and the table refuses it too
    assert an.assess(t=101.0).own_id == "A"


def test_own_echo_is_not_an_attack_but_another_sender_with_our_id_is() -> None:
    rx = SecureReceiver(own_id="A", verifier=HmacVerifier({1: KEY}))
    mine = encode_report(
        VehicleReport("A", 5.0, 50.0, 19.9, 1.0, 0.0), seq=3, signer=HmacSigner(KEY)
    )
    rx.note_sent(mine)
    assert rx.receive(mine, now=5.0) == [] and rx.counts["own_echo"] == 1
    spoof = encode_report(
        VehicleReport("A", 5.5, 50.0, 19.9, 1.0, 0.0), seq=4, signer=HmacSigner(KEY)
    )
    assert rx.receive(spoof, now=5.5) == []
    assert rx.rejected() == {"own_id": 1} and rx.counts["datagrams_rejected"] == 1
    assert rx.receive(b"\x01" * 5000, now=5.5) == [] and rx.rejected()["too_large"] == 1


def test_garbage_never_resends_a_genuine_frame_unchanged() -> None:
    # Two flips of the same bit once gave a receiver its own frame back: counted as an
    # echo, not a rejection, it failed the harness's attack accounting in a few runs per hundred.
    signer = HmacSigner(KEY)
    genuine = [
        encode_report(
            VehicleReport(f"T{i}", 100.0 + i, 50.06, 19.94, 8.0, 90.0), seq=i, signer=signer
        )
        for i in range(6)
    ]
    bodies = {g.strip(b"\x00") for g in genuine}
    frames = attack_frames(
        "garbage", 30_000, genuine=genuine, now=105.0, rng=random.Random(0), target_id="T0"
    )
    unchanged = [f for f in frames if f.strip(b"\x00") in bodies]
    assert unchanged == []


def _mutate(rng: random.Random, frame: bytes, signer: HmacSigner) -> bytes:
    """A frame changed where a forger can reach: bytes flipped, inserted or cut, then
    the tag and CRC made right again, so that the parser and validation are exercised."""
    body = bytearray(cobs_decode(frame.strip(b"\x00")))[:-4]
    tag_at = len(body) - 32
    for _ in range(rng.randint(1, 4)):
        op = rng.random()
        i = rng.randrange(len(body))
        if op < 0.6:
            body[i] = rng.randrange(256)
        elif op < 0.8:
            body[i:i] = rng.randbytes(rng.randint(1, 8))
        else:
            del body[i : i + rng.randint(1, 8)]
    if rng.random() < 0.5 and len(body) > 36:  # keep the length field honest half the time
        body[2:4] = struct.pack(">H", len(body))
        tag_at = len(body) - 32
        body[tag_at:] = signer.sign(bytes(body[:tag_at]))
    head = bytes(body)
    return b"\x00" + cobs_encode(head + struct.pack(">I", zlib.crc32(head))) + b"\x00"


@pytest.mark.slow
def test_a_million_fuzzed_inputs_raise_nothing() -> None:
    rng = random.Random(2024)
    signer = HmacSigner(KEY)
    rx = SecureReceiver(own_id="A", verifier=HmacVerifier({1: KEY}))
    an = Analyser(own_id="A")
    table = VehicleTable(capacity=32, own_id="A")
    an.update(VehicleReport("A", 0.0, 50.06, 19.93, 8.0, 90.0))
    table.update(VehicleReport("A", 0.0, 50.06, 19.93, 8.0, 90.0))
    seeds = [
        encode_report(
            VehicleReport(
                f"T{i}",
                i * 0.1,
                50.06 + i * 1e-4,
                19.93,
                8.0,
                90.0,
                braking="service",
                length_m=30.0,
                route=(1, 2, 3),
                hdop=0.9,
                fix_quality=1,
                odometer_m=100.0 * i,
            ),
            seq=i,
            signer=signer,
        )
        for i in range(16)
    ]
    accepted = 0
    for n in range(1_000_000):
        pick = n % 4
        if pick == 0:
            data = rng.randbytes(rng.randrange(0, 96))
        elif pick == 1:
            frame = bytearray(seeds[n % 16])
            j = rng.randrange(len(frame) * 8)
            frame[j // 8] ^= 1 << (j % 8)
            data = bytes(frame)
        elif pick == 2:
            data = seeds[n % 16][: rng.randrange(len(seeds[0]))] + rng.randbytes(rng.randrange(8))
        else:
            data = _mutate(rng, seeds[n % 16], signer)
        for r in rx.receive(data, now=0.5):
            accepted += 1
            table.update(r)
            an.update(r)
    assert rx.counts["datagrams"] == 1_000_000
    assert rx.decoder.stats.rejected["internal_error"] == 0
    assert an.assess().own_id == "A"
    assert len(table) <= 33


# --------------------------------------------------------------------------- transport


def test_transport_sends_and_receives_on_loopback_without_blocking() -> None:
    a = UdpTransport(("127.0.0.1", 0))
    b = UdpTransport(("127.0.0.1", 0), [a.address, ("127.0.0.1", 9)])
    try:
        assert a.receive(10) == []  # nothing there: returns at once
        assert b.send(b"\x00hello\x00") >= 1
        for _ in range(100):
            got = a.receive(10)
            if got:
                break
            time.sleep(0.01)
        assert got == [b"\x00hello\x00"]
        assert a.kernel_dropped == 0
    finally:
        a.close()
        b.close()


def test_parse_address() -> None:
    assert parse_address("127.0.0.1:5000") == ("127.0.0.1", 5000)
    assert parse_address(":5000") == ("0.0.0.0", 5000)
    assert parse_address("10.0.0.255") == ("10.0.0.255", 47800)
    with pytest.raises(ValueError):
        parse_address("host:70000")


# --------------------------------------------------------------------------- the process


def _antikol(*args: str, timeout: float = 120.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "antikol", *args], capture_output=True, text=True, timeout=timeout
    )


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--id", "T1", "--gps", "replay:x.csv", "--peer", "127.0.0.1:9"], "--key-file"),
        (["--id", "T1", "--peer", "127.0.0.1:9", "--unauthenticated"], "--id/--gps"),
        (["--id", "T1", "--gps", "replay:/nonexistent.csv", "--unauthenticated"], "destination"),
        (["--control-room", "--key-file", "/nonexistent/keys.toml"], "cannot read key file"),
        (["--id", "T1", "--gps", "bogus", "--unauthenticated", "--peer", "1.2.3.4:1"], "gps"),
    ],
)
def test_configuration_errors_exit_with_status_2(args: list[str], message: str) -> None:
    done = _antikol("onboard", *args)
    assert done.returncode == 2, done.stderr
    assert message in done.stderr


def test_port_in_use_is_a_configuration_error(tmp_path: Path) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as busy:
        busy.bind(("127.0.0.1", 0))
        port = busy.getsockname()[1]
        csv = tmp_path / "r.csv"
        csv.write_text("vehicle_id,t,lat,lon,speed_mps,course_deg\nT1,0,50.06,19.93,1,0\n")
        done = _antikol(
            "onboard", "--id", "T1", "--gps", f"replay:{csv}", "--unauthenticated",
            "--listen", f"127.0.0.1:{port}", "--peer", "127.0.0.1:9",
        )  # fmt: skip
    assert done.returncode == 2 and "Address already in use" in done.stderr


def test_keygen_writes_key_files(tmp_path: Path) -> None:
    done = _antikol("onboard", "--keygen", str(tmp_path), "--fleet", "T1,T2", "--scheme", "ed25519")
    assert done.returncode == 0, done.stderr
    assert {p.name for p in tmp_path.iterdir()} == {"T1.toml", "T2.toml", "public.toml"}


def test_a_unit_runs_lights_its_lamp_and_stops_cleanly_on_sigterm(tmp_path: Path) -> None:
    # T1 runs towards a standing T2 400 m ahead, which is another process's frames: here a
    # second unit on loopback (sector rule, no map), both without keys (and saying so)
    rows = ["vehicle_id,t,lat,lon,speed_mps,course_deg"]
    for k in range(40):
        rows.append(f"T1,{k},50.06,{19.93 + k * 10 / 71_600:.7f},10,90")
        rows.append(f"T2,{k},50.06,{19.93 + 400 / 71_600:.7f},0,90")
    csv = tmp_path / "r.csv"
    csv.write_text("\n".join(rows) + "\n")
    p1, p2 = _free_port(), _free_port()
    epoch = time.time() + 3.0
    common = ["--gps", f"replay:{csv}", "--unauthenticated", "--speed", "4", "--epoch", repr(epoch)]
    cmd = [sys.executable, "-m", "antikol", "onboard", "--json", *common]
    t2 = subprocess.Popen(
        [*cmd, "--id", "T2", "--listen", f"127.0.0.1:{p2}", "--peer", f"127.0.0.1:{p1}"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    t1 = subprocess.Popen(
        [*cmd, "--id", "T1", "--listen", f"127.0.0.1:{p1}", "--peer", f"127.0.0.1:{p2}"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        time.sleep(3.0 + 30 / 4)  # 30 s of report time at 4x
        t1.send_signal(signal.SIGTERM)
        out, err = t1.communicate(timeout=30)
    finally:
        t2.send_signal(signal.SIGINT)
        t2.communicate(timeout=30)
    assert t1.returncode == 0, err
    events = [json.loads(line) for line in out.splitlines()]
    assert events[0]["event"] == "start" and "UNAUTHENTICATED" in events[0]["mode"]
    assert "UNAUTHENTICATED" in err  # also logged as a warning
    lamps = [e for e in events if e["event"] == "lamp"]
    on = [e for e in lamps if e["lamp"]]
    assert on and on[0]["threats"][0]["vehicle_id"] == "T2"
    assert on[0]["t"] >= 10  # 400 m at 10 m/s: within the paper's 300 m from t = 10 s
    stop = events[-1]
    assert stop["event"] == "stop" and stop["sent"] > 20 and stop["accepted"] > 20
    assert stop["rejected_total"] == 0 and stop["overruns"] == 0
    assert t2.returncode == 0


def test_control_room_unit_caps_new_ids_and_assesses_everyone() -> None:
    import io
    import threading

    from antikol.ingest.auth import KeySet
    from antikol.onboard.unit import EventSink, OnboardUnit, UnitConfig

    keys = KeySet("hmac-sha256", None, HmacVerifier({1: KEY}))
    epoch = time.time()
    config = UnitConfig(
        vehicle_id=None,
        gps=None,
        bind=("127.0.0.1", 0),
        keys=keys,
        cycle_s=0.25,
        epoch=epoch,
        duration_s=2.5,
        max_new_ids=20,
        max_age_s=30.0,
    )
    events = io.StringIO()
    unit = OnboardUnit(config, events=EventSink(events, as_json=True))
    sender = UdpTransport(("127.0.0.1", 0), [unit.transport.address])
    signer = HmacSigner(KEY)

    def traffic() -> None:
        seq = 0
        for step in range(8):
            t = time.time() - epoch
            for vid, lon in (("A", 19.9300), ("B", 19.9320)):  # B stands 143 m ahead of A
                seq += 1
                r = VehicleReport(vid, t, 50.06, lon, 8.0 if vid == "A" else 0.0, 90.0)
                sender.send(encode_report(r, seq=seq, signer=signer))
            if step == 2:  # an insider floods 2000 new ids at once
                for i in range(2000):
                    r = VehicleReport(f"N{i}", t, 50.07, 19.90 + i * 1e-5, 0.0, 0.0)
                    sender.send(encode_report(r, seq=i, signer=signer))
            time.sleep(0.2)

    thread = threading.Thread(target=traffic)
    thread.start()
    stats = unit.run()
    thread.join()
    sender.close()
    table = stats["table"]
    assert table["rejected_cap"] > 0
    # 2000 new ids in one second of clock: 20 got in, the rest was refused and counted
    assert {"A", "B"} <= set(stats["vehicles"]) and len(stats["vehicles"]) <= 22
    assert table["rejected_cap"] + len(stats["vehicles"]) - 2 == 2000 - stats["kernel_dropped"]
    lamps = [json.loads(line) for line in events.getvalue().splitlines()]
    assert any(e["event"] == "lamp" and e["vehicle"] == "A" and e["lamp"] for e in lamps)
    assert lamps[-1]["event"] == "stop" and lamps[-1]["vehicle"] is None


def test_live_nmea_stream_and_paced_sources(tmp_path: Path) -> None:
    import os

    from antikol.ingest.nmea_writer import format_rmc
    from antikol.onboard.sources import NmeaStreamSource, PacedSource, open_source

    fixes = [VehicleReport("T1", 1_700_000_000.0 + k, 50.06, 19.93, 5.0, 90.0) for k in range(3)]
    read_fd, write_fd = os.pipe()
    source = NmeaStreamSource(os.fdopen(read_fd, "rb"), "T1")
    with os.fdopen(write_fd, "wb") as pipe:
        for r in fixes:
            pipe.write((format_rmc(r) + "\r\n").encode())
    got: list[VehicleReport] = []
    for _ in range(200):
        got += source.poll(time.time())
        if len(got) >= 2:
            break
        time.sleep(0.01)
    assert [r.t for r in got][:2] == [fixes[0].t, fixes[1].t]
    assert source.report_time(0.0) is None  # the clock follows the receiver
    source.close()
    # a regular NMEA file is replayed at the pace of its fixes
    path = tmp_path / "t1.nmea"
    path.write_text("".join(format_rmc(r) + "\r\n" for r in fixes))
    paced = open_source(f"nmea:{path}", "T1", start_wall=1000.0)
    assert isinstance(paced, PacedSource)
    assert [r.t for r in paced.poll(1000.5)] == [fixes[0].t]
    assert [r.t for r in paced.poll(1002.0)] == [fixes[1].t, fixes[2].t]
    assert paced.finished
