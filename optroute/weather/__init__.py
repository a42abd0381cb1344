"""Weather: the canonical dataset, loaders for provider files, sampling and synthetic scenarios.

* :func:`open_weather` — NetCDF / Zarr / GRIB files of ERA5, CMEMS,
  WAVEWATCH III, GFS-Wave and GFS (THREDDS) as canonical datasets;
* :class:`WeatherSampler` — vectorised interpolation at (time, lat, lon);
* :mod:`optroute.weather.scenarios` — deterministic synthetic weather;
* :mod:`optroute.weather.schema` — canonical names, units and checks.
"""

from optroute.weather import scenarios
from optroute.weather.io import open_weather
from optroute.weather.sample import WeatherSampler, sample_weather

__all__ = ["WeatherSampler", "open_weather", "sample_weather", "scenarios"]
