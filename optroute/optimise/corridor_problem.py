"""A corridor problem prepared once and solved for many ETAs: :class:`PreparedCorridor`.

:func:`optroute.optimise_corridor` is set-up then solves. Set-up
(:func:`optroute.optimise.corridor_setup.prepare_corridor`): the NLP's weather grid with the ship's
own power tabulated on it (one model, the referee's), the lateral bounds and land mask and the
CasADi builds of :class:`formulations.speed_nlp.SpeedNLP`. Only the solves depend on the ETA (a
solve parameter of the NLP), so a fuel-versus-ETA front (:func:`optroute.studies.tradeoff`)
prepares the corridor once, for a horizon covering all its ETAs, and solves each ETA with
:meth:`PreparedCorridor.solve`.

A solve, in stages: **start** — every candidate scored by the referee before the first solve
(:mod:`optroute.optimise.start_stage`: a given warm plan or search route, the ship's dual schedule, the
centreline start, and where a band or the exclusion can bind or none of those verifies the 3-D DP on the
corridor and its minimum-time plan); **solve** — Ipopt from it with the band outer loop
(:meth:`~optroute.optimise.nlp_solve.Problem.solve`; a verified start the NLP's smoothed sea puts inside a band
moves that sample's edge through the start), the load, band and exclusion rows also at the
referee's check points of a canonical start (:mod:`optroute.optimise.rows`); **verify** — the plan of the solution by the
referee; where it finds only the engine outside its range (the smooth power table cannot follow the
model's steps between the NLP's samples) the speeds of those legs move to the limit
(:func:`~optroute.optimise.starts.repaired_plan`, status ``"mended"``); otherwise re-solved with the rows the
verification flagged tightened (band edges, load limit, exclusion radius, lateral bounds); **plan** — the better of the NLP's verified plan
and the verified start, never a worse one, with a status that says which and why.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any, Literal

import numpy as np
import xarray as xr

from optroute._checks import finite
from optroute.errors import (
    ConfigError,
    InfeasibleETA,
    NoSafePassage,
    OptrouteError,
    SolverFailure,
    WeatherCoverageError,
)
from optroute.optimise.corridor_setup import CorridorSetup, ProgressFn, emit, prepare_corridor, recut
from optroute.optimise.corridor_stats import CorridorReport
from optroute.optimise.nlp_inputs import CorridorFrame, exclusion_frame_error_nm, formulation_bands
from optroute.optimise.nlp_solve import (
    Duals,
    Solved,
    Tightening,
    clear_of_exclusion,
)
from optroute.optimise.rescue import (
    LIMIT_STATUSES,
    feasible_iterate,
    first_failure,
    longer_horizon,
    route_plan,
    start_in_nlp_bands,
    tighten,
    to_plan,
)
from optroute.optimise.rows import (
    BAND_LEG_NM,
    ROW_PLACEMENTS,
    band_leg_for,
    binding_legs,
    canonical_rows,
    leg_end_rows,
    only_where_binding,
    points_of,
)
from optroute.optimise.start_legs import OWN_LEGS_BAND_SOLVES, plan_on_own_legs
from optroute.optimise.start_stage import Starts, discrete_start_mode, start_stage, warm_candidate
from optroute.optimise.starts import ENGINE_KINDS, Candidate, repaired_plan, score, warm_is_plan
from optroute.physics.performance import PerformanceModel
from optroute.physics.safety import BandRules
from optroute.physics.ship import Ship
from optroute.plan.result import Exclusion, Plan, PlanContext, Violation
from optroute.search.route import Corridor, Route
from optroute.units import as_utc_time as _as_time
from optroute.units import format_utc
from optroute.units import h_to_timedelta as _h_to_td
from optroute.units import timedelta_to_h as _hours
from optroute.weather.sample import WeatherSampler

__all__ = ["PreparedCorridor"]

Objective = Literal["time", "fuel", "cost"]
TIE_REL_TOL = 1e-9  # relative difference of scores below which the NLP's plan and the start's tie [-]


_Found = tuple[Plan, Solved, float | None]  # a verified plan, its solve and the ETA solved [h]


@dataclass
class _Call:
    """One :meth:`PreparedCorridor.solve`: its checked inputs and its running record (solves, log, stage times)."""

    ctx: PlanContext
    eta_user_h: float | None
    cap_h: float | None
    eta_mode: str
    objective: str
    route: Route | None
    solve_kw: dict[str, Any]
    progress: ProgressFn | None
    started: float
    counts0: tuple[float, int, int, float]  # the problem's build time, solves, iterations and Ipopt time before
    dual_starts0: int  # the problem's primal-dual warm starts before
    samples_per_leg: int
    log: list[str] = field(default_factory=list)
    stage_s: dict[str, float] = field(default_factory=dict)
    start_table: dict[str, float] = field(default_factory=dict)
    last: Solved | None = None
    last_violations: list[Violation] = field(default_factory=list)
    retries: int = 0
    first_solve: str | None = None  # the first solve's verdict: "verified", "mended", "rejected: ...", "Ipopt ..."
    starts: Starts | None = None  # the start stage's candidates and why the global starts ran
    start_in_bands: dict[str, int] | None = None  # the first verified start solved from, inside the NLP's bands
    own_legs: bool = False  # solved on its verified start's own legs (PreparedCorridor._on_start_legs)
    edges_through: int | None = None  # (sample, band) edges the first solve from a verified start moved through it
    stage_cpu_s: dict[str, float] = field(default_factory=dict)
    tabulate: bool = True  # the power table's error at the warm start and the solution (statistics alone)
    _stage: tuple[str, float, float] | None = None  # the running stage: name, wall and CPU clocks at its start

    def begin(self, stage: str | None) -> None:
        """End the running stage (its wall and CPU seconds into ``stage_s`` and ``stage_cpu_s``) and begin ``stage``."""
        wall, cpu = _time.perf_counter(), _time.process_time()
        if self._stage is not None:
            name, w0, c0 = self._stage
            self.stage_s[name] = self.stage_s.get(name, 0.0) + wall - w0
            self.stage_cpu_s[name] = self.stage_cpu_s.get(name, 0.0) + cpu - c0
        self._stage = None if stage is None else (stage, wall, cpu)


def _check_choices(constraint_rows: Any, objective: Any, corridor: Any, samples_per_leg: Any) -> None:
    """:class:`PreparedCorridor`'s choices checked: ConfigError naming a bad one and what to give."""
    if constraint_rows not in ROW_PLACEMENTS:
        raise ConfigError(
            f"constraint_rows={constraint_rows!r} is not known; use 'referee' (the NLP's rows at the referee's "
            "check points of its start) or 'midpoints' (at the quadrature's midpoints and the leg ends)"
        )
    if objective not in ("time", "fuel", "cost"):
        raise ConfigError(f"objective={objective!r} is not known; use 'time', 'fuel' or 'cost'")
    if not isinstance(corridor, Corridor):
        raise ConfigError(f"corridor must be an optroute.Corridor, got {type(corridor).__name__}")
    if not (isinstance(samples_per_leg, int | np.integer) and samples_per_leg >= 1):
        raise ConfigError(f"samples_per_leg={samples_per_leg!r} must be an integer >= 1")


def _departure_and_eta(departure: Any, latest_eta: Any) -> tuple[np.datetime64, np.datetime64 | None]:
    """The departure and the latest ETA [UTC] (None without one), the ETA after the departure."""
    t0 = _as_time(departure, "departure")
    eta_t = _as_time(latest_eta, "eta") if latest_eta is not None else None
    if eta_t is not None and _hours(eta_t - t0) <= 0:
        raise ConfigError(
            f"eta={format_utc(eta_t)} is not after departure={format_utc(t0)}; give an arrival later than the departure"
        )
    return t0, eta_t


class PreparedCorridor(CorridorReport):
    """The corridor NLP set up once for a range of ETAs; :meth:`solve` solves one ETA.

    Parameters
    ----------
    corridor, weather, ship, departure, model, rules, max_leg_nm, band_leg_nm, samples_per_leg, fuel_price_per_t,
    hourly_cost_per_h, exclusion, speed_range_kn, band_solves, max_retries,
    band_margin, band_hs_margin, verify_step_nm, solver_options, use_land_mask, jit, discrete_start, dp_options,
    constraint_rows, timed_no_passage
        As in :func:`optroute.optimise_corridor`.
    latest_eta : datetime64 or str, optional
        The latest ETA to be solved [UTC]: the weather grid (and the ship's power table on it) runs
        to just after it. Default: the end of the weather's time span when
        ``objective`` is ``"fuel"`` or ``"cost"``, else a free-arrival horizon (1.3 × the passage at
        half the design speed), as :func:`optimise_corridor` without an ETA.
    objective : {"fuel", "time", "cost"}
        For the default ``latest_eta``, and where ``band_leg_nm`` applies: a free-arrival minimum time
        (``"time"`` without ``latest_eta``) keeps ``max_leg_nm`` everywhere, since its 3-D DP start runs only where
        no local start verifies and shorter legs let a poorer local start verify in its place (harness seeds 13
        and 17).

    Notes
    -----
    Preparing for the latest ETA ``T`` gives exactly the problem :func:`optimise_corridor` sets up
    for ``eta=T``; an earlier ETA is solved on the same (longer) weather grid.
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
        max_retries: int = 4,
        band_margin: float = 0.005,
        band_hs_margin: float = 0.05,
        verify_step_nm: float = 5.0,
        solver_options: Mapping[str, Any] | None = None,
        use_land_mask: bool | None = None,
        progress: ProgressFn | None = None,
        jit: bool | str = "auto",
        discrete_start: bool | str = "auto",
        dp_options: Mapping[str, Any] | None = None,
        constraint_rows: str = "midpoints",
        timed_no_passage: bool = False,
        speed_nodes_kn: np.ndarray | None = None,
        band_leg_nm: float | None = BAND_LEG_NM,
    ) -> None:
        # every argument, for the free-arrival minimum-time twin of this corridor (minimum_time_twin)
        self._arguments = {k: v for k, v in locals().items() if k not in ("self", "__class__")}
        self._twin: PreparedCorridor | None = None
        _check_choices(constraint_rows, objective, corridor, samples_per_leg)
        self.constraint_rows = constraint_rows
        self._row_points: tuple[list[np.ndarray] | None] | None = None  # (rows,) once computed (_rows_from)
        t0, eta_t = _departure_and_eta(departure, latest_eta)
        self.fuel_price = float(
            finite("fuel_price_per_t", fuel_price_per_t, minimum=0.0, strict=True, error=ConfigError)
        )
        self.hourly = float(finite("hourly_cost_per_h", hourly_cost_per_h, minimum=0.0, error=ConfigError))
        self.margin0 = float(finite("band_margin", band_margin, minimum=0.0, error=ConfigError))
        self.hs_margin0 = float(finite("band_hs_margin", band_hs_margin, minimum=0.0, error=ConfigError))
        su = prepare_corridor(
            corridor, weather, ship, t0=t0, eta_t=eta_t, objective=objective, model=model, rules=rules,
            max_leg_nm=max_leg_nm, exclusion=exclusion, speed_range_kn=speed_range_kn, use_land_mask=use_land_mask,
            solver_options=solver_options, jit=jit, progress=progress, timed_no_passage=bool(timed_no_passage),
            speeds_kn=speed_nodes_kn, hs_margin=self.hs_margin0,
            band_leg_nm=band_leg_for(band_leg_nm, objective=objective, eta_given=eta_t is not None),
        )  # fmt: skip
        self.setup = su
        self.corridor, self.ship, self.model, self.rules = corridor, ship, su.model, su.rules
        self.sampler, self.dataset, self.exclusion, self.use_land_mask = (
            su.sampler,
            su.dataset,
            exclusion,
            use_land_mask,
        )
        self.departure, self.data_end_h, self.horizon_h, self.prepared_cap_h = t0, su.data_end_h, su.horizon_h, su.cap_h
        self.frame, self.grid, self.samples, self.power, self.table = su.frame, su.grid, su.samples, su.power, su.table
        self.y_lo, self.y_hi, self.v_min, self.v_max, self.length_nm = (
            su.y_lo,
            su.y_hi,
            su.v_min,
            su.v_max,
            su.length_nm,
        )
        self.samples_per_leg = int(samples_per_leg)
        self.band_solves, self.max_retries = int(band_solves), int(max_retries)
        #: the 3-D DP among the starts: True, False or "auto" (:mod:`optroute.optimise.start_stage`)
        self.discrete_start = discrete_start_mode(discrete_start)
        self.dp_options = dict(dp_options or {})
        #: the minimum-time plans solved so far, one per route given (None: no route), held with the route itself
        #: (:meth:`minimum_time_plan`; a front's points share them)
        self.minimum_time_plans: list[tuple[Route | None, Plan | None]] = []
        #: the start stage's lattice searches that found no passage within the weather's span ("3-D DP", "centreline":
        #: what each searched and where it ended), for the outcome of a solve that ends with no verified plan
        #: (:mod:`optroute.optimise.api`)
        self.lattice_closed: dict[str, str] = {}
        #: the multipliers of the last solve's plan when it is the NLP's (None when a start's): a neighbouring
        #: ETA's primal-dual warm start (``warm_plan.duals``), read right after the solve
        self.last_duals: Duals | None = None
        self.verify_step_nm = float(verify_step_nm)
        self.problem = su.problem
        self.exclusion_backoff_nm = self._exclusion_backoff()

    def cut_to(self, frame: CorridorFrame) -> None:
        """Solve on the legs of ``frame`` from now on: the same centreline's legs cut further, on the same great
        circles (:func:`~optroute.optimise.corridor_setup.recut`: the weather grid and power table stay, the lateral
        bounds and the problem are the new legs'). An ensemble's members share one cut (:mod:`optroute.optimise.robust`);
        only before any solve."""
        args = self._arguments
        su = recut(
            self.setup, frame, ship=self.ship, exclusion=self.exclusion, departure=self.departure,
            use_land_mask=self.use_land_mask, timed_no_passage=bool(args["timed_no_passage"]),
            solver_options=args["solver_options"], jit=args["jit"],
        )  # fmt: skip
        self._use_setup(su)

    def _use_setup(self, su: CorridorSetup) -> None:
        """Solve on the legs of the setup ``su`` (:meth:`cut_to`, and back after a solve on cut legs): its frame,
        lateral bounds and problem, and what is derived from the legs computed again."""
        self.setup, self.frame, self.y_lo, self.y_hi, self.problem = su, su.frame, su.y_lo, su.y_hi, su.problem
        self.__dict__.pop("binding", None)  # the cached property, of the old legs
        self._row_points = None
        self.exclusion_backoff_nm = self._exclusion_backoff()

    def _exclusion_backoff(self) -> float:
        """The flat frame's measured distance error near the exclusion's circle [nm]: the NLP's circle grows by it, so
        that a plan on its edge is outside the referee's (WGS84) circle on the first solve (0 without one)."""
        return 0.0 if self.exclusion is None else exclusion_frame_error_nm(self.exclusion, self.frame)

    def minimum_time_twin(self) -> PreparedCorridor:
        """This corridor prepared as :func:`optroute.optimise_corridor` prepares it for ``objective="time"`` without an
        ETA (its weather grid to the free-arrival horizon; this corridor itself when prepared so): its minimum-time
        plan is the one that call gives, which an ETA's weather grid, ending just after the ETA, can change
        (harness seed 51: 11.17 h and 125.40 t against 11.48 h and 128.53 t). Prepared once; its builds and solves
        count in this corridor's problem."""
        args = self._arguments
        if args["latest_eta"] is None and args["objective"] == "time":
            return self
        if self._twin is None:
            self._twin = PreparedCorridor(**{**args, "latest_eta": None, "objective": "time", "progress": None})
        return self._twin

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

    def _tightening(self) -> Tightening:
        n = self.frame.n_legs
        return Tightening(
            max_load=1.0,
            min_load=self.power.min_load,
            widen=self.margin0,
            hs_margin=self.hs_margin0,
            samples_per_leg=self.samples_per_leg,
            bound_scale=np.ones(n + 1),
            y_lo=self.y_lo.copy(),
            y_hi=self.y_hi.copy(),
            row_points=self._rows_from(),
            extra_radius_nm=self.exclusion_backoff_nm,
        )

    # ------------------------------------------------------------------ stage: start

    def starts(
        self,
        ctx: PlanContext,
        *,
        cap_h: float | None,
        objective: Objective,
        warm_plan: Plan | None,
        route: Route | None,
        st: Tightening,
    ) -> list[Candidate]:
        """The NLP's start candidates scored by the referee, best first (:func:`~optroute.optimise.start_stage.start_stage`)."""
        return start_stage(
            self, ctx, cap_h=cap_h, objective=objective, warm_plan=warm_plan, route=route, st=st
        ).candidates

    @cached_property
    def binding(self) -> np.ndarray:
        """Per leg, whether a danger band or the exclusion can bind on it (:func:`optroute.optimise.rows.binding_legs`,
        at the first solve's Hs back-off); computed once. The start stage computes the global starts where any does."""
        return binding_legs(self.frame, self.grid.s_nm, self.grid.hs_m, (self.ship, self.rules, self.exclusion),
                            self.hs_margin0, self.departure)  # fmt: skip

    def minimum_time_plan(self, route: Route | None = None) -> Plan | None:
        """The corridor's minimum-time plan (verified, any arrival): the plan :func:`optroute.optimise_corridor` gives
        for ``objective="time"`` without an ETA (:meth:`minimum_time_twin`), from ``route`` when given; None when that
        call gives no verified plan. Solved once per route (:attr:`minimum_time_plans`); the twin's builds and solves
        count in this corridor's problem (``solver_stats``)."""
        for held, plan in self.minimum_time_plans:
            if held is route:
                return plan
        fresh = self._twin is None
        twin = self.minimum_time_twin()
        q = twin.problem
        before = (0.0, 0, 0, 0.0) if fresh else (q.build_time_s, q.solves, q.iterations, q.solve_time_s)
        try:
            plan = twin.solve(None, objective="time", route=route)
        except SolverFailure as exc:
            plan = exc.best_plan
        except (InfeasibleETA, WeatherCoverageError, NoSafePassage, ConfigError):
            plan = None
        finally:
            if twin is not self:
                self.problem.add_counts(q, before)
        if plan is not None and plan.verify(step_nm=self.verify_step_nm):
            plan = None
        self.minimum_time_plans.append((route, plan))
        return plan

    # ------------------------------------------------------------------ one ETA

    def _window(self, eta: Any, objective: str) -> tuple[np.datetime64 | None, float | None, float | None]:
        """The ETA [UTC], its hours after departure, and the passage cap [h] of a solve (checked)."""
        t0 = self.departure
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
        return eta_t, eta_user_h, cap_h

    def solve(
        self,
        eta: Any = None,
        *,
        eta_mode: Literal["le", "eq"] = "le",
        objective: Objective = "fuel",
        warm_plan: Plan | None = None,
        route: Route | None = None,
        progress: ProgressFn | None = None,
        tabulate: bool = True,
    ) -> Plan:
        """Solve one ETA: :func:`optroute.optimise_corridor` on the prepared problem.

        Parameters
        ----------
        eta, eta_mode, objective, warm_plan, route, progress
            As in :func:`optimise_corridor`; ``eta`` at most the prepared ``latest_eta``.
        tabulate : bool
            Measure the power table's error at the warm start and at the solution (``solver_stats``'
            ``start_tabulation`` and ``tabulation``: a referee evaluation of each, statistics alone). False (a
            front's points, which keep none of it): both are ``{}``; the plan is the same.

        Returns
        -------
        Plan
            As :func:`optimise_corridor`'s; ``solver_stats`` also holds ``prepared_horizon_h``.

        Raises
        ------
        ConfigError
            An ETA after the prepared horizon (prepare with a later ``latest_eta``), or a free-arrival
            fuel/cost solve on a corridor prepared for an ETA.
        InfeasibleETA, SolverFailure, WeatherCoverageError
            As :func:`optimise_corridor`.
        """
        self.last_duals = None
        call = self._inputs(eta, eta_mode, objective, route, progress)  # stage: inputs
        call.tabulate = bool(tabulate)
        emit(progress, "start", 0.15)  # stage: start
        call.begin("start")
        st = self._tightening()
        st.log = call.log
        call.starts = start_stage(
            self, call.ctx, cap_h=call.cap_h, objective=objective, warm_plan=warm_plan, route=route, st=st
        )
        cands = call.starts.candidates
        start, first = cands[0], warm_candidate(cands)
        call.log.append(
            "starts: "
            + "; ".join(f"{c.label} {c.score:.6g}" if c.plan is not None else f"{c.label} unverified" for c in cands)
        )
        on_legs = self._on_start_legs(call, start) if first is start else None
        if on_legs is not None:
            start = first = on_legs[0]
        call.begin("solve and verify")  # stages: solve (with the band sides), verify
        try:
            best = self._solve_stage(call, start, first)
            call.begin("plan")
            return self._plan_stage(call, cands, start, first, best)
        finally:
            if on_legs is not None:
                self._restore_legs(on_legs[1])

    def _on_start_legs(self, call: _Call, start: Candidate) -> tuple[Candidate, CorridorSetup] | None:
        """For a free-arrival minimum time started from a verified plan on other legs (the 3-D DP's stages, which a
        corridor prepared for it keeps whole): this solve on that plan's own legs
        (:func:`~optroute.optimise.start_legs.plan_on_own_legs`, :meth:`cut_to`), the band-side search's budget
        :data:`~optroute.optimise.start_legs.OWN_LEGS_BAND_SOLVES`. Returns the candidate on those legs and the legs'
        state to restore after the solve (:meth:`_restore_legs`); None where the start is on the NLP's legs already
        or its plan does not verify on the cut legs.

        A first solve that fails there is not diagnosed by the elastic phase-1 problem (:meth:`_first_failure`): it
        started from a plan the referee passed on its own legs, so a safe start is not what it lacks, and that plan
        stands."""
        plan = start.plan
        if plan is None or call.objective != "time" or call.eta_user_h is not None or warm_is_plan(start, self.frame):
            return None
        own = plan_on_own_legs(call.ctx, self.frame, plan, self.departure, self.verify_step_nm)
        if own is None:
            call.log.append(f"the {start.label}'s plan does not verify on the NLP's legs cut at its stages")
            return None
        saved = self.setup
        self.cut_to(own.frame)
        self.problem.take_counts(saved.problem)  # this call's counts run on in the cut legs' problem
        call.log.append(f"legs cut where the {start.label}'s plan changes speed or offset: {own.frame.n_legs} legs")
        call.own_legs = True
        val = self._score(own.plan, call)
        return replace(start, warm=own.warm, plan=own.plan, score=val, estimate=min(val, start.estimate)), saved

    def _budget(self, call: _Call) -> int:
        """The band-side search's budget of solves in ``call``: on a verified start's own legs at most
        :data:`~optroute.optimise.start_legs.OWN_LEGS_BAND_SOLVES` (the DP chose its sides across the corridor)."""
        return min(self.band_solves, OWN_LEGS_BAND_SOLVES) if call.own_legs else self.band_solves

    def _restore_legs(self, saved: CorridorSetup) -> None:
        """The prepared legs (their setup ``saved``) back after a solve on legs cut for it (:meth:`_on_start_legs`),
        with that solve's builds and solves counted in their problem."""
        cut = self.problem
        self._use_setup(saved)
        self.problem.take_counts(cut)
        self.last_duals = None  # the cut legs' multipliers fit no solve on these legs

    # ------------------------------------------------------------------ the stages of a solve

    def _inputs(
        self, eta: Any, eta_mode: str, objective: str, route: Route | None, progress: ProgressFn | None
    ) -> _Call:
        """Stage inputs: the checked ETA, mode and objective, and the record of this solve."""
        if objective not in ("time", "fuel", "cost"):
            raise ConfigError(f"objective={objective!r} is not known; use 'time', 'fuel' or 'cost'")
        if eta_mode not in ("le", "eq"):
            raise ConfigError(f"eta_mode={eta_mode!r} is not known; use 'le' (arrive by) or 'eq' (arrive at)")
        started = _time.perf_counter()
        eta_t, eta_user_h, cap_h = self._window(eta, objective)
        prob = self.problem
        return _Call(
            ctx=self.plan_context(eta_t, eta_mode),  # type: ignore[arg-type]
            eta_user_h=eta_user_h,
            cap_h=cap_h,
            eta_mode=eta_mode,
            objective=objective,
            route=route,
            solve_kw={
                "eta_mode": eta_mode,
                "objective": objective,
                "fuel_price": self.fuel_price,
                "hourly_cost": self.hourly,
            },
            progress=progress,
            started=started,
            counts0=(prob.build_time_s, prob.solves, prob.iterations, prob.solve_time_s),
            dual_starts0=prob.dual_starts,
            samples_per_leg=self.samples_per_leg,
        )

    def _score(self, plan: Plan, call: _Call) -> float:
        return score(plan, call.objective, self.fuel_price, self.hourly)

    def _solve_stage(self, call: _Call, start: Candidate, first: Candidate) -> _Found | None:
        """Stages solve and verify: from the warm candidate, and once more from the verified start when that is better.

        A discrete start the NLP cannot improve on costs time, not fuel: the plan stage keeps the start.
        """
        call.start_table = self._table_at(call.ctx, first.warm) if call.tabulate else {}
        best: _Found | None = None
        tries = [first] + ([start] if first is not start and start.plan is not None else [])
        for k, cand in enumerate(tries):
            if k > 0:
                if best is not None and self._score(best[0], call) <= start.score:
                    break
                call.log.append(f"again from the verified {cand.label}")
            found = self._solve_from(
                call, cand, diagnose=k == 0 and not call.own_legs, verified_start=start.plan is not None
            )
            if found is not None and (best is None or self._score(found[0], call) < self._score(best[0], call)):
                best = found
        return best

    def _rows_from(self) -> list[np.ndarray] | None:
        """The NLP's row points: the leg ends where a band or the exclusion can bind
        (:func:`optroute.optimise.rows.leg_end_rows`), or with ``constraint_rows="referee"`` once per prepared
        corridor :func:`optroute.optimise.rows.canonical_rows`."""
        if self.constraint_rows != "referee":
            return leg_end_rows(self.binding)
        if self._row_points is None:
            cap_h = self.prepared_cap_h
            speed = self.length_nm / cap_h if cap_h is not None and np.isfinite(cap_h) else self.ship.design_speed_kn
            rows = canonical_rows(self.plan_context(), self.frame, (self.y_lo, self.y_hi), float(np.clip(
                speed, self.v_min, self.v_max)), self.departure, self.verify_step_nm)  # fmt: skip
            self._row_points = (only_where_binding(rows, self.binding),)
        return self._row_points[0]

    def _solve_from(
        self, call: _Call, cand: Candidate, *, diagnose: bool, verified_start: bool = False
    ) -> _Found | None:
        """Solve from one candidate; where the referee rejects the plan, tighten the rows it flagged and solve again
        from the rejected plan. Where that solve fails and the candidate is a plan on the NLP's legs
        (:func:`warm_is_plan`), the next attempt starts from it again, its samples inside the tightened bands with
        their edges through it (:func:`~optroute.optimise.nlp_solve.edges_through`): the rejected plan lies on the
        old edges, outside the widened bands' feasible set, where Ipopt may find no point (the storm crossings of
        ``benchmarks/bench_bands.py``). The rejected plan stays the first retry's start, nearer the optimum than the
        verified start where that retry succeeds.

        ``diagnose``: a failed first solve goes to :func:`first_failure` (the elastic phase-1 problem): without a
        verified start an unreachable ETA raises :class:`~optroute.errors.InfeasibleETA`; with one
        (``verified_start``) only phase-1's start is taken, and a diagnosis leaves the verified start standing.
        """
        prob, st = self.problem, self._tightening()
        st.log = call.log
        warm = clear_of_exclusion(dict(cand.warm), self.frame, self.exclusion, self.departure, self.y_lo, self.y_hi)
        st.row_points = self._rows_from()
        first_warm, from_plan = warm, warm_is_plan(cand, self.frame)
        for attempt in range(self.max_retries + 1):
            emit(call.progress, "solve", 0.2 + 0.7 * attempt / (self.max_retries + 1))
            nlp = prob.build(st)
            if attempt == 0 and cand.plan is not None:
                nlp = self._fitted_to_start(call, nlp, st, warm)
            eta_solve = None if call.cap_h is None else call.cap_h - st.eta_shift_h
            if eta_solve is not None and eta_solve <= 0:
                break
            # a start the referee passed, as the NLP sees it: the NLP's band edges may pass through it
            through = from_plan and warm is first_warm
            sol = prob.solve(nlp, eta_h=eta_solve, warm=warm, budget=self._budget(call), through_start=through,
                             **call.solve_kw)  # fmt: skip
            if through and call.edges_through is None:
                call.edges_through = sol.edges_through
            if not sol.ok and self._usable_iterate(sol, call.ctx):
                call.log.append(f"attempt {attempt}: kept Ipopt's last iterate ({sol.res.status}): its plan verifies")
                sol = replace(sol, ok=True)
            if not sol.ok and attempt == 0 and diagnose:
                call.first_solve = call.first_solve or f"Ipopt {sol.res.status}"
                sol = self._first_failure(call, nlp, sol, st, warm, verified_start=verified_start)
            call.last = sol
            at_limit = sol.res.status in LIMIT_STATUSES and not np.any(sol.res.samples.inside)
            if not sol.ok and not at_limit:
                call.log.append(f"attempt {attempt}: Ipopt {sol.res.status}")
                call.first_solve = call.first_solve or f"Ipopt {sol.res.status}"
                if from_plan and warm is not first_warm:  # from a rejected plan: once more from the verified start
                    warm = first_warm
                    continue
                break
            found, plan, violations = self._verified(call, sol, attempt)
            if call.first_solve is None:
                verdict = "rejected: " + ", ".join(sorted({v.kind for v in violations}))
                call.first_solve = verdict if found is None else ("mended" if found[1].mended_legs else "verified")
            if found is not None:
                return found[0], found[1], eta_solve
            call.last_violations = violations
            if st.retries >= self.max_retries:
                break
            st.retries += 1
            tighten(st, violations, plan, sol.res)
            if self.constraint_rows == "referee" and getattr(violations, "points", None) is not None:
                binding = self.binding.copy()  # the rejected plan's check points, and every leg it was rejected on
                binding[[v.leg for v in violations if 0 <= v.leg < binding.size]] = True
                st.row_points = only_where_binding(points_of(violations.points, plan.waypoints), binding)
            st.forced_legs = self._rejected_legs(st.forced_legs, violations)
            call.retries, call.samples_per_leg = st.retries, st.samples_per_leg
            warm = {"offset_nm": sol.res.offset_nm, "stw_kn": sol.res.stw_kn}
        return None

    def _fitted_to_start(self, call: _Call, nlp: Any, st: Tightening, warm: Mapping[str, np.ndarray]) -> Any:
        """The NLP of a first solve from a verified start, its band back-offs lowered so that the start is clear of them.

        A start the referee passed can lie inside the NLP's backed-off bands (:func:`start_in_nlp_bands`); started
        there, the NLP is outside its own feasible set and Ipopt reports it infeasible though the start is a plan. The
        back-offs are lowered to half the start's clearance where that clears it, the Hs threshold's no lower than
        the NLP's Hs reads under the referee's at the start's samples (:meth:`true_hs_m`,
        :func:`~optroute.optimise.rescue.hs_under_read`; a rejection by the referee raises them again,
        :func:`tighten`); where the NLP's own evaluation puts the start inside a rules' band, they stay, and
        the solve moves the edges of those samples alone through the start
        (:func:`~optroute.optimise.nlp_solve.edges_through`; ``start_edges_moved`` counts them).
        The first such start's counts are the call's record (``verified_start_in_nlp_bands``).
        """
        rules_bands, _, _ = formulation_bands(self.ship, self.rules)  # the rules' own: no back-offs
        counts, hs_margin, widen = start_in_nlp_bands(nlp, st, warm, rules_bands, true_hs=self.true_hs_m)
        if call.start_in_bands is None:
            call.start_in_bands = counts
        if counts["inside_rules_band"] or (hs_margin, widen) == (st.hs_margin, st.widen):
            return nlp
        st.log.append(
            f"back-offs fitted to the verified start: band edges {st.widen:.3g} -> {widen:.3g}, "
            f"Hs threshold {st.hs_margin:.3g} -> {hs_margin:.3g}"
        )
        st.hs_margin, st.widen = hs_margin, widen
        return self.problem.build(st)

    def true_hs_m(self, time_h: np.ndarray, s_nm: np.ndarray, y_nm: np.ndarray) -> np.ndarray:
        """The referee's Hs [m] at corridor coordinates: times [h after departure], along-track and lateral (port +)
        positions [nm]; NaN where the weather does not cover the point."""
        lat, lon, _ = self.frame.points(s_nm, y_nm)
        when = self.departure + _h_to_td(np.asarray(time_h, dtype=float))
        covered = self.sampler.covers(when, lat, lon)
        out = np.full(np.shape(lat), np.nan)
        if covered.any():
            out[covered] = self.sampler.sample(when[covered], lat[covered], lon[covered], ["hs_m"])["hs_m"]
        return out

    def _rejected_legs(self, forced: np.ndarray | None, violations: list[Violation]) -> np.ndarray | None:
        """``forced`` (N,) with the legs of the referee's band and exclusion ``violations``: those legs keep their band
        and exclusion rows in the next build whatever the weather grid says (:func:`optroute.optimise.rows.nlp_row_legs`)."""
        legs = [v.leg for v in violations if v.kind.startswith("band") or v.kind == "exclusion"]
        legs = [k for k in legs if 0 <= k < self.frame.n_legs]
        if not legs:
            return forced
        out = np.zeros(self.frame.n_legs, dtype=bool) if forced is None else forced.copy()
        out[legs] = True
        return out

    def _first_failure(
        self,
        call: _Call,
        nlp: Any,
        sol: Solved,
        st: Tightening,
        warm: Mapping[str, np.ndarray],
        *,
        verified_start: bool = False,
    ) -> Solved:
        """A failed first solve: an unreachable ETA, or a hard problem (:func:`first_failure`). With a verified start
        (a discrete plan that meets the ETA) a diagnosis is not the outcome: the start stands, and only phase-1's
        solve, when it gives one, can improve on it."""
        if not verified_start:
            return self._diagnosed(call, nlp, sol, st, warm)
        try:
            return self._diagnosed(call, nlp, sol, st, warm)
        except OptrouteError as exc:  # InfeasibleETA, NoSafePassage or SolverFailure: the verified start stands
            call.log.append(f"phase-1 after the failed first solve: {type(exc).__name__}; the verified start stands")
            return sol

    def _diagnosed(self, call: _Call, nlp: Any, sol: Solved, st: Tightening, warm: Mapping[str, np.ndarray]) -> Solved:
        prob = self.problem
        return first_failure(
            prob,
            nlp,
            sol,
            longer=lambda st=st: longer_horizon(prob, st, self.sampler, self.data_end_h, self.horizon_h),
            ctx=call.ctx,
            cap_h=call.cap_h,
            eta_user_h=call.eta_user_h,
            t0=self.departure,
            route=call.route,
            budget=self._budget(call),
            step_nm=self.verify_step_nm,
            solve_kw=call.solve_kw,
            first_warm=warm,
            log=call.log,
        )

    def _verified(
        self, call: _Call, sol: Solved, attempt: int
    ) -> tuple[tuple[Plan, Solved] | None, Plan, list[Violation]]:
        """Stage verify: the solution's plan by the referee; mended by speed where only the engine's range breaks.

        The smooth table cannot follow the model's steps (Kwon's Beaufort and direction sectors) at the
        referee's points: where only the engine's range is broken there, the speeds of those legs move to the
        limit by the propeller law (:func:`~optroute.optimise.starts.repaired_plan`; no re-solve, no global
        tightening of the load limit). Returns the verified plan and its solve (or None), the plan of the
        solution and the referee's violations.
        """
        step = self.verify_step_nm
        plan = to_plan(call.ctx, self.frame, sol.res, self.departure, step_nm=step)
        violations = plan.verify(step_nm=step)
        if not violations and sol.ok:
            return (plan, sol), plan, violations
        if sol.ok and all(v.kind in ENGINE_KINDS for v in violations):
            mended, legs = repaired_plan(
                call.ctx,
                plan.waypoints,
                plan.stw_kn,
                self.departure,
                step,
                "candidate",
                v_min_kn=self.v_min,
                v_max_kn=self.v_max,
            )
            if mended is not None:
                call.log.append(
                    f"attempt {attempt}: the referee found the engine outside its range on "
                    f"{len({v.leg for v in violations})} legs; speeds mended on {legs} legs"
                )
                return (mended, replace(sol, mended_legs=legs)), plan, violations
        if not sol.ok:  # stopped at a limit at a point the referee rejects: tighten what it found and go on
            call.log.append(f"attempt {attempt}: Ipopt {sol.res.status}; its iterate fails verification")
        return None, plan, violations

    def _plan_stage(
        self, call: _Call, cands: list[Candidate], start: Candidate, first: Candidate, best: _Found | None
    ) -> Plan:
        """Stage plan: the NLP's verified plan, or the verified start where the NLP did not improve on it."""
        if best is None and start.plan is None:
            self._no_plan(call)
        nlp_score = self._score(best[0], call) if best is not None else float("inf")
        stats = self._stats(call, cands, start, first, nlp_score)
        if best is not None:
            emit(call.progress, "certificate", 0.95)
            stats.update(self._solution_stats(call, best[1], best[2]))
        cap_h, mode, objective = call.cap_h, call.eta_mode, call.objective
        # a tie to the solver's tolerance (the start already optimal, as at a constant speed in calm water) keeps the
        # NLP's plan, with its multipliers and certificate; "worse" is beyond TIE_REL_TOL of the start's score
        if best is None or nlp_score > start.score + TIE_REL_TOL * max(1.0, abs(start.score)):
            why = self._no_nlp_plan(call) if best is None else f"its plan scores {nlp_score:.6g}"
            stats["status_reason"] = f"the NLP did not improve on the verified {start.label} ({start.score:.6g}): {why}"
            stats["certificate"] = self._ship_certificate(start.plan, stats, cap_h, mode, objective)  # type: ignore[arg-type]
            self._finish(call, stats)
            emit(call.progress, "done", 1.0)
            return replace(start.plan, status="start", solver_stats=stats)  # type: ignore[arg-type]
        plan, sol, _ = best
        status, reason = self._status(sol, call)
        if reason:
            stats["status_reason"] = reason
        shadow = float("nan")
        if call.eta_user_h is not None and objective in ("fuel", "cost"):
            shadow = float(sol.res.eta_multiplier) / (1.0 if objective == "fuel" else self.fuel_price)
        stats["certificate"] = self._ship_certificate(plan, stats, cap_h, mode, objective)
        self._finish(call, stats)
        self.last_duals = Duals.of(sol.res, sol.nlp)
        emit(call.progress, "done", 1.0)
        return replace(plan, status=status, solver_stats=stats, eta_shadow_price_t_per_h=shadow)

    @staticmethod
    def _no_nlp_plan(call: _Call) -> str:
        """Why the NLP gave no verified plan: its first solve's verdict, and where the verified start broke its bands."""
        first = call.first_solve or "not run"
        why = "its plan failed verification" if first.startswith("rejected") else f"its first solve: {first}"
        inside = call.start_in_bands
        if inside and inside["samples"]:
            why += (
                f"; the verified start lies inside the NLP's bands at {inside['samples']} samples "
                f"({inside['below_rules_threshold']} below the rules' Hs threshold, {inside['back_off_only']} in the "
                f"edges' back-off, {inside['inside_rules_band']} inside the rules' band as the NLP evaluates it)"
            )
        return why

    @staticmethod
    def _finish(call: _Call, stats: dict[str, Any]) -> None:
        """The plan stage's time recorded (``stage_time_s``, ``stage_cpu_s``) and the solve's total wall time."""
        call.begin(None)
        stats["total_time_s"] = _time.perf_counter() - call.started

    def _no_plan(self, call: _Call) -> None:
        """Neither the NLP nor any start gives a verified plan: :class:`SolverFailure` with Ipopt's status."""
        status = call.last.res.status if call.last is not None else "unknown"
        listed = "; ".join(str(v) for v in call.last_violations[:6])
        raise SolverFailure(
            f"no plan passing verification after {call.retries} tightened re-solves (Ipopt: {status}); last "
            f"violations: {listed or 'none (Ipopt failed)'}; no start candidate verifies either; try more "
            "samples_per_leg, shorter max_leg_nm or a wider band_margin",
            status=status,
            best_plan=route_plan(call.route, call.ctx, self.verify_step_nm),
        )

    def _status(self, sol: Solved, call: _Call) -> tuple[str, str | None]:
        """The returned NLP plan's status and why it is not ``"optimal"`` (None when it is)."""
        res = sol.res
        converged = res.status == "Solve_Succeeded"
        if converged and sol.mended_legs:
            return "mended", (
                "Ipopt converged; the referee found the engine outside its range between the NLP's samples, and the "
                f"speeds of {sol.mended_legs} legs were moved to the limit (optroute.optimise.starts.repaired_plan)"
            )
        if converged and sol.sides_settled:
            return "optimal", None
        if converged:
            return "sides_unsettled", f"the band-side search stopped on its budget of {self._budget(call)} solves"
        return "feasible", f"Ipopt stopped with {res.status}; its last iterate's plan passes verification"

    def _stats(
        self, call: _Call, cands: list[Candidate], start: Candidate, first: Candidate, nlp_score: float
    ) -> dict[str, Any]:
        """Every solve, every Ipopt iteration, time per stage, the starts and the power table of this solve."""
        prob = self.problem
        b0, s0, i0, t0 = call.counts0
        return {
            "ipopt_status": call.last.res.status if call.last is not None else "not run",
            "nlp_solves": prob.solves - s0,
            "dual_starts": prob.dual_starts - call.dual_starts0,
            "iterations": prob.iterations - i0,
            "build_time_s": prob.build_time_s - b0,
            "solve_time_s": prob.solve_time_s - t0,
            "jit": list(prob.compiled) if prob.jit else "off",
            "start": start.label,
            "start_score": start.score,
            "warm_start": first.label,
            "starts": call.starts.record(start, first) if call.starts is not None else {},
            "global_starts": call.starts.global_reason if call.starts is not None else "not run",
            "start_tabulation": call.start_table,
            "nlp_score": nlp_score,
            "stage_time_s": call.stage_s,
            "stage_cpu_s": call.stage_cpu_s,
            "retries": call.retries,
            "first_solve": call.first_solve or "not run",
            "verified_start_in_nlp_bands": call.start_in_bands,
            "start_edges_moved": call.edges_through,
            "constraint_rows": self.constraint_rows,
            "row_samples_per_leg": call.last.nlp.samples_per_leg if call.last is not None else None,
            "row_legs": self._row_legs(call),
            "tightening": list(call.log),
            "power_table": self._table_stats(),
            "n_legs": self.frame.n_legs,
            "samples_per_leg": call.samples_per_leg,
            "weather_grid_shape": list(np.shape(self.grid.hs_m)),
            "weather_nodes_filled": self.samples.filled,
            "prepared_horizon_h": self.horizon_h,
        }

    @staticmethod
    def _row_legs(call: _Call) -> dict[str, int] | None:
        """The last solve's NLP: its rows, and the legs that carry band rows and exclusion rows (the others carry only
        the dynamics, load and current rows: :func:`optroute.optimise.rows.nlp_row_legs`)."""
        if call.last is None:
            return None
        nlp = call.last.nlp
        return {"rows": nlp.n_rows, "legs": nlp.n_legs, "band": int(np.sum(nlp.row_legs.band_legs) if nlp.n_bands else 0),
                "exclusion": int(np.sum(nlp.row_legs.exclusion_legs) if nlp.exclusion is not None else 0)}  # fmt: skip

    @property
    def fixed_path(self) -> bool:
        """Whether the corridor has no lateral freedom (every waypoint's bounds at the centreline)."""
        return bool(np.all(self.y_lo == 0.0) and np.all(self.y_hi == 0.0))

    def _usable_iterate(self, sol: Solved, ctx: PlanContext) -> bool:
        return feasible_iterate(sol.res, ctx, self.frame, self.departure, self.verify_step_nm)
