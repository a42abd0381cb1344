"""A lower bound on the fuel objective's cost to the end, by region and course: a stronger A* heuristic (issue 15).

The fuel and cost objectives' A* heuristic is ρ times the geodesic distance to the end, ρ the calm-water
floor of (fuel + λ·time) per nm (:func:`optroute.physics.pointwise.least_cost_per_nm`): it ignores the
weather, and a westbound ship in a Beaufort 5 westerly everywhere pays 8 % more per mile than that.
:func:`cost_to_go` bounds each edge of the grid by the weather it may meet, whatever the time, and
returns those bounds with the least such bound from every node to the end (a backward Dijkstra on the static
graph, scipy's compiled one): a heuristic consistent with every edge the search costs, and the edge's own
bound, by which the compiled search defers costing it (:func:`optroute.search.compiled_search.run`).

Why each edge's weight is a lower bound on its cost, at any departure time:

* The weather is trilinear (:func:`optroute.weather.sample.sample_at`): at a point it is a convex
  combination of its cell's 8 grid nodes. Over a block of cells and every time, the wind vector lies in
  the convex hull of the nodes' vectors, so its speed is at least the hull's least projection on any
  direction (a few directions tried); the wave direction (interpolated as a unit vector) lies in the
  cone about the nodes' mean direction that holds them all, where that cone is narrower than a half
  plane; Hs lies between the nodes' least and largest. Only nodes with a finite sea state count: a point
  with another corner is no passage.
* Kwon's (2008) loss is C_β C_U C_Form / 100 (floored at 0) with C_β ≥ 0 set by the sector of the
  wave angle from the bow and by the Beaufort number, and C_Form ≥ 0 growing with it. The least
  C_β C_Form over the block's Beaufort numbers and over the wave angles its directions and the edge's
  courses allow (widened by the largest heading offset a current can make, asin(c / v_min)) is a floor k
  of the loss per C_U; a larger loss needs a larger calm speed for the same speed through water
  (:func:`optroute.physics.speed_loss.calm_speed_point` finds the least one), so the brake power at v
  is at least the calm-water power at that floor's calm speed, and at least the minimum load.
* The fuel rate grows with the power (IMO GHG4 SFOC), the speed over ground is at most v + the strongest
  current, so (fuel + λ) per nm is at least the least over the speed set of that floor's rate; per mile
  of a piece and by the trapezoid over check points as for ρ (:func:`optroute.physics.pointwise.least_cost_per_nm`).
* Every point an edge samples lies within one weather cell (and its great circle's bulge) of the box of
  its two ends, and its course between the courses at its ends (a great circle's course turns one way):
  the edge's floor is the least over the blocks that box touches and the course bins of that interval,
  times a lower bound on its length (the chord's arc at the least WGS84/sphere scale, shrunk by 1e-5).

The search checks every costed edge against the heuristic (``h(x) ≤ cost + h(y)``) and its own bound, and
raises if one is cheaper. Units: speeds [kn], wind and current [m/s], λ [t/h], costs [t].
"""

from __future__ import annotations

import math
import weakref
from typing import NamedTuple

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra as _scipy_dijkstra

from optroute import geodesy as geo
from optroute import units
from optroute._numba import jit
from optroute.physics.pointwise import (
    P_CU_A,
    P_CU_B,
    P_CU_C,
    P_FORM_DIV,
    P_FORM_LINEAR,
    P_INV_SQRT_GL_KN,
    P_KWON,
    P_V23,
    P_VMAX_KN,
    beaufort_from_hs,
    beaufort_from_wind,
    calm_power,
    kwon_direction_range,
    kwon_form_coefficient,
    rate_floor_at_power,
)
from optroute.physics.speed_loss import KWON_BISECTIONS, KWON_SCAN_STEPS, calm_speed_point
from optroute.weather.sample import grid_coordinates_at

__all__ = ["CostBound", "cost_to_go"]

BLOCK_CELLS = 4
"""Weather cells per block side (2° blocks on a 0.5° weather grid)."""
N_BINS = 72
"""Course bins of 5°."""
_K_STEPS = 256  # the loss floor's grid for the rate table
_N_PROJ = 16  # directions the wind hull is projected on
_SHRINK = 1.0 - 1e-5  # as the search's heuristic: the pieces sum to the geodesic length within 1e-6
_TWO_R_FLOOR_NM = 2.0 * geo.EARTH_RADIUS_NM * geo.SPHERE_TO_WGS84_MIN
_MS_PER_KN = units.MS_PER_KN
_META_PERIODIC = 12  # PointWeather.meta's periodic-longitude flag (optroute.weather.sample's layout)


@jit
def _block_stats(fields, nt, ny, nx, periodic, b):  # pragma: no cover - compiled
    """Per block of ``b`` x ``b`` cells over every time: (least wind bound, largest wind (−1: no node knows the
    wind), wind unknown somewhere, least Hs, largest Hs, mean wave direction [deg], the cone's half-angle [deg],
    largest current, sea nodes)."""
    ncy, ncx = max(ny - 1, 1), (nx if periodic else max(nx - 1, 1))
    nby, nbx = (ncy + b - 1) // b, (ncx + b - 1) // b
    out = np.zeros((nby, nbx, 9))
    for by in range(nby):
        for bx in range(nbx):
            proj = np.full(_N_PROJ, np.inf)
            w_max, unknown, hs_lo, hs_hi, c_max, ss, cc, n = -1.0, 0.0, np.inf, 0.0, 0.0, 0.0, 0.0, 0  # -1: no wind
            for t in range(nt):
                for yi in range(by * b, min(by * b + b, ncy) + 1):
                    for k in range(bx * b, min(bx * b + b, ncx) + 1):
                        xi = k % nx if periodic else min(k, nx - 1)
                        f = fields[(t * ny + min(yi, ny - 1)) * nx + xi]
                        if not (math.isfinite(f[0]) and math.isfinite(f[1]) and math.isfinite(f[2])
                                and math.isfinite(f[3]) and math.isfinite(f[6]) and math.isfinite(f[7])):  # fmt: skip
                            continue
                        n += 1
                        hs_lo, hs_hi = min(hs_lo, f[0]), max(hs_hi, f[0])
                        ss += f[2]
                        cc += f[3]
                        c_max = max(c_max, math.hypot(f[6], f[7]))
                        if math.isfinite(f[4]) and math.isfinite(f[5]):
                            w_max = max(w_max, math.hypot(f[4], f[5]))
                            for q in range(_N_PROJ):
                                a = 2.0 * math.pi * q / _N_PROJ
                                proj[q] = min(proj[q], f[4] * math.cos(a) + f[5] * math.sin(a))
                        else:
                            unknown = 1.0
            mean = math.atan2(ss, cc)
            half = 0.0
            for t in range(nt):  # the cone about the mean holding every node's direction
                for yi in range(by * b, min(by * b + b, ncy) + 1):
                    for k in range(bx * b, min(bx * b + b, ncx) + 1):
                        xi = k % nx if periodic else min(k, nx - 1)
                        f = fields[(t * ny + min(yi, ny - 1)) * nx + xi]
                        if math.isfinite(f[2]) and math.isfinite(f[3]):
                            dot = f[2] * math.sin(mean) + f[3] * math.cos(mean)
                            half = max(half, math.degrees(math.acos(min(max(dot, -1.0), 1.0))))
            w_lo = max(0.0, np.max(proj)) if w_max >= 0.0 else 0.0
            row = (w_lo, w_max, unknown, hs_lo, hs_hi, math.degrees(mean) % 360.0, half, c_max, float(n))
            for r in range(9):
                out[by, bx, r] = row[r]
    return out


@jit
def _loss_floors(p, stats, widen_deg):  # pragma: no cover - compiled
    """Per block and 5° course bin: the least C_β C_Form / 100 (inf where the block has no sea)."""
    nby, nbx = stats.shape[0], stats.shape[1]
    out = np.full((nby, nbx, N_BINS), np.inf)
    for by in range(nby):
        for bx in range(nbx):
            s = stats[by, bx]
            if s[8] == 0.0:
                continue
            bn_lo, bn_hi = np.inf, -np.inf
            if s[1] >= 0.0:  # where the wind is known, its Beaufort number
                bn_lo, bn_hi = beaufort_from_wind(s[0]), beaufort_from_wind(s[1])
            if s[2] != 0.0:  # where it is not (a corner without it), the Beaufort number of Hs there
                bn_lo, bn_hi = min(bn_lo, beaufort_from_hs(s[3])), max(bn_hi, beaufort_from_hs(s[4]))
            for q in range(N_BINS):
                c_lo, c_hi = 5.0 * q - widen_deg, 5.0 * q + 5.0 + widen_deg
                lo, hi = s[5] - s[6] - c_hi, s[5] + s[6] - c_lo  # the wave angle from the bow
                if s[6] >= 89.0 or hi - lo >= 360.0:
                    lo, hi = 0.0, 360.0
                best = np.inf
                bn = bn_lo
                while bn <= bn_hi:
                    form = kwon_form_coefficient(bn, p[P_FORM_LINEAR], p[P_FORM_DIV], p[P_V23])
                    best = min(best, kwon_direction_range(bn, lo, hi)[0] * form / 100.0)
                    bn += 1.0
                out[by, bx, q] = max(best, 0.0)
    return out


@jit
def _rate_table(p, speeds, lam, current_kn, k_max):  # pragma: no cover - compiled
    """The least (fuel + λ) / (v + c) over the speeds [t/nm] at losses per C_U k_i = k_max i / (steps − 1)."""
    out = np.empty(_K_STEPS)
    for i in range(_K_STEPS):
        k = k_max * i / (_K_STEPS - 1.0)
        best = np.inf
        for v in speeds:
            if v <= 0.0:
                continue
            v1 = calm_speed_point(v, p[P_CU_A], p[P_CU_B], p[P_CU_C], k, p[P_INV_SQRT_GL_KN], p[P_VMAX_KN],
                                  np.int64(KWON_SCAN_STEPS), np.int64(KWON_BISECTIONS))  # fmt: skip
            if math.isfinite(v1):
                best = min(best, rate_floor_at_power(p, calm_power(p, v1), v, lam, current_kn))
        out[i] = best if math.isfinite(best) else 0.0
    return out


@jit
def _course_deg(lat1, lon1, lat2, lon2):  # pragma: no cover - compiled
    """Initial great-circle course from point 1 to point 2 on the sphere [deg true, 0-360)."""
    p1, p2, dl = math.radians(lat1), math.radians(lat2), math.radians(lon2 - lon1)
    y = math.sin(dl) * math.cos(p2)
    x = math.cos(p1) * math.sin(p2) - math.sin(p1) * math.cos(p2) * math.cos(dl)
    return math.degrees(math.atan2(y, x)) % 360.0


@jit
def _edge_floors(
    lat, lon, nav, di, dj, coords, ktab, k_max, b, periodic, nx_w, lat_step
):  # pragma: no cover - compiled
    """(tail, head, offset, length floor [nm], rate-table index of the loss floor) of every edge between navigable
    nodes (see the module text): an edge's bound is its length floor times the rate at that index, at any λ."""
    ny, nx = lat.shape
    nby, nbx = ktab.shape[0], ktab.shape[1]
    n_max = ny * nx * di.size
    tail, head = np.empty(n_max, dtype=np.int64), np.empty(n_max, dtype=np.int64)
    offset = np.empty(n_max, dtype=np.int64)
    length, index = np.empty(n_max), np.empty(n_max, dtype=np.int64)
    m = 0
    for i in range(ny):
        for j in range(nx):
            if not nav[i, j]:
                continue
            for o in range(di.size):
                i2, j2 = i + di[o], j + dj[o]
                if i2 < 0 or i2 >= ny or j2 < 0 or j2 >= nx or not nav[i2, j2]:
                    continue
                la1, lo1, la2, lo2 = lat[i, j], lon[i, j], lat[i2, j2], lon[i2, j2]
                a1, a2 = math.radians(la1), math.radians(la2)
                dx = math.cos(a2) * math.cos(math.radians(lo2)) - math.cos(a1) * math.cos(math.radians(lo1))
                dy = math.cos(a2) * math.sin(math.radians(lo2)) - math.cos(a1) * math.sin(math.radians(lo1))
                dz = math.sin(a2) - math.sin(a1)
                d_nm = _TWO_R_FLOOR_NM * math.asin(min(1.0, 0.5 * math.sqrt(dx * dx + dy * dy + dz * dz))) * _SHRINK
                k_e = 0.0
                y1, x1, y2, x2 = coords[i, j, 0], coords[i, j, 1], coords[i2, j2, 0], coords[i2, j2, 1]
                if math.isfinite(y1) and math.isfinite(y2) and math.isfinite(x1) and math.isfinite(x2):
                    c1 = _course_deg(la1, lo1, la2, lo2)
                    c2 = (_course_deg(la2, lo2, la1, lo1) + 180.0) % 360.0
                    turn = (c2 - c1 + 180.0) % 360.0 - 180.0
                    c_lo, c_hi = min(c1, c1 + turn) - 0.5, max(c1, c1 + turn) + 0.5
                    # one weather cell, and the great circle's poleward bulge between the ends (d² tan φ / 8R)
                    top = min(max(abs(la1), abs(la2)) + 1.0, 89.0)
                    bulge_nm = d_nm * d_nm * math.tan(math.radians(top)) / (4.0 * _TWO_R_FLOOR_NM)
                    pad = 1.0 + bulge_nm / (60.0 * lat_step)
                    by0 = int(min(max(math.floor((min(y1, y2) - pad) / b), 0), nby - 1))
                    by1 = int(min(max(math.floor((max(y1, y2) + pad) / b), 0), nby - 1))
                    if periodic and abs(x2 - x1) > 0.5 * nx_w:  # across the seam: every longitude block
                        bx0, bx1 = 0, nbx - 1
                    else:
                        bx0 = int(min(max(math.floor((min(x1, x2) - 1.0) / b), 0), nbx - 1))
                        bx1 = int(min(max(math.floor((max(x1, x2) + 1.0) / b), 0), nbx - 1))
                    k_e = np.inf
                    q0, q1 = int(math.floor(c_lo / 5.0)), int(math.floor(c_hi / 5.0))
                    for by in range(by0, by1 + 1):
                        for bx in range(bx0, bx1 + 1):
                            for q in range(q0, q1 + 1):
                                k_e = min(k_e, ktab[by, bx, q % N_BINS])
                    k_e = min(k_e, k_max)  # no sea in the box: the edge is no passage, any bound holds
                idx = int(math.floor(k_e / k_max * (_K_STEPS - 1.0))) if k_max > 0.0 else 0
                tail[m], head[m], offset[m] = i * nx + j, i2 * nx + j2, o
                length[m], index[m] = d_nm, min(max(idx, 0), _K_STEPS - 1)
                m += 1
    return tail[:m], head[:m], offset[:m], length[:m], index[:m]


@jit
def _node_coords(lat, lon, time_s, lat_w, lon_w, meta, offset_ns):  # pragma: no cover - compiled
    """Each grid node's (lat, lon) weather cell coordinates (NaN outside the weather's area)."""
    ny, nx = lat.shape
    out = np.full((ny, nx, 2), np.nan)
    buf = np.empty(3)
    for i in range(ny):
        for j in range(nx):
            if grid_coordinates_at(time_s, lat_w, lon_w, meta, offset_ns, 0.0, lat[i, j], lon[i, j], buf):
                out[i, j, 0], out[i, j, 1] = buf[1], buf[2]
    return out


class CostBound(NamedTuple):
    """A lower bound on the fuel objective's cost (:func:`cost_to_go`): to the end from each node, and of each edge."""

    to_end_t: np.ndarray
    """(n_nodes,) the least bound to the end [t], flat as ``grid.flat`` (0 where no static path reaches it)."""
    edge_t: np.ndarray
    """(n_nodes, n_offsets) each edge's own bound [t] by its tail and neighbourhood offset (0 where it has none)."""


class _EdgeFloors(NamedTuple):
    """What the bound keeps of a grid, a weather and a speed set, at any λ: the reverse graph's CSR structure, its
    edges' length floors [nm], rate-table indices and places ``tail · n_offsets + offset`` (in the structure's
    order), the rate table's inputs."""

    indptr: np.ndarray
    indices: np.ndarray
    place: np.ndarray
    n_offsets: int
    length_nm: np.ndarray
    index: np.ndarray
    n_nodes: int
    goal: int
    c_max_kn: float
    k_max: float


_PREPARED: dict[tuple, tuple[weakref.ref, weakref.ref, _EdgeFloors]] = {}


def _edge_floors_of(params, weather, grid, offsets, speeds) -> _EdgeFloors:
    """The λ-independent part of :func:`cost_to_go` (the block statistics, loss floors and every edge's floor),
    built once per grid, weather fields (and departure), neighbourhood, model and speed set, and dropped with the
    grid: a λ bisection searches the same grid at many λ."""
    fields = weather[0]
    key = (id(grid), id(fields), int(weather[5]), params.tobytes(), np.asarray(offsets).tobytes(), speeds.tobytes())
    hit = _PREPARED.get(key)
    if hit is not None and hit[0]() is grid and hit[1]() is fields:
        return hit[2]
    _, time_s, lat_w, lon_w, meta, offset_ns = weather[:6]
    periodic = bool(meta[_META_PERIODIC] != 0.0)
    nx_w = lon_w.size
    stats = _block_stats(np.ascontiguousarray(fields), time_s.size, lat_w.size, nx_w, periodic, BLOCK_CELLS)
    c_max_kn = float(np.max(stats[..., 7], initial=0.0)) / _MS_PER_KN
    v_min = float(np.min(speeds[speeds > 0.0]))
    widen = math.degrees(math.asin(min(1.0, c_max_kn / v_min))) if c_max_kn > 0.0 else 0.0
    ktab = _loss_floors(params, stats, widen)
    finite = ktab[np.isfinite(ktab)]
    k_max = float(finite.max()) if finite.size else 0.0
    lat, lon = np.ascontiguousarray(grid.lat_deg, dtype=float), np.ascontiguousarray(grid.lon_deg, dtype=float)
    coords = _node_coords(lat, lon, time_s, lat_w, lon_w, meta, np.int64(offset_ns))
    di, dj = (np.ascontiguousarray(offsets[:, k], dtype=np.int64) for k in (0, 1))
    lat_step = float(np.min(np.abs(np.diff(lat_w)))) if lat_w.size > 1 else 180.0
    tail, head, offset, length, index = _edge_floors(lat, lon, np.ascontiguousarray(grid.navigable), di, dj, coords, ktab,
                                             k_max, float(BLOCK_CELLS), periodic, float(nx_w), lat_step)  # fmt: skip
    n = grid.n_nodes
    # the reverse graph's structure, its entries numbered by edge (one edge per node pair: one per offset)
    order = csr_matrix((np.arange(1.0, tail.size + 1.0), (head, tail)), shape=(n, n))
    edge = order.data.astype(np.int64) - 1
    place = (tail * di.size + offset)[edge]
    out = _EdgeFloors(order.indptr, order.indices, place, int(di.size), length[edge], index[edge], n,
                      int(grid.flat(*grid.end)), c_max_kn, k_max)  # fmt: skip
    _PREPARED[key] = (weakref.ref(grid), weakref.ref(fields), out)
    weakref.finalize(grid, _PREPARED.pop, key, None)
    return out


def cost_to_go(
    params: np.ndarray, weather: tuple, grid, offsets: np.ndarray, speeds_kn: np.ndarray, lambda_t_per_h: float
) -> CostBound | None:
    """A lower bound on (fuel + λ·time) [t] of every edge of the grid, and the least such to the end from every node
    (see the module text): a heuristic consistent with the edges' bounds, so with their costs.

    Parameters
    ----------
    params : ndarray
        The compiled model's point parameters (:func:`optroute.physics.pointwise.point_params`).
    weather : tuple
        :class:`~optroute.weather.sample.PointWeather` (fields, time, lat and lon axes, meta, offset).
    grid : RouteGrid
        The search's lattice (its navigable mask and end node).
    offsets : ndarray of int, shape (m, 2)
        The neighbourhood's ``(di, dj)`` [cells].
    speeds_kn : ndarray
        The speed set [kn].
    lambda_t_per_h : float
        λ [t/h].

    Returns
    -------
    CostBound or None
        The bound per node to the end and per edge; None for the calm-water model (no loss to bound: ρ is the
        bound).
    """
    if params[P_KWON] == 0.0:
        return None
    speeds = np.ascontiguousarray(speeds_kn, dtype=float)
    g = _edge_floors_of(params, weather, grid, offsets, speeds)
    rate = _rate_table(params, speeds, float(lambda_t_per_h), g.c_max_kn, g.k_max)
    # a weight of 0 (no speed of the set reachable at that loss: no passage) may count as no edge either way
    weight = rate[g.index] * g.length_nm
    reverse = csr_matrix((weight, g.indices, g.indptr), shape=(g.n_nodes, g.n_nodes))
    h = _scipy_dijkstra(reverse, indices=g.goal)
    edge = np.zeros(g.n_nodes * g.n_offsets)
    edge[g.place] = weight
    return CostBound(np.where(np.isfinite(h), h, 0.0), edge.reshape(g.n_nodes, g.n_offsets))
