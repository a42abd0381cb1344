"""Voyages that start at the weather's first hour or end at its last, through a current (issue 14, failure 7).

The fit correction of the optimiser differentiates the power in time by sampling the plan a quarter
of an hour earlier and later; at the first and last time steps those samples fall outside the
data, where every field — the current included — is NaN.  That NaN current was once taken for bad
input (``SeaStateError: current_u_ms must be finite``).  The weather here is uniform in space and
time, so the independent reference is time invariance: the same voyage at the first hour, at the
last and in the middle of the forecast costs the same fuel.
"""

from __future__ import annotations

import numpy as np
import pytest

import optroute as orx

T0 = np.datetime64("2024-01-10T00:00", "ns")
SHIP = orx.Ship.preset("container_54k_dwt")
CORRIDOR = orx.Corridor.from_waypoints([[0.0, -30.0], [0.0, -20.0]], width_nm=0.0)  # 600 nm due east
KW = {"max_leg_nm": 150.0, "use_land_mask": False}
# Hs 2 m from the west, and a 0.8 m/s current setting east (to 90°) across the whole 60 h forecast
WX = orx.scenarios.uniform(
    hs_m=2.0,
    tp_s=8.0,
    bbox=(-10, 10, -40, 0),
    start=T0,
    duration_h=60,
    resolution_deg=1.0,
    current_speed_ms=0.8,
    current_to_deg=90.0,
)
T_END = np.datetime64(WX.time.values[-1], "ns")
HOUR = np.timedelta64(1, "h")


def _plan(departure, eta_h=None, objective="fuel"):
    eta = None if eta_h is None else departure + np.timedelta64(int(round(eta_h * 3600)), "s")
    return orx.optimise_corridor(CORRIDOR, WX, SHIP, departure=departure, eta=eta, objective=objective, **KW)


@pytest.fixture(scope="module")
def middle():
    return _plan(T0 + 15 * HOUR, 30.0)


def test_departing_at_the_first_time_step_through_a_current(middle):
    for plan in (_plan(T0, 30.0), _plan(T0, objective="time")):
        assert plan.verify() == []
        assert plan.departure == T0
    assert _plan(T0, 30.0).total_fuel_t == pytest.approx(middle.total_fuel_t, rel=1e-6)


def test_arriving_at_the_last_time_step_through_a_current(middle):
    plan = _plan(T_END - 30 * HOUR, 30.0)  # the ETA is the forecast's last hour
    assert plan.verify() == []
    assert plan.arrival <= T_END
    assert plan.total_fuel_t == pytest.approx(middle.total_fuel_t, rel=1e-6)


def test_departing_before_the_data_is_a_coverage_error_naming_the_span():
    with pytest.raises(orx.WeatherCoverageError, match="before the weather's first time 2024-01-10T00:00"):
        _plan(T0 - HOUR, 30.0)


def test_a_voyage_running_past_the_forecast_is_a_coverage_error_not_a_solver_failure():
    # the fastest passage takes 21.6 h; ten hours before the forecast ends it cannot be covered
    with pytest.raises(orx.WeatherCoverageError, match="2024-01-12T12:00"):
        _plan(T_END - 10 * HOUR, objective="time")
