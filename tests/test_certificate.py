"""optroute.optimise.certificate: the ship's own lower bound against the referee, brute force and the optimiser.

References, all independent of the bound's code:

* the referee: :class:`optroute.Plan` (``legs["fuel_t"]``, :meth:`~optroute.Plan.verify`) and
  :func:`optroute.physics.passage.evaluate_speeds` (power, fuel and allowedness at every point);
* brute force: every schedule of a speed grid on a 3-leg path, each speed allowed by the referee
  at every point of its leg, scored with the referee's leg fuel;
* the optimiser's plan and a plan built from the dual's own schedule, both verified by the referee.

The sea: Hs 5.5–7.5 m rising eastwards, T = 8 s, waves from the west (following seas for an
eastbound ship), constant in time; a stiff ship (GM 4.5 m, T_R ≈ 9.9 s) with the bands applying
from Hs ≥ 0.02 L and a low minimum load (3 % MCR), so that the allowed speeds are two intervals —
above the synchronous-roll band and below the high-wave-attack band (≈ 8.2–9.7 kn), and between it
and the surf-riding band (≈ 14.6–19.4 kn) — and an ETA whose mean speed (12 kn) lies in the band.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import optroute as orx
from formulations.ship_bound import lagrangian_bound
from optroute.optimise.api import optimise_corridor
from optroute.optimise.certificate import fixed_path_problem, ship_certificate
from optroute.physics.passage import evaluate_speeds
from optroute.plan.evaluate import dense_points, sample_sea
from optroute.weather import schema

SHIP = orx.Ship.preset("container_54k_dwt").replace(gm_m=4.5, min_load_fraction=0.03)
RULES = orx.BandRules(hs_threshold_fraction=0.02)
T0 = np.datetime64("2024-01-10T00:00", "ns")
V_RANGE = (3.0, 26.5)


def _following_sea(hs0: float = 5.5, slope: float = 0.1, time_slope: float = 0.0, current_ms: float = 0.0):
    """Hs linear in longitude (and in time with ``time_slope`` [m/h]), T = 8 s, waves from the west."""
    time = T0 + np.arange(0, 241, 24).astype("timedelta64[h]")
    lat = np.arange(-5.0, 5.01, 1.0)
    lon = np.arange(-32.0, -7.99, 1.0)
    hours = np.arange(0, 241, 24.0)
    hs = hs0 + slope * (lon[None, None, :] + 30.0) + time_slope * hours[:, None, None]
    # a 14 m/s westerly with the waves: Kwon's Beaufort number comes from the wind where one is given
    fields = {
        "hs_m": hs + 0.0 * lat[None, :, None],
        "tp_s": 8.0,
        "wave_from_deg": 270.0,
        "wind_u_ms": 14.0,
        "wind_v_ms": 0.0,
    }
    if current_ms:
        fields.update({"current_u_ms": current_ms, "current_v_ms": 0.0})
    return schema.canonical_dataset(time, lat, lon, fields, {"title": "following sea", "source": "test"})


@pytest.fixture(scope="module")
def sea() -> xr.Dataset:
    return _following_sea()


def _plan(wx, waypoints, stw, eta_h=None):
    eta = None if eta_h is None else T0 + np.timedelta64(int(round(eta_h * 3600)), "s")
    return orx.Plan.from_schedule(
        waypoints, stw, departure=T0, ship=SHIP, weather=wx, rules=RULES, eta=eta, use_land_mask=False
    )


def _waypoints(n_legs: int, lon0: float = -30.0, lon1: float = -10.0) -> np.ndarray:
    lon = np.linspace(lon0, lon1, n_legs + 1)
    return np.column_stack([np.zeros_like(lon), lon])


def _referee_allowed(ctx, waypoints, speeds: np.ndarray, step_nm: float = 5.0) -> np.ndarray:
    """(legs, speeds): allowed by the referee's evaluate_speeds at every point of the leg, ends included."""
    leg, _, _, lat, lon, course, d = dense_points(waypoints, step_nm)
    sea_state, _ = sample_sea(ctx.sampler, np.full(lat.shape, T0), lat, lon)
    v = np.broadcast_to(speeds, (lat.size, speeds.size))
    *_, allowed = evaluate_speeds(ctx.ship, ctx.model, ctx.rules, course, sea_state, v)
    return np.stack([allowed[leg == k].all(axis=0) for k in range(d.size)])


def _in_sets(v: float, ivls) -> bool:
    return any(a <= v <= b for a, b in ivls)


def test_leg_fuel_is_the_referees(sea):
    wp = _waypoints(4)
    stw = np.array([9.0, 15.0, 17.5, 9.5])
    plan = _plan(sea, wp, stw)
    prob = fixed_path_problem(plan.context, wp, departure=T0, window_h=200.0, v_min_kn=3.0, v_max_kn=26.5)
    fuel = prob.distance_nm / stw * prob.fuel_rate_tph(np.arange(4), stw)
    np.testing.assert_allclose(fuel, plan.legs["fuel_t"].to_numpy(), rtol=1e-12)


def test_allowed_sets_hold_every_speed_the_referee_allows_and_little_else(sea):
    wp = _waypoints(4)
    ctx = _plan(sea, wp, np.full(4, 15.0)).context
    prob = fixed_path_problem(ctx, wp, departure=T0, window_h=200.0, v_min_kn=V_RANGE[0], v_max_kn=V_RANGE[1])
    speeds = np.arange(3.0, 26.5, 0.005)
    ok = _referee_allowed(ctx, wp, speeds)
    assert ok.any(axis=1).all() and (~ok).any(axis=1).all()  # speeds allowed and speeds forbidden on every leg
    assert all(len(ivls) >= 2 for ivls in prob.allowed_kn)  # the bands split every leg's speeds
    for k, ivls in enumerate(prob.allowed_kn):
        inside = np.array([_in_sets(v, ivls) for v in speeds])
        assert not np.any(ok[k] & ~inside)  # a superset of the referee's allowed speeds ...
        deep = np.array([_in_sets(v - 0.01, ivls) and _in_sets(v + 0.01, ivls) for v in speeds])
        assert np.all(ok[k][deep])  # ... and not by more than 0.01 kn at any edge


def test_bound_never_exceeds_the_referees_brute_force_on_a_three_leg_path(sea):
    wp = _waypoints(3, -30.0, -26.0)  # 3 legs of 80 nm
    ctx = _plan(sea, wp, np.full(3, 15.0)).context
    eta_h = 240.0 / 12.0  # mean 12 kn: inside the high-wave-attack band
    prob = fixed_path_problem(ctx, wp, departure=T0, window_h=eta_h, v_min_kn=V_RANGE[0], v_max_kn=V_RANGE[1])
    speeds = np.arange(3.0, 26.5, 0.02)
    ok = _referee_allowed(ctx, wp, speeds)
    d = prob.distance_nm
    fuel = np.stack([d[k] / speeds * prob.fuel_rate_tph(np.full(speeds.size, k), speeds) for k in range(3)])
    t = [d[k] / speeds[ok[k]] for k in range(3)]
    f = [fuel[k][ok[k]] for k in range(3)]
    # every pair of the first two legs, then the cheapest third leg that fits (a prefix minimum over its times)
    t01 = (t[0][:, None] + t[1][None, :]).ravel()
    f01 = (f[0][:, None] + f[1][None, :]).ravel()
    order = np.argsort(t[2])
    t2, f2 = t[2][order], np.minimum.accumulate(f[2][order])
    j = np.searchsorted(t2, eta_h - t01, side="right") - 1
    brute = float(np.min(f01[j >= 0] + f2[j[j >= 0]]))
    assert np.isfinite(brute)
    res = lagrangian_bound(d, prob.allowed_kn, prob.fuel_rate_tph, eta_h=eta_h)
    assert res.status == "converged"
    assert res.bound <= brute
    assert res.bound >= 0.95 * brute  # and a useful one: within 5 % of the grid's best schedule


def test_optimiser_plan_with_bands_is_within_the_stated_gap_of_the_bound(sea):
    # the optimiser starts from the dual's own schedule (moved 0.01 kn inside its speed intervals) among its
    # verified starts and returns a plan no worse: 0.2 % above the bound here (measured; the stated gap is 1 %);
    # the same schedule built by hand verifies, above the bound, and the returned plan is no worse than it
    # (measured: 90.838 t against the schedule's 90.880 t, with the NLP's back-offs fitted to that start)
    corridor = orx.Corridor(np.array([[0.0, -30.0], [0.0, -10.0]]), 0.0)
    eta_h = 100.0
    plan = optimise_corridor(
        corridor,
        sea,
        SHIP,
        departure=T0,
        eta=T0 + np.timedelta64(100, "h"),
        rules=RULES,
        max_leg_nm=60.0,
        band_solves=8,
        use_land_mask=False,
    )
    assert plan.verify() == []
    margins = plan.legs[[c for c in plan.legs.columns if c.startswith("margin_")]].to_numpy()
    assert np.isfinite(margins).all()  # a band applies on every leg
    cert = plan.solver_stats["certificate"]
    assert cert["method"] == "lagrangian dual" and cert["status"] == "converged"
    assert cert["bound_t"] <= plan.total_fuel_t
    assert 0.0 <= cert["gap"] <= 0.01
    # the dual's schedule with every interval shrunk by 0.01 kn: strictly inside, so the referee accepts it
    prob = fixed_path_problem(
        plan.context, plan.waypoints, departure=T0, window_h=eta_h, v_min_kn=V_RANGE[0], v_max_kn=V_RANGE[1]
    )
    inner = [[(a + 0.01, b - 0.01) for a, b in ivls if b - a > 0.02] for ivls in prob.allowed_kn]
    res = lagrangian_bound(prob.distance_nm, inner, prob.fuel_rate_tph, eta_h=eta_h)
    dual_plan = _plan(sea, plan.waypoints, res.primal_speed_kn, eta_h=eta_h)
    assert dual_plan.verify() == []
    assert cert["bound_t"] <= dual_plan.total_fuel_t and plan.total_fuel_t <= dual_plan.total_fuel_t * (1 + 1e-9)


def test_the_certificate_says_why_it_does_not_apply():
    wp = _waypoints(2)
    moving = _plan(_following_sea(time_slope=0.01), wp, np.full(2, 15.0))
    cert = ship_certificate(moving, eta_h=100.0, v_min_kn=3.0, v_max_kn=26.5)
    assert cert.method == "not applicable" and "changes in time" in cert.reason and np.isnan(cert.bound)
    current = _plan(_following_sea(current_ms=0.5), wp, np.full(2, 15.0))
    cert = ship_certificate(current, eta_h=100.0, v_min_kn=3.0, v_max_kn=26.5)
    assert cert.method == "not applicable" and "current" in cert.reason
    assert ship_certificate(current, eta_h=100.0).as_stats()["reason"] == cert.reason


def test_an_unknown_objective_or_eta_is_refused(sea):
    plan = _plan(sea, _waypoints(2), np.full(2, 15.0))
    with pytest.raises(orx.ConfigError, match="objective"):
        ship_certificate(plan, objective="time")
    with pytest.raises(orx.ConfigError, match="eta_h"):
        ship_certificate(plan, eta_h=-1.0)
