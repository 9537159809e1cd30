"""``antikol match``: put every report of a log on the track map and check the result.

Every report is positioned at its own time (:func:`antikol.evaluation.consistency.match_reports`)
and written as one row of a positions CSV; the matched positions are then checked without
ground truth (:func:`antikol.evaluation.consistency.trace_consistency`): moving fixes on a
track running the reported course's way, 10-s windows that no permitted route connects,
and, where the log has an odometer, the distance along the track against its increments.
Each report is also placed where the whole log puts it
(:mod:`antikol.positioning.hindsight`): the ``hindsight_*`` columns, checked the same way.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from collections import defaultdict
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

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
from antikol.errors import InputFileError, UsageError

__all__ = ["POSITION_CSV_COLUMNS", "add_parser"]

#: Columns of the positions CSV: the report (lat/lon as reported), then its track position.
POSITION_CSV_COLUMNS = (
    "vehicle_id",
    "t",
    "lat",
    "lon",
    "speed_mps",
    "course_deg",
    "odometer_m",
    "has_fix",
    "status",
    "edge_id",
    "direction",
    "offset_m",
    "track_lat",
    "track_lon",
    "heading_deg",
    "probability",
    "sigma_m",
    "wrong_way",
    "dead_reckoned_s",
    "hindsight_status",
    "hindsight_edge_id",
    "hindsight_direction",
    "hindsight_offset_m",
    "hindsight_track_lat",
    "hindsight_track_lon",
    "hindsight_probability",
)

#: Vehicles listed one per line before only the totals are printed.
_SHOWN_VEHICLES = 20
#: Windows no route connects listed on the terminal (all of them go to --json).
_SHOWN_BREAKS = 10
#: Report times from this on are Unix times (2001 on), printed as UTC, s.
_UNIX_TIME_FROM_S = 1e9


def add_parser(sub: Any) -> None:
    """Register the sub-command."""
    m = sub.add_parser(
        "match",
        help="put every report of a log on the track map and check the matched positions",
        description="Position every report of a log on a track map, write the positions "
        "as CSV and check them without ground truth: moving fixes on a track running the "
        "reported course's way, 10-s windows no permitted route connects, and the track "
        "distance against the odometer where the log has one.",
    )
    m.add_argument(
        "log",
        type=Path,
        help="a replay CSV, a directory of NMEA logs, an HSL HFP log (JSON lines or CSV) or "
        "GTFS-realtime VehiclePositions (a feed file or a directory of them); gzip, bzip2 "
        "and xz archives are read as they are",
    )
    m.add_argument(
        "--format",
        dest="log_format",
        choices=("auto", "csv", "nmea", "hfp", "gtfs-rt"),
        default="auto",
        help="log format (default: recognised by name and content)",
    )
    add_map_option(m, default="default")
    m.add_argument(
        "-o",
        "--positions",
        type=Path,
        default=Path("positions.csv"),
        help="positions CSV to write, one row per report (default positions.csv)",
    )
    m.add_argument(
        "--json", type=Path, default=None, metavar="FILE", help="also write every check as JSON"
    )
    m.add_argument(
        "--cycle",
        type=positive_float,
        default=1.0,
        metavar="S",
        help="analysis period in seconds (default 1)",
    )
    m.add_argument(
        "--odometer-tolerance",
        type=positive_float,
        default=10.0,
        metavar="M",
        help="largest track distance minus odometer increment that agrees, m (default 10)",
    )
    m.add_argument("--strict", action="store_true", help="stop at the first bad record")
    add_speed_unit_option(m)
    add_hfp_mode_option(m)
    m.add_argument(
        "--rejects",
        type=Path,
        default=None,
        metavar="FILE",
        help="write every rejected record (source, line, reason) to this CSV",
    )
    m.set_defaults(run=_match)


def _match(args: argparse.Namespace) -> int:
    from antikol.evaluation.consistency import (
        TraceConsistency,
        in_hindsight,
        match_reports,
        trace_consistency,
    )
    from antikol.ingest.feeds import detect_log_format

    if args.map is None or args.map == "none":
        raise UsageError("matching needs a track map: --map FILE or --map default")
    fmt = detect_log_format(args.log) if args.log_format == "auto" else args.log_format
    check_feed_options(args, fmt)
    for out in (args.positions, args.json):
        if out is not None and not out.parent.is_dir():
            raise InputFileError(f"{out}: cannot write: no directory {out.parent}")
    problems = ProblemPrinter(args.rejects)
    try:
        log = read_command_log(args, fmt, problems)
    finally:
        problems.close()
    print_ignored(log.ignored)
    if not log.reports:
        raise UsageError(f"{args.log}: no usable report in the log")
    net = load_map(args.map)
    off_map = off_map_warning(net, log.reports, map_name=args.map)
    if off_map is not None:
        print(off_map, file=sys.stderr)
    fixes = match_reports(net, log.reports, cycle_s=args.cycle)
    later = in_hindsight(net, fixes)

    def checked(matched: Sequence[Any]) -> dict[str, Any]:
        per_vehicle: dict[str, list[Any]] = defaultdict(list)
        for f in matched:
            per_vehicle[f.vehicle_id].append(f)
        return {
            vid: trace_consistency(net, seq, odometer_tolerance_m=args.odometer_tolerance)
            for vid, seq in sorted(per_vehicle.items())
        }

    checks, checks_later = checked(fixes), checked(later)
    total = TraceConsistency.pooled(list(checks.values()))
    total_later = TraceConsistency.pooled(list(checks_later.values()))
    rows = _write_positions(args.positions, fixes, later)
    rejected = log.rejected
    print(
        f"matched {total.reports:,} reports of {total.vehicles:,} vehicle(s) "
        f"({rejected:,} record(s) rejected): confident {total.confident:,}, "
        f"ambiguous {total.ambiguous:,}, lost {total.lost:,}, unmatched {total.unmatched:,}"
    )
    has_odometer = any(r.odometer_m is not None for r in log.reports)
    for line in _summary(total, has_odometer=has_odometer):
        print(line)
    for line in _where_broken(total.breaks):
        print(line)
    print(
        "in hindsight (each report where the whole log puts it, the hindsight_* columns): "
        f"confident {total_later.confident:,}, ambiguous {total_later.ambiguous:,}, "
        f"lost {total_later.lost:,}, unmatched {total_later.unmatched:,}"
    )
    for line in _summary(total_later, short=True):
        print(line)
    for line in _where_broken(total_later.breaks):
        print(line)
    if 1 < len(checks) <= _SHOWN_VEHICLES:
        _print_vehicles(checks)
    print(f"wrote {rows:,} positions to {args.positions}")
    if args.json is not None:
        document = {
            "log": str(args.log),
            "map": str(args.map),
            "records_rejected": rejected,
            "total": total.as_dict(),
            "vehicles": {vid: c.as_dict() for vid, c in checks.items()},
            "hindsight": {
                "total": total_later.as_dict(),
                "vehicles": {vid: c.as_dict() for vid, c in checks_later.items()},
            },
        }
        _write_text(args.json, json.dumps(document, indent=2, allow_nan=False) + "\n")
        print(f"wrote the checks to {args.json}")
    return 0


def _percent(share: float) -> str:
    return "n/a" if math.isnan(share) else f"{100.0 * share:.2f} %"


def _summary(c: Any, *, short: bool = False, has_odometer: bool = False) -> list[str]:
    """The checks' lines; ``short``: only the positions' own (way, windows), the feed's
    (course, odometer) being the same."""
    from antikol.evaluation.consistency import COURSE_OFF_DEG

    lines = [
        f"moving fixes on a track running the reported course's way: "
        f"{_percent(c.way_agrees_share)} ({c.moving_way_agrees:,} of {c.moving_fixes:,}; "
        f"{c.moving_fixes - c.moving_matched:,} not matched, "
        f"{c.moving_wrong_way:,} matched as running wrong way)",
        f"10-s windows no permitted route connects: {_percent(c.disconnected_share)} "
        f"({c.disconnected_windows:,} of {c.windows:,})",
    ]
    if short:
        return ["  " + line for line in lines]
    if c.course_chords:
        lines.append(
            f"reported course against the run between fixes: "
            f"{_percent(c.course_chords_off / c.course_chords)} of {c.course_chords:,} "
            f"chords off by {COURSE_OFF_DEG:g} degrees or more"
        )
        if c.course_off_vehicles:
            lines.append(
                f"  course off: {c.course_off_vehicles:,} of {c.vehicles:,} vehicles report a "
                "course mostly unrelated to their run (reversed, stuck or in another "
                "convention): positioning ignores it, or turns a reversed one round, where "
                "the run shows it wrong, and the course's-way share above says nothing of "
                "the matching for them"
            )
    if c.odometer_pairs:
        lines.append(
            f"odometer: {_percent(c.odometer_agrees_share)} of {c.odometer_pairs:,} pairs of "
            f"reports with a track distance within {c.odometer_tolerance_m:g} m of its "
            f"increment (RMS {c.odometer_rms_m:.2f} m; {c.odometer_unreachable:,} out of reach)"
        )
        if c.odometer_held_vehicles:
            lines.append(
                f"  held odometer: {c.odometer_held_vehicles:,} of {c.vehicles:,} vehicles "
                "repeat a reading while they move (a counter read out every few seconds, or "
                "counting in coarse units); theirs are compared from one new reading to the "
                "next, each as late as a report after its change"
            )
    elif has_odometer:
        lines.append(
            "odometer: in the log, but no two successive reports of a vehicle were matched "
            "with a reading each, nothing to compare"
        )
    else:
        lines.append("odometer: none in the log")
    return lines


def _where_broken(breaks: Sequence[Any]) -> list[str]:
    """The first :data:`_SHOWN_BREAKS` windows no route connects, where to look."""
    if not breaks:
        return []
    lines = [f"  where (the first {min(len(breaks), _SHOWN_BREAKS)}; all of them in --json):"]
    for b in breaks[:_SHOWN_BREAKS]:
        lines.append(
            f"    {b.vehicle_id} {_when(b.t_from_s)} -> {_when(b.t_to_s)}: edge {b.edge_from} "
            f"{b.offset_from_m:.1f} m ({b.direction_from:+d}) -> edge {b.edge_to} "
            f"{b.offset_to_m:.1f} m ({b.direction_to:+d})"
        )
    return lines


def _when(t_s: float) -> str:
    """A report time as the log gives it: UTC for Unix time, else seconds."""
    if t_s >= _UNIX_TIME_FROM_S:
        stamp = datetime.fromtimestamp(t_s, tz=UTC)
        return stamp.strftime("%Y-%m-%dT%H:%M:%S") + (
            f".{stamp.microsecond // 1000:03d}Z" if stamp.microsecond else "Z"
        )
    return f"t={t_s:.1f} s"


def _print_vehicles(checks: dict[str, Any]) -> None:
    print(f"{'vehicle':<14} {'reports':>8} {'way agrees':>11} {'disconnected':>13} {'odometer':>9}")
    for vid, c in checks.items():
        print(
            f"{vid:<14} {c.reports:>8,} {_percent(c.way_agrees_share):>11} "
            f"{c.disconnected_windows:>6} of {c.windows:<4} {_percent(c.odometer_agrees_share):>9}"
            + (" held" if c.odometer_held_vehicles else "")
            + (" course off" if c.course_off_vehicles else "")
        )


def _write_positions(path: Path, fixes: Sequence[Any], later: Sequence[Any]) -> int:
    from antikol.evaluation.replay import csv_cell as _cell

    try:
        fh = path.open("w", newline="", encoding="utf-8")
    except OSError as exc:
        raise InputFileError(f"{path}: cannot write the positions: {exc.strerror or exc}") from exc
    with fh:
        w = csv.writer(fh)
        w.writerow(POSITION_CSV_COLUMNS)
        for f, h in zip(fixes, later, strict=True):
            r, p = f.report, f.position
            w.writerow(
                [
                    r.vehicle_id,
                    _cell(r.t, 3),
                    _cell(r.lat, 7),
                    _cell(r.lon, 7),
                    _cell(r.speed_mps, 2),
                    _cell(r.course_deg, 1),
                    _cell(r.odometer_m, 1),
                    _cell(f.has_fix),
                    *_place_cells(f),
                    _cell(p.heading_deg, 1),
                    _cell(p.probability, 3),
                    _cell(p.sigma_m, 2),
                    _cell(p.wrong_way),
                    _cell(p.dead_reckoned_s, 1),
                    *_place_cells(h),
                    _cell(h.position.probability, 3),
                ]
            )
    return len(fixes)


def _place_cells(fix: Any) -> list[str]:
    """Status, edge, direction, offset and track lat/lon of a matched fix's position."""
    from antikol.evaluation.replay import csv_cell as _cell

    p = fix.position
    return [
        p.status,
        _cell(p.edge_id),
        _cell(p.direction),
        _cell(p.offset_m, 2),
        _cell(p.lat if fix.matched else None, 7),
        _cell(p.lon if fix.matched else None, 7),
    ]


def _write_text(path: Path, text: str) -> None:
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise InputFileError(f"{path}: cannot write: {exc.strerror or exc}") from exc
