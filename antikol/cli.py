"""Command line interface: ``antikol replay | simulate | compare | demo``."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from antikol.errors import AntikolError


def _add_map_option(p: argparse.ArgumentParser, *, default: str | None) -> None:
    p.add_argument(
        "--map",
        default=default,
        metavar="MAP",
        help="trackmap map file, 'default' for the embedded Kraków map, or 'none' for the "
        f"paper's sector rule only (default: {default or 'none'})",
    )


def _load_map(name: str | None) -> Any:
    if name is None or name.lower() == "none":
        return None
    import trackmap

    if name.lower() == "default":
        return trackmap.load_default()
    return trackmap.load(name)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="antikol",
        description="Collision warning for trams: the 2008 sector rule and the track-aware "
        "analyser. A driver-assistance aid, not a certified safety function.",
    )
    p.add_argument("-v", "--verbose", action="count", default=0, help="more logging (-vv: debug)")
    sub = p.add_subparsers(dest="command", required=True)

    r = sub.add_parser("replay", help="run the analyser over a recorded log")
    r.add_argument(
        "log",
        type=Path,
        help="CSV (vehicle_id,t,lat,lon,speed_mps,course_deg) or a directory of NMEA logs",
    )
    r.add_argument(
        "-o",
        "--events",
        type=Path,
        default=Path("events.csv"),
        help="events CSV to write (default events.csv)",
    )
    _add_map_option(r, default=None)
    r.add_argument(
        "--cycle",
        type=float,
        default=1.0,
        metavar="S",
        help="analysis period in seconds (default 1)",
    )
    r.add_argument("--strict", action="store_true", help="stop at the first bad row")
    r.add_argument("--progress", action="store_true", help="show a progress bar")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``antikol`` command; returns the exit status."""
    args = _parser().parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(_COMMANDS[args.command](args))
    except (AntikolError, ValueError, OSError) as exc:
        print(f"antikol {args.command}: error: {exc}", file=sys.stderr)
        return 2


def _replay(args: argparse.Namespace) -> int:
    from antikol.analyser import Analyser
    from antikol.replay import EventWriter, read_nmea_logs, read_replay_csv, replay

    log = (
        read_nmea_logs(args.log)
        if args.log.is_dir()
        else read_replay_csv(args.log, strict=args.strict)
    )
    for problem in log.problems[:20]:
        where = f"line {problem.line}" if problem.line else "NMEA"
        print(f"skipped {where}: {problem.reason}", file=sys.stderr)
    if len(log.problems) > 20:
        print(f"... and {len(log.problems) - 20} more skipped rows", file=sys.stderr)
    net = _load_map(args.map)
    analyser = Analyser(track_map=net)
    with EventWriter(args.events) as events:
        summary = replay(
            log, analyser, cycle_s=args.cycle, on_assessment=events, progress=args.progress
        )
    method = "track-aware analyser" if net is not None else "sector rule (no map)"
    print(
        f"replayed {summary.reports} reports of {summary.vehicles} vehicles in "
        f"{summary.cycles} cycles of {args.cycle:g} s with the {method}"
    )
    print(
        f"rejected rows: {summary.rejected_rows}; table: "
        + ", ".join(f"{k}={v}" for k, v in sorted(summary.table.items()))
    )
    print(f"{'vehicle':<12} {'lamp cycles':>12} {'episodes':>9}")
    for vid in sorted(set(summary.lamp_cycles) | set(summary.episodes)):
        print(f"{vid:<12} {summary.lamp_cycles[vid]:>12} {summary.episodes[vid]:>9}")
    kinds = ", ".join(f"{k}={v}" for k, v in sorted(summary.by_kind.items())) or "none"
    print(f"threat observations by kind: {kinds}; suppressed: {summary.suppressed}")
    print(f"wrote {events.rows} events to {args.events}")
    return 0


_COMMANDS = {"replay": _replay}

if __name__ == "__main__":
    raise SystemExit(main())
