"""The three tasks of fleet-scale replay; plain functions a Dask worker (or a loop) runs.

1. :func:`ingest_partition` — one archive file into a working-copy Parquet file, with its
   counts and the keys of the work it holds (vehicle-days, window-regions).
2. :func:`position_vehicles` — a group of vehicles on one day (each positioned as if
   alone): track positions at every analysis cycle a vehicle is in the vehicle table,
   written to Parquet per vehicle.
3. :func:`analyse_window` — one time window of one map region: the pairwise analysis (the
   track-aware analyser on the stored positions, and the paper's sector rule beside it),
   events written to Parquet and counts returned.

Why the partitions give the single-process answer
-------------------------------------------------
**Positioning is independent per vehicle.** The analyser's positioning state of a vehicle
depends on that vehicle's reports only (the fleet update is vectorised row by row) and on
*when* the vehicle table drops it, which stage 1 reproduces cycle by cycle. Stage 2 runs
the same analyser code as the single-process replay but is handed the positions of stage
1 through :class:`~antikol.evaluation.fleet.positions.StoredPositions` instead of
re-matching: a matcher re-started at a window's start would need the vehicle's whole
history (hours, for a tram that never leaves the network) to reach the same hypotheses;
stored positions need none. Stage 1 also records, per cycle, the rest of what the
analysers remember of each vehicle alone — the course kept from before it stopped and the
moving/standing hysteresis (:meth:`Analyser.memory`) — and stage 2 restores it when a
vehicle first reports in its task, so a tram standing at a terminus for an hour across a
window start is judged as in a continuous run.

**Time windows overlap by a warm-up.** What remains is memory of *pairs* and of the
table: the vehicle table holds reports of the last ``max(expiry, dead reckoning)`` = 30 s
and each pair's alarm has hysteresis (held while the gap closes, released seconds after
the conflict is over). A window's task replays ``warmup_s`` (default 600 s) before its
first cycle and keeps only the events of its own cycles. The result is exact when no pair
alarm crossing a window start has been held for longer than the warm-up: 600 s is far
longer than the hysteresis' hold and release times, but a pair whose gap kept closing
slowly for ten minutes would break it. That is checked: at the window's first cycle, the
pairs that have been in conflict since the warm-up began (their alarm may be on in a
continuous run and off here, see :meth:`AlarmBook.unsettled
<antikol.analysis.alarms.AlarmBook.unsettled>`) are counted in
:attr:`WindowResult.unsettled_alarms` and logged. ``tests/test_fleet.py`` checks the equality event
for event on generated traffic with 120 s windows and warm-ups;
``benchmarks/bench_fleet.py`` checks it on the Kraków map. The warm-up costs
``warmup_s / window_s`` of extra analysis.

**Map regions overlap by the interaction reach.** A region's task emits the events of the
vehicles whose newest report lies in its square, but feeds the analyser every report of
every vehicle that comes within ``margin_m`` of the square at any time of the window and
its warm-up (whole streams, never cut at the edge). A vehicle that can appear in the
assessment of a vehicle inside the square is within the interaction reach of it
(:meth:`FleetConfig.interaction_reach_m`: both look-ahead horizons at the top speed, the
distance run on a 30 s old report and a 10 s old one, the sector rule's 300 m and the
travel during an alarm's minimum hold), all straight-line distances bounded by the
along-track ones. ``margin_m`` must be at least that reach (checked).
"""

from __future__ import annotations

import logging
import math
from collections import Counter, defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import quote

import numpy as np

from antikol.analysis import braking
from antikol.analysis.analyser import Analyser
from antikol.analysis.assessment import Assessment
from antikol.analysis.geometry import geodesic_inverse
from antikol.analysis.profiles import load_profile
from antikol.errors import InvalidArgumentError
from antikol.evaluation.fleet.archive import (
    read_partition,
    read_working_copy,
    write_working_copy,
)
from antikol.evaluation.fleet.positions import (
    CycleRecord,
    StoredPositions,
    cycle_index,
    read_positions,
    write_positions,
)
from antikol.evaluation.replay import EVENT_COLUMNS, cycles, event_values
from antikol.positioning.config import PositioningConfig
from antikol.report import VehicleReport
from antikol.thresholds import EXPIRY_S

#: How long a vehicle stays in the analysers' memory without reporting, s.
_TABLE_MEMORY_S = max(EXPIRY_S, PositioningConfig().dead_reckoning_s)

__all__ = [
    "EVENT_FIELDS",
    "FleetConfig",
    "IngestResult",
    "PositionResult",
    "WindowResult",
    "analyse_window",
    "check_count",
    "ingest_partition",
    "load_map_cached",
    "position_vehicles",
]

logger = logging.getLogger(__name__)

#: Columns of the events Parquet files (one row per threat per own vehicle per cycle).
EVENT_FIELDS: tuple[str, ...] = ("analyser", *EVENT_COLUMNS, "lon", "lat")
_ALARM = ("warning", "emergency")
_MAPS: dict[str, Any] = {}


def load_map_cached(spec: str) -> Any:
    """The map a ``--map`` value names, loaded once per worker process (None: no map)."""
    if spec not in _MAPS:
        from trackmap.named import load_named

        _MAPS[spec] = load_named(spec)
    return _MAPS[spec]


@dataclass(frozen=True)
class FleetConfig:
    """How an archive is cut into work (SI units).

    Attributes
    ----------
    map_spec : str
        A map file, ``default``, ``synthetic`` or ``none`` (sector rule only; one region).
    cycle_s : float
        Analysis period, s.
    window_s : float
        Length of a time window of the pairwise analysis, s (a multiple of ``cycle_s``).
    warmup_s : float
        Replay before a window's first cycle whose events are discarded, s.
    region_m : float
        Side of a square map region, m (default ``inf``: one region). Every region's task
        also analyses the vehicles within ``margin_m`` of it, so regions pay off only on
        networks many times the margin across (on Kraków's 15 x 10 km, 8 km regions
        cost 2.1x the work of one region); time windows give the parallelism.
    margin_m : float
        Reach of a region's task beyond its square, m (at least
        :meth:`interaction_reach_m`).
    max_speed_mps : float
        Highest vehicle speed the margin is sized for, m/s (faster reports are logged).
    day_s, day_offset_s : float
        Positioning restarts at every ``day_offset_s + n·day_s`` (the service-day cut;
        put it at night when no tram runs), s.
    log_format : str
        Format of the archive's files (``auto`` recognises each).
    hotspot_m : float
        Grid of the false-alarm hot spots, m.
    group : int
        Vehicles positioned together in one task (memory: that many vehicle-days).
    """

    map_spec: str = "default"
    cycle_s: float = 1.0
    window_s: float = 3600.0
    warmup_s: float = 600.0
    region_m: float = math.inf
    margin_m: float = 2500.0
    max_speed_mps: float = 25.0
    day_s: float = 86_400.0
    day_offset_s: float = 0.0
    log_format: str = "auto"
    hotspot_m: float = 100.0
    group: int = 8

    def __post_init__(self) -> None:
        for name in ("cycle_s", "window_s", "day_s", "hotspot_m", "max_speed_mps"):
            _check_real(name, getattr(self, name), lo=0.0, strict=True)
        _check_real("warmup_s", self.warmup_s, lo=0.0)
        _check_real("margin_m", self.margin_m, lo=0.0)
        _check_real("day_offset_s", self.day_offset_s)
        _check_real("region_m", self.region_m, lo=0.0, strict=True, allow_inf=True)
        check_count("group", self.group, minimum=1)
        if abs(self.window_s / self.cycle_s - round(self.window_s / self.cycle_s)) > 1e-9:
            raise InvalidArgumentError("window_s", self.window_s, "must be a multiple of cycle_s")
        if self.margin_m < self.interaction_reach_m():
            raise InvalidArgumentError(
                "margin_m",
                self.margin_m,
                f"must be at least the interaction reach, {self.interaction_reach_m():.0f} m",
            )

    def interaction_reach_m(self) -> float:
        """How far apart two vehicles can be and still meet in one assessment, m.

        Both look-ahead horizons at ``max_speed_mps`` (tram profile, never below 300 m),
        plus the distance run on the newest report at its oldest (dead reckoning, 30 s)
        and on the other's (expiry, 10 s), plus the sector rule's 300 m, plus the travel
        of both during a 10 s alarm hold.
        """
        v = self.max_speed_mps
        horizon = float(braking.horizon_m(v, load_profile("tram"), minimum_m=300.0))
        dr = PositioningConfig().dead_reckoning_s
        return 2 * horizon + v * (dr + EXPIRY_S) + 300.0 + 2 * v * 10.0

    @property
    def window_cycles(self) -> int:
        """Cycles per window."""
        return round(self.window_s / self.cycle_s)

    def day_of(self, t: float) -> int:
        """The service day of a time (the day of its analysis cycle's end)."""
        k = cycle_index(t, self.cycle_s)
        return math.floor((k * self.cycle_s - self.day_offset_s) / self.day_s + 1e-9)

    def first_cycle(self, day: int) -> int:
        """The first analysis cycle of a service day."""
        return cycle_index(self.day_offset_s + day * self.day_s, self.cycle_s)

    def window_of(self, k: int) -> int:
        """The window of cycle ``k`` (windows never straddle a day: see :meth:`bounds`)."""
        return k // self.window_cycles

    def bounds(self, day: int, window: int) -> tuple[int, int]:
        """Cycles ``[lo, hi)`` of a window, clipped to its day."""
        lo, hi = window * self.window_cycles, (window + 1) * self.window_cycles
        return max(lo, self.first_cycle(day)), min(hi, self.first_cycle(day + 1))

    def warmup_start(self, day: int, window: int) -> int:
        """The first cycle a window's task replays: ``warmup_s`` before the window's
        first cycle (rounded up to whole cycles), never before the day's first cycle."""
        lo, _ = self.bounds(day, window)
        warm = lo - math.ceil(self.warmup_s / self.cycle_s - 1e-9)
        return max(warm, self.first_cycle(day))

    def cell_of(self, x: Any, y: Any) -> tuple[Any, Any]:
        """Region indices of local coordinates (arrays or scalars)."""
        if math.isinf(self.region_m):
            return np.zeros_like(x, dtype=np.int64), np.zeros_like(y, dtype=np.int64)
        return (
            np.floor(np.asarray(x) / self.region_m).astype(np.int64),
            np.floor(np.asarray(y) / self.region_m).astype(np.int64),
        )


def _check_real(
    name: str,
    value: Any,
    *,
    lo: float = -math.inf,
    strict: bool = False,
    allow_inf: bool = False,
) -> None:
    """Refuse a non-number, NaN, an infinity (unless ``allow_inf``: +inf) or a value
    below ``lo`` (at ``lo`` too when ``strict``)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InvalidArgumentError(name, value, "must be a number")
    if math.isnan(value) or value == -math.inf or (value == math.inf and not allow_inf):
        raise InvalidArgumentError(name, value, "must be finite")
    if value < lo or (strict and value == lo):
        raise InvalidArgumentError(name, value, f"must be {'>' if strict else '>='} {lo:g}")


def check_count(name: str, value: Any, *, minimum: int) -> None:
    """Refuse anything but an int (not a bool) of at least ``minimum``.

    Raises
    ------
    InvalidArgumentError
        Naming ``name`` and ``value``.
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InvalidArgumentError(name, value, "must be an integer")
    if value < minimum:
        raise InvalidArgumentError(name, value, f"must be >= {minimum}")


def _local_xy(net: Any, reports: Sequence[VehicleReport]) -> tuple[Any, Any]:
    lon = np.array([r.lon for r in reports], dtype=float)
    lat = np.array([r.lat for r in reports], dtype=float)
    if net is None:  # no map: one region, coordinates unused
        return np.zeros_like(lon), np.zeros_like(lat)
    x, y = net.to_local(lon, lat)
    return np.asarray(x, dtype=float), np.asarray(y, dtype=float)


# ---------------------------------------------------------------------------- stage 0
@dataclass(frozen=True)
class IngestResult:
    """What one partition holds.

    Attributes
    ----------
    name : str
    work_file : str
        Its working copy.
    rows : int or None
        Records read, when counted.
    reports : int
        Valid reports.
    rejected_by_reason : dict of str to int
    vehicle_days : frozenset of (int, str)
    windows : frozenset of (int, int, int, int)
        ``(day, window, cell_x, cell_y)`` of every report.
    """

    name: str
    work_file: str
    rows: int | None
    reports: int
    rejected_by_reason: dict[str, int]
    vehicle_days: frozenset[tuple[int, str]]
    windows: frozenset[tuple[int, int, int, int]]


def ingest_partition(path: str, index: int, config: FleetConfig, work_dir: str) -> IngestResult:
    """Stage 0: read one archive file into its working copy.

    Raises
    ------
    InputFileError, ReplayError
        The file cannot be read (the message names it).
    """
    data = read_partition(path, log_format=config.log_format)
    net = load_map_cached(config.map_spec)
    out = Path(work_dir) / f"part-{index:06d}.parquet"
    write_working_copy(data.reports, out)
    ks = [cycle_index(r.t, config.cycle_s) for r in data.reports]
    x, y = _local_xy(net, data.reports)
    cx, cy = config.cell_of(x, y)
    windows = set()
    days = set()
    for i, r in enumerate(data.reports):
        day = config.day_of(r.t)
        days.add((day, r.vehicle_id))
        windows.add((day, config.window_of(ks[i]), int(cx[i]), int(cy[i])))
    fast = [r for r in data.reports if r.speed_mps > config.max_speed_mps]
    if fast:
        logger.warning(
            "%s: %d report(s) above max_speed_mps %.1f (fastest %.1f m/s, %s): the region "
            "margin may be too short",
            path,
            len(fast),
            config.max_speed_mps,
            max(r.speed_mps for r in fast),
            max(fast, key=lambda r: r.speed_mps).vehicle_id,
        )
    return IngestResult(
        name=data.name,
        work_file=str(out),
        rows=data.rows,
        reports=len(data.reports),
        rejected_by_reason=data.rejected_by_reason,
        vehicle_days=frozenset(days),
        windows=frozenset(windows),
    )


# ---------------------------------------------------------------------------- stage 1
@dataclass(frozen=True)
class PositionResult:
    """One vehicle-day positioned.

    Attributes
    ----------
    day : int
    vehicle_id : str
    file : str
        Its positions file (positions and analyser memory per cycle).
    reports, positions : int
    vehicle_km : float
        Distance between successive fixes at most 10 s apart, km.
    """

    day: int
    vehicle_id: str
    file: str
    reports: int
    positions: int
    vehicle_km: float


def positions_path(out_dir: str, day: int, vehicle_id: str) -> Path:
    """Where the positions of a vehicle-day are written (Hive-style day partition)."""
    return Path(out_dir) / "positions" / f"day={day}" / f"{quote(vehicle_id, safe='')}.parquet"


def position_vehicles(
    day: int,
    vehicle_ids: Sequence[str],
    work_files: Sequence[str],
    config: FleetConfig,
    out_dir: str,
) -> list[PositionResult]:
    """Stage 1: position a group of vehicles on one day, exactly as a whole-fleet replay
    would.

    Positioning is independent per vehicle (the fleet update is vectorised row by row),
    so a group shares one :class:`Analyser` — for the vectorisation — without changing
    any vehicle's positions. The group is fed in the same analysis cycles as the fleet
    replay; every vehicle's position and memory are recorded at every cycle end while it
    is in the vehicle table (dead-reckoned between its reports), and it is forgotten when
    the table would drop it. Before a cycle's reports the table's clock is moved to the
    previous cycle end, where a fleet's clock stands.
    """
    wanted = set(vehicle_ids)
    reports = [
        r for r in read_working_copy(work_files, vehicles=wanted) if config.day_of(r.t) == day
    ]
    net = load_map_cached(config.map_spec)
    c = config.cycle_s
    track = Analyser(track_map=net) if net is not None else None
    sector = Analyser()
    main = track if track is not None else sector
    rows: dict[str, list[CycleRecord]] = {v: [] for v in vehicle_ids}
    batches = {cycle_index(t, c): b for t, b in cycles(reports, c, in_time_order=True)}
    pending = sorted(batches, reverse=True)
    k = pending[-1] if pending else 0
    while pending or len(main.table):
        if not len(main.table) and pending[-1] > k:
            k = pending[-1]  # nobody to dead-reckon: jump to the next reports
        batch = batches.get(k)
        for an in (track, sector):
            if an is not None:
                an.expire((k - 1) * c)
                if batch:
                    an.update_many(batch)
                an.expire(k * c)
        if pending and pending[-1] == k:
            pending.pop()
        for vid in main.table.vehicle_ids():
            pos = None if track is None else track.position(vid, k * c, as_placed=True)
            mem_s = sector.memory(vid) if vid in sector.table else (None, None)
            mem_t = track.memory(vid) if track is not None else (None, None)
            rows[vid].append(CycleRecord(vid, k, pos, mem_t, mem_s))
        k += 1
    own_reports: dict[str, list[VehicleReport]] = defaultdict(list)
    for r in reports:  # in time order, as read
        own_reports[r.vehicle_id].append(r)
    out = []
    for vid in vehicle_ids:
        path = positions_path(out_dir, day, vid)
        path.parent.mkdir(parents=True, exist_ok=True)
        write_positions(rows[vid], path)
        own = own_reports.get(vid, [])
        out.append(PositionResult(day, vid, str(path), len(own), len(rows[vid]), _vehicle_km(own)))
    return out


def _vehicle_km(reports: Sequence[VehicleReport]) -> float:
    """Distance between successive fixes at most 10 s apart (and at most 100 m/s), on
    the WGS84 ellipsoid, km."""
    if len(reports) < 2:
        return 0.0
    lat = np.array([r.lat for r in reports], dtype=float)
    lon = np.array([r.lon for r in reports], dtype=float)
    t = np.array([r.t for r in reports], dtype=float)
    d, _ = geodesic_inverse(lat[:-1], lon[:-1], lat[1:], lon[1:])
    d = np.asarray(d, dtype=float)
    dt = np.diff(t)
    ok = (dt > 0) & (dt <= 10.0) & (d <= 100.0 * np.maximum(dt, 1e-9))
    return float(np.sum(d[ok]) / 1000.0)


# ---------------------------------------------------------------------------- stage 2
@dataclass(frozen=True)
class WindowResult:
    """One window of one region analysed.

    Attributes
    ----------
    day, window : int
    cell : (int, int)
    events_file : str or None
        Its events (None when there were none).
    events : int
    vehicle_cycles : int
        Own-vehicle assessments this task was responsible for.
    alarms : dict of (str, str) to int
        ``(analyser, kind)`` to threat observations at level warning or above.
    lamp_cycles : dict of str to int
        Per analyser, own-vehicle cycles with the lamp on.
    sector_only : dict of (int, int) to dict of str to int
        False-alarm candidates: cycles the sector rule's lamp was on and the track-aware
        analyser's was off, per hot-spot grid cell, by why (``_cleared_because``: the
        suppression reason, ``track_advisory``, or ``not_flagged``).
    included : int
        Vehicles fed to the analyser (core and margin).
    unsettled_alarms : tuple of (str, str)
        Pairs whose alarm at the window's start may differ from a continuous replay: in
        conflict since the warm-up began (see the module). Empty when the warm-up sufficed.
    """

    day: int
    window: int
    cell: tuple[int, int]
    events_file: str | None
    events: int
    vehicle_cycles: int
    alarms: dict[tuple[str, str], int] = field(default_factory=dict)
    lamp_cycles: dict[str, int] = field(default_factory=dict)
    sector_only: dict[tuple[int, int], dict[str, int]] = field(default_factory=dict)
    included: int = 0
    unsettled_alarms: tuple[tuple[str, str], ...] = ()


def analyse_window(
    day: int,
    window: int,
    cell: tuple[int, int],
    work_files: Sequence[str],
    position_files: dict[str, str],
    config: FleetConfig,
    out_dir: str,
    excluded: frozenset[str] = frozenset(),
) -> WindowResult:
    """Stage 2: the pairwise analysis of one window in one region (see module notes).

    Parameters
    ----------
    day, window : int
    cell : (int, int)
    work_files : sequence of str
        Working copies holding reports of this window.
    position_files : dict of str to str
        Vehicle id to its positions file of the day.
    config : FleetConfig
    out_dir : str
    excluded : frozenset of str
        Vehicles whose positioning failed: left out (the run is reported incomplete).
    """
    c = config.cycle_s
    lo, hi = config.bounds(day, window)
    warm = config.warmup_start(day, window)
    net = load_map_cached(config.map_spec)
    reports = [
        r
        for r in read_working_copy(work_files, t_range=((warm - 1) * c - 1.0, (hi - 1) * c + 1.0))
        if warm <= cycle_index(r.t, c) < hi and r.vehicle_id not in excluded
    ]
    x, y = _local_xy(net, reports)
    included: set[str] = set()
    if math.isinf(config.region_m) or net is None:
        included = {r.vehicle_id for r in reports}
    else:
        m, side = config.margin_m, config.region_m
        x0, y0 = cell[0] * side - m, cell[1] * side - m
        near = (x >= x0) & (x <= x0 + side + 2 * m) & (y >= y0) & (y <= y0 + side + 2 * m)
        included = {r.vehicle_id for r, ok in zip(reports, near, strict=True) if ok}
    cell_by_report: dict[tuple[str, float], tuple[int, int]] = {}
    cx, cy = config.cell_of(x, y)
    for i, r in enumerate(reports):
        cell_by_report[(r.vehicle_id, r.t)] = (int(cx[i]), int(cy[i]))
    reports = [r for r in reports if r.vehicle_id in included]
    files = [position_files[v] for v in sorted(included) if v in position_files]
    records = read_positions(files, k_range=(warm - 1, hi))
    track: Analyser | None = None
    if net is not None:
        track = Analyser(track_map=net, position_source=StoredPositions(records, c))
    sector = Analyser()
    seen: set[str] = set()
    rows: list[dict[str, Any]] = []
    alarms: Counter[tuple[str, str]] = Counter()
    lamps: Counter[str] = Counter()
    sector_only: dict[tuple[int, int], Counter[str]] = defaultdict(Counter)
    vehicle_cycles = 0
    unsettled: tuple[tuple[str, str], ...] = ()
    checked = False  # at the first cycle of the window that has reports
    for t_end, batch in cycles(reports, c):
        k = cycle_index(t_end, c)
        for r in batch:
            if r.vehicle_id not in seen:  # first report here: the memory it came with
                seen.add(r.vehicle_id)
                rec = records.get((r.vehicle_id, k - 1))
                if rec is not None:
                    sector.restore_memory(r.vehicle_id, *rec.sector)
                    if track is not None:
                        track.restore_memory(r.vehicle_id, *rec.track)
        results: dict[str, dict[str, Assessment]] = {}
        for name, an in (("track", track), ("sector", sector)):
            if an is not None:
                an.update_many(batch)
                results[name] = an.assess_all(t=t_end)
        if k < lo:
            continue
        if not checked and track is not None and warm > config.first_cycle(day):
            unsettled = _unsettled(track, warm, config, day, window, cell)
        checked = True
        main = results["track" if track is not None else "sector"]
        table = (track if track is not None else sector).table
        for own in main:
            newest = table.get(own)
            if newest is None or cell_by_report[(own, newest.t)] != cell:
                continue
            vehicle_cycles += 1
            lon, lat = _where(track, own, t_end, newest)
            for name, res in results.items():
                a = res.get(own)
                if a is None:
                    continue
                lamps[name] += a.lamp
                for th in a.threats:
                    rows.append(_event_row(name, a, th, lon, lat))
                    if th.level in _ALARM:
                        alarms[(name, th.kind)] += 1
            t_a, s_a = results.get("track", {}).get(own), results["sector"].get(own)
            if track is not None and s_a is not None and s_a.lamp and not (t_a and t_a.lamp):
                reason = _cleared_because(s_a, t_a)
                gx, gy = _hotspot_cell(net, lon, lat, config.hotspot_m)
                sector_only[(gx, gy)][reason] += 1
    events_file = None
    if rows:
        events_file = str(_write_events(rows, out_dir, day, window, cell))
    return WindowResult(
        day=day,
        window=window,
        cell=cell,
        events_file=events_file,
        events=len(rows),
        vehicle_cycles=vehicle_cycles,
        alarms=dict(alarms),
        lamp_cycles=dict(lamps),
        sector_only={k: dict(v) for k, v in sector_only.items()},
        included=len(included),
        unsettled_alarms=unsettled,
    )


def _unsettled(
    track: Analyser, warm: int, config: FleetConfig, day: int, window: int, cell: tuple[int, int]
) -> tuple[tuple[str, str], ...]:
    """Pairs in conflict since the warm-up began (their first evaluation within the time a
    vehicle stays in the table without reporting): the warm-up did not settle them."""
    since_t = warm * config.cycle_s + _TABLE_MEMORY_S
    pairs = tuple(track.alarms.unsettled(since_t))
    if pairs:
        logger.warning(
            "day %d window %d region %s: %d pair alarm(s) in conflict since the warm-up "
            "began (%s): they may differ from a continuous replay; raise --warmup",
            day,
            window,
            cell,
            len(pairs),
            ", ".join(f"{a}/{b}" for a, b in pairs[:5]),
        )
    return pairs


def _where(
    track: Analyser | None, own: str, t: float, newest: VehicleReport
) -> tuple[float, float]:
    if track is not None:
        pos = track.position(own, t, as_placed=True)
        if pos is not None:
            return pos.lon, pos.lat
    return newest.lon, newest.lat


def _cleared_because(sector: Assessment, track: Assessment | None) -> str:
    """Why the track-aware analyser did not light the lamp the sector rule lit: the
    reason it suppressed the sector rule's nearest warning (``parallel_track``...), or
    ``track_advisory`` when it saw that vehicle but below the warning level."""
    if track is None:
        return "not_assessed"
    other = next((th.vehicle_id for th in sector.threats if th.level in _ALARM), None)
    for sup in track.suppressed:
        if sup.vehicle_id == other:
            return sup.reason
    for th in track.threats:
        if th.vehicle_id == other:
            return f"track_{th.level}"
    return "not_flagged"


def _hotspot_cell(net: Any, lon: float, lat: float, size_m: float) -> tuple[int, int]:
    x, y = net.to_local(lon, lat)
    return math.floor(float(x) / size_m), math.floor(float(y) / size_m)


def _event_row(name: str, a: Assessment, th: Any, lon: float, lat: float) -> dict[str, Any]:
    return {"analyser": name, **event_values(a, th), "lon": lon, "lat": lat}


def _write_events(
    rows: list[dict[str, Any]], out_dir: str, day: int, window: int, cell: tuple[int, int]
) -> Path:
    import pyarrow as pa
    import pyarrow.parquet as pq

    d = Path(out_dir) / "events" / f"day={day}"
    d.mkdir(parents=True, exist_ok=True)
    path = d / f"w{window:07d}_x{cell[0]:+05d}_y{cell[1]:+05d}.parquet"
    cols = {f: [r[f] for r in rows] for f in EVENT_FIELDS}
    schema = pa.schema(
        [
            (
                f,
                pa.string()
                if f in ("analyser", "own_id", "other_id", "level", "kind", "method", "zone")
                else pa.float64(),
            )
            for f in EVENT_FIELDS
        ]
    )
    pq.write_table(pa.table(cols, schema=schema), path)
    return path
