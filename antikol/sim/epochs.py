"""What every simulated receiver shares: fix epochs, noise generators, field checks and
the report builder.

:func:`epochs` lays a tram's fix epochs over its true states (rate, missing fixes,
tunnels); :func:`noise_generators` seeds its noise from ``(seed, vehicle_id)`` so that
adding a tram does not change another's; :func:`make_reports` turns the measured values
into :class:`~antikol.report.VehicleReport` rows. The receiver models
(:class:`~antikol.sim.gps.GpsModel`, :class:`~antikol.sim.urban_gps.UrbanGpsModel`) are
built on them.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from antikol.report import MAX_ROUTE_EDGES, VehicleReport
from antikol.sim.track import Track
from antikol.sim.truth import Truth
from antikol.sim.vehicles import TramSpec
from trackmap import TrackMap

__all__ = [
    "Epochs",
    "blocked_after_tunnels",
    "check_fields",
    "epochs",
    "held_course",
    "make_reports",
    "noise_generators",
    "start_course",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]


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
    raw_course: FloatArray,
    speed: FloatArray,
    idx: IntArray,
    hold_speed_mps: float,
    *,
    held_before: float | None = None,
) -> FloatArray:
    """Reported course at the epochs ``idx`` (NaN elsewhere): below ``hold_speed_mps`` of
    measured speed the receiver holds its last course (static hold), from the start
    ``held_before`` (degrees) if given (what it measured before the trace began)."""
    course = np.full(len(raw_course), np.nan)
    last_course = held_before if hold_speed_mps > 0.0 else None
    for m in idx.tolist():
        c = float(raw_course[m])
        if last_course is not None and speed[m] < hold_speed_mps:
            c = last_course
        course[m] = last_course = c
    return course


def start_course(
    held: bool,
    heading_rad: FloatArray,
    convergence_deg: FloatArray | float,
    *,
    course_sigma_deg: float,
    course_noise: FloatArray,
) -> float | None:
    """The course a receiver holds before its first epoch, degrees (None: not ``held``):
    the running way at the first epoch (grid heading ``heading_rad`` plus the meridian
    convergence) with ``course_sigma_deg`` times the first epoch's unit ``course_noise``."""
    if not held or not len(heading_rad):
        return None
    convergence = float(np.atleast_1d(convergence_deg)[0])
    noise = course_sigma_deg * float(course_noise[0])
    return (math.degrees(float(heading_rad[0])) + convergence + noise) % 360.0


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
