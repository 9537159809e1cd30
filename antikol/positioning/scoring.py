"""One step of the positioning's hidden Markov model over a batch of fixes.

For every fix the candidate places (:mod:`antikol.positioning.candidates`) in both running
directions are scored against every hypothesis the vehicle had: the **emission** — the
fix's lateral offset and its place along the track, explained by the hypothesis' own filter
of the fix error (:mod:`antikol.positioning.fixerror`: a slowly varying GPS bias, and the
lag between the fix and the distance the vehicle reported running, which a track of the
wrong length cannot keep small) plus white noise with a heavy-tailed floor, and the course
over ground against the track heading — and the **transition** — the along-track distance
between the states (:mod:`antikol.positioning.reach`) against the distance travelled, with
the costs of entering wrong-way running and of reversing. At a standstill the fixes' white
noise is itself correlated: the filter takes each such fix at ``standstill_evidence_weight``
of its information (its noise variance divided by the weight), as the score does; its
hypotheses follow the fix along the track no farther than five standard deviations of the
fix's error (a standing vehicle does not move: a fix whose places lie farther is an
outlier, however little it weighs). A candidate no hypothesis can reach may still be
taken at the small relocation prior (a track missing from the map). The result is read by
:class:`~antikol.positioning.matcher.Positioner`, which keeps the best hypotheses; this
module writes no state.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from antikol.positioning.biasscale import bias_sigma_of
from antikol.positioning.candidates import Candidates
from antikol.positioning.config import PositioningConfig, hdop_factor
from antikol.positioning.fixerror import (
    FIX_ERROR_FIELDS,
    FixErrorState,
    fix_error_predict,
    fix_error_update,
)
from antikol.positioning.fleet import FleetState
from antikol.positioning.latency import MAX_LATENCY_S
from antikol.positioning.odometerresolution import odometer_resolution, quantisation_sigma
from antikol.positioning.reach import ReachTable, state_direction, state_edge, state_id
from antikol.report import VehicleReport

__all__ = ["Scored", "score_fixes"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]
_NEG_INF = -math.inf
#: A standing vehicle's hypotheses follow its fixes along the track no farther than this
#: many standard deviations of a fix's error (white and bias together).
_STANDING_SCATTER_SIGMAS = 5.0
#: A hypothesis' place further than this from its fix's projection along the track has
#: the course compared with the track heading there, m.
PLACE_MOVE_M = 1.0
#: ... unless further than this: a lag not yet learnt (a fresh lineage), m.
MAX_PLACE_MOVE_M = 50.0


@dataclass(frozen=True, slots=True)
class Scored:
    """The candidate states of a batch of fixes, scored (parallel arrays).

    Per fix: ``unmatched`` (no candidate), ``stuck`` (the vehicle has hypotheses but none
    reaches a candidate by a plausible move, there is no candidate, or the best candidate
    scores below ``-outlier_fix_nats``, or it lies across the track beyond every candidate's
    Gaussian error: the fix is an outlier and rejected), ``fresh``
    (the vehicle starts afresh), ``standing`` (it ran less than ``standstill_distance_m``
    since its last fix), ``stood_s`` (how long it has stood at this fix, s), ``rejected``
    (its rejections in a row after this step) and ``along_sigma`` (the fix's error along
    the track, m). Per candidate state: the fix it belongs to (``cv``), the state id
    (``cs``), the offset (``co``, m), the log-probability (``log_p``), the progress along
    its lineage (``progress``, m), the parent slot (``parent``, -1 for a new lineage), the
    time running wrong way (``wrong_way_s``), the state it entered its own from
    (``came_from``, a float; -1: not known) and the fix error filter's state
    (``fix_error``: the arrays named by
    :data:`~antikol.positioning.fixerror.FIX_ERROR_FIELDS`). ``stats`` counts what happened;
    ``course_deg`` (per fix) is the course weighed, degrees (NaN: none).
    """

    unmatched: BoolArray
    stuck: BoolArray
    fresh: BoolArray
    standing: BoolArray
    stood_s: FloatArray
    rejected: IntArray
    along_sigma: FloatArray
    cv: IntArray
    cs: IntArray
    co: FloatArray
    log_p: FloatArray
    progress: FloatArray
    parent: IntArray
    wrong_way_s: FloatArray
    came_from: FloatArray
    fix_error: tuple[FloatArray, ...]
    stats: Counter[str]
    course_deg: FloatArray


def score_fixes(
    fleet: FleetState,
    reach: ReachTable,
    config: PositioningConfig,
    find: Callable[[FloatArray, FloatArray, FloatArray], Candidates],
    headings: Callable[[IntArray, FloatArray, IntArray], FloatArray],
    reports: list[VehicleReport],
    rows: IntArray,
    t: FloatArray,
    speed: FloatArray,
    odo: FloatArray,
    xs: FloatArray,
    ys: FloatArray,
    *,
    course_deg: FloatArray | None = None,
    reach_out_m: FloatArray | None = None,
) -> Scored:
    """Score the candidate states of one fix per vehicle (see the module).

    Parameters
    ----------
    fleet : FleetState
        The vehicles' hypotheses before the fixes (read only).
    reach : ReachTable
    config : PositioningConfig
    find : callable
        ``find(x, y, radius)``: the candidate places of fixes in the local frame (m).
    headings : callable
        ``headings(edge_id, offset_m, direction)``: true headings of travel (degrees) at
        track places (:meth:`antikol.positioning.headings.HeadingProfile.at`).
    reports : list of VehicleReport
    rows : ndarray of int
        Each report's row in ``fleet``.
    t, speed, odo, xs, ys : ndarray
        Time (s), speed (m/s), odometer (m, NaN: none) and local position (m) of each.
    course_deg : ndarray of float, optional
        The course to weigh of each, degrees (default: as reported); NaN: the vehicle is
        placed as if its receiver gave none (:mod:`antikol.positioning.coursecheck`).
    reach_out_m : ndarray of float, optional
        A search radius each fix gets at least, m (its vehicle's own tracks while it
        refuses fixes; :func:`~antikol.positioning.candidates.reach_to_own_tracks_m`).

    Returns
    -------
    Scored
    """
    stats: Counter[str] = Counter()
    c = config
    n = len(reports)
    hdop = np.fromiter((hdop_factor(r.hdop) for r in reports), float, n)
    quality = [r.fix_quality for r in reports]
    kinds = {q: c.error_scales(q) for q in set(quality)}
    if len(kinds) == 1:  # (a fleet's receivers mostly report one kind of fix)
        ((white, bias),) = kinds.values()
        sigma, bias_sigma = white * hdop, bias * hdop
    else:
        scales = np.array([kinds[q] for q in quality], dtype=float)
        sigma = scales[:, 0] * hdop
        bias_sigma = scales[:, 1] * hdop
    stated_bias_sigma = bias_sigma  # (the fix quality's prior, before any learnt one)
    # a plain fix's bias prior is its receiver's, as learnt from its fixes (biasscale)
    plain = np.fromiter((q not in (2, 4, 5) for q in quality), bool, n)
    if plain.any() and c.bias_sigma_max_factor > 1.0:
        learnt = bias_sigma_of(fleet, rows, c.bias_sigma_m, max_factor=c.bias_sigma_max_factor)
        bias_sigma = np.where(plain, learnt * hdop, bias_sigma)
    radius = np.maximum(c.search_radius_m, 4.0 * sigma)
    # the search reaches as far from a hypothesis' track as its fix may lie: the radius
    # covers a bias of twice the stated prior, and the search goes further by what a
    # hypothesis has learnt beyond that. A receiver whose bias had grown to 12 m put an
    # ordinary fix's heavy tail 25 m off its track: that track was no candidate, its
    # hypothesis died and a far less probable one on the next track (wrong-way running)
    # was left holding all the probability, confident. (Not twice the learnt prior: at
    # 10 m that left 5 m of the radius for the fix's own error beyond a 22 m bias)
    filled = fleet.hs[rows] >= 0
    learnt = np.where(filled, np.hypot(fleet.bx[rows], fleet.by[rows]), 0.0).max(axis=1)
    beyond = np.clip(learnt - 2.0 * stated_bias_sigma, 0.0, c.search_radius_m)
    search = radius + beyond
    if reach_out_m is not None:
        search = np.maximum(search, reach_out_m)
    found = find(xs, ys, search)
    # one candidate state per (candidate place, running direction)
    cv = np.repeat(found.point, 2)  # report index of each candidate state
    edge = np.repeat(found.edge_id, 2)
    direction = np.empty(len(edge), dtype=np.int64)
    direction[0::2], direction[1::2] = 1, -1
    cs = state_id(edge, direction)
    co = np.repeat(found.offset_m, 2)
    lateral = np.repeat(found.lateral_m, 2)
    heading = np.repeat(found.heading_deg, 2)
    wrong = ~reach.allowed[cs]

    prev_t = fleet.t[rows]
    dt = np.where(np.isfinite(prev_t), t - prev_t, 0.0)
    odo_prev = fleet.odo[rows]
    has_odo = np.isfinite(odo) & np.isfinite(odo_prev)
    travelled = np.where(
        has_odo,
        np.maximum(odo - np.where(has_odo, odo_prev, 0.0), 0.0),
        0.5 * (speed + fleet.v[rows]) * dt,
    )
    fresh = (
        (fleet.hs[rows, 0] < 0)
        | fleet.unmatched[rows]
        | ~np.isfinite(prev_t)
        | (dt > c.reset_gap_s)
    )
    counts = np.bincount(cv, minlength=n)
    unmatched = counts == 0

    # emission parts that do not depend on the parent: course and the wrong-way cost
    if course_deg is None:
        course_deg = np.fromiter((r.course_deg for r in reports), float, n)
    trusted = np.isfinite(course_deg)
    course = np.where(trusted, course_deg, 0.0)
    use_course = (speed >= c.min_speed_for_course_mps) & trusted
    course_sigma = np.hypot(c.course_sigma_deg, c.course_noise_deg_mps / np.maximum(speed, 0.1))
    track_dir = heading + np.where(direction == 1, 0.0, 180.0)
    diff = (course[cv] - track_dir + 180.0) % 360.0 - 180.0
    course_ll = np.where(
        use_course[cv], _course_ll(diff, course_sigma[cv], c.course_outlier_weight), 0.0
    )
    # a vehicle that starts afresh at a standstill has nothing else to tell the two tracks
    # of a double track apart: the course its receiver holds (the last one measured while
    # moving) breaks the tie, once and weakly (it may be a previous trip's or random)
    start_course = fresh & (speed < c.start_course_max_speed_mps) & trusted
    if start_course.any():
        course_ll = np.where(
            start_course[cv],
            _course_ll(diff, c.start_course_sigma_deg, c.start_course_outlier_weight),
            course_ll,
        )
    h = np.radians(heading)
    nx, ny = -np.cos(h), np.sin(h)  # left normal of the edge's vertex order
    sign = direction.astype(float)
    tx, ty = sign * np.sin(h), sign * np.cos(h)  # unit tangent, running way
    static_ll = course_ll + np.where(wrong, c.wrong_way_log_prior, 0.0)
    standing = travelled < c.standstill_distance_m
    # a long stop is not a long run of evidence: the bias that dominates a standing
    # vehicle's fixes drifts and jumps where it stands, the fixes follow it
    stood = fleet.stood[rows]
    move_weight = np.where(standing, c.standstill_evidence_weight, 1.0)
    weight = move_weight * np.where(standing, np.exp(-stood / c.standstill_evidence_s), 1.0)
    noise_var = (sigma * sigma)[cv]
    floor = c.outlier_weight / (2.0 * radius[cv])

    # pairs: every candidate state with every filled slot of its vehicle's previous
    # hypotheses (most vehicles fill one of the k slots), computed on the pairs alone
    prow = rows[cv]
    valid = (fleet.hs[prow] >= 0) & ~fresh[cv][:, None]
    pc, pk = np.nonzero(valid)  # candidate and slot of each pair
    pr = prow[pc]
    pss = fleet.hs[pr, pk]
    po = fleet.ho[pr, pk]
    exp_m = travelled[cv][pc]
    p_cs = cs[pc]
    dist = reach.signed_distance(
        pss,
        po,
        p_cs,
        co[pc],
        expected_m=exp_m,
        came_from=fleet.hv[pr, pk].astype(np.int64),
    )
    # the move between two candidate places is the distance run plus the difference of
    # the two fixes' errors along the track, which the fix-error filter scores (the lag):
    # an odometer makes the first part exact, not the second, so it narrows the scale
    # only by the speeds' share of it; the outlier gate keeps the odometer's own scale
    # (a fix 50 m off along the track is no move a good odometer allows)
    # (a coarse odometer's step is off by up to its unit: odometerresolution)
    quant = (
        np.where(
            has_odo,
            quantisation_sigma(
                odometer_resolution(fleet, rows), step_sigma_m=c.odometer_step_sigma_m
            ),
            0.0,
        )
        if has_odo.any()
        else np.zeros(n)  # (as np.where gives it: a feed without odometers)
    )
    beta = np.where(
        has_odo,
        c.transition_beta_m + 0.02 * travelled + quant,
        c.transition_beta_m + 0.1 * travelled,
    )[cv][pc]
    # a standing vehicle may change direction (bidirectional trams at termini)
    reversal = ((pss >> 1) == (p_cs >> 1)) & ((pss & 1) != (p_cs & 1))
    rev_ok = reversal & (exp_m < 1.0)
    rev_dist = np.abs(co[pc] - po)
    off_m = np.where(rev_ok, rev_dist, np.abs(dist - exp_m))
    move_cost = off_m / beta
    gate_cost = move_cost  # (the same scale without an odometer)
    odo_pair = has_odo[cv][pc]
    if odo_pair.any():
        gate_beta = np.where(
            odo_pair, 0.3 * c.transition_beta_m + 0.02 * exp_m + quant[cv][pc], beta
        )
        gate_cost = off_m / gate_beta
    pcv = cv[pc]
    still = standing[pcv]
    if still.any():
        # a standing vehicle does not move: a place that only a move of more than
        # five standard deviations of the fix's error (white and bias) reaches is none for
        # it. After a long stop the fixes weigh next to nothing (below), and one that lands
        # 30 m off would otherwise carry the hypotheses to the only places it offers (and
        # be the next fix's reference for a jump)
        scatter_m = _STANDING_SCATTER_SIGMAS * np.sqrt(noise_var[pc] + bias_sigma[pcv] ** 2)
        far = still & ~rev_ok & (off_m > scatter_m)
        if far.any():
            gate_cost = np.where(far, np.inf, gate_cost)
    # at a standstill the candidates move with the fix's own error: their moves are
    # evidence of the fix (weighted as its emission), not of the vehicle
    trans = np.where(rev_ok, c.reversal_log_prior, 0.0) - move_cost * move_weight[cv[pc]]
    dist = np.where(rev_ok, rev_dist, dist)
    enters_wrong = wrong[pc] & reach.allowed[pss]
    trans = trans + np.where(enters_wrong, c.wrong_way_entry_log_prior, 0.0)
    trans = np.where(np.isfinite(trans), trans, _NEG_INF)
    # a standing vehicle's fixes tell next to nothing (above), and its hypotheses must not
    # gain from it either: each one hands on its probability, shared over the places its
    # fix offers, instead of giving it whole to each (a switch offers a place on every
    # branch, and a tram standing past it would drift to the side with more places)
    if still.any():
        trans = _shared_out(trans, still, pcv * valid.shape[1] + pk, n * valid.shape[1])

    parent = FixErrorState(*(getattr(fleet, name)[pr, pk] for name in FIX_ERROR_FIELDS))
    # the error of the predicted distance: the odometer's, or the speeds' over the interval
    run_var = np.where(
        has_odo,
        (c.odometer_sigma_fraction * travelled) ** 2 + c.odometer_step_sigma_m**2 + quant**2,
        (c.speed_sigma_mps * dt) ** 2 + (c.speed_distance_sigma_fraction * travelled) ** 2,
    )[pcv]
    shift = np.where(np.isfinite(dist), exp_m - dist, 0.0)
    prior = fix_error_predict(
        parent, dt[pcv], bias_sigma[pcv], c.bias_tau_s, shift, run_var
    ).forget_lag(rev_ok)
    # a late fix lies behind the vehicle by its speed times its latency
    # (:mod:`~antikol.positioning.latency`), a lag that braking shrinks faster than the
    # lag's own filter follows (a 2-s receiver's tram braking into a stop lost its track
    # to a stub beside it). The latency counts from where it is surely above zero (two
    # standard deviations): one learnt from the noise of a receiver without any moved
    # every hypothesis' lag and cost the referee's selectivity
    learnt = fleet.lt[rows] - 2.0 * np.sqrt(np.maximum(fleet.lptt[rows], 0.0))
    latency = np.where(np.isfinite(learnt), np.clip(learnt, 0.0, MAX_LATENCY_S), c.fix_latency_s)
    late_m = latency * speed
    pair_late_m = late_m[pcv]
    post, lat_i, along_i = fix_error_update(
        prior, nx[pc], ny[pc], lateral[pc], tx[pc], ty[pc], noise_var[pc] / weight[pcv],
        pair_late_m,
    )  # fmt: skip
    # a moving vehicle's fix that lies, across the track, where the heavy-tailed floor
    # explains it better than the Gaussian does for every candidate is no evidence of
    # where along the track the vehicle is either: its places along diverging branches
    # still differ (the branches at an angle), and that difference alone decided a branch
    # (one fix 18 m beside two branches 1–2 m apart put their places 4 m apart). (A
    # standing vehicle's fixes are weighed down by a variance that puts even a fix on the
    # track below the floor; the standing gate judges those.)
    gaussian = _gaussian_part(lat_i.residual_m, lat_i.variance_m2, c.outlier_weight)
    lat_ll = np.log(gaussian + floor[pc])  # (as _mixture_ll, the Gaussian computed once)
    explained = standing.copy()
    np.logical_or.at(explained, pcv, gaussian > floor[pc])
    # the course is the heading where the hypothesis puts the vehicle, not where the fix
    # projects: in a tight curve a fix metres off along the track projects where the track
    # turns another way, and the hypothesis that knows its place should not pay for that
    # (where it was when the fix was taken: a late receiver's course is as late)
    # (a place behind the start of the candidate's edge is on the edge the hypothesis came
    # from: a fix metres ahead past a switch projects into the branch's curve)
    pair_course_ll = _placed_course_ll(
        headings, reach.lengths, edge[pc], direction[pc], co[pc], post.ad - pair_late_m,
        course[pcv], course_sigma[pcv], use_course[pcv], c.course_outlier_weight,
        course_ll[pc],
        parent=(pss, po, np.where(rev_ok | ~np.isfinite(dist), np.nan, dist)),
        parent_unbranched=reach.unbranched_exit,
    )  # fmt: skip
    along_ll = _mixture_ll(
        along_i.residual_m, along_i.variance_m2, c.outlier_weight, floor[pc]
    ) - _mixture_ll(0.0, noise_var[pc] + bias_sigma[pcv] ** 2, c.outlier_weight, floor[pc])
    along_ll = np.where(rev_ok, 0.0, along_ll)
    # a course measured while moving is evidence of its own, not the fixes' drift at a
    # standstill: it keeps its full weight when a short run (an odometer read out in whole
    # metres at a departure) counts the vehicle as standing
    course_weight = np.where(use_course, 1.0, weight)[pcv]
    emit = (lat_ll + along_ll + static_ll[pc] - course_ll[pc]) * weight[pcv]
    emit += pair_course_ll * course_weight
    # laid out (candidate, slot) for the reductions, every other slot at -inf: the sums
    # run over the k slots in the same order whatever the number of hypotheses
    score = np.full(valid.shape, _NEG_INF)
    score[pc, pk] = fleet.hp[pr, pk] + trans + emit
    cost = np.full(valid.shape, np.inf)
    cost[pc, pk] = gate_cost
    pair_of = np.full(valid.shape, len(pc))  # the pair at each (candidate, slot); none
    pair_of[pc, pk] = np.arange(len(pc))
    best = np.argmax(score, axis=1)
    ar = np.arange(len(cs))
    top = score[ar, best]
    with np.errstate(invalid="ignore"):
        lse = top + np.log(np.sum(np.exp(score - top[:, None]), axis=1))
    lse = np.where(np.isfinite(top), lse, _NEG_INF)

    # fresh starts: the emission alone, with the stationary bias prior
    start = FixErrorState.start(len(cs), bias_sigma[cv])
    post0, lat0_i, _ = fix_error_update(start, nx, ny, lateral, tx, ty, noise_var, late_m[cv])
    lat0 = _mixture_ll(lat0_i.residual_m, lat0_i.variance_m2, c.outlier_weight, floor)
    score0 = lat0 + static_ll + np.where(wrong, c.wrong_way_entry_log_prior, 0.0)

    # fixes no hypothesis explains: no track within the search radius, or none that a
    # plausible move reaches (a jump the map cannot explain, a far outlier near another
    # track); the vehicle keeps its hypotheses and the report is dead-reckoned
    cont = ~fresh[cv]
    cheapest = np.min(cost, axis=1)
    plausible = np.isfinite(lse) & cont & (cheapest <= c.implausible_move_nats)
    reach_any = np.zeros(n, bool)
    np.logical_or.at(reach_any, cv, plausible)
    stuck = ~fresh & ~reach_any
    # (counted as rejections in a row; enough of them and the vehicle starts afresh; a
    # copy of the last rejected fix counts once: it is the same evidence)
    noted = ~np.isnan(fleet.rx[rows])
    repeat = fleet.repeats_rejected(rows, xs, ys, t, c.dead_reckoning_s) if noted.any() else noted
    rejected = fleet.rejected[rows] + (stuck & ~repeat)
    restart = stuck & (rejected >= c.max_rejections_in_row)
    for name, happened in (
        ("unreachable_fix", stuck & ~unmatched),
        ("outlier_off_track", stuck & unmatched),
        ("reset_after_rejections", restart),
    ):
        if happened.any():
            stats[name] += int(np.count_nonzero(happened))
    rejected[restart] = 0
    fresh |= restart
    use0 = fresh[cv]
    # the vehicle may be where its previous hypotheses cannot reach (a track missing
    # from the map, a wrong connection): a small prior keeps the filter from holding on
    # to an impossible history (but a plausible move, however poor, keeps the lineage: a
    # fix off along the track is an outlier, not a relocation)
    relocate = score0 + c.relocation_log_prior
    # wrong-way running (and running against the reported course) is entered by a move
    # the map allows (a crossover, a reversal at a standstill) or at a fresh start, never
    # by a jump no route makes: a jump of the GPS bias puts the fixes of a tram on double
    # track onto the other direction's track, where a hypothesis without the bias'
    # history explains them better than the right one (which has learnt the old bias)
    # for the seconds it takes to learn the new one
    runs_right = reach.allowed[np.maximum(fleet.hs[prow, 0], 0)]
    against_course = use_course[cv] & (np.abs(diff) > 90.0)
    relocate = np.where((wrong & runs_right) | against_course, _NEG_INF, relocate)
    moved = ~use0 & (relocate > top) & ~plausible
    lse = np.where(use0, lse, np.logaddexp(lse, relocate))
    if moved.any():
        stats["relocated"] += int(np.count_nonzero(moved))
    use0 = use0 | moved
    new_lp = np.where(fresh[cv], score0, lse)
    # a fix every candidate explains worse than ``outlier_fix_nats`` (log-likelihood of the
    # step, the hypothesis' probability included) is an outlier as well
    top_lp = np.full(n, _NEG_INF)
    np.maximum.at(top_lp, cv, new_lp)
    # (judged with the best parent's move at the outlier gate's scale)
    top_strict = top_lp
    if gate_cost is not move_cost:
        gate_pair = pair_of[ar, best]
        with np.errstate(invalid="ignore"):  # (no move at all: inf - inf)
            extra = (gate_cost - move_cost) * move_weight[pcv]
        extra = np.where(np.isfinite(extra), extra, 0.0)
        stricter = np.where(gate_pair < len(pc), extra[np.minimum(gate_pair, len(pc) - 1)], 0.0)
        strict_lp = np.where(fresh[cv] | use0, new_lp, new_lp - stricter)
        top_strict = np.full(n, _NEG_INF)
        np.maximum.at(top_strict, cv, strict_lp)
    poor = ~fresh & ~unmatched & ~stuck & ((top_strict < -c.outlier_fix_nats) | ~explained)
    if poor.any():
        stats["outlier_fix"] += int(np.count_nonzero(poor))
        rejected = rejected + (poor & ~repeat)
        again = poor & (rejected >= c.max_rejections_in_row)
        stuck = stuck | (poor & ~again)
        rejected[again] = 0
    # a relocation is taken on the second fix in a row that it explains best: one stray
    # fix beside the track (a heavy-tailed error landing on another track) is an outlier,
    # not a jump there and back
    relocating = np.zeros(n, bool)
    np.logical_or.at(relocating, cv, moved & (new_lp >= top_lp[cv]))
    deferred = relocating & ~fresh & ~stuck & ((rejected == 0) | repeat)
    if deferred.any():
        stats["relocation_deferred"] += int(np.count_nonzero(deferred))
        rejected = rejected + (deferred & ~repeat)
        stuck = stuck | deferred
    # the best parent of each candidate state (a slot without a pair only where the
    # vehicle starts afresh, which every use below masks)
    chosen = pair_of[ar, best]
    has_pair = chosen < len(pc)
    at_pair = np.where(has_pair, chosen, 0)

    def of_best(a: npt.NDArray[Any], empty: float) -> npt.NDArray[Any]:
        if not len(a):
            return np.full(len(chosen), empty, dtype=a.dtype)
        return np.where(has_pair, a[at_pair], empty)

    new_prog = np.where(use0, 0.0, fleet.hg[prow, best] + of_best(dist, 0.0))
    new_parent = np.where(use0, -1, best)
    new_ww = np.where(wrong, np.where(use0, 0.0, fleet.hw[prow, best] + dt[cv]), 0.0)
    entered = _came_from(
        reach,
        of_best(pss, 0),
        fleet.hv[prow, best].astype(np.int64),
        cs,
        of_best(dist, 0.0),
    )
    new_came: FloatArray = np.where(use0 | of_best(rev_ok, False), -1.0, entered.astype(float))

    # the filter's columns, all at once: a fresh start's where the vehicle starts afresh,
    # else the best pair's
    # (np.array of the columns, not np.stack: a third of the time on a cycle's few rows)
    cols = np.array(post0.columns())
    if len(pc):
        cols = np.where(use0, cols, np.where(has_pair, np.array(post.columns())[:, at_pair], 0.0))
    else:
        cols = np.where(use0, cols, 0.0)
    error_cols = tuple(cols)
    return Scored(
        unmatched,
        stuck & ~fresh,
        fresh,
        standing,
        np.where(standing, stood + dt, 0.0),
        rejected,
        np.hypot(sigma, bias_sigma),
        cv,
        cs,
        co,
        new_lp,
        new_prog,
        new_parent,
        new_ww,
        new_came,
        error_cols,
        stats,
        course_deg,
    )


def _shared_out(
    trans: FloatArray, which: BoolArray, parent: IntArray, n_parents: int
) -> FloatArray:
    """``trans`` (log, per pair) of the pairs ``which`` normalised over the pairs of the
    same parent (``parent``, below ``n_parents``): each parent's outgoing weights sum to
    one."""
    at = np.flatnonzero(which & np.isfinite(trans))
    if not len(at):
        return trans
    group = parent[at]
    top = np.full(n_parents, _NEG_INF)
    np.maximum.at(top, group, trans[at])
    total = np.zeros(n_parents)
    np.add.at(total, group, np.exp(trans[at] - top[group]))
    out = trans.copy()
    out[at] = trans[at] - (top[group] + np.log(total[group]))
    return out


def _gaussian_part(resid: Any, var: Any, outlier_weight: float) -> Any:
    """Density of the Gaussian part of an innovation's mixture (weight ``1 -
    outlier_weight``)."""
    return (
        (1.0 - outlier_weight)
        * np.exp(-0.5 * resid * resid / var - 0.5 * np.log(var))
        / math.sqrt(2.0 * math.pi)
    )


def _mixture_ll(resid: Any, var: Any, outlier_weight: float, floor: Any) -> Any:
    """Log-density of a Gaussian innovation with a heavy-tailed floor (an outlier's)."""
    return np.log(_gaussian_part(resid, var, outlier_weight) + floor)


def _course_ll(diff_deg: Any, sigma_deg: Any, outlier_weight: float) -> Any:
    """Log-density of a course ``diff_deg`` off the track heading (degrees): a Gaussian of
    ``sigma_deg`` with a floor uniform over the circle (a course gone astray)."""
    gauss = np.exp(-0.5 * (diff_deg / sigma_deg) ** 2) / (sigma_deg * math.sqrt(2.0 * math.pi))
    return np.log((1.0 - outlier_weight) * gauss + outlier_weight / 360.0)


def _placed_course_ll(
    headings: Callable[[IntArray, FloatArray, IntArray], FloatArray],
    lengths: FloatArray,
    edge: IntArray,
    direction: IntArray,
    offset_m: FloatArray,
    lag_m: FloatArray,
    course_deg: FloatArray,
    sigma_deg: FloatArray,
    use: BoolArray,
    outlier_weight: float,
    at_fix_ll: FloatArray,
    *,
    parent: tuple[IntArray, FloatArray, FloatArray] | None = None,
    parent_unbranched: BoolArray | None = None,
) -> FloatArray:
    """The course's log-density against the track heading at the hypothesis' own place:
    the fix's projection ``offset_m`` moved by the filtered lag ``lag_m`` (m, in the
    running direction), where it moved by more than :data:`PLACE_MOVE_M`; ``at_fix_ll``
    elsewhere.

    A place behind the start of the edge is looked up on the previous hypothesis' edge
    where it lies there and that edge runs on to no other track (``parent_unbranched``,
    by state id): ``parent`` gives its track state, its offset (m) and the signed distance
    from it to ``offset_m`` (m; NaN: not known). Behind a facing switch the place would
    say nothing of the branch the hypothesis is on, and the branch is what its course
    decides. Elsewhere the place is kept on the edge."""
    moved = use & (np.abs(lag_m) > PLACE_MOVE_M) & (np.abs(lag_m) < MAX_PLACE_MOVE_M)
    if not moved.any():
        return at_fix_ll
    idx = np.flatnonzero(moved)
    e = edge[idx]
    d = direction[idx]
    along = offset_m[idx] + d * lag_m[idx]
    place = np.clip(along, 0.0, lengths[e])
    heading = headings(e, place, d)
    if parent is not None:
        p_state, p_offset, p_dist = (np.asarray(a)[idx] for a in parent)
        p_edge, p_dir = state_edge(p_state), state_direction(p_state)
        run = p_dist + lag_m[idx]  # from the previous place to the hypothesis' own, m
        left = np.where(p_dir > 0, lengths[p_edge] - p_offset, p_offset)
        back = (p_edge != e) & (np.where(d > 0, along < 0.0, along > lengths[e]))
        back &= (run >= 0.0) & (run <= left)  # (NaN: False)
        if parent_unbranched is not None:
            back &= parent_unbranched[p_state]
        if back.any():
            b = np.flatnonzero(back)
            heading = heading.copy()
            heading[b] = headings(p_edge[b], p_offset[b] + p_dir[b] * run[b], p_dir[b])
    diff = (course_deg[idx] - heading + 180.0) % 360.0 - 180.0
    out = at_fix_ll.copy()
    out[idx] = _course_ll(diff, sigma_deg[idx], outlier_weight)
    return out


def _came_from(
    reach: ReachTable, parent: IntArray, parent_came: IntArray, state: IntArray, moved: FloatArray
) -> IntArray:
    """The state each new hypothesis entered its own from: its parent's where it stays in
    the parent's state, the parent's state where it ran forward straight into the next
    one, the one way in that its run reaches where it ran over short edges into a state
    that tracks join before (:meth:`ReachTable.way_in`), else not known (-1: several ways,
    or it stepped back)."""
    same = state == parent
    forward = (moved >= 0.0) & ~same
    straight = forward & reach.adjacent(parent, state)
    came = np.where(same, parent_came, np.where(straight, parent, -1))
    # a tram that ran over a short edge into a junction's track must still be able to
    # step back the way it came when it stands (its fixes scatter behind the junction):
    # one stray fix ahead carried a stopping tram 9.5 m over a short edge past a trailing
    # junction, where its standing hypothesis could not step back and was lost
    over = forward & ~straight & (reach.ways_in_count[state] > 1)
    if over.any():
        came[over] = reach.way_in(parent[over], state[over], moved[over])
    return came
