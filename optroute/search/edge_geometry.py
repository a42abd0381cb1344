"""The static geometry of the grid's legs and their pieces, written once (numba) for every path that needs it.

A leg of the gnomonic grid (Boeing EP 2145155 Figs. 14, 18) is a straight
segment of the tangent plane, hence a great circle; the supercover walk of
:func:`optroute.search.grid.segment_cells` cuts it into pieces, one per cell
crossed, at plane fractions ``f0 < f1``.  Each piece is described by its
midpoint (the normalised plane midpoint), the great-circle course there and its
true length; the band check of the route search samples it at points evenly
spaced in arc length about that midpoint.  Units: positions [deg], courses
[deg true, to], lengths [nm]; plane points in Earth radii.

Every user of this geometry — the Python cost callbacks through
:class:`optroute.search.costs.LegEvaluator` and
:func:`optroute.search.piece_geometry.piece_points`, the compiled edge kernels
(:mod:`optroute.search.passage_kernels`) and the compiled search loop
(:mod:`optroute.search.compiled_search`) — calls the functions of this module,
so that a change of the geometry (an ellipsoid, say) is made here only.
:func:`edge_piece_arrays` returns the per-piece arrays of given edges for
callers that want them outside a kernel.
"""

from __future__ import annotations

import math

import numpy as np

from optroute import geodesy as geo
from optroute._numba import jit

__all__ = [
    "edge_piece_arrays",
    "edge_pieces",
    "frame_point",
    "latlon_of",
    "piece_frame",
    "piece_point",
    "piece_points_flat",
    "sphere_course",
    "wgs84_course",
    "wgs84_scale",
]

_R_NM = geo.EARTH_RADIUS_NM


_wgs84_radii = jit(geo.wgs84_radii_m)
_wgs84_factor = jit(geo.wgs84_local_factor)


@jit
def wgs84_scale(lat_deg, course_deg):  # pragma: no cover - compiled
    """Ellipsoidal / spherical length of a short piece at ``lat_deg`` on the sphere's ``course_deg`` [-].

    :func:`optroute.geodesy.wgs84_local_factor` (the scale of :func:`optroute.geodesy.sphere_to_wgs84`), compiled.
    """
    m, n = _wgs84_radii(lat_deg)
    return _wgs84_factor(m, n, course_deg)[0]


@jit
def wgs84_course(lat_deg, course_deg):  # pragma: no cover - compiled
    """The ellipsoid's course [deg true, [0, 360)] of a piece sailed on the sphere's ``course_deg`` (:func:`optroute.geodesy.wgs84_local_factor`)."""
    m, n = _wgs84_radii(lat_deg)
    return _wgs84_factor(m, n, course_deg)[1]


@jit
def sphere_course(lat_deg, course_deg):  # pragma: no cover - compiled
    """The inverse of :func:`wgs84_course`: the sphere's course [deg] of a piece on the ellipsoid's ``course_deg``."""
    m, n = _wgs84_radii(lat_deg)
    a = math.radians(course_deg)
    return math.degrees(math.atan2(m * math.sin(a), n * math.cos(a))) % 360.0


@jit
def latlon_of(x, y, z):  # pragma: no cover - compiled
    """(lat, lon) [deg] of a non-zero 3-vector, lon in [-180, 180) (as ``grid.xyz_to_latlon``)."""
    lat = math.degrees(math.atan2(z, math.hypot(x, y)))
    lon = (math.degrees(math.atan2(y, x)) + 180.0) % 360.0 - 180.0
    return lat, lon


@jit
def _course(ax, ay, az, dx, dy, dz):  # pragma: no cover - compiled
    """Course [deg true, in [0, 360)] of direction d at unit point a (as ``grid.course_between_deg``)."""
    rxy = math.hypot(ax, ay)
    safe = rxy if rxy > 0.0 else 1.0
    e = (-ay * dx + ax * dy) / safe
    n = (-az * ax * dx - az * ay * dy) / safe + rxy * dz
    r = math.degrees(math.atan2(e, n)) % 360.0
    return 0.0 if r >= 360.0 else r


@jit
def edge_pieces(tu, tv, f0, f1, n_pieces, lat, lon, course, length):  # pragma: no cover - compiled
    """The pieces of the plane segment ``tu → tv`` cut at plane fractions ``f0[k] < f1[k]``, ``k < n_pieces``.

    Writes each piece's midpoint (lat, lon) [deg], the great-circle course at it
    towards the piece's end [deg true] and its length [nm] into the output rows.  The pieces
    lie on the gnomonic sphere (a straight segment of the grid's plane is a great circle); the
    length and course are taken to WGS84 by the local factor at the midpoint (:func:`wgs84_scale`,
    :func:`wgs84_course`: :func:`optroute.geodesy.sphere_to_wgs84`, second order in the piece's
    length: the pieces of a leg sum to its geodesic length within 1e-6).
    """
    for k in range(n_pieces):
        a0, b0 = 1.0 - f0[k], f0[k]
        a1, b1 = 1.0 - f1[k], f1[k]
        pax, pay, paz = a0 * tu[0] + b0 * tv[0], a0 * tu[1] + b0 * tv[1], a0 * tu[2] + b0 * tv[2]
        pbx, pby, pbz = a1 * tu[0] + b1 * tv[0], a1 * tu[1] + b1 * tv[1], a1 * tu[2] + b1 * tv[2]
        mx, my, mz = pax + pbx, pay + pby, paz + pbz
        na = math.sqrt(pax * pax + pay * pay + paz * paz)
        nb = math.sqrt(pbx * pbx + pby * pby + pbz * pbz)
        nm = math.sqrt(mx * mx + my * my + mz * mz)
        pax, pay, paz = pax / na, pay / na, paz / na
        pbx, pby, pbz = pbx / nb, pby / nb, pbz / nb
        mx, my, mz = mx / nm, my / nm, mz / nm
        lat[k], lon[k] = latlon_of(mx, my, mz)
        c_sphere = _course(mx, my, mz, pbx, pby, pbz)
        course[k] = wgs84_course(lat[k], c_sphere)
        ch = math.sqrt((pax - pbx) ** 2 + (pay - pby) ** 2 + (paz - pbz) ** 2)
        length[k] = 2.0 * _R_NM * math.asin(min(max(ch / 2.0, 0.0), 1.0)) * wgs84_scale(lat[k], c_sphere)


@jit
def piece_frame(lat_deg, lon_deg, course_deg):  # pragma: no cover - compiled
    """The frame :func:`frame_point` walks a piece's great circle in, computed once per piece.

    Returns ``(mx, my, mz, tx, ty, tz, r_nm)``: the unit vector of the point (lat, lon) [deg], the unit
    tangent of the great circle on the ellipsoid's ``course_deg`` [deg true] turned into the sphere's
    (:func:`sphere_course`), and the sphere's radius times the local WGS84 factor [nm per radian].
    """
    c_sphere = sphere_course(lat_deg, course_deg)
    phi, lam, c = math.radians(lat_deg), math.radians(lon_deg), math.radians(c_sphere)
    sp, cp, sl, cl = math.sin(phi), math.cos(phi), math.sin(lam), math.cos(lam)
    sc, cc = math.sin(c), math.cos(c)
    tx = sc * -sl + cc * -sp * cl  # east sin c + north cos c
    ty = sc * cl + cc * -sp * sl
    tz = cc * cp
    return cp * cl, cp * sl, sp, tx, ty, tz, _R_NM * wgs84_scale(lat_deg, c_sphere)


@jit
def frame_point(frame, s_nm):  # pragma: no cover - compiled
    """The point ``s_nm`` [nm, WGS84] along the great circle of a :func:`piece_frame` (negative: behind), and its course.

    Returns ``(lat, lon, course)`` [deg, deg, deg true]; see :func:`piece_point`.
    """
    mx, my, mz, tx, ty, tz, r_nm = frame
    a = s_nm / r_nm
    sa, ca = math.sin(a), math.cos(a)
    px, py, pz = ca * mx + sa * tx, ca * my + sa * ty, ca * mz + sa * tz
    dx, dy, dz = -sa * mx + ca * tx, -sa * my + ca * ty, -sa * mz + ca * tz
    la, lo = latlon_of(px, py, pz)
    return la, lo, wgs84_course(la, _course(px, py, pz, dx, dy, dz))


@jit
def piece_point(lat_deg, lon_deg, course_deg, s_nm):  # pragma: no cover - compiled
    """The point ``s_nm`` along the great circle through (lat, lon) on ``course_deg`` (negative: behind), and the course there.

    The rotation of the unit vector in the plane of the great circle, equal to
    :func:`optroute.geodesy.sphere_destination` with the course at the point reached.
    ``s_nm`` is a WGS84 length and the courses are the ellipsoid's, as the pieces' of :func:`edge_pieces`:
    they are turned into the sphere's arc and course by the same local factor (:func:`sphere_course`),
    so that ``±length / 2`` from a piece's midpoint reaches its ends on the grid's great circle.
    Returns ``(lat, lon, course)`` [deg, deg, deg true].  Several points of one piece: build its
    :func:`piece_frame` once and call :func:`frame_point` (the same numbers).
    """
    return frame_point(piece_frame(lat_deg, lon_deg, course_deg), s_nm)


@jit
def piece_points_flat(lat, lon, course, s_nm, out_lat, out_lon, out_course):  # pragma: no cover - compiled
    """:func:`piece_point` over 1-D arrays of one length."""
    for i in range(s_nm.size):
        out_lat[i], out_lon[i], out_course[i] = piece_point(lat[i], lon[i], course[i], s_nm[i])


@jit
def _edges_batch(tangent, u, v, f0, f1, npc, lat, lon, course, length):  # pragma: no cover - compiled
    for i in range(u.size):
        edge_pieces(tangent[u[i]], tangent[v[i]], f0[i], f1[i], npc[i], lat[i], lon[i], course[i], length[i])


def edge_piece_arrays(
    tangent: np.ndarray, u: np.ndarray, v: np.ndarray, f0: np.ndarray, f1: np.ndarray, n_pieces: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The pieces of edges ``u → v`` as (n, kmax) arrays (zeros past each edge's ``n_pieces``).

    Parameters
    ----------
    tangent : ndarray, shape (n_nodes, 3)
        The nodes on the gnomonic tangent plane (:meth:`~optroute.search.grid.RouteGrid.tangent_points`).
    u, v : ndarray of int, shape (n,)
        Flat start and end nodes.
    f0, f1 : ndarray, shape (n, kmax)
        Plane fractions of each piece's ends.
    n_pieces : ndarray of int, shape (n,)

    Returns
    -------
    lat_deg, lon_deg, course_deg, length_nm : ndarray, shape (n, kmax)
        Piece midpoints, the course there [deg true] and the piece lengths [nm].
    """
    n = u.size
    kmax = int(n_pieces.max()) if n else 0
    out = [np.zeros((n, kmax)) for _ in range(4)]
    if n and kmax:
        _edges_batch(
            np.ascontiguousarray(tangent, dtype=float), np.ascontiguousarray(u, dtype=np.int64),
            np.ascontiguousarray(v, dtype=np.int64), np.ascontiguousarray(f0[:, :kmax], dtype=float),
            np.ascontiguousarray(f1[:, :kmax], dtype=float), np.ascontiguousarray(n_pieces, dtype=np.int64), *out,
        )  # fmt: skip
    return out[0], out[1], out[2], out[3]
