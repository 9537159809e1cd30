"""Cost of authenticated frames on the receiving side, and the in-process attack figures.

Run as ``python benchmarks/bench_onboard.py [n_frames]``. In the same run it measures, on
the same reports (32 senders, 10 Hz), the datagrams per second one on-board receiver
(:class:`~antikol.onboard.receiver.SecureReceiver`: decode, authenticate, replay guard)
accepts

* without keys (the paper's protocol, the reference of the ratios),
* with an HMAC-SHA-256 fleet key,
* with Ed25519 vehicle keys,

and how fast it rejects forged frames (wrong key). Then it runs
:func:`~antikol.onboard.inprocess.attack_in_process` (10,000 frames of each hostile kind
into the follower of the scripted approach on the embedded Kraków map) and prints, per
kind, how many were rejected, for which reasons, and whether anything got through.
"""

from __future__ import annotations

import random
import sys
import time
from collections.abc import Callable

from antikol.ingest.auth import Ed25519Signer, Ed25519Verifier, HmacSigner, HmacVerifier
from antikol.ingest.protocol import FrameSigner, FrameVerifier, encode_report
from antikol.onboard.receiver import SecureReceiver
from antikol.report import VehicleReport

N_FRAMES = 50_000
N_SENDERS = 32
REPEATS = 3


def make_reports(n: int) -> list[VehicleReport]:
    rng = random.Random(13)
    return [
        VehicleReport(
            f"T{k % N_SENDERS:03d}",
            (k // N_SENDERS) * 0.1,
            50.06 + 0.01 * rng.random(),
            19.93 + 0.01 * rng.random(),
            rng.uniform(0, 20),
            rng.uniform(0, 360),
            length_m=32.0,
            seq=k // N_SENDERS,
        )
        for k in range(n)
    ]


def rate(frames: list[bytes], make: Callable[[], SecureReceiver], end_t: float) -> float:
    """Best datagrams per second over ``REPEATS`` fresh receivers."""
    best = float("inf")
    for _ in range(REPEATS):
        rx = make()
        start = time.perf_counter()
        for i, frame in enumerate(frames):
            rx.receive(frame, now=end_t * i / len(frames))
        best = min(best, time.perf_counter() - start)
    return len(frames) / best


def main(n: int = N_FRAMES) -> None:
    reports = make_reports(n)
    end_t = reports[-1].t
    hmac_key = bytes(range(32))
    ed = {f"T{s:03d}": Ed25519Signer(bytes([s + 1]) * 32) for s in range(N_SENDERS)}
    public = {vid: s.public_key() for vid, s in ed.items()}
    setups: dict[str, tuple[Callable[[VehicleReport], FrameSigner | None], FrameVerifier | None]]
    setups = {
        "unauthenticated": (lambda r: None, None),
        "hmac-sha256": (lambda r: HmacSigner(hmac_key), HmacVerifier({1: hmac_key})),
        "ed25519": (lambda r: ed[r.vehicle_id], Ed25519Verifier(public)),
    }
    print(f"receiver, {n} frames from {N_SENDERS} senders (best of {REPEATS}):")
    base = 0.0
    for name, (signer, verifier) in setups.items():
        frames = [encode_report(r, signer=signer(r)) for r in reports]
        per_s = rate(frames, lambda v=verifier: SecureReceiver(own_id="OWN", verifier=v), end_t)
        base = base or per_s
        print(f"  {name:<16} {per_s:>10,.0f} accepted/s  ({per_s / base:.2f} x unauthenticated)")
        if verifier is not None:
            wrong = HmacSigner(bytes(32)) if name == "hmac-sha256" else Ed25519Signer(b"\x07" * 32)
            forged = [encode_report(r, signer=wrong) for r in reports[: n // 5]]
            per_s = rate(forged, lambda v=verifier: SecureReceiver(own_id="OWN", verifier=v), 1.0)
            print(f"  {'':<16} {per_s:>10,.0f} forged rejected/s")

    import trackmap
    from antikol.onboard.inprocess import attack_in_process

    net = trackmap.load_default()
    start = time.perf_counter()
    out = attack_in_process(net, count=10_000)
    took = time.perf_counter() - start
    print(f"\nattack in process (HMAC fleet key, 10,000 frames per kind, {took:.1f} s):")
    for kind, row in out.per_kind.items():
        reasons = ", ".join(
            f"{k}={v}"
            for k, v in sorted(row.items())
            if k not in ("sent", "accepted", "datagrams_rejected")
        )
        print(
            f"  {kind:<9} sent {row['sent']:>6}  rejected {row['datagrams_rejected']:>6}  "
            f"accepted {row['accepted']}  ({reasons})"
        )
    same = out.lamps_attacked == out.lamps_clean
    print(
        f"  phantom or moved reports stored: {out.foreign}; own unit assessed "
        f"{out.assessments} of {len(out.lamps_clean)} cycles; lamps as without the attack: {same}"
    )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else N_FRAMES)
