"""The shared vocabulary of antikol: warning levels, threat kinds, methods, statuses.

Every module that speaks of a level, a kind of threat or a position status uses these
names, so there is exactly one definition of each.

>>> from antikol.kinds import level_rank, max_level
>>> max_level("advisory", "warning", "none")
'warning'
>>> level_rank("emergency") > level_rank("warning")
True
"""

from __future__ import annotations

from typing import Final, Literal

__all__ = [
    "BRAKE_STATES",
    "GAP_CASES",
    "LEVELS",
    "METHODS",
    "POSITION_STATUSES",
    "SUPPRESSION_REASONS",
    "THREAT_KINDS",
    "BrakeState",
    "GapCase",
    "Level",
    "Method",
    "PositionStatus",
    "SuppressionReason",
    "ThreatKind",
    "level_rank",
    "max_level",
]

#: Warning level of a threat or an assessment; ``warning`` and above light the paper's lamp.
Level = Literal["none", "advisory", "warning", "emergency"]
#: Warning levels, lowest first; the index is the rank (see :func:`level_rank`).
LEVELS: Final[tuple[Level, ...]] = ("none", "advisory", "warning", "emergency")

#: What kind of conflict a threat is (``sector``: the paper's rule, kind unknown).
ThreatKind = Literal["rear_end", "head_on", "merge", "crossing", "sector"]
THREAT_KINDS: Final[tuple[ThreatKind, ...]] = ("rear_end", "head_on", "merge", "crossing", "sector")

#: How a threat was found: along the tracks, or by the paper's sector rule.
Method = Literal["track", "sector"]
METHODS: Final[tuple[Method, ...]] = ("track", "sector")

#: The braking model's geometric cases: a moving leader, an oncoming vehicle, a fixed point.
GapCase = Literal["rear_end", "head_on", "static"]
GAP_CASES: Final[tuple[GapCase, ...]] = ("rear_end", "head_on", "static")

#: Brake state announced by a vehicle.
BrakeState = Literal["none", "service", "emergency"]
BRAKE_STATES: Final[tuple[BrakeState, ...]] = ("none", "service", "emergency")

#: How sure the positioning is of a vehicle's place on the tracks.
PositionStatus = Literal["confident", "ambiguous", "lost", "unmatched"]
POSITION_STATUSES: Final[tuple[PositionStatus, ...]] = (
    "confident",
    "ambiguous",
    "lost",
    "unmatched",
)

#: Why the map cleared a vehicle the sector rule would flag.
SuppressionReason = Literal[
    "parallel_track",
    "not_reachable",
    "grade_separated",
    "no_overlap",
    "below_probability",
    "opening",
]
SUPPRESSION_REASONS: Final[tuple[SuppressionReason, ...]] = (
    "parallel_track",
    "not_reachable",
    "grade_separated",
    "no_overlap",
    "below_probability",
    "opening",
)


def level_rank(level: Level) -> int:
    """Rank of a warning level: 0 for ``"none"`` up to 3 for ``"emergency"``.

    Parameters
    ----------
    level : {"none", "advisory", "warning", "emergency"}

    Returns
    -------
    int
        Index of ``level`` in :data:`LEVELS`.

    Raises
    ------
    ValueError
        Unknown level.
    """
    try:
        return LEVELS.index(level)
    except ValueError:
        raise ValueError(f"level must be one of {LEVELS}, got {level!r}") from None


def max_level(*levels: Level) -> Level:
    """The most severe of some warning levels (``"none"`` when given none)."""
    return LEVELS[max((level_rank(level) for level in levels), default=0)]
