"""Faults of a feed's reports that no field flags: repeated positions, reset odometers.

**Repeated positions.** Many vehicle-location systems keep sending the last position they
had when the receiver loses its fix — with no fix-quality field to say so (an operator's
high-frequency positioning feed, GTFS-realtime), or with the field unchanged. While the
odometer (or the reported speed) says the vehicle moved on, such a report is not a fix:
taken as one, it pulls the position back towards where the fix froze — the along-track
filter restarts at the frozen place after a few of them, and the returning fixes look like
a jump. A real fix of a moving vehicle never repeats the previous report's coordinates to
the last digit, so a report that does, after a run of ``stale_fix_run_m`` since the last
fix, is dead-reckoned like a report without a fix (:func:`stale_fixes`; counted,
``stale_fix``). The run is the odometer's, else the reported speeds' over every report
since the fix: a tram that ran through a tunnel and then stood at a stop there has still
run far from the position the feed froze at the portal (taken as a fix again once it
stood, such a position put the tram back at the portal, confident, for a minute). A
receiver holding a static position while the vehicle stands repeats a position that was a
fix when the vehicle stopped: the run since then stays short, and it stays a fix. When the
position repeated is one that was rejected (a far outlier frozen by the feed through an
outage), each copy is the same evidence and counts once towards the rejections in a row
that start a vehicle afresh (:meth:`~antikol.positioning.fleet.FleetState.repeats_rejected`):
before, three copies of one outlier 64 m off put a standing tram there.

**Reset odometers.** Some feeds report the distance run since the start of the trip, back
to zero at every new trip. A reading that goes back (:func:`odometer_resets`; counted,
``odometer_reset``) leaves no baseline: that step runs on the reported speeds, and the
next one on the new readings. Taken at face value, the reset step counted as a standstill
and left a running tram ~9 m behind, confident, for half a minute.

**Odometer glitches.** A step the reported speeds cannot have run (:func:`odometer_glitches`;
counted, ``odometer_glitch``) is no measurement either: a reading that jumps ahead and
comes back, one that stands still while the tram runs at 10 m/s (a frozen counter), one
read in kilometres. Taken at face value, one reading 100 m ahead put the tram 100 m and
then 200 m ahead, confident, and the right fixes were thrown out as unreachable; a frozen
counter kept a running tram confident 20-30 m behind. That step too runs on the speeds,
and the next one on the new readings. The bounds are physics (the speeds at both ends, the
greatest acceleration) with a margin: they catch what cannot be, not what is unlikely.

>>> import numpy as np
>>> from antikol import VehicleReport
>>> from antikol.positioning.fleet import RunSinceFix
>>> last = VehicleReport("T1", 10.0, 50.06, 19.94, 8.0, 90.0, odometer_m=1000.0)
>>> ran = RunSinceFix(np.array([8.0]), np.array([1.0]), np.array([True]))  # 8 m in 1 s
>>> stale_fixes(np.array([50.06]), np.array([19.94]), [last], ran, run_m=2.0).tolist()
[True]
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from antikol.positioning.fleet import FleetState, RunSinceFix
from antikol.positioning.odometerresolution import glitch_margin, odometer_resolution
from antikol.report import VehicleReport

__all__ = [
    "odometer_glitches",
    "odometer_resets",
    "previous_odometer",
    "stale_fixes",
    "unusable_odometers",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: An odometer reading this far below the previous one is a reset, not rounding, m.
ODOMETER_BACK_M = 1.0
#: An odometer step may differ from what the speeds allow by this much (the speeds' and the
#: counter's own errors and rounding), m, plus :data:`ODOMETER_MARGIN_FRACTION` of the run.
ODOMETER_MARGIN_M = 2.0
ODOMETER_MARGIN_FRACTION = 0.1


def stale_fixes(
    lat: FloatArray,
    lon: FloatArray,
    previous: Sequence[VehicleReport | None],
    since_fix: RunSinceFix,
    *,
    run_m: float,
) -> BoolArray:
    """Which reports repeat the previous report's position although the vehicle ran on.

    Parameters
    ----------
    lat, lon : ndarray of float
        The new reports' position, degrees.
    previous : sequence of VehicleReport or None
        Each vehicle's previous report (None: none yet).
    since_fix : RunSinceFix
        How far each vehicle ran since its last fix
        (:meth:`~antikol.positioning.fleet.FleetState.run_since_fix`).
    run_m : float, keyword-only
        The distance the vehicle must have run since its last fix for a repeated position
        to be stale, m.

    Returns
    -------
    ndarray of bool
    """
    same = np.fromiter(
        (p is not None and lat[i] == p.lat and lon[i] == p.lon for i, p in enumerate(previous)),
        bool,
        len(previous),
    )
    if not same.any():
        return same
    ran = np.nan_to_num(since_fix.distance_m)
    return same & np.isfinite(since_fix.seconds) & (ran >= run_m)


def odometer_resets(odometer_m: FloatArray, before_m: FloatArray) -> BoolArray:
    """Which odometer readings went back (by ``ODOMETER_BACK_M`` or more) since the
    vehicle's previous reading (NaN, either: no reading).

    >>> odometer_resets(np.array([12.0, 1000.5, np.nan]), np.array([8000.0, 1000.9, 5.0]))
    array([ True, False, False])
    """
    with np.errstate(invalid="ignore"):
        return np.asarray(odometer_m <= before_m - ODOMETER_BACK_M, dtype=bool)


def odometer_glitches(
    step_m: FloatArray,
    dt_s: FloatArray,
    speed_before_mps: FloatArray,
    speed_mps: FloatArray,
    *,
    max_accel_mps2: float,
    max_speed_mps: float,
    extra_margin_m: FloatArray | float = 0.0,
) -> BoolArray:
    """Which odometer steps no run between the two reports' speeds can explain.

    With speeds ``v0`` and ``v1`` at the ends of ``dt`` and at most ``max_accel_mps2``
    between them, the run lies between ``min(v0, v1)·dt − a·dt²/2`` (at least 0) and
    ``max(v0, v1)·dt + a·dt²/2`` (at most ``max_speed_mps·dt``); a step outside that by
    more than :data:`ODOMETER_MARGIN_M` plus :data:`ODOMETER_MARGIN_FRACTION` of the
    larger bound is a glitch.

    Parameters
    ----------
    step_m : ndarray of float
        Odometer reading minus the previous report's, m (NaN: no step to judge).
    dt_s : ndarray of float
        Time between the two reports, s.
    speed_before_mps, speed_mps : ndarray of float
        The reported speeds of the previous report and of this one, m/s.
    max_accel_mps2, max_speed_mps : float, keyword-only
        The physical bounds.
    extra_margin_m : ndarray of float or float, keyword-only
        Added to the margin, m: a coarse odometer's steps
        (:func:`~antikol.positioning.odometerresolution.glitch_margin`).

    Returns
    -------
    ndarray of bool

    >>> odometer_glitches(np.array([10.3, 0.0, 110.0, 0.0]), np.ones(4), np.full(4, 10.0),
    ...                   np.array([10.0, 10.0, 10.0, 0.0]), max_accel_mps2=3.5,
    ...                   max_speed_mps=30.0).tolist()
    [False, True, True, False]
    """
    dt = np.maximum(dt_s, 0.0)
    slack = 0.5 * max_accel_mps2 * dt * dt
    low = np.maximum(np.minimum(speed_before_mps, speed_mps) * dt - slack, 0.0)
    high = np.minimum(np.maximum(speed_before_mps, speed_mps) * dt + slack, max_speed_mps * dt)
    margin = ODOMETER_MARGIN_M + ODOMETER_MARGIN_FRACTION * high + extra_margin_m
    with np.errstate(invalid="ignore"):
        return np.asarray((step_m < low - margin) | (step_m > high + margin), dtype=bool)


def unusable_odometers(
    fleet: FleetState,
    rows: npt.NDArray[np.int64],
    t: FloatArray,
    speed_mps: FloatArray,
    odometer_m: FloatArray,
    *,
    max_accel_mps2: float,
    max_speed_mps: float,
) -> tuple[BoolArray, BoolArray]:
    """Which new readings reset the odometer (:func:`odometer_resets`) and which others
    make a step the speeds cannot have run (:func:`odometer_glitches`), against each
    vehicle's state in ``fleet`` (read only) before the reports of ``rows`` (time ``t``,
    s; speed, m/s; reading, m); a coarse odometer's resolution
    (:mod:`~antikol.positioning.odometerresolution`) widens the bounds."""
    if np.isnan(odometer_m).all():  # (no readings: neither, as below; most feeds have none)
        return np.zeros(len(rows), dtype=bool), np.zeros(len(rows), dtype=bool)
    reset = odometer_resets(odometer_m, fleet.odo[rows])
    glitch = ~reset & odometer_glitches(
        odometer_m - previous_odometer(fleet, rows),
        t - fleet.t[rows],
        fleet.v[rows],
        speed_mps,
        max_accel_mps2=max_accel_mps2,
        max_speed_mps=max_speed_mps,
        extra_margin_m=glitch_margin(odometer_resolution(fleet, rows), margin_m=ODOMETER_MARGIN_M),
    )
    return reset, glitch


def previous_odometer(fleet: FleetState, rows: npt.NDArray[np.int64]) -> FloatArray:
    """The odometer reading of each vehicle's previous report, m (NaN when that report had
    none: the last reading is older, and its step spans more than one report)."""
    return np.fromiter(
        (
            math.nan if (r := fleet.last[row]) is None or r.odometer_m is None else fleet.odo[row]
            for row in rows.tolist()
        ),
        float,
        len(rows),
    )
