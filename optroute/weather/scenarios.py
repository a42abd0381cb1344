"""Built-in synthetic weather: calm, uniform, the seed documents' situations, cyclones, ensembles.

Every function returns a canonical :mod:`optroute.weather.schema` dataset
(``hs_m``, ``tp_s``, ``wave_from_deg``, ``wind_u_ms``, ``wind_v_ms``, and
``current_u_ms``/``current_v_ms`` where a current is asked for; coords
``time``, ``lat``, ``lon``) that writes with ``to_netcdf`` and reads back
through :func:`optroute.open_weather`.  Scenarios are pure functions of
their arguments; the random ones (:func:`ensemble`) draw from
``numpy.random.default_rng(seed)``, so the same seed gives the same
members, bit for bit.

Conventions (``shared/design.md``): wave and wind directions are where
they come **from** [deg true]; (u, v) components are the vector the wind
blows or the current flows **to** [m/s].  A domain across the antimeridian
keeps ``lon`` increasing past 180 (115 … 250 for 115 E – 110 W, values
>= 180 being western longitudes + 360), the convention of
:func:`optroute.weather.schema.normalise_lon`, recorded in
``attrs["lon_convention"]``.

No-go areas.  :func:`shao_case` marks its islands and its bad-weather
rectangle in two ways: the grid points inside a rectangle (edges included)
have NaN ``hs_m``, ``tp_s`` and ``wave_from_deg`` — "no passage" to the
sampler and to :func:`optroute.geo.land.navigable` — and the exact, moving
rectangles are stored as JSON in ``attrs["no_go_areas"]``, read back by
:func:`no_go_areas` (or :func:`shao_no_go` without a dataset).  Because the
sampler blocks the whole interpolation cell around a NaN point and both
bracketing time slices, the gridded no-go region is the exact one grown by
up to one grid step and one time step: conservative.  Such a dataset also
sets ``attrs["geography"] = "synthetic"``: its rectangles, not the real
coastline, are the land (the seed's route from (0°, 0°) to (0°, 90° E)
would otherwise cross Africa).

Modules: this one (calm, uniform, Shao et al.'s case studies, no-go areas,
ensembles); :mod:`optroute.weather.storms` (extratropical storms, Boeing EP 2145155);
:mod:`optroute.weather.cyclone` (tropical cyclones, the typhoon-avoidance patent);
:mod:`optroute.weather._synth` (grids, times and the wind–wave relations:
fully developed H_s = 0.21 U_19.5² / g with U_19.5 = 1.083 U_10, T_p =
5.0 sqrt(H_s); storm seas T_p = 3.85 sqrt(H_s)).

Public API
----------
:func:`calm`, :func:`uniform`, :func:`shao_case`, :func:`shao_no_go`,
:func:`no_go_areas`, :func:`in_no_go_area`, :func:`north_pacific_storms` (+ :class:`Storm`,
:func:`north_pacific_storm_specs`, :func:`storm_dataset`), :func:`moving_storm`,
:func:`tropical_cyclone` (+
:class:`Cyclone`, :func:`default_cyclone`, :func:`cyclone_track`,
:func:`cyclone_exclusion`, :func:`cyclone_radius_km`, :func:`straight_track`),
:func:`ensemble`, :func:`member`; forecasts that err like real ones (:mod:`optroute.weather.forecast`):
:func:`storm_forecast`, :func:`displaced_storms`, :func:`converging_forecasts`, with
:func:`moving_storm_spec`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.weather import schema
from optroute.weather._synth import (
    DEFAULT_START,
    PM_TP_PER_SQRT_HS,
    SAN_DIEGO,
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
from optroute.weather.cyclone import (
    Cyclone,
    cyclone_exclusion,
    cyclone_from_dict,
    cyclone_radius_km,
    cyclone_track,
    default_cyclone,
    straight_track,
    track_attr,
    tropical_cyclone,
)
from optroute.weather.forecast import converging_forecasts, displaced_storms, storm_forecast
from optroute.weather.storms import (
    Storm,
    moving_storm,
    moving_storm_spec,
    north_pacific_storm_specs,
    north_pacific_storms,
    storm_dataset,
)

__all__ = [
    "DEFAULT_START",
    "SAN_DIEGO",
    "SHAO_BACKGROUND",
    "SHAO_START_END",
    "TOKYO",
    "Cyclone",
    "NoGoArea",
    "Storm",
    "calm",
    "converging_forecasts",
    "cyclone_exclusion",
    "cyclone_radius_km",
    "cyclone_track",
    "default_cyclone",
    "displaced_storms",
    "ensemble",
    "member",
    "moving_storm",
    "moving_storm_spec",
    "in_no_go_area",
    "no_go_areas",
    "north_pacific_storm_specs",
    "north_pacific_storms",
    "pm_wind_from_hs",
    "shao_case",
    "shao_no_go",
    "storm_dataset",
    "storm_forecast",
    "straight_track",
    "tropical_cyclone",
    "uniform",
]


# --------------------------------------------------------------------------- calm, uniform


def calm(
    bbox: Sequence[float] = (-80.0, 80.0, -180.0, 180.0),
    *,
    start: Any = None,
    duration_h: float = 720.0,
    step_h: float = 6.0,
    resolution_deg: float = 5.0,
) -> xr.Dataset:
    """No wind, no waves, no current.

    ``hs_m`` is 0 and ``tp_s`` a placeholder 1 s (with no waves no band
    applies and the period does not matter; it stays positive so that
    period-based formulas remain finite).

    Parameters
    ----------
    bbox : (lat_min, lat_max, lon_min, lon_max)
        Area [deg]; the default is global (periodic in lon) between 80 S and 80 N.
    start : datetime64 or str, optional
        First time [UTC]; default :data:`DEFAULT_START`.
    duration_h, step_h : float
        Time span and spacing [h].
    resolution_deg : float
        Grid spacing [deg] (the fields are constant, so a coarse grid suffices).

    Returns
    -------
    xarray.Dataset
    """
    ds = uniform(
        hs_m=0.0,
        tp_s=1.0,
        wave_from_deg=0.0,
        wind_speed_ms=0.0,
        bbox=bbox,
        start=start,
        duration_h=duration_h,
        step_h=step_h,
        resolution_deg=resolution_deg,
    )
    ds.attrs.update(title="optroute synthetic scenario: calm", source="optroute.scenarios.calm", scenario="calm")
    return ds


def uniform(
    hs_m: float = 2.0,
    tp_s: float | None = None,
    wave_from_deg: float = 0.0,
    wind_speed_ms: float | None = None,
    wind_from_deg: float | None = None,
    current_speed_ms: float = 0.0,
    current_to_deg: float = 0.0,
    *,
    bbox: Sequence[float] = (-80.0, 80.0, -180.0, 180.0),
    start: Any = None,
    duration_h: float = 720.0,
    step_h: float = 6.0,
    resolution_deg: float = 5.0,
) -> xr.Dataset:
    """The same sea state, wind and current everywhere and always.

    Parameters
    ----------
    hs_m : float
        Significant wave height [m], >= 0.
    tp_s : float, optional
        Peak period [s]; default the fully developed 5.0 sqrt(H_s) (DNV-RP-C205).
    wave_from_deg : float
        Direction the waves come from [deg true].
    wind_speed_ms : float, optional
        10 m wind speed [m/s]; default the fully developed sea's wind
        :func:`pm_wind_from_hs` (so Beaufort from wind and from H_s agree).
    wind_from_deg : float, optional
        Direction the wind comes from [deg true]; default ``wave_from_deg``.
    current_speed_ms : float
        Surface current speed [m/s]; 0 leaves the current variables out
        (missing means zero).
    current_to_deg : float
        Direction the current flows to [deg true].
    bbox, start, duration_h, step_h, resolution_deg
        As in :func:`calm`.

    Returns
    -------
    xarray.Dataset
    """
    hs = float(finite("hs_m", hs_m, minimum=0.0, error=ConfigError))
    tp = (
        PM_TP_PER_SQRT_HS * math.sqrt(hs)
        if tp_s is None
        else float(finite("tp_s", tp_s, minimum=0.0, strict=True, error=ConfigError))
    )
    if tp <= 0.0:
        raise ConfigError(f"hs_m={hs} with tp_s=None gives a zero period; pass tp_s > 0")
    wdir = float(units.wrap_360(finite("wave_from_deg", wave_from_deg, error=ConfigError)))
    wspd = (
        float(pm_wind_from_hs(hs))
        if wind_speed_ms is None
        else float(finite("wind_speed_ms", wind_speed_ms, minimum=0.0, error=ConfigError))
    )
    wfrom = wdir if wind_from_deg is None else float(finite("wind_from_deg", wind_from_deg, error=ConfigError))
    cspd = float(finite("current_speed_ms", current_speed_ms, minimum=0.0, error=ConfigError))
    cto = float(finite("current_to_deg", current_to_deg, error=ConfigError))
    time = time_axis(start, duration_h, step_h)
    lat, lon = domain(bbox, resolution_deg)
    wu, wv = wind_uv_from(wspd, wfrom)
    variables: dict[str, Any] = {"hs_m": hs, "tp_s": tp, "wave_from_deg": wdir, "wind_u_ms": wu, "wind_v_ms": wv}
    if cspd > 0.0:
        cu, cv = units.speed_to_deg_to_uv(cspd, cto)
        variables["current_u_ms"], variables["current_v_ms"] = cu, cv
    params = grid_params(
        time[0],
        duration_h,
        step_h,
        resolution_deg,
        bbox,
        hs_m=hs,
        tp_s=tp,
        wave_from_deg=wdir,
        wind_speed_ms=wspd,
        wind_from_deg=wfrom,
        current_speed_ms=cspd,
        current_to_deg=cto,
    )
    return schema.canonical_dataset(time, lat, lon, variables, scenario_attrs("uniform", params, lon))


# --------------------------------------------------------------------------- no-go areas


@dataclass(frozen=True)
class NoGoArea:
    """A rectangle in (lat, lon) the ship may not enter, possibly moving.

    At ``hours`` after ``start`` the rectangle is the one given, shifted by
    ``velocity_*`` × max(0, hours − ``hold_h``) (it stays put for the first
    ``hold_h`` hours, and before ``start``).

    Attributes
    ----------
    name, kind : str
        E.g. ``"islands"``/``"islands"`` or ``"bad weather"``/``"weather"``.
    lat_min, lat_max, lon_min, lon_max : float
        Edges at ``start`` [deg], inclusive; lon as in the dataset.
    start : str
        ISO time [UTC] of the given position.
    hold_h : float
        Hours before the area starts to move.
    velocity_lat_deg_h, velocity_lon_deg_h : float
        Motion [deg/h] (3 kn due south = −0.05 deg/h of latitude).
    """

    name: str
    kind: str
    lat_min: float
    lat_max: float
    lon_min: float
    lon_max: float
    start: str
    hold_h: float = 0.0
    velocity_lat_deg_h: float = 0.0
    velocity_lon_deg_h: float = 0.0

    def at(self, time: Any) -> NoGoArea:
        """The rectangle at a time: hours after ``start`` (float) or a datetime64 [UTC]."""
        h = _as_hours(time, np.datetime64(self.start, "ns"))
        dt = max(0.0, h - self.hold_h)
        dlat, dlon = self.velocity_lat_deg_h * dt, self.velocity_lon_deg_h * dt
        return replace(
            self,
            lat_min=self.lat_min + dlat,
            lat_max=self.lat_max + dlat,
            lon_min=self.lon_min + dlon,
            lon_max=self.lon_max + dlon,
            hold_h=0.0,
            start=str(np.datetime64(self.start, "ns") + np.timedelta64(int(round(h * 3.6e12)), "ns")),
        )

    def contains(self, lat_deg: ArrayLike, lon_deg: ArrayLike, tol_deg: float = 1e-9) -> np.ndarray:
        """Whether points lie in the rectangle as given (call :meth:`at` first for a time); edges count."""
        lat = np.asarray(lat_deg, dtype=float)
        lon = self.lon_min + np.mod(np.asarray(lon_deg, dtype=float) - self.lon_min + tol_deg, 360.0) - tol_deg
        return (lat >= self.lat_min - tol_deg) & (lat <= self.lat_max + tol_deg) & (lon <= self.lon_max + tol_deg)

    def contains_at(self, lat_deg: ArrayLike, lon_deg: ArrayLike, time: Any, tol_deg: float = 1e-9) -> np.ndarray:
        """Whether points lie in the moving rectangle at their own times (vectorised over time too).

        Parameters
        ----------
        lat_deg, lon_deg : array_like
            Positions [deg].
        time : array_like
            UTC times (datetime64) or hours after ``start``, broadcast against the positions.
        """
        t = np.asarray(time)
        if np.issubdtype(t.dtype, np.datetime64) or t.dtype.kind in "US":
            h = (t.astype("datetime64[ns]") - np.datetime64(self.start, "ns")) / np.timedelta64(1, "h")
        else:
            h = finite("time (hours after the start)", t, error=ConfigError)
        dt = np.maximum(0.0, h - self.hold_h)
        lat = np.asarray(lat_deg, dtype=float) - self.velocity_lat_deg_h * dt
        lon = np.asarray(lon_deg, dtype=float) - self.velocity_lon_deg_h * dt
        return self.contains(lat, lon, tol_deg)

    def corners(self) -> tuple[tuple[float, float], ...]:
        """(lat, lon) of the SW, SE, NE, NW corners [deg]."""
        return (
            (self.lat_min, self.lon_min),
            (self.lat_min, self.lon_max),
            (self.lat_max, self.lon_max),
            (self.lat_max, self.lon_min),
        )


def _as_hours(time: Any, start: np.datetime64) -> float:
    arr = np.asarray(time)
    if np.issubdtype(arr.dtype, np.datetime64) or isinstance(time, str):
        return float((np.datetime64(time, "ns") - start) / np.timedelta64(1, "h"))
    return float(finite("time (hours after the start)", time, error=ConfigError))


def no_go_areas(source: xr.Dataset | str, time: Any) -> list[NoGoArea]:
    """The no-go rectangles of a scenario dataset at a time.

    Parameters
    ----------
    source : xarray.Dataset or str
        A dataset with ``attrs["no_go_areas"]`` (e.g. :func:`shao_case`, also
        after a NetCDF round trip) or that JSON string itself.
    time : datetime64, str or float
        A UTC time, or hours after each area's ``start``.

    Returns
    -------
    list of NoGoArea
        The rectangles at that time (empty when the dataset has none).
    """
    return [a.at(time) for a in _stored_areas(source)]


def _stored_areas(source: xr.Dataset | str) -> list[NoGoArea]:
    """The no-go areas as stored (at their start, with their hold and velocity)."""
    text = source if isinstance(source, str) else source.attrs.get("no_go_areas", "[]")
    try:
        return [NoGoArea(**item) for item in json.loads(text)]
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"attrs['no_go_areas'] is not a JSON list of rectangles: {str(text)[:200]!r}") from exc


def in_no_go_area(source: xr.Dataset | str, lat_deg: ArrayLike, lon_deg: ArrayLike, time: Any) -> np.ndarray:
    """Whether points at their times lie in any no-go rectangle of a scenario (exact geometry).

    Parameters
    ----------
    source : xarray.Dataset or str
        A dataset with ``attrs["no_go_areas"]`` or that JSON.
    lat_deg, lon_deg : array_like
        Positions [deg].
    time : array_like
        UTC times (datetime64) or hours after the areas' start, broadcast
        against the positions.

    Returns
    -------
    ndarray of bool
    """
    areas = _stored_areas(source)
    lat, lon, t = np.broadcast_arrays(
        np.asarray(lat_deg, dtype=float), np.asarray(lon_deg, dtype=float), np.asarray(time)
    )
    out = np.zeros(lat.shape, dtype=bool)
    for area in areas:
        out |= area.contains_at(lat, lon, t)
    return out


SHAO_BACKGROUND = {"hs_m": 2.0, "wave_from_deg": 90.0}
"""Background sea of :func:`shao_case` (the paper gives none): a moderate, Beaufort 5 sea from the east.

H_s 2.0 m (the Met Office probable height of force 5), T_p = 5.0 sqrt(H_s) = 7.07 s
(fully developed), wind 8.9 m/s (:func:`pm_wind_from_hs`) from 090° like the
waves: head seas for the eastbound ship of the case studies.
"""

_SHAO_ISLANDS = {
    "name": "islands",
    "kind": "islands",
    "lat_min": -1.0,
    "lat_max": 7.0,
    "lon_min": 50.0,
    "lon_max": 70.0,
}
_SHAO_WEATHER = {
    1: {"lat_min": -9.0, "lat_max": -1.0, "hold_h": 60.0, "course": "south"},
    2: {"lat_min": -15.0, "lat_max": -7.0, "hold_h": 0.0, "course": "north"},
}
SHAO_WEATHER_SPEED_KN = 3.0
SHAO_START_END = ((0.0, 0.0), (0.0, 90.0))
"""Start and end of the case studies (lat, lon) [deg]: grid (0, 0) and (90, 0) in (lon, lat) on the equator."""


def _shao_areas(case: int, start: np.datetime64) -> list[NoGoArea]:
    if case not in _SHAO_WEATHER:
        raise ConfigError(f"shao_case({case!r}): Shao et al. have case 1 and case 2; pass 1 or 2")
    w = _SHAO_WEATHER[case]
    v = SHAO_WEATHER_SPEED_KN / 60.0 * (-1.0 if w["course"] == "south" else 1.0)  # 1 deg lat = 60 nm
    s = str(start)
    return [
        NoGoArea(start=s, **_SHAO_ISLANDS),
        NoGoArea(
            name="bad weather",
            kind="weather",
            lat_min=w["lat_min"],
            lat_max=w["lat_max"],
            lon_min=50.0,
            lon_max=70.0,
            start=s,
            hold_h=w["hold_h"],
            velocity_lat_deg_h=v,
        ),
    ]


def shao_no_go(case: int, time: Any, start: Any = None) -> list[NoGoArea]:
    """Shao et al.'s no-go rectangles (islands, bad weather) of a case at a time.

    Case 1: islands lon 50–70°, lat −1 to 7° (fixed); bad weather lon 50–70°,
    lat −9 to −1° at t = 0, fixed for 60 h, then moving south at 3 kn
    (0.05° of latitude per hour).  Case 2: the same islands; bad weather
    lon 50–70°, lat −15 to −7° at t = 0, moving north at 3 kn from the start.

    Parameters
    ----------
    case : {1, 2}
    time : float or datetime64
        Hours after ``start``, or a UTC time.
    start : datetime64, optional
        t = 0 [UTC]; default :data:`DEFAULT_START`.

    Returns
    -------
    list of NoGoArea
        ``[islands, bad weather]`` at that time.
    """
    t0 = as_start(start)
    return [a.at(time) for a in _shao_areas(case, t0)]


def shao_case(
    case: int,
    *,
    start: Any = None,
    duration_h: float = 360.0,
    step_h: float = 6.0,
    resolution_deg: float = 0.25,
    bbox: Sequence[float] = (-20.0, 20.0, -5.0, 95.0),
    background_hs_m: float = SHAO_BACKGROUND["hs_m"],
    background_from_deg: float = SHAO_BACKGROUND["wave_from_deg"],
) -> xr.Dataset:
    """Shao et al.'s (3-D DP) case study I or II: islands and a moving bad-weather rectangle.

    The voyage runs from (0°, 0°) to (0°, 90° E) on the equator
    (:data:`SHAO_START_END`); the islands and the bad weather are no-go
    areas (see :func:`shao_no_go` for their geometry and timing).  Outside
    them the sea is :data:`SHAO_BACKGROUND`.  The seed's sea lies where
    Africa is, so the dataset declares ``attrs["geography"] = "synthetic"``.

    Parameters
    ----------
    case : {1, 2}
    start : datetime64 or str, optional
        t = 0 [UTC]; default :data:`DEFAULT_START`.
    duration_h : float
        Time span [h]; 360 h covers the seed's arrival times (233–272 h and beyond).
    step_h : float
        Time step [h]; the rectangle moves 0.05° per hour, so the gridded
        no-go area is conservative by ``0.05 * step_h`` degrees in time.
    resolution_deg : float
        Grid spacing [deg]; 0.25 puts grid lines on the integer rectangle edges.
    bbox : (lat_min, lat_max, lon_min, lon_max)
        Area [deg].
    background_hs_m, background_from_deg : float
        Background sea [m] and its direction [deg true, from].

    Returns
    -------
    xarray.Dataset
        With NaN wave variables inside the rectangles, ``attrs["no_go_areas"]``
        (JSON; :func:`no_go_areas`), ``attrs["geography"] = "synthetic"``,
        ``attrs["start_lat_lon"]`` and ``attrs["end_lat_lon"]``.
    """
    t0 = as_start(start)
    areas = _shao_areas(case, t0)
    time = time_axis(t0, duration_h, step_h)
    lat, lon = domain(bbox, resolution_deg)
    hs_bg = float(finite("background_hs_m", background_hs_m, minimum=0.0, strict=True, error=ConfigError))
    wdir = float(units.wrap_360(background_from_deg))
    hours = hours_since(time, t0)
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    blocked = np.zeros((time.size, lat.size, lon.size), dtype=bool)
    for k, h in enumerate(hours):
        for area in areas:
            blocked[k] |= area.at(float(h)).contains(la, lo)
    nan = np.where(blocked, np.nan, 1.0)
    wu, wv = wind_uv_from(pm_wind_from_hs(hs_bg), wdir)
    variables = {
        "hs_m": hs_bg * nan,
        "tp_s": PM_TP_PER_SQRT_HS * math.sqrt(hs_bg) * nan,
        "wave_from_deg": wdir * nan,
        "wind_u_ms": wu,
        "wind_v_ms": wv,
    }
    params = grid_params(
        t0,
        duration_h,
        step_h,
        resolution_deg,
        bbox,
        case=case,
        background_hs_m=hs_bg,
        background_from_deg=wdir,
    )
    attrs = scenario_attrs(
        "shao_case",
        params,
        lon,
        title=f"Shao et al. (3-D DP) case study {'I' * case}: islands and moving bad weather",
        no_go_areas=json.dumps([asdict(a) for a in areas]),
        geography="synthetic",
        start_lat_lon=json.dumps(SHAO_START_END[0]),
        end_lat_lon=json.dumps(SHAO_START_END[1]),
    )
    return schema.canonical_dataset(time, lat, lon, variables, attrs)


# --------------------------------------------------------------------------- ensembles


def ensemble(
    scenario: str | Callable[..., xr.Dataset],
    n: int,
    seed: int = 0,
    *,
    position_sigma_nm: float = 60.0,
    timing_sigma_h: float = 6.0,
    intensity_sigma: float = 0.1,
    include_control: bool = True,
    stack: bool = True,
    **kwargs: Any,
) -> xr.Dataset | list[xr.Dataset]:
    """N members of a storm scenario with perturbed tracks, timing and intensities.

    Each member moves every storm's whole track by an offset drawn from
    N(0, ``position_sigma_nm``) east and north, shifts its times (track and
    life cycle) by N(0, ``timing_sigma_h``), and scales its intensity (a
    :class:`Storm`'s peak H_s, a :class:`~optroute.weather.cyclone.Cyclone`'s
    pressure deficit) by exp(N(0, ``intensity_sigma``)), a log-normal factor
    with median 1.  Draws come from ``numpy.random.default_rng(seed)`` in a
    fixed order, so a seed gives the same members every time.

    Parameters
    ----------
    scenario : {"north_pacific_storms", "tropical_cyclone"} or callable
        A name, or a function taking ``storms=`` (a list of :class:`Storm`)
        or ``cyclone=`` (a :class:`Cyclone`) and returning a dataset.
    n : int
        Number of members, >= 1.
    seed : int
        Random seed.
    position_sigma_nm, timing_sigma_h, intensity_sigma : float
        Standard deviations [nm], [h], [-, of the log of the factor].
    include_control : bool
        Member 0 is the unperturbed scenario.
    stack : bool
        True: one dataset with a leading ``member`` dimension (variables on
        (member, time, lat, lon); select one with ``ds.isel(member=k)`` or
        :func:`member`); False: a list of canonical datasets.
    **kwargs
        Passed to the scenario (``storms``/``cyclone`` give the unperturbed specs).

    Returns
    -------
    xarray.Dataset or list of xarray.Dataset
        ``attrs["ensemble"]`` (JSON) holds the seed, the sigmas and every
        member's perturbations and perturbed specifications.
    """
    import inspect

    fn: Callable[..., xr.Dataset]
    if isinstance(scenario, str):
        table = {"north_pacific_storms": north_pacific_storms, "tropical_cyclone": tropical_cyclone}
        if scenario not in table:
            raise ConfigError(f"ensemble: unknown scenario {scenario!r}; use one of {sorted(table)} or a callable")
        fn = table[scenario]
    else:
        fn = scenario
    params = inspect.signature(fn).parameters
    if n < 1:
        raise ConfigError(f"ensemble: n={n} members; pass n >= 1")
    for name in ("position_sigma_nm", "timing_sigma_h", "intensity_sigma"):
        finite(name, locals()[name], minimum=0.0, error=ConfigError)
    rng = np.random.default_rng(seed)
    if "storms" in params:
        key = "storms"
        base: list[Any] = list(kwargs.pop("storms", None) or north_pacific_storm_specs())
    elif "cyclone" in params:
        key = "cyclone"
        base = [kwargs.pop("cyclone", None) or default_cyclone()]
    else:
        raise ConfigError(
            f"ensemble: {getattr(fn, '__name__', fn)!r} takes neither storms= nor cyclone=; nothing to perturb"
        )

    members, info = [], []
    for m in range(n):
        specs, perts = [], []
        for spec in base:
            z = rng.standard_normal(4)
            control = include_control and m == 0
            if control:
                z = np.zeros(4)
            lat_ref = float(np.mean([p[1] for p in spec.track]))
            dlat = z[0] * position_sigma_nm / 60.0
            dlon = z[1] * position_sigma_nm / (60.0 * max(math.cos(math.radians(lat_ref)), 0.05))
            dt = z[2] * timing_sigma_h
            fac = math.exp(z[3] * intensity_sigma)
            new = (spec.shifted if isinstance(spec, Storm) else spec.perturbed)(
                dlat_deg=dlat, dlon_deg=dlon, dt_h=dt, intensity_factor=fac
            )
            specs.append(new)
            perts.append({"name": spec.name, "dlat_deg": dlat, "dlon_deg": dlon, "dt_h": dt, "intensity_factor": fac})
        arg = specs if key == "storms" else specs[0]
        ds = fn(**{key: arg}, **kwargs)
        ds.attrs["ensemble_member"] = m
        members.append(ds)
        spec_json = [asdict(s) for s in specs] if key == "storms" else specs[0].to_dict()
        info.append({"member": m, "control": bool(include_control and m == 0), "perturbations": perts, key: spec_json})
    meta = json.dumps(
        {
            "scenario": getattr(fn, "__name__", str(fn)),
            "n": n,
            "seed": seed,
            "position_sigma_nm": position_sigma_nm,
            "timing_sigma_h": timing_sigma_h,
            "intensity_sigma": intensity_sigma,
            "include_control": include_control,
            "members": info,
        }
    )
    if not stack:
        for ds in members:
            ds.attrs["ensemble"] = meta
        return members
    attrs = dict(members[0].attrs)
    attrs.pop("ensemble_member", None)
    for k in ("storms", "cyclone"):
        attrs.pop(k, None)
    attrs["ensemble"] = meta
    out = xr.concat(members, dim=xr.DataArray(np.arange(n), dims="member", name="member"), combine_attrs="drop")
    out.attrs = attrs
    return out


def member(ds: xr.Dataset, k: int) -> xr.Dataset:
    """Member ``k`` of a stacked :func:`ensemble` as a canonical dataset, its own storm attrs restored."""
    if "member" not in ds.dims:
        raise ConfigError("member(): the dataset has no 'member' dimension; it is not a stacked ensemble")
    one = ds.isel(member=k).drop_vars("member")
    meta = json.loads(ds.attrs["ensemble"])
    entry = meta["members"][k]
    one.attrs = {key: v for key, v in ds.attrs.items() if key != "ensemble"}
    one.attrs["ensemble_member"] = k
    if "storms" in entry:
        one.attrs["storms"] = json.dumps(entry["storms"])
    if "cyclone" in entry:
        cyc = cyclone_from_dict(entry["cyclone"])
        t0 = np.datetime64(json.loads(ds.attrs["scenario_parameters"])["start"], "ns")
        one.attrs["cyclone"] = track_attr(cyc, t0, hours_since(one["time"].values, t0).tolist())
    return one
