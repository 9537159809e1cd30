"""Replay logs: decoded line by line, streamed in constant memory, every rejected row
reported with its line and counted by reason (issue 14)."""

from __future__ import annotations

import csv
import random
import tracemalloc

import pytest

from antikol import ReplayError, VehicleReport
from antikol.cli import main
from antikol.evaluation.replay import StreamedLog, cycles, replay
from antikol.ingest.nmea_writer import format_gga, format_rmc
from antikol.ingest.replaylog import (
    MAX_LINE_BYTES,
    RowProblem,
    iter_replay_csv,
    read_nmea_logs,
    read_replay_csv,
    scan_replay_csv,
    stream_replay_csv,
)
from tests._memory import traced_peak

HEADER = b"vehicle_id,t,lat,lon,speed_mps,course_deg\n"


def _rows(n: int, *, vehicles: int = 3) -> list[bytes]:
    return [
        f"T{k % vehicles},{k * 0.5},{50.06 + 1e-5 * k:.7f},19.94,5.0,90.0\n".encode()
        for k in range(n)
    ]


def test_a_latin1_byte_rejects_only_its_line(tmp_path):
    rows = _rows(3001)
    rows[1500] = rows[1500].replace(b"T0", b"T\xe9", 1)  # file line 1502
    path = tmp_path / "log.csv"
    path.write_bytes(HEADER + b"".join(rows))
    log = read_replay_csv(path)
    assert len(log.reports) == 3000 and log.rows == 3001
    assert [(p.line, p.code) for p in log.problems] == [(1502, "not UTF-8")]
    assert "byte 0xe9 at column 2" in log.problems[0].reason


def test_a_bad_byte_near_the_top_is_not_an_unreadable_header(tmp_path):
    rows = _rows(100)
    rows[1] = b"\xff" + rows[1]  # line 3
    path = tmp_path / "log.csv"
    path.write_bytes(HEADER + b"".join(rows))
    log = read_replay_csv(path)
    assert len(log.reports) == 99 and [p.line for p in log.problems] == [3]
    path.write_bytes(HEADER.replace(b"lat", b"l\xe4t") + b"".join(rows))
    with pytest.raises(ReplayError, match=r"log.csv:1: unreadable header: not UTF-8"):
        read_replay_csv(path)


def test_an_unclosed_quote_rejects_only_its_line(tmp_path):
    rows = _rows(50)
    rows[10] = b'"T1,5,50.06,19.94,5,90\n'
    path = tmp_path / "log.csv"
    path.write_bytes(HEADER + b"".join(rows))
    log = read_replay_csv(path)
    assert len(log.reports) == 49 and [(p.line, p.code) for p in log.problems] == [
        (12, "CSV syntax")
    ]


@pytest.mark.parametrize("end", [b"\n", b"\r\n", b"\r"])
def test_line_ends_and_a_line_too_long(end, tmp_path):
    rows = [r.rstrip(b"\n") for r in _rows(20)]
    rows[5] = b"x" * (MAX_LINE_BYTES + 10)
    path = tmp_path / "log.csv"
    path.write_bytes(end.join([HEADER.rstrip(b"\n"), *rows]))
    log = read_replay_csv(path)
    assert len(log.reports) == 19
    assert [(p.line, p.code) for p in log.problems] == [(7, "line too long")]


def test_every_row_is_a_report_or_a_problem_by_reason(tmp_path):
    path = tmp_path / "log.csv"
    path.write_bytes(
        HEADER
        + b"T1,0,50.06,19.94,5,90\n"
        + b"T1,1,95,19.94,5,90\n"  # invalid lat
        + b"T1,x,50.06,19.94,5,90\n"  # t not a number
        + b"T1,3\n"  # too few fields
        + b"\n"  # blank: not a row
        + b"   ,4,50.06,19.94,5,90\n"  # blank id
        + b"T1,5,50.06,19.94,35,90\n"
    )
    log = read_replay_csv(path)
    assert log.rows == 6 and len(log.reports) == 2 and log.rejected == 4
    assert log.rejected_by_reason() == {
        "invalid lat": 1,
        "t not a number": 1,
        "too few fields": 1,
        "invalid vehicle_id": 1,
    }
    scan = scan_replay_csv(path, keep_problems=1)
    assert (scan.rows, scan.valid, scan.rejected) == (6, 2, 4)
    assert scan.rejected_by_reason == log.rejected_by_reason() and len(scan.problems) == 1


def test_streaming_holds_one_cycle_not_the_log(tmp_path):
    n = 20_000
    path = tmp_path / "big.csv"
    path.write_bytes(HEADER + b"".join(_rows(n)))
    tracemalloc.start()
    try:
        scan = scan_replay_csv(path)
        count = sum(
            len(b) for _, b in cycles(StreamedLog(path, scan).reports, 1.0, in_time_order=True)
        )
        _, streamed_peak = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        held = read_replay_csv(path)
        _, held_peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert scan.in_time_order and count == n == len(held.reports)
    # 20,000 rows held take ~7 MB; streamed, the peak is one 64 kB read and one cycle
    assert streamed_peak < 1_000_000 and 10 * streamed_peak < held_peak


def test_a_log_out_of_time_order_streams_sorted(tmp_path):
    rows = _rows(2_500)
    random.Random(4).shuffle(rows)
    path = tmp_path / "shuffled.csv"
    path.write_bytes(HEADER + b"".join(rows))
    scan = scan_replay_csv(path)
    assert not scan.in_time_order
    streamed = list(stream_replay_csv(path, in_time_order=False, run_size=300))
    expected = sorted(read_replay_csv(path).reports, key=lambda r: r.t)
    assert streamed == expected


def test_a_log_out_of_time_order_streams_in_the_memory_of_one_run(tmp_path):
    # the merge once kept every report it had read (one unpickler's memo for the run)
    rows = _rows(20_000, vehicles=40)
    random.Random(5).shuffle(rows)
    path = tmp_path / "shuffled.csv"
    path.write_bytes(HEADER + b"".join(rows))

    def count_in_time_order() -> int:
        last, count = 0.0, 0
        for r in stream_replay_csv(path, in_time_order=False, run_size=500):
            assert r.t >= last
            last, count = r.t, count + 1
        return count

    count, peak = traced_peak(count_in_time_order)
    assert count == 20_000
    # 20,000 reports held take ~7 MB; 40 runs of 500 merge in well under 2 MB
    assert peak < 2_000_000


def test_cli_replay_summary_and_rejects_file(tmp_path, capsys):
    rows = _rows(400)
    rows[10] = rows[10].replace(b"50.06", b"95.06", 1)
    for k in range(30, 60):
        rows[k] = rows[k].replace(b"T", b"T\xe9", 1)
    path = tmp_path / "log.csv"
    path.write_bytes(HEADER + b"".join(rows))
    rejects = tmp_path / "rejects.csv"
    events = tmp_path / "events.csv"
    assert main(["replay", str(path), "-o", str(events), "--rejects", str(rejects)]) == 0
    out = capsys.readouterr()
    assert "read 400 rows: 369 replayed, 31 rejected (invalid lat: 1, not UTF-8: 30)" in out.out
    assert "skipped line 12: invalid lat=95.06" in out.err
    assert (
        f"... and 11 more bad record(s) or notes (all are in {rejects}); "
        "in all 31 skipped, 0 passed on"
    ) in out.err
    written = list(csv.DictReader(rejects.open()))
    assert [int(r["line"]) for r in written] == [12, *range(32, 62)]


def test_cli_replay_of_one_fast_row_with_the_default_map(tmp_path, capsys):
    path = tmp_path / "one.csv"
    path.write_bytes(HEADER + b"T1,0,50.06306,19.9326,35,90\n")
    assert main(["replay", str(path), "--map", "default", "-o", str(tmp_path / "e.csv")]) == 0
    assert "read 1 rows: 1 replayed, 0 rejected" in capsys.readouterr().out


def test_a_readme_in_an_nmea_directory_is_not_a_vehicle(tmp_path, capsys):
    d = tmp_path / "nmea"
    d.mkdir()
    r = VehicleReport("V1", 1_700_000_000.0, 50.06, 19.94, 5.0, 90.0)
    (d / "V1.nmea").write_text(format_rmc(r) + "\n" + format_gga(r) + "\n")
    (d / "README.txt").write_text("Recorded on line 8, 14 December.\nReceiver: u-blox.\n")
    log = read_nmea_logs(d)
    assert {x.vehicle_id for x in log.reports} == {"V1"}
    assert log.ignored == {"not an NMEA log (no sentence in 2 line(s)): README.txt": 1}
    assert main(["replay", str(d), "-o", str(tmp_path / "e.csv")]) == 0
    out = capsys.readouterr()
    assert "of 1 vehicles" in out.out and "README.txt" in out.err


def test_problems_carry_their_line_in_file_order(tmp_path):
    path = tmp_path / "log.csv"
    path.write_bytes(HEADER + b"T1,0,50.06,19.94,5,90\nT1,1,50.06,19.94,-5,90\n")
    items = list(iter_replay_csv(path))
    assert isinstance(items[0], VehicleReport) and isinstance(items[1], RowProblem)
    assert items[1].line == 3 and items[1].category == "invalid speed_mps"


def test_replay_of_a_streamed_log_equals_the_in_memory_replay(tmp_path):
    from antikol.analysis.analyser import Analyser

    rows = _rows(300, vehicles=2)
    path = tmp_path / "log.csv"
    path.write_bytes(HEADER + b"".join(rows))
    a = replay(StreamedLog(path, scan_replay_csv(path)), Analyser())
    b = replay(read_replay_csv(path), Analyser())
    assert (a.cycles, a.reports, a.rows_read, dict(a.by_kind)) == (
        b.cycles,
        b.reports,
        b.rows_read,
        dict(b.by_kind),
    )


def test_a_latin1_byte_in_an_hfp_log_costs_one_record(tmp_path):
    import json

    from antikol.ingest.hfp import read_hfp

    lines = [
        json.dumps(
            {
                "VP": {
                    "oper": 40,
                    "veh": 412,
                    "tst": f"2023-12-14T08:00:{k:02d}Z",
                    "lat": 50.06 + 1e-5 * k,
                    "long": 19.94,
                    "spd": 8.0,
                    "hdg": 90,
                    "loc": "GPS",
                }
            }
        ).encode()
        for k in range(20)
    ]
    lines[7] = lines[7].replace(b'"veh": 412', b'"veh": "41\xe9"')
    lines[9] = lines[9].replace(b'"loc": "GPS"', b'"loc": "GP\xe9"')  # a field not needed
    path = tmp_path / "feed.jsonl"
    path.write_bytes(b"\n".join(lines))
    log = read_hfp(path)
    assert len(log.reports) == 19 and [p.line for p in log.problems] == [8]
    assert "vehicle_id" in log.problems[0].reason
