"""Odometers read out on a slower cycle than the reports: held readings, filled in.

Some on-board units read their wheel counter every few seconds and send the last value
they read with every report. Between two reports a second apart such a counter says 0 m of
a tram's 8 m, and then, at the report after its next reading, the 40 m of five seconds at
once. Taken as wheel measurements those steps are a standstill and a burst: on the
simulator's street receiver (seeds 4–6 pooled, ``python benchmarks/positioning_accuracy.py
--gps urban --gps-set odometer_period_s=5``) 311 of 779 estimates past a switch were on the
wrong branch and 724 confident estimates wrong; filled in, 8 and 1 (a counter read every
report: 5 and 1). Read every 2 s: 53 and 48 → 4 and 2; every 10 s: 349 and 1,047 → 9
and 5.

**What gives such a counter away** (:func:`held_readings`): a reading that stays the same
while the reported speeds ran on clearly — at least twice the counter's smallest step so
far, and between 2 m and :data:`HELD_MIN_RUN_M` (no counter in use is that coarse:
:mod:`~antikol.positioning.odometerresolution` models coarser units as rounding) — and
then a step that catches up the run of the whole hold up to some moment of its last step,
within :data:`CATCH_UP_TOLERANCE_M` plus :data:`CATCH_UP_TOLERANCE_FRACTION` of it. A
coarse counter also stands still over runs shorter than its unit, but its steps are all
multiples of the unit, its smallest step: a catch-up is evidence only once the counter
has made a step of :data:`HELD_MIN_RUN_M` or less, or when it is no multiple of the
smallest step (within 5 %). A frozen counter never catches up. :data:`CONFIRMATIONS`
such catch-ups make the vehicle's counter a held one, for good, and its resolution is
learnt afresh from the filled-in readings (what was learnt from its zero steps and
catch-ups means nothing).

**How its readings are filled in.** A held counter's reading is the distance at its last
update, and the update before a changed reading lies between the two reports. The
vehicle's distance is then the reading plus its run by the reported speeds since
(trapezoids of the speeds, a standing vehicle's speeds taken as 0): while the reading
holds, the run goes on; when it changes, the run carried over is what the speeds ran
beyond the new reading, kept between 0 (the update just now) and the last step's run (the
update just after the previous report), and never so small that the reading goes back.
The filled-in steps are the speeds' runs, corrected at every update: the counter bounds
the speeds' drift, the speeds fill in between its updates.

**Until then** a reading that stays the same over a clear run (as above, or over 2 m once
the counter caught up a hold) is no measurement (NaN): that step runs on the speeds, as a
frozen counter's do. Below 2 m of running a step of 0 is taken as it comes (a tram
creeping into a stop). Counters read at every report never stand still over a clear run:
their readings pass unchanged.

>>> import numpy as np
>>> from antikol.positioning.fleet import FleetState
>>> fleet = FleetState(4)
>>> fleet.grow(1)
>>> rows = np.array([0])
>>> out = []
>>> def run_m(t):  # from standstill at 1 m/s² up to 8 m/s
...     return 0.5 * t * t if t <= 8 else 32.0 + 8.0 * (t - 8)
>>> out = []
>>> for k in range(40):  # the counter read every 3 s
...     raw = 1000.0 + run_m(3 * (k // 3))
...     out.append(held_readings(fleet, rows, np.array([float(k)]),
...                              np.array([float(min(k, 8))]), np.array([raw]))[0])
>>> bool(is_held(fleet, rows)[0])
True
>>> (np.array(out[-8:]) - [1000.0 + run_m(k) for k in range(32, 40)]).round(1).tolist()
[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
"""

from __future__ import annotations

from typing import Final

import numpy as np
import numpy.typing as npt

from antikol.positioning.fleet import FleetState
from antikol.positioning.odometerresolution import (
    COARSE_RESOLUTION_M,
    CONFIRMATIONS,
    forget_odometer_resolution,
)
from antikol.thresholds import STANDING_SPEED_MPS

__all__ = [
    "CATCH_UP_TOLERANCE_FRACTION",
    "CATCH_UP_TOLERANCE_M",
    "HELD_MIN_RUN_M",
    "held_readings",
    "is_held",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: A reading that stays the same over a step the speeds ran at least this far is held, m
#: ...
HELD_MIN_RUN_M: Final = COARSE_RESOLUTION_M
#: ... or over twice the counter's smallest step, if that is more than this, m.
_HELD_MIN_RUN_FINE_M: Final = 2.0
#: A catch-up step matches the run of its hold within this, m, ...
CATCH_UP_TOLERANCE_M: Final = 1.0
#: ... plus this share of the run.
CATCH_UP_TOLERANCE_FRACTION: Final = 0.05
#: A step within this share of its unit of a multiple of a counter's smallest step may be
#: one of a coarse counter's.
_MULTIPLE_TOLERANCE: Final = 0.05
#: A counter step counts as no change below this, m (a float's rounding).
_SAME_M = 1e-6


def is_held(fleet: FleetState, rows: IntArray) -> npt.NDArray[np.bool_]:
    """Which vehicles' odometers are known to be read out on a slower cycle."""
    return np.asarray(fleet.kn[rows] >= CONFIRMATIONS, dtype=bool)


def _catches_up(
    step: FloatArray,
    hold_low: FloatArray,
    ran: FloatArray,
    run: FloatArray,
    smallest: FloatArray,
    clear_run: FloatArray,
) -> npt.NDArray[np.bool_]:
    """Whether each counter step (m) is a held counter's catch-up: it ends a hold whose
    every step ran at least ``clear_run`` (``hold_low``, m), it makes up the run of the
    whole hold (``ran``, m) up to some moment of its last step (``run``, m), and the
    counter is no coarse one (it made a step of :data:`HELD_MIN_RUN_M` or less before, or
    this step is no multiple of its ``smallest``)."""
    tol = CATCH_UP_TOLERANCE_M + CATCH_UP_TOLERANCE_FRACTION * ran
    with np.errstate(invalid="ignore", divide="ignore"):
        fine = (smallest <= HELD_MIN_RUN_M) | (
            np.abs(step / smallest - np.round(step / smallest)) > _MULTIPLE_TOLERANCE
        )
        return np.asarray(
            fine & (hold_low >= clear_run) & (step >= ran - run - tol) & (step <= ran + tol),
            dtype=bool,
        )


def held_readings(
    fleet: FleetState, rows: IntArray, t_s: FloatArray, speed_mps: FloatArray, raw_m: FloatArray
) -> FloatArray:
    """Each vehicle's odometer reading, filled in where its counter is a held one.

    Parameters
    ----------
    fleet : FleetState
        Changed in place for ``rows``: the last reading ``kraw`` (m), the time ``kt`` (s)
        and speed ``kv`` (m/s) of the last report, the run since the counter's last update
        ``kacc`` (m), the shortest step run of the current hold ``klow`` (m, NaN: no hold),
        the smallest step its counter made ``kmin`` (m) and the catch-ups seen ``kn``; a
        vehicle found held has its odometer resolution forgotten.
    rows : ndarray of int
        Each report's vehicle row (each vehicle once).
    t_s : ndarray of float
        Report times, s.
    speed_mps : ndarray of float
        Reported speeds, m/s.
    raw_m : ndarray of float
        Odometer readings as reported, m (NaN: none).

    Returns
    -------
    ndarray of float
        The readings, m: as reported, or for a held counter the reading plus the run
        since its last update; a report no later than the vehicle's last passes as it
        is and changes nothing.
    """
    raw = np.asarray(raw_m, dtype=float)
    if not np.isfinite(raw).any() and not np.isfinite(fleet.kraw[rows]).any():
        return raw  # (most feeds have no odometer)
    t_s = np.asarray(t_s, dtype=float)
    late = t_s <= fleet.kt[rows]
    if late.any():
        # a report no later than the last one changes nothing (the positioner rejects
        # it for its time): its reading passes as it is
        out = raw.copy()
        on = ~late
        if on.any():
            out[on] = held_readings(fleet, rows[on], t_s[on], np.asarray(speed_mps)[on], raw[on])
        return out
    v = np.nan_to_num(np.asarray(speed_mps, dtype=float))
    # (a standing vehicle's reported speed is noise: summed over a stop it ran metres)
    v = np.where(v >= STANDING_SPEED_MPS, v, 0.0)
    dt = t_s - fleet.kt[rows]
    timed = np.isfinite(dt) & (dt > 0.0)
    v0 = fleet.kv[rows]
    run = np.where(timed, 0.5 * (v0 + v) * np.where(timed, dt, 0.0), 0.0)
    low = np.where(timed, np.minimum(v0, v) * np.where(timed, dt, 0.0), 0.0)
    last = fleet.kraw[rows]
    known = np.isfinite(raw) & np.isfinite(last)
    step = np.where(known, raw - np.where(known, last, 0.0), np.nan)
    with np.errstate(invalid="ignore"):
        same = known & (np.abs(step) <= _SAME_M)
        changed = known & (step > _SAME_M)
    acc = fleet.kacc[rows]
    hold_low = fleet.klow[rows]
    ran = acc + run
    smallest = fleet.kmin[rows]
    clear_run = np.clip(2.0 * smallest, _HELD_MIN_RUN_FINE_M, HELD_MIN_RUN_M)
    evidence = changed & _catches_up(step, hold_low, ran, run, smallest, clear_run)
    with np.errstate(invalid="ignore"):
        fleet.kmin[rows] = np.where(changed, np.fmin(smallest, step), smallest)
    was_held = is_held(fleet, rows)
    fleet.kn[rows] += evidence
    now_held = is_held(fleet, rows)
    if (now_held & ~was_held).any():
        forget_odometer_resolution(fleet, rows[now_held & ~was_held])
    # the run since the counter's last update: what the speeds ran beyond the new reading,
    # an update between the reports at most; never back (a standing vehicle's speeds
    # may have run it on too far)
    d_step = np.nan_to_num(step)
    carried = np.maximum(np.clip(ran - d_step, 0.0, run), acc - d_step)
    acc_new = np.where(same | ~np.isfinite(raw), ran, np.where(changed, carried, 0.0))
    with np.errstate(invalid="ignore"):
        fleet.klow[rows] = np.where(
            same, np.fmin(hold_low, low), np.where(np.isfinite(raw), np.nan, hold_low)
        )
    fleet.kacc[rows] = acc_new
    fleet.kraw[rows] = np.where(np.isfinite(raw), raw, last)
    fleet.kt[rows] = t_s
    fleet.kv[rows] = v
    # a counter not (yet) known as held that stands still over a clear run is no
    # measurement, if it counts finely or has caught up a hold before: the speeds carry
    # that step
    seen = fleet.kn[rows] >= 1.0
    with np.errstate(invalid="ignore"):
        suspect = same & (
            ((smallest <= HELD_MIN_RUN_M) & (low >= clear_run))
            | (seen & (low >= _HELD_MIN_RUN_FINE_M))
        )
    filled = np.where(suspect, np.nan, raw)
    return np.asarray(np.where(now_held & np.isfinite(raw), raw + acc_new, filled), dtype=float)
