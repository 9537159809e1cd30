"""Braking profiles: what one kind of vehicle can do when it brakes, and its warning margins.

Profiles ``tram`` (traction 2.0, service 1.2, emergency 2.8 m/s²), ``light_rail`` and
``mainline`` are shipped as TOML files; :func:`load_profile` also reads your own.

>>> from antikol.analysis.profiles import load_profile
>>> load_profile("tram").service_decel_mps2
1.2
"""

from __future__ import annotations

import math
import numbers
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from importlib import resources
from pathlib import Path
from typing import Any, Final, Literal

from antikol.errors import InputFileError, InvalidArgumentError, ProfileError

__all__ = ["BRAKES", "G_MPS2", "Brake", "BrakingProfile", "load_profile", "profile_names"]

#: Standard gravity, m/s².
G_MPS2: Final = 9.80665

Brake = Literal["service", "emergency"]
#: The brakes a distance can be computed for, weakest first.
BRAKES: Final[tuple[Brake, ...]] = ("service", "emergency")

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
    vehicle_length_m : float
        Length of a typical vehicle of this kind, m: used for a report without
        ``length_m``.
    antenna_offset_fraction : float
        Where the GPS antenna usually sits, as a fraction of the length back from the
        front (0.5: mid-vehicle): used for a report without ``antenna_offset_m``.
    antenna_offset_sigma_fraction : float
        Uncertainty of that assumed antenna position, as a fraction of the length: the
        gaps of such vehicles are shortened by it (see :mod:`antikol.analysis.ends`).
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
    vehicle_length_m: float = 32.0
    antenna_offset_fraction: float = 0.5
    antenna_offset_sigma_fraction: float = 0.1
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
        if self.antenna_offset_fraction > 1.0:
            raise _field_error(
                "antenna_offset_fraction", self.antenna_offset_fraction, "must be in [0, 1]"
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
        check_brake(brake)
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
        check_brake(brake)
        return self.service_buildup_s if brake == "service" else self.emergency_buildup_s

    @classmethod
    def from_mapping(
        cls, data: Mapping[str, Any], *, source: str = "profile", default_name: str | None = None
    ) -> BrakingProfile:
        """Build a profile from a mapping with the field names as keys (as in the TOML files).

        Every braking field is required; the vehicle geometry fields
        (``vehicle_length_m``, ``antenna_offset_fraction``,
        ``antenna_offset_sigma_fraction``) default to the tram's; ``name`` defaults to
        ``default_name`` and ``description`` to an empty string.

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
        missing = [
            name for name in _NUMERIC_FIELDS if name not in data and name not in _OPTIONAL_FIELDS
        ]
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
    "vehicle_length_m",
    "antenna_offset_fraction",
    "antenna_offset_sigma_fraction",
)
#: Vehicle geometry: optional in a profile file (the tram's values otherwise).
_OPTIONAL_FIELDS: Final = (
    "vehicle_length_m",
    "antenna_offset_fraction",
    "antenna_offset_sigma_fraction",
)
_POSITIVE_FIELDS: Final = (
    "traction_mps2",
    "service_decel_mps2",
    "emergency_decel_mps2",
    "max_speed_mps",
    "vehicle_length_m",
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


def check_brake(brake: str) -> None:
    """Reject a brake name that is not one of :data:`BRAKES`."""
    if brake not in BRAKES:
        raise InvalidArgumentError("brake", brake, f"must be one of {BRAKES}")
