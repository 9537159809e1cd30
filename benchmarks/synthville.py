"""Draw "Synthville", a tram network no part of antikol was tuned on, as an OSM extract.

Run: ``python benchmarks/synthville.py [-o synthville.osm] [--untagged-m 400] [--left-hand]``,
then score the library on it with the independent referee, which reads any OSM file:

    python ../shared/referee/run.py --map synthville.osm --analyser track --trams 20 --minutes 10
    python benchmarks/referee_selectivity.py synthville.osm --seed 1

Every figure about the library comes from Kraków, the one city whose data is in the
repository. This map has what Kraków lacks or has little of, drawn the way real OSM
extracts draw it: right-hand running on double track 3.2 m apart (Kraków's is wider), a
terminus loop with tail tracks and a balloon loop (radius 20 m), an S-bend (40 m) and a
sharp corner (25 m) between the buildings, a same-way passing track at a stop (4 m apart
for 80 m), a wye of two T junctions (curves of 25 and 30 m), a diamond crossing of two
lines drawn **without a shared node**, a single-track two-way branch to a stub, buffer
stops, tram stops beside the tracks, and a line **cut by the extract's bounding box**
(its ways name nodes the file does not have). ``--untagged-m`` leaves that much of the
east-west double track without ``oneway`` tags (a common omission; the library infers
right-hand running there, the referee lets trams run both ways on each track); 0 tags
every way. ``--left-hand`` mirrors the whole network east to west, ways and tags as they
are: a left-hand city, whose tagged double track tells the map builder so.

Coordinates are local metres (x east, y north) projected to WGS84 around Helsinki's centre
(a transverse Mercator, :mod:`pyproj`); node and way ids are positive and stable, so the
file is the same at every run.
"""

from __future__ import annotations

import argparse
import itertools
import math
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import pyproj

__all__ = ["Centreline", "OsmDraft", "draw_synthville", "main"]

HALF_SPACING_M = 1.6  # double track 3.2 m between centres
_STRAIGHT_STEP_M = 40.0
_CURVE_STEP_M = 6.0
_CENTRE_LONLAT = (24.94, 60.17)
_CLIP_Y_M = -1000.0  # the extract's south edge: nodes south of it are not in the file
_SNAP_M = 0.05  # points this close are one OSM node (how ways come to share nodes)

Point = tuple[float, float]


@dataclass
class Centreline:
    """A chain of straights and circular arcs, measured by arc length ``s`` (m).

    ``at(s, offset_m)`` is the point ``offset_m`` to the left of the line (negative: to the
    right) and the heading there (radians, counter-clockwise from east).
    """

    x0: float
    y0: float
    heading_rad: float
    pieces: list[tuple[float, float, float, float, float, float]] = field(default_factory=list)
    length_m: float = 0.0

    @classmethod
    def start(cls, x: float, y: float, heading_deg: float) -> Centreline:
        return cls(float(x), float(y), math.radians(heading_deg))

    def _end(self) -> tuple[float, float, float]:
        if not self.pieces:
            return self.x0, self.y0, self.heading_rad
        return self._along(self.pieces[-1], self.pieces[-1][1])

    @staticmethod
    def _along(
        piece: tuple[float, float, float, float, float, float], t: float
    ) -> tuple[float, float, float]:
        _, _, x0, y0, h0, curvature = piece
        if curvature == 0.0:
            return x0 + t * math.cos(h0), y0 + t * math.sin(h0), h0
        h = h0 + curvature * t
        return (
            x0 + (math.sin(h) - math.sin(h0)) / curvature,
            y0 - (math.cos(h) - math.cos(h0)) / curvature,
            h,
        )

    def straight(self, length_m: float) -> Centreline:
        x, y, h = self._end()
        self.pieces.append((self.length_m, float(length_m), x, y, h, 0.0))
        self.length_m += length_m
        return self

    def arc(self, radius_m: float, turn_deg: float) -> Centreline:
        """An arc turning ``turn_deg`` (positive: to the left)."""
        x, y, h = self._end()
        length = radius_m * math.radians(abs(turn_deg))
        self.pieces.append((self.length_m, length, x, y, h, math.copysign(1 / radius_m, turn_deg)))
        self.length_m += length
        return self

    def _piece(self, s: float) -> tuple[float, float, float, float, float, float]:
        for piece in self.pieces:
            if s <= piece[0] + piece[1] + 1e-9:
                return piece
        return self.pieces[-1]

    def at(self, s: float, offset_m: float = 0.0) -> tuple[float, float, float]:
        piece = self._piece(s)
        x, y, h = self._along(piece, s - piece[0])
        return x - offset_m * math.sin(h), y + offset_m * math.cos(h), h

    def point(self, s: float, offset_m: float = 0.0) -> Point:
        x, y, _ = self.at(s, offset_m)
        return x, y

    def locate(self, p: Point) -> tuple[float, float] | None:
        """``(s, offset_m)`` of a point beside a straight piece (within 6 m), else None."""
        for s0, length, x0, y0, h0, curvature in self.pieces:
            if curvature != 0.0:
                continue
            dx, dy = p[0] - x0, p[1] - y0
            t = dx * math.cos(h0) + dy * math.sin(h0)
            offset = -dx * math.sin(h0) + dy * math.cos(h0)
            if -1e-6 <= t <= length + 1e-6 and abs(offset) < 6.0:
                return s0 + t, offset
        return None

    def stations(self, s_from: float = 0.0, s_to: float | None = None, *, forced=()) -> list[float]:
        """Node positions: every piece's ends and ``forced`` ones, straights every 40 m,
        arcs every 6 m."""
        s_to = self.length_m if s_to is None else s_to
        breaks = {s_from, s_to} | {p[0] for p in self.pieces if s_from < p[0] < s_to}
        breaks |= {f for f in forced if s_from < f < s_to}
        ordered = sorted(breaks)
        out = [ordered[0]]
        for a, b in itertools.pairwise(ordered):
            if b - a < 1e-6:
                continue
            step = _CURVE_STEP_M if self._piece((a + b) / 2)[5] else _STRAIGHT_STEP_M
            out += np.linspace(a, b, max(1, math.ceil((b - a) / step)) + 1)[1:].tolist()
        return out


@dataclass
class OsmDraft:
    """Nodes (local metres, tags) and ways; points within 5 cm are one node."""

    nodes: dict[int, tuple[float, float, dict[str, str]]] = field(default_factory=dict)
    ways: list[tuple[int, list[int], dict[str, str]]] = field(default_factory=list)
    _grid: dict[tuple[int, int], list[int]] = field(default_factory=dict)

    def node(self, p: Point, tags: dict[str, str] | None = None, *, shared: bool = True) -> int:
        key = (round(p[0] / _SNAP_M), round(p[1] / _SNAP_M))
        if shared:
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    for nid in self._grid.get((key[0] + dx, key[1] + dy), ()):
                        x, y, old = self.nodes[nid]
                        if math.hypot(x - p[0], y - p[1]) < _SNAP_M:
                            old.update(tags or {})
                            return nid
        nid = len(self.nodes) + 1
        self.nodes[nid] = (p[0], p[1], dict(tags or {}))
        if shared:
            self._grid.setdefault(key, []).append(nid)
        return nid

    def way(self, points: Iterable[Point], tags: dict[str, str]) -> int:
        ids: list[int] = []
        for p in points:
            nid = self.node(p)
            if not ids or ids[-1] != nid:
                ids.append(nid)
        wid = 1000 + len(self.ways) + 1
        self.ways.append((wid, ids, dict(tags)))
        return wid

    def tag_switches(self) -> None:
        """``railway=switch`` where three or more track arms meet."""
        arms: Counter[int] = Counter()
        for _, ids, _ in self.ways:
            for i, nid in enumerate(ids):
                arms[nid] += 1 if i in (0, len(ids) - 1) else 2
        for nid, n in arms.items():
            if n >= 3 and "railway" not in self.nodes[nid][2]:
                self.nodes[nid][2]["railway"] = "switch"

    def mirrored(self) -> OsmDraft:
        """The same network mirrored east to west: right-hand running becomes left-hand
        running, with every way, tag and id as it was (a left-hand city drawn the same
        way)."""
        out = OsmDraft(ways=[(w, list(ids), dict(t)) for w, ids, t in self.ways])
        out.nodes = {n: (-x, y, dict(t)) for n, (x, y, t) in self.nodes.items()}
        return out

    def write_xml(self, path: Path, *, clip_south_m: float = _CLIP_Y_M) -> int:
        """Write OSM XML 0.6 as an extract cut at ``clip_south_m``: nodes south of it are
        left out while the ways still name them. Returns how many were left out."""
        local = pyproj.CRS.from_proj4(
            f"+proj=tmerc +lat_0={_CENTRE_LONLAT[1]} +lon_0={_CENTRE_LONLAT[0]} +k=1 "
            "+x_0=0 +y_0=0 +ellps=WGS84 +units=m +no_defs"
        )
        to_wgs84 = pyproj.Transformer.from_crs(local, "EPSG:4326", always_xy=True)
        kept = {nid: v for nid, v in self.nodes.items() if v[1] >= clip_south_m}
        xs = [v[0] for v in kept.values()]
        ys = [v[1] for v in kept.values()]
        lon, lat = to_wgs84.transform(
            [min(xs) - 30, max(xs) + 30, min(xs) - 30, max(xs) + 30],
            [clip_south_m, clip_south_m, max(ys) + 30, max(ys) + 30],
        )
        out = [
            '<?xml version="1.0" encoding="UTF-8"?>',
            '<osm version="0.6" generator="antikol benchmarks/synthville.py">',
            f'  <bounds minlat="{min(lat):.7f}" minlon="{min(lon):.7f}" '
            f'maxlat="{max(lat):.7f}" maxlon="{max(lon):.7f}"/>',
        ]

        def tag_lines(tags: dict[str, str]) -> list[str]:
            return [f"    <tag k={quoteattr(k)} v={quoteattr(v)}/>" for k, v in tags.items()]

        for nid in sorted(kept):
            x, y, tags = kept[nid]
            nlon, nlat = to_wgs84.transform(x, y)
            head = f'  <node id="{nid}" version="1" lat="{nlat:.7f}" lon="{nlon:.7f}"'
            out += [head + ">", *tag_lines(tags), "  </node>"] if tags else [head + "/>"]
        for wid, ids, tags in self.ways:
            out.append(f'  <way id="{wid}" version="1">')
            out += [f'    <nd ref="{nid}"/>' for nid in ids]
            out += [*tag_lines(tags), "  </way>"]
        out.append("</osm>")
        path.write_text("\n".join(out) + "\n", encoding="utf-8")
        return len(self.nodes) - len(kept)


def _tags(name: str, *, oneway: bool = True) -> dict[str, str]:
    tags = {"railway": "tram", "gauge": "1000", "electrified": "contact_line", "name": name}
    if oneway:
        tags["oneway"] = "yes"
    return tags


def _loop(x: float, y: float, heading_deg: float, radius_m: float = 20.0) -> Centreline:
    """A teardrop turning loop leaving the right-hand track and joining the other one
    (``2 * HALF_SPACING_M`` to its left) heading back: anticlockwise, as right-hand running
    turns."""
    easing_m, alpha = 40.0, math.radians(30.0)
    leg = (
        radius_m * math.cos(alpha) - HALF_SPACING_M - easing_m * (1 - math.cos(alpha))
    ) / math.sin(alpha)
    return (
        Centreline.start(x, y, heading_deg)
        .arc(easing_m, -30.0)
        .straight(leg)
        .arc(radius_m, 240.0)
        .straight(leg)
        .arc(easing_m, -30.0)
    )


def _tee(origin: Point, along: Point) -> list[tuple[Centreline, Point]]:
    """The four turning curves of a T junction whose through line runs along ``along``
    and whose leg leaves to its left: right turns of 25 m, left turns of 30 m (the curve
    and the point it must end at)."""
    u = np.asarray(along, dtype=float)
    v = np.array([-u[1], u[0]])
    o = np.asarray(origin, dtype=float)

    def local(a: float, b: float) -> Point:
        x, y = o + a * u + b * v
        return float(x), float(y)

    def heading(d: np.ndarray) -> float:
        return math.degrees(math.atan2(d[1], d[0]))

    h, right, left = HALF_SPACING_M, 25.0, 30.0
    starts = [  # (start, heading, radius, turn, end)
        (local(right + h, h), heading(-u), right, -90.0, local(h, h + right)),
        (local(-h, h + right), heading(-v), right, -90.0, local(-h - right, h)),
        (local(h - left, -h), heading(u), left, 90.0, local(h, left - h)),
        (local(-h, left - h), heading(-v), left, 90.0, local(left - h, -h)),
    ]
    return [(Centreline.start(*p, hd).arc(r, turn), end) for p, hd, r, turn, end in starts]


def draw_synthville(*, untagged_m: float = 400.0) -> OsmDraft:
    """The network (see the module's docstring).

    Parameters
    ----------
    untagged_m : float, keyword-only
        Length of the east-west double track drawn without ``oneway`` tags, m (0 to 800).
    """
    if not 0.0 <= untagged_m <= 800.0:
        raise ValueError(f"untagged_m={untagged_m!r}: must be within 0..800 m")
    osm = OsmDraft()
    meeting: list[Point] = []  # where a connecting way meets a through track: a shared node
    curves: list[tuple[Centreline, dict[str, str]]] = []

    line_a = (  # east-west, from the terminus loop to the stub end
        Centreline.start(-1330, 0, 0)
        .straight(430)
        .arc(40, 30)
        .arc(40, -30)
        .straight(300)
        .arc(25, 90)
        .straight(130)
        .arc(50, -90)
        .straight(1635)
    )
    line_b = (  # south-north, cut by the extract at its south end, balloon loop north
        Centreline.start(200, -1060, 90).straight(1620).arc(150, 20).arc(150, -20).straight(180)
    )
    y_a = line_a.point(line_a.length_m)[1]

    tail_m = 30.0
    x, y = line_a.point(tail_m, +HALF_SPACING_M)
    loop_a = _loop(x, y, 180.0)
    curves.append((loop_a, _tags("A terminus loop")))
    meeting += [(x, y), loop_a.point(loop_a.length_m)]
    x, y = line_b.point(line_b.length_m, -HALF_SPACING_M)
    curves.append((_loop(x, y, 90.0), _tags("B balloon loop")))

    located = line_a.locate((620.0, y_a))
    assert located is not None
    s_passing = located[0]
    x, y, h = line_a.at(s_passing, -HALF_SPACING_M)
    bend = math.degrees(math.acos(1 - 4.0 / (2 * 60.0)))  # two 60-m reverse curves: 4 m aside
    passing = (
        Centreline.start(x, y, math.degrees(h))
        .arc(60, -bend)
        .arc(60, bend)
        .straight(80)
        .arc(60, bend)
        .arc(60, -bend)
    )
    curves.append((passing, _tags("A passing track")))
    meeting += [(x, y), passing.point(passing.length_m)]

    tee_a, tee_b = (450.0, y_a), (200.0, 450.0)
    for origin, along, name in ((tee_a, (1.0, 0.0), "A"), (tee_b, (0.0, -1.0), "B")):
        for k, (curve, end) in enumerate(_tee(origin, along), 1):
            start = curve.point(0.0)
            got = curve.point(curve.length_m)
            assert math.hypot(got[0] - end[0], got[1] - end[1]) < 1e-6, (name, k)
            curves.append((curve, _tags(f"junction {name} curve {k}")))
            meeting += [start, end]
    x_c = tee_b[0] + 25 + HALF_SPACING_M
    line_c = Centreline.start(x_c, tee_b[1], 0).straight(420 - x_c).arc(30, -90)
    line_c.straight(line_c.point(line_c.length_m)[1] - (y_a + 25 + HALF_SPACING_M))

    located = line_b.locate((200.0, -300.0))
    assert located is not None
    x, y = line_b.point(located[0], -HALF_SPACING_M)
    out_curve = Centreline.start(x, y, 90).arc(30, -90)
    fork = out_curve.point(out_curve.length_m)
    in_curve = Centreline.start(*fork, 180).arc(30 + 2 * HALF_SPACING_M, 90)
    curves += [(out_curve, _tags("branch curve out")), (in_curve, _tags("branch curve in"))]
    meeting += [(x, y), in_curve.point(in_curve.length_m)]
    branch = Centreline.start(*fork, 0).straight(480)

    def double_track(centre: Centreline, pieces: Sequence[tuple[float, float, bool]]) -> None:
        """Both tracks of a double track, split into ways at the pieces' ends (``(s0, s1,
        oneway)``), each with a node wherever a connecting way meets it."""
        for offset, reverse in ((-HALF_SPACING_M, False), (+HALF_SPACING_M, True)):
            forced = [
                loc[0]
                for p in meeting
                if (loc := centre.locate(p)) is not None and abs(loc[1] - offset) < 0.05
            ]
            bounds = sorted({b for s0, s1, _ in pieces for b in (s0, s1)})
            stations = centre.stations(forced=forced + bounds)
            for s0, s1, oneway in pieces:
                pts = [centre.point(s, offset) for s in stations if s0 - 1e-6 <= s <= s1 + 1e-6]
                osm.way(pts[::-1] if reverse else pts, _tags("line", oneway=oneway))

    untagged_from = 450.0
    untagged_to = untagged_from + untagged_m
    double_track(
        line_a,
        [
            (0, untagged_from, True),
            (untagged_from, untagged_to, False),
            (untagged_to, line_a.length_m, True),
        ]
        if untagged_m > 0
        else [(0, line_a.length_m, True)],
    )
    double_track(line_b, [(0, line_b.length_m, True)])
    double_track(line_c, [(0, line_c.length_m, True)])
    for curve, tags in curves:
        osm.way([curve.point(s) for s in curve.stations()], tags)
    osm.way([branch.point(s) for s in branch.stations()], _tags("branch", oneway=False))

    for end in (
        line_a.point(0, -HALF_SPACING_M),
        line_a.point(0, HALF_SPACING_M),
        line_a.point(line_a.length_m, -HALF_SPACING_M),
        line_a.point(line_a.length_m, HALF_SPACING_M),
        branch.point(branch.length_m),
    ):
        osm.node(end, {"railway": "buffer_stop"})

    def stop(centre: Centreline, s: float, offset_m: float, name: str) -> None:
        osm.node(centre.point(s, offset_m), {"railway": "tram_stop", "name": name}, shared=False)

    def s_of(centre: Centreline, p: Point) -> float:
        loc = centre.locate(p)
        assert loc is not None
        return loc[0]

    side = HALF_SPACING_M + 2.0  # a platform beside each track
    passing_mid = s_passing + 70.7
    for centre, s, offset, name in (
        (line_a, 150, -side, "Loop Terminus"),
        (line_a, 170, side, "Loop Terminus"),
        (line_a, s_of(line_a, (-250, y_a)), -side, "Market Square"),
        (line_a, s_of(line_a, (-230, y_a)), side, "Market Square"),
        (line_a, passing_mid - 10, -HALF_SPACING_M - 1.5, "Passing Place"),
        (line_a, passing_mid + 10, -HALF_SPACING_M - 6.0, "Passing Place"),
        (line_a, passing_mid, side, "Passing Place"),
        (line_a, s_of(line_a, (1080, y_a)), -side, "East End"),
        (line_a, s_of(line_a, (1080, y_a)), side, "East End"),
        (line_b, s_of(line_b, (200, -700)), -side, "South Park"),
        (line_b, s_of(line_b, (200, -680)), side, "South Park"),
        (line_b, s_of(line_b, (200, 0)), -side, "Central"),
        (line_b, s_of(line_b, (200, 20)), side, "Central"),
        (line_b, line_b.length_m - 70, -side, "North Loop"),
        (line_b, line_b.length_m - 60, side, "North Loop"),
    ):
        stop(centre, s, offset, name)
    osm.tag_switches()
    return osm


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", type=Path, default=Path("synthville.osm"))
    ap.add_argument(
        "--untagged-m",
        type=float,
        default=400.0,
        help="metres of double track drawn without oneway tags (0: every way tagged)",
    )
    ap.add_argument(
        "--left-hand",
        action="store_true",
        help="mirror the network east to west: left-hand running, ways and tags as they are",
    )
    args = ap.parse_args(argv)
    osm = draw_synthville(untagged_m=args.untagged_m)
    if args.left_hand:
        osm = osm.mirrored()
    cut = osm.write_xml(args.output)
    print(
        f"{args.output}: {len(osm.nodes) - cut} nodes ({cut} beyond the extract's edge), "
        f"{len(osm.ways)} ways"
    )


if __name__ == "__main__":
    main()
