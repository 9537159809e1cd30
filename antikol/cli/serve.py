"""``antikol serve``: the live view for a control room."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from antikol.cli.common import add_map_option, load_map
from antikol.errors import UsageError

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    """Register the sub-command."""
    s = sub.add_parser(
        "serve",
        help="live view: the fleet and its threats on the map, in a web browser",
        description="Serve a read-only live view of the fleet moving on the map with its "
        "current threats, fed by the radio stream (--udp) or a recorded log replayed at any "
        "speed (--replay). It listens on loopback by default; bound to another address it "
        "requires an access token.",
    )
    source = s.add_mutually_exclusive_group(required=True)
    source.add_argument(
        "--replay",
        type=Path,
        metavar="LOG",
        help="replay a recorded log (any format antikol replay reads)",
    )
    source.add_argument(
        "--udp",
        metavar="[HOST:]PORT",
        help="receive the on-board units' radio frames as UDP datagrams (host default 127.0.0.1)",
    )
    s.add_argument(
        "--format",
        dest="log_format",
        choices=("auto", "csv", "nmea", "hfp", "gtfs-rt"),
        default="auto",
        help="--replay: log format (default: recognised by name and content)",
    )
    s.add_argument(
        "--speed",
        type=float,
        default=1.0,
        metavar="X",
        help="--replay: times faster than recorded (default 1: real time)",
    )
    s.add_argument("--loop", action="store_true", help="--replay: start again at the end")
    s.add_argument(
        "--wait-for-viewer",
        action="store_true",
        help="--replay: start when the first viewer opens the page",
    )
    add_map_option(s, default="default")
    s.add_argument(
        "--cycle", type=float, default=1.0, metavar="S", help="analysis period (default 1 s)"
    )
    s.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1, this machine only)",
    )
    s.add_argument("--port", type=int, default=8765, help="port to listen on (default 8765)")
    s.add_argument(
        "--token",
        default=None,
        help="access token (at least 12 characters); required on any address but loopback, "
        "and made up and printed when not given",
    )
    s.add_argument(
        "--tiles",
        default="none",
        help="online background tiles, a provider name or URL template (default none: the "
        "page makes no request but to this server)",
    )
    s.set_defaults(run=_serve)


def _udp_address(text: str) -> tuple[str, int]:
    host, _, port = text.rpartition(":")
    try:
        number = int(port)
    except ValueError:
        raise UsageError(f"--udp: {text!r} is not [HOST:]PORT") from None
    if not 0 < number < 65536:
        raise UsageError(f"--udp: port {number} is out of range")
    return (host.strip("[]") or "127.0.0.1"), number


def _serve(args: argparse.Namespace) -> int:
    from antikol.serve import LiveView, check_access, create_app, live_page, run
    from antikol.serve.app import require_serve
    from antikol.serve.feeds import replay_feed, udp_feed

    try:
        require_serve()
    except ImportError as exc:
        print(f"antikol serve: error: {exc}", file=sys.stderr)
        return 2
    token = check_access(args.host, args.token)
    net = load_map(args.map)
    if args.replay is not None:
        from antikol.ingest.feeds import detect_log_format, read_log

        fmt = detect_log_format(args.replay) if args.log_format == "auto" else args.log_format
        log = read_log(args.replay, log_format=fmt)
        if not log.reports:
            raise UsageError(f"{args.replay}: no usable report in the {fmt} log")
        if not args.speed > 0:
            raise UsageError(f"--speed must be positive, got {args.speed}")
        what = f"replay of {args.replay.name} at {args.speed:g}x"
        view = LiveView(net, source=what)

        async def feed() -> None:
            await replay_feed(
                view,
                log,
                speed=args.speed,
                cycle_s=args.cycle,
                loop=args.loop,
                wait_for_viewer=args.wait_for_viewer,
            )

    else:
        udp_host, udp_port = _udp_address(args.udp)
        what = f"radio frames on udp://{udp_host}:{udp_port}"
        view = LiveView(net, source=what)

        async def feed() -> None:
            await udp_feed(view, host=udp_host, port=udp_port, cycle_s=args.cycle)

    tiles = None if args.tiles.strip().lower() in ("", "none") else args.tiles
    page = live_page(net, title=f"antikol live view: {what}", tiles=tiles)
    app = create_app(view, page, token=token, feed=feed, tiles_online=tiles is not None)
    shown = f"[{args.host}]" if ":" in args.host else args.host
    url = f"http://{shown}:{args.port}/" + (f"?token={token}" if token else "")
    method = "track-aware analyser" if net is not None else "sector rule (no map)"
    print(f"antikol live view ({method}, {what}): open {url}", file=sys.stderr, flush=True)
    print("read-only; stop with Ctrl-C", file=sys.stderr, flush=True)
    run(app, host=args.host, port=args.port)
    return 0
