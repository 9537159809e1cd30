"""The error of a fix under one track hypothesis: GPS bias and along-track lag, one filter.

Under a hypothesis the vehicle is at a known place on a known track, up to how far it has
run along it. A fix is that place plus a slowly varying GPS bias ``b`` (east, north; m, a
first-order Gauss–Markov process) plus white noise. Its offset **across** the track measures
the bias' normal component; its place **along** the track measures the distance run plus the
bias' tangential component. The distance run is predicted from the reported speed or the
odometer, so the filter's third state is ``a``: the true position along the hypothesis'
history minus the fix's, m. A hypothesis on a track of the wrong length (the inner of two
loops, the shorter of two branches) falls behind or runs ahead of the distance the tram
reported, and its along-track innovations say so however close the tracks lie.

The state is ``(a, bx, by)`` with a full 3 × 3 covariance, written out in closed form over
numpy arrays (the test suite checks every step against filterpy's ``KalmanFilter``).

>>> import numpy as np
>>> from antikol.positioning.fixerror import FixErrorState, fix_error_predict, fix_error_update
>>> st = FixErrorState.start(1, 2.0)
>>> st = fix_error_predict(st, np.array([1.0]), 2.0, 60.0, np.array([0.0]), np.array([0.0]))
>>> post, lat, along = fix_error_update(
...     st, np.array([1.0]), np.array([0.0]), np.array([3.0]),
...     np.array([0.0]), np.array([1.0]), np.array([9.0]))
>>> round(float(post.bx[0]), 2), round(float(lat.residual_m[0]), 2)
(0.92, 3.0)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

__all__ = [
    "FIX_ERROR_FIELDS",
    "UNKNOWN_LAG_VAR_M2",
    "FixErrorState",
    "Innovation",
    "fix_error_predict",
    "fix_error_update",
]

FloatArray = npt.NDArray[np.float64]

#: Variance of the along-track lag where nothing is known of it (a fresh start), m².
UNKNOWN_LAG_VAR_M2 = 1.0e6

#: The state's arrays, in :class:`FixErrorState`'s order.
FIX_ERROR_FIELDS = ("ad", "bx", "by", "paa", "pax", "pay", "pxx", "pxy", "pyy")


class Innovation(NamedTuple):
    """A measurement's innovation: residual (m) and its variance (m²), arrays."""

    residual_m: FloatArray
    variance_m2: FloatArray


@dataclass(slots=True)
class FixErrorState:
    """Along-track lag ``ad`` and GPS bias ``bx, by`` (m) with their covariance (m²).

    Parallel arrays, one entry per hypothesis.
    """

    ad: FloatArray
    bx: FloatArray
    by: FloatArray
    paa: FloatArray
    pax: FloatArray
    pay: FloatArray
    pxx: FloatArray
    pxy: FloatArray
    pyy: FloatArray

    @classmethod
    def start(cls, n: int, bias_sigma_m: npt.ArrayLike) -> FixErrorState:
        """A fresh start: the bias at its stationary prior (``bias_sigma_m`` per axis),
        the lag unknown."""
        var = np.asarray(bias_sigma_m, dtype=float) ** 2  # a new array
        if var.shape != (n,):
            var = np.broadcast_to(var, (n,)).copy()
        zero = np.zeros(n)
        return cls(
            zero, zero.copy(), zero.copy(), np.full(n, UNKNOWN_LAG_VAR_M2),
            zero.copy(), zero.copy(), var, zero.copy(), var.copy(),
        )  # fmt: skip

    def columns(self) -> tuple[FloatArray, ...]:
        """The arrays in :data:`FIX_ERROR_FIELDS` order."""
        return tuple(getattr(self, name) for name in FIX_ERROR_FIELDS)

    def forget_lag(self, where: npt.NDArray[np.bool_]) -> FixErrorState:
        """The states with the lag unknown again ``where`` true (a reversal starts the
        distance run afresh); the bias is kept."""
        return FixErrorState(
            np.where(where, 0.0, self.ad),
            self.bx,
            self.by,
            np.where(where, UNKNOWN_LAG_VAR_M2, self.paa),
            np.where(where, 0.0, self.pax),
            np.where(where, 0.0, self.pay),
            self.pxx,
            self.pxy,
            self.pyy,
        )

    def take(self, idx: Any) -> FixErrorState:
        """The states at ``idx`` (copies)."""
        return FixErrorState(*(a[idx] for a in self.columns()))


def fix_error_predict(
    st: FixErrorState,
    dt_s: npt.ArrayLike,
    bias_sigma_m: npt.ArrayLike,
    tau_s: float,
    lag_shift_m: npt.ArrayLike,
    run_var_m2: npt.ArrayLike,
) -> FixErrorState:
    """Predict over ``dt_s``: the bias decays towards zero (Gauss–Markov, ``tau_s``); the
    lag moves by ``lag_shift_m`` (the distance predicted minus the distance between the
    fixes' places, m) and grows uncertain by ``run_var_m2`` (the error of the predicted
    distance, m²)."""
    rho = np.exp(-np.maximum(np.asarray(dt_s, dtype=float), 0.0) / tau_s)
    r2 = rho * rho
    add = (1.0 - r2) * np.asarray(bias_sigma_m, dtype=float) ** 2
    return FixErrorState(
        st.ad + np.asarray(lag_shift_m, dtype=float),
        rho * st.bx,
        rho * st.by,
        st.paa + np.asarray(run_var_m2, dtype=float),
        rho * st.pax,
        rho * st.pay,
        r2 * st.pxx + add,
        r2 * st.pxy,
        r2 * st.pyy + add,
    )


def _measure(
    st: FixErrorState, ha: Any, hx: FloatArray, hy: FloatArray, resid: FloatArray, r: FloatArray
) -> tuple[FixErrorState, Innovation]:
    """Fuse one scalar measurement with row ``(ha, hx, hy)`` and innovation ``resid``."""
    # P h
    ua = ha * st.paa + hx * st.pax + hy * st.pay
    ux = ha * st.pax + hx * st.pxx + hy * st.pxy
    uy = ha * st.pay + hx * st.pxy + hy * st.pyy
    var = ha * ua + hx * ux + hy * uy + r
    ka, kx, ky = ua / var, ux / var, uy / var
    post = FixErrorState(
        st.ad + ka * resid,
        st.bx + kx * resid,
        st.by + ky * resid,
        st.paa - ka * ua,
        st.pax - ka * ux,
        st.pay - ka * uy,
        st.pxx - kx * ux,
        st.pxy - kx * uy,
        st.pyy - ky * uy,
    )
    return post, Innovation(resid, var)


def fix_error_update(
    st: FixErrorState,
    nx: FloatArray,
    ny: FloatArray,
    lateral_m: FloatArray,
    tx: FloatArray,
    ty: FloatArray,
    noise_var_m2: FloatArray,
    expected_lag_m: FloatArray | float = 0.0,
) -> tuple[FixErrorState, Innovation, Innovation]:
    """Fuse a fix: its offset ``lateral_m`` along the unit normal ``(nx, ny)`` and its
    place along the track, whose unit tangent in the running direction is ``(tx, ty)``.

    The lateral offset is the bias' normal component plus white noise; the fix's place
    along the track is the true place plus the bias' tangential component plus white
    noise, less ``expected_lag_m`` for a fix that is late (the run since it was taken:
    latency times speed), so the lag's measurement is ``expected_lag_m = ad + t·b +
    noise`` (the lag is kept relative to the fix). Each part has white noise of variance
    ``noise_var_m2``.

    Returns
    -------
    FixErrorState
        Updated estimates.
    Innovation, Innovation
        Lateral and along-track innovations: the hypothesis' likelihood of the fix.
    """
    zero = np.zeros_like(nx)
    mid, lateral = _measure(st, zero, nx, ny, lateral_m - (nx * st.bx + ny * st.by), noise_var_m2)
    post, along = _measure(
        mid, 1.0, tx, ty, expected_lag_m - (mid.ad + tx * mid.bx + ty * mid.by), noise_var_m2
    )
    return post, lateral, along
