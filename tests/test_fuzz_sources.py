"""Fuzzing trackmap.build with broken OSM XML, Overpass JSON and GeoJSON (bounded).

Each example breaks the base network (:func:`tests._fuzz.mutate_source`: wrong types, bad
coordinates and ids, missing nodes, odd tags, degenerate and pole-to-pole ways) and writes
it in one format. Reading and building must give a TrackMapError naming the file, or a map
that accounts for every way (kept, or dropped by a counted reason), saves, loads back equal
and passes ``check`` without an exception.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests._fuzz_sources import mutate_source, try_source

_NAMES = {"osm": "s.osm", "overpass": "s.json", "geojson": "s.geojson"}


@pytest.fixture(scope="module")
def work_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder for the module's examples (pytest keeps only the last runs' folders)."""
    return tmp_path_factory.mktemp("fuzz")


@pytest.mark.parametrize("fmt", list(_NAMES))
@settings(max_examples=40, deadline=None)
@given(rng=st.randoms(use_true_random=False))
def test_broken_sources_are_rejected_or_built_whole(fmt, work_dir, rng):
    if fmt == "osm":
        pytest.importorskip("osmium")
    outcome = try_source(mutate_source(rng), fmt, work_dir / _NAMES[fmt])
    assert outcome.kind in ("accepted", "rejected"), outcome.detail
