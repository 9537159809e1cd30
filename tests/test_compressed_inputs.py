"""Recorded feeds compressed as operators publish them (gzip, bzip2, xz): read as their
content, a cut archive keeping the records before the cut (antikol.ingest.compressed)."""

from __future__ import annotations

import bz2
import csv
import gzip
import json
import lzma
import tracemalloc

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol.cli import main
from antikol.errors import InputFileError, ReplayError
from antikol.ingest import detect_log_format, read_log
from antikol.ingest.compressed import (
    compression_of,
    logical_suffix,
    open_input,
    read_head,
    read_input,
    stream_problem,
)
from antikol.ingest.gtfsrt import write_feed_message
from antikol.ingest.nmea import read_nmea_file
from antikol.ingest.replaylog import iter_replay_csv, read_nmea_logs, write_replay_csv
from antikol.sim import GpsModel, Simulator, fleet
from tests._feeds import EPOCH, gtfs_vehicle

_COMPRESS = {"gzip": gzip.compress, "bzip2": bz2.compress, "xz": lzma.compress}
_SUFFIX = {"gzip": ".gz", "bzip2": ".bz2", "xz": ".xz"}


@pytest.fixture(scope="module")
def simulation():
    net = trackmap.load_default()
    return Simulator(net, fleet(net, 2, 5), gps=GpsModel.urban(), seed=5).run(60.0)


@pytest.fixture(scope="module")
def simulated(simulation):
    return [r for r in simulation.reports if r.fix_quality == 1]


def _hfp_line(r) -> str:
    return json.dumps(
        {
            "VP": {
                "oper": 40,
                "veh": int(r.vehicle_id[1:]),
                "tsi": int(EPOCH + r.t),
                "lat": r.lat,
                "long": r.lon,
                "spd": r.speed_mps,
                "hdg": r.course_deg,
                "odo": r.odometer_m,
                "loc": "GPS",
            }
        }
    )


@settings(max_examples=60, deadline=None)
@given(
    payload=st.binary(max_size=3000),
    members=st.integers(min_value=1, max_value=3),
    kind=st.sampled_from(sorted(_COMPRESS)),
    cut=st.floats(min_value=0.0, max_value=1.0),
)
def test_any_content_comes_back_and_a_cut_keeps_a_prefix(
    tmp_path_factory, payload, members, kind, cut
):
    path = tmp_path_factory.mktemp("c") / f"log{_SUFFIX[kind]}"
    parts = [payload[k::members] for k in range(members)]  # concatenated members
    packed = [_COMPRESS[kind](part) for part in parts]
    blob = b"".join(packed)
    path.write_bytes(blob)
    whole = read_input(path)
    assert whole == (b"".join(parts), kind, None)
    assert read_head(path, 100) == b"".join(parts)[:100]
    keep = int(cut * (len(blob) - 1))  # at least the last byte is cut
    path.write_bytes(blob[:keep])
    if compression_of(blob[:keep]) is None:  # cut inside the magic number: a plain file
        assert read_input(path) == (blob[:keep], None, None)
        return
    ends = [sum(map(len, packed[: k + 1])) for k in range(members)]
    if keep in ends:  # cut between two members: a shorter file, nothing shows the cut
        assert read_input(path) == (b"".join(parts[: ends.index(keep) + 1]), kind, None)
        return
    try:
        got = read_input(path)
    except InputFileError as exc:  # nothing could be read before the cut
        assert str(path) in str(exc) and "lost" in str(exc)
        return
    assert b"".join(parts).startswith(got.data)
    assert got.problem is not None and "ends early" in got.problem


@given(head=st.binary(max_size=12))
def test_plain_files_are_read_as_they_are(tmp_path_factory, head):
    path = tmp_path_factory.mktemp("p") / "plain.csv"
    path.write_bytes(head)
    if compression_of(head) is None:
        assert read_input(path) == (head, None, None)
        with open_input(path) as fh:
            assert fh.read() == head and stream_problem(fh) is None


@pytest.mark.parametrize("pad", [0, 4, 8, 20_000])  # 20 000: padding across read chunks
def test_xz_streams_with_stream_padding_are_all_read_as_xz_reads_them(tmp_path, pad):
    path = tmp_path / "log.csv.xz"
    first, second = b"vehicle_id,t\n", b"T1,1\n" * 3
    packed = lzma.compress(first) + b"\0" * pad + lzma.compress(second)
    path.write_bytes(packed + b"\0" * pad)  # padding may follow the last stream too
    assert read_input(path) == (first + second, "xz", None)
    assert read_head(path, 20) == (first + second)[:20]
    with open_input(path) as fh:
        assert fh.readlines() == [first, *[b"T1,1\n"] * 3] and stream_problem(fh) is None


@pytest.mark.parametrize(
    "blob",
    [b"\0" * 3 + lzma.compress(b"T1,2\n"), b"\0" * 5],
    ids=["before a stream", "at the end"],
)
def test_xz_stream_padding_not_a_multiple_of_four_is_damage(tmp_path, blob):
    # xz -dc stops there too ("Compressed data is corrupt")
    path = tmp_path / "log.csv.xz"
    path.write_bytes(lzma.compress(b"T1,1\n") + blob)
    got = read_input(path)
    assert got.data == b"T1,1\n" and got.compression == "xz"
    assert got.problem is not None and "padding" in got.problem and "lost" in got.problem


@pytest.mark.parametrize("kind", sorted(_COMPRESS))
def test_a_compressed_bomb_is_streamed_in_bounded_memory(tmp_path, kind):
    # 32 MB of one line: bzip2 packs it in under 100 bytes, so one read of the file
    # must not decompress all it holds at once
    path = tmp_path / f"t1.nmea{_SUFFIX[kind]}"
    path.write_bytes(_COMPRESS[kind](b"$GPRMC," + b"x" * (32 << 20)))
    tracemalloc.start()
    try:
        head = read_head(path, 10)
        head_peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.reset_peak()
        reports, stats = read_nmea_file(path)
        file_peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    held = 8 << 20 if kind == "xz" else 0  # xz's decoder holds its dictionary (8 MiB)
    assert head == b"$GPRMC,xxx" and head_peak < held + (1 << 20)
    assert reports == [] and stats.skipped == {"too_long": 1} and stats.cut is None
    assert file_peak < held + (2 << 20)


def test_the_format_suffix_is_the_one_before_the_compression():
    assert logical_suffix("a/b/hfp-2023-12-14.CSV.gz") == ".csv"
    assert logical_suffix("vp.pb.xz") == ".pb"
    assert logical_suffix("feed.jsonl") == ".jsonl"
    assert logical_suffix("archive.gz") == ""


def test_a_missing_file_names_itself(tmp_path):
    with pytest.raises(InputFileError, match="nothing.gz"):
        read_input(tmp_path / "nothing.gz", what="HFP log")


@pytest.mark.parametrize("kind", sorted(_COMPRESS))
def test_a_compressed_hfp_archive_reads_as_the_plain_one(simulated, tmp_path, kind):
    text = "\n".join(_hfp_line(r) for r in simulated) + "\n"
    plain = tmp_path / "hfp.jsonl"
    plain.write_text(text)
    packed = tmp_path / f"hfp.jsonl{_SUFFIX[kind]}"
    packed.write_bytes(_COMPRESS[kind](text.encode()))
    assert detect_log_format(packed) == "hfp"
    assert read_log(packed).reports == read_log(plain).reports
    # the CSV archive form, named by its content's suffix
    rows = [json.loads(line)["VP"] for line in text.splitlines()]
    table = tmp_path / "hfp.csv"
    with table.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    packed_csv = tmp_path / f"hfp.csv{_SUFFIX[kind]}"
    packed_csv.write_bytes(_COMPRESS[kind](table.read_bytes()))
    assert detect_log_format(packed_csv) == "hfp"
    assert read_log(packed_csv).reports == read_log(table).reports


def test_a_cut_hfp_archive_keeps_the_records_before_the_cut(simulated, tmp_path):
    text = ("\n".join(_hfp_line(r) for r in simulated) + "\n").encode()
    packed = gzip.compress(text)
    path = tmp_path / "hfp.jsonl.gz"
    path.write_bytes(packed[: len(packed) * 3 // 4])
    log = read_log(path)
    assert 0 < len(log.reports) < len(simulated)
    cut = [p for p in log.problems if p.line == 0]
    assert len(cut) == 1 and "gzip stream ends early" in cut[0].reason
    with pytest.raises(ReplayError, match="ends early"):
        read_log(path, strict=True)


def test_a_compressed_replay_csv_streams_and_a_cut_one_ends_in_a_problem(simulated, tmp_path):
    plain = tmp_path / "log.csv"
    write_replay_csv(plain, simulated)
    packed = tmp_path / "log.csv.xz"
    blob = lzma.compress(plain.read_bytes())
    packed.write_bytes(blob)
    assert detect_log_format(packed) == "csv"
    assert read_log(packed).reports == read_log(plain).reports
    packed.write_bytes(blob[: len(blob) // 2])
    items = list(iter_replay_csv(packed))
    assert items and items[-1].code == "compressed stream cut"
    assert "xz stream ends early" in items[-1].reason
    with pytest.raises(ReplayError, match="ends early"):
        list(iter_replay_csv(packed, strict=True))


def test_replay_runs_on_a_directory_of_compressed_gtfs_realtime_snapshots(
    simulated, tmp_path, capsys
):
    feed = tmp_path / "rt"
    feed.mkdir()
    for k, r in enumerate(simulated[:20]):
        plain = tmp_path / f"{k:03d}.pb"
        write_feed_message(plain, [gtfs_vehicle(r)])
        (feed / f"{k:03d}.pb.gz").write_bytes(gzip.compress(plain.read_bytes()))
    assert detect_log_format(feed) == "gtfs-rt"
    assert len(read_log(feed).reports) == 20
    events = tmp_path / "events.csv"
    assert main(["replay", str(feed), "-o", str(events), "--map", "none"]) == 0
    assert "(gtfs-rt)" in capsys.readouterr().out


def test_a_directory_of_compressed_nmea_logs_names_each_vehicle_by_its_file(simulation, tmp_path):
    plain = tmp_path / "plain"
    written = simulation.write_nmea(plain)
    packed = tmp_path / "packed"
    packed.mkdir()
    for k, f in enumerate(written):  # one vehicle gzip, the other xz
        blob = (gzip.compress if k % 2 == 0 else lzma.compress)(f.read_bytes())
        (packed / (f.name + (".gz" if k % 2 == 0 else ".xz"))).write_bytes(blob)
    assert detect_log_format(packed) == "nmea"
    got, want = read_log(packed), read_log(plain)
    assert got.reports == want.reports and {r.vehicle_id for r in got.reports} == {"T01", "T02"}
    # a log cut short keeps its sentences before the cut, and says so
    first = sorted(packed.iterdir())[0]
    blob = first.read_bytes()
    first.write_bytes(blob[: len(blob) // 2])
    cut = read_log(packed)
    assert 0 < len(cut.reports) < len(want.reports)
    assert [p.code for p in cut.problems if p.code == "compressed stream cut"] == [
        "compressed stream cut"
    ]
    # the same vehicle twice, plain and compressed, is an error naming both
    (packed / written[0].name).write_bytes(written[0].read_bytes())
    with pytest.raises(InputFileError, match="two files for vehicle"):
        read_log(packed)


def test_a_damaged_compressed_nmea_log_without_a_line_is_damaged_not_ignored(simulation, tmp_path):
    written = simulation.write_nmea(tmp_path / "logs")
    d = written[0].parent
    (d / "notes.txt").write_text("a note, not a log\n")
    (d / "bad.log.gz").write_bytes(gzip.compress(written[0].read_bytes())[:12])  # 0 lines
    log = read_nmea_logs(d)
    assert {r.vehicle_id for r in log.reports} == {"T01", "T02"}
    assert list(log.ignored) == ["not an NMEA log (no sentence in 1 line(s)): notes.txt"]
    [cut] = [p for p in log.problems if p.code == "compressed stream cut"]
    assert cut.source == str(d / "bad.log.gz") and "gzip stream ends early" in cut.reason
    # alone in its directory it is still named, with why nothing could be read
    for f in written:
        f.unlink()
    with pytest.raises(InputFileError, match=r"bad\.log\.gz.*gzip stream ends early"):
        read_nmea_logs(d)
