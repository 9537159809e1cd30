"""The driving side a map is built for: given, or read from the extract's tagged track.

A map built for the wrong side gives every untagged double track the wrong direction. The
default, ``auto``, takes the side the tagged one-way double track of the same extract
shows; Synthville mirrored east to west (``benchmarks/synthville.py --left-hand``) is the
left-hand city it must recognise.
"""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from tests._osm import OsmBuilder
from tests._synthville import synthville
from trackmap.builder.drivingside import (
    DrivingSideTally,
    SideEvidence,
    parallel_neighbours,
    resolve_driving_side,
)
from trackmap.check import check
from trackmap.cli import main as trackmap_main


@pytest.fixture(scope="module")
def cities(tmp_path_factory):
    """Synthville (right-hand, 400 m untagged) and its mirror image (left-hand) as files."""
    folder = tmp_path_factory.mktemp("sides")
    right, left = folder / "right.osm", folder / "left.osm"
    town = synthville()
    town.main(["-o", str(right)])
    town.main(["-o", str(left), "--left-hand"])
    return right, left


def test_auto_reads_a_left_hand_city_from_its_tags(cities):
    right_file, left_file = cities
    right, left = trackmap.build(right_file), trackmap.build(left_file)
    assert (right.metadata.driving_side, left.metadata.driving_side) == ("right", "left")
    assert left.metadata.build["driving_side"] == "auto"
    evidence = left.metadata.source["driving_side_evidence"]
    assert evidence["left_m"] > 8000.0 > 100.0 > evidence["right_m"]
    inferred = [e.edge_id for e in right.edges if e.direction_source == "driving_side"]
    assert inferred  # the untagged stretch
    # a mirror image run on the other side: every track runs as it did
    assert [e.direction for e in left.edges] == [e.direction for e in right.edges]
    assert [e.direction_source for e in left.edges] == [e.direction_source for e in right.edges]


def test_a_side_given_against_the_tags_is_used_and_warned_of(cities, caplog):
    right_file, left_file = cities
    auto = trackmap.build(left_file)
    with caplog.at_level(logging.WARNING, logger="trackmap"):
        forced = trackmap.build(left_file, driving_side="right")
    assert forced.metadata.driving_side == "right"
    flipped = [e.edge_id for e, f in zip(auto.edges, forced.edges, strict=True) if e != f]
    inferred = {e.edge_id for e in auto.edges if e.direction_source == "driving_side"}
    assert inferred <= set(flipped)
    for e, f in zip(auto.edges, forced.edges, strict=True):
        if e.edge_id in inferred:
            assert f.direction == -e.direction
        elif e.direction_source in ("oneway", "preferred_direction", "none"):
            assert f.direction == e.direction  # (tags and two-way track do not move)
    (message,) = [r.getMessage() for r in caplog.records if "as asked" in r.getMessage()]
    assert str(left_file) in message and "left-hand running" in message
    (finding,) = [f for f in check(forced).warnings if f.code == "driving_side"]
    assert set(finding.edges) == inferred and "'left'" in finding.message
    assert not [f for f in check(auto).warnings if f.code == "driving_side"]
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="trackmap"):
        trackmap.build(right_file, driving_side="right")
    assert not [r for r in caplog.records if "as asked" in r.getMessage()]


def _pair(x0: float, length_m: float, *, left_hand: bool, **tags: str) -> list:
    """A double track 3.8 m apart at ``x0``, each track drawn the way its trams run."""
    # right-hand running: northbound on the eastern track, southbound on the western
    north, south = [(x0 + 3.8, 0.0), (x0 + 3.8, length_m)], [(x0, length_m), (x0, 0.0)]
    if left_hand:
        north, south = north[::-1], south[::-1]
    return [(north, tags), (south, tags)]


def _write(tmp_path: Path, lines: list) -> Path:
    b = OsmBuilder()
    for pts, tags in lines:
        b.line(pts, **tags)
    return b.write_xml(tmp_path / "f.osm")


def test_without_tagged_double_track_auto_is_right_hand(tmp_path):
    path = _write(tmp_path, _pair(0.0, 300.0, left_hand=False))  # untagged only
    auto, right = trackmap.build(path), trackmap.build(path, driving_side="right")
    assert auto == right and auto.metadata.driving_side == "right"
    assert auto.metadata.source["driving_side_evidence"] == {"right_m": 0.0, "left_m": 0.0}


def test_a_short_tagged_pair_does_not_decide(tmp_path):
    # 2 x 150 m of left-hand running is below the 400 m that decides
    lines = _pair(0.0, 150.0, left_hand=True, oneway="yes") + _pair(100.0, 300.0, left_hand=False)
    net = trackmap.build(_write(tmp_path, lines))
    assert net.metadata.driving_side == "right"
    assert net.metadata.source["driving_side_evidence"]["left_m"] == pytest.approx(300.0)


def test_mixed_tags_fall_back_to_right_hand_with_a_warning(tmp_path, caplog):
    lines = [
        *_pair(0.0, 400.0, left_hand=True, oneway="yes"),
        *_pair(100.0, 400.0, left_hand=False, oneway="yes"),
        *_pair(200.0, 300.0, left_hand=True),  # untagged: takes the fallback
    ]
    with caplog.at_level(logging.WARNING, logger="trackmap"):
        net = trackmap.build(_write(tmp_path, lines))
    assert net.metadata.driving_side == "right"
    assert any("too mixed" in r.getMessage() for r in caplog.records)


def test_the_side_and_its_evidence_survive_the_map_file(cities, tmp_path, capsys):
    _, left_file = cities
    net = trackmap.build(left_file)
    saved = net.save(tmp_path / "left.tmap")
    again = trackmap.load(saved)
    assert again == net
    assert (
        again.metadata.source["driving_side_evidence"]
        == (net.metadata.source["driving_side_evidence"])
    )
    assert json.loads(saved.read_text())["trackmap"]["build"]["driving_side"] == "auto"
    assert trackmap_main(["info", str(saved)]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if "driving_side" in x)
    assert "left (asked auto; tagged double track" in line and "km left-hand" in line


def test_an_unknown_side_is_refused(tmp_path):
    path = _write(tmp_path, _pair(0.0, 300.0, left_hand=False))
    with pytest.raises(trackmap.ParameterError, match="'auto', 'right' or 'left'"):
        trackmap.build(path, driving_side="middle")


def test_resolving_follows_the_tally():
    left = DrivingSideTally(right_m=100.0, left_m=5000.0)
    assert resolve_driving_side("auto", left) == "left"
    assert resolve_driving_side("right", left) == "right"
    assert resolve_driving_side("auto", DrivingSideTally(right_m=300.0)) == "right"
    assert DrivingSideTally(right_m=300.0).side() is None  # too little to tell
    assert DrivingSideTally(right_m=2000.0, left_m=1000.0).side() is None  # mixed
    assert DrivingSideTally(right_m=2000.0, left_m=1000.0).side(dominance=0.6) == "right"


# -- the vectorised neighbour search against a sample-by-sample one ------------------------
def _one_by_one(lines, candidates, *, lo, hi, step=5.0, max_angle=20.0):
    """Each sample point on its own: the nearest parallel neighbour within [lo, hi] m."""
    out = {}
    for e in candidates:
        line = lines[e]
        n = max(int(line.length // step), 1)
        left = right = 0
        for i in range(n):
            s = (i + 0.5) * line.length / n
            p = line.interpolate(s)
            a = line.interpolate(min(s + 1.0, line.length))
            b = line.interpolate(max(s - 1.0, 0.0))
            tx, ty = a.x - b.x, a.y - b.y
            norm = math.hypot(tx, ty) or 1.0
            tx, ty = tx / norm, ty / norm
            best = None
            for o, other in enumerate(lines):
                d = p.distance(other)
                if o == e or not lo <= d <= hi:
                    continue
                at = other.project(p)
                q = other.interpolate(at)
                q2 = other.interpolate(min(at + 1.0, other.length))
                q1 = other.interpolate(max(at - 1.0, 0.0))
                ox, oy = q2.x - q1.x, q2.y - q1.y
                on = math.hypot(ox, oy)
                if on == 0 or abs((ox * tx + oy * ty) / on) < math.cos(math.radians(max_angle)):
                    continue
                if best is None or d < best[0]:
                    best = (d, tx * (q.y - p.y) - ty * (q.x - p.x) > 0)
            if best is not None:
                left += best[1]
                right += not best[1]
        out[e] = SideEvidence(samples=n, left=left, right=right)
    return out


_xy = st.floats(-60.0, 60.0, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.lists(st.tuples(_xy, _xy), min_size=2, max_size=4), min_size=1, max_size=5),
    st.floats(0.0, 3.0),
    st.floats(3.5, 12.0),
)
def test_parallel_neighbours_counts_each_sample_as_one_at_a_time(paths, lo, hi):
    # pairs of parallel copies, so that neighbours exist, plus the random lines themselves
    lines = []
    for pts in paths:
        base = shapely.LineString(pts)
        if base.length == 0:
            continue
        lines += [base, shapely.offset_curve(base, 4.0)]
    lines = [g for g in lines if isinstance(g, shapely.LineString) and g.length > 0]
    if not lines:
        return
    everything = list(range(len(lines)))
    fast = parallel_neighbours(lines, everything, min_spacing_m=lo, max_spacing_m=hi)
    slow = _one_by_one(lines, everything, lo=lo, hi=hi)
    for e in everything:
        # (a sample exactly as near to two neighbours may fall to either: allow it)
        f, s = fast[e], slow[e]
        assert f.samples == s.samples
        assert f.left + f.right == s.left + s.right
        assert abs(f.left - s.left) <= _ties(lines, e)


def _ties(lines, e) -> int:
    """Samples of edge ``e`` whose two nearest other lines are equally near (to 1 um)."""
    line = lines[e]
    n = max(int(line.length // 5.0), 1)
    count = 0
    for i in range(n):
        p = line.interpolate((i + 0.5) * line.length / n)
        d = sorted(p.distance(o) for k, o in enumerate(lines) if k != e)
        count += len(d) > 1 and abs(d[0] - d[1]) < 1e-6
    return count


def test_no_candidates_no_evidence():
    assert parallel_neighbours([shapely.LineString([(0, 0), (1, 0)])], [], min_spacing_m=1.0,
                               max_spacing_m=2.0) == {}  # fmt: skip
    assert np.isclose(DrivingSideTally().total_m, 0.0)
