"""Track topology from raw ways: splitting, merging, node classes, directions, conflicts.

The functions here are pure: they take plain data (node ids, local coordinates, tags) and
return plain data. :mod:`trackmap.builder.assemble` runs them in order and assembles a
:class:`trackmap.TrackMap`.

Node classes follow the rule OSRD uses for inferring track topology: count the edges
meeting at a node and the pairs of them that a vehicle can pass straight through
(deflection at most ``max_deflection_deg``):

===========  =================  =================
edges        straight pairs     class
===========  =================  =================
1            -                  ``buffer_stop``
2            1                  ``link``
3            2                  ``point_switch``
4            2 (disjoint)       ``diamond_crossing``
4            4                  ``double_slip``
otherwise                       ``unknown`` (reported by ``check``)
===========  =================  =================
"""

from __future__ import annotations

import math
import re
from collections import defaultdict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import combinations
from typing import Final

import numpy as np
import shapely

from trackmap.builder.sources import MARKED_SERVICES
from trackmap.geometry import FloatArray, deflection_deg
from trackmap.kinds import NodeClass

__all__ = [
    "MAX_LAYER",
    "CrossingHit",
    "EdgeEnd",
    "NodeTopology",
    "Piece",
    "TrackAttributes",
    "classify_node",
    "direction_tag",
    "direction_tag_doubt",
    "drawn_tracks",
    "drop_duplicate_pieces",
    "find_crossings",
    "fouling_distance",
    "grade_separated",
    "merge_chains",
    "parse_layer",
    "parse_maxspeed_mps",
    "propagate_directions",
    "split_ways",
    "track_attributes",
]

#: An edge end: (edge index, 0 for the start vertex or 1 for the end vertex).
EdgeEnd = tuple[int, int]


# -- tags ---------------------------------------------------------------------------------
#: ``railway:preferred_direction`` values, as running directions relative to node order.
_PREFERRED: Final = {"forward": 1, "backward": -1, "both": 0}
#: ``oneway`` values, likewise; ``reversible`` and ``alternating`` ways carry traffic both
#: ways (one at a time), which is what matters to who may meet whom.
_ONEWAY: Final = {
    "yes": 1, "true": 1, "1": 1, "-1": -1, "reverse": -1,
    "no": 0, "false": 0, "0": 0, "reversible": 0, "alternating": 0,
}  # fmt: skip


def direction_tag(tags: Mapping[str, str]) -> tuple[int, str]:
    """Running direction a way's tags declare, relative to its node order.

    ``railway:preferred_direction`` wins over ``oneway`` (it is the railway tag; see
    :func:`direction_tag_doubt` for ways whose two tags disagree).

    A way drawn for several tracks (``tracks=2``) with neither tag carries traffic both
    ways: no direction is inferred for it.

    Returns
    -------
    (direction, source)
        direction +1 (node order), -1 (against it) or 0 (both ways); source
        ``preferred_direction``, ``oneway``, ``tracks`` or ``none``.
    """
    pref = _PREFERRED.get(tags.get("railway:preferred_direction", ""))
    if pref is not None:
        return pref, "preferred_direction"
    oneway = _ONEWAY.get(tags.get("oneway", ""))
    if oneway is not None:
        return oneway, "oneway"
    if drawn_tracks(tags) > 1:  # (two tracks, one each way, drawn as one line)
        return 0, "tracks"
    return 0, "none"


def drawn_tracks(tags: Mapping[str, str]) -> int:
    """How many parallel tracks a way's one line stands for (``tracks``; 1 when absent or
    not a whole number from 1 to 20)."""
    value = tags.get("tracks", "").strip()
    # (isdigit alone admits "²", which int() refuses)
    number = int(value) if value.isascii() and value.isdigit() else 1
    return number if 1 <= number <= 20 else 1


def direction_tag_doubt(tags: Mapping[str, str]) -> str | None:
    """What a maintainer should look at in a way's direction tags, or None: a value this
    builder does not read (the way counts as untagged there) or two tags that disagree
    (``railway:preferred_direction`` is used)."""
    doubts = []
    values = {}
    for key, known in (("railway:preferred_direction", _PREFERRED), ("oneway", _ONEWAY)):
        value = tags.get(key)
        if value is None:
            continue
        if value not in known:
            doubts.append(f"{key}={value} is not a running direction (read as untagged)")
        else:
            values[key] = value
    if len(values) == 2:
        pref, oneway = values["railway:preferred_direction"], values["oneway"]
        if _PREFERRED[pref] != _ONEWAY[oneway]:
            doubts.append(
                f"railway:preferred_direction={pref} and oneway={oneway} disagree "
                f"(railway:preferred_direction={pref} is used)"
            )
    return "; ".join(doubts) or None


_SPEED = re.compile(r"^\s*([0-9]+(?:\.[0-9]+)?)\s*(km/h|kmh|kph|mph|knots)?\s*$")


def parse_maxspeed_mps(value: str | None) -> float | None:
    """``maxspeed`` tag to m/s (``"50"``, ``"50 km/h"``, ``"30 mph"``); None if unusable."""
    if not value:
        return None
    m = _SPEED.match(value.split(";")[0])
    if not m:
        return None
    number = float(m.group(1))
    unit = m.group(2) or "km/h"
    factor = {"km/h": 1 / 3.6, "kmh": 1 / 3.6, "kph": 1 / 3.6, "mph": 0.44704, "knots": 1852 / 3600}
    speed = number * factor[unit]
    return speed if 0 < speed < 150 else None


#: OSM ``layer`` values beyond this are not layers (OSM uses -5..5).
MAX_LAYER = 100


def parse_layer(tags: Mapping[str, str]) -> int:
    """OSM ``layer`` as an int (0 when absent, unparsable or beyond +-:data:`MAX_LAYER`)."""
    try:
        layer = int(float(tags.get("layer", "0")))
    except (ValueError, OverflowError):  # "x", "nan", "inf", "1e400"
        return 0
    return layer if -MAX_LAYER <= layer <= MAX_LAYER else 0


def _yes(tags: Mapping[str, str], key: str) -> bool:
    value = tags.get(key)
    return value is not None and value not in ("no", "false", "0")


@dataclass(frozen=True, slots=True)
class TrackAttributes:
    """The attributes that must be equal along one edge."""

    kind: str
    service: str | None
    layer: int
    bridge: bool
    tunnel: bool
    maxspeed_mps: float | None


def track_attributes(tags: Mapping[str, str]) -> TrackAttributes:
    """Edge-relevant attributes of a way."""
    service = tags.get("service")
    return TrackAttributes(
        kind=tags.get("railway", "tram"),
        service=service if service in MARKED_SERVICES else None,
        layer=parse_layer(tags),
        bridge=_yes(tags, "bridge"),
        tunnel=_yes(tags, "tunnel"),
        maxspeed_mps=parse_maxspeed_mps(tags.get("maxspeed")),
    )


# -- splitting and merging ----------------------------------------------------------------
@dataclass
class Piece:
    """A run of nodes with uniform attributes (a way piece, later a merged edge)."""

    node_ids: list[int]
    way_ids: list[int]
    attrs: TrackAttributes
    direction: int
    direction_source: str
    name: str | None = None

    def reversed(self) -> Piece:
        return Piece(
            self.node_ids[::-1],
            self.way_ids[::-1],
            self.attrs,
            -self.direction,
            self.direction_source,
            self.name,
        )


def split_ways(ways: Sequence[tuple[int, Sequence[int], Mapping[str, str]]]) -> list[Piece]:
    """Split ways at every node they share with another way (or revisit).

    Parameters
    ----------
    ways : sequence of (way_id, node_ids, tags)

    Returns
    -------
    list of Piece
        Pieces whose interior nodes belong to no other piece.
    """
    uses: dict[int, int] = defaultdict(int)
    for _, nodes, _ in ways:
        for n in nodes:
            uses[n] += 1
    pieces: list[Piece] = []
    for way_id, nodes, tags in ways:
        attrs = track_attributes(tags)
        direction, source = direction_tag(tags)
        start = 0
        for i in range(1, len(nodes)):
            if i == len(nodes) - 1 or uses[nodes[i]] > 1:
                pieces.append(
                    Piece(
                        list(nodes[start : i + 1]),
                        [way_id],
                        attrs,
                        direction,
                        source,
                        tags.get("name"),
                    )
                )
                start = i
    return pieces


def drop_duplicate_pieces(pieces: list[Piece]) -> tuple[list[Piece], list[tuple[int, ...]]]:
    """Remove pieces that repeat another piece's node sequence (either way round).

    OSM sometimes holds two ways over exactly the same nodes; kept, they would look like a
    loop of zero width and an at-grade crossing of a track with itself. The first piece
    stays and gains the duplicate's way ids.

    Returns
    -------
    pieces : list of Piece
    duplicates : list of tuple of int
        The way ids of each group of duplicates (for ``check``).
    """
    kept: dict[tuple[int, ...], Piece] = {}
    groups: dict[tuple[int, ...], list[int]] = {}
    for p in pieces:
        seq = tuple(p.node_ids)
        key = min(seq, seq[::-1])
        if key in kept:
            first = kept[key]
            first.way_ids.extend(w for w in p.way_ids if w not in first.way_ids)
            groups[key].extend(p.way_ids)
        else:
            kept[key] = p
            groups[key] = list(p.way_ids)
    dups = [tuple(dict.fromkeys(g)) for g in groups.values() if len(set(g)) > 1]
    return list(kept.values()), dups


def propagate_directions(pieces: list[Piece], directions: list[int], sources: list[str]) -> None:
    """Give untagged main-line pieces the direction their one-way neighbours imply.

    Where an untagged piece continues a one-way piece through a plain link (two pieces at
    the node), traffic must flow on; the piece takes that direction when every such link
    agrees and both ends are such links. Repeated until nothing changes; edits
    ``directions`` and ``sources`` in place.
    """
    ends: dict[int, list[tuple[int, int]]] = defaultdict(list)
    for i, p in enumerate(pieces):
        ends[p.node_ids[0]].append((i, 0))
        ends[p.node_ids[-1]].append((i, 1))
    changed = True
    while changed:
        changed = False
        for i, p in enumerate(pieces):
            if directions[i] != 0 or p.attrs.service is not None or p.direction_source != "none":
                continue
            implied = set()
            informed = 0
            for node, end in ((p.node_ids[0], 0), (p.node_ids[-1], 1)):
                at = ends[node]
                if len(at) != 2:
                    continue
                j, end_j = at[0] if at[0][0] != i else at[1]
                if j == i or directions[j] == 0:
                    continue
                informed += 1
                into_node = (directions[j] == 1) == (end_j == 1)
                out_of_node = 1 if end == 0 else -1
                implied.add(out_of_node if into_node else -out_of_node)
            if len(implied) == 1 and informed == 2:
                directions[i] = implied.pop()
                sources[i] = "propagated"
                changed = True


def merge_chains(pieces: list[Piece]) -> list[Piece]:
    """Join pieces through nodes where exactly two pieces meet with equal attributes.

    Direction tags must agree after orienting the pieces, so two one-way pieces running
    head to head stay separate (``check`` reports them).
    """
    ends: dict[int, list[tuple[int, int]]] = defaultdict(list)
    for i, p in enumerate(pieces):
        ends[p.node_ids[0]].append((i, 0))
        ends[p.node_ids[-1]].append((i, 1))

    def mergeable(node: int) -> bool:
        return len(ends[node]) == 2 and ends[node][0][0] != ends[node][1][0]

    used = [False] * len(pieces)
    merged: list[Piece] = []
    for i in range(len(pieces)):
        if used[i]:
            continue
        used[i] = True
        chain = Piece(
            list(pieces[i].node_ids),
            list(pieces[i].way_ids),
            pieces[i].attrs,
            pieces[i].direction,
            pieces[i].direction_source,
            pieces[i].name,
        )
        for forward in (True, False):
            while True:
                node = chain.node_ids[-1] if forward else chain.node_ids[0]
                if not mergeable(node) or chain.node_ids[0] == chain.node_ids[-1]:
                    break
                (a, ea), (b, eb) = ends[node]
                j, ej = (b, eb) if used[a] else (a, ea)
                if used[j]:
                    break
                nxt = pieces[j]
                # orient the next piece so that it continues the chain
                if forward:
                    nxt = nxt if ej == 0 else nxt.reversed()
                else:
                    nxt = nxt if ej == 1 else nxt.reversed()
                if nxt.attrs != chain.attrs or nxt.direction != chain.direction:
                    break
                used[j] = True
                if forward:
                    chain.node_ids.extend(nxt.node_ids[1:])
                    chain.way_ids.extend(w for w in nxt.way_ids if w != chain.way_ids[-1])
                else:
                    chain.node_ids[:0] = nxt.node_ids[:-1]
                    chain.way_ids[:0] = [w for w in nxt.way_ids if w != chain.way_ids[0]]
                if chain.direction_source == "none":
                    chain.direction_source = nxt.direction_source
                chain.name = chain.name or nxt.name
        merged.append(chain)
    return merged


# -- node classes -------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class NodeTopology:
    """Class and allowed moves of one junction node."""

    cls: NodeClass
    ends: tuple[EdgeEnd, ...]
    allowed: tuple[tuple[int, int], ...]  # pairs of indices into ``ends``
    deflections: tuple[float, ...]  # per allowed pair, degrees


def classify_node(
    ends: Sequence[EdgeEnd],
    tangents: Sequence[FloatArray],
    *,
    max_deflection_deg: float,
    through_pairs: Sequence[tuple[int, int]] = (),
    tags: Mapping[str, str] | None = None,
    link_max_deflection_deg: float = 90.0,
) -> NodeTopology:
    """Classify a node from the directions of the edges meeting there.

    Parameters
    ----------
    ends : sequence of EdgeEnd
        The edge ends at the node.
    tangents : sequence of ndarray
        Unit vectors from the node into each edge.
    max_deflection_deg : float
        Largest deflection of a straight-enough pair, degrees.
    through_pairs : sequence of (i, j)
        Pairs of ends that belong to one OSM way passing through the node.
    tags : mapping, optional
        The node's own tags. ``railway=switch``, ``railway=railway_crossing`` and
        ``railway:switch=double_slip|single_slip`` override the geometric rule.
    link_max_deflection_deg : float
        Largest deflection still passable at a plain link (2 edges), degrees.

    Notes
    -----
    Untagged, a node where exactly two OSM ways cross (each passing straight through) is a
    diamond crossing: OSM marks slips with ``railway:switch``, and a tram curve crossing
    the opposite track meets it at 20-35 degrees, an angle the geometric rule alone would
    read as a double slip.
    """
    tags = tags or {}
    n = len(ends)
    defl = {(i, j): deflection_deg(tangents[i], tangents[j]) for i, j in combinations(range(n), 2)}
    straight = [pr for pr, d in defl.items() if d <= max_deflection_deg]
    passable = [pr for pr, d in defl.items() if d <= link_max_deflection_deg]
    switch_tag = tags.get("railway:switch")
    cls: NodeClass
    allowed: list[tuple[int, int]]
    if n == 1:
        cls, allowed = NodeClass.BUFFER_STOP, []
    elif n == 2:
        cls, allowed = NodeClass.LINK, passable
    elif n == 3 and (tags.get("railway") == "switch" or switch_tag in ("default", "wye", "abt")):
        # a tagged switch: the trunk is the end the other two diverge from
        branch_pair = max(defl, key=lambda pr: defl[pr])
        cls, allowed = NodeClass.POINT_SWITCH, [pr for pr in defl if pr != branch_pair]
    elif n == 4 and switch_tag in ("double_slip", "single_slip"):
        cls, allowed = NodeClass.DOUBLE_SLIP, straight
    elif n == 4 and (tags.get("railway") == "railway_crossing" or _two_disjoint(through_pairs)):
        pairs = list(through_pairs) if _two_disjoint(through_pairs) else _straightest_disjoint(defl)
        cls, allowed = (
            NodeClass.DIAMOND_CROSSING,
            [pr for pr in pairs if defl[pr] <= link_max_deflection_deg],
        )
    elif n == 3 and len(straight) == 2:
        cls, allowed = NodeClass.POINT_SWITCH, straight
    elif n == 4 and len(straight) == 2 and _two_disjoint(straight):
        cls, allowed = NodeClass.DIAMOND_CROSSING, straight
    elif n == 4 and len(straight) == 4:
        cls, allowed = NodeClass.DOUBLE_SLIP, straight
    else:
        cls, allowed = NodeClass.UNKNOWN, straight
    allowed = sorted(allowed)
    return NodeTopology(
        cls=cls,
        ends=tuple(ends),
        allowed=tuple(allowed),
        deflections=tuple(defl[pr] for pr in allowed),
    )


def _two_disjoint(pairs: Sequence[tuple[int, int]]) -> bool:
    return len(pairs) == 2 and not set(pairs[0]) & set(pairs[1])


def _straightest_disjoint(defl: dict[tuple[int, int], float]) -> list[tuple[int, int]]:
    options = [((0, 1), (2, 3)), ((0, 2), (1, 3)), ((0, 3), (1, 2))]
    best = min(options, key=lambda o: max(defl[o[0]], defl[o[1]]))
    return list(best)


# -- conflicts ----------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class CrossingHit:
    """Two edges whose lines cross away from any shared node."""

    edge_a: int
    edge_b: int
    x: float
    y: float
    offset_a_m: float
    offset_b_m: float
    angle_deg: float
    grade_separated: bool
    overlap: bool = False


def find_crossings(
    lines: Sequence[shapely.LineString],
    attrs: Sequence[TrackAttributes],
    node_xy: Sequence[tuple[FloatArray, FloatArray]],
    *,
    node_tolerance_m: float = 0.05,
) -> list[CrossingHit]:
    """Every point where two edges cross or touch without sharing a node there.

    Parameters
    ----------
    lines : sequence of LineString
        Edge geometries (local metres).
    attrs : sequence of TrackAttributes
        Per edge, for grade separation (``layer``, ``bridge``, ``tunnel``).
    node_xy : sequence of (start_xy, end_xy)
        Coordinates of each edge's end nodes; touching at a shared end node is topology,
        not a crossing.
    """
    tree = shapely.STRtree(list(lines))
    left, right = tree.query(list(lines), predicate="intersects")
    hits: list[CrossingHit] = []
    for a, b in zip(left.tolist(), right.tolist(), strict=True):
        if a >= b:
            continue
        inter = shapely.intersection(lines[a], lines[b])
        points = _intersection_points(inter)
        overlap = _has_overlap(inter)
        ends = [*node_xy[a], *node_xy[b]]
        for p in points:
            if any(math.hypot(p[0] - e[0], p[1] - e[1]) <= node_tolerance_m for e in ends):
                continue
            off_a = float(lines[a].project(shapely.Point(p)))
            off_b = float(lines[b].project(shapely.Point(p)))
            angle = _crossing_angle(lines[a], off_a, lines[b], off_b)
            hits.append(
                CrossingHit(
                    edge_a=a,
                    edge_b=b,
                    x=float(p[0]),
                    y=float(p[1]),
                    offset_a_m=off_a,
                    offset_b_m=off_b,
                    angle_deg=angle,
                    grade_separated=grade_separated(attrs[a], attrs[b]),
                    overlap=overlap,
                )
            )
    return hits


def grade_separated(a: TrackAttributes, b: TrackAttributes) -> bool:
    """Two tracks cannot meet when on different layers, or either is a bridge or tunnel."""
    return a.layer != b.layer or a.bridge or b.bridge or a.tunnel or b.tunnel


def _has_overlap(geom: shapely.Geometry) -> bool:
    if geom.is_empty:
        return False
    if geom.geom_type in ("LineString", "MultiLineString"):
        return True
    if geom.geom_type == "GeometryCollection":
        return any(_has_overlap(g) for g in geom.geoms)
    return False


def _intersection_points(geom: shapely.Geometry) -> list[tuple[float, float]]:
    if geom.is_empty:
        return []
    gtype = geom.geom_type
    if gtype == "Point":
        return [(geom.x, geom.y)]
    if gtype in ("MultiPoint", "GeometryCollection", "MultiLineString"):
        out: list[tuple[float, float]] = []
        for g in geom.geoms:
            out.extend(_intersection_points(g))
        return out
    if gtype == "LineString":  # collinear overlap: report its midpoint once
        mid = geom.interpolate(0.5, normalized=True)
        return [(mid.x, mid.y)]
    return []


def _crossing_angle(
    a: shapely.LineString, off_a: float, b: shapely.LineString, off_b: float
) -> float:
    def direction(line: shapely.LineString, s: float) -> tuple[float, float]:
        p1 = line.interpolate(max(s - 1.0, 0.0))
        p2 = line.interpolate(min(s + 1.0, line.length))
        dx, dy = p2.x - p1.x, p2.y - p1.y
        n = math.hypot(dx, dy) or 1.0
        return dx / n, dy / n

    ua, ub = direction(a, off_a), direction(b, off_b)
    cos = abs(ua[0] * ub[0] + ua[1] * ub[1])
    return math.degrees(math.acos(min(cos, 1.0)))


def fouling_distance(
    branch: shapely.LineString,
    branch_from_start: bool,
    other: shapely.LineString,
    *,
    clearance_m: float,
    step_m: float = 0.5,
) -> float:
    """Distance from a switch along one branch to where it clears the other branch.

    Parameters
    ----------
    branch, other : LineString
        The two diverging branches (local metres).
    branch_from_start : bool
        True when the branch starts at the switch node.
    clearance_m : float
        Track-centre separation at which vehicles on the two branches no longer foul each
        other, metres.

    Returns
    -------
    float
        Distance along ``branch`` from the switch, metres (the branch length if it never
        clears).
    """
    length = branch.length
    s = np.arange(step_m, length + step_m, step_m)
    s = np.minimum(s, length)
    along = s if branch_from_start else length - s
    pts = shapely.line_interpolate_point(branch, along)
    dist = shapely.distance(pts, other)
    clear = np.flatnonzero(dist >= clearance_m)
    return float(s[clear[0]]) if len(clear) else float(length)
