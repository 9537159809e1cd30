"""Reproducible tram traffic simulator over a :class:`~trackmap.TrackMap`.

The simulator drives trams along fixed routes of a track map with a look-ahead driver
model, records their true state every time step and turns it into noisy GPS reports
(:class:`~antikol.report.VehicleReport`), a replay CSV and per-vehicle NMEA logs. It is the
source of ground truth for tests, benchmarks and comparisons.

>>> import trackmap
>>> from antikol.sim.simulation import Simulator, fleet
>>> net = trackmap.load_default()
>>> trams = fleet(net, 20, 1)  # 20 trams on random main-line routes
>>> result = Simulator(net, trams, seed=1).run(1800.0)  # doctest: +SKIP
>>> result.write_csv("city.csv")  # doctest: +SKIP

Units are SI throughout (m, s, m/s, m/s²). Route distances are metres along a route from
its start position; track positions are ``(edge_id, offset_m, direction)`` as in
:mod:`trackmap.network`.

Models
------
Routes
    A :class:`Route` is a sequence of ``(edge_id, direction)`` steps of which every
    consecutive pair is an arc of ``net.traversal`` (a permitted move), with a start offset
    on the first edge and an end offset on the last.
Allowed speed
    On a grid along the route (every ``grid_m``, 2 m by default) the *limit* is the minimum
    of the edge's ``maxspeed_mps`` (or ``default_speed_mps``, 50 km/h), the vehicle's
    maximum speed and the curve speed ``sqrt(a_lat · R)``. The curve radius ``R`` comes from
    the turning of the track heading: the heading at ``s`` is the direction of the chord
    from ``s − 4 m`` to ``s + 4 m`` of the route polyline (exact on a circular arc, and it
    smooths the kinks of digitised OSM geometry), and ``1/R`` is the heading change between
    ``s − 4 m`` and ``s + 4 m`` divided by 8 m; a kink of coarse geometry thus reads as a
    tight curve (conservative). Edge limits are spread to the grid points on both sides of
    an edge, so linear interpolation never exceeds the limit of any edge however short,
    and curve limits over ±8 m, the reach of the estimate. The driver's
    *target* is ``cruise_factor`` times the minimum of the limit over the train's length
    (a restriction holds until the rear has cleared it), and the *envelope* is the highest
    speed from which every lower target ahead (and a stop at the route end) can be met with
    the planning deceleration.
Driver
    Each step the driver takes the largest acceleration that keeps the tram under every
    braking curve after the step: the envelope (linearised in ``v²``), the next stop, the
    route end, the leader and any conflict point where it has to yield. For a target at
    distance ``D`` with speed ``v_t`` the condition ``v(t+dt)² ≤ v_t² + 2·b·(D − Δs)`` with
    ``Δs = v·dt + a·dt²/2`` is a quadratic in ``a`` solved exactly, so a tram following a
    braking curve stops *exactly* at its target. Acceleration is limited by the profile's
    traction; planned braking uses ``comfort_decel_mps2`` (default 0.8 × service) and may
    use the full service brake; only the safety constraints (leader, conflict) may go
    beyond the service brake, up to the emergency brake, and then the report carries
    ``braking="emergency"``.
Car following
    Leaders are other trams whose front or rear lies on this tram's route ahead within its
    look-ahead, whatever their own route (an oncoming tram on single track counts too; a
    tram that joined the route at a merge occupies it only from the merge on). The driver
    plans to stay ``standstill_gap_m + time_headway_s·v`` behind the point where the leader
    would stop with its service brake (Gipps' safe-speed idea), with comfort braking; the
    safety constraint is the service-brake curve to ``standstill_gap_m`` behind that point,
    so a leader appearing too close costs a strong brake, not an emergency. Against an
    oncoming tram the driver subtracts that tram's stopping distance instead. Leaders are
    searched every 0.5 s (one vectorised look-up for all trams) and tracked in between.
Conflict points
    With ``yield_at_conflicts`` (default) trams do not run through each other at merges,
    diamond crossings and at-grade crossings: a tram claims a conflict point when it comes
    within its braking distance plus 30 m of the fouling area; of two trams arriving on
    different tracks the one that claimed first goes (a tram already in the fouling area
    always goes; ties go to the tram earlier in the list) and the other stops at the
    fouling point until the first has cleared it. Trams queued on the same track never
    compete. The fouling extents are the map's, widened at diamond crossings to the
    clearance the crossing angle needs (:func:`crossing_clearance_m`). This is a driver's
    give-way, not an interlocking: trams running head-on into a single-track section can
    still meet and stop nose to nose.
Stops and events
    The front stops at every stop position on the route (exactly, within 0.1 m), waits
    ``dwell_s`` and leaves with the traction limit. At the route end the tram stops and
    stays (an obstacle for others), or with ``exit_at_end`` drives on and leaves. A
    :class:`ScriptEvent` can brake to a standstill with the emergency brake (after the
    profile's emergency build-up time, so the stopping distance equals
    :func:`antikol.analysis.braking.stopping_distance` with ``brake="emergency"`` less its
    standstill margin), hold the tram, cap its speed or make the driver ignore leaders and conflicts
    (to stage collisions).
GPS
    See :class:`GpsModel`: white noise plus a Gauss–Markov bias per axis on the antenna
    position, outliers, missing fixes, tunnel dropouts, and speed and course from a noisy
    velocity vector with a static-hold course at standstill. Report times ``t`` are
    simulation seconds; NMEA logs carry ``epoch_utc_s + t`` as UTC.

Reproducibility: the dynamics are deterministic; each tram's GPS noise comes from its own
generators seeded from ``(seed, vehicle_id)``, drawn one row of numbers per fix epoch, so
adding a tram, or running longer, does not change another tram's noise.
"""

from __future__ import annotations

import csv
import functools
import hashlib
import itertools
import logging
import math
import os
import time
import weakref
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any, Final, Literal

import networkx as nx
import numpy as np
import numpy.typing as npt
import shapely

from antikol.analysis.braking import BrakingProfile, load_profile
from antikol.ingest.nmea import format_gga, format_rmc, format_vtg
from antikol.report import MAX_ROUTE_EDGES, MAX_VEHICLE_ID_BYTES, BrakeState, VehicleReport
from trackmap import ConflictPoint, Stop, TrackMap

__all__ = [
    "CSV_EXTRA_COLUMNS",
    "CSV_HEADER",
    "DEFAULT_DWELL_S",
    "DEFAULT_EPOCH_UTC_S",
    "DEFAULT_SPEED_MPS",
    "EVENT_KINDS",
    "EventKind",
    "FixLog",
    "GpsModel",
    "Route",
    "ScriptEvent",
    "SimulationResult",
    "Simulator",
    "SpeedPlan",
    "StopCall",
    "TramSpec",
    "Truth",
    "TruthState",
    "crossing_clearance_m",
    "fleet",
    "map_stops_on_route",
    "random_route",
    "route_from_edges",
]

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

#: Speed on edges without a ``maxspeed`` tag, m/s (50 km/h).
DEFAULT_SPEED_MPS: Final = 50.0 / 3.6
#: Default dwell time at a stop, s.
DEFAULT_DWELL_S: Final = 20.0
#: Default UTC time of simulation time 0 (2023-11-14 22:13:20 UTC), s since the Unix epoch.
DEFAULT_EPOCH_UTC_S: Final = 1_700_000_000.0
#: The replay CSV columns, in order (extra columns may follow).
CSV_HEADER: Final = ("vehicle_id", "t", "lat", "lon", "speed_mps", "course_deg")
#: Extra CSV columns :meth:`SimulationResult.write_csv` can append.
CSV_EXTRA_COLUMNS: Final = ("braking", "length_m", "antenna_offset_m", "seq")

EventKind = Literal["emergency_brake", "hold", "speed_cap", "inattentive"]
#: The kinds of :class:`ScriptEvent`.
EVENT_KINDS: Final[tuple[EventKind, ...]] = ("emergency_brake", "hold", "speed_cap", "inattentive")

_BRAKE_NAMES: Final[tuple[BrakeState, ...]] = ("none", "service", "emergency")
_CHORD_HALF_M: Final = 4.0  # curve radius: half chord of the heading estimate
_CURVE_HALF_M: Final = 4.0  # curve radius: half window of the heading difference
_MIN_RADIUS_M: Final = 1.0
_DETECT_EVERY_S: Final = 0.5  # leader and conflict search period
_CLAIM_MARGIN_M: Final = 30.0  # conflict claim distance beyond the braking distance
_OCCUPY_TOL_M: Final = 0.5  # a front this far into a fouling area occupies it
_ARRIVE_TOL_M: Final = 0.1  # a tram this close to its stop (and stopped) has arrived
_BRAKE_FLAG_MPS2: Final = 0.05  # deceleration above which the service brake is reported
_COMFORT_FRACTION: Final = 0.8  # default planning deceleration / service deceleration


# =========================================================================== routes
@dataclass(frozen=True)
class Route:
    """A path through the track map along permitted moves.

    Build one with :meth:`from_steps`, :func:`random_route` or :func:`route_from_edges`,
    which check the steps against the map; the constructor itself checks only the
    internal consistency (it has no map).

    Route distances are metres from the start position (``start_offset_m`` on the first
    step's edge) along the steps, from 0 to :attr:`length_m`.

    Attributes
    ----------
    steps : tuple of (int, int)
        ``(edge_id, direction)`` in running order; direction +1 runs along the edge's
        vertices, -1 against them. Consecutive steps are arcs of ``net.traversal``.
    edge_lengths_m : tuple of float
        Length of each step's edge, metres.
    start_offset_m : float
        Start position on the first edge, metres from its first vertex.
    end_offset_m : float
        End position on the last edge, metres from its first vertex.
    """

    steps: tuple[tuple[int, int], ...]
    edge_lengths_m: tuple[float, ...]
    start_offset_m: float
    end_offset_m: float

    def __post_init__(self) -> None:
        steps = tuple((int(e), int(d)) for e, d in self.steps)
        lengths = tuple(float(x) for x in self.edge_lengths_m)
        object.__setattr__(self, "steps", steps)
        object.__setattr__(self, "edge_lengths_m", lengths)
        object.__setattr__(self, "start_offset_m", float(self.start_offset_m))
        object.__setattr__(self, "end_offset_m", float(self.end_offset_m))
        if not steps:
            raise ValueError("a route needs at least one step")
        if len(lengths) != len(steps):
            raise ValueError(f"route has {len(steps)} steps but {len(lengths)} edge lengths")
        for k, ((edge_id, direction), length) in enumerate(zip(steps, lengths, strict=True)):
            if direction not in (1, -1):
                raise ValueError(f"route step {k} (edge {edge_id}): direction must be +1 or -1")
            if not (math.isfinite(length) and length > 0.0):
                raise ValueError(f"route step {k} (edge {edge_id}): length {length!r} m")
        tol = 1e-6
        if not -tol <= self.start_offset_m <= lengths[0] + tol:
            raise ValueError(
                f"start_offset_m={self.start_offset_m!r} is outside edge {steps[0][0]} "
                f"(0..{lengths[0]:.3f} m)"
            )
        if not -tol <= self.end_offset_m <= lengths[-1] + tol:
            raise ValueError(
                f"end_offset_m={self.end_offset_m!r} is outside edge {steps[-1][0]} "
                f"(0..{lengths[-1]:.3f} m)"
            )
        if self.length_m < -tol:
            raise ValueError(
                f"the route ends {-self.length_m:.3f} m before it starts on edge {steps[0][0]}"
            )

    # -- construction ------------------------------------------------------------------
    @classmethod
    def from_steps(
        cls,
        net: TrackMap,
        steps: Iterable[tuple[int, int]],
        *,
        start_offset_m: float | None = None,
        end_offset_m: float | None = None,
    ) -> Route:
        """A route from ``(edge_id, direction)`` steps, checked against the map.

        Parameters
        ----------
        net : TrackMap
        steps : iterable of (int, int)
            ``(edge_id, direction)`` in running order.
        start_offset_m : float, optional
            Start on the first edge, metres from its first vertex; default the edge's
            entry end (0 for direction +1, its length for -1).
        end_offset_m : float, optional
            End on the last edge, metres from its first vertex; default its exit end.

        Returns
        -------
        Route

        Raises
        ------
        trackmap.UnknownEdgeError
            A step names an edge the map does not have.
        ValueError
            A step runs against the edge's permitted direction, two consecutive steps are
            not a permitted move (the message names the pair), or an offset is outside
            its edge.
        """
        steps = tuple((int(e), int(d)) for e, d in steps)
        if not steps:
            raise ValueError("a route needs at least one step")
        for k, (edge_id, direction) in enumerate(steps):
            edge = net.edge(edge_id)
            if direction not in (1, -1):
                raise ValueError(f"route step {k} (edge {edge_id}): direction must be +1 or -1")
            if not edge.allows(direction):
                raise ValueError(
                    f"route step {k}: edge {edge_id} does not permit running direction "
                    f"{direction:+d} (permitted: {edge.direction:+d})"
                )
        for k, (a, b) in enumerate(itertools.pairwise(steps)):
            if not net.traversal.has_edge(a, b):
                raise ValueError(
                    f"route steps {k} and {k + 1}: {a} -> {b} is not a permitted move"
                    + _move_hint(net, a, b)
                )
        lengths = tuple(net.edge_length(e) for e, _ in steps)
        if start_offset_m is None:
            start_offset_m = 0.0 if steps[0][1] == 1 else lengths[0]
        if end_offset_m is None:
            end_offset_m = lengths[-1] if steps[-1][1] == 1 else 0.0
        return cls(steps, lengths, float(start_offset_m), float(end_offset_m))

    # -- basic facts -------------------------------------------------------------------
    @property
    def edge_ids(self) -> tuple[int, ...]:
        """Edge ids in running order."""
        return tuple(e for e, _ in self.steps)

    @cached_property
    def _entry_m(self) -> FloatArray:
        """Route distance of each step's edge entry (negative for the first step)."""
        lengths = np.asarray(self.edge_lengths_m, dtype=float)
        first_d = self.steps[0][1]
        behind = self.start_offset_m if first_d == 1 else lengths[0] - self.start_offset_m
        entry = np.concatenate(([0.0], np.cumsum(lengths[:-1]))) - behind
        return entry

    @property
    def length_m(self) -> float:
        """Length from the start to the end position, metres."""
        last_d = self.steps[-1][1]
        last_len = self.edge_lengths_m[-1]
        into_last = self.end_offset_m if last_d == 1 else last_len - self.end_offset_m
        return float(self._entry_m[-1] + into_last)

    def __len__(self) -> int:
        return len(self.steps)

    # -- conversions -------------------------------------------------------------------
    def locate(self, distance_m: float) -> tuple[int, float, int]:
        """Track position at a route distance.

        Parameters
        ----------
        distance_m : float
            Route distance, metres, in ``[0, length_m]``.

        Returns
        -------
        edge_id : int
        offset_m : float
            Metres from the edge's first vertex.
        direction : int
            Running direction on the edge (+1/-1).

        Raises
        ------
        ValueError
            The distance is outside the route.
        """
        e, o, d = self.locate_array(np.array([float(distance_m)]))
        return int(e[0]), float(o[0]), int(d[0])

    def locate_array(self, distances_m: npt.ArrayLike) -> tuple[IntArray, FloatArray, IntArray]:
        """Vectorised :meth:`locate`: arrays of edge ids, offsets (m) and directions.

        At a junction a distance maps to the start of the later step.
        """
        dist = np.asarray(distances_m, dtype=float)
        length = self.length_m
        bad = ~((dist >= -1e-6) & (dist <= length + 1e-6))
        if bad.any():
            raise ValueError(
                f"route distance {float(dist[bad].flat[0])!r} m is outside the route "
                f"(0..{length:.3f} m)"
            )
        return _locate(
            self._entry_m,
            np.asarray(self.edge_ids, dtype=np.int64),
            np.array([d for _, d in self.steps], dtype=np.int64),
            np.asarray(self.edge_lengths_m, dtype=float),
            dist,
        )

    def distance_of(self, edge_id: int, offset_m: float, *, after_m: float = 0.0) -> float | None:
        """Route distance of a track position, or None when the route does not pass it.

        Parameters
        ----------
        edge_id : int
        offset_m : float
            Metres from the edge's first vertex.
        after_m : float
            Return the first passage at or after this route distance, metres (routes may
            pass an edge twice).

        Returns
        -------
        float or None
        """
        d = self.distances_of(np.array([edge_id]), np.array([offset_m]), after_m=after_m)
        return None if np.isnan(d[0]) else float(d[0])

    def distances_of(
        self, edge_ids: npt.ArrayLike, offsets_m: npt.ArrayLike, *, after_m: float = 0.0
    ) -> FloatArray:
        """Vectorised :meth:`distance_of`: route distances (m), NaN where not on the route."""
        e = np.atleast_1d(np.asarray(edge_ids, dtype=np.int64))
        o = np.atleast_1d(np.asarray(offsets_m, dtype=float))
        if e.shape != o.shape:
            raise ValueError(f"{e.shape[0]} edge ids but {o.shape[0]} offsets")
        route_e = np.asarray(self.edge_ids, dtype=np.int64)
        route_d = np.array([d for _, d in self.steps], dtype=np.int64)
        lengths = np.asarray(self.edge_lengths_m, dtype=float)
        match = e[:, None] == route_e[None, :]
        rel = np.where(route_d[None, :] > 0, o[:, None], lengths[None, :] - o[:, None])
        dist = self._entry_m[None, :] + rel
        ok = (
            match
            & (dist >= max(after_m, 0.0) - 1e-9)
            & (dist <= self.length_m + 1e-9)
            & (rel >= -1e-9)
            & (rel <= lengths[None, :] + 1e-9)
        )
        dist = np.where(ok, dist, np.inf)
        best = dist.min(axis=1, initial=np.inf)
        return np.where(np.isfinite(best), best, np.nan)

    def edges_ahead(self, distance_m: float, *, limit: int = MAX_ROUTE_EDGES) -> tuple[int, ...]:
        """Edge ids from the one at a route distance to the end, at most ``limit`` of them."""
        k = int(np.searchsorted(self._entry_m, float(distance_m), side="right") - 1)
        k = min(max(k, 0), len(self.steps) - 1)
        return self.edge_ids[k : k + limit]

    def xy(self, net: TrackMap, distances_m: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Local (x, y) of route distances, metres (shapely; not for inner loops)."""
        e, o, _ = self.locate_array(np.atleast_1d(np.asarray(distances_m, dtype=float)))
        x, y = net.points_at(e, o)
        return np.asarray(x, dtype=float), np.asarray(y, dtype=float)


def _locate(
    entry: FloatArray, edges: IntArray, dirs: IntArray, lengths: FloatArray, dist: FloatArray
) -> tuple[IntArray, FloatArray, IntArray]:
    k = np.clip(np.searchsorted(entry, dist, side="right") - 1, 0, len(entry) - 1)
    rel = dist - entry[k]
    off = np.where(dirs[k] > 0, rel, lengths[k] - rel)
    off = np.clip(off, 0.0, lengths[k])
    return edges[k], off, dirs[k]


def _move_hint(net: TrackMap, a: tuple[int, int], b: tuple[int, int]) -> str:
    try:
        physical = b in net.successors(a[0], a[1], respect_direction=False)
    except TypeError:  # an older TrackMap without respect_direction
        physical = False
    if physical:
        return " (the tracks connect, but only against a permitted running direction)"
    return ""


# -- route construction ----------------------------------------------------------------
@dataclass(frozen=True)
class _StartTable:
    states: tuple[tuple[int, int], ...]  # the main line's largest strongly connected part
    members: frozenset[tuple[int, int]]
    cum_m: FloatArray  # cumulative track length over ``states``
    all_states: tuple[tuple[int, int], ...]
    all_cum_m: FloatArray


_START_CACHE: dict[int, tuple[weakref.ref[TrackMap], _StartTable]] = {}


def _start_table(net: TrackMap) -> _StartTable:
    """Where random routes may start (cached per map)."""
    hit = _START_CACHE.get(id(net))
    if hit is not None and hit[0]() is net:
        return hit[1]
    main = [s for s in net.traversal.nodes if net.edges[s[0]].service is None]
    comps: list[set[tuple[int, int]]] = list(
        nx.strongly_connected_components(net.traversal.subgraph(main))
    )
    best = sorted(comps[int(np.argmax([len(c) for c in comps]))]) if comps else []
    every = sorted(net.traversal.nodes)

    def cum(states: Sequence[tuple[int, int]]) -> FloatArray:
        return np.cumsum([net.edge_length(e) for e, _ in states], dtype=np.float64)

    table = _StartTable(tuple(best), frozenset(best), cum(best), tuple(every), cum(every))
    _START_CACHE[id(net)] = (weakref.ref(net), table)
    return table


def _as_generator(rng: np.random.Generator | int | None) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    return np.random.default_rng(rng)


def _random_start(
    net: TrackMap, gen: np.random.Generator, *, prefer_main: bool
) -> tuple[tuple[int, int], float]:
    """A random running position, uniform along the track."""
    table = _start_table(net)
    states, cum = (table.states, table.cum_m) if prefer_main else ((), np.zeros(0))
    if not states:
        states, cum = table.all_states, table.all_cum_m
    if not states:
        raise ValueError("the map has no track a tram may run on")
    u = float(gen.uniform(0.0, cum[-1]))
    k = min(int(np.searchsorted(cum, u, side="right")), len(states) - 1)
    edge_id, direction = states[k]
    length = net.edge_length(edge_id)
    offset = min(max(u - (cum[k] - length), 0.0), length)
    return (edge_id, direction), offset


def random_route(
    net: TrackMap,
    rng: np.random.Generator | int | None,
    *,
    length_m: float,
    start: tuple[int, float, int] | None = None,
    prefer_main: bool = True,
) -> Route:
    """A random walk along permitted moves.

    Parameters
    ----------
    net : TrackMap
    rng : numpy.random.Generator or int or None
        Random source (an int seeds a new generator).
    length_m : float
        Wanted route length, metres (> 0). The route is shorter only at a dead end.
    start : (edge_id, offset_m, direction), optional
        Start position; default a random position on the map, uniform along the track
        (on the main line's largest strongly connected part when ``prefer_main``).
    prefer_main : bool
        Avoid ``service`` tracks (yards, sidings, spurs, crossovers) and moves that leave
        the main line's strongly connected part (which lead to dead ends) whenever another
        branch is possible.

    Returns
    -------
    Route

    Raises
    ------
    ValueError
        ``length_m`` is not positive, or ``start`` is not a permitted running position.
    """
    if not (math.isfinite(length_m) and length_m > 0.0):
        raise ValueError(f"length_m must be a positive number of metres, got {length_m!r}")
    gen = _as_generator(rng)
    if start is None:
        state, offset = _random_start(net, gen, prefer_main=prefer_main)
    else:
        edge_id, offset, direction = int(start[0]), float(start[1]), int(start[2])
        edge = net.edge(edge_id)
        if direction not in (1, -1) or not edge.allows(direction):
            raise ValueError(
                f"start: edge {edge_id} does not permit running direction {direction!r} "
                f"(permitted: {edge.direction:+d})"
            )
        if not 0.0 <= offset <= net.edge_length(edge_id):
            raise ValueError(
                f"start offset {offset!r} m is outside edge {edge_id} "
                f"(0..{net.edge_length(edge_id):.3f} m)"
            )
        state = (edge_id, direction)
    main = _start_table(net).members if prefer_main else frozenset()
    first_len = net.edge_length(state[0])
    ahead = first_len - offset if state[1] == 1 else offset
    steps = [state]
    remaining = length_m - ahead
    while remaining > 0.0:
        succ = sorted(net.successors(*steps[-1]))
        if prefer_main and succ:
            on_main = [s for s in succ if net.edges[s[0]].service is None]
            in_scc = [s for s in on_main if s in main]
            succ = in_scc or on_main or succ
        if not succ:
            logger.debug("random_route: dead end after %d steps", len(steps))
            remaining = 0.0
            break
        nxt = succ[int(gen.integers(len(succ)))]
        steps.append(nxt)
        remaining -= net.edge_length(nxt[0])
    last_e, last_d = steps[-1]
    last_len = net.edge_length(last_e)
    overshoot = -remaining  # how far the last edge extends beyond the wanted length
    if len(steps) == 1:
        end = offset + last_d * min(length_m, ahead)
    else:
        end = last_len - overshoot if last_d == 1 else overshoot
    end = min(max(end, 0.0), last_len)
    return Route.from_steps(net, steps, start_offset_m=offset, end_offset_m=end)


def route_from_edges(
    net: TrackMap,
    edge_ids: Sequence[int],
    *,
    start_offset_m: float | None = None,
    end_offset_m: float | None = None,
    direction: int | None = None,
) -> Route:
    """A route through a list of edges, the running directions inferred.

    Parameters
    ----------
    net : TrackMap
    edge_ids : sequence of int
        Edges in running order.
    start_offset_m, end_offset_m : float, optional
        Start on the first and end on the last edge, metres from their first vertex;
        default the whole edges.
    direction : int, optional
        Running direction on the first edge, for a one-edge route or when the edges can
        be run both ways; default: inferred (+1 when still ambiguous).

    Returns
    -------
    Route

    Raises
    ------
    trackmap.UnknownEdgeError
        An edge id is not in the map.
    ValueError
        Two consecutive edges are not connected by a permitted move (the message names the
        pair and their positions in the list), or ``direction`` is not permitted.
    """
    ids = [int(e) for e in edge_ids]
    if not ids:
        raise ValueError("route_from_edges needs at least one edge id")
    for e in ids:
        net.edge(e)
    if direction is not None and direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    first = net.edges[ids[0]]
    cand = [direction] if direction is not None else [d for d in (1, -1) if first.allows(d)]
    cand = [d for d in cand if first.allows(d)]
    if not cand:
        raise ValueError(
            f"edge {ids[0]} does not permit running direction {direction!r} "
            f"(permitted: {first.direction:+d})"
        )
    layers: list[dict[int, int | None]] = [{d: None for d in cand}]
    for k in range(1, len(ids)):
        cur: dict[int, int | None] = {}
        for d_prev in sorted(layers[-1], reverse=True):
            for e2, d2 in net.successors(ids[k - 1], d_prev):
                if e2 == ids[k] and d2 not in cur:
                    cur[d2] = d_prev
        if not cur:
            hint = ""
            for d_prev in layers[-1]:
                for d2 in (1, -1):
                    hint = hint or _move_hint(net, (ids[k - 1], d_prev), (ids[k], d2))
            raise ValueError(
                f"edges {ids[k - 1]} and {ids[k]} (positions {k - 1} and {k} in the list) "
                f"are not connected by a permitted move{hint}"
            )
        layers.append(cur)
    d_last = 1 if 1 in layers[-1] else -1
    dirs = [d_last]
    for k in range(len(ids) - 1, 0, -1):
        prev = layers[k][dirs[-1]]
        assert prev is not None
        dirs.append(prev)
    dirs.reverse()
    return Route.from_steps(
        net,
        list(zip(ids, dirs, strict=True)),
        start_offset_m=start_offset_m,
        end_offset_m=end_offset_m,
    )


def map_stops_on_route(net: TrackMap, route: Route) -> tuple[tuple[float, Stop], ...]:
    """The map's stops the route passes, with their route distances (m), in order.

    A stop on an edge the route runs twice is listed twice.
    """
    by_edge: dict[int, list[Stop]] = {}
    for stop in net.stops:
        if stop.edge_id is not None and stop.offset_m is not None:
            by_edge.setdefault(stop.edge_id, []).append(stop)
    out: list[tuple[float, Stop]] = []
    entry = route._entry_m
    length = route.length_m
    for k, (edge_id, d) in enumerate(route.steps):
        for stop in by_edge.get(edge_id, ()):
            assert stop.offset_m is not None
            rel = stop.offset_m if d == 1 else route.edge_lengths_m[k] - stop.offset_m
            dist = float(entry[k] + rel)
            if -1e-9 <= dist <= length + 1e-9:
                out.append((dist, stop))
    out.sort(key=lambda item: item[0])
    return tuple(out)


# =========================================================================== vehicles
@dataclass(frozen=True, slots=True)
class StopCall:
    """A planned stop: where the front stops and for how long.

    Attributes
    ----------
    distance_m : float
        Route distance of the stop position of the front, metres.
    dwell_s : float
        Time standing at the stop, s.
    name : str or None
    """

    distance_m: float
    dwell_s: float = DEFAULT_DWELL_S
    name: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "distance_m", float(self.distance_m))
        object.__setattr__(self, "dwell_s", float(self.dwell_s))
        if not math.isfinite(self.distance_m):
            raise ValueError(f"stop distance_m must be finite, got {self.distance_m!r}")
        if not (math.isfinite(self.dwell_s) and self.dwell_s >= 0.0):
            raise ValueError(f"stop dwell_s must be >= 0 s, got {self.dwell_s!r}")


@dataclass(frozen=True, slots=True)
class ScriptEvent:
    """A timed driver action in a scenario.

    Use the constructors :meth:`emergency_brake`, :meth:`hold`, :meth:`speed_cap` and
    :meth:`inattentive`, or :meth:`parse` a tuple.

    Attributes
    ----------
    kind : {"emergency_brake", "hold", "speed_cap", "inattentive"}
        ``emergency_brake``: from ``t_s`` the traction is cut, and after the profile's
        emergency build-up time the tram decelerates at the emergency rate to a
        standstill; it stays there until ``until_s`` (None: for good). Reports carry
        ``braking="emergency"`` from ``t_s`` to ``until_s``.
        ``hold``: from ``t_s`` to ``until_s`` the driver brakes to a standstill (planning
        deceleration) and waits.
        ``speed_cap``: from ``t_s`` to ``until_s`` the tram runs at most ``speed_mps``.
        ``inattentive``: from ``t_s`` to ``until_s`` the driver ignores leaders and
        conflict points (stops, speed limits and the route end are still kept).
    t_s : float
        Start, simulation seconds.
    until_s : float or None
        End, simulation seconds; None: until the end of the run.
    speed_mps : float or None
        The cap of ``speed_cap``, m/s.
    """

    kind: EventKind
    t_s: float
    until_s: float | None = None
    speed_mps: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in EVENT_KINDS:
            raise ValueError(f"unknown script event kind {self.kind!r}; use one of {EVENT_KINDS}")
        if not (isinstance(self.t_s, int | float) and math.isfinite(self.t_s)):
            raise ValueError(f"{self.kind} event: t_s must be a finite time, got {self.t_s!r}")
        object.__setattr__(self, "t_s", float(self.t_s))
        if self.until_s is not None:
            if not (math.isfinite(self.until_s) and self.until_s >= self.t_s):
                raise ValueError(
                    f"{self.kind} event: until_s={self.until_s!r} must be >= t_s={self.t_s!r}"
                )
            object.__setattr__(self, "until_s", float(self.until_s))
        if self.kind == "speed_cap":
            if self.speed_mps is None or not (
                math.isfinite(self.speed_mps) and self.speed_mps >= 0.0
            ):
                raise ValueError(
                    f"speed_cap event needs speed_mps >= 0 m/s, got {self.speed_mps!r}"
                )
            object.__setattr__(self, "speed_mps", float(self.speed_mps))
        elif self.speed_mps is not None:
            raise ValueError(f"{self.kind} event takes no speed_mps")

    @classmethod
    def emergency_brake(cls, t_s: float, *, release_s: float | None = None) -> ScriptEvent:
        """Emergency brake at ``t_s`` (s); the driver releases at ``release_s`` (s) or never."""
        return cls("emergency_brake", t_s, release_s)

    @classmethod
    def hold(cls, t_from_s: float, t_to_s: float | None) -> ScriptEvent:
        """Stop as soon as comfortably possible at ``t_from_s`` and wait until ``t_to_s`` (s)."""
        return cls("hold", t_from_s, t_to_s)

    @classmethod
    def speed_cap(
        cls, t_s: float, speed_mps: float, *, until_s: float | None = None
    ) -> ScriptEvent:
        """Run at most ``speed_mps`` (m/s) from ``t_s`` until ``until_s`` (s)."""
        return cls("speed_cap", t_s, until_s, speed_mps)

    @classmethod
    def inattentive(cls, t_from_s: float, t_to_s: float | None = None) -> ScriptEvent:
        """Ignore leaders and conflict points from ``t_from_s`` until ``t_to_s`` (s)."""
        return cls("inattentive", t_from_s, t_to_s)

    @classmethod
    def parse(cls, item: ScriptEvent | Sequence[Any]) -> ScriptEvent:
        """An event from a tuple.

        Accepted: ``("emergency_brake", t[, release])``, ``("hold", t_from, t_to)``,
        ``("speed_cap", t, v[, until])``, ``("inattentive", t_from[, t_to])``.

        Raises
        ------
        ValueError
            Unknown kind or wrong number of values.
        """
        if isinstance(item, ScriptEvent):
            return item
        if isinstance(item, str) or not isinstance(item, Sequence) or not item:
            raise ValueError(f"a script event must be a ScriptEvent or a tuple, got {item!r}")
        kind, *args = item
        if kind not in EVENT_KINDS:
            raise ValueError(f"unknown script event kind {kind!r}; use one of {EVENT_KINDS}")
        arity = {"emergency_brake": (1, 2), "hold": (2, 2), "speed_cap": (2, 3)}
        lo, hi = arity.get(str(kind), (1, 2))
        if not lo <= len(args) <= hi:
            raise ValueError(
                f"cannot read script event {tuple(item)!r}: expected ('emergency_brake', t"
                "[, release]), ('hold', t_from, t_to), ('speed_cap', t, v[, until]) or "
                "('inattentive', t_from[, t_to])"
            )
        if kind == "speed_cap":
            return cls("speed_cap", args[0], args[2] if len(args) > 2 else None, args[1])
        return cls(kind, args[0], args[1] if len(args) > 1 else None)

    def active(self, t_s: float) -> bool:
        """Whether the event is in force at simulation time ``t_s`` (s)."""
        return self.t_s <= t_s < (math.inf if self.until_s is None else self.until_s)


@functools.lru_cache(maxsize=1)
def _tram_profile() -> BrakingProfile:
    return load_profile("tram")


@dataclass(frozen=True)
class TramSpec:
    """One simulated tram: route, vehicle, driver and timetable.

    Parameters
    ----------
    vehicle_id : str
        1 to 32 UTF-8 bytes, printable (it becomes a report field and an NMEA file name).
    route : Route
    length_m : float
        Vehicle length, metres (default 32).
    antenna_offset_m : float, optional
        Distance from the front back to the GPS antenna, metres; default half the length.
    profile : BrakingProfile
        Traction and brakes; default the shipped ``tram`` profile.
    depart_s : float
        Simulation time at which the tram appears at its start, s. It waits (absent) while
        another tram blocks the start.
    initial_speed_mps : float
        Speed when it appears, m/s.
    max_speed_mps : float, optional
        Vehicle maximum speed, m/s; default the profile's.
    stops : sequence of StopCall or (distance_m, dwell_s), optional
        Planned stops (route distances of the front, m, and dwell times, s); default every
        map stop on the route (:func:`map_stops_on_route`) with ``dwell_s``. Pass ``()``
        for a non-stop run.
    dwell_s : float
        Dwell time of the default stops, s (default 20).
    cruise_factor : float
        Fraction of the allowed speed the driver aims at, in (0, 1] (default 0.95).
    script : sequence of ScriptEvent or tuple
        Timed events (tuples are read with :meth:`ScriptEvent.parse`).
    broadcast_route : bool
        Put the route's edge ids ahead (at most 255) in every report.
    exit_at_end : bool
        Drive through the route end and leave the simulation there, instead of stopping at
        the end and staying.
    lateral_accel_mps2 : float
        Lateral acceleration allowed in curves, m/s² (default 1.0).
    standstill_gap_m : float
        Gap kept to a stopped leader, metres (default 10).
    time_headway_s : float
        Time headway kept to a moving leader, s (default 2): the gap is
        ``standstill_gap_m + time_headway_s · speed``.
    comfort_decel_mps2 : float, optional
        Deceleration the driver plans with, m/s²; default 0.8 × the service brake. It may
        exceed neither the service brake.

    Raises
    ------
    ValueError
        A value is out of range; the message names the field and the vehicle.
    """

    vehicle_id: str
    route: Route
    length_m: float = 32.0
    antenna_offset_m: float | None = None
    profile: BrakingProfile = field(default_factory=_tram_profile)
    depart_s: float = 0.0
    initial_speed_mps: float = 0.0
    max_speed_mps: float | None = None
    stops: tuple[StopCall, ...] | None = None
    dwell_s: float = DEFAULT_DWELL_S
    cruise_factor: float = 0.95
    script: tuple[ScriptEvent, ...] = ()
    broadcast_route: bool = False
    exit_at_end: bool = False
    lateral_accel_mps2: float = 1.0
    standstill_gap_m: float = 10.0
    time_headway_s: float = 2.0
    comfort_decel_mps2: float | None = None

    def __post_init__(self) -> None:
        vid = self.vehicle_id
        if not isinstance(vid, str) or not vid or not vid.isprintable():
            raise ValueError(f"vehicle_id must be a non-empty printable string, got {vid!r}")
        if len(vid.encode("utf-8")) > MAX_VEHICLE_ID_BYTES:
            raise ValueError(f"vehicle_id {vid!r} is longer than {MAX_VEHICLE_ID_BYTES} bytes")
        if not isinstance(self.route, Route):
            raise ValueError(f"tram {vid}: route must be a Route, got {type(self.route)!r}")
        if not isinstance(self.profile, BrakingProfile):
            raise ValueError(f"tram {vid}: profile must be a BrakingProfile")

        def check(name: str, value: Any, ok: bool, what: str) -> float:
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"tram {vid}: {name} must be a number, got {value!r}")
            if not (math.isfinite(value) and ok):
                raise ValueError(f"tram {vid}: {name}={value!r} {what}")
            return float(value)

        length = check("length_m", self.length_m, self.length_m > 0, "must be > 0 m")
        object.__setattr__(self, "length_m", length)
        ant = length / 2.0 if self.antenna_offset_m is None else self.antenna_offset_m
        ant = check("antenna_offset_m", ant, 0.0 <= ant <= length, "must be in [0, length_m]")
        object.__setattr__(self, "antenna_offset_m", ant)
        vmax = self.profile.max_speed_mps if self.max_speed_mps is None else self.max_speed_mps
        vmax = check("max_speed_mps", vmax, vmax > 0, "must be > 0 m/s")
        object.__setattr__(self, "max_speed_mps", vmax)
        for name, ok, what in (
            ("depart_s", self.depart_s >= 0, "must be >= 0 s"),
            ("initial_speed_mps", 0 <= self.initial_speed_mps <= vmax, "must be in [0, max]"),
            ("dwell_s", self.dwell_s >= 0, "must be >= 0 s"),
            ("cruise_factor", 0 < self.cruise_factor <= 1, "must be in (0, 1]"),
            ("lateral_accel_mps2", self.lateral_accel_mps2 > 0, "must be > 0 m/s²"),
            ("standstill_gap_m", self.standstill_gap_m >= 0, "must be >= 0 m"),
            ("time_headway_s", self.time_headway_s >= 0, "must be >= 0 s"),
        ):
            object.__setattr__(self, name, check(name, getattr(self, name), ok, what))
        service = self.profile.service_decel_mps2
        comfort = (
            _COMFORT_FRACTION * service
            if self.comfort_decel_mps2 is None
            else (self.comfort_decel_mps2)
        )
        comfort = check(
            "comfort_decel_mps2", comfort, 0 < comfort <= service, f"must be in (0, {service:g}]"
        )
        object.__setattr__(self, "comfort_decel_mps2", comfort)
        if self.stops is not None:
            calls = []
            for item in self.stops:
                if isinstance(item, StopCall):
                    calls.append(item)
                elif isinstance(item, Sequence) and len(item) in (2, 3):
                    calls.append(StopCall(*item))
                else:
                    raise ValueError(
                        f"tram {vid}: a stop must be a StopCall or (distance_m, dwell_s), "
                        f"got {item!r}"
                    )
            length_route = self.route.length_m
            for c in calls:
                if not -1e-6 <= c.distance_m <= length_route + 1e-6:
                    raise ValueError(
                        f"tram {vid}: stop at {c.distance_m:.3f} m is outside its route "
                        f"(0..{length_route:.3f} m)"
                    )
            object.__setattr__(self, "stops", tuple(sorted(calls, key=lambda c: c.distance_m)))
        script = tuple(ScriptEvent.parse(e) for e in self.script)
        object.__setattr__(self, "script", tuple(sorted(script, key=lambda e: e.t_s)))

    @property
    def antenna_m(self) -> float:
        """The resolved antenna offset behind the front, metres."""
        return _resolved(self.antenna_offset_m)

    @property
    def vmax_mps(self) -> float:
        """The resolved vehicle maximum speed, m/s."""
        return _resolved(self.max_speed_mps)

    @property
    def plan_decel_mps2(self) -> float:
        """The resolved planning (comfort) deceleration, m/s²."""
        return _resolved(self.comfort_decel_mps2)


def _resolved(value: float | None) -> float:
    if value is None:  # pragma: no cover - resolved in TramSpec.__post_init__
        raise AssertionError("unresolved TramSpec default")
    return value


# =========================================================================== GPS model
@dataclass(frozen=True, slots=True)
class GpsModel:
    """Error model of the trams' GPS receivers.

    Position (of the antenna, ``antenna_offset_m`` behind the front along the track), per
    local axis (east, north)::

        measured = true + bias(t) + white + outlier

    * ``white`` ~ N(0, ``sigma_m``²), independent per fix;
    * ``bias`` a first-order Gauss–Markov process, stationary standard deviation
      ``bias_sigma_m`` and correlation time ``bias_tau_s``:
      ``b[k] = φ·b[k−1] + sqrt(1−φ²)·bias_sigma_m·w``, ``φ = exp(−Δt/bias_tau_s)``,
      starting in its stationary distribution; it runs on during dropouts;
    * ``outlier`` ~ N(0, ``outlier_sigma_m``²) added with probability ``outlier_rate``.

    Fixes come at whole multiples of ``1/rate_hz`` simulation seconds (receivers align
    their epochs to GPS time). A fix is missing with probability ``missing_rate``, and
    while the antenna is on a ``tunnel`` edge (``tunnel_dropout``) plus
    ``tunnel_reacquire_s`` after leaving it.

    Speed and course come from the Doppler velocity, modelled as the true velocity vector
    plus N(0, ``speed_sigma_mps``²) per axis: the speed is its magnitude (never negative;
    Rayleigh with mean ``1.25·speed_sigma_mps`` at standstill) and the course its direction
    plus N(0, ``course_sigma_deg``²). The course error therefore grows at low speed, with
    a standard deviation of about ``sqrt(course_sigma_deg² + degrees(speed_sigma_mps/v)²)``
    (2.1° at 10 m/s, 6.1° at 1 m/s, 12° at 0.5 m/s with the defaults). Below
    ``course_hold_speed_mps`` of *measured* speed the receiver holds its last course, as
    receivers with static hold do (the first fix keeps its noisy course); set it to 0 for
    a course that wanders at random when standing.

    Attributes
    ----------
    sigma_m, bias_sigma_m, bias_tau_s, outlier_rate, outlier_sigma_m, missing_rate,
    tunnel_dropout, tunnel_reacquire_s, rate_hz, speed_sigma_mps, course_sigma_deg,
    course_hold_speed_mps
        As above (metres, seconds, probabilities per fix, Hz, m/s, degrees).
    """

    sigma_m: float = 3.0
    bias_sigma_m: float = 1.5
    bias_tau_s: float = 60.0
    outlier_rate: float = 0.0
    outlier_sigma_m: float = 50.0
    missing_rate: float = 0.0
    tunnel_dropout: bool = True
    tunnel_reacquire_s: float = 0.0
    rate_hz: float = 1.0
    speed_sigma_mps: float = 0.1
    course_sigma_deg: float = 2.0
    course_hold_speed_mps: float = 0.5

    def __post_init__(self) -> None:
        for name in (
            "sigma_m",
            "bias_sigma_m",
            "outlier_sigma_m",
            "tunnel_reacquire_s",
            "speed_sigma_mps",
            "course_sigma_deg",
            "course_hold_speed_mps",
        ):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ValueError(f"GpsModel.{name} must be a finite number >= 0, got {value!r}")
        for name in ("outlier_rate", "missing_rate"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and 0.0 <= value <= 1.0):
                raise ValueError(f"GpsModel.{name} must be a probability in [0, 1], got {value!r}")
        if not (isinstance(self.bias_tau_s, int | float) and self.bias_tau_s > 0):
            raise ValueError(f"GpsModel.bias_tau_s must be > 0 s, got {self.bias_tau_s!r}")
        if not (
            isinstance(self.rate_hz, int | float)
            and math.isfinite(self.rate_hz)
            and 0 < self.rate_hz <= 100
        ):
            raise ValueError(f"GpsModel.rate_hz must be in (0, 100] Hz, got {self.rate_hz!r}")

    @classmethod
    def exact(cls, *, rate_hz: float = 1.0) -> GpsModel:
        """A perfect receiver: no noise, no bias, no missing fixes (tunnels still drop)."""
        return cls(
            sigma_m=0.0,
            bias_sigma_m=0.0,
            speed_sigma_mps=0.0,
            course_sigma_deg=0.0,
            rate_hz=rate_hz,
        )


# =========================================================================== results
@dataclass(frozen=True, eq=False)
class SpeedPlan:
    """The static speed profile of one tram along its route.

    Attributes
    ----------
    vehicle_id : str
    distance_m : ndarray
        Grid of route distances, metres (spacing at most ``grid_m``).
    limit_mps : ndarray
        Allowed speed at the front: min(edge limit or default, vehicle max, curve speed),
        m/s. Linear interpolation between grid points is a valid limit.
    curve_radius_m : ndarray
        Estimated track radius, metres (large on straight track).
    target_mps : ndarray
        What the driver aims at: ``cruise_factor`` × the minimum of ``limit_mps`` over the
        train's length, m/s.
    envelope_mps : ndarray
        Highest speed from which every lower target ahead, and the route end (unless the
        tram exits there), is reached with the planning deceleration, m/s.
    stops : tuple of StopCall
        The stops the tram will make.
    """

    vehicle_id: str
    distance_m: FloatArray
    limit_mps: FloatArray
    curve_radius_m: FloatArray
    target_mps: FloatArray
    envelope_mps: FloatArray
    stops: tuple[StopCall, ...]

    def limit_at(self, distance_m: npt.ArrayLike) -> FloatArray:
        """Allowed speed at route distances (linear interpolation), m/s."""
        d = np.asarray(distance_m, dtype=np.float64)
        return np.asarray(np.interp(d, self.distance_m, self.limit_mps), dtype=np.float64)


@dataclass(frozen=True, slots=True)
class TruthState:
    """The true state of one tram at one time (see :class:`Truth` for the fields)."""

    vehicle_id: str
    t_s: float
    distance_m: float
    edge_id: int
    offset_m: float
    direction: int
    speed_mps: float
    accel_mps2: float
    x_m: float
    y_m: float
    antenna_x_m: float
    antenna_y_m: float
    heading_deg: float
    braking: BrakeState
    in_tunnel: bool


@dataclass(frozen=True, eq=False)
class Truth:
    """True states of one tram, sampled every simulation step while it is in service.

    All arrays have one entry per sample. Positions are in the map's local frame.

    Attributes
    ----------
    vehicle_id : str
    length_m, antenna_offset_m : float
        Vehicle length and antenna distance behind the front, metres.
    t_s : ndarray
        Simulation time, s (a contiguous run of steps from the tram's appearance to the
        end of the run or its exit).
    distance_m : ndarray
        Route distance of the front, metres.
    edge_id, offset_m, direction : ndarray
        Track position of the front (offset in metres from the edge's first vertex).
    speed_mps, accel_mps2 : ndarray
        Speed, m/s; acceleration applied from this sample to the next, m/s².
    x_m, y_m : ndarray
        Front position, metres.
    antenna_x_m, antenna_y_m : ndarray
        Antenna position, metres.
    heading_deg : ndarray
        True heading of travel at the front, degrees clockwise from north.
    braking : ndarray of str
        ``"none"``, ``"service"`` or ``"emergency"`` (what the tram would announce).
    in_tunnel : ndarray of bool
        Whether the antenna is on a tunnel edge.
    rear_edge_id, rear_offset_m, rear_direction : ndarray
        Track position of the rear.
    rear_x_m, rear_y_m : ndarray
        Rear position, metres.
    """

    vehicle_id: str
    length_m: float
    antenna_offset_m: float
    t_s: FloatArray
    distance_m: FloatArray
    edge_id: IntArray
    offset_m: FloatArray
    direction: IntArray
    speed_mps: FloatArray
    accel_mps2: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    antenna_x_m: FloatArray
    antenna_y_m: FloatArray
    heading_deg: FloatArray
    braking: npt.NDArray[np.str_]
    in_tunnel: BoolArray
    rear_edge_id: IntArray
    rear_offset_m: FloatArray
    rear_direction: IntArray
    rear_x_m: FloatArray
    rear_y_m: FloatArray

    def __len__(self) -> int:
        return len(self.t_s)

    def covers(self, t_s: float) -> bool:
        """Whether the tram is in service at ``t_s`` (within half a step of a sample)."""
        if not len(self.t_s):
            return False
        half = 0.5 * (self.t_s[1] - self.t_s[0]) if len(self.t_s) > 1 else 1e-9
        return bool(self.t_s[0] - half <= t_s <= self.t_s[-1] + half)

    def index_at(self, t_s: float) -> int:
        """Index of the sample nearest to ``t_s``.

        Raises
        ------
        ValueError
            The tram is not in service at ``t_s``.
        """
        if not self.covers(t_s):
            span = f"{self.t_s[0]:.3f}..{self.t_s[-1]:.3f} s" if len(self.t_s) else "never"
            raise ValueError(f"tram {self.vehicle_id} is not in service at t={t_s!r} s ({span})")
        k = int(np.searchsorted(self.t_s, t_s))
        k = min(max(k, 0), len(self.t_s) - 1)
        if k > 0 and abs(self.t_s[k - 1] - t_s) <= abs(self.t_s[k] - t_s):
            k -= 1
        return k

    def at(self, t_s: float, *, interpolate: bool = False) -> TruthState:
        """The state at ``t_s``: the nearest sample, or linearly interpolated.

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        interpolate : bool
            Interpolate the continuous quantities (distance, speed, positions, heading;
            the offset too when both samples are on the same edge) between the samples
            around ``t_s``; discrete ones (edge, direction, braking, tunnel) come from the
            nearest sample.

        Raises
        ------
        ValueError
            The tram is not in service at ``t_s``.
        """
        k = self.index_at(t_s)
        state = TruthState(
            vehicle_id=self.vehicle_id,
            t_s=float(self.t_s[k]),
            distance_m=float(self.distance_m[k]),
            edge_id=int(self.edge_id[k]),
            offset_m=float(self.offset_m[k]),
            direction=int(self.direction[k]),
            speed_mps=float(self.speed_mps[k]),
            accel_mps2=float(self.accel_mps2[k]),
            x_m=float(self.x_m[k]),
            y_m=float(self.y_m[k]),
            antenna_x_m=float(self.antenna_x_m[k]),
            antenna_y_m=float(self.antenna_y_m[k]),
            heading_deg=float(self.heading_deg[k]),
            braking=str(self.braking[k]),  # type: ignore[arg-type]
            in_tunnel=bool(self.in_tunnel[k]),
        )
        if not interpolate or len(self.t_s) < 2:
            return state
        i = int(np.clip(np.searchsorted(self.t_s, t_s, side="right") - 1, 0, len(self.t_s) - 2))
        w = float(np.clip((t_s - self.t_s[i]) / (self.t_s[i + 1] - self.t_s[i]), 0.0, 1.0))

        def lerp(a: FloatArray) -> float:
            return float(a[i] + w * (a[i + 1] - a[i]))

        turn = (self.heading_deg[i + 1] - self.heading_deg[i] + 180.0) % 360.0 - 180.0
        same_edge = self.edge_id[i] == self.edge_id[i + 1]
        return replace(
            state,
            t_s=float(t_s),
            distance_m=lerp(self.distance_m),
            offset_m=lerp(self.offset_m) if same_edge else state.offset_m,
            speed_mps=lerp(self.speed_mps),
            x_m=lerp(self.x_m),
            y_m=lerp(self.y_m),
            antenna_x_m=lerp(self.antenna_x_m),
            antenna_y_m=lerp(self.antenna_y_m),
            heading_deg=float((self.heading_deg[i] + w * turn) % 360.0),
        )


@dataclass(frozen=True, eq=False)
class FixLog:
    """Every GPS fix epoch of one tram, with the error terms, for analysing estimators.

    Arrays have one entry per epoch (multiples of ``1/rate_hz`` while the tram is in
    service), whether or not a report was sent. Positions are in the map's local frame.

    Attributes
    ----------
    vehicle_id : str
    t_s : ndarray
        Simulation time of the epoch, s.
    available : ndarray of bool
        A report was sent (no random miss, not in or just out of a tunnel).
    in_tunnel : ndarray of bool
        The antenna was on a tunnel edge.
    true_x_m, true_y_m : ndarray
        True antenna position, metres.
    x_m, y_m : ndarray
        Measured position (true + bias + white noise + outlier), metres.
    bias_x_m, bias_y_m : ndarray
        The Gauss–Markov bias, metres.
    outlier : ndarray of bool
        An outlier was added.
    true_speed_mps, speed_mps : ndarray
        True and measured speed, m/s.
    true_course_deg, course_deg : ndarray
        True track heading at the antenna and reported course (NaN when no report),
        degrees clockwise from true north.
    """

    vehicle_id: str
    t_s: FloatArray
    available: BoolArray
    in_tunnel: BoolArray
    true_x_m: FloatArray
    true_y_m: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    bias_x_m: FloatArray
    bias_y_m: FloatArray
    outlier: BoolArray
    true_speed_mps: FloatArray
    speed_mps: FloatArray
    true_course_deg: FloatArray
    course_deg: FloatArray

    def __len__(self) -> int:
        return len(self.t_s)


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """What :meth:`Simulator.run` returns.

    Attributes
    ----------
    truth : dict of str to Truth
        True states per vehicle id, in the order of the trams.
    reports : tuple of VehicleReport
        Noisy reports of all trams, sorted by time (then tram order). ``t`` is simulation
        seconds.
    fixes : dict of str to FixLog
        Every fix epoch per vehicle with its error terms (including dropped fixes).
    plans : dict of str to SpeedPlan
        Each tram's static speed profile and stops.
    specs : tuple of TramSpec
    gps : GpsModel
    dt_s, duration_s : float
        Step and simulated duration, s.
    seed : int
    epoch_utc_s : float
        UTC time of simulation time 0, seconds since the Unix epoch (used for NMEA).
    """

    truth: dict[str, Truth]
    reports: tuple[VehicleReport, ...]
    fixes: dict[str, FixLog]
    plans: dict[str, SpeedPlan]
    specs: tuple[TramSpec, ...]
    gps: GpsModel
    dt_s: float
    duration_s: float
    seed: int
    epoch_utc_s: float

    def reports_of(self, vehicle_id: str) -> list[VehicleReport]:
        """The reports of one vehicle, in time order."""
        if vehicle_id not in self.truth:
            raise KeyError(f"no simulated vehicle {vehicle_id!r}")
        return [r for r in self.reports if r.vehicle_id == vehicle_id]

    def write_csv(self, path: str | os.PathLike[str], *, extra_columns: Sequence[str] = ()) -> Path:
        """Write the reports as a replay CSV.

        The header is ``vehicle_id,t,lat,lon,speed_mps,course_deg`` followed by the chosen
        ``extra_columns`` (any of ``braking``, ``length_m``, ``antenna_offset_m``,
        ``seq``). ``t`` is simulation seconds; lat/lon are degrees with 8 decimals.

        Parameters
        ----------
        path : str or path-like
        extra_columns : sequence of str

        Returns
        -------
        pathlib.Path

        Raises
        ------
        ValueError
            An unknown extra column.
        """
        extras = tuple(extra_columns)
        unknown = [c for c in extras if c not in CSV_EXTRA_COLUMNS]
        if unknown:
            raise ValueError(f"unknown CSV column(s) {unknown}; choose from {CSV_EXTRA_COLUMNS}")
        out = Path(path)
        with out.open("w", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh, lineterminator="\n")
            writer.writerow([*CSV_HEADER, *extras])
            for r in self.reports:
                row = [
                    r.vehicle_id,
                    f"{r.t:.6f}",
                    f"{r.lat:.8f}",
                    f"{r.lon:.8f}",
                    f"{r.speed_mps:.3f}",
                    f"{r.course_deg:.2f}",
                ]
                for c in extras:
                    value = getattr(r, c)
                    row.append("" if value is None else str(value))
                writer.writerow(row)
        return out

    def write_nmea(
        self, directory: str | os.PathLike[str], *, vtg: bool = True, talker: str = "GN"
    ) -> list[Path]:
        """Write one NMEA log per vehicle, ``<vehicle_id>.nmea``: RMC, VTG, GGA per fix.

        The sentence order is a u-blox receiver's. NMEA times are ``epoch_utc_s + t``
        (UTC, 0.01 s resolution), so :func:`antikol.ingest.nmea.read_nmea_file` gives back ``t``
        shifted by ``epoch_utc_s`` (it emits the first fix on its RMC, before it has seen
        a GGA, and skips that epoch's VTG and GGA as unpaired). Vehicles without fixes get
        an empty file.

        Parameters
        ----------
        directory : str or path-like
            Created if missing.
        vtg : bool
            Also write a VTG sentence per fix.
        talker : str
            NMEA talker id (default ``GN``).

        Returns
        -------
        list of pathlib.Path
            The files written, in tram order.

        Raises
        ------
        ValueError
            A vehicle id cannot be a file name (path separators, ``.`` or ``..``).
        """
        folder = Path(directory)
        for vid in self.truth:
            if "/" in vid or "\\" in vid or os.sep in vid or vid in (".", ".."):
                raise ValueError(f"vehicle id {vid!r} cannot be used as an NMEA file name")
        folder.mkdir(parents=True, exist_ok=True)
        lines: dict[str, list[str]] = {vid: [] for vid in self.truth}
        for r in self.reports:
            shifted = replace(r, t=r.t + self.epoch_utc_s)
            out = lines[r.vehicle_id]
            out.append(format_rmc(shifted, talker=talker))
            if vtg:
                out.append(format_vtg(shifted, talker=talker))
            out.append(format_gga(shifted, talker=talker))
        paths = []
        for vid, text in lines.items():
            path = folder / f"{vid}.nmea"
            with path.open("w", newline="", encoding="ascii") as fh:
                fh.write("".join(line + "\r\n" for line in text))
            paths.append(path)
        return paths


# =========================================================================== internals
class _Track:
    """A tram's route extended backwards by a lead-in, as arrays for fast look-ups.

    Distances are route distances (the lead-in is negative).
    """

    def __init__(
        self,
        net: TrackMap,
        route: Route,
        lead_in_m: float,
        coords: dict[int, FloatArray],
    ) -> None:
        first = route.steps[0]
        behind = (
            route.start_offset_m
            if first[1] == 1
            else route.edge_lengths_m[0] - (route.start_offset_m)
        )
        prefix: list[tuple[int, int]] = []
        have = behind
        state = first
        seen = {first}
        while have < lead_in_m:
            preds = sorted(
                net.traversal.predecessors(state) if state in net.traversal else [],
                key=lambda s: (net.edges[s[0]].service is not None, s[0], s[1]),
            )
            preds = [p for p in preds if p not in seen]
            if not preds:
                break
            state = preds[0]
            seen.add(state)
            prefix.append(state)
            have += net.edge_length(state[0])
        prefix.reverse()
        steps = [*prefix, *route.steps]
        self.n_prefix = len(prefix)
        self.edge = np.array([e for e, _ in steps], dtype=np.int64)
        self.dir = np.array([d for _, d in steps], dtype=np.int64)
        self.len = np.array([net.edge_length(e) for e, _ in steps], dtype=float)
        entry_first = -behind
        before: FloatArray = np.cumsum(self.len[: self.n_prefix][::-1])[::-1]
        b0 = np.empty(len(steps))
        b0[: self.n_prefix] = entry_first - np.asarray(before, dtype=float)
        b0[self.n_prefix :] = entry_first + np.concatenate(
            ([0.0], np.cumsum(self.len[self.n_prefix : -1]))
        )
        self.b0 = b0
        self.b1 = b0 + self.len
        self.tunnel = np.array([net.edges[e].tunnel for e, _ in steps], dtype=bool)
        self.node_out = np.array(
            [net.edges[e].end_node if d == 1 else net.edges[e].start_node for e, d in steps],
            dtype=np.int64,
        )
        # polyline of the whole extended track
        xs: list[FloatArray] = []
        ys: list[FloatArray] = []
        ds: list[FloatArray] = []
        for k, (e, d) in enumerate(steps):
            xy = coords.get(e)
            if xy is None:
                xy = shapely.get_coordinates(net.edges[e].geometry).astype(float)
                coords[e] = xy
            seg = np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1]))
            cum = np.concatenate(([0.0], np.cumsum(seg)))
            scale = self.len[k] / cum[-1] if cum[-1] > 0 else 1.0
            cum = cum * scale
            if d == 1:
                px, py, pd = xy[:, 0], xy[:, 1], b0[k] + cum
            else:
                px, py, pd = xy[::-1, 0], xy[::-1, 1], b0[k] + (self.len[k] - cum[::-1])
            if k:
                px, py, pd = px[1:], py[1:], pd[1:]
            xs.append(px)
            ys.append(py)
            ds.append(pd)
        x = np.concatenate(xs)
        y = np.concatenate(ys)
        dist = np.concatenate(ds)
        if have < lead_in_m:  # dead end behind the start: extend straight backwards
            j = 1
            while j < len(x) - 1 and math.hypot(x[j] - x[0], y[j] - y[0]) < 1e-6:
                j += 1
            ux, uy = x[j] - x[0], y[j] - y[0]
            norm = math.hypot(ux, uy) or 1.0
            extra = lead_in_m - have + 1.0
            x = np.concatenate(([x[0] - ux / norm * extra], x))
            y = np.concatenate(([y[0] - uy / norm * extra], y))
            dist = np.concatenate(([dist[0] - extra], dist))
        # make distances strictly increasing for np.interp
        keep = np.concatenate(([True], np.diff(dist) > 1e-9))
        self.px, self.py, self.pd = x[keep], y[keep], dist[keep]
        sub = np.unique(np.concatenate((np.arange(0, len(self.pd), 25), [len(self.pd) - 1])))
        self.conv_d = self.pd[sub]
        self.conv_deg = net.frame.grid_north_azimuth_deg(self.px[sub], self.py[sub])

    def locate(self, s: FloatArray) -> tuple[IntArray, IntArray, FloatArray]:
        """Step index, edge id and offset of route distances (clamped to the track)."""
        k = np.clip(np.searchsorted(self.b0, s, side="right") - 1, 0, len(self.b0) - 1)
        rel = s - self.b0[k]
        off = np.clip(np.where(self.dir[k] > 0, rel, self.len[k] - rel), 0.0, self.len[k])
        return k, self.edge[k], off

    def xy(self, s: FloatArray) -> tuple[FloatArray, FloatArray]:
        return np.interp(s, self.pd, self.px), np.interp(s, self.pd, self.py)

    def grid_heading_rad(self, s: FloatArray, half_m: float = 1.0) -> FloatArray:
        """Heading from grid north (radians, clockwise) of the chord around ``s``.

        Near the ends of the track the chord is moved inwards so it keeps its length.
        """
        lo = self.pd[0] + half_m
        hi = self.pd[-1] - half_m
        s = np.clip(s, lo, hi) if lo < hi else s
        x0, y0 = self.xy(s - half_m)
        x1, y1 = self.xy(s + half_m)
        return np.arctan2(x1 - x0, y1 - y0)

    def convergence_deg(self, s: FloatArray) -> FloatArray:
        return np.asarray(np.interp(s, self.conv_d, self.conv_deg), dtype=float)


def _curve_radius(track: _Track, grid: FloatArray) -> FloatArray:
    h = _CHORD_HALF_M
    w = _CURVE_HALF_M
    th_a = track.grid_heading_rad(grid - w, h)
    th_b = track.grid_heading_rad(grid + w, h)
    turn = np.abs((th_b - th_a + np.pi) % (2 * np.pi) - np.pi)
    curvature = turn / (2.0 * w)
    with np.errstate(divide="ignore"):
        radius = np.where(curvature > 1e-9, 1.0 / np.maximum(curvature, 1e-9), 1e9)
    return np.maximum(radius, _MIN_RADIUS_M)


def _dilate_min(values: FloatArray, before: int, after: int) -> FloatArray:
    """Minimum over the window [i - before, i + after] (edges clamped)."""
    out = values.copy()
    n = len(values)
    for j in range(1, min(before, n - 1) + 1):
        out[j:] = np.minimum(out[j:], values[:-j])
        out[:j] = np.minimum(out[:j], values[0])
    for j in range(1, min(after, n - 1) + 1):
        out[:-j] = np.minimum(out[:-j], values[j:])
        out[-j:] = np.minimum(out[-j:], values[-1])
    return out


class _Vehicle:
    """Precomputed data of one tram."""

    def __init__(
        self,
        index: int,
        spec: TramSpec,
        net: TrackMap,
        *,
        grid_m: float,
        default_speed_mps: float,
        lead_in_m: float,
        coords: dict[int, FloatArray],
        node_conflicts: dict[int, list[int]],
        edge_crossings: dict[int, list[tuple[float, int]]],
        extents: dict[int, tuple[float, ...]],
        conflicts: dict[int, ConflictPoint],
    ) -> None:
        self.index = index
        self.spec = spec
        route = spec.route
        self.route_len = route.length_m
        self.track = _Track(net, route, lead_in_m, coords)
        tr = self.track
        length = self.route_len
        n_g = max(2, math.ceil(length / grid_m - 1e-9) + 1)
        dg = max(length / (n_g - 1), 1e-6)
        grid = np.arange(n_g, dtype=np.float64) * dg
        grid[-1] = max(length, grid[-2] + 1e-6)
        self.dg = dg
        vmax = spec.vmax_mps
        # track limit, dilated so that interpolation never exceeds any edge's limit
        track_lim = np.full(n_g, vmax)
        for k in range(len(tr.edge)):
            if tr.b1[k] <= 0.0 or tr.b0[k] >= length:
                continue
            maxspeed = net.edges[int(tr.edge[k])].maxspeed_mps
            c = default_speed_mps if maxspeed is None else maxspeed
            if c >= vmax:
                continue
            i0 = max(math.floor(max(tr.b0[k], 0.0) / dg), 0)
            i1 = min(math.ceil(min(tr.b1[k], length) / dg), n_g - 1)
            track_lim[i0 : i1 + 1] = np.minimum(track_lim[i0 : i1 + 1], c)
        radius = _curve_radius(tr, grid)
        # the estimate smears a curvature step over ±8 m: spread the limit as far
        reach = math.ceil((_CHORD_HALF_M + _CURVE_HALF_M) / dg)
        curve_lim = _dilate_min(np.sqrt(spec.lateral_accel_mps2 * radius), reach, reach)
        limit = np.minimum(np.minimum(track_lim, curve_lim), vmax)
        w = math.ceil(spec.length_m / dg)
        target = spec.cruise_factor * _dilate_min(limit, w, 0)
        bp = spec.plan_decel_mps2
        t2 = target**2
        if not spec.exit_at_end:
            t2[-1] = 0.0
        ramp = 2.0 * bp * dg * np.arange(n_g)
        env2 = np.minimum.accumulate((t2 + ramp)[::-1])[::-1] - ramp
        env2 = np.maximum(env2, 0.0)
        self.env2 = env2
        self.plan_stops = self._stops(net, spec)
        self.plan = SpeedPlan(
            vehicle_id=spec.vehicle_id,
            distance_m=grid,
            limit_mps=limit,
            curve_radius_m=radius,
            target_mps=target,
            envelope_mps=np.sqrt(env2),
            stops=self.plan_stops,
        )
        self.passes = self._conflict_passes(net, node_conflicts, edge_crossings, extents, conflicts)

    def _stops(self, net: TrackMap, spec: TramSpec) -> tuple[StopCall, ...]:
        if spec.stops is not None:
            return spec.stops
        v0 = spec.initial_speed_mps
        nearest = 1.0 + v0 * v0 / (2.0 * spec.plan_decel_mps2)
        calls: list[StopCall] = []
        for dist, stop in map_stops_on_route(net, spec.route):
            if dist < nearest:
                continue
            if calls and dist - calls[-1].distance_m < 1.0:
                continue
            calls.append(StopCall(dist, spec.dwell_s, stop.name))
        return tuple(calls)

    def _conflict_passes(
        self,
        net: TrackMap,
        node_conflicts: dict[int, list[int]],
        edge_crossings: dict[int, list[tuple[float, int]]],
        extents: dict[int, tuple[float, ...]],
        conflicts: dict[int, ConflictPoint],
    ) -> list[tuple[int, float, float, float, int]]:
        """(conflict id, route distance, extent before, extent after, entry key)."""
        tr = self.track
        out: dict[tuple[int, int], tuple[int, float, float, float, int]] = {}
        n = len(tr.edge)
        for k in range(n):
            e, d = int(tr.edge[k]), int(tr.dir[k])
            key = 2 * e + (1 if d > 0 else 0)
            for off, cid in edge_crossings.get(e, ()):
                dist = float(tr.b0[k] + (off if d > 0 else tr.len[k] - off))
                ext = extents[cid][conflicts[cid].edges.index(e)]
                out.setdefault((cid, round(dist * 1000)), (cid, dist, ext, ext, key))
            if k + 1 < n:
                node = int(tr.node_out[k])
                for cid in node_conflicts.get(node, ()):
                    c = conflicts[cid]
                    e2 = int(tr.edge[k + 1])
                    ext_in = extents[cid][c.edges.index(e)] if e in c.edges else 0.0
                    ext_out = extents[cid][c.edges.index(e2)] if e2 in c.edges else 0.0
                    dist = float(tr.b1[k])
                    out.setdefault((cid, round(dist * 1000)), (cid, dist, ext_in, ext_out, key))
        return sorted(out.values(), key=lambda p: p[1])


def crossing_clearance_m(angle_deg: float, *, width_m: float = 2.5, margin_m: float = 0.5) -> float:
    """Distance from a crossing point at which a tram clears a tram on the other track.

    Two tracks cross at ``angle_deg``. A tram whose front centre is ``d`` along its track
    from the crossing point is ``d·sin θ`` from the other track's centre line, and its
    front corners reach ``w/2·cos θ`` closer; it clears a vehicle of half width ``w/2`` on
    the other track, with ``margin_m``, when
    ``d >= (w/2·(1 + cos θ) + margin_m) / sin θ`` (1.75 m at 90°, 11 m at 15°).

    Parameters
    ----------
    angle_deg : float
        Crossing angle, degrees (folded into 0..90).
    width_m : float
        Vehicle width, metres.
    margin_m : float
        Lateral margin, metres.

    Returns
    -------
    float
        Metres along either track, at most 50.
    """
    theta = math.radians(abs(angle_deg) % 180.0)
    theta = min(theta, math.pi - theta)
    if theta < 1e-3:
        return 50.0
    need = (0.5 * width_m * (1.0 + math.cos(theta)) + margin_m) / math.sin(theta)
    return min(need, 50.0)


def _conflict_extents(net: TrackMap, c: ConflictPoint, *, width_m: float) -> tuple[float, ...]:
    """The map's conflict extents, widened at diamonds to the angle's clearance."""
    if c.kind != "diamond_crossing" or c.node_id is None or len(c.edges) != 4:
        return tuple(float(x) for x in c.extents_m)
    heads = []
    for e in c.edges:
        length = net.edge_length(e)
        at_start = net.edges[e].start_node == c.node_id
        px, py = net.point_at(e, 0.0 if at_start else length)
        qx, qy = net.point_at(e, min(8.0, length) if at_start else max(length - 8.0, 0.0))
        heads.append(math.atan2(qx - px, qy - py))  # leaving the crossing

    def off_straight(i: int, j: int) -> float:
        turn = (heads[i] - heads[j] + math.pi) % (2 * math.pi) - math.pi
        return abs(abs(turn) - math.pi)

    pairs = min(
        ((0, 1, 2, 3), (0, 2, 1, 3), (0, 3, 1, 2)),
        key=lambda p: off_straight(p[0], p[1]) + off_straight(p[2], p[3]),
    )
    angle = math.degrees(
        abs((heads[pairs[0]] - heads[pairs[2]] + math.pi) % (2 * math.pi) - math.pi)
    )
    clear = crossing_clearance_m(angle, width_m=width_m)
    return tuple(max(float(x), clear) for x in c.extents_m)


def _max_accel(
    v: FloatArray, e0: FloatArray, g: FloatArray, h: FloatArray, dt: float
) -> FloatArray:
    """Largest a with v'² + h·v' <= e0 + g·Δs after a step; -inf when none exists.

    ``v' = v + a·dt`` and ``Δs = v·dt + a·dt²/2``: a quadratic in ``a``. ``e0 + g·Δs`` is
    ``v_t² + 2·b·(D − Δs)`` for a braking curve to speed ``v_t`` at distance ``D``
    (``g = −2·b``) or the linearised envelope; ``h = 2·b·T`` adds a time headway ``T``.
    """
    a_q = dt * dt
    b_q = 2.0 * v * dt + h * dt - 0.5 * g * dt * dt
    c_q = v * v + h * v - e0 - g * v * dt
    disc = b_q * b_q - 4.0 * a_q * c_q
    root = (-b_q + np.sqrt(np.maximum(disc, 0.0))) / (2.0 * a_q)
    return np.where(disc >= 0.0, root, -np.inf)


#: Fast "any true" of a boolean array (much cheaper than ``ndarray.any`` on small arrays).
_nz = np.count_nonzero


def _id_words(vehicle_id: str) -> list[int]:
    digest = hashlib.sha256(vehicle_id.encode("utf-8")).digest()
    return [int.from_bytes(digest[i : i + 4], "little") for i in range(0, 16, 4)]


# =========================================================================== simulator
class Simulator:
    """Trams driving their routes over a track map, with noisy GPS reports.

    Parameters
    ----------
    net : TrackMap
    trams : sequence of TramSpec
        Vehicle ids must be unique.
    gps : GpsModel, optional
        Receiver model of every tram (default :class:`GpsModel` ()).
    dt_s : float
        Integration step, s (default 0.1).
    seed : int
        Seed of the GPS noise (each tram draws from generators seeded by
        ``(seed, vehicle_id)``).
    epoch_utc_s : float
        UTC time of simulation time 0, seconds since the Unix epoch; NMEA output carries
        ``epoch_utc_s + t`` while reports keep simulation seconds (default 1.7e9,
        2023-11-14 22:13:20 UTC).
    default_speed_mps : float
        Limit on edges without ``maxspeed``, m/s (default 50 km/h).
    yield_at_conflicts : bool
        Trams give way at merges and crossings (see the module notes); False lets them run
        through each other there.
    grid_m : float
        Spacing of the speed-profile grid along routes, metres (default 2).
    vehicle_width_m : float
        Width of the trams, metres (default 2.5); sets the clearance at diamond crossings
        (see :func:`crossing_clearance_m`).

    Raises
    ------
    ValueError
        Duplicate vehicle ids, a route with a move the map does not permit, or a bad
        option.
    trackmap.UnknownEdgeError
        A route uses an edge the map lacks.

    Notes
    -----
    Construction precomputes every tram's :class:`SpeedPlan` (see :attr:`plans`);
    :meth:`run` can be called several times and always starts from the beginning.
    """

    def __init__(
        self,
        net: TrackMap,
        trams: Sequence[TramSpec],
        *,
        gps: GpsModel | None = None,
        dt_s: float = 0.1,
        seed: int = 0,
        epoch_utc_s: float = DEFAULT_EPOCH_UTC_S,
        default_speed_mps: float = DEFAULT_SPEED_MPS,
        yield_at_conflicts: bool = True,
        grid_m: float = 2.0,
        vehicle_width_m: float = 2.5,
    ) -> None:
        if not (math.isfinite(dt_s) and 0 < dt_s <= 1.0):
            raise ValueError(f"dt_s must be in (0, 1] s, got {dt_s!r}")
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
            raise ValueError(f"seed must be a non-negative int, got {seed!r}")
        if not (math.isfinite(default_speed_mps) and default_speed_mps > 0):
            raise ValueError(f"default_speed_mps must be > 0 m/s, got {default_speed_mps!r}")
        if not (math.isfinite(grid_m) and 0.1 <= grid_m <= 50.0):
            raise ValueError(f"grid_m must be in [0.1, 50] m, got {grid_m!r}")
        if not (math.isfinite(vehicle_width_m) and 0 < vehicle_width_m <= 10.0):
            raise ValueError(f"vehicle_width_m must be in (0, 10] m, got {vehicle_width_m!r}")
        if not math.isfinite(epoch_utc_s):
            raise ValueError(f"epoch_utc_s must be finite, got {epoch_utc_s!r}")
        specs = tuple(trams)
        seen: set[str] = set()
        for spec in specs:
            if not isinstance(spec, TramSpec):
                raise ValueError(f"trams must be TramSpec records, got {type(spec)!r}")
            if spec.vehicle_id in seen:
                raise ValueError(f"two trams have vehicle_id {spec.vehicle_id!r}")
            seen.add(spec.vehicle_id)
            steps = spec.route.steps
            for e, _ in steps:
                net.edge(e)
            for a, b in itertools.pairwise(steps):
                if not net.traversal.has_edge(a, b):
                    raise ValueError(
                        f"tram {spec.vehicle_id}: its route moves {a} -> {b}, which this map "
                        "does not permit (a route of another map?)"
                    )
        self.net = net
        self.specs = specs
        self.gps = gps if gps is not None else GpsModel()
        self.dt_s = float(dt_s)
        self.seed = int(seed)
        self.epoch_utc_s = float(epoch_utc_s)
        self.default_speed_mps = float(default_speed_mps)
        self.yield_at_conflicts = bool(yield_at_conflicts)
        self.grid_m = float(grid_m)
        self.vehicle_width_m = float(vehicle_width_m)
        node_conflicts: dict[int, list[int]] = {}
        edge_crossings: dict[int, list[tuple[float, int]]] = {}
        for c in net.conflicts:
            if c.node_id is not None:
                node_conflicts.setdefault(c.node_id, []).append(c.conflict_id)
            else:
                for e, off in zip(c.edges, c.offsets_m, strict=True):
                    edge_crossings.setdefault(e, []).append((off, c.conflict_id))
        extents = {
            c.conflict_id: _conflict_extents(net, c, width_m=self.vehicle_width_m)
            for c in net.conflicts
        }
        conflicts = {c.conflict_id: c for c in net.conflicts}
        coords: dict[int, FloatArray] = {}
        t0 = time.perf_counter()
        self._veh = [
            _Vehicle(
                i,
                spec,
                net,
                grid_m=self.grid_m,
                default_speed_mps=self.default_speed_mps,
                lead_in_m=self._lookbehind_m(spec) + 20.0,
                coords=coords,
                node_conflicts=node_conflicts,
                edge_crossings=edge_crossings,
                extents=extents,
                conflicts=conflicts,
            )
            for i, spec in enumerate(specs)
        ]
        logger.debug("simulator: %d trams prepared in %.3f s", len(specs), time.perf_counter() - t0)

    @staticmethod
    def _lookbehind_m(spec: TramSpec) -> float:
        v = spec.vmax_mps
        return (
            spec.length_m
            + spec.standstill_gap_m
            + spec.time_headway_s * v
            + v * v / (2.0 * spec.plan_decel_mps2)
        )

    @property
    def vehicle_ids(self) -> tuple[str, ...]:
        """The trams' ids, in order."""
        return tuple(s.vehicle_id for s in self.specs)

    @property
    def plans(self) -> dict[str, SpeedPlan]:
        """Each tram's static speed profile and stops."""
        return {v.spec.vehicle_id: v.plan for v in self._veh}

    def rng_for(self, vehicle_id: str) -> tuple[np.random.Generator, np.random.Generator]:
        """The two generators of a tram's GPS noise (normals, uniforms), freshly seeded."""
        ss = np.random.SeedSequence([self.seed, *_id_words(vehicle_id)])
        a, b = ss.spawn(2)
        return np.random.default_rng(a), np.random.default_rng(b)

    # ------------------------------------------------------------------------- running
    def run(self, duration_s: float, *, progress: bool = False) -> SimulationResult:
        """Simulate ``duration_s`` seconds from time 0.

        Parameters
        ----------
        duration_s : float
            Simulated time, s (rounded to whole steps).
        progress : bool
            Show a tqdm progress bar.

        Returns
        -------
        SimulationResult

        Raises
        ------
        ValueError
            ``duration_s`` is negative or not finite.
        """
        if not (math.isfinite(duration_s) and duration_s >= 0):
            raise ValueError(f"duration_s must be a finite time >= 0 s, got {duration_s!r}")
        t0 = time.perf_counter()
        hist = _Dynamics(self).run(round(duration_s / self.dt_s), progress=progress)
        t1 = time.perf_counter()
        truth = {v.spec.vehicle_id: self._truth(v, hist) for v in self._veh}
        reports, fixes = self._reports(truth)
        t2 = time.perf_counter()
        logger.info(
            "simulated %d trams for %.0f s: dynamics %.2f s, truth and reports %.2f s",
            len(self._veh),
            duration_s,
            t1 - t0,
            t2 - t1,
        )
        return SimulationResult(
            truth=truth,
            reports=reports,
            fixes=fixes,
            plans=self.plans,
            specs=self.specs,
            gps=self.gps,
            dt_s=self.dt_s,
            duration_s=hist.n_steps * self.dt_s,
            seed=self.seed,
            epoch_utc_s=self.epoch_utc_s,
        )

    # ------------------------------------------------------------------------- outputs
    def _truth(self, veh: _Vehicle, hist: _History) -> Truth:
        i = veh.index
        rows = np.flatnonzero(hist.present[:, i])
        tr = veh.track
        spec = veh.spec
        t = rows.astype(np.float64) * self.dt_s
        s = hist.s[rows, i]
        k, edge, off = tr.locate(s)
        rk, redge, roff = tr.locate(s - spec.length_m)
        ak, _, _ = tr.locate(s - spec.antenna_m)
        x, y = tr.xy(s)
        ax, ay = tr.xy(s - spec.antenna_m)
        rx, ry = tr.xy(s - spec.length_m)
        heading = (np.degrees(tr.grid_heading_rad(s)) + tr.convergence_deg(s)) % 360.0
        names = np.array(_BRAKE_NAMES)
        return Truth(
            vehicle_id=spec.vehicle_id,
            length_m=spec.length_m,
            antenna_offset_m=spec.antenna_m,
            t_s=t,
            distance_m=s,
            edge_id=edge,
            offset_m=off,
            direction=tr.dir[k],
            speed_mps=hist.v[rows, i],
            accel_mps2=hist.a[rows, i],
            x_m=x,
            y_m=y,
            antenna_x_m=ax,
            antenna_y_m=ay,
            heading_deg=heading,
            braking=names[hist.code[rows, i]],
            in_tunnel=tr.tunnel[ak],
            rear_edge_id=redge,
            rear_offset_m=roff,
            rear_direction=tr.dir[rk],
            rear_x_m=rx,
            rear_y_m=ry,
        )

    def _reports(
        self, truth: dict[str, Truth]
    ) -> tuple[tuple[VehicleReport, ...], dict[str, FixLog]]:
        out: list[tuple[float, int, VehicleReport]] = []
        logs: dict[str, FixLog] = {}
        for veh in self._veh:
            vid = veh.spec.vehicle_id
            reports, logs[vid] = self._reports_of(veh, truth[vid])
            out.extend((r.t, veh.index, r) for r in reports)
        out.sort(key=lambda item: (item[0], item[1]))
        return tuple(r for _, _, r in out), logs

    def _reports_of(self, veh: _Vehicle, tru: Truth) -> tuple[list[VehicleReport], FixLog]:
        gps = self.gps
        spec = veh.spec
        tr = veh.track
        rate = gps.rate_hz
        if len(tru):
            m0 = math.ceil(tru.t_s[0] * rate - 1e-6)
            m1 = math.floor(tru.t_s[-1] * rate + 1e-6)
        else:
            m0, m1 = 0, -1
        tf = np.arange(m0, m1 + 1, dtype=np.float64) / rate
        n = len(tf)
        if n:
            s = np.interp(tf, tru.t_s, tru.distance_m)
            v = np.interp(tf, tru.t_s, tru.speed_mps)
            ki = np.clip(np.searchsorted(tru.t_s, tf + 1e-6, side="right") - 1, 0, len(tru) - 1)
        else:
            s = v = np.zeros(0)
            ki = np.zeros(0, dtype=np.int64)
        braking = tru.braking[ki]
        sa = s - spec.antenna_m
        x, y = tr.xy(sa)
        theta = tr.grid_heading_rad(sa)
        conv = tr.convergence_deg(sa)
        ak, _, _ = tr.locate(sa)
        tunnel = tr.tunnel[ak]
        g_norm, g_unif = self.rng_for(spec.vehicle_id)
        z = g_norm.standard_normal((n, 9))  # one row per epoch: prefix-stable streams
        u = g_unif.random((n, 2))
        # Gauss-Markov bias per axis, starting in its stationary distribution
        phi = math.exp(-1.0 / (rate * gps.bias_tau_s))
        q = gps.bias_sigma_m * math.sqrt(max(1.0 - phi * phi, 0.0))
        bias = np.empty((n, 2))
        if n:
            b = gps.bias_sigma_m * z[0, 2:4]
            bias[0] = b
            for m in range(1, n):
                b = phi * b + q * z[m, 2:4]
                bias[m] = b
        is_outlier = u[:, 0] < gps.outlier_rate
        outlier = is_outlier[:, None] * gps.outlier_sigma_m * z[:, 4:6]
        mx = x + bias[:, 0] + gps.sigma_m * z[:, 0] + outlier[:, 0]
        my = y + bias[:, 1] + gps.sigma_m * z[:, 1] + outlier[:, 1]
        vx = v * np.sin(theta) + gps.speed_sigma_mps * z[:, 6]
        vy = v * np.cos(theta) + gps.speed_sigma_mps * z[:, 7]
        speed = np.minimum(np.hypot(vx, vy), 99.0)
        raw_course = (
            np.degrees(np.arctan2(vx, vy)) + conv + gps.course_sigma_deg * z[:, 8]
        ) % 360.0
        available = u[:, 1] >= gps.missing_rate
        if gps.tunnel_dropout and tunnel.any():
            blocked = tunnel.copy()
            if gps.tunnel_reacquire_s > 0:
                last = -math.inf
                for m in range(n):
                    if tunnel[m]:
                        last = tf[m]
                    elif tf[m] - last < gps.tunnel_reacquire_s:
                        blocked[m] = True
            available &= ~blocked
        idx = np.flatnonzero(available)
        course = np.full(n, np.nan)
        last_course: float | None = None
        hold = gps.course_hold_speed_mps
        for m in idx.tolist():
            c = float(raw_course[m])
            if last_course is not None and speed[m] < hold:
                c = last_course
            course[m] = last_course = c
        log = FixLog(
            vehicle_id=spec.vehicle_id,
            t_s=tf,
            available=available,
            in_tunnel=tunnel,
            true_x_m=x,
            true_y_m=y,
            x_m=mx,
            y_m=my,
            bias_x_m=bias[:, 0].copy(),
            bias_y_m=bias[:, 1].copy(),
            outlier=is_outlier,
            true_speed_mps=v,
            speed_mps=speed,
            true_course_deg=(np.degrees(theta) + conv) % 360.0,
            course_deg=course,
        )
        if not len(idx):
            return [], log
        lon, lat = self.net.to_lonlat(mx[idx], my[idx])
        lon = np.atleast_1d(np.asarray(lon, dtype=float))
        lat = np.atleast_1d(np.asarray(lat, dtype=float))
        route_k = None
        if spec.broadcast_route:
            route_k = np.clip(
                np.searchsorted(spec.route._entry_m, s, side="right") - 1,
                0,
                len(spec.route.steps) - 1,
            )
        edge_ids = spec.route.edge_ids
        reports = []
        for seq, m in enumerate(idx.tolist()):
            route = None
            if route_k is not None:
                k = int(route_k[m])
                route = edge_ids[k : k + MAX_ROUTE_EDGES]
            reports.append(
                VehicleReport(
                    vehicle_id=spec.vehicle_id,
                    t=float(tf[m]),
                    lat=float(lat[seq]),
                    lon=float(lon[seq]),
                    speed_mps=float(speed[m]),
                    course_deg=float(course[m]),
                    braking=str(braking[m]),  # type: ignore[arg-type]
                    length_m=spec.length_m,
                    antenna_offset_m=spec.antenna_m,
                    route=route,
                    seq=seq,
                )
            )
        return reports, log


@dataclass
class _History:
    n_steps: int
    s: FloatArray
    v: FloatArray
    a: FloatArray
    code: npt.NDArray[np.int8]
    present: BoolArray


class _Dynamics:
    """The vectorised time-stepping of all trams (one instance per run)."""

    def __init__(self, sim: Simulator) -> None:
        self.sim = sim
        vehs = sim._veh
        self.n = len(vehs)
        dt = sim.dt_s
        self.dt = dt
        specs = [v.spec for v in vehs]
        f = np.array
        self.route_len = f([v.route_len for v in vehs], dtype=float)
        self.length = f([s.length_m for s in specs], dtype=float)
        self.gap0 = f([s.standstill_gap_m for s in specs], dtype=float)
        self.headway = f([s.time_headway_s for s in specs], dtype=float)
        self.b_plan = f([s.plan_decel_mps2 for s in specs], dtype=float)
        self.b_serv = f([s.profile.service_decel_mps2 for s in specs], dtype=float)
        self.b_emer = f([s.profile.emergency_decel_mps2 for s in specs], dtype=float)
        self.buildup = f([s.profile.emergency_buildup_s for s in specs], dtype=float)
        self.traction = f([s.profile.traction_mps2 for s in specs], dtype=float)
        self.depart = f([s.depart_s for s in specs], dtype=float)
        self.v0 = f([s.initial_speed_mps for s in specs], dtype=float)
        self.exit = f([s.exit_at_end for s in specs], dtype=bool)
        vmax = max((s.vmax_mps for s in specs), default=1.0)
        self.lookahead = f(
            [
                s.vmax_mps**2 / (2 * s.plan_decel_mps2)
                + s.standstill_gap_m
                + s.time_headway_s * s.vmax_mps
                + 2 * s.vmax_mps * _DETECT_EVERY_S
                + 60.0
                for s in specs
            ],
            dtype=float,
        )
        # speed envelope segments, padded so a window of m segments never leaves a tram
        min_dg = min((v.dg for v in vehs), default=sim.grid_m)
        self.m = min(max(2, math.ceil(vmax * dt / min_dg) + 2), 64)
        e_start, slope, base, nseg = [], [], [], []
        pos = 0
        for v in vehs:
            env2 = v.env2
            sl = np.diff(env2) / v.dg
            sl = np.concatenate((sl, np.full(self.m, sl[-1])))
            st = np.concatenate((env2[:-1], np.full(self.m, env2[-1])))
            e_start.append(st)
            slope.append(sl)
            base.append(pos)
            nseg.append(len(env2) - 1)
            pos += len(sl)
        self.e_start = np.concatenate(e_start) if e_start else np.zeros(0)
        self.slope = np.concatenate(slope) if slope else np.zeros(0)
        self.seg_base = f(base, dtype=np.int64)
        self.nseg = f(nseg, dtype=np.int64)
        self.dg = f([v.dg for v in vehs], dtype=float)
        # stops, each tram's list closed by an infinite sentinel
        sd, sw, sb = [], [], []
        pos = 0
        for v in vehs:
            sb.append(pos)
            sd.extend([c.distance_m for c in v.plan_stops] + [math.inf])
            sw.extend([c.dwell_s for c in v.plan_stops] + [0.0])
            pos += len(v.plan_stops) + 1
        self.stop_d = f(sd, dtype=float)
        self.stop_dwell = f(sw, dtype=float)
        self.stop_base = f(sb, dtype=np.int64)
        # the extended tracks of all trams, for locating body points
        keys, g_edge, g_dir, g_b0, g_len, g_tram, first, last = [], [], [], [], [], [], [], []
        shift = []
        pos = 0
        acc = 0.0
        for v in vehs:
            tr = v.track
            off = acc - tr.b0[0]
            shift.append(off)
            keys.append(tr.b0 + off)
            g_edge.append(tr.edge)
            g_dir.append(tr.dir)
            g_b0.append(tr.b0)
            g_len.append(tr.len)
            g_tram.append(np.full(len(tr.edge), v.index, dtype=np.int64))
            first.append(pos)
            pos += len(tr.edge)
            last.append(pos - 1)
            acc = float(tr.b1[-1] + off) + 1e4
        cat = np.concatenate
        self.g_key = cat(keys) if keys else np.zeros(0)
        self.g_edge = cat(g_edge) if keys else np.zeros(0, dtype=np.int64)
        self.g_dir = cat(g_dir) if keys else np.zeros(0, dtype=np.int64)
        self.g_b0 = cat(g_b0) if keys else np.zeros(0)
        self.g_len = cat(g_len) if keys else np.zeros(0)
        self.g_tram = cat(g_tram) if keys else np.zeros(0, dtype=np.int64)
        self.g_shift = f(shift, dtype=float)
        self.g_first = f(first, dtype=np.int64)
        self.g_last = f(last, dtype=np.int64)
        order = np.argsort(self.g_edge, kind="stable")
        self.e_g = order
        self.e_sorted = self.g_edge[order]
        self.e_tram = self.g_tram[order]
        self.e_dir = self.g_dir[order]
        self.e_b0 = self.g_b0[order]
        self.e_len = self.g_len[order]
        # conflict passes
        rows = [(v.index, *p) for v in vehs for p in v.passes]
        self.n_pass = len(rows)
        self.cp_tram = f([r[0] for r in rows], dtype=np.int64)
        self.cp_conf = f([r[1] for r in rows], dtype=np.int64)
        self.cp_dist = f([r[2] for r in rows], dtype=float)
        self.cp_in = f([r[3] for r in rows], dtype=float)
        self.cp_out = f([r[4] for r in rows], dtype=float)
        self.cp_entry = f([r[5] for r in rows], dtype=np.int64)
        # scripts
        self.scripted = [(v.index, v.spec.script) for v in vehs if v.spec.script]

    # ---------------------------------------------------------------------------------
    def run(self, n_steps: int, *, progress: bool) -> _History:
        n = self.n
        dt = self.dt
        hist = _History(
            n_steps=n_steps,
            s=np.zeros((n_steps + 1, n)),
            v=np.zeros((n_steps + 1, n)),
            a=np.zeros((n_steps + 1, n)),
            code=np.zeros((n_steps + 1, n), dtype=np.int8),
            present=np.zeros((n_steps + 1, n), dtype=bool),
        )
        if n == 0:
            return hist
        s = np.zeros(n)
        v = np.zeros(n)
        present = np.zeros(n, dtype=bool)
        waiting = np.ones(n, dtype=bool)
        due_seen = np.zeros(n, dtype=bool)
        at_end = np.zeros(n, dtype=bool)
        stop_idx = np.zeros(n, dtype=np.int64)
        dwell_until = np.full(n, np.inf)  # end of the current dwell, inf when none
        code = np.zeros(n, dtype=np.int8)
        self.leader = np.full(n, -1, dtype=np.int64)
        self.lead_tail0 = np.zeros(n)
        self.lead_join = np.full(n, -np.inf)
        self.lead_s0 = np.zeros(n)
        self.lead_sign = np.ones(n)
        self.yield_pos = np.full(n, np.inf)
        self.claim = np.full(self.n_pass, np.inf)
        cap = np.full(n, np.inf)
        hold = np.zeros(n, dtype=bool)
        inatt = np.zeros(n, dtype=bool)
        emerg = np.zeros(n, dtype=bool)
        building = np.zeros(n, dtype=bool)
        k_detect = max(1, round(_DETECT_EVERY_S / dt))
        m_idx = np.arange(self.m)
        bar = _progress_bar(n_steps, progress)
        b_plan, b_serv, b_emer = self.b_plan, self.b_serv, self.b_emer
        route_len, exit_ = self.route_len, self.exit
        any_exit = bool(_nz(exit_))
        end_at = np.where(exit_, np.inf, route_len)
        scripted = bool(self.scripted)
        inv_dg = 1.0 / self.dg
        last_seg = self.nseg - 1
        # Constraint rows, each a braking curve v'² + h·v' <= e0 + g·Δs after the step:
        # rows 0-4 are what the driver plans (envelope, route end, stop, leader with time
        # headway, conflict point; comfort braking), rows 5-6 what safety needs (leader
        # and conflict point on the service-brake curve).
        g = np.empty((7, n))
        g[1:5] = -2.0 * b_plan
        g[5:7] = -2.0 * b_serv
        h = np.zeros((7, n))
        h[3] = 2.0 * b_plan * self.headway
        lin_b = h * dt - 0.5 * g * dt * dt  # the parts of the quadratic's b and c that
        lin_c = h - g * dt  # do not depend on the state (row 0 changes every step)
        e0 = np.empty((7, n))
        dist = np.empty((4, n))
        two_dt = 2.0 * dt
        four_a = 4.0 * dt * dt
        two_a = 2.0 * dt * dt
        next_depart = float(self.depart.min())
        no_one = np.zeros(n, dtype=bool)
        next_dwell_end = np.inf
        for step in range(n_steps + 1):
            t = step * dt
            # -- scripted events ------------------------------------------------------
            if scripted:
                for i, events in self.scripted:
                    cap[i] = np.inf
                    hold[i] = inatt[i] = emerg[i] = building[i] = False
                    for ev in events:
                        if not ev.active(t):
                            continue
                        if ev.kind == "speed_cap":
                            cap[i] = min(cap[i], _resolved(ev.speed_mps))
                        elif ev.kind == "hold":
                            hold[i] = True
                        elif ev.kind == "inattentive":
                            inatt[i] = True
                        else:
                            emerg[i] = True
                            building[i] = building[i] or t - ev.t_s < self.buildup[i] - 1e-9
                emerg &= present
            # -- end of dwell -------------------------------------------------------
            if t + 1e-9 >= next_dwell_end:
                ended = dwell_until <= t + 1e-9
                stop_idx[ended] += 1
                dwell_until[ended] = np.inf
                next_dwell_end = float(dwell_until.min())
            dwelling = dwell_until < np.inf
            # -- appearance, leaders and conflicts ---------------------------------------
            newly = False
            due = no_one
            if t + 1e-9 >= next_depart:
                due = waiting & (self.depart <= t + 1e-9)
                newly = bool(_nz(due & ~due_seen))
                due_seen |= due
                later = self.depart[waiting & ~due]
                next_depart = float(later.min()) if len(later) else np.inf
            if step % k_detect == 0 or newly:
                self._detect(t, s, v, code, present, due, waiting, at_end, dwell_until, hold)
            if _nz(due):  # blocked at the start: try again
                next_depart = t
            # -- control --------------------------------------------------------------
            sc = np.minimum(s, route_len)
            j = (sc * inv_dg).astype(np.int64)
            np.minimum(j, last_seg, out=j)
            gi = self.seg_base + j
            e0[0] = self.e_start[gi] + self.slope[gi] * (sc - j * self.dg)
            np.maximum(e0[0], 0.0, out=e0[0])
            g_env = self.slope[gi[:, None] + m_idx].min(axis=1)
            g[0] = g_env
            lin_b[0] = (-0.5 * dt * dt) * g_env
            lin_c[0] = -dt * g_env
            # targets: route end, next stop, leader, conflict point (distances, m)
            np.subtract(end_at, s, out=dist[0])
            nxt = self.stop_d[self.stop_base + stop_idx]
            np.subtract(nxt, s, out=dist[1])
            lead = self.leader
            has = lead >= 0
            if scripted:
                has &= ~inatt
            if _nz(has):
                lj = np.where(has, lead, 0)
                b_l = np.where(code[lj] == 2, b_emer[lj], b_serv[lj])
                sign = self.lead_sign
                pos = np.maximum(self.lead_tail0 + sign * (s[lj] - self.lead_s0), self.lead_join)
                gap = pos - s - self.gap0 + sign * v[lj] ** 2 / (2.0 * b_l)
                dist[2] = np.where(has & present[lj], gap, np.inf)
            else:
                dist[2] = np.inf
            np.subtract(self.yield_pos, s, out=dist[3])
            if scripted:
                dist[3][inatt] = np.inf
            np.multiply(g[1:5], dist, out=e0[1:5])
            np.multiply(g[5:7], dist[2:4], out=e0[5:7])
            np.negative(e0[1:7], out=e0[1:7])
            # largest a with (v + a·dt)² + h·(v + a·dt) <= e0 + g·(v·dt + a·dt²/2)
            b_q = two_dt * v + lin_b
            c_q = v * v - e0 + lin_c * v
            disc = b_q * b_q - four_a * c_q
            acc = (np.sqrt(np.maximum(disc, 0.0)) - b_q) / two_a
            acc[disc < 0.0] = -np.inf
            # a target reached within the step: brake exactly onto it (the quadratic
            # would let the speed run negative)
            lim = -v / dt
            stopping = acc < lim
            stopping[0] &= g_env < 0.0
            if _nz(stopping):
                with np.errstate(divide="ignore", invalid="ignore"):
                    d_eq = e0 / -g
                    repl = np.where(d_eq > 1e-9, -(v * v) / (2.0 * d_eq), -np.inf)
                acc[stopping] = repl[stopping]
            a_plan = np.minimum(self.traction, acc[:5].min(axis=0))
            if scripted:
                capped = cap < np.inf
                if _nz(capped):
                    a_cap = np.maximum((cap - v) / dt, -b_plan)
                    a_plan = np.where(capped, np.minimum(a_plan, a_cap), a_plan)
                if _nz(hold):
                    a_hold = np.maximum(lim, -b_plan)
                    a_plan = np.where(hold, np.minimum(a_plan, a_hold), a_plan)
            np.maximum(a_plan, -b_serv, out=a_plan)
            a_safe = np.maximum(np.minimum(acc[5], acc[6]), -b_emer)
            a = np.minimum(a_plan, a_safe)
            hard = a < -b_serv
            if _nz(hard):
                # a crawling tram that the service brake stops within this step anyway
                crawl = hard & (v <= b_serv * dt)
                a[crawl] = lim[crawl]
            if scripted and _nz(emerg):
                a = np.where(emerg & building, np.minimum(a, 0.0), a)
                a = np.where(emerg & ~building, np.maximum(-b_emer, lim), a)
            a[dwelling | at_end | ~present | ((v <= 0.0) & (a < 0.0))] = 0.0
            escalated = a < -b_serv - 1e-9
            if _nz(escalated) and logger.isEnabledFor(logging.DEBUG):
                self._log_escalation(t, escalated, s, v, acc)
            code = (a < -_BRAKE_FLAG_MPS2).astype(np.int8)
            code[escalated] = 2
            if scripted:
                code[emerg] = 2
            hist.s[step] = s
            hist.v[step] = v
            hist.a[step] = a
            hist.code[step] = code
            hist.present[step] = present
            if step == n_steps:
                break
            # -- integration ----------------------------------------------------------
            v1 = v + a * dt
            ds = v * dt + (0.5 * dt * dt) * a
            halt = v1 < 1e-9
            if _nz(halt):
                with np.errstate(divide="ignore", invalid="ignore"):
                    brake = np.where(a < 0.0, v * v / (2.0 * np.maximum(-a, 1e-12)), 0.0)
                ds[halt] = brake[halt]
                v1[halt] = 0.0
            v = v1
            s = s + np.maximum(ds, 0.0)
            if any_exit:
                s = np.where(exit_, s, np.minimum(s, route_len))
            else:
                np.minimum(s, route_len, out=s)
            # -- stops, route end -----------------------------------------------------
            stopped = v == 0.0
            if _nz(stopped):
                arrive = stopped & present & ~dwelling & (np.abs(nxt - s) <= _ARRIVE_TOL_M)
                if _nz(arrive):
                    dwell_until[arrive] = (t + dt) + self.stop_dwell[self.stop_base + stop_idx][
                        arrive
                    ]
                    next_dwell_end = min(next_dwell_end, float(dwell_until[arrive].min()))
                    dwelling = dwelling | arrive
            passed = nxt < s - _ARRIVE_TOL_M
            if _nz(passed):
                passed &= present & ~dwelling
                while _nz(passed):
                    for i in np.flatnonzero(passed).tolist():
                        logger.debug(
                            "tram %s passed its stop at %.1f m without stopping",
                            self.sim.specs[i].vehicle_id,
                            nxt[i],
                        )
                    stop_idx[passed] += 1
                    nxt = self.stop_d[self.stop_base + stop_idx]
                    passed &= nxt < s - _ARRIVE_TOL_M
            near_end = s >= route_len - _ARRIVE_TOL_M
            if _nz(near_end):
                at_end |= near_end & present & ~exit_ & stopped
                gone = near_end & present & exit_ & (s >= route_len)
                if _nz(gone):
                    present = present & ~gone
            bar.update(1)
        bar.close()
        return hist

    def _log_escalation(
        self, t: float, escalated: BoolArray, s: FloatArray, v: FloatArray, acc: FloatArray
    ) -> None:
        for i in np.flatnonzero(escalated).tolist():
            lead = int(self.leader[i])
            why = (
                f"leader {self.sim.specs[lead].vehicle_id}"
                if acc[5, i] <= acc[6, i] and lead >= 0
                else f"conflict point at {self.yield_pos[i]:.1f} m"
            )
            logger.debug(
                "t=%.1f s: tram %s at %.1f m, %.2f m/s brakes beyond the service brake for %s",
                t,
                self.sim.specs[i].vehicle_id,
                s[i],
                v[i],
                why,
            )

    # ---------------------------------------------------------------------------------
    def _detect(
        self,
        t: float,
        s: FloatArray,
        v: FloatArray,
        code: npt.NDArray[np.int8],
        present: BoolArray,
        due: BoolArray,
        waiting: BoolArray,
        at_end: BoolArray,
        dwell_until: FloatArray,
        hold: BoolArray,
    ) -> None:
        """Let due trams appear, find every tram's leader, settle conflict points."""
        owners = np.flatnonzero(present)
        cand = np.flatnonzero(due)
        if len(cand):
            # blockers: trams in service, and due trams before this one in the list
            mt, md, mtail, mjoin, msign, mowner = self._matches(s, present | due)
            mpos = np.maximum(mtail, mjoin)
            first = present[mowner] | (mowner < mt)
            mt, md, mpos, mowner = mt[first], md[first], mpos[first], mowner[first]
            if len(mt):
                v_o = v[mowner]
                reach = self.b_plan[mowner]
                behind = -(
                    self.length[mt]
                    + self.gap0[mt]
                    + self.headway[mowner] * v_o
                    + v_o * v_o / (2.0 * reach)
                )
                ahead = (
                    self.gap0[mt]
                    + self.headway[mt] * self.v0[mt]
                    + self.v0[mt] ** 2 / (2.0 * self.b_plan[mt])
                )
                block = due[mt] & (md >= behind) & (mpos <= ahead)
                blocked = np.zeros(self.n, dtype=bool)
                blocked[mt[block]] = True
            else:
                blocked = np.zeros(self.n, dtype=bool)
            enter = due & ~blocked
            if _nz(enter):
                present |= enter
                waiting &= ~enter
                due &= ~enter
                s[enter] = 0.0
                v[enter] = self.v0[enter]
            owners = np.flatnonzero(present)
        self.leader[:] = -1
        if not len(owners):
            return
        mt, md, mtail, mjoin, msign, mowner = self._matches(s, present)
        mpos = np.maximum(mtail, mjoin)
        if len(mt):
            ok = (
                present[mt]
                & (md > s[mt])
                & (md <= s[mt] + self.lookahead[mt])
                & (mpos <= self.route_len[mt] + self.gap0[mt])
            )
            mt, mpos, msign, mowner = mt[ok], mpos[ok], msign[ok], mowner[ok]
            mtail, mjoin = mtail[ok], mjoin[ok]
        if len(mt):
            b_l = np.where(code[mowner] == 2, self.b_emer[mowner], self.b_serv[mowner])
            score = mpos + msign * v[mowner] ** 2 / (2.0 * b_l) - s[mt]
            order = np.lexsort((score, mt))
            mt, msign, mowner = mt[order], msign[order], mowner[order]
            mtail, mjoin = mtail[order], mjoin[order]
            firsts = np.concatenate(([True], mt[1:] != mt[:-1]))
            ti = mt[firsts]
            self.leader[ti] = mowner[firsts]
            self.lead_tail0[ti] = mtail[firsts]
            self.lead_join[ti] = mjoin[firsts]
            self.lead_s0[ti] = s[mowner[firsts]]
            self.lead_sign[ti] = msign[firsts]
        if self.sim.yield_at_conflicts and self.n_pass:
            self._conflicts(t, s, v, present, at_end, dwell_until, hold)

    def _matches(
        self, s: FloatArray, present: BoolArray
    ) -> tuple[IntArray, FloatArray, FloatArray, FloatArray, FloatArray, IntArray]:
        """Body points of present trams found on every tram's extended track.

        Returns, per match: the tram whose track it is, the point's route distance on it,
        the near end of the body as if the body lay on that track (it moves with the
        owner), the point where the owner's track joined it (the near end cannot be
        before it; -inf when not known), +1/-1 for same/opposite running, and the owner.
        """
        owners = np.flatnonzero(present)
        n_o = len(owners)
        qs = np.concatenate((s[owners], s[owners] - self.length[owners]))
        qo = np.concatenate((owners, owners))
        is_front = np.concatenate((np.ones(n_o, dtype=bool), np.zeros(n_o, dtype=bool)))
        gk = np.searchsorted(self.g_key, qs + self.g_shift[qo], side="right") - 1
        gk = np.clip(gk, self.g_first[qo], self.g_last[qo])
        rel = qs - self.g_b0[gk]
        pe = self.g_edge[gk]
        pdir = self.g_dir[gk]
        plen = self.g_len[gk]
        po = np.clip(np.where(pdir > 0, rel, plen - rel), 0.0, plen)
        lo = np.searchsorted(self.e_sorted, pe, side="left")
        hi = np.searchsorted(self.e_sorted, pe, side="right")
        cnt = hi - lo
        total = int(cnt.sum())
        empty_i = np.zeros(0, dtype=np.int64)
        empty_f = np.zeros(0)
        if total == 0:
            return empty_i, empty_f, empty_f, empty_f, empty_f, empty_i
        rep = np.repeat(np.arange(len(qs)), cnt)
        within = np.arange(total) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        iv = np.repeat(lo, cnt) + within
        mt = self.e_tram[iv]
        owner = qo[rep]
        keep = mt != owner
        iv, rep, mt, owner = iv[keep], rep[keep], mt[keep], owner[keep]
        d_iv = self.e_dir[iv]
        md = self.e_b0[iv] + np.where(d_iv > 0, po[rep], self.e_len[iv] - po[rep])
        sign = np.where(d_iv == pdir[rep], 1.0, -1.0)
        front = is_front[rep]
        # the body extends behind the front (same running: towards us)
        toward = front == (sign > 0)
        mtail = np.where(toward, md - self.length[owner], md)
        mjoin = np.full(len(md), -np.inf)
        # A front that joined our track at a merge: the body is on our track only from
        # where both tracks have run the same steps (walk back while they agree).
        walk = np.flatnonzero(front & (sign > 0))
        if len(walk):
            cur_m = self.e_g[iv[walk]]
            cur_o = gk[rep[walk]]
            tw = mt[walk]
            ow = owner[walk]
            tail = mtail[walk]
            join = self.g_b0[cur_m]
            for _ in range(64):
                can = (tail < join) & (cur_m > self.g_first[tw]) & (cur_o > self.g_first[ow])
                can[can] &= (self.g_edge[cur_m[can] - 1] == self.g_edge[cur_o[can] - 1]) & (
                    self.g_dir[cur_m[can] - 1] == self.g_dir[cur_o[can] - 1]
                )
                if not _nz(can):
                    break
                cur_m[can] -= 1
                cur_o[can] -= 1
                join[can] = self.g_b0[cur_m[can]]
            mjoin[walk] = join
        return mt, md, mtail, mjoin, sign, owner

    def _conflicts(
        self,
        t: float,
        s: FloatArray,
        v: FloatArray,
        present: BoolArray,
        at_end: BoolArray,
        dwell_until: FloatArray,
        hold: BoolArray,
    ) -> None:
        ct = self.cp_tram
        sp = s[ct]
        vp = v[ct]
        start = self.cp_dist - self.cp_in
        # a tram waiting at the fouling point (its yield target) does not occupy it
        occupying = (
            present[ct]
            & (sp > start + _OCCUPY_TOL_M)
            & (sp - self.length[ct] < self.cp_dist + self.cp_out)
        )
        reach = vp * vp / (2.0 * self.b_plan[ct]) + vp * _DETECT_EVERY_S + _CLAIM_MARGIN_M
        idle = np.isfinite(dwell_until[ct]) | hold[ct] | at_end[ct]
        approaching = (
            present[ct] & ~occupying & ~idle & (sp <= start + _OCCUPY_TOL_M) & (sp >= start - reach)
        )
        active = occupying | approaching
        newly = active & np.isinf(self.claim)
        self.claim[newly] = t
        self.claim[~active] = np.inf
        self.yield_pos[:] = np.inf
        idx = np.flatnonzero(active)
        if len(idx) < 2:
            return
        prio = np.where(occupying[idx], -1.0, self.claim[idx])
        order = np.lexsort((ct[idx], prio, self.cp_conf[idx]))
        p = idx[order]
        conf = self.cp_conf[p]
        entry = self.cp_entry[p]
        head = np.concatenate(([True], conf[1:] != conf[:-1]))
        group_start = np.maximum.accumulate(np.where(head, np.arange(len(p)), 0))
        diff = entry != entry[group_start]
        cs = np.cumsum(diff) - diff
        before = cs - cs[group_start]
        must_yield = (diff | (before > 0)) & ~occupying[p]
        # a tram on a loop may pass a conflict point twice: it never yields to itself
        starts = np.flatnonzero(head)
        trams = ct[p]
        alone = np.minimum.reduceat(trams, starts) == np.maximum.reduceat(trams, starts)
        must_yield &= ~alone[np.cumsum(head) - 1]
        if _nz(must_yield):
            y = p[must_yield]
            np.minimum.at(self.yield_pos, ct[y], start[y])


class _NoBar:
    def update(self, n: int) -> None:
        pass

    def close(self) -> None:
        pass


def _progress_bar(total: int, enabled: bool) -> Any:
    if not enabled:
        return _NoBar()
    try:
        from tqdm import tqdm
    except ImportError:  # tqdm is a dependency, but stay usable without it
        logger.warning("tqdm is not installed; running without a progress bar")
        return _NoBar()
    return tqdm(total=total, unit="step", desc="simulating", mininterval=0.5)


# =========================================================================== fleets
def fleet(
    net: TrackMap,
    n: int,
    rng_or_seed: np.random.Generator | int | None,
    *,
    route_length_m: float = 12_000.0,
    headway_s: float = 10.0,
    min_separation_m: float = 300.0,
    id_prefix: str = "T",
    cruise_factor_range: tuple[float, float] = (0.9, 1.0),
    **spec_options: Any,
) -> list[TramSpec]:
    """Trams on random main-line routes spread across the network.

    Parameters
    ----------
    net : TrackMap
    n : int
        Number of trams.
    rng_or_seed : numpy.random.Generator or int or None
        Random source for the routes and cruise factors.
    route_length_m : float
        Route length of every tram, metres (12 km: enough for 30 min with stops).
    headway_s : float
        Tram ``i`` departs at ``i · headway_s`` seconds.
    min_separation_m : float
        Wanted straight-line distance between start positions, metres; at most half the
        main-line length per tram, and relaxed after 50 failed draws for a tram.
    id_prefix : str
        Vehicle ids are ``id_prefix`` + a zero-padded number from 1.
    cruise_factor_range : (float, float)
        Each driver's cruise factor is drawn uniformly from this range.
    **spec_options
        Further :class:`TramSpec` fields (``length_m``, ``dwell_s``, ``broadcast_route``,
        ``exit_at_end``, ``profile``, ...); a ``cruise_factor`` here overrides the draw.

    Returns
    -------
    list of TramSpec

    Raises
    ------
    ValueError
        ``n`` is negative, or a length, headway or range is invalid.
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 0:
        raise ValueError(f"n must be a non-negative int, got {n!r}")
    if not (math.isfinite(headway_s) and headway_s >= 0):
        raise ValueError(f"headway_s must be >= 0 s, got {headway_s!r}")
    lo, hi = cruise_factor_range
    if not 0 < lo <= hi <= 1:
        raise ValueError(f"cruise_factor_range must satisfy 0 < lo <= hi <= 1, got {lo, hi}")
    gen = _as_generator(rng_or_seed)
    width = max(2, len(str(n)))
    table = _start_table(net)
    main_m = float(table.cum_m[-1]) if len(table.cum_m) else 0.0
    separation = min(min_separation_m, 0.5 * main_m / max(n, 1))
    xs = np.zeros(n)
    ys = np.zeros(n)
    specs: list[TramSpec] = []
    for i in range(n):
        for attempt in range(50):
            (edge_id, direction), offset = _random_start(net, gen, prefer_main=True)
            x, y = net.point_at(edge_id, offset)
            near = float(np.hypot(xs[:i] - x, ys[:i] - y).min(initial=np.inf))
            if near >= separation:
                break
            if attempt == 49:
                logger.debug("fleet: tram %d starts %.0f m from another", i + 1, near)
        xs[i], ys[i] = x, y
        route = random_route(net, gen, length_m=route_length_m, start=(edge_id, offset, direction))
        options = dict(spec_options)
        cruise = float(gen.uniform(lo, hi))
        options.setdefault("cruise_factor", cruise)
        specs.append(
            TramSpec(
                vehicle_id=f"{id_prefix}{i + 1:0{width}d}",
                route=route,
                depart_s=i * headway_s,
                **options,
            )
        )
    return specs
