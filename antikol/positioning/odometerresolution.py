"""How finely a vehicle's odometer counts, learnt from its readings.

Odometers are read out in steps: a tenth of a metre, a metre (HSL's ``odo``), ten metres,
a tenth of a kilometre; some are read out only every few seconds. Between two reports a
second apart, a counter in 10-m steps says 0 or 10 m of a tram's 8 m, and taken as a
wheel measurement good to a quarter of a metre that error is a jump along the track at
every step: with 10-m steps the right branch past a switch fell to about half and up to
5 % of confident estimates were wrong on the simulator (``python
benchmarks/positioning_accuracy.py --gps urban --gps-set odometer_resolution_m=10``).

Each vehicle's resolution is the smallest difference between two successive steps of its
odometer that differ, once :data:`CONFIRMATIONS` differences of that size have been seen
(:func:`learn_odometer_resolution`, :func:`odometer_resolution`): the steps of a counter,
and so their differences, are multiples of its unit. (The smallest step alone says
nothing of a fine counter until the vehicle creeps: at speed every step is metres long.
Successive steps at speed differ by the change of speed: up to about 3 m a second apart
while the tram accelerates or brakes hard, which is why only a coarser unit is modelled.
One difference alone may be a fault: a reading 100 m ahead, a counter that froze; a
counter's unit recurs.) A counter read out every few seconds is estimated finer than it
is, and its zero steps at speed stay glitches.

The error of one step is the difference of two roundings, of variance ``resolution² / 6``.
For a counter coarser than :data:`COARSE_RESOLUTION_M` the surplus over the configured
step error ``odometer_step_sigma_m`` (:func:`quantisation_sigma`) widens every use of the
step: the transition's scale, its outlier gate, the run's variance, the along-track filter
and dead reckoning; the glitch bounds widen by the resolution beyond their margin
(:func:`glitch_margin`), so that a step of 0 or of twice the run is no fault. A counter
coarser than :data:`MAX_USABLE_RESOLUTION_M` is not used (:func:`usable_readings`): one
step of it spans seconds of running, and the reported speeds say more. On the simulator
(seeds 4–6 of the street receiver, pooled), 10-m units: wrong past switches 406 → 19 of
779, confident and wrong 937 → 13; 100-m units: 384 → 46 and 1,240 → 69 (as without an
odometer). Units up to 6 m only widen the glitch bounds (modelling the rounding of 5-m
units made more estimates confident and wrong than it saved); HSL's integer metres change
nothing.

>>> import numpy as np
>>> quantisation_sigma(np.array([0.1, 1.0, 10.0, np.nan]), step_sigma_m=0.25).round(2).tolist()
[0.0, 0.0, 4.07, 0.0]
"""

from __future__ import annotations

from typing import Final

import numpy as np
import numpy.typing as npt

from antikol.positioning.fleet import FleetState

__all__ = [
    "COARSE_RESOLUTION_M",
    "CONFIRMATIONS",
    "MAX_USABLE_RESOLUTION_M",
    "forget_odometer_resolution",
    "glitch_margin",
    "learn_odometer_resolution",
    "odometer_resolution",
    "quantisation_sigma",
    "usable_readings",
]

FloatArray = npt.NDArray[np.float64]

#: An odometer whose steps come in units coarser than this is modelled as coarse, m.
COARSE_RESOLUTION_M: Final = 6.0
#: An odometer whose unit is coarser than this is not used at all, m: its steps say less
#: than the reported speeds.
MAX_USABLE_RESOLUTION_M: Final = 15.0
#: How many differences of one size between successive steps confirm a resolution.
CONFIRMATIONS: Final = 3


def learn_odometer_resolution(
    fleet: FleetState, rows: npt.NDArray[np.int64], step_m: FloatArray
) -> None:
    """Learn each vehicle's odometer resolution from its new step (see the module).

    Parameters
    ----------
    fleet : FleetState
        Changed in place for ``rows``: the smallest difference of successive steps
        (``oq``, m, NaN: none yet), how often one of that size was seen (``oqn``) and the
        last step (``ostep``, m).
    rows : ndarray of int
    step_m : ndarray of float
        Each vehicle's reading minus its previous report's, m (NaN: none).
    """
    with np.errstate(invalid="ignore"):
        change = np.abs(step_m - fleet.ostep[rows])
        changed = change > 1e-6
    fleet.ostep[rows] = step_m
    if not changed.any():
        return
    r, d = rows[changed], change[changed]
    known = fleet.oq[r]
    again = np.abs(d - known) <= 0.05 * known
    smaller = ~again & ~(d > known)  # (also where none is known: NaN)
    fleet.oqn[r] = np.where(again, fleet.oqn[r] + 1.0, np.where(smaller, 1.0, fleet.oqn[r]))
    fleet.oq[r] = np.where(smaller, d, known)


def forget_odometer_resolution(fleet: FleetState, rows: npt.NDArray[np.int64]) -> None:
    """Forget what was learnt of the resolution of the odometers of ``rows`` (their
    readings are filled in from now on: :mod:`~antikol.positioning.odometerhold`)."""
    fleet.oq[rows] = fleet.ostep[rows] = np.nan
    fleet.oqn[rows] = 0.0


def odometer_resolution(fleet: FleetState, rows: npt.NDArray[np.int64]) -> FloatArray:
    """Each vehicle's odometer resolution once confirmed, m (NaN: not yet)."""
    return np.where(fleet.oqn[rows] >= CONFIRMATIONS, fleet.oq[rows], np.nan)


def usable_readings(
    fleet: FleetState, rows: npt.NDArray[np.int64], odometer_m: FloatArray
) -> FloatArray:
    """The readings of ``odometer_m`` (m), NaN for vehicles whose odometer's unit is
    coarser than :data:`MAX_USABLE_RESOLUTION_M`: those run on their reported speeds."""
    coarse = odometer_resolution(fleet, rows) > MAX_USABLE_RESOLUTION_M
    return np.where(coarse, np.nan, odometer_m) if coarse.any() else odometer_m


def quantisation_sigma(resolution_m: FloatArray, *, step_sigma_m: float) -> FloatArray:
    """The error of one odometer step beyond the configured step error, m (0 where the
    resolution is :data:`COARSE_RESOLUTION_M` or finer, or unknown).

    Parameters
    ----------
    resolution_m : ndarray of float
        Each vehicle's odometer resolution, m (NaN: not known yet).
    step_sigma_m : float, keyword-only
        The configured error of one step, m (``odometer_step_sigma_m``).

    Returns
    -------
    ndarray of float
        ``sqrt(max(resolution² / 6 − step_sigma_m², 0))``, m.
    """
    # (NaN compares False: no np.nan_to_num, whose cost is most of a cycle's few rows)
    q = np.asarray(resolution_m, dtype=float)
    q = np.where(q > COARSE_RESOLUTION_M, q, 0.0)
    return np.sqrt(np.maximum(q * q / 6.0 - step_sigma_m * step_sigma_m, 0.0))


def glitch_margin(resolution_m: FloatArray, *, margin_m: float) -> FloatArray:
    """What the glitch bounds widen by for a coarse odometer: its resolution beyond
    ``margin_m`` (the bounds' own margin), m; 0 where it is finer or not known."""
    q = np.nan_to_num(np.asarray(resolution_m, dtype=float), nan=0.0)
    return np.maximum(q - margin_m, 0.0)
