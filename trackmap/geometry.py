"""Polyline helpers in the local metric frame: arc length, end tangents, deflection.

Shared by topology inference (:mod:`trackmap.builder.topology`) and the map checks
(:mod:`trackmap.check`), so neither depends on the other.

>>> import numpy as np
>>> xy = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 4.0]])
>>> cumulative_length(xy).tolist()
[0.0, 3.0, 7.0]
>>> end_tangent(xy, cumulative_length(xy), 1, 2.0).tolist()
[0.0, -1.0]
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

__all__ = ["FloatArray", "cumulative_length", "deflection_deg", "end_tangent", "point_at"]

FloatArray = npt.NDArray[np.float64]


def cumulative_length(xy: FloatArray) -> FloatArray:
    """Cumulative length along a polyline (n, 2) -> (n,), metres."""
    seg = np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1]))
    return np.concatenate([[0.0], np.cumsum(seg)])


def point_at(xy: FloatArray, cum: FloatArray, s: float) -> FloatArray:
    """Point at arc length ``s`` along a polyline (clamped to its ends)."""
    s = min(max(s, 0.0), float(cum[-1]))
    i = int(np.searchsorted(cum, s, side="right") - 1)
    i = min(max(i, 0), len(cum) - 2)
    span = cum[i + 1] - cum[i]
    f = 0.0 if span <= 0 else (s - cum[i]) / span
    return np.asarray(xy[i] + f * (xy[i + 1] - xy[i]), dtype=float)


def end_tangent(xy: FloatArray, cum: FloatArray, end: int, probe_m: float) -> FloatArray:
    """Unit vector pointing from an edge end into the edge, measured over ``probe_m``."""
    length = float(cum[-1])
    d = min(probe_m, length)
    vec = point_at(xy, cum, d) - xy[0] if end == 0 else point_at(xy, cum, length - d) - xy[-1]
    norm = math.hypot(vec[0], vec[1])
    if norm == 0:
        return np.array([0.0, 0.0])
    return np.asarray(vec / norm, dtype=float)


def deflection_deg(u: FloatArray, v: FloatArray) -> float:
    """Deflection of a move in along ``-u`` and out along ``v``: 0 straight, 180 reversal.

    ``u`` and ``v`` are the unit vectors pointing from the node into each edge.
    """
    cos = float(np.clip(-(u @ v), -1.0, 1.0))
    return math.degrees(math.acos(cos))
