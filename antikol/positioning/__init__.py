"""Track-selective positioning: candidates → HMM over (edge, direction) → along-track filter.

* :mod:`antikol.positioning.matcher` — the :class:`Positioner` (online HMM with a GPS bias
  per hypothesis, the reported lineage), vectorised over a fleet, with its parts:
  :mod:`~antikol.positioning.physics` (reports no vehicle can make),
  :mod:`~antikol.positioning.candidates` (places near each fix),
  :mod:`~antikol.positioning.scoring` (one HMM step), :mod:`~antikol.positioning.fleet`
  (the state arrays), :mod:`~antikol.positioning.deadreckoning` (moving along the track
  without a fix), :mod:`~antikol.positioning.outages` (an outage as evidence of a tunnel)
  and :mod:`~antikol.positioning.placing` (the reported place of each vehicle, most of a
  fleet in arrays);
* :mod:`antikol.positioning.reach` — along-track distances between track states, and
  :mod:`~antikol.positioning.headings` — track headings every metre (both once per map);
* :mod:`antikol.positioning.fixerror` — each hypothesis' filter of its fix error (GPS bias
  and along-track lag);
* :mod:`antikol.positioning.kalman` — the closed-form along-track filter;
* :mod:`antikol.positioning.latency` — how old each vehicle's fixes are when stamped;
* :mod:`antikol.positioning.fixes` — discrete fixes (balises, loop crossings);
* :mod:`antikol.positioning.feedfaults` — faults of a feed that no field flags (a position
  repeated while the vehicle runs, an odometer reset);
* :mod:`antikol.positioning.speedunits` — speeds a feed reports in km/h, knots or mph,
  told by the vehicle's fixes;
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
