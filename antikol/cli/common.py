"""Options and helpers shared by the ``antikol`` sub-commands."""

from __future__ import annotations

import argparse
import math
from typing import Any

__all__ = [
    "EXIT_INPUT_ERROR",
    "EXIT_INTERNAL_ERROR",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "add_map_option",
    "load_map",
    "positive_float",
    "positive_int",
]

#: Exit statuses of the antikol commands (the table is in :mod:`antikol.cli`).
EXIT_OK = 0
EXIT_INPUT_ERROR = 2
EXIT_INTERNAL_ERROR = 3
EXIT_INTERRUPTED = 130


def add_map_option(p: argparse.ArgumentParser, *, default: str | None) -> None:
    """Add ``--map`` (a map file, ``default``, ``synthetic`` or ``none``)."""
    p.add_argument(
        "--map",
        default=default,
        metavar="MAP",
        help="trackmap map file, 'default' for the embedded Kraków map, or 'none' for the "
        f"paper's sector rule only (default: {default or 'none'})",
    )


def load_map(name: str | None) -> Any:
    """The map a ``--map`` value names, or None for the sector rule only.

    Raises
    ------
    trackmap.errors.TrackMapError
        The map file is missing, unreadable or broken (the message names it).
    """
    if name is None or name.lower() == "none":
        return None
    import trackmap

    if name.lower() == "default":
        return trackmap.load_default()
    if name.lower() == "synthetic":
        from trackmap.synthetic import demo_network

        return demo_network().build()
    return trackmap.load(name)


def positive_float(text: str) -> float:
    """argparse type: a finite number above 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text[:40]!r}") from None
    if not 0 < value < math.inf:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text[:40]!r}")
    return value


def positive_int(text: str) -> int:
    """argparse type: an integer above 0."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text[:40]!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be 1 or more, got {value}")
    return value


def non_negative_float(text: str) -> float:
    """argparse type: a finite number of 0 or more."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text[:40]!r}") from None
    if not 0 <= value < math.inf:
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text[:40]!r}")
    return value


def non_negative_int(text: str) -> int:
    """argparse type: an integer of 0 or more."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text[:40]!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be 0 or more, got {value}")
    return value
