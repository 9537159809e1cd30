"""Track-selective positioning: where on the network each vehicle is, and how sure we are.

For every vehicle the :class:`Positioner` keeps a small set of hypotheses over
(edge, running direction, offset) — an online hidden Markov model in the style of
Newson & Krumm (2009), as used for train positioning by DLR's RCAS and CTU's systems:

* **emission** — the lateral distance of the fix from the track (Gaussian, sigma
  ``gps_sigma_m``) and, when moving, the agreement of the reported course with the track
  heading in that running direction (a Gaussian with a uniform floor so that an odd course
  cannot veto the truth); running against a one-way track costs a prior penalty;
* **transition** — the along-track route distance between successive states, through
  physical moves only (no turning at a diamond, no reversing through a switch), compared
  with the distance travelled ``speed x dt`` (exponential, scale ``transition_beta_m``).

The forward algorithm gives each hypothesis its probability; the top ``max_hypotheses``
survive, so past a switch both branches stay alive until the evidence separates them.
A Kalman filter (:mod:`antikol.positioning.kalman`) along the track fuses the best
hypothesis' travelled distance with the reported speed; during a GPS outage it
dead-reckons along the most probable path until its uncertainty or the outage length
passes a limit, when the position is declared ``lost``. Discrete fixes (balises, loop
crossings) at known map positions are accepted only inside an acceptance window that
grows with the distance since the last fix; a fix outside it, or too many expected fixes
missed, also makes the position ``lost`` rather than jumping silently.

Reports that contradict physics (a jump of hundreds of metres in a second, a speed or an
acceleration the vehicle cannot reach) are rejected and counted and leave the state
untouched; after ``max_rejections_in_row`` rejections in a row the vehicle is re-initialised
from the new evidence.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from antikol.kinds import PositionStatus
from antikol.positioning.kalman import AlongTrackFilter
from antikol.report import VehicleReport
from antikol.thresholds import FILTER_NIS_GATE, MAX_PATHS_SEARCH
from trackmap import CandidateBatch, Path, TrackMap

logger = logging.getLogger(__name__)

_NEG_INF = -math.inf


@dataclass(frozen=True, slots=True)
class PositioningConfig:
    """Parameters of the positioning filter (SI units).

    Attributes
    ----------
    gps_sigma_m : float
        Standard deviation of a GPS fix per axis, m (scaled up by HDOP above 1).
    search_radius_m : float
        Candidate tracks are searched within this radius, m.
    max_hypotheses : int
        Hypotheses kept per vehicle.
    min_probability : float
        Hypotheses below this probability are dropped.
    course_sigma_deg, course_noise_deg_mps : float
        Course agreement scale: ``hypot(course_sigma_deg, course_noise_deg_mps / speed)``
        degrees (track-heading mismatch plus a Doppler course error that shrinks with
        speed).
    course_outlier_weight : float
        Weight of the uniform floor of the course likelihood.
    min_speed_for_course_mps : float
        Below this speed the course carries no weight, m/s.
    wrong_way_log_prior : float
        Log-likelihood penalty of running against a one-way track.
    transition_beta_m : float
        Scale of the transition likelihood, m (plus 10 % of the distance travelled).
    backward_m : float
        How far behind the previous state a new fix may project (GPS noise), m.
    confidence : float
        A match is ``confident`` when the best place holds at least this probability.
    max_speed_mps, max_accel_mps2 : float
        Physical limits used to reject impossible reports.
    jump_margin_m : float
        Extra displacement allowed between two fixes beyond what speed permits, m.
    max_rejections_in_row : int
        After this many rejected reports in a row, the vehicle is re-initialised.
    dead_reckoning_s : float
        Longest outage bridged by dead reckoning before the position is lost, s.
    lost_sigma_m : float
        Along-track uncertainty at which a dead-reckoned position is lost, m.
    reset_gap_s : float
        A gap between reports longer than this restarts the filters, s.
    accel_sigma_mps2, speed_sigma_mps : float
        Kalman filter process noise and reported-speed noise.
    fix_window_base_m, fix_window_fraction : float
        Acceptance window of a discrete fix: base + fraction x distance since the last fix.
    fix_sigma_m : float
        Accuracy of a discrete fix, m.
    max_missed_fixes : int
        Expected fixes that may be missed in a row before the position is lost.
    relocalise_after : int
        A lost vehicle is trusted again after this many confident GPS matches in a row.
    reversal_log_prior : float
        Log-probability that a standing vehicle changes its running direction between two
        fixes (bidirectional trams at termini); small, because at a standstill nothing
        else tells the directions apart and the alternative would slowly gain weight.
    standstill_distance_m, standstill_evidence_weight : float
        While the vehicle moves less than ``standstill_distance_m`` between fixes, the
        emission log-likelihood is scaled by ``standstill_evidence_weight``: GPS errors are
        correlated in time, so the fixes of a standing vehicle repeat rather than add
        evidence.
    """

    gps_sigma_m: float = 4.0
    search_radius_m: float = 25.0
    max_hypotheses: int = 8
    min_probability: float = 1e-4
    course_sigma_deg: float = 6.0
    course_noise_deg_mps: float = 20.0
    course_outlier_weight: float = 0.02
    min_speed_for_course_mps: float = 2.0
    wrong_way_log_prior: float = math.log(0.02)
    transition_beta_m: float = 6.0
    backward_m: float = 15.0
    confidence: float = 0.8
    max_speed_mps: float = 30.0
    max_accel_mps2: float = 3.5
    jump_margin_m: float = 30.0
    max_rejections_in_row: int = 3
    dead_reckoning_s: float = 30.0
    lost_sigma_m: float = 60.0
    reset_gap_s: float = 30.0
    accel_sigma_mps2: float = 0.6
    speed_sigma_mps: float = 0.3
    fix_window_base_m: float = 2.0
    fix_window_fraction: float = 0.02
    fix_sigma_m: float = 0.5
    max_missed_fixes: int = 2
    relocalise_after: int = 5
    reversal_log_prior: float = math.log(1e-4)
    standstill_distance_m: float = 1.0
    standstill_evidence_weight: float = 0.2


@dataclass(frozen=True, slots=True)
class Hypothesis:
    """One place a vehicle may be.

    Attributes
    ----------
    edge_id : int
    direction : int
        +1 along the edge's vertices, -1 against them.
    offset_m : float
        Projection of the fix on the edge, m from its first vertex.
    probability : float
    progress_m : float
        Distance travelled along this hypothesis' history, m (the Kalman filter's frame).
    wrong_way : bool
        Running against the edge's permitted direction.
    """

    edge_id: int
    direction: int
    offset_m: float
    probability: float
    progress_m: float
    wrong_way: bool = False


@dataclass(frozen=True, slots=True)
class TrackPosition:
    """Where a vehicle is on the network.

    Attributes
    ----------
    vehicle_id : str
    t : float
        Time of the estimate, s (later than the last report when dead-reckoned).
    status : str
        ``confident``, ``ambiguous`` (several places plausible), ``lost`` (dead reckoning
        exhausted, or contradicted by a discrete fix) or ``unmatched`` (no track nearby).
    edge_id, direction, offset_m
        The most probable track position (None when unmatched).
    lon, lat : float
        Degrees: the filtered track position, or the raw fix when unmatched.
    heading_deg : float or None
        True heading of travel on the track, degrees.
    speed_mps : float
        Filtered speed, m/s.
    probability : float
        Probability of the most probable place (0 when unmatched).
    sigma_m : float or None
        Along-track one-sigma uncertainty, m.
    wrong_way : bool
        The vehicle runs against the track's permitted direction.
    hypotheses : tuple of Hypothesis
        Every hypothesis kept, most probable first.
    dead_reckoned_s : float
        Time since the last position fix, s (0 at a fix).
    """

    vehicle_id: str
    t: float
    status: PositionStatus
    edge_id: int | None
    direction: int | None
    offset_m: float | None
    lon: float
    lat: float
    heading_deg: float | None
    speed_mps: float
    probability: float
    sigma_m: float | None
    wrong_way: bool = False
    hypotheses: tuple[Hypothesis, ...] = ()
    dead_reckoned_s: float = 0.0

    @property
    def matched(self) -> bool:
        """True when confident or ambiguous (usable for track-based analysis)."""
        return self.status in ("confident", "ambiguous")


@dataclass(frozen=True, slots=True)
class FixPoint:
    """A discrete position reference on the map (a balise or a loop crossing)."""

    fix_id: str
    edge_id: int
    offset_m: float


@dataclass(frozen=True, slots=True)
class DiscreteFix:
    """A vehicle passing a :class:`FixPoint` at time ``t`` (s)."""

    t: float
    edge_id: int
    offset_m: float
    fix_id: str | None = None


@dataclass
class _VehicleState:
    filter: AlongTrackFilter
    hyps: list[Hypothesis] = field(default_factory=list)
    last: VehicleReport | None = None
    last_xy: tuple[float, float] | None = None
    z_last: float = 0.0
    rejected_in_row: int = 0
    lost: str | None = None
    confident_in_row: int = 0
    last_fix_s: float | None = None
    missed_fixes: int = 0
    expected_fixes: list[tuple[str, float]] = field(default_factory=list)
    unmatched: bool = False
    output: TrackPosition | None = None


class Positioner:
    """Track-selective positioning of a fleet on one map.

    Parameters
    ----------
    track_map : TrackMap
    config : PositioningConfig, optional
    fix_points : iterable of FixPoint, optional
        Known discrete position references; vehicles are expected to report passing them.
    fix_equipped : iterable of str, optional
        Vehicles able to read fix points (default: all, when fix points are given).
    """

    def __init__(
        self,
        track_map: TrackMap,
        config: PositioningConfig | None = None,
        *,
        fix_points: Iterable[FixPoint] = (),
        fix_equipped: Iterable[str] | None = None,
    ) -> None:
        self.net = track_map
        self.config = config or PositioningConfig()
        self._states: dict[str, _VehicleState] = {}
        self.stats: Counter[str] = Counter()
        self._fix_by_edge: dict[int, list[tuple[float, str]]] = {}
        for fp in fix_points:
            self.net.edge(fp.edge_id)
            self._fix_by_edge.setdefault(fp.edge_id, []).append((fp.offset_m, fp.fix_id))
        self._fix_equipped = None if fix_equipped is None else set(fix_equipped)

    # -- public API ----------------------------------------------------------------------
    def update(self, report: VehicleReport) -> TrackPosition:
        """Fuse one report of a vehicle.

        Parameters
        ----------
        report : VehicleReport

        Returns
        -------
        TrackPosition
            The vehicle's position after the report (unchanged if the report was rejected).
        """
        x, y = self.net.to_local(report.lon, report.lat)
        batch = self.net.candidates_batch_xy(np.array([x]), np.array([y]), self._radius(report))
        return self._update(report, (x, y), batch, np.arange(len(batch)))

    def update_many(self, reports: Sequence[VehicleReport]) -> list[TrackPosition]:
        """Fuse reports of many vehicles with one vectorised candidate search.

        Parameters
        ----------
        reports : sequence of VehicleReport
            At most one report per vehicle is typical (one cycle); several are processed in
            order.

        Returns
        -------
        list of TrackPosition
            In the order of ``reports``.
        """
        if not reports:
            return []
        lon = np.fromiter((r.lon for r in reports), float, len(reports))
        lat = np.fromiter((r.lat for r in reports), float, len(reports))
        xs, ys = self.net.to_local(lon, lat)
        radius = max(self._radius(r) for r in reports)
        batch = self.net.candidates_batch_xy(np.atleast_1d(xs), np.atleast_1d(ys), radius)
        order = np.argsort(batch.point, kind="stable")
        bounds = np.searchsorted(batch.point[order], np.arange(len(reports) + 1))
        out = []
        for i, r in enumerate(reports):
            rows = order[bounds[i] : bounds[i + 1]]
            rows = rows[batch.distance_m[rows] <= self._radius(r)]
            out.append(self._update(r, (float(xs[i]), float(ys[i])), batch, rows))
        return out

    def position(self, vehicle_id: str, t: float | None = None) -> TrackPosition | None:
        """The vehicle's position at time ``t`` (dead-reckoned when later than its report).

        Parameters
        ----------
        vehicle_id : str
        t : float, optional
            Time, s; default the time of the last report.

        Returns
        -------
        TrackPosition or None
            None for a vehicle never seen.
        """
        st = self._states.get(vehicle_id)
        if st is None or st.last is None:
            return None
        when = st.last.t if t is None else max(t, st.last.t)
        if st.output is not None and st.output.t == when:
            return st.output
        st.output = self._output(vehicle_id, st, when)
        return st.output

    def forget(self, vehicle_id: str) -> None:
        """Drop a vehicle's state (it left the vehicle table)."""
        self._states.pop(vehicle_id, None)

    def vehicles(self) -> list[str]:
        """Ids of the vehicles with a state."""
        return list(self._states)

    def fix(self, vehicle_id: str, fix: DiscreteFix) -> TrackPosition | None:
        """Apply a discrete position fix (a balise or loop crossing).

        A fix is accepted only when it lies within the acceptance window around the
        predicted position, ``fix_window_base_m + fix_window_fraction x distance since the
        last accepted fix``. An accepted fix resets the along-track error and pins the
        vehicle to the fix's track; a fix outside the window makes the position ``lost``.

        Returns
        -------
        TrackPosition or None
            The new position (None for an unknown vehicle).
        """
        st = self._states.get(vehicle_id)
        if st is not None:
            st.output = None
        if st is None or st.last is None or not st.hyps or not st.filter.initialised:
            self.stats["fix_unusable"] += 1
            return self.position(vehicle_id)
        self.net.edge(fix.edge_id)
        est = st.filter.estimate(fix.t)
        best = st.hyps[0]
        pred_edge, pred_off, pred_dir = self._advance(best, est.s_m - st.z_last, st.last)
        travelled = est.s_m - (st.last_fix_s if st.last_fix_s is not None else est.s_m)
        window = self.config.fix_window_base_m + self.config.fix_window_fraction * abs(travelled)
        if st.last_fix_s is None:
            window = max(window, 3.0 * self.config.gps_sigma_m + est.s_std_m)
        delta = self._signed_track_distance(
            (pred_edge, pred_off, pred_dir), (fix.edge_id, fix.offset_m), window + 5.0
        )
        if delta is None or abs(delta) > window:
            st.lost = "fix_outside_window"
            st.confident_in_row = 0
            self.stats["fix_rejected"] += 1
            logger.info(
                "%s: fix %s at edge %d/%.1f m is %s from the prediction (window %.1f m): lost",
                vehicle_id,
                fix.fix_id,
                fix.edge_id,
                fix.offset_m,
                "unreachable" if delta is None else f"{delta:+.1f} m",
                window,
            )
            return self.position(vehicle_id, fix.t)
        s_fix = est.s_m + delta
        # the fix is far more precise than the track so far: restart the along-track error
        st.filter.reset(fix.t, s_fix, est.v_mps, s_std_m=self.config.fix_sigma_m)
        st.hyps = [
            Hypothesis(
                fix.edge_id,
                pred_dir,
                fix.offset_m,
                1.0,
                s_fix,
                wrong_way=not self.net.edges[fix.edge_id].allows(pred_dir),
            )
        ]
        st.z_last = s_fix
        st.last_fix_s = s_fix
        st.missed_fixes = 0
        st.expected_fixes = [
            (fid, s) for fid, s in st.expected_fixes if s > s_fix + window and fid != fix.fix_id
        ]
        st.lost = None
        self.stats["fix_accepted"] += 1
        return self.position(vehicle_id, fix.t)

    def state(self, vehicle_id: str) -> dict[str, Any] | None:
        """The vehicle's filter state as a JSON-ready dict (bounded size)."""
        st = self._states.get(vehicle_id)
        if st is None:
            return None
        return {
            "hypotheses": [asdict(h) for h in st.hyps],
            "filter": st.filter.to_dict(),
            "z_last": st.z_last,
            "lost": st.lost,
            "last_fix_s": st.last_fix_s,
            "missed_fixes": st.missed_fixes,
            "expected_fixes": [list(e) for e in st.expected_fixes],
            "rejected_in_row": st.rejected_in_row,
            "confident_in_row": st.confident_in_row,
            "unmatched": st.unmatched,
            "last_report": None if st.last is None else _report_dict(st.last),
            "last_xy": None if st.last_xy is None else list(st.last_xy),
        }

    def restore(self, vehicle_id: str, data: dict[str, Any]) -> None:
        """Restore a state produced by :meth:`state`."""
        st = self._new_state()
        st.hyps = [Hypothesis(**h) for h in data["hypotheses"]]
        st.filter.load_dict(data["filter"])
        st.z_last = float(data["z_last"])
        st.lost = data["lost"]
        st.last_fix_s = data["last_fix_s"]
        st.missed_fixes = int(data["missed_fixes"])
        st.expected_fixes = [(str(a), float(b)) for a, b in data["expected_fixes"]]
        st.rejected_in_row = int(data["rejected_in_row"])
        st.confident_in_row = int(data["confident_in_row"])
        st.unmatched = bool(data["unmatched"])
        lr = data["last_report"]
        st.last = None if lr is None else VehicleReport(**lr)
        st.last_xy = None if data["last_xy"] is None else (data["last_xy"][0], data["last_xy"][1])
        self._states[vehicle_id] = st

    # -- internals -----------------------------------------------------------------------
    def _new_state(self) -> _VehicleState:
        c = self.config
        return _VehicleState(
            filter=AlongTrackFilter(
                accel_sigma_mps2=c.accel_sigma_mps2,
                position_sigma_m=c.gps_sigma_m,
                speed_sigma_mps=c.speed_sigma_mps,
            )
        )

    def _sigma(self, report: VehicleReport) -> float:
        scale = max(1.0, report.hdop) if report.hdop is not None else 1.0
        return self.config.gps_sigma_m * scale

    def _radius(self, report: VehicleReport) -> float:
        return max(self.config.search_radius_m, 4.0 * self._sigma(report))

    def _update(
        self,
        report: VehicleReport,
        xy: tuple[float, float],
        batch: CandidateBatch,
        rows: np.ndarray,
    ) -> TrackPosition:
        c = self.config
        vid = report.vehicle_id
        st = self._states.get(vid)
        if st is None:
            st = self._states[vid] = self._new_state()
        st.output = None
        reason = self._implausible(st, report, xy)
        if reason is not None:
            st.rejected_in_row += 1
            self.stats[f"rejected_{reason}"] += 1
            if st.rejected_in_row < c.max_rejections_in_row:
                logger.debug("%s: report at t=%.1f rejected (%s)", vid, report.t, reason)
                pos = self.position(vid)
                assert pos is not None
                return pos
            self.stats["reset_after_rejections"] += 1
            st.hyps = []
        st.rejected_in_row = 0
        gap = report.t - st.last.t if st.last is not None else math.inf
        if gap > c.reset_gap_s:
            st.hyps = []
        if len(rows) == 0:
            st.hyps = []
            st.unmatched = True
            st.last, st.last_xy = report, xy
            st.confident_in_row = 0
            self.stats["unmatched"] += 1
            return self._output(vid, st, report.t)
        states = self._candidate_states(report, batch, rows)
        prev = st.hyps
        dt = report.t - st.last.t if st.last is not None else 0.0
        if prev and st.last is not None and not st.unmatched:
            weights, progress, parents = self._transitions(prev, states, report, st.last, dt)
            if not np.isfinite(weights).any():
                self.stats["unreachable_fix"] += 1
                st.rejected_in_row += 1
                if st.rejected_in_row < c.max_rejections_in_row:
                    pos = self.position(vid)
                    assert pos is not None
                    return pos
                self.stats["reset_after_rejections"] += 1
                weights = np.array([s[3] for s in states])
                progress = np.zeros(len(states))
        else:
            weights = np.array([s[3] for s in states])
            progress = np.zeros(len(states))
            parents = None
        finite = np.isfinite(weights)
        w = weights - np.max(weights[finite])
        p = np.where(finite, np.exp(w), 0.0)
        p /= p.sum()
        order = np.argsort(-p, kind="stable")
        hyps: list[Hypothesis] = []
        for k in order[: c.max_hypotheses]:
            if p[k] < c.min_probability and hyps:
                break
            e, d, off, _, wrong = states[k]
            hyps.append(Hypothesis(e, d, off, float(p[k]), float(progress[k]), wrong))
        total = sum(h.probability for h in hyps)
        hyps = [
            Hypothesis(
                h.edge_id, h.direction, h.offset_m, h.probability / total, h.progress_m, h.wrong_way
            )
            for h in hyps
        ]
        best = hyps[0]
        fresh = not prev or st.unmatched or not st.filter.initialised or parents is None
        if fresh:
            st.filter.reset(report.t, best.progress_m, report.speed_mps)
            self.stats["filter_reset"] += 1
        else:
            st.filter.predict(report.t)
            nis = st.filter.update(best.progress_m, report.speed_mps, s_std_m=self._sigma(report))
            if abs(nis) > FILTER_NIS_GATE:
                st.filter.reset(report.t, best.progress_m, report.speed_mps)
                self.stats["filter_reset"] += 1
            if parents is not None:
                self._track_expected_fixes(st, prev, parents, order[0], states, report)
        st.hyps = hyps
        st.z_last = best.progress_m
        st.last, st.last_xy = report, xy
        st.unmatched = False
        self.stats["matched"] += 1
        if self._place_probability(hyps) >= c.confidence:
            st.confident_in_row += 1
        else:
            st.confident_in_row = 0
        if st.lost is not None and st.confident_in_row >= c.relocalise_after:
            self.stats["relocalised"] += 1
            st.lost = None
        self._check_missed_fixes(vid, st)
        return self._output(vid, st, report.t)

    def _implausible(
        self, st: _VehicleState, report: VehicleReport, xy: tuple[float, float]
    ) -> str | None:
        c = self.config
        if report.speed_mps > c.max_speed_mps:
            return "speed"
        last = st.last
        if last is None or st.last_xy is None:
            return None
        dt = report.t - last.t
        if dt <= 0:
            return "time"
        if abs(report.speed_mps - last.speed_mps) > c.max_accel_mps2 * dt + 2.0:
            return "acceleration"
        moved = math.hypot(xy[0] - st.last_xy[0], xy[1] - st.last_xy[1])
        reach = max(report.speed_mps, last.speed_mps) * dt + 0.5 * c.max_accel_mps2 * dt * dt
        if moved > reach + c.jump_margin_m:
            return "jump"
        return None

    def _candidate_states(
        self, report: VehicleReport, batch: CandidateBatch, rows: np.ndarray
    ) -> list[tuple[int, int, float, float, bool]]:
        """(edge, direction, offset, emission log-likelihood, wrong_way) per candidate."""
        c = self.config
        sigma = self._sigma(report)
        use_course = report.speed_mps >= c.min_speed_for_course_mps
        # receivers derive the course from Doppler velocity: its error shrinks with speed
        course_sigma = math.hypot(
            c.course_sigma_deg, c.course_noise_deg_mps / max(report.speed_mps, 0.1)
        )
        states = []
        seen: set[int] = set()
        for r in rows.tolist():
            e = int(batch.edge_id[r])
            if e in seen:
                continue
            seen.add(e)
            dist = float(batch.distance_m[r])
            base = -0.5 * (dist / sigma) ** 2
            edge = self.net.edges[e]
            for d in (1, -1):
                wrong = not edge.allows(d)
                ll = base + (c.wrong_way_log_prior if wrong else 0.0)
                if use_course:
                    heading = float(batch.heading_deg[r]) + (0.0 if d == 1 else 180.0)
                    diff = (report.course_deg - heading + 180.0) % 360.0 - 180.0
                    gauss = math.exp(-0.5 * (diff / course_sigma) ** 2) / (
                        course_sigma * math.sqrt(2 * math.pi)
                    )
                    ll += math.log(
                        (1 - c.course_outlier_weight) * gauss + c.course_outlier_weight / 360.0
                    )
                states.append((e, d, float(batch.offset_m[r]), ll, wrong))
        return states

    def _transitions(
        self,
        prev: list[Hypothesis],
        states: list[tuple[int, int, float, float, bool]],
        report: VehicleReport,
        last: VehicleReport,
        dt: float,
    ) -> tuple[np.ndarray, np.ndarray, list[tuple[int, float, Path | None]]]:
        c = self.config
        travelled = 0.5 * (report.speed_mps + last.speed_mps) * dt
        reach = (
            max(report.speed_mps, last.speed_mps) * dt
            + 0.5 * c.max_accel_mps2 * dt * dt
            + 3.0 * self._sigma(report)
            + 10.0
        )
        beta = c.transition_beta_m + 0.1 * travelled
        n = len(states)
        best_score = np.full(n, _NEG_INF)
        logsum = np.full(n, _NEG_INF)
        progress = np.zeros(n)
        parents: list[tuple[int, float, Path | None]] = [(-1, 0.0, None)] * n
        for i, h in enumerate(prev):
            log_prior = math.log(max(h.probability, 1e-300))
            ahead = self.net.paths_ahead(
                h.edge_id,
                h.offset_m,
                h.direction,
                reach,
                respect_direction=False,
                max_paths=MAX_PATHS_SEARCH,
            )
            behind = self.net.paths_ahead(
                h.edge_id,
                h.offset_m,
                -h.direction,
                c.backward_m,
                respect_direction=False,
                max_paths=MAX_PATHS_SEARCH,
            )
            for j, (e, d, off, _emit, _) in enumerate(states):
                dist, path = _route_offset(ahead, behind, e, d, off, travelled)
                if dist is None:
                    if e == h.edge_id and d == -h.direction and travelled < 1.0:
                        # a stopped vehicle may change direction (bidirectional trams)
                        dist, path = abs(off - h.offset_m), None
                        trans = c.reversal_log_prior - abs(dist) / beta
                    else:
                        continue
                else:
                    trans = -abs(dist - travelled) / beta
                score = log_prior + trans
                logsum[j] = np.logaddexp(logsum[j], score)
                if score > best_score[j]:
                    best_score[j] = score
                    progress[j] = h.progress_m + dist
                    parents[j] = (i, dist, path)
        emissions = np.array([s[3] for s in states])
        if travelled < c.standstill_distance_m:
            # a standing receiver's errors barely change between fixes: repeated fixes are
            # not independent evidence, so they must not talk the filter into certainty
            emissions = emissions * c.standstill_evidence_weight
        weights = np.where(np.isfinite(logsum), logsum + emissions, _NEG_INF)
        return weights, progress, parents

    def _place_probability(self, hyps: list[Hypothesis]) -> float:
        """Probability of the best hypothesis' place (the same spot across a plain node)."""
        if not hyps:
            return 0.0
        best = hyps[0]
        total = best.probability
        for h in hyps[1:]:
            if self._same_place(best, h):
                total += h.probability
        return min(total, 1.0)

    def _same_place(self, a: Hypothesis, b: Hypothesis, tol_m: float = 3.0) -> bool:
        if (a.edge_id, a.direction) == (b.edge_id, b.direction):
            return True
        g = self.net.traversal_any
        for u, v in ((a, b), (b, a)):
            if g.has_edge((u.edge_id, u.direction), (v.edge_id, v.direction)):
                u_len = self.net.edge_length(u.edge_id)
                to_exit = u_len - u.offset_m if u.direction == 1 else u.offset_m
                v_len = self.net.edge_length(v.edge_id)
                from_entry = v.offset_m if v.direction == 1 else v_len - v.offset_m
                if to_exit <= tol_m and from_entry <= tol_m:
                    return True
        return False

    def _advance(
        self, h: Hypothesis, distance_m: float, report: VehicleReport | None
    ) -> tuple[int, float, int]:
        """Move a track position along the most probable path by a signed distance."""
        if abs(distance_m) < 1e-6:
            return h.edge_id, h.offset_m, h.direction
        if distance_m > 0:
            paths = self.net.paths_ahead(
                h.edge_id,
                h.offset_m,
                h.direction,
                distance_m,
                respect_direction=not h.wrong_way,
                max_paths=MAX_PATHS_SEARCH,
            )
            if not paths:
                return h.edge_id, h.offset_m, h.direction
            path = _preferred_path(paths, report.route if report is not None else None)
            last = path.steps[-1]
            return last.edge_id, last.exit_offset_m, last.direction
        paths = self.net.paths_ahead(
            h.edge_id,
            h.offset_m,
            -h.direction,
            -distance_m,
            respect_direction=False,
            max_paths=MAX_PATHS_SEARCH,
        )
        last = _preferred_path(paths, None).steps[-1]
        return last.edge_id, last.exit_offset_m, -last.direction

    def _signed_track_distance(
        self, frm: tuple[int, float, int], to: tuple[int, float], cutoff_m: float
    ) -> float | None:
        e, off, d = frm
        ahead = self.net.route_distance(
            e, off, d, to[0], to[1], cutoff_m=cutoff_m, respect_direction=False
        )
        if ahead is not None:
            return ahead.distance_m
        back = self.net.route_distance(
            e, off, -d, to[0], to[1], cutoff_m=cutoff_m, respect_direction=False
        )
        if back is not None:
            return -back.distance_m
        return None

    def _output(self, vid: str, st: _VehicleState, t: float) -> TrackPosition:
        assert st.last is not None
        if st.unmatched or not st.hyps:
            return TrackPosition(
                vehicle_id=vid,
                t=t,
                status="unmatched",
                edge_id=None,
                direction=None,
                offset_m=None,
                lon=st.last.lon,
                lat=st.last.lat,
                heading_deg=None,
                speed_mps=st.last.speed_mps,
                probability=0.0,
                sigma_m=None,
            )
        est = st.filter.estimate(t)
        age = t - st.last.t
        best = st.hyps[0]
        edge, off, direction = self._advance(best, est.s_m - st.z_last, st.last)
        x, y = self.net.point_at(edge, off)
        lon, lat = self.net.to_lonlat(x, y)
        place_p = self._place_probability(st.hyps)
        status: PositionStatus
        if (
            st.lost is not None
            or age > self.config.dead_reckoning_s
            or est.s_std_m > self.config.lost_sigma_m
        ):
            status = "lost"
        elif place_p >= self.config.confidence:
            status = "confident"
        else:
            status = "ambiguous"
        return TrackPosition(
            vehicle_id=vid,
            t=t,
            status=status,
            edge_id=edge,
            direction=direction,
            offset_m=off,
            lon=float(lon),
            lat=float(lat),
            heading_deg=self.net.heading_at(edge, off, direction),
            speed_mps=est.v_mps,
            probability=place_p,
            sigma_m=est.s_std_m,
            wrong_way=best.wrong_way,
            hypotheses=tuple(st.hyps),
            dead_reckoned_s=age,
        )

    # -- discrete fixes ------------------------------------------------------------------
    def _equipped(self, vid: str) -> bool:
        return bool(self._fix_by_edge) and (self._fix_equipped is None or vid in self._fix_equipped)

    def _track_expected_fixes(
        self,
        st: _VehicleState,
        prev: list[Hypothesis],
        parents: list[tuple[int, float, Path | None]],
        best_index: int,
        states: list[tuple[int, int, float, float, bool]],
        report: VehicleReport,
    ) -> None:
        if not self._equipped(report.vehicle_id):
            return
        i, dist, path = parents[best_index]
        if i < 0 or path is None or dist <= 0:
            return
        origin = prev[i].progress_m
        for step in path.steps:
            if step.start_m > dist:
                break
            for off, fid in self._fix_by_edge.get(step.edge_id, ()):
                at = step.distance_to(off)
                if at is not None and 0 < at <= dist:
                    st.expected_fixes.append((fid, origin + at))

    def _check_missed_fixes(self, vid: str, st: _VehicleState) -> None:
        if not st.expected_fixes:
            return
        s_now = st.filter.estimate().s_m
        remaining = []
        for fid, s_exp in st.expected_fixes:
            since = s_exp - (st.last_fix_s if st.last_fix_s is not None else s_exp)
            window = self.config.fix_window_base_m + self.config.fix_window_fraction * abs(since)
            if s_now > s_exp + window + 10.0:
                st.missed_fixes += 1
                self.stats["fix_missed"] += 1
                logger.debug("%s: expected fix %s not received", vid, fid)
            else:
                remaining.append((fid, s_exp))
        st.expected_fixes = remaining
        if st.missed_fixes > self.config.max_missed_fixes and st.lost is None:
            st.lost = "missed_fixes"
            st.confident_in_row = 0
            self.stats["lost_missed_fixes"] += 1


def _route_offset(
    ahead: list[Path],
    behind: list[Path],
    edge: int,
    direction: int,
    offset: float,
    travelled: float,
) -> tuple[float | None, Path | None]:
    """Signed along-track distance to a candidate state, closest to ``travelled``."""
    best: float | None = None
    best_path: Path | None = None
    for path in ahead:
        for step in path.steps:
            if step.edge_id == edge and step.direction == direction:
                d = step.distance_to(offset)
                if d is not None and (best is None or abs(d - travelled) < abs(best - travelled)):
                    best, best_path = d, path
    for path in behind:
        for step in path.steps:
            if step.edge_id == edge and step.direction == -direction:
                d = step.distance_to(offset)
                if d is not None and (best is None or abs(-d - travelled) < abs(best - travelled)):
                    best, best_path = -d, None
    return best, best_path


def _preferred_path(paths: list[Path], route: tuple[int, ...] | None) -> Path:
    """The path a vehicle most probably takes: along its route, else the straightest."""
    if route:
        on_route = set(route)
        scored = [(sum(1 for e in p.edges if e in on_route), p) for p in paths]
        top = max(s for s, _ in scored)
        if top > 1:
            return next(p for s, p in scored if s == top)
    return min(paths, key=lambda p: sum(1 for n in p.nodes if n.choice not in (None, "straight")))


def _report_dict(r: VehicleReport) -> dict[str, Any]:
    d = {name: getattr(r, name) for name in r.__dataclass_fields__}
    if d.get("track_position") is not None:
        d["track_position"] = None  # not needed to resume positioning
    if d.get("route") is not None:
        d["route"] = list(d["route"])
    return d
