"""trackmap on small synthetic fixtures: reading, topology, directions, conflicts, queries."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import trackmap
from tests._osm import FRAME, OsmBuilder, diamond_fixture, switch_fixture
from trackmap.check import check


def build(b: OsmBuilder, tmp_path, fmt="xml", **kw) -> trackmap.TrackMap:
    writer = {
        "xml": (b.write_xml, "f.osm"),
        "overpass": (b.write_overpass, "f.json"),
        "geojson": (b.write_geojson, "f.geojson"),
    }[fmt]
    return trackmap.build(writer[0](tmp_path / writer[1]), **kw)


def classes(net):
    out = {}
    for n in net.nodes.values():
        out[n.cls] = out.get(n.cls, 0) + 1
    return out


def step_is_allowed(net, a, b):
    """Independent check that moving from step a to step b is a permitted move."""
    ea, eb = net.edges[a.edge_id], net.edges[b.edge_id]
    node_id = ea.end_node if a.direction == 1 else ea.start_node
    entry = eb.start_node if b.direction == 1 else eb.end_node
    if node_id != entry or not ea.allows(a.direction) or not eb.allows(b.direction):
        return False
    node = net.nodes[node_id]
    end_a = (a.edge_id, 1 if a.direction == 1 else 0)
    end_b = (b.edge_id, 0 if b.direction == 1 else 1)
    ia, ib = node.ends.index(end_a), node.ends.index(end_b)
    return tuple(sorted((ia, ib))) in node.allowed


# -- reading and errors -------------------------------------------------------------------
@pytest.mark.parametrize("fmt", ["xml", "overpass", "geojson"])
def test_same_network_from_every_format(tmp_path, fmt):
    net = build(switch_fixture(), tmp_path, fmt)
    assert classes(net) == {"buffer_stop": 3, "point_switch": 1}
    assert len(net.edges) == 3
    branch = [(0, 0), (1.0, 10.0), (4.0, 20.0), (9.0, 30.0), (30.0, 55.0), (80.0, 80.0)]
    branch_m = sum(math.dist(a, b) for a, b in itertools.pairwise(branch))
    assert net.stats()["track_km"] == pytest.approx((400.0 + branch_m) / 1000.0, abs=1e-4)


def test_source_errors_name_the_file(tmp_path):
    with pytest.raises(trackmap.SourceError, match="nope.osm"):
        trackmap.build(tmp_path / "nope.osm")
    (tmp_path / "empty.osm").write_text("")
    with pytest.raises(trackmap.SourceFormatError, match="empty.osm: empty"):
        trackmap.build(tmp_path / "empty.osm")
    (tmp_path / "x.shp").write_text("data")
    with pytest.raises(trackmap.SourceFormatError, match="unknown source format"):
        trackmap.build(tmp_path / "x.shp")
    (tmp_path / "bad.json").write_text('{"elements": [ broken')
    with pytest.raises(trackmap.SourceFormatError, match="bad.json: invalid JSON"):
        trackmap.build(tmp_path / "bad.json")
    (tmp_path / "garbage.osm").write_text("<osm><way id='1'><nd ref='x'/>")
    with pytest.raises(trackmap.TrackMapError, match="garbage.osm"):
        trackmap.build(tmp_path / "garbage.osm")
    with pytest.raises(ValueError, match="unknown track kinds"):
        trackmap.build(switch_fixture().write_xml(tmp_path / "s.osm"), kinds=("monorail",))


def test_whole_city_extract_is_filtered(tmp_path):
    b = switch_fixture()
    b.ways.append((900, [b.node(50, 0), b.node(60, 0)], {"highway": "residential"}))
    b.ways.append(
        (901, [b.node(50, 5), b.node(60, 5), b.node(60, 15), b.node(50, 5)], {"building": "yes"})
    )
    b.ways.append((902, [b.node(-50, 0), b.node(-50, 100)], {"railway": "disused"}))
    b.ways.append((903, [b.node(-60, 0), b.node(-60, 100)], {"railway": "tram", "disused": "yes"}))
    b.ways.append(
        (
            904,
            [b.node(-70, 0), b.node(-70, 100)],
            {"railway": "construction", "construction": "tram"},
        )
    )
    b.ways.append((905, [b.node(-80, 0), b.node(-80, 100)], {"railway": "rail"}))
    b.ways.append((906, [b.node(-90, 0), b.node(-90, 100)], {"railway": "tram", "service": "yard"}))
    net = build(b, tmp_path)
    ways = {w for e in net.edges for w in e.way_ids}
    assert ways == {1, 2, 3, 906}
    assert [e.service for e in net.edges if 906 in e.way_ids] == ["yard"]
    both = build(b, tmp_path, kinds=("tram", "rail"))
    assert 905 in {w for e in both.edges for w in e.way_ids}


def test_file_without_tracks_is_a_clear_error(tmp_path):
    b = OsmBuilder()
    b.ways.append((1, [b.node(0, 0), b.node(10, 0)], {"highway": "primary"}))
    with pytest.raises(trackmap.NoTracksError, match="no operating track"):
        build(b, tmp_path)


# -- topology -----------------------------------------------------------------------------
def test_point_switch_moves(tmp_path):
    net = build(switch_fixture(), tmp_path)
    trunk = next(e for e in net.edges if 1 in e.way_ids)
    straight = next(e for e in net.edges if 2 in e.way_ids)
    branch = next(e for e in net.edges if 3 in e.way_ids)
    # facing the switch from the trunk: two zones
    paths = net.paths_ahead(trunk.edge_id, 150.0, 1, 150.0)
    assert sorted(p.edges for p in paths) == sorted(
        [(trunk.edge_id, straight.edge_id), (trunk.edge_id, branch.edge_id)]
    )
    zones = {p.edges[-1]: p.zone for p in paths}
    assert zones[straight.edge_id] == "straight" and zones[branch.edge_id] == "right"
    assert all(p.switches[0].distance_m == pytest.approx(50.0, abs=0.01) for p in paths)
    # trailing through the switch from either branch leads to the trunk only
    for e in (straight, branch):
        back = net.paths_ahead(e.edge_id, 20.0, -1, 300.0)
        assert [p.edges for p in back] == [(e.edge_id, trunk.edge_id)]
        assert back[0].end == "buffer_stop"
    # never reversing through the switch: branch -> straight is impossible
    assert net.route_distance(branch.edge_id, 20.0, -1, straight.edge_id, 20.0) is None


def test_merge_conflict_point_and_fouling(tmp_path):
    net = build(switch_fixture(), tmp_path)
    merges = [c for c in net.conflicts if c.kind == "merge"]
    assert len(merges) == 1
    m = merges[0]
    assert net.edges[m.edges[0]].way_ids == (1,)
    # branches separate to 3.2 m within the first few tens of metres
    assert all(5.0 < ext < 40.0 for ext in m.extents_m[1:])


@pytest.mark.parametrize("angle", [90.0, 60.0, 25.0])
def test_diamond_crossing_is_straight_only(tmp_path, angle):
    net = build(diamond_fixture(angle), tmp_path)
    assert classes(net) == {"buffer_stop": 4, "diamond_crossing": 1}
    (c,) = net.conflicts
    assert c.kind == "diamond_crossing"
    for e in net.edges:
        for d in (1, -1):
            off = 75.0
            for p in net.paths_ahead(e.edge_id, off, d, 500.0):
                assert len(p.edges) <= 2
                if len(p.edges) == 2:
                    a, b = net.edges[p.edges[0]], net.edges[p.edges[1]]
                    assert a.way_ids == b.way_ids, "a path must not turn at a diamond"
                    assert [cp.kind for cp in p.conflicts] == ["diamond_crossing"]


def test_double_slip_tagged_and_geometric(tmp_path):
    # tagged slip at a shallow crossing: turning moves exist
    b = diamond_fixture(15.0)
    centre = next(
        n for n, v in b.nodes.items() if abs(v[0] - 19.94) < 1e-6 and abs(v[1] - 50.06) < 1e-6
    )
    b.nodes[centre][2]["railway:switch"] = "double_slip"
    net = build(b, tmp_path)
    assert classes(net)["double_slip"] == 1
    node = next(n for n in net.nodes.values() if n.cls == "double_slip")
    assert len(node.allowed) == 4
    # untagged four separate ways meeting at a shallow angle: OSRD's rule says double slip
    b2 = OsmBuilder()
    c = b2.node(0, 0)
    a = math.radians(15.0)
    for x, y in [
        (0, -100),
        (0, 100),
        (100 * math.sin(a), 100 * math.cos(a)),
        (-100 * math.sin(a), -100 * math.cos(a)),
    ]:
        b2.line([(x, y), c])
    assert classes(build(b2, tmp_path))["double_slip"] == 1


def test_balloon_loop(tmp_path):
    b = OsmBuilder()
    toe = b.node(0, 0)
    b.line([(0, -100), toe])
    # teardrop: leaves the toe at 14.5 degrees each side, turns round a 20 m radius
    pts = [(9.68, 37.5), *b.arc(0, 80, 20, -14.48, 194.48, n=24), (-9.68, 37.5)]
    ids = [toe] + [b.node(x, y) for x, y in pts] + [toe]
    b.line(ids)
    net = build(b, tmp_path)
    assert classes(net) == {"buffer_stop": 1, "point_switch": 1}
    trunk = next(e for e in net.edges if e.way_ids == (1,))
    paths = net.paths_ahead(trunk.edge_id, 50.0, 1, 150.0)
    assert len(paths) == 2  # round the loop either way
    for p in paths:
        for s1, s2 in zip(p.steps, p.steps[1:], strict=False):
            assert step_is_allowed(net, s1, s2)


def test_double_track_direction_from_driving_side(tmp_path):
    def pair(**tags):
        b = OsmBuilder()
        b.line([(0, 0), (0, 300)], **tags)  # west track, drawn northwards
        b.line([(3.8, 300), (3.8, 0)], **tags)  # east track, drawn southwards
        return b

    right = build(pair(), tmp_path, driving_side="right")
    west = next(e for e in right.edges if e.way_ids == (1,))
    east = next(e for e in right.edges if e.way_ids == (2,))
    # right-hand running: the east track carries northbound trams
    assert west.direction_source == east.direction_source == "driving_side"
    assert west.direction == -1 and east.direction == -1
    left = build(pair(), tmp_path, driving_side="left")
    assert [e.direction for e in left.edges] == [1, 1]
    tagged = build(pair(oneway="yes"), tmp_path, driving_side="right")
    assert [(e.direction, e.direction_source) for e in tagged.edges] == [(1, "oneway")] * 2
    single = OsmBuilder()
    single.line([(0, 0), (0, 300)])
    assert build(single, tmp_path).edges[0].direction == 0
    pref = OsmBuilder()
    pref.line([(0, 0), (0, 300)], **{"railway:preferred_direction": "backward", "oneway": "yes"})
    e = build(pref, tmp_path).edges[0]
    assert (e.direction, e.direction_source) == (-1, "preferred_direction")


def test_running_direction_is_respected_by_paths(tmp_path):
    b = OsmBuilder()
    b.line([(0, 0), (0, 300)], oneway="yes")
    net = build(b, tmp_path)
    with pytest.raises(trackmap.UnknownEdgeError):
        net.paths_ahead(99, 0.0, 1, 10.0)
    assert net.route_distance(0, 10.0, 1, 0, 100.0).distance_m == pytest.approx(90.0)
    assert net.route_distance(0, 100.0, -1, 0, 10.0) is None


def test_crossings_at_grade_and_grade_separated(tmp_path):
    b = OsmBuilder()
    b.line([(0, -100), (0, 100)])
    b.line([(-100, 0), (100, 0)])  # at grade, no shared node
    b.line([(-100, 50), (100, 50)], bridge="yes", layer="1")
    b.line([(-100, -50), (100, -50)], tunnel="yes", layer="-1")
    b.line([(-100, -80), (100, -80)], layer="1")
    net = build(b, tmp_path)
    crossing = [c for c in net.conflicts if c.kind == "crossing"]
    assert len(crossing) == 1 and crossing[0].angle_deg == pytest.approx(90.0, abs=0.5)
    assert len(net.grade_separated) == 3
    north = net.paths_ahead(0, 10.0, 1, 150.0)
    assert [c.kind for c in north[0].conflicts] == ["crossing"]
    assert north[0].conflicts[0].distance_m == pytest.approx(90.0, abs=0.01)
    report = check(net)
    assert report.counts().get("unnoded_crossing") == 1


def test_junction_curve_cutting_across_the_opposite_track(tmp_path):
    # a double track with a curve leaving the east track and crossing the west one unnoded
    b = OsmBuilder()
    b.line([(0, 0), (0, 300)], oneway="yes")
    toe = b.node(3.8, 200)
    b.line([(3.8, 300), toe, (3.8, 0)], oneway="yes")
    b.line([toe, *b.arc(-21.2, 200, 25.0, 0, -90, n=12)[1:], (-150.0, 175.0)], oneway="yes")
    net = build(b, tmp_path)
    kinds = sorted(c.kind for c in net.conflicts)
    assert kinds == ["crossing", "merge"]


def test_merged_chains_keep_way_ids(tmp_path):
    b = OsmBuilder()
    n1, n2 = b.node(0, 100), b.node(0, 200)
    b.line([(0, 0), n1])
    b.line([n1, n2])
    b.line([(0, 300), n2])  # drawn the other way: merged and reversed
    net = build(b, tmp_path)
    assert len(net.edges) == 1
    assert net.edges[0].way_ids == (1, 2, 3)
    assert net.edges[0].length_m == pytest.approx(300.0, abs=0.01)


def test_duplicate_ways_are_kept_once_and_reported(tmp_path):
    b = OsmBuilder()
    n1, n2 = b.node(0, 100), b.node(0, 101)
    b.line([(0, 0), n1])
    b.line([n1, n2])
    b.line([n2, n1])  # the same two nodes again, drawn the other way
    b.line([n2, (0, 300)])
    net = build(b, tmp_path)
    assert not [c for c in net.conflicts if c.kind == "crossing"]
    assert len(net.edges) == 1 and set(net.edges[0].way_ids) == {1, 2, 3, 4}
    assert check(net).counts()["duplicate_track"] == 1


def test_untagged_piece_between_one_way_links_takes_their_direction(tmp_path):
    b = OsmBuilder()
    n1, n2 = b.node(0, 100), b.node(0, 200)
    b.line([(0, 0), n1], oneway="yes")
    b.line([n1, n2], maxspeed="30")  # untagged, differs in maxspeed so stays separate
    b.line([n2, (0, 300)], oneway="yes")
    net = build(b, tmp_path)
    middle = next(e for e in net.edges if e.way_ids == (2,))
    assert (middle.direction, middle.direction_source) == (1, "propagated")
    assert middle.maxspeed_mps == pytest.approx(30 / 3.6)


def test_bridge_splits_chain_but_not_topology(tmp_path):
    b = OsmBuilder()
    n1, n2 = b.node(0, 100), b.node(0, 150)
    b.line([(0, 0), n1])
    b.line([n1, n2], bridge="yes", layer="1")
    b.line([n2, (0, 300)])
    net = build(b, tmp_path)
    assert len(net.edges) == 3
    assert classes(net) == {"buffer_stop": 2, "link": 2}
    assert len(net.paths_ahead(0, 10.0, 1, 250.0)[0].edges) == 3


# -- queries ------------------------------------------------------------------------------
def test_candidates_lateral_offset_heading(tmp_path):
    b = OsmBuilder()
    b.line([(0, 0), (0, 300)])
    net = build(b, tmp_path)
    lon, lat = FRAME.to_lonlat(-2.0, 120.0)
    (c,) = net.candidates(lon, lat, 10.0)
    assert c.offset_m == pytest.approx(120.0, abs=0.05)
    assert c.lateral_m == pytest.approx(2.0, abs=0.05)  # west of a northbound line: left
    assert c.heading_deg == pytest.approx(0.0, abs=0.2) or c.heading_deg == pytest.approx(
        360.0, abs=0.2
    )
    assert net.candidates(lon, lat, 1.0) == []
    with pytest.raises(ValueError):
        net.candidates(lon, lat, 0.0)


@settings(max_examples=30)
@given(xs=st.lists(st.tuples(st.floats(-60, 60), st.floats(-220, 220)), min_size=1, max_size=15))
def test_batch_candidates_equal_single(switch_net, xs):
    net = switch_net
    x = np.array([p[0] for p in xs])
    y = np.array([p[1] for p in xs])
    lon, lat = net.to_lonlat(x, y)
    batch = net.candidates_batch(lon, lat, 30.0)
    for i in range(len(xs)):
        single = net.candidates(float(lon[i]), float(lat[i]), 30.0)
        rows = np.flatnonzero(batch.point == i)
        assert sorted(int(batch.edge_id[r]) for r in rows) == sorted(c.edge_id for c in single)
        for c in single:
            r = rows[batch.edge_id[rows] == c.edge_id][0]
            assert batch.offset_m[r] == pytest.approx(c.offset_m)
            assert batch.lateral_m[r] == pytest.approx(c.lateral_m)


def test_nan_positions_give_no_candidates(switch_net):
    x, y = switch_net.to_local(*FRAME.to_lonlat(0.0, -10.0))
    batch = switch_net.candidates_batch_xy(np.array([np.nan, x]), np.array([0.0, y]), 5.0)
    assert set(batch.point.tolist()) == {1}


def test_route_distance_through_switch(tmp_path):
    net = build(switch_fixture(), tmp_path)
    trunk = next(e for e in net.edges if 1 in e.way_ids)
    branch = next(e for e in net.edges if 3 in e.way_ids)
    r = net.route_distance(trunk.edge_id, 100.0, 1, branch.edge_id, 10.0)
    assert r.distance_m == pytest.approx(110.0, abs=0.01)
    assert r.edges == (trunk.edge_id, branch.edge_id) and r.arrival_direction == 1
    assert net.route_distance(trunk.edge_id, 100.0, 1, branch.edge_id, 10.0, cutoff_m=50.0) is None


# -- map file -----------------------------------------------------------------------------
def test_save_load_round_trip_and_validation(tmp_path):
    net = build(switch_fixture(), tmp_path)
    path = net.save(tmp_path / "m.trackmap.geojson")
    again = trackmap.load(path)
    assert again == net
    assert again.paths_ahead(0, 10.0, 1, 300.0) == net.paths_ahead(0, 10.0, 1, 300.0)
    doc = json.loads(path.read_text())
    assert doc["type"] == "FeatureCollection" and doc["trackmap"]["version"] == 1
    assert "ODbL" in doc["trackmap"]["attribution"]
    assert doc["trackmap"]["crs_wkt"].startswith(("PROJCRS", "BOUNDCRS"))

    def broken(mutate, match):
        d = json.loads(path.read_text())
        mutate(d)
        p = tmp_path / "broken.geojson"
        p.write_text(json.dumps(d))
        with pytest.raises(trackmap.MapFileError, match=match):
            trackmap.load(p)

    broken(lambda d: d["trackmap"].update(version=99), "version 99 is not supported")
    broken(lambda d: d.pop("trackmap"), "not a trackmap map file")
    broken(lambda d: d["features"][0]["properties"].pop("direction"), "missing 'direction'")
    broken(lambda d: d["features"][0]["geometry"].update(coordinates=[[1, 2]]), "at least 2")
    broken(
        lambda d: d["features"][0]["geometry"]["coordinates"][0].__setitem__(1, 95.0),
        r"feature 0 \(edge 0\): geometry.coordinates\[0\]\[1\] must be smaller than or equal to 90",
    )
    broken(lambda d: d["features"].pop(0), "edge ids")
    broken(lambda d: d["trackmap"].update(crs_wkt="nonsense"), "CRS")
    (tmp_path / "x.geojson").write_text("{not json")
    with pytest.raises(trackmap.MapFileError, match="x.geojson: not valid JSON"):
        trackmap.load(tmp_path / "x.geojson")
    with pytest.raises(trackmap.SourceError):
        trackmap.load(tmp_path / "missing.geojson")
    with pytest.raises(trackmap.SourceFormatError, match="trackmap.load"):
        trackmap.build(path)


def test_local_frame_round_trip():
    lon, lat = np.array([19.9, 20.0]), np.array([50.0, 50.1])
    x, y = FRAME.to_local(lon, lat)
    lon2, lat2 = FRAME.to_lonlat(x, y)
    assert np.allclose(lon2, lon, atol=1e-10) and np.allclose(lat2, lat, atol=1e-10)
    assert isinstance(FRAME.to_local(19.94, 50.06)[0], float)


def test_direction_tags_that_disagree_or_cannot_be_read_are_listed(tmp_path):
    b = OsmBuilder()
    # railway:preferred_direction wins over oneway; the disagreement is listed
    both = b.line([(0, 0), (0, 100)], **{"railway:preferred_direction": "forward", "oneway": "-1"})
    odd = b.line([(50, 0), (50, 100)], oneway="yes;no")  # no running direction: untagged
    b.line([(100, 0), (100, 100)], oneway="reversible")  # both ways, one at a time
    b.line([(150, 0), (150, 100)], **{"railway:preferred_direction": "both", "oneway": "no"})
    net = build(b, tmp_path)
    by_way = {e.way_ids[0]: e for e in net.edges}
    assert (by_way[both].direction, by_way[both].direction_source) == (1, "preferred_direction")
    assert by_way[odd].direction_source != "oneway"
    reversible = by_way[odd + 1]
    assert (reversible.direction, reversible.direction_source) == (0, "oneway")
    found = [f for f in check(net).warnings if f.code == "direction_tags"]
    assert {f.message.split(":")[0] for f in found} == {f"way {both}", f"way {odd}"}
    first = next(f for f in found if f.message.startswith(f"way {both}"))
    assert "disagree" in first.message and first.edges == (by_way[both].edge_id,)
    assert first.lon is not None and first.lat is not None
    assert "oneway=yes;no is not a running direction" in next(
        f.message for f in found if f is not first
    )
    # the list survives the map file
    path = tmp_path / "m.json"
    net.save(path)
    again = [f.message for f in check(trackmap.load(path)).warnings if f.code == "direction_tags"]
    assert sorted(again) == sorted(f.message for f in found)


def test_a_way_drawn_for_two_tracks_runs_both_ways_and_is_listed(tmp_path):
    b = OsmBuilder()
    # a double track drawn as two one-way lines 3.5 m apart, then as one line (tracks=2)
    b.line([(0.0, 0), (0.0, 300)], oneway="yes")
    b.line([(3.5, 300), (3.5, 0)], oneway="yes")
    one = b.line([(200, 0), (200, 300)], tracks="2")
    beside = b.line([(203.5, 0), (203.5, 300)])  # untagged, beside it: not paired with it
    net = build(b, tmp_path)
    by_way = {e.way_ids[0]: e for e in net.edges}
    assert (by_way[one].direction, by_way[one].direction_source) == (0, "tracks")
    assert by_way[beside].direction_source != "tracks"
    found = [f for f in check(net).warnings if f.code == "multi_track_way"]
    assert [f.edges for f in found] == [(by_way[one].edge_id,)]
    assert found[0].message.startswith(f"way {one} is one line for 2 tracks")


_TAG_TEXT = st.one_of(
    st.sampled_from(["yes", "no", "-1", "forward", "backward", "both", "2", "reversible"]),
    st.text(max_size=8),
)


@settings(max_examples=300, deadline=None)
@given(
    st.dictionaries(st.sampled_from(["railway:preferred_direction", "oneway", "tracks"]), _TAG_TEXT)
)
@example({"tracks": "²"})  # (a digit to str.isdigit, not to int())
def test_direction_tags_of_any_text_are_read_without_error(tags):
    from trackmap.builder.topology import direction_tag, direction_tag_doubt, drawn_tracks

    direction, source = direction_tag(tags)
    assert direction in (-1, 0, 1)
    assert source in ("preferred_direction", "oneway", "tracks", "none")
    assert 1 <= drawn_tracks(tags) <= 20
    doubt = direction_tag_doubt(tags)
    if doubt is None and source == "none":  # (nothing readable, nothing doubtful: no tags)
        assert not {"railway:preferred_direction", "oneway"} & set(tags)


def test_check_finds_errors(tmp_path):
    b = OsmBuilder()
    n = b.node(0, 100)
    b.line([(0, 0), n], oneway="yes")
    b.line([(0, 200), n], oneway="yes")  # head to head with the first
    b.line([(0.8, 120), (30, 120)])  # ends 0.8 m from the track: dangling
    b.line([(50, 0), (50, 0.5)])  # 0.5 m edge
    report = check(build(b, tmp_path))
    codes = report.counts()
    assert codes["contradictory_direction"] == 1
    assert codes["dangling_end"] == 1
    assert codes["short_edge"] == 1
    assert codes["components"] == 1
    assert not report.ok
    assert check(build(switch_fixture(), tmp_path)).ok


@pytest.fixture(scope="module")
def switch_net(tmp_path_factory: pytest.TempPathFactory) -> trackmap.TrackMap:
    return trackmap.build(switch_fixture().write_xml(tmp_path_factory.mktemp("sw") / "s.osm"))


@pytest.fixture(scope="module")
def krakow() -> trackmap.TrackMap:
    return trackmap.load_default()


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.integers(min_value=0, max_value=10**6),
            st.floats(min_value=-0.2, max_value=1.2, allow_nan=False),
            st.sampled_from([1, -1]),
        ),
        min_size=1,
        max_size=40,
    )
)
def test_vectorised_headings_and_points_are_the_scalar_ones_to_the_last_bit(krakow, rows):
    # the positioning's batched outputs rely on it: same numbers as one call per position
    n = len(krakow.edges)
    edges = [e % n for e, _, _ in rows]
    offsets = [f * krakow.edge_length(e) for e, (_, f, _) in zip(edges, rows, strict=True)]
    dirs = [d for _, _, d in rows]
    headings = krakow.headings_at(edges, offsets, dirs)
    x, y = krakow.points_at(edges, offsets)
    for k, (e, o, d) in enumerate(zip(edges, offsets, dirs, strict=True)):
        assert float(headings[k]) == krakow.heading_at(e, o, d)
        assert (float(x[k]), float(y[k])) == krakow.point_at(e, o)
