"""Which hypotheses a vehicle keeps after a fix, and which one its reported position follows.

The candidates of a batch of fixes, ranked per vehicle, become each vehicle's hypothesis
slots: the most probable ``k`` (beyond the first only those above ``min_probability``).
Slot 0 is the **lineage** the reported position follows: the best candidate, unless it does
not descend from the previous slot 0 and is not decisive (below ``switch_probability``)
while the previous lineage is still plausible — all its descendants together, as past a
switch it splits over the branches — so successive reported positions stay connected by
the track. The lineage is then followed on its most probable descendant. Where the best
candidate lies on a track beside the lineage's that runs the same way and meets it again a
short way ahead (``same_way``, opt-in, :mod:`antikol.positioning.siblings`), the lineage can
be held however decisive the other is. A lineage that was a coin toss (an even split
without fixes, over a facing switch in an outage) and has not been shown yet is not
defended against a best of :data:`TOSS_LEAD` (``tossed``,
:func:`~antikol.positioning.branching.tossed_lineages`). A standing
vehicle has not left its lineage's place: only very decisive evidence
(``standing_switch_probability``) moves it to another, however little is left of the
lineage (the fixes of a tram waiting beside another track drift; the tram does not).

A change of lineage restarts the vehicle's along-track filter at the new lineage's progress
(:class:`~antikol.positioning.matcher.Positioner`), unless the new lineage descends from a
hypothesis at the old one's place, within a few metres along the track (the two sides of a
node a vehicle stands at): that is no move, and one stray fix taken by the other side must
not carry the filter with it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

__all__ = ["TOSS_LEAD", "SlotPlan", "plan_slots"]

#: A lineage that was a coin toss gives way to a best candidate with this much probability
#: (not to a near toss itself).
TOSS_LEAD = 0.6

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]


class SlotPlan(NamedTuple):
    """Where the kept candidates go.

    Attributes
    ----------
    chosen : ndarray of int
        Per committed report, the candidate its reported position follows (slot 0).
    candidate, report, slot : ndarray of int
        Per kept candidate: its index, the index of its report in ``bounds`` and its slot.
    """

    chosen: IntArray
    candidate: IntArray
    report: IntArray
    slot: IntArray


def plan_slots(
    rank_order: IntArray,
    bounds: IntArray,
    p: FloatArray,
    parent: IntArray,
    go: IntArray,
    *,
    fresh: BoolArray,
    standing: BoolArray,
    k: int,
    min_probability: float,
    switch_probability: float,
    standing_switch_probability: float,
    same_way: Callable[[IntArray, IntArray, IntArray], BoolArray] | None = None,
    tossed: Callable[[IntArray, IntArray, IntArray], BoolArray] | None = None,
) -> SlotPlan:
    """Keep the best ``k`` candidates of each committed report and order them into slots.

    Parameters
    ----------
    rank_order : ndarray of int
        The candidates, grouped by report and most probable first within each.
    bounds : ndarray of int
        Start of each report's candidates in ``rank_order`` (one more entry at the end).
    p, parent : ndarray
        Per candidate: probability, and the slot of the previous hypothesis it descends
        from (-1: a new lineage).
    go : ndarray of int
        The reports committed to hypotheses (indices into ``bounds``).
    fresh, standing : ndarray of bool
        Per report: it starts afresh; the vehicle stands.
    k : int
        Slots per vehicle.
    min_probability, switch_probability, standing_switch_probability : float
        See :class:`~antikol.positioning.config.PositioningConfig`.
    same_way : callable, optional
        ``same_way(report, best, lineage)``: report indices, and candidate indices of the
        best candidates and of the lineage's most probable descendants that would replace
        them: whether each lineage is held, however decisive the best (tracks side by side
        that meet again).
    tossed : callable, optional
        ``tossed(report, best, lineage)`` (as ``same_way``): whether each lineage was a
        coin toss not shown yet (:func:`~antikol.positioning.branching.tossed_lineages`):
        such a lineage is not held against a best of :data:`TOSS_LEAD` or more.

    Returns
    -------
    SlotPlan
    """
    n_ranked = len(rank_order)
    group = np.searchsorted(bounds, np.arange(n_ranked), side="right") - 1
    place = np.arange(n_ranked) - bounds[group]  # rank within the report's candidates
    member = (place < k) & ((place == 0) | (p[rank_order] >= min_probability))
    committed = np.zeros(len(bounds), dtype=bool)
    committed[go] = True
    member &= committed[group]
    best = rank_order[bounds[go]]
    decisive = np.where(standing[go], standing_switch_probability, switch_probability)
    of_own = fresh[go] | (parent[best] == 0)
    keep_best = of_own | (p[best] >= decisive)
    chosen = best
    if not of_own.all():  # (most cycles: every best descends from its lineage)
        of_lineage = parent[rank_order] == 0
        in_reach = committed[group] & (place > 0) & (place < k) & of_lineage
        lineage_at = np.where(in_reach, np.arange(n_ranked), n_ranked)
        first_lineage = np.full(len(bounds), n_ranked)
        np.minimum.at(first_lineage, group, lineage_at)
        first_lineage = first_lineage[go]
        lineage = rank_order[np.minimum(first_lineage, n_ranked - 1)]
        has_lineage = first_lineage < n_ranked
        kept = has_lineage & (p[lineage] >= min_probability)
        # the lineage is as plausible as all its descendants together: past a switch it
        # splits over the branches, and each branch alone may look implausible beside
        # another track
        lineage_mass = np.bincount(
            group[of_lineage], weights=p[rank_order[of_lineage]], minlength=len(bounds)
        )[go]
        held = kept & ~keep_best
        held &= (lineage_mass > 1.0 - switch_probability) | standing[go]
        asked = np.flatnonzero(held & (p[best] >= TOSS_LEAD))
        if tossed is not None and len(asked):
            held[asked] = ~tossed(go[asked], best[asked], lineage[asked])
        # (a lineage no move reaches has nothing left at all, p = 0: its place is gone)
        ask = np.flatnonzero(has_lineage & ~of_own & ~held & (p[lineage] > 0.0))
        if same_way is not None and len(ask):
            # however little is left of it: it is held only until the tracks meet
            beside = same_way(go[ask], best[ask], lineage[ask])
            held[ask] = beside
            member[first_lineage[ask[beside]]] = True
        chosen = np.where(held, lineage, best)
    # slots: the chosen one first, then the other members in rank order
    chosen_of = np.full(len(bounds), -1)
    chosen_of[go] = chosen
    m_pos = np.flatnonzero(member)
    m_idx, m_group = rank_order[m_pos], group[m_pos]
    m_rank = np.arange(len(m_pos)) - np.searchsorted(m_group, m_group)
    chosen_rank = np.zeros(len(bounds), dtype=np.int64)
    is_chosen = m_idx == chosen_of[m_group]
    chosen_rank[m_group[is_chosen]] = m_rank[is_chosen]
    col = np.where(is_chosen, 0, np.where(m_rank < chosen_rank[m_group], m_rank + 1, m_rank))
    return SlotPlan(chosen, m_idx, m_group, col)
