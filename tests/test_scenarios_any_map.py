"""``antikol compare --scenario all`` on maps other than the embedded one (issue 11,
finding 5): every scenario runs or says why it cannot, and the ones that stage a conflict
really need a warning."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

import trackmap
from antikol.cli import main
from antikol.evaluation.scenarios import SCENARIOS, build_scenario, run_scenario
from antikol.evaluation.scoring import compare
from tests._osm import OsmBuilder

KRAKOW_OVERPASS = (
    Path(__file__).resolve().parents[2] / "shared" / "data" / "krakow-tram-2023-12-14.overpass.json"
)
if not KRAKOW_OVERPASS.exists():  # a worktree beside shared/, or the repository inside it
    KRAKOW_OVERPASS = Path("/work/shared/data/krakow-tram-2023-12-14.overpass.json")

#: Scenarios that stage a conflict: wherever they run, a warning must be needed.
CONFLICTS = (
    "following_straight",
    "following_curve",
    "leader_behind_curve",
    "single_track_head_on",
    "merge_at_switch",
    "diamond_crossing",
    "leader_emergency",
    "tunnel_dropout",
    "wrong_way_single_line",
)


def cut_overpass(src: Path, dst: Path, south: float, west: float, north: float, east: float):
    """An Overpass extract of the ways lying wholly inside a bounding box (degrees)."""
    doc = json.loads(src.read_text(encoding="utf-8"))
    nodes = {e["id"]: e for e in doc["elements"] if e["type"] == "node"}

    def inside(n: dict) -> bool:
        return south <= n["lat"] <= north and west <= n["lon"] <= east

    ways = [
        e
        for e in doc["elements"]
        if e["type"] == "way" and all(inside(nodes[i]) for i in e["nodes"])
    ]
    keep = {i for w in ways for i in w["nodes"]}
    kept = [n for n in nodes.values() if n["id"] in keep]
    dst.write_text(json.dumps({"version": 0.6, "elements": kept + ways}), encoding="utf-8")
    return dst


@pytest.fixture(scope="module")
def krakow_centre(tmp_path_factory) -> Path:
    """The tram lines of Kraków's centre only: an extract that ends in stubs all round."""
    if not KRAKOW_OVERPASS.exists():
        pytest.skip("the Kraków extract of shared/data is not here")
    folder = tmp_path_factory.mktemp("centre")
    src = cut_overpass(KRAKOW_OVERPASS, folder / "centre.json", 50.045, 19.91, 50.075, 19.96)
    net = trackmap.build(src)
    return net.save(folder / "centre.trackmap.geojson")


@pytest.fixture(scope="module")
def unnoded(tmp_path_factory) -> Path:
    """Two one-way lines crossing at 70 degrees without a shared node, 600 m each side."""
    b = OsmBuilder()
    b.line([(0, -600), (0, 0), (0, 600)], oneway="yes")
    a = math.radians(70.0)
    b.line(
        [(-600 * math.sin(a), -600 * math.cos(a) + 5), (600 * math.sin(a), 600 * math.cos(a) + 5)],
        oneway="yes",
    )
    folder = tmp_path_factory.mktemp("unnoded")
    net = trackmap.build(b.write_xml(folder / "x.osm"))
    assert [c.kind for c in net.conflicts] == ["crossing"]
    return net.save(folder / "unnoded.trackmap.geojson")


def _compare_all(map_path: Path, capsys) -> dict:
    argv = ["compare", "--map", str(map_path), "--scenario", "all", "--json"]
    status = main([*argv, "--trams", "3", "--minutes", "1"])
    doc = json.loads(capsys.readouterr().out)
    assert status == 0 and doc["failed"] == [], doc["failed"]
    ran = {row["scenario"]: row for row in doc["scenarios"]}
    skipped = {line.split(":", 1)[0]: line for line in doc["skipped"]}
    assert set(ran) | set(skipped) == set(SCENARIOS)
    return {"ran": ran, "skipped": skipped}


def test_compare_all_runs_on_a_cut_out_of_krakow(krakow_centre, capsys):
    doc = _compare_all(krakow_centre, capsys)
    ran, skipped = doc["ran"], doc["skipped"]
    # the centre has curves, junctions, crossings and double track, but its one tunnel
    # ends at the edge of the cut and there is no long single track
    for name in ("following_curve", "leader_behind_curve", "merge_at_switch", "diamond_crossing"):
        assert name in ran, skipped.get(name)
    for line in skipped.values():
        assert "the map has no" in line or "has room" in line, line
    for name in CONFLICTS:
        if name in ran:
            assert ran[name]["track"]["required_warnings"] > 0, name


def test_unnoded_crossings_stage_the_crossing_scenario(unnoded):
    net = trackmap.load(unnoded)
    scn = build_scenario("diamond_crossing", net, seed=1)
    assert "unnoded" in scn.description
    c = compare(net, run_scenario(scn), name=scn.name)
    assert c.track.required > 0 and {m.kind for m in c.track.missed_detail} <= {"crossing"}


def test_compare_all_on_the_unnoded_map_says_why_it_skips(unnoded, capsys):
    doc = _compare_all(unnoded, capsys)
    assert "diamond_crossing" in doc["ran"]
    assert "no merging switch" in doc["skipped"]["merge_at_switch"]
