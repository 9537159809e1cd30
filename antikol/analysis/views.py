"""What the analysis knows of every vehicle at one time, and where to find it on the map.

A :class:`CycleViews` is built once per analysis time from the vehicle table and the
positioning: for every vehicle its speed, ends, braking distances, look-ahead and the
hypotheses worth evaluating with their paths ahead (one path per zone, each with the
probability of the vehicle taking it). The pairs are found and judged from these views by
:mod:`antikol.analysis.pairs`.

Walking the paths ahead is the dear part, and it is only needed for vehicles that can
interact: two vehicles whose hypotheses are farther apart in a straight line than both
look-aheads plus both bodies, their uncertainty and a slack can share neither track nor
conflict point within either look-ahead (a path along the track is never shorter than the
straight line). The paths of the others are walked on demand (:meth:`CycleViews.expand`),
so the cost of a cycle grows with the vehicles that can interact, not with the table.
"""

from __future__ import annotations

import dataclasses
import math
from collections import defaultdict
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from antikol.analysis import braking
from antikol.analysis.branches import BranchModel, BranchSettings
from antikol.analysis.ends import VehicleEnds, vehicle_ends
from antikol.analysis.profiles import BrakingProfile
from antikol.positioning.records import Hypothesis, TrackPosition
from antikol.report import VehicleReport
from trackmap import Path, TrackMap

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
        From the antenna to the conflict point along the paths, m; negative behind the
        antenna, under the vehicle's body (its rear may still foul the point).
    from_edge, to_edge : int
        The edges the paths arrive on and leave by (in running order, behind as ahead).
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


#: Added to the sum of two vehicles' reaches before they are taken to be out of reach, m.
REACH_SLACK_M = 100.0
#: How far behind its rear a vehicle may still foul a conflict point it passed, m (the
#: longest fouling extent of a merge, with a margin).
BEHIND_REAR_M = 20.0


@dataclass(frozen=True, slots=True)
class _Chosen:
    """A hypothesis chosen for evaluation, where its paths start."""

    edge_id: int
    offset_m: float
    direction: int
    hypothesis: Hypothesis


@dataclass(slots=True)
class CycleViews:
    """Views of every vehicle at one time.

    Vehicles out of every owner's reach have no paths until :meth:`expand` is asked for
    them. ``unusable`` counts matched positions with numbers that are not finite (from a
    position source): they were treated as lost, so the sector rule judges those vehicles.
    """

    t: float
    views: dict[str, VehicleView] = field(default_factory=dict)
    _passing: dict[int, set[str]] | None = None
    _pending: dict[str, list[_Chosen]] = field(default_factory=dict)
    unusable: int = 0
    _net: TrackMap | None = None
    _branches: BranchModel | None = None
    _settings: ViewSettings | None = None

    def expand(self, vehicle_id: str) -> VehicleView:
        """The view of a vehicle with its hypotheses and paths (walked now if they were
        deferred)."""
        view = self.views[vehicle_id]
        chosen = self._pending.pop(vehicle_id, None)
        net, branches, settings = self._net, self._branches, self._settings
        if chosen is not None and net is not None and branches is not None and settings:
            view.hyps = _hypotheses(net, branches, chosen, view, settings)
            self._passing = None
        return view

    @property
    def deferred(self) -> frozenset[str]:
        """The matched vehicles whose paths have not been walked (out of reach)."""
        return frozenset(self._pending)

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
    owners: Collection[str] | None = None,
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
    owners : collection of str, optional
        The vehicles that will be assessed (on board: the own vehicle). Their paths are
        always walked, and those of the vehicles within their reach; default: every
        vehicle is an owner, and the paths of vehicles without any other in reach wait for
        :meth:`CycleViews.expand`.

    Returns
    -------
    CycleViews
    """
    branches = BranchModel.for_map(net, settings.branches)
    cycle = CycleViews(t, _net=net, _branches=branches, _settings=settings)
    positions = list(positions)
    for k, pos in enumerate(positions):
        if pos is not None and pos.unplaced:
            positions[k] = pos = _weighed_unplaced(pos)
        if pos is not None and pos.matched and not _usable(pos):
            # a position source gave numbers that are not numbers: the sector rule judges it
            positions[k] = dataclasses.replace(pos, status="lost")
            cycle.unusable += 1
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
    chosen: dict[str, list[_Chosen]] = {}
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
            chosen[vid] = _choose(pos, settings)
        cycle.views[vid] = view
    cycle._pending = chosen
    for vid in _in_reach(net, cycle.views, chosen, owners):
        cycle.expand(vid)
    return cycle


def _weighed_unplaced(pos: TrackPosition) -> TrackPosition:
    """A vehicle not yet shown on a track, as the analysis weighs it: an ``ambiguous``
    position at its first hypothesis (where it was last matched), the others with it."""
    first = pos.hypotheses[0]
    return dataclasses.replace(
        pos,
        status="ambiguous",
        edge_id=first.edge_id,
        direction=first.direction,
        offset_m=first.offset_m,
        wrong_way=first.wrong_way,
    )


def _usable(pos: TrackPosition) -> bool:
    """A matched position whose numbers the analysis can use (all finite)."""
    values = (pos.offset_m, pos.speed_mps, pos.sigma_m if pos.sigma_m is not None else 0.0)
    return all(v is not None and math.isfinite(v) for v in values) and all(
        math.isfinite(h.offset_m) and math.isfinite(h.probability) for h in pos.hypotheses
    )


def _choose(pos: TrackPosition, settings: ViewSettings) -> list[_Chosen]:
    """The hypotheses of a position worth evaluating."""
    picked = [h for h in pos.hypotheses if h.probability >= settings.min_hypothesis_probability]
    picked = picked[: settings.max_hypotheses] or list(pos.hypotheses[:1])
    out = []
    for k, h in enumerate(picked):
        if k == 0 and pos.edge_id is not None and pos.offset_m is not None:
            # the reported (filtered, possibly dead-reckoned) estimate of the first one
            out.append(_Chosen(pos.edge_id, pos.offset_m, pos.direction or h.direction, h))
        else:
            out.append(_Chosen(h.edge_id, h.offset_m, h.direction, h))
    return out


def _reach_m(view: VehicleView) -> float:
    """How far from its antenna a vehicle can meet another's body or path, m (the slack
    shared by a pair is added once, half from each)."""
    ends = abs(view.ends.front_m) + abs(view.ends.rear_m)
    return view.horizon_m + ends + 4.0 * view.sigma_m + 0.5 * REACH_SLACK_M


def _in_reach(
    net: TrackMap,
    views: Mapping[str, VehicleView],
    chosen: Mapping[str, list[_Chosen]],
    owners: Collection[str] | None,
) -> set[str]:
    """The vehicles whose paths a cycle needs: the owners (when given) and every vehicle
    with an owner within reach."""
    ids = list(chosen)
    if not ids:
        return set()
    vehicle = np.repeat(np.arange(len(ids)), [len(chosen[v]) for v in ids])
    edges = [c.edge_id for v in ids for c in chosen[v]]
    offsets = [c.offset_m for v in ids for c in chosen[v]]
    x, y = net.points_at(edges, offsets)
    is_owner = np.ones(len(ids), dtype=bool)
    if owners is not None:
        wanted = set(owners)
        is_owner = np.array([v in wanted for v in ids], dtype=bool)
    needed = {v for v, own in zip(ids, is_owner.tolist(), strict=True) if own} if owners else set()
    reach = np.array([_reach_m(views[v]) for v in ids])[vehicle]
    xy = np.column_stack([x, y])
    if is_owner.sum() <= 8:
        rows = np.flatnonzero(is_owner[vehicle])
        dist = np.hypot(xy[rows, None, 0] - xy[None, :, 0], xy[rows, None, 1] - xy[None, :, 1])
        near = dist <= reach[rows, None] + reach[None, :]
        i, j = np.nonzero(near)
        a, b = vehicle[rows[i]], vehicle[j]
    else:
        pairs = cKDTree(xy).query_pairs(2.0 * float(reach.max()), output_type="ndarray")
        p, q = pairs[:, 0], pairs[:, 1]
        d = np.hypot(xy[p, 0] - xy[q, 0], xy[p, 1] - xy[q, 1])
        keep = d <= reach[p] + reach[q]
        a, b = vehicle[p[keep]], vehicle[q[keep]]
        both = is_owner[a] | is_owner[b]
        a, b = a[both], b[both]
    distinct = a != b
    needed.update(ids[k] for k in np.unique(np.concatenate([a[distinct], b[distinct]])).tolist())
    return needed


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
    chosen: list[_Chosen],
    view: VehicleView,
    settings: ViewSettings,
) -> list[HypothesisView]:
    """The chosen hypotheses of a vehicle with their paths ahead."""
    total = sum(c.hypothesis.probability for c in chosen) or 1.0
    out = []
    for c in chosen:
        h, edge, off, d = c.hypothesis, c.edge_id, c.offset_m, c.direction
        paths = tuple(
            net.paths_ahead(edge, off, d, view.horizon_m, respect_direction=not h.wrong_way)
        )
        probs = tuple(
            branches.path_probability(p, view.speed_mps, view.report.route) for p in paths
        )
        trusted = not h.wrong_way or h.wrong_way_s >= settings.wrong_way_evidence_s
        behind = _tracks_behind(net, edge, off, d, abs(view.ends.rear_m) + BEHIND_REAR_M)
        approaches, path_approaches = _approaches(paths, behind)
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


def _tracks_behind(
    net: TrackMap, edge_id: int, offset_m: float, direction: int, back_m: float
) -> tuple[Path, ...]:
    """The tracks up to ``back_m`` behind an antenna (walked backwards, every physical
    move), where they can hold a conflict point: none when the antenna is farther than
    that from its edge's entry node and the edge has no crossing along it."""
    to_entry_m = offset_m if direction > 0 else net.edges[edge_id].length_m - offset_m
    if to_entry_m > back_m and edge_id not in _edges_with_crossings(net):
        return ()
    return tuple(net.paths_ahead(edge_id, offset_m, -direction, back_m, respect_direction=False))


_CROSSING_EDGES: dict[int, tuple[object, frozenset[int]]] = {}


def _edges_with_crossings(net: TrackMap) -> frozenset[int]:
    """The edges with a conflict point along them, not at a node (kept per map)."""
    known = _CROSSING_EDGES.get(id(net))
    if known is not None and known[0] is net.conflicts:
        return known[1]
    edges = frozenset(e for c in net.conflicts if c.node_id is None for e in c.edges)
    if len(_CROSSING_EDGES) > 16:
        _CROSSING_EDGES.clear()
    _CROSSING_EDGES[id(net)] = (net.conflicts, edges)
    return edges


def _approaches(
    paths: tuple[Path, ...], behind: tuple[Path, ...] = ()
) -> tuple[tuple[ConflictApproach, ...], tuple[tuple[int, ...], ...]]:
    """The distinct ways a hypothesis' paths pass conflict points, and each path's.

    A way is the conflict point with the move of the first node of the path within 1e-6 m
    of it (the edges it arrives on and leaves by), or its own edge when no node is there (a
    crossing along edges).

    The conflict points on the tracks ``behind`` the antenna (walked backwards) are ways
    at negative distances, their moves turned to running order, first on every path: a
    vehicle whose front has passed a diamond still fouls it with its body for another.
    Where the tracks behind part (a merge or a crossover the vehicle has passed, walked
    backwards), only the conflict points up to that node count, there by every way: which
    track the vehicle came from is not known, and the far switch of a crossover behind it
    is not on its way.
    """
    # keyed by plain tuples: hashing a frozen dataclass rebuilds a tuple on every look-up
    index: dict[tuple[int, float, int, int], int] = {}
    back: list[int] = []
    parting_m = _parting_m(behind) if behind else math.inf
    for p in behind:
        for cid, d, walked_from, walked_to in _ways(p):
            if d > parting_m + 1e-6:
                break
            k = index.setdefault((cid, -d, walked_to, walked_from), len(index))
            if k not in back:
                back.append(k)
    if len(back) > 1:
        keys = list(index)
        back.sort(key=lambda k: keys[k][1])  # running order: the farthest behind first
    per_path = []
    for p in paths:
        mine = list(back)
        for key in _ways(p):
            mine.append(index.setdefault(key, len(index)))
        per_path.append(tuple(mine))
    return tuple(ConflictApproach(*key) for key in index), tuple(per_path)


def _parting_m(paths: tuple[Path, ...]) -> float:
    """Distance to the node where the paths part (no node: infinite), m."""
    if len(paths) < 2:
        return math.inf
    edges = [p.edges for p in paths]
    common = 0
    while all(len(e) > common and e[common] == edges[0][common] for e in edges):
        common += 1
    return paths[0].steps[common - 1].end_m if common else 0.0


def _ways(p: Path) -> list[tuple[int, float, int, int]]:
    """The ways one path passes its conflict points, in its running order. Conflict points
    and nodes are both sorted by distance: one walk, the window a little wider than the
    test so that no node the test would accept is skipped."""
    out = []
    nodes = p.nodes
    n_nodes = len(nodes)
    i = 0
    for cp in p.conflicts:
        d = cp.distance_m
        while i < n_nodes and nodes[i].distance_m < d - 2e-6:
            i += 1
        key = None
        for j in range(i, n_nodes):
            node = nodes[j]
            if node.distance_m > d + 2e-6:
                break
            if abs(node.distance_m - d) < 1e-6:
                key = (cp.conflict_id, d, node.from_edge, node.to_edge)
                break
        out.append((cp.conflict_id, d, cp.edge_id, cp.edge_id) if key is None else key)
    return out
