"""Fuzzing trackmap.load with broken map files (bounded: a few seconds).

Each example is the small base map broken once by :func:`tests._fuzz.mutate_map`; loading it
must give a MapFileError naming the file, or a map that ``check`` accepts without an
exception and that holds exactly what the file says. The long campaign with figures is
``python benchmarks/fuzz_inputs.py``.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests._fuzz import base_map_text, mutate_map, try_map_file


@pytest.fixture(scope="module")
def work_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder for the module's examples (pytest keeps only the last runs' folders)."""
    return tmp_path_factory.mktemp("fuzz")


@settings(max_examples=250, deadline=None)
@given(rng=st.randoms(use_true_random=False))
def test_broken_map_files_are_rejected_or_loaded_whole(work_dir, rng):
    outcome = try_map_file(mutate_map(base_map_text(), rng), work_dir / "m.trackmap.geojson")
    assert outcome.kind in ("accepted", "rejected"), outcome.detail
