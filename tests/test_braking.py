"""Tests of the braking and warning model (antikol.analysis.braking)."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from antikol.analysis.braking import (
    classify,
    conflict_distance,
    effective_deceleration,
    emergency_distance,
    head_on_distance,
    horizon_m,
    margin_distance,
    reaction_distance,
    rear_end_distance,
    static_obstacle_distance,
    stopping_distance,
    time_to_collision,
    warning_distance,
)
from antikol.analysis.profiles import G_MPS2, BrakingProfile, load_profile, profile_names
from antikol.atp import (
    MovementAuthority,
    movement_authority,
    permitted_speed,
    permitted_speed_curve,
    supervise,
)
from antikol.errors import InputFileError, ProfileError
from antikol.kinds import LEVELS, level_rank, max_level

TRAM = BrakingProfile()
SHIPPED = {name: load_profile(name) for name in profile_names()}
KMH = 1 / 3.6

# --------------------------------------------------------------------------------------
# Strategies
# --------------------------------------------------------------------------------------

speeds = st.floats(0.0, 50.0, allow_nan=False)
positive_speeds = st.floats(0.1, 50.0, allow_nan=False)
shipped = st.sampled_from(sorted(SHIPPED.values(), key=lambda p: p.name))
brakes = st.sampled_from(["service", "emergency"])
leader_states = st.sampled_from(["none", "service", "emergency"])
kinds = st.sampled_from(["rear_end", "head_on", "static"])


@st.composite
def profiles(draw: st.DrawFn) -> BrakingProfile:
    """Any valid profile, not only the shipped ones."""
    service = draw(st.floats(0.3, 3.0))
    service_buildup = draw(st.floats(0.0, 3.0))
    return BrakingProfile(
        name="random",
        traction_mps2=draw(st.floats(0.1, 3.0)),
        service_decel_mps2=service,
        emergency_decel_mps2=draw(st.floats(service, 4.0)),
        reaction_time_s=draw(st.floats(0.0, 2.0)),
        service_buildup_s=service_buildup,
        emergency_buildup_s=draw(st.floats(0.0, service_buildup)),
        standstill_margin_m=draw(st.floats(0.0, 20.0)),
        margin_k0_m=draw(st.floats(0.0, 10.0)),
        margin_k1_s=draw(st.floats(0.0, 1.0)),
        margin_k2_s2_per_m=draw(st.floats(0.0, 0.05)),
        max_speed_mps=draw(st.floats(1.0, 50.0)),
        max_grade=draw(st.floats(0.0, 0.9 * service / G_MPS2)),
    )


def grades_for(profile: BrakingProfile) -> st.SearchStrategy[float]:
    """Grades from 10 % uphill to the profile's steepest downhill grade."""
    return st.floats(-0.10, profile.max_grade)


# --------------------------------------------------------------------------------------
# Hand-computed values
# --------------------------------------------------------------------------------------


def test_tram_50_kmh_service_stopping_distance_by_hand() -> None:
    v = 50 / 3.6  # 13.889 m/s
    # v·t1 + v²/(2·a) + s0 with t1 = 0.5 s, a = 1.2 m/s², s0 = 5 m
    expected = v * 0.5 + v**2 / (2 * 1.2) + 5.0  # 6.944 + 80.376 + 5
    assert expected == pytest.approx(92.320, abs=1e-3)
    assert stopping_distance(v, TRAM) == pytest.approx(expected, rel=1e-12)


def test_tram_50_kmh_emergency_stopping_distance_by_hand() -> None:
    v = 50 / 3.6
    # t1 = 0.3 s, a = 2.8 m/s², s0 = 5 m
    expected = v * 0.3 + v**2 / (2 * 2.8) + 5.0  # 4.167 + 34.447 + 5
    assert expected == pytest.approx(43.613, abs=1e-3)
    assert stopping_distance(v, TRAM, brake="emergency") == pytest.approx(expected, rel=1e-12)


def test_tram_50_kmh_warning_and_emergency_distance_by_hand() -> None:
    v = 50 / 3.6
    reaction = v * 1.0  # 13.889
    service_stop = v * 0.5 + v**2 / (2 * 1.2) + 5.0  # 92.320
    margin = 2.0 + 0.2 * v + 0.005 * v**2  # 2 + 2.778 + 0.965 = 5.742
    assert warning_distance(v, TRAM) == pytest.approx(reaction + service_stop + margin)
    assert warning_distance(v, TRAM) == pytest.approx(111.951, abs=1e-3)
    assert reaction_distance(v, TRAM) == pytest.approx(13.889, abs=1e-3)
    assert margin_distance(v, TRAM) == pytest.approx(5.742, abs=1e-3)
    emergency_stop = v * 0.3 + v**2 / (2 * 2.8) + 5.0
    assert emergency_distance(v, TRAM) == pytest.approx(reaction + emergency_stop)
    assert emergency_distance(v, TRAM) == pytest.approx(57.502, abs=1e-3)


def test_downhill_grade_by_hand() -> None:
    v = 50 / 3.6
    a_eff = 1.2 - 9.80665 * 0.04  # 0.807734 m/s² on a 4 % downhill
    expected = v * 0.5 + v**2 / (2 * a_eff) + 5.0
    assert expected == pytest.approx(131.354, abs=1e-3)
    assert stopping_distance(v, TRAM, grade=0.04) == pytest.approx(expected, rel=1e-12)
    assert effective_deceleration(TRAM, brake="service", grade=0.04) == pytest.approx(a_eff)


def test_standstill_is_s0() -> None:
    for profile in SHIPPED.values():
        for brake in ("service", "emergency"):
            assert stopping_distance(0.0, profile, brake=brake) == profile.standstill_margin_m


def test_scalars_give_floats_and_arrays_give_arrays() -> None:
    v = np.array([0.0, 5.0, 10.0, 20.0])
    out = stopping_distance(v, TRAM, brake="emergency", grade=-0.02)
    assert isinstance(out, np.ndarray)
    assert out.shape == v.shape
    for vi, di in zip(v, out, strict=True):
        single = stopping_distance(float(vi), TRAM, brake="emergency", grade=-0.02)
        assert isinstance(single, float)
        assert di == pytest.approx(single)
    pair = rear_end_distance(v, v[::-1].copy(), TRAM)
    assert isinstance(pair, np.ndarray)
    assert isinstance(head_on_distance(3.0, 4.0, TRAM), float)
    assert isinstance(horizon_m(np.array([1.0, 30.0]), TRAM), np.ndarray)


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf")])
def test_bad_speed_is_rejected(bad: float) -> None:
    with pytest.raises(ValueError, match="v_mps"):
        stopping_distance(bad, TRAM)
    with pytest.raises(ValueError, match="v_mps"):
        stopping_distance(np.array([1.0, bad]), TRAM)


def test_unknown_brake_is_rejected() -> None:
    with pytest.raises(ValueError, match="brake"):
        stopping_distance(10.0, TRAM, brake="parking")  # type: ignore[arg-type]


def test_grade_too_steep_for_the_brake_names_grade() -> None:
    too_steep = 1.2 / 9.80665 + 0.001  # service brake of a tram cannot hold it
    with pytest.raises(ProfileError, match="grade"):
        stopping_distance(10.0, TRAM, grade=too_steep)
    with pytest.raises(ProfileError, match="grade"):
        warning_distance(10.0, TRAM, grade=too_steep)
    with pytest.raises(ProfileError, match="grade"):
        stopping_distance(10.0, TRAM, grade=float("nan"))
    # the emergency brake still holds the vehicle there
    assert stopping_distance(10.0, TRAM, brake="emergency", grade=too_steep) > 0


# --------------------------------------------------------------------------------------
# Properties of the distances
# --------------------------------------------------------------------------------------


@given(profile=profiles(), brake=brakes, data=st.data())
def test_stopping_distance_grows_with_speed(
    profile: BrakingProfile, brake: str, data: st.DataObject
) -> None:
    grade = data.draw(grades_for(profile))
    v1 = data.draw(speeds)
    v2 = data.draw(st.floats(v1 + 0.01, 60.0))
    d1 = stopping_distance(v1, profile, brake=brake, grade=grade)  # type: ignore[arg-type]
    d2 = stopping_distance(v2, profile, brake=brake, grade=grade)  # type: ignore[arg-type]
    assert d2 > d1
    assert warning_distance(v2, profile, grade=grade) > warning_distance(v1, profile, grade=grade)


@given(profile=shipped, brake=brakes, v=positive_speeds, data=st.data())
def test_downhill_longer_uphill_shorter(
    profile: BrakingProfile, brake: str, v: float, data: st.DataObject
) -> None:
    grade = data.draw(st.floats(0.001, profile.max_grade))
    level = stopping_distance(v, profile, brake=brake)  # type: ignore[arg-type]
    down = stopping_distance(v, profile, brake=brake, grade=grade)  # type: ignore[arg-type]
    up = stopping_distance(v, profile, brake=brake, grade=-grade)  # type: ignore[arg-type]
    assert up < level < down


@given(profile=shipped, v=positive_speeds, data=st.data())
def test_emergency_shorter_than_service(
    profile: BrakingProfile, v: float, data: st.DataObject
) -> None:
    grade = data.draw(grades_for(profile))
    assert stopping_distance(v, profile, brake="emergency", grade=grade) < stopping_distance(
        v, profile, brake="service", grade=grade
    )


@given(profile=profiles(), v=speeds, data=st.data())
def test_emergency_level_never_beyond_warning_level(
    profile: BrakingProfile, v: float, data: st.DataObject
) -> None:
    grade = data.draw(grades_for(profile))
    assert emergency_distance(v, profile, grade=grade) <= warning_distance(v, profile, grade=grade)
    assert warning_distance(v, profile, grade=grade) <= horizon_m(v, profile, grade=grade)


@given(
    own=profiles(),
    other=profiles(),
    kind=kinds,
    leader=leader_states,
    v=speeds,
    v_other=speeds,
    data=st.data(),
)
def test_conflict_levels_are_ordered(
    own: BrakingProfile,
    other: BrakingProfile,
    kind: str,
    leader: str,
    v: float,
    v_other: float,
    data: st.DataObject,
) -> None:
    limit = min(own.max_grade, other.max_grade)
    grade = data.draw(st.floats(-limit, limit))
    kwargs = {
        "kind": kind,
        "v_other_mps": v_other,
        "other_profile": other,
        "leader_braking": leader,
        "grade": grade,
    }
    emergency_m = conflict_distance(v, own, brake="emergency", **kwargs)  # type: ignore[arg-type]
    warning_m = conflict_distance(v, own, brake="service", **kwargs)  # type: ignore[arg-type]
    assert emergency_m <= warning_m
    gap_small = data.draw(st.floats(-10.0, 3000.0))
    gap_large = data.draw(st.floats(gap_small, 3000.0))
    small = classify(gap_small, v, own, **kwargs)  # type: ignore[arg-type]
    large = classify(gap_large, v, own, **kwargs)  # type: ignore[arg-type]
    assert level_rank(small) >= level_rank(large)
    if gap_small <= emergency_m:
        assert small == "emergency"


@given(follower=profiles(), leader=profiles(), state=leader_states, data=st.data())
def test_rear_end_never_below_s0_and_ordered_by_leader_state(
    follower: BrakingProfile, leader: BrakingProfile, state: str, data: st.DataObject
) -> None:
    grade = data.draw(st.floats(-0.05, min(follower.max_grade, leader.max_grade)))
    v_f = data.draw(speeds)
    v_l = data.draw(speeds)
    brake = data.draw(brakes)
    d = {
        s: rear_end_distance(v_f, v_l, follower, leader, leader_braking=s, brake=brake, grade=grade)  # type: ignore[arg-type]
        for s in ("none", "service", "emergency")
    }
    assert min(d.values()) >= follower.standstill_margin_m
    # a braking leader can only make the required gap larger
    assert d["none"] <= d["service"] <= d["emergency"]
    # a leader in emergency braking is a standing obstacle
    static = static_obstacle_distance(v_f, follower, brake=brake, grade=grade)  # type: ignore[arg-type]
    assert d["emergency"] == pytest.approx(static)


def test_rear_end_by_hand() -> None:
    v_f, v_l = 15.0, 10.0
    follower_warning = 15.0 * 1.0 + (15.0 * 0.5 + 15.0**2 / 2.4 + 5.0) + (2 + 3.0 + 1.125)
    leader_travel = 10.0 * 0.3 + 10.0**2 / 5.6  # leader may start an emergency stop now
    assert rear_end_distance(v_f, v_l, TRAM) == pytest.approx(follower_warning - leader_travel)
    leader_braking_travel = 10.0**2 / 5.6  # already braking: no build-up credited
    assert rear_end_distance(v_f, v_l, TRAM, leader_braking="service") == pytest.approx(
        follower_warning - leader_braking_travel
    )
    # a fast leader pulling away: only s0 is required
    assert rear_end_distance(5.0, 20.0, TRAM) == 5.0


@given(p1=shipped, p2=shipped, v1=speeds, v2=speeds, brake=brakes, grade=st.floats(-0.04, 0.04))
def test_head_on_is_both_distances_and_mirror_symmetric(
    p1: BrakingProfile, p2: BrakingProfile, v1: float, v2: float, brake: str, grade: float
) -> None:
    d12 = head_on_distance(v1, v2, p1, p2, brake=brake, grade=grade)  # type: ignore[arg-type]
    d21 = head_on_distance(v2, v1, p2, p1, brake=brake, grade=-grade)  # type: ignore[arg-type]
    assert d12 == pytest.approx(d21)
    own = static_obstacle_distance(v1, p1, brake=brake, grade=grade)  # type: ignore[arg-type]
    assert d12 >= own + p2.standstill_margin_m


def test_horizon_floor_and_growth() -> None:
    assert horizon_m(0.0, TRAM) == 300.0
    assert horizon_m(20.0, TRAM) == 300.0  # a tram's warning distance is well inside 300 m
    mainline = SHIPPED["mainline"]
    v = 160 / 3.6
    expected = warning_distance(v, mainline) + margin_distance(v, mainline)
    assert horizon_m(v, mainline) == pytest.approx(expected)
    assert expected > 1000.0
    assert horizon_m(10.0, TRAM, minimum_m=0.0) == pytest.approx(
        warning_distance(10.0, TRAM) + margin_distance(10.0, TRAM)
    )


# --------------------------------------------------------------------------------------
# Levels
# --------------------------------------------------------------------------------------


def test_level_helpers() -> None:
    assert LEVELS == ("none", "advisory", "warning", "emergency")
    assert [level_rank(level) for level in LEVELS] == [0, 1, 2, 3]
    assert max_level() == "none"
    assert max_level("advisory", "emergency", "warning") == "emergency"
    assert max_level("none", "advisory") == "advisory"
    with pytest.raises(ValueError, match="level"):
        level_rank("alarm")  # type: ignore[arg-type]


def test_classify_static_tram_at_50_kmh() -> None:
    v = 50 / 3.6
    # emergency level 57.50 m, warning level 111.95 m, horizon 300 m (see above)
    assert classify(-1.0, v, TRAM) == "emergency"
    assert classify(57.0, v, TRAM) == "emergency"
    assert classify(58.0, v, TRAM) == "warning"
    assert classify(111.9, v, TRAM) == "warning"
    assert classify(112.0, v, TRAM) == "advisory"
    assert classify(299.0, v, TRAM) == "advisory"
    assert classify(301.0, v, TRAM) == "none"
    assert classify(200.0, v, TRAM, horizon_m=150.0) == "none"


def test_classify_rear_end_depends_on_leader_state() -> None:
    v_f, v_l, gap = 15.0, 10.0, 110.0
    # moving leader: 127.375 m follower warning distance − 20.857 m leader travel = 106.5 m
    assert classify(gap, v_f, TRAM, kind="rear_end", v_other_mps=v_l) == "advisory"
    # leader in emergency braking: standing obstacle, 127.375 m
    braking = classify(gap, v_f, TRAM, kind="rear_end", v_other_mps=v_l, leader_braking="emergency")
    assert braking == "warning"


def test_classify_head_on_counts_both_vehicles() -> None:
    v = 50 / 3.6
    static = classify(110.0, v, TRAM)
    head_on = classify(110.0, v, TRAM, kind="head_on", v_other_mps=v)
    assert static == "warning"  # 57.50 m < 110 m <= 111.95 m
    assert head_on == "emergency"  # 110 m <= 2 × 57.50 m


def test_time_to_collision() -> None:
    assert time_to_collision(100.0, 10.0) == pytest.approx(10.0)
    assert time_to_collision(-5.0, 10.0) == 0.0
    assert time_to_collision(100.0, 0.0) is None
    assert time_to_collision(100.0, -3.0) is None


@given(gap=st.floats(-100.0, 1e4), closing=st.floats(-50.0, 0.0))
def test_time_to_collision_none_when_not_closing(gap: float, closing: float) -> None:
    assert time_to_collision(gap, closing) is None


# --------------------------------------------------------------------------------------
# Movement authority
# --------------------------------------------------------------------------------------


def test_movement_authority_rules_by_hand() -> None:
    se = 10.0 * 0.3 + 10.0**2 / 5.6 + 5.0  # both trams at 10 m/s: se_f = se_l = 25.857 m
    ma = movement_authority(100.0, 10.0, 10.0, TRAM)
    assert ma.kind == "authority"
    assert ma.ma_m == pytest.approx(100.0 + se - 5.0)
    assert ma.required_gap_m is None
    assert ma.has_authority

    emergency = movement_authority(100.0, 10.0, 10.0, TRAM, leader_braking="emergency")
    assert emergency.kind == "leader_emergency"
    assert emergency.ma_m == pytest.approx(95.0)

    # follower at 20 m/s, leader standing: |se_f − se_l| = (6 + 400/5.6 + 5) − 5
    se_f = 20.0 * 0.3 + 20.0**2 / 5.6 + 5.0
    diff = se_f - 5.0
    boundary = movement_authority(diff + 0.1, 20.0, 0.0, TRAM, tolerance_m=0.5)
    assert boundary.kind == "boundary"
    assert boundary.ma_m == pytest.approx(diff + 0.1 - 5.0)

    keep = movement_authority(30.0, 20.0, 0.0, TRAM)
    assert keep.kind == "keep_distance"
    assert keep.ma_m is None
    assert keep.required_gap_m == pytest.approx(se_f + 5.0 + 5.0)
    assert not keep.has_authority


@given(
    follower=shipped,
    leader=shipped,
    state=leader_states,
    gap=st.floats(0.0, 2000.0),
    v_f=speeds,
    v_l=speeds,
    tol=st.floats(0.0, 2.0),
)
def test_movement_authority_outcomes_consistent(
    follower: BrakingProfile,
    leader: BrakingProfile,
    state: str,
    gap: float,
    v_f: float,
    v_l: float,
    tol: float,
) -> None:
    ma = movement_authority(
        gap,
        v_f,
        v_l,
        follower,
        leader,
        leader_braking=state,  # type: ignore[arg-type]
        tolerance_m=tol,
    )
    assert isinstance(ma, MovementAuthority)
    s0 = follower.standstill_margin_m
    assert ma.follower_stop_m == pytest.approx(stopping_distance(v_f, follower, brake="emergency"))
    assert ma.leader_stop_m == pytest.approx(stopping_distance(v_l, leader, brake="emergency"))
    diff = abs(ma.follower_stop_m - ma.leader_stop_m)
    if state == "emergency":
        assert ma.kind == "leader_emergency"
    if ma.kind in ("leader_emergency", "boundary"):
        assert ma.ma_m is not None
        assert ma.ma_m == pytest.approx(gap - s0)
        assert ma.required_gap_m is None
    elif ma.kind == "authority":
        assert gap > diff
        assert ma.ma_m is not None
        assert ma.ma_m == pytest.approx(gap + ma.leader_stop_m - s0)
        assert ma.ma_m >= gap - s0
        assert ma.required_gap_m is None
    else:
        assert ma.kind == "keep_distance"
        assert gap < diff
        assert ma.ma_m is None
        assert ma.required_gap_m is not None
        assert ma.required_gap_m == pytest.approx(ma.follower_stop_m + ma.leader_stop_m + s0)
        assert ma.required_gap_m > gap


# --------------------------------------------------------------------------------------
# Speed supervision
# --------------------------------------------------------------------------------------


def test_permitted_speed_by_hand() -> None:
    # stop at 400 m with the tram service brake: sqrt(0² + 2·1.2·400) = sqrt(960)
    assert permitted_speed(400.0, 0.0, TRAM) == pytest.approx(math.sqrt(960.0))
    # 20 km/h at 100 m, emergency brake, 2 % uphill
    v_t = 20 / 3.6
    a = 2.8 + 9.80665 * 0.02
    expected = math.sqrt(v_t**2 + 2 * a * 100.0)
    assert permitted_speed(100.0, v_t, TRAM, brake="emergency", grade=-0.02) == pytest.approx(
        expected
    )
    # past the target the target speed applies
    assert permitted_speed(-10.0, v_t, TRAM) == pytest.approx(v_t)
    assert permitted_speed(0.0, 0.0, TRAM) == 0.0


@given(profile=shipped, brake=brakes, v=speeds, data=st.data())
def test_permitted_speed_with_buildup_inverts_stopping_distance(
    profile: BrakingProfile, brake: str, v: float, data: st.DataObject
) -> None:
    grade = data.draw(grades_for(profile))
    travel = stopping_distance(v, profile, brake=brake, grade=grade) - profile.standstill_margin_m  # type: ignore[arg-type]
    back = permitted_speed(
        travel,
        0.0,
        profile,
        brake=brake,  # type: ignore[arg-type]
        grade=grade,
        delay_s=profile.buildup_s(brake),  # type: ignore[arg-type]
    )
    assert back == pytest.approx(v, rel=1e-9, abs=1e-9)


@given(profile=shipped, brake=brakes, step=st.floats(0.5, 50.0), v_t=st.floats(0.0, 15.0))
def test_stepwise_curve_matches_closed_form_on_constant_grade(
    profile: BrakingProfile, brake: str, step: float, v_t: float
) -> None:
    distances, speeds_ = permitted_speed_curve(
        400.0,
        v_t,
        profile,
        brake=brake,  # type: ignore[arg-type]
        grade=profile.max_grade / 2,
        step_m=step,
    )
    assert distances[0] == 0.0
    assert distances[-1] == 400.0
    assert np.all(np.diff(distances) > 0)
    assert speeds_[-1] == v_t
    assert np.all(np.diff(speeds_) <= 0)
    closed = permitted_speed(
        400.0 - distances,
        v_t,
        profile,
        brake=brake,  # type: ignore[arg-type]
        grade=profile.max_grade / 2,
    )
    np.testing.assert_allclose(speeds_, closed, rtol=1e-9, atol=1e-12)


def test_stepwise_error_shrinks_with_step_on_varying_grade() -> None:
    length = 400.0

    def grade(x: np.ndarray) -> np.ndarray:
        return 0.06 * x / length  # level at the origin, 6 % downhill at the target

    # exact: v(0)² = 2·∫(a − g·grade(x))dx = 2·(a·L − g·0.06·L/2)
    exact = math.sqrt(2 * (1.2 * length - 9.80665 * 0.06 * length / 2))
    errors = []
    for step in (40.0, 10.0, 2.5, 0.625):
        _, v = permitted_speed_curve(length, 0.0, TRAM, grade=grade, step_m=step)
        errors.append(abs(v[0] - exact))
    assert errors == sorted(errors, reverse=True)
    assert errors[-1] < errors[0] / 20
    assert errors[-1] < 0.01


def test_curve_rejects_grade_the_brake_cannot_hold() -> None:
    with pytest.raises(ProfileError, match="grade"):
        permitted_speed_curve(400.0, 0.0, TRAM, grade=lambda x: 0.2 * x / 400.0)


def test_supervise_by_hand() -> None:
    # stop 100 m ahead; service: a = 1.2, t1 = 0.5 → −0.6 + sqrt(0.36 + 240) = 14.90 m/s
    # emergency: a = 2.8, t1 = 0.3 → −0.84 + sqrt(0.7056 + 560) = 22.84 m/s
    service_limit = -0.6 + math.sqrt(0.36 + 240.0)
    emergency_limit = -0.84 + math.sqrt(0.7056 + 560.0)
    assert service_limit == pytest.approx(14.904, abs=1e-3)
    assert emergency_limit == pytest.approx(22.839, abs=1e-3)
    assert supervise(10.0, 100.0, 0.0, TRAM) == "ok"
    assert supervise(14.8, 100.0, 0.0, TRAM) == "ok"
    assert supervise(15.0, 100.0, 0.0, TRAM) == "service"
    assert supervise(22.8, 100.0, 0.0, TRAM) == "service"
    assert supervise(23.0, 100.0, 0.0, TRAM) == "emergency"
    # without build-up the curves are the pure braking curves sqrt(2·a·d)
    assert supervise(15.3, 100.0, 0.0, TRAM, include_buildup=False) == "ok"


@given(profile=shipped, d=st.floats(-50.0, 2000.0), v_t=st.floats(0.0, 20.0), data=st.data())
def test_supervision_escalates_with_speed(
    profile: BrakingProfile, d: float, v_t: float, data: st.DataObject
) -> None:
    v1 = data.draw(speeds)
    v2 = data.draw(st.floats(v1, 60.0))
    order = ("ok", "service", "emergency")
    i1 = order.index(supervise(v1, d, v_t, profile))
    i2 = order.index(supervise(v2, d, v_t, profile))
    assert i1 <= i2
    assert supervise(min(v_t, v1), d, v_t, profile) == "ok"


# --------------------------------------------------------------------------------------
# Profiles
# --------------------------------------------------------------------------------------


def test_shipped_profiles() -> None:
    assert profile_names() == ("light_rail", "mainline", "tram")
    assert load_profile("tram") == BrakingProfile()
    assert load_profile() == TRAM
    light, main = SHIPPED["light_rail"], SHIPPED["mainline"]
    assert (light.service_decel_mps2, light.emergency_decel_mps2) == (1.3, 2.5)
    assert (main.service_decel_mps2, main.emergency_decel_mps2) == (0.7, 1.2)
    assert main.reaction_time_s > TRAM.reaction_time_s
    assert main.service_buildup_s > TRAM.service_buildup_s
    for name, profile in SHIPPED.items():
        assert profile.name == name
        assert profile.description


def _toml_value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, int):
        return str(value)
    return json.dumps(value)


def _write_profile(path: Path, **changes: object) -> Path:
    data: dict[str, object] = asdict(TRAM)
    data.pop("description")
    data["name"] = "custom"
    for key, value in changes.items():
        if value is _DROP:
            data.pop(key)
        else:
            data[key] = value
    path.write_text("".join(f"{k} = {_toml_value(v)}\n" for k, v in data.items()), "utf-8")
    return path


_DROP = object()


def test_custom_profile_from_file(tmp_path: Path) -> None:
    path = _write_profile(tmp_path / "custom.toml", service_decel_mps2=1.0, max_grade=0)
    profile = load_profile(path)
    assert profile == replace(TRAM, name="custom", service_decel_mps2=1.0, max_grade=0.0)
    assert isinstance(profile.max_grade, float)
    assert load_profile(str(path)) == profile
    nameless = _write_profile(tmp_path / "nameless.toml", name=_DROP)
    assert load_profile(nameless).name == "nameless"


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"service_decel_mps2": -1.2}, "service_decel_mps2"),
        ({"service_decel_mps2": 0.0}, "service_decel_mps2"),
        ({"emergency_decel_mps2": 0.0}, "emergency_decel_mps2"),
        ({"emergency_decel_mps2": 1.0}, "emergency_decel_mps2"),  # weaker than service
        ({"emergency_buildup_s": 0.9}, "emergency_buildup_s"),  # slower than service
        ({"reaction_time_s": float("nan")}, "reaction_time_s"),
        ({"standstill_margin_m": float("inf")}, "standstill_margin_m"),
        ({"margin_k2_s2_per_m": -0.001}, "margin_k2_s2_per_m"),
        ({"max_grade": 0.2}, "max_grade"),  # 1.2 − 9.80665·0.2 < 0
        ({"max_speed_mps": 0}, "max_speed_mps"),
        ({"traction_mps2": "fast"}, "traction_mps2"),
        ({"service_buildup_s": True}, "service_buildup_s"),
        ({"name": ""}, "name"),
        ({"brake_colour": "red"}, "brake_colour"),  # unknown key
        ({"margin_k1_s": _DROP}, "margin_k1_s"),  # missing key
    ],
)
def test_bad_profile_values_name_the_field(
    tmp_path: Path, changes: dict[str, object], field: str
) -> None:
    path = _write_profile(tmp_path / "bad.toml", **changes)
    with pytest.raises(ProfileError, match=field) as info:
        load_profile(path)
    assert isinstance(info.value, ValueError)
    assert "bad.toml" in str(info.value)


def test_invalid_toml_is_a_profile_error(tmp_path: Path) -> None:
    path = tmp_path / "broken.toml"
    path.write_text("service_decel_mps2 = = 1.2\n", "utf-8")
    with pytest.raises(ProfileError, match="TOML"):
        load_profile(path)


def test_missing_file_is_an_os_error(tmp_path: Path) -> None:
    with pytest.raises(InputFileError) as info:
        load_profile(tmp_path / "nope.toml")
    assert isinstance(info.value, OSError)
    with pytest.raises(OSError):
        load_profile(str(tmp_path / "nope.toml"))


def test_unknown_profile_name() -> None:
    with pytest.raises(ProfileError, match=r"unknown profile 'metro'.*tram"):
        load_profile("metro")


def test_direct_construction_is_validated() -> None:
    with pytest.raises(ProfileError, match="emergency_decel_mps2"):
        BrakingProfile(emergency_decel_mps2=1.0)
    with pytest.raises(ProfileError, match="service_decel_mps2"):
        BrakingProfile(service_decel_mps2=float("nan"))
    with pytest.raises(ProfileError, match="unknown key"):
        BrakingProfile.from_mapping({**asdict(TRAM), "k3": 1.0})
    assert BrakingProfile(reaction_time_s=1).reaction_time_s == 1.0


@given(profile=profiles())
def test_any_valid_profile_round_trips_through_a_mapping(profile: BrakingProfile) -> None:
    assume(profile.name)
    assert BrakingProfile.from_mapping(asdict(profile)) == profile
