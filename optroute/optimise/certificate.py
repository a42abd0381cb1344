"""The certificate of the ship: how far a fixed-path, static-weather plan can be from the least fuel.

For a fixed path in weather that does not change in time, and without current, the fuel of a leg
sailed at a constant speed through water ``v`` is a function of ``v`` alone, and the passage
problem separates per leg but for the ETA row ``Σ t ≤ T`` (issue 13, item 5).
:func:`formulations.ship_bound.lagrangian_bound` bounds its optimum from below by Lagrangian
duality with each leg's 1-D minimum taken globally over its allowed speeds, which needs no
convexity. This module builds that bound's inputs from the **referee's own physics**, so the bound
is one of the ship, not of the NLP's fitted power model:

* the path is cut as :meth:`optroute.plan.result.Plan.verify` cuts it
  (:func:`optroute.plan.evaluate.dense_points`, pieces of at most ``step_nm``, both leg ends);
* a leg's fuel rate at ``v`` is ``(v/d) Σ_j ℓ_j fuel_j / sog_j`` over its pieces, with heading, SOG,
  brake power and the IMO SFOC fuel rate from :func:`optroute.physics.passage.evaluate_speeds`, the
  function the referee calls;
* a leg's allowed speeds are those between the engine's limits at every point of it (the MCR and
  the minimum power, with :meth:`Plan.verify`'s relative tolerance, inverted by
  :func:`optroute.physics.performance.max_stw_kn`) and outside every danger band at every point
  (:func:`optroute.physics.safety.forbidden_speed_intervals`, the closed form of the referee's
  :func:`~optroute.physics.safety.is_speed_forbidden`), within the optimiser's speed range.

Every set is taken a little too large (limits widened by the bisection tolerance, bands narrowed by
1e-9 kn): a bound over a superset of the feasible speeds is still a bound. Constraints that do
not depend on the speeds on a fixed path in static weather (land, corridor) are not needed; an
exclusion circle, which does, is left out (the bound stays valid, only looser) and named in
``relaxed``. Weather that changes in time along the path, or a current, makes the leg fuel depend
on the schedule or the heading: the certificate then says why it does not apply.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from formulations.common import FormulationInputError
from formulations.ship_bound import ShipBoundResult, lagrangian_bound
from optroute import units
from optroute.errors import ConfigError, SeaStateError, WeatherCoverageError
from optroute.physics import seaway
from optroute.physics.passage import SeaState, evaluate_speeds
from optroute.physics.performance import max_stw_kn
from optroute.physics.safety import forbidden_speed_intervals, safe_speed_ranges
from optroute.plan.evaluate import PlanContext, dense_points, sample_sea
from optroute.plan.result import Plan
from optroute.units import h_to_timedelta as _h_to_td
from optroute.units import timedelta_to_h as _td_to_h

__all__ = ["FixedPathProblem", "ShipCertificate", "fixed_path_problem", "ship_certificate"]

METHOD = "lagrangian dual"
_SPEED_TOL_KN = 1e-6  # max_stw_kn's bisection tolerance: the limits are widened by it
_BAND_SHRINK_KN = 1e-9  # closed bands narrowed by this: the allowed set is taken a little too large
_STATIC_TIMES = 25  # times the weather is compared at when the dataset's own time axis is not known


def _subset(sea: SeaState, idx: np.ndarray) -> SeaState:
    return SeaState(*(np.asarray(getattr(sea, f))[idx] for f in SeaState.__dataclass_fields__))


@dataclass(frozen=True)
class FixedPathProblem:
    """The inputs of the dual bound for one fixed path in static weather, from the referee's physics.

    Attributes
    ----------
    context : PlanContext
        Ship, performance model, band rules and weather.
    distance_nm : numpy.ndarray, shape (n,)
        Great-circle leg lengths [nm].
    allowed_kn : tuple of tuples of (lo, hi)
        Each leg's allowed speeds through water [kn] (closure of the feasible set, slightly widened).
    point_leg, point_length_nm, point_course_deg : numpy.ndarray, shape (N,)
        The pieces of the legs (midpoints of the referee's resampling): leg index, length [nm],
        course made good [deg true, to].
    point_sea : SeaState
        The (static) sea state at those points.
    """

    context: PlanContext
    distance_nm: np.ndarray
    allowed_kn: tuple[tuple[tuple[float, float], ...], ...]
    point_leg: np.ndarray
    point_length_nm: np.ndarray
    point_course_deg: np.ndarray
    point_sea: SeaState = field(repr=False)

    def fuel_rate_tph(self, leg: np.ndarray, stw_kn: np.ndarray) -> np.ndarray:
        """Fuel rate [t/h] of leg ``leg[i]`` sailed at ``stw_kn[i]`` [kn], as the referee burns it.

        ``(v/d) Σ_j ℓ_j fuel_j / sog_j`` over the leg's pieces, so that ``(d/v) · rate`` is the
        referee's leg fuel [t] (:func:`optroute.plan.evaluate.legs_table`).
        """
        leg = np.asarray(leg, dtype=int).ravel()
        v = np.asarray(stw_kn, dtype=float).ravel()
        n = self.distance_nm.size
        count = np.bincount(self.point_leg, minlength=n)
        first = np.concatenate([[0], np.cumsum(count)[:-1]])
        reps = count[leg]
        pair = np.repeat(np.arange(leg.size), reps)
        offset = np.arange(pair.size) - np.repeat(np.cumsum(reps) - reps, reps)
        pt = first[leg][pair] + offset
        _, sog, _, fuel, _ = evaluate_speeds(
            self.context.ship,
            self.context.model,
            self.context.rules,
            self.point_course_deg[pt],
            _subset(self.point_sea, pt),
            v[pair],
        )
        burnt = np.bincount(pair, weights=self.point_length_nm[pt] * fuel / sog, minlength=leg.size)
        return (v / self.distance_nm[leg] * burnt).reshape(np.shape(stw_kn))


def _engine_limits(ctx: PlanContext, course: np.ndarray, sea: SeaState, v_top: float, rtol: float) -> tuple:
    """Per point: the lowest speed whose power reaches the minimum and the highest within the MCR [kn]."""
    hs = sea.hs_m
    wave_angle = seaway.relative_wave_angle_deg(course, sea.wave_from_deg)
    wind_speed, wind_from = units.wind_uv_to_speed_from_deg(sea.wind_u_ms, sea.wind_v_ms)
    kw = {
        "hs_m": hs,
        "wave_angle_deg": wave_angle,
        "wind_speed_ms": wind_speed,
        "wind_angle_deg": units.wrap_360(wind_from - course),
        "upper_kn": v_top,
        "tol_kn": _SPEED_TOL_KN,
    }
    model = ctx.model
    top = max_stw_kn(model, float(model.mcr_kw) * (1.0 + rtol), **kw)
    bottom = max_stw_kn(model, float(model.min_power_kw) * (1.0 - rtol), **kw)
    # P strictly increasing in V: below the highest speed at most the minimum power, none reaches it
    return np.maximum(bottom - 2 * _SPEED_TOL_KN, 0.0), np.minimum(top + 2 * _SPEED_TOL_KN, v_top)


def _leg_allowed(
    ctx: PlanContext, lo: float, hi: float, course: np.ndarray, sea: SeaState
) -> tuple[tuple[float, float], ...]:
    """[lo, hi] minus every danger band at the leg's points, as closed intervals [kn]."""
    if hi < lo:
        return ()
    bands = []
    for j in range(course.size):
        for iv in forbidden_speed_intervals(
            ctx.ship,
            hs_m=float(sea.hs_m[j]),
            period_s=float(sea.period_s[j]),
            wave_from_deg=float(sea.wave_from_deg[j]),
            heading_deg=float(course[j]),
            rules=ctx.rules,
            max_speed_kn=hi,
        ):
            if iv.hi_kn - iv.lo_kn > 2 * _BAND_SHRINK_KN:
                top = iv.hi_kn if iv.hi_kn >= hi else iv.hi_kn - _BAND_SHRINK_KN  # a band cut at hi reaches it
                bands.append((iv.lo_kn + _BAND_SHRINK_KN, top))
    out = []
    for a, b in safe_speed_ranges(bands, hi):
        a, b = max(a, lo), min(b, hi)
        if b >= a and b > 0:
            out.append((max(a, 1e-6), b))
    return tuple(out)


def _static_reason(
    ctx: PlanContext, lat: np.ndarray, lon: np.ndarray, t0: np.datetime64, window_h: float
) -> str | None:
    """Why the weather along the path is not static over [t0, t0 + window_h] (None when it is)."""
    hours = np.linspace(0.0, window_h, _STATIC_TIMES)
    if ctx.dataset is not None and "time" in ctx.dataset.coords:
        nodes = np.asarray(ctx.dataset["time"].values, dtype="datetime64[ns]")
        inside = _td_to_h(nodes - t0)
        hours = np.union1d(hours, inside[(inside > 0) & (inside < window_h)])
    ref, covered = sample_sea(ctx.sampler, np.full(lat.shape, t0), lat, lon)
    if not covered.all() or not ref.navigable.all():
        return "the path has no-passage or uncovered weather at the departure"
    for h in hours[1:]:
        sea, covered = sample_sea(ctx.sampler, np.full(lat.shape, t0 + _h_to_td(float(h))), lat, lon)
        if not covered.all():
            return f"the weather does not cover the path {h:.1f} h after departure"
        for name in SeaState.__dataclass_fields__:
            a, b = np.asarray(getattr(ref, name)), np.asarray(getattr(sea, name))
            if not np.allclose(a, b, rtol=1e-12, atol=1e-12, equal_nan=True):  # NaN: a wind not known, throughout
                return f"the weather changes in time along the path ({name} at {h:.1f} h after departure)"
    return None


def fixed_path_problem(
    context: PlanContext,
    waypoints: np.ndarray,
    *,
    departure: np.datetime64,
    window_h: float,
    v_min_kn: float = 0.0,
    v_max_kn: float = 40.0,
    step_nm: float = 5.0,
    power_rtol: float = 1e-6,
) -> FixedPathProblem | str:
    """The dual bound's inputs for the path through ``waypoints``, or why they cannot be built.

    Parameters
    ----------
    context : PlanContext
        Ship, model, band rules, weather (as a plan's).
    waypoints : numpy.ndarray, shape (n + 1, 2)
        (lat, lon) [deg]; the legs are the great circles between them.
    departure : numpy.datetime64
        [UTC].
    window_h : float
        How long after departure the weather must be static [h] (the latest arrival considered).
    v_min_kn, v_max_kn : float
        The optimiser's speed range [kn].
    step_nm : float
        The referee's resampling step [nm] (:meth:`Plan.verify`'s).
    power_rtol : float
        The referee's relative tolerance on the power limits.

    Returns
    -------
    FixedPathProblem or str
        The problem, or the reason it does not apply (weather changing in time, a current,
        no-passage weather on the path).
    """
    wp = np.asarray(waypoints, dtype=float)
    leg, frac, length, lat, lon, course, d = dense_points(wp, step_nm)
    reason = _static_reason(context, lat, lon, departure, window_h)
    if reason is not None:
        return reason
    sea, _ = sample_sea(context.sampler, np.full(lat.shape, departure), lat, lon)
    if np.any(np.hypot(sea.current_u_ms, sea.current_v_ms) > 1e-12):
        return "a current makes the speed over ground depend on the heading"
    bottom, top = _engine_limits(context, course, sea, float(v_max_kn), power_rtol)
    n = d.size
    lo = np.full(n, float(v_min_kn))
    hi = np.full(n, float(v_max_kn))
    np.maximum.at(lo, leg, bottom)
    np.minimum.at(hi, leg, top)
    allowed = tuple(
        _leg_allowed(context, float(lo[k]), float(hi[k]), course[leg == k], _subset(sea, np.flatnonzero(leg == k)))
        for k in range(n)
    )
    mid = length > 0
    return FixedPathProblem(
        context=context,
        distance_nm=d,
        allowed_kn=allowed,
        point_leg=leg[mid],
        point_length_nm=length[mid],
        point_course_deg=course[mid],
        point_sea=_subset(sea, np.flatnonzero(mid)),
    )


@dataclass(frozen=True)
class ShipCertificate:
    """A plan's distance to the Lagrangian lower bound of its fixed path in static weather.

    Attributes
    ----------
    method : str
        ``"lagrangian dual"``, or ``"not applicable"`` (see ``reason``).
    objective : str
        ``"fuel"`` (bound in t) or ``"cost"`` (bound in currency).
    plan_objective : float
        The plan's objective as the referee scores it (fuel [t] or cost).
    bound : float
        Lower bound on the least objective over every schedule on the path (``inf`` when no
        schedule meets the ETA; NaN when not applicable).
    gap : float
        ``(plan_objective − bound) / |plan_objective|``.
    reason : str or None
        Why the certificate does not apply.
    relaxed : tuple of str
        Constraints of the plan left out of the bound (it stays valid, only looser).
    dual : ShipBoundResult or None
        The formulation's result (λ*, the recovered schedule, its status, sampling margin).
    time_s : float
        Wall-clock time of building the inputs and the bound [s].
    """

    method: str
    objective: str
    plan_objective: float
    bound: float
    gap: float
    reason: str | None = None
    relaxed: tuple[str, ...] = ()
    dual: ShipBoundResult | None = field(default=None, repr=False)
    time_s: float = 0.0

    def as_stats(self) -> dict[str, Any]:
        """The entry for ``solver_stats["certificate"]``: ``bound_t`` (or ``bound`` for cost), ``gap``, ``method``."""
        if self.dual is None:
            return {"method": self.method, "gap": self.gap, "reason": self.reason}
        key = "bound_t" if self.objective == "fuel" else "bound"
        dual = self.dual
        return {
            "method": self.method,
            key: self.bound,
            "gap": self.gap,
            "status": dual.status,
            "lambda_t_per_h" if self.objective == "fuel" else "lambda_per_h": dual.lambda_tph,
            "recovered_schedule_objective": dual.primal_objective,
            "sampling_margin": dual.sampling_margin,
            "evaluations": dual.evaluations,
            "relaxed": list(self.relaxed),
            "time_s": self.time_s,
        }


def ship_certificate(
    plan: Plan,
    *,
    eta_h: float | None = None,
    eta_mode: str | None = None,
    objective: str = "fuel",
    fuel_price: float = 1.0,
    hourly_cost: float = 0.0,
    v_min_kn: float = 0.0,
    v_max_kn: float = 40.0,
    step_nm: float = 5.0,
    power_rtol: float = 1e-6,
) -> ShipCertificate:
    """Lower bound on the least objective over every schedule on ``plan``'s path, and the plan's gap to it.

    Parameters
    ----------
    plan : Plan
        Its waypoints fix the path; its context gives ship, model, rules and weather.
    eta_h : float, optional
        Passage time allowed [h after departure]; default the context's ETA, else none (then the
        weather must be static up to the slowest passage the speed range allows).
    eta_mode : {"le", "eq"}, optional
        Default the context's.
    objective : {"fuel", "cost"}
        Fuel [t], or ``fuel_price · fuel + hourly_cost · duration``.
    fuel_price, hourly_cost : float
        Cost weights [currency/t], [currency/h].
    v_min_kn, v_max_kn : float
        The speed range [kn] the plan was chosen in (the optimiser's ``speed_range_kn``).
    step_nm, power_rtol : float
        The referee's resampling step [nm] and power tolerance.

    Returns
    -------
    ShipCertificate

    Raises
    ------
    ConfigError
        An unknown objective or ETA mode, or a non-positive ETA.
    """
    started = time.perf_counter()
    ctx = plan.context
    if objective not in ("fuel", "cost"):
        raise ConfigError(f"objective={objective!r} has no dual certificate here; use 'fuel' or 'cost'")
    mode = eta_mode or ctx.eta_mode
    if mode not in ("le", "eq"):
        raise ConfigError(f"eta_mode={mode!r} is not known; use 'le' or 'eq'")
    if eta_h is None and ctx.eta is not None:
        eta_h = float(_td_to_h(ctx.eta - plan.departure))
    if eta_h is not None and not (math.isfinite(eta_h) and eta_h > 0):
        raise ConfigError(f"eta_h={eta_h} must be a positive number of hours after departure")
    price, hourly = (1.0, 0.0) if objective == "fuel" else (float(fuel_price), float(hourly_cost))
    plan_obj = price * plan.total_fuel_t + hourly * plan.duration_h
    length = float(np.sum(plan.legs["distance_nm"]))
    window = eta_h if eta_h is not None else length / max(v_min_kn, 1.0)
    prob = fixed_path_problem(
        ctx,
        plan.waypoints,
        departure=plan.departure,
        window_h=window,
        v_min_kn=v_min_kn,
        v_max_kn=v_max_kn,
        step_nm=step_nm,
        power_rtol=power_rtol,
    )
    if isinstance(prob, str):
        return ShipCertificate("not applicable", objective, plan_obj, math.nan, math.nan, reason=prob)
    dual = lagrangian_bound(
        prob.distance_nm,
        prob.allowed_kn,
        prob.fuel_rate_tph,
        eta_h=eta_h,
        eta_mode=mode,
        fuel_price=price,
        hourly_cost=hourly,
    )
    gap = (plan_obj - dual.bound) / abs(plan_obj) if plan_obj != 0 else math.nan
    return ShipCertificate(
        method=METHOD,
        objective=objective,
        plan_objective=plan_obj,
        bound=dual.bound,
        gap=float(gap),
        relaxed=("exclusion",) if ctx.exclusion is not None else (),
        dual=dual,
        time_s=time.perf_counter() - started,
    )


def dual_schedule(
    context: PlanContext,
    waypoints: np.ndarray,
    *,
    departure: np.datetime64,
    eta_h: float,
    eta_mode: str = "le",
    objective: str = "fuel",
    fuel_price: float = 1.0,
    hourly_cost: float = 0.0,
    v_min_kn: float = 0.0,
    v_max_kn: float = 40.0,
    step_nm: float = 5.0,
    inset_kn: float = 0.01,
) -> np.ndarray | None:
    """Speeds through water [kn] per leg from the dual's primal schedule, each ``inset_kn`` inside its interval.

    On a fixed path in static weather the dual bound's recovered schedule is a near-optimal discrete
    plan of the ship itself, bands included; moved ``inset_kn`` inside its allowed intervals it is a
    start the referee accepts (the optimiser verifies it before using it). ``None`` where the bound
    does not apply (weather changing in time, a current) or finds no schedule.
    """
    if objective not in ("fuel", "cost"):
        return None
    prob = fixed_path_problem(
        context, waypoints, departure=departure, window_h=eta_h, v_min_kn=v_min_kn, v_max_kn=v_max_kn, step_nm=step_nm
    )
    if isinstance(prob, str):
        return None
    inner = [[(a + inset_kn, b - inset_kn) for a, b in ivls if b - a > 2 * inset_kn] for ivls in prob.allowed_kn]
    if not all(inner):
        return None
    price, hourly = (1.0, 0.0) if objective == "fuel" else (float(fuel_price), float(hourly_cost))
    try:
        dual = lagrangian_bound(
            prob.distance_nm,
            inner,
            prob.fuel_rate_tph,
            eta_h=eta_h,
            eta_mode=eta_mode,
            fuel_price=price,
            hourly_cost=hourly,
        )
    except (SeaStateError, WeatherCoverageError, FormulationInputError):
        return None
    v = np.asarray(dual.primal_speed_kn, dtype=float)
    return v if v.size == prob.distance_nm.size and np.all(np.isfinite(v) & (v > 0)) else None


def certificate_stats(
    fitted: Mapping[str, Any], plan: Plan, *, fixed: bool, objective: str, **kw: Any
) -> dict[str, Any]:
    """``solver_stats["certificate"]`` of an optimiser's plan: the ship's certificate where it applies.

    ``fitted`` is the optimiser's own certificate of the model inside the NLP; it is kept under
    ``"nlp_model"``. Keyword arguments go to :func:`ship_certificate`.
    """
    if not fixed:
        reason = "the path is free (half-width > 0)"
    elif objective not in ("fuel", "cost"):
        reason = f"objective {objective!r} (every leg at its top speed)"
    else:
        try:
            stats = ship_certificate(plan, objective=objective, **kw).as_stats()
        except (SeaStateError, WeatherCoverageError, FormulationInputError) as exc:
            # a model that cannot be evaluated at some speed of the range (a power table's edge, say): the plan
            # stands, its certificate says why there is none
            stats = {"method": "not applicable", "gap": math.nan, "reason": f"{type(exc).__name__}: {exc}"}
        return {**stats, "nlp_model": dict(fitted)}
    return {"method": "not applicable", "gap": math.nan, "reason": reason, "nlp_model": dict(fitted)}
