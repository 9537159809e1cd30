"""The trackmap command line: build, info, check, plot."""

from __future__ import annotations

import json

from tests._osm import OsmBuilder, switch_fixture
from trackmap.cli import main


def test_build_info_check_plot(tmp_path, capsys):
    src = switch_fixture().write_xml(tmp_path / "s.osm")
    out = tmp_path / "s.trackmap.geojson"
    assert main(["build", str(src), "-o", str(out), "--driving-side", "left"]) == 0
    assert "1 switches" in capsys.readouterr().out
    assert main(["info", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["stats"]["switches"] == 1 and info["driving_side"] == "left"
    assert main(["check", str(out)]) == 0
    assert "0 error(s)" in capsys.readouterr().out
    assert main(["plot", str(out), "-o", str(tmp_path / "m.png")]) == 0
    assert (tmp_path / "m.png").read_bytes()[:4] == b"\x89PNG"
    assert main(["plot", str(out), "-o", str(tmp_path / "m.html"), "--tiles", "none"]) == 0
    assert "tile.openstreetmap.org" not in (tmp_path / "m.html").read_text()
    # the default page is offline too; online tiles only on request
    assert main(["plot", str(out), "-o", str(tmp_path / "d.html")]) == 0
    assert "tile.openstreetmap.org" not in (tmp_path / "d.html").read_text()
    assert main(["plot", str(out), "-o", str(tmp_path / "o.html"), "--tiles", "OpenStreetMap"]) == 0
    assert "tile.openstreetmap.org" in (tmp_path / "o.html").read_text()


def test_check_exit_status_and_errors(tmp_path, capsys):
    b = OsmBuilder()
    n = b.node(0, 100)
    b.line([(0, 0), n], oneway="yes")
    b.line([(0, 200), n], oneway="yes")
    out = tmp_path / "bad.geojson"
    assert main(["build", str(b.write_xml(tmp_path / "b.osm")), "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["check", str(out), "--json"]) == 1
    assert json.loads(capsys.readouterr().out)["counts"]["contradictory_direction"] == 1
    assert main(["info", str(tmp_path / "missing.geojson")]) == 2
    assert "missing.geojson" in capsys.readouterr().err
    assert main(["build", str(tmp_path / "nothing.osm"), "-o", str(out)]) == 2
