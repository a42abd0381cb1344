"""Shared pieces of the synthetic weather scenarios: grids, times, attributes, wind from waves.

Relations:

* fully developed sea (Pierson & Moskowitz 1964): H_s = 0.21 U_19.5² / g,
  with U_19.5 = 1.083 U_10 (power-law wind profile, exponent 0.12 over open
  sea, DNV-RP-C205), so U_10 = sqrt(g H_s / 0.21) / 1.083 (:func:`pm_wind_from_hs`);
* T_p = 5.0 sqrt(H_s) for a fully developed sea (DNV-RP-C205);
* T_p = 3.85 sqrt(H_s) for a young storm sea, inside the range
  3.6 <= T_p / sqrt(H_s) <= 5 for which DNV-RP-C205 recommends
  the JONSWAP spectrum (its peak-shape guidance).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.weather import schema

DEFAULT_START = np.datetime64("2024-01-10T00:00:00", "ns")
"""Time of the first slice of every scenario unless ``start`` is given [UTC]."""

G = 9.80665
U195_OVER_U10 = 1.083
STORM_TP_PER_SQRT_HS = 3.85
PM_TP_PER_SQRT_HS = 5.0

SAN_DIEGO = (32.71, -117.17)
"""Boeing EP 2145155's departure port (lat, lon) [deg]; on land: snap it with :func:`optroute.geo.land.snap_to_sea`."""
TOKYO = (35.65, 139.77)
"""Boeing EP 2145155's arrival port (lat, lon) [deg]."""


def pm_wind_from_hs(hs_m: ArrayLike) -> np.ndarray:
    """10 m wind speed [m/s] of a fully developed sea of height H_s [m] (Pierson–Moskowitz).

    U_10 = sqrt(g H_s / 0.21) / 1.083: e.g. 2.0 m → 8.9 m/s (Beaufort 5),
    3.0 m → 10.9 m/s (6), as the Met Office probable heights of physics.md §5.
    """
    hs = np.asarray(hs_m, dtype=float)
    return np.sqrt(G * np.maximum(hs, 0.0) / 0.21) / U195_OVER_U10


def as_start(start: Any) -> np.datetime64:
    try:
        t = np.datetime64(start, "ns") if start is not None else DEFAULT_START
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"start={start!r} is not a UTC time; pass e.g. '2024-01-10T00:00'") from exc
    if np.isnat(t):
        raise ConfigError("start is NaT; pass a UTC time such as '2024-01-10T00:00'")
    return t


def time_axis(start: Any, duration_h: float, step_h: float) -> np.ndarray:
    dur = float(finite("duration_h", duration_h, minimum=0.0, error=ConfigError))
    step = float(finite("step_h", step_h, minimum=0.0, strict=True, error=ConfigError))
    n = int(math.ceil(dur / step - 1e-9)) + 1
    hours = np.arange(n) * step
    return as_start(start) + (hours * 3.6e12).astype("timedelta64[ns]")


def hours_since(times: np.ndarray, start: np.datetime64) -> np.ndarray:
    return (np.asarray(times, dtype="datetime64[ns]") - start) / np.timedelta64(1, "h")


def domain(bbox: Sequence[float], resolution_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid of a (lat_min, lat_max, lon_min, lon_max) box [deg].

    ``lon_max < lon_min`` means the box crosses the antimeridian (lon is then
    unwrapped past 180); ``lon_max - lon_min == 360`` gives a global,
    periodic grid from -180.
    """
    if len(bbox) != 4:
        raise ConfigError(f"bbox={bbox!r} must be (lat_min, lat_max, lon_min, lon_max) [deg]")
    lat_min, lat_max, lon_min, lon_max = (float(v) for v in finite("bbox", bbox, error=ConfigError))
    res = float(finite("resolution_deg", resolution_deg, minimum=0.0, strict=True, error=ConfigError))
    if not -90.0 <= lat_min < lat_max <= 90.0:
        raise ConfigError(f"bbox latitudes {lat_min}..{lat_max} must satisfy -90 <= lat_min < lat_max <= 90")
    nlat = int(math.ceil((lat_max - lat_min) / res - 1e-9)) + 1
    lat = lat_min + res * np.arange(nlat)
    if lat[-1] > 90.0 + 1e-9:
        raise ConfigError(
            f"resolution_deg={res} does not divide the latitude span {lat_min}..{lat_max} without passing 90"
        )
    span = lon_max - lon_min
    if abs(abs(span) - 360.0) < 1e-9:
        nlon = int(round(360.0 / res))
        if abs(nlon * res - 360.0) > 1e-6:
            raise ConfigError(f"a global grid needs a resolution that divides 360 deg, got {res}")
        return lat, -180.0 + res * np.arange(nlon)
    lon0 = float(units.wrap_180(lon_min))
    span = float(np.mod(lon_max - lon_min, 360.0))
    if span == 0.0:
        raise ConfigError(f"bbox longitudes {lon_min}..{lon_max} give an empty span")
    nlon = int(math.ceil(span / res - 1e-9)) + 1
    return lat, lon0 + res * np.arange(nlon)


def grid_params(
    start: Any, duration_h: float, step_h: float, resolution_deg: float, bbox: Sequence[float], **specific: Any
) -> dict[str, Any]:
    """The parameters every synthetic scenario records: its grid and time axis, plus its own (``specific``)."""
    return {
        "start": str(start),
        "duration_h": duration_h,
        "step_h": step_h,
        "resolution_deg": resolution_deg,
        "bbox": list(bbox),
        **specific,
    }


def scenario_attrs(name: str, params: dict[str, Any], lon: np.ndarray, **extra: Any) -> dict[str, Any]:
    attrs = {
        "title": f"optroute synthetic scenario: {name}",
        "source": f"optroute.scenarios.{name}",
        "scenario": name,
        "scenario_parameters": json.dumps(params, default=str, sort_keys=True),
        schema.LON_CONVENTION_ATTR: schema.lon_convention(lon),
    }
    attrs.update(extra)
    return attrs


def wind_uv_from(speed_ms: ArrayLike, from_deg: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    return units.speed_to_deg_to_uv(speed_ms, units.from_to_flip_deg(from_deg))
