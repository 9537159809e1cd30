"""Fuzzing the replay CSV reader with broken rows (bounded).

Rows are broken in place (:func:`tests._fuzz.mutate_csv`: Latin-1 and NUL bytes, unclosed
quotes, cut rows, bad numbers, a 2 MB line, semicolons; LF, CRLF or CR line ends). Every
row that was not touched must come out as a report, and every problem must name a line
that was touched.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from tests._fuzz import csv_rows, mutate_csv, try_csv

_TMP = Path(tempfile.mkdtemp(prefix="fuzz-csv-"))
_ROWS = csv_rows(120)


@settings(max_examples=200, deadline=None)
@given(rng=st.randoms(use_true_random=False))
def test_broken_rows_are_reported_and_the_others_kept(rng):
    data, changed = mutate_csv(_ROWS, rng)
    outcome = try_csv(data, changed, len(_ROWS), _TMP / "log.csv")
    assert outcome.kind == "accepted", outcome.detail
