"""The receiving side of an on-board unit: datagrams in, trustworthy reports out.

Every datagram goes through, in order: the frame decoder (COBS, CRC, structure and, with
keys, the authentication tag: :mod:`antikol.ingest.protocol`), the own-id check (nobody
else may speak for this vehicle) and the replay guard (sequence window, time window
against the unit's own clock: :mod:`antikol.ingest.guard`). Each report is handled on its
own: a bad one is counted by reason and never stops the others. Nothing here raises on
received bytes.
"""

from __future__ import annotations

import hashlib
import logging
from collections import Counter, deque
from typing import Final

from antikol.ingest.guard import ReplayGuard
from antikol.ingest.protocol import REJECT_REASONS, FrameVerifier, StreamDecoder
from antikol.report import VehicleReport

__all__ = ["RECEIVER_REASONS", "SecureReceiver"]

logger = logging.getLogger(__name__)

#: Reasons of the receiver itself (besides the decoder's and the guard's).
RECEIVER_REASONS: Final = ("own_id", "too_large")
#: Largest datagram looked at, bytes (a frame is at most ~1.2 kB).
MAX_DATAGRAM_BYTES: Final = 4096


class SecureReceiver:
    """Decode, authenticate and de-duplicate received datagrams.

    Parameters
    ----------
    own_id : str or None
        The own vehicle: received frames carrying its id are rejected (``"own_id"``),
        except copies of frames this unit sent itself (multicast loop-back, counted as
        ``own_echo``, not as a rejection).
    verifier : FrameVerifier or None
        Keys of the fleet; None accepts unsigned frames (the paper's protocol).
    guard : ReplayGuard, optional
        Sequence and time windows (default :class:`~antikol.ingest.guard.ReplayGuard` ()).

    Examples
    --------
    >>> from antikol.ingest.protocol import encode_report
    >>> rx = SecureReceiver(own_id="T1", verifier=None)
    >>> frame = encode_report(VehicleReport("T2", 10.0, 50.0, 19.9, 8.0, 90.0), seq=1)
    >>> [r.vehicle_id for r in rx.receive(frame, now=10.2)], rx.receive(frame, now=10.3)
    (['T2'], [])
    >>> rx.rejected()
    {'duplicate': 1}
    """

    def __init__(
        self,
        *,
        own_id: str | None,
        verifier: FrameVerifier | None,
        guard: ReplayGuard | None = None,
    ) -> None:
        self.own_id = own_id
        self.authenticated = verifier is not None
        self.decoder = StreamDecoder(verifier=verifier)
        self.guard = guard if guard is not None else ReplayGuard()
        self.counts: Counter[str] = Counter()
        self._sent: deque[bytes] = deque(maxlen=16)

    def note_sent(self, frame: bytes) -> None:
        """Remember a frame this unit sent (to recognise its loop-back copy)."""
        self._sent.append(hashlib.blake2b(frame.strip(b"\x00"), digest_size=16).digest())

    def receive(self, datagram: bytes, now: float | None) -> list[VehicleReport]:
        """The reports of one datagram that pass every check.

        Parameters
        ----------
        datagram : bytes
            One UDP payload (one or more frames).
        now : float or None
            The unit's clock in report time, s (None: no own fix yet).

        Returns
        -------
        list of VehicleReport
        """
        self.counts["datagrams"] += 1
        if len(datagram) > MAX_DATAGRAM_BYTES:
            self.counts["too_large"] += 1
            return []
        # A datagram is self-contained: the leading delimiter drops anything pending.
        reports = self.decoder.feed(b"\x00" + datagram + b"\x00")
        out: list[VehicleReport] = []
        echo = False
        for report in reports:
            if self.own_id is not None and report.vehicle_id == self.own_id:
                digest = hashlib.blake2b(datagram.strip(b"\x00"), digest_size=16).digest()
                if digest in self._sent:
                    self.counts["own_echo"] += 1
                    echo = True
                else:
                    self.counts["own_id"] += 1
                    logger.info(
                        "frame with the own id %r from another sender rejected", self.own_id
                    )
                continue
            if self.guard.check(report, now) is None:
                out.append(report)
                self.counts["accepted"] += 1
        if not out and not echo:
            self.counts["datagrams_rejected"] += 1
        return out

    def rejected(self) -> dict[str, int]:
        """Rejected frames so far by reason (decoder, own id, guard); zeros left out."""
        out: dict[str, int] = {}
        stats = self.decoder.stats
        for reason in REJECT_REASONS:
            if stats.rejected[reason]:
                out[reason] = stats.rejected[reason]
        for reason in RECEIVER_REASONS:
            if self.counts[reason]:
                out[reason] = self.counts[reason]
        for reason, n in self.guard.stats.items():
            if reason not in ("accepted", "resync") and n:
                out[reason] = n
        return out

    def rejected_total(self) -> int:
        """Number of rejected frames, all reasons."""
        return sum(self.rejected().values())
