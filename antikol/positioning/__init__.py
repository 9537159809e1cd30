"""Track-selective positioning: candidates → HMM over (edge, direction) → along-track filter.

* :mod:`antikol.positioning.matcher` — the :class:`Positioner` (online HMM, physics checks,
  discrete fixes);
* :mod:`antikol.positioning.kalman` — the along-track Kalman filter (filterpy).
"""

from antikol.positioning.kalman import AlongTrackFilter, FilterEstimate
from antikol.positioning.matcher import (
    DiscreteFix,
    FixPoint,
    Hypothesis,
    Positioner,
    PositioningConfig,
    TrackPosition,
)

__all__ = [
    "AlongTrackFilter",
    "DiscreteFix",
    "FilterEstimate",
    "FixPoint",
    "Hypothesis",
    "Positioner",
    "PositioningConfig",
    "TrackPosition",
]
