"""The GPS model of the simulated trams: what their receivers report.

See :class:`GpsModel`: white noise plus a Gauss–Markov bias per axis on the antenna
position, outliers, missing fixes, tunnel dropouts, and speed and course from a noisy
velocity vector with a static-hold course at standstill. :func:`observe` turns a tram's
true states into its fixes (:class:`~antikol.sim.truth.FixLog`) and reports. Report times
``t`` are simulation seconds.

Reproducibility: each tram's GPS noise comes from its own generators seeded from
``(seed, vehicle_id)`` (:func:`noise_generators`), drawn one row of numbers per fix epoch,
so adding a tram, or running longer, does not change another tram's noise.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from antikol.report import MAX_ROUTE_EDGES, VehicleReport
from antikol.sim.track import Track
from antikol.sim.truth import FixLog, Truth
from antikol.sim.vehicles import TramSpec
from trackmap import TrackMap

if TYPE_CHECKING:
    from antikol.sim.urban_gps import UrbanGpsModel

__all__ = [
    "Epochs",
    "GpsModel",
    "blocked_after_tunnels",
    "check_fields",
    "epochs",
    "held_course",
    "make_reports",
    "noise_generators",
    "observe",
]

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
    receivers with static hold do (the first fix keeps its noisy course); set it to 0 for
    a course that wanders at random when standing.

    Attributes
    ----------
    sigma_m, bias_sigma_m, bias_tau_s, outlier_rate, outlier_sigma_m, missing_rate,
    tunnel_dropout, tunnel_reacquire_s, rate_hz, speed_sigma_mps, course_sigma_deg,
    course_hold_speed_mps
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


def check_fields(
    model: Any,
    *,
    non_negative: tuple[str, ...] = (),
    probabilities: tuple[str, ...] = (),
    positive: tuple[str, ...] = (),
) -> None:
    """Validate a receiver model's fields, and its ``rate_hz`` in (0, 100] Hz.

    Parameters
    ----------
    model : object
        A frozen receiver model (its class name goes into the messages).
    non_negative, probabilities, positive : tuple of str
        Fields that must be finite and >= 0, in [0, 1], and > 0.

    Raises
    ------
    ValueError
        The first field out of its domain, by name.
    """
    cls = type(model).__name__

    def number(value: object) -> bool:
        return isinstance(value, int | float) and not isinstance(value, bool)

    for name in non_negative:
        value = getattr(model, name)
        if not (number(value) and math.isfinite(value) and value >= 0):
            raise ValueError(f"{cls}.{name} must be a finite number >= 0, got {value!r}")
    for name in probabilities:
        value = getattr(model, name)
        if not (number(value) and 0.0 <= value <= 1.0):
            raise ValueError(f"{cls}.{name} must be a probability in [0, 1], got {value!r}")
    for name in positive:
        value = getattr(model, name)
        if not (number(value) and value > 0):
            raise ValueError(f"{cls}.{name} must be > 0, got {value!r}")
    rate = model.rate_hz
    if not (number(rate) and math.isfinite(rate) and 0 < rate <= 100):
        raise ValueError(f"{cls}.rate_hz must be in (0, 100] Hz, got {rate!r}")


def noise_generators(seed: int, vehicle_id: str) -> tuple[np.random.Generator, np.random.Generator]:
    """The two generators of a tram's GPS noise (normals, uniforms), freshly seeded.

    Parameters
    ----------
    seed : int
        The simulator's seed.
    vehicle_id : str

    Returns
    -------
    (numpy.random.Generator, numpy.random.Generator)
        Normals and uniforms, seeded from ``seed`` and a hash of ``vehicle_id``.
    """
    ss = np.random.SeedSequence([seed, *_id_words(vehicle_id)])
    a, b = ss.spawn(2)
    return np.random.default_rng(a), np.random.default_rng(b)


def _id_words(vehicle_id: str) -> list[int]:
    digest = hashlib.sha256(vehicle_id.encode("utf-8")).digest()
    return [int.from_bytes(digest[i : i + 4], "little") for i in range(0, 16, 4)]


@dataclass(frozen=True, eq=False)
class Epochs:
    """A tram's true state at its receiver's fix epochs (shared by the receiver models).

    Attributes
    ----------
    t_s : ndarray
        Epoch times, s (whole multiples of ``1/rate_hz``).
    distance_m, speed_mps : ndarray
        Route distance of the front, m, and true speed, m/s.
    antenna_m : ndarray
        Route distance of the antenna, m.
    x_m, y_m : ndarray
        True antenna position in the map's local frame, m.
    grid_heading_rad : ndarray
        Track heading at the antenna from grid north, radians clockwise.
    convergence_deg : ndarray
        True azimuth of grid north there, degrees.
    step : ndarray of int
        Index of the track step (edge) the antenna is on.
    tunnel : ndarray of bool
        The antenna is on a tunnel edge.
    braking : ndarray of str
        The brake state announced at each epoch.
    """

    t_s: FloatArray
    distance_m: FloatArray
    speed_mps: FloatArray
    antenna_m: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    grid_heading_rad: FloatArray
    convergence_deg: FloatArray
    step: IntArray
    tunnel: BoolArray
    braking: npt.NDArray[np.str_]

    def __len__(self) -> int:
        return len(self.t_s)


def epochs(rate_hz: float, spec: TramSpec, track: Track, truth: Truth) -> Epochs:
    """The true states of a tram at the fix epochs of a receiver running at ``rate_hz``.

    Parameters
    ----------
    rate_hz : float
        Fix rate, Hz.
    spec : TramSpec
    track : Track
    truth : Truth

    Returns
    -------
    Epochs
    """
    rate = rate_hz
    if len(truth):
        m0 = math.ceil(truth.t_s[0] * rate - 1e-6)
        m1 = math.floor(truth.t_s[-1] * rate + 1e-6)
    else:
        m0, m1 = 0, -1
    tf = np.arange(m0, m1 + 1, dtype=np.float64) / rate
    n = len(tf)
    if n:
        s = np.interp(tf, truth.t_s, truth.distance_m)
        v = np.interp(tf, truth.t_s, truth.speed_mps)
        ki = np.clip(np.searchsorted(truth.t_s, tf + 1e-6, side="right") - 1, 0, len(truth) - 1)
    else:
        s = v = np.zeros(0)
        ki = np.zeros(0, dtype=np.int64)
    sa = s - spec.antenna_m
    x, y = track.xy(sa)
    ak, _, _ = track.locate(sa)
    return Epochs(
        t_s=tf,
        distance_m=s,
        speed_mps=v,
        antenna_m=sa,
        x_m=x,
        y_m=y,
        grid_heading_rad=track.grid_heading_rad(sa),
        convergence_deg=track.convergence_deg(sa),
        step=ak,
        tunnel=track.tunnel[ak],
        braking=truth.braking[ki],
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
        Normals and uniforms (:func:`noise_generators`).

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
    course = held_course(raw_course, speed, idx, gps.course_hold_speed_mps)
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


def blocked_after_tunnels(tunnel: BoolArray, t_s: FloatArray, reacquire_s: float) -> BoolArray:
    """Epochs without a fix because of tunnels: in one, and ``reacquire_s`` after leaving it."""
    blocked = tunnel.copy()
    if reacquire_s > 0:
        last = -math.inf
        for m in range(len(t_s)):
            if tunnel[m]:
                last = t_s[m]
            elif t_s[m] - last < reacquire_s:
                blocked[m] = True
    return blocked


def held_course(
    raw_course: FloatArray, speed: FloatArray, idx: IntArray, hold_speed_mps: float
) -> FloatArray:
    """Reported course at the epochs ``idx`` (NaN elsewhere): below ``hold_speed_mps`` of
    measured speed the receiver holds its last course (static hold)."""
    course = np.full(len(raw_course), np.nan)
    last_course: float | None = None
    for m in idx.tolist():
        c = float(raw_course[m])
        if last_course is not None and speed[m] < hold_speed_mps:
            c = last_course
        course[m] = last_course = c
    return course


def make_reports(
    spec: TramSpec,
    net: TrackMap,
    ep: Epochs,
    idx: IntArray,
    mx: FloatArray,
    my: FloatArray,
    speed: FloatArray,
    course: FloatArray,
    *,
    fix_quality: IntArray | None = None,
    odometer_m: FloatArray | None = None,
) -> list[VehicleReport]:
    """The reports of the epochs ``idx`` (``seq`` counts them from 0).

    Parameters
    ----------
    spec : TramSpec
    net : TrackMap
        For converting local positions to WGS84.
    ep : Epochs
    idx : ndarray of int
        The epochs that yield a report, ascending.
    mx, my : ndarray
        Reported position per epoch in the local frame, m.
    speed, course : ndarray
        Reported speed (m/s) and course (degrees) per epoch.
    fix_quality : ndarray of int, optional
        GGA fix quality per epoch (``0``: no position fix).
    odometer_m : ndarray, optional
        Odometer reading per epoch, m.

    Returns
    -------
    list of VehicleReport
    """
    if not len(idx):
        return []
    lon, lat = net.to_lonlat(mx[idx], my[idx])
    lon = np.atleast_1d(np.asarray(lon, dtype=float))
    lat = np.atleast_1d(np.asarray(lat, dtype=float))
    route_k = None
    if spec.broadcast_route:
        route_k = np.clip(
            np.searchsorted(spec.route.entry_m, ep.distance_m, side="right") - 1,
            0,
            len(spec.route.steps) - 1,
        )
    edge_ids = spec.route.edge_ids
    reports = []
    for seq, m in enumerate(idx.tolist()):
        route = None
        if route_k is not None:
            k = int(route_k[m])
            route = edge_ids[k : k + MAX_ROUTE_EDGES]
        reports.append(
            VehicleReport(
                vehicle_id=spec.vehicle_id,
                t=float(ep.t_s[m]),
                lat=float(lat[seq]),
                lon=float(lon[seq]),
                speed_mps=float(speed[m]),
                course_deg=float(course[m]),
                braking=str(ep.braking[m]),  # type: ignore[arg-type]
                length_m=spec.length_m,
                antenna_offset_m=spec.antenna_m,
                route=route,
                seq=seq,
                fix_quality=None if fix_quality is None else int(fix_quality[m]),
                odometer_m=None if odometer_m is None else float(odometer_m[m]),
            )
        )
    return reports
