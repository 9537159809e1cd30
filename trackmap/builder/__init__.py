"""The build side of trackmap: from stored track geometry to a :class:`~trackmap.TrackMap`.

Three steps, one module each: :mod:`~trackmap.builder.sources` reads OSM XML/PBF, Overpass
JSON or GeoJSON into plain records; :mod:`~trackmap.builder.topology` infers edges, node
classes, running directions and crossings from them (the direction of untagged double track
from the driving side, :mod:`~trackmap.builder.drivingside`, which reads it from the tagged
track); :mod:`~trackmap.builder.assemble`
runs the steps and assembles the map. The query side (:mod:`trackmap.network`,
:mod:`trackmap.routing`, :mod:`trackmap.mapfile`) never imports this package.
"""

from trackmap.builder.assemble import assemble, build

__all__ = ["assemble", "build"]
