"""Positioning checked without ground truth: how consistent a trace's matched positions are.

A real trace (an operator's archive, an on-board log) has no true track to judge the
matcher against, but its matched positions can still be checked against what the trace
itself says and against the map:

* **way** — a moving fix should lie on a track that allows the direction the vehicle is
  matched in, and that direction should agree with the reported course over ground
  (within 90°: a fix on the other direction's track of a double track fails this);
* **connected windows** — in every 10-s window, each matched position must be reachable
  from the one before over permitted moves, within what a tram can run in between (the
  rule :func:`~antikol.evaluation.positioning_accuracy.positioning_accuracy` scores against
  the truth, :func:`disconnected_windows`);
* **odometer** — where the reports carry ``odometer_m``, the distance along the track
  between successive matched positions should equal the odometer's increment.

:func:`match_reports` runs a :class:`~antikol.positioning.matcher.Positioner` over a log's
reports (one position per report, at the report's time) and :func:`trace_consistency`
sums the checks up (:class:`TraceConsistency`). ``antikol match`` does both for a log
file. These checks cannot see every error — a vehicle matched consistently onto a parallel
track that runs its way passes them all — so they bound the failures from below.

>>> from trackmap.synthetic import SyntheticNetwork
>>> from antikol.report import VehicleReport, one_per_vehicle
>>> board = SyntheticNetwork()
>>> board.track([(0.0, 0.0), (1000.0, 0.0)], oneway="yes")  # one eastbound track
1
>>> net = board.build()
>>> def fix(t):
...     lon, lat = board.lonlat(100.0 + 10.0 * t, 1.5)  # 1.5 m beside the track
...     return VehicleReport("T1", t, lat, lon, speed_mps=10.0, course_deg=90.0,
...                          odometer_m=10.0 * t)
>>> check = trace_consistency(net, match_reports(net, [fix(float(t)) for t in range(30)]))
>>> check.reports, check.moving_way_agrees == check.moving_fixes, check.disconnected_windows
(30, True, 0)
>>> check.odometer_agrees == check.odometer_pairs == 29
True
"""

from __future__ import annotations

import itertools
import math
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Final, Protocol

import numpy as np

from antikol.evaluation.replay import cycles
from antikol.positioning.config import PositioningConfig
from antikol.positioning.coursecheck import chords
from antikol.positioning.estimates import NOT_MEASURED
from antikol.positioning.fleet import FleetState
from antikol.positioning.hindsight import REACH_MARGIN_M, hindsight_positions, reach_m, track_step_m
from antikol.positioning.matcher import Positioner
from antikol.positioning.records import TrackPosition
from antikol.report import VehicleReport, one_per_vehicle
from trackmap import TrackMap

__all__ = [
    "COURSE_OFF_DEG",
    "COURSE_OFF_SHARE",
    "HELD_SHARE",
    "HELD_SPAN_S",
    "MOVING_MPS",
    "MatchedFix",
    "Placed",
    "TraceConsistency",
    "WindowBreak",
    "disconnected_windows",
    "in_hindsight",
    "match_reports",
    "trace_consistency",
    "window_breaks",
]

#: A vehicle this fast or faster is moving, m/s (its course over ground is meaningful).
MOVING_MPS: Final = 1.0
#: A vehicle's odometer is held between read-outs when its reading stands still over this
#: share of its moving reports.
HELD_SHARE: Final = 0.2
#: Longest span between two new readings of a held odometer that are compared, s.
HELD_SPAN_S: Final = 30.0
_WINDOW_S: Final = 10.0
#: Chords test a course as positioning's do: from the speed its course weighs at, m/s.
_COURSE_SPEED_MPS: Final = PositioningConfig().min_speed_for_course_mps
_WAY_TOLERANCE_DEG: Final = 90.0
#: A reported course this far off the chord between the vehicle's fixes is off, degrees.
COURSE_OFF_DEG: Final = 60.0
#: A vehicle whose chords are off this often (of three or more) has its course off.
COURSE_OFF_SHARE: Final = 0.5


class Placed(Protocol):
    """A matched position of a vehicle at a time, as the window check reads it."""

    @property
    def vehicle_id(self) -> str: ...
    @property
    def t(self) -> float: ...
    @property
    def matched(self) -> bool: ...
    @property
    def edge_id(self) -> int | None: ...
    @property
    def offset_m(self) -> float | None: ...
    @property
    def direction(self) -> int | None: ...
    @property
    def est_wrong_way(self) -> bool: ...


@dataclass(frozen=True, slots=True)
class MatchedFix:
    """A report and the track position positioning gave right after it.

    Attributes
    ----------
    report : VehicleReport
    position : TrackPosition
    """

    report: VehicleReport
    position: TrackPosition

    @property
    def vehicle_id(self) -> str:
        return self.report.vehicle_id

    @property
    def t(self) -> float:
        """Time of the report, s."""
        return self.report.t

    @property
    def matched(self) -> bool:
        """The position is on a track (confident or ambiguous)."""
        p = self.position
        return p.matched and p.edge_id is not None and p.offset_m is not None

    @property
    def edge_id(self) -> int | None:
        return self.position.edge_id

    @property
    def offset_m(self) -> float | None:
        return self.position.offset_m

    @property
    def direction(self) -> int | None:
        return self.position.direction

    @property
    def est_wrong_way(self) -> bool:
        """Positioning places the vehicle against the track's permitted direction."""
        return self.position.wrong_way

    @property
    def has_fix(self) -> bool:
        """The report carries a position fix (``fix_quality`` neither 0 nor 6, an
        estimate)."""
        return self.report.fix_quality not in NOT_MEASURED


def match_reports(
    net: TrackMap,
    reports: Iterable[VehicleReport],
    *,
    config: PositioningConfig | None = None,
    cycle_s: float = 1.0,
    hindsight: bool = False,
) -> list[MatchedFix]:
    """Position every report of a log, in time order.

    The reports go to one :class:`~antikol.positioning.matcher.Positioner` one analysis
    cycle at a time (:func:`~antikol.evaluation.replay.cycles`); a vehicle with several
    reports in one cycle has them fused one after the other, so every report gets the
    position at its own time.

    Parameters
    ----------
    net : TrackMap
    reports : iterable of VehicleReport
        Any order (they are sorted by time, stably).
    config : PositioningConfig, optional
    cycle_s : float
        Analysis period, s.
    hindsight : bool, keyword-only
        Give each report the position the whole log gives it
        (:func:`~antikol.positioning.hindsight.hindsight_positions`) instead of the one
        positioning gave right after it (what an on-board unit shows).

    Returns
    -------
    list of MatchedFix
        One per report, in time order.
    """
    pos = Positioner(net, config)
    out: list[MatchedFix] = []
    for _, batch in cycles(reports, cycle_s):
        for one_each in one_per_vehicle(batch):
            out.extend(
                MatchedFix(r, p) for r, p in zip(one_each, pos.update_many(one_each), strict=True)
            )
    if hindsight:
        return in_hindsight(net, out, config=config)
    return out


def in_hindsight(
    net: TrackMap, matched: Sequence[MatchedFix], *, config: PositioningConfig | None = None
) -> list[MatchedFix]:
    """The same reports, each at the position the whole log gives it
    (:func:`~antikol.positioning.hindsight.hindsight_positions`).

    Parameters
    ----------
    net : TrackMap
    matched : sequence of MatchedFix
        As :func:`match_reports` gives them (each vehicle's in time order).
    config : PositioningConfig, optional
        Its ``confidence`` marks a place ``confident``.

    Returns
    -------
    list of MatchedFix
        In the same order.
    """
    c = config or PositioningConfig()
    later = hindsight_positions(
        net,
        [m.report for m in matched],
        [m.position for m in matched],
        confidence=c.confidence,
    )
    return [MatchedFix(m.report, p) for m, p in zip(matched, later, strict=True)]


@dataclass(frozen=True, slots=True)
class WindowBreak:
    """Two successive matched positions of a vehicle in one window that no permitted route
    connects (:func:`window_breaks`): where to look on the map.

    Attributes
    ----------
    vehicle_id : str
    t_from_s, t_to_s : float
        Report times of the two positions, s.
    edge_from, edge_to : int
        Their edges.
    offset_from_m, offset_to_m : float
        Their places along those edges, m from the edge's start.
    direction_from, direction_to : int
        Their running directions (+1 with the edge's geometry, -1 against it).
    """

    vehicle_id: str
    t_from_s: float
    t_to_s: float
    edge_from: int
    offset_from_m: float
    direction_from: int
    edge_to: int
    offset_to_m: float
    direction_to: int

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {name: getattr(self, name) for name in self.__slots__}


@dataclass(frozen=True, slots=True)
class TraceConsistency:
    """How consistent a trace's matched positions are (:func:`trace_consistency`).

    Attributes
    ----------
    vehicles, reports : int
    with_fix : int
        Reports carrying a position fix.
    confident, ambiguous, lost, unmatched : int
        Positions by status.
    moving_fixes : int
        Reports with a fix and a reported speed of at least :data:`MOVING_MPS`.
    moving_matched : int
        Of them, matched onto a track.
    moving_way_agrees : int
        Of them, matched on a track whose permitted direction is the matched one, with the
        matched heading within 90° of the reported course.
    moving_wrong_way : int
        Moving fixes positioning itself reports as running against the permitted direction.
    windows, disconnected_windows : int
        10-s windows with two or more matched positions of a vehicle, and those in which
        two successive positions are connected by no permitted route
        (:func:`disconnected_windows`).
    breaks : tuple of WindowBreak
        Where: the first unconnected pair of each such window, in time order per vehicle.
    odometer_pairs : int
        Successive matched reports of a vehicle (at most 10 s apart) that both carry an
        odometer reading; for a vehicle whose counter is held between read-outs
        (``odometer_held_vehicles``), successive reports that bring a new reading, at
        most 30 s apart.
    odometer_agrees : int
        Of them, those whose distance along the track equals the odometer's increment
        within ``odometer_tolerance_m``.
    odometer_unreachable : int
        Of them, those whose later position cannot be reached from the earlier within the
        odometer's increment plus the tolerance and 30 m.
    odometer_rms_m : float
        RMS of (distance along the track − odometer increment) over the reachable pairs, m
        (NaN when there are none).
    odometer_tolerance_m : float
        The tolerance used, m.
    course_chords, course_chords_off : int
        Chords between two fixes of a vehicle that test its course as positioning tests
        it (:func:`~antikol.positioning.coursecheck.chords`: at least 15 m and at most
        12 s apart, both ends at 1.5 m/s or more, as long as the run of the reported
        speeds), and those whose bearing is :data:`COURSE_OFF_DEG` or more off the mean
        of the courses reported at their ends: a check of the feed's course field itself.
    course_off_vehicles : int
        Vehicles with three or more chords, :data:`COURSE_OFF_SHARE` or more of them off:
        a course reversed, stuck or in another convention (positioning ignores a course,
        or turns a reversed one round, while the chords show it wrong,
        :mod:`antikol.positioning.coursecheck`; the
        "course's way" share above is then no measure of the matching).
    odometer_held_vehicles : int
        Vehicles whose odometer reading stands still over a fifth or more of their moving
        reports: a counter read out every few seconds and repeated in between (or one
        counting in coarse units). Compared
        report by report, each repeat would be taken as the track distance disagreeing
        with it; each new reading is compared with the one before it instead, so the
        residual carries the read-outs' lag behind the reports (up to one report interval
        of running at each end).
    """

    vehicles: int
    reports: int
    with_fix: int
    confident: int
    ambiguous: int
    lost: int
    unmatched: int
    moving_fixes: int
    moving_matched: int
    moving_way_agrees: int
    moving_wrong_way: int
    windows: int
    disconnected_windows: int
    odometer_pairs: int
    odometer_agrees: int
    odometer_unreachable: int
    odometer_rms_m: float
    odometer_tolerance_m: float
    odometer_held_vehicles: int = 0
    course_chords: int = 0
    course_chords_off: int = 0
    course_off_vehicles: int = 0
    breaks: tuple[WindowBreak, ...] = ()

    @property
    def way_agrees_share(self) -> float:
        """Share of moving fixes on a track running the reported course's way."""
        return self.moving_way_agrees / self.moving_fixes if self.moving_fixes else math.nan

    @property
    def disconnected_share(self) -> float:
        """Share of the windows no permitted route connects."""
        return self.disconnected_windows / self.windows if self.windows else math.nan

    @property
    def odometer_agrees_share(self) -> float:
        """Share of the odometer pairs whose track distance agrees with the odometer."""
        return self.odometer_agrees / self.odometer_pairs if self.odometer_pairs else math.nan

    @classmethod
    def pooled(cls, parts: Sequence[TraceConsistency]) -> TraceConsistency:
        """The checks of the traces of different vehicles taken together.

        Raises
        ------
        ValueError
            No parts, or parts checked with different odometer tolerances.
        """
        if not parts:
            raise ValueError("nothing to pool")
        tolerances = {p.odometer_tolerance_m for p in parts}
        if len(tolerances) != 1:
            raise ValueError(f"parts checked with different odometer tolerances {tolerances}")
        counts = {
            name: sum(getattr(p, name) for p in parts)
            for name in cls.__slots__
            if name not in ("odometer_rms_m", "odometer_tolerance_m", "breaks")
        }
        reached = [(p.odometer_pairs - p.odometer_unreachable, p.odometer_rms_m) for p in parts]
        n = sum(k for k, _ in reached)
        squares = sum(k * rms * rms for k, rms in reached if k)
        return cls(
            **counts,
            odometer_rms_m=math.sqrt(squares / n) if n else math.nan,
            odometer_tolerance_m=tolerances.pop(),
            breaks=tuple(b for p in parts for b in p.breaks),
        )

    def as_dict(self) -> dict[str, Any]:
        """Every count and share, and the breaks, JSON-ready (NaN as None)."""
        fields: dict[str, Any] = {name: getattr(self, name) for name in self.__slots__}
        fields["breaks"] = [b.as_dict() for b in self.breaks]
        fields.update(
            way_agrees_share=self.way_agrees_share,
            disconnected_share=self.disconnected_share,
            odometer_agrees_share=self.odometer_agrees_share,
        )
        return {
            k: (None if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in fields.items()
        }


def trace_consistency(
    net: TrackMap,
    fixes: Sequence[MatchedFix],
    *,
    window_s: float = _WINDOW_S,
    odometer_tolerance_m: float = 10.0,
) -> TraceConsistency:
    """Check a trace's matched positions against its own course, odometer and the map.

    Parameters
    ----------
    net : TrackMap
        The map the positions are on.
    fixes : sequence of MatchedFix
        As :func:`match_reports` returns them.
    window_s : float
        Window of the connectivity check, s; also the longest gap between the two reports
        of an odometer pair.
    odometer_tolerance_m : float
        Largest difference between the distance along the track and the odometer's
        increment that still agrees, m.

    Returns
    -------
    TraceConsistency
    """
    status: dict[str, int] = defaultdict(int)
    moving = moving_matched = way_agrees = wrong_way = 0
    for f in fixes:
        status[f.position.status] += 1
        if not (f.has_fix and f.report.speed_mps >= MOVING_MPS):
            continue
        moving += 1
        wrong_way += f.est_wrong_way
        if f.matched:
            moving_matched += 1
            way_agrees += _runs_reported_way(net, f)
    windows, breaks = _windows(net, fixes, window_s)
    residuals, unreachable, held = _odometer_residuals(net, fixes, window_s, odometer_tolerance_m)
    chords, chords_off, course_off = _course_chords(net, fixes)
    pairs = len(residuals) + unreachable
    return TraceConsistency(
        vehicles=len({f.vehicle_id for f in fixes}),
        reports=len(fixes),
        with_fix=sum(f.has_fix for f in fixes),
        confident=status["confident"],
        ambiguous=status["ambiguous"],
        lost=status["lost"],
        unmatched=status["unmatched"],
        moving_fixes=moving,
        moving_matched=moving_matched,
        moving_way_agrees=way_agrees,
        moving_wrong_way=wrong_way,
        windows=windows,
        disconnected_windows=len(breaks),
        odometer_pairs=pairs,
        odometer_agrees=int(np.count_nonzero(np.abs(residuals) <= odometer_tolerance_m)),
        odometer_unreachable=unreachable,
        odometer_rms_m=float(np.sqrt(np.mean(np.square(residuals)))) if residuals else math.nan,
        odometer_tolerance_m=odometer_tolerance_m,
        odometer_held_vehicles=held,
        course_chords=chords,
        course_chords_off=chords_off,
        course_off_vehicles=course_off,
        breaks=tuple(breaks),
    )


def _runs_reported_way(net: TrackMap, f: MatchedFix) -> bool:
    edge_id, offset_m, direction = _place(f)
    if not net.edges[edge_id].allows(direction):
        return False
    heading = net.heading_at(edge_id, offset_m, direction)
    turn = abs((heading - f.report.course_deg + 180.0) % 360.0 - 180.0)
    return turn < _WAY_TOLERANCE_DEG


def _held_counter(seq: Sequence[MatchedFix]) -> bool:
    """Whether a vehicle's odometer is read out every few seconds and repeated in between:
    its reading stands still over at least :data:`HELD_SHARE` of the successive reports
    at which it moves (both at :data:`MOVING_MPS` or more)."""
    moving = still = 0
    for p, q in itertools.pairwise(seq):
        if p.report.speed_mps >= MOVING_MPS and q.report.speed_mps >= MOVING_MPS:
            moving += 1
            still += q.report.odometer_m == p.report.odometer_m
    return moving > 0 and still >= HELD_SHARE * moving


def _odometer_residuals(
    net: TrackMap, fixes: Sequence[MatchedFix], window_s: float, tolerance_m: float
) -> tuple[list[float], int, int]:
    """(track distance − odometer increment) of successive matched reports of a vehicle
    that both carry an odometer reading, the count of those out of reach, and the number of
    vehicles whose counter is held between read-outs (compared from one new reading to the
    next, up to :data:`HELD_SPAN_S` apart)."""
    per: dict[str, list[MatchedFix]] = defaultdict(list)
    for f in fixes:
        if f.matched and f.report.odometer_m is not None:
            per[f.vehicle_id].append(f)
    residuals: list[float] = []
    unreachable = held = 0
    for seq in per.values():
        seq.sort(key=lambda f: f.t)
        span_s = window_s
        if _held_counter(seq):
            # a repeated reading is as old as the read-out: compare the reports that
            # bring a new one (each as late as one report after its read-out, at most)
            held += 1
            span_s = max(window_s, HELD_SPAN_S)
            seq = [
                q for p, q in itertools.pairwise(seq) if q.report.odometer_m != p.report.odometer_m
            ]
        for p, q in itertools.pairwise(seq):
            if not 0.0 < q.t - p.t <= span_s:
                continue
            if q.report.odometer_m is None or p.report.odometer_m is None:
                continue  # pragma: no cover - both were kept for their readings
            travelled = q.report.odometer_m - p.report.odometer_m
            if travelled < 0.0:
                continue  # an odometer reset: nothing to compare
            along = _signed_track_distance(net, p, q, travelled + tolerance_m + REACH_MARGIN_M)
            if along is None:
                unreachable += 1
            else:
                residuals.append(along - travelled)
    return residuals, unreachable, held


def _course_chords(net: TrackMap, fixes: Sequence[MatchedFix]) -> tuple[int, int, int]:
    """Chords between moving fixes of each vehicle, those whose bearing is off the mean
    reported course, and the vehicles whose course is mostly off (see
    :class:`TraceConsistency`): the chords positioning tests
    (:func:`~antikol.positioning.coursecheck.chords`), taken afresh over the trace."""
    per: dict[str, list[MatchedFix]] = defaultdict(list)
    for f in fixes:
        if f.has_fix:
            per[f.vehicle_id].append(f)
    anchors = FleetState(k=1)
    anchors.grow(1)
    row = np.zeros(1, np.int64)
    chords_in_all = off = vehicles_off = 0
    for seq in per.values():
        seq.sort(key=lambda f: f.t)
        anchors.clear(0)
        xs, ys = net.to_local([f.report.lon for f in seq], [f.report.lat for f in seq])
        tested = wrong = 0
        for f, x, y in zip(seq, np.atleast_1d(xs), np.atleast_1d(ys), strict=True):
            r = f.report
            got = chords(
                anchors, _COURSE_SPEED_MPS, row, np.array([r.t]), np.array([r.speed_mps]),
                np.array([x]), np.array([y]), np.array([r.course_deg]),
            )  # fmt: skip
            tested += len(got.at)
            wrong += int(np.count_nonzero(got.off_deg >= COURSE_OFF_DEG))
        chords_in_all += tested
        off += wrong
        vehicles_off += tested >= 3 and wrong >= COURSE_OFF_SHARE * tested
    return chords_in_all, off, vehicles_off


def _place(p: Placed) -> tuple[int, float, int]:
    if p.edge_id is None or p.offset_m is None or p.direction is None:
        raise RuntimeError("a matched position without a track position")  # pragma: no cover
    return p.edge_id, p.offset_m, p.direction


def _signed_track_distance(net: TrackMap, p: Placed, q: Placed, cutoff_m: float) -> float | None:
    """Distance along the track from ``p`` to ``q`` over moves ``p`` may make (negative: ``q``
    up to 10 m behind ``p``), or None when ``q`` is out of reach."""
    return track_step_m(
        net,
        _place(p),
        _place(q),
        cutoff_m=cutoff_m,
        permitted=not (p.est_wrong_way or q.est_wrong_way),
    )


def disconnected_windows(
    net: TrackMap, placed: Iterable[Placed], *, window_s: float = _WINDOW_S
) -> tuple[int, int]:
    """Count the windows of matched positions and those no permitted route connects.

    Parameters
    ----------
    net : TrackMap
    placed : iterable of Placed
        Matched positions of any vehicles (unmatched ones are skipped), e.g.
        :class:`MatchedFix` or :class:`~antikol.evaluation.positioning_accuracy.FixEvaluation`.
    window_s : float
        Window length, s (windows are aligned to multiples of it).

    Returns
    -------
    (int, int)
        Windows with two or more matched positions of a vehicle, and those in which two
        successive positions are connected by no permitted route within
        ``30 m + 25 m/s × Δt`` arriving in the later position's direction (nor is the later
        one up to 10 m behind the earlier on its track). Positions flagged wrong way are
        connected over physical moves.
    """
    windows, breaks = _windows(net, placed, window_s)
    return windows, len(breaks)


def window_breaks(
    net: TrackMap, placed: Iterable[Placed], *, window_s: float = _WINDOW_S
) -> list[WindowBreak]:
    """Where the windows of :func:`disconnected_windows` break: per window, its first pair
    of successive matched positions that no permitted route connects.

    Parameters
    ----------
    net : TrackMap
    placed : iterable of Placed
    window_s : float
        Window length, s.

    Returns
    -------
    list of WindowBreak
        By vehicle, then time.
    """
    return _windows(net, placed, window_s)[1]


def _windows(
    net: TrackMap, placed: Iterable[Placed], window_s: float
) -> tuple[int, list[WindowBreak]]:
    per: dict[tuple[str, int], list[Placed]] = defaultdict(list)
    for ev in placed:
        if ev.matched:
            per[(ev.vehicle_id, math.floor(ev.t / window_s))].append(ev)
    windows = 0
    breaks: list[WindowBreak] = []
    for _, seq in sorted(per.items()):
        if len(seq) < 2:
            continue
        windows += 1
        seq.sort(key=lambda e: e.t)
        for p, q in itertools.pairwise(seq):
            if _signed_track_distance(net, p, q, reach_m(q.t - p.t)) is None:
                (pe, po, pd), (qe, qo, qd) = _place(p), _place(q)
                breaks.append(
                    WindowBreak(
                        p.vehicle_id,
                        float(p.t),
                        float(q.t),
                        int(pe),
                        float(po),
                        int(pd),
                        int(qe),
                        float(qo),
                        int(qd),
                    )
                )
                break
    return windows, breaks
