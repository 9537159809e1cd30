"""When a vehicle is shown on a track: after a fresh start, and past a switch taken
without a fix.

A vehicle's first fix tells little about which of two parallel tracks it is on: the
fix's bias in a street is as large as the tracks' spacing, and a standing receiver's
course is a previous trip's or random. A position shown on the other direction's track
and moved across when the fixes tell the tracks apart is a jump that no permitted route
connects, which a map shows and a real trace's check counts. So a vehicle that starts
afresh (a new vehicle, one back after a long gap or after no track was near) is shown on
a track only once its evidence tells the track:

* its place is ``confident`` (it reaches ``confidence`` at ``confident_after`` fixes in a
  row, or ``sure_probability``);
* it sent ``show_after_moving_reports`` reports while moving (at
  ``start_course_max_speed_mps`` or faster, or without a speed) and its place holds
  ``show_moving_probability``: the course and the run between fixes count from the
  second, but they do not tell apart two tracks running the same way;
* it sent ``show_after_steady_course_reports`` standing reports whose course holds within
  :data:`STEADY_COURSE_DEG`: a receiver that holds the course it last measured while
  moving (the tie-break at a standing start) and not a random one;
* at the latest at its ``show_within_reports``-th report, whatever its evidence: a tram
  standing long at its first stop with a random course is shown on the likelier track
  after a few seconds (hidden for its whole stand, it would be missing from every count of
  where trams are, right or wrong); a tram moving at that report, :data:`MOVING_EXTRA_REPORTS`
  reports later.

Until then its position is ``lost`` with no edge, its hypotheses given
(:attr:`~antikol.positioning.records.TrackPosition.unplaced`); the analysis weighs those
hypotheses as it weighs an ``ambiguous`` position's. Nothing of the matching changes: a
vehicle is only shown later.

The same holds for a coin toss made without a fix (:func:`tossed`): a vehicle
dead-reckoned over a facing switch through a GPS outage splits evenly over the branches.
Within 40 m it is reported at the switch (:func:`~antikol.positioning.branching.hold_at_switch`);
beyond, shown on one branch, it was moved across when the fix came back on the other,
a window no route connects. It is now not shown from there until a fix (or estimates,
:mod:`antikol.positioning.estimates`) takes one branch to ``toss_shown_probability``.

>>> import numpy as np
>>> from antikol.positioning.fleet import FleetState
>>> fleet = FleetState(k=4)
>>> fleet.grow(1)
>>> rows = np.array([0])
>>> from antikol.positioning import PositioningConfig
>>> def report(speed, course, fresh=False, place=0.85):  # ambiguous
...     fleet.place[0] = place
...     note_showing_evidence(
...         fleet, rows, PositioningConfig(), fresh=np.array([fresh]),
...         speed_mps=np.array([speed]), course_deg=np.array([course]))
...     return bool(shown(fleet, rows)[0])
>>> report(0.0, 17.0, fresh=True), report(0.0, 201.0), report(1.5, 3.0), report(3.0, 2.0)
(False, False, False, True)
>>> report(0.0, 90.0, fresh=True), report(0.0, 90.0), report(0.0, 90.0)
(False, False, True)
>>> [report(0.0, 90.0 * k, fresh=k == 0) for k in range(5)]
[False, False, False, False, True]
>>> [report(8.0, 90.0, fresh=k == 0, place=0.6) for k in range(7)]  # which of two?
[False, False, False, False, False, False, True]
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from antikol.positioning.config import PositioningConfig
from antikol.positioning.fleet import BoolArray, FleetState, FloatArray, IntArray
from antikol.positioning.outputs import unplaced_position
from antikol.positioning.records import TrackPosition

__all__ = [
    "MOVING_EXTRA_REPORTS",
    "STEADY_COURSE_DEG",
    "as_shown",
    "note_showing_evidence",
    "shown",
    "tossed",
]

#: Reports a vehicle moving at its ``show_within_reports``-th report may stay hidden
#: beyond it, while its place is below ``show_moving_probability``.
MOVING_EXTRA_REPORTS = 2

#: Largest change of a standing receiver's course between two reports that still counts
#: as a course held, degrees (a held course repeats to the digit; a random one does not).
STEADY_COURSE_DEG = 2.0


def note_showing_evidence(
    fleet: FleetState,
    rows: IntArray,
    config: PositioningConfig,
    *,
    fresh: BoolArray,
    speed_mps: FloatArray,
    course_deg: FloatArray,
) -> None:
    """Count what the vehicles' new fixes tell of their track, once per fix, after their
    places' probabilities (``fleet.place``, ``fleet.confident_run``) are updated.

    Parameters
    ----------
    fleet : FleetState
        Its ``sm`` (moving reports), ``sc`` (last standing course, degrees), ``sn``
        (standing reports with that course held), ``sa`` (all reports) and ``sp`` (1:
        shown) are updated, counted since the vehicle started afresh.
    rows : ndarray of int
        The vehicles' rows, one per fix (distinct).
    config : PositioningConfig
        ``confidence``, ``confident_after``, ``sure_probability``,
        ``start_course_max_speed_mps`` (from this speed on a report counts
        as moving, m/s), ``show_after_moving_reports``, ``show_moving_probability``,
        ``show_after_steady_course_reports`` and ``show_within_reports``.
    fresh : ndarray of bool
        The fix starts the vehicle afresh: what was counted before is void.
    speed_mps : ndarray of float
        Reported speeds, m/s (NaN: none).
    course_deg : ndarray of float
        Reported courses over ground, degrees (NaN: none).
    """
    if not len(rows):
        return
    if fresh.any():  # (the usual fix continues what was counted)
        for name in ("sm", "sn", "sa", "sp"):
            getattr(fleet, name)[rows[fresh]] = 0.0
        fleet.sc[rows[fresh]] = np.nan
    with np.errstate(invalid="ignore"):  # no speed: the fixes' run tells the track
        moving = ~(speed_mps < config.start_course_max_speed_mps)
    fleet.sm[rows] += moving
    fleet.sa[rows] += 1.0
    last = fleet.sc[rows]
    turn = np.abs((course_deg - last + 180.0) % 360.0 - 180.0)
    held = ~moving & np.isfinite(turn) & (turn <= STEADY_COURSE_DEG)
    standing_course = ~moving & np.isfinite(course_deg)
    fleet.sn[rows] = np.where(held, fleet.sn[rows] + 1.0, np.where(standing_course, 1.0, 0.0))
    fleet.sc[rows] = np.where(standing_course, course_deg, np.nan)
    moving_reports, steady_reports, limit = (
        config.show_after_moving_reports,
        config.show_after_steady_course_reports,
        config.show_within_reports,
    )
    place = fleet.place[rows]
    # confident as a position is (placing._confident): a first belief that has just
    # swung may be a random standing course's
    confident = (place >= config.confidence) & (
        (fleet.confident_run[rows] >= config.confident_after) | (place >= config.sure_probability)
    )
    show = (
        (moving_reports == 0)
        | confident
        | ((fleet.sm[rows] >= moving_reports) & (place >= config.show_moving_probability))
        | ((steady_reports > 0) & (fleet.sn[rows] >= steady_reports))
        | ((limit > 0) & (fleet.sa[rows] >= np.where(moving, limit + MOVING_EXTRA_REPORTS, limit)))
    )
    fleet.sp[rows] = np.where(show, 1.0, fleet.sp[rows])
    fleet.pf[rows] = place


def shown(fleet: FleetState, rows: IntArray) -> BoolArray:
    """Whether each vehicle of ``rows`` is shown on a track (see the module's text)."""
    return np.asarray(fleet.sp[rows] > 0.0, dtype=bool)


def tossed(fleet: FleetState, row: int, position: TrackPosition, config: PositioningConfig) -> bool:
    """Whether a vehicle's position is a coin toss made without a fix: dead-reckoned since
    a fix at which its place held ``confidence`` or more, it now holds less than
    ``toss_shown_probability`` (the branches of a switch it ran over without a fix share
    it)."""
    return (
        position.dead_reckoned_s > 0.0
        and position.probability < config.toss_shown_probability
        and bool(fleet.pf[row] >= config.confidence)
    )


def as_shown(
    fleet: FleetState,
    rows: IntArray,
    positions: Sequence[TrackPosition],
    config: PositioningConfig,
    held: Sequence[bool],
) -> list[TrackPosition]:
    """The positions of the vehicles of ``rows`` as shown: those not yet shown on a track,
    and those dead-reckoned onto a coin toss (:func:`tossed`) but not ``held`` at the
    switch behind them, without their edge
    (:func:`~antikol.positioning.outputs.unplaced_position`)."""
    last = fleet.last
    return [
        pos
        if on and (hold or not tossed(fleet, row, pos, config))
        else unplaced_position(pos, last[row])
        for pos, on, row, hold in zip(
            positions, shown(fleet, rows).tolist(), rows.tolist(), held, strict=True
        )
    ]
