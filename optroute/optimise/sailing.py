"""Continuous refinement of a sailing route by the corridor optimiser's machinery (Życkowski, issue 18 item 3).

The graph route of :func:`~optroute.search.sailing.search_sailing_route` settles the disjunction
"port OR starboard tack" on every board, as the search's start settles a danger band's side for
the corridor NLP.  With the sides fixed, :func:`formulations.sailing_nlp.solve_sailing_boards`
moves the tack points by Ipopt (exact first derivatives through CasADi), each sub-leg's true wind
angle kept on its board's side outside the no-go sector.  The wind the NLP reads is the sampler's
own piecewise-linear interpolation, so the passage time has kinks wherever a sub-leg's start crosses
a grid line: an exact Hessian there is meaningless and Ipopt's Newton steps stall (on the Gulf of
Gdańsk case it ended at its iteration limit no faster than the graph route).  Ipopt therefore
runs with a limited-memory BFGS Hessian, the quasi-Newton choice that works well on nonsmooth
objectives (Lewis and Overton, "Nonsmooth optimization via quasi-Newton methods", Math.
Programming 2013); on such a problem it often stops at its iteration limit circling a kink rather
than meeting its tolerance, so its last iterate is used whatever its exit, and it is judged only
by the true model and the referee below — the returned ``status`` names Ipopt's exit verbatim and
is never "optimal".  Inside the NLP the polar is a B-spline of
``(cos TWA, TWS)`` tabulated from the true polar (its largest error on the table's cell midpoints
is measured and reported), the wind the sampler's own linear interpolation on the weather's grid.  The answer is then
re-sailed with the true model (:func:`~optroute.search.sailing_refine.sail_boards`: the polar's own
interpolation, the weather sampler, WGS84 geodesics) and returned only if the referee
(:meth:`SailingRoute.verify`) accepts it, it touches no land and it is faster than the graph route;
``stats`` carries the NLP's arrival beside the true one (the surrogate's error at the solution).

``method="slsqp"`` runs the earlier standalone refinement (scipy's SLSQP with finite differences
on the true model) for comparison.
"""

from __future__ import annotations

import dataclasses
import time as _time
from typing import Literal

import numpy as np
import xarray as xr

from formulations.sailing_nlp import solve_sailing_boards
from optroute import geodesy as geo
from optroute.errors import ConfigError, WeatherCoverageError
from optroute.physics.polar import Polar
from optroute.physics.yacht import SailingVessel, check_vessel
from optroute.search.sailing import SailingRoute, sailing_sampler
from optroute.search.sailing_refine import (
    accept_refinement,
    boards_of,
    keep_graph_route,
    sail_boards,
)
from optroute.search.sailing_refine import (
    refine_sailing_route as refine_sailing_route_slsqp,
)

__all__ = ["polar_cos_table", "refine_sailing_route"]


def polar_cos_table(polar: Polar, limit_deg: float, *, step_deg: float = 0.25, tws_per_cell: int = 8):
    """The polar tabulated on ``cos TWA`` × TWS for the NLP's B-spline, and its measured error.

    Parameters
    ----------
    polar : Polar
    limit_deg : float
        Smallest ``|TWA|`` the NLP may sail [deg]; the table starts a step inside it.
    step_deg : float
        Angle step of the table [deg].
    tws_per_cell : int
        Table columns per cell of the polar's own wind speeds.

    Returns
    -------
    cos_nodes, tws_nodes_kn, speed_kn : ndarray
        Ascending ``cos TWA`` nodes, TWS nodes [kn] and boat speeds [kn], shape (c, w).
    max_error_kn : float
        Largest difference [kn] between the B-spline through the table and the true polar at the
        table's cell midpoints (angles and wind speeds), where a spline's error peaks.
    """
    import casadi as ca

    lo = max(polar.no_go_deg, limit_deg - step_deg)
    twa = np.unique(np.concatenate([np.arange(180.0, lo, -step_deg), [lo]]))
    w = polar.tws_kn
    tws = np.unique(np.concatenate([np.linspace(w[i], w[i + 1], tws_per_cell + 1) for i in range(w.size - 1)]))
    cos_nodes = np.cos(np.radians(twa))[::-1].copy()
    twa_of_node = twa[::-1]
    speed = polar.speed_kn_at(twa_of_node[:, None], tws[None, :])
    spline = ca.interpolant("polar", "bspline", [cos_nodes, tws], speed.ravel(order="F"))
    mid_twa = 0.5 * (twa[1:] + twa[:-1])
    mid_tws = 0.5 * (tws[1:] + tws[:-1])
    a, s = np.meshgrid(mid_twa[mid_twa >= limit_deg], mid_tws, indexing="ij")
    true = polar.speed_kn_at(a, s)
    approx = np.asarray(spline(np.vstack([np.cos(np.radians(a.ravel())), s.ravel()]))).reshape(a.shape)
    return cos_nodes, tws, speed, float(np.max(np.abs(approx - true))) if a.size else 0.0


def _wind_box(weather: xr.Dataset, lat: np.ndarray, lon: np.ndarray, t0: np.datetime64, pad_deg: float):
    """The wind's grid around the route (one cell beyond the padded box), times in hours after ``t0``."""
    box = weather[["wind_u_ms", "wind_v_ms"]]
    for dim, vals in (("lat", lat), ("lon", lon)):
        ax = box[dim].values
        i0 = max(int(np.searchsorted(ax, vals.min() - pad_deg)) - 2, 0)
        i1 = min(int(np.searchsorted(ax, vals.max() + pad_deg)) + 2, ax.size)
        box = box.isel({dim: slice(i0, i1)})
    t_h = (box["time"].values - t0) / np.timedelta64(1, "h")
    return (t_h.astype(float), box["lat"].values, box["lon"].values), box["wind_u_ms"].values, box["wind_v_ms"].values


def refine_sailing_route(
    route: SailingRoute,
    weather: xr.Dataset,
    vessel: SailingVessel,
    *,
    method: Literal["ipopt", "slsqp"] = "ipopt",
    sub_nm: float = 1.0,
    margin_deg: float = 0.5,
    trust_deg: float = 0.05,
    max_iter: int = 200,
) -> SailingRoute:
    """Move the tack points of a graph route to shorten the passage (see the module text).

    Parameters
    ----------
    route : SailingRoute
        A route of :func:`~optroute.search.sailing.search_sailing_route` (no motoring legs).
    weather : xarray.Dataset
        The weather it was searched in (``wind_u_ms``/``wind_v_ms`` [m/s]).
    vessel : SailingVessel
    method : {"ipopt", "slsqp"}
        The CasADi/Ipopt board NLP, or the standalone SLSQP refinement (for comparison).
    sub_nm : float
        Sub-leg length [nm] on which the wind is re-read.
    margin_deg : float
        Clearance from the no-go limit kept by every sub-leg [deg].
    trust_deg : float
        How far a tack point may move in latitude and in longitude [deg].
    max_iter : int
        Solver iterations (Ipopt: its limit; its last iterate is judged by the true model whatever its exit).

    Returns
    -------
    SailingRoute
        The refined route (``status`` names the method and its solver's exit verbatim; never
        "optimal": a local optimum with the sides fixed), or the graph route when the refinement
        is rejected, ``stats["refinement"]`` saying which and why.  Ipopt's ``stats`` add
        ``nlp_passage_h`` (the NLP's own arrival), ``polar_table_error_kn``, ``ipopt_iterations``.
    """
    vessel = check_vessel(vessel)
    if method == "slsqp":
        return refine_sailing_route_slsqp(route, weather, vessel, sub_nm=sub_nm, margin_deg=margin_deg,
                                          max_iter=max_iter, trust_deg=trust_deg)  # fmt: skip
    if method != "ipopt":
        raise ConfigError(f"method={method!r} is not a refinement method; use 'ipopt' or 'slsqp'")
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
    lon_ax = weather["lon"].values
    if route.lon_deg.min() - trust_deg < lon_ax[0] or route.lon_deg.max() + trust_deg > lon_ax[-1]:
        # the NLP reads the wind on the dataset's own axis: a route in another longitude convention (or across
        # a periodic grid's seam) is left to the SLSQP method, which samples through the weather sampler
        return keep_graph_route(route, f"not refined: the route's longitudes {route.lon_deg.min():.3f} to "
                                f"{route.lon_deg.max():.3f} deg do not lie on the wind grid's axis {lon_ax[0]:.3f} to "
                                f"{lon_ax[-1]:.3f} deg; use method='slsqp'", started)  # fmt: skip
    c_nodes, w_nodes, table, table_err = polar_cos_table(vessel.polar, limit)
    grid, u, v = _wind_box(weather, route.lat_deg, route.lon_deg, route.time[0], trust_deg)
    res = solve_sailing_boards(
        pts0, sides, n_sub, polar_cos_nodes=c_nodes, polar_tws_nodes_kn=w_nodes, polar_speed_kn=table,
        wind_grid=grid, wind_u_ms=u, wind_v_ms=v, limit_deg=limit, trust_deg=trust_deg, max_iter=max_iter,
        ipopt_options={"hessian_approximation": "limited-memory"},
    )  # fmt: skip
    extra = {"nlp_passage_h": float(res.t_h[-1]), "polar_table_error_kn": table_err,
             "ipopt_iterations": res.iterations, "ipopt_status": res.status}  # fmt: skip
    if not np.all(np.isfinite(res.points_deg)) or not np.all(np.isfinite(res.t_h)):
        out = keep_graph_route(route, f"rejected: Ipopt ended with {res.status} at a non-finite iterate", started)
        return _with_stats(out, extra)
    try:
        sailed = sail_boards(res.points_deg, n_sub, sampler, vessel, route.time[0], res.t_h)
    except WeatherCoverageError as exc:
        return _with_stats(keep_graph_route(route, f"rejected: the refined boards leave the weather ({exc})",
                                            started), extra)  # fmt: skip
    extra["true_minus_nlp_passage_h"] = float(sailed[2][-1] - res.t_h[-1])
    return accept_refinement(route, weather, vessel, sailed, side_of, limit, f"refined (Ipopt: {res.status})",
                             started, extra)  # fmt: skip


def _with_stats(route: SailingRoute, extra: dict) -> SailingRoute:
    return dataclasses.replace(route, stats={**route.stats, **extra})
