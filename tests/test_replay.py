"""Replay logs (CSV and NMEA directories) through the analyser and the CLI."""

from __future__ import annotations

import csv
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import ReplayError
from antikol.cli import main
from antikol.errors import InputFileError
from antikol.evaluation.replay import cycles
from antikol.ingest.nmea_writer import format_gga, format_rmc
from antikol.ingest.replaylog import (
    REPLAY_OPTIONAL_COLUMNS,
    read_replay_csv,
    write_replay_csv,
)
from antikol.report import VehicleReport
from antikol.sim import Simulator, fleet
from tests._paths import interleave, reports_from_xy


def fig11_reports():
    t = np.arange(0.0, 46.0, 1.0)
    v1 = reports_from_xy("V1", t, np.zeros_like(t), -350.0 + 8.0 * t)
    v2 = reports_from_xy("V2", t, np.full_like(t, 4.0), 350.0 - 8.0 * t)
    return interleave(v1, v2)


def test_bad_rows_are_reported_with_line_numbers(tmp_path):
    p = tmp_path / "log.csv"
    p.write_text(
        "vehicle_id,t,lat,lon,speed_mps,course_deg,extra\n"
        "T1,0,50.06,19.94,5,90,x\n"
        "T1,1,95.0,19.94,5,90,x\n"  # line 3: latitude out of range
        "T1,2,50.06,abc,5,90,x\n"  # line 4: not a number
        "T1,3\n"  # line 5: too few fields
        "\n"
        "T1,4,50.06,19.94,5,90,x\n"
    )
    log = read_replay_csv(p)
    assert [r.t for r in log.reports] == [0.0, 4.0]
    assert [pr.line for pr in log.problems] == [3, 4, 5]
    assert "lat" in log.problems[0].reason and "lon" in log.problems[1].reason
    with pytest.raises(ReplayError, match=r"log.csv:3: .*lat"):
        read_replay_csv(p, strict=True)


def test_header_and_file_errors(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("id,time,lat,lon\n")
    with pytest.raises(ReplayError, match="header must start with"):
        read_replay_csv(p)
    with pytest.raises(InputFileError):
        read_replay_csv(tmp_path / "missing.csv")
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(ReplayError, match="empty"):
        read_replay_csv(tmp_path / "empty.csv")


def test_simulated_log_round_trip_keeps_the_optional_columns(tmp_path):
    net = trackmap.load_default()
    specs = fleet(
        net,
        3,
        2,
        route_length_m=2000.0,
        headway_s=2.0,
        length_m=28.0,
        antenna_offset_m=5.0,
        script=[("emergency_brake", 40.0)],
    )
    result = Simulator(net, specs, seed=2).run(60.0)
    path = result.write_csv(tmp_path / "sim.csv", extra_columns=REPLAY_OPTIONAL_COLUMNS)
    log = read_replay_csv(path, strict=True)
    # equal to the simulated reports within the printed precision of the format
    expected = [
        replace(
            r,
            lat=round(r.lat, 8),
            lon=round(r.lon, 8),
            speed_mps=round(r.speed_mps, 3),
            course_deg=round(r.course_deg, 2),
        )
        for r in result.reports
    ]
    assert log.reports == expected and log.problems == []
    assert {r.braking for r in log.reports} == {"none", "service", "emergency"}
    assert {(r.length_m, r.antenna_offset_m) for r in log.reports} == {(28.0, 5.0)}
    assert [r.seq for r in log.reports if r.vehicle_id == specs[0].vehicle_id][:3] == [0, 1, 2]
    # without the optional columns the reports carry the defaults
    plain = read_replay_csv(result.write_csv(tmp_path / "plain.csv"))
    assert [r.t for r in plain.reports] == [r.t for r in result.reports]
    assert {(r.braking, r.length_m, r.seq) for r in plain.reports} == {("none", None, None)}


def test_optional_columns_in_any_order_and_empty_cells(tmp_path):
    p = tmp_path / "log.csv"
    p.write_text(
        "vehicle_id,t,lat,lon,speed_mps,course_deg,seq,note,length_m,braking\n"
        "T1,0,50.06,19.94,5,90,7,x,31.5,service\n"
        "T1,1,50.06,19.94,5,90,,x,,\n"  # empty cells: not given
        "T1,2,50.06,19.94,5,90,8\n"  # a short row: the missing cells are not given
        "T1,3,50.06,19.94,5,90,x,x,31.5,none\n"  # line 5: seq is not an integer
        "T1,4,50.06,19.94,5,90,9,x,-2,none\n"  # line 6: a negative length
        "T1,5,50.06,19.94,5,90,9,x,31.5,stopping\n"  # line 7: an unknown brake state
    )
    log = read_replay_csv(p)
    base = VehicleReport("T1", 0.0, 50.06, 19.94, 5.0, 90.0)
    assert log.reports == [
        replace(base, seq=7, length_m=31.5, braking="service"),
        replace(base, t=1.0),
        replace(base, t=2.0, seq=8),
    ]
    assert [pr.line for pr in log.problems] == [5, 6, 7]
    assert "seq='x' is not an integer" in log.problems[0].reason
    assert "length_m" in log.problems[1].reason and "braking" in log.problems[2].reason


# What float()/int() accept beyond plain ASCII decimal syntax: digit-group underscores,
# digits of other scripts, Unicode spaces, words; a CSV cell must not mean 10 by '1_0'.
_NOT_PLAIN = ["1_0", "\u0661\u0662", "\uff15", "1\u00a0", "\u20035", "\x0c5", "0_1", "1e1_0"]
_NUMERIC_COLUMNS = ("t", "lat", "lon", "speed_mps", "course_deg", *REPLAY_OPTIONAL_COLUMNS[1:])
_HEADER = "vehicle_id,t,lat,lon,speed_mps,course_deg," + ",".join(REPLAY_OPTIONAL_COLUMNS[1:])
# a valid row for _HEADER, by column (integers where the column takes an integer)
_VALID = {"t": "5", "lat": "50", "lon": "19", "speed_mps": "1", "course_deg": "1"} | {
    "length_m": "30",
    "antenna_offset_m": "2",
    "seq": "7",
    "hdop": "1",
    "fix_quality": "1",
    "odometer_m": "100",
}


def _row(column: str, text: str) -> str:
    cells = [_VALID[c] if c != column else text for c in _NUMERIC_COLUMNS]
    return "T1," + ",".join(cells) + "\n"


@pytest.mark.parametrize("column", _NUMERIC_COLUMNS)
def test_numbers_are_plain_ascii_decimals_in_every_column(tmp_path, column):
    p = tmp_path / "log.csv"
    p.write_text(
        _HEADER + "\n" + _row(column, " 3 ") + "".join(_row(column, x) for x in _NOT_PLAIN),
        encoding="utf-8",
    )
    log = read_replay_csv(p)
    assert [getattr(r, column) for r in log.reports] == [3]  # spaces around are fine
    assert [pr.line for pr in log.problems] == list(range(3, 3 + len(_NOT_PLAIN)))
    assert all(f"{column}=" in pr.reason and "not a" in pr.reason for pr in log.problems)
    with pytest.raises(ReplayError, match=rf"log.csv:3: {column}='1_0' is not"):
        read_replay_csv(p, strict=True)


_PLAIN = st.from_regex(r"\A[+-]?([0-9]{1,12}(\.[0-9]{0,6})?|\.[0-9]{1,6})([eE][+-]?[0-9]{1,2})?\Z")


def _unplain(draw_text: str, how: int, where: int) -> str:
    """``draw_text`` changed into something float() still reads but that is not plain."""
    digits = [k for k, c in enumerate(draw_text) if c.isdigit()]
    k = digits[where % len(digits)]
    if how == 0:  # the same digit in another script (Arabic-Indic, fullwidth, Devanagari)
        base = (0x0660, 0xFF10, 0x0966)[where % 3]
        return draw_text[:k] + chr(base + int(draw_text[k])) + draw_text[k + 1 :]
    if how == 1 and k + 1 < len(draw_text) and draw_text[k + 1].isdigit():
        return draw_text[: k + 1] + "_" + draw_text[k + 1 :]
    if how == 2:
        return "nan"[: where % 3 + 1] if where % 2 else "-inf"
    return "\u2003" + draw_text + "\u00a0"  # Unicode spaces around


@settings(max_examples=200, deadline=None)
@given(text=_PLAIN, how=st.integers(0, 3), where=st.integers(0, 100))
def test_only_plain_decimal_syntax_is_a_number(tmp_path_factory, text, how, where):
    d = tmp_path_factory.mktemp("n")
    other = _unplain(text, how, where)
    try:
        float(other)
    except ValueError:  # 'n', 'na': not even float() reads it
        other = "\u00a0" + text
    unsigned = text.lstrip("+-")  # an odometer is not negative
    p = d / "log.csv"
    p.write_text(
        "vehicle_id,t,lat,lon,speed_mps,course_deg,odometer_m\n"
        f"T1,{text},50,19,1,1,{unsigned}\nT1,{other},50,19,1,1,\nT1,1,50,19,1,1,{other}\n",
        encoding="utf-8",
    )
    log = read_replay_csv(p)
    # plain: read as float() reads it; not plain: refused, naming the line and the field
    assert [(r.t, r.odometer_m) for r in log.reports] == [(float(text), float(unsigned))]
    assert [pr.line for pr in log.problems] == [3, 4]
    assert "t=" in log.problems[0].reason and "odometer_m=" in log.problems[1].reason


def test_optional_column_named_twice_is_an_error(tmp_path):
    p = tmp_path / "twice.csv"
    p.write_text("vehicle_id,t,lat,lon,speed_mps,course_deg,seq,braking,seq\n")
    with pytest.raises(ReplayError, match="'seq' appears twice"):
        read_replay_csv(p)
    with pytest.raises(ValueError, match="twice"):
        write_replay_csv(tmp_path / "w.csv", [], extra_columns=("seq", "seq"))
    with pytest.raises(ValueError, match="unknown CSV column"):
        write_replay_csv(tmp_path / "w.csv", [], extra_columns=("colour",))


def test_cycles_group_reports():
    reps = fig11_reports()
    groups = list(cycles(reps, 5.0))
    assert sum(len(b) for _, b in groups) == len(reps)
    assert all(all(t_end - 5.0 < r.t <= t_end for r in b) for t_end, b in groups)


def test_cli_replay_reproduces_fig11(tmp_path, capsys):
    log = write_replay_csv(tmp_path / "fig11.csv", fig11_reports())
    events = tmp_path / "events.csv"
    assert main(["replay", str(log), "-o", str(events)]) == 0
    out = capsys.readouterr().out
    assert "2 vehicles" in out and "sector rule" in out
    rows = list(csv.DictReader(events.open()))
    assert rows and {r["method"] for r in rows} == {"sector"}
    assert {r["own_id"] for r in rows} == {"V1", "V2"}
    # one alarm episode per vehicle, from ~300 m down to ~15 m
    for vid in ("V1", "V2"):
        dist = [float(r["distance_m"]) for r in rows if r["own_id"] == vid]
        assert 290.0 <= max(dist) < 300.0
        assert 14.0 < min(dist) < 40.0
        line = next(ln for ln in out.splitlines() if ln.startswith(vid))
        assert line.split()[-1] == "1"


def test_cli_replay_with_map_and_strict(tmp_path, capsys):
    log = write_replay_csv(tmp_path / "fig11.csv", fig11_reports())
    with log.open("a") as fh:
        fh.write("V1,100,nan,19.9,1,1\n")
    assert main(["replay", str(log), "-o", str(tmp_path / "e.csv"), "--strict"]) == 2
    assert "fig11.csv:94: invalid lat=nan" in capsys.readouterr().err
    assert main(["replay", str(log), "-o", str(tmp_path / "e.csv"), "--map", "default"]) == 0
    captured = capsys.readouterr()
    assert "track-aware analyser" in captured.out
    assert "skipped line 94" in captured.err


def test_cli_replay_of_nmea_directory(tmp_path, capsys):
    d = tmp_path / "nmea"
    d.mkdir()
    epoch = 1_700_000_000.0
    for vid in ("V1", "V2"):
        lines = []
        for r in fig11_reports():
            if r.vehicle_id != vid:
                continue
            shifted = type(r)(vid, epoch + r.t, r.lat, r.lon, r.speed_mps, r.course_deg)
            lines += [format_rmc(shifted), format_gga(shifted)]
        (d / f"{vid}.nmea").write_text("\n".join(lines) + "\nGARBAGE LINE\n")
    events = tmp_path / "events.csv"
    assert main(["replay", str(d), "-o", str(events)]) == 0
    out = capsys.readouterr()
    assert "2 vehicles" in out.out
    assert "NMEA" in out.err  # the garbage lines are reported, not silently dropped
    assert len(list(csv.DictReader(events.open()))) > 10
