"""Replay and comparison results as interactive maps: one self-contained HTML page each.

* :func:`replay_html` — a replay (``antikol replay LOG --html out.html``): each vehicle's
  path coloured by its warning level, every warning episode as a clickable marker;
* :func:`comparison_html` — a comparison of the sector rule and the track-aware analyser
  (``antikol compare --html DIR``): both analysers' lamps along the true paths (one layer
  each), every warning, false alarm and missed warning of each as a clickable marker;
  :func:`comparison_index_html` writes the page that lists the scenarios' pages.

A marker's popup gives the pair, kind, level, distance, closing speed and time and draws
the distance between the two vehicles and the warnings against time around it (the view
of Figs. 10 and 11 of the 2008 paper); a panel lists the scores and every event (a click
on a row opens it). The data come from :mod:`antikol.evaluation.results_data`.

The pages are drawn on the network map of :func:`trackmap.plot_html.html_map` with
Leaflet and the page's own script and stylesheet inlined (see
:mod:`trackmap.plot_assets`): they open on a machine without internet, and make no network
request at all unless online ``tiles`` are asked for. folium is needed
(``pip install antikol[plot]``).
"""

from __future__ import annotations

import html
import importlib.resources
import logging
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from antikol.analysis.assessment import Threat
from antikol.evaluation.results_data import (
    ReplayRecorder,
    comparison_results,
    replay_results,
)
from antikol.evaluation.scoring import Comparison
from trackmap import TrackMap
from trackmap.optional import require
from trackmap.plot_assets import script_json, style_tag
from trackmap.plot_html import HTML_SUFFIXES, html_map, save_html
from trackmap.plot_style import output_path

__all__ = [
    "comparison_html",
    "comparison_index_html",
    "replay_html",
    "results_page",
    "web_asset",
]

logger = logging.getLogger(__name__)


def web_asset(name: str) -> str:
    """The text of a file of ``antikol/evaluation/web`` (``results.js``, ``results.css``)."""
    return (
        importlib.resources.files("antikol.evaluation")
        .joinpath("web", name)
        .read_text(encoding="utf-8")
    )


def results_page(
    data: Mapping[str, Any],
    path: str | os.PathLike[str],
    *,
    net: TrackMap | None,
    tiles: str | None = None,
) -> Path:
    """Write result data (:mod:`antikol.evaluation.results_data`) as an interactive map.

    Parameters
    ----------
    data : mapping
        From :func:`~antikol.evaluation.results_data.replay_results` or
        :func:`~antikol.evaluation.results_data.comparison_results`.
    path : path-like
        Output ``.html`` file; its directory must exist.
    net : TrackMap or None
        The network to draw under the results (None: the results alone, e.g. a replay with
        the sector rule only).
    tiles : str or None
        Background tiles as for :func:`trackmap.plot_html.plot_map_html`; default none,
        so the page makes no network request.

    Returns
    -------
    Path
    """
    out = output_path(path, HTML_SUFFIXES, "results_page")
    folium = require("folium", purpose="HTML result maps")
    from branca.element import MacroElement
    from jinja2 import Template

    if net is not None:
        fmap = html_map(net, tiles=tiles, muted=True, legend=False, fit=not data.get("bounds"))
    else:
        fmap = _bare_map(folium, tiles, data.get("bounds"))
    control = folium.LayerControl(collapsed=True)
    control.add_to(fmap)

    class _Results(MacroElement):  # branca is untyped
        _template = Template(
            "{% macro header(this, kwargs) %}{{ this.css }}{% endmacro %}"
            "{% macro script(this, kwargs) %}{{ this.js }}\n"
            "antikolResults({{ this._parent.get_name() }}, {{ this.control }}, {{ this.data }});"
            "{% endmacro %}"
        )

        def __init__(self) -> None:
            super().__init__()
            self._name = "AntikolResults"
            self.css = style_tag(web_asset("results.css"), element_id="antikol-results-css")
            self.js = web_asset("results.js")
            self.control = control.get_name()
            self.data = script_json(data)

    fmap.add_child(_Results())
    title = html.escape(str(data.get("title", "antikol results")))
    fmap.get_root().header.add_child(folium.Element(f"<title>{title}</title>"), name="title")
    return save_html(fmap, out)


def _bare_map(folium: Any, tiles: str | None, bounds: Any) -> Any:
    """A map without a network under it, loading the vendored Leaflet."""
    from trackmap.plot_assets import use_vendored_assets

    src = None if tiles is None or tiles.strip().lower() in ("", "none") else tiles
    fmap = folium.Map(
        tiles=src, location=[0.0, 0.0], zoom_start=2, control_scale=True, prefer_canvas=True
    )
    use_vendored_assets(fmap)
    if bounds:
        fmap.fit_bounds(bounds, padding=(20, 20))
    return fmap


def replay_html(
    recorder: ReplayRecorder,
    path: str | os.PathLike[str],
    *,
    net: TrackMap | None,
    title: str,
    cycle_s: float = 1.0,
    tiles: str | None = None,
) -> Path:
    """Write the result map of a replay recorded by a :class:`ReplayRecorder`.

    Parameters
    ----------
    recorder : ReplayRecorder
        Passed as ``on_assessment`` to :func:`antikol.evaluation.replay.replay`.
    path : path-like
        Output ``.html`` file.
    net : TrackMap or None
        The map of the replay (None: sector rule only, no network drawn).
    title : str
    cycle_s : float
        Analysis period of the replay, s.
    tiles : str or None
        Online background tiles (default none: no network request).

    Returns
    -------
    Path
    """
    data = replay_results(recorder, title=title, cycle_s=cycle_s)
    return results_page(data, path, net=net, tiles=tiles)


def comparison_html(
    comparison: Comparison,
    net: TrackMap,
    path: str | os.PathLike[str],
    *,
    vehicles: Sequence[str] = (),
    tiles: str | None = None,
    threats: Mapping[str, Mapping[tuple[str, str], Mapping[int, Threat]]] | None = None,
) -> Path:
    """Write the result map of a comparison.

    Parameters
    ----------
    comparison : Comparison
        From :func:`antikol.evaluation.scoring.compare`.
    net : TrackMap
        The map of the run.
    path : path-like
        Output ``.html`` file.
    vehicles : sequence of str
        Vehicles to show (default all).
    tiles : str or None
        Online background tiles (default none: no network request).
    threats : mapping, optional
        From :func:`~antikol.evaluation.results_data.record_threats` (computed when not
        given: both analysers run once more on the run's reports).

    Returns
    -------
    Path
    """
    data = comparison_results(comparison, net, vehicles=vehicles, threats=threats)
    return results_page(data, path, net=net, tiles=tiles)


def comparison_index_html(
    entries: Sequence[tuple[Comparison, str]],
    path: str | os.PathLike[str],
    *,
    title: str = "antikol: sector rule and track-aware analyser",
    notes: Sequence[str] = (),
) -> Path:
    """Write the page listing compared scenarios, their scores and their maps.

    Parameters
    ----------
    entries : sequence of (Comparison, str)
        Each comparison and the file name of its map (relative to the index).
    path : path-like
        Output ``.html`` file.
    title : str
    notes : sequence of str
        Lines shown below the table (skipped or failed scenarios).

    Returns
    -------
    Path
    """
    out = output_path(path, HTML_SUFFIXES, "comparison_index_html")
    esc = html.escape
    head = (
        "<tr><th>scenario</th><th>method</th><th>required</th><th>timely</th><th>missed</th>"
        "<th>(late)</th><th>false alarms</th><th>FA / vehicle-hour</th><th>map</th></tr>"
    )
    rows = []
    for comp, name in entries:
        for method, sc in (("sector rule", comp.sector), ("track-aware", comp.track)):
            rows.append(
                f"<tr><td>{esc(comp.name)}</td><td>{method}</td><td>{sc.required}</td>"
                f"<td>{sc.timely}</td><td>{sc.missed}</td><td>{sc.late}</td>"
                f"<td>{sc.false_alarm_episodes}</td>"
                f"<td>{sc.false_alarms_per_vehicle_hour:.2f}</td>"
                f'<td><a href="{esc(name, quote=True)}">{esc(name)}</a></td></tr>'
            )
    css = (
        "body{font:14px/1.4 sans-serif;margin:1.5em}table{border-collapse:collapse}"
        "td,th{padding:3px 9px;border-bottom:1px solid #ddd;text-align:right}"
        "td:first-child,th:first-child,td:nth-child(2){text-align:left}"
    )
    page = (
        '<!DOCTYPE html>\n<html><head><meta charset="utf-8">'
        f"<title>{esc(title)}</title>{style_tag(css)}</head><body>"
        f"<h1>{esc(title)}</h1><table>{head}{''.join(rows)}</table>"
        + "".join(f"<p>{esc(n)}</p>" for n in notes)
        + "<p>Missed includes late warnings. Each map shows the lamp of both analysers along "
        "the true paths, and every warning, false alarm and missed warning; click one to "
        "see the distance and the warnings of its pair against time.</p></body></html>\n"
    )
    out.write_text(page, encoding="utf-8")
    return out
