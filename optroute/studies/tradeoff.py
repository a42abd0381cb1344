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
span, whichever comes first.  ETAs later than that save no fuel.  That solve
starts from the centreline sailed at the engine's minimum load
(:func:`optroute.optimise.starts.minimum_load_plan`), the slowest schedule the
engine allows.  The ``n`` points are spaced evenly in ETA between the two.

Given ``etas`` (datetimes, or hours after departure) the same two solves are
made first (for the warm starts and to classify the ETAs): an ETA before the
earliest arrival is reported as ``"infeasible: earliest arrival …"`` without
a solve, one at the earliest arrival or at or after the slow-steaming limit
(for the fuel objective) takes that solve's plan, and an ETA that cannot be
solved (past the weather, Ipopt failing) gets its reason as its status.  No
ETA is ever dropped.

The continuation
----------------
The ETAs between the two ends are swept from the fast end towards the slow-steaming one: each point's
:meth:`~optroute.optimise.corridor_problem.PreparedCorridor.solve` starts from its earlier neighbour's
plan, which arrives before the point's own ETA (``eta_mode="le"`` allows it) and so is a verified start of
the point as it is — no speed-up, no mending (each leg the referee finds outside the engine's range would
be moved to the limit: :func:`~optroute.studies.front_points.mended_start`; it verifies the plan for the new
ETA) — and the floor of its result: the front cannot rise within a chain.  The optimiser takes it as Ipopt's
start — inside a chain as its only start (no centreline start is built beside a verified neighbour: on the
benchmark's storm corridor that safe start, a timed search around the storm, was 28 % of a front's time)
and so is the end's plan for the chain whose first ETA is the end's neighbour; for another chain's first
point (the end's plan, arriving long before it) when it also scores best against the centreline's start —
its own start otherwise, together with the neighbour's Ipopt multipliers where the NLP has the same rows:
Ipopt's primal-dual warm start (``warm_start_init_point``, :data:`formulations.ipopt_options.WARM_START_OPTIONS`;
``dual_starts`` counts such solves per point).  One solve per point; only a point whose solve failed is
solved once more, from the optimiser's own start (``attrs["monotonicity_resolves"]``), and a point that rose
(below).

The sweep runs from the fast end, not from the slow one, by measurement: near the slow end the engine's
minimum load and the SFOC's rise at low load make the problem nonconvex and flat (its points take the most
Ipopt iterations whichever way they are reached), and a later neighbour's plan must be sped up to arrive in
time, which raises its fuel by about 4 % per step on the benchmark's storm corridor before Ipopt works it
back down; the earlier neighbour's plan needs no change (``python -m benchmarks.bench_front`` measures the
front).

Monotonicity
------------
Arriving by an ETA is allowed to arrive earlier (``eta_mode="le"``), so with the fuel objective
the true front never rises with a later ETA.  A point whose own solve ends above the fuel of an
earlier ETA's point (relative tolerance ``monotone_rtol``; the NLP is a local search on a model
that is only piecewise smooth; the tail of a front, where the ship overtakes a storm, is flat and
multi-modal) is solved once more, started from that earlier point's verified plan alone, which arrives
by its ETA too and is the floor of the re-solve (``attrs["risen_resolves"]``, the slow-steaming end's
solve included: its plan then arrives before the limit); the first solve's fuel stays beside it
(``own_fuel_t``) and its status says so (``"…; solved again from the plan of the earlier ETA …"``).  Only
where that re-solve fails or ends above the earlier fuel all the same does the point take the earlier
point's plan (status ``"optimal; the plan of the earlier ETA …"``): ``front.risen_points``
(``attrs["risen_points"]``), target 0.  Both solves count in the point's ``iterations``,
``nlp_solves`` and ``runtime_s``.  With ``objective="cost"`` (fuel
and time both priced) a later ETA may legitimately cost more fuel, so no point is replaced.

Chains, workers and determinism
-------------------------------
The ETAs between the ends are cut into ``chains`` contiguous chains (default 4), by ETA alone:
serial, the chains run one after the other; with ``n_workers >= 2`` (a
:class:`distributed.LocalCluster` on the loopback interface, for this call) or
``scheduler_address=`` (an existing Dask cluster: the address its ``dask scheduler`` printed,
e.g. ``"tcp://10.0.0.5:8786"``; the workers need optroute installed) the two end solves run side
by side and each chain is one Dask task, its points streamed back as it finishes; the chains are handed
out one per free worker thread, the slow end's (the costliest: its points sit at the engine's minimum
load) first.  Every chain
starts from the minimum-time plan whatever ran it, and Ipopt's BLAS runs one thread in every
process (:mod:`optroute.studies.threads`), so the front is the same to the last bit serial, on
a cluster and run to run (``runtime_s`` aside).

Set-up once per process
-----------------------
Every solve of a front — the minimum-time end, the slow-steaming end and the ETAs between — runs on
one :class:`~optroute.optimise.corridor_problem.PreparedCorridor` per process (this one when serial,
each Dask worker's), prepared for the weather's whole time span: the weather grid with the ship's
power table, lateral bounds and the CasADi build are made once, not once per end solve and again for
the chains.  It is kept in the process, keyed by the fingerprint of the front's inputs
(:mod:`optroute.studies.fingerprint`), for the next chain, the next front of the same inputs and a
study's cases (the two most recent are kept).  Each solve goes through
:func:`optroute.optimise.api.solve_prepared` (the solve and honest outcomes of
:func:`optroute.optimise_corridor`) from the untightened problem, so a point does not depend on
what was solved before it in the process.  On a cluster the front's inputs (its weather, tens of MB)
travel to each worker once and stay there under the same fingerprint
(:func:`~optroute.studies.front_points.install_spec`): the tasks carry the token, the ETAs and a warm
start, so the next front of the same inputs ships nothing.
"""

from __future__ import annotations

import math
import numbers
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from optroute.errors import (
    ConfigError,
    SolverFailure,
)
from optroute.physics.ship import Ship
from optroute.plot.front import knee_index
from optroute.search.route import Corridor
from optroute.units import as_utc_time, format_utc, h_to_timedelta, timedelta_to_h
from optroute.weather.sample import WeatherSampler

if TYPE_CHECKING:
    from matplotlib.figure import Figure

from optroute.studies.cluster import SYNCHRONOUS, check_cluster_options
from optroute.studies.front_points import (
    FORBIDDEN_OPTIONS,
    LEG_VARIABLES,
    FrontPoint,
    FrontSpec,
    front_token,
    replace_fields,
)
from optroute.studies.front_runners import Chain, DaskRunner, SerialRunner, split_chains

__all__ = ["TradeoffFront", "tradeoff"]

#: ``progress(points done, points in the front)``.
FrontProgress = Callable[[int, int], None]

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
        """Points whose solves (the first and the one from the earlier ETA's plan) ended above an earlier ETA's fuel and
        which took that ETA's plan (target 0)."""
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
    warm_start: bool | str = True,
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
        naming it.  ``"synchronous"`` runs in this process, as ``n_workers`` 0 or 1 does (as for
        :func:`optroute.study`).
    warm_start : bool or "primal"
        Warm-start each point from its neighbour's plan and multipliers (default).  ``"primal"``: from its
        plan alone; ``False``: every ETA from the optimiser's own start (both for benchmarks).
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
        end solves, which have none, but for a slow-steaming end solved again at its ETA: module
        docstring, Monotonicity), ``status`` (``"optimal"``/``"feasible"``, ``"infeasible:
        earliest arrival …"``, ``"infeasible: <reason>"``, ``"solver failure: <Ipopt status>"``,
        with ``"; solved again from the plan of the earlier ETA …"`` appended when its first solve rose
        above an earlier point and it was solved again from that point's plan, ``"; the plan of the earlier
        ETA …"`` when that plan, arriving earlier, serves it), ``own_fuel_t`` [t] (the point's first
        solve's fuel: above ``fuel_t`` where it rose), ``solve`` (``"minimum_time"``,
        ``"slow_steaming"`` or ``"eta"``), ``runtime_s`` [s], ``iterations`` (Ipopt),
        ``nlp_solves`` (Ipopt calls of the point's solve: band outer loop and verification re-solves)
        ``warm_start`` (the candidate Ipopt started from, e.g. ``"warm plan"``) and ``dual_starts`` (its
        Ipopt calls started from the neighbour's multipliers too) of the point; the plans on ``(eta, waypoint)`` —
        ``waypoint_lat_deg``, ``waypoint_lon_deg``, ``waypoint_time_h`` [h after departure] — and
        on ``(eta, leg)`` — ``leg_<v>`` for ``v`` in :data:`LEG_VARIABLES` — NaN where a point has
        no plan.  ``attrs``: departure, objective, ship, earliest arrival and slow-steaming limit
        [h], the knee's ETA [h], ``monotonicity_resolves`` (failed points solved again),
        ``risen_resolves`` (points solved again from an earlier ETA's plan), ``risen_points`` (also
        ``front.risen_points``: points left with an earlier ETA's plan), ``chains``.  Writes with
        ``front.to_netcdf(path)``.

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
    bad = sorted(set(optimise_kwargs) & set(FORBIDDEN_OPTIONS))
    if bad:
        raise ConfigError(f"tradeoff sets {bad} itself for every point; drop them from the keyword arguments")
    if etas is None and not (isinstance(n, numbers.Integral) and not isinstance(n, bool) and n >= 2):
        raise ConfigError(f"n={n!r} must be an integer >= 2 (the front's two ends and the points between)")
    check_cluster_options(n_workers, scheduler_address, timeout_s)
    if warm_start not in (True, False, "primal"):
        raise ConfigError(
            f"warm_start={warm_start!r} is not a warm start; use True (the neighbour's plan and multipliers), "
            "'primal' (its plan alone) or False (the optimiser's own start)"
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
    spec = FrontSpec(
        corridor,
        weather,
        ship,
        t0,
        objective,
        dict(optimise_kwargs),
        token=front_token(corridor, weather, ship, t0, objective, optimise_kwargs),
    )
    parallel = scheduler_address not in (None, SYNCHRONOUS) or (scheduler_address is None and (n_workers or 0) >= 2)
    if parallel:
        from optroute.studies.cluster import dask_client

        with dask_client(scheduler_address, int(n_workers or 0), 1, timeout_s) as client:
            runner: SerialRunner | DaskRunner = DaskRunner(client, spec)
            return _front(spec, route, user_h, n, progress, runner, warm_start, monotone_rtol, int(chains))
    return _front(spec, route, user_h, n, progress, SerialRunner(), warm_start, monotone_rtol, int(chains))


def _front(
    spec: FrontSpec,
    route: Any,
    user_h: np.ndarray | None,
    n: int,
    progress: FrontProgress | None,
    runner: SerialRunner | DaskRunner,
    warm_start: bool | str,
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
    fast = replace_fields(fast, eta_h=t_min)
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
    done: dict[float, FrontPoint] = {}
    todo: list[float] = []
    for h in grid.tolist():
        if h < t_min - _SAME_ETA_H:
            earliest = spec.departure + h_to_timedelta(t_min)
            done[h] = FrontPoint(
                h, "eta", f"infeasible: earliest arrival {str(earliest)[:16]} ({t_min:.2f} h after departure)"
            )
        elif h <= t_min + _SAME_ETA_H:
            done[h] = replace_fields(fast, eta_h=h)
        elif slow is not None and spec.objective == "fuel" and h >= t_slow - _SAME_ETA_H:
            done[h] = replace_fields(slow, eta_h=h)
        else:
            todo.append(h)
    return _rest(spec, grid, done, todo, t_min, t_slow, slow, fast, progress, runner, warm_start, rtol, n_chains)


def _rest(
    spec: FrontSpec,
    grid: np.ndarray,
    done: dict[float, FrontPoint],
    todo: list[float],
    t_min: float,
    t_slow: float,
    slow: FrontPoint | None,
    fast: FrontPoint,
    progress: FrontProgress | None,
    runner: SerialRunner | DaskRunner,
    warm_start: bool | str,
    rtol: float,
    n_chains: int,
) -> TradeoffFront:
    """The chains between the ends, the monotonicity re-solves and the dataset."""
    total = grid.size
    count = len(done)
    if progress is not None:
        progress(count, total)

    def report(_: FrontPoint) -> None:
        nonlocal count
        count += 1
        if progress is not None:
            progress(count, total)

    # the continuation: from the minimum-time end (its plan, arriving before every ETA, starts each chain) towards
    # the slow-steaming one. The chain whose first ETA is the end's neighbour in the front starts from the end's
    # plan alone, as a chain's later points start from their neighbour's; the others compare the end's plan with
    # the centreline's start
    nearest = min(todo, default=math.nan)
    chains: list[Chain] = [(etas, fast, bool(etas) and etas[0] == nearest) for etas in split_chains(todo, n_chains)]
    # the costliest chain first, so that a cluster never starts it last: the one at the slow end, whose points sit at
    # the engine's minimum load; each chain is independent, so the order changes nothing in the front
    chains.reverse()
    for p in runner.chains(spec, chains, warm_start is False, report, warm_start is True):
        done[p.eta_h] = p
    points = [done[h] for h in grid.tolist()]
    resolves = _resolve_failed(spec, points, runner)
    risen, again = _monotone(spec, points, rtol, runner) if spec.objective == "fuel" else (0, 0)
    return _dataset(spec, points, t_min, t_slow, resolves, (risen, again), n_chains)


def _resolve_failed(spec: FrontSpec, points: list[FrontPoint], runner: SerialRunner | DaskRunner) -> int:
    """Solve each point whose chain solve failed once more, from the optimiser's own start; the re-solves made."""
    failed = [
        i
        for i, p in enumerate(points)
        if p.kind == "eta" and not p.ok and not p.status.startswith("infeasible: earliest")
    ]
    for i in failed:
        (q,) = runner.resolve(spec, points[i].eta_h, [None])
        points[i] = replace_fields(q, runtime_s=points[i].runtime_s + q.runtime_s) if q.ok else points[i]
    return len(failed)


def _monotone(
    spec: FrontSpec, points: list[FrontPoint], rtol: float, runner: SerialRunner | DaskRunner
) -> tuple[int, int]:
    """Points whose own solve ended above an earlier ETA's fuel: solved once more from that plan; (risen, re-solved).

    Arriving by an ETA may arrive earlier (``eta_mode="le"``), so the earlier ETA's verified plan is a verified
    start of the later one, and the floor of its solve (the plan stage never returns worse than the verified
    start): that one re-solve, started from it alone (:func:`~optroute.studies.front_points.solve_point`'s
    ``end_adjacent``), ends at most at its fuel, lower where Ipopt finds better.  The first solve's fuel stays
    beside the point (``own_fuel_t``) and its status says so.  Only a re-solve that fails, or rises all the same,
    leaves the point with the earlier ETA's plan: a risen point.  Ascending ETA, so that a re-solved point is the
    next one's floor.
    """
    risen = again = 0
    best_before = math.inf
    best_point: FrontPoint | None = None
    for i, p in enumerate(points):
        if p.ok and p.fuel_t > best_before * (1.0 + rtol) and best_point is not None:
            again += 1
            (q,) = runner.resolve(spec, p.eta_h, [best_point], end_adjacent=True)
            spent = {
                "runtime_s": p.runtime_s + q.runtime_s,
                "iterations": p.iterations + q.iterations,
                "nlp_solves": p.nlp_solves + q.nlp_solves,
                "dual_starts": p.dual_starts + q.dual_starts,
            }
            first = f"its first solve ({p.status}) ended {p.fuel_t:.6g} t, above {best_before:.6g} t"
            if q.ok and q.fuel_t <= best_before * (1.0 + rtol):
                status = f"{q.status}; solved again from the plan of the earlier ETA {best_point.eta_h:.6g} h: {first}"
                points[i] = p = replace_fields(q, kind=p.kind, own_fuel_t=p.fuel_t, status=status, **spent)
            else:
                risen += 1
                points[i] = p = replace_fields(
                    best_point,
                    eta_h=p.eta_h,
                    kind=p.kind,
                    warm_start=p.warm_start,
                    carry=p.carry,
                    own_fuel_t=p.fuel_t,
                    status=f"{best_point.status.split(';')[0]}; the plan of the earlier ETA {best_point.eta_h:.6g} h "
                    f"(arrives earlier): this ETA's own solve ({p.status}) ended {p.fuel_t:.6g} t, above its "
                    f"{best_before:.6g} t; solved again from that plan: {q.status}, {q.fuel_t:.6g} t",
                    **spent,
                )
        if p.ok and p.fuel_t < best_before:
            best_before, best_point = p.fuel_t, p
    return risen, again


def _dataset(
    spec: FrontSpec,
    points: list[FrontPoint],
    t_min: float,
    t_slow: float,
    resolves: int,
    risen: tuple[int, int],
    n_chains: int,
) -> TradeoffFront:
    eta_h = np.array([p.eta_h for p in points], dtype=float)
    data = {**_point_variables(points), **_track_variables(points)}
    etas = np.array([spec.departure + h_to_timedelta(h) for h in eta_h], dtype="datetime64[ns]")
    fuel = data["fuel_t"][1]
    ok = np.isfinite(fuel)
    knee = knee_index(eta_h[ok], fuel[ok])
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
        "risen_points": int(risen[0]),
        "risen_resolves": int(risen[1]),
        "chains": int(n_chains),
        "conventions": "eta UTC; eta_h, waypoint_time_h hours after departure; lat/lon deg; heading deg true (to)",
    }
    return TradeoffFront(data, coords={"eta": etas, "eta_h": ("eta", eta_h, {"units": "h"})}, attrs=attrs)


def _point_variables(points: list[FrontPoint]) -> dict[str, Any]:
    """Each point's totals and how it was solved: one value per ETA."""

    def col(key: str) -> np.ndarray:
        return np.array([p.totals.get(key, math.nan) for p in points], dtype=float)

    return {
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
        "dual_starts": (
            "eta",
            np.array([p.dual_starts for p in points], dtype=np.int64),
            {"long_name": "Ipopt calls of the point's solve started from the neighbour's multipliers too"},
        ),
        "own_fuel_t": (
            "eta",
            np.array([p.fuel_t if p.own_fuel_t is None else p.own_fuel_t for p in points], dtype=float),
            {"units": "t", "long_name": "fuel of the point's own solve (above fuel_t where it rose)"},
        ),
    }


def _track_variables(points: list[FrontPoint]) -> dict[str, Any]:
    """Each point's waypoints, times and legs, NaN-padded to the longest track: (eta, waypoint) and (eta, leg)."""
    n_wp = max((p.waypoints.shape[0] for p in points if p.waypoints is not None), default=0)
    n_leg = max(n_wp - 1, 0)

    def padded(get: Callable[[FrontPoint], np.ndarray | None], size: int) -> np.ndarray:
        out = np.full((len(points), size), np.nan)
        for i, p in enumerate(points):
            a = get(p)
            if a is not None:
                out[i, : a.size] = a
        return out

    data: dict[str, Any] = {
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
    return data
