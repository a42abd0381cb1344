"""Vectorised sampling of a canonical weather dataset at (time, lat, lon) points.

:class:`WeatherSampler` is the hot path of the route search and of the NLP
set-up: it turns the dataset into plain numpy arrays once and then
interpolates any number of points with index arithmetic:

* linear in time and bilinear in (lat, lon) on the 2 x 2 x 2 cell around the
  point (trilinear on the grid, lat and lon taken as plane coordinates);
* across the antimeridian: a query longitude in any convention is mapped
  onto the dataset's increasing longitudes (see
  :func:`~optroute.weather.schema.normalise_lon`), and a global grid wraps
  its last column onto its first;
* directions (``wave_from_deg``) are interpolated as unit vectors
  (sin, cos), so 350 deg and 10 deg meet at 0 deg, not 180 deg;
* NaN marks land or ice: a point whose 2 x 2 x 2 stencil touches a NaN cell
  gets NaN — "no passage", never zero waves;
* a missing current is zero (no current); a missing wind is NaN (not known: Kwon's Beaufort number
  then comes from Hs, as it would in a wave-only file — zero wind would make waves without wind
  cost nothing); every other missing variable is an error.

Coverage: a point outside the dataset's lat/lon box, or a time outside its
span, raises :class:`~optroute.errors.WeatherCoverageError` naming the point,
the time and the extent.  ``time_policy="hold"`` holds the first or last
time slice instead; a static dataset (a single time) therefore covers all
times only with ``time_policy="hold"`` — otherwise it covers just its instant.

Lazy datasets (dask-backed, from :func:`~optroute.weather.io.open_weather`)
bigger than ``load_bytes`` are never loaded whole: each call loads only the
time slices its points need (horizontal fields of the used variables),
keeping the most recently used ones up to ``cache_bytes``.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from optroute._numba import jit
from optroute.errors import ConfigError, WeatherCoverageError, WeatherSchemaError
from optroute.units import format_utc
from optroute.weather import schema
from optroute.weather.io import TIME_POLICIES, check_required

__all__ = ["PointWeather", "WeatherSampler", "grid_coordinates_at", "sample_at", "sample_weather", "trilinear_at"]

_EPS_DEG = 1e-7
_DIR = "wave_from_deg"


_NUMBA_MIN_POINTS = 64
_NUMBA_PARALLEL_POINTS = 200_000


def _trilinear_numpy(
    flat: np.ndarray,
    base: np.ndarray,
    xi: np.ndarray,
    xj: np.ndarray,
    nx: int,
    dt: int,
    tw: np.ndarray,
    yw: np.ndarray,
    xw: np.ndarray,
) -> np.ndarray:
    """Trilinear interpolation by numpy gathers; ``flat`` is a (time, lat, lon) field raveled.

    ``base`` is the flat index of the stencil's (time, lat) lower corner row,
    ``xi``/``xj`` the lower/upper lon columns (``xj`` wraps on a global grid),
    ``dt`` the flat offset of the next time slice (0 for a single slice),
    ``tw``, ``yw``, ``xw`` the weights of the upper neighbours in [0, 1].
    A NaN anywhere in the stencil gives NaN.
    """
    wx0, wy0 = 1.0 - xw, 1.0 - yw
    idx = (base + xi, base + xj, base + nx + xi, base + nx + xj)
    weights = (wy0 * wx0, wy0 * xw, yw * wx0, yw * xw)
    lo = sum(w * flat.take(i) for w, i in zip(weights, idx, strict=True))
    if dt == 0:
        return np.asarray(lo, dtype=float)
    hi = sum(w * flat.take(i + dt) for w, i in zip(weights, idx, strict=True))
    return (1.0 - tw) * lo + tw * hi


@jit
def trilinear_at(flat, b, x0, x1, nx, dt, wt, wy, wx):  # pragma: no cover - compiled
    """One trilinear interpolation in a raveled (time, lat, lon) field (NaN if the stencil touches one).

    ``b`` is the flat index of the stencil's lower (time, lat) row, ``x0``/``x1``
    its lon columns, ``dt`` the flat offset of the next time slice (0: one
    slice), ``wt``, ``wy``, ``wx`` the weights of the upper neighbours.
    """
    lo = (1.0 - wy) * ((1.0 - wx) * flat[b + x0] + wx * flat[b + x1]) + wy * (
        (1.0 - wx) * flat[b + nx + x0] + wx * flat[b + nx + x1]
    )
    if dt == 0:
        return lo
    c = b + dt
    hi = (1.0 - wy) * ((1.0 - wx) * flat[c + x0] + wx * flat[c + x1]) + wy * (
        (1.0 - wx) * flat[c + nx + x0] + wx * flat[c + nx + x1]
    )
    return (1.0 - wt) * lo + wt * hi


@jit(inline="always")
def _node_field(fields, b, x0, x1, nx, dt, wt, wy, wx, k):  # pragma: no cover - compiled
    """:func:`trilinear_at` of field ``k`` in node-major ``fields`` (shape (n_nodes, n_fields)): the same arithmetic,
    with every field of a grid node in one place, so the 8 corners' cache lines serve all the fields of a point."""
    lo = (1.0 - wy) * ((1.0 - wx) * fields[b + x0, k] + wx * fields[b + x1, k]) + wy * (
        (1.0 - wx) * fields[b + nx + x0, k] + wx * fields[b + nx + x1, k]
    )
    if dt == 0:
        return lo
    c = b + dt
    hi = (1.0 - wy) * ((1.0 - wx) * fields[c + x0, k] + wx * fields[c + x1, k]) + wy * (
        (1.0 - wx) * fields[c + nx + x0, k] + wx * fields[c + nx + x1, k]
    )
    return (1.0 - wt) * lo + wt * hi


def _trilinear_body(flat, base, xi, xj, nx, dt, tw, yw, xw, out, p):  # pragma: no cover - compiled
    out[p] = trilinear_at(flat, base[p], xi[p], xj[p], nx, dt, tw[p], yw[p], xw[p])


def _trilinear_serial(flat, base, xi, xj, nx, dt, tw, yw, xw):  # pragma: no cover - compiled
    out = np.empty(base.size)
    for p in range(base.size):
        _trilinear_point(flat, base, xi, xj, nx, dt, tw, yw, xw, out, p)
    return out


def _trilinear_parallel(flat, base, xi, xj, nx, dt, tw, yw, xw):  # pragma: no cover - compiled
    out = np.empty(base.size)
    for p in numba.prange(base.size):
        _trilinear_point(flat, base, xi, xj, nx, dt, tw, yw, xw, out, p)
    return out


def _sincos_parallel(deg, s, c):  # pragma: no cover - compiled
    flat, fs, fc = deg.reshape(-1), s.reshape(-1), c.reshape(-1)
    for p in numba.prange(flat.size):
        r = np.radians(flat[p])
        fs[p] = np.sin(r)
        fc[p] = np.cos(r)


try:  # numba is optional: the numpy kernels give the same numbers
    import numba
except ImportError:
    numba = None
    _trilinear_numba = _trilinear_numba_parallel = _sincos_numba = None
else:
    from optroute._numba import njit

    _trilinear_point = njit(inline="always", nogil=True)(_trilinear_body)
    _trilinear_numba = njit(nogil=True)(_trilinear_serial)
    _trilinear_numba_parallel = njit(parallel=True, nogil=True)(_trilinear_parallel)
    _sincos_numba = njit(parallel=True, nogil=True)(_sincos_parallel)


# indices of PointWeather.meta
_M_T_START, _M_T_STEP, _M_T_UNIFORM, _M_T_STOP = 0, 1, 2, 3
_M_Y_START, _M_Y_STEP, _M_Y_UNIFORM, _M_Y_STOP = 4, 5, 6, 7
_M_X_START, _M_X_STEP, _M_X_UNIFORM, _M_X_STOP = 8, 9, 10, 11
_M_PERIODIC, _M_HOLD = 12, 13
N_POINT_FIELDS = 9
"""Fields of :class:`PointWeather`: hs, period, wave-from sin and cos, wind u and v, current u and v, and a zero row."""


class PointWeather(NamedTuple):
    """A sampler's arrays for :func:`sample_at` (compiled kernels); see :meth:`WeatherSampler.point_weather`.

    Attributes
    ----------
    fields : ndarray, shape (n_time * n_lat * n_lon, 9)
        Node-major (all fields of one grid node together; nodes raveled as (time, lat, lon)):
        Hs [m], the band period [s] (``tp_s``, else ``tm_s``),
        sin and cos of the wave direction, wind u, v [m/s], current u, v [m/s]
        (NaN columns for a wind and zero columns for a current the dataset does not have), and a zero column.
    time_s, lat_deg, lon_deg : ndarray
        The axes (time in seconds since the first time).
    meta : ndarray
        Axis starts, steps, uniformity and ends, the periodic-longitude and hold flags.
    offset_ns : int
        Departure minus the dataset's first time [ns]: search time t_h [h] is
        ``offset_ns + round(t_h · 3.6e12)`` ns after the first time.
    """

    fields: np.ndarray
    time_s: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    meta: np.ndarray
    offset_ns: int


@jit
def _locate(values, x, start, step, uniform):  # pragma: no cover - compiled
    """(lower index, upper weight) of x on an axis, as ``_Axis.locate``."""
    n = values.size
    if n == 1:
        return 0, 0.0
    if uniform != 0.0:
        f = (x - start) / step
        i = min(max(np.floor(f), 0.0), n - 2.0)
        w = f - i
        return int(i), min(max(w, 0.0), 1.0)
    i = min(max(np.searchsorted(values, x, side="right") - 1, 0), n - 2)
    lo = values[i]
    w = (x - lo) / (values[i + 1] - lo)
    return i, min(max(w, 0.0), 1.0)


@jit
def _placed(meta, offset_ns, t_h, lat, lon):  # pragma: no cover - compiled
    """A point against the grid: its time [s since the epoch], its longitude unwrapped onto the grid's
    [deg] and whether it lies inside the area and (unless held) the time span."""
    seconds = (offset_ns + np.int64(np.round(t_h * 3.6e12))) / 1e9
    lon0 = meta[_M_X_START]
    lonu = lon0 + (lon - lon0) % 360.0
    if lonu > lon0 + 360.0 - _EPS_DEG:
        lonu -= 360.0
    inside = meta[_M_Y_START] - _EPS_DEG <= lat <= meta[_M_Y_STOP] + _EPS_DEG
    if meta[_M_PERIODIC] == 0.0:
        inside = inside and lonu <= meta[_M_X_STOP] + _EPS_DEG
    if meta[_M_HOLD] == 0.0:
        inside = inside and meta[_M_T_START] <= seconds <= meta[_M_T_STOP]
    return seconds, lonu, inside


@jit
def sample_at(fields, time_s, lat_deg, lon_deg, meta, offset_ns, t_h, lat, lon, out):  # pragma: no cover - compiled
    """The weather at one point, as :meth:`WeatherSampler.sample` (trilinear; directions as unit vectors).

    ``t_h`` is hours after the departure of :attr:`PointWeather.offset_ns`.
    Writes Hs [m], period [s], wave-from [deg], wind u, v and current u, v
    [m/s] into ``out[:7]``; returns False, with NaN written, where the point
    lies outside the dataset's area or (unless held) time span.
    """
    seconds, lonu, inside = _placed(meta, offset_ns, t_h, lat, lon)
    lon0 = meta[_M_X_START]
    if not inside:
        out[:7] = np.nan
        return False
    tc = min(max(seconds, meta[_M_T_START]), meta[_M_T_STOP])
    ti, tw = _locate(time_s, tc, meta[_M_T_START], meta[_M_T_STEP], meta[_M_T_UNIFORM])
    yi, yw = _locate(lat_deg, lat, meta[_M_Y_START], meta[_M_Y_STEP], meta[_M_Y_UNIFORM])
    nx = lon_deg.size
    if meta[_M_PERIODIC] != 0.0:
        f = (lonu - lon0) / meta[_M_X_STEP]
        xi = int(min(max(np.floor(f), 0.0), nx - 1.0))
        xw = min(max(f - xi, 0.0), 1.0)
        xj = 0 if xi == nx - 1 else xi + 1
    else:
        xi, xw = _locate(lon_deg, lonu, lon0, meta[_M_X_STEP], meta[_M_X_UNIFORM])
        xj = xi + 1
    ny = lat_deg.size
    dt = ny * nx if time_s.size > 1 else 0
    b = (ti * ny + yi) * nx
    out[0] = _node_field(fields, b, xi, xj, nx, dt, tw, yw, xw, 0)
    out[1] = _node_field(fields, b, xi, xj, nx, dt, tw, yw, xw, 1)
    s = _node_field(fields, b, xi, xj, nx, dt, tw, yw, xw, 2)
    c = _node_field(fields, b, xi, xj, nx, dt, tw, yw, xw, 3)
    out[2] = np.degrees(np.arctan2(s, c)) % 360.0
    for k in range(4, 8):
        out[k - 1] = _node_field(fields, b, xi, xj, nx, dt, tw, yw, xw, k)
    return True


@jit
def grid_coordinates_at(time_s, lat_deg, lon_deg, meta, offset_ns, t_h, lat, lon, out):  # pragma: no cover - compiled
    """Continuous grid coordinates of one point, as :meth:`WeatherSampler.grid_coordinates`.

    ``t_h`` is hours after the departure of :attr:`PointWeather.offset_ns`.  Writes the
    ``[time, lat, lon]`` coordinates (the stencil's lower index plus its weight; under the "hold"
    policy −0.5 before the time span and ``n_time − 0.5`` after it) into ``out[:3]``; returns False,
    with NaN written, where the point lies outside the area or (unless held) the time span.
    """
    seconds, lonu, inside = _placed(meta, offset_ns, t_h, lat, lon)
    lon0 = meta[_M_X_START]
    if not inside:
        out[:3] = np.nan
        return False
    if seconds < meta[_M_T_START]:
        out[0] = -0.5
    elif seconds > meta[_M_T_STOP]:
        out[0] = time_s.size - 0.5
    else:
        ti, tw = _locate(time_s, seconds, meta[_M_T_START], meta[_M_T_STEP], meta[_M_T_UNIFORM])
        out[0] = ti + tw
    la = min(max(lat, meta[_M_Y_START]), meta[_M_Y_STOP])
    yi, yw = _locate(lat_deg, la, meta[_M_Y_START], meta[_M_Y_STEP], meta[_M_Y_UNIFORM])
    out[1] = yi + yw
    if meta[_M_PERIODIC] != 0.0:
        out[2] = min(max((lonu - lon0) / meta[_M_X_STEP], 0.0), float(lon_deg.size))
    else:
        lo = min(max(lonu, lon0), meta[_M_X_STOP])
        xi, xw = _locate(lon_deg, lo, lon0, meta[_M_X_STEP], meta[_M_X_UNIFORM])
        out[2] = xi + xw
    return True


def _unit_vectors(deg: np.ndarray, engine: str) -> tuple[np.ndarray, np.ndarray]:
    """(sin, cos) of directions [deg], in the array's own float type."""
    if engine == "numba" and _sincos_numba is not None and deg.size >= _NUMBA_MIN_POINTS:
        s, c = np.empty_like(deg), np.empty_like(deg)
        _sincos_numba(np.ascontiguousarray(deg), s, c)
        return s, c
    rad = np.radians(deg)
    return np.sin(rad), np.cos(rad)


class _Axis:
    """A 1-D grid axis: locates points as (lower index, weight) by arithmetic when uniform."""

    def __init__(self, values: np.ndarray) -> None:
        self.values = np.asarray(values, dtype=float)
        self.n = self.values.size
        self.start = float(self.values[0])
        self.stop = float(self.values[-1])
        if self.n > 1:
            self.step = (self.stop - self.start) / (self.n - 1)
            self.uniform = bool(np.allclose(np.diff(self.values), self.step, rtol=1e-9, atol=1e-9 * abs(self.step)))
        else:
            self.step, self.uniform = 1.0, True

    def locate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Lower cell index in [0, n-2] and weight in [0, 1] of the upper neighbour (x inside the axis)."""
        if self.n == 1:
            return np.zeros(x.shape, dtype=np.int64), np.zeros(x.shape)
        if self.uniform:
            f = (x - self.start) / self.step
            i = np.clip(np.floor(f), 0, self.n - 2).astype(np.int64)
            w = f - i
        else:
            i = np.clip(np.searchsorted(self.values, x, side="right") - 1, 0, self.n - 2)
            lo = self.values[i]
            w = (x - lo) / (self.values[i + 1] - lo)
        return i, np.clip(w, 0.0, 1.0)


class WeatherSampler:
    """Interpolate a canonical weather dataset at arrays of (time, lat, lon).

    Parameters
    ----------
    ds : xarray.Dataset
        A canonical dataset (:mod:`optroute.weather.schema`), e.g. from
        :func:`~optroute.weather.io.open_weather` or ``optroute.scenarios``.
    time_policy : {"raise", "hold"}, optional
        Out-of-span times raise :class:`~optroute.errors.WeatherCoverageError`
        (``"raise"``) or take the first/last time slice (``"hold"``).  Default:
        ``ds.attrs["time_policy"]``, else ``"raise"``.
    required : sequence of sequences of str
        Variable groups of which one each must be present (default: wave
        height, a wave period, wave direction); ``()`` accepts any.
    load_bytes : int
        A lazy dataset whose used variables are at most this big [bytes] is
        loaded into memory at construction; a bigger one is read slice by slice.
    cache_bytes : int
        Memory for the time slices a lazy dataset keeps between calls [bytes].
    engine : {"auto", "numpy", "numba"}
        The interpolation kernel: numba (compiled, parallel; the default when
        numba is installed — the first call compiles it, cached on disk) or
        numpy (vectorised gathers).  Both give the same numbers.

    Raises
    ------
    WeatherSchemaError
        Broken coordinates, a missing required variable, an all-NaN or
        implausible field (checked as fields are loaded).

    Examples
    --------
    >>> sampler = WeatherSampler(optroute.open_weather("era5.nc"))   # doctest: +SKIP
    >>> wx = sampler.sample(times, lats, lons)                      # doctest: +SKIP
    >>> wx["hs_m"], wx["wave_from_deg"]                             # doctest: +SKIP
    """

    def __init__(
        self,
        ds: xr.Dataset,
        *,
        time_policy: str | None = None,
        required: Sequence[Sequence[str]] = schema.WAVE_REQUIRED,
        load_bytes: int = 512 * 2**20,
        cache_bytes: int = 512 * 2**20,
        engine: str = "auto",
    ) -> None:
        if engine not in ("auto", "numpy", "numba"):
            raise ConfigError(f"engine={engine!r} is not known; use 'auto', 'numpy' or 'numba'")
        if engine == "numba" and _trilinear_numba is None:
            raise ConfigError("engine='numba' needs numba; install it with pip install numba, or use engine='numpy'")
        self.engine = (
            "numba" if engine == "auto" and _trilinear_numba is not None else ("numpy" if engine == "auto" else engine)
        )
        self.source = str(ds.attrs.get("source", "dataset"))
        schema.check_coords(ds, self.source)
        check_required(ds, required, self.source)
        self.time_policy = time_policy or str(ds.attrs.get("time_policy", "raise"))
        if self.time_policy not in TIME_POLICIES:
            raise ConfigError(f"time_policy={self.time_policy!r} is not known; use one of {TIME_POLICIES}")
        self.variables: tuple[str, ...] = tuple(str(v) for v in ds.data_vars if v in schema.VARIABLES)
        self._times = ds["time"].values.astype("datetime64[ns]")
        self._t0 = self._times[0].astype(np.int64)
        self._time = _Axis((self._times.astype(np.int64) - self._t0) / 1e9)  # seconds since the first time
        self._lat = _Axis(ds["lat"].values)
        self._lon = _Axis(ds["lon"].values)
        self.periodic = schema.lon_is_periodic(self._lon.values)
        self._shape = (self._time.n, self._lat.n, self._lon.n)
        self._fields = [f for v in self.variables for f in ((_DIR + ":sin", _DIR + ":cos") if v == _DIR else (v,))]
        self._ds = ds[list(self.variables)]
        self._cache: OrderedDict[int, dict[str, np.ndarray]] = OrderedDict()
        self._cache_bytes = int(cache_bytes)
        nbytes = sum(self._ds[v].nbytes for v in self.variables)
        in_memory = all(
            self._ds[v].chunks is None and getattr(self._ds[v].variable, "_in_memory", False) for v in self.variables
        )
        self.lazy = not in_memory and nbytes > load_bytes
        self._arrays: dict[str, np.ndarray] = {}
        if not self.lazy:
            values = self._read({})
            self._arrays = self._derive(values, where=self.source)

    # -- public -------------------------------------------------------------

    @property
    def extent(self) -> dict[str, Any]:
        """The dataset's extent: ``lat`` and ``lon`` (min, max) [deg], ``time`` (first, last), ``periodic``."""
        return {
            "lat": (self._lat.start, self._lat.stop),
            "lon": (self._lon.start, self._lon.stop),
            "time": (self._times[0], self._times[-1]),
            "periodic": self.periodic,
        }

    def covers(self, time: ArrayLike, lat: ArrayLike, lon: ArrayLike) -> np.ndarray:
        """Whether each point lies inside the dataset's area and (under ``"raise"``) its time span.

        Parameters
        ----------
        time : array_like of datetime64
            Times [UTC].
        lat, lon : array_like
            Positions [deg north, deg east, any longitude convention].

        Returns
        -------
        ndarray of bool
            Broadcast shape of the inputs.
        """
        shape, t, la, lo = self._inputs(time, lat, lon)
        inside_xy, inside_t, _ = self._inside(t, la, lo)
        return (inside_xy & inside_t).reshape(shape)

    def grid_coordinates(self, time: ArrayLike, lat: ArrayLike, lon: ArrayLike) -> np.ndarray:
        """Continuous grid coordinates of points: (time, lat, lon) index of the stencil's lower corner plus its weight.

        The integer part is the interpolation cell: inside one cell the sampled fields are one
        trilinear polynomial of (time, lat, lon); where it changes along a track the interpolated
        weather changes regime (the referee checks there, :mod:`optroute.plan.checkpoints`).

        Parameters
        ----------
        time : array_like of datetime64
            Times [UTC].
        lat, lon : array_like
            Positions [deg north, deg east, any longitude convention].

        Returns
        -------
        ndarray of float, shape (..., 3)
            ``[time, lat, lon]`` coordinates (0 at the first node, 1 at the second...); NaN in every
            column outside the area or (under ``"raise"``) the time span; under ``"hold"`` a time
            before the span is −0.5 and after it ``n_time − 0.5`` (the held slice is a regime of its own).
        """
        shape, t, la, lo = self._inputs(time, lat, lon)
        inside_xy, inside_t, lonu = self._inside(t, la, lo)
        ti, tw = self._time.locate(np.clip(t, self._time.start, self._time.stop))
        ft = np.where(t < self._time.start, -0.5, np.where(t > self._time.stop, self._time.n - 0.5, ti + tw))
        yi, yw = self._lat.locate(np.clip(la, self._lat.start, self._lat.stop))
        if self.periodic:
            fx = np.clip((lonu - self._lon.start) / self._lon.step, 0.0, float(self._lon.n))
        else:
            xi, xw = self._lon.locate(np.clip(lonu, self._lon.start, self._lon.stop))
            fx = xi + xw
        out = np.stack([ft, yi + yw, fx], axis=-1).astype(float)
        out[~(inside_xy & inside_t)] = np.nan
        return out.reshape((*shape, 3))

    def area_text(self) -> str:
        """The dataset's area in words: ``lat 25 to 37 deg N, lon -155 to -135 deg E``."""
        lon_lo, lon_hi = self._lon.start, self._lon.stop
        if self.periodic:
            lon_txt = "all longitudes (global)"
        elif lon_hi >= 180.0:
            lon_txt = f"{lon_lo:.6g} to {lon_hi:.6g} deg E unwrapped (across the antimeridian, to {lon_hi - 360.0:.6g})"
        else:
            lon_txt = f"{lon_lo:.6g} to {lon_hi:.6g} deg E"
        return f"lat {self._lat.start:.6g} to {self._lat.stop:.6g} deg N, lon {lon_txt}"

    def require_area(self, lat_deg: float, lon_deg: float, what: str) -> None:
        """Raise unless the position lies inside the dataset's area (its time span is not checked).

        Parameters
        ----------
        lat_deg, lon_deg : float
            The position [deg north, deg east, any longitude convention].
        what : str
            What the position is (``"start"``, ``"end"``, ``"corridor point 3"``), for the message.

        Raises
        ------
        WeatherCoverageError
            Outside the area; the message names the position, the area and the fix.
        """
        inside, _ = self._inside_xy(np.asarray([float(lat_deg)]), np.asarray([float(lon_deg)]))
        if not bool(inside[0]):
            raise WeatherCoverageError(
                f"{what} ({float(lat_deg):.4f}, {float(lon_deg):.4f}) lies outside the weather's area "
                f"({self.source}: {self.area_text()}); give a position inside that area, or weather that covers "
                "the whole voyage"
            )

    def sample(
        self, time: ArrayLike, lat: ArrayLike, lon: ArrayLike, variables: Sequence[str] | None = None
    ) -> dict[str, np.ndarray]:
        """Interpolate the weather at points.

        Parameters
        ----------
        time : array_like of datetime64
            Times [UTC, timezone-naive]; broadcast against ``lat`` and ``lon``.
        lat : array_like
            Latitudes [deg north].
        lon : array_like
            Longitudes [deg east], any convention (-180–180, 0–360, unwrapped).
        variables : sequence of str, optional
            Canonical names wanted; default all present plus NaN for a missing
            wind (not known) and zeros for a missing current.

        Returns
        -------
        dict of str to ndarray
            Canonical name → float64 values in canonical units
            (``wave_from_deg`` in [0, 360) deg true, coming from), in the
            broadcast shape of the inputs.  NaN where the interpolation
            stencil touches a NaN cell (land, ice): no passage.

        Raises
        ------
        WeatherCoverageError
            A point lies outside the lat/lon box or (with ``time_policy="raise"``)
            the time span; the message names the first such point, its time and
            the dataset's extent.
        WeatherSchemaError
            A wanted variable is neither present nor a zero-default one; a
            lazily loaded slice is all NaN, implausible or unreadable.
        ConfigError
            NaT times, non-finite or out-of-range positions.
        """
        wanted = self._wanted(variables)
        shape, t, la, lo = self._inputs(time, lat, lon)
        inside_xy, inside_t, lonu = self._inside(t, la, lo)
        if not inside_xy.all() or not inside_t.all():
            self._coverage_error(t, la, lo, inside_xy, inside_t)
        t = np.clip(t, self._time.start, self._time.stop)
        ti, tw = self._time.locate(t)
        yi, yw = self._lat.locate(la)
        if self.periodic:
            f = (lonu - self._lon.start) / self._lon.step
            xi = np.clip(np.floor(f), 0, self._lon.n - 1).astype(np.int64)
            xw = np.clip(f - xi, 0.0, 1.0)
            xj = np.where(xi == self._lon.n - 1, 0, xi + 1)
        else:
            xi, xw = self._lon.locate(lonu)
            xj = xi + 1
        arrays, ti = self._arrays_for(ti, wanted)
        nt_local = next(iter(arrays.values())).shape[0] if arrays else 1
        ny, nx = self._lat.n, self._lon.n
        dt = ny * nx if nt_local > 1 else 0
        base = (ti * ny + yi) * nx
        if self.engine == "numpy" or base.size < _NUMBA_MIN_POINTS:
            kernel = _trilinear_numpy
        else:  # threads pay off only for big batches; small ones would wait on busy cores
            kernel = _trilinear_numba_parallel if base.size >= _NUMBA_PARALLEL_POINTS else _trilinear_numba

        def interp(field: np.ndarray) -> np.ndarray:
            return kernel(field.reshape(-1), base, xi, xj, nx, dt, tw, yw, xw)

        out: dict[str, np.ndarray] = {}
        for name in wanted:
            if name not in self.variables:
                out[name] = np.full(shape, np.nan) if name in schema.OPTIONAL_UNKNOWN else np.zeros(shape)
            elif name == _DIR:
                s = interp(arrays[_DIR + ":sin"].ravel())
                c = interp(arrays[_DIR + ":cos"].ravel())
                out[name] = np.mod(np.degrees(np.arctan2(s, c)), 360.0).reshape(shape)
            else:
                out[name] = np.asarray(interp(arrays[name].ravel()), dtype=float).reshape(shape)
        return out

    def point_weather(self, departure: np.datetime64) -> PointWeather | None:
        """The arrays :func:`sample_at` reads, for a clock starting at ``departure`` [UTC].

        ``None`` for a lazy dataset (read slice by slice; use :meth:`sample`) or one
        without Hs, a wave period or the wave direction.  Built once and kept.
        """
        period = "tp_s" if "tp_s" in self.variables else "tm_s"
        if self.lazy or not {"hs_m", period, _DIR} <= set(self.variables):
            return None
        if getattr(self, "_point", None) is None:
            size = self._time.n * self._lat.n * self._lon.n
            rows = ["hs_m", period, _DIR + ":sin", _DIR + ":cos", *schema.OPTIONAL]
            fields = np.zeros((size, N_POINT_FIELDS))  # node-major: one gather of a node gives every field
            for k, name in enumerate(rows):
                if name in self._arrays:
                    fields[:, k] = self._arrays[name].ravel()
                elif name in schema.OPTIONAL_UNKNOWN:
                    fields[:, k] = np.nan
            meta = np.zeros(14)
            for at, ax in ((_M_T_START, self._time), (_M_Y_START, self._lat), (_M_X_START, self._lon)):
                meta[at : at + 4] = (ax.start, ax.step, 1.0 if ax.uniform else 0.0, ax.stop)
            meta[_M_PERIODIC] = 1.0 if self.periodic else 0.0
            meta[_M_HOLD] = 1.0 if self.time_policy == "hold" else 0.0
            self._point = (fields, self._time.values.copy(), self._lat.values.copy(), self._lon.values.copy(), meta)
        offset = int(np.datetime64(departure, "ns").astype(np.int64) - self._t0)
        return PointWeather(*self._point, offset)

    # -- internals ----------------------------------------------------------

    def _wanted(self, variables: Sequence[str] | None) -> list[str]:
        if variables is None:
            return list(self.variables) + [v for v in schema.OPTIONAL if v not in self.variables]
        wanted = [str(v) for v in variables]
        for v in wanted:
            if v not in self.variables and v not in schema.OPTIONAL:
                if v not in schema.VARIABLES:
                    raise ConfigError(
                        f"{v!r} is not a canonical weather variable; use one of {sorted(schema.VARIABLES)}"
                    )
                raise WeatherSchemaError(
                    f"{self.source}: variable {v} is not in the dataset (present: {', '.join(self.variables)}); "
                    "only wind (unknown) and current (zero) may be missing"
                )
        return wanted

    def _inputs(
        self, time: ArrayLike, lat: ArrayLike, lon: ArrayLike
    ) -> tuple[tuple[int, ...], np.ndarray, np.ndarray, np.ndarray]:
        try:
            t = np.asarray(time, dtype="datetime64[ns]")
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"time={time!r} is not a datetime64 array (UTC, timezone-naive)") from exc
        la = np.asarray(lat, dtype=float)
        lo = np.asarray(lon, dtype=float)
        try:
            shape = np.broadcast_shapes(t.shape, la.shape, lo.shape)
        except ValueError as exc:
            raise ConfigError(f"time, lat and lon shapes {t.shape}, {la.shape}, {lo.shape} do not broadcast") from exc
        t = np.broadcast_to(t, shape).ravel()
        la = np.broadcast_to(la, shape).ravel()
        lo = np.broadcast_to(lo, shape).ravel()
        if np.isnat(t).any():
            raise ConfigError(
                f"time holds NaT at flat index {int(np.flatnonzero(np.isnat(t))[0])}; pass valid UTC times"
            )
        bad = ~(np.isfinite(la) & np.isfinite(lo)) | (np.abs(la) > 90.0)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ConfigError(
                f"position (lat={float(la[k])!r}, lon={float(lo[k])!r}) at flat index {k} is not a valid (lat, lon) in degrees"
            )
        seconds = (t.astype(np.int64) - self._t0) / 1e9
        return shape, seconds, la, lo

    def _inside_xy(self, la: np.ndarray, lo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lon0 = self._lon.start
        lonu = lon0 + np.mod(lo - lon0, 360.0)
        lonu = np.where(lonu > lon0 + 360.0 - _EPS_DEG, lonu - 360.0, lonu)
        inside = (la >= self._lat.start - _EPS_DEG) & (la <= self._lat.stop + _EPS_DEG)
        if not self.periodic:
            inside &= lonu <= self._lon.stop + _EPS_DEG
        return inside, lonu

    def _inside(self, t: np.ndarray, la: np.ndarray, lo: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        inside, lonu = self._inside_xy(la, lo)
        if self.time_policy == "hold":
            inside_t = np.ones(t.shape, dtype=bool)
        else:
            inside_t = (t >= self._time.start) & (t <= self._time.stop)
        return inside, inside_t, lonu

    def _coverage_error(
        self, t: np.ndarray, la: np.ndarray, lo: np.ndarray, inside_xy: np.ndarray, inside_t: np.ndarray
    ) -> None:
        out = ~(inside_xy & inside_t)
        k = int(np.flatnonzero(out)[0])
        when = format_utc(np.int64(self._t0 + round(float(t[k]) * 1e9)).astype("datetime64[ns]"))
        what = "area" if not inside_xy[k] else "time span"
        fix = "extend the dataset or keep the voyage inside it"
        if inside_xy[k]:
            fix += ", or pass time_policy='hold' to hold the first/last time slice"
        t0, t1 = (format_utc(x) for x in (self._times[0], self._times[-1]))
        raise WeatherCoverageError(
            f"point (lat={la[k]:.6g}, lon={lo[k]:.6g}) at {when} lies outside the weather dataset's {what} "
            f"({self.source}: {self.area_text()}, time {t0} to {t1}); {int(out.sum())} of {out.size} points are "
            f"outside; {fix}"
        )

    def _read(self, isel: dict[str, Any]) -> dict[str, np.ndarray]:
        try:
            sub = self._ds.isel(isel) if isel else self._ds
            sub = sub.compute() if any(sub[v].chunks is not None for v in sub.data_vars) else sub
            return {v: np.asarray(sub[v].values) for v in self.variables}
        except (OSError, RuntimeError, ValueError) as exc:
            raise WeatherSchemaError(
                f"{self.source}: could not read the weather data ({exc}); the file is truncated or corrupted"
            ) from exc

    def _derive(self, values: dict[str, np.ndarray], where: str) -> dict[str, np.ndarray]:
        out: dict[str, np.ndarray] = {}
        for v, arr in values.items():
            arr = np.ascontiguousarray(arr if arr.dtype.kind == "f" else arr.astype(float))
            schema.check_values(v, arr, where)
            if v == _DIR:
                out[_DIR + ":sin"], out[_DIR + ":cos"] = _unit_vectors(arr, self.engine)
            else:
                out[v] = arr
        return out

    def _arrays_for(self, ti: np.ndarray, wanted: list[str]) -> tuple[dict[str, np.ndarray], np.ndarray]:
        fields = [f for f in self._fields if f.split(":")[0] in wanted]
        if not self.lazy:
            return {f: self._arrays[f] for f in fields}, ti
        need = np.unique(np.concatenate([ti, np.minimum(ti + 1, self._time.n - 1)]))
        missing = [int(k) for k in need if int(k) not in self._cache]
        if missing:
            values = self._read({"time": missing})
            for j, k in enumerate(missing):
                when = f"{self.source} at {format_utc(self._times[k])}"
                self._cache[k] = self._derive({v: a[j : j + 1] for v, a in values.items()}, where=when)
        for k in need:
            self._cache.move_to_end(int(k))
        self._evict(set(need.tolist()))
        local = np.full(self._time.n, -1, dtype=np.int64)
        local[need] = np.arange(need.size)
        arrays = {f: np.concatenate([self._cache[int(k)][f] for k in need], axis=0) for f in fields}
        return arrays, local[ti]

    def _evict(self, keep: set[int]) -> None:
        def size() -> int:
            return sum(a.nbytes for d in self._cache.values() for a in d.values())

        while len(self._cache) > len(keep) and size() > self._cache_bytes:
            k = next(k for k in self._cache if k not in keep)
            del self._cache[k]


def sample_weather(
    ds: xr.Dataset, time: ArrayLike, lat: ArrayLike, lon: ArrayLike, **kwargs: Any
) -> dict[str, np.ndarray]:
    """One-off :meth:`WeatherSampler.sample`; build a :class:`WeatherSampler` once for repeated calls.

    Parameters
    ----------
    ds : xarray.Dataset
        A canonical weather dataset.
    time, lat, lon : array_like
        Times [UTC], latitudes [deg north], longitudes [deg east].
    **kwargs
        ``variables`` goes to :meth:`WeatherSampler.sample`, the rest to :class:`WeatherSampler`.

    Returns
    -------
    dict of str to ndarray
        As :meth:`WeatherSampler.sample`.
    """
    variables = kwargs.pop("variables", None)
    return WeatherSampler(ds, **kwargs).sample(time, lat, lon, variables=variables)
