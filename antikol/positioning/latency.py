"""How old each vehicle's fixes are when their reports are stamped, learnt from its run.

A vehicle-location unit may stamp a report when it sends it, while the GPS fix in it is a
second or two old; the odometer and the wheel speed are current. The fix then shows where
the vehicle was: at 10 m/s a 1-s latency puts every position 10 m behind, and the
along-track filter follows it there. The lineage's progress along the track at each fix,
minus the distance the vehicle reports having run, is an offset ``c`` (where the odometer
started, drifting slowly with the along-track GPS bias) minus ``speed × latency``: standing
at a stop the fix is where the vehicle is, running it lags in proportion to the speed. A
two-state Kalman filter per vehicle estimates ``(c, latency)`` from that; ``c`` starts
afresh with every new lineage (its progress restarts), the latency is kept. Its prior is
``fix_latency_s ± fix_latency_sigma_s`` (:class:`~antikol.positioning.config.PositioningConfig`;
a sigma of 0 keeps the configured latency).

>>> import numpy as np
>>> from antikol.positioning.fleet import FleetState
>>> fleet = FleetState(k=1)
>>> fleet.grow(1)
>>> rows = np.array([0])
>>> for k in range(200):  # running at 0-15 m/s, the fix 1 s behind
...     v = 15.0 * (k % 20) / 19
...     run = 10.0 * k
...     got = learn_latency(fleet, rows, np.array([v]), np.array([run]),
...                         np.array([run - 1.0 * v]), np.array([3.0]), np.array([k == 0]),
...                         prior=(0.0, 1.0), offset_rate_m2_s=0.2, dt_s=np.array([1.0]))
>>> round(float(got[0]), 1)
1.0
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from antikol.positioning.fleet import FleetState

__all__ = ["MAX_LATENCY_S", "forget_latency", "learn_latency"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

#: The latency used is kept within [0, this], s.
MAX_LATENCY_S = 5.0
#: An innovation beyond this many standard deviations is an outlier: no update.
_GATE = 4.0
#: How fast the latency itself may drift, s² per s.
_LATENCY_DRIFT_S2_S = 1e-6


def learn_latency(
    fleet: FleetState,
    rows: IntArray,
    speed_mps: FloatArray,
    run_m: FloatArray,
    progress_m: FloatArray,
    sigma_m: FloatArray,
    restart: BoolArray,
    *,
    prior: tuple[float, float],
    offset_rate_m2_s: float,
    dt_s: FloatArray,
) -> FloatArray:
    """Update the vehicles' latency filters with a fix each; the latency to use now, s.

    Parameters
    ----------
    fleet : FleetState
        Its ``lc, lt, lpcc, lpct, lptt`` (offset, latency and covariance) are updated.
    rows : ndarray of int
        The vehicles' rows.
    speed_mps : ndarray
        Reported speed at the fix, m/s.
    run_m : ndarray
        Distance the vehicle has run by its odometer (else its speeds), m, from any origin.
    progress_m : ndarray
        Its reported lineage's progress along the track at the fix, m.
    sigma_m : ndarray
        The fix's error along the track, m.
    restart : ndarray of bool
        The lineage starts afresh: the offset is unknown again.
    prior : (float, float), keyword-only
        Mean and standard deviation of the latency before any evidence, s.
    offset_rate_m2_s : float, keyword-only
        Variance the offset gains per second (the along-track GPS bias wanders), m²/s.
    dt_s : ndarray, keyword-only
        Time since each vehicle's previous fix, s (ignored where ``restart``).

    Returns
    -------
    ndarray
        The latency of each vehicle's fixes, s, within [0, :data:`MAX_LATENCY_S`].
    """
    mean, sd = prior
    if sd <= 0.0:
        return np.full(len(rows), min(max(mean, 0.0), MAX_LATENCY_S))
    f = fleet
    d = progress_m - run_m
    r2 = sigma_m * sigma_m
    new = np.isnan(f.lt[rows])
    if new.any():
        r = rows[new]
        f.lt[r], f.lptt[r] = mean, sd * sd
    start = restart | np.isnan(f.lc[rows])
    if not start.any():
        _update(f, rows, speed_mps, d, r2, dt_s, offset_rate_m2_s)
    else:
        r, v = rows[start], speed_mps[start]
        # the offset is read off this fix given the latency: it shares the latency's
        # uncertainty (c = d + v·latency), so a later fix at the same speed says nothing
        # about the latency, only a change of speed does
        f.lc[r] = d[start] + v * f.lt[r]
        f.lpcc[r] = r2[start] + v * v * f.lptt[r]
        f.lpct[r] = v * f.lptt[r]
        go = ~start
        if go.any():
            _update(f, rows[go], speed_mps[go], d[go], r2[go], dt_s[go], offset_rate_m2_s)
    return np.clip(f.lt[rows], 0.0, MAX_LATENCY_S)


def forget_latency(fleet: FleetState, rows: IntArray) -> None:
    """Forget what the vehicles' fixes taught of their latency: back to the prior.

    For vehicles whose placement is found to rest on doubted evidence: a fix on the wrong
    one of two parallel tracks lies along it where a latency would put it, and a few such
    fixes at changing speeds taught a tram a latency of 4 s (75 m at 19 m/s).
    """
    fleet.lc[rows] = fleet.lt[rows] = np.nan
    fleet.lpcc[rows] = fleet.lpct[rows] = fleet.lptt[rows] = 0.0


def _update(
    f: FleetState,
    rows: IntArray,
    v: FloatArray,
    d: FloatArray,
    r2: FloatArray,
    dt: FloatArray,
    offset_rate_m2_s: float,
) -> None:
    """One predict-and-update of the filters of ``rows``: the offset wanders for ``dt``
    (s), then ``d = c - v * latency`` is measured with variance ``r2`` (m²)."""
    dt = np.maximum(dt, 0.0)
    c, tau = f.lc[rows], f.lt[rows]
    pcc = f.lpcc[rows] + offset_rate_m2_s * dt
    pct = f.lpct[rows]
    ptt = f.lptt[rows] + _LATENCY_DRIFT_S2_S * dt
    y = d - (c - v * tau)
    ua, ub = pcc - v * pct, pct - v * ptt  # P H' with H = (1, -v)
    s = ua - v * ub + r2
    fit = y * y <= (_GATE * _GATE) * s
    ka, kb = np.where(fit, ua / s, 0.0), np.where(fit, ub / s, 0.0)
    f.lc[rows], f.lt[rows] = c + ka * y, tau + kb * y
    f.lpcc[rows], f.lpct[rows], f.lptt[rows] = pcc - ka * ua, pct - ka * ub, ptt - kb * ub
