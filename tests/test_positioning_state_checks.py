"""What callers hand the positioner is checked before anything changes: a saved state to
restore, a discrete fix, the reports to fuse. Bad input gets an
:class:`~antikol.errors.InvalidArgumentError` naming it, and the positioner goes on as
it was."""

from __future__ import annotations

import copy
import json
import math
from typing import Any

import numpy as np
import pytest

import trackmap
from antikol import Analyser, VehicleReport
from antikol.errors import InvalidArgumentError
from antikol.positioning.matcher import DiscreteFix, Positioner, PositioningConfig
from tests._osm import FRAME, STRAIGHT_LINE, straight_fixture, switch_fixture
from tests._paths import reports_along

#: The switch fixture's track: a trunk (edge 0) and the branch that leaves it (edge 2).
_BRANCH = [(0.0, -200.0), (0.0, 0.0), (1.0, 10.0), (4.0, 20.0), (9.0, 30.0), (80.0, 80.0)]


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    """One edge, 2 km long."""
    return trackmap.build(straight_fixture().write_xml(tmp_path_factory.mktemp("s") / "s.osm"))


@pytest.fixture(scope="module")
def switch(tmp_path_factory):
    """Three edges of 120 to 200 m."""
    return trackmap.build(switch_fixture().write_xml(tmp_path_factory.mktemp("w") / "w.osm"))


def _line(vid: str, t0: float, n: int, start_m: float = 100.0) -> list[VehicleReport]:
    t = np.arange(t0, t0 + n, 1.0)
    return reports_along(vid, STRAIGHT_LINE, start_m=start_m, speed_mps=10.0, t=t, frame=FRAME)


def _driven(net: trackmap.TrackMap, n: int = 10) -> Positioner:
    """A positioner that has followed vehicle ``V`` (10 m/s from 100 m) and ``W``."""
    pos = Positioner(net)
    for r in _line("V", 0.0, n):
        pos.update(r)
    for r in _line("W", 0.0, n, start_m=900.0):
        pos.update(r)
    return pos


def _snapshot(pos: Positioner) -> str:
    """Everything a restore or a fix could change, comparable (NaN-safe: JSON text)."""
    return json.dumps(
        {v: pos.state(v) for v in sorted(pos.vehicles())} | {"stats": dict(pos.stats)},
        sort_keys=True,
        default=str,
    )


# -- restore ----------------------------------------------------------------------------------
def test_a_state_saved_on_another_map_is_refused_and_the_positioner_goes_on(straight, switch):
    on_branch = Positioner(switch)
    t = np.arange(0.0, 12.0, 1.0)
    for r in reports_along("V", _BRANCH, start_m=170.0, speed_mps=4.0, t=t, frame=FRAME):
        on_branch.update(r)
    saved = json.loads(json.dumps(on_branch.state("V")))
    assert max(saved["states"]) >= 2 * len(straight.edges)  # not a state id of the straight map
    pos = _driven(straight)
    before = _snapshot(pos)
    with pytest.raises(InvalidArgumentError, match=r"'V'.*states"):
        pos.restore("V", saved)
    assert _snapshot(pos) == before
    # the positioner goes on: the vehicle as it was, with new reports too
    follow = [pos.update(r) for r in _line("V", 10.0, 3, start_m=200.0)]
    assert [p.status for p in follow] == ["confident"] * 3
    assert follow[-1].offset_m == pytest.approx(220.0, abs=1.0)
    # a vehicle it never had is not left half restored either
    with pytest.raises(InvalidArgumentError):
        pos.restore("X", saved)
    assert pos.position("X") is None and "X" not in pos.vehicles()


def test_an_offset_beyond_its_edge_is_refused(straight, switch):
    # the straight map's state (240 m along its one 2-km edge) restored where edge 0 is
    # 200 m long: the state ids fit, the offsets do not
    saved = json.loads(json.dumps(_driven(straight, n=15).state("V")))
    assert saved["states"] == [0] and saved["slots"]["ho"][0] > switch.edges[0].length_m
    pos = Positioner(switch)
    with pytest.raises(InvalidArgumentError, match=r"'V'.*slots.*ho"):
        pos.restore("V", saved)
    assert pos.vehicles() == []


def _valid_state(net: trackmap.TrackMap) -> dict[str, Any]:
    state = _driven(net).state("V")
    assert state is not None
    return json.loads(json.dumps(state))


def _broken(name: str, state: dict[str, Any]) -> Any:
    """The saved state broken one way (``name``)."""
    s = copy.deepcopy(state)
    edits: dict[str, Any] = {
        "none": None,
        "str": "x",
        "list": [s],
        "empty": {},
        "no_states": {k: v for k, v in s.items() if k != "states"},
        "no_filter": {k: v for k, v in s.items() if k != "filter"},
        "no_last_report": {k: v for k, v in s.items() if k != "last_report"},
        "states_not_list": {**s, "states": 0},
        "states_huge": {**s, "states": [10**9]},
        "states_negative": {**s, "states": [-5]},
        "states_str": {**s, "states": ["x"]},
        "states_bool": {**s, "states": [True]},
        "states_float": {**s, "states": [0.5]},
        "slots_short": {**s, "slots": {k: [] for k in s["slots"]}},
        "slots_not_dict": {**s, "slots": [1.0]},
        "offset_nan": {**s, "slots": {**s["slots"], "ho": [math.nan]}},
        "offset_str": {**s, "slots": {**s["slots"], "ho": ["1"]}},
        "came_from_huge": {**s, "slots": {**s["slots"], "hv": [1e9]}},
        "no_offsets": {**s, "slots": {k: v for k, v in s["slots"].items() if k != "ho"}},
        "vehicle_str": {**s, "vehicle": {**s["vehicle"], "t": "x"}},
        "vehicle_not_dict": {**s, "vehicle": None},
        "vehicle_none": {**s, "vehicle": {**s["vehicle"], "z": None}},
        "speed_unit": {**s, "vehicle": {**s["vehicle"], "uscale": 0.0}},
        "log_p_positive": {**s, "slots": {**s["slots"], "hp": [1e6]}},
        "variance_negative": {**s, "filter": [*s["filter"][:3], -1.0, *s["filter"][4:]]},
        "filter_huge": {**s, "filter": [*s["filter"][:5], 1e50]},
        "count_huge": {**s, "rejected_in_row": 10**400},
        "filter_short": {**s, "filter": [1.0]},
        "filter_inf": {**s, "filter": [math.inf, *s["filter"][1:]]},
        "filter_half": {**s, "filter": [s["filter"][0], None, *s["filter"][2:]]},
        "before_huge": {**s, "before": [[10**9, 0.0, 0.0]]},
        "before_short": {**s, "before": [[0, 1.0]]},
        "rejected_negative": {**s, "rejected_in_row": -1},
        "confident_str": {**s, "confident_in_row": "3"},
        "unmatched_str": {**s, "unmatched": "no"},
        "lost_int": {**s, "lost": 5},
        "last_report_bad": {**s, "last_report": {**s["last_report"], "lat": 999}},
        "last_report_extra": {**s, "last_report": {**s["last_report"], "colour": "red"}},
        "last_report_str": {**s, "last_report": "x"},
        "reported_huge": {**s, "reported": [10**9, 1]},
        "reported_direction": {**s, "reported": [0, 3]},
        "reported_short": {**s, "reported_before": [0]},
        "fixes_missed": {**s, "fixes": {"last_fix_s": None, "missed": -1, "expected": []}},
        "fixes_expected": {
            **s,
            "fixes": {"last_fix_s": None, "missed": 0, "expected": [["B", "x"]]},
        },
        "fixes_previous": {
            **s,
            "fixes": {
                "last_fix_s": None,
                "missed": 0,
                "expected": [],
                "previous": [10**9, 0.0, 1, 0.0],
            },
        },
    }
    return edits[name]


_BROKEN = [
    ("none", "state of 'V'"),
    ("str", "state of 'V'"),
    ("list", "state of 'V'"),
    ("empty", "states"),
    ("no_states", "states"),
    ("no_filter", "filter"),
    ("no_last_report", "last_report"),
    ("states_not_list", "states"),
    ("states_huge", "states"),
    ("states_negative", "states"),
    ("states_str", "states"),
    ("states_bool", "states"),
    ("states_float", "states"),
    ("slots_short", "slots"),
    ("slots_not_dict", "slots"),
    ("offset_nan", "ho"),
    ("offset_str", "ho"),
    ("came_from_huge", "hv"),
    ("no_offsets", "ho"),
    ("vehicle_str", r"vehicle.*\bt\b"),
    ("vehicle_not_dict", "vehicle"),
    ("vehicle_none", r"vehicle\['z'\]"),
    ("speed_unit", "uscale"),
    ("log_p_positive", "hp"),
    ("variance_negative", r"filter\[3\]"),
    ("filter_huge", r"filter\[5\]"),
    ("count_huge", "rejected_in_row"),
    ("filter_short", "filter"),
    ("filter_inf", "filter"),
    ("filter_half", "filter"),
    ("before_huge", "before"),
    ("before_short", "before"),
    ("rejected_negative", "rejected_in_row"),
    ("confident_str", "confident_in_row"),
    ("unmatched_str", "unmatched"),
    ("lost_int", "lost"),
    ("last_report_bad", "last_report"),
    ("last_report_extra", "last_report"),
    ("last_report_str", "last_report"),
    ("reported_huge", "reported"),
    ("reported_direction", "reported"),
    ("reported_short", "reported_before"),
    ("fixes_missed", "missed"),
    ("fixes_expected", "expected"),
    ("fixes_previous", "previous"),
]


@pytest.mark.parametrize(("name", "key"), _BROKEN, ids=[n for n, _ in _BROKEN])
def test_a_broken_state_is_refused_and_changes_nothing(straight, name, key):
    saved = _valid_state(straight)
    pos = _driven(straight)
    before = _snapshot(pos)
    with pytest.raises(InvalidArgumentError, match=key) as caught:
        pos.restore("V", _broken(name, saved))
    assert "'V'" in str(caught.value)  # names the vehicle
    assert _snapshot(pos) == before
    # usable as before: the vehicle goes on where it was
    out = [pos.update(r) for r in _line("V", 10.0, 3, start_m=200.0)]
    assert [p.status for p in out] == ["confident"] * 3
    assert out[-1].offset_m == pytest.approx(220.0, abs=1.0)


def test_restore_refuses_a_vehicle_id_that_is_not_a_str(straight):
    pos = Positioner(straight)
    with pytest.raises(InvalidArgumentError, match="vehicle_id"):
        pos.restore(None, _valid_state(straight))  # type: ignore[arg-type]
    assert pos.vehicles() == []


@pytest.mark.parametrize("via_json", [True, False])
def test_a_valid_state_still_restores_and_goes_on_as_the_original(straight, via_json):
    original = _driven(straight)
    state = original.state("V")
    assert state is not None
    if via_json:
        state = json.loads(json.dumps(state))
    again = Positioner(straight)
    again.restore("V", state)
    assert again.state("V") == original.state("V")
    for r in _line("V", 10.0, 3, start_m=200.0):
        assert again.update(r) == original.update(r)


def test_a_state_saved_before_newer_keys_still_restores(straight):
    # a state of an older version: no hypotheses before the last fix, no gated count, no
    # showing flag (restore_row's own defaults stand in for them)
    state = _valid_state(straight)
    for key in ("before", "gated_in_row"):
        del state[key]
    del state["vehicle"]["sp"]
    again = Positioner(straight)
    again.restore("V", state)
    assert again.update(_line("V", 10.0, 1, start_m=200.0)[0]).status == "confident"


def test_a_state_of_a_vehicle_not_yet_matched_restores(straight):
    pos = Positioner(straight)
    lon, lat = FRAME.to_lonlat(5000.0, 5000.0)  # far off the track: unmatched
    pos.update(VehicleReport("V", 0.0, lat, lon, 0.0, 0.0))
    state = json.loads(json.dumps(pos.state("V")))
    assert state["states"] == [] and state["filter"][0] is None
    again = Positioner(straight)
    again.restore("V", state)
    assert again.state("V") == pos.state("V")


# -- discrete fixes ---------------------------------------------------------------------------
_REFUSED_TIMES = [(5.0, "fix_late"), (-1000.0, "fix_late"), (-1e20, "fix_late"),
                  (9.0 + 31.0, "fix_ahead"), (1e20, "fix_ahead")]  # fmt: skip


@pytest.mark.parametrize(("t", "counted"), _REFUSED_TIMES)
def test_a_fix_dated_before_the_latest_position_or_long_after_is_refused(straight, t, counted):
    # the latest position is the report at 9 s; dead reckoning goes on for 30 s
    pos = _driven(straight)
    at = pos.position("V")
    before = json.dumps(pos.state("V"), sort_keys=True)
    after = pos.fix("V", DiscreteFix(t, 0, 150.0, "B1"))
    assert pos.stats[counted] == 1 and pos.stats["fix_rejected"] == 0
    assert after == at and after is not None and after.status == "confident"
    assert json.dumps(pos.state("V"), sort_keys=True) == before
    nxt = pos.update(_line("V", 10.0, 1, start_m=200.0)[0])
    assert nxt.status == "confident" and nxt.sigma_m is not None and nxt.sigma_m < 5.0
    # and a fix in time is weighed as ever (a refused one locks nothing out)
    p = pos.fix("V", DiscreteFix(10.0, 0, 200.5, "B2"))
    assert pos.stats["fix_accepted"] == 1 and p is not None
    assert p.offset_m == pytest.approx(200.5, abs=0.1)


def test_a_fix_at_the_latest_position_or_later_is_still_weighed(straight):
    pos = _driven(straight)
    p = pos.fix("V", DiscreteFix(9.0, 0, 190.5, "B1"))
    assert pos.stats["fix_accepted"] == 1 and p is not None and p.status == "confident"
    p = pos.fix("V", DiscreteFix(9.5, 0, 195.5, "B2"))
    assert pos.stats["fix_accepted"] == 2 and p is not None
    assert p.offset_m == pytest.approx(195.5, abs=0.1)
    p = pos.fix("V", DiscreteFix(9.5 + 30.0, 0, 495.5, "B3"))  # as far ahead as allowed
    assert pos.stats["fix_accepted"] + pos.stats["fix_rejected"] == 3


_BAD_FIXES = [
    (None, "fix"),
    ("x", "fix"),
    ((9.0, 0, 150.0), "fix"),
    (DiscreteFix(math.nan, 0, 150.0), "fix.t"),
    (DiscreteFix(math.inf, 0, 150.0), "fix.t"),
    (DiscreteFix("9", 0, 150.0), "fix.t"),  # type: ignore[arg-type]
    (DiscreteFix(9.0, 1, 150.0), "fix.edge_id"),
    (DiscreteFix(9.0, -1, 150.0), "fix.edge_id"),
    (DiscreteFix(9.0, 10**9, 150.0), "fix.edge_id"),
    (DiscreteFix(9.0, True, 150.0), "fix.edge_id"),
    (DiscreteFix(9.0, 0.0, 150.0), "fix.edge_id"),  # type: ignore[arg-type]
    (DiscreteFix(9.0, 0, -1.0), "fix.offset_m"),
    (DiscreteFix(9.0, 0, 2500.0), "fix.offset_m"),
    (DiscreteFix(9.0, 0, math.nan), "fix.offset_m"),
    (DiscreteFix(9.0, 0, 150.0, 7), "fix.fix_id"),  # type: ignore[arg-type]
]


@pytest.mark.parametrize(("fix", "name"), _BAD_FIXES)
@pytest.mark.parametrize("vid", ["V", "nobody"])
def test_a_fix_with_bad_values_is_refused_and_changes_nothing(straight, fix, name, vid):
    pos = _driven(straight)
    before = _snapshot(pos)
    with pytest.raises(InvalidArgumentError, match=rf"^{name.replace('.', '[.]')} "):
        pos.fix(vid, fix)
    assert _snapshot(pos) == before


def test_the_analyser_goes_on_after_a_late_or_bad_fix(straight):
    an = Analyser(track_map=straight)
    for r in _line("A", 0.0, 10):
        an.update(r)
    with pytest.raises(InvalidArgumentError, match="fix"):
        an.fix("A", None)  # type: ignore[arg-type]
    an.fix("A", DiscreteFix(-1e20, 0, 152.0))
    an.update(_line("A", 10.0, 1, start_m=200.0)[0])
    an.assess("A")  # (it crashed placing a vehicle pinned at t=-1e20)
    pos = an.position("A")
    assert pos is not None and pos.status == "confident"


# -- reports ----------------------------------------------------------------------------------
@pytest.mark.parametrize("report", [None, {}, "x", 5, ("V", 1.0)])
def test_update_refuses_what_is_not_a_report(straight, report):
    pos = _driven(straight)
    before = _snapshot(pos)
    with pytest.raises(InvalidArgumentError, match=r"^report "):
        pos.update(report)
    assert _snapshot(pos) == before


def test_update_many_refuses_what_is_not_a_sequence_of_reports(straight):
    pos = _driven(straight)
    before = _snapshot(pos)
    good = _line("V", 10.0, 1, start_m=200.0)[0]
    with pytest.raises(InvalidArgumentError, match=r"^reports\[0\] "):
        pos.update_many([None])  # type: ignore[list-item]
    with pytest.raises(InvalidArgumentError, match=r"^reports\[1\] "):
        pos.update_many([good, "x"])  # type: ignore[list-item]
    for bad in (None, 5):
        with pytest.raises(InvalidArgumentError, match=r"^reports "):
            pos.update_many(bad)  # type: ignore[arg-type]
    assert _snapshot(pos) == before  # (the good report before the bad one was not taken)
    assert pos.update_many(r for r in [good])[0].status == "confident"  # any iterable


def test_a_state_of_more_hypotheses_than_kept_restores_its_first_ones(switch):
    original = Positioner(switch)
    t = np.arange(0.0, 20.0, 1.0)
    reports = reports_along("V", _BRANCH, start_m=170.0, speed_mps=4.0, t=t, frame=FRAME)
    states = []
    for r in reports:
        original.update(r)
        states.append(json.loads(json.dumps(original.state("V"))))
    state = max(states, key=lambda s: len(s["states"]))
    assert len(state["states"]) >= 2
    few = Positioner(switch, PositioningConfig(max_hypotheses=1))
    few.restore("V", state)
    assert [(h.edge_id, h.direction) for h in few.hypotheses("V")] == [
        (h["edge_id"], h["direction"]) for h in state["hypotheses"][:1]
    ]
