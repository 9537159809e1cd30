"""Positions estimated without a fix: weak evidence of the branch a vehicle took.

Some reports carry a position that is no measurement of the antenna and yet not the last
known one either: NMEA's GGA fix quality 6 (RMC mode ``E``), the receiver's own dead
reckoning, and an HSL-style feed's ``loc`` ``ODO`` or ``DR``, a position the vehicle's
computer moves along its route by its odometer (both become ``fix_quality`` 6,
:data:`ESTIMATED_FIX_QUALITY`). Taken as a fix, such a position would be gated, learnt
and relocated from like one: a receiver that extrapolates its last velocity leaves the
track in a curve by metres a second, its estimates are refused as jumps, and a few in a
row restart the vehicle. Ignored, it throws away what the vehicle's computer knows of its
route just where the fixes fail: the dead-reckoned vehicle splits over both branches at a
switch, and which one it is reported on is a coin toss until a fix comes back.

So an estimated report is dead-reckoned like one without a fix (its odometer or speeds
carry the hypotheses; nothing is gated, learnt or relocated from it) and its position
then weighs the hypotheses: each by ``(1 − w)·exp(−d² / 2σ²) + w`` of its distance ``d``
to the estimate, σ ``estimated_fix_sigma_m``, ``w`` the fixes' ``outlier_weight``. The
latest estimate replaces the one before in that weight (the hypotheses remember what each
was given): the errors of successive estimates are one drift (the last fix's error carried
on, an extrapolation running off), not fresh evidence every second. So the estimates since
the last fix change the odds of two hypotheses by ``1 / w`` at most, an estimate far from
every hypothesis (a stale position, an extrapolation run off) undoes the weight of those
before it, and an estimate on one branch, once the branches lie apart by more than about
σ, takes the probability there. The reported
lineage (slot 0) moves to the place holding ``switch_probability`` (the bar a fix's
lineage switch must clear), as it does for an outage's tunnel evidence
(:mod:`antikol.positioning.outages`). Estimates pick a branch; they do not make it sure: they
raise no place beyond halfway from ``switch_probability`` to ``confidence`` (the reported
position leads there, ``ambiguous``; the analysis keeps weighing the other branch), since a
receiver that extrapolates runs straight on at a diverging switch and votes for the wrong
branch as steadily as a route's estimate votes for the right one. A hypothesis keeps at
least ``floor`` of the probability, so the next fixes find it if the estimates were wrong.

>>> import numpy as np
>>> ll = estimate_log_likelihood(np.array([0.0, 8.0, 80.0]), sigma_m=8.0, outlier_weight=0.02)
>>> np.round(ll, 3).tolist()
[0.0, -0.487, -3.912]
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Final

import numpy as np
import numpy.typing as npt

from antikol.positioning.fleet import FleetState
from antikol.positioning.reach import state_edge
from antikol.report import ESTIMATED_FIX_QUALITY

if TYPE_CHECKING:
    from trackmap import TrackMap

__all__ = [
    "ESTIMATED_FIX_QUALITY",
    "NOT_MEASURED",
    "distances_to_estimate",
    "estimate_log_likelihood",
    "weigh_estimate",
]

FloatArray = npt.NDArray[np.float64]

#: Fix qualities whose position is no measurement: none (0) and estimated.
NOT_MEASURED: Final = (0, ESTIMATED_FIX_QUALITY)


def estimate_log_likelihood(
    distance_m: FloatArray, *, sigma_m: float, outlier_weight: float
) -> FloatArray:
    """Log-likelihood of an estimated position at ``distance_m`` from each hypothesis.

    Parameters
    ----------
    distance_m : ndarray of float
        Distance from each hypothesis' place to the estimated position, m.
    sigma_m : float, keyword-only
        Standard deviation of an estimate's error, m (> 0).
    outlier_weight : float, keyword-only
        Share of estimates that say nothing of the vehicle, in (0, 1].

    Returns
    -------
    ndarray of float
        ``log((1 − w)·exp(−d² / 2σ²) + w)``, nats: 0 at the estimate, never below
        ``log(w)``.
    """
    d = np.asarray(distance_m, dtype=float) / sigma_m
    return np.log((1.0 - outlier_weight) * np.exp(-0.5 * d * d) + outlier_weight)


def distances_to_estimate(
    net: TrackMap, fleet: FleetState, row: int, lon_deg: float, lat_deg: float
) -> FloatArray:
    """Distance from each filled slot's place (in slot order) to an estimated position, m.

    Parameters
    ----------
    net : TrackMap
    fleet : FleetState
    row : int
    lon_deg, lat_deg : float
        The estimated position, WGS84 degrees.

    Returns
    -------
    ndarray of float
        One distance per filled slot, m (empty when the vehicle has no hypotheses).
    """
    slots = np.flatnonzero(fleet.hs[row] >= 0)
    if not len(slots):
        return np.zeros(0)
    x, y = net.points_at(state_edge(fleet.hs[row, slots]), fleet.ho[row, slots])
    ex, ey = net.to_local(lon_deg, lat_deg)
    return np.asarray(np.hypot(np.asarray(x) - float(ex), np.asarray(y) - float(ey)))


def weigh_estimate(
    fleet: FleetState,
    row: int,
    distance_m: FloatArray,
    *,
    sigma_m: float,
    outlier_weight: float,
    switch_probability: float,
    most_probability: float,
    floor: float,
) -> bool:
    """Weigh a vehicle's hypotheses by an estimated position; move its lineage to the
    place that now holds at least ``switch_probability`` (see the module).

    Parameters
    ----------
    fleet : FleetState
        Changed in place: the log-probabilities of row ``row``'s slots, and their order
        when the lineage moves.
    row : int
    distance_m : ndarray of float
        Distance from each filled slot's place (in slot order) to the estimate, m.
    sigma_m, outlier_weight : float, keyword-only
        As :func:`estimate_log_likelihood`.
    switch_probability : float, keyword-only
        Share of the probability the reported lineage's new place must hold.
    most_probability : float, keyword-only
        The most an estimate may raise a place's probability to (a place that holds more
        from fixes may keep it): estimates pick a branch, they do not make it sure.
    floor : float, keyword-only
        Least probability an estimate leaves a hypothesis with (or what it had, if less).

    Returns
    -------
    bool
        Whether the reported lineage moved to another place.
    """
    slots = np.flatnonzero(fleet.hs[row] >= 0)
    if len(slots) < 2 or slots[0] != 0 or len(distance_m) != len(slots):
        return False
    ll = estimate_log_likelihood(distance_m, sigma_m=sigma_m, outlier_weight=outlier_weight)
    if not np.isfinite(ll).all() or np.ptp(ll) == 0.0:
        return False
    before = fleet.hp[row, slots]
    # the latest estimate replaces the one before (their errors are one drift, not news)
    base = before - fleet.he[row, slots]
    _, place = np.unique(fleet.hs[row, slots], return_inverse=True)
    limit = np.maximum(_place_mass(place, before), most_probability) + 1e-12
    weight = 1.0
    if (_place_mass(place, base + ll) > limit).any():
        # the largest share of the estimate's evidence that keeps every place in its limit
        low, high = 0.0, 1.0
        for _ in range(30):
            mid = 0.5 * (low + high)
            inside = (_place_mass(place, base + mid * ll) <= limit).all()
            low, high = (mid, high) if inside else (low, mid)
        weight = low
    fleet.he[row, slots] = weight * ll
    log_p = base + weight * ll
    p = np.exp(log_p - np.logaddexp.reduce(log_p))
    # a hypothesis is left the floor (or what it had, if less); the others share the rest
    keep = np.minimum(np.exp(before), floor)
    short = p < keep
    if short.any():
        p = np.where(short, keep, p * (1.0 - keep[short].sum()) / p[~short].sum())
    fleet.hp[row, slots] = np.log(p)
    return fleet.lead_to_heaviest_place(row, switch_probability=switch_probability)


def _place_mass(place: npt.NDArray[np.intp], log_p: FloatArray) -> FloatArray:
    """Probability of each place (hypotheses grouped by ``place``) after normalising."""
    p = np.exp(log_p - np.logaddexp.reduce(log_p))
    return np.bincount(place, weights=p).astype(float)
