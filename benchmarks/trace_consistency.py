"""How well the checks without ground truth (``antikol match``) see positioning's failures.

Run: ``python benchmarks/trace_consistency.py [--seeds 4 5 6] [--trams 12] [--minutes 10]
[--gps urban feed] [--gps-set NAME=VALUE ...]``

A fleet is simulated on the embedded Kraków map as in ``benchmarks/positioning_accuracy.py``
and positioned twice: once judged against the simulator's truth
(:func:`antikol.evaluation.positioning_accuracy.positioning_accuracy`) and once checked as
a real trace would be, from the reports and the map alone
(:func:`antikol.evaluation.consistency.trace_consistency`). Printed per GPS model and seed:
moving fixes on a track running the tram's way (truth) beside those on a track running the
reported course's way (no truth), disconnected 10-s windows by both (the same rule, so the
same count on the same reports; the truth has no track position for a tram's first metres,
while its antenna is still behind its route's start, so the no-truth count over all reports
is given too), the confident estimates on a wrong track (truth), and the odometer pairs whose track
distance disagrees with the odometer (no truth). The no-truth checks are a lower bound on
the failures: a tram matched onto a parallel track that runs its way passes them.
``--gps-set`` changes fields of the street receivers as in ``positioning_accuracy.py``, e.g.
``--gps-set course_hold_speed_mps=0.5 course_held_at_start=true`` for receivers that hold
their course at a standstill, from before the trace began.
"""

from __future__ import annotations

import argparse

from positioning_accuracy import add_street_option, gps_models, street_settings  # same receivers

import trackmap
from antikol.evaluation.consistency import disconnected_windows, match_reports, trace_consistency
from antikol.evaluation.positioning_accuracy import evaluate_fixes
from antikol.sim import Simulator, fleet


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[4, 5, 6])
    ap.add_argument("--trams", type=int, default=12)
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--gps", nargs="+", choices=sorted(gps_models()), default=["urban", "feed"])
    add_street_option(ap)
    args = ap.parse_args()
    net = trackmap.load_default()
    print(
        "| GPS | seed | moving fixes | right way (truth) | course's way (no truth) "
        "| disconnected windows (truth / no truth, same reports / all reports) "
        "| confident and wrong (truth) "
        "| odometer disagrees (no truth) |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    models = gps_models(**street_settings(args.gps_set))
    for name in args.gps:
        for seed in args.seeds:
            specs = fleet(net, args.trams, seed)
            result = Simulator(
                net, specs, gps=models[name], seed=seed, default_speed_mps=70 / 3.6
            ).run(60.0 * args.minutes)
            judged = evaluate_fixes(net, result)
            fixes = match_reports(net, result.reports)
            check = trace_consistency(net, fixes)
            # the truth has no track position for a tram's first metres (its antenna behind
            # its route's start): the window rule on the same reports, then on all of them
            keys = {(e.vehicle_id, e.t) for e in judged}
            same = [f for f in fixes if (f.vehicle_id, f.t) in keys]
            moving = [e for e in judged if e.matched and e.moving]
            right_way = sum(e.right_way for e in moving) / max(len(moving), 1)
            confident = [e for e in judged if e.status == "confident"]
            confident_wrong = sum(not e.right_track for e in confident)
            print(
                f"| {name} | {seed} | {check.moving_fixes:,} "
                f"| {100 * right_way:.2f} % "
                f"| {100 * check.way_agrees_share:.2f} % "
                f"| {disconnected_windows(net, judged)[1]} "
                f"/ {disconnected_windows(net, same)[1]} "
                f"/ {check.disconnected_windows} of {check.windows:,} "
                f"| {confident_wrong:,} of {len(confident):,} "
                f"| {check.odometer_pairs - check.odometer_agrees:,} of "
                f"{check.odometer_pairs:,} |"
            )


if __name__ == "__main__":
    main()
