"""What the figures of a map look like: colours, markers and labels, shared by both kinds.

:mod:`trackmap.plot_static` (matplotlib) and :mod:`trackmap.plot_html` (folium) draw with
these, so a track class or node class looks the same in a PNG and on the Leaflet map.
"""

from __future__ import annotations

import os
import pathlib
from collections.abc import Sequence
from dataclasses import dataclass

from trackmap.errors import SourceError
from trackmap.model import Edge
from trackmap.network import TrackMap

__all__ = [
    "CROSSING_STYLE",
    "GRADE_SEPARATED_STYLE",
    "HIGHLIGHT_COLOURS",
    "NODE_STYLES",
    "STOP_STYLE",
    "TRACK_COLOURS",
    "TRACK_LABELS",
    "MarkerStyle",
    "default_title",
    "output_path",
    "track_class",
]

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
#: Legend text of each track class.
TRACK_LABELS: dict[str, str] = {
    "main": "main line",
    "yard": "yard (depot)",
    "siding": "siding",
    "spur": "spur",
    "crossover": "crossover",
    "other": "other service track",
}


@dataclass(frozen=True)
class MarkerStyle:
    """How a kind of point is marked on both kinds of figure.

    Attributes
    ----------
    label : str
        Legend text.
    marker : str
        matplotlib marker code.
    colour, edge : str
        Fill and edge colours (``"none"``: a ring).
    size : float
        matplotlib marker size, points.
    zorder : float
        Drawing order in the static figure.
    html_radius : float
        Radius of the CircleMarker on the HTML map, pixels.
    """

    label: str
    marker: str
    colour: str
    size: float
    edge: str
    zorder: float
    html_radius: float


#: Markers of the junction node classes (``link`` nodes are not marked).
NODE_STYLES: dict[str, MarkerStyle] = {
    "point_switch": MarkerStyle("point switch", "o", "#2ca02c", 3.2, "#135a13", 4.0, 4.0),
    "diamond_crossing": MarkerStyle("diamond crossing", "D", "#9467bd", 3.6, "#3f2266", 4.1, 5.0),
    "double_slip": MarkerStyle("double slip", "X", "#8c564b", 6.0, "#3b2420", 4.2, 6.0),
    "buffer_stop": MarkerStyle("buffer stop", "s", "#111111", 3.6, "#111111", 4.3, 4.0),
    "unknown": MarkerStyle("unknown junction", "*", "#ff1fd2", 9.0, "#7a0063", 4.4, 7.0),
}
#: At-grade crossings without a shared node (conflict points of kind ``crossing``).
CROSSING_STYLE = MarkerStyle("at-grade crossing (conflict)", "o", "none", 10.0, "#e31a1c", 4.6, 9.0)
#: Crossings at different levels (no conflict).
GRADE_SEPARATED_STYLE = MarkerStyle(
    "grade-separated crossing", "+", "#555555", 7.0, "#555555", 3.9, 5.0
)
#: Stops snapped to the track.
STOP_STYLE = MarkerStyle("stop", "^", "#17becf", 3.6, "#0b5f68", 3.8, 3.0)
#: Colours of highlighted paths, in turn.
HIGHLIGHT_COLOURS = (
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


def track_class(edge: Edge) -> str:
    """The drawing class of an edge: ``main`` or its ``service`` value (or ``other``)."""
    if edge.service is None:
        return "main"
    return edge.service if edge.service in TRACK_COLOURS else "other"


# -- helpers ------------------------------------------------------------------------------
def output_path(path: str | os.PathLike[str], suffixes: Sequence[str], what: str) -> pathlib.Path:
    """Check an output path: a supported suffix and an existing parent directory.

    Raises
    ------
    ValueError
        The suffix is not one of ``suffixes`` (``what`` names the writer in the message).
    trackmap.errors.SourceError
        The directory does not exist.
    """
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


def default_title(net: TrackMap) -> str:
    """Source file, edge count and track length (km): the title when none is given."""
    source = net.metadata.source.get("file") or "track map"
    km = float(sum(e.length_m for e in net.edges)) / 1000.0
    return f"{source}: {len(net.edges)} edges, {km:.1f} km of track"
