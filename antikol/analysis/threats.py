"""What an assessment shows of a pair judged on the track views.

:func:`track_threat` turns a pair's outcome (:mod:`antikol.analysis.pairs`) into the
:class:`~antikol.analysis.assessment.Threat` a driver or an operator sees, with the
assumptions it rests on (the ends, the match probabilities, the conflict probability of an
ambiguous conflict). :func:`suppression_reason` says why the map cleared a vehicle that the
paper's sector rule would have flagged.
"""

from __future__ import annotations

import operator

import numpy as np
import shapely

from antikol.analysis import braking
from antikol.analysis.assessment import Threat
from antikol.analysis.pairs import PairOutcome
from antikol.analysis.sector import SectorHit, SectorRule
from antikol.analysis.views import CycleViews, VehicleView
from trackmap import TrackMap
from trackmap.records import positional

__all__ = ["sector_threat", "suppression_reason", "track_threat"]

_EDGE_ID = operator.attrgetter("edge_id")
#: Threats by position: every field of :class:`Threat` in its order (a test checks the
#: records against the keyword constructor); an assessment cycle builds thousands.
_threat = positional(Threat)


def track_threat(own: VehicleView, other: VehicleView, result: PairOutcome) -> Threat:
    """The threat of ``other`` to ``own`` from their pair's outcome (both matched)."""
    f = result.finding
    if own.position is None or other.position is None:  # pragma: no cover - matched
        raise RuntimeError("track threat without positions")
    detail = f"{f.detail} (zone {f.zone})"
    if result.ambiguous:
        detail += f" (conflict probability {result.probability:.2f})"
    return _threat(
        other.vehicle_id,
        f.kind,
        result.level,
        f.gap_m,  # distance_m
        f.closing_mps,
        f.ttc_s,
        "track",  # method
        f.zone,
        None,  # bearing_deg
        min(result.probability, 1.0),
        own.position.probability,  # own_match_probability
        other.position.probability,  # other_match_probability
        result.ambiguous,
        detail,
        own.ends.assumption,  # own_ends
        other.ends.assumption,  # other_ends
        False,  # held
    )


def sector_threat(
    rule: SectorRule, hit: SectorHit, closing_speed_mps: float, note: str = ""
) -> Threat:
    """The threat of a vehicle inside the own sector (the paper's rule).

    Parameters
    ----------
    rule : SectorRule
        The sector it was found in.
    hit : SectorHit
    closing_speed_mps : float
        How fast the planar distance shrinks, m/s (positive when closing).
    note : str
        Why the sector rule judged this pair (e.g. a vehicle not matched to the map).
    """
    detail = f"within {rule.d_col_m:g} m and ±{rule.half_angle_deg:g}° of own course"
    return _threat(
        hit.vehicle_id,
        "sector",  # kind
        "warning",  # level
        hit.distance_m,
        closing_speed_mps,
        braking.time_to_collision(hit.distance_m, closing_speed_mps),
        "sector",  # method
        None,  # zone
        hit.bearing_deg,
        None,  # probability
        None,  # own_match_probability
        None,  # other_match_probability
        False,  # ambiguous
        f"{detail} ({note})" if note else detail,
        None,  # own_ends
        None,  # other_ends
        False,  # held
    )


def suppression_reason(
    net: TrackMap | None,
    cycle: CycleViews,
    own: VehicleView,
    other: VehicleView,
    parallel_distance_m: float,
) -> str:
    """Why a vehicle in the sector ahead is no threat on the map.

    Parameters
    ----------
    net : TrackMap or None
    cycle : CycleViews
        The views of the analysis time (both vehicles' paths walked).
    own, other : VehicleView
    parallel_distance_m : float
        ``other`` this close to a track of the own paths is on a parallel track, m.

    Returns
    -------
    str
        ``grade_separated`` (a bridge or tunnel between the paths), ``no_overlap`` (the
        paths share a conflict point but not in time), ``parallel_track`` or
        ``not_reachable``.
    """
    if net is None:  # pragma: no cover - guarded by the caller
        return "not_reachable"
    own_edges: set[int] = set()
    for h in own.hyps:
        for p in h.paths:
            own_edges.update(map(_EDGE_ID, p.steps))
    oth_edges = {h.edge_id for h in other.hyps}
    for a, b, _, _ in net.grade_separated:
        if (a in own_edges and b in oth_edges) or (b in own_edges and a in oth_edges):
            return "grade_separated"
    shared = any(
        other.vehicle_id in cycle.passing(ap.conflict_id) for h in own.hyps for ap in h.approaches
    )
    if shared:
        return "no_overlap"
    pos = other.position
    if pos is not None and pos.edge_id is not None and pos.offset_m is not None:
        pt = shapely.Point(net.point_at(pos.edge_id, pos.offset_m))
        geoms = [net.edges[e].geometry for e in own_edges]
        # within the distance of any own track (GEOS stops at the first; the same test as
        # the smallest distance compared with it)
        if geoms and bool(np.any(shapely.dwithin(pt, geoms, parallel_distance_m))):
            return "parallel_track"
    return "not_reachable"
