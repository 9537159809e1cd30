"""Command line interface: ``trackmap build | info | check | plot``."""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from trackmap.builder import build
from trackmap.check import check
from trackmap.errors import TrackMapError
from trackmap.plot import plot
from trackmap.storage import load

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="trackmap",
        description="Build, inspect, check and draw rail network maps from OpenStreetMap data.",
    )
    p.add_argument("-v", "--verbose", action="count", default=0, help="more logging (-vv: debug)")
    sub = p.add_subparsers(dest="command", required=True)

    b = sub.add_parser("build", help="build a map file from OSM XML/PBF, Overpass JSON or GeoJSON")
    b.add_argument("source", type=Path, help="source file (.osm, .osm.pbf, .json, .geojson)")
    b.add_argument("-o", "--output", type=Path, required=True, help="map file to write")
    b.add_argument(
        "--kinds",
        default="tram",
        help="comma-separated railway kinds: tram, light_rail, rail, subway, narrow_gauge",
    )
    b.add_argument("--driving-side", choices=("right", "left"), default="right")
    b.add_argument(
        "--max-deflection",
        type=float,
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
    c.add_argument("--limit", type=int, default=20, help="findings listed per code (default 20)")

    pl = sub.add_parser("plot", help="draw a map: .png/.svg/.pdf (matplotlib) or .html (Leaflet)")
    pl.add_argument("map", type=Path)
    pl.add_argument("-o", "--output", type=Path, required=True)
    pl.add_argument(
        "--tiles",
        default="OpenStreetMap",
        help="HTML only: tile provider or URL template (fetched online when the page is "
        "viewed); 'none': no tiles, the page makes no network request (default OpenStreetMap)",
    )
    pl.add_argument("--title", default=None)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``trackmap`` command; returns the exit status."""
    args = _parser().parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(_COMMANDS[args.command](args))
    except (TrackMapError, ValueError, OSError) as exc:
        print(f"trackmap {args.command}: error: {exc}", file=sys.stderr)
        return 2


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
    return 0


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
    print(f"  {'driving_side':<26} {net.metadata.driving_side}")
    print(f"  {'source':<26} {net.metadata.source.get('file', '?')}")
    print(f"  {'attribution':<26} {net.metadata.attribution}")
    return 0


def _check(args: argparse.Namespace) -> int:
    report = check(load(args.map))
    if args.json:
        print(json.dumps(report.as_dict(), indent=2, ensure_ascii=False))
        return 0 if report.ok else 1
    for title, findings in (("error", report.errors), ("warning", report.warnings)):
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
    print(f"{len(report.errors)} error(s), {len(report.warnings)} warning(s): {summary}")
    return 0 if report.ok else 1


def _plot(args: argparse.Namespace) -> int:
    net = load(args.map)
    kwargs: dict[str, object] = {"title": args.title}
    if args.output.suffix.lower() == ".html":
        kwargs["tiles"] = None if args.tiles.lower() == "none" else args.tiles
    out = plot(net, args.output, **kwargs)
    print(f"wrote {out}")
    return 0


_COMMANDS = {"build": _build, "info": _info, "check": _check, "plot": _plot}

if __name__ == "__main__":
    raise SystemExit(main())
