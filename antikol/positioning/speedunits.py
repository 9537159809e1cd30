"""Speeds that a feed reports in the wrong unit, recognised from the vehicle's own fixes.

GTFS-realtime's ``speed`` and most vehicle-location feeds are in m/s, but some producers
fill the field in km/h, knots or mph, and nothing in a report says which. A tram at
40 km/h that reports 40 "m/s" has its fixes rejected as impossible speeds, its along-track
filter runs tens of metres ahead of exact fixes, and its braking distance is thirteen
times too long. Its fixes tell the unit: each *trail* (from a fix to the first later fix
at least :data:`TRAIL_RUN` reported units or :data:`TRAIL_S` away, with no gap between
reports over :data:`MAX_STEP_S`) adds the straight
distance between its ends and the integral of the reported speeds over it to two sums per
vehicle (halved once the run passes :data:`POOL_RUN`, so that a feed that changes is
followed). Once the fixes have moved :data:`MIN_DISPLACEMENT_M`, a ratio of the sums near
a unit's factor in m/s (:data:`UNIT_FACTORS`, within :data:`UNIT_TOLERANCE`) converts the
vehicle's speeds from then on; a ratio near 1 keeps them as they are. A straight line is a
little shorter than a curved track and GPS noise lengthens short moves: the factors
(1, 0.51, 0.45, 0.28) are far enough apart for that not to matter.

>>> import numpy as np
>>> from collections import Counter
>>> from antikol.positioning.fleet import FleetState
>>> fleet, stats = FleetState(k=1), Counter()
>>> fleet.grow(1)
>>> rows = np.array([0])
>>> for k in range(60):  # 10 m/s to the north, reported in km/h
...     speed = learn_speed_units(fleet, stats, rows, np.array([float(k)]), np.array([36.0]),
...                               np.array([0.0]), np.array([10.0 * k]), np.array([True]))
>>> round(float(fleet.uscale[0]), 4), stats["speed_unit_km/h"]
(0.2778, 1)
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from antikol.ingest.feed_common import SPEED_UNITS
from antikol.positioning.fleet import FleetState
from antikol.report import VehicleReport

__all__ = [
    "MAX_STEP_S",
    "MIN_DISPLACEMENT_M",
    "POOL_RUN",
    "TRAIL_RUN",
    "TRAIL_S",
    "UNIT_FACTORS",
    "UNIT_TOLERANCE",
    "in_recognised_units",
    "learn_speed_units",
]

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

#: m/s per reported unit, by the unit's name ("m/s": taken as reported).
UNIT_FACTORS: Mapping[str, float] = SPEED_UNITS
#: A pooled ratio within this fraction of a unit's factor is taken as that unit.
UNIT_TOLERANCE = 0.15
#: A trail ends at the first fix this far by the reported speeds (in their unit) ...
TRAIL_RUN = 100.0
#: ... or this long after its start, s.
TRAIL_S = 20.0
#: A trail is broken by a gap between two reports longer than this, s.
MAX_STEP_S = 5.0
#: A trail over which the reported speeds ran less than this (standing, creeping) is not
#: pooled: GPS noise would be all its displacement.
_TRAIL_MIN_RUN = 20.0
#: Both sums are halved when the pooled run passes this (reported units).
POOL_RUN = 3000.0
#: The unit is judged once the pooled fixes have moved this far, m.
MIN_DISPLACEMENT_M = 200.0


def learn_speed_units(
    fleet: FleetState,
    stats: Counter[str],
    rows: IntArray,
    t_s: FloatArray,
    speed: FloatArray,
    x_m: FloatArray,
    y_m: FloatArray,
    has_fix: BoolArray,
    *,
    reports: Sequence[VehicleReport] | None = None,
) -> FloatArray:
    """Pool each vehicle's reported speeds against its fixes; judge its speeds' unit.

    Parameters
    ----------
    fleet : FleetState
        Its ``ux, uy`` (the trail's first fix, local m), ``ut, uv`` (the last report's
        time, s, and speed as reported), ``urun`` (the trail's run by the speeds),
        ``udisp, urep`` (the pooled displacement, m, and run, reported units) and
        ``uscale`` (m/s per reported unit) are updated; when the unit changes, the speeds
        kept in ``v``, ``v_nofix`` and the along-track filter are converted.
    stats : Counter
        Counts ``speed_unit_<name>`` when a vehicle's speeds are found to be in a unit.
    rows : ndarray of int
        Each report's vehicle row (each vehicle once).
    t_s : ndarray
        Report times, s.
    speed : ndarray
        Reported speeds, m/s as the vehicle's speeds are converted now
        (:func:`in_recognised_units`).
    x_m, y_m : ndarray
        Local position of each report, m.
    has_fix : ndarray of bool
        The report carries a usable position fix.
    reports : sequence of VehicleReport, optional, keyword-only
        The reports, to name a converted vehicle in the log (else its row).

    Returns
    -------
    ndarray
        The speeds, m/s, converted where a unit was recognised with this report.
    """
    f = fleet
    before = f.uscale[rows].copy()
    raw = speed / before
    dt = t_s - f.ut[rows]
    step = np.isfinite(dt) & (dt > 0.0)
    run = np.where(step, 0.5 * (raw + f.uv[rows]) * np.where(step, dt, 0.0), 0.0)
    f.urun[rows] += np.where(np.isfinite(run), run, 0.0)
    newer = ~np.isfinite(f.ut[rows]) | step
    f.ut[rows] = np.where(newer, t_s, f.ut[rows])
    f.uv[rows] = np.where(newer, raw, f.uv[rows])
    # a gap between reports breaks the trail: the speeds between them are not known
    f.ux[rows[step & (dt > MAX_STEP_S)]] = np.nan
    fixed = has_fix & newer
    anchored = fixed & np.isfinite(f.ux[rows])
    span = t_s - f.utrail[rows]
    done = anchored & ((f.urun[rows] >= TRAIL_RUN) | (span >= TRAIL_S))
    pooled = done & (f.urun[rows] >= _TRAIL_MIN_RUN)
    # (the guards skip what changes nothing: most reports end no trail)
    if pooled.any():
        r = rows[pooled]
        f.udisp[r] += np.hypot(x_m[pooled] - f.ux[r], y_m[pooled] - f.uy[r])
        f.urep[r] += f.urun[r]
        full = r[f.urep[r] > POOL_RUN]
        f.udisp[full] *= 0.5
        f.urep[full] *= 0.5
    # a new trail starts at every fix that ends one, and at the first fix of a vehicle
    start = done | (fixed & ~anchored)
    if start.any():
        r = rows[start]
        f.ux[r], f.uy[r], f.utrail[r], f.urun[r] = x_m[start], y_m[start], t_s[start], 0.0
    if pooled.any():
        for i in np.flatnonzero(pooled & (f.udisp[rows] >= MIN_DISPLACEMENT_M)).tolist():
            name = f"row {rows[i]}" if reports is None else repr(reports[i].vehicle_id)
            _judge(f, stats, int(rows[i]), name)
    return np.asarray(speed * (f.uscale[rows] / before), dtype=np.float64)


def _judge(f: FleetState, stats: Counter[str], row: int, vehicle: str) -> None:
    """Take the unit whose factor is nearest the vehicle's pooled ratio, if near enough."""
    ratio = float(f.udisp[row] / f.urep[row])
    name, factor = min(UNIT_FACTORS.items(), key=lambda u: abs(np.log(ratio / u[1])))
    if abs(ratio / factor - 1.0) > UNIT_TOLERANCE or factor == f.uscale[row]:
        return
    # the speeds kept from before are converted with the rest (the step from them to the
    # next report's is no acceleration)
    change = factor / float(f.uscale[row])
    f.uscale[row] = factor
    f.v[row] *= change
    f.v_nofix[row] *= change
    f.kf.v[row] *= change
    f.kf.psv[row] *= change
    f.kf.pvv[row] *= change * change
    stats[f"speed_unit_{name}"] += 1
    logger.warning(
        "vehicle %s: its fixes moved %.0f m while its speeds ran %.0f units; its speeds "
        "are taken to be in %s from now on",
        vehicle,
        f.udisp[row],
        f.urep[row],
        name,
    )


def in_recognised_units(
    fleet: FleetState, row_of: Mapping[str, int], reports: Sequence[VehicleReport]
) -> list[VehicleReport]:
    """The reports with their speeds in m/s, for vehicles whose speeds' unit was recognised
    (:func:`learn_speed_units`); the others as they are (the same objects)."""
    out = list(reports)
    if not np.any(fleet.uscale != 1.0):  # the usual case: every feed in m/s
        return out
    for i, r in enumerate(out):
        row = row_of.get(r.vehicle_id)
        if row is not None and fleet.uscale[row] != 1.0:
            out[i] = replace(r, speed_mps=r.speed_mps * float(fleet.uscale[row]))
    return out
