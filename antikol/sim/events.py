"""Scripted events and planned stops of a simulated tram.

Stops
    The front stops at every stop position on the route (exactly, within 0.1 m), waits
    ``dwell_s`` and leaves with the traction limit (:class:`StopCall`).
Events
    A :class:`ScriptEvent` can brake to a standstill with the emergency brake (after the
    profile's emergency build-up time, so the stopping distance equals
    :func:`antikol.analysis.braking.stopping_distance` with ``brake="emergency"`` less its
    standstill margin), hold the tram, cap its speed or make the driver ignore leaders and
    conflicts (to stage collisions).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Final, Literal

__all__ = ["DEFAULT_DWELL_S", "EVENT_KINDS", "EventKind", "ScriptEvent", "StopCall", "resolved"]

#: Default dwell time at a stop, s.
DEFAULT_DWELL_S: Final = 20.0

EventKind = Literal["emergency_brake", "hold", "speed_cap", "inattentive"]
#: The kinds of :class:`ScriptEvent`.
EVENT_KINDS: Final[tuple[EventKind, ...]] = ("emergency_brake", "hold", "speed_cap", "inattentive")


@dataclass(frozen=True, slots=True)
class StopCall:
    """A planned stop: where the front stops and for how long.

    Attributes
    ----------
    distance_m : float
        Route distance of the stop position of the front, metres.
    dwell_s : float
        Time standing at the stop, s.
    name : str or None
    """

    distance_m: float
    dwell_s: float = DEFAULT_DWELL_S
    name: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "distance_m", float(self.distance_m))
        object.__setattr__(self, "dwell_s", float(self.dwell_s))
        if not math.isfinite(self.distance_m):
            raise ValueError(f"stop distance_m must be finite, got {self.distance_m!r}")
        if not (math.isfinite(self.dwell_s) and self.dwell_s >= 0.0):
            raise ValueError(f"stop dwell_s must be >= 0 s, got {self.dwell_s!r}")


@dataclass(frozen=True, slots=True)
class ScriptEvent:
    """A timed driver action in a scenario.

    Use the constructors :meth:`emergency_brake`, :meth:`hold`, :meth:`speed_cap` and
    :meth:`inattentive`, or :meth:`parse` a tuple.

    Attributes
    ----------
    kind : {"emergency_brake", "hold", "speed_cap", "inattentive"}
        ``emergency_brake``: from ``t_s`` the traction is cut, and after the profile's
        emergency build-up time the tram decelerates at the emergency rate to a
        standstill; it stays there until ``until_s`` (None: for good). Reports carry
        ``braking="emergency"`` from ``t_s`` to ``until_s``.
        ``hold``: from ``t_s`` to ``until_s`` the driver brakes to a standstill (planning
        deceleration) and waits.
        ``speed_cap``: from ``t_s`` to ``until_s`` the tram runs at most ``speed_mps``.
        ``inattentive``: from ``t_s`` to ``until_s`` the driver ignores leaders and
        conflict points (stops, speed limits and the route end are still kept).
    t_s : float
        Start, simulation seconds.
    until_s : float or None
        End, simulation seconds; None: until the end of the run.
    speed_mps : float or None
        The cap of ``speed_cap``, m/s.
    """

    kind: EventKind
    t_s: float
    until_s: float | None = None
    speed_mps: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in EVENT_KINDS:
            raise ValueError(f"unknown script event kind {self.kind!r}; use one of {EVENT_KINDS}")
        if not (isinstance(self.t_s, int | float) and math.isfinite(self.t_s)):
            raise ValueError(f"{self.kind} event: t_s must be a finite time, got {self.t_s!r}")
        object.__setattr__(self, "t_s", float(self.t_s))
        if self.until_s is not None:
            if not (math.isfinite(self.until_s) and self.until_s >= self.t_s):
                raise ValueError(
                    f"{self.kind} event: until_s={self.until_s!r} must be >= t_s={self.t_s!r}"
                )
            object.__setattr__(self, "until_s", float(self.until_s))
        if self.kind == "speed_cap":
            if self.speed_mps is None or not (
                math.isfinite(self.speed_mps) and self.speed_mps >= 0.0
            ):
                raise ValueError(
                    f"speed_cap event needs speed_mps >= 0 m/s, got {self.speed_mps!r}"
                )
            object.__setattr__(self, "speed_mps", float(self.speed_mps))
        elif self.speed_mps is not None:
            raise ValueError(f"{self.kind} event takes no speed_mps")

    @classmethod
    def emergency_brake(cls, t_s: float, *, release_s: float | None = None) -> ScriptEvent:
        """Emergency brake at ``t_s`` (s); the driver releases at ``release_s`` (s) or never."""
        return cls("emergency_brake", t_s, release_s)

    @classmethod
    def hold(cls, t_from_s: float, t_to_s: float | None) -> ScriptEvent:
        """Stop as soon as comfortably possible at ``t_from_s`` and wait until ``t_to_s`` (s)."""
        return cls("hold", t_from_s, t_to_s)

    @classmethod
    def speed_cap(
        cls, t_s: float, speed_mps: float, *, until_s: float | None = None
    ) -> ScriptEvent:
        """Run at most ``speed_mps`` (m/s) from ``t_s`` until ``until_s`` (s)."""
        return cls("speed_cap", t_s, until_s, speed_mps)

    @classmethod
    def inattentive(cls, t_from_s: float, t_to_s: float | None = None) -> ScriptEvent:
        """Ignore leaders and conflict points from ``t_from_s`` until ``t_to_s`` (s)."""
        return cls("inattentive", t_from_s, t_to_s)

    @classmethod
    def parse(cls, item: ScriptEvent | Sequence[Any]) -> ScriptEvent:
        """An event from a tuple.

        Accepted: ``("emergency_brake", t[, release])``, ``("hold", t_from, t_to)``,
        ``("speed_cap", t, v[, until])``, ``("inattentive", t_from[, t_to])``.

        Raises
        ------
        ValueError
            Unknown kind or wrong number of values.
        """
        if isinstance(item, ScriptEvent):
            return item
        if isinstance(item, str) or not isinstance(item, Sequence) or not item:
            raise ValueError(f"a script event must be a ScriptEvent or a tuple, got {item!r}")
        kind, *args = item
        if kind not in EVENT_KINDS:
            raise ValueError(f"unknown script event kind {kind!r}; use one of {EVENT_KINDS}")
        arity = {"emergency_brake": (1, 2), "hold": (2, 2), "speed_cap": (2, 3)}
        lo, hi = arity.get(str(kind), (1, 2))
        if not lo <= len(args) <= hi:
            raise ValueError(
                f"cannot read script event {tuple(item)!r}: expected ('emergency_brake', t"
                "[, release]), ('hold', t_from, t_to), ('speed_cap', t, v[, until]) or "
                "('inattentive', t_from[, t_to])"
            )
        if kind == "speed_cap":
            return cls("speed_cap", args[0], args[2] if len(args) > 2 else None, args[1])
        return cls(kind, args[0], args[1] if len(args) > 1 else None)

    def active(self, t_s: float) -> bool:
        """Whether the event is in force at simulation time ``t_s`` (s)."""
        return self.t_s <= t_s < (math.inf if self.until_s is None else self.until_s)


def resolved(value: float | None) -> float:
    """A field default that ``__post_init__`` has already filled in (never None).

    Raises
    ------
    AssertionError
        The value is still None (a bug: the record skipped its own validation).
    """
    if value is None:  # pragma: no cover - resolved in __post_init__
        raise AssertionError("unresolved default")
    return value
