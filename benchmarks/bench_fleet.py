"""Fleet-scale replay on Dask: fixes per second per worker, 1 -> 2 workers, and a paper
estimate for an operator's quarter of 10^9 fixes.

Run: ``python benchmarks/bench_fleet.py [--trams 60] [--minutes 30] [--quick]``. Needs the
``fleet`` extra (``pip install -e '.[fleet]'``).

Simulates a Kraków fleet on the embedded map, writes it as a Parquet archive of 10-minute
files, then replays it (track-aware analyser and the sector rule beside it, like
``antikol replay --fleet``) three ways, each timed end to end (ingest, positioning,
analysis, outputs; the cluster is started before the clock starts):

1. in this process without Dask, one window and one region (the single-process
   reference, no overlaps);
2. a ``LocalCluster`` of 1 worker process, 15-minute windows (5-minute warm-up), one
   region (``--region 8000`` cuts Kraków's 15 x 10 km into a handful, each analysing
   its 2.5 km margin too: about twice the work on a network this size);
3. the same with 2 worker processes.

The events of 2 and 3 are checked equal to those of 1. The estimate for 10^9 fixes
assumes that per-worker throughput holds as workers are added (the stages share nothing
but files), which the 1 -> 2 measurement on this 2-core machine can only indicate.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import pyarrow.dataset as ds
from dask.distributed import Client, LocalCluster

from antikol.evaluation.fleet import (
    FleetConfig,
    replay_archive,
    replay_archive_local,
    write_parquet_archive,
)
from antikol.evaluation.fleet.stages import load_map_cached
from antikol.sim import Simulator, fleet


def peak_rss_mb() -> float:
    """Peak resident memory of this process since it started, MB.

    VmHWM of ``/proc/self/status``: getrusage's ru_maxrss would be carried over from the
    parent through fork and exec, and report the benchmark's own peak for every worker.
    """
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def events(out: Path) -> list[dict]:
    rows = ds.dataset(out / "events", format="parquet", partitioning="hive").to_table().to_pylist()
    return sorted(rows, key=lambda r: (r["analyser"], r["t"], r["own_id"], r["other_id"]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trams", type=int, default=60)
    ap.add_argument("--minutes", type=float, default=30.0)
    ap.add_argument("--window", type=float, default=900.0, help="window, s")
    ap.add_argument("--warmup", type=float, default=300.0, help="warm-up, s")
    ap.add_argument(
        "--region", type=float, default=math.inf, help="region side, m (default inf: one)"
    )
    ap.add_argument("--quick", action="store_true", help="20 trams x 10 min")
    args = ap.parse_args()
    trams, minutes = (20, 10.0) if args.quick else (args.trams, args.minutes)
    net = load_map_cached("default")
    t0 = time.perf_counter()
    result = Simulator(net, fleet(net, trams, 7), seed=7).run(minutes * 60.0)
    fixes = len(result.reports)
    print(
        f"simulated {trams} trams x {minutes:g} min: {fixes} fixes "
        f"({time.perf_counter() - t0:.1f} s)"
    )
    tmp = Path(tempfile.mkdtemp(prefix="bench_fleet_"))
    files = write_parquet_archive(result.reports, tmp / "archive", chunk_s=600.0)
    print(f"archive: {len(files)} Parquet files in {tmp / 'archive'}")
    print(f"windows {args.window:g} s, warm-up {args.warmup:g} s, regions {args.region:g} m")

    whole = FleetConfig(map_spec="default", window_s=86_400.0, region_m=math.inf)
    t0 = time.perf_counter()
    ref = replay_archive_local([tmp / "archive"], tmp / "local", whole)
    wall_ref = time.perf_counter() - t0
    ref_events = events(tmp / "local")

    cfg = FleetConfig(
        map_spec="default", window_s=args.window, warmup_s=args.warmup, region_m=args.region
    )
    walls: dict[int, float] = {}
    peaks: dict[int, float] = {}
    for n in (1, 2):
        with (
            LocalCluster(
                n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None
            ) as cluster,
            Client(cluster) as client,
        ):
            client.run(load_map_cached, "default")  # the map is loaded once per worker
            t0 = time.perf_counter()
            s = replay_archive([tmp / "archive"], tmp / f"dask{n}", cfg, client=client)
            walls[n] = time.perf_counter() - t0
            peaks[n] = max(client.run(peak_rss_mb).values())
        same = events(tmp / f"dask{n}") == ref_events
        print(
            f"dask {n} worker(s): {s.tasks}, {walls[n]:.1f} s, complete={s.complete}, "
            f"events equal to the single-process run: {same} ({s.events} events), "
            f"unsettled alarms at window starts {s.unsettled_alarms}; "
            f"peak memory of a worker {peaks[n]:.0f} MB"
        )

    print()
    print(f"{'run':<34} {'wall s':>8} {'fixes/s':>9} {'fixes/s/worker':>15}")
    print("-" * 69)
    print(
        f"{'single process, no Dask (1 window)':<34} {wall_ref:>8.1f} "
        f"{fixes / wall_ref:>9.0f} {fixes / wall_ref:>15.0f}"
    )
    for n, w in walls.items():
        print(
            f"{f'Dask LocalCluster, {n} worker(s)':<34} {w:>8.1f} {fixes / w:>9.0f} "
            f"{fixes / w / n:>15.0f}"
        )
    scaling = walls[1] / walls[2]
    print(
        f"scaling 1 -> 2 workers: {scaling:.2f}x (parallel efficiency {scaling / 2:.0%}); "
        f"Dask 1 worker / single process: {wall_ref / walls[1]:.2f}x throughput"
    )
    per_worker = fixes / walls[2] / 2
    worker_hours = 1e9 / per_worker / 3600.0
    print(
        f"paper estimate, 10^9 fixes (a quarter of ~200 trams x 18 h at 1 Hz) at "
        f"{per_worker:.0f} fixes/s per worker: {worker_hours:,.0f} worker-hours = "
        f"{worker_hours / 32:,.1f} h on 32 workers, {worker_hours / 128:,.1f} h on 128 "
        f"(if per-worker throughput holds)"
    )
    print(f"single-process reference summary: {ref.vehicle_km:.0f} vehicle-km, {ref.events} events")


if __name__ == "__main__":
    main()
