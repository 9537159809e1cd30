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
``stale_fix``).

**Reset odometers.** Some feeds report the distance run since the start of the trip, back
to zero at every new trip. A reading that goes back (:func:`odometer_resets`; counted,
``odometer_reset``) leaves no baseline: that step runs on the reported speeds, and the
next one on the new readings. Taken at face value, the reset step counted as a standstill
and left a running tram ~9 m behind, confident, for half a minute.

>>> import numpy as np
>>> from antikol import VehicleReport
>>> last = VehicleReport("T1", 10.0, 50.06, 19.94, 8.0, 90.0, odometer_m=1000.0)
>>> now = VehicleReport("T1", 11.0, 50.06, 19.94, 8.0, 90.0, odometer_m=1008.0)
>>> stale_fixes([now], [last], np.array([10.0]), np.array([1000.0]), np.array([8.0]),
...             run_m=2.0).tolist()
[True]
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from antikol.report import VehicleReport

__all__ = ["odometer_resets", "stale_fixes"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: A vehicle reporting less speed than this is standing: a receiver may hold its position
#: then (static hold), m/s.
_MOVING_MPS = 1.0
#: An odometer reading this far below the previous one is a reset, not rounding, m.
ODOMETER_BACK_M = 1.0


def stale_fixes(
    reports: Sequence[VehicleReport],
    previous: Sequence[VehicleReport | None],
    t_fix_s: FloatArray,
    odometer_fix_m: FloatArray,
    speed_before_mps: FloatArray,
    *,
    run_m: float,
) -> BoolArray:
    """Which reports repeat the previous report's position although the vehicle ran on.

    Parameters
    ----------
    reports : sequence of VehicleReport
        The new reports.
    previous : sequence of VehicleReport or None
        Each vehicle's previous report (None: none yet).
    t_fix_s, odometer_fix_m : ndarray of float
        Per report: the time (s) and odometer (m, NaN: none) of the vehicle's last position
        fix (NaN time: none yet).
    speed_before_mps : ndarray of float
        Per report: the speed the vehicle reported before, m/s.
    run_m : float, keyword-only
        The distance the vehicle must have run since its last fix, by its odometer or
        else by its reported speeds, for a repeated position to be stale, m.

    Returns
    -------
    ndarray of bool
    """
    n = len(reports)
    same = np.fromiter(
        (
            p is not None and r.lat == p.lat and r.lon == p.lon
            for r, p in zip(reports, previous, strict=True)
        ),
        bool,
        n,
    )
    if not same.any():
        return same
    t = np.fromiter((r.t for r in reports), float, n)
    speed = np.fromiter((r.speed_mps for r in reports), float, n)
    odometer = np.fromiter(
        (np.nan if r.odometer_m is None else r.odometer_m for r in reports), float, n
    )
    has_odometer = np.isfinite(odometer) & np.isfinite(odometer_fix_m)
    with np.errstate(invalid="ignore"):
        by_odometer = odometer - odometer_fix_m
        by_speed = np.where(
            speed >= _MOVING_MPS, 0.5 * (speed + speed_before_mps) * (t - t_fix_s), 0.0
        )
    ran = np.where(has_odometer, by_odometer, by_speed)
    return same & np.isfinite(t_fix_s) & (np.nan_to_num(ran) >= run_m)


def odometer_resets(odometer_m: FloatArray, before_m: FloatArray) -> BoolArray:
    """Which odometer readings went back (by ``ODOMETER_BACK_M`` or more) since the
    vehicle's previous reading (NaN, either: no reading).

    >>> odometer_resets(np.array([12.0, 1000.5, np.nan]), np.array([8000.0, 1000.9, 5.0]))
    array([ True, False, False])
    """
    with np.errstate(invalid="ignore"):
        return np.asarray(odometer_m <= before_m - ODOMETER_BACK_M, dtype=bool)
