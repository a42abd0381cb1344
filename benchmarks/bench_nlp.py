"""Corridor-NLP benchmark: solve time, scaling with the number of legs, band-heuristic quality.

1. A 500-leg, 5 000 nm corridor (gently curving centreline, ±40 nm lateral freedom) through
   time-varying weather: six storms drifting along and across it, wave directions that veer with
   time and distance, a weak current, two danger bands (synchronous roll T_E/T_R with T_R = 20 s
   and surf-riding V cos χ / c, both ±20 %, applied where Hs ≥ 4 m), fuel objective with an ETA
   15 % above the 15 kn passage. Timed side by side in the same run: the median Ipopt solve with
   the leg-by-leg structured derivatives (interpreted, and compiled with ``jit=True``) and with
   CasADi's automatic derivatives of the same model; beside them the fuel of the same corridor at
   constant speed on the centreline and of the NLP restricted to the centreline (what the
   lateral freedom and the speed profile are worth).
2. Scaling: the same corridor cut into 250 … 5 000 legs; median solve time against N and the
   exponent of the least-squares fit ``time ∝ N^p``.
   §1–2 time one ``SpeedNLP.solve`` (2 samples per leg, one Ipopt call), not a user's call;
2b. the whole ``optroute.optimise_corridor`` call (starts, every solve at 3 samples per leg, verification) on
   §4's great circle at a few leg counts, ``jit=False`` against ``jit=True`` alternated, build and Ipopt
   time beside it (:mod:`benchmarks._nlp_call`).
3. Band heuristic quality on small fixed-path instances (4–6 legs, one forbidden speed
   interval of ±20 % per leg, a constant-speed start from the "search"): the share of instances
   where side selection + flip search reaches the exact optimum (exhaustive enumeration with the
   convex solver; Bonmin big-M on a subset as a second exact reference) and the worst gap; and the
   same loop with the NLP as the inner solver on the same instances.

4. The same comparison at the domain level, beside the 3-D DP: a 2 477 nm great circle at 30° N
   (170° W → 122° W, ±40 nm) through a 13 m storm moving south-east at 12 kn across it
   (:func:`optroute.scenarios.moving_storm`), the container ship, least fuel by an ETA at 18 kn.
   ``orx.optimise_corridor`` with ``max_leg_nm`` giving 496 legs (median of a few calls: the whole
   call, and its Ipopt solves alone) and, on the same great circle, half-width and ETA,
   ``orx.search_route(method="dp")`` at three resolutions (coarse/medium/fine ΔX, ΔY, Δt and speed
   step), each with its run time and fuel as ratios to the NLP's, the ETA met and ``verify()``.
   Beside the table: each DP route re-evaluated by the plan evaluator that referees the NLP (the
   DP's own fuel sums 30 nm pieces), the NLP's status, its Ipopt iterations and the tabulation error
   at its solution (the NLP optimises the ship's model tabulated on its weather grid,
   :mod:`optroute.optimise.power_table`). No band applies on this route (see ``BAND_FRACTION``).
   Full mode (or ``--crossing`` alone) adds a storm crossing a 730 nm track (:func:`bench_crossing_storm`),
   where the NLP on the old fitted model (error up to ~65 %) lost to the DP by 8 %: the NLP from the
   centreline, the NLP started from the 3-D DP, and the DP side by side, fuel by the referee, time,
   Ipopt solves and iterations.

Run ``python -m benchmarks.bench_nlp [--quick | --crossing | --jit]`` (quick: one repeat, 125–500 legs for the scaling,
62 legs and the coarse DP; ``--jit``: §2b's whole call at ~100 and ~300 legs, ``jit=False`` against ``jit=True``
alternated twice after a warm-up of each, the compile time apart — about an hour on a loaded 2-core machine;
``--scaling [--baseline REF] [--full] [--sizes N …]``: the whole call at 21, 125 and 500 legs (``--full``: also 2 000
and 5 000), each in a fresh process, CPU and wall seconds, against the commit ``REF``, :mod:`benchmarks._nlp_scaling`).
"""

from __future__ import annotations

import dataclasses
import os
import statistics
import time
from typing import Any

import numpy as np

from benchmarks._cli import bench_main
from benchmarks._nlp_call import jit_whole_call, print_whole_call, whole_call
from formulations.common import (
    G_OVER_2PI_KN_S,
    Band,
    CorridorGeometry,
    PowerLawFuel,
    PowerModel,
)
from formulations.disjunctive import (
    bonmin_fixed_path,
    convex_band_solver,
    enumerate_sides,
    improve_sides,
    nlp_band_solver,
    nlp_groups,
    select_sides,
)
from formulations.speed_nlp import SpeedNLP
from formulations.weather_grid import WeatherGrid

LENGTH_NM = 5000.0
SPEED_KN = 15.0
ETA_SLACK = 1.15
TR_S = 18.0


def corridor_case(
    n_legs: int, seed: int = 0
) -> tuple[CorridorGeometry, WeatherGrid, PowerModel, tuple[Band, ...], float]:
    """The synthetic 5 000 nm corridor cut into ``n_legs`` legs (see the module docstring)."""
    rng = np.random.default_rng(seed)
    leg = LENGTH_NM / n_legs
    s = np.arange(n_legs + 1) * leg
    heading = np.radians(60 + 20 * np.sin(2 * np.pi * s / LENGTH_NM))
    steps = np.column_stack([np.sin(heading[:-1]), np.cos(heading[:-1])]) * leg
    cor = CorridorGeometry(centre_xy_nm=np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)]), half_width_nm=40.0)
    eta = LENGTH_NM / SPEED_KN * ETA_SLACK
    tg, sg, yg = np.arange(0.0, 1.6 * eta, 6.0), np.linspace(0, cor.s_nm[-1], 101), np.linspace(-60, 60, 7)
    tt, ss, yy = np.meshgrid(tg, sg, yg, indexing="ij")
    hs = np.full(tt.shape, 2.0)
    for _ in range(6):
        s0, y0, drift, amp = rng.uniform(0, LENGTH_NM), rng.uniform(-60, 60), rng.uniform(-15, 15), rng.uniform(2, 5)
        hs += amp * np.exp(-(((ss - s0 - drift * tt) / 300) ** 2 + ((yy - y0) / 60) ** 2))
    veer = np.radians(30 + 0.2 * tt + 0.005 * ss)
    wx = WeatherGrid(
        t_h=tg,
        s_nm=sg,
        y_nm=yg,
        hs_m=hs,
        period_s=4.5 * np.sqrt(hs) + 1.0,
        wave_to_along=np.cos(veer),
        wave_to_across=np.sin(veer),
        current_along_kn=0.5 * np.sin(ss / 400 + tt / 50),
        current_across_kn=0.3 * np.cos(ss / 300),
    )
    # 36 MW container ship: 85 % MCR at 24 kn (physics.md §8), Kwon-type added power tabulated on the grid at five
    # headings ψ relative to the centreline: R = 1 + 0.02 Hs² (0.6 + 0.4 cos α), cos α = −cos(veer − ψ)
    psi = np.radians(np.array([-30.0, -15.0, 0.0, 15.0, 30.0]))
    cos_a = -np.cos(veer[..., None] - psi)
    ratio = 1.0 + 0.02 * hs[..., None] ** 2 * (0.6 + 0.4 * cos_a)
    wx = dataclasses.replace(
        wx, power_ratio=ratio[..., None, :], ratio_speed_kn=[15.0], ratio_heading_deg=np.degrees(psi)
    )
    power = PowerModel(calm_coef=[2.2], calm_exp=[3.0], mcr_kw=36000, min_load=0.1)
    bands = (
        Band("te_over_tr", 0.8, 1.2, param=TR_S, hs_min_m=4.0, name="synchronous roll"),
        Band("v_over_c", 0.8, 1.2, hs_min_m=4.0, name="surf-riding"),
    )
    return cor, wx, power, bands, eta


def _median_solve(nlp: SpeedNLP, eta: float, repeat: int, **kw: Any) -> tuple[float, Any]:
    times, res = [], None
    for _ in range(repeat):
        res = nlp.solve(eta_h=eta, **kw)
        times.append(res.solve_time_s)
    return statistics.median(times), res


def _constant_speed_fuel(nlp: SpeedNLP, eta: float) -> float:
    """Fuel [t] of the centreline at the constant speed through water that arrives at the ETA."""
    n = nlp.n_legs
    y = np.zeros(n + 1)
    lo, hi = 1.0, 30.0
    for _ in range(60):  # bisection on the speed for the arrival time
        v = 0.5 * (lo + hi)
        t = nlp.consistent_times(y, np.full(n, v), iterations=4)
        lo, hi = (v, hi) if t[-1] > eta else (lo, v)
    st = nlp.evaluate(y, np.full(n, hi), nlp.consistent_times(y, np.full(n, hi), iterations=4))
    ds = np.diff(nlp.corridor.s_nm)[:, None] / nlp.samples_per_leg
    return float(np.sum(st.fuel_rate_tph * ds / st.sog_kn))


def bench_500(quick: bool) -> dict[str, Any]:
    cor, wx, pw, bands, eta = corridor_case(500)
    repeat = 1 if quick else 7
    rows = []
    for label, kw in (
        ("structured derivatives", {}),
        ("structured, jit=True", {"jit": True}),
        ("CasADi automatic derivatives", {"structured": False}),
    ):
        if quick and "jit" in label:  # a cold compiler cache takes longer than the quick run's whole budget
            continue
        t0 = time.perf_counter()
        nlp = SpeedNLP(cor, wx, pw, bands=bands, v_min_kn=5, v_max_kn=24, **kw)
        build = time.perf_counter() - t0
        med, res = _median_solve(nlp, eta, 1 if (quick and "automatic" in label) else repeat)
        rows.append(
            {
                "method": label,
                "build_s": build,
                "median_solve_s": med,
                "iterations": res.iterations,
                "status": res.status,
                "fuel_t": res.total_fuel_t,
                "max_violation": res.max_violation,
            }
        )
    base = rows[0]["median_solve_s"]
    for r in rows:
        r["ratio_vs_structured"] = r["median_solve_s"] / base
    nlp = SpeedNLP(cor, wx, pw, bands=bands, v_min_kn=5, v_max_kn=24)
    fixed = nlp.solve(eta_h=eta, fix_offsets=True)
    free = nlp.solve(eta_h=eta)
    const = _constant_speed_fuel(nlp, eta)
    no_bands = SpeedNLP(cor, wx, pw, v_min_kn=5, v_max_kn=24).solve(eta_h=eta, fix_offsets=True)
    outer = None
    if not quick:  # the side-flip outer loop at full size: single flips, a budget of solves
        res = improve_sides(
            nlp_band_solver(nlp, eta_h=eta),
            free.sides,
            free.applies,
            groups=nlp_groups(free.sides.shape),
            pairs=False,
            max_solves=12,
        )
        outer = {
            "solves": res.n_solves,
            "time_s": res.solve_time_s,
            "start_t": free.total_fuel_t,
            "best_t": res.objective,
        }
    return {
        "legs": 500,
        "samples": 500 * nlp.samples_per_leg,
        "variables": 3 * 500 + 2,
        "constraints": nlp._ng,
        "eta_h": eta,
        "rows": rows,
        "constant_speed_centreline_fuel_t": const,
        "nlp_centreline_fuel_t": fixed.total_fuel_t,
        "nlp_centreline_no_bands_fuel_t": no_bands.total_fuel_t,
        "nlp_corridor_fuel_t": free.total_fuel_t,
        "eta_multiplier_t_per_h": free.eta_multiplier,
        "band_active_samples": int(free.band_active.sum()),
        "band_applicable_samples": int(free.applies.sum()),
        "outer_loop": outer,
    }


def bench_scaling(quick: bool, known: dict[str, Any] | None = None) -> dict[str, Any]:
    sizes = [125, 250, 500] if quick else [250, 500, 1000, 2000, 5000]
    rows = []
    for n in sizes:
        if known is not None and n == known["legs"]:  # the 500-leg case was just timed
            rows.append(known)
            continue
        cor, wx, pw, bands, eta = corridor_case(n)
        t0 = time.perf_counter()
        nlp = SpeedNLP(cor, wx, pw, bands=bands, v_min_kn=5, v_max_kn=24)
        build = time.perf_counter() - t0
        med, res = _median_solve(nlp, eta, 1 if quick or n >= 2000 else 3)
        rows.append(
            {"legs": n, "build_s": build, "median_solve_s": med, "iterations": res.iterations, "status": res.status}
        )
    n_arr = np.array([r["legs"] for r in rows], dtype=float)
    t_arr = np.array([r["median_solve_s"] for r in rows])
    it_arr = np.array([r["iterations"] for r in rows], dtype=float)
    exponent = float(np.polyfit(np.log(n_arr), np.log(t_arr), 1)[0])
    per_iter = float(np.polyfit(np.log(n_arr), np.log(t_arr / it_arr), 1)[0])
    return {"rows": rows, "exponent": exponent, "exponent_per_iteration": per_iter}


def _instance(seed: int) -> tuple[np.ndarray, PowerLawFuel, np.ndarray, float]:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(4, 7))
    d = rng.uniform(100, 400, n)
    k = rng.uniform(0.5e-3, 2e-3, n)
    eta = d.sum() / rng.uniform(12, 16)
    c = rng.uniform(11, 17, n)
    return d, PowerLawFuel.cubic(k), np.column_stack([0.8 * c, 1.2 * c]), float(eta)


def _nlp_for(d: np.ndarray, fuel: PowerLawFuel, forb: np.ndarray) -> SpeedNLP:
    """The fixed-path instance as a corridor NLP with the band v cos χ / c (following sea)."""
    s = np.concatenate([[0.0], np.cumsum(d)])
    eps = 1e-3 * d.min()
    nodes = np.ravel([[s[i] + eps, s[i + 1] - eps] for i in range(d.size)])
    nodes[0], nodes[-1] = s[0], s[-1]
    period = np.repeat(forb[:, 0] / 0.8 / G_OVER_2PI_KN_S, 2)[None, :, None]
    wx = WeatherGrid(
        t_h=[0.0],
        s_nm=nodes,
        y_nm=[0.0],
        hs_m=5.0,
        period_s=period,
        wave_to_along=1.0,
        wave_to_across=0.0,
        method="linear",
    )
    pw = PowerModel(calm_coef=[1.0], calm_exp=[3.0], mcr_kw=1e12, sfc_base_gpkwh=1e6, sfc_quad=(0.0, 0.0, 1.0))
    band = Band("v_over_c", 0.8, 1.2, hs_min_m=1.0)
    return SpeedNLP(
        CorridorGeometry.straight(d), wx, pw, bands=[band], v_min_kn=6, v_max_kn=22, leg_power_factor=fuel.coef[:, 0]
    )


def bench_heuristic(quick: bool) -> dict[str, Any]:
    n_inst = 8 if quick else 200
    n_bonmin = 2 if quick else 30
    n_nlp = 2 if quick else 40
    gaps, nlp_gaps, solves, bonmin_agree, infeasible = [], [], [], 0, 0
    t_heur = t_exact = 0.0
    for seed in range(n_inst):
        d, fuel, forb, eta = _instance(seed)
        solve = convex_band_solver(d, fuel, forb, eta_h=eta, v_min_kn=6, v_max_kn=22)
        v0 = np.full((d.size, 1), d.sum() / eta)
        s0, a0 = select_sides(v0, forb[:, None, 0], forb[:, None, 1]), np.ones((d.size, 1), dtype=bool)
        heur = improve_sides(solve, s0, a0)
        exact = enumerate_sides(solve, s0, a0)
        t_heur += heur.solve_time_s
        t_exact += exact.solve_time_s
        solves.append(heur.n_solves)
        if not exact.feasible:
            infeasible += 1
            continue
        gaps.append((heur.objective - exact.objective) / exact.objective if heur.feasible else np.inf)
        if seed < n_bonmin:
            bon = bonmin_fixed_path(d, fuel, forb, eta_h=eta, v_min_kn=6, v_max_kn=22)
            bonmin_agree += bool(bon.success and abs(bon.objective - exact.objective) <= 1e-5 * exact.objective)
        if seed < n_nlp:
            nlp = _nlp_for(d, fuel, forb)
            v = np.full(d.size, d.sum() / eta)
            st = nlp.evaluate(np.zeros(d.size + 1), v, nlp.consistent_times(np.zeros(d.size + 1), v))
            sides, applies = nlp.default_sides(st)
            res = improve_sides(nlp_band_solver(nlp, eta_h=eta), sides, applies, groups=nlp_groups(sides.shape))
            nlp_gaps.append((res.objective - exact.objective) / exact.objective if res.feasible else np.inf)
    g, ng = np.array(gaps), np.array(nlp_gaps)
    return {
        "instances": len(gaps),
        "share_exact": float(np.mean(g <= 1e-6)),
        "worst_gap": float(g.max()),
        "mean_gap": float(g[np.isfinite(g)].mean()),
        "mean_inner_solves": float(np.mean(solves)),
        "heuristic_time_s": t_heur,
        "enumeration_time_s": t_exact,
        "bonmin_checked": min(n_bonmin, len(gaps)),
        "bonmin_agrees": bonmin_agree,
        "nlp_instances": len(ng),
        "nlp_share_exact": float(np.mean(ng <= 1e-6)) if ng.size else float("nan"),
        "nlp_worst_gap": float(ng.max()) if ng.size else float("nan"),
        "no_feasible_side_choice": infeasible,
    }


DP_START, DP_END = (30.0, -170.0), (30.0, -122.0)
DP_T0 = np.datetime64("2024-01-10T00:00", "ns")
STORM_LAT = 34.0
# the patent's 0.04 L (10 m): the route meets only the storm's edge (Hs <= 4.5 m), so no band applies. With the
# threshold lowered into that sea (0.016 L = 4 m) the corridor NLP fails (Ipopt, also for minimum time), and at
# 0.0175 L the coarse DP finds no passage with 8-26 kn: the band-active comparison is left open; BAND_FRACTION is
# the knob that reproduces it
BAND_FRACTION = 0.04


def bench_dp(quick: bool) -> dict[str, Any]:
    """The corridor NLP against the 3-D DP on one great circle, time-varying weather (item 4 above)."""
    import optroute as orx
    from optroute import geodesy as geo

    ship = orx.Ship.preset("container_54k_dwt")
    rules = orx.BandRules(hs_threshold_fraction=BAND_FRACTION)
    wx = orx.scenarios.moving_storm(
        STORM_LAT,
        -160.0,
        120.0,
        12.0,
        peak_hs_m=13.0,
        radius_nm=250.0,
        start=DP_T0,
        duration_h=240.0,
        step_h=3.0,
        resolution_deg=0.5,
        bbox=(15, 45, -178, -115),
    )
    length = float(geo.distance_nm(*DP_START, *DP_END))
    eta_h = round(length / 18.0)
    eta = DP_T0 + np.timedelta64(int(eta_h), "h")
    half_width = 40.0
    corridor = orx.Corridor.from_waypoints([DP_START, DP_END], width_nm=2 * half_width)
    max_leg = 40.0 if quick else 5.0
    totals, solves, plans = [], [], []
    for _ in range(1 if quick else 3):
        t0 = time.perf_counter()
        plans.append(
            orx.optimise_corridor(corridor, wx, ship, departure=DP_T0, eta=eta, max_leg_nm=max_leg, rules=rules)
        )
        totals.append(time.perf_counter() - t0)
        solves.append(plans[-1].solver_stats["solve_time_s"])
    plan = plans[-1]
    legs = plan.legs
    margins = legs[[c for c in legs.columns if c.startswith("margin_")]].to_numpy()
    nlp = {
        "legs": int(plan.solver_stats["n_legs"]),
        "median_total_s": statistics.median(totals),
        "median_ipopt_s": statistics.median(solves),
        "nlp_solves": plan.solver_stats["nlp_solves"],
        "iterations": plan.solver_stats["iterations"],
        "status": plan.status,
        "tabulation_rel_error": (plan.solver_stats.get("tabulation") or {}).get("rel_error", float("nan")),
        "fuel_t": plan.total_fuel_t,
        "duration_h": plan.duration_h,
        "violations": len(plan.verify()),
        "legs_with_a_band": int(np.isfinite(margins).any(axis=1).sum()),
        "max_hs_m": float(legs["hs_m"].max()),
    }
    resolutions = [("coarse", 250.0, 20.0, 2.0, 1.0)]
    if not quick:
        resolutions += [("medium", 125.0, 10.0, 1.0, 0.5), ("fine", 100.0, 8.0, 0.5, 0.5)]
    rows = []
    for label, dx, dy, dt, dv in resolutions:
        t0 = time.perf_counter()
        route = orx.search_route(
            DP_START,
            DP_END,
            wx,
            ship,
            departure=DP_T0,
            method="dp",
            objective="fuel",
            eta=eta,
            rules=rules,
            speeds_kn=np.arange(8.0, 26.0 + 1e-9, dv),
            dp_options={"dx_nm": dx, "dy_nm": dy, "half_width_nm": half_width, "dt_h": dt},
        )
        el = time.perf_counter() - t0
        rows.append(_dp_row(route, label, (dx, dy, dt, dv), el, nlp, eta_h, ship, wx, rules))
    return {
        "length_nm": length,
        "eta_h": float(eta_h),
        "half_width_nm": half_width,
        "nlp": nlp,
        "dp": rows,
        "crossing": None if quick else bench_crossing_storm(),
    }


def _dp_row(
    route: Any,
    label: str,
    res: tuple[float, float, float, float],
    el: float,
    nlp: dict[str, Any],
    eta_h: float,
    ship: Any,
    wx: Any,
    rules: Any,
) -> dict[str, Any]:
    """One DP row: its own fuel and its route re-evaluated by the plan evaluator (the NLP's referee), as ratios."""
    import optroute as orx

    t0 = route.times[0]
    arrival_h = float((route.arrival - t0) / np.timedelta64(1, "s")) / 3600.0
    as_plan = orx.Plan.from_schedule(
        route.waypoints, route.stw_kn, departure=t0, ship=ship, weather=wx, rules=rules, times=route.times, step_nm=5.0
    )
    dx, dy, dt, dv = res
    return {
        "resolution": label,
        "dx_nm": dx,
        "dy_nm": dy,
        "dt_h": dt,
        "speed_step_kn": dv,
        "time_s": el,
        "fuel_t": route.total_fuel_t,
        "arrival_h": arrival_h,
        "eta_met": arrival_h <= eta_h + 1e-9,
        "time_ratio": el / nlp["median_total_s"],
        "fuel_ratio": route.total_fuel_t / nlp["fuel_t"],
        "as_plan_fuel_t": as_plan.total_fuel_t,
        "as_plan_ratio": as_plan.total_fuel_t / nlp["fuel_t"],
        "as_plan_violations": len(as_plan.verify()),
    }


def bench_crossing_storm() -> dict[str, Any]:
    """A 9 m storm moving SSE across a 730 nm great circle at 30° N, ETA 56 h: the NLP and the 3-D DP side by side.

    Kwon's power in the storm's head sea is up to 11× the calm-water power at 10 kn. The fitted separable
    model the NLP used before (fit error up to ~65 %) lost to the DP by 8 % here (81.95 t against 75.3 t).
    Now the NLP optimises the model itself (:mod:`optroute.optimise.power_table`); beside it, in the same
    run: the NLP started from the centreline alone, the NLP started from the 3-D DP on the same corridor
    (``discrete_start=True``: never worse than that start), and the DP (ΔX 60 nm, ΔY 10 nm, 1 h, 1 kn), all
    scored by the referee (the plan evaluator, 5 nm steps), with their run times and solve counts.
    """
    import optroute as orx

    ship = orx.Ship.preset("container_54k_dwt")
    wx = orx.scenarios.moving_storm(
        33.0,
        -147.0,
        160.0,
        10.0,
        peak_hs_m=9.0,
        radius_nm=200.0,
        start=DP_T0,
        duration_h=72.0,
        step_h=3.0,
        resolution_deg=0.5,
        bbox=(20, 40, -160, -130),
    )
    start, end, eta_h = (30.0, -152.0), (30.0, -138.0), 56.0
    eta = DP_T0 + np.timedelta64(int(eta_h), "h")
    corridor = orx.Corridor.from_waypoints([start, end], width_nm=60.0)
    dp_res = {"dx_nm": 60.0, "dy_nm": 10.0, "half_width_nm": 30.0, "dt_h": 1.0}
    kw = {"departure": DP_T0, "eta": eta, "max_leg_nm": 30.0, "use_land_mask": False}
    rows = {}
    runs = []
    for label, extra in (
        ("NLP from the centreline", {"discrete_start": False}),
        ("NLP from the 3-D DP", {"discrete_start": True, "dp_options": {**dp_res, "speed_step_kn": 1.0}}),
        ("default call (the start stage's own DP)", {}),
    ):
        # the rows where the referee checks beside the default placement, at the midpoints and leg ends
        runs += [(label, {**extra, "constraint_rows": "referee"})]
        runs += [(f"{label}, rows at midpoints and leg ends", {**extra, "constraint_rows": "midpoints"})]
    for label, extra in runs:
        t0 = time.perf_counter()
        plan = orx.optimise_corridor(corridor, wx, ship, **kw, **extra)
        st = plan.solver_stats
        rows[label] = {
            "legs": int(st["n_legs"]),
            "time_s": time.perf_counter() - t0,
            "fuel_t": plan.total_fuel_t,
            "status": plan.status,
            "nlp_solves": int(st["nlp_solves"]),
            "iterations": int(st["iterations"]),
            "nlp_score": float(st["nlp_score"]),
            "start": st["start"],
            "tabulation_rel_error": (st.get("tabulation") or {}).get("rel_error", float("nan")),
            "start_tabulation_rel_error": (st.get("start_tabulation") or {}).get("rel_error", float("nan")),
            "violations": len(plan.verify()),
            "first_solve": st.get("first_solve", "–"),
            "row_samples_per_leg": st.get("row_samples_per_leg"),
        }
    t0 = time.perf_counter()
    route = orx.search_route(
        start,
        end,
        wx,
        ship,
        departure=DP_T0,
        method="dp",
        objective="fuel",
        eta=eta,
        speeds_kn=np.arange(3.0, ship.max_calm_speed_kn, 1.0),
        dp_options=dp_res,
    )
    el = time.perf_counter() - t0
    ref = rows["NLP from the centreline"]
    row = _dp_row(
        route,
        "60/10 nm, 1 h, 1 kn",
        (60.0, 10.0, 1.0, 1.0),
        el,
        {**ref, "median_total_s": ref["time_s"]},
        eta_h,
        ship,
        wx,
        None,
    )
    # the DP's plan with its engine range mended where the referee finds it out between the DP's points
    from optroute.optimise.starts import repaired_plan

    stw = np.asarray(route.stw_kn, dtype=float)
    ctx = orx.Plan.from_schedule(route.waypoints, stw, departure=DP_T0, ship=ship, weather=wx, eta=eta).context
    mended, legs = repaired_plan(
        ctx, route.waypoints, stw, DP_T0, 5.0, "start", v_min_kn=3.0, v_max_kn=ship.max_calm_speed_kn
    )
    row["mended_fuel_t"] = mended.total_fuel_t if mended is not None else float("nan")
    row["mended_legs"] = legs
    return {"nlp": rows, "dp": row}


def _print_dp(b: dict[str, Any]) -> None:
    n = b["nlp"]
    print(
        f"\n### Domain level: NLP beside the 3-D DP ({b['length_nm']:.0f} nm great circle, ±{b['half_width_nm']:.0f} nm, "
        f"moving 13 m storm, ETA {b['eta_h']:.0f} h)\n"
    )
    print(
        f"optimise_corridor, {n['legs']} legs: median {n['median_total_s']:.2f} s per call, of which Ipopt "
        f"{n['median_ipopt_s']:.2f} s over {n['nlp_solves']} solves; fuel {n['fuel_t']:.2f} t, arrival "
        f"{n['duration_h']:.2f} h, verify() violations {n['violations']}; Hs up to {n['max_hs_m']:.1f} m, a band "
        f"applies on {n['legs_with_a_band']} legs\n"
    )
    print(
        "| DP resolution | ΔX [nm] | ΔY [nm] | Δt [h] | speed step [kn] | time [s] | DP time / NLP time | fuel [t] | "
        "DP fuel / NLP fuel | arrival [h] | ETA met |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for r in b["dp"]:
        print(
            f"| {r['resolution']} | {r['dx_nm']:g} | {r['dy_nm']:g} | {r['dt_h']:g} | {r['speed_step_kn']:g} | "
            f"{r['time_s']:.2f} | {r['time_ratio']:.2f} | {r['fuel_t']:.2f} | {r['fuel_ratio']:.4f} | "
            f"{r['arrival_h']:.2f} | {r['eta_met']} |"
        )
    print(
        f"\nstatus {n['status']}, {n['iterations']} Ipopt iterations, tabulation error at the solution "
        f"{n['tabulation_rel_error']:+.3%}. The DP routes re-evaluated by the plan evaluator "
        "(the NLP's referee, 5 nm steps, constant STW per DP leg): "
        + "; ".join(
            f"{r['resolution']} {r['as_plan_fuel_t']:.2f} t ({r['as_plan_ratio']:.4f} of the NLP, "
            f"{r['as_plan_violations']} violations)"
            for r in b["dp"]
        )
    )
    c = b.get("crossing")
    if c:
        print_crossing(c)


def print_crossing(c: dict[str, Any]) -> None:
    """The storm crossing's side-by-side table (:func:`bench_crossing_storm`)."""
    d = c["dp"]
    dp_fuel, dp_time = d["as_plan_fuel_t"], d["time_s"]
    print("\n### Storm crossing the track (730 nm, 9 m, ETA 56 h): NLP beside the 3-D DP, all scored by the referee\n")
    print(
        "| plan | fuel [t] | fuel / DP fuel | time [s] | time / DP time | Ipopt solves | iterations | status | "
        "first solve | samples per leg | tabulation error |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---|---|---:|---:|")
    for label, r in c["nlp"].items():
        print(
            f"| {label} ({r['legs']} legs) | {r['fuel_t']:.2f} | {r['fuel_t'] / dp_fuel:.4f} | {r['time_s']:.1f} | "
            f"{r['time_s'] / dp_time:.2f} | {r['nlp_solves']} | {r['iterations']} | {r['status']} | "
            f"{r.get('first_solve', '–')} | {r.get('row_samples_per_leg', '–')} | {r['tabulation_rel_error']:+.3%} |"
        )
    print(
        f"| 3-D DP {d['resolution']} | {dp_fuel:.2f} | 1.0000 | {dp_time:.1f} | 1.00 | – | – | {d['as_plan_violations']} violations | – | – | – |"
    )
    if "mended_fuel_t" in d:
        print(
            f"| 3-D DP, speeds mended on {d['mended_legs']} legs to verify | {d['mended_fuel_t']:.2f} | "
            f"{d['mended_fuel_t'] / dp_fuel:.4f} | – | – | – | – | verified | – | – | – |"
        )
    first = [r.get("first_solve") == "verified" for r in c["nlp"].values()]
    print(f"\n(first solve verified by the referee: {sum(first)} of {len(first)} runs above)")
    print(
        "\n(the NLP's table against the referee at each run's warm start: "
        + "; ".join(f"{label} {r['start_tabulation_rel_error']:+.2%}" for label, r in c["nlp"].items())
        + ")"
    )
    print(
        "\n(the NLP's own optimum from the DP's start scores "
        + f"{c['nlp']['NLP from the 3-D DP']['nlp_score']:.2f} t; the DP's own fuel figure {d['fuel_t']:.2f} t; "
        "before this change the NLP on the fitted model scored 81.95 t against the DP's 75.3 t)"
    )


def run(quick: bool) -> dict[str, Any]:
    """Run the three benchmarks, print markdown tables, return the figures."""
    started = time.perf_counter()
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    b = bench_500(quick)
    print(
        f"\n### {b['legs']}-leg corridor, {b['samples']} samples, {b['variables']} variables, "
        f"{b['constraints']} constraint rows, ETA {b['eta_h']:.1f} h\n"
    )
    print("_One `SpeedNLP.solve` per row at the formulation level (2 samples per leg, one Ipopt call; build timed "
          "apart): not the same work as an `optimise_corridor` call, which §2b times whole._\n")  # fmt: skip
    print("| derivatives | build [s] | median solve [s] | ratio | iterations | status | fuel [t] |")
    print("|---|---:|---:|---:|---:|---|---:|")
    for r in b["rows"]:
        print(
            f"| {r['method']} | {r['build_s']:.2f} | {r['median_solve_s']:.3f} | {r['ratio_vs_structured']:.2f} | "
            f"{r['iterations']} | {r['status']} | {r['fuel_t']:.2f} |"
        )
    c = b["constant_speed_centreline_fuel_t"]
    print("\n| plan (same ETA) | bands | fuel [t] | vs constant speed |")
    print("|---|---|---:|---:|")
    for label, bands_on, key in (
        ("constant speed on the centreline", "ignored", "constant_speed_centreline_fuel_t"),
        ("NLP speed profile on the centreline", "ignored", "nlp_centreline_no_bands_fuel_t"),
        ("NLP speed profile on the centreline", "sides from the start", "nlp_centreline_fuel_t"),
        ("NLP speeds and offsets in the corridor", "sides from the start", "nlp_corridor_fuel_t"),
    ):
        print(f"| {label} | {bands_on} | {b[key]:.2f} | {b[key] / c - 1:+.2%} |")
    print(
        f"\nETA multiplier {b['eta_multiplier_t_per_h']:.3f} t/h; band constraints active at "
        f"{b['band_active_samples']} of {b['band_applicable_samples']} applicable samples"
    )
    if b["outer_loop"] is not None:
        o = b["outer_loop"]
        print(
            f"side-flip outer loop (single flips, budget 12 solves): {o['solves']} solves in {o['time_s']:.1f} s, "
            f"fuel {o['start_t']:.2f} → {o['best_t']:.2f} t"
        )
    first = b["rows"][0]
    s = bench_scaling(
        quick, {"legs": 500, **{k: first[k] for k in ("build_s", "median_solve_s", "iterations", "status")}}
    )
    print("\n### Scaling (same 5 000 nm corridor, more legs)\n")
    print("| legs | build [s] | median solve [s] | iterations | ms / iteration | status |")
    print("|---:|---:|---:|---:|---:|---|")
    for r in s["rows"]:
        print(
            f"| {r['legs']} | {r['build_s']:.2f} | {r['median_solve_s']:.3f} | {r['iterations']} | "
            f"{1e3 * r['median_solve_s'] / r['iterations']:.1f} | {r['status']} |"
        )
    print(f"\nfitted exponent: time ∝ N^{s['exponent']:.2f} (per iteration: N^{s['exponent_per_iteration']:.2f})")
    wc = whole_call(quick)
    print_whole_call(wc)
    h = bench_heuristic(quick)
    print(f"\n### Band heuristic on {h['instances']} small fixed-path instances (4–6 legs, ±20 % bands)\n")
    print("| inner solver | instances | share exact | worst gap | mean gap |")
    print("|---|---:|---:|---:|---:|")
    print(
        f"| convex (Clarabel) | {h['instances']} | {h['share_exact']:.1%} | {h['worst_gap']:.2%} | {h['mean_gap']:.3%} |"
    )
    print(f"| NLP (Ipopt) | {h['nlp_instances']} | {h['nlp_share_exact']:.1%} | {h['nlp_worst_gap']:.2%} | |")
    print(
        f"\nmean inner solves per heuristic run {h['mean_inner_solves']:.1f}; heuristic {h['heuristic_time_s']:.2f} s "
        f"vs enumeration {h['enumeration_time_s']:.2f} s in total "
        f"({h['enumeration_time_s'] / h['heuristic_time_s']:.1f}×); Bonmin big-M agrees with enumeration on "
        f"{h['bonmin_agrees']}/{h['bonmin_checked']}"
    )
    d = bench_dp(quick)
    _print_dp(d)
    total = time.perf_counter() - started
    print(f"\ntotal {total:.1f} s\n")
    return {"corridor_500": b, "scaling": s, "whole_call": wc, "heuristic": h, "dp_comparison": d, "total_s": total}


def main(argv: list[str] | None = None) -> None:
    if argv is not None and "--crossing" in argv or argv is None and "--crossing" in __import__("sys").argv:
        print_crossing(bench_crossing_storm())  # section 4's storm crossing alone
        return
    args = list(__import__("sys").argv[1:] if argv is None else argv)
    if "--scaling" in args:  # §2b's whole call at 21 … 5 000 legs in fresh processes, against --baseline REF
        from benchmarks._nlp_scaling import main as scaling_main

        scaling_main(args)
        return
    if argv is not None and "--jit" in argv or argv is None and "--jit" in __import__("sys").argv:
        jit_whole_call()  # §2b's whole call at ~100 and ~300 legs, jit off and on alternated
        return
    bench_main(run, __doc__.splitlines()[0], "smaller cases, fewer repetitions (about 30 s)", argv)


if __name__ == "__main__":
    main()
