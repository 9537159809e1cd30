"""Conflict rules along the tracks: rear-end, head-on, merge and crossing.

Each rule looks at one own hypothesis and one path ahead of it, and one hypothesis of the
other vehicle, and returns a :class:`Finding`: the kind, the level, the gap between vehicle
ends, the closing speed. Distances are along the track from the own vehicle's front.

Levels follow the braking model with a margin (see :class:`RuleSettings`):

* **rear-end**, the other vehicle ahead on the path running the same way: trams drive on
  sight, and a leader can stop far shorter than its brakes allow (a collision with a car).
  Unless the gap opens, a moving follower must be able to stop before the leader's rear as
  before a standing obstacle: ``warning`` within the warning distance, ``emergency``
  within the emergency distance. An opening gap is ``advisory``.
  (``rear_end_model="moving_leader"`` instead credits the leader's own braking distance,
  as CBTC's moving authority does.)
* **head-on**, the other vehicle ahead running towards us: both must stop; the warning
  distance is the sum of both vehicles' distances.
* **merge** and **crossing**, both paths reach the same conflict point from different
  tracks: the own vehicle is warned by its braking distance to the fouling area when the
  other one *can* be there before the own vehicle has cleared it — the other's earliest
  arrival, accelerating from its speed (standing or not: a tram at a stop next to a
  junction may start at any moment), against the own clearing time at the current speed.

A gap is shortened before the level is chosen by ``gap_margin_sigmas`` standard deviations
of both positions and ends, and by ``anticipation_s`` seconds of closing: the warning must
be on before the limit is crossed, not a cycle later.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from antikol.analysis.views import HypothesisView, VehicleView
from antikol.kinds import Level, ThreatKind
from trackmap import ConflictPoint, Path, PathStep

__all__ = [
    "Approach",
    "Finding",
    "RuleSettings",
    "approach",
    "arrival_time_s",
    "at_conflict",
    "conflict_kind",
    "earliest_arrival_s",
    "on_path",
    "pair_sigma_m",
]


@dataclass(frozen=True, slots=True)
class RuleSettings:
    """Parameters of the conflict rules (SI units)."""

    standing_speed_mps: float
    closing_speed_mps: float
    gap_margin_sigmas: float
    anticipation_s: float
    merge_accel_mps2: float
    merge_max_speed_mps: float
    window_slack_s: float
    rear_end_model: Literal["on_sight", "moving_leader"]
    overlap_tolerance_m: float = 5.0


@dataclass(frozen=True, slots=True)
class Finding:
    """One conflict of one pair of hypotheses on one path.

    Attributes
    ----------
    kind : str
        ``rear_end``, ``head_on``, ``merge`` or ``crossing``.
    level : str
        From the braking model, before any cap.
    gap_m : float
        Between the vehicle ends (rear-end, head-on) or from the own front to the fouling
        area (merge, crossing), m.
    margin_m : float
        How far the gap is beyond the warning distance (negative: inside it), m.
    closing_mps : float
        Rate at which the gap shrinks, m/s.
    ttc_s : float or None
        Time to collision at the closing speed, s.
    zone : str
        The path's zone label.
    detail : str
        Short explanation.
    """

    kind: ThreatKind
    level: Level
    gap_m: float
    margin_m: float
    closing_mps: float
    ttc_s: float | None
    zone: str
    detail: str


def pair_sigma_m(own_sigma_m: float, other_sigma_m: float) -> float:
    """One-sigma uncertainty of a gap between two vehicles, m: ``sqrt(a² + b²)``.

    Written out rather than :func:`math.hypot` so that the vectorised pair evaluation
    (:mod:`antikol.analysis.pairs`) reproduces it to the last bit.
    """
    return math.sqrt(own_sigma_m * own_sigma_m + other_sigma_m * other_sigma_m)


def _level(gap_eff: float, warning_m: float, emergency_m: float, horizon_m: float) -> Level:
    if gap_eff <= emergency_m:
        return "emergency"
    if gap_eff <= warning_m:
        return "warning"
    if gap_eff <= horizon_m:
        return "advisory"
    return "none"


def _ttc(gap_m: float, closing_mps: float) -> float | None:
    return max(gap_m, 0.0) / closing_mps if closing_mps > 0.0 else None


def on_path(
    own: VehicleView,
    path: Path,
    distance_m: float,
    other: VehicleView,
    same_way: bool,
    rules: RuleSettings,
) -> Finding | None:
    """The other vehicle stands on the own path, ``distance_m`` from the own antenna.

    Parameters
    ----------
    own : VehicleView
    path : Path
        The own path holding the other vehicle.
    distance_m : float
        Along the path from the own antenna to the other's antenna, m.
    other : VehicleView
    same_way : bool
        The other runs the same way as the path (rear-end) or towards us (head-on).
    rules : RuleSettings

    Returns
    -------
    Finding or None
        None when the two bodies would overlap by more than the position uncertainty
        allows: two vehicles cannot stand inside each other, so one of the placements is
        wrong (a parallel track) and the pair is judged on its other hypotheses.
    """
    sigma = pair_sigma_m(own.sigma_m, other.sigma_m)
    # the speed over ground of a standing vehicle is receiver noise: count it as zero
    v_own = own.speed_mps if own.speed_mps >= rules.standing_speed_mps else 0.0
    v_other = other.speed_mps if other.speed_mps >= rules.standing_speed_mps else 0.0
    if same_way:
        gap = distance_m - own.ends.front_m - other.ends.rear_m
        closing = v_own - v_other
        kind: ThreatKind = "rear_end"
        warning, emergency = own.warning_m, own.emergency_m
        if rules.rear_end_model == "moving_leader" and other.report.braking != "emergency":
            # CBTC: the leader needs its own (emergency) braking distance to stand
            credit = 0.5 * other.speed_mps**2 / 2.8
            warning, emergency = warning - credit, emergency - credit
        what = "ahead on the same track"
    else:
        gap = distance_m - own.ends.front_m - other.ends.front_m
        closing = v_own + v_other
        kind = "head_on"
        warning = own.warning_m + other.warning_m
        emergency = own.emergency_m + other.emergency_m
        what = "ahead, running towards us"
    if gap < -(rules.overlap_tolerance_m + rules.gap_margin_sigmas * sigma):
        return None  # bodies that deeply overlap cannot be on one track: a placement error
    if same_way:
        # on sight: a follower inside its stopping distance must act unless the gap opens
        act = v_own > 0.0 and closing > -rules.closing_speed_mps
    else:
        act = closing > rules.closing_speed_mps
    gap_eff = gap - rules.gap_margin_sigmas * sigma - max(closing, 0.0) * rules.anticipation_s
    level = _level(gap_eff, warning, emergency, own.horizon_m)
    if not act and level in ("warning", "emergency"):
        level = "advisory"  # a gap that does not close needs no action now
    return Finding(
        kind,
        level,
        gap,
        gap_eff - warning,
        closing,
        _ttc(gap, closing),
        path.zone,
        f"{other.vehicle_id} {what} at {gap:.0f} m",
    )


def arrival_time_s(
    distance_m: float, speed_mps: float, accel_mps2: float, vmax_mps: float
) -> float:
    """Earliest time to cover a distance from a speed, accelerating up to a top speed.

    Parameters
    ----------
    distance_m : float
        Distance ahead, m (0 or less: already there).
    speed_mps : float
        Current speed, m/s.
    accel_mps2 : float
        Acceleration, m/s².
    vmax_mps : float
        Top speed, m/s.

    Returns
    -------
    float
        Time, s.
    """
    if distance_m <= 0.0:
        return 0.0
    v = min(speed_mps, vmax_mps)
    if accel_mps2 <= 0.0:
        return distance_m / v if v > 0.0 else math.inf
    d_acc = (vmax_mps * vmax_mps - v * v) / (2.0 * accel_mps2)
    if distance_m <= d_acc:
        return (-v + math.sqrt(v * v + 2.0 * accel_mps2 * distance_m)) / accel_mps2
    return (vmax_mps - v) / accel_mps2 + (distance_m - d_acc) / vmax_mps


@dataclass(frozen=True, slots=True)
class Approach:
    """Where a vehicle meets a conflict point's fouling area on its path, m from its front.

    Attributes
    ----------
    enter_m : float
        The front reaches the fouling area.
    point_m : float
        The front reaches the conflict point.
    clear_m : float
        The rear leaves the fouling area.
    """

    enter_m: float
    point_m: float
    clear_m: float


def approach(
    view: VehicleView, conflict: ConflictPoint, distance_m: float, frm: int, to: int
) -> Approach:
    """A vehicle's way through a conflict point's fouling area.

    Parameters
    ----------
    view : VehicleView
    conflict : ConflictPoint
    distance_m : float
        From the vehicle's antenna to the point along its path, m.
    frm, to : int
        Edges the path arrives on and leaves by (the fouling area of a merge lies on the
        branches).

    Returns
    -------
    Approach
    """
    front = distance_m - view.ends.front_m
    if conflict.kind == "merge":
        branches = conflict.edges[1:]
        extent = dict(zip(conflict.edges, conflict.extents_m, strict=True))
        before = extent[frm] if frm in branches else 0.0
        after = extent[to] if to in branches else 0.0
    else:
        before = after = max(conflict.extents_m)
    length = view.ends.front_m + view.ends.rear_m
    return Approach(front - before, front, front + after + length)


def earliest_arrival_s(
    view: VehicleView, way: Approach, rules: RuleSettings, traction_mps2: float
) -> float:
    """The earliest a vehicle can reach a fouling area: accelerating from its speed
    (standing or not) at the smaller of its traction and ``rules.merge_accel_mps2``, s."""
    accel = min(rules.merge_accel_mps2, traction_mps2)
    return arrival_time_s(
        way.enter_m, view.speed_mps, accel, max(rules.merge_max_speed_mps, view.speed_mps)
    )


def conflict_kind(
    conflict: ConflictPoint, own_from: int, own_to: int, other_from: int, other_to: int
) -> ThreatKind | None:
    """``merge`` or ``crossing`` when two ways through a conflict point come from different
    tracks; None when they share one (a rear-end or head-on case)."""
    if conflict.kind == "merge":
        branches = set(conflict.edges[1:])
        own_branch = {own_from, own_to} & branches
        other_branch = {other_from, other_to} & branches
        if not own_branch or not other_branch or own_branch == other_branch:
            return None
        return "merge"
    if {own_from, own_to} & {other_from, other_to}:
        return None  # the same line through the crossing
    return "crossing"


def at_conflict(
    own: VehicleView,
    kind: ThreatKind,
    mine: Approach,
    other: VehicleView,
    theirs: Approach,
    other_arrival_s: float,
    rules: RuleSettings,
) -> Finding | None:
    """Both paths reach the same conflict point from different tracks.

    Parameters
    ----------
    own : VehicleView
    kind : {"merge", "crossing"}
        From :func:`conflict_kind`.
    mine, theirs : Approach
        The two ways through the fouling area (:func:`approach`).
    other : VehicleView
    other_arrival_s : float
        The other's earliest arrival (:func:`earliest_arrival_s`), s.
    rules : RuleSettings

    Returns
    -------
    Finding or None
        Its ``zone`` is left empty: every own path through the point shares the finding
        (:func:`dataclasses.replace` sets the zone). None when the own vehicle has passed
        the point, the other has cleared it, or the other cannot be there in time.
    """
    if mine.point_m < 0.0 or theirs.clear_m <= 0.0:
        return None  # we are past the point, or they have cleared it
    v_own = own.speed_mps
    standing = v_own < rules.standing_speed_mps
    own_clear_s = math.inf if standing else mine.clear_m / v_own
    if other_arrival_s > own_clear_s + rules.window_slack_s:
        return None  # they cannot be there before we have cleared it
    # (also when they are in the area already: a tram whose rear is still on a diamond it
    # has passed, moving on, clears it like one that has yet to enter)
    if not standing:
        own_arrival_s = max(mine.enter_m, 0.0) / v_own
        other_latest_s = (
            theirs.clear_m / other.speed_mps
            if other.speed_mps >= rules.standing_speed_mps
            else math.inf
        )
        if own_arrival_s > other_latest_s + rules.window_slack_s and math.isfinite(other_latest_s):
            return None  # at their speed they will have cleared it before we get there
    gap = max(mine.enter_m, 0.0)
    sigma = pair_sigma_m(own.sigma_m, other.sigma_m)
    closing = 0.0 if standing else v_own
    gap_eff = gap - rules.gap_margin_sigmas * sigma - closing * rules.anticipation_s
    level = _level(gap_eff, own.warning_m, own.emergency_m, own.horizon_m)
    if standing and level in ("warning", "emergency"):
        level = "advisory"  # waiting at a junction, we are the obstacle: the other must act
    where = "switch" if kind == "merge" else "crossing"
    return Finding(
        kind,
        level,
        gap,
        gap_eff - own.warning_m,
        closing,
        None if standing else _ttc(gap, closing),
        "",
        f"{other.vehicle_id} can reach the same {where} (we are {gap:.0f} m away)",
    )


def locate(path: Path, hyp: HypothesisView) -> tuple[float, PathStep] | None:
    """Where another vehicle's hypothesis lies on a path: distance and step, or None."""
    return path.locate_step(hyp.edge_id, hyp.offset_m)
