"""Where an on-board unit gets its own position: a GPS receiver, a log, or a simulated tram.

``nmea:PATH``
    A live NMEA 0183 stream: a serial device (set its speed first, e.g. ``stty -F
    /dev/ttyUSB0 9600 raw``), a named pipe, or ``-`` for standard input. A reader thread
    puts lines into a bounded queue (lines beyond it are dropped and counted); the unit's
    clock follows the receiver's UTC time. A *regular file* is replayed at the pace of its
    own fix times instead (a demo).
``replay:CSV``
    The unit's own reports from a replay CSV (:mod:`antikol.ingest.replaylog`), emitted
    when the clock reaches their time.
``sim:SCENARIO``
    A simulated tram of a scenario (:mod:`antikol.evaluation.scenarios`) on the unit's
    map, simulated at start-up and emitted at the pace of its fix times.

Paced sources (a file, a CSV, a simulation) define the unit's clock: report time ``t``
is ``(wall clock - epoch) * speed``, where ``epoch`` is the wall-clock time of ``t = 0``
(by default chosen so that the first report is due at start-up). Units given the same
epoch share one time line, as GPS gives real units.
"""

from __future__ import annotations

import logging
import os
import queue
import stat
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any, BinaryIO, Protocol

from antikol.errors import InputFileError, InvalidArgumentError
from antikol.ingest.nmea import NmeaReader, read_nmea_file
from antikol.ingest.replaylog import read_replay_csv
from antikol.report import VehicleReport

__all__ = ["GpsSource", "NmeaStreamSource", "PacedSource", "open_source"]

logger = logging.getLogger(__name__)


class GpsSource(Protocol):
    """The own vehicle's position source."""

    def poll(self, wall: float) -> list[VehicleReport]:
        """New own reports since the last call, oldest first (``wall``: ``time.time()``)."""
        ...

    def report_time(self, wall: float) -> float | None:
        """The report time at wall-clock time ``wall`` if the source defines it, else None
        (a live receiver: the unit's clock then follows the fixes)."""
        ...

    def close(self) -> None:
        """Release the device or thread."""
        ...


class PacedSource:
    """Reports emitted when the clock reaches their time.

    Parameters
    ----------
    reports : sequence of VehicleReport
        One vehicle's reports (sorted here by time).
    epoch : float
        Wall-clock time (``time.time()``) of report time 0, s.
    speed : float
        Report seconds per wall-clock second (default 1).
    """

    def __init__(self, reports: Sequence[VehicleReport], epoch: float, speed: float = 1.0) -> None:
        if not speed > 0:
            raise InvalidArgumentError("speed", speed, "must be > 0")
        self.reports = sorted(reports, key=lambda r: r.t)
        self.epoch = float(epoch)
        self.speed = float(speed)
        self._next = 0

    def report_time(self, wall: float) -> float | None:
        """``(wall - epoch) * speed``."""
        return (wall - self.epoch) * self.speed

    def poll(self, wall: float) -> list[VehicleReport]:
        """The reports whose time has come since the last call."""
        now = (wall - self.epoch) * self.speed
        start = self._next
        while self._next < len(self.reports) and self.reports[self._next].t <= now:
            self._next += 1
        return self.reports[start : self._next]

    @property
    def finished(self) -> bool:
        """Every report has been emitted."""
        return self._next >= len(self.reports)

    def close(self) -> None:
        """Nothing to release."""


class NmeaStreamSource:
    """A live NMEA stream read by a background thread into a bounded queue.

    Parameters
    ----------
    stream : binary file
        The device, pipe or standard input (opened for reading, bytes).
    vehicle_id : str
    max_lines : int
        Lines held between two polls; more are dropped (``dropped_lines``).
    """

    def __init__(self, stream: BinaryIO, vehicle_id: str, *, max_lines: int = 1000) -> None:
        self.reader = NmeaReader(vehicle_id)
        self.dropped_lines = 0
        self._stream = stream
        self._lines: queue.Queue[bytes] = queue.Queue(maxsize=max_lines)
        self._thread = threading.Thread(target=self._run, name="nmea-reader", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            for line in self._stream:
                try:
                    self._lines.put_nowait(line)
                except queue.Full:
                    self.dropped_lines += 1
        except (OSError, ValueError) as exc:  # device gone, stream closed
            logger.warning("NMEA stream ended: %s", exc)

    def report_time(self, wall: float) -> float | None:
        """None: the clock follows the receiver's fixes."""
        return None

    def poll(self, wall: float) -> list[VehicleReport]:
        """Reports of the lines received since the last call."""
        out: list[VehicleReport] = []
        while True:
            try:
                line = self._lines.get_nowait()
            except queue.Empty:
                return out
            out.extend(self.reader.feed_line(line))

    def close(self) -> None:
        """Close the stream (the thread ends with it)."""
        if self._stream is not sys.stdin.buffer:
            self._stream.close()


def open_source(
    spec: str,
    vehicle_id: str,
    *,
    start_wall: float,
    epoch: float | None = None,
    speed: float = 1.0,
    track_map: Any = None,
    seed: int = 0,
) -> GpsSource:
    """Open the source a ``--gps`` value names (see the module docstring).

    Parameters
    ----------
    spec : str
        ``nmea:PATH``, ``replay:CSV`` or ``sim:SCENARIO``.
    vehicle_id : str
        The unit's vehicle (its reports are taken from logs and simulations).
    start_wall : float
        ``time.time()`` at start-up.
    epoch : float, optional
        Wall-clock time of report time 0 for paced sources (default: the first report is
        due at start-up).
    speed : float
        Report seconds per wall-clock second for paced sources.
    track_map : trackmap.TrackMap, optional
        The map of ``sim:`` scenarios.
    seed : int
        Seed of ``sim:`` scenarios.

    Raises
    ------
    InvalidArgumentError
        An unknown kind of source, or a log or scenario without this vehicle.
    InputFileError
        A file that cannot be opened.
    """
    kind, sep, arg = spec.partition(":")
    if not sep or not arg:
        raise InvalidArgumentError("gps", spec, "expected nmea:PATH, replay:CSV or sim:SCENARIO")
    reports: list[VehicleReport]
    if kind == "nmea":
        if arg == "-":
            return NmeaStreamSource(sys.stdin.buffer, vehicle_id)
        path = Path(arg)
        try:
            regular = stat.S_ISREG(os.stat(path).st_mode)
        except OSError as exc:
            raise InputFileError(f"cannot open GPS source {arg!r}: {exc}") from exc
        if not regular:
            try:
                stream = path.open("rb", buffering=0)
            except OSError as exc:
                raise InputFileError(f"cannot open GPS source {arg!r}: {exc}") from exc
            return NmeaStreamSource(stream, vehicle_id)
        reports, _stats = read_nmea_file(path, vehicle_id)
    elif kind == "replay":
        log = read_replay_csv(arg)
        reports = [r for r in log.reports if r.vehicle_id == vehicle_id]
    elif kind == "sim":
        if track_map is None:
            raise InvalidArgumentError("gps", spec, "a simulated tram needs a map (--map)")
        from antikol.evaluation.scenarios import build_scenario, run_scenario

        result = run_scenario(build_scenario(arg, track_map, seed=seed))
        if vehicle_id not in result.truth:
            raise InvalidArgumentError(
                "gps",
                spec,
                f"scenario has no vehicle {vehicle_id!r} (it has {sorted(result.truth)})",
            )
        reports = result.reports_of(vehicle_id)
    else:
        raise InvalidArgumentError("gps", spec, "expected nmea:PATH, replay:CSV or sim:SCENARIO")
    if not reports:
        raise InvalidArgumentError("gps", spec, f"no report of vehicle {vehicle_id!r}")
    if epoch is None:
        epoch = start_wall - min(r.t for r in reports) / speed
    return PacedSource(reports, epoch, speed)
