from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from antikol import VehicleReport
from antikol.analysis.sector import CourseKeeper, SectorRule
from antikol.table import VehicleTable
from tests._paths import GDANSK


def at(vid, x, y, *, t=0.0, speed=8.0, course=0.0):
    lon, lat = GDANSK.to_lonlat(x, y)
    return VehicleReport(vid, t, lat, lon, speed, course)


def test_sector_boundaries_and_order():
    rule = SectorRule()
    own = at("A", 0, 0)
    others = [
        at("near", 0, 50),
        at("far", 0, 299.0),
        at("out_of_range", 0, 301.0),
        at("edge_in", 100 * np.tan(np.radians(14.9)), 100),
        at("edge_out", 100 * np.tan(np.radians(15.2)), 100),
        at("behind", 0, -50),
    ]
    hits = rule.evaluate(own, others)
    assert [h.vehicle_id for h in hits] == ["near", "edge_in", "far"]
    assert hits[0].distance_m == pytest.approx(50, abs=0.2)


def test_sector_uses_given_course_across_north():
    rule = SectorRule()
    own = at("A", 0, 0, course=355.0)
    other = at("B", 100 * np.tan(np.radians(8)), 100)  # bearing 8 deg: 13 deg off 355
    assert [h.vehicle_id for h in rule.evaluate(own, [other])] == ["B"]
    assert rule.evaluate(own, [other], course_deg=330.0) == []


def test_course_keeper_holds_last_course_while_standing():
    keeper = CourseKeeper(min_speed_mps=1.0)
    assert keeper.update(at("A", 0, 0, speed=0.0, course=123.0)) is None
    assert keeper.update(at("A", 0, 0, speed=5.0, course=10.0)) == 10.0
    # stopped at a platform: the receiver's course wanders, the kept course does not
    assert keeper.update(at("A", 0, 0, speed=0.2, course=250.0)) == 10.0
    assert keeper.update(at("A", 0, 0, speed=1.5, course=20.0)) == 20.0


@pytest.mark.parametrize("bad", [dict(d_col_m=0), dict(half_angle_deg=0), dict(d_col_m=np.nan)])
def test_sector_rejects_bad_parameters(bad):
    with pytest.raises(ValueError):
        SectorRule(**bad)


def test_table_register_update_stale_duplicate_expire():
    table = VehicleTable(capacity=32, expiry_s=10.0)
    assert table.update(at("B", 0, 10, t=0.0)).outcome == "registered"
    assert table.update(at("B", 0, 11, t=1.0)).outcome == "updated"
    assert table.update(at("B", 0, 12, t=0.5)).outcome == "stale"
    assert table.update(at("B", 0, 12, t=1.0)).outcome == "duplicate"
    assert table.get("B").t == 1.0
    assert table.stats["stale"] == 1 and table.stats["duplicate"] == 1
    # C keeps talking; B falls silent
    table.update(at("C", 0, 50, t=5.0))
    assert "B" in table
    res = table.update(at("C", 0, 50, t=11.5))
    assert res.expired == ("B",)
    assert "B" not in table and "C" in table
    assert table.stats["expired"] == 1


def offer(table, vid, x, y, *, t=0.0):
    """A newcomer reports twice (a full table wants a confirmed newcomer)."""
    res = table.update(at(vid, x, y, t=t))
    if res.outcome == "rejected_full":
        res = table.update(at(vid, x, y, t=t + 0.5))
    return res


def test_table_full_keeps_the_nearest_and_never_drops_own():
    table = VehicleTable(capacity=2, own_id="OWN")
    table.update(at("OWN", 0, 0))
    table.update(at("far", 0, 200))
    table.update(at("mid", 0, 100))
    first = table.update(at("near", 0, 50))
    assert first.outcome == "rejected_full" and first.evicted is None  # not yet confirmed
    res = table.update(at("near", 0, 52, t=0.5))
    assert res.outcome == "registered" and res.evicted == "far"
    res = offer(table, "farther", 0, 500)
    assert res.outcome == "rejected_full"
    assert set(table.vehicle_ids()) == {"OWN", "mid", "near"}
    assert table.stats["rejected_full"] == 3 and table.stats["evicted"] == 1
    assert table.stats["unconfirmed"] == 2


def test_table_full_without_own_position_drops_least_recent():
    table = VehicleTable(capacity=2)
    table.update(at("a", 0, 10, t=0.0))
    table.update(at("b", 0, 20, t=1.0))
    res = offer(table, "c", 0, 30, t=2.0)
    assert res.evicted == "a"


def test_one_forged_frame_or_a_jumping_newcomer_never_evicts():
    table = VehicleTable(capacity=2, own_id="OWN")
    table.update(at("OWN", 0, 0))
    table.update(at("real1", 0, 200))
    table.update(at("real2", 0, 250))
    # 1000 one-shot phantoms nearer than both real trams: none gets in
    for i in range(1000):
        assert table.update(at(f"ph{i}", 0, 20, t=0.1)).outcome == "rejected_full"
    # a newcomer whose second report is 5 km from its first is not confirmed
    table.update(at("jump", 0, 30, t=0.2))
    assert table.update(at("jump", 5000, 30, t=0.4)).outcome == "rejected_full"
    # nor one without a position fix
    nofix = VehicleReport("nofix", 0.5, *reversed(GDANSK.to_lonlat(0, 10)), 5.0, 0.0, fix_quality=0)
    table.update(nofix)
    assert table.update(replace(nofix, t=0.6)).outcome == "rejected_full"
    assert set(table.vehicle_ids()) == {"OWN", "real1", "real2"}
    assert table.stats["evicted"] == 0 and table.stats["rejected_implausible"] >= 1


@settings(max_examples=60)
@given(
    capacity=st.integers(1, 6),
    positions=st.lists(
        st.tuples(st.floats(-800, 800), st.floats(-800, 800)), min_size=1, max_size=20
    ),
)
def test_a_dropped_vehicle_is_never_closer_than_a_kept_one(capacity, positions):
    table = VehicleTable(capacity=capacity, own_id="OWN")
    table.update(at("OWN", 0, 0))
    dist = {}
    dropped = set()
    for i, (x, y) in enumerate(positions):
        vid = f"v{i}"
        dist[vid] = np.hypot(x, y)
        res = offer(table, vid, x, y)
        if res.outcome == "rejected_full":
            dropped.add(vid)
        if res.evicted:
            dropped.add(res.evicted)
    kept = [v for v in table.vehicle_ids() if v != "OWN"]
    assert len(kept) == min(capacity, len(positions))
    for d in dropped:
        for k in kept:
            assert dist[d] >= dist[k] - 0.5  # planar vs projected distance tolerance


def test_table_rejects_bad_configuration():
    with pytest.raises(ValueError):
        VehicleTable(capacity=0)
    with pytest.raises(ValueError):
        VehicleTable(expiry_s=-1)


def test_table_never_expires_its_own_vehicle():
    table = VehicleTable(capacity=32, expiry_s=10.0, own_id="A")
    table.update(at("A", 0, 0, t=0.0))
    table.update(at("B", 0, 50, t=0.0))
    # own GPS silent for 30 s while B keeps reporting: B stays, and so does A
    for t in range(1, 31):
        table.update(at("B", 0, 50 + t, t=float(t)))
    assert "A" in table and "B" in table
    assert table.expire(100.0) == ["B"]
    assert "A" in table


def test_own_vehicle_is_still_assessed_after_an_own_gps_outage():
    from antikol import Analyser

    an = Analyser(own_id="A")
    an.update(at("A", 0, 0, t=0.0))
    for t in range(0, 20):
        an.update(at("B", 0, 100, t=float(t), speed=0.0))
    a = an.assess()  # raised UnknownVehicleError when the table dropped its own vehicle
    assert a.own_id == "A"
