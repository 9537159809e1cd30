"""Static figures of a map with matplotlib: PNG, SVG or PDF in the local metric frame.

matplotlib is used through its object-oriented API only (:class:`matplotlib.figure.Figure`
rendered by the Agg/SVG/PDF canvases): no window is ever opened, no pyplot state is touched,
so plotting is safe in scripts, servers and tests. It is imported by :func:`plot_map`
only, so trackmap works without it.
"""

from __future__ import annotations

import math
import os
import pathlib
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt
import shapely

from trackmap.model import Path
from trackmap.network import TrackMap
from trackmap.optional import require
from trackmap.plot_style import (
    CROSSING_STYLE,
    GRADE_SEPARATED_STYLE,
    HIGHLIGHT_COLOURS,
    NODE_STYLES,
    STOP_STYLE,
    TRACK_COLOURS,
    TRACK_LABELS,
    MarkerStyle,
    default_title,
    output_path,
    track_class,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["IMAGE_SUFFIXES", "Extent", "plot_map"]

#: Output suffixes written by :func:`plot_map`.
IMAGE_SUFFIXES = (".png", ".svg", ".pdf")

Extent = Sequence[float] | Literal["network", "paths"]

_TUNNEL_DASHES = (0, (4.0, 2.0))
_BRIDGE_CASING = "#202020"

_SCALE_STEPS_M = (1, 2, 5, 10, 20, 25, 50, 100, 200, 250, 500, 1000, 2000, 2500, 5000, 10000)


def _nice_scale_length(span_m: float) -> float:
    """A round scale-bar length of roughly a fifth of ``span_m`` (metres)."""
    target = max(span_m / 5.0, 1.0)
    best = float(_SCALE_STEPS_M[0])
    for step in _SCALE_STEPS_M:
        if step <= target:
            best = float(step)
    if target >= 2 * _SCALE_STEPS_M[-1]:
        best = float(10 ** math.floor(math.log10(target)))
    return best


def _format_metres(length_m: float) -> str:
    if length_m >= 1000:
        km = length_m / 1000.0
        return f"{km:g} km"
    return f"{length_m:g} m"


def _segments(geoms: Iterable[shapely.LineString]) -> list[npt.NDArray[np.float64]]:
    return [np.asarray(g.coords, dtype=float)[:, :2] for g in geoms]


def _bounds_of(arrays: Sequence[npt.NDArray[np.float64]]) -> tuple[float, float, float, float]:
    stacked = np.concatenate(arrays, axis=0)
    return (
        float(stacked[:, 0].min()),
        float(stacked[:, 1].min()),
        float(stacked[:, 0].max()),
        float(stacked[:, 1].max()),
    )


def _pad_bounds(
    bounds: tuple[float, float, float, float], frac: float, min_pad_m: float
) -> tuple[float, float, float, float]:
    x0, y0, x1, y1 = bounds
    pad = max(frac * max(x1 - x0, y1 - y0), min_pad_m)
    return x0 - pad, y0 - pad, x1 + pad, y1 + pad


# -- static figure ------------------------------------------------------------------------
def plot_map(
    net: TrackMap,
    path: str | os.PathLike[str],
    *,
    title: str | None = None,
    show_stops: bool = False,
    highlight_paths: Sequence[Path] | None = None,
    figsize: tuple[float, float] = (12, 12),
    dpi: int = 150,
    extent: Extent = "network",
    show_scale_bar: bool = True,
) -> pathlib.Path:
    """Draw the network in its local metric frame to a PNG, SVG or PDF file.

    Tracks are coloured by class (main line; ``yard``, ``siding``, ``spur`` and
    ``crossover`` service tracks), tunnels are dashed and bridges drawn with a dark casing.
    Point switches, diamond crossings, double slips, buffer stops and unknown junctions
    each get their own marker; at-grade crossings without a shared node (conflict points
    of kind ``crossing``) are ringed in red, grade-separated crossings marked with a grey
    cross. The axes are in metres (x east, y north of the map's local frame) with equal
    aspect and a scale bar; the data attribution is printed in the lower right corner and
    the legend (with counts) below the map.

    Parameters
    ----------
    net : TrackMap
        The map to draw.
    path : path-like
        Output file; the suffix (``.png``, ``.svg`` or ``.pdf``) chooses the format. Its
        directory must exist.
    title : str, optional
        Figure title; default: the source file name, edge count and track length.
    show_stops : bool
        Also mark the stops (``net.stops``).
    highlight_paths : sequence of trackmap.Path, optional
        Routes to draw thick on top of the network, each in its own colour and labelled
        with its zone (e.g. the result of :meth:`TrackMap.paths_ahead`: the sensitivity
        area ahead of a vehicle). The common start is marked.
    figsize : (float, float)
        Figure size, inches.
    dpi : int
        Resolution of raster output, dots per inch (ignored by SVG/PDF except for
        embedded rasters).
    extent : {"network", "paths"} or (xmin, ymin, xmax, ymax)
        Part of the map to show: the whole network (default), the highlighted paths with a
        margin, or a box in the local frame, metres.
    show_scale_bar : bool
        Draw a scale bar in the lower left corner.

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    ValueError
        Unsupported suffix, ``extent="paths"`` without paths, or a degenerate extent box.
    trackmap.errors.SourceError
        The output directory does not exist (an ``OSError``).
    trackmap.errors.MissingDependencyError
        matplotlib is not installed (an ``ImportError``).
    """
    require("matplotlib", purpose="plot_map")
    from matplotlib.figure import Figure

    out = output_path(path, IMAGE_SUFFIXES, "plot_map")
    paths = list(highlight_paths or [])
    if extent == "paths" and not paths:
        raise ValueError("extent='paths' needs highlight_paths")

    fig = Figure(figsize=figsize, dpi=dpi, layout="constrained")
    ax = fig.add_subplot()
    handles: list[Any] = []
    _draw_tracks(ax, net, handles)
    _draw_points(ax, net, handles, show_stops=show_stops)
    path_arrays = _draw_paths(ax, net, paths, handles)

    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.ticklabel_format(style="plain", useOffset=False)
    ax.grid(True, color="#e4e4e4", linewidth=0.5, zorder=0)
    ax.set_axisbelow(True)
    ax.set_title(title if title is not None else default_title(net))

    net_arrays = _segments(e.geometry for e in net.edges)
    if not isinstance(extent, str):
        box = tuple(float(v) for v in extent)
        if len(box) != 4 or not (box[0] < box[2] and box[1] < box[3]):
            raise ValueError(
                f"extent must be (xmin, ymin, xmax, ymax) with min < max, got {extent}"
            )
    elif extent == "paths":
        box = _pad_bounds(_bounds_of(path_arrays), 0.15, 30.0)
    elif extent == "network":
        box = _pad_bounds(_bounds_of(net_arrays), 0.02, 5.0) if net_arrays else (-1, -1, 1, 1)
    else:
        raise ValueError(f"extent must be 'network', 'paths' or a box, got {extent!r}")
    ax.set_xlim(box[0], box[2])
    ax.set_ylim(box[1], box[3])

    if show_scale_bar:
        _add_scale_bar(ax, box)
    ax.text(
        0.995,
        0.005,
        net.metadata.attribution,
        transform=ax.transAxes,
        ha="right",
        va="bottom",
        fontsize=8,
        color="#333333",
        bbox={"boxstyle": "round,pad=0.25", "facecolor": "white", "alpha": 0.85, "lw": 0},
        zorder=10,
    )
    if handles:
        fig.legend(
            handles=handles,
            loc="outside lower center",
            ncols=3 if len(handles) > 4 else len(handles),
            fontsize=8,
            frameon=False,
        )
    fig.savefig(out, format=out.suffix.lower().lstrip("."), dpi=dpi)
    fig.clear()  # not registered with pyplot: nothing else to close
    return out


def _draw_tracks(ax: Axes, net: TrackMap, handles: list[Any]) -> None:
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    widths = {"main": 1.0}
    groups: dict[tuple[str, bool], list[shapely.LineString]] = {}
    bridges: list[shapely.LineString] = []
    for e in net.edges:
        groups.setdefault((track_class(e), e.tunnel), []).append(e.geometry)
        if e.bridge:
            bridges.append(e.geometry)
    if bridges:  # a dark casing under the bridge sections
        ax.add_collection(
            LineCollection(
                _segments(bridges),
                colors=_BRIDGE_CASING,
                linewidths=3.6,
                zorder=1.5,
                capstyle="butt",
            )
        )
    for (cls, tunnel), geoms in sorted(groups.items()):
        ax.add_collection(
            LineCollection(
                _segments(geoms),
                colors=TRACK_COLOURS[cls],
                linewidths=widths.get(cls, 0.7),
                linestyles=_TUNNEL_DASHES if tunnel else "solid",
                alpha=0.8 if tunnel else 1.0,
                zorder=2.0 if cls == "main" else 1.9,
                capstyle="round",
            )
        )
    for cls in TRACK_COLOURS:
        n = sum(len(g) for (c, _), g in groups.items() if c == cls)
        if n:
            handles.append(
                Line2D(
                    [],
                    [],
                    color=TRACK_COLOURS[cls],
                    lw=2.0 if cls == "main" else 1.5,
                    label=f"{TRACK_LABELS[cls]} ({_edges(n)})",
                )
            )
    if bridges:
        handles.append(
            Line2D(
                [],
                [],
                color=TRACK_COLOURS["main"],
                lw=1.5,
                label=f"bridge ({_edges(len(bridges))})",
                path_effects=_casing_effect(),
            )
        )
    n_tunnel = sum(len(g) for (_, t), g in groups.items() if t)
    if n_tunnel:
        handles.append(
            Line2D(
                [],
                [],
                color=TRACK_COLOURS["main"],
                lw=1.5,
                linestyle=_TUNNEL_DASHES,
                label=f"tunnel ({_edges(n_tunnel)})",
            )
        )


def _edges(n: int) -> str:
    return f"{n} edge" if n == 1 else f"{n} edges"


def _casing_effect() -> list[Any]:
    from matplotlib import patheffects

    return [patheffects.Stroke(linewidth=4.5, foreground=_BRIDGE_CASING), patheffects.Normal()]


def _scatter(
    ax: Axes, xs: Sequence[float], ys: Sequence[float], style: MarkerStyle, n_label: int
) -> Any:
    (line,) = ax.plot(
        xs,
        ys,
        linestyle="none",
        marker=style.marker,
        markersize=style.size,
        markerfacecolor=style.colour,
        markeredgecolor=style.edge,
        markeredgewidth=1.2 if style.colour == "none" else 0.5,
        zorder=style.zorder,
        label=f"{style.label} ({n_label})",
    )
    return line


def _draw_points(ax: Axes, net: TrackMap, handles: list[Any], *, show_stops: bool) -> None:
    by_cls: dict[str, list[tuple[float, float]]] = {}
    for node in net.nodes.values():
        if node.cls in NODE_STYLES:
            by_cls.setdefault(node.cls, []).append((node.x, node.y))
    for cls, style in NODE_STYLES.items():
        pts = by_cls.get(cls)
        if pts:
            handles.append(_scatter(ax, [p[0] for p in pts], [p[1] for p in pts], style, len(pts)))
    crossings = [(c.x, c.y) for c in net.conflicts if c.kind == "crossing"]
    if crossings:
        cx = [p[0] for p in crossings]
        cy = [p[1] for p in crossings]
        handles.append(_scatter(ax, cx, cy, CROSSING_STYLE, len(crossings)))
    if net.grade_separated:
        xs = [g[2] for g in net.grade_separated]
        ys = [g[3] for g in net.grade_separated]
        handles.append(_scatter(ax, xs, ys, GRADE_SEPARATED_STYLE, len(xs)))
    if show_stops and net.stops:
        sx, sy = net.to_local(
            np.array([s.lon for s in net.stops], dtype=float),
            np.array([s.lat for s in net.stops], dtype=float),
        )
        handles.append(_scatter(ax, list(sx), list(sy), STOP_STYLE, len(net.stops)))


def _draw_paths(
    ax: Axes, net: TrackMap, paths: Sequence[Path], handles: list[Any]
) -> list[npt.NDArray[np.float64]]:
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    if not paths:
        return []
    arrays = _segments(net.path_geometry(p) for p in paths)
    colours = [HIGHLIGHT_COLOURS[k % len(HIGHLIGHT_COLOURS)] for k in range(len(paths))]
    # decreasing widths: where paths share track, each shows as a stripe of its own
    n = len(paths)
    widths = [3.0 + 5.0 * (n - 1 - k) / max(n - 1, 1) for k in range(n)]
    ax.add_collection(
        LineCollection(
            arrays, colors=colours, linewidths=widths, alpha=0.85, zorder=3.0, capstyle="round"
        )
    )
    starts = {tuple(np.round(a[0], 3)) for a in arrays}
    sx = [s[0] for s in starts]
    sy = [s[1] for s in starts]
    (start_marker,) = ax.plot(
        sx,
        sy,
        label="path start",
        linestyle="none",
        marker="o",
        markersize=8,
        markerfacecolor="white",
        markeredgecolor="black",
        markeredgewidth=1.5,
        zorder=6.0,
    )
    handles.append(start_marker)
    shown = paths if len(paths) <= 12 else paths[:11]
    for k, p in enumerate(shown):
        handles.append(
            Line2D(
                [],
                [],
                color=colours[k],
                lw=widths[k],
                alpha=0.85,
                label=f"path {k}: {p.zone} ({p.length_m:.0f} m, {p.end})",
            )
        )
    if len(shown) < len(paths):
        handles.append(
            Line2D([], [], color="#999999", lw=4.0, label=f"... {len(paths) - len(shown)} more")
        )
    return arrays


def _add_scale_bar(ax: Axes, box: tuple[float, float, float, float]) -> None:
    from matplotlib.offsetbox import AnchoredOffsetbox, AuxTransformBox, TextArea, VPacker
    from matplotlib.patches import Rectangle

    span = min(box[2] - box[0], box[3] - box[1])
    length = _nice_scale_length(span)
    bar = AuxTransformBox(ax.transData)
    bar.add_artist(Rectangle((0, 0), length, 0, edgecolor="black", lw=2.5, fill=False))
    label = TextArea(_format_metres(length), textprops={"fontsize": 8})
    packed = VPacker(children=[bar, label], align="center", pad=0, sep=3)
    anchored = AnchoredOffsetbox(
        loc="lower left", child=packed, pad=0.4, borderpad=0.6, frameon=True
    )
    anchored.patch.set_alpha(0.85)
    anchored.patch.set_edgecolor("none")
    anchored.set_zorder(10)
    ax.add_artist(anchored)
