"""Braking and warning model: stopping distances and warning levels.

Movement authority and ATP speed supervision are in :mod:`antikol.atp`; profiles in
:mod:`antikol.analysis.profiles`.

SI units everywhere (m, s, m/s, m/s²); every name carries its unit. The formulas come from
three source documents:

* **CBTC** (moving-block train control): stopping distance ``v·t1 + v²/(2·a) + s0`` — the
  vehicle coasts at ``v`` for the brake build-up time ``t1``, then decelerates at the constant
  rate ``a``, and keeps the standstill margin ``s0``; and the movement-authority rules with
  a moving leader (:func:`movement_authority`).
* **Train-to-train** driver assistance: the warning distance is the reaction distance
  ``v·t_react`` plus the service stopping distance plus a speed-dependent margin
  ``k0 + k1·v + k2·v²`` (:func:`warning_distance`).
* **Tram ATP**: permitted-speed curves back-calculated from a target point over steps of
  ``ΔS`` with ``v_prev = sqrt(v_next² + 2·a·ΔS)`` and the supervision that commands the
  service brake above the service curve and the emergency brake above the emergency curve
  (:func:`permitted_speed_curve`, :func:`permitted_speed`, :func:`supervise`).

Conventions
-----------
Grade
    ``grade`` is the dimensionless gradient (rise over run, 0.04 = 4 %) **positive downhill
    in the running direction**: gravity then pushes the vehicle forward, the effective
    deceleration is ``a − g·grade`` with ``g = 9.80665 m/s²`` and the stop gets longer.
    Uphill is negative and shortens the stop. A grade on which the brake cannot hold the
    vehicle (``a − g·grade ≤ 0``) raises :class:`~antikol.errors.ProfileError` naming
    ``grade``. In a head-on conflict the grade is given in the running direction of the
    first vehicle; the second vehicle, running the other way, sees ``-grade``.
Levels
    ``brake="service"`` is the *warning* level and ``brake="emergency"`` the *emergency*
    level. Both include the driver's reaction time: antikol warns a driver, it applies no
    brake itself. Only the warning level adds the margin polynomial; the emergency level is
    the bare physical limit. Because a profile's emergency brake is never weaker nor slower
    to build up than its service brake, the emergency distance is never longer than the
    warning distance, so the levels are ordered.
Build-up time
    The stopping distances include ``t1``. The permitted-speed *curves* are pure braking
    curves without ``t1`` (as the ATP document draws them); :func:`permitted_speed` takes
    an optional ``delay_s`` that adds a coasting phase, and :func:`supervise` uses the brake
    build-up time of the brake it would command.

Speeds must be finite and non-negative (:class:`ValueError` otherwise). Distance functions
accept a float or a numpy array of speeds and return the same kind.

This is a driver-assistance model, not a certified safety function.
"""

from __future__ import annotations

import math
import numbers
from typing import Any, TypeVar

import numpy as np
import numpy.typing as npt

from antikol.analysis.arguments import FloatArray, finite, like_inputs, speeds
from antikol.analysis.profiles import (
    BRAKES,
    G_MPS2,
    Brake,
    BrakingProfile,
    load_profile,
    profile_names,
)
from antikol.errors import InvalidArgumentError, ProfileError
from antikol.kinds import BRAKE_STATES, GAP_CASES, LEVELS, BrakeState, GapCase, Level
from antikol.thresholds import MIN_HORIZON_M

__all__ = [
    "BRAKES",
    "GAP_CASES",
    "G_MPS2",
    "LEVELS",
    "Brake",
    "BrakingProfile",
    "GapCase",
    "Level",
    "classify",
    "conflict_distance",
    "effective_deceleration",
    "emergency_distance",
    "head_on_distance",
    "horizon_m",
    "load_profile",
    "margin_distance",
    "profile_names",
    "reaction_distance",
    "rear_end_distance",
    "static_obstacle_distance",
    "stopping_distance",
    "time_to_collision",
    "warning_distance",
]

#: Speed (float) or speeds (numpy array); functions return the same kind they were given.
F = TypeVar("F", float, npt.NDArray[np.float64])


def effective_deceleration(profile: BrakingProfile, *, brake: Brake, grade: float = 0.0) -> float:
    """Deceleration of a brake on a gradient: ``a − g·grade``.

    Parameters
    ----------
    profile : BrakingProfile
        Vehicle profile.
    brake : {"service", "emergency"}
        Which brake.
    grade : float
        Gradient, dimensionless, positive downhill in the running direction.

    Returns
    -------
    float
        Effective deceleration, m/s² (> 0).

    Raises
    ------
    ProfileError
        ``grade`` is not finite or the brake cannot hold the vehicle on it
        (``a − g·grade <= 0``).
    """
    a = profile.deceleration_mps2(brake)
    if isinstance(grade, bool) or not isinstance(grade, numbers.Real) or not math.isfinite(grade):
        raise ProfileError(f"field grade={grade!r}: must be a finite number")
    a_eff = a - G_MPS2 * float(grade)
    if a_eff <= 0.0:
        raise ProfileError(
            f"field grade={grade!r}: steeper than the {brake} brake of profile "
            f"{profile.name!r} can hold ({a:g} − g·{grade:g} <= 0)"
        )
    return a_eff


# --------------------------------------------------------------------------------------
# Distances
# --------------------------------------------------------------------------------------


def _braking_travel(v: FloatArray, profile: BrakingProfile, brake: Brake, grade: float) -> Any:
    a = effective_deceleration(profile, brake=brake, grade=grade)
    return v * profile.buildup_s(brake) + v * v / (2.0 * a)


def stopping_distance(
    v_mps: F, profile: BrakingProfile, *, brake: Brake = "service", grade: float = 0.0
) -> F:
    """Stopping distance from the brake command: ``v·t1 + v²/(2·(a − g·grade)) + s0``.

    The CBTC formula: coasting at ``v`` during the brake build-up time ``t1``, then the
    constant effective deceleration, plus the standstill margin ``s0``. No reaction time.

    Parameters
    ----------
    v_mps : float or ndarray
        Speed(s), m/s, finite and >= 0.
    profile : BrakingProfile
        Vehicle profile.
    brake : {"service", "emergency"}
        Which brake is applied.
    grade : float
        Gradient, dimensionless, positive downhill in the running direction.

    Returns
    -------
    float or ndarray
        Distance, m, of the same kind as ``v_mps``; ``s0`` at standstill.

    Raises
    ------
    ValueError
        Negative or non-finite speed, unknown brake.
    ProfileError
        The brake cannot hold the vehicle on ``grade``.
    """
    v = speeds(v_mps, "v_mps")
    d = _braking_travel(v, profile, brake, grade) + profile.standstill_margin_m
    return like_inputs(d, v_mps)


def reaction_distance(v_mps: F, profile: BrakingProfile) -> F:
    """Distance run during the driver's reaction time: ``v·t_react``.

    Parameters
    ----------
    v_mps : float or ndarray
        Speed(s), m/s.
    profile : BrakingProfile
        Vehicle profile.

    Returns
    -------
    float or ndarray
        Distance, m.
    """
    v = speeds(v_mps, "v_mps")
    return like_inputs(v * profile.reaction_time_s, v_mps)


def margin_distance(v_mps: F, profile: BrakingProfile) -> F:
    """Speed-dependent warning margin ``k0 + k1·v + k2·v²``.

    Parameters
    ----------
    v_mps : float or ndarray
        Speed(s), m/s.
    profile : BrakingProfile
        Vehicle profile.

    Returns
    -------
    float or ndarray
        Margin, m.
    """
    v = speeds(v_mps, "v_mps")
    m = profile.margin_k0_m + profile.margin_k1_s * v + profile.margin_k2_s2_per_m * v * v
    return like_inputs(m, v_mps)


def static_obstacle_distance(
    v_mps: F, profile: BrakingProfile, *, brake: Brake = "service", grade: float = 0.0
) -> F:
    """Distance at which a driver must be alerted to stop before a standing obstacle.

    ``v·t_react + stopping_distance(v, brake)``, plus the margin ``k0 + k1·v + k2·v²`` at
    the warning level (``brake="service"``); no margin at the emergency level.

    Parameters
    ----------
    v_mps : float or ndarray
        Speed(s), m/s.
    profile : BrakingProfile
        Vehicle profile.
    brake : {"service", "emergency"}
        ``"service"`` for the warning level, ``"emergency"`` for the emergency level.
    grade : float
        Gradient, positive downhill in the running direction.

    Returns
    -------
    float or ndarray
        Distance, m.
    """
    v = speeds(v_mps, "v_mps")
    d = v * profile.reaction_time_s + _braking_travel(v, profile, brake, grade)
    d = d + profile.standstill_margin_m
    if brake == "service":
        d = d + margin_distance(v, profile)
    return like_inputs(d, v_mps)


def warning_distance(v_mps: F, profile: BrakingProfile, *, grade: float = 0.0) -> F:
    """Driver-assistance warning distance (train-to-train document).

    ``v·t_react + (v·t1 + v²/(2·(a_service − g·grade)) + s0) + (k0 + k1·v + k2·v²)``.

    Parameters
    ----------
    v_mps : float or ndarray
        Speed(s), m/s.
    profile : BrakingProfile
        Vehicle profile.
    grade : float
        Gradient, positive downhill in the running direction.

    Returns
    -------
    float or ndarray
        Distance, m.
    """
    return static_obstacle_distance(v_mps, profile, brake="service", grade=grade)


def emergency_distance(v_mps: F, profile: BrakingProfile, *, grade: float = 0.0) -> F:
    """Reaction plus emergency stopping distance, without margin: the emergency level.

    ``v·t_react + v·t1_e + v²/(2·(a_emergency − g·grade)) + s0``.

    Parameters
    ----------
    v_mps : float or ndarray
        Speed(s), m/s.
    profile : BrakingProfile
        Vehicle profile.
    grade : float
        Gradient, positive downhill in the running direction.

    Returns
    -------
    float or ndarray
        Distance, m; never longer than :func:`warning_distance`.
    """
    return static_obstacle_distance(v_mps, profile, brake="emergency", grade=grade)


def _leader_credit(
    v_l: FloatArray, profile: BrakingProfile, leader_braking: BrakeState, grade: float
) -> Any:
    """Distance the leader is sure to travel before it stands, m."""
    if leader_braking == "none":
        # It may start an emergency stop now: build-up coasting plus emergency braking,
        # i.e. the CBTC credit se_l − s0.
        return _braking_travel(v_l, profile, "emergency", grade)
    if leader_braking == "service":
        # Already braking, and it may escalate to the emergency brake at any moment.
        a = effective_deceleration(profile, brake="emergency", grade=grade)
        return v_l * v_l / (2.0 * a)
    if leader_braking == "emergency":
        return np.zeros_like(v_l)
    raise InvalidArgumentError("leader_braking", leader_braking, f"must be one of {BRAKE_STATES}")


def rear_end_distance(
    v_follower_mps: F,
    v_leader_mps: F,
    follower_profile: BrakingProfile,
    leader_profile: BrakingProfile | None = None,
    *,
    leader_braking: BrakeState = "none",
    brake: Brake = "service",
    grade: float = 0.0,
) -> F:
    """Gap at which the follower's driver must be alerted to avoid running into a leader.

    The follower's :func:`static_obstacle_distance` (reaction, stopping distance with
    ``brake`` and, at the warning level, the margin) minus the distance the leader is sure
    to travel before it stands, never below the follower's ``s0``:

    * ``leader_braking="none"``: the leader may start an emergency stop at any moment, so
      it still travels its emergency braking distance ``v·t1_e + v²/(2·a_e)`` (the CBTC
      credit ``se_l − s0``);
    * ``"service"``: it is already braking (no build-up credited) and may escalate to its
      emergency brake: ``v²/(2·a_e)``;
    * ``"emergency"``: no credit — a standing obstacle, as in the CBTC rule; the result is
      the follower's full :func:`static_obstacle_distance`.

    Parameters
    ----------
    v_follower_mps, v_leader_mps : float or ndarray
        Speeds of the follower (own vehicle) and the leader, m/s.
    follower_profile : BrakingProfile
        Follower's profile.
    leader_profile : BrakingProfile, optional
        Leader's profile; defaults to the follower's.
    leader_braking : {"none", "service", "emergency"}
        Brake state announced by the leader.
    brake : {"service", "emergency"}
        Follower's brake: ``"service"`` for the warning level, ``"emergency"`` for the
        emergency level.
    grade : float
        Gradient, positive downhill in the common running direction.

    Returns
    -------
    float or ndarray
        Distance, m, >= the follower's ``standstill_margin_m``.
    """
    leader = follower_profile if leader_profile is None else leader_profile
    v_f = speeds(v_follower_mps, "v_follower_mps")
    v_l = speeds(v_leader_mps, "v_leader_mps")
    need = static_obstacle_distance(v_f, follower_profile, brake=brake, grade=grade)
    credit = _leader_credit(v_l, leader, leader_braking, grade)
    d = np.maximum(need - credit, follower_profile.standstill_margin_m)
    return like_inputs(d, v_follower_mps, v_leader_mps)


def head_on_distance(
    v1_mps: F,
    v2_mps: F,
    profile1: BrakingProfile,
    profile2: BrakingProfile | None = None,
    *,
    brake: Brake = "service",
    grade: float = 0.0,
) -> F:
    """Gap at which two vehicles approaching each other on one track must be alerted.

    Both drivers are assumed warned (each vehicle runs antikol): the sum of both
    :func:`static_obstacle_distance` values — reaction and stopping distance of each
    (each with its ``s0``) plus, at the warning level, each margin.

    Parameters
    ----------
    v1_mps, v2_mps : float or ndarray
        Speeds of the two vehicles, m/s.
    profile1 : BrakingProfile
        Profile of vehicle 1.
    profile2 : BrakingProfile, optional
        Profile of vehicle 2; defaults to ``profile1``.
    brake : {"service", "emergency"}
        ``"service"`` for the warning level, ``"emergency"`` for the emergency level.
    grade : float
        Gradient in vehicle 1's running direction (positive downhill for vehicle 1);
        vehicle 2 sees ``-grade``.

    Returns
    -------
    float or ndarray
        Distance, m.
    """
    p2 = profile1 if profile2 is None else profile2
    v1 = speeds(v1_mps, "v1_mps")
    v2 = speeds(v2_mps, "v2_mps")
    d1 = static_obstacle_distance(v1, profile1, brake=brake, grade=grade)
    d2 = static_obstacle_distance(v2, p2, brake=brake, grade=-grade)
    return like_inputs(d1 + d2, v1_mps, v2_mps)


def conflict_distance(
    v_mps: float,
    profile: BrakingProfile,
    *,
    kind: GapCase = "static",
    brake: Brake = "service",
    v_other_mps: float = 0.0,
    other_profile: BrakingProfile | None = None,
    leader_braking: BrakeState = "none",
    grade: float = 0.0,
) -> float:
    """Alert distance of one conflict, dispatching on its kind.

    Parameters
    ----------
    v_mps : float
        Own speed, m/s. In a rear-end conflict the own vehicle is the follower.
    profile : BrakingProfile
        Own profile.
    kind : {"rear_end", "head_on", "static"}
        Conflict kind: :func:`rear_end_distance`, :func:`head_on_distance` or
        :func:`static_obstacle_distance`.
    brake : {"service", "emergency"}
        ``"service"`` for the warning level, ``"emergency"`` for the emergency level.
    v_other_mps : float
        Speed of the other vehicle, m/s (ignored for ``"static"``).
    other_profile : BrakingProfile, optional
        Other vehicle's profile; defaults to ``profile``.
    leader_braking : {"none", "service", "emergency"}
        Brake state of the leader (``"rear_end"`` only).
    grade : float
        Gradient, positive downhill in the own running direction.

    Returns
    -------
    float
        Distance, m.
    """
    v = finite(v_mps, "v_mps")
    if kind == "static":
        return static_obstacle_distance(v, profile, brake=brake, grade=grade)
    v_other = finite(v_other_mps, "v_other_mps")
    if kind == "rear_end":
        return rear_end_distance(
            v,
            v_other,
            profile,
            other_profile,
            leader_braking=leader_braking,
            brake=brake,
            grade=grade,
        )
    if kind == "head_on":
        return head_on_distance(v, v_other, profile, other_profile, brake=brake, grade=grade)
    raise InvalidArgumentError("kind", kind, f"must be one of {GAP_CASES}")


def _horizon(v_mps: F, profile: BrakingProfile, grade: float, minimum_m: float) -> F:
    minimum = finite(minimum_m, "minimum_m")
    if minimum < 0.0:
        raise InvalidArgumentError("minimum_m", minimum_m, "must be >= 0 m")
    v = speeds(v_mps, "v_mps")
    d = warning_distance(v, profile, grade=grade) + margin_distance(v, profile)
    return like_inputs(np.maximum(d, minimum), v_mps)


def horizon_m(
    v_mps: F, profile: BrakingProfile, *, grade: float = 0.0, minimum_m: float = MIN_HORIZON_M
) -> F:
    """Look-ahead distance of the analyser: warning distance plus margin, floored.

    ``max(minimum_m, warning_distance(v) + (k0 + k1·v + k2·v²))``. The floor defaults to
    the 2008 paper's ``d_col`` of 300 m, so the track-aware analyser never looks less far
    than the sector rule; pass ``minimum_m=0`` to use the braking model alone.

    Parameters
    ----------
    v_mps : float or ndarray
        Speed(s), m/s.
    profile : BrakingProfile
        Vehicle profile.
    grade : float
        Gradient, positive downhill in the running direction.
    minimum_m : float
        Floor of the horizon, m.

    Returns
    -------
    float or ndarray
        Horizon, m.
    """
    return _horizon(v_mps, profile, grade, minimum_m)


# --------------------------------------------------------------------------------------
# Levels
# --------------------------------------------------------------------------------------


def classify(
    gap_m: float,
    v_mps: float,
    profile: BrakingProfile,
    *,
    kind: GapCase = "static",
    v_other_mps: float = 0.0,
    other_profile: BrakingProfile | None = None,
    leader_braking: BrakeState = "none",
    grade: float = 0.0,
    horizon_m: float | None = None,
) -> Level:
    """Warning level of a conflict at a given gap.

    * ``"emergency"``: ``gap_m`` <= the emergency-level :func:`conflict_distance`
      (reaction plus emergency stopping distance, no margin);
    * ``"warning"``: ``gap_m`` <= the warning-level distance (reaction plus service
      stopping distance plus margin);
    * ``"advisory"``: ``gap_m`` <= ``horizon_m`` (the conflict is within the look-ahead);
    * ``"none"`` otherwise.

    The emergency distance never exceeds the warning distance, so a smaller gap at the
    same speeds is never classified lower.

    Parameters
    ----------
    gap_m : float
        Free distance along the track to the conflict point or other vehicle, m. Zero or
        negative (overlap) classifies as ``"emergency"``.
    v_mps : float
        Own speed, m/s; in a rear-end conflict the own vehicle is the follower.
    profile : BrakingProfile
        Own profile.
    kind : {"rear_end", "head_on", "static"}
        Conflict kind.
    v_other_mps : float
        Other vehicle's speed, m/s (ignored for ``"static"``).
    other_profile : BrakingProfile, optional
        Other vehicle's profile; defaults to ``profile``.
    leader_braking : {"none", "service", "emergency"}
        Leader's brake state (``"rear_end"`` only).
    grade : float
        Gradient, positive downhill in the own running direction.
    horizon_m : float, optional
        Advisory horizon, m. Default: the larger of :func:`horizon_m` for the own speed and
        the conflict's warning distance plus the own margin.

    Returns
    -------
    {"none", "advisory", "warning", "emergency"}
        The level.
    """
    gap = finite(gap_m, "gap_m")
    common: dict[str, Any] = {
        "kind": kind,
        "v_other_mps": v_other_mps,
        "other_profile": other_profile,
        "leader_braking": leader_braking,
        "grade": grade,
    }
    emergency_m = conflict_distance(v_mps, profile, brake="emergency", **common)
    warning_m = conflict_distance(v_mps, profile, brake="service", **common)
    if horizon_m is None:
        horizon = max(
            _horizon(float(v_mps), profile, grade, MIN_HORIZON_M),
            warning_m + margin_distance(float(v_mps), profile),
        )
    else:
        horizon = finite(horizon_m, "horizon_m")
    if gap <= emergency_m:
        return "emergency"
    if gap <= warning_m:
        return "warning"
    if gap <= horizon:
        return "advisory"
    return "none"


def time_to_collision(gap_m: float, closing_speed_mps: float) -> float | None:
    """Time until the gap closes at the current closing speed.

    Parameters
    ----------
    gap_m : float
        Free distance, m. Zero or negative gives 0.0 when closing.
    closing_speed_mps : float
        Rate at which the gap shrinks, m/s (positive when closing).

    Returns
    -------
    float or None
        Time, s; ``None`` when not closing (``closing_speed_mps <= 0``).
    """
    gap = finite(gap_m, "gap_m")
    closing = finite(closing_speed_mps, "closing_speed_mps")
    if closing <= 0.0:
        return None
    return max(gap, 0.0) / closing
