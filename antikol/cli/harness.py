"""``antikol harness``: several on-board units on loopback, a lossy relay and an attacker.

The figures of one run of :func:`antikol.onboard.harness.run_harness` as JSON on standard
output; exit status 0 when every unit exited 0, else 3 (each failed unit's standard error
goes to standard error).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import asdict
from pathlib import Path
from typing import Any

from antikol.cli.common import EXIT_INTERNAL_ERROR, EXIT_OK

__all__ = ["add_parser"]


def _blackout(text: str) -> tuple[str, float, float]:
    """``SENDER:START:END`` as (sender, start s, end s), or an argparse error."""
    who, _, span = text.partition(":")
    a, _, b = span.partition(":")
    try:
        start, end = float(a), float(b)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not SENDER:START:END") from None
    if not who or not (math.isfinite(start) and math.isfinite(end) and start < end):
        raise argparse.ArgumentTypeError(f"{text!r} is not SENDER:START:END with START < END")
    return who, start, end


def add_parser(sub: Any) -> None:
    """Register the sub-command."""
    p = sub.add_parser(
        "harness",
        help="run several on-board units on loopback through a lossy relay, with an attacker",
        description="Loopback test harness: one antikol onboard process per tram, a relay "
        "that loses, delays, duplicates, reorders and corrupts frames, an optional attacker; "
        "every lamp is compared cycle by cycle with one analyser fed the same reports.",
    )
    p.add_argument("--workdir", type=Path, default=Path("harness-run"))
    p.add_argument("--scenario", default="following_straight")
    p.add_argument("--extra-trams", type=int, default=2)
    p.add_argument("--duration", type=float, default=30.0, help="report seconds")
    p.add_argument("--speed", type=float, default=3.0, help="times faster than real time")
    p.add_argument("--auth", default="hmac-sha256", choices=("hmac-sha256", "ed25519", "none"))
    p.add_argument("--loss", type=float, default=0.0, help="share of frames lost")
    p.add_argument("--delay", type=float, default=0.0, help="wall-clock s")
    p.add_argument("--jitter", type=float, default=0.0, help="wall-clock s")
    p.add_argument("--duplicate", type=float, default=0.0, help="share of frames duplicated")
    p.add_argument("--reorder", type=float, default=0.0, help="share of frames reordered")
    p.add_argument("--corrupt", type=float, default=0.0, help="share of frames corrupted")
    p.add_argument(
        "--blackout",
        type=_blackout,
        default=None,
        help="SENDER:START:END in report seconds (e.g. L:10:20)",
    )
    p.add_argument("--attack-count", type=int, default=0, help="frames per kind per unit")
    p.add_argument("--attack-rate", type=float, default=4000.0, help="frames/s")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--startup", type=float, default=10.0, help="wall-clock s for units to start")
    p.set_defaults(run=_harness)


def _harness(args: argparse.Namespace) -> int:
    from antikol.onboard.harness import HarnessConfig, run_harness
    from antikol.onboard.netem import Impairment

    blackouts: tuple[tuple[str, float, float], ...] = ()
    if args.blackout is not None:
        blackouts = (args.blackout,)
    impaired = any((args.loss, args.delay, args.jitter, args.duplicate, args.reorder))
    impairment = (
        Impairment(
            loss=args.loss,
            delay_s=args.delay,
            jitter_s=args.jitter,
            duplicate=args.duplicate,
            reorder=args.reorder,
            reorder_s=0.5 / args.speed,
            corrupt=args.corrupt,
            blackouts=blackouts,
        )
        if impaired or args.corrupt or blackouts
        else None
    )
    cfg = HarnessConfig(
        workdir=args.workdir,
        scenario=args.scenario,
        extra_trams=args.extra_trams,
        duration_s=args.duration,
        speed=args.speed,
        auth=args.auth,
        impairment=impairment,
        attack_count=args.attack_count,
        attack_rate=args.attack_rate,
        seed=args.seed,
        startup_s=args.startup,
    )
    result = run_harness(cfg)
    summary = result.summary()
    summary["config"] = {k: str(v) for k, v in asdict(cfg).items()}
    print(json.dumps(summary, indent=1, sort_keys=True))
    bad = [u.vehicle_id for u in result.units.values() if u.returncode != 0]
    for vid in bad:
        print(f"unit {vid} exited {result.units[vid].returncode}:", file=sys.stderr)
        print(result.units[vid].stderr, file=sys.stderr)
    return EXIT_INTERNAL_ERROR if bad else EXIT_OK
