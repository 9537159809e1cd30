"""Records produced by the analyser: threats, suppressed vehicles, assessments and the
zones of a sensitivity area."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import shapely

from antikol.kinds import LEVELS, Level, Method, ThreatKind, level_rank, max_level
from trackmap import Path
from trackmap.records import positional

__all__ = [
    "LEVELS",
    "Assessment",
    "Level",
    "Method",
    "Suppressed",
    "Threat",
    "ThreatKind",
    "Zone",
    "assessment_of",
    "highest_level",
    "level_rank",
    "sort_threats",
]


@dataclass(frozen=True, slots=True)
class Threat:
    """One other vehicle that endangers the own vehicle.

    Attributes
    ----------
    vehicle_id : str
        The other vehicle.
    kind : str
        ``rear_end``, ``head_on``, ``merge``, ``crossing`` (track method) or ``sector``.
    level : str
        ``advisory``, ``warning`` or ``emergency``.
    distance_m : float
        Gap, metres: along the track when ``method == 'track'``, planar otherwise.
    closing_speed_mps : float
        Rate at which the gap shrinks, m/s (negative when opening).
    ttc_s : float or None
        Time to collision, s; None when not closing.
    method : str
        ``track`` (map-based) or ``sector`` (the paper's rule).
    zone : str or None
        Branch label of the zone ahead holding the conflict (track method).
    bearing_deg : float or None
        Bearing to the other vehicle (sector method), degrees.
    probability : float or None
        Probability of the conflict given the match hypotheses and, without a route, the
        branches either vehicle may take at facing switches (track method): over the own
        vehicle's hypotheses and paths, and the other's hypotheses, each with the summed
        probability of the other's paths through the conflict point.
    own_match_probability, other_match_probability : float or None
        Probabilities of the track matches the threat relied on.
    ambiguous : bool
        True when the track matches were ambiguous and the threat was raised because the
        conflict probability exceeded the analyser's threshold.
    detail : str
        Short human-readable explanation.
    own_ends, other_ends : str or None
        How the ends of each vehicle were placed (track method): ``reported``,
        ``assumed_offset`` or ``assumed_length`` (see :mod:`antikol.analysis.ends`).
    held : bool
        The alarm is held on by the analyser's hysteresis (the conflict is not clearly
        over) although the gap alone would not raise it now.
    """

    vehicle_id: str
    kind: ThreatKind
    level: Level
    distance_m: float
    closing_speed_mps: float
    ttc_s: float | None
    method: Method
    zone: str | None = None
    bearing_deg: float | None = None
    probability: float | None = None
    own_match_probability: float | None = None
    other_match_probability: float | None = None
    ambiguous: bool = False
    detail: str = ""
    own_ends: str | None = None
    other_ends: str | None = None
    held: bool = False


@dataclass(frozen=True, slots=True)
class Suppressed:
    """A vehicle the sector rule would flag but the map cleared.

    Attributes
    ----------
    vehicle_id : str
    reason : str
        ``parallel_track``, ``not_reachable``, ``grade_separated``, ``no_overlap`` (the
        paths meet, but not at the same time) or ``below_probability``.
    distance_m : float
        Planar distance, metres.
    bearing_deg : float
        Bearing from the own vehicle, degrees.
    """

    vehicle_id: str
    reason: str
    distance_m: float
    bearing_deg: float


@dataclass(frozen=True, slots=True)
class Assessment:
    """The analyser's verdict for one own vehicle at one time.

    Attributes
    ----------
    own_id : str
    t : float
        Time of the assessment, s.
    level : str
        Highest level among the threats (``none`` when there is none).
    threats : tuple of Threat
        Most severe first, then nearest first.
    suppressed : tuple of Suppressed
        Vehicles the sector rule would have flagged but the map cleared.
    method : str
        ``track`` when the own vehicle was matched to the map, otherwise ``sector``.
    """

    own_id: str
    t: float
    level: Level
    threats: tuple[Threat, ...] = field(default_factory=tuple)
    suppressed: tuple[Suppressed, ...] = field(default_factory=tuple)
    method: Method = "sector"

    @property
    def lamp(self) -> bool:
        """The paper's warning lamp: on at level ``warning`` or above."""
        return level_rank(self.level) >= level_rank("warning")

    @property
    def primary(self) -> Threat | None:
        """The most severe, nearest threat, or None."""
        return self.threats[0] if self.threats else None


def sort_threats(threats: list[Threat]) -> tuple[Threat, ...]:
    """Most severe first, nearest first within a level."""
    return tuple(sorted(threats, key=lambda th: (-level_rank(th.level), th.distance_m)))


def highest_level(threats: tuple[Threat, ...] | list[Threat]) -> Level:
    """Highest level among threats, ``none`` if empty."""
    return max_level(*(th.level for th in threats))


_assessment = positional(Assessment)
_QUIET = LEVELS[0]


def assessment_of(
    own_id: str,
    t: float,
    threats: list[Threat],
    suppressed: list[Suppressed],
    method: Method,
) -> Assessment:
    """The assessment of one vehicle from its threats, in any order.

    Parameters
    ----------
    own_id : str
    t : float
        Time of the assessment, s.
    threats : list of Threat
        Ordered here: most severe first, then nearest first.
    suppressed : list of Suppressed
        Ordered here: nearest first.
    method : str
        ``track`` or ``sector``.

    Returns
    -------
    Assessment
    """
    if not threats and not suppressed:  # most vehicles, most of the time
        return _assessment(own_id, t, _QUIET, (), (), method)
    ordered = sort_threats(threats)
    return _assessment(
        own_id,
        t,
        highest_level(ordered),
        ordered,
        tuple(sorted(suppressed, key=lambda s: s.distance_m)),
        method,
    )


@dataclass(frozen=True, slots=True)
class Zone:
    """One zone of the sensitivity area (a branch of the track ahead).

    Attributes
    ----------
    label : str
        ``main`` or the choices at facing switches (``straight/left``...).
    role : str
        ``warning`` or ``advisory`` (a branch off the known planned route).
    path : trackmap.Path
    corridor : shapely.Polygon
        The corridor along the path in the map's local frame (metres).
    probability : float
        Probability of the own match hypothesis the zone starts from, times the
        probability of taking this branch.
    """

    label: str
    role: Literal["warning", "advisory"]
    path: Path
    corridor: shapely.Polygon
    probability: float
