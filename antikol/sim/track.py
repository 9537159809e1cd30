"""Track geometry along a tram's route: positions, headings and curve radii.

A :class:`Track` is a route extended backwards by a lead-in (so that the body of a tram
near its start, and the trams behind it, have somewhere to be), flattened into arrays for
fast vectorised look-ups.

The curve radius ``R`` (:func:`curve_radius`) comes from the turning of the track heading:
the heading at ``s`` is the direction of the chord from ``s − 4 m`` to ``s + 4 m`` of the
route polyline (exact on a circular arc, and it smooths the kinks of digitised OSM
geometry), and ``1/R`` is the heading change between ``s − 4 m`` and ``s + 4 m`` divided by
8 m; a kink of coarse geometry thus reads as a tight curve (conservative).
"""

from __future__ import annotations

import math
from typing import Final

import numpy as np
import numpy.typing as npt
import shapely

from antikol.sim.routes import Route
from trackmap import TrackMap

__all__ = ["CURVE_REACH_M", "Track", "curve_radius"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

_CHORD_HALF_M: Final = 4.0  # curve radius: half chord of the heading estimate
_CURVE_HALF_M: Final = 4.0  # curve radius: half window of the heading difference
_MIN_RADIUS_M: Final = 1.0
#: How far along the track :func:`curve_radius` smears a step in curvature, metres.
CURVE_REACH_M: Final = _CHORD_HALF_M + _CURVE_HALF_M


class Track:
    """A tram's route extended backwards by a lead-in, as arrays for fast look-ups.

    Distances are route distances (the lead-in is negative).

    Parameters
    ----------
    net : TrackMap
    route : Route
    lead_in_m : float
        Length of track wanted behind the route start, metres. The lead-in follows the
        traversal graph backwards (main line first); at a dead end it goes on straight.
    coords : dict of int to ndarray
        Cache of edge vertex coordinates, shared between the trams of a simulator.

    Attributes
    ----------
    n_prefix : int
        Number of lead-in steps before the route's first step.
    edge, dir, len : ndarray
        Edge id, running direction and length (m) of each step.
    b0, b1 : ndarray
        Route distance of each step's entry and exit, metres.
    tunnel : ndarray of bool
        Whether each step's edge is a tunnel.
    node_out : ndarray
        The node each step leaves by.
    px, py, pd : ndarray
        The polyline of the whole extended track: local x and y, metres, and route
        distance of each vertex (strictly increasing).
    """

    def __init__(
        self,
        net: TrackMap,
        route: Route,
        lead_in_m: float,
        coords: dict[int, FloatArray],
    ) -> None:
        first = route.steps[0]
        behind = (
            route.start_offset_m
            if first[1] == 1
            else route.edge_lengths_m[0] - (route.start_offset_m)
        )
        prefix: list[tuple[int, int]] = []
        have = behind
        state = first
        seen = {first}
        while have < lead_in_m:
            preds = sorted(
                net.traversal.predecessors(state) if state in net.traversal else [],
                key=lambda s: (net.edges[s[0]].service is not None, s[0], s[1]),
            )
            preds = [p for p in preds if p not in seen]
            if not preds:
                break
            state = preds[0]
            seen.add(state)
            prefix.append(state)
            have += net.edge_length(state[0])
        prefix.reverse()
        steps = [*prefix, *route.steps]
        self.n_prefix = len(prefix)
        self.edge = np.array([e for e, _ in steps], dtype=np.int64)
        self.dir = np.array([d for _, d in steps], dtype=np.int64)
        self.len = np.array([net.edge_length(e) for e, _ in steps], dtype=float)
        entry_first = -behind
        before: FloatArray = np.cumsum(self.len[: self.n_prefix][::-1])[::-1]
        b0 = np.empty(len(steps))
        b0[: self.n_prefix] = entry_first - np.asarray(before, dtype=float)
        b0[self.n_prefix :] = entry_first + np.concatenate(
            ([0.0], np.cumsum(self.len[self.n_prefix : -1]))
        )
        self.b0 = b0
        self.b1 = b0 + self.len
        self.tunnel = np.array([net.edges[e].tunnel for e, _ in steps], dtype=bool)
        self.node_out = np.array(
            [net.edges[e].end_node if d == 1 else net.edges[e].start_node for e, d in steps],
            dtype=np.int64,
        )
        # polyline of the whole extended track
        xs: list[FloatArray] = []
        ys: list[FloatArray] = []
        ds: list[FloatArray] = []
        for k, (e, d) in enumerate(steps):
            xy = coords.get(e)
            if xy is None:
                xy = shapely.get_coordinates(net.edges[e].geometry).astype(float)
                coords[e] = xy
            seg = np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1]))
            cum = np.concatenate(([0.0], np.cumsum(seg)))
            scale = self.len[k] / cum[-1] if cum[-1] > 0 else 1.0
            cum = cum * scale
            if d == 1:
                px, py, pd = xy[:, 0], xy[:, 1], b0[k] + cum
            else:
                px, py, pd = xy[::-1, 0], xy[::-1, 1], b0[k] + (self.len[k] - cum[::-1])
            if k:
                px, py, pd = px[1:], py[1:], pd[1:]
            xs.append(px)
            ys.append(py)
            ds.append(pd)
        x = np.concatenate(xs)
        y = np.concatenate(ys)
        dist = np.concatenate(ds)
        if have < lead_in_m:  # dead end behind the start: extend straight backwards
            j = 1
            while j < len(x) - 1 and math.hypot(x[j] - x[0], y[j] - y[0]) < 1e-6:
                j += 1
            ux, uy = x[j] - x[0], y[j] - y[0]
            norm = math.hypot(ux, uy) or 1.0
            extra = lead_in_m - have + 1.0
            x = np.concatenate(([x[0] - ux / norm * extra], x))
            y = np.concatenate(([y[0] - uy / norm * extra], y))
            dist = np.concatenate(([dist[0] - extra], dist))
        # make distances strictly increasing for np.interp
        keep = np.concatenate(([True], np.diff(dist) > 1e-9))
        self.px, self.py, self.pd = x[keep], y[keep], dist[keep]
        sub = np.unique(np.concatenate((np.arange(0, len(self.pd), 25), [len(self.pd) - 1])))
        self.conv_d = self.pd[sub]
        self.conv_deg = net.frame.grid_north_azimuth_deg(self.px[sub], self.py[sub])

    def locate(self, s: FloatArray) -> tuple[IntArray, IntArray, FloatArray]:
        """Step index, edge id and offset of route distances (clamped to the track)."""
        k = np.clip(np.searchsorted(self.b0, s, side="right") - 1, 0, len(self.b0) - 1)
        rel = s - self.b0[k]
        off = np.clip(np.where(self.dir[k] > 0, rel, self.len[k] - rel), 0.0, self.len[k])
        return k, self.edge[k], off

    def xy(self, s: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Local (x, y) of route distances, metres."""
        return np.interp(s, self.pd, self.px), np.interp(s, self.pd, self.py)

    def grid_heading_rad(self, s: FloatArray, half_m: float = 1.0) -> FloatArray:
        """Heading from grid north (radians, clockwise) of the chord around ``s``.

        Near the ends of the track the chord is moved inwards so it keeps its length.
        """
        lo = self.pd[0] + half_m
        hi = self.pd[-1] - half_m
        s = np.clip(s, lo, hi) if lo < hi else s
        x0, y0 = self.xy(s - half_m)
        x1, y1 = self.xy(s + half_m)
        return np.arctan2(x1 - x0, y1 - y0)

    def convergence_deg(self, s: FloatArray) -> FloatArray:
        """True azimuth of grid north at route distances, degrees (grid heading + this = course)."""
        return np.asarray(np.interp(s, self.conv_d, self.conv_deg), dtype=float)


def curve_radius(track: Track, grid: FloatArray) -> FloatArray:
    """Estimated track radius at route distances (see the module notes).

    Parameters
    ----------
    track : Track
    grid : ndarray
        Route distances, metres.

    Returns
    -------
    ndarray
        Radius, metres, at least 1 m; 1e9 m on straight track.
    """
    h = _CHORD_HALF_M
    w = _CURVE_HALF_M
    th_a = track.grid_heading_rad(grid - w, h)
    th_b = track.grid_heading_rad(grid + w, h)
    turn = np.abs((th_b - th_a + np.pi) % (2 * np.pi) - np.pi)
    curvature = turn / (2.0 * w)
    with np.errstate(divide="ignore"):
        radius = np.where(curvature > 1e-9, 1.0 / np.maximum(curvature, 1e-9), 1e9)
    return np.maximum(radius, _MIN_RADIUS_M)
