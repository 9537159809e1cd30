"""Tiny OSM fixture writer: nodes in local metres, written as OSM XML, Overpass or GeoJSON."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import quoteattr

from trackmap import LocalFrame

FRAME = LocalFrame.centred_on(19.94, 50.06)


@dataclass
class OsmBuilder:
    nodes: dict[int, tuple[float, float, dict[str, str]]] = field(default_factory=dict)
    ways: list[tuple[int, list[int], dict[str, str]]] = field(default_factory=list)
    next_node: int = 1000
    next_way: int = 1

    def node(self, x: float, y: float, **tags: str) -> int:
        nid = self.next_node
        self.next_node += 1
        lon, lat = FRAME.to_lonlat(x, y)
        self.nodes[nid] = (round(lon, 7), round(lat, 7), dict(tags))
        return nid

    def line(self, pts: list[tuple[float, float]] | list[int], **tags: str) -> int:
        ids = [p if isinstance(p, int) else self.node(*p) for p in pts]
        wid = self.next_way
        self.next_way += 1
        self.ways.append((wid, ids, {"railway": "tram", **tags}))
        return wid

    def arc(
        self, cx: float, cy: float, r: float, a0: float, a1: float, n: int = 12
    ) -> list[tuple[float, float]]:
        """Points on a circle (angles in degrees, math convention)."""
        return [
            (
                cx + r * math.cos(math.radians(a0 + (a1 - a0) * i / n)),
                cy + r * math.sin(math.radians(a0 + (a1 - a0) * i / n)),
            )
            for i in range(n + 1)
        ]

    def write_xml(self, path: Path) -> Path:
        out = ['<?xml version="1.0" encoding="UTF-8"?>', '<osm version="0.6" generator="tests">']
        for nid, (lon, lat, tags) in self.nodes.items():
            if tags:
                out.append(f'  <node id="{nid}" version="1" lat="{lat:.7f}" lon="{lon:.7f}">')
                out += [f"    <tag k={quoteattr(k)} v={quoteattr(v)}/>" for k, v in tags.items()]
                out.append("  </node>")
            else:
                out.append(f'  <node id="{nid}" version="1" lat="{lat:.7f}" lon="{lon:.7f}"/>')
        for wid, ids, tags in self.ways:
            out.append(f'  <way id="{wid}" version="1">')
            out += [f'    <nd ref="{n}"/>' for n in ids]
            out += [f"    <tag k={quoteattr(k)} v={quoteattr(v)}/>" for k, v in tags.items()]
            out.append("  </way>")
        out.append("</osm>")
        path.write_text("\n".join(out), encoding="utf-8")
        return path

    def write_overpass(self, path: Path) -> Path:
        elements = [
            {"type": "node", "id": nid, "lat": lat, "lon": lon, **({"tags": tags} if tags else {})}
            for nid, (lon, lat, tags) in self.nodes.items()
        ]
        elements += [
            {"type": "way", "id": wid, "nodes": ids, "tags": tags} for wid, ids, tags in self.ways
        ]
        path.write_text(json.dumps({"version": 0.6, "elements": elements}), encoding="utf-8")
        return path

    def write_geojson(self, path: Path) -> Path:
        feats = [
            {
                "type": "Feature",
                "geometry": {
                    "type": "LineString",
                    "coordinates": [[self.nodes[n][0], self.nodes[n][1]] for n in ids],
                },
                "properties": {"osm_id": wid, **tags},
            }
            for wid, ids, tags in self.ways
        ]
        path.write_text(
            json.dumps({"type": "FeatureCollection", "features": feats}), encoding="utf-8"
        )
        return path


#: A straight one-way line, south to north, local metres (the positioning tests' track).
STRAIGHT_LINE = [(0.0, -500.0), (0.0, 1500.0)]


def straight_fixture() -> OsmBuilder:
    """One straight one-way track along :data:`STRAIGHT_LINE`."""
    b = OsmBuilder()
    b.line(STRAIGHT_LINE, oneway="yes")
    return b


def switch_fixture() -> OsmBuilder:
    """Trunk from the south, straight branch north, diverging branch curving right."""
    b = OsmBuilder()
    toe = b.node(0, 0)
    b.line([(0, -200), (0, -100), toe], oneway="no")
    b.line([toe, (0, 100), (0, 200)])
    # diverging branch: leaves at ~6 degrees, then turns right on a 50 m radius
    b.line([toe, (1.0, 10.0), (4.0, 20.0), (9.0, 30.0), (30.0, 55.0), (80.0, 80.0)])
    return b


def diamond_fixture(angle_deg: float = 60.0) -> OsmBuilder:
    b = OsmBuilder()
    c = b.node(0, 0)
    b.line([(0, -150), c, (0, 150)])
    a = math.radians(angle_deg)
    b.line([(-150 * math.sin(a), -150 * math.cos(a)), c, (150 * math.sin(a), 150 * math.cos(a))])
    return b
