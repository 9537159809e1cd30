"""The map builder on a city it was not written against: ``benchmarks/synthville.py``.

Synthville is drawn as real extracts draw a tram network (see the script): a diamond
crossing without a shared node, a line cut by the bounding box, a stretch of double track
without ``oneway`` tags, loops, a wye and a passing track. Every feature drawn must come
out of ``trackmap.build`` as what it is; the referee's figures on this map in the README
rest on it.
"""

from __future__ import annotations

import math
from collections import Counter

import pytest

import trackmap
from tests._synthville import synthville
from trackmap.check import check


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    def build(untagged_m: float) -> trackmap.TrackMap:
        path = tmp_path_factory.mktemp("synthville") / "synthville.osm"
        synthville().main(["-o", str(path), "--untagged-m", str(untagged_m)])
        return trackmap.build(path, kinds=("tram",), driving_side="right")

    return {m: build(m) for m in (400.0, 0.0)}


@pytest.mark.parametrize("untagged_m", [400.0, 0.0])
def test_every_drawn_feature_is_found(drawn, untagged_m):
    net = drawn[untagged_m]
    s = net.stats()
    assert s["switches"] == 19  # loops 2+1, passing track 2, wye 2 x 8, branch 2 ... as drawn
    assert s["unnoded_crossings"] == 11  # the A/B diamond's 4 and the wye's turning curves
    assert s["diamond_crossings"] == 0  # the diamond has no shared node
    assert s["components"] == 1
    assert s["stops"] == 15
    # 5 buffer stops drawn and the 2 ends the bounding box cut
    assert s["buffer_stops"] == 7
    assert net.metadata.source["clipped"] == {"ways": 2, "pieces": 2, "missing_refs": 4}
    kinds = Counter(str(c.kind.value) for c in net.conflicts)
    assert kinds == {"merge": 19, "crossing": 11}
    assert math.isclose(s["track_km"], 11.19, abs_tol=0.01)


def _left_of(net: trackmap.TrackMap, edge_id: int, other_id: int) -> float:
    """Signed distance of another edge's nearest point to the left of an edge's running
    direction at its middle, m."""
    edge = net.edge(edge_id)
    line = edge.geometry
    mid = line.interpolate(0.5, normalized=True)
    ahead = line.interpolate(min(line.length / 2 + 1.0, line.length))
    dx, dy = ahead.x - mid.x, ahead.y - mid.y
    if edge.direction == -1:
        dx, dy = -dx, -dy
    other = net.edge(other_id).geometry
    near = other.interpolate(other.project(mid))
    return (dx * (near.y - mid.y) - dy * (near.x - mid.x)) / math.hypot(dx, dy)


def test_untagged_double_track_runs_on_the_right(drawn):
    net = drawn[400.0]
    edges = range(net.stats()["edges"])
    inferred = [e for e in edges if net.edge(e).direction_source == "driving_side"]
    assert len(inferred) == 2  # the two tracks of the untagged stretch
    a, b = inferred
    # right-hand running: the other track is on the left of each one's running direction
    assert 2.5 < _left_of(net, a, b) < 4.0
    assert 2.5 < _left_of(net, b, a) < 4.0


def test_a_fully_tagged_drawing_infers_nothing(drawn):
    net = drawn[0.0]
    sources = Counter(net.edge(e).direction_source for e in range(net.stats()["edges"]))
    assert sources == {"oneway": 31, "none": 1}  # the single-track branch runs both ways
    assert "inferred_direction" not in check(net).counts()


def test_check_names_the_edges_whose_direction_was_inferred(drawn):
    net = drawn[400.0]
    notes = [f for f in check(net).notes if f.code == "inferred_direction"]
    edges = range(net.stats()["edges"])
    inferred = [e for e in edges if net.edge(e).direction_source == "driving_side"]
    assert sorted(f.edges[0] for f in notes) == inferred
    assert all("driving side (right)" in f.message for f in notes)
    assert all(f.lon is not None and 24.9 < f.lon < 25.0 for f in notes)


def test_the_drawing_refuses_a_stretch_longer_than_its_line():
    with pytest.raises(ValueError, match="untagged_m"):
        synthville().draw_synthville(untagged_m=900.0)
