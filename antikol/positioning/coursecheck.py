"""Whether a vehicle's reported course can be believed, checked against its own run.

Positioning leans on the course over ground while a vehicle moves: it is what tells the
two tracks of a double track apart when the fix's bias is as large as their spacing
(:mod:`antikol.positioning.scoring`). A feed's course can be wrong all along, and no field
says so:

* a bidirectional vehicle reports the heading of one end, 180 degrees off whenever it is
  driven from the other;
* a system sends 0 where it has no heading;
* a bearing comes in another convention (counter-clockwise from east);
* a GTFS-realtime ``bearing`` may be the direction towards the next stop.

Weighed as a course, a reversed one put the trams of a simulated street fleet on a wrong
track for a fifth of their moving fixes (confident for 935 of 5,459 confident fixes), and
one stuck at 0 put them on the wrong branch past a sixth of the switches.

So each vehicle's course is checked against the chord between two of its own fixes, at
least :data:`CHORD_MIN_M` and at most :data:`CHORD_MAX_S` apart. On a circular arc the
chord's bearing is the mean of the courses at its ends, and the persistent bias of street
GPS, the fixes' largest error, cancels in the difference; what is left is the fixes'
white noise, ``sqrt(2)`` times its sigma across the chord. Some chords are no test: one
whose length does not match the run of the reported speeds (a bias jump, an outlier), one
whose end courses differ by more than a right angle, one with an end below
``min_speed_for_course_mps`` (a standing receiver's course is a held or a random one).

Each test weighs a course that is right (the chord's bearing off the mean course by the
chord's and the course's errors, with a floor for what neither model knows) against one
unrelated to the run (any bearing alike), and so does it for the course turned round.
The log-likelihood ratios are summed per vehicle, from :data:`PRIOR_NATS` for the course
as reported and from :data:`REVERSED_PRIOR_NATS` for it turned round, each kept within
``±``:data:`CAP_NATS` (a long agreement is no licence). The vehicle's :class:`CourseUse`:

* its course is weighed as reported while that sum is at least 0;
* when it falls below (one chord far off at the start does it, as does a run of them
  after a long agreement), the course is weighed turned round once that sum is above
  :data:`PRIOR_NATS` (the second chord of a reversed course), as reported again once
  that one is (a course right on some headings only, like one stuck at 0, is believed
  where it agrees), and else not at all: the fixes and the run alone place the vehicle.

On the simulator's street and white-noise receivers (36 runs of 12 trams for 10 minutes,
four of 90 minutes) no right course was ever doubted: the chord-length test and the
floor take the heavy tails.

When a trusted course ends (its first doubt, or a turned-round course that turns out
right again: a bidirectional tram driven from its other end), the vehicle starts afresh:
its hypotheses were weighed with that course, and on the track running the reported way
they held it for up to a minute on the fixes alone. The latency its fixes taught is
forgotten too (:func:`~antikol.positioning.latency.forget_latency`).

>>> import numpy as np
>>> from antikol.positioning import PositioningConfig
>>> from antikol.positioning.fleet import FleetState
>>> fleet, config = FleetState(k=4), PositioningConfig()
>>> fleet.grow(1)
>>> def run(course_deg):  # a vehicle running east at 10 m/s, reporting course_deg
...     return [float(check_courses(fleet, config, [None], np.array([0]),
...                 np.array([float(s)]), np.array([10.0]), np.array([10.0 * s]),
...                 np.array([0.0]), np.array([course_deg])).course_deg[0]) for s in range(10)]
>>> run(90.0)
[90.0, 90.0, 90.0, 90.0, 90.0, 90.0, 90.0, 90.0, 90.0, 90.0]
>>> fleet.clear(0)
>>> run(270.0)  # reversed: ignored at the first chord, turned round from the second
[270.0, 270.0, nan, nan, 90.0, 90.0, 90.0, 90.0, 90.0, 90.0]
>>> fleet.clear(0)
>>> run(0.0)  # stuck at 0: ignored
[0.0, 0.0, nan, nan, nan, nan, nan, nan, nan, nan]
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Final, NamedTuple

import numpy as np

from antikol.positioning.config import PositioningConfig, hdop_factor
from antikol.positioning.fleet import FleetState, FloatArray, IntArray
from antikol.positioning.latency import forget_latency
from antikol.report import VehicleReport

__all__ = [
    "CAP_NATS",
    "CHECK_FIELDS",
    "CHORD_MAX_S",
    "CHORD_MIN_M",
    "CHORD_RUN_FACTOR",
    "PRIOR_NATS",
    "REVERSED_PRIOR_NATS",
    "Chords",
    "CourseCheck",
    "CourseCheckState",
    "CourseUse",
    "check_courses",
    "chords",
    "course_evidence",
    "restart_doubted",
]

#: Shortest chord that tests a course, m (a tram's run of one or two seconds).
CHORD_MIN_M: Final = 15.0
#: Longest time over which a chord tests a course, s (beyond, the anchor fix is renewed).
CHORD_MAX_S: Final = 12.0
#: A chord's length must lie within this factor of the run of the reported speeds.
CHORD_RUN_FACTOR: Final = 1.5
#: Largest turn between the courses at a chord's ends for their mean to mean anything,
#: degrees.
MAX_END_TURN_DEG: Final = 90.0
#: Weight of the floor of a right course's model (a chord or a course gone astray).
FLOOR_WEIGHT: Final = 0.2
#: The evidence for a right course before the first chord, nats.
PRIOR_NATS: Final = 1.5
#: The evidence for a reversed course before the first chord, nats.
REVERSED_PRIOR_NATS: Final = -2.5
#: The evidence is kept within plus and minus this, nats (a long agreement is no licence).
CAP_NATS: Final = 6.0


class CourseUse(IntEnum):
    """How a vehicle's reported course is weighed (:func:`check_courses`)."""

    UNTESTED = 0
    """As reported, never doubted."""
    IGNORED = 1
    """Not weighed: the chords of the vehicle's fixes show it unrelated to its run."""
    BELIEVED = 2
    """As reported, after it was doubted."""
    TURNED = 3
    """Turned round by 180 degrees: the chords show it reversed (a bidirectional vehicle
    reporting the heading of its other end)."""


# the uses as plain ints for the comparisons with arrays (an IntEnum member takes numpy's
# slow path for a Python object: four times the cost of the comparison of a few rows)
_UNTESTED, _IGNORED, _BELIEVED, _TURNED = (int(u) for u in CourseUse)


#: The course-check fields of a vehicle's row (:class:`CourseCheckState`, and the same
#: fields of a positioner's :class:`~antikol.positioning.fleet.FleetState`).
CHECK_FIELDS: Final = ("qx", "qy", "qt", "qv", "qc", "qe", "qr", "qn")


@dataclass
class CourseCheckState:
    """The course check's state of vehicles that are not positioned on a map (one row
    each): the anchor fix (``qx``, ``qy``, m, in the frame of the fixes passed with it;
    ``qt``, s; ``qv``, m/s; ``qc``, degrees), the evidence beyond the priors (``qe``,
    ``qr``, nats) and the :class:`CourseUse` (``qn``). Rows grow in blocks."""

    qx: FloatArray = field(default_factory=lambda: np.zeros(0))
    qy: FloatArray = field(default_factory=lambda: np.zeros(0))
    qt: FloatArray = field(default_factory=lambda: np.zeros(0))
    qv: FloatArray = field(default_factory=lambda: np.zeros(0))
    qc: FloatArray = field(default_factory=lambda: np.zeros(0))
    qe: FloatArray = field(default_factory=lambda: np.zeros(0))
    qr: FloatArray = field(default_factory=lambda: np.zeros(0))
    qn: FloatArray = field(default_factory=lambda: np.zeros(0))

    def __len__(self) -> int:
        return len(self.qt)

    def grow(self, n: int) -> None:
        """Extend to at least ``n`` rows (new rows cleared; capacity doubles)."""
        old = len(self)
        if n <= old:
            return
        n = max(n, 2 * old, 8)
        for name in CHECK_FIELDS:
            setattr(self, name, np.concatenate([getattr(self, name), np.zeros(n - old)]))
        for row in range(old, n):
            self.clear(row)

    def clear(self, row: int) -> None:
        """Empty one row (a new or forgotten vehicle): no anchor, no evidence, untested."""
        self.qx[row] = self.qy[row] = self.qt[row] = self.qv[row] = self.qc[row] = np.nan
        self.qe[row] = self.qr[row] = self.qn[row] = 0.0


def _turn(to_deg: FloatArray, from_deg: FloatArray) -> FloatArray:
    """Signed smallest turn from one bearing to another, degrees in [-180, 180)."""
    return np.asarray((to_deg - from_deg + 180.0) % 360.0 - 180.0, dtype=float)


def course_evidence(off_deg: FloatArray, sigma_deg: FloatArray) -> FloatArray:
    """Log-likelihood ratio of a right course against an unrelated one, nats.

    Parameters
    ----------
    off_deg : ndarray of float
        How far the chord's bearing is off the mean reported course, degrees (0-180).
    sigma_deg : ndarray of float
        The expected spread of that difference for a right course, degrees.

    Returns
    -------
    ndarray of float
        ``log(p(off | right) / p(off | unrelated))``: up to +2.6 for a close match, and
        ``log(FLOOR_WEIGHT)`` (-1.6) far off.

    >>> course_evidence(np.array([0.0, 10.0, 90.0, 180.0]), np.array([10.0] * 4)).round(1)
    array([ 2.5,  2. , -1.6, -1.6])
    """
    z = off_deg / sigma_deg
    right = 2.0 * np.exp(-0.5 * z * z) / (sigma_deg * math.sqrt(2.0 * math.pi))
    return np.asarray(np.log((1.0 - FLOOR_WEIGHT) * right * 180.0 + FLOOR_WEIGHT), dtype=float)


def restart_doubted(
    fleet: FleetState, checked: CourseCheck, stats: Counter[str] | None = None
) -> FloatArray:
    """Start afresh the vehicles of a positioner whose trusted course ended; the courses
    to weigh.

    Their hypotheses were weighed with that course (``hs`` emptied), and the latency their
    fixes taught is forgotten.

    Parameters
    ----------
    fleet : FleetState
        The positioner's fleet, checked by :func:`check_courses`.
    checked : CourseCheck
        What :func:`check_courses` found.
    stats : Counter, optional
        Counts ``course_doubted``: vehicles whose trusted use of their course ended.

    Returns
    -------
    ndarray of float
        ``checked.course_deg``: per report, the course to weigh, degrees (NaN: ignored).
    """
    if len(checked.ended):
        fleet.hs[checked.ended] = -1
        forget_latency(fleet, checked.ended)
        if stats is not None:
            stats["course_doubted"] += len(checked.ended)
    return checked.course_deg


class CourseCheck(NamedTuple):
    """What :func:`check_courses` found at a batch of reports: the course to weigh for
    each (degrees; NaN: ignored), the chords it tested, and the fleet rows of the vehicles
    whose trusted use of their course (as reported, never doubted, or turned round)
    ended there."""

    course_deg: FloatArray
    chords: Chords
    ended: IntArray


def check_courses(
    state: CourseCheckState | FleetState,
    config: PositioningConfig,
    reports: Sequence[VehicleReport | None],
    rows: IntArray,
    t: FloatArray,
    speed_mps: FloatArray,
    x_m: FloatArray,
    y_m: FloatArray,
    course_deg: FloatArray,
    stats: Counter[str] | None = None,
) -> CourseCheck:
    """Check each vehicle's course against the chord of its fixes.

    Parameters
    ----------
    state : CourseCheckState or FleetState
        Its course-check fields are updated (``qx``, ``qy``, ``qt``, ``qv``, ``qc``: the
        anchor fix's local position, m, time, s, speed, m/s, and course, degrees; ``qe``
        and ``qr``: the evidence for a right and for a reversed course beyond
        :data:`PRIOR_NATS` and :data:`REVERSED_PRIOR_NATS`, nats; ``qn``: the
        :class:`CourseUse`).
    config : PositioningConfig
        The fixes' white noise (``error_scales``), the course's error
        (``course_sigma_deg``, ``course_noise_deg_mps``), the slowest speed whose course
        means anything (``min_speed_for_course_mps``) and whether to check at all
        (``course_check``).
    reports : sequence of VehicleReport or None
        The reports (their fix quality and HDOP; None: a plain fix).
    rows : ndarray of int
        The state's row of each report (at most one report per vehicle).
    t : ndarray of float
        Report times, s.
    speed_mps : ndarray of float
        Reported speeds, m/s.
    x_m, y_m : ndarray of float
        The fixes in a local metric frame (x east, y north), m; a vehicle's fixes in the
        same frame as its anchor.
    course_deg : ndarray of float
        Reported courses, degrees clockwise from north.
    stats : Counter, optional
        Counts ``course_ignored`` and ``course_turned``: reports whose course is not
        weighed, or weighed turned round.

    Returns
    -------
    CourseCheck
        The course to weigh per report, the chords tested, the vehicles whose trusted
        course ended.
    """
    none = np.zeros(0, np.int64)
    if not config.course_check:
        return CourseCheck(course_deg, _no_chords(), none)
    f = state
    tested = chords(f, config.min_speed_for_course_mps, rows, t, speed_mps, x_m, y_m, course_deg)
    ended = none
    if len(tested.at):
        ended = _weigh_chords(f, config, [reports[i] for i in tested.at.tolist()], tested)
    use = f.qn[rows]
    ignored, turned = use == _IGNORED, use == _TURNED
    if not (ignored.any() or turned.any()):  # (the usual case: every course as reported)
        return CourseCheck(course_deg, tested, ended)
    if stats is not None:
        for name, which in (("course_ignored", ignored), ("course_turned", turned)):
            if which.any():
                stats[name] += int(np.count_nonzero(which))
    weighed = np.where(ignored, np.nan, np.where(turned, (course_deg + 180.0) % 360.0, course_deg))
    return CourseCheck(weighed, tested, ended)


class Chords(NamedTuple):
    """The chords tested at a batch of reports (:func:`chords`): the reports' indices in the
    batch and their vehicles' rows, how far each chord's bearing is off the mean of the
    courses at its ends (degrees, 0-180), its length, m, the mean of the speeds at its
    ends, m/s, and its bearing (the course made good, degrees clockwise from north)."""

    at: IntArray
    rows: IntArray
    off_deg: FloatArray
    chord_m: FloatArray
    mean_speed_mps: FloatArray
    bearing_deg: FloatArray


def _no_chords() -> Chords:
    none, empty = np.zeros(0, np.int64), np.zeros(0)
    return Chords(none, none, empty, empty, empty, empty)


def chords(
    fleet: CourseCheckState | FleetState,
    min_speed_mps: float,
    rows: IntArray,
    t: FloatArray,
    speed_mps: FloatArray,
    x_m: FloatArray,
    y_m: FloatArray,
    course_deg: FloatArray,
) -> Chords:
    """Close each vehicle's chord at its new fix where one is due, and test it.

    A chord runs from the vehicle's anchor fix to a fix at least :data:`CHORD_MIN_M` from
    it and at most :data:`CHORD_MAX_S` after it; the anchor then moves there (and to any
    fix of a vehicle standing below ``min_speed_mps``, or after a longer wait). A chord
    tests the course when both its ends move at ``min_speed_mps`` or more, it is as long
    as the run of the reported speeds (within :data:`CHORD_RUN_FACTOR`) and the courses
    at its ends differ by :data:`MAX_END_TURN_DEG` or less.

    Parameters
    ----------
    fleet : CourseCheckState or FleetState
        Its anchor fields (``qx``, ``qy``, ``qt``, ``qv``, ``qc``: local position, m,
        time, s, speed, m/s, course, degrees) are updated.
    min_speed_mps : float
        Slowest speed at which a course means anything, m/s.
    rows : ndarray of int
        The fleet row of each report (at most one report per vehicle).
    t, speed_mps, x_m, y_m, course_deg : ndarray of float
        Each report's time (s), reported speed (m/s), fix in the map's local frame (m)
        and reported course (degrees clockwise from north).

    Returns
    -------
    Chords
        The chords that test a course.
    """
    f = fleet
    age = t - f.qt[rows]
    with np.errstate(invalid="ignore"):  # NaN: no anchor yet
        dx, dy = x_m - f.qx[rows], y_m - f.qy[rows]
    chord_m = np.hypot(dx, dy)
    renew = ~(age <= CHORD_MAX_S) | (age < 0.0)  # also NaN: no anchor yet
    ready = ~renew & (chord_m >= CHORD_MIN_M)
    at = np.flatnonzero(ready)
    if len(at):
        ran_m = 0.5 * (f.qv[rows[at]] + speed_mps[at]) * age[at]
        end_turn = _turn(course_deg[at], f.qc[rows[at]])
        test = (
            (np.minimum(f.qv[rows[at]], speed_mps[at]) >= min_speed_mps)
            & (chord_m[at] <= CHORD_RUN_FACTOR * ran_m)
            & (chord_m[at] >= ran_m / CHORD_RUN_FACTOR)
            & (np.abs(end_turn) <= MAX_END_TURN_DEG)
        )
        at, end_turn = at[test], end_turn[test]
        bearing = np.degrees(np.arctan2(dx[at], dy[at]))
        off = np.abs(_turn(f.qc[rows[at]] + 0.5 * end_turn, bearing))
        mean_speed = 0.5 * (f.qv[rows[at]] + speed_mps[at])
    else:
        off = mean_speed = bearing = np.zeros(0)
    # a standing receiver's fix is no anchor: the chord starts at the first moving one
    move = renew | ready | (f.qv[rows] < min_speed_mps)
    if move.any():
        moved = rows[move]
        f.qx[moved], f.qy[moved], f.qt[moved] = x_m[move], y_m[move], t[move]
        f.qv[moved], f.qc[moved] = speed_mps[move], course_deg[move]
    return Chords(at, rows[at], off, chord_m[at], mean_speed, bearing % 360.0)


def _weigh_chords(
    f: CourseCheckState | FleetState,
    config: PositioningConfig,
    reports: Sequence[VehicleReport | None],
    tested: Chords,
) -> IntArray:
    """Weigh the tested chords (``reports`` are theirs) as evidence for a course that is
    right and for one turned round; update the vehicles' :class:`CourseUse` (a use only
    changes with its evidence). Returns the rows whose trusted use ended."""
    rows = tested.rows
    white_m = np.array([_white_m(config, r) for r in reports])
    sigma_deg = np.hypot(
        np.degrees(math.sqrt(2.0) * white_m / tested.chord_m),
        np.hypot(
            config.course_sigma_deg,
            config.course_noise_deg_mps / np.maximum(tested.mean_speed_mps, 0.1),
        ),
    )
    off = tested.off_deg
    for name, prior, off_deg in (("qe", PRIOR_NATS, off), ("qr", REVERSED_PRIOR_NATS, 180.0 - off)):
        held = prior + getattr(f, name)[rows] + course_evidence(off_deg, sigma_deg)
        getattr(f, name)[rows] = np.clip(held, -CAP_NATS, CAP_NATS) - prior
    before = f.qn[rows].astype(np.int64)
    use = _course_use(before, PRIOR_NATS + f.qe[rows], REVERSED_PRIOR_NATS + f.qr[rows])
    f.qn[rows] = use
    trusted = (before == _UNTESTED) | (before == _TURNED)
    return rows[(use != before) & trusted]


def _course_use(before: IntArray, right: FloatArray, reversed_: FloatArray) -> IntArray:
    """Each vehicle's :class:`CourseUse` from the one before and the evidence, nats: a
    trusted use holds while its evidence is at least 0; a vehicle whose course is
    ignored, or whose trusted use ends, takes a use whose evidence is above
    :data:`PRIOR_NATS` (as reported first), else ignores its course."""
    as_reported = (before == _UNTESTED) | (before == _BELIEVED)
    keep = np.where(as_reported, right >= 0.0, (before == _TURNED) & (reversed_ >= 0.0))
    fallback = np.where(
        right > PRIOR_NATS, _BELIEVED, np.where(reversed_ > PRIOR_NATS, _TURNED, _IGNORED)
    )
    return np.where(keep, before, fallback).astype(np.int64)


def _white_m(config: PositioningConfig, report: VehicleReport | None) -> float:
    """The white noise of a report's fix, m (its fix quality's, times its HDOP)."""
    if report is None:
        return config.error_scales(None)[0]
    return config.error_scales(report.fix_quality)[0] * hdop_factor(report.hdop)
