"""Helpers that turn planar test trajectories into vehicle reports."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np

from antikol import VehicleReport
from trackmap import LocalFrame

#: A frame centred in Gdańsk, where the paper's field tests were driven.
GDANSK = LocalFrame.centred_on(18.6359, 54.3902)


def heading_deg(dx: float, dy: float) -> float:
    """Compass heading of a planar displacement, degrees clockwise from north."""
    return math.degrees(math.atan2(dx, dy)) % 360.0


def reports_from_xy(
    vehicle_id: str,
    t: Sequence[float],
    x: Sequence[float],
    y: Sequence[float],
    *,
    frame: LocalFrame = GDANSK,
    **extra: object,
) -> list[VehicleReport]:
    """Reports with speed and course from finite differences of a sampled path."""
    t_a, x_a, y_a = (np.asarray(v, dtype=float) for v in (t, x, y))
    lon, lat = frame.to_lonlat(x_a, y_a)
    vx = np.gradient(x_a, t_a)
    vy = np.gradient(y_a, t_a)
    out = []
    for i in range(len(t_a)):
        speed = float(math.hypot(vx[i], vy[i]))
        out.append(
            VehicleReport(
                vehicle_id=vehicle_id,
                t=float(t_a[i]),
                lat=float(lat[i]),
                lon=float(lon[i]),
                speed_mps=speed,
                course_deg=heading_deg(vx[i], vy[i]),
                **extra,  # type: ignore[arg-type]
            )
        )
    return out


def interleave(*streams: Iterable[VehicleReport]) -> list[VehicleReport]:
    """All reports of several vehicles in time order (stable for equal times)."""
    merged = [r for s in streams for r in s]
    merged.sort(key=lambda r: r.t)
    return merged


def reports_along(
    vehicle_id: str,
    line_xy: Sequence[tuple[float, float]],
    *,
    start_m: float,
    speed_mps: float,
    t: Sequence[float],
    frame: LocalFrame,
    reverse: bool = False,
    **extra: object,
) -> list[VehicleReport]:
    """Reports of a vehicle driving along a polyline at constant speed (no noise).

    ``start_m`` is the distance along the line at ``t[0]``; with ``reverse`` the vehicle
    drives from the line's end towards its start, ``start_m`` counted from the end.
    """
    import shapely

    line = shapely.LineString(line_xy)
    if reverse:
        line = shapely.LineString(list(line.coords)[::-1])
    out = []
    t0 = float(t[0])
    for ti in t:
        s = min(start_m + speed_mps * (float(ti) - t0), line.length)
        p = line.interpolate(s)
        q = line.interpolate(min(s + 0.5, line.length))
        r = line.interpolate(max(s - 0.5, 0.0))
        lon, lat = frame.to_lonlat(p.x, p.y)
        out.append(
            VehicleReport(
                vehicle_id=vehicle_id,
                t=float(ti),
                lat=float(lat),
                lon=float(lon),
                speed_mps=speed_mps if s < line.length else 0.0,
                course_deg=heading_deg(q.x - r.x, q.y - r.y),
                **extra,  # type: ignore[arg-type]
            )
        )
    return out
