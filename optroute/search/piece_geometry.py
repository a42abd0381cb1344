"""Great-circle geometry of the pieces of a leg: the points the passage physics is evaluated at.

Used by the numpy search callbacks of :mod:`optroute.search.routing`; the
points of a piece come from :mod:`optroute.search.edge_geometry`, as in the
compiled kernels.  Positions
[deg], courses [deg true, to], lengths [nm].
"""

from __future__ import annotations

import numpy as np

from optroute import geodesy as geo
from optroute import units
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
    """Points at ``fractions`` (shape (m,), or (n, m) per leg) along each great-circle leg, and the course there [deg]."""
    p0 = np.radians(np.stack([lat0, lon0], axis=-1))
    p1 = np.radians(np.stack([lat1, lon1], axis=-1))
    a = np.stack([np.cos(p0[:, 0]) * np.cos(p0[:, 1]), np.cos(p0[:, 0]) * np.sin(p0[:, 1]), np.sin(p0[:, 0])], -1)
    b = np.stack([np.cos(p1[:, 0]) * np.cos(p1[:, 1]), np.cos(p1[:, 0]) * np.sin(p1[:, 1]), np.sin(p1[:, 0])], -1)
    omega = np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0))[:, None, None]
    f = np.asarray(fractions, dtype=float)
    f = (f if f.ndim == 2 else f[None, :])[:, :, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        w0 = np.where(omega > 1e-12, np.sin((1 - f) * omega) / np.sin(omega), 1 - f)
        w1 = np.where(omega > 1e-12, np.sin(f * omega) / np.sin(omega), f)
    xyz = w0 * a[:, None, :] + w1 * b[:, None, :]
    lat = np.degrees(np.arctan2(xyz[..., 2], np.hypot(xyz[..., 0], xyz[..., 1])))
    lon = units.wrap_180(np.degrees(np.arctan2(xyz[..., 1], xyz[..., 0])))
    lat1b = np.broadcast_to(lat1[:, None], lat.shape)
    lon1b = np.broadcast_to(lon1[:, None], lat.shape)
    course = geo.initial_course_deg(lat, lon, lat1b, lon1b)
    return lat, lon, course
