"""Self-contained HTML pages: the JavaScript and CSS they need come with the package.

Every page ``trackmap`` and ``antikol`` write (maps, replay and comparison results, the
live view) must work on a machine without internet: depot PCs, on-board screens and
control rooms are exactly such machines. Leaflet 1.9.4 (BSD 2-Clause) is vendored in
``trackmap/vendor/leaflet`` with its licence and inlined into each page: its stylesheet
with the images it refers to as ``data:`` URIs, its script, and the licence text in an
HTML comment. The only network requests a page makes are those of online tiles, when
the user asks for them.

folium maps are made self-contained by :func:`use_vendored_assets` (called before the
page is rendered: folium's CDN links of Leaflet, jQuery, Bootstrap and the awesome-markers
are replaced by markers of the vendored files, the rest dropped) and
:func:`render_self_contained` (renders, inlines the vendored files and checks with
:func:`external_resources` that nothing is left to fetch). Pages written without folium
use :func:`leaflet_head` and :func:`script_json`.

>>> external_resources('<script src="https://cdn.example.org/x.js"></script><a href="https://e.org">e</a>')
['https://cdn.example.org/x.js']
>>> external_resources('<img src="data:image/png;base64,AAAA">')
[]
>>> print(script_json({"a": "</script>"}))
{"a":"<\\/script>"}
"""

from __future__ import annotations

import base64
import functools
import html as html_lib
import importlib.resources
import json
import re
from typing import Any

from trackmap.errors import TrackMapError

__all__ = [
    "LEAFLET_VERSION",
    "NotSelfContainedError",
    "external_resources",
    "leaflet_css",
    "leaflet_head",
    "leaflet_js",
    "leaflet_licence",
    "render_self_contained",
    "script_json",
    "script_tag",
    "style_tag",
    "use_vendored_assets",
    "vendored_file",
]

#: Version of the vendored Leaflet (``trackmap/vendor/leaflet``).
LEAFLET_VERSION = "1.9.4"

_VENDOR_DIR = ("vendor", "leaflet")
# placeholders put into folium's resource lists; replaced by the inlined files
_PLACEHOLDER = "trackmap-vendored:"
_JS_PLACEHOLDER = _PLACEHOLDER + "leaflet.js"
_CSS_PLACEHOLDER = _PLACEHOLDER + "leaflet.css"


class NotSelfContainedError(TrackMapError, ValueError):
    """A page would load a script, stylesheet or image from the network."""


def vendored_file(name: str) -> bytes:
    """The bytes of a vendored Leaflet file (``leaflet.js``, ``images/layers.png``...).

    Raises
    ------
    FileNotFoundError
        No such file in ``trackmap/vendor/leaflet``.
    """
    res = importlib.resources.files("trackmap").joinpath(*_VENDOR_DIR, *name.split("/"))
    return res.read_bytes()


def _data_uri(name: str) -> str:
    data = base64.b64encode(vendored_file(name)).decode("ascii")
    return f"data:image/png;base64,{data}"


@functools.cache
def leaflet_css() -> str:
    """Leaflet's stylesheet with its images inlined as ``data:`` URIs."""
    css = vendored_file("leaflet.css").decode("utf-8")

    def inline(match: re.Match[str]) -> str:
        return f'url("{_data_uri(match.group(1))}")'

    return re.sub(r"url\(\s*['\"]?(images/[\w.-]+\.png)['\"]?\s*\)", inline, css)


@functools.cache
def leaflet_js() -> str:
    """Leaflet's script (its copyright header kept, the source-map comment dropped)."""
    js = vendored_file("leaflet.js").decode("utf-8")
    return re.sub(r"\n//# sourceMappingURL=\S+\s*$", "\n", js)


@functools.cache
def leaflet_licence() -> str:
    """The text of Leaflet's licence (BSD 2-Clause)."""
    return vendored_file("LICENSE").decode("utf-8")


def script_tag(js: str, *, element_id: str | None = None) -> str:
    """An inline ``<script>`` element holding ``js``.

    Raises
    ------
    ValueError
        ``js`` contains ``</script`` outside what can be escaped safely.
    """
    if re.search(r"</script", js, flags=re.I):
        raise ValueError("inline script contains '</script'; escape it as '<\\/script'")
    attr = f' id="{html_lib.escape(element_id)}"' if element_id else ""
    return f"<script{attr}>{js}</script>"


def style_tag(css: str, *, element_id: str | None = None) -> str:
    """An inline ``<style>`` element holding ``css``."""
    if re.search(r"</style", css, flags=re.I):
        raise ValueError("inline stylesheet contains '</style'")
    attr = f' id="{html_lib.escape(element_id)}"' if element_id else ""
    return f"<style{attr}>{css}</style>"


def script_json(value: Any) -> str:
    """``value`` as a JSON literal safe to place inside an inline ``<script>``.

    ``</`` and ``<!--`` (which could end the script or confuse the HTML parser) only occur
    inside JSON strings, where ``<\\/`` and ``<\\!--`` mean the same.
    """
    text = json.dumps(value, ensure_ascii=False, separators=(",", ":"), allow_nan=False)
    return text.replace("</", "<\\/").replace("<!--", "<\\!--")


@functools.cache
def _icon_defaults_js() -> str:
    # Leaflet finds its default marker icon through a CSS background-image URL it then
    # strips; with data: URIs that fails, so the icons are set directly.
    urls = {
        "iconUrl": _data_uri("images/marker-icon.png"),
        "iconRetinaUrl": _data_uri("images/marker-icon-2x.png"),
        "shadowUrl": _data_uri("images/marker-shadow.png"),
    }
    return f'L.Icon.Default.imagePath = "";L.Icon.Default.mergeOptions({json.dumps(urls)});'


def _licence_comment() -> str:
    text = leaflet_licence().replace("--", "- -")
    return (
        f"<!-- Leaflet {LEAFLET_VERSION} (https://leafletjs.com), inlined from the copy "
        f"shipped with trackmap. Its licence:\n{text}-->"
    )


def leaflet_head() -> str:
    """HTML for a page's ``<head>``: Leaflet's licence, stylesheet and script, inlined."""
    return "\n".join(
        [
            _licence_comment(),
            style_tag(leaflet_css(), element_id="leaflet-css"),
            script_tag(leaflet_js(), element_id="leaflet-js"),
            script_tag(_icon_defaults_js()),
        ]
    )


def use_vendored_assets(fmap: Any) -> None:
    """Make a folium map load Leaflet from the vendored copy and nothing from a CDN.

    Call before the page is rendered; :func:`render_self_contained` then inlines the
    files. jQuery, Bootstrap, Font Awesome and the awesome-markers, which folium links by
    default, are not loaded: the elements the project draws with (GeoJson, tooltips,
    GeoJsonPopup, circle markers, polylines, the layer control) do not need them.
    """
    fmap.default_js = [("leaflet", _JS_PLACEHOLDER)]
    fmap.default_css = [("leaflet_css", _CSS_PLACEHOLDER)]


def render_self_contained(fmap: Any) -> str:
    """Render a folium map (prepared by :func:`use_vendored_assets`) to one HTML page.

    Returns
    -------
    str
        The page, every script and stylesheet inline.

    Raises
    ------
    NotSelfContainedError
        Something in the page would still be fetched from the network (e.g. a folium
        plugin with its own CDN links); the message lists the addresses.
    """
    page = fmap.get_root().render()
    js_tag = re.compile(
        r"<script[^>]*\bsrc=\"" + re.escape(_JS_PLACEHOLDER) + r"\"[^>]*>\s*</script>"
    )
    css_tag = re.compile(r"<link[^>]*\bhref=\"" + re.escape(_CSS_PLACEHOLDER) + r"\"[^>]*/?>")
    if not js_tag.search(page) or not css_tag.search(page):
        raise NotSelfContainedError(
            "the page was not prepared with use_vendored_assets(), or folium changed how it "
            "links scripts: Leaflet could not be inlined"
        )
    # the script where folium put the link; the stylesheet and licence go with it
    page = css_tag.sub(lambda _m: "", page, count=1)
    page = js_tag.sub(lambda _m: leaflet_head(), page, count=1)
    remote = external_resources(page)
    if remote:
        raise NotSelfContainedError(
            "the page would fetch these from the network: " + ", ".join(sorted(set(remote)))
        )
    return page


_RESOURCE_ATTR = re.compile(
    r"<(?:script|link|img|iframe|embed|source|audio|video|object)\b[^>]*?"
    r"\b(?:src|href|data)\s*=\s*(?:\"([^\"]*)\"|'([^']*)'|([^\s>]+))",
    flags=re.I,
)
_CSS_URL = re.compile(r"url\(\s*['\"]?([^'\")]+)['\"]?\s*\)|@import\s+['\"]([^'\"]+)['\"]", re.I)


def external_resources(page: str) -> list[str]:
    """Addresses a page would fetch when opened: script, stylesheet, image and frame
    sources and CSS ``url()``/``@import`` that are not inline (``data:``), fragments
    (``#...``) or the placeholders of :func:`use_vendored_assets`.

    Links a user may click (``<a href>``) and tile URL templates inside scripts are not
    counted: they are not fetched when the page is opened.

    Parameters
    ----------
    page : str
        HTML text.

    Returns
    -------
    list of str
        In order of appearance.
    """
    found: list[str] = []
    for m in _RESOURCE_ATTR.finditer(page):
        url = next(g for g in m.groups() if g is not None)
        if _fetches(url):
            found.append(url)
    for block in re.findall(r"<style[^>]*>(.*?)</style>", page, flags=re.S | re.I):
        for m in _CSS_URL.finditer(block):
            url = m.group(1) or m.group(2)
            if _fetches(url):
                found.append(url)
    return found


def _fetches(url: str) -> bool:
    u = url.strip().lower()
    return not (u.startswith(("data:", "#", "about:", "javascript:")) or u == "")
