"""The course the paper's sector points along: the one reported, checked against the run.

The sector rule (:mod:`antikol.analysis.sector`) looks along a vehicle's course over
ground. At a standstill that course is noise, so the rule uses the last course reported
while moving. And a feed's course can be wrong all along, with no field to say so (a
bidirectional tram reporting the heading of its other end, 0 sent for "no heading", a
bearing counter-clockwise from east): a sector along a reversed course looks behind the
tram, and one along a course stuck at 0 looks north whichever way it runs. On the
simulator's street fleet with the course reversed, the paper's rule missed every
required warning of the city scenario.

So :class:`CourseKeeper` checks each vehicle's course against the chords between its own
fixes, with the rule positioning uses (:func:`~antikol.positioning.coursecheck.check_courses`:
a chord of 15 m or more within 12 s, both ends moving, as long as the run of the reported
speeds), which needs no map. The course it keeps for a vehicle is

* the reported one while the chords agree with it (always, for a right course: the
  check never doubted one in the simulator's runs), the rule of the paper;
* the reported one turned round once the chords show it reversed;
* the bearing of the vehicle's newest chord (its course made good) once they show it
  unrelated to the run.

``PositioningConfig(course_check=0)`` keeps every course as reported, as the paper does.

>>> from antikol.report import VehicleReport
>>> keeper = CourseKeeper()
>>> for s in range(8):  # a tram running north at 10 m/s, its course reported reversed
...     kept = keeper.update(VehicleReport("T1", float(s), 50.0 + s * 10.0 / 111_195,
...                                        19.9, 10.0, 180.0))
>>> round(kept), keeper.use("T1").name
(0, 'TURNED')
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from antikol.analysis.geometry import latdist_km, londist_km
from antikol.positioning.config import PositioningConfig
from antikol.positioning.coursecheck import CourseCheckState, CourseUse, check_courses
from antikol.positioning.fleet import FloatArray
from antikol.report import VehicleReport, one_per_vehicle
from antikol.thresholds import COURSE_MIN_SPEED_MPS

__all__ = ["CourseKeeper"]

#: (an enum member's look-up is slow in a loop over reports)
_IGNORED = int(CourseUse.IGNORED)


@dataclass
class CourseKeeper:
    """Remembers each vehicle's course for the sector rule, checked against its own run.

    Reports are queued (:meth:`add`) and checked together, in array calls, at the next
    question (:meth:`course`, :meth:`use`, :meth:`reported_course`) or :meth:`update`: a
    control room checks a whole cycle at once.

    Parameters
    ----------
    min_speed_mps : float
        Reports slower than this keep the course kept before, m/s (a standing receiver's
        course is noise).
    config : PositioningConfig, optional
        The course check's settings: the fixes' white noise, the course's error, the
        slowest speed whose course a chord tests (``min_speed_for_course_mps``) and
        whether to check at all (``course_check``). Default: ``PositioningConfig()``.
    """

    min_speed_mps: float = COURSE_MIN_SPEED_MPS
    config: PositioningConfig = field(default_factory=PositioningConfig)
    _courses: dict[str, float] = field(default_factory=dict, repr=False)
    _pending: list[VehicleReport] = field(default_factory=list, repr=False)
    _rows: dict[str, int] = field(default_factory=dict, repr=False)
    _free: list[int] = field(default_factory=list, repr=False)
    _state: CourseCheckState = field(default_factory=CourseCheckState, repr=False)
    # each row's anchor fix, degrees: the fixes go to the check in metres from it
    _anchor_lat: FloatArray = field(default_factory=lambda: np.zeros(0), repr=False)
    _anchor_lon: FloatArray = field(default_factory=lambda: np.zeros(0), repr=False)
    _made_good: dict[str, float] = field(default_factory=dict, repr=False)

    def add(self, report: VehicleReport) -> None:
        """Queue a report for the check (reports of a vehicle in time order)."""
        self._pending.append(report)

    def update(self, report: VehicleReport) -> float | None:
        """Record a report and return the course to use for it, degrees clockwise from
        north, or None while the vehicle has never moved at ``min_speed_mps``.

        Parameters
        ----------
        report : VehicleReport
            A vehicle's report, in time order for that vehicle.

        Returns
        -------
        float or None
            The kept course, degrees.
        """
        self._pending.append(report)
        return self.course(report.vehicle_id)

    def course(self, vehicle_id: str) -> float | None:
        """The kept course of a vehicle, degrees, or None when not known."""
        if self._pending:
            self._flush()
        return self._courses.get(vehicle_id)

    def use(self, vehicle_id: str) -> CourseUse:
        """How the vehicle's reported course is taken (:class:`CourseUse`; an unknown
        vehicle's is untested)."""
        if self._pending:
            self._flush()
        row = self._rows.get(vehicle_id)
        if row is None:
            return CourseUse.UNTESTED
        return CourseUse(int(self._state.qn[row]))

    def reported_course(self, report: VehicleReport) -> float:
        """A report's course as the check takes it, degrees: turned round when the
        vehicle's course is reversed, its course made good when it is unrelated to the
        run (the reported one while no chord was tested), else as reported."""
        use = self.use(report.vehicle_id)
        if use == CourseUse.TURNED:
            return (report.course_deg + 180.0) % 360.0
        if use == CourseUse.IGNORED:
            return self._made_good.get(report.vehicle_id, report.course_deg)
        return report.course_deg

    def forget(self, vehicle_id: str) -> None:
        """Drop a vehicle (e.g. when it leaves the vehicle table)."""
        if self._pending:
            self._flush()
        self._courses.pop(vehicle_id, None)
        self._made_good.pop(vehicle_id, None)
        row = self._rows.pop(vehicle_id, None)
        if row is not None:
            self._state.clear(row)
            self._free.append(row)

    def keep(self, vehicle_id: str, course_deg: float) -> None:
        """Set a vehicle's kept course, degrees (restoring a saved state)."""
        if self._pending:
            self._flush()
        self._courses[vehicle_id] = float(course_deg)

    def _flush(self) -> None:
        pending, self._pending = self._pending, []
        if not self.config.course_check:
            for r in pending:
                if r.speed_mps >= self.min_speed_mps:
                    self._courses[r.vehicle_id] = r.course_deg
            return
        for run in one_per_vehicle(pending):
            self._check(run)

    def _row(self, vehicle_id: str) -> int:
        row = self._rows.get(vehicle_id)
        if row is None:
            row = self._free.pop() if self._free else len(self._rows)
            if row >= len(self._state):
                self._state.grow(row + 1)
                extra = len(self._state) - len(self._anchor_lat)
                self._anchor_lat = np.concatenate([self._anchor_lat, np.zeros(extra)])
                self._anchor_lon = np.concatenate([self._anchor_lon, np.zeros(extra)])
            self._rows[vehicle_id] = row
        return row

    def _check(self, reports: list[VehicleReport]) -> None:
        """Check a run of reports (one per vehicle) and keep the courses they give."""
        n = len(reports)
        rows = np.fromiter((self._row(r.vehicle_id) for r in reports), np.int64, count=n)
        lat, lon, t, speed, course = np.array(
            [(r.lat, r.lon, r.t, r.speed_mps, r.course_deg) for r in reports], dtype=float
        ).T
        # formulas (4)-(7) from the anchor fix (no anchor yet: NaN, the check renews it)
        lat0 = self._anchor_lat[rows]
        y_m = -np.asarray(latdist_km(lat0, lat), dtype=float) * 1000.0
        x_m = -np.asarray(londist_km(lat0, self._anchor_lon[rows], lon), dtype=float) * 1000.0
        checked = check_courses(self._state, self.config, reports, rows, t, speed, x_m, y_m,
                                course)  # fmt: skip
        for i, bearing in zip(checked.chords.at.tolist(), checked.chords.bearing_deg.tolist(),
                              strict=True):  # fmt: skip
            self._made_good[reports[i].vehicle_id] = bearing
        s = self._state
        moved = s.qt[rows] == t  # the anchors that moved to these fixes: the new origins
        if moved.any():
            at = rows[moved]
            self._anchor_lat[at], self._anchor_lon[at] = lat[moved], lon[moved]
            s.qx[at] = s.qy[at] = 0.0
        use = s.qn[rows]
        for r, u, kept in zip(reports, use.tolist(), checked.course_deg.tolist(), strict=True):
            if r.speed_mps < self.min_speed_mps:
                continue
            if u == _IGNORED:
                made_good = self._made_good.get(r.vehicle_id)
                if made_good is None:  # (no chord yet: nothing better known)
                    self._courses.pop(r.vehicle_id, None)
                else:
                    self._courses[r.vehicle_id] = made_good
            else:  # as reported, or turned round
                self._courses[r.vehicle_id] = kept
