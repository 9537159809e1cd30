"""Fast constructors for frozen, slotted record classes.

A frozen dataclass's generated ``__init__`` sets every field through
``object.__setattr__``: about 0.1 µs per field, which adds up when a cycle builds tens of
thousands of records (the steps of the paths ahead, a control room's assessments).
:func:`positional` builds the same objects by setting their slots directly.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["positional"]

_R = TypeVar("_R")


def positional(cls: type[_R]) -> Callable[..., _R]:
    """A constructor of a frozen slotted dataclass taking every field by position.

    It sets the slots directly, as the class's own ``__init__`` would through
    ``object.__setattr__``: the objects are equal, hash alike and stay frozen. No defaults
    and no ``__post_init__``: only for records that have no validation to skip.

    Parameters
    ----------
    cls : type
        A dataclass declared with ``frozen=True, slots=True``.

    Returns
    -------
    callable
        ``make(*values)`` with one value per field, in the order of the fields.

    Raises
    ------
    TypeError
        ``cls`` is not a slotted dataclass, or has a ``__post_init__``.

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True, slots=True)
    ... class Span:
    ...     start_m: float
    ...     end_m: float = 0.0
    >>> make = positional(Span)
    >>> make(1.0, 2.5) == Span(1.0, 2.5)
    True
    """
    if not dataclasses.is_dataclass(cls) or "__slots__" not in vars(cls):
        raise TypeError(f"{cls!r} is not a slotted dataclass")
    if hasattr(cls, "__post_init__"):
        raise TypeError(f"{cls.__name__} validates its fields in __post_init__")
    names = [f.name for f in dataclasses.fields(cls)]
    setters = {f"_set_{k}": getattr(cls, name).__set__ for k, name in enumerate(names)}
    args = ", ".join(f"v{k}" for k in range(len(names)))
    body = "".join(f"    _set_{k}(obj, v{k})\n" for k in range(len(names)))
    source = f"def make({args}):\n    obj = _new(_cls)\n{body}    return obj\n"
    scope: dict[str, Any] = {"_new": object.__new__, "_cls": cls, **setters}
    exec(source, scope)  # as dataclasses builds __init__: one plain call per field
    make: Callable[..., _R] = scope["make"]
    make.__qualname__ = f"positional({cls.__name__})"
    return make
