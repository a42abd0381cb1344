"""The corridor optimiser: ``optimise_corridor`` and ``plan_voyage``.

:func:`optimise_corridor` turns a corridor, the weather and a ship into the arrays of the corridor NLP
(:mod:`optroute.optimise.nlp_inputs` → :class:`formulations.speed_nlp.SpeedNLP`) with the ship's own
performance model tabulated on the corridor's weather grid (:mod:`optroute.optimise.power_table`: the
NLP optimises the model that scores the plan, not a fit of it); starts it from the best verified
discrete plan on the corridor (:mod:`optroute.optimise.starts`: the search route, the 3-D DP, the
centreline start); solves it with the disjunctive outer loop over the danger-band sides
(:func:`formulations.disjunctive.improve_sides`); turns the solution into a
:class:`~optroute.plan.result.Plan` computed with the *true* performance model, and verifies it
(:meth:`Plan.verify`). A plan that fails verification is never returned: the problem is tightened where
the verification says (band edges backed off, the load limits, the ETA, the exclusion radius, the
lateral bounds) and solved again; the returned plan is never worse than the verified start (which is
returned, with ``status="start"``, when the NLP does not improve on it); when there is neither,
:class:`~optroute.errors.SolverFailure` is raised with Ipopt's status.

:func:`plan_voyage` is search → corridor → NLP in one call.
"""

from __future__ import annotations

import time as _time
from collections.abc import Mapping
from dataclasses import replace
from typing import Any, Literal

import numpy as np
import xarray as xr

from optroute.errors import ConfigError, InfeasibleETA
from optroute.optimise.corridor_problem import Objective, ProgressFn
from optroute.physics.performance import PerformanceModel
from optroute.physics.safety import BandRules
from optroute.physics.ship import Ship
from optroute.plan.result import Exclusion, Plan
from optroute.search.route import Corridor, Route
from optroute.weather.sample import WeatherSampler

__all__ = ["optimise_corridor", "plan_voyage"]


# --------------------------------------------------------------------------- main entry points


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
    warm_plan: Plan | None = None,
    max_leg_nm: float = 50.0,
    samples_per_leg: int = 3,
    fuel_price_per_t: float = 600.0,
    hourly_cost_per_h: float = 0.0,
    exclusion: Exclusion | None = None,
    progress: ProgressFn | None = None,
    speed_range_kn: tuple[float, float] | None = None,
    band_solves: int = 12,
    max_retries: int = 4,
    band_margin: float = 0.005,
    band_hs_margin: float = 0.05,
    verify_step_nm: float = 5.0,
    solver_options: Mapping[str, Any] | None = None,
    jit: bool = False,
    use_land_mask: bool | None = None,
    discrete_start: bool = False,
    dp_options: Mapping[str, Any] | None = None,
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
        The true power and fuel model (default :class:`~optroute.physics.performance.KwonModel`); the NLP
        optimises it, tabulated on the corridor's weather grid (:mod:`optroute.optimise.power_table`),
        and the plan is computed and verified with it.
    rules : BandRules, optional
        Danger bands (default Boeing EP 2145155).
    route : Route, optional
        A search route: the warm start (its leg speeds on the corridor's legs) and hence the side
        of every danger band each leg starts on.
    warm_plan : Plan, optional
        A previous solution on the same corridor and ``max_leg_nm`` (e.g. a neighbouring ETA's, as
        :func:`optroute.studies.tradeoff` uses): the warm start, taking precedence over ``route``. Only its
        ``waypoints`` (lateral offsets recovered across the centreline) and ``stw_kn`` are read; with
        another number of legs its speeds are interpolated along track and the offsets are zero.
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
    jit : bool
        Compile the NLP's per-leg derivative functions to C (CasADi's ``"shell"`` plugin; needs a C compiler
        ``cc`` on the PATH): a few seconds more per build, each solve about twice as fast (``benchmarks.bench_nlp``:
        500 legs 0.87 s against 1.71 s). Worth it for long corridors and fronts, where builds are reused.
    use_land_mask : bool, optional
        Apply the real coastline (default: unless the weather declares synthetic geography).
    discrete_start : bool
        Also run the 3-D DP (:mod:`optroute.search.dp`) on the corridor as a start candidate when its
        centreline is one great circle and there is an ETA (objective fuel or cost); see
        :mod:`optroute.optimise.starts`. Off by default: on the storm crossing of ``benchmarks.bench_nlp``
        the DP at its default resolution takes about 4× the rest of the call.
    dp_options : mapping, optional
        Resolution of that DP (``dx_nm``, ``dy_nm``, ``dt_h``, ``speed_step_kn``; :func:`optroute.optimise.starts.dp_route`).

    Returns
    -------
    Plan
        Verified (``plan.verify() == []``); ``total_fuel_t`` and ``legs`` are the true model's.
        ``status``: ``"optimal"`` (Ipopt converged and the band-side search finished), ``"sides_unsettled"``
        (converged, the side search stopped on ``band_solves``), ``"feasible"`` (Ipopt stopped at a limit; its
        iterate's plan verifies), ``"mended"`` (converged; the referee found the engine outside its range
        between the NLP's samples and the speeds of those legs were moved to the limit,
        :func:`optroute.optimise.starts.repaired_plan`; ``solver_stats["mended_legs"]``) or ``"start"`` (the
        verified start, because the NLP's plan was worse or failed; ``solver_stats["status_reason"]`` says
        which). ``solver_stats`` holds: ``ipopt_status``
        (verbatim), ``nlp_solves`` and ``iterations`` (every Ipopt call of the whole call, and all their
        iterations), ``build_time_s``, ``stage_time_s`` (start, solve and verify), ``total_time_s``;
        ``start``, ``start_score``, ``starts`` (every candidate's score by the referee, inf unverified),
        ``nlp_score``; ``power_table`` (its speed and heading nodes, capped share, evaluations, the SFOC
        curve's error) and, for an NLP plan, ``tabulation`` (the NLP's fuel at its solution against the
        referee's fuel of the same track and schedule: the measured tabulation error), ``outer_solves``,
        ``outer_flips``, ``outer_history``, ``sides_settled``, ``nlp_objective``, ``nlp_fuel_t``,
        ``nlp_max_violation``, ``frame_max_rel_distance_error``, ``bands``, ``certificate`` (fixed path
        in static weather without current: ``method`` ``"lagrangian dual"``, ``bound_t`` (``bound`` for
        cost) and the ``gap`` of the returned plan to the ship's own least fuel, bands included, see
        :mod:`optroute.optimise.certificate`; else ``reason``; the NLP model's dual bound under
        ``nlp_model``), ``eta_h_solved``; ``retries``, ``tightening`` (log), ``n_legs``, ``samples_per_leg``,
        ``weather_grid_shape``, ``weather_nodes_filled``.

    Raises
    ------
    InfeasibleETA
        The ETA cannot be met; ``earliest_arrival`` is the minimum-time solve's arrival (tried from
        several warm starts, on a weather grid covering its passage).
    SolverFailure
        Ipopt fails (``status`` verbatim) or no tightened re-solve gives a plan that passes
        verification; ``best_plan`` is the best plan known that passes verification (the minimum-time
        solve's, the search route's, the safe warm start's, or the timed safe start's passage,
        :func:`optroute.optimise.min_time.timed_safe_start`), else None. When the timed search finds no passage
        along the centreline, the message begins with where and when it found no allowed speed.
    WeatherCoverageError
        The corridor or the ETA lies outside the weather.
    NoSafePassage, OnLandError
        No navigable channel joins the corridor's ends (the message names the leg where it closes;
        :func:`optroute.optimise.lateral.lateral_bounds`), or it starts or ends on land.
    """
    from optroute.optimise.corridor_problem import PreparedCorridor

    if objective not in ("time", "fuel", "cost"):
        raise ConfigError(f"objective={objective!r} is not known; use 'time', 'fuel' or 'cost'")
    if eta_mode not in ("le", "eq"):
        raise ConfigError(f"eta_mode={eta_mode!r} is not known; use 'le' (arrive by) or 'eq' (arrive at)")
    started = _time.perf_counter()
    prepared = PreparedCorridor(
        corridor,
        weather,
        ship,
        departure=departure,
        latest_eta=eta,
        objective=objective,
        model=model,
        rules=rules,
        max_leg_nm=max_leg_nm,
        samples_per_leg=samples_per_leg,
        fuel_price_per_t=fuel_price_per_t,
        hourly_cost_per_h=hourly_cost_per_h,
        exclusion=exclusion,
        speed_range_kn=speed_range_kn,
        band_solves=band_solves,
        discrete_start=discrete_start,
        dp_options=dp_options,
        max_retries=max_retries,
        band_margin=band_margin,
        band_hs_margin=band_hs_margin,
        verify_step_nm=verify_step_nm,
        solver_options=solver_options,
        use_land_mask=use_land_mask,
        progress=progress,
        jit=jit,
    )
    plan = prepared.solve(
        eta, eta_mode=eta_mode, objective=objective, warm_plan=warm_plan, route=route, progress=progress
    )
    stats = dict(plan.solver_stats)
    stats["total_time_s"] = _time.perf_counter() - started
    return replace(plan, solver_stats=stats)


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
    from optroute.search.routing import search_route

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
    plan = optimise_corridor(
        corridor,
        weather,
        ship,
        departure=route.departure,
        eta=eta,
        objective=objective,
        model=model,
        rules=rules,
        route=route,
        **optimise_kwargs,
    )
    stats = dict(plan.solver_stats)
    stats["search"] = {
        "method": route.method,
        "objective": route.objective,
        "cost": route.cost,
        "fuel_t": route.total_fuel_t,
        "duration_h": route.total_duration_h,
        "stats": {k: v for k, v in route.stats.items() if np.isscalar(v)},
    }
    return replace(plan, solver_stats=stats)
