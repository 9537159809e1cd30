"""The cyclic garbage collector held off while one analysis cycle builds its objects.

A control-room cycle builds tens of thousands of small objects that live until the next
cycle (the paths ahead of every vehicle, their conflict points, the pairs' findings).
Python's collector counts those allocations and, every 700 of them, scans the young
objects; the survivors are scanned again in the older generations, and now and then the
whole heap — the map's routing graphs included. Measured with
``benchmarks/bench_analyser.py``'s clustered 1000 trams, that was about 160 ms of a
530 ms cycle, almost all of it spent finding nothing to free: the cycle's objects are
freed by reference counting when the next cycle replaces them.

:func:`gc_paused` holds the collector off for the duration of a call and restores it
afterwards (whatever the call raises); allocations are still counted, so the collector
runs at its next chance, once per cycle rather than a hundred times. Nested calls leave
the collector to the outermost one. Reference cycles are still collected, only later.

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

    return paused
