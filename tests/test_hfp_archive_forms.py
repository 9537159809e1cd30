"""HSL's own archive forms of HFP read as they come: the raw dumps (camelCase columns,
``latitude``/``longitude``, ``locationQualityMethod``) and the HFP analytics API's CSV
export (``operator_id``, PostgreSQL times)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from antikol.errors import InputFileError, InvalidArgumentError, ReplayError
from antikol.ingest import detect_log_format, read_log
from antikol.ingest.hfp import MAX_LINE_CHARS, hfp_fields, looks_like_hfp_csv, read_hfp
from tests._memory import traced_peak

#: The columns of a raw dump (every message, as HSL's sink writes it).
RAW_DUMP_COLUMNS = [
    "tst",
    "eventType",
    "receivedAt",
    "topicPrefix",
    "topicVersion",
    "journeyType",
    "isOngoing",
    "mode",
    "ownerOperatorId",
    "vehicleNumber",
    "uniqueVehicleId",
    "routeId",
    "directionId",
    "headsign",
    "journeyStartTime",
    "nextStopId",
    "geohashLevel",
    "topicLatitude",
    "topicLongitude",
    "desi",
    "dir",
    "oper",
    "veh",
    "tsi",
    "spd",
    "hdg",
    "latitude",
    "longitude",
    "acc",
    "dl",
    "odo",
    "drst",
    "oday",
    "jrn",
    "line",
    "start",
    "locationQualityMethod",
    "stop",
    "route",
    "occu",
    "seq",
    "drType",
]

#: The columns of the HFP analytics API's export (api.view_as_original_hfp_event).
API_COLUMNS = [
    "tst",
    "event_type",
    "route_id",
    "direction_id",
    "operator_id",
    "oper",
    "vehicle_number",
    "transport_mode",
    "oday",
    "start",
    "odo",
    "spd",
    "drst",
    "loc",
    "stop",
    "hdg",
    "long",
    "lat",
]


def _raw_row(
    *,
    owner: int,
    number: int,
    second: int,
    lat: float,
    lon: float,
    event: str = "VP",
    loc: str = "GPS",
    oper: int | None = None,
) -> dict[str, object]:
    tst = f"2023-05-02T07:00:{second:02d}.250Z"
    return {
        "tst": tst,
        "eventType": event,
        "receivedAt": tst,
        "topicPrefix": "/hfp/",
        "topicVersion": "v2",
        "journeyType": "journey",
        "isOngoing": "true",
        "mode": "tram",
        "ownerOperatorId": owner,
        "vehicleNumber": number,
        "uniqueVehicleId": "",
        "routeId": "1006",
        "directionId": 1,
        # a headsign with a comma: the field is quoted
        "headsign": "Pasila, Rautatieasema",
        "journeyStartTime": "09:55",
        "nextStopId": "1020201",
        "geohashLevel": 4,
        # the topic's geohash cell: about 100 m off the fix, never the position
        "topicLatitude": round(lat, 3) + 0.001,
        "topicLongitude": round(lon, 3) + 0.001,
        "desi": "6",
        "dir": 1,
        "oper": owner if oper is None else oper,
        "veh": number,
        "tsi": 1683010800 + second,
        "spd": 8.2,
        "hdg": 91,
        "latitude": lat,
        "longitude": lon,
        "acc": 0.1,
        "dl": -20,
        "odo": 1000 + 8 * second,
        "drst": 0,
        "oday": "2023-05-02",
        "jrn": 123,
        "line": 33,
        "start": "09:55",
        "locationQualityMethod": loc,
        "stop": "",
        "route": "1006",
        "occu": 0,
        "seq": 1,
        "drType": "",
    }


def _write(path: Path, columns, rows) -> Path:
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(columns))
        writer.writeheader()
        writer.writerows(rows)
    return path


def test_a_raw_dump_is_read_by_its_camel_case_columns(tmp_path):
    rows = [
        _raw_row(owner=40, number=412, second=s, lat=60.1699, lon=24.9401 + 1.5e-4 * s)
        for s in range(5)
    ]
    # the same vehicle number at another operator (a bus): another vehicle
    rows += [_raw_row(owner=22, number=412, second=s, lat=60.2, lon=24.8) for s in range(3)]
    # a door event, and an estimate of the vehicle's own
    rows.append(_raw_row(owner=40, number=412, second=6, lat=60.1699, lon=24.9, event="DOO"))
    rows.append(_raw_row(owner=40, number=412, second=7, lat=60.1699, lon=24.94115, loc="ODO"))
    log = read_hfp(_write(tmp_path / "dump.csv", RAW_DUMP_COLUMNS, rows))
    assert not log.problems
    assert log.ignored == {"HFP DOO event (not a vehicle position)": 1}
    tram = [r for r in log.reports if r.vehicle_id == "40/412"]
    bus = [r for r in log.reports if r.vehicle_id == "22/412"]
    assert (len(tram), len(bus)) == (6, 3)
    # the fix is latitude/longitude, not the topic's cell
    assert [r.lat for r in tram[:5]] == [60.1699] * 5
    assert [r.lon for r in tram[:5]] == pytest.approx([24.9401 + 1.5e-4 * s for s in range(5)])
    assert tram[0].t == 1683010800.25
    assert tram[0].odometer_m == 1000.0
    assert tram[-1].fix_quality == 6  # ODO: the vehicle's own estimate


def test_the_owner_names_the_vehicle_when_another_operator_runs_the_trip(tmp_path):
    # a subcontracted trip: oper is the trip's operator, ownerOperatorId the vehicle's
    rows = [
        _raw_row(owner=40, number=7, second=s, lat=60.17, lon=24.94, oper=6 if s > 2 else 40)
        for s in range(6)
    ]
    log = read_hfp(_write(tmp_path / "dump.csv", RAW_DUMP_COLUMNS, rows))
    assert {r.vehicle_id for r in log.reports} == {"40/7"}


def test_the_analytics_export_is_read_with_its_postgres_times(tmp_path):
    rows = []
    for s in range(4):
        # the same instants written in UTC and in Helsinki's summer time
        tst = f"2023-05-02 07:00:0{s}+00" if s % 2 else f"2023-05-02 10:00:0{s}.5+03"
        rows.append(
            {
                "tst": tst,
                "event_type": "VP",
                "route_id": "1006",
                "direction_id": 1,
                "operator_id": 40,
                "oper": 22,  # the trip's operator, not the vehicle's
                "vehicle_number": 412,
                "transport_mode": "tram",
                "oday": "2023-05-02",
                "start": "09:55:00",
                "odo": 1234 + 8 * s,
                "spd": 8.0,
                "drst": 0,
                "loc": "GPS",
                "stop": "",
                "hdg": 92,
                "long": 24.9401 + 1.5e-4 * s,
                "lat": 60.1699,
            }
        )
    log = read_hfp(_write(tmp_path / "export.csv", API_COLUMNS, rows))
    assert not log.problems
    assert {r.vehicle_id for r in log.reports} == {"40/412"}
    assert [r.t - 1683010800 for r in log.reports] == [0.5, 1.0, 2.5, 3.0]


def test_a_header_without_a_position_is_refused_by_name(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("tst,vehicleNumber,topicLatitude,topicLongitude\n")
    with pytest.raises(ReplayError, match="lat or latitude"):
        read_hfp(path)


def test_lat_is_preferred_to_latitude_and_an_empty_one_falls_back():
    both = {"veh": "1", "tst": "2023-05-02T07:00:00Z", "lat": "60.1", "latitude": "61"}
    assert hfp_fields({**both, "long": "24.9"}, 1, "f").lat == 60.1
    empty = {**both, "lat": "", "longitude": "25"}
    rec = hfp_fields(empty, 1, "f")
    assert (rec.lat, rec.lon) == (61.0, 25.0)


_NAME_FORMS = st.sampled_from([str.lower, str.upper, lambda s: s])


@given(
    vehicle=st.sampled_from(["veh", "vehicle_number", "vehicleNumber", "uniqueVehicleId"]),
    time=st.sampled_from(["tst", "tsi"]),
    latitude=st.sampled_from(["lat", "latitude", "Latitude"]),
    other=st.lists(st.sampled_from(["spd", "hdg", "odo", "oper", "topicLatitude"])),
    form=_NAME_FORMS,
)
def test_any_spelling_of_the_fields_is_an_hfp_header(vehicle, time, latitude, other, form):
    header = [form(vehicle), form(time), form(latitude), *other]
    assert looks_like_hfp_csv(header)
    # without a latitude (the topic's cell is not one) it is not
    assert not looks_like_hfp_csv([h for h in header if h.lower() not in ("lat", "latitude")])


@given(lat=st.floats(-89.0, 89.0), lon=st.floats(-179.0, 179.0))
def test_latitude_and_longitude_are_the_position(lat, lon):
    rec = hfp_fields(
        {"vehiclenumber": 3, "tst": "2023-05-02T07:00:00Z", "latitude": lat, "longitude": lon},
        1,
        "f",
    )
    assert math.isclose(rec.lat, lat) and math.isclose(rec.lon, lon)
    assert rec.vehicle_id == "3"


def _vp_line(second: int) -> str:
    return (
        '{"VP": {"oper": 40, "veh": 7, "tst": "2023-05-02T07:00:'
        + f"{second:02d}"
        + '.000Z", "lat": 60.17, "long": 24.94, "spd": 8.0, "hdg": 90, "loc": "GPS"}}'
    )


@pytest.mark.parametrize("ending", ["\n", "\r\n", "\r"])
def test_a_file_is_read_line_by_line_in_bounded_memory(tmp_path, ending):
    # 20 MB without a line break between two good lines: one problem, held a piece at a
    # time (the whole file was held twice over before, as bytes and as text)
    path = tmp_path / "feed.jsonl"
    with path.open("w", newline="") as fh:
        fh.write(_vp_line(0) + ending)
        fh.write('{"VP": {"x": "' + "y" * 20_000_000 + '"}}' + ending)
        fh.write(_vp_line(1) + ending)
    log, peak = traced_peak(lambda: read_hfp(path))
    assert peak < 4 << 20, peak
    assert [r.t - 1683010800 for r in log.reports] == [0.0, 1.0]
    [problem] = log.problems
    assert problem.line == 2 and f"a line of {20_000_017:,} characters" in problem.reason


def test_a_long_csv_row_is_one_problem_of_its_line(tmp_path):
    path = tmp_path / "feed.csv"
    rows = ["veh,oper,tst,lat,long,spd,hdg"]
    rows += [f"7,40,2023-05-02T07:00:0{s}Z,60.17,24.94,8,90" for s in range(2)]
    rows.insert(2, "7,40," + "9" * (MAX_LINE_CHARS + 5))
    path.write_text("\n".join(rows) + "\n")
    log = read_hfp(path)
    assert len(log.reports) == 2
    assert [(p.line, "more than" in p.reason) for p in log.problems] == [(3, True)]


def test_a_json_array_on_one_line_is_still_read_whole(tmp_path):
    # the array form is one JSON text: a compact one is a single line beyond the limit
    import json

    messages = [json.loads(_vp_line(s % 60)) for s in range(2000)]
    for k, message in enumerate(messages):
        message["VP"]["veh"] = k // 60
    path = tmp_path / "feed.json"
    path.write_text(json.dumps(messages, separators=(",", ":")))
    assert path.stat().st_size > MAX_LINE_CHARS
    log = read_hfp(path)
    assert not log.problems and len(log.reports) == 2000


def _dump_with_buses(tmp_path: Path) -> Path:
    rows = [
        {**_raw_row(owner=40, number=412, second=s, lat=60.17, lon=24.94 + 1.5e-4 * s)}
        for s in range(4)
    ]
    bus = [_raw_row(owner=22, number=412, second=s, lat=60.2, lon=24.8) for s in range(3)]
    for row in bus:
        row["mode"] = "bus"
    # a bus record the reader would refuse: skipped unread, not counted as a problem
    bus[1]["latitude"] = "not a number"
    return _write(tmp_path / "dump.csv", RAW_DUMP_COLUMNS, rows + bus)


def test_modes_read_only_the_trams_of_a_raw_dump(tmp_path):
    path = _dump_with_buses(tmp_path)
    every = read_hfp(path)
    assert {r.vehicle_id for r in every.reports} == {"40/412", "22/412"}
    assert len(every.problems) == 1
    trams = read_hfp(path, modes=["TRAM"])
    assert {r.vehicle_id for r in trams.reports} == {"40/412"}
    assert not trams.problems
    assert trams.ignored == {"HFP bus record (not a mode read)": 3}
    assert read_hfp(path, modes="tram").reports == trams.reports


def test_modes_come_from_the_mqtt_topic(tmp_path):
    lines = []
    for mode, owner in (("tram", "0040"), ("bus", "0022")):
        topic = f"/hfp/v2/journey/ongoing/vp/{mode}/{owner}/00412/1006/1/Pasila/09:55/1/60;24"
        lines += [f"{topic} {_vp_line(s)}" for s in range(3)]
    # a message without a topic names no mode: it is read
    lines.append(_vp_line(5).replace('"veh": 7', '"veh": 8'))
    path = tmp_path / "dump.jsonl"
    path.write_text("\n".join(lines) + "\n")
    log = read_hfp(path, modes={"tram"})
    assert sorted({r.vehicle_id for r in log.reports}) == ["40/412", "40/8"]
    assert log.ignored == {"HFP bus record (not a mode read)": 3}
    # ... and the analyst is told, once for the file (a log naming no mode at all is read
    # whole, whatever --hfp-mode says)
    assert [(p.line, p.kept) for p in log.problems] == [(0, True)]
    assert "1 record(s) name no transport mode" in log.problems[0].reason
    assert not read_hfp(path).problems


@pytest.mark.parametrize("modes", [[], [""], [3], 3])
def test_modes_must_name_modes(tmp_path, modes):
    path = _dump_with_buses(tmp_path)
    with pytest.raises(InvalidArgumentError, match="modes"):
        read_hfp(path, modes=modes)


def test_hfp_mode_on_the_command_line(tmp_path, capsys):
    from antikol.cli import main

    path = _dump_with_buses(tmp_path)
    out = tmp_path / "events.csv"
    assert main(["replay", str(path), "--map", "none", "--hfp-mode", "tram", "-o", str(out)]) == 0
    shown = capsys.readouterr()
    assert "replayed 4 reports (hfp) of 1 vehicles" in shown.out
    assert "ignored 3 record(s): HFP bus record (not a mode read)" in shown.out + shown.err
    csv_path = tmp_path / "log.csv"
    csv_path.write_text("vehicle_id,t,lat,lon,speed_mps,course_deg\nA,0,50,19,1,0\n")
    assert main(["replay", str(csv_path), "--map", "none", "--hfp-mode", "tram"]) != 0
    assert "--hfp-mode is for HFP logs" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["x.csv.gz", "x.jsonl.gz"])
def test_a_compressed_file_damaged_from_its_start_is_an_input_error(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b"\x1f\x8b")  # a gzip magic number and nothing more
    with pytest.raises(InputFileError, match="gzip stream ends early") as refused:
        read_hfp(path)
    assert str(refused.value).count("cannot read") == 1


def test_strict_mode_names_the_cut_before_a_bad_record(tmp_path):
    import gzip

    lines = ["not json", *(_vp_line(s) for s in range(40))]
    packed = gzip.compress(("\n".join(lines) + "\n").encode())
    path = tmp_path / "feed.jsonl.gz"
    path.write_bytes(packed[:-30])
    with pytest.raises(ReplayError, match=r":0: the gzip stream ends early"):
        read_hfp(path, strict=True)
    log = read_hfp(path)
    assert [p.line for p in log.problems][:2] == [0, 1]
    path.write_bytes(packed)  # whole: the bad record is the error
    with pytest.raises(ReplayError, match=r":1: unreadable JSON"):
        read_hfp(path, strict=True)


@pytest.mark.parametrize("blank", ["\n", " ", "\r\n\t"])
def test_a_json_array_after_much_white_space_is_still_an_array(tmp_path, blank):
    import json

    messages = [json.loads(_vp_line(s)) for s in range(3)]
    path = tmp_path / "feed.json"
    path.write_text(blank * 70_000 + json.dumps(messages))
    log = read_hfp(path)
    assert not log.problems and len(log.reports) == 3


def test_an_mqtt_dump_with_the_time_of_reception_before_the_topic(tmp_path: Path) -> None:
    # HSL's dumps of the MQTT stream write `<received at> <topic> <payload>`; the topic's
    # headsign may hold spaces and brackets
    topic = (
        "/hfp/v2/journey/ongoing/vp/{mode}/{oper}/{veh}/1004/2/Munkkiniemi (K)/15:56/1/4"
        "/60;24/17/63/84"
    )
    payload = (
        '{{"VP":{{"desi":"4","oper":{trip_oper},"veh":{short},"tst":"2023-10-23T13:42:{s:02d}.7Z",'
        '"spd":8.5,"hdg":156,"lat":60.1687,"long":24.9344,"odo":{odo},"loc":"GPS"}}}}'
    )
    lines = []
    for s in range(3):
        received = f"2023-10-23T13:42:{s:02d}.794243Z"
        tram = topic.format(mode="tram", oper="0040", veh="00412")
        bus = topic.format(mode="bus", oper="0018", veh="00412")
        lines.append(f"{received} {tram} " + payload.format(trip_oper=6, short=412, s=s, odo=s * 8))
        lines.append(f"{received} {bus} " + payload.format(trip_oper=18, short=412, s=s, odo=s))
    path = tmp_path / "dump.txt"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")

    log = read_hfp(path, modes={"tram"})
    assert not log.problems
    # the vehicle is the topic's owner and number, not the trip's operator (oper 6)
    assert [(r.vehicle_id, r.odometer_m) for r in log.reports] == [
        ("40/412", 0.0),
        ("40/412", 8.0),
        ("40/412", 16.0),
    ]
    assert sum(log.ignored.values()) == 3
    everyone = read_hfp(path)
    assert sorted({r.vehicle_id for r in everyone.reports}) == ["18/412", "40/412"]
    # and such a file is told an HFP log by its first line, whatever its name
    assert detect_log_format(path) == "hfp"
    assert read_log(path, hfp_modes={"tram"}).reports == log.reports


def test_two_records_of_a_vehicle_at_one_time_with_other_positions(tmp_path: Path) -> None:
    """An exact repeat is ignored and counted; a second record at the same time with
    another position (one of the two is wrong, which is unknown) is a problem of its own
    line, so that the analyst finds it: before, both were 'repeated record time'."""
    lines = []
    for s, lat in [(0, 60.1700), (1, 60.1701), (1, 60.1701), (1, 60.1801), (2, 60.1702)]:
        fields = {"oper": 40, "veh": 412, "tst": f"2023-10-23T13:42:0{s}Z", "lat": lat}
        fields |= {"long": 24.9344, "spd": 8.5, "hdg": 0, "loc": "GPS"}
        lines.append(json.dumps({"VP": fields}))
    path = tmp_path / "twice.jsonl"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    log = read_hfp(path)
    assert [r.lat for r in log.reports] == [60.17, 60.1701, 60.1702]
    assert log.ignored == {"repeated record time of a vehicle": 1}
    assert [(p.line, p.kept) for p in log.problems] == [(4, False)]
    assert "another position" in log.problems[0].reason
    assert "60.1801" in log.problems[0].reason


def test_a_position_of_zeros_is_no_fix(tmp_path: Path) -> None:
    """Feeds write lat 0, long 0 for a receiver without a fix; read as a fix it put the
    tram 5,000 km away, taken as a good fix and counted as such (an end-to-end review)."""
    lines = []
    for s, lat, lon in [(0, 60.17, 24.9344), (1, 0, 0), (2, 60.1702, 24.9344)]:
        fields = {"oper": 40, "veh": 412, "tst": f"2023-10-23T13:42:0{s}Z", "lat": lat}
        fields |= {"long": lon, "spd": 8.5, "hdg": 0, "odo": 100 + 8 * s, "loc": "GPS"}
        lines.append(json.dumps({"VP": fields}))
    path = tmp_path / "zeros.jsonl"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    log = read_hfp(path)
    assert [(r.lat, r.fix_quality, r.odometer_m) for r in log.reports] == [
        (60.17, 1, 100.0),
        (60.17, 0, 108.0),  # the last known position, without a fix
        (60.1702, 1, 116.0),
    ]
    assert [(p.line, p.kept) for p in log.problems] == [(2, True)]
    assert "0, 0 is no fix" in log.problems[0].reason


def test_a_course_outside_a_turn_is_passed_on_with_a_note(tmp_path: Path) -> None:
    """hdg 400 was wrapped to 40 without a word (an end-to-end review)."""
    lines = []
    for s, hdg in [(0, 10), (1, 400), (2, -30), (3, 360)]:
        fields = {"oper": 40, "veh": 412, "tst": f"2023-10-23T13:42:0{s}Z", "lat": 60.17}
        fields |= {"long": 24.93 + 1e-4 * s, "spd": 8.5, "hdg": hdg, "loc": "GPS"}
        lines.append(json.dumps({"VP": fields}))
    path = tmp_path / "courses.jsonl"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    log = read_hfp(path)
    assert [r.course_deg for r in log.reports] == [10.0, 40.0, 330.0, 0.0]
    assert [(p.line, p.kept) for p in log.problems] == [(2, True), (3, True)]
    assert "passed on as 40" in log.problems[0].reason
