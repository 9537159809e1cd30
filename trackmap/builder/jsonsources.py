"""Reading JSON sources: Overpass JSON and GeoJSON, checked element by element.

A value of the wrong type (tags given as a list, ``"nodes": "12"``, a coordinate that is a
string, an id that is not an integer) or out of range (a latitude of 91, ``NaN``) makes
the file unusable: :class:`~trackmap.errors.SourceFormatError` names the file, the element
(its index and id) and what is wrong. What is legitimately absent is counted instead: a
node without coordinates is outside the extract (its ways are cut there, see
:mod:`trackmap.builder.sources`), a GeoJSON feature without geometry is dropped by reason.
"""

from __future__ import annotations

import json
import logging
import math
import re
from pathlib import Path
from typing import Any

from trackmap.builder.rawdata import (
    INT64_MAX,
    INT64_MIN,
    RawStop,
    SourceData,
    add_way,
    coordinate_node_id,
    is_stop,
    is_topology_node,
    valid_lonlat,
    way_rejection,
)
from trackmap.errors import SourceError, SourceFormatError

__all__ = ["MAX_TAG_CHARS", "load_json", "read_geojson", "read_overpass"]

logger = logging.getLogger(__name__)

_ID_TEXT = re.compile(r"-?[0-9]{1,19}")
#: The longest tag key or value OSM allows, characters.
MAX_TAG_CHARS = 255


class _Bad(ValueError):
    """An element of a JSON source is malformed (caught and given the file's name)."""


# -- Overpass JSON ------------------------------------------------------------------------
def read_overpass(path: Path, kinds: frozenset[str]) -> SourceData:
    """Read the track ways and stops of an Overpass JSON file (``out body``/``out geom``).

    Raises
    ------
    SourceError
        The file cannot be read.
    SourceFormatError
        Not JSON, no ``elements`` list, or a malformed element (named by index and id).
    """
    doc = load_json(path)
    elements = doc.get("elements") if isinstance(doc, dict) else None
    if not isinstance(elements, list):
        raise SourceFormatError(f"{path}: Overpass JSON without an 'elements' list")
    data = SourceData([], [], str(path), "overpass-json")
    nodes: dict[int, tuple[float, float]] = {}
    ways: list[tuple[str, dict[str, Any], int]] = []
    for i, el in enumerate(elements):
        where = f"element {i}"
        try:
            if not isinstance(el, dict):
                raise _Bad("is not a JSON object")
            typ = el.get("type")
            if typ not in ("node", "way"):
                if not isinstance(typ, str):
                    raise _Bad("has no type")
                continue  # relations, areas, counts: not track geometry
            eid = _osm_id(el.get("id"), "id")
            where = f"element {i} ({typ} {eid})"
            if typ == "way":
                ways.append((where, el, eid))
                continue
            tags = _tags(el.get("tags"))
            if "lat" not in el and "lon" not in el:
                continue  # a node without coordinates: outside the extract
            lon, lat = _lonlat(el.get("lon"), el.get("lat"))
            nodes[eid] = (lon, lat)
            if is_topology_node(tags):
                data.node_tags[eid] = tags
            if is_stop(tags):
                data.stops.append(RawStop(eid, lon, lat, tags.get("name")))
        except _Bad as exc:
            raise SourceFormatError(f"{path}: {where}: {exc}") from None
    for where, el, eid in ways:
        try:
            tags = _tags(el.get("tags"))
            reason = way_rejection(tags, kinds)
            if reason:
                data.dropped[reason] += 1
                continue
            refs = _refs(el.get("nodes"), el.get("geometry"), nodes)
        except _Bad as exc:
            raise SourceFormatError(f"{path}: {where}: {exc}") from None
        add_way(data, eid, refs, tags)
    return data


def _refs(
    node_list: Any, geometry: Any, nodes: dict[int, tuple[float, float]]
) -> list[tuple[int, float, float] | int]:
    """A way's nodes with their locations (from the node elements or ``out geom``)."""
    if node_list is None:
        node_list = []
    if not isinstance(node_list, list):
        raise _Bad(f"'nodes' must be a list of node ids, got {_kind(node_list)}")
    if geometry is not None and not isinstance(geometry, list):
        raise _Bad(f"'geometry' must be a list of positions, got {_kind(geometry)}")
    refs: list[tuple[int, float, float] | int] = []
    for j, ref in enumerate(node_list):
        nid = _osm_id(ref, f"nodes[{j}]")
        if nid in nodes:
            refs.append((nid, *nodes[nid]))
        elif geometry is not None and j < len(geometry) and geometry[j] is not None:
            g = geometry[j]
            if not isinstance(g, dict):
                raise _Bad(f"geometry[{j}] must be an object with lat and lon")
            refs.append((nid, *_lonlat(g.get("lon"), g.get("lat"), f"geometry[{j}]")))
        else:
            refs.append(nid)
    return refs


# -- GeoJSON ------------------------------------------------------------------------------
def read_geojson(path: Path, kinds: frozenset[str]) -> SourceData:
    """Read the track lines and stops of a GeoJSON Feature or FeatureCollection.

    Raises
    ------
    SourceError
        The file cannot be read.
    SourceFormatError
        Not JSON, not a Feature(Collection), a trackmap map file, or a malformed feature
        (named by index).
    """
    doc = load_json(path)
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
    try:
        data.bounds = _bbox(doc.get("bbox"))
    except _Bad as exc:
        raise SourceFormatError(f"{path}: bbox: {exc}") from None
    for i, feat in enumerate(features):
        try:
            _geojson_feature(data, feat, i, kinds)
        except _Bad as exc:
            raise SourceFormatError(f"{path}: feature {i}: {exc}") from None
    return data


def _geojson_feature(data: SourceData, feat: Any, i: int, kinds: frozenset[str]) -> None:
    if not isinstance(feat, dict):
        raise _Bad("is not a JSON object")
    geom = feat.get("geometry")
    if geom is None:
        data.dropped["no_geometry"] += 1
        return
    if not isinstance(geom, dict):
        raise _Bad(f"'geometry' must be an object or null, got {_kind(geom)}")
    props = feat.get("properties")
    if props is None:
        props = {}
    if not isinstance(props, dict):
        raise _Bad(f"'properties' must be an object or null, got {_kind(props)}")
    # properties that are objects or lists (osmtogeojson's "relations", "meta") are not tags
    tags = {
        str(k): _tag_value(v, f"properties.{k}")
        for k, v in props.items()
        if v is not None and k not in ("nodes", "tags") and not isinstance(v, (dict, list))
    }
    if "railway" not in tags and props.get("tags") is not None:
        tags.update(_tags(props["tags"]))
    gtype = geom.get("type")
    coords = geom.get("coordinates")
    if gtype == "Point":
        lon, lat = _position(coords, "geometry.coordinates")
        if is_topology_node(tags):
            data.node_tags[coordinate_node_id(lon, lat)] = tags
        if is_stop(tags):
            data.stops.append(RawStop(_feature_id(feat, props, i), lon, lat, tags.get("name")))
        return
    if gtype == "LineString":
        lines = [_line(coords, "geometry.coordinates")]
    elif gtype == "MultiLineString":
        if not isinstance(coords, list):
            raise _Bad("geometry.coordinates of a MultiLineString must be a list of lines")
        lines = [_line(c, f"geometry.coordinates[{k}]") for k, c in enumerate(coords)]
    elif isinstance(gtype, str):
        data.dropped["not_a_line"] += 1
        return
    else:
        raise _Bad("geometry has no type")
    reason = way_rejection(tags, kinds)
    if reason:
        data.dropped[reason] += 1
        return
    fid = _feature_id(feat, props, i)
    node_list = props.get("nodes")
    if node_list is not None and not isinstance(node_list, list):
        raise _Bad(f"properties.nodes must be a list of node ids, got {_kind(node_list)}")
    if not lines:
        data.dropped["too_short"] += 1
        return
    for k, line in enumerate(lines):
        if node_list is not None and len(lines) == 1 and len(node_list) == len(line):
            ids = [_osm_id(n, f"properties.nodes[{j}]") for j, n in enumerate(node_list)]
        else:
            ids = [coordinate_node_id(lon, lat) for lon, lat in line]
        way_id = fid if len(lines) == 1 else fid * 1000 + k
        if not INT64_MIN <= way_id <= INT64_MAX:
            raise _Bad(f"feature id {fid} is too large to number the lines of a MultiLineString")
        refs: list[tuple[int, float, float] | int] = [
            (n, lon, lat) for n, (lon, lat) in zip(ids, line, strict=True)
        ]
        add_way(data, way_id, refs, tags)


def _feature_id(feat: dict[str, Any], props: dict[str, Any], index: int) -> int:
    for candidate in (props.get("osm_id"), props.get("@id"), props.get("id"), feat.get("id")):
        if candidate is None or isinstance(candidate, bool):
            continue
        text = str(candidate)[-40:].rsplit("/", 1)[-1]
        if _ID_TEXT.fullmatch(text) and INT64_MIN <= int(text) <= INT64_MAX:
            return int(text)
    return index + 1


def _bbox(value: Any) -> tuple[float, float, float, float] | None:
    if value is None:
        return None
    if not isinstance(value, list) or len(value) not in (4, 6):
        raise _Bad("must be a list of 4 (or 6) numbers")
    if len(value) == 6:  # with elevations: [w, s, low, e, n, high]
        value = [value[0], value[1], value[3], value[4]]
    w, s = _lonlat(value[0], value[1], "south-west corner")
    e, n = _lonlat(value[2], value[3], "north-east corner")
    if s > n:
        raise _Bad(f"its south {s} lies north of its north {n}")
    return (w, s, e, n)


# -- values -------------------------------------------------------------------------------
def _osm_id(value: Any, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _Bad(f"{what} must be an integer id, got {_kind(value)}")
    if not INT64_MIN <= value <= INT64_MAX:
        raise _Bad(f"{what} is out of the range of a 64-bit id")
    return value


def _tags(value: Any) -> dict[str, str]:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise _Bad(f"'tags' must be an object of key/value strings, got {_kind(value)}")
    return {_text(k, "a tag key"): _tag_value(v, f"tags.{k}") for k, v in value.items()}


def _tag_value(value: Any, what: str) -> str:
    if isinstance(value, str):
        return _text(value, _clip(what, 60))
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, float)):
        return str(value)
    raise _Bad(f"{_clip(what, 60)} must be a string, got {_kind(value)}")


def _text(value: str, what: str) -> str:
    """A tag key or value as OSM allows it: at most 255 characters of valid Unicode."""
    if len(value) > MAX_TAG_CHARS:
        raise _Bad(f"{what} is {len(value):,} characters long; OSM allows {MAX_TAG_CHARS}")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise _Bad(f"{what} is not valid Unicode text (a lone surrogate)") from None
    return value


def _lonlat(lon: Any, lat: Any, what: str = "") -> tuple[float, float]:
    if not valid_lonlat(lon, lat):
        prefix = f"{what}: " if what else ""
        raise _Bad(
            f"{prefix}lon {_clip(repr(lon))}, lat {_clip(repr(lat))} is not a valid WGS84 "
            "position (numbers, -180..180 and -90..90)"
        )
    return float(lon), float(lat)


def _position(value: Any, what: str) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) < 2:
        raise _Bad(f"{what} must be a position [lon, lat], got {_kind(value)}")
    return _lonlat(value[0], value[1], what)


def _line(value: Any, what: str) -> list[tuple[float, float]]:
    if not isinstance(value, list):
        raise _Bad(f"{what} must be a list of positions, got {_kind(value)}")
    return [_position(c, f"{what}[{j}]") for j, c in enumerate(value)]


def _kind(value: Any) -> str:
    """A short description of a value for messages (never the whole value)."""
    if value is None:
        return "null"
    name = {dict: "an object", list: "a list", str: "a string", bool: "a boolean"}.get(
        type(value), type(value).__name__
    )
    return f"{name} {_clip(repr(value), 40)}"


def _clip(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def load_json(path: Path) -> Any:
    """Parse a JSON source file.

    Raises
    ------
    SourceError
        The file cannot be read.
    SourceFormatError
        Not valid JSON (line and column), not UTF-8, nested too deeply, or a number
        Python cannot hold.
    """
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise SourceError(f"{path}: cannot read: {exc.strerror or exc}") from exc
    try:
        return json.loads(raw, parse_constant=_nan)
    except json.JSONDecodeError as exc:
        raise SourceFormatError(f"{path}: invalid JSON: {exc}") from None
    except UnicodeDecodeError as exc:
        raise SourceFormatError(
            f"{path}: invalid JSON: not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at "
            f"offset {exc.start})"
        ) from None
    except RecursionError:
        raise SourceFormatError(f"{path}: invalid JSON: nested too deeply") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise SourceFormatError(f"{path}: invalid JSON: {_clip(str(exc), 120)}") from None


def _nan(name: str) -> float:
    return math.nan  # NaN/Infinity parse, then fail the position checks with their element
