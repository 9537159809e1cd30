"""The vehicle table: the paper's short-term database of nearby vehicles.

Semantics (from the paper, section 4.3, made precise):

* the first valid report of an unknown vehicle registers it in a free slot;
* later reports of a registered vehicle update its slot;
* a report not newer than the stored one (an out-of-order or repeated radio packet) is
  ignored and counted (``stale`` or ``duplicate``);
* a vehicle silent for more than ``expiry_s`` seconds of the table's clock is removed
  (the paper's ~10 s, which rides out short radio outages);
* capacity counts the *other* vehicles; the own vehicle (``own_id``) always has its own
  slot and is never dropped.

The clock
---------
The table's clock says what "now" is for expiry and for judging received reports. It is
never taken from a single received report, so one report dated ``t = 1e9`` (forged, or
from a unit with a wrong clock) can neither expire every vehicle nor make the table
forget the own vehicle:

* **on board** (``own_id`` given): the clock is the newest time of the *own* vehicle's
  reports, or a later time passed by the caller (:meth:`expire`, the analyser's
  ``assess(t=...)``; the on-board unit passes its local clock this way through an own GPS
  outage). Until the own vehicle has reported, other reports are held provisionally;
  when the clock starts, those more than ``clock_window_s`` ahead of it are dropped
  (``stats["dropped_ahead"]``). An own report far ahead of the real time (a GPS date or
  week-rollover glitch) moves the clock with it; when the next two own reports lie more
  than ``clock_window_s`` behind it and agree with each other (newer, within
  ``expiry_s``), the clock goes back to them (``stats["clock_rewound"]``) and the own
  vehicle's state restarts (it is listed in the update's ``expired``).
* **control room** (no ``own_id``): the clock is the *upper median* of the newest times of
  the last 32 distinct vehicles whose reports were accepted (or, with ``time_source``,
  the time it returns), and never goes back; the caller's times move it too. A minority
  of senders with wrong clocks cannot move it; with one or two senders it is the newest
  of them. If the first report was dated far ahead, more distinct senders disagreeing
  with the clock (their reports older than ``clock_window_s`` behind it) than recently
  accepted ones reset it to their median (``stats["clock_reset"]``) and the reports far
  ahead of it are dropped. After a gap in the feed longer than ``clock_window_s``, every
  sender comes back ahead of the clock: once most of the senders heard (recently accepted
  or refused as ahead) are refused as ahead, the clock moves forward to their median
  (``stats["clock_forward"]``) and the report is judged again.

A report of another vehicle more than ``clock_window_s`` (default 30 s) ahead of the clock
is rejected (outcome ``out_of_window``); one older than ``expiry_s`` behind it is
``stale``. The own vehicle's reports are never judged against the clock: they set it.

Full-table policy
-----------------
When a new vehicle arrives and every slot is taken (after expiry), the table keeps the
vehicles nearest to the own vehicle. If the newcomer is closer than the farthest stored
vehicle, the farthest is dropped (counted ``evicted``) and the newcomer takes its slot;
otherwise the newcomer is not registered (counted ``rejected_full``). A newcomer evicts
nobody on its first report: it must report a second time, consistently with the first
(newer, and no farther from it than 100 m/s allows plus 50 m), and have a position fix
(``fix_quality`` not 0); until then it is ``rejected_full`` (counted ``unconfirmed`` or
``rejected_implausible``). Among confirmed newcomers a vehicle closer than one that is
kept is never the one dropped. Distances are the paper's planar formulas (4)-(8). Without
an own position (no ``own_id`` or no own report yet), the least recently heard vehicle is
dropped instead. One forged frame thus cannot evict a real tram; a forger who keeps
sending can, which is what authenticated frames (:mod:`antikol.ingest.auth`) prevent.

New vehicles per cycle
----------------------
``max_new_ids`` caps the vehicles registered per ``new_id_period_s`` seconds of the
clock (outcome ``rejected_cap``): by default 1000 a second in a control room (no
capacity), unlimited on board (the capacity bounds the table). Ten thousand new ids in
one second thus add 1000 vehicles, not 10,000.
"""

from __future__ import annotations

import bisect
import heapq
import logging
import math
from collections import Counter, OrderedDict
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Final, Literal

import numpy as np

from antikol.analysis.geometry import paper_offsets
from antikol.errors import InvalidArgumentError
from antikol.numeric import finite_float, why_not_finite
from antikol.report import MAX_SPEED_MPS, VehicleReport

__all__ = [
    "CLOCK_WINDOW_S",
    "DEFAULT_MAX_NEW_IDS",
    "TableUpdate",
    "UpdateOutcome",
    "VehicleTable",
]

logger = logging.getLogger(__name__)

UpdateOutcome = Literal[
    "registered",
    "updated",
    "stale",
    "duplicate",
    "rejected_full",
    "out_of_window",
    "rejected_cap",
]

#: Default tolerance of a received report's time ahead of the table's clock, s.
CLOCK_WINDOW_S: Final = 30.0
#: Default cap of new vehicles per ``new_id_period_s`` in a table without capacity.
DEFAULT_MAX_NEW_IDS: Final = 1000
#: Distinct recently accepted senders whose times make the control-room clock.
_RECENT_SENDERS: Final = 32
#: Slack of the newcomer consistency check, m.
_CONFIRM_SLACK_M: Final = 50.0


@dataclass(frozen=True, slots=True)
class TableUpdate:
    """Outcome of :meth:`VehicleTable.update`.

    Attributes
    ----------
    outcome : str
        ``registered``, ``updated``, ``stale``, ``duplicate``, ``rejected_full``,
        ``out_of_window`` or ``rejected_cap``.
    evicted : str or None
        Id of the vehicle dropped to make room, if any.
    expired : tuple of str
        Vehicles removed for silence (or dropped as far ahead of a clock that just
        started or was reset) while processing this update.
    """

    outcome: UpdateOutcome
    evicted: str | None = None
    expired: tuple[str, ...] = ()

    @property
    def accepted(self) -> bool:
        """True when the report is now stored in the table."""
        return self.outcome in ("registered", "updated")


#: The outcome of most reports (an update that expired nobody); records are immutable.
_UPDATED: Final = TableUpdate("updated")


class _RecentSenders:
    """The newest time of each of the last ``limit`` distinct senders, in the order they
    were last heard, with the times also kept sorted: the control-room clock reads their
    upper median at every accepted report."""

    __slots__ = ("_limit", "_sorted", "_times")

    def __init__(self, limit: int, items: Iterable[tuple[str, float]] = ()) -> None:
        self._limit = limit
        self._times: OrderedDict[str, float] = OrderedDict(items)
        self._sorted = sorted(self._times.values())

    def __len__(self) -> int:
        return len(self._times)

    def __contains__(self, vid: object) -> bool:
        return vid in self._times

    def put(self, vid: str, t: float) -> None:
        """Record a sender's newest time (it becomes the most recent sender)."""
        times = self._times
        old = times.get(vid)
        if old is not None:
            self._discard(old)
        times[vid] = t
        times.move_to_end(vid)
        bisect.insort(self._sorted, t)
        while len(times) > self._limit:
            self._discard(times.popitem(last=False)[1])

    def pop(self, vid: str) -> None:
        """Forget a sender (no error when unknown)."""
        old = self._times.pop(vid, None)
        if old is not None:
            self._discard(old)

    def upper_median(self) -> float | None:
        """The upper median of the senders' times (None without senders)."""
        ordered = self._sorted
        return ordered[len(ordered) // 2] if ordered else None

    def _discard(self, t: float) -> None:
        ordered = self._sorted
        del ordered[bisect.bisect_left(ordered, t)]


class VehicleTable:
    """Fixed-capacity table of the latest report per vehicle.

    Parameters
    ----------
    capacity : int or None
        Maximum number of *other* vehicles (paper: 32). ``None`` means unbounded
        (a control-room view of a whole fleet).
    expiry_s : float
        A vehicle whose newest report is more than this many seconds older than the table
        clock is removed, s.
    own_id : str, optional
        The own vehicle; it is never dropped, its reports set the clock and it is the
        reference of the full-table policy.
    clock_window_s : float or None
        A report of another vehicle more than this far ahead of the clock is rejected, s
        (default 30). None accepts any time (and lets reports move the clock, as before
        version 0.3).
    max_new_ids : int, None or "auto"
        New vehicles registered per ``new_id_period_s`` at most; None is unlimited;
        ``"auto"``: :data:`DEFAULT_MAX_NEW_IDS` without capacity, unlimited with one.
    new_id_period_s : float
        The period of ``max_new_ids``, s of the clock (default 1).
    time_source : callable, optional
        Returns the current time in report time (a control room's local clock); the
        clock follows it.

    Examples
    --------
    >>> from antikol.report import VehicleReport
    >>> table = VehicleTable(own_id="A")
    >>> table.update(VehicleReport("A", 100.0, 50.0, 19.9, 8.0, 90.0)).outcome
    'registered'
    >>> table.update(VehicleReport("X", 1e9, 50.0, 19.91, 8.0, 90.0)).outcome
    'out_of_window'
    >>> table.clock, table.stats["out_of_window"]
    (100.0, 1)
    """

    def __init__(
        self,
        *,
        capacity: int | None = 32,
        expiry_s: float = 10.0,
        own_id: str | None = None,
        clock_window_s: float | None = CLOCK_WINDOW_S,
        max_new_ids: int | Literal["auto"] | None = "auto",
        new_id_period_s: float = 1.0,
        time_source: Callable[[], float] | None = None,
    ) -> None:
        if capacity is not None and (
            isinstance(capacity, bool) or not isinstance(capacity, int) or capacity < 1
        ):
            raise InvalidArgumentError("capacity", capacity, "must be an int >= 1 or None")
        if not _positive(expiry_s):
            raise InvalidArgumentError("expiry_s", expiry_s, "must be a positive number of seconds")
        if clock_window_s is not None and not _positive(clock_window_s):
            raise InvalidArgumentError("clock_window_s", clock_window_s, "must be > 0 s or None")
        if max_new_ids == "auto":
            max_new_ids = DEFAULT_MAX_NEW_IDS if capacity is None else None
        if max_new_ids is not None and (
            isinstance(max_new_ids, bool) or not isinstance(max_new_ids, int) or max_new_ids < 1
        ):
            raise InvalidArgumentError("max_new_ids", max_new_ids, "must be an int >= 1 or None")
        if not _positive(new_id_period_s):
            raise InvalidArgumentError("new_id_period_s", new_id_period_s, "must be > 0 s")
        self.capacity = capacity
        self.expiry_s = float(expiry_s)
        self.own_id = own_id
        self.clock_window_s = None if clock_window_s is None else float(clock_window_s)
        self.max_new_ids = max_new_ids
        self.new_id_period_s = float(new_id_period_s)
        self.time_source = time_source
        self._reports: dict[str, VehicleReport] = {}
        self._heap: list[tuple[float, str]] = []  # (t, vid); stale entries skipped
        self._clock: float = -math.inf
        self._started = False  # on board: the own vehicle (or the caller) set the clock
        self._explicit: float = -math.inf
        self._recent = _RecentSenders(_RECENT_SENDERS)
        self._dissent: OrderedDict[str, float] = OrderedDict()
        self._ahead: OrderedDict[str, float] = OrderedDict()
        self._own_behind: float | None = None
        self._pending: OrderedDict[str, VehicleReport] = OrderedDict()
        self._new_period: int | None = None
        self._new_count = 0
        self.stats: Counter[str] = Counter()

    # -- queries -------------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self._reports)

    def __contains__(self, vehicle_id: object) -> bool:
        return vehicle_id in self._reports

    def __iter__(self) -> Iterator[VehicleReport]:
        return iter(list(self._reports.values()))

    @property
    def clock(self) -> float:
        """The table's current time, s (``-inf`` before it has one); see *The clock*."""
        return self._clock

    def get(self, vehicle_id: str) -> VehicleReport | None:
        """The latest stored report of a vehicle, or None."""
        return self._reports.get(vehicle_id)

    def others(self, own_id: str) -> list[VehicleReport]:
        """Reports of every stored vehicle except ``own_id``."""
        return [r for vid, r in self._reports.items() if vid != own_id]

    def vehicle_ids(self) -> list[str]:
        """Ids of the stored vehicles in registration order."""
        return list(self._reports)

    def n_others(self) -> int:
        """Number of stored vehicles that are not the own vehicle."""
        return len(self._reports) - (1 if self.own_id in self._reports else 0)

    # -- the clock -----------------------------------------------------------------------
    def _advance(self, now: float) -> list[str]:
        """Move the clock forward to ``now`` (a trusted time); returns dropped vehicles."""
        if now <= self._clock:
            return []
        self._clock = now
        if self.own_id is not None and not self._started:
            self._started = True
            return self._drop_ahead()
        return []

    def _drop_ahead(self) -> list[str]:
        """Drop other vehicles dated more than the window ahead of the clock."""
        if self.clock_window_s is None:
            return []
        limit = self._clock + self.clock_window_s
        gone = [v for v, r in self._reports.items() if r.t > limit and v != self.own_id]
        for vid in gone:
            del self._reports[vid]
            self._recent.pop(vid)
            self.stats["dropped_ahead"] += 1  # (not a refused report: out_of_window)
            logger.info("vehicle %s dropped: dated beyond the table clock %.1f", vid, self._clock)
        return gone

    def _dissent_from(self, vid: str, t: float) -> list[str]:
        """Control room: a sender far behind the clock; reset it if they outnumber."""
        self._dissent[vid] = t
        self._dissent.move_to_end(vid)
        while len(self._dissent) > _RECENT_SENDERS:
            self._dissent.popitem(last=False)
        if self.time_source is not None or len(self._dissent) <= len(self._recent):
            return []
        times = sorted(self._dissent.values())
        median = times[(len(times) - 1) // 2]
        logger.warning(
            "table clock %.1f reset to %.1f: %d senders disagree with it",
            self._clock,
            median,
            len(times),
        )
        self.stats["clock_reset"] += 1
        self._clock = max(median, self._explicit)
        self._recent = _RecentSenders(_RECENT_SENDERS, self._dissent.items())
        self._dissent.clear()
        self._ahead.clear()
        return self._drop_ahead()

    def _ahead_from(self, vid: str, t: float) -> list[str]:
        """Control room: a sender far ahead of the clock; move the clock to the senders
        ahead once they are most of the senders heard (the feed was silent for longer than
        the window: without this, every report after the gap was ``out_of_window`` and the
        clock never moved again)."""
        ahead = self._ahead
        ahead[vid] = t
        ahead.move_to_end(vid)
        while len(ahead) > _RECENT_SENDERS:
            ahead.popitem(last=False)
        heard = len(self._recent) + sum(1 for v in ahead if v not in self._recent)
        if self.time_source is not None or 2 * len(ahead) <= heard:
            return []
        times = sorted(ahead.values())
        median = times[(len(times) - 1) // 2]
        logger.warning(
            "table clock %.1f moved forward to %.1f: %d of %d senders are ahead of it",
            self._clock,
            median,
            len(times),
            heard,
        )
        self.stats["clock_forward"] += 1
        self._clock = max(median, self._clock)
        self._recent = _RecentSenders(_RECENT_SENDERS, ahead.items())
        ahead.clear()
        self._dissent.clear()
        return self._sweep([])

    def _rewind_own(self, report: VehicleReport) -> bool:
        """On board: whether this own report, far behind the stored own report, is the
        second in a row that agrees with the one before it, so that the stored one was a
        glitch (a GPS date or week-rollover error dated a day ahead); the clock then goes
        back to it. Without this, one glitched own fix made every later report ``stale``
        until the real time caught up with it."""
        stored = self._reports.get(report.vehicle_id)
        window = self.clock_window_s
        if stored is None or window is None or report.t >= stored.t - window:
            self._own_behind = None
            return False
        before, self._own_behind = self._own_behind, report.t
        if before is None or not 0.0 < report.t - before <= self.expiry_s:
            return False
        logger.warning(
            "own report dated %.1f s before the stored one (t=%.1f): table clock rewound",
            stored.t - report.t,
            stored.t,
        )
        self.stats["clock_rewound"] += 1
        self._own_behind = None
        self._clock = self._explicit = report.t
        return True

    # -- updates -------------------------------------------------------------------------
    def expire(self, now: float | None = None) -> list[str]:
        """Remove vehicles silent for more than ``expiry_s``.

        Parameters
        ----------
        now : float, optional
            Current time, s, from the caller (trusted: it moves the clock forward).
            Defaults to the table clock.

        Returns
        -------
        list of str
            Ids of the removed vehicles (never the own vehicle).

        Raises
        ------
        InvalidArgumentError
            ``now`` is not a finite number (nothing is changed).
        """
        if now is not None:
            if finite_float(now) is None:
                raise InvalidArgumentError("now", now, why_not_finite(now))
            now = float(now)
        if now is None and self.time_source is None:
            # the clock stands still: nothing to do unless the oldest entry is due (the
            # common case, checked at every report and every assessment)
            heap = self._heap
            if not heap or heap[0][0] >= self._clock - self.expiry_s:
                return []
            return self._sweep([])
        gone: list[str] = []
        if now is not None:
            self._explicit = max(self._explicit, float(now))
            gone += self._advance(float(now))
        if self.time_source is not None:
            gone += self._advance(float(self.time_source()))
        return self._sweep(gone)

    def _sweep(self, gone: list[str]) -> list[str]:
        """Remove the vehicles whose newest report is older than the clock's expiry limit
        (appended to ``gone``, which is returned)."""
        limit = self._clock - self.expiry_s
        heap = self._heap
        while heap and heap[0][0] < limit:
            t, vid = heapq.heappop(heap)
            report = self._reports.get(vid)
            # the own vehicle keeps its slot through an outage of its own GPS: the unit
            # must go on assessing (on its dead-reckoned position) rather than forget itself
            if report is None or report.t != t or vid == self.own_id:
                continue
            del self._reports[vid]
            self._recent.pop(vid)
            self.stats["expired"] += 1
            gone.append(vid)
            logger.debug("vehicle %s expired (silent for more than %.1f s)", vid, self.expiry_s)
        return gone

    def _store(self, report: VehicleReport) -> None:
        self._reports[report.vehicle_id] = report
        heap = self._heap
        heapq.heappush(heap, (report.t, report.vehicle_id))
        if len(heap) > 4 * len(self._reports) + 64:
            # the entries of superseded reports wait in the heap until they are due:
            # rebuild it from the stored reports once they outnumber them
            self._heap = [(r.t, v) for v, r in self._reports.items()]
            heapq.heapify(self._heap)

    def update(self, report: VehicleReport) -> TableUpdate:
        """Store a report according to the table's rules.

        Parameters
        ----------
        report : VehicleReport
            A validated report of any vehicle, own or other.

        Returns
        -------
        TableUpdate
            What happened to the report (and who was evicted or expired).
        """
        vid = report.vehicle_id
        own = vid == self.own_id
        rewound = own and self._rewind_own(report)
        if rewound:
            # the glitch's state goes: its own report, and the reports dated after it
            del self._reports[vid]
            expired = [vid, *self._drop_ahead()]
        elif own or self.time_source is not None:
            expired = self.expire(report.t if own else None)
        else:  # expire() without a time, inlined: checked at every report
            heap = self._heap
            due = bool(heap) and heap[0][0] < self._clock - self.expiry_s
            expired = self._sweep([]) if due else []
        outcome = self._judge(report, own)
        if outcome == "out_of_window" and self.own_id is None:
            clock = self._clock
            forward = self._ahead_from(vid, report.t)
            if self._clock != clock:  # the report is judged again against the new clock
                expired += forward
                outcome = self._judge(report, own)
        if outcome is not None:
            if outcome == "stale" and self.own_id is None and not own:
                window = self.clock_window_s
                if window is not None and report.t < self._clock - window:
                    expired += self._dissent_from(vid, report.t)
            self.stats[outcome] += 1
            return TableUpdate(outcome, expired=tuple(expired))
        if vid in self._reports:
            self._store(report)
            self.stats["updated"] += 1
            result = TableUpdate("updated", expired=tuple(expired)) if expired else _UPDATED
        else:
            result = self._register(report, own, expired)
        if self.own_id is None and result.accepted:
            self._recent.put(vid, report.t)
            if self._dissent:
                self._dissent.pop(vid, None)
            if self._ahead:
                self._ahead.pop(vid, None)
            median = self._recent.upper_median()  # the control-room clock
            moved = median is not None and median > self._clock
            if median is not None and moved:
                self._advance(median)
            if moved or self.time_source is not None:
                more = self.expire()
                if more:
                    result = TableUpdate(
                        result.outcome, result.evicted, result.expired + tuple(more)
                    )
        return result

    def _judge(self, report: VehicleReport, own: bool) -> UpdateOutcome | None:
        """The outcome of a report that is not stored, or None when it may be."""
        stored = self._reports.get(report.vehicle_id)
        if stored is not None:
            if report.t < stored.t:
                logger.debug(
                    "stale report of %s ignored (t=%s < %s)", report.vehicle_id, report.t, stored.t
                )
                return "stale"
            if report.t == stored.t:
                return "duplicate"
        if own:
            return None
        window = self.clock_window_s
        if window is not None and math.isfinite(self._clock):
            started = self.own_id is None or self._started
            if started and report.t > self._clock + window:
                logger.debug(
                    "report of %s dated %.1f s ahead of the clock rejected",
                    report.vehicle_id,
                    report.t - self._clock,
                )
                return "out_of_window"
        if report.t < self._clock - self.expiry_s:
            return "stale"
        return None

    def _register(self, report: VehicleReport, own: bool, expired: list[str]) -> TableUpdate:
        vid = report.vehicle_id
        if not own and self.max_new_ids is not None:
            ref = self._clock if math.isfinite(self._clock) else report.t
            period = math.floor(ref / self.new_id_period_s)
            if period != self._new_period:
                self._new_period, self._new_count = period, 0
            if self._new_count >= self.max_new_ids:
                self.stats["rejected_cap"] += 1
                return TableUpdate("rejected_cap", expired=tuple(expired))
        evicted: str | None = None
        if not own and self.capacity is not None and self.n_others() >= self.capacity:
            evicted = self._make_room(report)
            if evicted is None:
                self.stats["rejected_full"] += 1
                return TableUpdate("rejected_full", expired=tuple(expired))
            del self._reports[evicted]
            self._recent.pop(evicted)
            self.stats["evicted"] += 1
            logger.debug("table full: %s dropped to register %s", evicted, vid)
        self._pending.pop(vid, None)
        self._store(report)
        if not own:
            self._new_count += 1
        self.stats["registered"] += 1
        return TableUpdate("registered", evicted=evicted, expired=tuple(expired))

    def remove(self, vehicle_id: str) -> bool:
        """Remove a vehicle; returns whether it was present."""
        self._recent.pop(vehicle_id)
        return self._reports.pop(vehicle_id, None) is not None

    # -- full table ------------------------------------------------------------------------
    def _make_room(self, newcomer: VehicleReport) -> str | None:
        """The vehicle to drop for a plausible, confirmed newcomer, or None."""
        if newcomer.fix_quality == 0:
            self.stats["rejected_implausible"] += 1
            return None
        first = self._pending.get(newcomer.vehicle_id)
        if first is None or not _consistent(first, newcomer, self.expiry_s):
            self._pending[newcomer.vehicle_id] = newcomer
            self._pending.move_to_end(newcomer.vehicle_id)
            while len(self._pending) > max(self.capacity or 0, 32):
                self._pending.popitem(last=False)
            self.stats["unconfirmed"] += 1
            return None
        victim = self._choose_victim(newcomer)
        if victim is None:
            self._pending[newcomer.vehicle_id] = newcomer  # confirmed again next time
        return victim

    def _choose_victim(self, newcomer: VehicleReport) -> str | None:
        candidates = [r for vid, r in self._reports.items() if vid != self.own_id]
        own = self._reports.get(self.own_id) if self.own_id is not None else None
        if own is None:
            return min(candidates, key=lambda r: r.t).vehicle_id
        lat = np.array([r.lat for r in candidates] + [newcomer.lat])
        lon = np.array([r.lon for r in candidates] + [newcomer.lon])
        distance, _ = paper_offsets(own.lat, own.lon, lat, lon)
        farthest = int(np.argmax(distance[:-1]))
        if distance[-1] < distance[farthest]:
            return candidates[farthest].vehicle_id
        return None


def _positive(value: object) -> bool:
    return (
        isinstance(value, (int, float))
        and not isinstance(value, bool)
        and math.isfinite(value)
        and value > 0
    )


def _consistent(first: VehicleReport, second: VehicleReport, expiry_s: float) -> bool:
    """Whether two reports of one newcomer can be the same vehicle moving."""
    dt = second.t - first.t
    if not 0.0 < dt <= expiry_s:
        return False
    distance, _ = paper_offsets(
        first.lat, first.lon, np.array([second.lat]), np.array([second.lon])
    )
    return bool(distance[0] <= MAX_SPEED_MPS * dt + _CONFIRM_SLACK_M)
