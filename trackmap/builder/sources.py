"""Reading stored track geometry: OSM XML/PBF (osmium), Overpass JSON and GeoJSON.

Every reader returns :class:`SourceData`: the track ways of the requested kinds (with node
ids and WGS84 coordinates) and the tram stops. Filtering happens here, so a whole-city
extract with roads and buildings works as well as a tram-only file.
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections import Counter
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from trackmap.errors import MissingDependencyError, NoTracksError, SourceError, SourceFormatError
from trackmap.optional import require

__all__ = [
    "KNOWN_KINDS",
    "LIFECYCLE",
    "MARKED_SERVICES",
    "OSMIUM_SUFFIXES",
    "PROGRESS_BYTES",
    "TOPOLOGY_NODE_VALUES",
    "RawStop",
    "RawWay",
    "SourceData",
    "coordinate_node_id",
    "detect_format",
    "read_source",
    "way_rejection",
]

logger = logging.getLogger(__name__)

#: Railway kinds a map can be built from.
KNOWN_KINDS = ("tram", "light_rail", "rail", "subway", "narrow_gauge")
#: Lifecycle prefixes/values that mean "not an operating track".
LIFECYCLE = ("disused", "abandoned", "razed", "construction", "proposed", "dismantled")
#: ``service=`` values kept but marked (depot and auxiliary tracks).
MARKED_SERVICES = ("yard", "siding", "spur", "crossover")
#: Files larger than this show a progress bar while read, bytes.
PROGRESS_BYTES = 20_000_000

OSMIUM_SUFFIXES = (".osm.pbf", ".pbf", ".osm", ".osm.bz2", ".osm.gz", ".o5m", ".osc")


@dataclass(frozen=True, slots=True)
class RawWay:
    """One track way as read from a source.

    Attributes
    ----------
    way_id : int
        OSM way id (or a feature id for GeoJSON without OSM ids).
    node_ids : tuple of int
        Node ids along the way. For GeoJSON without node ids, ids derived from the
        coordinates so that shared vertices join.
    lon, lat : tuple of float
        Node coordinates, degrees.
    tags : dict
        The way's tags.
    """

    way_id: int
    node_ids: tuple[int, ...]
    lon: tuple[float, ...]
    lat: tuple[float, ...]
    tags: Mapping[str, str]


@dataclass(frozen=True, slots=True)
class RawStop:
    """A stop position (``railway=tram_stop`` and similar) read from a source."""

    node_id: int
    lon: float
    lat: float
    name: str | None


@dataclass
class SourceData:
    """Everything a map is built from.

    Attributes
    ----------
    ways : list of RawWay
        Kept track ways.
    stops : list of RawStop
        Stop positions.
    path : str
        The source file.
    fmt : str
        ``osmium``, ``overpass-json`` or ``geojson``.
    dropped : Counter
        Ways not kept, by reason (``other_kind``, ``lifecycle``, ``area``, ``too_short``,
        ``missing_nodes``).
    node_tags : dict
        Tags of nodes that describe track topology (``railway=switch``,
        ``railway=railway_crossing``, ``railway=buffer_stop``, ``railway:switch=*``).
    """

    ways: list[RawWay]
    stops: list[RawStop]
    path: str
    fmt: str
    dropped: Counter[str] = field(default_factory=Counter)
    node_tags: dict[int, dict[str, str]] = field(default_factory=dict)


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
        Unknown format or unparsable content (also a ``ValueError``).
    NoTracksError
        No operating track of the requested kinds in the file.
    MissingDependencyError
        An OSM XML/PBF file without osmium installed (also an ``ImportError``).
    """
    p = Path(path)
    kind_set = _check_kinds(kinds)
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
        data = _read_overpass(p, kind_set)
    else:
        data = _read_geojson(p, kind_set)
    if not data.ways:
        reasons = ", ".join(f"{k}: {v}" for k, v in sorted(data.dropped.items())) or "none"
        raise NoTracksError(
            f"{p}: no operating track of kinds {sorted(kind_set)} (ways dropped: {reasons})"
        )
    logger.info(
        "%s: %d track ways, %d stops (%s); dropped %s",
        p,
        len(data.ways),
        len(data.stops),
        fmt,
        dict(data.dropped),
    )
    return data


# -- filters ------------------------------------------------------------------------------
def _check_kinds(kinds: Iterable[str]) -> frozenset[str]:
    if isinstance(kinds, str):
        kinds = [k.strip() for k in kinds.split(",")]
    kind_set = frozenset(kinds)
    unknown = kind_set - set(KNOWN_KINDS)
    if unknown or not kind_set:
        raise ValueError(f"unknown track kinds {sorted(unknown)}; choose from {KNOWN_KINDS}")
    return kind_set


def way_rejection(tags: Mapping[str, str], kinds: frozenset[str]) -> str | None:
    """Why a way is not an operating track of the wanted kinds (None if it is one)."""
    railway = tags.get("railway")
    if railway in LIFECYCLE:
        return "lifecycle"
    if railway not in kinds:
        return "other_kind"
    for key in LIFECYCLE:
        if tags.get(key, "no") not in ("no", "") or f"{key}:railway" in tags:
            return "lifecycle"
    if tags.get("area") == "yes":
        return "area"
    return None


TOPOLOGY_NODE_VALUES = ("switch", "railway_crossing", "buffer_stop")


def _is_topology_node(tags: Mapping[str, str]) -> bool:
    return tags.get("railway") in TOPOLOGY_NODE_VALUES or "railway:switch" in tags


def _is_stop(tags: Mapping[str, str]) -> bool:
    return tags.get("railway") in ("tram_stop", "stop", "halt") or (
        tags.get("public_transport") == "stop_position"
        and (tags.get("tram") == "yes" or tags.get("light_rail") == "yes")
    )


# -- osmium -------------------------------------------------------------------------------
def _read_osmium(path: Path, kinds: frozenset[str], progress: bool) -> SourceData:
    osmium = require("osmium", purpose=f"reading {path.name} (an OSM file)")
    data = SourceData([], [], str(path), "osmium")
    try:
        processor = (
            osmium.FileProcessor(str(path))
            .with_locations()
            .with_filter(osmium.filter.KeyFilter("railway", "railway:switch", "public_transport"))
        )
        iterator: Iterable[Any] = (
            _with_progress(processor, f"reading {path.name}") if progress else processor
        )
        for obj in iterator:
            if obj.is_node():
                tags = dict(obj.tags)
                if _is_topology_node(tags):
                    data.node_tags[obj.id] = tags
                if _is_stop(tags) and obj.location.valid():
                    data.stops.append(
                        RawStop(obj.id, obj.location.lon, obj.location.lat, tags.get("name"))
                    )
            elif obj.is_way():
                tags = dict(obj.tags)
                reason = way_rejection(tags, kinds)
                if reason:
                    data.dropped[reason] += 1
                    continue
                try:
                    nodes = [(n.ref, n.location.lon, n.location.lat) for n in obj.nodes]
                except osmium.InvalidLocationError:
                    data.dropped["missing_nodes"] += 1
                    logger.warning("%s: way %d has nodes without a location", path, obj.id)
                    continue
                _add_way(data, obj.id, nodes, tags)
    except RuntimeError as exc:  # libosmium reports parse errors as RuntimeError
        raise SourceFormatError(f"{path}: cannot parse as an OSM file: {exc}") from exc
    return data


def _with_progress(items: Iterable[Any], desc: str) -> Iterable[Any]:
    """``items`` behind a tqdm progress bar, or as they are when tqdm is not installed."""
    try:
        tqdm = require("tqdm", purpose="a progress bar").tqdm
    except MissingDependencyError as exc:
        # a progress bar is a convenience: never fail a build for the want of one
        logger.warning("%s; reading without one", exc)
        return items
    return tqdm(items, desc=desc, unit=" obj", leave=False)


# -- Overpass JSON ------------------------------------------------------------------------
def _read_overpass(path: Path, kinds: frozenset[str]) -> SourceData:
    doc = _load_json(path)
    elements = doc.get("elements") if isinstance(doc, dict) else None
    if not isinstance(elements, list):
        raise SourceFormatError(f"{path}: Overpass JSON without an 'elements' list")
    data = SourceData([], [], str(path), "overpass-json")
    nodes: dict[int, tuple[float, float]] = {}
    ways: list[dict[str, Any]] = []
    for i, el in enumerate(elements):
        if not isinstance(el, dict) or "type" not in el or "id" not in el:
            raise SourceFormatError(f"{path}: element {i} has no type or id")
        if el["type"] == "node":
            lon, lat = el.get("lon"), el.get("lat")
            if not _valid_lonlat(lon, lat) or lon is None or lat is None:
                data.dropped["bad_node"] += 1
                continue
            nodes[int(el["id"])] = (float(lon), float(lat))
            tags = {str(k): str(v) for k, v in (el.get("tags") or {}).items()}
            if _is_topology_node(tags):
                data.node_tags[int(el["id"])] = tags
            if _is_stop(tags):
                data.stops.append(RawStop(int(el["id"]), float(lon), float(lat), tags.get("name")))
        elif el["type"] == "way":
            ways.append(el)
    for el in ways:
        tags = {str(k): str(v) for k, v in (el.get("tags") or {}).items()}
        reason = way_rejection(tags, kinds)
        if reason:
            data.dropped[reason] += 1
            continue
        refs = el.get("nodes") or []
        geometry = el.get("geometry")  # "out geom" exports carry coordinates inline
        coords: list[tuple[int, float, float]] = []
        for j, ref in enumerate(refs):
            if int(ref) in nodes:
                coords.append((int(ref), *nodes[int(ref)]))
            elif isinstance(geometry, list) and j < len(geometry) and geometry[j]:
                g = geometry[j]
                coords.append((int(ref), float(g["lon"]), float(g["lat"])))
            else:
                coords = []
                break
        if not coords:
            data.dropped["missing_nodes"] += 1
            logger.warning("%s: way %s references nodes that are not in the file", path, el["id"])
            continue
        _add_way(data, int(el["id"]), coords, tags)
    return data


# -- GeoJSON ------------------------------------------------------------------------------
def _read_geojson(path: Path, kinds: frozenset[str]) -> SourceData:
    doc = _load_json(path)
    if isinstance(doc, dict) and "trackmap" in doc:
        raise SourceFormatError(
            f"{path}: this is a trackmap map file; open it with trackmap.load(), not build()"
        )
    features: list[Any]
    if isinstance(doc, dict) and doc.get("type") == "Feature":
        features = [doc]
    elif isinstance(doc, dict) and doc.get("type") == "FeatureCollection":
        listed = doc.get("features")
        if not isinstance(listed, list):
            raise SourceFormatError(f"{path}: FeatureCollection without a 'features' list")
        features = listed
    else:
        raise SourceFormatError(f"{path}: GeoJSON must be a Feature or a FeatureCollection")
    data = SourceData([], [], str(path), "geojson")
    for i, feat in enumerate(features):
        if not isinstance(feat, dict) or not isinstance(feat.get("geometry"), dict):
            data.dropped["no_geometry"] += 1
            continue
        props = feat.get("properties") or {}
        tags = {str(k): str(v) for k, v in props.items() if v is not None and k != "nodes"}
        if "railway" not in tags and isinstance(props.get("tags"), dict):
            tags.update({str(k): str(v) for k, v in props["tags"].items()})
        geom = feat["geometry"]
        gtype = geom.get("type")
        if gtype == "Point":
            coords = geom.get("coordinates") or []
            valid_point = len(coords) >= 2 and _valid_lonlat(coords[0], coords[1])
            if valid_point and _is_topology_node(tags):
                data.node_tags[coordinate_node_id(coords[0], coords[1])] = tags
            if _is_stop(tags) and valid_point:
                data.stops.append(
                    RawStop(_feature_id(feat, props, i), coords[0], coords[1], tags.get("name"))
                )
            continue
        if gtype == "LineString":
            lines = [geom.get("coordinates")]
        elif gtype == "MultiLineString":
            lines = list(geom.get("coordinates") or [])
        else:
            data.dropped["not_a_line"] += 1
            continue
        reason = way_rejection(tags, kinds)
        if reason:
            data.dropped[reason] += 1
            continue
        fid = _feature_id(feat, props, i)
        node_list = props.get("nodes")
        for k, line in enumerate(lines):
            if not isinstance(line, list) or not all(
                isinstance(c, (list, tuple)) and len(c) >= 2 and _valid_lonlat(c[0], c[1])
                for c in line
            ):
                data.dropped["bad_coordinates"] += 1
                logger.warning("%s: feature %d has invalid coordinates", path, i)
                continue
            if isinstance(node_list, list) and len(lines) == 1 and len(node_list) == len(line):
                ids = [int(n) for n in node_list]
            else:
                ids = [coordinate_node_id(c[0], c[1]) for c in line]
            coords = [(n, float(c[0]), float(c[1])) for n, c in zip(ids, line, strict=True)]
            way_id = fid if len(lines) == 1 else fid * 1000 + k
            _add_way(data, way_id, coords, tags)
    return data


def coordinate_node_id(lon: float, lat: float) -> int:
    """A stable negative node id from coordinates rounded to 1e-7 degree.

    GeoJSON has no node ids; vertices at the same rounded position get the same id so
    lines that share vertices join (negative ids never clash with OSM ids).
    """
    ilon = round(lon * 1e7) + 1_800_000_000
    ilat = round(lat * 1e7) + 900_000_000
    return -(ilon * 2_000_000_000 + ilat) - 1


def _feature_id(feat: dict[str, Any], props: dict[str, Any], index: int) -> int:
    for candidate in (props.get("osm_id"), props.get("@id"), props.get("id"), feat.get("id")):
        if candidate is None:
            continue
        text = str(candidate).rsplit("/", 1)[-1]
        if text.lstrip("-").isdigit():
            return int(text)
    return index + 1


# -- helpers ------------------------------------------------------------------------------
def _add_way(
    data: SourceData, way_id: int, nodes: list[tuple[int, float, float]], tags: dict[str, str]
) -> None:
    # consecutive repeated nodes (drawing errors) carry no geometry
    cleaned = [n for i, n in enumerate(nodes) if i == 0 or n[0] != nodes[i - 1][0]]
    if len(cleaned) < 2:
        data.dropped["too_short"] += 1
        return
    data.ways.append(
        RawWay(
            way_id=way_id,
            node_ids=tuple(n[0] for n in cleaned),
            lon=tuple(n[1] for n in cleaned),
            lat=tuple(n[2] for n in cleaned),
            tags=tags,
        )
    )


def _valid_lonlat(lon: object, lat: object) -> bool:
    return (
        isinstance(lon, (int, float))
        and isinstance(lat, (int, float))
        and math.isfinite(lon)
        and math.isfinite(lat)
        and -180.0 <= lon <= 180.0
        and -90.0 <= lat <= 90.0
    )


def _read_head(path: Path, n: int) -> str:
    try:
        with path.open("rb") as fh:
            return fh.read(n).decode("utf-8", errors="replace")
    except OSError as exc:
        raise SourceError(f"{path}: cannot read: {exc.strerror or exc}") from exc


def _load_json(path: Path) -> Any:
    try:
        with path.open("rb") as fh:
            return json.load(fh)
    except OSError as exc:
        raise SourceError(f"{path}: cannot read: {exc.strerror or exc}") from exc
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise SourceFormatError(f"{path}: invalid JSON: {exc}") from exc
