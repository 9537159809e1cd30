"""Track-selective positioning against the simulator's truth: easy GPS and street GPS.

Run: ``python benchmarks/positioning_accuracy.py [--seeds 4 5 6] [--trams 12] [--minutes 15]
[--gps white urban feed late] [--set NAME=VALUE ...] [--gps-set NAME=VALUE ...]
[--figure reliability.png] [--hindsight]``

For each GPS model of :mod:`antikol.sim` — ``white`` (white noise σ 3 m plus a 1.5 m
Gauss–Markov bias, 10 % of fixes missing), ``urban`` (:meth:`GpsModel.urban`: lateral
multipath bias of several metres that persists for minutes and jumps, heavy tails, outages,
an odometer, no-fix reports in the tunnel), ``feed`` (the same receiver seen through an
operator's feed without a fix-quality field: a report without a fix repeats the last
position unflagged) and ``late`` (the same receiver's output 1 s old when the report is
stamped, the odometer current: not run unless asked, ``--gps late``) — a fleet is simulated
on the embedded Kraków map at up to 70 km/h and every report goes through
:class:`antikol.positioning.Positioner`, one cycle at a time, as in the analyser
(:func:`antikol.evaluation.positioning_accuracy`).

Printed: right track and direction on double track, right branch 40–60 m past a facing
switch (and of the reports with a position fix alone), the share of ``confident``
estimates that are on the wrong track, moving fixes on a track running the tram's way,
10-s windows that no permitted route connects, the along-track RMS error of the estimates
(and of the raw fixes projected on the track), the reliability table (estimates binned by
their ``probability`` against the share of them on the right track), and the wrong
estimates and broken windows pooled over the seeds.
``--set`` changes fields of :class:`~antikol.positioning.PositioningConfig` for the run
(e.g. ``--set stale_fix_run_m=1e12`` takes every repeated position as a fix, as before
stale reports were recognised). ``--gps-set`` changes fields of the street receivers
(:class:`~antikol.sim.urban_gps.UrbanGpsModel`: ``urban``, ``feed`` and ``late``), e.g.
``--gps-set bias_canyon_lateral_m=8 odometer=false`` for a stronger multipath bias and no
odometer. ``--hindsight`` scores the positions the whole run gives each report
(:mod:`antikol.positioning.hindsight`, an archive's analysis) instead of those shown at the
time. ``--figure`` draws the reliability diagram (needs
matplotlib).
"""

from __future__ import annotations

import argparse
import dataclasses

import trackmap
from antikol.evaluation.positioning_accuracy import PositioningScore, positioning_accuracy
from antikol.positioning import PositioningConfig
from antikol.sim import GpsModel, Simulator, fleet


def gps_models(**street: float | bool | str) -> dict[str, GpsModel]:
    """The receivers of the positioning benchmarks, by name (see the module); ``street``
    changes fields of the street receivers (``urban``, ``feed``, ``late``)."""
    return {
        "white": GpsModel(sigma_m=3.0, bias_sigma_m=1.5, bias_tau_s=60.0, missing_rate=0.10),
        "urban": GpsModel.urban(**street),
        "feed": GpsModel.urban(**{"fix_quality_field": False, **street}),
        "late": GpsModel.urban(**{"latency_s": 1.0, **street}),
    }


def street_settings(settings: list[str]) -> dict[str, float | bool | str]:
    """``NAME=VALUE`` settings of the street receivers
    (:func:`antikol.sim.urban_gps.street_settings`); a bad one ends the run with its message."""
    from antikol.sim.urban_gps import street_settings as parse

    try:
        return parse(settings)
    except ValueError as exc:
        raise SystemExit(f"--gps-set: {exc}") from None


def add_street_option(ap: argparse.ArgumentParser) -> None:
    """``--gps-set NAME=VALUE ...``: fields of the street receivers (see
    :func:`street_settings`)."""
    ap.add_argument(
        "--gps-set",
        metavar="NAME=VALUE",
        nargs="+",
        default=[],
        help="change UrbanGpsModel fields of the street receivers (urban, feed, late)",
    )


def _config(settings: list[str]) -> PositioningConfig:
    """The default configuration with ``NAME=VALUE`` settings applied (numbers)."""
    names = {f.name for f in dataclasses.fields(PositioningConfig)}
    changes: dict[str, float] = {}
    for item in settings:
        name, sep, value = item.partition("=")
        if not sep or name not in names:
            raise SystemExit(f"--set {item!r}: expected NAME=VALUE with a PositioningConfig field")
        try:
            changes[name] = float(value)
        except ValueError:
            raise SystemExit(f"--set {item!r}: {value!r} is not a number") from None
        if isinstance(getattr(PositioningConfig(), name), int):
            changes[name] = int(changes[name])
    return PositioningConfig(**changes)


def _pooled_reliability(scores: list[PositioningScore]) -> list[tuple[float, float, int, int]]:
    rows = []
    for bins in zip(*(s.reliability for s in scores), strict=True):
        rows.append(
            (bins[0].lo, bins[0].hi, sum(b.fixes for b in bins), sum(b.right for b in bins))
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[4, 5, 6])
    ap.add_argument("--trams", type=int, default=12)
    ap.add_argument("--minutes", type=float, default=15.0)
    ap.add_argument(
        "--gps", nargs="+", choices=sorted(gps_models()), default=["white", "urban", "feed"]
    )
    ap.add_argument(
        "--set",
        metavar="NAME=VALUE",
        nargs="+",
        default=[],
        help="change PositioningConfig fields for the run",
    )
    add_street_option(ap)
    ap.add_argument("--figure", help="write the reliability diagram to this PNG")
    ap.add_argument(
        "--hindsight",
        action="store_true",
        help="score the positions the whole run gives each report (antikol match's "
        "hindsight columns) instead of those shown at the time",
    )
    args = ap.parse_args()
    config = _config(args.set)
    street = street_settings(args.gps_set)
    net = trackmap.load_default()
    results: dict[str, list[PositioningScore]] = {}
    print(
        "| GPS | seed | fixes | right track, double track "
        "| right branch past a switch (with a fix) "
        "| confident and wrong | moving, right way | disconnected 10-s windows "
        "| along-track RMS error (raw fix) |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    models = gps_models(**street)
    for name in args.gps:
        gps = models[name]
        for seed in args.seeds:
            specs = fleet(net, args.trams, seed)
            sim = Simulator(net, specs, gps=gps, seed=seed, default_speed_mps=70 / 3.6)
            score = positioning_accuracy(
                net, sim.run(60.0 * args.minutes), config=config, hindsight=args.hindsight
            )
            results.setdefault(name, []).append(score)
            print(
                f"| {name} | {seed} | {score.fixes:,} "
                f"| {100 * score.double_track_right_share:.2f} % "
                f"| {100 * score.branch_accuracy:.2f} % "
                f"({100 * score.measured_branch_accuracy:.2f} %) "
                f"| {100 * score.confident_wrong_share:.2f} % of {score.confident_fixes:,} "
                f"| {100 * score.right_way_share:.2f} % "
                f"| {100 * score.disconnected_share:.1f} % of {score.windows:,} "
                f"| {score.along_rmse_m:.2f} m ({score.raw_along_rmse_m:.2f} m) |"
            )
    print("\nReliability (all seeds pooled): estimates by probability, share on the right track")
    print("\n| probability | " + " | ".join(f"{n}: fixes | {n}: right" for n in results) + " |")
    print("|---|" + "---:|---:|" * len(results))
    pooled = {n: _pooled_reliability(s) for n, s in results.items()}
    for k, (lo, hi, _, _) in enumerate(next(iter(pooled.values()))):
        cells = []
        for rows in pooled.values():
            _, _, fixes, right = rows[k]
            cells.append(f"{fixes:,} | {'-' if not fixes else f'{100 * right / fixes:.1f} %'}")
        print(f"| {lo:.2f}–{hi:.2f} | " + " | ".join(cells) + " |")
    print("\nPooled over the seeds: estimates that are wrong, and windows no route connects")
    print(
        "\n| GPS | double track: wrong of | past a switch: wrong of (with a fix) "
        "| confident: wrong of | disconnected windows of |"
    )
    print("|---|---:|---:|---:|---:|")
    for name, scores in results.items():

        def wrong(total: str, right: str, scores: list[PositioningScore] = scores) -> str:
            n = sum(getattr(s, total) for s in scores)
            return f"{n - sum(getattr(s, right) for s in scores):,} of {n:,}"

        confident = sum(s.confident_fixes for s in scores)
        print(
            f"| {name} | {wrong('double_track_fixes', 'double_track_right')} "
            f"| {wrong('after_switch_fixes', 'after_switch_correct')} "
            f"({wrong('after_switch_measured', 'after_switch_measured_correct')}) "
            f"| {sum(s.confident_wrong for s in scores):,} of {confident:,} "
            f"| {sum(s.disconnected_windows for s in scores):,} of "
            f"{sum(s.windows for s in scores):,} |"
        )
    if args.figure:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(4.5, 4.5))
        ax.plot([0, 1], [0, 1], color="0.6", lw=1, ls="--", label="calibrated")
        for name, rows in pooled.items():
            pts = [((lo + hi) / 2, right / fixes) for lo, hi, fixes, right in rows if fixes]
            ax.plot(*zip(*pts, strict=True), marker="o", label=f"{name} GPS")
        ax.set(xlabel="stated probability", ylabel="share on the right track", xlim=(0, 1))
        ax.legend()
        fig.tight_layout()
        fig.savefig(args.figure, dpi=120)


if __name__ == "__main__":
    main()
