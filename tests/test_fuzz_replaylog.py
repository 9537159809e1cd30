"""Fuzzing the replay CSV reader with broken rows (bounded).

Rows are broken in place (:func:`tests._fuzz.mutate_csv`: Latin-1 and NUL bytes, unclosed
quotes, cut rows, bad numbers, a 2 MB line, semicolons; LF, CRLF or CR line ends). Every
row that was not touched must come out as a report, and every problem must name a line
that was touched.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests._fuzz import csv_rows, mutate_csv, try_csv

_ROWS = csv_rows(120)


@pytest.fixture(scope="module")
def work_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder for the module's examples (pytest keeps only the last runs' folders)."""
    return tmp_path_factory.mktemp("fuzz")


@settings(max_examples=200, deadline=None)
@given(rng=st.randoms(use_true_random=False))
def test_broken_rows_are_reported_and_the_others_kept(work_dir, rng):
    data, changed = mutate_csv(_ROWS, rng)
    outcome = try_csv(data, changed, len(_ROWS), work_dir / "log.csv")
    assert outcome.kind == "accepted", outcome.detail
