"""The trackmap map file: a versioned GeoJSON FeatureCollection.

Layout (format ``trackmap``, version 1)::

    {
      "type": "FeatureCollection",
      "trackmap": {"format": "trackmap", "version": 1, "crs_wkt": "<WKT2>",
                   "driving_side": "right", "source": {...}, "build": {...},
                   "attribution": "...", "created": "<ISO 8601>", "stats": {...}},
      "features": [
        {"type": "Feature", "geometry": {"type": "LineString", ...},
         "properties": {"feature": "edge", "edge_id": 0, ...}},
        {"type": "Feature", "geometry": {"type": "Point", ...},
         "properties": {"feature": "node", "node_id": 123, "class": "point_switch", ...}},
        {"type": "Feature", ..., "properties": {"feature": "conflict", ...}},
        {"type": "Feature", ..., "properties": {"feature": "stop", ...}},
        {"type": "Feature", ..., "properties": {"feature": "grade_separated", ...}}
      ]
    }

Geometry is WGS84 (RFC 7946), so the file opens in any GIS. The WGS84 vertices are the
canonical geometry: local coordinates are recomputed from them with the stored CRS, which
makes ``load(save(net)) == net`` exact.

This module translates between the file and the map's records (:class:`~trackmap.model.MapData`);
:class:`trackmap.TrackMap` is built from those by :func:`trackmap.load`.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import shapely

from trackmap.crs import LocalFrame
from trackmap.errors import MapFileError, SourceError
from trackmap.kinds import ConflictKind, NodeClass
from trackmap.model import (
    ConflictPoint,
    Edge,
    GradeSeparation,
    MapData,
    MapMetadata,
    Node,
    Stop,
)

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "from_geojson", "read", "to_geojson", "write"]

FORMAT_NAME = "trackmap"
FORMAT_VERSION = 1


def to_geojson(data: MapData, *, stats: Mapping[str, Any]) -> dict[str, Any]:
    """A map as a GeoJSON-compatible dict (see the module docstring).

    Parameters
    ----------
    data : MapData
        The map's records.
    stats : mapping
        Summary figures written to the header (:meth:`trackmap.TrackMap.stats`).

    Returns
    -------
    dict
    """
    features: list[dict[str, Any]] = []
    for e in data.edges:
        features.append(
            {
                "type": "Feature",
                "geometry": {
                    "type": "LineString",
                    "coordinates": [[lon, lat] for lon, lat in zip(e.lon, e.lat, strict=True)],
                },
                "properties": {
                    "feature": "edge",
                    "edge_id": e.edge_id,
                    "start_node": e.start_node,
                    "end_node": e.end_node,
                    "node_ids": list(e.node_ids),
                    "way_ids": list(e.way_ids),
                    "kind": e.kind,
                    "service": e.service,
                    "layer": e.layer,
                    "bridge": e.bridge,
                    "tunnel": e.tunnel,
                    "maxspeed_mps": e.maxspeed_mps,
                    "direction": e.direction,
                    "direction_source": e.direction_source,
                    "name": e.name,
                    "length_m": round(e.length_m, 3),
                },
            }
        )
    for n in data.nodes:
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": [n.lon, n.lat]},
                "properties": {
                    "feature": "node",
                    "node_id": n.node_id,
                    "class": n.cls,
                    "ends": [list(end) for end in n.ends],
                    "allowed": [list(pr) for pr in n.allowed],
                },
            }
        )
    for c in data.conflicts:
        lon, lat = data.frame.to_lonlat(c.x, c.y)
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": [lon, lat]},
                "properties": {
                    "feature": "conflict",
                    "conflict_id": c.conflict_id,
                    "kind": c.kind,
                    "x": c.x,
                    "y": c.y,
                    "node_id": c.node_id,
                    "edges": list(c.edges),
                    "offsets_m": list(c.offsets_m),
                    "extents_m": list(c.extents_m),
                    "angle_deg": c.angle_deg,
                },
            }
        )
    for s in data.stops:
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": [s.lon, s.lat]},
                "properties": {
                    "feature": "stop",
                    "stop_id": s.stop_id,
                    "name": s.name,
                    "edge_id": s.edge_id,
                    "offset_m": s.offset_m,
                },
            }
        )
    for a, b, x, y in data.grade_separated:
        lon, lat = data.frame.to_lonlat(x, y)
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": [lon, lat]},
                "properties": {"feature": "grade_separated", "edges": [a, b], "x": x, "y": y},
            }
        )
    header = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "crs_wkt": data.frame.wkt,
        **data.metadata.as_dict(),
        "stats": dict(stats),
    }
    return {"type": "FeatureCollection", "trackmap": header, "features": features}


def write(data: MapData, path: str | os.PathLike[str], *, stats: Mapping[str, Any]) -> Path:
    """Write a map file (atomically: a partly written file never replaces a good one).

    Parameters
    ----------
    data : MapData
        The map's records.
    path : path-like
        Destination, conventionally ``*.trackmap.geojson``.
    stats : mapping
        Summary figures written to the header.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    trackmap.errors.SourceError
        The file cannot be written (also an ``OSError``).
    """
    p = Path(path)
    doc = to_geojson(data, stats=stats)
    tmp = p.with_name(p.name + ".tmp")
    try:
        with tmp.open("w", encoding="utf-8") as fh:
            json.dump(doc, fh, ensure_ascii=False, separators=(",", ":"), allow_nan=False)
        tmp.replace(p)
    except OSError as exc:
        raise SourceError(f"{p}: cannot write the map file: {exc.strerror or exc}") from exc
    return p


def read(path: str | os.PathLike[str]) -> MapData:
    """The records of a map file, validated (:func:`trackmap.load` builds a TrackMap of them).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    MapData

    Raises
    ------
    trackmap.errors.SourceError
        The file does not exist or cannot be read.
    trackmap.errors.MapFileError
        The file is not valid JSON or not a valid map of this format version; the
        message starts with the file name.
    """
    p = Path(path)
    if not p.exists():
        raise SourceError(f"{p}: no such map file")
    try:
        with p.open("rb") as fh:
            doc = json.load(fh)
    except OSError as exc:
        raise SourceError(f"{p}: cannot read: {exc.strerror or exc}") from exc
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise MapFileError(f"{p}: not valid JSON ({exc})") from exc
    try:
        return from_geojson(doc)
    except MapFileError as exc:
        raise MapFileError(f"{p}: {exc}") from None


def from_geojson(doc: Any) -> MapData:
    """The records of a map from its GeoJSON dict, validating everything.

    Raises
    ------
    trackmap.errors.MapFileError
        The content is not a valid map of this format version.
    """
    if not isinstance(doc, dict) or doc.get("type") != "FeatureCollection":
        raise MapFileError("not a GeoJSON FeatureCollection")
    header = doc.get("trackmap")
    if not isinstance(header, dict) or header.get("format") != FORMAT_NAME:
        raise MapFileError("not a trackmap map file (no 'trackmap' header with format 'trackmap')")
    version = header.get("version")
    if version != FORMAT_VERSION:
        raise MapFileError(
            f"map file format version {version!r} is not supported "
            f"(this trackmap reads version {FORMAT_VERSION}); rebuild the map with 'trackmap build'"
        )
    wkt = _req(header, "crs_wkt", str, "header")
    driving_side = header.get("driving_side", "right")
    if driving_side not in ("right", "left"):
        raise MapFileError(f"header: driving_side must be 'right' or 'left', got {driving_side!r}")
    frame = LocalFrame.from_wkt(wkt)
    features = doc.get("features")
    if not isinstance(features, list):
        raise MapFileError("'features' must be a list")

    edges: list[Edge] = []
    nodes: list[Node] = []
    conflicts: list[ConflictPoint] = []
    stops: list[Stop] = []
    grade_sep: list[GradeSeparation] = []
    for i, feat in enumerate(features):
        where = f"feature {i}"
        if not isinstance(feat, dict):
            raise MapFileError(f"{where}: not an object")
        props = feat.get("properties")
        geom = feat.get("geometry")
        if not isinstance(props, dict) or not isinstance(geom, dict):
            raise MapFileError(f"{where}: missing properties or geometry")
        kind = props.get("feature")
        if kind == "edge":
            edges.append(_edge(props, geom, frame, f"{where} (edge {props.get('edge_id')!r})"))
        elif kind == "node":
            nodes.append(_node(props, geom, frame, f"{where} (node {props.get('node_id')!r})"))
        elif kind == "conflict":
            conflicts.append(_conflict(props, f"{where} (conflict {props.get('conflict_id')!r})"))
        elif kind == "stop":
            lon, lat = _point(geom, where)
            stops.append(
                Stop(
                    stop_id=_req(props, "stop_id", int, where),
                    name=props.get("name"),
                    lon=lon,
                    lat=lat,
                    edge_id=props.get("edge_id"),
                    offset_m=props.get("offset_m"),
                )
            )
        elif kind == "grade_separated":
            a, b = _req(props, "edges", list, where)
            grade_sep.append(GradeSeparation(int(a), int(b), float(props["x"]), float(props["y"])))
        else:
            raise MapFileError(f"{where}: unknown feature type {kind!r}")
    edges.sort(key=lambda e: e.edge_id)
    if [e.edge_id for e in edges] != list(range(len(edges))):
        raise MapFileError("edge ids must be 0..n-1 without gaps or repeats")
    if not edges:
        raise MapFileError("the map has no edges")
    node_ids = {n.node_id for n in nodes}
    for e in edges:
        for nid in (e.start_node, e.end_node):
            if nid not in node_ids:
                raise MapFileError(
                    f"edge {e.edge_id} refers to node {nid}, which is not in the file"
                )
    for n in nodes:
        for eid, end in n.ends:
            if not 0 <= eid < len(edges) or end not in (0, 1):
                raise MapFileError(
                    f"node {n.node_id} refers to edge end {(eid, end)} that does not exist"
                )
            expected = edges[eid].start_node if end == 0 else edges[eid].end_node
            if expected != n.node_id:
                raise MapFileError(
                    f"node {n.node_id} lists edge {eid} end {end}, which ends at node {expected}"
                )
        for i, j in n.allowed:
            if not (0 <= i < len(n.ends) and 0 <= j < len(n.ends)) or i == j:
                raise MapFileError(f"node {n.node_id}: allowed pair {(i, j)} is out of range")
    conflicts.sort(key=lambda c: c.conflict_id)
    for k, c in enumerate(conflicts):
        if c.conflict_id != k:
            raise MapFileError("conflict ids must be 0..n-1 without gaps or repeats")
        if any(not 0 <= e < len(edges) for e in c.edges):
            raise MapFileError(f"conflict {c.conflict_id} refers to an edge that does not exist")
    meta = MapMetadata(
        source=dict(header.get("source") or {}),
        build=dict(header.get("build") or {}),
        driving_side=driving_side,
        attribution=str(header.get("attribution", "")),
        created=str(header.get("created", "")),
    )
    return MapData(
        frame=frame,
        edges=tuple(edges),
        nodes=tuple(nodes),
        conflicts=tuple(conflicts),
        stops=tuple(stops),
        grade_separated=tuple(grade_sep),
        metadata=meta,
    )


# -- validation helpers -------------------------------------------------------------------
def _req(props: dict[str, Any], key: str, typ: type, where: str) -> Any:
    if key not in props:
        raise MapFileError(f"{where}: missing '{key}'")
    value = props[key]
    if typ is int and isinstance(value, bool):
        raise MapFileError(f"{where}: '{key}' must be an integer")
    if typ is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if not isinstance(value, typ):
        raise MapFileError(f"{where}: '{key}' must be {typ.__name__}, got {type(value).__name__}")
    if isinstance(value, float) and not math.isfinite(value):
        raise MapFileError(f"{where}: '{key}' is not finite")
    return value


def _point(geom: dict[str, Any], where: str) -> tuple[float, float]:
    if geom.get("type") != "Point":
        raise MapFileError(f"{where}: geometry must be a Point")
    coords = geom.get("coordinates")
    if not (isinstance(coords, list) and len(coords) >= 2):
        raise MapFileError(f"{where}: bad Point coordinates")
    lon, lat = _lonlat(coords, where)
    return lon, lat


def _lonlat(c: Any, where: str) -> tuple[float, float]:
    if not (isinstance(c, list) and len(c) >= 2):
        raise MapFileError(f"{where}: a coordinate must be [lon, lat]")
    lon, lat = c[0], c[1]
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (lon, lat)):
        raise MapFileError(f"{where}: coordinates must be numbers")
    if not (math.isfinite(lon) and math.isfinite(lat) and -180 <= lon <= 180 and -90 <= lat <= 90):
        raise MapFileError(f"{where}: coordinate {c!r} is not a valid lon/lat")
    return float(lon), float(lat)


def _edge(props: dict[str, Any], geom: dict[str, Any], frame: LocalFrame, where: str) -> Edge:
    if geom.get("type") != "LineString":
        raise MapFileError(f"{where}: geometry must be a LineString")
    coords = geom.get("coordinates")
    if not isinstance(coords, list) or len(coords) < 2:
        raise MapFileError(f"{where}: a LineString needs at least 2 coordinates")
    lonlat = [_lonlat(c, where) for c in coords]
    lon = tuple(c[0] for c in lonlat)
    lat = tuple(c[1] for c in lonlat)
    x, y = frame.to_local(list(lon), list(lat))
    node_ids = tuple(int(n) for n in _req(props, "node_ids", list, where))
    if len(node_ids) != len(lon):
        raise MapFileError(f"{where}: {len(node_ids)} node_ids for {len(lon)} coordinates")
    direction = _req(props, "direction", int, where)
    if direction not in (-1, 0, 1):
        raise MapFileError(f"{where}: direction must be -1, 0 or 1, got {direction}")
    maxspeed = props.get("maxspeed_mps")
    if maxspeed is not None and not (isinstance(maxspeed, (int, float)) and maxspeed > 0):
        raise MapFileError(f"{where}: maxspeed_mps must be a positive number or null")
    start = _req(props, "start_node", int, where)
    end = _req(props, "end_node", int, where)
    if node_ids[0] != start or node_ids[-1] != end:
        raise MapFileError(f"{where}: start_node/end_node do not match node_ids")
    return Edge(
        edge_id=_req(props, "edge_id", int, where),
        start_node=start,
        end_node=end,
        node_ids=node_ids,
        lon=lon,
        lat=lat,
        geometry=shapely.LineString(list(zip(x.tolist(), y.tolist(), strict=True))),
        way_ids=tuple(int(w) for w in _req(props, "way_ids", list, where)),
        kind=_req(props, "kind", str, where),
        service=props.get("service"),
        layer=_req(props, "layer", int, where),
        bridge=bool(_req(props, "bridge", bool, where)),
        tunnel=bool(_req(props, "tunnel", bool, where)),
        maxspeed_mps=None if maxspeed is None else float(maxspeed),
        direction=direction,
        direction_source=_req(props, "direction_source", str, where),
        name=props.get("name"),
    )


def _node(props: dict[str, Any], geom: dict[str, Any], frame: LocalFrame, where: str) -> Node:
    lon, lat = _point(geom, where)
    x, y = frame.to_local(lon, lat)
    name = _req(props, "class", str, where)
    try:
        cls = NodeClass(name)
    except ValueError:
        raise MapFileError(f"{where}: unknown node class {name!r}") from None
    ends = tuple(tuple(int(v) for v in end) for end in _req(props, "ends", list, where))
    allowed = tuple(tuple(int(v) for v in pr) for pr in _req(props, "allowed", list, where))
    if any(len(e) != 2 for e in ends) or any(len(p) != 2 for p in allowed):
        raise MapFileError(f"{where}: 'ends' and 'allowed' must hold pairs")
    return Node(
        node_id=_req(props, "node_id", int, where),
        lon=lon,
        lat=lat,
        x=x,
        y=y,
        cls=cls,
        ends=ends,  # type: ignore[arg-type]
        allowed=allowed,  # type: ignore[arg-type]
    )


def _conflict(props: dict[str, Any], where: str) -> ConflictPoint:
    name = _req(props, "kind", str, where)
    try:
        kind = ConflictKind(name)
    except ValueError:
        raise MapFileError(f"{where}: unknown conflict kind {name!r}") from None
    edges = tuple(int(e) for e in _req(props, "edges", list, where))
    offsets = tuple(float(v) for v in _req(props, "offsets_m", list, where))
    extents = tuple(float(v) for v in _req(props, "extents_m", list, where))
    if not (len(edges) == len(offsets) == len(extents)):
        raise MapFileError(f"{where}: edges, offsets_m and extents_m differ in length")
    angle = props.get("angle_deg")
    return ConflictPoint(
        conflict_id=_req(props, "conflict_id", int, where),
        kind=kind,
        x=_req(props, "x", float, where),
        y=_req(props, "y", float, where),
        node_id=props.get("node_id"),
        edges=edges,
        offsets_m=offsets,
        extents_m=extents,
        angle_deg=None if angle is None else float(angle),
    )
