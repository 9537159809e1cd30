"""Positions in hindsight: a log's best connected path through its track hypotheses.

Online, a vehicle's position at a report rests on the fixes up to that report: past a
facing switch onto two tracks side by side, or with a street bias as wide as the gap
between a double track's two tracks, the fixes that tell the track apart may come tens of
seconds later, and the position shown until then is the likelier track *so far*. An
archive (an operator's feed, an on-board log) has the later fixes too. Its analyst wants
each report placed where the whole log puts it, and a chain of places that permitted
moves connect.

:func:`hindsight_positions` takes the positions a
:class:`~antikol.positioning.matcher.Positioner` gave at each report (their kept
hypotheses and probabilities: the forward pass) and runs the backward pass of a discrete
smoother over them:

* **places** — at each report, the position shown online and each kept hypothesis'
  place on its track. A hypothesis' place is the fix projected on its track, moved along
  it by what the along-track filter moved the shown one (so that every place is as smooth
  along the track as the shown one);
* **moves** — from a place at one report to a place at the next, the distance along
  permitted moves (:func:`track_step_m`, the rule of the 10-s window check in
  :mod:`antikol.evaluation.consistency`), weighed against the distance the vehicle ran
  (its odometer, else its speeds) on the matcher's Laplace scale; a place the other cannot
  reach has no move. A place's moves share one: they say which of the next report's
  places it leads to, not how likely the place itself is (the online probabilities have
  already weighed every place's run against the distance run);
* **probabilities** — each place's probability given the whole log, by the discrete
  Rauch–Tung–Striebel recursion from the last report back: the online probability times
  how well its moves lead to where the later reports put the vehicle;
* **the path** — from the likeliest place at the last report, backwards: at each report
  the place with the largest online probability times its move to the place chosen after
  it. Successive places are connected wherever a hypothesis kept online connects them; a
  vehicle whose right track was not among its hypotheses for a while keeps its online
  place there, and the path starts again after that report.

A vehicle not shown online at a report (a fresh start whose fixes did not yet tell its
track, a coin toss over a switch in an outage), or shown ``lost`` (dead-reckoned for too
long), is placed in hindsight wherever it has hypotheses. Reports without hypotheses
(no track near, never matched) keep their online position and split the log into
separate paths.

This is an offline tool: the on-board unit has no later fixes, and its lamp rests on the
online positions. ``antikol match`` reports both.

>>> from trackmap.synthetic import SyntheticNetwork
>>> from antikol.positioning.matcher import Positioner
>>> from antikol.report import VehicleReport
>>> board = SyntheticNetwork()
>>> board.track([(0.0, 0.0), (1000.0, 0.0)], oneway="yes")
1
>>> net = board.build()
>>> pos = Positioner(net)
>>> def fix(t):
...     lon, lat = board.lonlat(100.0 + 8.0 * t, 1.0)
...     return VehicleReport("T1", float(t), lat, lon, speed_mps=8.0, course_deg=90.0)
>>> reports = [fix(t) for t in range(20)]
>>> online = [pos.update(r) for r in reports]
>>> later = hindsight_positions(net, reports, online)
>>> [p.edge_id for p in later[-3:]], round(later[-1].probability, 3)
([0, 0, 0], 1.0)
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import replace
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from antikol.errors import InvalidArgumentError
from antikol.kinds import PositionStatus
from antikol.positioning.branching import STEP_BACK_M  # (a step back no window counts)
from antikol.positioning.records import TrackPosition
from antikol.report import VehicleReport
from trackmap import TrackMap
from trackmap.model import RouteDistance

__all__ = [
    "BRIDGE_S",
    "CARRY_MOVE_S",
    "MAX_SPEED_MPS",
    "REACH_MARGIN_M",
    "SAME_PLACE_M",
    "STEP_BACK_M",
    "hindsight_positions",
    "reach_m",
    "track_step_m",
]

#: What a tram can run between two reports, for the reach of a move, m/s.
MAX_SPEED_MPS = 25.0
#: Reach of a move beyond ``MAX_SPEED_MPS`` times the time between the reports, m.
REACH_MARGIN_M = 30.0
#: How far back a place is looked for that reaches the place chosen after a report when
#: no place at that report does (the online hypotheses lost the vehicle's track), s.
BRIDGE_S = 15.0
#: How long the along-track filter's move of a shown position is carried to reports where
#: it is not shown on its first hypothesis' track (held at a switch), s.
CARRY_MOVE_S = 10.0
#: Hypotheses whose fixes project this close along the track are at one spot (the two
#: ends of a node; the matcher sums a place's probability over them), m.
SAME_PLACE_M = 3.0
#: Scale of the mismatch between a move and the distance run, m, plus a tenth of the run
#: (the matcher's ``transition_beta_m`` without an odometer).
_MOVE_SCALE_M = 6.0
_MOVE_SCALE_SHARE = 0.1
#: A move's weight never falls below this (a connected move is always possible).
_MIN_MOVE_WEIGHT = 1e-12

FloatArray = npt.NDArray[np.float64]


class _Place(NamedTuple):
    """A place a vehicle may be at one report."""

    edge_id: int
    direction: int
    offset_m: float
    wrong_way: bool
    probability: float
    shown: bool  # the position shown online at that report
    hypothesis: int  # the online hypothesis it stands for (the shown one: the first)
    fix_place: tuple[int, float, int]  # that hypothesis' own place: its fix's projection


def reach_m(dt_s: float) -> float:
    """How far a vehicle may have moved along the track in ``dt_s`` seconds, m."""
    return REACH_MARGIN_M + MAX_SPEED_MPS * max(dt_s, 0.0)


def track_step_m(
    net: TrackMap,
    start: tuple[int, float, int],
    end: tuple[int, float, int],
    *,
    cutoff_m: float,
    permitted: bool = True,
) -> float | None:
    """Distance along the track from one place to the next, over moves a vehicle may make.

    Parameters
    ----------
    net : TrackMap
    start, end : (int, float, int)
        Edge id, offset (m from the edge's first vertex) and running direction (+1/-1) of
        each place.
    cutoff_m : float
        Farthest move looked for, m.
    permitted : bool, keyword-only
        Only moves the tracks' permitted directions allow (False: any physical move, for a
        vehicle running wrong way).

    Returns
    -------
    float or None
        The distance (m) arriving in ``end``'s direction; negative when ``end`` lies up
        to :data:`STEP_BACK_M` behind ``start`` on its track (a filtered position may step
        back that far); None when ``end`` is out of reach.
    """
    (se, so, sd), (ee, eo, ed) = start, end
    fwd = net.route_distance(se, so, sd, ee, eo, cutoff_m=cutoff_m, respect_direction=permitted)
    if fwd is not None and fwd.arrival_direction == ed:
        return float(fwd.distance_m)
    if ed != sd and ee == se:
        return None
    back = net.route_distance(ee, eo, ed, se, so, cutoff_m=STEP_BACK_M, respect_direction=permitted)
    if back is not None and back.arrival_direction == sd:
        return -float(back.distance_m)
    return None


def hindsight_positions(
    net: TrackMap,
    reports: Sequence[VehicleReport],
    positions: Sequence[TrackPosition],
    *,
    confidence: float = 0.8,
) -> list[TrackPosition]:
    """Place every report where the whole log puts it (see the module).

    Parameters
    ----------
    net : TrackMap
        The map the positions are on.
    reports : sequence of VehicleReport
        The log's reports, each vehicle's in time order (as
        :func:`~antikol.evaluation.consistency.match_reports` gives them).
    positions : sequence of TrackPosition
        The online position right after each report, with its hypotheses.
    confidence : float, keyword-only
        A place whose probability given the whole log reaches this is ``confident``, else
        ``ambiguous`` (the matcher's ``PositioningConfig.confidence``).

    Returns
    -------
    list of TrackPosition
        One per report, in order: at the place the path takes, with its probability given
        the whole log; the online position where the report has no hypotheses.

    Raises
    ------
    InvalidArgumentError
        When ``reports`` and ``positions`` differ in length, or a vehicle's reports go
        back in time.
    """
    if len(reports) != len(positions):
        raise InvalidArgumentError(
            "positions",
            len(positions),
            f"one position per report, and there are {len(reports)} reports",
        )
    out = list(positions)
    per_vehicle: dict[str, list[int]] = defaultdict(list)
    for i, r in enumerate(reports):
        before = per_vehicle[r.vehicle_id]
        if before and r.t < reports[before[-1]].t:
            raise InvalidArgumentError(
                "reports",
                f"report {i} of {r.vehicle_id!r} at t = {r.t} s",
                f"each vehicle's reports in time order (its report {before[-1]} is at "
                f"t = {reports[before[-1]].t} s)",
            )
        before.append(i)
    for idx in per_vehicle.values():
        places = []
        moved: tuple[float, float] | None = None  # (time, m) where the filter last showed it
        for i in idx:
            position = positions[i]
            if moved is not None and position.t - moved[0] > CARRY_MOVE_S:
                moved = None
            here, moved_m = _places(net, position, None if moved is None else moved[1])
            if moved_m is not None:
                moved = (position.t, moved_m)
            places.append(here)
        start = 0
        for k in range(len(idx) + 1):
            if k == len(idx) or not places[k]:
                if k > start:
                    run = idx[start:k]
                    chosen = _smooth_run(net, [reports[i] for i in run], places[start:k])
                    for i, (place, p) in zip(run, chosen, strict=True):
                        out[i] = _as_position(net, positions[i], place, p, confidence)
                start = k + 1
    return out


def _places(
    net: TrackMap, position: TrackPosition, moved_before_m: float | None
) -> tuple[tuple[_Place, ...], float | None]:
    """The shown position and each hypothesis' place, moved along as the shown one was
    (or as it was at an earlier report, ``moved_before_m``, m, when it is not shown on its
    first hypothesis' track); and that move, m (None when not shown there)."""
    hyps = position.hypotheses
    if not hyps:
        return (), None
    first = hyps[0]
    shown = position.matched and position.edge_id is not None and position.offset_m is not None
    on_first = shown and (position.edge_id, position.direction) == (
        first.edge_id,
        first.direction,
    )
    # how far the along-track filter moved the shown position from its fix's projection
    # (a late receiver's fix lies behind by its speed times its latency)
    moved_now = (
        (position.offset_m - first.offset_m) * first.direction
        if on_first and position.offset_m is not None
        else None
    )
    moved_m = moved_now if moved_now is not None else (moved_before_m or 0.0)
    # a shown position off its first hypothesis' track (held at a switch it has passed)
    # and that hypothesis' own place are one hypothesis: they share its probability
    share = 0.5 if shown and not on_first else 1.0
    places: list[_Place] = []
    if shown:
        places.append(
            _Place(
                int(position.edge_id),  # type: ignore[arg-type]
                int(position.direction or 1),
                float(position.offset_m),  # type: ignore[arg-type]
                position.wrong_way,
                share * first.probability,
                True,
                0,
                (first.edge_id, first.offset_m, first.direction),
            )
        )
    for j, h in enumerate(hyps):
        if j == 0 and on_first:
            continue
        length = net.edge_length(h.edge_id)
        offset = min(max(h.offset_m + h.direction * moved_m, 0.0), length)
        p = share * h.probability if j == 0 else h.probability
        own = (h.edge_id, h.offset_m, h.direction)
        places.append(_Place(h.edge_id, h.direction, offset, h.wrong_way, p, False, j, own))
    return tuple(places), moved_now


def _travelled_m(before: VehicleReport, after: VehicleReport) -> float:
    """Distance run between two reports: the odometer's increment, else the mean speed's."""
    if (
        before.odometer_m is not None
        and after.odometer_m is not None
        and after.odometer_m >= before.odometer_m
    ):
        return float(after.odometer_m - before.odometer_m)
    speeds = [v for v in (before.speed_mps, after.speed_mps) if v is not None and v == v]
    mean = sum(speeds) / len(speeds) if speeds else 0.0
    return mean * max(after.t - before.t, 0.0)


def _moves(
    net: TrackMap,
    before: tuple[_Place, ...],
    after: tuple[_Place, ...],
    dt_s: float,
    travelled_m: float,
) -> FloatArray:
    """Weights of the moves from each place before to each after (0: none), rows summing
    to 1 where a move exists."""
    scale = _MOVE_SCALE_M + _MOVE_SCALE_SHARE * travelled_m
    cutoff = reach_m(dt_s)
    w = np.zeros((len(before), len(after)))
    for a, pa in enumerate(before):
        for b, pb in enumerate(after):
            d = track_step_m(
                net,
                (pa.edge_id, pa.offset_m, pa.direction),
                (pb.edge_id, pb.offset_m, pb.direction),
                cutoff_m=cutoff,
                permitted=not (pa.wrong_way or pb.wrong_way),
            )
            if d is not None:
                w[a, b] = max(math.exp(-abs(d - travelled_m) / scale), _MIN_MOVE_WEIGHT)
    total = w.sum(axis=1, keepdims=True)
    return np.divide(w, total, out=np.zeros_like(w), where=total > 0)


def _smooth_run(
    net: TrackMap, reports: Sequence[VehicleReport], places: Sequence[tuple[_Place, ...]]
) -> list[tuple[_Place, float]]:
    """The chosen place at each report of one vehicle's unbroken run, with its
    probability given the whole run."""
    n = len(places)
    filtered = [_online_probabilities(p) for p in places]
    moves: list[FloatArray | None] = [None] * n
    for k in range(1, n):
        dt = reports[k].t - reports[k - 1].t
        moves[k] = _moves(
            net, places[k - 1], places[k], dt, _travelled_m(reports[k - 1], reports[k])
        )
    # backwards: the places' probabilities given the whole run (the discrete
    # Rauch-Tung-Striebel step) and the path, one report at a time
    smoothed: list[FloatArray] = [filtered[-1]] * n
    chosen = [0] * n
    chosen[-1] = _pick(places[-1], smoothed[-1])
    result: list[tuple[_Place, float] | None] = [None] * n
    k = n - 2
    while k >= 0:
        smoothed[k] = _smoothed(filtered[k], moves[k + 1], smoothed[k + 1])  # type: ignore[arg-type]
        weight = filtered[k] * moves[k + 1][:, chosen[k + 1]]  # type: ignore[index]
        if weight.max() > 0.0:
            chosen[k] = _pick(places[k], weight)
            k -= 1
            continue
        bridge = _bridge(net, reports, places, filtered, k, places[k + 1][chosen[k + 1]])
        if bridge is None:
            # no place connects to the one chosen after it: the path starts again here
            chosen[k] = _pick(places[k], smoothed[k])
            k -= 1
            continue
        j, a, between = bridge
        share = _state_probability(net, places[k + 1], smoothed[k + 1], chosen[k + 1])
        for q, place in zip(range(j + 1, k + 1), between, strict=True):
            result[q] = (place, share)
        # the smoother did not know the move: the place it starts from takes the share of
        # the place it reaches, the others the rest as they stood online
        rest = np.delete(filtered[j], a)
        rest = rest / rest.sum() * (1.0 - share) if rest.sum() > 0 else rest
        smoothed[j] = np.insert(rest, a, share)
        chosen[j] = a
        k = j - 1
    return [
        result[k]
        or (places[k][chosen[k]], _state_probability(net, places[k], smoothed[k], chosen[k]))
        for k in range(n)
    ]


def _pick(places: tuple[_Place, ...], weight: FloatArray) -> int:
    """The place with the most ``weight`` of the hypothesis with the most: a position held
    at a switch and its first hypothesis' own place are one hypothesis, each with half its
    probability, and a second hypothesis with more than that half is still less likely
    (their tie goes to the place shown online)."""
    hypothesis = np.array([pl.hypothesis for pl in places])
    total = np.array([weight[hypothesis == h].sum() for h in hypothesis])
    shown = np.array([pl.shown for pl in places])
    return int(np.lexsort((shown, weight, total))[-1])


def _bridge(
    net: TrackMap,
    reports: Sequence[VehicleReport],
    places: Sequence[tuple[_Place, ...]],
    filtered: Sequence[FloatArray],
    k: int,
    target: _Place,
) -> tuple[int, int, list[_Place]] | None:
    """Where the path to ``target`` (the place chosen at report ``k + 1``) can come from
    when no place at report ``k`` reaches it: the likeliest place at an earlier report
    (up to :data:`BRIDGE_S` back) that a permitted move connects to it, and the places
    along that move at the reports between, spaced as the vehicle ran (the online
    hypotheses lost the track the vehicle was on, and took it up again afresh)."""
    t_to = reports[k + 1].t
    for j in range(k - 1, -1, -1):
        if t_to - reports[j].t > BRIDGE_S:
            return None
        best: tuple[float, int, RouteDistance] | None = None
        for a, pa in enumerate(places[j]):
            if pa.wrong_way or target.wrong_way:
                continue
            route = net.route_distance(
                pa.edge_id,
                pa.offset_m,
                pa.direction,
                target.edge_id,
                target.offset_m,
                cutoff_m=reach_m(t_to - reports[j].t),
            )
            if route is None or route.arrival_direction != target.direction:
                continue
            if best is None or filtered[j][a] > best[0]:
                best = (float(filtered[j][a]), a, route)
        if best is None:
            continue
        _, a, route = best
        runs = np.cumsum([_travelled_m(reports[q - 1], reports[q]) for q in range(j + 1, k + 2)])
        scale = route.distance_m / runs[-1] if runs[-1] > 0 else 0.0
        start = places[j][a]
        between = [
            _along(net, start, route.edges, float(run) * scale, start.probability)
            for run in runs[:-1]
        ]
        return j, a, between
    return None


def _along(
    net: TrackMap, start: _Place, edges: Sequence[int], distance_m: float, probability: float
) -> _Place:
    """The place ``distance_m`` along a route's edges from ``start``."""
    edge, offset, direction = start.edge_id, start.offset_m, start.direction
    left = distance_m
    for k, e in enumerate(edges):
        length = net.edge_length(e)
        if k > 0:
            previous = net.edge(edges[k - 1])
            exit_node = previous.end_node if direction == 1 else previous.start_node
            direction = 1 if net.edge(e).start_node == exit_node else -1
            offset = 0.0 if direction == 1 else length
        ahead = length - offset if direction == 1 else offset
        edge = e
        if left <= ahead or k == len(edges) - 1:
            offset = offset + direction * min(left, ahead)
            break
        left -= ahead
    return _Place(edge, direction, offset, False, probability, False, -1, (edge, offset, direction))


def _online_probabilities(places: tuple[_Place, ...]) -> FloatArray:
    """The places' online probabilities, summing to 1."""
    p = np.array([pl.probability for pl in places], dtype=float)
    total = p.sum()
    return p / total if total > 0 else np.full(len(p), 1.0 / len(p))


def _smoothed(filtered: FloatArray, moves: FloatArray, smoothed_next: FloatArray) -> FloatArray:
    """One step of the discrete Rauch–Tung–Striebel recursion."""
    predicted = filtered @ moves
    ratio = np.divide(
        smoothed_next, predicted, out=np.zeros_like(smoothed_next), where=predicted > 0
    )
    out = filtered * (moves @ ratio)
    total = out.sum()
    return out / total if total > 0 else filtered


def _state_probability(
    net: TrackMap, places: tuple[_Place, ...], probability: FloatArray, chosen: int
) -> float:
    """The probability of the chosen place: of every place standing for its hypothesis or
    at the same spot (its track state, or a few metres along across a node, as the
    matcher sums a place's probability)."""
    c = places[chosen]
    here = c.fix_place  # (where the fixes project, as the matcher compares places)
    total = 0.0
    for k, pl in enumerate(places):
        same = pl.hypothesis == c.hypothesis or (pl.edge_id, pl.direction) == (
            c.edge_id,
            c.direction,
        )
        if not same:
            there = pl.fix_place
            step = track_step_m(net, here, there, cutoff_m=SAME_PLACE_M)
            if step is None:
                step = track_step_m(net, there, here, cutoff_m=SAME_PLACE_M)
            same = step is not None and abs(step) <= SAME_PLACE_M
        if same:
            total += float(probability[k])
    return min(total, 1.0)


def _as_position(
    net: TrackMap,
    online: TrackPosition,
    place: _Place,
    probability: float,
    confidence: float,
) -> TrackPosition:
    status: PositionStatus = "confident" if probability >= confidence else "ambiguous"
    if place.shown:
        return replace(online, status=status, probability=probability)
    x, y = net.point_at(place.edge_id, place.offset_m)
    lon, lat = net.to_lonlat(x, y)
    return replace(
        online,
        status=status,
        edge_id=place.edge_id,
        direction=place.direction,
        offset_m=place.offset_m,
        lon=float(lon),
        lat=float(lat),
        heading_deg=net.heading_at(place.edge_id, place.offset_m, place.direction),
        probability=probability,
        wrong_way=place.wrong_way,
    )
