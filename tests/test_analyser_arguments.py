"""The analyser's public calls and settings refuse bad arguments with the project's error,
before anything changes (an API probe found bare TypeErrors, a clock moved by a refused
call, a generator read twice and settings that silently hid an emergency)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import Analyser, AnalyserConfig, VehicleReport
from antikol.errors import InvalidArgumentError

BAD_TIMES = ["abc", 1j, [1.0], np.array([1.0]), np.array(5000.0), 10**400, True, math.nan]


@pytest.fixture(scope="module")
def net():
    return trackmap.load_default()


def _on_track(net, vid: str, t: float, offset_m: float, *, edge: int = 682) -> VehicleReport:
    lon, lat = net.to_lonlat(*net.point_at(edge, offset_m))
    heading = float(net.headings_at([edge], [offset_m], [1])[0])
    return VehicleReport(vid, t, lat, lon, 8.0, heading)


@pytest.mark.parametrize("with_map", [False, True])
@pytest.mark.parametrize("bad", BAD_TIMES, ids=repr)
def test_a_bad_time_is_refused_before_the_clock_moves(net, with_map, bad):
    an = Analyser(track_map=net if with_map else None)
    an.update_many([_on_track(net, "A", 100.0, 50.0), _on_track(net, "B", 100.0, 200.0)])
    calls = [
        lambda: an.assess("A", t=bad),
        lambda: an.assess_all(t=bad),
        lambda: an.expire(bad),
        lambda: an.table.expire(bad),
        lambda: an.zones("A", t=bad),
        lambda: an.position("A", bad),
    ]
    for call in calls:
        with pytest.raises(InvalidArgumentError, match="t|now"):
            call()
    # (a 0-d array of 5000 s moved the clock and expired every vehicle, then raised)
    assert an.table.clock == 100.0 and set(an.table.vehicle_ids()) == {"A", "B"}


@pytest.mark.parametrize("bad", [None, {}, "A", 5, [1]], ids=repr)
def test_wrong_types_of_arguments_are_refused_by_name(net, bad):
    an = Analyser(track_map=net)
    an.update(_on_track(net, "A", 1.0, 50.0))
    with pytest.raises(InvalidArgumentError, match="report"):
        an.update(bad)
    with pytest.raises(InvalidArgumentError, match="report"):
        an.update_many([_on_track(net, "A", 2.0, 58.0), bad])
    assert an.table.get("A").t == 1.0  # the batch was refused whole
    if bad is not None and not isinstance(bad, str):  # (None: the configured own_id)
        for call in (an.assess, an.position, an.zones):
            with pytest.raises(InvalidArgumentError, match="own_id|vehicle_id"):
                call(bad)


def test_update_many_refuses_a_single_report_or_none(net):
    an = Analyser(track_map=net)
    for bad in (None, _on_track(net, "A", 1.0, 50.0)):
        with pytest.raises(InvalidArgumentError, match="reports"):
            an.update_many(bad)


def test_update_many_takes_a_generator_with_a_map(net):
    # the table read it, and positioning found it empty (zip() raised; never positioned)
    an = Analyser(track_map=net)
    results = an.update_many(_on_track(net, "A", float(t), 50.0 + 8.0 * t) for t in range(3))
    assert [r.accepted for r in results] == [True, True, True]
    pos = an.position("A")
    assert pos is not None and pos.edge_id == 682 and pos.t == 2.0


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"expiry_s": -1.0}, "expiry_s"),
        ({"expiry_s": -math.inf}, "expiry_s"),
        ({"expiry_s": "x"}, "expiry_s"),
        ({"own_id": 5}, "own_id"),
        ({"track_map": "x"}, "track_map"),
    ],
)
def test_analyser_settings_are_checked(net, kwargs, name):
    with pytest.raises(InvalidArgumentError, match=name):
        Analyser(**({"track_map": net} | kwargs))


def test_the_emergency_a_negative_expiry_hid(net):
    # with a map the table keeps vehicles for dead reckoning, so expiry_s = -1 was
    # accepted and every other vehicle was dropped from each assessment
    an = Analyser(track_map=net)
    an.update_many([_on_track(net, "A", 0.0, 50.0), _on_track(net, "B", 0.0, 70.0)])
    assert an.assess("A").level == "emergency"


FLOAT_FIELDS = [f.name for f in dataclasses.fields(AnalyserConfig) if f.type == "float"]


@settings(max_examples=60, deadline=None)
@given(
    name=st.sampled_from(FLOAT_FIELDS),
    value=st.one_of(
        st.just(math.nan),
        st.just(math.inf),
        st.just(-math.inf),
        st.floats(max_value=-1e-9, allow_nan=False, allow_infinity=False),
        st.sampled_from(["x", None, [1.0], 1j]),
    ),
)
def test_no_analysis_setting_takes_a_non_finite_negative_or_non_number(name, value):
    # a NaN gap margin or anticipation gave no threat where there was an emergency
    with pytest.raises(InvalidArgumentError, match=name):
        AnalyserConfig(**{name: value})


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"max_hypotheses": 1.5}, "max_hypotheses"),
        ({"max_hypotheses": True}, "max_hypotheses"),
        ({"warning_probability": 1.5}, "warning_probability"),
        ({"start_speed_mps": 0.2}, "start_speed_mps"),  # below stopped_speed_mps
        ({"min_horizon_m": 0.0}, "min_horizon_m"),
        ({"hysteresis": "yes"}, "hysteresis"),
        ({"alarms": None}, "alarms"),
    ],
)
def test_analysis_settings_of_other_kinds_are_checked(kwargs, name):
    with pytest.raises(InvalidArgumentError, match=name):
        AnalyserConfig(**kwargs)


def test_nested_settings_are_checked_by_their_full_name():
    from antikol.analysis.alarms import AlarmPolicy
    from antikol.analysis.branches import BranchSettings

    with pytest.raises(InvalidArgumentError, match=r"alarms\.min_on_s"):
        AnalyserConfig(alarms=AlarmPolicy(min_on_s=math.nan))
    with pytest.raises(InvalidArgumentError, match=r"branches\.probe_m"):
        AnalyserConfig(branches=BranchSettings(probe_m=0.0))
    assert AnalyserConfig(wrong_way_evidence_s=0.0, gap_margin_sigmas=0.0).anticipation_s == 2.0
