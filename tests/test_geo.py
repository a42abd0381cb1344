"""Spherical navigation against hand-worked values and invariants."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optroute import geodesy as geo

lats = st.floats(-80.0, 80.0)
lons = st.floats(-180.0, 179.999)


def test_one_minute_of_latitude_is_one_nautical_mile_on_the_mean_sphere():
    # 1' of arc on R = 6 371 008.8 m is 1853.25 m: 1.00068 nm.
    assert geo.distance_nm(0.0, 0.0, 1 / 60, 0.0) == pytest.approx(6_371_008.8 * math.radians(1 / 60) / 1852, rel=1e-12)


def test_quarter_meridian_and_equator():
    quarter = math.pi / 2 * geo.EARTH_RADIUS_NM
    assert geo.distance_nm(0.0, 0.0, 90.0, 0.0) == pytest.approx(quarter)
    assert geo.distance_nm(0.0, 170.0, 0.0, -100.0) == pytest.approx(quarter)  # across the antimeridian


def test_san_diego_tokyo_great_circle_course_by_hand():
    # Spherical-trig by hand: cos D = sin φ1 sin φ2 + cos φ1 cos φ2 cos Δλ.
    p1, p2, dl = map(math.radians, (32.7, 35.6, 139.8 - (-117.2)))
    d = math.acos(math.sin(p1) * math.sin(p2) + math.cos(p1) * math.cos(p2) * math.cos(dl))
    assert geo.distance_nm(32.7, -117.2, 35.6, 139.8) == pytest.approx(d * geo.EARTH_RADIUS_NM, rel=1e-9)
    # The great circle leaves San Diego heading north-west (about 306°).
    assert 300 < geo.initial_course_deg(32.7, -117.2, 35.6, 139.8) < 310


@settings(max_examples=200, deadline=None)
@given(lats, lons, st.floats(0, 360, exclude_max=True), st.floats(1.0, 5000.0))
def test_destination_then_distance_and_course_round_trip(lat, lon, course, dist):
    lat2, lon2 = geo.destination(lat, lon, course, dist)
    assert geo.distance_nm(lat, lon, lat2, lon2) == pytest.approx(dist, rel=1e-7, abs=1e-6)
    if abs(lat) < 89 and dist > 1.0:
        c = geo.initial_course_deg(lat, lon, lat2, lon2)
        assert math.cos(math.radians(float(c) - course)) == pytest.approx(1.0, abs=1e-6)
    assert -180.0 <= float(lon2) < 180.0


@settings(max_examples=100, deadline=None)
@given(lats, lons, lats, lons)
def test_intermediate_points_lie_on_the_great_circle(la1, lo1, la2, lo2):
    d = float(geo.distance_nm(la1, lo1, la2, lo2))
    if d < 1.0 or d > 10_000:
        return
    f = np.array([0.0, 0.25, 0.5, 1.0])
    lat, lon = geo.intermediate_points(la1, lo1, la2, lo2, f)
    assert geo.distance_nm(la1, lo1, lat, lon) == pytest.approx(f * d, rel=1e-7, abs=1e-6)


@settings(max_examples=200, deadline=None)
@given(lats, lons, st.floats(-2000.0, 2000.0), st.floats(-2000.0, 2000.0))
def test_gnomonic_round_trip_and_straight_great_circles(lat0, lon0, x, y):
    lat, lon = geo.gnomonic_inverse(x, y, lat0, lon0)
    x2, y2 = geo.gnomonic_forward(lat, lon, lat0, lon0)
    assert float(x2) == pytest.approx(x, abs=1e-6) and float(y2) == pytest.approx(y, abs=1e-6)


def test_gnomonic_maps_a_great_circle_to_a_straight_line_across_the_antimeridian():
    lat, lon = geo.great_circle_points(32.7, -117.2, 35.6, 139.8, 50)
    c_lat, c_lon = geo.midpoint(32.7, -117.2, 35.6, 139.8)
    x, y = geo.gnomonic_forward(lat, lon, c_lat, c_lon)
    # collinear: the cross product of consecutive chords vanishes (relative to their lengths).
    cross = (x[1:-1] - x[0]) * (y[-1] - y[0]) - (y[1:-1] - y[0]) * (x[-1] - x[0])
    scale = np.hypot(x[-1] - x[0], y[-1] - y[0]) ** 2
    assert np.max(np.abs(cross)) / scale < 1e-9


def test_unwrap_lon_keeps_pacific_sequences_continuous():
    assert geo.unwrap_lon_deg([170.0, 179.0, -179.0, -170.0]) == pytest.approx([170, 179, 181, 190])
