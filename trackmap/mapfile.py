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
:class:`trackmap.TrackMap` is built from those by :func:`trackmap.load`. Reading checks
everything: the JSON itself (:func:`parse_json`), the format's schema
(:mod:`trackmap.mapschema`) and what a schema cannot state (:func:`from_geojson`), so a
broken file is a :class:`~trackmap.errors.MapFileError` naming the file, the feature and
what is wrong, and a file that loads is a map exactly as the file says.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from pyproj import Geod
from pyproj.exceptions import CRSError, ProjError

from trackmap import mapschema
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

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "LENGTH_TOLERANCE_M",
    "MAX_MAP_RADIUS_M",
    "from_geojson",
    "parse_json",
    "read",
    "to_geojson",
    "write",
]

FORMAT_NAME = mapschema.FORMAT_NAME
FORMAT_VERSION = mapschema.FORMAT_VERSION
#: Every coordinate of a map lies within this distance of its frame's origin, metres: a
#: transverse Mercator frame stretches lengths by 0.3 % there.
MAX_MAP_RADIUS_M = 500_000.0
#: How far a stored length or offset may differ from the geometry, metres (plus 1 ppm).
LENGTH_TOLERANCE_M = 0.01
# Conflict points, grade separations and snapped stops lie on their edges within this, m.
_POINT_TOLERANCE_M = 0.5
# A node lies on its edges' end vertices within this, degrees (about 1 cm).
_SAME_DEG = 1e-7
# Lengths in the frame are true lengths on the ground within this fraction.
_SCALE_TOLERANCE = 0.005
_SCALE_SAMPLES = 200
_MAX_INT_DIGITS = 20
_GEOD = Geod(ellps="WGS84")
_ENDS_OF_CLASS = {
    NodeClass.BUFFER_STOP: 1,
    NodeClass.LINK: 2,
    NodeClass.POINT_SWITCH: 3,
    NodeClass.DIAMOND_CROSSING: 4,
    NodeClass.DOUBLE_SLIP: 4,
}
_EDGES_OF_CONFLICT = {
    ConflictKind.MERGE: 3,
    ConflictKind.CROSSING: 2,
    ConflictKind.DIAMOND_CROSSING: 4,
    ConflictKind.DOUBLE_SLIP: 4,
}


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
    trackmap.errors.MapFileError
        The map holds what a map file cannot (a NaN, text that is not valid Unicode).
    """
    p = Path(path)
    doc = to_geojson(data, stats=stats)
    tmp = p.with_name(p.name + ".tmp")
    try:
        text = json.dumps(doc, ensure_ascii=False, separators=(",", ":"), allow_nan=False)
        raw = text.encode("utf-8")
    except (ValueError, UnicodeEncodeError) as exc:  # NaN/infinity, lone surrogates
        raise MapFileError(f"{p}: the map cannot be written as a map file: {exc}") from None
    try:
        tmp.write_bytes(raw)
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
        The file is not valid JSON, not a map of this format version, or its content is
        broken (see :func:`from_geojson`); the message starts with the file name and names
        the feature and member that is wrong.
    """
    p = Path(path)
    if not p.exists():
        raise SourceError(f"{p}: no such map file")
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise SourceError(f"{p}: cannot read: {exc.strerror or exc}") from exc
    try:
        return from_geojson(parse_json(raw))
    except MapFileError as exc:
        raise MapFileError(f"{p}: {exc}") from None


class _NumberError(ValueError):
    """A JSON number the map file format does not allow."""


def _no_constant(name: str) -> float:
    raise _NumberError(f"{name} is not a number a map file may hold (numbers must be finite)")


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise _NumberError(f"the number {_clip(text)} is beyond the range of a double")
    return value


def _bounded_int(text: str) -> int:
    if len(text.lstrip("-")) > _MAX_INT_DIGITS:
        raise _NumberError(f"the integer {_clip(text)} has more than {_MAX_INT_DIGITS} digits")
    return int(text)


def parse_json(raw: bytes | str) -> Any:
    """Parse a map file's JSON text, refusing what a map file may not hold.

    ``NaN``, ``Infinity``, numbers beyond the range of a double and integers of more than
    20 digits are refused here (Python's :mod:`json` would accept them).

    Raises
    ------
    trackmap.errors.MapFileError
        Not valid JSON (with the line and column), not UTF-8 text, nested too deeply, or a
        number of the kinds above.
    """
    try:
        return json.loads(
            raw,
            parse_constant=_no_constant,
            parse_float=_finite_float,
            parse_int=_bounded_int,
        )
    except _NumberError as exc:
        raise MapFileError(f"not a valid map file: {exc}") from None
    except json.JSONDecodeError as exc:
        raise MapFileError(f"not valid JSON ({exc})") from None
    except UnicodeDecodeError as exc:
        raise MapFileError(
            f"not valid JSON: not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset "
            f"{exc.start})"
        ) from None
    except RecursionError:
        raise MapFileError("not valid JSON for a map: nested too deeply") from None


def from_geojson(doc: Any) -> MapData:
    """The records of a map from its parsed GeoJSON document, validating everything.

    First the document is checked against the format's JSON Schema
    (:data:`trackmap.mapschema.SCHEMA`: types, finite numbers, value ranges, required
    members), then what a schema cannot state:

    * ids: edge ids are 0..n-1, conflict ids 0..n-1, node ids unique;
    * references: every node, edge, conflict, stop and grade separation refers to edges and
      nodes that exist, every edge end is listed by exactly one node, a node's class fits
      the number of edge ends meeting there, allowed moves join two different ends;
    * geometry: each edge's ``length_m`` is the length of its coordinates (a vertex moved
      after the build is caught), nodes lie on the ends of their edges, conflict points,
      grade separations and snapped stops lie on their edges at their offsets;
    * the CRS fits the coordinates: every coordinate lies within
      :data:`MAX_MAP_RADIUS_M` of the frame's origin and lengths in the frame are true
      lengths on the ground (to 0.5 %).

    Raises
    ------
    trackmap.errors.MapFileError
        The content is not a valid map of this format version; the message names the
        feature (index and id) and what is wrong.
    """
    mapschema.validate(doc)
    header = doc["trackmap"]
    frame = _frame(header["crs_wkt"])
    build = dict(header.get("build") or {})
    edges: list[Edge] = []
    nodes: list[Node] = []
    conflicts: list[tuple[str, ConflictPoint, tuple[float, float]]] = []
    stops: list[tuple[str, Stop]] = []
    grade_sep: list[tuple[str, GradeSeparation, tuple[float, float]]] = []
    stored_length: dict[int, float] = {}
    where_edge: dict[int, str] = {}
    for i, feat in enumerate(doc["features"]):
        props, coords = feat["properties"], feat["geometry"]["coordinates"]
        kind = props["feature"]
        if kind == "edge":
            where = f"feature {i} (edge {props['edge_id']})"
            edge = _edge(props, coords, frame, where)
            if edge.edge_id in where_edge:
                raise MapFileError(f"{where}: edge id {edge.edge_id} is used twice")
            where_edge[edge.edge_id] = where
            stored_length[edge.edge_id] = float(props["length_m"])
            edges.append(edge)
        elif kind == "node":
            nodes.append(_node(props, coords, frame))
        elif kind == "conflict":
            where = f"feature {i} (conflict {props['conflict_id']})"
            conflicts.append((where, _conflict(props), _lonlat(coords)))
        elif kind == "stop":
            lon, lat = _lonlat(coords)
            stop = Stop(
                stop_id=int(props["stop_id"]),
                name=props.get("name"),
                lon=lon,
                lat=lat,
                edge_id=None if props.get("edge_id") is None else int(props["edge_id"]),
                offset_m=None if props.get("offset_m") is None else float(props["offset_m"]),
            )
            stops.append((f"feature {i} (stop {stop.stop_id})", stop))
        else:  # grade_separated: the schema admits no other kind
            a, b = (int(v) for v in props["edges"])
            grade = GradeSeparation(a, b, float(props["x"]), float(props["y"]))
            grade_sep.append((f"feature {i} (grade separation)", grade, _lonlat(coords)))

    edges.sort(key=lambda e: e.edge_id)
    if not edges:
        raise MapFileError("the map has no edges")
    for k, e in enumerate(edges):
        if e.edge_id != k:
            raise MapFileError(
                f"edge ids must be 0..{len(edges) - 1} without gaps; edge {k} is missing"
            )
    for e in edges:
        _check_edge_geometry(e, stored_length[e.edge_id], frame, where_edge[e.edge_id])
    _check_scale(edges, frame)
    node_by_id = _check_nodes(nodes, edges)
    conflict_points = _check_conflicts(conflicts, edges, node_by_id, frame)
    stop_snap = float(build.get("stop_snap_m", 15.0))
    for where, st in stops:
        _check_stop(st, edges, frame, stop_snap, where)
    for where, g, lonlat in grade_sep:
        _check_grade_separation(g, lonlat, edges, frame, where)
    source = dict(header.get("source") or {})
    _check_source_references(source, len(edges), node_by_id)
    meta = MapMetadata(
        source=source,
        build=build,
        driving_side=header.get("driving_side", "right"),
        attribution=str(header.get("attribution", "")),
        created=str(header.get("created", "")),
    )
    return MapData(
        frame=frame,
        edges=tuple(edges),
        nodes=tuple(nodes),
        conflicts=tuple(conflict_points),
        stops=tuple(st for _, st in stops),
        grade_separated=tuple(g for _, g, _ in grade_sep),
        metadata=meta,
    )


# -- records ------------------------------------------------------------------------------
def _frame(wkt: str) -> LocalFrame:
    try:
        return LocalFrame.from_wkt(wkt)
    except MapFileError as exc:
        raise MapFileError(f"header: crs_wkt: {_clip(str(exc), 200)}") from None
    except (CRSError, ProjError) as exc:
        raise MapFileError(f"header: crs_wkt cannot be used: {_clip(str(exc), 200)}") from None


def _lonlat(c: list[Any]) -> tuple[float, float]:
    return float(c[0]), float(c[1])


def _edge(props: dict[str, Any], coords: list[Any], frame: LocalFrame, where: str) -> Edge:
    lon = tuple(float(c[0]) for c in coords)
    lat = tuple(float(c[1]) for c in coords)
    node_ids = tuple(int(n) for n in props["node_ids"])
    if len(node_ids) != len(lon):
        raise MapFileError(f"{where}: {len(node_ids)} node_ids for {len(lon)} coordinates")
    start, end = int(props["start_node"]), int(props["end_node"])
    if node_ids[0] != start or node_ids[-1] != end:
        raise MapFileError(f"{where}: start_node/end_node do not match node_ids")
    x, y = frame.to_local(np.asarray(lon), np.asarray(lat))
    _check_in_frame(x, y, where)
    maxspeed = props.get("maxspeed_mps")
    return Edge(
        edge_id=int(props["edge_id"]),
        start_node=start,
        end_node=end,
        node_ids=node_ids,
        lon=lon,
        lat=lat,
        geometry=shapely.LineString(np.column_stack([x, y])),
        way_ids=tuple(int(w) for w in props["way_ids"]),
        kind=props["kind"],
        service=props.get("service"),
        layer=int(props["layer"]),
        bridge=props["bridge"],
        tunnel=props["tunnel"],
        maxspeed_mps=None if maxspeed is None else float(maxspeed),
        direction=int(props["direction"]),
        direction_source=props["direction_source"],
        name=props.get("name"),
    )


def _node(props: dict[str, Any], coords: list[Any], frame: LocalFrame) -> Node:
    lon, lat = _lonlat(coords)
    x, y = frame.to_local(lon, lat)
    return Node(
        node_id=int(props["node_id"]),
        lon=lon,
        lat=lat,
        x=x,
        y=y,
        cls=NodeClass(props["class"]),
        ends=tuple((int(e), int(end)) for e, end in props["ends"]),
        allowed=tuple((int(i), int(j)) for i, j in props["allowed"]),
    )


def _conflict(props: dict[str, Any]) -> ConflictPoint:
    angle = props.get("angle_deg")
    node_id = props.get("node_id")
    return ConflictPoint(
        conflict_id=int(props["conflict_id"]),
        kind=ConflictKind(props["kind"]),
        x=float(props["x"]),
        y=float(props["y"]),
        node_id=None if node_id is None else int(node_id),
        edges=tuple(int(e) for e in props["edges"]),
        offsets_m=tuple(float(v) for v in props["offsets_m"]),
        extents_m=tuple(float(v) for v in props["extents_m"]),
        angle_deg=None if angle is None else float(angle),
    )


# -- consistency --------------------------------------------------------------------------
def _check_in_frame(x: Any, y: Any, where: str) -> None:
    xa, ya = np.atleast_1d(x), np.atleast_1d(y)
    ok = np.isfinite(xa) & np.isfinite(ya) & (np.hypot(xa, ya) <= MAX_MAP_RADIUS_M)
    if not ok.all():
        k = int(np.flatnonzero(~ok)[0])
        raise MapFileError(
            f"{where}: coordinate {k} lies outside the map's CRS (more than "
            f"{MAX_MAP_RADIUS_M / 1000:.0f} km from its origin); the CRS does not fit the "
            "coordinates"
        )


def _check_edge_geometry(e: Edge, stored: float, frame: LocalFrame, where: str) -> None:
    length = e.length_m
    if abs(length - stored) > LENGTH_TOLERANCE_M + 1e-6 * stored:
        raise MapFileError(
            f"{where}: its coordinates make it {length:,.3f} m long, but length_m says "
            f"{stored:,.3f} m (a vertex was moved after the build?); rebuild the map"
        )


def _check_scale(edges: list[Edge], frame: LocalFrame) -> None:
    """Lengths in the frame must be true lengths: the CRS is conformal with scale ~1."""
    step = max(1, len(edges) // _SCALE_SAMPLES)
    for e in edges[::step]:
        ground = float(_GEOD.line_length(e.lon, e.lat))
        if abs(e.length_m - ground) > _SCALE_TOLERANCE * ground + 0.05:
            raise MapFileError(
                f"edge {e.edge_id}: {e.length_m:,.2f} m long in the map's CRS but "
                f"{ground:,.2f} m on the ground; the CRS does not fit the coordinates "
                "(trackmap needs a metric CRS with scale 1 at the map; rebuild the map)"
            )


def _check_nodes(nodes: list[Node], edges: list[Edge]) -> dict[int, Node]:
    by_id: dict[int, Node] = {}
    listed: dict[tuple[int, int], int] = {}
    for n in nodes:
        where = f"node {n.node_id}"
        if n.node_id in by_id:
            raise MapFileError(f"{where}: node id used twice")
        by_id[n.node_id] = n
        needed = _ENDS_OF_CLASS.get(n.cls)
        if needed is not None and len(n.ends) != needed:
            raise MapFileError(
                f"{where}: a {n.cls} joins {needed} edge end(s), the node lists {len(n.ends)}"
            )
        for eid, end in n.ends:
            if eid >= len(edges):
                raise MapFileError(f"{where}: refers to edge {eid}, which is not in the file")
            e = edges[eid]
            expected = e.start_node if end == 0 else e.end_node
            if expected != n.node_id:
                raise MapFileError(
                    f"{where}: lists edge {eid} end {end}, which ends at node {expected}"
                )
            if (eid, end) in listed:
                raise MapFileError(f"{where}: lists edge {eid} end {end} twice")
            listed[(eid, end)] = n.node_id
            k = 0 if end == 0 else -1
            if abs(e.lon[k] - n.lon) > _SAME_DEG or abs(e.lat[k] - n.lat) > _SAME_DEG:
                raise MapFileError(
                    f"{where}: lies at ({n.lon:.7f}, {n.lat:.7f}), but edge {eid} ends at "
                    f"({e.lon[k]:.7f}, {e.lat[k]:.7f})"
                )
        pairs = set()
        for i, j in n.allowed:
            if i >= len(n.ends) or j >= len(n.ends) or i == j:
                raise MapFileError(f"{where}: allowed pair {[i, j]} is out of range")
            if frozenset((i, j)) in pairs:
                raise MapFileError(f"{where}: allowed pair {[i, j]} is listed twice")
            pairs.add(frozenset((i, j)))
    for e in edges:
        for end, nid in ((0, e.start_node), (1, e.end_node)):
            if nid not in by_id:
                raise MapFileError(
                    f"edge {e.edge_id} refers to node {nid}, which is not in the file"
                )
            if (e.edge_id, end) not in listed:
                raise MapFileError(f"node {nid} does not list edge {e.edge_id} end {end}")
    return by_id


def _on_edge(edge: Edge, offset: float, x: float, y: float) -> float:
    p = edge.geometry.interpolate(offset)
    return math.hypot(p.x - x, p.y - y)


def _check_point(
    frame: LocalFrame, lonlat: tuple[float, float], x: float, y: float, where: str
) -> None:
    _check_in_frame(x, y, where)
    px, py = frame.to_local(*lonlat)
    if not math.hypot(px - x, py - y) <= _POINT_TOLERANCE_M:
        raise MapFileError(
            f"{where}: its point ({lonlat[0]:.7f}, {lonlat[1]:.7f}) is "
            f"{math.hypot(px - x, py - y):,.2f} m from its x/y; the file was edited (rebuild "
            "the map)"
        )


def _check_conflicts(
    conflicts: list[tuple[str, ConflictPoint, tuple[float, float]]],
    edges: list[Edge],
    nodes: dict[int, Node],
    frame: LocalFrame,
) -> list[ConflictPoint]:
    conflicts.sort(key=lambda item: item[1].conflict_id)
    out = []
    for k, (where, c, lonlat) in enumerate(conflicts):
        if c.conflict_id != k:
            raise MapFileError(
                f"{where}: conflict ids must be 0..{len(conflicts) - 1} without gaps or "
                f"repeats; id {k} is {'repeated' if c.conflict_id < k else 'missing'}"
            )
        if not len(c.edges) == len(c.offsets_m) == len(c.extents_m):
            raise MapFileError(f"{where}: edges, offsets_m and extents_m differ in length")
        needed = _EDGES_OF_CONFLICT[c.kind]
        if len(c.edges) != needed:
            raise MapFileError(
                f"{where}: a {c.kind} conflict has {needed} edges, not {len(c.edges)}"
            )
        if c.node_id is not None and c.node_id not in nodes:
            raise MapFileError(f"{where}: refers to node {c.node_id}, which is not in the file")
        if c.node_id is None and c.kind != ConflictKind.CROSSING:
            raise MapFileError(f"{where}: a {c.kind} conflict needs its node_id")
        _check_point(frame, lonlat, c.x, c.y, where)
        for eid, off in zip(c.edges, c.offsets_m, strict=True):
            if eid >= len(edges):
                raise MapFileError(f"{where}: refers to edge {eid}, which is not in the file")
            length = edges[eid].length_m
            if off > length + LENGTH_TOLERANCE_M:
                raise MapFileError(
                    f"{where}: offset {off:,.3f} m is beyond the end of edge {eid} "
                    f"({length:,.3f} m)"
                )
            gap = _on_edge(edges[eid], off, c.x, c.y)
            if gap > _POINT_TOLERANCE_M:
                raise MapFileError(
                    f"{where}: edge {eid} at offset {off:,.3f} m lies {gap:,.2f} m from the "
                    "conflict point"
                )
        out.append(c)
    return out


def _check_stop(st: Stop, edges: list[Edge], frame: LocalFrame, snap_m: float, where: str) -> None:
    if (st.edge_id is None) != (st.offset_m is None):
        raise MapFileError(f"{where}: edge_id and offset_m must both be given or both null")
    if st.edge_id is None or st.offset_m is None:
        return
    if st.edge_id >= len(edges):
        raise MapFileError(f"{where}: refers to edge {st.edge_id}, which is not in the file")
    edge = edges[st.edge_id]
    if st.offset_m > edge.length_m + LENGTH_TOLERANCE_M:
        raise MapFileError(
            f"{where}: offset {st.offset_m:,.3f} m is beyond the end of edge {st.edge_id} "
            f"({edge.length_m:,.3f} m)"
        )
    x, y = frame.to_local(st.lon, st.lat)
    gap = _on_edge(edge, st.offset_m, x, y)
    if not gap <= snap_m + _POINT_TOLERANCE_M:
        raise MapFileError(
            f"{where}: lies {gap:,.1f} m from edge {st.edge_id} at offset "
            f"{st.offset_m:,.3f} m (stops snap within {snap_m:g} m)"
        )


def _check_grade_separation(
    g: GradeSeparation,
    lonlat: tuple[float, float],
    edges: list[Edge],
    frame: LocalFrame,
    where: str,
) -> None:
    for eid in (g.edge_a, g.edge_b):
        if eid >= len(edges):
            raise MapFileError(f"{where}: refers to edge {eid}, which is not in the file")
    if g.edge_a == g.edge_b:
        raise MapFileError(f"{where}: names edge {g.edge_a} twice")
    _check_point(frame, lonlat, g.x, g.y, where)
    pt = shapely.Point(g.x, g.y)
    for eid in (g.edge_a, g.edge_b):
        gap = float(edges[eid].geometry.distance(pt))
        if gap > _POINT_TOLERANCE_M:
            raise MapFileError(f"{where}: the crossing point lies {gap:,.2f} m from edge {eid}")


def _check_source_references(source: dict[str, Any], n_edges: int, nodes: dict[int, Node]) -> None:
    for item in source.get("overlapping_edges", []):
        for eid in item[:2]:
            if eid >= n_edges:
                raise MapFileError(
                    f"header: source.overlapping_edges refers to edge {eid}, which is not in "
                    "the file"
                )
    for nid, _way in source.get("boundary_nodes", []):
        if nid not in nodes:
            raise MapFileError(
                f"header: source.boundary_nodes refers to node {nid}, which is not in the file"
            )


def _clip(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."
