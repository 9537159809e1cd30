"""A reference run: simulated reports and the analyser's assessments of them.

``tests/test_reference_run.py`` replays the recording in ``tests/data/reference_run.json``:
every optimisation of the analyser must reproduce these assessments exactly (speed never
buys a different warning). Re-record with ``python -m tests._reference`` only for a
deliberate change of behaviour, and say so in the commit.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import trackmap
from antikol import Analyser, VehicleReport
from antikol.ingest.replaylog import REPLAY_OPTIONAL_COLUMNS
from antikol.sim import GpsModel, Simulator, fleet


def _plain(value):
    """A record's field as a JSON value; floats exactly, by repr."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, float):
        return repr(value)
    raise TypeError(f"unexpected field value {value!r}")


def assessment_record(a) -> list:
    """An assessment as plain JSON values: every field of it, its threats and its
    suppressed vehicles, in their order."""
    return [
        a.level,
        a.method,
        [[_plain(v) for v in dataclasses.astuple(th)] for th in a.threats],
        [[_plain(v) for v in dataclasses.astuple(s)] for s in a.suppressed],
    ]


def simulate() -> list:
    net = trackmap.load_default()
    gps = GpsModel(sigma_m=3.0, bias_sigma_m=1.5, bias_tau_s=60.0, missing_rate=0.05)
    # a dense fleet on the city centre's lines, so that trams follow, meet and merge
    specs = fleet(net, 30, 7, route_length_m=2500.0, headway_s=2.0, min_separation_m=40.0)
    result = Simulator(net, specs, gps=gps, seed=7).run(120.0)
    return sorted(result.reports, key=lambda r: (r.t, r.vehicle_id))


def replay(reports, *, with_map: bool = True) -> dict[str, list]:
    """The assessments of a control room (every vehicle at every time), with the default
    map or by the paper's sector rule alone."""
    an = Analyser(track_map=trackmap.load_default()) if with_map else Analyser()
    out: dict[str, list] = {}
    times = sorted({r.t for r in reports})
    by_t: dict[float, list] = {}
    for r in reports:
        by_t.setdefault(r.t, []).append(r)
    for t in times:
        batch = by_t[t]
        for r in batch:
            an.update(r)
        for r in batch:
            out[f"{r.vehicle_id}@{t!r}"] = assessment_record(an.assess(r.vehicle_id))
    return out


def replay_on_board(reports, own_id: str) -> dict[str, list]:
    """The same reports through an on-board analyser of ``own_id``: its assessments."""
    net = trackmap.load_default()
    an = Analyser(track_map=net, own_id=own_id)
    out: dict[str, list] = {}
    by_t: dict[float, list] = {}
    for r in reports:
        by_t.setdefault(r.t, []).append(r)
    for t in sorted(by_t):
        batch = by_t[t]
        for r in batch:
            an.update(r)
        if any(r.vehicle_id == own_id for r in batch):
            out[f"{own_id}@{t!r}"] = assessment_record(an.assess())
    return out


def load(path: Path, key: str = "assessments") -> tuple[list[VehicleReport], dict[str, list]]:
    """The recorded reports and assessments (``sector_assessments``: without a map)."""
    doc = json.loads(path.read_text(encoding="utf-8"))
    return [VehicleReport(**row) for row in doc["reports"]], doc[key]


def main(path: str) -> None:
    reports = simulate()
    fields = ("vehicle_id", "t", "lat", "lon", "speed_mps", "course_deg", *REPLAY_OPTIONAL_COLUMNS)
    rows = [{f: getattr(r, f) for f in fields if getattr(r, f, None) is not None} for r in reports]
    doc = {
        "reports": rows,
        "assessments": replay(reports),
        "sector_assessments": replay(reports, with_map=False),
    }
    Path(path).write_text(json.dumps(doc, separators=(",", ":")) + "\n", encoding="utf-8")
    print(f"{len(rows)} reports, {len(doc['assessments'])} assessments -> {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "tests/data/reference_run.json")
