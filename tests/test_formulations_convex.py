"""formulations.speed_convex against hand-worked and closed-form references."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from formulations.common import FormulationInputError, NonConvexFuelModel, PowerLawFuel
from formulations.speed_convex import solve_speed_convex

# physics.md §9, checked by hand: t_i ∝ d_i k_i^(1/3), fuel = Σ k d³/t².
D = np.array([300.0, 500.0, 200.0, 400.0])
K = np.array([1.0, 1.5, 0.8, 1.2]) * 1e-3
T_STAR = np.array([20.228, 38.592, 12.519, 28.661])
FUEL_STAR = 326.2101


@pytest.mark.parametrize("formulation", ["powcone", "power"])
@pytest.mark.parametrize("eta_mode", ["le", "eq"])
def test_physics_md_analytic_split(formulation: str, eta_mode: str) -> None:
    res = solve_speed_convex(D, PowerLawFuel.cubic(K), eta_h=100.0, eta_mode=eta_mode, formulation=formulation)
    assert res.success, res.status
    assert res.solver_status == "Solved"
    np.testing.assert_allclose(res.time_h, T_STAR, atol=5e-4)
    assert res.total_fuel_t == pytest.approx(FUEL_STAR, abs=5e-5)
    np.testing.assert_allclose(res.speed_kn, D / res.time_h)
    np.testing.assert_allclose(res.fuel_t, K * D**3 / res.time_h**2, rtol=1e-12)
    # the ETA dual is -dF/dT; for the cubic law F* ∝ T^-2, so -dF/dT = 2 F*/T
    assert res.eta_multiplier == pytest.approx(2.0 * FUEL_STAR / 100.0, rel=1e-5)


def test_powcone_and_power_give_the_same_optimum_with_mixed_terms_and_bounds() -> None:
    # a constant hourly term (p = 0), a per-mile term (p = 1), v^3 and v^-1: all convex in t
    fuel = PowerLawFuel(np.array([[2e-4, 0.3, 0.01, 5.0]] * 4) * np.array([[1.0], [1.4], [0.7], [1.1]]), [3, 0, 1, -1])
    kw = dict(eta_h=110.0, v_min_kn=[8, 8, 8, 12], v_max_kn=[18, 18, 14, 18])
    a = solve_speed_convex(D, fuel, formulation="powcone", **kw)
    b = solve_speed_convex(D, fuel, formulation="power", **kw)
    assert a.success and b.success
    assert a.objective == pytest.approx(b.objective, rel=1e-8)
    np.testing.assert_allclose(a.time_h, b.time_h, rtol=1e-5)
    assert a.total_fuel_t == pytest.approx(fuel.leg_fuel(D, a.time_h).sum(), rel=1e-12)
    assert (a.speed_kn <= np.array(kw["v_max_kn"]) + 1e-6).all()
    assert (a.speed_kn >= np.array(kw["v_min_kn"]) - 1e-6).all()


def test_objective_fuel_matches_a_brute_force_grid() -> None:
    # independent reference: two legs, scan the split of T on a fine grid
    d = np.array([250.0, 350.0])
    fuel = PowerLawFuel(np.array([[1e-3, 0.4], [2e-3, 0.4]]), [3.0, 0.0])
    res = solve_speed_convex(d, fuel, eta_h=50.0)
    t1 = np.linspace(5.0, 45.0, 400001)
    f = 1e-3 * d[0] ** 3 / t1**2 + 0.4 * t1 + 2e-3 * d[1] ** 3 / (50.0 - t1) ** 2 + 0.4 * (50.0 - t1)
    assert res.total_fuel_t == pytest.approx(f.min(), rel=1e-9)
    assert res.time_h[0] == pytest.approx(t1[np.argmin(f)], abs=2e-4)


def test_cost_objective_trades_fuel_against_time() -> None:
    # with no ETA, cost = price·k d³/t² + c·t per leg → t* = (2 price k d³ / c)^(1/3)
    d = np.array([300.0])
    k = 1e-3
    res = solve_speed_convex(d, PowerLawFuel.cubic([k]), objective="cost", fuel_price=500.0, hourly_cost=800.0)
    t_star = (2 * 500.0 * k * d[0] ** 3 / 800.0) ** (1 / 3)
    assert res.success
    assert res.time_h[0] == pytest.approx(t_star, rel=1e-4)
    cost = 500.0 * k * d[0] ** 3 / res.time_h[0] ** 2 + 800.0 * res.time_h[0]
    assert cost == pytest.approx(1.5 * 800.0 * t_star, rel=1e-9)
    assert res.eta_multiplier == 0.0


def test_time_objective_runs_every_leg_at_its_maximum_speed() -> None:
    res = solve_speed_convex(D, PowerLawFuel.cubic(K), objective="time", v_max_kn=[10, 12, 14, 16])
    np.testing.assert_allclose(res.speed_kn, [10, 12, 14, 16], rtol=1e-6)


def test_infeasible_eta_reports_the_solver_status_verbatim() -> None:
    res = solve_speed_convex(D, PowerLawFuel.cubic(K), eta_h=50.0, v_max_kn=20.0)
    assert not res.success
    assert res.status == "infeasible"
    assert res.solver_status == "PrimalInfeasible"
    assert np.isnan(res.time_h).all()


def test_eta_dual_is_the_derivative_of_the_optimum() -> None:
    fuel = PowerLawFuel(np.array([1e-3, 0.2]), [3.0, 0.0])
    cap = [20, 11, 20, 20]
    base = solve_speed_convex(D, fuel, eta_h=120.0, v_max_kn=cap)
    h = 1e-2
    up = solve_speed_convex(D, fuel, eta_h=120.0 + h, v_max_kn=cap)
    down = solve_speed_convex(D, fuel, eta_h=120.0 - h, v_max_kn=cap)
    fd = -(up.objective - down.objective) / (2 * h)
    assert base.eta_multiplier == pytest.approx(fd, rel=1e-4)
    # leg 1 runs at its 11 kn cap: its lower time bound binds, with a positive dual
    assert base.speed_kn[1] == pytest.approx(11.0, rel=1e-6)
    assert base.time_lower_dual[1] > 1e-3
    assert np.all(np.abs(base.time_lower_dual[[0, 2, 3]]) < 1e-6)


@pytest.mark.parametrize(
    ("coef", "exponent", "match"),
    [([1.0, 1.0], [0.5, 3.0], r"exponent\[0\] = 0.5"), ([1.0, -2.0], [3.0, 0.0], r"coef\[0, 1\] = -2")],
)
def test_non_convex_models_are_rejected_naming_the_coefficient(coef: list, exponent: list, match: str) -> None:
    with pytest.raises(NonConvexFuelModel, match=match):
        PowerLawFuel(coef, exponent)
    assert issubclass(NonConvexFuelModel, ValueError)


def test_bad_inputs_raise_formulation_input_error() -> None:
    with pytest.raises(FormulationInputError, match="positive"):
        solve_speed_convex([100.0, -1.0], PowerLawFuel.cubic([1e-3]), eta_h=10.0)
    with pytest.raises(FormulationInputError, match="objective"):
        solve_speed_convex([100.0], PowerLawFuel.cubic([1e-3]), eta_h=10.0, objective="speed")  # type: ignore[arg-type]
    with pytest.raises(FormulationInputError, match="NaN"):
        solve_speed_convex([100.0, np.nan], PowerLawFuel.cubic([1e-3]), eta_h=10.0)


@settings(max_examples=25, deadline=None)
@given(
    n=st.integers(2, 12),
    seed=st.integers(0, 2**31 - 1),
    slack=st.floats(1.05, 1.6),
)
# found by hypothesis: Clarabel stopped at AlmostSolved with the tight tolerances and with its own (before the retry
# with its linear systems refined further)
@example(n=12, seed=347, slack=1.15625)
def test_unbounded_optimum_is_the_cube_root_split(n: int, seed: int, slack: float) -> None:
    rng = np.random.default_rng(seed)
    d = rng.uniform(20.0, 400.0, n)
    k = rng.uniform(5e-4, 3e-3, n)
    eta = d.sum() / 15.0 * slack
    t = d * k ** (1 / 3)
    t *= eta / t.sum()
    res = solve_speed_convex(d, PowerLawFuel.cubic(k), eta_h=eta)
    assert res.success
    np.testing.assert_allclose(res.time_h, t, rtol=2e-4)
    best = np.sum(k * d**3 / t**2)  # the closed-form optimum: no feasible schedule burns less
    assert best * (1 - 1e-9) <= res.total_fuel_t <= best * (1 + 1e-6)  # Clarabel's tolerance, first order
