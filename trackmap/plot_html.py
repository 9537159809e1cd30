"""Interactive maps with folium: a Leaflet page (WGS84) with tooltips and popups.

Every page is one self-contained HTML file: Leaflet comes inlined from the copy shipped
with the package (:mod:`trackmap.plot_assets`), so the map renders on a machine without
internet; only online tiles, when asked for, are fetched.

* :func:`plot_map_html` writes the map of a network;
* :func:`html_map` builds the same map as a :class:`folium.Map` for other pages to draw
  on (the replay and comparison results of :mod:`antikol.evaluation.html_results`, the
  live view of :mod:`antikol.serve`), and :func:`save_html` writes such a map.

folium is an optional dependency (``pip install antikol[plot]``), imported by these
functions only.
"""

from __future__ import annotations

import html
import json
import os
import pathlib
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from trackmap.model import Edge, Path
from trackmap.network import TrackMap
from trackmap.optional import require
from trackmap.plot_assets import render_self_contained
from trackmap.plot_style import (
    CROSSING_STYLE,
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

__all__ = [
    "HTML_SUFFIXES",
    "MUTED_TRACK_COLOUR",
    "OSM_TILE_ATTRIBUTION",
    "html_map",
    "plot_map_html",
    "save_html",
]

#: Output suffixes written by :func:`plot_map_html`.
HTML_SUFFIXES = (".html",)
#: Attribution used for a custom tile URL when none is given.
OSM_TILE_ATTRIBUTION = (
    '&copy; <a href="https://www.openstreetmap.org/copyright">OpenStreetMap</a> contributors'
)


#: Colour of every track on the muted base map of result pages and the live view.
MUTED_TRACK_COLOUR = "#a7b0ba"


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

    The page is one self-contained file (Leaflet inlined, see
    :mod:`trackmap.plot_assets`): it can be copied to and opened on a machine without
    internet; with ``tiles=None`` it makes no network request at all.

    Parameters
    ----------
    net : TrackMap
        The map to draw.
    path : path-like
        Output ``.html`` file; its directory must exist.
    tiles : str or None
        Background: a folium/xyzservices provider name (default ``"OpenStreetMap"``;
        e.g. ``"CartoDB positron"``) or a tile URL template
        (``https://.../{z}/{x}/{y}.png``), fetched online when the page is viewed.
        ``None`` or ``"none"``: no tile layer at all, so the page needs no network.
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
    trackmap.errors.MissingDependencyError
        folium is not installed (an ``ImportError``).
    """
    out = output_path(path, HTML_SUFFIXES, "plot_map_html")
    fmap = html_map(
        net,
        tiles=tiles,
        title=title,
        tiles_attribution=tiles_attribution,
        show_stops=show_stops,
        highlight_paths=highlight_paths,
    )
    folium = require("folium", purpose="plot_map_html")
    folium.LayerControl(collapsed=True).add_to(fmap)
    return save_html(fmap, out)


def save_html(fmap: Any, path: str | os.PathLike[str]) -> pathlib.Path:
    """Write a folium map made by :func:`html_map` as one self-contained HTML page.

    Parameters
    ----------
    fmap : folium.Map
        From :func:`html_map`, with whatever was added to it.
    path : path-like
        Output ``.html`` file; its directory must exist.

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    ValueError
        The suffix is not ``.html``.
    trackmap.plot_assets.NotSelfContainedError
        Something added to the map would load a script or stylesheet from the network.
    trackmap.errors.SourceError
        The output directory does not exist.
    """
    out = output_path(path, HTML_SUFFIXES, "save_html")
    out.write_text(render_self_contained(fmap), encoding="utf-8")
    return out


def html_map(
    net: TrackMap,
    *,
    tiles: str | None = "OpenStreetMap",
    title: str | None = None,
    tiles_attribution: str | None = None,
    show_stops: bool = False,
    highlight_paths: Sequence[Path] | None = None,
    muted: bool = False,
    legend: bool = True,
    fit: bool = True,
) -> Any:
    """The Leaflet map of :func:`plot_map_html` as a :class:`folium.Map`, not yet saved.

    It loads Leaflet from the vendored copy (:func:`trackmap.plot_assets.use_vendored_assets`);
    write it with :func:`save_html` (or render it with
    :func:`trackmap.plot_assets.render_self_contained`). No layer control is added: add
    your layers first, then ``folium.LayerControl``.

    Parameters
    ----------
    net : TrackMap
    tiles, title, tiles_attribution, show_stops, highlight_paths
        As for :func:`plot_map_html`.
    muted : bool
        Draw every track thin in :data:`MUTED_TRACK_COLOUR` and leave the node, crossing
        and conflict layers off (they can be switched on): a base map for results drawn on
        top.
    legend : bool
        Add the legend box (track classes, markers, title, attribution).
    fit : bool
        Fit the view to the network when the page opens (False: the caller's script
        fits it to what it draws; a second fit while the first is still animated would be
        undone by it).

    Returns
    -------
    folium.Map
    """
    folium = require("folium", purpose="html_map")
    from trackmap.plot_assets import use_vendored_assets

    # None or "none": no tile layer at all
    tile_source = None if tiles is None or tiles.strip().lower() in ("", "none") else tiles
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
    if tile_source is None:
        fmap = folium.Map(tiles=None, **map_kw)
    else:
        is_template = "{z}" in tile_source or "://" in tile_source
        if not is_template:
            _check_tile_provider(tile_source)
        attr = tiles_attribution
        if attr is None and is_template:
            attr = OSM_TILE_ATTRIBUTION
        fmap = folium.Map(tiles=tile_source, attr=attr, **map_kw)
    use_vendored_assets(fmap)

    groups: dict[str, list[dict[str, Any]]] = {}
    for e in net.edges:
        cls = track_class(e)
        groups.setdefault(cls, []).append(_edge_feature(e))
    tooltip_fields = ["edge_id", "way_ids", "direction", "service", "structure", "length_m"]
    tooltip_aliases = ["edge", "OSM ways", "direction", "service", "structure", "length (m)"]
    for cls in TRACK_COLOURS:
        feats = groups.get(cls)
        if not feats:
            continue
        if muted:
            edge_style = _edge_style(MUTED_TRACK_COLOUR, 2.5 if cls == "main" else 2.0)
        else:
            edge_style = _edge_style(TRACK_COLOURS[cls], 4.0 if cls == "main" else 3.0)
        folium.GeoJson(
            {"type": "FeatureCollection", "features": feats},
            name=f"{TRACK_LABELS[cls]} ({len(feats)})",
            style_function=edge_style,
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
            show=not muted,
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
        label = f"{CROSSING_STYLE.label} ({len(crossing_ids)})"
        _add_points(
            folium,
            fmap,
            [conflict_feature(cid) for cid in crossing_ids],
            CROSSING_STYLE,
            label,
            conflict_fields,
            show=not muted,
        )
        legend_markers.append((CROSSING_STYLE.edge, label))
    if net.conflicts:
        _add_points(
            folium,
            fmap,
            [conflict_feature(c.conflict_id) for c in net.conflicts],
            MarkerStyle("conflict point", "o", "#ffcc00", 0, "#7a5c00", 0, 3.0),
            f"all conflict points ({len(net.conflicts)})",
            conflict_fields,
            show=False,
        )
    if show_stops and net.stops:
        feats = [
            _point_feature(s.lon, s.lat, {"stop": s.name or "", "stop_id": s.stop_id})
            for s in net.stops
        ]
        label = f"{STOP_STYLE.label} ({len(net.stops)})"
        _add_points(folium, fmap, feats, STOP_STYLE, label, ["stop", "stop_id"])
        legend_markers.append((STOP_STYLE.colour, label))
    for k, p in enumerate(highlight_paths or []):
        geom = net.path_geometry(p)
        xy = np.asarray(geom.coords, dtype=float)
        plon, plat = net.to_lonlat(xy[:, 0], xy[:, 1])
        folium.PolyLine(
            list(zip(np.asarray(plat).tolist(), np.asarray(plon).tolist(), strict=True)),
            color=HIGHLIGHT_COLOURS[k % len(HIGHLIGHT_COLOURS)],
            weight=8,
            opacity=0.7,
            tooltip=f"path {k}: {p.zone}, {p.length_m:.0f} m, ends at {p.end}",
        ).add_to(fmap)

    attribution = net.metadata.attribution
    _add_attribution(folium, fmap, attribution)
    if legend:
        track_rows = [(MUTED_TRACK_COLOUR, "track")] if muted else []
        if not muted:
            track_rows = [(TRACK_COLOURS[c], TRACK_LABELS[c]) for c in TRACK_COLOURS if c in groups]
        fmap.get_root().html.add_child(
            folium.Element(
                _legend_html(
                    title if title is not None else default_title(net),
                    track_rows,
                    [] if muted else legend_markers,
                    attribution,
                )
            )
        )
    if fit and net.edges:
        fmap.fit_bounds([[lat_min, lon_min], [lat_max, lon_max]], padding=(10, 10))
    return fmap


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
    style: MarkerStyle,
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
