"""Checks of numeric arguments shared by the braking model and ATP supervision.

Each check names the argument it rejects and raises
:class:`~antikol.errors.InvalidArgumentError` (a ``ValueError``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from antikol.errors import InvalidArgumentError
from antikol.numeric import finite_float, why_not_finite

__all__ = ["FloatArray", "finite", "like_inputs", "speeds"]

FloatArray = npt.NDArray[np.float64]


def speeds(value: npt.ArrayLike, name: str) -> FloatArray:
    """Speeds as an array, checked finite and non-negative, m/s."""
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise InvalidArgumentError(name, value, "must be finite")
    if np.any(arr < 0.0):
        raise InvalidArgumentError(name, value, "must be >= 0 m/s")
    return arr


def finite(value: float, name: str) -> float:
    """A real, finite number as a float."""
    out = finite_float(value)
    if out is None:
        raise InvalidArgumentError(name, value, why_not_finite(value))
    return out


def like_inputs(result: FloatArray, *inputs: object) -> Any:
    """A float when every input was a scalar, else the array."""
    if all(np.ndim(x) == 0 for x in inputs):  # type: ignore[arg-type]
        return float(result)
    return result
