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
    "hs_m": {
        "units": "m",
        "standard_name": "sea_surface_wave_significant_height",
        "long_name": "significant wave height",
    },
    "tp_s": {
        "units": "s",
        "standard_name": "sea_surface_wave_period_at_variance_spectral_density_maximum",
        "long_name": "peak wave period",
    },
    "tm_s": {"units": "s", "standard_name": "sea_surface_wave_mean_period", "long_name": "mean wave period"},
    "wave_from_deg": {
        "units": "degree",
        "standard_name": "sea_surface_wave_from_direction",
        "long_name": "mean wave direction (coming from, true)",
    },
    "wind_u_ms": {"units": "m s-1", "standard_name": "eastward_wind", "long_name": "10 m wind, eastward component"},
    "wind_v_ms": {"units": "m s-1", "standard_name": "northward_wind", "long_name": "10 m wind, northward component"},
    "current_u_ms": {
        "units": "m s-1",
        "standard_name": "eastward_sea_water_velocity",
        "long_name": "surface current, eastward component",
    },
    "current_v_ms": {
        "units": "m s-1",
        "standard_name": "northward_sea_water_velocity",
        "long_name": "surface current, northward component",
    },
}

REQUIRED = ("hs_m",)
PERIOD_VARIABLES = ("tp_s", "tm_s")
OPTIONAL_ZERO = ("current_u_ms", "current_v_ms")
"""Variables a dataset may leave out, meaning zero: no current."""
OPTIONAL_UNKNOWN = ("wind_u_ms", "wind_v_ms")
"""Variables a dataset may leave out, meaning *not known* (NaN when sampled): a wave file without wind
says nothing about the wind, and Kwon's method then takes the Beaufort number from Hs
(:meth:`optroute.physics.performance.KwonModel.beaufort`), not calm air."""
OPTIONAL = OPTIONAL_UNKNOWN + OPTIONAL_ZERO

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


# ---------------------------------------------------------------------------
# Validation helpers shared by the loaders (io.py) and the sampler (sample.py)
# ---------------------------------------------------------------------------

#: What a dataset must hold to plan a voyage: each group needs one of its names.
#: A wave height, a wave period (peak preferred) and a wave direction; wind and
#: current are optional and mean zero when absent.
WAVE_REQUIRED: tuple[tuple[str, ...], ...] = (("hs_m",), PERIOD_VARIABLES, ("wave_from_deg",))

#: Values outside these ranges [canonical units] mean a corrupted file or wrong units.
PLAUSIBLE_RANGE: dict[str, tuple[float, float]] = {
    "hs_m": (0.0, 40.0),
    "tp_s": (0.0, 60.0),
    "tm_s": (0.0, 60.0),
    "wave_from_deg": (0.0, 360.0),
    "wind_u_ms": (-150.0, 150.0),
    "wind_v_ms": (-150.0, 150.0),
    "current_u_ms": (-15.0, 15.0),
    "current_v_ms": (-15.0, 15.0),
}

#: Global attribute recording how longitudes are represented (see :func:`normalise_lon`).
LON_CONVENTION_ATTR = "lon_convention"

_LON_TOL_DEG = 1e-6


def normalise_lon(lon: Any) -> tuple[np.ndarray, np.ndarray]:
    """Order and unwrap longitudes so that any domain is one increasing piece.

    The canonical representation: ``lon`` is strictly increasing, starts in
    [-180, 180) and spans less than 360 deg.  A domain that does not cross the
    antimeridian lies in [-180, 180).  One that does (the North Pacific,
    120 E to 110 W) keeps running past 180: ``120, ..., 179.75, 180, ...,
    250`` — values >= 180 are the western longitudes plus 360.  The cut is put
    in the widest gap between data columns, so a regional domain is never
    split; a global grid is cut at -180.  A duplicated seam column (a global
    grid given as 0 ... 360 inclusive) is dropped.

    Parameters
    ----------
    lon : array_like
        Longitudes [deg east] in any convention (0–360, -180–180, unordered).

    Returns
    -------
    order : ndarray of int
        Indices that take the original columns into the new order.
    new_lon : ndarray of float
        The longitudes [deg east] of the reordered columns, as above.
    """
    from optroute.errors import WeatherSchemaError

    lon = np.asarray(lon, dtype=float)
    if lon.ndim != 1 or lon.size == 0:
        raise WeatherSchemaError(f"lon must be a non-empty 1-D coordinate, got shape {lon.shape}")
    if not np.all(np.isfinite(lon)):
        raise WeatherSchemaError(
            f"lon holds non-finite values at indices {np.flatnonzero(~np.isfinite(lon))[:5].tolist()}"
        )
    wrapped = np.mod(lon + 180.0, 360.0) - 180.0
    order = np.argsort(wrapped, kind="stable")
    w = wrapped[order]
    # a seam column repeated 360 deg apart (0 and 360, or -180 and 180) appears twice after wrapping
    if w.size > 1 and np.any(np.diff(w) <= _LON_TOL_DEG):
        dup = np.flatnonzero(np.diff(w) <= _LON_TOL_DEG)
        seam = [k for k in dup if abs(abs(lon[order[k]] - lon[order[k + 1]]) - 360.0) < 1e-3]
        if len(seam) != len(dup):
            k = next(k for k in dup if k not in seam)
            raise WeatherSchemaError(
                f"duplicate longitude {w[k]:.6g} deg east (columns {int(order[k])} and {int(order[k + 1])})"
            )
        keep = np.ones(w.size, dtype=bool)
        keep[np.asarray(seam) + 1] = False
        order, w = order[keep], w[keep]
    if w.size == 1:
        return order, w
    gaps = np.diff(w)
    wrap_gap = w[0] + 360.0 - w[-1]
    k = int(np.argmax(gaps))
    if gaps[k] <= wrap_gap + _LON_TOL_DEG:
        return order, w  # the widest gap is at the antimeridian: nothing to unwrap
    start = k + 1
    new_order = np.concatenate([order[start:], order[:start]])
    new_lon = np.concatenate([w[start:], w[:start] + 360.0])
    return new_order, new_lon


def lon_is_periodic(lon: Any) -> bool:
    """Whether a canonical ``lon`` grid is uniform and wraps round the globe.

    Parameters
    ----------
    lon : array_like
        Strictly increasing longitudes [deg east].

    Returns
    -------
    bool
        True when the spacing is uniform and ``n * spacing == 360`` deg, so the
        last column neighbours the first across the seam.
    """
    lon = np.asarray(lon, dtype=float)
    if lon.size < 3:
        return False
    d = np.diff(lon)
    step = (lon[-1] - lon[0]) / (lon.size - 1)
    return bool(np.allclose(d, step, rtol=0, atol=1e-6 * max(1.0, step)) and abs(step * lon.size - 360.0) < 1e-4)


def lon_convention(lon: Any) -> str:
    """A one-line description of a canonical ``lon`` grid for ``attrs[LON_CONVENTION_ATTR]``."""
    lon = np.asarray(lon, dtype=float)
    if lon_is_periodic(lon):
        return "global, periodic; lon in [-180, 180)"
    if lon[-1] >= 180.0:
        return (
            f"regional across the antimeridian: lon runs from {lon[0]:.6g} to {lon[-1]:.6g} deg east unwrapped; "
            "values >= 180 are western longitudes + 360"
        )
    return "regional; lon in [-180, 180)"


def check_coords(ds: xr.Dataset, source: str = "dataset") -> None:
    """Check the canonical coordinates of a weather dataset.

    Parameters
    ----------
    ds : xarray.Dataset
        With coords ``time``, ``lat``, ``lon`` as described in the module docstring.
    source : str
        Where the dataset came from, for messages (a path or ``"dataset"``).

    Raises
    ------
    WeatherSchemaError
        A coordinate is missing, empty, not 1-D, non-finite, not strictly
        increasing or duplicated, or out of range; the message names the
        offending values and their indices.
    """
    from optroute.errors import WeatherSchemaError

    for name in DIMS:
        if name not in ds.coords:
            raise WeatherSchemaError(f"{source}: coordinate {name!r} is missing; a canonical dataset has coords {DIMS}")
        if ds[name].ndim != 1 or ds[name].size == 0:
            raise WeatherSchemaError(
                f"{source}: coordinate {name!r} must be 1-D and non-empty, got shape {ds[name].shape}"
            )
    t = ds["time"].values
    if not np.issubdtype(t.dtype, np.datetime64):
        raise WeatherSchemaError(f"{source}: time must be datetime64 (UTC, timezone-naive), got dtype {t.dtype}")
    if np.any(np.isnat(t)):
        raise WeatherSchemaError(f"{source}: time holds NaT at indices {np.flatnonzero(np.isnat(t))[:5].tolist()}")
    _strictly_increasing(t.astype("datetime64[ns]").astype(np.int64), "time", source, t)
    for name in ("lat", "lon"):
        v = ds[name].values.astype(float)
        if not np.all(np.isfinite(v)):
            raise WeatherSchemaError(
                f"{source}: {name} holds non-finite values at indices {np.flatnonzero(~np.isfinite(v))[:5].tolist()}"
            )
        if v.size < 2:
            raise WeatherSchemaError(
                f"{source}: {name} has {v.size} point; bilinear sampling needs at least 2 points along lat and lon"
            )
        _strictly_increasing(v, name, source, v)
    lat = ds["lat"].values
    if lat[0] < -90.0 - _LON_TOL_DEG or lat[-1] > 90.0 + _LON_TOL_DEG:
        raise WeatherSchemaError(f"{source}: lat runs from {lat[0]:.6g} to {lat[-1]:.6g}, outside [-90, 90] deg north")
    lon = ds["lon"].values
    if not -180.0 - _LON_TOL_DEG <= lon[0] < 180.0 or lon[-1] - lon[0] >= 360.0 - _LON_TOL_DEG:
        raise WeatherSchemaError(
            f"{source}: lon runs from {lon[0]:.6g} to {lon[-1]:.6g}; canonical lon starts in [-180, 180) and spans "
            "less than 360 deg (open the data with optroute.open_weather, which normalises it)"
        )


def _strictly_increasing(key: np.ndarray, name: str, source: str, shown: np.ndarray) -> None:
    from optroute.errors import WeatherSchemaError

    if key.size < 2:
        return
    d = np.diff(key)
    if np.all(d > 0):
        return
    k = int(np.flatnonzero(d <= 0)[0])
    what = "duplicate" if d[k] == 0 else "not increasing"
    raise WeatherSchemaError(
        f"{source}: {name} is {what} at index {k + 1}: {name}[{k}] = {shown[k]}, {name}[{k + 1}] = {shown[k + 1]}; "
        f"{name} must be strictly increasing without duplicates"
    )


def check_values(name: str, values: np.ndarray, where: str) -> None:
    """Reject an all-NaN field and values outside :data:`PLAUSIBLE_RANGE`.

    Parameters
    ----------
    name : str
        Canonical variable name.
    values : ndarray
        A field (one time slice, or several stacked along axis 0) in canonical units.
    where : str
        Source and time of the field, for the message.

    Raises
    ------
    WeatherSchemaError
        The field (or one of the stacked slices) is entirely NaN, or a value
        lies outside the plausible range for ``name`` (wrong units or a
        corrupted file).
    """
    from optroute.errors import WeatherSchemaError

    values = np.asarray(values)
    if values.size == 0:
        raise WeatherSchemaError(f"{where}: {name} is empty")
    slices = values.reshape(values.shape[0], -1) if values.ndim >= 3 else values.reshape(1, -1)
    if slices.dtype.kind != "f":
        slices = slices.astype(float)
    mins = np.fmin.reduce(slices, axis=1)  # fmin skips NaN: NaN only for an all-NaN slice
    maxs = np.fmax.reduce(slices, axis=1)
    dead = np.isnan(mins)
    if dead.any():
        k = int(np.flatnonzero(dead)[0])
        tail = f" (slice {k} of {slices.shape[0]})" if slices.shape[0] > 1 else ""
        raise WeatherSchemaError(
            f"{where}: {name} is NaN everywhere{tail}; an all-NaN field carries no weather — check the variable and "
            "the time range you downloaded"
        )
    lo, hi = PLAUSIBLE_RANGE.get(name, (-np.inf, np.inf))
    vmin, vmax = float(np.min(mins)), float(np.max(maxs))
    if vmin < lo or vmax > hi:
        bad = vmin if vmin < lo else vmax
        unit = VARIABLES.get(name, {}).get("units", "")
        raise WeatherSchemaError(
            f"{where}: {name} holds {bad:.6g} {unit}, outside the plausible range [{lo:g}, {hi:g}] {unit}; "
            "the units attribute is wrong or the file is corrupted"
        )
