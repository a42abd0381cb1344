"""Fixed-route sailing (Boeing speed reduction) against hand values and seed 000's worked example."""

import warnings

import numpy as np
import pytest

import optroute as orx
from optroute import geodesy as geo
from optroute.errors import NoSafePassage
from optroute.search.routing import sail_route


def test_calm_sea_takes_distance_over_speed_and_calm_fuel():
    ship = orx.Ship.preset("container_54k_dwt")
    wx = orx.scenarios.uniform(hs_m=0.0, tp_s=6.0, bbox=(-10, 10, -10, 30), duration_h=240, resolution_deg=1.0)
    wp = np.array([[0.0, 0.0], [0.0, 10.0], [5.0, 20.0]])
    r = sail_route(wp, wx, ship, departure=wx.time.values[0], desired_speed_kn=20.0, model=orx.CalmWaterModel(ship))
    d = geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
    assert r.distance_nm == pytest.approx(d)
    assert r.duration_h == pytest.approx(d / 20.0)
    assert r.total_fuel_t == pytest.approx(float(ship.fuel_rate_tph(ship.calm_power_kw(20.0))) * d.sum() / 20.0)
    elapsed = r.times[-1] - r.times[0] - np.timedelta64(int(round(d.sum() / 20.0 * 3.6e12)), "ns")
    assert abs(elapsed) <= np.timedelta64(1, "us")  # to the rounding of the times


@pytest.fixture(scope="module")
def boeing_2008_north_pacific(north_pacific_storms):
    """Seed 000 (EP 2145155 Figs. 23-26) under the patent's own assumptions: bands and top speed only."""
    ship = orx.Ship.preset("container_8000teu").replace(min_load_fraction=0.0)
    return ship, orx.CalmWaterModel(ship), north_pacific_storms  # built once per process (tests/conftest.py)


def test_boeing_2008_great_circle_slows_below_10_kn_and_takes_over_12_days(boeing_2008_north_pacific):
    ship, model, wx = boeing_2008_north_pacific
    lat, lon = geo.great_circle_points(32.6, -117.4, 35.0, 140.0, 60)
    r = sail_route(np.column_stack([lat, lon]), wx, ship, departure=wx.time.values[0], model=model)
    # EP 2145155: "two storms force it below 10 kn so the great circle takes more than 12 days"
    assert r.stats["min_stw_kn"] < 10.0
    assert r.total_duration_h > 12 * 24
    # every piece the ship sailed was band-free and within MCR (checked inside best_speed); the slow legs
    # are the ones the storms cross, and elsewhere it keeps 25 kn
    assert np.nanmax(r.stw_kn) == pytest.approx(25.0)


def test_boeing_2008_searched_route_keeps_25_kn_and_arrives_in_about_8_days(boeing_2008_north_pacific):
    ship, model, wx = boeing_2008_north_pacific
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the ports are snapped to open water, with a warning
        r = orx.search_route(
            (32.71, -117.17), (35.65, 139.77), wx, ship, departure=wx.time.values[0], cell_nm=80, model=model
        )
    # EP 2145155: "the optimised route keeps 25 kn and arrives in 8 days 8 hours"
    assert r.total_duration_h < 8.5 * 24
    assert np.nanmin(r.stw_kn) == pytest.approx(25.0)
    gc = geo.distance_nm(32.71, -117.17, 35.65, 139.77)
    assert r.total_distance_nm < 1.05 * gc


def test_unsailable_fixed_route_names_where(boeing_2008_north_pacific):
    _, _, wx = boeing_2008_north_pacific  # the same storms (about 10 CPU-s to build), taken from the fixture
    ship = orx.Ship.preset("container_8000teu")  # Kwon at Beaufort 12 head seas: no headway at any speed
    lat, lon = geo.great_circle_points(32.6, -117.4, 35.0, 140.0, 60)
    with pytest.raises(NoSafePassage, match=r"no allowed speed down to 3.0 kn at \(.*\) on leg \d+ at"):
        sail_route(np.column_stack([lat, lon]), wx, ship, departure=wx.time.values[0])
