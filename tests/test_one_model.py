"""The corridor NLP on one model: the ship's own performance model tabulated on the corridor's weather grid.

References, independent of the NLP:

* the model's brake power worked by hand from its own arguments (the relative wave angle of IMO
  MSC.1/Circ.1228 from the heading and the wave direction) at a grid node;
* the cubic B-spline quasi-interpolant's textbook properties (partition of unity, exact for linear
  data; de Boor 1978);
* the referee (:class:`optroute.Plan`, the plan evaluator) scoring the NLP's own track and schedule;
* the finest 3-D DP of :func:`optroute.search_route` on the same corridor and ETA (the storm crossing
  of ``benchmarks/bench_nlp.py`` section 4, where the DP used to beat the NLP by 8 %).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import optroute as orx
from formulations.common import spline_weights
from optroute.optimise.api import optimise_corridor
from optroute.optimise.power_table import TABULATION_BOUND, baseline_power_model, tabulate_ratio
from optroute.physics.passage import SeaState
from optroute.physics.performance import KwonModel

SHIP = orx.Ship.preset("container_54k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")


@settings(max_examples=100, deadline=None)
@given(
    n=st.integers(2, 12),
    x=st.floats(-0.5, 1.5),
    a=st.floats(-10, 10),
    b=st.floats(-10, 10),
)
def test_spline_weights_are_a_partition_of_unity_exact_for_linear_data(n: int, x: float, a: float, b: float) -> None:
    x0, h = 3.0, 2.5
    xx = x0 + x * (n - 1) * h
    w = np.array(spline_weights(xx, x0, h, n, np), dtype=float)
    assert w.sum() == pytest.approx(1.0, abs=1e-12)
    nodes = x0 + h * np.arange(n)
    held = min(max(xx, nodes[0]), nodes[-1])  # held at the nearest node outside the range
    assert float(w @ (a + b * nodes)) == pytest.approx(a + b * held, abs=1e-9 * (1 + abs(a) + abs(b) * held))


def test_table_is_the_models_power_at_the_node_worked_by_hand() -> None:
    model = KwonModel(SHIP)
    base, sfoc_err = baseline_power_model(model, v_min_kn=3.0, v_max_kn=24.0, min_load=0.1)
    assert sfoc_err < 1e-9  # the ship's SFOC is the IMO quadratic
    sea = SeaState.uniform(3, hs_m=5.0, period_s=10.0, wave_from_deg=300.0, wind_u_ms=-12.0, wind_v_ms=3.0)
    along = np.array([270.0, 90.0, 10.0])
    speeds, headings = np.array([8.0, 14.0, 20.0]), np.array([-15.0, 0.0, 15.0])
    ratio, _ = tabulate_ratio(model, base, sea, along, speeds, headings)
    wind_speed = np.hypot(-12.0, 3.0)
    wind_from = np.degrees(np.arctan2(12.0, -3.0)) % 360.0  # the wind blows to (-12, 3): it comes from the ESE
    for i, a in enumerate(along):
        for k, psi in enumerate(headings):
            heading = a - psi  # psi to port: the heading turns anticlockwise
            alpha = (300.0 - heading) % 360.0  # relative wave angle, 0 = head sea (IMO)
            p = model.brake_power_kw(
                speeds,
                hs_m=5.0,
                wave_angle_deg=alpha,
                wind_speed_ms=wind_speed,
                wind_angle_deg=(wind_from - heading) % 360,
            )
            np.testing.assert_allclose(ratio[i, :, k] * base.calm_power_kw(speeds), p, rtol=1e-12)


@pytest.fixture(scope="module")
def crossing() -> dict:
    """The storm crossing of benchmarks/bench_nlp.py section 4 (9 m storm moving SSE across a 730 nm track)."""
    wx = orx.scenarios.moving_storm(
        33.0,
        -147.0,
        160.0,
        10.0,
        peak_hs_m=9.0,
        radius_nm=200.0,
        start=T0,
        duration_h=72.0,
        step_h=3.0,
        resolution_deg=0.5,
        bbox=(20, 40, -160, -130),
    )
    start, end = (30.0, -152.0), (30.0, -138.0)
    eta = T0 + np.timedelta64(56, "h")
    dp_res = {"dx_nm": 60.0, "dy_nm": 10.0, "half_width_nm": 30.0, "dt_h": 1.0}
    dp = orx.search_route(
        start,
        end,
        wx,
        SHIP,
        departure=T0,
        method="dp",
        objective="fuel",
        eta=eta,
        speeds_kn=np.arange(3.0, SHIP.max_calm_speed_kn, 1.0),
        dp_options=dp_res,
    )
    corridor = orx.Corridor.from_waypoints([start, end], width_nm=60.0)
    kw = {"departure": T0, "eta": eta, "max_leg_nm": 30.0, "use_land_mask": False}
    alone = optimise_corridor(corridor, wx, SHIP, **kw)
    dp_plan = orx.Plan.from_schedule(
        dp.waypoints, dp.stw_kn, departure=T0, ship=SHIP, weather=wx, times=dp.times, step_nm=5.0
    )
    return {"wx": wx, "dp": dp, "dp_plan": dp_plan, "alone": alone, "eta_h": 56.0}


def test_storm_crossing_nlp_is_within_4_percent_of_the_finest_dp_by_the_referee(crossing: dict) -> None:
    # the regression of benchmarks/bench_nlp.py section 4: on the fitted model the NLP lost by 8 % (81.95 t against
    # the DP's 75.3 t); on the ship's own model, from the centreline start, it is within 4 % (measured 77.3 t against
    # 75.25 t)
    plan, dp_plan = crossing["alone"], crossing["dp_plan"]
    assert plan.verify() == [] and plan.duration_h <= crossing["eta_h"] + 1e-6
    assert plan.total_fuel_t <= 1.04 * dp_plan.total_fuel_t
    assert plan.total_fuel_t <= plan.solver_stats["start_score"] * (1 + 1e-9)  # never worse than the verified start


@pytest.mark.xfail(
    strict=True,
    reason="not done: the NLP from the centreline ends in a local optimum 2.7 % above the DP (77.3 t against "
    "75.25 t); from the DP's own start (discrete_start=True) its plan trips the referee's minimum-power check where "
    "the table overestimates the power by 4-6 % along Kwon's following/beam sector edge (alpha = 150 deg), so the "
    "call solves again from the verified centreline start and returns the same 77.3 t (benchmarks.bench_nlp --crossing)",
)
def test_storm_crossing_nlp_is_no_worse_than_the_finest_dp_by_the_referee(crossing: dict) -> None:
    assert crossing["alone"].total_fuel_t <= crossing["dp_plan"].total_fuel_t


def test_nlp_objective_equals_the_referee_within_the_tabulation_bound(crossing: dict) -> None:
    tab = crossing["alone"].solver_stats["tabulation"]
    assert abs(tab["rel_error"]) <= TABULATION_BOUND
    # and the counts are honest: every solve and every iteration
    stats = crossing["alone"].solver_stats
    assert stats["nlp_solves"] >= 1 and stats["iterations"] >= stats["nlp_solves"]
