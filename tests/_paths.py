"""Helpers that turn planar test trajectories into vehicle reports."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np

from antikol import VehicleReport
from trackmap.crs import LocalFrame

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
