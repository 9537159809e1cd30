"""Only vehicles that can interact have their paths walked; the others wait, and nothing
an assessment shows depends on that."""

from __future__ import annotations

import numpy as np
import pytest

import trackmap
from antikol.analysis.analyser import Analyser
from tests._osm import FRAME, OsmBuilder
from tests._paths import interleave, reports_along

LINE = [(0.0, float(y)) for y in range(0, 4001, 200)]
T = np.arange(0.0, 6.0, 1.0)


def straight_line(tmp_path) -> trackmap.TrackMap:
    b = OsmBuilder()
    b.line(LINE, oneway="yes")
    return trackmap.build(b.write_xml(tmp_path / "line.osm"))


def streams():
    near = reports_along("A", LINE, start_m=100.0, speed_mps=10.0, t=T, frame=FRAME)
    ahead = reports_along("B", LINE, start_m=220.0, speed_mps=0.0, t=T, frame=FRAME)
    far = reports_along("C", LINE, start_m=3500.0, speed_mps=8.0, t=T, frame=FRAME)
    return interleave(near, ahead, far)


def test_a_vehicle_out_of_reach_is_not_walked_on_board(tmp_path):
    net = straight_line(tmp_path)
    an = Analyser(track_map=net, own_id="A")
    for r in streams():
        an.update(r)
    a = an.assess()
    assert [th.vehicle_id for th in a.threats] == ["B"]
    cycle = an._cycle
    assert cycle is not None
    assert cycle.deferred == {"C"}
    assert cycle.views["C"].hyps == []
    # walked on demand, C has its paths like any other vehicle
    assert cycle.expand("C").hyps and not cycle.deferred


def test_on_board_and_control_room_agree_with_a_vehicle_out_of_reach(tmp_path):
    net = straight_line(tmp_path)
    board, room = Analyser(track_map=net, own_id="A"), Analyser(track_map=net)
    reports = streams()
    for t in T:
        for r in (r for r in reports if r.t == t):
            board.update(r)
            room.update(r)
        assert board.assess(t=t) == room.assess("A", t=t)


def test_zones_of_an_isolated_vehicle_in_a_control_room(tmp_path):
    # C has nobody in reach: its paths were deferred, yet its zones are asked for
    net = straight_line(tmp_path)
    an = Analyser(track_map=net)
    for r in streams():
        an.update(r)
    an.assess_all()
    zones = an.zones("C")
    assert zones and all(z.path.length_m > 0 for z in zones)


def test_another_own_vehicle_on_board_sees_its_own_reach(tmp_path):
    # the views were built for A's reach; asking for C must walk C's neighbours too
    net = straight_line(tmp_path)
    d = reports_along("D", LINE, start_m=3600.0, speed_mps=0.0, t=T, frame=FRAME)
    an = Analyser(track_map=net, own_id="A")
    room = Analyser(track_map=net)
    for r in interleave(streams(), d):
        an.update(r)
        room.update(r)
    assert an.assess("C") == room.assess("C")
    assert [th.vehicle_id for th in an.assess("C").threats] == ["D"]


class _NanSigma:
    """A position source whose positions of some vehicles have no usable sigma."""

    def __init__(self, inner, vehicles):
        self.inner, self.vehicles = inner, set(vehicles)

    def update_many(self, reports, *, outputs=True):
        return self.inner.update_many(reports, outputs=outputs)

    def position(self, vehicle_id, t=None):
        import dataclasses

        pos = self.inner.position(vehicle_id, t)
        if pos is not None and vehicle_id in self.vehicles:
            pos = dataclasses.replace(pos, sigma_m=float("nan"))
        return pos

    def forget(self, vehicle_id):
        self.inner.forget(vehicle_id)


@pytest.mark.parametrize(
    ("nan_for", "deferred", "method"),
    [({"B"}, {"C"}, "track"), ({"A"}, {"B", "C"}, "sector"), (set(), {"C"}, "track")],
)
def test_a_position_with_a_nan_sigma_falls_back_to_the_sector_rule(
    tmp_path, nan_for, deferred, method
):
    # a source's NaN sigma used to crash the pair evaluation (IndexError); such a position
    # is now treated as lost, counted, and the sector rule judges that vehicle
    from antikol.positioning.matcher import Positioner

    net = straight_line(tmp_path)
    source = _NanSigma(Positioner(net), nan_for)
    an = Analyser(track_map=net, own_id="A", position_source=source)
    for r in streams():
        an.update(r)
    a = an.assess()
    assert an._cycle is not None and an._cycle.deferred == deferred
    assert a.method == method
    assert [th.vehicle_id for th in a.threats] == ["B"]  # B stands 120 m ahead either way
    assert an.stats["position_unusable"] == (1 if nan_for else 0)
