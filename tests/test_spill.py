"""Sorting in bounded memory (antikol.ingest.spill): the order of a stable sort, every pass."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from antikol.errors import InvalidArgumentError
from antikol.ingest.spill import SortedRuns, external_sort

# items that share objects (the same string as key and payload) and repeat keys
_ITEMS = st.lists(
    st.tuples(st.integers(-3, 3), st.sampled_from(["a", "bb", "a", "ccc"]), st.integers()),
    max_size=60,
)


@settings(max_examples=150, deadline=None)
@given(items=_ITEMS, run_size=st.integers(1, 8))
def test_sorted_runs_give_a_stable_sort_on_every_pass(items, run_size):
    def key(item):
        return (item[0], item[1])

    expected = sorted(items, key=key)
    with SortedRuns(items, key=key, run_size=run_size) as runs:
        assert len(runs) == len(items)
        assert runs.spilled == (0 if len(items) <= run_size else -(-len(items) // run_size))
        assert list(runs) == expected
        assert list(runs) == expected  # a second pass reads the runs again


def test_a_shared_string_is_read_back_as_itself():
    # the key and the item are one object: a pickle memo shared across entries mixed them up
    assert list(external_sort("badc", key=lambda c: c, run_size=3)) == list("abcd")


def test_passes_may_overlap():
    items = list(range(20, 0, -1))
    with SortedRuns(items, key=lambda x: x, run_size=3) as runs:
        first, second = iter(runs), iter(runs)
        pairs = list(zip(first, second, strict=True))
    assert pairs == [(x, x) for x in range(1, 21)]


def test_closing_deletes_the_runs_and_ends_iteration(tmp_path, monkeypatch):
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)
    runs = SortedRuns(range(10, 0, -1), key=lambda x: x, run_size=4)
    assert runs.spilled == 3 and any(tmp_path.iterdir())
    runs.close()
    assert not any(tmp_path.iterdir())
    with pytest.raises(ValueError, match="closed"):
        iter(runs)


def test_a_failing_source_leaves_no_file(tmp_path, monkeypatch):
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))

    def items():
        yield from range(10)
        raise OSError("the archive went away")

    with pytest.raises(OSError, match="went away"):
        SortedRuns(items(), key=lambda x: x, run_size=3)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("run_size", [0, -1, 1.5, True, "9"])
def test_a_run_size_that_is_no_positive_whole_number_is_refused(run_size):
    with pytest.raises(InvalidArgumentError, match="run_size"):
        SortedRuns([1], key=lambda x: x, run_size=run_size)
