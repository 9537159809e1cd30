"""Parameters of track-selective positioning (SI units), each with the reason for its value."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from antikol.errors import InvalidArgumentError
from antikol.numeric import finite_float
from antikol.thresholds import FILTER_NIS_GATE

__all__ = ["MAX_HDOP", "PositioningConfig", "hdop_factor"]

#: The largest HDOP a fix's error is scaled by: the most NMEA's field states (a receiver
#: without a solution writes it); a larger one tells no more, and an unbounded one made a
#: fix's error and the search around it infinite.
MAX_HDOP = 99.99


def hdop_factor(hdop: float | None) -> float:
    """The factor of a fix's error for its reported HDOP: 1 without one, at least 1 (the
    configured errors are those of a good fix), at most :data:`MAX_HDOP`.

    >>> hdop_factor(None), hdop_factor(0.7), hdop_factor(2.5), hdop_factor(1e200)
    (1.0, 1.0, 2.5, 99.99)
    """
    return 1.0 if hdop is None else min(max(1.0, hdop), MAX_HDOP)


@dataclass(frozen=True, slots=True)
class PositioningConfig:
    """Parameters of the positioning filter (SI units).

    GPS error model
    ---------------
    A fix is the antenna's true position plus a **slowly varying bias** (multipath in
    streets: several metres, persisting for tens of seconds to minutes) plus white noise.
    Every hypothesis carries its own estimate of the bias (a two-dimensional Gauss–Markov
    process), so a persistent lateral offset is explained as bias rather than as evidence
    for the neighbouring track, and the course over ground — good to a few degrees while
    moving — keeps its real weight. The same filter follows the fix's place **along** the
    track against the distance the vehicle reports running (odometer, else speed): the
    inner of two loops a few metres apart, or the shorter of two branches, falls behind
    that distance, and no lateral bias explains it away.

    Attributes
    ----------
    gps_sigma_m : float
        White noise of a fix per axis, m (scaled up by HDOP above 1), for a plain GNSS
        fix (GGA quality 1, or none reported).
    bias_sigma_m : float
        Stationary standard deviation of the GPS bias per axis, m (plain fix).
    dgps_sigma_m, rtk_float_sigma_m, rtk_sigma_m : float
        White noise and bias of a fix that reports GGA quality 2 (differential), 5 (RTK
        float) and 4 (RTK fixed), m: a receiver that says it is better is believed.
    bias_tau_s : float
        Correlation time of the bias, s.
    bias_sigma_max_factor : float
        A vehicle's bias prior (plain fixes) grows with the bias across the track that its
        hypotheses learn, up to this many times ``bias_sigma_m``
        (:mod:`antikol.positioning.biasscale`): under a receiver whose multipath runs to
        10 m a fixed prior of 2.5 m made the nearer track's hypothesis *confident*;
        1 keeps the prior fixed (>= 1).
    outlier_weight : float
        Weight of the broad component of the lateral likelihood (multipath jumps, heavy
        tails): one fix far off the track cannot veto the truth.
    search_radius_m : float
        Candidate tracks are searched within this radius, m (at least 4 sigma).
    max_hypotheses : int
        Hypotheses kept per vehicle.
    min_probability : float
        Hypotheses below this probability are dropped.
    course_sigma_deg, course_noise_deg_mps : float
        Course agreement scale: ``hypot(course_sigma_deg, course_noise_deg_mps / speed)``
        degrees (track-heading mismatch plus a Doppler course error that shrinks with
        speed).
    course_outlier_weight : float
        Weight of the uniform floor of the course likelihood.
    min_speed_for_course_mps : float
        Below this speed the course carries no weight, m/s, except at a standing start.
        Above it the course's scale already widens as the speed falls. With 2 m/s, a
        tram moving off at 1.9 m/s, its course against the other direction's track on
        which its biased first fixes lay, was shown there *confident* and moved across
        a second later. With 1 m/s (the paper's sector keeps courses from there), the
        course of a tram braking to a stop, near noise at 1 m/s, put it on the oncoming
        track for a moment: one more false alarm on the referee's seed 1.
    course_check : int
        1: each vehicle's course is checked against the chords of its own fixes, turned
        round while they show it reversed and ignored while they show it otherwise wrong
        (a stuck or misread course field, :mod:`antikol.positioning.coursecheck`); 0:
        every course is weighed as reported.
    start_course_max_speed_mps, start_course_sigma_deg, start_course_outlier_weight : float
        A vehicle that starts afresh below ``start_course_max_speed_mps`` (m/s) has its
        course compared once with the track's running way, at ``start_course_sigma_deg``
        degrees and with a floor of weight ``start_course_outlier_weight``: most receivers
        hold the last course they measured while moving, which breaks the tie between the
        two tracks of a double track at a standstill. The default floor caps it at odds of
        about 2 to 1, below ``confidence``: a double-ended tram holds its previous trip's
        course, a receiver without static hold a random one.
    show_after_moving_reports, show_after_steady_course_reports : int
        A vehicle that starts afresh is shown on a track once its place is
        ``confident``, after this many reports while moving (at
        ``start_course_max_speed_mps`` or faster), or after this many standing reports
        whose course holds within 2 degrees (a receiver holding its last course, not a
        random one); until then it is ``lost`` without an edge, its hypotheses given,
        and the analysis weighs them (:mod:`antikol.positioning.showing`). Its first fix
        cannot tell two parallel tracks apart under a street's bias: shown at once, one
        start in four on double track jumped across when it moved off. 0 moving reports
        shows every vehicle at once; 0 steady reports ignores the standing course.
    show_moving_probability : float
        The moving reports show a vehicle only once its place holds this probability:
        the course does not tell two tracks running the same way apart (a tram that
        started beside a parallel track of its own direction, with a 7-m bias towards it,
        was shown there at 0.60 and moved across three fixes later). 0: the moving
        reports alone show it.
    show_within_reports : int
        ... and at the latest at this report since it started afresh, whatever its
        evidence (0: no limit): a tram standing long at its first stop with a random
        course is shown on the likelier track; one moving at that report, while its place
        is below ``show_moving_probability``, two reports later.
    toss_shown_probability : float
        A vehicle dead-reckoned from a fix at which its place held ``confidence`` to a
        place below this probability (the branches of a facing switch it ran over in a
        GPS outage share it evenly) is not shown on a track either, unless it is
        reported at the switch (within 40 m of it): shown on a branch, it was moved across
        when the fix came back on the other one. 0 shows every such coin toss.
    wrong_way_entry_log_prior : float
        Log-probability of starting to run against a one-way track (a move onto it, or the
        first fix of a vehicle): wrong-way running is rare and must be earned.
    wrong_way_log_prior : float
        Log-likelihood cost of every fix spent running against a one-way track: sustained,
        consistent evidence must outweigh it before a wrong-way hypothesis wins.
    reversal_log_prior : float
        Log-probability that a standing vehicle changes its running direction between two
        fixes (bidirectional trams at termini).
    relocation_log_prior : float
        Log-probability that the vehicle is where none of its hypotheses can have taken
        it (a track missing from the map, a wrong connection in it): the filter recovers
        from map errors instead of holding on to an impossible history. Only a candidate
        that no plausible move reaches (``implausible_move_nats``) is relocated, and only
        on the second fix in a row that a relocation explains best (one stray fix beside
        the track, on another track the vehicle cannot have reached, is an outlier).
        A relocation never lands on wrong-way running (unless the vehicle already runs
        wrong way) nor, while the vehicle moves, against its reported course: those need a
        move the map allows or a fresh start.
    transition_beta_m : float
        Scale of the transition likelihood, m (plus 10 % of the distance travelled; 2 %
        with an odometer: the move between two fixes' places carries their errors along
        the track, which an odometer does not remove).
    implausible_move_nats : float
        A fix that every hypothesis reaches only by a move costing more than this (the
        along-track mismatch over the transition scale, with an odometer over 30 % of it:
        e.g. 50 m) is an outlier — a far multipath fix near another track — and is
        rejected like a fix with
        no track within the search radius: the vehicle keeps its hypotheses and is
        dead-reckoned, until ``max_rejections_in_row`` such fixes in a row restart it.
    outlier_fix_nats : float
        Likewise a fix whose best candidate scores a log-likelihood (of the move and of the
        fix, with its hypothesis' probability; about -6 for a typical fix, -8 at the
        emission's heavy-tailed floor) below minus this: no place explains it, it is
        dead-reckoned over (the ``max_rejections_in_row``-th in a row is taken as it is).
        So is a fix that lies, across the track, beyond what its Gaussian error and every
        hypothesis' learnt bias explain (the heavy-tailed floor explains it better) for
        every candidate: a fix 18 m beside two branches 1–2 m apart still has a place
        along each, and 4 m between those places decided the branch.
    confidence : float
        A match is ``confident`` when the best place holds at least this probability.
    confident_after : int
        ... and has held it at this many GPS matches in a row, on the same lineage (1: at
        once), unless it holds ``sure_probability``. A belief that has just swung (the
        nearer of two tracks changing under a jump of the bias) is not yet one to report
        as sure, nor one to carry as sure through the dead reckoning that may follow.
    sure_probability : float
        A place this probable is ``confident`` at once (a lone track, a clear winner).
    switch_probability : float
        The reported position stays on the lineage of the previous one (a position that a
        move along the track connects to it) unless another hypothesis reaches this
        probability or the lineage (all its descendants together: past a switch it splits
        over the branches) falls below its complement: a belief flip between unconnected
        tracks must be decisive.
    standing_switch_probability : float
        The same while the vehicle stands (it ran less than ``standstill_distance_m``
        since its last fix), when the lineage is kept however little is left of it: a
        standing tram cannot change track, while the drift of its fixes (a bias that
        changes at a standstill) builds up evidence that is not there.
    same_way_hold_m : float
        The lineage is kept, however decisive another hypothesis, where that one lies on a
        track beside the lineage's (within 10 m) that runs the same way and meets it again
        within this distance ahead of both places, m (platform tracks, a passing loop, the
        end of two parallel tracks), once the vehicle has been reported on the lineage's
        track: a jump across breaks the chain of reported positions and buys at most this
        distance on the right one of two tracks that lead to the same place. Longer holds
        trade right-track estimates for that continuity (:mod:`antikol.positioning.siblings`;
        README, Known limitations); 0 turns it off.
    max_speed_mps, max_accel_mps2 : float
        Physical limits used to reject impossible reports (m/s, m/s²).
    jump_margin_m : float
        Extra displacement allowed between two fixes beyond what speed permits, m.
    max_rejections_in_row : int
        After this many rejected reports in a row, the vehicle is re-initialised.
    dead_reckoning_s : float
        Longest outage bridged on speed alone before the position is lost, s: the time
        since the last report (reports without a fix carry the vehicle on their speeds,
        then up to ``odometer_dead_reckoning_m`` of their run, like an odometer).
    odometer_sigma_fraction : float
        Relative error of an odometer's distance once its scale is learnt (wheel slip).
    odometer_scale_sigma : float
        Standard deviation of an odometer's scale error before its fixes are seen (a worn
        wheel, a diameter set wrong): each vehicle's scale is learnt from its fixes
        (:mod:`antikol.positioning.odometerscale`); 0 takes the odometer as it reads.
    odometer_step_sigma_m : float
        Error of one odometer increment between two fixes beyond the relative one
        (resolution, timing), m.
    speed_distance_sigma_fraction : float
        Relative error of the distance run between two fixes when it comes from the
        reported speeds (their mean times the interval: acceleration in between, curves).
    odometer_dead_reckoning_m : float
        Longest distance bridged on the odometer (else on the speeds of reports without a
        fix) alone before the position is lost, m.
    surface_outage_s : float
        Mean length of a GPS outage in the open (a street canyon, a bridge overhead), s:
        every second a report says it has no fix, hypotheses outside tunnels lose
        ``1 / surface_outage_s`` nats against those in a tunnel, so that a tram whose
        fixes stopped at a switch before a tunnel's portal is found in the tunnel, not on
        the surface track beside it (:mod:`antikol.positioning.outages`); 0 takes an
        outage as no evidence.
    estimated_fix_sigma_m : float
        Standard deviation of a position estimated without a fix (``fix_quality`` 6: a
        receiver's dead reckoning, a feed's position moved along the route by the
        odometer), m: such a report is dead-reckoned like one without a fix, and its
        position then weighs the hypotheses with this spread and ``outlier_weight``
        (:mod:`antikol.positioning.estimates`); 0 ignores the position.
    lost_sigma_m : float
        Along-track uncertainty at which a dead-reckoned position is lost, m.
    reset_gap_s : float
        A gap between reports longer than this restarts the filters, s.
    accel_sigma_mps2, speed_sigma_mps : float
        Along-track filter process noise and reported-speed noise.
    nis_gate : float
        A normalised innovation beyond this restarts the along-track filter.
    fix_window_base_m, fix_window_fraction : float
        Acceptance window of a discrete fix: base + fraction x distance since the last fix.
    fix_sigma_m : float
        Accuracy of a discrete fix, m.
    max_missed_fixes : int
        Expected fixes that may be missed in a row before the position is lost.
    relocalise_after : int
        A lost vehicle is trusted again after this many confident GPS matches in a row.
    standstill_distance_m, standstill_evidence_weight : float
        While the vehicle moves less than ``standstill_distance_m`` between fixes, the
        emission log-likelihood is scaled by ``standstill_evidence_weight``: the white part
        of the GPS error is itself correlated at a standstill, so repeated fixes are not
        independent evidence. The move cost of its candidates is scaled the same way: at a
        standstill they move with the fix's own scatter, not with the vehicle. And each
        hypothesis shares its probability over the places it reaches (its move weights sum
        to one): a place with more candidates near the fix (a branch drawn as two edges)
        gains nothing from a long stop. A course reported at ``min_speed_for_course_mps``
        or faster keeps its whole weight: it is measured while moving, not drifting with
        the fixes (an odometer read out in whole metres shows no run at a departure).
    standstill_evidence_s : float
        The weight of a standing vehicle's fixes (not of its moves) decays further with the
        time it has stood: ``standstill_evidence_weight × exp(-stood / standstill_evidence_s)``.
        A long stop adds at most about ``standstill_evidence_weight × standstill_evidence_s``
        seconds' worth of fixes of evidence about its track, since the bias that dominates
        its fixes drifts and jumps while it stands and does not average out (s, > 0).
    fix_latency_s, fix_latency_sigma_s : float
        How old a fix is when its report is stamped, s (an AVL unit that stamps its reports
        when it sends them): the along-track filter takes the fix as the place the vehicle
        had then and adds the distance run since at the reported speed. The latency is
        learnt per vehicle from its run (:mod:`antikol.positioning.latency`), from this
        prior mean and standard deviation; a standard deviation of 0 keeps the mean. The
        track hypotheses expect each fix that far behind (latency times speed) once the
        learnt latency is two standard deviations above zero.
    stale_fix_run_m : float
        A report that repeats the previous report's coordinates exactly after the vehicle
        ran this far since its last fix (by its odometer, else its speeds) is no fix: the
        feed kept the last position (see :mod:`antikol.positioning.feedfaults`), m.
    reach_m : float
        Along-track distances between positions are precomputed up to this distance, m;
        farther moves (long outages) restart the vehicle from the evidence.
    """

    gps_sigma_m: float = 3.0
    bias_sigma_m: float = 2.5
    bias_tau_s: float = 60.0
    bias_sigma_max_factor: float = 4.0
    dgps_sigma_m: float = 1.0
    rtk_float_sigma_m: float = 0.3
    rtk_sigma_m: float = 0.05
    outlier_weight: float = 0.02
    search_radius_m: float = 25.0
    max_hypotheses: int = 8
    min_probability: float = 1e-4
    course_sigma_deg: float = 6.0
    course_noise_deg_mps: float = 20.0
    course_outlier_weight: float = 0.02
    min_speed_for_course_mps: float = 1.5
    course_check: int = 1
    start_course_max_speed_mps: float = 0.5
    start_course_sigma_deg: float = 15.0
    start_course_outlier_weight: float = 0.9
    show_after_moving_reports: int = 2
    show_after_steady_course_reports: int = 3
    show_within_reports: int = 5
    show_moving_probability: float = 0.8
    toss_shown_probability: float = 0.6
    wrong_way_entry_log_prior: float = math.log(1e-3)
    wrong_way_log_prior: float = -0.5
    reversal_log_prior: float = math.log(1e-4)
    relocation_log_prior: float = math.log(1e-5)
    transition_beta_m: float = 6.0
    implausible_move_nats: float = 25.0
    outlier_fix_nats: float = 20.0
    confidence: float = 0.8
    confident_after: int = 2
    sure_probability: float = 0.99
    switch_probability: float = 0.75
    standing_switch_probability: float = 0.95
    same_way_hold_m: float = 50.0
    max_speed_mps: float = 30.0
    max_accel_mps2: float = 3.5
    jump_margin_m: float = 30.0
    max_rejections_in_row: int = 3
    dead_reckoning_s: float = 30.0
    odometer_sigma_fraction: float = 0.01
    odometer_step_sigma_m: float = 0.25
    odometer_scale_sigma: float = 0.03
    speed_distance_sigma_fraction: float = 0.03
    odometer_dead_reckoning_m: float = 2000.0
    surface_outage_s: float = 5.0
    estimated_fix_sigma_m: float = 10.0
    lost_sigma_m: float = 60.0
    reset_gap_s: float = 30.0
    accel_sigma_mps2: float = 0.6
    speed_sigma_mps: float = 0.3
    nis_gate: float = FILTER_NIS_GATE
    fix_window_base_m: float = 2.0
    fix_window_fraction: float = 0.02
    fix_sigma_m: float = 0.5
    max_missed_fixes: int = 2
    relocalise_after: int = 5
    standstill_distance_m: float = 1.0
    standstill_evidence_weight: float = 0.2
    standstill_evidence_s: float = 10.0
    fix_latency_s: float = 0.0
    fix_latency_sigma_s: float = 1.0
    stale_fix_run_m: float = 2.0
    reach_m: float = 400.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise InvalidArgumentError(f.name, value, "must be a number")
            if finite_float(value) is None:  # (an int beyond a double: OverflowError before)
                raise InvalidArgumentError(f.name, value, "must be finite")
            if f.name.endswith("log_prior"):
                if value > 0.0:
                    raise InvalidArgumentError(f.name, value, "a log-probability is <= 0")
            elif value < 0.0:
                raise InvalidArgumentError(f.name, value, "must be >= 0")
        for name in (
            "gps_sigma_m",
            "bias_tau_s",
            "transition_beta_m",
            "search_radius_m",
            "dgps_sigma_m",
            "rtk_float_sigma_m",
            "rtk_sigma_m",
            "standstill_evidence_s",
            "start_course_sigma_deg",
        ):
            if getattr(self, name) <= 0.0:
                raise InvalidArgumentError(name, getattr(self, name), "must be > 0")
        if self.course_check not in (0, 1):
            raise InvalidArgumentError("course_check", self.course_check, "must be 0 or 1")
        for name in ("max_hypotheses", "confident_after", "bias_sigma_max_factor"):
            if getattr(self, name) < 1:
                raise InvalidArgumentError(name, getattr(self, name), "must be >= 1")
        for name in (
            "confidence",
            "sure_probability",
            "switch_probability",
            "standing_switch_probability",
            "outlier_weight",
            "start_course_outlier_weight",
            "toss_shown_probability",
            "show_moving_probability",
        ):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise InvalidArgumentError(name, getattr(self, name), "must be in [0, 1]")

    def error_scales(self, fix_quality: int | None) -> tuple[float, float]:
        """White noise and bias standard deviations of a fix of this GGA quality, m."""
        if fix_quality == 4:
            return self.rtk_sigma_m, self.rtk_sigma_m
        if fix_quality == 5:
            return self.rtk_float_sigma_m, self.rtk_float_sigma_m
        if fix_quality == 2:
            return self.dgps_sigma_m, self.dgps_sigma_m
        return self.gps_sigma_m, self.bias_sigma_m
