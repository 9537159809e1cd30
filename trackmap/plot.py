"""Figures of a :class:`~trackmap.network.TrackMap`: static (matplotlib) and interactive (folium).

* :func:`plot_map` draws the network in the map's local metric frame (metres, equal
  aspect) to PNG, SVG or PDF: tracks coloured by class, junction nodes and at-grade
  crossings marked, optional routes ahead (a sensitivity area) drawn thick.
* :func:`plot_map_html` writes an interactive Leaflet map (WGS84) with tooltips and popups;
  the background tiles are configurable and can be switched off for offline use.
* :func:`plot` picks one of the two from the output file's suffix.

Every figure carries the data attribution of the map (``net.metadata.attribution``, by
default "© OpenStreetMap contributors, ODbL 1.0").

matplotlib is used through its object-oriented API only (:class:`matplotlib.figure.Figure`
rendered by the Agg/SVG/PDF canvases): no window is ever opened, no pyplot state is touched,
so plotting is safe in scripts, servers and tests. folium is an optional dependency
(``pip install antikol[plot]``), imported only by :func:`plot_map_html`.
"""

from __future__ import annotations

import html
import json
import math
import os
import pathlib
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt
import shapely

from trackmap.errors import SourceError
from trackmap.network import Edge, Path, TrackMap

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = [
    "HTML_SUFFIXES",
    "IMAGE_SUFFIXES",
    "OSM_TILE_ATTRIBUTION",
    "plot",
    "plot_map",
    "plot_map_html",
]

#: Output suffixes written by :func:`plot_map`.
IMAGE_SUFFIXES = (".png", ".svg", ".pdf")
#: Output suffixes written by :func:`plot_map_html`.
HTML_SUFFIXES = (".html",)
#: Attribution used for a custom tile URL when none is given.
OSM_TILE_ATTRIBUTION = (
    '&copy; <a href="https://www.openstreetmap.org/copyright">OpenStreetMap</a> contributors'
)

Extent = Sequence[float] | Literal["network", "paths"]

# -- styles -------------------------------------------------------------------------------
#: Colour of each track class: main line (no ``service``) and the auxiliary services.
TRACK_COLOURS: dict[str, str] = {
    "main": "#1f4e9c",
    "yard": "#8f8f8f",
    "siding": "#8e5bbf",
    "spur": "#d9822b",
    "crossover": "#1a9e8f",
    "other": "#b5651d",
}
TRACK_LABELS: dict[str, str] = {
    "main": "main line",
    "yard": "yard (depot)",
    "siding": "siding",
    "spur": "spur",
    "crossover": "crossover",
    "other": "other service track",
}
_TUNNEL_DASHES = (0, (4.0, 2.0))
_BRIDGE_CASING = "#202020"


@dataclass(frozen=True)
class _MarkerStyle:
    label: str
    marker: str
    colour: str
    size: float  # points
    edge: str  # marker edge colour
    zorder: float
    html_radius: float  # CircleMarker radius on the HTML map, pixels


#: Markers of the junction node classes (``link`` nodes are not marked).
NODE_STYLES: dict[str, _MarkerStyle] = {
    "point_switch": _MarkerStyle("point switch", "o", "#2ca02c", 3.2, "#135a13", 4.0, 4.0),
    "diamond_crossing": _MarkerStyle("diamond crossing", "D", "#9467bd", 3.6, "#3f2266", 4.1, 5.0),
    "double_slip": _MarkerStyle("double slip", "X", "#8c564b", 6.0, "#3b2420", 4.2, 6.0),
    "buffer_stop": _MarkerStyle("buffer stop", "s", "#111111", 3.6, "#111111", 4.3, 4.0),
    "unknown": _MarkerStyle("unknown junction", "*", "#ff1fd2", 9.0, "#7a0063", 4.4, 7.0),
}
_CROSSING = _MarkerStyle("at-grade crossing (conflict)", "o", "none", 10.0, "#e31a1c", 4.6, 9.0)
_GRADE_SEP = _MarkerStyle("grade-separated crossing", "+", "#555555", 7.0, "#555555", 3.9, 5.0)
_STOP = _MarkerStyle("stop", "^", "#17becf", 3.6, "#0b5f68", 3.8, 3.0)
_HIGHLIGHT_COLOURS = (
    "#e6194b",
    "#f58231",
    "#3cb44b",
    "#911eb4",
    "#ffd60a",
    "#42d4f4",
    "#f032e6",
    "#469990",
    "#9a6324",
    "#800000",
)

_SCALE_STEPS_M = (1, 2, 5, 10, 20, 25, 50, 100, 200, 250, 500, 1000, 2000, 2500, 5000, 10000)


def track_class(edge: Edge) -> str:
    """The drawing class of an edge: ``main`` or its ``service`` value (or ``other``)."""
    if edge.service is None:
        return "main"
    return edge.service if edge.service in TRACK_COLOURS else "other"


# -- helpers ------------------------------------------------------------------------------
def _output_path(path: str | os.PathLike[str], suffixes: Sequence[str], what: str) -> pathlib.Path:
    """Check an output path: a supported suffix and an existing parent directory."""
    out = pathlib.Path(path).expanduser()
    suffix = out.suffix.lower()
    if suffix not in suffixes:
        raise ValueError(
            f"{what} cannot write {out.name!r}: unsupported suffix {out.suffix or '(none)'!r}; "
            f"supported: {', '.join(suffixes)}"
        )
    parent = out.parent
    if not parent.is_dir():
        raise SourceError(f"cannot write {out}: the output directory {parent} does not exist")
    return out


def _default_title(net: TrackMap) -> str:
    source = net.metadata.source.get("file") or "track map"
    km = float(sum(e.length_m for e in net.edges)) / 1000.0
    return f"{source}: {len(net.edges)} edges, {km:.1f} km of track"


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
    """
    from matplotlib.figure import Figure

    out = _output_path(path, IMAGE_SUFFIXES, "plot_map")
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
    ax.set_title(title if title is not None else _default_title(net))

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
    ax: Axes, xs: Sequence[float], ys: Sequence[float], style: _MarkerStyle, n_label: int
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
        handles.append(_scatter(ax, cx, cy, _CROSSING, len(crossings)))
    if net.grade_separated:
        xs = [g[2] for g in net.grade_separated]
        ys = [g[3] for g in net.grade_separated]
        handles.append(_scatter(ax, xs, ys, _GRADE_SEP, len(xs)))
    if show_stops and net.stops:
        sx, sy = net.to_local(
            np.array([s.lon for s in net.stops], dtype=float),
            np.array([s.lat for s in net.stops], dtype=float),
        )
        handles.append(_scatter(ax, list(sx), list(sy), _STOP, len(net.stops)))


def _draw_paths(
    ax: Axes, net: TrackMap, paths: Sequence[Path], handles: list[Any]
) -> list[npt.NDArray[np.float64]]:
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    if not paths:
        return []
    arrays = _segments(net.path_geometry(p) for p in paths)
    colours = [_HIGHLIGHT_COLOURS[k % len(_HIGHLIGHT_COLOURS)] for k in range(len(paths))]
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


# -- interactive map ----------------------------------------------------------------------
def plot_map_html(
    net: TrackMap,
    path: str | os.PathLike[str],
    *,
    tiles: str | None = "OpenStreetMap",
    title: str | None = None,
    tiles_attribution: str | None = None,
    show_stops: bool = False,
    highlight_paths: Sequence[Path] | None = None,
) -> pathlib.Path:
    """Write an interactive Leaflet map (folium) of the network to an HTML file.

    Edges are drawn in WGS84 from their canonical vertices (``edge.lon``, ``edge.lat``),
    one toggleable layer per track class, coloured as in :func:`plot_map` (tunnels dashed,
    bridges thicker); hovering shows the edge id, OSM way ids, running direction, service,
    structure and length. Junction nodes (not plain links) are circle markers with a popup
    (class, node id); at-grade crossings and, in a layer off by default, every conflict
    point are marked too. The view is fitted to the network, a metric scale is shown and
    the map's data attribution is always added (to the attribution control and a legend).

    Parameters
    ----------
    net : TrackMap
        The map to draw.
    path : path-like
        Output ``.html`` file; its directory must exist.
    tiles : str or None
        Background: a folium/xyzservices provider name (default ``"OpenStreetMap"``;
        e.g. ``"CartoDB positron"``) or a tile URL template
        (``https://.../{z}/{x}/{y}.png``). ``None`` or ``"none"``: no tile layer at all,
        so the map needs no tile server (the Leaflet script itself is still loaded from
        its CDN when the page is opened).
    title : str, optional
        Heading shown in the legend box; default: source file, edge count and length.
    tiles_attribution : str, optional
        Attribution of the tiles (HTML). Required by Leaflet for URL templates; defaults
        to the OpenStreetMap one. For provider names, overrides the provider's own.
    show_stops : bool
        Also mark the stops.
    highlight_paths : sequence of trackmap.Path, optional
        Routes to draw thick on top (converted to WGS84 from
        :meth:`TrackMap.path_geometry`).

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    ValueError
        The suffix is not ``.html``, or folium does not know the tile provider name.
    trackmap.errors.SourceError
        The output directory does not exist (an ``OSError``).
    ImportError
        folium is not installed.
    """
    out = _output_path(path, HTML_SUFFIXES, "plot_map_html")
    try:
        import folium
    except ImportError as exc:  # pragma: no cover - folium is in the 'plot' extra
        raise ImportError(
            "plot_map_html needs folium: pip install 'antikol[plot]' (or pip install folium)"
        ) from exc

    no_tiles = tiles is None or tiles.strip().lower() in ("", "none")
    if net.edges:
        lon_min = min(min(e.lon) for e in net.edges)
        lon_max = max(max(e.lon) for e in net.edges)
        lat_min = min(min(e.lat) for e in net.edges)
        lat_max = max(max(e.lat) for e in net.edges)
    else:
        lon_min, lat_min = net.to_lonlat(0.0, 0.0)
        lon_max, lat_max = lon_min, lat_min
    centre = [(lat_min + lat_max) / 2.0, (lon_min + lon_max) / 2.0]
    map_kw: dict[str, Any] = {
        "location": centre,
        "zoom_start": 13,
        "control_scale": True,
        "prefer_canvas": True,
        "max_zoom": 22,
    }
    if no_tiles:
        fmap = folium.Map(tiles=None, **map_kw)
    else:
        assert tiles is not None
        is_template = "{z}" in tiles or "://" in tiles
        if not is_template:
            _check_tile_provider(tiles)
        attr = tiles_attribution
        if attr is None and is_template:
            attr = OSM_TILE_ATTRIBUTION
        fmap = folium.Map(tiles=tiles, attr=attr, **map_kw)

    colour_of: dict[str, str] = {}
    groups: dict[str, list[dict[str, Any]]] = {}
    for e in net.edges:
        cls = track_class(e)
        colour_of[cls] = TRACK_COLOURS[cls]
        groups.setdefault(cls, []).append(_edge_feature(e))
    tooltip_fields = ["edge_id", "way_ids", "direction", "service", "structure", "length_m"]
    tooltip_aliases = ["edge", "OSM ways", "direction", "service", "structure", "length (m)"]
    for cls in TRACK_COLOURS:
        feats = groups.get(cls)
        if not feats:
            continue
        folium.GeoJson(
            {"type": "FeatureCollection", "features": feats},
            name=f"{TRACK_LABELS[cls]} ({len(feats)})",
            style_function=_edge_style(TRACK_COLOURS[cls], 4.0 if cls == "main" else 3.0),
            highlight_function=lambda _f: {"weight": 7, "opacity": 1.0},
            tooltip=folium.GeoJsonTooltip(
                fields=tooltip_fields, aliases=tooltip_aliases, sticky=True
            ),
        ).add_to(fmap)

    legend_markers: list[tuple[str, str]] = []
    for cls, style in NODE_STYLES.items():
        nodes = [n for n in net.nodes.values() if n.cls == cls]
        if not nodes:
            continue
        feats = [
            _point_feature(
                n.lon,
                n.lat,
                {
                    "class": cls,
                    "node_id": n.node_id,
                    "edges": ", ".join(str(eid) for eid, _ in n.ends),
                },
            )
            for n in nodes
        ]
        _add_points(
            folium,
            fmap,
            feats,
            style,
            f"{style.label} ({len(nodes)})",
            ["class", "node_id", "edges"],
        )
        legend_markers.append((style.colour, f"{style.label} ({len(nodes)})"))

    def conflict_feature(cid: int) -> dict[str, Any]:
        c = net.conflicts[cid]
        lon, lat = net.to_lonlat(c.x, c.y)
        return _point_feature(
            float(lon),
            float(lat),
            {
                "kind": c.kind,
                "conflict_id": c.conflict_id,
                "node_id": "" if c.node_id is None else c.node_id,
                "edges": ", ".join(str(eid) for eid in c.edges),
                "angle_deg": "" if c.angle_deg is None else round(c.angle_deg, 1),
            },
        )

    conflict_fields = ["kind", "conflict_id", "node_id", "edges", "angle_deg"]
    crossing_ids = [c.conflict_id for c in net.conflicts if c.kind == "crossing"]
    if crossing_ids:
        label = f"{_CROSSING.label} ({len(crossing_ids)})"
        _add_points(
            folium,
            fmap,
            [conflict_feature(cid) for cid in crossing_ids],
            _CROSSING,
            label,
            conflict_fields,
        )
        legend_markers.append((_CROSSING.edge, label))
    if net.conflicts:
        _add_points(
            folium,
            fmap,
            [conflict_feature(c.conflict_id) for c in net.conflicts],
            _MarkerStyle("conflict point", "o", "#ffcc00", 0, "#7a5c00", 0, 3.0),
            f"all conflict points ({len(net.conflicts)})",
            conflict_fields,
            show=False,
        )
    if show_stops and net.stops:
        feats = [
            _point_feature(s.lon, s.lat, {"stop": s.name or "", "stop_id": s.stop_id})
            for s in net.stops
        ]
        label = f"{_STOP.label} ({len(net.stops)})"
        _add_points(folium, fmap, feats, _STOP, label, ["stop", "stop_id"])
        legend_markers.append((_STOP.colour, label))
    for k, p in enumerate(highlight_paths or []):
        geom = net.path_geometry(p)
        xy = np.asarray(geom.coords, dtype=float)
        plon, plat = net.to_lonlat(xy[:, 0], xy[:, 1])
        folium.PolyLine(
            list(zip(np.asarray(plat).tolist(), np.asarray(plon).tolist(), strict=True)),
            color=_HIGHLIGHT_COLOURS[k % len(_HIGHLIGHT_COLOURS)],
            weight=8,
            opacity=0.7,
            tooltip=f"path {k}: {p.zone}, {p.length_m:.0f} m, ends at {p.end}",
        ).add_to(fmap)

    attribution = net.metadata.attribution
    _add_attribution(folium, fmap, attribution)
    fmap.get_root().html.add_child(  # type: ignore[attr-defined]
        folium.Element(
            _legend_html(
                title if title is not None else _default_title(net),
                [(TRACK_COLOURS[c], TRACK_LABELS[c]) for c in TRACK_COLOURS if c in groups],
                legend_markers,
                attribution,
            )
        )
    )
    folium.LayerControl(collapsed=True).add_to(fmap)
    if net.edges:
        fmap.fit_bounds([[lat_min, lon_min], [lat_max, lon_max]], padding=(10, 10))
    fmap.save(str(out))
    return out


def _check_tile_provider(name: str) -> None:
    """Raise a clear ValueError for a tile provider name folium would not know."""
    import importlib

    try:
        xyzservices = importlib.import_module("xyzservices")  # untyped; a folium dependency
    except ImportError:  # pragma: no cover
        return
    if name.lower() == "openstreetmap":  # folium's alias of "OpenStreetMap Mapnik"
        return
    try:
        xyzservices.providers.query_name(name)
    except ValueError:
        raise ValueError(
            f"unknown tile provider {name!r}: give a provider name known to folium/xyzservices "
            "(e.g. 'OpenStreetMap', 'CartoDB positron'), a URL template with {z}/{x}/{y}, "
            "or None for no tiles"
        ) from None


def _edge_feature(e: Edge) -> dict[str, Any]:
    structure = "bridge" if e.bridge else ("tunnel" if e.tunnel else "")
    direction = {1: "+1 (vertex order)", -1: "-1 (against vertex order)", 0: "both"}.get(
        e.direction, str(e.direction)
    )
    return {
        "type": "Feature",
        "geometry": {
            "type": "LineString",
            "coordinates": [[lon, lat] for lon, lat in zip(e.lon, e.lat, strict=True)],
        },
        "properties": {
            "edge_id": e.edge_id,
            "way_ids": ", ".join(str(w) for w in e.way_ids),
            "direction": direction,
            "service": e.service or "main line",
            "structure": structure,
            "length_m": round(e.length_m, 1),
            "bridge": e.bridge,
            "tunnel": e.tunnel,
        },
    }


def _edge_style(colour: str, weight: float) -> Callable[[dict[str, Any]], dict[str, Any]]:
    def style(feature: dict[str, Any]) -> dict[str, Any]:
        props = feature["properties"]
        s: dict[str, Any] = {"color": colour, "weight": weight, "opacity": 0.9}
        if props.get("tunnel"):
            s["dashArray"] = "6 4"
            s["opacity"] = 0.7
        if props.get("bridge"):
            s["weight"] = weight + 3
        return s

    return style


def _point_feature(lon: float, lat: float, props: dict[str, Any]) -> dict[str, Any]:
    return {
        "type": "Feature",
        "geometry": {"type": "Point", "coordinates": [lon, lat]},
        "properties": props,
    }


def _add_points(
    folium: Any,
    fmap: Any,
    feats: list[dict[str, Any]],
    style: _MarkerStyle,
    name: str,
    fields: list[str],
    *,
    show: bool = True,
) -> None:
    fill = style.colour if style.colour != "none" else style.edge
    fill_opacity = 0.0 if style.colour == "none" else 0.9
    folium.GeoJson(
        {"type": "FeatureCollection", "features": feats},
        name=name,
        show=show,
        marker=folium.CircleMarker(radius=style.html_radius),
        style_function=lambda _f: {
            "color": style.edge,
            "weight": 2 if style.colour == "none" else 1,
            "fill": True,
            "fillColor": fill,
            "fillOpacity": fill_opacity,
            "radius": style.html_radius,
        },
        popup=folium.GeoJsonPopup(fields=fields),
    ).add_to(fmap)


def _add_attribution(folium: Any, fmap: Any, text: str) -> None:
    """Add ``text`` to the Leaflet attribution control (present even without tiles)."""
    from branca.element import MacroElement
    from jinja2 import Template

    literal = json.dumps(html.escape(text, quote=False), ensure_ascii=False).replace("</", "<\\/")

    class _Attribution(MacroElement):
        _template = Template(
            "{% macro script(this, kwargs) %}"
            "{{ this._parent.get_name() }}.attributionControl.addAttribution("
            + literal
            + ");{% endmacro %}"
        )

    fmap.add_child(_Attribution())


def _legend_html(
    title: str,
    tracks: list[tuple[str, str]],
    markers: list[tuple[str, str]],
    attribution: str,
) -> str:
    esc = html.escape
    rows = [
        f'<div><span style="display:inline-block;width:18px;height:4px;background:{c};'
        f'vertical-align:middle;margin-right:6px"></span>{esc(label)}</div>'
        for c, label in tracks
    ]
    rows += [
        f'<div><span style="display:inline-block;width:9px;height:9px;border-radius:50%;'
        f'background:{c};border:1px solid #333;vertical-align:middle;margin:0 10px 0 4px">'
        f"</span>{esc(label)}</div>"
        for c, label in markers
    ]
    return (
        '<div id="trackmap-legend" style="position:fixed;bottom:24px;right:10px;z-index:9999;'
        "background:rgba(255,255,255,0.92);padding:6px 9px;border-radius:4px;"
        'font:12px/1.45 sans-serif;box-shadow:0 1px 4px rgba(0,0,0,0.3);max-width:320px">'
        f"<b>{esc(title)}</b>{''.join(rows)}"
        '<div style="margin-top:4px;color:#444;font-size:11px">Track data: '
        f"{esc(attribution)}</div></div>"
    )


# -- dispatch -----------------------------------------------------------------------------
def plot(net: TrackMap, path: str | os.PathLike[str], **kw: Any) -> pathlib.Path:
    """Write a figure of the map, choosing the kind from the file suffix.

    Parameters
    ----------
    net : TrackMap
        The map to draw.
    path : path-like
        ``.png``, ``.svg`` or ``.pdf`` → :func:`plot_map` (static, local metres);
        ``.html`` → :func:`plot_map_html` (interactive, WGS84). The directory must exist.
    **kw
        Keyword arguments of the chosen function.

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    ValueError
        Unsupported suffix (the message lists the supported ones).
    trackmap.errors.SourceError
        The output directory does not exist.
    """
    supported = IMAGE_SUFFIXES + HTML_SUFFIXES
    out = _output_path(path, supported, "trackmap plot")
    if out.suffix.lower() in HTML_SUFFIXES:
        return plot_map_html(net, out, **kw)
    return plot_map(net, out, **kw)
