"""``antikol onboard``: run the on-board unit of one vehicle (or a control-room receiver)."""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from pathlib import Path
from typing import Any

from antikol.cli.common import add_map_option, load_map
from antikol.errors import InvalidArgumentError

__all__ = ["add_parser"]

logger = logging.getLogger(__name__)

_EPILOG = """\
examples:
  antikol onboard --id T1 --gps nmea:/dev/ttyUSB0 --key-file fleet.toml \\
      --broadcast 192.168.8.255 --map default
  antikol onboard --keygen keys/ --fleet T1,T2,T3 --scheme ed25519
  antikol onboard --control-room --key-file keys/public.toml --listen :47800 --json

The lamp goes to standard output, one line per change (--json: one JSON event per line,
ending with a "stop" event that counts every rejected frame by reason). Exit status 0 after
a normal stop (SIGINT, SIGTERM, --duration, end of a replayed source), 2 on a configuration
error (unreadable key file, port in use, bad option).
"""


def add_parser(sub: Any) -> None:
    """Register the sub-command."""
    p = sub.add_parser(
        "onboard",
        help="run the on-board unit: own GPS, UDP frames, analyser, lamp",
        description="The paper's on-board unit: reads the own GPS, broadcasts its report "
        "every cycle over UDP, listens to the others and drives the lamp.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    who = p.add_argument_group("vehicle")
    who.add_argument("--id", dest="vehicle_id", help="the own vehicle id (1-32 bytes)")
    who.add_argument(
        "--gps",
        metavar="SOURCE",
        help="own position: nmea:PATH (serial device, pipe, '-' for stdin, or a file "
        "replayed at its pace), replay:CSV or sim:SCENARIO",
    )
    who.add_argument(
        "--control-room",
        action="store_true",
        help="no own vehicle: receive and assess every vehicle heard",
    )
    add_map_option(p, default=None)
    net = p.add_argument_group("network")
    net.add_argument(
        "--listen", default=":47800", metavar="[HOST]:PORT", help="receive on (default :47800)"
    )
    net.add_argument("--broadcast", metavar="ADDR[:PORT]", help="send to a broadcast address")
    net.add_argument("--multicast", metavar="GROUP[:PORT]", help="join and send to a group")
    net.add_argument(
        "--multicast-interface", default="0.0.0.0", metavar="ADDR", help="multicast interface"
    )
    net.add_argument(
        "--peer", action="append", default=[], metavar="HOST:PORT", help="unicast destination"
    )
    sec = p.add_argument_group("security")
    sec.add_argument("--key-file", type=Path, help="fleet key file (see antikol.ingest.auth)")
    sec.add_argument(
        "--unauthenticated",
        action="store_true",
        help="the paper's protocol without keys: anyone on the network can forge frames",
    )
    sec.add_argument("--max-age", type=float, default=5.0, metavar="S", help="oldest frame (5 s)")
    sec.add_argument(
        "--max-ahead", type=float, default=2.0, metavar="S", help="newest frame ahead (2 s)"
    )
    sec.add_argument(
        "--max-new-ids", type=int, metavar="N", help="control room: new vehicles per second"
    )
    run = p.add_argument_group("timing and output")
    run.add_argument("--cycle", type=float, default=1.0, metavar="S", help="period (1 s)")
    run.add_argument(
        "--listen-fraction", type=float, default=0.3, metavar="F", help="listen before assessing"
    )
    run.add_argument("--speed", type=float, default=1.0, help="pace of replayed sources")
    run.add_argument("--epoch", type=float, help="wall-clock time of report time 0 (replays)")
    run.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    run.add_argument("--seed", type=int, default=0, help="seed of sim: sources")
    run.add_argument("--json", action="store_true", help="JSON events on stdout")
    run.add_argument("--log", type=Path, help="JSON lines of every cycle and report")
    keys = p.add_argument_group("key generation")
    keys.add_argument("--keygen", type=Path, metavar="DIR", help="write key files and exit")
    keys.add_argument("--fleet", default="", help="vehicle ids for --keygen, comma-separated")
    keys.add_argument(
        "--scheme", choices=("hmac-sha256", "ed25519"), default="hmac-sha256", help="for --keygen"
    )
    p.set_defaults(run=_onboard)


def _onboard(args: argparse.Namespace) -> int:
    from antikol.ingest.auth import generate_key_files, load_key_file
    from antikol.onboard.transport import DEFAULT_PORT, parse_address
    from antikol.onboard.unit import EventSink, OnboardUnit, UnitConfig, open_log

    if args.keygen is not None:
        fleet = [v for v in args.fleet.split(",") if v]
        if not fleet:
            raise InvalidArgumentError("--fleet", args.fleet, "name the vehicles for --keygen")
        files = generate_key_files(args.keygen, args.scheme, fleet)
        for vid, path in files.items():
            print(f"{vid or '(public keys)'}: {path}")
        return 0
    if args.control_room:
        if args.vehicle_id or args.gps:
            raise InvalidArgumentError("--control-room", True, "takes no --id or --gps")
    elif not (args.vehicle_id and args.gps):
        raise InvalidArgumentError("--id/--gps", None, "a unit needs both (or --control-room)")
    if args.key_file is None and not args.unauthenticated:
        raise InvalidArgumentError(
            "--key-file", None, "give a key file, or --unauthenticated for the paper's protocol"
        )
    if args.key_file is not None and args.unauthenticated:
        raise InvalidArgumentError("--unauthenticated", True, "contradicts --key-file")
    keys = load_key_file(args.key_file) if args.key_file is not None else None
    bind = parse_address(args.listen)
    destinations = [parse_address(a) for a in args.peer]
    group = None
    if args.multicast:
        group, port = parse_address(args.multicast, default_port=bind[1] or DEFAULT_PORT)
        destinations.append((group, port))
    if args.broadcast:
        destinations.append(parse_address(args.broadcast, default_port=bind[1] or DEFAULT_PORT))
    if not args.control_room and not destinations:
        raise InvalidArgumentError(
            "--peer", None, "no destination: give --broadcast, --multicast or --peer"
        )
    config = UnitConfig(
        vehicle_id=None if args.control_room else args.vehicle_id,
        gps=None if args.control_room else args.gps,
        bind=bind,
        destinations=tuple(destinations),
        multicast_group=group,
        multicast_interface=args.multicast_interface,
        broadcast=args.broadcast is not None,
        keys=keys,
        cycle_s=args.cycle,
        listen_fraction=args.listen_fraction,
        speed=args.speed,
        epoch=args.epoch,
        duration_s=args.duration,
        max_age_s=args.max_age,
        max_ahead_s=args.max_ahead,
        max_new_ids=args.max_new_ids,
        seed=args.seed,
    )
    net = load_map(args.map)
    log = open_log(args.log)
    try:
        unit = OnboardUnit(
            config, track_map=net, events=EventSink(sys.stdout, as_json=args.json), log=log
        )
        previous = {
            sig: signal.signal(sig, lambda *_: unit.stop())
            for sig in (signal.SIGINT, signal.SIGTERM)
        }
        try:
            unit.run()
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
    finally:
        if log is not None:
            log.close()
    return 0
