"""Where a hypothesis' course is compared: at its own place, on the edge it came from
while that edge is the branch's own history, never back across a facing switch."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol.positioning.reach import ReachTable, state_id
from antikol.positioning.scoring import _placed_course_ll
from trackmap.synthetic import SyntheticNetwork

_SIGMA_DEG = 8.0


@pytest.fixture(scope="module")
def board() -> tuple[trackmap.TrackMap, dict[str, int]]:
    # a trunk running east with a facing switch at x = 100: a straight branch on east and
    # a diverging one, whose first edge ("bend", heading about 71 degrees) ends where a
    # track joins it from the south and runs on north-east ("on", 45 degrees)
    drawing = SyntheticNetwork()
    ways = {
        "trunk": drawing.track([(0.0, 0.0), (100.0, 0.0)], oneway="yes"),
        "straight": drawing.track([(100.0, 0.0), (200.0, 0.0)], oneway="yes"),
        "bend": drawing.track([(100.0, 0.0), (120.0, 7.0)], oneway="yes"),
        "on": drawing.track([(120.0, 7.0), (150.0, 37.0)], oneway="yes"),
        "joining": drawing.track([(110.0, -10.0), (120.0, 7.0)], oneway="yes"),
    }
    net = drawing.build()
    edges = {
        name: next(e.edge_id for e in net.edges if way in e.way_ids) for name, way in ways.items()
    }
    return net, edges


def _course_ll(net, edge, offset, lag, course, parent):
    reach = ReachTable.for_map(net, reach_m=300.0)
    p_state, p_offset, p_dist = parent
    return float(
        _placed_course_ll(
            reach.headings.at,
            reach.lengths,
            np.array([edge]),
            np.array([1]),
            np.array([offset]),
            np.array([lag]),
            np.array([course]),
            np.array([_SIGMA_DEG]),
            np.array([True]),
            0.02,
            np.array([-99.0]),
            parent=(np.array([p_state]), np.array([p_offset]), np.array([p_dist])),
            parent_unbranched=reach.unbranched_exit,
        )[0]
    )


def test_a_place_behind_the_next_edge_takes_the_heading_of_the_edge_it_came_from(board):
    net, e = board
    bend_length = net.edge_length(e["bend"])
    # the fix projects 5 m into "on"; the filter puts the tram 8 m behind that, back on
    # the bend, where the course (71 degrees) agrees
    parent = (int(state_id(e["bend"], 1)), 2.0, bend_length - 2.0 + 5.0)
    bend_course = _course_ll(net, e["on"], 5.0, -8.0, 70.7, parent)
    on_course = _course_ll(net, e["on"], 5.0, -8.0, 45.0, parent)
    assert bend_course > on_course
    assert bend_course == pytest.approx(-math.log(_SIGMA_DEG * math.sqrt(2 * math.pi)), abs=0.1)


def test_a_place_behind_a_branch_is_not_looked_up_across_the_facing_switch(board):
    net, e = board
    # the bend's hypothesis puts the tram 1 m before the switch: its course is still
    # compared with the bend (71 degrees), not with the trunk (90), which says nothing
    # of the branch the hypothesis is on
    parent = (int(state_id(e["trunk"], 1)), 95.0, 5.0 + 2.0)
    bend_course = _course_ll(net, e["bend"], 2.0, -3.0, 70.7, parent)
    trunk_course = _course_ll(net, e["bend"], 2.0, -3.0, 90.0, parent)
    assert bend_course > trunk_course


@settings(max_examples=40, deadline=None)
@given(edge=st.integers(0, 10_000), forward=st.booleans())
def test_an_exit_is_unbranched_where_one_state_follows(krakow_map, edge, forward):
    reach = ReachTable.for_map(krakow_map, reach_m=300.0)
    edge %= len(krakow_map.edges)
    direction = 1 if forward else -1
    ahead = krakow_map.successors(edge, direction, respect_direction=False)
    assert bool(reach.unbranched_exit[state_id(edge, direction)]) == (len(ahead) <= 1)


@pytest.fixture(scope="module")
def krakow_map() -> trackmap.TrackMap:
    return trackmap.load_default()


@settings(max_examples=40, deadline=None)
@given(pick=st.integers(0, 10_000), way=st.integers(0, 10), run_m=st.floats(0.0, 120.0))
def test_the_way_in_is_the_one_joining_track_a_run_reaches(krakow_map, pick, way, run_m):
    # into a track that several join before: from a place two edges back, the way in is
    # the joining track that a run of run_m reaches from the end of the place's edge
    # (networkx's shortest paths over the same moves as the reference), and none when
    # several or none do
    import networkx as nx

    reach = ReachTable.for_map(krakow_map, reach_m=300.0)
    joined = np.flatnonzero(reach.ways_in_count > 1)
    to = int(joined[pick % len(joined)])
    graph = krakow_map.traversal_any
    state = {int(state_id(e, int(d))): (e, d) for e, d in graph.nodes()}
    ways = [int(state_id(e, int(d))) for e, d in graph.predecessors(state[to])]
    q = ways[way % len(ways)]
    before = [int(state_id(e, int(d))) for e, d in graph.predecessors(state[q])]
    if not before:
        return
    frm = before[0]

    def gap_m(w: int) -> float:
        # the track from the end of frm to the start of w: the edges between them
        try:
            path = nx.shortest_path(
                graph, state[frm], state[w],
                weight=lambda u, v, _: krakow_map.edge_length(v[0]),
            )  # fmt: skip
        except nx.NetworkXNoPath:
            return math.inf
        return sum(krakow_map.edge_length(e) for e, _ in path[1:-1])

    reached = [w for w in ways if w == frm or gap_m(w) <= run_m]
    got = int(reach.way_in(np.array([frm]), np.array([to]), np.array([run_m]))[0])
    assert got == (reached[0] if len(reached) == 1 else -1)
