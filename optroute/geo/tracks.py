"""Tracks on WGS84: points and courses along geodesic legs, the nearest point of a polyline, moving circles.

Shared by the plan's verification (:mod:`optroute.plan.result`) and the corridor adapters
(:mod:`optroute.optimise.nlp_inputs`). Positions (lat, lon) [deg], lon in [-180, 180); courses degrees true,
the direction the ship goes **to**; distances on the WGS84 ellipsoid (:mod:`optroute.geodesy`).
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

__all__ = ["Exclusion", "gc_points", "inner_offset_nm", "project_to_polyline", "within_distance_of_polyline"]


# --------------------------------------------------------------------------- geodesic helpers


def gc_points(
    lat0: ArrayLike, lon0: ArrayLike, lat1: ArrayLike, lon1: ArrayLike, fraction: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points at fractions of geodesic legs on WGS84, and the course of the leg there.

    :func:`optroute.geodesy.points_along` (Karney's geodesics through pyproj); the name is kept
    for its callers, the ellipsoid's great circle being the geodesic.

    Parameters
    ----------
    lat0, lon0, lat1, lon1 : array_like
        Leg ends [deg]; broadcast together with ``fraction``. Not antipodal.
    fraction : array_like
        Fractions of the leg's length in [0, 1].

    Returns
    -------
    lat, lon : ndarray
        Points [deg], lon in [-180, 180).
    course : ndarray
        Course of the leg at the points [deg true, to], in [0, 360); exact at both ends too.
    """
    return geo.points_along(lat0, lon0, lat1, lon1, fraction)


def inner_offset_nm(half_width_nm: float, leg_along_nm: float) -> float:
    """Largest offset from a geodesic at which legs between offset points stay within a half-width of it.

    A leg between two points at the same cross-track offset ``h`` from a great circle, ``L`` apart along it,
    is itself a great circle and bulges away from the centre line: on the sphere of radius R its largest
    offset ``h_max`` satisfies ``tan(h_max/R) = tan(h/R) / cos(L/(2R))`` (Napier's rules for the right
    spherical triangle; the parallel at ``h`` is a small circle, the leg the great circle through two of its
    points). A leg whose ends are at most ``h`` off the line, on either side, stays within ``h_max``. This
    returns the ``h`` whose ``h_max`` is ``half_width_nm``, on the sphere of the ellipsoid's least radius of
    curvature (:data:`optroute.geodesy.SPHERE_TO_WGS84_MIN`), where the bulge is largest: 0.018 nm at 40 nm
    off a line with legs 206 nm long.

    Parameters
    ----------
    half_width_nm : float
        Half-width the legs must stay within [nm].
    leg_along_nm : float
        Largest along-track length of a leg [nm].

    Returns
    -------
    float
        The offset [nm], at most ``half_width_nm``.
    """
    r_nm = geo.EARTH_RADIUS_NM * geo.SPHERE_TO_WGS84_MIN
    h = np.arctan(np.tan(half_width_nm / r_nm) * np.cos(0.5 * leg_along_nm / r_nm)) * r_nm
    return float(min(h, half_width_nm))


def _sphere_foot(
    wp: np.ndarray, lat: np.ndarray, lon: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """The nearest leg of the polyline ``wp`` (n, 2) [deg] to each point (flat ``lat``, ``lon`` [deg]) on the R₁ sphere,
    and the foot on it (:func:`project_to_polyline`'s first step).

    Returns the leg index (M,), the foot's along-track position on the leg's WGS84 geodesic [nm from its start]
    (the sphere's, scaled to the leg's WGS84 length; it may lie before 0 or past the leg's end), the sphere's signed
    cross-track distance [nm], and every leg's WGS84 length [nm] and initial course [deg].
    """
    la0, lo0, la1, lo1 = wp[:-1, 0][None], wp[:-1, 1][None], wp[1:, 0][None], wp[1:, 1][None]
    r = geo.EARTH_RADIUS_NM
    d_sph = geo.sphere_distance_nm(la0, lo0, la1, lo1)
    delta = geo.sphere_distance_nm(la0, lo0, lat[:, None], lon[:, None]) / r
    dth = np.radians(
        geo.sphere_initial_course_deg(la0, lo0, lat[:, None], lon[:, None])
        - geo.sphere_initial_course_deg(la0, lo0, la1, lo1)
    )
    xt_s = r * np.arcsin(np.clip(np.sin(delta) * np.sin(dth), -1.0, 1.0))
    at_s = r * np.arctan2(np.sin(delta) * np.cos(dth), np.cos(delta))
    d_end = geo.sphere_distance_nm(la1, lo1, lat[:, None], lon[:, None])
    on_leg = (at_s >= 0.0) & (at_s <= d_sph)
    k = np.argmin(np.where(on_leg, np.abs(xt_s), np.minimum(delta * r, d_end)), axis=1)
    rows = np.arange(lat.size)
    # on WGS84, along the chosen leg
    d_leg, c_leg, _ = geo.inverse(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
    length = d_leg[k]
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(d_sph[0, k] > 0, length / np.where(d_sph[0, k] > 0, d_sph[0, k], 1.0), 1.0)
    return k, at_s[rows, k] * scale, xt_s[rows, k], (d_leg, c_leg)


def within_distance_of_polyline(
    waypoints: np.ndarray, lat_deg: ArrayLike, lon_deg: ArrayLike, radius_nm: float
) -> np.ndarray:
    """Which points are certainly within ``radius_nm`` [nm] of a geodesic polyline on WGS84: a cheap screen for
    :func:`project_to_polyline`.

    A point is, where its WGS84 distance to one point of the polyline is at most ``radius_nm``: the point on the
    nearest leg's geodesic at the sphere's foot (:func:`project_to_polyline`'s first step, held on the leg). The
    distance to the polyline is never larger, so a point this finds is within the radius; one it does not find may
    be too (the caller measures it with :func:`project_to_polyline`).

    Parameters
    ----------
    waypoints : ndarray, shape (n, 2)
        Polyline (lat, lon) [deg].
    lat_deg, lon_deg : array_like
        Points [deg].
    radius_nm : float
        Distance [nm].

    Returns
    -------
    ndarray of bool
        The points' shape.
    """
    wp = np.asarray(waypoints, dtype=float)
    lat = np.atleast_1d(np.asarray(lat_deg, dtype=float))
    lon = np.atleast_1d(np.asarray(lon_deg, dtype=float))
    k, s, _, (d_leg, c_leg) = _sphere_foot(wp, lat.ravel(), lon.ravel())
    f_lat, f_lon, _ = geo.direct(wp[k, 0], wp[k, 1], c_leg[k], np.clip(s, 0.0, d_leg[k]))
    return (geo.distance_nm(f_lat, f_lon, lat.ravel(), lon.ravel()) <= radius_nm).reshape(lat.shape)


def project_to_polyline(
    waypoints: np.ndarray, lat_deg: ArrayLike, lon_deg: ArrayLike, *, refine: int = 2, clamp: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Nearest point of a geodesic polyline on WGS84: along-track position and cross-track distance.

    The nearest leg is found on the R₁ sphere: for every point and leg, the cross-track distance
    to the leg's great circle ``xt = asin(sin δ sin(θ − θ₁₂))`` and the along-track distance
    ``at = atan2(sin δ cos(θ − θ₁₂), cos δ)`` (δ, θ: angular distance and initial course from the
    leg's start to the point; Napier's rules for the right spherical triangle); a leg counts when
    the foot of the perpendicular lies on it, otherwise the distance to its nearer end does.  On
    that leg the foot is then moved along the WGS84 geodesic until the geodesic from it to the
    point is perpendicular to the leg (``refine`` Newton steps, each a direct and an inverse
    problem: ``s += d cos(az − course)``); the sphere's foot is within 0.3 nm of the true one at
    60 nm off a leg, and two steps bring it to within 1e-3 nm (tested against Karney's geodesics).

    Parameters
    ----------
    waypoints : ndarray, shape (n, 2)
        Polyline (lat, lon) [deg].
    lat_deg, lon_deg : array_like
        Points [deg].
    refine : int
        Newton steps of the foot on the ellipsoid (0: the sphere's foot, scaled to the leg's length).
    clamp : bool
        True: ``s_nm`` is the nearest point *of the polyline* (a foot beyond the nearest leg's end is
        held at that end). False: the foot on the nearest leg's geodesic or its extension, the same
        foot ``xt_nm`` is measured from (``s_nm`` may then lie before 0 or past the leg's end), so that
        (``s_nm``, ``xt_nm``) place a point beyond the polyline's ends at its true distance from them.

    Returns
    -------
    s_nm : ndarray
        Along-track position of the nearest polyline point [nm from the first waypoint] (``clamp=False``:
        of the foot on the nearest leg's extension).
    xt_nm : ndarray
        Signed cross-track offset [nm], positive to starboard of the direction of travel
        (measured to the nearest leg's geodesic, or to its extension for a point beyond its end).
    dist_nm : ndarray
        Distance to the polyline [nm], >= 0.
    leg : ndarray of int
        Index of the nearest leg.
    """
    wp = np.asarray(waypoints, dtype=float)
    lat = np.atleast_1d(np.asarray(lat_deg, dtype=float))
    lon = np.atleast_1d(np.asarray(lon_deg, dtype=float))
    shape = lat.shape
    lat, lon = lat.ravel(), lon.ravel()
    k, s, xt_sphere, (d_leg, c_leg) = _sphere_foot(wp, lat, lon)
    a_lat, a_lon, c0, length = wp[k, 0], wp[k, 1], c_leg[k], d_leg[k]
    for _ in range(max(0, int(refine))):
        f_lat, f_lon, f_course = geo.direct(a_lat, a_lon, c0, s)
        dist, az, _ = geo.inverse(f_lat, f_lon, lat, lon)
        s = s + dist * np.cos(np.radians(az - f_course))
    f_lat, f_lon, f_course = geo.direct(a_lat, a_lon, c0, s)
    dist, az, _ = geo.inverse(f_lat, f_lon, lat, lon)
    xt = dist * np.sign(np.sin(np.radians(az - f_course)))
    if not refine:
        xt = xt_sphere * geo.sphere_to_wgs84(lat, c0 + 90.0)[0]
    inside = (s >= 0.0) & (s <= length)
    out_dist = np.abs(xt)
    beyond = np.flatnonzero(~inside)  # the foot past its leg's ends: the nearer end is the nearest point
    if beyond.size:
        end = k[beyond] + 1
        d_start = geo.distance_nm(a_lat[beyond], a_lon[beyond], lat[beyond], lon[beyond])
        d_stop = geo.distance_nm(wp[end, 0], wp[end, 1], lat[beyond], lon[beyond])
        out_dist[beyond] = np.minimum(d_start, d_stop)
    s_start = np.concatenate([[0.0], np.cumsum(d_leg)])[:-1]
    at_k = np.clip(s, 0.0, length) if clamp else s
    return (
        (s_start[k] + at_k).reshape(shape),
        xt.reshape(shape),
        out_dist.reshape(shape),
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
