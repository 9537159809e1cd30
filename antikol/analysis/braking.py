"""Braking and warning model: stopping distances, warning levels, movement authority and
speed supervision.

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
import os
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from importlib import resources
from pathlib import Path
from typing import Any, Final, Literal, TypeVar

import numpy as np
import numpy.typing as npt

from antikol.errors import InputFileError, ProfileError
from antikol.kinds import (
    BRAKE_STATES,
    GAP_CASES,
    LEVELS,
    BrakeState,
    GapCase,
    Level,
    level_rank,
    max_level,
)
from antikol.thresholds import MIN_HORIZON_M

__all__ = [
    "BRAKES",
    "GAP_CASES",
    "G_MPS2",
    "INTERVENTIONS",
    "LEVELS",
    "Brake",
    "BrakingProfile",
    "GapCase",
    "Intervention",
    "Level",
    "MovementAuthority",
    "MovementAuthorityKind",
    "classify",
    "conflict_distance",
    "effective_deceleration",
    "emergency_distance",
    "head_on_distance",
    "horizon_m",
    "level_rank",
    "load_profile",
    "margin_distance",
    "max_level",
    "movement_authority",
    "permitted_speed",
    "permitted_speed_curve",
    "profile_names",
    "reaction_distance",
    "rear_end_distance",
    "static_obstacle_distance",
    "stopping_distance",
    "supervise",
    "time_to_collision",
    "warning_distance",
]

#: Standard gravity, m/s².
G_MPS2: Final = 9.80665

Brake = Literal["service", "emergency"]
Intervention = Literal["ok", "service", "emergency"]
MovementAuthorityKind = Literal["authority", "boundary", "leader_emergency", "keep_distance"]

#: The brakes a distance can be computed for, weakest first.
BRAKES: Final[tuple[Brake, ...]] = ("service", "emergency")
#: Supervision outcomes, mildest first.
INTERVENTIONS: Final[tuple[Intervention, ...]] = ("ok", "service", "emergency")

#: Speed (float) or speeds (numpy array); functions return the same kind they were given.
F = TypeVar("F", float, npt.NDArray[np.float64])
FloatArray = npt.NDArray[np.float64]

_PROFILE_PACKAGE = "antikol"
_PROFILE_DIR = "profiles"


# --------------------------------------------------------------------------------------
# Profiles
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class BrakingProfile:
    """Braking capability and warning margins of one kind of vehicle.

    The defaults are the tram profile (also shipped as ``profiles/tram.toml``). Values are
    validated on construction; integers are stored as floats.

    Parameters
    ----------
    name : str
        Profile name, e.g. ``"tram"``.
    traction_mps2 : float
        Maximum acceleration under traction, m/s². Carried for simulators; the distance
        formulas follow the documents and assume no acceleration during the reaction time.
    service_decel_mps2 : float
        Full service brake deceleration on level track, m/s². Must be > 0.
    emergency_decel_mps2 : float
        Emergency brake deceleration on level track, m/s². Must be >= the service value.
    reaction_time_s : float
        Driver reaction time from warning to brake command, s (documents: 1.0 to 1.5 s).
    service_buildup_s : float
        Service brake build-up time ``t1``: the vehicle coasts at its speed this long
        before the full service deceleration acts, s.
    emergency_buildup_s : float
        Emergency brake build-up time ``t1``, s. Must be <= the service value.
    standstill_margin_m : float
        Standstill margin ``s0`` kept to the obstacle after stopping, m.
    margin_k0_m : float
        Constant term ``k0`` of the warning margin ``k0 + k1·v + k2·v²``, m.
    margin_k1_s : float
        Linear term ``k1`` of the warning margin, s (metres per m/s of speed).
    margin_k2_s2_per_m : float
        Quadratic term ``k2`` of the warning margin, s²/m (metres per (m/s)²).
    max_speed_mps : float
        Maximum service speed of the vehicle, m/s. Used for plots and curve caps only;
        faster reported speeds are still evaluated.
    max_grade : float
        Steepest gradient the profile is declared for (dimensionless, 0.08 = 8 %). The
        service brake must hold the vehicle there: ``service_decel_mps2 − g·max_grade > 0``.
        Steeper grades are still accepted by the functions as long as the brake in use
        can hold the vehicle.
    description : str
        Free text: where the values come from (not shown in the repr, ignored by ``==``).

    Raises
    ------
    ProfileError
        A value is missing its type, NaN, infinite, out of range, or inconsistent; the
        message names the field.
    """

    name: str = "tram"
    traction_mps2: float = 2.0
    service_decel_mps2: float = 1.2
    emergency_decel_mps2: float = 2.8
    reaction_time_s: float = 1.0
    service_buildup_s: float = 0.5
    emergency_buildup_s: float = 0.3
    standstill_margin_m: float = 5.0
    margin_k0_m: float = 2.0
    margin_k1_s: float = 0.2
    margin_k2_s2_per_m: float = 0.005
    max_speed_mps: float = 20.0
    max_grade: float = 0.08
    description: str = field(default="", repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise _field_error("name", self.name, "must be a non-empty string")
        if not isinstance(self.description, str):
            raise _field_error("description", self.description, "must be a string")
        for name in _NUMERIC_FIELDS:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise _field_error(name, value, "must be a number")
            value = float(value)
            if not math.isfinite(value):
                raise _field_error(name, value, "must be finite (not NaN or infinite)")
            object.__setattr__(self, name, value)
        for name in _POSITIVE_FIELDS:
            if getattr(self, name) <= 0.0:
                raise _field_error(name, getattr(self, name), "must be > 0")
        for name in _NON_NEGATIVE_FIELDS:
            if getattr(self, name) < 0.0:
                raise _field_error(name, getattr(self, name), "must be >= 0")
        if self.emergency_decel_mps2 < self.service_decel_mps2:
            raise _field_error(
                "emergency_decel_mps2",
                self.emergency_decel_mps2,
                f"emergency brake weaker than the service brake ({self.service_decel_mps2:g})",
            )
        if self.emergency_buildup_s > self.service_buildup_s:
            raise _field_error(
                "emergency_buildup_s",
                self.emergency_buildup_s,
                f"emergency brake slower to build up than the service brake "
                f"({self.service_buildup_s:g} s)",
            )
        if self.service_decel_mps2 - G_MPS2 * self.max_grade <= 0.0:
            raise _field_error(
                "max_grade",
                self.max_grade,
                f"steeper than the service brake can hold "
                f"({self.service_decel_mps2:g} − g·{self.max_grade:g} <= 0)",
            )

    def deceleration_mps2(self, brake: Brake) -> float:
        """Level-track deceleration of a brake.

        Parameters
        ----------
        brake : {"service", "emergency"}
            Which brake.

        Returns
        -------
        float
            Deceleration, m/s².
        """
        _check_brake(brake)
        return self.service_decel_mps2 if brake == "service" else self.emergency_decel_mps2

    def buildup_s(self, brake: Brake) -> float:
        """Build-up time ``t1`` of a brake.

        Parameters
        ----------
        brake : {"service", "emergency"}
            Which brake.

        Returns
        -------
        float
            Build-up time, s.
        """
        _check_brake(brake)
        return self.service_buildup_s if brake == "service" else self.emergency_buildup_s

    @classmethod
    def from_mapping(
        cls, data: Mapping[str, Any], *, source: str = "profile", default_name: str | None = None
    ) -> BrakingProfile:
        """Build a profile from a mapping with the field names as keys (as in the TOML files).

        Every numeric field is required; ``name`` defaults to ``default_name`` and
        ``description`` to an empty string.

        Parameters
        ----------
        data : mapping
            Field name to value.
        source : str
            Where the data comes from, used as the prefix of error messages.
        default_name : str, optional
            Name used when ``data`` has no ``name``.

        Returns
        -------
        BrakingProfile
            The validated profile.

        Raises
        ------
        ProfileError
            Unknown keys, missing fields or invalid values; the message names the field.
        """
        known = {f.name for f in fields(cls)}
        unknown = sorted(str(k) for k in data if k not in known)
        if unknown:
            raise ProfileError(
                f"{source}: unknown key(s) {', '.join(unknown)}; "
                f"known fields: {', '.join(sorted(known))}"
            )
        missing = [name for name in _NUMERIC_FIELDS if name not in data]
        if missing:
            raise ProfileError(f"{source}: missing field(s) {', '.join(missing)}")
        values = dict(data)
        if "name" not in values:
            if default_name is None:
                raise ProfileError(f"{source}: missing field(s) name")
            values["name"] = default_name
        try:
            return cls(**values)
        except ProfileError as err:
            raise ProfileError(f"{source}: {err}") from err


_NUMERIC_FIELDS: Final = (
    "traction_mps2",
    "service_decel_mps2",
    "emergency_decel_mps2",
    "reaction_time_s",
    "service_buildup_s",
    "emergency_buildup_s",
    "standstill_margin_m",
    "margin_k0_m",
    "margin_k1_s",
    "margin_k2_s2_per_m",
    "max_speed_mps",
    "max_grade",
)
_POSITIVE_FIELDS: Final = (
    "traction_mps2",
    "service_decel_mps2",
    "emergency_decel_mps2",
    "max_speed_mps",
)
_NON_NEGATIVE_FIELDS: Final = tuple(n for n in _NUMERIC_FIELDS if n not in _POSITIVE_FIELDS)


def _field_error(name: str, value: object, reason: str) -> ProfileError:
    return ProfileError(f"field {name}={value!r}: {reason}")


def _profile_dir() -> Any:
    return resources.files(_PROFILE_PACKAGE).joinpath(_PROFILE_DIR)


def profile_names() -> tuple[str, ...]:
    """Names of the profiles shipped with antikol.

    Returns
    -------
    tuple of str
        Sorted profile names (``"light_rail"``, ``"mainline"``, ``"tram"``), each loadable
        with :func:`load_profile`.
    """
    return tuple(
        sorted(
            p.name[: -len(".toml")] for p in _profile_dir().iterdir() if p.name.endswith(".toml")
        )
    )


def load_profile(name_or_path: str | os.PathLike[str] = "tram") -> BrakingProfile:
    """Load a shipped profile by name or a profile from a TOML file.

    A string equal to a shipped name (see :func:`profile_names`) selects that profile;
    anything else is read as a path. The TOML file holds the :class:`BrakingProfile` field
    names as top-level keys; every numeric field is required, ``name`` defaults to the file
    stem.

    Parameters
    ----------
    name_or_path : str or path-like
        Profile name (``"tram"``, ``"light_rail"``, ``"mainline"``) or a ``.toml`` path.

    Returns
    -------
    BrakingProfile
        The validated profile.

    Raises
    ------
    InputFileError
        The path does not exist or cannot be read (also an ``OSError``).
    ProfileError
        Unknown profile name, invalid TOML, unknown keys, missing fields or invalid values
        (also a ``ValueError``); the message names the field.
    """
    if isinstance(name_or_path, str) and name_or_path in profile_names():
        resource = _profile_dir().joinpath(f"{name_or_path}.toml")
        return _parse_profile(
            resource.read_text(encoding="utf-8"),
            source=f"profile {name_or_path!r}",
            default_name=name_or_path,
        )
    path = Path(name_or_path)
    looks_like_path = (
        not isinstance(name_or_path, str)
        or path.suffix.lower() == ".toml"
        or any(sep in str(name_or_path) for sep in ("/", os.sep))
    )
    if not path.exists() and not looks_like_path:
        raise ProfileError(
            f"unknown profile {name_or_path!r}; shipped profiles: "
            f"{', '.join(profile_names())}; or give the path of a .toml file"
        )
    try:
        raw = path.read_bytes()
    except OSError as err:
        raise InputFileError(f"cannot read profile file {str(path)!r}: {err}") from err
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise ProfileError(f"{path}: not UTF-8 text: {err}") from err
    return _parse_profile(text, source=str(path), default_name=path.stem)


def _parse_profile(text: str, *, source: str, default_name: str) -> BrakingProfile:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ProfileError(f"{source}: invalid TOML: {err}") from err
    return BrakingProfile.from_mapping(data, source=source, default_name=default_name)


# --------------------------------------------------------------------------------------
# Validation helpers
# --------------------------------------------------------------------------------------


def _check_brake(brake: str) -> None:
    if brake not in BRAKES:
        raise ValueError(f"brake must be one of {BRAKES}, got {brake!r}")


def _speeds(value: npt.ArrayLike, name: str) -> FloatArray:
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if np.any(arr < 0.0):
        raise ValueError(f"{name} must be >= 0 m/s, got {value!r}")
    return arr


def _finite(value: float, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return out


def _out(result: FloatArray, *inputs: object) -> Any:
    """A float when every input was a scalar, else the array."""
    if all(np.ndim(x) == 0 for x in inputs):  # type: ignore[arg-type]
        return float(result)
    return result


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
    v = _speeds(v_mps, "v_mps")
    d = _braking_travel(v, profile, brake, grade) + profile.standstill_margin_m
    return _out(d, v_mps)


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
    v = _speeds(v_mps, "v_mps")
    return _out(v * profile.reaction_time_s, v_mps)


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
    v = _speeds(v_mps, "v_mps")
    m = profile.margin_k0_m + profile.margin_k1_s * v + profile.margin_k2_s2_per_m * v * v
    return _out(m, v_mps)


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
    v = _speeds(v_mps, "v_mps")
    d = v * profile.reaction_time_s + _braking_travel(v, profile, brake, grade)
    d = d + profile.standstill_margin_m
    if brake == "service":
        d = d + margin_distance(v, profile)
    return _out(d, v_mps)


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
    raise ValueError(f"leader_braking must be one of {BRAKE_STATES}, got {leader_braking!r}")


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
    v_f = _speeds(v_follower_mps, "v_follower_mps")
    v_l = _speeds(v_leader_mps, "v_leader_mps")
    need = static_obstacle_distance(v_f, follower_profile, brake=brake, grade=grade)
    credit = _leader_credit(v_l, leader, leader_braking, grade)
    d = np.maximum(need - credit, follower_profile.standstill_margin_m)
    return _out(d, v_follower_mps, v_leader_mps)


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
    v1 = _speeds(v1_mps, "v1_mps")
    v2 = _speeds(v2_mps, "v2_mps")
    d1 = static_obstacle_distance(v1, profile1, brake=brake, grade=grade)
    d2 = static_obstacle_distance(v2, p2, brake=brake, grade=-grade)
    return _out(d1 + d2, v1_mps, v2_mps)


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
    v = _finite(v_mps, "v_mps")
    if kind == "static":
        return static_obstacle_distance(v, profile, brake=brake, grade=grade)
    v_other = _finite(v_other_mps, "v_other_mps")
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
    raise ValueError(f"kind must be one of {GAP_CASES}, got {kind!r}")


def _horizon(v_mps: F, profile: BrakingProfile, grade: float, minimum_m: float) -> F:
    minimum = _finite(minimum_m, "minimum_m")
    if minimum < 0.0:
        raise ValueError(f"minimum_m must be >= 0 m, got {minimum_m!r}")
    v = _speeds(v_mps, "v_mps")
    d = warning_distance(v, profile, grade=grade) + margin_distance(v, profile)
    return _out(np.maximum(d, minimum), v_mps)


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
    gap = _finite(gap_m, "gap_m")
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
        horizon = _finite(horizon_m, "horizon_m")
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
    gap = _finite(gap_m, "gap_m")
    closing = _finite(closing_speed_mps, "closing_speed_mps")
    if closing <= 0.0:
        return None
    return max(gap, 0.0) / closing


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
    s = _finite(gap_m, "gap_m")
    tol = _finite(tolerance_m, "tolerance_m")
    if tol < 0.0:
        raise ValueError(f"tolerance_m must be >= 0 m, got {tolerance_m!r}")
    if leader_braking not in BRAKE_STATES:
        raise ValueError(f"leader_braking must be one of {BRAKE_STATES}, got {leader_braking!r}")
    se_f = stopping_distance(
        _finite(v_follower_mps, "v_follower_mps"), follower_profile, brake="emergency", grade=grade
    )
    se_l = stopping_distance(
        _finite(v_leader_mps, "v_leader_mps"), leader, brake="emergency", grade=grade
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
        raise ValueError(f"distance_to_target_m must be finite, got {distance_to_target_m!r}")
    v_t = float(_speeds(target_speed_mps, "target_speed_mps"))
    delay = _finite(delay_s, "delay_s")
    if delay < 0.0:
        raise ValueError(f"delay_s must be >= 0 s, got {delay_s!r}")
    a = effective_deceleration(profile, brake=brake, grade=grade)
    c = v_t * v_t + 2.0 * a * np.maximum(d_arr, 0.0)
    a_t = a * delay
    # Rationalised root c / (aT + sqrt((aT)² + c)): no cancellation for large aT.
    denom = a_t + np.sqrt(a_t * a_t + c)
    v = np.divide(c, denom, out=np.zeros_like(c), where=denom > 0.0)
    return _out(np.maximum(v, v_t), distance_to_target_m)


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
    length = _finite(target_distance_m, "target_distance_m")
    if length <= 0.0:
        raise ValueError(f"target_distance_m must be > 0 m, got {target_distance_m!r}")
    step = _finite(step_m, "step_m")
    if step <= 0.0:
        raise ValueError(f"step_m must be > 0 m, got {step_m!r}")
    v_t = float(_speeds(target_speed_mps, "target_speed_mps"))
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
    speeds = np.empty_like(positions)
    speeds[0] = v_t
    for k in range(n_steps):
        ds = positions[k] - positions[k + 1]
        speeds[k + 1] = math.sqrt(speeds[k] ** 2 + 2.0 * a_eff[k] * ds)
    return positions[::-1].copy(), speeds[::-1].copy()


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
    v = float(_speeds(v_mps, "v_mps"))
    d = _finite(distance_to_target_m, "distance_to_target_m")
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
