"""A realistic street GPS receiver: multipath bias, heavy tails, outages and an odometer.

:class:`~antikol.sim.gps.GpsModel` (white noise plus a slowly wandering bias) is the easy
case. In streets the errors that matter are different (issue 12):

* **multipath** — signals reflected off facades give a *lateral* (across-street) bias of
  several metres that persists for tens of seconds to minutes and **jumps** when the
  satellite geometry changes; it is worst where double track runs between buildings;
* **heavy tails** — now and then an error several times the usual one;
* **urban-canyon outages** — runs of epochs without a fix, more frequent in canyons;
* a course over ground good to a few degrees when moving and meaningless at standstill,
  and a speed good to about 0.2 m/s;
* on board there is also a wheel **odometer**: the distance travelled with a small scale
  error, and in **tunnels** reports without a position fix (``fix_quality = 0``) that carry
  the last known position and the odometer.

:class:`UrbanGpsModel` simulates all of it; :func:`observe_urban` applies it to a tram's
true states. The **canyon factor** ``c`` in [0, 1] of a place sets how bad it is: the share
of double track of the edge (:func:`~antikol.sim.places.double_track_share`) mapped between
``canyon_open`` and ``canyon_double_track``, times a random factor per edge (log-normal,
seeded by ``canyon_seed`` and the edge id, so it is a property of the place, shared by all
trams), clipped to [0, 1] and interpolated along the route between edge midpoints.

>>> from antikol.sim import GpsModel
>>> gps = GpsModel.urban(canyon_seed=3)
>>> gps.canyon_seed, gps.odometer
(3, True)
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.special import stdtrit

from antikol.errors import InvalidArgumentError
from antikol.report import VehicleReport
from antikol.sim.epochs import (
    blocked_after_tunnels,
    check_fields,
    epochs,
    held_course,
    make_reports,
    start_course,
)
from antikol.sim.places import double_track_share, map_cache
from antikol.sim.track import Track
from antikol.sim.truth import FixLog, Truth
from antikol.sim.vehicles import TramSpec
from trackmap import TrackMap

__all__ = [
    "COURSE_FAULTS",
    "UrbanGpsModel",
    "canyon_factors",
    "course_with_fault",
    "observe_urban",
    "street_settings",
]

#: The faults of a feed's course that :class:`UrbanGpsModel` can simulate.
COURSE_FAULTS = ("none", "reversed", "zero", "ccw_from_east")

FloatArray = npt.NDArray[np.float64]

_N_NORMALS = 11  # normals drawn per epoch (prefix-stable streams)
_N_UNIFORMS = 7  # uniforms drawn per epoch
_ODOMETER_ORIGIN_M = 1.0e5  # odometer readings start anywhere in [0, this)


@dataclass(frozen=True, slots=True)
class UrbanGpsModel:
    """A street GPS receiver with multipath bias, heavy tails, outages and an odometer.

    Position of the antenna, per epoch, in the track's frame (along, left)::

        measured = true + R(heading) · (σ_along(c)·u_along, σ_lat(c)·u_lat) + white + outlier

    * ``u`` is a unit-variance Gauss–Markov process per component (correlation time
      ``bias_tau_s``) that is **re-drawn** at Poisson times — the satellite geometry
      changes — with mean interval ``jump_interval_s / (1 + c)``;
    * ``σ_lat(c) = bias_open_m + c·(bias_canyon_lateral_m − bias_open_m)``, and likewise
      ``σ_along`` with ``bias_canyon_along_m``: in the open the bias is isotropic, in a
      canyon mostly across the street;
    * ``white`` is Student-t with ``tail_dof`` degrees of freedom and scale ``sigma_m``
      per axis (standard deviation ``sigma_m·sqrt(ν/(ν−2))``; Gaussian when
      ``tail_dof`` is None);
    * ``outlier`` ~ N(0, ``outlier_sigma_m``²) per axis with probability ``outlier_rate``.

    Outages: a two-state (Gilbert–Elliott) chain per epoch; an outage starts with hazard
    ``dropout_open_hz + c·(dropout_canyon_hz − dropout_open_hz)`` per second and lasts
    ``dropout_mean_s`` on average (geometric). Besides, each epoch is missing with
    probability ``missing_rate``, and there is no fix in tunnels (``tunnel_dropout``) and
    for ``tunnel_reacquire_s`` after one.

    Speed and course are those of a Doppler velocity with N(0, ``speed_sigma_mps``²) noise
    per axis, plus N(0, ``course_sigma_deg``²) on the course (see
    :class:`~antikol.sim.gps.GpsModel`); below ``course_hold_speed_mps`` the receiver holds
    its course (0: no hold, the course is meaningless at standstill); with
    ``course_held_at_start`` it holds from the start the course it measured before the
    trace began (see :class:`~antikol.sim.gps.GpsModel`).

    The odometer (``odometer``) reads the distance travelled by the front times
    ``1 + ε``, ``ε ~ N(0, odometer_scale_sigma²)`` per tram, from a random origin,
    rounded to ``odometer_resolution_m``; with ``odometer_period_s`` the counter is updated
    only every that many seconds (from a random phase, not in step with the reports) and
    each report reads its last update (a unit that reads its counter on a slower cycle
    than it sends its fixes). With ``report_without_fix`` every epoch without a
    position fix (an outage or a tunnel, once the tram had a first fix) still yields a
    report with ``fix_quality = 0``, the last reported position and course, the wheel speed
    (true speed plus N(0, ``speed_sigma_mps``²)) and the odometer; reports with a fix carry
    ``fix_quality = 1``. With ``latency_s`` the receiver's position, speed and course are
    that old (rounded to whole epochs) when the report is stamped, the odometer is not (an
    AVL unit that stamps its reports when it sends them); it sends nothing until its first
    fix is that old. Without ``fix_quality_field`` (an
    operator's feed, GTFS-realtime) no report carries a fix quality: those without a fix
    repeat the last position unflagged. ``course_fault`` makes the reported course wrong
    all along (:func:`course_with_fault`): a feed that sends a bidirectional vehicle's
    heading of its other end (``"reversed"``), 0 where it has no heading (``"zero"``), or
    a bearing counter-clockwise from east (``"ccw_from_east"``).

    A report without a fix may carry a position the sender estimated instead
    (``fix_quality = 6``): with ``estimates_along_route`` the last fix moved on by the
    tram's true motion since (a vehicle computer that moves its position along the route by
    the odometer, HSL's ``loc`` ``ODO``); with ``estimates_extrapolated`` the last fix
    moved on at the last fix's speed along its heading (a receiver's dead reckoning without
    wheel input: off the track in curves and at diverging switches).

    Attributes
    ----------
    sigma_m, tail_dof, bias_open_m, bias_canyon_lateral_m, bias_canyon_along_m, bias_tau_s,
    jump_interval_s, outlier_rate, outlier_sigma_m, dropout_open_hz, dropout_canyon_hz,
    dropout_mean_s, missing_rate, tunnel_dropout, tunnel_reacquire_s, rate_hz,
    speed_sigma_mps, course_sigma_deg, course_hold_speed_mps, course_held_at_start, odometer,
    odometer_scale_sigma, odometer_resolution_m, odometer_period_s, report_without_fix,
    fix_quality_field, latency_s, estimates_along_route, estimates_extrapolated,
    course_fault
        As above (metres, seconds, Hz, probabilities, m/s, degrees; ``course_fault`` one
        of :data:`COURSE_FAULTS`).
    canyon_open, canyon_double_track : float
        Canyon factor of track without and with a parallel opposite-direction track.
    canyon_spread : float
        Standard deviation of the log of the random canyon factor per edge.
    canyon_seed : int
        Seed of the random canyon factors of the places.
    """

    sigma_m: float = 1.5
    tail_dof: float | None = 4.0
    bias_open_m: float = 1.0
    bias_canyon_lateral_m: float = 4.0
    bias_canyon_along_m: float = 2.0
    bias_tau_s: float = 120.0
    jump_interval_s: float = 120.0
    outlier_rate: float = 0.002
    outlier_sigma_m: float = 30.0
    dropout_open_hz: float = 0.0005
    dropout_canyon_hz: float = 0.01
    dropout_mean_s: float = 5.0
    missing_rate: float = 0.0
    tunnel_dropout: bool = True
    tunnel_reacquire_s: float = 3.0
    rate_hz: float = 1.0
    speed_sigma_mps: float = 0.15
    course_sigma_deg: float = 2.0
    course_hold_speed_mps: float = 0.0
    course_held_at_start: bool = False
    odometer: bool = True
    odometer_scale_sigma: float = 0.005
    odometer_resolution_m: float = 0.1
    odometer_period_s: float = 0.0
    report_without_fix: bool = True
    fix_quality_field: bool = True
    latency_s: float = 0.0
    estimates_along_route: bool = False
    estimates_extrapolated: bool = False
    course_fault: str = "none"
    canyon_open: float = 0.2
    canyon_double_track: float = 0.8
    canyon_spread: float = 0.4
    canyon_seed: int = 0

    def __post_init__(self) -> None:
        check_fields(
            self,
            non_negative=(
                "sigma_m",
                "bias_open_m",
                "bias_canyon_lateral_m",
                "bias_canyon_along_m",
                "outlier_sigma_m",
                "dropout_open_hz",
                "dropout_canyon_hz",
                "tunnel_reacquire_s",
                "speed_sigma_mps",
                "course_sigma_deg",
                "course_hold_speed_mps",
                "odometer_scale_sigma",
                "odometer_resolution_m",
                "odometer_period_s",
                "canyon_spread",
                "latency_s",
            ),
            probabilities=("outlier_rate", "missing_rate", "canyon_open", "canyon_double_track"),
            positive=("bias_tau_s", "jump_interval_s", "dropout_mean_s"),
        )
        if self.tail_dof is not None and not (
            isinstance(self.tail_dof, int | float) and 2.0 < self.tail_dof < math.inf
        ):
            raise ValueError(f"UrbanGpsModel.tail_dof must be > 2 or None, got {self.tail_dof!r}")
        if self.course_fault not in COURSE_FAULTS:
            raise ValueError(
                f"UrbanGpsModel.course_fault must be one of {COURSE_FAULTS}, "
                f"got {self.course_fault!r:.40}"
            )
        if self.estimates_along_route and self.estimates_extrapolated:
            raise ValueError(
                "UrbanGpsModel: estimates_along_route and estimates_extrapolated exclude each other"
            )
        if isinstance(self.canyon_seed, bool) or not isinstance(self.canyon_seed, int):
            raise ValueError(f"UrbanGpsModel.canyon_seed must be an int, got {self.canyon_seed!r}")

    def lateral_sigma_m(self, canyon: FloatArray | float) -> FloatArray:
        """Standard deviation of the across-track bias at canyon factor(s) ``canyon``, m."""
        c = np.asarray(canyon, dtype=float)
        return self.bias_open_m + c * (self.bias_canyon_lateral_m - self.bias_open_m)

    def along_sigma_m(self, canyon: FloatArray | float) -> FloatArray:
        """Standard deviation of the along-track bias at canyon factor(s) ``canyon``, m."""
        c = np.asarray(canyon, dtype=float)
        return self.bias_open_m + c * (self.bias_canyon_along_m - self.bias_open_m)


#: Either receiver model of the simulator.


def canyon_factors(model: UrbanGpsModel, net: TrackMap) -> FloatArray:
    """The canyon factor of every edge of a map, in [0, 1] (see the module notes).

    Parameters
    ----------
    model : UrbanGpsModel
    net : TrackMap

    Returns
    -------
    ndarray
        One factor per edge id. Tunnels and bridges are open sky (``canyon_open``): a
        tunnel has no fix at all, and a bridge stands free.
    """
    key = (model.canyon_open, model.canyon_double_track, model.canyon_spread, model.canyon_seed)
    per_map: dict[tuple[float, float, float, int], FloatArray] = map_cache(net).setdefault(
        "canyon_factors", {}
    )
    cached = per_map.get(key)
    if cached is not None:
        return cached
    share = double_track_share(net)
    out = np.empty(len(net.edges))
    for e in net.edges:
        base = model.canyon_open + share.get(e.edge_id, 0.0) * (
            model.canyon_double_track - model.canyon_open
        )
        if e.tunnel or e.bridge:
            base = model.canyon_open
        z = _place_normal(model.canyon_seed, e.edge_id)
        out[e.edge_id] = min(max(base * math.exp(model.canyon_spread * z), 0.0), 1.0)
    per_map[key] = out
    return out


def _place_normal(seed: int, edge_id: int) -> float:
    """A standard normal number that depends only on (seed, edge id)."""
    digest = hashlib.sha256(f"canyon:{seed}:{edge_id}".encode()).digest()
    words = [int.from_bytes(digest[i : i + 4], "little") for i in range(0, 16, 4)]
    return float(np.random.default_rng(np.random.SeedSequence(words)).standard_normal())


def street_settings(settings: Iterable[str]) -> dict[str, float | bool | str]:
    """Fields of :class:`UrbanGpsModel` from ``NAME=VALUE`` strings, as a command line
    gives them: numbers, ``true`` or ``false``, or words (``course_fault=reversed``).

    Parameters
    ----------
    settings : iterable of str
        ``NAME=VALUE`` items, e.g. ``["bias_canyon_lateral_m=6", "odometer=false"]``.

    Returns
    -------
    dict
        Keyword arguments of :class:`UrbanGpsModel` (checked: the model they make is valid).

    Raises
    ------
    InvalidArgumentError
        An item that names no field, a value of the wrong kind, or a model that rejects it
        (the message names the item).

    >>> street_settings(["bias_canyon_lateral_m=6", "odometer=false"])
    {'bias_canyon_lateral_m': 6.0, 'odometer': False}
    """
    items = list(settings)
    defaults = UrbanGpsModel()
    names = {f.name for f in dataclasses.fields(UrbanGpsModel)}
    changes: dict[str, float | bool | str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or name not in names:
            raise InvalidArgumentError(
                "gps setting", item, "expected NAME=VALUE with an UrbanGpsModel field"
            )
        default = getattr(defaults, name)
        if isinstance(default, str):
            changes[name] = value
        elif isinstance(default, bool):
            if value.lower() not in ("true", "false"):
                raise InvalidArgumentError("gps setting", item, f"{name} is true or false")
            changes[name] = value.lower() == "true"
        else:
            try:
                changes[name] = int(value) if isinstance(default, int) else float(value)
            except ValueError:
                raise InvalidArgumentError(
                    "gps setting", item, f"{value!r} is not a number"
                ) from None
    try:
        UrbanGpsModel(**changes)  # type: ignore[arg-type]
    except ValueError as exc:
        raise InvalidArgumentError("gps settings", items, str(exc)) from None
    return changes


def observe_urban(
    gps: UrbanGpsModel,
    spec: TramSpec,
    track: Track,
    truth: Truth,
    net: TrackMap,
    generators: tuple[np.random.Generator, np.random.Generator],
) -> tuple[list[VehicleReport], FixLog]:
    """A tram's reports from its true states under the urban receiver model.

    Parameters
    ----------
    gps : UrbanGpsModel
    spec : TramSpec
    track : Track
        The tram's extended track.
    truth : Truth
    net : TrackMap
    generators : (numpy.random.Generator, numpy.random.Generator)
        Normals and uniforms (:func:`~antikol.sim.epochs.noise_generators`); each epoch draws
        one row of each, so a longer run does not change the earlier noise.

    Returns
    -------
    reports : list of VehicleReport
        In time order, ``seq`` counting them from 0.
    log : FixLog
        Every epoch with its error terms, canyon factor and odometer.
    """
    ep = epochs(gps.rate_hz, spec, track, truth)
    tf = ep.t_s
    n = len(tf)
    dt = 1.0 / gps.rate_hz
    g_norm, g_unif = generators
    z = g_norm.standard_normal((n, _N_NORMALS))
    u = g_unif.random((n, _N_UNIFORMS))
    # canyon factor along the route: per edge, interpolated between edge midpoints
    factor = canyon_factors(gps, net)
    mid = 0.5 * (track.b0 + track.b1)
    canyon = np.interp(ep.antenna_m, mid, factor[track.edge]) if n else np.zeros(0)
    canyon = np.where(ep.tunnel, 0.0, canyon)
    # multipath bias: unit Gauss-Markov per component, re-drawn at geometry changes
    phi = math.exp(-dt / gps.bias_tau_s)
    q = math.sqrt(max(1.0 - phi * phi, 0.0))
    p_jump = 1.0 - np.exp(-dt * (1.0 + canyon) / gps.jump_interval_s)
    jump = u[:, 2] < p_jump
    unit = np.empty((n, 2))
    if n:
        b = z[0, 2:4].copy()
        unit[0] = b
        for m in range(1, n):
            b = z[m, 4:6].copy() if jump[m] else phi * b + q * z[m, 2:4]
            unit[m] = b
    if n:
        jump[0] = False
    along = gps.along_sigma_m(canyon) * unit[:, 1]
    lateral = gps.lateral_sigma_m(canyon) * unit[:, 0]
    th = ep.grid_heading_rad
    bias_x = along * np.sin(th) - lateral * np.cos(th)  # left of travel is (-cos, sin)
    bias_y = along * np.cos(th) + lateral * np.sin(th)
    if gps.tail_dof is None:
        white = gps.sigma_m * z[:, 0:2]
    else:
        uu = np.clip(u[:, 0:2], 1e-12, 1.0 - 1e-12)
        white = gps.sigma_m * stdtrit(gps.tail_dof, uu)
    is_outlier = u[:, 3] < gps.outlier_rate
    outlier = is_outlier[:, None] * gps.outlier_sigma_m * z[:, 6:8]
    mx = ep.x_m + bias_x + white[:, 0] + outlier[:, 0]
    my = ep.y_m + bias_y + white[:, 1] + outlier[:, 1]
    # velocity, speed and course
    v = ep.speed_mps
    vx = v * np.sin(th) + gps.speed_sigma_mps * z[:, 8]
    vy = v * np.cos(th) + gps.speed_sigma_mps * z[:, 9]
    speed = np.minimum(np.hypot(vx, vy), 99.0)
    raw_course = (
        np.degrees(np.arctan2(vx, vy)) + ep.convergence_deg + gps.course_sigma_deg * z[:, 10]
    ) % 360.0
    lag = round(gps.latency_s * gps.rate_hz) if gps.latency_s > 0.0 else 0
    if lag and n:
        # the receiver's output is latency_s old when the report is stamped (and there is
        # none before its first fix is that old)
        late = np.maximum(np.arange(n) - lag, 0)
        mx, my, speed, raw_course = mx[late], my[late], speed[late], raw_course[late]
    # outages: a two-state chain whose entry hazard grows with the canyon
    p_enter = 1.0 - np.exp(
        -dt * (gps.dropout_open_hz + canyon * (gps.dropout_canyon_hz - gps.dropout_open_hz))
    )
    p_exit = 1.0 - math.exp(-dt / gps.dropout_mean_s)
    outage = np.zeros(n, dtype=bool)
    state = False
    for m in range(n):
        state = bool(u[m, 4] >= p_exit) if state else bool(u[m, 4] < p_enter[m])
        outage[m] = state
    available = ~outage & (u[:, 5] >= gps.missing_rate)
    available[:lag] = False  # a late receiver has nothing to send yet
    if gps.tunnel_dropout and ep.tunnel.any():
        available &= ~blocked_after_tunnels(ep.tunnel, tf, gps.tunnel_reacquire_s)
    fix_idx = np.flatnonzero(available)
    course = held_course(
        raw_course, speed, fix_idx, gps.course_hold_speed_mps,
        held_before=start_course(gps.course_held_at_start, th, ep.convergence_deg,
                                 course_sigma_deg=gps.course_sigma_deg, course_noise=z[:, 10]),
    )  # fmt: skip
    course = course_with_fault(course, gps.course_fault)
    # odometer: distance of the front with a scale error, from a random origin
    odometer: FloatArray | None = None
    if gps.odometer and n:
        scale = 1.0 + gps.odometer_scale_sigma * float(z[0, 4])  # unused by the bias at 0
        origin = float(u[0, 6]) * _ODOMETER_ORIGIN_M
        raw = origin + scale * (ep.distance_m - ep.distance_m[0])
        if gps.odometer_period_s > 0.0:
            # the counter updates on a cycle of its own (its phase drawn from the origin's
            # draw): each report reads the value of the counter's last update before it
            period = gps.odometer_period_s
            phase = (float(u[0, 6]) * 97.0) % 1.0 * period
            updated = tf[0] + np.floor((tf - tf[0] - phase) / period) * period + phase
            raw = np.interp(np.maximum(updated, tf[0]), tf, raw)
        res = gps.odometer_resolution_m
        odometer = np.round(np.floor(raw / res) * res, 6) if res > 0 else raw
        odometer = np.maximum.accumulate(np.maximum(odometer, 0.0))
    # reports: fixes, and without a fix the last known position (once there is one)
    rx, ry = mx.copy(), my.copy()
    rspeed, rcourse = speed.copy(), course.copy()
    quality = np.ones(n, dtype=np.int64)
    no_fix = np.zeros(n, dtype=bool)
    if gps.report_without_fix and len(fix_idx):
        wheel = np.maximum(v + gps.speed_sigma_mps * z[:, 8], 0.0)
        last = -1
        for m in range(int(fix_idx[0]), n):
            if available[m]:
                last = m
                continue
            no_fix[m] = True
            rx[m], ry[m] = mx[last], my[last]
            rcourse[m] = course[last]
            rspeed[m] = min(float(wheel[m]), 99.0)
            if gps.estimates_along_route:
                rx[m] += ep.x_m[m] - ep.x_m[last]
                ry[m] += ep.y_m[m] - ep.y_m[last]
            elif gps.estimates_extrapolated:
                run = float(speed[last]) * float(tf[m] - tf[last])
                rx[m] += run * math.sin(th[last])
                ry[m] += run * math.cos(th[last])
            quality[m] = 6 if gps.estimates_along_route or gps.estimates_extrapolated else 0
    idx = np.flatnonzero(available | no_fix)
    reports = make_reports(
        spec,
        net,
        ep,
        idx,
        rx,
        ry,
        rspeed,
        rcourse,
        fix_quality=quality if gps.fix_quality_field else None,
        odometer_m=odometer,
    )
    log = FixLog(
        vehicle_id=spec.vehicle_id,
        t_s=tf,
        available=available,
        in_tunnel=ep.tunnel,
        true_x_m=ep.x_m,
        true_y_m=ep.y_m,
        x_m=mx,
        y_m=my,
        bias_x_m=bias_x,
        bias_y_m=bias_y,
        outlier=is_outlier,
        true_speed_mps=v,
        speed_mps=speed,
        true_course_deg=(np.degrees(th) + ep.convergence_deg) % 360.0,
        course_deg=course,
        canyon=canyon,
        bias_lateral_m=lateral,
        bias_jump=jump,
        outage=outage,
        no_fix_report=no_fix,
        odometer_m=odometer,
    )
    return reports, log


def course_with_fault(course_deg: FloatArray, fault: str) -> FloatArray:
    """The course a faulty feed reports for a receiver's course.

    Parameters
    ----------
    course_deg : ndarray of float
        The receiver's course over ground, degrees clockwise from north.
    fault : str
        One of :data:`COURSE_FAULTS`: ``"none"``; ``"reversed"`` (180 degrees off, the
        heading of a bidirectional vehicle's other end); ``"zero"`` (always 0); or
        ``"ccw_from_east"`` (the same direction as a mathematical angle, counter-clockwise
        from east).

    Returns
    -------
    ndarray of float
        Degrees in [0, 360).

    >>> course_with_fault(np.array([0.0, 90.0, 200.0]), "ccw_from_east").tolist()
    [90.0, 0.0, 250.0]
    """
    if fault == "none":
        return course_deg
    if fault == "reversed":
        return np.asarray((course_deg + 180.0) % 360.0, dtype=float)
    if fault == "zero":
        return np.zeros_like(course_deg)
    if fault == "ccw_from_east":
        return np.asarray((90.0 - course_deg) % 360.0, dtype=float)
    raise ValueError(f"course_fault must be one of {COURSE_FAULTS}, got {fault!r:.40}")
