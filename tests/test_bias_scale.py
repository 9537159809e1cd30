"""A receiver whose GPS bias runs several times the prior (issue 12: persistent bias).

The positioning's bias prior is a street receiver's 2.5 m per axis. Under a receiver whose
multipath ran to 10 m, a hypothesis on a neighbouring track that explained the fixes with
a small bias won, *confident*: each vehicle's prior now grows with the bias across the
track that its hypotheses learn (:mod:`antikol.positioning.biasscale`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import VehicleReport
from antikol.errors import InvalidArgumentError
from antikol.positioning import Positioner, PositioningConfig
from antikol.positioning.biasscale import LEARN_S, bias_sigma_of, learn_bias_sigma
from antikol.positioning.fleet import FleetState

_PRIOR_M = 2.5
_POOR_RECEIVER = Path(__file__).parent / "data" / "a_poor_receiver_past_a_switch.json"
_BEYOND_TWICE = Path(__file__).parent / "data" / "a_learnt_bias_beyond_twice_a_learnt_prior.json"


def _fleet(k: int = 2) -> FleetState:
    fleet = FleetState(k=k)
    fleet.grow(1)
    fleet.t[0] = 0.0
    return fleet


def _heading(deg: float):  # a track running ``deg`` from north everywhere
    def at(edge_ids, offsets_m, directions):
        return np.full(len(edge_ids), deg)

    return at


def _hold(fleet: FleetState, across_m: float, along_m: float, heading_deg: float, seconds: int):
    """One hypothesis holding a bias of ``across_m`` across and ``along_m`` along a track
    running ``heading_deg``, known exactly, for ``seconds`` fixes a second apart."""
    h = math.radians(heading_deg)
    fleet.hs[0, 0], fleet.hp[0, 0] = 6, 0.0
    fleet.bx[0, 0] = across_m * math.cos(h) + along_m * math.sin(h)
    fleet.by[0, 0] = -across_m * math.sin(h) + along_m * math.cos(h)
    for t in range(1, seconds + 1):
        learn_bias_sigma(
            fleet,
            np.array([0]),
            np.array([float(t)]),
            _heading(heading_deg),
            prior_sigma_m=_PRIOR_M,
        )
        fleet.t[0] = float(t)


def _sigma(fleet: FleetState, max_factor: float = 4.0) -> float:
    return float(bias_sigma_of(fleet, np.array([0]), _PRIOR_M, max_factor=max_factor)[0])


def test_a_vehicle_with_nothing_learnt_has_the_configured_prior():
    fleet = _fleet()
    assert _sigma(fleet) == _PRIOR_M
    _hold(fleet, 10.0, 0.0, 0.0, 600)
    assert _sigma(fleet) > 2.0 * _PRIOR_M
    fleet.clear(0)  # a forgotten vehicle's row starts again
    assert _sigma(fleet) == _PRIOR_M


@settings(max_examples=60, deadline=None)
@given(
    across=st.floats(0.0, 15.0),
    along=st.floats(-20.0, 20.0),
    heading=st.floats(0.0, 360.0),
)
def test_only_the_bias_across_the_track_is_learnt(across, along, heading):
    # along the track the bias is confounded with a late receiver's lag: it must not grow
    # the prior (learnt from it, the prior grew with the latency)
    with_along, without = _fleet(), _fleet()
    _hold(with_along, across, along, heading, 120)
    _hold(without, across, 0.0, heading, 120)
    assert _sigma(with_along) == pytest.approx(_sigma(without), rel=1e-9, abs=1e-9)
    assert _PRIOR_M <= _sigma(with_along) <= 4.0 * _PRIOR_M


@pytest.mark.parametrize("across", [1.0, 6.0, 9.0, 30.0])
def test_the_prior_settles_at_the_bias_across_within_its_bounds(across):
    fleet = _fleet()
    _hold(fleet, across, 0.0, 37.0, int(10 * LEARN_S))
    assert _sigma(fleet) == pytest.approx(min(max(across, _PRIOR_M), 4.0 * _PRIOR_M), rel=1e-3)
    assert _sigma(fleet, max_factor=1.0) == _PRIOR_M  # the prior kept fixed


def test_the_hypotheses_count_by_their_probability_and_an_unknown_bias_at_its_variance():
    fleet = _fleet()
    fleet.hs[0, :2] = (6, 8)
    fleet.hp[0, :2] = math.log(0.5)
    fleet.bx[0, :2] = (0.0, 10.0)  # across a track running north
    fleet.pxx[0, :2] = (4.0, 0.0)
    for t in range(1, int(10 * LEARN_S) + 1):
        learn_bias_sigma(
            fleet, np.array([0]), np.array([float(t)]), _heading(0.0), prior_sigma_m=2.5
        )
        fleet.t[0] = float(t)
    assert _sigma(fleet) == pytest.approx(math.sqrt(0.5 * 4.0 + 0.5 * 100.0), rel=1e-3)


def test_an_outage_counts_as_one_fix_not_minutes_of_evidence():
    after = {}
    for gap_s in (10.0, 600.0):
        fleet = _fleet()
        fleet.hs[0, 0], fleet.hp[0, 0], fleet.bx[0, 0] = 6, 0.0, 10.0
        learn_bias_sigma(
            fleet, np.array([0]), np.array([gap_s]), _heading(0.0), prior_sigma_m=_PRIOR_M
        )
        after[gap_s] = _sigma(fleet)
    assert after[600.0] == pytest.approx(after[10.0])
    assert _PRIOR_M < after[600.0] < 1.5 * _PRIOR_M


def test_the_factor_must_not_shrink_the_prior():
    with pytest.raises(InvalidArgumentError, match="bias_sigma_max_factor"):
        PositioningConfig(bias_sigma_max_factor=0.5)


def _replay(config: PositioningConfig, recorded: Path = _POOR_RECEIVER, vid: str = "T12") -> list:
    data = json.loads(recorded.read_text())
    pos = Positioner(trackmap.load_default(), config)
    return [
        pos.update(VehicleReport(vid, t, lat, lon, v, c, odometer_m=o, fix_quality=q))
        for t, lat, lon, v, c, o, q in data["reports"]
    ]


def test_a_poor_receiver_is_not_put_confident_on_the_branch_its_bias_points_to():
    # street GPS with a strong multipath bias (the simulator's urban receiver with a
    # canyon bias of 10 m): a tram crawls at 2.6 m/s past the switch where 288 leaves
    # 185, its fixes 10-13 m off its track towards 288, after four minutes of fixes as
    # far off. Under the fixed prior a 13 m bias was a five-sigma event: the tram was
    # reported on 288, confident, for 22 s. With the receiver's own prior it stays on 185
    out = _replay(PositioningConfig())
    assert not [p for p in out if p.edge_id == 288]
    fixed = _replay(PositioningConfig(bias_sigma_max_factor=1.0))
    assert [p for p in fixed if p.edge_id == 288 and p.status == "confident"]


def test_the_search_reaches_a_learnt_bias_beyond_twice_the_stated_prior():
    # a late street receiver with a strong multipath bias: after minutes of fixes 20-28 m
    # off 463 (the prior learnt: 10 m), the hypothesis on 463 had learnt a bias of 22 m,
    # and at t = 854 s a fix landed 27.7 m from 463, 24.4 m from 456 (the other
    # direction's track). The search went beyond its 25 m by the learnt bias less twice
    # the *learnt* prior (2.2 m): 463 was no candidate, its hypothesis died and the tram
    # was reported running wrong way on 456, confident, for 46 s
    out = _replay(PositioningConfig(), _BEYOND_TWICE, "T06")
    on_463 = [p for p in out if 850.0 <= p.t <= 887.0]
    assert {(p.edge_id, p.direction) for p in on_463} == {(463, 1)}
    assert all(p.status == "confident" for p in on_463)
    assert not any(p.wrong_way for p in out)


def test_the_saved_state_keeps_the_learnt_prior():
    out_config = PositioningConfig()
    data = json.loads(_POOR_RECEIVER.read_text())
    net = trackmap.load_default()
    pos = Positioner(net, out_config)
    for t, lat, lon, v, c, o, q in data["reports"][:200]:
        pos.update(VehicleReport("T12", t, lat, lon, v, c, odometer_m=o, fix_quality=q))
    state = json.loads(json.dumps(pos.state("T12")))
    assert state["vehicle"]["bvar"] > 4.0 * _PRIOR_M**2
    again = Positioner(net, out_config)
    again.restore("T12", state)
    assert again.state("T12")["vehicle"]["bvar"] == state["vehicle"]["bvar"]
