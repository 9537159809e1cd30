"""Options and helpers shared by the ``antikol`` sub-commands."""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["add_map_option", "load_map"]


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
    """The map a ``--map`` value names, or None for the sector rule only."""
    if name is None or name.lower() == "none":
        return None
    import trackmap

    if name.lower() == "default":
        return trackmap.load_default()
    if name.lower() == "synthetic":
        from trackmap.synthetic import demo_network

        return demo_network().build()
    return trackmap.load(name)
