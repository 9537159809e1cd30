"""The vectorised pair evaluation decides every pair exactly as the scalar rules do.

Traffic: trams at random places of the embedded Kraków map, running either way (wrong-way
hypotheses included), some standing, with GPS noise; five cycles each. Every ordered pair of
matched vehicles is decided by :class:`antikol.analysis.pairs.PairEvaluator` and by the
pair-by-pair loops of ``tests/_scalar_pairs.py``, under several configurations.
"""

from __future__ import annotations

import numpy as np
import pytest

import antikol
import trackmap
from antikol import AnalyserConfig
from antikol.analysis.pairs import PairEvaluator, PairSettings
from tests._scalar_pairs import pair_outcome


@pytest.fixture(scope="module")
def net() -> trackmap.TrackMap:
    return trackmap.load_default()


def _traffic(net: trackmap.TrackMap, n: int, cycles: int, seed: int):
    """Reports of ``n`` trams placed on random edges, either direction, 1 Hz."""
    rng = np.random.default_rng(seed)
    lengths = np.array([net.edge_length(e) for e in range(len(net.edges))])
    # a few busy edges, so that vehicles queue, meet and pass the same switches
    busy = rng.choice(len(lengths), size=max(n // 4, 1), p=lengths / lengths.sum())
    edges = rng.choice(busy, size=n)
    offset = rng.uniform(0.0, lengths[edges])
    direction = rng.choice([-1, 1], size=n)
    speed = np.where(rng.random(n) < 0.25, 0.0, rng.uniform(0.5, 14.0, size=n))
    # a third with RTK: their wrong-way running is seen (the others match the parallel track)
    rtk = rng.random(n) < 1 / 3
    braking = rng.choice(["none", "service", "emergency"], size=n, p=[0.8, 0.1, 0.1])
    out = []
    for c in range(cycles):
        batch = []
        for k in range(n):
            e = int(edges[k])
            s = float(np.clip(offset[k] + direction[k] * speed[k] * c, 0.0, lengths[e]))
            x, y = net.point_at(e, s)
            noise_m = 0.05 if rtk[k] else 2.5
            x += rng.normal(0.0, noise_m)
            y += rng.normal(0.0, noise_m)
            lon, lat = net.to_lonlat(x, y)
            course = net.heading_at(e, s, int(direction[k]))
            batch.append(
                antikol.VehicleReport(
                    f"T{k:03d}",
                    float(c),
                    float(lat),
                    float(lon),
                    float(max(speed[k] + rng.normal(0.0, 0.2), 0.0)),
                    float(course) % 360.0,
                    braking=str(braking[k]),
                    fix_quality=4 if rtk[k] else 1,
                    hdop=0.6 if rtk[k] else 1.2,
                )
            )
        out.append(batch)
    return out


CONFIGS = {
    "default": AnalyserConfig(),
    "moving leader": AnalyserConfig(rear_end_model="moving_leader"),
    "strict probabilities": AnalyserConfig(warning_probability=0.7, emergency_probability=0.02),
    "wrong way trusted at once": AnalyserConfig(wrong_way_evidence_s=0.0, max_hypotheses=4),
    "one hypothesis, no margins": AnalyserConfig(
        max_hypotheses=1, gap_margin_sigmas=0.0, anticipation_s=0.0, window_slack_s=0.0
    ),
}


@pytest.mark.parametrize("name", list(CONFIGS))
def test_every_pair_is_decided_as_by_the_scalar_rules(net, name):
    config = CONFIGS[name]
    an = antikol.Analyser(track_map=net, config=config)
    c = config
    settings = PairSettings(
        c.warning_probability,
        c.emergency_probability,
        c.closing_speed_mps,
        c.alarms.release_margin_m,
        c.alarms.release_time_s,
    )
    rules = an._rules
    evaluator = PairEvaluator(net, rules, settings)
    traction = antikol.load_profile("tram").traction_mps2
    compared = decided = alarms = wrong_way = capped = 0
    for batch in _traffic(net, 100, 7, seed=sum(map(ord, name))):
        an.update_many(batch)
        an.assess(batch[0].vehicle_id)
        cycle = an._refresh(an.table.clock)
        got = evaluator.evaluate(cycle, lambda vid: traction)
        matched = [v for v in cycle.views.values() if v.matched]
        wrong_way += sum(h.wrong_way for v in matched for h in v.hyps)
        for own in matched:
            for other in matched:
                if other is own:
                    continue
                expected = pair_outcome(net, cycle, own, other, rules, settings, traction)
                assert got.get(own.vehicle_id, {}).get(other.vehicle_id) == expected, (
                    own.vehicle_id,
                    other.vehicle_id,
                )
                compared += 1
                decided += expected is not None
                alarms += expected is not None and expected.level in ("warning", "emergency")
                capped += expected is not None and "(unconfirmed)" in expected.finding.detail
    # the traffic exercises what the evaluation has to get right
    assert compared > 10_000
    assert decided > 200
    assert alarms > 10
    assert wrong_way > 0
    if config.wrong_way_evidence_s > 7.0:  # never sustained in 7 s: wrong-way alarms capped
        assert capped > 0
    else:
        assert capped == 0


def test_owners_limit_the_evaluation_to_their_pairs(net):
    an = antikol.Analyser(track_map=net)
    for batch in _traffic(net, 60, 3, seed=5):
        an.update_many(batch)
    an.assess("T000")
    cycle = an._refresh(an.table.clock)
    c = an.config
    evaluator = PairEvaluator(
        net,
        an._rules,
        PairSettings(c.warning_probability, c.emergency_probability, 0.3, 15.0, 3.0),
    )
    everyone = evaluator.evaluate(cycle, lambda vid: 1.0)
    owners = sorted(everyone)[:3]
    some = evaluator.evaluate(cycle, lambda vid: 1.0, owners)
    assert set(some) == set(owners)
    assert all(some[o] == everyone[o] for o in owners)
