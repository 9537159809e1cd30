"""``--map`` names: a map file, or a source built on the fly; the kinds a build keeps.

A user who hands an OSM extract to ``antikol match --map`` was told "not valid JSON: not
UTF-8 text"; the map is now built from it (with a warning that ``trackmap build`` saves
it). A broken map file keeps its own error.
"""

from __future__ import annotations

import logging

import pytest

import trackmap
from antikol.cli import main as antikol_main
from tests._osm import OsmBuilder
from trackmap.named import load_named


def _city() -> OsmBuilder:
    b = OsmBuilder()
    b.line([(0.0, 0.0), (0.0, 400.0)], oneway="yes")  # a tram track
    b.line([(200.0, 0.0), (200.0, 400.0)], railway="light_rail", oneway="yes")
    return b


@pytest.mark.parametrize("writer", ["write_xml", "write_overpass", "write_geojson"])
def test_a_source_named_as_a_map_is_built(tmp_path, caplog, writer):
    suffix = {"write_xml": "city.osm", "write_overpass": "city.json", "write_geojson": "c.geojson"}
    path = getattr(_city(), writer)(tmp_path / suffix[writer])
    with caplog.at_level(logging.WARNING, logger="trackmap"):
        net = load_named(str(path))
    assert net is not None and net == trackmap.build(path)
    assert any("trackmap build" in r.getMessage() for r in caplog.records)


def test_a_build_keeps_tram_and_light_rail_by_default(tmp_path):
    path = _city().write_xml(tmp_path / "city.osm")
    both = trackmap.build(path)
    assert both.metadata.build["kinds"] == ["light_rail", "tram"]
    assert sorted(e.kind for e in both.edges) == ["light_rail", "tram"]
    assert [e.kind for e in trackmap.build(path, kinds="tram").edges] == ["tram"]


def test_a_broken_map_file_keeps_its_own_error(tmp_path):
    broken = tmp_path / "city.trackmap.geojson"
    broken.write_text('{"type": "FeatureCollection", "trackmap": {"format": "trackmap"}}')
    with pytest.raises(trackmap.MapFileError):
        load_named(str(broken))
    not_json = tmp_path / "notes.json"
    not_json.write_text('{"hello": 1}')
    with pytest.raises(trackmap.TrackMapError, match="neither Overpass JSON"):
        load_named(str(not_json))


def test_antikol_match_takes_an_osm_extract_as_its_map(tmp_path, capsys):
    b = OsmBuilder()
    b.line([(0.0, -500.0), (0.0, 500.0)], oneway="yes")
    osm = b.write_xml(tmp_path / "line.osm")
    net = trackmap.build(osm)
    edge = net.edges[0]
    rows = ["vehicle_id,t,lat,lon,speed_mps,course_deg"]
    for k in range(30):
        lon, lat = net.to_lonlat(*edge.geometry.interpolate(100.0 + 10.0 * k).coords[0])
        rows.append(f"T1,{k}.0,{lat:.7f},{lon:.7f},10.0,0.0")
    log = tmp_path / "log.csv"
    log.write_text("\n".join(rows) + "\n")
    out = tmp_path / "positions.csv"
    assert antikol_main(["match", str(log), "--map", str(osm), "-o", str(out)]) == 0
    positions = out.read_text().splitlines()
    assert len(positions) == 31 and positions[-1].split(",")[8] == "confident"
