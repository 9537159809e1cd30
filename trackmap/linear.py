"""Points at distances along many polylines in array code, as GEOS computes them.

:func:`shapely.line_interpolate_point` walks each line's segments in C, but every call
for a fleet also builds one shapely ``Point`` per result and reads its coordinates back
(about 1 µs per point, the largest single cost of placing a thousand vehicles). A map's
edges do not change, so their cumulative lengths can be kept once and a large batch of
queries answered by a vectorised binary search (a small one, below
:data:`ARRAY_SEARCH_FROM`, still goes to shapely: numpy's cost per call is the larger
there).

The arithmetic is that of GEOS's linear referencing (``LengthLocationMap`` and
``LinearLocation``), step by step, so the results are the same numbers to the last bit
(checked against shapely by property tests):

* the length of a segment is ``sqrt(dx*dx + dy*dy)`` and the running total adds them in
  order from the first vertex;
* a distance falls in the first segment whose running total after it exceeds the
  distance; the fraction is ``(distance - total before) / segment length``, clamped to
  [0, 1], and the point ``(x1 - x0) * fraction + x0``;
* a negative distance is measured back from the end (the line's total length plus the
  distance), zero or less from the start is the first vertex, a distance beyond the end
  the last vertex; a NaN distance gives NaN coordinates (shapely's empty point).

The nearest place on each line within a radius of many points
(:meth:`PackedLines.nearest_within`, what a ``dwithin`` query of an STRtree and
:func:`shapely.line_locate_point` give) is found through an STRtree of the lines'
*segments*: only the segments near a point are measured, in array code, with the
arithmetic of GEOS's ``Distance::pointToSegment`` and ``LengthIndexOfPoint`` (the first
segment at the least distance; its projection factor clamped to it, added to the running
length before it).

>>> import shapely
>>> lines = PackedLines([shapely.LineString([(0, 0), (3, 4), (3, 10)])])
>>> x, y = lines.interpolate([0, 0, 0], [2.5, 8.0, 99.0])
>>> x.tolist(), y.tolist()
([1.5, 3.0, 3.0], [2.0, 7.0, 10.0])
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import shapely

__all__ = ["ARRAY_SEARCH_FROM", "SEGMENT_INDEX_FROM", "PackedLines"]

#: Below this many queries one shapely call costs less than the array search (its cost is
#: mostly per call); the numbers are the same either way.
ARRAY_SEARCH_FROM = 160
#: From this many points on, the nearest places are found through the segment index (its
#: array code costs more per call than one shapely query below it); the same numbers.
SEGMENT_INDEX_FROM = 12
#: The segments searched around a point reach this much beyond the radius, m.
_BOX_MARGIN_M = 1e-6
#: (point, line, segment) keys are folded into one int64 below this product of counts.
_FOLD_LIMIT = 2**62

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


class PackedLines:
    """The vertices of many 2-D line strings in flat arrays, for :meth:`interpolate`.

    Parameters
    ----------
    lines : array_like of shapely.LineString
        Each with at least two vertices, coordinates in metres (a projected frame); any
        third dimension is ignored.

    Raises
    ------
    ValueError
        A geometry is not a line string of at least two vertices.
    """

    __slots__ = (
        "_cum_after",
        "_first",
        "_geoms",
        "_last_segment",
        "_length",
        "_segment",
        "_segments",
        "_tree",
        "_x",
        "_y",
    )

    def __init__(self, lines: Sequence[shapely.LineString] | npt.NDArray[np.object_]) -> None:
        geoms = np.asarray(lines, dtype=object)
        if geoms.ndim != 1:
            raise ValueError("lines must be a one-dimensional sequence of line strings")
        kinds = shapely.get_type_id(geoms)
        bad = np.flatnonzero(kinds != shapely.GeometryType.LINESTRING)
        if bad.size:
            raise ValueError(f"line {int(bad[0])} is not a LineString")
        counts = shapely.get_num_coordinates(geoms).astype(np.int64)
        short = np.flatnonzero(counts < 2)
        if short.size:
            raise ValueError(f"line {int(short[0])} has fewer than two vertices")
        self._geoms = geoms
        xy = shapely.get_coordinates(geoms)
        self._x: FloatArray = np.ascontiguousarray(xy[:, 0], dtype=float)
        self._y: FloatArray = np.ascontiguousarray(xy[:, 1], dtype=float)
        first = np.zeros(len(counts), dtype=np.int64)
        np.cumsum(counts[:-1], out=first[1:])
        self._first: IntArray = first
        #: index of each line's last segment (its second-to-last vertex)
        self._last_segment: IntArray = first + counts - 2
        # segment k runs from vertex k to k + 1; the pairs that straddle two lines are
        # computed too and never read (a line's search never leaves its own segments)
        dx = self._x[1:] - self._x[:-1]
        dy = self._y[1:] - self._y[:-1]
        seg = np.sqrt(dx * dx + dy * dy)
        self._segment: FloatArray = seg
        cum_after = np.empty(len(self._x), dtype=float)
        cum_after[-1] = np.inf
        length = np.empty(len(counts), dtype=float)
        for i, (a, b) in enumerate(zip(first.tolist(), self._last_segment.tolist(), strict=True)):
            # np.cumsum adds in order, as GEOS's running total does
            run = np.cumsum(seg[a : b + 1])
            cum_after[a : b + 1] = run
            cum_after[b + 1] = np.inf
            length[i] = run[-1]
        self._cum_after: FloatArray = cum_after
        self._length: FloatArray = length
        self._segments: _SegmentIndex | None = None
        self._tree: shapely.STRtree | None = None

    def __len__(self) -> int:
        return len(self._first)

    @property
    def lengths_m(self) -> FloatArray:
        """Length of each line, m (the running total over its segments)."""
        return self._length.copy()

    def interpolate(
        self,
        line_ids: npt.ArrayLike,
        distances_m: npt.ArrayLike,
        *,
        search_from: int = ARRAY_SEARCH_FROM,
    ) -> tuple[FloatArray, FloatArray]:
        """The points at distances along lines, as :func:`shapely.line_interpolate_point`.

        Parameters
        ----------
        line_ids : array_like of int
            Index of the line of each query.
        distances_m : array_like of float
            Distance from each line's first vertex, m (negative: back from its end).
        search_from : int
            Fewer queries than this go to shapely in one call, more to the array search
            (the same numbers either way).

        Returns
        -------
        x, y : ndarray of float
            Coordinates of the points, m, in the shape of the broadcast arguments.

        Raises
        ------
        IndexError
            A line index out of range.
        """
        ids, dist = np.broadcast_arrays(
            np.asarray(line_ids, dtype=np.int64), np.asarray(distances_m, dtype=float)
        )
        shape = ids.shape
        ids = ids.ravel()
        dist = dist.ravel()
        n_lines = len(self._first)
        if ids.size and (ids.min() < 0 or ids.max() >= n_lines):
            raise IndexError(f"line index out of range 0..{n_lines - 1}")
        if ids.size < search_from:
            pts = shapely.line_interpolate_point(self._geoms[ids], dist)
            return shapely.get_x(pts).reshape(shape), shapely.get_y(pts).reshape(shape)
        return self._search(ids, dist, shape)

    def _search(
        self, ids: IntArray, dist: FloatArray, shape: tuple[int, ...]
    ) -> tuple[FloatArray, FloatArray]:
        """:meth:`interpolate` by a binary search over the running lengths (flat queries)."""
        length = self._length[ids]
        forward = np.where(dist < 0.0, length + dist, dist)
        lo = self._first[ids]
        hi = self._last_segment[ids] + 1  # one past the last segment: beyond the end
        cum = self._cum_after
        # the first segment whose running total after it exceeds the distance
        while True:
            open_ = lo < hi
            if not open_.any():
                break
            mid = (lo + hi) >> 1
            beyond = cum[mid] > forward
            lo = np.where(open_ & ~beyond, mid + 1, lo)
            hi = np.where(open_ & beyond, mid, hi)
        last = self._last_segment[ids]
        past_end = lo > last
        seg = np.minimum(lo, last)
        x0, y0 = self._x[seg], self._y[seg]
        x1, y1 = self._x[seg + 1], self._y[seg + 1]
        before = np.where(seg == self._first[ids], 0.0, cum[seg - 1])
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = (forward - before) / self._segment[seg]
            x = (x1 - x0) * frac + x0
            y = (y1 - y0) * frac + y0
        # GEOS's clamps: the end (beyond it, NaN, or a fraction rounded up to one), a
        # fraction of zero, and a distance of zero or less (the first vertex)
        at_end = past_end | (frac >= 1.0)
        x = np.where(at_end, x1, np.where(frac <= 0.0, x0, x))
        y = np.where(at_end, y1, np.where(frac <= 0.0, y0, y))
        at_start = forward <= 0.0
        first = self._first[ids]
        x = np.where(at_start, self._x[first], x)
        y = np.where(at_start, self._y[first], y)
        # shapely answers a NaN distance with an empty point: NaN coordinates
        x[np.isnan(dist)] = np.nan
        y[np.isnan(dist)] = np.nan
        return x.reshape(shape), y.reshape(shape)

    def nearest_within(
        self,
        x: FloatArray,
        y: FloatArray,
        radius_m: float,
        *,
        index_from: int = SEGMENT_INDEX_FROM,
    ) -> tuple[IntArray, IntArray, FloatArray]:
        """Every line within ``radius_m`` of each point, and the distance along it of the
        point's nearest place, as :func:`shapely.line_locate_point` computes it.

        The lines near a point are found through an index of their segments, and only
        the segments near it are measured: a large batch costs a few array operations
        instead of a walk over every segment of every line in reach. Fewer points than
        ``index_from`` go to shapely (a ``dwithin`` query of whole lines and
        :func:`shapely.line_locate_point`), whose cost per call is the smaller there.

        Parameters
        ----------
        x, y : ndarray of float
            The points, m (non-finite: no lines).
        radius_m : float
            Search radius, m.
        index_from : int, keyword-only
            From this many points on, the segment index is used (the same rows and
            numbers either way; tests set it to exercise both).

        Returns
        -------
        point, line : ndarray of int
            Index of the point and of the line of each row, sorted by point, then line.
        offset_m : ndarray of float
            Distance along the line of the point's nearest place, m (GEOS's arithmetic:
            the first nearest segment, the projection factor clamped to it, the running
            length before it).

        Examples
        --------
        >>> import shapely
        >>> lines = PackedLines([shapely.LineString([(0, 0), (10, 0)]),
        ...                      shapely.LineString([(0, 5), (10, 5)])])
        >>> point, line, offset = lines.nearest_within(np.array([3.0]), np.array([1.0]), 2.0)
        >>> point.tolist(), line.tolist(), offset.tolist()
        ([0], [0], [3.0])
        """
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        if len(x) < index_from:
            return self._nearest_by_lines(x, y, float(radius_m))
        if self._segments is None:
            self._segments = _SegmentIndex.build(self)
        return self._segments.nearest_within(x, y, float(radius_m))

    def _nearest_by_lines(
        self, x: FloatArray, y: FloatArray, radius_m: float
    ) -> tuple[IntArray, IntArray, FloatArray]:
        """:meth:`nearest_within` by shapely: the lines' STRtree and line_locate_point."""
        if self._tree is None:
            self._tree = shapely.STRtree(self._geoms)
        finite = np.isfinite(x) & np.isfinite(y)
        pts = shapely.points(np.where(finite, x, 0.0), np.where(finite, y, 0.0))
        pts[~finite] = None
        point, line = self._tree.query(pts, predicate="dwithin", distance=radius_m)
        order = np.lexsort((line, point))
        point, line = point[order].astype(np.int64), line[order].astype(np.int64)
        return point, line, shapely.line_locate_point(self._geoms[line], pts[point])


class _SegmentIndex:
    """An STRtree of the segments of :class:`PackedLines` with their end points, lines and
    running lengths before them (built on first use)."""

    __slots__ = ("ax", "ay", "before", "bx", "by", "length", "line", "n_lines", "tree")

    def __init__(
        self,
        tree: shapely.STRtree,
        ends: FloatArray,
        line: IntArray,
        before: FloatArray,
        length: FloatArray,
        n_lines: int,
    ) -> None:
        self.tree = tree
        self.ax, self.ay, self.bx, self.by = ends
        self.line = line
        self.before = before
        self.length = length
        self.n_lines = n_lines

    @classmethod
    def build(cls, lines: PackedLines) -> _SegmentIndex:
        first, last = lines._first, lines._last_segment
        counts = last - first + 1
        line = np.repeat(np.arange(len(first), dtype=np.int64), counts)
        # flat vertex index of each segment's start: its line's first plus its rank
        rank = np.arange(len(line), dtype=np.int64) - np.repeat(np.cumsum(counts) - counts, counts)
        start = first[line] + rank
        before = np.where(rank == 0, 0.0, lines._cum_after[np.maximum(start - 1, 0)])
        ends = np.stack(
            [lines._x[start], lines._y[start], lines._x[start + 1], lines._y[start + 1]]
        )
        tree = shapely.STRtree(
            shapely.linestrings(np.stack([ends[[0, 1]].T, ends[[2, 3]].T], axis=1))
        )
        return cls(tree, ends, line, before, lines._segment[start], len(first))

    def nearest_within(
        self, x: FloatArray, y: FloatArray, radius_m: float
    ) -> tuple[IntArray, IntArray, FloatArray]:
        finite = np.flatnonzero(np.isfinite(x) & np.isfinite(y))
        fx, fy = x[finite], y[finite]
        # boxes a micrometre wider than the radius: a segment just beyond it in exact
        # arithmetic may be within it in floating point (as GEOS measures it)
        reach = radius_m + _BOX_MARGIN_M
        boxes = shapely.box(fx - reach, fy - reach, fx + reach, fy + reach)
        q, seg = self.tree.query(boxes)
        px, py = fx[q], fy[q]
        ax, ay, bx, by = self.ax[seg], self.ay[seg], self.bx[seg], self.by[seg]
        # GEOS: Distance::pointToSegment and LengthIndexOfPoint::segmentNearestMeasure
        ex, ey = bx - ax, by - ay
        len2 = ex * ex + ey * ey
        to_a = np.sqrt((px - ax) * (px - ax) + (py - ay) * (py - ay))
        to_b = np.sqrt((px - bx) * (px - bx) + (py - by) * (py - by))
        degenerate = (ax == bx) & (ay == by)  # (no division by its zero length is used)
        with np.errstate(invalid="ignore", divide="ignore"):
            r = ((px - ax) * ex + (py - ay) * ey) / len2
            across = np.abs(((ay - py) * ex - (ax - px) * ey) / len2) * np.sqrt(len2)
        dist = np.where(degenerate | (r <= 0.0), to_a, np.where(r >= 1.0, to_b, across))
        # a line is in reach when its nearest segment is: of each (point, line) the first
        # segment (along the line) at the least distance, among those within the radius
        near = np.flatnonzero(dist <= radius_m)
        q, seg, dist, r = q[near], seg[near], dist[near], r[near]
        keep = self._first_nearest(q, seg, dist, len(x))  # by point, then line
        # the projection factor is r (exactly 0 or 1 at the segment's ends, as GEOS's
        # special cases; NaN on a degenerate segment, which ends where it starts)
        r, seg = r[keep], seg[keep]
        start, length = self.before[seg], self.length[seg]
        with np.errstate(invalid="ignore"):
            measure = np.where(
                r <= 0.0, start, np.where(r <= 1.0, start + r * length, start + length)
            )
        return finite[q[keep]], self.line[seg], measure

    def _first_nearest(
        self, q: IntArray, seg: IntArray, dist: FloatArray, n_points: int
    ) -> IntArray:
        """Of each (point, line) the row of its first segment at the least distance, in
        the order of (point, line).

        Rows sorted once by (point, line, segment) folded into one integer (a point meets
        a segment at most once, so the keys are unique), then the least distance of each
        run and its first row; several times cheaper than a lexicographic sort that takes
        the distance as a key. ``n_points`` bounds the point numbers (for the fold).
        """
        if len(q) == 0:
            return np.zeros(0, dtype=np.int64)
        key = q * self.n_lines + self.line[seg]
        n_segments = len(self.line)
        if n_points * self.n_lines * n_segments >= _FOLD_LIMIT:  # too many: sort by keys
            order = np.lexsort((seg, dist, key))
            head = np.ones(len(order), dtype=bool)
            head[1:] = key[order[1:]] != key[order[:-1]]
            return order[head]
        order = np.argsort(key * n_segments + seg)
        run_key, run_dist = key[order], dist[order]
        starts = np.flatnonzero(np.concatenate([[True], run_key[1:] != run_key[:-1]]))
        least = np.minimum.reduceat(run_dist, starts)
        at_least = run_dist == np.repeat(least, np.diff(np.append(starts, len(order))))
        rows = np.arange(len(order))
        return order[np.minimum.reduceat(np.where(at_least, rows, len(order)), starts)]
