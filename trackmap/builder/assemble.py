"""Building a :class:`~trackmap.network.TrackMap` from a source file: read, infer, assemble."""

from __future__ import annotations

import itertools
import logging
import math
import os
from collections import defaultdict
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import shapely
from pyproj import Geod

from trackmap.builder.drivingside import (
    DRIVING_SIDE_CHOICES,
    DRIVING_SIDES,
    direction_from_side,
    parallel_neighbours,
    resolve_driving_side,
    tally_driving_side,
)
from trackmap.builder.sources import RawStop, SourceData, check_kinds, read_source
from trackmap.builder.topology import (
    Piece,
    classify_node,
    direction_tag_doubt,
    drawn_tracks,
    drop_duplicate_pieces,
    find_crossings,
    fouling_distance,
    merge_chains,
    propagate_directions,
    split_ways,
)
from trackmap.crs import LocalFrame
from trackmap.errors import ParameterError, SourceFormatError
from trackmap.geometry import cumulative_length, end_tangent
from trackmap.kinds import ConflictKind, NodeClass
from trackmap.mapfile import MAX_MAP_RADIUS_M
from trackmap.model import ConflictPoint, Edge, GradeSeparation, MapMetadata, Node, Stop
from trackmap.network import TrackMap

__all__ = ["DRIVING_SIDES", "assemble", "build"]

logger = logging.getLogger(__name__)

_GEOD = Geod(ellps="WGS84")


def build(
    source: str | os.PathLike[str],
    *,
    kinds: tuple[str, ...] | list[str] | str = ("tram", "light_rail"),
    driving_side: str = "auto",
    max_deflection_deg: float = 35.0,
    tangent_probe_m: float = 3.0,
    parallel_spacing_m: tuple[float, float] = (2.5, 6.0),
    fouling_clearance_m: float = 3.2,
    stop_snap_m: float = 15.0,
    progress: bool | None = None,
) -> TrackMap:
    """Build a rail network map from stored track geometry.

    Parameters
    ----------
    source : path-like
        OSM XML (``.osm``), OSM PBF (``.osm.pbf``), Overpass JSON or GeoJSON.
    kinds : sequence of str or comma-separated str
        ``railway=`` values to keep: ``tram``, ``light_rail`` (both by default: the
        vehicles this library is for, and mappers tag one city's light rail as the other's
        tram), ``rail``, ``subway``, ``narrow_gauge``.
    driving_side : {"auto", "right", "left"}
        Side trams keep to on double track; sets the running direction of untagged
        double track. ``auto`` (default): the side the source's tagged one-way double
        track shows (at least 400 m of it, 80 % one way), else right-hand running;
        ``metadata.driving_side`` says which, ``metadata.source["driving_side_evidence"]``
        what the tags showed. A side given by name that the tags contradict is used as
        given, with a logged warning.
    max_deflection_deg : float
        Largest change of direction a vehicle can make through a switch or crossing,
        degrees (OSRD's "straight enough" rule).
    tangent_probe_m : float
        Length over which an edge's direction at a node is measured, metres.
    parallel_spacing_m : (float, float)
        Track-centre spacing range of double track, metres (tram: ~3.8 m).
    fouling_clearance_m : float
        Track-centre separation at which vehicles on diverging branches stop fouling each
        other, metres.
    stop_snap_m : float
        Stops farther than this from any track are kept unsnapped, metres.
    progress : bool, optional
        Show progress bars (default: for large inputs only).

    Returns
    -------
    TrackMap

    Raises
    ------
    trackmap.errors.SourceError, trackmap.errors.SourceFormatError,
    trackmap.errors.NoTracksError
        The source cannot be used; the message names the file and the problem (for a
        malformed element: which one and what is wrong; for a network wider than a map's
        frame holds: the outlying node).
    trackmap.errors.MissingDependencyError
        Reading OSM XML/PBF needs osmium; the message names the extra to install.
    trackmap.errors.ParameterError
        A parameter is outside its domain.

    Notes
    -----
    A source cut by a bounding box keeps the located pieces of the ways that cross the
    box; ``metadata.source`` counts them (``clipped``) and lists the nodes where track
    leaves the map (``boundary_nodes``, reported by ``trackmap check`` as
    ``map_boundary``).
    """
    _check_parameters(
        driving_side=driving_side,
        max_deflection_deg=max_deflection_deg,
        tangent_probe_m=tangent_probe_m,
        parallel_spacing_m=parallel_spacing_m,
        fouling_clearance_m=fouling_clearance_m,
        stop_snap_m=stop_snap_m,
    )
    lo_sp, hi_sp = (float(v) for v in parallel_spacing_m)
    kind_list = sorted(check_kinds(kinds))
    data = read_source(source, kinds=kind_list, progress=progress)
    params = {
        "kinds": kind_list,
        "max_deflection_deg": float(max_deflection_deg),
        "tangent_probe_m": float(tangent_probe_m),
        "parallel_spacing_m": [lo_sp, hi_sp],
        "fouling_clearance_m": float(fouling_clearance_m),
        "stop_snap_m": float(stop_snap_m),
        "driving_side": driving_side,
    }
    return assemble(
        data,
        driving_side=driving_side,
        params=params,
    )


def assemble(data: SourceData, *, driving_side: str, params: dict[str, object]) -> TrackMap:
    """Turn read source data into a map (the steps after reading)."""
    max_deflection = float(params["max_deflection_deg"])  # type: ignore[arg-type]
    probe = float(params["tangent_probe_m"])  # type: ignore[arg-type]
    spacing = params["parallel_spacing_m"]
    clearance = float(params["fouling_clearance_m"])  # type: ignore[arg-type]

    # node coordinates (first occurrence wins; conflicting duplicates are logged)
    coords: dict[int, tuple[float, float]] = {}
    for way in data.ways:
        for nid, lon, lat in zip(way.node_ids, way.lon, way.lat, strict=True):
            old = coords.setdefault(nid, (lon, lat))
            if old != (lon, lat) and (abs(old[0] - lon) > 1e-6 or abs(old[1] - lat) > 1e-6):
                logger.warning("node %d has two locations in %s; using the first", nid, data.path)
    lons = np.fromiter((c[0] for c in coords.values()), dtype=float)
    lats = np.fromiter((c[1] for c in coords.values()), dtype=float)
    centre = LocalFrame.centred_on(
        round(float((lons.min() + lons.max()) / 2), 6),
        round(float((lats.min() + lats.max()) / 2), 6),
    )
    frame = LocalFrame.from_wkt(centre.wkt)  # exactly the CRS a saved map will reload
    xs, ys = frame.to_local(lons, lats)
    _check_extent(data.path, list(coords), lons, lats, xs, ys)
    local = {nid: (float(x), float(y)) for nid, x, y in zip(coords, xs, ys, strict=True)}

    pieces, duplicates = drop_duplicate_pieces(
        split_ways([(w.way_id, w.node_ids, w.tags) for w in data.ways])
    )
    for group in duplicates:
        logger.warning("%s: ways %s run over the same nodes; kept once", data.path, list(group))
    pieces = merge_chains(pieces)
    pieces.sort(key=lambda p: (min(p.way_ids), p.node_ids[0], p.node_ids[-1], len(p.node_ids)))
    lines = [shapely.LineString([local[n] for n in p.node_ids]) for p in pieces]

    # the side the tagged main-line track shows (depot fans and sidings run both ways)
    tagged = [
        i for i, p in enumerate(pieces) if p.direction_source != "none" and p.attrs.service is None
    ]
    tally = tally_driving_side(
        lines,
        [p.direction for p in pieces],
        tagged,
        min_spacing_m=spacing[0],  # type: ignore[index]
        max_spacing_m=spacing[1],  # type: ignore[index]
    )
    driving_side = resolve_driving_side(driving_side, tally, where=data.path)
    directions, sources = _running_directions(pieces, lines, driving_side, spacing)  # type: ignore[arg-type]

    edges = [
        Edge(
            edge_id=i,
            start_node=p.node_ids[0],
            end_node=p.node_ids[-1],
            node_ids=tuple(p.node_ids),
            lon=tuple(coords[n][0] for n in p.node_ids),
            lat=tuple(coords[n][1] for n in p.node_ids),
            geometry=lines[i],
            way_ids=tuple(p.way_ids),
            kind=p.attrs.kind,
            service=p.attrs.service,
            layer=p.attrs.layer,
            bridge=p.attrs.bridge,
            tunnel=p.attrs.tunnel,
            maxspeed_mps=p.attrs.maxspeed_mps,
            direction=directions[i],
            direction_source=sources[i],
            name=p.name,
        )
        for i, p in enumerate(pieces)
    ]

    nodes = _junction_nodes(edges, coords, local, max_deflection, probe, data.node_tags)
    conflicts, grade_sep, overlaps = _conflicts(edges, nodes, pieces, clearance)
    stops = _snap_stops(data.stops, frame, lines, float(params["stop_snap_m"]))  # type: ignore[arg-type]
    source: dict[str, object] = {
        "file": Path(data.path).name,
        "format": data.fmt,
        "ways": data.kept_ways,
        "dropped": dict(data.dropped),
        "duplicate_ways": [list(g) for g in duplicates],
        "direction_tag_doubts": _direction_tag_doubts(data),
        "multi_track_ways": [
            [w.way_id, drawn_tracks(w.tags)] for w in data.ways if drawn_tracks(w.tags) > 1
        ],
        "overlapping_edges": overlaps,
        "driving_side_evidence": {
            "right_m": round(tally.right_m, 1),
            "left_m": round(tally.left_m, 1),
        },
    }
    if data.bounds is not None:
        source["bounds"] = list(data.bounds)
    if data.clipped:
        junctions = {n.node_id for n in nodes}
        source["clipped"] = dict(data.clipped)
        source["boundary_nodes"] = [
            [nid, way] for nid, way in sorted(set(data.boundary_nodes)) if nid in junctions
        ]
    meta = MapMetadata(
        source=source,
        build=dict(params),
        driving_side=driving_side,
        created=datetime.now(UTC).replace(microsecond=0).isoformat(),
    )
    net = TrackMap(
        frame=frame,
        edges=edges,
        nodes=nodes,
        conflicts=conflicts,
        stops=stops,
        grade_separated=grade_sep,
        metadata=meta,
    )
    logger.info("built %r", net)
    return net


def _check_parameters(
    *,
    driving_side: object,
    max_deflection_deg: object,
    tangent_probe_m: object,
    parallel_spacing_m: object,
    fouling_clearance_m: object,
    stop_snap_m: object,
) -> None:
    """Raise :class:`ParameterError` for a build parameter outside its domain."""
    if driving_side not in DRIVING_SIDE_CHOICES:
        raise ParameterError(
            f"driving_side must be 'auto', 'right' or 'left', got {driving_side!r:.40}"
        )
    # (value, its domain, what the message says)
    ranges: dict[str, tuple[object, Callable[[float], bool], str]] = {
        "max_deflection_deg": (max_deflection_deg, lambda v: 0 < v < 90, "in (0, 90) degrees"),
        "tangent_probe_m": (tangent_probe_m, lambda v: 0 < v <= 1000, "in (0, 1000] m"),
        "fouling_clearance_m": (fouling_clearance_m, lambda v: 0 <= v <= 1000, "in [0, 1000] m"),
        "stop_snap_m": (stop_snap_m, lambda v: 0 <= v <= 100_000, "in [0, 100 km]"),
    }
    for name, (value, inside, text) in ranges.items():
        if not (_number(value) and inside(float(value))):  # type: ignore[arg-type]
            raise ParameterError(f"{name} must be a number {text}, got {value!r:.40}")
    pair = parallel_spacing_m
    if not (
        isinstance(pair, (tuple, list))
        and len(pair) == 2
        and all(_number(v) for v in pair)
        and 0 <= float(pair[0]) < float(pair[1]) <= 1000
    ):
        raise ParameterError(
            f"parallel_spacing_m must be (min, max) metres with 0 <= min < max, got {pair!r:.60}"
        )


def _number(value: object) -> bool:
    """A finite int or float (not a bool, not an int beyond a double)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def _check_extent(
    path: str,
    node_ids: list[int],
    lons: np.ndarray,
    lats: np.ndarray,
    xs: np.ndarray,
    ys: np.ndarray,
) -> None:
    """A map's frame holds coordinates within MAX_MAP_RADIUS_M of its centre: name the
    node that lies farthest from the rest when the source does not fit."""
    radius = np.hypot(xs, ys)
    if np.all(np.isfinite(radius)) and float(radius.max()) <= MAX_MAP_RADIUS_M:
        return
    mid_lon, mid_lat = float(np.median(lons)), float(np.median(lats))
    _, _, dist = _GEOD.inv(np.full_like(lons, mid_lon), np.full_like(lats, mid_lat), lons, lats)
    k = int(np.argmax(dist))
    raise SourceFormatError(
        f"{path}: node {node_ids[k]} at ({lons[k]:.7f}, {lats[k]:.7f}) lies "
        f"{float(dist[k]) / 1000:,.0f} km from the middle of the network ({mid_lon:.5f}, "
        f"{mid_lat:.5f}); a map spans at most {MAX_MAP_RADIUS_M / 1000:,.0f} km from its "
        "centre: check that node's coordinates, or cut the source into smaller areas"
    )


def _running_directions(
    pieces: list[Piece],
    lines: list[shapely.LineString],
    driving_side: str,
    spacing: tuple[float, float],
) -> tuple[list[int], list[str]]:
    directions = [p.direction for p in pieces]
    sources = [p.direction_source if p.direction_source != "none" else "none" for p in pieces]
    # depot fans and sidings are run both ways: only main-line double track follows the
    # driving side
    untagged = [
        i for i, p in enumerate(pieces) if p.direction_source == "none" and p.attrs.service is None
    ]
    if untagged:
        evidence = parallel_neighbours(
            lines, untagged, min_spacing_m=spacing[0], max_spacing_m=spacing[1]
        )
        for i, ev in evidence.items():
            d = direction_from_side(ev, driving_side)
            if d != 0:
                directions[i] = d
                sources[i] = "driving_side"
    propagate_directions(pieces, directions, sources)
    return directions, sources


def _junction_nodes(
    edges: list[Edge],
    coords: dict[int, tuple[float, float]],
    local: dict[int, tuple[float, float]],
    max_deflection: float,
    probe: float,
    node_tags: dict[int, dict[str, str]],
) -> list[Node]:
    ends: dict[int, list[tuple[int, int]]] = defaultdict(list)
    for e in edges:
        ends[e.start_node].append((e.edge_id, 0))
        ends[e.end_node].append((e.edge_id, 1))
    xy_cache = {}
    nodes = []
    for nid in sorted(ends):
        tangents = []
        way_of_end = []
        for eid, end in ends[nid]:
            way_of_end.append(edges[eid].way_ids[0] if end == 0 else edges[eid].way_ids[-1])
            if eid not in xy_cache:
                xy = np.asarray(edges[eid].geometry.coords, dtype=float)
                xy_cache[eid] = (xy, cumulative_length(xy))
            xy, cum = xy_cache[eid]
            tangents.append(end_tangent(xy, cum, end, probe))
        through = [
            (i, j)
            for i, j in itertools.combinations(range(len(way_of_end)), 2)
            if way_of_end[i] == way_of_end[j] and ends[nid][i][0] != ends[nid][j][0]
        ]
        topo = classify_node(
            ends[nid],
            tangents,
            max_deflection_deg=max_deflection,
            through_pairs=through,
            tags=node_tags.get(nid),
        )
        nodes.append(
            Node(
                node_id=nid,
                lon=coords[nid][0],
                lat=coords[nid][1],
                x=local[nid][0],
                y=local[nid][1],
                cls=topo.cls,
                ends=topo.ends,
                allowed=topo.allowed,
            )
        )
    return nodes


def _conflicts(
    edges: list[Edge], nodes: list[Node], pieces: list[Piece], clearance: float
) -> tuple[list[ConflictPoint], list[GradeSeparation], list[list[float]]]:
    conflicts: list[ConflictPoint] = []
    for node in nodes:
        if node.cls in (NodeClass.DIAMOND_CROSSING, NodeClass.DOUBLE_SLIP):
            conflicts.append(
                ConflictPoint(
                    conflict_id=len(conflicts),
                    kind=ConflictKind(node.cls),
                    x=node.x,
                    y=node.y,
                    node_id=node.node_id,
                    edges=tuple(e for e, _ in node.ends),
                    offsets_m=tuple(0.0 if end == 0 else edges[e].length_m for e, end in node.ends),
                    extents_m=tuple(clearance for _ in node.ends),
                )
            )
        elif node.cls == NodeClass.POINT_SWITCH:
            paired = {k for pair in node.allowed for k in pair}
            # the trunk is the end allowed with both others
            counts: dict[int, int] = defaultdict(int)
            for i, j in node.allowed:
                counts[i] += 1
                counts[j] += 1
            trunk = max(paired, key=lambda k: counts[k])
            branches = [k for k in range(3) if k != trunk]
            (ea, enda), (eb, endb) = node.ends[branches[0]], node.ends[branches[1]]
            fa = fouling_distance(
                edges[ea].geometry, enda == 0, edges[eb].geometry, clearance_m=clearance
            )
            fb = fouling_distance(
                edges[eb].geometry, endb == 0, edges[ea].geometry, clearance_m=clearance
            )
            et, _ = node.ends[trunk]
            conflicts.append(
                ConflictPoint(
                    conflict_id=len(conflicts),
                    kind=ConflictKind.MERGE,
                    x=node.x,
                    y=node.y,
                    node_id=node.node_id,
                    edges=(et, ea, eb),
                    offsets_m=tuple(
                        0.0 if end == 0 else edges[e].length_m
                        for e, end in (node.ends[trunk], (ea, enda), (eb, endb))
                    ),
                    extents_m=(0.0, fa, fb),
                )
            )
    lines = [e.geometry for e in edges]
    node_xy = [(np.asarray(e.geometry.coords[0]), np.asarray(e.geometry.coords[-1])) for e in edges]
    grade_sep: list[GradeSeparation] = []
    overlaps: list[list[float]] = []
    for hit in find_crossings(lines, [p.attrs for p in pieces], node_xy):
        if hit.overlap:
            overlaps.append([hit.edge_a, hit.edge_b, round(hit.x, 3), round(hit.y, 3)])
            continue
        if hit.grade_separated:
            grade_sep.append(GradeSeparation(hit.edge_a, hit.edge_b, hit.x, hit.y))
            continue
        half = min(clearance / max(math.sin(math.radians(max(hit.angle_deg, 1.0))), 0.1), 30.0)
        conflicts.append(
            ConflictPoint(
                conflict_id=len(conflicts),
                kind=ConflictKind.CROSSING,
                x=hit.x,
                y=hit.y,
                node_id=None,
                edges=(hit.edge_a, hit.edge_b),
                offsets_m=(hit.offset_a_m, hit.offset_b_m),
                extents_m=(half, half),
                angle_deg=hit.angle_deg,
            )
        )
    return conflicts, grade_sep, overlaps


def _snap_stops(
    stops: list[RawStop], frame: LocalFrame, lines: list[shapely.LineString], snap_m: float
) -> list[Stop]:
    if not stops:
        return []
    tree = shapely.STRtree(lines)
    x, y = frame.to_local(np.array([s.lon for s in stops]), np.array([s.lat for s in stops]))
    pts = shapely.points(x, y)
    nearest, dist = tree.query_nearest(
        pts, max_distance=snap_m, return_distance=True, all_matches=False
    )
    snapped: dict[int, tuple[int, float]] = {}
    for (pi, li), _d in zip(nearest.T.tolist(), dist.tolist(), strict=True):
        snapped[pi] = (li, float(lines[li].project(pts[pi])))
    out = []
    for k in sorted(range(len(stops)), key=lambda k: stops[k].node_id):
        st = stops[k]
        e, off = snapped.get(k, (None, None))
        out.append(
            Stop(stop_id=st.node_id, name=st.name, lon=st.lon, lat=st.lat, edge_id=e, offset_m=off)
        )
    return out


def _direction_tag_doubts(data: SourceData) -> list[list[int | str]]:
    """[way id, what is doubtful] of each kept way whose direction tags this builder
    cannot read or that disagree (logged once per source file)."""
    doubts: list[list[int | str]] = []
    for w in data.ways:
        doubt = direction_tag_doubt(w.tags)
        if doubt is not None:
            doubts.append([w.way_id, doubt])
    if doubts:
        logger.warning(
            "%s: %d way(s) with direction tags that cannot be read or disagree, e.g. way %d: "
            "%s ('trackmap check' lists them)", data.path, len(doubts), *doubts[0],
        )  # fmt: skip
    return doubts
