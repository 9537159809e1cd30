"""Named values instead of bare ints, strings and tuples; ints and strings keep working."""

from __future__ import annotations

import dataclasses
import json

import pytest

import trackmap
from trackmap import ConflictKind, Direction, NodeClass, PathEnd, TrackState


@pytest.fixture(scope="module")
def net() -> trackmap.TrackMap:
    return trackmap.load_default()


def _start(net: trackmap.TrackMap) -> tuple[int, float]:
    c = net.candidates(19.93260, 50.06306, radius_m=25.0)[0]
    return c.edge_id, c.offset_m


def test_direction_is_an_int():
    assert Direction.FORWARD == 1 and Direction.BACKWARD == -1
    assert Direction(1) is Direction.FORWARD
    assert Direction.FORWARD.opposite() is Direction.BACKWARD
    assert Direction.BACKWARD.opposite() is Direction.FORWARD
    assert -Direction.FORWARD == -1 and f"{Direction.BACKWARD:+d}" == "-1"
    assert json.dumps([Direction.FORWARD, NodeClass.LINK]) == '[1, "link"]'


def test_string_kinds_equal_their_strings():
    assert NodeClass.POINT_SWITCH == "point_switch" and NodeClass("unknown") is NodeClass.UNKNOWN
    assert ConflictKind.MERGE == "merge" and {"crossing": 1}[ConflictKind.CROSSING] == 1
    assert PathEnd.HORIZON == "horizon" and f"{PathEnd.DEAD_END}" == "dead_end"
    assert {str(k) for k in PathEnd} == {"horizon", "buffer_stop", "dead_end", "truncated"}


def test_ints_and_directions_give_the_same_routes(net):
    edge_id, offset = _start(net)
    by_int = net.paths_ahead(edge_id, offset, 1, 400.0)
    by_enum = net.paths_ahead(edge_id, offset, Direction.FORWARD, 400.0)
    assert by_int == by_enum
    for path in by_int:
        assert isinstance(path.end, PathEnd)
        assert all(isinstance(s.direction, Direction) for s in path.steps)
        assert all(isinstance(n.cls, NodeClass) for n in path.nodes)
        assert all(isinstance(c.kind, ConflictKind) for c in path.conflicts)
    last = by_int[0].steps[-1]
    route = net.route_distance(edge_id, offset, -1, last.edge_id, last.exit_offset_m)
    same = net.route_distance(edge_id, offset, Direction.BACKWARD, last.edge_id, last.exit_offset_m)
    assert route == same
    assert route is None or isinstance(route.arrival_direction, Direction)


@pytest.mark.parametrize("bad", [0, 2, -2])
def test_bad_direction_is_a_value_error(net, bad):
    edge_id, offset = _start(net)
    with pytest.raises(ValueError, match="direction must be"):
        net.paths_ahead(edge_id, offset, bad, 100.0)
    with pytest.raises(ValueError, match="direction must be"):
        net.route_distance(edge_id, offset, bad, edge_id, offset)


def test_traversal_nodes_are_track_states(net):
    state = next(iter(net.traversal.nodes))
    assert isinstance(state, TrackState) and isinstance(state.direction, Direction)
    assert (state.edge_id, int(state.direction)) in net.traversal
    succ = net.successors(state.edge_id, int(state.direction))
    assert succ == list(net.traversal.successors(state))
    assert all(isinstance(s, TrackState) for s in succ)


def test_map_records_use_the_named_kinds(net):
    assert all(isinstance(n.cls, NodeClass) for n in net.nodes.values())
    assert all(isinstance(c.kind, ConflictKind) for c in net.conflicts)
    a, b, x, y = net.grade_separated[0]
    assert net.grade_separated[0] == (a, b, x, y)
    assert net.grade_separated[0].edge_a == a
    with pytest.raises(dataclasses.FrozenInstanceError):
        net.metadata.attribution = "changed"  # type: ignore[misc]


def test_map_file_keeps_plain_values(net, tmp_path):
    path = net.save(tmp_path / "k.trackmap.geojson")
    doc = json.loads(path.read_text(encoding="utf-8"))
    props = [f["properties"] for f in doc["features"]]
    classes = {p["class"] for p in props if p["feature"] == "node"}
    kinds = {p["kind"] for p in props if p["feature"] == "conflict"}
    assert classes <= {str(c) for c in NodeClass} and "point_switch" in classes
    assert kinds <= {str(k) for k in ConflictKind} and "merge" in kinds
    assert path.read_bytes() == trackmap.default_map_path().read_bytes()
    assert trackmap.load(path) == net
