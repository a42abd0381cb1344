"""One point of a fuel–ETA front: its solve, its warm start, and the prepared corridors a process keeps.

A point is one :func:`optroute.optimise.api.solve_prepared` call (the solve of
:func:`optroute.optimise_corridor`) on the corridor prepared once per process for the weather's whole
time span (:func:`prepared_corridor`); an unreachable ETA or a solver failure becomes the point's
status, not an exception.  These functions
run in the calling process or on a Dask worker (:mod:`optroute.studies.front_runners`) for
:func:`optroute.studies.tradeoff.tradeoff` and :func:`optroute.studies.voyage_study.study`.
"""

from __future__ import annotations

import math
import threading
import time as _time
import uuid
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from optroute._store import StudyError
from optroute.errors import (
    ConfigError,
    InfeasibleETA,
    SolverFailure,
    WeatherCoverageError,
)
from optroute.optimise.api import optimise_corridor, solve_prepared
from optroute.optimise.corridor_problem import PreparedCorridor
from optroute.optimise.nlp_solve import Duals
from optroute.optimise.starts import repaired_plan
from optroute.physics.ship import Ship
from optroute.plan.result import Plan
from optroute.search.route import Corridor
from optroute.studies import fingerprint
from optroute.studies.threads import solver_process
from optroute.units import as_utc_time, format_utc, h_to_timedelta, timedelta_to_h
from optroute.weather.sample import WeatherSampler

if TYPE_CHECKING:
    pass

__all__ = [
    "FORBIDDEN_OPTIONS",
    "LEG_VARIABLES",
    "FrontPoint",
    "FrontSpec",
    "SpecMissing",
    "WarmStart",
    "failure_text",
    "front_token",
    "has_spec",
    "install_spec",
    "mended_start",
    "point_from_plan",
    "prepared_corridor",
    "replace_fields",
    "solve_chain",
    "solve_chain_by_token",
    "solve_point",
    "solve_point_by_token",
    "spec_of",
]

#: Leg variables a front keeps per point.
LEG_VARIABLES = ("sog_kn", "stw_kn", "heading_deg", "distance_nm", "duration_h", "power_kw", "fuel_t", "hs_m")
#: optimise_corridor options a front sets itself.
FORBIDDEN_OPTIONS = ("eta", "eta_mode", "objective", "warm_plan", "route", "departure", "progress")

# --------------------------------------------------------------------------- one point (runs on a worker)

#: A chain's point takes its previous point's verified plan as its only start (:attr:`WarmStart.sole_start`); a
#: chain's first point, started from an end's plan that arrives long before it (across the ETAs of the chains
#: between), is also compared with the centreline's start, unless that end is its neighbour in the front
#: (``end_adjacent``).
SOLE_START = True
#: A front's solves measure no power-table error (``solver_stats``' ``start_tabulation`` and ``tabulation``, two
#: referee evaluations per solve that :func:`point_from_plan` drops; on ``benchmarks/bench_front.py``'s storm corridor
#: about a tenth of a front's CPU): :meth:`~optroute.optimise.corridor_problem.PreparedCorridor.solve`'s ``tabulate``.
FRONT_TABULATION = False


@dataclass(frozen=True)
class WarmStart:
    """What :func:`optroute.optimise_corridor` reads of a ``warm_plan``: the track, its speeds and its solve's multipliers.

    ``duals`` (the NLP's multipliers of the plan, when the plan is the NLP's on a prepared corridor) start Ipopt's
    multipliers too where the next solve has the same rows: the primal-dual warm start of the continuation.
    ``sole_start``: when the referee accepts the plan for the new ETA it is the solve's only start and its floor
    (:meth:`~optroute.optimise.corridor_problem.PreparedCorridor.starts` builds no centreline start beside it).
    ``verified``: that plan as :func:`mended_start` verified it for the new ETA (the start stage does not verify it
    again; on the benchmark's storm corridor each verification of a 301-leg plan is about 1 CPU-s).
    """

    waypoints: np.ndarray
    stw_kn: np.ndarray
    duals: Duals | None = None
    sole_start: bool = False
    verified: Plan | None = None  # the referee's plan of exactly this track and speeds, verified for the next ETA


@dataclass(frozen=True)
class FrontSpec:
    """Everything a solve needs but the ETA and the warm start; shipped once to every worker."""

    corridor: Corridor
    weather: xr.Dataset | WeatherSampler
    ship: Ship
    departure: np.datetime64
    objective: str
    kwargs: Mapping[str, Any]
    token: str = ""  # names this front's prepared corridor in a process's cache


@dataclass(frozen=True)
class FrontPoint:
    eta_h: float  # NaN for the slow-steaming solve until its ETA is known
    kind: str  # "minimum_time" | "slow_steaming" | "eta"
    status: str
    runtime_s: float = 0.0
    iterations: int = 0
    totals: Mapping[str, float] = field(default_factory=dict)
    waypoints: np.ndarray | None = None
    times_h: np.ndarray | None = None
    legs: Mapping[str, np.ndarray] | None = None
    carry: WarmStart | None = None  # the warm start for the next point of a chain
    nlp_solves: int = 0  # Ipopt calls of the point's solve (band outer loop and verification re-solves included)
    warm_start: str = ""  # the candidate Ipopt started from ("warm plan", "centreline start", ...)
    dual_starts: int = 0  # Ipopt calls of the solve started from the neighbour's multipliers too
    own_fuel_t: float | None = None  # a risen point's own solve's fuel [t] (its plan is an earlier ETA's)

    @property
    def ok(self) -> bool:
        return self.waypoints is not None

    @property
    def fuel_t(self) -> float:
        return float(self.totals.get("fuel_t", math.nan))


def point_from_plan(plan: Plan, eta_h: float, kind: str, runtime_s: float) -> FrontPoint:
    legs = plan.legs
    dur = legs["duration_h"].to_numpy(dtype=float)
    power = legs["power_kw"].to_numpy(dtype=float)
    totals = {
        "fuel_t": float(plan.total_fuel_t),
        "duration_h": float(plan.duration_h),
        "distance_nm": float(plan.distance_nm),
        "mean_power_kw": float(np.sum(power * dur) / np.sum(dur)),
        "max_power_kw": float(np.max(power)),
        "eta_shadow_price_t_per_h": float(plan.eta_shadow_price_t_per_h),
    }
    times_h = np.array([timedelta_to_h(t - plan.departure) for t in plan.times], dtype=float)
    wp = np.asarray(plan.waypoints, dtype=float)
    return FrontPoint(
        eta_h=eta_h,
        kind=kind,
        status=plan.status,
        runtime_s=runtime_s,
        iterations=int(plan.solver_stats.get("iterations", 0)),
        nlp_solves=int(plan.solver_stats.get("nlp_solves", 0)),
        warm_start=str(plan.solver_stats.get("warm_start", "")),
        dual_starts=int(plan.solver_stats.get("dual_starts", 0)),
        totals=totals,
        waypoints=wp,
        times_h=times_h,
        legs={k: legs[k].to_numpy(dtype=float) for k in LEG_VARIABLES if k in legs},
        carry=WarmStart(wp, plan.stw_kn),
    )


def solve_point(
    spec: FrontSpec,
    eta_h: float | None,
    kind: str,
    warm: FrontPoint | WarmStart | None,
    route: Any = None,
    duals: bool = True,
    end_adjacent: bool = False,
    keep_plan: bool = False,
) -> FrontPoint:
    """One solve; an unreachable ETA or a solver failure becomes the point's status, not an exception.

    ``duals=False``: start from the warm plan's track and speeds alone, not its multipliers (a benchmark's
    primal-only continuation).  ``end_adjacent``: ``warm`` (an end's point, or an earlier ETA's plan for a
    point that rose above it) is the point's neighbour, so its verified plan is the only start, as a chain's
    previous point is (:data:`SOLE_START`); an end's plan from across other chains' ETAs is compared with
    the centreline's start too.  A neighbour is an earlier ETA's point (the front is swept from its fast end), so
    its plan arrives by the point's ETA as it is: where it carries that plan (``keep_plan`` kept it in its
    :attr:`WarmStart.verified`, as :func:`solve_chain` does inside a chain) the plan is the point's verified start
    without a second evaluation (:meth:`~optroute.plan.result.Plan.for_later_eta`), else :func:`mended_start`
    evaluates and verifies it.
    """
    solver_process()  # Ipopt's BLAS on one thread (the rounding of a Dask worker), glibc's thresholds raised
    started = _time.perf_counter()
    carry = warm.carry if isinstance(warm, FrontPoint) else warm
    if not duals and carry is not None and carry.duals is not None:
        carry = WarmStart(carry.waypoints, carry.stw_kn)
    objective = "time" if kind == "minimum_time" else spec.objective if kind == "eta" else "fuel"
    eta = None if eta_h is None else spec.departure + h_to_timedelta(eta_h)

    def failed(status: str) -> FrontPoint:  # the point of a solve that gave no plan, its status saying why
        return FrontPoint(
            math.nan if eta_h is None else eta_h, kind, status, _time.perf_counter() - started, carry=carry
        )

    plan_duals: Duals | None = None
    try:
        prepared, lock = prepared_corridor(spec) if spec.token else (None, None)
        if prepared is None or lock is None or not _covers(prepared, eta_h):
            # a study's case (no fingerprint: one solve, set up for its ETA) or an ETA past a free-arrival horizon
            plan = optimise_corridor(
                spec.corridor,
                spec.weather,
                spec.ship,
                departure=spec.departure,
                eta=eta,
                objective=objective,
                warm_plan=carry,
                route=route,
                **spec.kwargs,
            )
        else:
            with lock:  # one solve at a time: its cached builds are set up per solve (a worker may have threads)
                if kind == "eta" and isinstance(warm, FrontPoint) and carry is not None and eta is not None:
                    # a chain's previous point is the only start; an end's plan, from across a whole chain's span,
                    # is compared with the centreline's start
                    sole = SOLE_START and (warm.kind == "eta" or end_adjacent)
                    held = None if carry.verified is None else carry.verified.for_later_eta(eta, status="start")
                    start = mended_start(prepared, carry, eta) if held is None else replace_fields(carry, verified=held)
                    carry = replace_fields(start, sole_start=sole)
                plan = solve_prepared(
                    prepared,
                    eta,
                    objective=objective,
                    warm_plan=carry,  # type: ignore[arg-type]
                    route=route,
                    tabulate=FRONT_TABULATION,
                )
                plan_duals = prepared.last_duals  # this solve's multipliers, when its plan is the NLP's
    except InfeasibleETA as exc:
        if exc.earliest_arrival is not None:
            earliest = as_utc_time(exc.earliest_arrival, "earliest_arrival")
            status = (
                f"infeasible: earliest arrival {format_utc(earliest)} "
                f"({timedelta_to_h(earliest - spec.departure):.2f} h after departure)"
            )
        else:
            status = f"infeasible: {exc}"
        return failed(status)
    except SolverFailure as exc:
        if kind == "minimum_time" and exc.best_plan is not None:
            # the minimum-time NLP failed: the front starts from the fastest verified plan known (the search
            # route's, or a safe start's), an upper bound on the earliest arrival, and its status says so
            best = exc.best_plan
            point = point_from_plan(best, float(best.duration_h), kind, _time.perf_counter() - started)
            return replace_fields(
                point,
                status=f"feasible: fastest verified plan known ({best.status}); the minimum-time solve failed: "
                f"{failure_text(exc)}",
            )
        return failed(f"solver failure: {failure_text(exc)}")
    except WeatherCoverageError as exc:
        return failed(f"infeasible: {exc}")
    arrival_h = float(plan.duration_h)
    point = point_from_plan(plan, arrival_h if eta_h is None else eta_h, kind, _time.perf_counter() - started)
    if point.carry is not None and (plan_duals is not None or keep_plan):
        point = replace_fields(
            point, carry=replace_fields(point.carry, duals=plan_duals, verified=plan if keep_plan else None)
        )
    return point


def mended_start(prepared: PreparedCorridor, carry: WarmStart, eta: np.datetime64) -> WarmStart:
    """The neighbour's plan verified for the point's ETA, the engine's range mended leg by leg: the continuation's start.

    The earlier neighbour's plan arrives by the later ETA as it is, and the referee's verdict on it for that ETA
    (:attr:`WarmStart.verified`) spares the start stage a second verification of the same track and speeds.  Where
    the referee finds the engine outside its range (a plan carried to another ETA than its own, a plan not the
    NLP's), :func:`optroute.optimise.starts.repaired_plan` moves the speed of each such leg to the limit by the
    propeller law, as the optimiser does for a search route's plan; raising a leg's speed only arrives earlier, so
    the ETA still holds.  Where it cannot be verified the plan is returned unchanged (the optimiser then judges it
    with its own candidates).
    """
    plan, _ = repaired_plan(
        prepared.plan_context(eta),
        np.asarray(carry.waypoints, dtype=float),
        np.asarray(carry.stw_kn, dtype=float),
        prepared.departure,
        prepared.verify_step_nm,
        "start",
        v_min_kn=prepared.v_min,
        v_max_kn=prepared.v_max,
    )
    if plan is None:
        return carry
    return WarmStart(np.asarray(plan.waypoints, dtype=float), np.asarray(plan.stw_kn), carry.duals, verified=plan)


def solve_chain(
    spec: FrontSpec,
    etas: Sequence[float],
    warm: FrontPoint | None,
    cold: bool,
    duals: bool = True,
    end_adjacent: bool = False,
) -> list[FrontPoint]:
    """One chain of ETAs, each point started from the one before (the chain's first from ``warm``).

    ``cold``: every point from the optimiser's own start; ``duals=False``: from the neighbour's plan without its
    multipliers; ``end_adjacent``: ``warm`` (an end's point) is the chain's first ETA's neighbour in the front.
    """
    out = []
    for i, eta_h in enumerate(etas):
        p = solve_point(spec, eta_h, "eta", None if cold else warm, duals=duals, end_adjacent=end_adjacent and i == 0,
                        keep_plan=True)  # fmt: skip
        warm = p if p.ok else warm
        # the plan stays with the chain (the next point's start); the point returned carries arrays only
        out.append(p if p.carry is None else replace_fields(p, carry=replace_fields(p.carry, verified=None)))
    return out


#: Front inputs installed in this process (a Dask worker's), by their token, least recently used first: a
#: front's weather and corridor travel to a worker once (:func:`install_spec`), and its tasks carry the token
#: alone (:func:`solve_chain_by_token`), so a study's fronts and a benchmark's repetitions ship nothing again.
SPECS: dict[str, FrontSpec] = {}
SPECS_KEEP = 4


class SpecMissing(StudyError):
    """A task names front inputs this worker does not hold (it joined later, or evicted them)."""


def install_spec(spec: FrontSpec) -> str:
    """Keep ``spec`` in this process under its token (most recently used last); the token."""
    if not spec.token:
        raise ConfigError("install_spec needs a FrontSpec with a token (front_token of its inputs)")
    with _PREPARING:
        SPECS.pop(spec.token, None)
        SPECS[spec.token] = spec
        while len(SPECS) > SPECS_KEEP:
            SPECS.pop(next(iter(SPECS)))
    return spec.token


def has_spec(token: str) -> bool:
    """Whether this process holds the front inputs named ``token``."""
    return token in SPECS


def spec_of(token: str) -> FrontSpec:
    """The front inputs named ``token`` in this process; :class:`SpecMissing` when it has none."""
    spec = SPECS.get(token)
    if spec is None:
        raise SpecMissing(
            f"this process holds no front inputs with token {token!r} (a worker that joined after the front "
            "started, or one that kept newer fronts); the front installs them again and resubmits"
        )
    return spec


def solve_chain_by_token(
    token: str,
    etas: Sequence[float],
    warm: FrontPoint | None,
    cold: bool,
    duals: bool = True,
    end_adjacent: bool = False,
) -> list[FrontPoint]:
    """:func:`solve_chain` on the front inputs installed in this process under ``token``."""
    return solve_chain(spec_of(token), etas, warm, cold, duals, end_adjacent)


def solve_point_by_token(
    token: str,
    eta_h: float | None,
    kind: str,
    warm: FrontPoint | WarmStart | None,
    route: Any = None,
    end_adjacent: bool = False,
) -> FrontPoint:
    """:func:`solve_point` on the front inputs installed in this process under ``token``."""
    return solve_point(spec_of(token), eta_h, kind, warm, route, end_adjacent=end_adjacent)


#: Prepared corridors of this process (a Dask worker's too), by the inputs' fingerprint, least recently used
#: first: a worker keeps them between chains, between fronts of the same inputs and between a study's cases.
PREPARED_CORRIDORS: dict[str, tuple[PreparedCorridor, threading.Lock]] = {}
PREPARED_KEEP = 2
_PREPARING = threading.Lock()


def prepared_corridor(spec: FrontSpec) -> tuple[PreparedCorridor, threading.Lock]:
    """The corridor problem of ``spec`` prepared once in this process, and its solve lock.

    Prepared for the whole of the weather's time span (``latest_eta=None`` with the front's fuel or cost
    objective): the minimum-time and slow-steaming ends and every ETA between them are solved on the same
    weather grid, power table and CasADi build, so a front (or a study's cases of one ship, weather and
    corridor) costs one set-up per process.
    """
    with _PREPARING:
        hit = PREPARED_CORRIDORS.pop(spec.token, None)
        if hit is None:
            hit = (_prepare(spec), threading.Lock())
        PREPARED_CORRIDORS[spec.token] = hit  # most recently used last
        while len(PREPARED_CORRIDORS) > PREPARED_KEEP:
            PREPARED_CORRIDORS.pop(next(iter(PREPARED_CORRIDORS)))
    return hit


def _prepare(spec: FrontSpec) -> PreparedCorridor:
    """The corridor of ``spec`` prepared for the weather's whole time span."""
    return PreparedCorridor(
        spec.corridor,
        spec.weather,
        spec.ship,
        departure=spec.departure,
        latest_eta=None,
        objective=spec.objective,  # type: ignore[arg-type]
        **spec.kwargs,
    )


def _covers(prepared: PreparedCorridor, eta_h: float | None) -> bool:
    """Whether the prepared weather grid runs past an ETA [h] (always, when it runs to the weather's end)."""
    if eta_h is None or prepared.prepared_cap_h is not None:
        return True
    return eta_h * 1.02 + 1.0 <= prepared.horizon_h + 1e-9


def front_token(corridor: Corridor, weather: Any, ship: Ship, t0: np.datetime64, objective: str, kwargs: Any) -> str:
    """The fingerprint of a front's inputs (:mod:`optroute.studies.fingerprint`): the key of its prepared corridor.

    Inputs without a canonical form (an object that does not pickle) get a fresh random key: their front
    prepares its corridor again rather than risk another front's.
    """
    try:
        return fingerprint.digest(("front", corridor, weather, ship, str(t0), objective, dict(kwargs)))
    except ConfigError:
        return uuid.uuid4().hex


def failure_text(exc: SolverFailure) -> str:
    if exc.status in ("Solve_Succeeded", "Solved_To_Acceptable_Level"):
        return f"no plan passed verification (last Ipopt status {exc.status})"
    return exc.status or str(exc)


def replace_fields(p: Any, **changes: Any) -> Any:
    from dataclasses import replace

    return replace(p, **changes)
