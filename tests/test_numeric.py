"""The one rule for finite numbers, and the three places that use it."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from antikol.errors import InvalidArgumentError, InvalidReportError
from antikol.numeric import finite_float, why_not_finite

_ANY = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**400), max_value=10**400),
    st.booleans(),
    st.text(max_size=3),
    st.none(),
    st.fractions(),
    st.decimals(allow_nan=True),
)


@given(_ANY)
def test_finite_float_and_its_reason_agree(value):
    out = finite_float(value)
    reason = why_not_finite(value)
    assert (out is None) == bool(reason)
    if out is not None:
        assert isinstance(out, float) and math.isfinite(out)
        assert out == float(value)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("value", "reason"),
    [
        (True, "must be a real number"),
        ("1", "must be a real number"),
        (10**400, "too large for a double"),
        (math.nan, "must be finite (NaN or infinite)"),
        (-math.inf, "must be finite (NaN or infinite)"),
    ],
)
def test_every_entry_point_refuses_with_the_same_reason(value, reason):
    from antikol import VehicleReport
    from antikol.analysis.arguments import finite

    with pytest.raises(InvalidReportError, match=reason.split(" (")[0]):
        VehicleReport("T1", 0.0, 50.0, 19.9, value, 0.0)
    with pytest.raises(InvalidArgumentError, match=reason.split(" (")[0]):
        finite(value, "x")


def test_a_cam_epoch_follows_the_same_rule():
    pytest.importorskip("pycrate_asn1rt")
    from antikol import VehicleReport
    from antikol.ingest.cam import encode_cam

    report = VehicleReport("T1", 1.0, 50.0, 19.9, 5.0, 90.0)
    for bad in (True, 10**400, math.nan):
        with pytest.raises(InvalidArgumentError, match="epoch_unix_s"):
            encode_cam(report, station_id=1, epoch_unix_s=bad)
    assert encode_cam(report, station_id=1, epoch_unix_s=1.7e9)
