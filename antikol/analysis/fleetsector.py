"""The paper's sector rule for every vehicle of a control room at one time.

A control room assesses each of its vehicles at every time. The sector rule's hits of all
of them come from one array evaluation (:meth:`SectorRule.hit_pairs`), their closing
speeds from one more (:func:`pair_closing_speeds`); without a map, every vehicle's
assessment is then built at the first question of the time, so that each further
``assess()`` is a look-up.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from antikol.analysis.assessment import Assessment, assessment_of
from antikol.analysis.sector import (
    HitClosing,
    SectorHit,
    SectorRule,
    course_array,
    latitudes_longitudes,
    pair_closing_speeds,
)
from antikol.analysis.threats import sector_threat
from antikol.report import VehicleReport

__all__ = ["FleetSector", "fleet_sector", "sector_assessments"]


class FleetSector(NamedTuple):
    """The sector rule's hits of every vehicle of one time."""

    #: What the hits were computed for (the analyser's time and table version).
    key: object
    #: Each vehicle's hits, nearest first (vehicles without hits are absent).
    hits: dict[str, list[SectorHit]]
    #: The closing speed of each hit, by (own id, other id).
    closing: dict[tuple[str, str], HitClosing]


def fleet_sector(
    rule: SectorRule,
    reports: Sequence[VehicleReport],
    courses: Sequence[float | None],
    *,
    now: float,
    expiry_s: float,
    key: object = None,
    velocity_courses: Sequence[float] | None = None,
) -> FleetSector:
    """Every vehicle's sector hits and their closing speeds, in array calls.

    Parameters
    ----------
    rule : SectorRule
    reports : sequence of VehicleReport
        The newest report of every vehicle.
    courses : sequence of float or None
        The course each vehicle's sector is centred on, degrees (None: no hits of its own;
        the closing speed uses it, else the reported course).
    now : float
        The time of the assessments, s: reports older than ``expiry_s`` are not hit.
    expiry_s : float
        s.
    key : object
        Stored in the result (what it was computed for).
    velocity_courses : sequence of float, optional
        The course of each vehicle's velocity in the closing speeds, degrees (default:
        the reported ones; :meth:`~antikol.analysis.coursekeeper.CourseKeeper.reported_course`
        gives them as the course check takes them).

    Returns
    -------
    FleetSector
        The hits of :meth:`SectorRule.evaluate_all` and the closing speeds of
        :func:`~antikol.analysis.sector.closing_speeds`, the same numbers.
    """
    n = len(reports)
    lat, lon = latitudes_longitudes(reports)
    t = np.fromiter((r.t for r in reports), dtype=float, count=n)
    course = course_array(courses)
    pairs = rule.hit_pairs(lat, lon, course, now - t <= expiry_s)
    hits: dict[str, list[SectorHit]] = {}
    closing: dict[tuple[str, str], HitClosing] = {}
    if not len(pairs.own):
        return FleetSector(key, hits, closing)
    speed = np.fromiter((r.speed_mps for r in reports), dtype=float, count=n)
    if velocity_courses is None:
        reported = np.fromiter((r.course_deg for r in reports), dtype=float, count=n)
    else:
        reported = np.asarray(velocity_courses, dtype=float)
    speeds = pair_closing_speeds(pairs, speed, course, reported)
    for i, j, d, b, c in zip(
        pairs.own.tolist(),
        pairs.other.tolist(),
        pairs.distance_m.tolist(),
        pairs.bearing_deg.tolist(),
        speeds.tolist(),
        strict=True,
    ):
        own, other = reports[i], reports[j]
        hit = SectorHit(other.vehicle_id, d, b)
        found = hits.get(own.vehicle_id)
        if found is None:
            hits[own.vehicle_id] = [hit]
        else:
            found.append(hit)
        closing[(own.vehicle_id, other.vehicle_id)] = HitClosing(own, other, hit, c)
    return FleetSector(key, hits, closing)


def sector_assessments(
    rule: SectorRule, fleet: FleetSector, vehicle_ids: Sequence[str], now: float
) -> dict[str, Assessment]:
    """The sector rule's assessment of every vehicle (a control room without a map).

    Parameters
    ----------
    rule : SectorRule
    fleet : FleetSector
        The hits of the time (:func:`fleet_sector`).
    vehicle_ids : sequence of str
        The vehicles to assess.
    now : float
        Time of the assessments, s.

    Returns
    -------
    dict
        Vehicle id to :class:`Assessment` (method ``sector``).
    """
    out: dict[str, Assessment] = {}
    for vid in vehicle_ids:
        own_hits = fleet.hits.get(vid)
        threats = (
            [
                sector_threat(rule, h, fleet.closing[(vid, h.vehicle_id)].closing_speed_mps)
                for h in own_hits
            ]
            if own_hits
            else []
        )
        out[vid] = assessment_of(vid, now, threats, [], "sector")
    return out
