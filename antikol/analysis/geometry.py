"""Planar and spherical geometry between two vehicles.

This module reproduces the 2008 paper's formulas exactly so that its field tests can be
replayed, and sets them beside a proper geodesic reference (``pyproj.Geod`` on WGS84).

The paper (Komkowski 2008) computes, for the own vehicle P1 and another vehicle P2:

* (4)  ``latdist = (lat1 - lat2) * 111.138``                 [km]
* (5)  ``parlen  = cos(lat1 * pi / 180) * 40041.48``          [km]
* (6)  ``odlmst  = parlen / 360``                             [km per degree of longitude]
* (7)  ``londist = (lon1 - lon2) * odlmst``                   [km]
* (8)  ``dist    = sqrt(latdist**2 + londist**2)``            [km]
* (9)  ``sight``: the bearing from P1 to P2, clockwise from north, by four cases of the
  signs of ``latdist`` and ``londist``.

``latdist`` is positive when P2 lies south of P1 and ``londist`` positive when P2 lies west,
which is why case (9) adds ``arcsin(latdist / dist)`` for an eastern P2 and subtracts it for
a western one.

The great-circle formulas (1)-(3) are implemented in their correct form:

* formula (1) as printed uses ``arcsin`` of the spherical law of cosines; the law gives the
  *cosine* of the central angle, so the correct inverse is ``arccos`` (``arcsin`` would
  return the complement, ~90 degrees for nearby points). We use ``arccos`` on a value
  clipped to [-1, 1].
* formula (3) follows the Aviation Formulary, which counts longitude positive to the west;
  the paper states that western longitudes are negative, so the longitude difference is
  taken as ``lon2 - lon1`` and the quadrant is resolved with ``atan2``.

Functions accept scalars or numpy arrays (broadcast together) and return numpy floats or
arrays. Degrees at the interface, radians only inside.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import numpy.typing as npt
from pyproj import Geod

__all__ = [
    "PAPER_EQUATOR_KM",
    "PAPER_KM_PER_DEG_LAT",
    "PAPER_M_PER_DEG_ARC",
    "PAPER_SPHERE_RADIUS_M",
    "ArrayLike",
    "PlanarOffset",
    "angle_difference_deg",
    "closing_speed_mps",
    "dist_km",
    "geodesic_inverse",
    "great_circle_course_deg",
    "great_circle_distance_m",
    "latdist_km",
    "londist_km",
    "odlmst_km_per_deg",
    "paper_offset",
    "paper_offsets",
    "paper_sphere",
    "parlen_km",
    "sight_rad",
    "velocity_en",
    "wgs84",
]

ArrayLike = float | npt.NDArray[np.float64]

#: Length of one degree of meridian arc used by the paper, km (formula 4).
PAPER_KM_PER_DEG_LAT = 111.138
#: Equator length used by the paper, km (formula 5).
PAPER_EQUATOR_KM = 40041.48
#: Metres per degree of great-circle arc used by the paper (formula 2).
PAPER_M_PER_DEG_ARC = 111138.0


def latdist_km(lat1_deg: ArrayLike, lat2_deg: ArrayLike) -> ArrayLike:
    """Meridional distance of formula (4), km; positive when P2 is south of P1.

    Parameters
    ----------
    lat1_deg, lat2_deg : float or ndarray
        Latitudes of P1 (own) and P2 (other), degrees.
    """
    return (np.asarray(lat1_deg, dtype=float) - lat2_deg) * PAPER_KM_PER_DEG_LAT


def parlen_km(lat1_deg: ArrayLike) -> ArrayLike:
    """Length of the parallel through P1, formula (5), km."""
    return np.cos(np.asarray(lat1_deg, dtype=float) * np.pi / 180.0) * PAPER_EQUATOR_KM


def odlmst_km_per_deg(lat1_deg: ArrayLike) -> ArrayLike:
    """Distance per degree of longitude on the parallel through P1, formula (6), km/deg."""
    return parlen_km(lat1_deg) / 360.0


def londist_km(lat1_deg: ArrayLike, lon1_deg: ArrayLike, lon2_deg: ArrayLike) -> ArrayLike:
    """Zonal distance along P1's parallel, formula (7), km; positive when P2 is west of P1."""
    return (np.asarray(lon1_deg, dtype=float) - lon2_deg) * odlmst_km_per_deg(lat1_deg)


def dist_km(latdist: ArrayLike, londist: ArrayLike) -> ArrayLike:
    """Planar distance of formula (8), km, from ``latdist`` and ``londist`` (km)."""
    return np.hypot(latdist, londist)


def sight_rad(latdist: ArrayLike, londist: ArrayLike) -> ArrayLike:
    """Bearing from P1 to P2 by the four cases of formula (9), radians in [0, 2*pi).

    Parameters
    ----------
    latdist, londist : float or ndarray
        Outputs of :func:`latdist_km` and :func:`londist_km` (any common length unit).

    Returns
    -------
    float or ndarray
        ``pi/2 + asin(latdist/dist)`` when P2 is east (``londist < 0``),
        ``3*pi/2 - asin(latdist/dist)`` when P2 is west (``londist > 0``),
        ``0`` due north or coincident (``londist == 0`` and ``latdist <= 0``) and
        ``pi`` due south (``londist == 0`` and ``latdist > 0``).
    """
    lat_d = np.asarray(latdist, dtype=float)
    lon_d = np.asarray(londist, dtype=float)
    d = np.hypot(lat_d, lon_d)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.clip(np.where(d > 0.0, lat_d / np.where(d > 0.0, d, 1.0), 0.0), -1.0, 1.0)
    asin = np.arcsin(ratio)
    result = np.where(
        lon_d < 0.0,
        np.pi / 2.0 + asin,
        np.where(lon_d > 0.0, 1.5 * np.pi - asin, np.where(lat_d <= 0.0, 0.0, np.pi)),
    )
    return result[()] if result.ndim == 0 else result


@dataclass(frozen=True, slots=True)
class PlanarOffset:
    """Result of the paper's planar computation from P1 to P2.

    Attributes
    ----------
    north_m, east_m : float
        Position of P2 relative to P1, metres (north and east positive).
    distance_m : float
        Planar distance, formula (8), metres.
    bearing_deg : float
        Bearing from P1 to P2, formula (9), degrees clockwise from north in [0, 360).
    """

    north_m: float
    east_m: float
    distance_m: float
    bearing_deg: float


def paper_offset(
    lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float
) -> PlanarOffset:
    """Planar offset, distance and bearing from P1 to P2 by formulas (4)-(9).

    Parameters
    ----------
    lat1_deg, lon1_deg : float
        Own position P1, degrees.
    lat2_deg, lon2_deg : float
        Other vehicle's position P2, degrees.

    Returns
    -------
    PlanarOffset
    """
    lat_d = float(latdist_km(lat1_deg, lat2_deg))
    lon_d = float(londist_km(lat1_deg, lon1_deg, lon2_deg))
    return PlanarOffset(
        north_m=-lat_d * 1000.0,
        east_m=-lon_d * 1000.0,
        distance_m=float(dist_km(lat_d, lon_d)) * 1000.0,
        bearing_deg=float(np.degrees(sight_rad(lat_d, lon_d))) % 360.0,
    )


def paper_offsets(
    lat1_deg: float, lon1_deg: float, lat2_deg: ArrayLike, lon2_deg: ArrayLike
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Vectorised formulas (4)-(9) from one P1 to many P2.

    Parameters
    ----------
    lat1_deg, lon1_deg : float
        Own position, degrees.
    lat2_deg, lon2_deg : ndarray
        Other positions, degrees.

    Returns
    -------
    distance_m, bearing_deg : ndarray
        Planar distances (m) and bearings (degrees clockwise from north, [0, 360)).
    """
    lat_d = np.atleast_1d(latdist_km(lat1_deg, np.asarray(lat2_deg, dtype=float)))
    lon_d = np.atleast_1d(londist_km(lat1_deg, lon1_deg, np.asarray(lon2_deg, dtype=float)))
    distance_m = np.hypot(lat_d, lon_d) * 1000.0
    bearing_deg = np.degrees(np.atleast_1d(sight_rad(lat_d, lon_d))) % 360.0
    return distance_m, bearing_deg


def great_circle_distance_m(
    lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike
) -> ArrayLike:
    """Great-circle distance of formulas (1)-(2), metres, on the paper's sphere.

    Formula (1) is the spherical law of cosines solved with ``arccos`` (the paper prints
    ``arcsin``, see the module docstring); formula (2) converts the central angle with
    111138 m per degree. Double precision keeps ``arccos`` accurate to a few centimetres
    at the paper's ranges (>= 1 m).
    """
    lat1, lon1, lat2, lon2 = (
        np.radians(np.asarray(x, dtype=float)) for x in (lat1_deg, lon1_deg, lat2_deg, lon2_deg)
    )
    cos_arc = np.sin(lat1) * np.sin(lat2) + np.cos(lat1) * np.cos(lat2) * np.cos(lon1 - lon2)
    arc = np.arccos(np.clip(cos_arc, -1.0, 1.0))
    result = np.degrees(arc) * PAPER_M_PER_DEG_ARC
    return result[()] if np.ndim(result) == 0 else result


def great_circle_course_deg(
    lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike
) -> ArrayLike:
    """Initial great-circle course from P1 to P2, formula (3), degrees in [0, 360).

    East-positive longitudes (the paper's convention); the quadrant is resolved with
    ``atan2``. From the north pole every course is 180 degrees and from the south pole
    0 degrees, the limits formula (3) lists as special cases.
    """
    lat1, lon1, lat2, lon2 = (
        np.radians(np.asarray(x, dtype=float)) for x in (lat1_deg, lon1_deg, lat2_deg, lon2_deg)
    )
    dlon = lon2 - lon1
    y = np.sin(dlon) * np.cos(lat2)
    x = np.cos(lat1) * np.sin(lat2) - np.sin(lat1) * np.cos(lat2) * np.cos(dlon)
    course = np.degrees(np.arctan2(y, x)) % 360.0
    pole = np.cos(lat1) < 1e-12
    course = np.where(pole & (lat1 > 0), 180.0, np.where(pole & (lat1 < 0), 0.0, course))
    return course[()] if np.ndim(course) == 0 else course


#: Radius of the sphere implied by the paper's 111138 m per degree (formula 2), metres.
PAPER_SPHERE_RADIUS_M = PAPER_M_PER_DEG_ARC * 180.0 / np.pi


@lru_cache(maxsize=1)
def paper_sphere() -> Geod:
    """``pyproj.Geod`` on the paper's sphere (radius from 111138 m per degree)."""
    return Geod(a=PAPER_SPHERE_RADIUS_M, b=PAPER_SPHERE_RADIUS_M)


@lru_cache(maxsize=1)
def wgs84() -> Geod:
    """The WGS84 ellipsoid geodesic solver (cached ``pyproj.Geod``)."""
    return Geod(ellps="WGS84")


def geodesic_inverse(
    lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike
) -> tuple[ArrayLike, ArrayLike]:
    """Reference distance (m) and initial azimuth (degrees, [0, 360)) on WGS84.

    Uses ``pyproj.Geod.inv`` (Karney's algorithm), the reference for the paper's formulas.
    """
    az12, _az21, dist = wgs84().inv(lon1_deg, lat1_deg, lon2_deg, lat2_deg)
    return dist, np.mod(az12, 360.0)


def velocity_en(speed_mps: ArrayLike, course_deg: ArrayLike) -> tuple[ArrayLike, ArrayLike]:
    """East and north velocity components (m/s) from speed (m/s) and course (deg)."""
    course = np.radians(np.asarray(course_deg, dtype=float))
    return speed_mps * np.sin(course), speed_mps * np.cos(course)


def closing_speed_mps(
    east_m: ArrayLike,
    north_m: ArrayLike,
    own_speed_mps: float,
    own_course_deg: float,
    other_speed_mps: ArrayLike,
    other_course_deg: ArrayLike,
) -> ArrayLike:
    """Rate at which the distance between two vehicles shrinks, m/s.

    Parameters
    ----------
    east_m, north_m : float or ndarray
        Position of the other vehicle relative to the own one, metres.
    own_speed_mps, own_course_deg : float
        Own speed (m/s) and course (degrees clockwise from north).
    other_speed_mps, other_course_deg : float or ndarray
        The other vehicle's speed and course.

    Returns
    -------
    float or ndarray
        ``-d(distance)/dt``: positive when closing, negative when opening, 0 for
        coincident positions.
    """
    ve1, vn1 = velocity_en(own_speed_mps, own_course_deg)
    ve2, vn2 = velocity_en(other_speed_mps, other_course_deg)
    dx = np.asarray(east_m, dtype=float)
    dy = np.asarray(north_m, dtype=float)
    d = np.hypot(dx, dy)
    rel_e = np.asarray(ve2) - ve1
    rel_n = np.asarray(vn2) - vn1
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(d > 0.0, (dx * rel_e + dy * rel_n) / np.where(d > 0.0, d, 1.0), 0.0)
    closing = -rate
    return closing[()] if np.ndim(closing) == 0 else closing


def angle_difference_deg(a_deg: ArrayLike, b_deg: ArrayLike) -> ArrayLike:
    """Signed smallest difference ``a - b`` between two bearings, degrees in (-180, 180]."""
    diff = (np.asarray(a_deg, dtype=float) - b_deg + 180.0) % 360.0 - 180.0
    diff = np.where(diff == -180.0, 180.0, diff)
    return diff[()] if np.ndim(diff) == 0 else diff
