"""Maps by the names command lines and configurations use.

``default`` is the embedded Kraków map (:func:`~trackmap.defaults.load_default`),
``synthetic`` the drawn network with every feature (:mod:`trackmap.synthetic`, built on
the fly), ``none`` no map at all (the paper's sector rule alone); anything else is a map
file (:func:`~trackmap.storage.load`) or a source to build one from: an OSM extract
(``.osm.pbf``, ``.osm``, ...), Overpass JSON or GeoJSON, built on the fly with
:func:`trackmap.build`'s defaults (``trackmap build`` saves the map, and the build, for
the next time).

>>> load_named("none") is None
True
"""

from __future__ import annotations

import logging
from pathlib import Path

from trackmap.defaults import load_default
from trackmap.errors import MapFileError
from trackmap.network import TrackMap
from trackmap.sourcefiles import is_osm_extract
from trackmap.storage import load

__all__ = ["load_named"]

logger = logging.getLogger(__name__)


def load_named(spec: str) -> TrackMap | None:
    """The map a name stands for (case does not matter for the names).

    Parameters
    ----------
    spec : str
        ``default``, ``synthetic``, ``none``, the path of a map file, or the path of an OSM
        extract, Overpass JSON or GeoJSON source (built on the fly).

    Returns
    -------
    TrackMap or None
        None for ``none``.

    Raises
    ------
    trackmap.errors.TrackMapError
        The map file is missing, unreadable or broken, or the source cannot be built
        (the message names it; an OSM extract needs the ``osm`` extra).
    """
    name = spec.lower()
    if name == "none":
        return None
    if name == "default":
        return load_default()
    if name == "synthetic":
        from trackmap.synthetic import demo_network  # the build side, only when asked

        return demo_network().build()
    if is_osm_extract(name):  # (a map file is JSON)
        return _built(spec)
    try:
        return load(spec)
    except MapFileError:
        # a JSON file without a map file's header may be a source (Overpass JSON, GeoJSON);
        # a broken map file keeps its own message
        if not name.endswith((".json", ".geojson")) or _has_map_header(Path(spec)):
            raise
        return _built(spec)


def _has_map_header(path: Path) -> bool:
    """Whether a JSON file's start names the map file format (a map file, broken or not)."""
    with path.open("rb") as f:
        return b'"trackmap"' in f.read(4096)


def _built(source: str) -> TrackMap:
    """A map built from a source file with the builder's defaults."""
    from trackmap.builder import build  # the build side, only when asked

    logger.warning(
        "%s: a source, not a map file: building the map (trackmap build %s -o MAP saves it "
        "for the next run)",
        source,
        source,
    )
    return build(source)
