"""The paper's field tests (Figs. 10 and 11) replayed through the analyser without a map."""

import math

import numpy as np
import pytest

from antikol import UnknownVehicleError
from antikol.analysis.analyser import Analyser
from tests._paths import interleave, reports_from_xy

DT = 0.1


def integrate(segments, x0, y0):
    """Positions from (duration_s, speed_mps or (v0, v1), heading0_deg, heading1_deg)."""
    xs, ys, ts, phase = [x0], [y0], [0.0], [0]
    x, y, t = x0, y0, 0.0
    for k, (dur, speed, h0, h1) in enumerate(segments):
        n = round(dur / DT)
        for i in range(n):
            f = (i + 0.5) / n
            v = speed[0] + (speed[1] - speed[0]) * f if isinstance(speed, tuple) else speed
            h = math.radians(h0 + (h1 - h0) * f)
            x += v * math.sin(h) * DT
            y += v * math.cos(h) * DT
            t += DT
            xs.append(x)
            ys.append(y)
            ts.append(t)
            phase.append(k)
    return np.array(ts), np.array(xs), np.array(ys), np.array(phase)


def run(reports, own_id):
    an = Analyser()
    states = {}
    for r in reports:
        an.update(r)
        if r.vehicle_id == own_id:
            states[round(r.t, 3)] = an.assess(own_id)
    return states


def test_fig10_following_then_turning_left():
    # vehicle 1: right-hand U-turn (south -> north), follows at ~85 m, closes to ~15 m,
    # keeps the gap, then turns left by 60 degrees.
    segs = [
        (math.pi * 10 / 5, 5.0, 180.0, 360.0),  # U-turn to the right, radius 10 m
        (4.0, 8.0, 0.0, 0.0),  # following at the leader's speed
        (10.0, (8.0, 16.0), 0.0, 0.0),  # speeds up and closes in by 40 m
        (7.5, (16.0, 8.0), 0.0, 0.0),  # and slows to the leader's speed, 30 m more
        (2.0, 8.0, 0.0, 0.0),
        (2.0, 8.0, 0.0, -60.0),  # left turn
    ]
    t, x1, y1, phase = integrate(segs, 20.0, 0.0)
    t_follow = t[np.argmax(phase == 1)]
    x2 = np.zeros_like(t)
    y2 = y1[phase == 1][0] + 85.0 + 8.0 * (t - t_follow)
    v1 = reports_from_xy("V1", t, x1, y1)
    v2 = reports_from_xy("V2", t, x2, y2)
    states = run(interleave(v2, v1), "V1")
    gap = np.hypot(x2 - x1, y2 - y1)
    lamp = np.array([states[round(tt, 3)].lamp for tt in t])

    uturn_start = phase == 0
    assert not lamp[uturn_start][: len(lamp[uturn_start]) // 3].any()  # heading away
    following = (phase >= 1) & (phase <= 4)
    assert lamp[following].all(), "lamp must stay on while following"
    first_on = np.argmax(lamp)
    assert 80.0 <= gap[first_on] <= 95.0  # switches on at about 85 m after the U-turn
    assert gap[following].min() == pytest.approx(15.0, abs=3.0)
    end = len(t) - 1
    assert not lamp[end]
    assert gap[end] < 20.0  # still close in a straight line, yet outside the sector
    th = states[round(t[first_on + 5], 3)].primary
    assert th is not None and th.vehicle_id == "V2" and th.method == "sector"
    assert th.kind == "sector" and th.level == "warning"


def test_fig11_head_on_on_parallel_paths_4m_apart():
    speed = 8.0
    t = np.arange(0.0, 46.0, DT)
    y1 = -350.0 + speed * t
    y2 = 350.0 - speed * t
    v1 = reports_from_xy("V1", t, np.zeros_like(t), y1)
    v2 = reports_from_xy("V2", t, np.full_like(t, 4.0), y2)
    for own in ("V1", "V2"):
        states = run(interleave(v1, v2), own)
        sep = y2 - y1  # along-track separation, positive before they pass
        lamp = np.array([states[round(tt, 3)].lamp for tt in t])
        on_idx = np.flatnonzero(lamp)
        assert len(on_idx) > 0
        assert np.all(np.diff(on_idx) == 1), "one continuous alarm episode"
        on_sep, off_sep = sep[on_idx[0]], sep[on_idx[-1]]
        assert math.hypot(on_sep, 4.0) == pytest.approx(300.0, abs=3.0)
        assert off_sep == pytest.approx(4.0 / math.tan(math.radians(15.0)), abs=2.5)
        th = states[round(t[on_idx[len(on_idx) // 2]], 3)].primary
        assert th.closing_speed_mps > 15.0 and th.ttc_s is not None


def test_assess_unknown_vehicle_and_expiry():
    t = np.arange(0, 3, 1.0)
    an = Analyser()
    for r in interleave(
        reports_from_xy("A", t, np.zeros(3), 8 * t),
        reports_from_xy("B", t, np.zeros(3), 100 + 8 * t),
    ):
        an.update(r)
    assert an.assess("A").level == "warning"
    with pytest.raises(UnknownVehicleError, match="Z"):
        an.assess("Z")
    # B silent for 11 s while A keeps reporting: B leaves the table
    for r in reports_from_xy("A", np.arange(3, 15, 1.0), np.zeros(12), 8 * np.arange(3, 15, 1.0)):
        an.update(r)
    a = an.assess("A")
    assert a.level == "none" and not a.threats
    assert an.table.stats["expired"] == 1
