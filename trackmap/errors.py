"""Exceptions raised by :mod:`trackmap`.

Each derives from :class:`TrackMapError` and from the matching built-in, so callers can
catch ``ValueError`` / ``OSError`` / ``ImportError`` without importing trackmap.
"""

from __future__ import annotations

__all__ = [
    "MapFileError",
    "MissingDependencyError",
    "NoTracksError",
    "ParameterError",
    "SourceError",
    "SourceFormatError",
    "TrackMapError",
    "UnknownEdgeError",
]


class TrackMapError(Exception):
    """Base class of every trackmap error."""


class SourceError(TrackMapError, OSError):
    """A source file is missing or unreadable."""


class SourceFormatError(TrackMapError, ValueError):
    """A source file is of an unknown format or cannot be parsed."""


class NoTracksError(TrackMapError, ValueError):
    """A source file holds no usable track of the requested kinds."""


class ParameterError(TrackMapError, ValueError):
    """A function argument or command-line option is outside its valid domain."""


class MapFileError(TrackMapError, ValueError):
    """A map file is broken, of an unknown format or of an unsupported version."""


class UnknownEdgeError(TrackMapError, KeyError):
    """An edge id that the map does not have."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "unknown edge"


class MissingDependencyError(TrackMapError, ImportError):
    """An optional package a function needs is not installed; the message says which."""
