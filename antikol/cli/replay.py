"""``antikol replay``: run the analyser over a recorded log."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from antikol.cli.common import add_map_option, load_map

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    """Register the sub-command."""
    r = sub.add_parser("replay", help="run the analyser over a recorded log")
    r.add_argument(
        "log",
        type=Path,
        help="replay CSV (vehicle_id,t,lat,lon,speed_mps,course_deg), a directory of NMEA "
        "logs, an HSL HFP log (JSON lines or CSV) or GTFS-realtime VehiclePositions (a "
        "feed file or a directory of them)",
    )
    r.add_argument(
        "--format",
        dest="log_format",
        choices=("auto", "csv", "nmea", "hfp", "gtfs-rt"),
        default="auto",
        help="log format (default: recognised by name and content)",
    )
    r.add_argument(
        "-o",
        "--events",
        type=Path,
        default=Path("events.csv"),
        help="events CSV to write (default events.csv)",
    )
    add_map_option(r, default=None)
    r.add_argument(
        "--cycle",
        type=float,
        default=1.0,
        metavar="S",
        help="analysis period in seconds (default 1)",
    )
    r.add_argument("--strict", action="store_true", help="stop at the first bad row")
    r.add_argument(
        "--html",
        type=Path,
        default=None,
        metavar="FILE",
        help="also write the results as an interactive map (one self-contained page: paths "
        "coloured by lamp state, every warning as a clickable marker with its pair's "
        "distance and warnings against time)",
    )
    r.add_argument(
        "--tiles",
        default="none",
        help="--html only: online background tiles, a provider name or URL template "
        "(default none: the page makes no network request)",
    )
    r.add_argument("--progress", action="store_true", help="show a progress bar")

    r.set_defaults(run=_replay)


def _replay(args: argparse.Namespace) -> int:
    from antikol.analysis.analyser import Analyser
    from antikol.evaluation.replay import EventWriter, replay
    from antikol.ingest.feeds import detect_log_format, read_log

    fmt = detect_log_format(args.log) if args.log_format == "auto" else args.log_format
    log = read_log(args.log, log_format=fmt, strict=args.strict)
    for problem in log.problems[:20]:
        what = "note" if problem.kept else "skipped"
        print(f"{what} {problem.where()}: {problem.reason}", file=sys.stderr)
    if len(log.problems) > 20:
        print(f"... and {len(log.problems) - 20} more bad records", file=sys.stderr)
    for reason, n in sorted(log.ignored.items()):
        print(f"ignored {n} record(s): {reason}", file=sys.stderr)
    if not log.reports:
        raise ValueError(f"{args.log}: no usable report in the {fmt} log")
    net = load_map(args.map)
    analyser = Analyser(track_map=net)
    recorder = None
    if args.html is not None:
        from antikol.evaluation.results_data import ReplayRecorder

        recorder = ReplayRecorder(analyser)
    with EventWriter(args.events) as events:

        def on_assessment(a: Any) -> None:
            events(a)
            if recorder is not None:
                recorder(a)

        summary = replay(
            log, analyser, cycle_s=args.cycle, on_assessment=on_assessment, progress=args.progress
        )
    method = "track-aware analyser" if net is not None else "sector rule (no map)"
    print(
        f"replayed {summary.reports} reports ({fmt}) of {summary.vehicles} vehicles in "
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
    if recorder is not None:
        from antikol.evaluation.html_results import replay_html

        page = replay_html(
            recorder,
            args.html,
            net=net,
            title=f"{args.log.name}: {method}",
            cycle_s=args.cycle,
            tiles=args.tiles,
        )
        print(f"wrote the result map {page}")
    return 0
