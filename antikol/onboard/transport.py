"""UDP transport of the on-board unit: one non-blocking socket, never waiting on the network.

The unit sends each frame as one datagram to a list of destinations: a broadcast address
(``--broadcast``), a multicast group (``--multicast``, joined for reception too) or
unicast peers (``--peer``, e.g. the loopback test harness). Sending never blocks: a full
socket buffer or an unreachable peer drops the datagram and counts it. Reception reads
what the kernel holds, a bounded number of datagrams at a time; on Linux the kernel's own
drop counter (``SO_RXQ_OVFL``) is read so that datagrams lost before the unit saw them are
counted too (``kernel_dropped``).
"""

from __future__ import annotations

import errno
import logging
import socket
import struct
import sys
from collections import Counter
from collections.abc import Sequence
from typing import Final

from antikol.errors import InvalidArgumentError

__all__ = ["DEFAULT_PORT", "UdpTransport", "parse_address"]

logger = logging.getLogger(__name__)

#: Default UDP port of the radio protocol.
DEFAULT_PORT: Final = 47800
_SO_RXQ_OVFL: Final = getattr(socket, "SO_RXQ_OVFL", 40)
_U32 = struct.Struct("=I")


def parse_address(text: str, *, default_port: int = DEFAULT_PORT) -> tuple[str, int]:
    """``"host:port"`` or ``"host"`` as ``(host, port)``.

    Raises
    ------
    InvalidArgumentError
        The port is not an integer in 0..65535 (the message names the address).
    """
    host, sep, port = text.rpartition(":")
    if not sep:
        host, port = text, str(default_port)
    if not host:
        host = "0.0.0.0"
    try:
        number = int(port)
    except ValueError:
        raise InvalidArgumentError("address", text, "port is not an integer") from None
    if not 0 <= number <= 65535:
        raise InvalidArgumentError("address", text, "port outside 0..65535")
    return host, number


class UdpTransport:
    """A non-blocking UDP socket bound for reception, with a list of destinations.

    Parameters
    ----------
    bind : (str, int)
        Local address and port to receive on (port 0: any free port).
    destinations : sequence of (str, int)
        Where every frame is sent.
    multicast_group : str, optional
        Join this IPv4 multicast group (and allow several units on one host to share the
        port).
    multicast_interface : str
        Local address of the interface for multicast (default ``0.0.0.0``: the system's
        choice; ``127.0.0.1`` keeps it on the loopback interface).
    broadcast : bool
        Allow sending to broadcast addresses.
    ttl : int
        Multicast time to live (default 1: the local network only).
    receive_buffer : int
        Requested kernel receive buffer, bytes (the kernel may grant less).

    Raises
    ------
    OSError
        The socket cannot be created or bound (e.g. the port is taken).
    """

    def __init__(
        self,
        bind: tuple[str, int],
        destinations: Sequence[tuple[str, int]] = (),
        *,
        multicast_group: str | None = None,
        multicast_interface: str = "0.0.0.0",
        broadcast: bool = False,
        ttl: int = 1,
        receive_buffer: int = 1 << 20,
    ) -> None:
        self.destinations = list(destinations)
        self.counts: Counter[str] = Counter()
        self._kernel_dropped = 0
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            if multicast_group is not None and hasattr(socket, "SO_REUSEPORT"):
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
            if broadcast:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
            try:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, receive_buffer)
            except OSError:  # pragma: no cover - platform limit
                logger.debug("receive buffer of %d bytes refused", receive_buffer)
            self._overflow = sys.platform.startswith("linux")
            if self._overflow:
                try:
                    sock.setsockopt(socket.SOL_SOCKET, _SO_RXQ_OVFL, 1)
                except OSError:  # pragma: no cover - old kernels
                    self._overflow = False
            sock.bind(bind)
            if multicast_group is not None:
                membership = socket.inet_aton(multicast_group) + socket.inet_aton(
                    multicast_interface
                )
                sock.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, membership)
                sock.setsockopt(
                    socket.IPPROTO_IP, socket.IP_MULTICAST_IF, socket.inet_aton(multicast_interface)
                )
                sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, ttl)
                sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
            sock.setblocking(False)
        except OSError:
            sock.close()
            raise
        self.sock = sock

    @property
    def address(self) -> tuple[str, int]:
        """The bound local address."""
        host, port = self.sock.getsockname()[:2]
        return str(host), int(port)

    def fileno(self) -> int:
        """The socket's file descriptor (for :mod:`selectors`)."""
        return self.sock.fileno()

    @property
    def kernel_dropped(self) -> int:
        """Datagrams the kernel dropped for a full receive buffer (Linux; else 0)."""
        return self._kernel_dropped

    def send(self, frame: bytes) -> int:
        """Send one frame to every destination without blocking; returns how many went."""
        sent = 0
        for dest in self.destinations:
            try:
                self.sock.sendto(frame, dest)
                sent += 1
            except BlockingIOError:
                self.counts["send_dropped"] += 1
            except OSError as exc:  # unreachable, refused (ICMP of an earlier send), ...
                self.counts["send_error"] += 1
                logger.debug("send to %s:%d failed: %s", dest[0], dest[1], exc)
        self.counts["sent"] += sent
        return sent

    def receive(self, max_datagrams: int) -> list[bytes]:
        """Up to ``max_datagrams`` datagrams already received; never waits."""
        out: list[bytes] = []
        space = socket.CMSG_SPACE(_U32.size) if self._overflow else 0
        for _ in range(max_datagrams):
            try:
                if space:
                    data, ancillary, _flags, _addr = self.sock.recvmsg(65535, space)
                    for level, kind, value in ancillary:
                        if level == socket.SOL_SOCKET and kind == _SO_RXQ_OVFL:
                            self._kernel_dropped = _U32.unpack(value[: _U32.size])[0]
                else:
                    data = self.sock.recv(65535)
            except BlockingIOError:
                break
            except OSError as exc:
                if exc.errno not in (errno.ECONNREFUSED, errno.EINTR):
                    logger.debug("receive failed: %s", exc)
                self.counts["receive_error"] += 1
                continue
            out.append(data)
        self.counts["received"] += len(out)
        return out

    def close(self) -> None:
        """Close the socket."""
        self.sock.close()
