"""Spherical-earth navigation geometry: great circles and the gnomonic grid.

The Earth is a sphere of the IUGG mean radius R₁ = 6 371 008.8 m (Moritz,
2000, *Geodetic Reference System 1980*); great-circle distances then differ
from WGS84 geodesics by at most about 0.5 %, well inside forecast and
speed-model uncertainty.  Formulas: Snyder (1987), *Map Projections — A
Working Manual*, USGS PP 1395, §5 (great circles) and §22 (gnomonic).

Positions are (lat, lon) in degrees, lon in [-180, 180); every function
works across the antimeridian.  Courses are degrees true, the direction the
ship goes to.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError

EARTH_RADIUS_M = 6_371_008.8
EARTH_RADIUS_NM = EARTH_RADIUS_M / units.M_PER_NM


def _latlon(lat_deg: ArrayLike, lon_deg: ArrayLike, what: str = "") -> tuple[np.ndarray, np.ndarray]:
    lat = finite(f"{what}lat_deg", lat_deg, error=ConfigError)
    lon = finite(f"{what}lon_deg", lon_deg, error=ConfigError)
    if np.any(np.abs(lat) > 90.0):
        bad = lat[np.abs(lat) > 90.0].flat[0]
        raise ConfigError(f"{what}latitude {bad!r} deg is outside [-90, 90]; pass (lat, lon) in degrees")
    return np.radians(lat), np.radians(lon)


def distance_nm(lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike) -> np.ndarray:
    """Great-circle distance (haversine) between two positions.

    Parameters
    ----------
    lat1_deg, lon1_deg, lat2_deg, lon2_deg : array_like
        Positions [deg, lat north positive, lon east positive].

    Returns
    -------
    ndarray
        Distance [nm] on the sphere of radius :data:`EARTH_RADIUS_NM`.
    """
    p1, l1 = _latlon(lat1_deg, lon1_deg)
    p2, l2 = _latlon(lat2_deg, lon2_deg)
    h = np.sin((p2 - p1) / 2) ** 2 + np.cos(p1) * np.cos(p2) * np.sin((l2 - l1) / 2) ** 2
    return 2.0 * EARTH_RADIUS_NM * np.arcsin(np.sqrt(np.clip(h, 0.0, 1.0)))


def initial_course_deg(
    lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike
) -> np.ndarray:
    """Initial great-circle course from point 1 to point 2 [deg true, to], in [0, 360)."""
    p1, l1 = _latlon(lat1_deg, lon1_deg)
    p2, l2 = _latlon(lat2_deg, lon2_deg)
    dl = l2 - l1
    y = np.sin(dl) * np.cos(p2)
    x = np.cos(p1) * np.sin(p2) - np.sin(p1) * np.cos(p2) * np.cos(dl)
    return units.wrap_360(np.degrees(np.arctan2(y, x)))


def destination(
    lat_deg: ArrayLike, lon_deg: ArrayLike, course_deg: ArrayLike, distance_nm_: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Point reached by sailing a great circle from a start on an initial course.

    Parameters
    ----------
    lat_deg, lon_deg : array_like
        Start [deg].
    course_deg : array_like
        Initial course [deg true, to].
    distance_nm_ : array_like
        Distance sailed [nm].

    Returns
    -------
    lat, lon : ndarray
        End point [deg], lon in [-180, 180).
    """
    p1, l1 = _latlon(lat_deg, lon_deg)
    c = np.radians(np.asarray(course_deg, dtype=float))
    d = np.asarray(distance_nm_, dtype=float) / EARTH_RADIUS_NM
    p2 = np.arcsin(np.clip(np.sin(p1) * np.cos(d) + np.cos(p1) * np.sin(d) * np.cos(c), -1, 1))
    l2 = l1 + np.arctan2(np.sin(c) * np.sin(d) * np.cos(p1), np.cos(d) - np.sin(p1) * np.sin(p2))
    return np.degrees(p2), units.wrap_180(np.degrees(l2))


def _to_xyz(lat_rad: np.ndarray, lon_rad: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(lat_rad) * np.cos(lon_rad), np.cos(lat_rad) * np.sin(lon_rad), np.sin(lat_rad)], axis=-1)


def _from_xyz(xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
    return np.degrees(np.arctan2(z, np.hypot(x, y))), units.wrap_180(np.degrees(np.arctan2(y, x)))


def intermediate_points(
    lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float, fractions: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Points at given fractions of the great-circle arc from point 1 to point 2.

    Spherical linear interpolation of the unit vectors (Snyder 1987 §5).

    Parameters
    ----------
    lat1_deg, lon1_deg, lat2_deg, lon2_deg : float
        End points [deg]; they must not be antipodal.
    fractions : array_like
        Fractions of the arc in [0, 1].

    Returns
    -------
    lat, lon : ndarray
        Points [deg], lon in [-180, 180).
    """
    p1, l1 = _latlon(lat1_deg, lon1_deg)
    p2, l2 = _latlon(lat2_deg, lon2_deg)
    a, b = _to_xyz(p1, l1), _to_xyz(p2, l2)
    omega = np.arccos(np.clip(np.dot(a, b), -1.0, 1.0))
    f = np.asarray(fractions, dtype=float)[..., None]
    if omega < 1e-12:
        return _from_xyz(np.broadcast_to(a, f.shape[:-1] + (3,)).copy())
    if abs(omega - np.pi) < 1e-9:
        raise ConfigError(
            f"({lat1_deg}, {lon1_deg}) and ({lat2_deg}, {lon2_deg}) are antipodal: the great circle "
            "between them is not unique; add a waypoint"
        )
    xyz = (np.sin((1 - f) * omega) * a + np.sin(f * omega) * b) / np.sin(omega)
    return _from_xyz(xyz)


def great_circle_points(
    lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """``n`` >= 2 equally spaced points on the great circle, both ends included [deg]."""
    if n < 2:
        raise ConfigError(f"n={n} points cannot describe a great circle; use n >= 2")
    return intermediate_points(lat1_deg, lon1_deg, lat2_deg, lon2_deg, np.linspace(0.0, 1.0, n))


def gnomonic_forward(
    lat_deg: ArrayLike, lon_deg: ArrayLike, lat0_deg: float, lon0_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """Gnomonic projection centred at (lat0, lon0): great circles map to straight lines.

    Snyder (1987) eqs. 22-3 to 22-5, scaled by the Earth radius.

    Parameters
    ----------
    lat_deg, lon_deg : array_like
        Points [deg]; they must lie within 90° of the centre.
    lat0_deg, lon0_deg : float
        Projection centre [deg].

    Returns
    -------
    x_nm, y_nm : ndarray
        Plane coordinates [nm], x east and y north at the centre.
    """
    p, lam = _latlon(lat_deg, lon_deg)
    p0, l0 = _latlon(lat0_deg, lon0_deg, "centre ")
    cos_c = np.sin(p0) * np.sin(p) + np.cos(p0) * np.cos(p) * np.cos(lam - l0)
    if np.any(cos_c <= 1e-6):
        raise ConfigError(
            "a point lies 90 deg or more from the gnomonic centre "
            f"({lat0_deg}, {lon0_deg}); split the voyage into shorter parts"
        )
    x = np.cos(p) * np.sin(lam - l0) / cos_c
    y = (np.cos(p0) * np.sin(p) - np.sin(p0) * np.cos(p) * np.cos(lam - l0)) / cos_c
    return EARTH_RADIUS_NM * x, EARTH_RADIUS_NM * y


def gnomonic_inverse(
    x_nm: ArrayLike, y_nm: ArrayLike, lat0_deg: float, lon0_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """Inverse gnomonic projection (Snyder 1987 eqs. 22-14, 22-15) [nm] → (lat, lon) [deg]."""
    x = np.asarray(x_nm, dtype=float) / EARTH_RADIUS_NM
    y = np.asarray(y_nm, dtype=float) / EARTH_RADIUS_NM
    p0, l0 = _latlon(lat0_deg, lon0_deg, "centre ")
    rho = np.hypot(x, y)
    c = np.arctan(rho)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(rho > 0, y * np.sin(c) * np.cos(p0) / np.where(rho > 0, rho, 1.0), 0.0)
    lat = np.arcsin(np.clip(np.cos(c) * np.sin(p0) + ratio, -1, 1))
    lon = l0 + np.arctan2(x * np.sin(c), rho * np.cos(p0) * np.cos(c) - y * np.sin(p0) * np.sin(c))
    return np.degrees(lat), units.wrap_180(np.degrees(lon))


def midpoint(lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float) -> tuple[float, float]:
    """Great-circle midpoint of two positions [deg]."""
    lat, lon = intermediate_points(lat1_deg, lon1_deg, lat2_deg, lon2_deg, 0.5)
    return float(lat), float(lon)


def unwrap_lon_deg(lon_deg: ArrayLike) -> np.ndarray:
    """Unwrap a sequence of longitudes [deg] so consecutive values never jump by more than 180°."""
    return np.degrees(np.unwrap(np.radians(np.asarray(lon_deg, dtype=float))))
