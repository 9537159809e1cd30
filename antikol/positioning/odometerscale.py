"""The scale of each vehicle's odometer, learnt from its own fixes.

A wheel odometer counts wheel turns times a nominal circumference. A worn wheel, or a
diameter set wrong at the last wheel change, makes it read a few per cent long or short,
the same for the whole day. The positioning trusts an odometer step to about one per cent
(``odometer_sigma_fraction``: it is the best measure of the distance run between two
fixes), so a scale 4 % off moves every hypothesis too far or too short at every step. The
along-track estimate then settles metres away from the fixes, the right track's hypothesis
builds a lag its fixes contradict, and past a switch the wrong branch can win. In the
street simulator, scale errors of σ 4 % per tram took the along-track RMS error from
2.0–2.3 m to 6.6–8.0 m, and the right branch past switches from 99 % to 88 %.

Every vehicle's odometer is therefore read through a scale of its own
(:func:`corrected_odometers`): each new reading becomes the previous corrected reading plus
the scale times the raw increment. A scale that changes never moves the past, and a reset
(the reading falling back) stays a fall.

The scale is learnt from the vehicle's committed fixes (:func:`learn_odometer_scale`).
Along a run of fixes of one lineage, each fix is a point: the raw odometer run since the
run began, and the lineage's progress along the track (the distance between the fixes'
places on the track) minus that run. The points lie on a line whose slope is the scale
error; the fixes' errors along the track (white noise, bias, a latency) scatter them about
it but do not grow with the distance. The slope is fitted over every point (not from the
run's two ends, whose errors would jitter it by their metres at every fix), pooled over the
runs, as the posterior mean under a prior of ``odometer_scale_sigma`` (0 turns the learning
off); a few hundred metres give it to a per cent, a few kilometres to a few tenths. A new
lineage (another track, a restart) begins a new run, and so does a step whose progress and
odometer disagree beyond any scale (a reset, a glitch, a jump). The pooled fit is halved
past :data:`POOL_M` of odometer, so that a scale that changes (a wheel change in service)
is followed.

>>> import numpy as np
>>> from antikol.positioning.fleet import FleetState
>>> fleet = FleetState(k=1)
>>> fleet.grow(1)
>>> rows = np.array([0])
>>> for k in range(200):  # 8 m a second by the fixes, 8.4 m by the odometer (0.952)
...     odo = corrected_odometers(fleet, rows, np.array([1000.0 + 8.4 * k]))
...     learn_odometer_scale(fleet, rows, odo, np.array([8.0 * k]), np.array([4.0]),
...                          np.array([k == 0]), np.array([k > 0]), prior_sigma=0.03)
>>> round(float(fleet.oscale[0]), 3)
0.953
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from antikol.positioning.fleet import FleetState
from antikol.positioning.odometerresolution import learn_odometer_resolution

__all__ = ["MAX_SCALE_ERROR", "POOL_M", "corrected_odometers", "learn_odometer_scale"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

#: The pooled fit of the runs before is halved when the pooled odometer run passes this, m.
POOL_M = 5000.0
#: The learnt scale stays within 1 ± this (a reading further off is no odometer).
MAX_SCALE_ERROR = 0.25
#: A step whose progress and odometer increment differ by more than this share of the
#: increment plus :data:`_JUMP_M` breaks the run of fixes (a reset, a jump, a reversal).
_STEP_TOLERANCE = 0.2
_JUMP_M = 15.0
#: The fixes' errors along the track are not independent (a bias that persists for a
#: minute): the regression takes them at this many fixes' worth of variance each.
_CORRELATED_FIXES = 10.0


def corrected_odometers(fleet: FleetState, rows: IntArray, raw_m: FloatArray) -> FloatArray:
    """The readings of ``raw_m`` (m, NaN: none) through each vehicle's learnt scale.

    Parameters
    ----------
    fleet : FleetState
        Its ``oraw`` and ``ocor`` (the last raw and corrected readings, m) are updated, and
        the raw steps teach the odometer's resolution
        (:func:`~antikol.positioning.odometerresolution.learn_odometer_resolution`).
    rows : ndarray of int
        Each reading's vehicle row (each vehicle once).
    raw_m : ndarray
        Odometer readings as reported, m.

    Returns
    -------
    ndarray
        Corrected readings, m: the last corrected reading plus the scale times the raw
        increment (the raw reading itself at a vehicle's first one); NaN where none.
    """
    raw = np.asarray(raw_m, dtype=float)
    have = np.isfinite(raw)
    if not have.any():  # (most feeds have no odometer: nothing to read or keep)
        return raw
    last_raw = fleet.oraw[rows]
    known = np.isfinite(raw) & np.isfinite(last_raw)
    # (the counter's unit shows in its raw steps; a step back is a reset, no step)
    raw_step = np.where(known, raw - np.where(known, last_raw, 0.0), np.nan)
    learn_odometer_resolution(fleet, rows, np.where(raw_step >= 0.0, raw_step, np.nan))
    scaled = fleet.ocor[rows] + fleet.oscale[rows] * (raw - np.where(known, last_raw, 0.0))
    out = np.where(known, scaled, raw)
    fleet.oraw[rows[have]] = raw[have]
    fleet.ocor[rows[have]] = out[have]
    return np.asarray(out, dtype=np.float64)


def learn_odometer_scale(
    fleet: FleetState,
    rows: IntArray,
    odometer_m: FloatArray,
    progress_m: FloatArray,
    along_sigma_m: FloatArray,
    restart: BoolArray,
    usable: BoolArray,
    *,
    prior_sigma: float,
) -> None:
    """Pool each vehicle's lineage progress against its raw odometer; update its scale.

    Parameters
    ----------
    fleet : FleetState
        Its ``olf, zlf`` (raw odometer and lineage progress at the last fix, m), the
        current run's ``ox, oy`` (odometer run and progress minus run, m), ``orn`` (its
        fixes), ``omx, omy`` (their means, m) and ``ocxx, ocxy`` (co-moments, m²), the
        pooled co-moments of the runs before ``opxx, opxy`` (m²) and odometer ``osum``
        (m), and ``oscale`` are updated; the raw reading of each vehicle's current report
        is ``oraw`` (see :func:`corrected_odometers`).
    rows : ndarray of int
        Vehicle rows of committed fixes (each vehicle once).
    odometer_m : ndarray
        The fixes' corrected odometer readings, m (NaN: the report had none).
    progress_m : ndarray
        The reported lineage's progress along the track at each fix, m.
    along_sigma_m : ndarray
        Each fix's error along the track (white noise and bias), m.
    restart : ndarray of bool
        A new lineage starts at the fix (a fresh start, another track).
    usable : ndarray of bool
        The odometer's step since the last report is a measurement (False: a reset, a
        glitch, no reading before); False breaks the run.
    prior_sigma : float, keyword-only
        Standard deviation of the scale error before any fix (0: no learning).
    """
    has = np.isfinite(odometer_m)
    if not has.any() and not np.isfinite(fleet.olf[rows]).any():
        return  # no odometer now nor at the last fixes: no run to end or go on
    raw = np.where(has, fleet.oraw[rows], np.nan)
    d_raw = raw - fleet.olf[rows]
    d_z = progress_m - fleet.zlf[rows]
    with np.errstate(invalid="ignore"):
        cont = (
            has
            & usable
            & ~restart
            & np.isfinite(d_raw)
            & np.isfinite(d_z)
            & (d_raw >= 0.0)
            & (np.abs(d_z - d_raw) <= _STEP_TOLERANCE * d_raw + _JUMP_M)
        )
    f = fleet
    # a run of fixes ends: its regression joins the pooled one, a new run starts here
    ends = rows[has & ~cont]
    f.opxx[ends] += f.ocxx[ends]
    f.opxy[ends] += f.ocxy[ends]
    f.ox[ends] = f.oy[ends] = f.omx[ends] = f.omy[ends] = f.ocxx[ends] = f.ocxy[ends] = 0.0
    f.orn[ends] = 1.0
    # the run goes on: (odometer run, progress minus run) is one more point of its line
    r = rows[cont]
    f.osum[r] += d_raw[cont]
    x = f.ox[r] + d_raw[cont]
    y = f.oy[r] + (d_z - d_raw)[cont]
    f.ox[r], f.oy[r] = x, y
    n = f.orn[r] + 1.0
    dx = x - f.omx[r]
    f.omx[r] += dx / n
    f.omy[r] += (y - f.omy[r]) / n
    f.ocxx[r] += dx * (x - f.omx[r])
    f.ocxy[r] += dx * (y - f.omy[r])
    f.orn[r] = n
    f.olf[rows] = raw
    f.zlf[rows] = np.where(has, progress_m, np.nan)
    full = r[f.osum[r] > POOL_M]
    f.osum[full] *= 0.5
    f.opxx[full] *= 0.5
    f.opxy[full] *= 0.5
    if prior_sigma <= 0.0 or not len(r):
        return
    sxx = f.opxx[r] + f.ocxx[r]
    sxy = f.opxy[r] + f.ocxy[r]
    noise = _CORRELATED_FIXES * along_sigma_m[cont] ** 2
    error = sxy / (sxx + noise / prior_sigma**2)
    fleet.oscale[r] = 1.0 + np.clip(error, -MAX_SCALE_ERROR, MAX_SCALE_ERROR)
