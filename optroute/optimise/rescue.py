"""The corridor optimiser's recovery steps: warm starts, the first-failure diagnosis and tightening.

What :func:`optroute.optimise.api.optimise_corridor` and
:meth:`optroute.optimise.corridor_problem.PreparedCorridor.solve` do when a solve fails or its plan
does not verify: the diagnosis of a failed first solve by the elastic phase-1 problem (a safe start,
an infeasible ETA, no safe passage, or a solver problem), the tightening of the rows the referee
flagged, and the plan built from an NLP solution with the true model.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from formulations.common import Band
from formulations.phase1 import SLACK_TOL
from formulations.speed_nlp import NLPResult, SpeedNLP
from optroute import geodesy as geo
from optroute.errors import SolverFailure
from optroute.optimise.lateral import avoid_point
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
    safe_warm_start,
    warm_point,
)
from optroute.optimise.phase1 import infeasible_eta, phase1_point
from optroute.optimise.rows import HS_SLACK
from optroute.optimise.starts import verified_plan
from optroute.plan.result import Exclusion, Plan, PlanContext, Violation
from optroute.search.route import Route
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


def start_in_nlp_bands(
    nlp: SpeedNLP,
    st: Tightening,
    warm: Mapping[str, np.ndarray],
    rules_bands: tuple[Band, ...],
    true_hs: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> tuple[dict[str, int], float, float]:
    """Where a start lies inside the NLP's bands (its samples, the NLP's own evaluation), counted by why, and the
    back-offs that would clear it.

    The NLP imposes each band from ``(1 − hs_margin)`` times the rules' Hs threshold and with its edges moved out by
    ``widen`` (:func:`~optroute.optimise.nlp_inputs.formulation_bands`); its rules for the IMO bands are conservative
    (no wave-angle sector for surf-riding, no wavelength condition for the high-wave zone) and it sees a smoothed
    sea. A start the referee passed can therefore break the NLP's band rows, and the NLP, started outside its own
    feasible set, may find no solution. Per (sample, band) inside the NLP's band: ``"below_rules_threshold"`` (Hs
    under the rules' threshold there), ``"back_off_only"`` (in the edges' back-off, outside the rules' band) or
    ``"inside_rules_band"`` (where the rules' threshold is met and the ratio is inside the rules' band, as the NLP
    evaluates it); ``"samples"`` all. ``rules_bands`` are the rules' own, in the NLP's order
    (:func:`~optroute.optimise.nlp_inputs.formulation_bands` without back-offs).

    Returns
    -------
    counts : dict of str to int
    hs_margin, widen : float
        ``st.hs_margin`` and ``st.widen`` lowered to half the start's clearance from the rules' threshold and edges
        at the samples of the first two kinds (unchanged where there are none): with them the start is clear of the
        NLP's bands but where the third kind puts it inside. With ``true_hs`` (the referee's Hs [m] at the NLP's
        samples: times [h after departure], along-track and lateral positions [nm], each (N, m)), ``hs_margin`` is
        lowered no further than the NLP's Hs reads under the referee's at the start's samples in a band's seas
        (:func:`hs_under_read`): below that, a sea the referee finds over the threshold could be one where the NLP
        applies no band (the storm re-plan of ``tests/test_voyage_sim.py`` is the case).
    """
    y0, v0 = warm_point(nlp, warm)  # the point the solve starts from (Problem.solve)
    state = nlp.evaluate(y0, v0, nlp.consistent_times(y0, v0))
    out = {"samples": 0, "below_rules_threshold": 0, "back_off_only": 0, "inside_rules_band": 0}
    hs_margin, widen = st.hs_margin, st.widen
    for k, j, b in np.argwhere(state.inside):
        ratio = float(state.ratio[k, j, b])
        rules_hs, lo, hi = rules_bands[b].hs_min_m, rules_bands[b].lower, rules_bands[b].upper
        if state.hs_m[k, j] < rules_hs:
            out["below_rules_threshold"] += 1
            hs_margin = min(hs_margin, 0.5 * (1.0 - state.hs_m[k, j] / rules_hs))
        elif lo < ratio < hi:
            out["inside_rules_band"] += 1
        else:
            out["back_off_only"] += 1
            if lo > 0.0 and ratio <= lo:
                room = 1.0 - ratio / lo
            elif np.isfinite(hi) and hi > 0.0 and ratio >= hi:
                room = ratio / hi - 1.0
            else:  # an edge at or below 0: no relative back-off clears it
                room = 0.0
            widen = min(widen, 0.5 * room)
        out["samples"] += 1
    if true_hs is not None and hs_margin < st.hs_margin:
        floor = hs_under_read(state.hs_m, true_hs(state.time_h, state.s_nm, state.y_nm), rules_bands)
        hs_margin = max(hs_margin, min(st.hs_margin, floor))
    return out, hs_margin, widen


def hs_under_read(nlp_hs_m: np.ndarray, true_hs_m: np.ndarray, rules_bands: tuple[Band, ...]) -> float:
    """How far the NLP's Hs reads under the referee's in a band's seas, as a share of that band's Hs threshold [-].

    ``nlp_hs_m`` and ``true_hs_m`` are Hs [m] at the same samples (the NLP's smooth weather and the referee's
    interpolation of the data); ``rules_bands`` the rules' own bands. Over the samples where the referee's sea reaches
    ``(1 − HS_SLACK)`` of a band's threshold, the largest ``(true − nlp) / threshold``; 0 where there are none or the
    NLP never reads under. The NLP applies a band from ``(1 − hs_margin)`` times the threshold by its own Hs: with
    ``hs_margin`` at least this, every such sample the referee finds over the threshold is one where the NLP applies
    the band.
    """
    nlp_hs, true = np.asarray(nlp_hs_m, dtype=float), np.asarray(true_hs_m, dtype=float)
    out = 0.0
    for band in rules_bands:
        thr = float(band.hs_min_m)
        if not thr > 0.0:
            continue
        near = np.isfinite(true) & (true >= (1.0 - HS_SLACK) * thr)
        if near.any():
            out = max(out, float(np.max(true[near] - nlp_hs[near])) / thr)
    return out


def route_plan(route: Route | None, ctx: PlanContext, step_nm: float) -> Plan | None:
    """The search route as a plan (one speed per leg), when it passes verification."""
    if route is None:
        return None
    stw = np.where(np.isfinite(route.stw_kn) & (route.stw_kn > 0), route.stw_kn, route.sog_kn)
    # the fallback plan is optional; the failure being reported is what matters
    return verified_plan(ctx, route.waypoints, stw, route.departure, step_nm, "search")


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
        windows=prob.windows,
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
    first_warm: Mapping[str, np.ndarray],
    log: list[str],
) -> Solved:
    """The first solve failed and no start verifies: find out why from the elastic phase-1 problem, and solve from it.

    Ipopt's last iterate is kept where it stopped at a limit on a plan that verifies (:func:`feasible_iterate`).
    Else the elastic phase-1 problem (:func:`optroute.optimise.phase1.phase1_point`, the ETA row elastic) decides,
    started from the other end of the schedule than the failed solve (whose start was ``first_warm``): the
    fastest speeds the true model allows leg by leg (Boeing's reduction from the top speed,
    :func:`~optroute.optimise.nlp_solve.safe_warm_start` with the call's rules, moved clear of an exclusion circle;
    on the beam-seas case of tests/test_band_suite.py the fuel solve from phase-1's point found 18.90 t from this
    start, as the minimum-time rescue did, and 21.64 t from the failed solve's start; from the reduction with the
    NLP's back-offs (:func:`~optroute.optimise.nlp_solve.warm_rules`) phase-1 stayed in the synchronous-roll band
    there):

    * a leg the true model closes: :class:`~optroute.errors.NoSafePassage` (raised there);
    * safe, but the ETA (or, without one, the weather's end) missed from its point: the minimum-time solve from
      that point (on a weather grid covering the passage, ``longer``) gives the earliest arrival,
      :class:`InfeasibleETA` (:class:`WeatherCoverageError`); where it meets the ETA after all, it is the start;
    * safe and on time: the problem is solved again from its point (for ``objective="time"`` from the
      minimum-time point it *is* the solution).

    Where phase-1 finds no safe point that the true model confirms closed, or the solve from its point fails
    too, :class:`SolverFailure` with Ipopt's status (``best_plan``: the search route's plan when it verifies;
    :func:`optroute.optimise.api.optimise_corridor` adds the minimum-time plan).
    """
    if feasible_iterate(sol.res, ctx, prob.frame, t0, step_nm):
        log.append(
            f"kept Ipopt's last iterate ({sol.res.status}, largest violation {sol.res.max_violation:.2g}): "
            "its plan passes verification; a feasible, not optimal, solution"
        )
        return replace(sol, ok=True)
    frame = prob.frame
    top = safe_warm_start(ctx, frame, t0, prob.v_max, prob.v_min, rules=prob.rules)
    top = clear_of_exclusion(top, frame, prob.exclusion, t0, prob.y_lo, prob.y_hi)
    log.append(f"phase-1 from the fastest safe speeds, not the failed solve's start ({np.mean(first_warm['stw_kn']):.1f} kn "
               "on average)")  # fmt: skip
    point = phase1_point(prob, nlp, ctx=ctx, warm=top, cap_h=cap_h, t0=t0, log=log)
    if point is None:
        raise _failure(sol, route, ctx, step_nm, log, "the elastic phase-1 problem found no safe start either")
    warm = {"offset_nm": point.offset_nm, "stw_kn": point.stw_kn}
    if cap_h is not None and point.eta_slack_h > SLACK_TOL:
        fast = _fastest(prob, nlp, warm, float(point.time_h[-1]), longer=longer, budget=budget, solve_kw=solve_kw,
                        log=log)  # fmt: skip
        kw = {"cap_h": cap_h, "eta_user_h": eta_user_h, "t0": t0}
        if fast is None:
            infeasible_eta(float(point.time_h[-1]), **kw, what="the earliest safe passage the elastic phase-1 "
                           "problem found (the minimum-time solve from it failed)")  # fmt: skip
        arrival_h = fast.res.duration_total_h
        if arrival_h > cap_h + 1e-6:
            infeasible_eta(arrival_h, **kw, what=f"the minimum-time solve of this corridor (Ipopt: {fast.res.status})")
        if solve_kw["objective"] == "time":
            return fast
        warm = {"offset_nm": fast.res.offset_nm, "stw_kn": fast.res.stw_kn}
    again = prob.solve(nlp, eta_h=cap_h, warm=warm, budget=budget, **solve_kw)
    log.append(f"solve from the phase-1 point: Ipopt {again.res.status}")
    if again.ok:
        return again
    if feasible_iterate(again.res, ctx, prob.frame, t0, step_nm):
        log.append(f"kept Ipopt's last iterate ({again.res.status}) from the phase-1 point: its plan verifies")
        return replace(again, ok=True)
    raise _failure(again, route, ctx, step_nm, log, "nor from the elastic phase-1 problem's safe point")


def _fastest(
    prob: Problem,
    nlp: SpeedNLP,
    warm: Mapping[str, np.ndarray],
    arrival_h: float,
    *,
    longer: Callable[[], tuple[Problem, SpeedNLP]],
    budget: int,
    solve_kw: Mapping[str, Any],
    log: list[str],
) -> Solved | None:
    """The minimum-time solve from ``warm`` (phase-1's point, arriving ``arrival_h`` [h]); on a weather grid that covers
    the passage when phase-1 arrives after this one's end (:func:`longer_horizon`). None when it fails."""
    p, n = prob, nlp
    if arrival_h > float(np.asarray(prob.grid.t_h, dtype=float)[-1]):
        p, n = longer()
    fast = p.solve(n, eta_h=None, warm=warm, budget=budget, **{**solve_kw, "objective": "time"})
    prob.absorb_counts(p)  # its build and solves are this call's too (solver_stats counts every solve)
    log.append(
        f"minimum time from the phase-1 point on a grid to {float(p.grid.t_h[-1]):.1f} h: Ipopt {fast.res.status}"
        + (f", {fast.res.duration_total_h:.3f} h" if fast.ok else "")
    )
    return fast if fast.ok else None


def _failure(
    sol: Solved, route: Route | None, ctx: PlanContext, step_nm: float, log: list[str], why: str
) -> SolverFailure:
    """:class:`SolverFailure` with Ipopt's status and what was tried."""
    return SolverFailure(
        f"Ipopt did not solve the corridor problem: status {sol.res.status!r} (best of {sol.n_solves} solves of the "
        f"band outer loop, {sol.res.iterations} iterations, largest constraint violation "
        f"{sol.res.max_violation:.3g}); {why}; raise ipopt.max_iter in solver_options or band_solves, use shorter "
        f"legs, or check the corridor and ETA (tried: {'; '.join(log)})",
        status=sol.res.status,
        best_plan=route_plan(route, ctx, step_nm),
    )
