"""A GPS outage as evidence of a tunnel (issue 12).

At a tunnel's portal the track often divides: one branch runs down into the tunnel, the
other stays on the street beside it. The fixes stop at the switch, so nothing but the
outage itself tells the branches apart — and an outage in the open lasts seconds, one in
a tunnel as long as the tunnel. A tram that went in is found in the tunnel after a few
seconds without a fix; one whose receiver failed on the street beside it is found on the
street again by the first fixes that come back.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import VehicleReport
from antikol.errors import InvalidArgumentError
from antikol.positioning import PositioningConfig
from antikol.positioning.fleet import SLOT_FIELDS, FleetState
from antikol.positioning.matcher import Positioner
from antikol.positioning.outages import outage_log_likelihood, weigh_outage
from antikol.positioning.reach import state_id
from tests._osm import FRAME, OsmBuilder
from tests._paths import reports_along

SPEED_MPS = 8.0
#: The switch at the portal, and where the branches part (the tunnel's ramp veers east).
SWITCH_Y = 300.0
TRUNK = [(0.0, 0.0), (0.0, SWITCH_Y)]
STREET = [(0.0, SWITCH_Y), (0.0, 1500.0)]
RAMP = [(0.0, SWITCH_Y), (3.0, 360.0), (9.0, 420.0)]
TUNNEL = [(9.0, 420.0), (9.0, 1500.0)]


@pytest.fixture(scope="module")
def portal(tmp_path_factory):
    """A one-way trunk dividing at a switch into a street track and a ramp into a tunnel."""
    b = OsmBuilder()
    switch = b.node(*TRUNK[1])
    b.line([TRUNK[0], switch], oneway="yes")
    b.line([switch, *STREET[1:]], oneway="yes")
    ramp_end = b.node(*RAMP[-1])
    b.line([switch, *RAMP[1:-1], ramp_end], oneway="yes")
    b.line([ramp_end, *TUNNEL[1:]], oneway="yes", tunnel="yes", layer="-1")
    net = trackmap.build(b.write_xml(tmp_path_factory.mktemp("portal") / "portal.osm"))
    (tunnel,) = [e.edge_id for e in net.edges if e.tunnel]
    (street,) = [e.edge_id for e in net.edges if e.length_m > 1000.0 and not e.tunnel]
    return net, tunnel, street


def _drive(path: list[tuple[float, float]], seconds: int, *, fix_until_y: float,
           fix_from_s: float = np.inf) -> list[VehicleReport]:  # fmt: skip
    """A tram from y = 100 m along ``path`` at 8 m/s with its odometer; its reports have no
    fix (they repeat the last fix's place) from where it passes ``fix_until_y`` until
    ``fix_from_s`` (s)."""
    t = np.arange(0.0, float(seconds), 1.0)
    reports = reports_along("T", path, start_m=100.0, speed_mps=SPEED_MPS, t=t, frame=FRAME)
    out: list[VehicleReport] = []
    for r in reports:
        _, y = FRAME.to_local(r.lon, r.lat)
        blind = float(y) > fix_until_y and r.t < fix_from_s
        place = {"lat": out[-1].lat, "lon": out[-1].lon} if blind and out else {}
        out.append(
            dataclasses.replace(
                r, odometer_m=1000.0 + SPEED_MPS * r.t, fix_quality=0 if blind else 1, **place
            )
        )
    return out


@pytest.mark.parametrize("outage_s", [5.0, 0.0], ids=["weighed", "no evidence"])
def test_a_tram_whose_fixes_stop_at_the_portal_is_found_in_the_tunnel(portal, outage_s):
    net, tunnel, _ = portal
    into_tunnel = [*TRUNK, *RAMP[1:], *TUNNEL[1:]]
    # the fixes stop at the switch; the ramp down (120 m, 15 s) is open track like the
    # street beside it, so only the time in the tunnel tells them apart
    reports = _drive(into_tunnel, 75, fix_until_y=SWITCH_Y - 4.0)
    pos = Positioner(net, PositioningConfig(surface_outage_s=outage_s))
    out = [pos.update(r) for r in reports]
    blind_from = next(r.t for r in reports if r.fix_quality == 0)
    in_tunnel_from = blind_from + 15.0

    def tunnel_mass(p):
        return sum(h.probability for h in p.hypotheses if h.edge_id == tunnel)

    if outage_s == 0.0:  # the old coin toss: both branches keep half
        assert all(0.3 < tunnel_mass(p) < 0.7 for p in out if p.t > in_tunnel_from)
        return
    # the reported place goes into the tunnel about 6 s after the tram (its branch then
    # holds three times the street's), once, and stays
    assert all(p.edge_id == tunnel for p in out if p.t >= in_tunnel_from + 8.0)
    assert all(tunnel_mass(p) > 0.95 for p in out if p.t >= in_tunnel_from + 16.0)
    edges = [p.edge_id for p in out if p.t > in_tunnel_from]
    assert sum(a != b for a, b in itertools.pairwise(edges)) == 1
    assert pos.stats["outage_lineage_switch"] == 1


def test_a_receiver_failing_on_the_street_beside_the_portal_is_found_again(portal):
    net, tunnel, street = portal
    on_street = [*TRUNK, *STREET[1:]]
    # no fix from the switch on for 60 s (a failed receiver), then fixes again
    reports = _drive(on_street, 90, fix_until_y=SWITCH_Y - 4.0, fix_from_s=85.0)
    pos = Positioner(net)
    out = [pos.update(r) for r in reports]
    blind = [p for p in out if reports[int(p.t)].fix_quality == 0]
    assert len(blind) > 50
    # an outage that long is evidence of the tunnel (the model's own conclusion) ...
    assert blind[-1].edge_id == tunnel
    # ... but the street track is kept, and the fixes that come back find it: the third
    # is placed on it (the tunnel runs 9 m beside the street, within a biased fix's reach)
    street_left = [h.probability for h in blind[-1].hypotheses if h.edge_id == street]
    assert street_left and min(street_left) >= 10.0 * PositioningConfig().min_probability * 0.99
    back = [p for p in out if p.t >= 85.0]
    assert all(p.edge_id == street for p in back[2:])


def test_an_outage_where_no_hypothesis_is_in_a_tunnel_changes_nothing(portal):
    net, _, street = portal
    # the fixes ran 300 m past the switch: the tunnel branch is long pruned
    on_street = [*TRUNK, *STREET[1:]]
    reports = _drive(on_street, 70, fix_until_y=600.0, fix_from_s=62.0)
    runs = []
    for outage_s in (5.0, 0.0):
        pos = Positioner(net, PositioningConfig(surface_outage_s=outage_s))
        runs.append([(p.edge_id, p.offset_m, p.probability) for p in map(pos.update, reports)])
    assert runs[0] == runs[1]
    assert {edge for edge, *_ in runs[0][30:]} == {street}  # past the switch


def test_surface_outage_is_checked():
    with pytest.raises(InvalidArgumentError, match="surface_outage_s"):
        PositioningConfig(surface_outage_s=-1.0)


# -- the weighing itself -------------------------------------------------------------------
def test_outage_log_likelihood():
    covered = np.array([True, False, False])
    assert outage_log_likelihood(covered, 2.0, surface_outage_s=4.0).tolist() == [0, -0.5, -0.5]
    assert not outage_log_likelihood(covered, 2.0, surface_outage_s=0.0).any()
    assert not outage_log_likelihood(covered, 0.0, surface_outage_s=4.0).any()
    assert not outage_log_likelihood(covered, float("nan"), surface_outage_s=4.0).any()


def _fleet(states: list[int], probabilities: list[float]) -> FleetState:
    fleet = FleetState(8)
    fleet.grow(1)
    m = len(states)
    fleet.hs[0, :m] = states
    fleet.hp[0, :m] = np.log(probabilities)
    for k, name in enumerate(SLOT_FIELDS):
        if name != "hp":  # a value per slot that shows where it went
            getattr(fleet, name)[0, :m] = 100.0 * k + np.arange(m)
    return fleet


@settings(max_examples=150, deadline=None)
@given(
    tunnel_of=st.lists(st.booleans(), min_size=2, max_size=8),
    weights=st.lists(st.floats(0.01, 1.0), min_size=8, max_size=8),
    dt_s=st.floats(0.0, 120.0),
)
def test_weighing_keeps_a_distribution_and_moves_whole_slots(tunnel_of, weights, dt_s):
    m = len(tunnel_of)
    tunnel_edges = np.array(tunnel_of)
    states = [int(state_id(e, 1)) for e in range(m)]  # one slot per edge
    w = np.array(weights[:m]) / sum(weights[:m])
    fleet = _fleet(states, w.tolist())
    before = {name: getattr(fleet, name)[0].copy() for name in ("hs", *SLOT_FIELDS)}
    moved = weigh_outage(
        fleet, 0, tunnel_edges, dt_s, surface_outage_s=5.0, switch_probability=0.75, floor=1e-3
    )
    p = np.exp(fleet.hp[0, :m])
    assert p.sum() == pytest.approx(1.0)
    contrast = tunnel_edges.any() and not tunnel_edges.all()
    if not contrast or dt_s == 0.0:
        assert not moved and np.array_equal(fleet.hp[0], before["hp"])
        return
    # slots keep their other fields together: the same permutation for every field
    order = [int(np.flatnonzero(before["hs"] == s)[0]) for s in fleet.hs[0, :m]]
    for name in SLOT_FIELDS:
        if name != "hp":
            assert np.array_equal(getattr(fleet, name)[0, :m], before[name][order])
    # tunnel slots gain against open ones; no open one falls far below the floor
    ratio = p / w[order]
    covered = tunnel_edges[np.array(order)]
    assert ratio[covered].min() >= ratio[~covered].max() - 1e-9
    assert (p[~covered] >= np.minimum(w[order][~covered], 1e-3) * 0.99).all()
    # the lineage moves only into a tunnel, to the best place, holding the switch
    # probability; nothing moves without a contrast or with no evidence (0 s)
    if moved:
        assert order[0] != 0 and covered[0] and p[0] >= 0.75 and p[0] == p.max()
    else:
        assert order == list(range(m))
    again = _fleet(states, w.tolist())
    kept = again.hp.copy()
    assert not weigh_outage(
        again, 0, tunnel_edges, dt_s, surface_outage_s=0.0, switch_probability=0.75, floor=1e-3
    )
    assert np.array_equal(again.hp, kept)


def test_an_operator_feed_saying_its_position_is_not_gps_puts_the_tram_in_the_tunnel(
    portal, tmp_path
):
    """End to end from an HFP archive: in the tunnel the feed's ``loc`` is ``ODO`` (the
    position is the operator's own dead reckoning, not a fix), which is all it says."""
    import json
    from datetime import UTC, datetime

    from antikol.ingest import read_hfp

    net, tunnel, _ = portal
    drive = _drive([*TRUNK, *RAMP[1:], *TUNNEL[1:]], 75, fix_until_y=SWITCH_Y - 4.0)
    start = datetime(2024, 3, 1, 8, 0, tzinfo=UTC).timestamp()
    lines = []
    for r in drive:
        stamp = datetime.fromtimestamp(start + r.t, UTC).strftime("%Y-%m-%dT%H:%M:%S.000Z")
        vp = {"oper": 40, "veh": 412, "tst": stamp, "lat": r.lat, "long": r.lon,
              "spd": r.speed_mps, "hdg": round(r.course_deg), "odo": r.odometer_m,
              "loc": "GPS" if r.fix_quality else "ODO"}  # fmt: skip
        lines.append(json.dumps({"VP": vp}))
    path = tmp_path / "hfp.jsonl"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    log = read_hfp(path)
    assert not log.problems and len(log.reports) == len(drive)
    pos = Positioner(net)
    out = [pos.update(r) for r in log.reports]
    in_tunnel_from = start + next(r.t for r in drive if r.fix_quality == 0) + 15.0
    assert all(p.edge_id == tunnel for p in out if p.t >= in_tunnel_from + 8.0)
