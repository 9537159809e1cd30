"""The embedded Kraków map: plausible figures and paths that obey the topology."""

from __future__ import annotations

import numpy as np
import pytest

import trackmap
from tests.test_trackmap import step_is_allowed
from trackmap.check import check


@pytest.fixture(scope="module")
def net():
    return trackmap.load_default()


def test_stats_in_plausible_ranges(net):
    s = net.stats()
    assert 200.0 <= s["track_km"] <= 215.0
    assert 300 <= s["switches"] <= 800
    assert 10 <= s["diamond_crossings"] <= 300
    assert s["components"] <= 3
    assert s["buffer_stops"] < 100
    assert s["unknown_nodes"] <= 5
    assert s["directed_edges"] > 0.75 * s["edges"]
    assert s["stops"] > 300
    assert s["grade_separated_crossings"] > 0  # bridges and the tunnel


def test_default_map_is_the_embedded_file(net):
    path = trackmap.default_map_path()
    assert path.name == "krakow-tram.trackmap.geojson"
    assert "ODbL" in net.metadata.attribution
    assert (path.parent / "ATTRIBUTION").read_text().count("OpenStreetMap") >= 1


def test_paths_from_random_positions_obey_moves_and_directions(net):
    rng = np.random.default_rng(2008)
    checked = 0
    for _ in range(100):
        e = net.edges[int(rng.integers(len(net.edges)))]
        direction = e.direction if e.direction != 0 else int(rng.choice([1, -1]))
        offset = float(rng.uniform(0, e.length_m))
        paths = net.paths_ahead(e.edge_id, offset, direction, 300.0)
        assert paths
        zones = [p.zone for p in paths]
        assert len(set(zones)) == len(zones), "one zone per branch"
        for p in paths:
            assert p.length_m == pytest.approx(300.0) or p.end in ("buffer_stop", "dead_end")
            assert p.steps[0].edge_id == e.edge_id and p.steps[0].direction == direction
            for s in p.steps:
                assert net.edges[s.edge_id].allows(s.direction)
            for s1, s2 in zip(p.steps, p.steps[1:], strict=False):
                assert step_is_allowed(net, s1, s2)
                assert s2.start_m == pytest.approx(s1.end_m)
                checked += 1
    assert checked > 100


def test_route_distance_matches_paths(net):
    rng = np.random.default_rng(7)
    for _ in range(30):
        e = net.edges[int(rng.integers(len(net.edges)))]
        d = e.direction or 1
        paths = net.paths_ahead(e.edge_id, 0.0 if d == 1 else e.length_m, d, 400.0)
        for p in paths:
            last = p.steps[-1]
            target = last.exit_offset_m
            r = net.route_distance(
                e.edge_id, 0.0 if d == 1 else e.length_m, d, last.edge_id, target
            )
            assert r is not None
            assert r.distance_m <= p.length_m + 1e-6


def test_check_runs_and_reports_real_data_issues(net):
    report = check(net)
    counts = report.counts()
    assert counts.get("unknown_node", 0) == net.stats()["unknown_nodes"]
    assert set(counts) <= {
        "unknown_node",
        "short_edge",
        "contradictory_direction",
        "dangling_end",
        "components",
        "unnoded_crossing",
        "sharp_link",
        "duplicate_track",
        "overlapping_tracks",
    }
