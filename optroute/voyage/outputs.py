"""The voyage log's files: NetCDF (the whole log), CSV (one row per step) and GeoJSON (track and plans).

Every file is encoded in memory and written atomically (:func:`optroute.plan.outputs.write_bytes`:
a temporary name in the same folder, then a rename), so an interrupted run leaves no half file.
"""

from __future__ import annotations

import io
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from optroute import units
from optroute.plan.outputs import write_bytes, write_netcdf

__all__ = ["log_csv_text", "log_geojson", "write_log"]

_STEP_COLUMNS = (
    "lat", "lon", "duration_h", "distance_nm", "commanded_stw_kn", "stw_kn", "sog_kn", "heading_deg", "power_kw",
    "fuel_t", "hs_m", "period_s", "wave_from_deg", "in_band", "band_met", "slowed",
)  # fmt: skip


def _num(x: Any) -> Any:
    v = float(x)
    return v if np.isfinite(v) else None


def log_csv_text(log: xr.Dataset) -> str:
    """One CSV row per simulator step: ``time_utc`` (ISO 8601 ``Z``), the step variables and ``margin_<band>``."""
    cols = [c for c in _STEP_COLUMNS if c in log] + sorted(v for v in log.data_vars if str(v).startswith("margin_"))
    buf = io.StringIO()
    buf.write(",".join(["step", "time_utc", *cols]) + "\n")
    for i in range(log.sizes.get("step", 0)):
        vals = [str(i), units.format_utc(log["step_time"].values[i])]
        vals += [f"{float(log[c].values[i]):.10g}" for c in cols]
        buf.write(",".join(vals) + "\n")
    return buf.getvalue()


def log_geojson(log: xr.Dataset) -> dict[str, Any]:
    """RFC 7946 FeatureCollection: the ``track`` sailed (a LineString of [lon, lat]) and one ``plan`` per (re-)plan.

    Plan features carry ``time_utc``, ``reason``, ``status``, ``forecast_issued_utc``, ``fuel_t`` and
    ``arrival_utc``; a failed re-plan has no geometry. Tracks across the antimeridian are not split.
    """
    lat, lon = log["lat"].values, log["lon"].values
    feats: list[dict[str, Any]] = []
    if lat.size:
        coords = [[float(a), float(b)] for a, b in zip(lon, lat, strict=True)]
        feats.append({"type": "Feature", "geometry": {"type": "LineString", "coordinates": coords},
                      "properties": {"kind": "track", "fuel_t": _num(log["fuel_t"].sum())}})  # fmt: skip
    for k in range(log.sizes.get("replan", 0)):
        wl, wo = log["replan_waypoint_lat"].values[k], log["replan_waypoint_lon"].values[k]
        ok = np.isfinite(wl) & np.isfinite(wo)
        geom = None
        if ok.sum() >= 2:
            geom = {
                "type": "LineString",
                "coordinates": [[float(a), float(b)] for a, b in zip(wo[ok], wl[ok], strict=True)],
            }
        issued = log["replan_forecast_issued"].values[k]
        arrival = log["replan_arrival"].values[k]
        feats.append({
            "type": "Feature",
            "geometry": geom,
            "properties": {
                "kind": "plan",
                "index": k,
                "time_utc": units.format_utc(log["replan_time"].values[k]),
                "reason": str(log["replan_reason"].values[k]),
                "status": str(log["replan_status"].values[k]),
                "forecast_issued_utc": None if np.isnat(issued) else units.format_utc(issued),
                "fuel_t": _num(log["replan_fuel_t"].values[k]),
                "arrival_utc": None if np.isnat(arrival) else units.format_utc(arrival),
            },
        })  # fmt: skip
    return {"type": "FeatureCollection", "features": feats}


def write_log(log: xr.Dataset, stem: str | os.PathLike[str]) -> list[Path]:
    """Write ``<stem>.nc``, ``<stem>.csv`` and ``<stem>.geojson`` atomically; return the paths."""
    base = Path(stem)
    nc = write_netcdf(log, base.with_suffix(".nc"))
    csv = write_bytes(base.with_suffix(".csv"), log_csv_text(log).encode())
    gj = write_bytes(base.with_suffix(".geojson"), json.dumps(log_geojson(log), allow_nan=False, indent=1).encode())
    return [nc, csv, gj]
