"""Command line interface: ``antikol replay | match | simulate | compare | demo | onboard |
harness | serve``.

One module per sub-command registers its parser (``add_parser``) and the function that
runs it; :func:`main` dispatches and turns every failure into one line and an exit status.

Exit status
-----------
===  ======================================================================================
 0   success
 2   usage or input error: a bad option, a missing, unreadable or unusable log or map file;
     one line ``antikol CMD: error: ...`` says what and where
 3   internal error: a bug in antikol, not a problem of the input; the message asks to
     report it (``-vv`` prints the traceback). ``compare`` also ends with 3 when a
     scenario failed (the others are still scored and printed), ``harness`` when a unit
     exited with an error; ``replay --fleet`` ends with 2 when a partition failed because
     of its input and 3 when one failed otherwise (the others are still replayed; every
     failure is listed)
130  interrupted (Ctrl-C)
===  ======================================================================================

Status 1 ("findings") is ``trackmap check``'s; no antikol command uses it. A reader that
leaves early (``antikol match LOG | head``) ends only the printing: the command finishes
its files, and its status is as above.
"""

from __future__ import annotations

import argparse
import logging
import sys
import traceback
from collections.abc import Sequence

from antikol.cli import evaluate, harness, match, onboard, replay, serve
from antikol.cli.common import EXIT_INPUT_ERROR, EXIT_INTERNAL_ERROR, EXIT_INTERRUPTED, EXIT_OK
from antikol.errors import AntikolError

__all__ = ["EXIT_INPUT_ERROR", "EXIT_INTERNAL_ERROR", "EXIT_INTERRUPTED", "EXIT_OK", "main"]

_MAX_MESSAGE = 2000


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="antikol",
        description="Collision warning for trams: the 2008 sector rule and the track-aware "
        "analyser. A driver-assistance aid, not a certified safety function.",
        epilog="exit status: 0 ok, 2 usage or input error, 3 internal error (a bug: please "
        "report it)",
    )
    p.add_argument("-v", "--verbose", action="count", default=0, help="more logging (-vv: debug)")
    sub = p.add_subparsers(dest="command", required=True)
    replay.add_parser(sub)
    match.add_parser(sub)
    evaluate.add_parsers(sub)
    onboard.add_parser(sub)
    harness.add_parser(sub)
    serve.add_parser(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``antikol`` command; returns the exit status (module notes)."""
    from trackmap.cli import quiet_when_reader_leaves

    with quiet_when_reader_leaves():
        return _run(argv)


def _run(argv: Sequence[str] | None) -> int:
    from trackmap.errors import TrackMapError

    args = _parser().parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    prog = f"antikol {args.command}"
    try:
        return int(args.run(args))
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (AntikolError, TrackMapError, OSError) as exc:
        print(f"{prog}: error: {_clip(str(exc) or type(exc).__name__)}", file=sys.stderr)
        return EXIT_INPUT_ERROR
    except Exception as exc:  # the catch-all: whatever it is, a bug of ours
        if args.verbose >= 2:
            traceback.print_exc()
        print(
            f"{prog}: internal error: {type(exc).__name__}: {_clip(str(exc))}\n"
            "This is a bug in antikol, not a problem of your input. Please report it with "
            "the command line, the input file if you can share it, and the output of the same "
            "command run with -vv (it shows the traceback).",
            file=sys.stderr,
        )
        return EXIT_INTERNAL_ERROR


def _clip(text: str) -> str:
    return text if len(text) <= _MAX_MESSAGE else text[: _MAX_MESSAGE - 3] + "..."


if __name__ == "__main__":
    raise SystemExit(main())
