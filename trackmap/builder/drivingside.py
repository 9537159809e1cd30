"""Which side trams keep to on double track, and the running direction it gives a track.

Mappers tag most main-line double track ``oneway``; some of it they leave untagged. An
untagged track with a parallel neighbour is run the way the driving side says: with
right-hand running, a track whose neighbour lies to its left (looking along the edge) is
run in the edge's direction. A map built for the wrong side gives every such track the
wrong direction, and a tram on it would be placed on the other track of its pair.

The side need not be guessed. The tagged double track of the same extract shows it: each
tagged track with a clear neighbour either runs the way right-hand running would have it
or the way left-hand running would. :func:`tally_driving_side` adds those tracks up by
length, and :func:`resolve_driving_side` takes the side they show when asked for ``auto``
(and warns when a side asked for by name contradicts them). Kraków's extract shows 177 km
of right-hand running against 2.5 km (loops and same-way pairs at stops).

>>> import shapely
>>> left_hand = [shapely.LineString([(0, 3.5), (500, 3.5)]),  # eastbound on the north track
...              shapely.LineString([(500, 0), (0, 0)])]      # westbound on the south track
>>> tally = tally_driving_side(left_hand, [1, 1], [0, 1], min_spacing_m=2.5, max_spacing_m=6.0)
>>> (round(tally.right_m), round(tally.left_m), tally.side())
(0, 1000, 'left')
>>> resolve_driving_side("auto", tally)
'left'
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np
import shapely

__all__ = [
    "DRIVING_SIDES",
    "DRIVING_SIDE_CHOICES",
    "DrivingSideTally",
    "SideEvidence",
    "direction_from_side",
    "parallel_neighbours",
    "resolve_driving_side",
    "tally_driving_side",
]

logger = logging.getLogger(__name__)

#: The sides trams keep to.
DRIVING_SIDES: Final = ("right", "left")
#: What a build may ask for: a side, or ``auto`` (the side the tagged track shows).
DRIVING_SIDE_CHOICES: Final = ("auto", *DRIVING_SIDES)
#: Tagged double track needed before it decides the side, m (a few hundred metres of one
#: pair of tracks is enough; a stray pair at a stop is not).
MIN_EVIDENCE_M: Final = 400.0
#: The share of that track that must show one side.
DOMINANCE: Final = 0.8


@dataclass(frozen=True, slots=True)
class SideEvidence:
    """Where an edge's neighbouring parallel tracks lie: sample points in all, and with the
    nearest parallel neighbour on the left and on the right."""

    samples: int
    left: int
    right: int


@dataclass(frozen=True, slots=True)
class DrivingSideTally:
    """Tagged double track by the side its running direction shows, m.

    Attributes
    ----------
    right_m : float
        Length of tagged one-way track run as right-hand running has it, m.
    left_m : float
        ... as left-hand running has it, m.
    """

    right_m: float = 0.0
    left_m: float = 0.0

    @property
    def total_m(self) -> float:
        """Tagged one-way track with a clear neighbour, m."""
        return self.right_m + self.left_m

    def side(
        self, *, min_evidence_m: float = MIN_EVIDENCE_M, dominance: float = DOMINANCE
    ) -> str | None:
        """The side the track shows, or None when there is too little of it or it is mixed.

        Parameters
        ----------
        min_evidence_m : float, keyword-only
            Least tagged track that decides, m.
        dominance : float, keyword-only
            Least share of it that must show one side.
        """
        if self.total_m < min_evidence_m:
            return None
        if self.right_m >= dominance * self.total_m:
            return "right"
        if self.left_m >= dominance * self.total_m:
            return "left"
        return None

    def describe(self) -> str:
        """The tally in words (for messages)."""
        return (
            f"tagged double track shows {self.right_m / 1000:,.1f} km of right-hand and "
            f"{self.left_m / 1000:,.1f} km of left-hand running"
        )


def parallel_neighbours(
    lines: Sequence[shapely.LineString],
    candidates: Sequence[int],
    *,
    min_spacing_m: float,
    max_spacing_m: float,
    step_m: float = 5.0,
    max_angle_deg: float = 20.0,
) -> dict[int, SideEvidence]:
    """For each candidate edge, count samples with a parallel track to its left or right.

    A sample point every ``step_m`` along the edge has a neighbour when another edge lies
    between ``min_spacing_m`` and ``max_spacing_m`` away, running parallel (within
    ``max_angle_deg``, either orientation); the nearest such edge gives the side.

    Parameters
    ----------
    lines : sequence of LineString
        Every edge's line in a metric frame (m).
    candidates : sequence of int
        The edges to look at (indices into ``lines``).
    min_spacing_m, max_spacing_m : float, keyword-only
        Track-centre spacing of double track, m.
    step_m : float, keyword-only
        Distance between sample points, m.
    max_angle_deg : float, keyword-only
        Largest angle between a track and a neighbour that counts as parallel, degrees.

    Returns
    -------
    dict of int to SideEvidence
        One entry per candidate.
    """
    cands = np.asarray(candidates, dtype=np.int64)
    if len(cands) == 0:
        return {}
    every = np.asarray(lines, dtype=object)
    own = every[cands]
    length = shapely.length(own)
    count = np.maximum((length // step_m).astype(np.int64), 1)
    which = np.repeat(np.arange(len(cands)), count)  # the candidate of each sample
    first = np.cumsum(count) - count
    index = np.arange(len(which)) - first[which]
    s = (index + 0.5) * length[which] / count[which]
    line = own[which]
    pts = shapely.line_interpolate_point(line, s)
    ahead = shapely.line_interpolate_point(line, np.minimum(s + 1.0, length[which]))
    behind = shapely.line_interpolate_point(line, np.maximum(s - 1.0, 0.0))
    tx = shapely.get_x(ahead) - shapely.get_x(behind)
    ty = shapely.get_y(ahead) - shapely.get_y(behind)
    norm = np.hypot(tx, ty)
    norm[norm == 0] = 1.0
    tx, ty = tx / norm, ty / norm

    k, o = shapely.STRtree(every).query(pts, predicate="dwithin", distance=max_spacing_m)
    keep = o != cands[which[k]]
    k, o = k[keep], o[keep]
    d = shapely.distance(pts[k], every[o])
    keep = (min_spacing_m <= d) & (d <= max_spacing_m)
    k, o, d = k[keep], o[keep], d[keep]
    other = every[o]
    along = shapely.line_locate_point(other, pts[k])
    q = shapely.line_interpolate_point(other, along)
    q2 = shapely.line_interpolate_point(other, np.minimum(along + 1.0, shapely.length(other)))
    q1 = shapely.line_interpolate_point(other, np.maximum(along - 1.0, 0.0))
    ox = shapely.get_x(q2) - shapely.get_x(q1)
    oy = shapely.get_y(q2) - shapely.get_y(q1)
    on = np.hypot(ox, oy)
    with np.errstate(divide="ignore", invalid="ignore"):
        cos = np.abs((ox * tx[k] + oy * ty[k]) / on)
    keep = (on != 0) & (cos >= math.cos(math.radians(max_angle_deg)))
    k, o, d, q = k[keep], o[keep], d[keep], q[keep]
    cross = tx[k] * (shapely.get_y(q) - shapely.get_y(pts[k])) - ty[k] * (
        shapely.get_x(q) - shapely.get_x(pts[k])
    )
    # the nearest neighbour of each sample decides (ties: the lower edge index)
    order = np.lexsort((o, d, k))
    k, cross = k[order], cross[order]
    nearest = np.ones(len(k), dtype=bool)
    nearest[1:] = k[1:] != k[:-1]
    k, on_left = k[nearest], cross[nearest] > 0
    n = len(cands)
    left = np.bincount(which[k[on_left]], minlength=n)
    right = np.bincount(which[k[~on_left]], minlength=n)
    return {
        int(e): SideEvidence(samples=int(c), left=int(lt), right=int(rt))
        for e, c, lt, rt in zip(cands, count, left, right, strict=True)
    }


def direction_from_side(
    ev: SideEvidence, driving_side: str, *, min_fraction: float = 0.5, dominance: float = 0.8
) -> int:
    """Running direction implied by the side of the neighbouring track (0 if unclear).

    With right-hand running a track whose neighbour lies to its left (looking along the
    edge) is run in the edge's direction (+1); with left-hand running, the opposite.

    Parameters
    ----------
    ev : SideEvidence
    driving_side : {"right", "left"}
    min_fraction : float, keyword-only
        Least share of the samples that must have a neighbour.
    dominance : float, keyword-only
        Least share of those whose neighbour must lie on one side.

    Returns
    -------
    int
        +1 (the edge's direction), -1 (against it) or 0 (unclear).
    """
    total = ev.left + ev.right
    if ev.samples == 0 or total < min_fraction * ev.samples:
        return 0
    if ev.left >= dominance * total:
        neighbour_left = True
    elif ev.right >= dominance * total:
        neighbour_left = False
    else:
        return 0
    forward = neighbour_left if driving_side == "right" else not neighbour_left
    return 1 if forward else -1


def tally_driving_side(
    lines: Sequence[shapely.LineString],
    directions: Sequence[int],
    tagged: Sequence[int],
    *,
    min_spacing_m: float,
    max_spacing_m: float,
) -> DrivingSideTally:
    """Add up tagged one-way double track by the side its running direction shows.

    Parameters
    ----------
    lines : sequence of LineString
        Every edge's line in a metric frame (m).
    directions : sequence of int
        Every edge's tagged running direction (+1, -1; 0: both ways).
    tagged : sequence of int
        The main-line edges whose direction is tagged (indices into ``lines``).
    min_spacing_m, max_spacing_m : float, keyword-only
        Track-centre spacing of double track, m.

    Returns
    -------
    DrivingSideTally
    """
    one_way = [i for i in tagged if directions[i] != 0]
    # (a sample every 20 m tells a track's side as well as one every 5 m, at a quarter of
    # the cost: the tally is a sum over kilometres)
    evidence = parallel_neighbours(
        lines, one_way, min_spacing_m=min_spacing_m, max_spacing_m=max_spacing_m, step_m=20.0
    )
    right_m = left_m = 0.0
    for i, ev in evidence.items():
        as_right = direction_from_side(ev, "right")
        if as_right == 0:
            continue
        if as_right == directions[i]:
            right_m += lines[i].length
        else:
            left_m += lines[i].length
    return DrivingSideTally(right_m=right_m, left_m=left_m)


def resolve_driving_side(asked: str, tally: DrivingSideTally, *, where: object = "") -> str:
    """The side a map is built for: the one asked for, or for ``auto`` the one the tagged
    track shows (right-hand running when it shows none).

    Parameters
    ----------
    asked : {"auto", "right", "left"}
    tally : DrivingSideTally
        What the source's tagged double track shows.
    where : object, keyword-only
        The source, for log messages.

    Returns
    -------
    str
        ``right`` or ``left``.

    Notes
    -----
    Logs a warning when a side asked for by name contradicts the tagged track, and when
    ``auto`` falls back to right-hand running with too little tagged track to tell.
    """
    shown = tally.side()
    if asked != "auto":
        if shown is not None and shown != asked:
            logger.warning(
                "%s: built for %s-hand running as asked, though its %s; its untagged double "
                "track is run the way the side asked for has it (driving_side='auto' "
                "follows the tags)",
                where,
                asked,
                tally.describe(),
            )
        return asked
    if shown is None:
        if tally.total_m >= MIN_EVIDENCE_M:
            logger.warning(
                "%s: %s, too mixed to tell the driving side: right-hand running assumed "
                "(pass driving_side to choose)",
                where,
                tally.describe(),
            )
        return "right"
    return shown
