"""Options and helpers shared by the ``antikol`` sub-commands."""

from __future__ import annotations

import argparse
import csv
import itertools
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any, TextIO

from antikol.errors import InputFileError
from antikol.ingest.feed_common import SPEED_UNITS
from antikol.ingest.replaylog import ReplayLog, RowProblem
from trackmap.cli import (
    EXIT_INPUT_ERROR,
    EXIT_INTERNAL_ERROR,
    EXIT_INTERRUPTED,
    EXIT_OK,
    non_negative_float,
    non_negative_int,
    positive_float,
    positive_int,
)

__all__ = [
    "EXIT_INPUT_ERROR",
    "EXIT_INTERNAL_ERROR",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "SHOWN_PROBLEMS",
    "ProblemPrinter",
    "add_hfp_mode_option",
    "add_map_option",
    "add_speed_unit_option",
    "check_feed_options",
    "load_map",
    "non_negative_float",
    "non_negative_int",
    "off_map_warning",
    "positive_float",
    "positive_int",
    "print_ignored",
    "read_command_log",
]

# the exit statuses and argparse number types are trackmap's: both programs share one table


def add_speed_unit_option(p: argparse.ArgumentParser) -> None:
    """Add ``--speed-unit`` (the unit of an HFP or GTFS-realtime log's speed field)."""
    p.add_argument(
        "--speed-unit",
        choices=tuple(SPEED_UNITS),
        default="m/s",
        help="unit of the speed field of an HFP or GTFS-realtime log (default m/s, as their "
        "specifications say; some GTFS-realtime producers send km/h)",
    )


def add_hfp_mode_option(p: argparse.ArgumentParser) -> None:
    """Add ``--hfp-mode`` (the transport modes read from an HFP log)."""
    p.add_argument(
        "--hfp-mode",
        type=_mode_list,
        default=None,
        metavar="MODE[,MODE...]",
        help="read only these transport modes of an HFP log (e.g. tram; from the MQTT topic "
        "or the archive's mode column): HSL's raw dumps hold every bus and ferry too",
    )


def check_feed_options(args: argparse.Namespace, log_format: str) -> None:
    """Refuse ``--speed-unit`` and ``--hfp-mode`` for a log whose format has no use for them.

    Raises
    ------
    UsageError
        Either option given for a log of another format (the message names the log).
    """
    from antikol.errors import UsageError

    if args.speed_unit != "m/s" and log_format not in ("hfp", "gtfs-rt"):
        raise UsageError(
            f"--speed-unit is for HFP and GTFS-realtime logs; {args.log} is {log_format}"
        )
    if args.hfp_mode is not None and log_format != "hfp":
        raise UsageError(f"--hfp-mode is for HFP logs; {args.log} is {log_format}")


def _mode_list(text: str) -> tuple[str, ...]:
    modes = tuple(m.strip().lower() for m in text.split(",") if m.strip())
    if not modes:
        raise argparse.ArgumentTypeError(f"no mode in {text!r}")
    return modes


def add_map_option(p: argparse.ArgumentParser, *, default: str | None) -> None:
    """Add ``--map`` (a map file, ``default``, ``synthetic`` or ``none``)."""
    p.add_argument(
        "--map",
        default=default,
        metavar="MAP",
        help="trackmap map file, 'default' for the embedded Kraków map, or 'none' for the "
        f"paper's sector rule only (default: {default or 'none'})",
    )


def load_map(name: str | None) -> Any:
    """The map a ``--map`` value names, or None for the sector rule only.

    Raises
    ------
    trackmap.errors.TrackMapError
        The map file is missing, unreadable or broken (the message names it).
    """
    if name is None:
        return None
    from trackmap.named import load_named

    return load_named(name)


#: A fix this far outside the map's extent is on none of its tracks, m.
OFF_MAP_M = 2_000.0
#: Fixes of a log looked at to tell whether it belongs to the map (its first ones).
_OFF_MAP_SAMPLE = 20_000


def off_map_warning(net: Any, reports: Iterable[Any], *, map_name: str | None) -> str | None:
    """A warning when most fixes of a log lie far outside the map, None otherwise.

    A log of another city matched on the embedded Kraków map (``--map`` forgotten) is
    otherwise only a count of unmatched reports.

    Parameters
    ----------
    net : trackmap.TrackMap
    reports : iterable of VehicleReport
        The log's reports; the first 20,000 with a fix are looked at.
    map_name : str or None
        The ``--map`` value, for the message.

    Returns
    -------
    str or None
        The warning when more than half of those fixes lie more than :data:`OFF_MAP_M`
        outside the bounding box of the map's tracks.
    """
    import numpy as np
    import shapely

    fixes = itertools.islice((r for r in reports if r.fix_quality != 0), _OFF_MAP_SAMPLE)
    lonlat = np.array([(r.lon, r.lat) for r in fixes], dtype=float).reshape(-1, 2)
    if not len(lonlat) or not net.edges:
        return None
    with np.errstate(all="ignore"):
        x, y = net.to_local(lonlat[:, 0], lonlat[:, 1])
    min_x, min_y, max_x, max_y = shapely.total_bounds([e.geometry for e in net.edges])
    near = (
        np.isfinite(x)
        & np.isfinite(y)
        & (x >= min_x - OFF_MAP_M)
        & (x <= max_x + OFF_MAP_M)
        & (y >= min_y - OFF_MAP_M)
        & (y <= max_y + OFF_MAP_M)
    )
    outside = int(np.count_nonzero(~near))
    if 2 * outside <= len(near):
        return None
    west, south = net.to_lonlat(min_x, min_y)
    east, north = net.to_lonlat(max_x, max_y)
    return (
        f"warning: {outside:,} of {len(near):,} fixes lie more than {OFF_MAP_M / 1000:g} km "
        f"outside the map {map_name!r} (latitude {south:.3f} to {north:.3f}, longitude "
        f"{west:.3f} to {east:.3f}): is it the log's map? ('default' is Kraków; build one "
        "with trackmap build and give it with --map)"
    )


def read_command_log(
    args: argparse.Namespace, log_format: str, problems: ProblemPrinter
) -> ReplayLog:
    """Read the log a command names (``args.log``) with its options (``--strict``,
    ``--speed-unit``, ``--hfp-mode``), each problem of it given to ``problems``.

    Returns
    -------
    ReplayLog

    Raises
    ------
    InputFileError, ReplayError
        As :func:`antikol.ingest.feeds.read_log` raises them.
    """
    from antikol.ingest.feeds import read_log

    log = read_log(
        args.log,
        log_format=log_format,
        strict=args.strict,
        speed_unit=args.speed_unit,
        hfp_modes=args.hfp_mode,
    )
    for problem in log.problems:
        problems(problem)
    return log


def print_ignored(ignored: dict[str, int]) -> None:
    """Print on stderr the records a log's reader ignored, by reason."""
    for reason, n in sorted(ignored.items()):
        print(f"ignored {n} record(s): {reason}", file=sys.stderr)


#: Bad records printed on stderr before the rest are only counted.
SHOWN_PROBLEMS = 20


class ProblemPrinter:
    """Prints the first bad records of a log on stderr and writes all of them to ``--rejects``.

    Parameters
    ----------
    rejects : Path, optional
        CSV to write every rejected record to (source, line, kept, code, reason).

    Raises
    ------
    InputFileError
        ``rejects`` cannot be written.
    """

    def __init__(self, rejects: Path | None) -> None:
        self.shown = 0
        self.total = 0
        self.kept = 0  # notes: records passed on with a word on them
        self._fh: TextIO | None = None
        self._writer: Any = None
        if rejects is not None:
            try:
                self._fh = rejects.open("w", newline="", encoding="utf-8")
            except OSError as exc:
                raise InputFileError(
                    f"{rejects}: cannot write the rejected records: {exc.strerror or exc}"
                ) from exc
            self._writer = csv.writer(self._fh)
            self._writer.writerow(["source", "line", "kept", "code", "reason"])

    def __call__(self, problem: RowProblem) -> None:
        self.total += 1
        self.kept += problem.kept
        if self._writer is not None:
            self._writer.writerow(
                [problem.source, problem.line, problem.kept, problem.category, problem.reason]
            )
        if self.shown < SHOWN_PROBLEMS:
            self.shown += 1
            what = "note" if problem.kept else "skipped"
            print(f"{what} {problem.where()}: {problem.reason}", file=sys.stderr)

    def close(self) -> None:
        if self.total > self.shown:
            more = self.total - self.shown
            where = "" if self._fh is None else f" (all are in {self._fh.name})"
            split = f"; in all {self.total - self.kept:,} skipped, {self.kept:,} passed on"
            print(f"... and {more:,} more bad record(s) or notes{where}{split}", file=sys.stderr)
        if self._fh is not None:
            self._fh.close()
