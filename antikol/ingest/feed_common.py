"""What the operator-feed readers share: turning loose feed records into checked reports.

Operator feeds (:mod:`antikol.ingest.hfp`, :mod:`antikol.ingest.gtfsrt`) leave out what a
:class:`~antikol.report.VehicleReport` needs now and then: a speed or a heading while
standing, a position when the location source is not GPS. :class:`FeedCollector` takes one
record at a time and

* derives a missing speed and course over ground from the vehicle's previous position
  (WGS84 geodesic through pyproj), or from its odometer for the speed;
* keeps the last known position for records without a position fix (``fix_quality`` 0),
  and passes a position the vehicle estimated itself as one (``fix_quality`` 6);
* passes an odometer reading that goes back on, noted: many feeds count the distance from
  the start of the trip, back to zero at every new trip, and the positioner takes such a
  step on the speeds (:mod:`antikol.positioning.feedfaults`); dropping the reading would
  drop every later one of the trip as well;
* never makes up a course: a moving vehicle's first record without one (nothing to derive
  it from) is no report, noted, but the next record derives its speed and course from it;
* skips exact repeats of a vehicle's last record time (feeds repeat snapshots), counted;
* checks each record's own values first (:data:`FEED_TIME_RANGE` for its time): a bad
  record is rejected for what is wrong with it and is never the position, time or
  odometer its vehicle's next record derives a speed or a course from;
* converts the speed field from the feed's unit (``speed_unit``: the specifications say
  m/s, some GTFS-realtime producers send km/h; :data:`SPEED_UNITS`);
* turns every invalid value into a :class:`~antikol.ingest.replaylog.RowProblem` naming
  the record and the field — never an exception, never a silent loss (``strict`` raises
  :class:`~antikol.errors.ReplayError` at the first bad record instead).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Final, NamedTuple

from pyproj import Geod

from antikol.errors import InvalidArgumentError, InvalidReportError, ReplayError
from antikol.ingest.nmea_spec import KMH_PER_MPS, KNOT_MPS
from antikol.ingest.replaylog import ReplayLog, RowProblem
from antikol.numeric import why_not_finite
from antikol.report import ESTIMATED_FIX_QUALITY, MAX_SPEED_MPS, VehicleReport
from antikol.thresholds import COURSE_MIN_SPEED_MPS

__all__ = [
    "FEED_TIME_RANGE",
    "SPEED_UNITS",
    "FeedCollector",
    "FeedRecord",
    "record_order",
    "speed_unit_factor",
    "time_problem",
]

logger = logging.getLogger(__name__)

_GEOD = Geod(ellps="WGS84")
#: m/s per unit of a speed field, by the unit's name.
SPEED_UNITS: Mapping[str, float] = MappingProxyType(
    {"m/s": 1.0, "km/h": 1.0 / KMH_PER_MPS, "kn": KNOT_MPS, "mph": 0.44704}
)


def speed_unit_factor(unit: str) -> float:
    """m/s per ``unit`` (a name of :data:`SPEED_UNITS`).

    Raises
    ------
    InvalidArgumentError
        An unknown unit (the error names ``speed_unit`` and the units known).

    >>> round(speed_unit_factor("km/h") * 36.0, 6)
    10.0
    """
    factor = SPEED_UNITS.get(unit)
    if factor is None:
        raise InvalidArgumentError("speed_unit", unit, f"one of {', '.join(SPEED_UNITS)}")
    return factor


#: The times a feed record may have, POSIX s: from 1970 to the end of the year 9999. A
#: time outside is no time a feed means (a field in another unit, a default, garbage), and
#: beyond 9999 no date can show it.
FEED_TIME_RANGE: Final = (0.0, 253_402_300_800.0)


def time_problem(t: float) -> str | None:
    """Why ``t`` (POSIX s) is no time of a feed record, or None when it is one.

    >>> time_problem(1702540801.0) is None, time_problem(1e30)
    (True, 'not a time in the years 1970 to 9999')
    """
    if not math.isfinite(t):
        return "must be finite (NaN or infinite)"
    if not FEED_TIME_RANGE[0] <= t < FEED_TIME_RANGE[1]:
        return "not a time in the years 1970 to 9999"
    return None


#: A course is derived from two fixes at least this far apart, m: from one second's run
#: of a tram (a few metres) the fixes' own errors give courses off by tens of degrees.
_COURSE_BASELINE_M = 15.0
#: Fixes kept per vehicle to derive a course or a speed from, s.
_TRAIL_S = 10.0
#: A speed is derived over the fixes of the last few seconds (not the last one alone), s.
_SPEED_BASELINE_S = 5.0


@dataclass(frozen=True, slots=True)
class FeedRecord:
    """One vehicle-position record as a feed gives it (None: not given).

    Attributes
    ----------
    record : int
        Line or record number in its file (1-based).
    source : str
        The file it came from.
    vehicle_id : str
    t : float
        Seconds since the Unix epoch (UTC).
    lat, lon : float or None
        Degrees.
    speed_mps, course_deg, odometer_m : float or None
        Speed as the feed gives it (m/s unless the collector's ``speed_factor`` says
        otherwise), degrees, m.
    has_fix : bool
        The position is a GPS fix (False: odometer, dead reckoning, manual or unknown).
    estimated : bool
        Without a fix, the position is an estimate of the vehicle's own (moved along its
        route by the odometer, dead reckoning): the report's ``fix_quality`` is 6, whose
        position weighs the branches (:mod:`antikol.positioning.estimates`), not 0.
    """

    record: int
    source: str
    vehicle_id: str
    t: float
    lat: float | None
    lon: float | None
    speed_mps: float | None
    course_deg: float | None
    odometer_m: float | None
    has_fix: bool = True
    estimated: bool = False

    def __reduce__(self) -> tuple[type[FeedRecord], tuple[object, ...]]:
        # pickled as its fields (sorting spills records to disk): several times faster
        # than a frozen slotted dataclass's state, set field by field
        return FeedRecord, (
            self.record,
            self.source,
            self.vehicle_id,
            self.t,
            self.lat,
            self.lon,
            self.speed_mps,
            self.course_deg,
            self.odometer_m,
            self.has_fix,
            self.estimated,
        )


def record_order(rec: FeedRecord) -> tuple[float, str]:
    """The order in which :class:`FeedCollector` takes records: by time (POSIX s), then
    vehicle id (a stable sort keeps each vehicle's records of one time in file order).

    A time that is NaN sorts first (it is rejected when taken): a NaN in the keys would
    leave the records around it out of order.

    >>> rec = FeedRecord(7, "f.jsonl", "40/412", 1702540801.0, 60.17, 24.94, 8.2, 91.0, None)
    >>> record_order(rec)
    (1702540801.0, '40/412')
    """
    return (rec.t if rec.t == rec.t else -math.inf), rec.vehicle_id


class _Fix(NamedTuple):
    t: float
    lat: float
    lon: float


#: Two positions of a vehicle closer than this are the same one, degrees (about 0.1 m).
_SAME_POSITION_DEG = 1e-6


def _moved(last: _Last, rec: FeedRecord) -> bool:
    """Whether a record gives another position than the vehicle's last one."""
    if rec.lat is None or rec.lon is None:
        return False
    return (
        abs(rec.lat - last.lat) > _SAME_POSITION_DEG or abs(rec.lon - last.lon) > _SAME_POSITION_DEG
    )


@dataclass
class _Last:
    t: float
    lat: float
    lon: float
    course: float | None  # None: not known (never reported nor derived)
    odometer: float | None
    trail: tuple[_Fix, ...] = ()  # the vehicle's fixes of the last _TRAIL_S, oldest first

    def followed_by(
        self,
        t: float,
        lat: float,
        lon: float,
        fix: bool,
        course: float | None,
        odometer: float | None,
    ) -> _Last:
        """The vehicle's memory after a record (a fix joins the trail)."""
        trail = tuple(f for f in self.trail if f.t >= t - _TRAIL_S)
        return _Last(t, lat, lon, course, odometer, (*trail, _Fix(t, lat, lon)) if fix else trail)


def _derived_course(trail: tuple[_Fix, ...], lat: float, lon: float) -> float | None:
    """Azimuth (degrees) from the newest fix of ``trail`` at least ``_COURSE_BASELINE_M``
    away to (lat, lon); None when every fix is nearer."""
    for f in reversed(trail):
        az, _, dist = _GEOD.inv(f.lon, f.lat, lon, lat)
        if dist >= _COURSE_BASELINE_M:
            return float(az) % 360.0
    return None


def _derived_speed(trail: tuple[_Fix, ...], t: float, lat: float, lon: float) -> float | None:
    """Mean speed (m/s) since the oldest fix of ``trail`` in the last ``_SPEED_BASELINE_S``
    (the last fix when none is that recent); None without a fix before ``t``."""
    before = [f for f in trail if f.t < t]
    if not before:
        return None
    recent = [f for f in before if f.t >= t - _SPEED_BASELINE_S] or before[-1:]
    first = recent[0]
    _, _, dist = _GEOD.inv(first.lon, first.lat, lon, lat)
    return float(dist) / (t - first.t)


def _unusable(rec: FeedRecord, speed: float | None) -> str | None:
    """What makes a record unusable on its own (None: nothing), ``speed`` in m/s.

    Checked before the record is compared with or derived from its vehicle's last one,
    and before it becomes that last one: a time of NaN or a latitude of 1000 kept as the
    reference would give the next record a made-up speed, or reject it for this one's
    fault.
    """
    why = time_problem(rec.t)
    if why is not None:
        return str(InvalidReportError("t", rec.t, why))
    values = (("lat", rec.lat, 90.0), ("lon", rec.lon, 180.0))
    for name, value, limit in values:
        if value is not None and not abs(value) <= limit:  # (False for NaN as well)
            why = why_not_finite(value) or f"|{name}| > {limit:g} degrees"
            return str(InvalidReportError(name, value, why))
    if rec.odometer_m is not None and not rec.odometer_m >= 0.0:
        why = why_not_finite(rec.odometer_m) or "negative"
        return str(InvalidReportError("odometer_m", rec.odometer_m, why))
    if speed is not None and not 0.0 <= speed <= MAX_SPEED_MPS:
        why = why_not_finite(speed) or (
            "negative speed" if speed < 0.0 else f"above {MAX_SPEED_MPS:g} m/s"
        )
        return str(InvalidReportError("speed_mps", speed, why))
    if rec.course_deg is not None and not math.isfinite(rec.course_deg):
        return str(InvalidReportError("course_deg", rec.course_deg, why_not_finite(rec.course_deg)))
    return None


@dataclass
class FeedCollector:
    """Collects feed records into a :class:`~antikol.ingest.replaylog.ReplayLog`.

    Parameters
    ----------
    source : str
        Name of the log (a file or directory).
    strict : bool
        Raise :class:`~antikol.errors.ReplayError` at the first bad record.
    speed_factor : float
        m/s per unit of the records' speeds (:func:`speed_unit_factor`).
    """

    source: str
    strict: bool = False
    speed_factor: float = 1.0
    reports: list[VehicleReport] = field(default_factory=list)
    problems: list[RowProblem] = field(default_factory=list)
    ignored: dict[str, int] = field(default_factory=dict)
    _last: dict[str, _Last] = field(default_factory=dict)

    def problem(self, record: int, source: str, reason: str, *, kept: bool = False) -> None:
        """Note a bad record (raise in strict mode unless it was kept)."""
        where = f"{source}:{record}" if source else f"record {record}"
        if self.strict and not kept:
            raise ReplayError(f"{where}: {reason}")
        self.problems.append(RowProblem(record, reason, source, kept))
        logger.debug("%s: %s%s", where, reason, " (kept)" if kept else "")

    def ignore(self, reason: str) -> None:
        """Count a valid record that is deliberately not a report."""
        self.ignored[reason] = self.ignored.get(reason, 0) + 1

    def add(self, rec: FeedRecord) -> None:
        """Turn one record into a report, kept in :attr:`reports`, or note why it cannot
        be one."""
        report = self.take(rec)
        if report is not None:
            self.reports.append(report)

    def take(self, rec: FeedRecord) -> VehicleReport | None:
        """Turn one record into a report, returned and not kept (None: noted why not).

        Records are taken in time order, each vehicle's in its file order at equal times
        (:func:`record_order`): the vehicle's last record is what the next one derives
        from and is checked against.
        """
        speed, course = rec.speed_mps, rec.course_deg
        if speed is not None:
            speed *= self.speed_factor
        bad = _unusable(rec, speed)
        if bad is not None:
            self.problem(rec.record, rec.source, bad)
            return None
        last = self._last.get(rec.vehicle_id)
        if last is not None and rec.t == last.t:
            if _moved(last, rec):  # two records disagree: which one is right is unknown
                self.problem(
                    rec.record,
                    rec.source,
                    f"a second record of the vehicle at t={rec.t!r} with another position "
                    f"({rec.lat!r}, {rec.lon!r}; the first one is kept)",
                )
            else:
                self.ignore("repeated record time of a vehicle")
            return None
        if last is not None and rec.t < last.t:
            self.problem(
                rec.record,
                rec.source,
                f"t={rec.t!r} is earlier than the vehicle's previous record ({last.t!r})",
            )
            return None
        odometer = rec.odometer_m
        last_odo = None if last is None else last.odometer
        went_back = odometer is not None and last_odo is not None and odometer < last_odo
        if went_back:
            self.problem(
                rec.record,
                rec.source,
                f"odometer {odometer!r} m is below the previous {last_odo!r} m "
                "(a new trip's count?): passed on, positioning takes the step on the speed",
                kept=True,
            )
        has_pos = rec.lat is not None and rec.lon is not None
        if has_pos and rec.lat == 0.0 and rec.lon == 0.0:
            # a receiver without a fix writing zeros, not a tram in the Gulf of Guinea
            self.problem(
                rec.record,
                rec.source,
                "position 0, 0 is no fix: passed on as a report without one",
                kept=True,
            )
            has_pos = False
        fix = rec.has_fix and has_pos
        if has_pos:
            lat, lon = float(rec.lat), float(rec.lon)  # type: ignore[arg-type]
        elif last is not None:
            lat, lon = last.lat, last.lon
        else:
            self.problem(rec.record, rec.source, "no position (lat/lon) and none known before")
            return None
        if (speed is None or course is None) and last is not None:
            if speed is None:
                if odometer is not None and last.odometer is not None and not went_back:
                    speed = (odometer - last.odometer) / (rec.t - last.t)
                elif fix:
                    speed = _derived_speed(last.trail, rec.t, lat, lon)
            if course is None:
                derived = _derived_course(last.trail, lat, lon) if fix else None
                course = last.course if derived is None else derived
        keep_odo = odometer if odometer is not None else (last.odometer if last else None)
        start = last if last is not None else _Last(rec.t, lat, lon, None, None)
        if speed is None or (course is None and speed >= COURSE_MIN_SPEED_MPS):
            # no report, but the next record derives what it lacks from this one
            missing = "no speed (spd)" if speed is None else "no course (hdg) while moving"
            self.problem(rec.record, rec.source, f"{missing} and nothing to derive it from")
            self._last[rec.vehicle_id] = start.followed_by(rec.t, lat, lon, fix, course, keep_odo)
            return None
        if rec.course_deg is not None and not 0.0 <= rec.course_deg <= 360.0:
            self.problem(
                rec.record,
                rec.source,
                f"course {rec.course_deg!r} degrees is outside 0 to 360: passed on as "
                f"{rec.course_deg % 360.0:g}",
                kept=True,
            )
        known_course = course
        quality = 1 if fix else (ESTIMATED_FIX_QUALITY if has_pos and rec.estimated else 0)
        if course is None:  # standing: no course is used below COURSE_MIN_SPEED_MPS
            course = 0.0
        try:
            report = VehicleReport(
                vehicle_id=rec.vehicle_id,
                t=rec.t,
                lat=lat,
                lon=lon,
                speed_mps=speed,
                course_deg=course % 360.0 if math.isfinite(course) else course,
                fix_quality=quality,
                odometer_m=odometer,
            )
        except InvalidReportError as exc:
            self.problem(rec.record, rec.source, str(exc))
            return None
        # (a made-up standing course is not remembered as one)
        self._last[rec.vehicle_id] = start.followed_by(
            rec.t, lat, lon, fix, None if known_course is None else report.course_deg, keep_odo
        )
        return report

    def log(self) -> ReplayLog:
        """The reports in time order (then vehicle id), the problems in file and line order,
        and the ignored counts."""
        reports = sorted(self.reports, key=lambda r: (r.t, r.vehicle_id))
        problems = sorted(self.problems, key=lambda p: (p.source, p.line))
        return ReplayLog(reports, problems, self.source, dict(self.ignored))
