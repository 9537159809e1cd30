"""A trace that starts with the tram standing on double track (issue 12).

At a standstill the fixes sit between the two tracks with a bias of metres, and the
course over ground is no measurement. But most receivers hold the last course they
measured while moving: taken once, weakly, at the start, it tells the tracks apart, so the
tram does not stand on the other direction's track and jump across when it departs (a
window whose positions no permitted route connects). Its weight stays below
``confidence``: a double-ended tram holds its previous trip's course.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import VehicleReport
from antikol.errors import InvalidArgumentError
from antikol.positioning import PositioningConfig
from antikol.positioning.matcher import Positioner
from tests._osm import FRAME, OsmBuilder

#: The tracks' spacing, m: the northbound track at x = 0, the southbound one west of it.
SPACING_M = 3.8
STAND_S = 40
CONFIDENCE = PositioningConfig().confidence
STEADY = PositioningConfig().show_after_steady_course_reports


def _double_track(oneway: bool) -> OsmBuilder:
    b = OsmBuilder()
    tags = {"oneway": "yes"} if oneway else {}
    b.line([(0.0, 0.0), (0.0, 2000.0)], **tags)
    b.line([(-SPACING_M, 2000.0), (-SPACING_M, 0.0)], **tags)
    return b


@pytest.fixture(scope="module", params=[True, False], ids=["oneway", "driving-side"])
def double(request, tmp_path_factory):
    """Two straight tracks 2 km long; one-way tags, or right-hand running inferred."""
    path = tmp_path_factory.mktemp("double") / "double.osm"
    return trackmap.build(_double_track(request.param).write_xml(path), driving_side="right")


def _start_at_a_stop(
    bias_m: float, standing_course_deg: float, *, seed: int = 0, stand_s: int = STAND_S
) -> list[tuple[VehicleReport, float]]:
    """A northbound tram standing at y = 500 m for ``stand_s`` s, then departing at
    1 m/s² up to 10 m/s; its fixes ``bias_m`` west (toward the other track) with 0.5 m of
    white noise, its course ``standing_course_deg`` while it stands. Returns each report
    with the true northing, m."""
    rng = np.random.default_rng(seed)
    y, v, out = 500.0, 0.0, []
    for k in range(stand_s + 40):
        if k >= stand_s:
            v = min(10.0, v + 1.0)
            y += v
        x_fix = -bias_m + rng.normal(0.0, 0.5)
        lon, lat = FRAME.to_lonlat(x_fix, y + rng.normal(0.0, 0.5))
        course = standing_course_deg if v == 0.0 else float(rng.normal(0.0, 2.0)) % 360.0
        report = VehicleReport(
            "T", float(k), float(lat), float(lon), speed_mps=v, course_deg=course
        )
        out.append((report, y))
    return out


def _on_northbound(net: trackmap.TrackMap, pos) -> bool:
    """On the northbound track, running north."""
    if pos.edge_id is None:
        return False
    x, _ = FRAME.to_local(pos.lon, pos.lat)
    heading = (pos.heading_deg + 180.0) % 360.0 - 180.0
    return abs(float(x)) < 0.5 and abs(heading) < 30.0


@pytest.mark.parametrize("bias_m", [2.0, 3.0, 4.5])
def test_a_start_at_a_stop_takes_the_course_the_receiver_holds(double, bias_m):
    pos = Positioner(double)
    out = [(pos.update(r), y) for r, y in _start_at_a_stop(bias_m, 2.0)]
    # shown on a track once the course is seen to hold, not on the first fix
    assert all(p.unplaced and p.edge_id is None for p, _ in out[: STEADY - 1])
    assert all(_on_northbound(double, p) for p, _ in out[STEADY - 1 :])
    standing = [p for p, _ in out[STEADY - 1 : STAND_S]]
    # the held course is a tie-break, not a certainty: counted once, not at every fix
    assert all(p.status == "ambiguous" and p.probability < CONFIDENCE for p in standing)
    moving = [p for p, _ in out[STAND_S + 3 :]]
    assert all(p.status == "confident" for p in moving)


@pytest.mark.parametrize("bias_m", [0.0, 3.0])
def test_a_previous_trips_course_is_overturned_and_never_confident(double, bias_m):
    """A double-ended tram that reversed holds the course of the way it came."""
    pos = Positioner(double)
    out = [(pos.update(r), y) for r, y in _start_at_a_stop(bias_m, 180.0)]
    standing = [p for p, _ in out[:STAND_S]]
    assert not any(p.status == "confident" for p in standing if not _on_northbound(double, p))
    # the first fixes moving at 1.5 m/s and more decide it
    assert all(_on_northbound(double, p) for p, _ in out[STAND_S + 3 :])


@pytest.fixture(scope="module")
def oneway_double(tmp_path_factory):
    path = tmp_path_factory.mktemp("oneway") / "double.osm"
    return trackmap.build(_double_track(True).write_xml(path))


@settings(max_examples=25, deadline=None)
@given(course=st.floats(0.0, 359.9), seed=st.integers(0, 1000))
def test_a_standing_start_course_alone_never_makes_a_position_confident(
    oneway_double, course, seed
):
    """Fixes midway between the tracks: whatever the course, the standing position
    stays short of ``confidence`` however long the tram stands."""
    pos = Positioner(oneway_double)
    for r, _ in _start_at_a_stop(SPACING_M / 2.0, course, seed=seed, stand_s=60)[:60]:
        p = pos.update(r)
        assert p.probability < CONFIDENCE and p.status != "confident", (course, r.t)


@pytest.mark.parametrize(
    ("name", "value"),
    [("start_course_sigma_deg", 0.0), ("start_course_outlier_weight", 1.5),
     ("start_course_max_speed_mps", -1.0)],
)  # fmt: skip
def test_start_course_settings_are_checked(name, value):
    with pytest.raises(InvalidArgumentError, match=name):
        PositioningConfig(**{name: value})


def _departure_in_whole_metres(bias_m: float) -> list[VehicleReport]:
    """A northbound tram's first reports: standing at y = 500 m with a previous trip's
    course (southbound), then moving off at 2.1, 4.4 and 5.9 m/s with a course good to a
    degree; its fixes ``bias_m`` west (toward the southbound track), its odometer read out
    in whole metres (the 0.9 m run in the first second reads 0)."""
    out = []
    for k, (speed, run_m, course) in enumerate(
        [(0.3, 0.0, 180.0), (2.1, 0.9, 1.0), (4.4, 4.0, 359.0), (5.9, 9.2, 0.5)]
    ):
        lon, lat = FRAME.to_lonlat(-bias_m, 500.0 + run_m)
        odometer_m = float(64564 + int(run_m))
        out.append(VehicleReport("T", float(k), float(lat), float(lon), speed, course,
                                 odometer_m=odometer_m))  # fmt: skip
    return out


@pytest.mark.parametrize("bias_m", [2.5, 3.0])
def test_a_course_moving_off_weighs_whole_when_the_odometer_shows_no_run(double, bias_m):
    """Harsher street GPS, HFP's whole-metre odometer: the first moving report's odometer
    step read 0, the tram counted as standing and its course (313 degrees against a
    held 133) weighed a fifth. The previous trip's track kept 0.80, the tram was shown
    there and jumped across a second later. A course measured while moving is no
    standing fix's drift: it weighs whole."""
    pos = Positioner(double)
    out = [pos.update(r) for r in _departure_in_whole_metres(bias_m)]
    north_edges = {c.edge_id for c in double.candidates(*FRAME.to_lonlat(0.0, 500.0), radius_m=0.5)}
    northbound = [
        sum(h.probability for h in p.hypotheses if h.edge_id in north_edges and not h.wrong_way)
        for p in out
    ]
    assert northbound[0] < 0.5  # the held course and the fix: the southbound track
    assert northbound[1] > 0.9  # the first course moving off overturns it
    assert all(_on_northbound(double, p) for p in out if p.edge_id is not None)
