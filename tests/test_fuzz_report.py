"""Fuzzing VehicleReport's fields and the radio frame encoder (bounded).

A report built from any values is either an InvalidReportError or holds exactly the values
given (reals as float). ``encode_report`` of any valid report gives a frame that decodes to
the same report within the wire's resolution, or an EncodeError.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from antikol.errors import InvalidReportError, ProtocolError
from antikol.ingest.protocol import encode_report
from antikol.report import VehicleReport
from tests._fuzz import draw_report_fields, try_encode, try_report

ANY = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    st.floats(),
    st.text(max_size=40),
    st.lists(st.integers(), max_size=5),
    st.tuples(st.integers()),
)


def _real(lo: float, hi: float):
    return st.one_of(st.floats(lo, hi), st.integers(math.ceil(lo), math.floor(hi)), ANY)


FIELDS = {
    "vehicle_id": st.one_of(st.text(min_size=0, max_size=40), ANY),
    "t": _real(-1e12, 1e12),
    "lat": _real(-91, 91),
    "lon": _real(-181, 181),
    "speed_mps": _real(-1, 101),
    "course_deg": _real(-1, 361),
    "braking": st.one_of(st.sampled_from(["none", "service", "emergency", "x"]), ANY),
    "length_m": st.one_of(st.none(), _real(-1, 1e3 + 1)),
    "antenna_offset_m": st.one_of(st.none(), _real(-1, 1e10)),
    "route": st.one_of(st.none(), st.lists(st.integers(-1, 2**32), max_size=300), ANY),
    "seq": st.one_of(st.none(), st.integers(-1, 2**33), ANY),
    "hdop": st.one_of(st.none(), st.floats(min_value=0), ANY),
    "fix_quality": st.one_of(st.none(), st.integers(-1, 10), ANY),
    "odometer_m": st.one_of(st.none(), _real(-1, 1e15)),
}


@settings(max_examples=600, deadline=None)
@given(st.fixed_dictionaries({}, optional=FIELDS), st.randoms(use_true_random=False))
def test_any_report_fields_are_rejected_or_kept_exactly(drawn, rng):
    kw = draw_report_fields(rng)
    kw.update(drawn)
    outcome = try_report(kw)
    assert outcome.kind in ("accepted", "rejected"), outcome.detail


VALID = st.builds(
    VehicleReport,
    vehicle_id=st.text(
        alphabet=st.characters(codec="utf-8", categories=["L", "N", "P", "S"]),
        min_size=1,
        max_size=8,
    ),
    t=st.floats(-1e300, 1e300),
    lat=st.floats(-90, 90),
    lon=st.floats(-180, 180),
    speed_mps=st.floats(0, 100),
    course_deg=st.floats(0, 360),
    braking=st.sampled_from(["none", "service", "emergency"]),
    length_m=st.one_of(st.none(), st.floats(1e-9, 1000)),
    route=st.one_of(st.none(), st.lists(st.integers(0, 2**32 - 1), max_size=255)),
    seq=st.one_of(st.none(), st.integers(0, 2**32 - 1)),
    hdop=st.one_of(st.none(), st.floats(0, 1e308)),
    fix_quality=st.one_of(st.none(), st.integers(0, 9)),
)


@settings(max_examples=400, deadline=None)
@given(VALID)
@example(VehicleReport("T1", 0.0, 50.0, 20.0, 1.0, 2.0, hdop=1e308))
def test_the_frame_encoder_encodes_any_valid_report(report):
    try:
        encode_report(report)  # no OverflowError, whatever the magnitudes
    except ProtocolError:
        return
    outcome = try_encode(report)
    assert outcome.kind in ("accepted", "rejected"), outcome.detail


def test_the_report_fuzzer_sees_both_outcomes():
    import random

    rng = random.Random(1)
    kinds = {try_report(draw_report_fields(rng)).kind for _ in range(300)}
    assert kinds == {"accepted", "rejected"}
    with pytest.raises(InvalidReportError):
        VehicleReport("T1", 0.0, 91.0, 0.0, 0.0, 0.0)
