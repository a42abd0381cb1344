"""Standard output files of a plan: GeoJSON (RFC 7946), CSV and CF NetCDF, written atomically.

:class:`~optroute.plan.result.Plan` exposes these as ``to_geojson()``, ``to_csv(path)``,
``to_dataset()`` and ``to_netcdf(path)``; the command line writes all three.

GeoJSON (RFC 7946)
    A ``FeatureCollection`` of

    * one ``track`` feature: the whole route, ``LineString`` of [lon, lat] positions, or a
      ``MultiLineString`` when it crosses the antimeridian (§3.1.9: split there, the crossing
      latitude on the leg's great circle, so that no segment spans more than 180° of
      longitude); properties: ``departure_utc``, ``arrival_utc``, ``duration_h``,
      ``distance_nm``, ``total_fuel_t``, ``status``, ``eta_shadow_price_t_per_h``;
    * one ``leg`` feature per leg (``LineString`` or, across the antimeridian,
      ``MultiLineString``) with ``leg``, ``start_time_utc``, ``end_time_utc`` and every leg
      quantity of :attr:`Plan.legs` under its unit-suffixed name (``sog_kn``, ``fuel_t``,
      ``hs_m``, ``margin_<band>`` …);
    * one ``waypoint`` feature per waypoint (``Point``) with ``index``, ``time_utc`` and the
      quantities of the leg that starts there.

    Longitudes are in [-180, 180], latitudes in [-90, 90], positions [lon, lat] (WGS 84).
    JSON has no NaN or infinity: a NaN quantity and an infinite band margin (the band never
    applies on that leg) are written as ``null``.

CSV
    One row per leg, units in the headers: ``leg``, ``start_time_utc``, ``end_time_utc``
    (ISO 8601, ``Z``), ``start_lat_deg``, ``start_lon_deg``, ``end_lat_deg``, ``end_lon_deg``,
    then the leg quantities (``heading_deg``, ``sog_kn``, ``stw_kn``, ``distance_nm``,
    ``duration_h``, ``power_kw``, ``fuel_t``, ``hs_m``, ``period_s``, ``wave_from_deg``,
    ``encounter_period_s``, ``margin_<band>`` [-], ``inf`` where a band never applies).

NetCDF (CF-1.8)
    Leg variables on dimension ``leg``, waypoint positions and times on ``waypoint``; every
    variable has ``units`` (UDUNITS) and ``long_name``, and ``standard_name`` where the CF
    standard-name table has one; times are encoded as ``hours since <departure>`` (float64,
    proleptic Gregorian); global attributes ``Conventions = "CF-1.8"``, ``title``, ``source``,
    ``history`` and the plan's totals.

Every file goes to a temporary name in the destination folder, is flushed to disk and then
renamed over the destination (:func:`optroute._store.atomic_write_bytes`): an interrupted
write leaves any earlier file intact and never a half-written one.
"""

from __future__ import annotations

import io
import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
import xarray as xr

from optroute import units
from optroute._store import atomic_write_bytes
from optroute.errors import ConfigError
from optroute.geo.tracks import gc_points

if TYPE_CHECKING:
    from optroute.plan.result import Plan

__all__ = [
    "CF_CONVENTIONS",
    "LEG_ATTRS",
    "csv_text",
    "geojson",
    "plan_dataset",
    "split_antimeridian",
    "write_bytes",
    "write_csv",
    "write_geojson",
    "write_netcdf",
]

CF_CONVENTIONS = "CF-1.8"

#: CF attributes of the leg quantities of :attr:`Plan.legs` (``units`` in UDUNITS-2 spelling).
LEG_ATTRS: dict[str, dict[str, str]] = {
    "heading_deg": {
        "units": "degree",
        "long_name": "time-mean heading of the ship, crabbed against the current (degrees true, going to)",
        "standard_name": "platform_orientation",
    },
    "sog_kn": {
        "units": "knot",
        "long_name": "speed over ground (leg distance / leg duration)",
        "standard_name": "platform_speed_wrt_ground",
    },
    "stw_kn": {
        "units": "knot",
        "long_name": "speed through the water, constant on the leg",
        "standard_name": "platform_speed_wrt_sea_water",
    },
    "distance_nm": {"units": "nautical_mile", "long_name": "great-circle length of the leg"},
    "duration_h": {"units": "h", "long_name": "duration of the leg"},
    "power_kw": {"units": "kW", "long_name": "time-mean brake power of the main engine"},
    "fuel_t": {"units": "t", "long_name": "main-engine fuel burnt on the leg (tonnes)"},
    "hs_m": {
        "units": "m",
        "long_name": "time-mean significant wave height along the leg",
        "standard_name": "sea_surface_wave_significant_height",
    },
    "period_s": {"units": "s", "long_name": "time-mean wave period along the leg (the weather's tp_s or tm_s)"},
    "wave_from_deg": {
        "units": "degree",
        "long_name": "circular-mean direction the waves come from along the leg (degrees true)",
        "standard_name": "sea_surface_wave_from_direction",
    },
    "encounter_period_s": {"units": "s", "long_name": "wave encounter period at the leg's mean sea and speed"},
}

_MARGIN_ATTRS = {
    "units": "1",
    "long_name": "smallest signed distance to the danger band along the leg in the band's ratio units "
    "(> 0 safe; inf where the band never applies)",
}


def _margin_attrs(name: str) -> dict[str, str]:
    band = name.removeprefix("margin_")
    return {**_MARGIN_ATTRS, "long_name": f"margin to the {band} band: " + _MARGIN_ATTRS["long_name"]}


# --------------------------------------------------------------------------- writing


def write_bytes(path: str | os.PathLike[str], data: bytes | memoryview) -> Path:
    """Write ``data`` to ``path`` atomically (temporary name in the same folder, then rename).

    Parameters
    ----------
    path : str or PathLike
        Destination; its folder must exist.
    data : bytes
        The whole file.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    ConfigError
        The folder does not exist, or the file cannot be written there (permissions, a
        directory of that name, a full disk); any earlier file at ``path`` is left as it was.
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise ConfigError(f"cannot write {str(target)!r}: folder {str(folder)!r} does not exist; create it first")
    if target.is_dir():
        raise ConfigError(f"cannot write {str(target)!r}: it is a directory; give a file name")
    try:
        atomic_write_bytes(target, data)
    except OSError as exc:
        raise ConfigError(f"cannot write {str(target)!r}: {exc.strerror or exc}; choose another location") from exc
    return target


# --------------------------------------------------------------------------- GeoJSON


def _crossing_lat(la0: float, lo0: float, la1: float, lo1: float) -> float:
    """Latitude where the great circle from (la0, lo0) to (la1, lo1) crosses the antimeridian [deg]."""
    east = lo0 > 0.0  # leaving the eastern side (lon → +180)
    lo, hi = 0.0, 1.0
    for _ in range(60):  # bisection on the fraction of the arc; 2^-60 of the arc
        mid = 0.5 * (lo + hi)
        _, lon_m, _ = gc_points(la0, lo0, la1, lo1, mid)
        if (float(lon_m) > 0.0) == east:
            lo = mid
        else:
            hi = mid
    lat_x, _, _ = gc_points(la0, lo0, la1, lo1, 0.5 * (lo + hi))
    return float(lat_x)


def split_antimeridian(latlon: np.ndarray) -> list[list[list[float]]]:
    """A polyline of great-circle legs as RFC 7946 line parts split at the antimeridian.

    Parameters
    ----------
    latlon : numpy.ndarray, shape (n, 2)
        (lat, lon) [deg] of the vertices; consecutive vertices are joined by great circles
        shorter than 180° of longitude.

    Returns
    -------
    list of list of [lon, lat]
        One part if the line does not cross the antimeridian, else one more part per crossing;
        a part ends at ``±180`` and the next starts at ``∓180`` at the same (great-circle)
        latitude. Longitudes in [-180, 180].
    """
    wp = np.asarray(latlon, dtype=float)
    lon = units.wrap_180(wp[:, 1])
    parts: list[list[list[float]]] = [[[float(lon[0]), float(wp[0, 0])]]]
    for k in range(wp.shape[0] - 1):
        la0, lo0, la1, lo1 = float(wp[k, 0]), float(lon[k]), float(wp[k + 1, 0]), float(lon[k + 1])
        # a vertex on the antimeridian is written as +180 or -180, whichever side its leg lies on
        if abs(lo0) == 180.0 and lo1 != 0.0 and abs(lo1) != 180.0:
            lo0 = math.copysign(180.0, lo1)
        if abs(lo1) == 180.0 and lo0 != 0.0:
            lo1 = math.copysign(180.0, lo0)
        if parts[-1][-1][0] != lo0:  # the previous leg ended on the other side's +-180
            parts.append([[lo0, la0]])
        if abs(lo1 - lo0) > 180.0:
            lat_x = _crossing_lat(la0, lo0, la1, lo1)
            edge = 180.0 if lo0 > 0.0 else -180.0
            parts[-1].append([edge, lat_x])
            parts.append([[-edge, lat_x]])
        parts[-1].append([float(lo1), float(la1)])
    return [p for p in parts if len(p) >= 2] or parts


def _line_geometry(latlon: np.ndarray) -> dict[str, Any]:
    parts = split_antimeridian(latlon)
    if len(parts) == 1:
        return {"type": "LineString", "coordinates": parts[0]}
    return {"type": "MultiLineString", "coordinates": parts}


def _json_value(x: Any) -> Any:
    """A JSON-safe scalar: numpy scalars unwrapped, NaN and ±inf as ``None``."""
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def _leg_quantities(plan: Plan, k: int) -> dict[str, Any]:
    row = plan.legs.iloc[k]
    return {col: _json_value(row[col]) for col in plan.legs.columns if col not in ("lat", "lon", "time")}


def geojson(plan: Plan) -> dict[str, Any]:
    """The plan as an RFC 7946 GeoJSON ``FeatureCollection`` (see the module docstring).

    Parameters
    ----------
    plan : Plan

    Returns
    -------
    dict
        JSON-serialisable with ``json.dumps(..., allow_nan=False)``.
    """
    wp = plan.waypoints
    track = {
        "type": "Feature",
        "geometry": _line_geometry(wp),
        "properties": {
            "kind": "track",
            "departure_utc": units.format_utc(plan.departure),
            "arrival_utc": units.format_utc(plan.arrival),
            "duration_h": _json_value(plan.duration_h),
            "distance_nm": _json_value(plan.distance_nm),
            "total_fuel_t": _json_value(plan.total_fuel_t),
            "status": plan.status,
            "eta_shadow_price_t_per_h": _json_value(plan.eta_shadow_price_t_per_h),
        },
    }
    features: list[dict[str, Any]] = [track]
    for k in range(wp.shape[0] - 1):
        props = {
            "kind": "leg",
            "leg": k,
            "start_time_utc": units.format_utc(plan.times[k]),
            "end_time_utc": units.format_utc(plan.times[k + 1]),
            **_leg_quantities(plan, k),
        }
        features.append({"type": "Feature", "geometry": _line_geometry(wp[k : k + 2]), "properties": props})
    for k in range(wp.shape[0]):
        props = {"kind": "waypoint", "index": k, "time_utc": units.format_utc(plan.times[k])}
        if k < wp.shape[0] - 1:
            props.update(_leg_quantities(plan, k))
        point = [float(units.wrap_180(wp[k, 1])), float(wp[k, 0])]
        features.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": point}, "properties": props})
    return {"type": "FeatureCollection", "features": features}


def write_geojson(plan: Plan, path: str | os.PathLike[str]) -> Path:
    """Write :func:`geojson` of ``plan`` to ``path`` atomically; return the path."""
    text = json.dumps(geojson(plan), indent=1, allow_nan=False) + "\n"
    return write_bytes(path, text.encode())


# --------------------------------------------------------------------------- CSV


def csv_frame(plan: Plan) -> pd.DataFrame:
    """The plan's legs as the CSV table: one row per leg, units in the column names."""
    wp = plan.waypoints
    lon = units.wrap_180(wp[:, 1])
    table: dict[str, Any] = {
        "leg": np.arange(wp.shape[0] - 1),
        "start_time_utc": [units.format_utc(t) for t in plan.times[:-1]],
        "end_time_utc": [units.format_utc(t) for t in plan.times[1:]],
        "start_lat_deg": wp[:-1, 0],
        "start_lon_deg": lon[:-1],
        "end_lat_deg": wp[1:, 0],
        "end_lon_deg": lon[1:],
    }
    for col in plan.legs.columns:
        if col not in ("lat", "lon", "time"):
            table[col] = plan.legs[col].to_numpy()
    return pd.DataFrame(table)


def csv_text(plan: Plan) -> str:
    """:func:`csv_frame` as CSV text (full float precision, ``inf`` where a band never applies)."""
    buf = io.StringIO()
    csv_frame(plan).to_csv(buf, index=False, lineterminator="\n")
    return buf.getvalue()


def write_csv(plan: Plan, path: str | os.PathLike[str]) -> Path:
    """Write :func:`csv_text` of ``plan`` to ``path`` atomically; return the path."""
    return write_bytes(path, csv_text(plan).encode())


# --------------------------------------------------------------------------- NetCDF


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
        v = _json_value(obj)
        return str(obj) if isinstance(v, float) and not math.isfinite(v) else v
    return str(obj)


def _time_encoding(departure: np.datetime64) -> dict[str, Any]:
    ref = str(np.datetime64(departure, "s")).replace("T", " ")
    return {"units": f"hours since {ref}", "calendar": "proleptic_gregorian", "dtype": "float64"}


def plan_dataset(plan: Plan) -> xr.Dataset:
    """The plan as a CF-1.8 ``xarray.Dataset``.

    Variables: every column of :attr:`Plan.legs` on ``leg`` (``leg_time``, ``leg_start_lat``,
    ``leg_start_lon`` for the leg start, the quantities under their own names), and
    ``waypoint_lat``, ``waypoint_lon``, ``waypoint_time`` on ``waypoint``; each with ``units``,
    ``long_name`` and, where CF has one, ``standard_name``. Times carry the encoding ``hours
    since <departure>``. Global attributes: ``Conventions``, ``title``, ``source``, ``history``,
    ``total_fuel_t``, ``duration_h``, ``distance_nm``, ``departure``, ``arrival``, ``status``,
    ``eta_shadow_price_t_per_h``, ``solver_stats`` (JSON), ``comment`` (direction conventions).
    """
    from optroute._version import __version__

    legs = plan.legs
    enc = _time_encoding(plan.departure)
    lat_attrs = {"units": "degrees_north", "standard_name": "latitude"}
    lon_attrs = {"units": "degrees_east", "standard_name": "longitude"}
    data: dict[str, xr.Variable] = {}
    for col in legs.columns:
        values = legs[col].to_numpy()
        if col == "time":
            var = xr.Variable(
                "leg",
                values.astype("datetime64[ns]"),
                {"standard_name": "time", "long_name": "time the ship starts the leg (UTC)"},
            )
            var.encoding = dict(enc)
            data["leg_time"] = var
        elif col == "lat":
            data["leg_start_lat"] = xr.Variable("leg", values, {**lat_attrs, "long_name": "latitude of the leg start"})
        elif col == "lon":
            data["leg_start_lon"] = xr.Variable(
                "leg", units.wrap_180(values), {**lon_attrs, "long_name": "longitude of the leg start"}
            )
        else:
            attrs = LEG_ATTRS.get(col) or (_margin_attrs(col) if col.startswith("margin_") else {"long_name": col})
            data[col] = xr.Variable("leg", values, dict(attrs))
    data["waypoint_lat"] = xr.Variable(
        "waypoint", plan.waypoints[:, 0], {**lat_attrs, "long_name": "waypoint latitude"}
    )
    data["waypoint_lon"] = xr.Variable(
        "waypoint", units.wrap_180(plan.waypoints[:, 1]), {**lon_attrs, "long_name": "waypoint longitude"}
    )
    wt = xr.Variable(
        "waypoint",
        np.asarray(plan.times, dtype="datetime64[ns]"),
        {"standard_name": "time", "long_name": "time the ship passes the waypoint (UTC)"},
    )
    wt.encoding = dict(enc)
    data["waypoint_time"] = wt
    now = np.datetime64("now", "s")
    attrs = {
        "Conventions": CF_CONVENTIONS,
        "title": "optroute voyage plan",
        "source": f"optroute {__version__}",
        "history": f"{now}Z created by optroute {__version__}",
        "total_fuel_t": float(plan.total_fuel_t),
        "duration_h": float(plan.duration_h),
        "distance_nm": float(plan.distance_nm),
        "departure": units.format_utc(plan.departure),
        "arrival": units.format_utc(plan.arrival),
        "status": str(plan.status),
        "eta_shadow_price_t_per_h": float(plan.eta_shadow_price_t_per_h),
        "solver_stats": json.dumps(_jsonable(plan.solver_stats)),
        "comment": "positions WGS 84 (lat, lon); times UTC; heading degrees true, the direction the ship goes to; "
        "wave_from_deg degrees true, the direction the waves come from",
    }
    return xr.Dataset(data, attrs=attrs)


def netcdf_bytes(ds: xr.Dataset) -> bytes:
    """``ds`` encoded as a NetCDF-4 file in memory (h5netcdf)."""
    return bytes(ds.to_netcdf(engine="h5netcdf"))


def write_netcdf(plan_or_dataset: Plan | xr.Dataset, path: str | os.PathLike[str]) -> Path:
    """Write a plan (:func:`plan_dataset`) or any dataset to NetCDF-4 at ``path`` atomically.

    The file is encoded in memory, then written under a temporary name and renamed over
    ``path``; returns the path.
    """
    ds = plan_or_dataset if isinstance(plan_or_dataset, xr.Dataset) else plan_dataset(plan_or_dataset)
    return write_bytes(path, netcdf_bytes(ds))
