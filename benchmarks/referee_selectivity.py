"""The referee's track selectivity on another OSM file than its default Kraków extract.

Run: ``python benchmarks/referee_selectivity.py MAP.osm [--seed 1] [--minutes 10] [--trams 12]``
(from the repository root, with ``../shared/referee`` beside it), e.g. on the map that
``python benchmarks/synthville.py`` draws.

``../shared/referee/selectivity.py`` (how often ``Analyser.position`` puts each of its
simulated trams on the right track, on double track and past switches) reads the file
named by its module constant ``DEFAULT_PBF`` and has no option to change it. This script
imports it unchanged, points that constant at ``MAP`` and runs its ``main`` with the
remaining options; nothing of the referee is copied or altered.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

_REFEREE = Path(__file__).resolve().parents[1].parent / "shared" / "referee"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("map", type=Path, help="OSM file (.osm, .osm.pbf)")
    ap.add_argument("--referee", type=Path, default=_REFEREE, help="the referee's folder")
    args, rest = ap.parse_known_args(argv)
    if not args.map.is_file():
        ap.error(f"{args.map}: no such file")
    sys.path.insert(0, str(args.referee))
    import selectivity  # type: ignore[import-not-found]

    selectivity.DEFAULT_PBF = args.map.resolve()
    return int(selectivity.main(rest))


if __name__ == "__main__":
    sys.exit(main())
