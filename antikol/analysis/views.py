"""What the analysis knows of every vehicle at one time, and where to find it on the map.

A :class:`CycleViews` is built once per analysis time from the vehicle table and the
positioning: for every vehicle its speed, ends, braking distances, look-ahead and the
hypotheses worth evaluating with their paths ahead (one path per zone, each with the
probability of the vehicle taking it); and two indices that let a pair be found without
comparing every vehicle with every other: which hypotheses stand on each edge, and which
paths pass each conflict point.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from antikol.analysis import braking
from antikol.analysis.branches import BranchModel, BranchSettings
from antikol.analysis.ends import VehicleEnds, vehicle_ends
from antikol.analysis.profiles import BrakingProfile
from antikol.positioning.records import TrackPosition
from antikol.report import VehicleReport
from trackmap import NodePass, Path, PathStep, TrackMap

__all__ = [
    "ConflictApproach",
    "ConflictEntry",
    "CycleViews",
    "EdgeEntry",
    "HypothesisView",
    "VehicleView",
    "ViewSettings",
    "build_views",
]


@dataclass(frozen=True, slots=True)
class ViewSettings:
    """What the views need of the analyser's configuration (SI units)."""

    min_horizon_m: float
    max_hypotheses: int
    min_hypothesis_probability: float
    wrong_way_evidence_s: float
    standing_speed_mps: float
    branches: BranchSettings


@dataclass(frozen=True, slots=True)
class ConflictApproach:
    """One way through a conflict point: the paths of a hypothesis that take it share it.

    Attributes
    ----------
    conflict_id : int
    distance_m : float
        From the antenna to the conflict point along the paths, m.
    from_edge, to_edge : int
        The edges the paths arrive on and leave by.
    """

    conflict_id: int
    distance_m: float
    from_edge: int
    to_edge: int


@dataclass(frozen=True, slots=True)
class HypothesisView:
    """One place a vehicle may be, with the paths ahead of it.

    Attributes
    ----------
    edge_id, direction, offset_m
        Where the antenna is.
    probability : float
        Normalised over the hypotheses kept for evaluation.
    wrong_way : bool
        Running against the track's permitted direction.
    trusted : bool
        Not wrong way, or wrong way on sustained evidence: only trusted hypotheses may
        raise more than an advisory.
    paths : tuple of Path
        One per zone ahead (a branch at each facing switch).
    path_probability : tuple of float
        Probability of taking each path (from the planned route, or the options at every
        facing switch that the vehicle can still take at its speed, see
        :mod:`antikol.analysis.branches`).
    approaches : tuple of ConflictApproach
        The distinct ways the paths pass conflict points.
    path_approaches : tuple of tuple of int
        For each path, the indices of its approaches in running order.
    edge_steps : dict of int to tuple
        For each edge the paths pass, the (path index, step) pairs, in path order.
    """

    edge_id: int
    direction: int
    offset_m: float
    probability: float
    wrong_way: bool
    trusted: bool
    paths: tuple[Path, ...]
    path_probability: tuple[float, ...]
    approaches: tuple[ConflictApproach, ...] = ()
    path_approaches: tuple[tuple[int, ...], ...] = ()
    edge_steps: dict[int, tuple[tuple[int, PathStep], ...]] = field(default_factory=dict)


@dataclass(slots=True)
class VehicleView:
    """Everything about one vehicle at one analysis time.

    Attributes
    ----------
    report : VehicleReport
        The latest report.
    position : TrackPosition or None
        Its track position at the analysis time (None without a map).
    speed_mps : float
        Filtered speed when matched, else the reported speed.
    ends : VehicleEnds
    sigma_m : float
        One-sigma uncertainty of the along-track position plus the ends, m.
    warning_m, emergency_m : float
        Distance needed to stop before a standing obstacle at the warning and emergency
        levels (reaction, brake build-up, braking, margin), m.
    horizon_m : float
        Look-ahead along the track, m.
    hyps : list of HypothesisView
    """

    report: VehicleReport
    position: TrackPosition | None
    speed_mps: float
    ends: VehicleEnds
    sigma_m: float
    warning_m: float
    emergency_m: float
    horizon_m: float
    hyps: list[HypothesisView] = field(default_factory=list)

    @property
    def vehicle_id(self) -> str:
        """The vehicle's id."""
        return self.report.vehicle_id

    @property
    def matched(self) -> bool:
        """True when positioned on the map (confident or ambiguous)."""
        return self.position is not None and self.position.matched


@dataclass(frozen=True, slots=True)
class EdgeEntry:
    """A hypothesis standing on an edge: the vehicle and the hypothesis' index."""

    vehicle_id: str
    hyp: int


@dataclass(frozen=True, slots=True)
class ConflictEntry:
    """A vehicle's hypothesis passing a conflict point one way.

    Attributes
    ----------
    vehicle_id : str
    hyp : int
        Index of the hypothesis.
    distance_m : float
        From the antenna to the conflict point along its paths, m.
    from_edge, to_edge : int
        The edges the paths arrive on and leave by.
    probability : float
        Probability that the vehicle takes this way (the most probable of its paths
        through the point that way).
    """

    vehicle_id: str
    hyp: int
    distance_m: float
    from_edge: int
    to_edge: int
    probability: float


@dataclass(slots=True)
class CycleViews:
    """Views of every vehicle at one time, with the edge and conflict-point indices."""

    t: float
    views: dict[str, VehicleView] = field(default_factory=dict)
    by_edge: dict[int, list[EdgeEntry]] = field(default_factory=dict)
    #: conflict point -> vehicle -> the paths of that vehicle passing it
    by_conflict: dict[int, dict[str, list[ConflictEntry]]] = field(default_factory=dict)
    #: scratch of the pair evaluations of this time: each vehicle's way through a fouling
    #: area, and each other vehicle's way with its earliest arrival there (s)
    ways: dict[tuple[str, ConflictApproach], Any] = field(default_factory=dict)
    arrivals: dict[ConflictEntry, tuple[Any, float]] = field(default_factory=dict)


def build_views(
    net: TrackMap,
    reports: Sequence[VehicleReport],
    positions: Sequence[TrackPosition | None],
    profiles: Mapping[str, BrakingProfile],
    default_profile: BrakingProfile,
    settings: ViewSettings,
    t: float,
    moving: Mapping[str, bool],
) -> CycleViews:
    """Build the views and indices of one analysis time.

    Parameters
    ----------
    net : TrackMap
    reports : sequence of VehicleReport
        The latest report of every vehicle in the table.
    positions : sequence of TrackPosition or None
        Their positions at ``t``, in the same order.
    profiles : mapping of str to BrakingProfile
        Per-vehicle profiles; others use ``default_profile``.
    default_profile : BrakingProfile
    settings : ViewSettings
    t : float
        The analysis time, s.
    moving : mapping of str to bool
        Whether each vehicle moves; a standing vehicle's speed is taken as 0 (its speed over
        ground is receiver noise).

    Returns
    -------
    CycleViews
    """
    cycle = CycleViews(t)
    by_edge: dict[int, list[EdgeEntry]] = defaultdict(list)
    by_conflict: dict[int, dict[str, list[ConflictEntry]]] = defaultdict(dict)
    speeds = np.array(
        [
            (pos.speed_mps if pos is not None and pos.matched else r.speed_mps)
            if moving.get(r.vehicle_id, True)
            else 0.0
            for r, pos in zip(reports, positions, strict=True)
        ],
        dtype=float,
    )
    warn, emerg, horizon = _distances(reports, speeds, profiles, default_profile, settings)
    branches = BranchModel.for_map(net, settings.branches)
    for k, (report, pos) in enumerate(zip(reports, positions, strict=True)):
        vid = report.vehicle_id
        prof = profiles.get(vid, default_profile)
        ends = vehicle_ends(report, prof)
        pos_sigma = pos.sigma_m if pos is not None and pos.sigma_m is not None else 0.0
        view = VehicleView(
            report=report,
            position=pos,
            speed_mps=float(speeds[k]),
            ends=ends,
            sigma_m=float(np.hypot(pos_sigma, ends.sigma_m)),
            warning_m=float(warn[k]),
            emergency_m=float(emerg[k]),
            horizon_m=float(horizon[k]),
        )
        if pos is not None and pos.matched:
            view.hyps = _hypotheses(net, branches, pos, view, settings)
            for h_idx, h in enumerate(view.hyps):
                by_edge[h.edge_id].append(EdgeEntry(vid, h_idx))
                best: dict[int, float] = {}
                for p_idx, ways in enumerate(h.path_approaches):
                    for a in ways:
                        best[a] = max(best.get(a, 0.0), h.path_probability[p_idx])
                for a, prob in best.items():
                    ap = h.approaches[a]
                    by_conflict[ap.conflict_id].setdefault(vid, []).append(
                        ConflictEntry(vid, h_idx, ap.distance_m, ap.from_edge, ap.to_edge, prob)
                    )
        cycle.views[vid] = view
    cycle.by_edge = dict(by_edge)
    cycle.by_conflict = dict(by_conflict)
    return cycle


def _node_at(path: Path, distance_m: float) -> NodePass | None:
    for n in path.nodes:
        if abs(n.distance_m - distance_m) < 1e-6:
            return n
    return None


def _distances(
    reports: Sequence[VehicleReport],
    speeds: np.ndarray,
    profiles: Mapping[str, BrakingProfile],
    default_profile: BrakingProfile,
    settings: ViewSettings,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Warning and emergency stopping distances and look-ahead of every vehicle, vectorised
    per braking profile, m."""
    n = len(reports)
    warn, emerg, horizon = np.zeros(n), np.zeros(n), np.zeros(n)
    groups: dict[int, list[int]] = defaultdict(list)
    chosen: dict[int, BrakingProfile] = {}
    for k, r in enumerate(reports):
        prof = profiles.get(r.vehicle_id, default_profile)
        groups[id(prof)].append(k)
        chosen[id(prof)] = prof
    for key, members in groups.items():
        prof = chosen[key]
        idx = np.array(members)
        v = speeds[idx]
        warn[idx] = braking.warning_distance(v, prof)
        emerg[idx] = braking.emergency_distance(v, prof)
        horizon[idx] = braking.horizon_m(v, prof, minimum_m=settings.min_horizon_m)
    return warn, emerg, horizon


def _hypotheses(
    net: TrackMap,
    branches: BranchModel,
    pos: TrackPosition,
    view: VehicleView,
    settings: ViewSettings,
) -> list[HypothesisView]:
    """The hypotheses of a position worth evaluating, with their paths ahead."""
    chosen = [h for h in pos.hypotheses if h.probability >= settings.min_hypothesis_probability]
    chosen = chosen[: settings.max_hypotheses] or list(pos.hypotheses[:1])
    total = sum(h.probability for h in chosen) or 1.0
    out = []
    for k, h in enumerate(chosen):
        if k == 0 and pos.edge_id is not None and pos.offset_m is not None:
            # the reported (filtered, possibly dead-reckoned) estimate of the first one
            edge, off, d = pos.edge_id, pos.offset_m, pos.direction or h.direction
        else:
            edge, off, d = h.edge_id, h.offset_m, h.direction
        paths = tuple(
            net.paths_ahead(edge, off, d, view.horizon_m, respect_direction=not h.wrong_way)
        )
        probs = tuple(
            branches.path_probability(p, view.speed_mps, view.report.route) for p in paths
        )
        trusted = not h.wrong_way or h.wrong_way_s >= settings.wrong_way_evidence_s
        approaches, path_approaches = _approaches(paths)
        steps: dict[int, list[tuple[int, PathStep]]] = defaultdict(list)
        for p_idx, p in enumerate(paths):
            for step in p.steps:
                steps[step.edge_id].append((p_idx, step))
        out.append(
            HypothesisView(
                edge,
                d,
                off,
                h.probability / total,
                h.wrong_way,
                trusted,
                paths,
                probs,
                approaches,
                path_approaches,
                {e: tuple(v) for e, v in steps.items()},
            )
        )
    return out


def _approaches(
    paths: tuple[Path, ...],
) -> tuple[tuple[ConflictApproach, ...], tuple[tuple[int, ...], ...]]:
    """The distinct ways a hypothesis' paths pass conflict points, and each path's."""
    index: dict[ConflictApproach, int] = {}
    per_path = []
    for p in paths:
        mine = []
        for cp in p.conflicts:
            node = _node_at(p, cp.distance_m)
            ap = ConflictApproach(
                cp.conflict_id,
                cp.distance_m,
                node.from_edge if node is not None else cp.edge_id,
                node.to_edge if node is not None else cp.edge_id,
            )
            mine.append(index.setdefault(ap, len(index)))
        per_path.append(tuple(mine))
    return tuple(index), tuple(per_path)
