"""The live view's page: the network map with the fleet drawn on it as snapshots arrive.

The page is rendered once when the server starts: the network (muted) from
:func:`trackmap.plot_html.html_map`, Leaflet and the page's own script and stylesheet
(``antikol/serve/web``) inlined, so it needs nothing but the server it came from. Its
script opens ``events`` (server-sent events, with the access token of the page's own
address, if any) and moves a marker per vehicle, coloured by its level, with lines to the
vehicles it is warned about and a panel listing the current warnings.
"""

from __future__ import annotations

import html
import importlib.resources
from typing import Any

from trackmap import TrackMap
from trackmap.optional import require
from trackmap.plot_assets import render_self_contained, script_json, style_tag, use_vendored_assets
from trackmap.plot_html import html_map

__all__ = ["live_page", "web_asset"]


def web_asset(name: str) -> str:
    """The text of a file of ``antikol/serve/web`` (``live.js``, ``live.css``)."""
    return importlib.resources.files("antikol.serve").joinpath("web", name).read_text("utf-8")


def live_page(
    net: TrackMap | None,
    *,
    title: str = "antikol live view",
    tiles: str | None = None,
    events_url: str = "events",
) -> str:
    """The HTML of the live view.

    Parameters
    ----------
    net : TrackMap or None
        The network drawn under the fleet (None: none; the view follows the vehicles).
    title : str
    tiles : str or None
        Online background tiles as for :func:`trackmap.plot_html.plot_map_html`; default
        none: the page makes no request but to its own server.
    events_url : str
        Address of the server-sent events, relative to the page.

    Returns
    -------
    str
    """
    folium = require("folium", purpose="the live view's page")
    from branca.element import MacroElement
    from jinja2 import Template

    if net is not None:
        fmap = html_map(net, tiles=tiles, muted=True, legend=False)
    else:
        src = None if tiles is None or tiles.strip().lower() in ("", "none") else tiles
        fmap = folium.Map(
            tiles=src, location=[0.0, 0.0], zoom_start=2, prefer_canvas=True, control_scale=True
        )
        use_vendored_assets(fmap)
    control = folium.LayerControl(collapsed=True)
    control.add_to(fmap)
    options: dict[str, Any] = {
        "events": events_url,
        "title": title,
        "fit": net is None,
        "attribution": net.metadata.attribution if net is not None else "",
    }

    class _Live(MacroElement):  # branca is untyped
        _template = Template(
            "{% macro header(this, kwargs) %}{{ this.css }}{% endmacro %}"
            "{% macro script(this, kwargs) %}{{ this.js }}\n"
            "antikolLive({{ this._parent.get_name() }}, {{ this.control }}, {{ this.options }});"
            "{% endmacro %}"
        )

        def __init__(self) -> None:
            super().__init__()
            self._name = "AntikolLive"
            self.css = style_tag(web_asset("live.css"), element_id="antikol-live-css")
            self.js = web_asset("live.js")
            self.control = control.get_name()
            self.options = script_json(options)

    fmap.add_child(_Live())
    fmap.get_root().header.add_child(
        folium.Element(f"<title>{html.escape(title)}</title>"), name="title"
    )
    return render_self_contained(fmap)
