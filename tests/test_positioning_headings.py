"""The track headings sampled every metre against the geometry's own."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol.positioning import reach
from antikol.positioning.headings import HeadingProfile
from antikol.positioning.reach import ReachTable
from tests._memory import traced_peak


@pytest.fixture(scope="module")
def krakow() -> trackmap.TrackMap:
    return trackmap.load_default()


@pytest.fixture(scope="module")
def profile(krakow) -> HeadingProfile:
    return HeadingProfile(krakow)


def _angle_gap(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs((a - b + 180.0) % 360.0 - 180.0)


@settings(max_examples=60, deadline=None)
@given(
    picks=st.lists(
        st.tuples(
            st.floats(0.0, 1.0),
            st.floats(-0.2, 1.2),  # a share of the edge's length, past either end too
            st.sampled_from([1, -1]),
        ),
        min_size=1,
        max_size=20,
    ),
    data=st.data(),
)
def test_the_profile_is_the_geometry_at_the_nearest_metre(krakow, profile, picks, data):
    n_edges = len(krakow.edges)
    edge = np.array([data.draw(st.integers(0, n_edges - 1)) for _ in picks])
    length = np.array([krakow.edges[e].geometry.length for e in edge])
    offset = np.array([share for _, share, _ in picks]) * length
    direction = np.array([d for *_, d in picks])
    got = profile.at(edge, offset, direction)
    nearest = np.minimum(np.rint(np.clip(offset, 0.0, length)), length)
    assert np.all((got >= 0.0) & (got < 360.0))
    assert np.all(_angle_gap(got, krakow.headings_at(edge, nearest, direction)) < 1e-9)


def test_the_profile_is_within_a_curves_half_metre_of_the_exact_heading(krakow, profile):
    rng = np.random.default_rng(3)
    edge = rng.integers(0, len(krakow.edges), 2000)
    length = np.array([krakow.edges[e].geometry.length for e in edge])
    offset = rng.uniform(0.0, 1.0, len(edge)) * length
    direction = rng.choice([1, -1], len(edge))
    gap = _angle_gap(
        profile.at(edge, offset, direction), krakow.headings_at(edge, offset, direction)
    )
    # half a metre along a smooth 20-m curve turns 1.4 degrees; a sharp vertex of the
    # drawn line inside the one-metre chord turns it by its share of the kink (up to
    # ~12 degrees on the Krakow map, for one place in a thousand beyond 5)
    assert np.median(gap) < 0.1
    assert np.percentile(gap, 99) < 3.5
    assert np.mean(gap > 5.0) < 0.005


def test_the_reach_table_of_a_map_carries_its_profile(krakow):
    table = ReachTable.for_map(krakow, reach_m=400.0)
    e, s = np.array([7]), np.array([3.0])
    assert table.headings.at(e, s, np.array([1]))[0] == pytest.approx(krakow.heading_at(7, 3.0, 1))


def test_building_the_profile_holds_little_beyond_the_table(krakow):
    # every positioner (each on-board unit) builds it: the whole map's samples in one
    # search passed through ~75 MB of temporaries, which set the units' peak memory
    again, peak = traced_peak(lambda: HeadingProfile(krakow))
    lengths = np.array([e.geometry.length for e in krakow.edges])
    table_bytes = 8 * int(np.sum(np.ceil(lengths) + 1))  # (Kraków: 212,745 samples, 1.7 MB)
    assert peak < 8 * table_bytes
    # (and the table is the same, built in pieces or whole)
    edge = np.arange(len(krakow.edges))
    half = lengths / 2.0
    ones = np.ones(len(edge), dtype=np.int64)
    assert np.array_equal(again.at(edge, half, ones), krakow.headings_at(edge, np.rint(half), ones))


def test_a_positioners_tables_are_built_in_little_memory(krakow, monkeypatch):
    # every on-board unit builds them: the heading table in one search (~75 MB of
    # temporaries) and the reach table's Dijkstra 256 sources at a time (~26 MB) set its
    # peak memory; both now work in pieces
    table, peak = traced_peak(lambda: ReachTable(krakow, reach_m=600.0))
    assert peak < 16e6
    # (the pieces' size changes no distance)
    monkeypatch.setattr(reach, "_CHUNK", 1000)
    whole = ReachTable(krakow, reach_m=600.0)
    states = np.arange(table.n_states)
    zero = np.zeros(len(states))
    for frm in (0, 1, 700, table.n_states - 1):
        at = np.full(len(states), frm)
        assert np.array_equal(
            table.between(at, zero, states, zero), whole.between(at, zero, states, zero)
        )
