"""Where to report a vehicle that has just passed a facing switch whose branch is open.

A few metres past a switch the branches lie closer together than GPS can tell apart; the
matcher keeps a hypothesis on each and the most probable one may still change. Reporting
the vehicle on a branch it is not sure of, then on the other, gives positions that no
permitted move connects. While the branches' hypotheses are undecided, the vehicle is
reported at the switch itself, on the track before it, with its along-track uncertainty
grown by the distance it has run past the switch: every branch it may be on starts there.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence

from antikol.positioning.records import Hypothesis
from trackmap import TrackMap

__all__ = ["Arrivals", "hold_at_switch"]

#: Past a switch farther than this, the branch is reported even if undecided, m.
HOLD_M = 40.0
#: A branch holding this share of the branches' probability is decided.
DECIDED_SHARE = 0.9


class Arrivals:
    """The (edge, direction) states that arrive at each node of a map (built once)."""

    def __init__(self, net: TrackMap) -> None:
        self.net = net
        self._at: dict[int, list[tuple[int, int]]] = defaultdict(list)
        for e in net.edges:
            self._at[e.end_node].append((e.edge_id, 1))
            self._at[e.start_node].append((e.edge_id, -1))

    def trunk(self, node: int, edge: int, direction: int) -> tuple[int, int] | None:
        """A state arriving at ``node`` from which ``(edge, direction)`` is entered."""
        for state in self._at.get(node, ()):
            if state[0] == edge:
                continue
            if (edge, direction) in self.net.successors(*state, respect_direction=False):
                return state
        return None


def _entry(net: TrackMap, edge: int, offset: float, direction: int) -> tuple[int, float]:
    e = net.edges[edge]
    return (e.start_node, offset) if direction == 1 else (e.end_node, e.length_m - offset)


def hold_at_switch(
    arrivals: Arrivals,
    hypotheses: Sequence[Hypothesis],
    edge: int,
    offset: float,
    direction: int,
) -> tuple[int, float, int, float] | None:
    """The switch to report instead of an undecided branch: (edge, offset, direction of
    the track before it, metres run past it), or None when the branch is decided.

    Parameters
    ----------
    arrivals : Arrivals
        Of the map the positions are on.
    hypotheses : sequence of Hypothesis
        The matcher's hypotheses of the vehicle.
    edge, offset, direction
        The position it would report (edge id, m from the edge's start, +1/-1).
    """
    net = arrivals.net
    node, past_m = _entry(net, edge, offset, direction)
    if past_m > HOLD_M:
        return None
    mine = others = 0.0
    for h in hypotheses:
        h_node, h_past = _entry(net, h.edge_id, h.offset_m, h.direction)
        if h_node != node or h_past > HOLD_M:
            continue
        if h.edge_id == edge and h.direction == direction:
            mine += h.probability
        elif h.edge_id != edge:
            others += h.probability
    if others <= 0.0 or mine / (mine + others) >= DECIDED_SHARE:
        return None
    trunk = arrivals.trunk(node, edge, direction)
    if trunk is None:
        return None
    t_edge, t_dir = trunk
    end = net.edges[t_edge].length_m if t_dir == 1 else 0.0
    return t_edge, end, t_dir, past_m
