"""Positions of many vehicles at once: the same records as one vehicle at a time."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol.positioning.matcher import Positioner
from antikol.positioning.outputs import hypotheses_of
from antikol.sim import GpsModel, Simulator, fleet


@pytest.fixture(scope="module")
def city():
    net = trackmap.load_default()
    specs = fleet(net, 12, 7, route_length_m=2000.0)
    result = Simulator(net, specs, gps=GpsModel.urban(), seed=7).run(90.0)
    return net, result.reports


def _fed(net, reports, until_s):
    pos = Positioner(net)
    by_t: dict[float, list] = {}
    for r in reports:
        if r.t <= until_s:
            by_t.setdefault(r.t, []).append(r)
    for t in sorted(by_t):
        pos.update_many(by_t[t], outputs=False)
    return pos


@pytest.mark.parametrize("until_s", [20.0, 60.0, 90.0])
def test_positions_are_those_of_one_vehicle_at_a_time(city, until_s):
    net, reports = city
    one, many = _fed(net, reports, until_s), _fed(net, reports, until_s)
    ids = sorted(one.vehicles())
    at = until_s + 1.5  # dead-reckoned a little past the last reports
    single = [one.position(v, at) for v in ids]
    batch = many.positions([*ids, "nobody", ids[0]], at)
    assert batch[:-2] == single  # bit for bit, every field
    assert batch[-2] is None
    assert batch[-1] == batch[0]
    statuses = {p.status for p in batch if p is not None}
    assert "confident" in statuses
    # each at its last report when no time is given
    assert many.positions(ids) == [one.position(v) for v in ids]


@pytest.fixture(scope="module", params=["white", "urban"])
def busy_city(request):
    net = trackmap.load_default()
    gps = GpsModel.urban() if request.param == "urban" else GpsModel(sigma_m=3.0)
    specs = fleet(net, 60, 3, route_length_m=1500.0, headway_s=0.0, min_separation_m=40.0)
    result = Simulator(net, specs, gps=gps, seed=3).run(60.0)
    return net, result.reports


def test_a_fleet_placed_in_arrays_is_placed_as_one_vehicle_at_a_time(busy_city, monkeypatch):
    """From ``placing.ARRAY_FROM`` vehicles on, those on their lineage's edge away from
    switches are placed in arrays: the same records, bit for bit, as the scalar path, at
    every cycle, at the reports' time and dead-reckoned past it (past the limit too)."""
    from antikol.positioning import placing

    net, reports = busy_city
    scalar_calls: list[str] = []
    real = placing.place_one

    def counted(*args, **kwargs):
        scalar_calls.append(args[4])
        return real(*args, **kwargs)

    monkeypatch.setattr(placing, "place_one", counted)
    one, many = Positioner(net), Positioner(net)
    by_t: dict[float, list] = {}
    for r in reports:
        by_t.setdefault(r.t, []).append(r)
    batches = statuses = 0
    seen: set[str] = set()
    for t in sorted(by_t):
        for r in by_t[t]:  # one vehicle at a time: placed by the scalar path
            one.update_many([r], outputs=False)
        many.update_many(by_t[t], outputs=False)
        ids = sorted(one.vehicles())
        if len(ids) < placing.ARRAY_FROM:
            continue
        limit_s = one.config.dead_reckoning_s
        for at in (None, t + 1.5, t + 7.0, t + limit_s - 0.5, t + limit_s + 0.5):
            single = [one.placed_positions([v], at)[0] for v in ids]
            scalar_calls.clear()
            batch = many.placed_positions(ids, at)
            assert batch == single, (t, at)
            # and as shown (a vehicle not yet shown on a track without its edge)
            assert many.positions(ids, at) == [one.position(v, at) for v in ids], (t, at)
            batches += 1
            matched = sum(p is not None and p.edge_id is not None for p in batch)
            # both paths are taken: most vehicles in arrays, some one at a time
            assert len(scalar_calls) < matched
            statuses += any(scalar_calls)
            seen.update(p.status for p in batch if p is not None)
    assert batches > 100 and statuses > 0
    assert {"confident", "ambiguous", "lost"} <= seen


def test_a_placement_holds_the_fields_of_a_track_position_but_its_geometry():
    """track_positions builds each record from a Placement by position."""
    from antikol.positioning.outputs import Placement
    from antikol.positioning.records import TrackPosition

    geometry = {"lon", "lat", "heading_deg"}
    fields = [f.name for f in dataclasses.fields(TrackPosition)]
    assert list(Placement._fields) == [*(f for f in fields if f not in geometry), "held"]
    assert fields[6:9] == ["lon", "lat", "heading_deg"]


def test_hypotheses_are_built_in_the_order_of_their_fields():
    """hypotheses_of builds each Hypothesis by position."""
    from antikol.positioning.records import Hypothesis

    assert [f.name for f in dataclasses.fields(Hypothesis)] == [
        "edge_id",
        "direction",
        "offset_m",
        "probability",
        "progress_m",
        "wrong_way",
        "wrong_way_s",
    ]


def test_an_unmatched_vehicle_stands_where_its_fix_is(city):
    net, reports = city
    first = reports[0]
    far = dataclasses.replace(first, vehicle_id="far", lat=first.lat + 0.5, lon=first.lon)
    pos = Positioner(net)
    pos.update_many([far], outputs=False)
    (p,) = pos.positions(["far"])
    assert p is not None and p.status == "unmatched"
    assert (p.lon, p.lat, p.edge_id) == (far.lon, far.lat, None)


@pytest.mark.parametrize("t", [float("nan"), float("inf"), "soon"])
def test_a_time_that_is_not_a_number_is_refused_by_name(city, t):
    from antikol.errors import InvalidArgumentError

    net, reports = city
    pos = _fed(net, reports, 20.0)
    ids = pos.vehicles()
    for asked in (ids[:1], ids):  # one vehicle or many: the same answer
        with pytest.raises(InvalidArgumentError, match="t"):
            pos.positions(asked, t)


@settings(max_examples=100, deadline=None)
@given(
    st.lists(
        st.lists(st.integers(-1, 9), min_size=4, max_size=4),  # -1: an empty slot
        min_size=0,
        max_size=6,
    )
)
def test_hypotheses_of_reads_the_filled_slots_of_each_vehicle_in_order(slot_states):
    states = np.array(slot_states, dtype=np.int64).reshape(-1, 4)
    rng = np.random.default_rng(len(slot_states))
    offsets, logp, progress, wrong_s = (rng.normal(size=states.shape) for _ in range(4))
    allowed = rng.random(10) < 0.5
    got = hypotheses_of(states, offsets, logp, progress, wrong_s, allowed)
    assert len(got) == len(states)
    for row, hyps in enumerate(got):
        slots = [k for k in range(4) if states[row, k] >= 0]
        assert [(h.edge_id, h.direction) for h in hyps] == [
            (int(states[row, k]) >> 1, 1 - 2 * (int(states[row, k]) & 1)) for k in slots
        ]
        assert [h.offset_m for h in hyps] == [float(offsets[row, k]) for k in slots]
        assert [h.probability for h in hyps] == [math.exp(logp[row, k]) for k in slots]
        assert [h.progress_m for h in hyps] == [float(progress[row, k]) for k in slots]
        assert [h.wrong_way_s for h in hyps] == [float(wrong_s[row, k]) for k in slots]
        assert [h.wrong_way for h in hyps] == [not allowed[states[row, k]] for k in slots]


def test_several_reports_of_a_vehicle_in_one_call_are_taken_in_their_order(city):
    """update_many with two reports of each vehicle: the positions of taking them one
    after the other, one list entry per report (each the vehicle's latest position)."""
    net, reports = city
    by_t: dict[float, list] = {}
    for r in reports:
        by_t.setdefault(r.t, []).append(r)
    times = sorted(by_t)
    one, many = Positioner(net), Positioner(net)
    for a, b in zip(times[0::2], times[1::2], strict=False):
        for r in by_t[a] + by_t[b]:
            one.update(r)
        got = many.update_many(by_t[a] + by_t[b])
        latest = {p.vehicle_id: p for p in got}
        assert [p.vehicle_id for p in got] == [r.vehicle_id for r in by_t[a] + by_t[b]]
        assert all(got[k] is latest[r.vehicle_id] for k, r in enumerate(by_t[a] + by_t[b]))
        assert latest == {v: one.position(v) for v in latest}
