"""Where to report a vehicle that has just passed a facing switch whose branch is open.

A few metres past a switch the branches lie closer together than GPS can tell apart; the
matcher keeps a hypothesis on each and the most probable one may still change. Reporting
the vehicle on a branch it is not sure of, then on the other, gives positions that no
permitted move connects. While the branches' hypotheses are undecided, the vehicle is
reported at the switch itself, on the track before it, with its along-track uncertainty
grown by the distance it has run past it: every branch it may be on starts there.

The switch is found by following each hypothesis back along the track it came by
(:meth:`Arrivals.before`), so a switch a few short edges behind the reported position counts
as well as one at the start of its edge, and a hypothesis on another branch counts however
its branch is cut into edges; a hypothesis still on the track before the switch has not
decided either. Where tracks join, the track alone does not tell the way back: the reported
position is then followed back the way its lineage came (:meth:`Arrivals.switches_along`),
so that a branch that runs into another line a few metres past the switch is held at the
switch as any other. Of several undecided switches the vehicle is held at the earliest: a later
one lies on a branch of it that is not decided either. A position carried past a switch by
the along-track filter before any hypothesis has passed it is undecided too.

Once a vehicle has been reported more than ``STEP_BACK_M`` past a switch on a branch, it is
held at that switch again (``released``) only when that branch has fallen clearly below
even odds (``RELEASED_SHARE``): stepping back to the switch breaks the chain of reported
positions as much as a branch change does, and a share wavering around a half would step
back and forth (a simulated HFP log had a branch at 0.91, then 0.499, then 0.73: reported
on it, at the switch 21 m back, and on it again).

Below ``TWO_FIXES_BELOW_MPS`` a branch is decided only when it held ``DECIDED_SHARE`` of the
vehicle's hypotheses at the fix before too (``SURE_SHARE`` decides at once): at walking pace
a fix moves the tram less than a street fix is off, and one stray fix could swing the
branches. A simulated HFP log had a tram held at a switch at 0.87, shown on the other
branch at 0.93 after a fix beside it, and on its own at 0.99 the fix after.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable, Collection, Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from antikol.positioning.reach import enters_within, state_direction, state_edge
from antikol.positioning.records import Hypothesis
from trackmap import TrackMap

__all__ = [
    "TIE_NATS",
    "TOSS_MEMORY_S",
    "TWO_FIXES_BELOW_MPS",
    "Arrivals",
    "HypothesisBefore",
    "SwitchHold",
    "entry_node",
    "hold_at_switch",
    "tossed_lineages",
]

#: Past a switch farther than this, the branch is reported even if undecided, m.
HOLD_M = 40.0
#: A branch holding this share of the branches' probability is decided.
DECIDED_SHARE = 0.9
#: A branch holding this share is decided at once; below it, only when it held
#: ``DECIDED_SHARE`` at the fix before too.
SURE_SHARE = 0.99
#: Below this speed a branch is decided only when it was decided at the fix before too,
#: m/s (at walking pace a fix moves the tram less than one stray fix moves the shares).
TWO_FIXES_BELOW_MPS = 5.0
#: Once reported past a switch, the vehicle is held at it again only when the branch it
#: was reported on holds less than this share (below a half: a branch that wavers around
#: even odds keeps being reported; the other one takes over at ``switch_probability``).
RELEASED_SHARE = 0.35
#: A step back to a switch it was reported past this short is no break in the chain of
#: reported positions (what :func:`~antikol.evaluation.positioning_accuracy.disconnected_windows`
#: allows), m: the hysteresis of ``RELEASED_SHARE`` applies beyond it.
STEP_BACK_M = 10.0
#: Hypotheses are followed back this far to find the switch they passed, m.
LOOKBACK_M = HOLD_M + 40.0

State = tuple[int, int]
FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


class Arrivals:
    """The (edge, direction) states that arrive at each node of a map (built once)."""

    def __init__(self, net: TrackMap) -> None:
        self.net = net
        self._at: dict[int, list[State]] = defaultdict(list)
        for e in net.edges:
            self._at[e.end_node].append((e.edge_id, 1))
            self._at[e.start_node].append((e.edge_id, -1))
        self._before: dict[State, State | None] = {}
        self._facing: dict[State, bool] = {}
        self._skeletons: dict[State, tuple[tuple[int, float, State, bool], ...]] = {}
        self._passed: dict[State, frozenset[int]] = {}
        self._switches: dict[State, tuple[tuple[int, float, State], ...]] = {}
        self._merge: dict[State, float] = {}
        #: Length of each edge, m (``net.edge_length``, indexed by edge id).
        self.lengths_m = np.array([net.edge_length(e.edge_id) for e in net.edges], dtype=float)
        # metres to the nearest facing switch behind each state's entry, by state id
        # (``2 * edge + (direction < 0)``); NaN: not looked up yet
        self._nearest = np.full(2 * len(net.edges), np.nan)

    def trunk(self, node: int, edge: int, direction: int) -> tuple[int, int] | None:
        """A state arriving at ``node`` from which ``(edge, direction)`` is entered."""
        for state in self._at.get(node, ()):
            if state[0] == edge:
                continue
            if (edge, direction) in self.net.successors(*state, respect_direction=False):
                return state
        return None

    def before(self, edge: int, direction: int) -> State | None:
        """The one state a vehicle in ``(edge, direction)`` came from (None where several
        join, at a trailing switch, or none: the end of the track)."""
        key = (edge, direction)
        if key not in self._before:
            node = entry_node(self.net, edge, direction)
            came = [
                s
                for s in self._at.get(node, ())
                if s[0] != edge and key in self.net.successors(*s, respect_direction=False)
            ]
            self._before[key] = came[0] if len(came) == 1 else None
        return self._before[key]

    def facing(self, state: State) -> bool:
        """Whether the track branches at the end of ``state`` (a facing switch)."""
        if state not in self._facing:
            ahead = self.net.successors(*state, respect_direction=False)
            self._facing[state] = len(ahead) > 1
        return self._facing[state]

    def chain(self, edge: int, offset: float, direction: int) -> list[tuple[int, float, State]]:
        """The nodes a position came through, nearest first, up to :data:`LOOKBACK_M`:
        (node, metres run past it, the state entered there)."""
        past = offset if direction == 1 else self.net.edge_length(edge) - offset
        return [
            (node, past + behind, state)
            for node, behind, state, _ in self.skeleton((edge, direction))
            if past + behind <= LOOKBACK_M
        ]

    def skeleton(self, start: State) -> tuple[tuple[int, float, State, bool], ...]:
        """The nodes a vehicle in state ``start`` came through, nearest first (cached):
        (node, metres of track between it and the entry of ``start``, the state entered
        there, whether it is a facing switch), up to :data:`LOOKBACK_M` back."""
        cached = self._skeletons.get(start)
        if cached is not None:
            return cached
        out: list[tuple[int, float, State, bool]] = []
        state, behind, seen = start, 0.0, {start[0]}
        while behind <= LOOKBACK_M:
            prev = self.before(*state)
            switch = prev is not None and self.facing(prev)
            out.append((entry_node(self.net, *state), behind, state, switch))
            if prev is None or prev[0] in seen:
                break
            seen.add(prev[0])
            state = prev
            behind += self.net.edge_length(state[0])
        result = tuple(out)
        self._skeletons[start] = result
        return result

    def merge_behind_m(self, state: State) -> float:
        """Metres of track between the entry of ``state`` and the junction behind it where
        :meth:`skeleton` stops because several tracks join (``inf``: it stops at none
        within :data:`LOOKBACK_M`). A facing switch beyond such a junction is found only
        along the way a vehicle came (:meth:`switches_along`)."""
        cached = self._merge.get(state)
        if cached is None:
            cached = math.inf
            *_, (node, behind, last, _) = self.skeleton(state)
            if behind <= LOOKBACK_M and self.before(*last) is None:
                joining = [
                    s
                    for s in self._at.get(node, ())
                    if s[0] != last[0] and last in self.net.successors(*s, respect_direction=False)
                ]
                if len(joining) > 1:
                    cached = behind
            self._merge[state] = cached
        return cached

    def switches_along(self, way: Sequence[State]) -> tuple[tuple[int, float, State], ...]:
        """The facing switches behind the entry of the last state of ``way``, following
        the way back: ``way`` lists the (edge, direction) states a vehicle ran through,
        oldest first, each entered from the one before; behind the first, its
        :meth:`switches`. As :meth:`switches`: (node, metres of track between it and the
        entry of the last state, the state entered there), nearest first, up to
        :data:`LOOKBACK_M`."""
        out: list[tuple[int, float, State]] = []
        behind = 0.0
        for k in range(len(way) - 1, 0, -1):
            if behind > LOOKBACK_M:
                return tuple(out)
            came, entered = way[k - 1], way[k]
            if self.facing(came):
                out.append((entry_node(self.net, *entered), behind, entered))
            behind += self.net.edge_length(came[0])
        out.extend(
            (n, behind + b, s) for n, b, s in self.switches(way[0]) if behind + b <= LOOKBACK_M
        )
        return tuple(out)

    def switches(self, state: State) -> tuple[tuple[int, float, State], ...]:
        """The facing switches of :meth:`skeleton`, nearest first (cached): (node, metres of
        track between it and the entry of ``state``, the state entered there)."""
        cached = self._switches.get(state)
        if cached is None:
            cached = tuple((n, b, s) for n, b, s, switch in self.skeleton(state) if switch)
            self._switches[state] = cached
        return cached

    def nearest_switch_m(self, edges: IntArray, directions: IntArray) -> FloatArray:
        """Metres of track between the entry of each state and the nearest facing switch
        behind it (:meth:`switches`; ``inf`` where there is none), for arrays of edge ids
        and directions (+1/-1). A junction where tracks join counts as such a switch
        (:meth:`merge_behind_m`): beyond it only the way a vehicle came tells."""
        ids = 2 * edges + (directions < 0)
        near = self._nearest[ids]
        missing = np.isnan(near)
        if missing.any():
            for i in np.unique(ids[missing]).tolist():
                state = (i >> 1, 1 - 2 * (i & 1))
                found = self.switches(state)
                nearest = found[0][1] if found else math.inf
                self._nearest[i] = min(nearest, self.merge_behind_m(state))
            near = self._nearest[ids]
        return near

    def switches_behind(self, state: State) -> frozenset[int]:
        """Nodes of the facing switches a vehicle in ``state`` came through (cached), up to
        :data:`LOOKBACK_M` behind the entry of its edge: for ``released`` of
        :func:`hold_at_switch`, from the state a vehicle was last reported in."""
        cached = self._passed.get(state)
        if cached is None:
            cached = frozenset(n for n, _, _ in self.switches(state))
            self._passed[state] = cached
        return cached


def _first_way(
    net: TrackMap, hypotheses: Sequence[Hypothesis], way: Sequence[State], here: State
) -> list[State]:
    """The states the first hypothesis came through, oldest first, as far as ``way`` (the
    reported position's, ending at ``here``) tells: up to the first hypothesis' state when
    that is on it, ``way`` and then the first hypothesis' state when the position lies
    behind its lineage on the track the lineage entered its edge from, else none."""
    if not hypotheses or not way or tuple(way[-1]) != here:
        return []
    first = (hypotheses[0].edge_id, hypotheses[0].direction)
    states: list[State] = [(int(s[0]), int(s[1])) for s in way]
    if first in states[1:]:
        return states[: states.index(first) + 1]
    if first != here and first in net.successors(*here, respect_direction=False):
        return [*states, first]
    return []


class HypothesisBefore(NamedTuple):
    """A vehicle's hypothesis at the fix before its last.

    Attributes
    ----------
    edge_id, direction, offset_m
        Its place (edge id, +1/-1, m from the edge's start).
    probability : float
    """

    edge_id: int
    direction: int
    offset_m: float
    probability: float


def _chains(
    arrivals: Arrivals, hypotheses: Sequence[Hypothesis] | Sequence[HypothesisBefore]
) -> list[tuple[dict[int, State], float]]:
    """Each hypothesis' passed switches (node: the state entered there, up to
    :data:`LOOKBACK_M` back) and its probability."""
    return [
        ({n: s for n, _, s in arrivals.chain(h.edge_id, h.offset_m, h.direction)}, h.probability)
        for h in hypotheses
    ]


def _branch_share(
    chains: Sequence[tuple[Mapping[int, State], float]],
    states: Sequence[State],
    node: int,
    branch: State,
    trunk: State,
    *,
    along: Collection[State] = (),
) -> float | None:
    """The share of hypotheses that took ``branch`` at the switch ``node`` among those
    that took any branch of it or are still on ``trunk`` before it (``chains``: each
    hypothesis' passed switches and probability; ``states``: each one's state; ``along``:
    states known to lie on ``branch``'s way on, beyond a junction that hides the way
    back); None when no hypothesis is either."""
    mine = others = 0.0
    for (passed, p), here in zip(chains, states, strict=True):
        taken = passed.get(node)
        if taken == branch or (taken is None and here in along):
            mine += p
        elif taken is not None or here == trunk:
            others += p  # on another branch, or still before the switch
    if mine + others == 0.0:
        return None
    return mine / (mine + others)


def entry_node(net: TrackMap, edge: int, direction: int) -> int:
    """The node at which a vehicle in ``(edge, direction)`` entered the edge."""
    e = net.edges[edge]
    return e.start_node if direction == 1 else e.end_node


class SwitchHold(NamedTuple):
    """Where to report a vehicle held at a switch.

    Attributes
    ----------
    edge_id, offset_m, direction
        The end of the track before the switch (edge id, m from the edge's start, +1/-1).
    past_m : float
        How far the position it replaces has run past the switch, m.
    node : int
        The switch's node.
    """

    edge_id: int
    offset_m: float
    direction: int
    past_m: float
    node: int


def hold_at_switch(
    arrivals: Arrivals,
    hypotheses: Sequence[Hypothesis],
    edge: int,
    offset: float,
    direction: int,
    *,
    released: Collection[int] = (),
    route: Collection[int] | None = None,
    way: Sequence[State] = (),
    before: Sequence[HypothesisBefore] | Callable[[], Sequence[HypothesisBefore]] = (),
) -> SwitchHold | None:
    """The switch to report instead of an undecided branch, or None when every switch the
    position has just passed is decided.

    Parameters
    ----------
    arrivals : Arrivals
        Of the map the positions are on.
    hypotheses : sequence of Hypothesis
        The matcher's hypotheses of the vehicle.
    edge, offset, direction
        The position it would report (edge id, m from the edge's start, +1/-1).
    released : collection of int
        Nodes of switches the vehicle has already been reported past: held at again, more
        than :data:`STEP_BACK_M` behind, only while the branch holds less than
        :data:`RELEASED_SHARE`.
    route : collection of int, optional
        Edge ids of the vehicle's planned route: a branch on it is decided.
    way : sequence of (int, int), optional
        The states the reported position came through, oldest first, ending with
        ``(edge, direction)``; the first hypothesis came that way when its state is
        among them or is entered from the last (the position lags its hypothesis by a
        node), and the switches along it are the hypothesis' own
        (:meth:`Arrivals.switches_along`). Without it, the track's own way back
        (:meth:`Arrivals.switches`), which stops where tracks join.
    before : sequence of HypothesisBefore, or a callable giving one, optional
        The vehicle's hypotheses at the fix before its last: a branch is decided only
        when it held :data:`DECIDED_SHARE` of them too, so that one stray fix that swings
        the branches does not decide (empty: not known, a fresh start; the share alone
        decides). A callable is called only when a branch needs them.

    Returns
    -------
    SwitchHold or None
    """
    net = arrivals.net
    along = len(way) > 1 and tuple(way[-1]) == (edge, direction)
    behind_us = arrivals.switches_along(way) if along else arrivals.switches((edge, direction))
    if not behind_us:
        return None
    past0 = offset if direction == 1 else net.edge_length(edge) - offset
    if past0 + behind_us[0][1] > HOLD_M:  # the nearest switch is too far behind
        return None
    switches = [
        (node, past0 + behind, state)
        for node, behind, state in behind_us
        if past0 + behind <= HOLD_M and not (route and state[0] in route)
    ]
    if not switches:
        return None
    chains = _chains(arrivals, hypotheses)
    chains_before: list[tuple[dict[int, State], float]] | None = None
    states_before: list[State] = []
    came = dict(zip(way[1:], way[:-1], strict=False)) if along else {}
    mine_way = _first_way(net, hypotheses, way, (edge, direction))
    if mine_way:
        # the first hypothesis came the reported position's way: the switches along it
        # are the ones it passed, also beyond a junction that hides the track's way back
        passed = {n: s for n, _, s in arrivals.switches_along(mine_way)}
        chains[0] = ({**chains[0][0], **passed}, chains[0][1])
    for node, past, state in reversed(switches):  # the earliest switch first
        trunk = came.get(state) or arrivals.before(*state)
        if trunk is None:  # pragma: no cover - a switch has a track before it
            continue
        now = _branch_share(
            chains, [(h.edge_id, h.direction) for h in hypotheses], node, state, trunk
        )
        if now is None:
            # every hypothesis lies beyond a junction that hides the way back to this
            # switch: none is before it or on another branch, nothing is left open
            continue
        if node in released and past > STEP_BACK_M:
            if now >= RELEASED_SHARE:
                continue
        elif now >= SURE_SHARE:
            continue
        elif now >= DECIDED_SHARE:
            if chains_before is None:
                hyps_before = before() if callable(before) else before
                chains_before = _chains(arrivals, hyps_before)
                states_before = [(h.edge_id, h.direction) for h in hyps_before]
            # beyond a junction only the reported lineage's way tells which branch a
            # hypothesis on it came by
            on_way = mine_way[mine_way.index(state) :] if state in mine_way else []
            then = _branch_share(
                chains_before, states_before, node, state, trunk, along=frozenset(on_way)
            )
            if then is None or then >= DECIDED_SHARE:
                continue
        t_edge, t_dir = trunk
        end = net.edges[t_edge].length_m if t_dir == 1 else 0.0
        return SwitchHold(t_edge, end, t_dir, past, node)
    return None


#: How many edges ahead of the track a vehicle was last reported on its lineage may be and
#: still not have been reported (the branch of a switch at the end of that track, or one
#: beyond a short edge).
_UNREPORTED_EDGES = 2
#: Two hypotheses' log-probabilities this close are a tie (a split without evidence).
TIE_NATS = 1e-9
#: A lineage tied with another hypothesis is a toss for this long after the tie, s: the fix
#: right after a split over the branches seldom decides, and at the next one the lineage
#: and the best no longer stand tied (an outage at a switch; the tram was shown on the
#: lineage's branch at 0.29, two fixes after the tie, against 0.71).
TOSS_MEMORY_S = 10.0


def tossed_lineages(
    net: TrackMap,
    states: npt.NDArray[np.int64],
    parent: npt.NDArray[np.int64],
    slot_log_p: npt.NDArray[np.float64],
    rows: npt.NDArray[np.int64],
    reports: Sequence[Any],
    reported: Mapping[str, tuple[int, int]],
    tied_at: npt.NDArray[np.float64] | None = None,
) -> Callable[[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]],
              npt.NDArray[np.bool_]]:  # fmt: skip
    """The ``tossed`` test of :func:`~antikol.positioning.lineage.plan_slots` for one batch
    of reports: whether a vehicle's lineage was a coin toss that nothing has shown yet.

    Dead-reckoned over a facing switch without fixes, a vehicle splits evenly over the
    branches and its lineage follows one of them, the first slot. Kept until the other
    branch is decisive, as a lineage that has been reported is, it was shown when the
    switch hold ran out, at 0.44 against 0.56, and a few seconds later the vehicle jumped
    to the other branch. A lineage is a toss when its hypothesis and the best candidate's
    parent held the same probability before this fix (or the lineage stood tied with
    another hypothesis within :data:`TOSS_MEMORY_S` before, ``tied_at``), and not yet
    shown when the vehicle was last reported on a track behind it (up to two edges back)
    from which the best candidate is reachable too: then the best leads, and no chain of
    reported positions breaks.

    Parameters
    ----------
    net : TrackMap
    states, parent : ndarray of int
        Per candidate: its track state, and the previous slot it descends from.
    slot_log_p : ndarray of float, shape (vehicle rows, slots)
        The fleet's slot log-probabilities before this fix (slot 0: lineage), read only
        when asked (most batches never ask).
    rows : ndarray of int
        Per report: its vehicle's row.
    reports : sequence of VehicleReport
    reported : mapping
        The (edge, direction) each vehicle was last reported on, by vehicle id.
    tied_at : ndarray of float, optional
        Per vehicle row: when its lineage last stood tied with another hypothesis, s (NaN:
        not since its lineage changed).
    """

    def ahead(origin: tuple[int, int], target: tuple[int, int]) -> bool:
        return enters_within(net, origin, target, _UNREPORTED_EDGES)

    def tossed(
        report: npt.NDArray[np.int64], best: npt.NDArray[np.int64], lineage: npt.NDArray[np.int64]
    ) -> npt.NDArray[np.bool_]:
        out = np.zeros(len(report), dtype=bool)
        triples = zip(report.tolist(), best.tolist(), lineage.tolist(), strict=True)
        for i, (n, b, ln) in enumerate(triples):
            row = rows[n]
            p_lineage, p_best = slot_log_p[row, 0], slot_log_p[row, parent[b]]
            shown = reported.get(reports[n].vehicle_id)
            if parent[b] < 0 or shown is None:
                continue
            recent = tied_at is not None and reports[n].t - tied_at[row] <= TOSS_MEMORY_S
            if abs(p_lineage - p_best) > TIE_NATS and not recent:
                continue
            ours = (int(state_edge(states[ln])), int(state_direction(states[ln])))
            if ours == shown or not ahead(shown, ours):
                continue
            theirs = (int(state_edge(states[b])), int(state_direction(states[b])))
            out[i] = theirs == shown or ahead(shown, theirs)
        return out

    return tossed
