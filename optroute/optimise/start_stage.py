"""The start stage of a corridor solve: every candidate start scored by the referee before the first solve.

:meth:`optroute.optimise.corridor_problem.PreparedCorridor.solve` runs Ipopt once from the best of these
candidates (:func:`start_stage`) and never returns a plan worse by the referee than the best verified one
(issue 13 item 2, issue 14 item 4). The candidates (:mod:`optroute.optimise.starts` builds and scores each):

* the *local* starts, always: a given warm plan, a given search route, the ship's dual schedule (fixed path,
  static weather: :func:`optroute.optimise.certificate.dual_schedule`) and the centreline start
  (:func:`optroute.optimise.min_time.clean_start`); for least fuel without an ETA, the centreline at the engine's
  minimum load (:func:`optroute.optimise.starts.minimum_load_plan`) instead of the centreline start where it
  verifies: the centreline start there is made for the mean speed to the weather's end, below the minimum load on a
  long forecast, and falls back to the timed passage at full speed (the benchmark's storm front: 819.6 t, against
  252.0 t at the minimum load), from which the slow-steaming solve took 1 178 Ipopt iterations in 4 calls;
* the *global* starts, which cost a search or a solve of their own: the 3-D DP's plan on the corridor
  (:func:`optroute.optimise.starts.dp_route`) and the corridor's minimum-time plan (the plan
  :func:`optroute.optimise_corridor` gives for ``objective="time"`` without an ETA,
  :meth:`~optroute.optimise.corridor_problem.PreparedCorridor.minimum_time_plan`), computed where a local
  start is known not to suffice (:func:`global_starts_reason`): no local start verifies, or a danger band or the
  exclusion circle can bind on the corridor (:func:`optroute.optimise.rows.binding_legs`). Where nothing binds the
  problem is smooth in the speeds and a verified local start is a good start; where a band binds, the plans lie
  on either side of it and a local start can hold Ipopt on the worse side (harness seed 51: the timed centreline
  start at 127.01 t, the minimum-time plan 125.40 t at the same ETA; a storm crossing raced to the south at 139 t
  where the 3-D DP passes north on 57 t). The minimum-time plan is computed only where the DP gives no verified
  plan (the DP does not apply — no ETA, not a great circle, the time objective — or finds none; a given search
  route that is the DP's counts as the DP's): the DP's plan is the least fuel by the ETA on its grid, and the minimum-time plan, a race, rarely beats it (the storm crossing of
  ``benchmarks.bench_nlp``: 183.5 t against the DP's 75.4 t, and 0.7–1.0 CPU-s to solve).
  For a free-arrival minimum time where no local start verifies, the DP's earliest passage within the weather's
  span (each arrival bin keeping its earliest label, :func:`optroute.search.solve_dp`'s ``label_value="time"``)
  and the centreline's timed passage (:func:`_fine_centre_candidate`) are both computed: two lattices, neither a
  proof (harness seed 20: both 23.64 h, where the DP with its bins ranked by fuel found 29.96 h; seed 80: the DP
  19.08 h, the centreline closed to the timed passage).

The stage's record (``solver_stats["starts"]``) holds every candidate's score by the referee (``inf``
unverified), whether it verified, its own estimate and the CPU seconds it cost.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from optroute.errors import ConfigError, NoSafePassage
from optroute.optimise.certificate import dual_schedule
from optroute.optimise.min_time import TimedStart, clean_start, timed_safe_start
from optroute.optimise.nlp_inputs import build_frame
from optroute.optimise.nlp_solve import Tightening, desired_speed, warm_rules
from optroute.optimise.rescue import plan_warm_start
from optroute.optimise.starts import (
    Candidate,
    dp_route,
    minimum_load_plan,
    repaired_plan,
    route_stw,
    score,
    track_warm_start,
    verified_plan,
)
from optroute.plan.result import Plan, PlanContext
from optroute.search.route import Route

__all__ = [
    "DISCRETE_START_MODES",
    "FINE_BLOCK_NM",
    "LABEL_ORDER",
    "Starts",
    "TIME_LATTICE",
    "discrete_start_mode",
    "global_starts_reason",
    "start_stage",
    "time_lattice",
    "warm_candidate",
]

#: ``discrete_start`` of :func:`optroute.optimise_corridor`: the 3-D DP always (where it applies), never, or where
#: :func:`global_starts_reason` asks for the global starts.
DISCRETE_START_MODES = (True, False, "auto")
#: The 3-D DP's lattice for a free-arrival minimum time where no local start verifies: stages every ``dx_nm`` or
#: 1/``stages`` of the corridor (the longer), ``per_side`` lateral positions each side, ``dt_h`` arrival bins, speeds
#: every ``speed_step_kn``. Finer than an ETA's start (its storms leave narrow windows in time and speed: on the
#: harness's seeds 5, 19 and 82 a passage that verifies is found at this resolution and none at the ETA start's).
TIME_LATTICE = {"dx_nm": 10.0, "stages": 36.0, "per_side": 3.0, "dt_h": 0.5, "speed_step_kn": 0.5}
#: Longest block [nm] of the centreline's timed passage for a free-arrival minimum time where no local start verifies.
FINE_BLOCK_NM = 10.0
#: Why the 3-D DP is a candidate of least fuel (or cost) without an ETA: the weather changes in time along the corridor,
#: so the slowest schedule (the minimum-load one) need not burn the least: behind a storm that moves with the ship (as
#: on ``benchmarks/bench_front.py``'s corridor) the slowest schedule stays in it longest, and the NLP started there
#: stays in that basin; the DP searches every arrival time.
FREE_ARRIVAL_DP = (
    "computed: no ETA, and the weather changes in time along the corridor (the slowest schedule need not burn the "
    "least)"
)
#: The 3-D DP's speed step [kn] without an ETA: least fuel sails near the engine's minimum load, and a 2 kn ladder
#: straddles it (the rung below under the minimum load, the one above well over it).
FREE_ARRIVAL_STEP_KN = 1.0
#: Arrival-time bins of the free-arrival DP per passage (the best verified candidate's): a resolution of 1 % of it.
FREE_ARRIVAL_BINS = 100
#: How far above the best verified candidate's fuel (a share) a route of the free-arrival DP is kept: room for the
#: difference between the DP's own fuel figure (its 30 nm pieces, its speed over ground) and the referee's.
FREE_ARRIVAL_CUT = 0.05
#: The order of the candidates among equal scores, and of the warm starts when none verifies.
LABEL_ORDER = (
    "warm plan",
    "search route",
    "3-D DP",
    "timed passage",
    "minimum-time plan",
    "ship dual",
    "minimum-load schedule",
    "centreline start",
)


@dataclass(frozen=True)
class Starts:
    """The start stage's outcome: the candidates, best by the referee first, and why the global starts ran.

    Attributes
    ----------
    candidates : list of Candidate
        Verified candidates by score, then the unverified ones in :data:`LABEL_ORDER`.
    global_reason : str
        Why the 3-D DP and the minimum-time plan were candidates, or why not.
    """

    candidates: list[Candidate]
    global_reason: str

    def record(self, start: Candidate, warm: Candidate) -> dict[str, dict[str, Any]]:
        """``solver_stats["starts"]``: per candidate its score, verified, estimate, CPU seconds, and which was chosen."""
        return {
            c.label: {
                "score": c.score,
                "verified": c.plan is not None,
                "estimate": c.estimate,
                "cpu_s": c.cpu_s,
                "chosen": c is start,
                "warm_start": c is warm,
            }
            for c in self.candidates
        }


def start_stage(
    prepared: Any,
    ctx: PlanContext,
    *,
    cap_h: float | None,
    objective: str,
    warm_plan: Plan | None,
    route: Route | None,
    st: Tightening,
) -> Starts:
    """The NLP's start candidates on a :class:`~optroute.optimise.corridor_problem.PreparedCorridor`, scored.

    Parameters
    ----------
    prepared : PreparedCorridor
    ctx : PlanContext
        The solve's context (its ETA and mode): every candidate is verified in it.
    cap_h : float or None
        The passage's cap [h] (the ETA, or the weather's end for fuel without one).
    objective : {"fuel", "time", "cost"}
    warm_plan, route : optional
        As in :func:`optroute.optimise_corridor`.
    st : Tightening
        The first solve's tightening (its rules for the centreline start; its log).
    """
    found: dict[str, Candidate] = {}
    prepared.lattice_closed = {}  # this solve's lattice searches only
    if warm_plan is not None:
        found["warm plan"] = _timed(lambda: _warm_plan_candidate(prepared, ctx, warm_plan, objective))
    if route is not None:
        found["search route"] = _timed(lambda: _discrete(prepared, "search route", ctx, route, objective, st.log))
    warm = found.get("warm plan")
    if warm is not None and warm.plan is not None and bool(getattr(warm_plan, "sole_start", False)):
        # a continuation's verified neighbour (a front's point, :class:`optroute.studies.front_points.WarmStart`) is
        # the start and the floor: the ship's dual schedule, the centreline's safe start (a timed search around a
        # storm: 28 % of a front's time on the benchmark's storm corridor) and the global starts are the starts of a
        # solve without one
        return Starts(_ranked(found), "not computed: a verified neighbour is the sole start")
    if prepared.fixed_path and cap_h is not None and objective in ("fuel", "cost"):
        dual = _timed(lambda: _dual_candidate(prepared, ctx, cap_h, objective))
        if dual is not None:
            found["ship dual"] = dual
    if ctx.eta is None and objective == "fuel":  # least fuel without an ETA: the slowest schedule the engine allows
        slow = _timed(lambda: _minimum_load_candidate(prepared, ctx))
        if slow.plan is not None:
            found["minimum-load schedule"] = slow
    if "minimum-load schedule" not in found:
        found["centreline start"] = _timed(lambda: _centre_candidate(prepared, ctx, cap_h, objective, st))
    reason = global_starts_reason(prepared, ctx, list(found.values()), cap_h, objective)
    if _dp_applies(prepared, ctx, objective, route, reason):
        dp = _timed(lambda: _dp_candidate(prepared, ctx, objective, st.log, list(found.values())))
        if dp is not None:
            found["3-D DP"] = dp
        if objective == "time":  # two lattices, neither a proof: the better of both (harness seeds 20 and 80)
            fine = _timed(lambda: _fine_centre_candidate(prepared, ctx, st.log))
            if fine is not None:
                found["timed passage"] = fine
    # the DP's verified plan (its own, or the given search route when that is the DP's), least fuel by the ETA on its
    # grid, stands in for the minimum-time plan
    dp = found.get("3-D DP") or (found.get("search route") if route is not None and route.method == "dp" else None)
    free_time = objective == "time" and ctx.eta is None  # the minimum-time plan is this solve's own plan
    fallback = reason.startswith("computed") and reason != FREE_ARRIVAL_DP and not free_time
    if fallback and (dp is None or dp.plan is None):
        fast = _timed(lambda: _minimum_time_candidate(prepared, ctx, objective, route))
        if fast is not None:
            found["minimum-time plan"] = fast
    return Starts(_ranked(found), reason)


def _ranked(found: dict[str, Candidate]) -> list[Candidate]:
    """The candidates best by the referee first; equal scores (and the unverified, inf) in :data:`LABEL_ORDER`."""
    given = [found[k] for k in LABEL_ORDER if k in found]
    order = sorted(range(len(given)), key=lambda i: (given[i].score, i))
    return [given[i] for i in order]


def discrete_start_mode(value: Any) -> bool | str:
    """``discrete_start`` checked: True, False or ``"auto"`` (:data:`DISCRETE_START_MODES`), else a ConfigError."""
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, str) and value == "auto":
        return value
    raise ConfigError(
        f"discrete_start={value!r} is not known; use 'auto' (the 3-D DP among the starts where a band or the "
        "exclusion can bind, or no other start verifies), True (always) or False (never)"
    )


def global_starts_reason(
    prepared: Any, ctx: PlanContext, local: list[Candidate], cap_h: float | None, objective: str
) -> str:
    """Whether the global starts (the 3-D DP, the minimum-time plan) are candidates: ``"computed: <why>"`` or
    ``"not computed: <why>"``.

    They are computed for a bounded passage (an ETA, or the weather's end) where no local start verifies, or, for
    fuel or cost by an ETA, where a danger band or the exclusion can bind on some leg of the corridor
    (:attr:`~optroute.optimise.corridor_problem.PreparedCorridor.binding`). For a free-arrival minimum time where no
    local start verifies, the 3-D DP's earliest passage within the weather's span is computed (the minimum-time
    plan is that solve's own). For fuel or cost without an ETA where the weather changes in time along the corridor,
    the 3-D DP alone (:data:`FREE_ARRIVAL_DP`; its speeds every :data:`FREE_ARRIVAL_STEP_KN`), unless a search route
    is given: its time-dependent search over the arrival times is that call's global start (``plan_voyage``).
    """
    verified = any(c.plan is not None for c in local)
    if cap_h is None:
        if objective == "time" and not verified and np.isfinite(prepared.data_end_h):
            return "computed: no local start verifies (the 3-D DP's earliest passage within the weather's span)"
        return "not computed: a free-arrival passage"
    if not verified:
        return "computed: no local start verifies"
    if objective == "time":
        return "not computed: a local start verifies (minimum time)"
    if ctx.eta is None:
        if prepared.samples.static:
            return (
                "not computed: a local start verifies, there is no ETA (the weather's end bounds the passage) and the "
                "weather does not change in time along the corridor"
            )
        if any(c.label == "search route" for c in local):
            return (
                "not computed: no ETA, and the given route search's schedule, a search over the arrival times in this "
                "weather, is a candidate"
            )
        return FREE_ARRIVAL_DP
    binding = np.asarray(prepared.binding, dtype=bool)
    if binding.any():
        return f"computed: a band or the exclusion can bind on {int(binding.sum())} of {binding.size} legs"
    return "not computed: a local start verifies and no band or exclusion can bind"


def warm_candidate(cands: list[Candidate]) -> Candidate:
    """The candidate to start Ipopt from: the best by the referee, or by its own figure where that is lower
    (an unverified DP route that claims less fuel than every verified candidate: the NLP repairs and
    improves it, and the verified best remains the floor of the result)."""
    return min(cands, key=lambda c: (c.estimate, c.plan is None))


# --------------------------------------------------------------------------- the candidates


def _timed(make: Any) -> Any:
    """``make()`` with its CPU seconds (``time.process_time``) recorded in the candidate (None stays None)."""
    c0 = _time.process_time()
    cand = make()
    return None if cand is None else replace(cand, cpu_s=_time.process_time() - c0)


def _candidate(
    prepared: Any, label: str, warm: dict[str, Any], plan: Plan | None, objective: str, own: float = float("inf")
) -> Candidate:
    """A start candidate: its score by the referee (inf unverified) and its estimate (the lower of that and ``own``)."""
    val = score(plan, objective, prepared.fuel_price, prepared.hourly) if plan is not None else float("inf")
    return Candidate(label, warm, plan, val, min(val, own))


def _warm_plan_candidate(prepared: Any, ctx: PlanContext, warm_plan: Plan, objective: str) -> Candidate:
    """A given previous plan (a neighbouring ETA's), with a neighbour's multipliers when it carries them.

    A warm plan that carries its own referee verdict for this solve's ETA (``verified``: the plan of exactly its
    track and speeds, verified in a context with the same ETA and mode, as a front's mended start is) is not
    evaluated and verified a second time.
    """
    stw = np.asarray(warm_plan.stw_kn, dtype=float)
    plan = getattr(warm_plan, "verified", None)
    if plan is None or (plan.context.eta, plan.context.eta_mode) != (ctx.eta, ctx.eta_mode):
        plan = verified_plan(ctx, warm_plan.waypoints, stw, prepared.departure, prepared.verify_step_nm, "start")
    warm = plan_warm_start(warm_plan, prepared.frame)
    duals = getattr(warm_plan, "duals", None)  # a neighbour's multipliers (a front's WarmStart), if any
    return _candidate(prepared, "warm plan", warm if duals is None else {**warm, "duals": duals}, plan, objective)


def _discrete(prepared: Any, label: str, ctx: PlanContext, route: Route, objective: str, log: list[str]) -> Candidate:
    """A discrete plan (a search route, the 3-D DP) as a candidate, its engine range mended where the referee
    finds it out between the search's own points (:func:`~optroute.optimise.starts.repaired_plan`); the DP's own
    figure of the objective orders the warm starts too."""
    stw = route_stw(route)
    plan, legs = repaired_plan(ctx, route.waypoints, stw, prepared.departure, prepared.verify_step_nm, "start",
                               v_min_kn=prepared.v_min, v_max_kn=prepared.v_max)  # fmt: skip
    if plan is not None and legs:
        log.append(
            f"{label}: the referee found the engine outside its range or a band grazed; speeds mended on {legs} legs"
        )
    warm = track_warm_start(route.waypoints, plan.stw_kn if plan is not None else stw, prepared.frame)
    figure = float("inf")
    if label == "3-D DP" and objective in ("fuel", "cost"):
        figure = float(route.total_fuel_t) if objective == "fuel" else float(route.cost)
    return _candidate(prepared, label, warm, plan, objective, figure)


def _dual_candidate(prepared: Any, ctx: PlanContext, cap_h: float, objective: str) -> Candidate | None:
    """On a fixed path in static weather: the ship's own dual bound's schedule, a near-optimal discrete plan
    with its band sides (:func:`optroute.optimise.certificate.dual_schedule`); None where it has none."""
    frame, t0, step = prepared.frame, prepared.departure, prepared.verify_step_nm
    centre_wp = frame.waypoints(np.zeros(frame.n_legs + 1))
    stw = dual_schedule(ctx, centre_wp, departure=t0, eta_h=cap_h, eta_mode=ctx.eta_mode, objective=objective,
                        fuel_price=prepared.fuel_price, hourly_cost=prepared.hourly, v_min_kn=prepared.v_min,
                        v_max_kn=prepared.v_max, step_nm=step)  # fmt: skip
    if stw is None:
        return None
    plan = verified_plan(ctx, centre_wp, stw, t0, step, "start")
    return _candidate(prepared, "ship dual", track_warm_start(centre_wp, stw, frame), plan, objective)


def _centre_candidate(
    prepared: Any, ctx: PlanContext, cap_h: float | None, objective: str, st: Tightening
) -> Candidate:
    """The NLP's own safe start on the centreline (:func:`optroute.optimise.min_time.clean_start`)."""
    t0, frame, step = prepared.departure, prepared.frame, prepared.verify_step_nm

    def verify(warm: dict[str, np.ndarray]) -> Plan | None:
        return verified_plan(ctx, frame.waypoints(warm["offset_nm"]), warm["stw_kn"], t0, step, "start")

    def mend(warm: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], Plan] | None:
        plan, _ = repaired_plan(ctx, frame.waypoints(warm["offset_nm"]), warm["stw_kn"], t0, step, "start",
                                v_min_kn=prepared.v_min, v_max_kn=prepared.v_max)  # fmt: skip
        return None if plan is None else ({**warm, "stw_kn": np.asarray(plan.stw_kn, dtype=float)}, plan)

    centre, plan = clean_start(ctx, frame, t0, desired_kn=desired_speed(prepared.length_nm, cap_h, prepared.v_max,
                               objective), v_min_kn=prepared.v_min, v_max_kn=prepared.v_max, eta_h=cap_h,
                               rules=warm_rules(prepared.rules, st), log=st.log, verify=verify,
                               mend=mend)  # fmt: skip
    return _candidate(prepared, "centreline start", centre, plan, objective)


def centreline_minimum_load(prepared: Any, ctx: PlanContext) -> Plan | None:
    """The corridor's centreline sailed at the engine's minimum load, verified in ``ctx``
    (:func:`optroute.optimise.starts.minimum_load_plan`): the slowest schedule the engine allows there; None where the
    ship has no minimum power or no round verifies."""
    centre_wp = prepared.frame.waypoints(np.zeros(prepared.frame.n_legs + 1))
    return minimum_load_plan(ctx, centre_wp, prepared.departure, prepared.verify_step_nm, v_min_kn=prepared.v_min,
                             v_max_kn=prepared.v_max)  # fmt: skip


def _minimum_load_candidate(prepared: Any, ctx: PlanContext) -> Candidate:
    """The centreline sailed at the engine's minimum load (:func:`centreline_minimum_load`)."""
    frame = prepared.frame
    centre_wp = frame.waypoints(np.zeros(frame.n_legs + 1))
    plan = centreline_minimum_load(prepared, ctx)
    stw = plan.stw_kn if plan is not None else np.full(frame.n_legs, prepared.v_min)
    return _candidate(prepared, "minimum-load schedule", track_warm_start(centre_wp, stw, frame), plan, "fuel")


def _minimum_time_candidate(prepared: Any, ctx: PlanContext, objective: str, route: Route | None) -> Candidate | None:
    """The corridor's minimum-time plan, verified in this solve's context (its ETA), as a candidate; None without one."""
    fast = prepared.minimum_time_plan(route)
    if fast is None:
        return None
    plan = verified_plan(ctx, fast.waypoints, fast.stw_kn, prepared.departure, prepared.verify_step_nm, "start")
    return _candidate(prepared, "minimum-time plan", plan_warm_start(fast, prepared.frame), plan, objective)


def _dp_applies(prepared: Any, ctx: PlanContext, objective: str, route: Route | None, reason: str) -> bool:
    """Whether the 3-D DP is a candidate: for fuel or cost ``discrete_start`` True, or ``"auto"`` where the global
    starts are computed (:func:`global_starts_reason`); for a free-arrival minimum time where the stage computes
    them (no local start verifies); on any corridor (its stages follow the centreline's bends,
    :func:`optroute.optimise.starts.corridor_stations`), not when the given route is the DP's own."""
    mode = prepared.discrete_start
    wanted = mode is True or (mode == "auto" and reason.startswith("computed"))
    if objective == "time":
        wanted = mode is not False and ctx.eta is None and reason.startswith("computed")
    # a given search route that is the DP's plan already: not again
    return wanted and not (route is not None and route.method == "dp")


def time_lattice(prepared: Any) -> dict[str, float]:
    """The 3-D DP's lattice for a free-arrival minimum time (:data:`TIME_LATTICE`'s resolution on the corridor)."""
    length = float(prepared.frame.s_nm[-1])
    half = float(np.max(prepared.frame.corridor.half_width_nm))
    return {
        "dx_nm": max(TIME_LATTICE["dx_nm"], length / TIME_LATTICE["stages"]),
        "dy_nm": max(half / TIME_LATTICE["per_side"], 1.0),
        "dt_h": TIME_LATTICE["dt_h"],
        "speed_step_kn": TIME_LATTICE["speed_step_kn"],
    }


def _dp_candidate(
    prepared: Any, ctx: PlanContext, objective: str, log: list[str], local: list[Candidate]
) -> Candidate | None:
    """The 3-D DP's plan on the corridor by the ETA, or its earliest for a free-arrival minimum time on
    :func:`time_lattice` (:func:`optroute.optimise.starts.dp_route`; ``dp_options`` override); None without one.
    Where the DP finds no route at all within the weather's span, its lattice statement is kept
    (``prepared.lattice_closed``) for a solve that ends without a verified plan.

    For least fuel (or cost) without an ETA, from the best verified ``local`` candidate (the minimum-load
    schedule): speeds every :data:`FREE_ARRIVAL_STEP_KN`, arrival bins of its passage over
    :data:`FREE_ARRIVAL_BINS` (at least 1 h), and for fuel its fuel plus :data:`FREE_ARRIVAL_CUT` as the DP's
    ``fuel_cut_t``: only the labels of routes that can burn less (by the DP's own figure and its lower bound to the
    end) are kept."""
    opts = prepared.dp_options if objective != "time" else {**time_lattice(prepared), **prepared.dp_options}
    verified = [c for c in local if c.plan is not None]
    if ctx.eta is None and objective != "time" and verified:
        best = min(verified, key=lambda c: c.score)
        dt_h = max(1.0, float(best.plan.duration_h) / FREE_ARRIVAL_BINS)
        opts = {"speed_step_kn": FREE_ARRIVAL_STEP_KN, "dt_h": dt_h, **opts}
        if objective == "fuel":
            opts = {"fuel_cut_t": best.score * (1.0 + FREE_ARRIVAL_CUT), **opts}
    try:
        dp = dp_route(ctx, prepared.frame, departure=prepared.departure, eta=ctx.eta, objective=objective,
                      v_min_kn=prepared.v_min, v_max_kn=prepared.v_max, fuel_price=prepared.fuel_price,
                      hourly=prepared.hourly, options=opts)  # fmt: skip
    except NoSafePassage as exc:
        prepared.lattice_closed["3-D DP"] = str(exc)
        log.append(f"3-D DP: no route within the weather's span ({exc})")
        return None
    return None if dp is None else _discrete(prepared, "3-D DP", ctx, dp, objective, log)


def _fine_centre_candidate(prepared: Any, ctx: PlanContext, log: list[str]) -> Candidate | None:
    """The earliest passage along the centreline within the weather's span, one speed through water per block of
    :data:`FINE_BLOCK_NM` (:func:`optroute.optimise.min_time.timed_safe_start` on the corridor resampled so, the true
    bands, every arrival bucket kept); None without one (its dead end kept in ``prepared.lattice_closed``).

    The 3-D DP's lattice can miss a passage this one keeps (harness seed 20: 3.5 kn for one block while a storm
    passes, then the top speed; the DP stops 90 nm out whatever its labels per bin), and the other way round. Both
    are lattices: on seed 20 blocks of 9.78 nm (the corridor's one leg in 28) find a verified passage and blocks of
    9 nm none, so neither finding nothing proves that there is no passage."""
    frame = build_frame(prepared.corridor.resample(FINE_BLOCK_NM))
    t0 = prepared.departure
    found = timed_safe_start(ctx, frame, t0, v_min_kn=prepared.v_min, v_max_kn=prepared.v_max,
                             block_nm=FINE_BLOCK_NM, hs_backoff=0.0, window_h=prepared.data_end_h)  # fmt: skip
    if not isinstance(found, TimedStart):
        prepared.lattice_closed["centreline"] = (
            f"on the centreline cut into blocks of at most {FINE_BLOCK_NM:g} nm, each at one speed through water "
            f"every 0.5 kn from {prepared.v_min:g} to {prepared.v_max:.4g} kn, one arrival per half hour kept (the "
            f"earliest), {found}"
        )
        log.append(f"timed passage: {found}")
        return None
    wp = frame.waypoints(found.offset_nm)
    plan = verified_plan(ctx, wp, found.stw_kn, t0, prepared.verify_step_nm, "start")
    return _candidate(prepared, "timed passage", track_warm_start(wp, found.stw_kn, prepared.frame), plan, "time")
