"""Options and helpers shared by the ``antikol`` sub-commands."""

from __future__ import annotations

import argparse
from typing import Any

from trackmap.cli import (
    EXIT_INPUT_ERROR,
    EXIT_INTERNAL_ERROR,
    EXIT_INTERRUPTED,
    EXIT_OK,
    non_negative_float,
    non_negative_int,
    positive_float,
    positive_int,
)

__all__ = [
    "EXIT_INPUT_ERROR",
    "EXIT_INTERNAL_ERROR",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "add_map_option",
    "load_map",
    "non_negative_float",
    "non_negative_int",
    "positive_float",
    "positive_int",
]

# the exit statuses and argparse number types are trackmap's: both programs share one table


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
    if name is None:
        return None
    from trackmap.named import load_named

    return load_named(name)
