"""The vehicle table: the paper's short-term database of nearby vehicles.

Semantics (from the paper, section 4.3, made precise):

* the first valid report of an unknown vehicle registers it in a free slot;
* later reports of a registered vehicle update its slot;
* a report not newer than the stored one (an out-of-order or repeated radio packet) is
  ignored and counted (``stale`` or ``duplicate``);
* a vehicle silent for more than ``expiry_s`` seconds of report time is removed
  (the paper's ~10 s, which rides out short radio outages);
* capacity counts the *other* vehicles; the own vehicle (``own_id``) always has its own
  slot and is never dropped.

Full-table policy: when a new vehicle arrives and every slot is taken (after expiry),
the table keeps the vehicles nearest to the own vehicle. If the newcomer is closer than the
farthest stored vehicle, the farthest is dropped (counted ``evicted``) and the newcomer takes
its slot; otherwise the newcomer is not registered (counted ``rejected_full``). Hence a
vehicle closer than one that is kept is never the one dropped. Distances are the paper's
planar formulas (4)-(8). Without an own position (no ``own_id`` or no own report yet), the
least recently heard vehicle is dropped instead.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Literal

import numpy as np

from antikol.analysis.geometry import paper_offsets
from antikol.errors import InvalidArgumentError
from antikol.report import VehicleReport

logger = logging.getLogger(__name__)

UpdateOutcome = Literal["registered", "updated", "stale", "duplicate", "rejected_full"]


@dataclass(frozen=True, slots=True)
class TableUpdate:
    """Outcome of :meth:`VehicleTable.update`.

    Attributes
    ----------
    outcome : str
        ``registered``, ``updated``, ``stale``, ``duplicate`` or ``rejected_full``.
    evicted : str or None
        Id of the vehicle dropped to make room, if any.
    expired : tuple of str
        Vehicles removed for silence while processing this update.
    """

    outcome: UpdateOutcome
    evicted: str | None = None
    expired: tuple[str, ...] = ()

    @property
    def accepted(self) -> bool:
        """True when the report is now stored in the table."""
        return self.outcome in ("registered", "updated")


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
        The own vehicle; it is never dropped and is the reference of the full-table policy.
    """

    def __init__(
        self, *, capacity: int | None = 32, expiry_s: float = 10.0, own_id: str | None = None
    ) -> None:
        if capacity is not None and capacity < 1:
            raise InvalidArgumentError("capacity", capacity, "must be >= 1 or None")
        if not np.isfinite(expiry_s) or expiry_s <= 0:
            raise InvalidArgumentError("expiry_s", expiry_s, "must be a positive number of seconds")
        self.capacity = capacity
        self.expiry_s = float(expiry_s)
        self.own_id = own_id
        self._reports: dict[str, VehicleReport] = {}
        self._clock: float = -np.inf
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
        """Newest report time seen, s (``-inf`` before the first report)."""
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

    # -- updates -------------------------------------------------------------------------
    def expire(self, now: float | None = None) -> list[str]:
        """Remove vehicles silent for more than ``expiry_s``.

        Parameters
        ----------
        now : float, optional
            Current time, s. Defaults to the table clock (newest report time seen).

        Returns
        -------
        list of str
            Ids of the removed vehicles (never the own vehicle).
        """
        if now is not None and now > self._clock:
            self._clock = float(now)
        limit = self._clock - self.expiry_s
        # the own vehicle keeps its slot through an outage of its own GPS: the unit must go
        # on assessing (on its dead-reckoned position) rather than forget itself
        gone = [vid for vid, r in self._reports.items() if r.t < limit and vid != self.own_id]
        for vid in gone:
            del self._reports[vid]
            self.stats["expired"] += 1
            logger.debug("vehicle %s expired (silent for more than %.1f s)", vid, self.expiry_s)
        return gone

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
        expired = tuple(self.expire(report.t))
        vid = report.vehicle_id
        stored = self._reports.get(vid)
        if stored is not None:
            if report.t < stored.t:
                self.stats["stale"] += 1
                logger.debug("stale report of %s ignored (t=%s < %s)", vid, report.t, stored.t)
                return TableUpdate("stale", expired=expired)
            if report.t == stored.t:
                self.stats["duplicate"] += 1
                return TableUpdate("duplicate", expired=expired)
            self._reports[vid] = report
            self.stats["updated"] += 1
            return TableUpdate("updated", expired=expired)
        if report.t < self._clock - self.expiry_s:
            self.stats["stale"] += 1
            return TableUpdate("stale", expired=expired)
        evicted: str | None = None
        if vid != self.own_id and self.capacity is not None and self.n_others() >= self.capacity:
            evicted = self._choose_victim(report)
            if evicted is None:
                self.stats["rejected_full"] += 1
                logger.debug("table full: %s not registered (farther than every stored one)", vid)
                return TableUpdate("rejected_full", expired=expired)
            del self._reports[evicted]
            self.stats["evicted"] += 1
            logger.debug("table full: %s dropped to register %s", evicted, vid)
        self._reports[vid] = report
        self.stats["registered"] += 1
        return TableUpdate("registered", evicted=evicted, expired=expired)

    def remove(self, vehicle_id: str) -> bool:
        """Remove a vehicle; returns whether it was present."""
        return self._reports.pop(vehicle_id, None) is not None

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
