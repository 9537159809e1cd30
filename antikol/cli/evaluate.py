"""``antikol simulate | compare | demo``: the project's own simulator and scoring."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

from antikol.cli.common import (
    EXIT_INTERNAL_ERROR,
    add_map_option,
    load_map,
    non_negative_float,
    positive_float,
    positive_int,
)
from antikol.errors import UsageError

__all__ = ["add_parsers"]

logger = logging.getLogger(__name__)


def _scenario_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    p.add_argument(
        "--trams", type=positive_int, default=20, help="city scenario: trams (default 20)"
    )
    p.add_argument(
        "--minutes",
        type=positive_float,
        default=30.0,
        help="city scenario: simulated minutes (default 30)",
    )
    p.add_argument(
        "--gps",
        choices=("white", "urban"),
        default="white",
        help="receiver model: 'white' (white noise and a slow bias, the scenarios' own) or "
        "'urban' (multipath bias worst on double track, jumps, heavy tails, outages, "
        "odometer; GpsModel.urban())",
    )
    p.add_argument(
        "--course-fault",
        choices=("none", "reversed", "zero", "ccw_from_east"),
        default="none",
        help="with --gps urban: a course field wrong all along, as some feeds send it "
        "(reversed: a bidirectional tram's other end; zero: 0 for no heading; "
        "ccw_from_east: a mathematical angle) (default none)",
    )
    p.add_argument(
        "--latency",
        type=non_negative_float,
        default=0.0,
        metavar="S",
        help="with --gps urban: the receiver's position, speed and course are S seconds old "
        "when a report is stamped (its odometer is not), as an AVL unit that stamps its "
        "reports when it sends them (default 0)",
    )
    p.add_argument(
        "--gps-set",
        metavar="NAME=VALUE",
        nargs="+",
        default=[],
        help="with --gps urban: change fields of the street receiver (UrbanGpsModel), e.g. "
        "bias_canyon_lateral_m=6 for a stronger multipath bias or odometer=false",
    )


def add_parsers(sub: Any) -> None:
    """Register the sub-commands."""
    s = sub.add_parser("simulate", help="simulate a scenario and write its reports")
    add_map_option(s, default="default")
    s.add_argument("--scenario", default="city", help="scenario name (default city)")
    s.add_argument(
        "-o",
        "--output",
        type=Path,
        default=Path("reports.csv"),
        help="replay CSV to write (default reports.csv)",
    )
    s.add_argument(
        "--nmea",
        type=Path,
        default=None,
        metavar="DIR",
        help="also write one NMEA log per vehicle into DIR",
    )
    s.add_argument(
        "--hfp",
        type=Path,
        default=None,
        metavar="FILE",
        help="also write the reports as an HSL-style HFP log (JSON lines: a report without "
        "a fix as loc N/A, the odometer as odo), as an operator's archive gives them",
    )
    _scenario_options(s)

    c = sub.add_parser("compare", help="compare the sector rule and the track-aware analyser")
    add_map_option(c, default="default")
    c.add_argument("--scenario", default="all", help="scenario name or 'all' (default all)")
    c.add_argument("--json", action="store_true", help="machine-readable output")
    c.add_argument(
        "--figures",
        type=Path,
        default=None,
        metavar="DIR",
        help="write one figure per scenario into DIR",
    )
    c.add_argument(
        "--html",
        type=Path,
        default=None,
        metavar="DIR",
        help="write one interactive result map per scenario into DIR, and index.html (self-"
        "contained pages: both analysers' lamps along the true paths, every warning, false "
        "alarm and missed warning as a clickable marker)",
    )
    c.add_argument(
        "--tiles",
        default="none",
        help="--html only: online background tiles, a provider name or URL template "
        "(default none: the pages make no network request)",
    )
    _scenario_options(c)

    d = sub.add_parser("demo", help="the city scenario on the embedded Kraków map")
    d.add_argument(
        "--out",
        type=Path,
        default=Path("antikol-demo"),
        help="output directory (default antikol-demo)",
    )
    _scenario_options(d)
    s.set_defaults(run=_simulate)
    c.set_defaults(run=_compare)
    d.set_defaults(run=_demo)


def _scenario_names(name: str) -> list[str]:
    from antikol.evaluation.scenarios import SCENARIOS

    if name == "all":
        return list(SCENARIOS)
    if name not in SCENARIOS:
        raise UsageError(f"unknown scenario {name[:40]!r}; choose from all, {', '.join(SCENARIOS)}")
    return [name]


def _params(name: str, args: argparse.Namespace) -> dict[str, Any]:
    params: dict[str, Any] = {"seed": args.seed}
    if name == "city":
        params.update(trams=args.trams, minutes=args.minutes)
    return params


def _build(name: str, net: Any, args: argparse.Namespace) -> Any:
    """The named scenario on ``net`` with the chosen receiver model."""
    import dataclasses

    from antikol.evaluation.scenarios import build_scenario
    from antikol.sim import GpsModel
    from antikol.sim.urban_gps import street_settings

    fault = getattr(args, "course_fault", "none")
    latency_s = getattr(args, "latency", 0.0)
    urban = getattr(args, "gps", "white") == "urban"
    if fault != "none" and not urban:
        raise UsageError("--course-fault needs the street receiver (--gps urban)")
    if latency_s > 0.0 and not urban:
        raise UsageError("--latency needs the street receiver (--gps urban)")
    settings = getattr(args, "gps_set", [])
    if settings and not urban:
        raise UsageError("--gps-set needs the street receiver (--gps urban)")
    try:
        street = street_settings(settings)
    except ValueError as exc:
        raise UsageError(f"--gps-set: {exc}") from None
    scn = build_scenario(name, net, **_params(name, args))
    if urban:
        gps = GpsModel.urban(**{"course_fault": fault, "latency_s": latency_s, **street})
        scn = dataclasses.replace(scn, gps=gps)
    return scn


def _simulate(args: argparse.Namespace) -> int:
    from antikol.evaluation.scenarios import run_scenario

    net = load_map(args.map)
    if net is None:
        raise UsageError("simulate needs a map (--map default, synthetic or a map file)")
    (name,) = _scenario_names(args.scenario)
    scn = _build(name, net, args)
    result = run_scenario(scn, progress=True)
    extra = ("fix_quality", "odometer_m") if args.gps == "urban" else ()
    result.write_csv(args.output, extra_columns=extra)
    print(
        f"{name}: {len(result.truth)} vehicles, {result.duration_s:g} s simulated, "
        f"{len(result.reports)} reports written to {args.output}"
    )
    if args.nmea is not None:
        args.nmea.mkdir(parents=True, exist_ok=True)
        result.write_nmea(args.nmea)
        print(f"NMEA logs written to {args.nmea}/ (times are UTC from {_utc(result.epoch_utc_s)})")
    if args.hfp is not None:
        result.write_hfp(args.hfp)
        print(f"HFP log written to {args.hfp} (times are UTC from {_utc(result.epoch_utc_s)})")
    return 0


def _run_comparisons(
    net: Any,
    names: list[str],
    args: argparse.Namespace,
    figures: Path | None,
    failed: list[str] | None = None,
    html: Path | None = None,
) -> tuple[list[Any], list[str]]:
    """Compare on each named scenario; those the map cannot host go to the skipped list,
    those that fail (a bug) to ``failed`` (or raise when it is None)."""
    from antikol.evaluation.figures import comparison_figure
    from antikol.evaluation.scenarios import ScenarioUnavailable, run_scenario
    from antikol.evaluation.scoring import compare

    done, skipped = [], []
    for name in names:
        try:
            scn = _build(name, net, args)
            result = run_scenario(scn, progress=name == "city")
            comp = compare(net, result, name=name, progress=True, off_map=scn.off_map.keys())
        except ScenarioUnavailable as exc:
            skipped.append(f"{name}: {exc}")
            continue
        except Exception as exc:
            if failed is None:
                raise
            logger.exception("scenario %s failed", name)
            failed.append(f"{name}: {type(exc).__name__}: {exc}")
            continue
        done.append(comp)
        if figures is not None:
            figures.mkdir(parents=True, exist_ok=True)
            own = tuple(v for v in result.truth if v not in scn.off_map)
            comparison_figure(comp, net, figures / f"{name}.png", vehicles=own)
        if html is not None:
            from antikol.evaluation.html_results import comparison_html

            html.mkdir(parents=True, exist_ok=True)
            own = tuple(v for v in result.truth if v not in scn.off_map)
            comparison_html(comp, net, html / f"{name}.html", vehicles=own, tiles=args.tiles)
    return done, skipped


def _compare(args: argparse.Namespace) -> int:
    import json

    from antikol.evaluation.scoring import format_table

    net = load_map(args.map)
    if net is None:
        raise UsageError("compare needs a map (--map default, synthetic or a map file)")
    failed: list[str] = []
    names = _scenario_names(args.scenario)
    done, skipped = _run_comparisons(net, names, args, args.figures, failed, args.html)
    status = EXIT_INTERNAL_ERROR if failed else 0  # a scenario that failed is a bug
    if args.json:
        doc = {
            "map": args.map,
            "gps": args.gps,
            "scenarios": [c.as_dict() for c in done],
            "skipped": skipped,
            "failed": failed,
        }
        print(json.dumps(doc, indent=2))
        return status
    print(format_table(done))
    for line in skipped:
        print(f"skipped {line}")
    for line in failed:
        print(f"FAILED {line}")
    if args.figures is not None:
        print(f"figures written to {args.figures}/")
    if args.html is not None:
        from antikol.evaluation.html_results import comparison_index_html

        index = comparison_index_html(
            [(c, f"{c.name}.html") for c in done],
            args.html / "index.html",
            notes=[f"skipped {line}" for line in skipped] + [f"FAILED {line}" for line in failed],
        )
        print(f"result maps written to {args.html}/ (open {index})")
    return status


def _demo(args: argparse.Namespace) -> int:
    import json
    import time

    import trackmap
    from antikol.evaluation.scoring import format_table

    t0 = time.perf_counter()
    net = trackmap.load_default()
    print(
        f"Kraków tram network: {net.stats()['track_km']:.0f} km of track "
        f"({net.metadata.attribution}); {args.trams} trams for {args.minutes:g} min"
    )
    args.out.mkdir(parents=True, exist_ok=True)
    args.tiles = "none"  # the demo's page is offline: Leaflet and the tracks are inlined
    (comp,), _ = _run_comparisons(net, ["city"], args, None, html=args.out)
    from antikol.evaluation.figures import comparison_figure

    fig = comparison_figure(comp, net, args.out / "city.png")
    (args.out / "city.json").write_text(json.dumps(comp.as_dict(), indent=2))
    print(format_table([comp]))
    print(
        "(missed includes late warnings, counted in '(late)'; start% = alarm within "
        "[start - 5 s, start + 1 s]; lead = mean lead of timely warnings; FA/vh = "
        "false-alarm episodes on clearly conflict-free pairs and toggle/vh = lamp toggles "
        "per vehicle-hour; nuis% = lamp on away from any need, share of vehicle time; "
        f"{comp.truth.vehicle_hours():.1f} vehicle-hours)"
    )
    print(
        f"figure: {fig}; interactive map: {args.out / 'city.html'}; "
        f"scores: {args.out / 'city.json'}; {time.perf_counter() - t0:.0f} s in all"
    )
    return 0


def _utc(unix_s: float) -> str:
    """A Unix time as an ISO 8601 UTC time (the epoch of a simulated log)."""
    from datetime import UTC, datetime

    return datetime.fromtimestamp(unix_s, tz=UTC).isoformat().replace("+00:00", "Z")
