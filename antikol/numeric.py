"""One rule for what counts as a real, finite number wherever values enter the library.

A value received from a feed, a file, the radio or a caller is a number only if it is a
real number that is not a ``bool`` and is finite as a double: NaN, infinities and integers
beyond a double's range (``float(10**400)`` raises ``OverflowError``) are refused, each
caller with its own error naming the field (:func:`why_not_finite` gives the reason).

>>> finite_float(3), finite_float(True), finite_float(float("nan")), finite_float(10**400)
(3.0, None, None, None)
>>> why_not_finite(10**400)
'too large for a double'
"""

from __future__ import annotations

import math
import numbers

__all__ = ["finite_float", "why_not_finite"]


def finite_float(value: object) -> float | None:
    """``value`` as a finite float, or None when it is not a real, finite number."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return None
    try:
        number = float(value)
    except OverflowError:  # an int beyond the range of a double
        return None
    return number if math.isfinite(number) else None


def why_not_finite(value: object) -> str:
    """Why :func:`finite_float` refuses ``value`` (empty when it does not)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return "must be a real number"
    try:
        number = float(value)
    except OverflowError:
        return "too large for a double"
    return "" if math.isfinite(number) else "must be finite (NaN or infinite)"
