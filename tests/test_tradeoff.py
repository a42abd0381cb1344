"""orx.tradeoff: the fuel-versus-ETA front against hand-worked calm-water physics and the convex optimum.

References, independent of the NLP:

* calm water on a fixed path: the least fuel to arrive by T is at constant speed D/T, fuel
  T · fuel_rate(calm_power(D/T)) from the Ship's own curves; the earliest arrival is D / (calm speed
  at MCR) and the slow-steaming limit D / (calm speed at the minimum load);
* a static sea with a power law (``LinearSeaModel`` of test_optimise, inside the NLP's class):
  :func:`formulations.speed_convex.solve_speed_convex` (Clarabel), the global optimum.
"""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest
import xarray as xr
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from matplotlib.figure import Figure

import optroute as orx
from formulations.common import PowerLawFuel
from formulations.speed_convex import solve_speed_convex
from optroute.optimise.api import optimise_corridor
from optroute.plot.common import save_png
from optroute.plot.front import front_figure, knee_index
from optroute.studies.study import SchedulerUnreachable
from optroute.studies.tradeoff import TradeoffFront, tradeoff
from tests.test_optimise import LinearSeaModel, _static_linear_sea

# the module, not the function orx.tradeoff that shadows it as an attribute of the package
points_mod = importlib.import_module("optroute.studies.front_points")
runners_mod = importlib.import_module("optroute.studies.front_runners")
SHIP = orx.Ship.preset("container_54k_dwt")
SMALL_SHIP = SHIP.replace(name="small_feeder", mcr_kw=20000.0)
T0 = np.datetime64("2024-01-10T00:00", "ns")
KW = {"max_leg_nm": 150.0, "use_land_mask": False}


def _calm() -> xr.Dataset:
    return orx.scenarios.uniform(
        hs_m=0.0, tp_s=6.0, bbox=(-10, 10, -40, 0), start=T0, duration_h=240, resolution_deg=1.0
    )


CORRIDOR = orx.Corridor.from_waypoints([[0.0, -30.0], [0.0, -20.0]], width_nm=0.0)


@pytest.fixture(scope="module")
def calm_front() -> TradeoffFront:
    return tradeoff(CORRIDOR, _calm(), SHIP, departure=T0, n=5, **KW)


def _by_hand_fuel(eta_h: float) -> float:
    v = CORRIDOR.length_nm / eta_h
    return eta_h * float(SHIP.fuel_rate_tph(SHIP.calm_power_kw(v)))


def test_calm_front_matches_the_ship_by_hand_from_earliest_arrival_to_slow_steaming(calm_front):
    f = calm_front
    assert f.sizes["eta"] == 5 and list(f.status.values) == ["optimal"] * 5
    eta_h = f.eta_h.values
    # the ends: top speed at MCR, and the speed at which the engine reaches its minimum load
    assert eta_h[0] == pytest.approx(CORRIDOR.length_nm / SHIP.max_calm_speed_kn, rel=1e-6)
    assert eta_h[-1] == pytest.approx(CORRIDOR.length_nm / SHIP.calm_speed_kn(SHIP.min_power_kw), rel=1e-5)
    assert list(f.solve.values) == ["minimum_time", "eta", "eta", "eta", "slow_steaming"]
    np.testing.assert_allclose(np.diff(eta_h), np.diff(eta_h)[0], rtol=1e-9)  # evenly spaced
    for h, fuel in zip(eta_h, f.fuel_t.values, strict=True):
        assert fuel == pytest.approx(_by_hand_fuel(h), rel=1e-5)
    assert np.all(np.diff(f.fuel_t.values) < 0)
    # the shadow price is -dF/dT of the by-hand curve (central difference)
    for h, price in zip(eta_h[1:-1], f.eta_shadow_price_t_per_h.values[1:-1], strict=True):
        slope = (_by_hand_fuel(h - 1e-3) - _by_hand_fuel(h + 1e-3)) / 2e-3
        assert price == pytest.approx(slope, rel=1e-3)
    # the per-point plans: constant speed D/T on every leg, waypoints on the fixed path
    np.testing.assert_allclose(
        f.leg_stw_kn.values, np.broadcast_to((CORRIDOR.length_nm / eta_h)[:, None], (5, 5)), rtol=1e-5
    )
    assert np.nanmax(np.abs(f.waypoint_lat_deg.values)) < 1e-9
    np.testing.assert_allclose(f.waypoint_time_h.values[:, -1], f.duration_h.values, rtol=1e-9)


def test_front_ends_are_the_independent_minimum_time_and_slow_steaming_solves(calm_front):
    fast = optimise_corridor(CORRIDOR, _calm(), SHIP, departure=T0, objective="time", **KW)
    slow = optimise_corridor(CORRIDOR, _calm(), SHIP, departure=T0, objective="fuel", **KW)
    assert calm_front.duration_h.values[0] == pytest.approx(fast.duration_h, rel=1e-9)
    assert calm_front.fuel_t.values[0] == pytest.approx(fast.total_fuel_t, rel=1e-9)
    assert calm_front.duration_h.values[-1] == pytest.approx(slow.duration_h, rel=1e-9)
    assert calm_front.fuel_t.values[-1] == pytest.approx(slow.total_fuel_t, rel=1e-9)


def test_static_sea_front_equals_the_convex_optimum_at_every_eta():
    model = LinearSeaModel(SHIP)
    wx = _static_linear_sea(1.0, 0.15, wave_from_deg=45.0)
    corridor = orx.Corridor(np.array([[0.0, -30.0], [0.0, -10.0]]), 0.0)
    etas = [70.0, 80.0, 95.0]
    front = tradeoff(corridor, wx, SHIP, departure=T0, etas=etas, model=model, max_leg_nm=60.0, use_land_mask=False)
    legs = corridor.resample(60.0)
    lon_mid = 0.5 * (legs.waypoints[:-1, 1] + legs.waypoints[1:, 1])
    ca = np.cos(np.radians(45.0))
    c = float(SHIP.calm_power_kw(1.0))
    k = model.sfoc_gpkwh * 1e-6 * c * (1 + model.h * (1.0 + 0.15 * (lon_mid + 30.0)) * (0.6 + 0.3 * ca + 0.1 * ca**2))
    for eta_h, fuel in zip(front.eta_h.values, front.fuel_t.values, strict=True):
        ref = solve_speed_convex(
            legs.leg_distance_nm, PowerLawFuel.cubic(k), eta_h=eta_h, v_min_kn=3.0, v_max_kn=SHIP.max_calm_speed_kn
        )
        assert fuel == pytest.approx(ref.total_fuel_t, rel=1e-6)
    # fuel ∝ 1/T² for the cubic law on a fixed path
    f = front.fuel_t.values
    assert f[0] / f[1] == pytest.approx((80.0 / 70.0) ** 2, rel=1e-5)


def test_infeasible_etas_are_reported_per_point_not_dropped(calm_front):
    t_min = float(calm_front.eta_h.values[0])
    etas = [T0 + np.timedelta64(int(0.8 * t_min * 3600), "s"), 35.0, 230.0, 500.0]
    front = tradeoff(CORRIDOR, _calm(), SHIP, departure=T0, etas=etas, **KW)
    assert front.sizes["eta"] == 4
    status = [str(s) for s in front.status.values]
    assert status[0].startswith("infeasible: earliest arrival") and f"{t_min:.2f} h" in status[0]
    assert status[1] == "optimal" and front.fuel_t.values[1] == pytest.approx(_by_hand_fuel(35.0), rel=1e-5)
    # past the slow-steaming limit the ETA does not bind: the slow-steaming plan, arriving before it
    assert status[2] == "optimal" and front.solve.values[2] == "slow_steaming"
    assert front.duration_h.values[2] < 230.0
    assert front.fuel_t.values[2] == pytest.approx(calm_front.fuel_t.values[-1], rel=1e-9)
    # 500 h is past the 240 h forecast, but the slow-steaming plan arrives within it, by that ETA
    assert status[3] == "optimal" and front.duration_h.values[3] == front.duration_h.values[2]
    assert np.isnan(front.fuel_t.values[0]) and np.isnan(front.leg_fuel_t.values[0]).all()


def test_a_rising_point_keeps_the_earlier_plan_beside_its_own_solve_and_is_counted(monkeypatch):
    real = points_mod.solve_point
    solved = []

    def spoiled(spec, eta_h, kind, warm, route=None, **kw):
        p = real(spec, eta_h, kind, warm, route, **kw)
        solved.append((kind, eta_h))
        if kind == "eta" and eta_h == 35.0:  # planted: the 35 h solve ends above the 30 h point's fuel
            p = points_mod.replace_fields(p, totals={**p.totals, "fuel_t": 1e6})
        return p

    for mod in (points_mod, runners_mod):  # the chains' and the end solves' callers
        monkeypatch.setattr(mod, "solve_point", spoiled)
    front = tradeoff(CORRIDOR, _calm(), SHIP, departure=T0, etas=[30.0, 35.0, 40.0], **KW)
    # one solve per point, and the risen point once more from the 30 h plan (which rises too: planted)
    assert sorted(h for k, h in solved if k == "eta") == [30.0, 35.0, 35.0, 40.0]
    assert front.attrs["risen_points"] == front.risen_points == 1
    assert front.attrs["risen_resolves"] == 1 and front.attrs["monotonicity_resolves"] == 0
    assert front.nlp_solves.values[1] >= 2  # both solves counted in the point
    # arriving by 35 h may arrive at 30 h, so the 30 h plan serves it; its own solve is reported beside it
    assert "the plan of the earlier ETA 30 h" in str(front.status.values[1])
    assert "ended 1e+06 t" in str(front.status.values[1])
    assert front.own_fuel_t.values[1] == 1e6
    assert front.fuel_t.values[1] == front.fuel_t.values[0] == pytest.approx(_by_hand_fuel(30.0), rel=1e-5)
    assert front.duration_h.values[1] == front.duration_h.values[0] <= 30.0 + 1e-6
    assert front.eta_h.values[1] == 35.0
    np.testing.assert_array_equal(front.own_fuel_t.values[[0, 2]], front.fuel_t.values[[0, 2]])
    assert front.fuel_t.values[2] == pytest.approx(_by_hand_fuel(40.0), rel=1e-5)


def test_a_rising_point_is_solved_again_from_the_earlier_plan_and_no_longer_rises(monkeypatch):
    """A point whose first solve rose is solved once more, from the earlier ETA's plan alone (its floor): in calm
    water on a fixed path that re-solve reaches the 35 h optimum by hand, the first solve's fuel stays beside it."""
    real = points_mod.solve_point
    solved = []

    def spoiled_once(spec, eta_h, kind, warm, route=None, **kw):
        p = real(spec, eta_h, kind, warm, route, **kw)
        solved.append((kind, eta_h, getattr(warm, "eta_h", None), kw.get("end_adjacent", False), p.warm_start))
        if kind == "eta" and eta_h == 35.0 and sum(s[1] == 35.0 for s in solved) == 1:  # planted: the first only
            p = points_mod.replace_fields(p, totals={**p.totals, "fuel_t": 1e6})
        return p

    for mod in (points_mod, runners_mod):
        monkeypatch.setattr(mod, "solve_point", spoiled_once)
    front = tradeoff(CORRIDOR, _calm(), SHIP, departure=T0, etas=[30.0, 35.0, 40.0], **KW)
    again = [s for s in solved if s[1] == 35.0][1]
    assert again[2:] == (30.0, True, "warm plan")  # from the 30 h point's plan, as its sole start
    assert front.attrs["risen_points"] == front.risen_points == 0 and front.attrs["risen_resolves"] == 1
    assert front.own_fuel_t.values[1] == 1e6
    assert "solved again from the plan of the earlier ETA 30 h" in str(front.status.values[1])
    assert front.fuel_t.values[1] == pytest.approx(_by_hand_fuel(35.0), rel=1e-5)
    assert front.fuel_t.values[1] < front.fuel_t.values[0]
    assert front.solve.values[1] == "eta" and front.nlp_solves.values[1] >= 2


def test_one_solve_per_point_each_started_from_the_earlier_neighbours_plan_as_it_is(monkeypatch):
    """The sweep runs from the fast end: each interior point's warm plan is its earlier neighbour's plan, speeds
    unchanged to the bit (it arrives before the later ETA), so no point of a chain ends above its neighbour."""
    started: list[np.ndarray] = []
    real = points_mod.solve_prepared

    def spying(*args, warm_plan=None, **kw):
        if warm_plan is not None:
            started.append(np.asarray(warm_plan.stw_kn, dtype=float).copy())
        return real(*args, warm_plan=warm_plan, **kw)

    monkeypatch.setattr(points_mod, "solve_prepared", spying)
    front = tradeoff(CORRIDOR, _calm(), SHIP, departure=T0, n=5, chains=1, **KW)
    interior = np.flatnonzero(front.solve.values == "eta")
    assert front.attrs["risen_points"] == 0 and front.attrs["monotonicity_resolves"] == 0
    assert (front.nlp_solves.values[interior] >= 1).all()
    assert len(started) == interior.size  # the ends start from their own candidates
    for i, stw in zip(interior, started, strict=True):
        np.testing.assert_array_equal(stw, front.leg_stw_kn.values[i - 1])  # the earlier point's plan, as it is
    assert np.all(np.diff(front.fuel_t.values) < 0)


def test_each_point_starts_from_its_neighbours_plan_and_multipliers_and_reaches_the_cold_front():
    """The continuation's primal-dual warm start: a point takes its neighbour's multipliers exactly when Ipopt
    starts from its neighbour's plan (the same rows), never at the ends. References: the cold front (each point
    from the optimiser's own start) and the calm-water fuel by hand on the great circle (the equator), the
    shortest track. (On the benchmark's storm corridor 24 of 28 points start from the multipliers.)"""
    wide = orx.Corridor.from_waypoints([[0.0, -30.0], [0.0, -20.0]], width_nm=20.0)
    warm = tradeoff(wide, _calm(), SHIP, departure=T0, n=4, **KW)
    interior = warm.solve.values == "eta"
    assert interior.sum() == 2
    np.testing.assert_array_equal(warm.dual_starts.values >= 1, warm.warm_start.values == "warm plan")
    assert (warm.dual_starts.values[~interior] == 0).all()  # the ends start from their own candidates
    cold = tradeoff(wide, _calm(), SHIP, departure=T0, n=4, warm_start=False, **KW)
    assert (cold.dual_starts.values == 0).all() and (cold.warm_start.values != "warm plan").all()
    np.testing.assert_allclose(warm.fuel_t.values, cold.fuel_t.values, rtol=1e-7)
    by_hand = [_by_hand_fuel(h) for h in warm.eta_h.values[interior]]
    np.testing.assert_allclose(warm.fuel_t.values[interior], by_hand, rtol=1e-5)


def test_a_start_below_the_minimum_load_is_mended_up_to_it_by_the_propeller_law():
    """Calm water, fixed path: a leg slowed below the engine's minimum load moves up to the speed where the
    ship's own calm-water power meets it (by hand, bisection on ``Ship.calm_power_kw``), and no faster than
    the repair's step beyond; the others keep their speeds, so the plan arrives earlier and verifies."""
    legs = CORRIDOR.resample(150.0)
    v_limit = _bisect(lambda v: SHIP.calm_power_kw(v) - SHIP.min_power_kw, 1.0, 20.0)
    stw = np.full(legs.n_legs, 1.2 * v_limit)  # above the minimum load
    stw[1] = 0.8 * v_limit  # about half the minimum power
    spec = points_mod.FrontSpec(
        CORRIDOR,
        _calm(),
        SHIP,
        T0,
        "fuel",
        dict(KW),
        token=points_mod.front_token(CORRIDOR, _calm(), SHIP, T0, "fuel", KW),
    )
    prepared, _ = points_mod.prepared_corridor(spec)
    eta = T0 + np.timedelta64(60, "h")
    mended = points_mod.mended_start(prepared, points_mod.WarmStart(legs.waypoints, stw), eta)
    assert np.array_equal(np.delete(mended.stw_kn, 1), np.delete(stw, 1))
    assert v_limit <= mended.stw_kn[1] <= v_limit + 0.3
    plan = orx.Plan.from_context(prepared.plan_context(eta), mended.waypoints, mended.stw_kn, departure=T0)
    assert not plan.verify() and plan.duration_h <= 60.0


def _bisect(f, lo: float, hi: float) -> float:
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(mid) < 0 else (lo, mid)
    return hi


def test_chains_split_by_eta_alone_ascending_from_the_fast_end():
    split = runners_mod.split_chains
    assert split([1.0, 2.0, 3.0, 4.0, 5.0], 2) == [[1.0, 2.0, 3.0], [4.0, 5.0]]
    assert split([1.0, 2.0, 3.0], 2) == [[1.0, 2.0], [3.0]]
    assert split([1.0, 2.0], 4) == [[1.0], [2.0]]  # never an empty chain


def test_a_failed_minimum_time_solve_starts_the_front_from_the_fastest_verified_plan(monkeypatch):
    # planted: the minimum-time NLP fails, carrying a verified 30 h plan as its best (as SolverFailure
    # does with the search route's); the front starts there, labelled, and the rest is unchanged
    real = points_mod.solve_prepared
    best = optimise_corridor(CORRIDOR, _calm(), SHIP, departure=T0, eta=T0 + np.timedelta64(30, "h"), **KW)

    def failing(*args, objective="fuel", **kw):
        if objective == "time":
            raise orx.SolverFailure("planted", status="Maximum_Iterations_Exceeded", best_plan=best)
        return real(*args, objective=objective, **kw)

    monkeypatch.setattr(points_mod, "solve_prepared", failing)
    front = tradeoff(CORRIDOR, _calm(), SHIP, departure=T0, n=3, **KW)
    assert front.eta_h.values[0] == pytest.approx(best.duration_h, rel=1e-9)
    assert str(front.status.values[0]).startswith("feasible: fastest verified plan known")
    assert "Maximum_Iterations_Exceeded" in str(front.status.values[0])
    assert front.fuel_t.values[0] == pytest.approx(_by_hand_fuel(best.duration_h), rel=1e-5)
    assert np.all(np.diff(front.fuel_t.values) <= 0)


def test_plot_returns_a_figure_and_the_front_round_trips_through_netcdf(calm_front, tmp_path):
    fig = calm_front.plot()
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert "ETA [h" in ax.get_xlabel() and "fuel [t]" in ax.get_ylabel() and fig._suptitle.get_text()
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "knee" in labels and any("shadow price" in s for s in labels)
    png = save_png(fig, tmp_path / "front.png")
    assert png.stat().st_size > 10_000
    path = tmp_path / "front.nc"
    calm_front.to_netcdf(path)
    back = xr.open_dataset(path)
    np.testing.assert_allclose(back.fuel_t.values, calm_front.fuel_t.values)
    assert [str(s) for s in back.status.values] == [str(s) for s in calm_front.status.values]
    assert isinstance(front_figure(back), Figure)
    assert isinstance(TradeoffFront.from_dataset(back).plot(), Figure)


def test_knee_by_hand():
    # a front falling 10, 2, 1, 0.5: scaled, the second point is farthest below the chord
    assert knee_index([0.0, 1.0, 2.0, 3.0, 4.0], [13.5, 3.5, 1.5, 0.5, 0.0]) == 1
    assert knee_index([0.0, 1.0, 2.0], [2.0, 1.0, 0.0]) is None  # a straight line has no knee
    assert knee_index([0.0, 1.0], [2.0, 1.0]) is None


def test_bad_arguments_and_unreachable_scheduler():
    wx = _calm()
    with pytest.raises(orx.ConfigError, match="objective='time'"):
        tradeoff(CORRIDOR, wx, SHIP, departure=T0, objective="time")
    with pytest.raises(orx.ConfigError, match="eta"):
        tradeoff(CORRIDOR, wx, SHIP, departure=T0, eta=T0)
    with pytest.raises(orx.ConfigError, match="duplicates"):
        tradeoff(CORRIDOR, wx, SHIP, departure=T0, etas=[30.0, 30.0])
    with pytest.raises(orx.ConfigError, match="n=1"):
        tradeoff(CORRIDOR, wx, SHIP, departure=T0, n=1)
    with pytest.raises(orx.ConfigError, match="corridor_or_endpoints"):
        tradeoff("Rotterdam", wx, SHIP, departure=T0)
    with pytest.raises(SchedulerUnreachable, match="127.0.0.1:9"):
        tradeoff(CORRIDOR, wx, SHIP, departure=T0, scheduler_address="tcp://127.0.0.1:9", timeout_s=2)
    # where the front runs: the same checks and messages as optroute.study's (one function)
    for kw, match in (
        ({"n_workers": -1}, r"n_workers=-1 must be an integer >= 0"),
        ({"n_workers": True}, r"n_workers=True must be an integer"),
        ({"n_workers": 2, "scheduler_address": "tcp://127.0.0.1:9"}, "applies to the local cluster only"),
        ({"scheduler_address": 8786}, r"scheduler_address=8786 must be a string"),
        ({"timeout_s": 0}, r"timeout_s=0 must be a positive number of seconds"),
    ):
        with pytest.raises(orx.ConfigError, match=match):
            tradeoff(CORRIDOR, wx, SHIP, departure=T0, **kw)


def test_a_synchronous_scheduler_runs_the_front_in_this_process_as_n_workers_0():
    wx = _calm()
    serial = tradeoff(CORRIDOR, wx, SHIP, departure=T0, n=3, n_workers=0, **KW)
    here = tradeoff(CORRIDOR, wx, SHIP, departure=T0, n=3, scheduler_address="synchronous", n_workers=2, **KW)
    np.testing.assert_array_equal(here.fuel_t.values, serial.fuel_t.values)


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    hs=st.lists(st.floats(0.0, 4.0), min_size=2, max_size=4),
    from_deg=st.floats(0.0, 359.0),
)
def test_fuel_never_rises_with_a_later_eta_on_random_fixed_paths(hs, from_deg):
    # a static sea whose Hs steps along the path (one value per 3 deg of longitude)
    lon = np.arange(-32.0, -7.99, 1.0)
    field = np.interp(lon, np.linspace(-31.0, -9.0, len(hs)), hs)
    time = T0 + np.arange(0, 241, 24).astype("timedelta64[h]")
    wx = orx.weather.schema.canonical_dataset(
        time,
        np.arange(-5.0, 5.01, 1.0),
        lon,
        {"hs_m": np.broadcast_to(field, (11, lon.size))[None], "tp_s": 8.0, "wave_from_deg": from_deg},
        {"title": "random static sea"},
    )
    front = tradeoff(CORRIDOR, wx, SHIP, departure=T0, n=4, **KW)
    fuel = front.fuel_t.values
    assert np.isfinite(fuel).all()
    assert np.all(np.diff(fuel) <= 1e-6 * fuel[:-1])
    assert not any("non-monotone" in str(s) for s in front.status.values)
    assert math.isclose(front.eta_h.values[0], front.duration_h.values[0], rel_tol=1e-9)


def test_a_front_on_a_prepared_corridor_is_monotone_and_prepares_once(monkeypatch):
    """The ends and the points between share one PreparedCorridor per process; each equals optimise_corridor's plan."""
    from tests.test_optimise import _static_linear_sea

    made = []

    class Counting(points_mod.PreparedCorridor):
        def __init__(self, *args, **kwargs):
            made.append(kwargs["latest_eta"])
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(points_mod, "PreparedCorridor", Counting)
    wx = _static_linear_sea(1.0, 0.15, wave_from_deg=45.0)
    corridor = orx.Corridor(np.array([[0.0, -30.0], [0.0, -10.0]]), 20.0)
    kw = {"max_leg_nm": 150.0, "use_land_mask": False, "speed_range_kn": (9.0, SHIP.max_calm_speed_kn)}
    etas = [70.0, 80.0, 95.0, 110.0]
    front = tradeoff(corridor, wx, SHIP, departure=T0, etas=etas, **kw)
    fuel = front.fuel_t.values
    assert np.all(np.isfinite(fuel)) and np.all(np.diff(fuel) <= 1e-6 * fuel[:-1])
    assert not any("non-monotone" in str(s) for s in front.status.values)
    interior = front.eta_h.values[front.solve.values == "eta"]
    assert interior.size >= 2
    assert made == [None]  # prepared once, for the weather's whole time span: the two ends and every ETA between
    # kept for the next front of the same inputs (a study's): keyed by their fingerprint, which another ship changes
    token = points_mod.front_token(corridor, wx, SHIP, T0, "fuel", kw)
    assert token in points_mod.PREPARED_CORRIDORS
    assert points_mod.front_token(corridor, wx, SMALL_SHIP, T0, "fuel", kw) != token
    ref = optimise_corridor(corridor, wx, SHIP, departure=T0, eta=T0 + np.timedelta64(80, "h"), **kw)
    assert fuel[1] == pytest.approx(ref.total_fuel_t, rel=1e-6)


def test_a_front_point_skips_the_table_statistics_alone_and_plans_the_same():
    # solve_prepared(tabulate=False), as a front's points solve: the same plan to the last bit, only the two
    # power-table statistics (a referee evaluation each) left out; the front's own points carry none of them
    from optroute.optimise.api import solve_prepared
    from optroute.optimise.corridor_problem import PreparedCorridor

    storm = orx.scenarios.moving_storm(0.0, -32.0, 90.0, 6.0, peak_hs_m=6.0, start=T0, duration_h=200.0,
                                       bbox=(-10, 10, -40, 0))  # fmt: skip
    corridor = orx.Corridor.from_waypoints([[0.0, -30.0], [1.0, -20.0]], width_nm=20.0)
    prepared = PreparedCorridor(corridor, storm, SHIP, departure=T0, objective="fuel", **KW)
    eta = T0 + np.timedelta64(60, "h")
    full = solve_prepared(prepared, eta, objective="fuel")
    lean = solve_prepared(prepared, eta, objective="fuel", tabulate=False)
    assert full.solver_stats["tabulation"] and full.solver_stats["start_tabulation"]
    assert lean.solver_stats["tabulation"] == {} and lean.solver_stats["start_tabulation"] == {}
    assert lean.total_fuel_t == full.total_fuel_t and lean.status == full.status
    np.testing.assert_array_equal(lean.stw_kn, full.stw_kn)
    np.testing.assert_array_equal(lean.waypoints, full.waypoints)
    assert points_mod.FRONT_TABULATION is False
