"""Figures of track maps (:mod:`trackmap.plot`): static PNG/SVG/PDF and interactive HTML."""

from __future__ import annotations

import json
import pathlib
import re

import pytest

import trackmap
from trackmap.plot import plot, plot_map, plot_map_html

pytest.importorskip("folium")

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
ATTRIBUTION = "© OpenStreetMap contributors, ODbL 1.0"
OSM_TILES = "tile.openstreetmap.org"

# a straight track A-B-C-D (~86 m along lat 50.06) with a siding diverging at B (a point
# switch), a tunnel beyond D, a track crossing the main line at grade without a shared
# vertex (an unnoded crossing conflict) and a bridge crossing it (grade-separated)
A = (19.9400, 50.0600)
B = (19.9404, 50.0600)
C = (19.9408, 50.0600)
D = (19.9412, 50.0600)


def _line(fid: int, coords: list[tuple[float, float]], **props: str) -> dict[str, object]:
    return {
        "type": "Feature",
        "properties": {"railway": "tram", "id": fid, **props},
        "geometry": {"type": "LineString", "coordinates": [list(c) for c in coords]},
    }


@pytest.fixture(scope="module")
def small_net(tmp_path_factory: pytest.TempPathFactory) -> trackmap.TrackMap:
    features = [
        _line(1, [A, B, C]),
        _line(2, [C, D]),
        _line(3, [B, (19.9406, 50.06003), (19.9409, 50.06015)], service="siding"),
        _line(4, [(19.9410, 50.0598), (19.9410, 50.0602)]),
        _line(5, [(19.9402, 50.0598), (19.9402, 50.0602)], bridge="yes", layer="1"),
        _line(6, [D, (19.9416, 50.0600)], tunnel="yes", layer="-1"),
        {
            "type": "Feature",
            "properties": {"railway": "tram_stop", "name": "Test Stop", "id": 99},
            "geometry": {"type": "Point", "coordinates": [19.94065, 50.06]},
        },
    ]
    src = tmp_path_factory.mktemp("fixture") / "small.geojson"
    src.write_text(json.dumps({"type": "FeatureCollection", "features": features}))
    return trackmap.build(src)


@pytest.fixture(scope="module")
def krakow() -> trackmap.TrackMap:
    return trackmap.load_default()


def _switch_paths(net: trackmap.TrackMap) -> list[trackmap.Path]:
    """The two routes through the point switch from the start of the A-B edge."""
    (switch,) = [n for n in net.nodes.values() if n.cls == "point_switch"]
    (edge_id,) = [e.edge_id for e in net.edges if e.end_node == switch.node_id]
    return net.paths_ahead(edge_id, 0.0, 1, 200.0)


def test_fixture_has_every_drawn_feature(small_net: trackmap.TrackMap) -> None:
    s = small_net.stats()
    assert s["switches"] == 1
    assert s["buffer_stops"] >= 4
    assert s["unnoded_crossings"] == 1
    assert s["grade_separated_crossings"] == 1
    assert any(e.service == "siding" for e in small_net.edges)
    assert any(e.bridge for e in small_net.edges)
    assert any(e.tunnel for e in small_net.edges)
    assert len(_switch_paths(small_net)) == 2


@pytest.mark.parametrize("suffix", [".png", ".PNG"])
def test_png_is_a_valid_png(
    small_net: trackmap.TrackMap, tmp_path: pathlib.Path, suffix: str
) -> None:
    import matplotlib.pyplot as plt

    figures_before = plt.get_fignums()
    out = plot_map(small_net, tmp_path / f"small{suffix}", show_stops=True, figsize=(4, 4), dpi=60)
    assert out == tmp_path / f"small{suffix}"
    data = out.read_bytes()
    assert data.startswith(PNG_MAGIC)
    assert len(data) > 2000
    assert plt.get_fignums() == figures_before  # no figure left open


def test_png_size_follows_figsize_and_dpi(
    small_net: trackmap.TrackMap, tmp_path: pathlib.Path
) -> None:
    out = plot_map(small_net, tmp_path / "s.png", figsize=(4, 3), dpi=50)
    data = out.read_bytes()
    width = int.from_bytes(data[16:20], "big")  # IHDR
    height = int.from_bytes(data[20:24], "big")
    assert (width, height) == (200, 150)


def test_svg_carries_title_axis_units_and_attribution(
    small_net: trackmap.TrackMap, tmp_path: pathlib.Path
) -> None:
    import matplotlib

    with matplotlib.rc_context({"svg.fonttype": "none"}):  # keep text as text
        out = plot(small_net, tmp_path / "small.svg", title="Test title", show_stops=True)
    text = out.read_text(encoding="utf-8")
    assert text.lstrip().startswith("<?xml")
    assert "Test title" in text
    assert "(m)" in text  # metre axis labels
    assert ATTRIBUTION in text
    for label in (
        "main line",
        "siding",
        "bridge",
        "tunnel",
        "point switch",
        "buffer stop",
        "at-grade crossing",
        "stop (1)",
    ):
        assert label in text, label


def test_pdf_is_written(small_net: trackmap.TrackMap, tmp_path: pathlib.Path) -> None:
    out = plot(small_net, tmp_path / "small.pdf", figsize=(4, 4))
    assert out.read_bytes().startswith(b"%PDF")


def test_highlight_paths_are_drawn(small_net: trackmap.TrackMap, tmp_path: pathlib.Path) -> None:
    import matplotlib

    paths = _switch_paths(small_net)
    with matplotlib.rc_context({"svg.fonttype": "none"}):
        plain = plot_map(small_net, tmp_path / "plain.svg").read_text(encoding="utf-8")
        lit = plot_map(
            small_net, tmp_path / "lit.svg", highlight_paths=paths, extent="paths"
        ).read_text(encoding="utf-8")
    for k, p in enumerate(paths):
        assert f"path {k}: {p.zone}" in lit
        assert f"path {k}" not in plain
    assert len({p.zone for p in paths}) == 2
    png = plot_map(small_net, tmp_path / "lit.png", highlight_paths=paths, dpi=60)
    assert png.read_bytes().startswith(PNG_MAGIC)


def test_extent_options(small_net: trackmap.TrackMap, tmp_path: pathlib.Path) -> None:
    out = plot_map(small_net, tmp_path / "box.png", extent=[-60.0, -30.0, 60.0, 30.0], dpi=40)
    assert out.read_bytes().startswith(PNG_MAGIC)
    with pytest.raises(ValueError, match="highlight_paths"):
        plot_map(small_net, tmp_path / "x.png", extent="paths")
    with pytest.raises(ValueError, match="extent"):
        plot_map(small_net, tmp_path / "x.png", extent=(10.0, 0.0, 0.0, 10.0))
    assert not (tmp_path / "x.png").exists()


def test_html_has_leaflet_attribution_tiles_and_features(
    small_net: trackmap.TrackMap, tmp_path: pathlib.Path
) -> None:
    out = plot(small_net, tmp_path / "small.html", title="Small <test>")
    text = out.read_text(encoding="utf-8")
    assert "leaflet" in text.lower()
    assert ATTRIBUTION in text
    assert OSM_TILES in text  # default tiles: OpenStreetMap
    assert "fitBounds" in text
    assert "Small &lt;test&gt;" in text  # title escaped into the legend
    # tooltips name the edge fields; popups the node fields
    for field in ("edge_id", "way_ids", "direction", "service", "length_m", "node_id"):
        assert f'"{field}"' in text, field
    assert '"point_switch"' in text
    assert '"crossing"' in text  # the at-grade conflict point
    # every edge is present with its WGS84 vertices
    for e in small_net.edges:
        assert f'"edge_id": {e.edge_id},' in text
    assert "[19.9404, 50.06]" in text


@pytest.mark.parametrize("tiles", [None, "none", "None"])
def test_html_without_tiles(
    small_net: trackmap.TrackMap, tmp_path: pathlib.Path, tiles: str | None
) -> None:
    out = plot_map_html(small_net, tmp_path / "offline.html", tiles=tiles)
    text = out.read_text(encoding="utf-8")
    assert OSM_TILES not in text
    assert "L.tileLayer" not in text
    assert ATTRIBUTION in text
    assert "leaflet" in text.lower()


def test_html_with_tile_url_template(small_net: trackmap.TrackMap, tmp_path: pathlib.Path) -> None:
    url = "https://tiles.example.org/{z}/{x}/{y}.png"
    text = plot_map_html(small_net, tmp_path / "t.html", tiles=url).read_text(encoding="utf-8")
    assert "tiles.example.org" in text
    assert OSM_TILES not in text
    assert "openstreetmap.org/copyright" in text  # default attribution of a URL template
    text2 = plot_map_html(
        small_net, tmp_path / "t2.html", tiles=url, tiles_attribution="Example Tiles Ltd"
    ).read_text(encoding="utf-8")
    assert "Example Tiles Ltd" in text2


def test_html_unknown_tile_provider(small_net: trackmap.TrackMap, tmp_path: pathlib.Path) -> None:
    with pytest.raises(ValueError, match="unknown tile provider 'NoSuchTiles'"):
        plot_map_html(small_net, tmp_path / "u.html", tiles="NoSuchTiles")
    assert not (tmp_path / "u.html").exists()
    for name in ("openstreetmap", "OpenStreetMap.Mapnik", "OpenTopoMap"):
        out = plot_map_html(small_net, tmp_path / "k.html", tiles=name)
        assert "L.tileLayer" in out.read_text(encoding="utf-8")


def test_html_highlight_paths(small_net: trackmap.TrackMap, tmp_path: pathlib.Path) -> None:
    paths = _switch_paths(small_net)
    text = plot_map_html(
        small_net, tmp_path / "p.html", tiles=None, highlight_paths=paths
    ).read_text(encoding="utf-8")
    for k, p in enumerate(paths):
        assert f"path {k}: {p.zone}" in text


@pytest.mark.parametrize("name", ["map.jpg", "map.geojson", "map", "map.htm"])
def test_unsupported_suffix(
    small_net: trackmap.TrackMap, tmp_path: pathlib.Path, name: str
) -> None:
    with pytest.raises(ValueError, match=r"\.png.*\.svg.*\.pdf.*\.html"):
        plot(small_net, tmp_path / name)
    assert not (tmp_path / name).exists()


def test_wrong_function_for_suffix(small_net: trackmap.TrackMap, tmp_path: pathlib.Path) -> None:
    with pytest.raises(ValueError, match="html"):
        plot_map_html(small_net, tmp_path / "x.png")
    with pytest.raises(ValueError, match="png"):
        plot_map(small_net, tmp_path / "x.html")


@pytest.mark.parametrize("name", ["map.png", "map.html"])
def test_missing_output_directory(
    small_net: trackmap.TrackMap, tmp_path: pathlib.Path, name: str
) -> None:
    missing = tmp_path / "no" / "such" / "dir"
    with pytest.raises(trackmap.SourceError, match=re.escape(str(missing))) as info:
        plot(small_net, missing / name)
    assert isinstance(info.value, OSError)


def test_krakow_png_and_html(krakow: trackmap.TrackMap, tmp_path: pathlib.Path) -> None:
    png = plot(krakow, tmp_path / "krakow.png", figsize=(6, 6), dpi=80)
    data = png.read_bytes()
    assert data.startswith(PNG_MAGIC)
    assert len(data) > 20_000
    html = plot(krakow, tmp_path / "krakow.html", tiles=None).read_text(encoding="utf-8")
    assert ATTRIBUTION in html
    assert OSM_TILES not in html
    s = krakow.stats()
    assert f"point switch ({s['switches']})" in html
    assert f"diamond crossing ({s['diamond_crossings']})" in html
    assert html.count('"edge_id": ') == s["edges"]


def test_krakow_sensitivity_area_figure(krakow: trackmap.TrackMap, tmp_path: pathlib.Path) -> None:
    # a track position with a facing switch within 300 m: more than one route ahead
    paths: list[trackmap.Path] = []
    for e in krakow.edges:
        if e.direction != 0 and e.length_m > 100:
            off = e.length_m - 50.0 if e.direction == 1 else 50.0
            paths = krakow.paths_ahead(e.edge_id, off, e.direction, 300.0)
            if len(paths) >= 2:
                break
    assert len(paths) >= 2
    out = plot_map(
        krakow, tmp_path / "area.png", highlight_paths=paths, extent="paths", figsize=(5, 5)
    )
    assert out.read_bytes().startswith(PNG_MAGIC)
