"""What the analysis knows of every vehicle at one time, and where to find it on the map.

A :class:`CycleViews` is built once per analysis time from the vehicle table and the
positioning: for every vehicle its speed, ends, braking distances, look-ahead and the
hypotheses worth evaluating with their paths ahead (one path per zone, each with the
probability of the vehicle taking it). The pairs are found and judged from these views by
:mod:`antikol.analysis.pairs`.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from antikol.analysis import braking
from antikol.analysis.branches import BranchModel, BranchSettings
from antikol.analysis.ends import VehicleEnds, vehicle_ends
from antikol.analysis.profiles import BrakingProfile
from antikol.positioning.records import TrackPosition
from antikol.report import VehicleReport
from trackmap import NodePass, Path, TrackMap

__all__ = [
    "ConflictApproach",
    "CycleViews",
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


@dataclass(slots=True)
class CycleViews:
    """Views of every vehicle at one time."""

    t: float
    views: dict[str, VehicleView] = field(default_factory=dict)
    _passing: dict[int, set[str]] | None = None

    def passing(self, conflict_id: int) -> set[str]:
        """The vehicles whose paths pass a conflict point (an index built on first use)."""
        if self._passing is None:
            index: dict[int, set[str]] = defaultdict(set)
            for vid, view in self.views.items():
                for h in view.hyps:
                    for ap in h.approaches:
                        index[ap.conflict_id].add(vid)
            self._passing = dict(index)
        return self._passing.get(conflict_id, set())


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
        cycle.views[vid] = view
    return cycle


def _nodes_at(path: Path) -> list[NodePass | None]:
    """For each conflict point of a path (in order), the first node within 1e-6 m of it.

    Both are sorted by distance: one walk, the window a little wider than the test so that
    no node the test would accept is skipped.
    """
    nodes = path.nodes
    out: list[NodePass | None] = []
    i = 0
    for cp in path.conflicts:
        d = cp.distance_m
        while i < len(nodes) and nodes[i].distance_m < d - 2e-6:
            i += 1
        found = None
        j = i
        while j < len(nodes) and nodes[j].distance_m <= d + 2e-6:
            if abs(nodes[j].distance_m - d) < 1e-6:
                found = nodes[j]
                break
            j += 1
        out.append(found)
    return out


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
        for cp, node in zip(p.conflicts, _nodes_at(p), strict=True):
            ap = ConflictApproach(
                cp.conflict_id,
                cp.distance_m,
                node.from_edge if node is not None else cp.edge_id,
                node.to_edge if node is not None else cp.edge_id,
            )
            mine.append(index.setdefault(ap, len(index)))
        per_path.append(tuple(mine))
    return tuple(index), tuple(per_path)
