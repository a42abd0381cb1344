"""The corridor optimiser: ``optimise_corridor`` and ``plan_voyage``.

:func:`optimise_corridor` turns a corridor, the weather and a ship into the arrays of the corridor NLP
(:mod:`optroute.optimise.nlp_inputs` → :class:`formulations.speed_nlp.SpeedNLP`) with the ship's own
performance model tabulated on the corridor's weather grid (:mod:`optroute.optimise.power_table`: the
NLP optimises the model that scores the plan, not a fit of it); starts it from the best candidate by the
referee, chosen before the first solve (:mod:`optroute.optimise.start_stage`: the search route, the
centreline start and, where a band or the exclusion can bind or no other start verifies, the 3-D DP and the
minimum-time plan); solves it with the disjunctive outer loop over the danger-band sides
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

from optroute import geodesy as geo
from optroute import units
from optroute.errors import ConfigError, InfeasibleETA, NoSafePassage, SolverFailure, WeatherCoverageError
from optroute.optimise.corridor_problem import Objective, ProgressFn
from optroute.optimise.lateral import ROUTE_AROUND
from optroute.optimise.rows import BAND_LEG_NM
from optroute.physics.performance import PerformanceModel
from optroute.physics.safety import BandRules
from optroute.physics.ship import Ship
from optroute.plan.result import Exclusion, Plan
from optroute.search.route import Corridor, Route
from optroute.weather.sample import WeatherSampler

__all__ = ["optimise_corridor", "plan_voyage", "solve_prepared"]

#: Tolerance of "meets the ETA" for the plans compared here [h] (Plan.verify's default).
_ETA_TOL_H = 1.0 / 60.0


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
    band_leg_nm: float | None = BAND_LEG_NM,
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
    jit: bool | str = "auto",
    use_land_mask: bool | None = None,
    discrete_start: bool | Literal["auto"] = "auto",
    dp_options: Mapping[str, Any] | None = None,
    robust: Literal["all", "cvar", "chance"] | None = None,
    cvar_alpha: float = 0.0,
    violation_fraction: float = 0.0,
    constraint_rows: Literal["referee", "midpoints"] = "midpoints",
    timed_no_passage: bool = False,
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
        another number of legs its speeds are interpolated along track and the offsets are zero.  An
        object with a ``duals`` attribute (:class:`optroute.optimise.nlp_solve.Duals`, a front's
        neighbouring solve's multipliers) also starts Ipopt's multipliers when it is the start chosen and
        the NLP has the same rows (``solver_stats["dual_starts"]`` counts such solves).
    max_leg_nm : float
        Longest NLP leg [nm]; the corridor is resampled on its great circles.
    band_leg_nm : float or None
        Longest NLP leg [nm] where a danger band or the exclusion can bind (on the NLP's weather grid,
        :func:`optroute.optimise.rows.binding_legs`): those legs are cut further, so that the NLP can change
        speed as often as the 3-D DP start does (:func:`optroute.optimise.rows.cut_where_binding`).
        Default :data:`optroute.optimise.rows.BAND_LEG_NM`, 20 nm, the DP's stage spacing; None:
        ``max_leg_nm`` everywhere (``python -m benchmarks --only compare`` runs both side by side). Not for
        a free-arrival minimum time (``objective="time"`` without an ETA): started from the 3-D DP's plan,
        its legs are cut where that plan changes speed or lateral offset instead, for that solve.
        ``solver_stats["n_legs"]`` gives the legs solved.
    samples_per_leg : int
        NLP samples per leg of the midpoint-rule time and fuel (every constraint is imposed there too).
    constraint_rows : {"midpoints", "referee"}
        Where the NLP's engine-load, band and exclusion rows sit. ``"midpoints"`` (default): at the
        quadrature's midpoints, and both ends of every leg where a band or the exclusion can bind on
        the corridor (:func:`optroute.optimise.rows.leg_end_rows`). ``"referee"``: also at the
        referee's check points of a canonical start —
        the centreline at the speed of the latest ETA (leg ends, weather-grid crossings, points near band
        edges; :func:`optroute.optimise.rows.canonical_rows`), the same for every ETA of a prepared
        corridor — on the legs where a band or the exclusion can bind (elsewhere the leg ends only, for
        the engine load; :func:`optroute.optimise.rows.binding_legs`), aimed at plans that pass
        :meth:`Plan.verify` on the first try (``solver_stats["first_solve"]``). Not yet the default:
        measured side by side it costs 1.3–3.7× the call, raised the first-try share on the cyclone
        voyage and one harness seed only, and turns harness seed 0's minimum-time solve from a verified
        plan into a SolverFailure (cause not established; a candidate: the band outer loop flips all
        samples of a leg together, and more samples per leg can leave it no common side).
    fuel_price_per_t, hourly_cost_per_h : float
        For ``"cost"`` [currency/t], [currency/h].
    exclusion : Exclusion, optional
        A moving circle (storm, cyclone) to stay out of.
    timed_no_passage : bool
        The weather's no-passage cells that are NaN at some times only (a moving no-go area, as in
        ``scenarios.shao_case``) become time windows on the NLP's waypoint times — leave each leg they
        cross before they reach it, or enter it after they have gone, on the side the start passes
        (:mod:`optroute.optimise.timed_no_go`) — instead of lateral bounds blocked over every time a
        ship could be on the leg, which close a track that clears the area by its timing alone. Needs
        ``weather`` as a dataset. Default False (lateral bounds).
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
    jit : {"auto", True, False}
        Compile the NLP's per-leg derivative functions to C with the system C compiler (``$CC``, else ``gcc``), once
        per machine and ship: the libraries are cached on disk (``$OPTROUTE_CASADI_CACHE``, else
        ``~/.cache/optroute/casadi``; :mod:`formulations.compiled`), compiled for the interpreter's arithmetic
        (``tests/test_compiled.py`` checks the numbers bit for bit). ``"auto"`` (default): from
        :data:`~optroute.optimise.corridor_setup.JIT_AUTO_LEGS` legs on, where a compiler is found (the 496-leg storm
        corridor of ``benchmarks/_nlp_call.py``: the whole call 8.0 s interpreted, 5.6 s compiled; the first call
        on a machine also compiles, about 5 CPU-s); True: always (a ConfigError without a compiler or a writable cache
        folder); False: never.
    use_land_mask : bool, optional
        Apply the real coastline (default: unless the weather declares synthetic geography).
    discrete_start : {"auto", True, False}
        The 3-D DP (:mod:`optroute.search.dp`) on the corridor as a start candidate, when its centreline is one
        great circle and there is an ETA (objective fuel or cost): ``"auto"`` (default) where the start stage
        computes its global starts — a danger band or the exclusion can bind on some leg, or no other start
        verifies (:func:`optroute.optimise.start_stage.global_starts_reason`) — and not when ``route`` is the DP's
        own; True always; False never (the minimum-time plan stays a candidate where the stage computes it).
    dp_options : mapping, optional
        Resolution of that DP (``dx_nm``, ``dy_nm``, ``dt_h``, ``speed_step_kn``; :func:`optroute.optimise.starts.dp_route`).
    robust : {"all", "cvar", "chance"}, optional
        With ``weather`` an ensemble (a ``member`` dimension, :func:`optroute.weather.scenarios.ensemble`): one plan
        whose danger bands, engine range, exclusion and ETA hold in every member, minimising the members' mean
        objective (``"all"``) or its CVaR at ``cvar_alpha`` (``"cvar"``); verified in every member
        (:func:`optroute.optimise.robust.optimise_robust`, which documents its statuses and statistics).
    cvar_alpha : float
        CVaR level in [0, 1) for ``robust="cvar"`` (0: the mean).
    violation_fraction : float
        For ``robust="chance"``: the share in (0, 1) of the members whose constraints the plan may break (all but
        that share hold; mean objective; exact by enumeration of the members dropped, for small ensembles).

    Returns
    -------
    Plan
        Verified (``plan.verify() == []``); ``total_fuel_t`` and ``legs`` are the true model's.
        ``status``: ``"optimal"`` (Ipopt converged and the band-side search finished), ``"sides_unsettled"``
        (converged, the side search stopped on ``band_solves``), ``"feasible"`` (Ipopt stopped at a limit; its
        iterate's plan verifies), ``"mended"`` (converged; the referee found the engine outside its range
        between the NLP's samples and the speeds of those legs were moved to the limit,
        :func:`optroute.optimise.starts.repaired_plan`; ``solver_stats["mended_legs"]``) or ``"start"`` (the
        best verified start candidate, because the NLP's plan was worse or failed, or the best verified plan
        after a SolverFailure; ``solver_stats["status_reason"]`` says which). ``solver_stats`` holds: ``ipopt_status`` (verbatim), ``nlp_solves``, ``iterations`` and
        ``solve_time_s`` (every Ipopt call of the whole call — side flips, re-solves, phase-1, the minimum-time
        plan's solves — with all their iterations and wall-clock time [s]), ``build_time_s``, ``total_time_s``;
        ``start``, ``start_score``, ``warm_start``, ``starts`` (per candidate: ``score`` by the referee, inf
        unverified, ``verified``, its own ``estimate``, ``cpu_s`` to make and score it, ``chosen``, ``warm_start``),
        ``global_starts`` (why the 3-D DP and the minimum-time plan were candidates, or why not), ``stage_time_s``
        and ``stage_cpu_s`` (wall and CPU seconds of the stages start, solve and verify, plan), ``nlp_score``; ``power_table`` (its speed and heading nodes, capped share, evaluations, the SFOC
        curve's error) and, for an NLP plan, ``tabulation`` (the NLP's fuel at its solution against the
        referee's fuel of the same track and schedule: the measured tabulation error; and at the NLP's own
        samples, its power and leg fuel against the model's in the referee's weather,
        ``max_leg_rel_error``, ``worst_leg``, ``mean_abs_leg_rel_error``, ``max_sample_rel_error``,
        ``mean_abs_sample_rel_error``, ``capped_samples``, ``samples``: the per-leg error of
        :func:`optroute.optimise.power_table.sample_error`, stated bound
        :data:`~optroute.optimise.power_table.LEG_BOUND`), ``outer_solves``,
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
        The ETA cannot be met; ``earliest_arrival`` is the minimum-time plan's arrival (its solve started from
        the elastic phase-1 problem's point where no start verifies, on a weather grid covering its passage). With
        ``eta_mode="eq"``, an ETA later than the centreline sailed at the engine's minimum load arrives, where no plan
        arriving at the ETA was found: ``latest_arrival`` is that schedule's arrival.
    SolverFailure
        Ipopt fails (``status`` verbatim) or no tightened re-solve gives a plan that passes
        verification, and no verified plan meets the ETA (one that does, the minimum-time plan included, is
        returned with ``status="start"``); ``best_plan`` is the search route's plan when it verifies, else None.
    WeatherCoverageError
        The corridor or the ETA lies outside the weather.
    NoSafePassage, OnLandError
        No navigable channel joins the corridor's ends (the message names the leg where it closes;
        :func:`optroute.optimise.lateral.lateral_bounds`), or it starts or ends on land; or, after a failed
        solve, the elastic phase-1 problem keeps a slack on the first leg and the true model allows no constant
        speed on it from departure (the message names the leg, position and time; :mod:`optroute.optimise.phase1`).
    """
    from optroute.optimise.corridor_problem import PreparedCorridor

    if objective not in ("time", "fuel", "cost"):
        raise ConfigError(f"objective={objective!r} is not known; use 'time', 'fuel' or 'cost'")
    if eta_mode not in ("le", "eq"):
        raise ConfigError(f"eta_mode={eta_mode!r} is not known; use 'le' (arrive by) or 'eq' (arrive at)")
    if robust is not None or (isinstance(weather, xr.Dataset) and "member" in weather.dims):
        return _robust(robust, weather, locals())
    if violation_fraction != 0.0:
        raise ConfigError(f"violation_fraction={violation_fraction!r} applies to an ensemble plan only; pass an "
                          "ensemble (dimension 'member') with robust='chance', or drop violation_fraction")  # fmt: skip
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
        band_leg_nm=band_leg_nm,
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
        constraint_rows=constraint_rows,
        timed_no_passage=timed_no_passage,
    )
    plan = _solve_honestly(
        prepared, eta, eta_mode=eta_mode, objective=objective, warm_plan=warm_plan, route=route, progress=progress
    )
    stats = dict(plan.solver_stats)
    # every solve of the call, those of a failed first solve and of the minimum-time solve behind an honest
    # outcome included (the plan's own solve counts only its solve)
    prob = prepared.problem
    stats.update(
        nlp_solves=prob.solves, iterations=prob.iterations, solve_time_s=prob.solve_time_s,
        build_time_s=prob.build_time_s,
    )  # fmt: skip
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
    exclusion: Exclusion | None = None,
    **optimise_kwargs: Any,
) -> Plan:
    """Search a route, take the corridor around it, and optimise speeds and waypoints in it.

    1. :func:`optroute.search_route` (objective ``"time"`` for a time plan, else ``"fuel"`` — or
       ``"cost"`` with the prices — with the ETA; the fuel objective's λ bisection with
       ``stop_at_track=True``: only the route's track is kept; on a long voyage the λ is bisected on a coarser
       grid first, ``lambda_cell_nm``); when the search cannot meet the ETA it
       is run for minimum time instead, and the NLP decides (it may meet an ETA the grid cannot).
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
    exclusion : Exclusion, optional
        A moving circle to stay out of (a cyclone's R + margin, :meth:`optroute.Exclusion.from_track`),
        imposed on the search's legs and by the optimiser, and checked by :meth:`Plan.verify`.
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
    opts.setdefault("stop_at_track", True)  # the optimiser keeps the search's track and sets the speeds again
    common = {"departure": departure, "model": model, "rules": rules, "exclusion": exclusion}
    try:
        route = search_route(start, end, weather, ship, objective=search_objective, eta=eta, **common, **opts)
    except InfeasibleETA:
        route = search_route(start, end, weather, ship, objective="time", **common, **opts)
    corridor = route.corridor(width_nm=corridor_width_nm)
    try:
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
            exclusion=exclusion,
            **optimise_kwargs,
        )
    except NoSafePassage as exc:
        raise _over_land(exc, route) from exc
    stats = dict(plan.solver_stats)
    stats["search"] = {
        "method": route.method,
        "objective": route.objective,
        "cost": route.cost,
        "fuel_t": route.total_fuel_t,
        "duration_h": route.total_duration_h,
        "stats": {k: v for k, v in route.stats.items() if np.isscalar(v)},
        "legs_crossing_land": list(route.stats.get("legs_crossing_land", [])),
    }
    return replace(plan, solver_stats=stats)


def _over_land(exc: NoSafePassage, route: Any) -> NoSafePassage:
    """The corridor's NoSafePassage, saying when the searched route itself crosses land between its grid nodes.

    Where the grid search cannot walk its legs on the coastline (GSHHG) it tests the coastline at its cells'
    centres only (``route.stats["legs_crossing_land"]``): a route over a peninsula gives a corridor closed by
    land across its whole width, and the corridor's own advice (plan it with plan_voyage) is what the user did.
    """
    legs = list(route.stats.get("legs_crossing_land", []))
    if not legs:
        return exc
    cell = float(route.stats.get("cell_nm", np.nan))
    text = str(exc).removesuffix(f"; {ROUTE_AROUND}")
    return NoSafePassage(
        f"{text}: the searched route itself crosses land between its grid nodes on legs {legs} (the grid search "
        f"tests the coastline at the centres of its {cell:.3g} nm cells only), so the corridor about it can lie "
        "across land; search on other cells (search_options={'cell_nm': ...}: the route then meets the coast at "
        "other nodes), or give optimise_corridor a corridor that keeps to the sea"
    )


def _robust(robust: Any, weather: Any, args: dict[str, Any]) -> Plan:
    """``optimise_corridor`` on an ensemble: :func:`optroute.optimise.robust.optimise_robust`, or the ConfigError."""
    from optroute.optimise.robust import optimise_robust

    if robust is None:
        raise ConfigError(
            f"the weather holds {weather.sizes['member']} ensemble members (dimension 'member'): pick one member "
            "(optroute.weather.scenarios.member(ds, k) or ds.isel(member=k)), or pass robust='all' (or 'cvar') for "
            "one plan that is safe in every member"
        )
    skip = ("corridor", "weather", "ship", "PreparedCorridor")
    kw = {k: v for k, v in args.items() if k not in skip}
    return optimise_robust(args["corridor"], weather, args["ship"], **kw)


# --------------------------------------------------------------------------- honest outcomes (issue 14 items 4, 5)


def solve_prepared(
    prepared: Any,
    eta: Any = None,
    *,
    eta_mode: str = "le",
    objective: str = "fuel",
    warm_plan: Plan | None = None,
    route: Route | None = None,
    tabulate: bool = True,
) -> Plan:
    """:func:`optimise_corridor`'s solve and honest outcomes on a corridor prepared once (a front's points).

    ``prepared`` is a :class:`~optroute.optimise.corridor_problem.PreparedCorridor`; the rest as in
    :func:`optimise_corridor`, whose outcomes (plans, statuses, errors) this gives for the same solve.
    ``tabulate=False``: no ``start_tabulation`` nor ``tabulation`` in ``solver_stats`` (two referee evaluations of
    statistics alone; :meth:`~optroute.optimise.corridor_problem.PreparedCorridor.solve`).
    """
    kw = {"eta_mode": eta_mode, "objective": objective, "warm_plan": warm_plan, "route": route, "progress": None}
    return _solve_honestly(prepared, eta, tabulate=tabulate, **kw)


def _solve_honestly(
    prepared: Any, eta: Any, *, eta_mode: str, objective: str, warm_plan, route, progress, tabulate: bool = True
) -> Plan:
    """``prepared.solve`` with outcomes that tell the truth about the plans the call found.

    The solve itself starts from the best candidate by the referee and never returns a plan worse than a verified
    one, the 3-D DP's and the minimum-time plan's included where the start stage computes them
    (:mod:`optroute.optimise.start_stage`). Its errors are checked here:

    * A free-arrival minimum-time passage that cannot end inside the weather's time span is a
      :class:`WeatherCoverageError` naming the span needed (before any solve: the fastest conceivable
      passage, the corridor's end-to-end great circle at the top speed plus the strongest current).
    * :class:`InfeasibleETA`: its ``earliest_arrival`` is the arrival of the minimum-time *plan* (verified,
      :meth:`PreparedCorridor.minimum_time_plan`, the plan :func:`optimise_corridor` gives for
      ``objective="time"`` without an ETA).
    * :class:`SolverFailure`: a verified plan that meets the ETA (the error's best plan, or the minimum-time plan)
      is returned, the better by the objective, with ``status="start"`` and the failure in
      ``solver_stats["status_reason"]``; when the minimum-time plan arrives after the ETA it is
      :class:`InfeasibleETA`, and so is an ETA to be met exactly (``eta_mode="eq"``) after the arrival of the
      centreline sailed at the engine's minimum load
      (:func:`~optroute.optimise.start_stage.centreline_minimum_load`); a cross-section where no speed is
      allowed at any time, or on a fixed path a section no schedule reaches
      (:func:`optroute.optimise.barrier.fixed_path_barrier`), is :class:`NoSafePassage`; weather-coverage
      violations are :class:`WeatherCoverageError`.
    """
    _check_time_span(prepared, eta, objective)
    kw = {"eta_mode": eta_mode, "objective": objective, "progress": progress}
    try:
        return prepared.solve(eta, warm_plan=warm_plan, route=route, tabulate=tabulate, **kw)
    except InfeasibleETA as exc:
        fast = prepared.minimum_time_plan(route)
        if fast is None:  # no verified passage at all: closed, or the NLP's word for it
            _raise_if_blocked(prepared, exc)
            raise
        if not _meets(fast, prepared, eta, "le"):
            raise _infeasible(prepared, eta, [fast]) from exc
        # the minimum-time plan was a candidate of the start stage (no local start verified): it arrives before an
        # ETA that is to be met exactly, and no plan arriving at it was found
        raise
    except SolverFailure as exc:
        return _after_failure(prepared, eta, exc, route, kw)


def _check_time_span(prepared: Any, eta: Any, objective: str) -> None:
    """WeatherCoverageError when even the fastest conceivable free-arrival passage ends after the weather."""
    if eta is not None or objective != "time" or not np.isfinite(prepared.data_end_h):
        return
    wp = np.asarray(prepared.corridor.waypoints, dtype=float)
    gc_nm = float(geo.distance_nm(wp[0, 0], wp[0, 1], wp[-1, 0], wp[-1, 1]))
    current_kn = _strongest_current_kn(prepared)
    if current_kn is None:
        return
    fastest_h = gc_nm / (prepared.v_max + current_kn)
    if fastest_h <= prepared.data_end_h:
        return
    t0 = prepared.departure
    end = prepared.sampler.extent["time"][1]
    needed = t0 + units.h_to_timedelta(fastest_h)
    raise WeatherCoverageError(
        f"the passage cannot end inside the weather's time span: it ends at {units.format_utc(end)}, and the fastest "
        f"conceivable passage ({gc_nm:.0f} nm end to end at {prepared.v_max:.1f} kn plus a current of "
        f"{current_kn:.1f} kn) departing {units.format_utc(t0)} arrives {units.format_utc(needed)} at the earliest; "
        f"give weather from {units.format_utc(t0)} to at least {units.format_utc(needed)}, depart earlier, or open "
        "the weather with time_policy='hold'"
    )


def _strongest_current_kn(prepared: Any) -> float | None:
    """The strongest current of the weather [kn] (0 without one); None when it cannot be read (a lazy sampler)."""
    names = [v for v in ("current_u_ms", "current_v_ms") if v in prepared.sampler.variables]
    if not names:
        return 0.0
    ds = prepared.dataset
    if ds is None:
        return None
    u = np.asarray(ds["current_u_ms"].values, dtype=float) if "current_u_ms" in names else 0.0
    v = np.asarray(ds["current_v_ms"].values, dtype=float) if "current_v_ms" in names else 0.0
    speed = np.hypot(u, v)
    return float(units.ms_to_kn(np.nanmax(speed))) if np.isfinite(speed).any() else 0.0


def _meets(plan: Plan, prepared: Any, eta: Any, eta_mode: str) -> bool:
    """Whether ``plan`` passes verification with the ETA (none: any arrival)."""
    return not plan.verify(step_nm=prepared.verify_step_nm, eta=eta, eta_mode=eta_mode if eta is not None else None)


def _restamp(prepared: Any, plan: Plan, eta: Any, eta_mode: str, reason: str) -> Plan:
    """``plan`` in the call's context (its ETA), with status ``"start"`` and why."""
    ctx = prepared.plan_context(None if eta is None else units.as_utc_time(eta, "eta"), eta_mode)
    stats = dict(plan.solver_stats)
    stats["status_reason"] = reason
    stats["returned_plan"] = plan.status
    return replace(plan, status="start", solver_stats=stats, context=ctx)


def _infeasible(prepared: Any, eta: Any, plans: list[Plan]) -> InfeasibleETA:
    """InfeasibleETA whose earliest arrival is the earliest verified plan's."""
    first = min(plans, key=lambda p: p.arrival)
    eta_t = units.as_utc_time(eta, "eta")
    return InfeasibleETA(
        f"the ETA {units.format_utc(eta_t)} cannot be met: the minimum-time plan of this corridor (verified) arrives "
        f"{first.duration_h:.2f} h after departure, at {units.format_utc(first.arrival)}, "
        f"{units.timedelta_to_h(first.arrival - eta_t):.2f} h after the ETA; give an ETA at or after that, or widen "
        "the corridor",
        earliest_arrival=first.arrival,
    )


def _too_late(prepared: Any, eta_t: np.datetime64, slowest: Plan) -> InfeasibleETA:
    """InfeasibleETA for an ETA to be met exactly (``eta_mode="eq"``) later than every plan found arrives, the
    centreline's slowest schedule (:func:`~optroute.optimise.start_stage.centreline_minimum_load`) included."""
    pmin = float(prepared.plan_context().model.min_power_kw)
    return InfeasibleETA(
        f"the ETA {units.format_utc(eta_t)} is to be met exactly (eta_mode='eq'), and no plan was found that arrives "
        f"so late: the centreline sailed at the engine's minimum load ({pmin:.0f} kW), the slowest the engine allows, "
        f"arrives {slowest.duration_h:.2f} h after departure, at {units.format_utc(slowest.arrival)}, "
        f"{units.timedelta_to_h(eta_t - slowest.arrival):.2f} h before the ETA (a track weaving across the corridor "
        "is longer, and none was found that reaches the ETA either); use eta_mode='le' to arrive by the ETA (earlier, "
        "and wait), or give an earlier ETA",
        latest_arrival=slowest.arrival,
    )


def _after_failure(prepared: Any, eta: Any, exc: SolverFailure, route, kw: dict[str, Any]) -> Plan:
    """A SolverFailure turned into the truth: a verified plan, InfeasibleETA, NoSafePassage or coverage."""
    from optroute.optimise.starts import score

    eta_mode, objective = kw["eta_mode"], kw["objective"]
    verified = [p for p in (exc.best_plan,) if p is not None and _meets(p, prepared, None, "le")]
    if objective != "time":
        fast = prepared.minimum_time_plan(route)  # solved already when the start stage computed it
        verified += [fast] if fast is not None else []
    meeting = [p for p in verified if eta is None or _meets(p, prepared, eta, eta_mode)]
    if meeting:
        best = min(meeting, key=lambda p: score(p, objective, prepared.fuel_price, prepared.hourly))
        return _restamp(prepared, best, eta, eta_mode, f"the best verified plan the call found; SolverFailure: {exc}")
    if eta is not None and verified:
        eta_t = units.as_utc_time(eta, "eta")
        if eta_mode == "le" or all(p.arrival > eta_t for p in verified):
            raise _infeasible(prepared, eta, verified) from exc
        from optroute.optimise.start_stage import centreline_minimum_load

        # eq: an ETA after every plan found may lie after the slowest schedule the engine allows
        slowest = centreline_minimum_load(prepared, prepared.plan_context())
        if slowest is not None and slowest.arrival < eta_t:
            raise _too_late(prepared, eta_t, slowest) from exc
    if "weather_coverage" in str(exc):
        end = prepared.sampler.extent["time"][1]
        raise WeatherCoverageError(
            f"the passages tried run past the weather's last time {units.format_utc(end)}: give weather that covers "
            "the whole passage (an ETA inside the span, or a later forecast end), or open the weather with "
            "time_policy='hold'"
        ) from exc
    _raise_if_blocked(prepared, exc)
    raise _undetermined(prepared, exc)


def _undetermined(prepared: Any, exc: SolverFailure) -> SolverFailure:
    """The SolverFailure of a call without any verified plan, naming the lattice searches that found no passage either.

    Where the start stage's lattice searches (the 3-D DP across the corridor, the centreline's timed passage) found
    none within the weather's span, the failure says so: whether a passage exists is not established. A lattice
    search finding nothing is not :class:`NoSafePassage`: on harness seed 20 the centreline in blocks of 9.78 nm
    holds a passage the referee and the harness's 0.1 nm check pass, and in blocks of 9 nm none."""
    closed = prepared.lattice_closed
    if not closed:
        return exc
    found = "; ".join(f"{k}: {v}" for k, v in closed.items())
    return SolverFailure(
        f"{exc} -- no passage found on the start stage's lattices either ({found}); these do not prove that none "
        "exists (whether a safe passage exists is not established): try another departure or route, a wider corridor, "
        "or a finer lattice (dp_options)",
        status=exc.status,
        best_plan=exc.best_plan,
    )


def _raise_if_blocked(prepared: Any, exc: SolverFailure) -> None:
    """NoSafePassage when a cross-section of the corridor allows no speed at any time (:func:`blocked_section`), or,
    on a fixed path, when no schedule gets past some section (:func:`optroute.optimise.barrier.fixed_path_barrier`)."""
    from optroute.optimise.min_time import blocked_section

    end_h = min(prepared.horizon_h, prepared.data_end_h)
    blocked = blocked_section(
        prepared.plan_context(),
        prepared.frame,
        prepared.departure,
        y_lo_nm=prepared.y_lo,
        y_hi_nm=prepared.y_hi,
        v_min_kn=prepared.v_min,
        v_max_kn=prepared.v_max,
        horizon_h=end_h,
    )
    if blocked is None and prepared.fixed_path:
        from optroute.optimise.barrier import fixed_path_barrier

        # the weather's end bounds every passage (a later end only adds schedules: the claim holds for an ETA too)
        last_h = prepared.data_end_h if np.isfinite(prepared.data_end_h) else end_h
        blocked = fixed_path_barrier(prepared.plan_context(), prepared.frame, prepared.departure,
                                     v_min_kn=prepared.v_min, v_max_kn=prepared.v_max, end_h=last_h)  # fmt: skip
    if blocked is not None:
        raise NoSafePassage(
            f"{blocked}: there is no safe passage through this corridor in this weather; take another route or "
            "another departure"
        ) from exc
