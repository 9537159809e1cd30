"""Throughput of the broadcast radio protocol (:mod:`antikol.ingest.protocol`).

Run as ``python benchmarks/bench_protocol.py [n_frames]``. It builds a realistic stream
(default 100,000 frames from 32 senders, half of them sending every optional field),
measures :func:`~antikol.ingest.protocol.encode_report` and
:class:`~antikol.ingest.protocol.StreamDecoder` on it (random chunk sizes of 1 to 1500
bytes, like UDP datagrams or serial reads), and, in the same run, two peers on the same reports:

* ``struct.pack`` / ``struct.unpack`` of the raw fixed fields alone (no framing, no CRC,
  no optional fields, no validation): a floor for any binary encoding in Python;
* ``json.dumps`` / ``json.loads`` of the same reports (decode also builds the validated
  ``VehicleReport``, as a JSON receiver would have to).

Each figure is the best of ``REPEATS`` runs; ratios above 1 mean antikol is faster.
"""

from __future__ import annotations

import itertools
import json
import random
import struct
import sys
import time
from collections.abc import Callable

from antikol.ingest.protocol import StreamDecoder, encode_report
from antikol.report import ReportedTrackPosition, VehicleReport

N_FRAMES = 100_000
N_SENDERS = 32
REPEATS = 3
SEED = 20080


def make_reports(n: int, senders: int, rng: random.Random) -> list[VehicleReport]:
    """Reports of ``senders`` trams at 10 Hz around a city centre, interleaved."""
    out = []
    for k in range(n):
        s = k % senders
        step = k // senders
        full = s % 2 == 0  # half the fleet sends every next-generation field
        out.append(
            VehicleReport(
                vehicle_id=f"TRAM-{s:03d}",
                t=1_700_000_000.0 + step * 0.1 + s * 1e-3,
                lat=50.08 + 0.01 * rng.random(),
                lon=14.42 + 0.01 * rng.random(),
                speed_mps=rng.uniform(0.0, 20.0),
                course_deg=rng.uniform(0.0, 360.0),
                braking=rng.choice(("none", "none", "none", "service")) if full else "none",
                length_m=31.4 if full else None,
                antenna_offset_m=2.5 if full else None,
                route=tuple(range(1000 + s * 10, 1008 + s * 10)) if full else None,
                track_position=ReportedTrackPosition(1000 + s * 10, rng.uniform(0, 400), 1)
                if full
                else None,
                seq=step,
                hdop=round(rng.uniform(0.6, 2.0), 2) if full else None,
                fix_quality=4 if full else None,
            )
        )
    return out


def best_time(fn: Callable[[], object]) -> float:
    """Best wall time of ``REPEATS`` calls of ``fn``, seconds."""
    best = float("inf")
    for _ in range(REPEATS):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def as_dict(r: VehicleReport) -> dict[str, object]:
    d: dict[str, object] = {
        "vehicle_id": r.vehicle_id,
        "t": r.t,
        "lat": r.lat,
        "lon": r.lon,
        "speed_mps": r.speed_mps,
        "course_deg": r.course_deg,
        "braking": r.braking,
        "seq": r.seq,
    }
    for name in ("length_m", "antenna_offset_m", "hdop", "fix_quality"):
        value = getattr(r, name)
        if value is not None:
            d[name] = value
    if r.route is not None:
        d["route"] = list(r.route)
    if r.track_position is not None:
        tp = r.track_position
        d["track_position"] = [tp.edge_id, tp.offset_m, tp.direction]
    return d


def from_dict(d: dict[str, object]) -> VehicleReport:
    tp = d.pop("track_position", None)
    route = d.pop("route", None)
    return VehicleReport(
        **d,  # type: ignore[arg-type]
        track_position=None if tp is None else ReportedTrackPosition(*tp),  # type: ignore[misc]
        route=None if route is None else tuple(route),  # type: ignore[arg-type]
    )


def main(n: int = N_FRAMES) -> None:
    rng = random.Random(SEED)
    reports = make_reports(n, N_SENDERS, rng)

    frames: list[bytes] = []

    def encode() -> None:
        frames[:] = [encode_report(r) for r in reports]

    t_encode = best_time(encode)
    stream = b"".join(frames)
    cuts = [0]
    while cuts[-1] < len(stream):
        cuts.append(cuts[-1] + rng.randint(1, 1500))
    chunks = [stream[a:b] for a, b in itertools.pairwise(cuts)]

    decoded: list[VehicleReport] = []

    def decode() -> None:
        dec = StreamDecoder()
        out: list[VehicleReport] = []
        for chunk in chunks:
            out += dec.feed(chunk)
        assert dec.stats.rejected_total == 0
        decoded[:] = out

    t_decode = best_time(decode)
    assert len(decoded) == n and decoded[-1].seq == reports[-1].seq

    raw = struct.Struct(">8sdIddff")
    raw_fields = [
        (r.vehicle_id.encode(), r.t, r.seq or 0, r.lat, r.lon, r.speed_mps, r.course_deg)
        for r in reports
    ]
    packed: list[bytes] = []

    def struct_pack() -> None:
        packed[:] = [raw.pack(*f) for f in raw_fields]

    def struct_unpack() -> None:
        for p in packed:
            raw.unpack(p)

    t_struct_pack = best_time(struct_pack)
    t_struct_unpack = best_time(struct_unpack)

    dicts = [as_dict(r) for r in reports]
    lines: list[str] = []

    def json_dumps() -> None:
        lines[:] = [json.dumps(d) for d in dicts]

    def json_loads() -> None:
        for line in lines:
            from_dict(json.loads(line))

    t_json_dumps = best_time(json_dumps)
    t_json_loads = best_time(json_loads)

    def rate(seconds: float) -> float:
        return n / seconds

    mean_frame = len(stream) / n
    mean_json = sum(len(line) + 1 for line in lines) / n
    print(f"protocol benchmark: {n} frames, {N_SENDERS} senders, {len(chunks)} chunks")
    print(f"mean frame {mean_frame:.1f} B (JSON line {mean_json:.1f} B)")
    print()
    header = f"{'operation':<44}{'frames/s':>12}{'us/frame':>10}{'antikol/peer':>14}"
    print(header)
    print("-" * len(header))
    rows = [
        ("antikol encode_report", t_encode, None),
        ("  peer struct.pack (raw fixed fields)", t_struct_pack, t_encode),
        ("  peer json.dumps", t_json_dumps, t_encode),
        ("antikol StreamDecoder.feed (random chunks)", t_decode, None),
        ("  peer struct.unpack (raw fixed fields)", t_struct_unpack, t_decode),
        ("  peer json.loads + VehicleReport", t_json_loads, t_decode),
    ]
    for name, seconds, ours in rows:
        ratio = "" if ours is None else f"{seconds / ours:.2f}x"
        print(f"{name:<44}{rate(seconds):>12,.0f}{1e6 * seconds / n:>10.2f}{ratio:>14}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else N_FRAMES)
