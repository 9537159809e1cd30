"""Fleet-scale replay: its inputs, options and outputs (self-contained pages, a bad map,
bad settings, rejection reasons, the output directory, the summary's JSON)."""

from __future__ import annotations

import math

import pytest

pytest.importorskip("pyarrow.parquet")

from antikol.cli import main
from antikol.errors import InvalidArgumentError, UsageError
from antikol.evaluation import fleet as fl
from antikol.evaluation.fleet.stages import load_map_cached
from antikol.sim import Simulator, fleet
from trackmap.errors import TrackMapError

MAP = "synthetic"


@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    net = load_map_cached(MAP)
    result = Simulator(net, fleet(net, 4, 1), seed=2).run(120.0)
    d = tmp_path_factory.mktemp("archive")
    fl.write_parquet_archive(
        sorted(result.reports, key=lambda r: (r.t, r.vehicle_id)), d, chunk_s=60.0
    )
    return d


def test_hotspot_page_is_self_contained(tmp_path):
    pytest.importorskip("folium")
    from tests.test_html_pages import assert_self_contained

    net = load_map_cached(MAP)
    spot = fl.HotSpot(*net.to_lonlat(200.0, 100.0), 100.0, 3, {"parallel_track": 3})
    summary = fl.FleetSummary(
        partitions=1,
        rows_read=0,
        reports=0,
        rejected_by_reason={},
        vehicles=0,
        vehicle_days=0,
        vehicle_km=0.0,
        vehicle_cycles=0,
        events=0,
        alarms={},
        lamp_cycles={},
        hot_spots=(spot,),
    )
    page = fl.hotspot_html(summary, net, tmp_path / "hotspots.html").read_text(encoding="utf-8")
    assert_self_contained(page)
    for cdn in ("https://cdn", "unpkg", "jsdelivr", "cdnjs", "bootstrapcdn"):
        assert cdn not in page, cdn
    assert "parallel_track" in page


def test_a_bad_map_is_an_input_error_at_once(archive, tmp_path, capsys, monkeypatch):
    """A broken ``--map`` stops the run before any partition (exit 2, naming the file),
    instead of failing every partition as a bug."""
    from antikol.evaluation.fleet import run as fleet_run

    called = []

    def never(*args):
        called.append(args)
        raise AssertionError("a partition was read with a broken map")

    monkeypatch.setattr(fleet_run, "ingest_partition", never)
    bad = tmp_path / "broken_map.json"
    bad.write_text("{not json", encoding="utf-8")
    out = tmp_path / "out"
    code = main(["replay", str(archive), "--fleet", str(out), "--no-dask", "--map", str(bad)])
    assert code == 2
    err = capsys.readouterr().err
    assert "broken_map.json" in err
    assert "partition(s) failed" not in err and "task" not in err
    assert not (out / "summary.json").exists()
    assert not called
    with pytest.raises(TrackMapError, match="broken_map.json"):
        fl.replay_archive_local([archive], tmp_path / "out2", fl.FleetConfig(map_spec=str(bad)))
    assert not called


@pytest.mark.parametrize(
    ("name", "value"),
    [
        *[
            (name, v)
            for name in ("window_s", "cycle_s")
            for v in (math.nan, math.inf, -math.inf, 0.0, -1.0)
        ],
        *[("warmup_s", v) for v in (math.nan, math.inf, -math.inf, -1.0)],
        *[("margin_m", v) for v in (math.nan, math.inf, -1.0)],
        *[("region_m", v) for v in (math.nan, -math.inf, 0.0, -5.0)],
        *[("day_s", v) for v in (math.nan, math.inf, 0.0)],
        *[("hotspot_m", v) for v in (math.nan, math.inf, 0.0)],
        *[("max_speed_mps", v) for v in (math.nan, math.inf, 0.0)],
        ("day_offset_s", math.nan),
        *[("group", v) for v in (0, -1, 1.5, 2.0, math.nan, True, "3")],
    ],
)
def test_bad_settings_are_refused_with_the_projects_error(name, value):
    with pytest.raises(InvalidArgumentError, match=name):
        fl.FleetConfig(**{name: value})


def test_good_edge_settings_are_accepted():
    cfg = fl.FleetConfig(warmup_s=0.0, region_m=math.inf, group=1)
    assert cfg.group == 1 and cfg.region_m == math.inf


@pytest.mark.parametrize("retries", [-1, 1.5, math.nan, True])
def test_bad_retries_are_refused(archive, tmp_path, retries):
    pytest.importorskip("dask.distributed")
    with pytest.raises(InvalidArgumentError, match="retries"):
        fl.replay_archive([archive], tmp_path, fl.FleetConfig(map_spec="none"), retries=retries)


@pytest.mark.parametrize("option", [["--retries", "-1"], ["--retries", "x"], ["--warmup", "nan"]])
def test_cli_refuses_bad_fleet_options(archive, tmp_path, option, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["replay", str(archive), "--fleet", str(tmp_path / "o"), "--no-dask", *option])
    assert exc.value.code == 2
    assert option[0] in capsys.readouterr().err


def test_parquet_rejections_use_the_csv_readers_vocabulary(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    from antikol.evaluation.fleet.archive import read_partition
    from antikol.ingest.replaylog import read_replay_csv

    rows = {
        "vehicle_id": ["A", "B", "C"],
        "t": [1.0, 2.0, None],
        "lat": [50.0, 95.0, 50.0],
        "lon": [19.9, 19.9, 19.9],
        "speed_mps": [5.0, 5.0, 5.0],
        "course_deg": [90.0, 90.0, 90.0],
    }
    pq.write_table(pa.table(rows), tmp_path / "p.parquet")
    got = read_partition(tmp_path / "p.parquet").rejected_by_reason
    assert got == {"invalid lat": 1, "invalid record": 1}
    csv = tmp_path / "p.csv"
    csv.write_text(
        "vehicle_id,t,lat,lon,speed_mps,course_deg\nA,1,50,19.9,5,90\nB,2,95,19.9,5,90\n",
        encoding="utf-8",
    )
    assert "invalid lat" in read_replay_csv(csv).rejected_by_reason()


def test_a_non_empty_directory_of_something_else_is_refused(archive, tmp_path):
    out = tmp_path / "precious"
    (out / "events").mkdir(parents=True)
    (out / "events" / "keep.txt").write_text("mine", encoding="utf-8")
    cfg = fl.FleetConfig(map_spec="none")
    with pytest.raises(UsageError, match="precious"):
        fl.replay_archive_local([archive], out, cfg)
    assert (out / "events" / "keep.txt").read_text(encoding="utf-8") == "mine"
    # an earlier fleet run's directory is replaced
    again = tmp_path / "again"
    fl.replay_archive_local([archive], again, cfg)
    assert fl.replay_archive_local([archive], again, cfg).complete
    assert not (again / "events" / "keep.txt").exists()


def test_an_output_directory_inside_the_archive_is_not_read_as_partitions(archive, tmp_path):
    d = tmp_path / "arch"
    d.mkdir()
    for f in sorted(archive.glob("*.parquet")):
        (d / f.name).write_bytes(f.read_bytes())
    n = len(list(d.glob("*.parquet")))
    out = d / "fleet-out"
    cfg = fl.FleetConfig(map_spec=MAP)
    first = fl.replay_archive_local([d], out, cfg)
    second = fl.replay_archive_local([d], out, cfg)
    assert first.partitions == second.partitions == n
    assert second.complete and second.reports == first.reports
    assert fl.find_partitions([d], exclude=[out]) == sorted(d.glob("*.parquet"))


def test_summary_json_is_valid_when_no_vehicle_km(tmp_path):
    import json

    summary = fl.FleetSummary(
        partitions=1,
        rows_read=2,
        reports=2,
        rejected_by_reason={},
        vehicles=2,
        vehicle_days=2,
        vehicle_km=0.0,
        vehicle_cycles=2,
        events=1,
        alarms={"sector": {"rear_end": 1}},
        lamp_cycles={"sector": 1},
    )

    def refuse(name):
        raise ValueError(f"not JSON: {name}")

    text = summary.to_json(tmp_path / "s.json").read_text(encoding="utf-8")
    data = json.loads(text, parse_constant=refuse)
    assert data["per_vehicle_km"] == {"sector": {"rear_end": None}}


def test_replay_archive_restores_the_distributed_log_level(archive, tmp_path):
    """``quiet`` silences Dask's logger for the run only (the run here stops at once: the
    output directory is refused; no cluster is started as a client is given)."""
    import logging

    pytest.importorskip("dask.distributed")
    log = logging.getLogger("distributed")
    before = log.level
    log.setLevel(logging.INFO)
    try:
        (tmp_path / "x.txt").write_text("x", encoding="utf-8")
        with pytest.raises(UsageError):
            fl.replay_archive([archive], tmp_path, fl.FleetConfig(map_spec="none"), client=object())
        assert log.level == logging.INFO
    finally:
        log.setLevel(before)


@pytest.mark.parametrize("warmup_s", [0.0, 0.4, 1.0, 2.5, 3.5, 120.0, 1e6])
def test_one_warmup_start_for_the_driver_and_the_window_task(
    archive, tmp_path, monkeypatch, warmup_s
):
    """The driver (which picks the files a window's task reads) and the task (which
    replays from there) take the warm-up's first cycle from the same method."""
    cfg = fl.FleetConfig(map_spec="none", window_s=60.0, warmup_s=warmup_s)
    lo, _ = cfg.bounds(0, 1)
    assert cfg.warmup_start(0, 1) == max(lo - math.ceil(warmup_s - 1e-9), cfg.first_cycle(0))
    calls = []
    real = fl.FleetConfig.warmup_start

    def spy(self, day, window):
        calls.append((day, window))
        return real(self, day, window)

    monkeypatch.setattr(fl.FleetConfig, "warmup_start", spy)
    summary = fl.replay_archive_local([archive], tmp_path / "o", cfg)
    assert summary.complete
    # once per analysis task in the driver, once in the task
    assert len(calls) == 2 * summary.tasks["analysis"] > 0


def test_vehicle_km_is_the_wgs84_distance_of_close_fixes():
    from antikol.analysis.geometry import geodesic_inverse
    from antikol.evaluation.fleet.stages import _vehicle_km
    from antikol.report import VehicleReport

    lats = [50.0, 50.0001, 50.0002, 50.0003, 50.0004]
    ts = [0.0, 1.0, 2.0, 30.0, 31.0]  # the 28 s gap is not counted
    reps = [
        VehicleReport("A", t=t, lat=la, lon=19.9, speed_mps=10.0, course_deg=0.0)
        for t, la in zip(ts, lats, strict=True)
    ]
    d, _ = geodesic_inverse(lats[:-1], [19.9] * 4, lats[1:], [19.9] * 4)
    want = (d[0] + d[1] + d[3]) / 1000.0
    assert _vehicle_km(reps) == pytest.approx(want, rel=1e-9)
    assert _vehicle_km(reps[:1]) == 0.0
