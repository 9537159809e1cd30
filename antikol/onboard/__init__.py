"""The on-board unit: GPS in, authenticated frames over UDP out and in, the lamp as output.

* :mod:`antikol.onboard.unit` — :class:`OnboardUnit` and its :class:`UnitConfig`: the cycle,
  the clock, the lamp events (``antikol onboard``);
* :mod:`antikol.onboard.receiver` — :class:`SecureReceiver`: decode, authenticate and
  de-duplicate every datagram on its own;
* :mod:`antikol.onboard.transport` — :class:`UdpTransport`: one non-blocking socket for
  broadcast, multicast or unicast peers;
* :mod:`antikol.onboard.sources` — the own position: NMEA stream, log or simulated tram;
* :mod:`antikol.onboard.netem` and :mod:`antikol.onboard.attacker` — fault injection on
  loopback for tests: a lossy relay between units and a sender of hostile frames;
* :mod:`antikol.onboard.harness` — runs several units, the relay and the attacker as
  processes and checks their lamps against one analyser (``antikol harness``).

Frames, keys and replay protection themselves are in :mod:`antikol.ingest`
(``protocol``, ``auth``, ``guard``).
"""

from antikol.onboard.receiver import SecureReceiver
from antikol.onboard.sources import NmeaStreamSource, PacedSource, open_source
from antikol.onboard.transport import DEFAULT_PORT, UdpTransport, parse_address
from antikol.onboard.unit import EventSink, OnboardUnit, UnitConfig

__all__ = [
    "DEFAULT_PORT",
    "EventSink",
    "NmeaStreamSource",
    "OnboardUnit",
    "PacedSource",
    "SecureReceiver",
    "UdpTransport",
    "UnitConfig",
    "open_source",
    "parse_address",
]
