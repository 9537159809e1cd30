"""Tracks side by side that run the same way and meet again (issue 12).

Two platform tracks of a terminus, or the two tracks of a passing loop, lie a few metres
apart, run the same way and meet again a short way on. A jump of the GPS bias across them
moves the evidence from one to the other; the reported position follows its lineage on
its own track until the two meet rather than jump across, so that successive positions
stay connected by the track. The branches of an ordinary junction, which part for good,
and the two directions of a double track are no such pair.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol.evaluation.consistency import disconnected_windows, match_reports
from antikol.positioning import PositioningConfig
from antikol.positioning.reach import ReachTable, state_id
from antikol.positioning.siblings import SameWaySiblings
from tests._osm import FRAME, OsmBuilder
from tests._paths import reports_along
from tests._recorded import assert_connected, replay_recorded

SPEED_MPS = 5.0
#: The bubble: a straight platform track and one bowed 4 m to the east, from the switch
#: at y = 300 m to the join at y = 420 m.
STRAIGHT = [(0.0, 300.0), (0.0, 420.0)]
BOWED = [(0.0, 300.0), (4.0, 312.0), (4.0, 408.0), (0.0, 420.0)]


@pytest.fixture(scope="module")
def bubble(tmp_path_factory):
    """A one-way line through a bubble of two platform tracks; beside it, a junction whose
    branch parts for good, and a track of the other direction 3.5 m west."""
    b = OsmBuilder()
    split, join = b.node(*STRAIGHT[0]), b.node(*STRAIGHT[1])
    b.line([(0.0, 0.0), split], oneway="yes")
    b.line([split, join], oneway="yes")
    b.line([split, *BOWED[1:-1], join], oneway="yes")
    b.line([join, (0.0, 900.0)], oneway="yes")
    b.line([(-3.5, 900.0), (-3.5, 0.0)], oneway="yes")  # the other direction
    fork = b.node(200.0, 0.0)
    b.line([(200.0, -300.0), fork], oneway="yes")
    b.line([fork, (200.0, 600.0)], oneway="yes")
    b.line([fork, (204.0, 15.0), (260.0, 80.0), (600.0, 300.0)], oneway="yes")
    net = trackmap.build(b.write_xml(tmp_path_factory.mktemp("bubble") / "bubble.osm"))
    return net


def _nearest(net, x: float, y: float):
    """The track nearest a point of the drawing (metres)."""
    lon, lat = FRAME.to_lonlat(x, y)
    (cand, *_) = sorted(net.candidates(lon, lat, radius_m=1.0), key=lambda c: c.distance_m)
    return cand


def _edge_at(net, x: float, y: float) -> int:
    return _nearest(net, x, y).edge_id


def _state_at(net, x: float, y: float) -> tuple[int, float]:
    """The permitted track state through a point, and its offset there."""
    cand = _nearest(net, x, y)
    edge = net.edges[cand.edge_id]
    direction = 1 if edge.allows(1) else -1
    return int(state_id(cand.edge_id, direction)), float(cand.offset_m)


def _siblings(net):
    return SameWaySiblings(net, ReachTable.for_map(net, reach_m=400.0), meet_within_m=200.0)


def test_platform_tracks_are_siblings_and_parting_branches_are_not(bubble):
    net = bubble
    siblings = _siblings(net)
    straight, s_off = _state_at(net, 0.0, 360.0)
    bowed, b_off = _state_at(net, 4.0, 360.0)
    assert siblings.hold([bowed], [b_off], [straight], [s_off]).tolist() == [True]
    assert siblings.hold([straight], [s_off], [bowed], [b_off]).tolist() == [True]
    # only once the vehicle was reported on the lineage's track, not held at the switch
    on_straight, at_switch = (straight >> 1, 1), (_edge_at(net, 0.0, 200.0), 1)
    for reported, held in ((on_straight, True), (at_switch, False), (None, False)):
        got = siblings.hold(
            [bowed], [b_off], [straight], [s_off], reported=[reported], lineage_before=[straight]
        )
        assert got.tolist() == [held]
    # the two branches of a junction lie as close a few metres past the switch, but part
    branch, br_off = _state_at(net, 204.0, 15.0)
    main, m_off = _state_at(net, 200.0, 15.0)
    assert siblings.hold([branch], [br_off], [main], [m_off]).tolist() == [False]
    # the other direction's track is beside, but runs the other way
    other = int(state_id(_edge_at(net, -3.5, 360.0), -1))
    other_off = net.edges[other >> 1].length_m - 540.0
    assert siblings.hold([other], [other_off], [straight], [s_off]).tolist() == [False]
    # the same track ahead is no jump; a hold distance of 0 turns it off
    ahead, a_off = _state_at(net, 0.0, 500.0)
    assert siblings.hold([ahead], [a_off], [straight], [s_off]).tolist() == [False]
    off = SameWaySiblings(net, ReachTable.for_map(net, reach_m=400.0), meet_within_m=0.0)
    assert off.hold([bowed], [b_off], [straight], [s_off]).tolist() == [False]


@settings(max_examples=60, deadline=None)
@given(y_a=st.floats(302.0, 418.0), y_b=st.floats(302.0, 418.0))
def test_the_sibling_relation_is_symmetric_and_local(bubble, y_a, y_b):
    net = bubble
    siblings = _siblings(net)
    a, a_off = _state_at(net, 0.0, y_a)
    b, b_off = _state_at(net, 4.0 if 312.0 <= y_b <= 408.0 else 0.0, y_b)
    one = siblings.hold([a], [a_off], [b], [b_off])
    other = siblings.hold([b], [b_off], [a], [a_off])
    assert one.tolist() == other.tolist()
    if a == b:
        assert not one[0]  # one track: a move, not a jump
    elif abs(y_a - y_b) > 10.0:
        assert not one[0]  # not side by side


def _from_the_platform(*, bias_m: float, bias_until_y: float) -> list:
    """A tram that starts its service standing 20 s at the straight platform track
    (y = 330 m), then leaves north at 5 m/s; its fixes carry a bias of ``bias_m`` to the
    east, towards the bowed track, until it passes ``bias_until_y`` (the satellite geometry
    changes), and none after."""
    line = [(0.0, 0.0), *STRAIGHT, (0.0, 900.0)]
    standing = reports_along(
        "T", line, start_m=330.0, speed_mps=0.0, t=np.arange(0.0, 20.0), frame=FRAME
    )
    leaving = reports_along(
        "T", line, start_m=330.0, speed_mps=SPEED_MPS, t=np.arange(20.0, 140.0), frame=FRAME
    )
    rng = np.random.default_rng(7)
    out = []
    for r in [*standing, *leaving]:
        x, y = (float(v) for v in FRAME.to_local(r.lon, r.lat))
        x += (bias_m if y < bias_until_y else 0.0) + rng.normal(0.0, 0.5)
        y += rng.normal(0.0, 0.5)
        lon, lat = FRAME.to_lonlat(x, y)
        out.append(dataclasses.replace(r, lon=float(lon), lat=float(lat)))
    return out


@pytest.mark.parametrize("hold_m", [200.0, 0.0], ids=["held", "off"])
def test_a_bias_that_changes_on_a_platform_track_does_not_move_the_tram_across(bubble, hold_m):
    # the tram starts on the bowed track (the bias puts it there), and the evidence moves
    # to the straight one once the bias is gone
    net = bubble
    reports = _from_the_platform(bias_m=3.0, bias_until_y=350.0)
    matched = match_reports(net, reports, config=PositioningConfig(same_way_hold_m=hold_m))
    straight, bowed = _edge_at(net, 0.0, 360.0), _edge_at(net, 4.0, 360.0)
    on = [m.edge_id for m in matched if m.matched]
    assert bowed in on
    across = straight in on[on.index(bowed) :]
    _, broken = disconnected_windows(net, matched)
    if hold_m:
        # held on its track to the join, however far the evidence moved
        assert not across and broken == 0
        after = [m for m in matched if m.t > 60.0]
        assert all(m.matched and m.edge_id not in (straight, bowed) for m in after)
        assert all(m.position.status == "confident" for m in after)
    else:
        assert across and broken >= 1  # jumped across


@pytest.fixture(scope="module")
def long_pair(tmp_path_factory):
    """Two one-way tracks 5 m apart for 800 m (a switch at y = 0, a join at y = 820 m),
    then one track on north."""
    b = OsmBuilder()
    split, join = b.node(0.0, 0.0), b.node(0.0, 820.0)
    b.line([(0.0, -300.0), split], oneway="yes")
    b.line([split, (0.0, 400.0), join], oneway="yes")
    b.line([split, (5.0, 10.0), (5.0, 810.0), join], oneway="yes")
    b.line([join, (0.0, 1200.0)], oneway="yes")
    return trackmap.build(b.write_xml(tmp_path_factory.mktemp("long") / "long.osm"))


@pytest.mark.parametrize(("y", "held"), [(780.0, True), (500.0, False), (100.0, False)])
def test_long_parallel_tracks_are_held_only_near_where_they_meet(long_pair, y, held):
    # what counts is how far ahead of the two places the tracks meet, not of their starts
    # (800 m back): 40 m before the join a jump across buys at most 40 m on the right one
    net = long_pair
    siblings = SameWaySiblings(net, ReachTable.for_map(net, reach_m=400.0), meet_within_m=50.0)
    west, w_off = _state_at(net, 0.0, y)
    east, e_off = _state_at(net, 5.0, y)
    assert siblings.hold([east], [e_off], [west], [w_off]).tolist() == [held]
    assert siblings.hold([west], [w_off], [east], [e_off]).tolist() == [held]


def test_by_default_the_bias_swinging_before_two_tracks_meet_moves_no_tram_across(long_pair):
    # a tram starts between the two tracks (its fixes 2.5 m east of the west one, as near
    # one as the other) and is shown on one; 60 m before the join its fixes swing another
    # 2.5 m east and the evidence moves to the other one. The default hold keeps it on its
    # track to the join, with no window that no permitted route connects; without the hold
    # it jumps across
    net = long_pair
    clean = reports_along(
        "T", [(0.0, -300.0), (0.0, 1200.0)], start_m=940.0, speed_mps=SPEED_MPS,
        t=np.arange(0.0, 80.0), frame=FRAME,
    )  # fmt: skip
    rng = np.random.default_rng(1)
    reports = []
    for r in clean:
        x, y = (float(v) for v in FRAME.to_local(r.lon, r.lat))
        x += (2.5 if y < 760.0 else 5.0 if y < 820.0 else 0.0) + rng.normal(0.0, 0.4)
        lon, lat = FRAME.to_lonlat(x, y + rng.normal(0.0, 0.4))
        reports.append(dataclasses.replace(r, lon=float(lon), lat=float(lat)))
    pair = {_edge_at(net, 0.0, 600.0), _edge_at(net, 5.0, 600.0)}
    for config, jumps in (
        (PositioningConfig(), False),
        (PositioningConfig(same_way_hold_m=0), True),
    ):
        matched = match_reports(net, reports, config=config)
        on_pair = [m.edge_id for m in matched if m.matched and m.edge_id in pair]
        _, broken = disconnected_windows(net, matched)
        assert on_pair
        assert (len(set(on_pair)) == 2) == jumps
        assert (broken >= 1) == jumps


_LAGGING = "a_lagging_position_beside_a_same_way_track.json"
# in the embedded Kraków map: two one-way tracks 4-5 m apart, 348 then 349 and 107 then 27,
# from a switch to where they meet again (the start of 742)
_LINEAGE_FIRST, _LINEAGE_SECOND, _OTHER_FIRST, _OTHER_SECOND, _MET = 348, 349, 107, 27, 742


def test_a_reported_position_an_edge_behind_its_lineage_still_holds_it():
    # the reported position is smoothed along the track and enters a short edge a fix or
    # two after its lineage's hypothesis: reported on 348 with the lineage on 349, the
    # vehicle was reported on its lineage, and a jump to 27 (which 348 does not lead to)
    # breaks the chain as much as one from 349 does
    net = trackmap.load_default()
    siblings = SameWaySiblings(net, ReachTable.for_map(net, reach_m=400.0), meet_within_m=50.0)
    lineage, best = int(state_id(_LINEAGE_SECOND, 1)), int(state_id(_OTHER_SECOND, 1))
    lineage_off, best_off = 5.0, 5.0

    def held(reported):
        got = siblings.hold(
            [best], [best_off], [lineage], [lineage_off],
            reported=[reported], lineage_before=[lineage],
        )  # fmt: skip
        return bool(got[0])

    assert held((_LINEAGE_SECOND, 1))
    assert held((_LINEAGE_FIRST, 1))  # an edge behind: the position lags its lineage
    assert not held((_OTHER_FIRST, 1))  # reported on the other track: moves on at no break
    assert not held((_MET, 1))  # not behind the lineage at all
    assert not held(None)


def test_a_lagging_reported_position_is_not_moved_across_before_the_tracks_meet():
    # a harsher street receiver (6 m of lateral bias in canyons) read back from an HFP
    # log: 40/8 was reported on 348 while the evidence moved to 107 beside it, and held
    # there, the two meeting 50 m on. At t = 714 s its lineage had entered 349 while its
    # reported position, 9 m before the end of 348, had not: it was no longer counted as
    # reported on its lineage, and jumped to 27, which no move from 348 reaches
    net = trackmap.load_default()
    out = replay_recorded(net, _LAGGING, "40/8")
    late = [p for p in out if p.matched and p.t >= 705.0]
    assert_connected(net, late)
    assert {p.edge_id for p in late} >= {_LINEAGE_FIRST, _MET}
    assert not any(p.edge_id in (_OTHER_FIRST, _OTHER_SECOND) for p in late)
