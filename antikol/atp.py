"""Train protection on top of the braking model: CBTC movement authority with a moving
leader, and tram ATP speed supervision by back-calculated permitted-speed curves.

* **CBTC** (moving-block train control): the movement-authority rules with a moving leader
  (:func:`movement_authority`), stopping distance ``v·t1 + v²/(2·a) + s0``.
* **Tram ATP**: permitted-speed curves back-calculated from a target point over steps of
  ``ΔS`` with ``v_prev = sqrt(v_next² + 2·a·ΔS)`` and the supervision that commands the
  service brake above the service curve and the emergency brake above the emergency curve
  (:func:`permitted_speed_curve`, :func:`permitted_speed`, :func:`supervise`).

The curves are pure braking curves without the build-up time ``t1`` (as the ATP document
draws them); :func:`permitted_speed` takes an optional ``delay_s`` that adds a coasting
phase, and :func:`supervise` uses the brake build-up time of the brake it would command.
This is a driver-assistance model, not a certified safety function.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Final, Literal

import numpy as np
import numpy.typing as npt

from antikol.analysis.arguments import FloatArray, finite, like_inputs, speeds
from antikol.analysis.braking import F, effective_deceleration, stopping_distance
from antikol.analysis.profiles import BRAKES, G_MPS2, Brake, BrakingProfile
from antikol.errors import InvalidArgumentError, ProfileError
from antikol.kinds import BRAKE_STATES, BrakeState

__all__ = [
    "INTERVENTIONS",
    "Intervention",
    "MovementAuthority",
    "MovementAuthorityKind",
    "movement_authority",
    "permitted_speed",
    "permitted_speed_curve",
    "supervise",
]

Intervention = Literal["ok", "service", "emergency"]
MovementAuthorityKind = Literal["authority", "boundary", "leader_emergency", "keep_distance"]
#: Supervision outcomes, mildest first.
INTERVENTIONS: Final[tuple[Intervention, ...]] = ("ok", "service", "emergency")


# --------------------------------------------------------------------------------------
# Movement authority (CBTC)
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class MovementAuthority:
    """Outcome of the CBTC movement-authority rules with a moving leader.

    Parameters
    ----------
    kind : {"authority", "boundary", "leader_emergency", "keep_distance"}
        Which rule applied: ``"authority"`` (``s > |se_f − se_l|``: ``MA = s + se_l − s0``),
        ``"boundary"`` (``s == |se_f − se_l|`` within the tolerance: ``MA = s − s0``),
        ``"leader_emergency"`` (leader emergency braking: ``MA = s − s0``) or
        ``"keep_distance"`` (``s < |se_f − se_l|``: no authority; the leader must be asked
        to keep ``se_f + se_l + s0``).
    ma_m : float or None
        Movement authority: distance ahead of the follower's front it may run to, m.
        ``None`` for ``"keep_distance"``. Zero or negative means no movement.
    required_gap_m : float or None
        Distance the leader must keep, ``se_f + se_l + s0``, m; only for
        ``"keep_distance"``.
    gap_m : float
        The gap ``s`` the rules were applied to, m.
    follower_stop_m : float
        ``se_f``: the follower's emergency stopping distance, m.
    leader_stop_m : float
        ``se_l``: the leader's emergency stopping distance, m.
    standstill_margin_m : float
        ``s0`` used, m.
    """

    kind: MovementAuthorityKind
    ma_m: float | None
    required_gap_m: float | None
    gap_m: float
    follower_stop_m: float
    leader_stop_m: float
    standstill_margin_m: float

    @property
    def has_authority(self) -> bool:
        """Whether the follower may move: an MA exists and is positive."""
        return self.ma_m is not None and self.ma_m > 0.0


def movement_authority(
    gap_m: float,
    v_follower_mps: float,
    v_leader_mps: float,
    follower_profile: BrakingProfile,
    leader_profile: BrakingProfile | None = None,
    *,
    leader_braking: BrakeState = "none",
    grade: float = 0.0,
    tolerance_m: float = 0.5,
) -> MovementAuthority:
    """Movement authority behind a moving leader, by the CBTC document's rules.

    With ``s`` the gap, ``se_f`` and ``se_l`` the emergency stopping distances
    (:func:`stopping_distance` with ``brake="emergency"``, each including its ``s0``) and
    ``s0`` the follower's standstill margin, the rules are applied in this order:

    1. leader emergency braking: ``MA = s − s0`` (``"leader_emergency"``);
    2. ``|s − |se_f − se_l|| <= tolerance_m``: ``MA = s − s0`` (``"boundary"``);
    3. ``s > |se_f − se_l|``: ``MA = s + se_l − s0`` (``"authority"``);
    4. otherwise the leader must be asked to keep ``se_f + se_l + s0`` (``"keep_distance"``,
       no MA).

    A leader announcing ``"service"`` braking is a moving leader, as in the document. No
    reaction time: the rules describe automatic train control. With equal profiles
    ``MA = s + se_l − s0`` is the gap plus the leader's emergency braking travel.

    Parameters
    ----------
    gap_m : float
        Gap ``s`` from the follower's front to the leader's rear, m.
    v_follower_mps, v_leader_mps : float
        Speeds, m/s.
    follower_profile : BrakingProfile
        Follower's profile (gives ``s0``).
    leader_profile : BrakingProfile, optional
        Leader's profile; defaults to the follower's.
    leader_braking : {"none", "service", "emergency"}
        Leader's brake state.
    grade : float
        Gradient, positive downhill in the common running direction.
    tolerance_m : float
        Tolerance of the equality rule, m (>= 0).

    Returns
    -------
    MovementAuthority
        The outcome; never raises for a small gap.
    """
    leader = follower_profile if leader_profile is None else leader_profile
    s = finite(gap_m, "gap_m")
    tol = finite(tolerance_m, "tolerance_m")
    if tol < 0.0:
        raise InvalidArgumentError("tolerance_m", tolerance_m, "must be >= 0 m")
    if leader_braking not in BRAKE_STATES:
        raise InvalidArgumentError(
            "leader_braking", leader_braking, f"must be one of {BRAKE_STATES}"
        )
    se_f = stopping_distance(
        finite(v_follower_mps, "v_follower_mps"), follower_profile, brake="emergency", grade=grade
    )
    se_l = stopping_distance(
        finite(v_leader_mps, "v_leader_mps"), leader, brake="emergency", grade=grade
    )
    s0 = follower_profile.standstill_margin_m
    diff = abs(se_f - se_l)

    def outcome(
        kind: MovementAuthorityKind, ma: float | None, required: float | None = None
    ) -> MovementAuthority:
        return MovementAuthority(kind, ma, required, s, se_f, se_l, s0)

    if leader_braking == "emergency":
        return outcome("leader_emergency", s - s0)
    if abs(s - diff) <= tol:
        return outcome("boundary", s - s0)
    if s > diff:
        return outcome("authority", s + se_l - s0)
    return outcome("keep_distance", None, se_f + se_l + s0)


# --------------------------------------------------------------------------------------
# Speed supervision (tram ATP)
# --------------------------------------------------------------------------------------


def permitted_speed(
    distance_to_target_m: F,
    target_speed_mps: float,
    profile: BrakingProfile,
    *,
    brake: Brake = "service",
    grade: float = 0.0,
    delay_s: float = 0.0,
) -> F:
    """Highest speed from which the target speed is reached at the target point.

    Closed form of the braking curve on a constant grade: ``v = sqrt(v_t² + 2·a·d)`` with
    ``a = a_brake − g·grade``. With ``delay_s = T > 0`` the vehicle first coasts at ``v``
    for ``T`` and then brakes, so ``v·T + (v² − v_t²)/(2·a) = d``, whose positive root is
    ``v = −a·T + sqrt((a·T)² + v_t² + 2·a·d)``. The result is never below ``v_t``: a
    vehicle already at or below the target speed needs no braking. At or past the target
    (``d <= 0``) it is ``v_t``. ``s0`` is not included: place the target point where the
    speed must be reached.

    Parameters
    ----------
    distance_to_target_m : float or ndarray
        Distance(s) to the target point, m (finite; negative means past the target).
    target_speed_mps : float
        Speed to be reached at the target point, m/s.
    profile : BrakingProfile
        Vehicle profile.
    brake : {"service", "emergency"}
        Brake of the curve.
    grade : float
        Gradient, positive downhill in the running direction.
    delay_s : float
        Coasting time before the deceleration acts (e.g. the brake build-up time), s.

    Returns
    -------
    float or ndarray
        Permitted speed(s), m/s.
    """
    d_arr = np.asarray(distance_to_target_m, dtype=float)
    if not np.all(np.isfinite(d_arr)):
        raise InvalidArgumentError("distance_to_target_m", distance_to_target_m, "must be finite")
    v_t = float(speeds(target_speed_mps, "target_speed_mps"))
    delay = finite(delay_s, "delay_s")
    if delay < 0.0:
        raise InvalidArgumentError("delay_s", delay_s, "must be >= 0 s")
    a = effective_deceleration(profile, brake=brake, grade=grade)
    c = v_t * v_t + 2.0 * a * np.maximum(d_arr, 0.0)
    a_t = a * delay
    # Rationalised root c / (aT + sqrt((aT)² + c)): no cancellation for large aT.
    denom = a_t + np.sqrt(a_t * a_t + c)
    v = np.divide(c, denom, out=np.zeros_like(c), where=denom > 0.0)
    return like_inputs(np.maximum(v, v_t), distance_to_target_m)


GradeLike = float | Callable[[FloatArray], npt.ArrayLike]


def permitted_speed_curve(
    target_distance_m: float,
    target_speed_mps: float,
    profile: BrakingProfile,
    *,
    brake: Brake = "service",
    grade: GradeLike = 0.0,
    step_m: float = 10.0,
) -> tuple[FloatArray, FloatArray]:
    """Permitted-speed (braking) curve back-calculated stepwise from a target point.

    The ATP method: positions run from 0 (the curve's origin) to the target point at
    ``target_distance_m``. Starting at the target with ``v = v_t`` and stepping backwards
    by ``ΔS = step_m`` (the last step towards 0 may be shorter),
    ``v_prev = sqrt(v_next² + 2·(a − g·grade)·ΔS)``, with the grade taken at the step's
    target-side end. On a constant grade this equals :func:`permitted_speed` (without
    delay); a grade that varies along the track (a callable) is what the stepwise method
    is for, with an error that shrinks with ``ΔS``. The curve has no build-up delay.

    Parameters
    ----------
    target_distance_m : float
        Position of the target point from the curve origin, m (> 0).
    target_speed_mps : float
        Speed to be reached at the target point, m/s.
    profile : BrakingProfile
        Vehicle profile.
    brake : {"service", "emergency"}
        Brake of the curve.
    grade : float or callable
        Gradient (positive downhill in the running direction), or a function mapping an
        array of positions from the curve origin (m) to gradients.
    step_m : float
        Step ``ΔS``, m (> 0).

    Returns
    -------
    distances_m : ndarray
        Positions from the curve origin, m, increasing from 0 to ``target_distance_m``.
    speeds_mps : ndarray
        Permitted speed at each position, m/s.

    Raises
    ------
    ProfileError
        The brake cannot hold the vehicle on the grade somewhere.
    """
    length = finite(target_distance_m, "target_distance_m")
    if length <= 0.0:
        raise InvalidArgumentError("target_distance_m", target_distance_m, "must be > 0 m")
    step = finite(step_m, "step_m")
    if step <= 0.0:
        raise InvalidArgumentError("step_m", step_m, "must be > 0 m")
    v_t = float(speeds(target_speed_mps, "target_speed_mps"))
    n_steps = max(1, math.ceil(length / step - 1e-9))
    positions = np.maximum(length - step * np.arange(n_steps + 1, dtype=float), 0.0)
    positions[-1] = 0.0
    if callable(grade):
        grades = np.broadcast_to(np.asarray(grade(positions), dtype=float), positions.shape)
    else:
        grades = np.full_like(positions, float(grade))
    a_brake = profile.deceleration_mps2(brake)
    a_eff = a_brake - G_MPS2 * grades
    bad = ~np.isfinite(a_eff) | (a_eff <= 0.0)
    if np.any(bad):
        where = float(positions[np.argmax(bad)])
        raise ProfileError(
            f"field grade={float(grades[np.argmax(bad)])!r} at {where:g} m: not finite or "
            f"steeper than the {brake} brake of profile {profile.name!r} can hold"
        )
    curve_mps = np.empty_like(positions)
    curve_mps[0] = v_t
    for k in range(n_steps):
        ds = positions[k] - positions[k + 1]
        curve_mps[k + 1] = math.sqrt(curve_mps[k] ** 2 + 2.0 * a_eff[k] * ds)
    return positions[::-1].copy(), curve_mps[::-1].copy()


def supervise(
    v_mps: float,
    distance_to_target_m: float,
    target_speed_mps: float,
    profile: BrakingProfile,
    *,
    grade: float = 0.0,
    include_buildup: bool = True,
) -> Intervention:
    """ATP supervision of the speed towards a target point.

    Above the emergency permitted speed the emergency brake is commanded, else above the
    service permitted speed the service brake, else nothing. Each curve is
    :func:`permitted_speed` with that brake and, by default, its build-up time as delay
    (the ATP commands the brake directly, so there is no driver reaction time).

    Parameters
    ----------
    v_mps : float
        Current speed, m/s.
    distance_to_target_m : float
        Distance to the target point, m.
    target_speed_mps : float
        Speed to be reached at the target point, m/s.
    profile : BrakingProfile
        Vehicle profile.
    grade : float
        Gradient, positive downhill in the running direction.
    include_buildup : bool
        Whether the curves account for the brake build-up time.

    Returns
    -------
    {"ok", "service", "emergency"}
        Intervention.
    """
    v = float(speeds(v_mps, "v_mps"))
    d = finite(distance_to_target_m, "distance_to_target_m")
    limits = {
        brake: permitted_speed(
            d,
            target_speed_mps,
            profile,
            brake=brake,
            grade=grade,
            delay_s=profile.buildup_s(brake) if include_buildup else 0.0,
        )
        for brake in BRAKES
    }
    if v > limits["emergency"]:
        return "emergency"
    if v > limits["service"]:
        return "service"
    return "ok"
