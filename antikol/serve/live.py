"""The state of the live view: an analyser, its latest fleet snapshot and the viewers.

:class:`LiveView` runs one control-room :class:`~antikol.analysis.analyser.Analyser`. A
feed (:mod:`antikol.serve.feeds`) hands it each analysis cycle's reports with
:meth:`LiveView.cycle`; it assesses every vehicle and publishes a *snapshot* — plain
JSON-ready data: every vehicle's position, speed, heading, level and threats — to every
subscribed viewer. A viewer that falls behind loses the oldest snapshots, never the
newest. Nothing here needs the web server, so it can be tested and used on its own.

>>> view = LiveView(None)
>>> snap = view.cycle(10.0, [VehicleReport("T1", 10.0, 54.39, 18.63, 5.0, 90.0)])
>>> snap["cycle"], [v["id"] for v in snap["vehicles"]], snap["vehicles"][0]["level"]
(1, ['T1'], 'none')
"""

from __future__ import annotations

import asyncio
import logging
import math
import threading
from collections.abc import Callable, Sequence
from typing import Any

from antikol.analysis.analyser import Analyser
from antikol.analysis.assessment import Assessment
from antikol.kinds import level_rank
from antikol.report import VehicleReport
from trackmap import TrackMap

__all__ = ["LiveView", "Subscription"]

logger = logging.getLogger(__name__)


def _num(value: float | None, digits: int = 1) -> float | None:
    if value is None or not math.isfinite(value):
        return None
    return round(float(value), digits)


class Subscription:
    """One viewer's queue of snapshots (the oldest are dropped when it falls behind).

    Use :meth:`LiveView.subscribe` to get one and :meth:`LiveView.unsubscribe` to end it.
    """

    def __init__(self, loop: asyncio.AbstractEventLoop, maxsize: int) -> None:
        self.loop = loop
        self.queue: asyncio.Queue[dict[str, Any]] = asyncio.Queue(maxsize=maxsize)
        #: Snapshots this viewer lost because it fell behind.
        self.dropped = 0

    def put(self, snapshot: dict[str, Any]) -> None:
        """Queue a snapshot (call in the subscription's event loop)."""
        while self.queue.full():
            self.queue.get_nowait()
            self.dropped += 1
        self.queue.put_nowait(snapshot)

    async def get(self) -> dict[str, Any]:
        """The next snapshot."""
        return await self.queue.get()


class LiveView:
    """A control-room analyser and the snapshots it publishes.

    Parameters
    ----------
    track_map : TrackMap or None
        The network (None: the sector rule only).
    source : str
        What feeds the view, shown on the page (e.g. ``"replay of log.csv at 10x"``).
    make_analyser : callable, optional
        Returns a fresh analyser (default: ``Analyser(track_map=track_map)``); called
        again by :meth:`reset`.
    queue_size : int
        Snapshots kept per viewer that falls behind.
    on_snapshot : callable, optional
        Called with every snapshot published (e.g. to record the session), in the thread
        that ran the cycle.
    """

    def __init__(
        self,
        track_map: TrackMap | None,
        *,
        source: str = "",
        make_analyser: Callable[[], Analyser] | None = None,
        queue_size: int = 64,
        on_snapshot: Callable[[dict[str, Any]], None] | None = None,
    ) -> None:
        self.track_map = track_map
        self.source = source
        self._make = make_analyser or (lambda: Analyser(track_map=track_map))
        self.analyser = self._make()
        self.queue_size = queue_size
        self.on_snapshot = on_snapshot
        #: Number of the latest cycle (0 before the first).
        self.cycles = 0
        #: The latest snapshot (None before the first cycle).
        self.latest: dict[str, Any] | None = None
        #: The first cycle whose snapshot held a threat at level ``warning`` or above.
        self.first_warning_cycle: int | None = None
        #: Whether the feed has ended (a replay that reached its end).
        self.ended = False
        self._subs: set[Subscription] = set()
        self._lock = threading.Lock()
        self._viewer = threading.Event()

    # -- viewers ---------------------------------------------------------------------------
    def subscribe(self) -> Subscription:
        """A new viewer (call in the event loop that will read it); it gets the latest
        snapshot first."""
        sub = Subscription(asyncio.get_running_loop(), self.queue_size)
        with self._lock:
            self._subs.add(sub)
            latest = self.latest
        if latest is not None:
            sub.put(latest)
        self._viewer.set()
        return sub

    def unsubscribe(self, sub: Subscription) -> None:
        """End a viewer's subscription."""
        with self._lock:
            self._subs.discard(sub)

    @property
    def viewers(self) -> int:
        """Viewers subscribed now."""
        with self._lock:
            return len(self._subs)

    def has_had_viewer(self) -> bool:
        """Whether a viewer ever subscribed."""
        return self._viewer.is_set()

    async def wait_for_viewer(self) -> None:
        """Return once a viewer has subscribed."""
        while not self._viewer.is_set():
            await asyncio.sleep(0.05)

    def _publish(self, snapshot: dict[str, Any]) -> None:
        if self.on_snapshot is not None:
            self.on_snapshot(snapshot)
        with self._lock:
            self.latest = snapshot
            subs = list(self._subs)
        for sub in subs:
            try:
                running = asyncio.get_running_loop()
            except RuntimeError:
                running = None
            if running is sub.loop:
                sub.put(snapshot)
            else:  # published from a worker thread
                sub.loop.call_soon_threadsafe(sub.put, snapshot)

    # -- input -----------------------------------------------------------------------------
    def reset(self) -> None:
        """Start again with a fresh analyser (a replay that loops)."""
        self.analyser = self._make()

    def feed_bytes(self, data: bytes) -> int:
        """Feed radio frames (:func:`antikol.encode_report`); returns the reports accepted."""
        return sum(1 for u in self.analyser.feed_bytes(data) if u.accepted)

    def cycle(self, t: float | None, reports: Sequence[VehicleReport] = ()) -> dict[str, Any]:
        """Run one analysis cycle and publish its snapshot.

        Parameters
        ----------
        t : float or None
            Time of the cycle, s (the reports' clock); None: the newest report's time.
        reports : sequence of VehicleReport
            The reports received since the previous cycle.

        Returns
        -------
        dict
            The snapshot (see :meth:`snapshot`).
        """
        if reports:
            self.analyser.update_many(list(reports))
        assessments = self.analyser.assess_all(t=t) if len(self.analyser.table) else {}
        self.cycles += 1
        snap = self.snapshot(assessments, t)
        if self.first_warning_cycle is None and snap["warnings"]:
            self.first_warning_cycle = self.cycles
        self._publish(snap)
        return snap

    def end(self) -> None:
        """Mark the feed as ended and publish the last snapshot again, flagged ``end``."""
        self.ended = True
        last = dict(self.latest or self.snapshot({}, None))
        last["end"] = True
        self._publish(last)

    # -- output ----------------------------------------------------------------------------
    def snapshot(self, assessments: dict[str, Assessment], t: float | None) -> dict[str, Any]:
        """The JSON-ready state of the fleet after a cycle.

        Keys: ``cycle``, ``t`` (s), ``source``, ``end``, ``vehicles`` (each: ``id``,
        ``lat``, ``lon``, ``heading`` (deg), ``speed`` (m/s), ``status``, ``level``,
        ``lamp``, ``method``, ``threats``), ``warnings`` (threats at level ``warning`` or
        above, most severe first: ``own``, ``other``, ``kind``, ``level``, ``d`` (m),
        ``v`` (closing speed, m/s), ``ttc`` (s), ``held``, ``method``).
        """
        an = self.analyser
        vehicles: list[dict[str, Any]] = []
        warnings: list[dict[str, Any]] = []
        clock = t if t is not None else (an.table.clock if len(an.table) else None)
        for vid in sorted(assessments):
            a = assessments[vid]
            pos = an.position(vid, a.t)
            report = an.table.get(vid)
            if pos is not None:
                lat, lon = pos.lat, pos.lon
                heading, speed, status = pos.heading_deg, pos.speed_mps, pos.status
            elif report is not None:
                lat, lon = report.lat, report.lon
                heading, speed, status = report.course_deg, report.speed_mps, "unmatched"
            else:  # pragma: no cover - assessed vehicles are in the table
                continue
            threats = []
            for th in a.threats:
                item = {
                    "own": vid,
                    "other": th.vehicle_id,
                    "kind": th.kind,
                    "level": th.level,
                    "d": _num(th.distance_m),
                    "v": _num(th.closing_speed_mps),
                    "ttc": _num(th.ttc_s),
                    "held": th.held,
                    "method": th.method,
                }
                threats.append(item)
                if level_rank(th.level) >= level_rank("warning"):
                    warnings.append(item)
            vehicles.append(
                {
                    "id": vid,
                    "lat": round(float(lat), 7),
                    "lon": round(float(lon), 7),
                    "heading": _num(heading),
                    "speed": _num(speed),
                    "status": status,
                    "level": a.level,
                    "lamp": a.lamp,
                    "method": a.method,
                    "threats": threats,
                }
            )
        warnings.sort(key=lambda w: (-level_rank(w["level"]), w["d"] if w["d"] is not None else 0))
        return {
            "cycle": self.cycles,
            "t": _num(clock, 3),
            "source": self.source,
            "end": False,
            "vehicles": vehicles,
            "warnings": warnings,
        }
