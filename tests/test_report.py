import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from antikol import InvalidReportError, ReportedTrackPosition, VehicleReport

BASE = dict(vehicle_id="T1", t=0.0, lat=50.06, lon=19.94, speed_mps=8.0, course_deg=90.0)


def make(**kw):
    return VehicleReport(**{**BASE, **kw})


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("lat", math.nan),
        ("lat", 90.0001),
        ("lat", -91.0),
        ("lon", 180.5),
        ("lon", math.inf),
        ("speed_mps", -0.1),
        ("speed_mps", 100.01),
        ("speed_mps", math.nan),
        ("course_deg", -1.0),
        ("course_deg", 360.1),
        ("t", math.inf),
        ("vehicle_id", ""),
        ("vehicle_id", "x" * 33),
        ("vehicle_id", "bad\nid"),
        ("length_m", 0.0),
        ("braking", "hard"),
        ("hdop", -1.0),
        ("fix_quality", 12),
        ("seq", -1),
    ],
)
def test_invalid_values_name_the_field(field, value):
    with pytest.raises(InvalidReportError) as err:
        make(**{field: value})
    assert err.value.field == field
    assert field in str(err.value)
    assert isinstance(err.value, ValueError)


def test_course_360_is_stored_as_zero_and_route_as_tuple():
    r = make(course_deg=360.0, route=[3, 4, 5])
    assert r.course_deg == 0.0
    assert r.route == (3, 4, 5)


def test_antenna_beyond_length_rejected():
    with pytest.raises(InvalidReportError, match="antenna_offset_m"):
        make(length_m=30.0, antenna_offset_m=31.0)


def test_track_position_validated():
    with pytest.raises(InvalidReportError, match="direction"):
        ReportedTrackPosition(edge_id=3, offset_m=1.0, direction=0)
    with pytest.raises(InvalidReportError, match="offset_m"):
        ReportedTrackPosition(edge_id=3, offset_m=-1.0, direction=1)


@given(
    lat=st.floats(-90, 90),
    lon=st.floats(-180, 180),
    speed=st.floats(0, 100),
    course=st.floats(0, 360),
)
def test_any_value_in_range_is_accepted(lat, lon, speed, course):
    r = make(lat=lat, lon=lon, speed_mps=speed, course_deg=course)
    assert 0.0 <= r.course_deg < 360.0


@given(lat=st.floats(allow_nan=True, allow_infinity=True).filter(lambda v: not -90 <= v <= 90))
def test_any_latitude_out_of_range_is_rejected(lat):
    with pytest.raises(InvalidReportError):
        make(lat=lat)
