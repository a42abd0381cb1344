"""Tracks on the sphere: points and courses along great circles, the nearest point of a polyline, moving circles.

Shared by the plan's verification (:mod:`optroute.plan.result`) and the corridor adapters
(:mod:`optroute.optimise.nlp_inputs`). Positions (lat, lon) [deg], lon in [-180, 180); courses degrees true,
the direction the ship goes **to**; the sphere of :data:`optroute.geodesy.EARTH_RADIUS_NM`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.units import h_to_timedelta as _h_to_td
from optroute.units import timedelta_to_h as _td_to_h

if TYPE_CHECKING:
    from optroute.weather.cyclone_tracks import CycloneTrack

__all__ = ["Exclusion", "gc_points", "project_to_polyline"]


# --------------------------------------------------------------------------- great-circle helpers


def _xyz(lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
    p, lam = np.radians(lat_deg), np.radians(lon_deg)
    return np.stack([np.cos(p) * np.cos(lam), np.cos(p) * np.sin(lam), np.sin(p)], axis=-1)


def gc_points(
    lat0: ArrayLike, lon0: ArrayLike, lat1: ArrayLike, lon1: ArrayLike, fraction: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points at fractions of great-circle arcs, and the course of the arc there.

    Spherical linear interpolation of the unit vectors (Snyder 1987 §5); the course is the
    direction of the arc's tangent ``dp/df`` at the point, so it is exact at both ends too.

    Parameters
    ----------
    lat0, lon0, lat1, lon1 : array_like
        Arc ends [deg]; broadcast together with ``fraction``. Not antipodal.
    fraction : array_like
        Fractions of the arc in [0, 1].

    Returns
    -------
    lat, lon : ndarray
        Points [deg], lon in [-180, 180).
    course : ndarray
        Course of the arc at the points [deg true, to], in [0, 360).
    """
    lat0, lon0, lat1, lon1, f = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (lat0, lon0, lat1, lon1, fraction))
    )
    a, b = _xyz(lat0, lon0), _xyz(lat1, lon1)
    omega = np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0))[..., None]
    fe = f[..., None]
    small = omega < 1e-12
    so = np.where(small, 1.0, np.sin(omega))
    w0 = np.where(small, 1.0 - fe, np.sin((1.0 - fe) * omega) / so)
    w1 = np.where(small, fe, np.sin(fe * omega) / so)
    p = w0 * a + w1 * b
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    tangent = np.where(small, b - a, -np.cos((1.0 - fe) * omega) * a + np.cos(fe * omega) * b)
    lat = np.degrees(np.arctan2(p[..., 2], np.hypot(p[..., 0], p[..., 1])))
    lon_r = np.arctan2(p[..., 1], p[..., 0])
    east = np.stack([-np.sin(lon_r), np.cos(lon_r), np.zeros_like(lon_r)], axis=-1)
    pr = np.radians(lat)
    north = np.stack([-np.sin(pr) * np.cos(lon_r), -np.sin(pr) * np.sin(lon_r), np.cos(pr)], axis=-1)
    course = units.wrap_360(np.degrees(np.arctan2(np.sum(tangent * east, -1), np.sum(tangent * north, -1))))
    return lat, units.wrap_180(np.degrees(lon_r)), course


def project_to_polyline(
    waypoints: np.ndarray, lat_deg: ArrayLike, lon_deg: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Nearest point of a great-circle polyline: along-track position and cross-track distance.

    For every point and polyline leg, the cross-track distance to the leg's great circle
    ``xt = asin(sin δ sin(θ − θ₁₂))`` and the along-track distance
    ``at = atan2(sin δ cos(θ − θ₁₂), cos δ)`` (δ, θ: angular distance and initial course from the
    leg's start to the point; Napier's rules for the right spherical triangle); a leg counts when
    the foot of the perpendicular lies on it, otherwise the distance to its nearer end does.

    Parameters
    ----------
    waypoints : ndarray, shape (n, 2)
        Polyline (lat, lon) [deg].
    lat_deg, lon_deg : array_like
        Points [deg].

    Returns
    -------
    s_nm : ndarray
        Along-track position of the nearest polyline point [nm from the first waypoint].
    xt_nm : ndarray
        Signed cross-track offset [nm], positive to starboard of the direction of travel
        (measured to the nearest leg's great circle, or to its end for a point beyond it).
    dist_nm : ndarray
        Distance to the polyline [nm], >= 0.
    leg : ndarray of int
        Index of the nearest leg.
    """
    wp = np.asarray(waypoints, dtype=float)
    lat = np.atleast_1d(np.asarray(lat_deg, dtype=float))
    lon = np.atleast_1d(np.asarray(lon_deg, dtype=float))
    shape = lat.shape
    lat, lon = lat.ravel()[:, None], lon.ravel()[:, None]
    la0, lo0, la1, lo1 = wp[:-1, 0][None], wp[:-1, 1][None], wp[1:, 0][None], wp[1:, 1][None]
    r = geo.EARTH_RADIUS_NM
    d_leg = geo.distance_nm(la0, lo0, la1, lo1)
    delta = geo.distance_nm(la0, lo0, lat, lon) / r
    dth = np.radians(geo.initial_course_deg(la0, lo0, lat, lon) - geo.initial_course_deg(la0, lo0, la1, lo1))
    xt = r * np.arcsin(np.clip(np.sin(delta) * np.sin(dth), -1.0, 1.0))
    at = r * np.arctan2(np.sin(delta) * np.cos(dth), np.cos(delta))
    d_end = geo.distance_nm(la1, lo1, lat, lon)
    on_leg = (at >= 0.0) & (at <= d_leg)
    dist = np.where(on_leg, np.abs(xt), np.minimum(delta * r, d_end))
    k = np.argmin(dist, axis=1)
    rows = np.arange(lat.shape[0])
    s_start = np.concatenate([[0.0], np.cumsum(d_leg[0])])[:-1]
    at_k = np.clip(at[rows, k], 0.0, d_leg[0, k])
    return (
        (s_start[k] + at_k).reshape(shape),
        xt[rows, k].reshape(shape),
        dist[rows, k].reshape(shape),
        k.reshape(shape),
    )


# --------------------------------------------------------------------------- exclusion


@dataclass(frozen=True)
class Exclusion:
    """A moving circle the ship must stay out of (a storm or cyclone centre plus a safety radius).

    Centre and radius are interpolated linearly in time (longitude unwrapped, so a track may
    cross the antimeridian) and held at the first/last value outside the track.

    Parameters
    ----------
    time : array_like of datetime64, shape (n,)
        Track times [UTC], strictly increasing.
    lat_deg, lon_deg : array_like, shape (n,)
        Centre [deg].
    radius_nm : float or array_like, shape (n,)
        Exclusion radius [nm], >= 0.
    """

    time: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    radius_nm: np.ndarray

    def __post_init__(self) -> None:
        t = np.atleast_1d(np.asarray(self.time, dtype="datetime64[ns]"))
        if t.ndim != 1 or t.size == 0 or np.isnat(t).any() or np.any(np.diff(t) <= np.timedelta64(0, "ns")):
            raise ConfigError(f"Exclusion.time must be non-empty, strictly increasing UTC times, got {t!r}")
        lat = np.broadcast_to(finite("Exclusion.lat_deg", self.lat_deg, error=ConfigError), t.shape).copy()
        lon = np.broadcast_to(finite("Exclusion.lon_deg", self.lon_deg, error=ConfigError), t.shape).copy()
        rad = np.broadcast_to(finite("Exclusion.radius_nm", self.radius_nm, minimum=0.0, error=ConfigError), t.shape)
        if np.any(np.abs(lat) > 90):
            raise ConfigError(f"Exclusion.lat_deg has a latitude outside [-90, 90]: {lat}; pass (lat, lon) in degrees")
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "lat_deg", lat)
        object.__setattr__(self, "lon_deg", units.wrap_180(lon))
        object.__setattr__(self, "radius_nm", rad.copy())

    @classmethod
    def from_cyclone(cls, source: xr.Dataset | str, margin_km: float = 30.0) -> Exclusion:
        """The typhoon-avoidance patent's circle (radius of Beaufort-7 winds + ``margin_km``) along a cyclone track.

        Parameters
        ----------
        source : xarray.Dataset or str
            A :func:`optroute.scenarios.tropical_cyclone` dataset or its ``attrs["cyclone"]``.
        margin_km : float
            Safety margin added to the force-7 radius [km] (the typhoon-avoidance patent settles on 30 km).
        """
        from optroute.weather.cyclone import cyclone_track

        tr = cyclone_track(source)
        margin = float(finite("margin_km", margin_km, minimum=0.0, error=ConfigError))
        radius_nm = (tr["r7_km"] + margin) * 1000.0 / units.M_PER_NM
        return cls(tr["time"], tr["lat"], tr["lon"], radius_nm)

    @classmethod
    def from_track(
        cls, track: CycloneTrack, margin_km: float = 30.0, cone_km_per_h: float | None = None, step_h: float = 1.0
    ) -> Exclusion:
        """The circle R + ``margin_km`` (+ the forecast cone) along a read cyclone track.

        Parameters
        ----------
        track : CycloneTrack
            From :func:`optroute.weather.cyclone_tracks.read_track` (ATCF or IBTrACS).
        margin_km : float
            Safety margin added to the force-7 radius R [km] (the typhoon-avoidance patent: 30 km).
        cone_km_per_h : float, optional
            Growth of the radius with the forecast lead time [km/h]; default
            :data:`~optroute.weather.cyclone_tracks.DEFAULT_CONE_KM_PER_H` (0 adds nothing; a best
            track has lead 0 everywhere).
        step_h : float
            Spacing of the circle's time samples [h] (the centre is interpolated linearly in time
            between the track's points; the radius too).
        """
        from optroute.weather.cyclone_tracks import DEFAULT_CONE_KM_PER_H

        margin = float(finite("margin_km", margin_km, minimum=0.0, error=ConfigError))
        cone = DEFAULT_CONE_KM_PER_H if cone_km_per_h is None else cone_km_per_h
        cone = float(finite("cone_km_per_h", cone, minimum=0.0, error=ConfigError))
        step = float(finite("step_h", step_h, minimum=0.0, strict=True, error=ConfigError))
        span_h = float((track.time[-1] - track.time[0]) / np.timedelta64(1, "h"))
        hours = np.unique(np.concatenate([np.arange(0.0, span_h, step), _td_to_h(track.time - track.time[0])]))
        t = track.time[0] + _h_to_td(hours)
        s = track.at(t)
        radius_km = s["r7_km"] + margin + cone * s["lead_h"]
        return cls(t, s["lat"], s["lon"], radius_km * 1000.0 / units.M_PER_NM)

    def at(self, time: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centre (lat, lon) [deg] and radius [nm] at the given UTC times."""
        t = np.asarray(time, dtype="datetime64[ns]")
        x = _td_to_h(self.time - self.time[0])
        q = _td_to_h(t - self.time[0])
        lon_u = geo.unwrap_lon_deg(self.lon_deg)
        return (
            np.interp(q, x, self.lat_deg),
            units.wrap_180(np.interp(q, x, lon_u)),
            np.interp(q, x, self.radius_nm),
        )
