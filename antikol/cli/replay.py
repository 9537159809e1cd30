"""``antikol replay``: run the analyser over a recorded log.

A replay CSV is read twice and never held in memory: a first pass checks every line
(bad lines are reported with their number and counted by reason; ``--strict`` stops at
the first) and a second streams the reports in time order through the analyser. An HFP
or GTFS-realtime log is read once into runs sorted by time, on disk past 200,000 records
(:class:`~antikol.ingest.feed_stream.StreamedFeed`), checked in a first pass over them and
replayed in a second. A directory of NMEA logs is read into memory. The summary accounts
for every record: read, replayed, rejected by reason; ``--rejects FILE`` writes every
rejected record.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from antikol.cli.common import (
    ProblemPrinter,
    add_hfp_mode_option,
    add_map_option,
    add_speed_unit_option,
    check_feed_options,
    load_map,
    off_map_warning,
    positive_float,
    print_ignored,
    read_command_log,
)
from antikol.cli.fleet import add_fleet_options, run_fleet
from antikol.errors import UsageError

if TYPE_CHECKING:
    from antikol.evaluation.replay import StreamedLog
    from antikol.ingest.feed_stream import StreamedFeed
    from antikol.ingest.replaylog import ReplayLog

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    """Register the sub-command."""
    r = sub.add_parser("replay", help="run the analyser over a recorded log")
    r.add_argument(
        "log",
        type=Path,
        nargs="+",
        help="with --fleet: archive files and directories (also Parquet); otherwise one "
        "replay CSV (vehicle_id,t,lat,lon,speed_mps,course_deg), a directory of NMEA "
        "logs, an HSL HFP log (JSON lines or CSV) or GTFS-realtime VehiclePositions (a "
        "feed file or a directory of them)",
    )
    r.add_argument(
        "--format",
        dest="log_format",
        choices=("auto", "csv", "nmea", "hfp", "gtfs-rt", "parquet"),
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
        type=positive_float,
        default=1.0,
        metavar="S",
        help="analysis period in seconds (default 1)",
    )
    r.add_argument("--strict", action="store_true", help="stop at the first bad row")
    add_speed_unit_option(r)
    add_hfp_mode_option(r)
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
    r.add_argument(
        "--rejects",
        type=Path,
        default=None,
        metavar="FILE",
        help="write every rejected record (source, line, reason) to this CSV",
    )
    r.add_argument("--progress", action="store_true", help="show a progress bar")
    add_fleet_options(r)

    r.set_defaults(run=_replay)


def _replay(args: argparse.Namespace) -> int:
    from antikol.evaluation.replay import StreamedLog
    from antikol.ingest.feed_stream import STREAMED_FORMATS, StreamedFeed
    from antikol.ingest.feeds import detect_log_format
    from antikol.ingest.replaylog import scan_replay_csv

    if args.fleet is not None:
        # (the fleet's partitions are read as they are: m/s, every mode)
        if args.speed_unit != "m/s" or args.hfp_mode is not None:
            raise UsageError("--speed-unit and --hfp-mode are not read with --fleet DIR")
        return run_fleet(args)
    if args.scheduler is not None or args.no_dask:
        raise UsageError("--scheduler and --no-dask need --fleet DIR")
    if len(args.log) != 1:
        raise UsageError(f"one log at a time without --fleet DIR ({len(args.log)} given)")
    if args.log_format == "parquet":
        raise UsageError("Parquet archives are replayed with --fleet DIR")
    args.log = args.log[0]
    fmt = detect_log_format(args.log) if args.log_format == "auto" else args.log_format
    check_feed_options(args, fmt)
    problems = ProblemPrinter(args.rejects)
    log: ReplayLog | StreamedLog | StreamedFeed
    try:
        if fmt == "csv":
            scan = scan_replay_csv(args.log, strict=args.strict, on_problem=problems)
            log, usable = StreamedLog(args.log, scan), scan.valid
        elif fmt in STREAMED_FORMATS:
            log = StreamedFeed(
                args.log,
                log_format=fmt,
                strict=args.strict,
                speed_unit=args.speed_unit,
                modes=args.hfp_mode,
            )
            usable = log.valid
            for problem in log.problems:
                problems(problem)
        else:
            log = read_command_log(args, fmt, problems)
            usable = len(log.reports)
    finally:
        problems.close()
    try:
        return _replay_log(args, log, fmt, usable)
    finally:
        if isinstance(log, StreamedFeed):
            log.close()


def _replay_log(
    args: argparse.Namespace, log: ReplayLog | StreamedLog | StreamedFeed, fmt: str, usable: int
) -> int:
    from antikol.analysis.analyser import Analyser
    from antikol.evaluation.replay import EventWriter, StreamedLog, replay

    if not isinstance(log, StreamedLog):
        print_ignored(log.ignored)
    if not usable:
        raise UsageError(f"{args.log}: no usable report in the {fmt} log")
    net = load_map(args.map)
    if net is not None:
        off_map = off_map_warning(net, log.reports, map_name=args.map)
        if off_map is not None:
            print(off_map, file=sys.stderr)
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
    reasons = ", ".join(f"{k}: {v}" for k, v in sorted(summary.rejected_by_reason.items()))
    read = "" if summary.rows_read is None else f"read {summary.rows_read} rows: "
    print(
        f"{read}{summary.reports} replayed, {summary.rejected_rows} rejected"
        + (f" ({reasons})" if reasons else "")
    )
    print(f"rejected rows: {summary.rejected_rows}; table: " + _counts(summary.table))
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


def _counts(counts: dict[str, int]) -> str:
    return ", ".join(f"{k}={v}" for k, v in sorted(counts.items()))
