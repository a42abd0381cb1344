"""The solves behind :func:`optroute.optimise_corridor`: problem state, band outer loop, warm starts, certificate.

* :class:`Problem` holds the domain → formulation adapters of one call (:mod:`optroute.optimise.nlp_inputs`)
  and builds and solves :class:`formulations.speed_nlp.SpeedNLP` with the disjunctive outer loop
  (:func:`formulations.disjunctive.improve_sides`), which tries only the side flips the Lagrangian
  estimate of each solve (:mod:`optroute.optimise.side_gains`) does not rule out; :class:`Tightening` is what the
  verification loop changes between solves.
* Warm starts: a search route's speeds (:func:`route_warm_start`), Boeing's speed reduction leg by
  leg with the true model (:func:`safe_warm_start`), moved clear of an exclusion circle
  (:func:`clear_of_exclusion`).
* :func:`certificate`: the global-optimality certificate of a fixed-path, static-weather solve.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from formulations.common import PowerModel
from formulations.disjunctive import InnerOutcome, improve_sides, nlp_band_solver, nlp_groups, select_sides
from formulations.speed_nlp import NLPResult, SpeedNLP
from optroute import units
from optroute.geo.tracks import Exclusion, gc_points, project_to_polyline
from optroute.optimise.nlp_inputs import CorridorFrame, formulation_bands, moving_exclusion
from optroute.optimise.rows import nlp_row_legs, sample_layout
from optroute.optimise.side_gains import LegCosts, flip_gains, flippable_groups, leg_costs, release_gains
from optroute.optimise.timed_no_go import NoPassageWindows
from optroute.physics.passage import best_speed
from optroute.physics.safety import BandRules
from optroute.physics.ship import Ship
from optroute.plan.evaluate import PlanContext, sample_sea
from optroute.search.route import Route
from optroute.units import NS_PER_H as _NS_PER_H

__all__ = [
    "Duals",
    "Problem",
    "Solved",
    "Tightening",
    "band_solver",
    "certificate",
    "clear_of_exclusion",
    "desired_speed",
    "edges_through",
    "route_warm_start",
    "safe_warm_start",
    "warm_rules",
]

VIOLATION_TOL = 1e-6  # largest scaled constraint violation accepted from Ipopt


# --------------------------------------------------------------------------- tightening state


@dataclass(frozen=True)
class Duals:
    """A solve's multipliers for the primal-dual warm start of a neighbouring solve (a front's next ETA).

    ``lam_x`` and ``lam_g`` are Ipopt's bound and row multipliers (:class:`formulations.speed_nlp.NLPResult`);
    ``key`` is :meth:`formulations.speed_nlp.SpeedNLP.dual_key` of the problem they belong to: they start
    only a problem with the same key (:meth:`Problem.solve`), others start from the primal point alone.
    """

    lam_x: np.ndarray
    lam_g: np.ndarray
    key: tuple[Any, ...]

    @classmethod
    def of(cls, res: NLPResult, nlp: SpeedNLP) -> Duals:
        return cls(np.asarray(res.lam_x, dtype=float), np.asarray(res.lam_g, dtype=float), nlp.dual_key())


@dataclass
class Tightening:
    """What the verification loop changes between solves."""

    max_load: float
    min_load: float
    widen: float  # band back-off [-]
    hs_margin: float  # applicability back-off [-]
    samples_per_leg: int
    extra_radius_nm: float = 0.0
    eta_shift_h: float = 0.0
    bound_scale: np.ndarray = field(default_factory=lambda: np.ones(0))
    y_lo: np.ndarray | None = None  # lateral bounds [nm, port +] moved off land met by the verification
    y_hi: np.ndarray | None = None  # (None: the prepared ones; see optroute.optimise.lateral.avoid_point)
    retries: int = 0
    log: list[str] = field(default_factory=list)
    # row-only samples per leg, fractions [-] of the referee's check points (optroute.optimise.rows); None: midpoints
    row_points: list[np.ndarray] | None = None
    # legs the referee rejected a plan on: they keep their band and exclusion rows (rows.nlp_row_legs); None: none
    forced_legs: np.ndarray | None = None


@dataclass
class Solved:
    """One solve with the band outer loop.

    ``n_solves`` and ``iterations`` count every Ipopt call of the outer loop and all their
    iterations; ``sides_settled`` is False when the side search stopped on its budget of solves;
    ``mended_legs`` counts the legs whose speed was moved after the solve to bring the engine back into
    its range where the referee found it out (:func:`optroute.optimise.starts.repaired_plan`).
    """

    res: NLPResult
    ok: bool
    n_solves: int
    flips: int
    history: list[float]
    nlp: SpeedNLP
    iterations: int = 0
    sides_settled: bool = True
    mended_legs: int = 0  # legs whose speed the referee's engine-range check moved (starts.repaired_plan)
    edges_through: int = 0  # (sample, band) pairs whose edge moved through the verified start (edges_through)


# --------------------------------------------------------------------------- the problem


class Problem:
    """The domain → formulation adapters of one call, and the solves."""

    def __init__(
        self,
        *,
        frame: CorridorFrame,
        grid: Any,
        samples: Any,
        power: PowerModel,
        ship: Ship,
        rules: BandRules,
        y_lo: np.ndarray,
        y_hi: np.ndarray,
        v_min: float,
        v_max: float,
        exclusion: Exclusion | None,
        departure: np.datetime64,
        solver_options: Mapping[str, Any] | None,
        jit: bool = False,
        windows: NoPassageWindows | None = None,
    ) -> None:
        self.frame, self.grid, self.samples, self.power = frame, grid, samples, power
        self.windows = windows  # a moving no-go area's time windows (optroute.optimise.timed_no_go), or None
        self.jit = bool(jit)
        #: with jit, how the last build's leg functions were compiled, or why they stay interpreted
        self.compiled: tuple[str, ...] = ()
        self.ship, self.rules = ship, rules
        self.y_lo, self.y_hi = y_lo, y_hi
        self.v_min, self.v_max = v_min, v_max
        self.exclusion, self.departure = exclusion, departure
        self.solver_options = dict(solver_options or {})
        self.build_time_s = 0.0
        self.builds = 0
        self.solves = 0  # every Ipopt call of every solve (outer loop included)
        self.iterations = 0  # and all their iterations
        self.solve_time_s = 0.0  # and all their Ipopt time [s]
        self.dual_starts = 0  # solves started from a given solution's multipliers too (Duals)
        self._cache: dict[tuple[Any, ...], tuple[SpeedNLP, tuple[str, ...]]] = {}

    trial_max_iter = 150

    def _count(self, res: NLPResult | Any) -> None:
        """Count one Ipopt call: its iterations and its wall-clock time [s] (every solve, the side flips' too)."""
        self.solves += 1
        self.iterations += int(res.iterations)
        self.solve_time_s += float(res.solve_time_s)

    def count(self, res: Any) -> None:
        """Count one Ipopt call of another problem made for this one (the elastic phase-1 problem,
        :mod:`optroute.optimise.phase1`): ``res`` has ``iterations`` and ``solve_time_s``."""
        self._count(res)

    def absorb_counts(self, other: Problem) -> None:
        """Add the builds and solves of ``other`` (a problem made for this one, e.g. on a longer grid) to these."""
        if other is self:
            return
        self.builds += other.builds
        self.build_time_s += other.build_time_s
        self.solves += other.solves
        self.iterations += other.iterations
        self.solve_time_s += other.solve_time_s

    def take_counts(self, other: Problem) -> None:
        """These builds, solves and their totals set to ``other``'s: one problem's running record handed to the one
        that stands in for it (:meth:`optroute.optimise.corridor_problem.PreparedCorridor.solve` on legs cut for
        one call, and back)."""
        self.builds, self.build_time_s, self.dual_starts = other.builds, other.build_time_s, other.dual_starts
        self.solves, self.iterations, self.solve_time_s = other.solves, other.iterations, other.solve_time_s

    def add_counts(self, other: Problem, before: tuple[float, int, int, float]) -> None:
        """Add what ``other`` (a problem made for this one: the minimum-time twin's) built and solved since ``before``,
        its (build time [s], solves, iterations, Ipopt time [s]) then."""
        self.build_time_s += other.build_time_s - before[0]
        self.solves += other.solves - before[1]
        self.iterations += other.iterations - before[2]
        self.solve_time_s += other.solve_time_s - before[3]

    def bounds(self, st: Tightening) -> tuple[np.ndarray, np.ndarray]:
        """Lateral bounds [nm]: the tightening's (moved off land) or the prepared ones, shrunk about their middle."""
        lo = self.y_lo if st.y_lo is None else st.y_lo
        hi = self.y_hi if st.y_hi is None else st.y_hi
        mid = 0.5 * (lo + hi)
        return mid + (lo - mid) * st.bound_scale, mid + (hi - mid) * st.bound_scale

    cache_size = 8  # built NLPs kept (a 300-leg build holds some tens of MB)

    def _key(self, st: Tightening, max_iter: int | None) -> tuple[Any, ...]:
        """What shapes a build: the tightening but its load limits (solve-time data)."""
        return (
            float(st.widen),
            float(st.hs_margin),
            int(st.samples_per_leg),
            float(st.extra_radius_nm),
            np.asarray(st.bound_scale, dtype=float).tobytes(),
            max_iter,
            *(b.tobytes() if b is not None else None for b in (st.y_lo, st.y_hi)),
            None if st.row_points is None else b"|".join(np.asarray(p, dtype=float).tobytes() for p in st.row_points),
            None if st.forced_legs is None else np.asarray(st.forced_legs, dtype=bool).tobytes(),
        )

    def build(self, st: Tightening, *, max_iter: int | None = None) -> SpeedNLP:
        """The NLP of a tightening state: cached by :meth:`_key`, its load limits set from ``st``.

        The load limits enter :meth:`SpeedNLP.solve` only as the bounds of its load rows (read from
        ``nlp.power`` at each solve), so one build serves states that differ in them alone: the
        verification loop's load tightening costs a solve, not a build.
        """
        self._last_state = st
        power = replace(self.power, max_load=st.max_load, min_load=st.min_load)
        key = self._key(st, max_iter)
        hit = self._cache.pop(key, None)
        if hit is not None:
            self._cache[key] = hit  # most recently used last
            nlp, self.band_names = hit
            nlp.power = power
            return nlp
        nlp = self._build(st, max_iter=max_iter)
        self._cache[key] = (nlp, self.band_names)
        while len(self._cache) > self.cache_size:
            self._cache.pop(next(iter(self._cache)))
        return nlp

    def _build(self, st: Tightening, *, max_iter: int | None = None) -> SpeedNLP:
        started = _time.perf_counter()
        self.builds += 1
        options = dict(self.solver_options)
        if max_iter is not None:
            options["ipopt.max_iter"] = min(int(max_iter), int(options.get("ipopt.max_iter", max_iter)))
        bands, names, a = formulation_bands(self.ship, self.rules, widen=st.widen, hs_margin=st.hs_margin)
        hs_top = float(np.max(self.grid.hs_m))
        # a band applies only where Hs >= its threshold: leave out those the weather never reaches
        keep = [i for i, b in enumerate(bands) if hs_top >= b.hs_min_m]
        bands, self.band_names = tuple(bands[i] for i in keep), tuple(names[i] for i in keep)
        geom = self.frame.geometry(*self.bounds(st))
        power = replace(self.power, max_load=st.max_load, min_load=st.min_load)
        excl = None
        if self.exclusion is not None:
            excl = moving_exclusion(self.exclusion, self.frame, self.departure, extra_radius_nm=st.extra_radius_nm)
        band_legs, excl_legs = nlp_row_legs(self.frame, self.grid.s_nm, self.grid.hs_m, bands, excl, st.forced_legs)
        nlp = SpeedNLP(
            geom,
            self.grid,
            power,
            bands=bands,
            exclusion=excl,
            sample_layout=sample_layout(st.row_points, self.frame.n_legs, st.samples_per_leg),
            band_legs=band_legs,
            exclusion_legs=excl_legs,
            v_min_kn=self.v_min,
            v_max_kn=self.v_max,
            g_over_2pi_kn_s=a,
            ipopt_options=options,
            jit=self.jit,
            # the ship's power table is a field with real curvature in time and across track (a storm's edge):
            # with its second derivatives in the Hessian Ipopt converges in a fraction of the iterations
            # (storm crossing of benchmarks.bench_nlp: 27 against 74, and from the 3-D DP's start 47 against
            # more than 500)
            exact_hessian=True,
        )
        self.compiled = nlp.compiled_functions or self.compiled  # jit: how its leg functions were compiled
        self.build_time_s += _time.perf_counter() - started
        return nlp

    def solve(
        self,
        nlp: SpeedNLP,
        *,
        eta_h: float | None,
        eta_mode: str,
        objective: str,
        fuel_price: float,
        hourly_cost: float,
        warm: Mapping[str, Any] | None,
        budget: int,
        through_start: bool = False,
    ) -> Solved:
        """One solve with the band outer loop (side selection from the warm start, flips, applicability).

        ``through_start``: the warm start is a plan the referee passed; where it lies inside the NLP's bands (its
        smoothed sea and conservative rules, :func:`~optroute.optimise.rescue.start_in_nlp_bands`) those samples'
        edges move to the start's own ratio (:func:`edges_through`), so that the NLP starts inside its feasible set
        and can only move those samples away from the band.
        """
        n = nlp.n_legs
        kwargs: dict[str, Any] = {
            "eta_h": eta_h,
            "eta_mode": eta_mode,
            "objective": objective,
            "fuel_price": fuel_price,
            "hourly_cost": hourly_cost,
        }
        if warm is not None:
            y0, v0 = warm_point(nlp, warm)
        else:
            y0 = np.clip(np.zeros(n + 1), *nlp.corridor.offset_bounds())
            total = float(self.frame.s_nm[-1])
            guess = total / eta_h if eta_h is not None else 0.9 * self.v_max
            v0 = np.clip(np.full(n, guess), nlp.v_min_kn, nlp.v_max_kn)
        t0 = nlp.consistent_times(y0, v0)
        kwargs.update(offset0_nm=y0, stw0_kn=v0, time0_h=t0)
        if self.windows is not None and self.windows.legs.size:  # each leg passed on the warm start's side
            kwargs["time_lo_h"], kwargs["time_hi_h"] = self.windows.time_bounds(self.windows.sides(t0))
        duals = warm.get("duals") if warm is not None else None
        if duals is not None and duals.key == nlp.dual_key():  # a neighbour's multipliers on the same rows
            kwargs.update(lam_x0=duals.lam_x, lam_g0=duals.lam_g)
            self.dual_starts += 1
        if nlp.n_bands == 0:
            res = nlp.solve(**kwargs)
            ok = bool(res.success and res.max_violation <= VIOLATION_TOL)
            self._count(res)
            return Solved(res, ok, 1, 0, [res.objective] if ok else [], nlp, iterations=int(res.iterations))
        state = nlp.evaluate(y0, v0, t0)
        edges = edges_through(nlp, state) if through_start else None
        moved = 0
        if edges is not None:
            moved = int(np.sum(state.inside))
            nlp = nlp.with_edges(*edges)
            state = nlp.evaluate(y0, v0, t0)
        sides, applies = nlp.default_sides(state)
        shape = sides.shape
        flippable = flippable_groups(nlp, state, y0, t0)
        trial_nlp: list[SpeedNLP] = []

        def trial() -> SpeedNLP:
            if not trial_nlp:  # flip trials: an iteration cap, so that hopeless flips fail fast
                built = self.build(self._last_state, max_iter=self.trial_max_iter)
                trial_nlp.append(built if edges is None else built.with_edges(*edges))
            return trial_nlp[0]

        inner = band_solver(nlp, trial, kwargs)
        iterations = [0]

        def counted(s: np.ndarray, a: np.ndarray) -> InnerOutcome:
            out = inner(s, a)
            iterations[0] += int(out.payload.iterations)  # every solve's iterations, not only the best one's
            self._count(out.payload)
            return out

        out = improve_sides(counted, sides, applies, flippable=flippable, groups=nlp_groups(shape), max_solves=budget)
        res = out.outcome.payload
        return Solved(
            res,
            bool(out.feasible),
            out.n_solves,
            max(0, len(out.history) - 1),
            list(out.history),
            nlp,
            iterations=iterations[0],
            sides_settled=out.finished,
            edges_through=moved,
        )


def edges_through(nlp: SpeedNLP, state: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """Band edges (lower, upper), (N, m, B) each, through a start's samples that lie inside the NLP's bands; None
    where none does.

    At such a sample (``state.inside``: the band applies and the ratio is strictly inside it, as the NLP evaluates
    the start) the nearer edge (:func:`formulations.disjunctive.select_sides`) moves to the start's ratio; every
    other sample keeps the NLP's own edges. The NLP then holds that sample at least as far from the band as the
    start, in its own sea.
    """
    if not nlp.n_bands or not state.inside.any():
        return None
    lower, upper = nlp.sample_edges()
    side = select_sides(state.ratio, lower, upper)
    lo = np.where(state.inside & (side < 0), state.ratio, lower)
    hi = np.where(state.inside & (side > 0), state.ratio, upper)
    return lo, hi


def warm_point(nlp: SpeedNLP, warm: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """A warm start's offsets (N+1,) [nm] and leg speeds (N,) [kn] within ``nlp``'s bounds: the point its solve starts
    from (with :meth:`SpeedNLP.consistent_times` for the times)."""
    y0 = np.clip(warm["offset_nm"], *nlp.corridor.offset_bounds())
    v0 = np.clip(warm["stw_kn"], nlp.v_min_kn, nlp.v_max_kn)
    return y0, v0


def band_solver(nlp: SpeedNLP, trial: Callable[[], SpeedNLP], kwargs: dict[str, Any]) -> Callable[..., InnerOutcome]:
    """Inner solver of the band outer loop: :func:`formulations.disjunctive.nlp_band_solver`.

    The first solve uses the full NLP; the later ones (side flips, applicability re-checks) an
    instance with an iteration cap. Every solve is warm-started from the best valid solution so far, and
    estimates the change of each side flip and release from its solution (:func:`~optroute.optimise.side_gains.
    flip_gains`, :func:`~optroute.optimise.side_gains.release_gains`) for the side search, on the solutions the
    search keeps only.
    """
    prices = {k: kwargs[k] for k in ("objective", "fuel_price", "hourly_cost")}
    made: list[tuple[NLPResult, LegCosts | None]] = []  # the last solve's cost table, shared by both estimates

    def costs(res: NLPResult) -> LegCosts | None:
        if not made or made[0][0] is not res:
            made[:] = [(res, leg_costs(nlp, res, **prices))]
        return made[0][1]

    def gains(res: NLPResult) -> np.ndarray | None:
        return flip_gains(nlp, res, **prices, costs=costs(res))

    def releases(res: NLPResult, take: np.ndarray) -> np.ndarray | None:
        return release_gains(nlp, res, take, costs(res))

    return nlp_band_solver(nlp, violation_tol=VIOLATION_TOL, later=trial, gains=gains, release_gains=releases, **kwargs)


def route_warm_start(route: Route, frame: CorridorFrame) -> dict[str, np.ndarray]:
    """Leg speeds of a search route on the corridor's legs (by along-track position), centreline offsets."""
    wp = frame.corridor.waypoints
    mid_lat = 0.5 * (wp[:-1, 0] + wp[1:, 0])
    mid_lon = units.wrap_180(wp[:-1, 1] + 0.5 * units.wrap_180(wp[1:, 1] - wp[:-1, 1]))
    _, _, _, k = project_to_polyline(route.waypoints, mid_lat, mid_lon)
    stw = np.asarray(route.stw_kn, dtype=float)
    sog = np.asarray(route.sog_kn, dtype=float)
    speed = np.where(np.isfinite(stw) & (stw > 0), stw, sog)[k]
    fallback = route.total_distance_nm / route.total_duration_h
    speed = np.where(np.isfinite(speed) & (speed > 0), speed, fallback)
    return {"offset_nm": np.zeros(frame.n_legs + 1), "stw_kn": speed}


def safe_warm_start(
    ctx: PlanContext,
    frame: CorridorFrame,
    t0: np.datetime64,
    desired_kn: float,
    v_min: float,
    m: int = 3,
    rules: BandRules | None = None,
) -> dict[str, np.ndarray]:
    """Centreline warm start at speeds the true model allows: Boeing's speed reduction leg by leg.

    At ``m`` points of every centreline leg, at the time a ship sailing the desired speed is there,
    :func:`optroute.physics.passage.best_speed` gives the fastest allowed speed at or below ``desired_kn``
    (outside every band, within the power limits); the leg takes the slowest of its points (``v_min``
    where none is allowed). The band sides the NLP starts on are then sides a ship can actually keep.
    ``rules`` (default the context's) may be the NLP's backed-off rules (:func:`warm_rules`).
    """
    ctx_rules = ctx.rules if rules is None else rules
    wp = frame.corridor.waypoints
    n = frame.n_legs
    frac = (np.arange(m) + 0.5) / m
    leg = np.repeat(np.arange(n), m)
    f = np.tile(frac, n)
    lat, lon, course = gc_points(wp[leg, 0], wp[leg, 1], wp[leg + 1, 0], wp[leg + 1, 1], f)
    d = np.diff(frame.s_nm)
    speed = np.full(n, float(desired_kn))
    for _ in range(2):
        t_leg = np.concatenate([[0.0], np.cumsum(d / speed)])
        t_h = t_leg[leg] + f * (d / speed)[leg]
        when = t0 + (t_h * _NS_PER_H).astype("timedelta64[ns]")
        sea, covered = sample_sea(ctx.sampler, when, lat, lon)
        choice = best_speed(
            ctx.ship, ctx.model, ctx_rules, course, sea, float(desired_kn), step_kn=0.25, min_stw_kn=v_min
        )
        v = np.where(choice.feasible & covered, choice.stw_kn, v_min)
        speed = np.maximum(np.min(v.reshape(n, m), axis=1), v_min)
    return {"offset_nm": np.zeros(n + 1), "stw_kn": speed}


def clear_of_exclusion(
    warm: dict[str, np.ndarray],
    frame: CorridorFrame,
    exclusion: Exclusion | None,
    t0: np.datetime64,
    y_lo: np.ndarray,
    y_hi: np.ndarray,
) -> dict[str, np.ndarray]:
    """Move warm-start waypoints that the exclusion circle covers out of it, behind the moving circle.

    The exclusion constraint is non-convex: started at the circle's centre, Ipopt has no direction to
    leave by. A waypoint within 1.5 radii of the centre at the time the warm start passes it is moved
    across the corridor to 1.3 radii from the centre, all on one side: the side the circle comes from
    (passing behind it) when it moves across the corridor, else the side away from its centre.
    """
    if exclusion is None:
        return warm
    d = np.diff(frame.s_nm)
    t_h = np.concatenate([[0.0], np.cumsum(d / np.asarray(warm["stw_kn"], dtype=float))])
    when = t0 + (t_h * _NS_PER_H).astype("timedelta64[ns]")
    clat, clon, rad = exclusion.at(when)
    later = exclusion.at(when + np.timedelta64(1, "h"))
    s_c, xt_c, _, _ = project_to_polyline(frame.corridor.waypoints, clat, clon)
    _, xt_next, _, _ = project_to_polyline(frame.corridor.waypoints, later[0], later[1])
    y_c, motion = -xt_c, -(xt_next - xt_c)  # port-positive offset of the centre and its lateral motion [nm/h]
    y = np.asarray(warm["offset_nm"], dtype=float).copy()
    gap = frame.s_nm - s_c
    near = np.hypot(gap, y - y_c) < 1.5 * rad
    if not near.any():
        return warm
    # one side for the whole encounter: behind the circle (against its lateral motion), else away from it
    drift = float(np.mean(motion[near]))
    offset = float(np.mean(y_c[near]))
    ship_side = -np.sign(drift) if abs(drift) > 1e-3 else (-np.sign(offset) if abs(offset) > 1e-6 else -1.0)
    reach = np.sqrt(np.maximum((1.3 * rad) ** 2 - gap**2, 0.0))
    y = np.where(near, y_c + ship_side * reach, y)
    return {**warm, "offset_nm": np.clip(y, y_lo, y_hi)}


def desired_speed(length_nm: float, eta_h: float | None, v_max: float, objective: str) -> float:
    """Speed of a warm start [kn]: the ETA's mean speed, the top speed for minimum time, else 3/4 of it."""
    if eta_h:
        return min(v_max, length_nm / eta_h)
    return v_max if objective == "time" else 0.75 * v_max


def warm_rules(rules: BandRules, st: Tightening) -> BandRules:
    """The rules with about the NLP's back-offs: lower applicability threshold, wider bands."""
    margin = min(0.95, rules.margin * (1.0 + st.widen) + st.widen)
    return replace(rules, hs_threshold_fraction=rules.hs_threshold_fraction * (1.0 - st.hs_margin), margin=margin)


# --------------------------------------------------------------------------- certificate


def _leg_rates(nlp: SpeedNLP, res: NLPResult, v: np.ndarray) -> np.ndarray:
    """Mean fuel rate [t/h] of every leg at per-leg speeds ``v`` (N,) [kn]: the NLP's own power at its samples."""
    n = nlp.n_legs
    ev = nlp._eval(nlp._pack(res.offset_nm, np.asarray(v, dtype=float), res.time_h), ("rate",))
    # the quadrature's weights (row-only samples weigh 0; the midpoint rule 1/m each)
    return np.sum(np.reshape(ev["rate"], (n, nlp.samples_per_leg)) * nlp.sample_layout.weight, axis=1)


def _leg_powers(nlp: SpeedNLP, res: NLPResult, v: np.ndarray) -> np.ndarray:
    ev = nlp._eval(nlp._pack(res.offset_nm, np.asarray(v, dtype=float), res.time_h), ("power",))
    return np.reshape(ev["power"], (nlp.n_legs, nlp.samples_per_leg))


def certificate(
    nlp: SpeedNLP,
    res: NLPResult,
    *,
    objective: str,
    eta_h: float | None,
    eta_mode: str,
    fuel_price: float,
    hourly_cost: float,
) -> dict[str, Any]:
    """Lagrangian dual bound of a fixed-path, static-weather solve without bands, on the NLP's own model.

    On a fixed path in static weather the legs couple only through ``Σ t ≤ T``; weak duality at the
    NLP's ETA multiplier λ gives ``q(λ) = Σ_i min_t (F_i(t) + λ t) − λ T ≤ optimum``, each leg's
    one-dimensional minimum taken over its speed interval (the load limits, by bisection) on a
    dense grid of speeds refined by golden-section search around the best node. The model is the
    NLP's (the tabulated ship model), evaluated at the solution's samples; the bound certifies the
    NLP's optimum of that model (the tabulation error is reported beside it).
    """
    pw: PowerModel = nlp.power
    d = res.distance_nm
    n = d.size
    w_f, w_t = (1.0, 0.0) if objective == "fuel" else (float(fuel_price), float(hourly_cost))
    lo, hi = nlp.v_min_kn.copy(), nlp.v_max_kn.copy()
    # load limits per sample → speed interval per leg (power increases with speed): bisection
    a, b = lo.copy(), hi.copy()
    for _ in range(60):
        mid = 0.5 * (a + b)
        over = np.max(_leg_powers(nlp, res, mid), axis=1) / pw.mcr_kw > pw.max_load
        b, a = np.where(over, mid, b), np.where(over, a, mid)
    top = np.max(_leg_powers(nlp, res, hi), axis=1) / pw.mcr_kw <= pw.max_load
    hi = np.where(top, hi, a)
    a, b = lo.copy(), hi.copy()
    for _ in range(60):
        mid = 0.5 * (a + b)
        under = np.min(_leg_powers(nlp, res, mid), axis=1) / pw.mcr_kw < pw.min_load
        a, b = np.where(under, mid, a), np.where(under, b, mid)
    bottom = np.min(_leg_powers(nlp, res, lo), axis=1) / pw.mcr_kw >= pw.min_load
    lo = np.where(bottom, lo, b)
    lam = float(res.eta_multiplier) if eta_h is not None else 0.0

    def cost(v: np.ndarray) -> np.ndarray:
        t = d / v
        return w_f * t * _leg_rates(nlp, res, v) + (w_t + lam) * t

    grid = np.linspace(0.0, 1.0, 65)
    vals = np.array([cost(lo + f * (hi - lo)) for f in grid])  # (65, N)
    best = np.argmin(vals, axis=0)
    step = (hi - lo) / 64.0
    a = np.maximum(lo, lo + (best - 1) * step)
    b = np.minimum(hi, lo + (best + 1) * step)
    g = (np.sqrt(5.0) - 1.0) / 2.0
    c_, d_ = b - g * (b - a), a + g * (b - a)
    fc, fd = cost(c_), cost(d_)
    for _ in range(60):
        left = fc < fd
        b = np.where(left, d_, b)
        a = np.where(left, a, c_)
        c_, d_ = b - g * (b - a), a + g * (b - a)
        fc, fd = cost(c_), cost(d_)
    leg_min = np.minimum(np.min(vals, axis=0), np.minimum(fc, fd))
    bound = float(np.sum(leg_min)) - (lam * eta_h if eta_h is not None else 0.0)
    gap = (res.objective - bound) / max(abs(res.objective), 1e-12)
    return {"method": "Lagrangian dual bound", "lambda": lam, "bound": bound, "gap": float(gap), "legs": n}
