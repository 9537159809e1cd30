"""Broken map files get a clear answer: a MapFileError naming the file, the feature and what
is wrong — never a bare exception, never a map that silently differs from the file.

Every case here is one of issue 14's findings (or next to one); on the code before it,
each ended in a bare exception or loaded without complaint.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from typing import Any

import pytest

import trackmap
from tests._fuzz import base_map_text
from trackmap.check import check

Doc = dict[str, Any]


def _feature(doc: Doc, feature: str, **match: Any) -> Doc:
    for f in doc["features"]:
        props = f["properties"]
        if props["feature"] == feature and all(props.get(k) == v for k, v in match.items()):
            return f
    raise LookupError(feature)


def _edge(doc: Doc, edge_id: int = 0) -> Doc:
    return _feature(doc, "edge", edge_id=edge_id)


def _set(path: Callable[[Doc], Doc], key: str, value: Any) -> Callable[[Doc], None]:
    return lambda doc: path(doc)["properties"].__setitem__(key, value)


def _move_vertex(doc: Doc) -> None:
    _edge(doc, 2)["geometry"]["coordinates"][1][0] = -179.0


CASES: dict[str, tuple[Callable[[Doc], None], str]] = {
    "node_ids[0] null": (
        lambda d: _edge(d)["properties"]["node_ids"].__setitem__(0, None),
        r"feature 0 \(edge 0\): properties.node_ids\[0\] must be integer",
    ),
    "offsets_m [[1,2]]": (
        _set(lambda d: _feature(d, "conflict", conflict_id=1), "offsets_m", [[1, 2]]),
        r"\(conflict 1\): properties.offsets_m\[0\] must be number",
    ),
    "grade separation without x": (
        lambda d: _feature(d, "grade_separated")["properties"].pop("x"),
        r"\(grade_separated\): properties missing 'x'",
    ),
    "stop on edge 999": (
        _set(lambda d: _feature(d, "stop"), "edge_id", 999),
        r"\(stop 1017\): refers to edge 999, which is not in the file",
    ),
    "crossing on edge 999": (
        _set(lambda d: _feature(d, "conflict", kind="crossing"), "edges", [0, 999]),
        r"\(conflict 2\): refers to edge 999, which is not in the file",
    ),
    "version true": (
        lambda d: d["trackmap"].__setitem__("version", True),
        r"format version True is not supported",
    ),
    "vertex moved to -179": (
        _move_vertex,
        r"\(edge 2\): coordinate 1 lies outside the map's CRS",
    ),
    "node with ends []": (
        _set(lambda d: _feature(d, "node", node_id=1002), "ends", []),
        r"\(node 1002\): properties.ends must contain at least 1 items",
    ),
    "node id twice": (
        _set(lambda d: _feature(d, "node", node_id=1006), "node_id", 1002),
        r"node 1002: node id used twice",
    ),
    "class that does not fit the ends": (
        _set(lambda d: _feature(d, "node", node_id=1002), "class", "point_switch"),
        r"node 1002: a point_switch joins 3 edge end\(s\), the node lists 1",
    ),
    "vertex moved a little": (
        lambda d: _edge(d, 2)["geometry"]["coordinates"][1].__setitem__(0, 19.95),
        r"\(edge 2\): its coordinates make it .* m long, but length_m says",
    ),
    "conflict moved off its edges": (
        _set(lambda d: _feature(d, "conflict", kind="crossing"), "x", 55.0),
        r"\(conflict 2\): its point .* from its x/y",
    ),
    "stop offset beyond its edge": (
        _set(lambda d: _feature(d, "stop"), "offset_m", 1e6),
        r"\(stop 1017\): offset 1,000,000.000 m is beyond the end of edge 0",
    ),
    "web mercator": (
        lambda d: d["trackmap"].__setitem__(
            "crs_wkt", __import__("pyproj").CRS.from_epsg(3857).to_wkt()
        ),
        r"lies outside the map's CRS|the CRS does not fit the coordinates",
    ),
    "maxspeed 1e308": (
        _set(_edge, "maxspeed_mps", 1e308),
        r"properties.maxspeed_mps must be smaller than or equal to 150",
    ),
    "string edge id": (_set(_edge, "edge_id", "0"), r"properties.edge_id must be integer"),
    "metadata overlapping edge 99": (
        lambda d: d["trackmap"]["source"].__setitem__("overlapping_edges", [[0, 99, 1.0, 2.0]]),
        r"header: source.overlapping_edges refers to edge 99",
    ),
    "build parameter of the wrong type": (
        lambda d: d["trackmap"]["build"].__setitem__("max_deflection_deg", "35"),
        r"header: build.max_deflection_deg must be number",
    ),
    "source as a list": (
        lambda d: d["trackmap"].__setitem__("source", [1, 2]),
        r"header: source must be object",
    ),
}


@pytest.fixture(scope="module")
def base() -> str:
    return base_map_text()


@pytest.mark.parametrize("case", list(CASES))
def test_broken_map_file_is_a_clear_error(case, base, tmp_path):
    mutate, message = CASES[case]
    doc = json.loads(base)
    mutate(doc)
    path = tmp_path / "broken.trackmap.geojson"
    path.write_text(json.dumps(doc))
    with pytest.raises(trackmap.MapFileError, match=message) as err:
        trackmap.load(path)
    assert str(err.value).startswith(str(path))
    assert len(str(err.value)) < 600


RAW_CASES: dict[str, tuple[Callable[[str], bytes], str]] = {
    "maxspeed Infinity": (
        lambda t: t.replace('"maxspeed_mps":null', '"maxspeed_mps":Infinity', 1).encode(),
        r"Infinity is not a number a map file may hold",
    ),
    "NaN offset": (
        lambda t: t.replace('"offsets_m":[', '"offsets_m":[NaN,', 1).encode(),
        r"NaN is not a number a map file may hold",
    ),
    "1e400": (
        lambda t: t.replace('"layer":0', '"layer":1e400', 1).encode(),
        r"the number 1e400 is beyond the range of a double",
    ),
    "5000-digit integer": (
        lambda t: t.replace('"layer":0', '"layer":' + "9" * 5000, 1).encode(),
        r"has more than 20 digits",
    ),
    "deeply nested": (lambda t: b"[" * 100_000 + b"]" * 100_000, r"nested too deeply"),
    "Latin-1 byte": (
        lambda t: t.encode().replace(b'"name":"Main"', b'"name":"M\xe4in"', 1),
        r"not UTF-8 text \(byte 0xe4",
    ),
    "cut short": (lambda t: t.encode()[: len(t) // 2], r"not valid JSON \(.*line 1 column"),
}


@pytest.mark.parametrize("case", list(RAW_CASES))
def test_broken_map_file_text_is_a_clear_error(case, base, tmp_path):
    make, message = RAW_CASES[case]
    path = tmp_path / "broken.trackmap.geojson"
    raw = make(base)
    assert raw != base.encode()
    path.write_bytes(raw)
    with pytest.raises(trackmap.MapFileError, match=message) as err:
        trackmap.load(path)
    assert str(err.value).startswith(str(path))


def test_the_base_map_loads_checks_and_round_trips(base, tmp_path):
    path = tmp_path / "m.trackmap.geojson"
    path.write_text(base)
    net = trackmap.load(path)
    assert check(net).ok
    again = trackmap.load(net.save(tmp_path / "again.trackmap.geojson"))
    assert again == net


def test_the_embedded_map_passes_every_check():
    net = trackmap.load(trackmap.default_map_path())
    assert net.stats()["edges"] > 1000


def test_the_published_schema_accepts_the_embedded_map():
    import fastjsonschema

    from trackmap.mapschema import SCHEMA

    doc = json.loads(trackmap.default_map_path().read_text(encoding="utf-8"))
    fastjsonschema.compile(SCHEMA)(doc)  # the single-document schema, as other tools use it
    doc["features"][0]["properties"]["node_ids"][0] = None
    with pytest.raises(fastjsonschema.JsonSchemaValueException):
        fastjsonschema.compile(SCHEMA)(doc)


def test_writing_a_map_that_no_file_can_hold_is_a_clear_error(base, tmp_path):
    path = tmp_path / "m.trackmap.geojson"
    path.write_text(base)
    net = trackmap.load(path)
    import dataclasses

    edges = list(net.edges)
    edges[0] = dataclasses.replace(edges[0], name="bad \udc80 name")
    broken = trackmap.TrackMap(
        frame=net.frame, edges=edges, nodes=net.nodes.values(), conflicts=net.conflicts
    )
    with pytest.raises(trackmap.MapFileError, match="cannot be written as a map file"):
        broken.save(tmp_path / "out.trackmap.geojson")
    assert not (tmp_path / "out.trackmap.geojson").exists()
    assert math.isfinite(net.edges[0].length_m)
