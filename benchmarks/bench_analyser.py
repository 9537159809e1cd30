"""Cycle cost of the analysers against the paper's rule in numpy, measured in one run.

Run: ``python benchmarks/bench_analyser.py [--quick] [--map FILE]``.

Three uses, each timed as medians over cycles after a warm-up, in one process:

* **control room, clustered**: N trams at random places of the map (weighted by track
  length, permitted direction, speeds 0-15 m/s, 3 m GPS noise), as many wait near the same
  switches; a cycle is ``update()`` for every report, then ``assess()`` for every vehicle;
* **control room, spread**: N trams on simulated routes (:mod:`antikol.sim`), evenly spread;
* **on board**: one own tram and its 32 nearest neighbours; a cycle is ``update()`` for the
  33 reports and ``assess()`` of the own tram.

Each is compared with the paper's sector rule for every ordered pair at once in numpy
(formulas 4-9 broadcast over an N x N matrix: the cheapest honest implementation), and
with the library's ``Analyser()`` without a map (the same rule, vehicle by vehicle).
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable, Sequence

import numpy as np

import trackmap
from antikol import Analyser, ReportedTrackPosition, VehicleReport
from antikol.analysis.geometry import PAPER_EQUATOR_KM, PAPER_KM_PER_DEG_LAT
from antikol.sim import GpsModel, Simulator, fleet


def numpy_all_pairs(lat: np.ndarray, lon: np.ndarray, course: np.ndarray, speed: np.ndarray):
    """The paper's sector rule for every ordered pair: the N x N alarm matrix."""
    north_km = (lat[None, :] - lat[:, None]) * PAPER_KM_PER_DEG_LAT
    km_per_deg_lon = np.cos(np.radians(lat))[:, None] * PAPER_EQUATOR_KM / 360.0
    east_km = (lon[None, :] - lon[:, None]) * km_per_deg_lon
    distance_m = 1000.0 * np.hypot(north_km, east_km)
    bearing = np.degrees(np.arctan2(east_km, north_km)) % 360.0
    off = np.abs((bearing - course[:, None] + 180.0) % 360.0 - 180.0)
    alarm = (distance_m < 300.0) & (off <= 15.0) & (speed[:, None] >= 1.0)
    np.fill_diagonal(alarm, False)
    return alarm


class RandomFleet:
    """Trams at random places of a map, moving along their edges, with GPS noise."""

    def __init__(self, net: trackmap.TrackMap, n: int, seed: int) -> None:
        self.net = net
        self.rng = np.random.default_rng(seed)
        lengths = np.array([e.length_m for e in net.edges])
        self.edges = self.rng.choice(len(lengths), size=n, p=lengths / lengths.sum())
        self.lengths = lengths[self.edges]
        self.offset = self.rng.uniform(0.0, self.lengths)
        self.direction = np.array(
            [1 if net.edges[e].allows(1) else -1 for e in self.edges.tolist()], dtype=float
        )
        self.speed = self.rng.uniform(0.0, 15.0, size=n)

    def cycle(self, t: float, *, reported: bool = False) -> list[VehicleReport]:
        """One report per tram; with ``reported`` each but ``T0`` carries its own track
        position (as on-board units on the same map send it)."""
        self.offset = np.clip(self.offset + self.direction * self.speed, 0.0, self.lengths)
        out = []
        for k, e in enumerate(self.edges.tolist()):
            x, y = self.net.point_at(e, float(self.offset[k]))
            lon, lat = self.net.to_lonlat(x + self.rng.normal(0, 3.0), y + self.rng.normal(0, 3.0))
            course = self.net.heading_at(e, float(self.offset[k]), int(self.direction[k]))
            own = None
            if reported and k > 0:
                own = ReportedTrackPosition(e, float(self.offset[k]), int(self.direction[k]))
            out.append(
                VehicleReport(
                    f"T{k}",
                    t,
                    float(lat),
                    float(lon),
                    float(self.speed[k]),
                    course,
                    track_position=own,
                )
            )
        return out


def spread_fleet(net: trackmap.TrackMap, n: int, seconds: float) -> list[list[VehicleReport]]:
    specs = fleet(net, n, 5, route_length_m=3000.0, headway_s=0.0, min_separation_m=40.0)
    gps = GpsModel(sigma_m=3.0, bias_sigma_m=1.5)
    result = Simulator(net, specs, gps=gps, seed=5).run(seconds)
    by_t: dict[float, list[VehicleReport]] = {}
    for r in result.reports:
        by_t.setdefault(r.t, []).append(r)
    return [by_t[t] for t in sorted(by_t)]


def median_ms(times: Sequence[float]) -> float:
    return 1e3 * statistics.median(times)


def time_control_room(
    make: Callable[[], Analyser], batches: Sequence[list[VehicleReport]], warmup: int
) -> float:
    an = make()
    times = []
    for k, batch in enumerate(batches):
        t0 = time.perf_counter()
        for r in batch:
            an.update(r)
        for r in batch:
            an.assess(r.vehicle_id)
        if k >= warmup:
            times.append(time.perf_counter() - t0)
    return median_ms(times)


def time_numpy(batches: Sequence[list[VehicleReport]], warmup: int) -> float:
    times = []
    for k, batch in enumerate(batches):
        lat = np.array([r.lat for r in batch])
        lon = np.array([r.lon for r in batch])
        course = np.array([r.course_deg for r in batch])
        speed = np.array([r.speed_mps for r in batch])
        t0 = time.perf_counter()
        numpy_all_pairs(lat, lon, course, speed)
        if k >= warmup:
            times.append(time.perf_counter() - t0)
    return median_ms(times)


def on_board_fleet(net: trackmap.TrackMap) -> RandomFleet:
    """Tram ``T0`` of a city of 400 at random places and its 32 nearest neighbours."""
    city = RandomFleet(net, 400, seed=3)
    xy = np.array(
        [net.point_at(int(e), float(o)) for e, o in zip(city.edges, city.offset, strict=True)]
    )
    nearest = np.argsort(np.hypot(*(xy - xy[0]).T))[:33]
    for name in ("edges", "lengths", "offset", "direction", "speed"):
        setattr(city, name, getattr(city, name)[nearest])
    return city


def on_board(
    net: trackmap.TrackMap, cycles: int, warmup: int, *, reported: bool = False
) -> tuple[float, float, float]:
    """(track-aware, sector rule, numpy) ms per on-board cycle: own tram + 32 others
    (with ``reported``, the others send their own track positions)."""
    city = on_board_fleet(net)
    batches = [city.cycle(float(c), reported=reported) for c in range(cycles)]
    out = []
    for make in (lambda: Analyser(track_map=net, own_id="T0"), lambda: Analyser(own_id="T0")):
        an = make()
        times = []
        for k, batch in enumerate(batches):
            t0 = time.perf_counter()
            for r in batch:
                an.update(r)
            an.assess()
            if k >= warmup:
                times.append(time.perf_counter() - t0)
        out.append(median_ms(times))
    out.append(time_numpy(batches, warmup))
    return out[0], out[1], out[2]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer sizes and cycles")
    ap.add_argument("--map", help="OSM extract to build the map from (default: embedded)")
    args = ap.parse_args()
    net = (
        trackmap.build(args.map, kinds=("tram",), driving_side="right")
        if args.map
        else trackmap.load_default()
    )
    sizes = (32, 200) if args.quick else (32, 200, 1000)
    warm, measured = (3, 3) if args.quick else (3, 5)
    print(
        "| traffic | trams | track-aware, ms | `Analyser()` sector, ms | numpy all pairs, ms "
        "| track / numpy | sector / numpy |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|")
    for kind in ("clustered", "spread"):
        for n in sizes:
            if kind == "clustered":
                city = RandomFleet(net, n, seed=1)
                batches = [city.cycle(float(c)) for c in range(warm + measured)]
            else:
                batches = spread_fleet(net, n, 30.0)[-(warm + measured) :]
            track = time_control_room(lambda: Analyser(track_map=net), batches, warm)
            sector = time_control_room(Analyser, batches, warm)
            vec = time_numpy(batches, warm)
            print(
                f"| {kind} | {n:,} | {track:,.1f} | {sector:,.2f} | {vec:,.3f} "
                f"| {track / vec:,.1f}x | {sector / vec:,.1f}x |"
            )
    for reported, label in ((False, "on board, own + 32"), (True, "... others send positions")):
        track, sector, vec = on_board(net, 25 if args.quick else 60, 5, reported=reported)
        print(
            f"| {label} | 33 | {track:,.2f} | {sector:,.3f} | {vec:,.3f} "
            f"| {track / vec:,.1f}x | {sector / vec:,.1f}x |"
        )
    print(f"\n(medians; {math.floor(measured)} measured cycles per size after {warm} warm-up)")


if __name__ == "__main__":
    main()
