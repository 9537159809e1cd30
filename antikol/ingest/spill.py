"""Sorting more records than memory should hold: sorted runs spilled to temporary files.

A day of an operator's archive is millions of vehicle positions, and its records come
roughly, not exactly, in time order (messages arrive late, files are concatenated). The
readers sort them in bounded memory: :class:`SortedRuns` sorts ``run_size`` items at a
time, writes each sorted run to a file of its own temporary directory, and merges the runs
(:func:`heapq.merge`) each time it is iterated, so one sort serves several passes (a
counting pass, then the replay; each pass reads the files afresh, so passes may overlap).
Equal keys keep their input order: the sort is stable.

>>> with SortedRuns([3, 1, 2, 1], key=lambda x: (x,), run_size=2) as runs:
...     list(runs), list(runs), runs.spilled
([1, 1, 2, 3], [1, 1, 2, 3], 2)
"""

from __future__ import annotations

import heapq
import pickle
import shutil
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any, Generic, TypeVar

from antikol.errors import InvalidArgumentError

__all__ = ["DEFAULT_RUN_SIZE", "SortedRuns", "external_sort"]

T = TypeVar("T")

#: Items per sorted run: a few hundred MB at most for the readers' records.
DEFAULT_RUN_SIZE = 200_000

_Entry = tuple[Any, int, Any]  # (key, input position, item)
#: Entries per pickle in a run's file, at most.
_BLOCK = 1024


class SortedRuns(Generic[T]):
    """Items sorted by ``key`` in memory for ``run_size`` items at a time.

    Parameters
    ----------
    items : iterable
        Read once, here.
    key : callable
        The sort key of an item (anything orderable; a tuple of numbers and strings).
    run_size : int, keyword-only
        Items per sorted run (memory holds one run while sorting, and one item per run
        while merging). When every item fits in one run, nothing is written to disk.

    Raises
    ------
    InvalidArgumentError
        ``run_size`` is not a positive whole number.
    OSError
        A temporary file cannot be written (full disk): every file written is closed.

    Notes
    -----
    Iterating merges the runs again each time (the temporary files are read from their
    start); :meth:`close` (or leaving the ``with`` block) deletes them.
    """

    def __init__(
        self,
        items: Iterable[T],
        *,
        key: Callable[[T], Any],
        run_size: int = DEFAULT_RUN_SIZE,
    ) -> None:
        if isinstance(run_size, bool) or not isinstance(run_size, int) or run_size < 1:
            raise InvalidArgumentError("run_size", run_size, "a positive whole number")
        self._directory: Path | None = None
        self._files: list[Path] = []
        self._memory: list[_Entry] = []
        self._closed = False
        # a merge holds one block of each run: a small part of a run, however many runs
        self._block = max(1, min(_BLOCK, run_size // 8))
        self.count = 0
        buffer: list[_Entry] = []
        try:
            for item in items:
                if len(buffer) == run_size:  # (spilled once more come: n <= run_size stays here)
                    self._spill(buffer)
                    buffer = []
                buffer.append((key(item), self.count, item))
                self.count += 1
            if self._files:
                if buffer:
                    self._spill(buffer)
            else:
                buffer.sort()  # (entries compare as tuples: key, then input position)
                self._memory = buffer
        except BaseException:
            self.close()
            raise

    @property
    def spilled(self) -> int:
        """Runs written to temporary files (0: sorted in memory)."""
        return len(self._files)

    def __len__(self) -> int:
        return self.count

    def __iter__(self) -> Iterator[T]:
        if self._closed:
            raise ValueError("the sorted runs are closed")
        if not self._files:
            return (item for _, _, item in self._memory)
        # (entries compare as tuples: key, then input position, never the item itself)
        merged = heapq.merge(*(_unspill(f) for f in self._files))
        return (item for _, _, item in merged)

    def close(self) -> None:
        """Delete the temporary files (iterating afterwards is an error)."""
        self._closed = True
        self._memory = []
        if self._directory is not None:
            shutil.rmtree(self._directory, ignore_errors=True)
            self._directory = None

    def _spill(self, buffer: list[_Entry]) -> None:
        if self._directory is None:
            self._directory = Path(tempfile.mkdtemp(prefix="antikol-sort-"))
        path = self._directory / f"run{len(self._files)}.pickle"
        self._files.append(path)
        buffer.sort()
        with path.open("wb") as f:
            # a pickle of its own for each block: one pickler for the whole run would make
            # the reader keep every object it has read through the memo (and a memo
            # cleared on one side only mixes entries up); blocks, not single entries, for
            # the speed of one call per block
            block = self._block
            for start in range(0, len(buffer), block):
                pickle.dump(buffer[start : start + block], f, protocol=pickle.HIGHEST_PROTOCOL)

    def __enter__(self) -> SortedRuns[T]:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def external_sort(
    items: Iterable[T], *, key: Callable[[T], Any], run_size: int = DEFAULT_RUN_SIZE
) -> Iterator[T]:
    """``items`` sorted by ``key`` (stable), in memory for ``run_size`` items at a time.

    A generator: the temporary files live until it is exhausted or closed.

    >>> list(external_sort("badc", key=lambda c: c, run_size=3))
    ['a', 'b', 'c', 'd']
    """
    with SortedRuns(items, key=key, run_size=run_size) as runs:
        yield from runs


def _unspill(path: Path) -> Iterator[_Entry]:
    with path.open("rb") as f:
        while True:
            try:
                block = pickle.load(f)
            except EOFError:
                return
            yield from block
