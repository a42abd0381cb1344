"""Open weather files of the common providers as canonical datasets.

:func:`open_weather` reads NetCDF (classic or NetCDF-4/HDF5, through the
``netcdf4`` or ``h5netcdf`` engine), Zarr stores and GRIB (through cfgrib,
the optional extra ``optroute[grib]``), and returns the canonical dataset of
:mod:`optroute.weather.schema`: canonical variable names and units, coords
``time``, ``lat`` (increasing) and ``lon`` (one increasing piece, see
:func:`~optroute.weather.schema.normalise_lon`), dims ``(time, lat, lon)``.

This module is the only place that knows the providers' names.  Sources:

* ERA5 (ECMWF, C3S; CDS NetCDF and GRIB/cfgrib short names): ``swh``,
  ``mwd``, ``pp1d``, ``mwp``, ``u10``, ``v10``; coords
  ``latitude``/``longitude`` (descending latitude, 0–360 longitude) and
  ``valid_time`` (or ``time`` + ``step`` in GRIB forecasts).
* Copernicus Marine (CMEMS) global wave and physics products: ``VHM0``,
  ``VMDR``, ``VTPK``, ``VTM10``, ``uo``, ``vo`` and the total currents
  ``utotal``, ``vtotal``; currents carry a ``depth`` dimension, the surface
  (the level nearest 0 m) is taken.
* NOAA WAVEWATCH III NetCDF output: ``hs``, ``dir``, ``fp`` (peak frequency
  [Hz], turned into ``tp_s = 1 / fp``) or ``tp``, ``t0m1``, ``uwnd``,
  ``vwnd``, ``ucur``, ``vcur``.
* NOAA GFS-Wave GRIB2 names (and wgrib2 ``-netcdf`` names with ``_surface``):
  ``HTSGW``, ``DIRPW``, ``PERPW``, ``UGRD``, ``VGRD``.
* GFS as served over THREDDS (NCSS NetCDF): ``u-component_of_wind_height_above_ground``
  and ``v-...`` on a ``height_above_ground*`` dimension, of which the 10 m
  level is taken; times on ``time``, ``time1``, ... dimensions.

Telling the file's format and opening it is :mod:`optroute.weather.formats`; this module
normalises what it read.  Unknown or missing units, missing variables, broken coordinates and
unreadable files raise :class:`~optroute.errors.WeatherSchemaError` naming
the variable or file; nothing is filled in silently.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Hashable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from optroute import units
from optroute.errors import ConfigError, WeatherSchemaError
from optroute.weather import schema
from optroute.weather.formats import LAT_NAMES, LON_NAMES, open_path
from optroute.weather.reftime import ATTR as REFTIME_ATTR
from optroute.weather.reftime import reference_time

__all__ = ["PROVIDER_NAMES", "TIME_POLICIES", "accepted_names", "check_required", "open_weather"]

TIME_POLICIES = ("raise", "hold")

# canonical name -> ((provider variable name, provider), ...), in order of preference
PROVIDER_NAMES: dict[str, tuple[tuple[str, str], ...]] = {
    "hs_m": (
        ("hs_m", "optroute"),
        ("swh", "ERA5"),
        ("VHM0", "CMEMS"),
        ("hs", "WAVEWATCH III"),
        ("HTSGW", "GFS-Wave"),
        ("HTSGW_surface", "GFS-Wave (wgrib2)"),
        ("Significant_height_of_combined_wind_waves_and_swell_surface", "GFS-Wave (THREDDS)"),
    ),
    "tp_s": (
        ("tp_s", "optroute"),
        ("pp1d", "ERA5"),
        ("VTPK", "CMEMS"),
        ("tp", "WAVEWATCH III"),
        ("fp", "WAVEWATCH III (peak frequency, tp = 1/fp)"),
        ("PERPW", "GFS-Wave"),
        ("PERPW_surface", "GFS-Wave (wgrib2)"),
        ("Primary_wave_mean_period_surface", "GFS-Wave (THREDDS)"),
    ),
    "tm_s": (
        ("tm_s", "optroute"),
        ("mwp", "ERA5"),
        ("VTM10", "CMEMS"),
        ("t0m1", "WAVEWATCH III"),
    ),
    "wave_from_deg": (
        ("wave_from_deg", "optroute"),
        ("mwd", "ERA5"),
        ("VMDR", "CMEMS"),
        ("dir", "WAVEWATCH III"),
        ("DIRPW", "GFS-Wave"),
        ("DIRPW_surface", "GFS-Wave (wgrib2)"),
        ("Primary_wave_direction_surface", "GFS-Wave (THREDDS)"),
    ),
    "wind_u_ms": (
        ("wind_u_ms", "optroute"),
        ("u10", "ERA5"),
        ("uwnd", "WAVEWATCH III"),
        ("UGRD", "GFS-Wave"),
        ("UGRD_surface", "GFS-Wave (wgrib2)"),
        ("UGRD_10maboveground", "GFS (wgrib2)"),
        ("u-component_of_wind_height_above_ground", "GFS (THREDDS)"),
        ("u-component_of_wind_surface", "GFS-Wave (THREDDS)"),
        ("eastward_wind", "CMEMS wind"),
    ),
    "wind_v_ms": (
        ("wind_v_ms", "optroute"),
        ("v10", "ERA5"),
        ("vwnd", "WAVEWATCH III"),
        ("VGRD", "GFS-Wave"),
        ("VGRD_surface", "GFS-Wave (wgrib2)"),
        ("VGRD_10maboveground", "GFS (wgrib2)"),
        ("v-component_of_wind_height_above_ground", "GFS (THREDDS)"),
        ("v-component_of_wind_surface", "GFS-Wave (THREDDS)"),
        ("northward_wind", "CMEMS wind"),
    ),
    "current_u_ms": (
        ("current_u_ms", "optroute"),
        ("utotal", "CMEMS total current"),
        ("uo", "CMEMS"),
        ("ucur", "WAVEWATCH III"),
    ),
    "current_v_ms": (
        ("current_v_ms", "optroute"),
        ("vtotal", "CMEMS total current"),
        ("vo", "CMEMS"),
        ("vcur", "WAVEWATCH III"),
    ),
}

# CF standard names accepted when no provider name matches: canonical -> ((standard_name, flip_to_from), ...)
_STANDARD_NAMES: dict[str, tuple[tuple[str, bool], ...]] = {
    "hs_m": (("sea_surface_wave_significant_height", False),),
    "tp_s": (("sea_surface_wave_period_at_variance_spectral_density_maximum", False),),
    "tm_s": (
        ("sea_surface_wave_mean_period_from_variance_spectral_density_inverse_frequency_moment", False),
        ("sea_surface_wave_mean_period", False),
    ),
    "wave_from_deg": (("sea_surface_wave_from_direction", False), ("sea_surface_wave_to_direction", True)),
    "wind_u_ms": (("eastward_wind", False),),
    "wind_v_ms": (("northward_wind", False),),
    "current_u_ms": (("eastward_sea_water_velocity", False), ("surface_eastward_sea_water_velocity", False)),
    "current_v_ms": (("northward_sea_water_velocity", False), ("surface_northward_sea_water_velocity", False)),
}

# unit spellings by kind -> factor to the canonical unit; "frequency" converts by reciprocal
_UNITS: dict[str, dict[str, float]] = {
    "length": {
        "m": 1.0,
        "meter": 1.0,
        "meters": 1.0,
        "metre": 1.0,
        "metres": 1.0,
        "cm": 0.01,
        "ft": 0.3048,
        "feet": 0.3048,
    },
    "period": {"s": 1.0, "sec": 1.0, "second": 1.0, "seconds": 1.0},
    "frequency": {"hz": 1.0, "s-1": 1.0, "1/s": 1.0, "/s": 1.0},
    "angle": {
        "degree": 1.0,
        "degrees": 1.0,
        "deg": 1.0,
        "degree_true": 1.0,
        "degrees_true": 1.0,
        "degree true": 1.0,
        "degrees true": 1.0,
        "degree_t": 1.0,
        "°": 1.0,
        "rad": 180.0 / np.pi,
        "radian": 180.0 / np.pi,
        "radians": 180.0 / np.pi,
    },
    "speed": {
        "m s-1": 1.0,
        "m/s": 1.0,
        "ms-1": 1.0,
        "m.s-1": 1.0,
        "meter second-1": 1.0,
        "meters/second": 1.0,
        "metres/second": 1.0,
        "m sec-1": 1.0,
        "meter/second": 1.0,
        "meters second-1": 1.0,
        "knots": units.MS_PER_KN,
        "knot": units.MS_PER_KN,
        "kt": units.MS_PER_KN,
        "kts": units.MS_PER_KN,
        "kn": units.MS_PER_KN,
        "cm s-1": 0.01,
        "cm/s": 0.01,
        "km/h": 1.0 / 3.6,
        "km h-1": 1.0 / 3.6,
    },
}
_KIND_OF: dict[str, tuple[str, ...]] = {
    "hs_m": ("length",),
    "tp_s": ("period", "frequency"),
    "tm_s": ("period", "frequency"),
    "wave_from_deg": ("angle",),
    "wind_u_ms": ("speed",),
    "wind_v_ms": ("speed",),
    "current_u_ms": ("speed",),
    "current_v_ms": ("speed",),
}
_DEPTH_NAMES = ("depth", "deptht", "depthu", "depthv", "depthw", "lev", "olevel", "z")
_CHECK_ALL_BYTES = 64 * 2**20


def accepted_names(canonical: str) -> str:
    """The names accepted for a canonical variable, with their providers, for messages.

    Parameters
    ----------
    canonical : str
        A canonical variable name of :data:`optroute.weather.schema.VARIABLES`.

    Returns
    -------
    str
        E.g. ``"hs_m (optroute), swh (ERA5), VHM0 (CMEMS), ..."``.
    """
    names = [f"{n} ({p})" for n, p in PROVIDER_NAMES.get(canonical, ())]
    names += [f"standard_name={s}" for s, _ in _STANDARD_NAMES.get(canonical, ())]
    return ", ".join(names)


def check_required(
    ds: xr.Dataset, required: Sequence[Sequence[str]] = schema.WAVE_REQUIRED, source: str = "dataset", notes: str = ""
) -> None:
    """Raise when a required variable group has no member in a canonical dataset.

    Parameters
    ----------
    ds : xarray.Dataset
        A canonical dataset.
    required : sequence of sequences of str
        Groups of canonical names; each group needs one present member.
    source : str
        Where the dataset came from, for the message.
    notes : str
        Extra explanation appended (e.g. candidates rejected for their units).

    Raises
    ------
    WeatherSchemaError
        Naming the missing variable and every accepted name across providers;
        also when one component of the wind or current vector is there
        without the other (never filled with zero).
    """
    for pair in (("wind_u_ms", "wind_v_ms"), ("current_u_ms", "current_v_ms")):
        have = [name for name in pair if name in ds.data_vars]
        if len(have) == 1:
            lack = next(name for name in pair if name not in have)
            raise WeatherSchemaError(
                f"{source}: {have[0]} is present but {lack} is not; a vector needs both components "
                f"(accepted names for {lack}: {accepted_names(lack)})"
            )
    for group in required:
        if not any(name in ds.data_vars for name in group):
            accepted = "; ".join(f"{name}: {accepted_names(name)}" for name in group)
            have = ", ".join(map(str, ds.data_vars)) or "none"
            raise WeatherSchemaError(
                f"{source}: required variable {' or '.join(group)} is missing (variables present: {have}); "
                f"accepted names: {accepted}{notes}"
            )


def open_weather(
    source: str | os.PathLike[str] | xr.Dataset,
    *,
    engine: str | None = None,
    chunks: Any = "auto",
    time_policy: str = "raise",
    required: Sequence[Sequence[str]] = schema.WAVE_REQUIRED,
    backend_kwargs: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """Open a weather file or dataset as a canonical :mod:`~optroute.weather.schema` dataset.

    Parameters
    ----------
    source : path or xarray.Dataset
        A NetCDF file, a Zarr store (directory), a GRIB file, or a dataset
        already opened with xarray, in ERA5, CMEMS, WAVEWATCH III, GFS-Wave,
        GFS-THREDDS or canonical naming.
    engine : str, optional
        xarray backend (``"netcdf4"``, ``"h5netcdf"``, ``"scipy"``, ``"zarr"``,
        ``"cfgrib"``); sniffed from the file's first bytes when omitted.
    chunks : "auto", int, dict or None
        Dask chunks.  ``"auto"`` (default) opens lazily with dask, one chunk
        per time step (and level) holding whole lat/lon fields, so that the
        sampler reads only the time slices it needs; a dict or int goes to
        :func:`xarray.open_dataset` as is (provider dimension names); ``None``
        uses xarray's lazy backend arrays without dask (a variable whose units
        are converted is then read whole on first use).
    time_policy : {"raise", "hold"}
        Recorded in ``attrs["time_policy"]`` and used by
        :class:`~optroute.weather.sample.WeatherSampler`: ``"raise"`` makes a
        time outside the dataset's span a
        :class:`~optroute.errors.WeatherCoverageError`; ``"hold"`` holds the
        first or last time slice instead.  A dataset with a single time is
        valid for all times only with ``"hold"``.
    required : sequence of sequences of str
        Groups of canonical names of which one each must be present; the
        default needs a wave height, a wave period and a wave direction.
        Pass ``()`` for a wind- or current-only file.
    backend_kwargs : mapping, optional
        Passed to :func:`xarray.open_dataset` (for cfgrib, e.g.
        ``{"filter_by_keys": {"typeOfLevel": "surface"}}``).

    Returns
    -------
    xarray.Dataset
        Canonical names and units, dims ``(time, lat, lon)``, lat increasing,
        lon one increasing piece (values run past 180 deg east when the domain
        crosses the antimeridian; ``attrs["lon_convention"]`` says which),
        directions in [0, 360) deg true coming from.  ``attrs`` record the
        source, the provider names used (``source_variables``) and the levels
        selected, and a forecast's issue time (``forecast_reference_time``, ISO 8601 UTC) when
        the file states it (:func:`optroute.weather.reftime.reference_time`).  Lazy (dask-backed)
        when opened from a file with chunks.

    Raises
    ------
    WeatherSchemaError
        A missing file, an empty, truncated, corrupted or unrecognised file, a
        missing required variable (the message lists the accepted names), unknown
        units, broken or duplicate coordinates, an unusable extra dimension,
        an all-NaN field.
    ConfigError
        A bad option, or a GRIB file without the ``grib`` extra installed.
    """
    if time_policy not in TIME_POLICIES:
        raise ConfigError(f"time_policy={time_policy!r} is not known; use one of {TIME_POLICIES}")
    if isinstance(source, xr.Dataset):
        raw, where = source, str(source.encoding.get("source", "dataset"))
    elif isinstance(source, str | os.PathLike):
        raw, where = open_path(Path(source), engine, chunks, backend_kwargs), os.fspath(source)
    else:
        raise ConfigError(f"open_weather takes a path or an xarray.Dataset, got {type(source).__name__}")
    issued = reference_time(raw, where)
    try:
        ds, notes = _normalise(raw, where)
    except (OSError, RuntimeError) as exc:  # a lazily read coordinate failed: a damaged file
        raise WeatherSchemaError(
            f"{where}: could not read the file's coordinates ({exc}); the file is truncated or corrupted"
        ) from exc
    check_required(ds, required, where, notes)
    _check_fields(ds, where)
    ds.attrs["time_policy"] = time_policy
    if issued is not None:
        ds.attrs[REFTIME_ATTR] = units.format_utc(issued)
    return ds


# ---------------------------------------------------------------------------
# normalising names, units, dimensions and coordinates
# ---------------------------------------------------------------------------


def _normalise(raw: xr.Dataset, where: str) -> tuple[xr.Dataset, str]:
    raw = _rename_horizontal(raw, where)
    chosen, notes, sources = _choose_variables(raw, where)
    levels: list[str] = []
    arrays = {}
    for canon, (src, da) in chosen.items():
        da = _reduce_extra_dims(da, src, where, levels)
        da = _time_axis(da, src, where)
        if "lat" not in da.dims or "lon" not in da.dims:
            raise WeatherSchemaError(f"{where}: variable {src!r} has dims {da.dims}, without lat and lon")
        arrays[canon] = da.transpose("time", "lat", "lon")
    if not arrays:
        ds = xr.Dataset(attrs=dict(raw.attrs))
        return ds, notes
    try:
        aligned = xr.align(*arrays.values(), join="exact")
    except ValueError as exc:
        raise WeatherSchemaError(
            f"{where}: variables {list(sources)} are not on the same time/lat/lon grid ({exc}); open them separately"
        ) from exc
    ds = xr.Dataset(dict(zip(arrays, aligned, strict=True)))
    ds = ds.drop_vars([c for c in ds.coords if c not in schema.DIMS])
    ds = _order_lat(ds, where)
    order, new_lon = schema.normalise_lon(ds["lon"].values)
    if not np.array_equal(order, np.arange(ds.sizes["lon"])):
        ds = ds.isel(lon=order)
    ds = ds.assign_coords(
        time=("time", ds["time"].values.astype("datetime64[ns]"), dict(schema.COORD_ATTRS["time"])),
        lat=("lat", ds["lat"].values.astype(float), dict(schema.COORD_ATTRS["lat"])),
        lon=("lon", new_lon, dict(schema.COORD_ATTRS["lon"])),
    )
    schema.check_coords(ds, where)
    for canon in ds.data_vars:
        src = sources[canon]
        ds[canon].attrs = {**schema.VARIABLES[str(canon)], "source_name": src[0], "source_units": src[1]}
    ds.attrs = {k: v for k, v in raw.attrs.items() if isinstance(v, str | int | float)}
    ds.attrs.update(
        {
            "Conventions": "CF-1.8",
            "source": where,
            "provider": ", ".join(sorted({s[2] for s in sources.values()})),
            "source_variables": "; ".join(f"{c} <- {s[0]} [{s[1] or 'no units'}]" for c, s in sources.items()),
            schema.LON_CONVENTION_ATTR: schema.lon_convention(new_lon),
        }
    )
    if levels:
        ds.attrs["levels_selected"] = "; ".join(levels)
    return ds, notes


def _rename_horizontal(raw: xr.Dataset, where: str) -> xr.Dataset:
    renames: dict[Hashable, str] = {}
    for target, names, std, unit in (
        ("lat", LAT_NAMES, "latitude", "degrees_north"),
        ("lon", LON_NAMES, "longitude", "degrees_east"),
    ):
        found = [n for n in names if n in raw.variables]
        found += [
            n
            for n, v in raw.coords.items()
            if n not in found and (v.attrs.get("standard_name") == std or v.attrs.get("units") == unit)
        ]
        if not found:
            raise WeatherSchemaError(
                f"{where}: no {std} coordinate (looked for {', '.join(names)} and standard_name={std}); "
                f"coordinates present: {', '.join(map(str, raw.coords)) or 'none'}"
            )
        name = found[0]
        if raw[name].ndim != 1:
            raise WeatherSchemaError(
                f"{where}: {name!r} is {raw[name].ndim}-D (a curvilinear grid); optroute reads regular lat/lon grids — "
                "regrid the data first"
            )
        dim = raw[name].dims[0]
        if dim != name:  # a coordinate on a dim of another name (e.g. lat(y))
            raw = raw.swap_dims({dim: name})
        if name != target:
            if target in raw.variables:
                raw = raw.drop_vars(target)
            renames[name] = target
    return raw.rename(renames) if renames else raw


def _norm_units(u: Any) -> str:
    s = " ".join(str(u).strip().lower().replace("**", "").replace("^", "").split())
    return s


def _unit_kind(canon: str, units_attr: str) -> tuple[str, float] | None:
    """(kind, factor) when the unit is an accepted one for ``canon``, else None."""
    for kind in _KIND_OF[canon]:
        if units_attr in _UNITS[kind]:
            return kind, _UNITS[kind][units_attr]
    return None


def _any_kind(units_attr: str) -> str | None:
    return next((kind for kind, table in _UNITS.items() if units_attr in table), None)


def _choose_variables(
    raw: xr.Dataset, where: str
) -> tuple[dict[str, tuple[str, xr.DataArray]], str, dict[str, tuple[str, str, str]]]:
    chosen: dict[str, tuple[str, xr.DataArray]] = {}
    sources: dict[str, tuple[str, str, str]] = {}
    rejected: list[str] = []
    for canon in schema.VARIABLES:
        candidates: list[tuple[str, str, bool]] = [
            (n, p, False) for n, p in PROVIDER_NAMES[canon] if n in raw.data_vars
        ]
        for std, flip in _STANDARD_NAMES[canon]:
            candidates += [
                (str(n), f"standard_name={std}", flip)
                for n, v in raw.data_vars.items()
                if v.attrs.get("standard_name") == std and str(n) not in [c[0] for c in candidates]
            ]
        for name, provider, flip in candidates:
            da = raw[name]
            raw_units = da.attrs.get("units")
            if raw_units is None:
                kind = "frequency" if name == "fp" else _KIND_OF[canon][0]
                factor = 1.0
                warnings.warn(
                    f"{where}: variable {name!r} has no units attribute; assuming {kind} in the canonical unit "
                    f"({'Hz' if kind == 'frequency' else schema.VARIABLES[canon]['units']})",
                    UserWarning,
                    stacklevel=4,
                )
            else:
                u = _norm_units(raw_units)
                hit = _unit_kind(canon, u)
                if hit is None:
                    other = _any_kind(u)
                    if other is not None:  # a known unit of another quantity: not this variable (ERA5 tp is rain)
                        rejected.append(
                            f"{name!r} has units {raw_units!r} ({other}), not {' or '.join(_KIND_OF[canon])}"
                        )
                        continue
                    accepted = sorted(set().union(*(_UNITS[k] for k in _KIND_OF[canon])))
                    raise WeatherSchemaError(
                        f"{where}: variable {name!r} (for {canon}) has unknown units {raw_units!r}; accepted units: "
                        f"{', '.join(accepted)}"
                    )
                kind, factor = hit
            chosen[canon] = (name, _convert(da, canon, kind, factor, flip))
            sources[canon] = (name, str(raw_units or ""), provider.split(" (")[0])
            break
    notes = ("; candidates rejected: " + "; ".join(rejected)) if rejected else ""
    return chosen, notes, sources


def _convert(da: xr.DataArray, canon: str, kind: str, factor: float, flip: bool) -> xr.DataArray:
    attrs = dict(da.attrs)
    if kind == "frequency":
        out = 1.0 / da.where(da > 0)  # fp <= 0 has no peak period: NaN, never 0 s
    elif factor != 1.0:
        out = da * factor
    else:
        out = da
    if canon == "wave_from_deg":
        out = (out + 180.0) % 360.0 if flip else out % 360.0
    out.attrs = attrs
    return out


def _reduce_extra_dims(da: xr.DataArray, src: str, where: str, levels: list[str]) -> xr.DataArray:
    for dim in list(da.dims):
        if dim in ("lat", "lon") or _is_time_dim(da, dim):
            continue
        coord = da.coords.get(dim)
        attrs = coord.attrs if coord is not None else {}
        name = str(dim)
        if name == "expver" and da.sizes[dim] > 1:  # ERA5 + ERA5T mixed: one of the two is NaN at each time
            parts = [da.isel({dim: k}, drop=True) for k in range(da.sizes[dim])]
            out = parts[0]
            for p in parts[1:]:
                out = out.combine_first(p)
            da = out
            levels.append(f"{src}: ERA5/ERA5T expver merged")
        elif name in _DEPTH_NAMES or attrs.get("standard_name") == "depth" or attrs.get("positive") == "down":
            if coord is None:
                raise WeatherSchemaError(
                    f"{where}: variable {src!r} has a depth dimension {name!r} without depth values"
                )
            k = int(np.argmin(np.abs(coord.values.astype(float))))
            levels.append(f"{src}: surface level {name}={float(coord.values[k]):g} m")
            da = da.isel({dim: k}, drop=True)
        elif name.lower().startswith("height") or attrs.get("standard_name") == "height":
            if coord is None:
                raise WeatherSchemaError(
                    f"{where}: variable {src!r} has a height dimension {name!r} without height values"
                )
            h = coord.values.astype(float)
            hit = np.flatnonzero(np.abs(h - 10.0) < 0.5)
            if hit.size == 0:
                raise WeatherSchemaError(
                    f"{where}: variable {src!r} has no 10 m level on its height dimension {name!r} "
                    f"(levels {h.tolist()} m); optroute needs the 10 m wind"
                )
            levels.append(f"{src}: {name}=10 m")
            da = da.isel({dim: int(hit[0])}, drop=True)
        elif da.sizes[dim] == 1:
            da = da.isel({dim: 0}, drop=True)
        elif name == "number":
            raise WeatherSchemaError(
                f"{where}: variable {src!r} holds {da.sizes[dim]} ensemble members (dimension 'number'); "
                "select one with ds.isel(number=k) and pass the dataset to open_weather"
            )
        else:
            raise WeatherSchemaError(
                f"{where}: variable {src!r} has an unexpected dimension {name!r} of size {da.sizes[dim]}; "
                f"select one level (ds.isel({name}=k)) and pass the dataset to open_weather"
            )
    return da


def _is_time_dim(da: xr.DataArray, dim: Hashable) -> bool:
    if dim in ("time", "valid_time", "step"):
        return True
    coord = da.coords.get(dim)
    return coord is not None and (
        np.issubdtype(coord.dtype, np.datetime64) or np.issubdtype(coord.dtype, np.timedelta64)
    )


def _time_axis(da: xr.DataArray, src: str, where: str) -> xr.DataArray:
    """Give ``da`` one dimension ``time`` of valid times [UTC].

    ``valid_time`` wins when present (ERA5 CDS NetCDF, cfgrib); else ``time +
    step`` (a forecast run); else the one datetime dimension (``time``,
    ``time1``, ...); else a scalar time becomes a dimension of length one.
    """
    vt: xr.DataArray | None = None
    if "valid_time" in da.coords:
        vt = da.coords["valid_time"]
    elif "step" in da.coords and "time" in da.coords and np.issubdtype(da.coords["step"].dtype, np.timedelta64):
        vt = da.coords["time"] + da.coords["step"]
    if vt is None:
        tdims = [d for d in da.dims if d in da.coords and np.issubdtype(da.coords[d].dtype, np.datetime64)]
        if len(tdims) > 1:
            raise WeatherSchemaError(f"{where}: variable {src!r} has several time dimensions {tdims}; select one")
        if tdims:
            vt = da.coords[tdims[0]]
        else:
            scalars = [
                c for c in da.coords if da.coords[c].ndim == 0 and np.issubdtype(da.coords[c].dtype, np.datetime64)
            ]
            if not scalars:
                raise WeatherSchemaError(
                    f"{where}: variable {src!r} has no time coordinate (dims {da.dims}); add one, e.g. "
                    "ds.expand_dims(time=[np.datetime64('2024-01-01T00')]), and pass the dataset to open_weather"
                )
            vt = da.coords[scalars[0]]
    for d in list(vt.dims):
        if vt.ndim > 1 and vt.sizes[d] == 1:
            vt = vt.isel({d: 0}, drop=True)
            if d in da.dims:
                da = da.isel({d: 0}, drop=True)
    if vt.ndim > 1:
        raise WeatherSchemaError(
            f"{where}: variable {src!r} holds several forecast runs (valid_time over {vt.dims}); "
            "select one run with ds.isel(time=k) and pass the dataset to open_weather"
        )
    values = np.asarray(vt.values).astype("datetime64[ns]")
    da = da.drop_vars([c for c in da.coords if c not in ("lat", "lon")])
    if vt.ndim == 0:
        return da.expand_dims(time=[values])
    dim = vt.dims[0]
    if dim not in da.dims:
        raise WeatherSchemaError(f"{where}: variable {src!r}: its time runs over {dim!r}, a dimension it does not have")
    if dim != "time":
        da = da.rename({dim: "time"})
    return da.assign_coords(time=("time", values))


def _order_lat(ds: xr.Dataset, where: str) -> xr.Dataset:
    lat = ds["lat"].values
    if lat.size > 1 and np.all(np.diff(lat) < 0):
        return ds.isel(lat=slice(None, None, -1))
    return ds


def _check_fields(ds: xr.Dataset, where: str) -> None:
    """All-NaN and plausibility checks: whole fields when small, else the first and last time slices.

    The sampler checks every further slice it loads, so a large lazy file is never read whole here.
    """
    for name in ds.data_vars:
        da = ds[name]
        try:
            if da.nbytes <= _CHECK_ALL_BYTES:
                values = da.values
            else:
                values = da.isel(time=sorted({0, da.sizes["time"] - 1})).values
        except (OSError, RuntimeError, ValueError) as exc:
            raise WeatherSchemaError(
                f"{where}: could not read {name} ({exc}); the file is truncated or corrupted"
            ) from exc
        schema.check_values(str(name), values, f"{where}: {da.attrs.get('source_name', name)}")
