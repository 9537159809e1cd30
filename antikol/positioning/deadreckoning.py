"""Moving a track position without a position fix: along the track, by a distance.

A vehicle without a GPS fix but with an odometer is carried along the track by the distance
its wheels ran (:func:`dead_reckon`); where the track branches each branch becomes a
hypothesis of its own and the next fix decides (:func:`carry`). Between reports a vehicle's
position is moved along its most probable path (:func:`advance`): its planned route, else
the branch that the matcher's other hypotheses already hold, else the straightest way
(:func:`preferred_path`).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable, Mapping
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from antikol.positioning.config import PositioningConfig
from antikol.positioning.estimates import (
    ESTIMATED_FIX_QUALITY,
    distances_to_estimate,
    weigh_estimate,
)
from antikol.positioning.fleet import SLOT_FIELDS, FleetState
from antikol.positioning.kalman import track_distance_step
from antikol.positioning.odometerresolution import odometer_resolution, quantisation_sigma
from antikol.positioning.outages import weigh_outage
from antikol.positioning.reach import ReachTable, state_id
from antikol.positioning.records import Hypothesis
from antikol.report import VehicleReport
from antikol.thresholds import MAX_PATHS_SEARCH
from trackmap import Path, TrackMap

__all__ = ["Advanced", "advance", "carry", "dead_reckon", "edge_mass", "preferred_path"]

_NEG_INF = -math.inf


def dead_reckon(
    fleet: FleetState,
    reach: ReachTable,
    net: TrackMap,
    config: PositioningConfig,
    stats: Counter[str],
    row: int,
    report: VehicleReport,
    odometer: float,
    *,
    speeds: bool = True,
    tunnel_edges: npt.NDArray[np.bool_] | None = None,
) -> None:
    """A report without a position: advance on the odometer, else (``speeds``) on the
    reported speeds, else only note the time.

    ``tunnel_edges`` (per edge of the map, whether it is a tunnel) when the report says the
    receiver has no fix, not when its fix was refused: the interval without a fix is then
    weighed as evidence of a tunnel (:mod:`antikol.positioning.outages`).

    Without an odometer the run is the mean of the previous and the reported speed over
    the interval, known to ``hypot(speed_sigma_mps·dt, speed_distance_sigma_fraction·run)``:
    a tram that leaves a stop in a tunnel (or while the feed repeats the stop's position)
    is carried on, not left at the stop, confident, while it runs away.
    """
    fleet.note_run_without_fix(row, report.t, report.speed_mps)
    fleet.last[row] = report
    by_odometer = math.isfinite(odometer) and math.isfinite(fleet.odo[row])
    dt = report.t - fleet.t[row]
    by_speed = (
        speeds
        and not by_odometer
        and dt > 0.0
        and math.isfinite(fleet.v[row])
        and fleet.hs[row, 0] >= 0
    )
    if not by_odometer and not by_speed:
        stats["no_fix"] += 1
        if math.isfinite(odometer):
            fleet.odo[row] = odometer
        return
    held = fleet.hs[row] >= 0
    if by_odometer:
        travelled = max(odometer - fleet.odo[row], 0.0)
        stats["odometer_dead_reckoning"] += 1
        sigma_m = config.odometer_sigma_fraction * travelled + 0.05
        coarse = odometer_resolution(fleet, np.array([row]))
        sigma_m += float(quantisation_sigma(coarse, step_sigma_m=config.odometer_step_sigma_m)[0])
        # the odometer's scale error is the tram's own, not fresh at every step: the
        # lag's uncertainty grows with the whole distance run since the last fix
        since_fix = fleet.odo[row] - fleet.odo_fix[row]
        since_fix = since_fix if math.isfinite(since_fix) else 0.0
        frac = config.odometer_sigma_fraction
        fleet.paa[row, held] += frac * frac * ((since_fix + travelled) ** 2 - since_fix**2)
    else:
        travelled = 0.5 * (float(fleet.v[row]) + report.speed_mps) * dt
        stats["speed_dead_reckoning"] += 1
        sigma_m = math.hypot(
            config.speed_sigma_mps * dt, config.speed_distance_sigma_fraction * travelled
        )
        fleet.paa[row, held] += sigma_m * sigma_m
    if not math.isnan(fleet.kf.t[row]):
        track_distance_step(
            fleet.kf, row, np.float64(report.t), np.float64(travelled), np.float64(sigma_m)
        )
    carry(fleet, reach, net, row, travelled, report.route)
    if tunnel_edges is not None and weigh_outage(
        fleet,
        row,
        tunnel_edges,
        dt,
        surface_outage_s=config.surface_outage_s,
        switch_probability=config.switch_probability,
        floor=10.0 * config.min_probability,
    ):
        stats["outage_lineage_switch"] += 1
        fleet.confident_run[row] = 0  # the reported place's run starts again
    if report.fix_quality == ESTIMATED_FIX_QUALITY and config.estimated_fix_sigma_m > 0.0:
        stats["estimated_position"] += 1
        if weigh_estimate(
            fleet,
            row,
            distances_to_estimate(net, fleet, row, report.lon, report.lat),
            sigma_m=config.estimated_fix_sigma_m,
            outlier_weight=config.outlier_weight,
            switch_probability=config.switch_probability,
            most_probability=0.5 * (config.switch_probability + config.confidence),
            floor=10.0 * config.min_probability,
        ):
            stats["estimate_lineage_switch"] += 1
            fleet.confident_run[row] = 0
    fleet.z[row] += travelled
    standing = travelled < config.standstill_distance_m and math.isfinite(dt)
    fleet.stood[row] = fleet.stood[row] + dt if standing else 0.0
    if math.isfinite(odometer):
        fleet.odo[row] = odometer
    fleet.t[row] = report.t
    fleet.v[row] = report.speed_mps  # the wheel speed: the next physics check needs it


def carry(
    fleet: FleetState,
    reach: ReachTable,
    net: TrackMap,
    row: int,
    travelled_m: float,
    route: tuple[int, ...] | None,
) -> None:
    """Move every hypothesis of a vehicle ``travelled_m`` along the track (odometer dead
    reckoning). Where the track branches, each branch becomes a hypothesis of its own
    (equally likely, or the planned route's): the next fix decides. The reported lineage
    (slot 0) goes on along the branch holding the most probability of all hypotheses."""
    f = fleet
    slots = np.flatnonzero(f.hs[row] >= 0)
    # log-p, state, offset, parent slot, the state it entered its own from (-1: not known)
    grown: list[tuple[float, int, float, int, float]] = []
    for k in slots.tolist():
        s = int(f.hs[row, k])
        edge, off, d = s >> 1, float(f.ho[row, k]), 1 - 2 * (s & 1)
        moved = off + d * travelled_m
        length = float(reach.lengths[edge])
        came = float(f.hv[row, k])
        if 0.0 <= moved <= length or travelled_m < 1e-6:
            grown.append((float(f.hp[row, k]), s, min(max(moved, 0.0), length), k, came))
            continue
        paths = net.paths_ahead(
            edge,
            off,
            d,
            travelled_m,
            respect_direction=bool(reach.allowed[s]),
            max_paths=MAX_PATHS_SEARCH,
        )
        if route and paths:
            paths = [preferred_path(paths, route)]
        if not paths:
            grown.append((float(f.hp[row, k]), s, min(max(moved, 0.0), length), k, came))
            continue
        share = math.log(1.0 / len(paths))
        for p in paths:
            last = p.steps[-1]
            sid = int(state_id(last.edge_id, last.direction))
            if sid == s:
                entered = came
            elif len(p.steps) > 1:
                entered = float(state_id(p.steps[-2].edge_id, p.steps[-2].direction))
            else:  # pragma: no cover - a path that leaves its edge has a second step
                entered = -1.0
            grown.append((float(f.hp[row, k]) + share, sid, last.exit_offset_m, k, entered))
    if not grown:
        return
    # the reported lineage goes on along the branch that holds the most probability
    mass: dict[int, float] = {}
    for g in grown:
        mass[g[1]] = mass.get(g[1], 0.0) + math.exp(g[0])
    first = max((g for g in grown if g[3] == 0), key=lambda g: (mass[g[1]], g[0]), default=None)
    rest = sorted((g for g in grown if g is not first), key=lambda g: -g[0])
    kept = ([first] if first is not None else []) + rest
    kept = kept[: fleet.k]
    parents = np.array([g[3] for g in kept])
    cols = {name: getattr(f, name)[row, parents].copy() for name in SLOT_FIELDS}
    f.hs[row] = -1
    f.hp[row] = _NEG_INF
    m = len(kept)
    f.hs[row, :m] = [g[1] for g in kept]
    for name, values in cols.items():
        getattr(f, name)[row, :m] = values
    f.ho[row, :m] = [g[2] for g in kept]
    f.hv[row, :m] = [g[4] for g in kept]
    lp = np.array([g[0] for g in kept])
    f.hp[row, :m] = lp - np.logaddexp.reduce(lp)
    f.hg[row, :m] += travelled_m


class Advanced(NamedTuple):
    """A track position moved by :func:`advance`.

    Attributes
    ----------
    edge_id, offset_m, direction
        Where it is now (edge id, m from the edge's start, +1/-1).
    branch_share : float
        When the move passed a switch: the share of the other hypotheses' probability
        beyond the start edge that lies on the path taken (1.0 when no switch was passed or
        no hypothesis lies beyond). A position carried past a switch is no surer of its
        branch than the hypotheses are.
    via : tuple of (int, int)
        The (edge, direction) states a forward move entered beyond its start edge, in
        order, the last one where it is now (empty when it stayed on its edge or moved
        back): the way it came, which the track alone does not tell past a junction
        where tracks join.
    """

    edge_id: int
    offset_m: float
    direction: int
    branch_share: float = 1.0
    via: tuple[tuple[int, int], ...] = ()


def advance(
    net: TrackMap,
    edge: int,
    offset: float,
    direction: int,
    distance_m: float,
    report: VehicleReport | None,
    *,
    wrong: bool,
    edge_mass: Mapping[tuple[int, int], float] | None = None,
    came_from: tuple[int, int] | None = None,
) -> Advanced:
    """Move a track position by a signed distance along its most probable path.

    Parameters
    ----------
    net : TrackMap
    edge, offset, direction
        The start (edge id, m from the edge's start, +1/-1).
    distance_m : float
        How far to move, m; a move back stops at the start of the edge unless it runs
        through ``came_from``.
    report : VehicleReport or None
        Its planned route, when it has one, chooses the branch.
    wrong : bool
        Running against the permitted direction (physical moves only).
    edge_mass : mapping of (int, int) to float, optional
        Probability held by other hypotheses in each (edge, direction) state: without a
        route, the path holding the most of it is taken at a switch (the straightest on a
        tie).
    came_from : (int, int), optional
        The (edge, direction) state the vehicle was placed on before: a move back past
        the start of the edge follows the track back through it (the way the vehicle
        came), and stops at the start of the edge when no track back reaches it.

    Returns
    -------
    Advanced
    """
    if abs(distance_m) < 1e-6:
        return Advanced(edge, offset, direction)
    length = net.edge_length(edge)
    moved = offset + direction * distance_m
    if 0.0 <= moved <= length:  # the common case: still on the same edge
        return Advanced(edge, moved, direction)
    if distance_m > 0:
        paths = net.paths_ahead(
            edge,
            offset,
            direction,
            distance_m,
            respect_direction=not wrong,
            max_paths=MAX_PATHS_SEARCH,
        )
        if not paths:
            return Advanced(edge, min(max(moved, 0.0), length), direction)
        route = report.route if report is not None else None
        taken = preferred_path(paths, route, edge_mass=edge_mass)
        last = taken.steps[-1]
        return Advanced(
            last.edge_id,
            last.exit_offset_m,
            last.direction,
            _share(paths, taken, edge_mass),
            tuple((st.edge_id, int(st.direction)) for st in taken.steps[1:]),
        )
    # behind the start of the edge (the filter lags the matched lineage, or kept its
    # prediction over an outlier fix): back the way the vehicle came, when it is known;
    # guessing a branch behind would be worse than stopping at the node
    if came_from is not None and came_from != (edge, direction):
        back = _back_through(net, edge, offset, direction, -distance_m, came_from)
        if back is not None:
            return back
    return Advanced(edge, min(max(moved, 0.0), length), direction)


def _back_through(
    net: TrackMap, edge: int, offset: float, direction: int, run_m: float, via: tuple[int, int]
) -> Advanced | None:
    """``run_m`` back along the track from a position, on the way that runs through the
    state ``via`` (None when no way back within ``run_m`` does)."""
    reverse = net.paths_ahead(
        edge, offset, -direction, run_m, respect_direction=False, max_paths=MAX_PATHS_SEARCH
    )
    # running back through ``via`` is running its edge against its direction
    target = (via[0], -via[1])
    for path in reverse:
        if any((st.edge_id, int(st.direction)) == target for st in path.steps[1:]):
            last = path.steps[-1]
            return Advanced(last.edge_id, last.exit_offset_m, -int(last.direction))
    return None


def _states(path: Path) -> set[tuple[int, int]]:
    """The (edge, direction) states a path runs through beyond its start edge."""
    return {(st.edge_id, int(st.direction)) for st in path.steps[1:]}


def _share(
    paths: list[Path], taken: Path, edge_mass: Mapping[tuple[int, int], float] | None
) -> float:
    if not edge_mass or len(paths) < 2:
        return 1.0
    beyond = set().union(*(_states(p) for p in paths))
    everywhere = sum(edge_mass.get(s, 0.0) for s in beyond)
    if everywhere <= 0.0:
        return 1.0
    return sum(edge_mass.get(s, 0.0) for s in _states(taken)) / everywhere


def edge_mass(hypotheses: Iterable[Hypothesis]) -> dict[tuple[int, int], float]:
    """Probability held by the hypotheses in each (edge, direction) state (for
    :func:`advance`: a hypothesis running the other way on a branch is no vote for it)."""
    mass: dict[tuple[int, int], float] = {}
    for h in hypotheses:
        key = (h.edge_id, h.direction)
        mass[key] = mass.get(key, 0.0) + h.probability
    return mass


def preferred_path(
    paths: list[Path],
    route: tuple[int, ...] | None,
    *,
    edge_mass: Mapping[tuple[int, int], float] | None = None,
) -> Path:
    """The path a vehicle most probably takes: along its route, else the one holding the
    most probability of other hypotheses (``edge_mass``: (edge id, direction) to
    probability; the start edge, shared by every path, does not count), else the
    straightest."""
    if route:
        on_route = set(route)
        scored = [(sum(1 for e in p.edges if e in on_route), p) for p in paths]
        top = max(s for s, _ in scored)
        if top > 1:
            return next(p for s, p in scored if s == top)
    if edge_mass and len(paths) > 1:
        held = [sum(edge_mass.get(s, 0.0) for s in _states(p)) for p in paths]
        best = max(held)
        if best > 0.0:
            paths = [p for p, m in zip(paths, held, strict=True) if m == best]
    return min(paths, key=lambda p: sum(1 for n in p.nodes if n.choice not in (None, "straight")))
