"""Hostile frames for tests: what a forger, a replayer or a broken unit could send.

For tests on loopback only. :func:`attack_frames` makes the frames of one kind;
``python -m antikol.onboard.attacker`` sends them to units as a separate process,
sniffing genuine frames from the test relay's tap for its replays.

Kinds (each aimed at the failures the issue describes):

``forged``
    Well-formed frames of real trams moved 100 km away and of phantoms 40 m in front of
    them, tagged with a key the fleet does not have (HMAC or Ed25519 alike).
``unsigned``
    The same content without a tag (the paper's protocol).
``replayed``
    Genuine frames sent again: half at once (duplicates), half more than the time window
    later (a tram resurrected where it was).
``future`` / ``past``
    Correctly signed by an *insider* key (a fleet unit with a wrong clock, or a stolen
    one), dated far ahead or behind the receivers' clock, claiming real and new ids.
``garbage``
    Random bytes, truncated and bit-flipped genuine frames.
``own_id``
    Frames carrying the receiver's own id, signed with the insider key.
"""

from __future__ import annotations

import argparse
import json
import math
import random
import socket
import sys
import time
from collections import Counter, deque
from collections.abc import Iterator, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Final

from antikol.ingest.auth import Ed25519Signer, HmacSigner, load_key_file
from antikol.ingest.protocol import FrameError, FrameSigner, decode_frame, encode_report
from antikol.report import VehicleReport

__all__ = ["ATTACK_KINDS", "attack_frames", "main"]

#: The kinds of hostile frames.
ATTACK_KINDS: Final = ("forged", "unsigned", "replayed", "future", "past", "garbage", "own_id")
_M_PER_DEG: Final = 111_320.0


def _moved(r: VehicleReport, ahead_m: float, east_m: float = 0.0) -> VehicleReport:
    """``r`` moved ``ahead_m`` along its course and ``east_m`` east."""
    c = math.radians(r.course_deg)
    lat = r.lat + (ahead_m * math.cos(c)) / _M_PER_DEG
    lon = r.lon + (ahead_m * math.sin(c) + east_m) / (_M_PER_DEG * math.cos(math.radians(r.lat)))
    return replace(r, lat=max(-90.0, min(90.0, lat)), lon=max(-180.0, min(180.0, lon)))


def _wrong_signer(rng: random.Random, scheme: str) -> FrameSigner:
    key = rng.randbytes(32)
    return Ed25519Signer(key) if scheme == "ed25519" else HmacSigner(key, 1)


def attack_frames(
    kind: str,
    n: int,
    *,
    genuine: Sequence[bytes],
    now: float,
    rng: random.Random,
    scheme: str = "hmac-sha256",
    insider: FrameSigner | None = None,
    target_id: str = "T1",
    old: Sequence[bytes] = (),
) -> Iterator[bytes]:
    """``n`` hostile frames of one kind.

    Parameters
    ----------
    kind : str
        One of :data:`ATTACK_KINDS`.
    n : int
    genuine : sequence of bytes
        Recently sniffed genuine frames (the attacker's model of the traffic).
    now : float
        The current report time, s.
    rng : random.Random
    scheme : str
        The fleet's scheme (the forger's wrong key is of the same kind).
    insider : FrameSigner, optional
        A fleet key in the attacker's hands (for ``future``, ``past``, ``own_id``).
    target_id : str
        The receiver's own id (``own_id``).
    old : sequence of bytes
        Genuine frames sniffed long ago (half of ``replayed``).

    Yields
    ------
    bytes
        One datagram each.
    """
    if not genuine:
        raise ValueError("the attacker has sniffed no genuine frame yet")
    reports = [decode_frame(f) for f in genuine]
    # a receiver's own frames coming back are loop-back, not an attack: replay the others
    others = [f for f, r in zip(genuine, reports, strict=True) if r.vehicle_id != target_id]
    others_old = [f for f in old if decode_frame(f).vehicle_id != target_id]
    wrong = _wrong_signer(rng, scheme)
    for i in range(n):
        base = reports[i % len(reports)]
        seq = rng.randrange(1 << 32)
        if kind in ("forged", "unsigned"):
            fake = (
                _moved(base, 0.0, 100_000.0)  # a real tram, 100 km away
                if i % 2
                else replace(_moved(base, 40.0), vehicle_id=f"PH{i % 997}")  # a phantom
            )
            fake = replace(fake, t=now + rng.uniform(-0.5, 0.5))
            yield encode_report(fake, seq=seq, signer=wrong if kind == "forged" else None)
        elif kind == "replayed":
            pool = others_old if (i % 2 and others_old) else (others or genuine)
            yield pool[rng.randrange(len(pool))]
        elif kind in ("future", "past", "own_id"):
            if kind == "own_id":
                fake = replace(_moved(base, 30.0), vehicle_id=target_id, t=now)
            else:
                delta = rng.choice((60.0, 3600.0, 86400.0 * 365, 1e9 - now))
                vid = base.vehicle_id if i % 2 else f"X{i % 97}"
                fake = replace(
                    base, vehicle_id=vid, t=now + delta if kind == "future" else now - delta
                )
            yield encode_report(fake, seq=seq, signer=insider if insider is not None else wrong)
        elif kind == "garbage":
            frame = genuine[i % len(genuine)]
            style = i % 3
            if style == 0:  # random bytes without a delimiter inside: one rejected stretch
                yield bytes(rng.randrange(1, 256) for _ in range(rng.randrange(1, 200)))
            elif style == 1:  # truncated
                yield frame[: rng.randrange(1, len(frame) - 1)]
            else:  # bit flips (a flip may leave a 0x00: still one datagram)
                buf = bytearray(frame)
                # distinct bits: the same bit flipped twice would send the genuine frame
                for j in rng.sample(range(8, (len(buf) - 1) * 8), rng.randint(1, 3)):
                    buf[j // 8] ^= 1 << (j % 8)
                yield bytes(buf)
        else:
            raise ValueError(f"unknown attack kind {kind!r}")


def main(argv: Sequence[str] | None = None) -> int:
    """Attacker process: sniff from a tap, then send every kind to the targets."""
    p = argparse.ArgumentParser(prog="python -m antikol.onboard.attacker")
    p.add_argument("--targets", required=True, help="id=port,... of the units on 127.0.0.1")
    p.add_argument("--tap-port", type=int, required=True, help="where the relay copies traffic")
    p.add_argument("--kinds", default=",".join(ATTACK_KINDS))
    p.add_argument("--count", type=int, default=1000, help="frames of each kind per target")
    p.add_argument("--rate", type=float, default=4000.0, help="datagrams per second")
    p.add_argument("--epoch", type=float, required=True)
    p.add_argument("--speed", type=float, default=1.0)
    p.add_argument("--scheme", default="hmac-sha256")
    p.add_argument("--insider-key", type=Path, help="key file of a fleet unit")
    p.add_argument("--start-after", type=float, default=8.0, help="report time to begin at")
    p.add_argument("--old-age", type=float, default=8.0, help="age of replayed old frames, s")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    rng = random.Random(args.seed)
    targets = {}
    for item in args.targets.split(","):
        vid, _, port = item.partition("=")
        targets[vid] = int(port)
    insider = load_key_file(args.insider_key).signer if args.insider_key else None
    tap = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    tap.bind(("127.0.0.1", args.tap_port))
    tap.settimeout(0.05)
    out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sniffed: deque[tuple[float, bytes]] = deque(maxlen=2000)

    def now() -> float:
        return (time.time() - args.epoch) * args.speed

    def sniff() -> None:
        while True:
            try:
                data = tap.recv(65535)
            except (TimeoutError, BlockingIOError):
                return
            try:
                decode_frame(data)
            except FrameError:
                continue
            sniffed.append((now(), data))
            tap.settimeout(0.0)

    deadline = time.time() + 120.0
    while (now() < args.start_after or not sniffed) and time.time() < deadline:
        tap.settimeout(0.05)
        sniff()
    sent: Counter[str] = Counter()
    gap = 1.0 / args.rate
    next_at = time.monotonic()
    for kind in args.kinds.split(","):
        for vid, port in targets.items():
            tap.settimeout(0.0)
            sniff()
            t = now()
            recent = [f for at, f in sniffed if t - at < 2.0] or [f for _, f in sniffed]
            old = [f for at, f in sniffed if t - at > args.old_age]
            frames = attack_frames(
                kind,
                args.count,
                genuine=recent[-50:],
                now=t,
                rng=rng,
                scheme=args.scheme,
                insider=insider,
                target_id=vid,
                old=old,
            )
            for frame in frames:
                wait = next_at - time.monotonic()
                if wait > 0:
                    time.sleep(wait)
                next_at = max(next_at + gap, time.monotonic() - 0.1)
                try:
                    out.sendto(frame, ("127.0.0.1", port))
                    sent[f"{vid}:{kind}"] += 1
                except OSError:
                    sent[f"{vid}:send_error"] += 1
    json.dump({"sent": dict(sent)}, sys.stdout)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":  # pragma: no cover - run as a process by the harness
    raise SystemExit(main())
