"""Every HTML page the project writes is self-contained, and the result maps hold what they
should: the maps of ``trackmap plot``, ``antikol replay --html`` and ``antikol compare
--html``, the live view's page, and the comparison figure's zoom panels.

(Opening the pages in a real browser with the network off: ``tests/test_browser.py``.)
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("folium")

import trackmap
from antikol.analysis.analyser import Analyser
from antikol.cli import main
from antikol.evaluation.figures import comparison_figure, differences
from antikol.evaluation.groundtruth import CLEAR
from antikol.evaluation.html_results import comparison_html, replay_html
from antikol.evaluation.replay import replay
from antikol.evaluation.results_data import (
    ReplayRecorder,
    comparison_results,
    record_threats,
    replay_results,
)
from antikol.evaluation.scenarios import build_scenario, run_scenario
from antikol.evaluation.scoring import Comparison, compare
from antikol.ingest.replaylog import ReplayLog
from tests._paths import interleave, reports_from_xy
from trackmap.cli import main as trackmap_main
from trackmap.plot_assets import (
    LEAFLET_VERSION,
    NotSelfContainedError,
    external_resources,
    leaflet_css,
    leaflet_licence,
    render_self_contained,
    use_vendored_assets,
    vendored_file,
)
from trackmap.synthetic import demo_network

ROOT = Path(__file__).resolve().parent.parent


def assert_self_contained(page: str) -> None:
    """No script, stylesheet or image to fetch; Leaflet and its licence inline."""
    assert external_resources(page) == []
    assert "<script src" not in page.replace(" ", "").lower()
    assert f"Leaflet {LEAFLET_VERSION}" in page
    assert "BSD 2-Clause License" in page  # the licence travels with the code
    for cdn in ("cdn.jsdelivr.net", "code.jquery.com", "cdnjs.cloudflare.com", "bootstrapcdn"):
        assert cdn not in page, cdn
    assert "trackmap-vendored:" not in page


@pytest.fixture(scope="module")
def synthetic() -> trackmap.TrackMap:
    return demo_network().build()


@pytest.fixture(scope="module")
def comparisons(synthetic: trackmap.TrackMap) -> dict[str, Comparison]:
    """Two comparisons on the synthetic map: the sector rule misses the merge; it gives
    false alarms on double track."""
    out = {}
    for name in ("merge_at_switch", "oncoming_double_track"):
        scn = build_scenario(name, synthetic, seed=1)
        out[name] = compare(synthetic, run_scenario(scn), name=name, off_map=scn.off_map.keys())
    return out


# -- the vendored assets ------------------------------------------------------------------
def test_vendored_leaflet_is_shipped_with_its_licence() -> None:
    js = vendored_file("leaflet.js").decode()
    assert f"Leaflet {LEAFLET_VERSION}" in js[:300]
    assert "Volodymyr Agafonkin" in leaflet_licence()
    for name in ("layers.png", "layers-2x.png", "marker-icon.png", "marker-shadow.png"):
        assert vendored_file(f"images/{name}").startswith(b"\x89PNG")
    css = leaflet_css()
    assert "images/" not in css and css.count("data:image/png;base64,") == 3
    # the packaging ships them
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert '"vendor/leaflet/*"' in pyproject and '"vendor/leaflet/images/*"' in pyproject


def test_external_resources_finds_what_a_page_would_fetch() -> None:
    page = (
        '<link rel="stylesheet" href="https://cdn.example.org/a.css"/>'
        "<script src='//cdn.example.org/b.js'></script>"
        '<img src="tiles/1.png"><a href="https://example.org/">a link is fine</a>'
        "<style>.x{background:url(https://e.org/c.png)}@import 'd.css';</style>"
        '<img src="data:image/png;base64,AA==">'
    )
    assert external_resources(page) == [
        "https://cdn.example.org/a.css",
        "//cdn.example.org/b.js",
        "tiles/1.png",
        "https://e.org/c.png",
        "d.css",
    ]


def test_a_plugin_with_its_own_cdn_is_refused() -> None:
    import folium
    from folium.plugins import Fullscreen

    fmap = folium.Map(tiles=None)
    use_vendored_assets(fmap)
    Fullscreen().add_to(fmap)
    with pytest.raises(NotSelfContainedError, match="would fetch"):
        render_self_contained(fmap)
    plain = folium.Map(tiles=None)  # not prepared: refused, not silently online
    with pytest.raises(NotSelfContainedError, match="use_vendored_assets"):
        render_self_contained(plain)


# -- trackmap plot ------------------------------------------------------------------------
@pytest.mark.parametrize("tiles", ["none", "OpenStreetMap"])
def test_trackmap_plot_page_is_self_contained(tmp_path: Path, tiles: str) -> None:
    # the new user's command of the issue, on the embedded map
    out = tmp_path / "k.html"
    src = trackmap.default_map_path()
    assert trackmap_main(["plot", str(src), "-o", str(out), "--tiles", tiles]) == 0
    page = out.read_text(encoding="utf-8")
    assert_self_contained(page)
    # online tiles only when asked for: a tile URL template inside the script
    assert ("tile.openstreetmap.org" in page) == (tiles != "none")


# -- replay results -----------------------------------------------------------------------
def head_on_log() -> ReplayLog:
    """Two trams approaching on parallel tracks 4 m apart (the paper's Fig. 11)."""
    t = np.arange(0.0, 46.0, 1.0)
    v1 = reports_from_xy("V1", t, np.zeros_like(t), -350.0 + 8.0 * t)
    v2 = reports_from_xy("V2", t, np.full_like(t, 4.0), 350.0 - 8.0 * t)
    return ReplayLog(reports=interleave(v1, v2), source="fig11")


def test_replay_results_hold_every_warning_with_its_pair_and_chart(tmp_path: Path) -> None:
    analyser = Analyser()  # the sector rule: it warns about the train on the other track
    recorder = ReplayRecorder(analyser)
    replay(head_on_log(), analyser, on_assessment=recorder)
    data = replay_results(recorder, title="fig11", cycle_s=1.0)
    assert data["methods"][0]["key"] == "sector"
    assert sorted(p["v"] for p in data["paths"]["sector"]) == ["V1", "V2"]
    levels = {run[0] for p in data["paths"]["sector"] for run in p["runs"]}
    assert 0 in levels and max(levels) >= 2  # lamp off, then on
    pairs = {(e["own"], e["other"]) for e in data["events"]}
    assert pairs == {("V1", "V2"), ("V2", "V1")}
    for ev in data["events"]:
        assert ev["cat"] == "warning" and ev["level"] in ("warning", "emergency")
        assert ev["kind"] == "sector" and ev["d"] > 0 and ev["v"] > 0
        assert ev["t0"] <= ev["t1"]
        chart = data["charts"][ev["chart"]]
        assert (chart["own"], chart["other"]) == (ev["own"], ev["other"])
        assert ev["t0"] in chart["marks"] and len(chart["t"]) == len(chart["bars"][0]["values"])
        dist = chart["lines"][0]["values"]
        assert min(d for d in dist if d is not None) < 40.0  # they pass 4 m apart
    out = replay_html(recorder, tmp_path / "fig11.html", net=None, title="fig11 <replay>")
    page = out.read_text(encoding="utf-8")
    assert_self_contained(page)
    assert "<title>fig11 &lt;replay&gt;</title>" in page
    assert "antikolResults(" in page


def test_cli_replay_html_on_a_map(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    net = trackmap.load_default()
    result = run_scenario(build_scenario("merge_at_switch", net, seed=1))
    log = result.write_csv(tmp_path / "merge.csv")
    page = tmp_path / "merge.html"
    args = ["replay", str(log), "--map", "default", "-o", str(tmp_path / "e.csv")]
    assert main([*args, "--html", str(page)]) == 0
    assert f"wrote the result map {page}" in capsys.readouterr().out
    text = page.read_text(encoding="utf-8")
    assert_self_contained(text)
    data = json.loads(re.search(r"antikolResults\([^,]+, [^,]+, (\{.*\})\);", text).group(1))
    assert data["methods"][0]["key"] == "track"
    kinds = {e["kind"] for e in data["events"]}
    assert "merge" in kinds  # the scripted merge is warned about
    assert all(e["lat"] and e["lon"] and "chart" in e for e in data["events"])


# -- comparison results -------------------------------------------------------------------
def test_comparison_events_match_the_scores(
    comparisons: dict[str, Comparison], synthetic: trackmap.TrackMap
) -> None:
    for comp in comparisons.values():
        data = comparison_results(comp, synthetic)
        for method in ("sector", "track"):
            score = getattr(comp, method)
            evs = [e for e in data["events"] if e["method"] == method]
            assert sum(e["cat"] == "false_alarm" for e in evs) == score.false_alarm_episodes
            assert sum(e["cat"] == "missed" for e in evs) == score.missed
            for e in evs:
                assert e["own"] != e["other"] and e["kind"]
                assert e["d"] is not None and e["t0"] is not None
                assert "chart" in e
        for chart in data["charts"]:
            n = len(chart["t"])
            assert len(chart["band"]["values"]) == n
            assert [b["label"].split(":")[0] for b in chart["bars"]] == [
                "sector rule (2008 paper)",
                "track-aware analyser",
            ]
    merge = comparison_results(comparisons["merge_at_switch"], synthetic)
    missed = [e for e in merge["events"] if e["cat"] == "missed"]
    assert {e["method"] for e in missed} == {"sector"} and {e["kind"] for e in missed} == {"merge"}
    assert all(e["v"] > 0 for e in missed)  # closing in on the merge


def test_false_alarms_are_on_conflict_free_pairs(
    comparisons: dict[str, Comparison], synthetic: trackmap.TrackMap
) -> None:
    comp = comparisons["oncoming_double_track"]
    data = comparison_results(comp, synthetic)
    fas = [e for e in data["events"] if e["cat"] == "false_alarm"]
    assert fas and {e["method"] for e in fas} == {"sector"}
    times = list(comp.truth.times_s)
    for e in fas:
        k = times.index(e["t0"])
        assert comp.truth.state[(e["own"], e["other"])][k] == CLEAR
        assert e["level"] == "warning" and e["kind"] == "sector"


def test_recorded_threats_agree_with_the_scored_run(
    comparisons: dict[str, Comparison],
    synthetic: trackmap.TrackMap,
    caplog: pytest.LogCaptureFixture,
) -> None:
    comp = comparisons["merge_at_switch"]
    threats = record_threats(comp, synthetic)
    assert "differs from the scored run" not in caplog.text
    for method in ("sector", "track"):
        warned = comp.logs[method].pair_warn
        for pair, by_k in threats[method].items():
            assert all(warned[pair][k] for k in by_k)


def test_cli_compare_html(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "maps"
    args = ["compare", "--map", "synthetic", "--scenario", "oncoming_double_track"]
    assert main([*args, "--html", str(out)]) == 0
    assert "result maps written to" in capsys.readouterr().out
    index = (out / "index.html").read_text(encoding="utf-8")
    assert 'href="oncoming_double_track.html"' in index
    assert external_resources(index) == []
    assert_self_contained((out / "oncoming_double_track.html").read_text(encoding="utf-8"))


def test_comparison_page_with_online_tiles_only_when_asked(
    comparisons: dict[str, Comparison], synthetic: trackmap.TrackMap, tmp_path: Path
) -> None:
    comp = comparisons["merge_at_switch"]
    offline = comparison_html(comp, synthetic, tmp_path / "a.html").read_text()
    online = comparison_html(
        comp,
        synthetic,
        tmp_path / "b.html",
        tiles="OpenStreetMap",
    ).read_text()
    assert "L.tileLayer" not in offline and "L.tileLayer" in online
    assert_self_contained(offline)
    assert_self_contained(online)


# -- the comparison figure ----------------------------------------------------------------
def test_figure_zooms_on_the_places_where_the_analysers_differ(
    comparisons: dict[str, Comparison], synthetic: trackmap.TrackMap, tmp_path: Path
) -> None:
    import matplotlib

    comp = comparisons["merge_at_switch"]
    diffs = differences(comp)
    assert {(d.method, d.category) for d in diffs} == {("sector", "missed")}
    with matplotlib.rc_context({"svg.fonttype": "none"}):
        svg = comparison_figure(comp, synthetic, tmp_path / "m.svg").read_text()
    assert "1: sector rule: 2 missed" in svg  # one place, both misses
    assert "track-aware only" in svg  # the legend of the lamp states
    png = comparison_figure(comp, synthetic, tmp_path / "m.png", zooms=0)
    assert png.read_bytes().startswith(b"\x89PNG")
    fa = differences(comparisons["oncoming_double_track"])
    assert {(d.method, d.category) for d in fa} == {("sector", "false_alarm")}


# -- the live view's page ----------------------------------------------------------------
def test_live_page_is_self_contained(synthetic: trackmap.TrackMap) -> None:
    pytest.importorskip("starlette")
    from antikol.serve import live_page

    page = live_page(synthetic, title="live <test>")
    assert_self_contained(page)
    assert "antikolLive(" in page and "<title>live &lt;test&gt;</title>" in page
    bare = live_page(None)
    assert_self_contained(bare)
