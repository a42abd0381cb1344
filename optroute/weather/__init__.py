"""Weather: the canonical dataset, loaders for provider files, sampling and synthetic scenarios.

* :func:`open_weather` — NetCDF / Zarr / GRIB files of ERA5, CMEMS,
  WAVEWATCH III, GFS-Wave and GFS (THREDDS) as canonical datasets;
* :func:`open_forecasts` — a set of forecast runs with their issue times (from the files);
* :class:`WeatherSampler` — vectorised interpolation at (time, lat, lon);
* :mod:`optroute.weather.scenarios` — deterministic synthetic weather;
* :func:`load_weather`, :func:`scenario`, :func:`scenario_names` — the
  built-in scenarios by name, or a file (:mod:`optroute.weather.catalogue`);
* :mod:`optroute.weather.schema` — canonical names, units and checks.
"""

from optroute.weather import scenarios
from optroute.weather.catalogue import load_weather, scenario, scenario_names
from optroute.weather.forecast_files import open_forecasts
from optroute.weather.io import open_weather
from optroute.weather.sample import WeatherSampler, sample_weather

__all__ = [
    "WeatherSampler",
    "load_weather",
    "open_forecasts",
    "open_weather",
    "sample_weather",
    "scenario",
    "scenario_names",
    "scenarios",
]
