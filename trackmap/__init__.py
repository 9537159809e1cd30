"""trackmap: a rail network graph built from stored track geometry (OpenStreetMap).

>>> import trackmap
>>> net = trackmap.load_default()            # Kraków's tram network, © OSM contributors
>>> cands = net.candidates(19.93260, 50.06306, radius_m=25.0)   # Teatr Bagatela 01
>>> paths = net.paths_ahead(cands[0].edge_id, cands[0].offset_m, 1, 300.0)
>>> {p.end for p in paths} <= set(trackmap.PathEnd)   # why each route ends
True

Layout: the build side (:mod:`trackmap.builder`: reading sources, inferring topology,
assembling) produces a :class:`TrackMap` (:mod:`trackmap.network`) made of the records
of :mod:`trackmap.model`; routing runs in :mod:`trackmap.routing`; map files are read
and written by :mod:`trackmap.mapfile` and :mod:`trackmap.storage`. Importing trackmap
needs neither osmium, tqdm, matplotlib nor folium: they are imported by the functions
that use them.
"""

from trackmap.builder import build
from trackmap.crs import LocalFrame
from trackmap.defaults import default_map_path, load_default
from trackmap.errors import (
    MapFileError,
    MissingDependencyError,
    NoTracksError,
    ParameterError,
    SourceError,
    SourceFormatError,
    TrackMapError,
    UnknownEdgeError,
)
from trackmap.kinds import ConflictKind, Direction, NodeClass, PathEnd
from trackmap.model import (
    Candidate,
    CandidateBatch,
    ConflictPass,
    ConflictPoint,
    Edge,
    GradeSeparation,
    MapData,
    MapMetadata,
    Node,
    NodePass,
    Path,
    PathStep,
    RouteDistance,
    Stop,
    TrackState,
)
from trackmap.named import load_named
from trackmap.network import TrackMap
from trackmap.storage import load, save

__version__ = "0.1.0"

__all__ = [
    "Candidate",
    "CandidateBatch",
    "ConflictKind",
    "ConflictPass",
    "ConflictPoint",
    "Direction",
    "Edge",
    "GradeSeparation",
    "LocalFrame",
    "MapData",
    "MapFileError",
    "MapMetadata",
    "MissingDependencyError",
    "NoTracksError",
    "Node",
    "NodeClass",
    "NodePass",
    "ParameterError",
    "Path",
    "PathEnd",
    "PathStep",
    "RouteDistance",
    "SourceError",
    "SourceFormatError",
    "Stop",
    "TrackMap",
    "TrackMapError",
    "TrackState",
    "UnknownEdgeError",
    "__version__",
    "build",
    "default_map_path",
    "load",
    "load_default",
    "load_named",
    "save",
]
