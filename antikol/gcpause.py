"""The cyclic garbage collector held off while one analysis cycle builds its objects.

A control-room cycle builds tens of thousands of small objects that live until the next
cycle (the paths ahead of every vehicle, their conflict points, the pairs' findings).
Python's collector counts those allocations and, every 700 of them, scans the young
objects; the survivors are scanned again in the older generations, and now and then the
whole heap — the map's routing graphs included. Measured on 1000 clustered trams (the
referee's ``perf.py``), that was about 160 ms of a 530 ms cycle in some 130 collections,
almost all of it spent finding nothing to free: the cycle's objects are freed by
reference counting when the next cycle replaces them.

:func:`gc_paused` holds the collector off for the duration of a call and restores it
afterwards (whatever the call raises). Nested calls leave the collector to the outermost
one. When the call has allocated more than the collector's first threshold, what it
built is *promoted* to the oldest generation without a scan (``gc.freeze()`` then
``gc.unfreeze()``, which only moves the collector's lists): scanning the young objects
once more when the call returns still cost some 50 ms of a 440 ms cycle of 1000 trams,
again to find nothing. What the caller built since the previous call is promoted with it,
so a reference cycle of the caller's is found later, by a full collection, not lost: a
full collection runs instead of a promotion once the memory blocks in use
(:func:`sys.getallocatedblocks`) have grown by a quarter since the last one (the share of
the collector's own rule for its full collections). Counting the promoted objects instead
ran a full collection every few cycles, since most of them die in the next cycle. A
caller that froze objects itself (``gc.get_freeze_count() > 0``), or an interpreter
without the block count, gets the young collections the collector would have run.

>>> import gc
>>> @gc_paused
... def build():
...     return gc.isenabled()
>>> build(), gc.isenabled()
(False, True)
"""

from __future__ import annotations

import functools
import gc
import sys
from collections.abc import Callable
from dataclasses import dataclass
from typing import ParamSpec, TypeVar

__all__ = ["gc_paused"]

_P = ParamSpec("_P")
_R = TypeVar("_R")

#: A full collection once the memory blocks in use have grown by this share since the
#: last one (CPython's ``long_lived_pending > long_lived_total / 4``).
FULL_COLLECTION_SHARE = 0.25


@dataclass(slots=True)
class _Promotions:
    """Memory blocks in use after the last full collection (None: none yet)."""

    blocks_after_full: int | None = None


_promotions = _Promotions()


def gc_paused(func: Callable[_P, _R]) -> Callable[_P, _R]:
    """Decorate ``func`` to run with the cyclic garbage collector disabled.

    The collector's state before the call is restored after it, also when the call
    raises; a collector that was already off (by the caller or an outer call) stays off.
    """

    @functools.wraps(func)
    def paused(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        if not gc.isenabled():
            return func(*args, **kwargs)
        gc.disable()
        try:
            return func(*args, **kwargs)
        finally:
            gc.enable()
            _catch_up()

    return paused


def _catch_up() -> None:
    """Settle the paused allocations once, now: the cost stays with the call that caused
    it (not with whatever code allocates next)."""
    counts, thresholds = gc.get_count(), gc.get_threshold()
    if thresholds[0] <= 0 or counts[0] <= thresholds[0]:
        return  # switched off by its thresholds, or too few allocations to matter
    blocks = sys.getallocatedblocks()
    if gc.get_freeze_count() > 0 or blocks <= 0:  # the caller froze objects / no count
        _collect_young(counts[1], thresholds[1])
        return
    state = _promotions
    last = state.blocks_after_full
    if last is None or blocks - last >= FULL_COLLECTION_SHARE * last:
        gc.collect()
        state.blocks_after_full = sys.getallocatedblocks()
        return
    gc.freeze()
    gc.unfreeze()


def _collect_young(young_collections: int, threshold: int) -> None:
    """The young collections the paused allocations asked for, as the collector would:
    the middle generation too once ``threshold`` youngest ones have run since its last."""
    if threshold > 0 and young_collections >= threshold:
        gc.collect(1)
    else:
        gc.collect(0)
