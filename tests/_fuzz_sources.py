"""Fuzzing harness, sources' part: broken OSM XML, Overpass JSON and GeoJSON (see
``tests/_fuzz.py`` for the outcomes)."""

from __future__ import annotations

import contextlib
import json
import random
from pathlib import Path
from typing import Any

import trackmap
from tests._fuzz import Outcome, _bare, base_network, weird
from tests._osm import OsmBuilder
from trackmap.builder import assemble
from trackmap.builder.sources import read_source
from trackmap.check import check
from trackmap.errors import TrackMapError

# -- sources (OSM XML, Overpass JSON, GeoJSON) ---------------------------------------------
SOURCE_FORMATS = ("osm", "overpass", "geojson")
_RAW_WEIRD = ("nan", "1e300", "", "x", "91", "-181", "0", "1" * 5000, "-0", "inf", " 5", "1e-400")


def mutate_source(rng: random.Random) -> OsmBuilder:
    """A broken copy of the base network (values of the intermediate form, any type)."""
    b = base_network()
    nodes, ways = b.nodes, b.ways
    for _ in range(rng.randrange(1, 4)):
        # an earlier mutation may have left nothing this one can change
        with contextlib.suppress(TypeError, ValueError, IndexError, KeyError):
            _mutate_once(rng, nodes, ways)
    return b


def _mutate_once(rng: random.Random, nodes: dict[Any, Any], ways: list[Any]) -> None:
    if True:
        op = rng.randrange(12)
        if op == 0:  # a coordinate: wrong text or value
            nid = rng.choice(list(nodes))
            lon, lat, tags = nodes[nid]
            shifted = lon + 0.5 if type(lon) in (int, float) else 0.5
            value: Any = rng.choice([*_RAW_WEIRD, weird(rng), 179.9, -89.99, shifted])
            nodes[nid] = (value, lat, tags) if rng.random() < 0.5 else (lon, value, tags)
        elif op == 1:  # a node without location (outside the extract)
            del nodes[rng.choice(list(nodes))]
        elif op == 2:  # an id
            i = rng.randrange(len(ways))
            wid, refs, tags = ways[i]
            ways[i] = (rng.choice([*_RAW_WEIRD, weird(rng), -5, 2**63]), refs, tags)
        elif op == 3:  # a node reference
            i = rng.randrange(len(ways))
            wid, refs, tags = ways[i]
            refs = list(refs)
            refs[rng.randrange(len(refs))] = rng.choice([*_RAW_WEIRD, weird(rng), 12345, refs[0]])
            ways[i] = (wid, refs, tags)
        elif op == 4:  # tags
            i = rng.randrange(len(ways))
            wid, refs, tags = ways[i]
            key = rng.choice(["railway", "maxspeed", "layer", "oneway", "bridge", "service", "x"])
            tags = dict(tags)
            tags[key] = rng.choice([*_RAW_WEIRD, weird(rng), "disused", "1e400", "-1", "yes"])
            ways[i] = (wid, refs, tags if rng.random() < 0.9 else rng.choice([[], "railway", None]))
        elif op == 5:  # refs: empty, one node, a loop, repeated, not a list
            i = rng.randrange(len(ways))
            wid, refs, tags = ways[i]
            ways[i] = (
                wid,
                rng.choice([[], refs[:1], [*refs, refs[0]], [refs[0]] * 3, refs[::-1], "12"]),
                tags,
            )
        elif op == 6:  # duplicate a way
            ways.append(rng.choice(ways))
        elif op == 7:  # all nodes of a way at one place
            _, refs, _ = rng.choice(ways)
            located = (
                [n for n in refs if _hashable(n) and n in nodes] if isinstance(refs, list) else []
            )
            for n in located:
                nodes[n] = (nodes[located[0]][0], nodes[located[0]][1], nodes[n][2])
        elif op == 8:  # pole to pole
            _, refs, _ = rng.choice(ways)
            located = (
                [n for n in refs if _hashable(n) and n in nodes] if isinstance(refs, list) else []
            )
            if len(located) >= 2:
                nodes[located[0]] = (19.94, -89.9, nodes[located[0]][2])
                nodes[located[-1]] = (19.94, 89.9, nodes[located[-1]][2])
        elif op == 9:  # node tags
            nid = rng.choice(list(nodes))
            lon, lat, _ = nodes[nid]
            nodes[nid] = (
                lon,
                lat,
                rng.choice(
                    [
                        {"railway": "switch"},
                        {"railway": "tram_stop", "name": weird(rng)},
                        {"railway:switch": "double_slip"},
                        weird(rng),
                    ]
                ),
            )
        elif op == 10:  # a way entirely without its nodes
            _, refs, _ = rng.choice(ways)
            for n in refs if isinstance(refs, list) else []:
                if _hashable(n):
                    nodes.pop(n, None)
        else:  # a huge tag value
            i = rng.randrange(len(ways))
            wid, refs, tags = ways[i]
            if isinstance(tags, dict):
                ways[i] = (wid, refs, {**tags, "name": "x" * 100_000})


def _hashable(value: Any) -> bool:
    try:
        hash(value)
    except TypeError:
        return False
    return True


def write_source(b: OsmBuilder, fmt: str, path: Path) -> Path:
    """Write a (possibly broken) network as OSM XML, Overpass JSON or GeoJSON, values as
    they are (a wrong type is written as it is, where the format can hold it)."""
    from xml.sax.saxutils import quoteattr

    def text(v: Any) -> str:
        return quoteattr(
            str(v) if not isinstance(v, str) else v.encode("utf-8", "replace").decode()
        )

    if fmt == "osm":
        out = ['<?xml version="1.0" encoding="UTF-8"?>', '<osm version="0.6" generator="fuzz">']
        for nid, (lon, lat, tags) in b.nodes.items():
            out.append(f'<node id={text(nid)} version="1" lat={text(lat)} lon={text(lon)}>')
            if isinstance(tags, dict):
                out += [f"<tag k={text(k)} v={text(v)}/>" for k, v in tags.items()]
            out.append("</node>")
        for wid, refs, tags in b.ways:
            out.append(f'<way id={text(wid)} version="1">')
            out += [f"<nd ref={text(n)}/>" for n in (refs if isinstance(refs, list) else [refs])]
            if isinstance(tags, dict):
                out += [f"<tag k={text(k)} v={text(v)}/>" for k, v in tags.items()]
            out.append("</way>")
        out.append("</osm>")
        path.write_text("\n".join(out), encoding="utf-8")
        return path
    if fmt == "overpass":
        elements: list[Any] = []
        for nid, (lon, lat, tags) in b.nodes.items():
            elements.append(
                {
                    "type": "node",
                    "id": nid,
                    "lat": _json_value(lat),
                    "lon": _json_value(lon),
                    "tags": tags,
                }
            )
        for wid, refs, tags in b.ways:
            elements.append({"type": "way", "id": _json_value(wid), "nodes": refs, "tags": tags})
        path.write_text(
            json.dumps({"version": 0.6, "elements": elements}, allow_nan=True, default=str),
            encoding="utf-8",
            errors="surrogatepass",
        )
        return path
    feats = []
    for wid, refs, tags in b.ways:
        coords = []
        for n in refs if isinstance(refs, list) else []:
            if _hashable(n) and n in b.nodes:
                coords.append([_json_value(b.nodes[n][0]), _json_value(b.nodes[n][1])])
        props = dict(tags) if isinstance(tags, dict) else {"tags": tags}
        feats.append(
            {
                "type": "Feature",
                "geometry": {"type": "LineString", "coordinates": coords},
                "properties": {"osm_id": _json_value(wid), **props},
            }
        )
    for _nid, (lon, lat, tags) in b.nodes.items():
        if isinstance(tags, dict) and tags:
            feats.append(
                {
                    "type": "Feature",
                    "geometry": {
                        "type": "Point",
                        "coordinates": [_json_value(lon), _json_value(lat)],
                    },
                    "properties": tags,
                }
            )
    path.write_text(
        json.dumps({"type": "FeatureCollection", "features": feats}, allow_nan=True, default=str),
        encoding="utf-8",
        errors="surrogatepass",
    )
    return path


def _json_value(v: Any) -> Any:
    """A raw attribute text as JSON would carry it: numbers as numbers where they parse."""
    if isinstance(v, str):
        try:
            return float(v) if len(v) < 400 else v
        except ValueError:
            return v
    return v


def _expected_ways(b: OsmBuilder, fmt: str) -> int | None:
    """How many way elements the reader must account for (None: unknown)."""
    if fmt == "osm":
        keys = ("railway", "railway:switch", "public_transport")
        return sum(
            1 for _, _, tags in b.ways if isinstance(tags, dict) and any(k in tags for k in keys)
        )
    return len(b.ways)


def try_source(b: OsmBuilder, fmt: str, path: Path) -> Outcome:
    """Read a source, build its map, save and load it, check it; account for every way."""
    write_source(b, fmt, path)
    try:
        data = read_source(path)
    except TrackMapError as exc:
        if str(path) not in str(exc):
            return Outcome("exception", f"message does not name the file: {str(exc)[:120]}")
        return Outcome("rejected")
    except Exception as exc:
        return _bare(exc)
    expected = _expected_ways(b, fmt)
    accounted = data.kept_ways + sum(data.dropped.values())
    if expected is not None and accounted != expected:
        return Outcome("silent_loss", f"{expected} ways in the source, {accounted} kept or counted")
    params = {
        "kinds": ["tram"],
        "max_deflection_deg": 35.0,
        "tangent_probe_m": 3.0,
        "parallel_spacing_m": [2.5, 6.0],
        "fouling_clearance_m": 3.2,
        "stop_snap_m": 15.0,
    }
    try:
        net = assemble(data, driving_side="right", params=params)
    except TrackMapError as exc:
        if str(path) not in str(exc):
            return Outcome("exception", f"message does not name the file: {str(exc)[:120]}")
        return Outcome("rejected")
    except Exception as exc:
        return _bare(exc)
    in_map = {w for e in net.edges for w in e.way_ids}
    in_map |= {w for g in net.metadata.source.get("duplicate_ways", []) for w in g}
    missing = {w.way_id for w in data.ways} - in_map
    if missing:
        return Outcome("silent_loss", f"kept ways {sorted(missing)[:5]} are in no edge")
    try:
        saved = net.save(path.with_suffix(".trackmap.geojson"))
    except Exception as exc:
        return _bare(exc)
    try:
        again = trackmap.load(saved)
        check(again)
    except Exception as exc:  # a map the builder wrote must load: a MapFileError is a bug here
        return _bare(exc)
    if again != net:
        return Outcome("silent_loss", "the saved map loads as a different map")
    return Outcome("accepted")
