"""Positions estimated without a fix (``fix_quality`` 6) weigh the branches (issue 12).

An HSL-style feed's ``loc`` ``ODO``/``DR`` and NMEA's dead-reckoning mode say the position
is the vehicle's own estimate, not a measurement: it must neither be gated and learnt like
a fix (an extrapolation off the track in a curve restarted the vehicle) nor be thrown away
(it knows which branch the route took where the fixes stop at a switch).
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import VehicleReport
from antikol.ingest.hfp import read_hfp
from antikol.ingest.nmea import NmeaReader
from antikol.positioning import PositioningConfig
from antikol.positioning.estimates import (
    NOT_MEASURED,
    estimate_log_likelihood,
    weigh_estimate,
)
from antikol.positioning.fleet import FleetState
from antikol.positioning.matcher import Positioner
from antikol.positioning.reach import state_id
from antikol.report import ESTIMATED_FIX_QUALITY
from tests._osm import FRAME, OsmBuilder
from tests._paths import reports_along

SPEED_MPS = 8.0
SWITCH_Y = 300.0
TRUNK = [(0.0, 0.0), (0.0, SWITCH_Y)]
STRAIGHT = [(0.0, SWITCH_Y), (0.0, 1200.0)]
# the diverging branch turns away gently: 3 m apart 60 m past the switch, 40 m at 200 m
TURNOUT = [(0.0, SWITCH_Y), (3.0, 360.0), (12.0, 420.0), (40.0, 500.0), (120.0, 620.0)]


@pytest.fixture(scope="module")
def junction(tmp_path_factory):
    """A one-way trunk dividing at a switch into a straight and a diverging surface track."""
    b = OsmBuilder()
    switch = b.node(*TRUNK[1])
    b.line([TRUNK[0], switch], oneway="yes")
    b.line([switch, *STRAIGHT[1:]], oneway="yes")
    b.line([switch, *TURNOUT[1:]], oneway="yes")
    net = trackmap.build(b.write_xml(tmp_path_factory.mktemp("junction") / "junction.osm"))
    (straight,) = [e.edge_id for e in net.edges if e.length_m > 850.0]
    (turnout,) = [
        e.edge_id for e in net.edges if 300.0 < e.length_m < 400.0 and e.edge_id != straight
    ]
    return net, straight, turnout


def _drive(path, seconds, *, blind_after_y, estimate=None):
    """A tram from y = 100 m along ``path`` at 8 m/s with its odometer; past
    ``blind_after_y`` its reports have no fix: ``estimate(true_x, true_y, last_fix, t)``
    gives the estimated position (``fix_quality`` 6), else the last fix is repeated
    (``fix_quality`` 0)."""
    t = np.arange(0.0, float(seconds), 1.0)
    reports = reports_along("T", path, start_m=100.0, speed_mps=SPEED_MPS, t=t, frame=FRAME)
    out: list[VehicleReport] = []
    last_fix = None
    for r in reports:
        x, y = (float(v) for v in FRAME.to_local(r.lon, r.lat))
        odometer = 1000.0 + SPEED_MPS * r.t
        if y <= blind_after_y:
            last_fix = (x, y, r.t, r.course_deg)
            out.append(dataclasses.replace(r, odometer_m=odometer, fix_quality=1))
            continue
        if estimate is None:
            place, quality = {"lat": out[-1].lat, "lon": out[-1].lon}, 0
        else:
            lon, lat = FRAME.to_lonlat(*estimate(x, y, last_fix, r.t))
            place, quality = {"lat": float(lat), "lon": float(lon)}, ESTIMATED_FIX_QUALITY
        out.append(dataclasses.replace(r, odometer_m=odometer, fix_quality=quality, **place))
    return out


def _along_route(x, y, last_fix, t):
    return x, y


def _ambiguous_or_tossed(position) -> bool:
    """``ambiguous``, or a coin toss past a switch not shown on a track (``lost`` without
    an edge, below ``toss_shown_probability``)."""
    if position.unplaced:
        return position.probability < PositioningConfig().toss_shown_probability
    return position.status == "ambiguous"


def _mass(position, edge_id):
    return sum(h.probability for h in position.hypotheses if h.edge_id == edge_id)


@pytest.mark.parametrize("sigma_m", [10.0, 0.0], ids=["weighed", "ignored"])
def test_estimates_along_the_route_decide_the_branch_the_fixes_did_not(junction, sigma_m):
    net, _, turnout = junction
    path = [*TRUNK, *TURNOUT[1:]]
    # no fix from 4 m before the switch on: only the estimates know the tram turned
    reports = _drive(path, 45, blind_after_y=SWITCH_Y - 4.0, estimate=_along_route)
    pos = Positioner(net, PositioningConfig(estimated_fix_sigma_m=sigma_m))
    out = [pos.update(r) for r in reports]
    blind_from = next(r.t for r in reports if r.fix_quality == ESTIMATED_FIX_QUALITY)
    late = [p for p in out if p.t >= blind_from + 17.0]  # 136 m on, 18 m off the straight
    assert len(late) >= 3
    if sigma_m == 0.0:  # the old coin toss: both branches keep about half
        assert all(0.3 < _mass(p, turnout) < 0.7 for p in late)
        return
    # the branches part slowly (3 m 60 m past the switch): the reported place stays on the
    # switch's first 40 m, then a coin toss, until an estimate takes the turnout past the
    # switch probability (the latest estimate counts, not their sum: their errors are one
    # drift); they never make it sure (halfway to the confidence, 0.775)
    config = PositioningConfig()
    most = 0.5 * (config.switch_probability + config.confidence)
    assert all(p.edge_id == turnout for p in late)
    # (and between the hold and that estimate, a coin toss is not shown on a track)
    assert all(_ambiguous_or_tossed(p) for p in out if p.t >= blind_from)
    assert any(p.unplaced for p in out if p.t >= blind_from)
    assert all(math.isclose(_mass(p, turnout), most, abs_tol=1e-6) for p in late)
    assert pos.stats["estimated_position"] == sum(
        r.fix_quality == ESTIMATED_FIX_QUALITY for r in reports
    )
    # estimates are no fixes: nothing refused, nothing restarted
    assert not any(k.startswith("rejected_") or k == "reset_after_rejections" for k in pos.stats)


def test_an_extrapolation_off_the_track_is_no_fix(junction):
    """A receiver that extrapolates its last velocity runs straight on where the tram
    turns: taken as fixes, its positions were refused as jumps and outliers; as estimates
    they vote for the wrong branch, but never make it sure (``ambiguous``), and the first
    fixes back find the tram on its branch."""
    net, straight, turnout = junction
    path = [*TRUNK, *TURNOUT[1:]]

    def straight_on(x, y, last_fix, t):
        lx, ly, lt, course = last_fix
        run = SPEED_MPS * (t - lt)
        return lx + run * math.sin(math.radians(course)), ly + run * math.cos(math.radians(course))

    reports = _drive(path, 66, blind_after_y=SWITCH_Y - 4.0, estimate=straight_on)
    # fixes come back 35 s on, 200 m along the turnout (40 m off the straight)
    blind_from = next(r.t for r in reports if r.fix_quality == ESTIMATED_FIX_QUALITY)
    back_from = blind_from + 35.0
    truth = _drive(path, 66, blind_after_y=math.inf)
    reports = [r if r.t < back_from else truth[int(r.t)] for r in reports]
    pos = Positioner(net)
    out = [pos.update(r) for r in reports]
    assert not any(k.startswith("rejected_") or k == "reset_after_rejections" for k in pos.stats)
    assert pos.stats["estimated_position"] > 30
    blind = [p for p in out if blind_from <= p.t < back_from]
    assert blind[-1].edge_id == straight  # the extrapolation's vote ...
    assert all(_ambiguous_or_tossed(p) for p in blind)  # ... never sure
    back = [p for p in out if p.t >= back_from + 2.0]
    assert back and all(p.edge_id == turnout and p.status == "confident" for p in back)
    # the same estimates taken as fixes (the behaviour before): refused, then a restart
    as_fixes = [
        dataclasses.replace(r, fix_quality=1) if r.fix_quality == ESTIMATED_FIX_QUALITY else r
        for r in reports
    ]
    old = Positioner(net)
    for r in as_fixes:
        old.update(r)
    assert any(k.startswith("rejected_") or k == "outlier_fix" for k in old.stats)


def test_a_far_estimate_changes_nothing(junction):
    """An estimate far from every hypothesis (a stale or garbled position) leaves the
    odds as they are."""
    net = junction[0]
    path = [*TRUNK, *TURNOUT[1:]]
    runs = []
    for far in (False, True):

        def estimate(x, y, last_fix, t, far=far):
            return (x + 5000.0, y) if far else last_fix[:2]

        reports = _drive(path, 40, blind_after_y=SWITCH_Y - 4.0, estimate=estimate)
        pos = Positioner(net)
        runs.append([(p.edge_id, round(p.probability, 9)) for p in map(pos.update, reports)])
    ignored = _drive(path, 40, blind_after_y=SWITCH_Y - 4.0)
    pos = Positioner(net)
    plain = [(p.edge_id, round(p.probability, 9)) for p in map(pos.update, ignored)]
    assert runs[1] == plain  # 5 km off: exactly no evidence
    # the last fix repeated (behind the switch, as far from either branch): no side taken
    assert [e for e, _ in runs[0]] == [e for e, _ in plain]


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.floats(0.0, 1e4), min_size=1, max_size=8),
    st.floats(0.5, 50.0),
    st.floats(0.001, 1.0),
)
def test_estimate_likelihood_is_bounded_and_falls_with_distance(distances, sigma, w):
    d = np.sort(np.array(distances))
    ll = estimate_log_likelihood(d, sigma_m=sigma, outlier_weight=w)
    assert np.all(ll <= 1e-12)
    assert np.all(ll >= math.log(w) - 1e-9)
    assert np.all(np.diff(ll) <= 1e-12)


@settings(max_examples=25, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from([0, 1, ESTIMATED_FIX_QUALITY]),
            st.floats(-200.0, 200.0),  # the estimate's offset east of the truth, m
            st.floats(-200.0, 200.0),  # and north
            st.floats(0.0, 12.0),  # speed, m/s
        ),
        min_size=5,
        max_size=40,
    )
)
def test_any_mix_of_fixes_and_estimates_keeps_a_sound_state(junction, steps):
    """Whatever the estimates say, and however they mix with fixes and outages, the
    positioner keeps probabilities that sum to one, reports a place on the map, and no
    estimate is ever refused like a fix or makes a place confident on its own."""
    net = junction[0]
    path = [*TRUNK, *TURNOUT[1:]]
    truth = _drive(path, len(steps), blind_after_y=math.inf)
    pos = Positioner(net)
    sure_from_fix = False
    for r, (quality, dx, dy, speed) in zip(truth, steps, strict=True):
        if quality == 1:
            report = dataclasses.replace(r, speed_mps=speed)
        else:
            x, y = (float(v) for v in FRAME.to_local(r.lon, r.lat))
            lon, lat = FRAME.to_lonlat(x + dx, y + dy)
            report = dataclasses.replace(
                r, lat=float(lat), lon=float(lon), speed_mps=speed, fix_quality=quality
            )
        p = pos.update(report)
        if p is None or p.edge_id is None:  # (no fix yet, or lost: no place to check)
            assert p is None or p.status in ("unmatched", "lost")
            continue
        assert p.edge_id in range(len(net.edges))
        total = sum(h.probability for h in p.hypotheses)
        assert math.isclose(total, 1.0, abs_tol=1e-3)  # (the listed ones: the least are cut)
        if quality == 1:
            sure_from_fix = p.probability >= PositioningConfig().confidence
        elif quality == ESTIMATED_FIX_QUALITY and not sure_from_fix and len(p.hypotheses) > 1:
            assert p.status != "confident"
    assert pos.stats["estimated_position"] <= sum(q == ESTIMATED_FIX_QUALITY for q, *_ in steps)


def _fleet(probabilities):
    fleet = FleetState(k=4)
    fleet.grow(1)
    for slot, p in enumerate(probabilities):
        fleet.hs[0, slot] = state_id(slot, 1)
        fleet.ho[0, slot] = 10.0
        fleet.hp[0, slot] = math.log(p)
    return fleet


def test_weigh_estimate_moves_the_lineage_only_past_the_switch_probability():
    fleet = _fleet([0.5, 0.5])
    kw = {"sigma_m": 10.0, "outlier_weight": 0.02, "switch_probability": 0.75,
          "most_probability": 0.9, "floor": 0.001}  # fmt: skip
    # an estimate 12 m from slot 0 and on slot 1: 0.33 / 0.67, the lineage stays
    assert not weigh_estimate(fleet, 0, np.array([12.0, 0.0]), **kw)
    assert fleet.hs[0, 0] == state_id(0, 1)
    assert math.isclose(np.exp(fleet.hp[0, 1]), 0.67, abs_tol=0.01)
    # the next one replaces it: the same estimate again changes nothing
    assert not weigh_estimate(fleet, 0, np.array([12.0, 0.0]), **kw)
    assert math.isclose(np.exp(fleet.hp[0, 1]), 0.67, abs_tol=0.01)
    # one 16 m from slot 0 takes slot 1 past 0.75: it leads
    assert weigh_estimate(fleet, 0, np.array([16.0, 0.0]), **kw)
    assert fleet.hs[0, 0] == state_id(1, 1)
    assert math.isclose(np.exp(fleet.hp[0, :2]).sum(), 1.0)
    # estimates raise no place beyond most_probability ...
    for _ in range(20):
        weigh_estimate(fleet, 0, np.array([0.0, 500.0]), **kw)  # (for the new lead)
    assert math.isclose(np.exp(fleet.hp[0, 0]), 0.9, rel_tol=1e-6)
    # ... unless fixes had put it higher: then they may lower it, by 1/w at most
    fleet = _fleet([0.999, 0.001])
    for _ in range(5):
        assert weigh_estimate(fleet, 0, np.array([500.0, 0.0]), **kw) is False
    assert math.isclose(np.exp(fleet.hp[0, 0]), 0.999 * 0.02 / (0.999 * 0.02 + 0.001), rel_tol=1e-6)
    # however far the estimates, the odds move by 1/w at most, and never below the floor
    fleet = _fleet([0.5, 0.5])
    for _ in range(5):
        weigh_estimate(fleet, 0, np.array([0.0, 500.0]), **{**kw, "most_probability": 1.0})
    assert math.isclose(np.exp(fleet.hp[0, 1]), 0.02 / 1.02, rel_tol=1e-6)
    floored = {**kw, "most_probability": 1.0, "outlier_weight": 1e-6}
    weigh_estimate(fleet, 0, np.array([0.0, 500.0]), **floored)
    assert math.isclose(np.exp(fleet.hp[0, 1]), 0.001, rel_tol=1e-9)


def test_estimated_fix_sigma_is_checked():
    with pytest.raises(ValueError, match="estimated_fix_sigma_m"):
        PositioningConfig(estimated_fix_sigma_m=-1.0)


def test_hfp_location_sources(tmp_path):
    def message(t, loc, lat):
        vp = {"oper": 40, "veh": 7, "tst": f"2023-12-14T08:00:{t:02d}Z", "lat": lat,
              "long": 19.94, "spd": 5.0, "hdg": 0, "odo": 100 + 5 * t, "loc": loc}  # fmt: skip
        return json.dumps({"VP": vp})

    lines = [
        message(0, "GPS", 50.06),
        message(1, "ODO", 50.06005),
        message(2, "DR", 50.0601),
        message(3, "MAN", 50.0602),
        message(4, "N/A", None),
    ]
    path = tmp_path / "hfp.jsonl"
    path.write_text("\n".join(lines) + "\n")
    log = read_hfp(path)
    assert [r.fix_quality for r in log.reports] == [1, 6, 6, 0, 0]
    # an estimate carries its own position; without a fix the last known one is kept
    assert [r.lat for r in log.reports] == [50.06, 50.06005, 50.0601, 50.0602, 50.0602]
    assert all(r.fix_quality in NOT_MEASURED for r in log.reports[1:])


def _nmea(body: str) -> str:
    checksum = 0
    for ch in body:
        checksum ^= ord(ch)
    return f"${body}*{checksum:02X}\r\n"


@pytest.mark.parametrize(
    ("mode", "gga", "quality"),
    [("E", None, 6), ("A", None, None), ("E", 1, 1), ("A", 6, 6)],
)
def test_nmea_dead_reckoning_mode(mode, gga, quality):
    lines = []
    if gga is not None:
        lines.append(
            _nmea(f"GPGGA,080001.00,5003.6000,N,01956.4000,E,{gga},08,1.0,210.0,M,40.0,M,,")
        )
    lines.append(_nmea(f"GPRMC,080001.00,A,5003.6000,N,01956.4000,E,10.0,90.0,141223,,,{mode}"))
    reader = NmeaReader("T")
    reports = [r for line in lines for r in reader.feed_line(line)] + reader.flush()
    assert [r.fix_quality for r in reports] == [quality]
