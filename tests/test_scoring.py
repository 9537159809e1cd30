"""Scoring that does not hide lateness (issue 11, finding 6), on hand-made alarm logs."""

from __future__ import annotations

import numpy as np
import pytest

from antikol.evaluation.groundtruth import CLEAR, NEUTRAL, REQUIRED, GroundTruth
from antikol.evaluation.scoring import AlarmLog, Score, score

N = 120  # one-second cycles


def _truth(required: list[tuple[int, int]], clear: list[tuple[int, int]] = ()) -> GroundTruth:
    times = np.arange(1.0, N + 1.0)
    st = np.full(N, NEUTRAL, dtype=np.int8)
    kinds = [""] * N
    for a, b in required:
        st[a:b] = REQUIRED
        for k in range(a, b):
            kinds[k] = "rear_end"
    for a, b in clear:
        st[a:b] = CLEAR
    back = np.full(N, NEUTRAL, dtype=np.int8)
    return GroundTruth(
        times,
        ["A", "B"],
        {("A", "B"): st, ("B", "A"): back},
        {("A", "B"): kinds, ("B", "A"): [""] * N},
        {"A": np.ones(N, dtype=bool), "B": np.ones(N, dtype=bool)},
    )


def _log(warn_ab: list[tuple[int, int]], lamp_b: list[tuple[int, int]] = ()) -> AlarmLog:
    w = np.zeros(N, dtype=bool)
    for a, b in warn_ab:
        w[a:b] = True
    lb = np.zeros(N, dtype=bool)
    for a, b in lamp_b:
        lb[a:b] = True
    return AlarmLog(
        np.arange(1.0, N + 1.0),
        {("A", "B"): w, ("B", "A"): np.zeros(N, dtype=bool)},
        {"A": w.copy(), "B": lb},
    )


def test_a_late_warning_is_a_miss():
    """The requirement begins at cycle 40; the lamp comes on 4 s later: that is a miss."""
    sc = score(_truth([(40, 60)]), _log([(44, 60)]))
    assert sc.required == 1
    assert sc.missed == 1 and sc.timely == 0
    assert sc.late == 1  # for information: the miss was a late warning
    (m,) = sc.missed_detail
    assert (m.own, m.other, m.start_s, m.kind, m.late_s) == ("A", "B", 41.0, "rear_end", 4.0)
    assert sc.alarm_at_start_rate == 0.0
    assert sc.as_dict()["missed"] == 1


def test_a_warning_within_a_cycle_of_the_start_is_timely_and_leads_are_measured():
    sc = score(_truth([(40, 60), (80, 90)]), _log([(41, 60), (72, 75)]))
    assert (sc.required, sc.timely, sc.missed, sc.late) == (2, 2, 0, 0)
    assert sc.leads_s == (0.0, 8.0)
    assert sc.mean_lead_s == pytest.approx(4.0)
    # at start: within [start - 5 s, start + 1 s]; a chance alarm 8 s before does not count
    assert sc.at_start == 1 and sc.alarm_at_start_rate == 0.5


def test_never_warned_is_missed_and_not_late():
    sc = score(_truth([(40, 60)]), _log([]))
    assert (sc.missed, sc.late, sc.timely) == (1, 0, 0)
    assert sc.missed_detail[0].late_s is None


def test_short_gaps_do_not_split_an_episode():
    truth = _truth([(40, 50), (52, 60)])
    assert score(truth, _log([(40, 60)])).required == 1
    assert score(truth, _log([(40, 60)]), bridge_s=0.0).required == 2


def test_false_alarms_toggles_and_nuisance_lamp():
    truth = _truth([(40, 60)], clear=[(0, 20), (100, 120)])
    # A: warned in time, and once more on a conflict-free stretch far from any need
    log = _log([(38, 62), (5, 15)], lamp_b=[(100, 110)])
    sc = score(truth, log)
    assert sc.false_alarm_episodes == 1
    assert sc.lamp_toggles == 2 + 2 + 2  # A: two episodes, B: one
    assert sc.lamp_on_s == 24 + 10 + 10
    # A's lamp at 5..15 is far from its need at 40..60; B never needs a warning
    assert sc.nuisance_lamp_s == 10 + 10
    assert sc.nuisance_lamp_share == pytest.approx(20.0 / (2 * N))
    assert sc.nuisance_share_of_lamp == pytest.approx(20.0 / 44.0)
    # within 10 s before and 5 s after the need it is not a nuisance
    near = score(truth, _log([(30, 65)]))
    assert near.nuisance_lamp_s == 0.0
    assert score(truth, _log([(29, 66)])).nuisance_lamp_s == 2.0


def test_score_record_is_frozen_and_its_rates_are_safe():
    sc = Score()
    assert sc.alarm_at_start_rate is None and sc.missed_share == 0.0
    assert sc.false_alarms_per_vehicle_hour == 0.0 and sc.nuisance_lamp_share == 0.0
    with pytest.raises(AttributeError):
        sc.missed = 3  # type: ignore[misc]
