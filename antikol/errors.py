"""Exceptions raised by :mod:`antikol`.

Every exception derives from :class:`AntikolError` and also from the matching built-in
(``ValueError`` for bad values, ``OSError`` for unreadable inputs) so callers can catch
either.
"""

from __future__ import annotations

__all__ = [
    "AntikolError",
    "InputFileError",
    "InvalidArgumentError",
    "InvalidReportError",
    "ProfileError",
    "ProtocolError",
    "ReplayError",
    "UnknownVehicleError",
    "UsageError",
]


class AntikolError(Exception):
    """Base class of every error raised by antikol."""


class InvalidReportError(AntikolError, ValueError):
    """A vehicle report has a value outside its valid domain.

    Attributes
    ----------
    field : str
        Name of the offending field (e.g. ``"lat"``).
    value : object
        The rejected value.
    """

    def __init__(self, field: str, value: object, reason: str) -> None:
        self.field = field
        self.value = value
        self.reason = reason
        super().__init__(f"invalid {field}={_short_repr(value)}: {reason}")


class ProtocolError(AntikolError, ValueError):
    """A frame or payload cannot be encoded or decoded."""


class ProfileError(AntikolError, ValueError):
    """A braking profile has invalid values or cannot be read."""


class ReplayError(AntikolError, ValueError):
    """A replay log has a malformed row (raised only in strict mode)."""


class InputFileError(AntikolError, OSError):
    """An input file or directory is missing or unreadable."""


class UsageError(AntikolError, ValueError):
    """A command was asked for something it cannot do (the message says what to change)."""


class UnknownVehicleError(AntikolError, KeyError):
    """The analyser has no current report for the requested vehicle."""

    def __str__(self) -> str:  # KeyError quotes its argument; keep the sentence readable
        return str(self.args[0]) if self.args else "unknown vehicle"


class InvalidArgumentError(AntikolError, ValueError):
    """A function argument is outside its valid domain (the message names it).

    Attributes
    ----------
    name : str
        Name of the argument.
    value : object
        The rejected value.
    """

    def __init__(self, name: str, value: object, reason: str) -> None:
        self.name = name
        self.value = value
        self.reason = reason
        super().__init__(f"{name} must be valid, got {_short_repr(value)}: {reason}")


def _short_repr(value: object, limit: int = 80) -> str:
    """repr() cut to ``limit`` characters: error messages must not echo huge inputs."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
