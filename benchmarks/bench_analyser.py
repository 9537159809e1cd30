"""One analysis cycle for a fleet: the sector rule against the track-aware analyser.

Run: ``python benchmarks/bench_analyser.py [--quick]``.

A cycle is what a control room (or, for 32 vehicles, an on-board unit seeing 32 others)
does every second: feed one report per vehicle, then assess every vehicle. Both analysers
run on the same simulated Kraków traffic in the same process; the table gives the median
cycle time over several cycles after a warm-up, and the ratio track / sector.
"""

from __future__ import annotations

import argparse
import statistics
import time

import trackmap
from antikol.analysis.analyser import Analyser
from antikol.sim import GpsModel, Simulator, fleet


def cycles(net: trackmap.TrackMap, n: int, seconds: float) -> list[list]:
    specs = fleet(net, n, 5, route_length_m=3000.0, headway_s=0.0, min_separation_m=40.0)
    result = Simulator(net, specs, gps=GpsModel(sigma_m=3.0, bias_sigma_m=1.5), seed=5).run(seconds)
    by_t: dict[float, list] = {}
    for r in result.reports:
        by_t.setdefault(r.t, []).append(r)
    return [by_t[t] for t in sorted(by_t)]


def time_cycles(make, batches, warmup: int, measured: int) -> float:
    an = make()
    for batch in batches[:warmup]:
        an.update_many(batch)
        an.assess_all(t=batch[0].t)
    times = []
    for batch in batches[warmup : warmup + measured]:
        t0 = time.perf_counter()
        an.update_many(batch)
        an.assess_all(t=batch[0].t)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    net = trackmap.load_default()
    print("| vehicles | sector rule, ms/cycle | track-aware, ms/cycle | track / sector |")
    print("|---:|---:|---:|---:|")
    for n in (32, 200) if args.quick else (32, 1000):
        batches = cycles(net, n, 30.0 if args.quick else 40.0)
        warm, meas = (10, 5) if args.quick else (20, 10)
        sector = time_cycles(lambda: Analyser(), batches, warm, meas)
        track = time_cycles(lambda: Analyser(track_map=net), batches, warm, meas)
        print(f"| {n} | {1e3 * sector:,.1f} | {1e3 * track:,.1f} | {track / sector:.1f}x |")


if __name__ == "__main__":
    main()
