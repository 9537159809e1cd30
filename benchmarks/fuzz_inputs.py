"""A long fuzz campaign over every input a user brings: the figures of the README.

Run from the repository root as ``python benchmarks/fuzz_inputs.py [--budget S] [--seed N]``.
For each entry point it feeds broken inputs for ``--budget`` seconds (default 30) and
prints a markdown table of inputs tried and outcomes (see ``tests/_fuzz.py``):

* **accepted** — used, nothing lost (map files load as exactly what they say; sources
  account for every way and build maps that save and load back equal; every untouched
  log row is a report; reports hold exactly the values given; frames decode to their
  report within the wire's resolution);
* **rejected** — the project's own error, naming the file;
* **exceptions** — anything else (a bare exception, or a message that does not name the
  file);
* **silent losses** — accepted, but something vanished or changed without a word.

Entry points: ``trackmap.load`` (+ ``check``) on mutated map files; ``trackmap.build``
(+ save, load, ``check``) on mutated OSM XML, Overpass JSON and GeoJSON; the replay CSV
reader; ``VehicleReport`` on random field values; ``encode_report`` on valid reports with
extreme values. The exit status is 1 when any exception or silent loss was seen.
"""

from __future__ import annotations

import argparse
import logging
import random
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the harness lives with the tests

from tests import _fuzz as F  # noqa: E402
from tests import _fuzz_sources as S  # noqa: E402

_SOURCE_NAMES = {"osm": "s.osm", "overpass": "s.json", "geojson": "s.geojson"}


def _entry_points(tmp: Path) -> dict[str, Callable[[random.Random], F.Outcome | None]]:
    text = F.base_map_text()
    rows = F.csv_rows(200)

    def map_file(rng: random.Random) -> F.Outcome:
        return F.try_map_file(F.mutate_map(text, rng), tmp / "m.trackmap.geojson")

    def source(fmt: str) -> Callable[[random.Random], F.Outcome]:
        return lambda rng: S.try_source(S.mutate_source(rng), fmt, tmp / _SOURCE_NAMES[fmt])

    def csv_log(rng: random.Random) -> F.Outcome:
        data, changed = F.mutate_csv(rows, rng)
        return F.try_csv(data, changed, len(rows), tmp / "log.csv")

    def report(rng: random.Random) -> F.Outcome:
        return F.try_report(F.draw_report_fields(rng))

    def encoder(rng: random.Random) -> F.Outcome | None:
        r = F.draw_encodable_report(rng)
        return None if r is None else F.try_encode(r)

    return {
        "map file: trackmap.load + check": map_file,
        "OSM XML: trackmap.build + save/load + check": source("osm"),
        "Overpass JSON: trackmap.build + save/load + check": source("overpass"),
        "GeoJSON: trackmap.build + save/load + check": source("geojson"),
        "replay CSV: iter_replay_csv": csv_log,
        "report fields: VehicleReport": report,
        "frame encoder: encode_report": encoder,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--budget", type=float, default=30.0, help="seconds per entry point")
    p.add_argument("--seed", type=int, default=2008)
    p.add_argument("--only", default=None, help="run the entry points whose name has this")
    args = p.parse_args(argv)
    logging.disable(logging.CRITICAL)  # the builder warns about every broken input
    tmp = Path(tempfile.mkdtemp(prefix="antikol-fuzz-"))
    rows = []
    failures: dict[str, Counter[str]] = {}
    for name, trial in _entry_points(tmp).items():
        if args.only and args.only.lower() not in name.lower():
            continue
        rng = random.Random(f"{args.seed}:{name}")
        tally = F.Tally(name)
        seen: Counter[str] = Counter()
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < args.budget:
            outcome = trial(rng)
            if outcome is None:
                continue
            tally.add(outcome)
            if outcome.kind in ("exception", "silent_loss"):
                seen[f"{outcome.kind}: {outcome.detail[:160]}"] += 1
        seconds = time.perf_counter() - t0
        c = tally.counts
        rows.append(
            f"| {name} | {tally.tried:,} | {c['accepted']:,} | {c['rejected']:,} | "
            f"{c['exception']:,} | {c['silent_loss']:,} | {seconds:.0f} |"
        )
        failures[name] = seen
        print(f"{name}: {tally.tried:,} inputs, {dict(c)}", file=sys.stderr, flush=True)
    print(
        "| entry point | inputs tried | accepted | rejected (own error) | exceptions | "
        "silent losses | s |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|")
    print("\n".join(rows))
    bad = False
    for name, seen in failures.items():
        if seen:
            bad = True
            print(f"\n{name}:")
            for detail, n in seen.most_common(10):
                print(f"  {n:>6} x {detail}")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
