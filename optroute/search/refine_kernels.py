"""The referee's band check between a piece's check points, compiled for the search kernels (issue 14 item 1).

:func:`piece_clear` applies the rules of :mod:`optroute.search.band_refine` (regime crossings, then
adaptive halving until every interval is certified by :func:`~optroute.search.band_refine.certified`,
compiled from that very function) to one piece of the route search whose speed is already allowed
at its check points (:func:`optroute.search.passage_kernels.cost_leg`), with the one-point
functions of the referee's model: :func:`optroute.physics.pointwise.band_state` and
:func:`~optroute.physics.pointwise.allowed_speed`, :func:`optroute.weather.sample.sample_at` and
:func:`~optroute.weather.sample.grid_coordinates_at`, :func:`optroute.search.edge_geometry.frame_point`.
The numpy callbacks do the same with :mod:`optroute.search.band_refine` itself
(:meth:`optroute.search.passage_physics.PassagePhysics.segment_checked`).

Distances ``s`` [nm] run from the piece's start; the ship is at a point at the time linear in
distance between the check points (the times the speed was checked at).  Everything compiles
lazily, at the first search that uses it.
"""

from __future__ import annotations

import numpy as np

from optroute._numba import jit
from optroute.physics.pointwise import allowed_speed, band_state, stw_for_sog
from optroute.search import band_refine
from optroute.search.band_bounds import piece_certified
from optroute.search.band_refine import BAND_TOL_NM, CROSSING_PASSES, CROSSING_TOL_NM, MAX_ROUNDS, TURN_DEG
from optroute.search.edge_geometry import frame_point, piece_frame
from optroute.weather.sample import grid_coordinates_at, sample_at

__all__ = ["CAPACITY", "N_FIELDS", "piece_clear", "refined_clear", "workspace"]

CAPACITY = 2048
"""Most points one piece's check may use; a piece needing more is treated as failing (never seen: a
10 nm piece halved to 0.1 nm everywhere takes ~200)."""
_S, _T, _LAT, _LON, _CRS, _C0, _G, _W, _M0, _PROBED = 0, 1, 2, 3, 4, 5, 8, 9, 10, 14
N_FIELDS = 15
"""Per point: s, t, lat, lon, course, 3 grid coordinates, g, wave direction, 4 band margins, evaluated (1) or not."""
_N_SLOPES = 5  # g and the four bands
_XTOL = min(CROSSING_TOL_NM, BAND_TOL_NM)

_certified = jit(band_refine.certified)


@jit
def workspace(checked):  # pragma: no cover - compiled
    """(points (2, CAPACITY, N_FIELDS), slopes (5, CAPACITY), scratch (16,)) for :func:`piece_clear`; tiny unless ``checked``."""
    cap = CAPACITY if checked else 1
    return np.empty((2, cap, N_FIELDS)), np.empty((_N_SLOPES, cap)), np.empty(16)


@jit
def _copy_row(src, i, dst, k):  # pragma: no cover - compiled
    """``dst[k] = src[i]`` (rows of the same width), element by element (see :func:`_copy_rows`)."""
    for c in range(src.shape[1]):
        dst[k, c] = src[i, c]


@jit
def _copy_rows(src, dst, n):  # pragma: no cover - compiled
    """``dst[:n] = src[:n]`` (rows of the same width), element by element.

    A slice assignment would compile numba's shape-mismatch error path (its message formatting), several
    CPU-seconds at every clean compile, for shapes that always match here; the row index and count are always
    variables at the call sites, so each helper has one signature (a literal argument would add a second).
    """
    for r in range(n):
        _copy_row(src, r, dst, r)


@jit
def _place(w, frame, length, row, scratch):  # pragma: no cover - compiled
    """Position, course and grid coordinates of the point at ``row[_S]``, ``row[_T]`` (``frame``: the piece's
    :func:`~optroute.search.edge_geometry.piece_frame` at its midpoint)."""
    row[_LAT], row[_LON], row[_CRS] = frame_point(frame, row[_S] - 0.5 * length)
    row[_PROBED] = 0.0
    grid_coordinates_at(w[1], w[2], w[3], w[4], w[5], row[_T], row[_LAT], row[_LON], scratch[13:16])
    row[_C0], row[_C0 + 1], row[_C0 + 2] = scratch[13], scratch[14], scratch[15]


@jit
def _stw(spd, sog_mode, course, sea):  # pragma: no cover - compiled
    """The speed through water [kn]: ``spd`` itself, or with ``sog_mode`` the one making ``spd`` good over ground."""
    return stw_for_sog(course, spd, sea[5], sea[6]) if sog_mode else spd


@jit
def _probe(p, w, spd, sog_mode, row, scratch):  # pragma: no cover - compiled
    """The speed's allowedness at a placed point (False: a violation), and its band functions into ``row``."""
    sea = scratch[:9]
    sample_at(w[0], w[1], w[2], w[3], w[4], w[5], row[_T], row[_LAT], row[_LON], sea)
    stw = _stw(spd, sog_mode, row[_CRS], sea)
    if not (stw > 0.0 and np.isfinite(stw)):
        return False
    sog, _, allowed = allowed_speed(p, row[_CRS], sea[0], sea[1], sea[2], sea[3], sea[4], sea[5], sea[6], stw)
    ok, wf, g = band_state(p, row[_CRS], sea[0], sea[1], sea[2], sea[3], sea[4], sea[5], sea[6], stw, scratch[9:13])
    row[_G], row[_W] = g, wf
    for b in range(4):
        row[_M0 + b] = scratch[9 + b]
    return allowed and ok and sog > 0.0


@jit
def _between(a, i, s_new, out, w, frame, length, scratch):  # pragma: no cover - compiled
    """The point at ``s_new`` inside the interval (i, i + 1) of ``a``, its time linear in distance, placed."""
    out[_S] = s_new
    out[_T] = a[i, _T] + (s_new - a[i, _S]) / (a[i + 1, _S] - a[i, _S]) * (a[i + 1, _T] - a[i, _T])
    _place(w, frame, length, out, scratch)


@jit
def _crossing_fraction(ca, cb):  # pragma: no cover - compiled
    """Where a coordinate linear from ``ca`` to ``cb`` first crosses a grid line, as a fraction in (0, 1); inf if not."""
    cell_a = np.floor(ca) if np.isfinite(ca) else -1.0
    cell_b = np.floor(cb) if np.isfinite(cb) else -1.0
    if cell_a == cell_b or not (np.isfinite(ca) and np.isfinite(cb)) or cb == ca:
        return np.inf
    line = np.floor(ca) + 1.0 if cb > ca else np.ceil(ca) - 1.0 + (1.0 if ca == np.floor(ca) else 0.0)
    f = (line - ca) / (cb - ca)
    return f if 0.0 < f < 1.0 else np.inf


@jit
def _crossings(a, b, n, w, frame, length, scratch):  # pragma: no cover - compiled
    """Both sides of every cell change added (as :func:`~optroute.search.band_refine.crossing_nodes`); the count, -1 if full."""
    half = 0.45 * _XTOL
    for _ in range(CROSSING_PASSES):
        k = np.int64(0)  # not a literal 0: a literal would compile _copy_row/_copy_rows for Literal[int](0) too
        added = False
        for i in range(n):
            _copy_row(a, i, b, k)
            k += 1
            if i == n - 1:
                break
            h = a[i + 1, _S] - a[i, _S]
            change = False
            for d in range(3):
                ca, cb = a[i, _C0 + d], a[i + 1, _C0 + d]
                if (np.floor(ca) if np.isfinite(ca) else -1.0) != (np.floor(cb) if np.isfinite(cb) else -1.0):
                    change = True
            if not (change and h > _XTOL):
                continue
            f = np.inf
            for d in range(3):
                f = min(f, _crossing_fraction(a[i, _C0 + d], a[i + 1, _C0 + d]))
            if not np.isfinite(f):
                f = 0.5  # (leaving the data: halve)
            mid = a[i, _S] + f * h
            lo_s = min(max(mid - half, a[i, _S] + 0.25 * half), a[i + 1, _S] - 0.25 * half)
            hi_s = min(max(mid + half, a[i, _S] + 0.25 * half), a[i + 1, _S] - 0.25 * half)
            if k + 3 > a.shape[0]:
                return -1
            _between(a, i, lo_s, b[k], w, frame, length, scratch)
            _between(a, i, hi_s, b[k + 1], w, frame, length, scratch)
            k += 2
            added = True
        _copy_rows(b, a, k)
        n = k
        if not added:
            break
    return n


@jit
def _slopes(a, n, sl):  # pragma: no cover - compiled
    """Per interval, the secant slopes of g and the band margins (0 where not finite), as ``secant_slopes``."""
    for i in range(n - 1):
        h = a[i + 1, _S] - a[i, _S]
        for q in range(_N_SLOPES):
            col = _G if q == 0 else _M0 + q - 1
            v = abs(a[i + 1, col] - a[i, col]) / h if h > 0.0 else np.inf
            sl[q, i] = v if np.isfinite(v) else 0.0


@jit
def _neighbour_slope(sl, q, i, n):  # pragma: no cover - compiled
    """The largest secant slope of interval i and its neighbours (of ``n - 1``)."""
    return max(sl[q, i], sl[q, i - 1] if i > 0 else 0.0, sl[q, i + 1] if i + 1 < n - 1 else 0.0)


@jit
def _needs_halving(a, i, n, sl):  # pragma: no cover - compiled
    """Whether interval (i, i + 1) is longer than the tolerance and not certified (as ``intervals_to_halve``)."""
    h = a[i + 1, _S] - a[i, _S]
    if not h > BAND_TOL_NM:
        return False
    turn = abs((a[i + 1, _W] - a[i, _W] + 180.0) % 360.0 - 180.0)
    if turn > TURN_DEG:
        return True
    ga, gb = a[i, _G], a[i + 1, _G]
    hs_cert = _certified(ga, gb, _neighbour_slope(sl, np.int64(0), i, n), h, BAND_TOL_NM)
    for q in range(1, _N_SLOPES):
        ma, mb = a[i, _M0 + q - 1], a[i + 1, _M0 + q - 1]
        if (ma <= 0.0 and ga <= 0.0) or (mb <= 0.0 and gb <= 0.0):
            continue  # an end inside the band: found
        fin_a, fin_b = np.isfinite(ma), np.isfinite(mb)
        ratio_cert = (
            _certified(ma, mb, _neighbour_slope(sl, q, i, n), h, BAND_TOL_NM)
            if fin_a and fin_b
            else not fin_a and not fin_b
        )
        if not (ratio_cert or hs_cert):
            return True
    return False


@jit
def piece_clear(
    p, w, spd, sog_mode, lat, lon, course, length, s0, t0, n0, la0, lo0, crs0, sea0, ws, sl, scratch
):  # pragma: no cover - compiled
    """Whether speed ``spd`` [kn] is allowed everywhere the referee's rules look between the piece's check points.

    Parameters
    ----------
    p, w
        :func:`optroute.physics.pointwise.point_params`; :class:`~optroute.weather.sample.PointWeather` fields
        with their node table (:func:`optroute.search.band_bounds.weather_with_bounds`).
    spd : float
        Speed through water [kn]; with ``sog_mode`` the speed over ground made good (the 3-D DP's command), the
        speed through water then taken at each point against the current there
        (:func:`optroute.physics.pointwise.stw_for_sog`).
    sog_mode : bool
    lat, lon, course, length : float
        The piece's midpoint [deg], course there [deg true] and length [nm].
    s0, t0 : ndarray
        The check points' distances from the piece's start [nm] (increasing, ends included) and the
        times the ship passes them [h]; ``n0`` of them.
    la0, lo0, crs0, sea0 : ndarray
        Their positions [deg], courses [deg true] and the weather sampled there (``sample_at``'s rows),
        where the speed is allowed already: they are not evaluated again.
    ws, sl, scratch : ndarray
        :func:`workspace`.

    Returns
    -------
    bool
        False where a point put by the rules (a regime crossing or a halving) has the speed not
        allowed (:func:`~optroute.physics.pointwise.allowed_speed`: a band, the power, no sea), or
        more than :data:`CAPACITY` points would be needed.  A piece that
        :func:`optroute.search.band_bounds.piece_certified` certifies from its weather's node bounds (no point
        of it can fail) is True at once, without the points: the outcome is the same.
    """
    if piece_certified(p, w, spd, sog_mode, la0, lo0, t0, s0, n0, lat, lon, length, np.int64(CAPACITY), scratch):
        return True
    return refined_clear(
        p, w, spd, sog_mode, lat, lon, course, length, s0, t0, n0, la0, lo0, crs0, sea0, ws, sl, scratch
    )


@jit
def refined_clear(
    p, w, spd, sog_mode, lat, lon, course, length, s0, t0, n0, la0, lo0, crs0, sea0, ws, sl, scratch
):  # pragma: no cover - compiled
    """:func:`piece_clear` without the certificate: the regime crossings and the halvings, every point put evaluated.

    For a caller that has tried :func:`optroute.search.band_bounds.piece_certified` on the piece already (the 3-D
    DP's :func:`optroute.search.passage_kernels._dp_piece_clear`, before sampling the piece's ends); the
    arguments and the result as :func:`piece_clear`'s.
    """
    a, b = ws[0], ws[1]
    for j in range(n0):
        row = a[j]
        row[_S], row[_T], row[_LAT], row[_LON], row[_CRS] = s0[j], t0[j], la0[j], lo0[j], crs0[j]
        grid_coordinates_at(w[1], w[2], w[3], w[4], w[5], t0[j], la0[j], lo0[j], scratch[13:16])
        row[_C0], row[_C0 + 1], row[_C0 + 2] = scratch[13], scratch[14], scratch[15]
        sea = sea0[j]
        _, row[_W], row[_G] = band_state(
            p,
            crs0[j],
            sea[0],
            sea[1],
            sea[2],
            sea[3],
            sea[4],
            sea[5],
            sea[6],
            _stw(spd, sog_mode, crs0[j], sea),
            scratch[9:13],
        )
        for q in range(4):
            row[_M0 + q] = scratch[9 + q]
        row[_PROBED] = 1.0
    frame = piece_frame(lat, lon, course)
    n = _crossings(a, b, n0, w, frame, length, scratch)
    if n < 0:
        return False
    for j in range(n):
        if a[j, _PROBED] == 0.0 and not _probe(p, w, spd, sog_mode, a[j], scratch):
            return False
    for _ in range(MAX_ROUNDS):
        _slopes(a, n, sl)
        k = np.int64(0)  # (as in _crossings)
        added = False
        for i in range(n):
            _copy_row(a, i, b, k)
            k += 1
            if i == n - 1 or not _needs_halving(a, i, n, sl):
                continue
            if k + 2 > a.shape[0]:
                return False
            _between(a, i, 0.5 * (a[i, _S] + a[i + 1, _S]), b[k], w, frame, length, scratch)
            if not _probe(p, w, spd, sog_mode, b[k], scratch):
                return False
            k += 1
            added = True
        _copy_rows(b, a, k)
        n = k
        if not added:
            return True
    return True
