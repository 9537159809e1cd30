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
    if name.lower() == "synthetic":
        from trackmap.synthetic import demo_network

        return demo_network().build()
    return trackmap.load(name)


def _scenario_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    p.add_argument("--trams", type=int, default=20, help="city scenario: trams (default 20)")
    p.add_argument(
        "--minutes", type=float, default=30.0, help="city scenario: simulated minutes (default 30)"
    )


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

    s = sub.add_parser("simulate", help="simulate a scenario and write its reports")
    _add_map_option(s, default="default")
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
    _scenario_options(s)

    c = sub.add_parser("compare", help="compare the sector rule and the track-aware analyser")
    _add_map_option(c, default="default")
    c.add_argument("--scenario", default="all", help="scenario name or 'all' (default all)")
    c.add_argument("--json", action="store_true", help="machine-readable output")
    c.add_argument(
        "--figures",
        type=Path,
        default=None,
        metavar="DIR",
        help="write one figure per scenario into DIR",
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
    from antikol.analysis.analyser import Analyser
    from antikol.evaluation.replay import EventWriter, replay
    from antikol.ingest.replaylog import read_nmea_logs, read_replay_csv

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


def _scenario_names(name: str) -> list[str]:
    from antikol.evaluation.scenarios import SCENARIOS

    if name == "all":
        return list(SCENARIOS)
    if name not in SCENARIOS:
        raise ValueError(f"unknown scenario {name!r}; choose from all, {', '.join(SCENARIOS)}")
    return [name]


def _params(name: str, args: argparse.Namespace) -> dict[str, Any]:
    params: dict[str, Any] = {"seed": args.seed}
    if name == "city":
        params.update(trams=args.trams, minutes=args.minutes)
    return params


def _simulate(args: argparse.Namespace) -> int:
    from antikol.evaluation.scenarios import build_scenario, run_scenario

    net = _load_map(args.map)
    if net is None:
        raise ValueError("simulate needs a map (--map default, synthetic or a map file)")
    (name,) = _scenario_names(args.scenario)
    scn = build_scenario(name, net, **_params(name, args))
    result = run_scenario(scn, progress=True)
    result.write_csv(args.output)
    print(
        f"{name}: {len(result.truth)} vehicles, {result.duration_s:g} s simulated, "
        f"{len(result.reports)} reports written to {args.output}"
    )
    if args.nmea is not None:
        args.nmea.mkdir(parents=True, exist_ok=True)
        result.write_nmea(args.nmea)
        print(f"NMEA logs written to {args.nmea}/ (times are UTC from {result.epoch_utc_s:g})")
    return 0


def _run_comparisons(
    net: Any, names: list[str], args: argparse.Namespace, figures: Path | None
) -> tuple[list[Any], list[str]]:
    from antikol.evaluation.figures import comparison_figure
    from antikol.evaluation.scenarios import ScenarioUnavailable, build_scenario, run_scenario
    from antikol.evaluation.scoring import compare

    done, skipped = [], []
    for name in names:
        try:
            scn = build_scenario(name, net, **_params(name, args))
        except ScenarioUnavailable as exc:
            skipped.append(f"{name}: {exc}")
            continue
        result = run_scenario(scn, progress=name == "city")
        comp = compare(net, result, name=name, progress=True, off_map=scn.off_map.keys())
        done.append(comp)
        if figures is not None:
            figures.mkdir(parents=True, exist_ok=True)
            own = tuple(v for v in result.truth if v not in scn.off_map)
            comparison_figure(comp, net, figures / f"{name}.png", vehicles=own)
    return done, skipped


def _compare(args: argparse.Namespace) -> int:
    import json

    from antikol.evaluation.scoring import format_table

    net = _load_map(args.map)
    if net is None:
        raise ValueError("compare needs a map (--map default, synthetic or a map file)")
    done, skipped = _run_comparisons(net, _scenario_names(args.scenario), args, args.figures)
    if args.json:
        print(
            json.dumps(
                {"map": args.map, "scenarios": [c.as_dict() for c in done], "skipped": skipped},
                indent=2,
            )
        )
        return 0
    print(format_table(done))
    for line in skipped:
        print(f"skipped {line}")
    if args.figures is not None:
        print(f"figures written to {args.figures}/")
    return 0


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
    (comp,), _ = _run_comparisons(net, ["city"], args, None)
    from antikol.evaluation.figures import comparison_figure

    fig = comparison_figure(comp, net, args.out / "city.png")
    (args.out / "city.json").write_text(json.dumps(comp.as_dict(), indent=2))
    print(format_table([comp]))
    print(
        f"(FA = false-alarm episodes on clearly conflict-free pairs; lead = mean warning "
        f"lead of timely warnings; {comp.truth.vehicle_hours():.1f} vehicle-hours)"
    )
    print(
        f"figure: {fig}; scores: {args.out / 'city.json'}; {time.perf_counter() - t0:.0f} s in all"
    )
    return 0


_COMMANDS = {
    "replay": _replay,
    "simulate": _simulate,
    "compare": _compare,
    "demo": _demo,
}

if __name__ == "__main__":
    raise SystemExit(main())
