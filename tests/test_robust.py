"""Ensemble-robust plans (issue 16 item 3): the stacked NLP against a hand-worked two-member case, the referee's
CVaR against its tail-mean definition, and a robust plan against a plan made on the ensemble mean.

The hand-built ensemble ``THREE_STORMS`` has one stationary 8.7 m storm (below the Boeing bands' threshold,
4 % of the 250 m ship's length) 150 nm north of the track, on it, or 150 nm south; its mean is a 3–4 m sea.
With an ETA that asks about 25.2 kn of the container ship (MCR 36.5 MW) the plan made on the mean runs within
the MCR in the mean sea, and over it in the member whose storm sits on the track (the referee's power there,
37.5 MW, was measured by ``Plan.verify(weather=member)``), which the robust plan avoids.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st

import optroute as orx
from formulations.common import CorridorGeometry, PowerModel
from formulations.robust_nlp import RobustSpeedNLP
from formulations.weather_grid import WeatherGrid
from optroute.errors import ConfigError
from optroute.optimise.robust import cvar, member_datasets
from optroute.weather import storms

# --------------------------------------------------------------------------- the stacked NLP, hand-worked

# fuel rate = k V³ [t/h] exactly (constant SFOC 1e6 g/kWh, P = V³), as tests/test_formulations_nlp.py
K = 1e-3
CUBIC = PowerModel(calm_coef=[K], calm_exp=[3.0], mcr_kw=1e12, sfc_base_gpkwh=1e6, sfc_quad=(0.0, 0.0, 1.0))
D_NM, ETA_H, C_KN = 200.0, 20.0, 2.0


def _current(u_kn: float) -> WeatherGrid:
    return WeatherGrid(
        t_h=[0.0], s_nm=[0.0], y_nm=[0.0], hs_m=0.0, period_s=8.0, current_along_kn=u_kn, current_across_kn=0.0
    )


def _two_members(risk: str, alpha: float = 0.0) -> RobustSpeedNLP:
    return RobustSpeedNLP(
        CorridorGeometry.straight([D_NM]),
        [_current(+C_KN), _current(-C_KN)],
        CUBIC,
        risk=risk,  # type: ignore[arg-type]
        alpha=alpha,
        samples_per_leg=1,
        v_min_kn=5.0,
        v_max_kn=30.0,
    )


def _hand_worked() -> tuple[float, np.ndarray]:
    """One leg, members with a following and a head current of C: the head-current member must arrive by the
    ETA, so V* = D/T + C (fuel k V³ D/(V + u) rises with V for V > 1.5 C), and J_m = k V*³ D / (V* + u_m)."""
    v = D_NM / ETA_H + C_KN
    return v, np.array([K * v**3 * D_NM / (v + u) for u in (+C_KN, -C_KN)])


@pytest.mark.parametrize(("risk", "alpha"), [("mean", 0.0), ("cvar", 0.0), ("cvar", 0.5)])
def test_two_members_by_hand(risk: str, alpha: float) -> None:
    nlp = _two_members(risk, alpha)
    res = nlp.solve_sides(eta_h=ETA_H, offset0_nm=np.zeros(2), stw0_kn=np.array([12.0]))
    v, j = _hand_worked()
    assert res.success
    assert res.stw_kn[0] == pytest.approx(v, rel=1e-6)
    np.testing.assert_allclose(res.member_fuel_t, j, rtol=1e-6)
    np.testing.assert_allclose(res.time_h[:, -1], [D_NM / (v + C_KN), ETA_H], rtol=1e-6)  # the ETA holds in both
    # CVaR at α = 0 is the mean; at α = ½ of two equally likely members it is the worse one (module docstring)
    expected = j.mean() if alpha == 0.0 else j.max()
    assert res.objective == pytest.approx(expected, rel=1e-6)


def test_bad_formulation_inputs() -> None:
    from formulations.common import FormulationInputError

    with pytest.raises(FormulationInputError, match="alpha"):
        _two_members("cvar", 1.0)
    with pytest.raises(FormulationInputError, match="risk"):
        _two_members("worst")
    with pytest.raises(FormulationInputError, match="WeatherGrid"):
        RobustSpeedNLP(CorridorGeometry.straight([D_NM]), [], CUBIC)


# --------------------------------------------------------------------------- all but k members, against enumeration

#: Along-track currents [kn] of three one-leg members (following, slack, head) and the number that may be dropped.
DROP_CASES = [((2.0, 0.0, -3.0), 1), ((1.0, -2.5, -0.5), 1), ((3.0, -1.0, -4.0), 2)]


def _brute_force(currents: tuple[float, ...], k: int, v_min: float) -> tuple[float, float, set[int]]:
    """Every set of at most k members to drop, solved by hand: the kept members' ETA asks V ≥ D/T − u_m, the mean
    fuel (1/M) Σ_m K V³ D/(V + u_m) of all members rises with V there, so V is the least speed the kept members allow.
    Returns the best (objective, V, dropped members)."""
    best = (np.inf, np.nan, set())
    for size in range(k + 1):
        for drop in itertools.combinations(range(len(currents)), size):
            kept = [u for i, u in enumerate(currents) if i not in drop]
            v = max(v_min, max(D_NM / ETA_H - u for u in kept))
            j = float(np.mean([K * v**3 * D_NM / (v + u) for u in currents]))
            if j < best[0] - 1e-12:
                best = (j, v, set(drop))
    return best


@pytest.mark.parametrize(("currents", "k"), DROP_CASES)
def test_all_but_k_members_matches_enumeration(currents: tuple[float, ...], k: int) -> None:
    nlp = RobustSpeedNLP(
        CorridorGeometry.straight([D_NM]), [_current(u) for u in currents], CUBIC, samples_per_leg=1,
        v_min_kn=5.0, v_max_kn=30.0,
    )  # fmt: skip
    results = nlp.solve_chance(max_dropped=k, eta_h=ETA_H, offset0_nm=np.zeros(2), stw0_kn=np.array([12.0]))
    j, v, drop = _brute_force(currents, k, 5.0)
    best = results[0]
    assert best.success and len(results) == math.comb(len(currents), k)
    assert best.objective == pytest.approx(j, rel=1e-6)
    assert best.stw_kn[0] == pytest.approx(v, rel=1e-6)
    assert drop <= set(np.flatnonzero(best.dropped))  # the brute force's dropped members are among the NLP's
    kept_arrival = best.time_h[~best.dropped, -1]
    assert np.all(kept_arrival <= ETA_H + 1e-6)  # the ETA holds in every member kept


def test_drop_choices_are_bounded() -> None:
    from formulations.common import FormulationInputError

    nlp = _two_members("mean")
    with pytest.raises(FormulationInputError, match="max_dropped"):
        nlp.solve_chance(max_dropped=2, eta_h=ETA_H, offset0_nm=np.zeros(2), stw0_kn=np.array([12.0]))


# --------------------------------------------------------------------------- the referee's CVaR


@settings(max_examples=60, deadline=None)
@given(
    values=st.lists(st.floats(0.0, 1e3, allow_nan=False), min_size=1, max_size=12),
    worst=st.integers(1, 12),
)
def test_cvar_is_the_mean_of_the_worst_share(values: list[float], worst: int) -> None:
    # with (1 − α) M = w members exactly, CVaR_α is the mean of the w largest outcomes (Rockafellar & Uryasev 2000)
    v = np.asarray(values)
    w = min(worst, v.size)
    alpha = 1.0 - w / v.size
    assert cvar(v, alpha) == pytest.approx(np.sort(v)[::-1][:w].mean(), rel=1e-9, abs=1e-9)


def test_cvar_bad_inputs() -> None:
    with pytest.raises(ConfigError, match="cvar_alpha"):
        cvar([1.0, 2.0], 1.0)
    with pytest.raises(ConfigError, match="finite"):
        cvar([1.0, np.nan], 0.5)


# --------------------------------------------------------------------------- robust against ensemble-mean plans

SHIP = orx.Ship.preset("container_54k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")
ETA = T0 + np.timedelta64(372, "m")  # 6.2 h for 156 nm
OPTS = {"max_leg_nm": 30.0, "samples_per_leg": 3, "use_land_mask": False}


@pytest.fixture(scope="module")
def three_storms() -> xr.Dataset:
    """THREE_STORMS (module docstring): members 0, 1, 2 with the storm 2.5° north of, on, and 2.5° south of the track."""
    kw = {"start": T0, "duration_h": 12.0, "step_h": 3.0, "resolution_deg": 0.5, "background_hs_m": 1.5}
    members = []
    for dlat in (2.5, 0.0, -2.5):
        storm = storms.moving_storm_spec(30.0 + dlat, -148.5, 90.0, 0.5, peak_hs_m=8.7, radius_nm=40.0, duration_h=12.0)
        members.append(storms.storm_dataset([storm], bbox=(25, 35, -152, -145), **kw))
    ens = xr.concat(members, dim="member")
    ens.attrs = {k: v for k, v in members[0].attrs.items() if k != "storms"}
    return ens


@pytest.fixture(scope="module")
def corridor() -> orx.Corridor:
    return orx.Corridor.from_waypoints([(30.0, -150.0), (30.0, -147.0)], width_nm=0.0)


@pytest.fixture(scope="module")
def plans(three_storms: xr.Dataset, corridor: orx.Corridor) -> dict[str, orx.Plan]:
    mean = three_storms.mean("member")
    mean.attrs = dict(three_storms.attrs)
    on_mean = orx.optimise_corridor(corridor, mean, SHIP, departure=T0, eta=ETA, **OPTS)
    robust = orx.optimise_corridor(corridor, three_storms, SHIP, departure=T0, eta=ETA, robust="all", **OPTS)
    return {"ensemble mean": on_mean, "robust": robust}


def test_robust_plan_verifies_in_every_member_and_the_mean_plan_does_not(
    plans: dict[str, orx.Plan], three_storms: xr.Dataset
) -> None:
    members = member_datasets(three_storms)
    robust, on_mean = plans["robust"], plans["ensemble mean"]
    assert robust.status in ("optimal", "sides_unsettled", "feasible")
    for m in members:
        assert robust.verify(weather=m) == []
    assert on_mean.verify() == []  # clean in the weather it was planned in
    found = on_mean.verify(weather=members[1])  # the storm on the track
    assert found and {v.kind for v in found} == {"power_above_mcr"}
    assert on_mean.verify(weather=members[0]) == [] and on_mean.verify(weather=members[2]) == []
    # the robust plan slows in the storm's member where the mean plan breaks the MCR: it takes longer over each of
    # those legs (compared by longitude on the fixed path along 30 deg N: the robust plan's legs are cut where a band
    # can bind in some member, the mean plan's where one can in the mean, band_leg_nm)
    for k in sorted({v.leg for v in found}):
        lon_ab = on_mean.waypoints[[k, k + 1], 1]
        hours = {
            name: np.diff(np.interp(lon_ab, p.waypoints[:, 1], (p.times - T0) / np.timedelta64(1, "s")))[0]
            for name, p in plans.items()
        }
        assert hours["robust"] > hours["ensemble mean"]
    stats = robust.solver_stats["robust"]
    assert stats["members"] == 3 and len(stats["member_fuel_t"]) == 3
    assert stats["fuel_mean_t"] == pytest.approx(np.mean(stats["member_fuel_t"]))


def test_member_violations_report(plans: dict[str, orx.Plan], three_storms: xr.Dataset) -> None:
    table = orx.member_violations(plans, three_storms)
    assert table.loc["ensemble mean", "members_violated"] == 1
    assert table.loc["ensemble mean", "violated_members"] == "1"
    assert table.loc["ensemble mean", "kinds"] == "power_above_mcr"
    assert table.loc["robust", "members_violated"] == 0
    sailed = [plans["robust"].in_weather(m).total_fuel_t for m in member_datasets(three_storms)]
    assert table.loc["robust", "fuel_mean_t"] == pytest.approx(np.mean(sailed))
    assert table.loc["robust", "fuel_max_t"] == pytest.approx(max(sailed))


def test_chance_plan_keeps_all_but_one_member(
    plans: dict[str, orx.Plan], three_storms: xr.Dataset, corridor: orx.Corridor
) -> None:
    # a third of three members: one may be violated; the plan claims the other two and is clean in them
    plan = orx.optimise_corridor(
        corridor, three_storms, SHIP, departure=T0, eta=ETA, robust="chance", violation_fraction=0.34, **OPTS
    )
    stats = plan.solver_stats["robust"]
    assert len(stats["dropped_members"]) == 1 and stats["drop_choices_solved"] == 3
    assert set(stats["members_violated"]) <= set(stats["dropped_members"])
    for k, m in enumerate(member_datasets(three_storms)):
        assert (plan.verify(weather=m) != []) == (k in stats["members_violated"])
    # dropping a member only relaxes the problem: no worse than the plan kept clean in all three
    assert stats["nlp_objective"] <= plans["robust"].solver_stats["robust"]["nlp_objective"] * (1 + 1e-6)
    table = orx.member_violations({"chance": plan}, three_storms)
    assert table.loc["chance", "members_violated"] == len(stats["members_violated"])


# --------------------------------------------------------------------------- bad inputs


def test_ensemble_without_robust_names_the_fix(three_storms: xr.Dataset, corridor: orx.Corridor) -> None:
    with pytest.raises(ConfigError, match=r"3 ensemble members.*pick one member.*robust='all'"):
        orx.optimise_corridor(corridor, three_storms, SHIP, departure=T0, eta=ETA)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"robust": "worst"}, "robust='worst' is not known"),
        ({"robust": "chance"}, r"violation_fraction=0.0 must be in \(0, 1\)"),
        ({"robust": "all", "violation_fraction": 0.3}, "only used with robust='chance'"),
        ({"robust": "cvar", "cvar_alpha": 1.0}, r"cvar_alpha=1.0 must be in \[0, 1\)"),
        ({"robust": "all", "cvar_alpha": 0.5}, "only used with robust='cvar'"),
        ({"robust": "all", "eta_mode": "eq"}, "eta_mode='eq'"),
        ({"robust": "all", "jit": True}, "jit is not available"),
        ({"robust": "all", "constraint_rows": "everywhere"}, "constraint_rows='everywhere' is not known"),
    ],
)
def test_bad_robust_options(three_storms: xr.Dataset, corridor: orx.Corridor, kwargs: dict, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        orx.optimise_corridor(corridor, three_storms, SHIP, departure=T0, eta=ETA, **kwargs)


def test_robust_needs_an_ensemble(three_storms: xr.Dataset, corridor: orx.Corridor) -> None:
    one = three_storms.isel(member=0)
    with pytest.raises(ConfigError, match="'member' dimension"):
        orx.optimise_corridor(corridor, one, SHIP, departure=T0, eta=ETA, robust="all")


def test_verify_in_an_ensemble_asks_for_a_member(plans: dict[str, orx.Plan], three_storms: xr.Dataset) -> None:
    with pytest.raises(ConfigError, match=r"pick a member"):
        plans["robust"].verify(weather=three_storms)
    with pytest.raises(ConfigError, match="no plans"):
        orx.member_violations({}, three_storms)
    with pytest.raises(ConfigError, match="not optroute Plans"):
        orx.member_violations({"x": 1}, three_storms)  # type: ignore[dict-item]


# --------------------------------------------------------------------------- derivatives against CasADi's own


def _member_weather(scale: float, shift_kn: float) -> WeatherGrid:
    """A small time-varying sea with waves, current and a power table; members differ in height and current."""
    tg, sg, yg = np.arange(0.0, 48.0, 8.0), np.linspace(0.0, 160.0, 5), np.linspace(-30.0, 30.0, 4)
    tt, ss, yy = np.meshgrid(tg, sg, yg, indexing="ij")
    hs = scale * (2.0 + 3.0 * np.exp(-(((ss - 80 - 2 * tt) / 60) ** 2 + ((yy - 5) / 20) ** 2)))
    th = np.radians(20 + tt + ss / 10)
    return WeatherGrid(
        t_h=tg, s_nm=sg, y_nm=yg, hs_m=hs, period_s=4.5 * np.sqrt(hs) + 1, wave_to_along=np.cos(th),
        wave_to_across=np.sin(th), current_along_kn=shift_kn + 1.5 * np.sin(ss / 50),
        current_across_kn=2.0 * np.cos(tt / 10),
        power_ratio=1.0 + 0.02 * hs[..., None, None] ** 2 * (1.0 + 0.01 * np.array([8.0, 16.0])[:, None])
        * (0.8 + 0.2 * np.cos(np.radians(np.array([-30.0, 30.0])) + th[..., None, None])),
        ratio_speed_kn=[8.0, 16.0], ratio_heading_deg=[-30.0, 30.0],
    )  # fmt: skip


@pytest.mark.parametrize("risk", ["mean", "cvar"])
def test_member_derivatives_equal_casadi_automatic_differentiation(risk: str) -> None:
    """The robust NLP's gradient, Jacobian and Hessian (the single-weather leg cores per member, scattered) equal
    CasADi's automatic derivatives of each member's whole single-weather model (``SpeedNLP(structured=False)``),
    stacked by hand: mean objective ``(1/M) Σ J_m``, member-major rows, ``∇²L = Σ_m ∇²L_m``; CVaR rows
    ``u_m − J_m + z``."""
    from formulations.common import Band
    from formulations.speed_nlp import SpeedNLP

    cor = CorridorGeometry.straight([40.0] * 4, half_width_nm=25.0)
    weathers = [_member_weather(1.0, 0.0), _member_weather(1.4, -2.0)]
    pw = PowerModel(calm_coef=[2.2], calm_exp=[3.0], mcr_kw=36000, min_load=0.1)
    bands = (Band("te_over_tr", 0.8, 1.2, param=20.0, hs_min_m=3.0),)
    kw = {"bands": bands, "samples_per_leg": 2, "v_min_kn": 6.0, "v_max_kn": 24.0}
    nlp = RobustSpeedNLP(cor, weathers, pw, risk=risk, alpha=0.3, weather_curvature=True, **kw)  # type: ignore[arg-type]
    auto = [SpeedNLP(cor, w, pw, structured=False, **kw) for w in weathers]  # type: ignore[arg-type]
    n, mm, ngm, kb = 4, 2, auto[0]._ng, 4 * 2
    rng = np.random.default_rng(5)
    yv = np.concatenate([[0.0], rng.uniform(-15, 15, n - 1), [0.0], rng.uniform(10, 18, n)])  # one plan
    xm = [np.concatenate([yv, np.linspace(0, 20 + 3 * k, n + 1)]) for k in range(mm)]  # each member's times
    x = np.concatenate([yv, xm[0][2 * n + 1 :], xm[1][2 * n + 1 :]])
    if risk == "cvar":
        x = np.concatenate([x, [0.4], rng.uniform(0, 1, mm)])
    betas = [rng.uniform(0.5, 1.5, kb) for _ in range(mm)]
    fac = rng.uniform(0.8, 1.2, n)
    p = np.concatenate([[1.3, 0.7], *betas, fac])
    pm = [np.concatenate([[1.3, 0.7], b, fac]) for b in betas]
    lam_g, lam_f = rng.normal(size=nlp._ng), 0.8
    fn = {k: nlp._solver.get_function(k) for k in ("nlp_grad_f", "nlp_jac_g", "nlp_hess_l")}
    ref = [{k: s._solver.get_function(k) for k in fn} for s in auto]
    col = [np.concatenate([np.arange(2 * n + 1), 2 * n + 1 + k * (n + 1) + np.arange(n + 1)]) for k in range(mm)]
    j_m = [float(ref[k]["nlp_grad_f"](xm[k], pm[k])[0]) for k in range(mm)]
    grad_m = [np.asarray(ref[k]["nlp_grad_f"](xm[k], pm[k])[1]).ravel() for k in range(mm)]
    jac = np.zeros((nlp._ng, x.size))
    grad = np.zeros(x.size)
    hess = np.zeros((x.size, x.size))
    for k in range(mm):
        jk = np.asarray(ref[k]["nlp_jac_g"](xm[k], pm[k])[1].full())
        jac[np.ix_(k * ngm + np.arange(ngm), col[k])] = jk
        weight = lam_f / mm if risk == "mean" else -lam_g[mm * ngm + k]  # the CVaR rows' multipliers weight J_m
        hk = np.asarray(ref[k]["nlp_hess_l"](xm[k], pm[k], weight, lam_g[k * ngm : (k + 1) * ngm]).full())
        hess[np.ix_(col[k], col[k])] += hk
        if risk == "mean":
            grad[col[k]] += grad_m[k] / mm
        else:
            jac[mm * ngm + k, col[k]] = -grad_m[k]
            jac[mm * ngm + k, x.size - mm + k] = jac[mm * ngm + k, x.size - 1 - mm] = 1.0
    if risk == "cvar":
        grad[x.size - 1 - mm], grad[x.size - mm :] = 1.0, 1.0 / ((1 - 0.3) * mm)
        g_cvar = np.asarray(fn["nlp_jac_g"](x, p)[0]).ravel()[mm * ngm :]
        np.testing.assert_allclose(g_cvar, x[x.size - mm :] - np.array(j_m) + x[x.size - 1 - mm], rtol=1e-10)
    np.testing.assert_allclose(np.asarray(fn["nlp_grad_f"](x, p)[1]).ravel(), grad, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(np.asarray(fn["nlp_jac_g"](x, p)[1].full()), jac, rtol=1e-9, atol=1e-12)
    mine = np.asarray(fn["nlp_hess_l"](x, p, lam_f, lam_g).full())
    np.testing.assert_allclose(mine, np.triu(hess), rtol=1e-8, atol=1e-10 * np.abs(hess).max())


def test_referee_rows_plan_verifies_in_every_member(three_storms: xr.Dataset, corridor: orx.Corridor) -> None:
    """``constraint_rows="referee"``: row-only samples at every member's referee check points (more samples a leg
    than the quadrature's 3); the plan is still clean in every member by the referee."""
    plan = orx.optimise_corridor(
        corridor, three_storms, SHIP, departure=T0, eta=ETA, robust="all", constraint_rows="referee", **OPTS
    )
    for m in member_datasets(three_storms):
        assert plan.verify(weather=m) == []
    # the waypoint times are sums of the legs' durations rounded to nanoseconds (measured 15 ns over on 18 legs)
    assert plan.arrival <= ETA + np.timedelta64(1, "us")
    assert plan.solver_stats["nlp_samples_per_leg"] > OPTS["samples_per_leg"]
