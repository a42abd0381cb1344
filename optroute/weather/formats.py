"""Weather files: the format told from a file's first bytes, and the file opened with the matching engine.

:func:`open_path` is the file side of :func:`optroute.weather.io.open_weather`: it checks the
path exists, picks the xarray engine from the file's magic bytes (:func:`sniff_engine`: HDF5
for NetCDF-4, ``CDF\\x01``/``CDF\\x02`` for classic NetCDF, whose header is checked against the
file's length, ``GRIB`` for GRIB through cfgrib, a Zarr store's metadata files), opens it
lazily one time slice per dask chunk, and turns every failure of the readers into a
:class:`~optroute.errors.WeatherSchemaError` naming the file (a zip archive, an empty or
truncated file, GRIB messages ecCodes cannot decode). Naming and units are left to
:mod:`optroute.weather.io`.
"""

from __future__ import annotations

import contextlib
import logging
import os
import warnings
from collections.abc import Hashable, Mapping
from pathlib import Path
from typing import Any

import xarray as xr

from optroute.errors import ConfigError, WeatherSchemaError

__all__ = ["LAT_NAMES", "LON_NAMES", "has_module", "open_path", "sniff_engine", "slice_chunks"]

#: Latitude and longitude coordinate names of the providers (:mod:`optroute.weather.io` renames them).
LAT_NAMES = ("lat", "latitude", "Latitude", "LATITUDE", "LAT", "nav_lat")
LON_NAMES = ("lon", "longitude", "Longitude", "LONGITUDE", "LON", "nav_lon")

# ---------------------------------------------------------------------------
# opening files
# ---------------------------------------------------------------------------


def sniff_engine(path: Path) -> str:
    """Guess the engine from a file's first bytes (or a directory's Zarr metadata)."""
    if path.is_dir():
        if any((path / m).exists() for m in ("zarr.json", ".zgroup", ".zmetadata", ".zattrs")):
            return "zarr"
        raise WeatherSchemaError(f"{path}: is a directory but not a Zarr store (no zarr.json or .zgroup inside)")
    size = path.stat().st_size
    if size == 0:
        raise WeatherSchemaError(
            f"{path}: the file is empty (0 bytes); the download or the write failed — fetch it again"
        )
    with path.open("rb") as fh:
        head = fh.read(8)
    if head.startswith(b"\x89HDF"):
        return "netcdf4" if has_module("netCDF4") else "h5netcdf"
    if head.startswith(b"CDF\x01") or head.startswith(b"CDF\x02"):
        check_netcdf3_header(path)
        return "netcdf4" if has_module("netCDF4") else "scipy"
    if head.startswith(b"CDF\x05"):
        return "netcdf4"
    if head.startswith(b"GRIB") or path.suffix.lower() in (".grib", ".grib2", ".grb", ".grb2"):
        return "cfgrib"
    if head.startswith(b"PK\x03\x04"):
        raise WeatherSchemaError(
            f"{path}: is a zip archive, not a NetCDF file (the Copernicus CDS delivers ERA5 as a zip of NetCDF "
            "files); unzip it and open each file"
        )
    raise WeatherSchemaError(
        f"{path}: is not a NetCDF, HDF5/NetCDF-4, Zarr or GRIB file (first bytes {head!r}); "
        "the file is corrupted or of another format"
    )


def check_netcdf3_header(path: Path) -> None:
    """Parse a classic NetCDF header and check the file holds all the data it announces."""
    from scipy.io import netcdf_file

    try:
        with netcdf_file(path, "r", mmap=True) as nc:
            for var in list(nc.variables.values()):
                var.data  # noqa: B018 - touching each memory map checks the file reaches its end
    except (ValueError, TypeError, OSError, IndexError, EOFError) as exc:
        raise WeatherSchemaError(
            f"{path}: the classic NetCDF file is truncated or corrupted ({exc}); fetch or write it again"
        ) from exc


def has_module(name: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(name) is not None


def open_path(path: Path, engine: str | None, chunks: Any, backend_kwargs: Mapping[str, Any] | None) -> xr.Dataset:
    if not path.exists():
        raise WeatherSchemaError(f"{path}: no such file or directory; check the path (working directory {os.getcwd()})")
    engine = engine or sniff_engine(path)
    kwargs: dict[str, Any] = dict(backend_kwargs or {})
    if engine == "cfgrib":
        if not (has_module("cfgrib") and has_module("eccodes")):
            raise ConfigError(
                f'{path}: reading GRIB needs cfgrib and ecCodes; install them with pip install "optroute[grib]"'
            )
        kwargs.setdefault("indexpath", "")  # never write .idx files beside the data
    with _CfgribLog() if engine == "cfgrib" else contextlib.nullcontext() as grib_log:
        try:
            if isinstance(chunks, str) and chunks == "auto":
                raw = xr.open_dataset(path, engine=engine, chunks=None, cache=False, backend_kwargs=kwargs or None)
                out = raw.chunk(slice_chunks(raw))
            else:
                out = xr.open_dataset(path, engine=engine, chunks=chunks, backend_kwargs=kwargs or None)
        except (OSError, ValueError, RuntimeError, KeyError, TypeError, IndexError, EOFError) as exc:
            said = f"; ecCodes said: {grib_log.summary()}" if grib_log is not None and grib_log.records else ""
            raise WeatherSchemaError(
                f"{path}: could not be read with the {engine!r} engine ({type(exc).__name__}: {exc}){said}; "
                "the file is truncated, corrupted or not weather data"
            ) from exc
    if grib_log is not None and grib_log.records:
        warnings.warn(
            f"{path}: cfgrib skipped part of the file ({grib_log.summary()}); the rest was read — check that "
            "no time step or variable is missing",
            stacklevel=3,
        )
    return out


class _CfgribLog(logging.Handler):
    """Collects what cfgrib logs while it opens a file, instead of letting it print tracebacks.

    cfgrib logs every message it cannot decode with its traceback (``LOG.exception("skipping
    corrupted Message")``), hundreds of lines for a text file named ``.grib``; through Python's
    last-resort handler they reach stderr before the one error that matters.  While the file is
    opened the ``cfgrib`` logger sends its records here only (and cfgrib's warnings are held);
    :meth:`summary` turns them into one line for the error or warning raised instead.
    """

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []
        self._logger = logging.getLogger("cfgrib")
        self._saved: tuple[bool, int] = (True, logging.NOTSET)
        self._warnings = warnings.catch_warnings(record=True)
        self._caught: list[warnings.WarningMessage] | None = None

    def emit(self, record: logging.LogRecord) -> None:
        if record.levelno >= logging.WARNING:
            self.records.append(record)

    def __enter__(self) -> _CfgribLog:
        self._saved = (self._logger.propagate, self._logger.level)
        self._logger.addHandler(self)
        self._logger.propagate = False
        self._caught = self._warnings.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        caught = self._caught or []
        self._warnings.__exit__(*exc)
        for w in caught:  # cfgrib's own warnings are dropped; anybody else's pass on
            if "cfgrib" not in str(w.filename):
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        self._logger.removeHandler(self)
        self._logger.propagate, level = self._saved
        self._logger.setLevel(level)

    def summary(self) -> str:
        """``"<n> undecodable messages: <last error>"`` from the records collected."""
        last = self.records[-1]
        cause = f"{type(last.exc_info[1]).__name__}: {last.exc_info[1]}" if last.exc_info and last.exc_info[1] else ""
        text = last.getMessage() + (f" ({cause})" if cause else "")
        return f"{len(self.records)} x {text}" if len(self.records) > 1 else text


def slice_chunks(raw: xr.Dataset) -> dict[Hashable, int]:
    """Dask chunks of one time step (and one level) with whole horizontal fields.

    The sampler reads the time slices around its points; dask's ``"auto"``
    chunks would bundle dozens of time steps into one chunk and read them all.
    """
    spec: dict[Hashable, int] = {}
    for dim in raw.dims:
        coord = raw.coords.get(dim)
        horizontal = (
            dim in LAT_NAMES
            or dim in LON_NAMES
            or (coord is not None and coord.attrs.get("units") in ("degrees_north", "degrees_east"))
        )
        spec[dim] = -1 if horizontal else 1
    return spec
