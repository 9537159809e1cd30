"""trackmap: a rail network graph built from stored track geometry (OpenStreetMap).

>>> import trackmap
>>> net = trackmap.load_default()            # Kraków's tram network, © OSM contributors
>>> cands = net.candidates(19.93260, 50.06306, radius_m=25.0)   # Teatr Bagatela 01
>>> paths = net.paths_ahead(cands[0].edge_id, cands[0].offset_m, 1, 300.0)
"""

from trackmap.build import build
from trackmap.crs import LocalFrame
from trackmap.defaults import default_map_path, load_default
from trackmap.errors import (
    MapFileError,
    NoTracksError,
    SourceError,
    SourceFormatError,
    TrackMapError,
    UnknownEdgeError,
)
from trackmap.mapfile import load, save
from trackmap.network import (
    Candidate,
    CandidateBatch,
    ConflictPass,
    ConflictPoint,
    Edge,
    Node,
    NodePass,
    Path,
    PathStep,
    RouteDistance,
    Stop,
    TrackMap,
)

__version__ = "0.1.0"

__all__ = [
    "Candidate",
    "CandidateBatch",
    "ConflictPass",
    "ConflictPoint",
    "Edge",
    "LocalFrame",
    "MapFileError",
    "NoTracksError",
    "Node",
    "NodePass",
    "Path",
    "PathStep",
    "RouteDistance",
    "SourceError",
    "SourceFormatError",
    "Stop",
    "TrackMap",
    "TrackMapError",
    "UnknownEdgeError",
    "__version__",
    "build",
    "default_map_path",
    "load",
    "load_default",
    "save",
]
