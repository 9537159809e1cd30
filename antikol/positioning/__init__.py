"""Track-selective positioning: candidates → HMM over (edge, direction) → along-track filter.

* :mod:`antikol.positioning.matcher` — the :class:`Positioner` (online HMM with a GPS bias
  per hypothesis, physics checks, odometer dead reckoning), vectorised over a fleet;
* :mod:`antikol.positioning.reach` — along-track distances between track states;
* :mod:`antikol.positioning.kalman` — closed-form along-track and bias filters;
* :mod:`antikol.positioning.fixes` — discrete fixes (balises, loop crossings);
* :mod:`antikol.positioning.config`, :mod:`antikol.positioning.records` — parameters and
  results.
"""

from antikol.positioning.config import PositioningConfig
from antikol.positioning.kalman import AlongTrackFilter, FilterEstimate
from antikol.positioning.matcher import Positioner
from antikol.positioning.reach import ReachTable
from antikol.positioning.records import DiscreteFix, FixPoint, Hypothesis, TrackPosition

__all__ = [
    "AlongTrackFilter",
    "DiscreteFix",
    "FilterEstimate",
    "FixPoint",
    "Hypothesis",
    "Positioner",
    "PositioningConfig",
    "ReachTable",
    "TrackPosition",
]
