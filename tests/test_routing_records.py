"""The routing's fast record constructors and look-up tables agree with what they replace."""

from __future__ import annotations

import dataclasses

from hypothesis import given
from hypothesis import strategies as st

import trackmap
from trackmap import routing
from trackmap.kinds import ConflictKind, Direction, NodeClass, PathEnd
from trackmap.model import ConflictPass, NodePass, Path, PathStep

_floats = st.floats(allow_nan=False, allow_infinity=False)
_ids = st.integers(min_value=0, max_value=10**6)
_steps = st.tuples(_ids, st.sampled_from(list(Direction)), _floats, _floats, _floats, _floats)
_nodes = st.tuples(
    _ids, st.sampled_from(list(NodeClass)), _floats, _ids, _ids,
    st.sampled_from([None, "straight", "left", "right"]),
)  # fmt: skip
_conflicts = st.tuples(_ids, st.sampled_from(list(ConflictKind)), _floats, _ids)


@given(step=_steps, node=_nodes, conflict=_conflicts, zone=st.text(max_size=12))
def test_positional_constructors_build_the_records_their_classes_build(step, node, conflict, zone):
    made = [
        (routing._step(*step), PathStep(*step)),
        (routing._node_pass(*node), NodePass(*node)),
        (routing._conflict_pass(*conflict), ConflictPass(*conflict)),
    ]
    steps, nodes, conflicts = (tuple(m for m, _ in made[k : k + 1]) for k in range(3))
    path_values = (zone, steps, step[5], nodes, conflicts, PathEnd.HORIZON)
    made.append((routing._path(*path_values), Path(*path_values)))
    for fast, slow in made:
        assert type(fast) is type(slow)
        assert fast == slow and hash(fast) == hash(slow)
        assert dataclasses.astuple(fast) == dataclasses.astuple(slow)
        # still frozen
        field = dataclasses.fields(fast)[0].name
        try:
            setattr(fast, field, None)
        except dataclasses.FrozenInstanceError:
            pass
        else:  # pragma: no cover - the assertion below reports it
            raise AssertionError(f"{type(fast).__name__} built by position is not frozen")


def test_a_positional_constructor_wants_every_field():
    try:
        routing._step(1, Direction.FORWARD, 0.0)
    except TypeError:
        return
    raise AssertionError("a missing field was accepted")


def test_the_routing_tables_repeat_the_graphs_and_lengths():
    net = trackmap.load_default()
    index = net.routing_index
    for graph, moves in ((index.traversal, index.moves), (index.traversal_any, index.moves_any)):
        assert set(moves) == set(graph.nodes)
        assert all(moves[s] == tuple(graph.successors(s)) for s in graph)
    assert index.edge_lengths_m == tuple(float(x) for x in index.lengths_m)
    for node, ids in index.conflicts_by_node.items():
        kinds = tuple((cid, net.conflicts[cid].kind) for cid in ids)
        assert index.node_conflicts[node] == kinds
