"""Which hypothesis the reported position follows (antikol.positioning.lineage)."""

from __future__ import annotations

import numpy as np
import pytest

from antikol.positioning.lineage import plan_slots


def _plan_one(p: list[float], parent: list[int], *, standing: bool, same_way=None, tossed=None):
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
        tossed=tossed,
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


@pytest.mark.parametrize(("tossed", "follows"), [(True, "best"), (False, "lineage")])
def test_a_lineage_that_was_a_coin_toss_not_shown_yet_gives_way(tossed, follows):
    # an outage at a switch split the vehicle 50/50 and the lineage went one way; the
    # first fix back favours the other while the vehicle is still shown at the switch
    calls = []

    def ask(report, best, lineage):
        calls.append((report.tolist(), best.tolist(), lineage.tolist()))
        return np.full(len(report), tossed)

    plan = _plan_one([0.65, 0.35], [1, 0], standing=False, tossed=ask)
    assert plan.chosen[0] == (0 if follows == "best" else 1)
    assert calls == [([0], [0], [1])]
    # a near toss itself (below the lead) is not asked about: the lineage stays
    calls.clear()
    assert _plan_one([0.55, 0.45], [1, 0], standing=False, tossed=ask).chosen[0] == 1
    assert calls == []
    # a decisive best is followed without asking
    calls.clear()
    assert _plan_one([0.8, 0.2], [1, 0], standing=False, tossed=ask).chosen[0] == 0
    assert calls == []


def test_tossed_lineages_on_the_branches_of_a_switch(tmp_path):
    import trackmap
    from antikol import VehicleReport
    from antikol.positioning.branching import tossed_lineages
    from antikol.positioning.reach import state_id
    from tests._osm import FRAME, switch_fixture

    net = trackmap.build(switch_fixture().write_xml(tmp_path / "switch.osm"))
    (on_trunk,) = net.candidates(*FRAME.to_lonlat(0.0, -50.0), radius_m=1.0)[:1]
    trunk = next(
        (on_trunk.edge_id, d)
        for d in (1, -1)
        if any(e != on_trunk.edge_id for e, _ in net.successors(on_trunk.edge_id, d))
    )
    straight, diverging = net.successors(*trunk)[:2]
    states = np.array([state_id(*s) for s in (straight, diverging, trunk)])
    parent = np.array([0, 1, 0])  # the candidates descend from slots 0, 1 and 0

    def ask(
        slot_p: list[float], shown: dict, best: int = 1, lineage: int = 0, tied_at=None
    ) -> bool:
        log_p = np.log(np.array([slot_p]))
        reports = [VehicleReport("V", 20.0, 50.06, 19.94, 5.0, 0.0)]
        tossed = tossed_lineages(
            net, states, parent, log_p, np.array([0]), reports, shown, tied_at=tied_at
        )
        return bool(tossed(np.array([0]), np.array([best]), np.array([lineage]))[0])

    # split 50/50 without evidence, shown at the switch: a toss not shown yet
    assert ask([0.5, 0.5], {"V": trunk})
    # split by evidence (0.6 / 0.4): the lineage was chosen, not tossed
    assert not ask([0.6, 0.4], {"V": trunk})
    # shown on the lineage's own branch, or never shown: kept
    assert not ask([0.5, 0.5], {"V": straight})
    assert not ask([0.5, 0.5], {})
    # tied a fix ago (the first fix after the split did not decide): still a toss, for
    # TOSS_MEMORY_S after the tie; the lineage shown on its own branch is kept all the same
    from antikol.positioning.branching import TOSS_MEMORY_S

    assert ask([0.46, 0.54], {"V": trunk}, tied_at=np.array([19.0]))
    assert not ask([0.46, 0.54], {"V": trunk}, tied_at=np.array([20.0 - TOSS_MEMORY_S - 1]))
    assert not ask([0.46, 0.54], {"V": trunk}, tied_at=np.array([np.nan]))
    assert not ask([0.46, 0.54], {"V": straight}, tied_at=np.array([19.0]))
