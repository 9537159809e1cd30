"""The analyser: one object that takes reports and answers "what threatens vehicle X?".

Without a map the analyser runs the 2008 paper's sector rule for every pair: every threat
has ``method='sector'`` and level ``warning`` (the paper's lamp).

With a map (``Analyser(track_map=net)``) it implements the paper's next generation:

1. every vehicle is positioned on the tracks (:mod:`antikol.positioning.matcher`);
2. the own sensitivity area follows the track ahead up to a horizon from the braking model
   (never shorter than the paper's 300 m unless configured) and splits into one **zone**
   per branch at facing switches; with a known planned route only the routed zone can
   raise a ``warning``, the others are ``advisory``;
3. conflicts with every other matched vehicle are found along those zones:
   ``rear_end`` (the other is ahead on a zone, running the same way), ``head_on`` (ahead,
   running towards us), ``merge`` (our zones and the other's meet in the fouling area of a
   switch from different branches) and ``crossing`` (both reach the same crossing conflict
   point), the last two only when the arrival windows overlap;
4. levels follow the braking model (:func:`antikol.analysis.braking.classify`);
5. when a match is ambiguous every combination of hypotheses is evaluated and a threat is
   raised when the probability of conflict reaches ``conflict_probability`` (err towards
   warning);
6. a vehicle the sector rule would flag but that has no conflict on the map is listed in
   ``Assessment.suppressed`` with the reason (e.g. ``parallel_track``);
7. a pair where either vehicle is unmatched or lost falls back to the sector rule
   (``method='sector'``). Nothing is dropped silently.
"""

from __future__ import annotations

import logging
import math
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import shapely

from antikol.analysis import braking
from antikol.analysis.assessment import Assessment, Suppressed, Threat, highest_level, sort_threats
from antikol.analysis.braking import BrakingProfile
from antikol.analysis.geometry import closing_speed_mps
from antikol.analysis.sector import CourseKeeper, SectorHit, SectorRule
from antikol.errors import UnknownVehicleError
from antikol.kinds import Level, level_rank
from antikol.positioning.matcher import (
    DiscreteFix,
    FixPoint,
    Positioner,
    PositioningConfig,
    TrackPosition,
)
from antikol.report import VehicleReport
from antikol.table import TableUpdate, VehicleTable
from antikol.thresholds import EXPIRY_S, MIN_HORIZON_M, STANDING_SPEED_MPS, TABLE_CAPACITY

if TYPE_CHECKING:
    from trackmap import Path, TrackMap

logger = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class AnalyserConfig:
    """Parameters of the track-aware analysis (SI units).

    Attributes
    ----------
    min_horizon_m : float
        Shortest look-ahead along the track, m (the paper's d_col by default).
    conflict_probability : float
        A conflict is raised when its probability over the match hypotheses reaches this.
    max_hypotheses : int
        Hypotheses per vehicle evaluated in ambiguous cases.
    min_hypothesis_probability : float
        Hypotheses less probable than this are not evaluated.
    window_slack_s : float
        Arrival windows at merges and crossings overlap when closer than this, s.
    stopped_speed_mps : float
        Below this speed a vehicle is treated as standing, m/s.
    corridor_half_width_m : float
        Half-width of the corridor polygons drawn for zones, m.
    parallel_distance_m : float
        A suppressed vehicle this close to a zone counts as on a parallel track, m.
    gap_margin_sigmas : float
        Gaps are shortened by this many standard deviations of the combined along-track
        uncertainty of both positions before the level is chosen (err towards warning).
    """

    min_horizon_m: float = MIN_HORIZON_M
    conflict_probability: float = 0.2
    max_hypotheses: int = 3
    min_hypothesis_probability: float = 0.01
    window_slack_s: float = 5.0
    stopped_speed_mps: float = STANDING_SPEED_MPS
    corridor_half_width_m: float = 1.7
    parallel_distance_m: float = 10.0
    gap_margin_sigmas: float = 2.0


@dataclass(frozen=True, slots=True)
class Zone:
    """One zone of the sensitivity area (a branch of the track ahead).

    Attributes
    ----------
    label : str
        ``main`` or the choices at facing switches (``straight/left``...).
    role : str
        ``warning`` or ``advisory`` (a branch off the known planned route).
    path : trackmap.Path
    corridor : shapely.Polygon
        The corridor along the path in the map's local frame (metres).
    probability : float
        Probability of the own match hypothesis the zone starts from.
    """

    label: str
    role: Literal["warning", "advisory"]
    path: Path
    corridor: shapely.Polygon
    probability: float


@dataclass
class _Hyp:
    edge_id: int
    direction: int
    offset_m: float
    probability: float
    wrong_way: bool
    paths: list[Path]


@dataclass
class _View:
    """Everything about one vehicle at one analysis time."""

    report: VehicleReport
    position: TrackPosition | None
    speed_mps: float
    horizon_m: float
    hyps: list[_Hyp] = field(default_factory=list)

    @property
    def matched(self) -> bool:
        return self.position is not None and self.position.matched


@dataclass
class _Candidate:
    kind: str
    level: Level
    gap_m: float
    closing_mps: float
    ttc_s: float | None
    zone: str | None
    detail: str


class Analyser:
    """Collision-warning analyser for one own vehicle or a whole fleet.

    Parameters
    ----------
    track_map : trackmap.TrackMap, optional
        The rail network. ``None`` runs the paper's sector rule throughout.
    sector : SectorRule, optional
        The sector rule used without a map and as fallback.
    own_id : str, optional
        On-board use: the own vehicle (the reference of the vehicle table's full-table
        policy, never expired). ``None`` (control-room use) lets :meth:`assess` be asked
        for any vehicle.
    capacity : int, None or "auto"
        Vehicle table capacity (other vehicles); ``None`` is unbounded. ``"auto"``: 32 (the
        paper) when ``own_id`` is given, unbounded otherwise.
    expiry_s : float
        Silence after which a vehicle is dropped, s (paper: ~10 s).
    profile : BrakingProfile, optional
        Braking profile of every vehicle without its own entry in ``profiles`` (default:
        the tram profile).
    profiles : mapping of str to BrakingProfile, optional
        Per-vehicle braking profiles.
    positioning : PositioningConfig, optional
    config : AnalyserConfig, optional
    fix_points : iterable of FixPoint
        Discrete position references on the map (balises, loop crossings).
    """

    def __init__(
        self,
        track_map: TrackMap | None = None,
        *,
        sector: SectorRule | None = None,
        own_id: str | None = None,
        capacity: int | Literal["auto"] | None = "auto",
        expiry_s: float = EXPIRY_S,
        profile: BrakingProfile | None = None,
        profiles: Mapping[str, BrakingProfile] | None = None,
        positioning: PositioningConfig | None = None,
        config: AnalyserConfig | None = None,
        fix_points: Iterable[FixPoint] = (),
    ) -> None:
        self.track_map = track_map
        self.sector = sector if sector is not None else SectorRule()
        self.own_id = own_id
        table_capacity = (
            (TABLE_CAPACITY if own_id is not None else None) if capacity == "auto" else capacity
        )
        self.expiry_s = float(expiry_s)
        # Control-room use emulates every vehicle's own unit: a vehicle that falls silent (GPS
        # lost in a tunnel) keeps being assessed on its dead-reckoned position, while the
        # others stop seeing it after expiry_s, as in the paper.
        retain = self.expiry_s
        if own_id is None and track_map is not None:
            retain = max(retain, (positioning or PositioningConfig()).dead_reckoning_s)
        self.table = VehicleTable(capacity=table_capacity, expiry_s=retain, own_id=own_id)
        self.courses = CourseKeeper(min_speed_mps=self.sector.min_speed_for_course_mps)
        self.profile = profile if profile is not None else braking.load_profile("tram")
        self.profiles = dict(profiles or {})
        self.config = config or AnalyserConfig()
        self.positioner = (
            Positioner(track_map, positioning, fix_points=fix_points)
            if track_map is not None
            else None
        )
        self._views: dict[str, _View] = {}
        self._views_time: float | None = None
        self._edge_index: dict[int, list[tuple[str, int]]] = {}
        self._conflict_index: dict[int, list[tuple[str, int, Path, float, int, int]]] = {}
        self._decoder: Any = None
        self._nmea: Any = None
        self._version = 0
        self._index_version = -1

    # -- input ---------------------------------------------------------------------------
    def update(self, report: VehicleReport) -> TableUpdate:
        """Feed one report (own or other vehicle).

        Returns
        -------
        TableUpdate
            What the vehicle table did with it.
        """
        result = self._table_update(report)
        if result.accepted and self.positioner is not None:
            self.positioner.update(report)
        return result

    def update_many(self, reports: Sequence[VehicleReport]) -> list[TableUpdate]:
        """Feed many reports at once (one analysis cycle of a fleet); positions are
        matched with one vectorised candidate search."""
        results = [self._table_update(r) for r in reports]
        if self.positioner is not None:
            accepted = [r for r, res in zip(reports, results, strict=True) if res.accepted]
            self.positioner.update_many(accepted)
        return results

    def feed_bytes(self, chunk: bytes) -> list[TableUpdate]:
        """Feed raw radio bytes (any chunking); decoded reports update the analyser.

        Rejected frames are counted in :attr:`decoder_stats`; this never raises.
        """
        from antikol.ingest.protocol import StreamDecoder

        if self._decoder is None:
            self._decoder = StreamDecoder()
        return self.update_many(self._decoder.feed(chunk))

    @property
    def decoder_stats(self) -> Any:
        """Statistics of the radio stream decoder (None before :meth:`feed_bytes`)."""
        return None if self._decoder is None else self._decoder.stats

    def feed_nmea(self, line: str | bytes) -> list[TableUpdate]:
        """Feed one NMEA 0183 line of the own receiver (needs ``own_id``)."""
        from antikol.ingest.nmea import NmeaReader

        if self.own_id is None:
            raise ValueError("feed_nmea() needs the analyser's own_id")
        if self._nmea is None:
            self._nmea = NmeaReader(self.own_id)
        return [self.update(r) for r in self._nmea.feed_line(line)]

    def fix(self, vehicle_id: str, fix: DiscreteFix) -> TrackPosition | None:
        """Apply a discrete position fix (balise, loop crossing) to a vehicle."""
        if self.positioner is None:
            raise ValueError("discrete fixes need a track map")
        self._version += 1
        return self.positioner.fix(vehicle_id, fix)

    def _table_update(self, report: VehicleReport) -> TableUpdate:
        result = self.table.update(report)
        for vid in result.expired:
            self._forget(vid)
        if result.evicted is not None:
            self._forget(result.evicted)
        if result.accepted:
            self.courses.update(report)
            self._version += 1
        return result

    def _forget(self, vehicle_id: str) -> None:
        self.courses.forget(vehicle_id)
        if self.positioner is not None:
            self.positioner.forget(vehicle_id)
        self._version += 1

    # -- output --------------------------------------------------------------------------
    def position(self, vehicle_id: str, t: float | None = None) -> TrackPosition | None:
        """Track position of a vehicle (None without a map or for an unknown vehicle).

        Parameters
        ----------
        vehicle_id : str
        t : float, optional
            Time, s (default: the newest report time); later than the vehicle's last
            report means dead reckoning.
        """
        if self.positioner is None or vehicle_id not in self.table:
            return None
        return self.positioner.position(vehicle_id, self.table.clock if t is None else t)

    def assess_all(self, *, t: float | None = None) -> dict[str, Assessment]:
        """Assessments of every vehicle in the table (control-room use)."""
        self._expire(t)
        return {vid: self.assess(vid, t=t) for vid in self.table.vehicle_ids()}

    def assess(self, own_id: str | None = None, *, t: float | None = None) -> Assessment:
        """Assess the threats to one vehicle.

        Parameters
        ----------
        own_id : str, optional
            The vehicle to assess; defaults to the analyser's ``own_id``.
        t : float, optional
            Assessment time, s; vehicles silent for longer than the expiry are dropped
            first. Defaults to the newest report time.

        Returns
        -------
        Assessment

        Raises
        ------
        UnknownVehicleError
            No current report of ``own_id``.
        """
        vid = own_id if own_id is not None else self.own_id
        if vid is None:
            raise UnknownVehicleError("assess() needs an own_id (none was configured)")
        self._expire(t)
        own = self.table.get(vid)
        if own is None:
            raise UnknownVehicleError(f"no current report of vehicle {vid!r}")
        now = self.table.clock if t is None else float(t)
        others = [r for r in self.table.others(vid) if now - r.t <= self.expiry_s]
        hits = self._sector_hits(own, others)
        if self.track_map is None:
            plain = [self._sector_threat(own, self.table.get(h.vehicle_id), h) for h in hits]
            return self._assessment(vid, now, plain, [], "sector")
        self._refresh(now)
        own_view = self._views[vid]
        hit_by_id = {h.vehicle_id: h for h in hits}
        threats: list[Threat] = []
        suppressed: list[Suppressed] = []
        if not own_view.matched:
            for h in hits:
                other = self.table.get(h.vehicle_id)
                assert other is not None
                threats.append(self._sector_threat(own, other, h, note="own vehicle not matched"))
            return self._assessment(vid, now, threats, [], "sector")
        for ovid in self._track_candidates(vid, own_view) | set(hit_by_id):
            ov = self._views.get(ovid)
            if ov is None or now - ov.report.t > self.expiry_s:
                continue
            hit = hit_by_id.get(ovid)
            if not ov.matched:
                if hit is not None:
                    state = ov.position.status if ov.position is not None else "unmatched"
                    threats.append(
                        self._sector_threat(own, ov.report, hit, note=f"other vehicle {state}")
                    )
                continue
            threat, reason = self._track_threat(own_view, ov)
            if threat is not None:
                threats.append(threat)
            elif hit is not None:
                suppressed.append(
                    Suppressed(ovid, reason or "not_reachable", hit.distance_m, hit.bearing_deg)
                )
        return self._assessment(vid, now, threats, suppressed, "track")

    def zones(self, own_id: str | None = None, *, t: float | None = None) -> list[Zone]:
        """The zones of the own sensitivity area with their corridor polygons (local frame).

        Empty without a map or when the vehicle is not matched.
        """
        vid = own_id if own_id is not None else self.own_id
        if vid is None or self.track_map is None or vid not in self.table:
            return []
        self._refresh(self.table.clock if t is None else float(t))
        view = self._views[vid]
        if not view.matched:
            return []
        out = []
        for h in view.hyps:
            for p in h.paths:
                line = self.track_map.path_geometry(p)
                out.append(
                    Zone(
                        label=p.zone,
                        role=self._zone_role(view.report, p),
                        path=p,
                        corridor=line.buffer(self.config.corridor_half_width_m, cap_style="flat"),
                        probability=h.probability,
                    )
                )
        return out

    # -- building blocks -----------------------------------------------------------------
    def _expire(self, t: float | None) -> None:
        for gone in self.table.expire(t):
            self._forget(gone)

    def _profile(self, vid: str) -> BrakingProfile:
        return self.profiles.get(vid, self.profile)

    def _sector_hits(self, own: VehicleReport, others: list[VehicleReport]) -> list[SectorHit]:
        course = self.courses.course(own.vehicle_id)
        if course is None or not others:
            return []
        return self.sector.evaluate(own, others, course_deg=course)

    def _sector_threat(
        self, own: VehicleReport, other: VehicleReport | None, hit: SectorHit, note: str = ""
    ) -> Threat:
        assert other is not None
        course = self.courses.course(own.vehicle_id)
        bearing = math.radians(hit.bearing_deg)
        closing = float(
            closing_speed_mps(
                hit.distance_m * math.sin(bearing),
                hit.distance_m * math.cos(bearing),
                own.speed_mps,
                own.course_deg if course is None else course,
                other.speed_mps,
                other.course_deg,
            )
        )
        detail = (
            f"within {self.sector.d_col_m:g} m and ±{self.sector.half_angle_deg:g}° of own course"
        )
        return Threat(
            vehicle_id=hit.vehicle_id,
            kind="sector",
            level="warning",
            distance_m=hit.distance_m,
            closing_speed_mps=closing,
            ttc_s=braking.time_to_collision(hit.distance_m, closing),
            method="sector",
            bearing_deg=hit.bearing_deg,
            detail=f"{detail} ({note})" if note else detail,
        )

    @staticmethod
    def _assessment(
        vid: str, now: float, threats: list[Threat], suppressed: list[Suppressed], method: str
    ) -> Assessment:
        ordered = sort_threats(threats)
        return Assessment(
            own_id=vid,
            t=now,
            level=highest_level(ordered),
            threats=ordered,
            suppressed=tuple(sorted(suppressed, key=lambda s: s.distance_m)),
            method=method,  # type: ignore[arg-type]
        )

    # -- per-cycle views -----------------------------------------------------------------
    def _refresh(self, now: float) -> None:
        if self._views_time == now and self._index_version == self._version:
            return
        assert self.positioner is not None and self.track_map is not None
        views: dict[str, _View] = {}
        edge_index: dict[int, list[tuple[str, int]]] = defaultdict(list)
        conflict_index: dict[int, list[tuple[str, int, Path, float, int, int]]] = defaultdict(list)
        reports = list(self.table)
        positions = [self.positioner.position(r.vehicle_id, now) for r in reports]
        speeds = [
            pos.speed_mps if pos is not None and pos.matched else r.speed_mps
            for r, pos in zip(reports, positions, strict=True)
        ]
        horizons = self._horizons(reports, speeds)
        for report, pos, speed, horizon in zip(reports, positions, speeds, horizons, strict=True):
            vid = report.vehicle_id
            view = _View(report, pos, speed, horizon)
            if pos is not None and pos.matched:
                view.hyps = self._hypotheses(pos, horizon)
                for k, h in enumerate(view.hyps):
                    edge_index[h.edge_id].append((vid, k))
                    for p in h.paths:
                        for cp in p.conflicts:
                            node = next(
                                (n for n in p.nodes if abs(n.distance_m - cp.distance_m) < 1e-6),
                                None,
                            )
                            frm = node.from_edge if node is not None else cp.edge_id
                            to = node.to_edge if node is not None else cp.edge_id
                            conflict_index[cp.conflict_id].append(
                                (vid, k, p, cp.distance_m, frm, to)
                            )
            views[vid] = view
        self._views = views
        self._edge_index = dict(edge_index)
        self._conflict_index = dict(conflict_index)
        self._views_time = now
        self._index_version = self._version

    def _horizons(self, reports: list[VehicleReport], speeds: list[float]) -> list[float]:
        """Look-ahead of every vehicle, vectorised per braking profile, m."""
        out = [0.0] * len(reports)
        groups: dict[int, list[int]] = defaultdict(list)
        for k, r in enumerate(reports):
            groups[id(self._profile(r.vehicle_id))].append(k)
        for members in groups.values():
            prof = self._profile(reports[members[0]].vehicle_id)
            hs = braking.horizon_m(
                np.array([speeds[k] for k in members]), prof, minimum_m=self.config.min_horizon_m
            )
            for k, h in zip(members, np.atleast_1d(hs), strict=True):
                out[k] = float(h)
        return out

    def _hypotheses(self, pos: TrackPosition, horizon: float) -> list[_Hyp]:
        assert self.track_map is not None and pos.edge_id is not None
        assert pos.direction is not None and pos.offset_m is not None
        c = self.config
        chosen = [h for h in pos.hypotheses if h.probability >= c.min_hypothesis_probability]
        chosen = chosen[: c.max_hypotheses] or list(pos.hypotheses[:1])
        total = sum(h.probability for h in chosen) or 1.0
        out = []
        for k, h in enumerate(chosen):
            if k == 0:  # the filtered (possibly dead-reckoned) estimate of the best one
                edge, off, d = pos.edge_id, pos.offset_m, pos.direction
            else:
                edge, off, d = h.edge_id, h.offset_m, h.direction
            paths = self.track_map.paths_ahead(
                edge, off, d, horizon, respect_direction=not h.wrong_way
            )
            out.append(_Hyp(edge, d, off, h.probability / total, h.wrong_way, paths))
        return out

    def _track_candidates(self, vid: str, view: _View) -> set[str]:
        found: set[str] = set()
        for h in view.hyps:
            for p in h.paths:
                for s in p.steps:
                    for ovid, _ in self._edge_index.get(s.edge_id, ()):
                        found.add(ovid)
                for cp in p.conflicts:
                    for entry in self._conflict_index.get(cp.conflict_id, ()):
                        found.add(entry[0])
        found.discard(vid)
        return found

    # -- pairwise track analysis ---------------------------------------------------------
    def _track_threat(self, own: _View, other: _View) -> tuple[Threat | None, str | None]:
        c = self.config
        p_conflict = 0.0
        worst: _Candidate | None = None
        overlap_missed = False
        for h in own.hyps:
            for g in other.hyps:
                cand, missed = self._pair_conflict(own, h, other, g)
                overlap_missed = overlap_missed or missed
                if cand is None:
                    continue
                p_conflict += h.probability * g.probability
                if worst is None or (level_rank(cand.level), -cand.gap_m) > (
                    level_rank(worst.level),
                    -worst.gap_m,
                ):
                    worst = cand
        if worst is None:
            return None, self._suppression_reason(own, other, overlap_missed)
        if p_conflict < c.conflict_probability:
            return None, "below_probability"
        assert own.position is not None and other.position is not None
        ambiguous = (
            p_conflict < 0.999
            or own.position.status == "ambiguous"
            or other.position.status == "ambiguous"
        )
        detail = worst.detail
        if ambiguous:
            detail += f" (conflict probability {p_conflict:.2f})"
        return (
            Threat(
                vehicle_id=other.report.vehicle_id,
                kind=worst.kind,  # type: ignore[arg-type]
                level=worst.level,
                distance_m=worst.gap_m,
                closing_speed_mps=worst.closing_mps,
                ttc_s=worst.ttc_s,
                method="track",
                zone=worst.zone,
                probability=min(p_conflict, 1.0),
                own_match_probability=own.position.probability,
                other_match_probability=other.position.probability,
                ambiguous=ambiguous,
                detail=detail,
            ),
            None,
        )

    def _pair_conflict(
        self, own: _View, h: _Hyp, other: _View, g: _Hyp
    ) -> tuple[_Candidate | None, bool]:
        """The most severe conflict of one pair of hypotheses (and whether a shared
        merge/crossing was dismissed because the arrival windows do not overlap)."""
        best: _Candidate | None = None
        missed = False
        ov_id = other.report.vehicle_id
        for p in h.paths:
            located = p.locate_step(g.edge_id, g.offset_m)
            if located is None:
                continue
            d, step = located
            best = _more_severe(
                best, self._on_path(own, other, p, d, step.direction == g.direction)
            )
        if best is not None:
            return best, False
        # merges and crossings: conflict points both vehicles' zones pass
        for p in h.paths:
            for cp in p.conflicts:
                for vid, k, op, od, ofrom, oto in self._conflict_index.get(cp.conflict_id, ()):
                    if vid != ov_id or other.hyps[k] is not g:
                        continue
                    found, no_overlap = self._at_conflict(own, p, cp, other, op, od, ofrom, oto)
                    missed = missed or no_overlap
                    best = _more_severe(best, found)
        return best, missed

    def _on_path(
        self, own: _View, other: _View, path: Path, d: float, same_way: bool
    ) -> _Candidate:
        own_front = own.report.antenna_offset_m or 0.0
        o = other.report
        if same_way:
            extent = (
                (o.length_m - o.antenna_offset_m)
                if (o.length_m is not None and o.antenna_offset_m is not None)
                else 0.0
            )
            kind = "rear_end"
            closing = own.speed_mps - other.speed_mps
        else:
            extent = o.antenna_offset_m or 0.0
            kind = "head_on"
            closing = own.speed_mps + other.speed_mps
        gap = d - own_front - extent
        level = braking.classify(
            gap - self._uncertainty(own, other),
            own.speed_mps,
            self._profile(own.report.vehicle_id),
            kind=kind,  # type: ignore[arg-type]
            v_other_mps=other.speed_mps,
            other_profile=self._profile(o.vehicle_id),
            leader_braking=o.braking if same_way else "none",
            horizon_m=own.horizon_m,
        )
        level = self._cap(level, own, closing, path)
        what = "ahead on the same track" if same_way else "ahead, running towards us"
        return _Candidate(
            kind,
            level,
            gap,
            closing,
            braking.time_to_collision(gap, closing),
            path.zone,
            f"{o.vehicle_id} {what} at {gap:.0f} m (zone {path.zone})",
        )

    def _at_conflict(
        self,
        own: _View,
        path: Path,
        cp: Any,
        other: _View,
        opath: Path,
        od: float,
        ofrom: int,
        oto: int,
    ) -> tuple[_Candidate | None, bool]:
        assert self.track_map is not None
        conflict = self.track_map.conflicts[cp.conflict_id]
        node = next((n for n in path.nodes if abs(n.distance_m - cp.distance_m) < 1e-6), None)
        frm = node.from_edge if node is not None else cp.edge_id
        to = node.to_edge if node is not None else cp.edge_id
        if conflict.kind == "merge":
            branches = conflict.edges[1:]
            own_branch = {frm, to} & set(branches)
            other_branch = {ofrom, oto} & set(branches)
            if not own_branch or not other_branch or own_branch == other_branch:
                return None, False  # same branch: a rear-end or head-on case, not a merge
            extent = dict(zip(conflict.edges, conflict.extents_m, strict=True))
            own_in = cp.distance_m - (extent[frm] if frm in branches else 0.0)
            own_out = cp.distance_m + (extent[to] if to in branches else 0.0)
            oth_in = od - (extent[ofrom] if ofrom in branches else 0.0)
            oth_out = od + (extent[oto] if oto in branches else 0.0)
            kind = "merge"
        else:
            own_edges, oth_edges = {frm, to}, {ofrom, oto}
            if own_edges & oth_edges:
                return None, False  # the same line through the crossing
            half = max(conflict.extents_m)
            own_in, own_out = cp.distance_m - half, cp.distance_m + half
            oth_in, oth_out = od - half, od + half
            kind = "crossing"
        own_len = own.report.length_m or 0.0
        oth_len = other.report.length_m or 0.0
        own_window = self._window(own, own_in, own_out + own_len)
        oth_window = self._window(other, oth_in, oth_out + oth_len)
        if own_window is None or oth_window is None:
            return None, True
        slack = self.config.window_slack_s
        if own_window[0] > oth_window[1] + slack or oth_window[0] > own_window[1] + slack:
            return None, True
        gap = max(own_in, 0.0)
        level = braking.classify(
            gap - self._uncertainty(own, other),
            own.speed_mps,
            self._profile(own.report.vehicle_id),
            kind="static",
            horizon_m=own.horizon_m,
        )
        # a standing vehicle at a merge or crossing is the obstacle, not the one to act
        closing = own.speed_mps if own.speed_mps >= self.config.stopped_speed_mps else 0.0
        level = self._cap(level, own, closing, path)
        where = "switch" if kind == "merge" else "crossing"
        return (
            _Candidate(
                kind,
                level,
                gap,
                closing,
                own_window[0] if own.speed_mps > self.config.stopped_speed_mps else None,
                path.zone,
                f"{other.report.vehicle_id} reaches the same {where} "
                f"(we are {gap:.0f} m away, zone {path.zone})",
            ),
            False,
        )

    def _uncertainty(self, own: _View, other: _View) -> float:
        """Margin for position uncertainty: k x sqrt(sigma_own^2 + sigma_other^2), m."""
        s1 = own.position.sigma_m if own.position and own.position.sigma_m else 0.0
        s2 = other.position.sigma_m if other.position and other.position.sigma_m else 0.0
        return self.config.gap_margin_sigmas * math.hypot(s1, s2)

    def _window(self, view: _View, d_in: float, d_out: float) -> tuple[float, float] | None:
        """Time interval a vehicle occupies a zone from d_in to d_out ahead, s (None if it
        will not get there at its current speed)."""
        v = view.speed_mps
        if d_in <= 0.0:
            return (0.0, d_out / v if v > self.config.stopped_speed_mps else math.inf)
        if v <= self.config.stopped_speed_mps:
            return None
        return (d_in / v, d_out / v)

    def _cap(self, level: Level, own: _View, closing: float, path: Path) -> Level:
        """Standing and not (or barely) closing: at most advisory; off the planned route:
        advisory."""
        if (
            own.speed_mps < self.config.stopped_speed_mps
            and closing <= self.config.stopped_speed_mps
        ):
            level = "advisory" if level_rank(level) > level_rank("advisory") else level
        if self._zone_role(own.report, path) == "advisory":
            level = "advisory" if level_rank(level) > level_rank("advisory") else level
        return level

    @staticmethod
    def _zone_role(report: VehicleReport, path: Path) -> Literal["warning", "advisory"]:
        if not report.route:
            return "warning"
        route = set(report.route)
        # the zone is on the route when every edge it takes after the first is routed
        return "warning" if all(e in route for e in path.edges[1:]) else "advisory"

    def _suppression_reason(self, own: _View, other: _View, overlap_missed: bool) -> str:
        assert self.track_map is not None
        c_parallel = self.config.parallel_distance_m
        if overlap_missed:
            return "no_overlap"
        own_edges = {s.edge_id for h in own.hyps for p in h.paths for s in p.steps}
        oth_edges = {h.edge_id for h in other.hyps}
        for a, b, _, _ in self.track_map.grade_separated:
            if (a in own_edges and b in oth_edges) or (b in own_edges and a in oth_edges):
                return "grade_separated"
        pos = other.position
        if pos is not None and pos.edge_id is not None and pos.offset_m is not None:
            pt = shapely.Point(self.track_map.point_at(pos.edge_id, pos.offset_m))
            geoms = [self.track_map.edges[e].geometry for e in own_edges]
            if geoms and float(np.min(shapely.distance(pt, geoms))) <= c_parallel:
                return "parallel_track"
        return "not_reachable"


def _more_severe(a: _Candidate | None, b: _Candidate | None) -> _Candidate | None:
    if a is None:
        return b
    if b is None:
        return a
    return b if (level_rank(b.level), -b.gap_m) > (level_rank(a.level), -a.gap_m) else a


__all__ = ["Analyser", "AnalyserConfig", "Zone"]
