"""Route search through forecast weather: ``search_route``, its arguments, and the grid search's route.

The search machinery (:mod:`optroute.search`) knows nothing of ships or
weather; :func:`search_route` checks the user's arguments, builds the
callbacks of :class:`~optroute.search.passage_physics.PassagePhysics` (the
weather at the ship and the speed chosen there, Boeing EP 2145155 Figs. 21–22),
runs the grid search for the objective asked
(:mod:`optroute.search.objective_search`), the 3-D DP
(:mod:`optroute.search.dp_route`, Shao et al.) or the sailing search, and
turns the answer into a :class:`~optroute.search.route.Route`.
:func:`sail_route` (fixed waypoints, :mod:`optroute.search.fixed_route`),
:class:`PassagePhysics` and :func:`as_sampler` are re-exported here.
"""

from __future__ import annotations

import dataclasses
import time as _time
import warnings
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError, InfeasibleETA, NoSafePassage, WeatherCoverageError
from optroute.geo import land
from optroute.geo.tracks import Exclusion
from optroute.physics.performance import PerformanceModel, default_model
from optroute.physics.safety import BandRules
from optroute.physics.ship import Ship
from optroute.physics.yacht import SailingVessel
from optroute.search import cost_bound
from optroute.search.dijkstra import shortest_path
from optroute.search.dp_route import search_dp
from optroute.search.edge_land import EdgeLand
from optroute.search.exclusion import avoiding
from optroute.search.fixed_route import sail_route
from optroute.search.grid import RouteGrid
from optroute.search.neighbourhood import Neighbourhood, angular_resolution, compass
from optroute.search.objective_search import eta_as_time, explain_uncovered, run_objective
from optroute.search.passage_physics import PassagePhysics, as_sampler, leg_band_sides, per_leg
from optroute.search.route import Route
from optroute.search.sailing import SailingGraph, SailingGrid, SailingRoute, SailObjective, search_sailing_route
from optroute.units import as_utc_time as _as_time
from optroute.units import h_to_timedelta as _h_to_td
from optroute.weather.sample import WeatherSampler

Objective = Literal["time", "fuel", "cost"]
Method = Literal["astar", "dijkstra", "dp"]

__all__ = [
    "LAMBDA_CELLS_ALONG",
    "LAMBDA_CELL_MAX_NM",
    "PORT_CLEARANCE_NM",
    "Method",
    "Objective",
    "PassagePhysics",
    "as_sampler",
    "sail_route",
    "search_route",
]


PORT_CLEARANCE_NM = 10.0
"""Most open water the grid search keeps about a snapped port where it walks its legs on the coastline [nm]:
the default 20 nm cells' half cell, so that coarser cells start and end where those do, not farther out to sea
(half a cell of a coarse grid would plan a shorter voyage)."""

LAMBDA_CELLS_ALONG = 40
"""With ``stop_at_track``, the fuel objective's λ is bisected on a grid of about this many cells along the great
circle (cells of at most :data:`LAMBDA_CELL_MAX_NM`), then searched once on the route's own grid
(:func:`optroute.search.objective_search.bisect_on_coarse`), where that grid is at least twice as coarse."""
LAMBDA_CELL_MAX_NM = 120.0
"""The largest cell [nm] of the grid the λ is bisected on by default (:data:`LAMBDA_CELLS_ALONG`)."""


def _neighbourhood(angular_resolution_deg: float | None, directions: int | None, radius: int) -> Neighbourhood:
    if directions is not None:
        return compass(directions)
    if angular_resolution_deg is None:
        raise ConfigError("give angular_resolution_deg (Boeing neighbourhood) or directions (8, 16 or 32)")
    return angular_resolution(angular_resolution_deg, radius)


def _max_current_kn(ds: xr.Dataset | None) -> float:
    if ds is None or "current_u_ms" not in ds or "current_v_ms" not in ds:
        return 0.0
    speed = np.hypot(ds["current_u_ms"], ds["current_v_ms"]).max(skipna=True)
    return float(units.ms_to_kn(float(speed.compute() if hasattr(speed, "compute") else speed)))


def search_route(
    start: tuple[float, float],
    end: tuple[float, float],
    weather: xr.Dataset | WeatherSampler,
    ship: Ship | None = None,
    *,
    departure: Any,
    objective: Objective | SailObjective = "time",
    eta: Any = None,
    method: Method = "astar",
    angular_resolution_deg: float | None = 5.0,
    directions: int | None = None,
    radius_cells: int = 12,
    cell_nm: float = 20.0,
    margin_nm: float | None = None,
    desired_speed_kn: float | None = None,
    speeds_kn: ArrayLike | None = None,
    speed_step_kn: float = 0.5,
    min_speed_kn: float = 3.0,
    lambda_t_per_h: float | None = None,
    fuel_price_per_t: float = 600.0,
    hourly_cost_per_h: float = 0.0,
    model: PerformanceModel | None = None,
    rules: BandRules | None = None,
    use_land_mask: bool | None = None,
    snap_max_nm: float | None = None,
    band_check_nm: float | None = 10.0,
    dp_options: dict[str, Any] | None = None,
    compiled: bool = True,
    exclusion: Exclusion | None = None,
    vessel: SailingVessel | None = None,
    manoeuvre_penalty_h: float | None = None,
    sailing_grid: SailingGrid | SailingGraph | None = None,
    stop_at_track: bool = False,
    lambda_cell_nm: float | None = None,
) -> Route | SailingRoute:
    """Search the route corridor through forecast weather.

    Parameters
    ----------
    start, end : (float, float)
        Departure and destination (lat, lon) [deg]; points on land (ports)
        are snapped to navigable water within ``snap_max_nm`` with a warning.
    weather : xarray.Dataset or WeatherSampler
        Canonical weather (:func:`optroute.open_weather`, :mod:`optroute.scenarios`).
    ship : Ship
    departure : datetime64 or str
        Departure time [UTC].
    objective : {"time", "fuel", "cost"}
        ``"time"``: earliest arrival, each piece at the fastest allowed speed
        at or below ``desired_speed_kn`` (Boeing).  ``"fuel"``: least fuel;
        with ``eta`` an outer bisection on λ (t/h) finds the least-fuel route
        arriving by the ETA.  ``"cost"``: fuel price × fuel + hourly cost ×
        time, i.e. λ = hourly cost / fuel price.
    eta : datetime64 or str, optional
        Required arrival [UTC] (arrive at or before).
    method : {"astar", "dijkstra", "dp"}
        Time-dependent A* or Dijkstra on a gnomonic grid (Boeing EP 2145155), or the
        3D dynamic programme along the great circle (Shao et al.).
    angular_resolution_deg, directions, radius_cells
        Grid neighbourhood: Boeing's minimum-angular-resolution set (default
        5° within 12 cells), or ``directions`` = 8, 16 or 32 (Życkowski).
    cell_nm : float
        Grid cell size [nm].
    margin_nm : float, optional
        Grid margin around the start–end box [nm].
    desired_speed_kn : float, optional
        Speed through water wanted [kn]; default the ship's design speed.
    speeds_kn : array_like, optional
        Discrete speed set for ``"fuel"``/``"cost"`` and the DP [kn]; default
        5, 5.5, … up to the ship's calm-water top speed.
    speed_step_kn, min_speed_kn : float
        Boeing speed-reduction step and floor [kn].
    lambda_t_per_h : float, optional
        Fix λ instead of deriving it (``"fuel"``/``"cost"``) [t/h].
    fuel_price_per_t, hourly_cost_per_h : float
        For ``"cost"``: fuel price [currency/t] and the ship's hourly cost
        [currency/h].
    model : PerformanceModel, optional
        Default :class:`~optroute.physics.performance.KwonModel`.
    rules : BandRules, optional
        Default Boeing bands.
    use_land_mask : bool, optional
        Apply the coastline; default: yes, unless the weather is synthetic
        geography (``attrs["geography"] == "synthetic"``).
    snap_max_nm : float, optional
        How far a port may be moved to reach navigable water [nm]; default
        20 nm plus two grid cells.  The grid search needs open water about
        its end points (a 20 nm cell cannot enter Tokyo Bay): ports are
        snapped with a clearance of half a cell, at most
        :data:`PORT_CLEARANCE_NM` where its legs are walked on the coastline
        (GLOBE), half a cell again where no route leaves such ends, so that a
        coarse grid does not plan a shorter voyage; the last miles into port
        are pilotage, outside the routing problem.
    band_check_nm : float or None
        Grid search: each piece's speed is checked (danger bands, MCR) at
        points at most this far apart along the piece [nm], ends included, at
        the times the ship passes them (:meth:`PassagePhysics.segment_checked`),
        and between them where the referee looks (:mod:`optroute.search.band_refine`:
        a band entered over more than 0.1 nm is found).  ``None`` checks the piece's midpoint at its entry time only (Boeing's
        one sea state per cell): faster, but a route can then cross a band
        between midpoints.
    dp_options : dict, optional
        Passed to :func:`optroute.search.dp.solve_dp` (``dx_nm``, ``dy_nm``,
        ``half_width_nm``, ``dt_h`` …) for ``method="dp"``; besides,
        ``piece_nm`` (the leg costing's piece [nm]) and ``routes_for_eta_h``
        (ETAs [h from departure]: the same run's least-fuel routes for them,
        in ``route.stats["routes_for_eta_h"]``).
    compiled : bool
        Cost the legs with the compiled kernels of
        :mod:`optroute.search.passage_kernels` where they apply (the built-in
        performance models and in-memory weather; default), or with the numpy
        callbacks only (the same route and costs to rounding; slower, kept as
        the reference the kernels are tested against).
    exclusion : Exclusion, optional
        A moving circle to stay out of (a cyclone's force-7 radius + margin,
        :meth:`optroute.Exclusion.from_track`): a leg is infeasible where any point of it is
        inside the circle at the time the ship is there (:func:`optroute.search.exclusion.avoiding`;
        for the DP, its navigability test at each node and piece point, every ``piece_nm``, at its time).
    vessel : SailingVessel, optional
        A sailing boat instead of ``ship``: the route is searched by
        :func:`optroute.search.sailing.search_sailing_route` on a
        latitude/longitude lattice of ``cell_nm`` spacing (the 20 nm default is
        a ship's: give about 1 nm for coastal sailing) or ``sailing_grid``
        with ``directions`` = 8, 16 (default) or 32 headings, ``margin_nm``
        (default 5 nm), ``objective`` = ``"time"``, ``"manoeuvres"`` or
        ``"weighted"`` (with ``manoeuvre_penalty_h`` [h]); the weather needs
        wind only.  The ship-only options are not used.
    manoeuvre_penalty_h : float, optional
        Sailing, ``objective="weighted"``: hours one tack or gybe is worth [h].
    sailing_grid : SailingGrid or SailingGraph, optional
        Sailing: the lattice (default one around start and end) or its graph.
    stop_at_track : bool
        Objective ``"fuel"`` (the λ bisection): stop halving λ's bracket as soon
        as a λ's route in time takes the same grid nodes as the best one so far
        (:func:`optroute.search.objective_search.bisect_lambda`), for a caller
        that keeps the track and sets the speeds again (:func:`optroute.plan_voyage`
        does), and once λ = 0 is late take a λ whose speed in calm water is no
        faster than λ = 0's as late without searching it; default False, 12 halvings.
        With it the λ is bisected on a coarser grid first (``lambda_cell_nm``).
    lambda_cell_nm : float, optional
        Objective ``"fuel"`` with ``stop_at_track`` and no ``lambda_t_per_h``: the cell [nm] of the grid the λ
        is bisected on before the route's own grid searches once at that λ (and bisects again only where that
        route is late: :func:`optroute.search.objective_search.bisect_on_coarse`); default the great circle over
        :data:`LAMBDA_CELLS_ALONG`, at most :data:`LAMBDA_CELL_MAX_NM`, and used only where at least twice
        ``cell_nm``; ``cell_nm`` or less bisects on the route's own grid.

    Returns
    -------
    Route or SailingRoute
        For the grid search, ``stats["pieces"]`` holds the per-piece records
        of the route (``leg``, ``lat_deg``/``lon_deg`` of the midpoint,
        ``course_deg``, ``length_nm``, ``t_h`` entry [h from departure],
        ``duration_h``, ``stw_kn``, ``heading_deg``, ``power_kw``, …): the
        speed actually sailed on each piece; ``stats["searches"]`` the grid
        searches run (the λ bisection's rounds, failing ones included);
        ``stats["legs_crossing_land"]`` the legs that touch land between
        their grid nodes, checked every 0.5 nm (a warning names the first):
        empty where the search walked its legs on the coastline
        (:mod:`optroute.search.edge_land`, GLOBE), the nodes' test alone
        otherwise (GSHHG); ``stats["cell_nm"]`` the grid's cell [nm] and ``stats["lambda_cell_nm"]`` that
        of the grid λ was bisected on, with ``stats["coarse_searches"]`` its rounds (also counted in
        ``searches``).  For every
        method, ``stats["ends_moved_nm"]`` holds how far the start and the end
        were moved to open water [nm] and ``stats["ends_clearance_nm"]`` the
        open water kept about them [nm] (``snap_max_nm``).

    Raises
    ------
    NoSafePassage
        No route through navigable, survivable water.
    InfeasibleETA
        The ETA cannot be met; ``earliest_arrival`` holds the earliest found.
    OnLandError
        A port is farther than ``snap_max_nm`` from navigable water.
    WeatherCoverageError
        The voyage leaves the weather's area or time span.
    """
    if vessel is not None:
        if ship is not None:
            raise ConfigError("give either ship (engine-driven) or vessel (sailing), not both")
        if not isinstance(weather, xr.Dataset):
            raise ConfigError("a sailing search takes the weather as a canonical xarray.Dataset with wind")
        return search_sailing_route(
            start, end, weather, vessel, departure=departure, directions=directions,
            grid=sailing_grid, use_land_mask=use_land_mask, cell_nm=cell_nm, margin_nm=5.0 if margin_nm is None else margin_nm,
            objective=objective, manoeuvre_penalty_h=manoeuvre_penalty_h,  # type: ignore[arg-type]
        )  # fmt: skip
    if ship is None:
        raise ConfigError("search_route needs a ship (or vessel=SailingVessel for a sailing boat)")
    t_start = _time.perf_counter()
    if objective not in ("time", "fuel", "cost"):
        raise ConfigError(f"objective={objective!r} is not known; use 'time', 'fuel' or 'cost'")
    if method not in ("astar", "dijkstra", "dp"):
        raise ConfigError(f"method={method!r} is not known; use 'astar', 'dijkstra' or 'dp'")
    t0, eta_h = _departure_and_eta_h(departure, eta)
    ds = weather if isinstance(weather, xr.Dataset) else None
    sampler = as_sampler(weather)
    _require_departure_in_span(sampler, t0)
    model = model if model is not None else default_model(ship)
    rules = rules if rules is not None else BandRules()
    desired = float(desired_speed_kn if desired_speed_kn is not None else ship.design_speed_kn)
    finite("desired_speed_kn", desired, minimum=0.0, strict=True, error=ConfigError)
    if objective == "cost" and lambda_t_per_h is None:  # λ = hourly cost / fuel price
        finite("fuel_price_per_t", fuel_price_per_t, minimum=0.0, strict=True, error=ConfigError,
               fix="give the fuel price per tonne, > 0 (e.g. 600)")  # fmt: skip
        finite("hourly_cost_per_h", hourly_cost_per_h, minimum=0.0, error=ConfigError,
               fix="give the ship's cost per hour, >= 0 (0 makes the cost least fuel alone)")  # fmt: skip
    speeds = _speed_set(ship, speeds_kn)
    if lambda_cell_nm is not None:
        finite("lambda_cell_nm", lambda_cell_nm, minimum=0.0, strict=True, error=ConfigError,
               fix="give the cell [nm] of the grid to bisect λ on (e.g. 120), or leave it out for the default")  # fmt: skip
    physics = PassagePhysics(ship, model, rules, sampler, t0, compiled=bool(compiled))
    snap_nm = float(snap_max_nm) if snap_max_nm is not None else 20.0 + 2.0 * cell_nm
    coast = land.coastline_applies(ds, use_land_mask)

    def ends(clearance_nm: float) -> tuple[tuple, tuple, dict]:
        a, b = _snapped_ends(start, end, sampler, ds, t0, snap_nm, clearance_nm=clearance_nm,
                             use_land_mask=use_land_mask)  # fmt: skip
        moved = tuple(float(geo.distance_nm(*p, *q)) for p, q in ((start, a), (end, b)))
        return a, b, {"ends_moved_nm": moved, "ends_clearance_nm": float(clearance_nm)}

    if method == "dp":
        a, b, moved = ends(0.5)
        route = search_dp(physics, a, b, eta_h, speeds, dict(dp_options or {}), objective, t_start, coast, exclusion)
        return dataclasses.replace(route, stats={**route.stats, **moved})

    check = None if band_check_nm is None else float(
        finite("band_check_nm", band_check_nm, minimum=0.0, strict=True, error=ConfigError)
    )  # fmt: skip
    # the fastest any leg can go over ground: the speed ceiling of the objective plus the strongest current
    top_kn = desired if objective == "time" and lambda_t_per_h is None else float(speeds.max())

    def grid_search(start: tuple, end: tuple, cell: float) -> _GridSearch:
        grid = RouteGrid.build(
            start, end, cell_nm=cell, margin_nm=margin_nm, navigable=_navigable(sampler, ds, t0, use_land_mask)
        )
        search = _GridSearch(
            physics, grid, _neighbourhood(angular_resolution_deg, directions, radius_cells), exclusion, objective,
            method, eta_h, desired, speed_step_kn, min_speed_kn, speeds, check, top_kn, top_kn + _max_current_kn(ds) + 1e-6,
        )  # fmt: skip
        if coast:
            search.edge_land = EdgeLand.build(search.grid)
        return search

    def grid_route(start: tuple, end: tuple, moved: dict) -> Route:
        search = grid_search(start, end, cell_nm)
        lam_cell = cell_nm
        coarse = None
        if objective == "fuel" and lambda_t_per_h is None and stop_at_track:
            lam_cell = _lambda_cell_nm(lambda_cell_nm, cell_nm, start, end)
            coarse = grid_search(start, end, lam_cell) if lam_cell > cell_nm else None
        try:
            res, lam_used = run_objective(
                search.run, objective, eta_h, t0, lambda_t_per_h, hourly_cost_per_h, fuel_price_per_t, stop_at_track,
                lambda lam: physics.calm_cheapest_speed_kn(speeds, lam), None if coarse is None else coarse.run,
            )  # fmt: skip
        except NoSafePassage as exc:
            raise explain_uncovered(exc, physics) from None
        except InfeasibleETA as exc:
            raise eta_as_time(exc, t0) from None
        except WeatherCoverageError as exc:
            last_t = sampler.extent["time"][1]
            raise WeatherCoverageError(f"{exc} (the weather ends at {units.format_utc(last_t)})") from None
        n_coarse = 0 if coarse is None else coarse.searches
        route = _route_from_search(res, physics, t0, objective, method, lam_used, t_start, search.searches + n_coarse)
        stats = {**route.stats, **moved, "lambda_cell_nm": float(lam_cell), "coarse_searches": n_coarse}
        return _flag_land_crossings(dataclasses.replace(route, stats=stats), coast, search.grid.cell_nm)

    half_cell = 0.5 * cell_nm
    near = min(half_cell, PORT_CLEARANCE_NM) if coast and land.packed_land_available() else half_cell
    if near < half_cell:  # ports nearer the coast, the legs walked on it; where no route leaves them, half a cell out
        try:
            return grid_route(*ends(near))
        except NoSafePassage:
            pass
    return grid_route(*ends(half_cell))


def _lambda_cell_nm(given: float | None, cell_nm: float, start: tuple, end: tuple) -> float:
    """The cell [nm] of the grid the fuel objective's λ is bisected on (``search_route``'s ``lambda_cell_nm``): the
    one given, or the great circle over :data:`LAMBDA_CELLS_ALONG` (at most :data:`LAMBDA_CELL_MAX_NM`) where that
    is at least twice ``cell_nm``; else ``cell_nm`` itself (the route's own grid)."""
    if given is not None:
        return max(float(given), float(cell_nm))
    cell = min(LAMBDA_CELL_MAX_NM, float(geo.distance_nm(*start, *end)) / LAMBDA_CELLS_ALONG)
    return cell if cell >= 2.0 * cell_nm else float(cell_nm)


def _departure_and_eta_h(departure: Any, eta: Any) -> tuple[np.datetime64, float | None]:
    """The departure [UTC] and the ETA [h after it] (None without one), checked: the ETA after the departure."""
    t0 = _as_time(departure, "departure")
    if eta is None:
        return t0, None
    eta_t = _as_time(eta, "eta")
    eta_h = float((eta_t - t0) / np.timedelta64(1, "s")) / 3600.0
    if eta_h <= 0:
        raise ConfigError(
            f"eta={units.format_utc(eta_t)} is not after departure={units.format_utc(t0)}; give an arrival later than "
            "the departure"
        )
    return t0, eta_h


def _require_departure_in_span(sampler: WeatherSampler, t0: np.datetime64) -> None:
    first_t, last_t = sampler.extent["time"]
    if sampler.time_policy == "raise" and not first_t <= t0 <= last_t:
        raise WeatherCoverageError(
            f"departure={units.format_utc(t0)} lies outside the weather's time span {units.format_utc(first_t)} to "
            f"{units.format_utc(last_t)}; give a departure inside it or a forecast that covers it"
        )


def _speed_set(ship: Ship, speeds_kn: ArrayLike | None) -> np.ndarray:
    """The discrete speeds [kn]: those given, checked, or 5, 5.5, … up to the ship's calm-water top speed (≤ 40)."""
    if speeds_kn is not None:
        return finite("speeds_kn", speeds_kn, minimum=0.0, strict=True, error=ConfigError).ravel()
    top = min(ship.max_calm_speed_kn, 40.0)
    return np.arange(5.0, np.floor(top * 2) / 2 + 1e-9, 0.5)


def _snapped_ends(start, end, sampler, ds, t0, snap_nm, *, clearance_nm, use_land_mask) -> tuple:
    """Start and end inside the weather's area (else :class:`WeatherCoverageError`, not "on land"), moved to
    navigable water within ``snap_nm`` with ``clearance_nm`` of sea around them (:func:`optroute.geo.land.snap_to_sea`)."""
    for p, w in ((start, "start"), (end, "end")):  # outside the weather is not "on land": say which it is
        sampler.require_area(*p, what=w)
    return tuple(
        land.snap_to_sea(
            *p, snap_nm, clearance_nm=clearance_nm, weather=ds, time=t0, use_land_mask=use_land_mask, what=w,
            fix="give a position at sea, e.g. a pilot station off the port",
        )
        for p, w in ((start, "start"), (end, "end"))
    )  # fmt: skip


def _flag_land_crossings(route: Route, coast: bool, cell_nm: float) -> Route:
    """The grid search's route with ``stats["legs_crossing_land"]``, its legs that touch land between their ends,
    and ``stats["cell_nm"]``, the grid's cell [nm].

    The grid tests the coastline at its nodes (each cell a leg crosses, at the cell's centre) and, with a
    coastline it can walk (:class:`~optroute.search.edge_land.EdgeLand`, GLOBE), every leg across a cell with
    land in it; with another one (GSHHG) land narrower than about a cell (an island, a peninsula) can lie
    under a leg between two open-water nodes.  Each leg is checked every
    :data:`optroute.geo.land.DEFAULT_LEG_RESOLUTION_NM` along its great circle; where any touches land a
    warning names the first and the fix.  Without the coastline (``coast`` False) nothing is checked and the
    list is empty.
    """
    wp = np.asarray(route.waypoints, dtype=float)
    legs = np.zeros(0, dtype=int)
    if coast and wp.shape[0] > 1:
        step = land.DEFAULT_LEG_RESOLUTION_NM
        legs = np.flatnonzero(land.legs_cross_land(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1], step,
                                                   use_land_mask=True))  # fmt: skip
    crossing = {"legs_crossing_land": [int(k) for k in legs], "cell_nm": float(cell_nm)}
    route = dataclasses.replace(route, stats={**route.stats, **crossing})
    if legs.size:
        k = int(legs[0])
        warnings.warn(
            f"the searched route crosses land between its grid nodes on {legs.size} of its {wp.shape[0] - 1} legs "
            f"(checked every {land.DEFAULT_LEG_RESOLUTION_NM:g} nm; route.stats['legs_crossing_land']), the "
            f"first leg {k} from ({wp[k, 0]:.3f}, {wp[k, 1]:.3f}) to ({wp[k + 1, 0]:.3f}, {wp[k + 1, 1]:.3f}): "
            f"the grid tests the coastline at the centres of its {cell_nm:.3g} nm cells only; search with a "
            "smaller cell_nm, or optimise a corridor about the route (its track keeps off land)",
            UserWarning,
            stacklevel=3,
        )
    return route


def _navigable(sampler: WeatherSampler, ds: xr.Dataset | None, t0, use_land_mask: bool | None) -> Callable:
    """The grid's navigability test: inside the weather at the departure and at sea (the coastline as asked)."""

    def nav(lat, lon):
        covered = sampler.covers(np.full(np.shape(lat), t0), lat, lon)
        out = covered.copy()
        if out.any():
            out[covered] = (
                land.navigable(lat[covered], lon[covered], ds, use_land_mask=use_land_mask)
                if ds is not None
                else ~land.is_land(lat[covered], lon[covered])
            )
        return out

    return nav


class _GridSearch:
    """One grid search per call of :meth:`run` (a λ of the objective's outer search), counted in ``searches``
    (the failing ones included: ``stats["searches"]``)."""

    def __init__(self, physics, grid, hood, exclusion, objective, method, eta_h, desired, step_kn, min_kn, speeds,
                 check, top_kn, v_bound) -> None:  # fmt: skip
        self.physics, self.grid, self.hood, self.exclusion = physics, grid, hood, exclusion
        self.objective, self.method, self.eta_h = objective, method, eta_h
        self.desired, self.step_kn, self.min_kn, self.speeds, self.check = desired, step_kn, min_kn, speeds, check
        self.top_kn, self.v_bound = top_kn, v_bound
        self.limit_h = _time_limit_h(physics.sampler, physics.departure, check)
        self.searches = 0
        self.edge_land: EdgeLand | None = None  # the coastline between the nodes (set where it applies)

    def run(self, lam: float | None, ceiling: float | None = None):
        self.searches += 1
        physics, t0 = self.physics, self.physics.departure
        common = {"v_max_kn": self.v_bound, "method": self.method, "time_limit_h": self.limit_h,
                  "edge_land": self.edge_land}  # fmt: skip
        if self.objective == "time" and lam is None:
            cb = _avoid(physics.segment_time(self.desired, self.step_kn, self.min_kn, self.check), self.exclusion, t0)
            return shortest_path(self.grid, self.hood, segment_cost=cb, objective="time", eta_h=self.eta_h, **common)
        cb = _avoid(physics.segment_cheapest(self.speeds, lam, self.check), self.exclusion, t0)
        inputs = physics.kernel_inputs() if self.method == "astar" else None
        bound = (
            None if inputs is None else cost_bound.cost_to_go(*inputs, self.grid, self.hood.offsets, self.speeds, lam)
        )
        return shortest_path(
            self.grid, self.hood, segment_cost=cb, objective="cost", lambda_t_per_h=lam,
            cost_floor_per_nm=physics.cost_floor_per_nm(self.speeds, lam, self.v_bound - self.top_kn),
            cost_ceiling=ceiling, cost_to_go=None if bound is None else bound.to_end_t,
            edge_cost_floor=None if bound is None else bound.edge_t, **common,
        )  # fmt: skip


def _time_limit_h(sampler: WeatherSampler, t0: np.datetime64, check_nm: float | None) -> float | None:
    """The weather's end [h after ``t0``] when no leg can run past it, else None (see ``shortest_path``).

    Past the end a point is outside the weather (no passage) unless the sampler holds the last time
    (``time_policy="hold"``); and only a band check samples each piece's end at the time the ship reaches it
    (the midpoint check samples a piece at its entry time, so a route may then end after the weather).
    """
    if sampler.time_policy == "hold" or check_nm is None:
        return None
    return float((sampler.extent["time"][1] - t0) / np.timedelta64(1, "s")) / 3600.0


def _avoid(cb: Callable, exclusion: Exclusion | None, t0: np.datetime64) -> Callable:
    """``cb`` with the moving exclusion's edge-feasibility check (:mod:`optroute.search.exclusion`), if any."""
    return cb if exclusion is None else avoiding(cb, exclusion, t0)


def _route_from_search(res, physics: PassagePhysics, t0, objective, method, lam, t_start, searches) -> Route:
    n_legs = res.lat_deg.size - 1
    extra = res.extra
    leg_of = np.asarray(extra.get("piece_leg", np.zeros(0, dtype=int)), dtype=int)
    piece_extra = {k.removeprefix("piece_"): np.asarray(v) for k, v in extra.items() if k.startswith("piece_")}
    dur = np.asarray(piece_extra.get("duration_h", np.ones(leg_of.size)), dtype=float)
    stw = per_leg(piece_extra, "stw_kn", dur, leg_of, n_legs) if leg_of.size else np.full(n_legs, np.nan)
    power = per_leg(piece_extra, "power_kw", dur, leg_of, n_legs) if leg_of.size else np.full(n_legs, np.nan)
    sides = leg_band_sides(physics.ship, physics.rules, piece_extra, leg_of, n_legs)
    return Route(
        waypoints=np.column_stack([res.lat_deg, res.lon_deg]),
        times=t0 + _h_to_td(res.times_h),
        sog_kn=res.leg_sog_kn,
        stw_kn=stw,
        power_kw=power,
        fuel_t=res.leg_fuel_t,
        duration_h=res.leg_duration_h,
        distance_nm=res.leg_distance_nm,
        cost=float(res.cost),
        objective=objective,
        method=method,
        band_side=sides,
        stats={
            "expanded": res.expanded,
            "evaluated_edges": res.evaluated_edges,
            "callback_calls": res.callback_calls,
            "lambda_t_per_h": lam,
            "searches": searches,
            "neighbourhood": res.neighbourhood,
            "runtime_s": _time.perf_counter() - t_start,
            "pieces": piece_extra,
        },
    )
