"""The collector pause: off inside, restored after, whatever happens."""

from __future__ import annotations

import gc
import weakref

import pytest

import trackmap
from antikol import Analyser, UnknownVehicleError, VehicleReport
from antikol.gcpause import gc_paused


@gc_paused
def _state() -> bool:
    return gc.isenabled()


@gc_paused
def _nested() -> tuple[bool, bool]:
    inner = _state()
    return inner, gc.isenabled()


@gc_paused
def _raises() -> None:
    raise KeyError("boom")


def test_paused_inside_and_restored_after() -> None:
    assert gc.isenabled()
    assert _state() is False
    assert gc.isenabled()


def test_nested_calls_leave_the_collector_to_the_outermost() -> None:
    assert _nested() == (False, False)
    assert gc.isenabled()


def test_restored_after_an_exception() -> None:
    with pytest.raises(KeyError):
        _raises()
    assert gc.isenabled()


def test_a_collector_switched_off_by_the_caller_stays_off() -> None:
    gc.disable()
    try:
        assert _state() is False
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_the_analyser_leaves_the_collector_on() -> None:
    an = Analyser(track_map=trackmap.load_default())
    an.update(VehicleReport("A", 0.0, 50.06306, 19.93260, 5.0, 90.0))
    an.assess("A")
    assert gc.isenabled()
    with pytest.raises(UnknownVehicleError):
        an.assess("nobody")
    assert gc.isenabled()


def test_the_young_collection_runs_when_the_call_returns() -> None:
    # the allocations of a paused call are collected when it returns, not by whatever
    # code allocates next (a benchmark would charge them to the wrong call)
    @gc_paused
    def allocate() -> list[list[int]]:
        return [[k] for k in range(5 * gc.get_threshold()[0])]

    gc.collect()
    kept = allocate()
    assert gc.get_count()[0] < gc.get_threshold()[0]
    assert len(kept) == 5 * gc.get_threshold()[0]


class _Node:
    """A caller's object that can sit in a reference cycle (weak-referenceable)."""

    def __init__(self) -> None:
        self.other: _Node | None = None


@gc_paused
def _allocate_some() -> list[list[int]]:
    return [[k] for k in range(3 * gc.get_threshold()[0])]


def _garbage_cycles(n: int) -> _Node:
    """``n`` pairs of objects referring to each other, dropped: garbage only the cyclic
    collector frees. Returns the first (the caller keeps a weak reference)."""
    first = None
    for _ in range(n):
        a, b = _Node(), _Node()
        a.other, b.other = b, a
        first = first or a
    assert first is not None
    return first


def test_a_callers_reference_cycles_are_still_collected() -> None:
    # the paused calls promote what the caller built without a scan; the garbage cycles
    # the caller keeps making must be found by the full collections that the growing
    # memory leads to, not kept forever
    _allocate_some()  # the first settling of a process is a full collection: not this one
    probe = weakref.ref(_garbage_cycles(1000))
    calls = 0
    while probe() is not None and calls < 5_000:
        _garbage_cycles(1000)
        _allocate_some()
        calls += 1
    assert probe() is None


def test_the_callers_frozen_objects_stay_frozen() -> None:
    gc.collect()
    kept = [[k] for k in range(10)]
    gc.freeze()
    try:
        frozen = gc.get_freeze_count()
        assert frozen > 0
        for _ in range(3):
            _allocate_some()
        # an unfreeze would empty the permanent generation; another thread (tqdm's
        # monitor wakes every 10 s) may free a few objects frozen with the rest, which
        # takes them out of it: the count may drop by those, not to nothing
        assert gc.get_freeze_count() >= 0.9 * frozen
    finally:
        gc.unfreeze()
    assert len(kept) == 10
