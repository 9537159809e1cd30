"""Fuzzing harness: mutate valid inputs of each entry point and classify what happens.

Used by the bounded fuzz tests (``tests/test_fuzz_*.py``) and by the long campaign in
``benchmarks/fuzz_inputs.py``; the sources' part is in ``tests/_fuzz_sources.py``. Each
``try_*`` function takes one input and returns an :class:`Outcome`:

``accepted``
    The input was used, and nothing in it was lost (see each entry point).
``rejected``
    The project's own error (a ``TrackMapError`` / ``AntikolError``), naming the file
    where there is one.
``exception``
    Anything else: a bare exception, or an error message that does not name the file.
``silent_loss``
    Accepted, but something the input holds vanished or changed without a word.

Every ``mutate_*`` function turns a valid input into a broken one with a seeded
:class:`random.Random`, the way a user's bad file is broken: wrong types, values out of
range, references to nothing, moved coordinates, missing members, bad bytes, cut text.
"""

from __future__ import annotations

import copy
import functools
import json
import math
import random
import traceback
from collections.abc import Iterator
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import trackmap
from antikol.errors import AntikolError, InvalidReportError, ProtocolError
from antikol.ingest.protocol import decode_frame, encode_report
from antikol.report import ReportedTrackPosition, VehicleReport
from tests._osm import OsmBuilder
from trackmap import mapfile
from trackmap.check import check
from trackmap.errors import TrackMapError

OUTCOMES = ("accepted", "rejected", "exception", "silent_loss")


@dataclass(frozen=True)
class Outcome:
    """What one input led to (:data:`OUTCOMES`) and, for failures, what happened."""

    kind: str
    detail: str = ""


@dataclass
class Tally:
    """Counts of outcomes for one entry point, with the first failures described."""

    name: str
    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(OUTCOMES, 0))
    failures: list[str] = field(default_factory=list)

    @property
    def tried(self) -> int:
        return sum(self.counts.values())

    def add(self, outcome: Outcome) -> None:
        self.counts[outcome.kind] += 1
        if outcome.kind in ("exception", "silent_loss") and len(self.failures) < 20:
            self.failures.append(f"{outcome.kind}: {outcome.detail}")


def _bare(exc: BaseException) -> Outcome:
    tb = traceback.extract_tb(exc.__traceback__)
    at = f" at {Path(tb[-1].filename).name}:{tb[-1].lineno}" if tb else ""
    return Outcome("exception", f"{type(exc).__name__}: {str(exc)[:160]}{at}")


WEIRD: tuple[Any, ...] = (
    None,
    True,
    False,
    0,
    -1,
    1,
    2,
    999,
    2**31,
    2**63,
    -(2**63) - 1,
    10**25,
    -1e308,
    1e308,
    1e-320,
    0.5,
    -0.0,
    float("nan"),
    float("inf"),
    "",
    "x",
    "edge",
    "1",
    "\udc80",
    [],
    [[]],
    [[1, 2]],
    [None],
    {},
    {"a": 1},
)


def weird(rng: random.Random) -> Any:
    """A value of a wrong type or out of range (NaN and infinities included)."""
    return copy.deepcopy(rng.choice(WEIRD))


# -- map files ----------------------------------------------------------------------------
def base_network() -> OsmBuilder:
    """A small network with every kind of map feature: a switch, a diamond, an at-grade
    crossing without a node, a bridge over the line, a stop and buffer stops."""
    b = OsmBuilder()
    diamond = b.node(0, 0)
    toe = b.node(0, 120)
    b.line([(0, -200), (0, -100), diamond], oneway="yes", name="Main")
    b.line([diamond, (0, 60), toe], oneway="yes")
    b.line([toe, (0, 200), (0, 300)])
    b.line([toe, (2.0, 135.0), (8.0, 150.0), (30.0, 180.0), (80.0, 210.0)])
    b.line([(-100, -60), diamond, (100, 60)], maxspeed="30")
    b.line([(-100, -140), (100, -60)])  # crosses the main line without a node
    b.line([(-100, 240), (100, 260)], bridge="yes", layer="1")
    b.node(3.0, -150.0, railway="tram_stop", name="Stop A")
    return b


@functools.cache
def base_map_text() -> str:
    """The base network as a map file's text."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        src = base_network().write_xml(Path(tmp) / "base.osm")
        net = trackmap.build(src)
        kinds = {
            f["properties"]["feature"] for f in mapfile.to_geojson(net.data, stats={})["features"]
        }
        assert kinds == {"edge", "node", "conflict", "stop", "grade_separated"}, kinds
        return net.save(Path(tmp) / "base.trackmap.geojson").read_text(encoding="utf-8")


def _paths(obj: Any, prefix: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    """Every member path of a JSON document."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield (*prefix, k)
            yield from _paths(v, (*prefix, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield (*prefix, i)
            yield from _paths(v, (*prefix, i))


def _parent(doc: Any, path: tuple[Any, ...]) -> Any:
    for p in path[:-1]:
        doc = doc[p]
    return doc


def _number_like(rng: random.Random, old: Any) -> Any:
    """A plausible-looking wrong number near a valid one (a semantic mutation)."""
    if isinstance(old, bool) or not isinstance(old, (int, float)):
        return rng.choice([0, 1, 999, -1, 0.25])
    return rng.choice(
        [
            old + 1,
            old - 1,
            -old,
            old * 10,
            old + rng.uniform(-5, 5),
            old + 1e-4,
            999 if isinstance(old, int) else old + 50.0,
        ]
    )


def mutate_map(text: str, rng: random.Random) -> bytes:
    """A broken copy of a map file (structure, values, references or bytes)."""
    op = rng.randrange(14)
    if op >= 11:  # byte-level damage
        raw = text.encode("utf-8")
        if op == 11:
            return raw[: rng.randrange(len(raw))]
        k = rng.randrange(len(raw))
        if op == 12:
            return (
                raw[:k] + bytes([rng.choice([0xE9, 0x00, 0xFF, 0x22, 0x5D, 0x7B])]) + raw[k + 1 :]
            )
        depth = rng.choice([10, 1000, 100_000])
        return ("[" * depth + "]" * depth).encode() if rng.random() < 0.5 else raw + b"x"
    doc = json.loads(text)
    feats = doc["features"]
    if op <= 3:  # any member: a weird value, or a plausible wrong number
        path = rng.choice(list(_paths(doc)))
        parent = _parent(doc, path)
        old = parent[path[-1]]
        parent[path[-1]] = weird(rng) if op <= 1 else _number_like(rng, old)
    elif op == 4:  # delete a member
        path = rng.choice([p for p in _paths(doc) if isinstance(_parent(doc, p), dict)])
        del _parent(doc, path)[path[-1]]
    elif op == 5:  # move a vertex or a point
        f = rng.choice(feats)
        coords = f["geometry"]["coordinates"]
        if f["geometry"]["type"] == "LineString":
            coords = rng.choice(coords)
        axis = rng.randrange(2)
        coords[axis] = rng.choice(
            [-179.0, 0.0, coords[axis] + 1e-5, coords[axis] + 0.01, 89.9, coords[axis] * -1]
        )
    elif op == 6:  # duplicate or delete a feature
        f = rng.choice(feats)
        if rng.random() < 0.5:
            feats.append(copy.deepcopy(f))
        else:
            feats.remove(f)
    elif op == 7:  # point a reference elsewhere
        f = rng.choice(feats)
        props = f["properties"]
        for key in ("edge_id", "start_node", "end_node", "node_id", "edges", "ends", "allowed"):
            if key in props:
                value = props[key]
                if isinstance(value, list) and value:
                    i = rng.randrange(len(value))
                    inner = value[i]
                    value[i] = (
                        [rng.randrange(-1, 40), rng.randrange(-1, 3)]
                        if isinstance(inner, list)
                        else rng.randrange(-1, 40)
                    )
                else:
                    props[key] = rng.randrange(-1, 40)
                break
    elif op == 8:  # header members
        header = doc["trackmap"]
        key = rng.choice(["version", "crs_wkt", "driving_side", "source", "build", "format"])
        header[key] = rng.choice(
            [weird(rng), True, 2, "left", "EPSG:3857", header.get("crs_wkt", "")[:50], {}]
        )
    elif op == 9:  # swap two features' properties
        a, b = rng.sample(feats, 2)
        a["properties"], b["properties"] = b["properties"], a["properties"]
    else:  # NaN and infinities written as JSON tokens
        path = rng.choice([p for p in _paths(doc) if isinstance(_parent(doc, p)[p[-1]], float)])
        _parent(doc, path)[path[-1]] = rng.choice([math.nan, math.inf, -math.inf])
    return json.dumps(doc, allow_nan=True).encode("utf-8", errors="surrogatepass")


# members the writer derives (not canonical), and optional members with their default
_DERIVED = {"edge": {"length_m"}}
_OPTIONAL = {
    "edge": {"service": None, "maxspeed_mps": None, "name": None},
    "conflict": {"angle_deg": None},
    "stop": {"name": None, "edge_id": None, "offset_m": None},
}
_CANONICAL_GEOMETRY = {"edge", "node", "stop"}


def _normal(value: Any) -> Any:
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, (int, float)):
        return float(value) + 0.0  # -0.0 is 0
    if isinstance(value, list):
        return [_normal(v) for v in value]
    if isinstance(value, dict):
        return {k: _normal(v) for k, v in value.items()}
    return value


def canonical_map(doc: dict[str, Any]) -> tuple[Any, ...]:
    """What a map file says, without its derived members, as a comparable value."""
    feats = []
    for f in doc["features"]:
        props = f["properties"]
        kind = props["feature"]
        keys = set(mapfile_keys(kind)) - _DERIVED.get(kind, set())
        shown = {k: _normal(props.get(k, _OPTIONAL.get(kind, {}).get(k))) for k in sorted(keys)}
        geom = _normal(f["geometry"]["coordinates"]) if kind in _CANONICAL_GEOMETRY else None
        feats.append(json.dumps([kind, shown, geom], sort_keys=True))
    header = doc["trackmap"]
    head = {
        "driving_side": header.get("driving_side", "right"),
        "source": _normal(header.get("source") or {}),
        "build": _normal(header.get("build") or {}),
        "attribution": header.get("attribution", ""),
        "created": header.get("created", ""),
    }
    return (json.dumps(head, sort_keys=True), tuple(sorted(feats)))


@functools.cache
def _writer_keys() -> dict[str, tuple[str, ...]]:
    doc = json.loads(base_map_text())
    out: dict[str, tuple[str, ...]] = {}
    for f in doc["features"]:
        out.setdefault(f["properties"]["feature"], tuple(f["properties"]))
    return out


def mapfile_keys(kind: str) -> tuple[str, ...]:
    """The property names the writer writes for a feature kind."""
    return _writer_keys()[kind]


def try_map_file(data: bytes, path: Path) -> Outcome:
    """Load a map file, check it, and compare what was loaded with what the file says."""
    path.write_bytes(data)
    try:
        net = trackmap.load(path)
    except TrackMapError as exc:
        if str(path) not in str(exc):
            return Outcome("exception", f"message does not name the file: {str(exc)[:120]}")
        return Outcome("rejected")
    except Exception as exc:
        return _bare(exc)
    try:
        check(net)
        written = mapfile.to_geojson(net.data, stats={})
        said = json.loads(data)
    except Exception as exc:
        return _bare(exc)
    if canonical_map(said) != canonical_map(written):
        return Outcome("silent_loss", "the loaded map differs from what the file says")
    return Outcome("accepted")


# -- replay CSV ---------------------------------------------------------------------------
CSV_HEADER = "vehicle_id,t,lat,lon,speed_mps,course_deg,braking,seq,hdop"


def csv_rows(n: int) -> list[str]:
    """Valid replay rows whose ``t`` is their index."""
    return [
        f"T{k % 3},{k},{50.06 + 1e-4 * k:.7f},19.94,{k % 20}.5,{(7 * k) % 360},none,{k},1.2"
        for k in range(n)
    ]


def mutate_csv(rows: list[str], rng: random.Random) -> tuple[bytes, set[int]]:
    """A replay CSV with some rows broken in place; returns its bytes and the line numbers
    (1-based, the header is line 1) of the rows that were changed."""
    lines = [CSV_HEADER.encode(), *(r.encode() for r in rows)]
    changed: set[int] = set()
    for _ in range(rng.randrange(1, 6)):
        k = rng.randrange(1, len(lines))
        raw = lines[k]
        j = rng.randrange(len(raw) + 1)
        op = rng.randrange(9)
        if op == 0:
            raw = raw[:j] + b"\xe9" + raw[j:]  # a Latin-1 byte
        elif op == 1:
            raw = raw[:j] + b'"' + raw[j:]  # a quote that does not close
        elif op == 2:
            raw = raw[:j]  # cut short
        elif op == 3:
            raw = raw[:j] + b"\x00" + raw[j:]
        elif op == 4:
            raw = raw[:j] + rng.choice([b",", b"nan", b"1e400", b"-", b"\xff\xfe", b" "]) + raw[j:]
        elif op == 5:
            fields_ = raw.split(b",")
            fields_[rng.randrange(len(fields_))] = rng.choice(
                [b"", b"x", b"nan", b"inf", b"1" * 5000, b"-1", b"400", b"\xed\xa0\x80", b"   "]
            )
            raw = b",".join(fields_)
        elif op == 6:
            raw = b"x" * rng.choice([10, 2_000_000])  # a very long line
        elif op == 7:
            raw = b'"' + raw + b'"'
        else:
            raw = raw.replace(b",", b";")
        lines[k] = raw
        changed.add(k + 1)
    end = rng.choice([b"\n", b"\r\n", b"\r"])
    return end.join(lines) + rng.choice([end, b""]), changed


def try_csv(data: bytes, changed: set[int], n_rows: int, path: Path) -> Outcome:
    """Read a replay CSV; every row is a report or a problem with its line, and every row
    that was not changed is a report."""
    from antikol.ingest.replaylog import RowProblem, iter_replay_csv

    path.write_bytes(data)
    try:
        items = list(iter_replay_csv(path))
    except AntikolError as exc:
        if str(path) not in str(exc):
            return Outcome("exception", f"message does not name the file: {str(exc)[:120]}")
        return Outcome("rejected")
    except Exception as exc:
        return _bare(exc)
    reports = [i for i in items if isinstance(i, VehicleReport)]
    problems = [i for i in items if isinstance(i, RowProblem)]
    if any(p.line not in changed for p in problems):
        bad = [p.line for p in problems if p.line not in changed]
        return Outcome("silent_loss", f"problems reported at unchanged lines {bad[:5]}")
    seen = {r.t for r in reports}
    lost = [k for k in range(n_rows) if k + 2 not in changed and float(k) not in seen]
    if lost:
        return Outcome(
            "silent_loss", f"unchanged rows at lines {[k + 2 for k in lost[:5]]} vanished"
        )
    return Outcome("accepted")


# -- report fields ------------------------------------------------------------------------
_VALID_FIELDS: dict[str, Any] = {
    "vehicle_id": "T1",
    "t": 1.0,
    "lat": 50.06,
    "lon": 19.94,
    "speed_mps": 8.0,
    "course_deg": 90.0,
}
_FIELD_POOLS: dict[str, tuple[Any, ...]] = {
    "vehicle_id": ("T1", "", "   ", "\udc80", "x" * 33, "ü" * 17, "a\nb", "x" * 1_000_000, 5, None),
    "t": (0, -1.0, 1e300, 10**400, 2**53 + 1),
    "lat": (90, -90.0, 90.0000001, 1e-300),
    "lon": (180, -180.0, 180.5),
    "speed_mps": (0, 100, 100.0001, -1e-9),
    "course_deg": (0, 360, 359.999, 360.0001, -0.0),
    "braking": ("none", "service", "emergency", "stop", ["none"], None),
    "length_m": (None, 0.0005, 1000, 1000.1, 0),
    "antenna_offset_m": (None, 0, 5.0, 2000.0, 5e9),
    "route": (None, (), (0, 1), [1, 2], 5, "12", (2**32,), (-1,), tuple(range(256)), (True,)),
    "track_position": (None, "x", 5),
    "seq": (None, 0, 2**32, -1, True, 10**30),
    "hdop": (None, 0.0, 99.99, 1e308, 1e20, -0.1),
    "fix_quality": (None, 0, 9, 10, True, 4),
    "odometer_m": (None, 0, 1e12, -1.0),
}


_REAL_FIELDS = frozenset(
    {"t", "lat", "lon", "speed_mps", "course_deg", "length_m", "antenna_offset_m", "hdop"}
    | {"odometer_m"}
)


def draw_report_fields(rng: random.Random) -> dict[str, Any]:
    """Report fields, each valid, from its pool of edge cases, or any weird value."""
    kw = dict(_VALID_FIELDS)
    for name, pool in _FIELD_POOLS.items():
        r = rng.random()
        if r < 0.25:
            kw[name] = copy.deepcopy(rng.choice(pool))
        elif r < 0.32:
            kw[name] = weird(rng)
    if rng.random() < 0.2:
        kw["track_position"] = _track_position(rng)
    return kw


def _track_position(rng: random.Random) -> Any:
    try:
        return ReportedTrackPosition(
            rng.choice([0, 5, 2**32 - 1]),
            rng.choice([0.0, 12.5, 5e9, 4294967.295]),
            rng.choice([1, -1]),
        )
    except InvalidReportError:
        return None


def try_report(kw: dict[str, Any]) -> Outcome:
    """Construct a report; accepted ones must hold exactly the values given."""
    try:
        r = VehicleReport(**kw)
    except InvalidReportError as exc:
        if len(str(exc)) > 300:
            return Outcome("exception", f"message of {len(str(exc))} characters")
        return Outcome("rejected")
    except Exception as exc:
        return _bare(exc)
    for f in fields(VehicleReport):
        given, kept = kw.get(f.name, f.default), getattr(r, f.name)
        if f.name == "course_deg" and given == 360:
            given = 0.0
        if f.name == "route" and given is not None:
            given = tuple(given)
        if f.name in _REAL_FIELDS and given is not None:
            given = float(given)  # documented: real-valued fields are stored as float
        if not (given == kept and type(given) is type(kept)):
            return Outcome("silent_loss", f"{f.name}: gave {given!r:.60}, kept {kept!r:.60}")
    return Outcome("accepted")


# -- frame encoder ------------------------------------------------------------------------
def _close(a: float | None, b: float | None, tol: float) -> bool:
    if a is None or b is None:
        return a is b
    return abs(a - b) <= tol


def try_encode(report: VehicleReport) -> Outcome:
    """Encode a valid report; decoding the frame gives it back within the resolution."""
    try:
        frame = encode_report(report)
    except ProtocolError:
        return Outcome("rejected")
    except Exception as exc:
        return _bare(exc)
    try:
        back = decode_frame(frame)
    except Exception as exc:
        return _bare(exc)
    hdop = None if report.hdop is None else min(report.hdop, 655.35)
    # a positive length below 0.5 mm is sent as 1 mm (documented)
    length = None if report.length_m is None else max(report.length_m, 0.001)
    course = report.course_deg if round(report.course_deg * 100) % 36000 else 0.0
    checks: list[tuple[str, bool]] = [
        ("vehicle_id", back.vehicle_id == report.vehicle_id),
        ("t", back.t == report.t),
        ("lat", _close(back.lat, report.lat, 0.51e-7)),
        ("lon", _close(back.lon, report.lon, 0.51e-7)),
        ("speed_mps", _close(back.speed_mps, report.speed_mps, 0.0051)),
        (
            "course_deg",
            _close(back.course_deg, course, 0.0051)
            or _close(back.course_deg + 360, course, 0.0051),
        ),
        ("braking", back.braking == report.braking),
        ("length_m", _close(back.length_m, length, 0.00051)),
        ("antenna_offset_m", _close(back.antenna_offset_m, report.antenna_offset_m, 0.00051)),
        ("route", back.route == report.route),
        ("hdop", _close(back.hdop, hdop, 0.0051)),
        ("fix_quality", back.fix_quality == report.fix_quality),
        ("track_position", (back.track_position is None) == (report.track_position is None)),
    ]
    wrong = [name for name, ok in checks if not ok]
    if wrong:
        return Outcome("silent_loss", f"{wrong} changed in the frame")
    return Outcome("accepted")


def draw_encodable_report(rng: random.Random) -> VehicleReport | None:
    """A valid report with extreme values (None when the drawn fields are invalid)."""
    kw = draw_report_fields(rng)
    kw["odometer_m"] = None  # not carried by the frame (see the protocol's layout)
    try:
        return VehicleReport(**kw)
    except InvalidReportError:
        return None
    except Exception:
        return None
