"""A feed's course that is wrong all along is found out and ignored (issue 12).

Positioning weighs the reported course to tell the two tracks of a double track apart. A
feed that reports a bidirectional tram's heading of its other end (180 degrees off), 0
where it has no heading, or a bearing counter-clockwise from east, put trams on the other
direction's track: on a simulated street fleet with a reversed course, 60-79 % of the
moving fixes on double track were on the right track and hundreds of confident positions
were wrong. Each vehicle's course is now checked against the chords of its own fixes.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol.errors import InvalidArgumentError
from antikol.evaluation.positioning_accuracy import evaluate_fixes
from antikol.positioning import PositioningConfig
from antikol.positioning.coursecheck import (
    CourseUse,
    check_courses,
    course_evidence,
    restart_doubted,
)
from antikol.positioning.fleet import FleetState
from antikol.positioning.latency import forget_latency, learn_latency
from antikol.sim import GpsModel, Simulator, fleet
from antikol.sim.urban_gps import COURSE_FAULTS, course_with_fault

CONFIG = PositioningConfig()


def _row() -> FleetState:
    f = FleetState(k=4)
    f.grow(1)
    return f


def _step(
    f: FleetState,
    t: float,
    speed: float,
    x: float,
    y: float,
    course: float,
    config: PositioningConfig = CONFIG,
    stats: Counter[str] | None = None,
) -> float:
    """The course weighed for one report (NaN: none)."""
    checked = check_courses(
        f, config, [None], np.array([0]), np.array([t]), np.array([speed]),
        np.array([x]), np.array([y]), np.array([course % 360.0]), stats,
    )  # fmt: skip
    used = restart_doubted(f, checked, stats)
    return float(used[0])


def _path(speed: float, turn_deg_s: float, heading0: float, n: int) -> tuple[list, list, list]:
    """Positions (m) and headings (degrees) at 1 Hz of a run at constant speed and turn rate."""
    xs, ys, hs = [0.0], [0.0], [heading0]
    for _ in range(n - 1):
        mid = math.radians(hs[-1] + 0.5 * turn_deg_s)  # exact chord of a circular arc
        half_turn = math.radians(abs(turn_deg_s)) / 2
        chord = speed if half_turn < 1e-9 else speed * math.sin(half_turn) / half_turn
        xs.append(xs[-1] + chord * math.sin(mid))
        ys.append(ys[-1] + chord * math.cos(mid))
        hs.append(hs[-1] + turn_deg_s)
    return xs, ys, hs


@settings(max_examples=60, deadline=None)
@given(
    speed=st.floats(3.0, 20.0),
    turn=st.floats(-8.0, 8.0),
    heading0=st.floats(0.0, 360.0),
    bias=st.tuples(st.floats(-10.0, 10.0), st.floats(-10.0, 10.0)),
    seed=st.integers(0, 2**16),
)
def test_a_right_course_is_always_believed(speed, turn, heading0, bias, seed):
    # fixes within 1.5 m of the truth plus any steady bias, a course within 4 degrees
    rng = np.random.default_rng(seed)
    f = _row()
    xs, ys, hs = _path(speed, turn, heading0, 60)
    for k, (x, y, h) in enumerate(zip(xs, ys, hs, strict=True)):
        nx, ny = rng.uniform(-1.5, 1.5, 2)
        course = (h + rng.uniform(-4.0, 4.0)) % 360.0
        assert _step(f, float(k), speed, x + bias[0] + nx, y + bias[1] + ny, course) == course
    assert f.qe[0] > 0.0  # the chords were tested, and agreed


@pytest.mark.parametrize("fault", ["reversed", "zero", "ccw_from_east"])
@pytest.mark.parametrize("heading", [100.0, 200.0, 290.0])
def test_a_wrong_course_is_ignored_within_60_m_and_a_reversed_one_turned(fault, heading):
    f = _row()
    f.hs[0, 0] = 7  # a placement made with the course
    xs, ys, hs = _path(10.0, 0.0, heading, 30)
    courses = course_with_fault(np.array(hs) % 360.0, fault)
    stats: Counter[str] = Counter()
    used = [
        _step(f, float(k), 10.0, x, y, c, stats=stats)
        for k, (x, y, c) in enumerate(zip(xs, ys, courses, strict=True))
    ]
    first = next(k for k, (u, c) in enumerate(zip(used, courses, strict=True)) if u != c)
    assert 10.0 * first <= 60.0
    assert math.isnan(used[first])
    assert f.hs[0, 0] == -1  # started afresh without the course's evidence
    assert stats["course_doubted"] == 1
    if fault == "reversed":  # turned round from the next chord: the right course again
        turned = next(k for k in range(first, len(used)) if not math.isnan(used[k]))
        assert 10.0 * (turned - first) <= 30.0
        assert used[turned:] == pytest.approx([heading] * (len(used) - turned))
        assert f.qn[0] == CourseUse.TURNED
    else:  # ignored, or turned round where that comes near (stuck at 0 running 200)
        assert all(
            math.isnan(u) or abs((u - heading + 180.0) % 360.0 - 180.0) <= 30.0
            for u in used[first:]
        )
    assert stats["course_ignored"] + stats["course_turned"] == len(used) - first


def test_a_bidirectional_trams_course_is_followed_through_each_change_of_end():
    # driven from its front (right), from its other end (reversed), from its front again
    f = _row()
    stats: Counter[str] = Counter()
    legs = [(0.0, 0.0), (180.0, 0.0), (0.0, 0.0)]  # course offset, per leg of 40 s east
    used = []
    for leg, (offset, _) in enumerate(legs):
        f.hs[0, 0] = 7
        for k in range(40):
            t = 100.0 * leg + k  # a layover of 60 s between the legs
            used.append(_step(f, t, 10.0, 10.0 * (40 * leg + k), 0.0, 90.0 + offset, stats=stats))
        assert used[-1] == 90.0  # the right course, after each change
    assert stats["course_doubted"] == 2  # the right course, then the turned one, ended
    assert sum(math.isnan(u) for u in used) <= 6  # a chord or two each change
    assert f.qn[0] == CourseUse.BELIEVED


def test_a_standing_receivers_course_is_no_test():
    # a standing receiver's course is random and its fixes wander with the bias
    rng = np.random.default_rng(3)
    f = _row()
    for k in range(200):
        x, y = rng.normal(0.0, 12.0, 2)
        course = rng.uniform(0.0, 360.0)
        assert _step(f, float(k), 0.2, x, y, course) == course
    assert f.qe[0] == 0.0


def test_a_course_right_on_some_headings_is_believed_there_and_restarts_once():
    # stuck at 0: wrong running east, right running north
    f = _row()
    f.hs[0, 0] = 7
    east = [_step(f, float(k), 10.0, 10.0 * k, 0.0, 0.0) for k in range(20)]
    assert math.isnan(east[-1]) and f.hs[0, 0] == -1
    f.hs[0, 0] = 7
    north = [_step(f, 20.0 + k, 10.0, 200.0, 10.0 * k, 0.0) for k in range(40)]
    assert north[-1] == 0.0  # believed again where it agrees
    again = [_step(f, 60.0 + k, 10.0, 200.0 + 10.0 * k, 400.0, 0.0) for k in range(20)]
    assert math.isnan(again[-1])
    assert f.hs[0, 0] == 7  # doubted again: no second restart


def test_the_check_can_be_switched_off():
    f = _row()
    off = PositioningConfig(course_check=0)
    assert all(_step(f, float(k), 10.0, 10.0 * k, 0.0, 270.0, off) == 270.0 for k in range(30))
    assert math.isnan(f.qt[0])
    with pytest.raises(InvalidArgumentError, match="course_check"):
        PositioningConfig(course_check=2)


def test_evidence_is_positive_near_and_floored_far():
    sigma = np.full(4, 15.0)
    ev = course_evidence(np.array([0.0, 15.0, 60.0, 180.0]), sigma)
    assert ev[0] > ev[1] > 0.0 > ev[2] >= ev[3] == pytest.approx(math.log(0.2))


def test_a_doubted_course_forgets_the_latency_it_taught():
    f = _row()
    rows = np.array([0])
    for k in range(60):  # the fixes 2 s behind at changing speeds
        v = 5.0 + 10.0 * (k % 10) / 9
        learn_latency(f, rows, np.array([v]), np.array([10.0 * k]), np.array([10.0 * k - 2 * v]),
                      np.array([3.0]), np.array([k == 0]), prior=(0.0, 1.0),
                      offset_rate_m2_s=0.2, dt_s=np.array([1.0]))  # fmt: skip
    assert f.lt[0] == pytest.approx(2.0, abs=0.3)
    forget_latency(f, rows)
    got = learn_latency(f, rows, np.array([5.0]), np.array([0.0]), np.array([0.0]),
                        np.array([3.0]), np.array([True]), prior=(0.0, 1.0),
                        offset_rate_m2_s=0.2, dt_s=np.array([1.0]))  # fmt: skip
    assert got[0] == 0.0


@given(course=st.floats(0.0, 359.99), fault=st.sampled_from(COURSE_FAULTS))
def test_simulated_course_faults(course, fault):
    got = course_with_fault(np.array([course]), fault)
    assert 0.0 <= got[0] < 360.0
    if fault in ("reversed", "ccw_from_east"):  # each is its own inverse
        back = course_with_fault(got, fault)[0]
        assert abs((back - course + 180.0) % 360.0 - 180.0) < 1e-9
    if fault == "zero":
        assert got[0] == 0.0


def test_an_unknown_course_fault_is_refused():
    with pytest.raises(ValueError, match="course_fault"):
        GpsModel.urban(course_fault="sideways")


@pytest.fixture(scope="module")
def krakow():
    return trackmap.load_default()


def _double_track_right(net, fault: str, seed: int, check: int) -> tuple[float, int]:
    result = Simulator(
        net, fleet(net, 4, seed), gps=GpsModel.urban(course_fault=fault), seed=seed,
        default_speed_mps=70 / 3.6,
    ).run(240.0)  # fmt: skip
    judged = evaluate_fixes(net, result, config=PositioningConfig(course_check=check))
    moving = [e for e in judged if e.double_track and e.moving]
    wrong = sum(e.status == "confident" and not e.right_track for e in judged)
    return sum(e.right_track for e in moving) / len(moving), wrong


@pytest.mark.parametrize("seed", [1, 2])
def test_a_street_fleet_with_a_reversed_course_stays_on_its_tracks(krakow, seed):
    right, confident_wrong = _double_track_right(krakow, "reversed", seed, check=1)
    unchecked, unchecked_wrong = _double_track_right(krakow, "reversed", seed, check=0)
    assert right >= 0.95
    assert unchecked < 0.85  # what it was: the other direction's track
    assert confident_wrong < unchecked_wrong / 5


def test_a_right_course_changes_nothing(krakow):
    checked = _double_track_right(krakow, "none", 1, check=1)
    assert checked == _double_track_right(krakow, "none", 1, check=0)
    assert checked[0] == 1.0


def test_antikol_simulate_writes_a_faulty_course(tmp_path, capsys):
    from antikol.cli import main
    from antikol.ingest.replaylog import read_replay_csv

    base = ["simulate", "--trams", "2", "--minutes", "1", "--gps", "urban", "--seed", "3"]
    good, bad = tmp_path / "good.csv", tmp_path / "reversed.csv"
    assert main([*base, "-o", str(good)]) == 0
    assert main([*base, "--course-fault", "reversed", "-o", str(bad)]) == 0
    pairs = list(zip(read_replay_csv(good).reports, read_replay_csv(bad).reports, strict=True))
    assert pairs and all(
        abs((b.course_deg - a.course_deg) % 360.0 - 180.0) < 1e-6
        and (a.lat, a.lon) == (b.lat, b.lon)
        for a, b in pairs
    )
    assert main(["simulate", "--course-fault", "zero", "-o", str(tmp_path / "x.csv")]) == 2
    assert "--gps urban" in capsys.readouterr().err
