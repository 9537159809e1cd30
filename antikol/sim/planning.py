"""Speed planning: what each simulated tram knows about its route before the run.

On a grid along the route (every ``grid_m``, 2 m by default) the *limit* is the minimum of
the edge's ``maxspeed_mps`` (or ``default_speed_mps``, 50 km/h), the vehicle's maximum
speed and the curve speed ``sqrt(a_lat · R)``, with the curve radius ``R`` of
:func:`antikol.sim.track.curve_radius`. Edge limits are spread to the grid points on both
sides of an edge, so linear interpolation never exceeds the limit of any edge however
short, and curve limits over ±8 m, the reach of the radius estimate. The driver's
*target* is ``cruise_factor`` times the minimum of the limit over the train's length (a
restriction holds until the rear has cleared it), and the *envelope* is the highest speed
from which every lower target ahead (and a stop at the route end) can be met with the
planning deceleration.

A :class:`VehiclePlan` also holds the tram's extended :class:`~antikol.sim.track.Track`,
its stops and the conflict points its route passes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numpy as np
import numpy.typing as npt

from antikol.sim.conflicts import ConflictIndex, conflict_passes
from antikol.sim.events import StopCall
from antikol.sim.routes import map_stops_on_route
from antikol.sim.track import CURVE_REACH_M, Track, curve_radius
from antikol.sim.vehicles import TramSpec
from trackmap import TrackMap

__all__ = ["DEFAULT_SPEED_MPS", "SpeedPlan", "VehiclePlan"]

FloatArray = npt.NDArray[np.float64]

#: Speed on edges without a ``maxspeed`` tag, m/s (50 km/h).
DEFAULT_SPEED_MPS: Final = 50.0 / 3.6


@dataclass(frozen=True, eq=False)
class SpeedPlan:
    """The static speed profile of one tram along its route.

    Attributes
    ----------
    vehicle_id : str
    distance_m : ndarray
        Grid of route distances, metres (spacing at most ``grid_m``).
    limit_mps : ndarray
        Allowed speed at the front: min(edge limit or default, vehicle max, curve speed),
        m/s. Linear interpolation between grid points is a valid limit.
    curve_radius_m : ndarray
        Estimated track radius, metres (large on straight track).
    target_mps : ndarray
        What the driver aims at: ``cruise_factor`` × the minimum of ``limit_mps`` over the
        train's length, m/s.
    envelope_mps : ndarray
        Highest speed from which every lower target ahead, and the route end (unless the
        tram exits there), is reached with the planning deceleration, m/s.
    stops : tuple of StopCall
        The stops the tram will make.
    """

    vehicle_id: str
    distance_m: FloatArray
    limit_mps: FloatArray
    curve_radius_m: FloatArray
    target_mps: FloatArray
    envelope_mps: FloatArray
    stops: tuple[StopCall, ...]

    def limit_at(self, distance_m: npt.ArrayLike) -> FloatArray:
        """Allowed speed at route distances (linear interpolation), m/s."""
        d = np.asarray(distance_m, dtype=np.float64)
        return np.asarray(np.interp(d, self.distance_m, self.limit_mps), dtype=np.float64)


def _dilate_min(values: FloatArray, before: int, after: int) -> FloatArray:
    """Minimum over the window [i - before, i + after] (edges clamped)."""
    out = values.copy()
    n = len(values)
    for j in range(1, min(before, n - 1) + 1):
        out[j:] = np.minimum(out[j:], values[:-j])
        out[:j] = np.minimum(out[:j], values[0])
    for j in range(1, min(after, n - 1) + 1):
        out[:-j] = np.minimum(out[:-j], values[j:])
        out[-j:] = np.minimum(out[-j:], values[-1])
    return out


class VehiclePlan:
    """Precomputed data of one tram: its track, speed plan, stops and conflict passes.

    Parameters
    ----------
    index : int
        The tram's position in the simulator's list.
    spec : TramSpec
    net : TrackMap
    grid_m : float
        Spacing of the speed-profile grid, metres.
    default_speed_mps : float
        Limit on edges without ``maxspeed``, m/s.
    lead_in_m : float
        Track wanted behind the route start, metres (see :class:`Track`).
    coords : dict of int to ndarray
        Edge coordinate cache shared between trams.
    conflicts : ConflictIndex

    Attributes
    ----------
    route_len : float
        Route length, metres.
    track : Track
    dg : float
        Actual grid spacing, metres (at most ``grid_m``).
    env2 : ndarray
        Squared speed envelope on the grid, m²/s².
    plan_stops : tuple of StopCall
    plan : SpeedPlan
    passes : list of ConflictPass
    """

    def __init__(
        self,
        index: int,
        spec: TramSpec,
        net: TrackMap,
        *,
        grid_m: float,
        default_speed_mps: float,
        lead_in_m: float,
        coords: dict[int, FloatArray],
        conflicts: ConflictIndex,
    ) -> None:
        self.index = index
        self.spec = spec
        route = spec.route
        self.route_len = route.length_m
        self.track = Track(net, route, lead_in_m, coords)
        tr = self.track
        length = self.route_len
        n_g = max(2, math.ceil(length / grid_m - 1e-9) + 1)
        dg = max(length / (n_g - 1), 1e-6)
        grid = np.arange(n_g, dtype=np.float64) * dg
        grid[-1] = max(length, grid[-2] + 1e-6)
        self.dg = dg
        vmax = spec.vmax_mps
        # track limit, dilated so that interpolation never exceeds any edge's limit
        track_lim = np.full(n_g, vmax)
        for k in range(len(tr.edge)):
            if tr.b1[k] <= 0.0 or tr.b0[k] >= length:
                continue
            maxspeed = net.edges[int(tr.edge[k])].maxspeed_mps
            c = default_speed_mps if maxspeed is None else maxspeed
            if c >= vmax:
                continue
            i0 = max(math.floor(max(tr.b0[k], 0.0) / dg), 0)
            i1 = min(math.ceil(min(tr.b1[k], length) / dg), n_g - 1)
            track_lim[i0 : i1 + 1] = np.minimum(track_lim[i0 : i1 + 1], c)
        radius = curve_radius(tr, grid)
        # the estimate smears a curvature step over ±8 m: spread the limit as far
        reach = math.ceil(CURVE_REACH_M / dg)
        curve_lim = _dilate_min(np.sqrt(spec.lateral_accel_mps2 * radius), reach, reach)
        limit = np.minimum(np.minimum(track_lim, curve_lim), vmax)
        w = math.ceil(spec.length_m / dg)
        target = spec.cruise_factor * _dilate_min(limit, w, 0)
        bp = spec.plan_decel_mps2
        t2 = target**2
        if not spec.exit_at_end:
            t2[-1] = 0.0
        ramp = 2.0 * bp * dg * np.arange(n_g)
        env2 = np.minimum.accumulate((t2 + ramp)[::-1])[::-1] - ramp
        env2 = np.maximum(env2, 0.0)
        self.env2 = env2
        self.plan_stops = self._stops(net, spec)
        self.plan = SpeedPlan(
            vehicle_id=spec.vehicle_id,
            distance_m=grid,
            limit_mps=limit,
            curve_radius_m=radius,
            target_mps=target,
            envelope_mps=np.sqrt(env2),
            stops=self.plan_stops,
        )
        self.passes = conflict_passes(self.track, conflicts)

    def _stops(self, net: TrackMap, spec: TramSpec) -> tuple[StopCall, ...]:
        """The spec's stops, or every map stop on the route the tram can still make."""
        if spec.stops is not None:
            return spec.stops
        v0 = spec.initial_speed_mps
        nearest = 1.0 + v0 * v0 / (2.0 * spec.plan_decel_mps2)
        calls: list[StopCall] = []
        for dist, stop in map_stops_on_route(net, spec.route):
            if dist < nearest:
                continue
            if calls and dist - calls[-1].distance_m < 1.0:
                continue
            calls.append(StopCall(dist, spec.dwell_s, stop.name))
        return tuple(calls)
