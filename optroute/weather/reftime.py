"""The issue time (reference time) of a forecast file, read from the file itself.

Forecast centres write the run's issue time in a few standard places:

* ``forecast_reference_time`` — the CF standard name (CF conventions 1.8 §4.4, "forecast
  reference time"), as a scalar or length-one coordinate or variable (THREDDS/NCSS subsets of GFS,
  CMEMS forecasts, Copernicus products);
* ``time`` beside ``step`` or ``valid_time`` — the layout of GRIB files opened with cfgrib (ECMWF
  open data, ERA5/HRES GRIB, GFS GRIB2): ``time`` is the run's reference time (the GRIB
  ``dataDate``/``dataTime`` keys) and ``valid_time = time + step``;
* a global attribute ``forecast_reference_time`` (ISO 8601), as written by optroute.

An analysis or a reanalysis (ERA5 hourly NetCDF) has none of them: its issue time must be given.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from optroute.errors import WeatherSchemaError

__all__ = ["ATTR", "reference_time"]

ATTR = "forecast_reference_time"
"""The attribute under which :func:`optroute.open_weather` records a file's issue time (ISO 8601 UTC)."""


def _one_time(values: Any) -> np.datetime64 | None:
    """The one reference time of ``values``; None when there is none or several (an analysis, an aggregation)."""
    v = np.unique(np.asarray(values).astype("datetime64[ns]").ravel())
    v = v[~np.isnat(v)]
    return v[0] if v.size == 1 else None


def reference_time(raw: xr.Dataset, where: str = "dataset") -> np.datetime64 | None:
    """The issue time of the forecast run in ``raw`` [UTC], or None when the file does not say.

    Parameters
    ----------
    raw : xarray.Dataset
        The file as opened, with the provider's names (before canonicalisation).
    where : str
        The file's name for error messages.

    Returns
    -------
    numpy.datetime64 or None
        ``datetime64[ns]``, timezone-naive UTC; None also when the file holds several reference
        times (an analysis with one GRIB ``time`` per field, a "best estimate" aggregation).

    Raises
    ------
    WeatherSchemaError
        A ``forecast_reference_time`` attribute that is not an ISO 8601 time.
    """
    if ATTR in raw.variables:
        return _one_time(raw[ATTR].values)
    has_step = "step" in raw.coords and np.issubdtype(raw.coords["step"].dtype, np.timedelta64)
    if "time" in raw.coords and (has_step or "valid_time" in raw.coords):
        t = raw.coords["time"]
        if np.issubdtype(t.dtype, np.datetime64):
            return _one_time(t.values)
    text = raw.attrs.get(ATTR)
    if text:
        try:
            return np.datetime64(str(text).rstrip("Z"), "ns")
        except ValueError:
            raise WeatherSchemaError(
                f"{where}: the attribute {ATTR}={text!r} is not an ISO 8601 time; fix it or pass the issue time"
            ) from None
    return None
