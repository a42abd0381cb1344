"""The built-in weather scenarios by name, and one loader for "a name or a file".

Command lines, studies and benchmarks name their weather with a string:
either a built-in scenario, runnable with its defaults, or a weather file.
This module is the one table of those names.

* :func:`scenario_names` — the names, in a fixed order;
* :func:`scenario` — the canonical dataset of one name;
* :func:`load_weather` — a scenario name, else an existing file opened
  through :func:`optroute.weather.io.open_weather`.

Names (each with the defaults of its function in
:mod:`optroute.weather.scenarios`):

``calm``
    :func:`~optroute.weather.scenarios.calm` — no waves, no wind, whole globe.
``uniform``
    :func:`~optroute.weather.scenarios.uniform` — H_s 2 m from the north, whole globe.
``north_pacific_storms``
    :func:`~optroute.weather.scenarios.north_pacific_storms` — Boeing EP 2145155's
    San Diego → Tokyo storms.
``shao_case_1``, ``shao_case_2``
    :func:`~optroute.weather.scenarios.shao_case` ``(1)`` and ``(2)`` — seed
    001's case studies with their no-go rectangles.
``tropical_cyclone``
    :func:`~optroute.weather.scenarios.tropical_cyclone` — the typhoon-avoidance patent's
    moving typhoon with its default track.

(:func:`~optroute.weather.scenarios.moving_storm` needs a position, course
and speed, so it has no default and no name here.)

A scenario is built once per process and cached; every call returns a deep
copy, so a caller may modify the dataset it gets.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable
from pathlib import Path

import xarray as xr

from optroute.errors import ConfigError
from optroute.weather import scenarios as _sc
from optroute.weather.io import open_weather

__all__ = ["load_weather", "scenario", "scenario_names"]

_BUILDERS: dict[str, Callable[[], xr.Dataset]] = {
    "calm": _sc.calm,
    "uniform": _sc.uniform,
    "north_pacific_storms": _sc.north_pacific_storms,
    "shao_case_1": lambda: _sc.shao_case(1),
    "shao_case_2": lambda: _sc.shao_case(2),
    "tropical_cyclone": _sc.tropical_cyclone,
}


def scenario_names() -> tuple[str, ...]:
    """The built-in scenarios runnable by name with their defaults.

    Returns
    -------
    tuple of str
        In a fixed order: ``calm``, ``uniform``, ``north_pacific_storms``,
        ``shao_case_1``, ``shao_case_2``, ``tropical_cyclone``.
    """
    return tuple(_BUILDERS)


@functools.cache
def _built(name: str) -> xr.Dataset:
    ds = _BUILDERS[name]()
    ds.attrs["scenario_name"] = name
    return ds


def scenario(name: str) -> xr.Dataset:
    """The canonical weather dataset of a built-in scenario.

    Parameters
    ----------
    name : str
        One of :func:`scenario_names`.

    Returns
    -------
    xarray.Dataset
        A deep copy of the (cached) dataset, ``attrs["scenario_name"]`` set
        to ``name``.

    Raises
    ------
    ConfigError
        ``name`` is not a string or not a known scenario; the message lists
        the valid names.
    """
    if not isinstance(name, str) or name not in _BUILDERS:
        raise ConfigError(
            f"scenario {name!r} is not a built-in weather scenario; use one of {', '.join(scenario_names())}, "
            "or call a function of optroute.weather.scenarios for other parameters"
        )
    return _built(name).copy(deep=True)


def load_weather(source: str | os.PathLike[str]) -> xr.Dataset:
    """Weather by name or by file: a built-in scenario, else a weather file.

    Parameters
    ----------
    source : str or path
        A name from :func:`scenario_names` (tried first), or the path of an
        existing NetCDF / Zarr / GRIB file, opened with
        :func:`~optroute.weather.io.open_weather` and its defaults.

    Returns
    -------
    xarray.Dataset
        A canonical weather dataset.

    Raises
    ------
    ConfigError
        ``source`` is neither a scenario name nor an existing path; the
        message names the value and lists the valid scenario names.
    WeatherSchemaError
        The file exists but is not a usable weather file (from
        :func:`~optroute.weather.io.open_weather`).
    """
    if isinstance(source, str) and source in _BUILDERS:
        return scenario(source)
    if not isinstance(source, str | os.PathLike):
        raise ConfigError(
            f"load_weather: got a {type(source).__name__} ({source!r}); pass a scenario name "
            f"({', '.join(scenario_names())}) or the path of a weather file"
        )
    path = Path(source)
    if not path.exists():
        raise ConfigError(
            f"weather {os.fspath(source)!r} is neither a built-in scenario nor an existing file; "
            f"use one of {', '.join(scenario_names())}, or the path of a NetCDF/Zarr/GRIB weather file"
        )
    return open_weather(path)
