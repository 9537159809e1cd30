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
afterwards (whatever the call raises); allocations are still counted, so the collector
runs once when the call returns (the young generations only, as the collector itself
would at that point), rather than a hundred times during it. Nested calls leave the
collector to the outermost one. Reference cycles are still collected, only later.

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
from collections.abc import Callable
from typing import ParamSpec, TypeVar

__all__ = ["gc_paused"]

_P = ParamSpec("_P")
_R = TypeVar("_R")


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
    """Run the young collections the paused allocations asked for, once, now: the cost
    stays with the call that caused it (not with whatever code allocates next)."""
    counts, thresholds = gc.get_count(), gc.get_threshold()
    if thresholds[0] <= 0:  # the collector is switched off by its thresholds
        return
    if len(counts) > 1 and thresholds[1] > 0 and counts[1] >= thresholds[1]:
        gc.collect(1)
    elif counts[0] > thresholds[0]:
        gc.collect(0)
