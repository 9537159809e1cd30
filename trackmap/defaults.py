"""The embedded default map: Kraków's tram network (© OpenStreetMap contributors, ODbL)."""

from __future__ import annotations

import functools
from importlib import resources
from pathlib import Path

from trackmap.errors import SourceError
from trackmap.network import TrackMap
from trackmap.storage import load

__all__ = ["DEFAULT_MAP_NAME", "DEFAULT_SOURCE_NAME", "default_map_path", "load_default"]

DEFAULT_MAP_NAME = "krakow-tram.trackmap.geojson"
DEFAULT_SOURCE_NAME = "krakow-tram-2023-12-14.osm.pbf"


def default_map_path() -> Path:
    """Path of the embedded Kraków map file (shipped in ``maps/``).

    Raises
    ------
    trackmap.errors.SourceError
        The file is missing from the installation.
    """
    try:
        path = Path(str(resources.files("trackmap.maps").joinpath(DEFAULT_MAP_NAME)))
    except ModuleNotFoundError:
        path = Path(__file__).resolve().parent.parent / "maps" / DEFAULT_MAP_NAME
    if not path.is_file():
        raise SourceError(f"the embedded default map is missing: {path}")
    return path


@functools.lru_cache(maxsize=1)
def _load_cached() -> TrackMap:
    return load(default_map_path())


def load_default() -> TrackMap:
    """Load the embedded Kraków tram map (no network access, no external data).

    The map is read once per process and shared: treat it as read-only.

    Returns
    -------
    TrackMap
        Built from OpenStreetMap data of 2023-12-14 (ODbL 1.0).
    """
    return _load_cached()
