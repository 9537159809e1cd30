"""Hostile and odd HFP input: every bad record is one problem naming its line and field,
never an exception, never a loss of the good records around it, never a wrong value.

The shared :class:`~antikol.ingest.feed_common.FeedCollector` is tested here as well: a
bad record must not become the reference the vehicle's next record derives its speed and
course from.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from antikol.cli import main
from antikol.ingest.feed_common import FeedCollector, FeedRecord
from antikol.ingest.hfp import HfpRecordError, hfp_record, read_hfp

_T0 = 1_702_540_800  # 2023-12-14 08:00:00 UTC


def _fields(k: int = 0, **over: Any) -> dict[str, Any]:
    """A good VP payload of vehicle 40/412, ``k`` seconds after 08:00 (moving north)."""
    fields: dict[str, Any] = {
        "oper": 40,
        "veh": 412,
        "tst": f"2023-12-14T08:{k // 60:02d}:{k % 60:02d}Z",
        "lat": 60.1 + k * 1e-4,
        "long": 24.9,
        "spd": 10.0,
        "hdg": 0,
        "odo": 1000 + 10 * k,
    }
    fields.update(over)
    return {key: value for key, value in fields.items() if value is not ...}


def _line(k: int = 0, **over: Any) -> str:
    return json.dumps({"VP": _fields(k, **over)}, ensure_ascii=False)


def _read(tmp_path: Path, lines: list[str], name: str = "hfp.jsonl"):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return read_hfp(path)


def _problems(log) -> list[tuple[int, str]]:
    return [(p.line, p.reason) for p in log.problems]


# -- 1: numbers too large, nesting too deep -------------------------------------------------
_HUGE = "1" + "0" * 400  # an integer beyond a double's range


@pytest.mark.parametrize("name", ["spd", "tsi", "odo", "lat", "hdg"])
def test_an_integer_beyond_a_double_is_a_problem_of_its_field(tmp_path, name):
    over: dict[str, Any] = {name: 0}
    if name == "tsi":
        over["tst"] = ...
    bad = _line(1, **over).replace(f'"{name}": 0', f'"{name}": {_HUGE}')
    log = _read(tmp_path, [_line(0), bad, _line(2)])
    assert len(log.reports) == 2
    [(line, reason)] = _problems(log)
    assert line == 2 and reason.startswith(f"{name}=") and "not a finite number" in reason


@pytest.mark.parametrize(
    ("line", "why"),
    [
        ('{"VP": {"veh": 1, "spd": 1' + "0" * 5000 + "}}", "digits"),
        # (deeper than json reads, within a line's limit: MAX_LINE_CHARS)
        ("[" * 30_000 + "]" * 30_000, "nested too deeply"),
        ('{"VP": ' + "[" * 30_000 + "]" * 30_000 + "}", "nested too deeply"),
        ('{"VP": {"veh": ' + "[" * 30_000 + "]" * 30_000 + "}}", "nested too deeply"),
    ],
    ids=["5000 digits", "deep line", "deep payload", "deep field"],
)
def test_a_line_json_cannot_read_is_one_problem(tmp_path, line, why):
    log = _read(tmp_path, [_line(0), line, _line(2)])
    assert len(log.reports) == 2
    [(number, reason)] = _problems(log)
    assert number == 2 and "unreadable JSON" in reason and why in reason


def test_an_array_element_json_cannot_read_is_one_problem_of_its_record(tmp_path):
    deep = "[" * 100_000 + "]" * 100_000
    digits = '{"VP": {"veh": 1, "odo": 1' + "0" * 5000 + "}}"
    elements = [_line(0), deep, _line(2), digits, _line(4)]
    path = tmp_path / "hfp.json"
    path.write_text("[" + ",\n".join(elements) + "]", encoding="utf-8")
    log = read_hfp(path)
    assert [r.t for r in log.reports] == [_T0, _T0 + 2, _T0 + 4]
    assert [p.line for p in log.problems] == [2, 4]
    assert "nested too deeply" in log.problems[0].reason
    assert "digits" in log.problems[1].reason


def test_a_cut_json_array_keeps_its_records_before_the_cut(tmp_path):
    path = tmp_path / "hfp.json"
    path.write_text("[" + ",".join([_line(0), _line(1), _line(2)[:30]]), encoding="utf-8")
    log = read_hfp(path)
    assert len(log.reports) == 2
    [(number, reason)] = _problems(log)
    assert number == 3 and "unreadable JSON array" in reason


@pytest.mark.parametrize("command", ["replay", "match"])
def test_the_commands_read_on_past_such_lines(tmp_path, capsys, command):
    lines = [_line(k, lat=50.06306 + k * 1e-4, long=19.9326) for k in range(5)]
    lines[1] = lines[1].replace('"spd": 10.0', f'"spd": {_HUGE}')
    lines[2] = "[" * 100_000 + "]" * 100_000
    lines[3] = '{"VP": {"veh": 1, "spd": 1' + "0" * 5000 + "}}"
    path = tmp_path / "hfp.jsonl"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    args = [command, str(path), "-o", str(tmp_path / "out.csv")]
    assert main([*args, "--map", "none" if command == "replay" else "default"]) == 0
    assert "internal error" not in capsys.readouterr().err


# -- 2: a time that is no number must not upset the order of the others ----------------------
@pytest.mark.parametrize("bad", ['"nan"', "NaN", '"-inf"', "Infinity", '"1e400"'])
def test_a_non_finite_time_is_a_problem_before_the_records_are_sorted(tmp_path, bad):
    other = _line(9, veh=9, tst=None, tsi=0).replace('"tsi": 0', f'"tsi": {bad}')
    log = _read(tmp_path, [_line(3), other, _line(1), _line(2)])
    assert [r.t for r in log.reports] == [_T0 + 1, _T0 + 2, _T0 + 3]
    [(line, reason)] = _problems(log)
    assert line == 2 and reason.startswith("tsi=") and "not a finite number" in reason


@pytest.mark.parametrize("name", ["lat", "long", "spd", "hdg", "odo"])
@pytest.mark.parametrize("bad", ["NaN", "Infinity", "-Infinity", '"nan"', '"inf"'])
def test_a_non_finite_value_is_a_problem_of_its_field(tmp_path, name, bad):
    line = _line(1, **{name: 0}).replace(f'"{name}": 0', f'"{name}": {bad}')
    log = _read(tmp_path, [_line(0), line, _line(2)])
    assert len(log.reports) == 2
    [(number, reason)] = _problems(log)
    assert number == 2 and reason.startswith(f"{name}=") and "not a finite number" in reason


# -- 3: a quote left open in the CSV form ---------------------------------------------------
_HEADER = "veh,oper,tst,lat,long,spd,hdg,odo"


def _csv_row(k: int) -> str:
    return f"{400 + k},40,2023-12-14T08:00:{k:02d}Z,60.1,24.9,1.0,90,100"


def test_a_csv_quote_left_open_is_a_problem_of_its_line_alone(tmp_path):
    rows = [_csv_row(k) for k in range(50)]
    path = tmp_path / "hfp.csv"
    path.write_text("\n".join([_HEADER, '"' + rows[0], *rows[1:]]) + "\n", encoding="utf-8")
    log = read_hfp(path)
    assert len(log.reports) == 49
    [(line, reason)] = _problems(log)
    assert line == 2 and "unreadable row" in reason


def test_a_csv_quote_in_a_field_is_a_problem_of_its_line_and_the_lines_count_on(tmp_path):
    rows = [_csv_row(k) for k in range(6)]
    rows[1] = rows[1].replace("2023-12-14", '"2023"-12-14')  # text after a closing quote
    rows[3] = rows[3].replace("403", '"403')
    rows[4] = rows[4].replace("404", '4"0"4')  # a quote inside an unquoted field
    path = tmp_path / "hfp.csv"
    path.write_bytes(("\r\n".join([_HEADER, *rows]) + "\r\n").encode())
    log = read_hfp(path)
    assert sorted(int(r.vehicle_id.split("/")[1]) for r in log.reports) == [400, 402, 405]
    assert [p.line for p in log.problems] == [3, 5, 6]
    assert all("quote" in p.reason for p in log.problems)


def test_a_quoted_csv_field_is_read_as_csv(tmp_path):
    path = tmp_path / "hfp.csv"
    row = '"412",40,"2023-12-14T08:00:01Z",60.1,24.9,1,90,1,"4, ""5"" , 6",""'
    path.write_text(f"{_HEADER},desi,dir\n{row}\n")
    log = read_hfp(path)
    assert not log.problems
    assert [r.vehicle_id for r in log.reports] == ["40/412"]


# -- 4: a bad record is no reference for the next one ---------------------------------------
def _rec(number: int, t: float, lat: float | None = 60.1, lon: float | None = 24.9, **kw):
    values = {"speed_mps": None, "course_deg": None, "odometer_m": None, **kw}
    return FeedRecord(number, "f", "V", t, lat, lon, **values)


@pytest.mark.parametrize(
    ("bad", "field"),
    [
        (_rec(1, -math.inf, lat=60.0), "t="),
        (_rec(1, math.nan, lat=60.0), "t="),
        (_rec(1, 1e30, lat=60.0), "t="),
        (_rec(1, 99.0, lat=1000.0), "lat="),
        (_rec(1, 99.0, lat=math.nan), "lat="),
        (_rec(1, 99.0, lon=2400.0), "lon="),
        (_rec(1, 99.0, lon=-math.inf), "lon="),
        (_rec(1, 99.0, lat=60.0, odometer_m=-5.0), "odometer_m="),
        (_rec(1, 99.0, lat=60.0, odometer_m=math.nan), "odometer_m="),
    ],
)
def test_a_bad_record_without_speed_is_rejected_for_its_field_and_is_no_reference(bad, field):
    out = FeedCollector("f")
    out.add(bad)
    # the next record derives nothing from the bad one: no report of a made-up speed
    out.add(_rec(2, 100.0, course_deg=0.0, odometer_m=5000.0))
    out.add(_rec(3, 101.0, lat=60.1001, course_deg=0.0, odometer_m=5011.0))
    assert out.problems[0].line == 1 and out.problems[0].reason.startswith(f"invalid {field}")
    assert [(p.line, p.reason) for p in out.problems[1:]] == [
        (2, "no speed (spd) and nothing to derive it from")
    ]
    assert [(r.t, r.speed_mps) for r in out.log().reports] == [(101.0, 11.0)]


@pytest.mark.parametrize(
    ("speed", "course", "why"),
    [
        (200.0, None, "speed_mps"),
        (-1.0, None, "speed_mps"),
        (math.nan, None, "speed_mps"),
        (1.0, math.inf, "course_deg"),
    ],
)
def test_a_bad_speed_or_course_is_what_the_record_is_rejected_for(speed, course, why):
    out = FeedCollector("f")
    out.add(_rec(1, 100.0, speed_mps=speed, course_deg=course))
    [problem] = out.problems
    assert problem.reason.startswith(f"invalid {why}=")
    assert not out.reports and not out._last


def test_a_time_is_one_of_a_calendar():
    for t in (-1.0, 253_402_300_800.0):
        out = FeedCollector("f")
        out.add(_rec(1, t, speed_mps=1.0, course_deg=0.0))
        assert out.problems[0].reason.startswith("invalid t=")


# -- 5: line breaks inside a JSON string -----------------------------------------------------
@pytest.mark.parametrize("char", ["\u2028", "\u2029", "\u0085"])
def test_only_a_newline_ends_a_json_line(tmp_path, char):
    lines = [_line(0, desi=f"Kamppi{char}x"), _line(1, desi=f"x{char}y"), _line(2, lat="bad")]
    log = _read(tmp_path, lines)
    assert len(log.reports) == 2
    assert [p.line for p in log.problems] == [3]


def test_line_ends_of_each_convention_count_lines(tmp_path):
    lines = [_line(0), _line(1, lat="bad"), _line(2), _line(3, lat="bad")]
    for end in ("\n", "\r\n", "\r"):
        path = tmp_path / "hfp.jsonl"
        path.write_bytes(end.join(lines).encode() + end.encode())
        log = read_hfp(path)
        assert len(log.reports) == 2 and [p.line for p in log.problems] == [2, 4], repr(end)


# -- 6: only plain numbers, times of day, vehicle numbers -----------------------------------
@pytest.mark.parametrize("name", ["lat", "long", "spd", "hdg", "odo", "tsi"])
@pytest.mark.parametrize("text", ["1_0", "١٢", "0x1p3", "1e", "--1", "1.2.3", "½", "+"])
def test_a_number_is_plain_ascii_decimal(tmp_path, name, text):
    over: dict[str, Any] = {name: text}
    if name == "tsi":
        over["tst"] = None
    log = _read(tmp_path, [_line(0), _line(1, **over), _line(2)])
    assert len(log.reports) == 2
    [(line, reason)] = _problems(log)
    assert line == 2 and reason == f"{name}={text!r} is not a number"


@pytest.mark.parametrize("text", ["8.2", " 8.2 ", "+8.2", "8.", ".5", "8e0", "8.2E+0", "-0"])
def test_plain_numbers_are_read(tmp_path, text):
    log = _read(tmp_path, [_line(0, spd=text)])
    assert not log.problems
    assert log.reports[0].speed_mps == float(text)


def test_a_csv_number_is_plain_ascii_decimal(tmp_path):
    path = tmp_path / "hfp.csv"
    rows = [_csv_row(0).replace("60.1", "6_0"), _csv_row(1).replace("1.0", "١"), _csv_row(2)]
    path.write_text("\n".join([_HEADER, *rows]) + "\n", encoding="utf-8")
    log = read_hfp(path)
    assert len(log.reports) == 1
    assert _problems(log) == [(2, "lat='6_0' is not a number"), (3, "spd='١' is not a number")]


@pytest.mark.parametrize("veh", [[1], {"a": 1}, True, 1.5, "NaN"])
def test_a_vehicle_number_is_a_whole_number_or_a_string(tmp_path, veh):
    line = _line(0, veh=veh)
    if veh == "NaN":
        line = line.replace('"NaN"', "NaN")
    log = _read(tmp_path, [line, _line(1)])
    assert len(log.reports) == 1
    [(number, reason)] = _problems(log)
    assert number == 1 and reason.startswith("veh=")


@pytest.mark.parametrize("veh", [412.0, "412.0", "0412", " 412 "])
def test_a_vehicle_number_written_otherwise_is_the_same_vehicle(tmp_path, veh):
    log = _read(tmp_path, [_line(0), _line(1, veh=veh), _line(2)])
    assert not log.problems
    assert {r.vehicle_id for r in log.reports} == {"40/412"}


@pytest.mark.parametrize(
    "tst",
    ["2023-12-14", "2023-W50-4T08:00", "2023-348T08:00", "2023-W50-4", "٢٠٢٣-12-14T08:00:01Z"],
)
def test_a_time_has_a_calendar_date_and_a_time_of_day(tmp_path, tst):
    log = _read(tmp_path, [_line(0, tst=tst, tsi=_T0)])
    [(_, reason)] = _problems(log)
    assert reason.startswith(f"tst={tst!r}") and "time of day" in reason


@pytest.mark.parametrize(
    ("tst", "t"),
    [
        ("2023-12-14T08:00:01Z", _T0 + 1),
        ("2023-12-14 08:00:01.5", _T0 + 1.5),
        ("2023-12-14T10:00:01+02:00", _T0 + 1),
        ("20231214T080001Z", _T0 + 1),
    ],
)
def test_iso_times_of_day_are_read(tmp_path, tst, t):
    log = _read(tmp_path, [_line(0, tst=tst)])
    assert not log.problems
    assert log.reports[0].t == t


@pytest.mark.parametrize("tst", [123, 1.5, True, ["2023-12-14T08:00:01Z"], {"a": 1}])
def test_a_tst_that_is_no_string_says_so(tmp_path, tst):
    log = _read(tmp_path, [_line(0, tst=tst)])
    [(_, reason)] = _problems(log)
    assert reason.startswith("tst=") and "not a time" in reason and "missing" not in reason


@pytest.mark.parametrize(
    ("over", "name"),
    [
        ({"tst": None, "tsi": 1e30}, "tsi"),
        ({"tst": None, "tsi": -1}, "tsi"),
        ({"tst": None, "tsi": 253_402_300_800}, "tsi"),
        ({"tst": "0001-01-01T00:00:00+14:00"}, "tst"),
        ({"tst": "9999-12-31T23:59:59-14:00"}, "tst"),
    ],
)
def test_a_time_outside_1970_to_9999_is_a_problem_of_its_field(tmp_path, over, name):
    log = _read(tmp_path, [_line(0, **over), _line(1)])
    assert len(log.reports) == 1
    [(_, reason)] = _problems(log)
    assert reason.startswith(f"{name}=") and "1970" in reason


@pytest.mark.parametrize("loc", [["GPS"], 1, {"a": "GPS"}])
def test_a_location_source_is_a_string(tmp_path, loc):
    log = _read(tmp_path, [_line(0, loc=loc)])
    [(_, reason)] = _problems(log)
    assert reason.startswith("loc=")


# -- any JSON value in any field --------------------------------------------------------------
_json = st.recursive(
    st.none()
    | st.booleans()
    | st.integers()
    | st.integers(-(10**400), 10**400)
    | st.floats()
    | st.text(max_size=12)
    | st.sampled_from(["1_0", "١٢", "nan", "-inf", "1e400", "2023-12-14", "412.0", " 7 "]),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner),
    max_leaves=6,
)
_NAMES = [
    "oper",
    "veh",
    "tst",
    "tsi",
    "lat",
    "long",
    "lon",
    "spd",
    "hdg",
    "odo",
    "loc",
    "unique_vehicle_id",
    "vehicle_number",
    "owner_operator_id",
]


@settings(max_examples=300, deadline=None)
@given(
    over=st.dictionaries(st.sampled_from(_NAMES), _json, max_size=4),
    drop=st.lists(st.sampled_from(_NAMES), max_size=3),
)
@example(over={"spd": 10**400}, drop=[])
@example(over={"tst": None, "tsi": math.nan}, drop=[])
@example(over={"tst": None, "tsi": 1e30}, drop=[])
@example(over={"lat": math.inf, "spd": None}, drop=[])
def test_any_json_value_in_any_field_is_a_record_or_a_problem(over, drop):
    fields = _fields(0, **over)
    for name in drop:
        fields.pop(name, None)
    try:
        rec = hfp_record({"VP": fields}, 1, "f")
    except HfpRecordError as exc:
        assert str(exc)
        return
    assert isinstance(rec, FeedRecord)
    assert math.isfinite(rec.t) and 0.0 <= rec.t < 253_402_300_800.0
    assert isinstance(rec.vehicle_id, str) and rec.vehicle_id
    for value in (rec.lat, rec.lon, rec.speed_mps, rec.course_deg, rec.odometer_m):
        assert value is None or (type(value) is float and math.isfinite(value))
    out = FeedCollector("f")
    out.add(rec)  # a report or a problem, never an exception
    assert len(out.reports) + len(out.problems) >= 1


_messages = st.dictionaries(st.sampled_from(_NAMES), _json, max_size=4).map(
    lambda over: {"VP": _fields(0, **over)}
)


@settings(max_examples=100, deadline=None)
@given(st.lists(_json | _messages, max_size=4))
@example([{"VP": _fields(1, odo=10**400)}, [[[[]]]]])
def test_any_json_lines_are_records_or_problems(tmp_path_factory, values):
    lines = [json.dumps(v) for v in values]
    path = tmp_path_factory.mktemp("any") / "hfp.jsonl"
    path.write_text("\n".join([_line(0), *lines]) + "\n", encoding="utf-8")
    log = read_hfp(path)
    assert len(log.reports) >= 1
    assert all(p.line >= 2 for p in log.problems)
