"""What the operator-feed readers share: turning loose feed records into checked reports.

Operator feeds (:mod:`antikol.ingest.hfp`, :mod:`antikol.ingest.gtfsrt`) leave out what a
:class:`~antikol.report.VehicleReport` needs now and then: a speed or a heading while
standing, a position when the location source is not GPS. :class:`FeedCollector` takes one
record at a time and

* derives a missing speed and course over ground from the vehicle's previous position
  (WGS84 geodesic through pyproj), or from its odometer for the speed;
* keeps the last known position for records without a position fix (``fix_quality`` 0);
* drops an odometer reading that goes back (the record is kept, the problem noted);
* skips exact repeats of a vehicle's last record time (feeds repeat snapshots), counted;
* turns every invalid value into a :class:`~antikol.ingest.replaylog.RowProblem` naming
  the record and the field — never an exception, never a silent loss (``strict`` raises
  :class:`~antikol.errors.ReplayError` at the first bad record instead).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

from pyproj import Geod

from antikol.errors import InvalidReportError, ReplayError
from antikol.ingest.replaylog import ReplayLog, RowProblem
from antikol.report import VehicleReport

__all__ = ["FeedCollector", "FeedRecord"]

logger = logging.getLogger(__name__)

_GEOD = Geod(ellps="WGS84")
#: Below this derived speed the derived course is meaningless and the last one is kept, m/s.
_COURSE_MIN_SPEED_MPS = 0.5


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
    has_fix : bool
        The position is a GPS fix (False: odometer, dead reckoning, manual or unknown).
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


@dataclass
class _Last:
    t: float
    lat: float
    lon: float
    course: float
    odometer: float | None


@dataclass
class FeedCollector:
    """Collects feed records into a :class:`~antikol.ingest.replaylog.ReplayLog`.

    Parameters
    ----------
    source : str
        Name of the log (a file or directory).
    strict : bool
        Raise :class:`~antikol.errors.ReplayError` at the first bad record.
    """

    source: str
    strict: bool = False
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
        """Turn one record into a report, or note why it cannot be one."""
        last = self._last.get(rec.vehicle_id)
        if last is not None and rec.t == last.t:
            self.ignore("repeated record time of a vehicle")
            return
        if last is not None and rec.t < last.t:
            self.problem(
                rec.record,
                rec.source,
                f"t={rec.t!r} is earlier than the vehicle's previous record ({last.t!r})",
            )
            return
        odometer = rec.odometer_m
        last_odo = None if last is None else last.odometer
        if odometer is not None and last_odo is not None and odometer < last_odo:
            self.problem(
                rec.record,
                rec.source,
                f"odometer {odometer!r} m is below the previous {last_odo!r} m; "
                "dropped from this record",
                kept=True,
            )
            odometer = None
        has_pos = rec.lat is not None and rec.lon is not None
        fix = rec.has_fix and has_pos
        if has_pos:
            lat, lon = float(rec.lat), float(rec.lon)  # type: ignore[arg-type]
        elif last is not None:
            lat, lon = last.lat, last.lon
        else:
            self.problem(rec.record, rec.source, "no position (lat/lon) and none known before")
            return
        speed, course = rec.speed_mps, rec.course_deg
        if (speed is None or course is None) and last is not None and rec.t > last.t:
            dt = rec.t - last.t
            az, _, dist = _GEOD.inv(last.lon, last.lat, lon, lat)
            if speed is None:
                if odometer is not None and last.odometer is not None:
                    speed = (odometer - last.odometer) / dt
                elif fix:
                    speed = dist / dt
            if course is None:
                course = az % 360.0 if dist / dt >= _COURSE_MIN_SPEED_MPS else last.course
        if speed is None:
            self.problem(
                rec.record, rec.source, "no speed (spd) and no earlier record to derive it from"
            )
            return
        if course is None:
            course = last.course if last is not None else 0.0
        try:
            report = VehicleReport(
                vehicle_id=rec.vehicle_id,
                t=rec.t,
                lat=lat,
                lon=lon,
                speed_mps=speed,
                course_deg=course % 360.0 if math.isfinite(course) else course,
                fix_quality=1 if fix else 0,
                odometer_m=odometer,
            )
        except InvalidReportError as exc:
            self.problem(rec.record, rec.source, str(exc))
            return
        self.reports.append(report)
        keep_odo = odometer if odometer is not None else (last.odometer if last else None)
        self._last[rec.vehicle_id] = _Last(rec.t, lat, lon, report.course_deg, keep_odo)

    def log(self) -> ReplayLog:
        """The reports in time order (then vehicle id), the problems in file and line order,
        and the ignored counts."""
        reports = sorted(self.reports, key=lambda r: (r.t, r.vehicle_id))
        problems = sorted(self.problems, key=lambda p: (p.source, p.line))
        return ReplayLog(reports, problems, self.source, dict(self.ignored))
