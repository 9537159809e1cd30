"""Argument checks shared by the analysis functions: the project's error, never a bare one."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from antikol.analysis.arguments import finite
from antikol.errors import InvalidArgumentError


@pytest.mark.parametrize("bad", [10**400, -(10**400), math.nan, math.inf, True, "1", None])
def test_finite_refuses_with_the_projects_error(bad):
    with pytest.raises(InvalidArgumentError, match="speed_mps"):
        finite(bad, "speed_mps")


@given(st.one_of(st.integers(), st.floats(allow_nan=True, allow_infinity=True)))
def test_finite_returns_the_float_or_raises_only_its_error(value):
    try:
        out = finite(value, "x")
    except InvalidArgumentError:
        return
    assert math.isfinite(out) and out == float(value)
