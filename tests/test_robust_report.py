"""VehicleReport's validation has no gaps: every bad value is an InvalidReportError that
names the field and never echoes a huge value (issue 14)."""

from __future__ import annotations

import contextlib

import pytest

from antikol import InvalidReportError, VehicleReport
from antikol.ingest.protocol import EncodeError, decode_frame, encode_report

BASE = {
    "vehicle_id": "T1",
    "t": 1.0,
    "lat": 50.06,
    "lon": 19.94,
    "speed_mps": 8.0,
    "course_deg": 90.0,
}


@pytest.mark.parametrize(
    ("field", "value", "reason"),
    [
        ("t", 10**400, "too large for a double"),
        ("vehicle_id", "\udc80", "not valid Unicode text"),
        ("vehicle_id", "   ", "blank"),
        ("vehicle_id", "x" * 10_000_000, "longer than 32 UTF-8 bytes"),
        ("route", 5, "must be a sequence of edge ids"),
        ("route", "12", "must be a sequence of edge ids"),
        ("braking", ["none"], "must be one of"),
        ("lat", 10**400, "too large for a double"),
    ],
)
def test_bad_values_are_invalid_report_errors(field, value, reason):
    with pytest.raises(InvalidReportError, match=reason) as err:
        VehicleReport(**{**BASE, field: value})
    assert err.value.field == field
    assert len(str(err.value)) < 200


def test_real_fields_are_stored_as_float():
    r = VehicleReport(**{**BASE, "t": 2**53 + 1, "lat": 50, "length_m": 30})
    assert type(r.t) is float and type(r.lat) is float and type(r.length_m) is float
    assert decode_frame(encode_report(r)).t == r.t


def test_an_hdop_beyond_the_frame_saturates_or_is_an_encode_error():
    r = VehicleReport(**{**BASE, "hdop": 1e308})
    with contextlib.suppress(EncodeError):  # an EncodeError is a clear answer too
        assert decode_frame(encode_report(r)).hdop == 655.35
