"""The analyser: one object that takes reports and answers "what threatens vehicle X?".

Without a map the analyser runs the 2008 paper's sector rule for every pair: every threat
has ``method='sector'`` and level ``warning`` (the paper's lamp), exactly as published.

With a map (``Analyser(track_map=net)``) it implements the paper's next generation:

1. every vehicle is positioned on the tracks (:mod:`antikol.positioning`);
2. the own sensitivity area follows the track ahead up to a horizon from the braking model
   (never shorter than the paper's 300 m unless configured) and splits into one **zone**
   per branch at facing switches; with a planned route the vehicle takes one zone, without
   one every option of a facing switch is equally likely;
3. conflicts with every other matched vehicle are found along those zones by the rules of
   :mod:`antikol.analysis.conflicts` — ``rear_end``, ``head_on``, ``merge``, ``crossing`` —
   between vehicle **ends**, placed by :mod:`antikol.analysis.ends` when a report lacks them;
4. every combination of the two vehicles' match hypotheses and of the own zones is weighed
   by its probability; a ``warning`` needs the probability of a warning-level conflict to
   reach ``warning_probability``, otherwise the conflict is ``advisory``; a hypothesis of
   wrong-way running counts for more than an advisory only on sustained evidence;
5. each pair's alarm has hysteresis (:mod:`antikol.analysis.alarms`): raised at the warning
   distance, held while the gap still closes, released when the conflict is clearly over;
6. a vehicle the sector rule would flag but that has no conflict on the map is listed in
   ``Assessment.suppressed`` with the reason (e.g. ``parallel_track``);
7. a pair where either vehicle is unmatched or lost falls back to the sector rule
   (``method='sector'``). Nothing is dropped silently, and nothing a vehicle reports makes
   the analyser raise: a report that cannot be positioned is counted in :attr:`stats`.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import replace
from typing import Literal

from antikol.analysis.alarms import AlarmBook
from antikol.analysis.assessment import Assessment, Suppressed, Threat, Zone, assessment_of
from antikol.analysis.config import AnalyserConfig
from antikol.analysis.conflicts import RuleSettings
from antikol.analysis.coursekeeper import CourseKeeper
from antikol.analysis.fleetsector import FleetSector, fleet_sector, sector_assessments
from antikol.analysis.pairs import PairEvaluator, PairOutcome, PairSettings
from antikol.analysis.profiles import BrakingProfile, load_profile
from antikol.analysis.sector import SectorHit, SectorRule, hit_closing_speed
from antikol.analysis.threats import sector_threat, suppression_reason, track_threat
from antikol.analysis.views import CycleViews, ViewSettings, build_views
from antikol.errors import InvalidArgumentError, UnknownVehicleError
from antikol.gcpause import gc_paused
from antikol.ingest.guard import ReplayGuard
from antikol.ingest.nmea import NmeaReader
from antikol.ingest.protocol import DecoderStats, FrameVerifier, StreamDecoder
from antikol.numeric import finite_float
from antikol.positioning.config import PositioningConfig
from antikol.positioning.inputs import checked_report, checked_reports
from antikol.positioning.matcher import Positioner
from antikol.positioning.outputs import asked_time
from antikol.positioning.records import (
    DiscreteFix,
    FixPoint,
    PositionSource,
    TrackPosition,
    positions_of,
)
from antikol.positioning.reported import ReportedFirst
from antikol.report import VehicleReport
from antikol.table import CLOCK_WINDOW_S, TableUpdate, VehicleTable
from antikol.thresholds import EXPIRY_S, TABLE_CAPACITY
from trackmap import TrackMap

__all__ = ["Analyser", "AnalyserConfig", "PositionSource", "Zone"]

logger = logging.getLogger(__name__)

_ALARM_LEVELS = ("warning", "emergency")


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
    verifier : FrameVerifier, optional
        Keys of the fleet: :meth:`feed_bytes` then accepts only authenticated frames
        (:mod:`antikol.ingest.auth`); None accepts the paper's unsigned frames.
    replay_guard : ReplayGuard, optional
        Sequence and time windows for :meth:`feed_bytes` (:mod:`antikol.ingest.guard`).
    clock_window_s, max_new_ids, time_source
        Passed to the :class:`~antikol.table.VehicleTable` (its clock and its cap on new
        vehicle ids; ``max_new_ids="auto"`` caps a control room only).
    position_source : PositionSource, optional
        Track positions computed elsewhere (needs ``track_map``): the analyser then feeds
        it the accepted reports and asks it for positions instead of positioning itself
        (:attr:`positioner` is None).
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
        verifier: FrameVerifier | None = None,
        replay_guard: ReplayGuard | None = None,
        clock_window_s: float | None = CLOCK_WINDOW_S,
        max_new_ids: int | Literal["auto"] | None = "auto",
        time_source: Callable[[], float] | None = None,
        position_source: PositionSource | None = None,
    ) -> None:
        if track_map is not None and not isinstance(track_map, TrackMap):
            raise InvalidArgumentError(
                "track_map", track_map, "must be a trackmap.TrackMap or None"
            )
        if own_id is not None:
            _check_vehicle_id(own_id, "own_id")
        expiry = finite_float(expiry_s)
        if expiry is None or expiry <= 0.0:
            raise InvalidArgumentError("expiry_s", expiry_s, "must be a positive number of seconds")
        self.track_map = track_map
        self.sector = sector if sector is not None else SectorRule()
        self.own_id = own_id
        if capacity == "auto":
            table_capacity: int | None = TABLE_CAPACITY if own_id is not None else None
        else:
            table_capacity = capacity
        self.expiry_s = float(expiry_s)
        # Control-room use emulates every vehicle's own unit: a vehicle that falls silent (GPS
        # lost in a tunnel) keeps being assessed on its dead-reckoned position, while the
        # others stop seeing it after expiry_s, as in the paper.
        retain = self.expiry_s
        if own_id is None and track_map is not None:
            retain = max(retain, (positioning or PositioningConfig()).dead_reckoning_s)
        self.table = VehicleTable(
            capacity=table_capacity,
            expiry_s=retain,
            own_id=own_id,
            clock_window_s=clock_window_s,
            max_new_ids=max_new_ids,
            time_source=time_source,
        )
        self.verifier = verifier
        self.replay_guard = replay_guard
        self.courses = CourseKeeper(
            min_speed_mps=self.sector.min_speed_for_course_mps,
            config=positioning or PositioningConfig(),
        )
        self.profile = profile if profile is not None else load_profile("tram")
        self.profiles = dict(profiles or {})
        self.config = config or AnalyserConfig()
        if position_source is not None and track_map is None:
            raise InvalidArgumentError(
                "position_source", position_source, "track positions need a track_map"
            )
        self.positioner = (
            Positioner(track_map, positioning, fix_points=fix_points)
            if track_map is not None and position_source is None
            else None
        )
        c = self.config
        #: Reported track positions in use (None without a map, with a ``position_source``
        #: or when :attr:`AnalyserConfig.reported_positions` is None): ``.used`` and
        #: ``.rejected`` count them.
        self.reported: ReportedFirst | None = None
        if track_map is not None and self.positioner is not None and c.reported_positions:
            self.reported = ReportedFirst(
                track_map,
                self.positioner,
                exclude=() if own_id is None else (own_id,),
                settings=c.reported_positions,
            )
        self._source: PositionSource | None = (
            position_source
            if position_source is not None
            else self.reported
            if self.reported is not None
            else self.positioner
        )
        self._view_settings = ViewSettings(
            c.min_horizon_m,
            c.max_hypotheses,
            c.min_hypothesis_probability,
            c.wrong_way_evidence_s,
            c.stopped_speed_mps,
            c.branches,
        )
        self._rules = RuleSettings(
            c.stopped_speed_mps,
            c.closing_speed_mps,
            c.gap_margin_sigmas,
            c.anticipation_s,
            c.merge_accel_mps2,
            c.merge_max_speed_mps,
            c.window_slack_s,
            c.rear_end_model,
        )
        self._pairs = (
            PairEvaluator(
                track_map,
                self._rules,
                PairSettings(
                    c.warning_probability,
                    c.emergency_probability,
                    c.closing_speed_mps,
                    c.alarms.release_margin_m,
                    c.alarms.release_time_s,
                ),
            )
            if track_map is not None
            else None
        )
        self._outcomes: dict[str, dict[str, PairOutcome]] = {}
        self._outcomes_of: tuple[CycleViews | None, set[str]] = (None, set())
        #: Alarm states of every pair (track method).
        self.alarms = AlarmBook(c.alarms)
        #: What went wrong with reports (counted, never raised).
        self.stats: Counter[str] = Counter()
        self._cycle: CycleViews | None = None
        self._cycle_version = -1
        self._version = 0
        self._decoder: StreamDecoder | None = None
        self._nmea: NmeaReader | None = None
        self._last_threats: dict[tuple[str, str], Threat] = {}
        self._moving: dict[str, bool] = {}
        self._pending: list[VehicleReport] = []
        self._fleet_sector = FleetSector(None, {}, {})
        self._sector_assessed: tuple[object, dict[str, Assessment]] = (None, {})

    # -- input ---------------------------------------------------------------------------
    def update(self, report: VehicleReport) -> TableUpdate:
        """Feed one report (own or other vehicle).

        Returns
        -------
        TableUpdate
            What the vehicle table did with it.
        """
        checked_report(report)
        result = self._table_update(report)
        if self._source is not None and result.accepted:
            self._pending.append(report)
        return result

    def update_many(self, reports: Sequence[VehicleReport]) -> list[TableUpdate]:
        """Feed many reports at once (one analysis cycle of a fleet).

        Positioning runs lazily: the reports accepted by the table are matched to the map
        together, in one vectorised update, when a position or an assessment is next asked
        for. One report the positioning cannot use never stops the others: it is counted
        in :attr:`stats` and the vehicle keeps its previous state."""
        reports = checked_reports(reports)  # (a list: a generator is read twice)
        results = [self._table_update(r) for r in reports]
        if self._source is not None:
            self._pending.extend(r for r, res in zip(reports, results, strict=True) if res.accepted)
        return results

    def _flush(self) -> None:
        """Position the reports received since the last query."""
        source = self._source
        if not self._pending or source is None:
            return
        pending, self._pending = self._pending, []
        try:
            source.update_many(pending, outputs=False)
        except Exception:  # one at a time, to find and count the culprit
            for r in pending:
                try:
                    source.update_many([r], outputs=False)
                except Exception:
                    self.stats["positioning_error"] += 1
                    logger.exception("positioning failed on a report of %s", r.vehicle_id)

    def feed_bytes(self, chunk: bytes, *, now: float | None = None) -> list[TableUpdate]:
        """Feed raw radio bytes (any chunking); decoded reports update the analyser.

        Frames are checked by the ``verifier`` and the ``replay_guard`` when configured.
        Rejected frames are counted in :attr:`decoder_stats` (decoding, authentication) and
        in the guard's ``stats`` (replays, times out of window); this never raises.

        Parameters
        ----------
        chunk : bytes
        now : float, optional
            The receiver's clock in report time, s, for the replay guard's time window
            (default: the vehicle table's clock, or none before it has one).
        """
        if self._decoder is None:
            self._decoder = StreamDecoder(verifier=self.verifier)
        try:
            reports = self._decoder.feed(chunk)
            if self.replay_guard is not None:
                clock = self.table.clock if now is None else float(now)
                at = clock if math.isfinite(clock) else None
                reports = [r for r in reports if self.replay_guard.check(r, at) is None]
            return self.update_many(reports)
        except Exception:
            self.stats["feed_error"] += 1
            logger.exception("radio input could not be processed")
            return []

    @property
    def decoder_stats(self) -> DecoderStats | None:
        """Statistics of the radio stream decoder (None before :meth:`feed_bytes`)."""
        return None if self._decoder is None else self._decoder.stats

    def feed_nmea(self, line: str | bytes) -> list[TableUpdate]:
        """Feed one NMEA 0183 line of the own receiver (needs ``own_id``)."""
        if self.own_id is None:
            raise InvalidArgumentError("own_id", None, "feed_nmea() needs the analyser's own_id")
        if self._nmea is None:
            self._nmea = NmeaReader(self.own_id)
        return self.update_many(self._nmea.feed_line(line))

    def fix(self, vehicle_id: str, fix: DiscreteFix) -> TrackPosition | None:
        """Apply a discrete position fix (balise, loop crossing) to a vehicle; returns its
        position as :meth:`position` gives it (a vehicle placed by its own reported track
        position keeps it: the fix corrects the matcher's state behind it)."""
        if self.positioner is None:
            raise InvalidArgumentError("track_map", None, "discrete fixes need a track map")
        self._version += 1
        self._flush()
        matched = self.positioner.fix(vehicle_id, fix)
        if matched is None or self.reported is None:
            return matched
        return self.position(vehicle_id, fix.t)

    def _table_update(self, report: VehicleReport) -> TableUpdate:
        result = self.table.update(report)
        for vid in result.expired:
            self._forget(vid)
        if result.evicted is not None:
            self._forget(result.evicted)
        if result.accepted:
            self.courses.add(report)
            was = self._moving.get(report.vehicle_id, False)
            limit = self.config.stopped_speed_mps if was else self.config.start_speed_mps
            self._moving[report.vehicle_id] = report.speed_mps >= limit
            self._version += 1
        return result

    def _forget(self, vehicle_id: str) -> None:
        if any(r.vehicle_id == vehicle_id for r in self._pending):
            self._pending = [r for r in self._pending if r.vehicle_id != vehicle_id]
        self.courses.forget(vehicle_id)
        self._moving.pop(vehicle_id, None)
        if self._source is not None:
            self._source.forget(vehicle_id)
        self.alarms.forget(vehicle_id)
        for key in [k for k in self._last_threats if vehicle_id in k]:
            del self._last_threats[key]
        self._version += 1

    # -- output --------------------------------------------------------------------------
    def position(
        self, vehicle_id: str, t: float | None = None, *, as_placed: bool = False
    ) -> TrackPosition | None:
        """Track position of a vehicle (None without a map or for an unknown vehicle).

        Parameters
        ----------
        vehicle_id : str
        t : float, optional
            Time, s (default: the newest report time); later than the vehicle's last
            report means dead reckoning.
        as_placed : bool, keyword-only
            The position the analysis weighs: a vehicle not yet shown on a track
            (:attr:`TrackPosition.unplaced`) where its hypotheses place it.
        """
        _check_vehicle_id(vehicle_id, "vehicle_id")
        when = self._now(t)
        if self._source is None or vehicle_id not in self.table:
            return None
        self._flush()
        if as_placed:
            return positions_of(self._source, [vehicle_id], when, as_placed=True)[0]
        return self._source.position(vehicle_id, when)

    def memory(self, vehicle_id: str) -> tuple[float | None, bool | None]:
        """What the analyser remembers of one vehicle beyond its newest report: the course
        kept from before it stopped (deg) and whether it counts as moving (hysteresis)."""
        return self.courses.course(vehicle_id), self._moving.get(vehicle_id)

    def restore_memory(
        self, vehicle_id: str, course_deg: float | None, moving: bool | None
    ) -> None:
        """Set a vehicle's :meth:`memory` before its first report (fleet-scale replay starts
        a time window with the memory its positioning stage recorded)."""
        self.courses.forget(vehicle_id)
        if course_deg is not None:
            self.courses.keep(vehicle_id, course_deg)
        self._moving.pop(vehicle_id, None)
        if moving is not None:
            self._moving[vehicle_id] = moving

    def expire(self, t: float) -> list[str]:
        """Drop the vehicles silent past the table's retention at time ``t``, s, as
        :meth:`assess_all` does first; returns their ids (fleet-scale positioning)."""
        asked = asked_time(t)
        if asked is None:
            raise InvalidArgumentError("t", t, "must be a finite time, s")
        return self._expire(asked)

    @gc_paused
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
        if vid is not None:
            _check_vehicle_id(vid, "own_id")
        if vid is None:
            raise UnknownVehicleError("assess() needs an own_id (none was configured)")
        if self.track_map is None and self.own_id is None:
            # a control room without a map: every vehicle's assessment of the time is
            # built at its first question, the others are look-ups
            self._expire(t)
            now = self._now(t)
            key = (now, self._version)
            if self._sector_assessed[0] != key:
                self._sector_assessed = (key, self._assess_sector_fleet(now))
            found = self._sector_assessed[1].get(vid)
            if found is None:
                raise UnknownVehicleError(f"no current report of vehicle {vid!r}")
            return found
        return self._assess(vid, t)

    @gc_paused
    def _assess_sector_fleet(self, now: float) -> dict[str, Assessment]:
        return sector_assessments(self.sector, self._fleet_hits(now), self.table.vehicle_ids(), now)

    @gc_paused
    def _assess(self, vid: str, t: float | None) -> Assessment:
        self._expire(t)
        own = self.table.get(vid)
        if own is None:
            raise UnknownVehicleError(f"no current report of vehicle {vid!r}")
        now = self._now(t)
        hits = self._sector_hits(own, now)
        if self.track_map is None:
            plain = [self._sector_threat(own, self._report(h.vehicle_id), h) for h in hits]
            return assessment_of(vid, now, plain, [], "sector")
        cycle = self._refresh(now)
        own_view = cycle.expand(vid)
        threats: list[Threat] = []
        suppressed: list[Suppressed] = []
        seen: set[str] = set()
        if not own_view.matched:
            for h in hits:
                th = self._sector_threat(
                    own, self._report(h.vehicle_id), h, note="own vehicle not matched"
                )
                threats.append(self._alarm(vid, h.vehicle_id, now, th, raise_now=True, hold=False))
                seen.add(h.vehicle_id)
            threats.extend(self._released(vid, now, seen))
            return assessment_of(vid, now, threats, [], "sector")
        hit_by_id = {h.vehicle_id: h for h in hits}
        outcomes = self._pair_outcomes(cycle, vid)
        for ovid in sorted(outcomes.keys() | hit_by_id.keys()):
            ov = cycle.views.get(ovid)
            if ov is None or now - ov.report.t > self.expiry_s:
                continue
            hit = hit_by_id.get(ovid)
            if hit is not None:
                ov = cycle.expand(ovid)  # its paths tell why a sector hit is suppressed
            if not ov.matched:
                if hit is not None:
                    state = ov.position.status if ov.position is not None else "unmatched"
                    th = self._sector_threat(own, ov.report, hit, note=f"other vehicle {state}")
                    threats.append(self._alarm(vid, ovid, now, th, raise_now=True, hold=False))
                    seen.add(ovid)
                continue
            result = outcomes.get(ovid)
            if result is None:
                if hit is not None:
                    reason = suppression_reason(
                        self.track_map, cycle, own_view, ov, self.config.parallel_distance_m
                    )
                    suppressed.append(Suppressed(ovid, reason, hit.distance_m, hit.bearing_deg))
                continue
            raise_now = result.level in _ALARM_LEVELS
            if result.level == "none" and not self._alarm_on(vid, ovid, now, result.hold):
                continue  # nothing to show and no alarm to hold
            th = track_threat(own_view, ov, result)
            threats.append(self._alarm(vid, ovid, now, th, raise_now=raise_now, hold=result.hold))
            seen.add(ovid)
        threats.extend(self._released(vid, now, seen))
        shown = [th for th in threats if th.level != "none"]
        return assessment_of(vid, now, shown, suppressed, "track")

    def zones(self, own_id: str | None = None, *, t: float | None = None) -> list[Zone]:
        """The zones of the own sensitivity area with their corridor polygons (local frame).

        Empty without a map or when the vehicle is not matched.
        """
        vid = own_id if own_id is not None else self.own_id
        if vid is not None:
            _check_vehicle_id(vid, "own_id")
        asked_time(t)  # (checked before anything moves)
        if vid is None or self.track_map is None or vid not in self.table:
            return []
        view = self._refresh(self._now(t)).expand(vid)
        if not view.matched:
            return []
        out = []
        for h in view.hyps:
            for p, pi in zip(h.paths, h.path_probability, strict=True):
                line = self.track_map.path_geometry(p)
                out.append(
                    Zone(
                        label=p.zone,
                        role="warning" if pi > 0.0 else "advisory",
                        path=p,
                        corridor=line.buffer(self.config.corridor_half_width_m, cap_style="flat"),
                        probability=h.probability * pi,
                    )
                )
        return out

    # -- alarms and threats --------------------------------------------------------------
    def _alarm(
        self, own: str, other: str, t: float, threat: Threat, *, raise_now: bool, hold: bool
    ) -> Threat:
        """Pass a threat through its pair's hysteresis; a held alarm shows as a warning."""
        if not self.config.hysteresis or self.track_map is None:
            return threat
        on = self.alarms.step(own, other, t, raise_now=raise_now, hold=hold)
        if on and threat.level not in _ALARM_LEVELS:
            threat = replace(threat, level="warning", held=True, detail=threat.detail + " (held)")
        self._last_threats[(own, other)] = threat
        return threat

    def _alarm_on(self, own: str, other: str, t: float, hold: bool) -> bool:
        """Step a pair without an alarm-level conflict; whether its alarm stays on."""
        if not self.config.hysteresis:
            return False
        return self.alarms.step(own, other, t, raise_now=False, hold=hold)

    def _released(self, own: str, t: float, seen: set[str]) -> list[Threat]:
        """Alarms of pairs not evaluated this time: released once their minimum time is up,
        shown (held) until then."""
        if not self.config.hysteresis or self.track_map is None:
            return []
        out = []
        for other in self.alarms.active(own):
            if other in seen:
                continue
            if self.alarms.step(own, other, t, raise_now=False, hold=False):
                last = self._last_threats.get((own, other))
                if last is not None:
                    out.append(replace(last, held=True))
        return out

    # -- building blocks -----------------------------------------------------------------
    def _now(self, t: float | None) -> float:
        """The time asked for, s: ``t``, else the table's clock; before the table has a
        clock (on board, until the own vehicle's first report) the newest report held."""
        asked = asked_time(t)  # (InvalidArgumentError unless a finite number)
        if asked is not None:
            return asked
        clock = self.table.clock
        if math.isfinite(clock):
            return clock
        return max((r.t for r in self.table), default=clock)

    def _expire(self, t: float | None) -> list[str]:
        t = asked_time(t)  # (InvalidArgumentError before the clock moves)
        dropped = self.table.expire(t)
        for gone in dropped:
            self._forget(gone)
        if t is not None:
            self.alarms.prune(float(t))
        return dropped

    def _report(self, vid: str) -> VehicleReport:
        report = self.table.get(vid)
        if report is None:  # pragma: no cover - hits come from the table
            raise UnknownVehicleError(f"no current report of vehicle {vid!r}")
        return report

    def _profile(self, vid: str) -> BrakingProfile:
        return self.profiles.get(vid, self.profile)

    def _sector_hits(self, own: VehicleReport, now: float) -> list[SectorHit]:
        """The sector rule's hits of a vehicle among the others heard within the expiry:
        on board from the own vehicle alone, in a control room for every vehicle of the
        time at once (:func:`~antikol.analysis.fleetsector.fleet_sector`)."""
        if self.own_id is None:
            return self._fleet_hits(now).hits.get(own.vehicle_id, [])
        course = self.courses.course(own.vehicle_id)
        others = [r for r in self.table.others(own.vehicle_id) if now - r.t <= self.expiry_s]
        if course is None or not others:
            return []
        return self.sector.evaluate(own, others, course_deg=course)

    def _sector_threat(
        self, own: VehicleReport, other: VehicleReport, hit: SectorHit, note: str = ""
    ) -> Threat:
        known = self._fleet_sector.closing.get((own.vehicle_id, hit.vehicle_id))
        if known is not None and known[0] is own and known[1] is other and known[2] is hit:
            closing = known[3]  # the cycle's hits, computed in one array call
        else:
            closing = hit_closing_speed(
                own, self.courses.course(own.vehicle_id), other, hit,
                other_course_deg=self.courses.reported_course(other),
            )  # fmt: skip
        return sector_threat(self.sector, hit, closing, note)

    def _fleet_hits(self, now: float) -> FleetSector:
        """Every vehicle's sector hits at time ``now``, computed at its first question."""
        key = (now, self._version)
        if self._fleet_sector.key != key:
            reports = list(self.table)
            courses = [self.courses.course(r.vehicle_id) for r in reports]
            self._fleet_sector = fleet_sector(
                self.sector, reports, courses, now=now, expiry_s=self.expiry_s, key=key,
                velocity_courses=[self.courses.reported_course(r) for r in reports],
            )  # fmt: skip
        return self._fleet_sector

    # -- per-cycle views -----------------------------------------------------------------
    def _refresh(self, now: float) -> CycleViews:
        cycle = self._cycle
        if cycle is not None and cycle.t == now and self._cycle_version == self._version:
            return cycle
        source = self._source
        if source is None or self.track_map is None:  # pragma: no cover - guarded
            raise RuntimeError("views need a map")
        self._flush()
        reports = list(self.table)
        positions = positions_of(source, [r.vehicle_id for r in reports], now, as_placed=True)
        cycle = build_views(
            self.track_map,
            reports,
            positions,
            self.profiles,
            self.profile,
            self._view_settings,
            now,
            self._moving,
            owners=None if self.own_id is None else (self.own_id,),
        )
        if cycle.unusable:
            self.stats["position_unusable"] += cycle.unusable
            logger.warning(
                "%d track position(s) with non-finite numbers: sector rule for them", cycle.unusable
            )
        self._cycle, self._cycle_version = cycle, self._version
        return cycle

    def _pair_outcomes(self, cycle: CycleViews, vid: str) -> dict[str, PairOutcome]:
        """The pairs of one own vehicle with a finding: on board the own vehicle's alone;
        in a control room every vehicle's at the first question of a time (one vectorised
        evaluation, see :mod:`antikol.analysis.pairs`)."""
        if self._pairs is None:  # pragma: no cover - guarded by the caller
            return {}
        of_cycle, done = self._outcomes_of
        if of_cycle is not cycle:
            self._outcomes, done = {}, set()
            self._outcomes_of = (cycle, done)
        if vid not in done:
            owners = None if self.own_id is None else (vid,)
            if owners is not None and vid != self.own_id:
                # the views were built for the own vehicle's reach: another owner needs all
                for other in cycle.deferred:
                    cycle.expand(other)
            self._outcomes.update(self._pairs.evaluate(cycle, self._traction, owners))
            done.update(cycle.views if owners is None else owners)
        return self._outcomes.get(vid, {})

    def _traction(self, vid: str) -> float:
        return self._profile(vid).traction_mps2


def _check_vehicle_id(value: object, name: str) -> None:
    """A vehicle id argument must be a string (a list raised "unhashable type")."""
    if not isinstance(value, str):
        raise InvalidArgumentError(name, value, "must be a vehicle id (str)")
