"""Which hypothesis the reported position follows (antikol.positioning.lineage)."""

from __future__ import annotations

import numpy as np
import pytest

from antikol.positioning.lineage import plan_slots


def _plan_one(p: list[float], parent: list[int], *, standing: bool, same_way=None):
    """The slot plan of one report whose candidates, ranked by probability, have the
    probabilities ``p`` and descend from the previous slots ``parent``."""
    return plan_slots(
        np.arange(len(p)),
        np.array([0, len(p)]),
        np.array(p),
        np.array(parent),
        np.array([0]),
        fresh=np.array([False]),
        standing=np.array([standing]),
        k=4,
        min_probability=1e-4,
        switch_probability=0.75,
        standing_switch_probability=0.95,
        same_way=same_way,
    )


def _plan(p_best: float, *, standing: bool, p_lineage: float | None = None):
    # one report, two candidates ranked by probability: the best descends from another
    # slot (1) than the reported lineage (0); the second descends from the lineage
    p_lineage = 1.0 - p_best if p_lineage is None else p_lineage
    return _plan_one([p_best, p_lineage], [1, 0], standing=standing)


@pytest.mark.parametrize(
    ("p_best", "standing", "follows"),
    [
        (0.70, False, "lineage"),  # not decisive, the lineage still plausible
        (0.80, False, "best"),  # decisive while moving
        (0.80, True, "lineage"),  # not decisive enough for a standing vehicle
        (0.96, True, "best"),
    ],
)
def test_the_reported_position_leaves_its_lineage_only_on_decisive_evidence(
    p_best, standing, follows
):
    plan = _plan(p_best, standing=standing)
    assert plan.chosen[0] == (0 if follows == "best" else 1)
    # the followed candidate goes to slot 0, the other after it
    slots = dict(zip(plan.candidate.tolist(), plan.slot.tolist(), strict=True))
    assert slots[int(plan.chosen[0])] == 0 and sorted(slots.values()) == [0, 1]


def test_a_standing_vehicle_keeps_its_lineage_however_little_is_left():
    # moving, a lineage below the switch probability's complement is given up
    assert _plan(0.6, standing=False, p_lineage=0.1).chosen[0] == 0
    assert _plan(0.6, standing=True, p_lineage=0.1).chosen[0] == 1


def test_a_lineage_split_over_branches_counts_as_all_its_branches():
    # the best (0.65) descends from another slot; the reported lineage has gone past a
    # switch and split over two branches, each below the 0.25 that keeps it alone
    def plan(p_lineage: list[float]):
        p = np.array([0.65, *p_lineage])
        return _plan_one(list(p / p.sum()), [1] + [0] * len(p_lineage), standing=False)

    assert plan([0.2, 0.15]).chosen[0] == 1  # together above 0.25: the lineage is kept
    assert plan([0.2, 0.15]).slot[0] == 1
    assert plan([0.1, 0.1]).chosen[0] == 0  # together still below: the best is followed


def _beside(p_best: float, p_lineage: float, *, beside: bool | None):
    """The plan when the best (from slot 1) and the lineage's candidate lie on tracks beside
    each other that meet again (``beside``; None: no such test), and the test's calls."""
    calls: list[tuple[list[int], list[int]]] = []

    def same_way(report, best, lineage):
        assert report.tolist() == [0]
        calls.append((best.tolist(), lineage.tolist()))
        return np.full(len(best), bool(beside))

    plan = _plan_one(
        [p_best, p_lineage], [1, 0], standing=False, same_way=None if beside is None else same_way
    )
    return plan, calls


def test_a_lineage_beside_the_best_is_held_however_little_is_left():
    # (antikol.positioning.siblings decides which tracks lie beside each other)
    for p_lineage in (0.1, 1e-6):
        plan, calls = _beside(1.0 - p_lineage, p_lineage, beside=True)
        assert plan.chosen.tolist() == [1] and calls == [([0], [1])]
        # held below min_probability, it keeps its slot 0 and the best its slot 1
        assert dict(zip(plan.candidate.tolist(), plan.slot.tolist(), strict=True)) == {1: 0, 0: 1}
        assert _beside(1.0 - p_lineage, p_lineage, beside=False)[0].chosen.tolist() == [0]
        assert _beside(1.0 - p_lineage, p_lineage, beside=None)[0].chosen.tolist() == [0]
    # asked only where the lineage would be left
    assert _beside(0.6, 0.4, beside=True)[1] == []
