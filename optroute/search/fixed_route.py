"""Fixed waypoints sailed with Boeing's speed reduction (EP 2145155 Fig. 22): the baseline a master would sail."""

from __future__ import annotations

import time as _time
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError, NoSafePassage
from optroute.physics.passage import best_speed
from optroute.physics.performance import PerformanceModel, default_model
from optroute.physics.safety import BandRules
from optroute.physics.ship import Ship
from optroute.search.passage_physics import PassagePhysics, as_sampler, leg_band_sides, per_leg
from optroute.search.piece_geometry import points_along
from optroute.search.route import Corridor, Route
from optroute.units import as_utc_time as _as_time
from optroute.units import h_to_timedelta as _h_to_td
from optroute.weather.sample import WeatherSampler


def sail_route(
    waypoints: ArrayLike,
    weather: xr.Dataset | WeatherSampler,
    ship: Ship,
    *,
    departure: Any,
    desired_speed_kn: float | None = None,
    piece_nm: float = 10.0,
    speed_step_kn: float = 0.5,
    min_speed_kn: float = 3.0,
    model: PerformanceModel | None = None,
    rules: BandRules | None = None,
) -> Route:
    """Sail fixed waypoints with Boeing's speed reduction: the baseline a master would sail.

    Every leg is cut into pieces of at most ``piece_nm``; at each piece, at
    the time the ship gets there, the speed starts at ``desired_speed_kn`` and
    is reduced until every danger band holds and the power is within
    [minimum load, MCR] (EP 2145155 Fig. 22).  This is the "great circle with
    forced slow-downs" of Boeing EP 2145155's worked example when the waypoints are a
    great circle (:func:`optroute.geodesy.great_circle_points`).

    Parameters
    ----------
    waypoints : array_like, shape (n, 2)
        (lat, lon) [deg].
    weather : xarray.Dataset or WeatherSampler
    ship : Ship
    departure : datetime64 or str
        [UTC].
    desired_speed_kn : float, optional
        [kn]; default the design speed.
    piece_nm : float
        Longest piece evaluated with one sea state [nm].
    speed_step_kn, min_speed_kn : float
        Speed-reduction step and floor [kn].
    model, rules
        As in :func:`search_route`.

    Returns
    -------
    Route
        With ``objective="time"`` and ``method="fixed"``.

    Raises
    ------
    NoSafePassage
        A piece where no speed down to ``min_speed_kn`` is allowed (or the
        weather has no data); the message names the position and time.
    """
    t_start = _time.perf_counter()
    t0 = _as_time(departure, "departure")
    wp = np.asarray(Corridor(waypoints).waypoints)
    model = model if model is not None else default_model(ship)
    rules = rules if rules is not None else BandRules()
    desired = float(desired_speed_kn if desired_speed_kn is not None else ship.design_speed_kn)
    step = float(finite("piece_nm", piece_nm, minimum=0.0, strict=True, error=ConfigError))
    physics = PassagePhysics(ship, model, rules, as_sampler(weather), t0)
    t_h = 0.0
    times, leg_dur, leg_fuel, leg_dist = [0.0], [], [], []
    pieces: dict[str, list] = {
        k: [] for k in ("stw_kn", "heading_deg", "power_kw", "hs_m", "period_s", "wave_from_deg", "duration_h")
    }
    leg_of: list[int] = []
    for k in range(wp.shape[0] - 1):
        (la0, lo0), (la1, lo1) = wp[k], wp[k + 1]
        dist = float(geo.distance_nm(la0, lo0, la1, lo1))
        m = max(1, int(np.ceil(dist / step)))
        lat, lon, course = points_along(
            np.array([la0]), np.array([lo0]), np.array([la1]), np.array([lo1]), (np.arange(m) + 0.5) / m
        )
        dur_k = fuel_k = 0.0
        for j in range(m):
            sea = physics.sea(lat[0, j : j + 1], lon[0, j : j + 1], np.array([t_h]))
            choice = best_speed(
                ship, model, rules, course[0, j : j + 1], sea, desired, step_kn=speed_step_kn, min_stw_kn=min_speed_kn
            )
            if not choice.feasible[0] or not choice.sog_kn[0] > 0:
                when = units.format_utc(t0 + _h_to_td(t_h))
                raise NoSafePassage(
                    f"no allowed speed down to {min_speed_kn} kn at ({lat[0, j]:.3f}, {lon[0, j]:.3f}) on leg {k} at "
                    f"{when} (Hs {sea.hs_m[0]:.1f} m): the fixed route cannot be sailed; search a route instead"
                )
            d = dist / m / choice.sog_kn[0]
            t_h += d
            dur_k += d
            fuel_k += d * choice.fuel_tph[0]
            for key, val in (
                ("stw_kn", choice.stw_kn),
                ("heading_deg", choice.heading_deg),
                ("power_kw", choice.power_kw),
                ("hs_m", sea.hs_m),
                ("period_s", sea.period_s),
                ("wave_from_deg", sea.wave_from_deg),
            ):
                pieces[key].append(float(val[0]))
            pieces["duration_h"].append(d)
            leg_of.append(k)
        times.append(t_h)
        leg_dur.append(dur_k)
        leg_fuel.append(fuel_k)
        leg_dist.append(dist)
    piece = {k: np.asarray(v) for k, v in pieces.items()}
    leg_idx = np.asarray(leg_of, dtype=int)
    n_legs = wp.shape[0] - 1
    dur = np.asarray(leg_dur)
    return Route(
        waypoints=wp,
        times=t0 + _h_to_td(np.asarray(times)),
        sog_kn=np.asarray(leg_dist) / dur,
        stw_kn=per_leg(piece, "stw_kn", piece["duration_h"], leg_idx, n_legs),
        power_kw=per_leg(piece, "power_kw", piece["duration_h"], leg_idx, n_legs),
        fuel_t=np.asarray(leg_fuel),
        duration_h=dur,
        distance_nm=np.asarray(leg_dist),
        cost=float(t_h),
        objective="time",
        method="fixed",
        band_side=leg_band_sides(ship, rules, piece, leg_idx, n_legs),
        stats={
            "pieces": int(leg_idx.size),
            "min_stw_kn": float(piece["stw_kn"].min()),
            "runtime_s": _time.perf_counter() - t_start,
        },
    )
