"""The control room's sector rule for a whole fleet at once equals the rule per vehicle."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from antikol import SectorRule, VehicleReport


def _fleet(seed: int, n: int, spread_deg: float, lat0: float):
    rng = np.random.default_rng(seed)
    lat = lat0 + rng.uniform(-spread_deg, spread_deg, n)
    lon = 19.9 + rng.uniform(-spread_deg, spread_deg, n) * 1.5
    # a few vehicles at the very same place, or due north/south of another
    lat[: n // 10] = lat[0]
    lon[n // 10 : n // 5] = lon[0]
    reports = [
        VehicleReport(f"V{k}", 0.0, float(lat[k]), float(lon[k]), 5.0, float(c))
        for k, c in enumerate(rng.uniform(0.0, 360.0, n))
    ]
    courses = [None if rng.random() < 0.1 else r.course_deg for r in reports]
    return reports, courses


def _cycles(test):
    """Run ``test`` on fleets of one cycle: a seed, a size, a spread (degrees), a latitude."""
    return settings(max_examples=60, deadline=None)(
        given(
            seed=st.integers(0, 2**31),
            n=st.integers(1, 80),
            spread=st.sampled_from([0.0005, 0.003]),
            lat0=st.sampled_from([50.06, -33.9, 69.6]),
        )(test)
    )


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    n=st.integers(1, 120),
    spread=st.sampled_from([0.0005, 0.003, 0.02]),
    lat0=st.sampled_from([50.06, -33.9, 69.6, 0.0]),
    d_col=st.sampled_from([300.0, 50.0, 1000.0]),
    half=st.sampled_from([15.0, 45.0, 180.0]),
)
def test_whole_fleet_hits_equal_the_per_vehicle_rule(seed, n, spread, lat0, d_col, half):
    reports, courses = _fleet(seed, n, spread, lat0)
    rule = SectorRule(d_col_m=d_col, half_angle_deg=half)
    rng = np.random.default_rng(seed + 1)
    seen = rng.random(n) < 0.9
    batch = rule.evaluate_all(reports, courses, targets=seen)
    for k, own in enumerate(reports):
        others = [r for j, r in enumerate(reports) if j != k and seen[j]]
        expected = (
            rule.evaluate(own, others, course_deg=courses[k]) if courses[k] is not None else []
        )
        assert batch[k] == expected


@_cycles
def test_closing_speeds_of_a_cycle_equal_those_hit_by_hit(seed, n, spread, lat0):
    """One array call for every hit of a cycle gives the numbers of one call per hit (the
    own vehicle at its kept course, else its reported one), bit for bit."""
    from antikol.analysis.sector import closing_speeds, hit_closing_speed

    reports, courses = _fleet(seed, n, spread, lat0)
    rng = np.random.default_rng(seed + 2)
    reports = [
        VehicleReport(r.vehicle_id, 0.0, r.lat, r.lon, float(v), r.course_deg)
        for r, v in zip(reports, rng.uniform(0.0, 20.0, n), strict=True)
    ]
    # a kept course that is not the reported one (the vehicle slowed below the threshold)
    courses = [c if c is None or rng.random() < 0.7 else (c + 40.0) % 360.0 for c in courses]
    hits = SectorRule(half_angle_deg=60.0).evaluate_all(reports, courses)
    closing = closing_speeds(reports, courses, hits)
    by_id = {r.vehicle_id: r for r in reports}
    assert len(closing) == sum(len(h) for h in hits)
    for own, course, own_hits in zip(reports, courses, hits, strict=True):
        for h in own_hits:
            expected = hit_closing_speed(own, course, by_id[h.vehicle_id], h)
            got = closing[(own.vehicle_id, h.vehicle_id)]
            assert got.closing_speed_mps == expected
            assert (got.own, got.other, got.hit) == (own, by_id[h.vehicle_id], h)


@_cycles
def test_the_fleet_form_gives_the_hits_and_closing_speeds_of_the_rule(seed, n, spread, lat0):
    """A control room's cycle in arrays (hits and closing speeds at once, old reports not
    hit) equals the rule's whole-fleet hits and their closing speeds."""
    from antikol.analysis.fleetsector import fleet_sector
    from antikol.analysis.sector import closing_speeds

    reports, courses = _fleet(seed, n, spread, lat0)
    rng = np.random.default_rng(seed + 3)
    ages = np.where(rng.random(n) < 0.2, rng.uniform(9.0, 12.0, n), 0.0)
    reports = [
        VehicleReport(r.vehicle_id, 100.0 - float(a), r.lat, r.lon, float(v), r.course_deg)
        for r, a, v in zip(reports, ages, rng.uniform(0.0, 20.0, n), strict=True)
    ]
    rule = SectorRule(half_angle_deg=45.0)
    got = fleet_sector(rule, reports, courses, now=100.0, expiry_s=10.0, key="k")
    hits = rule.evaluate_all(reports, courses, targets=[100.0 - r.t <= 10.0 for r in reports])
    assert got.key == "k"
    assert got.hits == {r.vehicle_id: h for r, h in zip(reports, hits, strict=True) if h}
    assert got.closing == closing_speeds(reports, courses, hits)
