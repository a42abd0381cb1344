"""The corridor optimiser: ``optimise_corridor`` and ``plan_voyage``.

:func:`optimise_corridor` turns a corridor, the weather and a ship into the
arrays of the corridor NLP (:mod:`optroute.nlp_inputs` →
:class:`formulations.speed_nlp.SpeedNLP`), solves it with the disjunctive
outer loop over the danger-band sides (:func:`formulations.disjunctive.improve_sides`),
turns the solution into a :class:`~optroute.plan.Plan` computed with the
*true* performance model, and verifies it (:meth:`Plan.verify`). A plan
that fails verification is never returned: the problem is tightened where
the verification says (per-leg power factors corrected to the true model's
power, band edges backed off, the ETA, the exclusion radius, the lateral
bounds) and solved again; when that does not produce a clean plan,
:class:`~optroute.errors.SolverFailure` is raised with Ipopt's status.

:func:`plan_voyage` is search → corridor → NLP in one call.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
import xarray as xr
from scipy.optimize import minimize_scalar

from formulations._common import PowerLawFuel, PowerModel
from formulations.disjunctive import InnerOutcome, improve_sides, nlp_groups, select_sides
from formulations.speed_convex import solve_speed_convex
from formulations.speed_nlp import NLPResult, SpeedNLP
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError, InfeasibleETA, OptrouteError, SolverFailure, WeatherCoverageError
from optroute.nlp_inputs import (
    CorridorFrame,
    PowerFit,
    build_frame,
    dataset_spacing,
    fit_power_model,
    formulation_bands,
    lateral_bounds,
    moving_exclusion,
    weather_grid,
)
from optroute.performance import PerformanceModel, default_model
from optroute.plan import Exclusion, Plan, PlanContext, Violation, project_to_polyline
from optroute.route import Corridor, Route
from optroute.safety import BandRules
from optroute.ship import Ship
from optroute.weather.sample import WeatherSampler

__all__ = ["optimise_corridor", "plan_voyage"]

Objective = Literal["time", "fuel", "cost"]
ProgressFn = Callable[[str, float], None]

_NS_PER_H = 3.6e12
_VIOLATION_TOL = 1e-6  # largest scaled constraint violation accepted from Ipopt


def _h_to_td(h: float) -> np.timedelta64:
    return np.timedelta64(int(round(float(h) * _NS_PER_H)), "ns")


def _hours(td: Any) -> float:
    return float(np.asarray(td, dtype="timedelta64[ns]").astype(np.int64)) / _NS_PER_H


def _as_time(t: Any, what: str) -> np.datetime64:
    try:
        out = np.datetime64(t, "ns")
    except (TypeError, ValueError):
        raise ConfigError(f"{what}={t!r} is not a time; pass a numpy.datetime64 or an ISO string (UTC)") from None
    if np.isnat(out):
        raise ConfigError(f"{what} is NaT; pass a UTC time")
    return out


# --------------------------------------------------------------------------- tightening state


@dataclass
class _Tightening:
    """What the verification loop changes between solves."""

    factor: np.ndarray  # per-leg power factor (fit correction) [-]
    max_load: float
    min_load: float
    widen: float  # band back-off [-]
    hs_margin: float  # applicability back-off [-]
    samples_per_leg: int
    extra_radius_nm: float = 0.0
    eta_shift_h: float = 0.0
    bound_scale: np.ndarray = field(default_factory=lambda: np.ones(0))
    retries: int = 0
    corrections: int = 0
    log: list[str] = field(default_factory=list)


@dataclass
class _Solved:
    res: NLPResult
    ok: bool
    n_solves: int
    flips: int
    history: list[float]
    nlp: SpeedNLP


# --------------------------------------------------------------------------- the problem


class _Problem:
    """The domain → formulation adapters of one call, and the solves."""

    def __init__(
        self,
        *,
        frame: CorridorFrame,
        grid: Any,
        samples: Any,
        fit: PowerFit,
        ship: Ship,
        rules: BandRules,
        y_lo: np.ndarray,
        y_hi: np.ndarray,
        v_min: float,
        v_max: float,
        exclusion: Exclusion | None,
        departure: np.datetime64,
        solver_options: Mapping[str, Any] | None,
    ) -> None:
        self.frame, self.grid, self.samples, self.fit = frame, grid, samples, fit
        self.ship, self.rules = ship, rules
        self.y_lo, self.y_hi = y_lo, y_hi
        self.v_min, self.v_max = v_min, v_max
        self.exclusion, self.departure = exclusion, departure
        self.solver_options = dict(solver_options or {})
        self.build_time_s = 0.0

    trial_max_iter = 150

    def bounds(self, st: _Tightening) -> tuple[np.ndarray, np.ndarray]:
        """Lateral bounds [nm], each range shrunk about its middle by the tightening's scale."""
        mid = 0.5 * (self.y_lo + self.y_hi)
        return mid + (self.y_lo - mid) * st.bound_scale, mid + (self.y_hi - mid) * st.bound_scale

    def build(self, st: _Tightening, *, max_iter: int | None = None) -> SpeedNLP:
        started = _time.perf_counter()
        self._last_state = st
        options = dict(self.solver_options)
        if max_iter is not None:
            options["ipopt.max_iter"] = min(int(max_iter), int(options.get("ipopt.max_iter", max_iter)))
        bands, names, a = formulation_bands(self.ship, self.rules, widen=st.widen, hs_margin=st.hs_margin)
        hs_top = float(np.max(self.grid.hs_m))
        # a band applies only where Hs >= its threshold: leave out those the weather never reaches
        keep = [i for i, b in enumerate(bands) if hs_top >= b.hs_min_m]
        bands, self.band_names = tuple(bands[i] for i in keep), tuple(names[i] for i in keep)
        geom = self.frame.geometry(*self.bounds(st))
        power = replace(self.fit.power, max_load=st.max_load, min_load=st.min_load)
        excl = None
        if self.exclusion is not None:
            excl = moving_exclusion(self.exclusion, self.frame, self.departure, extra_radius_nm=st.extra_radius_nm)
        nlp = SpeedNLP(
            geom,
            self.grid,
            power,
            bands=bands,
            exclusion=excl,
            samples_per_leg=st.samples_per_leg,
            v_min_kn=self.v_min,
            v_max_kn=self.v_max,
            leg_power_factor=st.factor,
            g_over_2pi_kn_s=a,
            ipopt_options=options,
        )
        self.build_time_s += _time.perf_counter() - started
        return nlp

    def solve(
        self,
        nlp: SpeedNLP,
        *,
        eta_h: float | None,
        eta_mode: str,
        objective: str,
        fuel_price: float,
        hourly_cost: float,
        warm: Mapping[str, np.ndarray] | None,
        budget: int,
    ) -> _Solved:
        """One solve with the band outer loop (side selection from the warm start, flips, applicability)."""
        n = nlp.n_legs
        kwargs: dict[str, Any] = {
            "eta_h": eta_h,
            "eta_mode": eta_mode,
            "objective": objective,
            "fuel_price": fuel_price,
            "hourly_cost": hourly_cost,
        }
        if warm is not None:
            y0 = np.clip(warm["offset_nm"], *nlp.corridor.offset_bounds())
            v0 = np.clip(warm["stw_kn"], nlp.v_min_kn, nlp.v_max_kn)
        else:
            y0 = np.clip(np.zeros(n + 1), *nlp.corridor.offset_bounds())
            total = float(self.frame.s_nm[-1])
            guess = total / eta_h if eta_h is not None else 0.9 * self.v_max
            v0 = np.clip(np.full(n, guess), nlp.v_min_kn, nlp.v_max_kn)
        t0 = nlp.consistent_times(y0, v0)
        kwargs.update(offset0_nm=y0, stw0_kn=v0, time0_h=t0)
        if nlp.n_bands == 0:
            res = nlp.solve(**kwargs)
            ok = bool(res.success and res.max_violation <= _VIOLATION_TOL)
            return _Solved(res, ok, 1, 0, [res.objective] if ok else [], nlp)
        state = nlp.evaluate(y0, v0, t0)
        sides, applies = nlp.default_sides(state)
        shape = sides.shape
        flippable = _flippable(nlp, state)
        trial_nlp: list[SpeedNLP] = []

        def trial() -> SpeedNLP:
            if not trial_nlp:  # flip trials: an iteration cap, so that hopeless flips fail fast
                trial_nlp.append(self.build(self._last_state, max_iter=self.trial_max_iter))
            return trial_nlp[0]

        solve = _band_solver(nlp, trial, kwargs)
        out = improve_sides(solve, sides, applies, flippable=flippable, groups=nlp_groups(shape), max_solves=budget)
        res = out.outcome.payload
        return _Solved(res, bool(out.feasible), out.n_solves, max(0, len(out.history) - 1), list(out.history), nlp)


def _band_solver(nlp: SpeedNLP, trial: Callable[[], SpeedNLP], kwargs: dict[str, Any]) -> Callable[..., InnerOutcome]:
    """Inner solver of the band outer loop (as :func:`formulations.disjunctive.nlp_band_solver`).

    The first solve uses the full NLP; the later ones (side flips, applicability re-checks) an
    instance with an iteration cap. Every solve is warm-started from the best valid solution so far.
    """
    lower = np.array([b.lower for b in nlp.bands])
    upper = np.array([b.upper for b in nlp.bands])
    warm = dict(kwargs)
    best = {"objective": math.inf}
    calls = [0]

    def solve(sides: np.ndarray, applies: np.ndarray) -> InnerOutcome:
        which = nlp if calls[0] == 0 else trial()
        calls[0] += 1
        res = which.solve(sides=sides, applies=applies, **warm)
        feasible = bool(res.success and res.max_violation <= _VIOLATION_TOL)
        st = res.samples
        if feasible and not st.inside.any() and res.objective < best["objective"]:
            best["objective"] = float(res.objective)
            warm.update(offset0_nm=res.offset_nm, stw0_kn=res.stw_kn, time0_h=res.time_h)
        return InnerOutcome(
            feasible=feasible,
            objective=float(res.objective) if feasible else math.inf,
            active=res.band_active,
            weight=np.abs(res.band_multiplier),
            applies=st.applies,
            side_at_solution=select_sides(st.ratio, lower, upper),
            inside=st.inside,
            status=res.status,
            payload=res,
            infeasibility=0.0 if feasible else float(res.max_violation),
        )

    return solve


def _flippable(nlp: SpeedNLP, state: Any, n_speeds: int = 64) -> np.ndarray:
    """(leg, band) groups whose both sides a ship can reach at every sample (speed and power bounds).

    At the sample's sea state (Hs, wave period and encounter angle of ``state``) each side of a band
    is tested on ``n_speeds`` speeds in the NLP's speed range with the fitted power within the load
    limits. A side no allowed speed reaches cannot be flipped to: the flip would only cost a failed
    solve. Shape (N, m, B), constant over the samples of a group.
    """
    pw: PowerModel = nlp.power
    n, m, nb = nlp.n_legs, nlp.samples_per_leg, nlp.n_bands
    v = np.linspace(float(np.min(nlp.v_min_kn)), float(np.max(nlp.v_max_kn)), n_speeds)[None, None, :]
    hs = np.maximum(state.hs_m, 0.0)[..., None]
    per = state.period_s[..., None]
    cos_chi = state.cos_chi[..., None]
    ca = -cos_chi
    w = sum((h * hs**q for h, q in zip(pw.hs_coef, pw.hs_exp, strict=True)), np.zeros_like(hs))
    wd = w * (pw.angle_coef[0] + pw.angle_coef[1] * ca + pw.angle_coef[2] * ca**2)
    calm = sum(c * v**e for c, e in zip(pw.calm_coef, pw.calm_exp, strict=True))
    sv = sum(u * v**r for r, u in enumerate(pw.speed_coef))
    load = nlp.leg_power_factor[:, None, None] * calm * (1.0 + wd * sv) / pw.mcr_kw
    ok_power = (load <= pw.max_load) & (load >= pw.min_load)
    a = nlp.g_over_2pi
    along = v * cos_chi
    out = np.zeros((n, m, nb), dtype=bool)
    for i, b in enumerate(nlp.bands):
        if len(b.allowed_sides) < 2:
            continue
        if b.kind == "te_over_tr":
            ratio = a * per**2 / (b.param * np.maximum(np.abs(a * per - along), 1e-9))
        else:
            den = {"v_over_c": a * per, "v_over_cg": 0.5 * a * per}.get(b.kind, b.param)
            ratio = along / den
        low = np.any(ok_power & (ratio <= b.lower), axis=-1)
        high = np.any(ok_power & (ratio >= b.upper), axis=-1)
        both = low & high
        out[:, :, i] = np.all(both | ~state.applies[:, :, i], axis=1)[:, None]
    return out


def _route_warm_start(route: Route, frame: CorridorFrame) -> dict[str, np.ndarray]:
    """Leg speeds of a search route on the corridor's legs (by along-track position), centreline offsets."""
    wp = frame.corridor.waypoints
    mid_lat = 0.5 * (wp[:-1, 0] + wp[1:, 0])
    mid_lon = units.wrap_180(wp[:-1, 1] + 0.5 * units.wrap_180(wp[1:, 1] - wp[:-1, 1]))
    _, _, _, k = project_to_polyline(route.waypoints, mid_lat, mid_lon)
    stw = np.asarray(route.stw_kn, dtype=float)
    sog = np.asarray(route.sog_kn, dtype=float)
    speed = np.where(np.isfinite(stw) & (stw > 0), stw, sog)[k]
    fallback = route.total_distance_nm / route.total_duration_h
    speed = np.where(np.isfinite(speed) & (speed > 0), speed, fallback)
    return {"offset_nm": np.zeros(frame.n_legs + 1), "stw_kn": speed}


def _safe_warm_start(ctx: PlanContext, frame: CorridorFrame, t0: np.datetime64, desired_kn: float, v_min: float,
                     m: int = 3, rules: BandRules | None = None) -> dict[str, np.ndarray]:
    """Centreline warm start at speeds the true model allows: Boeing's speed reduction leg by leg.

    At ``m`` points of every centreline leg, at the time a ship sailing the desired speed is there,
    :func:`optroute.passage.best_speed` gives the fastest allowed speed at or below ``desired_kn``
    (outside every band, within the power limits); the leg takes the slowest of its points (``v_min``
    where none is allowed). The band sides the NLP starts on are then sides a ship can actually keep.
    ``rules`` (default the context's) may be the NLP's backed-off rules (:func:`_warm_rules`).
    """
    from optroute.passage import best_speed
    from optroute.plan import _sea, gc_points

    ctx_rules = ctx.rules if rules is None else rules
    wp = frame.corridor.waypoints
    n = frame.n_legs
    frac = (np.arange(m) + 0.5) / m
    leg = np.repeat(np.arange(n), m)
    f = np.tile(frac, n)
    lat, lon, course = gc_points(wp[leg, 0], wp[leg, 1], wp[leg + 1, 0], wp[leg + 1, 1], f)
    d = np.diff(frame.s_nm)
    speed = np.full(n, float(desired_kn))
    for _ in range(2):
        t_leg = np.concatenate([[0.0], np.cumsum(d / speed)])
        t_h = t_leg[leg] + f * (d / speed)[leg]
        when = t0 + (t_h * _NS_PER_H).astype("timedelta64[ns]")
        sea, covered = _sea(ctx.sampler, when, lat, lon)
        choice = best_speed(ctx.ship, ctx.model, ctx_rules, course, sea, float(desired_kn), step_kn=0.25,
                            min_stw_kn=v_min)
        v = np.where(choice.feasible & covered, choice.stw_kn, v_min)
        speed = np.maximum(np.min(v.reshape(n, m), axis=1), v_min)
    return {"offset_nm": np.zeros(n + 1), "stw_kn": speed}


def _clear_of_exclusion(warm: dict[str, np.ndarray], frame: CorridorFrame, exclusion: Exclusion | None,
                        t0: np.datetime64, y_lo: np.ndarray, y_hi: np.ndarray) -> dict[str, np.ndarray]:
    """Move warm-start waypoints that the exclusion circle covers out of it, behind the moving circle.

    The exclusion constraint is non-convex: started at the circle's centre, Ipopt has no direction to
    leave by. A waypoint within 1.5 radii of the centre at the time the warm start passes it is moved
    across the corridor to 1.3 radii from the centre, all on one side: the side the circle comes from
    (passing behind it) when it moves across the corridor, else the side away from its centre.
    """
    if exclusion is None:
        return warm
    d = np.diff(frame.s_nm)
    t_h = np.concatenate([[0.0], np.cumsum(d / np.asarray(warm["stw_kn"], dtype=float))])
    when = t0 + (t_h * _NS_PER_H).astype("timedelta64[ns]")
    clat, clon, rad = exclusion.at(when)
    later = exclusion.at(when + np.timedelta64(1, "h"))
    s_c, xt_c, _, _ = project_to_polyline(frame.corridor.waypoints, clat, clon)
    _, xt_next, _, _ = project_to_polyline(frame.corridor.waypoints, later[0], later[1])
    y_c, motion = -xt_c, -(xt_next - xt_c)  # port-positive offset of the centre and its lateral motion [nm/h]
    y = np.asarray(warm["offset_nm"], dtype=float).copy()
    gap = frame.s_nm - s_c
    near = np.hypot(gap, y - y_c) < 1.5 * rad
    if not near.any():
        return warm
    # one side for the whole encounter: behind the circle (against its lateral motion), else away from it
    drift = float(np.mean(motion[near]))
    offset = float(np.mean(y_c[near]))
    ship_side = -np.sign(drift) if abs(drift) > 1e-3 else (-np.sign(offset) if abs(offset) > 1e-6 else -1.0)
    reach = np.sqrt(np.maximum((1.3 * rad) ** 2 - gap**2, 0.0))
    y = np.where(near, y_c + ship_side * reach, y)
    return {**warm, "offset_nm": np.clip(y, y_lo, y_hi)}


def _desired_speed(length_nm: float, eta_h: float | None, v_max: float, objective: str) -> float:
    """Speed of a warm start [kn]: the ETA's mean speed, the top speed for minimum time, else 3/4 of it."""
    if eta_h:
        return min(v_max, length_nm / eta_h)
    return v_max if objective == "time" else 0.75 * v_max


def _warm_rules(rules: BandRules, st: _Tightening) -> BandRules:
    """The rules with about the NLP's back-offs: lower applicability threshold, wider bands."""
    margin = min(0.95, rules.margin * (1.0 + st.widen) + st.widen)
    return replace(rules, hs_threshold_fraction=rules.hs_threshold_fraction * (1.0 - st.hs_margin), margin=margin)


# --------------------------------------------------------------------------- certificate


def _leg_functions(nlp: SpeedNLP, res: NLPResult) -> tuple[Callable[[np.ndarray], np.ndarray], np.ndarray, np.ndarray]:
    """Per-leg power P_ij(V) on a fixed path in static weather without current, and the speed bounds."""
    pw: PowerModel = nlp.power
    smp = res.samples
    hs = np.maximum(smp.hs_m, 0.0)
    ca = -smp.cos_chi  # cos α (IMO: 0 = head sea); without current it does not depend on V
    w = sum((h * hs**q for h, q in zip(pw.hs_coef, pw.hs_exp, strict=True)), np.zeros_like(hs))
    b0, b1, b2 = pw.angle_coef
    wd = w * (b0 + b1 * ca + b2 * ca**2)  # (n, m)
    f = nlp.leg_power_factor

    def power(v: np.ndarray) -> np.ndarray:  # v (n, K) → (n, m, K)
        vv = np.asarray(v, dtype=float)[:, None, :]
        calm = sum(c * vv**e for c, e in zip(pw.calm_coef, pw.calm_exp, strict=True))
        s = sum(u * vv**r for r, u in enumerate(pw.speed_coef))
        return f[:, None, None] * calm * (1.0 + wd[:, :, None] * s)

    lo, hi = nlp.v_min_kn.copy(), nlp.v_max_kn.copy()
    # load limits per sample → speed interval per leg (power increases with speed): bisection
    a, b = lo.copy(), hi.copy()
    for _ in range(80):
        mid = 0.5 * (a + b)
        over = np.max(power(mid[:, None])[..., 0], axis=1) / pw.mcr_kw > pw.max_load
        b = np.where(over, mid, b)
        a = np.where(over, a, mid)
    top = np.max(power(hi[:, None])[..., 0], axis=1) / pw.mcr_kw <= pw.max_load
    hi = np.where(top, hi, a)
    a, b = lo.copy(), hi.copy()
    for _ in range(80):
        mid = 0.5 * (a + b)
        under = np.min(power(mid[:, None])[..., 0], axis=1) / pw.mcr_kw < pw.min_load
        a = np.where(under, mid, a)
        b = np.where(under, b, mid)
    bottom = np.min(power(lo[:, None])[..., 0], axis=1) / pw.mcr_kw >= pw.min_load
    lo = np.where(bottom, lo, b)
    return power, lo, hi


def _certificate(
    nlp: SpeedNLP, res: NLPResult, *, objective: str, eta_h: float | None, eta_mode: str, fuel_price: float,
    hourly_cost: float,
) -> dict[str, Any]:
    """Global-optimality certificate of a fixed-path, static-weather solve.

    With a constant SFOC and non-negative power terms the fuel rate is a sum of power laws and the
    problem is :func:`formulations.speed_convex.solve_speed_convex`'s (Clarabel, the global optimum).
    The IMO SFOC curve has a negative linear term and is outside that class (the fuel rate is still
    convex in V: for P = cV³ its second derivative is a positive quadratic in the load), so the
    bound is then weak Lagrangian duality at the NLP's ETA multiplier λ:
    ``q(λ) = Σ_i min_t (F_i(t) + λ t) − λ T ≤ optimum``, each leg minimised on its speed interval.
    """
    pw: PowerModel = nlp.power
    power, lo, hi = _leg_functions(nlp, res)
    d = res.distance_nm
    n = d.size
    w_f, w_t = (1.0, 0.0) if objective == "fuel" else (float(fuel_price), float(hourly_cost))
    a2, a1, a0 = pw.sfc_quad
    pw_terms = [(c, e, 0) for c, e in zip(pw.calm_coef, pw.calm_exp, strict=True)]
    smp = res.samples
    ca = -smp.cos_chi
    hs = np.maximum(smp.hs_m, 0.0)
    wd = sum((h * hs**q for h, q in zip(pw.hs_coef, pw.hs_exp, strict=True)), np.zeros_like(hs))
    wd = wd * (pw.angle_coef[0] + pw.angle_coef[1] * ca + pw.angle_coef[2] * ca**2)
    wd_mean = wd.mean(axis=1)
    coef = None
    if a2 == 0.0 and a1 == 0.0 and a0 > 0:
        k = pw.sfc_base_gpkwh * a0 * 1e-6 * nlp.leg_power_factor
        exps: dict[float, np.ndarray] = {}
        for c, e, _ in pw_terms:
            exps[float(e)] = exps.get(float(e), np.zeros(n)) + k * c
            for r, u in enumerate(pw.speed_coef):
                exps[float(e + r)] = exps.get(float(e + r), np.zeros(n)) + k * c * u * wd_mean
        ex = np.array(sorted(exps))
        coef = np.column_stack([exps[x] for x in ex])
        scale = float(np.max(np.abs(coef))) or 1.0
        # a sum of power laws with non-negative coefficients (exponents >= 1): PowerLawFuel's class
        coef = np.where(np.abs(coef) <= 1e-12 * scale, 0.0, coef) if np.all(coef >= -1e-12 * scale) else None
    if coef is not None:
        fuel = PowerLawFuel(coef, ex)
        conv = solve_speed_convex(d, fuel, eta_h=eta_h, eta_mode=eta_mode, v_min_kn=lo, v_max_kn=hi,
                                  objective=objective, fuel_price=fuel_price, hourly_cost=hourly_cost)
        if not conv.success:
            return {"method": "convex (CVXPY + Clarabel)", "status": conv.status, "gap": float("nan")}
        gap = (res.objective - conv.objective) / max(abs(conv.objective), 1e-12)
        return {"method": "convex (CVXPY + Clarabel)", "status": conv.status, "objective": conv.objective,
                "total_fuel_t": conv.total_fuel_t, "gap": float(gap)}
    lam = float(res.eta_multiplier) if eta_h is not None else 0.0

    def leg_cost(i: int, t: float) -> float:
        v = d[i] / t
        p = power(np.full((n, 1), v))[i, :, 0]
        rate = float(np.mean(pw.fuel_rate_tph(p)))
        return w_f * t * rate + w_t * t + lam * t

    total = 0.0
    for i in range(n):
        t_lo, t_hi = d[i] / hi[i], d[i] / lo[i]
        cands = [leg_cost(i, t_lo), leg_cost(i, t_hi)]
        if t_hi > t_lo:
            r = minimize_scalar(lambda t, i=i: leg_cost(i, t), bounds=(t_lo, t_hi), method="bounded",
                                options={"xatol": 1e-10 * t_hi})
            cands.append(float(r.fun))
        total += min(cands)
    bound = total - (lam * eta_h if eta_h is not None else 0.0)
    gap = (res.objective - bound) / max(abs(res.objective), 1e-12)
    return {"method": "Lagrangian dual bound", "lambda": lam, "bound": bound, "gap": float(gap)}


# --------------------------------------------------------------------------- main entry points


def _emit(progress: ProgressFn | None, stage: str, fraction: float) -> None:
    if progress is not None:
        progress(stage, float(fraction))


def optimise_corridor(
    corridor: Corridor,
    weather: xr.Dataset | WeatherSampler,
    ship: Ship,
    *,
    departure: Any,
    eta: Any = None,
    eta_mode: Literal["le", "eq"] = "le",
    objective: Objective = "fuel",
    model: PerformanceModel | None = None,
    rules: BandRules | None = None,
    route: Route | None = None,
    max_leg_nm: float = 50.0,
    samples_per_leg: int = 3,
    fuel_price_per_t: float = 600.0,
    hourly_cost_per_h: float = 0.0,
    exclusion: Exclusion | None = None,
    progress: ProgressFn | None = None,
    speed_range_kn: tuple[float, float] | None = None,
    band_solves: int = 12,
    fit_corrections: int = 1,
    max_retries: int = 4,
    band_margin: float = 0.005,
    band_hs_margin: float = 0.05,
    verify_step_nm: float = 5.0,
    solver_options: Mapping[str, Any] | None = None,
    use_land_mask: bool | None = None,
) -> Plan:
    """Optimise the waypoints and leg speeds inside a corridor: the corridor NLP, verified.

    Parameters
    ----------
    corridor : Corridor
        Centreline and half-width (``half_width_nm = 0`` fixes the path).
    weather : xarray.Dataset or WeatherSampler
        Canonical weather (:func:`optroute.open_weather`, :mod:`optroute.scenarios`).
    ship : Ship
    departure : datetime64 or str
        [UTC].
    eta : datetime64 or str, optional
        Required arrival [UTC]. Without it, ``"fuel"``/``"cost"`` keep the passage within the
        weather's time span (the slowest passage otherwise has no end) and ``"time"`` is free.
    eta_mode : {"le", "eq"}
        Arrive no later than the ETA, or at it.
    objective : {"fuel", "time", "cost"}
        Least fuel [t], least passage time [h], or ``fuel_price_per_t · fuel + hourly_cost_per_h · time``.
    model : PerformanceModel, optional
        The true power and fuel model (default :class:`~optroute.performance.KwonModel`); the NLP
        uses a least-squares fit of it, the plan is computed and verified with it.
    rules : BandRules, optional
        Danger bands (default Boeing EP 2145155).
    route : Route, optional
        A search route: the warm start (its leg speeds on the corridor's legs) and hence the side
        of every danger band each leg starts on.
    max_leg_nm : float
        Longest NLP leg [nm]; the corridor is resampled on its great circles.
    samples_per_leg : int
        NLP samples per leg (constraints and the midpoint-rule time and fuel).
    fuel_price_per_t, hourly_cost_per_h : float
        For ``"cost"`` [currency/t], [currency/h].
    exclusion : Exclusion, optional
        A moving circle (storm, cyclone) to stay out of.
    progress : callable, optional
        ``progress(stage, fraction)`` with ``fraction`` in [0, 1].
    speed_range_kn : (float, float), optional
        Speed-through-water bounds [kn]; default 3 kn to the calm-water speed at MCR (at most 40).
    band_solves : int
        Budget of NLP solves of the band outer loop (side flips, applicability re-checks) per solve.
    fit_corrections : int
        Re-solves after a clean plan with the per-leg power factor set to the ratio of the true
        model's power to the fit's at the solution (defect correction of the fit).
    max_retries : int
        Tightened re-solves after a failed verification.
    band_margin : float
        Initial relative back-off of the band edges [-] (the bands are closed and the NLP ends on
        their edges); grows when the verification finds a band.
    band_hs_margin : float
        Initial relative back-off of the bands' Hs threshold [-] (the NLP imposes a band from
        ``(1 − band_hs_margin)`` times the threshold); grows when the verification finds a band.
    verify_step_nm : float
        Longest piece of the plan's dense evaluation and verification [nm].
    solver_options : mapping, optional
        Ipopt/CasADi options for :class:`formulations.speed_nlp.SpeedNLP` (e.g. ``{"ipopt.max_iter": 100}``).
    use_land_mask : bool, optional
        Apply the real coastline (default: unless the weather declares synthetic geography).

    Returns
    -------
    Plan
        Verified (``plan.verify() == []``). ``solver_stats`` holds: ``ipopt_status`` (verbatim),
        ``iterations``, ``nlp_solves``, ``outer_flips``, ``outer_history``, ``solve_time_s``,
        ``build_time_s``, ``total_time_s``, ``fit_max_rel_error``, ``fit_rms_rel_error``,
        ``sfoc_fit_max_rel_error``, ``nlp_objective`` (fitted model), ``nlp_fuel_t``,
        ``frame_max_rel_distance_error``, ``retries``, ``tightening`` (log), ``certificate``
        (fixed path in static weather: method and gap), ``n_legs``, ``samples_per_leg``,
        ``weather_grid_shape``, ``eta_h_solved``.

    Raises
    ------
    InfeasibleETA
        The ETA cannot be met; ``earliest_arrival`` is the minimum-time solve's arrival.
    SolverFailure
        Ipopt fails (``status`` verbatim) or no tightened re-solve gives a plan that passes
        verification; ``best_plan`` is the search route's plan when it passes verification.
    WeatherCoverageError
        The corridor or the ETA lies outside the weather.
    NoSafePassage, OnLandError
        The corridor has a waypoint with no navigable offset, or starts or ends on land.
    """
    started = _time.perf_counter()
    if objective not in ("time", "fuel", "cost"):
        raise ConfigError(f"objective={objective!r} is not known; use 'time', 'fuel' or 'cost'")
    if eta_mode not in ("le", "eq"):
        raise ConfigError(f"eta_mode={eta_mode!r} is not known; use 'le' (arrive by) or 'eq' (arrive at)")
    if not isinstance(corridor, Corridor):
        raise ConfigError(f"corridor must be an optroute.Corridor, got {type(corridor).__name__}")
    t0 = _as_time(departure, "departure")
    eta_t = _as_time(eta, "eta") if eta is not None else None
    eta_user_h = _hours(eta_t - t0) if eta_t is not None else None
    if eta_user_h is not None and eta_user_h <= 0:
        raise ConfigError(f"eta={eta_t} is not after departure={t0}; give an arrival later than the departure")
    if not (isinstance(samples_per_leg, int | np.integer) and samples_per_leg >= 1):
        raise ConfigError(f"samples_per_leg={samples_per_leg!r} must be an integer >= 1")
    fuel_price = float(finite("fuel_price_per_t", fuel_price_per_t, minimum=0.0, strict=True, error=ConfigError))
    hourly = float(finite("hourly_cost_per_h", hourly_cost_per_h, minimum=0.0, error=ConfigError))
    margin0 = float(finite("band_margin", band_margin, minimum=0.0, error=ConfigError))
    hs_margin0 = float(finite("band_hs_margin", band_hs_margin, minimum=0.0, error=ConfigError))
    if isinstance(weather, WeatherSampler):
        sampler, ds = weather, None
    elif isinstance(weather, xr.Dataset):
        sampler, ds = WeatherSampler(weather), weather
    else:
        raise ConfigError(f"weather must be a canonical xarray.Dataset or a WeatherSampler, got {type(weather).__name__}")
    model = model if model is not None else default_model(ship)
    rules = rules if rules is not None else BandRules()
    if speed_range_kn is None:
        v_min, v_max = 3.0, float(min(ship.max_calm_speed_kn, 40.0))
    else:
        v_min, v_max = (float(x) for x in finite("speed_range_kn", speed_range_kn, minimum=0.0, strict=True,
                                                  error=ConfigError))
        if v_max <= v_min:
            raise ConfigError(f"speed_range_kn={speed_range_kn!r} needs lower < upper")
    _emit(progress, "corridor", 0.0)

    # ---- time window -----------------------------------------------------------------
    ext = sampler.extent
    data_end_h = _hours(ext["time"][1] - t0) if sampler.time_policy == "raise" else math.inf
    if sampler.time_policy == "raise" and _hours(ext["time"][0] - t0) > 1e-9:
        raise WeatherCoverageError(
            f"departure={t0} is before the weather's first time {ext['time'][0]}; depart later or extend the forecast"
        )
    if data_end_h <= 0:
        raise WeatherCoverageError(
            f"departure={t0} is at or after the weather's last time {ext['time'][1]}; extend the forecast"
        )
    if eta_user_h is not None and eta_user_h > data_end_h + 1e-9:
        raise WeatherCoverageError(
            f"eta={eta_t} is after the weather's last time {ext['time'][1]}: the passage could not be checked against "
            "the weather; extend the forecast, give an earlier eta, or open the weather with time_policy='hold'"
        )
    cap_h = eta_user_h if eta_user_h is not None else (data_end_h if objective != "time" and math.isfinite(data_end_h)
                                                        else None)
    cor = corridor.resample(float(finite("max_leg_nm", max_leg_nm, minimum=0.0, strict=True, error=ConfigError)))
    frame = build_frame(cor)
    length = float(frame.s_nm[-1])
    if cap_h is not None:
        horizon = cap_h * 1.02 + 1.0
    else:
        horizon = 1.3 * length / max(v_min, 0.5 * ship.design_speed_kn)
    horizon = min(horizon, data_end_h) if math.isfinite(data_end_h) else horizon
    dt_ds, ds_ds = dataset_spacing(ds)
    # the NLP's grid is twice as fine as the data's, so that its smooth interpolant stays within about a
    # quarter of its own O(h²) departure from the data's multilinear interpolation (the verifier's)
    dt_h = float(np.clip(0.5 * dt_ds if dt_ds else 1.5, 0.5, 3.0))
    ds_nm = float(min(np.clip(0.5 * ds_ds if ds_ds else 15.0, 5.0, 30.0), max(float(np.max(cor.leg_distance_nm)), 5.0)))
    hw_max = float(np.max(cor.half_width_nm))
    dy_nm = float(np.clip(ds_nm / 2.0, 2.0, max(hw_max / 2.0, 2.0)))
    _emit(progress, "weather grid", 0.05)
    grid, samples = weather_grid(frame, sampler, departure=t0, t_end_h=horizon, dt_h=dt_h, ds_nm=ds_nm, dy_nm=dy_nm)
    window = t0 + np.array([_h_to_td(h) for h in np.linspace(0.0, horizon, int(min(25, max(2, horizon / dt_h + 1))))])
    _emit(progress, "lateral bounds", 0.1)
    y_lo, y_hi = lateral_bounds(frame, sampler=sampler, dataset=ds, times=window, use_land_mask=use_land_mask,
                                step_nm=max(1.0, min(5.0, hw_max / 10.0)) if hw_max > 0 else 1.0)
    _emit(progress, "power fit", 0.15)
    v_ref = length / cap_h if cap_h else 0.75 * v_max
    fit = fit_power_model(model, hs_m=samples.hs_m, wind_ms=samples.wind_ms, v_min_kn=max(v_min, 0.5 * v_ref),
                          v_max_kn=v_max, min_load=float(model.min_power_kw) / float(model.mcr_kw))
    ctx = PlanContext(ship=ship, model=model, rules=rules, sampler=sampler, dataset=ds, corridor=corridor,
                      eta=eta_t, eta_mode=eta_mode, exclusion=exclusion, use_land_mask=use_land_mask)
    prob = _Problem(frame=frame, grid=grid, samples=samples, fit=fit, ship=ship, rules=rules, y_lo=y_lo, y_hi=y_hi,
                    v_min=v_min, v_max=v_max, exclusion=exclusion, departure=t0, solver_options=solver_options)
    st = _Tightening(factor=np.ones(frame.n_legs), max_load=1.0, min_load=fit.power.min_load, widen=margin0,
                     hs_margin=hs_margin0,
                     samples_per_leg=int(samples_per_leg), bound_scale=np.ones(frame.n_legs + 1))
    if route is not None:
        warm = _route_warm_start(route, frame)
    else:
        warm = _safe_warm_start(ctx, frame, t0, _desired_speed(length, cap_h, v_max, objective), v_min,
                                rules=_warm_rules(rules, st))
    warm = _clear_of_exclusion(warm, frame, exclusion, t0, y_lo, y_hi)
    fresh_start = False
    solve_kw = {"eta_mode": eta_mode, "objective": objective, "fuel_price": fuel_price, "hourly_cost": hourly}

    best: tuple[float, Plan, _Solved, float | None] | None = None
    last_violations: list[Violation] = []
    last: _Solved | None = None
    solve_time = 0.0
    iterations = 0
    total_attempts = max_retries + fit_corrections + 1
    for attempt in range(total_attempts):
        _emit(progress, "solve", 0.2 + 0.7 * attempt / total_attempts)
        nlp = prob.build(st)
        eta_solve = None if cap_h is None else cap_h - st.eta_shift_h
        if eta_solve is not None and eta_solve <= 0:
            break
        t_s = _time.perf_counter()
        sol = prob.solve(nlp, eta_h=eta_solve, warm=warm, budget=band_solves, **solve_kw)
        solve_time += _time.perf_counter() - t_s
        iterations += int(sol.res.iterations)
        if not sol.ok and attempt > 0 and not fresh_start:
            # the tightened problem failed from the last solution: once more from a safe warm start
            fresh_start = True
            fresh = _safe_warm_start(ctx, frame, t0, _desired_speed(length, eta_solve, v_max, objective), v_min,
                                     rules=_warm_rules(rules, st))
            fresh = _clear_of_exclusion(fresh, frame, exclusion, t0, *prob.bounds(st))
            sol = prob.solve(nlp, eta_h=eta_solve, warm=fresh, budget=band_solves, **solve_kw)
            iterations += int(sol.res.iterations)
        if not sol.ok:
            if attempt == 0:
                _diagnose_failure(prob, nlp, sol, ctx=ctx, cap_h=cap_h, eta_user_h=eta_user_h, t0=t0, route=route,
                                  budget=band_solves, step_nm=verify_step_nm, solve_kw=solve_kw,
                                  warm_rules=_warm_rules(rules, st))
            st.log.append(f"attempt {attempt}: Ipopt {sol.res.status} after tightening; keeping the last clean plan")
            break
        last = sol
        plan = _to_plan(ctx, frame, sol.res, t0, step_nm=verify_step_nm)
        violations = plan.verify(step_nm=verify_step_nm)
        warm = {"offset_nm": sol.res.offset_nm, "stw_kn": sol.res.stw_kn}
        if not violations:
            score = _score(plan, objective, fuel_price, hourly)
            if best is None or score < best[0] - 1e-12 * max(1.0, abs(best[0])):
                best = (score, plan, sol, eta_solve)
            if st.corrections >= fit_corrections:
                break
            ratio = _correction(plan, sol.res)
            if np.all(np.abs(ratio - 1.0) <= 1e-6):
                break  # the fit is exact at this solution: nothing to correct
            st.corrections += 1
            st.factor = st.factor * ratio
            st.log.append(f"attempt {attempt}: clean; fit corrected on every leg (defect correction)")
            continue
        last_violations = violations
        if st.retries >= max_retries:
            break
        st.retries += 1
        _tighten(st, violations, plan, sol.res)
    if best is None:
        status = last.res.status if last is not None else "unknown"
        listed = "; ".join(str(v) for v in last_violations[:6])
        raise SolverFailure(
            f"no plan passing verification after {st.retries} tightened re-solves (Ipopt: {status}); last "
            f"violations: {listed or 'none (Ipopt failed)'}; try more samples_per_leg, shorter max_leg_nm or a "
            "wider band_margin",
            status=status,
            best_plan=_route_plan(route, ctx, verify_step_nm),
        )
    _, plan, sol, eta_solve = best
    _emit(progress, "certificate", 0.95)
    res = sol.res
    cert: dict[str, Any] = {"method": "not applicable", "gap": float("nan")}
    fixed = bool(np.all(y_lo == 0.0) and np.all(y_hi == 0.0))
    reason = _certificate_reason(fixed, samples, res, exclusion, objective)
    if reason is None:
        cert = _certificate(sol.nlp, res, objective=objective, eta_h=eta_solve, eta_mode=eta_mode,
                            fuel_price=fuel_price, hourly_cost=hourly)
    else:
        cert["reason"] = reason
    shadow = float("nan")
    if eta_user_h is not None and objective == "fuel":
        shadow = float(res.eta_multiplier)
    elif eta_user_h is not None and objective == "cost":
        shadow = float(res.eta_multiplier) / fuel_price
    stats = {
        "ipopt_status": res.status,
        "iterations": iterations,
        "nlp_solves": sol.n_solves,
        "outer_flips": sol.flips,
        "outer_history": sol.history,
        "solve_time_s": solve_time,
        "build_time_s": prob.build_time_s,
        "total_time_s": _time.perf_counter() - started,
        "fit_max_rel_error": fit.max_rel_error,
        "fit_rms_rel_error": fit.rms_rel_error,
        "sfoc_fit_max_rel_error": fit.sfoc_max_rel_error,
        "fit_points": fit.n_points,
        "nlp_objective": float(res.objective),
        "nlp_fuel_t": float(res.total_fuel_t),
        "nlp_max_violation": float(res.max_violation),
        "frame_max_rel_distance_error": frame.distance_error(res.offset_nm),
        "retries": st.retries,
        "fit_corrections": st.corrections,
        "tightening": list(st.log),
        "max_load": st.max_load,
        "band_margin": st.widen,
        "certificate": cert,
        "n_legs": frame.n_legs,
        "samples_per_leg": sol.nlp.samples_per_leg,
        "bands": list(prob.band_names),
        "weather_grid_shape": list(np.shape(grid.hs_m)),
        "weather_nodes_filled": samples.filled,
        "eta_h_solved": eta_solve,
    }
    status = "optimal" if res.status == "Solve_Succeeded" else "feasible"
    _emit(progress, "done", 1.0)
    return replace(plan, status=status, solver_stats=stats, eta_shadow_price_t_per_h=shadow)


def _certificate_reason(fixed: bool, samples: Any, res: NLPResult, exclusion: Exclusion | None,
                        objective: str) -> str | None:
    if not fixed:
        return "the path is free (half-width > 0)"
    if not samples.static:
        return "the weather changes in time"
    if samples.has_current:
        return "a current makes the speed over ground depend on the heading"
    if res.applies.any():
        return "a danger band applies"
    if exclusion is not None:
        return "an exclusion circle"
    if objective == "time":
        return "objective 'time' (every leg at its top speed)"
    return None


def _score(plan: Plan, objective: str, fuel_price: float, hourly: float) -> float:
    if objective == "time":
        return plan.duration_h
    if objective == "fuel":
        return plan.total_fuel_t
    return fuel_price * plan.total_fuel_t + hourly * plan.duration_h


def _to_plan(ctx: PlanContext, frame: CorridorFrame, res: NLPResult, t0: np.datetime64, *, step_nm: float) -> Plan:
    wp = frame.waypoints(res.offset_nm)
    return Plan.from_context(ctx, wp, np.asarray(res.stw_kn, dtype=float), departure=t0, status="candidate",
                             step_nm=step_nm)


def _nlp_leg_power(res: NLPResult) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    p = res.samples.power_kw
    return p.mean(axis=1), p.max(axis=1), p.min(axis=1)


def _correction(plan: Plan, res: NLPResult) -> np.ndarray:
    """Per-leg ratio of the true model's mean power to the fitted model's at the solution, in [0.5, 2]."""
    true = plan.legs["power_kw"].to_numpy(dtype=float)
    mean, _, _ = _nlp_leg_power(res)
    ratio = np.where((mean > 0) & np.isfinite(true), true / np.where(mean > 0, mean, 1.0), 1.0)
    return np.clip(ratio, 0.5, 2.0)


def _tighten(st: _Tightening, violations: list[Violation], plan: Plan, res: NLPResult) -> None:
    """Change the problem where the verification found it wrong (see the module docstring)."""
    kinds = {v.kind.split(":")[0] for v in violations}
    _, p_max, p_min = _nlp_leg_power(res)
    for v in violations:
        k = v.leg
        if v.kind == "power_above_mcr":
            ratio = v.value / max(p_max[k], 1e-9) if np.isfinite(v.value) else 1.2
            st.factor[k] *= float(np.clip(ratio, 1.0, 2.0)) * 1.003
        elif v.kind == "power_below_min":
            ratio = v.value / max(p_min[k], 1e-9)
            st.factor[k] *= float(np.clip(ratio, 0.5, 1.0)) * 0.997
        elif v.kind in ("land", "no_passage", "corridor", "course"):
            st.bound_scale[k] *= 0.5
            st.bound_scale[k + 1] *= 0.5
    if "power_above_mcr" in kinds and st.retries > 1:
        st.max_load *= 0.99
    if "band" in kinds:
        # back the edges off by what the verification found beyond them, with room to spare
        beyond = max((abs(v.value - v.limit) / max(abs(v.limit), 1e-9) for v in violations if v.kind.startswith("band:")),
                     default=0.0)
        st.widen = min(0.2, st.widen + 1.5 * beyond + 0.002)
        st.hs_margin = min(0.3, 1.5 * st.hs_margin + 0.02)
        if st.retries > 1:
            st.samples_per_leg = min(st.samples_per_leg + 1, 8)
    for v in violations:
        if v.kind == "eta":
            st.eta_shift_h += v.value + 1e-3
        elif v.kind == "schedule":
            st.samples_per_leg = min(st.samples_per_leg + 1, 8)
        elif v.kind == "exclusion":
            st.extra_radius_nm += (v.limit - v.value) + 0.5
    st.log.append(f"retry {st.retries}: " + ", ".join(sorted({v.kind for v in violations})))


def _route_plan(route: Route | None, ctx: PlanContext, step_nm: float) -> Plan | None:
    """The search route as a plan (one speed per leg), when it passes verification."""
    if route is None:
        return None
    stw = np.where(np.isfinite(route.stw_kn) & (route.stw_kn > 0), route.stw_kn, route.sog_kn)
    if not np.all(np.isfinite(stw) & (stw > 0)):
        return None
    try:
        plan = Plan.from_context(ctx, np.asarray(route.waypoints), stw, departure=route.departure, status="search",
                                 step_nm=step_nm)
    except OptrouteError:  # the fallback plan is optional; the failure being reported is what matters
        return None
    return plan if not plan.verify(step_nm=step_nm) else None


def _diagnose_failure(
    prob: _Problem,
    nlp: SpeedNLP,
    sol: _Solved,
    *,
    ctx: PlanContext,
    cap_h: float | None,
    eta_user_h: float | None,
    t0: np.datetime64,
    route: Route | None,
    budget: int,
    step_nm: float,
    solve_kw: Mapping[str, Any],
    warm_rules: BandRules,
) -> None:
    """The first solve failed: an unreachable ETA (InfeasibleETA / WeatherCoverageError) or a solver failure."""
    status = sol.res.status
    if cap_h is not None:
        kw = dict(solve_kw)
        kw["objective"] = "time"
        fast_warm = _safe_warm_start(ctx, prob.frame, t0, prob.v_max, prob.v_min, rules=warm_rules)
        fast_warm = _clear_of_exclusion(fast_warm, prob.frame, prob.exclusion, t0, prob.y_lo, prob.y_hi)
        fast = prob.solve(nlp, eta_h=None, warm=fast_warm, budget=budget, **kw)
        if fast.ok and fast.res.duration_total_h > cap_h + 1e-6:
            earliest = t0 + _h_to_td(fast.res.duration_total_h)
            if eta_user_h is None:
                raise WeatherCoverageError(
                    f"the passage cannot be completed within the weather's time span ({cap_h:.1f} h after departure): "
                    f"the minimum-time solve arrives {fast.res.duration_total_h:.1f} h after departure, at {earliest}; "
                    "extend the forecast or pass an ETA"
                )
            raise InfeasibleETA(
                f"the ETA {cap_h:.2f} h after departure cannot be met: the minimum-time solve of this corridor arrives "
                f"{fast.res.duration_total_h:.2f} h after departure, at {earliest} (Ipopt: {fast.res.status}); give an "
                "ETA at or after that, or widen the corridor",
                earliest_arrival=earliest,
            )
    raise SolverFailure(
        f"Ipopt did not solve the corridor problem: status {status!r} (best of {sol.n_solves} solves of the band "
        f"outer loop, {sol.res.iterations} iterations, largest constraint violation {sol.res.max_violation:.3g}); "
        "raise ipopt.max_iter in solver_options or band_solves, use shorter legs, or check the corridor and ETA",
        status=status,
        best_plan=_route_plan(route, ctx, step_nm),
    )


def plan_voyage(
    start: tuple[float, float],
    end: tuple[float, float],
    weather: xr.Dataset | WeatherSampler,
    ship: Ship,
    *,
    departure: Any,
    eta: Any = None,
    objective: Objective = "fuel",
    corridor_width_nm: float = 60.0,
    search_options: Mapping[str, Any] | None = None,
    model: PerformanceModel | None = None,
    rules: BandRules | None = None,
    **optimise_kwargs: Any,
) -> Plan:
    """Search a route, take the corridor around it, and optimise speeds and waypoints in it.

    1. :func:`optroute.search_route` (objective ``"time"`` for a time plan, else ``"fuel"`` — or
       ``"cost"`` with the prices — with the ETA); when the search cannot meet the ETA it is run
       for minimum time instead, and the NLP decides (it may meet an ETA the grid cannot).
    2. ``route.corridor(width_nm=corridor_width_nm)``.
    3. :func:`optimise_corridor` warm-started from the route (its speeds and band sides).

    Parameters
    ----------
    start, end : (float, float)
        (lat, lon) [deg]; ports on land are snapped to the sea by the search.
    weather, ship, departure, eta, objective
        As in :func:`optimise_corridor`.
    corridor_width_nm : float
        Total width of the corridor about the searched route [nm].
    search_options : mapping, optional
        Keyword arguments of :func:`optroute.search_route` (``cell_nm``, ``method``, ``dp_options``,
        ``objective`` to search for another objective than the plan's, ...).
    model, rules
        Shared by the search and the optimiser.
    **optimise_kwargs
        Further keyword arguments of :func:`optimise_corridor`.

    Returns
    -------
    Plan
        Verified; ``solver_stats["search"]`` holds the search's method, cost and statistics.
    """
    from optroute.routing import search_route

    opts = dict(search_options or {})
    search_objective = opts.pop("objective", "time" if objective == "time" else objective)
    if objective == "cost":
        opts.setdefault("fuel_price_per_t", optimise_kwargs.get("fuel_price_per_t", 600.0))
        opts.setdefault("hourly_cost_per_h", optimise_kwargs.get("hourly_cost_per_h", 0.0))
    common = {"departure": departure, "model": model, "rules": rules}
    try:
        route = search_route(start, end, weather, ship, objective=search_objective, eta=eta, **common, **opts)
    except InfeasibleETA:
        route = search_route(start, end, weather, ship, objective="time", **common, **opts)
    corridor = route.corridor(width_nm=corridor_width_nm)
    plan = optimise_corridor(corridor, weather, ship, departure=route.departure, eta=eta, objective=objective,
                             model=model, rules=rules, route=route, **optimise_kwargs)
    stats = dict(plan.solver_stats)
    stats["search"] = {"method": route.method, "objective": route.objective, "cost": route.cost,
                       "fuel_t": route.total_fuel_t, "duration_h": route.total_duration_h,
                       "stats": {k: v for k, v in route.stats.items() if np.isscalar(v)}}
    return replace(plan, solver_stats=stats)
