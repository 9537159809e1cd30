"""How large a vehicle's GPS bias runs, learnt from its own fixes.

Every hypothesis explains a fix as its track plus a slowly varying bias whose prior is
:attr:`~antikol.positioning.PositioningConfig.bias_sigma_m` per axis — a street receiver's
few metres. A receiver whose multipath bias runs several times that (a poor antenna, a
deep canyon) breaks the prior's promise: a bias of 12 m is a five-sigma event under it, so
a hypothesis on a neighbouring track that explains the same fixes with a small bias wins —
*confident* — though the fixes say nothing about which of the two tracks the tram is on.

So each vehicle keeps the mean square of the bias its hypotheses have learnt **across
their track** — the part that tells tracks apart, and the part the fixes measure: along
the track the bias is confounded with the lag of a late receiver and of the odometer, and
learnt from that it grew with the latency, not with the multipath. At every committed fix
the hypotheses' probability-weighted ``b_lat² + P_lat`` (the posterior second moment, so a
bias still unknown counts at its prior) enters a running mean over :data:`LEARN_S`
seconds of fixes. Its square root is the bias prior, per axis, of the vehicle's plain
fixes — never below the configured one (a good receiver keeps the prior that tells
tracks apart), and at most
:attr:`~antikol.positioning.PositioningConfig.bias_sigma_max_factor` times it (1: fixed).
A differential or RTK fix keeps the prior its quality states.

Ten minutes of fixes whose one hypothesis, on a track running north, holds a bias of 9 m
east (across the track), known well, take the prior from 2.5 m towards 9 m:

>>> import numpy as np
>>> from antikol.positioning.fleet import FleetState
>>> f = FleetState(2)
>>> f.grow(1)
>>> f.hs[0, 0], f.hp[0, 0], f.bx[0, 0] = 4, 0.0, 9.0
>>> f.t[0] = 0.0
>>> def north(edge_ids, offsets_m, directions):
...     return np.zeros(len(edge_ids))
>>> for t in range(1, 601):
...     learn_bias_sigma(f, np.array([0]), np.array([float(t)]), north, prior_sigma_m=2.5)
...     f.t[0] = float(t)
>>> round(float(bias_sigma_of(f, np.array([0]), 2.5)[0]), 1)
8.4
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from antikol.positioning.fleet import FleetState
from antikol.positioning.reach import state_direction, state_edge

__all__ = ["LEARN_S", "bias_sigma_of", "learn_bias_sigma"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Time scale of the running mean of the squared bias, s: a few of the bias' own
#: correlation times (a minute or two), so one stretch of canyon does not make the
#: receiver a poor one, while a receiver that is poor is found within minutes.
LEARN_S = 300.0
#: Longest interval between two fixes that counts in full, s (an outage's end is one
#: fix, not minutes of evidence).
MAX_STEP_S = 10.0


def bias_sigma_of(
    fleet: FleetState, rows: IntArray, prior_sigma_m: float, *, max_factor: float = 4.0
) -> FloatArray:
    """The bias prior of the plain fixes of vehicles ``rows``, m per axis.

    Parameters
    ----------
    fleet : FleetState
    rows : ndarray of int
    prior_sigma_m : float
        The configured prior, m (the floor).
    max_factor : float, keyword-only
        The cap, as a multiple of ``prior_sigma_m`` (1: the prior as configured).

    Returns
    -------
    ndarray
        ``prior_sigma_m`` for a vehicle with nothing learnt yet.
    """
    learnt = fleet.bvar[rows]
    sigma = np.sqrt(np.where(learnt > 0.0, learnt, 0.0))
    return np.clip(sigma, prior_sigma_m, max_factor * prior_sigma_m)


def learn_bias_sigma(
    fleet: FleetState,
    rows: IntArray,
    t: FloatArray,
    headings: Callable[[IntArray, FloatArray, IntArray], FloatArray],
    *,
    prior_sigma_m: float,
) -> None:
    """Fold the bias the hypotheses of ``rows`` hold now into their vehicles' mean square.

    Call after the hypotheses of a fix are stored and before the fix's time is.

    Parameters
    ----------
    fleet : FleetState
        Read: the hypotheses (``hs``, ``ho``, ``hp``, ``bx``, ``by``, ``pxx``, ``pxy``,
        ``pyy``) and the previous fix's time ``t``; written: ``bvar`` (m²).
    rows : ndarray of int
        Vehicles with a committed fix.
    t : ndarray
        The fix's time, s.
    headings : callable
        ``headings(edge_id, offset_m, direction)``: headings of travel (degrees) at track
        places (:meth:`antikol.positioning.headings.HeadingProfile.at`).
    prior_sigma_m : float, keyword-only
        The configured bias prior, m (where a vehicle's mean starts).
    """
    if not len(rows):
        return
    hs = fleet.hs[rows]
    filled = hs >= 0
    weight = np.where(filled, np.exp(fleet.hp[rows]), 0.0)
    total = weight.sum(axis=1)
    r, k = np.nonzero(filled)
    row = rows[r]
    state = hs[r, k]
    h = np.radians(headings(state_edge(state), fleet.ho[row, k], state_direction(state)))
    nx, ny = np.cos(h), -np.sin(h)  # across the track (either side: it is squared)
    bx, by = fleet.bx[row, k], fleet.by[row, k]
    pxx, pxy, pyy = fleet.pxx[row, k], fleet.pxy[row, k], fleet.pyy[row, k]
    power = np.zeros(hs.shape)
    power[r, k] = (bx * nx + by * ny) ** 2 + pxx * nx * nx + 2.0 * pxy * nx * ny + pyy * ny * ny
    sample = (weight * power).sum(axis=1) / np.where(total > 0, total, 1.0)
    before = fleet.bvar[rows]
    before = np.where(before > 0.0, before, prior_sigma_m**2)
    dt = t - fleet.t[rows]
    step = np.clip(np.where(np.isfinite(dt), dt, 0.0), 0.0, MAX_STEP_S) / LEARN_S
    fleet.bvar[rows] = np.where(total > 0, before + step * (sample - before), before)
