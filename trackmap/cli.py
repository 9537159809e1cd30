"""Command line interface: ``trackmap build | info | check | plot``.

Exit status
-----------
===  ======================================================================================
 0   success (``check``: no error found)
 1   ``check`` found data errors in the map (the findings are printed)
 2   usage or input error: a bad option, a missing, unreadable or broken file; one line
     ``trackmap CMD: error: ...`` says what and where
 3   internal error: a bug in trackmap, not a problem of the input; the message asks to
     report it (``-vv`` prints the traceback)
130  interrupted (Ctrl-C)
===  ======================================================================================

A reader that leaves early (``trackmap check MAP | head``) ends only the printing: the
command finishes, and its status is as above.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import logging
import math
import os
import sys
import time
import traceback
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any, TextIO

from trackmap.builder import build
from trackmap.check import check
from trackmap.errors import ParameterError, TrackMapError
from trackmap.network import TrackMap
from trackmap.storage import load

__all__ = [
    "EXIT_FINDINGS",
    "EXIT_INPUT_ERROR",
    "EXIT_INTERNAL_ERROR",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "main",
    "non_negative_float",
    "non_negative_int",
    "positive_float",
    "positive_int",
    "quiet_when_reader_leaves",
]

EXIT_OK = 0
EXIT_FINDINGS = 1
EXIT_INPUT_ERROR = 2
EXIT_INTERNAL_ERROR = 3
EXIT_INTERRUPTED = 130
_MAX_MESSAGE = 2000


def positive_float(text: str) -> float:
    """argparse type: a finite number above 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text[:40]!r}") from None
    if not 0 < value < math.inf:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text[:40]!r}")
    return value


def positive_int(text: str) -> int:
    """argparse type: an integer above 0."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text[:40]!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be 1 or more, got {value}")
    return value


def non_negative_float(text: str) -> float:
    """argparse type: a finite number of 0 or more."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text[:40]!r}") from None
    if not 0 <= value < math.inf:
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text[:40]!r}")
    return value


def non_negative_int(text: str) -> int:
    """argparse type: an integer of 0 or more."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text[:40]!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be 0 or more, got {value}")
    return value


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="trackmap",
        description="Build, inspect, check and draw rail network maps from OpenStreetMap data.",
        epilog="exit status: 0 ok, 1 check found errors, 2 usage or input error, "
        "3 internal error (a bug: please report it)",
    )
    p.add_argument("-v", "--verbose", action="count", default=0, help="more logging (-vv: debug)")
    sub = p.add_subparsers(dest="command", required=True)

    b = sub.add_parser("build", help="build a map file from OSM XML/PBF, Overpass JSON or GeoJSON")
    b.add_argument("source", type=Path, help="source file (.osm, .osm.pbf, .json, .geojson)")
    b.add_argument("-o", "--output", type=Path, required=True, help="map file to write")
    b.add_argument(
        "--kinds",
        default="tram,light_rail",
        help="comma-separated railway kinds: tram, light_rail, rail, subway, narrow_gauge "
        "(default tram,light_rail)",
    )
    b.add_argument(
        "--driving-side",
        choices=("auto", "right", "left"),
        default="auto",
        help="side trams keep to on double track, which sets the direction of untagged "
        "double track (default auto: the side the tagged double track shows, else right)",
    )
    b.add_argument(
        "--max-deflection",
        type=positive_float,
        default=35.0,
        metavar="DEG",
        help="largest change of direction through a switch or crossing (default 35)",
    )
    prog = b.add_mutually_exclusive_group()
    prog.add_argument("--progress", dest="progress", action="store_true", default=None)
    prog.add_argument("--no-progress", dest="progress", action="store_false")

    i = sub.add_parser("info", help="print the statistics of a map file")
    i.add_argument("map", type=Path)
    i.add_argument("--json", action="store_true", help="machine-readable output")

    c = sub.add_parser("check", help="report data problems; exit status 1 if errors are found")
    c.add_argument("map", type=Path)
    c.add_argument("--json", action="store_true", help="machine-readable output")
    c.add_argument(
        "--limit", type=non_negative_int, default=20, help="findings listed per code (default 20)"
    )
    c.add_argument(
        "--max-edge-m",
        type=positive_float,
        default=None,
        metavar="M",
        help="edges longer than this are errors (default by kind: tram 5000, light_rail and "
        "subway 10000, rail 50000)",
    )

    pl = sub.add_parser("plot", help="draw a map: .png/.svg/.pdf (matplotlib) or .html (Leaflet)")
    pl.add_argument("map", type=Path)
    pl.add_argument("-o", "--output", type=Path, required=True)
    pl.add_argument(
        "--tiles",
        default="none",
        help="HTML only: online background tiles, a provider name (e.g. OpenStreetMap) or URL "
        "template, fetched when the page is viewed (default none: the page makes no network "
        "request, like antikol's result maps)",
    )
    pl.add_argument("--title", default=None)
    return p


class _ReaderMayLeave:
    """Standard output that goes quiet when its reader leaves (a pipe into ``head``)."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream
        self.reader_left = False

    def write(self, text: str) -> int:
        if not self.reader_left:
            try:
                return self._stream.write(text)
            except BrokenPipeError:
                self._leave()
        return len(text)

    def flush(self) -> None:
        if not self.reader_left:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._leave()

    def _leave(self) -> None:
        self.reader_left = True
        # what the stream still holds goes nowhere, not into an error at exit
        with contextlib.suppress(OSError, ValueError, io.UnsupportedOperation):
            devnull = os.open(os.devnull, os.O_WRONLY)
            try:
                os.dup2(devnull, self._stream.fileno())
            finally:
                os.close(devnull)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


@contextlib.contextmanager
def quiet_when_reader_leaves() -> Iterator[None]:
    """Run a command whose printing ends, quietly, when its reader leaves: the rest of
    the command (its files) runs as usual."""
    saved = sys.stdout
    sys.stdout = _ReaderMayLeave(saved)
    try:
        yield
    finally:
        if isinstance(sys.stdout, _ReaderMayLeave):
            sys.stdout.flush()
            sys.stdout = saved


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``trackmap`` command; returns the exit status (module notes)."""
    with quiet_when_reader_leaves():
        return _run(argv)


def _run(argv: Sequence[str] | None) -> int:
    args = _parser().parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    prog = f"trackmap {args.command}"
    try:
        return int(_COMMANDS[args.command](args))
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (TrackMapError, OSError) as exc:
        print(f"{prog}: error: {_clip(str(exc) or type(exc).__name__)}", file=sys.stderr)
        return EXIT_INPUT_ERROR
    except Exception as exc:  # the catch-all: whatever it is, a bug of ours
        if args.verbose >= 2:
            traceback.print_exc()
        print(
            f"{prog}: internal error: {type(exc).__name__}: {_clip(str(exc))}\n"
            "This is a bug in trackmap, not a problem of your input. Please report it with "
            "the command line, the input file if you can share it, and the output of the same "
            "command run with -vv (it shows the traceback).",
            file=sys.stderr,
        )
        return EXIT_INTERNAL_ERROR


def _clip(text: str) -> str:
    return text if len(text) <= _MAX_MESSAGE else text[: _MAX_MESSAGE - 3] + "..."


def _build(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    net = build(
        args.source,
        kinds=args.kinds,
        driving_side=args.driving_side,
        max_deflection_deg=args.max_deflection,
        progress=args.progress,
    )
    net.save(args.output)
    s = net.stats()
    print(
        f"wrote {args.output}: {s['track_km']:.1f} km of track, {s['edges']} edges, "
        f"{s['switches']} switches, {s['diamond_crossings']} diamond crossings, "
        f"{s['conflict_points']} conflict points ({time.perf_counter() - t0:.1f} s)"
    )
    source = net.metadata.source
    dropped = {k: v for k, v in source.get("dropped", {}).items() if k != "other_kind"}
    if dropped:
        print(
            f"ways not used: {', '.join(f'{k}={v}' for k, v in sorted(dropped.items()))} "
            "(other railway kinds not counted)"
        )
    clipped = source.get("clipped")
    if clipped:
        print(
            f"cut by the extract's boundary: {clipped.get('ways', 0)} way(s) kept as "
            f"{clipped.get('pieces', 0)} piece(s), {clipped.get('missing_refs', 0)} node "
            f"reference(s) without a location, {len(source.get('boundary_nodes', []))} map "
            "boundary end(s) (listed by 'trackmap check')"
        )
    return 0


def _driving_side_text(net: TrackMap) -> str:
    """The map's driving side, with how the build chose it where the file says."""
    side = net.metadata.driving_side
    asked = net.metadata.build.get("driving_side")
    evidence = net.metadata.source.get("driving_side_evidence")
    if not isinstance(evidence, dict):
        return side if asked is None else f"{side} (asked {asked})"
    right_km = float(evidence.get("right_m", 0.0)) / 1000
    left_km = float(evidence.get("left_m", 0.0)) / 1000
    shown = f"tagged double track {right_km:,.1f} km right-hand, {left_km:,.1f} km left-hand"
    return f"{side} (asked {asked or '?'}; {shown})"


def _info(args: argparse.Namespace) -> int:
    net = load(args.map)
    stats = net.stats()
    if args.json:
        out = {
            "map": str(args.map),
            "stats": stats,
            "driving_side": net.metadata.driving_side,
            "source": net.metadata.source,
            "build": net.metadata.build,
            "attribution": net.metadata.attribution,
        }
        print(json.dumps(out, indent=2, ensure_ascii=False))
        return 0
    print(f"{args.map}")
    for key, value in stats.items():
        shown = f"{value:.2f}" if isinstance(value, float) else str(value)
        print(f"  {key:<26} {shown}")
    print(f"  {'driving_side':<26} {_driving_side_text(net)}")
    print(f"  {'source':<26} {net.metadata.source.get('file', '?')}")
    clipped = net.metadata.source.get("clipped")
    if clipped:
        boundary = len(net.metadata.source.get("boundary_nodes", []))
        cut = f"{clipped.get('ways', 0)} ways cut, {boundary} boundary nodes"
        print(f"  {'cut by the extract':<26} {cut}")
    print(f"  {'attribution':<26} {net.metadata.attribution}")
    return 0


def _check(args: argparse.Namespace) -> int:
    report = check(load(args.map), max_edge_m=args.max_edge_m)
    if args.json:
        print(json.dumps(report.as_dict(), indent=2, ensure_ascii=False))
        return EXIT_OK if report.ok else EXIT_FINDINGS
    groups = (("error", report.errors), ("warning", report.warnings), ("note", report.notes))
    for title, findings in groups:
        shown: dict[str, int] = {}
        for f in findings:
            shown[f.code] = shown.get(f.code, 0) + 1
            if shown[f.code] > args.limit:
                continue
            where = (
                f" at {f.lat:.6f},{f.lon:.6f}" if f.lat is not None and f.lon is not None else ""
            )
            print(f"{title}: {f.code}: {f.message}{where}")
    counts = report.counts()
    summary = ", ".join(f"{k}={v}" for k, v in sorted(counts.items())) or "nothing found"
    print(
        f"{len(report.errors)} error(s), {len(report.warnings)} warning(s), "
        f"{len(report.notes)} note(s): {summary}"
    )
    return EXIT_OK if report.ok else EXIT_FINDINGS


def _plot(args: argparse.Namespace) -> int:
    from trackmap.plot import plot

    net = load(args.map)
    kwargs: dict[str, object] = {"title": args.title}
    if args.output.suffix.lower() == ".html":
        kwargs["tiles"] = None if args.tiles.lower() == "none" else args.tiles
    try:
        out = plot(net, args.output, **kwargs)
    except ValueError as exc:  # plot's own checks: the output suffix, the tile provider
        raise ParameterError(str(exc)) from exc
    print(f"wrote {out}")
    return EXIT_OK


_COMMANDS = {"build": _build, "info": _info, "check": _check, "plot": _plot}

if __name__ == "__main__":
    raise SystemExit(main())
