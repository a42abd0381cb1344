"""The voyage simulator (optroute.voyage) against the plan evaluator, a hand-worked calm passage and its own rules.

References, all independent of the simulator's stepping:

* calm water: the ship sails the plan's speed, so it arrives after D / V and burns
  (D / V) · fuel_rate(calm power(V)) from the Ship's own performance model;
* truth = forecast: the plan's arrival and fuel are :meth:`optroute.Plan.from_schedule`'s dense
  evaluation (:func:`optroute.plan.evaluate.evaluate_track`), which shares no stepping code with
  the simulator;
* a storm the forecast places 300 nm north of its true track (built with
  :func:`optroute.scenarios.storm_forecast`): the first plan sailed blind meets a danger band of
  the truth (the band check is :func:`optroute.physics.safety.is_speed_forbidden`).
"""

from __future__ import annotations

import numpy as np
import pytest

import optroute as orx
from optroute import geodesy as geo
from optroute.errors import ConfigError
from optroute.physics.performance import default_model
from optroute.voyage import ForecastSequence, ForecastTimeError, ReplanPolicy, VoyageOutcome
from optroute.weather import scenarios as sc

SHIP = orx.Ship.preset("container_54k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")
A, B = (30.0, -150.0), (30.0, -140.0)
STEP_H = 0.25


def _calm(hours: float = 60.0):
    return sc.calm(start=T0, duration_h=hours, step_h=3.0, resolution_deg=1.0, bbox=(20, 40, -160, -130))


def _hours(td) -> float:
    return float(td / np.timedelta64(1, "ns")) / 3.6e12


# --------------------------------------------------------------------------- policies and forecasts


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"every_h": 0.0}, "every_h=0.0"),
        ({"every_h": -3}, "every_h=-3"),
        ({"hs_threshold_m": float("nan")}, "hs_threshold_m=nan"),
        ({"direction_threshold_deg": 200.0}, "direction_threshold_deg=200.0"),
        ({"period_threshold_s": "x"}, "period_threshold_s='x'"),
        ({"min_interval_h": -1.0}, "min_interval_h=-1.0"),
        ({"on_forecast": "yes"}, "on_forecast='yes'"),
    ],
)
def test_bad_policies_are_errors_naming_the_value(kwargs, named):
    with pytest.raises(ConfigError, match=named.replace("(", r"\(")):
        ReplanPolicy(**kwargs)


def test_policy_never_has_no_trigger_and_the_default_replans_on_forecasts():
    assert not ReplanPolicy.never().replans
    assert ReplanPolicy().replans and ReplanPolicy().on_forecast


def test_outcome_is_validated():
    with pytest.raises(ConfigError, match="fuel_t=-1"):
        VoyageOutcome(T0, T0, -1.0, 0.0, 0.0, 0.0, None, 0)
    with pytest.raises(ConfigError, match="before the departure"):
        VoyageOutcome(T0, T0 - np.timedelta64(1, "h"), 1.0, 0.0, 0.0, 0.0, None, 0)
    o = VoyageOutcome(T0, T0 + np.timedelta64(10, "h"), 1.0, 1.0, 0.0, 0.0, T0 + np.timedelta64(9, "h"), 0)
    assert o.eta_miss_h == pytest.approx(1.0) and o.eta_met is False and o.duration_h == pytest.approx(10.0)


def test_a_forecast_used_before_its_issue_time_is_an_error_naming_both_times():
    issued = T0 + np.timedelta64(6, "h")
    fs = ForecastSequence([(issued, _calm())])
    with pytest.raises(ForecastTimeError, match="2024-01-10T06:00:00Z.*2024-01-10T00:00:00Z"):
        fs.get(0, T0)
    # the simulator asks for the first plan's forecast at the departure: the same error, before any planning
    with pytest.raises(
        ForecastTimeError, match="issued at 2024-01-10T06:00:00Z cannot be used at 2024-01-10T00:00:00Z"
    ):
        orx.simulate_voyage((A, B), _calm(), SHIP, forecasts=[(issued, _calm())], departure=T0)


def test_forecast_sequence_picks_the_newest_issued():
    a, b = _calm(), _calm()
    fs = ForecastSequence([(T0 + np.timedelta64(6, "h"), b), (T0, a)])
    assert fs.latest(T0 + np.timedelta64(5, "h"))[1] is a
    assert fs.latest(T0 + np.timedelta64(6, "h"))[1] is b
    with pytest.raises(ConfigError, match="share an issue time"):
        ForecastSequence([(T0, a), (T0, b)])


# --------------------------------------------------------------------------- sailing a plan


def test_calm_passage_matches_the_hand_worked_time_and_fuel():
    wx = _calm()
    v = 15.0
    plan = orx.Plan.from_schedule([A, B], [v], departure=T0, ship=SHIP, weather=wx, use_land_mask=False)
    res = orx.simulate_voyage(plan, wx, SHIP, replan=ReplanPolicy.never(), step_h=STEP_H)
    d = float(geo.distance_nm(*A, *B))
    model = default_model(SHIP)
    fuel = d / v * float(model.fuel_rate_tph(model.brake_power_kw(v)))
    assert res.outcome.duration_h == pytest.approx(d / v, abs=1e-6)
    assert res.outcome.fuel_t == pytest.approx(fuel, rel=1e-9)
    assert res.outcome.distance_nm == pytest.approx(d, rel=1e-9)
    assert res.outcome.time_in_band_h == 0.0 and res.outcome.n_replans == 0
    assert res.log.sizes["step"] == int(np.ceil(d / v / STEP_H))


def test_truth_equal_to_the_forecast_reproduces_the_plan():
    """A plan through a moving storm, sailed in the same weather: its arrival to the step, its fuel to 1 %."""
    wx = sc.moving_storm(
        32.0,
        -146.0,
        180.0,
        8.0,
        peak_hs_m=7.0,
        radius_nm=200.0,
        start=T0,
        duration_h=60.0,
        step_h=3.0,
        resolution_deg=0.5,
        bbox=(20, 42, -156, -134),
    )
    mid = geo.intermediate_points(*A, *B, np.linspace(0.0, 1.0, 6))
    wp = np.column_stack(mid)
    plan = orx.Plan.from_schedule(
        wp, [15.0, 14.0, 14.5, 16.0, 15.0], departure=T0, ship=SHIP, weather=wx, use_land_mask=False
    )
    assert plan.verify() == []
    res = orx.simulate_voyage(plan, wx, SHIP, forecasts=[(T0, wx)], replan=ReplanPolicy.never(), step_h=STEP_H)
    o = res.outcome
    assert abs(_hours(o.arrival - plan.arrival)) <= STEP_H
    assert o.fuel_t == pytest.approx(plan.total_fuel_t, rel=0.01)
    assert o.time_in_band_h == 0.0 and o.time_slowed_h == 0.0
    assert np.allclose(res.log["stw_kn"], res.log["commanded_stw_kn"])
    assert res.log["fuel_t"].sum() == pytest.approx(o.fuel_t)
