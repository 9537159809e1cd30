"""trackmap without its optional packages: osmium, tqdm, matplotlib and folium.

Each test runs a fresh interpreter in which those modules are blocked
(``sys.modules[name] = None`` makes ``import name`` raise ImportError) before trackmap
is imported, so nothing already imported by the test session can mask a missing lazy
import.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BLOCKED = ("osmium", "tqdm", "matplotlib", "folium")
PBF = ROOT / "maps" / "krakow-tram-2023-12-14.osm.pbf"


def run_blocked(body: str, tmp_path: Path) -> dict[str, object]:
    """Run ``body`` with the optional modules blocked; it prints one JSON object last."""
    script = f"import sys\nfor _name in {BLOCKED!r}:\n    sys.modules[_name] = None\n"
    script += textwrap.dedent(body)
    done = subprocess.run(
        [sys.executable, "-c", script],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "PYTHONPATH": str(ROOT), "TRACKMAP_TEST_DIR": str(tmp_path)},
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_queries_need_no_optional_package(tmp_path):
    out = run_blocked(
        """
        import json, os
        import trackmap
        from trackmap import routing

        net = trackmap.load_default()
        cands = net.candidates(19.93260, 50.06306, radius_m=25.0)
        c = cands[0]
        paths = net.paths_ahead(c.edge_id, c.offset_m, trackmap.Direction.FORWARD, 300.0)
        same = paths == routing.paths_ahead(net, c.edge_id, c.offset_m, 1, 300.0)
        step = paths[0].steps[-1]
        route = net.route_distance(c.edge_id, c.offset_m, 1, step.edge_id, step.exit_offset_m)
        batch = net.candidates_batch([19.93260, 19.94], [50.06306, 50.06], radius_m=25.0)
        path = os.path.join(os.environ["TRACKMAP_TEST_DIR"], "copy.trackmap.geojson")
        net.save(path)
        again = trackmap.load(path)
        loaded = [m for m in ("osmium", "tqdm", "matplotlib", "folium") if sys.modules.get(m)]
        print(json.dumps({
            "stats": net.stats(),
            "candidates": len(cands),
            "paths": len(paths),
            "same": same,
            "route_m": route.distance_m if route else None,
            "batch": len(batch),
            "reloaded_equal": again == net,
            "loaded": loaded,
        }))
        """,
        tmp_path,
    )
    assert out["stats"]["edges"] == 1328
    assert out["candidates"] and out["paths"] and out["batch"]
    assert out["same"] is True and out["reloaded_equal"] is True
    assert 0.0 < out["route_m"] <= 300.0 + 1e-6
    assert out["loaded"] == []


def test_build_from_osm_without_osmium_names_the_extra(tmp_path):
    out = run_blocked(
        f"""
        import json
        import trackmap

        try:
            trackmap.build({str(PBF)!r})
        except trackmap.TrackMapError as exc:
            result = {{
                "type": type(exc).__name__,
                "import_error": isinstance(exc, ImportError),
                "message": str(exc),
            }}
        print(json.dumps(result))
        """,
        tmp_path,
    )
    assert out["type"] == "MissingDependencyError" and out["import_error"] is True
    message = str(out["message"])
    assert "osmium" in message and "antikol[osm]" in message and PBF.name in message


def test_build_from_json_and_cli_without_osmium(tmp_path):
    src = ROOT.parent / "shared" / "data" / "krakow-tram-2023-12-14.overpass.json"
    if not src.is_file():
        pytest.skip(f"{src} not present")
    out = run_blocked(
        f"""
        import contextlib, io, json
        import trackmap
        from trackmap.cli import main

        net = trackmap.build({str(src)!r}, progress=True)  # no tqdm: no bar, no failure
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            status = main(["build", {str(PBF)!r}, "-o", "unused.trackmap.geojson"])
        print(json.dumps({{"edges": len(net.edges), "status": status, "err": err.getvalue()}}))
        """,
        tmp_path,
    )
    assert out["edges"] == 1328
    assert out["status"] == 2 and "antikol[osm]" in str(out["err"])


def test_plotting_without_its_libraries_names_the_extra(tmp_path):
    out = run_blocked(
        """
        import json, os
        import trackmap
        from trackmap.plot import plot

        net = trackmap.load_default()
        messages = {}
        for suffix in (".png", ".html"):
            try:
                plot(net, os.path.join(os.environ["TRACKMAP_TEST_DIR"], "map" + suffix))
            except trackmap.MissingDependencyError as exc:
                messages[suffix] = str(exc)
        print(json.dumps(messages))
        """,
        tmp_path,
    )
    assert "matplotlib" in out[".png"] and "antikol[plot]" in out[".png"]
    assert "folium" in out[".html"] and "antikol[plot]" in out[".html"]
