"""Warnings that hold on noisy, realistic traffic (issue 11's findings, each as a test).

Each scenario is drawn in metres on a small OSM fixture and fed to the public API
(``antikol.Analyser(track_map=...)``, ``antikol.VehicleReport``) with GPS noise: white noise
plus a lateral bias that persists, towards the neighbouring track where there is one.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import antikol
import trackmap
from antikol.analysis import braking
from tests._osm import FRAME, OsmBuilder
from tests._paths import interleave

TRAM = braking.load_profile("tram")


def noisy_along(
    vid: str,
    line: list[tuple[float, float]],
    *,
    start_m: float,
    speeds: np.ndarray,
    t: np.ndarray,
    rng: np.random.Generator,
    white_m: float = 2.0,
    bias_left_m: float = 0.0,
    **extra: object,
) -> list[antikol.VehicleReport]:
    """Reports of a vehicle along a polyline with a speed profile, with GPS noise: white
    noise per axis and a constant bias to the left of the running direction."""
    import shapely

    geom = shapely.LineString(line)
    s = start_m + np.concatenate([[0.0], np.cumsum(0.5 * (speeds[1:] + speeds[:-1]) * np.diff(t))])
    out = []
    for ti, si, vi in zip(t, s, speeds, strict=True):
        si = min(float(si), geom.length - 0.6)
        p, q = geom.interpolate(max(si - 0.5, 0.0)), geom.interpolate(si + 0.5)
        hx, hy = q.x - p.x, q.y - p.y
        norm = math.hypot(hx, hy)
        left = (-hy / norm, hx / norm)
        c = geom.interpolate(si)
        x = c.x + bias_left_m * left[0] + rng.normal(0.0, white_m)
        y = c.y + bias_left_m * left[1] + rng.normal(0.0, white_m)
        lon, lat = FRAME.to_lonlat(x, y)
        course = (math.degrees(math.atan2(hx, hy)) + rng.normal(0.0, 3.0)) % 360.0
        speed = max(float(vi) + rng.normal(0.0, 0.15), 0.0)
        out.append(
            antikol.VehicleReport(vid, float(ti), lat, lon, speed, course, **extra)  # type: ignore[arg-type]
        )
    return out


def feed(net, *streams, config=None):
    """Feed an analyser second by second; {t: {vid: Assessment}} for every reporting vehicle."""
    an = antikol.Analyser(track_map=net, config=config)
    out: dict[float, dict[str, antikol.Assessment]] = {}
    merged = interleave(*streams)
    times = sorted({r.t for r in merged})
    for t in times:
        batch = [r for r in merged if r.t == t]
        an.update_many(batch)
        out[t] = {r.vehicle_id: an.assess(r.vehicle_id) for r in batch}
    return out, an


def toggles(states: dict[float, dict[str, antikol.Assessment]], vid: str) -> int:
    lamp = [a[vid].lamp for _, a in sorted(states.items()) if vid in a]
    return sum(1 for x, y in itertools.pairwise(lamp) if x != y) + int(bool(lamp and lamp[0]))


@pytest.fixture(scope="module")
def double_track(tmp_path_factory):
    """Double track 3.8 m apart, one way each (right-hand running): east track northbound."""
    b = OsmBuilder()
    b.line([(3.8, -200.0), (3.8, 1400.0)], oneway="yes")
    b.line([(0.0, 1400.0), (0.0, -200.0)], oneway="yes")
    return trackmap.build(b.write_xml(tmp_path_factory.mktemp("dt") / "dt.osm"))


EAST = [(3.8, -200.0), (3.8, 1400.0)]
WEST = [(0.0, 1400.0), (0.0, -200.0)]


def test_ends_are_placed_when_the_antenna_offset_is_unknown(double_track):
    """Finding 1: a report with a length but no antenna offset (the paper's packet, GTFS-rt,
    HFP) must not be measured antenna to antenna: 30 m too long for two 30 m trams."""
    t = np.arange(0.0, 40.0)
    rng = np.random.default_rng(1)
    leader = noisy_along(
        "B", EAST, start_m=700.0, speeds=np.zeros_like(t), t=t, rng=rng, length_m=30.0
    )
    follower = noisy_along(
        "A", EAST, start_m=200.0, speeds=np.full_like(t, 11.0), t=t, rng=rng, length_m=30.0
    )
    states, _ = feed(double_track, leader, follower)
    # the true gap between A's front and B's rear (antennas mid-vehicle, as the rule assumes)
    gap = {tt: 700.0 - (200.0 + 11.0 * tt) - 30.0 for tt in states}
    warn = braking.warning_distance(11.0, TRAM)
    due = [tt for tt in states if gap[tt] <= warn]
    assert due, "the approach must reach the warning distance"
    assert states[due[0]]["A"].lamp, "the lamp must be on when the warning distance is reached"
    th = next(x for x in states[due[0]]["A"].threats if x.vehicle_id == "B")
    assert th.kind == "rear_end" and th.own_ends == th.other_ends == "assumed_offset"
    assert th.distance_m == pytest.approx(gap[due[0]], abs=8.0)


def test_the_lamp_does_not_flicker_through_an_approach(double_track):
    """Finding 3: one approach to a standing tram, noisy GPS and speed: the lamp goes on
    once and stays on until the follower stands."""
    t = np.arange(0.0, 70.0)
    v = np.clip(11.0 - np.maximum(t - 30.0, 0.0) * 0.8, 0.0, None)  # brakes from t = 30 s
    for seed in range(4):
        rng = np.random.default_rng(seed)
        leader = noisy_along("B", EAST, start_m=620.0, speeds=np.zeros_like(t), t=t, rng=rng)
        follower = noisy_along("A", EAST, start_m=200.0, speeds=v, t=t, rng=rng)
        states, _ = feed(double_track, leader, follower)
        assert any(a["A"].lamp for a in states.values())
        assert toggles(states, "A") <= 2, f"seed {seed}: the lamp blinks"


@pytest.mark.parametrize("bias", [0.0, 2.5])
def test_no_alarm_for_a_tram_passing_on_the_other_track_of_one_way_double_track(double_track, bias):
    """Finding 4: on a network where every track is one way, a tram on the other track is
    neither head-on (a wrong-way hypothesis of small probability) nor ahead of us (an
    other-track hypothesis), even with a GPS bias pulling both towards each other."""
    t = np.arange(0.0, 80.0)
    for seed in range(3):
        rng = np.random.default_rng(10 + seed)
        a = noisy_along(
            "A",
            EAST,
            start_m=100.0,
            speeds=np.full_like(t, 9.0),
            t=t,
            rng=rng,
            bias_left_m=bias,
            length_m=30.0,
        )
        b = noisy_along(
            "B",
            WEST,
            start_m=100.0,
            speeds=np.full_like(t, 9.0),
            t=t,
            rng=rng,
            bias_left_m=bias,
            length_m=30.0,
        )
        states, _ = feed(double_track, a, b)
        lamps = [tt for tt, s in states.items() if s["A"].lamp or s["B"].lamp]
        assert lamps == [], f"seed {seed}: false alarm at t={lamps[:5]}"


def test_no_alarm_for_a_standing_tram_on_the_other_track(double_track):
    """Finding 4, the other half: a tram that came along the neighbouring track and stopped
    there is not a rear-end threat to a tram passing it, although its fixes lean towards our
    track."""
    t = np.arange(0.0, 90.0)
    vb = np.clip(20.0 - t, 0.0, 8.0)  # B runs south at 8 m/s, brakes and stands from t = 20 s
    for seed in range(3):
        rng = np.random.default_rng(20 + seed)
        a = noisy_along(
            "A",
            EAST,
            start_m=0.0,
            speeds=np.full_like(t, 10.0),
            t=t,
            rng=rng,
            bias_left_m=2.0,
            length_m=30.0,
        )
        b = noisy_along(
            "B", WEST, start_m=300.0, speeds=vb, t=t, rng=rng, bias_left_m=2.0, length_m=30.0
        )
        states, _ = feed(double_track, a, b)
        assert not any(s["A"].lamp for s in states.values()), f"seed {seed}"


@pytest.fixture(scope="module")
def merge_map(tmp_path_factory):
    """A branch joining a main line at a switch (a trailing merge for both)."""
    b = OsmBuilder()
    join = b.node(0.0, 0.0)
    b.line([(0.0, -400.0), join], oneway="yes")  # main line northbound
    b.line([join, (0.0, 400.0)], oneway="yes")
    # branch from the south-west, joining at a shallow angle
    b.line([(-300.0, -300.0), (-40.0, -40.0), (-8.0, -20.0), (-1.0, -8.0), join], oneway="yes")
    return trackmap.build(b.write_xml(tmp_path_factory.mktemp("mg") / "mg.osm"))


MAIN = [(0.0, -400.0), (0.0, 400.0)]
BRANCH = [(-300.0, -300.0), (-40.0, -40.0), (-8.0, -20.0), (-1.0, -8.0), (0.0, 0.0), (0.0, 400.0)]


def test_a_tram_standing_before_a_merge_is_a_possible_conflict(merge_map):
    """Also in issue 11: a tram standing at a stop just before the merge may start at any
    moment; the approaching tram is warned by the braking model, before it starts."""
    t = np.arange(0.0, 40.0)
    rng = np.random.default_rng(5)
    # B stands 45 m before the merge, starts at t = 16 s and accelerates at 1 m/s²
    branch_len = sum(math.dist(p, q) for p, q in itertools.pairwise(BRANCH[:5]))
    vb = np.clip(t - 16.0, 0.0, 8.0)
    b = noisy_along("B", BRANCH, start_m=branch_len - 45.0, speeds=vb, t=t, rng=rng, length_m=30.0)
    a = noisy_along(
        "A", MAIN, start_m=150.0, speeds=np.full_like(t, 10.0), t=t, rng=rng, length_m=30.0
    )
    states, _ = feed(merge_map, a, b)
    first = min((tt for tt, s in states.items() if s["A"].lamp), default=None)
    assert first is not None, "the merge must be warned"
    assert first < 16.0, f"warned only at t={first}, after the standing tram had started"
    th = next(x for x in states[first]["A"].threats if x.vehicle_id == "B")
    assert th.kind == "merge"
