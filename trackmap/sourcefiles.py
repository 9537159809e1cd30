"""The source files a map is built from, told by their names.

Shared by the build side (:mod:`trackmap.builder.sources`) and the query side's map names
(:mod:`trackmap.named`, which builds a map from a source named where a map file is
expected) without the query side importing the builder.

>>> is_osm_extract("helsinki.osm.pbf"), is_osm_extract("helsinki.trackmap.geojson")
(True, False)
"""

from __future__ import annotations

from typing import Final

__all__ = ["OSMIUM_SUFFIXES", "is_osm_extract"]

#: File names osmium reads as OSM data (XML, PBF, compressed XML, o5m, change files).
OSMIUM_SUFFIXES: Final = (".osm.pbf", ".pbf", ".osm", ".osm.bz2", ".osm.gz", ".o5m", ".osc")


def is_osm_extract(name: str) -> bool:
    """Whether a file name (any case) is one osmium reads.

    Parameters
    ----------
    name : str
        A file name or path.
    """
    return name.lower().endswith(OSMIUM_SUFFIXES)
