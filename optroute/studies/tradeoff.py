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

Monotonicity
------------
Arriving by an ETA is allowed to arrive earlier (``eta_mode="le"``), so with
the fuel objective the true front never rises with a later ETA.  A point
whose fuel is above that of an earlier point (relative tolerance
``monotone_rtol``), or whose solve failed, is solved again warm-started from
each neighbour's solution and once from the optimiser's own start, keeping
the least fuel; if it still rises (the NLP is a local search on a model that is only
piecewise smooth), the point takes the earlier point's verified plan, which arrives by this ETA too, and its
status says so (``"optimal; the plan of the earlier ETA …"``): the front never rises.  With ``objective="cost"``
(fuel and time both priced) a later ETA may legitimately cost more fuel, so
nothing is re-solved.

Parallel fronts
---------------
With ``n_workers >= 2`` (a :class:`distributed.LocalCluster` on the loopback
interface, for this call) or ``scheduler_address=`` (an existing Dask
cluster: the address its ``dask scheduler`` printed, e.g.
``"tcp://10.0.0.5:8786"``; the workers need optroute installed), the two
end solves run side by side, then the ETAs between them are split into one
contiguous chain per worker, each chain warm-started along itself — the
first from the minimum-time plan (ascending), the last from the
slow-steaming plan (descending), any middle ones from the minimum-time plan.
Each point is a Dask task depending on its predecessor in the chain, pinned
to the chain's worker.  The results equal the serial ones within the
solver's tolerance (the warm starts differ, not the problems).

Set-up once per front
---------------------
The points between the two ends are solved on one
:class:`~optroute.optimise.corridor_problem.PreparedCorridor` per process (this one
when serial, each Dask worker's), prepared for the latest of them: the
weather grid with the ship's power table, lateral bounds and the CasADi build are made once,
and each point costs only its solves (the ETA and the load limits are solve
parameters).  Each point starts from the
untightened problem, as :func:`optroute.optimise_corridor` would, so a point
does not depend on the chain it was solved in.
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
        totals=totals,
        waypoints=wp,
        times_h=times_h,
        legs={k: legs[k].to_numpy(dtype=float) for k in LEG_VARIABLES if k in legs},
        carry=_Warm(wp, plan.stw_kn),
    )


def _solve_point(spec: _Spec, eta_h: float | None, kind: str, warm: _Point | _Warm | None, route: Any = None) -> _Point:
    """One solve; an unreachable ETA or a solver failure becomes the point's status, not an exception."""
    started = _time.perf_counter()
    carry = warm.carry if isinstance(warm, _Point) else warm
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


#: Prepared corridors of this process (a Dask worker's too), by front and latest ETA; the oldest is dropped.
_PREPARED: dict[tuple[str, float], tuple[PreparedCorridor, threading.Lock]] = {}
_PREPARED_KEEP = 2
_PREPARING = threading.Lock()


def _prepared(spec: _Spec) -> tuple[PreparedCorridor, threading.Lock]:
    """The front's corridor problem prepared once in this process for its latest ETA, and its solve lock."""
    latest = float(spec.latest_eta_h)  # type: ignore[arg-type]
    key = (spec.token, latest)
    with _PREPARING:
        hit = _PREPARED.get(key)
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
            hit = _PREPARED[key] = (prepared, threading.Lock())
            while len(_PREPARED) > _PREPARED_KEEP:
                _PREPARED.pop(next(iter(_PREPARED)))
    return hit


def _forget(spec: _Spec) -> None:
    """Drop this front's prepared corridors from this process's cache."""
    for key in [k for k in _PREPARED if k[0] == spec.token]:
        _PREPARED.pop(key, None)


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

    def chains(
        self, spec: _Spec, chains: list[tuple[list[float], _Point | None]], cold: bool, report: Callable[[_Point], None]
    ) -> list[_Point]:
        out = []
        for etas, warm in chains:
            for eta_h in etas:
                p = _solve_point(spec, eta_h, "eta", None if cold else warm)
                warm = p if p.ok else warm
                out.append(p)
                report(p)
        return out


class _Distributed:
    """Runs the end solves side by side and one chain per worker on a Dask cluster."""

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

        # the spec now names the chains' latest ETA: each worker prepares the corridor once for it
        shipped = self._shipped = self.client.scatter(spec, broadcast=True, hash=False)
        futures = []
        for c, (etas, warm) in enumerate(chains):
            where = [self.workers[c % len(self.workers)]]
            prev: Any = None if cold else warm
            for eta_h in etas:
                fut = self.client.submit(
                    _solve_point,
                    shipped,
                    eta_h,
                    "eta",
                    None if cold else prev,
                    pure=False,
                    workers=where,
                    allow_other_workers=True,
                )
                futures.append(fut)
                prev = fut
        out = []
        for fut in as_completed(futures, loop=self.client.loop):
            p = fut.result()
            out.append(p)
            report(p)
        return out


def _split(etas: list[float], k: int, has_slow: bool) -> list[tuple[list[float], str]]:
    """Contiguous chains: the first ascending from the fast end, the last descending from the slow end."""
    k = max(1, min(k, len(etas)))
    parts = [list(a) for a in np.array_split(np.asarray(etas), k)]
    out = []
    for c, part in enumerate(parts):
        if c == k - 1 and k > 1 and has_slow:
            out.append((part[::-1], "slow"))
        else:
            out.append((part, "fast"))
    return out


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
        with ``"; the plan of the earlier ETA …"`` appended when its own solves rose above an earlier point
        and that point's plan, arriving earlier, serves it), ``solve``
        (``"minimum_time"``, ``"slow_steaming"`` or ``"eta"``), ``runtime_s`` [s] and
        ``iterations`` (Ipopt) of the point; the plans on ``(eta, waypoint)`` —
        ``waypoint_lat_deg``, ``waypoint_lon_deg``, ``waypoint_time_h`` [h after departure] — and
        on ``(eta, leg)`` — ``leg_<v>`` for ``v`` in :data:`LEG_VARIABLES` — NaN where a point has
        no plan.  ``attrs``: departure, objective, ship, earliest arrival and slow-steaming limit
        [h], the knee's ETA [h], the monotonicity re-solves.  Writes with ``front.to_netcdf(path)``.

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
    if not (isinstance(monotone_rtol, numbers.Real) and 0.0 <= monotone_rtol < 1.0):
        raise ConfigError(f"monotone_rtol={monotone_rtol!r} must be a number in [0, 1)")
    if not isinstance(ship, Ship):
        raise ConfigError(f"ship must be an optroute.Ship, got {type(ship).__name__}; e.g. Ship.preset(name)")
    corridor, route, t0 = _resolve_corridor(
        corridor_or_endpoints, weather, ship, departure, optimise_kwargs, corridor_width_nm, search_options
    )
    user_h = _eta_hours(etas, t0) if etas is not None else None
    spec = _Spec(corridor, weather, ship, t0, objective, dict(optimise_kwargs), token=uuid.uuid4().hex)
    parallel = scheduler_address is not None or (n_workers or 0) >= 2
    if parallel:
        from optroute.studies.cluster import dask_client

        with dask_client(scheduler_address, int(n_workers or 0), 1, timeout_s) as client:
            return _front(spec, route, user_h, n, progress, _Distributed(client, spec), warm_start, monotone_rtol)
    return _front(spec, route, user_h, n, progress, _Serial(), warm_start, monotone_rtol)


def _front(
    spec: _Spec,
    route: Any,
    user_h: np.ndarray | None,
    n: int,
    progress: FrontProgress | None,
    runner: _Serial | _Distributed,
    warm_start: bool,
    rtol: float,
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
    try:
        return _rest(spec, grid, done, todo, t_min, t_slow, slow, fast, progress, runner, warm_start, rtol)
    finally:
        _forget(spec)


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

    n_chains = len(runner.workers) if isinstance(runner, _Distributed) else 1
    chains = [
        (etas, slow if end == "slow" else fast)
        for etas, end in _split(todo, n_chains, slow is not None and spec.objective == "fuel")
    ]
    for p in runner.chains(spec, chains, not warm_start, report):
        done[p.eta_h] = p
    points = [done[h] for h in grid.tolist()]
    resolves = _monotone(spec, points, rtol, runner) if spec.objective == "fuel" else 0
    return _dataset(spec, points, t_min, t_slow, resolves)


def _replace(p: Any, **changes: Any) -> Any:
    from dataclasses import replace

    return replace(p, **changes)


def _monotone(spec: _Spec, points: list[_Point], rtol: float, runner: _Serial | _Distributed | None = None) -> int:
    """Re-solve rising or failed points from each neighbour's solution; flag those that still rise."""
    resolves = 0
    best_before = math.inf
    best_point: _Point | None = None
    for i, p in enumerate(points):
        eligible = p.kind == "eta" and not p.status.startswith("infeasible: earliest")
        rises = p.ok and p.fuel_t > best_before * (1.0 + rtol)
        if eligible and (rises or not p.ok):
            left = next((q for q in reversed(points[:i]) if q.ok), None)
            right = next((q for q in points[i + 1 :] if q.ok), None)
            # each neighbour's solution, then the optimiser's own start (side by side on a cluster)
            starts = [None if nb == "cold" else nb for nb in (left, right, "cold") if nb is not None]
            resolves += len(starts)
            if isinstance(runner, _Distributed):
                tried = runner.resolve(spec, p.eta_h, starts)
            else:
                tried = [_solve_point(spec, p.eta_h, "eta", w) for w in starts]
            for q in tried:
                if q.ok and (not p.ok or q.fuel_t < p.fuel_t):
                    p = _replace(q, runtime_s=p.runtime_s + q.runtime_s)
            points[i] = p
        if p.ok and p.fuel_t > best_before * (1.0 + rtol) and best_point is not None:
            # arriving by this ETA may arrive earlier: the earlier ETA's verified plan serves it with less fuel
            points[i] = p = _replace(
                best_point,
                eta_h=p.eta_h,
                kind=p.kind,
                runtime_s=p.runtime_s,
                carry=p.carry,
                status=f"{best_point.status}; the plan of the earlier ETA {best_point.eta_h:.6g} h (arrives earlier): "
                f"this ETA's own solves, from both neighbours and cold, ended {p.fuel_t:.6g} t, above its "
                f"{best_before:.6g} t",
            )
        if p.ok and p.fuel_t < best_before:
            best_before, best_point = p.fuel_t, p
    return resolves


def _dataset(spec: _Spec, points: list[_Point], t_min: float, t_slow: float, resolves: int) -> TradeoffFront:
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
        "conventions": "eta UTC; eta_h, waypoint_time_h hours after departure; lat/lon deg; heading deg true (to)",
    }
    return TradeoffFront(data, coords={"eta": etas, "eta_h": ("eta", eta_h, {"units": "h"})}, attrs=attrs)
