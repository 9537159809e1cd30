"""Measured accuracy of track-selective positioning on simulated Kraków traces.

The easy case: GPS white noise sigma 3 m plus a Gauss-Markov bias (1.5 m, 60 s), 1 Hz, 10 %
of fixes missing, speeds up to 70 km/h; fixed seeds. The realistic case (issue 12): the
street receiver of ``GpsModel.urban()`` — a lateral multipath bias of up to ~4 m on double
track that persists for minutes and jumps, heavy tails, outages, an odometer and no-fix
reports in the tunnel. Its thresholds are what the current positioner achieves with a
margin (``python benchmarks/positioning_accuracy.py``, seeds 4-6, 12 trams, 15 min: right
track on double track 99.7-99.9 %, right branch 96-99 %, confident and wrong 0.06-0.20 %
of confident estimates, disconnected 10-s windows 0.2 %); tighten them as positioning
improves.
"""

from __future__ import annotations

import dataclasses

import pytest

import trackmap
from antikol.evaluation.positioning_accuracy import (
    PositioningScore,
    positioning_accuracy,
    wrong_way_positioning,
)
from antikol.evaluation.scenarios import build_scenario, run_scenario
from antikol.evaluation.scoring import compare
from antikol.sim import GpsModel, Simulator, fleet

SEEDS = (2, 3)


@pytest.fixture(scope="module")
def scores() -> list[PositioningScore]:
    net = trackmap.load_default()
    gps = GpsModel(sigma_m=3.0, bias_sigma_m=1.5, bias_tau_s=60.0, missing_rate=0.10)
    out = []
    for seed in SEEDS:
        result = Simulator(
            net, fleet(net, 20, seed), gps=gps, seed=seed, default_speed_mps=70 / 3.6
        ).run(900.0)
        out.append(positioning_accuracy(net, result))
    return out


def test_right_track_and_direction_on_double_track(scores):
    fixes = sum(s.double_track_fixes for s in scores)
    correct = sum(s.double_track_correct for s in scores)
    assert fixes > 10_000
    assert correct / fixes >= 0.99


def test_right_branch_50_m_after_a_switch(scores):
    fixes = sum(s.after_switch_fixes for s in scores)
    correct = sum(s.after_switch_correct for s in scores)
    assert fixes > 300
    assert correct / fixes >= 0.97


def test_along_track_error_a_third_below_raw_projection(scores):
    for s in scores:
        assert s.along_rmse_m <= (1.0 - 1.0 / 3.0) * s.raw_along_rmse_m


# -- realistic street GPS (issue 12) ---------------------------------------------------------
@pytest.fixture(scope="module")
def urban() -> PositioningScore:
    net = trackmap.load_default()
    result = Simulator(
        net, fleet(net, 12, 4), gps=GpsModel.urban(), seed=4, default_speed_mps=70 / 3.6
    ).run(600.0)
    assert any(r.fix_quality == 0 for r in result.reports)  # outages and the tunnel
    return positioning_accuracy(net, result)


def test_realistic_bias_right_track_on_double_track_and_after_switches(urban):
    assert urban.double_track_fixes > 4000 and urban.after_switch_fixes > 100
    # 0.995 before an undecided branch was reported at its switch, 0.998 before outlier
    # fixes were dead-reckoned over
    assert urban.double_track_right_share >= 0.9985
    assert urban.double_track_accuracy >= 0.985
    assert urban.branch_accuracy >= 0.93


def test_realistic_bias_confident_and_wrong_is_rare(urban):
    assert urban.confident_fixes > 0.9 * urban.fixes
    assert urban.confident_wrong_share <= 0.005  # the target


def test_realistic_bias_reliability_table_and_direction(urban):
    top = urban.reliability[-1]
    assert (top.lo, top.hi) == (0.99, 1.0)
    assert top.fixes > 0.8 * urban.fixes
    assert top.share_right is not None and top.share_right >= 0.995
    assert sum(b.fixes for b in urban.reliability) == urban.fixes - urban.unmatched
    assert urban.right_way_share >= 0.99
    assert urban.windows > 500
    # 1.8 % before an undecided branch was reported at its switch (a corrected branch
    # jumps), 0.8 % before outlier fixes were forgiven and the hold found the switch behind
    assert urban.disconnected_share <= 0.004


# -- the same receiver through an operator's feed: no fix-quality field ----------------------
@pytest.fixture(scope="module")
def feed() -> PositioningScore:
    net = trackmap.load_default()
    gps = GpsModel.urban(fix_quality_field=False)
    result = Simulator(net, fleet(net, 12, 4), gps=gps, seed=4, default_speed_mps=70 / 3.6).run(
        600.0
    )
    assert all(r.fix_quality is None for r in result.reports)
    return positioning_accuracy(net, result)


def test_a_feed_that_repeats_the_last_position_unflagged_positions_as_well(feed):
    # the outages' reports repeat the last position with no field to say so; taken as
    # fixes they pulled the positions back to where the fix froze (seed 4: 76 wrong
    # estimates on double track, 110 confident and wrong, 21 broken windows of 654)
    assert feed.double_track_fixes > 4000
    assert feed.double_track_right_share >= 0.9985
    assert feed.confident_wrong_share <= 0.005
    assert feed.disconnected_share <= 0.004


def test_past_switches_the_reports_with_a_fix_are_told_by_the_receiver_not_the_feed(urban, feed):
    # the split counts what the receiver had (the simulator's log), so the unflagged feed
    # and the flagged receiver of the same run agree; the 98 % holds with a fix
    assert feed.after_switch_measured == urban.after_switch_measured > 100
    assert urban.after_switch_measured <= urban.after_switch_fixes
    assert urban.measured_branch_accuracy >= 0.98


def test_fixes_a_second_late_cost_little_once_their_latency_is_learnt(urban):
    # the same receiver, its output 1 s old when stamped: before the latency was learnt
    # the along-track error was 7.5-8.2 m on seeds 4-6 (2.0-2.2 m on time)
    net = trackmap.load_default()
    gps = GpsModel.urban(latency_s=1.0)
    late = positioning_accuracy(
        net,
        Simulator(net, fleet(net, 12, 4), gps=gps, seed=4, default_speed_mps=70 / 3.6).run(600.0),
    )
    assert late.along_rmse_m <= 1.25 * urban.along_rmse_m
    assert late.double_track_right_share >= 0.9985
    assert late.confident_wrong_share <= 0.005


# -- wrong-way running (a hook for positioning) ------------------------------------------
@pytest.fixture(scope="module")
def wrong_way():
    net = trackmap.load_default()
    scn = build_scenario("wrong_way_single_line", net, seed=1)
    scn = dataclasses.replace(scn, gps=GpsModel.exact())
    result = run_scenario(scn)
    return scn, wrong_way_positioning(net, result, "W"), compare(net, result, name=scn.name)


@pytest.fixture(scope="module")
def wrong_way_dgps():
    net = trackmap.load_default()
    scn = build_scenario("wrong_way_single_line", net, seed=2)
    gps = GpsModel(sigma_m=0.7, bias_sigma_m=0.5, fix_quality=2)  # differential receiver
    result = run_scenario(dataclasses.replace(scn, gps=gps))
    return wrong_way_positioning(net, result, "W"), compare(net, result, name=scn.name)


def test_wrong_way_running_is_detected_with_a_differential_receiver(wrong_way_dgps):
    ww, comparison = wrong_way_dgps
    assert ww.flagged_on_true_track >= 0.8 * ww.fixes
    assert ww.first_detection_s is not None and ww.first_detection_s <= 10.0
    assert comparison.track.missed == 0


def test_the_wrong_way_scenario_runs_wrong_way_over_a_crossover(wrong_way):
    scn, ww, comparison = wrong_way
    assert "crossover" in scn.description and scn.specs[0].route.wrong_way
    assert ww.fixes >= 20  # W runs against the permitted direction for 20 s and more
    assert comparison.track.required >= 1  # a head-on conflict with O on that track


def test_positioning_detects_wrong_way_running(wrong_way):
    # an RTK receiver (fix quality 4) puts the tram on its true track at once: wrong-way
    # running is detected from the first fix and the head-on conflict is warned
    _, ww, comparison = wrong_way
    assert ww.detected_share >= 0.8
    assert ww.first_detection_s is not None and ww.first_detection_s <= 10.0
    assert comparison.track.missed == 0
