"""Measured accuracy of track-selective positioning on simulated Kraków traces.

GPS white noise sigma 3 m plus a Gauss-Markov bias (1.5 m, 60 s), 1 Hz, 10 % of fixes
missing, speeds up to 70 km/h; fixed seeds.
"""

from __future__ import annotations

import pytest

import trackmap
from antikol.evaluation.positioning_accuracy import PositioningScore, positioning_accuracy
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
