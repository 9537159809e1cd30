"""Tracks side by side that run the same way and meet again ahead: where the reported
position keeps its track rather than jump across.

A vehicle's reported position follows one lineage of hypotheses
(:mod:`antikol.positioning.lineage`), and moves to another when the evidence has moved
there: a jump across to another track, which no permitted move connects. Between two
tracks a few metres apart that run the same way and meet again a short way ahead — the
platform tracks of a terminus, a passing loop, the two tracks of a bubble at a junction —
the jump buys little and costs much:

* both tracks lead to the same place, and the vehicle runs its way on either, so every
  track ahead of it (what the analysis looks along) is the same a few metres on;
* what tells such tracks apart is their lateral offset, a few metres, which is what a GPS
  bias in a street is (several metres, persisting for tens of seconds, with jumps): a jump
  of the bias moves the evidence across, and the lineage with it, and back;
* a jump breaks the chain of reported positions, which a user reads as a vehicle that
  changed track where no switch is.

:attr:`PositioningConfig.same_way_hold_m
<antikol.positioning.config.PositioningConfig.same_way_hold_m>` is how far ahead of the
vehicle such tracks must meet for the lineage to be held on its own track until they do,
where its hypotheses and the others join again — once the vehicle has been reported on it
(a vehicle still held at the switch before the two tracks moves to the best at no break).
The distance is measured from where the two hypotheses put the vehicle, so on two long
parallel tracks only their last stretch counts. Nothing else changes: the reported
probability is the held lineage's own (a held position reads ``ambiguous`` once the
evidence has moved), and the analysis weighs every hypothesis whichever one is reported.

By default it is 50 m: in the last 50 m before two such tracks meet, the jump buys at most
50 m on the right one of two tracks that lead to the same place. Simulated HFP logs showed
what it costs there: a tram on the wrong one of two tracks 5 m apart for a kilometre was
moved to the other one 37 m before they met, on a swing of the bias, and back on the next
(two windows no permitted route connects). A longer hold trades more: a tram put on the
wrong one of two such tracks stays there, however sure the evidence, to their end, where
the positioner would correct it within a few seconds (a jump); see the README's Known
limitations for what 200 m costs and saves. A user who counts a same-way track as right,
and a break in the chain of positions as a failure (a display of where the trams are, a
trace checked without the exact track), may want it longer; 0 turns it off.

>>> import numpy as np, trackmap
>>> from trackmap.synthetic import SyntheticNetwork
>>> from antikol.positioning.reach import ReachTable, state_id
>>> board = SyntheticNetwork()
>>> a = board.track([(0.0, 0.0), (100.0, 0.0)], oneway="yes")
>>> upper = board.track([(100.0, 0.0), (110.0, 4.0), (190.0, 4.0), (200.0, 0.0)], oneway="yes")
>>> lower = board.track([(100.0, 0.0), (200.0, 0.0)], oneway="yes")
>>> b = board.track([(200.0, 0.0), (300.0, 0.0)], oneway="yes")
>>> net = board.build()
>>> siblings = SameWaySiblings(net, ReachTable.for_map(net, reach_m=400.0), meet_within_m=200.0)
>>> def state(way):
...     return state_id(next(e.edge_id for e in net.edges if way in e.way_ids), 1)
>>> bool(siblings.hold([state(upper)], [50.0], [state(lower)], [50.0])[0])
True
>>> bool(siblings.hold([state(b)], [50.0], [state(a)], [50.0])[0])  # one track, ahead
False
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Final

import numpy as np
import numpy.typing as npt
import shapely
from shapely.ops import substring

from antikol.positioning.reach import (
    ReachTable,
    enters_within,
    state_direction,
    state_edge,
    state_id,
)
from trackmap import Path

__all__ = ["SIDE_BY_SIDE_M", "SameWaySiblings"]

#: Two places farther apart than this are on tracks no GPS bias confuses, m.
SIDE_BY_SIDE_M: Final = 10.0
#: Tracks whose headings differ by more than this at the two places are not side by
#: side (a branch leaving at an angle), degrees.
_MAX_HEADING_DIFFERENCE_DEG: Final = 30.0
#: Answers kept before the cache starts afresh (pairs of places to the metre).
_MAX_KEPT: Final = 100_000
#: How many edges the reported position may lag its lineage's hypothesis and still count as
#: reported on it (smoothed along the track, it enters a short edge a fix or two late).
_LAG_EDGES: Final = 2

IntArray = npt.NDArray[np.int64]
FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


class SameWaySiblings:
    """Which changes of lineage cross to a track that runs the same way beside the
    lineage's and meets it again within ``meet_within_m`` ahead.

    Parameters
    ----------
    net : trackmap.TrackMap
    reach : ReachTable
        The positioner's along-track distances and track headings.
    meet_within_m : float
        Farthest ahead of either track's start the two may meet, m (0: never hold; at most
        the table's ``reach_m``).

    Notes
    -----
    Two places are siblings when some route ahead of each reaches a common track within
    ``meet_within_m`` of both places and the two routes up to it stay within
    ``SIDE_BY_SIDE_M`` of each other all the way (their Hausdorff distance): the two
    branches of a facing switch lie that close only for their first metres, and are not
    siblings unless they also run on side by side. The answer is kept per pair of states
    and pair of whole metres of their offsets.
    """

    def __init__(self, net: Any, reach: ReachTable, meet_within_m: float) -> None:
        self.net = net
        self.reach = reach
        self.meet_within_m = min(float(meet_within_m), reach.reach_m)
        self._pairs: dict[tuple[int, int, int, int], bool] = {}
        self._next: dict[tuple[int, int], bool] = {}

    def hold(
        self,
        best_state: Any,
        best_offset_m: Any,
        lineage_state: Any,
        lineage_offset_m: Any,
        *,
        reported: Sequence[tuple[int, int] | None] | None = None,
        lineage_before: Any = None,
    ) -> BoolArray:
        """Whether the lineage at each of its places is held against the best hypothesis.

        Parameters
        ----------
        best_state, best_offset_m : array_like
            The best hypothesis's track state (``2 * edge + (direction < 0)``) and offset
            on its edge, m.
        lineage_state, lineage_offset_m : array_like
            The lineage's.
        reported : sequence of (int, int) or None, optional
            The (edge, direction) each vehicle was last reported on (None: not yet) ...
        lineage_before : array_like of int, optional
            ... and its lineage's previous track state: a lineage is held only where the
            vehicle was reported on it, or on a track up to two edges behind it from which
            the best's is not reached (the reported position, smoothed along the track,
            enters a short edge a fix or two after its lineage). Held at the switch before
            the two tracks (not yet reported on either), it moves to the best at no break
            in the chain.

        Returns
        -------
        ndarray of bool
            True where the two places lie side by side (within ``SIDE_BY_SIDE_M``, headings
            within 30 degrees) on tracks that permit this running direction only, neither
            lies ahead of the other within ``meet_within_m`` (a move there is no jump), and
            their tracks are siblings (see Notes).
        """
        bs = np.atleast_1d(np.asarray(best_state, dtype=np.int64))
        bo = np.atleast_1d(np.asarray(best_offset_m, dtype=float))
        ls = np.atleast_1d(np.asarray(lineage_state, dtype=np.int64))
        lo = np.atleast_1d(np.asarray(lineage_offset_m, dtype=float))
        out = np.zeros(bs.shape, dtype=bool)
        if self.meet_within_m <= 0.0 or len(bs) == 0:
            return out
        # the tests on states first (most asks end there), then the geometry of the rest
        near = bs != ls
        # one-way tracks only: two tracks that permit both ways (a double track whose
        # directions the map does not give) may be the two directions' tracks
        near &= ~self.reach.allowed[bs ^ 1] & ~self.reach.allowed[ls ^ 1]
        if reported is not None and lineage_before is not None:
            before = np.atleast_1d(np.asarray(lineage_before, dtype=np.int64)).tolist()
            near &= np.array(
                [
                    self._reported_on(r, s, b)
                    for r, s, b in zip(reported, before, bs.tolist(), strict=True)
                ],
                dtype=bool,
            )
        if not near.any():
            return out
        k = np.flatnonzero(near)
        be, le = state_edge(bs[k]), state_edge(ls[k])
        bx, by = self.net.points_at(be, bo[k])
        lx, ly = self.net.points_at(le, lo[k])
        beside = np.hypot(np.asarray(bx) - lx, np.asarray(by) - ly) <= SIDE_BY_SIDE_M
        turn = self.reach.headings.at(be, bo[k], state_direction(bs[k])) - self.reach.headings.at(
            le, lo[k], state_direction(ls[k])
        )
        beside &= np.cos(np.radians(turn)) >= math.cos(math.radians(_MAX_HEADING_DIFFERENCE_DEG))
        near[k] = beside
        if not near.any():
            return out
        k = np.flatnonzero(near)
        within = self.meet_within_m
        apart = (self.reach.ahead(ls[k], lo[k], bs[k], bo[k], physical=False) > within) & (
            self.reach.ahead(bs[k], bo[k], ls[k], lo[k], physical=False) > within
        )
        for i in k[apart].tolist():
            out[i] = self._siblings(int(ls[i]), float(lo[i]), int(bs[i]), float(bo[i]))
        return out

    def asker(
        self,
        states: IntArray,
        offsets_m: FloatArray,
        reports: Sequence[Any],
        rows: IntArray,
        slots: IntArray,
        reported: Mapping[str, tuple[int, int]],
    ) -> Callable[[IntArray, IntArray, IntArray], BoolArray] | None:
        """The ``same_way`` test of :func:`~antikol.positioning.lineage.plan_slots` for one
        batch of reports (None while the hold is off).

        Parameters
        ----------
        states, offsets_m : ndarray
            Per candidate: track state and offset on its edge, m.
        reports : sequence of VehicleReport
        rows : ndarray of int
            Each report's vehicle row in ``slots``.
        slots : ndarray of int, shape (vehicles, slots)
            The vehicles' previous hypotheses' track states (slot 0: the lineage).
        reported : mapping
            The (edge, direction) each vehicle was last reported on, by vehicle id.
        """
        if self.meet_within_m <= 0.0:
            return None

        def same_way(report: IntArray, best: IntArray, lineage: IntArray) -> BoolArray:
            return self.hold(
                *(states[best], offsets_m[best], states[lineage], offsets_m[lineage]),
                reported=[reported.get(reports[n].vehicle_id) for n in report.tolist()],
                lineage_before=slots[rows[report], 0],
            )

        return same_way

    def _reported_on(self, reported: tuple[int, int] | None, lineage: int, best: int) -> bool:
        """Whether the vehicle was reported on its lineage: on the lineage's track, or on
        one up to :data:`_LAG_EDGES` behind it from which the best's track is not reached
        (the reported position is smoothed along the track and lags the lineage's
        hypothesis by an edge or two at a node; held at a switch before both, it reaches
        the best's track too, and a move there is no jump)."""
        if reported is None:
            return False
        shown = int(state_id(*reported))
        if shown == lineage:
            return True
        return self._follows(shown, lineage) and best != shown and not self._follows(shown, best)

    def _follows(self, origin: int, target: int) -> bool:
        """Whether ``target`` is entered from ``origin`` within :data:`_LAG_EDGES` steps."""
        key = (origin, target)
        found = self._next.get(key)
        if found is None:
            found = enters_within(
                self.net,
                (int(state_edge(origin)), int(state_direction(origin))),
                (int(state_edge(target)), int(state_direction(target))),
                _LAG_EDGES,
            )
            if len(self._next) >= _MAX_KEPT:
                self._next.clear()
            self._next[key] = found
        return found

    def _siblings(self, a: int, a_offset_m: float, b: int, b_offset_m: float) -> bool:
        here = ((a, math.floor(a_offset_m)), (b, math.floor(b_offset_m)))
        (sa, oa), (sb, ob) = sorted(here)
        key = (sa, oa, sb, ob)
        found = self._pairs.get(key)
        if found is None:
            if len(self._pairs) >= _MAX_KEPT:
                self._pairs.clear()
            found = self._pairs[key] = self._meet_beside(sa, float(oa), sb, float(ob))
        return found

    def _ways(self, state: int, offset_m: float) -> list[Path]:
        """The permitted routes ahead of a place, ``meet_within_m`` long."""
        edge, direction = int(state_edge(state)), int(state_direction(state))
        offset_m = min(max(offset_m, 0.0), self.net.edge_length(edge))
        return self.net.paths_ahead(edge, offset_m, direction, self.meet_within_m)

    def _meet_beside(self, a: int, a_offset_m: float, b: int, b_offset_m: float) -> bool:
        ways_a, ways_b = self._ways(a, a_offset_m), self._ways(b, b_offset_m)
        for way_a in ways_a:
            on_a = {(st.edge_id, int(st.direction)): st for st in way_a.steps[1:]}
            for way_b in ways_b:
                meet = next(
                    (
                        (on_a[key].start_m, st.start_m)
                        for st in way_b.steps[1:]
                        if (key := (st.edge_id, int(st.direction))) in on_a
                    ),
                    None,
                )
                if meet is None or meet[0] <= 0.0 or meet[1] <= 0.0:
                    continue
                line_a = substring(self.net.path_geometry(way_a), 0.0, meet[0])
                line_b = substring(self.net.path_geometry(way_b), 0.0, meet[1])
                if shapely.hausdorff_distance(line_a, line_b) <= SIDE_BY_SIDE_M:
                    return True
        return False
