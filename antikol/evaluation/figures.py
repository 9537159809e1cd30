"""Figures of compared runs: where the two analysers differ, on the map.

Like Figs. 10 and 11 of the 2008 paper, each vehicle's true path is drawn as dots, red
where its lamp was on (level ``warning`` or above) and grey where it was off, once for the
sector rule and once for the track-aware analyser (the top row). A whole network at once
hides what matters, so the places where the analysers differ — a warning one of them
missed, a false alarm only one of them gave — are found, ranked (misses first) and drawn
enlarged in a row of zoom panels below, numbered on the overview panels: in each, the
paths of the vehicles involved around the time of the events, coloured by which analyser
had the lamp on, and the events marked.

>>> _cluster([(0.0, 0.0, 1), (50.0, 0.0, 5), (900.0, 0.0, 1)], radius_m=150.0)
[[1, 0], [2]]
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle

from antikol.evaluation.groundtruth import CLEAR
from antikol.evaluation.scoring import Comparison
from trackmap import TrackMap

__all__ = ["Difference", "comparison_figure", "differences"]

#: Colours of the lamp states of a vehicle in the zoom panels.
BOTH_COLOUR = "#7b2d8b"
SECTOR_ONLY_COLOUR = "#f58231"
TRACK_ONLY_COLOUR = "#2166ac"
OFF_COLOUR = "#9aa3ad"
_METHOD_COLOUR = {"sector": SECTOR_ONLY_COLOUR, "track": TRACK_ONLY_COLOUR}
_MARKER = {"missed": "v", "false_alarm": "X"}
_LABEL = {"sector": "sector rule", "track": "track-aware"}


@dataclass(frozen=True)
class Difference:
    """A missed warning or false alarm of one analyser that the other did not share.

    Attributes
    ----------
    method : str
        ``sector`` or ``track``: whose event it is.
    category : str
        ``missed`` or ``false_alarm``.
    own, other : str
        The vehicle warned (or not) and the one it was about.
    t0_s, t1_s : float
        Start and end of the event, s.
    x_m, y_m : float
        Where the own vehicle was at the start (local frame), m.
    """

    method: str
    category: str
    own: str
    other: str
    t0_s: float
    t1_s: float
    x_m: float
    y_m: float


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    if not mask.any():
        return []
    padded = np.concatenate([[False], mask, [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def differences(comparison: Comparison, vehicles: Sequence[str] = ()) -> list[Difference]:
    """The missed warnings and false alarms of each analyser that the other did not share.

    A miss differs when the other analyser has no miss of the same pair and start; a
    false-alarm episode (warnings on a clearly conflict-free pair, as scored) differs when
    the other analyser did not warn about that pair at any time during it.

    Parameters
    ----------
    comparison : Comparison
    vehicles : sequence of str
        Only events between these vehicles (default: all).

    Returns
    -------
    list of Difference
        Misses first, then false alarms, each in time order.
    """
    shown = set(vehicles or comparison.result.truth)
    times = comparison.truth.times_s
    truth = comparison.result.truth
    out: list[Difference] = []

    def where(own: str, t: float) -> tuple[float, float]:
        tr = truth[own]
        i = tr.index_at(min(max(t, float(tr.t_s[0])), float(tr.t_s[-1])))
        return float(tr.x_m[i]), float(tr.y_m[i])

    scores = {"sector": comparison.sector, "track": comparison.track}
    for method, other_method in (("sector", "track"), ("track", "sector")):
        theirs = {(m.own, m.other, m.start_s) for m in scores[other_method].missed_detail}
        for m in scores[method].missed_detail:
            if m.own in shown and m.other in shown and (m.own, m.other, m.start_s) not in theirs:
                x, y = where(m.own, m.start_s)
                out.append(Difference(method, "missed", m.own, m.other, m.start_s, m.start_s, x, y))
    for method, other_method in (("sector", "track"), ("track", "sector")):
        mine, theirs_log = comparison.logs[method], comparison.logs[other_method]
        for (own, other), warn in sorted(mine.pair_warn.items()):
            if own not in shown or other not in shown or not warn.any():
                continue
            clear = comparison.truth.state[(own, other)] == CLEAR
            for a, b in _runs(warn & clear):
                if theirs_log.pair_warn[(own, other)][a:b].any():
                    continue
                x, y = where(own, float(times[a]))
                out.append(
                    Difference(
                        method,
                        "false_alarm",
                        own,
                        other,
                        float(times[a]),
                        float(times[b - 1]),
                        x,
                        y,
                    )
                )
    out.sort(key=lambda d: (d.category != "missed", d.t0_s))
    return out


def _cluster(points: Sequence[tuple[float, float, int]], *, radius_m: float) -> list[list[int]]:
    """Group weighted points lying within ``radius_m`` of a group's first point; groups by
    falling total weight (then first index), members by falling weight."""
    order = sorted(range(len(points)), key=lambda i: -points[i][2])
    groups: list[list[int]] = []
    for i in order:
        x, y, _ = points[i]
        for g in groups:
            gx, gy, _ = points[g[0]]
            if np.hypot(x - gx, y - gy) <= radius_m:
                g.append(i)
                break
        else:
            groups.append([i])
    groups.sort(key=lambda g: (-sum(points[i][2] for i in g), min(g)))
    return groups


def _places(diffs: list[Difference]) -> list[list[Difference]]:
    """The differences grouped by place (within 150 m), heaviest first (a miss weighs 5)."""
    weights = [(d.x_m, d.y_m, 5 if d.category == "missed" else 1) for d in diffs]
    return [[diffs[i] for i in g] for g in _cluster(weights, radius_m=150.0)]


def _pick(places: list[list[Difference]], n: int) -> list[list[Difference]]:
    """Up to ``n`` places: first the heaviest place of each kind of difference (a miss or
    a false alarm of either analyser), then the other places with misses, then the
    heaviest; those with misses are shown first."""
    chosen: list[list[Difference]] = []

    def add(place: list[Difference]) -> None:
        if len(chosen) < n and all(place is not c for c in chosen):
            chosen.append(place)

    for method in ("track", "sector"):
        for category in ("missed", "false_alarm"):
            for place in places:
                if any(d.method == method and d.category == category for d in place):
                    add(place)
                    break
    for place in places:
        if any(d.category == "missed" for d in place):
            add(place)
    for place in places:
        add(place)
    rank = {id(p): i for i, p in enumerate(places)}
    chosen.sort(key=lambda p: (all(d.category != "missed" for d in p), rank[id(p)]))
    return chosen


def comparison_figure(
    comparison: Comparison,
    net: TrackMap,
    path: str | os.PathLike[str],
    *,
    vehicles: tuple[str, ...] = (),
    dpi: int = 130,
    zooms: int = 6,
) -> Path:
    """Draw a comparison: lamp states per method, and zooms where the methods differ.

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
    zooms : int
        Largest number of zoom panels on the places where the analysers differ, three
        per row (0: the overview panels only). Each kind of difference (a miss or a false
        alarm of either analyser) gets a panel first, then places with misses, then the
        places with the most false alarms.

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
    if not len(allx):
        allx, ally = np.zeros(1), np.zeros(1)
    pad = max(60.0, 0.08 * max(np.ptp(allx), np.ptp(ally)))
    box = (allx.min() - pad, allx.max() + pad, ally.min() - pad, ally.max() + pad)

    diffs = differences(comparison, vids) if zooms > 0 else []
    all_places = _places(diffs)
    places = _pick(all_places, zooms)
    zoom_rows = -(-len(places) // 3)
    fig = Figure(figsize=(13, 6.5 + 4.3 * zoom_rows), dpi=dpi)
    if places:
        grid = fig.add_gridspec(1 + zoom_rows, 6, height_ratios=[1.45] + [1.0] * zoom_rows)
        ax0 = fig.add_subplot(grid[0, :3])
        ax1 = fig.add_subplot(grid[0, 3:], sharex=ax0, sharey=ax0)
        overview = [ax0, ax1]
        zoom_axes = [
            fig.add_subplot(grid[1 + i // 3, 2 * (i % 3) : 2 * (i % 3) + 2])
            for i in range(len(places))
        ]
    else:
        overview = list(fig.subplots(1, 2, sharex=True, sharey=True))
        zoom_axes = []
    segs = [np.asarray(e.geometry.coords) for e in net.edges]
    for ax, method in zip(overview, ("sector", "track"), strict=True):
        ax.add_collection(LineCollection(segs, colors="#bbbbbb", linewidths=1.0, zorder=1))
        log = comparison.logs[method]
        for v, (x, y, live) in pts.items():
            lamp = log.lamp[v][live]
            ax.scatter(x[~lamp], y[~lamp], s=4, c="#7a8794", zorder=2, linewidths=0)
            ax.scatter(x[lamp], y[lamp], s=7, c="#d62728", zorder=3, linewidths=0)
            if len(x) and len(vids) <= 6:
                ax.annotate(v, (x[0], y[0]), fontsize=8, xytext=(3, 3), textcoords="offset points")
        for d in diffs:
            if d.method == method:
                ax.scatter(
                    [d.x_m],
                    [d.y_m],
                    s=40,
                    marker=_MARKER[d.category],
                    c="#000000" if d.category == "missed" else _METHOD_COLOUR[method],
                    edgecolors="white",
                    linewidths=0.6,
                    zorder=5,
                )
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
    overview[0].set_ylabel("y north (m)")
    for k, (place, zax) in enumerate(zip(places, zoom_axes, strict=True), 1):
        zbox = _zoom(zax, k, place, comparison, segs, times)
        for ax in overview:
            ax.add_patch(
                Rectangle(
                    (zbox[0], zbox[2]),
                    zbox[1] - zbox[0],
                    zbox[3] - zbox[2],
                    fill=False,
                    edgecolor="#000000",
                    linewidth=1.0,
                    zorder=6,
                )
            )
            ax.annotate(
                str(k),
                (zbox[1], zbox[3]),
                fontsize=9,
                fontweight="bold",
                xytext=(2, 2),
                textcoords="offset points",
                zorder=7,
            )
    if zoom_axes:
        zoom_axes[0].set_ylabel("y north (m)")
        handles = [
            Line2D([], [], ls="", marker="o", color=BOTH_COLOUR, label="lamp on: both"),
            Line2D([], [], ls="", marker="o", color=SECTOR_ONLY_COLOUR, label="sector rule only"),
            Line2D([], [], ls="", marker="o", color=TRACK_ONLY_COLOUR, label="track-aware only"),
            Line2D([], [], ls="", marker="o", color=OFF_COLOUR, label="lamp off"),
            Line2D([], [], ls="", marker="v", color="#000000", label="missed warning"),
            Line2D([], [], ls="", marker="X", color="#555555", label="false alarm"),
        ]
        fig.legend(handles=handles, loc="lower center", ncol=6, fontsize=8, frameon=False)
    fig.suptitle(
        f"{comparison.name}: lamp on (red) / off (grey) along the true paths"
        + (
            f"; {len(diffs)} missed warning(s) or false alarm(s) of one analyser only, at "
            f"{len(all_places)} place(s): {len(places)} enlarged below"
            if places
            else ("" if zooms <= 0 else "; the analysers never differ")
        ),
        fontsize=11,
    )
    fig.text(0.99, 0.005, net.metadata.attribution, ha="right", fontsize=7, color="#555555")
    fig.tight_layout(rect=(0, 0.03 if places else 0.0, 1, 1))
    fig.savefig(out)
    return out


def _zoom(
    ax: Axes,
    number: int,
    place: list[Difference],
    comparison: Comparison,
    segs: list[np.ndarray],
    times: np.ndarray,
) -> tuple[float, float, float, float]:
    """Draw one zoom panel; returns its box (x0, x1, y0, y1), m."""
    xs = np.array([d.x_m for d in place])
    ys = np.array([d.y_m for d in place])
    half = max(120.0, 0.5 * max(np.ptp(xs), np.ptp(ys)) + 60.0)
    cx, cy = float(xs.mean()), float(ys.mean())
    zbox = (cx - half, cx + half, cy - half, cy + half)
    ax.add_collection(LineCollection(segs, colors="#bbbbbb", linewidths=1.2, zorder=1))
    involved = sorted({d.own for d in place} | {d.other for d in place})
    t_lo = min(d.t0_s for d in place) - 40.0
    t_hi = max(d.t1_s for d in place) + 15.0
    window = (times >= t_lo) & (times <= t_hi)
    sector, track = comparison.logs["sector"], comparison.logs["track"]
    for v in involved:
        tr = comparison.result.truth[v]
        ks = np.flatnonzero(window & comparison.truth.in_service[v])
        if not len(ks):
            continue
        idx = np.array([tr.index_at(float(times[k])) for k in ks], dtype=int)
        x, y = tr.x_m[idx], tr.y_m[idx]
        s_on, t_on = sector.lamp[v][ks], track.lamp[v][ks]
        for mask, colour in (
            (~s_on & ~t_on, OFF_COLOUR),
            (s_on & ~t_on, SECTOR_ONLY_COLOUR),
            (~s_on & t_on, TRACK_ONLY_COLOUR),
            (s_on & t_on, BOTH_COLOUR),
        ):
            ax.scatter(x[mask], y[mask], s=9, c=colour, linewidths=0, zorder=2)
        inside = (x >= zbox[0]) & (x <= zbox[1]) & (y >= zbox[2]) & (y <= zbox[3])
        if inside.any():
            j = int(np.flatnonzero(inside)[0])
            ax.annotate(v, (x[j], y[j]), fontsize=7, xytext=(3, 3), textcoords="offset points")
    for d in place:
        ax.scatter(
            [d.x_m],
            [d.y_m],
            s=70,
            marker=_MARKER[d.category],
            c="#000000" if d.category == "missed" else _METHOD_COLOUR[d.method],
            edgecolors="white",
            linewidths=0.8,
            zorder=5,
        )
    counts: dict[tuple[str, str], int] = {}
    for d in place:
        counts[(d.method, d.category)] = counts.get((d.method, d.category), 0) + 1
    what = ", ".join(
        f"{_LABEL[m]}: {n} {'missed' if c == 'missed' else 'false alarm(s)'}"
        for (m, c), n in sorted(counts.items(), key=lambda kv: (kv[0][1] != "missed", kv[0]))
    )
    t0 = min(d.t0_s for d in place)
    ax.set_title(f"{number}: {what}\nfrom t = {t0:.0f} s ({', '.join(involved)})", fontsize=8)
    ax.set_xlim(zbox[0], zbox[1])
    ax.set_ylim(zbox[2], zbox[3])
    ax.set_aspect("equal")
    ax.tick_params(labelsize=7)
    ax.set_xlabel("x east (m)", fontsize=8)
    ax.grid(alpha=0.2)
    return zbox
