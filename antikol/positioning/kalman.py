"""Along-track Kalman filter (the only module that touches filterpy).

The state is the distance travelled along the track ``s`` (m) and the speed ``v`` (m/s),
optionally with the acceleration ``a`` (m/s²). Measurements are the matched along-track
position and the reported speed over ground. Time steps vary from report to report; the
process noise is a discretised white-noise acceleration (constant velocity model) or jerk
(constant acceleration model).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import KalmanFilter


@functools.lru_cache(maxsize=256)
def _transition(dim: int, dt: float, var: float) -> tuple[np.ndarray, np.ndarray]:
    """Transition and process-noise matrices for a time step (cached: steps repeat)."""
    if dim == 3:
        f = np.array([[1.0, dt, 0.5 * dt * dt], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    else:
        f = np.array([[1.0, dt], [0.0, 1.0]])
    q = Q_discrete_white_noise(dim=dim, dt=dt, var=var)
    f.setflags(write=False)
    q.setflags(write=False)
    return f, q


@dataclass(frozen=True, slots=True)
class FilterEstimate:
    """A filter state at one time.

    Attributes
    ----------
    t : float
        Time, s.
    s_m : float
        Distance travelled along the track, m.
    v_mps : float
        Speed, m/s.
    s_std_m, v_std_mps : float
        One-sigma uncertainties.
    """

    t: float
    s_m: float
    v_mps: float
    s_std_m: float
    v_std_mps: float


class AlongTrackFilter:
    """Kalman filter of position and speed along the track.

    Parameters
    ----------
    accel_sigma_mps2 : float
        Process noise: standard deviation of unmodelled acceleration (or of the jerk, in
        m/s³, with ``with_acceleration``).
    position_sigma_m : float
        Default standard deviation of a matched along-track position, m.
    speed_sigma_mps : float
        Standard deviation of a reported speed, m/s.
    with_acceleration : bool
        Track acceleration too (constant-acceleration model).
    """

    def __init__(
        self,
        *,
        accel_sigma_mps2: float = 0.6,
        position_sigma_m: float = 3.0,
        speed_sigma_mps: float = 0.3,
        with_acceleration: bool = False,
    ) -> None:
        self.accel_sigma_mps2 = float(accel_sigma_mps2)
        self.position_sigma_m = float(position_sigma_m)
        self.speed_sigma_mps = float(speed_sigma_mps)
        self.with_acceleration = with_acceleration
        self.dim = 3 if with_acceleration else 2
        self._kf = KalmanFilter(dim_x=self.dim, dim_z=2)
        self._kf.H = np.zeros((2, self.dim))
        self._kf.H[0, 0] = 1.0
        self._kf.H[1, 1] = 1.0
        self.t: float | None = None

    @property
    def initialised(self) -> bool:
        """True once :meth:`reset` has been called."""
        return self.t is not None

    def reset(self, t: float, s_m: float, v_mps: float, *, s_std_m: float | None = None) -> None:
        """Start from a known state (after a gap, a reset or at the first fix).

        Parameters
        ----------
        t : float
            Time, s.
        s_m : float
            Along-track position, m.
        v_mps : float
            Speed, m/s.
        s_std_m : float, optional
            Initial position uncertainty, m (default: ``position_sigma_m``).
        """
        x = np.zeros((self.dim, 1))
        x[0, 0], x[1, 0] = s_m, v_mps
        self._kf.x = x
        p = np.eye(self.dim)
        p[0, 0] = (s_std_m if s_std_m is not None else self.position_sigma_m) ** 2
        p[1, 1] = (2.0 * self.speed_sigma_mps) ** 2
        if self.with_acceleration:
            p[2, 2] = 1.0
        self._kf.P = p
        self.t = float(t)

    def _transition(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        return _transition(self.dim, round(dt, 6), self.accel_sigma_mps2**2)

    def predict(self, t: float) -> None:
        """Advance the state to time ``t`` (s); earlier times are ignored."""
        if self.t is None:
            raise RuntimeError("predict() before reset()")
        dt = float(t) - self.t
        if dt <= 0:
            return
        f, q = self._transition(dt)
        self._kf.predict(F=f, Q=q)
        # a tram does not run backwards through its own filter: clamp a negative speed
        self._kf.x[1, 0] = max(self._kf.x[1, 0], 0.0)
        self.t = float(t)

    def update(
        self, s_m: float, v_mps: float | None = None, *, s_std_m: float | None = None
    ) -> float:
        """Fuse a matched position (and a speed, if given).

        Parameters
        ----------
        s_m : float
            Measured along-track position, m.
        v_mps : float, optional
            Measured speed, m/s.
        s_std_m : float, optional
            Standard deviation of ``s_m`` (default ``position_sigma_m``), m.

        Returns
        -------
        float
            Normalised innovation of the position (innovation / its standard deviation),
            useful to detect a measurement the filter cannot explain.
        """
        sigma_s = s_std_m if s_std_m is not None else self.position_sigma_m
        innovation = s_m - float(self._kf.x[0, 0])
        spread = math.sqrt(float(self._kf.P[0, 0]) + sigma_s**2)
        if v_mps is None:
            h = np.zeros((1, self.dim))
            h[0, 0] = 1.0
            self._kf.update(np.array([[s_m]]), R=np.array([[sigma_s**2]]), H=h)
        else:
            r = np.diag([sigma_s**2, self.speed_sigma_mps**2])
            self._kf.update(np.array([[s_m], [v_mps]]), R=r)
        self._kf.x[1, 0] = max(self._kf.x[1, 0], 0.0)
        return innovation / spread

    def estimate(self, t: float | None = None) -> FilterEstimate:
        """The state at ``t`` (s) without changing the filter (prediction if later)."""
        if self.t is None:
            raise RuntimeError("estimate() before reset()")
        x, p = self._kf.x, self._kf.P
        when = self.t
        if t is not None and t > self.t:
            f, q = self._transition(float(t) - self.t)
            x = f @ x
            p = f @ p @ f.T + q
            when = float(t)
        return FilterEstimate(
            t=when,
            s_m=float(x[0, 0]),
            v_mps=max(float(x[1, 0]), 0.0),
            s_std_m=math.sqrt(max(float(p[0, 0]), 0.0)),
            v_std_mps=math.sqrt(max(float(p[1, 1]), 0.0)),
        )

    def shift(self, delta_m: float) -> None:
        """Move the position coordinate by ``delta_m`` (re-anchoring, no information)."""
        self._kf.x[0, 0] += delta_m

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready state."""
        return {
            "t": self.t,
            "x": self._kf.x.ravel().tolist(),
            "P": self._kf.P.tolist(),
            "with_acceleration": self.with_acceleration,
        }

    def load_dict(self, data: dict[str, Any]) -> None:
        """Restore a state written by :meth:`to_dict`."""
        if bool(data.get("with_acceleration")) != self.with_acceleration:
            raise ValueError("filter state was saved with a different model")
        self.t = data["t"]
        if self.t is not None:
            self._kf.x = np.asarray(data["x"], dtype=float).reshape(self.dim, 1)
            self._kf.P = np.asarray(data["P"], dtype=float).reshape(self.dim, self.dim)
