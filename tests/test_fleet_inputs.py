"""Fleet-scale replay: its inputs, options and outputs (self-contained pages, a bad map,
bad settings, rejection reasons, the output directory, the summary's JSON)."""

from __future__ import annotations

import pytest

pytest.importorskip("pyarrow.parquet")

from antikol.evaluation import fleet as fl
from antikol.evaluation.fleet.stages import load_map_cached
from antikol.sim import Simulator, fleet

MAP = "synthetic"


@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    net = load_map_cached(MAP)
    result = Simulator(net, fleet(net, 4, 1), seed=2).run(120.0)
    d = tmp_path_factory.mktemp("archive")
    fl.write_parquet_archive(sorted(result.reports, key=lambda r: (r.t, r.vehicle_id)), d)
    return d


def test_hotspot_page_is_self_contained(tmp_path):
    pytest.importorskip("folium")
    from tests.test_html_pages import assert_self_contained

    net = load_map_cached(MAP)
    spot = fl.HotSpot(*net.to_lonlat(200.0, 100.0), 100.0, 3, {"parallel_track": 3})
    summary = fl.FleetSummary(
        partitions=1,
        rows_read=0,
        reports=0,
        rejected_by_reason={},
        vehicles=0,
        vehicle_days=0,
        vehicle_km=0.0,
        vehicle_cycles=0,
        events=0,
        alarms={},
        lamp_cycles={},
        hot_spots=(spot,),
    )
    page = fl.hotspot_html(summary, net, tmp_path / "hotspots.html").read_text(encoding="utf-8")
    assert_self_contained(page)
    for cdn in ("https://cdn", "unpkg", "jsdelivr", "cdnjs", "bootstrapcdn"):
        assert cdn not in page, cdn
    assert "parallel_track" in page
