"""Helpers that turn simulated reports into operator feed records (GTFS-realtime)."""

from __future__ import annotations

from typing import Any

from antikol import VehicleReport

#: The POSIX time of the simulations' t = 0: 2023-12-14 08:00:00 UTC.
EPOCH = 1_702_540_800.0


def gtfs_vehicle(r: VehicleReport) -> dict[str, Any]:
    """The plainest GTFS-realtime vehicle position of a report (no odometer, no route)."""
    return {
        "id": r.vehicle_id,
        "timestamp": int(EPOCH + r.t),
        "lat": r.lat,
        "lon": r.lon,
        "speed": r.speed_mps,
        "bearing": r.course_deg,
    }
