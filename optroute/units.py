"""Unit and angle conversions: the only place in optroute that holds them.

Conventions (see ``shared/design.md``):

* speeds in knots at the public surface (``_kn``), m/s inside physics (``_ms``);
* distances in nautical miles (``_nm``) or metres (``_m``);
* headings and courses in degrees true, the direction the ship goes **to**;
* wave and wind directions in degrees true, the direction they come **from**;
* wind and current vectors as (u, v) = (east, north) components of the
  direction they go **to**.

Sources: 1 international nautical mile = 1852 m exactly (BIPM SI Brochure,
Table 8); 1 knot = 1 nm/h.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

M_PER_NM = 1852.0
S_PER_H = 3600.0
MS_PER_KN = M_PER_NM / S_PER_H  # 0.514444... m/s per knot


def kn_to_ms(speed_kn: ArrayLike) -> np.ndarray:
    """Knots [kn] to metres per second [m/s]."""
    return np.asarray(speed_kn, dtype=float) * MS_PER_KN


def ms_to_kn(speed_ms: ArrayLike) -> np.ndarray:
    """Metres per second [m/s] to knots [kn]."""
    return np.asarray(speed_ms, dtype=float) / MS_PER_KN


def nm_to_m(distance_nm: ArrayLike) -> np.ndarray:
    """Nautical miles [nm] to metres [m]."""
    return np.asarray(distance_nm, dtype=float) * M_PER_NM


def m_to_nm(distance_m: ArrayLike) -> np.ndarray:
    """Metres [m] to nautical miles [nm]."""
    return np.asarray(distance_m, dtype=float) / M_PER_NM


def h_to_s(duration_h: ArrayLike) -> np.ndarray:
    """Hours [h] to seconds [s]."""
    return np.asarray(duration_h, dtype=float) * S_PER_H


def s_to_h(duration_s: ArrayLike) -> np.ndarray:
    """Seconds [s] to hours [h]."""
    return np.asarray(duration_s, dtype=float) / S_PER_H


def wrap_360(angle_deg: ArrayLike) -> np.ndarray:
    """Wrap an angle [deg] into [0, 360).

    ``np.mod`` of a tiny negative angle rounds to 360.0 itself; that case is
    folded back to 0 so the half-open interval really holds.
    """
    r = np.mod(np.asarray(angle_deg, dtype=float), 360.0)
    return np.where(r >= 360.0, 0.0, r)


def wrap_180(angle_deg: ArrayLike) -> np.ndarray:
    """Wrap an angle or a longitude [deg] into [-180, 180)."""
    return wrap_360(np.asarray(angle_deg, dtype=float) + 180.0) - 180.0


def from_to_flip_deg(direction_deg: ArrayLike) -> np.ndarray:
    """Turn a 'coming from' direction into a 'going to' one, or back [deg, true]."""
    return wrap_360(np.asarray(direction_deg, dtype=float) + 180.0)


def uv_to_speed_to_deg(u: ArrayLike, v: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Vector (u east, v north) to its magnitude and the direction it goes **to**.

    Parameters
    ----------
    u, v : array_like
        East and north components [any speed unit].

    Returns
    -------
    speed : ndarray
        Magnitude [same unit as u, v].
    to_deg : ndarray
        Direction the vector points to [deg true, 0 = north, clockwise], in [0, 360).
    """
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    return np.hypot(u, v), wrap_360(np.degrees(np.arctan2(u, v)))


def speed_to_deg_to_uv(speed: ArrayLike, to_deg: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Magnitude and 'going to' direction [deg true] to (u east, v north)."""
    speed = np.asarray(speed, dtype=float)
    rad = np.radians(np.asarray(to_deg, dtype=float))
    return speed * np.sin(rad), speed * np.cos(rad)


def wind_uv_to_speed_from_deg(u_ms: ArrayLike, v_ms: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Wind (u, v) [m/s], the vector it blows to, to speed [m/s] and 'from' direction [deg true]."""
    speed, to_deg = uv_to_speed_to_deg(u_ms, v_ms)
    return speed, from_to_flip_deg(to_deg)


NS_PER_H = 3.6e12
"""Nanoseconds per hour: times are ``datetime64[ns]``, durations hours."""


def h_to_timedelta(duration_h: ArrayLike) -> np.ndarray | np.timedelta64:
    """Hours [h] to ``timedelta64[ns]``, rounded to the nanosecond (a scalar for scalar input)."""
    return np.round(np.asarray(duration_h, dtype=float) * NS_PER_H).astype("timedelta64[ns]")[()]


def timedelta_to_h(duration: ArrayLike) -> np.ndarray | np.float64:
    """``timedelta64`` to hours [h] (a scalar for scalar input)."""
    return (np.asarray(duration, dtype="timedelta64[ns]").astype(np.int64) / NS_PER_H)[()]


def as_utc_time(t: object, what: str) -> np.datetime64:
    """A time as timezone-naive UTC ``datetime64[ns]``; ``what`` names it in the error.

    Raises
    ------
    ConfigError
        ``t`` is not a time or is NaT.
    """
    from optroute.errors import ConfigError

    try:
        out = np.datetime64(t, "ns")
    except (TypeError, ValueError):
        raise ConfigError(f"{what}={t!r} is not a time; pass a numpy.datetime64 or an ISO string (UTC)") from None
    if np.isnat(out):
        raise ConfigError(f"{what} is NaT; pass a UTC time")
    return out


def format_utc(t: object) -> str:
    """A time as ISO 8601 UTC to the second, e.g. ``2024-01-18T09:14:00Z``: the one format optroute prints.

    Parameters
    ----------
    t : numpy.datetime64, datetime or str
        A time, timezone-naive UTC (optroute's convention), of any precision.

    Returns
    -------
    str
        ``YYYY-MM-DDTHH:MM:SSZ``, rounded to the nearest second (half a second rounds up);
        ``"NaT"`` for a missing time.
    """
    ns = np.datetime64(t, "ns")
    if np.isnat(ns):
        return "NaT"
    # datetime64 casts floor to the coarser unit, so adding half a second first rounds to the nearest
    return f"{(ns + np.timedelta64(500, 'ms')).astype('datetime64[s]')}Z"
