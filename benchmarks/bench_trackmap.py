"""Speed of :mod:`trackmap` on the Kraków tram network, measured on this machine.

Run as ``python benchmarks/bench_trackmap.py [--quick] [--positions N] [--seed S]``. It
prints a markdown table of:

1. map build time from the OSM PBF shipped in ``maps/`` and from the Overpass JSON in
   ``../shared/data/`` (skipped with a note when absent), and the load time of the
   embedded map file (``trackmap.load``);
2. :meth:`~trackmap.TrackMap.candidates` queries per second, one call per position and
   all positions in one :meth:`~trackmap.TrackMap.candidates_batch` call, at random
   positions near the tracks (uniform along the track, a few metres of GNSS-like noise);
3. :meth:`~trackmap.TrackMap.paths_ahead` calls per second (300 m horizon) with the mean
   number of routes per call, and :meth:`~trackmap.TrackMap.route_distance` calls per
   second between random positions less than 500 m apart (cutoff 1000 m);
4. a peer measured in the same run: a naive planar search, ``shapely.distance`` from the
   query point to every edge (vectorised over the edge array) and a filter on the radius,
   one query at a time, as the baseline of ``candidates()``. It gets local coordinates
   (no WGS84 conversion) and returns distances only (no offset, side or heading).

Each timing is the best of 5 runs after an untimed warm-up run (builds: of 3, cold;
the median is shown alongside); ``--quick``
runs fewer positions and repeats for a smoke test. Ratios above 1 mean trackmap is faster.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import shapely

import trackmap

ROOT = Path(__file__).resolve().parent.parent
PBF = ROOT / "maps" / "krakow-tram-2023-12-14.osm.pbf"
OVERPASS = ROOT.parent / "shared" / "data" / "krakow-tram-2023-12-14.overpass.json"
MAP_FILE = ROOT / "maps" / "krakow-tram.trackmap.geojson"

RADIUS_M = 25.0
HORIZON_M = 300.0
ROUTE_CUTOFF_M = 1000.0
ROUTE_PAIR_MAX_M = 500.0
NOISE_M = 3.0  # standard deviation of the position noise per axis, metres


@dataclass
class Timing:
    best_s: float
    median_s: float
    runs: int


def measure(fn: Callable[[], Any], repeats: int, *, warmup: bool = True) -> tuple[Timing, Any]:
    """Run ``fn`` ``repeats`` times; the best and median wall time and the last result.

    With ``warmup`` one untimed run comes first (caches, lazy imports, allocator).
    """
    times = []
    result: Any = fn() if warmup else None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return Timing(min(times), statistics.median(times), repeats), result


# -- workload -----------------------------------------------------------------------------
@dataclass
class Positions:
    edge_id: np.ndarray
    offset_m: np.ndarray
    x: np.ndarray  # noisy local position, metres
    y: np.ndarray
    lon: np.ndarray
    lat: np.ndarray


def random_positions(net: trackmap.TrackMap, n: int, rng: np.random.Generator) -> Positions:
    """Positions uniform along the track (edges drawn by length) plus Gaussian noise."""
    lengths = np.array([e.length_m for e in net.edges])
    edge_id = rng.choice(len(lengths), size=n, p=lengths / lengths.sum())
    offset = rng.uniform(0.0, lengths[edge_id])
    tx, ty = net.points_at(edge_id, offset)
    x = tx + rng.normal(0.0, NOISE_M, n)
    y = ty + rng.normal(0.0, NOISE_M, n)
    lon, lat = net.to_lonlat(x, y)
    return Positions(edge_id, offset, x, y, np.asarray(lon), np.asarray(lat))


def route_pairs(
    net: trackmap.TrackMap, pos: Positions, rng: np.random.Generator
) -> list[tuple[int, float, int, int, float]]:
    """(from_edge, from_offset, direction, to_edge, to_offset) with targets < 500 m away."""
    geoms = np.array([e.geometry for e in net.edges], dtype=object)
    tree = shapely.STRtree(geoms)
    out = []
    for k in range(len(pos.edge_id)):
        e = int(pos.edge_id[k])
        sx, sy = net.point_at(e, float(pos.offset_m[k]))
        near = tree.query(shapely.Point(sx, sy), predicate="dwithin", distance=ROUTE_PAIR_MAX_M)
        target = int(rng.choice(near))
        direction = net.edges[e].direction or 1
        out.append(
            (
                e,
                float(pos.offset_m[k]),
                direction,
                target,
                float(rng.uniform(0.0, net.edges[target].length_m)),
            )
        )
    return out


# -- peer ---------------------------------------------------------------------------------
def naive_candidates(
    geoms: np.ndarray, x: float, y: float, radius_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Edges within ``radius_m`` of a local point, nearest first: distance to every edge."""
    d = shapely.distance(shapely.Point(x, y), geoms)
    idx = np.flatnonzero(d <= radius_m)
    order = np.argsort(d[idx], kind="stable")
    return idx[order], d[idx][order]


# -- report -------------------------------------------------------------------------------
class Table:
    def __init__(self) -> None:
        self.rows: list[tuple[str, str, str, str]] = []

    def add(self, what: str, value: str, median: str = "", note: str = "") -> None:
        self.rows.append((what, value, median, note))

    def render(self) -> str:
        head = ("Measurement", "Best", "Median", "Notes")
        lines = [
            "| " + " | ".join(head) + " |",
            "|" + "|".join(["---", "---:", "---:", "---"]) + "|",
        ]
        lines += ["| " + " | ".join(r) + " |" for r in self.rows]
        return "\n".join(lines)


def fmt_s(seconds: float) -> str:
    return f"{seconds * 1000:.0f} ms" if seconds >= 0.01 else f"{seconds * 1000:.2f} ms"


def fmt_rate(n: int, seconds: float) -> str:
    rate = n / seconds
    return f"{rate:,.0f} /s" if rate >= 100 else f"{rate:,.1f} /s"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer positions and repeats")
    parser.add_argument("--positions", type=int, default=None, help="query positions")
    parser.add_argument("--seed", type=int, default=2023)
    args = parser.parse_args(argv)
    n = args.positions or (300 if args.quick else 2000)
    repeats = 2 if args.quick else 5
    build_repeats = 1 if args.quick else 3
    rng = np.random.default_rng(args.seed)
    table = Table()

    # 1. build and load
    t, net_pbf = measure(lambda: trackmap.build(PBF, progress=False), build_repeats, warmup=False)
    table.add(
        "build from OSM PBF",
        fmt_s(t.best_s),
        fmt_s(t.median_s),
        f"{PBF.name} ({PBF.stat().st_size / 1e3:.0f} kB) → {len(net_pbf.edges)} edges",
    )
    if OVERPASS.is_file():
        t, net_op = measure(
            lambda: trackmap.build(OVERPASS, progress=False), build_repeats, warmup=False
        )
        same = "same map as PBF" if net_op == net_pbf else "DIFFERS from the PBF map"
        table.add(
            "build from Overpass JSON",
            fmt_s(t.best_s),
            fmt_s(t.median_s),
            f"{OVERPASS.name} ({OVERPASS.stat().st_size / 1e6:.1f} MB); {same}",
        )
    else:
        table.add("build from Overpass JSON", "skipped", "", f"{OVERPASS} not present")
    t, net = measure(lambda: trackmap.load(MAP_FILE), repeats)
    same = "same map as PBF build" if net == net_pbf else "DIFFERS from a fresh PBF build"
    table.add(
        "load map file (`trackmap.load`)",
        fmt_s(t.best_s),
        fmt_s(t.median_s),
        f"{MAP_FILE.name} ({MAP_FILE.stat().st_size / 1e6:.1f} MB); {same}",
    )

    # 2. candidates
    pos = random_positions(net, n, rng)
    lons = pos.lon.tolist()
    lats = pos.lat.tolist()
    xs = pos.x.tolist()
    ys = pos.y.tolist()

    def single() -> list[list[trackmap.Candidate]]:
        return [net.candidates(lo, la, RADIUS_M) for lo, la in zip(lons, lats, strict=True)]

    def single_xy() -> list[list[trackmap.Candidate]]:
        return [net.candidates_xy(x, y, RADIUS_M) for x, y in zip(xs, ys, strict=True)]

    t_single, res_single = measure(single, repeats)
    t_xy, _ = measure(single_xy, repeats)
    t_batch, batch = measure(lambda: net.candidates_batch(pos.lon, pos.lat, RADIUS_M), repeats)
    n_cands = sum(len(c) for c in res_single)
    empty = sum(1 for c in res_single if not c)
    true_first = sum(
        1 for c, e in zip(res_single, pos.edge_id.tolist(), strict=True) if c and c[0].edge_id == e
    )
    agree = len(batch) == n_cands
    table.add(
        f"`candidates()` single calls, {n} positions",
        fmt_rate(n, t_single.best_s),
        fmt_rate(n, t_single.median_s),
        f"r = {RADIUS_M:g} m, noise σ = {NOISE_M:g} m/axis; {n_cands / n:.2f} candidates/query, "
        f"{empty} with none, true edge nearest in {100 * true_first / n:.1f} %",
    )
    table.add(
        "`candidates_xy()` single calls (no WGS84 conversion)",
        fmt_rate(n, t_xy.best_s),
        fmt_rate(n, t_xy.median_s),
        "",
    )
    table.add(
        "`candidates_batch()` one call",
        fmt_rate(n, t_batch.best_s),
        fmt_rate(n, t_batch.median_s),
        f"{fmt_s(t_batch.best_s)} per call; same rows as single calls: {'yes' if agree else 'NO'}",
    )
    table.add(
        "ratio batched / single",
        f"{t_single.best_s / t_batch.best_s:.1f}×",
        f"{t_single.median_s / t_batch.median_s:.1f}×",
        "queries per second",
    )

    # 4. the peer: naive planar search over all edges
    geoms = np.array([e.geometry for e in net.edges], dtype=object)

    def naive() -> list[tuple[np.ndarray, np.ndarray]]:
        return [naive_candidates(geoms, x, y, RADIUS_M) for x, y in zip(xs, ys, strict=True)]

    t_naive, res_naive = measure(naive, repeats)
    same_sets = sum(
        1
        for c, (idx, _) in zip(res_single, res_naive, strict=True)
        if sorted(k.edge_id for k in c) == sorted(idx.tolist())
    )
    table.add(
        f"peer: naive `shapely.distance` to all {len(geoms)} edges, per query",
        fmt_rate(n, t_naive.best_s),
        fmt_rate(n, t_naive.median_s),
        f"local x/y in, distances out; same edge sets as candidates() for {same_sets}/{n}",
    )
    table.add(
        "ratio `candidates()` / naive peer",
        f"{t_naive.best_s / t_single.best_s:.1f}×",
        f"{t_naive.median_s / t_single.median_s:.1f}×",
        f"`candidates_xy()` / peer: {t_naive.best_s / t_xy.best_s:.1f}×; "
        f"`candidates_batch()` / peer: {t_naive.best_s / t_batch.best_s:.0f}×",
    )

    # 3. routing
    starts = random_positions(net, n, rng)
    jobs = [
        (int(e), float(o), net.edges[int(e)].direction or 1)
        for e, o in zip(starts.edge_id, starts.offset_m, strict=True)
    ]

    def ahead() -> list[list[trackmap.Path]]:
        return [net.paths_ahead(e, o, d, HORIZON_M) for e, o, d in jobs]

    t_paths, res_paths = measure(ahead, repeats)
    counts = np.array([len(p) for p in res_paths])
    ends: dict[str, int] = {}
    for plist in res_paths:
        for p in plist:
            ends[p.end] = ends.get(p.end, 0) + 1
    table.add(
        f"`paths_ahead()` {HORIZON_M:g} m, {n} positions",
        fmt_rate(n, t_paths.best_s),
        fmt_rate(n, t_paths.median_s),
        f"{counts.mean():.2f} paths/call (max {counts.max()}); path ends: "
        + ", ".join(f"{k} {v}" for k, v in sorted(ends.items())),
    )

    pairs = route_pairs(net, starts, rng)

    def routes() -> list[trackmap.RouteDistance | None]:
        return [net.route_distance(*p, cutoff_m=ROUTE_CUTOFF_M) for p in pairs]

    t_route, res_route = measure(routes, repeats)
    found = [r for r in res_route if r is not None]
    mean_d = float(np.mean([r.distance_m for r in found])) if found else float("nan")
    table.add(
        f"`route_distance()` cutoff {ROUTE_CUTOFF_M:g} m, {n} pairs",
        fmt_rate(n, t_route.best_s),
        fmt_rate(n, t_route.median_s),
        f"targets < {ROUTE_PAIR_MAX_M:g} m apart; reachable {len(found)}/{n}, "
        f"mean {mean_d:.0f} m along track",
    )

    print(
        f"trackmap {trackmap.__version__} on {net!r}\n"
        f"Python {platform.python_version()}, shapely {shapely.__version__}, "
        f"numpy {np.__version__}, {platform.machine()} ({platform.processor() or 'cpu'}); "
        f"best of {repeats} (builds: {build_repeats}), seed {args.seed}\n"
    )
    print(table.render())
    return 0


if __name__ == "__main__":
    sys.exit(main())
