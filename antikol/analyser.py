"""The analyser: one object that takes reports and answers "what threatens vehicle X?".

Without a map the analyser runs the 2008 paper's sector rule for every pair (every threat
has ``method='sector'`` and level ``warning``, the paper's lamp).
"""

from __future__ import annotations

import logging
from typing import Any, Literal

import numpy as np

from antikol.assessment import Assessment, Threat, highest_level, sort_threats
from antikol.errors import UnknownVehicleError
from antikol.geometry import closing_speed_mps
from antikol.report import VehicleReport
from antikol.sector import CourseKeeper, SectorRule
from antikol.table import TableUpdate, VehicleTable

logger = logging.getLogger(__name__)


class Analyser:
    """Collision-warning analyser for one own vehicle or a whole fleet.

    Parameters
    ----------
    track_map : trackmap.TrackMap, optional
        The rail network. ``None`` runs the paper's sector rule throughout.
    sector : SectorRule, optional
        The sector rule used without a map and as fallback.
    own_id : str, optional
        On-board use: the own vehicle. It is the reference of the vehicle table's
        full-table policy. ``None`` (control-room use) lets :meth:`assess` be asked for any
        vehicle.
    capacity : int, None or "auto"
        Vehicle table capacity (other vehicles); ``None`` is unbounded. ``"auto"``: 32 (the
        paper) when ``own_id`` is given, unbounded otherwise.
    expiry_s : float
        Silence after which a vehicle is dropped, s (paper: ~10 s).
    """

    def __init__(
        self,
        track_map: Any | None = None,
        *,
        sector: SectorRule | None = None,
        own_id: str | None = None,
        capacity: int | Literal["auto"] | None = "auto",
        expiry_s: float = 10.0,
    ) -> None:
        self.track_map = track_map
        self.sector = sector if sector is not None else SectorRule()
        self.own_id = own_id
        table_capacity = (32 if own_id is not None else None) if capacity == "auto" else capacity
        self.table = VehicleTable(capacity=table_capacity, expiry_s=expiry_s, own_id=own_id)
        self.courses = CourseKeeper(min_speed_mps=self.sector.min_speed_for_course_mps)

    # -- input ---------------------------------------------------------------------------
    def update(self, report: VehicleReport) -> TableUpdate:
        """Feed one report (own or other vehicle).

        Parameters
        ----------
        report : VehicleReport

        Returns
        -------
        TableUpdate
            What the vehicle table did with it.
        """
        result = self.table.update(report)
        for vid in result.expired:
            self._forget(vid)
        if result.evicted is not None:
            self._forget(result.evicted)
        if result.accepted:
            self.courses.update(report)
        return result

    def _forget(self, vehicle_id: str) -> None:
        self.courses.forget(vehicle_id)

    # -- output --------------------------------------------------------------------------
    def assess(self, own_id: str | None = None, *, t: float | None = None) -> Assessment:
        """Assess the threats to one vehicle.

        Parameters
        ----------
        own_id : str, optional
            The vehicle to assess; defaults to the analyser's ``own_id``.
        t : float, optional
            Assessment time, s; vehicles silent for longer than the expiry are dropped
            first. Defaults to the newest report time.

        Returns
        -------
        Assessment

        Raises
        ------
        UnknownVehicleError
            No current report of ``own_id``.
        """
        vid = own_id if own_id is not None else self.own_id
        if vid is None:
            raise UnknownVehicleError("assess() needs an own_id (none was configured)")
        for gone in self.table.expire(t):
            self._forget(gone)
        own = self.table.get(vid)
        if own is None:
            raise UnknownVehicleError(f"no current report of vehicle {vid!r}")
        now = self.table.clock if t is None else float(t)
        others = self.table.others(vid)
        threats = self._sector_threats(own, others)
        ordered = sort_threats(threats)
        return Assessment(
            own_id=vid, t=now, level=highest_level(ordered), threats=ordered, method="sector"
        )

    def _sector_threats(self, own: VehicleReport, others: list[VehicleReport]) -> list[Threat]:
        course = self.courses.course(own.vehicle_id)
        if course is None or not others:
            return []
        hits = self.sector.evaluate(own, others, course_deg=course)
        if not hits:
            return []
        by_id = {o.vehicle_id: o for o in others}
        threats = []
        for hit in hits:
            other = by_id[hit.vehicle_id]
            bearing = np.radians(hit.bearing_deg)
            closing = float(
                closing_speed_mps(
                    hit.distance_m * np.sin(bearing),
                    hit.distance_m * np.cos(bearing),
                    own.speed_mps,
                    course,
                    other.speed_mps,
                    other.course_deg,
                )
            )
            threats.append(
                Threat(
                    vehicle_id=hit.vehicle_id,
                    kind="sector",
                    level="warning",
                    distance_m=hit.distance_m,
                    closing_speed_mps=closing,
                    ttc_s=hit.distance_m / closing if closing > 0 else None,
                    method="sector",
                    bearing_deg=hit.bearing_deg,
                    detail=f"within {self.sector.d_col_m:g} m and "
                    f"±{self.sector.half_angle_deg:g}° of own course",
                )
            )
        return threats
