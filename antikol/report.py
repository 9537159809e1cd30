"""Vehicle reports: one position, speed and course sample of one vehicle.

A :class:`VehicleReport` is what every input (own GPS receiver, radio packets, replay logs,
the simulator) is turned into before the analyser sees it. Values are validated on
construction, so a report that exists is physically plausible.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from antikol.errors import InvalidReportError
from antikol.kinds import BRAKE_STATES, BrakeState
from antikol.numeric import finite_float, why_not_finite

__all__ = [
    "ESTIMATED_FIX_QUALITY",
    "MAX_ROUTE_EDGES",
    "MAX_SPEED_MPS",
    "MAX_VEHICLE_ID_BYTES",
    "ReportedTrackPosition",
    "VehicleReport",
    "one_per_vehicle",
]

#: Upper bound on a plausible rail vehicle speed (360 km/h); anything faster is an error.
MAX_SPEED_MPS = 100.0
#: Longest vehicle identifier in UTF-8 bytes (it must fit the radio frame).
MAX_VEHICLE_ID_BYTES = 32
#: Longest planned route carried in a report (number of track edges).
MAX_ROUTE_EDGES = 255
#: GGA fix quality of a position estimated without a fix (dead reckoning).
ESTIMATED_FIX_QUALITY = 6


@dataclass(frozen=True, slots=True)
class ReportedTrackPosition:
    """A vehicle's own estimate of where it is on the track map.

    Parameters
    ----------
    edge_id : int
        Track edge identifier in the shared map.
    offset_m : float
        Distance from the start of the edge (its first vertex), metres.
    direction : int
        +1 when moving in the edge's geometric direction, -1 against it.
    """

    edge_id: int
    offset_m: float
    direction: int

    def __post_init__(self) -> None:
        if isinstance(self.edge_id, bool) or not isinstance(self.edge_id, int):
            raise InvalidReportError("track_position.edge_id", self.edge_id, "must be an int")
        if self.edge_id < 0 or self.edge_id > 0xFFFFFFFF:
            raise InvalidReportError("track_position.edge_id", self.edge_id, "out of 0..2^32-1")
        _store_float(self, "offset_m", "track_position.offset_m")
        if self.offset_m < 0:
            raise InvalidReportError("track_position.offset_m", self.offset_m, "negative")
        if type(self.direction) is not int or self.direction not in (1, -1):
            raise InvalidReportError("track_position.direction", self.direction, "must be +1 or -1")


@dataclass(frozen=True, slots=True)
class VehicleReport:
    """One report of a vehicle's state.

    Parameters
    ----------
    vehicle_id : str
        Identifier, 1 to 32 UTF-8 bytes of printable characters, not only spaces.
    t : float
        Time of the fix, seconds (any epoch; all reports of a run share it).
    lat, lon : float
        WGS84 latitude and longitude of the antenna, degrees.
    speed_mps : float
        Speed over ground, m/s, in ``[0, 100]``.
    course_deg : float
        Course over ground, degrees clockwise from true north, in ``[0, 360)``
        (360 is accepted and stored as 0).
    braking : {"none", "service", "emergency"}
        Brake state announced by the vehicle.
    length_m : float, optional
        Vehicle length, metres.
    antenna_offset_m : float, optional
        Distance from the vehicle's front (in its running direction) back to the GPS
        antenna, metres. With ``length_m`` it places both vehicle ends.
    route : tuple of int, optional
        Planned route as track edge ids of the shared map, in running order.
    track_position : ReportedTrackPosition, optional
        The vehicle's own matched track position.
    seq : int, optional
        Sender sequence number (radio frames).
    hdop : float, optional
        Horizontal dilution of precision of the fix (GGA).
    fix_quality : int, optional
        GGA fix quality indicator (0 invalid, 1 GPS, 2 DGPS, 4 RTK fixed, ...). ``0`` means
        the report carries no position fix: ``lat``/``lon`` are the last known position
        and are not used as a measurement (a tunnel); with ``odometer_m`` the vehicle is
        dead-reckoned along the track. ``6`` (:data:`ESTIMATED_FIX_QUALITY`) is a position
        the sender estimated without a fix: dead-reckoned the same way, its position only
        weighs the branches (:mod:`antikol.positioning.estimates`).
    odometer_m : float, optional
        Distance the vehicle has travelled, m, from any origin (its odometer or the
        operator feed's travelled distance). Positioning uses its increments as the
        distance travelled; a reading that goes back (a new trip's count) or a step the
        reported speeds cannot have run (a glitch, a frozen counter) is no measurement,
        and that step runs on the speeds.

    Raises
    ------
    InvalidReportError
        A value is NaN, infinite or out of range; the message names the field.

    Notes
    -----
    Real-valued fields are stored as ``float``: an ``int`` is converted (beyond 2**53 that
    rounds it to the nearest double), so a report holds what its radio frame carries.
    """

    vehicle_id: str
    t: float
    lat: float
    lon: float
    speed_mps: float
    course_deg: float
    braking: BrakeState = "none"
    length_m: float | None = None
    antenna_offset_m: float | None = None
    route: tuple[int, ...] | None = None
    track_position: ReportedTrackPosition | None = None
    seq: int | None = None
    hdop: float | None = None
    fix_quality: int | None = None
    odometer_m: float | None = None

    def __post_init__(self) -> None:
        _check_vehicle_id(self.vehicle_id)
        _store_float(self, "t")
        _store_float(self, "lat")
        _store_float(self, "lon")
        _store_float(self, "speed_mps")
        _store_float(self, "course_deg")
        if abs(self.lat) > 90.0:
            raise InvalidReportError("lat", self.lat, "|lat| > 90 degrees")
        if abs(self.lon) > 180.0:
            raise InvalidReportError("lon", self.lon, "|lon| > 180 degrees")
        if self.speed_mps < 0.0:
            raise InvalidReportError("speed_mps", self.speed_mps, "negative speed")
        if self.speed_mps > MAX_SPEED_MPS:
            raise InvalidReportError("speed_mps", self.speed_mps, f"above {MAX_SPEED_MPS:g} m/s")
        if not 0.0 <= self.course_deg <= 360.0:
            raise InvalidReportError("course_deg", self.course_deg, "outside 0..360 degrees")
        if self.course_deg == 360.0:
            object.__setattr__(self, "course_deg", 0.0)
        if not isinstance(self.braking, str) or self.braking not in BRAKE_STATES:
            raise InvalidReportError("braking", self.braking, f"must be one of {BRAKE_STATES}")
        if self.length_m is not None:
            _store_float(self, "length_m")
            if not 0.0 < self.length_m <= 1000.0:
                raise InvalidReportError("length_m", self.length_m, "outside (0, 1000] m")
        if self.antenna_offset_m is not None:
            _store_float(self, "antenna_offset_m")
            if self.antenna_offset_m < 0.0:
                raise InvalidReportError("antenna_offset_m", self.antenna_offset_m, "negative")
            if self.length_m is not None and self.antenna_offset_m > self.length_m:
                raise InvalidReportError(
                    "antenna_offset_m", self.antenna_offset_m, "beyond the vehicle length"
                )
        if self.route is not None:
            if not isinstance(self.route, tuple):
                object.__setattr__(self, "route", _edge_sequence(self.route))
            if len(self.route) > MAX_ROUTE_EDGES:
                raise InvalidReportError(
                    "route", len(self.route), f"more than {MAX_ROUTE_EDGES} edges"
                )
            for edge in self.route:
                if (
                    isinstance(edge, bool)
                    or not isinstance(edge, int)
                    or not (0 <= edge <= 0xFFFFFFFF)
                ):
                    raise InvalidReportError("route", edge, "edge ids must be ints in 0..2^32-1")
        if self.track_position is not None and not isinstance(
            self.track_position, ReportedTrackPosition
        ):
            raise InvalidReportError(
                "track_position", self.track_position, "must be a ReportedTrackPosition"
            )
        if self.seq is not None and (
            isinstance(self.seq, bool) or not isinstance(self.seq, int) or self.seq < 0
        ):
            raise InvalidReportError("seq", self.seq, "must be a non-negative int")
        if self.hdop is not None:
            _store_float(self, "hdop")
            if self.hdop < 0.0:
                raise InvalidReportError("hdop", self.hdop, "negative")
        if self.fix_quality is not None and (
            isinstance(self.fix_quality, bool)
            or not isinstance(self.fix_quality, int)
            or not 0 <= self.fix_quality <= 9
        ):
            raise InvalidReportError("fix_quality", self.fix_quality, "must be an int 0..9")
        if self.odometer_m is not None:
            _store_float(self, "odometer_m")
            if self.odometer_m < 0.0:
                raise InvalidReportError("odometer_m", self.odometer_m, "negative")

    @property
    def course_rad(self) -> float:
        """Course over ground in radians, clockwise from north."""
        return math.radians(self.course_deg)


def _store_float(obj: object, attr: str, name: str | None = None) -> None:
    """Check that ``obj.attr`` is a finite real number and store it as a float."""
    value = getattr(obj, attr)
    _require_finite(name or attr, value)
    if type(value) is not float:
        object.__setattr__(obj, attr, float(value))


def _require_finite(name: str, value: object) -> None:
    if finite_float(value) is None:
        raise InvalidReportError(name, value, why_not_finite(value))


def _edge_sequence(route: object) -> tuple[object, ...]:
    """A planned route given as a list (or another iterable) as a tuple."""
    if isinstance(route, (str, bytes, bytearray)):
        raise InvalidReportError("route", route, "must be a sequence of edge ids")
    try:
        return tuple(route)  # type: ignore[arg-type]
    except TypeError:
        raise InvalidReportError("route", route, "must be a sequence of edge ids") from None


def _check_vehicle_id(vehicle_id: object) -> None:
    if not isinstance(vehicle_id, str):
        raise InvalidReportError("vehicle_id", vehicle_id, "must be a str")
    if not vehicle_id:
        raise InvalidReportError("vehicle_id", vehicle_id, "empty")
    # a str of more characters than the limit has more UTF-8 bytes: no need to encode it
    too_long = f"longer than {MAX_VEHICLE_ID_BYTES} UTF-8 bytes"
    if len(vehicle_id) > MAX_VEHICLE_ID_BYTES:
        raise InvalidReportError("vehicle_id", vehicle_id, too_long)
    try:
        encoded = vehicle_id.encode("utf-8")
    except UnicodeEncodeError:
        raise InvalidReportError(
            "vehicle_id", vehicle_id, "not valid Unicode text (a lone surrogate)"
        ) from None
    if len(encoded) > MAX_VEHICLE_ID_BYTES:
        raise InvalidReportError("vehicle_id", vehicle_id, too_long)
    if not vehicle_id.isprintable():
        raise InvalidReportError("vehicle_id", vehicle_id, "contains control characters")
    if not vehicle_id.strip():
        raise InvalidReportError("vehicle_id", vehicle_id, "blank (only spaces)")


def one_per_vehicle(reports: Sequence[VehicleReport]) -> list[list[VehicleReport]]:
    """Split reports into runs with at most one report per vehicle, keeping their order.

    The k-th run holds each vehicle's k-th report; a batch with one report per vehicle
    (the usual cycle) is one run.

    >>> a1, b1, a2 = (VehicleReport(v, t, 50.06, 19.94, 5.0, 90.0)
    ...               for v, t in (("A", 1.0), ("B", 1.0), ("A", 2.0)))
    >>> [[(r.vehicle_id, r.t) for r in run] for run in one_per_vehicle([a1, b1, a2])]
    [[('A', 1.0), ('B', 1.0)], [('A', 2.0)]]
    """
    if len({r.vehicle_id for r in reports}) == len(reports):
        return [list(reports)] if reports else []
    runs: list[list[VehicleReport]] = []
    seen: dict[str, int] = {}
    for r in reports:
        k = seen[r.vehicle_id] = seen.get(r.vehicle_id, -1) + 1
        if k == len(runs):
            runs.append([])
        runs[k].append(r)
    return runs
