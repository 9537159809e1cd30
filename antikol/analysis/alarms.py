"""The lamp a driver can trust: alarm state per pair of vehicles, with hysteresis.

A lamp that blinks on and off through one approach, or stays on "to be safe", is a lamp a
driver switches off. The alarm of each pair (own vehicle, other vehicle) therefore has a
state with three rules:

* **raise** when the evaluated level reaches ``warning`` (the warning distance, with its
  margin, is reached);
* **hold** while the conflict is not clearly over: the same conflict is still found, the gap
  is still closing and within the warning distance plus a release margin
  (``release_margin_m + release_time_s x closing speed``) — no release while closing; and
  in any case for ``min_on_s`` after it was raised;
* **release** otherwise — the gap opens, the conflict is gone (the other vehicle took
  another branch, passed, stopped far enough) — once that has lasted ``release_after_s``
  (a one-cycle dip does not blink the lamp).

The vehicle's lamp is on while any of its pair alarms is on. Every change of state is
counted (:attr:`AlarmBook.toggles`), so the flicker of a configuration can be measured.

A replay that starts in the middle of traffic cannot know the alarms of pairs already in
conflict: a pair held (not raised) at its first evaluation is off here but may have been
on. :meth:`AlarmBook.unsettled` lists the pairs whose state may still depend on what came
before a given time: not yet clear long enough since for any alarm to be released.

>>> from antikol.analysis.alarms import AlarmBook, AlarmPolicy
>>> book = AlarmBook(AlarmPolicy(min_on_s=3.0))
>>> book.step("A", "B", 0.0, raise_now=True, hold=False)
True
>>> book.step("A", "B", 1.0, raise_now=False, hold=False)   # held: on for 3 s at least
True
>>> book.step("A", "B", 3.5, raise_now=False, hold=False)   # clear for 2 s: released
False
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

__all__ = ["AlarmBook", "AlarmPolicy", "PairAlarm"]


@dataclass(frozen=True, slots=True)
class AlarmPolicy:
    """When a pair alarm may be released (SI units).

    Attributes
    ----------
    min_on_s : float
        An alarm stays on at least this long, s.
    release_margin_m : float
        A closing conflict keeps its alarm until the gap exceeds the warning distance by
        this much, m ...
    release_time_s : float
        ... plus this many seconds of closing, s.
    release_after_s : float
        The conditions for release must hold this long, s.
    forget_s : float
        A pair not evaluated for this long is dropped from the book, s.
    """

    min_on_s: float = 3.0
    release_after_s: float = 2.0
    release_margin_m: float = 15.0
    release_time_s: float = 3.0
    forget_s: float = 30.0


@dataclass(slots=True)
class PairAlarm:
    """State of one pair's alarm."""

    on: bool = False
    since: float = 0.0
    last_seen: float = 0.0
    last_step: float = float("-inf")
    first_step: float = float("nan")
    last_raise: float = float("-inf")
    settled: bool = False


@dataclass
class AlarmBook:
    """Alarm states of every pair of an analyser.

    Parameters
    ----------
    policy : AlarmPolicy
    """

    policy: AlarmPolicy = field(default_factory=AlarmPolicy)
    toggles: Counter[str] = field(default_factory=Counter)
    _pairs: dict[tuple[str, str], PairAlarm] = field(default_factory=dict)
    _on: dict[str, set[str]] = field(default_factory=dict)  # own -> others with the alarm on

    def step(self, own: str, other: str, t: float, *, raise_now: bool, hold: bool) -> bool:
        """Advance one pair's alarm to time ``t`` (s); returns whether it is on.

        Parameters
        ----------
        own, other : str
            The pair (the alarm belongs to ``own``'s lamp).
        t : float
            Time of the evaluation, s. Repeated calls at the same time change nothing.
        raise_now : bool
            The conflict is at warning level or above now.
        hold : bool
            The conflict is not clearly over (see the module).
        """
        key = (own, other)
        state = self._pairs.get(key)
        if state is None:
            state = self._pairs[key] = PairAlarm()
        if t <= state.last_step:
            return state.on
        if state.first_step != state.first_step:  # NaN: the first evaluation
            # as if seen at the first evaluation: a longer history may have held it till now
            state.first_step = state.last_seen = t
        state.last_step = t
        if raise_now or hold:
            state.last_seen = t
        if raise_now:
            state.last_raise = t
            if not state.on:
                state.on, state.since = True, t
                self.toggles[own] += 1
                self._on.setdefault(own, set()).add(other)
            self._settle(state, t)
            return True
        quiet = t - state.last_seen
        if (
            state.on
            and not hold
            and t - state.since >= self.policy.min_on_s
            and quiet >= self.policy.release_after_s
        ):
            state.on = False
            self.toggles[own] += 1
            self._on.get(own, set()).discard(other)
        self._settle(state, t)
        return state.on

    def _settle(self, state: PairAlarm, t: float) -> None:
        """Mark a pair whose state no longer depends on evaluations before its first.

        Two histories of a pair agree for good once both are off (an alarm that is off
        remembers nothing that matters). An alarm held from before the first evaluation, or
        raised since, is surely released by now when the pair has been clear for
        ``release_after_s`` and neither the first evaluation nor the last raise is within
        ``min_on_s``: then it is off here and in any longer history.
        """
        if state.settled or state.on:
            return
        p = self.policy
        state.settled = (
            t - state.last_seen >= p.release_after_s
            and t - max(state.first_step, state.last_raise) >= p.min_on_s
        )

    def unsettled(self, since_t: float) -> list[tuple[str, str]]:
        """Pairs whose alarm state may depend on evaluations before ``since_t`` (s).

        A pair is unsettled when it was first evaluated at or before ``since_t`` and has
        not since been clear long enough for any alarm to be released (see
        :meth:`_settle`): with a longer history it could be on where it is off, or have
        been raised earlier and be released at another time.
        """
        return sorted(
            key for key, s in self._pairs.items() if not s.settled and s.first_step <= since_t
        )

    def is_on(self, own: str, other: str) -> bool:
        """Whether a pair's alarm is on."""
        state = self._pairs.get((own, other))
        return state is not None and state.on

    def active(self, own: str) -> list[str]:
        """The other vehicles whose alarm is on for ``own``."""
        return sorted(self._on.get(own, ()))

    def forget(self, vehicle_id: str) -> None:
        """Drop every pair of a vehicle (it left the table)."""
        for key in [k for k in self._pairs if vehicle_id in k]:
            del self._pairs[key]
        self._on.pop(vehicle_id, None)
        for others in self._on.values():
            others.discard(vehicle_id)

    def prune(self, t: float) -> None:
        """Drop pairs that are off and have not been evaluated for ``forget_s``."""
        limit = t - self.policy.forget_s
        for key in [k for k, s in self._pairs.items() if not s.on and s.last_step < limit]:
            del self._pairs[key]
