"""Positioning checked without ground truth (issue 12: a real trace has none):
``antikol.evaluation.consistency`` and ``antikol match``."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import re

import hypothesis.strategies as st
import pytest
from hypothesis import HealthCheck, given, settings

import trackmap
from antikol import VehicleReport
from antikol.cli import main
from antikol.evaluation.consistency import (
    MatchedFix,
    TraceConsistency,
    WindowBreak,
    disconnected_windows,
    match_reports,
    trace_consistency,
    window_breaks,
)
from antikol.evaluation.positioning_accuracy import evaluate_fixes, positioning_accuracy
from antikol.positioning.records import TrackPosition
from antikol.sim import GpsModel, Simulator, fleet
from tests._feeds import EPOCH
from trackmap.synthetic import SyntheticNetwork

GAP_M = 3.8  # between the two tracks of the double track


@pytest.fixture(scope="module")
def double():
    """A north-south double track, 1 km, right-hand running: northbound at x = 3.8 m,
    southbound at x = 0."""
    board = SyntheticNetwork()
    board.track([(GAP_M, 0.0), (GAP_M, 1000.0)], oneway="yes")
    board.track([(0.0, 1000.0), (0.0, 0.0)], oneway="yes")
    net = board.build()
    north = next(e.edge_id for e in net.edges if e.geometry.coords[0][0] > 1.0)
    south = next(e.edge_id for e in net.edges if e.edge_id != north)
    return board, net, north, south


def _report(board, t, y, *, x=GAP_M, speed=10.0, course=0.0, odometer=None, vid="T1"):
    lon, lat = board.lonlat(x, y)
    return VehicleReport(vid, t, lat, lon, speed_mps=speed, course_deg=course, odometer_m=odometer)


def _placed(net, report, edge_id, direction, offset_m, *, wrong_way=False):
    x, y = net.point_at(edge_id, offset_m)
    lon, lat = net.to_lonlat(x, y)
    position = TrackPosition(
        report.vehicle_id,
        report.t,
        "confident",
        edge_id,
        direction,
        offset_m,
        float(lon),
        float(lat),
        net.heading_at(edge_id, offset_m, direction),
        report.speed_mps,
        0.99,
        2.0,
        wrong_way=wrong_way,
    )
    return MatchedFix(report, position)


def test_a_tram_running_on_its_track_is_consistent(double):
    board, net, north, _ = double
    reports = [
        _report(board, float(t), 100.0 + 10.0 * t, x=GAP_M + 1.2, odometer=5000.0 + 10.0 * t)
        for t in range(40)
    ]
    fixes = match_reports(net, reports)
    check = trace_consistency(net, fixes)
    assert [f.report for f in fixes] == reports
    assert {f.edge_id for f in fixes} == {north}
    assert check.reports == check.with_fix == check.moving_fixes == 40
    assert check.moving_way_agrees == 40 and check.moving_wrong_way == 0
    assert check.windows == 4 and check.disconnected_windows == 0
    assert check.odometer_pairs == check.odometer_agrees == 39
    assert check.odometer_rms_m < 1.0
    assert check.way_agrees_share == 1.0 and check.disconnected_share == 0.0


def test_a_jump_onto_the_other_directions_track_is_seen(double):
    """The issue's failure: a northbound tram matched onto the southbound track running
    north (wrong way) is off the course's way, and its window no permitted route connects;
    matched running south it also disagrees with the reported course."""
    board, net, north, south = double
    reports = [_report(board, float(t), 100.0 + 10.0 * t) for t in range(6)]
    fixes = [_placed(net, r, north, 1, 100.0 + 10.0 * r.t) for r in reports[:4]]
    fixes.append(_placed(net, reports[4], south, -1, 1000.0 - 140.0, wrong_way=True))
    fixes.append(_placed(net, reports[5], south, 1, 1000.0 - 150.0))
    check = trace_consistency(net, fixes)
    assert check.moving_fixes == 6 and check.moving_way_agrees == 4
    assert check.moving_wrong_way == 1
    assert check.windows == 1 and check.disconnected_windows == 1
    # windows are aligned to multiples of their length: in 2-s windows the jump at
    # t = 3 -> 4 falls between two and only the reversal at t = 4 -> 5 is seen
    assert disconnected_windows(net, fixes, window_s=2.0) == (3, 1)
    # where: the window's first unconnected pair, for an analyst to look up
    jump = WindowBreak("T1", 3.0, 4.0, north, 130.0, 1, south, 860.0, -1)
    assert check.breaks == (jump,)
    assert window_breaks(net, fixes, window_s=2.0) == [
        WindowBreak("T1", 4.0, 5.0, south, 860.0, -1, south, 850.0, 1)
    ]
    assert check.as_dict()["breaks"] == [jump.as_dict()]
    json.dumps(check.as_dict(), allow_nan=False)
    assert TraceConsistency.pooled([check, check]).breaks == (jump, jump)


@pytest.mark.parametrize("period_s", [3, 5, 10])
def test_an_odometer_read_out_every_few_seconds_is_compared_between_read_outs(double, period_s):
    """A counter read out every ``period_s`` s and repeated in between (from a phase off
    the reports' seconds): compared report by report, every repeat at 10 m/s was a
    disagreement; compared from one new reading to the next it agrees."""
    board, net, north, _ = double

    def reading(t):
        read_out = math.floor((t - 0.4) / period_s) * period_s + 0.4
        return 5000.0 + 10.0 * max(read_out, 0.0)

    reports = [_report(board, float(t), 100.0 + 10.0 * t, odometer=reading(t)) for t in range(60)]
    fixes = [_placed(net, r, north, 1, 100.0 + 10.0 * r.t) for r in reports]
    check = trace_consistency(net, fixes)
    assert check.odometer_held_vehicles == 1
    assert check.odometer_pairs >= 60 // period_s - 2
    assert check.odometer_agrees == check.odometer_pairs
    assert check.odometer_rms_m < 1.0
    # a counter read at every report is no held one
    every = [_report(board, float(t), 100.0 + 10.0 * t, odometer=5000.0 + 10.0 * t)
             for t in range(60)]  # fmt: skip
    check = trace_consistency(net, [_placed(net, r, north, 1, 100.0 + 10.0 * r.t) for r in every])
    assert check.odometer_held_vehicles == 0 and check.odometer_pairs == 59


def test_track_distance_against_the_odometer(double):
    board, net, north, _ = double
    reports = [
        _report(board, 0.0, 100.0, odometer=0.0),
        _report(board, 1.0, 110.0, odometer=10.0),  # agrees
        _report(board, 2.0, 120.0, odometer=15.0),  # 5 m short: agrees within 10 m
        _report(board, 3.0, 130.0, odometer=5.0),  # a reset: not compared
        _report(board, 4.0, 140.0, odometer=7.0),  # 8 m short
        _report(board, 5.0, 150.0, odometer=None),  # no reading
        _report(board, 6.0, 160.0, odometer=9.0),  # 10 s apart at most: compared with t=4
        _report(board, 7.0, 100.0, odometer=10.0),  # 60 m behind: out of reach
    ]
    offsets = [100.0, 110.0, 120.0, 130.0, 140.0, 150.0, 160.0, 100.0]
    fixes = [_placed(net, r, north, 1, o) for r, o in zip(reports, offsets, strict=True)]
    check = trace_consistency(net, fixes, odometer_tolerance_m=6.0)
    assert check.odometer_pairs == 5  # 0-1, 1-2, 4-6, 6-7 and 2-3 skipped as a reset
    assert check.odometer_unreachable == 1
    assert check.odometer_agrees == 2  # 0-1 (0 m) and 1-2 (5 m); 4-6 is 18 m over
    residuals = [0.0, 5.0, 18.0]  # 2-3 is a reset; 3-4 compared: 10 - 2 = 8 m over
    assert check.odometer_pairs == len(residuals) + 1 + check.odometer_unreachable
    squares = [*residuals, 8.0]
    expected_rms = math.sqrt(sum(r * r for r in squares) / len(squares))
    assert check.odometer_rms_m == pytest.approx(expected_rms)


def test_pooled_vehicles_equal_one_check_of_all(double):
    board, net, *_ = double
    reports = []
    for vid, start in (("A", 100.0), ("B", 500.0)):
        reports += [
            _report(board, float(t), start + 8.0 * t, odometer=8.0 * t, vid=vid) for t in range(25)
        ]
    fixes = match_reports(net, reports)
    whole = trace_consistency(net, fixes)
    parts = [
        trace_consistency(net, [f for f in fixes if f.vehicle_id == vid]) for vid in ("A", "B")
    ]
    pooled = TraceConsistency.pooled(parts)
    for name in ("vehicles", "reports", "moving_way_agrees", "windows", "odometer_agrees"):
        assert getattr(pooled, name) == getattr(whole, name)
    assert pooled.odometer_rms_m == pytest.approx(whole.odometer_rms_m)
    with pytest.raises(ValueError, match="nothing"):
        TraceConsistency.pooled([])
    document = whole.as_dict()
    assert json.loads(json.dumps(document, allow_nan=False)) == document


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["A", "B"]),
            st.integers(0, 30).map(float),
            st.floats(-30.0, 30.0),  # x, m
            st.floats(-50.0, 1050.0),  # y, m
            st.floats(0.0, 20.0),  # speed, m/s
            st.floats(0.0, 359.9),  # course, deg
            st.none() | st.floats(0.0, 2000.0),  # odometer, m
        ),
        max_size=40,
    )
)
def test_any_reports_get_one_position_each_and_coherent_counts(double, rows):
    board, net, *_ = double
    reports = [
        _report(board, t, y, x=x, speed=v, course=c, odometer=o, vid=vid)
        for vid, t, x, y, v, c, o in rows
    ]
    fixes = match_reports(net, reports)
    assert sorted(map(id, (f.report for f in fixes))) == sorted(map(id, reports))
    assert [f.t for f in fixes] == sorted(r.t for r in reports)
    c = trace_consistency(net, fixes)
    assert c.confident + c.ambiguous + c.lost + c.unmatched == c.reports == len(reports)
    assert c.moving_way_agrees <= c.moving_matched <= c.moving_fixes <= c.with_fix
    assert c.disconnected_windows <= c.windows
    assert c.odometer_agrees + c.odometer_unreachable <= c.odometer_pairs


@pytest.fixture(scope="module")
def kraków_run():
    net = trackmap.load_default()
    result = Simulator(net, fleet(net, 4, 11), gps=GpsModel.urban(), seed=11).run(180.0)
    return net, result


def test_the_checks_need_no_truth(kraków_run):
    """The window rule gives the same count with and without the simulator's truth on
    the same reports (the truth judges no report of a tram's first metres), and the
    course's way follows the true way."""
    net, result = kraków_run
    judged = evaluate_fixes(net, result)
    fixes = match_reports(net, result.reports)
    keys = {(e.vehicle_id, e.t) for e in judged}
    same = [f for f in fixes if (f.vehicle_id, f.t) in keys]
    assert len(same) == len(judged) and len(fixes) >= len(judged)
    windows, broken = disconnected_windows(net, same)
    assert windows >= 60
    assert (windows, broken) == disconnected_windows(net, judged)
    check = trace_consistency(net, fixes)
    truth = positioning_accuracy(net, result)
    assert check.odometer_pairs > 0.9 * check.reports
    assert check.odometer_agrees_share > 0.95
    assert abs(check.way_agrees_share - truth.right_way_share) < 0.02


def _hfp_line(r) -> str:
    fields = {
        "oper": 40,
        "veh": int(r.vehicle_id[1:]),
        "tsi": round(EPOCH + r.t, 3),
        "lat": round(r.lat, 7),
        "long": round(r.lon, 7),
        "spd": round(r.speed_mps, 2),
        "hdg": round(r.course_deg),
        "odo": None if r.odometer_m is None else round(r.odometer_m),
        "loc": "GPS" if r.fix_quality != 0 else "ODO",
    }
    return json.dumps({"VP": fields})


def test_antikol_match_on_an_hfp_log(kraków_run, tmp_path, capsys):
    _, result = kraków_run
    log = tmp_path / "hfp.jsonl"
    lines = [_hfp_line(r) for r in result.reports]
    lines.insert(5, '{"VP": {"oper": 40, "veh": 1, "tsi": "soon", "lat": 50.0, "long": 19.9}}')
    log.write_text("\n".join(lines) + "\n", encoding="utf-8")
    out_csv, out_json = tmp_path / "positions.csv", tmp_path / "checks.json"
    assert (
        main(["match", str(log), "--map", "default", "-o", str(out_csv), "--json", str(out_json)])
        == 0
    )
    captured = capsys.readouterr()
    assert "hfp.jsonl:6: tsi='soon' is not a number" in captured.err
    assert "outside the map" not in captured.err
    assert f"matched {len(result.reports):,} reports of 4 vehicle(s)" in captured.out
    assert "(1 record(s) rejected)" in captured.out
    assert "running the reported course's way" in captured.out
    with out_csv.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(result.reports)
    assert {row["vehicle_id"] for row in rows} == {"40/1", "40/2", "40/3", "40/4"}
    matched = [row for row in rows if row["status"] in ("confident", "ambiguous")]
    assert len(matched) > 0.95 * len(rows)
    assert all(row["edge_id"] and row["track_lat"] for row in matched)
    # every report also where the whole log puts it, checked the same way, every one
    # counted by status
    line = next(x for x in captured.out.splitlines() if x.startswith("in hindsight"))
    counts = re.findall(r"(confident|ambiguous|lost|unmatched) ([\d,]+)", line)
    assert [k for k, _ in counts] == ["confident", "ambiguous", "lost", "unmatched"]
    assert sum(int(n.replace(",", "")) for _, n in counts) == len(result.reports)
    later = [row for row in rows if row["hindsight_status"] in ("confident", "ambiguous")]
    assert len(later) >= len(matched)
    assert all(row["hindsight_edge_id"] and row["hindsight_track_lat"] for row in later)
    document = json.loads(out_json.read_text(encoding="utf-8"))
    assert document["hindsight"]["total"]["reports"] == len(result.reports)
    assert (
        document["hindsight"]["total"]["disconnected_windows"]
        <= document["total"]["disconnected_windows"]
    )
    assert document["records_rejected"] == 1
    assert len(document["total"]["breaks"]) == document["total"]["disconnected_windows"]
    assert document["total"]["reports"] == len(result.reports)
    assert sorted(document["vehicles"]) == ["40/1", "40/2", "40/3", "40/4"]
    assert sum(v["reports"] for v in document["vehicles"].values()) == len(result.reports)


def test_a_log_of_another_city_is_named_as_off_the_map(kraków_run, tmp_path, capsys):
    """The log of a tram in Helsinki matched on the default map (``--map`` forgotten) is
    not just a count of unmatched reports: both commands say the fixes lie off the map."""
    _, result = kraków_run
    log = tmp_path / "helsinki.jsonl"
    moved = [
        dataclasses.replace(r, lat=r.lat + 10.1, lon=r.lon + 5.0)
        for r in result.reports
        if r.fix_quality != 0
    ]
    log.write_text("\n".join(_hfp_line(r) for r in moved) + "\n", encoding="utf-8")
    assert main(["match", str(log), "-o", str(tmp_path / "positions.csv")]) == 0
    captured = capsys.readouterr()
    assert f"{len(moved):,} of {len(moved):,} fixes lie more than 2 km outside the map" in (
        captured.err
    )
    assert "--map" in captured.err
    # the log has odometer readings, but nothing was matched to compare them with
    assert "odometer: none in the log" not in captured.out
    assert "odometer: in the log, but" in captured.out
    events = tmp_path / "events.csv"
    assert main(["replay", str(log), "--map", "default", "-o", str(events)]) == 0
    assert "outside the map 'default'" in capsys.readouterr().err


def test_antikol_match_says_what_is_wrong(tmp_path, capsys):
    log = tmp_path / "hfp.jsonl"
    fields = {"oper": 40, "veh": 1, "tsi": 1, "lat": 50.06, "long": 19.94, "spd": 0, "hdg": 0}
    log.write_text(json.dumps({"VP": fields}) + "\n", encoding="utf-8")
    assert main(["match", str(log), "--map", "none"]) == 2
    assert "needs a track map" in capsys.readouterr().err
    assert main(["match", str(tmp_path / "missing.jsonl")]) == 2
    assert "missing.jsonl" in capsys.readouterr().err
    bad_out = tmp_path / "no-such-dir" / "positions.csv"
    assert main(["match", str(log), "-o", str(bad_out)]) == 2
    assert "no-such-dir" in capsys.readouterr().err


@pytest.mark.parametrize("fault", ["reversed", "zero"])
def test_a_course_unrelated_to_the_run_is_reported(double, fault):
    """A feed whose course is reversed or stuck at 0 (on a line running north and south
    alike) is told apart from the matching: its chords are off, vehicle by vehicle."""
    board, net, _, _ = double
    north = [_report(board, float(t), 100.0 + 10.0 * t, vid="N") for t in range(30)]
    south = [
        _report(board, float(t), 900.0 - 10.0 * t, x=0.0, course=180.0, vid="S") for t in range(30)
    ]
    good = trace_consistency(net, match_reports(net, north + south))
    assert good.course_chords >= 20 and good.course_chords_off == 0
    assert good.course_off_vehicles == 0
    bad_course = {"reversed": lambda c: (c + 180.0) % 360.0, "zero": lambda c: 0.0}[fault]
    faulty = [
        VehicleReport(r.vehicle_id, r.t, r.lat, r.lon, r.speed_mps, bad_course(r.course_deg))
        for r in north + south
    ]
    check = trace_consistency(net, match_reports(net, faulty))
    assert check.course_chords == good.course_chords
    off_vehicles = {"reversed": 2, "zero": 1}[fault]  # stuck at 0 is right running north
    assert check.course_off_vehicles == off_vehicles
    assert check.course_chords_off == off_vehicles * good.course_chords // 2
    pooled = TraceConsistency.pooled([check, good])
    assert pooled.course_off_vehicles == off_vehicles


def test_antikol_match_says_when_the_course_is_off(kraków_run, tmp_path, capsys):
    _, result = kraków_run
    log = tmp_path / "hfp.jsonl"
    reversed_course = (
        VehicleReport(
            r.vehicle_id, r.t, r.lat, r.lon, r.speed_mps, (r.course_deg + 180.0) % 360.0,
            odometer_m=r.odometer_m, fix_quality=r.fix_quality,
        )
        for r in result.reports
    )  # fmt: skip
    log.write_text("\n".join(_hfp_line(r) for r in reversed_course) + "\n", encoding="utf-8")
    assert main(["match", str(log), "-o", str(tmp_path / "positions.csv")]) == 0
    out = capsys.readouterr().out
    assert "course off: 4 of 4 vehicles" in out
    assert "chords off by 60 degrees or more" in out


def test_antikol_match_says_where_the_windows_break():
    from antikol.cli.match import _SHOWN_BREAKS, _where_broken

    unix = WindowBreak("40/8", 1_700_000_361.0, 1_700_000_362.0, 219, 21.25, 1, 373, 2245.1, 1)
    lines = _where_broken([unix])
    assert lines[1].strip() == (
        "40/8 2023-11-14T22:19:21Z -> 2023-11-14T22:19:22Z: edge 219 21.2 m (+1) "
        "-> edge 373 2245.1 m (+1)"
    )
    simulated = WindowBreak("T09", 495.0, 496.0, 379, 66.7, 1, 383, 75.4, -1)
    assert (
        "T09 t=495.0 s -> t=496.0 s: edge 379 66.7 m (+1) -> edge 383 75.4 m (-1)"
        in (_where_broken([simulated])[1])
    )
    many = _where_broken([simulated] * (_SHOWN_BREAKS + 5))
    assert len(many) == 1 + _SHOWN_BREAKS and "all of them in --json" in many[0]
    assert _where_broken([]) == []
