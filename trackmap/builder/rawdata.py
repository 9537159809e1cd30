"""The records a source is read into, and the rules every reader shares.

:class:`SourceData` holds a source's track ways (:class:`RawWay`) and stops
(:class:`RawStop`) with the counts of what was dropped or cut; :func:`add_way` keeps a way,
or the located pieces of a way cut by the extract's boundary (see
:mod:`trackmap.builder.sources`); :func:`way_rejection`, :func:`is_stop` and
:func:`is_topology_node` are the tag rules.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

__all__ = [
    "INT64_MAX",
    "INT64_MIN",
    "KNOWN_KINDS",
    "LIFECYCLE",
    "MARKED_SERVICES",
    "TOPOLOGY_NODE_VALUES",
    "RawStop",
    "RawWay",
    "SourceData",
    "add_way",
    "coordinate_node_id",
    "is_stop",
    "is_topology_node",
    "valid_lonlat",
    "way_rejection",
]

logger = logging.getLogger(__name__)

#: Railway kinds a map can be built from.
KNOWN_KINDS = ("tram", "light_rail", "rail", "subway", "narrow_gauge")
#: Lifecycle prefixes/values that mean "not an operating track".
LIFECYCLE = ("disused", "abandoned", "razed", "construction", "proposed", "dismantled")
#: ``service=`` values kept but marked (depot and auxiliary tracks).
MARKED_SERVICES = ("yard", "siding", "spur", "crossover")
#: OSM ids are signed 64-bit integers (so are the ids of a map file).
INT64_MIN = -(2**63)
INT64_MAX = 2**63 - 1

# How many dropped or cut elements a warning names before it only counts them.
_NAMED = 5


@dataclass(frozen=True, slots=True)
class RawWay:
    """One track way (or one located piece of a cut way) as read from a source.

    Attributes
    ----------
    way_id : int
        OSM way id (or a feature id for GeoJSON without OSM ids). The pieces of a way cut
        by the extract's boundary share its id.
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
        Kept track ways (the located pieces of cut ways).
    stops : list of RawStop
        Stop positions.
    path : str
        The source file.
    fmt : str
        ``osmium``, ``overpass-json`` or ``geojson``.
    dropped : Counter
        Ways not kept, by reason: ``other_kind``, ``lifecycle``, ``area``, ``too_short``
        (fewer than two distinct nodes), ``missing_nodes`` (no two consecutive nodes with
        a location: outside the extract), and for GeoJSON ``no_geometry`` and
        ``not_a_line``.
    node_tags : dict
        Tags of nodes that describe track topology (``railway=switch``,
        ``railway=railway_crossing``, ``railway=buffer_stop``, ``railway:switch=*``).
    bounds : (min_lon, min_lat, max_lon, max_lat) or None
        The extent the source declares (OSM header ``<bounds>``, GeoJSON ``bbox``), degrees.
    clipped : Counter
        Ways cut by the extract's boundary: ``ways`` kept in pieces, ``pieces`` kept,
        ``missing_refs`` node references without a location in them, ``short_pieces``
        single located nodes that could not make a piece.
    boundary_nodes : list of (node_id, way_id)
        Located nodes of kept pieces next to a missing node: the track goes on beyond the
        map there.
    kept_ways : int
        Way elements kept, whole or in pieces: with :attr:`dropped` they account for every
        way element of a track kind the reader saw.
    """

    ways: list[RawWay]
    stops: list[RawStop]
    path: str
    fmt: str
    dropped: Counter[str] = field(default_factory=Counter)
    node_tags: dict[int, dict[str, str]] = field(default_factory=dict)
    bounds: tuple[float, float, float, float] | None = None
    clipped: Counter[str] = field(default_factory=Counter)
    boundary_nodes: list[tuple[int, int]] = field(default_factory=list)
    kept_ways: int = 0


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


def is_topology_node(tags: Mapping[str, str]) -> bool:
    """Whether a node's tags describe track topology (a switch, crossing or buffer stop)."""
    return tags.get("railway") in TOPOLOGY_NODE_VALUES or "railway:switch" in tags


def is_stop(tags: Mapping[str, str]) -> bool:
    """Whether a node's tags make it a stop position of a tram or light-rail line."""
    return tags.get("railway") in ("tram_stop", "stop", "halt") or (
        tags.get("public_transport") == "stop_position"
        and (tags.get("tram") == "yes" or tags.get("light_rail") == "yes")
    )


def coordinate_node_id(lon: float, lat: float) -> int:
    """A stable negative node id from coordinates rounded to 1e-7 degree.

    GeoJSON has no node ids; vertices at the same rounded position get the same id so
    lines that share vertices join (negative ids never clash with OSM ids).
    """
    ilon = round(lon * 1e7) + 1_800_000_000
    ilat = round(lat * 1e7) + 900_000_000
    return -(ilon * 2_000_000_000 + ilat) - 1


def add_way(
    data: SourceData,
    way_id: int,
    refs: Sequence[tuple[int, float, float] | int],
    tags: dict[str, str],
) -> None:
    """Keep a track way, or its located pieces when some of its nodes have no location.

    Parameters
    ----------
    data : SourceData
        Where the way (or its pieces, the counts and the boundary nodes) is added.
    way_id : int
    refs : sequence
        The way's nodes in order: ``(node_id, lon, lat)`` for a located node, the bare
        ``node_id`` for a node without a location (outside the extract).
    tags : dict
    """
    runs: list[list[tuple[int, float, float]]] = [[]]
    missing = 0
    for ref in refs:
        if isinstance(ref, tuple):
            runs[-1].append(ref)
        else:
            missing += 1
            if runs[-1]:
                runs.append([])
    runs = [r for r in runs if r]
    if not missing:
        if _add_piece(data, way_id, runs[0] if runs else [], tags):
            data.kept_ways += 1
        return
    kept = 0
    for k, run in enumerate(runs):
        if _add_piece(data, way_id, run, tags, count_short=False):
            kept += 1
            first_cut = k > 0 or not isinstance(refs[0], tuple)
            last_cut = k < len(runs) - 1 or not isinstance(refs[-1], tuple)
            if first_cut:
                data.boundary_nodes.append((run[0][0], way_id))
            if last_cut:
                data.boundary_nodes.append((run[-1][0], way_id))
        else:
            data.clipped["short_pieces"] += 1
    if not kept:
        data.dropped["missing_nodes"] += 1
        if data.dropped["missing_nodes"] <= _NAMED:
            logger.info("%s: way %d lies outside the extract (no located piece)", data.path, way_id)
        return
    data.kept_ways += 1
    data.clipped["ways"] += 1
    data.clipped["pieces"] += kept
    data.clipped["missing_refs"] += missing


def _add_piece(
    data: SourceData,
    way_id: int,
    nodes: list[tuple[int, float, float]],
    tags: dict[str, str],
    *,
    count_short: bool = True,
) -> bool:
    # consecutive repeated nodes (drawing errors) carry no geometry
    cleaned = [n for i, n in enumerate(nodes) if i == 0 or n[0] != nodes[i - 1][0]]
    if len(cleaned) < 2:
        if count_short:
            data.dropped["too_short"] += 1
        return False
    data.ways.append(
        RawWay(
            way_id=way_id,
            node_ids=tuple(n[0] for n in cleaned),
            lon=tuple(n[1] for n in cleaned),
            lat=tuple(n[2] for n in cleaned),
            tags=tags,
        )
    )
    return True


def valid_lonlat(lon: object, lat: object) -> bool:
    """Whether ``lon``, ``lat`` are finite numbers (not booleans) within WGS84's range."""
    return (
        isinstance(lon, (int, float))
        and isinstance(lat, (int, float))
        and not isinstance(lon, bool)
        and not isinstance(lat, bool)
        and _finite(lon)
        and _finite(lat)
        and -180.0 <= lon <= 180.0
        and -90.0 <= lat <= 90.0
    )


def _finite(value: int | float) -> bool:
    try:
        return math.isfinite(value)
    except OverflowError:  # an int beyond the range of a double
        return False
