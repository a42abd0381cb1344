"""Navigation geometry on the WGS84 ellipsoid, and the sphere where a formula needs one.

Ships navigate on the WGS84 ellipsoid (a = 6 378 137 m, 1/f = 298.257 223 563;
NIMA TR8350.2, 2000).  Distances, initial and final courses, the direct problem
(where a course and a distance lead) and points along a leg are computed on it
through PROJ's implementation of Karney's geodesic algorithms (C. F. F. Karney,
"Algorithms for geodesics", J. Geodesy 87, 43–55, 2013; the same algorithms as
GeographicLib), by :class:`pyproj.Geod`, vectorised, accurate to 15 nm
(nanometres) — far below anything a voyage plan needs.  A "leg" is a geodesic,
the ellipsoid's great circle.

The sphere of the IUGG mean radius R₁ = 6 371 008.8 m (Moritz 2000, *Geodetic
Reference System 1980*) is kept, under names that say so (``sphere_*``,
``gnomonic_*``, :data:`EARTH_RADIUS_NM`), only where a formula needs it: the
gnomonic routing grid (great circles straight, Snyder 1987 §22), closed forms
inside numba kernels and the cross-track trigonometry of a polyline.  Its error
is bounded: every curve's length on the ellipsoid is between
:data:`SPHERE_TO_WGS84_MIN` and :data:`SPHERE_TO_WGS84_MAX` times its length on
that sphere (same latitudes and longitudes), i.e. −0.56 % to +0.45 %, because
the ellipsoid's principal radii of curvature M (meridian) and N (prime
vertical) lie between a(1 − e²) and a/√(1 − e²); :func:`sphere_to_wgs84` gives
the local factor, which turns a short spherical piece into its ellipsoidal
length and course to second order in its length.

Positions are (lat, lon) in degrees (geodetic latitude), lon in [-180, 180);
every function works across the antimeridian and broadcasts its arguments.
Courses are degrees true in [0, 360), the direction the ship goes **to**.
Distances are nautical miles (1 852 m).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from pyproj import Geod

from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError

__all__ = [
    "EARTH_RADIUS_M",
    "EARTH_RADIUS_NM",
    "SPHERE_TO_WGS84_MAX",
    "SPHERE_TO_WGS84_MIN",
    "WGS84_A_M",
    "WGS84_F",
    "destination",
    "direct",
    "distance_nm",
    "final_course_deg",
    "geodesic_points",
    "gnomonic_forward",
    "gnomonic_inverse",
    "great_circle_points",
    "initial_course_deg",
    "intermediate_points",
    "inverse",
    "midpoint",
    "points_along",
    "sphere_destination",
    "sphere_distance_nm",
    "sphere_initial_course_deg",
    "sphere_to_wgs84",
    "wgs84_local_factor",
    "wgs84_radii_m",
    "unwrap_lon_deg",
]

WGS84_A_M = 6_378_137.0
"""WGS84 semi-major axis [m] (NIMA TR8350.2)."""
WGS84_F = 1.0 / 298.257223563
"""WGS84 flattening [-] (NIMA TR8350.2)."""
_E2 = WGS84_F * (2.0 - WGS84_F)

EARTH_RADIUS_M = 6_371_008.8
"""IUGG mean radius R₁ [m] of the sphere kept for gnomonic and closed-form formulas."""
EARTH_RADIUS_NM = EARTH_RADIUS_M / units.M_PER_NM

SPHERE_TO_WGS84_MIN = WGS84_A_M * (1.0 - _E2) / EARTH_RADIUS_M
"""Least ratio of a curve's WGS84 length to its length on the R₁ sphere: M at the equator / R₁ (0.99442)."""
SPHERE_TO_WGS84_MAX = WGS84_A_M / np.sqrt(1.0 - _E2) / EARTH_RADIUS_M
"""Largest ratio of a curve's WGS84 length to its length on the R₁ sphere: M = N at a pole / R₁ (1.00449)."""

_GEOD = Geod(a=WGS84_A_M, f=WGS84_F)


def _deg(lat_deg: ArrayLike, lon_deg: ArrayLike, what: str = "") -> tuple[np.ndarray, np.ndarray]:
    lat = finite(f"{what}lat_deg", lat_deg, error=ConfigError)
    lon = finite(f"{what}lon_deg", lon_deg, error=ConfigError)
    if np.any(np.abs(lat) > 90.0):
        bad = lat[np.abs(lat) > 90.0].flat[0]
        raise ConfigError(f"{what}latitude {bad!r} deg is outside [-90, 90]; pass (lat, lon) in degrees")
    return lat, lon


def _latlon(lat_deg: ArrayLike, lon_deg: ArrayLike, what: str = "") -> tuple[np.ndarray, np.ndarray]:
    lat, lon = _deg(lat_deg, lon_deg, what)
    return np.radians(lat), np.radians(lon)


def _flat(*arrays: np.ndarray) -> tuple[tuple[int, ...], list[np.ndarray]]:
    b = np.broadcast_arrays(*arrays)
    return b[0].shape, [np.ascontiguousarray(a, dtype=float).ravel() for a in b]


# --------------------------------------------------------------------------- the ellipsoid


def inverse(
    lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The inverse geodesic problem on WGS84 (Karney 2013, through :class:`pyproj.Geod`).

    Parameters
    ----------
    lat1_deg, lon1_deg, lat2_deg, lon2_deg : array_like
        Start and end [deg, lat north positive, lon east positive]; broadcast together.

    Returns
    -------
    distance_nm : ndarray
        Length of the shortest geodesic [nm].
    initial_course_deg, final_course_deg : ndarray
        Course at the start and at the end, in the direction of travel [deg true, to], in [0, 360).
        Coincident points give distance 0 and an arbitrary course.
    """
    la1, lo1 = _deg(lat1_deg, lon1_deg)
    la2, lo2 = _deg(lat2_deg, lon2_deg)
    shape, (la1, lo1, la2, lo2) = _flat(la1, lo1, la2, lo2)
    az1, az2_back, d_m = _GEOD.inv(lo1, la1, lo2, la2)
    c1 = units.wrap_360(np.asarray(az1)).reshape(shape)
    c2 = units.wrap_360(np.asarray(az2_back) + 180.0).reshape(shape)
    return np.asarray(d_m).reshape(shape) / units.M_PER_NM, c1, c2


def distance_nm(lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike) -> np.ndarray:
    """Geodesic distance on WGS84 between two positions.

    Parameters
    ----------
    lat1_deg, lon1_deg, lat2_deg, lon2_deg : array_like
        Positions [deg, lat north positive, lon east positive].

    Returns
    -------
    ndarray
        Distance [nm] (Karney 2013 through :class:`pyproj.Geod`).
    """
    return inverse(lat1_deg, lon1_deg, lat2_deg, lon2_deg)[0]


def initial_course_deg(
    lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike
) -> np.ndarray:
    """Initial course of the WGS84 geodesic from point 1 to point 2 [deg true, to], in [0, 360)."""
    return inverse(lat1_deg, lon1_deg, lat2_deg, lon2_deg)[1]


def final_course_deg(lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike) -> np.ndarray:
    """Course on arrival at point 2 of the WGS84 geodesic from point 1 [deg true, to], in [0, 360)."""
    return inverse(lat1_deg, lon1_deg, lat2_deg, lon2_deg)[2]


def direct(
    lat_deg: ArrayLike, lon_deg: ArrayLike, course_deg: ArrayLike, distance_nm_: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The direct geodesic problem on WGS84: where a course and a distance lead, and the course there.

    Parameters
    ----------
    lat_deg, lon_deg : array_like
        Start [deg].
    course_deg : array_like
        Initial course [deg true, to].
    distance_nm_ : array_like
        Distance sailed along the geodesic [nm]; negative goes backwards along it.

    Returns
    -------
    lat, lon : ndarray
        End point [deg], lon in [-180, 180).
    course : ndarray
        Course of the geodesic at the end, in the direction of ``course_deg`` [deg true, to].
    """
    la, lo = _deg(lat_deg, lon_deg)
    c = finite("course_deg", course_deg, error=ConfigError)
    d = finite("distance_nm", distance_nm_, error=ConfigError)
    shape, (la, lo, c, d) = _flat(la, lo, c, d)
    lo2, la2, back = _GEOD.fwd(lo, la, c, d * units.M_PER_NM)
    return (
        np.asarray(la2).reshape(shape),
        units.wrap_180(np.asarray(lo2)).reshape(shape),
        units.wrap_360(np.asarray(back) + 180.0).reshape(shape),
    )


def destination(
    lat_deg: ArrayLike, lon_deg: ArrayLike, course_deg: ArrayLike, distance_nm_: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Point reached by sailing the WGS84 geodesic from a start on an initial course.

    Parameters
    ----------
    lat_deg, lon_deg : array_like
        Start [deg].
    course_deg : array_like
        Initial course [deg true, to].
    distance_nm_ : array_like
        Distance sailed [nm] (negative: backwards).

    Returns
    -------
    lat, lon : ndarray
        End point [deg], lon in [-180, 180).
    """
    lat, lon, _ = direct(lat_deg, lon_deg, course_deg, distance_nm_)
    return lat, lon


def points_along(
    lat0_deg: ArrayLike, lon0_deg: ArrayLike, lat1_deg: ArrayLike, lon1_deg: ArrayLike, fraction: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points at fractions of WGS84 geodesic legs, and the course of the leg there.

    Parameters
    ----------
    lat0_deg, lon0_deg, lat1_deg, lon1_deg : array_like
        Leg ends [deg]; broadcast together with ``fraction``. Not antipodal.
    fraction : array_like
        Fractions of each leg's length in [0, 1].

    Returns
    -------
    lat, lon : ndarray
        Points [deg], lon in [-180, 180).
    course : ndarray
        Course of the leg at the points, in its direction of travel [deg true, to], in [0, 360)
        (exact at both ends: the initial and the final course).
    """
    d, c0, c1 = inverse(lat0_deg, lon0_deg, lat1_deg, lon1_deg)
    f = finite("fraction", fraction, error=ConfigError)
    la0, lo0 = _deg(lat0_deg, lon0_deg)
    la1, lo1 = _deg(lat1_deg, lon1_deg)
    lat, lon, course = direct(la0, lo0, c0, f * d)
    # the ends exactly as given (no round-off: a waypoint is checked where it is)
    end = np.broadcast_to(f == 1.0, lat.shape)
    start = np.broadcast_to(f == 0.0, lat.shape)
    lat = np.where(end, la1, np.where(start, la0, lat))
    lon = np.where(end, units.wrap_180(lo1), np.where(start, units.wrap_180(lo0), lon))
    return lat, lon, np.where(end, c1, course)


def intermediate_points(
    lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float, fractions: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Points at given fractions of the WGS84 geodesic from point 1 to point 2.

    Parameters
    ----------
    lat1_deg, lon1_deg, lat2_deg, lon2_deg : float
        End points [deg]; they must not be antipodal.
    fractions : array_like
        Fractions of the length in [0, 1].

    Returns
    -------
    lat, lon : ndarray
        Points [deg], lon in [-180, 180).

    Raises
    ------
    ConfigError
        Antipodal end points (the geodesic between them is not unique).
    """
    p1, l1 = _latlon(lat1_deg, lon1_deg)
    p2, l2 = _latlon(lat2_deg, lon2_deg)
    cos_w = np.sin(p1) * np.sin(p2) + np.cos(p1) * np.cos(p2) * np.cos(l2 - l1)
    if np.any(cos_w < -1.0 + 1e-12):
        raise ConfigError(
            f"({lat1_deg}, {lon1_deg}) and ({lat2_deg}, {lon2_deg}) are antipodal: the geodesic "
            "between them is not unique; add a waypoint"
        )
    lat, lon, _ = points_along(lat1_deg, lon1_deg, lat2_deg, lon2_deg, fractions)
    return lat, lon


def geodesic_points(
    lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """``n`` >= 2 equally spaced points on the WGS84 geodesic, both ends included [deg]."""
    if n < 2:
        raise ConfigError(f"n={n} points cannot describe a geodesic; use n >= 2")
    return intermediate_points(lat1_deg, lon1_deg, lat2_deg, lon2_deg, np.linspace(0.0, 1.0, n))


great_circle_points = geodesic_points
"""The name kept for callers: the ellipsoid's "great circle" is the geodesic (:func:`geodesic_points`)."""


def midpoint(lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float) -> tuple[float, float]:
    """Midpoint of the WGS84 geodesic between two positions [deg]."""
    lat, lon = intermediate_points(lat1_deg, lon1_deg, lat2_deg, lon2_deg, 0.5)
    return float(lat), float(lon)


# --------------------------------------------------------------------------- the sphere, where needed


def wgs84_radii_m(lat_deg):
    """WGS84's principal radii of curvature (M, N) at a geodetic latitude [m].

    M = a(1 − e²)/(1 − e² sin² φ)^{3/2} (meridian) and N = a/(1 − e² sin² φ)^{1/2} (prime
    vertical), Torge & Müller, *Geodesy*, 4th ed., §4.1.  Written with numpy's ufuncs only, so that
    one source serves arrays (numpy) and single points in the compiled kernels
    (:mod:`optroute.search.edge_geometry` compiles it with numba; this module never imports numba).

    Parameters
    ----------
    lat_deg : float or ndarray
        Geodetic latitude [deg].

    Returns
    -------
    (float or ndarray, float or ndarray)
        M and N [m].
    """
    s = np.sin(np.radians(lat_deg))
    w = 1.0 - _E2 * s * s
    return WGS84_A_M * (1.0 - _E2) / (w * np.sqrt(w)), WGS84_A_M / np.sqrt(w)


def wgs84_local_factor(m_m, n_m, course_deg):
    """:func:`sphere_to_wgs84` from the radii of curvature: (scale [-], ellipsoid's course [deg, [0, 360)]).

    ``m_m, n_m`` are :func:`wgs84_radii_m` at the piece's latitude [m], ``course_deg`` the piece's
    course on the sphere [deg true].  The one implementation of the local factor (formula and
    accuracy in :func:`sphere_to_wgs84`), on floats or float arrays with numpy's ufuncs only:
    :mod:`optroute.search.edge_geometry` compiles this very function for its kernels.
    """
    a = np.radians(course_deg)
    north, east = m_m * np.cos(a), n_m * np.sin(a)
    course = np.mod(np.degrees(np.arctan2(east, north)), 360.0)
    course = course - 360.0 * (course >= 360.0)  # np.mod of a tiny negative angle rounds to 360 (as units.wrap_360)
    return np.hypot(north, east) / EARTH_RADIUS_M, course


def sphere_to_wgs84(lat_deg: ArrayLike, course_deg: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Local conversion of a short piece from the R₁ sphere to WGS84 (same latitudes and longitudes).

    A piece of length ds on the sphere sailed at course α there (north component R dφ = ds cos α,
    east component R cos φ dλ = ds sin α) has on the ellipsoid the components M dφ and N cos φ dλ,
    M = a(1 − e²)/(1 − e² sin² φ)^{3/2} and N = a/(1 − e² sin² φ)^{1/2} the principal radii of
    curvature (Torge & Müller, *Geodesy*, 4th ed., §4.1).  Hence the length factor
    √(M² cos² α + N² sin² α)/R₁ and the course atan2(N sin α, M cos α).  For a piece of length L
    the error is second order in L/R₁: below 1e-6 relative in length and 0.01° in course for
    L ≤ 60 nm (checked against Karney's geodesics in the tests).  Between pieces the factor lies in
    [:data:`SPHERE_TO_WGS84_MIN`, :data:`SPHERE_TO_WGS84_MAX`]; the course correction is at most
    0.193° (where N/M is largest, at the equator, near α = 45°).

    Parameters
    ----------
    lat_deg : array_like
        Geodetic latitude of the piece (its midpoint) [deg].
    course_deg : array_like
        Course of the piece on the sphere [deg true, to].

    Returns
    -------
    scale : ndarray
        Ellipsoidal length / spherical length [-].
    course_deg : ndarray
        Course of the piece on the ellipsoid [deg true, to], in [0, 360).
    """
    m, n = wgs84_radii_m(np.asarray(lat_deg, dtype=float))
    scale, course = wgs84_local_factor(m, n, np.asarray(course_deg, dtype=float))
    return np.asarray(scale, dtype=float), np.asarray(course, dtype=float)


def sphere_distance_nm(
    lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike
) -> np.ndarray:
    """Great-circle distance (haversine) on the R₁ sphere [nm].

    For closed-form spherical formulas only (it is within −0.56 %/+0.45 % of :func:`distance_nm`,
    see the module docstring); a voyage's distances are :func:`distance_nm`.
    """
    p1, l1 = _latlon(lat1_deg, lon1_deg)
    p2, l2 = _latlon(lat2_deg, lon2_deg)
    h = np.sin((p2 - p1) / 2) ** 2 + np.cos(p1) * np.cos(p2) * np.sin((l2 - l1) / 2) ** 2
    return 2.0 * EARTH_RADIUS_NM * np.arcsin(np.sqrt(np.clip(h, 0.0, 1.0)))


def sphere_initial_course_deg(
    lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike
) -> np.ndarray:
    """Initial great-circle course on the sphere [deg true, to] (within 0.2° of :func:`initial_course_deg`)."""
    p1, l1 = _latlon(lat1_deg, lon1_deg)
    p2, l2 = _latlon(lat2_deg, lon2_deg)
    dl = l2 - l1
    y = np.sin(dl) * np.cos(p2)
    x = np.cos(p1) * np.sin(p2) - np.sin(p1) * np.cos(p2) * np.cos(dl)
    return units.wrap_360(np.degrees(np.arctan2(y, x)))


def sphere_destination(
    lat_deg: ArrayLike, lon_deg: ArrayLike, course_deg: ArrayLike, distance_nm_: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Point reached along a great circle of the R₁ sphere [deg] (closed form; a voyage uses :func:`destination`)."""
    p1, l1 = _latlon(lat_deg, lon_deg)
    c = np.radians(np.asarray(course_deg, dtype=float))
    d = np.asarray(distance_nm_, dtype=float) / EARTH_RADIUS_NM
    p2 = np.arcsin(np.clip(np.sin(p1) * np.cos(d) + np.cos(p1) * np.sin(d) * np.cos(c), -1, 1))
    l2 = l1 + np.arctan2(np.sin(c) * np.sin(d) * np.cos(p1), np.cos(d) - np.sin(p1) * np.sin(p2))
    return np.degrees(p2), units.wrap_180(np.degrees(l2))


def gnomonic_forward(
    lat_deg: ArrayLike, lon_deg: ArrayLike, lat0_deg: float, lon0_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """Gnomonic projection of the R₁ sphere centred at (lat0, lon0): great circles map to straight lines.

    Snyder (1987) eqs. 22-3 to 22-5, scaled by the Earth radius.  The routing grid is laid out
    on this plane; true lengths are measured on WGS84 (:func:`distance_nm`).

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
    """Inverse gnomonic projection of the R₁ sphere (Snyder 1987 eqs. 22-14, 22-15) [nm] → (lat, lon) [deg]."""
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


def unwrap_lon_deg(lon_deg: ArrayLike) -> np.ndarray:
    """Unwrap a sequence of longitudes [deg] so consecutive values never jump by more than 180°."""
    return np.degrees(np.unwrap(np.radians(np.asarray(lon_deg, dtype=float))))
