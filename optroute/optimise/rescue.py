"""The corridor optimiser's recovery steps: warm starts, the first-failure diagnosis and tightening.

What :func:`optroute.optimise.api.optimise_corridor` and
:meth:`optroute.optimise.corridor_problem.PreparedCorridor.solve` do when a solve fails or its plan
does not verify: the minimum-time starts, the diagnosis of a failed first solve (infeasible ETA or
a solver problem), the tightening of the rows the referee flagged, and the plan built from an NLP
solution with the true model.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from formulations.speed_nlp import NLPResult, SpeedNLP
from optroute import geodesy as geo
from optroute import units
from optroute.errors import InfeasibleETA, OptrouteError, SolverFailure, WeatherCoverageError
from optroute.optimise.lateral import avoid_point
from optroute.optimise.min_time import DeadEnd, TimedStart, timed_safe_start
from optroute.optimise.nlp_inputs import (
    CorridorFrame,
    weather_grid,
)
from optroute.optimise.nlp_solve import (
    VIOLATION_TOL,
    Problem,
    Solved,
    Tightening,
    clear_of_exclusion,
    route_warm_start,
    safe_warm_start,
)
from optroute.optimise.phase1 import diagnose
from optroute.physics.safety import BandRules
from optroute.plan.result import Exclusion, Plan, PlanContext, Violation
from optroute.search.route import Route
from optroute.units import h_to_timedelta as _h_to_td
from optroute.weather.sample import WeatherSampler

__all__ = [
    "LIMIT_STATUSES",
    "certificate_reason",
    "feasible_iterate",
    "first_failure",
    "longer_horizon",
    "plan_warm_start",
    "route_plan",
    "tighten",
    "to_plan",
]


def plan_warm_start(plan: Plan, frame: CorridorFrame) -> dict[str, np.ndarray]:
    """Warm start from a previous plan: its offsets across the centreline [nm, port +] and leg speeds [kn]."""
    wp, stw = np.asarray(plan.waypoints, dtype=float), np.asarray(plan.stw_kn, dtype=float)
    centre = frame.corridor.waypoints
    if wp.shape != centre.shape or stw.shape != (frame.n_legs,):
        s_old = np.concatenate([[0.0], np.cumsum(geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1]))])
        mid_old = 0.5 * (s_old[:-1] + s_old[1:]) / max(s_old[-1], 1e-9)
        mid_new = 0.5 * (frame.s_nm[:-1] + frame.s_nm[1:]) / max(frame.s_nm[-1], 1e-9)
        return {"offset_nm": np.zeros(frame.n_legs + 1), "stw_kn": np.interp(mid_new, mid_old, stw)}
    dist = geo.distance_nm(centre[:, 0], centre[:, 1], wp[:, 0], wp[:, 1])
    bearing = geo.initial_course_deg(centre[:, 0], centre[:, 1], wp[:, 0], wp[:, 1])
    starboard = dist * np.cos(np.radians(bearing - frame.corridor.normal_course_deg()))
    return {"offset_nm": np.where(dist > 1e-9, -starboard, 0.0), "stw_kn": stw}


def certificate_reason(
    fixed: bool, samples: Any, res: NLPResult, exclusion: Exclusion | None, objective: str
) -> str | None:
    """Why the NLP model's own dual bound (:func:`optroute.optimise.nlp_solve.certificate`) does not apply, or None.

    It applies on a fixed path (``fixed``) in static weather without current, bands, exclusion circle, for
    the fuel or cost objective; ``samples`` is the weather grid's summary, ``res`` the solve.
    """
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


def to_plan(ctx: PlanContext, frame: CorridorFrame, res: NLPResult, t0: np.datetime64, *, step_nm: float) -> Plan:
    """The plan of an NLP solution: its waypoints and leg speeds [kn] sailed from ``t0`` [UTC], scored by the referee."""
    return _to_plan_xy(ctx, frame, res.offset_nm, res.stw_kn, t0, step_nm=step_nm)


def _to_plan_xy(
    ctx: PlanContext,
    frame: CorridorFrame,
    offset_nm: np.ndarray,
    stw_kn: np.ndarray,
    t0: np.datetime64,
    *,
    step_nm: float,
) -> Plan:
    wp = frame.waypoints(offset_nm)
    return Plan.from_context(
        ctx, wp, np.asarray(stw_kn, dtype=float), departure=t0, status="candidate", step_nm=step_nm
    )


def _move_off(st: Tightening, v: Violation, plan: Plan, res: NLPResult) -> bool:
    """Move the lateral bounds of leg ``v.leg`` off the land (no-passage) point the verification met.

    The point is at fraction ``f`` along the leg, so at offset ``(1 − f) y_k + f y_{k+1}`` [nm, port +] in
    the leg's sweep; :func:`optroute.optimise.lateral.avoid_point` keeps the leg a margin (1 nm, doubled on every
    further cut of that leg) to the side with more room. False when the bounds are not the tightening's
    or neither side has room (the caller then shrinks the bounds about their middle).
    """
    if st.y_lo is None or st.y_hi is None:
        return False
    k = v.leg
    wp = np.asarray(plan.waypoints, dtype=float)
    d = float(geo.distance_nm(wp[k, 0], wp[k, 1], wp[k + 1, 0], wp[k + 1, 1]))
    f = float(geo.distance_nm(wp[k, 0], wp[k, 1], *v.position)) / d if d > 0 else 0.0
    y = np.asarray(res.offset_nm, dtype=float)
    at = (1.0 - f) * y[k] + f * y[k + 1]
    cuts = sum(f"land cut on leg {k}:" in line for line in st.log)
    moved = avoid_point(st.y_lo, st.y_hi, leg=k, fraction=f, offset_port_nm=at, margin_nm=2.0**cuts)
    if moved is None:
        return False
    st.y_lo, st.y_hi = moved
    st.log.append(f"land cut on leg {k}: bounds moved {2.0**cuts:g} nm off ({v.position[0]:.4f}, {v.position[1]:.4f})")
    return True


def tighten(st: Tightening, violations: list[Violation], plan: Plan, res: NLPResult) -> None:
    """Change the problem where the verification found it wrong (see the module docstring)."""
    kinds = {v.kind.split(":")[0] for v in violations}
    for v in violations:
        k = v.leg
        if v.kind in ("land", "no_passage") and _move_off(st, v, plan, res):
            pass
        elif v.kind in ("land", "no_passage", "corridor", "course"):
            st.bound_scale[k] *= 0.5
            st.bound_scale[k + 1] *= 0.5
    # the table's power is the model's up to the tabulation error: where the referee finds the engine outside its
    # range, the load limits move inwards by what it found beyond them
    over = [v.value / v.limit for v in violations if v.kind == "power_above_mcr" and np.isfinite(v.value)]
    if "power_above_mcr" in kinds:
        st.max_load *= 1.0 / (max(over, default=1.02) * 1.002)
    under = [v.limit / max(v.value, 1e-9) for v in violations if v.kind == "power_below_min"]
    if under:
        st.min_load = min(0.99 * st.max_load, st.min_load * max(under) * 1.002)
    if kinds & {"power_above_mcr", "power_below_min"}:
        # the engine's range is checked at the NLP's samples and between them by the referee: denser samples
        st.samples_per_leg = min(st.samples_per_leg + 1, 8)
    if "band" in kinds:
        # back the edges off by what the verification found beyond them, with room to spare
        beyond = max(
            (abs(v.value - v.limit) / max(abs(v.limit), 1e-9) for v in violations if v.kind.startswith("band:")),
            default=0.0,
        )
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


def route_plan(route: Route | None, ctx: PlanContext, step_nm: float) -> Plan | None:
    """The search route as a plan (one speed per leg), when it passes verification."""
    if route is None:
        return None
    stw = np.where(np.isfinite(route.stw_kn) & (route.stw_kn > 0), route.stw_kn, route.sog_kn)
    if not np.all(np.isfinite(stw) & (stw > 0)):
        return None
    try:
        plan = Plan.from_context(
            ctx, np.asarray(route.waypoints), stw, departure=route.departure, status="search", step_nm=step_nm
        )
    except OptrouteError:  # the fallback plan is optional; the failure being reported is what matters
        return None
    return plan if not plan.verify(step_nm=step_nm) else None


def _minimum_time(
    prob: Problem,
    nlp: SpeedNLP,
    *,
    ctx: PlanContext,
    t0: np.datetime64,
    route: Route | None,
    budget: int,
    solve_kw: Mapping[str, Any],
    warm_rules: BandRules,
    first_warm: Mapping[str, np.ndarray],
    log: list[str],
    passages: list[TimedStart] | None = None,
) -> Solved | None:
    """The minimum-time solve of the corridor, tried from several warm starts; None when every one fails.

    Ipopt's minimum-time solve is local and can fail from one start and succeed from another (a storm
    that follows the ship, bands whose sides are fixed from the start's timing, a minimum load that
    leaves a narrow speed window between it and a band). The starts, cheapest and most often right
    first: the fastest allowed speed leg by leg with the true model (Boeing's reduction from the top
    speed) when a speed is allowed at every point of it; the earliest passage of the time-expanded
    search (:func:`optroute.optimise.min_time.timed_safe_start`: its timing avoids the places and times where
    no speed is allowed, which the point-by-point reduction meets at the lowest speed, below the
    minimum load, on band sides no speed keeps); the search route's speeds, the failed solve's own
    (safe) start, and safe starts from 3/4 and 1/2 of the top speed (they reach a storm later, so
    their band sides are other ones).
    """
    kw = dict(solve_kw)
    kw["objective"] = "time"
    frame = prob.frame

    def safe(fraction: float) -> dict[str, np.ndarray]:
        return safe_warm_start(ctx, frame, t0, fraction * prob.v_max, prob.v_min, rules=warm_rules)

    def timed() -> Mapping[str, np.ndarray] | None:
        started = _time.perf_counter()
        found = timed_safe_start(ctx, frame, t0, v_min_kn=prob.v_min, v_max_kn=prob.v_max, rules=warm_rules)
        log.append(
            f"timed safe start ({_time.perf_counter() - started:.2f} s): "
            + (f"{found.arrival_h:.3f} h" if isinstance(found, TimedStart) else f"no passage found: {found}")
        )
        if isinstance(found, DeadEnd):
            return None
        if passages is not None:
            passages.append(found)
        return found.warm()

    top = safe(1.0)
    # a leg at the lowest speed is where no speed was allowed: that start's sides cannot be kept
    top_clean = bool(np.all(top["stw_kn"] > prob.v_min + 1e-9))
    starts: list[tuple[str, Callable[[], Mapping[str, np.ndarray] | None]]] = []
    if top_clean:
        starts.append(("top speed", lambda: top))
    starts.append(("timed safe start", timed))
    if route is not None:
        starts.append(("search route", lambda: route_warm_start(route, frame)))
    # a dead end of the timed search is no proof (its speed ladder and blocks may miss a narrow window): the other
    # starts are still tried
    starts += [
        ("first start", lambda: first_warm),
        ("3/4 top speed", lambda: safe(0.75)),
        ("1/2 top speed", lambda: safe(0.5)),
    ]
    if not top_clean:
        starts.append(("top speed", lambda: top))
    for name, make in starts:
        made = make()
        if made is None:
            continue
        warm = clear_of_exclusion(dict(made), frame, prob.exclusion, t0, prob.y_lo, prob.y_hi)
        fast = prob.solve(nlp, eta_h=None, warm=warm, budget=budget, **kw)
        log.append(
            f"minimum time from {name}: Ipopt {fast.res.status}"
            + (f", {fast.res.duration_total_h:.3f} h" if fast.ok else "")
        )
        if fast.ok:
            return fast
    return None


def longer_horizon(
    prob: Problem, st: Tightening, sampler: WeatherSampler, data_end_h: float, horizon_h: float
) -> tuple[Problem, SpeedNLP]:
    """The problem on a weather grid long enough for a minimum-time passage that misses the ETA.

    The ETA's grid ends just after the ETA; a minimum-time solve that arrives later would meet weather
    held at the grid's last time. The longer grid runs to 1.3 × the passage at half the design speed
    (the free-arrival horizon) or the weather's end; the rest of the problem is the same.
    """
    frame, grid = prob.frame, prob.grid
    want = 1.3 * float(frame.s_nm[-1]) / max(prob.v_min, 0.5 * prob.ship.design_speed_kn)
    end = min(max(want, horizon_h), data_end_h) if math.isfinite(data_end_h) else max(want, horizon_h)
    t_h = np.asarray(grid.t_h, dtype=float)
    if end <= horizon_h + 1e-9 or t_h.size < 2:
        return prob, prob.build(st)
    dt = float(t_h[1] - t_h[0])
    ds = float(grid.s_nm[1] - grid.s_nm[0]) if grid.s_nm.size > 1 else float(frame.s_nm[-1])
    dy = float(grid.y_nm[1] - grid.y_nm[0]) if grid.y_nm.size > 1 else 1.0
    g, smp = weather_grid(frame, sampler, departure=prob.departure, t_end_h=end, dt_h=dt, ds_nm=ds, dy_nm=dy)
    p = Problem(
        frame=frame,
        grid=g,
        samples=smp,
        power=prob.power,
        ship=prob.ship,
        rules=prob.rules,
        y_lo=prob.y_lo,
        y_hi=prob.y_hi,
        v_min=prob.v_min,
        v_max=prob.v_max,
        exclusion=prob.exclusion,
        departure=prob.departure,
        solver_options=prob.solver_options,
        jit=prob.jit,
    )
    return p, p.build(st)


#: Ipopt statuses that stop at a limit rather than at a verdict: the last iterate may still be feasible.
LIMIT_STATUSES = frozenset({"Maximum_Iterations_Exceeded", "Maximum_CpuTime_Exceeded", "Maximum_WallTime_Exceeded"})


def feasible_iterate(res: NLPResult, ctx: PlanContext, frame: CorridorFrame, t0: np.datetime64, step_nm: float) -> bool:
    """Ipopt hit a limit at an iterate clear of every band whose plan is usable.

    Usable: within Ipopt's constraint tolerance, or else its plan — recomputed with the true model, times
    integrated from the speeds — passes :meth:`Plan.verify`. Near a flat optimum of a piecewise-smooth model
    Ipopt can circle the solution with its scaled rows a few 1e-5 off (the time-dynamics rows, which the plan
    does not use) until its iteration limit; the independent verification, not Ipopt's tolerance, is what a
    returned plan must pass.
    """
    if res.status not in LIMIT_STATUSES or np.any(res.samples.inside):
        return False
    if res.max_violation <= VIOLATION_TOL:
        return True
    return not to_plan(ctx, frame, res, t0, step_nm=step_nm).verify(step_nm=step_nm)


def first_failure(
    prob: Problem,
    nlp: SpeedNLP,
    sol: Solved,
    *,
    longer: Callable[[], tuple[Problem, SpeedNLP]],
    ctx: PlanContext,
    cap_h: float | None,
    eta_user_h: float | None,
    t0: np.datetime64,
    route: Route | None,
    budget: int,
    step_nm: float,
    solve_kw: Mapping[str, Any],
    warm_rules: BandRules,
    first_warm: Mapping[str, np.ndarray],
    log: list[str],
) -> Solved:
    """The first solve failed: find out why, and recover when the problem is solvable after all.

    The minimum-time solve (:func:`_minimum_time`, several warm starts) decides:

    * it arrives after the ETA (or after the weather's end without an ETA): :class:`InfeasibleETA`
      carrying its arrival (:class:`WeatherCoverageError`);
    * it meets the ETA: the ETA is reachable and the minimum-time solution is a feasible start, so
      the problem is solved again from it (for ``objective="time"`` it *is* the solution) and the
      new solve is returned; when that fails too, :class:`SolverFailure` carries the minimum-time
      plan as the best verified plan;
    * it fails from every start: the elastic phase-1 problem (:func:`optroute.optimise.phase1.diagnose`)
      raises :class:`~optroute.errors.NoSafePassage` or :class:`InfeasibleETA` where it proves one, or
      gives a feasible start that is solved from; else :class:`SolverFailure` with the first solve's
      Ipopt status and the best verified plan known (the search route's, the safe warm start's, the
      timed passage's).
    """
    if feasible_iterate(sol.res, ctx, prob.frame, t0, step_nm):
        log.append(
            f"kept Ipopt's last iterate ({sol.res.status}, largest violation {sol.res.max_violation:.2g}): "
            "its plan passes verification; a feasible, not optimal, solution"
        )
        return replace(sol, ok=True)
    passages: list[TimedStart] = []
    fast = _minimum_time(
        prob,
        nlp,
        ctx=ctx,
        t0=t0,
        route=route,
        budget=budget,
        solve_kw=solve_kw,
        warm_rules=warm_rules,
        first_warm=first_warm,
        log=log,
        passages=passages,
    )
    t_grid = np.asarray(prob.grid.t_h, dtype=float)
    if fast is not None and cap_h is not None and t_grid.size > 1 and fast.res.duration_total_h > t_grid[-1]:
        # it arrives after the ETA's weather grid ends: again on a grid that covers the passage
        p_long, nlp_long = longer()
        if p_long is not prob:
            again = p_long.solve(
                nlp_long,
                eta_h=None,
                warm={"offset_nm": fast.res.offset_nm, "stw_kn": fast.res.stw_kn},
                budget=budget,
                **{**solve_kw, "objective": "time"},
            )
            prob.absorb_counts(p_long)  # its build and solve are this call's too (solver_stats counts every solve)
            log.append(f"minimum time on a grid to {float(p_long.grid.t_h[-1]):.1f} h: Ipopt {again.res.status}")
            if again.ok:
                fast = again
    if fast is not None and cap_h is not None and fast.res.duration_total_h > cap_h + 1e-6:
        earliest = t0 + _h_to_td(fast.res.duration_total_h)
        if eta_user_h is None:
            raise WeatherCoverageError(
                f"the passage cannot be completed within the weather's time span ({cap_h:.1f} h after departure): "
                f"the minimum-time solve arrives {fast.res.duration_total_h:.1f} h after departure, at {units.format_utc(earliest)}; "
                "extend the forecast or pass an ETA"
            )
        raise InfeasibleETA(
            f"the ETA {cap_h:.2f} h after departure cannot be met: the minimum-time solve of this corridor arrives "
            f"{fast.res.duration_total_h:.2f} h after departure, at {units.format_utc(earliest)} (Ipopt: {fast.res.status}); give an "
            "ETA at or after that, or widen the corridor",
            earliest_arrival=earliest,
        )
    status = sol.res.status
    candidates = [sol]
    if fast is not None:
        if solve_kw["objective"] == "time":
            return fast
        again = prob.solve(
            nlp,
            eta_h=cap_h,
            warm={"offset_nm": fast.res.offset_nm, "stw_kn": fast.res.stw_kn},
            budget=budget,
            **solve_kw,
        )
        log.append(f"attempt 0 again from the minimum-time solution: Ipopt {again.res.status}")
        if again.ok:
            return again
        status = again.res.status
        candidates.insert(0, again)
    for cand in candidates:
        if feasible_iterate(cand.res, ctx, prob.frame, t0, step_nm):
            # Ipopt stopped on its iteration or time limit at a point that satisfies every constraint: a
            # usable, not an optimal, solution. It goes through verify() like any other; the plan's status
            # is "feasible" and solver_stats keeps Ipopt's status verbatim.
            log.append(
                f"kept Ipopt's last iterate ({cand.res.status}, largest violation "
                f"{cand.res.max_violation:.2g}) as a feasible, not optimal, solution"
            )
            return replace(cand, ok=True)
    # the elastic phase-1 problem: a feasible start after all, or where (and whether) the passage is closed
    found = diagnose(
        prob, nlp, ctx=ctx, warm=first_warm, cap_h=cap_h, eta_user_h=eta_user_h, t0=t0, budget=budget,
        solve_kw=solve_kw, log=log,
    )  # fmt: skip
    if found is not None:
        return found
    dead = next(
        (
            line.split("no passage found: ", 1)[1]
            for line in log
            if line.startswith("timed safe start") and "no passage found: " in line
        ),
        None,
    )
    raise SolverFailure(
        (
            f"the timed search along the centreline found no passage: {dead} (the bands, the engine's load range "
            f"[{prob.power.min_load:g}, 1] of MCR and speeds of {prob.v_min:g}–{prob.v_max:.1f} kn, on its "
            "speed ladder), and the NLP found none from any start: a wider corridor, another route or another "
            "departure may pass. "
            if dead is not None
            else ""
        )
        + f"Ipopt did not solve the corridor problem: status {status!r} (best of {sol.n_solves} solves of the band "
        f"outer loop, {sol.res.iterations} iterations, largest constraint violation {sol.res.max_violation:.3g}); "
        + (
            "the minimum-time solve meets the ETA (its plan is the error's best_plan); "
            if fast is not None
            else "the minimum-time solve failed from every warm start too; "
        )
        + "raise ipopt.max_iter in solver_options or band_solves, use shorter legs, or check the corridor and ETA "
        f"(tried: {'; '.join(log)})",
        status=status,
        best_plan=_best_known_plan(fast, route, ctx, prob.frame, t0, first_warm, step_nm, passages),
    )


def _best_known_plan(
    fast: Solved | None,
    route: Route | None,
    ctx: PlanContext,
    frame: CorridorFrame,
    t0: np.datetime64,
    safe: Mapping[str, np.ndarray],
    step_nm: float,
    passages: list[TimedStart] | None = None,
) -> Plan | None:
    """The best plan that passes verification: the minimum-time solve's, the search route's, the safe start's,
    the timed safe start's passage (:func:`optroute.optimise.min_time.timed_safe_start`)."""

    def own(stw: np.ndarray, offsets: np.ndarray, status: str) -> Plan:
        return Plan.from_context(
            ctx,
            frame.waypoints(np.asarray(offsets, dtype=float)),
            np.asarray(stw, dtype=float),
            departure=t0,
            status=status,
            step_nm=step_nm,
        )

    if fast is not None:
        try:
            plan = to_plan(ctx, frame, fast.res, t0, step_nm=step_nm)
            if not plan.verify(step_nm=step_nm):
                return replace(plan, status="minimum time")
        except OptrouteError:  # a fallback plan is optional; the failure being reported is what matters
            pass
    candidates: list[Callable[[], Plan | None]] = [
        lambda: route_plan(route, ctx, step_nm),
        lambda: own(safe["stw_kn"], safe["offset_nm"], "safe warm start"),
    ]
    candidates += [lambda p=p: own(p.stw_kn, p.offset_nm, "timed safe start") for p in (passages or [])]
    for make in candidates:
        try:
            plan = make()
        except OptrouteError:  # a fallback plan is optional; the failure being reported is what matters
            continue
        if plan is not None and not plan.verify(step_nm=step_nm):
            return plan
    return None
