"""Records of track-selective positioning: hypotheses, positions and discrete fixes."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from antikol.kinds import PositionStatus
from antikol.report import VehicleReport

__all__ = [
    "DiscreteFix",
    "FixPoint",
    "Hypothesis",
    "PositionSource",
    "TrackPosition",
    "positions_of",
]


@dataclass(frozen=True, slots=True)
class Hypothesis:
    """One place a vehicle may be.

    Attributes
    ----------
    edge_id : int
    direction : int
        +1 along the edge's vertices, -1 against them.
    offset_m : float
        Projection of the fix on the edge, m from its first vertex.
    probability : float
    progress_m : float
        Distance travelled along this hypothesis' history, m (the Kalman filter's frame).
    wrong_way : bool
        Running against the edge's permitted direction.
    wrong_way_s : float
        How long this hypothesis' history has been running wrong way, s (0 when not).
    """

    edge_id: int
    direction: int
    offset_m: float
    probability: float
    progress_m: float
    wrong_way: bool = False
    wrong_way_s: float = 0.0


@dataclass(frozen=True, slots=True)
class TrackPosition:
    """Where a vehicle is on the network.

    Attributes
    ----------
    vehicle_id : str
    t : float
        Time of the estimate, s (later than the last report when dead-reckoned).
    status : str
        ``confident``, ``ambiguous`` (several places plausible), ``lost`` (dead reckoning
        exhausted, or contradicted by a discrete fix; or not shown on a track, see
        :attr:`unplaced`) or ``unmatched`` (no track nearby).
    edge_id, direction, offset_m
        The most probable track position (None when unmatched or not yet shown).
    lon, lat : float
        Degrees: the filtered track position, or the raw fix when unmatched.
    heading_deg : float or None
        True heading of travel on the track, degrees.
    speed_mps : float
        Filtered speed, m/s.
    probability : float
        Probability of the most probable place (0 when unmatched).
    sigma_m : float or None
        Along-track one-sigma uncertainty, m.
    wrong_way : bool
        The vehicle runs against the track's permitted direction.
    hypotheses : tuple of Hypothesis
        Every hypothesis kept: the one the reported position follows first, then the
        others, most probable first.
    dead_reckoned_s : float
        Time since the last position fix, s (0 at a fix).
    """

    vehicle_id: str
    t: float
    status: PositionStatus
    edge_id: int | None
    direction: int | None
    offset_m: float | None
    lon: float
    lat: float
    heading_deg: float | None
    speed_mps: float
    probability: float
    sigma_m: float | None
    wrong_way: bool = False
    hypotheses: tuple[Hypothesis, ...] = ()
    dead_reckoned_s: float = 0.0

    @property
    def unplaced(self) -> bool:
        """A vehicle not shown on a track because its fixes cannot tell the track: it
        started afresh, or it ran over a switch without a fix and its branches are a coin
        toss (``lost`` without an edge, its hypotheses given; see
        :mod:`antikol.positioning.showing`)."""
        return self.status == "lost" and self.edge_id is None and bool(self.hypotheses)

    @property
    def matched(self) -> bool:
        """True when confident or ambiguous (usable for track-based analysis)."""
        return self.status in ("confident", "ambiguous")


@dataclass(frozen=True, slots=True)
class FixPoint:
    """A discrete position reference on the map (a balise or a loop crossing)."""

    fix_id: str
    edge_id: int
    offset_m: float


@dataclass(frozen=True, slots=True)
class DiscreteFix:
    """A vehicle passing a :class:`FixPoint` at time ``t`` (s)."""

    t: float
    edge_id: int
    offset_m: float
    fix_id: str | None = None


class PositionSource(Protocol):
    """Where the analyser's track positions come from (by default its own
    :class:`~antikol.positioning.matcher.Positioner`).

    Fleet-scale replay (:mod:`antikol.evaluation.fleet`) positions every vehicle alone
    first and then hands the stored positions to the pairwise analysis through this hook.
    A source may also have ``positions(vehicle_ids, t)`` (many vehicles at once, as
    :meth:`Positioner.positions <antikol.positioning.matcher.Positioner.positions>`);
    :func:`positions_of` asks ``position`` of each vehicle when it has none. The analysis
    asks ``placed_positions(vehicle_ids, t)`` when the source has it (vehicles not yet
    shown on a track too, :mod:`antikol.positioning.showing`).
    """

    def update_many(
        self, reports: Sequence[VehicleReport], *, outputs: bool = True
    ) -> list[TrackPosition]: ...

    def position(self, vehicle_id: str, t: float | None = None) -> TrackPosition | None: ...

    def forget(self, vehicle_id: str) -> None: ...


def positions_of(
    source: PositionSource,
    vehicle_ids: Sequence[str],
    t: float | None = None,
    *,
    as_placed: bool = False,
) -> list[TrackPosition | None]:
    """The positions of many vehicles from a source: its ``positions`` when it has one,
    else its ``position`` of each (a caller's own source may have only that). With
    ``as_placed``, its ``placed_positions`` when it has them: vehicles not yet shown on a
    track placed where the analysis weighs them (:mod:`antikol.positioning.showing`)."""
    many = getattr(source, "placed_positions" if as_placed else "positions", None)
    if as_placed and not callable(many):
        many = getattr(source, "positions", None)
    if callable(many):
        return list(many(vehicle_ids, t))
    return [source.position(v, t) for v in vehicle_ids]
