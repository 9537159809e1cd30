"""An operator's feed replayed in bounded memory (antikol.ingest.feed_stream): the same
reports, problems and counts as the readers' lists, on every pass, whatever the run size."""

from __future__ import annotations

import json
import random
import tempfile

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from antikol.analysis.analyser import Analyser
from antikol.cli import main
from antikol.errors import InvalidArgumentError, ReplayError
from antikol.evaluation.replay import EventWriter, replay
from antikol.ingest import read_gtfs_realtime, read_hfp
from antikol.ingest.feed_stream import StreamedFeed
from antikol.ingest.gtfsrt import write_feed_message
from tests._feeds import EPOCH
from tests._memory import traced_peak


def _vp(veh: int, t: float, lat: float, lon: float, **fields) -> dict:
    tst = f"2023-12-14T08:{int(t) // 60:02d}:{t % 60:06.3f}Z"
    return {"VP": {"oper": 40, "veh": veh, "tst": tst, "lat": lat, "long": lon, **fields}}


_MESSAGE = st.builds(
    lambda veh, t, dlat, dlon, spd, hdg, odo, bad: (
        "{not json"
        if bad == 1
        else json.dumps(
            _vp(
                veh,
                t,
                50.06 + dlat if bad != 2 else 95.0,
                19.94 + dlon,
                **({} if spd is None else {"spd": spd}),
                **({} if hdg is None else {"hdg": hdg}),
                **({} if odo is None else {"odo": odo}),
            )
        )
    ),
    veh=st.integers(1, 3),
    t=st.integers(0, 40).map(lambda k: k * 0.5),
    dlat=st.integers(-200, 200).map(lambda k: k * 1e-5),
    dlon=st.integers(-200, 200).map(lambda k: k * 1e-5),
    spd=st.none() | st.sampled_from([0.0, 0.3, 6.5, 12.0]),
    hdg=st.none() | st.integers(0, 359),
    odo=st.none() | st.integers(0, 500),
    bad=st.integers(0, 12),
)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(lines=st.lists(_MESSAGE, max_size=50), run_size=st.integers(1, 12))
def test_a_streamed_hfp_log_gives_what_read_hfp_gives(tmp_path, lines, run_size):
    path = tmp_path / "vp.jsonl"
    path.write_text("\n".join(lines) + "\n")
    held = read_hfp(path)
    with StreamedFeed(path, log_format="hfp", run_size=run_size) as feed:
        assert list(feed.reports) == held.reports
        assert list(feed.reports) == held.reports  # every pass
        assert feed.valid == len(held.reports)
        assert feed.problems == held.problems and feed.ignored == held.ignored
        assert feed.rejected == held.rejected
        assert feed.rejected_by_reason() == held.rejected_by_reason()


def _shuffled_log(path, *, vehicles: int, seconds: int, seed: int) -> None:
    rng = random.Random(seed)
    # trams 65 m apart, one behind the other, running north at 4 m/s
    lines = [
        json.dumps(
            _vp(v, float(k), 50.06 + 3.6e-5 * k + 6e-4 * v, 19.94, spd=4.0, hdg=0, odo=4 * k)
        )
        for v in range(1, vehicles + 1)
        for k in range(seconds)
    ]
    rng.shuffle(lines)
    path.write_text("\n".join(lines) + "\n")


def test_a_gtfs_realtime_directory_streams_as_it_reads(tmp_path):
    feed_dir = tmp_path / "rt"
    feed_dir.mkdir()
    rng = random.Random(3)
    for k in range(60):
        vehicles = [
            {
                "id": f"T{v}",
                "timestamp": int(EPOCH + k + rng.choice([0, 0, -3])),  # late ones as well
                "lat": 50.06 + 1e-5 * k,
                "lon": 19.94 + 1e-3 * v,
                "speed": 4.0,
                "bearing": 0.0,
            }
            for v in range(4)
        ]
        write_feed_message(feed_dir / f"vp-{k:03d}.pb", vehicles, timestamp=int(EPOCH + k))
    held = read_gtfs_realtime(feed_dir)
    with StreamedFeed(feed_dir, log_format="gtfs-rt", run_size=7) as feed:
        assert feed.spilled > 1
        assert list(feed.reports) == held.reports
        assert (feed.problems, feed.ignored) == (held.problems, held.ignored)


def _count_in_time_order(reports) -> int:
    count, last = 0, -1.0
    for r in reports:
        assert r.t >= last
        count, last = count + 1, r.t
    return count


def test_a_streamed_log_is_replayed_in_the_memory_of_one_run(tmp_path):
    path = tmp_path / "vp.jsonl"
    _shuffled_log(path, vehicles=20, seconds=1_000, seed=1)
    with StreamedFeed(path, log_format="hfp", run_size=500) as feed:
        count, streamed_peak = traced_peak(lambda: _count_in_time_order(feed.reports))
    held, held_peak = traced_peak(lambda: read_hfp(path))
    assert count == len(held.reports) == 20_000
    # 20,000 reports held take ~10 MB; merging 40 runs of 500 takes a small part of it
    assert 5 * streamed_peak < held_peak


def test_the_cli_replays_a_feed_as_the_reports_in_memory_replay(tmp_path, capsys):
    path = tmp_path / "vp.jsonl"
    _shuffled_log(path, vehicles=4, seconds=120, seed=2)
    streamed = tmp_path / "streamed.csv"
    assert main(["replay", str(path), "-o", str(streamed), "--map", "none"]) == 0
    assert "replayed 480 reports (hfp) of 4 vehicles" in capsys.readouterr().out
    held = tmp_path / "held.csv"
    with EventWriter(held) as events:
        replay(read_hfp(path), Analyser(), on_assessment=events)
    assert streamed.read_bytes() == held.read_bytes() and events.rows > 0


def test_strict_stops_at_the_first_bad_record_and_leaves_no_file(tmp_path, monkeypatch):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    path = tmp_path / "vp.jsonl"
    _shuffled_log(path, vehicles=2, seconds=30, seed=3)
    with path.open("a") as f:
        f.write("{not json\n")
    with pytest.raises(ReplayError, match=r"vp.jsonl:61"):
        StreamedFeed(path, log_format="hfp", strict=True, run_size=4)
    assert not any((tmp_path / "tmp").iterdir())
    with StreamedFeed(path, log_format="hfp", run_size=4) as feed:
        assert feed.spilled and feed.rejected == 1
    assert not any((tmp_path / "tmp").iterdir())


def test_a_format_it_does_not_stream_or_modes_of_gtfs_realtime_are_refused(tmp_path):
    with pytest.raises(InvalidArgumentError, match="log_format"):
        StreamedFeed(tmp_path / "x.csv", log_format="csv")
    with pytest.raises(InvalidArgumentError, match="modes"):
        StreamedFeed(tmp_path / "rt", log_format="gtfs-rt", modes=["tram"])
