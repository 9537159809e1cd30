"""Parameters of the track-aware analysis, checked when they are made.

A setting the analysis cannot use raises :class:`~antikol.errors.InvalidArgumentError`
naming it (``alarms.min_on_s`` for a nested one) at construction: a NaN anticipation or a
negative gap margin, accepted silently, turned an emergency into no threat at all, and a
string gave a bare ``TypeError`` deep inside the first assessment.

>>> AnalyserConfig(anticipation_s=float("nan"))  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
antikol.errors.InvalidArgumentError: anticipation_s must be valid, got nan: ...
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Literal

from antikol.analysis.alarms import AlarmPolicy
from antikol.analysis.arguments import finite
from antikol.analysis.branches import BranchSettings
from antikol.errors import InvalidArgumentError
from antikol.positioning.reported import ReportedSettings
from antikol.thresholds import MIN_HORIZON_M, STANDING_SPEED_MPS

__all__ = ["AnalyserConfig"]

#: Settings that must be strictly positive (the others: finite and not negative).
_POSITIVE = frozenset(
    {
        "min_horizon_m",
        "merge_accel_mps2",
        "merge_max_speed_mps",
        "corridor_half_width_m",
        "lateral_accel_mps2",
        "plan_decel_mps2",
        "probe_m",
    }
)
_PROBABILITIES = frozenset(
    {"warning_probability", "emergency_probability", "min_hypothesis_probability"}
)


def _check_number(name: str, value: float, *, positive: bool) -> None:
    number = finite(value, name)
    if positive and number <= 0.0:
        raise InvalidArgumentError(name, value, "must be > 0")
    if number < 0.0:
        raise InvalidArgumentError(name, value, "must be >= 0")


def _check_numbers(settings: object, prefix: str = "") -> None:
    """Check every float field of a settings dataclass (finite, not negative; positive
    where :data:`_POSITIVE` says so; in [0, 1] for a probability)."""
    for f in fields(settings):  # type: ignore[arg-type]
        if f.type not in ("float", float):
            continue
        value = getattr(settings, f.name)
        _check_number(prefix + f.name, value, positive=f.name in _POSITIVE)
        if f.name in _PROBABILITIES and value > 1.0:
            raise InvalidArgumentError(prefix + f.name, value, "must be in [0, 1]")


@dataclass(frozen=True, slots=True)
class AnalyserConfig:
    """Parameters of the track-aware analysis (SI units).

    Attributes
    ----------
    min_horizon_m : float
        Shortest look-ahead along the track, m (the paper's d_col by default).
    warning_probability : float
        A conflict raises more than an advisory when the probability of a warning-level
        conflict over the match hypotheses and zones reaches this ...
    emergency_probability : float
        ... or when the probability of an emergency-level conflict reaches this (the
        graver the consequence, the less probability it takes).
    max_hypotheses : int
        Hypotheses per vehicle evaluated.
    min_hypothesis_probability : float
        Hypotheses less probable than this are not evaluated.
    wrong_way_evidence_s : float
        A hypothesis of running against a one-way track raises more than an advisory only
        after this long of consistent evidence, s.
    window_slack_s : float
        Merges and crossings: slack between the other vehicle's earliest arrival and the
        own clearing time, s.
    merge_accel_mps2, merge_max_speed_mps : float
        Merges and crossings: how the other vehicle's earliest arrival is computed
        (acceleration from its current speed, standing or not, up to a speed), m/s², m/s.
    stopped_speed_mps : float
        Below this speed a moving vehicle is taken to stand, m/s ...
    start_speed_mps : float
        ... and above this a standing one to move again, m/s (hysteresis: the speed over
        ground of a standing receiver wanders).
    closing_speed_mps : float
        A gap closing slower than this does not need action now, m/s.
    gap_margin_sigmas : float
        Gaps are shortened by this many standard deviations of both vehicles' positions and
        ends before the level is chosen (err towards warning).
    anticipation_s : float
        Gaps are also shortened by this many seconds of closing: the warning is on before
        the limit is crossed, not a cycle after.
    rear_end_model : {"on_sight", "moving_leader"}
        ``on_sight`` (default): a closing follower must be able to stop before the leader as
        before a standing obstacle (trams run on sight; a leader can stop abruptly).
        ``moving_leader``: credit the leader's own braking distance (CBTC).
    hysteresis : bool
        Hold and release pair alarms by :attr:`alarms` (track method).
    alarms : AlarmPolicy
    branches : BranchSettings
        How the branch a vehicle takes at a facing switch is weighed without a route.
    corridor_half_width_m : float
        Half-width of the corridor polygons drawn for zones, m.
    parallel_distance_m : float
        A suppressed vehicle this close to a zone counts as on a parallel track, m.
    reported_positions : ReportedSettings or None
        Use the track positions other vehicles report of themselves, after the checks of
        :mod:`antikol.positioning.reported` (None: always match every vehicle here).
    """

    min_horizon_m: float = MIN_HORIZON_M
    warning_probability: float = 0.3
    emergency_probability: float = 0.1
    max_hypotheses: int = 3
    min_hypothesis_probability: float = 0.01
    wrong_way_evidence_s: float = 10.0
    window_slack_s: float = 6.0
    merge_accel_mps2: float = 1.0
    merge_max_speed_mps: float = 14.0
    stopped_speed_mps: float = STANDING_SPEED_MPS
    start_speed_mps: float = 1.0
    closing_speed_mps: float = 0.3
    gap_margin_sigmas: float = 2.0
    anticipation_s: float = 2.0
    rear_end_model: Literal["on_sight", "moving_leader"] = "on_sight"
    hysteresis: bool = True
    alarms: AlarmPolicy = field(default_factory=AlarmPolicy)
    branches: BranchSettings = field(default_factory=BranchSettings)
    corridor_half_width_m: float = 1.7
    parallel_distance_m: float = 10.0
    reported_positions: ReportedSettings | None = field(default_factory=ReportedSettings)

    def __post_init__(self) -> None:
        _check_numbers(self)
        hypotheses = self.max_hypotheses
        if isinstance(hypotheses, bool) or not isinstance(hypotheses, int) or hypotheses < 1:
            raise InvalidArgumentError("max_hypotheses", hypotheses, "must be an int >= 1")
        if self.rear_end_model not in ("on_sight", "moving_leader"):
            raise InvalidArgumentError(
                "rear_end_model", self.rear_end_model, "must be 'on_sight' or 'moving_leader'"
            )
        if not isinstance(self.hysteresis, bool):
            raise InvalidArgumentError("hysteresis", self.hysteresis, "must be True or False")
        for name, kind in (("alarms", AlarmPolicy), ("branches", BranchSettings)):
            nested = getattr(self, name)
            if not isinstance(nested, kind):
                raise InvalidArgumentError(name, nested, f"must be a {kind.__name__}")
            _check_numbers(nested, f"{name}.")
        reported = self.reported_positions
        if reported is not None and not isinstance(reported, ReportedSettings):
            raise InvalidArgumentError(
                "reported_positions", reported, "must be a ReportedSettings or None"
            )
        if self.start_speed_mps < self.stopped_speed_mps:
            raise InvalidArgumentError(
                "start_speed_mps",
                self.start_speed_mps,
                f"must be >= stopped_speed_mps ({self.stopped_speed_mps})",
            )
        if self.branches.infeasible_weight > 1.0:
            raise InvalidArgumentError(
                "branches.infeasible_weight", self.branches.infeasible_weight, "must be in [0, 1]"
            )
