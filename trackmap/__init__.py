"""trackmap: a rail network graph built from stored track geometry (OpenStreetMap)."""

__version__ = "0.1.0"
