"""Tropical cyclones for the typhoon-avoidance scenarios (the Chinese typhoon-avoidance patent, dynamic artificial potential field).

Wind: the Holland (1980) gradient wind profile, a cyclonic inflow angle, an
optional translation asymmetry, reduced to 10 m by a constant factor.
Waves: fetch-limited JONSWAP growth from the local 10 m wind over an
effective fetch, capped at the fully developed sea.  The force-7 circle of
the typhoon-avoidance patent (the radius inside which the 10 m wind reaches Beaufort 7,
13.9 m/s) is :func:`cyclone_radius_km`.

:func:`tropical_cyclone` builds the canonical dataset (default: the typhoon-avoidance patent's
test typhoon, :func:`default_cyclone`) and stores the track with the
force-7 radius at every time step in ``attrs["cyclone"]``;
:func:`cyclone_track` and :func:`cyclone_exclusion` read it back, for a
time-dependent exclusion circle (the patent: R + 30 km).

Sources
-------
* Holland, G. J. (1980), An analytic model of the wind and pressure profiles
  in hurricanes, *Mon. Wea. Rev.* 108, 1212–1218: pressure
  p(r) = p_c + Δp exp(−(R_max/r)^B), gradient wind

      V_g(r) = sqrt( (B Δp / ρ) (R_max/r)^B exp(−(R_max/r)^B) + (r f / 2)² ) − r f / 2,

  and, without Coriolis, the maximum V_max = sqrt(B Δp / (ρ e)) at r = R_max.
  f = 2 Ω sin φ, Ω = 7.2921e-5 rad/s; ρ = 1.15 kg/m³, the surface air
  density usually taken with this profile.
* Translation asymmetry: Jelesnianski, C. P. (1966), *Mon. Wea. Rev.* 94,
  379–394 (as used in NOAA's SLOSH model): the storm's motion U_t is added
  with weight r R_max / (r² + R_max²), half of U_t at R_max, fading far out.
* Inflow angle: 20° towards the centre, a constant typical of parametric
  models (10–25° is the usual range; a modelling choice); winds turn
  counter-clockwise in the northern hemisphere, clockwise in the southern.
* 10 m wind = ``surface_factor`` × gradient wind, 0.8 by default (a modelling
  choice over open ocean; 0.7–0.9 is the usual range; 1.0 keeps the
  gradient wind).
* Waves: JONSWAP fetch-limited growth (Hasselmann et al. 1973) as given in
  the *Shore Protection Manual* (CERC 1984): g H_s / U² = 1.6e-3 (g F / U²)^½,
  g T_p / U = 0.2857 (g F / U²)^⅓, capped at the fully developed limits
  g H_s / U² = 0.2433, g T_p / U = 8.134.  The effective fetch F stands for
  Young's (1988) "equivalent fetch" of a moving cyclone (Young, I. R., 1988,
  Parametric hurricane wave prediction model, *J. Waterway Port Coastal
  Ocean Eng.* 114(5)); its value is a modelling choice (300 km by default).  Waves come from the direction the local wind comes from.
* Beaufort 7 lower limit 13.9 m/s: WMO No. 306 (physics.md §5).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.weather import schema
from optroute.weather._synth import (
    PM_TP_PER_SQRT_HS,
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
    "AIR_DENSITY_KGM3",
    "BEAUFORT_7_MS",
    "Cyclone",
    "cyclone_exclusion",
    "cyclone_radius_km",
    "cyclone_track",
    "cyclone_waves",
    "cyclone_wind",
    "default_cyclone",
    "holland_gradient_wind_ms",
    "holland_vmax_ms",
    "straight_track",
    "tropical_cyclone",
]

AIR_DENSITY_KGM3 = 1.15
"""Air density in the cyclone boundary layer [kg/m³]."""

EARTH_ROTATION_RADS = 7.2921e-5
"""Earth's angular velocity Ω [rad/s]."""

BEAUFORT_7_MS = 13.9
"""Lower limit of Beaufort force 7 [m/s] at 10 m (WMO; the typhoon-avoidance patent's circle)."""

INFLOW_DEG = 20.0
"""Cross-isobar inflow angle of the surface wind towards the centre [deg]."""

G = 9.80665

# JONSWAP / SPM (CERC 1984) fetch-limited growth and the fully developed cap.
_HS_FETCH_COEF = 1.6e-3
_TP_FETCH_COEF = 0.2857
_HS_FULL = 0.2433
_TP_FULL = 8.134


def coriolis_per_s(lat_deg: ArrayLike) -> np.ndarray:
    """Coriolis parameter f = 2 Ω sin φ [1/s] at latitude φ [deg]."""
    return 2.0 * EARTH_ROTATION_RADS * np.sin(np.radians(np.asarray(lat_deg, dtype=float)))


def holland_vmax_ms(pressure_deficit_hpa: float, holland_b: float, air_density_kgm3: float = AIR_DENSITY_KGM3) -> float:
    """Holland's (1980) cyclostrophic maximum gradient wind V_max = sqrt(B Δp / (ρ e)).

    Parameters
    ----------
    pressure_deficit_hpa : float
        Δp = ambient minus central pressure [hPa], > 0.
    holland_b : float
        Holland's shape parameter B [-], > 0 (typically 1–2.5).
    air_density_kgm3 : float
        ρ [kg/m³].

    Returns
    -------
    float
        V_max [m/s], reached at r = R_max when Coriolis is neglected.
    """
    dp = (
        float(finite("pressure_deficit_hpa", pressure_deficit_hpa, minimum=0.0, strict=True, error=ConfigError)) * 100.0
    )
    b = float(finite("holland_b", holland_b, minimum=0.0, strict=True, error=ConfigError))
    return math.sqrt(b * dp / (air_density_kgm3 * math.e))


def holland_gradient_wind_ms(
    r_km: ArrayLike,
    pressure_deficit_hpa: float,
    rmax_km: float,
    holland_b: float,
    lat_deg: float,
    air_density_kgm3: float = AIR_DENSITY_KGM3,
) -> np.ndarray:
    """Holland (1980) gradient wind speed at distance r from the centre.

    V_g(r) = sqrt((B Δp/ρ)(R_max/r)^B exp(−(R_max/r)^B) + (r f/2)²) − r f/2,
    with |f| = 2 Ω |sin φ| (the speed is the same in both hemispheres).

    Parameters
    ----------
    r_km : array_like
        Distance from the centre [km], >= 0 (0 gives 0).
    pressure_deficit_hpa : float
        Δp [hPa], > 0.
    rmax_km : float
        Radius of maximum wind R_max [km], > 0.
    holland_b : float
        Shape parameter B [-], > 0.
    lat_deg : float
        Latitude of the centre [deg] for the Coriolis parameter.
    air_density_kgm3 : float
        ρ [kg/m³].

    Returns
    -------
    ndarray
        Gradient wind speed [m/s].
    """
    r = finite("r_km", r_km, minimum=0.0, error=ConfigError) * 1000.0
    dp = (
        float(finite("pressure_deficit_hpa", pressure_deficit_hpa, minimum=0.0, strict=True, error=ConfigError)) * 100.0
    )
    rmax = float(finite("rmax_km", rmax_km, minimum=0.0, strict=True, error=ConfigError)) * 1000.0
    b = float(finite("holland_b", holland_b, minimum=0.0, strict=True, error=ConfigError))
    f = abs(float(coriolis_per_s(lat_deg)))
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        x = np.where(r > 0, (rmax / np.where(r > 0, r, 1.0)) ** b, np.inf)
        term = np.where(np.isfinite(x), (b * dp / air_density_kgm3) * x * np.exp(-np.minimum(x, 700.0)), 0.0)
    half_rf = 0.5 * r * f
    return np.sqrt(term + half_rf**2) - half_rf


@dataclass(frozen=True)
class Cyclone:
    """A tropical cyclone: track, intensity and wave parameters.

    Attributes
    ----------
    track : tuple of (float, float, float)
        (hours after the scenario start, lat [deg], lon [deg]) of the centre;
        positions in between are interpolated linearly in time (lon
        unwrapped, so a track may cross the antimeridian).
    pressure_deficit_hpa : float or tuple of float
        Δp [hPa], one value or one per track point.
    rmax_km : float or tuple of float
        Radius of maximum wind [km], one value or one per track point.
    holland_b : float
        Holland's B [-].
    surface_factor : float
        10 m wind / gradient wind [-].
    fetch_km : float
        Effective fetch of the wave growth relation [km].
    translation_asymmetry : bool
        Add the storm's motion with Jelesnianski's (1966) weight.
    name : str
        For attributes and messages.
    """

    track: tuple[tuple[float, float, float], ...]
    pressure_deficit_hpa: float | tuple[float, ...] = 60.0
    rmax_km: float | tuple[float, ...] = 40.0
    holland_b: float = 1.4
    surface_factor: float = 0.8
    fetch_km: float = 300.0
    translation_asymmetry: bool = True
    name: str = "cyclone"

    def __post_init__(self) -> None:
        track = tuple(tuple(float(v) for v in p) for p in self.track)
        if len(track) < 1 or any(len(p) != 3 for p in track):
            raise ConfigError(
                f"cyclone {self.name!r}: track must be a sequence of (hours, lat, lon) triples, got {self.track!r}"
            )
        arr = finite("track", np.array(track), error=ConfigError)
        if np.any(np.diff(arr[:, 0]) <= 0):
            raise ConfigError(
                f"cyclone {self.name!r}: track times {arr[:, 0].tolist()} must be strictly increasing [h]"
            )
        object.__setattr__(self, "track", track)
        for name in ("pressure_deficit_hpa", "rmax_km"):
            v = getattr(self, name)
            vals = finite(name, v, minimum=0.0, strict=True, error=ConfigError)
            if vals.ndim and vals.size != len(track):
                raise ConfigError(f"cyclone {self.name!r}: {name} has {vals.size} values for {len(track)} track points")
            object.__setattr__(self, name, tuple(float(x) for x in vals) if vals.ndim else float(vals))
        finite("holland_b", self.holland_b, minimum=0.0, strict=True, error=ConfigError)
        finite("surface_factor", self.surface_factor, minimum=0.0, strict=True, error=ConfigError)
        finite("fetch_km", self.fetch_km, minimum=0.0, strict=True, error=ConfigError)

    # -- track ------------------------------------------------------------

    def _series(self, name: str) -> np.ndarray:
        v = getattr(self, name)
        return np.asarray(v, dtype=float) if isinstance(v, tuple) else np.full(len(self.track), float(v))

    def state(self, hours: ArrayLike) -> dict[str, np.ndarray]:
        """Centre, motion and intensity at times [h after the start].

        Before the first or after the last track point the end values are
        held (a storm that has not moved yet, or has stopped).

        Returns
        -------
        dict
            ``lat``, ``lon`` [deg, lon in [-180, 180)], ``u_ms``, ``v_ms``
            (translation velocity east/north [m/s]), ``dp_hpa``, ``rmax_km``.
        """
        t = np.asarray(hours, dtype=float)
        tr = np.asarray(self.track)
        th, lat, lon = tr[:, 0], tr[:, 1], geo.unwrap_lon_deg(tr[:, 2])
        out = {
            "lat": np.interp(t, th, lat),
            "lon": units.wrap_180(np.interp(t, th, lon)),
            "dp_hpa": np.interp(t, th, self._series("pressure_deficit_hpa")),
            "rmax_km": np.interp(t, th, self._series("rmax_km")),
        }
        if len(th) > 1:
            k = np.clip(np.searchsorted(th, t, side="right") - 1, 0, len(th) - 2)
            dt_s = (th[k + 1] - th[k]) * 3600.0
            dlat_m = np.radians(lat[k + 1] - lat[k]) * geo.EARTH_RADIUS_M
            mid = np.radians(0.5 * (lat[k + 1] + lat[k]))
            dlon_m = np.radians(lon[k + 1] - lon[k]) * geo.EARTH_RADIUS_M * np.cos(mid)
            moving = (t >= th[0]) & (t <= th[-1])
            out["u_ms"] = np.where(moving, dlon_m / dt_s, 0.0)
            out["v_ms"] = np.where(moving, dlat_m / dt_s, 0.0)
        else:
            out["u_ms"] = np.zeros(t.shape)
            out["v_ms"] = np.zeros(t.shape)
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (for ``Dataset.attrs``)."""
        d = asdict(self)
        d["track"] = [list(p) for p in self.track]
        return d

    def perturbed(
        self, *, dlat_deg: float = 0.0, dlon_deg: float = 0.0, dt_h: float = 0.0, intensity_factor: float = 1.0
    ) -> Cyclone:
        """A copy shifted in position and time, its pressure deficit scaled."""
        track = tuple((t + dt_h, min(max(la + dlat_deg, -89.0), 89.0), lo + dlon_deg) for t, la, lo in self.track)
        dp = self.pressure_deficit_hpa
        dp = tuple(x * intensity_factor for x in dp) if isinstance(dp, tuple) else dp * intensity_factor
        return replace(self, track=track, pressure_deficit_hpa=dp)


def straight_track(
    lat_deg: float,
    lon_deg: float,
    course_deg: float,
    speed_kn: float,
    duration_h: float,
    step_h: float = 6.0,
    start_h: float = 0.0,
) -> tuple[tuple[float, float, float], ...]:
    """A track along a great circle at constant speed: start position + velocity.

    Parameters
    ----------
    lat_deg, lon_deg : float
        Start of the centre [deg].
    course_deg : float
        Direction of motion [deg true, to]; e.g. 315 for north-west.
    speed_kn : float
        Translation speed [kn], >= 0.
    duration_h : float
        Track length [h], > 0.
    step_h : float
        Spacing of the track points [h].
    start_h : float
        Time of the first point [h after the scenario start].

    Returns
    -------
    tuple of (hours, lat, lon)
    """
    duration = float(finite("duration_h", duration_h, minimum=0.0, strict=True, error=ConfigError))
    step = float(finite("step_h", step_h, minimum=0.0, strict=True, error=ConfigError))
    speed = float(finite("speed_kn", speed_kn, minimum=0.0, error=ConfigError))
    hours = np.arange(0.0, duration + 0.5 * step, step)
    lat, lon = geo.destination(np.full(hours.shape, lat_deg), np.full(hours.shape, lon_deg), course_deg, speed * hours)
    return tuple((float(start_h + h), float(a), float(b)) for h, a, b in zip(hours, lat, lon, strict=True))


def _bearing_distance(lat_c: float, lon_c: float, lat: np.ndarray, lon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance [km] and bearing [deg true] from a centre to points (antimeridian-safe)."""
    d_km = geo.distance_nm(lat_c, lon_c, lat, lon) * units.M_PER_NM / 1000.0
    brg = geo.initial_course_deg(np.full(lat.shape, lat_c), np.full(lat.shape, lon_c), lat, lon)
    return d_km, brg


def cyclone_wind(
    cyclone: Cyclone, hours: float, lat_deg: ArrayLike, lon_deg: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """10 m wind of the cyclone at one time, as (u, v) [m/s] — the vector the wind blows to.

    Parameters
    ----------
    cyclone : Cyclone
    hours : float
        Time [h after the scenario start].
    lat_deg, lon_deg : array_like
        Positions [deg].

    Returns
    -------
    u_ms, v_ms : ndarray
        East and north components [m/s].
    """
    lat = np.asarray(lat_deg, dtype=float)
    lon = np.asarray(lon_deg, dtype=float)
    lat, lon = np.broadcast_arrays(lat, lon)
    st = cyclone.state(hours)
    lat_c, lon_c = float(st["lat"]), float(st["lon"])
    rmax = float(st["rmax_km"])
    d_km, brg = _bearing_distance(lat_c, lon_c, lat, lon)
    speed = cyclone.surface_factor * holland_gradient_wind_ms(d_km, float(st["dp_hpa"]), rmax, cyclone.holland_b, lat_c)
    north = lat_c >= 0.0
    to_deg = brg - 90.0 - INFLOW_DEG if north else brg + 90.0 + INFLOW_DEG
    u, v = units.speed_to_deg_to_uv(speed, to_deg)
    if cyclone.translation_asymmetry:
        w = d_km * rmax / (d_km**2 + rmax**2)
        u = u + w * float(st["u_ms"])
        v = v + w * float(st["v_ms"])
    return u, v


def cyclone_waves(wind_speed_ms: ArrayLike, fetch_km: float) -> tuple[np.ndarray, np.ndarray]:
    """Fetch-limited JONSWAP sea from a 10 m wind, capped at full development (CERC 1984).

    Parameters
    ----------
    wind_speed_ms : array_like
        10 m wind speed U [m/s], >= 0.
    fetch_km : float
        Effective fetch F [km], > 0.

    Returns
    -------
    hs_m, tp_s : ndarray
        Significant wave height [m] and peak period [s]; a calm gives (0, 0).
    """
    u = finite("wind_speed_ms", wind_speed_ms, minimum=0.0, error=ConfigError)
    f_m = float(finite("fetch_km", fetch_km, minimum=0.0, strict=True, error=ConfigError)) * 1000.0
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(u > 0, G * f_m / np.where(u > 0, u, 1.0) ** 2, 0.0)
    hs_nd = np.minimum(_HS_FETCH_COEF * np.sqrt(x), _HS_FULL)
    tp_nd = np.minimum(_TP_FETCH_COEF * np.cbrt(x), _TP_FULL)
    return hs_nd * u**2 / G, tp_nd * u / G


def cyclone_radius_km(
    pressure_deficit_hpa: float,
    rmax_km: float,
    holland_b: float,
    lat_deg: float,
    wind_ms: float = BEAUFORT_7_MS,
    surface_factor: float = 0.8,
    air_density_kgm3: float = AIR_DENSITY_KGM3,
) -> float:
    """Outer radius inside which the symmetric 10 m wind reaches ``wind_ms``: the force-7 circle of the typhoon-avoidance patent.

    Parameters
    ----------
    pressure_deficit_hpa, rmax_km, holland_b, lat_deg, air_density_kgm3
        As in :func:`holland_gradient_wind_ms`.
    wind_ms : float
        Threshold 10 m wind [m/s]; 13.9 (Beaufort 7) by default, 17.2 for
        force 8, 24.5 for force 10.
    surface_factor : float
        10 m wind / gradient wind [-].

    Returns
    -------
    float
        The radius [km] (outside R_max, where the wind falls below the
        threshold for good); 0.0 when the cyclone never reaches ``wind_ms``.
    """
    from scipy.optimize import brentq

    thr = float(finite("wind_ms", wind_ms, minimum=0.0, strict=True, error=ConfigError))
    k = float(finite("surface_factor", surface_factor, minimum=0.0, strict=True, error=ConfigError))

    def excess(r: float) -> float:
        return (
            float(k * holland_gradient_wind_ms(r, pressure_deficit_hpa, rmax_km, holland_b, lat_deg, air_density_kgm3))
            - thr
        )

    r = np.geomspace(max(rmax_km, 1e-3) * 0.05, 5000.0, 4000)
    ex = k * holland_gradient_wind_ms(r, pressure_deficit_hpa, rmax_km, holland_b, lat_deg, air_density_kgm3) - thr
    above = np.flatnonzero(ex >= 0.0)
    if above.size == 0:
        return 0.0
    i = int(above[-1])
    if i == r.size - 1:
        raise ConfigError(
            f"the wind stays above {thr} m/s beyond 5000 km from the centre; check pressure_deficit_hpa="
            f"{pressure_deficit_hpa}, rmax_km={rmax_km}, holland_b={holland_b}"
        )
    return float(brentq(excess, r[i], r[i + 1], xtol=1e-6))


def track_attr(cyclone: Cyclone, start: np.datetime64, hours: Sequence[float]) -> str:
    """JSON of the cyclone and its track with the force-7 radius at each point, for ``attrs``."""
    st = cyclone.state(np.asarray(hours, dtype=float))
    points = []
    for k, h in enumerate(hours):
        r7 = cyclone_radius_km(
            float(st["dp_hpa"][k]),
            float(st["rmax_km"][k]),
            cyclone.holland_b,
            float(st["lat"][k]),
            BEAUFORT_7_MS,
            cyclone.surface_factor,
        )
        points.append(
            {
                "time": str((start + np.timedelta64(int(round(h * 3600)), "s")).astype("datetime64[s]")),
                "hours": float(h),
                "lat": float(st["lat"][k]),
                "lon": float(st["lon"][k]),
                "pressure_deficit_hpa": float(st["dp_hpa"][k]),
                "rmax_km": float(st["rmax_km"][k]),
                "r7_km": r7,
            }
        )
    return json.dumps({"cyclone": cyclone.to_dict(), "track": points})


def default_cyclone() -> Cyclone:
    """The typhoon-avoidance patent's test typhoon: from (20° N, 130° E) north-west at 10 kn, force-7 radius 280 km.

    The seed ([0141]) moves the typhoon "from (130° E, 20° N) north-west at
    10 kn" with a force-7 circle of 280 km radius, against a ship from
    (15° N, 115° E) to (25° N, 130° E) at 11–12 kn.  Intensity (not given
    there) is chosen to reproduce that radius with the Holland profile:
    Δp = 57 hPa, R_max = 45 km, B = 1.3 give R7 = 280 km at 20° N and a
    maximum 10 m wind of 39 m/s (a typhoon of about 953 hPa).
    """
    return Cyclone(
        track=straight_track(20.0, 130.0, 315.0, 10.0, duration_h=168.0, step_h=6.0),
        pressure_deficit_hpa=57.0,
        rmax_km=45.0,
        holland_b=1.3,
        name="typhoon-avoidance patent test typhoon",
    )


def tropical_cyclone(
    cyclone: Cyclone | None = None,
    *,
    start: Any = None,
    duration_h: float = 144.0,
    step_h: float = 3.0,
    resolution_deg: float = 0.25,
    bbox: Sequence[float] = (5.0, 35.0, 105.0, 145.0),
    background_hs_m: float = 1.5,
    background_from_deg: float = 45.0,
) -> xr.Dataset:
    """A tropical cyclone on a moving track over a background sea (the typhoon-avoidance patent).

    Wind: :func:`optroute.weather.cyclone.cyclone_wind` (Holland 1980 with
    inflow and translation asymmetry) plus the background wind weighted by
    the background's share of the wave energy (so it fades into the storm).  Waves: the
    cyclone's fetch-limited sea (:func:`optroute.weather.cyclone.cyclone_waves`)
    and the background sea added as energy; direction and period
    energy-weighted.  The track and the force-7 radius at every time step
    are stored in ``attrs["cyclone"]`` (JSON), read by :func:`cyclone_track`.

    Parameters
    ----------
    cyclone : Cyclone, optional
        Default :func:`default_cyclone`.
    start : datetime64 or str, optional
        t = 0 [UTC].
    duration_h, step_h, resolution_deg : float
        Span [h], spacing [h], grid spacing [deg].
    bbox : (lat_min, lat_max, lon_min, lon_max)
        Area [deg]; default the Philippine Sea, 5–35 N, 105–145 E.
    background_hs_m, background_from_deg : float
        Background sea [m] (fully developed, its wind from the same
        direction) and direction [deg true, from]: 1.5 m from the north-east
        (the autumn monsoon of the seed's October case).

    Returns
    -------
    xarray.Dataset
    """
    cyc = default_cyclone() if cyclone is None else cyclone
    t0 = as_start(start)
    time = time_axis(t0, duration_h, step_h)
    lat, lon = domain(bbox, resolution_deg)
    hs_bg = float(finite("background_hs_m", background_hs_m, minimum=0.0, strict=True, error=ConfigError))
    from_bg = float(units.wrap_360(background_from_deg))
    bg_u, bg_v = wind_uv_from(pm_wind_from_hs(hs_bg), from_bg)
    tp_bg = PM_TP_PER_SQRT_HS * math.sqrt(hs_bg)
    la, lo = np.meshgrid(lat, units.wrap_180(lon), indexing="ij")
    names = ("hs_m", "tp_s", "wave_from_deg", "wind_u_ms", "wind_v_ms")
    out = {k: np.empty((time.size, lat.size, lon.size)) for k in names}
    hours = hours_since(time, t0)
    for k, h in enumerate(hours):
        cu, cv = cyclone_wind(cyc, float(h), la, lo)
        speed, to_deg = units.uv_to_speed_to_deg(cu, cv)
        hs_c, tp_c = cyclone_waves(speed, cyc.fetch_km)
        from_c = units.from_to_flip_deg(to_deg)
        e_bg, e_c = hs_bg**2, hs_c**2
        e = e_bg + e_c
        sx = e_bg * math.sin(math.radians(from_bg)) + e_c * np.sin(np.radians(from_c))
        cx = e_bg * math.cos(math.radians(from_bg)) + e_c * np.cos(np.radians(from_c))
        out["hs_m"][k] = np.sqrt(e)
        out["tp_s"][k] = (e_bg * tp_bg + e_c * tp_c) / e
        out["wave_from_deg"][k] = units.wrap_360(np.degrees(np.arctan2(sx, cx)))
        out["wind_u_ms"][k] = cu + bg_u * e_bg / e
        out["wind_v_ms"][k] = cv + bg_v * e_bg / e
    params = grid_params(
        t0,
        duration_h,
        step_h,
        resolution_deg,
        bbox,
        background_hs_m=hs_bg,
        background_from_deg=from_bg,
    )
    attrs = scenario_attrs(
        "tropical_cyclone",
        params,
        lon,
        title=f"Tropical cyclone ({cyc.name}), Holland (1980) wind",
        cyclone=track_attr(cyc, t0, hours.tolist()),
    )
    return schema.canonical_dataset(time, lat, lon, out, attrs)


def cyclone_track(source: xr.Dataset | str) -> dict[str, np.ndarray]:
    """The cyclone track of a :func:`tropical_cyclone` dataset, one entry per time step.

    Parameters
    ----------
    source : xarray.Dataset or str
        The dataset (also after a NetCDF round trip) or its ``attrs["cyclone"]``.

    Returns
    -------
    dict of ndarray
        ``time`` [datetime64, UTC], ``lat``, ``lon`` [deg], ``pressure_deficit_hpa``,
        ``rmax_km``, ``r7_km`` (radius of Beaufort-7 winds, the typhoon-avoidance patent's circle R;
        its safe distance is R + 30 km).
    """
    text = source if isinstance(source, str) else source.attrs.get("cyclone")
    if text is None:
        raise ConfigError("the dataset has no attrs['cyclone']; build it with optroute.scenarios.tropical_cyclone")
    try:
        pts = json.loads(text)["track"]
    except (TypeError, ValueError, KeyError) as exc:
        raise ConfigError(f"attrs['cyclone'] is not the JSON written by tropical_cyclone: {str(text)[:200]!r}") from exc
    out = {"time": np.array([p["time"] for p in pts], dtype="datetime64[ns]")}
    for key in ("lat", "lon", "pressure_deficit_hpa", "rmax_km", "r7_km"):
        out[key] = np.array([p[key] for p in pts], dtype=float)
    return out


def cyclone_exclusion(source: xr.Dataset | str, time: Any, margin_km: float = 30.0) -> tuple[float, float, float]:
    """Centre and radius of the typhoon-avoidance patent's circle (force-7 radius R + margin) at a time.

    Parameters
    ----------
    source : xarray.Dataset or str
        A :func:`tropical_cyclone` dataset or its ``attrs["cyclone"]``.
    time : datetime64 or str
        UTC time, within the track (linear interpolation between steps).
    margin_km : float
        Safety margin added to R [km]; the typhoon-avoidance patent settles on 30 km.

    Returns
    -------
    lat, lon, radius_km : float
    """
    tr = cyclone_track(source)
    t = np.datetime64(time, "ns")
    x = (tr["time"] - tr["time"][0]) / np.timedelta64(1, "s")
    q = float((t - tr["time"][0]) / np.timedelta64(1, "s"))
    if not x[0] <= q <= x[-1]:
        raise ConfigError(
            f"time {units.format_utc(t)} is outside the cyclone track ({units.format_utc(tr['time'][0])} to "
            f"{units.format_utc(tr['time'][-1])})"
        )
    lon = geo.unwrap_lon_deg(tr["lon"])
    return (
        float(np.interp(q, x, tr["lat"])),
        float(units.wrap_180(np.interp(q, x, lon))),
        float(np.interp(q, x, tr["r7_km"])) + float(margin_km),
    )


def cyclone_from_dict(d: dict[str, Any]) -> Cyclone:
    d = dict(d)
    d["track"] = tuple(tuple(p) for p in d["track"])
    for k in ("pressure_deficit_hpa", "rmax_km"):
        if isinstance(d[k], list):
            d[k] = tuple(d[k])
    return Cyclone(**d)
