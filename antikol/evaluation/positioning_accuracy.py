"""Accuracy of track-selective positioning against the simulator's true states."""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

from antikol.positioning.matcher import Positioner
from antikol.sim import Route, SimulationResult
from trackmap import TrackMap

__all__ = ["PositioningScore", "positioning_accuracy"]


@dataclass
class PositioningScore:
    """Accuracy of track-selective positioning against the simulator's truth.

    Attributes
    ----------
    fixes : int
        Reports evaluated (matched or not).
    double_track_fixes, double_track_correct : int
        Fixes on double track (an opposite-direction track within 6 m) and those placed on
        the right track and running direction (within ``tolerance_m`` along the route).
    after_switch_fixes, after_switch_correct : int
        Fixes 40-60 m past a facing switch and those on the right branch.
    along_rmse_m, raw_along_rmse_m : float
        Along-track RMS error of the filtered position and of the raw fix projected on the
        true track, m.
    unmatched : int
        Fixes with no usable match.
    """

    fixes: int = 0
    double_track_fixes: int = 0
    double_track_correct: int = 0
    after_switch_fixes: int = 0
    after_switch_correct: int = 0
    along_rmse_m: float = math.nan
    raw_along_rmse_m: float = math.nan
    unmatched: int = 0

    @property
    def double_track_accuracy(self) -> float:
        return self.double_track_correct / max(self.double_track_fixes, 1)

    @property
    def branch_accuracy(self) -> float:
        return self.after_switch_correct / max(self.after_switch_fixes, 1)

    @property
    def rmse_reduction(self) -> float:
        """1 - filtered / raw along-track RMSE (0.33 means a third lower)."""
        return 1.0 - self.along_rmse_m / self.raw_along_rmse_m

    def as_dict(self) -> dict[str, Any]:
        return {
            "fixes": self.fixes,
            "double_track_accuracy": round(self.double_track_accuracy, 4),
            "double_track_fixes": self.double_track_fixes,
            "branch_accuracy_50m_after_switch": round(self.branch_accuracy, 4),
            "after_switch_fixes": self.after_switch_fixes,
            "along_track_rmse_m": round(self.along_rmse_m, 3),
            "raw_along_track_rmse_m": round(self.raw_along_rmse_m, 3),
            "rmse_reduction": round(self.rmse_reduction, 3),
            "unmatched": self.unmatched,
        }


def _facing_switch_distances(net: TrackMap, route: Route) -> list[float]:
    """Route distances of the facing switches a route takes (trunk -> branch)."""
    out = []
    merge_by_node = {c.node_id: c for c in net.conflicts if c.kind == "merge"}
    entry = -(
        route.start_offset_m
        if route.steps[0][1] == 1
        else route.edge_lengths_m[0] - route.start_offset_m
    )
    for k, (e, d) in enumerate(route.steps[:-1]):
        entry += route.edge_lengths_m[k]
        node = net.edges[e].end_node if d == 1 else net.edges[e].start_node
        c = merge_by_node.get(node)
        if c is not None and c.edges[0] == e and route.steps[k + 1][0] in c.edges[1:]:
            out.append(entry)
    return out


def positioning_accuracy(
    net: TrackMap,
    result: SimulationResult,
    *,
    config: Any = None,
    tolerance_m: float = 8.0,
) -> PositioningScore:
    """Run the positioning filter over a simulation's reports and score it against truth.

    Parameters
    ----------
    net : TrackMap
    result : SimulationResult
    config : PositioningConfig, optional
    tolerance_m : float
        An estimate counts as on the right track when it lies on the true route within
        this distance of the true antenna position, in the true running direction, m.
    """
    specs = {s.vehicle_id: s for s in result.specs}
    pos = Positioner(net, config)
    sc = PositioningScore()
    errs: list[float] = []
    raw: list[float] = []
    rows: list[tuple[float, float, bool, bool]] = []  # true x, y, on-double?, after switch?
    checks: list[bool] = []
    by_time = sorted(result.reports, key=lambda r: r.t)
    switch_at = {v: _facing_switch_distances(net, specs[v].route) for v in specs}
    for r in by_time:
        spec = specs[r.vehicle_id]
        truth = result.truth[r.vehicle_id]
        est = pos.update(r)
        idx = truth.index_at(r.t)
        s_ant = float(truth.distance_m[idx]) - spec.antenna_m
        te, to, _ = spec.route.locate(max(s_ant, 0.0))
        sc.fixes += 1
        tx, ty = float(truth.antenna_x_m[idx]), float(truth.antenna_y_m[idx])
        after = any(40.0 <= s_ant - s0 <= 60.0 for s0 in switch_at[r.vehicle_id])
        if not est.matched or est.edge_id is None or est.offset_m is None:
            sc.unmatched += 1
            correct = False
        else:
            d = spec.route.distance_of(est.edge_id, est.offset_m, after_m=max(s_ant - 50.0, 0.0))
            correct = (
                d is not None
                and abs(d - s_ant) <= tolerance_m
                and spec.route.locate(d)[2] == est.direction
            )
            geom = net.edges[te].geometry
            ex, ey = net.point_at(est.edge_id, est.offset_m)
            p_est = shapely.Point(ex, ey)
            if geom.distance(p_est) <= tolerance_m:
                errs.append(float(geom.project(p_est)) - to)
            rx, ry = net.to_local(r.lon, r.lat)
            p_raw = shapely.Point(rx, ry)
            raw.append(float(geom.project(p_raw)) - to)
        rows.append((tx, ty, False, after))
        checks.append(correct)
    if rows:
        xs = np.array([row[0] for row in rows])
        ys = np.array([row[1] for row in rows])
        double = _on_double_track(net, xs, ys)
        for k, row in enumerate(rows):
            if double[k]:
                sc.double_track_fixes += 1
                sc.double_track_correct += int(checks[k])
            if row[3]:
                sc.after_switch_fixes += 1
                sc.after_switch_correct += int(checks[k])
    if errs:
        sc.along_rmse_m = float(np.sqrt(np.mean(np.square(errs))))
        sc.raw_along_rmse_m = float(np.sqrt(np.mean(np.square(raw))))
    return sc


def _on_double_track(net: TrackMap, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Whether each point lies on double track: two tracks 2.5-6 m apart, opposite ways."""
    batch = net.candidates_batch_xy(x, y, 6.5)
    out = np.zeros(len(x), dtype=bool)
    per: dict[int, list[int]] = defaultdict(list)
    for row in range(len(batch)):
        per[int(batch.point[row])].append(row)
    for k, rows_k in per.items():
        if len(rows_k) < 2:
            continue
        nearest = min(rows_k, key=lambda r: batch.distance_m[r])
        e0 = net.edges[int(batch.edge_id[nearest])]
        if e0.direction == 0:
            continue
        h0 = (float(batch.heading_deg[nearest]) + (0.0 if e0.direction == 1 else 180.0)) % 360.0
        for r in rows_k:
            e = net.edges[int(batch.edge_id[r])]
            if r == nearest or e.direction == 0:
                continue
            h = (float(batch.heading_deg[r]) + (0.0 if e.direction == 1 else 180.0)) % 360.0
            sep = abs(float(batch.lateral_m[r]) - float(batch.lateral_m[nearest]))
            if 2.5 <= sep <= 6.0 and abs((h - h0 + 180.0) % 360.0 - 180.0) > 150.0:
                out[k] = True
                break
    return out
