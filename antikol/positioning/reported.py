"""Track positions that the vehicles report themselves, checked before they are used.

An on-board unit positions its own vehicle with everything it has — every GPS fix, its
odometer, its route — and can send the result in its report
(:attr:`VehicleReport.track_position <antikol.report.VehicleReport.track_position>`).
A receiver that re-matches the other vehicle from one report a second knows less, and
spends most of its cycle doing it. :class:`ReportedFirst` uses a reported track position
when it passes every check, and the receiver's own matching otherwise:

* the edge exists on this map (the sender's map must be the same: edge ids are the map's);
* the offset lies on the edge (``length_slack_m`` of rounding allowed);
* when the report carries a GPS fix, the reported place is within ``max_fix_distance_m``
  of it (a sender on another map version, or a wrong position, shows here); a report
  without a fix (a tunnel) is taken on the sender's word, its odometer being better than
  anything the receiver has;
* when the vehicle moves, its reported course runs the reported direction of the track
  (within 90 degrees): an edge drawn the other way on another map version shows here.

Nothing received is trusted further than that: a refused track position is counted by
reason (:attr:`ReportedFirst.rejected`). While a vehicle's positions are used, one of its
reports every ``matcher_refresh_s`` still goes to the matcher, so that a vehicle that stops
sending its position (an on-board unit sends it only while confident) is matched from a
state at most that old, without paying for matching every report the vehicle positions
better itself; every report without a usable position goes to the matcher. The own
vehicle of an on-board unit is always matched by the unit itself (``exclude``). A used
position is carried to the analysis time along the track at the reported speed, with an
uncertainty growing with that time; it is not carried past a switch the report's route
does not decide (it stops at the switch, its uncertainty grown by the distance it did not
travel).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Collection, Sequence
from dataclasses import dataclass

import numpy as np

from antikol.positioning.deadreckoning import Advanced, advance
from antikol.positioning.outputs import asked_time
from antikol.positioning.records import Hypothesis, PositionSource, TrackPosition, positions_of
from antikol.report import ReportedTrackPosition, VehicleReport
from trackmap import TrackMap

__all__ = ["ReportedFirst", "ReportedSettings"]

#: Above this speed a report's course is checked against the reported direction, m/s.
_MOVING_MPS = 1.0


@dataclass(frozen=True, slots=True)
class ReportedSettings:
    """Checks and uncertainty of reported track positions (SI units).

    Attributes
    ----------
    max_fix_distance_m : float
        Farthest the reported place may lie from the report's own GPS fix, m.
    length_slack_m : float
        How far past an edge's end a reported offset may lie (rounding), m.
    sigma_m : float
        One-sigma uncertainty of a reported position at its report time, m ...
    speed_sigma_mps : float
        ... growing by this for every second it is carried forward, m/s.
    matcher_refresh_s : float
        While a vehicle's reported positions are used, its reports go to the matcher at
        most this often, s (0: every report). Matching the others is most of an on-board
        cycle; the matcher needs only a recent state to take over when the vehicle stops
        sending its position.
    """

    max_fix_distance_m: float = 30.0
    length_slack_m: float = 1.0
    sigma_m: float = 2.0
    speed_sigma_mps: float = 0.3
    matcher_refresh_s: float = 5.0


class ReportedFirst:
    """A :class:`~antikol.positioning.records.PositionSource`: reported track positions
    that pass the checks, the ``inner`` source (the matcher) for everything else.

    Parameters
    ----------
    net : TrackMap
    inner : PositionSource
        Positions the reports without a usable track position.
    exclude : collection of str, optional
        Vehicles always positioned by ``inner`` (the own vehicle of an on-board unit).
    settings : ReportedSettings, optional
    """

    def __init__(
        self,
        net: TrackMap,
        inner: PositionSource,
        *,
        exclude: Collection[str] = (),
        settings: ReportedSettings | None = None,
    ) -> None:
        self.net = net
        self.inner = inner
        self.exclude = frozenset(exclude)
        self.settings = settings or ReportedSettings()
        self.rejected: Counter[str] = Counter()
        self.used = 0
        #: Reports with a used position that were not matched (the matcher was fresh).
        self.unmatched = 0
        self._latest: dict[str, VehicleReport] = {}
        self._matched_at: dict[str, float] = {}

    def check(self, report: VehicleReport) -> str | None:
        """Why a report's track position cannot be used (None when it can)."""
        return self.check_many([report])[0]

    def check_many(self, reports: Sequence[VehicleReport]) -> list[str | None]:
        """:meth:`check` of many reports, the geometry of all in a few array calls."""
        out: list[str | None] = [None] * len(reports)
        slack = self.settings.length_slack_m
        n_edges = len(self.net.edges)
        placed: list[tuple[int, int, float, int]] = []  # report, edge, offset, direction
        for k, report in enumerate(reports):
            tp = report.track_position
            if tp is None:
                out[k] = "absent"
            elif not 0 <= tp.edge_id < n_edges:
                out[k] = "unknown_edge"
            else:
                length = self.net.edge_length(tp.edge_id)
                if tp.offset_m > length + slack:
                    out[k] = "offset_beyond_edge"
                else:
                    placed.append((k, tp.edge_id, min(tp.offset_m, length), tp.direction))
        if not placed:
            return out
        rows, edges, offsets, directions = (list(c) for c in zip(*placed, strict=True))
        fixed = [i for i, k in enumerate(rows) if reports[k].fix_quality != 0]
        if fixed:
            x, y = self.net.points_at([edges[i] for i in fixed], [offsets[i] for i in fixed])
            fx, fy = self.net.to_local(
                np.array([reports[rows[i]].lon for i in fixed]),
                np.array([reports[rows[i]].lat for i in fixed]),
            )
            apart = ((fx - x) ** 2 + (fy - y) ** 2) ** 0.5
            far_off = (apart > self.settings.max_fix_distance_m).tolist()
            for i, far in zip(fixed, far_off, strict=True):
                if far:
                    out[rows[i]] = "far_from_fix"
        moving = [
            i for i, k in enumerate(rows) if out[k] is None and reports[k].speed_mps >= _MOVING_MPS
        ]
        if moving:
            heading = self.net.headings_at(
                [edges[i] for i in moving],
                [offsets[i] for i in moving],
                [directions[i] for i in moving],
            )
            for i, h in zip(moving, heading.tolist(), strict=True):
                if abs((h - reports[rows[i]].course_deg + 180.0) % 360.0 - 180.0) > 90.0:
                    out[rows[i]] = "against_course"
        return out

    def update_many(
        self, reports: Sequence[VehicleReport], *, outputs: bool = True
    ) -> list[TrackPosition]:
        """Take the usable reported positions; the other reports, and those of vehicles
        not matched for ``matcher_refresh_s``, go to ``inner``."""
        refresh_s = self.settings.matcher_refresh_s
        to_match = []
        usable: list[bool] = []
        refused: Counter[str] = Counter()
        skipped = 0
        matched_at = dict(self._matched_at)
        reasons = self.check_many([r for r in reports if r.vehicle_id not in self.exclude])
        checked = iter(reasons)
        for r in reports:
            vid = r.vehicle_id
            reason = "absent" if vid in self.exclude else next(checked)
            usable.append(reason is None)
            if reason is None:
                last = matched_at.get(vid)
                if refresh_s > 0 and last is not None and r.t - last < refresh_s:
                    skipped += 1
                    continue
            elif reason != "absent":
                refused[reason] += 1
            to_match.append(r)
            matched_at[vid] = r.t
        if to_match:
            self.inner.update_many(to_match, outputs=False)
        # kept and counted once the matcher has taken the batch: a caller that retries a
        # failed batch report by report must find nothing matched or counted twice
        self._matched_at = matched_at
        for r, ok in zip(reports, usable, strict=True):
            if ok:
                self._latest[r.vehicle_id] = r
            else:
                self._latest.pop(r.vehicle_id, None)
        self.used += sum(usable)
        self.unmatched += skipped
        self.rejected.update(refused)
        if not outputs:
            return []
        out = []
        for r in reports:
            pos = self.position(r.vehicle_id, r.t)
            if pos is None:  # pragma: no cover - every vehicle here has just reported
                raise RuntimeError(f"no position of {r.vehicle_id!r} after its report")
            out.append(pos)
        return out

    def position(self, vehicle_id: str, t: float | None = None) -> TrackPosition | None:
        """The vehicle's position at ``t`` (s): from its reported track position when its
        newest report had a usable one, else from ``inner``."""
        return self.positions([vehicle_id], t)[0]

    def positions(
        self, vehicle_ids: Sequence[str], t: float | None = None, *, as_placed: bool = False
    ) -> list[TrackPosition | None]:
        """:meth:`position` of many vehicles, those without a used reported position
        asked of ``inner`` together (``t``: s; a time that is not a finite number raises
        :class:`~antikol.errors.InvalidArgumentError`); ``as_placed``: ``inner``'s as
        placed (:meth:`placed_positions`)."""
        t = asked_time(t)
        out: list[TrackPosition | None] = [None] * len(vehicle_ids)
        matched: list[int] = []
        carried: list[tuple[int, VehicleReport, float]] = []
        for k, vid in enumerate(vehicle_ids):
            report = self._latest.get(vid)
            if report is None:
                matched.append(k)
            else:
                carried.append((k, report, report.t if t is None else float(t)))
        if carried:
            used = self._carried([(r, when) for _, r, when in carried])
            for (k, _, _), position in zip(carried, used, strict=True):
                out[k] = position
        if matched:
            ids = [vehicle_ids[k] for k in matched]
            inner = positions_of(self.inner, ids, t, as_placed=as_placed)
            for k, pos in zip(matched, inner, strict=True):
                out[k] = pos
        return out

    def placed_positions(
        self, vehicle_ids: Sequence[str], t: float | None = None
    ) -> list[TrackPosition | None]:
        """:meth:`positions` as placed: vehicles not yet shown on a track too
        (:mod:`antikol.positioning.showing`)."""
        return self.positions(vehicle_ids, t, as_placed=True)

    def forget(self, vehicle_id: str) -> None:
        """Drop a vehicle (it left the table)."""
        self._latest.pop(vehicle_id, None)
        self._matched_at.pop(vehicle_id, None)
        self.inner.forget(vehicle_id)

    def _branches(self, tp: ReportedTrackPosition, offset: float, run_m: float) -> bool:
        """Whether the track branches within ``run_m`` ahead of a reported position."""
        wrong = not self.net.edges[tp.edge_id].allows(tp.direction)
        paths = self.net.paths_ahead(
            tp.edge_id, offset, tp.direction, run_m, respect_direction=not wrong, max_paths=2
        )
        return len(paths) > 1

    def _moved(self, report: VehicleReport, t: float) -> tuple[Advanced, float]:
        """A used position carried to ``t`` (s) at the reported speed, and how far it was
        not carried past an undecided switch (m)."""
        tp = report.track_position
        if tp is None:  # pragma: no cover - only checked reports are kept
            raise RuntimeError("a kept report without a track position")
        edge = self.net.edges[tp.edge_id]
        offset = min(tp.offset_m, edge.length_m)
        run_m = report.speed_mps * max(t - report.t, 0.0)
        moved = advance(
            self.net,
            tp.edge_id,
            offset,
            tp.direction,
            run_m,
            report,
            wrong=not edge.allows(tp.direction),
        )
        if moved.edge_id != tp.edge_id and not report.route and self._branches(tp, offset, run_m):
            # a switch ahead that nothing decides: stop at it rather than guess a branch
            end = edge.length_m if tp.direction == 1 else 0.0
            return Advanced(tp.edge_id, end, tp.direction), run_m - abs(end - offset)
        return moved, 0.0

    def _carried(self, asked: Sequence[tuple[VehicleReport, float]]) -> list[TrackPosition]:
        """The used positions of reports carried to the times asked (s), their places'
        geometry in array calls."""
        moves = [self._moved(report, t) for report, t in asked]
        edges = [m.edge_id for m, _ in moves]
        offsets = [m.offset_m for m, _ in moves]
        directions = [m.direction for m, _ in moves]
        x, y = self.net.points_at(edges, offsets)
        lons, lats = self.net.to_lonlat(x, y)
        headings = self.net.headings_at(edges, offsets, directions).tolist()
        s = self.settings
        out = []
        for k, ((report, t), (moved, undecided_m)) in enumerate(zip(asked, moves, strict=True)):
            dt = max(t - report.t, 0.0)
            wrong = not self.net.edges[moved.edge_id].allows(moved.direction)
            hyp = Hypothesis(
                edge_id=moved.edge_id,
                direction=moved.direction,
                offset_m=moved.offset_m,
                probability=1.0,
                progress_m=0.0,
                wrong_way=wrong,
                # the sender matched itself against the permitted direction: its word is
                # the sustained evidence a receiver would otherwise wait for
                wrong_way_s=float("inf") if wrong else 0.0,
            )
            out.append(
                TrackPosition(
                    vehicle_id=report.vehicle_id,
                    t=t,
                    status="confident",
                    edge_id=moved.edge_id,
                    direction=moved.direction,
                    offset_m=moved.offset_m,
                    lon=float(lons[k]),
                    lat=float(lats[k]),
                    heading_deg=headings[k],
                    speed_mps=report.speed_mps,
                    probability=1.0,
                    sigma_m=s.sigma_m + s.speed_sigma_mps * dt + undecided_m,
                    wrong_way=wrong,
                    hypotheses=(hyp,),
                    dead_reckoned_s=dt,
                )
            )
        return out
