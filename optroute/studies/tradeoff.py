"""The fuel-versus-ETA front: :func:`tradeoff`.

How much fuel does each extra hour of passage save, and where is the knee?
:func:`tradeoff` answers on one corridor by solving the corridor NLP
(:func:`optroute.optimise_corridor`) for a sequence of ETAs, each solve
warm-started from its neighbour's solution, and returns the front as a
:class:`TradeoffFront` — an :class:`xarray.Dataset` with dimension ``eta``
whose :meth:`TradeoffFront.plot` draws it.

The range of the default front
------------------------------
From the **earliest feasible arrival** — the minimum-time solve
(``optimise_corridor(objective="time")``), whose plan is the front's first
point: at that ETA it is the only feasible plan — to the **slow-steaming
limit** — the least-fuel solve without an ETA, whose plan is the last point.
Fuel per mile falls as the ship slows (power grows about as the cube of the
speed), so that solve slows down until something stops it: the engine's
minimum continuous load (``model.min_power_kw``), the lowest speed through
the water (``speed_range_kn``, default 3 kn), or the end of the weather's time
span, whichever comes first.  ETAs later than that save no fuel.  The ``n``
points are spaced evenly in ETA between the two.

Given ``etas`` (datetimes, or hours after departure) the same two solves are
made first (for the warm starts and to classify the ETAs): an ETA before the
earliest arrival is reported as ``"infeasible: earliest arrival …"`` without
a solve, one at the earliest arrival or at or after the slow-steaming limit
(for the fuel objective) takes that solve's plan, and an ETA that cannot be
solved (past the weather, Ipopt failing) gets its reason as its status.  No
ETA is ever dropped.

The continuation
----------------
The ETAs between the two ends are swept from the slow-steaming end, where the problem is
easiest (loads far from the engine's limits), towards the fast one: each point's
:meth:`~optroute.optimise.corridor_problem.PreparedCorridor.solve` starts from its later
neighbour's plan sped up to arrive by its own ETA (speeds through the water times
``arrival / ETA``), which the optimiser takes as Ipopt's start when the referee accepts it (the
optimiser's own start otherwise).  One solve per point; only a point whose solve failed is
solved once more, from the optimiser's own start (``attrs["monotonicity_resolves"]``).  The
primal solution only: the optimiser's public interface (``warm_plan``) carries no multipliers.

Monotonicity
------------
Arriving by an ETA is allowed to arrive earlier (``eta_mode="le"``), so with the fuel objective
the true front never rises with a later ETA.  A point whose own solve ends above the fuel of an
earlier ETA's point (relative tolerance ``monotone_rtol``; the NLP is a local search on a model
that is only piecewise smooth) takes that earlier point's verified plan, which arrives by its ETA
too; its own solve's fuel stays beside it (``own_fuel_t``), its status says so (``"optimal; the
plan of the earlier ETA …"``), and the number of such points is ``front.risen_points``
(``attrs["risen_points"]``).  Nothing is solved again for it.  With ``objective="cost"`` (fuel
and time both priced) a later ETA may legitimately cost more fuel, so no point is replaced.

Chains, workers and determinism
-------------------------------
The ETAs between the ends are cut into ``chains`` contiguous chains (default 4), by ETA alone:
serial, the chains run one after the other; with ``n_workers >= 2`` (a
:class:`distributed.LocalCluster` on the loopback interface, for this call) or
``scheduler_address=`` (an existing Dask cluster: the address its ``dask scheduler`` printed,
e.g. ``"tcp://10.0.0.5:8786"``; the workers need optroute installed) the two end solves run side
by side and each chain is one Dask task, its points streamed back as it finishes.  Every chain
starts from the slow-steaming plan whatever ran it, and Ipopt's BLAS runs one thread in every
process (:mod:`optroute.studies.threads`), so the front is the same to the last bit serial, on
a cluster and run to run (``runtime_s`` aside).

Set-up once per process
-----------------------
The points between the ends are solved on one
:class:`~optroute.optimise.corridor_problem.PreparedCorridor` per process (this one when serial,
each Dask worker's), prepared for the latest of them: the weather grid with the ship's power
table, lateral bounds and the CasADi build are made once.  It is kept in the process, keyed by
the fingerprint of the front's inputs (:mod:`optroute.studies.fingerprint`) and that ETA, for
the next chain and the next front of the same inputs (the two most recent are kept).  Each point
starts from the untightened problem, as :func:`optroute.optimise_corridor` would, so a point does
not depend on what was solved before it in the process.
"""

from __future__ import annotations

import math
import numbers
import os
import tempfile
import threading
import time as _time
import uuid
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from optroute.errors import (
    ConfigError,
    InfeasibleETA,
    SolverFailure,
    WeatherCoverageError,
)
from optroute.optimise.api import optimise_corridor
from optroute.optimise.corridor_problem import PreparedCorridor
from optroute.physics.ship import Ship
from optroute.plan.result import Plan
from optroute.plot.front import knee_index
from optroute.search.route import Corridor
from optroute.studies import fingerprint
from optroute.studies.threads import pin_solver_threads
from optroute.units import as_utc_time, format_utc, h_to_timedelta, timedelta_to_h
from optroute.weather.sample import WeatherSampler

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["TradeoffFront", "tradeoff"]

#: ``progress(points done, points in the front)``.
FrontProgress = Callable[[int, int], None]

LEG_VARIABLES = ("sog_kn", "stw_kn", "heading_deg", "distance_nm", "duration_h", "power_kw", "fuel_t", "hs_m")
_FORBIDDEN = ("eta", "eta_mode", "objective", "warm_plan", "route", "departure", "progress")
_SAME_ETA_H = 1e-6  # ETAs this close to an end solve's arrival [h] take that solve's plan


class TradeoffFront(xr.Dataset):
    """A fuel-versus-ETA front: an :class:`xarray.Dataset` that plots itself.

    A thin subclass (no state of its own, ``__slots__ = ()``) chosen over an
    accessor so that ``front.plot()`` returns the figure directly, as
    :meth:`optroute.Plan.plot` does.  xarray operations that build new
    datasets may return a plain :class:`xarray.Dataset`; a front read back
    from NetCDF is one too — wrap either with :meth:`from_dataset`, or call
    :func:`optroute.plot.front.front_figure` on it.  See :func:`tradeoff` for
    the variables.
    """

    __slots__ = ()

    @classmethod
    def from_dataset(cls, ds: xr.Dataset) -> TradeoffFront:
        """Wrap a dataset holding a front (e.g. ``xr.open_dataset("front.nc")``), sharing its data."""
        if not isinstance(ds, xr.Dataset):
            raise ConfigError(f"TradeoffFront.from_dataset takes an xarray.Dataset, got {type(ds).__name__}")
        out = cls(data_vars=ds.data_vars, coords=ds.coords, attrs=ds.attrs)
        return out

    @property
    def risen_points(self) -> int:
        """Points whose own solve ended above an earlier ETA's fuel and which took that ETA's plan (target 0)."""
        return int(self.attrs.get("risen_points", 0))

    def plot(self, *, title: str | None = None) -> Figure:  # type: ignore[override]
        """Fuel [t] against ETA [h after departure], the knee and the ETA shadow price marked.

        Returns
        -------
        matplotlib.figure.Figure
            See :func:`optroute.plot.front.front_figure`.
        """
        from optroute.plot.front import front_figure  # matplotlib only when a figure is drawn

        return front_figure(self, title=title)

    def to_netcdf(self, path: Any = None, **kwargs: Any) -> Any:  # type: ignore[override]
        """As :meth:`xarray.Dataset.to_netcdf`; a file is written atomically (temporary name, then rename)."""
        if path is None or not isinstance(path, str | os.PathLike):
            return super().to_netcdf(path, **kwargs)
        target = Path(path)
        folder = target.parent if str(target.parent) else Path(".")
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
        os.close(fd)
        try:
            super().to_netcdf(tmp, **kwargs)
            os.replace(tmp, target)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        return None


# --------------------------------------------------------------------------- one point (runs on a worker)


@dataclass(frozen=True)
class _Warm:
    """What :func:`optroute.optimise_corridor` reads of a ``warm_plan``."""

    waypoints: np.ndarray
    stw_kn: np.ndarray


@dataclass(frozen=True)
class _Spec:
    """Everything a solve needs but the ETA and the warm start; shipped once to every worker."""

    corridor: Corridor
    weather: xr.Dataset | WeatherSampler
    ship: Ship
    departure: np.datetime64
    objective: str
    kwargs: Mapping[str, Any]
    token: str = ""  # names this front's prepared corridor in a process's cache
    latest_eta_h: float | None = None  # the chains' latest ETA [h]: set once the end solves are known


@dataclass(frozen=True)
class _Point:
    eta_h: float  # NaN for the slow-steaming solve until its ETA is known
    kind: str  # "minimum_time" | "slow_steaming" | "eta"
    status: str
    runtime_s: float = 0.0
    iterations: int = 0
    totals: Mapping[str, float] = field(default_factory=dict)
    waypoints: np.ndarray | None = None
    times_h: np.ndarray | None = None
    legs: Mapping[str, np.ndarray] | None = None
    carry: _Warm | None = None  # the warm start for the next point of a chain
    nlp_solves: int = 0  # Ipopt calls of the point's solve (band outer loop and verification re-solves included)
    warm_start: str = ""  # the candidate Ipopt started from ("warm plan", "centreline start", ...)
    own_fuel_t: float | None = None  # a risen point's own solve's fuel [t] (its plan is an earlier ETA's)

    @property
    def ok(self) -> bool:
        return self.waypoints is not None

    @property
    def fuel_t(self) -> float:
        return float(self.totals.get("fuel_t", math.nan))


def _from_plan(plan: Plan, eta_h: float, kind: str, runtime_s: float) -> _Point:
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
    return _Point(
        eta_h=eta_h,
        kind=kind,
        status=plan.status,
        runtime_s=runtime_s,
        iterations=int(plan.solver_stats.get("iterations", 0)),
        nlp_solves=int(plan.solver_stats.get("nlp_solves", 0)),
        warm_start=str(plan.solver_stats.get("warm_start", "")),
        totals=totals,
        waypoints=wp,
        times_h=times_h,
        legs={k: legs[k].to_numpy(dtype=float) for k in LEG_VARIABLES if k in legs},
        carry=_Warm(wp, plan.stw_kn),
    )


def _solve_point(spec: _Spec, eta_h: float | None, kind: str, warm: _Point | _Warm | None, route: Any = None) -> _Point:
    """One solve; an unreachable ETA or a solver failure becomes the point's status, not an exception."""
    pin_solver_threads()  # one BLAS thread for Ipopt, in this process as on a Dask worker: the same rounding
    started = _time.perf_counter()
    carry = _retimed(warm, eta_h) if kind == "eta" else warm.carry if isinstance(warm, _Point) else warm
    objective = "time" if kind == "minimum_time" else spec.objective if kind == "eta" else "fuel"
    eta = None if eta_h is None else spec.departure + h_to_timedelta(eta_h)
    try:
        if kind == "eta" and spec.latest_eta_h is not None and eta_h is not None and eta_h <= spec.latest_eta_h:
            # the problem of optimise_corridor for this ETA from the same warm start; the untightened start (not
            # the neighbour's learnt tightening) keeps every point independent of the chain it was solved in
            prepared, lock = _prepared(spec)
            with lock:  # one solve at a time: its cached builds are set up per solve (a worker may have threads)
                plan = prepared.solve(eta, objective=objective, warm_plan=carry)  # type: ignore[arg-type]
        else:
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
    except InfeasibleETA as exc:
        if exc.earliest_arrival is not None:
            earliest = as_utc_time(exc.earliest_arrival, "earliest_arrival")
            status = (
                f"infeasible: earliest arrival {format_utc(earliest)} "
                f"({timedelta_to_h(earliest - spec.departure):.2f} h after departure)"
            )
        else:
            status = f"infeasible: {exc}"
        return _Point(math.nan if eta_h is None else eta_h, kind, status, _time.perf_counter() - started, carry=carry)
    except SolverFailure as exc:
        if kind == "minimum_time" and exc.best_plan is not None:
            # the minimum-time NLP failed: the front starts from the fastest verified plan known (the search
            # route's, or a safe start's), an upper bound on the earliest arrival, and its status says so
            best = exc.best_plan
            point = _from_plan(best, float(best.duration_h), kind, _time.perf_counter() - started)
            return _replace(
                point,
                status=f"feasible: fastest verified plan known ({best.status}); the minimum-time solve failed: "
                f"{_failure_text(exc)}",
            )
        return _Point(
            math.nan if eta_h is None else eta_h,
            kind,
            f"solver failure: {_failure_text(exc)}",
            _time.perf_counter() - started,
            carry=carry,
        )
    except WeatherCoverageError as exc:
        return _Point(
            math.nan if eta_h is None else eta_h,
            kind,
            f"infeasible: {exc}",
            _time.perf_counter() - started,
            carry=carry,
        )
    arrival_h = float(plan.duration_h)
    return _from_plan(plan, arrival_h if eta_h is None else eta_h, kind, _time.perf_counter() - started)


def _retimed(warm: _Point | _Warm | None, eta_h: float | None) -> _Warm | None:
    """A later ETA's plan sped up to arrive by ``eta_h``: the continuation's start from the slow side.

    The optimiser starts Ipopt from a warm plan only when the referee accepts that plan for the new
    ETA; a neighbour that arrives later never is.  Its speeds through the water scaled by
    ``arrival / eta_h`` (plus 1e-6) arrive by ``eta_h`` wherever the speed over ground is the speed
    through the water (no current); where the faster plan breaks the engine's limits or a danger
    band, the referee refuses it and the optimiser starts from its own candidates, as cold.
    """
    if not isinstance(warm, _Point):
        return warm
    carry = warm.carry
    arrival_h = warm.totals.get("duration_h", math.nan)
    if carry is None or eta_h is None or not math.isfinite(arrival_h) or arrival_h <= eta_h:
        return carry
    return _Warm(carry.waypoints, np.asarray(carry.stw_kn, dtype=float) * (arrival_h / eta_h * (1.0 + 1e-6)))


def _solve_chain(spec: _Spec, etas: Sequence[float], warm: _Point | None, cold: bool) -> list[_Point]:
    """One chain of ETAs, each point started from the one before (the chain's first from ``warm``)."""
    out = []
    for eta_h in etas:
        p = _solve_point(spec, eta_h, "eta", None if cold else warm)
        warm = p if p.ok else warm
        out.append(p)
    return out


#: Prepared corridors of this process (a Dask worker's too), by the inputs' fingerprint and latest ETA, least
#: recently used first: a worker keeps them between chains and between fronts of the same inputs (a study's).
_PREPARED: dict[tuple[str, float], tuple[PreparedCorridor, threading.Lock]] = {}
_PREPARED_KEEP = 2
_PREPARING = threading.Lock()


def _prepared(spec: _Spec) -> tuple[PreparedCorridor, threading.Lock]:
    """The front's corridor problem prepared once in this process for its latest ETA, and its solve lock."""
    latest = float(spec.latest_eta_h)  # type: ignore[arg-type]
    key = (spec.token, latest)
    with _PREPARING:
        hit = _PREPARED.pop(key, None)
        if hit is None:
            prepared = PreparedCorridor(
                spec.corridor,
                spec.weather,
                spec.ship,
                departure=spec.departure,
                latest_eta=spec.departure + h_to_timedelta(latest),
                objective=spec.objective,  # type: ignore[arg-type]
                **spec.kwargs,
            )
            hit = (prepared, threading.Lock())
        _PREPARED[key] = hit  # most recently used last
        while len(_PREPARED) > _PREPARED_KEEP:
            _PREPARED.pop(next(iter(_PREPARED)))
    return hit


def _token(corridor: Corridor, weather: Any, ship: Ship, t0: np.datetime64, objective: str, kwargs: Any) -> str:
    """The fingerprint of a front's inputs (:mod:`optroute.studies.fingerprint`): the key of its prepared corridor.

    Inputs without a canonical form (an object that does not pickle) get a fresh random key: their front
    prepares its corridor again rather than risk another front's.
    """
    try:
        return fingerprint.digest(("front", corridor, weather, ship, str(t0), objective, dict(kwargs)))
    except ConfigError:
        return uuid.uuid4().hex


def _failure_text(exc: SolverFailure) -> str:
    if exc.status in ("Solve_Succeeded", "Solved_To_Acceptable_Level"):
        return f"no plan passed verification (last Ipopt status {exc.status})"
    return exc.status or str(exc)


# --------------------------------------------------------------------------- input handling


def _resolve_corridor(
    where: Any,
    weather: Any,
    ship: Ship,
    departure: Any,
    kwargs: Mapping[str, Any],
    width_nm: float,
    search_options: Mapping[str, Any] | None,
) -> tuple[Corridor, Any, np.datetime64]:
    if isinstance(where, Corridor):
        return where, None, as_utc_time(departure, "departure")
    try:
        start, end = ((float(p[0]), float(p[1])) for p in where)  # type: ignore[union-attr]
    except (TypeError, ValueError, IndexError) as exc:
        raise ConfigError(
            f"corridor_or_endpoints={where!r} is neither an optroute.Corridor nor two (lat, lon) endpoints; "
            "pass a Corridor (e.g. route.corridor(width_nm=60)) or ((lat0, lon0), (lat1, lon1))"
        ) from exc
    from optroute.search.routing import search_route

    opts = dict(search_options or {})
    opts.setdefault("objective", "time")
    route = search_route(
        start, end, weather, ship, departure=departure, model=kwargs.get("model"), rules=kwargs.get("rules"), **opts
    )
    return route.corridor(width_nm=width_nm), route, route.departure


def _eta_hours(etas: Any, t0: np.datetime64) -> np.ndarray:
    if isinstance(etas, str | bytes) or not isinstance(etas, Sequence | np.ndarray):
        raise ConfigError(f"etas={etas!r} must be a sequence of datetimes or of hours after departure")
    out = []
    for e in etas:
        if isinstance(e, numbers.Real) and not isinstance(e, bool):
            h = float(e)
        else:
            h = timedelta_to_h(as_utc_time(e, "etas") - t0)
        if not math.isfinite(h) or h <= 0:
            raise ConfigError(
                f"eta {e!r} is {h} h after departure {format_utc(t0)}; every ETA must be a finite time after it"
            )
        out.append(h)
    hours = np.array(out, dtype=float)
    if hours.size == 0:
        raise ConfigError("etas=[] is empty; give at least one ETA, or None for the default front")
    if np.unique(hours).size != hours.size:
        raise ConfigError(f"etas has duplicates ({sorted(hours.tolist())} h after departure); give distinct ETAs")
    return np.sort(hours)


# --------------------------------------------------------------------------- execution


class _Serial:
    """Runs points in this process."""

    def ends(self, spec: _Spec, route: Any, need_slow: bool) -> tuple[_Point, _Point | None]:
        fast = _solve_point(spec, None, "minimum_time", None, route)
        slow = _solve_point(spec, None, "slow_steaming", None) if need_slow else None
        return fast, slow

    def resolve(self, spec: _Spec, eta_h: float, starts: list[_Point | None]) -> list[_Point]:
        return [_solve_point(spec, eta_h, "eta", w) for w in starts]

    def chains(
        self, spec: _Spec, chains: list[tuple[list[float], _Point | None]], cold: bool, report: Callable[[_Point], None]
    ) -> list[_Point]:
        out = []
        for etas, warm in chains:
            for p in _solve_chain(spec, etas, warm, cold):
                out.append(p)
                report(p)
        return out


class _Distributed:
    """Runs the end solves side by side and each chain as one task on a Dask cluster."""

    def __init__(self, client: Any, spec: _Spec) -> None:
        self.client = client
        self.spec = client.scatter(spec, broadcast=True, hash=False)
        self.workers = sorted(client.scheduler_info()["workers"])
        self._shipped: Any = None  # the spec naming the chains' latest ETA, once scattered

    def ends(self, spec: _Spec, route: Any, need_slow: bool) -> tuple[_Point, _Point | None]:
        fast = self.client.submit(_solve_point, self.spec, None, "minimum_time", None, route, pure=False)
        slow = (
            self.client.submit(_solve_point, self.spec, None, "slow_steaming", None, pure=False) if need_slow else None
        )
        return fast.result(), slow.result() if slow is not None else None

    def resolve(self, spec: _Spec, eta_h: float, starts: list[_Point | None]) -> list[_Point]:
        """Solves of one ETA from several starts, side by side (the workers' prepared corridors serve them)."""
        shipped = self._shipped if self._shipped is not None else self.client.scatter(spec, broadcast=True, hash=False)
        futures = [self.client.submit(_solve_point, shipped, eta_h, "eta", w, pure=False) for w in starts]
        return [f.result() for f in futures]

    def chains(
        self, spec: _Spec, chains: list[tuple[list[float], _Point | None]], cold: bool, report: Callable[[_Point], None]
    ) -> list[_Point]:
        from distributed import as_completed

        # the spec now names the chains' latest ETA: each worker prepares the corridor once for it (and keeps it)
        shipped = self._shipped = self.client.scatter(spec, broadcast=True, hash=False)
        # one task per chain (a chain's points run one after the other anyway): few, long tasks, streamed back
        futures = [self.client.submit(_solve_chain, shipped, etas, warm, cold, pure=False) for etas, warm in chains]
        out = []
        for fut in as_completed(futures, loop=self.client.loop):
            for p in fut.result():
                out.append(p)
                report(p)
            fut.release()
        return out


def _split(etas: list[float], k: int, from_slow: bool) -> list[list[float]]:
    """``k`` contiguous chains of the ETAs, each in solving order: descending from the slow end with ``from_slow``.

    The chains depend on the ETAs and ``k`` alone, never on the workers: the front is the same serial and
    on any cluster.
    """
    k = max(1, min(k, len(etas)))
    parts = [[float(h) for h in a] for a in np.array_split(np.asarray(etas, dtype=float), k)]
    return [part[::-1] if from_slow else part for part in parts]


# --------------------------------------------------------------------------- public API


def tradeoff(
    corridor_or_endpoints: Corridor | Sequence[tuple[float, float]],
    weather: xr.Dataset | WeatherSampler,
    ship: Ship,
    *,
    departure: Any,
    etas: Sequence[Any] | None = None,
    n: int = 30,
    objective: str = "fuel",
    progress: FrontProgress | None = None,
    n_workers: int | None = None,
    scheduler_address: str | None = None,
    warm_start: bool = True,
    chains: int = 4,
    monotone_rtol: float = 1e-6,
    corridor_width_nm: float = 60.0,
    search_options: Mapping[str, Any] | None = None,
    timeout_s: float = 10.0,
    **optimise_kwargs: Any,
) -> TradeoffFront:
    """The fuel-versus-ETA front of a corridor, each point warm-started from its neighbour.

    Parameters
    ----------
    corridor_or_endpoints : Corridor or ((lat, lon), (lat, lon))
        A corridor, or start and end [deg]: then :func:`optroute.search_route` runs once (objective
        ``"time"`` unless ``search_options`` says otherwise) and its corridor (``corridor_width_nm``
        wide) serves every point; its route warm-starts the minimum-time solve.
    weather : xarray.Dataset or WeatherSampler
        Canonical weather (a dataset for a Dask cluster: it is sent to every worker once).
    ship : Ship
    departure : datetime64 or str
        [UTC]; with endpoints, the search's departure is used.
    etas : sequence of datetime64/str or of float, optional
        Arrival times [UTC], or hours after departure [h]; sorted, duplicates refused.  Default:
        ``n`` ETAs evenly from the earliest arrival to the slow-steaming limit (module docstring).
    n : int
        Points of the default front, >= 2.
    objective : {"fuel", "cost"}
        What each point minimises subject to arriving by its ETA (``"cost"`` with
        ``fuel_price_per_t`` and ``hourly_cost_per_h`` in ``optimise_kwargs``).
    progress : callable, optional
        ``progress(points done, points)`` in this process after each point.
    n_workers : int, optional
        ``None``, 0 or 1: serial, in this process.  >= 2: a local Dask cluster of that many
        worker processes on 127.0.0.1 for this call.
    scheduler_address : str, optional
        An existing Dask scheduler (``"tcp://host:port"``); one chain per worker.  An address that
        does not answer within ``timeout_s`` raises :class:`~optroute.studies.study.SchedulerUnreachable`
        naming it.
    warm_start : bool
        Warm-start each point from its neighbour (default).  ``False`` solves every ETA from the
        optimiser's own start (for benchmarks).
    chains : int
        The warm-start chains the ETAs between the two ends are split into (contiguous, each swept from
        its slow end).  The front depends on this number and never on the workers: it is the same,
        to the last bit, serial and on any cluster.  A cluster runs the chains side by side, so give at
        least as many as workers.
    monotone_rtol : float
        Relative tolerance of the monotonicity check [-].
    corridor_width_nm, search_options
        For endpoints: the corridor's total width [nm] and :func:`optroute.search_route` options.
    timeout_s : float
        Seconds to reach an existing scheduler [s].
    **optimise_kwargs
        Passed to every :func:`optroute.optimise_corridor` call (``model``, ``rules``,
        ``max_leg_nm``, ``solver_options``, ...), but not ``eta``, ``eta_mode``, ``objective``,
        ``warm_plan``, ``route``, ``progress``.

    Returns
    -------
    TradeoffFront
        Dimension ``eta`` (the arrival times [UTC], ascending) with coordinate ``eta_h`` [h after
        departure]; per ETA: ``fuel_t`` [t], ``duration_h`` [h], ``distance_nm`` [nm],
        ``mean_power_kw`` (time-weighted) and ``max_power_kw`` [kW] of the legs,
        ``eta_shadow_price_t_per_h`` (−dF/dETA of the solve's ETA constraint [t/h]; NaN at the two
        end solves, which have none), ``status`` (``"optimal"``/``"feasible"``, ``"infeasible:
        earliest arrival …"``, ``"infeasible: <reason>"``, ``"solver failure: <Ipopt status>"``,
        with ``"; the plan of the earlier ETA …"`` appended when its own solve rose above an earlier point
        and that point's plan, arriving earlier, serves it), ``own_fuel_t`` [t] (the point's own
        solve's fuel: above ``fuel_t`` where it rose), ``solve`` (``"minimum_time"``,
        ``"slow_steaming"`` or ``"eta"``), ``runtime_s`` [s], ``iterations`` (Ipopt),
        ``nlp_solves`` (Ipopt calls of the point's solve: band outer loop and verification re-solves)
        and ``warm_start`` (the candidate Ipopt started from, e.g. ``"warm plan"``) of the point; the plans on ``(eta, waypoint)`` —
        ``waypoint_lat_deg``, ``waypoint_lon_deg``, ``waypoint_time_h`` [h after departure] — and
        on ``(eta, leg)`` — ``leg_<v>`` for ``v`` in :data:`LEG_VARIABLES` — NaN where a point has
        no plan.  ``attrs``: departure, objective, ship, earliest arrival and slow-steaming limit
        [h], the knee's ETA [h], ``monotonicity_resolves`` (failed points solved again),
        ``risen_points`` (also ``front.risen_points``), ``chains``.  Writes with ``front.to_netcdf(path)``.

    Raises
    ------
    ConfigError
        Bad arguments (the message names the value).
    InfeasibleETA, SolverFailure, WeatherCoverageError
        The minimum-time solve fails (no front at all), or, for the default front, the slow-steaming
        solve does.
    SchedulerUnreachable
        ``scheduler_address`` does not answer.
    """
    if objective not in ("fuel", "cost"):
        raise ConfigError(
            f"objective={objective!r} is not a front's objective; use 'fuel' or 'cost' (each point "
            "minimises it subject to its ETA)"
        )
    bad = sorted(set(optimise_kwargs) & set(_FORBIDDEN))
    if bad:
        raise ConfigError(f"tradeoff sets {bad} itself for every point; drop them from the keyword arguments")
    if etas is None and not (isinstance(n, numbers.Integral) and not isinstance(n, bool) and n >= 2):
        raise ConfigError(f"n={n!r} must be an integer >= 2 (the front's two ends and the points between)")
    if n_workers is not None and (
        isinstance(n_workers, bool) or not isinstance(n_workers, numbers.Integral) or n_workers < 0
    ):
        raise ConfigError(f"n_workers={n_workers!r} must be None or an integer >= 0")
    if scheduler_address is not None and n_workers is not None:
        raise ConfigError(
            f"n_workers={n_workers} applies to a local cluster; with scheduler_address="
            f"{scheduler_address!r} the cluster's own workers are used: drop n_workers"
        )
    if isinstance(chains, bool) or not isinstance(chains, numbers.Integral) or chains < 1:
        raise ConfigError(f"chains={chains!r} must be an integer >= 1 (the warm-start chains the ETAs are split into)")
    if not (isinstance(monotone_rtol, numbers.Real) and 0.0 <= monotone_rtol < 1.0):
        raise ConfigError(f"monotone_rtol={monotone_rtol!r} must be a number in [0, 1)")
    if not isinstance(ship, Ship):
        raise ConfigError(f"ship must be an optroute.Ship, got {type(ship).__name__}; e.g. Ship.preset(name)")
    corridor, route, t0 = _resolve_corridor(
        corridor_or_endpoints, weather, ship, departure, optimise_kwargs, corridor_width_nm, search_options
    )
    user_h = _eta_hours(etas, t0) if etas is not None else None
    spec = _Spec(
        corridor,
        weather,
        ship,
        t0,
        objective,
        dict(optimise_kwargs),
        token=_token(corridor, weather, ship, t0, objective, optimise_kwargs),
    )
    parallel = scheduler_address is not None or (n_workers or 0) >= 2
    if parallel:
        from optroute.studies.cluster import dask_client

        with dask_client(scheduler_address, int(n_workers or 0), 1, timeout_s) as client:
            runner: _Serial | _Distributed = _Distributed(client, spec)
            return _front(spec, route, user_h, n, progress, runner, warm_start, monotone_rtol, int(chains))
    return _front(spec, route, user_h, n, progress, _Serial(), warm_start, monotone_rtol, int(chains))


def _front(
    spec: _Spec,
    route: Any,
    user_h: np.ndarray | None,
    n: int,
    progress: FrontProgress | None,
    runner: _Serial | _Distributed,
    warm_start: bool,
    rtol: float,
    n_chains: int,
) -> TradeoffFront:
    need_slow = user_h is None or spec.objective == "fuel"
    fast, slow = runner.ends(spec, route, need_slow)
    if not fast.ok:
        raise SolverFailure(
            f"the minimum-time solve of the front failed ({fast.status}); no front can be drawn: "
            "check the corridor and weather, or pass solver_options",
            status=fast.status,
        )
    t_min = fast.totals["duration_h"]
    fast = _replace(fast, eta_h=t_min)
    if slow is not None and not slow.ok:
        if user_h is None:
            raise SolverFailure(
                f"the slow-steaming solve of the front failed ({slow.status}); pass etas= to draw the front without it",
                status=slow.status,
            )
        slow = None
    t_slow = slow.totals["duration_h"] if slow is not None else math.inf
    if user_h is None:
        grid = np.linspace(t_min, t_slow, n) if t_slow > t_min + _SAME_ETA_H else np.array([t_min])
    else:
        grid = user_h
    done: dict[float, _Point] = {}
    todo: list[float] = []
    for h in grid.tolist():
        if h < t_min - _SAME_ETA_H:
            earliest = spec.departure + h_to_timedelta(t_min)
            done[h] = _Point(
                h, "eta", f"infeasible: earliest arrival {str(earliest)[:16]} ({t_min:.2f} h after departure)"
            )
        elif h <= t_min + _SAME_ETA_H:
            done[h] = _replace(fast, eta_h=h)
        elif slow is not None and spec.objective == "fuel" and h >= t_slow - _SAME_ETA_H:
            done[h] = _replace(slow, eta_h=h)
        else:
            todo.append(h)
    if todo:  # the points between the ends are solved on one corridor prepared per process for the latest
        spec = _replace(spec, latest_eta_h=max(todo))
    return _rest(spec, grid, done, todo, t_min, t_slow, slow, fast, progress, runner, warm_start, rtol, n_chains)


def _rest(
    spec: _Spec,
    grid: np.ndarray,
    done: dict[float, _Point],
    todo: list[float],
    t_min: float,
    t_slow: float,
    slow: _Point | None,
    fast: _Point,
    progress: FrontProgress | None,
    runner: _Serial | _Distributed,
    warm_start: bool,
    rtol: float,
    n_chains: int,
) -> TradeoffFront:
    """The chains between the ends, the monotonicity re-solves and the dataset."""
    total = grid.size
    count = len(done)
    if progress is not None:
        progress(count, total)

    def report(_: _Point) -> None:
        nonlocal count
        count += 1
        if progress is not None:
            progress(count, total)

    # the continuation: from the slow-steaming end (its plan, sped up, starts each chain) towards the fast one
    from_slow = slow is not None and spec.objective == "fuel"
    chains = [(etas, slow if from_slow else fast) for etas in _split(todo, n_chains, from_slow)]
    for p in runner.chains(spec, chains, not warm_start, report):
        done[p.eta_h] = p
    points = [done[h] for h in grid.tolist()]
    resolves = _resolve_failed(spec, points, runner)
    risen = _monotone(points, rtol) if spec.objective == "fuel" else 0
    return _dataset(spec, points, t_min, t_slow, resolves, risen, n_chains)


def _replace(p: Any, **changes: Any) -> Any:
    from dataclasses import replace

    return replace(p, **changes)


def _resolve_failed(spec: _Spec, points: list[_Point], runner: _Serial | _Distributed) -> int:
    """Solve each point whose chain solve failed once more, from the optimiser's own start; the re-solves made."""
    failed = [
        i
        for i, p in enumerate(points)
        if p.kind == "eta" and not p.ok and not p.status.startswith("infeasible: earliest")
    ]
    for i in failed:
        (q,) = runner.resolve(spec, points[i].eta_h, [None])
        points[i] = _replace(q, runtime_s=points[i].runtime_s + q.runtime_s) if q.ok else points[i]
    return len(failed)


def _monotone(points: list[_Point], rtol: float) -> int:
    """Points whose own solve ended above an earlier ETA's fuel take that plan; their number.

    Arriving by an ETA may arrive earlier (``eta_mode="le"``), so the earlier ETA's verified plan serves
    the later one with less fuel.  The point's own solve stays beside it: its fuel in ``own_fuel_t``, its
    status saying so.  Nothing is solved again.
    """
    risen = 0
    best_before = math.inf
    best_point: _Point | None = None
    for i, p in enumerate(points):
        if p.ok and p.fuel_t > best_before * (1.0 + rtol) and best_point is not None:
            risen += 1
            points[i] = p = _replace(
                best_point,
                eta_h=p.eta_h,
                kind=p.kind,
                runtime_s=p.runtime_s,
                iterations=p.iterations,
                nlp_solves=p.nlp_solves,
                warm_start=p.warm_start,
                carry=p.carry,
                own_fuel_t=p.fuel_t,
                status=f"{best_point.status}; the plan of the earlier ETA {best_point.eta_h:.6g} h (arrives earlier): "
                f"this ETA's own solve ({p.status}) ended {p.fuel_t:.6g} t, above its {best_before:.6g} t",
            )
        if p.ok and p.fuel_t < best_before:
            best_before, best_point = p.fuel_t, p
    return risen


def _dataset(
    spec: _Spec, points: list[_Point], t_min: float, t_slow: float, resolves: int, risen: int, n_chains: int
) -> TradeoffFront:
    eta_h = np.array([p.eta_h for p in points], dtype=float)
    n_wp = max((p.waypoints.shape[0] for p in points if p.waypoints is not None), default=0)
    n_leg = max(n_wp - 1, 0)

    def col(key: str) -> np.ndarray:
        return np.array([p.totals.get(key, math.nan) for p in points], dtype=float)

    def padded(get: Callable[[_Point], np.ndarray | None], size: int) -> np.ndarray:
        out = np.full((len(points), size), np.nan)
        for i, p in enumerate(points):
            a = get(p)
            if a is not None:
                out[i, : a.size] = a
        return out

    data: dict[str, Any] = {
        "fuel_t": ("eta", col("fuel_t"), {"units": "t", "long_name": "fuel burnt on the passage"}),
        "duration_h": ("eta", col("duration_h"), {"units": "h", "long_name": "passage time"}),
        "distance_nm": ("eta", col("distance_nm"), {"units": "nmi", "long_name": "distance sailed"}),
        "mean_power_kw": ("eta", col("mean_power_kw"), {"units": "kW", "long_name": "time-weighted mean power"}),
        "max_power_kw": ("eta", col("max_power_kw"), {"units": "kW", "long_name": "highest leg power"}),
        "eta_shadow_price_t_per_h": (
            "eta",
            col("eta_shadow_price_t_per_h"),
            {"units": "t h-1", "long_name": "fuel saved per hour of later ETA (-dF/dETA)"},
        ),
        "status": ("eta", np.array([p.status for p in points], dtype=str)),
        "solve": ("eta", np.array([p.kind for p in points], dtype=str)),
        "runtime_s": ("eta", np.array([p.runtime_s for p in points], dtype=float), {"units": "s"}),
        "iterations": ("eta", np.array([p.iterations for p in points], dtype=np.int64)),
        "nlp_solves": (
            "eta",
            np.array([p.nlp_solves for p in points], dtype=np.int64),
            {"long_name": "Ipopt calls of the point's solve (band outer loop and verification re-solves)"},
        ),
        "warm_start": ("eta", np.array([p.warm_start for p in points], dtype=str)),
        "own_fuel_t": (
            "eta",
            np.array([p.fuel_t if p.own_fuel_t is None else p.own_fuel_t for p in points], dtype=float),
            {"units": "t", "long_name": "fuel of the point's own solve (above fuel_t where it rose)"},
        ),
        "waypoint_lat_deg": (
            ("eta", "waypoint"),
            padded(lambda p: None if p.waypoints is None else p.waypoints[:, 0], n_wp),
            {"units": "degrees_north"},
        ),
        "waypoint_lon_deg": (
            ("eta", "waypoint"),
            padded(lambda p: None if p.waypoints is None else p.waypoints[:, 1], n_wp),
            {"units": "degrees_east"},
        ),
        "waypoint_time_h": (
            ("eta", "waypoint"),
            padded(lambda p: p.times_h, n_wp),
            {"units": "h", "long_name": "time after departure"},
        ),
    }
    for v in LEG_VARIABLES:
        data[f"leg_{v}"] = (("eta", "leg"), padded(lambda p, v=v: None if p.legs is None else p.legs.get(v), n_leg))
    etas = np.array([spec.departure + h_to_timedelta(h) for h in eta_h], dtype="datetime64[ns]")
    ok = np.isfinite(col("fuel_t"))
    knee = knee_index(eta_h[ok], col("fuel_t")[ok])
    attrs = {
        "title": "optroute fuel-versus-ETA front",
        "departure": str(spec.departure)[:19],
        "objective": spec.objective,
        "ship": spec.ship.name,
        "corridor_length_nm": float(spec.corridor.length_nm),
        "earliest_arrival_h": float(t_min),
        "slow_steaming_limit_h": float(t_slow) if math.isfinite(t_slow) else "not solved",
        "slow_steaming_limit": "least-fuel solve without an ETA: the engine's minimum load, the lowest speed or "
        "the end of the weather, whichever binds first",
        "knee_eta_h": float(eta_h[ok][knee]) if knee is not None else "none",
        "monotonicity_resolves": int(resolves),
        "risen_points": int(risen),
        "chains": int(n_chains),
        "conventions": "eta UTC; eta_h, waypoint_time_h hours after departure; lat/lon deg; heading deg true (to)",
    }
    return TradeoffFront(data, coords={"eta": etas, "eta_h": ("eta", eta_h, {"units": "h"})}, attrs=attrs)
