"""The canonical weather dataset that everything downstream of the loaders sees.

Coordinates ``time`` (timezone-naive UTC ``datetime64[ns]``, strictly
increasing), ``lat`` [degrees_north, strictly increasing] and ``lon``
[degrees_east, in [-180, 180), strictly increasing, or increasing after
unwrapping when the domain straddles the antimeridian].

Variables, each on (time, lat, lon), with CF-style attributes
(``units``, ``standard_name``, ``long_name``):

========================  ==========  =====================================================
name                      units       meaning
========================  ==========  =====================================================
``hs_m``                  m           significant wave height (required)
``tp_s``                  s           peak wave period (``tm_s`` mean period accepted instead)
``tm_s``                  s           mean wave period (T01 or Tm-1,0, as the provider gives)
``wave_from_deg``         degree      mean wave direction, the direction waves come **from**
``wind_u_ms``             m s-1       10 m wind, eastward component (the vector it blows to)
``wind_v_ms``             m s-1       10 m wind, northward component
``current_u_ms``          m s-1       surface current, eastward component (the vector it flows to)
``current_v_ms``          m s-1       surface current, northward component
========================  ==========  =====================================================

Missing optional variables mean zero (calm wind, no current); a missing
required one is a :class:`~optroute.errors.WeatherSchemaError`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

DIMS = ("time", "lat", "lon")

VARIABLES: dict[str, dict[str, str]] = {
    "hs_m": {"units": "m", "standard_name": "sea_surface_wave_significant_height", "long_name": "significant wave height"},
    "tp_s": {"units": "s", "standard_name": "sea_surface_wave_period_at_variance_spectral_density_maximum", "long_name": "peak wave period"},
    "tm_s": {"units": "s", "standard_name": "sea_surface_wave_mean_period", "long_name": "mean wave period"},
    "wave_from_deg": {"units": "degree", "standard_name": "sea_surface_wave_from_direction", "long_name": "mean wave direction (coming from, true)"},
    "wind_u_ms": {"units": "m s-1", "standard_name": "eastward_wind", "long_name": "10 m wind, eastward component"},
    "wind_v_ms": {"units": "m s-1", "standard_name": "northward_wind", "long_name": "10 m wind, northward component"},
    "current_u_ms": {"units": "m s-1", "standard_name": "eastward_sea_water_velocity", "long_name": "surface current, eastward component"},
    "current_v_ms": {"units": "m s-1", "standard_name": "northward_sea_water_velocity", "long_name": "surface current, northward component"},
}

REQUIRED = ("hs_m",)
PERIOD_VARIABLES = ("tp_s", "tm_s")
OPTIONAL_ZERO = ("wind_u_ms", "wind_v_ms", "current_u_ms", "current_v_ms")

COORD_ATTRS: dict[str, dict[str, str]] = {
    "lat": {"units": "degrees_north", "standard_name": "latitude", "long_name": "latitude"},
    "lon": {"units": "degrees_east", "standard_name": "longitude", "long_name": "longitude"},
    "time": {"standard_name": "time", "long_name": "time (UTC)"},
}


def canonical_dataset(
    time: Any,
    lat: Any,
    lon: Any,
    variables: Mapping[str, Any],
    attrs: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """Build a canonical weather dataset from arrays.

    Parameters
    ----------
    time : array_like of datetime64
        Times [UTC, timezone-naive], strictly increasing.
    lat : array_like
        Latitudes [deg north], strictly increasing.
    lon : array_like
        Longitudes [deg east] in [-180, 180).
    variables : mapping
        Canonical name → array of shape (time, lat, lon) (or broadcastable to
        it) in the canonical unit of :data:`VARIABLES`.
    attrs : mapping, optional
        Global attributes (``title``, ``source``, ...).

    Returns
    -------
    xarray.Dataset
        With CF-style attributes on every variable and coordinate.
    """
    from optroute.errors import WeatherSchemaError

    time = np.asarray(time, dtype="datetime64[ns]")
    lat = np.asarray(lat, dtype=float)
    lon = np.asarray(lon, dtype=float)
    shape = (time.size, lat.size, lon.size)
    data_vars = {}
    for name, values in variables.items():
        if name not in VARIABLES:
            raise WeatherSchemaError(f"{name!r} is not a canonical weather variable; use one of {sorted(VARIABLES)}")
        arr = np.broadcast_to(np.asarray(values, dtype=float), shape).copy()
        data_vars[name] = (DIMS, arr, dict(VARIABLES[name]))
    ds = xr.Dataset(
        data_vars,
        coords={
            "time": ("time", time, dict(COORD_ATTRS["time"])),
            "lat": ("lat", lat, dict(COORD_ATTRS["lat"])),
            "lon": ("lon", lon, dict(COORD_ATTRS["lon"])),
        },
        attrs=dict(attrs or {}),
    )
    ds.attrs.setdefault("Conventions", "CF-1.8")
    return ds
