"""The run reductions of the vectorised pair evaluation against plain Python."""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from antikol.analysis.runs import expand_rows, first_least, order_by, run_starts, severity_keys


@st.composite
def _keys(draw: st.DrawFn) -> tuple[list[np.ndarray], list[int]]:
    n = draw(st.integers(0, 40))
    sizes = draw(st.lists(st.integers(1, 6), min_size=1, max_size=4))
    keys = [np.array(draw(st.lists(st.integers(0, s - 1), min_size=n, max_size=n))) for s in sizes]
    return keys, sizes


@given(_keys())
def test_order_by_is_the_stable_lexicographic_order(drawn) -> None:
    keys, sizes = drawn
    n = len(keys[0])
    expected = sorted(range(n), key=lambda i: tuple(int(k[i]) for k in keys))  # stable
    assert order_by(keys, sizes).tolist() == expected
    # sizes too large to fold into one integer: the key-by-key sort, same order
    assert order_by(keys, [2**40] * len(sizes)).tolist() == expected


@given(_keys())
def test_order_by_unique_keys_sorts_as_the_stable_order(drawn) -> None:
    keys, sizes = drawn
    n = len(keys[0])
    row = np.arange(n)
    expected = sorted(range(n), key=lambda i: tuple(int(k[i]) for k in keys))
    assert order_by([*keys, row], [*sizes, max(n, 1)], unique=True).tolist() == expected


_MARGINS = st.sampled_from([-3.5, -0.0, 0.0, 0.5, 2.0, 1e-300, -1e300, 7.25, float("nan")])


def _severity(rank: int, margin: float) -> tuple[int, int, float]:
    """The documented order: highest rank, then smallest margin (-0.0 == 0.0), NaN last
    and all NaNs equal."""
    return (-rank, 1, 0.0) if margin != margin else (-rank, 0, margin)


@given(st.lists(st.tuples(st.integers(0, 3), st.integers(0, 3), _MARGINS), max_size=30))
def test_run_starts_and_most_severe_against_a_loop(rows) -> None:
    rows = sorted(rows, key=lambda r: r[0])
    group = np.array([r[0] for r in rows], dtype=np.int64)
    rank = np.array([r[1] for r in rows], dtype=np.int64)
    margin = np.array([r[2] for r in rows], dtype=np.float64)
    starts = run_starts(group)
    assert starts.tolist() == [k for k in range(len(rows)) if k == 0 or group[k] != group[k - 1]]
    keys = severity_keys(rank, margin)
    eligible = rank != 2
    bounds = [*starts.tolist(), len(rows)]
    for choose, mask in (
        (first_least(keys, starts, eligible), eligible),
        (first_least(keys, starts), None),
    ):
        for g, (lo, hi) in enumerate(itertools.pairwise(bounds)):
            pool = [k for k in range(lo, hi) if mask is None or mask[k]]
            # the most severe, then the first
            want = min(pool, key=lambda k: (*_severity(rank[k], margin[k]), k)) if pool else -1
            assert choose[g] == want


@given(st.lists(st.tuples(st.integers(0, 3), _MARGINS), max_size=30))
def test_severity_keys_order_rows_as_rank_then_margin(rows) -> None:
    rank = np.array([r[0] for r in rows], dtype=np.int64)
    margin = np.array([r[1] for r in rows], dtype=np.float64)
    keys = severity_keys(rank, margin)
    for i, j in itertools.product(range(len(rows)), repeat=2):
        a, b = _severity(rank[i], margin[i]), _severity(rank[j], margin[j])
        assert (keys[i] < keys[j]) == (a < b)
        assert (keys[i] == keys[j]) == (a == b)
    # dense: every key from 0 to the number of distinct rows less one
    assert sorted(set(keys.tolist())) == list(
        range(len({_severity(r, m) for r, m in zip(rank.tolist(), margin.tolist(), strict=True)}))
    )


def test_expand_rows_pairs_each_row_with_its_targets() -> None:
    rows, targets = expand_rows(
        np.array([5, 6, 7]), np.array([0, 1, 1]), np.array([1, 3, 1]), np.array([10, 11, 12])
    )
    assert list(zip(rows.tolist(), targets.tolist(), strict=True)) == [(5, 10), (6, 11), (6, 12)]
