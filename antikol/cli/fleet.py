"""``antikol replay --fleet DIR``: an archive of many files on a Dask cluster.

The options are added to ``antikol replay``; :func:`run_fleet` runs when ``--fleet`` is
given. Exit status: 0 when every partition was replayed, 2 when some failed because of
their input (an unreadable file), 3 when some failed otherwise (a bug); the failed
partitions are listed on stderr and in ``DIR/summary.json`` either way.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from antikol.cli.common import non_negative_float, non_negative_int, positive_float, positive_int
from antikol.errors import UsageError

__all__ = ["add_fleet_options", "run_fleet"]


def add_fleet_options(r: argparse.ArgumentParser) -> None:
    """Add the fleet-scale options to ``antikol replay``."""
    g = r.add_argument_group(
        "fleet-scale replay (pip install 'antikol[fleet]')",
        "replay a partitioned archive (files or directories of Parquet, replay CSV, HFP or "
        "GTFS-realtime) on a dask.distributed cluster; events and positions are written as "
        "partitioned Parquet under DIR with summary.json, hotspots.png and hotspots.html",
    )
    g.add_argument("--fleet", type=Path, default=None, metavar="DIR", help="output directory")
    g.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDR",
        help="address of a running Dask scheduler (default: a local cluster)",
    )
    g.add_argument(
        "--workers", type=positive_int, default=2, metavar="N", help="local cluster workers"
    )
    g.add_argument(
        "--no-dask",
        action="store_true",
        help="run the same stages in this process (the single-process reference)",
    )
    g.add_argument(
        "--window", type=positive_float, default=3600.0, metavar="S", help="time window, s"
    )
    g.add_argument(
        "--warmup",
        type=non_negative_float,
        default=600.0,
        metavar="S",
        help="replay before each window whose events are discarded, s (default 600)",
    )
    g.add_argument(
        "--region",
        type=_region,
        default=math.inf,
        metavar="M",
        help="side of a square map region, m (default inf: one region; regions pay off on "
        "networks many times the 2.5 km margin across)",
    )
    g.add_argument(
        "--group",
        type=positive_int,
        default=8,
        metavar="N",
        help="vehicles positioned together per task (default 8; memory: N vehicle-days)",
    )
    g.add_argument(
        "--retries", type=non_negative_int, default=2, metavar="N", help="retries per task"
    )
    g.add_argument("--dashboard", action="store_true", help="serve the Dask dashboard")
    g.add_argument("--keep-work", action="store_true", help="keep DIR/work (working copy)")


def _region(text: str) -> float:
    """argparse type: a positive side in metres, or ``inf``."""
    if text.strip().lower() in ("inf", "infinity"):
        return math.inf
    return positive_float(text)


def run_fleet(args: argparse.Namespace) -> int:
    """Run ``antikol replay --fleet``."""
    from antikol.evaluation.fleet import FleetConfig, replay_archive, replay_archive_local

    if args.html is not None or args.rejects is not None or args.strict:
        raise UsageError("--html, --rejects and --strict apply to a single log, not to --fleet")
    map_spec = args.map if args.map is not None else "none"
    fmt = args.log_format
    config = FleetConfig(
        map_spec=map_spec,
        cycle_s=args.cycle,
        window_s=args.window,
        warmup_s=args.warmup,
        region_m=args.region,
        log_format=fmt,
        group=args.group,
    )
    out: Path = args.fleet
    out.mkdir(parents=True, exist_ok=True)
    if args.no_dask:
        summary = replay_archive_local(args.log, out, config, keep_work=args.keep_work)
    else:
        try:
            import dask.distributed  # noqa: F401
        except ImportError:
            raise UsageError(
                "--fleet needs dask.distributed and pyarrow: pip install 'antikol[fleet]' "
                "(or run with --no-dask)"
            ) from None

        def connected(client: Any) -> None:
            where = args.scheduler or f"local cluster of {args.workers} workers"
            shown = args.dashboard or args.scheduler is not None
            print(f"running on {where}; dashboard: {client.dashboard_link if shown else 'off'}")

        summary = replay_archive(
            args.log,
            out,
            config,
            scheduler=args.scheduler,
            n_workers=args.workers,
            retries=args.retries,
            progress=args.progress,
            dashboard=args.dashboard,
            on_client=connected,
            keep_work=args.keep_work,
            quiet=args.verbose == 0,
        )
    for line in summary.lines():
        print(line)
    net = None
    if summary.hot_spots:
        from antikol.evaluation.fleet.stages import load_map_cached

        net = load_map_cached(map_spec)
    if net is not None:
        _figures(summary, net, out)
    print(f"wrote {summary.events} events, positions and summary.json under {out}")
    if summary.failures:
        for f in summary.failures:
            print(f"failed {f.stage} partition {f.name}: {f.error}", file=sys.stderr)
        bug = any(not f.input_error for f in summary.failures)
        print(
            f"antikol replay: {len(summary.failures)} partition(s) failed; the result is "
            "incomplete",
            file=sys.stderr,
        )
        return 3 if bug else 2
    return 0


def _figures(summary: Any, net: Any, out: Path) -> None:
    from antikol.evaluation.fleet import hotspot_figure, hotspot_html

    try:
        print(f"wrote {hotspot_figure(summary, net, out / 'hotspots.png')}")
        print(f"wrote {hotspot_html(summary, net, out / 'hotspots.html')}")
    except ImportError as exc:
        print(f"no hot-spot figures: {exc} (pip install 'antikol[plot]')", file=sys.stderr)
