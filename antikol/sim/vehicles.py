"""Vehicle specs: one simulated tram's route, vehicle, driver and timetable.

A :class:`TramSpec` is validated on construction and resolves its defaults (antenna
position, maximum speed, planning deceleration, stops and script order), so the rest of
the simulator reads plain numbers from it.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Final

from antikol.analysis.braking import BrakingProfile, load_profile
from antikol.report import MAX_VEHICLE_ID_BYTES
from antikol.sim.events import DEFAULT_DWELL_S, ScriptEvent, StopCall, resolved
from antikol.sim.routes import Route

__all__ = ["TramSpec"]

_COMFORT_FRACTION: Final = 0.8  # default planning deceleration / service deceleration


@functools.lru_cache(maxsize=1)
def _tram_profile() -> BrakingProfile:
    return load_profile("tram")


@dataclass(frozen=True)
class TramSpec:
    """One simulated tram: route, vehicle, driver and timetable.

    Parameters
    ----------
    vehicle_id : str
        1 to 32 UTF-8 bytes, printable (it becomes a report field and an NMEA file name).
    route : Route
    length_m : float
        Vehicle length, metres (default 32).
    antenna_offset_m : float, optional
        Distance from the front back to the GPS antenna, metres; default half the length.
    profile : BrakingProfile
        Traction and brakes; default the shipped ``tram`` profile.
    depart_s : float
        Simulation time at which the tram appears at its start, s. It waits (absent) while
        another tram blocks the start.
    initial_speed_mps : float
        Speed when it appears, m/s.
    max_speed_mps : float, optional
        Vehicle maximum speed, m/s; default the profile's.
    stops : sequence of StopCall or (distance_m, dwell_s), optional
        Planned stops (route distances of the front, m, and dwell times, s); default every
        map stop on the route (:func:`~antikol.sim.routes.map_stops_on_route`) with
        ``dwell_s``. Pass ``()`` for a non-stop run.
    dwell_s : float
        Dwell time of the default stops, s (default 20).
    cruise_factor : float
        Fraction of the allowed speed the driver aims at, in (0, 1] (default 0.95).
    script : sequence of ScriptEvent or tuple
        Timed events (tuples are read with :meth:`~antikol.sim.events.ScriptEvent.parse`).
    broadcast_route : bool
        Put the route's edge ids ahead (at most 255) in every report.
    exit_at_end : bool
        Drive through the route end and leave the simulation there, instead of stopping at
        the end and staying.
    lateral_accel_mps2 : float
        Lateral acceleration allowed in curves, m/s² (default 1.0).
    standstill_gap_m : float
        Gap kept to a stopped leader, metres (default 10).
    time_headway_s : float
        Time headway kept to a moving leader, s (default 2): the gap is
        ``standstill_gap_m + time_headway_s · speed``.
    comfort_decel_mps2 : float, optional
        Deceleration the driver plans with, m/s²; default 0.8 × the service brake. It may
        exceed neither the service brake.

    Raises
    ------
    ValueError
        A value is out of range; the message names the field and the vehicle.
    """

    vehicle_id: str
    route: Route
    length_m: float = 32.0
    antenna_offset_m: float | None = None
    profile: BrakingProfile = field(default_factory=_tram_profile)
    depart_s: float = 0.0
    initial_speed_mps: float = 0.0
    max_speed_mps: float | None = None
    stops: tuple[StopCall, ...] | None = None
    dwell_s: float = DEFAULT_DWELL_S
    cruise_factor: float = 0.95
    script: tuple[ScriptEvent, ...] = ()
    broadcast_route: bool = False
    exit_at_end: bool = False
    lateral_accel_mps2: float = 1.0
    standstill_gap_m: float = 10.0
    time_headway_s: float = 2.0
    comfort_decel_mps2: float | None = None

    def __post_init__(self) -> None:
        vid = self.vehicle_id
        if not isinstance(vid, str) or not vid or not vid.isprintable():
            raise ValueError(f"vehicle_id must be a non-empty printable string, got {vid!r}")
        if len(vid.encode("utf-8")) > MAX_VEHICLE_ID_BYTES:
            raise ValueError(f"vehicle_id {vid!r} is longer than {MAX_VEHICLE_ID_BYTES} bytes")
        if not isinstance(self.route, Route):
            raise ValueError(f"tram {vid}: route must be a Route, got {type(self.route)!r}")
        if not isinstance(self.profile, BrakingProfile):
            raise ValueError(f"tram {vid}: profile must be a BrakingProfile")

        def check(name: str, value: Any, ok: bool, what: str) -> float:
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"tram {vid}: {name} must be a number, got {value!r}")
            if not (math.isfinite(value) and ok):
                raise ValueError(f"tram {vid}: {name}={value!r} {what}")
            return float(value)

        length = check("length_m", self.length_m, self.length_m > 0, "must be > 0 m")
        object.__setattr__(self, "length_m", length)
        ant = length / 2.0 if self.antenna_offset_m is None else self.antenna_offset_m
        ant = check("antenna_offset_m", ant, 0.0 <= ant <= length, "must be in [0, length_m]")
        object.__setattr__(self, "antenna_offset_m", ant)
        vmax = self.profile.max_speed_mps if self.max_speed_mps is None else self.max_speed_mps
        vmax = check("max_speed_mps", vmax, vmax > 0, "must be > 0 m/s")
        object.__setattr__(self, "max_speed_mps", vmax)
        for name, ok, what in (
            ("depart_s", self.depart_s >= 0, "must be >= 0 s"),
            ("initial_speed_mps", 0 <= self.initial_speed_mps <= vmax, "must be in [0, max]"),
            ("dwell_s", self.dwell_s >= 0, "must be >= 0 s"),
            ("cruise_factor", 0 < self.cruise_factor <= 1, "must be in (0, 1]"),
            ("lateral_accel_mps2", self.lateral_accel_mps2 > 0, "must be > 0 m/s²"),
            ("standstill_gap_m", self.standstill_gap_m >= 0, "must be >= 0 m"),
            ("time_headway_s", self.time_headway_s >= 0, "must be >= 0 s"),
        ):
            object.__setattr__(self, name, check(name, getattr(self, name), ok, what))
        service = self.profile.service_decel_mps2
        comfort = (
            _COMFORT_FRACTION * service
            if self.comfort_decel_mps2 is None
            else (self.comfort_decel_mps2)
        )
        comfort = check(
            "comfort_decel_mps2", comfort, 0 < comfort <= service, f"must be in (0, {service:g}]"
        )
        object.__setattr__(self, "comfort_decel_mps2", comfort)
        if self.stops is not None:
            calls = []
            for item in self.stops:
                if isinstance(item, StopCall):
                    calls.append(item)
                elif isinstance(item, Sequence) and len(item) in (2, 3):
                    calls.append(StopCall(*item))
                else:
                    raise ValueError(
                        f"tram {vid}: a stop must be a StopCall or (distance_m, dwell_s), "
                        f"got {item!r}"
                    )
            length_route = self.route.length_m
            for c in calls:
                if not -1e-6 <= c.distance_m <= length_route + 1e-6:
                    raise ValueError(
                        f"tram {vid}: stop at {c.distance_m:.3f} m is outside its route "
                        f"(0..{length_route:.3f} m)"
                    )
            object.__setattr__(self, "stops", tuple(sorted(calls, key=lambda c: c.distance_m)))
        script = tuple(ScriptEvent.parse(e) for e in self.script)
        object.__setattr__(self, "script", tuple(sorted(script, key=lambda e: e.t_s)))

    @property
    def antenna_m(self) -> float:
        """The resolved antenna offset behind the front, metres."""
        return resolved(self.antenna_offset_m)

    @property
    def vmax_mps(self) -> float:
        """The resolved vehicle maximum speed, m/s."""
        return resolved(self.max_speed_mps)

    @property
    def plan_decel_mps2(self) -> float:
        """The resolved planning (comfort) deceleration, m/s²."""
        return resolved(self.comfort_decel_mps2)
