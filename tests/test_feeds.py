"""Operator feeds (issue 12): HSL-style HFP (JSON lines, JSON array, CSV) and
GTFS-realtime VehiclePositions, read into reports and replayed through the CLI."""

from __future__ import annotations

import csv
import json
from datetime import UTC, datetime

import pytest
from hypothesis import given
from hypothesis import strategies as st

import trackmap
from antikol.cli import main
from antikol.errors import InputFileError, InvalidArgumentError, ReplayError
from antikol.ingest import detect_log_format, read_gtfs_realtime, read_hfp, read_log
from antikol.ingest.gtfsrt import write_feed_message
from antikol.sim import GpsModel, Simulator, fleet
from tests._feeds import EPOCH, gtfs_vehicle


@pytest.fixture(scope="module")
def simulated():
    """Three trams on Kraków for two minutes with the urban receiver (odometer on)."""
    net = trackmap.load_default()
    result = Simulator(net, fleet(net, 3, 7), gps=GpsModel.urban(), seed=7).run(120.0)
    return [r for r in result.reports if r.fix_quality == 1]


def _iso(t: float) -> str:
    return datetime.fromtimestamp(EPOCH + t, tz=UTC).isoformat(timespec="milliseconds")[:-6] + "Z"


def _vp(r, **over) -> dict:
    oper, veh = 40, int(r.vehicle_id[1:])
    fields = {
        "desi": "4",
        "dir": "1",
        "oper": oper,
        "veh": veh,
        "tst": _iso(r.t),
        "tsi": int(EPOCH + r.t),
        "spd": round(r.speed_mps, 2),
        "hdg": round(r.course_deg),
        "lat": round(r.lat, 7),
        "long": round(r.lon, 7),
        "acc": 0.0,
        "dl": 0,
        "odo": round(r.odometer_m),
        "drst": 0,
        "oday": "2023-12-14",
        "jrn": 1,
        "line": 4,
        "start": "08:00",
        "loc": "GPS",
        "stop": None,
        "route": "1004",
        "occu": 0,
    }
    fields.update(over)
    return {"VP": fields}


def test_hfp_json_lines_with_events_mqtt_lines_and_bad_records(simulated, tmp_path):
    lines = [json.dumps(_vp(r)) for r in simulated]
    n = len(lines)
    topic = "/hfp/v2/journey/ongoing/vp/tram/0040/00001/1004/1/Kurdwanow/08:00/1/60;19/29/46/38"
    lines.insert(3, f"{topic} {json.dumps(_vp(simulated[3], tst=_iso(simulated[3].t + 0.5)))}")
    lines.insert(5, json.dumps({"DOO": {"oper": 40, "veh": 1, "tst": _iso(3.0)}}))
    lines.insert(7, '{"VP": {"oper": 40, "veh": 2, "tst": "yesterday"}}')  # line 8
    lines.insert(
        9,
        '{"VP": {"oper": 40, "veh": 2, "tst": "2023-12-14T08:00:01Z", "lat": 95.0,'
        ' "long": 19.9, "spd": 1.0, "hdg": 0, "odo": 5}}',
    )  # line 10: latitude
    lines.insert(11, "{not json")  # line 12
    path = tmp_path / "hfp.jsonl"
    path.write_text("\n".join(lines) + "\n")
    assert detect_log_format(path) == "hfp"
    log = read_hfp(path)
    assert len(log.reports) == n + 1
    assert [(p.line, p.kept) for p in log.problems] == [(8, False), (10, False), (12, False)]
    assert "tst" in log.problems[0].reason and "lat" in log.problems[1].reason
    assert "JSON" in log.problems[2].reason
    assert log.ignored == {"HFP DOO event (not a vehicle position)": 1}
    by_vid = {r.vehicle_id for r in log.reports}
    assert by_vid == {"40/1", "40/2", "40/3"}
    first = next(r for r in log.reports if r.vehicle_id == "40/1")
    src = next(r for r in simulated if r.vehicle_id == "T01")
    assert first.t == pytest.approx(EPOCH + src.t)
    assert first.odometer_m == round(src.odometer_m) and first.fix_quality == 1
    assert first.lat == pytest.approx(src.lat, abs=1e-7)
    with pytest.raises(ReplayError, match=r"hfp.jsonl:8: .*tst"):
        read_hfp(path, strict=True)


def test_hfp_derives_missing_speed_and_heading_and_flags_positions_without_a_fix(
    simulated, tmp_path
):
    t1 = [r for r in simulated if r.vehicle_id == "T02"][:20]
    msgs = [_vp(r) for r in t1]
    msgs[5]["VP"]["spd"] = None
    msgs[5]["VP"]["hdg"] = None
    msgs[6]["VP"].update(loc="ODO", lat=None, long=None)
    msgs[7]["VP"]["odo"] = msgs[6]["VP"]["odo"] - 50  # an odometer going back: passed on
    msgs[0]["VP"]["spd"] = None  # the first record: nothing to derive from
    path = tmp_path / "array.json"
    path.write_text(json.dumps(msgs))
    log = read_hfp(path)
    assert [(p.line, p.kept) for p in log.problems] == [(1, False), (8, True)]
    assert "spd" in log.problems[0].reason and "odometer" in log.problems[1].reason
    reports = log.reports
    assert len(reports) == 19
    derived = reports[4]
    assert derived.speed_mps == pytest.approx(t1[5].speed_mps, abs=1.0)
    no_fix = reports[5]
    assert no_fix.fix_quality == 0 and (no_fix.lat, no_fix.lon) == (reports[4].lat, reports[4].lon)
    assert no_fix.odometer_m == msgs[6]["VP"]["odo"]
    assert reports[6].odometer_m == msgs[7]["VP"]["odo"]
    assert reports[7].odometer_m == msgs[8]["VP"]["odo"]


def _moving(simulated, vehicle_id: str, n: int):
    run = [r for r in simulated if r.vehicle_id == vehicle_id and r.speed_mps > 3.0][:n]
    assert len(run) == n
    return run


def test_hfp_odometer_counted_per_trip_is_kept_after_the_reset(simulated, tmp_path):
    # HSL-style feeds count the odometer from the start of each trip: it goes back to 0
    # at a new trip. Every reading of the new trip went back against the old trip's last
    # one, and all of them were dropped (the tram ran the rest of the day without one)
    run = _moving(simulated, "T01", 30)
    msgs = [_vp(r) for r in run]
    base = run[0].odometer_m
    for k, (m, r) in enumerate(zip(msgs, run, strict=True)):
        m["VP"]["odo"] = round(r.odometer_m - base if k < 15 else r.odometer_m - run[15].odometer_m)
    path = tmp_path / "trips.json"
    path.write_text(json.dumps(msgs))
    log = read_hfp(path)
    assert len(log.reports) == 30
    assert [r.odometer_m for r in log.reports] == [m["VP"]["odo"] for m in msgs]
    assert [(p.line, p.kept) for p in log.problems] == [(16, True)]
    assert "odometer" in log.problems[0].reason


def test_hfp_without_speeds_derives_them_from_the_first_record_on(simulated, tmp_path):
    # a feed that never fills spd: the first record has nothing to derive a speed from;
    # it was dropped without being remembered, and so was every record after it
    run = _moving(simulated, "T02", 12)
    msgs = [_vp(r, spd=None, odo=None) for r in run]  # (from the fixes alone)
    path = tmp_path / "nospeed.json"
    path.write_text(json.dumps(msgs))
    log = read_hfp(path)
    assert [(p.line, p.kept) for p in log.problems] == [(1, False)]
    assert "spd" in log.problems[0].reason
    assert len(log.reports) == 11
    errors = [
        abs(got.speed_mps - src.speed_mps) for got, src in zip(log.reports, run[1:], strict=True)
    ]
    # (street fixes are metres off each; over 5 s the speed lags an accelerating tram)
    assert sorted(errors)[len(errors) // 2] < 2.0, errors


def test_hfp_never_makes_up_the_course_of_a_moving_tram(simulated, tmp_path):
    # hdg missing on the first records of a running tram: the course was made up as 0
    # (north) and positioning weighed it like a measured one
    # (nor derives it from one second's run: the fixes' errors are as large as the run)
    run = _moving(simulated, "T03", 12)
    msgs = [_vp(r, hdg=None) for r in run]
    path = tmp_path / "nocourse.json"
    path.write_text(json.dumps(msgs))
    log = read_hfp(path)
    dropped = len(log.problems)
    assert 1 <= dropped <= 4
    assert [(p.line, p.kept) for p in log.problems] == [(k, False) for k in range(1, dropped + 1)]
    assert all("hdg" in p.reason for p in log.problems)
    assert len(log.reports) == 12 - dropped
    offs = [
        abs((got.course_deg - src.course_deg + 180.0) % 360.0 - 180.0)
        for got, src in zip(log.reports, run[dropped:], strict=True)
    ]
    assert max(offs) < 45.0 and sorted(offs)[len(offs) // 2] < 15.0, offs


def test_hfp_csv_archive_form(simulated, tmp_path):
    rows = [_vp(r)["VP"] for r in simulated[:30]]
    path = tmp_path / "hfp.csv"
    names = ["event_type", *rows[0].keys()]
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        for k, row in enumerate(rows):
            w.writerow(["VP" if k != 4 else "ARR", *["" if v is None else v for v in row.values()]])
        w.writerow(["VP", "4", "1", "40", "9", "", "", "1.0"])  # line 32: too few fields
    assert detect_log_format(path) == "hfp"
    log = read_log(path)
    assert len(log.reports) == 29
    assert [p.line for p in log.problems] == [32]
    assert log.ignored == {"HFP ARR event (not a vehicle position)": 1}
    assert all(r.odometer_m is not None for r in log.reports)


def test_gtfs_realtime_directory_with_repeats_and_bad_entities(simulated, tmp_path):
    feed = tmp_path / "gtfsrt"
    feed.mkdir()
    by_t: dict[float, list] = {}
    for r in simulated:
        by_t.setdefault(r.t, []).append(r)
    times = sorted(by_t)[:40]
    for k, t in enumerate(times):
        vehicles = [
            {
                "id": r.vehicle_id,
                "label": f"tram {r.vehicle_id}",
                "timestamp": int(EPOCH + t),
                "lat": r.lat,
                "lon": r.lon,
                "speed": r.speed_mps,
                "bearing": r.course_deg,
                "odometer": r.odometer_m,
                "route_id": "4",
            }
            for r in by_t[t]
        ]
        if k == 3:
            vehicles.append({"id": "X9"})  # no position
        write_feed_message(feed / f"vp-{k:04d}.pb", vehicles, timestamp=int(EPOCH + t))
    # the same snapshot fetched twice, and a file that is not a feed
    (feed / "vp-0000b.pb").write_bytes((feed / "vp-0000.pb").read_bytes())
    (feed / "vp-0005x.pb").write_bytes(b"\xff\xff\xff garbage")
    assert detect_log_format(feed) == "gtfs-rt"
    log = read_gtfs_realtime(feed)
    expected = sum(len(by_t[t]) for t in times)
    assert len(log.reports) == expected
    assert log.ignored == {"repeated record time of a vehicle": len(by_t[times[0]])}
    bad = sorted((p.source.rsplit("/", 1)[-1], p.line) for p in log.problems)
    assert bad == [("vp-0003.pb", len(by_t[times[3]]) + 1), ("vp-0005x.pb", 0)]
    assert "position" in log.problems[0].reason or "position" in log.problems[1].reason
    one = log.reports[0]
    assert one.odometer_m is not None and one.fix_quality == 1
    assert read_gtfs_realtime(feed / "vp-0001.pb").reports
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputFileError, match="no GTFS-realtime files"):
        read_gtfs_realtime(tmp_path / "empty")


def test_replay_cli_reads_the_feeds(simulated, tmp_path, capsys):
    path = tmp_path / "feed.jsonl"
    path.write_text("\n".join(json.dumps(_vp(r)) for r in simulated) + "\n")
    events = tmp_path / "e.csv"
    assert main(["replay", str(path), "-o", str(events), "--map", "none"]) == 0
    out = capsys.readouterr().out
    assert "(hfp) of 3 vehicles" in out
    feed = tmp_path / "rt"
    feed.mkdir()
    for k, r in enumerate(simulated[:30]):
        write_feed_message(feed / f"{k:03d}.pb", [gtfs_vehicle(r)])
    assert main(["replay", str(feed), "-o", str(events), "--map", "none"]) == 0
    assert "(gtfs-rt)" in capsys.readouterr().out
    assert main(["replay", str(path), "--format", "gtfs-rt", "-o", str(events)]) == 2
    assert "not a GTFS-realtime FeedMessage" in capsys.readouterr().err


def test_urban_simulation_round_trips_through_the_replay_csv(tmp_path, capsys):
    out = tmp_path / "urban.csv"
    argv = ["simulate", "--map", "synthetic", "--scenario", "tunnel_dropout", "--gps", "urban"]
    assert main([*argv, "-o", str(out)]) == 0
    log = read_log(out)
    assert log.problems == [] and log.reports
    assert {r.fix_quality for r in log.reports} == {0, 1}  # no fix in the tunnel
    assert all(r.odometer_m is not None for r in log.reports)
    capsys.readouterr()
    assert main(["replay", str(out), "-o", str(tmp_path / "e.csv"), "--map", "synthetic"]) == 0
    assert "(csv) of 2 vehicles" in capsys.readouterr().out


def test_a_feed_in_km_h_is_read_with_its_speed_unit(simulated, tmp_path, capsys):
    # GTFS-realtime's speed is m/s, but some producers send km/h: --speed-unit km/h
    feed = tmp_path / "kmh"
    feed.mkdir()
    first = simulated[:20]
    for k, r in enumerate(first):
        vehicle = gtfs_vehicle(r) | {"speed": r.speed_mps * 3.6}
        write_feed_message(feed / f"{k:03d}.pb", [vehicle])
    as_m_s = read_gtfs_realtime(feed)
    in_km_h = read_gtfs_realtime(feed, speed_unit="km/h")
    assert [r.speed_mps for r in in_km_h.reports] == pytest.approx(
        [r.speed_mps for r in first], abs=1e-4
    )
    assert [r.speed_mps for r in as_m_s.reports] == pytest.approx(
        [3.6 * r.speed_mps for r in first], abs=1e-4
    )
    hfp = tmp_path / "kn.jsonl"
    hfp.write_text("\n".join(json.dumps(_vp(r, spd=r.speed_mps / 0.514444)) for r in first))
    got = read_log(hfp, speed_unit="kn").reports
    assert [r.speed_mps for r in got] == pytest.approx([r.speed_mps for r in first], abs=1e-3)
    with pytest.raises(InvalidArgumentError, match="speed_unit.*km/h"):
        read_hfp(hfp, speed_unit="furlongs per fortnight")
    events = tmp_path / "e.csv"
    args = ["replay", str(feed), "-o", str(events), "--map", "none", "--speed-unit", "km/h"]
    assert main(args) == 0
    csv_log = tmp_path / "log.csv"
    csv_log.write_text("vehicle_id,t,lat,lon,speed_mps,course_deg\nT1,0,50.06,19.94,5,90\n")
    assert main(["replay", str(csv_log), "--map", "none", "--speed-unit", "km/h"]) == 2
    assert "--speed-unit is for HFP and GTFS-realtime logs" in capsys.readouterr().err
    with pytest.raises(InvalidArgumentError, match="csv log"):
        read_log(csv_log, speed_unit="km/h")
    assert main(["match", str(csv_log), "--speed-unit", "km/h"]) == 2
    assert "--speed-unit is for HFP and GTFS-realtime logs" in capsys.readouterr().err
    # (--hfp-mode likewise, in the option's own name rather than the API's hfp_modes)
    assert main(["match", str(csv_log), "--hfp-mode", "tram"]) == 2
    assert "--hfp-mode is for HFP logs; " in capsys.readouterr().err


def test_hfp_vehicles_are_keyed_by_their_owner_not_the_trip_operator(simulated, tmp_path):
    # HFP's oper is the operator running the trip: a subcontracted trip names another
    # operator than the vehicle's owner in the topic. Keyed by oper, vehicle 18/1 split
    # at its second trip and merged with 6/1, another vehicle of the same number
    t1 = [r for r in simulated if r.vehicle_id == "T01"][:20]
    t2 = [r for r in simulated if r.vehicle_id == "T02"][:20]
    headsign = "Matinkylä (M)"  # (spaces in the topic)

    def line(owner: str, r, oper: int) -> str:
        topic = f"/hfp/v2/journey/ongoing/vp/tram/{owner}/00001/1004/1/{headsign}/08:00/1/60;19"
        return f"{topic} {json.dumps(_vp(r, oper=oper, veh=1))}"

    lines = [line("0018", r, 6 if k >= 10 else 18) for k, r in enumerate(t1)]
    lines += [line("0006", r, 6) for r in t2]
    path = tmp_path / "hfp.jsonl"
    path.write_text("\n".join(lines) + "\n")
    log = read_hfp(path)
    assert not log.problems
    assert {r.vehicle_id for r in log.reports} == {"18/1", "6/1"}
    assert sum(r.vehicle_id == "18/1" for r in log.reports) == len(t1)

    rows = [_vp(r, oper=6, veh=1)["VP"] for r in t1]
    archive = tmp_path / "hfp.csv"
    with archive.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["event_type", "owner_operator_id", "vehicle_number", *rows[0].keys()])
        for row in rows:
            w.writerow(["VP", "18", "1", *["" if v is None else v for v in row.values()]])
    assert {r.vehicle_id for r in read_log(archive).reports} == {"18/1"}


@given(
    operator=st.integers(0, 9999),
    vehicle=st.integers(0, 99999),
    rest=st.lists(st.text(st.characters(blacklist_characters="/"), max_size=8), max_size=8),
)
def test_hfp_topic_names_the_owner_and_the_vehicle(operator, vehicle, rest):
    from antikol.ingest.hfp import topic_vehicle_id

    head = ["", "hfp", "v2", "journey", "ongoing", "vp", "tram"]
    topic = "/".join([*head, f"{operator:04d}", f"{vehicle:05d}", *rest])
    assert topic_vehicle_id(topic) == f"{operator}/{vehicle}"
    v1 = "/".join(["", "hfp", "v1", "journey", "ongoing", "bus", str(operator), str(vehicle)])
    assert topic_vehicle_id(v1) == f"{operator}/{vehicle}"


@given(st.text(max_size=80))
def test_any_topic_gives_an_id_or_none(topic):
    from antikol.ingest.hfp import topic_vehicle_id

    got = topic_vehicle_id(topic)
    assert got is None or (isinstance(got, str) and got)


def test_gtfs_realtime_timestamp_0_is_no_time(tmp_path):
    # 0 is protobuf's default: a producer that leaves the field unset may still write it
    here = {"id": "A", "lat": 50.06, "lon": 19.94, "speed": 1.0, "bearing": 90.0}
    with_header = write_feed_message(tmp_path / "a.pb", [{**here, "timestamp": 0}], timestamp=5)
    assert [r.t for r in read_gtfs_realtime(with_header).reports] == [5.0]
    alone = write_feed_message(tmp_path / "b.pb", [{**here, "timestamp": 0}])
    log = read_gtfs_realtime(alone)
    assert not log.reports
    assert [(p.line, "no timestamp" in p.reason) for p in log.problems] == [(1, True)]
    too_late = write_feed_message(tmp_path / "c.pb", [{**here, "timestamp": 2**64 - 1}])
    log = read_gtfs_realtime(too_late)
    assert not log.reports
    assert "vehicle.timestamp=18446744073709551615" in log.problems[0].reason


def test_an_empty_gtfs_realtime_file_is_a_problem(simulated, tmp_path):
    empty = tmp_path / "empty.pb"
    empty.write_bytes(b"")
    log = read_gtfs_realtime(empty)
    assert [(p.line, p.source) for p in log.problems] == [(0, str(empty))]
    assert "empty" in log.problems[0].reason
    with pytest.raises(ReplayError, match=r"empty\.pb.*empty"):
        read_gtfs_realtime(empty, strict=True)
    feed = tmp_path / "rt"
    feed.mkdir()
    write_feed_message(feed / "0.pb", [gtfs_vehicle(simulated[0])])
    (feed / "1.pb").write_bytes(b"")
    log = read_gtfs_realtime(feed)
    assert len(log.reports) == 1 and [p.line for p in log.problems] == [0]
