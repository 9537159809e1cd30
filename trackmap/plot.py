"""Figures of a :class:`~trackmap.network.TrackMap`: static (matplotlib) and interactive (folium).

* :func:`plot_map` draws the network in the map's local metric frame (metres, equal
  aspect) to PNG, SVG or PDF: tracks coloured by class, junction nodes and at-grade
  crossings marked, optional routes ahead (a sensitivity area) drawn thick.
* :func:`plot_map_html` writes an interactive Leaflet map (WGS84) with tooltips and popups
  as one self-contained page (Leaflet inlined from the copy shipped with the package, see
  :mod:`trackmap.plot_assets`); the background tiles are configurable and can be switched
  off, and then the page makes no network request at all.
* :func:`plot` picks one of the two from the output file's suffix.

Every figure carries the data attribution of the map (``net.metadata.attribution``, by
default "© OpenStreetMap contributors, ODbL 1.0").

matplotlib is used through its object-oriented API only (:class:`matplotlib.figure.Figure`
rendered by the Agg/SVG/PDF canvases): no window is ever opened, no pyplot state is touched,
so plotting is safe in scripts, servers and tests. Both libraries are optional
(``pip install antikol[plot]``) and imported only by the function that draws with them:
:func:`plot_map` lives in :mod:`trackmap.plot_static`, :func:`plot_map_html` in
:mod:`trackmap.plot_html`, their common styles in :mod:`trackmap.plot_style`, the vendored
web assets in :mod:`trackmap.plot_assets`.
"""

from __future__ import annotations

import os
import pathlib
from typing import Any

from trackmap.network import TrackMap
from trackmap.plot_html import (
    HTML_SUFFIXES,
    OSM_TILE_ATTRIBUTION,
    html_map,
    plot_map_html,
    save_html,
)
from trackmap.plot_static import IMAGE_SUFFIXES, plot_map
from trackmap.plot_style import output_path

__all__ = [
    "HTML_SUFFIXES",
    "IMAGE_SUFFIXES",
    "OSM_TILE_ATTRIBUTION",
    "html_map",
    "plot",
    "plot_map",
    "plot_map_html",
    "save_html",
]


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
    out = output_path(path, supported, "trackmap plot")
    if out.suffix.lower() in HTML_SUFFIXES:
        return plot_map_html(net, out, **kw)
    return plot_map(net, out, **kw)
