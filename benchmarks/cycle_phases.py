"""Where an analysis cycle's time goes, phase by phase, against the paper's rule in numpy.

Run: ``python benchmarks/cycle_phases.py [--quick]``.

The speed targets of the control-room issue are ratios to the paper's sector rule for all
pairs at once in numpy. This benchmark splits the cycles of ``bench_analyser.py`` into
their phases, so that each phase can be set against the whole budget of a target:

* **on board** (own tram and its 32 nearest neighbours, the others' GPS matched to the
  map): the table updates, positioning (the matcher's batch of the cycle), the views
  (paths ahead of every vehicle in reach), the pair evaluation and the rest of the own
  assessment (threats, alarms); and, beside the cycle, the matcher's cost for a batch of
  one fix, which every cycle pays at least once;
* **control room, 1000 clustered trams** (random places, many waiting near the same
  switches): the same phases, the later assessments of the cycle, and the rows of the pair
  evaluation (ways through conflict points paired at each point, and links of paths to
  those pairs);
* **``Analyser()`` without a map, 32 trams**: the updates, the first ``assess()`` (the
  array evaluation and every vehicle's assessment) and the look-ups of the others.

The phases are timed by wrapping the analyser's stages for the run (the stages themselves
are not changed); medians over cycles after a warm-up.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import defaultdict
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from bench_analyser import RandomFleet, on_board_fleet, time_numpy

import antikol.analysis.analyser as analyser_module
import antikol.analysis.pairs as pairs_module
import trackmap
from antikol import Analyser, VehicleReport
from antikol.positioning import Positioner


class Phases:
    """Seconds spent in wrapped stages during one cycle, and sizes they reported."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)
        self.sizes: dict[str, list[int]] = defaultdict(list)

    def reset(self) -> None:
        self.seconds.clear()
        self.sizes.clear()


@contextmanager
def wrapped(
    owner: Any,
    name: str,
    phases: Phases,
    *,
    phase: str | None = None,
    size: tuple[str, Callable[[Any], int]] | None = None,
) -> Iterator[None]:
    """While the block runs, time every call of ``owner.name`` as ``phase`` and/or record
    ``size[1](result)`` under ``size[0]``."""
    original = getattr(owner, name)

    def instrumented(*args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        try:
            out = original(*args, **kwargs)
        finally:
            if phase is not None:
                phases.seconds[phase] += time.perf_counter() - t0
        if size is not None:
            phases.sizes[size[0]].append(size[1](out))
        return out

    setattr(owner, name, instrumented)
    try:
        yield
    finally:
        setattr(owner, name, original)


def run_cycles(
    an: Analyser,
    batches: Sequence[list[VehicleReport]],
    warmup: int,
    phases: Phases,
    assess: Callable[[Analyser, list[VehicleReport]], None],
) -> dict[str, float]:
    """Median ms of every phase over the cycles after ``warmup``."""
    per_phase: dict[str, list[float]] = defaultdict(list)
    for k, batch in enumerate(batches):
        phases.reset()
        t0 = time.perf_counter()
        for r in batch:
            an.update(r)
        t1 = time.perf_counter()
        assess(an, batch)
        t2 = time.perf_counter()
        if k < warmup:
            continue
        inner = dict(phases.seconds)
        per_phase["cycle"].append(t2 - t0)
        per_phase["updates"].append(t1 - t0)
        for name, seconds in inner.items():
            per_phase[name].append(seconds)
        per_phase["rest of the assessments"].append(t2 - t1 - sum(inner.values()))
        for name, sizes in phases.sizes.items():
            per_phase[name].append(float(sum(sizes)))
    return {
        name: statistics.median(v) * (1.0 if name == "expanded rows" else 1e3)
        for name, v in per_phase.items()
    }


def _rows(expanded: tuple[Any, ...]) -> int:
    return len(expanded[0])


def track_phases(
    net: trackmap.TrackMap,
    batches: Sequence[list[VehicleReport]],
    warmup: int,
    *,
    own_id: str | None,
) -> dict[str, float]:
    phases = Phases()
    an = Analyser(track_map=net, own_id=own_id)

    def assess(an: Analyser, batch: list[VehicleReport]) -> None:
        if own_id is not None:
            an.assess()
            return
        for r in batch:
            an.assess(r.vehicle_id)

    with (
        wrapped(analyser_module.Analyser, "_flush", phases, phase="positioning"),
        wrapped(analyser_module, "build_views", phases, phase="views (paths ahead)"),
        wrapped(pairs_module.PairEvaluator, "evaluate", phases, phase="pair evaluation"),
        wrapped(pairs_module, "expand_rows", phases, size=("expanded rows", _rows)),
    ):
        return run_cycles(an, batches, warmup, phases, assess)


def sector_phases(batches: Sequence[list[VehicleReport]], warmup: int) -> dict[str, float]:
    phases = Phases()

    def assess(an: Analyser, batch: list[VehicleReport]) -> None:
        for r in batch:
            an.assess(r.vehicle_id)

    name = "array evaluation and every assessment (first assess)"
    with wrapped(analyser_module.Analyser, "_assess_sector_fleet", phases, phase=name):
        return run_cycles(Analyser(), batches, warmup, phases, assess)


def one_fix_ms(net: trackmap.TrackMap, batches: Sequence[list[VehicleReport]]) -> float:
    """The matcher's cost for a batch of one fix (the own tram alone), ms."""
    positioner = Positioner(net)
    times = []
    for k, batch in enumerate(batches):
        t0 = time.perf_counter()
        positioner.update_many(batch[:1], outputs=False)
        if k >= 5:
            times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def print_table(title: str, phases: dict[str, float], numpy_rule_ms: float) -> None:
    print(f"\n{title} (paper's rule in numpy: {numpy_rule_ms:.3f} ms)\n")
    print("| phase | ms | x numpy rule | share of the cycle |")
    print("|---|---:|---:|---:|")
    cycle = phases["cycle"]
    for name, value in phases.items():
        if name == "expanded rows":
            continue
        print(
            f"| {name} | {value:,.3f} | {value / numpy_rule_ms:,.1f}x "
            f"| {100 * value / cycle:.0f} % |"
        )
    if "expanded rows" in phases:
        print(f"\npair evaluation rows expanded per cycle: {phases['expanded rows']:,.0f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer cycles, 300 trams")
    args = ap.parse_args()
    net = trackmap.load_default()
    warm = 3
    city = on_board_fleet(net)
    board = [city.cycle(float(c)) for c in range(25 if args.quick else 60)]
    phases = track_phases(net, board, warm, own_id="T0")
    phases["matcher, a batch of one fix (beside the cycle)"] = one_fix_ms(net, board)
    print_table("On board: own tram + 32, track-aware", phases, time_numpy(board, warm))

    n = 300 if args.quick else 1000
    clustered = RandomFleet(net, n, seed=1)
    batches = [clustered.cycle(float(c)) for c in range(warm + (3 if args.quick else 5))]
    print_table(
        f"Control room: {n:,} clustered trams, track-aware",
        track_phases(net, batches, warm, own_id=None),
        time_numpy(batches, warm),
    )

    small = RandomFleet(net, 32, seed=1)
    batches = [small.cycle(float(c)) for c in range(warm + (30 if args.quick else 100))]
    print_table("Control room: 32 trams, Analyser() without a map", sector_phases(batches, warm),
                time_numpy(batches, warm))  # fmt: skip
    print(f"\n(medians over the cycles after {warm} warm-up cycles)")


if __name__ == "__main__":
    main()
