"""Analysis: from positioned vehicles to threats and warning levels.

* :mod:`antikol.analysis.geometry` — the paper's planar formulas (1)–(9);
* :mod:`antikol.analysis.sector` — the paper's sector rule;
* :mod:`antikol.analysis.braking` — braking profiles, distances and warning levels;
* :mod:`antikol.analysis.assessment` — the records the analyser returns;
* :mod:`antikol.analysis.analyser` — the :class:`Analyser` that orchestrates them.
"""

from antikol.analysis.analyser import Analyser, AnalyserConfig, Zone
from antikol.analysis.assessment import Assessment, Suppressed, Threat
from antikol.analysis.braking import BrakingProfile, load_profile
from antikol.analysis.coursekeeper import CourseKeeper
from antikol.analysis.sector import SectorHit, SectorRule

__all__ = [
    "Analyser",
    "AnalyserConfig",
    "Assessment",
    "BrakingProfile",
    "CourseKeeper",
    "SectorHit",
    "SectorRule",
    "Suppressed",
    "Threat",
    "Zone",
    "load_profile",
]
