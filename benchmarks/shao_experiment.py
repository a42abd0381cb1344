"""Shao et al.'s (3-D DP) case studies as the paper sets them: lattice, baseline, the IMO f_w estimate, the evidence.

The pieces :mod:`benchmarks.bench_shao` runs and prints, importable by the tests:

* :func:`dp_options` — the paper's lattice (Tabla 4): 16 stages (15 legs, ΔX = the great circle / 15,
  360.65 nm on the WGS84 ellipsoid against the paper's 360 nm on its 5 400 nm), ΔY 75 nm, 17 lateral
  states per stage (N(k) = 17: ±600 nm), Δt 1 h;
* :func:`lattice_speeds` — the paper's speed set, 5–30 kn every 1 kn, without the speeds above the
  ship's calm-water speed at MCR (26.5 kn for ``container_54k_dwt``; the DP's MCR check would reject
  them on every leg);
* :func:`baseline_curve` — the paper's "MEPC" strategy: one constant speed on the shortest safe route
  (the DP's lattice with that one speed: in the uniform background sea the fuel at one speed is the
  fuel rate times the distance over the speed, so the DP's least-fuel route is the shortest one that
  keeps out of the no-go areas when a ship at that speed gets there);
* :func:`fw_fuel_t` — the IMO MEPC.1/Circ.796 weather-factor estimate of a constant-speed schedule;
* :func:`storm_clearance` — how far a route keeps from the bad weather and the islands at the times it
  passes them (the evidence of whether the storm binds at all).
"""

from __future__ import annotations

import multiprocessing
import os
import resource
import time
import warnings
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

import optroute as orx
from optroute import geodesy
from optroute.geo.land import SYNTHETIC_GEOGRAPHY
from optroute.physics.speed_loss import imo_fw, imo_fw_capacity
from optroute.weather.scenarios import SHAO_START_END, shao_no_go

SHIP = "container_54k_dwt"
PAPER_LEGS = 15
"""Shao et al. (Tabla 4): K = 16 stages from departure to arrival, so 15 legs of ΔX."""
PAPER_DY_NM = 75.0
PAPER_HALF_WIDTH_NM = 600.0
"""N(k) = 17 lateral states at the inner stages (Tabla 4): ±8 × 75 nm."""
PAPER_DT_H = 1.0
PAPER_SPEEDS_KN = (5.0, 30.0, 1.0)
"""5–30 kn (Tabla 4); the paper gives no step, 1 kn is ours."""


def great_circle_nm() -> float:
    """Distance (0°, 0°) → (0°, 90° E) on the WGS84 ellipsoid [nm] (5 409.7; the paper's sphere: 5 400)."""
    return float(geodesy.distance_nm(*SHAO_START_END[0], *SHAO_START_END[1]))


def dp_options(legs: int = PAPER_LEGS, dy_nm: float = PAPER_DY_NM, half_width_nm: float = PAPER_HALF_WIDTH_NM,
               dt_h: float = PAPER_DT_H) -> dict[str, float]:  # fmt: skip
    """``solve_dp`` options for a lattice of ``legs`` equal legs (ΔX = great circle / legs) [nm, h]."""
    return {"dx_nm": great_circle_nm() / legs, "dy_nm": dy_nm, "half_width_nm": half_width_nm, "dt_h": dt_h}


def lattice_speeds(ship: orx.Ship, lo_kn: float = PAPER_SPEEDS_KN[0], hi_kn: float = PAPER_SPEEDS_KN[1],
                   step_kn: float = PAPER_SPEEDS_KN[2]) -> np.ndarray:  # fmt: skip
    """The DP's speed set [kn]: ``lo_kn`` to ``min(hi_kn, calm speed at MCR)`` every ``step_kn``."""
    top = min(hi_kn, ship.max_calm_speed_kn)
    return np.arange(lo_kn, top + 1e-9, step_kn)


WORKERS = max(1, int(os.environ.get("OPTROUTE_BENCH_WORKERS", "0")) or min(2, os.cpu_count() or 1))
"""Processes the baseline's one-speed searches run in (``$OPTROUTE_BENCH_WORKERS``, default 2 or the cores).

Each search is independent of the others (its own speed, its own labels), so they run side by side
with the same figures as one after the other (:func:`pool_map`)."""

_JOB: list[tuple[Callable[[Any], Any], list[Any]]] = []
"""The function and items of the running :func:`pool_map` (inherited by the forked workers, not pickled)."""


def _run_job(i: int) -> Any:
    fn, items = _JOB[0]
    return fn(items[i])


def pool_map(fn: Callable[[Any], Any], items: Iterable[Any], workers: int = WORKERS) -> list[Any]:
    """``[fn(x) for x in items]``, in ``workers`` forked processes when there is more than one item.

    ``fn`` and the items reach the workers by ``fork`` (a closure over a 158 MB dataset needs no
    pickling); only the results are pickled back. Without ``fork`` (or one worker) it runs here.
    """
    items = list(items)
    if workers <= 1 or len(items) <= 1 or "fork" not in multiprocessing.get_all_start_methods():
        return [fn(x) for x in items]
    _JOB[:] = [(fn, items)]
    try:
        pool = multiprocessing.get_context("fork").Pool(min(workers, len(items)))
        try:
            return pool.map(_run_job, range(len(items)), chunksize=1)
        finally:
            pool.close()
            pool.join()  # reaped: their CPU time is in :func:`cpu_s`
    finally:
        _JOB.clear()


def cpu_s() -> float:
    """CPU time [s] of this process and of its reaped children (the :func:`pool_map` workers): user + system."""
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + kids.ru_utime + kids.ru_stime


_SAMPLER: list[tuple[Any, orx.WeatherSampler]] = []
"""The last dataset searched and its sampler (one at a time: a case's 158 MB weather and its point arrays)."""


def sampler_of(wx: Any) -> orx.WeatherSampler:
    """One :class:`WeatherSampler` per dataset, kept for the next search on it.

    ``search_route`` given the dataset builds a sampler, its compiled point arrays and the ports'
    snapping on every call: ~1.5 CPU-s of the ~3.5 of a one-speed search on the paper's lattice,
    paid ~40 times per case by the baseline's searches.
    """
    if not _SAMPLER or _SAMPLER[0][0] is not wx:
        _SAMPLER.clear()
        _SAMPLER.append((wx, orx.WeatherSampler(wx)))
    return _SAMPLER[0][1]


def _coast(wx: Any) -> bool:
    """Whether the coastline applies to ``wx`` (not to synthetic geography: Shao et al.'s equator crosses Africa)."""
    return wx.attrs.get("geography") != SYNTHETIC_GEOGRAPHY


def search(wx: Any, ship: orx.Ship, t0: np.datetime64, dp: dict[str, float], **kw: Any) -> orx.Route:
    """``search_route(method="dp", objective="fuel")`` from (0°, 0°) to (0°, 90° E) on lattice ``dp``.

    Searched on the dataset's kept sampler (:func:`sampler_of`); the coastline is applied as
    ``search_route`` would for the dataset itself (not for synthetic geography, as Shao et al.'s sea).
    """
    coast = _coast(wx)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return orx.search_route(*SHAO_START_END, sampler_of(wx), ship, departure=t0, method="dp", objective="fuel",
                                dp_options=dict(dp), use_land_mask=coast, **kw)  # fmt: skip


def refereed(route: orx.Route, wx: Any, ship: orx.Ship, t0: np.datetime64) -> tuple[float, float]:
    """(the referee's fuel [t], its number of violations) of a DP route sailed as a plan (NaN, NaN if it cannot be)."""
    try:
        plan = orx.Plan.from_schedule(route.waypoints, route.stw_kn, departure=t0, ship=ship, weather=sampler_of(wx),
                                      times=route.times, use_land_mask=_coast(wx))  # fmt: skip
    except orx.OptrouteError:
        return float("nan"), float("nan")
    return plan.total_fuel_t, float(len(plan.verify()))


def one_speed(dp: dict[str, float]) -> dict[str, Any]:
    """The lattice ``dp`` for a one-speed search of the baseline: only its least-fuel route is wanted.

    ``least_fuel_only`` (:func:`optroute.search.solve_dp`): the labels whose fuel plus the fuel floor
    to the end exceeds the earliest route's are dropped; the route is the DP's own.
    """
    return {**dp, "least_fuel_only": True}


def baseline_curve(wx: Any, ship: orx.Ship, t0: np.datetime64, dp: dict[str, float], speeds_kn: np.ndarray,
                   latest_eta_h: float, *, referee: bool = True, workers: int = WORKERS) -> dict[str, Any]:  # fmt: skip
    """Per lattice speed: the shortest safe route sailed at that one speed (one search per speed, ``workers`` at a time).

    Returns arrival [h], the DP's own fuel [t], distance [nm], the referee's fuel [t] and its number of
    violations (NaN without ``referee``), the IMO f_w estimate [t] (:func:`fw_fuel_t`) and the route
    (None where no route exists at that speed). Speeds too slow to arrive by ``latest_eta_h`` even on
    the great circle are left out (they cannot be the baseline at any ETA compared).
    """
    speeds = np.asarray(speeds_kn, dtype=float)
    speeds = speeds[great_circle_nm() / speeds <= latest_eta_h]
    arrival, fuel, dist, ref, viol, fw = (np.full(speeds.size, np.nan) for _ in range(6))
    sampler_of(wx)  # built once, before the workers fork

    def one(v: float) -> orx.Route | None:
        try:
            return search(wx, ship, t0, one_speed(dp), speeds_kn=[v])
        except orx.OptrouteError:  # no safe passage at this speed (or beyond the weather's span)
            return None

    routes: list[orx.Route | None] = pool_map(one, [float(v) for v in speeds], workers)
    for k, (v, r) in enumerate(zip(speeds, routes, strict=True)):
        if r is None:
            continue
        arrival[k], fuel[k], dist[k] = r.total_duration_h, r.total_fuel_t, r.total_distance_nm
        fw[k] = fw_fuel_t(ship, float(v), r.total_duration_h)
        if referee:
            ref[k], viol[k] = refereed(r, wx, ship, t0)
    return {"speed_kn": speeds, "arrival_h": arrival, "fuel_t": fuel, "distance_nm": dist, "referee_fuel_t": ref,
            "violations": viol, "fw_fuel_t": fw, "routes": routes}  # fmt: skip


def exact_baseline(wx: Any, ship: orx.Ship, t0: np.datetime64, dp: dict[str, float], eta_h: float,
                   *, guess_nm: float | None = None, referee: bool = True, max_iter: int = 4) -> dict[str, Any]:  # fmt: skip
    """The paper's "MEPC" strategy at one ETA: the one constant speed that arrives at ``eta_h`` on its shortest safe route.

    Fixed point: start at ``guess_nm`` (default the great circle) over the ETA; the lattice's shortest safe route at that one
    speed (:func:`search`) sets the next speed, its length over the ETA; stop when the route (and so the
    speed) repeats. The speed is not on the DP's speed set: the DP mixes its lattice speeds to approach
    it. Returns speed [kn], arrival [h], fuel [t] (the DP's accounting), distance [nm], the referee's fuel
    [t] and violations, the IMO f_w estimate [t] and the route; NaN / None where no constant speed works
    (the route's length never settles, or no safe route exists at that speed).
    """
    nan = float("nan")
    out: dict[str, Any] = {"speed_kn": nan, "arrival_h": nan, "fuel_t": nan, "distance_nm": nan,
                           "referee_fuel_t": nan, "violations": nan, "fw_fuel_t": nan, "route": None}  # fmt: skip
    v = (great_circle_nm() if guess_nm is None else guess_nm) / eta_h
    for _ in range(max_iter):
        try:
            r = search(wx, ship, t0, one_speed(dp), speeds_kn=[v])
        except orx.OptrouteError:
            return out
        v_next = r.total_distance_nm / eta_h
        if abs(v_next - v) < 1e-9 * v:
            break
        v = v_next
    else:
        return out
    out.update(speed_kn=v, arrival_h=r.total_duration_h, fuel_t=r.total_fuel_t, distance_nm=r.total_distance_nm,
               fw_fuel_t=fw_fuel_t(ship, v, r.total_duration_h), route=r)  # fmt: skip
    if referee:
        out["referee_fuel_t"], out["violations"] = refereed(r, wx, ship, t0)
    return out


def baseline_at(curve: dict[str, Any], eta_h: float) -> int | None:
    """Index of the lattice speed whose constant-speed route arriving by ``eta_h`` uses least fuel (None: none does).

    No interpolation between speeds: the baseline is a schedule the DP's lattice can represent.
    """
    ok = np.isfinite(curve["arrival_h"]) & (curve["arrival_h"] <= eta_h + 1e-9)
    if not ok.any():
        return None
    idx = np.flatnonzero(ok)
    return int(idx[np.argmin(curve["fuel_t"][idx])])


def dp_at(curve_end_h: np.ndarray, curve_fuel_t: np.ndarray, eta_h: float) -> float:
    """The DP's least fuel [t] over its arrival bins that end by ``eta_h`` (NaN when none does)."""
    ok = np.isfinite(curve_fuel_t) & (curve_end_h <= eta_h + 1e-9)
    return float(np.min(curve_fuel_t[ok])) if ok.any() else float("nan")


def fw_factor(ship: orx.Ship) -> float:
    """The IMO standard weather factor f_w of ``ship`` (MEPC.1/Circ.796 Table 1; Capacity = 70 % DWT for containers)."""
    return float(imo_fw(ship.ship_type, imo_fw_capacity(ship.ship_type, ship.dwt_t)))


def fw_fuel_t(ship: orx.Ship, sog_kn: float, duration_h: float) -> float:
    """The IMO f_w method's fuel [t] for ``duration_h`` at a constant ``sog_kn`` in the representative sea.

    MEPC.1/Circ.796: in the representative sea (Beaufort 6 head seas) the ship makes f_w times its
    calm-water speed at the same power; so making ``sog_kn`` there takes the calm-water power of
    ``sog_kn / f_w``, burnt at the ship's SFOC for the whole passage (Shao et al. compare this
    regression estimate with the DP's Kwon-based one). NaN where ``sog_kn / f_w`` exceeds the calm-water
    speed at MCR: by the f_w method the ship cannot make that speed.
    """
    v_calm = sog_kn / fw_factor(ship)
    if v_calm > ship.max_calm_speed_kn:
        return float("nan")
    return float(ship.fuel_rate_tph(ship.calm_power_kw(v_calm))) * duration_h


def storm_clearance(route: orx.Route, case: int, t0: np.datetime64, step_nm: float = 10.0) -> dict[str, float]:
    """How close ``route``, sailed on its own schedule, comes to the bad weather and to the islands [nm].

    The route is sampled every ``step_nm`` along its legs (constant speed on each leg); at each point
    inside the rectangles' longitudes (50–70° E) the latitude distance to each rectangle at that time
    is taken (0 inside). Returns the least clearance to the storm and to the islands [nm], the hours
    the route is abreast of the rectangles (first and last sample inside their longitudes) and the
    route's length over the great circle [nm].
    """
    wp = np.asarray(route.waypoints, float)
    hours = (np.asarray(route.times) - t0) / np.timedelta64(1, "s") / 3600.0
    lat, lon, t = [], [], []
    for k in range(len(wp) - 1):
        d = float(geodesy.distance_nm(*wp[k], *wp[k + 1]))
        f = np.linspace(0.0, 1.0, max(2, int(np.ceil(d / step_nm)) + 1))
        la, lo = geodesy.intermediate_points(wp[k, 0], wp[k, 1], wp[k + 1, 0], wp[k + 1, 1], f)
        lat.append(la)
        lon.append(lo)
        t.append(hours[k] + f * (hours[k + 1] - hours[k]))
    lat, lon, t = np.concatenate(lat), np.concatenate(lon), np.concatenate(t)
    inside = (lon >= 50.0) & (lon <= 70.0)
    out = {"storm_nm": float("inf"), "islands_nm": float("inf"), "abreast_from_h": float("nan"),
           "abreast_to_h": float("nan"), "excess_nm": float(route.total_distance_nm) - great_circle_nm()}  # fmt: skip
    if not inside.any():
        return out
    out["abreast_from_h"], out["abreast_to_h"] = float(t[inside].min()), float(t[inside].max())
    for la, h in zip(lat[inside], t[inside], strict=True):
        islands, storm = shao_no_go(case, float(h), start=t0)
        for key, area in (("islands_nm", islands), ("storm_nm", storm)):
            gap = max(area.lat_min - la, la - area.lat_max, 0.0) * 60.0
            out[key] = min(out[key], gap)
    return out


def storm_cover_h(case: int, lat_deg: float, t0: np.datetime64, horizon_h: float = 400.0) -> tuple[float, float] | None:
    """First and last hour (every 0.5 h up to ``horizon_h``) the storm's rectangle covers latitude ``lat_deg`` (None: never)."""
    hours = np.arange(0.0, horizon_h + 1e-9, 0.5)
    cover = [h for h in hours if (a := shao_no_go(case, float(h), start=t0)[1]).lat_min <= lat_deg <= a.lat_max]
    return (float(cover[0]), float(cover[-1])) if cover else None


def gap_lat_deg(dy_nm: float) -> float:
    """The lattice's first latitude south of the islands (below −1°) [deg]: a multiple of ΔY from the equator."""
    return -float(np.floor(60.0 / dy_nm) + 1.0) * dy_nm / 60.0
