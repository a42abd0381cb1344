"""Where a ship can go: the land mask, the weather's no-passage cells, port snapping.

The coastline comes from the **GLOBE** 30-arc-second (about 1 km) land/sea
mask shipped in the PyPI package ``global-land-mask`` (Karin, 2020,
https://github.com/toddkarin/global-land-mask; data: GLOBE Task Team, 1999,
*The Global Land One-kilometer Base Elevation (GLOBE) Digital Elevation
Model, Version 1.0*, NOAA NGDC).  Lakes count as land.  The package itself
decompresses the whole mask into a 933 MB boolean array when it is imported;
optroute never imports it: it reads the same cells bit-packed in 1° latitude
bands from a copy packaged with it (:mod:`optroute.geo._globe_bits`, checked
against the installed file's SHA-256), inflating a band the first time a
look-up needs it (a few milliseconds), so the answers are those of
``global_land_mask.globe.is_land``.

``roaring-landmask`` (GSHHG full-resolution shoreline, Wessel & Smith 1996)
is the second backend, ``land_mask("gshhg")``: it is closer to
OpenStreetMap at the coast but needs a 100 MB wheel, 6–8 s and about
1.3 GB to start, and is 5–10 times slower per point.  The default is GLOBE
when ``global-land-mask`` is installed, else GSHHG; the environment
variable ``OPTROUTE_LAND_MASK=globe|gshhg`` or the ``mask=`` argument of
every function chooses explicitly.

Everything here is vectorised over numpy arrays, takes positions in degrees
(lat north, lon east; any longitude, wrapped to [-180, 180) internally) and
works across the antimeridian.

Public functions
----------------
:func:`is_land`
    Land or not, from the coastline only.
:func:`navigable`
    Sea **and** not a NaN ("no passage") cell of a weather dataset.
:func:`snap_to_sea`
    Move a start or end point (ports lie on land) to the nearest navigable
    point with clear water around it, with a warning; :class:`OnLandError`
    beyond the limit.
:func:`leg_crosses_land`, :func:`legs_cross_land`
    Whether a great-circle leg touches land (or no-passage weather) at a
    stated resolution.

Datasets whose ``attrs["geography"] == "synthetic"`` (the Shao case studies
of :mod:`optroute.weather.scenarios`) declare that real coastlines do not
apply to them: their NaN cells are the only obstacles, and
:func:`navigable` then skips the land mask unless told otherwise.
"""

from __future__ import annotations

import functools
import importlib.util
import math
import os
import threading
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError, OnLandError, WeatherSchemaError
from optroute.geo import _globe_bits

__all__ = [
    "DEFAULT_CLEARANCE_NM",
    "DEFAULT_LEG_RESOLUTION_NM",
    "DEFAULT_SNAP_DISTANCE_NM",
    "GlobeLandMask",
    "GshhgLandMask",
    "LandMask",
    "PackedLand",
    "coastline_applies",
    "is_land",
    "default_land_mask_name",
    "land_mask",
    "leg_crosses_land",
    "legs_cross_land",
    "navigable",
    "packed_land",
    "packed_land_available",
    "snap_to_sea",
    "weather_nan",
]

DEFAULT_SNAP_DISTANCE_NM = 20.0
"""How far :func:`snap_to_sea` may move a point [nm] by default (a pilotage approach)."""

DEFAULT_CLEARANCE_NM = 0.5
"""Clear water required all round a snapped point [nm]: a quay is not a waypoint."""

DEFAULT_LEG_RESOLUTION_NM = 0.5
"""Spacing of the points checked along a leg [nm]: about one GLOBE cell (0.93 km)."""

SYNTHETIC_GEOGRAPHY = "synthetic"
"""Value of ``attrs["geography"]`` for datasets to which real coastlines do not apply."""


class LandMask(Protocol):
    """What optroute needs of a coastline source.

    Attributes
    ----------
    name : str
        Short name (``"globe"``, ``"gshhg"``).
    resolution_nm : float
        Typical cell size or accuracy of the coastline [nm].
    """

    name: str
    resolution_nm: float

    def is_land(self, lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
        """Boolean array, True on land, for lat [deg] and lon [deg] in [-180, 180)."""
        ...


def _package_dir(package: str) -> Path:
    """Directory of an installed package, found without importing it."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise ConfigError(
            f"the land mask needs the package {package.replace('_', '-')!r}, which is not installed; "
            + (
                'pip install "optroute[gshhg]"'
                if package == "roaring_landmask"
                else f"pip install {package.replace('_', '-')}"
            )
        )
    return Path(next(iter(spec.submodule_search_locations)))


@dataclass(frozen=True, eq=False)
class PackedLand:
    """Rows of the GLOBE mask, bit-packed (8 cells a byte, the first in the high bit), for compiled look-ups.

    A point ``(lat, lon)`` [deg], clipped to ``lat_range`` and ``lon_range``, is land when bit ``j & 7`` (from
    the high end) of ``bits[i - row0, j >> 3]`` is set, with ``i`` and ``j`` the truncated
    ``(lat - lat0) / dlat`` and ``(lon - lon0) / dlon`` clipped to ``[0, nlat)`` and ``[0, nlon)``: the look-up
    of :meth:`GlobeLandMask.is_land`.  Rows outside ``bits`` are not loaded.
    """

    bits: np.ndarray
    row0: int
    lat0: float
    dlat: float
    lon0: float
    dlon: float
    nlat: int
    nlon: int
    lat_range: tuple[float, float]
    lon_range: tuple[float, float]

    def lat_deg_bounds(self) -> tuple[float, float]:
        """The latitudes [deg] the loaded rows cover, (south, north)."""
        a = self.lat0 + self.row0 * self.dlat
        b = self.lat0 + (self.row0 + self.bits.shape[0]) * self.dlat
        return min(a, b), max(a, b)


def _mask_of(mask: LandMask | str | None) -> LandMask:
    """The land mask itself, from a mask, its name or None (the default)."""
    return land_mask(mask) if mask is None or isinstance(mask, str) else mask


def packed_land_available(mask: LandMask | str | None = None) -> bool:
    """Whether the mask has packed cells (:func:`packed_land`) that searches can walk legs on (GLOBE; not GSHHG)."""
    return getattr(_mask_of(mask), "packed_rows", None) is not None


def packed_land(lat_min_deg: float, lat_max_deg: float, *, mask: LandMask | str | None = None) -> PackedLand | None:
    """The coastline between two latitudes [deg] as :class:`PackedLand`; None for a mask without packed cells
    (GSHHG), whose users fall back to point look-ups."""
    rows = getattr(_mask_of(mask), "packed_rows", None)
    return None if rows is None else rows(float(lat_min_deg), float(lat_max_deg))


class GlobeLandMask:
    """The GLOBE 1 km land mask of ``global-land-mask``, bit-packed.

    The file ``globe_combined_mask_compressed.npz`` holds ``mask`` (True on
    the ocean) on a 21 600 × 43 200 grid with ``lat`` from 90° down in steps
    of 1/120° and ``lon`` from −180° up in steps of 1/120°.  A point falls in
    the cell whose index is the truncated ``(x − x0) / dx``, exactly as in
    ``global_land_mask.globe``.

    By default the cells come from the copy packaged with optroute in 1° latitude bands
    (:mod:`optroute.geo._globe_bits`), each inflated when a look-up first needs it, provided the
    installed file has the SHA-256 the copy was built from; otherwise, or with an explicit ``path``,
    the whole file is streamed into memory once (about 3 s).

    Parameters
    ----------
    path : path-like, optional
        The ``.npz`` file; by default the one inside the installed package.
    """

    name = "globe"
    resolution_nm = 0.5

    def __init__(self, path: str | Path | None = None) -> None:
        banded = None
        if path is None:
            path = _package_dir("global_land_mask") / _globe_bits.SOURCE_NAME
            if _globe_bits.PACKED_PATH.is_file():
                candidate = _globe_bits.BandedBits()
                if candidate.source_sha256 == _globe_bits.sha256_of(path):
                    banded = candidate
        self.path = Path(path)
        axes = banded.axes if banded is not None else _globe_bits.read_axes(self.path)
        lat0, lat_last, lat_min, lat_max, lon0, lon_last, lon_min, lon_max = (float(a) for a in axes[:8])
        self._nlat, self._nlon = int(axes[8]), int(axes[9])
        self._lat0, self._dlat = lat0, (lat_last - lat0) / (self._nlat - 1)
        self._lon0, self._dlon = lon0, (lon_last - lon0) / (self._nlon - 1)
        self._lat_range = (lat_min, lat_max)
        self._lon_range = (lon_min, lon_max)
        self._banded = banded
        if banded is not None:
            self._land_bits = banded.bits
        else:
            self._land_bits = _globe_bits.stream_packed(self.path, (self._nlat, self._nlon))

    def _need_rows(self, rows: np.ndarray) -> None:
        """Inflate the packaged bands holding ``rows`` (nothing to do for a streamed mask)."""
        if self._banded is not None:
            self._banded.ensure_rows(rows)

    def any_land_in_box(self, lat_min: float, lat_max: float, lon_min: float, lon_max: float) -> bool:
        """Whether any cell touching the box [deg] is land (conservative by up to 8 cells in longitude).

        The box must not cross the antimeridian (``-180 <= lon_min <= lon_max < 180``); callers split
        or fall back to point look-ups otherwise.
        """
        i0 = int(np.clip((lat_max - self._lat0) / self._dlat, 0, self._nlat - 1))
        i1 = int(np.clip((lat_min - self._lat0) / self._dlat, 0, self._nlat - 1))
        j0 = int(np.clip((lon_min - self._lon0) / self._dlon, 0, self._nlon - 1))
        j1 = int(np.clip((lon_max - self._lon0) / self._dlon, 0, self._nlon - 1))
        self._need_rows(np.arange(min(i0, i1), max(i0, i1) + 1))
        return bool(self._land_bits[min(i0, i1) : max(i0, i1) + 1, j0 >> 3 : (j1 >> 3) + 1].any())

    def packed_rows(self, lat_min_deg: float, lat_max_deg: float) -> PackedLand:
        """The mask's bit-packed rows from ``lat_min_deg`` to ``lat_max_deg`` [deg], inflated, for compiled look-ups
        that answer as :meth:`is_land` does (:class:`PackedLand`)."""
        i_lo, i_hi = (
            int(np.clip((v - self._lat0) / self._dlat, 0, self._nlat - 1)) for v in (lat_max_deg, lat_min_deg)
        )
        lo, hi = min(i_lo, i_hi), max(i_lo, i_hi)
        self._need_rows(np.arange(lo, hi + 1))
        return PackedLand(
            self._land_bits[lo : hi + 1], lo, self._lat0, self._dlat, self._lon0, self._dlon, self._nlat, self._nlon,
            self._lat_range, self._lon_range,
        )  # fmt: skip

    def is_land(self, lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
        """True on land [bool array] for lat [deg] and lon [deg] in [-180, 180)."""
        lat = np.clip(np.asarray(lat_deg, dtype=float), *self._lat_range)
        lon = np.clip(np.asarray(lon_deg, dtype=float), *self._lon_range)
        i = np.clip(((lat - self._lat0) / self._dlat).astype(np.int64), 0, self._nlat - 1)
        j = np.clip(((lon - self._lon0) / self._dlon).astype(np.int64), 0, self._nlon - 1)
        self._need_rows(i)
        byte = self._land_bits[i, j >> 3]
        return ((byte >> (7 - (j & 7)).astype(np.uint8)) & 1).astype(bool)


class GshhgLandMask:
    """The GSHHG full-resolution shoreline through ``roaring-landmask`` (optional)."""

    name = "gshhg"
    resolution_nm = 0.1

    def __init__(self) -> None:
        _package_dir("roaring_landmask")
        from roaring_landmask import RoaringLandmask

        self._mask = RoaringLandmask.new()

    def is_land(self, lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
        """True on land [bool array] for lat [deg] and lon [deg] in [-180, 180)."""
        lat = np.ascontiguousarray(np.asarray(lat_deg, dtype=float).ravel())
        lon = np.ascontiguousarray(np.asarray(lon_deg, dtype=float).ravel())
        return np.asarray(self._mask.contains_many(lon, lat), dtype=bool).reshape(np.shape(lat_deg))


_BACKENDS: dict[str, type] = {"globe": GlobeLandMask, "gshhg": GshhgLandMask}
_LOCK = threading.Lock()


@functools.cache
def _cached_mask(name: str) -> LandMask:
    return _BACKENDS[name]()


LAND_MASK_ENV = "OPTROUTE_LAND_MASK"
"""Environment variable naming the default land mask (``globe`` or ``gshhg``)."""


def default_land_mask_name() -> str:
    """The backend used when none is named.

    ``$OPTROUTE_LAND_MASK`` if set; otherwise ``"globe"`` when
    ``global-land-mask`` is installed, else ``"gshhg"`` when
    ``roaring-landmask`` is.

    Raises
    ------
    ConfigError
        Neither package is installed (and no variable is set).
    """
    name = os.environ.get(LAND_MASK_ENV, "").strip().lower()
    if name:
        return name
    for name, package in (("globe", "global_land_mask"), ("gshhg", "roaring_landmask")):
        if importlib.util.find_spec(package) is not None:
            return name
    raise ConfigError('no coastline data is installed; pip install global-land-mask (or pip install "optroute[gshhg]")')


def land_mask(name: str | None = None) -> LandMask:
    """The process-wide land mask of a backend, built on first use.

    Parameters
    ----------
    name : {"globe", "gshhg"}, optional
        ``"globe"``: GLOBE 1 km through ``global-land-mask`` (preferred);
        ``"gshhg"``: GSHHG through ``roaring-landmask``.  Default:
        :func:`default_land_mask_name`.

    Returns
    -------
    LandMask
    """
    if name is None:
        name = default_land_mask_name()
    if name not in _BACKENDS:
        raise ConfigError(f"unknown land mask {name!r}; use one of {sorted(_BACKENDS)}")
    with _LOCK:
        return _cached_mask(name)


def _positions(lat_deg: ArrayLike, lon_deg: ArrayLike, what: str = "") -> tuple[np.ndarray, np.ndarray]:
    lat = finite(f"{what}lat_deg", lat_deg, error=ConfigError)
    lon = finite(f"{what}lon_deg", lon_deg, error=ConfigError)
    if np.any(np.abs(lat) > 90.0):
        bad = lat[np.abs(lat) > 90.0].flat[0]
        raise ConfigError(f"{what}latitude {bad!r} deg is outside [-90, 90]; pass (lat, lon) in degrees")
    lat, lon = np.broadcast_arrays(lat, lon)
    return lat, units.wrap_180(lon)


def is_land(lat_deg: ArrayLike, lon_deg: ArrayLike, *, mask: LandMask | str | None = None) -> np.ndarray:
    """Whether positions lie on land (coastline only, weather ignored).

    Parameters
    ----------
    lat_deg, lon_deg : array_like
        Positions [deg]; any longitude (wrapped to [-180, 180)).
    mask : LandMask or str, optional
        The coastline source or its name; default :func:`default_land_mask_name`.

    Returns
    -------
    ndarray of bool
        True on land (lakes included), broadcast shape of the inputs.
    """
    lat, lon = _positions(lat_deg, lon_deg)
    return np.asarray(_mask_of(mask).is_land(lat, lon), dtype=bool).reshape(lat.shape)


# --------------------------------------------------------------------------- weather NaN cells


_EPS = 1e-7


def _axis_stencil(axis: np.ndarray, q: np.ndarray, periodic: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lower and upper neighbour indices of ``q`` on an increasing ``axis``, and whether ``q`` is inside it.

    The stencil is the one of :class:`optroute.weather.WeatherSampler`: the
    lower index is ``floor`` of the position clipped to [0, n - 2], and both
    neighbours count (a NaN neighbour spoils the interpolated value even with
    weight 0).  A one-point axis covers only its own value.
    """
    n = axis.size
    if n == 1:
        zero = np.zeros(q.shape, dtype=np.int64)
        return zero, zero, np.abs(q - axis[0]) <= _EPS * max(1.0, abs(float(axis[0])))
    if periodic:
        step = (axis[-1] - axis[0]) / (n - 1)
        i0 = np.clip(np.floor((q - axis[0]) / step), 0, n - 1).astype(np.int64)
        return i0, (i0 + 1) % n, np.ones(q.shape, dtype=bool)
    inside = (q >= axis[0] - _EPS) & (q <= axis[-1] + _EPS)
    step = (axis[-1] - axis[0]) / (n - 1)
    if np.allclose(np.diff(axis), step, rtol=1e-9, atol=1e-9 * abs(step)):  # uniform: the sampler's arithmetic
        i0 = np.clip(np.floor((q - axis[0]) / step), 0, n - 2).astype(np.int64)
    else:
        i0 = np.clip(np.searchsorted(axis, q, side="right") - 1, 0, n - 2)
    return i0, i0 + 1, inside


def _weather_lon_axis(weather: Any) -> tuple[np.ndarray, bool]:
    """The dataset's longitudes as one increasing piece, and whether the grid wraps round the globe."""
    from optroute.weather import schema

    lon = np.asarray(weather["lon"].values, dtype=float)
    lon_u = geo.unwrap_lon_deg(lon)
    if lon_u.size > 1 and np.any(np.diff(lon_u) <= 0):
        raise WeatherSchemaError(
            "the weather dataset's longitudes are not increasing even after unwrapping across the antimeridian "
            f"(first values {lon[:4].tolist()}); open the data with optroute.open_weather, which normalises them"
        )
    return lon_u, schema.lon_is_periodic(lon_u)


def weather_nan(weather: Any, lat_deg: ArrayLike, lon_deg: ArrayLike, time: Any = None) -> np.ndarray:
    """Whether the weather marks positions as "no passage" (or does not cover them).

    A point is blocked when any grid value of ``hs_m`` in its interpolation
    stencil (the 2 x 2 cell around it, and with a time the two bracketing
    time slices) is NaN, i.e. exactly when
    :class:`optroute.weather.WeatherSampler` would return NaN there.  With
    ``time=None`` only cells that are NaN at every time count (land in a wave
    model), so moving no-go areas are ignored.  Points outside the dataset's
    area or time span are blocked too (times are clipped to the span when
    ``attrs["time_policy"] == "hold"``).

    Parameters
    ----------
    weather : xarray.Dataset
        Canonical dataset (coords ``time``, ``lat`` increasing, ``lon``
        increasing after unwrapping).
    lat_deg, lon_deg : array_like
        Positions [deg].
    time : datetime64 or array_like of datetime64, optional
        Time(s) [UTC], broadcast against the positions.

    Returns
    -------
    ndarray of bool
        True where the weather blocks passage.
    """
    if "hs_m" not in weather:
        raise WeatherSchemaError("the weather dataset has no 'hs_m'; open it with optroute.open_weather")
    lat, lon = _positions(lat_deg, lon_deg)
    lat_axis = np.asarray(weather["lat"].values, dtype=float)
    if lat_axis.size > 1 and np.any(np.diff(lat_axis) <= 0):
        raise WeatherSchemaError(
            "the weather dataset's latitudes are not strictly increasing; open it with optroute.open_weather"
        )
    lon_axis, periodic = _weather_lon_axis(weather)
    lon_q = lon_axis[0] + np.mod(lon - lon_axis[0], 360.0)
    lon_q = np.where(lon_q > lon_axis[0] + 360.0 - _EPS, lon_q - 360.0, lon_q)
    yi0, yi1, y_in = _axis_stencil(lat_axis, lat)
    xi0, xi1, x_in = _axis_stencil(lon_axis, lon_q, periodic)
    covered = y_in & x_in

    hs = weather["hs_m"]
    if time is None:
        nan_all = hs.isnull().all("time") if "time" in hs.dims else hs.isnull()
        grid = np.asarray(nan_all.transpose("lat", "lon").values, dtype=bool)
        blocked = grid[yi0, xi0] | grid[yi0, xi1] | grid[yi1, xi0] | grid[yi1, xi1]
        return blocked | ~covered

    t_ns = np.asarray(weather["time"].values).astype("datetime64[ns]").astype(np.int64)
    times = (t_ns - t_ns[0]) / 1e9  # seconds since the first time, as the sampler counts
    try:
        tq = np.asarray(time, dtype="datetime64[ns]")
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"time={time!r} is not a datetime64 (UTC, timezone-naive)") from exc
    if np.isnat(tq).any():
        raise ConfigError("time holds NaT; pass valid UTC times")
    tq = np.broadcast_to((tq.astype(np.int64) - t_ns[0]) / 1e9, lat.shape)
    if weather.attrs.get("time_policy") == "hold":
        tq = np.clip(tq, times[0], times[-1])
    ti0, ti1, t_in = _axis_stencil(times, tq)
    covered &= t_in
    # Load only the box of grid values the stencils touch (a dask-backed dataset stays lazy elsewhere).
    idx = [np.concatenate([a.ravel(), b.ravel()]) for a, b in ((ti0, ti1), (yi0, yi1), (xi0, xi1))]
    lo = [int(i.min()) if i.size else 0 for i in idx]
    hi = [int(i.max()) + 1 if i.size else 1 for i in idx]
    box = hs.transpose("time", "lat", "lon").isel(
        time=slice(lo[0], hi[0]), lat=slice(lo[1], hi[1]), lon=slice(lo[2], hi[2])
    )
    nan_box = np.isnan(np.asarray(box.values, dtype=float))
    corner_nan = np.zeros(lat.shape, dtype=bool)
    for ti in (ti0, ti1):
        for yi in (yi0, yi1):
            for xi in (xi0, xi1):
                corner_nan |= nan_box[ti - lo[0], yi - lo[1], xi - lo[2]]
    return corner_nan | ~covered


def coastline_applies(weather: Any, use_land_mask: bool | None) -> bool:
    """Whether the real coastline applies: ``use_land_mask`` when given, else unless ``weather`` (a dataset, or
    None) declares a synthetic geography (``attrs["geography"] ==`` :data:`SYNTHETIC_GEOGRAPHY`)."""
    if use_land_mask is not None:
        return bool(use_land_mask)
    return not (weather is not None and weather.attrs.get("geography") == SYNTHETIC_GEOGRAPHY)


def navigable(
    lat_deg: ArrayLike,
    lon_deg: ArrayLike,
    weather: Any = None,
    time: Any = None,
    *,
    use_land_mask: bool | None = None,
    mask: LandMask | str | None = None,
) -> np.ndarray:
    """Whether a ship may be at these positions: at sea and not in a no-passage weather cell.

    Parameters
    ----------
    lat_deg, lon_deg : array_like
        Positions [deg]; any longitude.
    weather : xarray.Dataset, optional
        Canonical weather; its NaN ``hs_m`` cells (land or ice in a wave
        model, no-go areas of a scenario) are not navigable, nor are points
        outside its area or time span (see :func:`weather_nan`).
    time : datetime64 or array_like, optional
        Time(s) [UTC] at which to read the weather; ``None`` uses only the
        cells that are NaN at every time.
    use_land_mask : bool, optional
        Apply the real coastline.  Default: yes, unless ``weather`` declares
        ``attrs["geography"] == "synthetic"``.
    mask : LandMask or str, optional
        The coastline source or its name; default :func:`default_land_mask_name`.

    Returns
    -------
    ndarray of bool
        True where navigable.
    """
    lat, lon = _positions(lat_deg, lon_deg)
    ok = np.ones(lat.shape, dtype=bool)
    if coastline_applies(weather, use_land_mask):
        ok &= ~is_land(lat, lon, mask=mask)
    if weather is not None:
        ok &= ~weather_nan(weather, lat, lon, time)
    return ok


def _local_grid(
    lat0: float, lon0: float, radius_nm: float, step_nm: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A square grid of points around (lat0, lon0) on a local equirectangular plane [nm]."""
    n = int(math.ceil(radius_nm / step_nm))
    off = np.arange(-n, n + 1) * step_nm
    x, y = np.meshgrid(off, off)  # x east, y north [nm], shape (2n+1, 2n+1)
    lat = np.clip(lat0 + y / 60.0, -90.0, 90.0)
    coslat = max(math.cos(math.radians(lat0)), 1e-6)
    lon = units.wrap_180(lon0 + x / (60.0 * coslat))
    return x, y, lat, lon


def _erode_disk(ok: np.ndarray, radius: float, step: float) -> np.ndarray:
    """Erode a boolean grid by the disk ``|offset| <= radius`` (grid spacing ``step``), outside = blocked.

    The same cells as :func:`scipy.ndimage.binary_erosion` with that disk and ``border_value=0``,
    done as a Euclidean distance transform: O(cells) instead of O(cells x disk cells) — the erosion
    took 7–13 s per port with the default clearance.  A cell survives when the nearest blocked cell,
    or the outside, is farther than ``radius`` (lengths in the same unit as ``step``).
    """
    from scipy import ndimage

    padded = np.pad(ok, 1, constant_values=False)
    return ndimage.distance_transform_edt(padded)[1:-1, 1:-1] > (radius + 1e-9) / step


def snap_to_sea(
    lat_deg: float,
    lon_deg: float,
    max_distance_nm: float = DEFAULT_SNAP_DISTANCE_NM,
    *,
    clearance_nm: float = DEFAULT_CLEARANCE_NM,
    step_nm: float | None = None,
    weather: Any = None,
    time: Any = None,
    use_land_mask: bool | None = None,
    mask: LandMask | str | None = None,
    what: str = "point",
    fix: str = "give a position at sea or raise max_distance_nm",
) -> tuple[float, float]:
    """Move a start or end point (ports lie on land) to the nearest navigable water.

    A point is kept as it is when every point within ``clearance_nm`` of it
    is navigable (see :func:`navigable`).  Otherwise the nearest point that
    has that clearance, within ``max_distance_nm`` (great-circle distance),
    is returned with a :class:`UserWarning` naming both positions and the
    distance.  Candidates lie on a local grid of spacing ``step_nm``; the
    clearance is checked on the same grid out to ``clearance_nm + sqrt(2) *
    step_nm``, which catches every land (or no-passage) cell at least one
    step wide that comes within ``clearance_nm``.

    Parameters
    ----------
    lat_deg, lon_deg : float
        The position [deg].
    max_distance_nm : float
        How far the point may move [nm], > 0.
    clearance_nm : float
        Radius of clear water required around the returned point [nm], >= 0.
    step_nm : float, optional
        Candidate spacing [nm]; default ``max(0.1, max_distance_nm / 200)``
        (0.1 nm is a fifth of a GLOBE cell).
    weather, time, use_land_mask, mask
        As in :func:`navigable`.
    what : str
        What the point is (``"start"``, ``"end"``), for messages.
    fix : str
        The fix the error names: the caller's user may have no ``max_distance_nm`` to raise
        (:func:`optroute.search_route` and the command line pass their own).

    Returns
    -------
    lat, lon : float
        The navigable position [deg], lon in [-180, 180).

    Raises
    ------
    OnLandError
        No navigable point with the clearance lies within ``max_distance_nm``.
    """
    lat_a, lon_a = _positions(lat_deg, lon_deg, f"{what} ")
    if lat_a.ndim != 0:
        raise ConfigError(f"snap_to_sea takes one position, got arrays of shape {lat_a.shape}; call it per point")
    lat0, lon0 = float(lat_a), float(lon_a)
    max_d = float(finite("max_distance_nm", max_distance_nm, minimum=0.0, strict=True, error=ConfigError))
    clear = float(finite("clearance_nm", clearance_nm, minimum=0.0, error=ConfigError))
    step = (
        max(0.1, max_d / 200.0)
        if step_nm is None
        else float(finite("step_nm", step_nm, minimum=0.0, strict=True, error=ConfigError))
    )
    # A land cell at least one step wide that reaches into the clearance disk holds a candidate
    # within clearance + sqrt(2) steps of the centre: erode with that radius.
    reach = clear + math.sqrt(2.0) * step if clear > 0.0 else 0.0
    x, y, glat, glon = _local_grid(lat0, lon0, max_d + reach, step)
    ok = navigable(glat, glon, weather, time, use_land_mask=use_land_mask, mask=mask)
    if clear > 0.0:
        ok = _erode_disk(ok, reach, step)
    c = ok.shape[0] // 2
    if ok[c, c]:
        return lat0, float(lon_a)
    dist = np.full(ok.shape, np.inf)  # distances only where a candidate can lie: the navigable cells
    dist[ok] = geo.distance_nm(lat0, lon0, glat[ok], glon[ok])
    cand = ok & (dist <= max_d)
    if not cand.any():
        raise OnLandError(
            f"{what} ({lat0:.4f}, {lon0:.4f}) is on land or within {clear:g} nm of it "
            f"(or in a no-passage weather cell), and no navigable point with {clear:g} nm of clear water lies "
            f"within the searched radius of {max_d:g} nm (checked every {step:g} nm); "
            f"{fix}"
        )
    k = np.flatnonzero(cand.ravel())[np.argmin(dist.ravel()[cand.ravel()])]
    new_lat, new_lon, d = float(glat.ravel()[k]), float(glon.ravel()[k]), float(dist.ravel()[k])
    warnings.warn(
        f"{what} ({lat0:.4f}, {lon0:.4f}) is on land or within {clear:g} nm of it; moved {d:.2f} nm "
        f"to the nearest navigable water at ({new_lat:.4f}, {new_lon:.4f})",
        UserWarning,
        stacklevel=2,
    )
    return new_lat, new_lon


# --------------------------------------------------------------------------- legs


def _leg_points(
    lat1: np.ndarray, lon1: np.ndarray, lat2: np.ndarray, lon2: np.ndarray, resolution_nm: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points every <= resolution_nm along each great-circle leg, both ends included.

    Returns flat (lat, lon, leg index), in order along each leg.
    """
    d = np.atleast_1d(geo.distance_nm(lat1, lon1, lat2, lon2))
    n = np.maximum(np.ceil(d / resolution_nm).astype(np.int64), 1) + 1
    leg = np.repeat(np.arange(d.size), n)
    start = np.cumsum(n) - n
    frac = (np.arange(leg.size) - start[leg]) / (n[leg] - 1)
    p1, l1, p2, l2 = (np.radians(np.atleast_1d(a).astype(float)) for a in (lat1, lon1, lat2, lon2))
    a = np.stack([np.cos(p1) * np.cos(l1), np.cos(p1) * np.sin(l1), np.sin(p1)], axis=-1)
    b = np.stack([np.cos(p2) * np.cos(l2), np.cos(p2) * np.sin(l2), np.sin(p2)], axis=-1)
    omega = np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0))
    if np.any(np.abs(omega - np.pi) < 1e-9):
        raise ConfigError("a leg joins antipodal points: its great circle is not unique; add a waypoint")
    om = omega[leg][:, None]
    f = frac[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        so = np.sin(om)
        wa = np.where(om > 1e-12, np.sin((1 - f) * om) / np.where(so > 0, so, 1.0), 1 - f)
        wb = np.where(om > 1e-12, np.sin(f * om) / np.where(so > 0, so, 1.0), f)
    xyz = wa * a[leg] + wb * b[leg]
    lat = np.degrees(np.arctan2(xyz[:, 2], np.hypot(xyz[:, 0], xyz[:, 1])))
    lon = units.wrap_180(np.degrees(np.arctan2(xyz[:, 1], xyz[:, 0])))
    return lat, lon, leg


def legs_cross_land(
    lat1_deg: ArrayLike,
    lon1_deg: ArrayLike,
    lat2_deg: ArrayLike,
    lon2_deg: ArrayLike,
    resolution_nm: float = DEFAULT_LEG_RESOLUTION_NM,
    *,
    weather: Any = None,
    time: Any = None,
    use_land_mask: bool | None = None,
    mask: LandMask | str | None = None,
) -> np.ndarray:
    """Whether each great-circle leg touches land (or no-passage weather), vectorised over legs.

    Each leg is checked at points at most ``resolution_nm`` apart, both ends
    included; land narrower than that can slip between two points.

    Parameters
    ----------
    lat1_deg, lon1_deg, lat2_deg, lon2_deg : array_like
        Leg ends [deg], broadcast together.
    resolution_nm : float
        Largest spacing of the checked points [nm], > 0.
    weather, time, use_land_mask, mask
        As in :func:`navigable`; ``time`` is one time for all legs (or one per leg).

    Returns
    -------
    ndarray of bool
        True for legs that touch a non-navigable point, in the broadcast shape.
    """
    res = float(finite("resolution_nm", resolution_nm, minimum=0.0, strict=True, error=ConfigError))
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (lat1_deg, lon1_deg, lat2_deg, lon2_deg)))
    shape = arrays[0].shape
    lat1, lon1, lat2, lon2 = (a.ravel() for a in arrays)
    _positions(lat1, lon1, "leg start ")
    _positions(lat2, lon2, "leg end ")
    lat, lon, leg = _leg_points(lat1, lon1, lat2, lon2, res)
    t = None
    if time is not None:
        t = np.asarray(time, dtype="datetime64[ns]")
        t = np.broadcast_to(t, shape).ravel()[leg] if t.ndim else t
    bad = ~navigable(lat, lon, weather, t, use_land_mask=use_land_mask, mask=mask)
    out = np.zeros(lat1.size, dtype=bool)
    np.logical_or.at(out, leg, bad)
    return out.reshape(shape)


def leg_crosses_land(
    lat1_deg: float,
    lon1_deg: float,
    lat2_deg: float,
    lon2_deg: float,
    resolution_nm: float = DEFAULT_LEG_RESOLUTION_NM,
    *,
    weather: Any = None,
    time: Any = None,
    use_land_mask: bool | None = None,
    mask: LandMask | str | None = None,
) -> tuple[float, float] | None:
    """The first non-navigable point on a great-circle leg, or None when the leg is clear.

    Parameters
    ----------
    lat1_deg, lon1_deg : float
        Leg start [deg].
    lat2_deg, lon2_deg : float
        Leg end [deg].
    resolution_nm : float
        Largest spacing of the checked points [nm], > 0; both ends are checked.
    weather, time, use_land_mask, mask
        As in :func:`navigable`.

    Returns
    -------
    tuple of float or None
        (lat, lon) [deg] of the first land (or no-passage) point met going
        from start to end, lon in [-180, 180); None when there is none.
    """
    res = float(finite("resolution_nm", resolution_nm, minimum=0.0, strict=True, error=ConfigError))
    p1 = _positions(lat1_deg, lon1_deg, "leg start ")
    p2 = _positions(lat2_deg, lon2_deg, "leg end ")
    if p1[0].ndim or p2[0].ndim:
        raise ConfigError("leg_crosses_land takes one leg; use legs_cross_land for arrays of legs")
    lat, lon, _ = _leg_points(p1[0], p1[1], p2[0], p2[1], res)
    bad = ~navigable(lat, lon, weather, time, use_land_mask=use_land_mask, mask=mask)
    if not bad.any():
        return None
    k = int(np.argmax(bad))
    return float(lat[k]), float(lon[k])
