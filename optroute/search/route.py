"""Route and corridor: what the discrete search returns and the optimiser works in.

A :class:`Route` is the search's answer: waypoints, the time the ship passes
each, and per leg the speed, power, fuel and which side of each danger band
it keeps.  A :class:`Corridor` is a centreline with a half-width on each
side; the continuous optimiser moves waypoints across it.

Positions are (lat, lon) [deg], lon in [-180, 180); times are timezone-naive
UTC ``numpy.datetime64[ns]``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError


def _waypoints(waypoints: ArrayLike, what: str) -> np.ndarray:
    try:
        wp = np.asarray(waypoints, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{what}: waypoints must be an (n, 2) array of (lat, lon) in degrees") from None
    if wp.ndim != 2 or wp.shape[1] != 2 or wp.shape[0] < 2:
        raise ConfigError(f"{what}: waypoints have shape {wp.shape}; give at least two (lat, lon) pairs, shape (n, 2)")
    finite(f"{what} waypoint", wp, error=ConfigError)
    if np.any(np.abs(wp[:, 0]) > 90.0):
        k = int(np.argmax(np.abs(wp[:, 0]) > 90.0))
        raise ConfigError(
            f"{what}: waypoint {k} has latitude {wp[k, 0]} outside [-90, 90]; pass (lat, lon), not (lon, lat)"
        )
    wp = wp.copy()
    wp[:, 1] = units.wrap_180(wp[:, 1])
    d = geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
    if np.any(d < 1e-6):
        k = int(np.argmax(d < 1e-6))
        raise ConfigError(f"{what}: waypoints {k} and {k + 1} coincide at {tuple(wp[k])}; remove the duplicate")
    wp.setflags(write=False)
    return wp


@dataclass(frozen=True)
class Corridor:
    """A centreline with a lateral half-width, within which waypoints may move.

    Parameters
    ----------
    waypoints : array_like, shape (n, 2)
        Centreline (lat, lon) [deg], n >= 2, consecutive points distinct.
    half_width_nm : float or array_like, shape (n,)
        Half-width to each side of the centreline at each waypoint [nm], >= 0
        (0 fixes the path).
    """

    waypoints: np.ndarray
    half_width_nm: np.ndarray

    def __init__(self, waypoints: ArrayLike, half_width_nm: ArrayLike = 0.0) -> None:
        wp = _waypoints(waypoints, "Corridor")
        hw = finite("half_width_nm", half_width_nm, minimum=0.0, error=ConfigError)
        try:
            hw = np.broadcast_to(hw, (wp.shape[0],)).copy()
        except ValueError:
            raise ConfigError(
                f"Corridor: half_width_nm has shape {hw.shape}; give a scalar or one value per waypoint ({wp.shape[0]})"
            ) from None
        hw.setflags(write=False)
        object.__setattr__(self, "waypoints", wp)
        object.__setattr__(self, "half_width_nm", hw)

    @classmethod
    def from_waypoints(cls, waypoints: ArrayLike, *, width_nm: float = 0.0) -> Corridor:
        """A corridor of total width ``width_nm`` [nm] (half to each side) about the waypoints."""
        return cls(waypoints, 0.5 * float(finite("width_nm", width_nm, minimum=0.0, error=ConfigError)))

    @property
    def n_legs(self) -> int:
        """Number of legs of the centreline."""
        return self.waypoints.shape[0] - 1

    @property
    def leg_distance_nm(self) -> np.ndarray:
        """Great-circle length of each centreline leg [nm]."""
        wp = self.waypoints
        return geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])

    @property
    def along_track_nm(self) -> np.ndarray:
        """Distance along the centreline at each waypoint [nm], starting at 0."""
        return np.concatenate([[0.0], np.cumsum(self.leg_distance_nm)])

    @property
    def length_nm(self) -> float:
        """Total centreline length [nm]."""
        return float(self.leg_distance_nm.sum())

    def normal_course_deg(self) -> np.ndarray:
        """Course pointing to starboard of the centreline at each waypoint [deg true].

        At interior waypoints it bisects the normals of the legs in and out.
        """
        wp = self.waypoints
        c_out = geo.initial_course_deg(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
        c_in = units.wrap_360(geo.initial_course_deg(wp[1:, 0], wp[1:, 1], wp[:-1, 0], wp[:-1, 1]) + 180.0)
        first, last = c_out[:1], c_in[-1:]
        mid_vec = np.exp(1j * np.radians(c_in[:-1])) + np.exp(1j * np.radians(c_out[1:]))
        mid = np.degrees(np.angle(mid_vec))
        along = np.concatenate([first, mid, last])
        return units.wrap_360(along + 90.0)

    def offset_points(self, offset_nm: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Positions displaced across the centreline.

        Parameters
        ----------
        offset_nm : array_like, shape (n,)
            Lateral offset at each waypoint [nm], positive to starboard of
            the direction of travel.

        Returns
        -------
        lat, lon : ndarray
            Displaced waypoints [deg].
        """
        off = np.broadcast_to(finite("offset_nm", offset_nm, error=ConfigError), (self.waypoints.shape[0],))
        beyond = np.abs(off) > self.half_width_nm + 1e-9
        if beyond.any():
            k = int(np.argmax(beyond))
            raise ConfigError(
                f"offset_nm[{k}]={off[k]} lies outside the corridor's half-width {self.half_width_nm[k]} nm"
            )
        return geo.destination(self.waypoints[:, 0], self.waypoints[:, 1], self.normal_course_deg(), off)

    def resample(self, max_leg_nm: ArrayLike) -> Corridor:
        """The same corridor with legs no longer than ``max_leg_nm`` [nm], on the great circles.

        ``max_leg_nm`` is one length for every leg or one per leg (shape (n − 1,)): each leg is cut into the
        fewest equal pieces no longer than its own. The original waypoints are kept; half-widths are
        interpolated along track.
        """
        n_legs = self.waypoints.shape[0] - 1
        given = finite("max_leg_nm", max_leg_nm, minimum=0.0, strict=True, error=ConfigError)
        if given.ndim > 1 or given.size not in (1, n_legs):
            raise ConfigError(f"max_leg_nm has shape {given.shape}; give one length [nm] or one per leg ({n_legs},)")
        steps = np.broadcast_to(given.ravel(), (n_legs,))
        lats, lons, s_new = [self.waypoints[:1, 0]], [self.waypoints[:1, 1]], [np.zeros(1)]
        s = self.along_track_nm
        for k, d in enumerate(self.leg_distance_nm):
            m = max(1, int(np.ceil(d / steps[k] - 1e-9)))
            f = np.arange(1, m + 1) / m
            la, lo = geo.intermediate_points(*self.waypoints[k], *self.waypoints[k + 1], f)
            lats.append(np.atleast_1d(la))
            lons.append(np.atleast_1d(lo))
            s_new.append(s[k] + f * d)
        s_all = np.concatenate(s_new)
        hw = np.interp(s_all, s, self.half_width_nm)
        return Corridor(np.column_stack([np.concatenate(lats), np.concatenate(lons)]), hw)

    def cut_at(self, s_nm: ArrayLike, min_piece_nm: float = 0.05) -> Corridor:
        """The same corridor with its legs also cut at the along-track positions ``s_nm`` [nm], on the great circles.

        The original waypoints are kept; a cut within ``min_piece_nm`` [nm] of a waypoint or of an earlier cut, or
        outside the corridor, is left out. Half-widths are interpolated along track.
        """
        s = self.along_track_nm
        cuts = np.sort(finite("s_nm", s_nm, error=ConfigError).ravel())
        kept: list[float] = []
        for x in cuts:
            if min_piece_nm < x < s[-1] - min_piece_nm and np.min(np.abs(s - x)) > min_piece_nm:
                if not kept or x - kept[-1] > min_piece_nm:
                    kept.append(float(x))
        if not kept:
            return self
        at = np.asarray(kept)
        k = np.clip(np.searchsorted(s, at, side="right") - 1, 0, self.n_legs - 1)
        lat, lon = np.empty(at.size), np.empty(at.size)
        for leg in np.unique(k):
            sel = k == leg
            f = (at[sel] - s[leg]) / (s[leg + 1] - s[leg])
            la, lo = geo.intermediate_points(*self.waypoints[leg], *self.waypoints[leg + 1], f)
            lat[sel], lon[sel] = la, lo
        s_all = np.concatenate([s, at])
        order = np.argsort(s_all, kind="stable")
        points = np.vstack([self.waypoints, np.column_stack([lat, lon])])[order]
        return Corridor(points, np.interp(s_all[order], s, self.half_width_nm))


@dataclass(frozen=True)
class Route:
    """The discrete search's result.

    Attributes
    ----------
    waypoints : ndarray, shape (n, 2)
        (lat, lon) [deg] of the grid nodes passed, start to end.
    times : ndarray of datetime64[ns], shape (n,)
        When the ship passes each waypoint [UTC].
    sog_kn, stw_kn, power_kw, fuel_t, duration_h, distance_nm : ndarray, shape (n - 1,)
        Per leg: mean speed over ground [kn], distance-weighted speed through
        water [kn], time-weighted mean brake power [kW], fuel [t], duration
        [h], great-circle length [nm].
    cost : float
        The search objective's value (hours for ``"time"``, tonnes for
        ``"fuel"``, tonnes + λ·hours for ``"cost"``).
    objective, method : str
        What was minimised and how.
    band_side : mapping of str to ndarray of int8, shape (n - 1,)
        For each danger band, the side kept on each leg: −1 below the band's
        speeds, +1 above, 0 where it does not apply (see
        :func:`optroute.physics.safety.band_margins`).
    stats : mapping
        Search statistics (nodes expanded, edges evaluated, run time [s], λ).
    """

    waypoints: np.ndarray
    times: np.ndarray
    sog_kn: np.ndarray
    stw_kn: np.ndarray
    power_kw: np.ndarray
    fuel_t: np.ndarray
    duration_h: np.ndarray
    distance_nm: np.ndarray
    cost: float
    objective: str
    method: str
    band_side: Mapping[str, np.ndarray] = field(default_factory=dict)
    stats: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        wp = _waypoints(self.waypoints, "Route")
        object.__setattr__(self, "waypoints", wp)
        n = wp.shape[0]
        times = np.asarray(self.times, dtype="datetime64[ns]")
        if times.shape != (n,) or np.any(np.diff(times) <= np.timedelta64(0, "ns")):
            raise ConfigError(f"Route: times must be {n} strictly increasing datetimes, got shape {times.shape}")
        object.__setattr__(self, "times", times)
        for name in ("sog_kn", "stw_kn", "power_kw", "fuel_t", "duration_h", "distance_nm"):
            arr = np.asarray(getattr(self, name), dtype=float)
            if arr.shape != (n - 1,):
                raise ConfigError(f"Route: {name} has shape {arr.shape}; expected one value per leg ({n - 1})")
            object.__setattr__(self, name, arr)

    @property
    def departure(self) -> np.datetime64:
        """Departure time [UTC]."""
        return self.times[0]

    @property
    def arrival(self) -> np.datetime64:
        """Arrival time [UTC]."""
        return self.times[-1]

    @property
    def total_duration_h(self) -> float:
        """Passage time [h]."""
        return float(self.duration_h.sum())

    @property
    def total_fuel_t(self) -> float:
        """Fuel for the passage [t]."""
        return float(self.fuel_t.sum())

    @property
    def total_distance_nm(self) -> float:
        """Distance sailed [nm]."""
        return float(self.distance_nm.sum())

    def corridor(self, width_nm: float = 60.0) -> Corridor:
        """The corridor of total width ``width_nm`` [nm] (half to each side) about this route."""
        return Corridor.from_waypoints(self.waypoints, width_nm=width_nm)
