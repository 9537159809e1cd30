"""Evaluation tools: scenarios, ground truth, scoring, positioning accuracy and log replay.

* :mod:`~antikol.evaluation.scenarios` — named, parameterised simulator scenarios, placed
  on any map by :mod:`~antikol.evaluation.scenario_places`;
* :mod:`~antikol.evaluation.groundtruth` — which vehicle pairs need a warning, from the
  simulator's true states;
* :mod:`~antikol.evaluation.scoring` — analysers scored against the ground truth, and the
  sector rule compared with the track-aware analyser;
* :mod:`~antikol.evaluation.positioning_accuracy` — track-selective positioning against
  the true track;
* :mod:`~antikol.evaluation.consistency` — a trace's matched positions checked without
  ground truth (course's way, connected windows, odometer): ``antikol match``;
* :mod:`~antikol.evaluation.replay` — recorded logs replayed through the analyser;
* :mod:`~antikol.evaluation.fleet` — an operator's archive replayed on a Dask cluster
  (``antikol replay --fleet``); Dask and pyarrow are imported only when it runs;
* :mod:`~antikol.evaluation.figures` — comparison figures. It needs matplotlib (an
  optional extra), so it is not imported here: import ``antikol.evaluation.figures``.
"""

from antikol.evaluation.consistency import (
    MatchedFix,
    TraceConsistency,
    match_reports,
    trace_consistency,
)
from antikol.evaluation.groundtruth import GroundTruth, Passage, analysis_times, ground_truth
from antikol.evaluation.positioning_accuracy import (
    FixEvaluation,
    PositioningScore,
    ReliabilityBin,
    WrongWayScore,
    evaluate_fixes,
    positioning_accuracy,
    wrong_way_positioning,
)
from antikol.evaluation.replay import EVENT_COLUMNS, EventWriter, ReplaySummary, cycles, replay
from antikol.evaluation.scenarios import (
    SCENARIOS,
    Scenario,
    ScenarioUnavailable,
    build_scenario,
    run_scenario,
)
from antikol.evaluation.scoring import (
    AlarmLog,
    Comparison,
    MissedEpisode,
    Score,
    compare,
    format_table,
    run_analyser,
    score,
)

__all__ = [
    "EVENT_COLUMNS",
    "SCENARIOS",
    "AlarmLog",
    "Comparison",
    "EventWriter",
    "FixEvaluation",
    "GroundTruth",
    "MatchedFix",
    "MissedEpisode",
    "Passage",
    "PositioningScore",
    "ReliabilityBin",
    "ReplaySummary",
    "Scenario",
    "ScenarioUnavailable",
    "Score",
    "TraceConsistency",
    "WrongWayScore",
    "analysis_times",
    "build_scenario",
    "compare",
    "cycles",
    "evaluate_fixes",
    "format_table",
    "ground_truth",
    "match_reports",
    "positioning_accuracy",
    "replay",
    "run_analyser",
    "run_scenario",
    "score",
    "trace_consistency",
    "wrong_way_positioning",
]
