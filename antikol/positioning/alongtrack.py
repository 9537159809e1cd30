"""The along-track filter step of the reported lineages, with one outlier forgiven.

Every committed fix brings the reported lineage's progress along the track (m); it is fused
into the vehicle's along-track Kalman filter (:mod:`antikol.positioning.kalman`) together with
the reported speed, or after an odometer step. A normalised innovation beyond
``nis_gate`` used to restart the filter at the measured progress at once. In streets a single
fix can be off by tens of metres *along* the track (a heavy-tailed multipath error); every
candidate place of that fix shares the error, so the lineage's progress jumps and the
restarted filter — the reported position — jumped with it, then back a second later. Now the
first gated innovation is taken as an outlier: the measurement is dropped and the filter keeps
its prediction. Only a second one in a row (the position really is elsewhere) restarts it.
A fix that is older than its report (:mod:`antikol.positioning.latency`) is taken as the
place the vehicle had then, plus the distance it has run since at its reported speed. Each
fix also teaches the vehicle's odometer scale (:mod:`antikol.positioning.odometerscale`).
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import numpy.typing as npt

from antikol.positioning.config import PositioningConfig
from antikol.positioning.fleet import FleetState
from antikol.positioning.kalman import track_distance_step, track_predict, track_update
from antikol.positioning.latency import learn_latency
from antikol.positioning.odometerresolution import odometer_resolution, quantisation_sigma
from antikol.positioning.odometerscale import learn_odometer_scale

__all__ = ["run_track_filters"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def run_track_filters(
    fleet: FleetState,
    config: PositioningConfig,
    stats: Counter[str],
    done: IntArray,
    measured: tuple[FloatArray, FloatArray, FloatArray, FloatArray],
    progress: FloatArray,
    restart: npt.NDArray[np.bool_],
) -> None:
    """Fuse each reported lineage's progress into the vehicles' along-track filters.

    Parameters
    ----------
    fleet : FleetState
        Its filters ``fleet.kf``, odometers and lineage progress ``fleet.z`` are updated.
    config : PositioningConfig
    stats : Counter
        Counts ``filter_reset`` and ``along_outlier`` (a gated innovation forgiven).
    done : ndarray of int
        Rows of the vehicles.
    measured : (ndarray, ndarray, ndarray, ndarray)
        Time (s), speed (m/s), odometer (m, NaN: none) and along-track sigma of the fix
        (white and bias, m) of each.
    progress : ndarray
        The reported lineage's progress at the fix, m.
    restart : ndarray of bool
        Start the filter afresh (a new or switched lineage).
    """
    c = config
    kf = fleet.kf
    t, speed, odo, along = measured
    lineage_progress = progress
    # a late fix shows where the vehicle was: it has run on since, at its speed
    ran, since_fix, _ = fleet.run_since_fix(done, t, speed, odo)
    fleet.run[done] += np.where(np.isfinite(ran), np.maximum(ran, 0.0), 0.0)
    latency = learn_latency(
        fleet,
        done,
        speed,
        fleet.run[done],
        progress,
        along,
        restart,
        prior=(c.fix_latency_s, c.fix_latency_sigma_s),
        offset_rate_m2_s=2.0 * c.bias_sigma_m**2 / c.bias_tau_s,
        dt_s=np.where(np.isfinite(since_fix), since_fix, 0.0),
    )
    progress = progress + speed * latency
    # the scale from the fixes' places where the vehicle was when reported (a late fix falls
    # behind by its speed times the latency, a deficit that is no scale); the previous
    # reading is NaN where this step's odometer was found no measurement
    learn_odometer_scale(
        fleet, done, odo, progress, along, restart, np.isfinite(fleet.odo[done]),
        prior_sigma=c.odometer_scale_sigma,
    )  # fmt: skip
    reset = restart | np.isnan(kf.t[done])
    r = done[reset]
    kf.t[r], kf.s[r], kf.v[r] = t[reset], progress[reset], speed[reset]
    kf.pss[r] = along[reset] * along[reset]
    kf.psv[r] = 0.0
    kf.pvv[r] = (2.0 * c.speed_sigma_mps) ** 2
    fleet.gated[r] = 0
    resets = int(np.count_nonzero(reset))
    odo_prev = fleet.odo[done]
    wheels = ~reset & np.isfinite(odo) & np.isfinite(odo_prev)
    gps = ~reset & ~wheels
    if wheels.any():
        step = np.maximum(odo[wheels] - odo_prev[wheels], 0.0)
        quant = quantisation_sigma(
            odometer_resolution(fleet, done[wheels]), step_sigma_m=c.odometer_step_sigma_m
        )
        sigma = c.odometer_sigma_fraction * step + 0.05 + quant  # (track_odometer_step's)
        track_distance_step(kf, done[wheels], t[wheels], step, sigma)
    if gps.any():
        track_predict(kf, done[gps], t[gps], c.accel_sigma_mps2)
    predicted = [a[done].copy() for a in (kf.s, kf.v, kf.pss, kf.psv, kf.pvv)]
    nis = np.zeros(len(done))
    if wheels.any():
        r = done[wheels]
        nis[wheels] = track_update(kf, r, progress[wheels], along[wheels], None, c.speed_sigma_mps)
    if gps.any():
        r = done[gps]
        nis[gps] = track_update(kf, r, progress[gps], along[gps], speed[gps], c.speed_sigma_mps)
    gate = ~reset & (np.abs(nis) > c.nis_gate)
    # the first gated innovation: an outlier, the prediction stands
    forgive = gate & (fleet.gated[done] == 0)
    r = done[forgive]
    for arr, before in zip((kf.s, kf.v, kf.pss, kf.psv, kf.pvv), predicted, strict=True):
        arr[r] = before[forgive]
    # a second in a row: the position is elsewhere, restart at the measurement
    again = gate & ~forgive
    r = done[again]
    kf.s[r] = progress[again]
    kf.pss[r] = along[again] * along[again]
    kf.psv[r] = 0.0
    fleet.gated[done] = np.where(forgive, 1, 0)
    stats["filter_reset"] += resets + int(np.count_nonzero(again))
    stats["along_outlier"] += int(np.count_nonzero(forgive))
    fleet.z[done] = lineage_progress
