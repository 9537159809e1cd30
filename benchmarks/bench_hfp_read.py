"""Reading an HSL HFP archive: time and peak memory of ``read_hfp`` per vehicle position.

Run: ``python benchmarks/bench_hfp_read.py [--positions 600000] [--form jsonl|csv|csv.zst]
[--streamed | --replay]`` (``csv.zst`` needs the ``feeds`` extra).

Writes an archive of ``--positions`` vehicle positions of 200 trams (HSL's MQTT payload
fields, one message per line, or the raw dumps' camelCase CSV), then reads it in a fresh
process (``python -c``), so that the peak resident memory (``VmHWM``) is the reader's
alone: the file's bytes, the records sorted by time (in runs of 200,000, on disk past
one run) and the reports. ``--streamed`` reads it as ``antikol replay`` does
(:class:`~antikol.ingest.feed_stream.StreamedFeed`: the sorted runs, a checking pass and
one pass over the reports, none of them held); ``--replay`` runs the whole
``antikol replay --map none`` over it.
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import tempfile
from pathlib import Path

_READ = """
import json, sys, time
from pathlib import Path
from antikol.ingest.feed_stream import StreamedFeed
from antikol.ingest.hfp import read_hfp
t0 = time.perf_counter()
if sys.argv[2] == "replay":  # the whole command: reading, the analyser, the events CSV
    import contextlib, io
    from antikol.cli import main
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        main(["replay", sys.argv[1], "-o", sys.argv[1] + ".events.csv", "--map", "none"])
    reports = problems = 0
elif sys.argv[2] == "streamed":
    with StreamedFeed(sys.argv[1], log_format="hfp") as feed:
        reports, problems = sum(1 for _ in feed.reports), len(feed.problems)
else:
    log = read_hfp(sys.argv[1])
    reports, problems = len(log.reports), len(log.problems)
seconds = time.perf_counter() - t0
peak_kb = next(int(line.split()[1]) for line in Path("/proc/self/status").read_text()
               .splitlines() if line.startswith("VmHWM:"))
print(json.dumps({"reports": reports, "problems": problems,
                  "seconds": seconds, "peak_mb": peak_kb / 1024}))
"""

_BASELINE = """
import json
from pathlib import Path
import antikol.ingest.hfp
peak_kb = next(int(line.split()[1]) for line in Path("/proc/self/status").read_text()
               .splitlines() if line.startswith("VmHWM:"))
print(json.dumps({"peak_mb": peak_kb / 1024}))
"""


def _position(k: int, trams: int) -> dict[str, object]:
    vehicle, second = k % trams, k // trams
    minute, s = divmod(second, 60)
    hour, minute = divmod(minute, 60)
    return {
        "desi": "6",
        "dir": "1",
        "oper": 40,
        "veh": vehicle,
        "tst": f"2023-05-02T{7 + hour:02d}:{minute:02d}:{s:02d}.{k % 1000:03d}Z",
        "tsi": 1683010800 + second,
        "spd": 8.2,
        "hdg": 91,
        "lat": round(60.17 + vehicle * 1e-3, 6),
        "long": round(24.94 + second * 1e-5, 6),
        "acc": 0.1,
        "dl": -20,
        "odo": 1000 + second * 8,
        "drst": 0,
        "oday": "2023-05-02",
        "jrn": 123,
        "line": 33,
        "start": "09:55",
        "loc": "GPS",
        "stop": None,
        "route": "1006",
        "occu": 0,
    }


def write_archive(path: Path, positions: int, form: str, trams: int = 200) -> Path:
    """An archive of ``positions`` HFP vehicle positions in ``form``."""
    if form == "jsonl":
        with path.open("w") as fh:
            for k in range(positions):
                fh.write(json.dumps({"VP": _position(k, trams)}) + "\n")
        return path
    rows = (_position(k, trams) for k in range(positions))
    names = {"veh": "vehicleNumber", "oper": "ownerOperatorId", "lat": "latitude"}
    names |= {"long": "longitude", "loc": "locationQualityMethod"}
    header = ["eventType", *(names.get(key, key) for key in _position(0, trams))]
    plain = path.with_suffix(".csv")
    with plain.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(header)
        for row in rows:
            writer.writerow(["VP", *("" if v is None else v for v in row.values())])
    if form == "csv":
        return plain
    try:
        from compression import zstd  # type: ignore[import-not-found]
    except ImportError:
        from backports import zstd  # type: ignore[import-not-found,no-redef]
    packed = plain.with_suffix(".csv.zst")
    packed.write_bytes(zstd.compress(plain.read_bytes()))
    plain.unlink()
    return packed


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--positions", type=int, default=600_000)
    ap.add_argument("--form", choices=("jsonl", "csv", "csv.zst"), default="jsonl")
    how = ap.add_mutually_exclusive_group()
    how.add_argument(
        "--streamed", action="store_true", help="read as antikol replay does (StreamedFeed)"
    )
    how.add_argument(
        "--replay",
        action="store_true",
        help="run the whole antikol replay (--map none: the sector rule) and time it",
    )
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        path = write_archive(Path(tmp) / "hfp.jsonl", args.positions, args.form)
        size_mb = path.stat().st_size / 1e6
        how = "streamed" if args.streamed else "replay" if args.replay else "read_hfp"
        run = [sys.executable, "-c", _READ, str(path), how]
        got = json.loads(subprocess.run(run, check=True, capture_output=True).stdout)
        base = json.loads(
            subprocess.run(
                [sys.executable, "-c", _BASELINE], check=True, capture_output=True
            ).stdout
        )
    held = got["peak_mb"] - base["peak_mb"]
    if args.replay:
        print(
            f"{args.form}: {size_mb:.0f} MB, antikol replay --map none of {args.positions:,} "
            f"positions in {got['seconds']:.1f} s; peak {got['peak_mb']:.0f} MB, "
            f"{held:.0f} MB above the imports"
        )
        return
    print(
        f"{args.form}{' streamed' if args.streamed else ''}: {size_mb:.0f} MB, "
        f"{got['reports']:,} reports "
        f"({got['problems']} problems) in {got['seconds']:.1f} s "
        f"({got['reports'] / got['seconds']:,.0f}/s); peak {got['peak_mb']:.0f} MB, "
        f"{held:.0f} MB above the imports ({held * 1024 / got['reports'] * 1024:.0f} B "
        "per position)"
    )


if __name__ == "__main__":
    main()
