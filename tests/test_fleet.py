"""Fleet-scale replay (antikol.evaluation.fleet): the partitioned run on a 2-worker Dask
cluster gives the single-process answer event for event, failures are retried and
reported, and on-board imports stay free of Dask."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("dask.distributed")
pq = pytest.importorskip("pyarrow.parquet")
ds = pytest.importorskip("pyarrow.dataset")

from antikol.analysis.analyser import Analyser  # noqa: E402
from antikol.cli import main  # noqa: E402
from antikol.errors import InvalidArgumentError  # noqa: E402
from antikol.evaluation import fleet as fl  # noqa: E402
from antikol.evaluation.fleet import run as fleet_run  # noqa: E402
from antikol.evaluation.fleet.stages import load_map_cached  # noqa: E402
from antikol.evaluation.replay import event_values, replay  # noqa: E402
from antikol.ingest.replaylog import ReplayLog  # noqa: E402
from antikol.sim import Simulator, fleet  # noqa: E402

MAP = "synthetic"
#: Small windows and regions so that conflicts straddle both kinds of boundary.
SMALL = fl.FleetConfig(map_spec=MAP, window_s=120.0, warmup_s=120.0, region_m=1000.0)
WHOLE = fl.FleetConfig(map_spec=MAP, window_s=86_400.0, region_m=math.inf)
COMPARED = (
    "t",
    "own_id",
    "other_id",
    "level",
    "kind",
    "distance_m",
    "method",
    "zone",
    "closing_speed_mps",
    "ttc_s",
    "probability",
)


@pytest.fixture(scope="module")
def reports():
    net = load_map_cached(MAP)
    result = Simulator(net, fleet(net, 8, 1), seed=1).run(600.0)
    return sorted(result.reports, key=lambda r: (r.t, r.vehicle_id))


@pytest.fixture(scope="module")
def archive(reports, tmp_path_factory):
    d = tmp_path_factory.mktemp("archive")
    fl.write_parquet_archive(reports, d, chunk_s=200.0)
    return d


@pytest.fixture(scope="module")
def local_run(archive, tmp_path_factory):
    out = tmp_path_factory.mktemp("local")
    return fl.replay_archive_local([archive], out, WHOLE), out


@pytest.fixture(scope="module")
def dask_run(archive, tmp_path_factory):
    out = tmp_path_factory.mktemp("dask")
    return fl.replay_archive([archive], out, SMALL, n_workers=2), out


def test_a_running_scheduler_given_by_address_gives_the_same_events(archive, local_run, tmp_path):
    """``scheduler=ADDRESS`` (``--scheduler``): a cluster started elsewhere, reached over TCP."""
    from distributed import LocalCluster

    out = tmp_path / "remote"
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        assert cluster.scheduler_address.startswith("tcp://")
        got = fl.replay_archive([archive], out, SMALL, scheduler=cluster.scheduler_address)
    assert got.complete
    assert _events(out) == _events(local_run[1])


def _events(out: Path) -> list[dict]:
    table = ds.dataset(out / "events", format="parquet", partitioning="hive").to_table()
    rows = [{k: v for k, v in r.items() if k != "day"} for r in table.to_pylist()]
    return sorted(rows, key=lambda r: (r["analyser"], r["t"], r["own_id"], r["other_id"]))


def _plain(reports, track_map) -> list[dict]:
    an = Analyser(track_map=track_map)
    rows: list[dict] = []

    def on(a):
        rows.extend({k: event_values(a, th)[k] for k in COMPARED} for th in a.threats)

    replay(ReplayLog(reports=list(reports)), an, on_assessment=on)
    return sorted(rows, key=lambda r: (r["t"], r["own_id"], r["other_id"]))


def test_single_process_stages_equal_the_plain_replay(reports, local_run):
    """Positioning each vehicle alone and analysing on the stored positions gives what
    one analyser replaying the whole log gives: both analysers, event for event."""
    summary, out = local_run
    assert summary.complete
    events = _events(out)
    for name, net in (("track", load_map_cached(MAP)), ("sector", None)):
        ours = [{k: r[k] for k in COMPARED} for r in events if r["analyser"] == name]
        assert ours == _plain(reports, net), name
        assert ours


def test_dask_two_workers_equal_the_single_process_run(local_run, dask_run):
    """Windows of 120 s with a 120 s warm-up and regions of 1 km: the distributed result
    is the single-process one, event for event, and the boundaries were really crossed."""
    (ref, ref_out), (got, got_out) = local_run, dask_run
    assert got.complete and got.unsettled_alarms == 0  # the warm-up sufficed, and says so
    assert got.tasks["analysis"] > ref.tasks["analysis"] == 1
    a, b = _events(ref_out), _events(got_out)
    assert len(a) > 1000
    assert a == b
    assert (got.vehicle_cycles, got.lamp_cycles, got.alarms) == (
        ref.vehicle_cycles,
        ref.lamp_cycles,
        ref.alarms,
    )
    # boundaries crossed: a pair with events in two windows, events of vehicles in two
    # regions, and pairs whose vehicles are in different regions at the same time
    files = sorted((got_out / "events" / "day=0").glob("*.parquet"))
    windows = {f.name.split("_")[0] for f in files}
    regions = {f.name.split("_", 1)[1] for f in files}
    assert len(windows) >= 4 and len(regions) >= 2
    net = load_map_cached(MAP)
    pos = ds.dataset(got_out / "positions", format="parquet", partitioning="hive").to_table()
    where = {}
    for r in pos.select(["vehicle_id", "t", "lon", "lat"]).to_pylist():
        x, y = net.to_local(r["lon"], r["lat"])
        where[(r["vehicle_id"], r["t"])] = (math.floor(x / 1000.0), math.floor(y / 1000.0))
    track = [r for r in b if r["analyser"] == "track"]
    across_regions = [
        r for r in track if where.get((r["own_id"], r["t"])) != where.get((r["other_id"], r["t"]))
    ]
    assert across_regions
    by_pair: dict[tuple[str, str], set[int]] = {}
    for r in track:
        by_pair.setdefault((r["own_id"], r["other_id"]), set()).add(int(r["t"] - 1) // 120)
    assert any(len(w) > 1 for w in by_pair.values())


def test_outputs_and_summary(dask_run):
    summary, out = dask_run
    assert (out / "summary.json").is_file()
    assert not (out / "work").exists()
    assert summary.vehicles == 7 and summary.vehicle_km > 10
    assert summary.reports == summary.rows_read > 3000
    rates = summary.per_vehicle_km("sector")
    assert rates["sector"] > 0
    assert summary.hot_spots and summary.hot_spots[0].cycles >= summary.hot_spots[-1].cycles
    positions = pq.read_table(next((out / "positions" / "day=0").glob("*.parquet")))
    assert positions.num_rows > 100


def test_replay_csv_partitions_give_the_plain_replay_events(reports, tmp_path):
    """The archive may be replay CSVs (any format read_log reads), one file per hour, say
    (CSV rounds the values, so the reference is the plain replay of the CSVs)."""
    from antikol.ingest.replaylog import read_replay_csv, write_replay_csv

    d = tmp_path / "csv"
    d.mkdir()
    write_replay_csv(d / "a.csv", [r for r in reports if r.t <= 300.0])
    write_replay_csv(d / "b.csv", [r for r in reports if r.t > 300.0])
    summary = fl.replay_archive_local([d], tmp_path / "out", WHOLE)
    assert summary.complete and summary.partitions == 2
    read = read_replay_csv(d / "a.csv").reports + read_replay_csv(d / "b.csv").reports
    read.sort(key=lambda r: (r.t, r.vehicle_id))
    events = _events(tmp_path / "out")
    ours = [{k: r[k] for k in COMPARED} for r in events if r["analyser"] == "track"]
    assert ours == _plain(read, load_map_cached(MAP))


def test_broken_partition_is_retried_and_reported(archive, tmp_path, capsys):
    """An unreadable file is a counted failure (input error: exit 2), never skipped."""
    d = tmp_path / "archive"
    d.mkdir()
    for f in sorted(archive.glob("*.parquet"))[:2]:
        (d / f.name).write_bytes(f.read_bytes())
    (d / "part-broken.parquet").write_bytes(b"not parquet at all")
    out = tmp_path / "out"
    code = main(
        ["replay", str(d), "--fleet", str(out), "--map", MAP, "--workers", "2", "--retries", "1"]
    )
    assert code == 2
    err = capsys.readouterr().err
    assert "part-broken.parquet" in err and "1 partition(s) failed" in err
    summary = fl.replay_archive_local([d], tmp_path / "out2", SMALL)
    assert [(f.stage, Path(f.name).name, f.input_error) for f in summary.failures] == [
        ("ingest", "part-broken.parquet", True)
    ]
    assert summary.reports > 0


def test_flaky_task_succeeds_on_retry(archive, tmp_path, monkeypatch):
    """A task that fails once succeeds on its retry (the attempts are counted in files:
    Dask ships the task function by value)."""
    marks = tmp_path / "attempts"
    marks.mkdir()
    real = fleet_run.ingest_partition

    def flaky(path, *args):
        tries = sorted(marks.glob(Path(path).name + ".*"))
        (marks / f"{Path(path).name}.{len(tries)}").touch()
        if not tries:
            raise OSError(f"{path}: transient")
        return real(path, *args)

    monkeypatch.setattr(fleet_run, "ingest_partition", flaky)
    summary = fl.replay_archive(
        [archive], tmp_path / "out", SMALL, n_workers=2, processes=False, retries=1
    )
    assert summary.complete and summary.reports > 3000
    attempts = sorted(p.name for p in marks.iterdir())
    assert len(attempts) == 2 * len(list(archive.glob("*.parquet")))


def test_a_bug_in_a_partition_exits_3(archive, tmp_path, monkeypatch, capsys):
    def broken(day, vehicle_ids, *args):
        if "T03" in vehicle_ids:
            raise RuntimeError("boom")
        return real(day, vehicle_ids, *args)

    real = fleet_run.position_vehicles
    monkeypatch.setattr(fleet_run, "position_vehicles", broken)
    out = tmp_path / "out"
    code = main(
        ["replay", str(archive), "--fleet", str(out), "--map", MAP, "--no-dask", "--group", "1"]
    )
    assert code == 3
    assert "day=0/T03" in capsys.readouterr().err
    events = _events(out)
    assert events and all("T03" not in (r["own_id"], r["other_id"]) for r in events)


def test_cli_fleet_writes_figures(archive, tmp_path, capsys):
    out = tmp_path / "out"
    code = main(
        ["replay", str(archive), "--fleet", str(out), "--map", MAP, "--no-dask", "--window", "300"]
    )
    assert code == 0
    text = capsys.readouterr().out
    assert "warnings per vehicle-km" in text and "false-alarm candidates" in text
    assert (out / "hotspots.png").stat().st_size > 0
    assert "<html" in (out / "hotspots.html").read_text(encoding="utf-8").lower()


def test_cli_usage_errors(archive, tmp_path):
    assert main(["replay", str(archive), "--scheduler", "tcp://127.0.0.1:1"]) == 2
    assert main(["replay", str(archive), str(archive)]) == 2


def test_margin_must_cover_the_interaction_reach():
    reach = fl.FleetConfig().interaction_reach_m()
    assert 1000 < reach <= fl.FleetConfig().margin_m
    with pytest.raises(InvalidArgumentError, match="margin_m"):
        fl.FleetConfig(margin_m=reach - 1)
    with pytest.raises(InvalidArgumentError, match="window_s"):
        fl.FleetConfig(window_s=1.5, cycle_s=1.0)


def test_importing_antikol_and_the_fleet_package_imports_no_dask():
    code = (
        "import sys, antikol, antikol.evaluation.fleet, antikol.cli;"
        "bad = [m for m in ('dask', 'distributed', 'pyarrow') if m in sys.modules];"
        "assert not bad, bad"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_a_warm_up_too_short_is_reported(archive, local_run, tmp_path):
    """With a 1 s warm-up the windowed run loses alarms held across window starts; the
    run says so instead of passing the difference off as the answer."""
    short = fl.FleetConfig(map_spec=MAP, window_s=60.0, warmup_s=1.0, region_m=math.inf)
    summary = fl.replay_archive_local([archive], tmp_path, short)
    ref_summary, ref_out = local_run
    differs = _events(tmp_path) != _events(ref_out)
    assert differs, "the case must really lose something"
    assert summary.unsettled_alarms > 0
    assert any("warm-up too short" in line for line in summary.lines())
    assert ref_summary.unsettled_alarms == 0
