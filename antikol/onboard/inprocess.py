"""The attack of the harness in one process: deterministic, fast, and countable per kind.

:func:`attack_in_process` plays simulated traffic cycle by cycle into one unit's receiving
side (:class:`~antikol.onboard.receiver.SecureReceiver` and an
:class:`~antikol.analysis.analyser.Analyser`), injects ``count`` hostile frames of each kind
(:func:`~antikol.onboard.attacker.attack_frames`) at chosen cycles, and compares the unit's
lamp with the same run without the attack. No sockets, so no datagram can be lost and
every hostile frame must be accounted for.
"""

from __future__ import annotations

import random
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from antikol.analysis.analyser import Analyser
from antikol.ingest.auth import Ed25519Signer, HmacSigner, HmacVerifier
from antikol.ingest.protocol import FrameSigner, FrameVerifier, decode_frame, encode_report
from antikol.onboard.attacker import ATTACK_KINDS, attack_frames
from antikol.onboard.harness import simulate_traffic
from antikol.onboard.receiver import SecureReceiver
from antikol.report import VehicleReport

__all__ = ["AttackOutcome", "attack_in_process"]


@dataclass
class AttackOutcome:
    """What :func:`attack_in_process` observed.

    Attributes
    ----------
    per_kind : dict
        For each kind: ``sent``, ``accepted`` (reports that got through),
        ``datagrams_rejected`` and the rejections by reason.
    lamps_clean, lamps_attacked : list of bool
        The target's lamp every cycle without and with the attack.
    foreign : int
        Reports stored in the target's table, over the whole run, that no vehicle sent
        (phantoms) or that put a vehicle elsewhere (moved).
    assessments : int
        Cycles the target assessed itself under attack (one per cycle when it stays in
        service).
    """

    per_kind: dict[str, dict[str, int]] = field(default_factory=dict)
    lamps_clean: list[bool] = field(default_factory=list)
    lamps_attacked: list[bool] = field(default_factory=list)
    foreign: int = 0
    assessments: int = 0


def _signers(scheme: str, ids: Sequence[str]) -> tuple[dict[str, FrameSigner], FrameVerifier]:
    if scheme == "hmac-sha256":
        key = random.Random(1).randbytes(32)
        signer = HmacSigner(key, 1)
        return dict.fromkeys(ids, signer), HmacVerifier({1: key})
    from antikol.ingest.auth import Ed25519Verifier

    rng = random.Random(2)
    signers: dict[str, FrameSigner] = {v: Ed25519Signer(rng.randbytes(32)) for v in ids}
    public = {v: s.public_key() for v, s in signers.items()}  # type: ignore[attr-defined]
    return signers, Ed25519Verifier(public)


def attack_in_process(
    net: Any,
    *,
    count: int = 10_000,
    kinds: Sequence[str] = ATTACK_KINDS,
    scheme: str = "hmac-sha256",
    target: str = "F",
    first_attack_cycle: int = 6,
    duration_s: float = 30.0,
    seed: int = 0,
) -> AttackOutcome:
    """Run the traffic twice, clean and attacked, into the target's receiving side.

    Parameters
    ----------
    net : trackmap.TrackMap
        The map (simulation and the target's analyser).
    count : int
        Hostile frames of each kind.
    kinds : sequence of str
        Injected one kind per cycle from ``first_attack_cycle`` on.
    scheme : {"hmac-sha256", "ed25519"}
        The fleet's keys; the attacker's insider key is a fleet key (HMAC: the fleet key
        itself; Ed25519: vehicle ``X9``'s).
    target : str
        The unit under attack (a vehicle of the scenario).
    first_attack_cycle : int
    duration_s : float
    seed : int

    Returns
    -------
    AttackOutcome
    """
    result = simulate_traffic(
        net, scenario="following_straight", extra_trams=2, duration_s=duration_s, seed=seed
    )
    ids = [s.vehicle_id for s in result.specs]
    signers, verifier = _signers(scheme, [*ids, "X9"])
    by_cycle: dict[int, list[VehicleReport]] = {}
    for r in result.reports:
        by_cycle.setdefault(round(r.t), []).append(r)
    seqs = Counter[str]()
    frames: dict[int, list[bytes]] = {}
    for k, batch in sorted(by_cycle.items()):
        for r in batch:
            seqs[r.vehicle_id] += 1
            frame = encode_report(r, seq=seqs[r.vehicle_id], signer=signers[r.vehicle_id])
            frames.setdefault(k, []).append(frame)
    genuine = {
        (rep.vehicle_id, rep.t): (rep.lat, rep.lon)
        for fs in frames.values()
        for rep in map(decode_frame, fs)
    }
    schedule = {first_attack_cycle + i: kind for i, kind in enumerate(kinds)}
    out = AttackOutcome()
    rng = random.Random(seed)
    for attacked in (False, True):
        receiver = SecureReceiver(own_id=target, verifier=verifier)
        analyser = Analyser(track_map=net, own_id=target)
        lamps = out.lamps_attacked if attacked else out.lamps_clean
        for k in sorted(frames):
            now = k + 0.1
            for frame in frames[k]:
                report = decode_frame(frame)
                if report.vehicle_id == target:
                    analyser.update(report)
                else:
                    for r in receiver.receive(frame, now):
                        analyser.update(r)
            if attacked and k in schedule:
                kind = schedule[k]
                before = Counter(receiver.rejected())
                counts0 = Counter(receiver.counts)
                old = [f for j in range(max(0, k - 30), k - 6) for f in frames.get(j, [])]
                for datagram in attack_frames(
                    kind,
                    count,
                    genuine=frames[k] + frames.get(k - 1, []),
                    now=now,
                    rng=rng,
                    scheme=scheme,
                    insider=signers["X9"],
                    target_id=target,
                    old=old,
                ):
                    for r in receiver.receive(datagram, now):
                        analyser.update(r)
                delta = Counter(receiver.rejected()) - before
                row = {"sent": count, **dict(delta)}
                row["accepted"] = receiver.counts["accepted"] - counts0["accepted"]
                row["datagrams_rejected"] = (
                    receiver.counts["datagrams_rejected"] - counts0["datagrams_rejected"]
                )
                out.per_kind[kind] = row
            if attacked:
                for r in analyser.table:
                    where = genuine.get((r.vehicle_id, r.t))
                    if r.vehicle_id != target and where != (r.lat, r.lon):
                        out.foreign += 1
            if target in analyser.table:
                lamps.append(analyser.assess(t=float(k)).lamp)
                out.assessments += attacked
    return out
