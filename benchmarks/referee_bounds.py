"""What any lamp can reach on the referee's traffic, and where the analyser's lamp stands.

Run: ``python benchmarks/referee_bounds.py [--seeds 1 2 3] [--trams 40] [--minutes 15]``
(from the repository root, with ``../shared/referee`` beside it).

The referee (``../shared/referee``) scores a lamp against its ground truth. Some of its
targets pull against each other: a long lead time needs the lamp on early, but a lamp on
more than 10 s before any required second counts as nuisance; and the required seconds
themselves come and go (a follower's closing speed changes sign in a queue), so even a
lamp that knows the truth toggles. This script measures those limits with **oracle
lamps** built from the referee's own ground truth and scored by its own scorer:

* ``oracle, lead L s``: the pair alarm is on at every required second and from ``L``
  seconds before the start of every counted episode (a lamp that knows the future);
* ``oracle, widest``: on at every second the scorer does not count as nuisance (10 s
  before to 5 s after any required second): the fewest toggles possible without nuisance;
* ``oracle, widest, gaps <= G s bridged``: the same lamp kept on through every off-time of
  up to G s: fewer toggles bought with nuisance (bridging the shortest gaps first is the
  cheapest way to buy them).

It then runs ``antikol.Analyser(track_map=...)`` as the referee does and splits its false
alarms and lamp-on nuisance by what raised them: a conflict that depends on a branch the
other (or the own) tram may or may not take (``ambiguous``: no route in the reports), or
a definite one.
"""

from __future__ import annotations

import argparse
import itertools
import sys
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

import antikol
import trackmap

_ALARM = ("warning", "emergency")


def _referee(path: Path):
    sys.path.insert(0, str(path))
    import graph  # type: ignore[import-not-found]
    import score  # type: ignore[import-not-found]
    import sim  # type: ignore[import-not-found]
    import truth  # type: ignore[import-not-found]

    return graph, score, sim, truth


def _need(truth) -> dict[str, set[int]]:
    need: dict[str, set[int]] = defaultdict(set)
    for (a, _b), p in truth.pairs.items():
        need[a].update((p.k0 + np.flatnonzero(p.required)).tolist())
    return need


def _bridge(lamp: set[int], gap_s: int) -> None:
    """Keep a lamp on through every off-time of at most ``gap_s`` seconds."""
    ks = sorted(lamp)
    for a, b in itertools.pairwise(ks):
        if 1 < b - a <= gap_s + 1:
            lamp.update(range(a + 1, b))


def _oracle(score_mod, res, truth, episodes, lead_s: int | None, bridge_s: int = 0):
    alarms = score_mod.Alarms()
    for (a, b), p in truth.pairs.items():
        ks = (p.k0 + np.flatnonzero(p.required)).tolist()
        if lead_s is None:  # widest: everything that is not nuisance
            ks = [k + d for k in ks for d in range(-10, 6)]
        alarms.pair[(a, b)].update(ks)
        alarms.lamp[a].update(ks)
    for e in episodes if lead_s is not None else ():
        k = int(e["t_start"])
        span = range(k - lead_s, k + 1)
        alarms.pair[(e["a"], e["b"])].update(span)
        alarms.lamp[e["a"]].update(span)
    for lamp in alarms.lamp.values():
        _bridge(lamp, bridge_s)
    return score_mod.score(res, truth, alarms)


def _run_analyser(score_mod, res, net):
    """Feed the referee's reports as its harness does; keep every alarm-level threat."""
    an = antikol.Analyser(track_map=net)
    alarms = score_mod.Alarms()
    threats: dict[tuple[str, str, int], antikol.Threat] = {}
    for k, reps in enumerate(res.reports):
        for r in reps:
            an.update(antikol.VehicleReport(**r))
        for r in reps:
            a = an.assess(r["vehicle_id"])
            if a.level in _ALARM:
                alarms.lamp[a.own_id].add(k)
            for th in a.threats:
                if th.level in _ALARM:
                    alarms.pair[(a.own_id, th.vehicle_id)].add(k)
                    threats[(a.own_id, th.vehicle_id, k)] = th
    return alarms, threats


def _cause(th: antikol.Threat | None) -> str:
    if th is None:
        return "held"
    return f"{th.kind}, {'ambiguous' if th.ambiguous else 'definite'}"


def _nuisance_causes(res, truth, alarms, threats) -> Counter[str]:
    need = _need(truth)
    out: Counter[str] = Counter()
    by_own: dict[tuple[str, int], list] = defaultdict(list)
    for (a, _b, k), th in threats.items():
        by_own[(a, k)].append(th)
    for v, ks in alarms.lamp.items():
        near = {k + d for k in need.get(v, ()) for d in range(-10, 6)}
        for k in ks - near:
            ths = by_own.get((v, k))
            out[_cause(ths[0] if ths else None)] += 1
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--trams", type=int, default=40)
    ap.add_argument("--minutes", type=float, default=15.0)
    ap.add_argument(
        "--referee", type=Path, default=Path(__file__).resolve().parents[1] / "../shared/referee"
    )
    ap.add_argument("--no-analyser", action="store_true", help="oracle lamps only")
    args = ap.parse_args()
    graph_mod, score_mod, sim_mod, truth_mod = _referee(args.referee.resolve())
    g = graph_mod.TrackGraph(graph_mod.DEFAULT_PBF)
    net = (
        None
        if args.no_analyser
        else trackmap.build(str(graph_mod.DEFAULT_PBF), kinds=("tram",), driving_side="right")
    )
    rows, causes = [], []
    for seed in args.seeds:
        cfg = sim_mod.SimConfig(n_trams=args.trams, duration_s=args.minutes * 60.0, seed=seed)
        res = sim_mod.Simulator(g, cfg).run()
        truth = truth_mod.label(res)
        base = score_mod.score(res, truth, score_mod.Alarms(), keep_episodes=True)
        episodes = base["episodes"]
        for name, lead in (
            ("oracle, lead 0 s", 0),
            ("oracle, lead 10 s", 10),
            ("oracle, lead 15 s", 15),
            ("oracle, lead 21 s", 21),
            ("oracle, widest", None),
        ):
            rows.append((seed, name, _oracle(score_mod, res, truth, episodes, lead)))
        for gap in (30, 120):
            m = _oracle(score_mod, res, truth, episodes, None, bridge_s=gap)
            rows.append((seed, f"oracle, widest, gaps <= {gap} s bridged", m))
        if net is not None:
            alarms, threats = _run_analyser(score_mod, res, net)
            m = score_mod.score(res, truth, alarms, keep_episodes=True)
            rows.append((seed, "antikol track-aware", m))
            fa = Counter(
                _cause(threats.get((f["a"], f["b"], int(f["t_start"]))))
                for f in m["false_alarm_episode_list"]
            )
            causes.append((seed, fa, _nuisance_causes(res, truth, alarms, threats)))
    print("| seed | lamp | timely | lead, mean | toggles /veh-h | nuisance | FA /veh-h |")
    print("|---:|---|---:|---:|---:|---:|---:|")
    for seed, name, m in rows:
        lead = m["lead_time_s"]["mean"]
        print(
            f"| {seed} | {name} | {100 * m['detection_rate']:.1f} % | "
            f"{'-' if lead is None else f'{lead:.1f} s'} | "
            f"{m['lamp_toggles_per_vehicle_hour']:.1f} | "
            f"{100 * m['nuisance_lamp_share']:.2f} % | {m['false_alarms_per_vehicle_hour']:.2f} |"
        )
    for seed, fa, nuis in causes:
        print(f"\nseed {seed}: false-alarm episodes by cause: {dict(fa.most_common())}")
        print(f"seed {seed}: nuisance lamp-seconds by cause: {dict(nuis.most_common())}")


if __name__ == "__main__":
    main()
