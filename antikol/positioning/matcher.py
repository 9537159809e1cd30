"""Track-selective positioning: where on the network each vehicle is, and how sure we are.

For every vehicle the :class:`Positioner` keeps a small set of hypotheses over
(edge, running direction, offset) — an online hidden Markov model in the style of
Newson & Krumm (2009), as used for train positioning by DLR's RCAS (Heirich 2016):

* **emission** — the lateral offset of the fix from the track and its place along it,
  explained by a slowly varying GPS **bias** and the **lag** behind the distance reported
  run that every hypothesis estimates for itself (:mod:`antikol.positioning.fixerror`)
  plus white noise with a heavy-tailed floor; and, when moving, the agreement of the course
  over ground with the track heading in that running direction;
* **transition** — the along-track distance between successive states over physical moves
  (precomputed, :mod:`antikol.positioning.reach`), compared with the distance travelled
  (the odometer when the report has one, else ``speed x dt``);
* **wrong-way running** is a mode that must be entered (a one-off prior cost) and kept
  (a cost per fix): it wins only on sustained, consistent evidence, and only where the
  track's topology lets the vehicle get there.

The forward algorithm gives each hypothesis its probability; the top ``max_hypotheses``
survive, so past a switch both branches stay alive until the evidence separates them. The
reported position follows one **lineage**: it moves to a hypothesis that does not descend
from the previous one only when that hypothesis is decisive (``switch_probability``), so
successive positions are connected by the track (:mod:`antikol.positioning.lineage`; a
standing vehicle keeps its lineage, however little is left of it, until another hypothesis
reaches ``standing_switch_probability``). A hypothesis remembers the track it entered its
own from: a step back (the fixes of a standing vehicle scatter round it) crosses a trailing
switch only onto that track (:meth:`~antikol.positioning.reach.ReachTable.signed_distance`).
An along-track Kalman filter fuses the lineage's travelled distance with the reported speed
(or the odometer); during a GPS outage it dead-reckons along the most probable path (a
position estimated without a fix weighs the branches, :mod:`~antikol.positioning.estimates`)
until its uncertainty, the outage length or the distance run on the odometer passes a
limit, when the position is declared ``lost``.

Everything per report is vectorised over the fleet: :meth:`Positioner.update_many` handles
one cycle of a whole city in a few array operations.

Reports that contradict physics (a jump of hundreds of metres in a second, a speed or an
acceleration the vehicle cannot reach) are rejected and counted and leave the state
untouched; after ``max_rejections_in_row`` rejections in a row the vehicle is re-initialised
from the new evidence. A fix that no hypothesis explains — no track within the search
radius, or only one that no plausible move reaches (``implausible_move_nats``) — is an
outlier too: the vehicle is dead-reckoned over it as over a report without a fix. The first
along-track innovation beyond the gate is forgiven likewise (:mod:`antikol.positioning.alongtrack`).
"""

from __future__ import annotations

import functools
import math
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import asdict
from typing import Any

import numpy as np
import numpy.typing as npt

from antikol.gcpause import gc_paused
from antikol.positioning.alongtrack import run_track_filters
from antikol.positioning.biasscale import learn_bias_sigma
from antikol.positioning.branching import TIE_NATS, Arrivals, tossed_lineages
from antikol.positioning.candidates import find_candidates, loop_edges, reach_to_own_tracks_m
from antikol.positioning.config import PositioningConfig
from antikol.positioning.coursecheck import check_courses, restart_doubted
from antikol.positioning.deadreckoning import advance, dead_reckon, edge_mass
from antikol.positioning.fixerror import FIX_ERROR_FIELDS
from antikol.positioning.fixes import DiscreteFixes
from antikol.positioning.fleet import FleetState
from antikol.positioning.inputs import check_state, checked_fix, checked_report, checked_reports
from antikol.positioning.kalman import track_estimate
from antikol.positioning.lineage import plan_slots
from antikol.positioning.outputs import (
    asked_time,
    hypotheses_of,
    track_positions,
    unmatched_position,
)
from antikol.positioning.placing import place_probabilities, place_vehicles
from antikol.positioning.reach import ReachTable, state_id
from antikol.positioning.records import DiscreteFix, FixPoint, Hypothesis, TrackPosition
from antikol.positioning.scoring import Scored, score_fixes
from antikol.positioning.screening import screen_reports
from antikol.positioning.showing import as_shown, note_showing_evidence
from antikol.positioning.siblings import SameWaySiblings
from antikol.positioning.speedunits import in_recognised_units
from antikol.report import VehicleReport, one_per_vehicle
from trackmap import TrackMap

__all__ = [
    "DiscreteFix",
    "FixPoint",
    "Hypothesis",
    "Positioner",
    "PositioningConfig",
    "TrackPosition",
]


FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
_NEG_INF = -math.inf
Position = TrackPosition | None  # a vehicle's position (None: never seen)
_LOG_2PI = math.log(2.0 * math.pi)
#: From this many vehicles on, their rows are checked in array operations.
_ARRAY_CHECKS_FROM = 16
#: Hypotheses this close (m) across a plain node are the same place.
_SAME_PLACE_M = 3.0


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
        self.reach = ReachTable.for_map(track_map, reach_m=self.config.reach_m)
        self._siblings = SameWaySiblings(track_map, self.reach, self.config.same_way_hold_m)
        self.stats: Counter[str] = Counter()
        self._arrivals = Arrivals(track_map)
        self.fixes = DiscreteFixes(track_map, self.config, fix_points, fix_equipped)
        self._k = self.config.max_hypotheses
        self._row: dict[str, int] = {}
        self._f = FleetState(self._k)
        self._f.grow(64)
        self._free: list[int] = list(range(63, -1, -1))
        # each vehicle's last position asked for: as placed, as shown (showing.py)
        self._cache: dict[str, tuple[TrackPosition, TrackPosition]] = {}
        # the (edge, direction) each vehicle was last reported on: the switches behind it
        # are released (branching.hold_at_switch)
        self._reported: dict[str, tuple[int, int]] = {}
        self._reported_before: dict[str, tuple[int, int]] = {}
        self._loops = loop_edges(track_map, self.config.search_radius_m)
        self._tunnel_edges = np.array([e.tunnel for e in track_map.edges], dtype=bool)

    # -- fleet storage -------------------------------------------------------------------
    def _row_of(self, vehicle_id: str) -> int:
        row = self._row.get(vehicle_id)
        if row is None:
            if not self._free:
                start = len(self._f.t)
                self._f.grow(max(64, 2 * start))
                self._free.extend(range(len(self._f.t) - 1, start - 1, -1))
            row = self._free.pop()
            self._row[vehicle_id] = row
            self._f.clear(row)
        return row

    # -- public API ----------------------------------------------------------------------
    def update(self, report: VehicleReport) -> TrackPosition:
        """Fuse one report of a vehicle.

        Parameters
        ----------
        report : VehicleReport
            Anything else is refused (:class:`~antikol.errors.InvalidArgumentError`).

        Returns
        -------
        TrackPosition
            The vehicle's position after the report (unchanged if the report was rejected;
            ``unmatched`` at the report if no report of the vehicle was ever taken).
        """
        self.update_many([checked_report(report)], outputs=False)
        return self.position(report.vehicle_id) or unmatched_position(report, report.t)

    @gc_paused
    def update_many(
        self, reports: Sequence[VehicleReport], *, outputs: bool = True
    ) -> list[TrackPosition]:
        """Fuse reports of many vehicles at once (one analysis cycle of a fleet).

        Parameters
        ----------
        reports : sequence of VehicleReport
            One report per vehicle is typical (one cycle); several reports of one vehicle
            are processed in their order. An item that is not a report refuses the batch
            before any is fused (:class:`~antikol.errors.InvalidArgumentError`, ``reports[i]``).
        outputs : bool
            Return the positions (skip it when they are read later anyway).

        Returns
        -------
        list of TrackPosition
            One per report, in their order (empty when ``outputs`` is False): each vehicle's
            position after its last report here, as :meth:`update` gives it.
        """
        reports = in_recognised_units(self._f, self._row, checked_reports(reports))
        ids = [r.vehicle_id for r in reports]
        passes = one_per_vehicle(reports)
        # each vehicle's position after its last report here (None: ask again at the end)
        final: dict[str, TrackPosition | None] = {}
        for batch in passes:
            self._update_pass(batch)
            placed = self._remember(batch)
            final.update((r.vehicle_id, placed.get(r.vehicle_id)) for r in batch)
        if not outputs:
            return []
        again = [vid for vid, pos in final.items() if pos is None]
        if again:
            final.update(zip(again, self.positions(again), strict=True))
        last = {r.vehicle_id: r for r in reports}  # (a vehicle none of whose reports was taken)
        return [final[v] or unmatched_position(last[v], last[v].t) for v in ids]

    def _remember(self, reports: list[VehicleReport]) -> dict[str, TrackPosition]:
        """Place the vehicles at their new reports' times and remember where (the switch
        hold's memory): a function of the reports taken alone, never of which positions
        were asked for, and when (a rejected report changes nothing). Returns the
        positions of the vehicles whose report was taken."""
        row_of, last = self._row, self._f.last
        taken = [
            (r.vehicle_id, row, r)
            for r in reports
            if (row := row_of.get(r.vehicle_id)) is not None and last[row] is r
        ]
        cache, reported, before = self._cache, self._reported, self._reported_before
        for vid, _, _ in taken:
            cache.pop(vid, None)
            where = reported.get(vid)
            if where is None:
                before.pop(vid, None)
            else:
                before[vid] = where
        placed: dict[str, TrackPosition] = {}
        for pos, shown_as in self._positions_at_reports(taken):
            placed[pos.vehicle_id] = shown_as
            if pos.edge_id is not None and pos.direction is not None:
                reported[pos.vehicle_id] = (pos.edge_id, pos.direction)
        return placed

    def _positions_at_reports(
        self, taken: list[tuple[str, int, VehicleReport]]
    ) -> list[tuple[TrackPosition, TrackPosition]]:
        """:meth:`positions` of vehicles (each once, none cached) at the reports just
        taken: (id, row, report) of each; as :meth:`_placed`, without the look-ups."""
        off = self._off_track([row for _, row, _ in taken])
        out: dict[str, tuple[TrackPosition, TrackPosition]] = {}
        asked: list[tuple[str, int, float, tuple[int, int] | None]] = []
        before = self._reported_before
        for (vid, row, report), unmatched in zip(taken, off, strict=True):
            if unmatched:
                pos = unmatched_position(report, report.t)
                out[vid] = self._cache[vid] = (pos, pos)
            else:
                asked.append((vid, row, report.t, before.get(vid)))
        for pair in self._placed(asked):
            out[pair[0].vehicle_id] = pair
        return [out[vid] for vid, _, _ in taken]

    def _off_track(self, rows: list[int]) -> list[bool]:
        """Whether each row has no track position: unmatched, without a hypothesis or
        without an along-track filter (many rows in one array call)."""
        f = self._f
        if len(rows) >= _ARRAY_CHECKS_FROM:
            at = np.array(rows, dtype=np.int64)
            return list((f.unmatched[at] | (f.hs[at, 0] < 0) | np.isnan(f.kf.t[at])).tolist())
        return [bool(f.unmatched[r] or f.hs[r, 0] < 0 or math.isnan(f.kf.t[r])) for r in rows]

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
        return self.positions([vehicle_id], t)[0]

    def positions(self, vehicle_ids: Sequence[str], t: float | None = None) -> list[Position]:
        """:meth:`position` of many vehicles at once (their geometry in array calls, see
        :mod:`antikol.positioning.outputs`); ``t`` None: each at its last report, else a
        finite time, s (:class:`~antikol.errors.InvalidArgumentError` otherwise)."""
        return [None if pair is None else pair[1] for pair in self._pairs(vehicle_ids, t)]

    def placed_positions(
        self, vehicle_ids: Sequence[str], t: float | None = None
    ) -> list[Position]:
        """:meth:`positions` as placed, those not shown too (:mod:`antikol.positioning.showing`)."""
        return [None if pair is None else pair[0] for pair in self._pairs(vehicle_ids, t)]

    @gc_paused
    def _pairs(
        self, vehicle_ids: Sequence[str], t: float | None
    ) -> list[tuple[TrackPosition, TrackPosition] | None]:
        """Each vehicle's position as placed and as shown (see :meth:`_placed`)."""
        t = asked_time(t)
        out: list[tuple[TrackPosition, TrackPosition] | None] = [None] * len(vehicle_ids)
        where: dict[str, list[int]] = {}  # a vehicle asked twice gets one placement
        asked: list[tuple[str, int, float, tuple[int, int] | None]] = []
        for k, vid in enumerate(vehicle_ids):
            row = self._row.get(vid)
            last = None if row is None else self._f.last[row]
            if row is None or last is None:
                continue
            when = last.t if t is None else max(float(t), last.t)
            cached = self._cache.get(vid)
            if cached is not None and cached[0].t == when:
                out[k] = cached
            elif self._off_track([row])[0]:
                pos = unmatched_position(last, when)
                out[k] = self._cache[vid] = (pos, pos)
            elif vid in where:
                where[vid].append(k)
            else:
                where[vid] = [k]
                # the hold's memory: where the vehicle was placed at its report before
                # this one (at this report's time) or at this one (later: dead reckoning)
                basis = (self._reported_before if when == last.t else self._reported).get(vid)
                asked.append((vid, row, when, basis))
        for pair in self._placed(asked):
            for k in where[pair[0].vehicle_id]:
                out[k] = pair
        return out

    def _placed(
        self, asked: list[tuple[str, int, float, tuple[int, int] | None]]
    ) -> list[tuple[TrackPosition, TrackPosition]]:
        """The track positions of matched vehicles, each once: (id, row, time (s), where
        it was placed before) of each; each as placed and as shown (not yet on a track:
        :mod:`antikol.positioning.showing`), kept in the cache."""
        if not asked:
            return []
        rows = np.array([row for _, row, _, _ in asked], dtype=np.int64)
        when_s = np.array([when for _, _, when, _ in asked], dtype=float)
        est = track_estimate(self._f.kf, rows, when_s, self.config.accel_sigma_mps2)
        places = place_vehicles(
            self.net,
            self._arrivals,
            self._f,
            self.config,
            [vid for vid, _, _, _ in asked],
            rows,
            when_s,
            (est[0], est[1], est[2]),
            self._hypotheses_of(rows),
            [basis for _, _, _, basis in asked],
        )
        out = track_positions(self.net, places)
        shown_as = as_shown(self._f, rows, out, self.config, [p.held for p in places])
        pairs = list(zip(out, shown_as, strict=True))
        for pair in pairs:
            self._cache[pair[0].vehicle_id] = pair
        return pairs

    def forget(self, vehicle_id: str) -> None:
        """Drop a vehicle's state (it left the vehicle table)."""
        row = self._row.pop(vehicle_id, None)
        self._cache.pop(vehicle_id, None)
        self._reported.pop(vehicle_id, None)
        self._reported_before.pop(vehicle_id, None)
        self.fixes.forget(vehicle_id)
        if row is not None:
            self._f.clear(row)
            self._free.append(row)

    def vehicles(self) -> list[str]:
        """Ids of the vehicles with a state."""
        return list(self._row)

    def hypotheses(self, vehicle_id: str) -> tuple[Hypothesis, ...]:
        """The hypotheses kept for a vehicle (reported lineage first)."""
        row = self._row.get(vehicle_id)
        return () if row is None else self._hypotheses(row)

    # -- one pass: at most one report per vehicle ------------------------------------------
    def _update_pass(self, reports: list[VehicleReport]) -> None:
        rows = np.array([self._row_of(r.vehicle_id) for r in reports], dtype=np.int64)
        for r in reports:
            self._cache.pop(r.vehicle_id, None)
        # 1. what of the reports can be used: the odometer, the feed's faults, physics
        s = screen_reports(self._f, self.net, self.config, self.stats, reports, rows)
        # 2. reports without a position fix: dead reckoning on the odometer, if any
        odo = s.odometer_m
        self._dead_reckon(np.flatnonzero(s.keep & s.no_fix), reports, rows, odo, outage=True)
        fix = s.keep & ~s.no_fix
        if not fix.any():
            return
        idx = np.flatnonzero(fix)
        self._fuse([reports[i] for i in idx], rows[idx], s.t[idx], s.speed_mps[idx], odo[idx],
                   s.x_m[idx], s.y_m[idx])  # fmt: skip

    # -- the fusion of position fixes ----------------------------------------------------
    def _fuse(
        self,
        reports: list[VehicleReport],
        rows: IntArray,
        t: FloatArray,
        speed: FloatArray,
        odo: FloatArray,
        xs: FloatArray,
        ys: FloatArray,
    ) -> None:
        find = functools.partial(find_candidates, self.net, self._loops)
        # a course the run between the vehicle's own fixes shows wrong: ignored or turned round
        course = np.fromiter((r.course_deg for r in reports), float, len(reports))
        course = restart_doubted(self._f, check_courses(self._f, self.config, reports, rows, t,
                                 speed, xs, ys, course, self.stats), self.stats)  # fmt: skip
        f, c, reach_out = self._f, self.config, None
        refusing = f.rejected[rows] > 0
        if refusing.any():  # (see there: a jump of the GPS bias)
            moving = speed >= c.min_speed_for_course_mps
            reach_out = reach_to_own_tracks_m(
                self.net, (f.hs[rows], f.ho[rows]), speed * np.maximum(t - f.t[rows], 0.0),
                refusing, (xs, ys, np.where(moving, course, np.nan)),
                along_tolerance_m=c.search_radius_m, cap_m=2.0 * c.search_radius_m,
            )  # fmt: skip
        scored = score_fixes(self._f, self.reach, self.config, find, self.reach.headings.at,
                             reports, rows, t, speed, odo, xs, ys,
                             course_deg=course, reach_out_m=reach_out)  # fmt: skip
        self.stats.update(scored.stats)
        self._f.rejected[rows] = scored.rejected
        out = scored.stuck
        if out.any():
            self._f.note_rejected(rows[out], xs[out], ys[out])
        self._commit(reports, rows, t, speed, odo, xs, ys, scored)
        # an outlier fix leaves the hypotheses as they were: carried on the odometer (not
        # on the speeds: the next fix's move spans the outlier's interval)
        self._dead_reckon(np.flatnonzero(scored.stuck), reports, rows, odo, speeds=False)

    def _dead_reckon(
        self, which: IntArray, reports: list[VehicleReport], rows: IntArray, odo: FloatArray,
        *, speeds: bool = True, outage: bool = False,
    ) -> None:  # fmt: skip
        """Carry the vehicles of reports ``which`` (no usable fix) on their odometers, else
        (``speeds``) on their speeds; the reported place's probability follows the
        hypotheses split at switches. ``outage``: the reports have no fix (not a refused
        one), which tells a tunnel from open track."""
        tunnels = self._tunnel_edges if outage else None
        for i in which.tolist():
            dead_reckon(self._f, self.reach, self.net, self.config, self.stats, rows[i],
                        reports[i], odo[i], speeds=speeds, tunnel_edges=tunnels)  # fmt: skip
        if len(which):
            self._f.place[rows[which]] = self._place_probabilities(rows[which])

    def _commit(
        self,
        reports: list[VehicleReport],
        rows: IntArray,
        t: FloatArray,
        speed: FloatArray,
        odo: FloatArray,
        xs: FloatArray,
        ys: FloatArray,
        scored: Scored,
    ) -> None:
        """Keep the best hypotheses of every vehicle, choose the reported lineage, run the
        along-track filter."""
        c = self.config
        n = len(reports)
        unmatched, skip, fresh = scored.unmatched, scored.stuck, scored.fresh
        cv, cs, co, lp = scored.cv, scored.cs, scored.co, scored.log_p
        prog, parent, ww = scored.progress, scored.parent, scored.wrong_way_s
        came = scored.came_from
        error_cols, along_sigma = scored.fix_error, scored.along_sigma
        finite = np.isfinite(lp)
        # normalise per vehicle (candidates are grouped by vehicle, in vehicle order)
        vmax = np.full(n, _NEG_INF)
        np.maximum.at(vmax, cv[finite], lp[finite])
        with np.errstate(invalid="ignore"):  # -inf - -inf where a vehicle has no finite score
            p = np.where(finite, np.exp(lp - vmax[cv]), 0.0)
        total = np.bincount(cv, weights=p, minlength=n)
        p = p / np.where(total[cv] > 0, total[cv], 1.0)
        rank_order = np.lexsort((-p, cv))
        bounds = np.searchsorted(cv[rank_order], np.arange(n + 1))
        gone = rows[unmatched & ~skip]
        self._f.hs[gone] = -1
        self._f.hp[gone] = _NEG_INF
        self._f.unmatched[gone] = True
        self._f.rejected[gone] = 0
        if len(gone):
            self.stats["unmatched"] += len(gone)
        go = np.flatnonzero(~unmatched & ~skip)  # reports committed to hypotheses
        if len(go):
            self._keep_hypotheses(
                go,
                reports,
                rows,
                (t, speed, odo, along_sigma),
                (rank_order, bounds, p, parent, fresh, scored.standing),
                (cs, co, prog, ww, came, error_cols),
            )
            learn_bias_sigma(self._f, rows[go], t[go], self.reach.headings.at,
                             prior_sigma_m=c.bias_sigma_m)  # fmt: skip
        kept = np.flatnonzero(~skip)
        self._set_fixes(kept, reports, rows, t, speed, odo, xs, ys)
        self._f.stood[rows[kept]] = scored.stood_s[kept]
        if not len(go):
            return
        done = rows[go]
        self._f.place[done] = self._place_probabilities(done)
        confident = self._f.place[done] >= c.confidence
        self._f.confident_run[done] = np.where(confident, self._f.confident_run[done] + 1, 0)
        note_showing_evidence(self._f, done, c, fresh=fresh[go], speed_mps=speed[go],
                              course_deg=scored.course_deg[go])  # fmt: skip
        lost = self._f.lost
        watch = go if self.fixes.active else [i for i in go.tolist() if lost[rows[i]] is not None]
        for i in watch:
            row = rows[i]
            if self._f.lost[row] is not None and self._f.confident_run[row] >= c.relocalise_after:
                self.stats["relocalised"] += 1
                self._f.lost[row] = None
            if not self.fixes.active:
                continue
            missed = self.fixes.check_missed(reports[i].vehicle_id, self, row)
            if missed and self._f.lost[row] is None:
                self._f.lost[row] = "missed_fixes"
                self._f.confident_run[row] = 0
                self.stats["lost_missed_fixes"] += 1
        gone = rows[unmatched & ~skip]
        self._f.confident_run[gone] = 0
        self._f.place[gone] = 0.0

    def _keep_hypotheses(
        self,
        go: IntArray,
        reports: list[VehicleReport],
        rows: IntArray,
        measured: tuple[FloatArray, FloatArray, FloatArray, FloatArray],
        ranking: tuple[
            IntArray, IntArray, FloatArray, IntArray, npt.NDArray[np.bool_], npt.NDArray[np.bool_]
        ],
        candidates: tuple[
            IntArray, FloatArray, FloatArray, FloatArray, FloatArray, tuple[FloatArray, ...]
        ],
    ) -> None:
        """Store the kept hypotheses of the committed reports ``go``: the most probable
        ``max_hypotheses`` (beyond the first only those above ``min_probability``), the one
        the reported position follows in slot 0 (:func:`~antikol.positioning.lineage.plan_slots`);
        then run their along-track filters.

        ``measured``: time, speed, odometer and along-track sigma of each report;
        ``ranking``: candidates in rank order, the bounds of each report's, their
        probabilities, parent slots, whether each report starts afresh and whether the
        vehicle stands;
        ``candidates``: state id, offset, progress, wrong-way time, the state it came from
        and fix error filter state of each."""
        c = self.config
        rank_order, bounds, p, parent, fresh, standing = ranking
        cs, co, prog, ww, came, error_cols = candidates
        f, done = self._f, rows[go]
        f.note_ties(done, measured[0][go], TIE_NATS)
        toss = tossed_lineages(self.net, cs, parent, f.hp, rows, reports, self._reported, f.tt)
        chosen, m_idx, m_group, col = plan_slots(
            *(rank_order, bounds, p, parent, go),
            fresh=fresh,
            standing=standing,
            k=self._k,
            min_probability=c.min_probability,
            switch_probability=c.switch_probability,
            standing_switch_probability=c.standing_switch_probability,
            same_way=self._siblings.asker(cs, co, reports, rows, f.hs, self._reported),
            tossed=toss,
        )
        r = rows[m_group]
        switched = ~fresh[go] & (parent[chosen] != 0)
        f.tt[done[switched | fresh[go]]] = np.nan  # (a new lineage: no toss of its own)
        progress = prog[chosen]
        rebased = None
        if switched.any():
            # from a slot at the same place (see lineage): the filter goes on, rebased
            at, rw, j = np.flatnonzero(switched), done[switched], parent[chosen[switched]]
            gap = self.reach.between(f.hs[rw, 0], f.ho[rw, 0], f.hs[rw, j], f.ho[rw, j])
            same = np.abs(gap) <= _SAME_PLACE_M
            progress[at[same]] += (f.hg[rw, 0] + gap - f.hg[rw, j])[same]
            rebased = at[same]
            switched[rebased] = False
            self.stats["lineage_switch_in_place"] += int(np.count_nonzero(same))
        f.keep_before(done, fresh[go])
        f.hs[done] = -1
        f.hp[done] = _NEG_INF
        f.hs[r, col] = cs[m_idx]
        f.ho[r, col] = co[m_idx]
        f.hp[r, col] = np.log(np.maximum(p[m_idx], 1e-300))
        f.hg[r, col] = prog[m_idx]
        if rebased is not None:
            f.hg[done[rebased], 0] = progress[rebased]
        f.hw[r, col] = ww[m_idx]
        f.he[r, col] = 0.0  # (a fix: the estimates' evidence so far stays as it is)
        f.hv[r, col] = came[m_idx]
        for name, values in zip(FIX_ERROR_FIELDS, error_cols, strict=True):
            getattr(f, name)[r, col] = values[m_idx]
        self.stats["lineage_switch"] += int(np.count_nonzero(switched))
        f.confident_run[done[switched]] = 0  # the reported place's run starts again
        # (a last defence: a lineage's progress that is no number would turn the filters
        # and the position into NaN; it starts afresh instead, counted)
        lost_track = ~np.isfinite(progress)
        if lost_track.any():
            progress[lost_track] = f.hg[done[lost_track], 0] = 0.0
            switched |= lost_track
            self.stats["progress_not_finite"] += int(np.count_nonzero(lost_track))
        run_track_filters(
            f,
            c,
            self.stats,
            rows[go],
            (measured[0][go], measured[1][go], measured[2][go], measured[3][go]),
            progress,
            fresh[go] | switched,
        )
        if self.fixes.active:
            for k in np.flatnonzero(~fresh[go] & ~switched).tolist():
                i = int(go[k])
                self.fixes.track_expected(reports[i].vehicle_id, self, rows[i], progress[k])
        f.unmatched[done] = False
        f.rejected[done] = 0
        self.stats["matched"] += len(go)

    def _set_fixes(
        self, which: IntArray, reports: list[VehicleReport], rows: IntArray, t: FloatArray,
        speed: FloatArray, odo: FloatArray, xs: FloatArray, ys: FloatArray,
    ) -> None:  # fmt: skip
        """Remember the fixes ``which`` as the vehicles' latest."""
        f = self._f
        r = rows[which]
        f.t[r] = f.t_fix[r] = t[which]
        f.x[r], f.y[r] = xs[which], ys[which]
        f.v[r] = speed[which]
        f.odo[r] = f.odo_fix[r] = odo[which]
        f.note_fix(r)
        for i in which.tolist():
            f.last[rows[i]] = reports[i]

    # -- outputs -------------------------------------------------------------------------
    def _hypotheses(self, row: int) -> tuple[Hypothesis, ...]:
        return self._hypotheses_of(np.array([row], dtype=np.int64))[0]

    def _hypotheses_of(self, rows: IntArray) -> list[tuple[Hypothesis, ...]]:
        """The hypotheses of many vehicles, read from the arrays at once."""
        f = self._f
        return hypotheses_of(
            f.hs[rows], f.ho[rows], f.hp[rows], f.hg[rows], f.hw[rows], self.reach.allowed
        )

    def _place_probabilities(self, rows: IntArray) -> FloatArray:
        """:func:`~antikol.positioning.placing.place_probabilities` of ``rows``."""
        apart = {"same_place_m": _SAME_PLACE_M, "same_state_m": self.config.search_radius_m}
        return place_probabilities(self._f, self.reach, rows, **apart)

    # -- discrete fixes ------------------------------------------------------------------
    def fix(self, vehicle_id: str, fix: DiscreteFix) -> TrackPosition | None:
        """Apply a discrete position fix (a balise or loop crossing).

        A fix is accepted only when it lies within the acceptance window around the
        predicted position, ``fix_window_base_m + fix_window_fraction x distance since the
        last accepted fix``. An accepted fix resets the along-track error and pins the
        vehicle to the fix's track; a fix outside the window makes the position ``lost``.
        One dated before the vehicle's latest position, or long after it, is refused and
        counted (``fix_late``, ``fix_ahead``; :mod:`antikol.positioning.fixes`); one not of
        this map raises :class:`~antikol.errors.InvalidArgumentError` naming the field.

        Returns
        -------
        TrackPosition or None
            The new position (None for an unknown vehicle).
        """
        fix, row = checked_fix(self.reach.lengths, fix), self._row.get(vehicle_id)
        if self.fixes.refuses(vehicle_id, fix, self._f, row, self.stats) or row is None:
            return self.position(vehicle_id)  # (counted; an unknown vehicle is refused too)
        self.fixes.apply(vehicle_id, self, row, fix)
        self._cache.pop(vehicle_id, None)
        return self.position(vehicle_id, fix.t)

    # hooks used by :class:`DiscreteFixes` (kept small and explicit)
    def predicted(self, row: int, t: float) -> tuple[int, float, int, float, float, float]:
        """Predicted (edge, offset, direction, s, speed, s_std) of a vehicle at ``t``."""
        c = self.config
        s, v, s_std, _ = track_estimate(self._f.kf, row, np.float64(t), c.accel_sigma_mps2)
        hyps = self._hypotheses(row)
        first = hyps[0]
        moved = advance(
            self.net,
            first.edge_id,
            first.offset_m,
            first.direction,
            float(s) - self._f.z[row],
            self._f.last[row],
            wrong=first.wrong_way,
            edge_mass=edge_mass(hyps),
        )
        return moved.edge_id, moved.offset_m, moved.direction, float(s), float(v), float(s_std)

    def pin(
        self, row: int, t: float, edge: int, offset: float, direction: int, s: float, v: float
    ) -> None:
        """Pin a vehicle to one track position (an accepted discrete fix)."""
        self._f.pin(row, t, state_id(edge, direction), offset, s, v, self.config.fix_sigma_m)

    def mark_lost(self, row: int, reason: str) -> None:
        """Declare a vehicle's position lost (until relocalised)."""
        self._f.lost[row] = reason
        self._f.confident_run[row] = 0

    def along(self, row: int) -> float:
        """Current along-track filter position of a vehicle, m."""
        return float(self._f.kf.s[row])

    # -- persistence ---------------------------------------------------------------------
    def state(self, vehicle_id: str) -> dict[str, Any] | None:
        """The vehicle's filter state as a JSON-ready dict (bounded size)."""
        row = self._row.get(vehicle_id)
        if row is None:
            return None
        return {
            "hypotheses": [asdict(h) for h in self._hypotheses(row)],
            **self._f.row_state(row),
            "fixes": self.fixes.state(vehicle_id),
            "reported": self._reported.get(vehicle_id),
            "reported_before": self._reported_before.get(vehicle_id),
        }

    def restore(self, vehicle_id: str, data: dict[str, Any]) -> None:
        """Restore a state produced by :meth:`state` on this map; any other is refused before
        anything changes (:class:`~antikol.errors.InvalidArgumentError` naming the vehicle
        and the key, :func:`~antikol.positioning.inputs.check_state`)."""
        reported = check_state(self.reach.lengths, vehicle_id, data)
        self.forget(vehicle_id)
        row = self._row_of(vehicle_id)
        m = self._f.restore_row(row, data)
        self.fixes.restore(vehicle_id, data.get("fixes"))
        for memory, where in zip((self._reported, self._reported_before), reported, strict=True):
            if where is not None:  # where the switch hold placed it
                memory[vehicle_id] = where
        self._f.place[row] = self._place_probabilities(np.array([row]))[0] if m else 0.0
