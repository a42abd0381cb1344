"""Boeing speed reduction at sampled points against closed forms and brute force."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optroute.physics.passage import SeaState, best_speed, cheapest_speed, evaluate_speeds
from optroute.physics.performance import CalmWaterModel, KwonModel
from optroute.physics.safety import BandRules, forbidden_speed_intervals
from optroute.physics.ship import Ship

SHIP = Ship.preset("container_8000teu")
RULES = BandRules()


def test_calm_sea_keeps_the_desired_speed_and_calm_power():
    sea = SeaState.uniform(3)
    choice = best_speed(SHIP, KwonModel(SHIP), RULES, [0.0, 90.0, 250.0], sea, 25.0)
    assert choice.feasible.all()
    assert choice.stw_kn == pytest.approx(25.0)
    assert choice.power_kw == pytest.approx(SHIP.calm_power_kw(25.0))
    assert choice.fuel_tph == pytest.approx(SHIP.fuel_rate_tph(SHIP.calm_power_kw(25.0)))


def test_desired_speed_above_mcr_speed_is_reduced_to_the_ladder_step_below_it():
    sea = SeaState.uniform(1)
    choice = best_speed(SHIP, CalmWaterModel(SHIP), RULES, 0.0, sea, 30.0, step_kn=0.25)
    vmax = SHIP.max_calm_speed_kn  # 27.65 kn for the 8000 TEU preset
    expected = 30.0 - 0.25 * np.ceil((30.0 - vmax) / 0.25)
    assert choice.stw_kn[0] == pytest.approx(expected)


def test_surf_riding_band_forces_the_speed_below_its_closed_form_edge():
    # Following sea (waves from the north, ship heading south), T 9 s: c = 27.3 kn, surf-riding
    # band V ∈ [0.8 c, 1.2 c] for V cos χ = V; Hs 13 m ≥ 0.04·320 m so the bands apply.
    sea = SeaState.uniform(1, hs_m=13.0, period_s=9.0, wave_from_deg=0.0)
    intervals = forbidden_speed_intervals(SHIP, hs_m=13.0, period_s=9.0, wave_from_deg=0.0, heading_deg=180.0)
    choice = best_speed(SHIP, CalmWaterModel(SHIP), RULES, 180.0, sea, 25.0, step_kn=0.01)
    assert choice.feasible[0]
    v = choice.stw_kn[0]
    assert not any(iv.lo_kn <= v <= iv.hi_kn for iv in intervals)
    # no allowed speed lies between v and 25 kn (brute force on a fine grid)
    grid = np.arange(v + 0.01, 25.0, 0.01)
    _, _, _, _, allowed = evaluate_speeds(
        SHIP,
        CalmWaterModel(SHIP),
        RULES,
        np.full(grid.size, 180.0),
        SeaState.uniform(grid.size, hs_m=13.0, period_s=9.0),
        grid,
    )
    assert not allowed.any()


def test_nan_sea_means_no_passage():
    sea = SeaState.uniform(2, hs_m=2.0)
    sea = SeaState(
        np.array([2.0, np.nan]),
        sea.period_s,
        sea.wave_from_deg,
        sea.wind_u_ms,
        sea.wind_v_ms,
        sea.current_u_ms,
        sea.current_v_ms,
    )
    choice = best_speed(SHIP, KwonModel(SHIP), RULES, 0.0, sea, 20.0)
    assert choice.feasible.tolist() == [True, False]
    assert np.isnan(choice.stw_kn[1])


def test_outside_the_data_the_current_is_nan_too_and_the_point_is_simply_not_navigable():
    # what a sampler gives outside the weather's area or time span: every field NaN, the current included
    # (issue 14 failure 7: this raised SeaStateError "current_u_ms must be finite" as if it were bad input)
    nan = np.array([np.nan])
    outside = SeaState(nan, nan, nan, nan, nan, nan, nan)
    heading, sog, power, fuel, allowed = evaluate_speeds(SHIP, KwonModel(SHIP), RULES, [90.0], outside, [20.0])
    assert not allowed[0] and np.isnan(power[0]) and np.isnan(sog[0]) and fuel[0] == np.inf
    assert not best_speed(SHIP, KwonModel(SHIP), RULES, 90.0, outside, 20.0).feasible[0]
    # inside, the current still counts: 1 m/s (1.944 kn) from astern at 20 kn gives 21.944 kn over ground
    inside = SeaState.uniform(1, current_u_ms=1.0)
    sog_in = evaluate_speeds(SHIP, KwonModel(SHIP), RULES, [90.0], inside, [20.0])[1]
    assert sog_in[0] == pytest.approx(20.0 + 3600.0 / 1852.0, rel=1e-12)


def test_min_load_makes_very_slow_speeds_infeasible_in_calm_water():
    # 10 % MCR = 6 864 kW is reached in calm water at 25·(6864/50734)^(1/3) = 12.83 kn.
    sea = SeaState.uniform(1)
    v_min_load = 25.0 * (0.1 * 68_640 / (0.85 * 68_640 / 1.15)) ** (1 / 3)
    _, _, _, _, allowed = evaluate_speeds(
        SHIP, CalmWaterModel(SHIP), RULES, [0.0], sea, np.array([[v_min_load - 0.01, v_min_load + 0.01]])
    )
    assert allowed.tolist() == [[False, True]]


@settings(max_examples=40, deadline=None)
@given(
    st.floats(0.0, 16.0),
    st.floats(4.0, 16.0),
    st.floats(0.0, 360.0),
    st.floats(0.0, 360.0),
    st.floats(-1.5, 1.5),
    st.floats(-1.5, 1.5),
    st.floats(8.0, 27.0),
)
def test_best_speed_is_the_fastest_allowed_ladder_speed(hs, tp, wave_from, course, cu, cv, desired):
    sea = SeaState.uniform(1, hs_m=hs, period_s=tp, wave_from_deg=wave_from, current_u_ms=cu, current_v_ms=cv)
    model = KwonModel(SHIP)
    choice = best_speed(SHIP, model, RULES, course, sea, desired, step_kn=1.0)
    ladder = desired - 1.0 * np.arange(int(desired - 1.0) + 1)
    ok = []
    for v in ladder:  # one speed at a time: independent of the vectorised ladder
        *_, allowed = evaluate_speeds(SHIP, model, RULES, [course], sea, [v])
        ok.append(bool(allowed[0]))
    if any(ok):
        assert choice.stw_kn[0] == pytest.approx(ladder[ok.index(True)])
        forbidden = forbidden_speed_intervals(
            SHIP, hs_m=hs, period_s=tp, wave_from_deg=wave_from, heading_deg=choice.heading_deg[0]
        )
        assert not any(iv.lo_kn <= choice.stw_kn[0] <= iv.hi_kn for iv in forbidden)
        assert model.min_power_kw <= choice.power_kw[0] <= model.mcr_kw
    else:
        assert not choice.feasible[0]


def test_cheapest_speed_is_the_argmin_of_fuel_plus_lambda_time_per_mile():
    # Calm water, no current: cost per nm = (F(V) + λ) / V over the allowed set, checked by brute force.
    speeds = np.arange(5.0, 28.0, 0.5)
    sea = SeaState.uniform(1)
    model = CalmWaterModel(SHIP)
    for lam in (0.0, 2.0, 20.0, 200.0):
        choice = cheapest_speed(SHIP, model, RULES, 45.0, sea, speeds, lam)
        p = SHIP.calm_power_kw(speeds)
        ok = (p <= SHIP.mcr_kw) & (p >= SHIP.min_power_kw)
        rate = np.where(ok, (SHIP.fuel_rate_tph(p) + lam) / speeds, np.inf)
        assert choice.stw_kn[0] == pytest.approx(speeds[np.argmin(rate)])
    # λ = 200 t/h values time far above fuel: the fastest allowed speed of the set.
    assert choice.stw_kn[0] == pytest.approx(speeds[speeds <= SHIP.max_calm_speed_kn].max())
