"""Speed-distance curves of a braking profile, like the tram ATP document's figures.

Left panel: permitted-speed curves towards a target point (default: stop at 400 m) for the
service and emergency brakes — the stepwise back-calculated braking curves (solid) and the
supervision curves including the brake build-up time (dashed), capped at the profile's
maximum speed. Right panel: stopping, warning and emergency distances against speed.

Usage::

    python examples/braking_curves.py -o braking_curves.png
    python examples/braking_curves.py --profile light_rail --target-m 600 --target-kmh 20
"""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np

from antikol.analysis.braking import emergency_distance, stopping_distance, warning_distance
from antikol.analysis.profiles import load_profile
from antikol.atp import permitted_speed, permitted_speed_curve

KMH_PER_MPS = 3.6


def main(argv: list[str] | None = None) -> None:
    """Draw the figure."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default="braking_curves.png", help="output image")
    parser.add_argument(
        "--profile", default="tram", help="profile name or .toml path (default: tram)"
    )
    parser.add_argument("--target-m", type=float, default=400.0, help="target point, m")
    parser.add_argument("--target-kmh", type=float, default=0.0, help="target speed, km/h")
    parser.add_argument("--step-m", type=float, default=10.0, help="back-calculation step, m")
    parser.add_argument(
        "--grade", type=float, default=0.0, help="gradient, positive downhill (0.04 = 4 %%)"
    )
    args = parser.parse_args(argv)

    profile = load_profile(args.profile)
    v_target = args.target_kmh / KMH_PER_MPS
    v_max_kmh = profile.max_speed_mps * KMH_PER_MPS

    fig, (ax_curve, ax_dist) = plt.subplots(1, 2, figsize=(12, 5), layout="constrained")

    colours = {"service": "tab:blue", "emergency": "tab:red"}
    for brake in ("service", "emergency"):
        x, v = permitted_speed_curve(
            args.target_m, v_target, profile, brake=brake, grade=args.grade, step_m=args.step_m
        )
        ax_curve.plot(
            x,
            np.minimum(v * KMH_PER_MPS, v_max_kmh),
            color=colours[brake],
            label=f"{brake} braking curve (ΔS = {args.step_m:g} m)",
        )
        x_fine = np.linspace(0.0, args.target_m, 801)
        v_sup = permitted_speed(
            args.target_m - x_fine,
            v_target,
            profile,
            brake=brake,
            grade=args.grade,
            delay_s=profile.buildup_s(brake),
        )
        ax_curve.plot(
            x_fine,
            np.minimum(v_sup * KMH_PER_MPS, v_max_kmh),
            color=colours[brake],
            linestyle="--",
            label=f"{brake} intervention (t1 = {profile.buildup_s(brake):g} s)",
        )
    ax_curve.axvline(args.target_m, color="k", linewidth=0.8)
    ax_curve.annotate(
        f"target {args.target_kmh:g} km/h",
        (args.target_m, args.target_kmh),
        textcoords="offset points",
        xytext=(-5, 10),
        ha="right",
    )
    ax_curve.set_xlabel("distance, m")
    ax_curve.set_ylabel("permitted speed, km/h")
    ax_curve.set_title(f"Permitted speed towards a target ({profile.name}, grade {args.grade:g})")
    ax_curve.set_xlim(0, args.target_m * 1.05)
    ax_curve.set_ylim(0, v_max_kmh * 1.1)
    ax_curve.grid(True, alpha=0.3)
    ax_curve.legend(loc="lower left", fontsize="small")

    v_kmh = np.linspace(0.0, v_max_kmh, 200)
    v = v_kmh / KMH_PER_MPS
    series = {
        "warning distance (reaction + service + margin)": warning_distance(
            v, profile, grade=args.grade
        ),
        "service stopping distance": stopping_distance(
            v, profile, brake="service", grade=args.grade
        ),
        "emergency distance (reaction + emergency)": emergency_distance(
            v, profile, grade=args.grade
        ),
        "emergency stopping distance": stopping_distance(
            v, profile, brake="emergency", grade=args.grade
        ),
    }
    styles = ["tab:orange", "tab:blue", "tab:purple", "tab:red"]
    for (label, d), colour in zip(series.items(), styles, strict=True):
        ax_dist.plot(v_kmh, d, color=colour, label=label)
    ax_dist.set_xlabel("speed, km/h")
    ax_dist.set_ylabel("distance, m")
    ax_dist.set_title(f"Distances against speed ({profile.name})")
    ax_dist.grid(True, alpha=0.3)
    ax_dist.legend(loc="upper left", fontsize="small")

    fig.savefig(args.output, dpi=120)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
