"""Broken sources get a clear answer; extracts cut by a bounding box keep their pieces.

Issue 14: every failure of ``trackmap.build`` is a SourceFormatError naming the file, the
element and what is wrong, and implausible geometry never builds quietly. Issue 11
(finding 2): ways cut by an extract's bounding box keep their located pieces, counted in
the build report and listed by ``trackmap check`` as map boundaries, not as data errors.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from pyproj import Geod

import trackmap
from tests._fuzz import base_network
from tests._osm import OsmBuilder
from trackmap.check import check
from trackmap.cli import main as trackmap_main

_GEOD = Geod(ellps="WGS84")
PBF = Path(__file__).resolve().parent.parent / "maps" / "krakow-tram-2023-12-14.osm.pbf"
#: A box over Kraków's city centre, as an extract tool would cut it.
BOX = (19.925, 50.050, 19.960, 50.070)


# -- broken sources -----------------------------------------------------------------------
def _overpass(tmp_path: Path, edit: Any) -> Path:
    path = base_network().write_overpass(tmp_path / "src.json")
    doc = json.loads(path.read_text())
    edit(doc)
    path.write_text(json.dumps(doc))
    return path


def _first(doc: dict[str, Any], typ: str) -> dict[str, Any]:
    return next(e for e in doc["elements"] if e["type"] == typ)


OVERPASS_CASES = {
    "tags as a list": (
        lambda d: _first(d, "way").__setitem__("tags", ["railway", "tram"]),
        r"element 18 \(way 1\): 'tags' must be an object",
    ),
    "nodes as a string": (
        lambda d: _first(d, "way").__setitem__("nodes", "12"),
        r"element 18 \(way 1\): 'nodes' must be a list of node ids, got a string '12'",
    ),
    "geometry without lon": (
        lambda d: (
            _first(d, "way").__setitem__("geometry", [{"lat": 50.0}] * 5),
            d["elements"].pop(0),
        ),
        r"\(way 1\): geometry\[2\]: lon None, lat 50.0 is not a valid WGS84 position",
    ),
    "node id 'x'": (
        lambda d: _first(d, "node").__setitem__("id", "x"),
        r"element 0: id must be an integer id, got a string 'x'",
    ),
    "latitude 91": (
        lambda d: _first(d, "node").__setitem__("lat", 91.0),
        r"element 0 \(node 1000\): lon .*, lat 91.0 is not a valid WGS84 position",
    ),
    "latitude NaN": (
        lambda d: _first(d, "node").__setitem__("lat", float("nan")),
        r"element 0 \(node 1000\): lon .*, lat nan is not a valid WGS84 position",
    ),
    "tag value of 100,000 characters": (
        lambda d: _first(d, "way")["tags"].__setitem__("name", "x" * 100_000),
        r"\(way 1\): tags.name is 100,000 characters long; OSM allows 255",
    ),
}


@pytest.mark.parametrize("case", list(OVERPASS_CASES))
def test_broken_overpass_json_is_a_clear_error(case, tmp_path):
    edit, message = OVERPASS_CASES[case]
    path = _overpass(tmp_path, edit)
    with pytest.raises(trackmap.SourceFormatError, match=message) as err:
        trackmap.build(path)
    assert str(err.value).startswith(str(path)) and len(str(err.value)) < 400


def _osm_xml(tmp_path: Path, old: str, new: str) -> Path:
    path = base_network().write_xml(tmp_path / "src.osm")
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    return path


def test_a_5000_digit_number_is_a_json_error(tmp_path):
    path = base_network().write_overpass(tmp_path / "src.json")
    path.write_text(path.read_text().replace('"nodes": [', '"nodes": [' + "9" * 5000 + ", ", 1))
    with pytest.raises(trackmap.SourceFormatError, match=r"src.json: invalid JSON: .*4300"):
        trackmap.build(path)


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('lat="', 'lat="nan" x="', r"cannot parse as an OSM file: .*coordinate"),
        ('<nd ref="', '<nd ref="x', r"cannot parse as an OSM file: illegal id"),
        ('<way id="', '<way id="' + "9" * 5000, r"cannot parse as an OSM file: illegal id"),
    ],
)
def test_broken_osm_xml_is_a_clear_error(old, new, message, tmp_path):
    path = _osm_xml(tmp_path, old, new)
    with pytest.raises(trackmap.SourceFormatError, match=message) as err:
        trackmap.build(path)
    assert str(err.value).startswith(str(path)) and len(str(err.value)) < 400


def test_a_coordinate_far_from_the_network_names_the_node(tmp_path):
    # osmium reads lon="1e300" as 0.0: the build used to make a 1,427 km edge of it
    path = _osm_xml(tmp_path, 'lon="', 'lon="1e300" x="')
    with pytest.raises(trackmap.SourceFormatError, match=r"node 1000 at \(0.0000000, 50.06"):
        trackmap.build(path)


def test_a_pole_to_pole_way_does_not_build(tmp_path):
    b = base_network()
    b.line([(0, 0), (10, 10)])
    _, refs, _ = b.ways[-1]
    b.nodes[refs[0]] = (19.94, -89.9, {})
    b.nodes[refs[1]] = (19.94, 89.9, {})
    with pytest.raises(trackmap.SourceFormatError, match="a map spans at most 500 km"):
        trackmap.build(b.write_overpass(tmp_path / "pole.json"))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"kinds": "tram,monorail"}, "unknown track kinds"),
        ({"driving_side": "middle"}, "driving_side"),
        ({"max_deflection_deg": float("nan")}, "max_deflection_deg"),
        ({"tangent_probe_m": -1.0}, "tangent_probe_m"),
        ({"parallel_spacing_m": (6.0, 2.5)}, "parallel_spacing_m"),
        ({"stop_snap_m": "15"}, "stop_snap_m"),
    ],
)
def test_bad_build_parameters_are_parameter_errors(kwargs, message, tmp_path):
    src = base_network().write_xml(tmp_path / "s.osm")
    with pytest.raises(trackmap.ParameterError, match=message):
        trackmap.build(src, **kwargs)


def test_check_flags_implausible_geometry(tmp_path):
    b = OsmBuilder()
    b.line([(0, 0), (0, 6000)])  # one 6 km tram edge: a node with wrong coordinates?
    b.line([(100, 0), (100, 100), (100, 50)])  # runs back over itself
    b.line([(200, 0), (200, 100), (250, 50), (150, 50)])  # crosses itself
    report = check(trackmap.build(b.write_overpass(tmp_path / "g.json")))
    codes = report.counts()
    assert codes["long_edge"] == 1 and codes["self_overlapping_edge"] == 1
    assert codes["self_crossing_edge"] == 1
    assert {f.code for f in report.errors} >= {"long_edge", "self_overlapping_edge"}
    long_edge = next(f for f in report.errors if f.code == "long_edge")
    assert "6.0 km long" in long_edge.message


def test_check_flags_vertices_outside_the_declared_bounds(tmp_path):
    b = OsmBuilder()
    b.line([(0, 0), (0, 100), (0, 3000)])
    path = b.write_geojson(tmp_path / "b.geojson")
    doc = json.loads(path.read_text())
    lon, lat = b.nodes[1000][0], b.nodes[1000][1]
    doc["bbox"] = [lon - 0.01, lat - 0.01, lon + 0.01, lat + 0.005]  # ~550 m north
    path.write_text(json.dumps(doc))
    report = check(trackmap.build(path))
    assert [f.code for f in report.warnings] == ["outside_bounds"]
    assert "up to 2.4 km" in report.warnings[0].message


# -- extracts cut by a bounding box (issue 11, finding 2) ---------------------------------
def _inside(lon: float, lat: float) -> bool:
    return BOX[0] <= lon <= BOX[2] and BOX[1] <= lat <= BOX[3]


@pytest.fixture(scope="module")
def krakow() -> dict[str, Any]:
    """The embedded Kraków PBF as plain nodes and ways (read with osmium)."""
    osmium = pytest.importorskip("osmium")
    nodes: dict[int, tuple[float, float, dict[str, str]]] = {}
    ways: list[tuple[int, list[int], dict[str, str]]] = []
    for obj in osmium.FileProcessor(str(PBF)):
        if obj.is_node():
            nodes[obj.id] = (obj.location.lon, obj.location.lat, dict(obj.tags))
        elif obj.is_way():
            ways.append((obj.id, [n.ref for n in obj.nodes], dict(obj.tags)))
    return {"nodes": nodes, "ways": ways}


def _cut(krakow: dict[str, Any]) -> OsmBuilder:
    """The network cut by BOX the way extract tools cut: every way with a node inside keeps
    all its node references; only the nodes inside are kept."""
    b = OsmBuilder()
    b.nodes = {n: v for n, v in krakow["nodes"].items() if _inside(v[0], v[1])}
    b.ways = [w for w in krakow["ways"] if any(n in b.nodes for n in w[1])]
    return b


def _length_inside(net: trackmap.TrackMap) -> float:
    """Geodesic length of the map's segments with both ends inside BOX, metres."""
    total = 0.0
    for e in net.edges:
        for k in range(len(e.lon) - 1):
            if _inside(e.lon[k], e.lat[k]) and _inside(e.lon[k + 1], e.lat[k + 1]):
                total += _GEOD.line_length(e.lon[k : k + 2], e.lat[k : k + 2])
    return total


@pytest.mark.parametrize("fmt", ["overpass", "osm"])
def test_a_cut_extract_keeps_the_located_pieces_of_its_ways(fmt, krakow, tmp_path):
    full = trackmap.build(PBF)
    b = _cut(krakow)
    path = (
        b.write_overpass(tmp_path / "cut.json")
        if fmt == "overpass"
        else b.write_xml(tmp_path / "cut.osm")
    )
    net = trackmap.build(path)
    # every stretch of track inside the box is kept (the old build dropped 18 % of it)
    got = sum(_GEOD.line_length(e.lon, e.lat) for e in net.edges)
    assert got == pytest.approx(_length_inside(full), rel=1e-9)
    inside_switches = [
        n for n in full.nodes.values() if n.cls == "point_switch" and _inside(n.lon, n.lat)
    ]
    assert net.stats()["switches"] == len(inside_switches)
    # ... counted in the build report
    crossing = [w for w in b.ways if any(n not in b.nodes for n in w[1])]
    clipped = net.metadata.source["clipped"]
    assert clipped["ways"] + clipped.get("short_pieces", 0) >= len(crossing) > 10
    assert clipped["missing_refs"] == sum(
        sum(n not in b.nodes for n in w[1]) for w in crossing if w[2].get("railway") == "tram"
    ) - _refs_of_dropped(net, crossing, b)
    boundary = net.metadata.source["boundary_nodes"]
    assert len(boundary) >= clipped["ways"]
    # ... and listed by check as map boundaries, not as data errors
    report = check(net)
    notes = [f for f in report.notes if f.code == "map_boundary"]
    assert {f.node_id for f in notes} == {n for n, _ in boundary}
    assert not any(f.node_id in {n for n, _ in boundary} for f in report.errors)
    # the map file keeps them
    again = trackmap.load(net.save(tmp_path / "cut.trackmap.geojson"))
    assert again.metadata.source["boundary_nodes"] == boundary


def _refs_of_dropped(net: trackmap.TrackMap, crossing: list[Any], b: OsmBuilder) -> int:
    """Missing references of tram ways that kept no piece (counted as dropped, not cut)."""
    kept = {w for e in net.edges for w in e.way_ids}
    kept |= {w for g in net.metadata.source["duplicate_ways"] for w in g}
    return sum(
        sum(n not in b.nodes for n in refs)
        for wid, refs, tags in crossing
        if tags.get("railway") == "tram" and wid not in kept
    )


def test_a_way_cut_twice_gives_two_pieces_and_the_cli_reports_the_cut(tmp_path, capsys):
    b = OsmBuilder()
    ids = [b.node(0, 100.0 * k) for k in range(7)]
    b.line(ids)
    b.line([(50, 0), (50, 100)])
    outside = b.node(300, 0)
    b.line([outside, b.node(300, 100), b.node(300, 200)])
    for n in (ids[0], ids[3], outside):  # its first node, one in the middle, another way's
        del b.nodes[n]
    src = b.write_xml(tmp_path / "cut.osm")
    out = tmp_path / "cut.trackmap.geojson"
    assert trackmap_main(["build", str(src), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "cut by the extract's boundary: 2 way(s) kept as 3 piece(s)" in printed
    net = trackmap.load(out)
    assert net.metadata.source["clipped"] == {"ways": 2, "pieces": 3, "missing_refs": 3}
    assert [n for n, _ in net.metadata.source["boundary_nodes"]] == sorted(
        [ids[1], ids[2], ids[4], b.ways[2][1][1]]
    )
    assert trackmap_main(["check", str(out)]) == 0
    printed = capsys.readouterr().out
    assert printed.count("note: map_boundary") == 4 and "0 error(s)" in printed
