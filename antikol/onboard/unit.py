"""The on-board unit: one process per vehicle, as the paper built it.

Every cycle (1 s by default) the unit

1. reads its own GPS source and, if it has a new fix, broadcasts the report as one
   (authenticated) frame over UDP;
2. listens for ``listen_fraction`` of the cycle; datagrams are read as they arrive, each
   decoded, authenticated and checked against replays on its own
   (:class:`~antikol.onboard.receiver.SecureReceiver`) into a bounded queue;
3. feeds the queued reports to the analyser one at a time (one bad report never aborts
   the others), assesses the own vehicle and drives the lamp: a line (or a JSON event) per
   change.

Without an own vehicle (``vehicle_id`` None) the unit is a control-room receiver: it
assesses every vehicle heard and reports each lamp change.

Timing. Cycle boundaries are fixed on the clock (for paced sources on the shared epoch,
so that all units send together); a cycle that starts late by more than a period skips
the missed ones, counts them (``overruns``) and says so (an ``overrun`` event). Nothing
waits on the network: the socket is non-blocking and polled with :mod:`selectors`.

Clock. The unit's time is its own: the paced source's time line, or the newest own fix
plus the monotonic time since it arrived (so the table keeps going through an own GPS
outage). Received reports never set it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import logging
import math
import os
import resource
import selectors
import socket
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, Final

from antikol.analysis.analyser import Analyser
from antikol.errors import InvalidArgumentError
from antikol.ingest.auth import KeySet
from antikol.ingest.guard import ReplayGuard
from antikol.ingest.protocol import decode_frame, encode_report, next_seq
from antikol.onboard.receiver import SecureReceiver
from antikol.onboard.sources import GpsSource, PacedSource, open_source
from antikol.onboard.transport import DEFAULT_PORT, UdpTransport
from antikol.positioning.reported import ReportedSettings
from antikol.report import ReportedTrackPosition, VehicleReport

__all__ = ["EventSink", "OnboardUnit", "UnitConfig", "open_log"]

logger = logging.getLogger(__name__)

#: Seconds of silence after which a finished paced source ends the run, in cycles.
_END_CYCLES: Final = 2


@dataclass(frozen=True)
class UnitConfig:
    """Configuration of an :class:`OnboardUnit`.

    Attributes
    ----------
    vehicle_id : str or None
        The own vehicle; None runs a control-room receiver (no GPS, no sending).
    gps : str or None
        The own position source (:func:`~antikol.onboard.sources.open_source`).
    bind : (str, int)
        Address and UDP port to receive on.
    destinations : tuple of (str, int)
        Where every frame goes (broadcast address, multicast group or unicast peers).
    multicast_group : str, optional
        Multicast group to join.
    multicast_interface : str
        Local interface address for multicast.
    broadcast : bool
        Allow broadcast destinations.
    keys : KeySet or None
        Fleet keys (:func:`~antikol.ingest.auth.load_key_file`); None is the paper's
        unauthenticated protocol.
    cycle_s : float
        Cycle period in report time, s (paper: 1).
    listen_fraction : float
        Part of the cycle between sending and assessing, in (0, 1).
    speed : float
        Report seconds per wall-clock second of paced sources (tests run faster).
    epoch : float, optional
        Wall-clock time of report time 0 for paced sources.
    duration_s : float, optional
        Stop after this many wall-clock seconds.
    max_age_s, max_ahead_s : float
        Time window of received reports against the unit's clock, s.
    seq_window : int
        Sequence window per sender.
    max_pending : int
        Reports queued between two assessments; beyond it they are dropped and counted.
    max_datagrams : int
        Datagrams read per wake-up before the deadlines are looked at again.
    max_new_ids : int, optional
        Control room: new vehicles per second of report time (table cap).
    seed : int
        Seed of ``sim:`` sources.
    """

    vehicle_id: str | None
    gps: str | None
    bind: tuple[str, int] = ("0.0.0.0", DEFAULT_PORT)
    destinations: tuple[tuple[str, int], ...] = ()
    multicast_group: str | None = None
    multicast_interface: str = "0.0.0.0"
    broadcast: bool = False
    keys: KeySet | None = None
    cycle_s: float = 1.0
    listen_fraction: float = 0.3
    speed: float = 1.0
    epoch: float | None = None
    duration_s: float | None = None
    max_age_s: float = 5.0
    max_ahead_s: float = 2.0
    seq_window: int = 64
    max_pending: int = 4096
    max_datagrams: int = 256
    max_new_ids: int | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("cycle_s", "speed"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InvalidArgumentError(name, value, "must be > 0")
        if not 0 < self.listen_fraction < 1:
            raise InvalidArgumentError("listen_fraction", self.listen_fraction, "must be in (0, 1)")
        if self.duration_s is not None and not self.duration_s > 0:
            raise InvalidArgumentError("duration_s", self.duration_s, "must be > 0 s")
        if (self.vehicle_id is None) != (self.gps is None):
            raise InvalidArgumentError(
                "gps", self.gps, "a vehicle needs a GPS source, a control room has none"
            )
        if self.keys is not None and self.vehicle_id is not None:
            if self.keys.signer is None:
                raise InvalidArgumentError("keys", str(self.keys.path), "holds no signing key")
            if self.keys.owner is not None and self.keys.owner != self.vehicle_id:
                raise InvalidArgumentError(
                    "keys", str(self.keys.path), f"is the key of {self.keys.owner!r}"
                )


class EventSink:
    """Writes the unit's events: plain lines for people, or JSON lines for programs.

    Parameters
    ----------
    stream : text stream
        Usually standard output.
    as_json : bool
        One JSON object per line instead of text.
    """

    def __init__(self, stream: IO[str], *, as_json: bool = False) -> None:
        self.stream = stream
        self.as_json = as_json

    def emit(self, event: str, **fields: Any) -> None:
        """Write one event (``start``, ``lamp``, ``status``, ``overrun``, ``stop``)."""
        if self.as_json:
            self.stream.write(json.dumps({"event": event, **fields}, sort_keys=True) + "\n")
        else:
            self.stream.write(_text(event, fields) + "\n")
        self.stream.flush()


def _text(event: str, f: dict[str, Any]) -> str:
    who = f.get("vehicle") or "control-room"
    if event == "lamp":
        if not f["lamp"]:
            return f"{who} t={f['t']:.1f} lamp off ({f['level']})"
        threats = ", ".join(
            f"{th['vehicle_id']} {th['kind']} {th['distance_m']:.0f} m" for th in f["threats"]
        )
        return f"{who} t={f['t']:.1f} LAMP ON {f['level']}: {threats}"
    if event == "start":
        return f"{who} started: {f['mode']}; listening on {f['listen']}"
    if event == "stop":
        rejected = ", ".join(f"{k}={v}" for k, v in sorted(f["rejected"].items())) or "none"
        return (
            f"{who} stopped after {f['cycles']} cycles ({f['overruns']} overruns): "
            f"sent {f['sent']}, accepted {f['accepted']}, rejected: {rejected}"
        )
    return f"{who} {event}: " + ", ".join(f"{k}={v}" for k, v in sorted(f.items()))


@dataclass
class _Lamp:
    on: bool | None = None
    level: str = "none"


@dataclass
class _Counters:
    cycles: int = 0
    overruns: int = 0
    lamp_changes: int = 0
    faults: Counter[str] = field(default_factory=Counter)


class OnboardUnit:
    """One vehicle's unit (or a control-room receiver).

    Parameters
    ----------
    config : UnitConfig
    track_map : trackmap.TrackMap, optional
        The map for the track-aware analysis (None: the paper's sector rule).
    events : EventSink
        Where lamp changes and status events go.
    log : text stream, optional
        JSON lines of every cycle (``cycle``), sent (``tx``) and accepted (``rx``)
        report, for tests and analysis.
    """

    def __init__(
        self,
        config: UnitConfig,
        *,
        track_map: Any = None,
        events: EventSink,
        log: IO[str] | None = None,
    ) -> None:
        self.config = config
        self.track_map = track_map
        self.events = events
        self.log = log
        self.counters = _Counters()
        self._wall_offset = time.time() - time.monotonic()
        start_wall = time.time()
        self.source: GpsSource | None = None
        if config.vehicle_id is not None and config.gps is not None:
            self.source = open_source(
                config.gps,
                config.vehicle_id,
                start_wall=start_wall,
                epoch=config.epoch,
                speed=config.speed,
                track_map=track_map,
                seed=config.seed,
            )
        verifier = config.keys.verifier if config.keys is not None else None
        self.receiver = SecureReceiver(
            own_id=config.vehicle_id,
            verifier=verifier,
            guard=ReplayGuard(
                seq_window=config.seq_window,
                max_age_s=config.max_age_s,
                max_ahead_s=config.max_ahead_s,
            ),
        )
        self.analyser = self._new_analyser()
        self.transport = UdpTransport(
            config.bind,
            config.destinations,
            multicast_group=config.multicast_group,
            multicast_interface=config.multicast_interface,
            broadcast=config.broadcast,
        )
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        self._stopping = False
        self._seq = int.from_bytes(os.urandom(4), "big")
        self._pending: list[VehicleReport] = []
        self._lamps: dict[str, _Lamp] = {}
        self._last_own: VehicleReport | None = None
        self._last_own_mono: float = -math.inf
        self._epoch = config.epoch
        if isinstance(self.source, PacedSource):
            self._epoch = self.source.epoch

    # -- set-up ----------------------------------------------------------------------------
    def _new_analyser(self) -> Analyser:
        control_room = self.config.vehicle_id is None
        max_new_ids = self.config.max_new_ids if control_room else None
        return Analyser(
            track_map=self.track_map,
            own_id=self.config.vehicle_id,
            max_new_ids="auto" if max_new_ids is None else max_new_ids,
            time_source=self._clock_now if control_room else None,
        )

    @property
    def mode(self) -> str:
        """What the unit says at start-up about its protection."""
        keys = self.config.keys
        if keys is None:
            return (
                "UNAUTHENTICATED (the paper's protocol: anyone on the network can add, move "
                "or hide vehicles; use --key-file)"
            )
        return f"authenticated frames ({keys.scheme}, key file {keys.path})"

    # -- clock -------------------------------------------------------------------------------
    def _wall(self, mono: float) -> float:
        return mono + self._wall_offset

    def now(self, mono: float | None = None) -> float | None:
        """The unit's clock in report time, s (None before the first own fix of a live
        receiver)."""
        mono = time.monotonic() if mono is None else mono
        wall = self._wall(mono)
        if self.source is not None:
            paced = self.source.report_time(wall)
            if paced is not None:
                return paced
            if self._last_own is None:
                return None
            return self._last_own.t + (mono - self._last_own_mono)
        if self._epoch is not None:
            return (wall - self._epoch) * self.config.speed
        return wall

    def _clock_now(self) -> float:
        now = self.now()
        return -math.inf if now is None else now

    # -- running -----------------------------------------------------------------------------
    def stop(self) -> None:
        """Ask the loop to finish (safe from a signal handler)."""
        self._stopping = True
        with contextlib.suppress(OSError):  # buffer full: a wake-up is pending anyway
            self._wake_w.send(b"x")

    def run(self) -> dict[str, Any]:
        """Run until :meth:`stop`, the duration, or the end of a paced source.

        Returns
        -------
        dict
            The closing statistics (also emitted as the ``stop`` event).
        """
        cfg = self.config
        period = cfg.cycle_s / cfg.speed  # wall-clock seconds
        start = time.monotonic()
        self.events.emit(
            "start",
            vehicle=cfg.vehicle_id,
            mode=self.mode,
            listen="{}:{}".format(*self.transport.address),
            authenticated=cfg.keys is not None,
            cycle_s=cfg.cycle_s,
        )
        if cfg.keys is None:
            logger.warning("%s: running %s", cfg.vehicle_id or "control room", self.mode)
        end = start + cfg.duration_s if cfg.duration_s is not None else math.inf
        next_send = self._first_boundary(start, period)
        next_assess: float | None = None
        finished_at: float | None = None
        sel = selectors.DefaultSelector()
        sel.register(self.transport.sock, selectors.EVENT_READ, "net")
        sel.register(self._wake_r, selectors.EVENT_READ, "wake")
        try:
            while not self._stopping:
                mono = time.monotonic()
                due = min(next_send, next_assess if next_assess is not None else math.inf, end)
                for key, _ in sel.select(max(0.0, due - mono)):
                    if key.data == "net":
                        self._drain()
                    else:
                        self._wake_r.recv(64)
                mono = time.monotonic()
                if mono >= end:
                    break
                if next_assess is not None and mono >= next_assess:
                    next_assess = None
                    self._assess()
                if mono >= next_send:
                    late = mono - next_send
                    if late >= period:
                        skipped = int(late // period)
                        self.counters.overruns += skipped
                        next_send += skipped * period
                        self.events.emit(
                            "overrun", vehicle=cfg.vehicle_id, skipped=skipped, late_s=late
                        )
                    self._send()
                    next_assess = next_send + cfg.listen_fraction * period
                    next_send += period
                    if self._source_finished() and finished_at is None:
                        finished_at = mono
                if finished_at is not None and mono - finished_at > _END_CYCLES * period:
                    break
        finally:
            sel.close()
        return self.close()

    def _first_boundary(self, start: float, period: float) -> float:
        if self._epoch is None:
            return start
        wall = self._wall(start)
        k = math.ceil((wall - self._epoch) / period - 1e-9)
        return self._epoch + k * period - self._wall_offset

    def _source_finished(self) -> bool:
        return isinstance(self.source, PacedSource) and self.source.finished

    # -- the cycle -------------------------------------------------------------------------
    def _drain(self) -> None:
        """Read what the socket holds (bounded) and queue the reports that pass."""
        datagrams = self.transport.receive(self.config.max_datagrams)
        if not datagrams:
            return
        now = self.now()
        for datagram in datagrams:
            try:
                reports = self.receiver.receive(datagram, now)
            except Exception:  # a receiver bug must not stop the unit
                self.counters.faults["receiver_error"] += 1
                logger.exception("receiver error on a %d-byte datagram", len(datagram))
                continue
            room = self.config.max_pending - len(self._pending)
            if len(reports) > room:
                self.counters.faults["queue_full"] += len(reports) - max(room, 0)
                reports = reports[: max(room, 0)]
            self._pending.extend(reports)

    def _send(self) -> None:
        """Read the own source; broadcast and store the newest new fix."""
        self.counters.cycles += 1
        if self.source is None:
            return
        try:
            fresh = self.source.poll(self._wall(time.monotonic()))
        except Exception:
            self.counters.faults["gps_error"] += 1
            logger.exception("GPS source error")
            return
        if not fresh:
            return
        newest = fresh[-1]
        stored = self.analyser.table.get(newest.vehicle_id)
        if stored is not None and newest.t < stored.t - self.config.cycle_s:
            logger.warning(
                "own GPS time moved back from %.1f to %.1f: vehicle table restarted",
                stored.t,
                newest.t,
            )
            self.counters.faults["own_time_reset"] += 1
            self.analyser = self._new_analyser()
        self._seq = next_seq(self._seq)
        keys = self.config.keys
        signer = keys.signer if keys is not None else None
        try:
            # the analyser sees what the others see: the report as the frame carries it
            own = decode_frame(encode_report(newest, seq=self._seq))
        except Exception:
            self.counters.faults["encode_error"] += 1
            logger.exception("own report cannot be encoded")
            return
        for report in [*fresh[:-1], own]:
            self._update(report)
        try:  # sent with the own track position that this very fix gave
            frame = encode_report(self._with_track_position(own), seq=self._seq, signer=signer)
        except Exception:
            self.counters.faults["encode_error"] += 1
            logger.exception("own report cannot be encoded")
            return
        self.transport.send(frame)
        self.receiver.note_sent(frame)
        self._last_own, self._last_own_mono = own, time.monotonic()
        self._log("tx", own)

    def _with_track_position(self, report: VehicleReport) -> VehicleReport:
        """The own report with the unit's own track position at its time, when confident
        and no more uncertain than receivers assume (``ReportedSettings.sigma_m``):
        receivers on the same map use it instead of matching this vehicle again."""
        if report.track_position is not None or self.analyser.track_map is None:
            return report
        try:
            pos = self.analyser.position(report.vehicle_id, report.t)
        except Exception:  # a report goes out with or without it
            self.counters.faults["own_position_error"] += 1
            logger.exception("own track position unavailable")
            return report
        if pos is None or pos.status != "confident" or pos.edge_id is None:
            return report
        assumed = self.analyser.config.reported_positions or ReportedSettings()
        if pos.sigma_m is None or pos.sigma_m > assumed.sigma_m:
            return report
        if pos.offset_m is None or pos.direction is None:  # pragma: no cover - confident
            return report
        own = ReportedTrackPosition(pos.edge_id, pos.offset_m, pos.direction)
        return dataclasses.replace(report, track_position=own)

    def _update(self, report: VehicleReport) -> None:
        try:
            result = self.analyser.update(report)
        except Exception:  # one bad report never aborts the cycle
            self.counters.faults["analyser_error"] += 1
            logger.exception("analyser error on a report of %s", report.vehicle_id)
            return
        if result.accepted and report.vehicle_id != self.config.vehicle_id:
            self._log("rx", report)

    def _assess(self) -> None:
        pending, self._pending = self._pending, []
        for report in pending:
            self._update(report)
        now = self.now()
        vid = self.config.vehicle_id
        if vid is None:
            self._assess_all(now)
            return
        own = self.analyser.table.get(vid)
        if own is None or now is None:
            self._set_lamp(vid, None, "no_fix", now, [])
            return
        t = own.t if now - own.t <= 1.5 * self.config.cycle_s else now
        try:
            a = self.analyser.assess(t=t)
        except Exception:
            self.counters.faults["assess_error"] += 1
            logger.exception("assessment failed")
            self._set_lamp(vid, None, "fault", t, [])
            return
        self._set_lamp(vid, a.lamp, a.level, t, a.threats)
        self._log_cycle(t, {vid: (a.lamp, a.level)})

    def _assess_all(self, now: float | None) -> None:
        if now is None:
            return
        try:
            results = self.analyser.assess_all(t=now)
        except Exception:
            self.counters.faults["assess_error"] += 1
            logger.exception("control-room assessment failed")
            return
        for vid, a in results.items():
            self._set_lamp(vid, a.lamp, a.level, now, a.threats)
        self._log_cycle(now, {v: (a.lamp, a.level) for v, a in results.items()})

    def _set_lamp(
        self, vid: str, on: bool | None, level: str, t: float | None, threats: Sequence[Any]
    ) -> None:
        lamp = self._lamps.setdefault(vid, _Lamp())
        if lamp.on == on and (on is not None or lamp.level == level):
            return
        first = lamp.on is None and lamp.level == "none"
        lamp.on, lamp.level = on, level
        if first and on is False:
            return  # a lamp that starts off is not a change
        self.counters.lamp_changes += 1
        if on is None:
            self.events.emit("status", vehicle=vid, status=level, t=t)
            return
        self.events.emit(
            "lamp",
            vehicle=vid,
            lamp=on,
            level=level,
            t=t,
            threats=[
                {
                    "vehicle_id": th.vehicle_id,
                    "kind": th.kind,
                    "distance_m": round(float(th.distance_m), 1),
                    "method": th.method,
                }
                for th in threats
                if th.level in ("warning", "emergency")
            ],
        )

    # -- logging and closing -----------------------------------------------------------------
    def _log(self, kind: str, r: VehicleReport) -> None:
        if self.log is not None:
            row = {"ev": kind, "id": r.vehicle_id, "t": r.t, "lat": r.lat, "lon": r.lon}
            row["seq"] = r.seq
            self.log.write(json.dumps(row) + "\n")

    def _log_cycle(self, t: float, lamps: dict[str, tuple[bool, str]]) -> None:
        if self.log is not None:
            row = {
                "ev": "cycle",
                "t": t,
                "lamps": {v: [on, level] for v, (on, level) in lamps.items()},
                "ids": self.analyser.table.vehicle_ids(),
            }
            self.log.write(json.dumps(row) + "\n")

    def statistics(self) -> dict[str, Any]:
        """Counters of the run so far."""
        rx = self.receiver
        return {
            "vehicle": self.config.vehicle_id,
            "cycles": self.counters.cycles,
            "overruns": self.counters.overruns,
            "lamp_changes": self.counters.lamp_changes,
            "sent": self.transport.counts["sent"],
            "send_dropped": self.transport.counts["send_dropped"]
            + self.transport.counts["send_error"],
            "datagrams": rx.counts["datagrams"],
            "datagrams_rejected": rx.counts["datagrams_rejected"],
            "accepted": rx.counts["accepted"],
            "own_echo": rx.counts["own_echo"],
            "rejected": rx.rejected(),
            "rejected_total": rx.rejected_total(),
            "kernel_dropped": self.transport.kernel_dropped,
            "faults": dict(self.counters.faults),
            "table": dict(self.analyser.table.stats),
            "vehicles": self.analyser.table.vehicle_ids(),
            "max_rss_kb": _peak_rss_kb(),
        }

    def close(self) -> dict[str, Any]:
        """Release the socket and source; emit and return the statistics."""
        stats = self.statistics()
        self.events.emit("stop", **stats)
        self.transport.close()
        self._wake_r.close()
        self._wake_w.close()
        if self.source is not None:
            self.source.close()
        if self.log is not None:
            self.log.flush()
        return stats


def _peak_rss_kb() -> int:
    """Peak resident memory of this process, kB (``VmHWM``: ``ru_maxrss`` would include
    the parent's memory before ``exec``)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    except (OSError, ValueError, IndexError):  # pragma: no cover - not Linux
        pass
    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)


def open_log(path: Path | None) -> IO[str] | None:
    """Open the ``--log`` file (line-buffered), or None."""
    return None if path is None else path.open("w", encoding="utf-8", buffering=1)
