"""Track headings sampled every metre, precomputed once per map.

The scoring compares each hypothesis' reported course with the track heading at the place
the hypothesis puts the vehicle, a different place for every pair of every cycle. A
heading from the geometry costs two interpolations along the line; here the heading of
every edge is taken once at every whole metre (over a chord of one metre, as
:meth:`trackmap.TrackMap.heading_at`), and each query is one array lookup at the nearest
metre. Rounding the place to the metre turns the heading by half a metre of curvature
(1.4 degrees in a 20-m curve), well inside a course's error; where a sharp vertex of the
drawn line falls inside the chord, by its share of the kink (beyond 5 degrees at one place
in a thousand on the Krakow map).

>>> import numpy as np, trackmap
>>> from antikol.positioning.headings import HeadingProfile
>>> net = trackmap.load_default()
>>> profile = HeadingProfile(net)
>>> e, s = np.array([5]), np.array([12.0])
>>> bool(np.allclose(profile.at(e, s, np.array([1])), net.headings_at(e, s, [1])))
True
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["HeadingProfile"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


_CHUNK = 8192  # samples per call of the map's heading search while the table is built


class HeadingProfile:
    """The true heading (degrees, along the vertex order) of every edge at every metre.

    Parameters
    ----------
    track_map : trackmap.TrackMap
    """

    __slots__ = ("_first", "_heading", "_lengths")

    def __init__(self, track_map: Any) -> None:
        lengths = np.asarray([e.geometry.length for e in track_map.edges], dtype=float)
        samples = np.ceil(lengths).astype(np.int64) + 1  # 0, 1, ... and the end
        first = np.zeros(len(lengths), dtype=np.int64)
        np.cumsum(samples[:-1], out=first[1:])
        edge = np.repeat(np.arange(len(lengths)), samples)
        metre = np.arange(len(edge)) - first[edge]
        offset = np.minimum(metre.astype(float), lengths[edge])
        self._first: IntArray = first
        self._lengths: FloatArray = lengths
        # in chunks: the whole map at once (210,000 samples for Kraków) passed through
        # ~75 MB of temporaries, each on-board unit's peak memory (the values are per
        # sample, so the chunks give the same table)
        heading = np.empty(len(edge), dtype=float)
        for lo in range(0, len(edge), _CHUNK):
            part = slice(lo, lo + _CHUNK)
            heading[part] = track_map.headings_at(edge[part], offset[part], 1)
        self._heading: FloatArray = heading

    def at(self, edge_ids: IntArray, offsets_m: FloatArray, directions: IntArray) -> FloatArray:
        """True headings of travel at track places, degrees (at the nearest whole metre).

        Parameters
        ----------
        edge_ids : ndarray of int
        offsets_m : ndarray of float
            Distance along each edge's vertices, m (clipped to the edge).
        directions : ndarray of int
            Running direction, +1/-1.

        Returns
        -------
        ndarray of float
            Degrees clockwise from true north, in [0, 360).
        """
        lengths = self._lengths[edge_ids]
        metre = np.rint(np.clip(offsets_m, 0.0, lengths)).astype(np.int64)
        metre = np.minimum(metre, np.ceil(lengths).astype(np.int64))
        heading = self._heading[self._first[edge_ids] + metre]
        return np.where(directions < 0, (heading + 180.0) % 360.0, heading)
