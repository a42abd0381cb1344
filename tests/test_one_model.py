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
from formulations._ratio_table import power_ratio
from formulations.common import spline_weights
from formulations.splines import SECTOR_RAMP_DEG
from optroute.optimise.api import optimise_corridor
from optroute.optimise.power_table import LEG_BOUND, TABULATION_BOUND, baseline_power_model, tabulate_ratio
from optroute.optimise.starts import repaired_plan
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
    tab = tabulate_ratio(model, base, sea, along, speeds, headings)
    # Kwon reads the heading only through the wave angle, so each sector's field is one heading node
    assert tab.sector_edges_deg == (30.0, 60.0, 150.0) and tab.ratio.shape == (3, 3, 1, 4)
    wind_speed = np.hypot(-12.0, 3.0)
    axes = (0.0, 1.0, 1, 0.0, 1.0, 1, tab.sector_edges_deg)  # one speed at a time: no spline in speed
    for i, a in enumerate(along):
        for psi in headings:
            heading = a - psi  # psi to port: the heading turns anticlockwise
            alpha = (300.0 - heading) % 360.0  # relative wave angle, 0 = head sea (IMO)
            folded = min(alpha, 360.0 - alpha)
            p = model.brake_power_kw(speeds, hs_m=5.0, wave_angle_deg=alpha, wind_speed_ms=wind_speed)
            # Kwon's sector of the angle: edges belong to the sector nearer the bow (15, 30, 45, 165, 150, 135, 85,
            # 70, 55 deg here: every sector, and both edges 30 and 150 exactly)
            q = int(np.searchsorted([30.0, 60.0, 150.0], folded, side="left"))
            np.testing.assert_allclose(tab.ratio[i, :, 0, q] * base.calm_power_kw(speeds), p, rtol=1e-12)
            # away from the ramps the blend is exact (15, 45, 165, 135, 85 deg: every sector)
            if min(abs(folded - e) for e in (30.0, 60.0, 150.0)) > 1.3 * SECTOR_RAMP_DEG:
                cos_a = np.cos(np.radians(alpha))
                cols = [{f"ratio_0_0_s{k}": tab.ratio[i, j, 0, k] for k in range(4)} for j in range(3)]
                r = [power_ratio(col, v, psi, axes, np, cos_a) for col, v in zip(cols, speeds, strict=True)]
                np.testing.assert_allclose(np.array(r) * base.calm_power_kw(speeds), p, rtol=1e-12)


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
    # the NLP without the 3-D DP's start (the minimum-time plan, 183 t, is its other candidate)
    alone = optimise_corridor(corridor, wx, SHIP, **kw, discrete_start=False)
    # the DP's route as the search route: the same start as discrete_start=True, without running the DP twice
    from_dp = optimise_corridor(corridor, wx, SHIP, **kw, route=dp)
    # the default call: the storm binds, so the start stage scores its own (coarser) 3-D DP's plan too
    default = optimise_corridor(corridor, wx, SHIP, **kw)
    dp_plan = orx.Plan.from_schedule(
        dp.waypoints, dp.stw_kn, departure=T0, ship=SHIP, weather=wx, times=dp.times, step_nm=5.0
    )
    return {
        "wx": wx,
        "dp": dp,
        "dp_plan": dp_plan,
        "alone": alone,
        "from_dp": from_dp,
        "default": default,
        "eta_h": 56.0,
    }


def test_storm_crossing_nlp_is_within_4_percent_of_the_finest_dp_by_the_referee(crossing: dict) -> None:
    # the regression of benchmarks/bench_nlp.py section 4: on the fitted model the NLP lost by 8 % (81.95 t against
    # the DP's 75.3 t); on the ship's own model, from the centreline start, it is within 4 % (measured 77.3 t against
    # 75.25 t)
    plan, dp_plan = crossing["alone"], crossing["dp_plan"]
    assert plan.verify() == [] and plan.duration_h <= crossing["eta_h"] + 1e-6
    assert plan.total_fuel_t <= 1.04 * dp_plan.total_fuel_t
    assert plan.total_fuel_t <= plan.solver_stats["start_score"] * (1 + 1e-9)  # never worse than the verified start


def test_the_dps_plan_passes_the_referee_between_its_own_points(crossing: dict) -> None:
    # the 3-D DP checks each leg's pieces at both ends and between them by the referee's own rule
    # (search.refine_kernels.piece_clear): before, it checked piece midpoints only, and the referee (every 5 nm and at
    # both leg ends) found the engine under its minimum power on two legs of this plan (following seas at 10-12 kn)
    dp, dp_plan = crossing["dp"], crossing["dp_plan"]
    assert dp_plan.verify() == []
    assert dp_plan.verify(step_nm=0.5) == []  # a finer brute-force walk agrees
    assert dp_plan.duration_h <= crossing["eta_h"] + 1e-6
    ctx = dp_plan.context
    mended, legs = repaired_plan(
        ctx, dp.waypoints, np.asarray(dp.stw_kn, dtype=float), T0, 5.0, "start", v_min_kn=3.0, v_max_kn=24.0
    )
    assert legs == 0 and mended is not None and mended.total_fuel_t == pytest.approx(dp_plan.total_fuel_t, rel=1e-12)


def test_storm_crossing_nlp_from_the_dp_is_no_worse_than_the_finest_dp_by_the_referee(crossing: dict) -> None:
    # the regression of benchmarks/bench_nlp.py section 4 (NLP <= DP): started from the DP's route, the NLP's plan
    # verifies and burns less than the DP's own plan (which fails verification) and its mended, verified version
    plan, dp_plan = crossing["from_dp"], crossing["dp_plan"]
    assert plan.verify() == [] and plan.duration_h <= crossing["eta_h"] + 1e-6
    assert plan.total_fuel_t <= dp_plan.total_fuel_t
    assert plan.total_fuel_t <= plan.solver_stats["start_score"] * (1 + 1e-9)
    assert plan.solver_stats["start"] == "search route"


def test_storm_crossing_nlp_from_the_centreline_is_within_half_a_percent_of_the_finest_dp_by_the_referee(
    crossing: dict,
) -> None:
    # from the centreline alone the NLP is a local method: which basin it ends in moves with its rows even where they
    # do not bind (measured 77.71 t with midpoint rows, 77.99 t with the leg ends added, 77.21 t on legs cut to 20 nm
    # where the band binds, against the DP's 77.82 t by the referee; 78.65 t with the heading-node table). NLP <= DP is the default call's promise (the next test),
    # which starts from a discrete plan.
    plan = crossing["alone"]
    assert plan.verify() == [] and plan.total_fuel_t <= crossing["dp_plan"].total_fuel_t * 1.005


def test_storm_crossing_default_call_is_no_worse_than_the_finest_dp_by_the_referee(crossing: dict) -> None:
    # issue 13's regression: the default optimise_corridor call, NLP <= the DP (77.68 t by the referee; 78.65 t on
    # the previous main, which started from the centreline alone). The start stage ran the DP because the storm can
    # bind; the plan is never worse than any verified candidate, and every candidate's CPU is counted in its stage.
    plan, st = crossing["default"], crossing["default"].solver_stats
    assert plan.verify() == [] and plan.total_fuel_t <= crossing["dp_plan"].total_fuel_t
    assert st["global_starts"].startswith("computed") and "3-D DP" in st["starts"]
    assert plan.total_fuel_t <= min(c["score"] for c in st["starts"].values()) * (1 + 1e-9)
    assert sum(c["cpu_s"] for c in st["starts"].values()) <= st["stage_cpu_s"]["start"] + 1e-6


def test_nlp_objective_equals_the_referee_within_the_tabulation_bound(crossing: dict) -> None:
    tab = crossing["alone"].solver_stats["tabulation"]
    assert abs(tab["rel_error"]) <= TABULATION_BOUND
    # the largest measured: +1.9 % at the NLP's solution from the 3-D DP's start (+3.6 % there with the
    # heading-node table, which spread Kwon's sector steps over +-30 deg)
    from_dp = crossing["from_dp"].solver_stats["tabulation"]
    assert abs(from_dp["rel_error"]) <= TABULATION_BOUND
    # per leg, at the NLP's own samples against the model in the referee's weather (measured +5.4 % from the
    # centreline, +6.8 % from the DP's start, against -10.7 % and +7.8 % with the heading-node table: what is left
    # is the Beaufort number's steps in Hs, smoothed over the (t, s, y) grid, and the sector ramps)
    for key in ("alone", "from_dp"):
        tab = crossing[key].solver_stats["tabulation"]
        # every leg: 3 midpoints and the 2 leg ends
        assert tab["samples"] == crossing[key].solver_stats["n_legs"] * 5 and tab["capped_samples"] == 0
        assert abs(tab["max_leg_rel_error"]) <= LEG_BOUND and tab["mean_abs_leg_rel_error"] <= abs(
            tab["max_leg_rel_error"]
        )
    # and the counts are honest: every solve and every iteration
    stats = crossing["alone"].solver_stats
    assert stats["nlp_solves"] >= 1 and stats["iterations"] >= stats["nlp_solves"]


def test_repaired_plan_moves_only_the_slow_leg_to_the_minimum_power_speed_found_by_bisection() -> None:
    # calm water, three legs: the middle one at 3 kn is below the engine's minimum power; the repair moves it to just
    # above the speed where the model's calm-water power equals the minimum (found here by bisection on the model)
    wx = orx.scenarios.calm((20.0, 40.0, -160.0, -130.0), start=T0, duration_h=200.0)
    wp = np.array([[30.0, -150.0], [30.0, -149.0], [30.0, -148.0], [30.0, -147.0]])
    stw = np.array([14.0, 3.0, 14.0])
    ctx = orx.Plan.from_schedule(wp, stw, departure=T0, ship=SHIP, weather=wx).context
    assert {v.kind for v in orx.Plan.from_context(ctx, wp, stw, departure=T0).verify()} == {"power_below_min"}
    plan, legs = repaired_plan(ctx, wp, stw, T0, 5.0, "start", v_min_kn=3.0, v_max_kn=24.0)
    assert plan is not None and plan.verify() == [] and legs == 1
    assert plan.stw_kn[0] == 14.0 and plan.stw_kn[2] == 14.0
    model = KwonModel(SHIP)
    lo, hi = 3.0, 24.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        p = float(model.brake_power_kw(mid, hs_m=0.0, wave_angle_deg=0.0, wind_speed_ms=0.0, wind_angle_deg=0.0))
        lo, hi = (mid, hi) if p < model.min_power_kw else (lo, mid)
    assert hi <= plan.stw_kn[1] <= hi * 1.01  # at the limit, 0.2 % beyond it in power (about 0.07 % in speed)
