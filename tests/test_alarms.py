"""Pair alarms with hysteresis, and which of them a replay started mid-traffic can trust."""

from __future__ import annotations

from hypothesis import example, given, settings
from hypothesis import strategies as st

from antikol.analysis.alarms import AlarmBook, AlarmPolicy

POLICY = AlarmPolicy(min_on_s=3.0, release_after_s=2.0)


def test_a_pair_held_since_the_start_is_unsettled_until_clearly_over():
    book = AlarmBook(POLICY)
    for t in range(10):
        assert not book.step("A", "B", float(t), raise_now=False, hold=True)
        # off here, but a longer history may have raised it before t = 0 and held it since
        assert book.unsettled(0.0) == [("A", "B")]
    book.step("A", "B", 10.0, raise_now=False, hold=False)
    assert book.unsettled(0.0) == [("A", "B")]  # a held alarm is released only after 2 s
    book.step("A", "B", 12.0, raise_now=False, hold=False)
    assert book.unsettled(0.0) == []


def test_a_pair_raised_at_the_start_is_unsettled_until_released_for_sure():
    # with a longer history it may have been raised earlier and be released earlier
    book = AlarmBook(POLICY)
    book.step("A", "B", 0.0, raise_now=True, hold=False)
    book.step("A", "B", 2.0, raise_now=True, hold=False)
    book.step("A", "B", 3.0, raise_now=False, hold=True)
    assert book.unsettled(0.0) == [("A", "B")]
    assert book.step("A", "B", 4.0, raise_now=False, hold=False)  # quiet for 1 s only
    assert book.unsettled(0.0) == [("A", "B")]
    assert not book.step("A", "B", 5.0, raise_now=False, hold=False)
    assert book.unsettled(0.0) == []


def test_pairs_first_seen_later_are_not_listed():
    book = AlarmBook(POLICY)
    book.step("A", "B", 5.0, raise_now=False, hold=True)
    assert book.unsettled(4.0) == [] and book.unsettled(5.0) == [("A", "B")]


_STEP = st.sampled_from([(False, False), (False, True), (True, False), (True, True)])


@settings(max_examples=2000, deadline=None)
@given(st.lists(_STEP, min_size=2, max_size=40), st.integers(min_value=1, max_value=20))
# found by hypothesis: a longer history released at t = 3 while the late book's minimum
# on-time still held its alarm, which a hold at t = 4 then kept on
@example(
    steps=[(True, False), (True, False), (False, False), (False, False), (False, True)], start=1
)
def test_a_settled_pair_agrees_with_the_full_history(steps, start):
    """Whatever came before, a pair that the late book calls settled is in the same state
    as in a book that saw everything; the unsettled ones are the only possible
    differences."""
    full, late = AlarmBook(POLICY), AlarmBook(POLICY)
    start = min(start, len(steps) - 1)
    for t, (raise_now, hold) in enumerate(steps):
        on_full = full.step("A", "B", float(t), raise_now=raise_now, hold=hold)
        if t < start:
            continue
        on_late = late.step("A", "B", float(t), raise_now=raise_now, hold=hold)
        if not late.unsettled(float(start)):
            assert on_late == on_full, (t, steps)
