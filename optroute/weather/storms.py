"""Extratropical winter storms: Boeing EP 2145155's San Diego → Tokyo situation.

A storm here is its sea: an elliptic, flat-topped H_s field around the
wave maximum that moves along a track and grows and decays, with waves
from the direction of a cyclonic wind about its low; see :class:`Storm`.
:func:`north_pacific_storms` (also ``optroute.scenarios.north_pacific_storms``)
places two of them across the great circle.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
import xarray as xr

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.weather import schema
from optroute.weather._synth import (
    PM_TP_PER_SQRT_HS,
    SAN_DIEGO,
    STORM_TP_PER_SQRT_HS,
    TOKYO,
    as_start,
    domain,
    grid_params,
    hours_since,
    pm_wind_from_hs,
    scenario_attrs,
    time_axis,
    wind_uv_from,
)

__all__ = [
    "Storm",
    "moving_storm",
    "moving_storm_spec",
    "north_pacific_storm_specs",
    "north_pacific_storms",
    "storm_dataset",
]


@dataclass(frozen=True)
class Storm:
    """An extratropical storm's sea: an elliptic, flat-topped H_s field that moves and grows or decays.

    H_s of the storm's own sea at distance d and bearing θ from its centre:
    ``peak_hs_m * envelope(t) * exp(-0.5 * rho**(2 * shape_order))`` with
    ``rho**2 = (d cos(θ - major_axis_deg) / semi_major_nm)**2 + (d sin(θ - major_axis_deg) / semi_minor_nm)**2``
    (d, θ on the sphere, so the antimeridian is harmless; ``shape_order`` 1
    is a Gaussian, 2 a flatter top).  It adds to the background as energy:
    H_s = sqrt(H_bg² + Σ H_storm²).

    Its waves come from the direction the storm's wind comes from: a
    cyclonic (counter-clockwise in the north) circulation about the low,
    which lies ``low_offset_nm`` from the wave maximum on the bearing
    ``low_bearing_deg``, turned 20° in towards the low (inflow angle); the
    strongest seas of a mid-latitude winter storm lie in the westerly flow
    south of its low.

    Attributes
    ----------
    name : str
    track : tuple of (hours, lat, lon)
        Centre of the wave maximum [h after the start, deg, deg]; linear in
        time between points (lon unwrapped), held beyond the ends.
    peak_hs_m : float
        H_s of the storm's own sea at the centre at full strength [m].
    semi_major_nm, semi_minor_nm : float
        Axes of the ellipse where the field falls to exp(-0.5) of the peak [nm].
    major_axis_deg : float
        Direction of the major axis [deg true].
    envelope : tuple of (hours, factor)
        Strength against time, linear in between, held beyond the ends.
    low_offset_nm, low_bearing_deg : float
        Where the low centre lies from the wave maximum [nm, deg true].
    shape_order : int
        1 Gaussian, 2 flat-topped.
    tp_per_sqrt_hs : float
        T_p / sqrt(H_s) of the storm's sea [s/sqrt(m)]; 3.85 (young storm sea).
    """

    name: str
    track: tuple[tuple[float, float, float], ...]
    peak_hs_m: float
    semi_major_nm: float
    semi_minor_nm: float
    major_axis_deg: float
    envelope: tuple[tuple[float, float], ...] = ((0.0, 1.0),)
    low_offset_nm: float = 900.0
    low_bearing_deg: float = 0.0
    shape_order: int = 2
    tp_per_sqrt_hs: float = STORM_TP_PER_SQRT_HS

    def __post_init__(self) -> None:
        track = tuple(tuple(float(v) for v in p) for p in self.track)
        if not track or any(len(p) != 3 for p in track):
            raise ConfigError(f"storm {self.name!r}: track must be (hours, lat, lon) triples, got {self.track!r}")
        if np.any(np.diff([p[0] for p in track]) <= 0):
            raise ConfigError(f"storm {self.name!r}: track times must be strictly increasing [h]")
        env = tuple(tuple(float(v) for v in p) for p in self.envelope)
        if not env or any(len(p) != 2 for p in env) or np.any(np.diff([p[0] for p in env]) <= 0):
            raise ConfigError(f"storm {self.name!r}: envelope must be (hours, factor) pairs with increasing hours")
        object.__setattr__(self, "track", track)
        object.__setattr__(self, "envelope", env)
        for f in ("peak_hs_m", "semi_major_nm", "semi_minor_nm", "tp_per_sqrt_hs"):
            finite(f, getattr(self, f), minimum=0.0, strict=True, error=ConfigError)
        finite("low_offset_nm", self.low_offset_nm, minimum=0.0, error=ConfigError)
        if self.shape_order < 1:
            raise ConfigError(f"storm {self.name!r}: shape_order={self.shape_order} must be >= 1")

    def centre(self, hours: float) -> tuple[float, float]:
        """(lat, lon) of the wave maximum [deg] at hours after the start."""
        tr = np.asarray(self.track)
        lon = geo.unwrap_lon_deg(tr[:, 2])
        return float(np.interp(hours, tr[:, 0], tr[:, 1])), float(units.wrap_180(np.interp(hours, tr[:, 0], lon)))

    def strength(self, hours: float) -> float:
        """Envelope factor [-] at hours after the start."""
        env = np.asarray(self.envelope)
        return float(np.clip(np.interp(hours, env[:, 0], env[:, 1]), 0.0, None))

    def fields(self, hours: float, lat: np.ndarray, lon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The storm's own H_s [m] and the direction its waves come from [deg true] at one time."""
        lat_c, lon_c = self.centre(hours)
        d, brg, _ = geo.inverse(lat_c, lon_c, lat, lon)  # one geodesic solve gives both
        rel = np.radians(brg - self.major_axis_deg)
        rho2 = (d * np.cos(rel) / self.semi_major_nm) ** 2 + (d * np.sin(rel) / self.semi_minor_nm) ** 2
        hs = self.peak_hs_m * self.strength(hours) * np.exp(-0.5 * rho2**self.shape_order)
        lat_l, lon_l = geo.destination(lat_c, lon_c, self.low_bearing_deg, self.low_offset_nm)
        b = geo.initial_course_deg(np.full(lat.shape, float(lat_l)), np.full(lat.shape, float(lon_l)), lat, lon)
        north = float(lat_l) >= 0.0
        from_deg = b + 90.0 - _INFLOW_DEG if north else b - 90.0 + _INFLOW_DEG
        return hs, units.wrap_360(from_deg)

    def shifted(
        self, *, dlat_deg: float = 0.0, dlon_deg: float = 0.0, dt_h: float = 0.0, intensity_factor: float = 1.0
    ) -> Storm:
        """A copy moved in position and time, its peak scaled."""
        track = tuple((t + dt_h, min(max(la + dlat_deg, -89.0), 89.0), lo + dlon_deg) for t, la, lo in self.track)
        env = tuple((t + dt_h, f) for t, f in self.envelope)
        return replace(self, track=track, envelope=env, peak_hs_m=self.peak_hs_m * intensity_factor)


_INFLOW_DEG = 20.0


def _compose(
    hs_bg: float, from_bg: float, systems: list[tuple[np.ndarray, np.ndarray, float]]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Combine a background sea with storm seas.

    systems: (H_s [m], from [deg], T_p / sqrt(H_s)) per storm.  H_s adds as
    energy; direction and T_p / sqrt(H_s) are energy-weighted means (the
    direction as a vector); T_p = that ratio × sqrt(H_s); the wind is the
    fully developed wind of the total H_s, from the wave direction.
    """
    e_bg = hs_bg**2
    shape = systems[0][0].shape if systems else ()
    e_tot = np.full(shape, e_bg)
    sx = np.full(shape, e_bg * math.sin(math.radians(from_bg)))
    cx = np.full(shape, e_bg * math.cos(math.radians(from_bg)))
    ratio = np.full(shape, e_bg * PM_TP_PER_SQRT_HS)
    for hs, frm, c in systems:
        e = hs**2
        e_tot = e_tot + e
        sx = sx + e * np.sin(np.radians(frm))
        cx = cx + e * np.cos(np.radians(frm))
        ratio = ratio + e * c
    hs = np.sqrt(e_tot)
    tp = ratio / e_tot * np.sqrt(hs)
    wdir = units.wrap_360(np.degrees(np.arctan2(sx, cx)))
    wu, wv = wind_uv_from(pm_wind_from_hs(hs), wdir)
    return hs, tp, wdir, wu, wv


def north_pacific_storm_specs(
    start_lat_lon: tuple[float, float] = SAN_DIEGO, end_lat_lon: tuple[float, float] = TOKYO
) -> list[Storm]:
    """The two winter storms of :func:`north_pacific_storms`, placed on the great circle.

    Each storm's wave maximum starts on the San Diego → Tokyo great circle
    (storm A at 32 % of the way, 45.1 N 148 W, where the ship at 25 kn would
    be after 62 h; storm B at 73 %, 45.2 N 166 E, 142 h) and drifts east
    along it at 3 kn (towards the westbound ship); its ellipse lies along the
    local great-circle course and its low lies 900 nm to the north-east (A)
    or north (B), so at the centre its waves come from the course a
    westbound ship steers: head seas.

    Parameters
    ----------
    start_lat_lon, end_lat_lon : (float, float)
        The voyage whose great circle the storms straddle [deg].

    Returns
    -------
    list of Storm
    """
    d = float(geo.distance_nm(*start_lat_lon, *end_lat_lon))
    specs = []
    for name, frac0, env, drift_kn in (
        ("A", 0.32, ((0.0, 0.6), (24.0, 1.0), (220.0, 1.0), (280.0, 0.0)), 3.0),
        ("B", 0.73, ((0.0, 0.3), (48.0, 1.0), (260.0, 1.0), (320.0, 0.0)), 3.0),
    ):
        hours = np.arange(0.0, 16 * 24 + 1, 24.0)
        frac = frac0 - drift_kn * hours / d
        lat, lon = geo.intermediate_points(*start_lat_lon, *end_lat_lon, frac)
        la0, lo0 = geo.intermediate_points(*start_lat_lon, *end_lat_lon, [frac0, frac0 + 1e-3])
        course = float(geo.initial_course_deg(la0[0], lo0[0], la0[1], lo0[1]))
        specs.append(
            Storm(
                name=name,
                track=tuple((float(h), float(a), float(b)) for h, a, b in zip(hours, lat, lon, strict=True)),
                peak_hs_m=14.0,
                semi_major_nm=620.0,
                semi_minor_nm=330.0,
                major_axis_deg=course,
                envelope=env,
                low_offset_nm=900.0,
                low_bearing_deg=float(units.wrap_360(course + 90.0 + _INFLOW_DEG)),
            )
        )
    return specs


def north_pacific_storms(
    storms: Sequence[Storm] | None = None,
    *,
    start: Any = None,
    duration_h: float = 384.0,
    step_h: float = 6.0,
    resolution_deg: float = 0.5,
    bbox: Sequence[float] = (15.0, 60.0, 115.0, -110.0),
    background_hs_m: float = 2.5,
    background_from_deg: float = 280.0,
) -> xr.Dataset:
    """Boeing EP 2145155's San Diego → Tokyo situation: two winter storms across the great circle.

    Designed so that a 25 kn container ship on the great circle must slow
    below 10 kn under the Boeing danger bands inside both storms.  For
    ``Ship.preset("container_8000teu")`` (L_pp 320 m, so the bands apply
    where H_s >= 0.04 L = 12.8 m; T_R = 20.7 s by the IS Code) in head seas,
    the parametric-roll band T_E / T_R in [0.4, 0.6] covers every speed from
    10 to 25 kn when 13.4 s <= T_p <= 15.1 s; the storms' young sea,
    T_p = 3.85 sqrt(H_s), gives 13.9–14.7 s for H_s 12.8–14.2 m, and their
    waves meet a ship on the great circle within 45° of the bow (head seas at
    the storm centres), where the band still reaches below 10 kn.

    Storms (:func:`north_pacific_storm_specs`): peak H_s 14 m over a
    flat-topped ellipse (semi-axes 620 nm along and 330 nm across the great
    circle), drifting east along the great circle at 3 kn; A grows from 60 %
    at t = 0 to full strength at 24 h and decays from 220 h to nothing at
    280 h; B grows from 30 % to full at 48 h and decays from 260 h to nothing
    at 320 h.  Background: H_s 2.5 m from 280° (winter westerlies), fully
    developed (T_p 7.9 s, wind 10 m/s).

    Outcome (checked in ``tests/test_scenarios.py`` with
    :func:`optroute.physics.safety.forbidden_speed_intervals`): wherever the bands
    apply on the great circle the fastest band-free speed is below 9 kn, and
    a ship leaving San Diego at t = 0 that keeps to the great circle at the
    fastest band-free speed (at most 25 kn) needs about 12.5 days instead of
    8.1 — the patent's "more than 12 days".

    Parameters
    ----------
    storms : sequence of Storm, optional
        Default :func:`north_pacific_storm_specs`.
    start : datetime64 or str, optional
        t = 0 [UTC]; default :data:`DEFAULT_START` (the ship is meant to sail at t = 0).
    duration_h, step_h : float
        Span (16 days) and spacing [h].
    resolution_deg : float
        Grid spacing [deg].
    bbox : (lat_min, lat_max, lon_min, lon_max)
        15–60 N, 115 E – 110 W across the antimeridian (lon 115 … 250 unwrapped).
    background_hs_m, background_from_deg : float
        Background sea [m] and direction [deg true, from].

    Returns
    -------
    xarray.Dataset
        With ``attrs["storms"]`` (JSON of the storm specifications) and the
        ports in ``attrs["start_lat_lon"]``/``attrs["end_lat_lon"]``.
    """
    specs = list(north_pacific_storm_specs() if storms is None else storms)
    return storm_dataset(
        specs,
        name="north_pacific_storms",
        start=start,
        duration_h=duration_h,
        step_h=step_h,
        resolution_deg=resolution_deg,
        bbox=bbox,
        background_hs_m=background_hs_m,
        background_from_deg=background_from_deg,
        title="Boeing EP 2145155: San Diego to Tokyo: two winter storms across the great circle",
        start_lat_lon=json.dumps(SAN_DIEGO),
        end_lat_lon=json.dumps(TOKYO),
    )


def storm_dataset(
    storms: Sequence[Storm],
    *,
    bbox: Sequence[float],
    start: Any = None,
    duration_h: float = 240.0,
    step_h: float = 6.0,
    resolution_deg: float = 0.5,
    background_hs_m: float = 2.0,
    background_from_deg: float = 270.0,
    name: str = "storm_dataset",
    **attrs: Any,
) -> xr.Dataset:
    """A canonical dataset of any storms over a background sea.

    H_s adds as energy, H = sqrt(H_bg² + Σ H_storm²); wave direction and
    T_p / sqrt(H_s) are energy-weighted means (the background sea is fully
    developed, T_p = 5.0 sqrt(H_s); each storm has its own ratio); the wind
    is the fully developed wind of the total H_s (:func:`pm_wind_from_hs`),
    from the wave direction.

    Parameters
    ----------
    storms : sequence of Storm
    bbox : (lat_min, lat_max, lon_min, lon_max)
        Area [deg]; ``lon_max < lon_min`` crosses the antimeridian.
    start : datetime64 or str, optional
        t = 0 [UTC].
    duration_h, step_h, resolution_deg : float
        Span [h], spacing [h], grid spacing [deg].
    background_hs_m, background_from_deg : float
        Background sea [m] and direction [deg true, from].
    name : str
        Scenario name for ``attrs``.
    **attrs
        Extra global attributes (strings or numbers).

    Returns
    -------
    xarray.Dataset
        With ``attrs["storms"]`` (JSON of the storm specifications).
    """
    specs = list(storms)
    t0 = as_start(start)
    time = time_axis(t0, duration_h, step_h)
    lat, lon = domain(bbox, resolution_deg)
    hs_bg = float(finite("background_hs_m", background_hs_m, minimum=0.0, strict=True, error=ConfigError))
    from_bg = float(units.wrap_360(background_from_deg))
    la, lo = np.meshgrid(lat, units.wrap_180(lon), indexing="ij")
    names = ("hs_m", "tp_s", "wave_from_deg", "wind_u_ms", "wind_v_ms")
    out = {k: np.empty((time.size, lat.size, lon.size)) for k in names}
    for k, h in enumerate(hours_since(time, t0)):
        systems = []
        for s in specs:
            hs_s, from_s = s.fields(float(h), la, lo)
            systems.append((hs_s, from_s, s.tp_per_sqrt_hs))
        for key, value in zip(names, _compose(hs_bg, from_bg, systems), strict=True):
            out[key][k] = value
    params = grid_params(
        t0,
        duration_h,
        step_h,
        resolution_deg,
        bbox,
        background_hs_m=hs_bg,
        background_from_deg=from_bg,
    )
    extra = {"storms": json.dumps([asdict(s) for s in specs]), **attrs}
    return schema.canonical_dataset(time, lat, lon, out, scenario_attrs(name, params, lon, **extra))


def moving_storm_spec(
    lat_deg: float,
    lon_deg: float,
    course_deg: float,
    speed_kn: float,
    *,
    peak_hs_m: float = 8.0,
    radius_nm: float = 250.0,
    duration_h: float = 120.0,
) -> Storm:
    """The :class:`Storm` of :func:`moving_storm`: round, Gaussian, moving on a great circle at constant speed.

    Parameters are those of :func:`moving_storm` (centre at t = 0 [deg], course [deg true, to],
    speed [kn], peak H_s [m], radius [nm], track length [h]).
    """
    from optroute.weather.cyclone import straight_track

    track = straight_track(lat_deg, lon_deg, course_deg, speed_kn, duration_h=max(float(duration_h), 1.0), step_h=6.0)
    return Storm(
        name="moving storm",
        track=track,
        peak_hs_m=peak_hs_m,
        semi_major_nm=radius_nm,
        semi_minor_nm=radius_nm,
        major_axis_deg=course_deg,
        low_offset_nm=0.0,
        shape_order=1,
    )


def moving_storm(
    lat_deg: float,
    lon_deg: float,
    course_deg: float,
    speed_kn: float,
    *,
    peak_hs_m: float = 8.0,
    radius_nm: float = 250.0,
    start: Any = None,
    duration_h: float = 120.0,
    step_h: float = 3.0,
    resolution_deg: float = 0.5,
    bbox: Sequence[float] | None = None,
    background_hs_m: float = 1.5,
    background_from_deg: float = 270.0,
) -> xr.Dataset:
    """One round storm moving on a great circle at constant speed, waves turning cyclonically about its centre.

    Parameters
    ----------
    lat_deg, lon_deg : float
        Centre at t = 0 [deg].
    course_deg : float
        Direction of motion [deg true, to].
    speed_kn : float
        Speed of the centre [kn], >= 0.
    peak_hs_m : float
        H_s of the storm's sea at the centre [m].
    radius_nm : float
        Where the storm's H_s falls to exp(-0.5) of the peak (Gaussian) [nm].
    start, duration_h, step_h, resolution_deg
        As in :func:`storm_dataset`.
    bbox : (lat_min, lat_max, lon_min, lon_max), optional
        Default: the track's extent plus 4 radii all round.
    background_hs_m, background_from_deg : float
        Background sea [m] and direction [deg true, from].

    Returns
    -------
    xarray.Dataset
    """
    storm = moving_storm_spec(
        lat_deg, lon_deg, course_deg, speed_kn, peak_hs_m=peak_hs_m, radius_nm=radius_nm, duration_h=duration_h
    )
    track = storm.track
    if bbox is None:
        lats = np.array([p[1] for p in track])
        lons = geo.unwrap_lon_deg([p[2] for p in track])
        pad_lat = 4.0 * radius_nm / 60.0
        pad_lon = pad_lat / math.cos(math.radians(min(float(np.abs(lats).mean()), 70.0)))
        lat_lo, lat_hi = max(lats.min() - pad_lat, -89.5), min(lats.max() + pad_lat, 89.5)
        lon_lo, lon_hi = lons.min() - pad_lon, lons.max() + pad_lon
        if lon_hi - lon_lo >= 360.0:
            lon_lo, lon_hi = -180.0, 180.0
        bbox = (lat_lo, lat_hi, float(units.wrap_180(lon_lo)), float(units.wrap_180(lon_hi)))
        if bbox[3] == bbox[2]:
            bbox = (lat_lo, lat_hi, -180.0, 180.0)
    return storm_dataset(
        [storm],
        name="moving_storm",
        start=start,
        duration_h=duration_h,
        step_h=step_h,
        resolution_deg=resolution_deg,
        bbox=bbox,
        background_hs_m=background_hs_m,
        background_from_deg=background_from_deg,
        title="A storm moving on a great circle",
    )
