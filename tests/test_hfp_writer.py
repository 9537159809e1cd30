"""The HFP writer (``antikol simulate --hfp``) and the HFP reader agree: what is written is
read back at the feed's resolution, a report without a fix as the feed sends it."""

from __future__ import annotations

import json
import math

from hypothesis import example, given, settings
from hypothesis import strategies as st

from antikol import VehicleReport
from antikol.ingest import read_hfp, write_hfp
from antikol.ingest.hfp_writer import hfp_message, hfp_vehicle_numbers

EPOCH_S = 1_700_000_000.0


@st.composite
def _runs(draw):
    """A few vehicles' reports at 1 Hz; some without a fix (never a vehicle's first),
    some estimated, some without an odometer."""
    reports = []
    for vid in draw(
        st.lists(st.sampled_from(["T1", "T07", "T12", "X9"]), min_size=1, max_size=3, unique=True)
    ):
        n = draw(st.integers(1, 6))
        odometer = draw(st.one_of(st.none(), st.floats(0.0, 1e6)))
        for k in range(n):
            quality = 1 if k == 0 else draw(st.sampled_from([1, 1, 0, 6]))
            # (0, 0) as written (to 1e-6 degree) is what feeds write without a fix, and is read
            # as none: not a place
            lat, lon = draw(
                st.tuples(st.floats(-80.0, 80.0), st.floats(-179.0, 179.0)).filter(
                    lambda p: (round(p[0], 6), round(p[1], 6)) != (0.0, 0.0)
                )
            )
            reports.append(
                VehicleReport(
                    vid,
                    float(k) + draw(st.floats(0.0, 0.9)),
                    lat,
                    lon,
                    draw(st.floats(0.0, 30.0)),
                    draw(st.floats(0.0, 359.4)),
                    fix_quality=quality,
                    odometer_m=None if odometer is None else odometer + 10.0 * k,
                )
            )
    return sorted(reports, key=lambda r: (r.t, r.vehicle_id))


@settings(max_examples=60, deadline=None)
@given(_runs())
@example([VehicleReport("T1", 0.0005, 50.06, 19.94, 0.0, 0.0, fix_quality=1)])  # half a ms
def test_written_reports_read_back_at_the_feeds_resolution(tmp_path_factory, reports):
    path = write_hfp(tmp_path_factory.mktemp("hfp") / "log.jsonl", reports, epoch_utc_s=EPOCH_S)
    log = read_hfp(path)
    assert not log.problems
    numbers = hfp_vehicle_numbers(r.vehicle_id for r in reports)
    assert len(log.reports) == len(reports)
    by_vehicle: dict[str, list[VehicleReport]] = {}
    for back in log.reports:
        by_vehicle.setdefault(back.vehicle_id, []).append(back)
    last_fix = {}
    for r in reports:
        back = by_vehicle[f"40/{numbers[r.vehicle_id]}"].pop(0)  # both in time order
        assert abs(back.t - EPOCH_S - r.t) <= 0.0005 + 1e-6  # to the millisecond
        assert math.isclose(back.speed_mps, r.speed_mps, abs_tol=0.006)
        assert abs((back.course_deg - r.course_deg + 180.0) % 360.0 - 180.0) <= 0.5
        if r.odometer_m is None:
            assert back.odometer_m is None
        else:
            assert back.odometer_m is not None and abs(back.odometer_m - r.odometer_m) <= 0.5
        if r.fix_quality == 0:  # no position in the feed: the last known one is kept
            assert back.fix_quality == 0
            assert (back.lat, back.lon) == last_fix[r.vehicle_id]
            continue
        assert abs(back.lat - r.lat) <= 5.1e-7 and abs(back.lon - r.lon) <= 5.1e-7
        assert (back.fix_quality == 6) == (r.fix_quality == 6)  # an estimate stays one
        assert back.fix_quality != 0
        last_fix[r.vehicle_id] = (back.lat, back.lon)


def test_a_report_without_a_fix_has_no_position_and_loc_na():
    r = VehicleReport("T3", 12.5, 50.06, 19.94, 0.0, 0.0, fix_quality=0)
    fields = hfp_message(r, vehicle_number=3, epoch_utc_s=EPOCH_S)["VP"]
    assert fields["loc"] == "N/A" and fields["lat"] is None and fields["long"] is None
    assert fields["tst"] == "2023-11-14T22:13:32.500Z" and fields["odo"] is None
    json.dumps(fields)  # JSON-ready


def test_vehicle_numbers_come_from_the_ids_when_they_are_distinct():
    assert hfp_vehicle_numbers(["T01", "T12", "T7"]) == {"T01": 1, "T12": 12, "T7": 7}
    # (ids without a number, or two ending in the same one: their sorted place)
    assert hfp_vehicle_numbers(["B", "A"]) == {"A": 1, "B": 2}
    assert hfp_vehicle_numbers(["A1", "B01", "C2"]) == {"A1": 1, "B01": 2, "C2": 3}
