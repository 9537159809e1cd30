"""Stored track geometry shipped with trackmap (installed as ``trackmap.maps``).

See ``ATTRIBUTION``: © OpenStreetMap contributors, ODbL 1.0.
"""
