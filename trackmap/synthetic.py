"""Synthetic track maps drawn in metres: for tests, scenarios and teaching.

:class:`SyntheticNetwork` collects track polylines in a local metric frame (x east, y north)
with OSM-style tags, then builds a :class:`~trackmap.network.TrackMap` through the same
reader and topology code as real OpenStreetMap data. Polylines that share a vertex
(within 1 mm) are joined there.

:func:`demo_network` draws a small network holding every feature the analyser handles:
double track with right-hand running, sharp curves, a single-track section, a merging
junction, diamond crossings, a tunnel and a bridge.
"""

from __future__ import annotations

import json
import math
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from trackmap.builder import build
from trackmap.crs import LocalFrame
from trackmap.network import TrackMap

__all__ = ["Point", "SyntheticNetwork", "arc", "demo_network"]

Point = tuple[float, float]


@dataclass
class SyntheticNetwork:
    """A drawing board for track polylines in metres.

    Parameters
    ----------
    lon0, lat0 : float
        Where the drawing's origin lies on Earth, degrees (default: Gdańsk, where the
        2008 field tests were driven).
    """

    lon0: float = 18.6359
    lat0: float = 54.3902
    lines: list[tuple[list[Point], dict[str, str]]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.frame = LocalFrame.centred_on(self.lon0, self.lat0)

    def track(self, points: Sequence[Point], **tags: str) -> int:
        """Add a track polyline (metres); returns its way id. Tags as in OSM."""
        if len(points) < 2:
            raise ValueError("a track needs at least two points")
        self.lines.append(([(float(x), float(y)) for x, y in points], {"railway": "tram", **tags}))
        return len(self.lines)

    def to_geojson(self) -> dict[str, object]:
        """The drawing as a GeoJSON FeatureCollection in WGS84."""
        feats = []
        for i, (pts, tags) in enumerate(self.lines, start=1):
            coords = []
            for x, y in pts:
                lon, lat = self.frame.to_lonlat(x, y)
                coords.append([round(lon, 9), round(lat, 9)])
            feats.append(
                {
                    "type": "Feature",
                    "geometry": {"type": "LineString", "coordinates": coords},
                    "properties": {"osm_id": i, **tags},
                }
            )
        return {"type": "FeatureCollection", "features": feats}

    def build(self, **build_options: object) -> TrackMap:
        """Build the map (options as for :func:`trackmap.build`)."""
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "synthetic.geojson"
            path.write_text(json.dumps(self.to_geojson()), encoding="utf-8")
            net = build(path, **build_options)  # type: ignore[arg-type]
        net.metadata = replace(
            net.metadata, attribution="synthetic network drawn with trackmap.synthetic"
        )
        return net

    def lonlat(self, x: float, y: float) -> tuple[float, float]:
        """WGS84 (lon, lat) of a drawing point (metres), degrees."""
        lon, lat = self.frame.to_lonlat(x, y)
        return float(lon), float(lat)


def arc(
    cx: float, cy: float, radius_m: float, a0_deg: float, a1_deg: float, n: int = 16
) -> list[Point]:
    """Points on a circular arc (angles counter-clockwise from east, degrees)."""
    return [
        (
            cx + radius_m * math.cos(math.radians(a0_deg + (a1_deg - a0_deg) * k / n)),
            cy + radius_m * math.sin(math.radians(a0_deg + (a1_deg - a0_deg) * k / n)),
        )
        for k in range(n + 1)
    ]


def demo_network() -> SyntheticNetwork:
    """A compact network with every feature the analyser distinguishes (metres).

    * **line A** — east-west double track, 3.8 m apart, right-hand running (eastbound on
      the south track y=0, westbound on y=3.8), from x=-1200 to x=1500, with a short tunnel
      from x=-600 to x=-520;
    * **sharp curves** — at the west end line A turns north on radii of 21.8 m (outer) and
      18 m (inner) and runs on to y=900;
    * **single track** — east of x=1500 the two tracks join at a switch (x=1540) into one
      track used both ways, up to a buffer stop at x=2700;
    * **line B** — north-south double track (southbound x=500, northbound x=503.8) crossing
      line A at grade through four diamond crossings;
    * **a junction curve** — from line B's southbound track (switch at y=25) a 25 m curve
      turns east, cuts across the northbound and westbound tracks without shared nodes
      (at-grade crossings) and merges into line A's eastbound track at a switch (x=525);
    * **a bridge** — a north-south single track on a bridge (layer 1) over line A at
      x=-150, grade-separated.
    """
    n = SyntheticNetwork()
    g = 3.8
    # line A eastbound: from the north, round the outer curve, east to the single track
    eb_curve = arc(-1200.0, 21.8, 21.8, -180.0, -90.0, n=24)
    n.track([(-1221.8, 900.0), *eb_curve, (-600.0, 0.0)], oneway="yes")
    n.track([(-600.0, 0.0), (-520.0, 0.0)], oneway="yes", tunnel="yes", layer="-1")
    n.track(
        [
            (-520.0, 0.0),
            (500.0, 0.0),
            (503.8, 0.0),
            (525.0, 0.0),
            (1500.0, 0.0),
            (1520.0, 0.4),
            (1540.0, 1.9),
        ],
        oneway="yes",
    )
    # line A westbound: from the single track, west, round the inner curve, north
    wb_curve = arc(-1200.0, 21.8, 18.0, -90.0, -180.0, n=24)
    n.track(
        [(1540.0, 1.9), (1520.0, 3.4), (1500.0, g), (503.8, g), (500.0, g), (-520.0, g)],
        oneway="yes",
    )
    n.track([(-520.0, g), (-600.0, g)], oneway="yes", tunnel="yes", layer="-1")
    n.track([(-600.0, g), *wb_curve, (-1218.0, 900.0)], oneway="yes")
    # the single track, both ways
    n.track([(1540.0, 1.9), (2700.0, 1.9)])
    # line B: southbound (west track) with the junction switch, northbound (east track)
    n.track(
        [(500.0, 600.0), (500.0, 25.0), (500.0, g), (500.0, 0.0), (500.0, -600.0)], oneway="yes"
    )
    n.track([(503.8, -600.0), (503.8, 0.0), (503.8, g), (503.8, 600.0)], oneway="yes")
    # junction curve from line B southbound into line A eastbound
    n.track(arc(525.0, 25.0, 25.0, 180.0, 270.0, n=18), oneway="yes")
    # a single track on a bridge over line A
    n.track([(-150.0, -300.0), (-150.0, 300.0)], bridge="yes", layer="1")
    return n
