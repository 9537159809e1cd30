"""Map files as :class:`~trackmap.network.TrackMap` objects: :func:`load` and :func:`save`.

:mod:`trackmap.mapfile` reads and writes the records of a map; this module joins them to
the network built from them.
"""

from __future__ import annotations

import os
import pathlib

from trackmap import mapfile
from trackmap.network import TrackMap

__all__ = ["load", "save"]


def load(path: str | os.PathLike[str]) -> TrackMap:
    """Read and validate a map file.

    Parameters
    ----------
    path : path-like
        A map file (``*.trackmap.geojson``) written by :func:`save` or ``trackmap build``.

    Returns
    -------
    TrackMap

    Raises
    ------
    trackmap.errors.SourceError
        Missing or unreadable file (also an ``OSError``).
    trackmap.errors.MapFileError
        Not a trackmap file, an unsupported version, or broken content; the message names
        the file and what is wrong (also a ``ValueError``).
    """
    return TrackMap.from_data(mapfile.read(path))


def save(net: TrackMap, path: str | os.PathLike[str]) -> pathlib.Path:
    """Write a map file (the same as ``net.save(path)``).

    Parameters
    ----------
    net : TrackMap
    path : path-like
        Destination, conventionally ``*.trackmap.geojson``.

    Returns
    -------
    pathlib.Path
        The written file.
    """
    return net.save(path)
