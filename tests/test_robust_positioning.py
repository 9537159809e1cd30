"""Valid reports that the positioner refuses or scales down still leave a position for
every report and finite numbers, and the on-board analyser answers before its own
vehicle's first report (an adversarial probe's findings; each test failed before)."""

from __future__ import annotations

import math
import warnings

import pytest

import antikol
import trackmap
from antikol import VehicleReport
from antikol.evaluation.consistency import match_reports
from antikol.positioning.config import MAX_HDOP

# a point beside a track of the embedded Kraków map, and one 7 m east along it
LAT, LON = 50.06306, 19.93260
LON_NEXT = 19.93270


@pytest.fixture(scope="module")
def krakow():
    return trackmap.load_default()


def _report(vid: str, t: float, lon: float = LON, **kw) -> VehicleReport:
    kw.setdefault("speed_mps", 8.0)
    return VehicleReport(vid, t, LAT, lon, course_deg=90.0, **kw)


def test_a_first_report_too_fast_for_a_tram_still_gets_its_position(krakow):
    # 45 m/s is a valid report (a km/h feed read as m/s) but beyond max_speed_mps (30)
    fast = _report("T1", 0.0, speed_mps=45.0)
    pos = antikol.Positioner(krakow)
    first = pos.update(fast)
    assert first.status == "unmatched" and first.edge_id is None
    assert (first.lat, first.lon, first.t) == (LAT, LON, 0.0)
    assert pos.stats["rejected_speed"] == 1
    # the next plausible report starts the vehicle as any first report does
    assert pos.update(_report("T1", 1.0, LON_NEXT)).hypotheses
    # one position per report, whatever the batch
    batch = antikol.Positioner(krakow).update_many([fast, _report("T2", 0.0)])
    assert [p.vehicle_id for p in batch] == ["T1", "T2"]
    assert batch[0].status == "unmatched"
    matched = match_reports(krakow, [fast, _report("T1", 1.0, LON_NEXT)], hindsight=True)
    assert [m.position.t for m in matched] == [0.0, 1.0]


def test_an_hdop_beyond_what_nmea_states_is_taken_at_its_largest(krakow):
    def run(hdop: float) -> list[antikol.TrackPosition]:
        pos = antikol.Positioner(krakow)
        return [pos.update(_report("T1", float(t), LON + 1e-4 * t, hdop=hdop)) for t in range(3)]

    huge, largest = run(1e200), run(MAX_HDOP)
    assert all(p.sigma_m is not None and math.isfinite(p.sigma_m) for p in huge)
    assert huge == largest


def test_on_board_before_the_own_vehicles_first_report(krakow):
    an = antikol.Analyser(track_map=krakow, own_id="T1")
    an.update(_report("T2", 5.0))
    # the table has no clock yet: the newest report held stands in for it
    assert an.position("T2").t == 5.0
    assert an.position("T2", as_placed=True).t == 5.0
    assert an.assess("T2").t == 5.0
    assert set(an.assess_all()) == {"T2"}
    assert isinstance(an.zones("T2"), list)
    an.update(_report("T1", 6.0, LON_NEXT))
    assert an.assess().t == 6.0


def test_a_position_asked_for_absurdly_far_ahead_is_lost_not_nan(krakow):
    pos = antikol.Positioner(krakow)
    for t in range(5):  # an odometer: dead reckoning runs out only by its distance
        pos.update(_report("T1", float(t), LON + 8e-5 * t, odometer_m=6.0 * t))
    for t in (1e200, 1.7e308):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # (an overflow is the answer, not a warning)
            ahead = pos.position("T1", t)
        assert ahead.status == "lost"
        assert ahead.sigma_m is not None and not math.isnan(ahead.sigma_m)
