"""Command line interface: ``antikol replay | simulate | compare | demo | onboard``.

One module per sub-command registers its parser (``add_parser``) and the function that
runs it; :func:`main` dispatches.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from antikol.cli import evaluate, onboard, replay, serve
from antikol.errors import AntikolError

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="antikol",
        description="Collision warning for trams: the 2008 sector rule and the track-aware "
        "analyser. A driver-assistance aid, not a certified safety function.",
    )
    p.add_argument("-v", "--verbose", action="count", default=0, help="more logging (-vv: debug)")
    sub = p.add_subparsers(dest="command", required=True)
    replay.add_parser(sub)
    evaluate.add_parsers(sub)
    onboard.add_parser(sub)
    serve.add_parser(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``antikol`` command; returns the exit status."""
    args = _parser().parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(args.run(args))
    except (AntikolError, ValueError, OSError) as exc:
        print(f"antikol {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
