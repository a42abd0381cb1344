"""Sailing a yacht under way, re-planning when the wind met departs from the forecast (Życkowski; issue 18 item 4).

:func:`simulate_sailing` sails a :class:`~optroute.physics.yacht.SailingVessel` along the route of
the sailing search (:func:`optroute.search.sailing.search_sailing_route`) through a "truth" wind
in time steps: each step the boat steers the great circle from where it is to the next node of
its route, at the speed its polar gives in the TRUE wind met at the step's start
(:meth:`SailingVessel.leg_speed_kn`, the model the search and ``SailingRoute.verify`` use); no
fuel. A step ends at a node, so each leg is sailed at its own heading and the tacks and gybes
fall where the route puts them; they are counted from the signed true wind angle of the steps
sailed (:func:`optroute.search.sailing.manoeuvres_along`).

Re-plans start from the boat's position and time under the shared
:class:`~optroute.voyage.policy.ReplanPolicy`: on a new forecast
(:class:`~optroute.voyage.policy.ForecastSequence`), every N hours, or when the wind met differs
from the route's forecast at the boat by more than ``wind_speed_threshold_kn`` or
``wind_direction_threshold_deg`` (the paper's trigger). A re-plan the wind met triggers searches
the newest forecast corrected by the error observed: the (u, v) difference between the wind met
and the forecast at the boat added to the whole forecast (a modelling choice: the observed error
persists, as a navigator assumes who sees the forecast wrong on deck). A leg the truth puts in the
no-go sector cannot be sailed: the boat then re-plans whatever the policy (the master must), and
stops with :class:`~optroute.voyage.simulate.VoyageError` if no route is found.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError, OptrouteError
from optroute.physics.yacht import SailingVessel, check_vessel, wind_kn_from
from optroute.search.sailing import SailingRoute, manoeuvres_along, sailing_sampler, search_sailing_route
from optroute.units import as_utc_time as _as_time
from optroute.units import h_to_timedelta as _h_to_td
from optroute.units import timedelta_to_h as _td_to_h
from optroute.voyage.policy import ForecastSequence, ReplanPolicy
from optroute.voyage.simulate import VoyageError

__all__ = ["SailingOutcome", "SailingVoyage", "simulate_sailing"]

_ARRIVED_NM = 1e-6


@dataclass(frozen=True)
class SailingOutcome:
    """What a simulated sailing passage achieved in the truth wind.

    Attributes
    ----------
    departure, arrival : numpy.datetime64
        [UTC].
    distance_nm : float
        Distance sailed [nm].
    n_manoeuvres : int
        Tacks and gybes sailed.
    n_replans : int
        Routes searched after the first.
    time_motoring_h : float
        Time under engine [h].
    """

    departure: np.datetime64
    arrival: np.datetime64
    distance_nm: float
    n_manoeuvres: int
    n_replans: int
    time_motoring_h: float

    @property
    def passage_h(self) -> float:
        """Passage time [h]."""
        return float(_td_to_h(self.arrival - self.departure))


@dataclass(frozen=True, eq=False)
class SailingVoyage:
    """A simulated sailing passage: the outcome, the log and every route sailed (the first first)."""

    outcome: SailingOutcome
    log: xr.Dataset = field(repr=False)
    routes: tuple[SailingRoute, ...] = field(repr=False)


class _Wind:
    """True wind speed [kn] and direction (from) [deg] of a dataset at a point, its sampler built once."""

    def __init__(self, ds: xr.Dataset) -> None:
        self.ds, self.sampler = ds, sailing_sampler(ds)

    def at(self, t: np.datetime64, lat: float, lon: float) -> tuple[float, float, float, float]:
        w = self.sampler.sample(np.array([t]), np.array([lat]), np.array([lon]), variables=["wind_u_ms", "wind_v_ms"])
        u, v = float(w["wind_u_ms"][0]), float(w["wind_v_ms"][0])
        if not (math.isfinite(u) and math.isfinite(v)):
            raise VoyageError(
                f"no wind at ({lat:.4f}, {lon:.4f}) {units.format_utc(t)} in {self.sampler.source}; give a wind "
                "covering the whole passage (area and time)"
            )
        tws, frm = wind_kn_from(u, v)
        return float(tws), float(frm), u, v


@dataclass
class _State:
    route: SailingRoute
    wind: _Wind  # the forecast (possibly corrected) the route was searched on
    forecast_index: int | None
    made_at: np.datetime64
    node: int = 0  # the route node the boat last reached (it sails to node + 1)


def _corrected(ds: xr.Dataset, du_ms: float, dv_ms: float) -> xr.Dataset:
    """The forecast with the observed (u, v) error added everywhere (the error persists)."""
    out = ds.copy()
    out["wind_u_ms"] = ds["wind_u_ms"] + du_ms
    out["wind_v_ms"] = ds["wind_v_ms"] + dv_ms
    out.attrs = {**ds.attrs, "source": f"{ds.attrs.get('source', 'forecast')} corrected by the wind met"}
    return out


def _wind_trigger(policy: ReplanPolicy, met: tuple, fc: tuple) -> str:
    d_speed = abs(met[0] - fc[0])
    d_dir = abs((met[1] - fc[1] + 180.0) % 360.0 - 180.0)
    for name, diff, limit, unit in (
        ("wind speed", d_speed, policy.wind_speed_threshold_kn, "kn"),
        ("wind direction", d_dir, policy.wind_direction_threshold_deg, "deg"),
    ):
        if limit is not None and diff > limit:
            return f"wind met: {name} differs from the route's forecast by {diff:.3g} {unit} > {limit:.3g} {unit}"
    return ""


def simulate_sailing(
    endpoints: Sequence[Any],
    truth: xr.Dataset,
    vessel: SailingVessel,
    *,
    forecasts: Sequence[tuple[Any, xr.Dataset]],
    departure: Any,
    replan: ReplanPolicy | None = None,
    step_h: float = 0.25,
    search_options: Mapping[str, Any] | None = None,
    min_replan_distance_nm: float = 2.0,
) -> SailingVoyage:
    """Sail a yacht through the truth wind, re-planning with the sailing search under a policy.

    Parameters
    ----------
    endpoints : ((lat, lon), (lat, lon))
        Start and destination [deg].
    truth : xarray.Dataset
        The wind the boat really meets (canonical, ``wind_u_ms``/``wind_v_ms`` [m/s]).
    vessel : SailingVessel
    forecasts : sequence of (issue time, xarray.Dataset)
        Wind forecasts [UTC], each usable from its issue time on.
    departure : datetime64 or str
        [UTC].
    replan : ReplanPolicy, optional
        Default: on new forecasts only. ``wind_speed_threshold_kn`` and
        ``wind_direction_threshold_deg`` give Życkowski's trigger.
    step_h : float
        Simulator time step [h], > 0 (a step also ends at every route node).
    search_options : mapping, optional
        Keyword arguments of :func:`optroute.search.sailing.search_sailing_route` (``cell_nm``,
        ``directions``, ``objective``, ``margin_nm``, ...).
    min_replan_distance_nm : float
        No re-plan when less than this is left to the destination [nm], >= 0.

    Returns
    -------
    SailingVoyage

    Raises
    ------
    ConfigError
        A bad argument; ForecastTimeError, a forecast before its issue time.
    VoyageError
        The boat cannot go on (a leg in the no-go sector of the truth and no route from there).
    """
    policy = replan if replan is not None else ReplanPolicy()
    if not isinstance(policy, ReplanPolicy):
        raise ConfigError(f"replan must be a ReplanPolicy, got {type(policy).__name__}")
    vessel = check_vessel(vessel)
    fseq = forecasts if isinstance(forecasts, ForecastSequence) else ForecastSequence(forecasts)
    step = float(finite("step_h", step_h, minimum=0.0, strict=True, error=ConfigError, fix="pass a step > 0 h"))
    min_left = float(finite("min_replan_distance_nm", min_replan_distance_nm, minimum=0.0, error=ConfigError))
    try:
        (a_lat, a_lon), (b_lat, b_lon) = endpoints
        start, dest = (float(a_lat), float(a_lon)), (float(b_lat), float(b_lon))
    except (TypeError, ValueError):
        raise ConfigError(f"endpoints={endpoints!r} must be ((lat, lon), (lat, lon)) [deg]") from None
    t0 = _as_time(departure, "departure")
    opts = dict(search_options or {})
    truth_wind = _Wind(truth)

    def search(pos: np.ndarray, t: np.datetime64, wind: _Wind) -> SailingRoute:
        return search_sailing_route((float(pos[0]), float(pos[1])), dest, wind.ds, vessel, departure=t, **opts)

    k, ds = fseq.latest(t0)
    wind = _Wind(ds)
    first = _from_here(search(np.array(start), t0, wind), np.array(start))
    state = _State(first, wind, k, t0)
    routes, replans = [first], [_replan_row(first, "initial plan", "optimal", t0, k, fseq)]
    steps: list[dict[str, Any]] = []
    t, pos = t0, np.array(start, dtype=float)
    while float(geo.distance_nm(pos[0], pos[1], *dest)) > _ARRIVED_NM:
        met = truth_wind.at(t, float(pos[0]), float(pos[1]))
        target = _target(state.route, state.node, dest)
        course = float(geo.initial_course_deg(pos[0], pos[1], target[0], target[1]))
        speed, twa, motoring = (float(np.asarray(x)) for x in vessel.leg_speed_kn(course, met[1], met[0]))
        left = float(geo.distance_nm(pos[0], pos[1], *dest))
        reason = _reason(policy, state, fseq, t, pos, met) if left >= max(min_left, _ARRIVED_NM) else ""
        if not speed > 0 and not reason:
            if state.made_at == t and len(routes) > 1:
                raise VoyageError(
                    f"the boat at ({pos[0]:.4f}, {pos[1]:.4f}) {units.format_utc(t)} cannot sail the first leg of the "
                    f"route just searched from there (no-go sector of the wind met, {met[0]:.3g} kn from "
                    f"{met[1]:.0f} deg); give a forecast closer to the truth or a finer step"
                )
            reason = f"the leg to ({target[0]:.4f}, {target[1]:.4f}) lies in the no-go sector of the wind met"
        if reason:
            n_routes = len(routes)
            state = _replan(state, reason, search, fseq, t, pos, met, routes, replans, must=not speed > 0)
            if len(routes) > n_routes:
                continue  # sail the new route from here (its first leg's wind evaluated afresh)
        budget = step - _elapsed_in_step(t, t0, step)
        rec, end, reached = _advance(t, pos, target, course, speed, budget)
        steps.append({**rec, "twa_deg": twa, "tws_kn": met[0], "wind_from_deg": met[1], "motoring": bool(motoring),
                      "node": state.node})  # fmt: skip
        t, pos = t + _h_to_td(rec["duration_h"]), end
        if reached:
            state.node += 1
    return _result(steps, replans, routes, t0, t)


def _advance(t, pos, target, course: float, speed: float, budget_h: float) -> tuple[dict[str, Any], np.ndarray, bool]:
    """Sail ``speed`` kn on ``course`` toward ``target`` for at most ``budget_h`` (stopping there): the step, its end."""
    d = float(geo.distance_nm(pos[0], pos[1], target[0], target[1]))
    h = min(budget_h, d / speed)
    reached = d / speed <= budget_h
    if reached:
        end = np.array(target, dtype=float)
    else:
        elat, elon = geo.destination(pos[0], pos[1], course, speed * h)
        end = np.array([float(elat), float(units.wrap_180(elon))])
    rec = {"time": t, "lat": float(pos[0]), "lon": float(pos[1]), "duration_h": h, "distance_nm": speed * h,
           "heading_deg": course, "speed_kn": speed}  # fmt: skip
    return rec, end, reached


def _target(route: SailingRoute, node: int, dest: tuple[float, float]) -> tuple[float, float]:
    """The next route node; past the route's last node (the lattice node nearest the destination) the destination."""
    if node + 1 < route.lat_deg.size:
        return float(route.lat_deg[node + 1]), float(route.lon_deg[node + 1])
    return dest


def _reason(policy, state: _State, fseq: ForecastSequence, t, pos, met) -> str:
    since = float(_td_to_h(t - state.made_at))
    if not policy.replans or since < policy.min_interval_h or since <= 0:
        return ""
    k = fseq.latest_index(t)
    if policy.on_forecast and k is not None and (state.forecast_index is None or k > state.forecast_index):
        return f"new forecast issued {units.format_utc(fseq.issue_times[k])}"
    if policy.every_h is not None and since >= policy.every_h - 1e-9:
        return f"periodic: {since:.3g} h since the last route"
    return _wind_trigger(policy, met, state.wind.at(t, float(pos[0]), float(pos[1])))


def _replan(state, reason, search, fseq, t, pos, met, routes, replans, *, must: bool) -> _State:
    """Search from here on the newest forecast (corrected by the wind met when the wind triggered it)."""
    k, ds = fseq.latest(t)
    wind = _Wind(ds)
    if reason.startswith("wind met") or must:
        fc = wind.at(t, float(pos[0]), float(pos[1]))
        wind = _Wind(_corrected(ds, met[2] - fc[2], met[3] - fc[3]))
    try:
        route = search(pos, t, wind)
    except OptrouteError as exc:
        replans.append(_replan_row(None, reason, f"failed: {exc}", t, k, fseq))
        if must:
            raise VoyageError(
                f"the boat at ({pos[0]:.4f}, {pos[1]:.4f}) {units.format_utc(t)} cannot sail its route in the wind "
                f"met ({reason}) and no new route was found: {exc}"
            ) from exc
        state.made_at, state.forecast_index = t, k
        return state
    route = _from_here(route, pos)
    routes.append(route)
    replans.append(_replan_row(route, reason, route.status, t, k, fseq))
    return _State(route, wind, k, t)


def _from_here(route: SailingRoute, pos: np.ndarray) -> SailingRoute:
    """The route as found: its first node is the lattice node at the boat (the lattice is anchored there)."""
    if float(geo.distance_nm(pos[0], pos[1], route.lat_deg[0], route.lon_deg[0])) > 1e-6:
        raise VoyageError(f"the re-planned route starts at ({route.lat_deg[0]:.5f}, {route.lon_deg[0]:.5f}), not at "
                          f"the boat ({pos[0]:.5f}, {pos[1]:.5f}); pass a grid anchored at the boat (cell_nm)")  # fmt: skip
    return route


def _elapsed_in_step(t: np.datetime64, t0: np.datetime64, step: float) -> float:
    h = float(_td_to_h(t - t0))
    r = h - step * np.floor(h / step + 1e-9)
    return 0.0 if r < 1e-9 or step - r < 1e-9 else r


def _replan_row(route, reason, status, t, k, fseq) -> dict[str, Any]:
    nat = np.datetime64("NaT", "ns")
    return {
        "time": t, "reason": reason, "status": status, "forecast_index": -1 if k is None else int(k),
        "forecast_issued": fseq.issue_times[k] if k is not None else nat,
        "passage_h": math.nan if route is None else route.passage_h,
        "arrival": nat if route is None else route.time[-1],
        "manoeuvres": -1 if route is None else route.n_manoeuvres,
        "waypoints": np.zeros((0, 2)) if route is None else np.column_stack([route.lat_deg, route.lon_deg]),
    }  # fmt: skip


def _result(steps, replans, routes, t0, t) -> SailingVoyage:
    """The outcome and the log (``step`` and ``replan`` variables, the ship simulator's names where shared)."""
    col = {k: np.array([s[k] for s in steps]) for k in steps[0]} if steps else {}
    times = col.get("time", np.zeros(0, dtype="datetime64[ns]")).astype("datetime64[ns]")
    t_h = np.asarray(_td_to_h(times - t0), dtype=float)
    lat, lon = col.get("lat", np.zeros(0)), col.get("lon", np.zeros(0))
    man = manoeuvres_along(
        col.get("twa_deg", np.zeros(0)), col.get("motoring", np.zeros(0, bool)), times, t_h, lat, lon
    )
    outcome = SailingOutcome(
        departure=t0, arrival=t, distance_nm=float(np.sum(col.get("distance_nm", 0.0))), n_manoeuvres=len(man),
        n_replans=len(routes) - 1,
        time_motoring_h=float(np.sum(col["duration_h"][col["motoring"]])) if steps else 0.0,
    )  # fmt: skip
    data: dict[str, Any] = {"step_time": ("step", times)}
    units_of = {"lat": "degrees_north", "lon": "degrees_east", "duration_h": "h", "distance_nm": "nmi",
                "heading_deg": "degree", "speed_kn": "kn", "twa_deg": "degree", "tws_kn": "kn",
                "wind_from_deg": "degree"}  # fmt: skip
    for name, unit in units_of.items():
        data[name] = ("step", np.asarray(col.get(name, np.zeros(0)), dtype=float), {"units": unit})
    data["motoring"] = ("step", np.asarray(col.get("motoring", np.zeros(0)), dtype=np.int8))
    data["leg"] = ("step", np.asarray(col.get("node", np.zeros(0)), dtype=np.int32))
    n_wp = max(r["waypoints"].shape[0] for r in replans)
    wlat, wlon = np.full((len(replans), n_wp), np.nan), np.full((len(replans), n_wp), np.nan)
    for i, r in enumerate(replans):
        m = r["waypoints"].shape[0]
        wlat[i, :m], wlon[i, :m] = r["waypoints"][:, 0], r["waypoints"][:, 1]
    for key, dtype in (("time", "datetime64[ns]"), ("reason", str), ("status", str), ("forecast_index", np.int32),
                       ("forecast_issued", "datetime64[ns]"), ("passage_h", float), ("arrival", "datetime64[ns]"),
                       ("manoeuvres", np.int32)):  # fmt: skip
        data[f"replan_{key}"] = ("replan", np.array([r[key] for r in replans], dtype=dtype))
    data["replan_waypoint_lat"] = (("replan", "replan_waypoint"), wlat, {"units": "degrees_north"})
    data["replan_waypoint_lon"] = (("replan", "replan_waypoint"), wlon, {"units": "degrees_east"})
    log = xr.Dataset(data)
    log.attrs.update({
        "title": "optroute simulated sailing passage log", "departure": units.format_utc(t0),
        "arrival": units.format_utc(t), "passage_h": outcome.passage_h, "distance_nm": outcome.distance_nm,
        "n_manoeuvres": outcome.n_manoeuvres, "n_replans": outcome.n_replans,
    })  # fmt: skip
    return SailingVoyage(outcome, log, tuple(routes))
