"""The main job of the README's first command: ``antikol demo`` writes what it promises."""

from __future__ import annotations

import json

from antikol.cli import main


def test_demo_writes_table_figure_scores_and_an_offline_map(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--trams", "4", "--minutes", "2", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "sector" in printed and "track" in printed  # both methods in the table
    assert (out / "city.png").read_bytes()[:4] == b"\x89PNG"
    scores = json.loads((out / "city.json").read_text())
    assert scores  # the comparison's scores, both methods
    page = (out / "city.html").read_text(encoding="utf-8")
    assert "<html" in page.lower() and "leaflet" in page.lower()
    assert "tile.openstreetmap.org" not in page  # no network request
    assert "https://unpkg.com" not in page and "cdn.jsdelivr" not in page
