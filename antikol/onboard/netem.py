"""A lossy radio on loopback: a UDP relay that impairs what the units send each other.

For tests only (127.0.0.1). Every unit sends its frames to the relay; the relay forwards a
copy to every other unit, and on each copy independently applies loss, delay and jitter,
duplication, reordering (a copy held back), corruption (bit flips) and, per sender, a
blackout (every copy dropped in a window of report time). Random draws come from one
seeded generator per link, so the impairment of a link depends only on the order of its
packets. The relay may also copy every datagram, unimpaired, to a *tap* (the attacker's
sniffer: what anyone near the track hears).
"""

from __future__ import annotations

import heapq
import logging
import random
import selectors
import socket
import threading
import time
import zlib
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Final

from antikol.errors import InvalidArgumentError

__all__ = ["Impairment", "Relay"]

logger = logging.getLogger(__name__)

_MAX_HELD: Final = 100_000


@dataclass(frozen=True)
class Impairment:
    """What happens to each copy of a datagram on its way to one receiver.

    Attributes
    ----------
    loss : float
        Probability that a copy is lost, 0..1.
    delay_s, jitter_s : float
        Fixed delay plus a uniform random one in ``[0, jitter_s]``, wall-clock s.
    duplicate : float
        Probability that a copy is delivered twice (the second after a further jitter).
    reorder : float
        Probability that a copy is held back by ``reorder_s`` more (delivered after
        later ones).
    reorder_s : float
        Hold-back of reordered copies, wall-clock s.
    corrupt : float
        Probability that a copy gets 1 to 3 flipped bits.
    blackouts : tuple of (str, float, float)
        ``(sender, start, end)``: every copy from ``sender`` sent at report times in
        ``[start, end)`` is dropped.
    """

    loss: float = 0.0
    delay_s: float = 0.0
    jitter_s: float = 0.0
    duplicate: float = 0.0
    reorder: float = 0.0
    reorder_s: float = 0.0
    corrupt: float = 0.0
    blackouts: tuple[tuple[str, float, float], ...] = ()

    def __post_init__(self) -> None:
        for name in ("loss", "duplicate", "reorder", "corrupt"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise InvalidArgumentError(name, value, "must be a probability in [0, 1]")
        for name in ("delay_s", "jitter_s", "reorder_s"):
            if not 0.0 <= getattr(self, name) <= 10.0:
                raise InvalidArgumentError(name, getattr(self, name), "must be in [0, 10] s")


class Relay:
    """The impairing relay, run in a background thread.

    Parameters
    ----------
    units : mapping of str to int
        Each unit's vehicle id and the loopback port it receives on (and sends from).
    impairment : Impairment
    report_time : callable
        Wall-clock time (``time.time()``) to report time, for the blackouts.
    seed : int
    tap : (str, int), optional
        Where an unimpaired copy of every datagram goes.
    """

    def __init__(
        self,
        units: Mapping[str, int],
        impairment: Impairment,
        *,
        report_time: Callable[[float], float],
        seed: int = 0,
        tap: tuple[str, int] | None = None,
    ) -> None:
        self.units = dict(units)
        self.impairment = impairment
        self.report_time = report_time
        self.tap = tap
        self.stats: Counter[str] = Counter()
        self._by_port = {port: vid for vid, port in self.units.items()}
        self._rng = {
            (a, b): random.Random(zlib.crc32(f"{seed}:{a}>{b}".encode()))
            for a in self.units
            for b in self.units
            if a != b
        }
        self._held: list[tuple[float, int, int, bytes]] = []
        self._n = 0
        self._stop = threading.Event()
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setblocking(False)
        self._thread = threading.Thread(target=self._run, name="relay", daemon=True)

    @property
    def address(self) -> tuple[str, int]:
        """Where the units send."""
        host, port = self.sock.getsockname()[:2]
        return str(host), int(port)

    def start(self) -> None:
        """Start forwarding."""
        self._thread.start()

    def stop(self) -> None:
        """Stop and close (held copies are dropped)."""
        self._stop.set()
        self._thread.join(timeout=5.0)
        self.sock.close()

    def _run(self) -> None:
        sel = selectors.DefaultSelector()
        sel.register(self.sock, selectors.EVENT_READ)
        try:
            while not self._stop.is_set():
                now = time.monotonic()
                timeout = 0.05 if not self._held else max(0.0, min(0.05, self._held[0][0] - now))
                if sel.select(timeout):
                    self._read(time.monotonic())
                self._deliver(time.monotonic())
        finally:
            sel.close()

    def _read(self, now: float) -> None:
        for _ in range(1000):
            try:
                data, (_host, port) = self.sock.recvfrom(65535)
            except BlockingIOError:
                return
            except OSError:
                continue
            self.stats["received"] += 1
            if self.tap is not None:
                self._send(data, self.tap)
            sender = self._by_port.get(port)
            if sender is None:
                self.stats["unknown_sender"] += 1
                continue
            t = self.report_time(time.time())
            if any(s == sender and a <= t < b for s, a, b in self.impairment.blackouts):
                self.stats["blackout"] += len(self.units) - 1
                continue
            for dest, dport in self.units.items():
                if dest != sender:
                    self._impair(data, self._rng[(sender, dest)], dport, now)

    def _impair(self, data: bytes, rng: random.Random, port: int, now: float) -> None:
        imp = self.impairment
        if rng.random() < imp.loss:
            self.stats["lost"] += 1
            return
        if rng.random() < imp.corrupt:
            buf = bytearray(data)
            for _ in range(rng.randint(1, 3)):
                i = rng.randrange(len(buf) * 8)
                buf[i // 8] ^= 1 << (i % 8)
            data = bytes(buf)
            self.stats["corrupted"] += 1
        due = now + imp.delay_s + rng.uniform(0.0, imp.jitter_s)
        if rng.random() < imp.reorder:
            due += imp.reorder_s
            self.stats["reordered"] += 1
        self._hold(due, port, data)
        if rng.random() < imp.duplicate:
            self._hold(due + rng.uniform(0.0, imp.jitter_s), port, data)
            self.stats["duplicated"] += 1

    def _hold(self, due: float, port: int, data: bytes) -> None:
        if len(self._held) >= _MAX_HELD:
            self.stats["overflow"] += 1
            return
        self._n += 1
        heapq.heappush(self._held, (due, self._n, port, data))

    def _deliver(self, now: float) -> None:
        while self._held and self._held[0][0] <= now:
            _due, _n, port, data = heapq.heappop(self._held)
            self._send(data, ("127.0.0.1", port))
            self.stats["forwarded"] += 1

    def _send(self, data: bytes, dest: tuple[str, int]) -> None:
        try:
            self.sock.sendto(data, dest)
        except OSError:
            self.stats["send_error"] += 1
