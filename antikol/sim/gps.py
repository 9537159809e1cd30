"""The GPS model of the simulated trams: what their receivers report.

See :class:`GpsModel`: white noise plus a Gauss–Markov bias per axis on the antenna
position, outliers, missing fixes, tunnel dropouts, and speed and course from a noisy
velocity vector with a static-hold course at standstill. :func:`observe` turns a tram's
true states into its fixes (:class:`~antikol.sim.truth.FixLog`) and reports. Report times
``t`` are simulation seconds.

Reproducibility: each tram's GPS noise comes from its own generators seeded from
``(seed, vehicle_id)`` (:func:`~antikol.sim.epochs.noise_generators`), drawn one row of
numbers per fix epoch, so adding a tram, or running longer, does not change another
tram's noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from antikol.report import VehicleReport
from antikol.sim.epochs import (
    blocked_after_tunnels,
    check_fields,
    epochs,
    held_course,
    make_reports,
    start_course,
)
from antikol.sim.track import Track
from antikol.sim.truth import FixLog, Truth
from antikol.sim.vehicles import TramSpec
from trackmap import TrackMap

if TYPE_CHECKING:
    from antikol.sim.urban_gps import UrbanGpsModel

__all__ = ["GpsModel", "observe"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True, slots=True)
class GpsModel:
    """Error model of the trams' GPS receivers.

    Position (of the antenna, ``antenna_offset_m`` behind the front along the track), per
    local axis (east, north)::

        measured = true + bias(t) + white + outlier

    * ``white`` ~ N(0, ``sigma_m``²), independent per fix;
    * ``bias`` a first-order Gauss–Markov process, stationary standard deviation
      ``bias_sigma_m`` and correlation time ``bias_tau_s``:
      ``b[k] = φ·b[k−1] + sqrt(1−φ²)·bias_sigma_m·w``, ``φ = exp(−Δt/bias_tau_s)``,
      starting in its stationary distribution; it runs on during dropouts;
    * ``outlier`` ~ N(0, ``outlier_sigma_m``²) added with probability ``outlier_rate``.

    Fixes come at whole multiples of ``1/rate_hz`` simulation seconds (receivers align
    their epochs to GPS time). A fix is missing with probability ``missing_rate``, and
    while the antenna is on a ``tunnel`` edge (``tunnel_dropout``) plus
    ``tunnel_reacquire_s`` after leaving it.

    Speed and course come from the Doppler velocity, modelled as the true velocity vector
    plus N(0, ``speed_sigma_mps``²) per axis: the speed is its magnitude (never negative;
    Rayleigh with mean ``1.25·speed_sigma_mps`` at standstill) and the course its direction
    plus N(0, ``course_sigma_deg``²). The course error therefore grows at low speed, with
    a standard deviation of about ``sqrt(course_sigma_deg² + degrees(speed_sigma_mps/v)²)``
    (2.1° at 10 m/s, 6.1° at 1 m/s, 12° at 0.5 m/s with the defaults). Below
    ``course_hold_speed_mps`` of *measured* speed the receiver holds its last course, as
    receivers with static hold do; set it to 0 for a course that wanders at random when
    standing. With ``course_held_at_start`` the receiver holds from the start the course
    it measured before the trace began (the tram's running way plus the course noise: a
    trace cut from a service, the tram standing at a stop); without, a tram that starts
    standing reports its first fix's noisy course (a cold start).

    Attributes
    ----------
    sigma_m, bias_sigma_m, bias_tau_s, outlier_rate, outlier_sigma_m, missing_rate,
    tunnel_dropout, tunnel_reacquire_s, rate_hz, speed_sigma_mps, course_sigma_deg,
    course_hold_speed_mps, course_held_at_start
        As above (metres, seconds, probabilities per fix, Hz, m/s, degrees).
    fix_quality : int or None
        GGA fix quality the receiver reports with every fix (``None``: not reported), e.g.
        ``4`` for an RTK receiver.
    """

    sigma_m: float = 3.0
    bias_sigma_m: float = 1.5
    bias_tau_s: float = 60.0
    outlier_rate: float = 0.0
    outlier_sigma_m: float = 50.0
    missing_rate: float = 0.0
    tunnel_dropout: bool = True
    tunnel_reacquire_s: float = 0.0
    rate_hz: float = 1.0
    speed_sigma_mps: float = 0.1
    course_sigma_deg: float = 2.0
    course_hold_speed_mps: float = 0.5
    course_held_at_start: bool = False
    fix_quality: int | None = None

    def __post_init__(self) -> None:
        check_fields(
            self,
            non_negative=(
                "sigma_m",
                "bias_sigma_m",
                "outlier_sigma_m",
                "tunnel_reacquire_s",
                "speed_sigma_mps",
                "course_sigma_deg",
                "course_hold_speed_mps",
            ),
            probabilities=("outlier_rate", "missing_rate"),
            positive=("bias_tau_s",),
        )

    @classmethod
    def urban(cls, **overrides: Any) -> UrbanGpsModel:
        """The realistic street receiver (:class:`~antikol.sim.urban_gps.UrbanGpsModel`):
        multipath bias that jumps and is worst on double track between buildings, heavy
        tails, outages, an odometer and no-fix reports in tunnels.

        Parameters
        ----------
        **overrides
            Fields of :class:`~antikol.sim.urban_gps.UrbanGpsModel` to change.
        """
        from antikol.sim.urban_gps import UrbanGpsModel

        return UrbanGpsModel(**overrides)

    @classmethod
    def exact(cls, *, rate_hz: float = 1.0) -> GpsModel:
        """A perfect receiver: no noise, no bias, no missing fixes (tunnels still drop).

        It reports fix quality 4 (RTK fixed): a receiver that good says so.
        """
        return cls(
            sigma_m=0.0,
            bias_sigma_m=0.0,
            speed_sigma_mps=0.0,
            course_sigma_deg=0.0,
            rate_hz=rate_hz,
            fix_quality=4,
        )


def observe(
    gps: GpsModel,
    spec: TramSpec,
    track: Track,
    truth: Truth,
    net: TrackMap,
    generators: tuple[np.random.Generator, np.random.Generator],
) -> tuple[list[VehicleReport], FixLog]:
    """A tram's GPS fixes and reports from its true states.

    Parameters
    ----------
    gps : GpsModel
    spec : TramSpec
    track : Track
        The tram's extended track (positions and headings of the antenna).
    truth : Truth
        The tram's true states.
    net : TrackMap
        For converting local positions to WGS84.
    generators : (numpy.random.Generator, numpy.random.Generator)
        Normals and uniforms (:func:`~antikol.sim.epochs.noise_generators`).

    Returns
    -------
    reports : list of VehicleReport
        The fixes that were sent, in time order (``seq`` counts them from 0).
    log : FixLog
        Every fix epoch with its error terms.
    """
    ep = epochs(gps.rate_hz, spec, track, truth)
    rate = gps.rate_hz
    tf = ep.t_s
    n = len(tf)
    v = ep.speed_mps
    x, y = ep.x_m, ep.y_m
    theta = ep.grid_heading_rad
    conv = ep.convergence_deg
    tunnel = ep.tunnel
    g_norm, g_unif = generators
    z = g_norm.standard_normal((n, 9))  # one row per epoch: prefix-stable streams
    u = g_unif.random((n, 2))
    # Gauss-Markov bias per axis, starting in its stationary distribution
    phi = math.exp(-1.0 / (rate * gps.bias_tau_s))
    q = gps.bias_sigma_m * math.sqrt(max(1.0 - phi * phi, 0.0))
    bias = np.empty((n, 2))
    if n:
        b = gps.bias_sigma_m * z[0, 2:4]
        bias[0] = b
        for m in range(1, n):
            b = phi * b + q * z[m, 2:4]
            bias[m] = b
    is_outlier = u[:, 0] < gps.outlier_rate
    outlier = is_outlier[:, None] * gps.outlier_sigma_m * z[:, 4:6]
    mx = x + bias[:, 0] + gps.sigma_m * z[:, 0] + outlier[:, 0]
    my = y + bias[:, 1] + gps.sigma_m * z[:, 1] + outlier[:, 1]
    vx = v * np.sin(theta) + gps.speed_sigma_mps * z[:, 6]
    vy = v * np.cos(theta) + gps.speed_sigma_mps * z[:, 7]
    speed = np.minimum(np.hypot(vx, vy), 99.0)
    raw_course = (np.degrees(np.arctan2(vx, vy)) + conv + gps.course_sigma_deg * z[:, 8]) % 360.0
    available = u[:, 1] >= gps.missing_rate
    if gps.tunnel_dropout and tunnel.any():
        available &= ~blocked_after_tunnels(tunnel, tf, gps.tunnel_reacquire_s)
    idx = np.flatnonzero(available)
    course = held_course(
        raw_course, speed, idx, gps.course_hold_speed_mps,
        held_before=start_course(gps.course_held_at_start, theta, conv,
                                 course_sigma_deg=gps.course_sigma_deg, course_noise=z[:, 8]),
    )  # fmt: skip
    log = FixLog(
        vehicle_id=spec.vehicle_id,
        t_s=tf,
        available=available,
        in_tunnel=tunnel,
        true_x_m=x,
        true_y_m=y,
        x_m=mx,
        y_m=my,
        bias_x_m=bias[:, 0].copy(),
        bias_y_m=bias[:, 1].copy(),
        outlier=is_outlier,
        true_speed_mps=v,
        speed_mps=speed,
        true_course_deg=(np.degrees(theta) + conv) % 360.0,
        course_deg=course,
    )
    quality = None if gps.fix_quality is None else np.full(len(ep.t_s), gps.fix_quality)
    reports = make_reports(spec, net, ep, idx, mx, my, speed, course, fix_quality=quality)
    return reports, log
