"""Geodesic (WGS84) geometry of the pieces of a leg: the points the passage physics is evaluated at.

Used by the numpy search callbacks of :mod:`optroute.search.routing`; the
points of a piece come from :mod:`optroute.search.edge_geometry`, as in the
compiled kernels.  Positions
[deg], courses [deg true, to], lengths [nm].
"""

from __future__ import annotations

import numpy as np

from optroute import geodesy as geo
from optroute.search.edge_geometry import piece_points_flat

__all__ = ["cumulative", "piece_points", "points_along"]


def cumulative(dt: np.ndarray) -> np.ndarray:
    """Running sums of (n, m - 1) intervals as (n, m) times from 0."""
    return np.concatenate([np.zeros((dt.shape[0], 1)), np.cumsum(dt, axis=1)], axis=1)


def piece_points(lat, lon, course, length_nm, fractions):
    """Points at ``fractions`` (n, m) of pieces given by midpoint, course there and length; the course at each.

    The points lie ``(fraction - 0.5) · length`` along the piece's great circle from its midpoint
    (:func:`optroute.search.edge_geometry.piece_point`, the compiled kernels' own function).
    """
    s = (np.asarray(fractions, dtype=float) - 0.5) * np.asarray(length_nm, dtype=float)[:, None]
    shape = s.shape
    args = [np.ascontiguousarray(np.broadcast_to(np.asarray(a, dtype=float)[:, None], shape)).ravel()
            for a in (lat, lon, course)]  # fmt: skip
    out = [np.empty(s.size) for _ in range(3)]
    if s.size:
        piece_points_flat(*args, np.ascontiguousarray(s).ravel(), *out)
    return tuple(o.reshape(shape) for o in out)


def points_along(lat0, lon0, lat1, lon1, fractions):
    """Points at ``fractions`` (shape (m,), or (n, m) per leg) along each WGS84 geodesic leg, and the course there [deg]."""
    f = np.asarray(fractions, dtype=float)
    f = f if f.ndim == 2 else f[None, :]
    col = (np.asarray(a, dtype=float)[:, None] for a in (lat0, lon0, lat1, lon1))
    return geo.points_along(*col, f)
