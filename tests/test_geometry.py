import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from antikol.analysis import geometry as g


def test_formulas_4_to_8_by_hand():
    lat1, lon1, lat2, lon2 = 54.390173, 18.635925, 54.381877, 18.635839
    latdist = (lat1 - lat2) * 111.138
    parlen = math.cos(lat1 * math.pi / 180) * 40041.48
    londist = (lon1 - lon2) * parlen / 360
    assert g.latdist_km(lat1, lat2) == pytest.approx(latdist)
    assert g.parlen_km(lat1) == pytest.approx(parlen)
    assert g.odlmst_km_per_deg(lat1) == pytest.approx(parlen / 360)
    assert g.londist_km(lat1, lon1, lon2) == pytest.approx(londist)
    assert g.dist_km(latdist, londist) == pytest.approx(math.hypot(latdist, londist))


def test_paper_table_1_points_planar_matches_spherical():
    # Table 1 of the paper compares planar and spherical results for two Gdansk points and
    # finds them within ~0.3 m and ~0.02 deg. (Its printed distance and bearing do not
    # follow from its printed coordinates, so only the agreement is checked.)
    p1, p2 = (54.390173, 18.635925), (54.381877, 18.635839)
    off = g.paper_offset(*p1, *p2)
    assert off.distance_m == pytest.approx(g.great_circle_distance_m(*p1, *p2), abs=0.3)
    course = g.great_circle_course_deg(*p1, *p2)
    assert g.angle_difference_deg(off.bearing_deg, course) == pytest.approx(0.0, abs=0.022)


@pytest.mark.parametrize(
    ("north", "east", "expected"),
    [
        (100.0, 0.0, 0.0),  # due north (londist == 0, latdist < 0)
        (-100.0, 0.0, 180.0),  # due south (londist == 0, latdist > 0)
        (0.0, 100.0, 90.0),
        (0.0, -100.0, 270.0),
        (100.0, 100.0, 45.0),  # quadrant I
        (-100.0, 100.0, 135.0),  # quadrant II (south-east)
        (-100.0, -100.0, 225.0),  # quadrant III
        (100.0, -100.0, 315.0),  # quadrant IV
        (0.0, 0.0, 0.0),  # coincident: the paper's third case
    ],
)
def test_sight_all_quadrants_and_poles(north, east, expected):
    latdist = -north
    londist = -east
    assert math.degrees(g.sight_rad(latdist, londist)) == pytest.approx(expected, abs=1e-9)


@given(
    lat=st.floats(0, 70),
    dist=st.floats(1.0, 1000.0),
    az=st.floats(0, 360, exclude_max=True),
)
def test_planar_within_0_1_percent_of_geodesic_on_paper_sphere(lat, dist, az):
    lon2, lat2, _ = g.paper_sphere().fwd(19.0, lat, az, dist)
    off = g.paper_offset(lat, 19.0, lat2, lon2)
    assert off.distance_m == pytest.approx(dist, rel=1e-3)
    # formulas (1)-(2) are the same sphere's great circle
    assert g.great_circle_distance_m(lat, 19.0, lat2, lon2) == pytest.approx(
        dist, rel=1e-6, abs=0.05
    )


@given(lat=st.floats(0, 70), dist=st.floats(1.0, 1000.0), az=st.floats(0, 360, exclude_max=True))
def test_planar_against_wgs84_is_bounded_by_the_ellipsoid(lat, dist, az):
    # The paper's constants describe a sphere; on WGS84 the degree of meridian runs from
    # 110.574 km (equator) to 111.694 km (pole), so the planar distance can be up to ~0.6 %
    # off there, never more.
    lon2, lat2, _ = g.wgs84().fwd(19.0, lat, az, dist)
    off = g.paper_offset(lat, 19.0, lat2, lon2)
    assert off.distance_m == pytest.approx(dist, rel=6e-3)


@given(
    lat=st.floats(-70, 70),
    dist=st.floats(10.0, 1000.0),
    az=st.floats(0, 360, exclude_max=True),
)
def test_bearing_matches_geodesic_azimuth(lat, dist, az):
    lon2, lat2, _ = g.paper_sphere().fwd(19.0, lat, az, dist)
    off = g.paper_offset(lat, 19.0, lat2, lon2)
    assert g.angle_difference_deg(off.bearing_deg, az) == pytest.approx(0.0, abs=0.2)
    gc = g.great_circle_course_deg(lat, 19.0, lat2, lon2)
    assert g.angle_difference_deg(gc, az) == pytest.approx(0.0, abs=1e-6)


def test_vectorised_offsets_match_scalar():
    lat2 = np.array([50.0, 50.001, 49.999])
    lon2 = np.array([19.0, 19.001, 18.998])
    d, b = g.paper_offsets(50.0005, 19.0002, lat2, lon2)
    for i in range(3):
        off = g.paper_offset(50.0005, 19.0002, lat2[i], lon2[i])
        assert d[i] == pytest.approx(off.distance_m)
        assert b[i] == pytest.approx(off.bearing_deg)


def test_closing_speed_head_on_following_and_crossing():
    # other 100 m north, coming south at 10 while we go north at 5: closing 15 m/s
    assert g.closing_speed_mps(0, 100, 5, 0, 10, 180) == pytest.approx(15)
    # following a slower leader: closing at the speed difference
    assert g.closing_speed_mps(0, 100, 10, 0, 6, 0) == pytest.approx(4)
    # leader faster: opening (negative)
    assert g.closing_speed_mps(0, 100, 6, 0, 10, 0) == pytest.approx(-4)
    # passing side by side, 4 m apart: no closing component along the line of sight
    assert g.closing_speed_mps(4, 0, 10, 0, 10, 180) == pytest.approx(0, abs=1e-9)
    assert g.closing_speed_mps(0, 0, 10, 0, 10, 180) == 0.0


@given(
    e=st.floats(-500, 500),
    n=st.floats(-500, 500),
    v1=st.floats(0, 30),
    c1=st.floats(0, 360),
    v2=st.floats(0, 30),
    c2=st.floats(0, 360),
)
def test_closing_speed_is_minus_the_derivative_of_distance(e, n, v1, c1, v2, c2):
    if math.hypot(e, n) < 1.0:
        return
    dt = 1e-4
    ve1, vn1 = g.velocity_en(v1, c1)
    ve2, vn2 = g.velocity_en(v2, c2)
    d_minus = math.hypot(e - (ve2 - ve1) * dt, n - (vn2 - vn1) * dt)
    d_plus = math.hypot(e + (ve2 - ve1) * dt, n + (vn2 - vn1) * dt)
    numeric = -(d_plus - d_minus) / (2 * dt)
    assert g.closing_speed_mps(e, n, v1, c1, v2, c2) == pytest.approx(numeric, abs=1e-2)


def test_great_circle_uses_arccos_not_arcsin():
    # 1 km apart on the meridian: arcsin of the printed formula would give ~10,000 km
    d = g.great_circle_distance_m(50.0, 19.0, 50.0 + 1000 / 111138, 19.0)
    assert d == pytest.approx(1000.0, abs=0.05)


def test_course_from_poles():
    assert g.great_circle_course_deg(90.0, 0.0, 80.0, 45.0) == pytest.approx(180.0)
    assert g.great_circle_course_deg(-90.0, 0.0, -80.0, 45.0) == pytest.approx(0.0)
