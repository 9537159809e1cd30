"""Matching throughput and accuracy of track-selective positioning, with a peer.

Run: ``python benchmarks/bench_positioning.py [--quick]``. Needs the ``peers`` extra
(``pip install -e '.[peers]'``) for leuvenmapmatching; without it that row is skipped.

Measures on the embedded Kraków map and simulated traces (GPS sigma 3 m + 1.5 m bias,
1 Hz, 10 % missing):

1. fleet throughput: fixes per second when 1,000 trams are updated once per cycle with
   ``Positioner.update_many`` (one vectorised candidate search per cycle);
2. single-vehicle throughput: ``Positioner.update`` one fix at a time;
3. the peer leuvenmapmatching (DistanceMatcher, Newson & Krumm style HMM, offline over a
   whole trace) on the same map and the same single-vehicle traces: throughput and the
   fraction of fixes placed on the right track, against ours.
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import time

import numpy as np

import trackmap
from antikol.positioning.matcher import Positioner
from antikol.sim import GpsModel, Simulator, fleet

GPS = GpsModel(sigma_m=3.0, bias_sigma_m=1.5, bias_tau_s=60.0, missing_rate=0.10)


def fleet_throughput(net: trackmap.TrackMap, n: int, seconds: float) -> tuple[float, int]:
    specs = fleet(net, n, 11, route_length_m=3000.0, headway_s=0.0, min_separation_m=50.0)
    result = Simulator(net, specs, gps=GPS, seed=11).run(seconds)
    by_t: dict[float, list] = {}
    for r in result.reports:
        by_t.setdefault(r.t, []).append(r)
    pos = Positioner(net)
    times = sorted(by_t)
    for t in times[:5]:  # warm up: first fixes initialise the filters
        pos.update_many(by_t[t])
    fixes = 0
    t0 = time.perf_counter()
    for t in times[5:]:
        pos.update_many(by_t[t])
        fixes += len(by_t[t])
    return fixes / (time.perf_counter() - t0), fixes


def single_traces(net: trackmap.TrackMap, n: int, seconds: float):
    specs = fleet(net, n, 21)
    return Simulator(net, specs, gps=GPS, seed=21, default_speed_mps=70 / 3.6).run(seconds)


def ours(net, result) -> tuple[float, float]:
    specs = {s.vehicle_id: s for s in result.specs}
    correct = total = 0
    elapsed = 0.0
    for vid in result.truth:
        reports = result.reports_of(vid)
        pos = Positioner(net)
        t0 = time.perf_counter()
        estimates = [pos.update(r) for r in reports]
        elapsed += time.perf_counter() - t0
        for r, est in zip(reports, estimates, strict=True):
            total += 1
            correct += _right_track(specs[vid], result.truth[vid], r.t, est.edge_id, est.offset_m)
    return total / elapsed, correct / total


def _right_track(spec, truth, t, edge_id, offset_m, tol_m: float = 8.0) -> bool:
    if edge_id is None:
        return False
    i = truth.index_at(t)
    s_ant = float(truth.distance_m[i]) - spec.antenna_m
    # (behind the start of the route, in its first metres: a negative distance)
    d = spec.route.distance_of(edge_id, offset_m, after_m=s_ant - 50.0)
    return d is not None and abs(d - s_ant) <= tol_m


def leuven(net, result) -> tuple[float, float] | None:
    try:
        from leuvenmapmatching.map.inmem import InMemMap
        from leuvenmapmatching.matcher.distance import DistanceMatcher
    except ImportError:
        return None
    graph = InMemMap("krakow", use_latlon=False, use_rtree=True, index_edges=True)
    vertex: dict[tuple[float, float], int] = {}
    seg_edge: dict[tuple[int, int], tuple[int, np.ndarray]] = {}

    def vid_of(x: float, y: float) -> int:
        key = (round(x, 3), round(y, 3))
        if key not in vertex:
            vertex[key] = len(vertex)
            graph.add_node(vertex[key], key)
        return vertex[key]

    for e in net.edges:
        xy = list(e.geometry.coords)
        ids = [vid_of(x, y) for x, y in xy]
        cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(np.array(xy), axis=0).T))])
        for k, (a, b) in enumerate(itertools.pairwise(ids)):
            if e.direction in (0, 1):
                graph.add_edge(a, b)
                seg_edge[(a, b)] = (e.edge_id, cum[k : k + 2])
            if e.direction in (0, -1):
                graph.add_edge(b, a)
                seg_edge[(b, a)] = (e.edge_id, cum[k : k + 2][::-1])
    specs = {s.vehicle_id: s for s in result.specs}
    correct = total = 0
    elapsed = 0.0
    for vid in result.truth:
        reports = result.reports_of(vid)
        xs, ys = net.to_local(
            np.array([r.lon for r in reports]), np.array([r.lat for r in reports])
        )
        path = list(zip(xs.tolist(), ys.tolist(), strict=True))
        matcher = DistanceMatcher(
            graph,
            max_dist=40.0,
            obs_noise=4.0,
            obs_noise_ne=6.0,
            dist_noise=6.0,
            non_emitting_states=True,
            max_lattice_width=8,
        )
        t0 = time.perf_counter()
        matcher.match(path)
        elapsed += time.perf_counter() - t0
        matches = matcher.lattice_best
        for k, r in enumerate(reports):
            total += 1
            if k >= len(matches):
                continue
            m = matches[k]
            key = (m.edge_m.l1, m.edge_m.l2)
            if key not in seg_edge:
                continue
            edge_id, (c0, c1) = seg_edge[key]
            offset = float(c0 + (c1 - c0) * m.edge_m.ti)
            correct += _right_track(specs[vid], result.truth[vid], r.t, edge_id, offset)
    return total / elapsed, correct / total


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    net = trackmap.load_default()
    n_fleet = 200 if args.quick else 1000
    rates = [fleet_throughput(net, n_fleet, 40.0 if args.quick else 60.0)[0] for _ in range(2)]
    traces = single_traces(net, 2 if args.quick else 5, 300.0 if args.quick else 600.0)
    our_rate, our_acc = ours(net, traces)
    peer = leuven(net, traces)
    print("| measurement | fixes/s | right track |")
    print("|---|---:|---:|")
    print(
        f"| ours, fleet of {n_fleet} per cycle (update_many) | {statistics.median(rates):,.0f} | |"
    )
    print(f"| ours, one vehicle (update) | {our_rate:,.0f} | {our_acc:.1%} |")
    if peer is None:
        print("| leuvenmapmatching | not installed (pip install -e '.[peers]') | |")
    else:
        print(
            f"| peer leuvenmapmatching DistanceMatcher, offline | {peer[0]:,.0f} | {peer[1]:.1%} |"
        )
        print(f"\nours / peer throughput: {our_rate / peer[0]:.1f}x")


if __name__ == "__main__":
    main()
