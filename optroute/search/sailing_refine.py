"""Continuous refinement of a sailing route: the tack points move off the lattice (issue 18 item 3, standalone).

The graph route fixes the *side* of the no-go sector on every board (the
disjunction "port or starboard tack" decided by the discrete search, as the
corridor optimiser takes a danger band's side from its start); the refinement
then moves the tack points continuously.  Each board becomes a straight line
between two tack points, cut into ``n`` equal sub-legs (``n`` fixed from the
graph route, about ``sub_nm`` each); a sub-leg is sailed as the graph's legs
are — the polar speed for its course in the wind at its start and time
(:class:`~optroute.weather.sample.WeatherSampler`, :meth:`SailingVessel.leg_speed_kn`)
— and its signed true wind angle must stay on its board's side, outside the
no-go sector: ``side · TWA ≥ no_go + margin``.  The arrival time is minimised
over the tack points by SLSQP (scipy) with finite-difference gradients.

This is **not** the corridor optimiser's CasADi/Ipopt machinery: the sailing
model (a polar patch in numba, the wind of the weather sampler) is not in
CasADi's expression graph, and the corridor NLP's band sides are speed bands,
not heading sectors.  The result is a local optimum near the graph route; it
is returned only when the referee (:meth:`SailingRoute.verify`) accepts it,
it touches no land and it is faster — otherwise the graph route comes back
with the reason in ``stats["refinement"]``.
"""

from __future__ import annotations

import dataclasses
import time as _time

import numpy as np
import xarray as xr
from scipy.optimize import minimize

from optroute import geodesy as geo
from optroute import units
from optroute.errors import ConfigError, WeatherCoverageError
from optroute.geo import land
from optroute.physics.yacht import SailingVessel, check_vessel, tack_of, wind_kn_from
from optroute.search.sailing import SailingRoute, manoeuvres_along, sailing_sampler


def boards_of(route: SailingRoute) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tack points (lat, lon) [deg], each board's side (+1 starboard, −1 port) and its leg count."""
    side = tack_of(route.twa_deg)
    pts, sides, counts = [0], [], []
    cur, n = 0, 0
    for k, s in enumerate(side):
        if s and cur and s != cur:
            pts.append(k)
            sides.append(cur)
            counts.append(n)
            n = 0
        cur = s or cur
        n += 1
    pts.append(len(side))
    sides.append(cur)
    counts.append(n)
    idx = np.array(pts)
    sgn = np.where(np.array(sides) == 1, 1.0, -1.0)
    return np.stack([route.lat_deg[idx], route.lon_deg[idx]], axis=1), sgn, np.array(counts)


def sail_boards(points, n_sub, sampler, vessel, t0, t_guess=None):
    """Sub-leg ends, times [h], courses, TWAs, speeds, lengths of the boards through ``points`` (k+1, 2)."""
    lat, lon = [points[0, 0]], [points[0, 1]]
    for b in range(points.shape[0] - 1):
        f = np.arange(1, n_sub[b] + 1) / n_sub[b]
        lat.extend(points[b, 0] + f * (points[b + 1, 0] - points[b, 0]))
        lon.extend(points[b, 1] + f * (points[b + 1, 1] - points[b, 1]))
    lat, lon = np.array(lat), np.array(lon)
    course = geo.initial_course_deg(lat[:-1], lon[:-1], lat[1:], lon[1:])
    length = geo.distance_nm(lat[:-1], lon[:-1], lat[1:], lon[1:])
    # each sub-leg starts when the previous one ends: a triangular system solved by sweeping all sub-legs at once
    # (vectorised sampling) until the times repeat; sweep k fixes at least sub-leg k, so it ends
    t = np.zeros(lat.size) if t_guess is None else t_guess.copy()  # a nearby trial's times: a few sweeps
    floor = 1e-3 * vessel.polar.max_speed_kn
    for _ in range(course.size + 2):
        wx = sampler.sample(t0 + units.h_to_timedelta(t[:-1]), lat[:-1], lon[:-1], variables=["wind_u_ms", "wind_v_ms"])
        tws, frm = wind_kn_from(wx["wind_u_ms"], wx["wind_v_ms"])
        spd, twa, _ = vessel.leg_speed_kn(course, frm, tws, source=sampler.source)
        # inside the no-go sector (a trial point, or the straightened start): the speed at the limit angle,
        # continuous for SLSQP, whose side constraints push it out; a route with such a sub-leg is never returned
        v = np.where(spd > 0, spd, vessel.polar.speed_kn_at(np.full(spd.shape, vessel.polar.no_go_deg), tws))
        t_new = np.concatenate([[0.0], np.cumsum(length / np.maximum(v, floor))])
        done = np.max(np.abs(t_new - t)) < 1e-11
        t = t_new
        if done:
            break
    return lat, lon, t, course, twa, spd, length


def refine_sailing_route(
    route: SailingRoute,
    weather: xr.Dataset,
    vessel: SailingVessel,
    *,
    sub_nm: float = 1.0,
    margin_deg: float = 0.5,
    max_iter: int = 60,
    trust_deg: float = 0.05,
) -> SailingRoute:
    """Move the tack points of a graph route to shorten the passage (see the module text).

    Parameters
    ----------
    route : SailingRoute
        A route of :func:`~optroute.search.sailing.search_sailing_route` (no motoring legs).
    weather : xarray.Dataset
        The weather it was searched in (with ``wind_u_ms``/``wind_v_ms``).
    vessel : SailingVessel
    sub_nm : float
        Sub-leg length [nm] on which the wind is re-read.
    margin_deg : float
        Clearance from the no-go limit kept by every sub-leg [deg].
    max_iter : int
        SLSQP iterations.
    trust_deg : float
        How far a tack point may move in latitude and in longitude [deg].

    Returns
    -------
    SailingRoute
        The refined route (``status`` names SLSQP's exit, never "optimal": a
        local optimum), or the graph route when the refinement is rejected;
        ``stats["refinement"]`` says which and why, ``stats["graph_passage_h"]``
        the graph route's time.
    """
    vessel = check_vessel(vessel)
    if not (np.isfinite(sub_nm) and sub_nm > 0 and np.isfinite(margin_deg) and margin_deg >= 0):
        raise ConfigError(f"sub_nm={sub_nm} must be > 0 [nm] and margin_deg={margin_deg} >= 0 [deg]")
    started = _time.perf_counter()
    if route.motoring.any():
        return keep_graph_route(route, "not refined: the route motors on some legs (no tack side there)", started)
    pts0, sides, _ = boards_of(route)
    blen = geo.distance_nm(pts0[:-1, 0], pts0[:-1, 1], pts0[1:, 0], pts0[1:, 1])
    n_sub = np.maximum(np.ceil(blen / sub_nm).astype(int), 1)
    sampler = sailing_sampler(weather)
    limit = vessel.polar.no_go_deg + margin_deg
    side_of = np.repeat(sides, n_sub)
    cache: dict[bytes, tuple] = {}
    last: list[np.ndarray] = []

    def sail(x: np.ndarray) -> tuple:
        key = x.tobytes()
        if key not in cache:
            pts = pts0.copy()
            pts[1:-1] = x.reshape(-1, 2)
            cache.clear()
            cache[key] = sail_boards(pts, n_sub, sampler, vessel, route.time[0], last[0] if last else None)
            last[:] = [cache[key][2]]
        return cache[key]

    def objective(x):
        return sail(x)[2][-1]

    def sides_ok(x):
        return side_of * sail(x)[4] - limit

    x0 = pts0[1:-1].ravel()
    if x0.size == 0:
        res = None
        x = x0
    else:
        bounds = [(v - trust_deg, v + trust_deg) for v in x0]
        try:
            res = minimize(objective, x0, method="SLSQP", constraints=[{"type": "ineq", "fun": sides_ok}],
                           bounds=bounds, options={"maxiter": int(max_iter), "eps": 1e-6, "ftol": 1e-9})  # fmt: skip
        except WeatherCoverageError as exc:
            return keep_graph_route(route, f"rejected: a trial left the weather ({exc})", started)
        x = res.x
    status = f"refined (SLSQP: {res.message})" if res is not None else "refined (one board: the straight line)"
    return accept_refinement(route, weather, vessel, sail(x), side_of, limit, status, started)


def accept_refinement(
    route: SailingRoute,
    weather: xr.Dataset,
    vessel: SailingVessel,
    sailed: tuple,
    side_of: np.ndarray,
    limit_deg: float,
    status: str,
    started: float,
    stats: dict | None = None,
) -> SailingRoute:
    """The refined route if it is sailable, faster, off land and passes the referee; else the graph route.

    Parameters
    ----------
    route : SailingRoute
        The graph route that was refined.
    weather, vessel
        As for :func:`refine_sailing_route`.
    sailed : tuple
        :func:`sail_boards`' output for the refined tack points (the true model's sub-legs).
    side_of : ndarray
        Each sub-leg's board side (+1 starboard, −1 port).
    limit_deg : float
        The ``|TWA|`` the refinement aimed to keep [deg] (no-go limit plus a margin); the route is
        accepted while every sub-leg keeps its board's side outside the no-go limit itself, and
        ``stats["min_twa_margin_deg"]`` reports the clearance it kept from ``limit_deg``.
    status : str
        The refined route's status (the method and its solver's exit).
    started : float
        ``time.perf_counter()`` at the refinement's start.
    stats : dict, optional
        Extra entries for the refined route's ``stats``.
    """
    lat, lon, t, course, twa, spd, length = sailed
    worst = float(np.min(side_of * twa)) if twa.size else 180.0
    if np.any(spd <= 0) or worst < vessel.polar.no_go_deg:
        return keep_graph_route(route, f"rejected: the refinement ({status}) sails at |TWA| {worst:.3f} deg on a "
                                f"board's side, inside the no-go limit {vessel.polar.no_go_deg:g} deg", started)  # fmt: skip
    if t[-1] >= route.passage_h:
        return keep_graph_route(
            route, f"rejected: no faster ({t[-1]:.4f} h against the graph's {route.passage_h:.4f} h)", started
        )
    if land.legs_cross_land(lat[:-1], lon[:-1], lat[1:], lon[1:], 0.25, weather=None,
                            use_land_mask=land.coastline_applies(weather, None)).any():  # fmt: skip
        return keep_graph_route(route, "rejected: a refined board touches land", started)
    time = route.time[0] + units.h_to_timedelta(t)
    man = manoeuvres_along(twa, np.zeros(twa.size, dtype=bool), time, t, lat, lon)
    stats = {**route.stats, "graph_passage_h": route.passage_h, "refine_s": _time.perf_counter() - started,
             "refinement": "refined", "boards": int(np.count_nonzero(np.diff(side_of)) + 1),
             "sub_legs": int(side_of.size), "min_twa_margin_deg": worst - limit_deg, **(stats or {})}  # fmt: skip
    refined = SailingRoute(
        lat_deg=lat, lon_deg=lon, time=time, t_h=t, course_deg=course, twa_deg=twa, speed_kn=spd, length_nm=length,
        motoring=np.zeros(twa.size, dtype=bool), manoeuvres=tuple(man),
        heading_changes=int(np.count_nonzero(np.abs(np.diff(course)) > 1e-6)), objective=route.objective,
        status=status, stats=stats,
    )  # fmt: skip
    check = refined.verify(weather, vessel)
    if not check["ok"]:
        return keep_graph_route(route, f"rejected by the referee: {check}", started)
    return refined


def keep_graph_route(route: SailingRoute, why: str, started: float) -> SailingRoute:
    stats = {**route.stats, "graph_passage_h": route.passage_h, "refinement": why,
             "refine_s": _time.perf_counter() - started}  # fmt: skip
    return dataclasses.replace(route, stats=stats)
