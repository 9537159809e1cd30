"""Figures of compared runs: trajectories on the map with the alarm state along them.

Like Figs. 10 and 11 of the 2008 paper: each vehicle's true path is drawn as dots, red
where its lamp was on (level ``warning`` or above) and grey where it was off, once for the
sector rule and once for the track-aware analyser.
"""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from antikol.evaluation.scoring import Comparison
from trackmap import TrackMap

__all__ = ["comparison_figure"]


def comparison_figure(
    comparison: Comparison,
    net: TrackMap,
    path: str | os.PathLike[str],
    *,
    vehicles: tuple[str, ...] = (),
    dpi: int = 130,
) -> Path:
    """Draw a comparison: one panel per method, trajectories coloured by lamp state.

    Parameters
    ----------
    comparison : Comparison
        From :func:`antikol.evaluation.compare`.
    net : TrackMap
        The map of the run (its tracks are drawn in grey).
    path : path-like
        Output image (``.png``, ``.svg``, ``.pdf``).
    vehicles : tuple of str
        Vehicles to draw (default: all).
    dpi : int

    Returns
    -------
    Path
    """
    out = Path(path)
    if not out.parent.exists():
        raise OSError(f"cannot write {out}: directory {out.parent} does not exist")
    result = comparison.result
    times = comparison.truth.times_s
    vids = list(vehicles or result.truth)
    pts = {}
    for v in vids:
        truth = result.truth[v]
        live = comparison.truth.in_service[v]
        idx = np.array([truth.index_at(t) for t in times[live]], dtype=int)
        pts[v] = (truth.x_m[idx], truth.y_m[idx], live)
    allx = np.concatenate([p[0] for p in pts.values()]) if pts else np.zeros(1)
    ally = np.concatenate([p[1] for p in pts.values()]) if pts else np.zeros(1)
    pad = max(60.0, 0.08 * max(np.ptp(allx), np.ptp(ally)))
    box = (allx.min() - pad, allx.max() + pad, ally.min() - pad, ally.max() + pad)
    fig = Figure(figsize=(13, 6.5), dpi=dpi)
    axes = fig.subplots(1, 2, sharex=True, sharey=True)
    segs = [np.asarray(e.geometry.coords) for e in net.edges]
    for ax, method in zip(axes, ("sector", "track"), strict=True):
        ax.add_collection(LineCollection(segs, colors="#bbbbbb", linewidths=1.0, zorder=1))
        log = comparison.logs[method]
        for v, (x, y, live) in pts.items():
            lamp = log.lamp[v][live]
            ax.scatter(x[~lamp], y[~lamp], s=4, c="#7a8794", zorder=2, linewidths=0)
            ax.scatter(x[lamp], y[lamp], s=7, c="#d62728", zorder=3, linewidths=0)
            if len(x) and len(vids) <= 6:
                ax.annotate(v, (x[0], y[0]), fontsize=8, xytext=(3, 3), textcoords="offset points")
        score = comparison.sector if method == "sector" else comparison.track
        title = "sector rule (2008 paper)" if method == "sector" else "track-aware analyser"
        ax.set_title(
            f"{title}\nrequired {score.required}: timely {score.timely}, "
            f"missed {score.missed} ({score.late} late); "
            f"false-alarm episodes {score.false_alarm_episodes}",
            fontsize=9,
        )
        ax.set_xlim(box[0], box[1])
        ax.set_ylim(box[2], box[3])
        ax.set_aspect("equal")
        ax.set_xlabel("x east (m)")
        ax.grid(alpha=0.2)
    axes[0].set_ylabel("y north (m)")
    fig.suptitle(
        f"{comparison.name}: lamp on (red) / off (grey) along the true paths",
        fontsize=11,
    )
    fig.text(0.99, 0.01, net.metadata.attribution, ha="right", fontsize=7, color="#555555")
    fig.tight_layout()
    fig.savefig(out)
    return out
