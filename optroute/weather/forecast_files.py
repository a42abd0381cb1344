"""A set of forecast files, each with its issue time: the input of :func:`optroute.simulate_voyage`.

Real forecasts arrive as runs (ECMWF 00/06/12/18 UTC, GFS every 6 h), each usable only from its
issue time on. :func:`open_forecasts` opens each file with :func:`optroute.open_weather` and takes
its issue time from the file (:mod:`optroute.weather.reftime`: CF ``forecast_reference_time``, the
GRIB ``time`` beside ``step``) or from the caller, and returns the runs in issue order.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr

from optroute import units
from optroute.errors import ConfigError, WeatherSchemaError
from optroute.weather.io import open_weather
from optroute.weather.reftime import ATTR

__all__ = ["open_forecasts"]


def _name(source: Any) -> str:
    if isinstance(source, xr.Dataset):
        return str(source.encoding.get("source", "dataset"))
    return os.fspath(source)


def open_forecasts(
    sources: Sequence[str | os.PathLike[str] | xr.Dataset],
    *,
    issue_times: Sequence[Any] | None = None,
    **open_kwargs: Any,
) -> list[tuple[np.datetime64, xr.Dataset]]:
    """Open forecast runs as (issue time, canonical dataset) pairs sorted by issue time.

    Parameters
    ----------
    sources : sequence of path or xarray.Dataset
        One forecast run each (NetCDF, Zarr, GRIB or an opened dataset, any provider naming that
        :func:`optroute.open_weather` reads).
    issue_times : sequence, optional
        The runs' issue times [UTC] in the order of ``sources``; an entry None (or no sequence)
        takes the time the file states. A given time that differs from the file's is an error.
    **open_kwargs
        Passed to :func:`optroute.open_weather` (``engine``, ``chunks``, ``time_policy``, ...).

    Returns
    -------
    list of (numpy.datetime64, xarray.Dataset)
        Sorted by issue time; each dataset's ``attrs["forecast_reference_time"]`` holds its
        issue time. The form :func:`optroute.simulate_voyage` takes as ``forecasts``.

    Raises
    ------
    ConfigError
        ``sources`` is not a sequence, ``issue_times`` has another length, a given time differs
        from the file's, or two runs have the same issue time.
    WeatherSchemaError
        A file that does not state its issue time when none is given (the message names the
        file and both fixes), or any error of :func:`optroute.open_weather`.
    """
    if isinstance(sources, str | os.PathLike | xr.Dataset) or not isinstance(sources, Sequence):
        raise ConfigError(
            f"open_forecasts takes a list of forecast files, got {type(sources).__name__}; "
            "pass [path, ...] (open one file with open_weather)"
        )
    given = [None] * len(sources) if issue_times is None else list(issue_times)
    if len(given) != len(sources):
        raise ConfigError(f"issue_times has {len(given)} entries for {len(sources)} forecast files; give one each")
    runs: list[tuple[np.datetime64, xr.Dataset, str]] = []
    for source, want in zip(sources, given, strict=True):
        name = _name(source)
        ds = open_weather(source, **open_kwargs)
        stated = ds.attrs.get(ATTR)
        if want is not None:
            t = units.as_utc_time(want, f"issue time of {name}")
            if stated and np.datetime64(stated.rstrip("Z"), "ns") != t:
                raise ConfigError(
                    f"{name} states its issue time {stated} but {units.format_utc(t)} was given; "
                    "leave the issue time out to take the file's, or check which run this file is"
                )
        elif stated:
            t = np.datetime64(stated.rstrip("Z"), "ns")
        else:
            raise WeatherSchemaError(
                f"{name} does not state its issue time (no forecast_reference_time, no GRIB time beside step); "
                "pass issue_times=[...] (on the command line ISSUE=FILE), or set the file's "
                "forecast_reference_time"
            )
        ds.attrs[ATTR] = units.format_utc(t)
        runs.append((t, ds, name))
    runs.sort(key=lambda r: r[0])
    for (t1, _, a), (t2, _, b) in zip(runs, runs[1:], strict=False):
        if t1 == t2:
            raise ConfigError(
                f"{a} and {b} are both issued {units.format_utc(t1)}; give each run once (or their issue times)"
            )
    return [(t, ds) for t, ds, _ in runs]
