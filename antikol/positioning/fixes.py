"""Discrete position fixes: balises and loop crossings at known places on the map.

Following on-board ATP practice (position correction at crossing points, with acceptance
windows and a tolerated number of missed fixes):

* a fix is accepted only inside a window around the predicted position that grows with the
  distance run since the last accepted fix, ``base + fraction x distance``; an accepted fix
  pins the vehicle to the fix's track and resets its along-track error;
* a fix outside the window does not move the vehicle: its position becomes ``lost``;
* fix points the vehicle passes without reporting them are counted as missed; more than
  ``max_missed_fixes`` in a row also make the position ``lost``;
* a fix is weighed against the vehicle's latest position (its last report, or its last
  accepted fix) carried to the fix's time, so it must be dated from then on: an older one
  is refused as late (counted ``fix_late``). The along-track filter keeps no past to weigh
  it against (against where the vehicle is now, past the fix point, it would be found
  outside the window), and pinning the vehicle there would turn the filter's clock back
  (1000 s back, the vehicle's next report found it hundreds of kilometres uncertain: lost).
  A fix dated more than ``dead_reckoning_s`` after the latest position is refused too
  (``fix_ahead``): the prediction is dead reckoning past its limit, and pinning there would
  set the filter's clock ahead of the reports still to come.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from antikol.positioning.config import PositioningConfig
from antikol.positioning.records import DiscreteFix, FixPoint, Hypothesis

if TYPE_CHECKING:
    from antikol.positioning.fleet import FleetState
    from trackmap import TrackMap

__all__ = ["DiscreteFixes", "FixHooks"]


class FixHooks(Protocol):
    """What discrete fixes need of the positioner, kept small and explicit (the
    :class:`~antikol.positioning.matcher.Positioner` provides it; no import of it here)."""

    stats: Counter[str]

    def hypotheses(self, vehicle_id: str) -> tuple[Hypothesis, ...]: ...

    def along(self, row: int) -> float: ...

    def predicted(self, row: int, t: float) -> tuple[int, float, int, float, float, float]: ...

    def mark_lost(self, row: int, reason: str) -> None: ...

    def pin(
        self, row: int, t: float, edge: int, offset: float, direction: int, s: float, v: float
    ) -> None: ...


logger = logging.getLogger(__name__)

#: A vehicle this far past an expected fix point without reporting it has missed it, m.
_MISSED_AFTER_M = 10.0
#: Fix points are looked for along at most this much track per report, m.
_LOOK_M = 500.0


@dataclass
class _VehicleFixes:
    last_fix_s: float | None = None
    missed: int = 0
    expected: list[tuple[str, float]] = field(default_factory=list)
    previous: tuple[int, float, int, float] | None = None  # edge, offset, direction, s


class DiscreteFixes:
    """Expected and received discrete fixes of every vehicle of a positioner.

    Parameters
    ----------
    track_map : TrackMap
    config : PositioningConfig
    fix_points : iterable of FixPoint
    fix_equipped : iterable of str, optional
        Vehicles able to read fix points (default: all, when fix points are given).
    """

    def __init__(
        self,
        track_map: TrackMap,
        config: PositioningConfig,
        fix_points: Iterable[FixPoint],
        fix_equipped: Iterable[str] | None,
    ) -> None:
        self.net = track_map
        self.config = config
        self._by_edge: dict[int, list[tuple[float, str]]] = {}
        for fp in fix_points:
            self.net.edge(fp.edge_id)
            self._by_edge.setdefault(fp.edge_id, []).append((fp.offset_m, fp.fix_id))
        self._equipped = None if fix_equipped is None else set(fix_equipped)
        self._vehicles: dict[str, _VehicleFixes] = {}

    @property
    def active(self) -> bool:
        """True when the map has fix points."""
        return bool(self._by_edge)

    def _vehicle(self, vid: str) -> _VehicleFixes:
        return self._vehicles.setdefault(vid, _VehicleFixes())

    def equipped(self, vid: str) -> bool:
        """True when the vehicle is expected to report the fix points it passes."""
        return self.active and (self._equipped is None or vid in self._equipped)

    def forget(self, vid: str) -> None:
        """Drop a vehicle."""
        self._vehicles.pop(vid, None)

    def track_expected(self, vid: str, positioner: FixHooks, row: int, progress_m: float) -> None:
        """Note the fix points passed since the previous report of a vehicle."""
        if not self.equipped(vid):
            return
        first = positioner.hypotheses(vid)[0]
        vf = self._vehicle(vid)
        prev, vf.previous = (
            vf.previous,
            (first.edge_id, first.offset_m, first.direction, progress_m),
        )
        if prev is None:
            return
        edge, offset, direction, s0 = prev
        run = progress_m - s0
        if not 0.0 < run <= _LOOK_M:
            return
        paths = self.net.paths_ahead(edge, offset, direction, run, respect_direction=False)
        path = next((p for p in paths if p.steps[-1].edge_id == first.edge_id), None)
        if path is None:
            return
        for step in path.steps:
            for off, fid in self._by_edge.get(step.edge_id, ()):
                at = step.distance_to(off)
                if at is not None and 0.0 < at <= run:
                    vf.expected.append((fid, s0 + at))

    def check_missed(self, vid: str, positioner: FixHooks, row: int) -> bool:
        """Count expected fixes left behind; True when too many were missed."""
        vf = self._vehicles.get(vid)
        if vf is None or not vf.expected:
            return False
        s_now = positioner.along(row)
        c = self.config
        remaining = []
        for fid, s_exp in vf.expected:
            since = s_exp - (vf.last_fix_s if vf.last_fix_s is not None else s_exp)
            window = c.fix_window_base_m + c.fix_window_fraction * abs(since)
            if s_now > s_exp + window + _MISSED_AFTER_M:
                vf.missed += 1
                positioner.stats["fix_missed"] += 1
                logger.debug("%s: expected fix %s not received", vid, fid)
            else:
                remaining.append((fid, s_exp))
        vf.expected = remaining
        return vf.missed > c.max_missed_fixes

    def refuses(
        self, vid: str, fix: DiscreteFix, fleet: FleetState, row: int | None, stats: Counter[str]
    ) -> bool:
        """Whether a (checked) fix cannot be weighed, counted: the vehicle is not known, or
        has no track position (``fix_unusable``), or the fix is dated before its latest
        position, its along-track filter's time (``fix_late``), or more than
        ``dead_reckoning_s`` after it (``fix_ahead``)."""
        if (
            row is None
            or fleet.last[row] is None
            or fleet.hs[row, 0] < 0
            or math.isnan(fleet.kf.t[row])
        ):
            stats["fix_unusable"] += 1
            return True
        after_s = fix.t - float(fleet.kf.t[row])
        if 0.0 <= after_s <= self.config.dead_reckoning_s:
            return False
        stats["fix_late" if after_s < 0.0 else "fix_ahead"] += 1
        logger.info(
            "%s: fix %s at t=%g s is %g s from the latest position: refused",
            vid,
            fix.fix_id,
            fix.t,
            after_s,
        )
        return True

    def apply(self, vid: str, positioner: FixHooks, row: int, fix: DiscreteFix) -> None:
        """Accept a fix inside its window (pin the vehicle) or declare the position lost."""
        c = self.config
        self.net.edge(fix.edge_id)
        vf = self._vehicle(vid)
        edge, off, direction, s, v, s_std = positioner.predicted(row, fix.t)
        travelled = s - (vf.last_fix_s if vf.last_fix_s is not None else s)
        window = c.fix_window_base_m + c.fix_window_fraction * abs(travelled)
        if vf.last_fix_s is None:
            window = max(window, 3.0 * c.gps_sigma_m + s_std)
        delta = self._signed_distance(
            (edge, off, direction), (fix.edge_id, fix.offset_m), window + 5.0
        )
        if delta is None or abs(delta) > window:
            positioner.mark_lost(row, "fix_outside_window")
            positioner.stats["fix_rejected"] += 1
            logger.info(
                "%s: fix %s at edge %d/%.1f m is %s from the prediction (window %.1f m): lost",
                vid,
                fix.fix_id,
                fix.edge_id,
                fix.offset_m,
                "unreachable" if delta is None else f"{delta:+.1f} m",
                window,
            )
            return
        s_fix = s + delta
        positioner.pin(row, fix.t, fix.edge_id, fix.offset_m, direction, s_fix, v)
        vf.last_fix_s = s_fix
        vf.missed = 0
        vf.previous = (fix.edge_id, fix.offset_m, direction, s_fix)
        vf.expected = [(f, se) for f, se in vf.expected if se > s_fix + window and f != fix.fix_id]
        positioner.stats["fix_accepted"] += 1

    def _signed_distance(
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
        return None if back is None else -back.distance_m

    def state(self, vid: str) -> dict[str, Any] | None:
        """JSON-ready fix bookkeeping of a vehicle."""
        vf = self._vehicles.get(vid)
        if vf is None:
            return None
        return {
            "last_fix_s": vf.last_fix_s,
            "missed": vf.missed,
            "expected": [list(e) for e in vf.expected],
            "previous": None if vf.previous is None else list(vf.previous),
        }

    def restore(self, vid: str, data: dict[str, Any] | None) -> None:
        """Restore what :meth:`state` wrote."""
        if data is None:
            self._vehicles.pop(vid, None)
            return
        prev = data.get("previous")
        self._vehicles[vid] = _VehicleFixes(
            last_fix_s=data["last_fix_s"],
            missed=int(data["missed"]),
            expected=[(str(a), float(b)) for a, b in data["expected"]],
            previous=None
            if prev is None
            else (int(prev[0]), float(prev[1]), int(prev[2]), float(prev[3])),
        )
