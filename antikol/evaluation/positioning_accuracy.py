"""Accuracy of track-selective positioning against the simulator's true states.

:func:`evaluate_fixes` runs a :class:`~antikol.positioning.matcher.Positioner` over a
simulation's reports, one analysis cycle at a time, and judges every estimate against the
truth (:class:`FixEvaluation`). :func:`positioning_accuracy` sums them up
(:class:`PositioningScore`):

* **right track and direction on double track** (an opposite-direction track within 6 m)
  and **right branch** 40–60 m past a facing switch;
* **confident and wrong** — estimates of status ``confident`` on the wrong track: the
  failure a collision warning cannot see coming;
* a **reliability table** — bins of the estimate's ``probability`` against the share of
  them on the right track (a calibrated positioner is right as often as it says);
* **right way** — moving fixes placed on a track running the vehicle's way;
* **disconnected 10-s windows** — windows in which two successive matched positions of a
  vehicle are connected by no permitted route, within what the vehicle can run in between
  plus a margin, arriving in the estimated direction; a small step back along the track is
  allowed (:func:`~antikol.evaluation.consistency.disconnected_windows`, the check that
  needs no truth);
* along-track RMS error of the filtered and the raw position.

:func:`wrong_way_positioning` measures what positioning makes of a vehicle that really
runs against the permitted direction (the ``wrong_way_single_line`` scenario).
"""

from __future__ import annotations

import itertools
import math
from collections import defaultdict
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
import shapely

from antikol.evaluation.consistency import MOVING_MPS, disconnected_windows
from antikol.positioning.config import PositioningConfig
from antikol.positioning.estimates import NOT_MEASURED
from antikol.positioning.hindsight import hindsight_positions
from antikol.positioning.matcher import Positioner
from antikol.positioning.records import TrackPosition
from antikol.sim import Route, SimulationResult
from antikol.sim.places import on_double_track
from trackmap import TrackMap

__all__ = [
    "RELIABILITY_EDGES",
    "FixEvaluation",
    "PositioningScore",
    "ReliabilityBin",
    "WrongWayScore",
    "evaluate_fixes",
    "positioning_accuracy",
    "wrong_way_positioning",
]

#: Bin edges of the reliability table (probability of the estimate).
RELIABILITY_EDGES: Final = (0.0, 0.5, 0.7, 0.8, 0.9, 0.95, 0.99, 1.0)


@dataclass(frozen=True, slots=True)
class FixEvaluation:
    """One report's position estimate judged against the truth.

    Attributes
    ----------
    vehicle_id : str
    t : float
        Report time, s.
    status : str
        The estimate's status.
    probability : float
    matched : bool
        Confident or ambiguous, with a track position.
    right_track : bool
        On the vehicle's true route, within ``track_tolerance_m`` of the true antenna
        position along it, in the true running direction.
    correct : bool
        ``right_track`` and within ``tolerance_m`` along the track.
    double_track, after_switch : bool
        The vehicle is on double track; 40–60 m past a facing switch.
    moving : bool
        True speed of 1 m/s or more.
    right_way : bool
        Matched on a track permitting the estimated direction, heading within 90 degrees
        of the vehicle's true heading.
    true_wrong_way : bool
        The vehicle really runs against its track's permitted direction.
    est_wrong_way : bool
        The estimate says it runs wrong way.
    has_fix : bool
        The receiver had a position fix at the report (the simulator's fix log: a feed's
        report may repeat the last position without saying so).
    edge_id, direction : int or None
    offset_m : float or None
        The estimate (None when unmatched).
    along_error_m, raw_along_error_m : float
        Along-track error of the estimate and of the raw fix projected on the true edge,
        m (NaN when not measurable).
    """

    vehicle_id: str
    t: float
    status: str
    probability: float
    matched: bool
    right_track: bool
    correct: bool
    double_track: bool
    after_switch: bool
    moving: bool
    right_way: bool
    true_wrong_way: bool
    est_wrong_way: bool
    has_fix: bool
    edge_id: int | None
    direction: int | None
    offset_m: float | None
    along_error_m: float
    raw_along_error_m: float


@dataclass(frozen=True, slots=True)
class ReliabilityBin:
    """Estimates with probability in ``(lo, hi]`` and how many were on the right track."""

    lo: float
    hi: float
    fixes: int
    right: int

    @property
    def share_right(self) -> float | None:
        """Share on the right track (None for an empty bin)."""
        return self.right / self.fixes if self.fixes else None


@dataclass(frozen=True)
class PositioningScore:
    """Accuracy of track-selective positioning against the simulator's truth.

    Attributes
    ----------
    fixes : int
        Reports evaluated (matched or not).
    double_track_fixes, double_track_correct : int
        Fixes on double track and those placed on the right track and running direction
        within ``tolerance_m`` along it.
    double_track_right : int
        Fixes on double track placed on the right track and running direction (within
        ``track_tolerance_m`` along it).
    after_switch_fixes, after_switch_correct : int
        Fixes 40–60 m past a facing switch and those on the right branch.
    after_switch_measured, after_switch_measured_correct : int
        The same for the reports with a position fix (the others are dead-reckoned
        through an outage, with nothing to tell the branch by until the next fix).
    along_rmse_m, raw_along_rmse_m : float
        Along-track RMS error of the filtered position and of the raw fix projected on
        the true track, m.
    unmatched : int
        Fixes with no usable match.
    confident_fixes, confident_wrong : int
        Estimates with status ``confident``, and those of them on the wrong track.
    moving_fixes, moving_right_way : int
        Matched fixes of moving vehicles, and those on a track running the vehicle's way.
    windows, disconnected_windows : int
        10-s windows with two or more matched positions of a vehicle, and those in which
        no permitted route connects two successive positions.
    reliability : tuple of ReliabilityBin
        Matched estimates by probability (:data:`RELIABILITY_EDGES`).
    """

    fixes: int = 0
    double_track_fixes: int = 0
    double_track_correct: int = 0
    double_track_right: int = 0
    after_switch_fixes: int = 0
    after_switch_correct: int = 0
    after_switch_measured: int = 0
    after_switch_measured_correct: int = 0
    along_rmse_m: float = math.nan
    raw_along_rmse_m: float = math.nan
    unmatched: int = 0
    confident_fixes: int = 0
    confident_wrong: int = 0
    moving_fixes: int = 0
    moving_right_way: int = 0
    windows: int = 0
    disconnected_windows: int = 0
    reliability: tuple[ReliabilityBin, ...] = ()

    @property
    def double_track_accuracy(self) -> float:
        return self.double_track_correct / max(self.double_track_fixes, 1)

    @property
    def double_track_right_share(self) -> float:
        """Fixes on double track on the right track and direction, as a share."""
        return self.double_track_right / max(self.double_track_fixes, 1)

    @property
    def branch_accuracy(self) -> float:
        return self.after_switch_correct / max(self.after_switch_fixes, 1)

    @property
    def measured_branch_accuracy(self) -> float:
        """The share on the right branch past a switch of the reports with a fix."""
        return self.after_switch_measured_correct / max(self.after_switch_measured, 1)

    @property
    def confident_wrong_share(self) -> float:
        """Confident estimates on the wrong track per confident estimate."""
        return self.confident_wrong / max(self.confident_fixes, 1)

    @property
    def right_way_share(self) -> float:
        """Matched moving fixes on a track running the vehicle's way, as a share."""
        return self.moving_right_way / max(self.moving_fixes, 1)

    @property
    def disconnected_share(self) -> float:
        """Disconnected 10-s windows per window."""
        return self.disconnected_windows / max(self.windows, 1)

    @property
    def rmse_reduction(self) -> float:
        """1 - filtered / raw along-track RMSE (0.33 means a third lower)."""
        return 1.0 - self.along_rmse_m / self.raw_along_rmse_m

    def as_dict(self) -> dict[str, Any]:
        """The scores as plain JSON-ready values."""
        return {
            "fixes": self.fixes,
            "double_track_accuracy": round(self.double_track_accuracy, 4),
            "double_track_right_track": round(self.double_track_right_share, 4),
            "double_track_fixes": self.double_track_fixes,
            "branch_accuracy_50m_after_switch": round(self.branch_accuracy, 4),
            "after_switch_fixes": self.after_switch_fixes,
            "branch_accuracy_with_a_fix": round(self.measured_branch_accuracy, 4),
            "after_switch_with_a_fix": self.after_switch_measured,
            "confident_wrong_share": round(self.confident_wrong_share, 5),
            "confident_fixes": self.confident_fixes,
            "right_way_share_moving": round(self.right_way_share, 4),
            "disconnected_10s_windows": self.disconnected_windows,
            "windows": self.windows,
            "along_track_rmse_m": round(self.along_rmse_m, 3),
            "raw_along_track_rmse_m": round(self.raw_along_rmse_m, 3),
            "rmse_reduction": round(self.rmse_reduction, 3),
            "unmatched": self.unmatched,
            "reliability": [
                {
                    "probability": [b.lo, b.hi],
                    "fixes": b.fixes,
                    "share_right": None if b.share_right is None else round(b.share_right, 4),
                }
                for b in self.reliability
            ],
        }


@dataclass(frozen=True)
class WrongWayScore:
    """What positioning makes of a vehicle really running against the permitted direction.

    Attributes
    ----------
    vehicle_id : str
    fixes : int
        Reports while the vehicle really runs wrong way.
    on_true_track : int
        Of them, estimates on its true track in its true running direction.
    flagged : int
        Of them, estimates flagged ``wrong_way``.
    flagged_on_true_track : int
        Both.
    first_detection_s : float or None
        Time from the first wrong-way report to the first estimate both on the true track
        and flagged, s (None: never).
    statuses : dict of str to int
        Statuses of the estimates.
    """

    vehicle_id: str
    fixes: int
    on_true_track: int
    flagged: int
    flagged_on_true_track: int
    first_detection_s: float | None
    statuses: dict[str, int]

    @property
    def detected_share(self) -> float:
        """Share of the wrong-way reports placed on the true track and flagged."""
        return self.flagged_on_true_track / max(self.fixes, 1)


def _facing_switch_distances(net: TrackMap, route: Route) -> list[float]:
    """Route distances of the facing switches a route takes (trunk -> branch)."""
    out = []
    merge_by_node = {c.node_id: c for c in net.conflicts if c.kind == "merge"}
    entry = -(
        route.start_offset_m
        if route.steps[0][1] == 1
        else route.edge_lengths_m[0] - route.start_offset_m
    )
    for k, (e, d) in enumerate(route.steps[:-1]):
        entry += route.edge_lengths_m[k]
        node = net.edges[e].end_node if d == 1 else net.edges[e].start_node
        c = merge_by_node.get(node)
        if c is not None and c.edges[0] == e and route.steps[k + 1][0] in c.edges[1:]:
            out.append(entry)
    return out


def evaluate_fixes(
    net: TrackMap,
    result: SimulationResult,
    *,
    config: PositioningConfig | None = None,
    tolerance_m: float = 8.0,
    track_tolerance_m: float = 30.0,
    hindsight: bool = False,
) -> list[FixEvaluation]:
    """Run positioning over a simulation's reports and judge every estimate.

    Reports are fed one analysis cycle (equal report time) at a time with
    :meth:`~antikol.positioning.matcher.Positioner.update_many`.

    Parameters
    ----------
    net : TrackMap
    result : SimulationResult
    config : PositioningConfig, optional
    tolerance_m : float
        Along-track tolerance of a ``correct`` estimate, m.
    track_tolerance_m : float
        Along-track tolerance of a ``right_track`` estimate, m (a right-track estimate
        may still be off along the track).
    hindsight : bool
        Judge the positions the whole run gives each report
        (:func:`~antikol.positioning.hindsight.hindsight_positions`) instead of those
        positioning gave right after it.

    Returns
    -------
    list of FixEvaluation
        In report order (time, then vehicle).
    """
    specs = {s.vehicle_id: s for s in result.specs}
    pos = Positioner(net, config)
    switch_at = {v: _facing_switch_distances(net, specs[v].route) for v in specs}
    reports = sorted(result.reports, key=lambda r: r.t)
    estimates: list[Any] = []
    i = 0
    while i < len(reports):
        j = i
        while j < len(reports) and reports[j].t == reports[i].t:
            j += 1
        estimates.extend(pos.update_many(reports[i:j]))
        i = j
    if hindsight:
        c = config or PositioningConfig()
        estimates = hindsight_positions(net, reports, estimates, confidence=c.confidence)
    rows: list[dict[str, Any]] = []
    for r, est in zip(reports, estimates, strict=True):
        if _antenna_before_route(result, specs[r.vehicle_id], r.t):
            continue  # the truth has no track position for it: nothing to judge
        rows.append(
            _judge(
                net, result, specs[r.vehicle_id], r, est, switch_at, tolerance_m, track_tolerance_m
            )
        )
    if not rows:
        return []
    xs = np.array([row.pop("true_x") for row in rows])
    ys = np.array([row.pop("true_y") for row in rows])
    double = on_double_track(net, xs, ys)
    return [FixEvaluation(double_track=bool(double[k]), **row) for k, row in enumerate(rows)]


def _had_fix(result: SimulationResult, r: Any) -> bool:
    """Whether the receiver had a position fix at report ``r`` (by the simulator's log;
    by the report's flag where there is no log of its vehicle)."""
    log = result.fixes.get(r.vehicle_id)
    if log is None or not len(log.t_s):
        return r.fix_quality not in NOT_MEASURED
    k = int(np.searchsorted(log.t_s, r.t))
    if k < len(log.t_s) and log.t_s[k] == r.t:
        return bool(log.available[k])
    return r.fix_quality not in NOT_MEASURED


def _antenna_before_route(result: SimulationResult, spec: Any, t: float) -> bool:
    """A tram's first metres: its antenna is still behind the start of its route."""
    truth = result.truth[spec.vehicle_id]
    return float(truth.distance_m[truth.index_at(t)]) < spec.antenna_m


def _judge(
    net: TrackMap,
    result: SimulationResult,
    spec: Any,
    r: Any,
    est: TrackPosition,
    switch_at: dict[str, list[float]],
    tolerance_m: float,
    track_tolerance_m: float,
) -> dict[str, Any]:
    truth = result.truth[r.vehicle_id]
    idx = truth.index_at(r.t)
    s_ant = max(float(truth.distance_m[idx]) - spec.antenna_m, 0.0)
    te, to, td = spec.route.locate(min(s_ant, spec.route.length_m))
    tx, ty = float(truth.antenna_x_m[idx]), float(truth.antenna_y_m[idx])
    moving = float(truth.speed_mps[idx]) >= MOVING_MPS
    matched = est.matched and est.edge_id is not None and est.offset_m is not None
    right_track = correct = right_way = False
    along = raw = math.nan
    has_fix = _had_fix(result, r)
    if matched:
        if est.edge_id is None or est.offset_m is None or est.direction is None:
            raise RuntimeError("a matched estimate without a track position")  # pragma: no cover
        # (a tram's first metres: the estimate may lie on the route's first edge behind
        # its start, where the antenna truly is; a negative distance, not another track)
        d = spec.route.distance_of(
            est.edge_id, est.offset_m, after_m=s_ant - track_tolerance_m - 20.0
        )
        on_route = d is not None and spec.route.locate(max(d, 0.0))[2] == est.direction
        right_track = on_route and d is not None and abs(d - s_ant) <= track_tolerance_m
        correct = right_track and d is not None and abs(d - s_ant) <= tolerance_m
        edge = net.edges[est.edge_id]
        heading = net.heading_at(est.edge_id, est.offset_m, est.direction)
        turn = abs((heading - float(truth.heading_deg[idx]) + 180.0) % 360.0 - 180.0)
        right_way = edge.allows(est.direction) and turn < 90.0
        geom = net.edges[te].geometry
        ex, ey = net.point_at(est.edge_id, est.offset_m)
        p_est = shapely.Point(ex, ey)
        if geom.distance(p_est) <= tolerance_m:
            along = float(geom.project(p_est)) - to
        if has_fix:
            rx, ry = net.to_local(r.lon, r.lat)
            raw = float(geom.project(shapely.Point(rx, ry))) - to
    return {
        "vehicle_id": r.vehicle_id,
        "t": float(r.t),
        "status": est.status,
        "probability": float(est.probability),
        "matched": matched,
        "right_track": right_track,
        "correct": correct,
        "after_switch": any(40.0 <= s_ant - s0 <= 60.0 for s0 in switch_at[r.vehicle_id]),
        "moving": moving,
        "right_way": right_way,
        "true_wrong_way": not net.edges[te].allows(td),
        "est_wrong_way": bool(est.wrong_way),
        "has_fix": has_fix,
        "edge_id": est.edge_id if matched else None,
        "direction": est.direction if matched else None,
        "offset_m": est.offset_m if matched else None,
        "along_error_m": along,
        "raw_along_error_m": raw,
        "true_x": tx,
        "true_y": ty,
    }


def positioning_accuracy(
    net: TrackMap,
    result: SimulationResult,
    *,
    config: PositioningConfig | None = None,
    tolerance_m: float = 8.0,
    track_tolerance_m: float = 30.0,
    hindsight: bool = False,
) -> PositioningScore:
    """Run the positioning filter over a simulation's reports and score it against truth.

    Parameters
    ----------
    net : TrackMap
    result : SimulationResult
    config : PositioningConfig, optional
    tolerance_m : float
        An estimate counts as correct when it lies on the true route within this distance
        of the true antenna position, in the true running direction, m.
    track_tolerance_m : float
        The same tolerance for being on the right track (confident-and-wrong, reliability),
        m.
    hindsight : bool
        Score the positions the whole run gives each report (see :func:`evaluate_fixes`).

    Returns
    -------
    PositioningScore
    """
    evs = evaluate_fixes(
        net,
        result,
        config=config,
        tolerance_m=tolerance_m,
        track_tolerance_m=track_tolerance_m,
        hindsight=hindsight,
    )
    errs = [e.along_error_m for e in evs if not math.isnan(e.along_error_m)]
    raw = [e.raw_along_error_m for e in evs if not math.isnan(e.raw_along_error_m)]
    matched = [e for e in evs if e.matched]
    probs = np.array([e.probability for e in matched])
    right = np.array([e.right_track for e in matched], dtype=bool)
    bins = []
    for lo, hi in itertools.pairwise(RELIABILITY_EDGES):
        sel = (probs > lo) & (probs <= hi) if lo > 0 else (probs >= lo) & (probs <= hi)
        bins.append(ReliabilityBin(lo, hi, int(sel.sum()), int((sel & right).sum())))
    windows, broken = disconnected_windows(net, evs)
    confident = [e for e in evs if e.status == "confident" and e.matched]
    moving = [e for e in matched if e.moving]
    return PositioningScore(
        fixes=len(evs),
        double_track_fixes=sum(e.double_track for e in evs),
        double_track_correct=sum(e.double_track and e.correct for e in evs),
        double_track_right=sum(e.double_track and e.right_track for e in evs),
        after_switch_fixes=sum(e.after_switch for e in evs),
        after_switch_correct=sum(e.after_switch and e.correct for e in evs),
        after_switch_measured=sum(e.after_switch and e.has_fix for e in evs),
        after_switch_measured_correct=sum(e.after_switch and e.has_fix and e.correct for e in evs),
        along_rmse_m=float(np.sqrt(np.mean(np.square(errs)))) if errs else math.nan,
        raw_along_rmse_m=float(np.sqrt(np.mean(np.square(raw)))) if raw else math.nan,
        unmatched=len(evs) - len(matched),
        confident_fixes=len(confident),
        confident_wrong=sum(not e.right_track for e in confident),
        moving_fixes=len(moving),
        moving_right_way=sum(e.right_way for e in moving),
        windows=windows,
        disconnected_windows=broken,
        reliability=tuple(bins),
    )


def wrong_way_positioning(
    net: TrackMap,
    result: SimulationResult,
    vehicle_id: str,
    *,
    config: PositioningConfig | None = None,
) -> WrongWayScore:
    """How positioning places a vehicle while it really runs against the permitted direction.

    Parameters
    ----------
    net : TrackMap
    result : SimulationResult
        A run in which ``vehicle_id`` runs wrong way for a while (e.g. the scenario
        ``wrong_way_single_line``, vehicle ``W``).
    vehicle_id : str
    config : PositioningConfig, optional

    Returns
    -------
    WrongWayScore
    """
    evs = [
        e
        for e in evaluate_fixes(net, result, config=config)
        if e.vehicle_id == vehicle_id and e.true_wrong_way
    ]
    statuses: dict[str, int] = defaultdict(int)
    for e in evs:
        statuses[e.status] += 1
    hits = [e for e in evs if e.right_track and e.est_wrong_way]
    return WrongWayScore(
        vehicle_id=vehicle_id,
        fixes=len(evs),
        on_true_track=sum(e.right_track for e in evs),
        flagged=sum(e.est_wrong_way for e in evs),
        flagged_on_true_track=len(hits),
        first_detection_s=hits[0].t - evs[0].t if hits else None,
        statuses=dict(statuses),
    )
