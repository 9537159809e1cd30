"""Reports that contradict physics: a jump no vehicle makes, an acceleration or a speed it
cannot reach, a time that goes back.

Such a report is rejected before it reaches the hypotheses and leaves the positioning state
untouched (:class:`~antikol.positioning.matcher.Positioner` counts it, and after
``max_rejections_in_row`` in a row starts the vehicle afresh: it really is elsewhere). The
bounds are generous: they catch what is impossible, not what is unlikely, which the
hypotheses weigh.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from antikol.positioning.config import PositioningConfig
from antikol.positioning.fleet import FleetState

__all__ = ["implausible"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def implausible(
    fleet: FleetState,
    config: PositioningConfig,
    rows: IntArray,
    measured: tuple[FloatArray, FloatArray, FloatArray, FloatArray],
    no_fix: npt.NDArray[np.bool_],
) -> npt.NDArray[np.str_]:
    """Why each report is physically impossible.

    Parameters
    ----------
    fleet : FleetState
        The vehicles' last reports and fixes (read only).
    config : PositioningConfig
        ``max_speed_mps``, ``max_accel_mps2`` and ``jump_margin_m``.
    rows : ndarray of int
        Each report's vehicle row.
    measured : (ndarray, ndarray, ndarray, ndarray)
        Time (s), reported speed (m/s) and local position (x, y, m) of each report.
    no_fix : ndarray of bool
        Reports without a position fix (their position is not checked).

    Returns
    -------
    ndarray of str
        ``"jump"``, ``"acceleration"``, ``"time"`` or ``"speed"``; ``""`` when plausible.
    """
    t, speed, xs, ys = measured
    c = config
    out = np.full(len(rows), "", dtype=object)
    prev_t = fleet.t[rows]
    has_prev = np.isfinite(prev_t)
    dt = np.where(has_prev, t - prev_t, 1.0)
    # displacement from the last position fix (reports without one come in between)
    dt_fix = np.where(np.isfinite(fleet.t_fix[rows]), t - fleet.t_fix[rows], dt)
    moved = np.hypot(xs - fleet.x[rows], ys - fleet.y[rows])
    prev_v = fleet.v[rows]
    reach = (
        np.maximum(speed, prev_v) * dt_fix
        + 0.5 * c.max_accel_mps2 * dt_fix * dt_fix
        + c.max_speed_mps * np.maximum(dt_fix - dt, 0.0)
    )
    jump = has_prev & ~no_fix & np.isfinite(moved) & (moved > reach + c.jump_margin_m)
    accel = has_prev & (np.abs(speed - prev_v) > c.max_accel_mps2 * dt + 2.0)
    out[jump] = "jump"
    out[accel] = "acceleration"
    out[has_prev & (dt <= 0)] = "time"
    out[speed > c.max_speed_mps] = "speed"
    return np.asarray(out.astype(str))
