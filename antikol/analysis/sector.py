"""The 2008 paper's sector rule: a circular sector ahead of the own vehicle.

A vehicle is a threat when its planar distance (formula 8) is below ``d_col_m`` and the
bearing to it (formula 9) lies within ``half_angle_deg`` of the own course. The nearest such
vehicle is the primary threat. This rule is also the fallback of the track-aware analyser
whenever no map is loaded or a vehicle cannot be matched to a track.

Standing still: a GPS course over ground is noise when the vehicle barely moves, so the
course used by the rule is the last course reported at or above ``min_speed_for_course_mps``
(:class:`~antikol.analysis.coursekeeper.CourseKeeper`, which also checks it against the
vehicle's own run). A vehicle that has never moved fast enough has no known course and
raises no sector alarm of its own: it cannot run into anything while it stands, and the
vehicles approaching it see it in their own sectors.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from antikol.analysis.geometry import (
    PAPER_SPHERE_RADIUS_M,
    angle_difference_deg,
    closing_speed_mps,
    dist_km,
    latdist_km,
    londist_km,
    paper_offsets,
    sight_rad,
)
from antikol.errors import InvalidArgumentError
from antikol.report import VehicleReport
from antikol.thresholds import COURSE_MIN_SPEED_MPS, D_COL_M, HALF_ANGLE_DEG

__all__ = [
    "HitClosing",
    "SectorHit",
    "SectorPairs",
    "SectorRule",
    "closing_speeds",
    "course_array",
    "hit_closing_speed",
    "latitudes_longitudes",
    "pair_closing_speeds",
]


@dataclass(frozen=True, slots=True)
class SectorRule:
    """The paper's sensitivity sector.

    Parameters
    ----------
    d_col_m : float
        Collision threshold distance (radius of the sector), metres. Paper: 300 m.
    half_angle_deg : float
        Half-angle of the sector around the own course, degrees. Paper: 15 degrees.
    min_speed_for_course_mps : float
        Below this speed the reported course is not trusted and the last trusted one is
        kept (see :class:`CourseKeeper`), m/s.
    """

    d_col_m: float = D_COL_M
    half_angle_deg: float = HALF_ANGLE_DEG
    min_speed_for_course_mps: float = COURSE_MIN_SPEED_MPS

    def __post_init__(self) -> None:
        if not np.isfinite(self.d_col_m) or self.d_col_m <= 0:
            raise InvalidArgumentError("d_col_m", self.d_col_m, "must be a positive distance, m")
        if not 0 < self.half_angle_deg <= 180:
            raise InvalidArgumentError("half_angle_deg", self.half_angle_deg, "must be in (0, 180]")
        if self.min_speed_for_course_mps < 0:
            raise InvalidArgumentError(
                "min_speed_for_course_mps", self.min_speed_for_course_mps, "must be >= 0 m/s"
            )

    def inside(
        self, distance_m: npt.ArrayLike, bearing_deg: npt.ArrayLike, course_deg: float
    ) -> npt.NDArray[np.bool_]:
        """Whether targets at given distances and bearings lie in the sector.

        Parameters
        ----------
        distance_m : array_like
            Planar distances to the targets, metres.
        bearing_deg : array_like
            Bearings to the targets, degrees clockwise from north.
        course_deg : float
            Own course, degrees clockwise from north.

        Returns
        -------
        ndarray of bool
        """
        off = np.abs(angle_difference_deg(np.asarray(bearing_deg, dtype=float), course_deg))
        return np.asarray(
            (np.asarray(distance_m) < self.d_col_m) & (off <= self.half_angle_deg), dtype=bool
        )

    def evaluate(
        self, own: VehicleReport, others: list[VehicleReport], *, course_deg: float | None = None
    ) -> list[SectorHit]:
        """Every other vehicle inside the own sector, nearest first.

        Parameters
        ----------
        own : VehicleReport
            The own vehicle's current report.
        others : list of VehicleReport
            Reports of the other vehicles.
        course_deg : float, optional
            Course to use instead of ``own.course_deg`` (e.g. from :class:`CourseKeeper`).
            ``None`` uses the report's course.

        Returns
        -------
        list of SectorHit
            One entry per vehicle in the sector, sorted by distance.
        """
        if not others:
            return []
        course = own.course_deg if course_deg is None else course_deg
        distance, bearing = self.measure(own, others)
        mask = self.inside(distance, bearing, course)
        hits = [
            SectorHit(others[i].vehicle_id, float(distance[i]), float(bearing[i]))
            for i in np.flatnonzero(mask)
        ]
        hits.sort(key=lambda h: h.distance_m)
        return hits

    def evaluate_all(
        self,
        reports: Sequence[VehicleReport],
        courses: Sequence[float | None],
        *,
        targets: npt.ArrayLike | None = None,
    ) -> list[list[SectorHit]]:
        """Every vehicle's sector at once (a control room's cycle).

        The same hits as :meth:`evaluate` for each vehicle against all the others, found
        through a k-d tree of the positions so that the cost grows with the pairs within
        ``d_col_m``, not with the square of the fleet.

        Parameters
        ----------
        reports : sequence of VehicleReport
            The current report of every vehicle.
        courses : sequence of float or None
            The course to use for each (degrees); None: no known course, no hits.
        targets : array_like of bool, optional
            Which reports may be hit (default: all), e.g. not those too old to be seen.

        Returns
        -------
        list of list of SectorHit
            For each report the others in its sector, nearest first (equal distances in
            the order of ``reports``).

        Examples
        --------
        >>> from antikol.report import VehicleReport
        >>> fleet = [VehicleReport("A", 0.0, 50.06, 19.930, 8.0, 90.0),
        ...          VehicleReport("B", 0.0, 50.06, 19.932, 8.0, 90.0)]
        >>> hits = SectorRule().evaluate_all(fleet, [90.0, 90.0])
        >>> [[h.vehicle_id for h in own] for own in hits]
        [['B'], []]
        """
        n = len(reports)
        out: list[list[SectorHit]] = [[] for _ in range(n)]
        if n < 2:
            return out
        lat, lon = latitudes_longitudes(reports)
        seen = np.ones(n, dtype=bool) if targets is None else np.asarray(targets, dtype=bool)
        pairs = self.hit_pairs(lat, lon, course_array(courses), seen)
        for i, j, d, b in zip(
            pairs.own.tolist(),
            pairs.other.tolist(),
            pairs.distance_m.tolist(),
            pairs.bearing_deg.tolist(),
            strict=True,
        ):
            out[i].append(SectorHit(reports[j].vehicle_id, d, b))
        return out

    def hit_pairs(
        self,
        lat_deg: npt.NDArray[np.float64],
        lon_deg: npt.NDArray[np.float64],
        course_deg: npt.NDArray[np.float64],
        targets: npt.NDArray[np.bool_],
    ) -> SectorPairs:
        """Every (own, other) pair of a fleet inside the own sector, as arrays.

        The array form of :meth:`evaluate_all`: candidates from a k-d tree of the
        positions, then formulas (4)-(9) pair by pair.

        Parameters
        ----------
        lat_deg, lon_deg : ndarray of float
            Positions of the fleet, degrees.
        course_deg : ndarray of float
            The course each vehicle's sector is centred on, degrees; NaN: no course, no
            hits of its own.
        targets : ndarray of bool
            Which vehicles may be hit.

        Returns
        -------
        SectorPairs
            Sorted by own vehicle, then distance, then other vehicle.
        """
        n = len(lat_deg)
        if n < 2:
            empty = np.zeros(0, dtype=np.intp)
            return SectorPairs(empty, empty, np.zeros(0), np.zeros(0))
        # candidates: chords on the paper's sphere, with room for the planar formulas'
        # difference from it (under 1 % at the sector's range)
        phi, lam = np.radians(lat_deg), np.radians(lon_deg)
        xyz = PAPER_SPHERE_RADIUS_M * np.column_stack(
            (np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi))
        )
        pairs = cKDTree(xyz).query_pairs(1.05 * self.d_col_m + 10.0, output_type="ndarray")
        own = np.concatenate([pairs[:, 0], pairs[:, 1]])
        other = np.concatenate([pairs[:, 1], pairs[:, 0]])
        keep = ~np.isnan(course_deg[own]) & targets[other]
        own, other = own[keep], other[keep]
        # formulas (4)-(9) pair by pair, as paper_offsets computes them from one vehicle
        lat_d = latdist_km(lat_deg[own], lat_deg[other])
        lon_d = londist_km(lat_deg[own], lon_deg[own], lon_deg[other])
        distance = np.asarray(dist_km(lat_d, lon_d)) * 1000.0
        bearing = np.degrees(np.asarray(sight_rad(lat_d, lon_d))) % 360.0
        off = np.abs(np.asarray(angle_difference_deg(bearing, course_deg[own])))
        hit = np.flatnonzero((distance < self.d_col_m) & (off <= self.half_angle_deg))
        own, other, distance, bearing = own[hit], other[hit], distance[hit], bearing[hit]
        order = np.lexsort((other, distance, own))
        return SectorPairs(own[order], other[order], distance[order], bearing[order])

    @staticmethod
    def measure(
        own: VehicleReport, others: list[VehicleReport]
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Planar distances (m) and bearings (deg) from the own vehicle, formulas (4)-(9)."""
        lat, lon = latitudes_longitudes(others)
        return paper_offsets(own.lat, own.lon, lat, lon)


@dataclass(frozen=True, slots=True)
class SectorHit:
    """A vehicle inside the sector: its id, planar distance (m) and bearing (deg)."""

    vehicle_id: str
    distance_m: float
    bearing_deg: float


class SectorPairs(NamedTuple):
    """The hits of a fleet's sectors as arrays, one row per (own, other) pair."""

    #: Index of the own vehicle of each hit.
    own: npt.NDArray[np.intp]
    #: Index of the vehicle inside its sector.
    other: npt.NDArray[np.intp]
    #: Planar distance, formula (8), metres.
    distance_m: npt.NDArray[np.float64]
    #: Bearing from the own vehicle, formula (9), degrees clockwise from north.
    bearing_deg: npt.NDArray[np.float64]


class HitClosing(NamedTuple):
    """The closing speed of one sector hit, with the reports it was computed from."""

    own: VehicleReport
    other: VehicleReport
    hit: SectorHit
    closing_speed_mps: float


def hit_closing_speed(
    own: VehicleReport,
    course_deg: float | None,
    other: VehicleReport,
    hit: SectorHit,
    *,
    other_course_deg: float | None = None,
) -> float:
    """The closing speed of one sector hit, m/s (positive when closing).

    The other vehicle's offset from the hit's distance and bearing; the own vehicle at
    ``course_deg`` (its kept course, degrees; None: the reported one), the other at
    ``other_course_deg`` (degrees; None: its reported course).
    """
    bearing = math.radians(hit.bearing_deg)
    return float(
        closing_speed_mps(
            hit.distance_m * math.sin(bearing),
            hit.distance_m * math.cos(bearing),
            own.speed_mps,
            own.course_deg if course_deg is None else course_deg,
            other.speed_mps,
            other.course_deg if other_course_deg is None else other_course_deg,
        )
    )


def closing_speeds(
    reports: Sequence[VehicleReport],
    courses: Sequence[float | None],
    hits: Sequence[Sequence[SectorHit]],
) -> dict[tuple[str, str], HitClosing]:
    """The closing speed of every hit of a cycle in one array call.

    The numbers are those of :func:`hit_closing_speed` called hit by hit.

    Parameters
    ----------
    reports : sequence of VehicleReport
        The reports the hits were found among.
    courses : sequence of float or None
        The course used for each report, degrees (None: no hits of its own).
    hits : sequence of sequence of SectorHit
        Each report's hits (:meth:`SectorRule.evaluate_all`).

    Returns
    -------
    dict
        ``(own id, other id)`` to :class:`HitClosing` (closing speed in m/s, positive when
        closing).
    """
    index = {r.vehicle_id: k for k, r in enumerate(reports)}
    rows = [(i, index[h.vehicle_id], h) for i, own in enumerate(hits) for h in own]
    if not rows:
        return {}
    pairs = SectorPairs(
        np.array([i for i, _, _ in rows], dtype=np.intp),
        np.array([j for _, j, _ in rows], dtype=np.intp),
        np.array([h.distance_m for _, _, h in rows], dtype=float),
        np.array([h.bearing_deg for _, _, h in rows], dtype=float),
    )
    speed = np.fromiter((r.speed_mps for r in reports), dtype=float, count=len(reports))
    reported = np.fromiter((r.course_deg for r in reports), dtype=float, count=len(reports))
    closing = pair_closing_speeds(pairs, speed, course_array(courses), reported)
    return {
        (reports[i].vehicle_id, h.vehicle_id): HitClosing(reports[i], reports[j], h, c)
        for (i, j, h), c in zip(rows, closing.tolist(), strict=True)
    }


def course_array(courses: Sequence[float | None]) -> npt.NDArray[np.float64]:
    """Courses as an array, degrees; NaN where a vehicle has none."""
    return np.array([np.nan if c is None else c for c in courses], dtype=float)


def latitudes_longitudes(
    reports: Sequence[VehicleReport],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The reports' latitudes and longitudes as two arrays, degrees."""
    n = len(reports)
    lat = np.fromiter((r.lat for r in reports), dtype=float, count=n)
    lon = np.fromiter((r.lon for r in reports), dtype=float, count=n)
    return lat, lon


def pair_closing_speeds(
    pairs: SectorPairs,
    speed_mps: npt.NDArray[np.float64],
    course_deg: npt.NDArray[np.float64],
    reported_course_deg: npt.NDArray[np.float64],
) -> npt.NDArray[np.float64]:
    """The closing speed of every hit of a fleet's sectors, m/s (positive when closing).

    The numbers of :func:`hit_closing_speed` called hit by hit.

    Parameters
    ----------
    pairs : SectorPairs
        The hits (:meth:`SectorRule.hit_pairs`).
    speed_mps : ndarray of float
        Each vehicle's reported speed, m/s.
    course_deg : ndarray of float
        The course each vehicle's sector used, degrees (NaN: the reported one).
    reported_course_deg : ndarray of float
        Each vehicle's reported course, degrees.

    Returns
    -------
    ndarray of float
        One closing speed per row of ``pairs``, m/s.
    """
    own_course = np.where(np.isnan(course_deg), reported_course_deg, course_deg)[pairs.own]
    bearing = np.radians(pairs.bearing_deg)
    closing = closing_speed_mps(
        pairs.distance_m * np.sin(bearing),
        pairs.distance_m * np.cos(bearing),
        speed_mps[pairs.own],  # type: ignore[arg-type]  # arrays: one own vehicle per hit
        own_course,  # type: ignore[arg-type]
        speed_mps[pairs.other],
        reported_course_deg[pairs.other],
    )
    return np.asarray(closing, dtype=float).reshape(-1)
