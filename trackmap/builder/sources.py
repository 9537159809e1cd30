"""Reading stored track geometry: OSM XML/PBF (osmium), Overpass JSON and GeoJSON.

Every reader returns :class:`SourceData`: the track ways of the requested kinds (with node
ids and WGS84 coordinates) and the tram stops. Filtering happens here, so a whole-city
extract with roads and buildings works as well as a tram-only file.

Every way element is accounted for: it is kept (whole, or in pieces when cut by the
extract's boundary), or counted in :attr:`SourceData.dropped` by reason. A file that cannot
be read as its format raises :class:`~trackmap.errors.SourceFormatError` naming the file,
the element and what is wrong.

Extracts cut by a bounding box
------------------------------
Extract tools (``osmium extract``, Overpass ``(bbox)`` queries) keep every node reference
of a way that crosses the box but only the nodes inside it. Such a way keeps each run of
consecutive nodes that have a location (a way may give several pieces); the located node
next to a missing one is a *boundary node*: the track goes on beyond the map there. The
counts are in :attr:`SourceData.clipped` and ``trackmap check`` lists boundary nodes as map
boundaries, not as data errors.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from trackmap.builder.jsonsources import read_geojson, read_overpass
from trackmap.builder.rawdata import (
    INT64_MAX,
    INT64_MIN,
    KNOWN_KINDS,
    LIFECYCLE,
    MARKED_SERVICES,
    TOPOLOGY_NODE_VALUES,
    RawStop,
    RawWay,
    SourceData,
    add_way,
    coordinate_node_id,
    is_stop,
    is_topology_node,
    valid_lonlat,
    way_rejection,
)
from trackmap.errors import (
    MissingDependencyError,
    NoTracksError,
    ParameterError,
    SourceError,
    SourceFormatError,
)
from trackmap.optional import require
from trackmap.sourcefiles import OSMIUM_SUFFIXES

__all__ = [
    "INT64_MAX",
    "INT64_MIN",
    "KNOWN_KINDS",
    "LIFECYCLE",
    "MARKED_SERVICES",
    "OSMIUM_SUFFIXES",
    "PROGRESS_BYTES",
    "TOPOLOGY_NODE_VALUES",
    "RawStop",
    "RawWay",
    "SourceData",
    "add_way",
    "check_kinds",
    "coordinate_node_id",
    "detect_format",
    "is_stop",
    "is_topology_node",
    "read_source",
    "valid_lonlat",
    "way_rejection",
]

logger = logging.getLogger(__name__)

#: Files larger than this show a progress bar while read, bytes.
PROGRESS_BYTES = 20_000_000


def detect_format(path: Path) -> str:
    """Name the format of a source file from its suffix and, for JSON, its content.

    Returns
    -------
    str
        ``osmium``, ``overpass-json`` or ``geojson``.

    Raises
    ------
    SourceFormatError
        The format is not recognised.
    """
    name = path.name.lower()
    if name.endswith(OSMIUM_SUFFIXES):
        return "osmium"
    if name.endswith((".json", ".geojson")):
        head = _read_head(path, 4096)
        if '"elements"' in head or '"osm3s"' in head:
            return "overpass-json"
        if '"FeatureCollection"' in head or '"Feature"' in head or name.endswith(".geojson"):
            return "geojson"
        raise SourceFormatError(
            f"{path}: JSON file that is neither Overpass JSON (no 'elements') "
            "nor GeoJSON (no FeatureCollection)"
        )
    raise SourceFormatError(
        f"{path}: unknown source format (expected .osm, .osm.pbf, .osm.bz2, .o5m, "
        "Overpass .json or .geojson)"
    )


def read_source(
    path: str | os.PathLike[str],
    *,
    kinds: Iterable[str] = ("tram",),
    progress: bool | None = None,
) -> SourceData:
    """Read the track ways of the given kinds from a source file.

    Parameters
    ----------
    path : path-like
        ``.osm``, ``.osm.pbf`` (and other osmium formats), Overpass ``.json`` or ``.geojson``.
    kinds : iterable of str
        ``railway=`` values to keep (see :data:`KNOWN_KINDS`).
    progress : bool, optional
        Show a progress bar; default: only for files above 20 MB.

    Returns
    -------
    SourceData

    Raises
    ------
    SourceError
        The file is missing or unreadable (also an ``OSError``).
    SourceFormatError
        Unknown format or unparsable content (also a ``ValueError``); the message names
        the file, the element and what is wrong.
    NoTracksError
        No operating track of the requested kinds in the file.
    MissingDependencyError
        An OSM XML/PBF file without osmium installed (also an ``ImportError``).
    ParameterError
        An unknown track kind.
    """
    p = Path(path)
    kind_set = check_kinds(kinds)
    if not p.exists():
        raise SourceError(f"{p}: no such file")
    if not p.is_file():
        raise SourceError(f"{p}: not a regular file")
    if not os.access(p, os.R_OK):
        raise SourceError(f"{p}: not readable (permission denied)")
    size = p.stat().st_size
    if size == 0:
        raise SourceFormatError(f"{p}: empty file")
    show = progress if progress is not None else size > PROGRESS_BYTES
    fmt = detect_format(p)
    if fmt == "osmium":
        data = _read_osmium(p, kind_set, show)
    elif fmt == "overpass-json":
        data = read_overpass(p, kind_set)
    else:
        data = read_geojson(p, kind_set)
    if data.clipped:
        logger.warning(
            "%s: %d way(s) cut by the extract's boundary kept as %d piece(s) "
            "(%d node references without a location)",
            p,
            data.clipped["ways"],
            data.clipped["pieces"],
            data.clipped["missing_refs"],
        )
    if not data.ways:
        reasons = ", ".join(f"{k}: {v}" for k, v in sorted(data.dropped.items())) or "none"
        raise NoTracksError(
            f"{p}: no operating track of kinds {sorted(kind_set)} (ways dropped: {reasons})"
        )
    logger.info(
        "%s: %d track ways, %d stops (%s); dropped %s",
        p,
        data.kept_ways,
        len(data.stops),
        fmt,
        dict(data.dropped),
    )
    return data


# -- filters ------------------------------------------------------------------------------
def check_kinds(kinds: Iterable[str]) -> frozenset[str]:
    """The set of railway kinds asked for (a comma-separated string or an iterable).

    Raises
    ------
    ParameterError
        An unknown kind, or none.
    """
    if isinstance(kinds, str):
        kinds = [k.strip() for k in kinds.split(",")]
    try:
        kind_set = frozenset(kinds)
    except TypeError:
        raise ParameterError(f"kinds must be names of track kinds, got {kinds!r:.60}") from None
    unknown = kind_set - set(KNOWN_KINDS)
    if unknown or not kind_set:
        shown = sorted(str(k)[:30] for k in unknown)[:5]
        raise ParameterError(f"unknown track kinds {shown}; choose from {KNOWN_KINDS}")
    return kind_set


# -- osmium -------------------------------------------------------------------------------
def _read_osmium(path: Path, kinds: frozenset[str], progress: bool) -> SourceData:
    osmium = require("osmium", purpose=f"reading {path.name} (an OSM file)")
    data = SourceData([], [], str(path), "osmium")
    # libosmium reports parse errors as RuntimeError, bad ids as ValueError and bad
    # coordinates as InvalidLocationError (none of them names a line)
    parse_errors = (RuntimeError, ValueError, osmium.InvalidLocationError)
    try:
        processor = osmium.FileProcessor(str(path))
        data.bounds = _osmium_bounds(processor)
        processor = processor.with_locations().with_filter(
            osmium.filter.KeyFilter("railway", "railway:switch", "public_transport")
        )
        iterator: Iterable[Any] = (
            _with_progress(processor, f"reading {path.name}") if progress else processor
        )
        for obj in iterator:
            if obj.is_node():
                tags = dict(obj.tags)
                if is_topology_node(tags):
                    data.node_tags[obj.id] = tags
                if is_stop(tags) and obj.location.valid():
                    data.stops.append(
                        RawStop(obj.id, obj.location.lon, obj.location.lat, tags.get("name"))
                    )
            elif obj.is_way():
                tags = dict(obj.tags)
                reason = way_rejection(tags, kinds)
                if reason:
                    data.dropped[reason] += 1
                    continue
                refs: list[tuple[int, float, float] | int] = []
                for n in obj.nodes:
                    loc = n.location
                    refs.append((n.ref, loc.lon, loc.lat) if loc.valid() else n.ref)
                add_way(data, obj.id, refs, tags)
    except parse_errors as exc:
        raise SourceFormatError(f"{path}: cannot parse as an OSM file: {_clip(exc)}") from None
    return data


def _osmium_bounds(processor: Any) -> tuple[float, float, float, float] | None:
    box = processor.header.box()
    if not box.valid():
        return None
    bl, tr = box.bottom_left, box.top_right
    return (bl.lon, bl.lat, tr.lon, tr.lat)


def _with_progress(items: Iterable[Any], desc: str) -> Iterable[Any]:
    """``items`` behind a tqdm progress bar, or as they are when tqdm is not installed."""
    try:
        tqdm = require("tqdm", purpose="a progress bar").tqdm
    except MissingDependencyError as exc:
        # a progress bar is a convenience: never fail a build for the want of one
        logger.warning("%s; reading without one", exc)
        return items
    return tqdm(items, desc=desc, unit=" obj", leave=False)


# -- helpers ------------------------------------------------------------------------------
def _read_head(path: Path, n: int) -> str:
    try:
        with path.open("rb") as fh:
            return fh.read(n).decode("utf-8", errors="replace")
    except OSError as exc:
        raise SourceError(f"{path}: cannot read: {exc.strerror or exc}") from exc


def _clip(value: object, limit: int = 200) -> str:
    text = str(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
