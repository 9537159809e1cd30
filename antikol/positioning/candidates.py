"""Candidate places of a batch of fixes on the tracks.

Every edge within the search radius of a fix gives its nearest point; a turning loop, whose
start and end lie metres apart, gives the nearest point of its other half too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely
import shapely.ops

from trackmap import TrackMap

__all__ = ["Candidates", "TurningLoop", "find_candidates", "loop_edges", "reach_to_own_tracks_m"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
#: A fix may lie this far beyond an edge's end (along it) and still be a candidate of it, m.
END_OVERSHOOT_M = 2.0
#: A refusing vehicle whose course turned farther than this from its track's way has left
#: the track (:func:`reach_to_own_tracks_m`), degrees: a GPS bias moves fixes, not the
#: course, which a moving receiver measures to a few degrees.
OWN_TRACK_COURSE_DEG = 30.0


@dataclass(frozen=True, slots=True)
class Candidates:
    """Candidate places of a batch of fixes (parallel arrays, grouped by fix)."""

    point: IntArray  # index of the fix
    edge_id: IntArray
    offset_m: FloatArray
    lateral_m: FloatArray  # signed distance from the track, m (left positive)
    heading_deg: FloatArray  # track heading in the edge's vertex order

    def __iter__(self) -> Any:
        return iter((self.point, self.edge_id, self.offset_m, self.lateral_m, self.heading_deg))


@dataclass(frozen=True, slots=True)
class TurningLoop:
    """An edge that comes back near its own start, and its two halves (local frame, m)."""

    half_m: float
    geometry: shapely.LineString
    first_half: shapely.LineString
    second_half: shapely.LineString


def loop_edges(net: TrackMap, radius_m: float) -> dict[int, TurningLoop]:
    """Edges that come back within ``2 * radius_m`` (m) of their own start (turning
    loops), by edge id; their halves are cut once here, not per fix."""
    out = {}
    for e in net.edges:
        g = e.geometry
        start, end = g.coords[0], g.coords[-1]
        if math.dist(start, end) < 2.0 * radius_m and g.length > 6.0 * radius_m:
            half = g.length / 2.0
            out[e.edge_id] = TurningLoop(
                half,
                g,
                shapely.ops.substring(g, 0.0, half),
                shapely.ops.substring(g, half, g.length),
            )
    return out


def find_candidates(
    net: TrackMap,
    loops: dict[int, TurningLoop],
    xs: FloatArray,
    ys: FloatArray,
    radius: FloatArray,
) -> Candidates:
    """Places on the tracks near each fix: the nearest point of every edge in reach,
    and on a loop the nearest point of its other half too (where a turning loop closes,
    its start and end lie metres apart and the fix may belong to either)."""
    batch = net.candidates_batch_xy(xs, ys, float(radius.max()))  # by fix, then edge
    # a fix beyond an edge's end projects onto that end: the neighbouring edge holds it
    # (a candidate there would turn an along-track miss into a small "lateral" offset)
    overshoot = np.sqrt(np.maximum(batch.distance_m**2 - batch.lateral_m**2, 0.0))
    within = (batch.distance_m <= radius[batch.point]) & (overshoot <= END_OVERSHOOT_M)
    found = Candidates(
        batch.point[within],
        batch.edge_id[within],
        batch.offset_m[within],
        # beyond an end by less than the tolerance: the whole distance is the offset
        np.copysign(batch.distance_m[within], batch.lateral_m[within]),
        batch.heading_deg[within],
    )
    if not loops:
        return found
    # (from every edge in reach, before the overshoot test: where a loop closes, a fix
    # beyond its start lies beside its end, and the start's overshoot must not hide that)
    in_reach = batch.distance_m <= radius[batch.point]
    extra = np.flatnonzero(in_reach & np.isin(batch.edge_id, np.fromiter(loops, np.int64)))
    if not len(extra):
        return found
    rows: list[tuple[int, int, float, float, float]] = []
    for e, i, nearest_m in zip(
        batch.edge_id[extra].tolist(),
        batch.point[extra].tolist(),
        batch.offset_m[extra].tolist(),
        strict=True,
    ):
        off, lateral_m, overshoot_m, heading_deg = _other_half(
            net, loops[e], e, xs[i], ys[i], nearest_m
        )
        if math.hypot(lateral_m, overshoot_m) > radius[i] or overshoot_m > END_OVERSHOOT_M:
            continue
        if abs(off - nearest_m) < 2.0 * radius[i]:
            continue  # (the same place as the edge's nearest point)
        rows.append((i, e, off, math.copysign(math.hypot(lateral_m, overshoot_m), lateral_m),
                     heading_deg))  # fmt: skip
    if not rows:
        return found
    add = np.array(rows, dtype=float)
    merged = Candidates(
        np.concatenate([found.point, add[:, 0].astype(np.int64)]),
        np.concatenate([found.edge_id, add[:, 1].astype(np.int64)]),
        np.concatenate([found.offset_m, add[:, 2]]),
        np.concatenate([found.lateral_m, add[:, 3]]),
        np.concatenate([found.heading_deg, add[:, 4]]),
    )
    keep = np.lexsort((merged.edge_id, merged.point))
    return Candidates(*(a[keep] for a in merged))


def _other_half(
    net: TrackMap, loop: TurningLoop, edge_id: int, x: float, y: float, nearest_m: float
) -> tuple[float, float, float, float]:
    """The nearest place of a fix on the half of a loop that does not hold its nearest
    point: offset along the edge, signed lateral offset (left positive) and overshoot
    beyond the half's ends, m, and the true heading of the edge there, degrees."""
    geom = loop.geometry
    point = shapely.Point(x, y)
    if nearest_m < loop.half_m:
        start_m, part = loop.half_m, loop.second_half
    else:
        start_m, part = 0.0, loop.first_half
    off = start_m + float(part.project(point))
    p = geom.interpolate(off)
    a = geom.interpolate(max(off - 0.5, 0.0))
    b = geom.interpolate(min(off + 0.5, geom.length))
    tx, ty = b.x - a.x, b.y - a.y
    tn = math.hypot(tx, ty) or 1.0
    lateral_m = (tx * (y - p.y) - ty * (x - p.x)) / tn
    overshoot_m = math.sqrt(max(math.dist((x, y), (p.x, p.y)) ** 2 - lateral_m**2, 0.0))
    return off, lateral_m, overshoot_m, net.heading_at(edge_id, off)


def reach_to_own_tracks_m(
    net: TrackMap,
    hypotheses: tuple[IntArray, FloatArray],
    run_m: FloatArray,
    refusing: npt.NDArray[np.bool_],
    fixes: tuple[FloatArray, FloatArray, FloatArray],
    *,
    along_tolerance_m: float,
    course_tolerance_deg: float = OWN_TRACK_COURSE_DEG,
    cap_m: float,
) -> FloatArray:
    """The search radius that takes in the tracks of a vehicle's own hypotheses while it
    refuses fixes: the fix's distance to the nearest of them plus a metre, at most
    ``cap_m``, where the fix lies beside the place the hypothesis has run to (on its edge,
    or on the edges it runs on to) and the vehicle still runs the way it does.

    A jump of the GPS bias can carry a run of fixes beyond the search radius of the track
    the vehicle is on, while the other direction's track, a few metres nearer, stays
    within it: the vehicle's own track must stay a candidate, or the restart that follows a
    run of refused fixes can only land on the other track, running wrong way. A vehicle
    that has left its track (a turn the map does not connect) shows it otherwise: its
    course turns away from the track, and its fixes fall behind the place it would have
    run to along it. The search is not widened for those.

    Parameters
    ----------
    net : TrackMap
    hypotheses : (ndarray of int, ndarray of float), shapes (n, k)
        Each fix's vehicle's hypotheses: state ids (negative: an empty slot) and offsets
        along their edges, m.
    run_m : ndarray of float
        How far each vehicle has run since its hypotheses' time, m.
    refusing : ndarray of bool
        The vehicles that refused their last fix.
    fixes : (ndarray of float, ndarray of float, ndarray of float)
        The fixes in the map's local frame (x, y, m) and the course to weigh of each
        (degrees; NaN where none is, e.g. at a standstill).
    along_tolerance_m : float, keyword-only
        The largest distance along the track between the fix and the place run to, m.
    course_tolerance_deg : float, keyword-only
        The largest angle between the course and the hypothesis' way along its track, deg.
    cap_m : float, keyword-only
        The largest radius given, m.

    Returns
    -------
    ndarray of float
        One radius per fix, m: 0 where the vehicle does not refuse fixes or no hypothesis
        qualifies.
    """
    states, offsets = hypotheses
    xs, ys, course = fixes
    out = np.zeros(len(xs))
    for i in np.flatnonzero(refusing).tolist():
        fix = shapely.Point(xs[i], ys[i])
        best = math.inf
        for state, offset in zip(states[i].tolist(), offsets[i].tolist(), strict=True):
            if state < 0:
                continue
            # every way the hypothesis can have run on, onto the next edges too (state id:
            # the edge, and the way in the low bit)
            edge, way = state >> 1, -1 if state & 1 else 1
            # (no path of the length searched comes within the cap of a fix this far from
            # the place: a receiver gone wild, e.g. jammed, costs one distance per hypothesis)
            line = net.edge(edge).geometry
            if line.interpolate(offset).distance(fix) > cap_m + run_m[i] + 4.0 * along_tolerance_m:
                continue
            # from up to the tolerance behind the place on its edge (a fix lagging along the
            # track) to beyond it (a fix farther on would project short)
            length = line.length
            start = (
                max(offset - along_tolerance_m, 0.0)
                if way == 1
                else min(offset + along_tolerance_m, length)
            )
            back = abs(offset - start)
            reach = back + run_m[i] + 2.0 * along_tolerance_m
            for path in net.paths_ahead(edge, start, way, reach, respect_direction=False):
                ran = net.path_geometry(path)  # (as the hypothesis runs)
                at = ran.project(fix)
                if abs(at - back - run_m[i]) > along_tolerance_m or ran.length == 0.0:
                    continue
                if math.isfinite(course[i]):
                    a = ran.interpolate(max(at - 1.0, 0.0))
                    b = ran.interpolate(min(at + 1.0, ran.length))
                    heading = math.degrees(math.atan2(b.x - a.x, b.y - a.y))
                    if abs((course[i] - heading + 180.0) % 360.0 - 180.0) > course_tolerance_deg:
                        continue
                best = min(best, ran.distance(fix))
        if best + 1.0 <= cap_m:
            out[i] = best + 1.0
    return out
