"""Sailing boards as a CasADi/Ipopt NLP: the tack points move, each board stays on its side of the no-go sector.

Życkowski's graph route (Polish sailing paper) fixes, on every board, the *side* of the wind the boat
sails on (starboard or port tack) — the disjunction "port OR starboard" that the corridor optimiser
settles for a danger band from its start.  With the sides fixed, the continuous problem is:

* decision variables: the interior tack points' offsets (lat, lon) within a trust box of their
  start; each board is the straight line (in lat/lon) between its tack points, cut into ``n_sub``
  equal sub-legs, as :func:`optroute.search.sailing_refine.sail_boards` sails it;
* single shooting in time: sub-leg ``k`` starts when ``k − 1`` ends and is sailed at the polar speed
  for its course in the wind at its start point and start time, ``t[k+1] = t[k] + L_k / v_k``;
* its signed true wind angle keeps to its board's side, outside the no-go sector:
  ``cos TWA_k ≤ cos(limit)`` and ``side · sin TWA_k ≥ 0`` (both smooth: no angle is unwrapped);
* minimise the arrival time ``t[N]``.

The wind is read by piecewise-(bi/tri)linear interpolants on the weather's own grid — the weather
sampler's own interpolation, so the NLP and the referee read the same wind (a smooth B-spline of a
field that is rough at its grid scale differs from it by up to 0.7 m/s on the Gulf of Gdańsk case,
and its optimum broke the no-go sector in the true wind); the price is a passage time with kinks
where a sub-leg's start crosses a grid line, for which the caller asks Ipopt for a limited-memory
quasi-Newton Hessian (``ipopt_options``) rather than the exact one.  The boat
speed is a cubic B-spline of ``(cos TWA, TWS)`` tabulated from the true polar (speed is an even
function of TWA, so it is smooth in ``cos TWA`` at a dead run); its error is measured by the caller.
The sub-leg geometry is the local plane of the WGS84 ellipsoid at the sub-leg's middle latitude
(meridional and prime-vertical radii of curvature): relative error O((L/R)²), below 1e-7 for
1–3 nm sub-legs.  The caller re-sails the solution with the true model and the referee.

Only numpy arrays go in; the result is a frozen dataclass carrying Ipopt's own return status.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from formulations.common import FormulationInputError

__all__ = ["SailingBoardsResult", "solve_sailing_boards"]

_WGS84_A_M = 6378137.0
_WGS84_E2 = 6.69437999014e-3
_NM_M = 1852.0
_MS_TO_KN = 3600.0 / 1852.0


@dataclass(frozen=True)
class SailingBoardsResult:
    """Ipopt's answer for the boards.

    Attributes
    ----------
    points_deg : ndarray, shape (B + 1, 2)
        Tack points (lat, lon) [deg], the ends unchanged.
    t_h : ndarray, shape (N + 1,)
        Sub-leg end times [h after departure] in the NLP's model, N = ``n_sub.sum()``.
    status : str
        Ipopt's ``return_status``, verbatim.
    success : bool
        Ipopt's own success flag.
    iterations : int
        Ipopt iterations.
    solve_s : float
        Build and solve time [s].
    """

    points_deg: np.ndarray
    t_h: np.ndarray
    status: str
    success: bool
    iterations: int
    solve_s: float


def _interpolant(name: str, grid: list[np.ndarray], values: np.ndarray, method: str = "bspline"):
    import casadi as ca

    method = method if all(g.size >= 4 for g in grid) else "linear"
    return ca.interpolant(name, method, [np.asarray(g, dtype=float) for g in grid], values.ravel(order="F"))


def _check(points_deg, sides, n_sub, limit_deg, trust_deg) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    pts = np.asarray(points_deg, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] < 2 or not np.all(np.isfinite(pts)):
        raise FormulationInputError(f"points_deg must be finite (B+1, 2) with B >= 1, got shape {pts.shape}")
    sides = np.asarray(sides, dtype=float)
    n_sub = np.asarray(n_sub, dtype=int)
    if sides.shape != (pts.shape[0] - 1,) or not np.all(np.abs(sides) == 1.0):
        raise FormulationInputError(f"sides must hold ±1 per board ({pts.shape[0] - 1}), got {sides.tolist()}")
    if n_sub.shape != sides.shape or np.any(n_sub < 1):
        raise FormulationInputError(f"n_sub must hold >= 1 sub-legs per board, got {n_sub.tolist()}")
    if not (0.0 < limit_deg < 180.0 and trust_deg >= 0.0):
        raise FormulationInputError(f"limit_deg={limit_deg} must lie in (0, 180) and trust_deg={trust_deg} >= 0")
    return pts, sides, n_sub


def _fields(wind_grid, wind_u_ms, wind_v_ms, cos_nodes, tws_nodes_kn, speed_kn):
    """The wind as piecewise-(bi/tri)linear interpolants on its own grid — the weather sampler's own
    interpolation, so the NLP reads the wind the referee reads — and the polar as a cubic B-spline."""
    t_ax, lat_ax, lon_ax = (np.asarray(a, dtype=float) for a in wind_grid)
    u3, v3 = np.asarray(wind_u_ms, dtype=float), np.asarray(wind_v_ms, dtype=float)
    if t_ax.size == 1:  # a steady wind
        fu, fv = (_interpolant(k, [lat_ax, lon_ax], a[0], "linear") for k, a in (("u", u3), ("v", v3)))
    else:
        fu, fv = (_interpolant(k, [t_ax, lat_ax, lon_ax], a, "linear") for k, a in (("u", u3), ("v", v3)))
    polar = _interpolant("polar", [np.asarray(cos_nodes, dtype=float), np.asarray(tws_nodes_kn, dtype=float)],
                         np.asarray(speed_kn, dtype=float))  # fmt: skip
    return fu, fv, polar


def _board_nodes(ca, pts, n_sub: np.ndarray):
    """Sub-leg end points (lat, lon) [deg] as expressions of the tack points, linear in lat/lon along each board."""
    lat, lon = [pts[0][0]], [pts[0][1]]
    for b, n in enumerate(n_sub):
        for f in np.arange(1, n + 1) / n:
            lat.append(pts[b][0] + f * (pts[b + 1][0] - pts[b][0]))
            lon.append(pts[b][1] + f * (pts[b + 1][1] - pts[b][1]))
    return ca.vertcat(*lat), ca.vertcat(*lon)


def _local_plane(ca, lat, lon):
    """East and north components [m] of each sub-leg on the WGS84 tangent plane at its middle latitude."""
    phi = np.pi / 180.0 * 0.5 * (lat[:-1] + lat[1:])
    w = ca.sqrt(1.0 - _WGS84_E2 * ca.sin(phi) ** 2)
    m_rad = _WGS84_A_M * (1.0 - _WGS84_E2) / w**3  # meridional radius of curvature
    n_rad = _WGS84_A_M / w  # prime vertical radius of curvature
    d_east = n_rad * ca.cos(phi) * (np.pi / 180.0) * (lon[1:] - lon[:-1])
    d_north = m_rad * (np.pi / 180.0) * (lat[1:] - lat[:-1])
    return d_east, d_north


def solve_sailing_boards(
    points_deg: np.ndarray,
    sides: np.ndarray,
    n_sub: np.ndarray,
    *,
    polar_cos_nodes: np.ndarray,
    polar_tws_nodes_kn: np.ndarray,
    polar_speed_kn: np.ndarray,
    wind_grid: tuple[np.ndarray, np.ndarray, np.ndarray],
    wind_u_ms: np.ndarray,
    wind_v_ms: np.ndarray,
    limit_deg: float,
    trust_deg: float,
    max_iter: int = 200,
    tol: float = 1e-8,
    ipopt_options: dict | None = None,
) -> SailingBoardsResult:
    """Least-time tack points for boards whose sides are fixed (see the module text).

    Parameters
    ----------
    points_deg : ndarray, shape (B + 1, 2)
        Start, tack points and end (lat, lon) [deg]; the start guess for the interior ones.
    sides : ndarray, shape (B,)
        +1 starboard tack (wind over starboard, TWA > 0), −1 port, per board.
    n_sub : ndarray of int, shape (B,)
        Sub-legs per board.
    polar_cos_nodes, polar_tws_nodes_kn, polar_speed_kn
        The polar tabulated on ``cos TWA`` (ascending) × TWS [kn]: boat speed [kn], shape (c, w).
    wind_grid : (t_h, lat_deg, lon_deg)
        The wind's grid axes, ascending: hours after departure, latitude, longitude [deg]; a single
        time gives a steady wind.
    wind_u_ms, wind_v_ms : ndarray, shape (t, lat, lon)
        Wind components [m/s] (the direction the wind blows to: east, north).
    limit_deg : float
        Smallest allowed ``|TWA|`` [deg] (the no-go limit plus a margin).
    trust_deg : float
        Each interior tack point moves at most this far in latitude and in longitude [deg].
    max_iter : int
        Ipopt's iteration limit.
    tol : float
        Ipopt's tolerance.
    ipopt_options : dict, optional
        Further Ipopt options.

    Returns
    -------
    SailingBoardsResult
    """
    import casadi as ca

    pts0, sides, n_sub = _check(points_deg, sides, n_sub, limit_deg, trust_deg)
    started = time.perf_counter()
    n_int, n = pts0.shape[0] - 2, int(n_sub.sum())
    x_pts = ca.MX.sym("p", 2 * n_int)
    scale = max(trust_deg, 1e-9)  # the variables are the tack points' offsets in units of the trust box
    moved = pts0[1:-1].ravel() + scale * x_pts
    pts = [pts0[0]] + [moved[2 * i : 2 * i + 2] for i in range(n_int)] + [pts0[-1]]
    pts = [ca.vertcat(*(float(v) for v in p)) if isinstance(p, np.ndarray) else p for p in pts]
    lat, lon = _board_nodes(ca, [[p[0], p[1]] for p in pts], n_sub)
    d_east, d_north = _local_plane(ca, lat, lon)
    length_m = ca.sqrt(d_east**2 + d_north**2 + 1e-6)
    ce, cn = d_east / length_m, d_north / length_m  # the course's unit vector (east, north)
    fu, fv, polar = _fields(wind_grid, wind_u_ms, wind_v_ms, polar_cos_nodes, polar_tws_nodes_kn, polar_speed_kn)
    steady = np.asarray(wind_grid[0]).size == 1
    floor_kn = 1e-3 * float(np.max(polar_speed_kn))
    c_lo, c_hi = float(np.min(polar_cos_nodes)), float(np.max(polar_cos_nodes))
    w_lo, w_hi = float(np.min(polar_tws_nodes_kn)), float(np.max(polar_tws_nodes_kn))
    t, cos_twa, sin_twa = [ca.MX(0.0)], [], []
    for k in range(n):  # single shooting: sub-leg k starts when k − 1 ends, in the wind of that time
        at = ca.vertcat(lat[k], lon[k]) if steady else ca.vertcat(t[k], lat[k], lon[k])
        u, v = fu(at), fv(at)
        tws_ms = ca.sqrt(u**2 + v**2 + 1e-9)
        fe, fn = -u / tws_ms, -v / tws_ms  # the unit vector the wind comes from
        cos_twa.append(ce[k] * fe + cn[k] * fn)
        sin_twa.append(fe * cn[k] - fn * ce[k])  # sin(from − heading): + when the wind is over starboard
        # inside the no-go sector (a trial point only: the rows below keep the solution out) the speed at the
        # table's edge angle, so that the passage time stays continuous and finite for the line search
        c_in = ca.fmin(ca.fmax(cos_twa[k], c_lo), c_hi)
        speed_kn = polar(ca.vertcat(c_in, ca.fmin(ca.fmax(tws_ms * _MS_TO_KN, w_lo), w_hi)))
        t.append(t[k] + length_m[k] / _NM_M / ca.fmax(speed_kn, floor_kn))
    side_of = np.repeat(sides, n_sub)
    g = ca.vertcat(ca.vertcat(*cos_twa), side_of * ca.vertcat(*sin_twa))
    lbg = np.concatenate([np.full(n, -np.inf), np.zeros(n)])
    ubg = np.concatenate([np.full(n, np.cos(np.radians(limit_deg))), np.full(n, np.inf)])
    interior = pts0[1:-1].ravel()
    opts = {
        "print_time": False,
        "ipopt": {"print_level": 0, "max_iter": int(max_iter), "tol": tol, "sb": "yes", **(ipopt_options or {})},
    }
    solver = ca.nlpsol("boards", "ipopt", {"x": x_pts, "f": t[-1], "g": g}, opts)
    times = ca.Function("times", [x_pts], [ca.vertcat(*t)])
    sol = solver(x0=np.zeros(2 * n_int), lbx=-1.0, ubx=1.0, lbg=lbg, ubg=ubg)
    stats = solver.stats()
    x = np.asarray(sol["x"]).ravel()
    out = pts0.copy()
    out[1:-1] = (interior + scale * x).reshape(-1, 2)
    return SailingBoardsResult(
        points_deg=out,
        t_h=np.asarray(times(x)).ravel(),
        status=str(stats.get("return_status", "unknown")),
        success=bool(stats.get("success", False)),
        iterations=int(stats.get("iter_count", -1)),
        solve_s=time.perf_counter() - started,
    )
