"""Where each matched vehicle is reported: its lineage moved to the asked time, held at an
undecided switch, and its status.

The reported place follows the first hypothesis (the reported lineage) by the along-track
filter's travel since the lineage's last fix (:func:`~antikol.positioning.deadreckoning.advance`),
then :func:`~antikol.positioning.branching.hold_at_switch` may report it at a switch it has
just passed whose branch is still open. Most vehicles of a cycle stay on their lineage's
edge and have no switch within :data:`~antikol.positioning.branching.HOLD_M` behind them:
:func:`place_vehicles` places those in array operations and only the others one at a time,
with the same numbers either way (a test compares the two).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from antikol.kinds import PositionStatus
from antikol.positioning.branching import (
    HOLD_M,
    TWO_FIXES_BELOW_MPS,
    Arrivals,
    HypothesisBefore,
    hold_at_switch,
)
from antikol.positioning.config import PositioningConfig
from antikol.positioning.deadreckoning import Advanced, advance, edge_mass
from antikol.positioning.fleet import FleetState
from antikol.positioning.outputs import Placement
from antikol.positioning.reach import ReachTable, state_direction, state_edge
from antikol.positioning.records import Hypothesis
from trackmap import TrackMap

__all__ = ["Estimate", "place_one", "place_probabilities", "place_vehicles"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
#: A move shorter than this leaves the position where it is, m (as ``advance``).
_NO_MOVE_M = 1e-6
#: Below this many vehicles the array path costs more than it saves.
ARRAY_FROM = 16
_STATUSES: tuple[PositionStatus, ...] = ("confident", "ambiguous", "lost")

#: The along-track filter's estimate of each vehicle: position (m along its history),
#: speed (m/s) and the position's standard deviation (m), parallel arrays.
Estimate = tuple[FloatArray, FloatArray, FloatArray]


def _exhausted(
    fleet: FleetState, rows: npt.NDArray[np.int64], when_s: npt.ArrayLike, config: PositioningConfig
) -> npt.NDArray[np.bool_]:
    """Whether the vehicles' dead reckoning at ``when_s`` (s) has run out: beyond
    ``odometer_dead_reckoning_m`` on the odometer; without one, beyond ``dead_reckoning_s``
    past the last report (reports without a fix carry the vehicle on their speeds, so a
    tram in a tunnel that keeps reporting is not lost after that time, only after the
    odometer's distance or when its uncertainty passes ``lost_sigma_m``)."""
    when = np.asarray(when_s, dtype=float)
    odometer_run = fleet.odo[rows] - fleet.odo_fix[rows]
    t_nofix = fleet.t_nofix[rows]
    reported = np.isfinite(t_nofix)
    since = when - np.where(reported, t_nofix, fleet.t_fix[rows])
    by_speeds = (since > config.dead_reckoning_s) | (
        reported & (fleet.run_nofix[rows] > config.odometer_dead_reckoning_m)
    )
    return np.asarray(
        np.where(
            np.isfinite(odometer_run), odometer_run > config.odometer_dead_reckoning_m, by_speeds
        ),
        dtype=bool,
    )


def _confident(place_p: npt.ArrayLike, run: npt.ArrayLike, config: PositioningConfig) -> Any:
    """Whether places are ``confident``: probability at least ``confidence``, held at
    ``confident_after`` matches in a row or at least ``sure_probability`` (arrays or
    scalars, numpy booleans)."""
    p = np.asarray(place_p)
    return (p >= config.confidence) & (
        (np.asarray(run) >= config.confident_after) | (p >= config.sure_probability)
    )


def place_vehicles(
    net: TrackMap,
    arrivals: Arrivals,
    fleet: FleetState,
    config: PositioningConfig,
    vehicle_ids: Sequence[str],
    rows: IntArray,
    when_s: FloatArray,
    estimate: Estimate,
    hypotheses: Sequence[tuple[Hypothesis, ...]],
    bases: Sequence[tuple[int, int] | None],
    *,
    array_from: int = ARRAY_FROM,
) -> list[Placement]:
    """Place matched vehicles at the asked times.

    Parameters
    ----------
    net : TrackMap
    arrivals : Arrivals
        Of ``net`` (the switch hold's look-ups).
    fleet : FleetState
        The matcher's state (read only).
    config : PositioningConfig
    vehicle_ids : sequence of str
    rows : ndarray of int
        Each vehicle's row in ``fleet`` (every one matched, with a report).
    when_s : ndarray of float
        Time each is placed at, s.
    estimate : Estimate
        The along-track filter's estimate of each at ``when_s``.
    hypotheses : sequence of tuple of Hypothesis
        Each vehicle's hypotheses, its reported lineage first.
    bases : sequence of (int, int) or None
        Where each was placed before (edge id, direction): switches behind it are released.
    array_from : int, keyword-only
        From this many vehicles on, those that stay on their lineage's edge away from
        switches are placed in array operations (tests set 0 to exercise it always).

    Returns
    -------
    list of Placement
        In the order of ``vehicle_ids``.
    """
    n = len(vehicle_ids)
    s, v, s_std = estimate
    s_std = np.where(np.isnan(s_std), np.inf, s_std)  # (an absurd time: no bound on it)

    def one_at_a_time(i: int) -> Placement:
        return place_one(
            net,
            arrivals,
            fleet,
            config,
            vehicle_ids[i],
            int(rows[i]),
            float(when_s[i]),
            (s[i], v[i], s_std[i]),
            hypotheses[i],
            bases[i],
        )

    if n < max(array_from, 1):
        return [one_at_a_time(i) for i in range(n)]
    state = fleet.hs[rows, 0]
    edge = state >> 1
    direction = 1 - 2 * (state & 1)
    offset = fleet.ho[rows, 0]
    run = s - fleet.z[rows]
    still = np.abs(run) < _NO_MOVE_M
    moved = np.where(still, offset, offset + direction * run)
    length = arrivals.lengths_m[edge]
    past = np.where(direction == 1, moved, length - moved)
    plain = (still | ((moved >= 0.0) & (moved <= length))) & ~(
        past + arrivals.nearest_switch_m(edge, direction) <= HOLD_M
    )
    age = when_s - fleet.t_fix[rows]
    lost = _exhausted(fleet, rows, when_s, config) | (s_std > config.lost_sigma_m)
    place_p = fleet.place[rows]
    confident = _confident(place_p, fleet.confident_run[rows], config)
    # the status of each plainly placed vehicle (an index into _STATUSES), -1 the others
    code = np.where(plain, np.where(lost, 2, np.where(confident, 0, 1)), -1).tolist()
    offsets, speeds, probabilities, sigmas, times = (
        a.tolist() for a in (moved, v, place_p, s_std, when_s)
    )
    reckoned = np.maximum(age, 0.0).tolist()
    row_of = rows.tolist()
    named_lost = fleet.lost
    out: list[Placement] = []
    for i, k in enumerate(code):
        if k < 0:
            out.append(one_at_a_time(i))
            continue
        hyps = hypotheses[i]
        first = hyps[0]
        out.append(
            Placement(
                vehicle_ids[i],
                times[i],
                "lost" if named_lost[row_of[i]] is not None else _STATUSES[k],
                first.edge_id,
                first.direction,
                offsets[i],
                speeds[i],
                probabilities[i],
                sigmas[i],
                first.wrong_way,
                hyps,
                reckoned[i],
            )
        )
    return out


def place_one(
    net: TrackMap,
    arrivals: Arrivals,
    fleet: FleetState,
    config: PositioningConfig,
    vehicle_id: str,
    row: int,
    t: float,
    estimate: tuple[float, float, float],
    hyps: tuple[Hypothesis, ...],
    basis: tuple[int, int] | None,
) -> Placement:
    """Where one matched vehicle is at ``t`` (s) from its along-track estimate (position,
    speed, sigma: m, m/s, m), its hypotheses and where it was placed before (``basis``:
    edge, direction); see :func:`place_vehicles`."""
    s, v, s_std = estimate
    s_std = math.inf if math.isnan(s_std) else s_std  # (as in place_vehicles)
    c = config
    last = fleet.last[row]
    if last is None:  # pragma: no cover - only vehicles with a report are placed
        raise RuntimeError(f"positioning state of {vehicle_id!r} without a report")
    first = hyps[0]
    entered = int(fleet.hv[row, 0])
    moved = advance(
        net,
        first.edge_id,
        first.offset_m,
        first.direction,
        float(s) - fleet.z[row],
        last,
        wrong=first.wrong_way,
        edge_mass=edge_mass(hyps),
        # a position behind its lineage goes back the way the vehicle came (else it stops
        # at a node): where it was placed before when the last fix was a forgiven outlier
        # (the lineage sits at the outlier's place), else the track the lineage entered
        # its edge from (a fix off along the track, under the gate, can carry the lineage
        # over a node the filter has not reached)
        came_from=basis
        if fleet.gated[row]
        else ((int(state_edge(entered)), int(state_direction(entered))) if entered >= 0 else None),
    )
    edge, off, direction = moved.edge_id, moved.offset_m, moved.direction
    place_p = float(fleet.place[row]) * moved.branch_share
    # held at an undecided switch behind it? (None at once when there is none)
    way = _way(net, first, entered, moved)
    held = hold_at_switch(
        arrivals,
        hyps,
        edge,
        off,
        direction,
        released=_released(arrivals, basis, way),
        route=last.route,
        way=way,
        before=(lambda: [HypothesisBefore(*h) for h in fleet.hypotheses_before(row)])
        if float(v) < TWO_FIXES_BELOW_MPS
        else (),
    )
    if held is not None:
        edge, off, direction, past_m, _ = held
        s_std, place_p = s_std + past_m, float(fleet.place[row])
    age = t - float(fleet.t_fix[row])
    exhausted = bool(_exhausted(fleet, np.array([row], dtype=np.int64), t, c)[0])
    status: PositionStatus
    if fleet.lost[row] is not None or exhausted or float(s_std) > c.lost_sigma_m:
        status = "lost"
    elif _confident(place_p, fleet.confident_run[row], c):
        status = "confident"
    else:
        status = "ambiguous"
    return Placement(
        vehicle_id,
        t,
        status,
        edge,
        direction,
        off,
        float(v),
        place_p,
        float(s_std),
        first.wrong_way,
        hyps,
        max(age, 0.0),
        held is not None,
    )


def _released(
    arrivals: Arrivals, basis: tuple[int, int] | None, way: list[tuple[int, int]]
) -> frozenset[int]:
    """Nodes of the switches the vehicle was reported past: behind where it was placed
    before (``basis``), by the track's way back, and when ``basis`` lies on the reported
    position's ``way``, along that way too (the track's way back stops where tracks join:
    a tram reported past a switch, then past a junction, was held at the switch again)."""
    if basis is None:
        return frozenset()
    behind = arrivals.switches_behind(basis)
    if basis not in way[1:]:
        return behind
    along = arrivals.switches_along(way[: way.index(basis) + 1])
    return behind | {node for node, _, _ in along}


def _way(net: TrackMap, first: Hypothesis, entered: int, moved: Advanced) -> list[tuple[int, int]]:
    """The states the reported position came through, oldest first, ending where it is:
    the state its lineage entered its edge from (when known), the lineage's, and those a
    forward move ran into (only where it is, when it moved back)."""
    here = (moved.edge_id, moved.direction)
    lineage = (first.edge_id, first.direction)
    if here != lineage and not moved.via:
        return [here]  # moved back off the lineage's edge
    way = [lineage, *moved.via]
    if entered >= 0:
        came = (int(state_edge(entered)), int(state_direction(entered)))
        if lineage in net.successors(*came, respect_direction=False):
            way.insert(0, came)
    return way


def place_probabilities(
    fleet: FleetState,
    reach: ReachTable,
    rows: npt.NDArray[np.int64],
    *,
    same_place_m: float,
    same_state_m: float,
) -> npt.NDArray[np.float64]:
    """Probability of each vehicle's reported place: its hypothesis plus those at the same
    spot (the same state within ``same_state_m``, or within ``same_place_m`` across a
    plain node).

    Parameters
    ----------
    fleet : FleetState
        The hypotheses (``hs``, ``ho``, ``hp``; read only).
    reach : ReachTable
    rows : ndarray of int
        The vehicles' rows.
    same_place_m : float, keyword-only
        Hypotheses this close along the track are at the same spot, m.
    same_state_m : float, keyword-only
        Hypotheses of one state (edge and direction) farther apart along it than this are
        at two places, m: a turning loop's two sides are one edge, metres apart across
        and hundreds along (:func:`~antikol.positioning.candidates.find_candidates` gives
        its other side a candidate only that far from its nearest point, twice the search
        radius at least). Counted as one, a fix between the sides showed the vehicle on
        the side holding 0.70 as 0.999, confident; the next fix took the other side.

    Returns
    -------
    ndarray of float
        At most 1.
    """
    hs, ho = fleet.hs[rows], fleet.ho[rows]
    filled = hs >= 0
    prob = np.where(filled, np.exp(fleet.hp[rows]), 0.0)
    if not filled[:, 1:].any():  # (most often one hypothesis: no distance to measure)
        return np.minimum(np.sum(prob, axis=1), 1.0)
    first = np.zeros(hs.shape[1], dtype=np.intp)  # slot 0 in every column
    others = np.where(filled, hs, 0)
    gap = reach.between(hs[:, first], ho[:, first], others, ho)
    same = (hs == hs[:, first]) & (np.abs(ho - ho[:, first]) <= same_state_m)
    same |= np.abs(gap) <= same_place_m
    same[:, 0] = True
    return np.minimum(np.sum(np.where(same & filled, prob, 0.0), axis=1), 1.0)
