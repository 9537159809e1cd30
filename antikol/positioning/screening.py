"""What positioning takes from a batch of reports before any fix meets the map.

Each report is screened against its vehicle's own past, in this order:

1. **the odometer**: a reading held while the vehicle runs on is no reading
   (:mod:`~antikol.positioning.odometerhold`), nor one coarser than the run it should
   measure (:mod:`~antikol.positioning.odometerresolution`), and the readings are put on
   the track's scale (:mod:`~antikol.positioning.odometerscale`);
2. **faults of the feed** (:mod:`~antikol.positioning.feedfaults`): a reset or glitching
   odometer leaves no baseline, and a position repeated while the vehicle runs on is no fix;
3. **speed units** learnt from the run between fixes (:mod:`~antikol.positioning.speedunits`);
4. **physics** (:func:`~antikol.positioning.physics.implausible`): a report that a vehicle
   cannot have made is refused and counted, and leaves the state untouched; after
   ``max_rejections_in_row`` refusals in a row the vehicle starts afresh from the evidence.

The feed's faults are counted only for the reports kept: a report that came late, its
odometer behind the last one's, is refused for its time and must not wipe the odometer's
baseline.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from antikol.positioning.config import PositioningConfig
from antikol.positioning.estimates import NOT_MEASURED
from antikol.positioning.feedfaults import stale_fixes, unusable_odometers
from antikol.positioning.fleet import FleetState
from antikol.positioning.odometerhold import held_readings
from antikol.positioning.odometerresolution import usable_readings
from antikol.positioning.odometerscale import corrected_odometers
from antikol.positioning.physics import implausible
from antikol.positioning.speedunits import learn_speed_units
from antikol.report import VehicleReport
from trackmap import TrackMap

__all__ = ["Screened", "screen_reports"]

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True, slots=True)
class Screened:
    """A batch of reports as positioning takes them (parallel arrays, one per report).

    Attributes
    ----------
    t : ndarray of float
        Report time, s.
    speed_mps : ndarray of float
        Reported speed in the units learnt for the vehicle, m/s.
    odometer_m : ndarray of float
        Usable odometer reading on the track's scale, m (NaN: none).
    x_m, y_m : ndarray of float
        The reported position in the map's local frame, m.
    no_fix : ndarray of bool
        The report carries no position fix (none measured, or a stale one).
    keep : ndarray of bool
        Not refused by physics.
    """

    t: FloatArray
    speed_mps: FloatArray
    odometer_m: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    no_fix: BoolArray
    keep: BoolArray


def screen_reports(
    fleet: FleetState,
    net: TrackMap,
    config: PositioningConfig,
    stats: Counter[str],
    reports: list[VehicleReport],
    rows: IntArray,
) -> Screened:
    """Screen one report per vehicle (see the module); updates ``fleet`` (the odometer's
    baselines, the refusals in a row, a restart) and counts in ``stats``.

    Parameters
    ----------
    fleet : FleetState
    net : TrackMap
        For its local frame.
    config : PositioningConfig
    stats : Counter
        Counts by event (``rejected_<reason>``, ``reset_after_rejections``,
        ``odometer_reset``, ``odometer_glitch``, ``stale_fix``, speed units).
    reports : list of VehicleReport
    rows : ndarray of int
        Each report's row in ``fleet``.

    Returns
    -------
    Screened
    """
    c, f, n = config, fleet, len(reports)
    t = np.fromiter((r.t for r in reports), float, n)
    speed = np.fromiter((r.speed_mps for r in reports), float, n)
    odo = np.fromiter(
        (math.nan if r.odometer_m is None else r.odometer_m for r in reports), float, n
    )
    odo = held_readings(f, rows, t, speed * f.uscale[rows], odo)
    odo = usable_readings(f, rows, corrected_odometers(f, rows, odo))
    no_fix = np.fromiter((r.fix_quality in NOT_MEASURED for r in reports), bool, n)
    reset, glitch = unusable_odometers(
        f, rows, t, speed, odo, max_accel_mps2=c.max_accel_mps2, max_speed_mps=c.max_speed_mps
    )
    lon = np.fromiter((r.lon for r in reports), float, n)
    lat = np.fromiter((r.lat for r in reports), float, n)
    stale = ~no_fix & stale_fixes(
        lat, lon, [f.last[r] for r in rows.tolist()],
        f.run_since_fix(rows, t, speed, odo), run_m=c.stale_fix_run_m,
    )  # fmt: skip
    no_fix |= stale
    xs, ys = net.to_local(lon, lat)
    xs, ys = np.atleast_1d(np.asarray(xs, float)), np.atleast_1d(np.asarray(ys, float))
    speed = learn_speed_units(f, stats, rows, t, speed, xs, ys, ~no_fix, reports=reports)
    keep = ~_refused(f, c, stats, reports, rows, (t, speed, xs, ys), no_fix)
    faults = {"odometer_reset": reset & keep, "odometer_glitch": glitch & keep,
              "stale_fix": stale & keep}  # fmt: skip
    unusable = faults["odometer_reset"] | faults["odometer_glitch"]
    f.odo[rows[unusable]] = f.odo_fix[rows[unusable]] = np.nan
    stats.update({k: int(v.sum()) for k, v in faults.items() if v.any()})
    return Screened(t, speed, odo, xs, ys, no_fix, keep)


def _refused(
    fleet: FleetState,
    config: PositioningConfig,
    stats: Counter[str],
    reports: list[VehicleReport],
    rows: IntArray,
    measured: tuple[FloatArray, FloatArray, FloatArray, FloatArray],
    no_fix: BoolArray,
) -> BoolArray:
    """The reports physics refuses (``measured``: time, speed, local x and y); a vehicle
    refused ``max_rejections_in_row`` times in a row starts afresh, and its report is kept."""
    f, c = fleet, config
    t, _, xs, ys = measured
    reason = implausible(f, c, rows, measured, no_fix)
    rejected = reason != ""
    # a copy of the last rejected fix is no new evidence that the vehicle is elsewhere
    repeat = rejected  # (all False when nothing is rejected)
    if rejected.any():
        repeat = f.repeats_rejected(rows, xs, ys, t, c.dead_reckoning_s)
        f.note_rejected(rows[rejected], xs[rejected], ys[rejected])
    for i in np.flatnonzero(rejected):
        row = rows[i]
        f.rejected[row] += 0 if repeat[i] else 1
        stats[f"rejected_{reason[i]}"] += 1
        if f.rejected[row] >= c.max_rejections_in_row:
            stats["reset_after_rejections"] += 1
            f.hs[row] = -1
            f.rejected[row] = 0
            rejected[i] = False
        else:
            logger.debug(
                "%s: report at t=%.1f rejected (%s)", reports[i].vehicle_id, t[i], reason[i]
            )
    return rejected
