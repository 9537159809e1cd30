"""Kinds of place on a track map that matter to GPS and to positioning: double track.

Double track is where two tracks run side by side, 2.5–6 m apart, in opposite permitted
directions — street running in most tram cities. It is where a lateral GPS error puts a
vehicle on the wrong track, and, between buildings, where multipath makes such errors
large and persistent (:class:`~antikol.sim.urban_gps.UrbanGpsModel`).

>>> from trackmap.synthetic import demo_network
>>> net = demo_network().build()
>>> share = double_track_share(net)
>>> 0.0 <= min(share.values()) and max(share.values()) <= 1.0
True
"""

from __future__ import annotations

import weakref
from collections import defaultdict
from typing import Any, Final

import numpy as np
import numpy.typing as npt
import shapely

from trackmap import TrackMap

__all__ = [
    "DOUBLE_TRACK_SPACING_M",
    "double_track_share",
    "map_cache",
    "on_double_track",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: Track-centre spacing of double track, metres (min, max).
DOUBLE_TRACK_SPACING_M: Final = (2.5, 6.0)
_OPPOSITE_DEG: Final = 150.0  # headings differing by more than this run opposite ways
_SAMPLE_M: Final = 10.0

_caches: dict[int, tuple[weakref.ref[TrackMap], dict[str, Any]]] = {}


def map_cache(net: TrackMap) -> dict[str, Any]:
    """A dictionary of derived data kept with a map while it lives (maps are unhashable).

    Parameters
    ----------
    net : TrackMap

    Returns
    -------
    dict
        The same dictionary for the same map object; dropped when the map is collected.
    """
    key = id(net)
    entry = _caches.get(key)
    if entry is not None and entry[0]() is net:
        return entry[1]
    store: dict[str, Any] = {}

    def drop(_ref: weakref.ref[TrackMap], k: int = key) -> None:
        _caches.pop(k, None)

    _caches[key] = (weakref.ref(net, drop), store)
    return store


def on_double_track(net: TrackMap, x: FloatArray, y: FloatArray) -> BoolArray:
    """Whether each point lies on double track.

    A point is on double track when, besides the nearest directed track, another directed
    track runs the opposite way at a track-centre spacing within
    :data:`DOUBLE_TRACK_SPACING_M`.

    Parameters
    ----------
    net : TrackMap
    x, y : ndarray
        Points in the map's local frame, metres.

    Returns
    -------
    ndarray of bool
    """
    lo, hi = DOUBLE_TRACK_SPACING_M
    x = np.atleast_1d(np.asarray(x, dtype=float))
    y = np.atleast_1d(np.asarray(y, dtype=float))
    out = np.zeros(len(x), dtype=bool)
    if not len(x):
        return out
    batch = net.candidates_batch_xy(x, y, hi + 0.5)
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
            if lo <= sep <= hi and abs((h - h0 + 180.0) % 360.0 - 180.0) > _OPPOSITE_DEG:
                out[k] = True
                break
    return out


def double_track_share(net: TrackMap) -> dict[int, float]:
    """The share of each edge's length that is double track (see :func:`on_double_track`).

    Sampled every 10 m along every edge (at least three points an edge); computed once per
    map and kept while the map lives.

    Parameters
    ----------
    net : TrackMap

    Returns
    -------
    dict of int to float
        Edge id to a share in [0, 1].
    """
    cache = map_cache(net)
    cached: dict[int, float] | None = cache.get("double_track_share")
    if cached is not None:
        return cached
    xs: list[FloatArray] = []
    ys: list[FloatArray] = []
    owner: list[FloatArray] = []
    for e in net.edges:
        n = max(3, int(e.length_m // _SAMPLE_M) + 1)
        offsets = (np.arange(n) + 0.5) * (e.length_m / n)
        pts = shapely.line_interpolate_point(e.geometry, offsets)
        xy = shapely.get_coordinates(pts)
        xs.append(xy[:, 0])
        ys.append(xy[:, 1])
        owner.append(np.full(n, e.edge_id, dtype=float))
    if xs:
        flags = on_double_track(net, np.concatenate(xs), np.concatenate(ys))
        ids = np.concatenate(owner).astype(np.int64)
        total = np.bincount(ids, minlength=len(net.edges))
        hits = np.bincount(ids, weights=flags.astype(float), minlength=len(net.edges))
        share = {e.edge_id: float(hits[e.edge_id] / max(total[e.edge_id], 1)) for e in net.edges}
    else:
        share = {}
    cache["double_track_share"] = share
    return share
