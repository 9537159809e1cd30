"""Consistency checks of a map: what a maintainer of the OSM data should look at.

Errors (``trackmap check`` exits with status 1 when any is found):

* ``unknown_node`` — a junction that fits no node class;
* ``short_edge`` — an edge shorter than ``min_edge_m`` (1 m);
* ``contradictory_direction`` — two one-way edges that meet head to head (or tail to tail)
  where a vehicle should pass between them;
* ``dangling_end`` — a track end that stops within ``snap_m`` of another track without
  joining it (a missing connection rather than a buffer stop);
* ``long_edge`` — an edge longer than is plausible between two junctions (5 km for trams,
  10 km for light rail and subways, 50 km for railways; ``max_edge_m`` overrides): usually
  a node with wrong coordinates;
* ``self_overlapping_edge`` — an edge that runs back over itself.

Warnings:

* ``components`` — the network falls apart into more than one connected piece;
* ``unnoded_crossing`` — two tracks cross at the same level without a shared node (they are
  still conflict points; OSM should usually have a crossing node there);
* ``sharp_link`` — a plain link whose kink exceeds the switch deflection threshold;
* ``duplicate_track`` — OSM ways over exactly the same nodes (kept once);
* ``overlapping_tracks`` — two edges that run on top of each other without shared nodes;
* ``self_crossing_edge`` — an edge whose line crosses itself without a node there (not a
  conflict point: OSM should have a crossing node, or a bridge);
* ``outside_bounds`` — an edge with vertices more than ``bounds_margin_m`` outside the
  extent the source declared (its ``<bounds>`` or ``bbox``);
* ``driving_side`` — the map was built for the other driving side than its tagged double
  track shows (a side given by name): its untagged double track runs the wrong way round;
* ``multi_track_way`` — a way drawn as one line for several tracks (``tracks=2``): it runs
  both ways (unless tagged), and vehicles on it are not told apart by track;
* ``direction_tags`` — a way whose ``railway:preferred_direction`` and ``oneway`` disagree
  (the first is used), or whose value of either is no running direction (``oneway=yes;no``:
  the way counts as untagged there, and its direction may be inferred).

Notes (facts about the map, not problems):

* ``map_boundary`` — a node where the source's extract cut a way: the track goes on
  beyond the map there (see :func:`trackmap.build`);
* ``inferred_direction`` — an edge whose running direction no tag gives: the builder took
  it from the driving side (untagged double track) or from its one-way neighbours. Where
  vehicles really run both ways (single-line working), tag the ways: positioning holds a
  vehicle to the inferred direction, and a head-on meeting there would be missed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import shapely

from trackmap.builder.drivingside import DrivingSideTally
from trackmap.geometry import cumulative_length, deflection_deg, end_tangent
from trackmap.kinds import ConflictKind, NodeClass
from trackmap.model import Edge
from trackmap.network import TrackMap

__all__ = ["MAX_EDGE_M", "CheckReport", "Finding", "check"]

#: Longest plausible edge (track between two junctions) per railway kind, metres.
MAX_EDGE_M: dict[str, float] = {
    "tram": 5_000.0,
    "light_rail": 10_000.0,
    "subway": 10_000.0,
    "rail": 50_000.0,
    "narrow_gauge": 50_000.0,
}
_MAX_EDGE_OTHER_M = 10_000.0
# An edge whose line covers less than its length by more than this overlaps itself, m.
_OVERLAP_M = 0.5
_GRID_M = 0.05


@dataclass(frozen=True, slots=True)
class Finding:
    """One problem found by :func:`check`.

    Attributes
    ----------
    code : str
    message : str
    lon, lat : float or None
        Where to look, degrees.
    edges : tuple of int
    node_id : int or None
    """

    code: str
    message: str
    lon: float | None = None
    lat: float | None = None
    edges: tuple[int, ...] = ()
    node_id: int | None = None


@dataclass
class CheckReport:
    """Errors and warnings of a map, and notes (facts such as map boundaries)."""

    errors: list[Finding] = field(default_factory=list)
    warnings: list[Finding] = field(default_factory=list)
    notes: list[Finding] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when no error was found (warnings allowed)."""
        return not self.errors

    def counts(self) -> dict[str, int]:
        """Number of findings per code."""
        out: dict[str, int] = {}
        for f in [*self.errors, *self.warnings, *self.notes]:
            out[f.code] = out.get(f.code, 0) + 1
        return out

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {
            "ok": self.ok,
            "counts": self.counts(),
            "errors": [asdict(f) for f in self.errors],
            "warnings": [asdict(f) for f in self.warnings],
            "notes": [asdict(f) for f in self.notes],
        }


def check(
    net: TrackMap,
    *,
    min_edge_m: float = 1.0,
    snap_m: float = 1.5,
    max_deflection_deg: float | None = None,
    max_edge_m: float | None = None,
    bounds_margin_m: float = 1000.0,
) -> CheckReport:
    """Check a map for data problems.

    Parameters
    ----------
    net : TrackMap
    min_edge_m : float
        Edges shorter than this are errors, metres.
    snap_m : float
        A track end this close to another track without joining it is an error, metres.
    max_deflection_deg : float, optional
        Kink above which a link is reported; defaults to the map's build parameter.
    max_edge_m : float, optional
        Edges longer than this are errors, metres; by default :data:`MAX_EDGE_M` of the
        edge's railway kind.
    bounds_margin_m : float
        Vertices farther than this outside the source's declared extent are reported,
        metres (extracts that keep whole ways reach a little beyond their box).

    Returns
    -------
    CheckReport
    """
    report = CheckReport()
    limit = max_deflection_deg or float(net.metadata.build.get("max_deflection_deg", 35.0))
    probe = float(net.metadata.build.get("tangent_probe_m", 3.0))

    def at(x: float, y: float) -> tuple[float, float]:
        lon, lat = net.to_lonlat(x, y)
        return float(lon), float(lat)

    for node in net.nodes.values():
        if node.cls == NodeClass.UNKNOWN:
            report.errors.append(
                Finding(
                    "unknown_node",
                    f"node {node.node_id}: {len(node.ends)} edges meet with "
                    f"{len(node.allowed)} straight-enough pairs; fits no node class",
                    node.lon,
                    node.lat,
                    tuple(e for e, _ in node.ends),
                    node.node_id,
                )
            )
    for e in net.edges:
        if e.length_m < min_edge_m:
            lon, lat = _middle(e, at)
            report.errors.append(
                Finding(
                    "short_edge",
                    f"edge {e.edge_id} (ways {list(e.way_ids)}) is {e.length_m:.2f} m long",
                    lon,
                    lat,
                    (e.edge_id,),
                )
            )
    for node in net.nodes.values():
        for i, j in node.allowed:
            (ea, enda), (eb, endb) = node.ends[i], node.ends[j]
            da, db = net.edges[ea].direction, net.edges[eb].direction
            if da == 0 or db == 0:
                continue
            # +1 on an edge flows into its end vertex: flowing into the node from end 1
            into_a = (da == 1) == (enda == 1)
            into_b = (db == 1) == (endb == 1)
            if into_a == into_b:
                how = "head to head" if into_a else "tail to tail"
                report.errors.append(
                    Finding(
                        "contradictory_direction",
                        f"node {node.node_id}: one-way edges {ea} and {eb} meet {how}",
                        node.lon,
                        node.lat,
                        (ea, eb),
                        node.node_id,
                    )
                )
        if node.cls == NodeClass.LINK and len(node.ends) == 2:
            tangents = []
            for eid, end in node.ends:
                xy = np.asarray(net.edges[eid].geometry.coords, dtype=float)
                tangents.append(end_tangent(xy, cumulative_length(xy), end, probe))
            kink = deflection_deg(tangents[0], tangents[1])
            if kink > limit:
                report.warnings.append(
                    Finding(
                        "sharp_link",
                        f"node {node.node_id}: edges bend by {kink:.0f} degrees at a plain link",
                        node.lon,
                        node.lat,
                        tuple(e for e, _ in node.ends),
                        node.node_id,
                    )
                )
    boundary = _boundaries(net, report)
    _inferred_directions(net, report, at)
    _driving_side(net, report)
    _dangling(net, snap_m, report, boundary)
    _geometry(net, report, at, max_edge_m, bounds_margin_m)
    comps = net.components()
    if len(comps) > 1:
        sizes = [
            f"{len(c)} edges / {sum(net.edges[e].length_m for e in c) / 1000:.2f} km" for c in comps
        ]
        report.warnings.append(
            Finding("components", f"{len(comps)} separate networks: " + "; ".join(sizes))
        )
    for group in net.metadata.source.get("duplicate_ways", []):
        report.warnings.append(
            Finding("duplicate_track", f"ways {list(group)} run over the same nodes (kept once)")
        )
    edges_of_way: dict[int, list[int]] = {}
    for e in net.edges:
        for w in e.way_ids:
            edges_of_way.setdefault(w, []).append(e.edge_id)
    for way, doubt in net.metadata.source.get("direction_tag_doubts", []):
        on = tuple(edges_of_way.get(int(way), ()))
        place = _first_middle(net, on, at)
        report.warnings.append(Finding("direction_tags", f"way {way}: {doubt}", *place, on))
    for way, tracks in net.metadata.source.get("multi_track_ways", []):
        on = tuple(edges_of_way.get(int(way), ()))
        place = _first_middle(net, on, at)
        report.warnings.append(
            Finding(
                "multi_track_way",
                f"way {way} is one line for {tracks} tracks: vehicles on it are not told "
                "apart by track, and two meeting there are a head-on conflict to the analyser "
                "(draw each track as its own way)",
                *place,
                on,
            )
        )
    for a, b, x, y in net.metadata.source.get("overlapping_edges", []):
        lon, lat = at(x, y)
        report.warnings.append(
            Finding(
                "overlapping_tracks",
                f"edges {int(a)} and {int(b)} overlap along a stretch without sharing nodes",
                lon,
                lat,
                (int(a), int(b)),
            )
        )
    for c in net.conflicts:
        if c.kind == ConflictKind.CROSSING:
            lon, lat = at(c.x, c.y)
            report.warnings.append(
                Finding(
                    "unnoded_crossing",
                    f"edges {c.edges[0]} and {c.edges[1]} cross at {c.angle_deg or 0:.0f} degrees "
                    "at the same level without a shared node (kept as a conflict point)",
                    lon,
                    lat,
                    c.edges,
                )
            )
    return report


def _boundaries(net: TrackMap, report: CheckReport) -> set[int]:
    """Note the nodes where the source's extract cut a way; return their ids."""
    ways: dict[int, list[int]] = {}
    for nid, way in net.metadata.source.get("boundary_nodes", []):
        ways.setdefault(int(nid), []).append(int(way))
    for nid, way_ids in sorted(ways.items()):
        node = net.nodes.get(nid)
        if node is None:
            continue
        report.notes.append(
            Finding(
                "map_boundary",
                f"node {nid}: the track goes on beyond the map (way(s) {way_ids} cut by the "
                "source's extract)",
                node.lon,
                node.lat,
                tuple(e for e, _ in node.ends),
                nid,
            )
        )
    return set(ways)


def _middle(e: Edge, at: Callable[[float, float], tuple[float, float]]) -> tuple[float, float]:
    """The middle of an edge along its line, degrees (lon, lat)."""
    return at(*e.geometry.interpolate(0.5, normalized=True).coords[0])


def _first_middle(
    net: TrackMap, edges: tuple[int, ...], at: Callable[[float, float], tuple[float, float]]
) -> tuple[float | None, float | None]:
    """The middle of the first of ``edges`` (degrees), or no place when there is none (a
    way the extract's edge cut down to nothing)."""
    return _middle(net.edges[edges[0]], at) if edges else (None, None)


def _driving_side(net: TrackMap, report: CheckReport) -> None:
    """Warn of a map built for the side its own tagged double track contradicts."""
    evidence = net.metadata.source.get("driving_side_evidence")
    if not isinstance(evidence, dict):
        return  # (a map file written before the builder kept the evidence)
    tally = DrivingSideTally(
        right_m=float(evidence.get("right_m", 0.0)), left_m=float(evidence.get("left_m", 0.0))
    )
    shown = tally.side()
    if shown is None or shown == net.metadata.driving_side:
        return
    inferred = tuple(e.edge_id for e in net.edges if e.direction_source == "driving_side")
    report.warnings.append(
        Finding(
            "driving_side",
            f"built for {net.metadata.driving_side}-hand running, but its {tally.describe()}; "
            f"{len(inferred)} untagged edges take their direction from the side built for "
            f"(rebuild with driving_side='auto' or '{shown}')",
            edges=inferred,
        )
    )


def _inferred_directions(
    net: TrackMap, report: CheckReport, at: Callable[[float, float], tuple[float, float]]
) -> None:
    """Note the edges whose running direction was inferred rather than tagged."""
    why = {
        "driving_side": f"the driving side ({net.metadata.driving_side})",
        "propagated": "its one-way neighbours",
    }
    for e in net.edges:
        if e.direction_source in why:
            lon, lat = _middle(e, at)
            report.notes.append(
                Finding(
                    "inferred_direction",
                    f"edge {e.edge_id} (ways {list(e.way_ids)}): no tag gives its running "
                    f"direction, taken from {why[e.direction_source]}",
                    lon,
                    lat,
                    (e.edge_id,),
                )
            )


def _geometry(
    net: TrackMap,
    report: CheckReport,
    at: Callable[[float, float], tuple[float, float]],
    max_edge_m: float | None,
    margin_m: float,
) -> None:
    """Implausible geometry: long edges, edges over themselves, vertices out of bounds."""
    bounds = net.metadata.source.get("bounds")
    for e in net.edges:
        limit = max_edge_m if max_edge_m is not None else MAX_EDGE_M.get(e.kind, _MAX_EDGE_OTHER_M)
        mid = _middle(e, at)
        if e.length_m > limit:
            report.errors.append(
                Finding(
                    "long_edge",
                    f"edge {e.edge_id} (ways {list(e.way_ids)[:5]}) is {e.length_m / 1000:,.1f} "
                    f"km long, more than the {limit / 1000:g} km plausible for {e.kind} track "
                    "between junctions (a node with wrong coordinates?)",
                    *mid,
                    (e.edge_id,),
                )
            )
        overlap = _self_overlap_m(e.geometry)
        if overlap > _OVERLAP_M or not e.geometry.is_simple:
            if overlap > _OVERLAP_M:
                report.errors.append(
                    Finding(
                        "self_overlapping_edge",
                        f"edge {e.edge_id} (ways {list(e.way_ids)[:5]}) runs back over itself "
                        f"for {overlap:,.2f} m",
                        *mid,
                        (e.edge_id,),
                    )
                )
            else:
                report.warnings.append(
                    Finding(
                        "self_crossing_edge",
                        f"edge {e.edge_id} (ways {list(e.way_ids)[:5]}) crosses itself without "
                        "a node there (not a conflict point)",
                        *mid,
                        (e.edge_id,),
                    )
                )
        if bounds is not None:
            _outside(e, bounds, margin_m, report)


def _self_overlap_m(line: shapely.LineString) -> float:
    """How much of a line runs over another part of itself, metres (GEOS calls a line that
    doubles back on itself simple: its segments are merged to find out)."""
    xy = np.asarray(line.coords)
    if len(xy) < 3:
        return 0.0
    segments = shapely.multilinestrings(np.stack([xy[:-1], xy[1:]], axis=1))
    # on a 5 cm grid: a track drawn back over itself is never exactly collinear
    merged = shapely.unary_union(shapely.set_precision(segments, _GRID_M))
    return max(0.0, float(shapely.set_precision(line, _GRID_M).length - merged.length))


def _outside(e: Edge, bounds: list[float], margin_m: float, report: CheckReport) -> None:
    west, south, east, north = (float(v) for v in bounds)
    lon, lat = np.asarray(e.lon), np.asarray(e.lat)
    # distance outside the box, metres (1 degree of latitude is 111.2 km)
    dlat = np.maximum(np.maximum(south - lat, lat - north), 0.0) * 111_195.0
    dlon = np.maximum(np.maximum(west - lon, lon - east), 0.0)
    dlon = np.minimum(dlon, 360.0 - dlon) * 111_195.0 * np.cos(np.radians(lat))
    dist = np.hypot(dlat, dlon)
    far = np.flatnonzero(dist > margin_m)
    if len(far):
        k = int(far[np.argmax(dist[far])])
        report.warnings.append(
            Finding(
                "outside_bounds",
                f"edge {e.edge_id}: {len(far)} vertex(es) lie outside the source's bounds "
                f"{[round(float(b), 6) for b in bounds]}, up to {float(dist[k]) / 1000:,.1f} "
                f"km (node {e.node_ids[k]})",
                float(lon[k]),
                float(lat[k]),
                (e.edge_id,),
            )
        )


def _dangling(net: TrackMap, snap_m: float, report: CheckReport, boundary: set[int]) -> None:
    geoms = np.array([e.geometry for e in net.edges], dtype=object)
    tree = shapely.STRtree(geoms)
    for node in net.nodes.values():
        if node.cls != NodeClass.BUFFER_STOP or node.node_id in boundary:
            continue
        own = node.ends[0][0]
        pt = shapely.Point(node.x, node.y)
        near = [int(i) for i in tree.query(pt, predicate="dwithin", distance=snap_m) if i != own]
        if not near:
            continue
        gap = min(float(shapely.distance(pt, geoms[i])) for i in near)
        report.errors.append(
            Finding(
                "dangling_end",
                f"node {node.node_id}: track end {gap:.2f} m from edge(s) {near} "
                "without joining them (missing connection?)",
                node.lon,
                node.lat,
                (own, *near),
                node.node_id,
            )
        )
