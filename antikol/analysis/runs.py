"""Reductions over runs of rows: the building blocks of the vectorised pair evaluation.

Rows of flat arrays are grouped in *runs* of equal consecutive keys (:func:`run_starts`);
the reductions keep the order of the rows, so that a vectorised evaluation decides as the
scalar rules do, row by row (the first of equals wins).

>>> import numpy as np
>>> run_starts(np.array([3, 3, 5, 5, 5, 7])).tolist()
[0, 2, 5]
>>> lo, hi = np.array([0, 2]), np.array([2, 3])
>>> rows, targets = expand_rows(np.array([0, 1]), lo, hi, np.array([9, 8, 7]))
>>> rows.tolist(), targets.tolist()
([0, 0, 1], [9, 8, 7])
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

__all__ = [
    "expand_rows",
    "first_least",
    "group_of",
    "max_of_runs",
    "order_by",
    "run_starts",
    "severity_keys",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]


def expand_rows(
    rows: IntArray, lo: IntArray, hi: IntArray, targets: IntArray
) -> tuple[IntArray, IntArray]:
    """Each row repeated once per target in ``targets[lo:hi]``, with that target."""
    counts = hi - lo
    total = int(counts.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    rep = np.repeat(rows, counts)
    first = np.repeat(lo - np.cumsum(counts) + counts, counts)
    return rep, targets[first + np.arange(total)]


def order_by(keys: Sequence[IntArray], sizes: Sequence[int], *, unique: bool = False) -> IntArray:
    """The stable permutation that sorts rows by ``keys``, the first the most significant
    (:func:`numpy.lexsort` with the keys in reverse order).

    Each key holds integers in ``[0, size)``. When the sizes multiply to less than 2**62
    the keys are folded into one integer and sorted once (several times cheaper than
    sorting key by key); the permutation is the same either way. ``unique``: no two rows
    have the same keys, so an unstable sort (cheaper still) gives that permutation too.

    >>> order_by([np.array([1, 0, 1, 0]), np.array([0, 2, 0, 1])], [2, 3]).tolist()
    [3, 1, 0, 2]
    """
    span = 1
    for size in sizes:
        span *= max(int(size), 1)
    if span >= 2**62:
        return np.lexsort(tuple(reversed(keys)))
    folded = np.zeros(len(keys[0]), dtype=np.int64)
    for key, size in zip(keys, sizes, strict=True):
        folded = folded * max(int(size), 1) + key
    return np.argsort(folded) if unique else np.argsort(folded, kind="stable")


def run_starts(*keys: IntArray) -> IntArray:
    """Start positions of the runs of equal consecutive keys."""
    n = len(keys[0])
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    change = np.zeros(n, dtype=bool)
    change[0] = True
    for k in keys:
        change[1:] |= k[1:] != k[:-1]
    return np.flatnonzero(change)


def group_of(n: int, starts: IntArray) -> IntArray:
    """The group number of each of ``n`` rows, groups starting at ``starts``."""
    mark = np.zeros(n, dtype=np.int64)
    mark[starts[1:]] = 1
    return np.cumsum(mark)


def max_of_runs(x: FloatArray, starts: IntArray) -> FloatArray:
    """Maxima of the runs starting at ``starts``."""
    return np.maximum.reduceat(x, starts) if len(starts) else x[:0].copy()


def severity_keys(rank: IntArray, margin: FloatArray) -> IntArray:
    """Dense integer keys of rows by severity: the highest ``rank`` first, then the
    smallest ``margin``; rows equal in both share a key (smaller: more severe).

    One float sort and one stable sort of a small integer (a radix sort) instead of a
    lexicographic sort; the keys let :func:`first_least` find each group's most severe row
    with a single reduction. ``-0.0`` and ``0.0`` compare equal, as they do as floats;
    a NaN margin counts as larger than any number, and all NaN margins of a rank share a
    key (so the first such row wins among them).

    >>> severity_keys(np.array([1, 3, 1, 3]), np.array([2.0, 5.0, -1.0, 5.0])).tolist()
    [2, 0, 1, 0]
    """
    n = len(rank)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    by_margin = np.argsort(margin)
    lowered = int(rank.max()) - rank[by_margin]
    if int(lowered.max()) < 2**15:
        lowered = lowered.astype(np.int16)  # numpy sorts small integers by radix
    order = by_margin[np.argsort(lowered, kind="stable")]
    r, m = rank[order], margin[order]
    change = np.zeros(n, dtype=np.int64)
    nan = np.isnan(m)
    change[1:] = (r[1:] != r[:-1]) | ((m[1:] != m[:-1]) & ~(nan[1:] & nan[:-1]))
    keys = np.empty(n, dtype=np.int64)
    keys[order] = np.cumsum(change)
    return keys


def first_least(keys: IntArray, starts: IntArray, eligible: BoolArray | None = None) -> IntArray:
    """Per group (``starts``) the position of the first eligible row with the least key,
    or -1 when none is eligible (with :func:`severity_keys`: the most severe row — highest
    rank, then smallest margin, then first). Keys are non-negative integers with
    ``max(keys) * len(keys) < 2**63`` (dense keys of up to a few million rows).

    >>> first_least(np.array([4, 2, 2, 7, 5]), np.array([0, 3])).tolist()
    [1, 4]
    """
    n = len(keys)
    if n == 0 or len(starts) == 0:
        return np.zeros(len(starts), dtype=np.int64)
    # (key, position) folded into one integer: position < n keeps the order of pairs
    combined = keys * n + np.arange(n)
    none = np.iinfo(np.int64).max
    if eligible is not None:
        combined = np.where(eligible, combined, none)
    least = np.minimum.reduceat(combined, starts)
    return np.where(least == none, -1, least % n)
