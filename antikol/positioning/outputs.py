"""Track positions of many vehicles at once: the geometry of their places in arrays.

Deciding where a vehicle is (its along-track estimate, dead reckoning, the hold at an
undecided switch) is per vehicle; what follows from the place — its point in the local
frame, its longitude and latitude, its heading — is the same computation for every
vehicle, and one array call of shapely and pyproj for a fleet costs what three scalar
calls cost for one vehicle. :func:`track_positions` turns the :class:`Placement` of every
vehicle asked for into its :class:`~antikol.positioning.records.TrackPosition`, with the
numbers, to the last bit, of one scalar call per vehicle
(:meth:`trackmap.TrackMap.headings_at`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from antikol.errors import InvalidArgumentError
from antikol.kinds import PositionStatus
from antikol.numeric import finite_float, why_not_finite
from antikol.positioning.records import Hypothesis, TrackPosition
from antikol.report import VehicleReport
from trackmap import TrackMap

__all__ = [
    "Placement",
    "asked_time",
    "hypotheses_of",
    "track_positions",
    "unmatched_position",
    "unplaced_position",
]


class Placement(NamedTuple):
    """Where a matched vehicle is, before its geometry (see :class:`TrackPosition` for
    the attributes; SI units; ``held``: reported at a switch behind it whose branch is
    undecided). A named tuple: one is built per vehicle and cycle."""

    vehicle_id: str
    t: float
    status: PositionStatus
    edge_id: int
    direction: int
    offset_m: float
    speed_mps: float
    probability: float
    sigma_m: float
    wrong_way: bool
    hypotheses: tuple[Hypothesis, ...]
    dead_reckoned_s: float
    held: bool = False


def track_positions(net: TrackMap, placements: Sequence[Placement]) -> list[TrackPosition]:
    """The track positions of placed vehicles, their geometry computed in arrays.

    Parameters
    ----------
    net : TrackMap
    placements : sequence of Placement

    Returns
    -------
    list of TrackPosition
        In the order of ``placements``.
    """
    if not placements:
        return []
    if len(placements) == 1:  # one vehicle (on board): scalar calls cost less than arrays
        p = placements[0]
        lo, la = net.to_lonlat(*net.point_at(p.edge_id, p.offset_m))
        lons, lats = [lo], [la]
        headings = [net.heading_at(p.edge_id, p.offset_m, p.direction)]
    else:
        edges = [p.edge_id for p in placements]
        offsets = [p.offset_m for p in placements]
        x, y = net.points_at(edges, offsets)
        lon, lat = net.to_lonlat(x, y)
        lons, lats = lon.tolist(), lat.tolist()
        headings = net.headings_at(edges, offsets, [p.direction for p in placements]).tolist()
    # positional arguments, in the order of TrackPosition's fields (a test checks it):
    # keywords cost a third more per record
    return [
        TrackPosition(vid, t, status, edge, direction, off, lo, la, h, v, p, sd, ww, hyps, dr)
        for (vid, t, status, edge, direction, off, v, p, sd, ww, hyps, dr, _), lo, la, h in zip(
            placements, lons, lats, headings, strict=True
        )
    ]


def hypotheses_of(
    states: npt.NDArray[np.int64],
    offsets_m: npt.NDArray[np.float64],
    log_probability: npt.NDArray[np.float64],
    progress_m: npt.NDArray[np.float64],
    wrong_way_s: npt.NDArray[np.float64],
    allowed: npt.NDArray[np.bool_],
) -> list[tuple[Hypothesis, ...]]:
    """The hypotheses of many vehicles from their rows of the matcher's arrays.

    Parameters
    ----------
    states : ndarray of int, shape (vehicles, slots)
        Track state of each slot (``2 * edge + (direction < 0)``; negative: empty).
    offsets_m, log_probability, progress_m, wrong_way_s : ndarray, same shape
        Offset on the edge (m), log probability, progress along the history (m) and time
        running wrong way (s) of each slot.
    allowed : ndarray of bool
        Whether each track state runs the permitted direction.

    Returns
    -------
    list of tuple of Hypothesis
        Per vehicle, its filled slots in order (``math.exp`` of each log probability, the
        scalar function, so that one vehicle at a time gives the same numbers).
    """
    filled = states >= 0
    # only the filled slots are read and converted (most vehicles fill one of eight; the
    # map's every state, converted, would cost more than a few vehicles' slots)
    counts = np.count_nonzero(filled, axis=1).tolist()
    flat = [
        a[filled].tolist() for a in (states, offsets_m, log_probability, progress_m, wrong_way_s)
    ]
    wrong = (~allowed[states[filled]]).tolist()
    hyps = [
        # positional: edge_id, direction, offset_m, probability, progress_m, wrong_way,
        # wrong_way_s (a test keeps the order)
        Hypothesis(s >> 1, 1 - 2 * (s & 1), o, math.exp(p), g, bad, w)
        for s, o, p, g, w, bad in zip(*flat, wrong, strict=True)
    ]
    out: list[tuple[Hypothesis, ...]] = []
    start = 0
    for n in counts:
        out.append(tuple(hyps[start : start + n]))
        start += n
    return out


def unmatched_position(report: VehicleReport, t: float) -> TrackPosition:
    """The position of a vehicle no track explains: its report's fix as it stands."""
    return TrackPosition(
        vehicle_id=report.vehicle_id,
        t=t,
        status="unmatched",
        edge_id=None,
        direction=None,
        offset_m=None,
        lon=report.lon,
        lat=report.lat,
        heading_deg=None,
        speed_mps=report.speed_mps,
        probability=0.0,
        sigma_m=None,
    )


def unplaced_position(placed: TrackPosition, report: VehicleReport | None) -> TrackPosition:
    """The position of a vehicle not yet shown on a track (:mod:`antikol.positioning.showing`):
    ``lost`` without an edge, at its report's fix, its hypotheses and the numbers of its
    place as ``placed`` has them."""
    return dataclasses.replace(
        placed,
        status="lost",
        edge_id=None,
        direction=None,
        offset_m=None,
        lon=placed.lon if report is None else report.lon,
        lat=placed.lat if report is None else report.lat,
        heading_deg=None,
        wrong_way=False,
    )


def asked_time(t: object) -> float | None:
    """A time a position is asked for, s (None: none given), checked.

    Raises
    ------
    InvalidArgumentError
        ``t`` is not a finite number.
    """
    if t is None:
        return None
    value = finite_float(t)
    if value is None:
        raise InvalidArgumentError("t", t, why_not_finite(t) or "must be a finite time, s")
    return value
