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

__all__ = ["Candidates", "TurningLoop", "find_candidates", "loop_edges"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
#: A fix may lie this far beyond an edge's end (along it) and still be a candidate of it, m.
END_OVERSHOOT_M = 2.0


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
    extra = [k for k, e in enumerate(found.edge_id.tolist()) if e in loops]
    if not extra:
        return found
    rows: list[tuple[int, int, float, float, float]] = []
    for k in extra:
        e = int(found.edge_id[k])
        loop = loops[e]
        geom = loop.geometry
        i = int(found.point[k])
        pt_geom = shapely.Point(xs[i], ys[i])
        if found.offset_m[k] < loop.half_m:
            start_m, part = loop.half_m, loop.second_half
        else:
            start_m, part = 0.0, loop.first_half
        off = start_m + float(part.project(pt_geom))
        p = geom.interpolate(off)
        dist = float(p.distance(pt_geom))
        if dist > radius[i] or abs(off - found.offset_m[k]) < 2.0 * radius[i]:
            continue
        a, b = (
            geom.interpolate(max(off - 0.5, 0.0)),
            geom.interpolate(min(off + 0.5, geom.length)),
        )
        tx, ty = b.x - a.x, b.y - a.y
        side = tx * (pt_geom.y - p.y) - ty * (pt_geom.x - p.x)
        rows.append(
            (i, e, off, math.copysign(dist, side), math.degrees(math.atan2(tx, ty)) % 360.0)
        )
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
