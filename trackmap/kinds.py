"""The named values of trackmap: running directions, node classes, conflict kinds, path ends.

The string enumerations are :class:`enum.StrEnum`: each member *is* its string, so it
compares equal to it, hashes like it and is written to JSON as it (the map file keeps its
plain string values). :class:`Direction` is an :class:`enum.IntEnum` for the same reason:
callers may keep passing ``1`` and ``-1``.

>>> Direction.FORWARD == 1, Direction(-1).opposite()
(True, <Direction.FORWARD: 1>)
>>> NodeClass("point_switch") is NodeClass.POINT_SWITCH, PathEnd.HORIZON == "horizon"
(True, True)
"""

from __future__ import annotations

from enum import IntEnum, StrEnum

__all__ = ["ConflictKind", "Direction", "NodeClass", "PathEnd"]


class Direction(IntEnum):
    """Running direction along an edge, relative to the order of its vertices."""

    FORWARD = 1
    """Along the vertices: from the edge's first vertex towards its last."""
    BACKWARD = -1
    """Against the vertices."""

    def opposite(self) -> Direction:
        """The other direction."""
        return Direction.BACKWARD if self is Direction.FORWARD else Direction.FORWARD


class NodeClass(StrEnum):
    """Class of a junction node, from the number of edges meeting and their moves."""

    BUFFER_STOP = "buffer_stop"
    """One edge: the end of a track."""
    LINK = "link"
    """Two edges joined end to end."""
    POINT_SWITCH = "point_switch"
    """Three edges: a trunk and two branches (a facing or trailing switch)."""
    DIAMOND_CROSSING = "diamond_crossing"
    """Four edges crossing in two straight pairs, no move between the pairs."""
    DOUBLE_SLIP = "double_slip"
    """Four edges with moves between every straight-enough pair."""
    UNKNOWN = "unknown"
    """Fits no class (reported by ``trackmap check``)."""


class ConflictKind(StrEnum):
    """Kind of a conflict point: where two routes on different tracks can collide."""

    MERGE = "merge"
    """The fouling area of a point switch, where two branches join."""
    DIAMOND_CROSSING = "diamond_crossing"
    """A diamond crossing node."""
    DOUBLE_SLIP = "double_slip"
    """A double slip node."""
    CROSSING = "crossing"
    """Two tracks crossing at the same level without a shared node."""


class PathEnd(StrEnum):
    """Why a route ahead (:class:`trackmap.Path`) ends where it does."""

    HORIZON = "horizon"
    """It reached the look-ahead horizon."""
    BUFFER_STOP = "buffer_stop"
    """The track ends at a buffer stop."""
    DEAD_END = "dead_end"
    """No permitted move leads on (e.g. a one-way track ends against the direction)."""
    TRUNCATED = "truncated"
    """Too many branches: the search bound ``max_paths`` was reached."""
