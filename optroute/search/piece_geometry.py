"""Geodesic (WGS84) geometry of the pieces of a leg: the points the passage physics is evaluated at.

Used by the search callbacks of :mod:`optroute.search.routing` and, for the
compiled kernels (:mod:`optroute.search.passage_kernels`), to lay out each
piece's check points before the kernel samples the weather there.  Positions
[deg], courses [deg true, to], lengths [nm].
"""

from __future__ import annotations

import numpy as np

from optroute import geodesy as geo

__all__ = ["check_points", "cumulative", "piece_points", "points_along"]


def check_points(lat, lon, course, length, n_pieces, check_nm):
    """The check points of every piece of a batch for :func:`~optroute.search.passage_kernels.cost_legs`.

    As :meth:`optroute.search.routing.PassagePhysics.segment_checked`: ``1 + 2 max(1, ceil(length / 2 check_nm))``
    points per piece, evenly spaced, ends included.  Returns (lat, lon, course) of shape
    (n, kmax, m) and the count per piece (n, kmax); empty arrays without a check.
    """
    n, kmax = lat.shape
    if check_nm is None:
        return np.zeros((n, kmax, 1)), np.zeros((n, kmax, 1)), np.zeros((n, kmax, 1)), np.zeros((n, kmax), np.int64)
    real = np.arange(kmax)[None, :] < n_pieces[:, None]
    n_pts = np.where(real, 1 + 2 * np.maximum(1, np.ceil(length / (2.0 * check_nm))), 0).astype(np.int64)
    m = int(n_pts.max(initial=3))
    out = [np.zeros((n, kmax, m)) for _ in range(3)]
    i, k = np.nonzero(real)
    if i.size:
        npk = n_pts[i, k][:, None]
        frac = np.minimum(np.arange(m)[None, :], npk - 1) / (npk - 1)
        for o, a in zip(out, piece_points(lat[i, k], lon[i, k], course[i, k], length[i, k], frac), strict=True):
            o[i, k] = a
    return (*out, n_pts)


def cumulative(dt: np.ndarray) -> np.ndarray:
    """Running sums of (n, m - 1) intervals as (n, m) times from 0."""
    return np.concatenate([np.zeros((dt.shape[0], 1)), np.cumsum(dt, axis=1)], axis=1)


def piece_points(lat, lon, course, length_nm, fractions):
    """Points at ``fractions`` (n, m) of pieces given by midpoint, course there and length; the course at each."""
    s = (fractions - 0.5) * length_nm[:, None]
    return geo.direct(lat[:, None], lon[:, None], course[:, None], s)  # backwards along the geodesic for s < 0


def points_along(lat0, lon0, lat1, lon1, fractions):
    """Points at ``fractions`` (shape (m,), or (n, m) per leg) along each WGS84 geodesic leg, and the course there [deg]."""
    f = np.asarray(fractions, dtype=float)
    f = f if f.ndim == 2 else f[None, :]
    col = (np.asarray(a, dtype=float)[:, None] for a in (lat0, lon0, lat1, lon1))
    return geo.points_along(*col, f)
