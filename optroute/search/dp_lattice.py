"""The 3-D DP's lattice: its options checked, the stages' lateral states and the arrival-time bins.

Split out of :mod:`optroute.search.dp` (:func:`~optroute.search.dp.solve_dp`): the states are the great-circle
lattice of Shao et al. (stages every ΔX along the great circle, lateral states every ΔY on its perpendicular) or
the stations a caller gives (a corridor's bent centreline), and the bins those of the module docstring of
:mod:`optroute.search.dp`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from optroute import geodesy as geo
from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.search.dp_kernels import BIN_TOL_H
from optroute.search.dp_stages import LegCostFn

__all__ = ["Lattice", "Options", "checked_options", "given_stations", "lattice", "stage_geometry"]


def stage_geometry(
    start: tuple[float, float], end: tuple[float, float], dx_nm: float, dy_nm: float, n_half: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Shao et al.'s lattice: ``(lat, lon)`` (K+1, 2n+1) [deg] of the stages every ``dx_nm`` or less (the distance
    divided evenly) along the great circle from ``start`` to ``end`` [deg], ``n_half`` lateral states every
    ``dy_nm`` [nm] a side on its perpendicular, the lateral offsets [nm, starboard +] and K."""
    lat_s, lon_s = start
    lat_e, lon_e = end
    dist = float(geo.distance_nm(lat_s, lon_s, lat_e, lon_e))
    n_stages = max(1, int(np.ceil(dist / dx_nm - 1e-9)))
    clat, clon = geo.intermediate_points(lat_s, lon_s, lat_e, lon_e, np.linspace(0.0, 1.0, n_stages + 1))
    course = np.empty(n_stages + 1)
    course[:-1] = geo.initial_course_deg(clat[:-1], clon[:-1], lat_e, lon_e)
    course[-1] = geo.initial_course_deg(lat_s, lon_s, lat_e, lon_e)  # unused: the end has no lateral states
    lateral = dy_nm * (np.arange(2 * n_half + 1) - n_half)
    side = np.where(lateral >= 0, 90.0, -90.0)
    lat, lon = geo.destination(clat[:, None], clon[:, None], course[:, None] + side[None, :], np.abs(lateral)[None, :])
    lat[0], lon[0] = lat_s, lon_s  # only the centre is a state at the two ends
    lat[-1], lon[-1] = lat_e, lon_e
    return lat, lon, lateral, n_stages


def given_stations(
    stations: tuple[ArrayLike, ArrayLike, ArrayLike], start: tuple[float, float], end: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """``stations`` checked: ``(lat, lon)`` (K+1, 2n+1) [deg] and ``lateral_nm`` (2n+1,) rising through 0 at the
    centre column n, whose first and last rows' centres are ``start`` and ``end``; as :func:`stage_geometry`'s."""
    if not isinstance(stations, tuple | list) or len(stations) != 3:
        raise ConfigError(
            f"stations must be (lat_deg, lon_deg, lateral_nm), the stages' lateral states, got {type(stations).__name__}"
            f"{'' if not isinstance(stations, tuple | list) else f' of {len(stations)} items'}; build them with "
            "optroute.optimise.starts.corridor_stations"
        )
    lat = finite("stations' lat_deg", np.asarray(stations[0], dtype=float), error=ConfigError)
    lon = finite("stations' lon_deg", np.asarray(stations[1], dtype=float), error=ConfigError)
    lateral = finite("stations' lateral_nm", np.asarray(stations[2], dtype=float), error=ConfigError)
    n_lat = lateral.size
    if lat.ndim != 2 or lat.shape != lon.shape or lat.shape[0] < 2 or lat.shape[1] != n_lat or n_lat % 2 != 1:
        raise ConfigError(
            f"stations' lat_deg {lat.shape} and lon_deg {lon.shape} must be (stages + 1, lateral states), with an odd "
            f"number of lateral states as in lateral_nm {lateral.shape}"
        )
    c = n_lat // 2
    if lateral[c] != 0.0 or np.any(np.diff(lateral) <= 0.0):
        raise ConfigError(f"stations' lateral_nm {lateral} must rise through 0 at its centre")
    for name, row, point in (("start", 0, start), ("end", -1, end)):
        gap = float(geo.distance_nm(lat[row, c], lon[row, c], point[0], point[1]))
        if gap > 1e-6:
            raise ConfigError(
                f"the stations' centre of the {name} row is {gap:.3g} nm from the {name} {point}; make the centre "
                f"column's {name} the route's {name}"
            )
    lat, lon = lat.copy(), lon.copy()
    lat[0], lon[0] = start  # only the centre is a state at the two ends
    lat[-1], lon[-1] = end
    return lat, lon, lateral, lat.shape[0] - 1


@dataclass(frozen=True, eq=False)
class Options:
    """:func:`solve_dp`'s options, checked: endpoints [deg], spacings [nm], bin [h], speeds [kn], ETA [h]."""

    start: tuple[float, float]
    end: tuple[float, float]
    dx: float
    dy: float
    half_width: float
    dt: float
    speeds: np.ndarray
    eta_h: float | None
    step: int | None
    n_labels: int | None
    nogo_step: float
    by_time: bool = False  # a bin's labels ranked by arrival time, not fuel (``label_value="time"``)


def checked_options(
    leg_cost: LegCostFn,
    start: tuple[float, float],
    end: tuple[float, float],
    eta_h: float | None,
    spacing: tuple[float, float, float, float],
    speeds_kn: ArrayLike | None,
    nogo_step_nm: float | None,
    max_lateral_step: int | None,
    labels_per_bin: int | None,
    label_value: str = "fuel",
) -> Options:
    """:func:`solve_dp`'s arguments checked (``spacing`` = dx_nm, dy_nm, half_width_nm, dt_h); ConfigError naming a bad one."""
    if not callable(leg_cost):
        raise ConfigError(f"leg_cost must be callable, got {type(leg_cost).__name__}")
    s = tuple(float(v) for v in finite("start (lat, lon) [deg]", start, error=ConfigError))
    e = tuple(float(v) for v in finite("end (lat, lon) [deg]", end, error=ConfigError))
    dx_nm, dy_nm, half_width_nm, dt_h = spacing
    dx = float(finite("dx_nm", dx_nm, minimum=0.0, strict=True, error=ConfigError))
    dy = float(finite("dy_nm", dy_nm, minimum=0.0, strict=True, error=ConfigError))
    hw = float(finite("half_width_nm", half_width_nm, minimum=0.0, error=ConfigError))
    dt = float(finite("dt_h", dt_h, minimum=0.0, strict=True, error=ConfigError))
    speeds = np.arange(5.0, 30.5, 1.0) if speeds_kn is None else np.unique(np.asarray(speeds_kn, dtype=float))
    speeds = finite("speeds_kn", speeds, minimum=0.0, strict=True, error=ConfigError)
    if speeds.ndim != 1 or speeds.size == 0:
        raise ConfigError("speeds_kn must be a non-empty 1-D set of speeds [kn]")
    if eta_h is not None:
        eta_h = float(finite("eta_h", eta_h, minimum=0.0, strict=True, error=ConfigError))
    step = None if max_lateral_step is None else int(max_lateral_step)
    n_labels = None
    if labels_per_bin is not None:
        n_labels = int(finite("labels_per_bin", labels_per_bin, minimum=1.0, error=ConfigError))
        if n_labels != labels_per_bin:
            raise ConfigError(f"labels_per_bin={labels_per_bin} must be a whole number >= 1, or None (every label)")
    if step is not None and step < 0:
        raise ConfigError(f"max_lateral_step={max_lateral_step} must be >= 0")
    nogo_step = (
        dy
        if nogo_step_nm is None
        else float(finite("nogo_step_nm", nogo_step_nm, minimum=0.0, strict=True, error=ConfigError))
    )
    if float(geo.distance_nm(*s, *e)) < 1e-6:
        raise ConfigError(f"start {s} and end {e} coincide; there is nothing to route")
    if label_value not in ("fuel", "time"):
        raise ConfigError(
            f"label_value={label_value!r} is not known; use 'fuel' (least fuel per arrival bin) or 'time' (the "
            "earliest arrival per bin, for a minimum time)"
        )
    return Options(s, e, dx, dy, hw, dt, speeds, eta_h, step, n_labels, nogo_step, label_value == "time")


@dataclass(frozen=True, eq=False)
class Lattice:
    """The DP's states: positions (K+1, n_lat) [deg], lateral offsets [nm], distances to the end [nm] and leg
    lengths [nm] per stage, the horizon [h] and the arrival bins ``(t_ref, dt, n_bins)``: bin b holds the arrivals
    in ``(t_ref + b dt, t_ref + (b + 1) dt]``."""

    lat: np.ndarray
    lon: np.ndarray
    lateral: np.ndarray
    n_stages: int
    rem_nm: np.ndarray
    dists: list[np.ndarray]
    horizon: float
    bins: tuple[float, float, int]

    @property
    def n_lat(self) -> int:
        return self.lateral.size

    @property
    def centre(self) -> int:
        return self.lateral.size // 2

    @property
    def n_bins(self) -> int:
        return self.bins[2]

    def bin_of(self, t_h: float) -> int:
        """The bin of an arrival at ``t_h`` [h]."""
        t_ref, dt, _ = self.bins
        return int(np.ceil((t_h - t_ref) / dt - BIN_TOL_H / dt)) - 1

    def destinations(self, k: int) -> np.ndarray:
        """The lateral states of stage k + 1 (the centre alone at the end)."""
        return np.array([self.centre]) if k + 1 == self.n_stages else np.arange(self.n_lat)


def lattice(opt: Options, stations: tuple | None, horizon_h: float | None) -> Lattice:
    """The stages' states (the great-circle lattice of ``opt`` or the given ``stations``), horizon and bins."""
    s, e = opt.start, opt.end
    if stations is None:
        n_half = int(np.floor(opt.half_width / opt.dy + 1e-9))
        lat, lon, lateral, n_stages = stage_geometry(s, e, opt.dx, opt.dy, n_half)
    else:
        lat, lon, lateral, n_stages = given_stations(stations, s, e)
    rem_nm = geo.distance_nm(lat, lon, e[0], e[1])  # WGS84, as the legs
    horizon = (
        float(geo.distance_nm(*s, *e)) / float(opt.speeds.min())
        if horizon_h is None
        else float(finite("horizon_h", horizon_h, minimum=0.0, strict=True, error=ConfigError))
    )
    eta_h, dt = opt.eta_h, opt.dt
    if eta_h is not None:
        horizon = max(horizon, eta_h)
    # the ETA is a bin end, departure in bin 0
    t_ref = (0.0 if eta_h is None else eta_h - np.ceil(eta_h / dt - 1e-12) * dt) - dt
    n_bins = int(np.ceil((horizon - t_ref) / dt - BIN_TOL_H / dt))
    dists = [
        geo.distance_nm(lat[k][:, None], lon[k][:, None], lat[k + 1][None, :], lon[k + 1][None, :])
        for k in range(n_stages)
    ]
    return Lattice(lat, lon, lateral, n_stages, rem_nm, dists, horizon, (t_ref, dt, n_bins))
