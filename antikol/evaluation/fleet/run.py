"""Running a fleet-scale replay: on a ``dask.distributed`` cluster, or in this process.

:func:`replay_archive` submits the three stages of :mod:`.stages` to a Dask cluster — a
``LocalCluster`` started here by default, or any scheduler by address — with retries;
:func:`replay_archive_local` runs the very same task functions in a loop, one process, no
Dask (the reference the distributed result is compared with, and what runs without the
``fleet`` extra).

Memory: a worker holds one partition file (stage 0), one vehicle-day (stage 1) or one
window and its warm-up of one region (stage 2) at a time, whatever the archive's size;
the driver holds only the small per-task results. Outputs go to files under ``out_dir``
(which every worker must be able to write: a shared file system for a remote cluster):

* ``events/day=D/*.parquet`` — one row per threat per vehicle per cycle, both analysers
  (column ``analyser``: ``track`` or ``sector``);
* ``positions/day=D/VEHICLE.parquet`` — every vehicle's track position per cycle;
* ``summary.json`` — :class:`~.summary.FleetSummary`;
* ``work/`` — the working copy of the archive (deleted unless ``keep_work``).

``out_dir`` must be new, empty or the directory of an earlier fleet run (it holds
``summary.json``; its events and positions are replaced): anything else is refused with
:class:`~antikol.errors.UsageError`. When it lies inside an archive directory, it is not
read as partitions.

A task that still fails after its retries is reported in the summary with its partition
and error (``FleetSummary.failures``), never silently skipped; a failed vehicle-day is
left out of the analysis of its day, so the run is then incomplete.
"""

from __future__ import annotations

import logging
import os
import shutil
import time
from collections import Counter, defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from antikol.errors import AntikolError, UsageError
from antikol.evaluation.fleet.archive import find_partitions
from antikol.evaluation.fleet.stages import (
    FleetConfig,
    IngestResult,
    PositionResult,
    WindowResult,
    analyse_window,
    check_count,
    ingest_partition,
    load_map_cached,
    position_vehicles,
)
from antikol.evaluation.fleet.summary import FleetSummary, PartitionFailure, merge_hot_spots
from trackmap.errors import TrackMapError

__all__ = ["replay_archive", "replay_archive_local"]

logger = logging.getLogger(__name__)

#: A task: its name, the function and its arguments.
Task = tuple[str, Callable[..., Any], tuple[Any, ...]]
#: Runs a stage's tasks; returns results by name and the failures.
Runner = Callable[[str, list[Task]], tuple[dict[str, Any], list[PartitionFailure]]]


def replay_archive_local(
    paths: Sequence[str | os.PathLike[str]],
    out_dir: str | os.PathLike[str],
    config: FleetConfig,
    *,
    keep_work: bool = False,
) -> FleetSummary:
    """Replay an archive in this process (no Dask), with the same stages and outputs.

    Parameters
    ----------
    paths : sequence of path-like
        Archive files and directories (:func:`~.archive.find_partitions`).
    out_dir : path-like
    config : FleetConfig
    keep_work : bool
        Keep the working copy of the archive.
    """

    def run(stage: str, tasks: list[Task]) -> tuple[dict[str, Any], list[PartitionFailure]]:
        done: dict[str, Any] = {}
        failed: list[PartitionFailure] = []
        for name, fn, args in tasks:
            try:
                done[name] = fn(*args)
            except Exception as exc:
                failed.append(_failure(stage, name, exc))
        return done, failed

    return _pipeline(paths, out_dir, config, run, keep_work=keep_work)


def replay_archive(
    paths: Sequence[str | os.PathLike[str]],
    out_dir: str | os.PathLike[str],
    config: FleetConfig,
    *,
    scheduler: str | None = None,
    client: Any = None,
    n_workers: int = 2,
    processes: bool = True,
    retries: int = 2,
    progress: bool = False,
    dashboard: bool = False,
    on_client: Callable[[Any], None] | None = None,
    keep_work: bool = False,
    quiet: bool = True,
) -> FleetSummary:
    """Replay an archive on a ``dask.distributed`` cluster.

    Parameters
    ----------
    paths : sequence of path-like
        Archive files and directories.
    out_dir : path-like
    config : FleetConfig
    scheduler : str, optional
        Address of a running scheduler (``tcp://host:8786``); default: a ``LocalCluster``
        of ``n_workers`` single-threaded workers started and stopped here.
    client : distributed.Client, optional
        Use this client instead (neither a cluster nor a connection is made).
    n_workers : int
        Workers of the local cluster.
    processes : bool
        Local cluster: workers are processes (True) or threads of this one.
    retries : int
        Times a failed task is retried before it counts as failed.
    progress : bool
        Show a progress bar per stage.
    dashboard : bool
        Local cluster: serve the dashboard (on a free port).
    on_client : callable, optional
        Called with the client once connected (e.g. to print ``client.dashboard_link``).
    keep_work : bool
        Keep the working copy of the archive.
    quiet : bool
        Local cluster: silence Dask's own log lines (a failed task is still logged here,
        once, and reported in the summary).
    """
    check_count("retries", retries, minimum=0)
    dask_log = logging.getLogger("distributed")
    level = dask_log.level
    if quiet:
        dask_log.setLevel(logging.ERROR)
    try:
        return _on_cluster(
            paths,
            out_dir,
            config,
            client=client,
            scheduler=scheduler,
            n_workers=n_workers,
            processes=processes,
            retries=retries,
            progress=progress,
            dashboard=dashboard,
            on_client=on_client,
            keep_work=keep_work,
            quiet=quiet,
        )
    finally:
        dask_log.setLevel(level)  # quiet for this run only


def _on_cluster(
    paths: Sequence[str | os.PathLike[str]],
    out_dir: str | os.PathLike[str],
    config: FleetConfig,
    *,
    client: Any,
    scheduler: str | None,
    n_workers: int,
    processes: bool,
    retries: int,
    progress: bool,
    dashboard: bool,
    on_client: Callable[[Any], None] | None,
    keep_work: bool,
    quiet: bool,
) -> FleetSummary:
    from dask.distributed import Client, LocalCluster, as_completed
    from dask.distributed import progress as dask_progress

    cluster = None
    own_client = client is None
    if client is None:
        if scheduler is None:
            cluster = LocalCluster(
                n_workers=n_workers,
                threads_per_worker=1,
                processes=processes,
                dashboard_address=":0" if dashboard else None,
                silence_logs=logging.CRITICAL if quiet else logging.WARNING,
            )
            client = Client(cluster)
        else:
            client = Client(scheduler)
    try:
        if on_client is not None:
            on_client(client)

        def run(stage: str, tasks: list[Task]) -> tuple[dict[str, Any], list[PartitionFailure]]:
            futures = {
                client.submit(
                    fn, *args, key=f"{stage}-{i}-{name}", retries=retries, pure=False
                ): name
                for i, (name, fn, args) in enumerate(tasks)
            }
            if progress and futures:
                logger.info("stage %s: %d tasks", stage, len(futures))
                dask_progress(list(futures))
            done: dict[str, Any] = {}
            failed: list[PartitionFailure] = []
            for fut in as_completed(list(futures)):
                name = futures[fut]
                if fut.status == "error":
                    failed.append(_failure(stage, name, fut.exception()))
                else:
                    done[name] = fut.result()
                fut.release()
            return done, failed

        return _pipeline(paths, out_dir, config, run, keep_work=keep_work)
    finally:
        if own_client:
            client.close()
        if cluster is not None:
            cluster.close()


def _failure(stage: str, name: str, exc: BaseException | None) -> PartitionFailure:
    text = f"{type(exc).__name__}: {exc}".splitlines()[0][:300]
    logger.error("%s task %s failed: %s", stage, name, text)
    return PartitionFailure(
        stage, name, text, isinstance(exc, (AntikolError, TrackMapError, OSError))
    )


def _pipeline(
    paths: Sequence[str | os.PathLike[str]],
    out_dir: str | os.PathLike[str],
    config: FleetConfig,
    run: Runner,
    *,
    keep_work: bool,
) -> FleetSummary:
    started = time.perf_counter()
    out = Path(out_dir)
    if out.is_dir() and any(out.iterdir()) and not (out / "summary.json").is_file():
        raise UsageError(
            f"{out}: the output directory is not empty and holds no summary.json of an "
            "earlier fleet run; give an empty or new directory"
        )
    files = find_partitions(paths, exclude=[out])
    # a missing or broken map is the user's input error, raised here at once (not a
    # failure of every partition); workers load it again from the same spec
    load_map_cached(config.map_spec)
    for sub in ("events", "positions"):
        if (out / sub).exists():
            shutil.rmtree(out / sub)
    work = out / "work"
    work.mkdir(parents=True, exist_ok=True)
    failures: list[PartitionFailure] = []

    # stage 0: every archive file into the working copy
    ingest_tasks: list[Task] = [
        (str(f), ingest_partition, (str(f), i, config, str(work))) for i, f in enumerate(files)
    ]
    ingested, failed = run("ingest", ingest_tasks)
    failures += failed
    parts: list[IngestResult] = [ingested[name] for name, _, _ in ingest_tasks if name in ingested]

    # stage 1: every vehicle-day, in groups of config.group vehicles of a day
    files_of_vday: dict[tuple[int, str], set[str]] = defaultdict(set)
    for p in parts:
        for vd in p.vehicle_days:
            files_of_vday[vd].add(p.work_file)
    pos_tasks: list[Task] = []
    vdays = sorted(files_of_vday)
    for d in sorted({d for d, _ in vdays}):
        of_day = [v for dd, v in vdays if dd == d]
        for i in range(0, len(of_day), config.group):
            group = of_day[i : i + config.group]
            wfiles = sorted(set().union(*(files_of_vday[(d, v)] for v in group)))
            name = f"day={d}/" + (group[0] if len(group) == 1 else f"{group[0]}..{group[-1]}")
            pos_tasks.append((name, position_vehicles, (d, group, wfiles, config, str(out))))
    positioned, failed = run("positioning", pos_tasks)
    failures += failed
    pos_results: list[PositionResult] = [r for rs in positioned.values() for r in rs]
    files_of_day: dict[int, dict[str, str]] = defaultdict(dict)
    for r in pos_results:
        files_of_day[r.day][r.vehicle_id] = r.file
    excluded: dict[int, frozenset[str]] = defaultdict(frozenset)
    for d, v in files_of_vday:
        if v not in files_of_day[d]:
            excluded[d] = excluded[d] | {v}

    # stage 2: every window of every region
    windows_of_file: dict[str, set[tuple[int, int]]] = {
        p.work_file: {(d, w) for d, w, _, _ in p.windows} for p in parts
    }
    keys = sorted({key for p in parts for key in p.windows})
    win_tasks: list[Task] = []
    for d, w, cx, cy in keys:
        # the task reads reports from its warm-up's first cycle (and one before)
        first = config.window_of(config.warmup_start(d, w) - 1)
        needed = {(d, ww) for ww in range(first, w + 1)}
        wfiles = [f for f, ws in windows_of_file.items() if ws & needed]
        win_tasks.append(
            (
                f"day={d}/window={w}/region={cx},{cy}",
                analyse_window,
                (d, w, (cx, cy), wfiles, files_of_day[d], config, str(out), excluded[d]),
            )
        )
    analysed, failed = run("analysis", win_tasks)
    failures += failed
    win_results: list[WindowResult] = list(analysed.values())
    if not keep_work:
        shutil.rmtree(work, ignore_errors=True)
    summary = _summarise(
        config,
        files,
        parts,
        pos_results,
        win_results,
        failures,
        started,
        {"ingest": len(ingest_tasks), "positioning": len(pos_tasks), "analysis": len(win_tasks)},
    )
    summary.to_json(out / "summary.json")
    return summary


def _summarise(
    config: FleetConfig,
    files: Sequence[Path],
    parts: Sequence[IngestResult],
    pos: Sequence[PositionResult],
    wins: Sequence[WindowResult],
    failures: Sequence[PartitionFailure],
    started: float,
    tasks: dict[str, int],
) -> FleetSummary:
    rejected: Counter[str] = Counter()
    for p in parts:
        rejected.update(p.rejected_by_reason)
    alarms: dict[str, Counter[str]] = defaultdict(Counter)
    lamps: Counter[str] = Counter()
    for w in wins:
        for (analyser, kind), n in w.alarms.items():
            alarms[analyser][kind] += n
        lamps.update(w.lamp_cycles)
    net = load_map_cached(config.map_spec)
    spots = (
        merge_hot_spots([w.sector_only for w in wins], net, config.hotspot_m)
        if net is not None
        else ()
    )
    return FleetSummary(
        partitions=len(files),
        rows_read=sum(p.rows if p.rows is not None else p.reports for p in parts),
        reports=sum(p.reports for p in parts),
        rejected_by_reason=dict(rejected),
        vehicles=len({r.vehicle_id for r in pos}),
        vehicle_days=len(pos),
        vehicle_km=sum(r.vehicle_km for r in pos),
        vehicle_cycles=sum(w.vehicle_cycles for w in wins),
        events=sum(w.events for w in wins),
        alarms={a: dict(c) for a, c in alarms.items()},
        lamp_cycles=dict(lamps),
        hot_spots=spots,
        failures=tuple(sorted(failures, key=lambda f: (f.stage, f.name))),
        tasks=tasks,
        seconds=time.perf_counter() - started,
        unsettled_alarms=sum(len(w.unsettled_alarms) for w in wins),
    )
