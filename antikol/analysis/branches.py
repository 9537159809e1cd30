"""Which branch a vehicle will take at a facing switch, from its route or its speed.

Without a planned route every option of a facing switch is a priori equally likely. But a
driver obeys the curve speed of the branch: a tram that is still too fast to slow down to a
sharp branch's speed before the switch, braking comfortably, will not take that branch.
Each option therefore gets the weight 1 when the vehicle can still enter it and
``infeasible_weight`` when it cannot, and the weights at a switch are normalised.

The curve speed of a branch is ``sqrt(a_lat x R)`` where ``R`` is the smallest radius within
the first ``probe_m`` metres past the switch and ``a_lat`` a comfortable lateral
acceleration.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import shapely

from trackmap import Path, TrackMap

__all__ = ["BranchModel", "BranchSettings"]


@dataclass(frozen=True, slots=True)
class BranchSettings:
    """How branch choices are weighed (SI units).

    Attributes
    ----------
    lateral_accel_mps2 : float
        Comfortable lateral acceleration in curves, m/s².
    plan_decel_mps2 : float
        Comfortable braking a driver plans with, m/s².
    infeasible_weight : float
        Relative weight of a branch the vehicle is too fast for.
    probe_m : float
        Length past the switch over which the branch's radius is taken, m.
    """

    lateral_accel_mps2: float = 1.0
    plan_decel_mps2: float = 1.0
    infeasible_weight: float = 0.05
    probe_m: float = 25.0


class BranchModel:
    """Curve speeds at the entry of every edge of a map, and branch probabilities.

    Parameters
    ----------
    track_map : TrackMap
    settings : BranchSettings
    """

    _cache: ClassVar[dict[int, tuple[weakref.ref[Any], dict[BranchSettings, BranchModel]]]] = {}

    def __init__(self, track_map: TrackMap, settings: BranchSettings) -> None:
        self.net = track_map
        self.settings = settings
        radius = self._entry_radii(track_map, settings.probe_m)
        self._curve_speed = np.sqrt(settings.lateral_accel_mps2 * radius)
        # per running state: the squared curve speeds of the options after its end
        self._options: dict[tuple[int, int], tuple[float, ...]] = {}

    @classmethod
    def for_map(cls, track_map: TrackMap, settings: BranchSettings) -> BranchModel:
        """The model of a map, computed once per map object and settings."""
        key = id(track_map)
        entry = cls._cache.get(key)
        if entry is None or entry[0]() is not track_map:
            entry = (weakref.ref(track_map, lambda _: cls._cache.pop(key, None)), {})
            cls._cache[key] = entry
        model = entry[1].get(settings)
        if model is None:
            model = entry[1][settings] = cls(track_map, settings)
        return model

    @staticmethod
    def _entry_radii(net: TrackMap, probe_m: float) -> np.ndarray:
        """Smallest radius within ``probe_m`` of each edge's entry, per state
        (``2 * edge`` entering at the first vertex, ``2 * edge + 1`` at the last), m."""
        geoms = np.array([e.geometry for e in net.edges], dtype=object)
        lengths = shapely.length(geoms)
        steps = np.linspace(0.0, 1.0, 7)  # 0 .. probe_m in 6 steps
        out = np.full(2 * len(geoms), np.inf)
        for reverse in (False, True):
            span = np.minimum(lengths, probe_m)
            at = span[:, None] * steps[None, :]
            if reverse:
                at = lengths[:, None] - at
            pts = shapely.line_interpolate_point(geoms[:, None], at)
            x, y = shapely.get_x(pts), shapely.get_y(pts)
            heading = np.unwrap(np.arctan2(np.diff(x, axis=1), np.diff(y, axis=1)), axis=1)
            turn = np.abs(np.diff(heading, axis=1))
            ds = (span / (len(steps) - 1))[:, None]
            with np.errstate(divide="ignore"):
                radius = np.where(turn > 1e-9, ds / turn, np.inf)
            out[int(reverse) :: 2] = np.min(radius, axis=1)
        return out

    def curve_speed_mps(self, edge_id: int, direction: int) -> float:
        """Comfortable speed at the entry of an edge run in a direction, m/s."""
        return float(self._curve_speed[2 * edge_id + (direction < 0)])

    def _squared_speeds(self, edge: int, direction: int) -> tuple[float, ...]:
        """Squared curve speeds of the options at the end of an edge run one way."""
        key = (edge, direction)
        known = self._options.get(key)
        if known is None:
            options = self.net.successors(edge, direction, respect_direction=True)
            known = self._options[key] = tuple(
                vc * vc for vc in (self.curve_speed_mps(e, d) for e, d in options)
            )
        return known

    def path_probability(
        self, path: Path, speed_mps: float, route: tuple[int, ...] | None
    ) -> float:
        """Probability that a vehicle at the path's origin takes this path.

        Parameters
        ----------
        path : Path
        speed_mps : float
            The vehicle's speed now, m/s.
        route : tuple of int, optional
            Planned route (edge ids): decides alone when given.

        Returns
        -------
        float
        """
        if route:
            on = set(route)
            return 1.0 if all(e in on for e in path.edges[1:]) else 0.0
        infeasible = self.settings.infeasible_weight
        plan_decel = self.settings.plan_decel_mps2
        steps = path.steps
        p = 1.0
        for k, node in enumerate(path.nodes):
            if node.choice is None or k + 1 >= len(steps):
                continue
            step = steps[k]
            options = self._squared_speeds(step.edge_id, step.direction)
            if len(options) < 2:
                continue
            # the square of the speed the vehicle has at the switch after braking comfortably
            arrive2 = speed_mps * speed_mps - 2.0 * plan_decel * node.distance_m
            taken = steps[k + 1]
            total = sum(1.0 if arrive2 <= v2 else infeasible for v2 in options)
            vc = self.curve_speed_mps(taken.edge_id, taken.direction)
            mine = 1.0 if arrive2 <= vc * vc else infeasible
            p *= mine / total if total > 0 else 0.0
        return p if math.isfinite(p) else 0.0
