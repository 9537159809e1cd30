"""Replay protection for received reports: a per-sender sequence window and a time window.

An authenticated frame (see :mod:`antikol.ingest.auth`) cannot be forged, but it can be
recorded and sent again: to resurrect a tram where it was a minute ago, or to flood a
receiver with duplicates. :class:`ReplayGuard` checks every authenticated report against

* the receiver's own clock: a report dated more than ``max_age_s`` before it (a replay, a
  frame held back, a sender whose clock is late) or more than ``max_ahead_s`` after it (a
  sender whose clock is wrong) is rejected (``"too_old"``, ``"future"``);
* the sender's sequence numbers, as IPsec does (RFC 4303, section 3.4.3): it keeps the
  highest number seen and a bitmap of the ``seq_window`` numbers below it. A number seen
  before is a ``"duplicate"``; a newer number with an older time than the sender's newest
  report is a ``"replay"``; a newer number ``seq_window`` or more ahead (frames lost, e.g.
  in a tunnel) leaves only itself in the window, however far ahead it is. A number below
  the window is a ``"replay"`` too, unless the report is also newer than every report of
  that sender so far (the sender restarted and its numbers began again), which restarts
  the window (counted in ``stats["resync"]``); a number in the restarted window but dated
  before the restart is a ``"replay"``.
  Numbers wrap at 2**32 (serial number arithmetic, RFC 1982).

A report that is rejected leaves the state unchanged, so a forged report can never move a
sender's window. The state is bounded: the least recently heard senders beyond
``max_senders`` are forgotten.

>>> from antikol.report import VehicleReport
>>> guard = ReplayGuard()
>>> r = VehicleReport("T1", 100.0, 50.0, 19.9, 8.0, 90.0, seq=7)
>>> guard.check(r, now=100.4), guard.check(r, now=100.5)
(None, 'duplicate')
>>> guard.check(VehicleReport("T1", 50.0, 50.0, 19.9, 8.0, 90.0, seq=8), now=100.5)
'too_old'
"""

from __future__ import annotations

import logging
import math
from collections import Counter, OrderedDict
from dataclasses import dataclass
from typing import Final

from antikol.errors import InvalidArgumentError
from antikol.report import VehicleReport

__all__ = ["GUARD_REASONS", "ReplayGuard"]

logger = logging.getLogger(__name__)

#: Why :meth:`ReplayGuard.check` rejects a report.
GUARD_REASONS: Final = ("no_clock", "too_old", "future", "duplicate", "replay")

_MOD: Final = 1 << 32
_HALF: Final = 1 << 31


@dataclass(slots=True)
class _Sender:
    highest: int
    bitmap: int  # bit i set: highest - i was seen
    newest_t: float
    restart_t: float = -math.inf  # time of the report its numbers began again with


class ReplayGuard:
    """Rejects replayed, duplicated and far-past or future reports.

    Parameters
    ----------
    seq_window : int
        Sequence numbers below the highest one that are still accepted once (reordered
        frames), 1..1024 (default 64).
    max_age_s : float
        Oldest report accepted, seconds before the receiver's clock (default 5 s).
    max_ahead_s : float
        Newest report accepted, seconds after the receiver's clock (default 2 s).
    max_senders : int
        Senders whose windows are kept (default 4096).

    Attributes
    ----------
    stats : collections.Counter
        Rejections by reason (:data:`GUARD_REASONS`), ``accepted`` and ``resync``.
    """

    def __init__(
        self,
        *,
        seq_window: int = 64,
        max_age_s: float = 5.0,
        max_ahead_s: float = 2.0,
        max_senders: int = 4096,
    ) -> None:
        if isinstance(seq_window, bool) or not isinstance(seq_window, int):
            raise InvalidArgumentError("seq_window", seq_window, "must be an int")
        if not 1 <= seq_window <= 1024:
            raise InvalidArgumentError("seq_window", seq_window, "must be in 1..1024")
        for name, value in (("max_age_s", max_age_s), ("max_ahead_s", max_ahead_s)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise InvalidArgumentError(name, value, "must be a finite number >= 0 s")
        if isinstance(max_senders, bool) or not isinstance(max_senders, int) or max_senders < 1:
            raise InvalidArgumentError("max_senders", max_senders, "must be an int >= 1")
        self.seq_window = seq_window
        self.max_age_s = float(max_age_s)
        self.max_ahead_s = float(max_ahead_s)
        self.max_senders = max_senders
        self._senders: OrderedDict[str, _Sender] = OrderedDict()
        self.stats: Counter[str] = Counter()

    def __len__(self) -> int:
        return len(self._senders)

    def check(self, report: VehicleReport, now: float | None) -> str | None:
        """Check one report and, if it passes, record it.

        Parameters
        ----------
        report : VehicleReport
            A decoded, authenticated report (``seq`` set; a missing ``seq`` counts as 0).
        now : float or None
            The receiver's clock in report time, s; None when it has none yet (every
            report is then rejected as ``"no_clock"``).

        Returns
        -------
        str or None
            None when the report is fresh, else the reason (:data:`GUARD_REASONS`).
        """
        reason = self._check(report, now)
        if reason is None:
            self.stats["accepted"] += 1
        else:
            self.stats[reason] += 1
            logger.debug("report of %s rejected: %s", report.vehicle_id, reason)
        return reason

    def _check(self, report: VehicleReport, now: float | None) -> str | None:
        if now is None:
            return "no_clock"
        t = report.t
        if t > now + self.max_ahead_s:
            return "future"
        if t < now - self.max_age_s:
            return "too_old"
        seq = (report.seq or 0) % _MOD
        vid = report.vehicle_id
        state = self._senders.get(vid)
        if state is None:
            self._remember(vid, _Sender(seq, 1, t))
            return None
        ahead = (seq - state.highest) % _MOD
        if ahead == 0:
            return "duplicate"
        if ahead < _HALF:  # newer than every number so far
            if t < state.newest_t:  # a genuine sender's times never go back with its numbers
                return "replay"
            # no number seen stays in the window past a jump of its size, and shifting by
            # ``ahead`` (up to 2**31, as the frame says) would build an integer that long
            if ahead < self.seq_window:
                state.bitmap = ((state.bitmap << ahead) | 1) & ((1 << self.seq_window) - 1)
            else:
                state.bitmap = 1
            state.highest = seq
        else:
            behind = _MOD - ahead
            if behind < self.seq_window:
                if state.bitmap >> behind & 1:
                    return "duplicate"
                if t < state.restart_t:  # a number of before the restart, sent again
                    return "replay"
                state.bitmap |= 1 << behind
            elif t > state.newest_t:  # numbers began again: the sender restarted
                self.stats["resync"] += 1
                state.highest, state.bitmap, state.restart_t = seq, 1, t
            else:
                return "replay"
        state.newest_t = max(state.newest_t, t)
        self._senders.move_to_end(vid)
        return None

    def _remember(self, vid: str, state: _Sender) -> None:
        self._senders[vid] = state
        if len(self._senders) > self.max_senders:
            self._senders.popitem(last=False)

    def forget(self, vehicle_id: str) -> None:
        """Drop a sender's window (e.g. when its key is revoked)."""
        self._senders.pop(vehicle_id, None)
