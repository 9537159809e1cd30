"""Local metric coordinate reference systems.

Every map works in a transverse Mercator projection centred on the network, so distances
and angles in the local plane are true to a few parts per million across a city. The CRS
is stored as WKT2 in the map file, and its transformers are built once, with
``always_xy=True`` so that the axis order is always (lon, lat) and (x east, y north).
"""

from __future__ import annotations

from typing import overload

import numpy as np
import numpy.typing as npt
from pyproj import CRS, Geod, Transformer

from trackmap.errors import MapFileError

__all__ = ["WGS84", "FloatArray", "LocalFrame"]

WGS84 = CRS.from_epsg(4326)
_GEOD = Geod(ellps="WGS84")

FloatArray = npt.NDArray[np.float64]


class LocalFrame:
    """A projected metric frame and its cached transformers.

    Parameters
    ----------
    crs : pyproj.CRS
        A projected CRS with metre units.

    Examples
    --------
    >>> frame = LocalFrame.centred_on(19.94, 50.06)
    >>> x, y = frame.to_local(19.94, 50.06)
    >>> round(x, 6), round(y, 6)
    (0.0, 0.0)
    """

    def __init__(self, crs: CRS) -> None:
        if not crs.is_projected:
            raise MapFileError(f"the local CRS must be projected, got {crs.name!r}")
        units = {axis.unit_name for axis in crs.axis_info}
        if units - {"metre"}:
            raise MapFileError(f"the local CRS must use metres, got units {sorted(units)}")
        self.crs = crs
        self._forward = Transformer.from_crs(WGS84, crs, always_xy=True)
        self._inverse = Transformer.from_crs(crs, WGS84, always_xy=True)

    @classmethod
    def centred_on(cls, lon0_deg: float, lat0_deg: float) -> LocalFrame:
        """Transverse Mercator (scale 1, WGS84) centred on a point.

        Parameters
        ----------
        lon0_deg, lat0_deg : float
            Centre of the frame, degrees.
        """
        if not (np.isfinite(lon0_deg) and np.isfinite(lat0_deg)):
            raise ValueError("frame centre must be finite")
        crs = CRS.from_proj4(
            f"+proj=tmerc +lat_0={lat0_deg:.9f} +lon_0={lon0_deg:.9f} +k=1 "
            "+x_0=0 +y_0=0 +ellps=WGS84 +units=m +no_defs +type=crs"
        )
        return cls(crs)

    @classmethod
    def from_wkt(cls, wkt: str) -> LocalFrame:
        """Rebuild a frame from its WKT2 text (as stored in a map file)."""
        try:
            crs = CRS.from_wkt(wkt)
        except Exception as exc:  # pyproj raises CRSError with a terse message
            raise MapFileError(f"cannot parse the map's CRS WKT: {exc}") from exc
        return cls(crs)

    @property
    def wkt(self) -> str:
        """The CRS as WKT2 (2019)."""
        return str(self.crs.to_wkt(version="WKT2_2019"))

    @overload
    def to_local(self, lon: float, lat: float) -> tuple[float, float]: ...
    @overload
    def to_local(self, lon: npt.ArrayLike, lat: npt.ArrayLike) -> tuple[FloatArray, FloatArray]: ...

    def to_local(self, lon, lat):
        """WGS84 (lon, lat) degrees to local (x east, y north) metres; scalars or arrays."""
        x, y = self._forward.transform(lon, lat)
        if np.ndim(x) == 0:
            return float(x), float(y)
        return np.asarray(x, dtype=float), np.asarray(y, dtype=float)

    @overload
    def to_lonlat(self, x: float, y: float) -> tuple[float, float]: ...
    @overload
    def to_lonlat(self, x: npt.ArrayLike, y: npt.ArrayLike) -> tuple[FloatArray, FloatArray]: ...

    def to_lonlat(self, x, y):
        """Local (x, y) metres to WGS84 (lon, lat) degrees; scalars or arrays."""
        lon, lat = self._inverse.transform(x, y)
        if np.ndim(lon) == 0:
            return float(lon), float(lat)
        return np.asarray(lon, dtype=float), np.asarray(lat, dtype=float)

    def grid_north_azimuth_deg(self, x: npt.ArrayLike, y: npt.ArrayLike) -> FloatArray:
        """True azimuth of grid north at local points, degrees (within a few tenths of 0).

        A heading measured in the local plane (from grid north) becomes a true course over
        ground by adding this angle; the difference is the projection's meridian
        convergence, below 0.2 degrees across a city-sized map but accounted for exactly.
        """
        xa = np.atleast_1d(np.asarray(x, dtype=float))
        ya = np.atleast_1d(np.asarray(y, dtype=float))
        lon0, lat0 = self.to_lonlat(xa, ya)
        lon1, lat1 = self.to_lonlat(xa, ya + 10.0)
        az, _, _ = _GEOD.inv(lon0, lat0, lon1, lat1)
        return np.asarray((np.asarray(az) + 180.0) % 360.0 - 180.0, dtype=float)
