"""A corridor problem prepared once and solved for many ETAs: :class:`PreparedCorridor`.

:func:`optroute.optimise_corridor` is set-up then solves: the NLP's weather grid
(:func:`~optroute.optimise.nlp_inputs.weather_grid`), the lateral bounds and land mask
(:func:`~optroute.optimise.nlp_inputs.lateral_bounds`), the power fit
(:func:`~optroute.optimise.nlp_inputs.fit_power_model`), the :class:`~optroute.optimise.nlp_solve.Problem`, and
the CasADi builds of :class:`formulations.speed_nlp.SpeedNLP`. Only the last solves depend on the
ETA (it is a solve parameter of the NLP), so a fuel-versus-ETA front (:func:`optroute.studies.tradeoff`)
prepares the corridor once, for a horizon covering all its ETAs, and solves each ETA with
:meth:`PreparedCorridor.solve` — the verification loop, tightening, :class:`InfeasibleETA` /
:class:`SolverFailure` behaviour and ``solver_stats`` of :func:`optimise_corridor`, which is this
class prepared for its one ETA.

Builds are cached by the tightening state that shapes them (band back-offs, samples per leg,
exclusion radius, lateral bounds); the load limits are solve-time constraint bounds and the per-leg
power factors a solve parameter, so the fit corrections and power tightenings of the verification
loop, and every ETA after the first, cost a solve, not a build. :class:`Learnt` carries what the verification loop learnt at one ETA (the
corrected power factor, the load limit and band back-offs) to the next one's start.
"""

from __future__ import annotations

import math
import shutil
import time as _time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np
import xarray as xr

from formulations.speed_nlp import POWER_TERMS, jit_compiler
from optroute._checks import finite
from optroute.errors import ConfigError, SolverFailure, WeatherCoverageError
from optroute.optimise.certificate import certificate_stats
from optroute.optimise.fit_correction import fit_correction
from optroute.optimise.min_time import clean_start
from optroute.optimise.nlp_inputs import build_frame, dataset_spacing, fit_power_model, lateral_bounds, weather_grid
from optroute.optimise.nlp_solve import (
    Problem,
    Solved,
    Tightening,
    certificate,
    clear_of_exclusion,
    desired_speed,
    route_warm_start,
    safe_warm_start,
    warm_rules,
)
from optroute.physics.performance import PerformanceModel, default_model
from optroute.physics.safety import BandRules
from optroute.physics.ship import Ship
from optroute.plan.result import Exclusion, Plan, PlanContext, Violation
from optroute.search.route import Corridor, Route
from optroute.units import as_utc_time as _as_time
from optroute.units import format_utc
from optroute.units import h_to_timedelta as _h_to_td
from optroute.units import timedelta_to_h as _hours
from optroute.weather.sample import WeatherSampler

__all__ = ["Learnt", "PreparedCorridor"]

Objective = Literal["time", "fuel", "cost"]
ProgressFn = Callable[[str, float], None]


@dataclass(frozen=True)
class Learnt:
    """What the verification loop of one solve learnt: a start for a neighbouring ETA's tightening.

    Attributes
    ----------
    leg_power_factor : numpy.ndarray
        Per-leg factor on the fitted power [-], shape (N,), positive (fit corrections, load tightening).
    leg_power_terms : mapping of str to numpy.ndarray, optional
        The other terms of the NLP's per-leg power multiplier (speed elasticity, time slope and their
        reference points; :meth:`formulations.speed_nlp.SpeedNLP.set_leg_power_factor`).
    max_load : float
        Upper engine load limit of the NLP [fraction of MCR], in (0, 1].
    band_margin, band_hs_margin : float
        Band-edge and Hs-threshold back-offs [-], >= 0.
    """

    leg_power_factor: np.ndarray
    max_load: float
    band_margin: float
    band_hs_margin: float
    leg_power_terms: Mapping[str, np.ndarray] | None = None

    def __post_init__(self) -> None:
        f = np.asarray(self.leg_power_factor, dtype=float)
        if f.ndim != 1 or not np.all(np.isfinite(f) & (f > 0)):
            raise ConfigError(f"Learnt.leg_power_factor must be a 1-D array of positive numbers, got {f!r}")
        object.__setattr__(self, "leg_power_factor", f.copy())
        if self.leg_power_terms is not None:
            terms = {}
            for name, a in self.leg_power_terms.items():
                a = np.asarray(a, dtype=float)
                if name not in POWER_TERMS[1:] or a.shape != f.shape or not np.all(np.isfinite(a)):
                    raise ConfigError(
                        f"Learnt.leg_power_terms[{name!r}] must be one of {POWER_TERMS[1:]}, a finite array shaped "
                        f"like leg_power_factor {f.shape}; got {a!r}; pass the learnt state of one plan"
                    )
                terms[name] = a.copy()
            object.__setattr__(self, "leg_power_terms", terms)
        if not (0.0 < float(self.max_load) <= 1.0):
            raise ConfigError(f"Learnt.max_load={self.max_load!r} must be in (0, 1] (a fraction of MCR)")
        for name in ("band_margin", "band_hs_margin"):
            finite(f"Learnt.{name}", getattr(self, name), minimum=0.0, error=ConfigError)

    @classmethod
    def from_plan(cls, plan: Plan) -> Learnt | None:
        """The learnt state of a plan returned by :meth:`PreparedCorridor.solve` (None for another plan)."""
        s = plan.solver_stats
        if "leg_power_factor" not in s:
            return None
        return cls(
            np.asarray(s["leg_power_factor"], dtype=float),
            float(s["max_load"]),
            float(s["band_margin"]),
            float(s["band_hs_margin"]),
            {k: np.asarray(v, dtype=float) for k, v in s["leg_power_terms"].items()}
            if "leg_power_terms" in s
            else None,
        )


def _emit(progress: ProgressFn | None, stage: str, fraction: float) -> None:
    if progress is not None:
        progress(stage, float(fraction))


def _check_jit(jit: bool) -> bool:
    """``jit`` as a bool; True needs a C compiler for CasADi's ``"shell"`` plugin."""
    if not isinstance(jit, bool | np.bool_):
        raise ConfigError(f"jit={jit!r} must be True or False")
    if jit and shutil.which(jit_compiler()) is None:
        raise ConfigError(
            f"jit=True compiles the NLP's derivatives with a C compiler, and {jit_compiler()!r} is not on the PATH; "
            "install gcc or name another compiler in the CC environment variable, or use jit=False"
        )
    return bool(jit)


class PreparedCorridor:
    """The corridor NLP set up once for a range of ETAs; :meth:`solve` solves one ETA.

    Parameters
    ----------
    corridor, weather, ship, departure, model, rules, max_leg_nm, samples_per_leg, fuel_price_per_t,
    hourly_cost_per_h, exclusion, speed_range_kn, band_solves, fit_corrections, max_retries,
    band_margin, band_hs_margin, verify_step_nm, solver_options, use_land_mask, jit
        As in :func:`optroute.optimise_corridor`.
    latest_eta : datetime64 or str, optional
        The latest ETA to be solved [UTC]: the weather grid runs to just after it, and the power fit
        covers the mean speed it needs. Default: the end of the weather's time span when
        ``objective`` is ``"fuel"`` or ``"cost"``, else a free-arrival horizon (1.3 × the passage at
        half the design speed), as :func:`optimise_corridor` without an ETA.
    objective : {"fuel", "time", "cost"}
        Only for the default ``latest_eta``.

    Notes
    -----
    Preparing for the latest ETA ``T`` gives exactly the problem :func:`optimise_corridor` sets up
    for ``eta=T``; an earlier ETA is solved on the same (longer) weather grid and wider power fit.
    """

    def __init__(
        self,
        corridor: Corridor,
        weather: xr.Dataset | WeatherSampler,
        ship: Ship,
        *,
        departure: Any,
        latest_eta: Any = None,
        objective: Objective = "fuel",
        model: PerformanceModel | None = None,
        rules: BandRules | None = None,
        max_leg_nm: float = 50.0,
        samples_per_leg: int = 3,
        fuel_price_per_t: float = 600.0,
        hourly_cost_per_h: float = 0.0,
        exclusion: Exclusion | None = None,
        speed_range_kn: tuple[float, float] | None = None,
        band_solves: int = 12,
        fit_corrections: int = 6,
        max_retries: int = 4,
        band_margin: float = 0.005,
        band_hs_margin: float = 0.05,
        verify_step_nm: float = 5.0,
        solver_options: Mapping[str, Any] | None = None,
        use_land_mask: bool | None = None,
        progress: ProgressFn | None = None,
        jit: bool = False,
    ) -> None:
        if objective not in ("time", "fuel", "cost"):
            raise ConfigError(f"objective={objective!r} is not known; use 'time', 'fuel' or 'cost'")
        if not isinstance(corridor, Corridor):
            raise ConfigError(f"corridor must be an optroute.Corridor, got {type(corridor).__name__}")
        t0 = _as_time(departure, "departure")
        eta_t = _as_time(latest_eta, "eta") if latest_eta is not None else None
        eta_user_h = _hours(eta_t - t0) if eta_t is not None else None
        if eta_user_h is not None and eta_user_h <= 0:
            raise ConfigError(
                f"eta={format_utc(eta_t)} is not after departure={format_utc(t0)}; give an arrival later than the departure"
            )
        if not (isinstance(samples_per_leg, int | np.integer) and samples_per_leg >= 1):
            raise ConfigError(f"samples_per_leg={samples_per_leg!r} must be an integer >= 1")
        self.fuel_price = float(
            finite("fuel_price_per_t", fuel_price_per_t, minimum=0.0, strict=True, error=ConfigError)
        )
        self.hourly = float(finite("hourly_cost_per_h", hourly_cost_per_h, minimum=0.0, error=ConfigError))
        self.margin0 = float(finite("band_margin", band_margin, minimum=0.0, error=ConfigError))
        self.hs_margin0 = float(finite("band_hs_margin", band_hs_margin, minimum=0.0, error=ConfigError))
        if isinstance(weather, WeatherSampler):
            sampler, ds = weather, None
        elif isinstance(weather, xr.Dataset):
            sampler, ds = WeatherSampler(weather), weather
        else:
            raise ConfigError(
                f"weather must be a canonical xarray.Dataset or a WeatherSampler, got {type(weather).__name__}"
            )
        n_wp = len(corridor.waypoints)
        for k, (lat_k, lon_k) in enumerate(corridor.waypoints):  # named before any grid node is sampled
            role = "start, " if k == 0 else ("end, " if k == n_wp - 1 else "")
            sampler.require_area(lat_k, lon_k, what=f"{role}corridor point {k}")
        model = model if model is not None else default_model(ship)
        rules = rules if rules is not None else BandRules()
        if speed_range_kn is None:
            v_min, v_max = 3.0, float(min(ship.max_calm_speed_kn, 40.0))
        else:
            v_min, v_max = (
                float(x) for x in finite("speed_range_kn", speed_range_kn, minimum=0.0, strict=True, error=ConfigError)
            )
            if v_max <= v_min:
                raise ConfigError(f"speed_range_kn={speed_range_kn!r} needs lower < upper")
        _emit(progress, "corridor", 0.0)

        # ---- time window -------------------------------------------------------------
        ext = sampler.extent
        data_end_h = _hours(ext["time"][1] - t0) if sampler.time_policy == "raise" else math.inf
        if sampler.time_policy == "raise" and _hours(ext["time"][0] - t0) > 1e-9:
            raise WeatherCoverageError(
                f"departure={format_utc(t0)} is before the weather's first time {format_utc(ext['time'][0])}; depart later "
                "or extend the "
                "forecast"
            )
        if data_end_h <= 0:
            raise WeatherCoverageError(
                f"departure={format_utc(t0)} is at or after the weather's last time {format_utc(ext['time'][1])}; "
                "extend the forecast"
            )
        if eta_user_h is not None and eta_user_h > data_end_h + 1e-9:
            raise WeatherCoverageError(
                f"eta={format_utc(eta_t)} is after the weather's last time {format_utc(ext['time'][1])}: the passage could not be checked "
                "against the weather; extend the forecast, give an earlier eta, or open the weather with "
                "time_policy='hold'"
            )
        cap_h = (
            eta_user_h
            if eta_user_h is not None
            else (data_end_h if objective != "time" and math.isfinite(data_end_h) else None)
        )
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
        # short NLP legs (a small max_leg_nm) do not refine it: the grid would grow with N and its spline's build
        # dominate the solve (15 s against 1 s at 500 legs); the corridor's own vertices (where it turns) bound it
        ds_nm = float(
            min(np.clip(0.5 * ds_ds if ds_ds else 15.0, 5.0, 30.0), max(float(np.max(corridor.leg_distance_nm)), 5.0))
        )
        hw_max = float(np.max(cor.half_width_nm))
        dy_nm = float(np.clip(ds_nm / 2.0, 2.0, max(hw_max / 2.0, 2.0)))
        _emit(progress, "weather grid", 0.05)
        grid, samples = weather_grid(frame, sampler, departure=t0, t_end_h=horizon, dt_h=dt_h, ds_nm=ds_nm, dy_nm=dy_nm)
        window = t0 + np.array(
            [_h_to_td(h) for h in np.linspace(0.0, horizon, int(min(25, max(2, horizon / dt_h + 1))))]
        )
        _emit(progress, "lateral bounds", 0.1)
        y_lo, y_hi = lateral_bounds(
            frame,
            sampler=sampler,
            dataset=ds,
            times=window,
            use_land_mask=use_land_mask,
            step_nm=max(1.0, min(5.0, hw_max / 10.0)) if hw_max > 0 else 1.0,
        )
        _emit(progress, "power fit", 0.15)
        v_ref = length / cap_h if cap_h else 0.75 * v_max
        fit = fit_power_model(
            model,
            hs_m=samples.hs_m,
            wind_ms=samples.wind_ms,
            v_min_kn=max(v_min, 0.5 * v_ref),
            v_max_kn=v_max,
            min_load=float(model.min_power_kw) / float(model.mcr_kw),
        )
        self.corridor, self.ship, self.model, self.rules = corridor, ship, model, rules
        self.sampler, self.dataset, self.exclusion, self.use_land_mask = sampler, ds, exclusion, use_land_mask
        self.departure, self.data_end_h, self.horizon_h, self.prepared_cap_h = t0, data_end_h, horizon, cap_h
        self.frame, self.grid, self.samples, self.fit = frame, grid, samples, fit
        self.y_lo, self.y_hi, self.v_min, self.v_max, self.length_nm = y_lo, y_hi, v_min, v_max, length
        self.samples_per_leg = int(samples_per_leg)
        self.band_solves, self.fit_corrections, self.max_retries = (
            int(band_solves),
            int(fit_corrections),
            int(max_retries),
        )
        self.verify_step_nm = float(verify_step_nm)
        self.problem = Problem(
            frame=frame,
            grid=grid,
            samples=samples,
            fit=fit,
            ship=ship,
            rules=rules,
            y_lo=y_lo,
            y_hi=y_hi,
            v_min=v_min,
            v_max=v_max,
            exclusion=exclusion,
            departure=t0,
            solver_options=solver_options,
            jit=_check_jit(jit),
        )

    # ------------------------------------------------------------------ one ETA

    def plan_context(self, eta: np.datetime64 | None = None, eta_mode: Literal["le", "eq"] = "le") -> PlanContext:
        """The :class:`PlanContext` its plans are evaluated and verified in (ETA [UTC] and mode as in :meth:`solve`)."""
        return PlanContext(
            ship=self.ship,
            model=self.model,
            rules=self.rules,
            sampler=self.sampler,
            dataset=self.dataset,
            corridor=self.corridor,
            eta=eta,
            eta_mode=eta_mode,
            exclusion=self.exclusion,
            use_land_mask=self.use_land_mask,
        )

    def _tightening(self, learnt: Learnt | None) -> Tightening:
        n = self.frame.n_legs
        st = Tightening(
            factor=np.ones(n),
            max_load=1.0,
            min_load=self.fit.power.min_load,
            widen=self.margin0,
            hs_margin=self.hs_margin0,
            samples_per_leg=self.samples_per_leg,
            bound_scale=np.ones(n + 1),
            y_lo=self.y_lo.copy(),
            y_hi=self.y_hi.copy(),
        )
        if learnt is not None:
            if learnt.leg_power_factor.shape != (n,):
                raise ConfigError(
                    f"learnt.leg_power_factor has {learnt.leg_power_factor.size} legs, this corridor {n}; pass the "
                    "learnt state of a plan of the same prepared corridor"
                )
            st.factor = learnt.leg_power_factor.copy()
            if learnt.leg_power_terms is not None:
                st.power_terms = {k: v.copy() for k, v in learnt.leg_power_terms.items()}
            st.max_load = float(learnt.max_load)
            st.widen, st.hs_margin = max(st.widen, learnt.band_margin), max(st.hs_margin, learnt.band_hs_margin)
            st.log.append("started from a neighbouring solve's tightening")
        return st

    def solve(
        self,
        eta: Any = None,
        *,
        eta_mode: Literal["le", "eq"] = "le",
        objective: Objective = "fuel",
        warm_plan: Plan | None = None,
        route: Route | None = None,
        learnt: Learnt | None = None,
        progress: ProgressFn | None = None,
    ) -> Plan:
        """Solve one ETA: :func:`optroute.optimise_corridor` on the prepared problem.

        Parameters
        ----------
        eta, eta_mode, objective, warm_plan, route, progress
            As in :func:`optimise_corridor`; ``eta`` at most the prepared ``latest_eta``.
        learnt : Learnt, optional
            The tightening to start from (e.g. ``Learnt.from_plan(neighbour)``); default the untightened
            problem, as :func:`optimise_corridor`.

        Returns
        -------
        Plan
            As :func:`optimise_corridor`'s; ``solver_stats`` also holds ``leg_power_factor`` (the returned
            solve's, a list) and ``prepared_horizon_h``.

        Raises
        ------
        ConfigError
            An ETA after the prepared horizon (prepare with a later ``latest_eta``), or a free-arrival
            fuel/cost solve on a corridor prepared for an ETA.
        InfeasibleETA, SolverFailure, WeatherCoverageError
            As :func:`optimise_corridor`.
        """
        from optroute.optimise.rescue import (
            _certificate_reason,
            _feasible_iterate,
            _first_failure,
            _longer,
            _plan_warm_start,
            _route_plan,
            _score,
            _tighten,
            _to_plan,
            _to_plan_xy,
        )

        started = _time.perf_counter()
        if objective not in ("time", "fuel", "cost"):
            raise ConfigError(f"objective={objective!r} is not known; use 'time', 'fuel' or 'cost'")
        if eta_mode not in ("le", "eq"):
            raise ConfigError(f"eta_mode={eta_mode!r} is not known; use 'le' (arrive by) or 'eq' (arrive at)")
        t0, prob, frame = self.departure, self.problem, self.frame
        eta_t = _as_time(eta, "eta") if eta is not None else None
        eta_user_h = _hours(eta_t - t0) if eta_t is not None else None
        if eta_user_h is not None and eta_user_h <= 0:
            raise ConfigError(
                f"eta={format_utc(eta_t)} is not after departure={format_utc(t0)}; give an arrival later than the departure"
            )
        data_end_h = self.data_end_h
        if eta_user_h is not None and eta_user_h > data_end_h + 1e-9:
            raise WeatherCoverageError(
                f"eta={eta_t} is after the weather's last time: the passage could not be checked against the "
                "weather; extend the forecast, give an earlier eta, or open the weather with time_policy='hold'"
            )
        cap_h = (
            eta_user_h
            if eta_user_h is not None
            else (data_end_h if objective != "time" and math.isfinite(data_end_h) else None)
        )
        prepared = self.prepared_cap_h
        if cap_h is not None and prepared is not None and cap_h > prepared + 1e-9:
            raise ConfigError(
                f"eta {cap_h:.3f} h after departure is after the prepared corridor's latest ETA ({prepared:.3f} h); "
                "prepare it with a later latest_eta"
            )
        if cap_h is not None and prepared is None and cap_h * 1.02 + 1.0 > self.horizon_h + 1e-9:
            raise ConfigError(
                f"eta {cap_h:.3f} h after departure needs a weather grid past the prepared {self.horizon_h:.1f} h; "
                "prepare the corridor with latest_eta"
            )
        fuel_price, hourly = self.fuel_price, self.hourly
        sampler, exclusion, rules, v_min, v_max = self.sampler, self.exclusion, self.rules, self.v_min, self.v_max
        length, step_nm = self.length_nm, self.verify_step_nm
        ctx = self.plan_context(eta_t, eta_mode)
        build_before = prob.build_time_s
        st = self._tightening(learnt)
        if warm_plan is not None:
            warm = _plan_warm_start(warm_plan, frame)
        elif route is not None:
            warm = route_warm_start(route, frame)
        else:
            warm = clean_start(
                ctx,
                frame,
                t0,
                desired_kn=desired_speed(length, cap_h, v_max, objective),
                v_min_kn=v_min,
                v_max_kn=v_max,
                eta_h=cap_h,
                rules=warm_rules(rules, st),
                log=st.log,
            )
        warm = clear_of_exclusion(warm, frame, exclusion, t0, self.y_lo, self.y_hi)
        fresh_start = False
        if (warm_plan is not None or route is not None) and learnt is None and self.fit_corrections > 0:
            # correct the fit where the given start is, so that the first solve sees the true model's power and
            # slopes there (a start from a global search is not left for the fit's own optimum)
            nlp0 = prob.build(st)
            times0 = nlp0.consistent_times(warm["offset_nm"], warm["stw_kn"])
            start_plan = _to_plan_xy(ctx, frame, warm["offset_nm"], warm["stw_kn"], t0, step_nm=step_nm)
            corr = fit_correction(ctx, start_plan, nlp0, warm["offset_nm"], warm["stw_kn"], times0, step_nm=step_nm)
            st.factor, st.power_terms = corr.factor, dict(corr.terms)
            st.log.append(f"fit corrected at the given start (level off by up to {corr.level_error:.2%})")
        solve_kw = {"eta_mode": eta_mode, "objective": objective, "fuel_price": fuel_price, "hourly_cost": hourly}

        best: tuple[float, Plan, Solved, float | None, dict[str, Any]] | None = None
        stale = 0  # clean solves since the best one
        last_violations: list[Violation] = []
        last: Solved | None = None
        solve_time = 0.0
        iterations = 0
        total_attempts = self.max_retries + self.fit_corrections + 1
        for attempt in range(total_attempts):
            _emit(progress, "solve", 0.2 + 0.7 * attempt / total_attempts)
            nlp = prob.build(st)
            eta_solve = None if cap_h is None else cap_h - st.eta_shift_h
            if eta_solve is not None and eta_solve <= 0:
                break
            t_s = _time.perf_counter()
            sol = prob.solve(nlp, eta_h=eta_solve, warm=warm, budget=self.band_solves, **solve_kw)
            solve_time += _time.perf_counter() - t_s
            iterations += int(sol.res.iterations)
            if not sol.ok and attempt > 0 and _feasible_iterate(sol.res, ctx, frame, t0, step_nm):
                st.log.append(f"attempt {attempt}: kept Ipopt's last iterate ({sol.res.status}): its plan verifies")
                sol = replace(sol, ok=True)
            if not sol.ok and attempt > 0 and not fresh_start:
                # the tightened problem failed from the last solution: once more from a safe warm start
                fresh_start = True
                fresh = safe_warm_start(
                    ctx,
                    frame,
                    t0,
                    desired_speed(length, eta_solve, v_max, objective),
                    v_min,
                    rules=warm_rules(rules, st),
                )
                fresh = clear_of_exclusion(fresh, frame, exclusion, t0, *prob.bounds(st))
                sol = prob.solve(nlp, eta_h=eta_solve, warm=fresh, budget=self.band_solves, **solve_kw)
                iterations += int(sol.res.iterations)
            if not sol.ok and attempt == 0:
                # an unreachable ETA (InfeasibleETA / WeatherCoverageError), a hard start, or a solver failure
                sol = _first_failure(
                    prob,
                    nlp,
                    sol,
                    longer=lambda st=st: _longer(prob, st, sampler, data_end_h, self.horizon_h),
                    ctx=ctx,
                    cap_h=cap_h,
                    eta_user_h=eta_user_h,
                    t0=t0,
                    route=route,
                    budget=self.band_solves,
                    step_nm=step_nm,
                    solve_kw=solve_kw,
                    warm_rules=warm_rules(rules, st),
                    first_warm=warm,
                    log=st.log,
                )
                iterations += int(sol.res.iterations)
            if not sol.ok:
                st.log.append(
                    f"attempt {attempt}: Ipopt {sol.res.status} after tightening; keeping the last clean plan"
                )
                break
            last = sol
            plan = _to_plan(ctx, frame, sol.res, t0, step_nm=step_nm)
            violations = plan.verify(step_nm=step_nm)
            warm = {"offset_nm": sol.res.offset_nm, "stw_kn": sol.res.stw_kn}
            if not violations:
                score = _score(plan, objective, fuel_price, hourly)
                if best is None or score < best[0] - 1e-12 * max(1.0, abs(best[0])):
                    snapshot = {
                        "max_load": st.max_load,
                        "band_margin": st.widen,
                        "band_hs_margin": st.hs_margin,
                        "bands": list(prob.band_names),
                        "leg_power_factor": st.factor.tolist(),
                        "leg_power_terms": {k: v.tolist() for k, v in st.power_terms.items()},
                        "_min_load": st.min_load,
                    }
                    best, stale = (score, plan, sol, eta_solve, snapshot), 0
                else:
                    stale += 1
                if st.corrections >= self.fit_corrections or stale >= 2:
                    break  # corrections used up, or two corrected solves in a row no better than the best
                corr = fit_correction(
                    ctx, plan, sol.nlp, sol.res.offset_nm, sol.res.stw_kn, sol.res.time_h, step_nm=step_nm
                )
                if corr.level_error <= 1e-4 and corr.slope_error <= 1e-3 and corr.time_slope_error <= 1e-4:
                    break  # the corrected fit matches the model's power and its slopes at this solution
                st.corrections += 1
                st.factor, st.power_terms = corr.factor, dict(corr.terms)
                st.log.append(
                    f"attempt {attempt}: clean ({_score(plan, objective, fuel_price, hourly):.6g}); fit corrected on "
                    f"every leg (level off by up to {corr.level_error:.2%}, speed elasticity by {corr.slope_error:.3f})"
                )
                continue
            last_violations = violations
            if st.retries >= self.max_retries:
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
                best_plan=_route_plan(route, ctx, step_nm),
            )
        _, plan, sol, eta_solve, snapshot = best
        min_load = snapshot.pop("_min_load")
        _emit(progress, "certificate", 0.95)
        res = sol.res
        cert: dict[str, Any] = {"method": "not applicable", "gap": float("nan")}
        fixed = bool(np.all(self.y_lo == 0.0) and np.all(self.y_hi == 0.0))
        reason = _certificate_reason(fixed, self.samples, res, exclusion, objective)
        if reason is None:
            # a cached build is shared by states differing in load limits and power factors: the best solve's
            sol.nlp.power = replace(self.fit.power, max_load=snapshot["max_load"], min_load=min_load)
            sol.nlp.set_leg_power_factor(
                np.asarray(snapshot["leg_power_factor"], dtype=float),
                **{k: np.asarray(v, dtype=float) for k, v in snapshot["leg_power_terms"].items()},
            )
            cert = certificate(
                sol.nlp,
                res,
                objective=objective,
                eta_h=eta_solve,
                eta_mode=eta_mode,
                fuel_price=fuel_price,
                hourly_cost=hourly,
            )
        else:
            cert["reason"] = reason
        # issue 13 item 5: the certificate of the ship itself (true model, IMO SFOC, bands), kept a separate call
        cert = certificate_stats(
            cert,
            plan,
            fixed=fixed,
            objective=objective,
            eta_h=cap_h,
            eta_mode=eta_mode,
            fuel_price=fuel_price,
            hourly_cost=hourly,
            v_min_kn=v_min,
            v_max_kn=v_max,
            step_nm=step_nm,
        )
        shadow = float("nan")
        if eta_user_h is not None and objective == "fuel":
            shadow = float(res.eta_multiplier)
        elif eta_user_h is not None and objective == "cost":
            shadow = float(res.eta_multiplier) / fuel_price
        fit = self.fit
        stats = {
            "ipopt_status": res.status,
            "iterations": iterations,
            "nlp_solves": sol.n_solves,
            "outer_flips": sol.flips,
            "outer_history": sol.history,
            "solve_time_s": solve_time,
            "build_time_s": prob.build_time_s - build_before,
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
            **snapshot,
            "certificate": cert,
            "n_legs": frame.n_legs,
            "samples_per_leg": sol.nlp.samples_per_leg,
            "weather_grid_shape": list(np.shape(self.grid.hs_m)),
            "weather_nodes_filled": self.samples.filled,
            "eta_h_solved": eta_solve,
            "prepared_horizon_h": self.horizon_h,
        }
        status = "optimal" if res.status == "Solve_Succeeded" else "feasible"
        _emit(progress, "done", 1.0)
        return replace(plan, status=status, solver_stats=stats, eta_shadow_price_t_per_h=shadow)
