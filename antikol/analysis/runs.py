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

import numpy as np
import numpy.typing as npt

__all__ = ["expand_rows", "first_worst", "group_of", "max_of_runs", "run_starts"]

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


def first_worst(
    idx: IntArray, rank: IntArray, margin: FloatArray, starts: IntArray, eligible: BoolArray
) -> IntArray:
    """Per group (``starts``) the position of the most severe eligible row — highest rank,
    then smallest margin, then first — or -1 when none is eligible."""
    n = len(idx)
    if n == 0 or len(starts) == 0:
        return np.zeros(len(starts), dtype=np.int64)
    group = group_of(n, starts)
    top = np.maximum.reduceat(np.where(eligible, rank, -1), starts)
    best = eligible & (rank == top[group])
    tight = np.minimum.reduceat(np.where(best, margin, np.inf), starts)
    best &= margin == tight[group]
    first = np.minimum.reduceat(np.where(best, np.arange(n), n), starts)
    return np.where(top >= 0, first, -1)
