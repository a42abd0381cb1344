"""The optimiser's result: a :class:`Plan`, and its independent verification.

A :class:`Plan` is a voyage fixed down to the leg: waypoints, the time the
ship passes each, and per leg a constant speed through the water.  Whatever
produced it (the corridor NLP of :func:`optroute.optimise_corridor`, the
search, a user's own schedule through :meth:`Plan.from_schedule`), the leg
quantities in :attr:`Plan.legs` are computed here from the *true* ship
model (:class:`~optroute.performance.PerformanceModel`, not the NLP's fitted
power model) on a dense resampling of every leg, and :meth:`Plan.verify`
re-checks every constraint on such a resampling with code that shares
nothing with the NLP:

* each leg is a great circle between its waypoints, cut into pieces of at
  most ``step_nm``; the ship is at a piece at the time the plan's schedule
  puts it there (the leg's duration shared out in proportion to the piece
  times at the planned speed);
* the sea state there comes from :class:`~optroute.weather.WeatherSampler`;
  the heading is crabbed against the current
  (:func:`optroute.speed_loss.heading_for_course`), the brake power is the
  true model's (:func:`optroute.passage.evaluate_speeds`);
* checked: minimum load ≤ power ≤ MCR, no danger band
  (:func:`optroute.safety.is_speed_forbidden`, closed bands), navigable
  water (land mask, NaN weather, weather coverage), the course can be held
  against the current, within the corridor, the exclusion circle, the
  schedule is sailable at the planned speeds, and the ETA.

Conventions: positions (lat, lon) [deg], lon in [-180, 180); times
timezone-naive UTC ``datetime64[ns]``; headings and courses degrees true, the
direction the ship goes **to**; wave and wind directions where they come
**from**; IMO angle of encounter α, 0 = head sea (MSC.1/Circ.1228).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from numpy.typing import ArrayLike

from optroute import geo, land, seaway, units
from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.passage import SeaState, evaluate_speeds
from optroute.performance import PerformanceModel, default_model
from optroute.route import Corridor
from optroute.safety import BANDS, BandRules, band_margins, is_speed_forbidden
from optroute.ship import Ship
from optroute.weather.sample import WeatherSampler

__all__ = ["LEG_COLUMNS", "Exclusion", "Plan", "PlanContext", "Violation"]

#: Columns of :attr:`Plan.legs`, in order (followed by ``margin_<band>`` for every band of
#: :data:`optroute.safety.BANDS`).
LEG_COLUMNS: tuple[str, ...] = (
    "lat",
    "lon",
    "time",
    "heading_deg",
    "sog_kn",
    "stw_kn",
    "distance_nm",
    "duration_h",
    "power_kw",
    "fuel_t",
    "hs_m",
    "period_s",
    "wave_from_deg",
    "encounter_period_s",
)

_SEA_VARS = ("hs_m", "tp_s", "tm_s", "wave_from_deg", "wind_u_ms", "wind_v_ms", "current_u_ms", "current_v_ms")
_NS_PER_H = 3.6e12


def _h_to_td(h: ArrayLike) -> np.ndarray:
    return np.round(np.asarray(h, dtype=float) * _NS_PER_H).astype("timedelta64[ns]")


def _td_to_h(td: ArrayLike) -> np.ndarray:
    return np.asarray(td, dtype="timedelta64[ns]").astype(np.int64) / _NS_PER_H


def _as_time(t: Any, what: str) -> np.datetime64:
    try:
        out = np.datetime64(t, "ns")
    except (TypeError, ValueError):
        raise ConfigError(f"{what}={t!r} is not a time; pass a numpy.datetime64 or an ISO string (UTC)") from None
    if np.isnat(out):
        raise ConfigError(f"{what} is NaT; pass a UTC time")
    return out


def _as_sampler(weather: xr.Dataset | WeatherSampler) -> tuple[WeatherSampler, xr.Dataset | None]:
    if isinstance(weather, WeatherSampler):
        return weather, None
    if isinstance(weather, xr.Dataset):
        return WeatherSampler(weather), weather
    raise ConfigError(f"weather must be a canonical xarray.Dataset or a WeatherSampler, got {type(weather).__name__}")


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
    lat0, lon0, lat1, lon1, f = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (lat0, lon0, lat1, lon1, fraction)))
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
        """Seed 004's avoidance circle (radius of Beaufort-7 winds + ``margin_km``) along a cyclone track.

        Parameters
        ----------
        source : xarray.Dataset or str
            A :func:`optroute.scenarios.tropical_cyclone` dataset or its ``attrs["cyclone"]``.
        margin_km : float
            Safety margin added to the force-7 radius [km] (seed 004 settles on 30 km).
        """
        from optroute.weather.cyclone import cyclone_track

        tr = cyclone_track(source)
        margin = float(finite("margin_km", margin_km, minimum=0.0, error=ConfigError))
        radius_nm = (tr["r7_km"] + margin) * 1000.0 / units.M_PER_NM
        return cls(tr["time"], tr["lat"], tr["lon"], radius_nm)

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


# --------------------------------------------------------------------------- violations and context


@dataclass(frozen=True)
class Violation:
    """One broken constraint found by :meth:`Plan.verify` (the worst point of its kind on its leg).

    Attributes
    ----------
    kind : str
        ``"power_above_mcr"``, ``"power_below_min"``, ``"band:<name>"`` (a danger band of
        :data:`optroute.safety.BANDS`), ``"land"``, ``"no_passage"`` (NaN weather: land, ice, a
        no-go area), ``"weather_coverage"``, ``"course"`` (the current does not let the ship hold
        the course at the planned speed), ``"corridor"``, ``"exclusion"``, ``"schedule"`` (the
        planned times cannot be sailed at the planned speeds), ``"eta"``.
    leg : int
        Leg index (0-based).
    position : (float, float)
        (lat, lon) [deg] of the worst point.
    time : numpy.datetime64
        When the ship is there [UTC].
    value, limit : float
        The offending value and its limit, in the unit of the kind: power [kW]; band ratio [-];
        distance outside the corridor or inside the exclusion [nm] against the allowed [nm];
        hours [h] for ``"eta"`` (arrival − ETA) and ``"schedule"`` (time error).
    """

    kind: str
    leg: int
    position: tuple[float, float]
    time: np.datetime64
    value: float
    limit: float

    def __str__(self) -> str:
        lat, lon = self.position
        return (
            f"{self.kind} on leg {self.leg} at ({lat:.4f}, {lon:.4f}) {str(self.time)[:19]}: "
            f"{self.value:.6g} against the limit {self.limit:.6g}"
        )


@dataclass(frozen=True)
class PlanContext:
    """What :meth:`Plan.verify` checks a plan against: ship, models, rules, weather and requirements.

    Attributes
    ----------
    ship : Ship
    model : PerformanceModel
        The true performance model (power and fuel).
    rules : BandRules
        Danger-band rules.
    sampler : WeatherSampler
        The weather.
    dataset : xarray.Dataset or None
        The canonical dataset behind the sampler, when known (its ``attrs["geography"]`` decides
        whether the land mask applies by default).
    corridor : Corridor or None
        The corridor the plan must stay within (None: no corridor constraint).
    eta : numpy.datetime64 or None
        Required arrival [UTC].
    eta_mode : {"le", "eq"}
        Arrive no later than, or at, the ETA.
    exclusion : Exclusion or None
        A moving circle to stay out of.
    use_land_mask : bool or None
        Apply the real coastline (None: unless the weather declares synthetic geography).
    """

    ship: Ship
    model: PerformanceModel
    rules: BandRules
    sampler: WeatherSampler
    dataset: xr.Dataset | None = None
    corridor: Corridor | None = None
    eta: np.datetime64 | None = None
    eta_mode: str = "le"
    exclusion: Exclusion | None = None
    use_land_mask: bool | None = None

    def __post_init__(self) -> None:
        if self.eta_mode not in ("le", "eq"):
            raise ConfigError(f"eta_mode={self.eta_mode!r} is not known; use 'le' (arrive by) or 'eq' (arrive at)")
        if self.eta is not None:
            object.__setattr__(self, "eta", _as_time(self.eta, "eta"))

    @property
    def land_mask_applies(self) -> bool:
        """Whether the real coastline is checked."""
        if self.use_land_mask is not None:
            return bool(self.use_land_mask)
        return not (self.dataset is not None and self.dataset.attrs.get("geography") == land.SYNTHETIC_GEOGRAPHY)


# --------------------------------------------------------------------------- dense evaluation


@dataclass(frozen=True)
class _Dense:
    """Points along every leg: the piece midpoints (weight = piece length) and the leg ends (weight 0)."""

    leg: np.ndarray
    frac: np.ndarray
    length_nm: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    course: np.ndarray
    time_h: np.ndarray
    sea: SeaState
    covered: np.ndarray
    heading: np.ndarray
    sog: np.ndarray
    power: np.ndarray
    fuel_tph: np.ndarray
    dt_h: np.ndarray
    leg_duration_h: np.ndarray
    stw: np.ndarray


def _dense_points(waypoints: np.ndarray, step_nm: float) -> tuple[np.ndarray, ...]:
    d = geo.distance_nm(waypoints[:-1, 0], waypoints[:-1, 1], waypoints[1:, 0], waypoints[1:, 1])
    legs, fracs, lens = [], [], []
    for k, dk in enumerate(d):
        m = max(1, int(math.ceil(dk / step_nm - 1e-9)))
        f = np.concatenate([[0.0], (np.arange(m) + 0.5) / m, [1.0]])
        legs.append(np.full(f.size, k))
        fracs.append(f)
        lens.append(np.concatenate([[0.0], np.full(m, dk / m), [0.0]]))
    leg = np.concatenate(legs)
    frac = np.concatenate(fracs)
    lat, lon, course = gc_points(waypoints[leg, 0], waypoints[leg, 1], waypoints[leg + 1, 0], waypoints[leg + 1, 1], frac)
    return leg, frac, np.concatenate(lens), lat, lon, course, d


def _sea(sampler: WeatherSampler, when: np.ndarray, lat: np.ndarray, lon: np.ndarray) -> tuple[SeaState, np.ndarray]:
    names = [v for v in _SEA_VARS if v in sampler.variables]
    inside = sampler.covers(when, lat, lon)
    out = {v: np.full(lat.shape, np.nan) for v in names}
    if inside.any():
        got = sampler.sample(when[inside], lat[inside], lon[inside], variables=names)
        for v in names:
            out[v][inside] = got[v]
    return SeaState.from_sample(out), inside


def _evaluate(
    ctx: PlanContext,
    waypoints: np.ndarray,
    stw_kn: np.ndarray,
    departure: np.datetime64,
    times_h: np.ndarray | None,
    step_nm: float,
    iterations: int = 3,
) -> _Dense:
    """Sea, heading, SOG, power and fuel at dense points at the times the ship is there.

    ``times_h`` (waypoint times [h since departure]) fixes the schedule: inside each leg the
    duration is shared in proportion to the piece times at the planned speed. Without it the
    schedule is integrated from the piece times themselves (``Σ piece / SOG``). The piece times
    depend on the current at the time the ship is there, so the two are iterated to a fixed point.
    """
    leg, frac, length, lat, lon, course, d = _dense_points(waypoints, step_nm)
    stw = stw_kn[leg]
    n = d.size
    dt = length / stw  # first guess: no current
    for it in range(max(1, iterations)):
        dur_int = np.bincount(leg, weights=dt, minlength=n)
        sched = np.concatenate([[0.0], np.cumsum(dur_int)]) if times_h is None else times_h
        scale = np.diff(sched) / np.where(dur_int > 0, dur_int, 1.0)
        # elapsed time inside the leg up to each point (midpoints: half their own piece)
        before = np.cumsum(dt) - dt - np.concatenate([[0.0], np.cumsum(dur_int)])[leg]
        elapsed = np.where(frac >= 1.0, dur_int[leg], before + 0.5 * dt)
        elapsed = np.where(frac <= 0.0, 0.0, elapsed)
        t_h = sched[leg] + elapsed * scale[leg]
        when = departure + _h_to_td(t_h)
        sea, covered = _sea(ctx.sampler, when, lat, lon)
        heading, sog, power, fuel, _ = evaluate_speeds(ctx.ship, ctx.model, ctx.rules, course, sea, stw)
        usable = np.isfinite(sog) & (sog > 0)
        new_dt = np.where(length > 0, length / np.where(usable, sog, stw), 0.0)
        converged = np.allclose(new_dt, dt, rtol=1e-12, atol=1e-12)
        dt = new_dt
        if converged or it == max(1, iterations) - 1:
            break
    return _Dense(leg, frac, length, lat, lon, course, t_h, sea, covered, heading, sog, power, fuel,
                  dt, np.bincount(leg, weights=dt, minlength=n), stw)


def _circular_mean_deg(angle_deg: np.ndarray, weights: np.ndarray, leg: np.ndarray, n: int) -> np.ndarray:
    r = np.radians(angle_deg)
    s = np.bincount(leg, weights=weights * np.sin(r), minlength=n)
    c = np.bincount(leg, weights=weights * np.cos(r), minlength=n)
    return units.wrap_360(np.degrees(np.arctan2(s, c)))


def _legs_table(ctx: PlanContext, waypoints: np.ndarray, times: np.ndarray, ev: _Dense, d: np.ndarray) -> pd.DataFrame:
    n = d.size
    w = ev.dt_h  # time weights (leg ends carry 0)
    wsum = np.bincount(ev.leg, weights=w, minlength=n)

    def wmean(x: np.ndarray) -> np.ndarray:
        x = np.where(np.isfinite(x), x, 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.bincount(ev.leg, weights=w * x, minlength=n) / wsum

    sea = ev.sea
    nav = sea.navigable
    hs = np.where(nav, sea.hs_m, np.nan)
    period = np.where(nav, sea.period_s, np.nan)
    heading = np.where(np.isfinite(ev.heading), ev.heading, ev.course)
    fuel = np.bincount(ev.leg, weights=w * np.where(np.isfinite(ev.fuel_tph), ev.fuel_tph, np.inf), minlength=n)
    power = wmean(ev.power)
    heading_leg = _circular_mean_deg(heading, w, ev.leg, n)
    wave_from = _circular_mean_deg(np.where(nav, sea.wave_from_deg, 0.0), w, ev.leg, n)
    hs_leg, per_leg = wmean(hs), wmean(period)
    stw = np.asarray(ev.stw[np.searchsorted(ev.leg, np.arange(n))], dtype=float)
    duration = np.diff(_td_to_h(times - times[0]))
    alpha = seaway.relative_wave_angle_deg(heading_leg, wave_from)
    te = seaway.encounter_period_s(np.where(per_leg > 0, per_leg, 1.0), stw, alpha, form=ctx.rules.period_form)
    cols: dict[str, Any] = {
        "lat": waypoints[:-1, 0],
        "lon": waypoints[:-1, 1],
        "time": times[:-1],
        "heading_deg": heading_leg,
        "sog_kn": d / duration,
        "stw_kn": stw,
        "distance_nm": d,
        "duration_h": duration,
        "power_kw": power,
        "fuel_t": fuel,
        "hs_m": hs_leg,
        "period_s": per_leg,
        "wave_from_deg": wave_from,
        "encounter_period_s": np.where(per_leg > 0, te, np.nan),
    }
    margins = band_margins(
        ctx.ship,
        speed_kn=ev.stw,
        hs_m=np.where(nav, sea.hs_m, 0.0),
        period_s=np.where(nav, sea.period_s, 1.0),
        wave_from_deg=np.where(nav, sea.wave_from_deg, 0.0),
        heading_deg=heading,
        rules=ctx.rules,
    )
    for band in BANDS:
        m = np.full(n, np.inf)
        np.minimum.at(m, ev.leg, np.asarray(margins[band].margin, dtype=float))
        cols[f"margin_{band}"] = m
    return pd.DataFrame(cols)


# --------------------------------------------------------------------------- the plan


@dataclass(frozen=True, eq=False)
class Plan:
    """A voyage plan: waypoints, schedule and per-leg speeds, with the true model's leg quantities.

    Build one with :func:`optroute.optimise_corridor`, :func:`optroute.plan_voyage` or
    :meth:`Plan.from_schedule`; every plan returned by the optimiser has passed :meth:`verify`.

    Attributes
    ----------
    legs : pandas.DataFrame
        One row per leg, columns :data:`LEG_COLUMNS` then ``margin_<band>`` for every band of
        :data:`optroute.safety.BANDS`: ``lat``, ``lon`` of the leg start [deg]; ``time`` of the
        leg start [UTC]; ``heading_deg`` (time-mean heading crabbed against the current [deg true,
        to]); ``sog_kn`` (distance / duration [kn]); ``stw_kn`` (speed through the water, constant
        on the leg [kn]); ``distance_nm`` (great circle [nm]); ``duration_h`` [h]; ``power_kw``
        (time-mean brake power of the true model [kW]); ``fuel_t`` (fuel of the true model [t]);
        ``hs_m``, ``period_s`` (time-mean sea [m], [s]); ``wave_from_deg`` (circular mean [deg
        true, from]); ``encounter_period_s`` (at those means [s]); ``margin_<band>`` (the smallest
        signed distance to the band along the leg in its ratio units, > 0 safe, ``inf`` where it
        never applies; :func:`optroute.safety.band_margins`).
    waypoints : numpy.ndarray, shape (n, 2)
        (lat, lon) [deg].
    times : numpy.ndarray of datetime64[ns], shape (n,)
        When the ship passes each waypoint [UTC].
    total_fuel_t : float
        Voyage fuel [t] (true model).
    duration_h : float
        Passage time [h].
    departure, arrival : numpy.datetime64
        [UTC].
    status : str
        ``"optimal"`` (Ipopt converged: a local optimum for the band sides chosen, refined by the
        side-flip search), ``"feasible"`` (a verified plan Ipopt only solved to its acceptable
        level) or, for :meth:`from_schedule`, the caller's label.
    solver_stats : mapping
        Ipopt's status verbatim, iterations, times, outer-loop flips, the power-fit error, the
        convex certificate gap... (see :func:`optroute.optimise_corridor`).
    eta_shadow_price_t_per_h : float
        Fuel saved per extra hour of passage [t/h] (the ETA constraint's multiplier); NaN when
        there is no ETA or the objective is time.
    context : PlanContext
        Ship, models, rules, weather and requirements :meth:`verify` checks against.
    """

    legs: pd.DataFrame
    waypoints: np.ndarray
    times: np.ndarray
    total_fuel_t: float
    duration_h: float
    departure: np.datetime64
    arrival: np.datetime64
    status: str
    solver_stats: Mapping[str, Any]
    eta_shadow_price_t_per_h: float
    context: PlanContext = field(repr=False)

    def __post_init__(self) -> None:
        wp = np.asarray(self.waypoints, dtype=float)
        if wp.ndim != 2 or wp.shape[1] != 2 or wp.shape[0] < 2:
            raise ConfigError(f"Plan.waypoints must be an (n, 2) array of (lat, lon) with n >= 2, got {wp.shape}")
        times = np.asarray(self.times, dtype="datetime64[ns]")
        if times.shape != (wp.shape[0],) or np.any(np.diff(times) <= np.timedelta64(0, "ns")):
            raise ConfigError(f"Plan.times must be {wp.shape[0]} strictly increasing UTC times")
        if not isinstance(self.legs, pd.DataFrame) or len(self.legs) != wp.shape[0] - 1:
            raise ConfigError(f"Plan.legs must be a DataFrame with one row per leg ({wp.shape[0] - 1})")
        missing = [c for c in LEG_COLUMNS if c not in self.legs.columns]
        if missing:
            raise ConfigError(f"Plan.legs lacks the columns {missing}")
        if not isinstance(self.context, PlanContext):
            raise ConfigError("Plan.context must be a PlanContext (build plans with Plan.from_schedule)")
        wp = wp.copy()
        wp.setflags(write=False)
        times.setflags(write=False)
        object.__setattr__(self, "waypoints", wp)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "solver_stats", dict(self.solver_stats))

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_schedule(
        cls,
        waypoints: ArrayLike,
        stw_kn: ArrayLike,
        *,
        departure: Any,
        ship: Ship,
        weather: xr.Dataset | WeatherSampler,
        model: PerformanceModel | None = None,
        rules: BandRules | None = None,
        times: ArrayLike | None = None,
        corridor: Corridor | None = None,
        eta: Any = None,
        eta_mode: str = "le",
        exclusion: Exclusion | None = None,
        use_land_mask: bool | None = None,
        status: str = "unverified",
        solver_stats: Mapping[str, Any] | None = None,
        eta_shadow_price_t_per_h: float = float("nan"),
        step_nm: float = 5.0,
    ) -> Plan:
        """A plan from waypoints and leg speeds, its leg quantities computed with the true model.

        Parameters
        ----------
        waypoints : array_like, shape (n, 2)
            (lat, lon) [deg]; the legs are the great circles between them.
        stw_kn : array_like, shape (n - 1,)
            Speed through the water of every leg [kn], > 0.
        departure : datetime64 or str
            [UTC].
        ship, weather, model, rules
            The ship, the weather (canonical dataset or sampler), its performance model (default
            :class:`~optroute.performance.KwonModel`) and danger-band rules (default Boeing).
        times : array_like of datetime64, shape (n,), optional
            The schedule (first = departure). Default: sailed at ``stw_kn`` through the weather
            (``Σ piece / SOG`` on pieces of at most ``step_nm``, the SOG at the time the ship is
            there). A given schedule is kept as is; :meth:`verify` reports it when the speeds
            cannot sail it (``"schedule"``).
        corridor, eta, eta_mode, exclusion, use_land_mask
            What :meth:`verify` checks (see :class:`PlanContext`).
        status, solver_stats, eta_shadow_price_t_per_h
            Stored as given.
        step_nm : float
            Longest piece of the dense resampling [nm].
        """
        wp = np.asarray(waypoints, dtype=float)
        if wp.ndim != 2 or wp.shape[1] != 2 or wp.shape[0] < 2:
            raise ConfigError(f"waypoints must be an (n, 2) array of (lat, lon) with n >= 2, got shape {wp.shape}")
        finite("waypoints", wp, error=ConfigError)
        wp = np.column_stack([wp[:, 0], units.wrap_180(wp[:, 1])])
        stw = finite("stw_kn", stw_kn, minimum=0.0, strict=True, error=ConfigError, fix="give one speed > 0 per leg")
        stw = np.broadcast_to(stw, (wp.shape[0] - 1,)).astype(float)
        step = float(finite("step_nm", step_nm, minimum=0.0, strict=True, error=ConfigError))
        t0 = _as_time(departure, "departure")
        sampler, ds = _as_sampler(weather)
        ctx = PlanContext(
            ship=ship,
            model=model if model is not None else default_model(ship),
            rules=rules if rules is not None else BandRules(),
            sampler=sampler,
            dataset=ds,
            corridor=corridor,
            eta=eta,
            eta_mode=eta_mode,
            exclusion=exclusion,
            use_land_mask=use_land_mask,
        )
        tt = None
        if times is not None:
            tt = np.asarray(times, dtype="datetime64[ns]")
            if tt.shape != (wp.shape[0],) or tt[0] != t0:
                raise ConfigError(f"times must hold {wp.shape[0]} UTC times starting at the departure {t0}")
        return cls.from_context(
            ctx,
            wp,
            stw,
            departure=t0,
            times=tt,
            status=status,
            solver_stats=solver_stats,
            eta_shadow_price_t_per_h=eta_shadow_price_t_per_h,
            step_nm=step,
        )

    @classmethod
    def from_context(
        cls,
        context: PlanContext,
        waypoints: np.ndarray,
        stw_kn: np.ndarray,
        *,
        departure: np.datetime64,
        times: np.ndarray | None = None,
        status: str = "unverified",
        solver_stats: Mapping[str, Any] | None = None,
        eta_shadow_price_t_per_h: float = float("nan"),
        step_nm: float = 5.0,
    ) -> Plan:
        """:meth:`from_schedule` with a ready :class:`PlanContext` (checked inputs: (n, 2) waypoints, n − 1 speeds)."""
        wp = np.asarray(waypoints, dtype=float)
        stw = np.asarray(stw_kn, dtype=float)
        sched_h = None if times is None else _td_to_h(np.asarray(times, dtype="datetime64[ns]") - departure)
        ev = _evaluate(context, wp, stw, departure, sched_h, step_nm)
        if sched_h is None:
            sched_h = np.concatenate([[0.0], np.cumsum(ev.leg_duration_h)])
        tt = departure + _h_to_td(sched_h)
        d = geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
        legs = _legs_table(context, wp, tt, ev, d)
        return cls(
            legs=legs,
            waypoints=wp,
            times=tt,
            total_fuel_t=float(legs["fuel_t"].sum()),
            duration_h=float(sched_h[-1]),
            departure=departure,
            arrival=tt[-1],
            status=status,
            solver_stats=dict(solver_stats or {}),
            eta_shadow_price_t_per_h=float(eta_shadow_price_t_per_h),
            context=context,
        )

    # ------------------------------------------------------------------ properties
    @property
    def distance_nm(self) -> float:
        """Distance sailed [nm]."""
        return float(self.legs["distance_nm"].sum())

    @property
    def stw_kn(self) -> np.ndarray:
        """Speed through the water of every leg [kn]."""
        return self.legs["stw_kn"].to_numpy(dtype=float)

    # ------------------------------------------------------------------ verification
    def verify(
        self,
        *,
        step_nm: float = 5.0,
        time_tol_h: float = 1.0 / 60.0,
        power_rtol: float = 1e-6,
        corridor_tol_nm: float = 0.01,
        eta: Any = None,
        eta_mode: str | None = None,
    ) -> list[Violation]:
        """Re-check every constraint on a dense resampling, independently of the optimiser.

        Parameters
        ----------
        step_nm : float
            Longest piece of the resampling [nm]; the checks are made at every piece midpoint and
            at both ends of every leg.
        time_tol_h : float
            Tolerance of the ETA and of the schedule [h] (default one minute).
        power_rtol : float
            Relative tolerance of the power limits [-].
        corridor_tol_nm : float
            Tolerance of the corridor's half-width [nm].
        eta, eta_mode : optional
            Override the plan's ETA requirement (default: the context's).

        Returns
        -------
        list of Violation
            The worst point of every (kind, leg) that breaks a constraint; empty when the plan is clean.
        """
        ctx = self.context
        step = float(finite("step_nm", step_nm, minimum=0.0, strict=True, error=ConfigError))
        tol_h = float(finite("time_tol_h", time_tol_h, minimum=0.0, error=ConfigError))
        eta_t = _as_time(eta, "eta") if eta is not None else ctx.eta
        mode = eta_mode or ctx.eta_mode
        if mode not in ("le", "eq"):
            raise ConfigError(f"eta_mode={mode!r} is not known; use 'le' or 'eq'")
        t0 = self.departure
        sched = _td_to_h(self.times - t0)
        stw = self.stw_kn
        ev = _evaluate(ctx, self.waypoints, stw, t0, sched, step)
        found: dict[tuple[str, int], tuple[float, Violation]] = {}

        def report(kind: str, mask: np.ndarray, value: np.ndarray, limit: Any, badness: np.ndarray) -> None:
            limit = np.broadcast_to(np.asarray(limit, dtype=float), mask.shape)
            for i in np.flatnonzero(mask):
                key = (kind, int(ev.leg[i]))
                if key not in found or badness[i] > found[key][0]:
                    when = t0 + _h_to_td(ev.time_h[i])
                    v = Violation(kind, key[1], (float(ev.lat[i]), float(ev.lon[i])), when, float(value[i]),
                                  float(limit[i]))
                    found[key] = (float(badness[i]), v)

        sea = ev.sea
        nav = sea.navigable & ev.covered
        ones = np.ones(ev.leg.shape)
        report("weather_coverage", ~ev.covered, ones, 0.0, ones)
        report("no_passage", ev.covered & ~sea.navigable, ones, 0.0, ones)
        if ctx.land_mask_applies:
            on_land = land.is_land(ev.lat, ev.lon)
            report("land", on_land, ones, 0.0, ones)
        held = np.isfinite(ev.heading)
        report("course", nav & ~held, ones, 0.0, ones)
        ok = nav & held
        mcr, pmin = float(ctx.model.mcr_kw), float(ctx.model.min_power_kw)
        p = np.where(np.isfinite(ev.power), ev.power, np.inf)
        high = ok & (p > mcr * (1.0 + power_rtol))
        report("power_above_mcr", high, p, mcr, np.where(np.isfinite(p), p, 1e300))
        low = ok & (p < pmin * (1.0 - power_rtol))
        report("power_below_min", low, p, pmin, pmin - p)
        heading = np.where(held, ev.heading, ev.course)
        hs = np.where(nav, sea.hs_m, 0.0)
        per = np.where(nav, sea.period_s, 1.0)
        wfrom = np.where(nav, sea.wave_from_deg, 0.0)
        margins = band_margins(ctx.ship, speed_kn=ev.stw, hs_m=hs, period_s=per, wave_from_deg=wfrom,
                               heading_deg=heading, rules=ctx.rules)
        for band in ctx.rules.enabled_bands:
            hit = ok & is_speed_forbidden(ctx.ship, speed_kn=ev.stw, hs_m=hs, period_s=per, wave_from_deg=wfrom,
                                          heading_deg=heading, rules=ctx.rules, band=band)
            bm = margins[band]
            below = bm.ratio < 0.5 * (bm.lo + bm.hi) if np.isfinite(bm.hi) else np.ones(bm.ratio.shape, dtype=bool)
            edge = np.where(below, bm.lo, bm.hi)
            report(f"band:{band}", hit, bm.ratio, edge, -np.asarray(bm.margin, dtype=float))
        if ctx.corridor is not None:
            cw = ctx.corridor.waypoints
            s, _, dist, _ = project_to_polyline(cw, ev.lat, ev.lon)
            hw = np.interp(s, ctx.corridor.along_track_nm, ctx.corridor.half_width_nm)
            out = dist > hw + corridor_tol_nm
            report("corridor", out, dist, hw, dist - hw)
        if ctx.exclusion is not None:
            when = t0 + _h_to_td(ev.time_h)
            clat, clon, rad = ctx.exclusion.at(when)
            dist = geo.distance_nm(ev.lat, ev.lon, clat, clon)
            inside = dist < rad
            report("exclusion", inside, dist, rad, rad - dist)
        # schedule: the planned times against the times the planned speeds give
        sailed = np.concatenate([[0.0], np.cumsum(ev.leg_duration_h)])
        err = sailed - sched
        bad = np.flatnonzero(np.abs(err) > tol_h)
        if bad.size:
            k = int(bad[np.argmax(np.abs(err[bad]))])
            leg = max(k - 1, 0)
            v = Violation("schedule", leg, tuple(float(x) for x in self.waypoints[k]), self.times[k], float(err[k]),
                          tol_h)
            found[("schedule", leg)] = (abs(float(err[k])), v)
        if eta_t is not None:
            eta_h = float(_td_to_h(eta_t - t0))
            offsets = [float(sched[-1]) - eta_h, float(sailed[-1]) - eta_h]  # planned and sailed arrival − ETA
            late = max(offsets) if mode == "le" else max(offsets, key=abs)
            if (mode == "le" and late > tol_h) or (mode == "eq" and abs(late) > tol_h):
                leg = self.waypoints.shape[0] - 2
                v = Violation("eta", leg, tuple(float(x) for x in self.waypoints[-1]), self.arrival, late, tol_h)
                found[("eta", leg)] = (abs(late), v)
        return [v for _, v in sorted(found.values(), key=lambda item: (item[1].leg, item[1].kind))]

    # ------------------------------------------------------------------ export
    def to_geojson(self) -> dict[str, Any]:
        """The plan as an RFC 7946 GeoJSON FeatureCollection.

        The track is a ``LineString`` of the waypoints ([lon, lat] positions), split into a
        ``MultiLineString`` where it crosses the antimeridian (RFC 7946 §3.1.9), the crossing
        latitude found on the leg's great circle. One ``Point`` feature per waypoint carries its
        time and the quantities of the leg that starts there.

        Returns
        -------
        dict
            JSON-serialisable (``json.dumps``).
        """
        wp = self.waypoints
        parts: list[list[list[float]]] = [[[float(wp[0, 1]), float(wp[0, 0])]]]
        for k in range(wp.shape[0] - 1):
            (la0, lo0), (la1, lo1) = wp[k], wp[k + 1]
            if abs(lo1 - lo0) > 180.0:
                east = lo0 > 0  # leaving the eastern hemisphere side (lon → +180)
                lo, hi = 0.0, 1.0
                for _ in range(60):  # bisection on the fraction where the great circle crosses 180°
                    mid = 0.5 * (lo + hi)
                    _, lon_m, _ = gc_points(la0, lo0, la1, lo1, mid)
                    if (float(lon_m) > 0) == east:
                        lo = mid
                    else:
                        hi = mid
                lat_x, _, _ = gc_points(la0, lo0, la1, lo1, 0.5 * (lo + hi))
                edge = 180.0 if east else -180.0
                parts[-1].append([edge, float(lat_x)])
                parts.append([[-edge, float(lat_x)]])
            parts[-1].append([float(lo1), float(la1)])
        if len(parts) == 1:
            geometry: dict[str, Any] = {"type": "LineString", "coordinates": parts[0]}
        else:
            geometry = {"type": "MultiLineString", "coordinates": parts}
        track = {
            "type": "Feature",
            "geometry": geometry,
            "properties": {
                "kind": "track",
                "departure": str(self.departure),
                "arrival": str(self.arrival),
                "duration_h": self.duration_h,
                "total_fuel_t": self.total_fuel_t,
                "distance_nm": self.distance_nm,
                "status": self.status,
                "eta_shadow_price_t_per_h": _json_number(self.eta_shadow_price_t_per_h),
            },
        }
        features = [track]
        legs = self.legs
        for k in range(wp.shape[0]):
            props: dict[str, Any] = {"kind": "waypoint", "index": k, "time": str(self.times[k])}
            if k < len(legs):
                for col in legs.columns:
                    if col in ("lat", "lon", "time"):
                        continue
                    props[col] = _json_number(legs[col].iloc[k])
            features.append(
                {"type": "Feature", "geometry": {"type": "Point", "coordinates": [float(wp[k, 1]), float(wp[k, 0])]},
                 "properties": props}
            )
        return {"type": "FeatureCollection", "features": features}

    def to_dataset(self) -> xr.Dataset:
        """The plan as an ``xarray.Dataset``: leg variables on ``leg``, waypoints on ``waypoint``."""
        legs = self.legs
        data: dict[str, Any] = {}
        for col in legs.columns:
            name = "leg_time" if col == "time" else col if col not in ("lat", "lon") else f"leg_start_{col}"
            data[name] = ("leg", legs[col].to_numpy())
        data["waypoint_lat"] = ("waypoint", self.waypoints[:, 0])
        data["waypoint_lon"] = ("waypoint", self.waypoints[:, 1])
        data["waypoint_time"] = ("waypoint", self.times)
        attrs = {
            "title": "optroute voyage plan",
            "total_fuel_t": self.total_fuel_t,
            "duration_h": self.duration_h,
            "departure": str(self.departure),
            "arrival": str(self.arrival),
            "status": self.status,
            "eta_shadow_price_t_per_h": self.eta_shadow_price_t_per_h,
            "solver_stats": json.dumps(_jsonable(self.solver_stats)),
            "conventions": "lat/lon deg; times UTC; heading deg true (to); wave_from_deg deg true (from)",
        }
        return xr.Dataset(data, attrs=attrs)

    def to_netcdf(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`to_dataset` to NetCDF, atomically (a temporary file in the same folder, then ``os.replace``).

        Returns
        -------
        pathlib.Path
            The path written.
        """
        target = Path(path)
        folder = target.parent if str(target.parent) else Path(".")
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
        os.close(fd)
        try:
            self.to_dataset().to_netcdf(tmp)
            os.replace(tmp, target)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        return target


def _json_number(x: Any) -> Any:
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None if math.isnan(x) else ("inf" if x > 0 else "-inf")
    return x


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, Mapping):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_jsonable(v) for v in obj.tolist()]
    if isinstance(obj, np.datetime64):
        return str(obj)
    if isinstance(obj, np.generic | float | int | bool | str) or obj is None:
        return _json_number(obj)
    return str(obj)
