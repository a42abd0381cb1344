"""Ensemble-robust corridor plans: one plan that is safe in every member of an ensemble (issue 16 item 3).

:func:`optimise_robust` is :func:`optroute.optimise_corridor` with ``weather`` an ensemble (a dataset with a
``member`` dimension, :func:`optroute.weather.scenarios.ensemble`) and ``robust="all"`` or ``"cvar"``:

* **Set-up per member.** Every member is prepared as :func:`optimise_corridor` prepares one weather
  (:class:`~optroute.optimise.corridor_problem.PreparedCorridor`: the corridor frame, the member's weather on the
  corridor's grid as B-spline interpolants and the ship's own performance model tabulated in that member's sea,
  the member's navigable lateral bounds). The lateral bounds are intersected over the members.
* **One plan, every member's rows.** :class:`formulations.robust_nlp.RobustSpeedNLP` decides one set of waypoint
  offsets and leg speeds through water; its rows are the corridor NLP's stacked per member (each with its own
  arrival times, since the speed over ground depends on the member's current): danger bands (sides per member),
  the engine's load range (MCR and minimum power), the moving exclusion, and the ETA for every member's arrival.
* **Start: a schedule safe in every member.** The NLP keeps the band sides and the samples where a band applies
  of its start; from the centreline at the ETA's constant speed two members can ask for opposite sides of one band
  (one member's storm passed ahead of it, another's behind), and Ipopt then declares the stacked problem infeasible
  although a common schedule exists. Without a warm plan or route, ``"all"`` and ``"cvar"`` start from the 3-D DP of
  Shao et al. on the members' joint leg cost (:func:`~optroute.optimise.robust_start.ensemble_dp_path`: feasible
  only where feasible in every member, mean fuel). Where that lattice has no schedule by the ETA safe in every
  member, the NLP is still tried from the centreline; if it finds no verified plan either, the lattice's
  :class:`~optroute.errors.InfeasibleETA` (the earliest arrival safe in all members) or
  :class:`~optroute.errors.NoSafePassage` (none within the weather's horizon) is raised, naming the members with a
  schedule of their own and those without, in place of a :class:`~optroute.errors.SolverFailure`.
* **Objective.** ``robust="all"``: the mean of the members' fuel (or time, cost) — the members equally likely;
  ``robust="cvar"``: their conditional value at risk at level ``cvar_alpha`` by the Rockafellar–Uryasev auxiliary
  variable (Rockafellar & Uryasev 2000; :func:`cvar` is the referee's value of it). In both, every constraint holds
  in every member.
* **All but a stated fraction.** ``robust="chance"`` with ``violation_fraction=ε`` in (0, 1): the plan may break
  the constraints (bands, engine range, exclusion, ETA) of at most ``k = ⌊ε M⌋`` members, the sample-based chance
  constraint "P(violation) ≤ ε" over equally likely members; objective the mean over all M members. Formulated
  exactly for small M: every choice of ``k`` members to drop is solved
  (:meth:`~formulations.robust_nlp.RobustSpeedNLP.solve_chance`; dropping more only relaxes, so the optimum drops
  exactly ``k``), at most :data:`~formulations.robust_nlp.MAX_DROP_CHOICES` choices (else ConfigError). Not chosen:
  the CVaR-based convex approximation of the chance constraint (Nemirovski & Shapiro 2006, "Convex approximations
  of chance constrained programs", SIAM J. Optim. 17(4)), conservative — it guarantees the fraction but may drop no
  member where the enumeration drops ``k``. The plan is verified in every member it keeps;
  ``solver_stats["robust"]["members_violated"]`` lists the members the referee finds it breaks (at most ``k``,
  all among ``dropped_members``).
* **Verified in every member.** The plan of the solution is evaluated by the referee in the reference member
  (its context: ship, rules, corridor, ETA, exclusion) and :meth:`Plan.verify(weather=member) <Plan.verify>` is run
  for every member. Where a member breaks a constraint the problem is tightened where the verification says (band
  edges and threshold backed off, load limits, exclusion radius, the ETA) and solved again, at most
  ``max_retries`` times; a plan that fails any member is never returned. Where no solve gives a plan clean in every
  member, the joint 3-D DP's schedule (the start) is returned if the referee finds it clean in every member
  (``status="start"``, as a single weather's verified start where the NLP does not improve on it), else
  :class:`~optroute.errors.SolverFailure`, whose ``best_plan`` is the warm plan when that verifies in every member.
  Kept although ``constraint_rows="referee"`` is available: on tests/test_robust.py's three-storm ensemble the
  loop fires twice for ``"all"`` and ``"cvar"`` with the midpoint rows and twice with the referee's, the same
  plans: what fails is the engine's MCR where the NLP's smooth power table is below the
  performance model's peak in the storm's core — a table error that rows at the referee's points do not see, but
  the loop's per-leg power factor corrects.

The returned :class:`~optroute.plan.result.Plan` is evaluated in the reference member (``reference_member``,
default 0: :func:`optroute.weather.scenarios.ensemble`'s control): its ``legs`` and ``total_fuel_t`` are that
member's; ``solver_stats["robust"]`` holds every member's fuel and arrival by the referee, their mean and CVaR,
and the NLP's objective.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np
import xarray as xr

from formulations.robust_nlp import MAX_DROP_CHOICES, RobustResult, RobustSpeedNLP
from optroute._checks import finite
from optroute.errors import ConfigError, InfeasibleETA, NoSafePassage, OptrouteError, SolverFailure
from optroute.optimise.corridor_setup import cut_frame
from optroute.optimise.nlp_inputs import formulation_bands, moving_exclusion
from optroute.optimise.nlp_solve import VIOLATION_TOL, route_warm_start
from optroute.optimise.rescue import LIMIT_STATUSES, plan_warm_start
from optroute.optimise.robust_start import ensemble_dp_path
from optroute.optimise.rows import (
    BAND_LEG_NM,
    ROW_PLACEMENTS,
    band_leg_for,
    canonical_rows,
    leg_end_rows,
    only_where_binding,
    points_of,
    sample_layout,
)
from optroute.optimise.starts import track_warm_start
from optroute.plan.result import Plan, Violation
from optroute.search.route import Corridor, Route
from optroute.units import as_utc_time, format_utc, timedelta_to_h

__all__ = ["ROBUST_MODES", "cvar", "member_datasets", "optimise_robust"]

#: The values of ``optimise_corridor(robust=...)``.
ROBUST_MODES = ("all", "cvar", "chance")

_BAND_KINDS = "band:"
_ENGINE = ("power_above_mcr", "power_below_min")


def member_datasets(weather: xr.Dataset) -> list[xr.Dataset]:
    """The members of an ensemble (a canonical dataset with a ``member`` dimension) as canonical datasets.

    Each keeps the ensemble's global attributes but ``ensemble`` (its own storm attrs are those of
    :func:`optroute.weather.scenarios.member` when the dataset came from :func:`~optroute.weather.scenarios.ensemble`).

    Raises
    ------
    ConfigError
        Not a dataset with a ``member`` dimension, or no member in it.
    """
    if not isinstance(weather, xr.Dataset) or "member" not in weather.dims:
        raise ConfigError(
            f"robust plans need an ensemble: an xarray.Dataset with a 'member' dimension, got {type(weather).__name__}"
            f"{' without one' if isinstance(weather, xr.Dataset) else ''}; build one with "
            "optroute.weather.scenarios.ensemble(...) or stack members with xarray.concat(..., dim='member')"
        )
    n = int(weather.sizes["member"])
    if n < 1:
        raise ConfigError("the ensemble has no member (member dimension of size 0); give at least one member")
    out = []
    for k in range(n):
        one = weather.isel(member=k)
        one = one.drop_vars("member") if "member" in one.coords else one
        one.attrs = {key: v for key, v in weather.attrs.items() if key != "ensemble"}
        one.attrs["ensemble_member"] = k
        out.append(one)
    return out


def cvar(values: Any, alpha: float) -> float:
    """Conditional value at risk of equally likely outcomes at level ``alpha`` in [0, 1).

    ``CVaR_α = min_z z + Σ_m max(v_m − z, 0) / ((1 − α) M)`` (Rockafellar & Uryasev 2000), evaluated at its
    breakpoints (the function of ``z`` is convex and piecewise linear with kinks at the values): the mean of the
    worst ``(1 − α)`` share of the outcomes, the boundary outcome weighted by its fraction. α = 0 is the mean.
    """
    v = np.asarray(values, dtype=float).ravel()
    if v.size == 0 or not np.isfinite(v).all():
        raise ConfigError(f"cvar needs finite values, got {v!r}")
    a = float(finite("cvar_alpha", alpha, minimum=0.0, error=ConfigError))
    if a >= 1.0:
        raise ConfigError(f"cvar_alpha={alpha!r} must be below 1 (1 is the worst member: use a value such as 0.9)")
    scale = 1.0 / ((1.0 - a) * v.size)
    return float(min(z + scale * np.maximum(v - z, 0.0).sum() for z in v))


def _check_options(robust: Any, cvar_alpha: Any, fraction: Any, eta_mode: str, unsupported: Mapping[str, Any]):
    """``(alpha, violation_fraction)`` checked (ConfigError naming the value and the fix)."""
    if robust not in ROBUST_MODES:
        raise ConfigError(
            f"robust={robust!r} is not known; use 'all' (every member's constraints, mean objective), 'cvar' "
            "(every member's constraints, CVaR of the objective at cvar_alpha) or 'chance' (every member's but a "
            "violation_fraction of them, mean objective)"
        )
    alpha = float(finite("cvar_alpha", cvar_alpha, minimum=0.0, error=ConfigError))
    if alpha >= 1.0:
        raise ConfigError(f"cvar_alpha={cvar_alpha!r} must be in [0, 1): 0 is the mean, towards 1 the worst member")
    if robust != "cvar" and alpha != 0.0:
        raise ConfigError(f"cvar_alpha={cvar_alpha!r} is only used with robust='cvar'; pass robust='cvar' or drop it")
    eps = float(finite("violation_fraction", fraction, minimum=0.0, error=ConfigError))
    if robust != "chance" and eps != 0.0:
        raise ConfigError(
            f"violation_fraction={fraction!r} is only used with robust='chance'; pass robust='chance' or drop it"
        )
    if robust == "chance" and not 0.0 < eps < 1.0:
        raise ConfigError(
            f"violation_fraction={fraction!r} must be in (0, 1) with robust='chance' (e.g. 0.1: all but one member "
            "in ten may be violated); for every member use robust='all'"
        )
    if eta_mode != "le":
        raise ConfigError(
            f"eta_mode={eta_mode!r}: a robust plan arrives by the ETA in every member ('le'); the members' currents "
            "make one schedule arrive at different times, so 'eq' cannot be asked of every member"
        )
    on = [k for k, v in unsupported.items() if v]
    if on:
        raise ConfigError(f"{', '.join(on)} is not available with robust=; leave it at its default")
    return alpha, eps


def _warm(frame: Any, length_nm: float, eta_h: float | None, v_max: float, warm_plan, route) -> dict[str, np.ndarray]:
    if warm_plan is not None:
        return plan_warm_start(warm_plan, frame)
    if route is not None:
        return route_warm_start(route, frame)
    speed = length_nm / eta_h if eta_h is not None else 0.9 * v_max
    return {"offset_nm": np.zeros(frame.n_legs + 1), "stw_kn": np.full(frame.n_legs, speed)}


def _start(prepared, frame, eta_h, robust, warm_plan, route) -> tuple[dict, OptrouteError | None, str, Any]:
    """The NLP's start, where the members' joint 3-D DP finds no common schedule its evidence, which start it is
    (``"given"``, ``"ensemble_dp"`` or ``"centreline"``: ``solver_stats["start"]``), and the DP's path (or None).

    A warm plan or route given is the start. Otherwise (``"all"``/``"cvar"`` with an ETA) the least-mean-fuel lattice
    schedule safe in every member (:func:`~optroute.optimise.robust_start.ensemble_dp_path`): the band sides the NLP
    keeps are then those of a schedule safe in all members, where the centreline at the ETA's speed can ask for
    opposite sides in two members. Where the DP finds none, the centreline start and the error that says so.
    """
    ref = prepared[0]
    given = warm_plan is not None or route is not None
    if given or eta_h is None or robust == "chance":
        kind = "given" if given else "centreline"
        return _warm(frame, ref.length_nm, eta_h, ref.v_max, warm_plan, route), None, kind, None
    try:
        path = ensemble_dp_path(
            prepared, frame, eta_h, float(np.min(ref.v_min)), float(np.max(ref.v_max)), ref.exclusion
        )
    except (InfeasibleETA, NoSafePassage) as exc:
        return _warm(frame, ref.length_nm, eta_h, ref.v_max, None, None), exc, "centreline", None
    route_start = track_warm_start(np.column_stack([path.lat_deg, path.lon_deg]), path.extra["stw_kn"], frame)
    return route_start, None, "ensemble_dp", path


def _lattice_plan(path: Any, ctx: Any, t0: Any, ref: Any, members: list[xr.Dataset]) -> Plan | None:
    """The joint 3-D DP's schedule as a plan (its stage points, the path's mean STW per leg) when the referee finds it
    clean in every member (:meth:`Plan.verify` with ``weather=member``), else None."""
    if path is None:
        return None
    plan = Plan.from_context(
        ctx, np.column_stack([path.lat_deg, path.lon_deg]), path.extra["stw_kn"], departure=t0, status="start",
        step_nm=ref.verify_step_nm,
    )  # fmt: skip
    return None if any(plan.verify(weather=m, step_nm=ref.verify_step_nm) for m in members) else plan


def _tighten(state: dict[str, float], found: list[Violation], log: list[str]) -> bool:
    """Tighten the robust problem where the members' verification says; False when nothing can be tightened."""
    kinds = {v.kind for v in found}
    moved = False
    if any(k.startswith(_BAND_KINDS) for k in kinds):
        state["widen"] = 2.0 * state["widen"] + 0.01
        state["hs_margin"] = min(state["hs_margin"] + 0.05, 0.5)
        moved = True
    for v in found:  # the smooth power table misses the model's peak (a storm's core between samples): that leg's
        # power is scaled up in the NLP by what the referee found beyond the limit (down for the minimum power)
        if v.kind in _ENGINE and np.isfinite(v.value) and v.limit > 0:
            ratio = v.value / v.limit
            factor = ratio * 1.01 if v.kind == "power_above_mcr" else ratio / 1.01
            state["leg_factor"][v.leg] *= factor
            moved = True
    if "exclusion" in kinds:
        state["extra_radius_nm"] += 2.0 + max(v.limit - v.value for v in found if v.kind == "exclusion")
        moved = True
    if "eta" in kinds:
        state["eta_shift_h"] += 2.0 / 60.0 + max(v.value for v in found if v.kind == "eta")
        moved = True
    shown = {k: (round(v, 4) if np.isscalar(v) else np.round(v, 4).tolist()) for k, v in state.items()}
    log.append(f"tightened for {sorted(kinds)}: {shown}")
    return moved


def optimise_robust(
    corridor: Corridor,
    weather: xr.Dataset,
    ship: Any,
    *,
    robust: str,
    cvar_alpha: float = 0.0,
    violation_fraction: float = 0.0,
    departure: Any,
    eta: Any = None,
    eta_mode: str = "le",
    objective: str = "fuel",
    model: Any = None,
    rules: Any = None,
    route: Route | None = None,
    warm_plan: Plan | None = None,
    max_leg_nm: float = 50.0,
    band_leg_nm: float | None = BAND_LEG_NM,
    samples_per_leg: int = 3,
    fuel_price_per_t: float = 600.0,
    hourly_cost_per_h: float = 0.0,
    exclusion: Any = None,
    speed_range_kn: tuple[float, float] | None = None,
    band_solves: int = 6,
    max_retries: int = 4,
    band_margin: float = 0.005,
    band_hs_margin: float = 0.05,
    verify_step_nm: float = 5.0,
    solver_options: Mapping[str, Any] | None = None,
    use_land_mask: bool | None = None,
    reference_member: int = 0,
    constraint_rows: str = "midpoints",
    progress: Any = None,
    jit: bool | str = "auto",
    discrete_start: bool | str = "auto",
    dp_options: Mapping[str, Any] | None = None,
    timed_no_passage: bool = False,
) -> Plan:
    """One plan for every member of an ensemble (module docstring); called by ``optimise_corridor(robust=...)``.

    Parameters
    ----------
    robust : {"all", "cvar", "chance"}
        Constraints in every member; objective the members' mean (``"all"``) or CVaR at ``cvar_alpha``; or
        (``"chance"``) constraints in all but ``⌊violation_fraction · M⌋`` members, mean objective.
    cvar_alpha : float
        CVaR level in [0, 1) (``"cvar"`` only; 0 gives the mean).
    violation_fraction : float
        ``"chance"`` only: the share of members in (0, 1) whose constraints the plan may break.
    reference_member : int
        The member whose context the returned plan is evaluated in (its ``legs``, ``total_fuel_t``).
    constraint_rows : {"midpoints", "referee"}
        As :func:`optroute.optimise_corridor` (whose default, ``"midpoints"``, it receives from there):
        ``"midpoints"`` the quadrature's midpoints and, where a band or the exclusion can bind in some member, the
        leg ends (:func:`~optroute.optimise.rows.leg_end_rows`); ``"referee"`` adds row-only samples at the referee's check points of the canonical start (the centreline at the ETA's
        speed) in every member, on the legs where a band or the exclusion can bind in that member
        (:func:`_member_rows`, the union over the members, at most :data:`~optroute.optimise.rows.MAX_ROW_POINTS`
        a leg); after a plan fails a member, the rows move to that plan's check points in the failing members.
    band_leg_nm : float or None
        As :func:`optroute.optimise_corridor`; the members share one set of legs, cut where a band or the exclusion
        can bind in some member (:func:`prepare_members`).
    band_solves : int
        Solves of the band re-imposition loop (:meth:`RobustSpeedNLP.solve_sides`) per tightening.
    solver_options : mapping, optional
        Ipopt/CasADi options. The exact Hessian is the default (:mod:`formulations.robust_nlp`: the limited-memory
        approximation took about ten times the iterations, the cause of the 10-member plan of
        ``benchmarks.bench_voyage`` stopping at Ipopt's iteration limit); ``{"ipopt.hessian_approximation":
        "limited-memory"}`` restores it.
    Other parameters
        As :func:`optroute.optimise_corridor`; ``eta_mode`` must be ``"le"``; ``jit=True``, ``discrete_start=True``,
        ``dp_options`` and ``timed_no_passage`` are not available (ConfigError; the robust plan has no 3-D DP start); ``progress`` is not called.

    Returns
    -------
    Plan
        Verified in every member (``plan.verify(weather=m) == []`` for each) — with ``"chance"``, in every member
        but those of ``members_violated``. ``status``: ``"optimal"`` (Ipopt
        converged and no member met a band that was not imposed), ``"sides_unsettled"`` (converged; the band
        re-imposition stopped on ``band_solves``), ``"feasible"`` (Ipopt stopped at a limit at a point that
        verifies in every member), ``"start"`` (no solve gave a plan clean in every member, but the joint 3-D DP's
        schedule is: that schedule, ``solver_stats["status_reason"]`` says why; the NLP's figures are None).
        ``solver_stats["robust"]``: ``mode``, ``cvar_alpha``, ``violation_fraction``,
        ``dropped_members`` (the NLP's, ``"chance"``), ``members_violated`` (the referee's), ``members``,
        ``reference_member``, ``member_fuel_t`` and ``member_arrival`` (referee, per member), ``fuel_mean_t``,
        ``fuel_cvar_t`` (referee), ``nlp_objective``, ``nlp_member_fuel_t``, ``nlp_var``; and ``ipopt_status``,
        ``nlp_solves``, ``iterations``, ``solve_time_s``, ``build_time_s``, ``retries``, ``tightening``,
        ``nlp_samples_per_leg`` (with ``constraint_rows="referee"`` the row-only samples too),
        ``total_time_s``; ``start`` (``"given"``, ``"ensemble_dp"``, ``"centreline"``), ``start_cpu_s`` (the joint
        DP's CPU) and ``start_evidence`` (the lattice's error where it found no common schedule, else None).

    Raises
    ------
    ConfigError
        Bad ``robust``, ``cvar_alpha``, ``violation_fraction`` (or too many choices of members to drop),
        ``eta_mode``, ``reference_member``, or an option not available here.
    NoSafePassage
        The members' navigable lateral ranges do not overlap at some waypoint.
    InfeasibleETA, NoSafePassage
        No plan verified and the members' joint 3-D DP has no schedule by the ETA safe in all of them (the earliest
        arrival safe in all, or none within the weather's horizon; the members with a schedule of their own named).
    SolverFailure
        No tightened solve gave a plan that verifies in every member (``best_plan``: the warm plan if it does)
        although the members' joint lattice has a common schedule, and that schedule does not verify in every member
        either (or the lattice was not run: a warm plan or route given).
    """
    started = _time.perf_counter()
    alpha, fraction = _check_options(
        robust,
        cvar_alpha,
        violation_fraction,
        eta_mode,
        {
            "jit": not (jit is False or (isinstance(jit, str) and jit == "auto")),
            "discrete_start": discrete_start is True,
            "dp_options": dp_options,
            "timed_no_passage": timed_no_passage,
        },
    )
    if constraint_rows not in ROW_PLACEMENTS:
        raise ConfigError(
            f"constraint_rows={constraint_rows!r} is not known; use 'midpoints' (the NLP's rows at its quadrature "
            "points and leg ends) or 'referee' (also at the referee's check points in every member)"
        )
    members = member_datasets(weather)
    n_drop = _dropped_count(robust, fraction, violation_fraction, len(members))
    shared = {
        "departure": departure, "latest_eta": eta, "objective": objective, "model": model, "rules": rules,
        "max_leg_nm": max_leg_nm, "samples_per_leg": samples_per_leg, "fuel_price_per_t": fuel_price_per_t,
        "hourly_cost_per_h": hourly_cost_per_h, "exclusion": exclusion, "speed_range_kn": speed_range_kn,
        "band_margin": band_margin, "band_hs_margin": band_hs_margin, "verify_step_nm": verify_step_nm,
        "use_land_mask": use_land_mask,
    }  # fmt: skip
    band_leg_nm = band_leg_for(band_leg_nm, objective=objective, eta_given=eta is not None)
    prepared, y_lo, y_hi = prepare_members(corridor, members, ship, shared, reference_member, band_leg_nm)
    ref = prepared[int(reference_member)]
    frame, t0 = ref.frame, ref.departure
    eta_t = as_utc_time(eta, "eta") if eta is not None else None
    eta_h = timedelta_to_h(eta_t - t0) if eta_t is not None else (ref.prepared_cap_h if objective != "time" else None)
    ctx = ref.plan_context(eta_t, "le")
    start_cpu = _time.process_time()
    warm, evidence, kind, lattice = _start(prepared, frame, eta_h, robust, warm_plan, route)
    start = {
        "start": kind,
        "start_cpu_s": _time.process_time() - start_cpu,
        "start_evidence": None if evidence is None else str(evidence),
    }
    state = _untightened(ref, frame.n_legs)
    if constraint_rows == "referee":
        points = _member_rows(prepared, eta_t, y_lo, y_hi, eta_h)
    else:  # the leg ends where a band or the exclusion can bind in some member, as optimise_corridor's rows
        points = leg_end_rows(np.any([p.binding for p in prepared], axis=0))
    log: list[str] = []
    counts = {"solves": 0, "iterations": 0, "solve_time_s": 0.0, "build_time_s": 0.0}
    last: RobustResult | None = None
    setup = (prepared, ref, y_lo, y_hi, exclusion, dict(solver_options or {}), robust, alpha)
    builds: dict[tuple[float, float, float], RobustSpeedNLP] = {}
    for retry in range(int(max_retries) + 1):
        nlp, candidates = _solve_once(
            setup, builds, counts, state, sample_layout(points, frame.n_legs, ref.samples_per_leg),
            (eta_h, objective, warm, int(band_solves), n_drop),
        )  # fmt: skip
        last = candidates[0]
        picked, failing = _pick(candidates, ctx, frame, t0, ref, members, log, retry)
        if picked is not None:
            res, plan, violated = picked
            stats = _stats(plan, members, res, robust, alpha, int(reference_member), objective, ref)
            stats["robust"].update(
                violation_fraction=fraction,
                dropped_members=np.flatnonzero(res.dropped).tolist(),
                members_violated=violated,
                drop_choices_solved=len(candidates),
            )
            stats.update(counts, retries=retry, tightening=log, ipopt_status=res.status, nlp_solves=counts["solves"])
            stats.update(start, nlp_samples_per_leg=nlp.samples_per_leg)  # the quadrature's and row-only samples
            stats["total_time_s"] = _time.perf_counter() - started
            return replace(plan, status=_solved_status(res), solver_stats=stats)
        if failing is None:  # no usable solve: nothing the verification could say, tightening would not help
            break
        res, failing = failing
        warm = {"offset_nm": res.offset_nm, "stw_kn": res.stw_kn}
        if points is not None:  # the rows move to the rejected plan's check points in the members it failed
            points = _failing_points(failing, frame.waypoints(res.offset_nm), frame.n_legs)
        if not _tighten(state, [v for f in failing.values() for v in f], log):
            break
    if evidence is not None:  # the NLP found no plan either: the lattice's proof that no common schedule exists
        raise evidence
    plan = _lattice_plan(lattice, ctx, t0, ref, members)
    if plan is None:
        raise _failure(members, warm_plan, last, log, counts["solves"])
    stats = _stats(plan, members, None, robust, alpha, int(reference_member), objective, ref)
    return _as_start(plan, stats, fraction, counts, start, log, last, started)


def _as_start(
    plan: Plan, stats: dict, fraction: float, counts: dict, start: dict, log: list[str], last: Any, started: float
) -> Plan:
    """The lattice's common schedule, returned where the NLP found no plan clean in every member: labelled
    ``"start"`` (as a single weather's verified start where the NLP does not improve on it), never optimal."""
    stats["robust"].update(violation_fraction=fraction, dropped_members=[], members_violated=[])
    stats.update(counts, **start, tightening=log, ipopt_status=None if last is None else last.status)
    stats.update(retries=sum(e.startswith("tightened for") for e in log), nlp_solves=counts["solves"])
    stats["status_reason"] = f"the robust NLP found no plan clean in every member ({log[-1] if log else ''})"
    stats["total_time_s"] = _time.perf_counter() - started
    return replace(plan, status="start", solver_stats=stats)


def _untightened(ref: Any, n_legs: int) -> dict[str, Any]:
    """The tightening state before any retry (:func:`_tighten` moves it): the reference member's band back-offs,
    the engine's load range, no extra exclusion radius or ETA shift, and no leg's power raised."""
    return {
        "widen": ref.margin0,
        "hs_margin": ref.hs_margin0,
        "max_load": 1.0,
        "min_load": ref.power.min_load,
        "extra_radius_nm": 0.0,
        "eta_shift_h": 0.0,
        "leg_factor": np.ones(n_legs),
    }


def _solve_once(
    setup: tuple,
    builds: dict[tuple, RobustSpeedNLP],
    counts: dict[str, float],
    state: dict[str, Any],
    layout: Any,
    task: tuple[float | None, str, dict[str, np.ndarray], int, int],
) -> tuple[RobustSpeedNLP, tuple[RobustResult, ...]]:
    """The robust NLP at the tightening ``state`` (built once per shape: ``builds``) solved from the warm start.

    ``setup``: (prepared members, reference member, lateral bounds lo / hi [nm], exclusion, solver options, mode,
    CVaR level); ``task``: (ETA [h] or None, objective, warm start, band solves, members that may be dropped).
    Returns the NLP and its candidates, best first (several for ``"chance"``); ``counts`` gains their solves,
    iterations and times.
    """
    prepared, ref, y_lo, y_hi, exclusion, options, robust, alpha = setup
    eta_h, objective, warm, band_solves, n_drop = task
    key = (state["widen"], state["hs_margin"], state["extra_radius_nm"], layout.fraction.tobytes())  # shapes a build
    if key not in builds:
        builds[key] = _build(
            prepared, ref, ref.frame, y_lo, y_hi, state, exclusion, ref.departure, options, robust, alpha, layout
        )
        counts["build_time_s"] += builds[key].build_time_s
    nlp = builds[key]
    nlp.power = replace(nlp.power, max_load=state["max_load"], min_load=state["min_load"])
    solve_kw = {
        "eta_h": None if eta_h is None else eta_h - state["eta_shift_h"],
        "objective": objective,
        "fuel_price": ref.fuel_price,
        "hourly_cost": ref.hourly,
        "offset0_nm": warm["offset_nm"],
        "stw0_kn": warm["stw_kn"],
        "max_solves": band_solves,
        "leg_power_factor": state["leg_factor"],
    }
    if robust == "chance":
        candidates = nlp.solve_chance(max_dropped=n_drop, **solve_kw)
    else:
        candidates = (nlp.solve_sides(**solve_kw),)
    counts["solves"] += candidates[0].solves
    counts["iterations"] += candidates[0].iterations
    counts["solve_time_s"] += candidates[0].solve_time_s
    return nlp, candidates


def _dropped_count(robust: str, fraction: float, violation_fraction: Any, n_members: int) -> int:
    """The members a ``"chance"`` plan may violate, ``⌊fraction · M⌋``; ConfigError where the choices of them are
    more than :data:`~formulations.robust_nlp.MAX_DROP_CHOICES`."""
    n_drop = int(np.floor(fraction * n_members + 1e-9))
    if robust == "chance" and math.comb(n_members, n_drop) > MAX_DROP_CHOICES:
        raise ConfigError(
            f"violation_fraction={violation_fraction!r} of {n_members} members lets {n_drop} be violated: "
            f"{math.comb(n_members, n_drop)} choices of members, more than the {MAX_DROP_CHOICES} solved exactly; "
            "give a smaller fraction or fewer members, or use robust='cvar'"
        )
    return n_drop


def _solved_status(res: RobustResult) -> str:
    """``"feasible"`` where Ipopt stopped at a limit, else ``"optimal"``, or ``"sides_unsettled"`` where the band
    re-imposition stopped on its budget."""
    return "feasible" if not res.success else ("optimal" if res.sides_settled else "sides_unsettled")


def _pick(candidates, ctx, frame, t0, ref, members, log: list[str], retry: int):
    """The first candidate (best objective first) whose plan verifies in every member it keeps.

    Returns ``((result, plan, violated members), None)`` for it, else ``(None, (result, {member: violations}))``
    for the best usable candidate's failing kept members, or ``(None, None)`` when no solve was usable.
    """
    first_failing = None
    for res in candidates:
        usable = res.max_violation <= VIOLATION_TOL and (res.success or res.status in LIMIT_STATUSES)
        if not usable:
            log.append(f"solve {retry}: Ipopt {res.status}, max violation {res.max_violation:.2e}")
            continue
        plan = Plan.from_context(
            ctx,
            frame.waypoints(res.offset_nm),
            res.stw_kn,
            departure=t0,
            status="candidate",
            step_nm=ref.verify_step_nm,
        )
        found = {k: plan.verify(weather=m, step_nm=ref.verify_step_nm) for k, m in enumerate(members)}
        failing = {k: f for k, f in found.items() if f and not res.dropped[k]}
        if not failing:
            return (res, plan, sorted(k for k, f in found.items() if f)), None
        log.append(
            f"solve {retry}: the plan fails kept members {sorted(failing)}: "
            + "; ".join(f"member {k}: {f[0]}" for k, f in sorted(failing.items())[:3])
        )
        if first_failing is None:
            first_failing = (res, failing)
    return None, first_failing


def prepare_members(
    corridor: Corridor,
    members: list[xr.Dataset],
    ship: Any,
    shared: dict[str, Any],
    reference: Any,
    band_leg_nm: float | None = None,
):
    """Every member prepared as ``optimise_corridor`` prepares one weather, and the lateral bounds all allow.

    The members share one power table's speed nodes (the densest any member's sea asked for,
    :data:`~optroute.optimise.power_table.SPEED_TOL`; a member whose table had others is prepared again) and one set
    of legs: with ``band_leg_nm`` [nm] (the one that applies, :func:`~optroute.optimise.rows.band_leg_for`), the legs
    where a band or the exclusion can bind in some member are cut to it
    (:func:`~optroute.optimise.corridor_setup.cut_frame`), each member's weather grid kept
    (:meth:`~optroute.optimise.corridor_problem.PreparedCorridor.cut_to`).
    """
    from optroute.optimise.corridor_problem import PreparedCorridor

    if not (isinstance(reference, int | np.integer) and 0 <= reference < len(members)):
        raise ConfigError(
            f"reference_member={reference!r} is not a member index; give an integer in [0, {len(members) - 1}]"
        )
    prepared = [PreparedCorridor(corridor, ds, ship, **shared, band_leg_nm=None) for ds in members]
    nodes = max((np.asarray(p.table.speeds_kn) for p in prepared), key=np.size)
    prepared = [
        p if np.array_equal(p.table.speeds_kn, nodes)
        else PreparedCorridor(corridor, ds, ship, **shared, band_leg_nm=None, speed_nodes_kn=nodes)
        for p, ds in zip(prepared, members, strict=True)
    ]  # fmt: skip
    if band_leg_nm is not None:
        whole = prepared[int(reference)].frame
        frame = cut_frame(whole, np.any([p.binding for p in prepared], axis=0), band_leg_nm)
        if frame is not whole:
            for p in prepared:
                p.cut_to(frame)
    y_lo = np.max([p.y_lo for p in prepared], axis=0)
    y_hi = np.min([p.y_hi for p in prepared], axis=0)
    closed = np.flatnonzero(y_lo > y_hi)
    if closed.size:
        raise NoSafePassage(
            f"the members' navigable ranges across waypoint {int(closed[0])} of the corridor do not overlap: no one "
            "track is navigable in every member; widen the corridor or leave out the members that close it"
        )
    return prepared, y_lo, y_hi


def _failure(members: list, warm_plan: Plan | None, last: RobustResult | None, log: list[str], solves: int):
    """The SolverFailure of a call without a plan clean in every member; its best plan is the warm plan if clean."""
    best = None
    if warm_plan is not None and not any(warm_plan.verify(weather=m) for m in members):
        best = warm_plan
    status = last.status if last is not None else "not solved"
    return SolverFailure(
        f"no robust plan verifies in every one of the {len(members)} members after {solves} solve(s) (Ipopt's last "
        f"status {status}; {log[-1] if log else ''}); widen the corridor, give a later ETA, or plan on fewer members",
        status=status,
        best_plan=best,
    )


def _member_rows(prepared: list, eta_t: Any, y_lo: np.ndarray, y_hi: np.ndarray, eta_h: float | None):
    """Per leg, the union over the members of the referee's check points of the canonical start
    (:func:`optroute.optimise.rows.canonical_rows`: the centreline at the ETA's speed), or None if no member gives any."""
    ref = prepared[0]
    speed = ref.length_nm / eta_h if eta_h is not None and np.isfinite(eta_h) else ref.ship.design_speed_kn
    speed = float(np.clip(speed, np.max(ref.v_min), np.min(ref.v_max)))
    per = []
    for p in prepared:  # each member's rows only where a band or the exclusion can bind in it (as a single weather's)
        ctx = p.plan_context(eta_t, "le")
        rows = canonical_rows(ctx, p.frame, (y_lo, y_hi), speed, p.departure, p.verify_step_nm)
        per.append(only_where_binding(rows, p.binding))
    per = [r for r in per if r is not None]
    if not per:
        return None
    return [np.unique(np.concatenate([r[k] for r in per])) for k in range(ref.frame.n_legs)]


def _failing_points(failing: dict[int, list], waypoints: np.ndarray, n_legs: int) -> list[np.ndarray] | None:
    """Per leg, the union of the check points of the members a plan failed (their verifications' ``points``)."""
    found = [points_of(f.points, waypoints) for f in failing.values() if getattr(f, "points", None) is not None]
    if not found:
        return None
    return [np.unique(np.concatenate([r[k] for r in found])) for k in range(n_legs)]


def _build(
    prepared, ref, frame, y_lo, y_hi, state, exclusion, t0, solver_options, robust, alpha, layout
) -> RobustSpeedNLP:
    """The stacked NLP for one tightening state."""
    bands, _, a = formulation_bands(ref.ship, ref.rules, widen=state["widen"], hs_margin=state["hs_margin"])
    hs_top = max(float(np.max(p.grid.hs_m)) for p in prepared)
    bands = tuple(b for b in bands if hs_top >= b.hs_min_m)  # bands no member's sea reaches are left out
    power = ref.power
    excl = None
    if exclusion is not None:
        excl = moving_exclusion(exclusion, frame, t0, extra_radius_nm=state["extra_radius_nm"])
    return RobustSpeedNLP(
        frame.geometry(y_lo, y_hi),
        [p.grid for p in prepared],
        power,
        risk="cvar" if robust == "cvar" else "mean",
        alpha=alpha,
        bands=bands,
        exclusion=excl,
        samples_per_leg=ref.samples_per_leg,
        v_min_kn=ref.v_min,
        v_max_kn=ref.v_max,
        g_over_2pi_kn_s=a,
        ipopt_options=dict(solver_options),
        sample_layout=layout,
    )


def _stats(plan, members, res, robust, alpha, reference, objective, ref) -> dict[str, Any]:
    """The plan's ``solver_stats``: every member's fuel and arrival by the referee, their mean and CVaR (the NLP's
    figures None where the plan is not the NLP's, ``res`` None)."""
    sailed = [plan.in_weather(m, step_nm=ref.verify_step_nm) for m in members]
    fuel = np.array([p.total_fuel_t for p in sailed])
    return {
        "robust": {
            "mode": robust,
            "cvar_alpha": alpha,
            "objective": objective,
            "members": len(members),
            "reference_member": reference,
            "member_fuel_t": fuel.tolist(),
            "member_arrival": [format_utc(p.arrival) for p in sailed],
            "member_duration_h": [p.duration_h for p in sailed],
            "fuel_mean_t": float(fuel.mean()),
            "fuel_cvar_t": cvar(fuel, alpha),
            "nlp_objective": None if res is None else res.objective,
            "nlp_member_fuel_t": None if res is None else res.member_fuel_t.tolist(),
            "nlp_var": None if res is None else res.var,
            "sides_settled": None if res is None else res.sides_settled,
        },
        "n_legs": int(np.asarray(plan.waypoints).shape[0] - 1),
        "samples_per_leg": ref.samples_per_leg,
    }
