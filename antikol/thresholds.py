"""Thresholds shared by several stages, each defined once and named.

Configuration classes (``AnalyserConfig``, ``PositioningConfig``, ``SectorRule``) take their
defaults from here, so a threshold that two modules must agree on cannot drift apart.
"""

from __future__ import annotations

from typing import Final

__all__ = [
    "COURSE_MIN_SPEED_MPS",
    "D_COL_M",
    "EXPIRY_S",
    "FILTER_NIS_GATE",
    "HALF_ANGLE_DEG",
    "MAX_PATHS_SEARCH",
    "MIN_HORIZON_M",
    "STANDING_SPEED_MPS",
    "TABLE_CAPACITY",
]

#: The paper's sensitivity distance d_col, m.
D_COL_M: Final = 300.0
#: The paper's sector half-angle, degrees.
HALF_ANGLE_DEG: Final = 15.0
#: Shortest look-ahead of the track-aware analysis: the paper's d_col, m.
MIN_HORIZON_M: Final = D_COL_M
#: The paper's vehicle table: other vehicles kept on board.
TABLE_CAPACITY: Final = 32
#: The paper's table expiry: a vehicle silent this long is dropped, s.
EXPIRY_S: Final = 10.0
#: Below this speed a vehicle counts as standing (analysis, truth, NMEA course), m/s.
STANDING_SPEED_MPS: Final = 0.5
#: Below this speed a reported course is noise and the last good one is kept, m/s.
COURSE_MIN_SPEED_MPS: Final = 1.0
#: Branches followed when searching the track around a position (positioning), paths.
MAX_PATHS_SEARCH: Final = 16
#: Normalised innovation beyond which the along-track filter restarts from the fix.
FILTER_NIS_GATE: Final = 6.0
