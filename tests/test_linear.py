"""trackmap.linear: points along many lines, the same numbers as shapely (GEOS)."""

from unittest import mock

import numpy as np
import pytest
import shapely
from hypothesis import example, given, settings
from hypothesis import strategies as st

import trackmap
from trackmap import linear
from trackmap.linear import PackedLines

coordinate = st.floats(-5000.0, 5000.0, allow_nan=False, allow_infinity=False)
vertex = st.tuples(coordinate, coordinate)


@st.composite
def lines_and_queries(draw):
    lines = []
    for _ in range(draw(st.integers(1, 4))):
        pts = draw(st.lists(vertex, min_size=2, max_size=8))
        # repeated vertices (zero-length segments) occur in real map data
        repeats = draw(st.lists(st.integers(0, len(pts) - 1), max_size=3))
        for k in sorted(repeats, reverse=True):
            pts.insert(k, pts[k])
        lines.append(shapely.LineString(pts))
    packed = PackedLines(lines)
    ids, distances = [], []
    for _ in range(draw(st.integers(1, 12))):
        i = draw(st.integers(0, len(lines) - 1))
        length = float(shapely.length(lines[i]))
        cums = packed._cum_after[packed._first[i] : packed._last_segment[i] + 1].tolist()
        # exactly at a vertex, and one ulp either side: where rounding decides
        at_vertex = st.tuples(st.sampled_from(cums), st.sampled_from([-np.inf, 0, np.inf])).map(
            lambda cs: cs[0] if cs[1] == 0 else float(np.nextafter(*cs))
        )
        d = draw(
            st.one_of(
                st.floats(-1.2 * length - 1, 1.2 * length + 1, allow_nan=False),
                st.sampled_from([0.0, -0.0, length, -length, np.nan, np.inf, -np.inf]),
                at_vertex,
            )
        )
        ids.append(i)
        distances.append(d)
    return lines, packed, ids, distances


def same_bits(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return (
        a.shape == b.shape
        and ((a.view(np.int64) == b.view(np.int64)) | (np.isnan(a) & np.isnan(b))).all()
    )


@settings(max_examples=300, deadline=None)
@given(lines_and_queries())
def test_interpolate_is_shapely_to_the_last_bit(case):
    lines, packed, ids, distances = case
    x, y = packed.interpolate(ids, distances, search_from=0)
    pts = shapely.line_interpolate_point(np.array(lines, dtype=object)[ids], distances)
    assert same_bits(x, shapely.get_x(pts))
    assert same_bits(y, shapely.get_y(pts))


def test_lengths_are_shapely_lengths():
    net = trackmap.load_default()
    geoms = np.array([e.geometry for e in net.edges], dtype=object)
    assert same_bits(PackedLines(geoms).lengths_m, shapely.length(geoms))


def test_every_edge_of_the_embedded_map_to_the_last_bit():
    net = trackmap.load_default()
    geoms = np.array([e.geometry for e in net.edges], dtype=object)
    packed = PackedLines(geoms)
    rng = np.random.default_rng(5)
    ids = rng.integers(0, len(geoms), 50_000)
    distances = rng.uniform(-0.05, 1.05, ids.size) * shapely.length(geoms)[ids]
    x, y = packed.interpolate(ids, distances)
    pts = shapely.line_interpolate_point(geoms[ids], distances)
    assert same_bits(x, shapely.get_x(pts)) and same_bits(y, shapely.get_y(pts))
    # and the map's own array queries, which use it, agree with its scalar ones
    px, py = net.points_at(ids[:200], distances[:200])
    for i, d, a, b in zip(ids[:200], distances[:200], px, py, strict=True):
        assert (a, b) == net.point_at(int(i), float(d))


def test_broadcasting_and_shape():
    packed = PackedLines([shapely.LineString([(0, 0), (10, 0)])])
    for search_from in (0, 1000):  # the array search and shapely
        x, y = packed.interpolate(0, [[1.0, 2.0], [3.0, 4.0]], search_from=search_from)
        assert x.shape == (2, 2) and x.tolist() == [[1.0, 2.0], [3.0, 4.0]]
        assert y.tolist() == [[0.0, 0.0], [0.0, 0.0]]
        empty_x, empty_y = packed.interpolate([], [], search_from=search_from)
        assert empty_x.shape == empty_y.shape == (0,)


@pytest.mark.parametrize(
    ("geometry", "message"),
    [
        (shapely.Point(0, 0), "line 0 is not a LineString"),
        (shapely.LineString(), "line 0 has fewer than two vertices"),
    ],
)
def test_what_is_not_a_line_is_refused(geometry, message):
    with pytest.raises(ValueError, match=message):
        PackedLines([geometry])


def test_a_line_index_out_of_range_is_an_index_error():
    packed = PackedLines([shapely.LineString([(0, 0), (10, 0)])])
    for search_from in (0, 1000):
        with pytest.raises(IndexError, match="out of range"):
            packed.interpolate([1], [0.0], search_from=search_from)
        with pytest.raises(IndexError, match="out of range"):
            packed.interpolate([-1], [0.0], search_from=search_from)


def _shapely_nearest(lines, x, y, radius):
    """The reference: shapely's dwithin query and line_locate_point, sorted by point, line."""
    geoms = np.array(lines, dtype=object)
    finite = np.isfinite(x) & np.isfinite(y)
    pts = shapely.points(np.where(finite, x, 0.0), np.where(finite, y, 0.0))
    pts[~finite] = None
    p, e = shapely.STRtree(geoms).query(pts, predicate="dwithin", distance=radius)
    order = np.lexsort((e, p))
    p, e = p[order], e[order]
    with np.errstate(invalid="ignore", divide="ignore"):  # GEOS on zero-length segments
        return p, e, shapely.line_locate_point(geoms[e], pts[p])


@st.composite
def lines_and_points(draw):
    small = st.floats(-50.0, 50.0, allow_nan=False, allow_infinity=False)
    lines = []
    for _ in range(draw(st.integers(1, 4))):
        pts = draw(st.lists(st.tuples(small, small), min_size=2, max_size=8))
        repeats = draw(st.lists(st.integers(0, len(pts) - 1), max_size=3))
        for k in sorted(repeats, reverse=True):
            pts.insert(k, pts[k])
        lines.append(shapely.LineString(pts))
    vertices = [tuple(c) for g in lines for c in shapely.get_coordinates(g).tolist()]
    # anywhere, exactly on a vertex (where segments tie), or not a number
    point = st.one_of(
        st.tuples(small, small),
        st.sampled_from(vertices),
        st.sampled_from([(np.nan, 0.0), (np.inf, 1.0)]),
    )
    xy = draw(st.lists(point, min_size=1, max_size=10))
    radius = draw(st.sampled_from([0.5, 5.0, 25.0, 200.0]))
    return lines, np.array([p[0] for p in xy]), np.array([p[1] for p in xy]), radius


@settings(max_examples=300, deadline=None)
@given(lines_and_points())
# a segment whose end lies beyond the radius in exact arithmetic, at it in floating point
@example(
    (
        [shapely.LineString([(0, -3), (1, 1), (0, 2.962e-110)])],
        np.array([0.0]),
        np.array([-0.5]),
        0.5,
    )
)
def test_nearest_within_is_shapely_to_the_last_bit(case):
    """The lines within the radius of each point and the distance along each: those of a
    ``dwithin`` query and :func:`shapely.line_locate_point`, repeated vertices and points
    exactly on a vertex included."""
    lines, x, y, radius = case
    ref_point, ref_line, ref_offset = _shapely_nearest(lines, x, y, radius)
    # the keys folded into one integer, and (as for a city's worth of points) sorted apart
    for fold_limit in (2**62, 1):
        with mock.patch.object(linear, "_FOLD_LIMIT", fold_limit):
            point, line, offset = PackedLines(lines).nearest_within(x, y, radius, index_from=0)
        assert point.tolist() == ref_point.tolist()
        assert line.tolist() == ref_line.tolist()
        assert same_bits(offset, ref_offset)


def test_nearest_within_on_the_embedded_map_to_the_last_bit():
    net = trackmap.load_default()
    geoms = np.array([e.geometry for e in net.edges], dtype=object)
    xy = shapely.get_coordinates(geoms)
    rng = np.random.default_rng(8)
    # near the track (GPS fixes) and exactly on its vertices
    near = xy[rng.integers(0, len(xy), 20_000)] + rng.normal(0.0, 8.0, (20_000, 2))
    on = xy[rng.integers(0, len(xy), 2_000)]
    pts = np.concatenate([near, on])
    got = PackedLines(geoms).nearest_within(pts[:, 0], pts[:, 1], 25.0)
    ref = _shapely_nearest(list(geoms), pts[:, 0], pts[:, 1], 25.0)
    assert got[0].tolist() == ref[0].tolist() and got[1].tolist() == ref[1].tolist()
    assert same_bits(got[2], ref[2])
