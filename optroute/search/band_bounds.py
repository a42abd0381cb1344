"""A table lookup that certifies a piece clear of every band before the referee's refinement is run (issue 15).

The compiled band check of the route search (:func:`optroute.search.refine_kernels.piece_clear`, the
referee's rule of :mod:`optroute.search.band_refine`) puts points along a piece at every regime
crossing and halves intervals until each is certified, evaluating the speed at every point it puts.
It fails a piece where one of those points has the speed not allowed
(:func:`optroute.physics.pointwise.allowed_speed`): not navigable, the course not held, a danger band
(Boeing EP 2145155; IMO MSC.1/Circ.1228) or the power outside [min load, MCR].

:func:`piece_certified` decides from bounds alone that *no* point of the piece can fail, so that
the refinement would return True whatever points it put, and returns True without running it.  The
weather is trilinear (:func:`optroute.weather.sample.sample_at`): at any point it is a convex
combination of the 8 grid nodes of its cell, so over a box of (time, lat, lon) the largest Hs, wind
speed and current speed are at most the largest at the nodes of the cells the box touches, and a
point is navigable where all those nodes are.  :func:`node_bounds` tabulates, per grid node, Hs
(``inf`` where the sea state or the current is not finite), the wind speed (NaN where unknown) and
the current speed; the piece's box is its check points' (positions on one great circle, times
linear between them) widened by the great circle's curvature between neighbouring points.  The
piece is certified when, over the box's nodes:

* every sea state is finite, inside the data (area and, unless held, time span);
* Hs stays below the bands' threshold (:data:`~optroute.physics.pointwise.P_HS_MIN`): no band
  applies (:func:`~optroute.physics.pointwise.band_forbidden`), whatever the ratios;
* the current is slower than the speed through water, so the course is held with a positive SOG
  (Bowditch's current triangle);
* the brake power stays within [min load, MCR] at every wave angle and every Beaufort number up to
  the box's largest (:func:`optroute.physics.pointwise.brake_power_bound`);
* the refinement cannot run out of room (:data:`~optroute.search.refine_kernels.CAPACITY`).

Every comparison keeps a relative margin of 1e-9 over the rounding of the interpolation, so a
certified piece is one the refinement passes: the labels and routes are those of the full check.
Elsewhere the full refinement runs as before.  Units: Hs [m], speeds [kn], wind and current [m/s],
positions [deg], times [h after the departure], distances [nm].
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from optroute import geodesy as geo
from optroute import units
from optroute._numba import jit
from optroute.physics.pointwise import (
    P_HS_MIN,
    P_MCR,
    P_MIN_POWER,
    beaufort_from_hs,
    beaufort_from_wind,
    brake_power_bound,
)
from optroute.search.band_refine import BAND_TOL_NM, CROSSING_PASSES
from optroute.weather.sample import grid_coordinates_at

__all__ = ["NO_BOUNDS", "node_bounds", "piece_certified", "weather_with_bounds"]

NO_BOUNDS = np.zeros((0, 3))
"""The node table of a weather without bounds: :func:`piece_certified` then certifies nothing."""
_B_HS, _B_WIND, _B_CUR = 0, 1, 2
_REL = 1e-9  # relative margin over the interpolation's rounding
_MAX_LAT = 80.0  # no certificate nearer the poles (the box's curvature bound grows with tan(lat))
_R_NM = geo.EARTH_RADIUS_NM * 0.99  # a radius below every local WGS84 scale of the pieces' arcs (edge_geometry)
_MS_PER_KN = units.MS_PER_KN
_META_PERIODIC = 12  # PointWeather.meta's periodic-longitude flag (optroute.weather.sample's layout)


@jit
def _node_table(fields):  # pragma: no cover - compiled
    n = fields.shape[0]
    out = np.empty((n, 3))
    for i in range(n):
        ok = True
        for r in (0, 1, 2, 3, 6, 7):  # Hs, period, wave direction's sin and cos, current u and v
            if not math.isfinite(fields[i, r]):
                ok = False
        out[i, _B_HS] = fields[i, 0] if ok else np.inf
        out[i, _B_WIND] = math.hypot(fields[i, 4], fields[i, 5])
        out[i, _B_CUR] = math.hypot(fields[i, 6], fields[i, 7]) if ok else np.inf
    return out


def node_bounds(fields: np.ndarray) -> np.ndarray:
    """Per grid node of :attr:`~optroute.weather.sample.PointWeather.fields`: Hs (inf: no sea state), wind and current speed.

    Shape (n_nodes, 3), node-major as the fields: Hs [m] where Hs, the period, the wave direction and the current are finite, else
    ``inf``; the wind speed [m/s] (NaN where the wind is unknown); the current speed [m/s].
    """
    return _node_table(np.ascontiguousarray(fields, dtype=float))


_TABLES: dict[int, tuple[weakref.ref, np.ndarray]] = {}


def weather_with_bounds(pw: tuple) -> tuple:
    """The :class:`~optroute.weather.sample.PointWeather` fields with their :func:`node_bounds` appended (built once per fields array)."""
    fields = pw[0]
    hit = _TABLES.get(id(fields))
    if hit is None or hit[0]() is not fields:
        for key in [k for k, (ref, _) in _TABLES.items() if ref() is None]:
            del _TABLES[key]
        table = node_bounds(fields) if fields.ndim == 2 and fields.shape[1] >= 8 else NO_BOUNDS
        hit = (weakref.ref(fields), table)
        _TABLES[id(fields)] = hit
    return (*tuple(pw)[:6], hit[1])


@jit
def _node_range(c_lo, c_hi, n, periodic):  # pragma: no cover - compiled
    """First node and node count of the cells whose coordinate lies in [c_lo, c_hi] on an axis of ``n`` nodes."""
    if n == 1:
        return 0, 1
    top = n - 1.0 if periodic else n - 2.0
    i_lo = min(max(math.floor(c_lo), 0.0), top)
    i_hi = min(max(math.floor(c_hi), 0.0), top)
    return int(i_lo), int(i_hi - i_lo) + 2


@jit
def _box_maxima(table, time_s, lat_deg, lon_deg, meta, c_lo, c_hi):  # pragma: no cover - compiled
    """(largest Hs, largest wind speed, any wind unknown, largest current speed) over the box's cells' nodes."""
    nt, ny, nx = time_s.size, lat_deg.size, lon_deg.size
    periodic = meta[_META_PERIODIC] != 0.0
    t0, kt = _node_range(c_lo[0], c_hi[0], nt, np.bool_(False))  # typed, as ``periodic`` below: one signature
    y0, ky = _node_range(c_lo[1], c_hi[1], ny, np.bool_(False))
    x0, kx = _node_range(c_lo[2], c_hi[2], nx, periodic)
    if nt == 1:
        kt = 1
    hs, wind, cur = -np.inf, 0.0, 0.0
    wind_unknown = False
    for a in range(kt):
        for b in range(ky):
            row = ((t0 + a) * ny + y0 + b) * nx
            for c in range(kx):
                x = x0 + c
                if x >= nx:
                    x -= nx
                i = row + x
                hs = max(hs, table[i, _B_HS])
                cur = max(cur, table[i, _B_CUR])
                wv = table[i, _B_WIND]
                if math.isfinite(wv):
                    wind = max(wind, wv)
                else:
                    wind_unknown = True
    return hs, wind, wind_unknown, cur


@jit
def _box(w, la0, lo0, t0, s0, n0, lat_mid, lon_mid, c_lo, c_hi):  # pragma: no cover - compiled
    """The grid coordinates of the box around the piece into ``c_lo``, ``c_hi``; (inside the data, grid lines in it)."""
    t_lo, t_hi = np.inf, -np.inf
    la_lo, la_hi, dl_lo, dl_hi = np.inf, -np.inf, np.inf, -np.inf
    gap = 0.0
    for j in range(n0):
        t_lo, t_hi = min(t_lo, t0[j]), max(t_hi, t0[j])
        la_lo, la_hi = min(la_lo, la0[j]), max(la_hi, la0[j])
        d = (lo0[j] - lon_mid + 180.0) % 360.0 - 180.0
        dl_lo, dl_hi = min(dl_lo, d), max(dl_hi, d)
        if j > 0:
            gap = max(gap, s0[j] - s0[j - 1])
    phi = max(abs(la_lo), abs(la_hi))
    if not phi < _MAX_LAT:
        return False, 0.0
    # a great circle's lat and lon between neighbouring points: |lat''| <= tan(lat), |lon''| <= 2 tan(lat) / cos(lat)
    # per unit arc; the excursion off the straight line between them is at most h^2 / 8 times that
    arc = gap / _R_NM
    phi_r = math.radians(min(phi + math.degrees(arc), 89.0))
    tan_p, cos_p = math.tan(phi_r), math.cos(phi_r)
    pad_la = math.degrees(arc * arc / 8.0 * (tan_p + 1.0)) * 2.0 + 1e-9
    pad_lo = math.degrees(arc * arc / 8.0 * (2.0 * tan_p / cos_p + 1.0)) * 2.0 + 1e-9
    pad_t = 1e-9 * (1.0 + abs(t_hi))
    lon_lo, lon_hi = lon_mid + dl_lo - pad_lo, lon_mid + dl_hi + pad_lo
    ok_lo = grid_coordinates_at(w[1], w[2], w[3], w[4], w[5], t_lo - pad_t, la_lo - pad_la, lon_lo, c_lo)
    ok_hi = grid_coordinates_at(w[1], w[2], w[3], w[4], w[5], t_hi + pad_t, la_hi + pad_la, lon_hi, c_hi)
    if not (ok_lo and ok_hi) or c_hi[2] < c_lo[2] or c_hi[1] < c_lo[1] or c_hi[0] < c_lo[0]:
        return False, 0.0  # leaving the data, or across the longitude seam: no certificate
    lines = 2.0 * (math.floor(c_hi[1]) - math.floor(c_lo[1]) + math.floor(c_hi[2]) - math.floor(c_lo[2]) + 2.0)
    lines += math.floor(c_hi[0]) - math.floor(c_lo[0]) + 1.0
    return True, lines


@jit
def piece_certified(
    p, w, spd, sog_mode, la0, lo0, t0, s0, n0, lat_mid, lon_mid, length, capacity, scratch
):  # pragma: no cover - compiled
    """Whether no point of a piece can have the speed not allowed, from the node bounds alone (see the module).

    Parameters
    ----------
    p : ndarray
        :func:`optroute.physics.pointwise.point_params`.
    w : tuple
        :func:`weather_with_bounds`: the :class:`~optroute.weather.sample.PointWeather` fields and the node table.
    spd : float
        Speed through water [kn]; with ``sog_mode`` the speed over ground the ship makes good [kn].
    la0, lo0, t0, s0 : ndarray
        The piece's check points: positions [deg] on one great circle, the times the ship passes them [h]
        and their distances along the piece [nm], increasing, ends included; ``n0`` of them.
    lat_mid, lon_mid, length : float
        The piece's midpoint [deg] and length [nm].
    capacity : int
        The most points the refinement may put (:data:`~optroute.search.refine_kernels.CAPACITY`).
    scratch : ndarray
        At least 6 floats of work space.

    Returns
    -------
    bool
        True only where every point of the piece (between its check points, at the time linear between
        theirs) has the speed allowed and the refinement cannot overflow; False where that is not certain.
    """
    table = w[6]
    if table.shape[0] == 0 or n0 < 2 or not spd > 0.0:
        return False
    c_lo, c_hi = scratch[0:3], scratch[3:6]
    inside, lines = _box(w, la0, lo0, t0, s0, n0, lat_mid, lon_mid, c_lo, c_hi)
    if not inside:
        return False
    # points the refinement may put: the check points, every crossing's two sides per pass, halvings to BAND_TOL / 2
    if n0 + 2.0 * CROSSING_PASSES * lines + 2.0 * length / BAND_TOL_NM + 4.0 >= capacity:
        return False
    hs, wind, wind_unknown, cur = _box_maxima(table, w[1], w[2], w[3], w[4], c_lo, c_hi)
    thr = p[P_HS_MIN]
    if not hs * (1.0 + _REL) + 1e-12 < thr:  # (also: a sea state not finite somewhere, hs = inf)
        return False
    cur_kn = cur / _MS_PER_KN * (1.0 + _REL)
    if sog_mode:
        if cur_kn > 0.0:
            return False  # the speed through water would vary along the piece: no certificate
        stw_lo, stw_hi = spd * (1.0 - _REL), spd * (1.0 + _REL)
    else:
        if not cur_kn < 0.99 * spd:
            return False
        stw_lo, stw_hi = spd, spd
    bn = beaufort_from_wind(wind * (1.0 + _REL))
    if wind_unknown:
        bn = max(bn, beaufort_from_hs(hs * (1.0 + _REL)))
    power = brake_power_bound(p, stw_lo, stw_hi, bn)
    if not power <= p[P_MCR]:
        return False
    floor = brake_power_bound(p, stw_lo, stw_lo, 0.0) / (1.0 + 1e-9)  # (calm water: the least power)
    return p[P_MIN_POWER] <= 0.0 or floor >= p[P_MIN_POWER] * (1.0 + 1e-6)
