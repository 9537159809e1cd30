"""What feeds the live view: a recorded log replayed at any speed, or the radio stream.

* :func:`replay_feed` — the reports of a log (any format :func:`antikol.ingest.feeds.read_log`
  reads) grouped into analysis cycles and played against the wall clock, ``speed`` times
  faster than recorded; long silences are shortened; optionally in a loop.
* :func:`udp_feed` — the on-board units' radio frames (:mod:`antikol.ingest.protocol`)
  received as UDP datagrams, analysed every ``cycle_s`` of wall time.

Both are coroutines that run until cancelled (a replay without ``loop`` returns at its
end). The analysis runs in a worker thread, one cycle at a time, so the web server stays
responsive.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from antikol.errors import InvalidArgumentError
from antikol.evaluation.replay import cycles
from antikol.ingest.replaylog import ReplayLog
from antikol.serve.live import LiveView

__all__ = ["replay_feed", "udp_feed"]

logger = logging.getLogger(__name__)


async def replay_feed(
    view: LiveView,
    log: ReplayLog,
    *,
    speed: float = 1.0,
    cycle_s: float = 1.0,
    loop: bool = False,
    wait_for_viewer: bool = False,
    max_idle_s: float = 30.0,
) -> None:
    """Replay a log into the live view against the wall clock.

    Parameters
    ----------
    view : LiveView
    log : ReplayLog
        The reports to replay.
    speed : float
        How many times faster than recorded (1: real time), > 0.
    cycle_s : float
        Analysis period, s of log time.
    loop : bool
        Start again at the end (with a fresh analyser), until cancelled.
    wait_for_viewer : bool
        Start only once a viewer has opened the page.
    max_idle_s : float
        Silences in the log longer than this are shortened to it, s of log time.

    Raises
    ------
    InvalidArgumentError
        ``speed`` or ``cycle_s`` is not positive, or the log holds no report.
    """
    if not speed > 0:
        raise InvalidArgumentError("speed", speed, "a positive factor")
    if not cycle_s > 0:
        raise InvalidArgumentError("cycle_s", cycle_s, "a positive period in seconds")
    if not log.reports:
        raise InvalidArgumentError("log", log.source, "holds no report to replay")
    if wait_for_viewer:
        logger.info("replay waits for the first viewer")
        await view.wait_for_viewer()
    clock = asyncio.get_running_loop().time
    while True:
        start = clock()
        played = 0.0  # log time played so far, s (silences shortened)
        prev: float | None = None
        for t_end, batch in cycles(log.reports, cycle_s):
            if prev is not None:
                played += min(t_end - prev, max_idle_s)
            prev = t_end
            delay = start + played / speed - clock()
            if delay > 0:
                await asyncio.sleep(delay)
            await asyncio.to_thread(view.cycle, t_end, batch)
        if not loop:
            view.end()
            return
        logger.info("replay reached its end: starting again")
        await asyncio.to_thread(view.reset)


class _Datagrams(asyncio.DatagramProtocol):
    def __init__(self, inbox: list[bytes]) -> None:
        self.inbox = inbox

    def datagram_received(self, data: bytes, addr: Any) -> None:
        self.inbox.append(data)


async def udp_feed(
    view: LiveView,
    *,
    host: str = "127.0.0.1",
    port: int = 5005,
    cycle_s: float = 1.0,
    ready: asyncio.Event | None = None,
) -> None:
    """Receive radio frames as UDP datagrams and analyse them every cycle.

    Parameters
    ----------
    view : LiveView
    host, port
        Address to listen on (default loopback).
    cycle_s : float
        Analysis period, s of wall time.
    ready : asyncio.Event, optional
        Set once the socket is bound.
    """
    if not cycle_s > 0:
        raise InvalidArgumentError("cycle_s", cycle_s, "a positive period in seconds")
    inbox: list[bytes] = []
    loop = asyncio.get_running_loop()
    transport, _ = await loop.create_datagram_endpoint(
        lambda: _Datagrams(inbox), local_addr=(host, port)
    )
    logger.info("listening for radio frames on udp://%s:%d", host, port)
    if ready is not None:
        ready.set()

    def step(chunks: list[bytes]) -> None:
        for chunk in chunks:
            view.feed_bytes(chunk)
        view.cycle(None)

    try:
        next_at = loop.time()
        while True:
            next_at += cycle_s
            await asyncio.sleep(max(0.0, next_at - loop.time()))
            chunks, inbox[:] = list(inbox), []
            await asyncio.to_thread(step, chunks)
    finally:
        transport.close()
