"""Route search through forecast weather: the physics callbacks and ``search_route``.

The search machinery (:mod:`optroute.search`) knows nothing of ships or
weather; this module hands it callbacks that sample the weather at the time
the ship is at each piece of a leg and choose the speed there with
:mod:`optroute.physics.passage` (Boeing EP 2145155 Figs. 21–22; Shao et al.'s (3-D DP) MCR and
ship-motion loop), and turns its answer into a :class:`~optroute.search.route.Route`.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field
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
from optroute.physics import pointwise
from optroute.physics.passage import SeaState, SpeedChoice, best_speed, cheapest_speed, evaluate_speeds
from optroute.physics.performance import PerformanceModel, default_model
from optroute.physics.safety import BANDS, BandRules, band_margins
from optroute.physics.ship import Ship
from optroute.physics.yacht import SailingVessel
from optroute.search import passage_kernels
from optroute.search.compiled_search import LegKernel
from optroute.search.dijkstra import shortest_path
from optroute.search.dp import solve_dp
from optroute.search.dp_kernels import DPLegKernel
from optroute.search.exclusion import avoiding
from optroute.search.grid import RouteGrid
from optroute.search.neighbourhood import Neighbourhood, angular_resolution, compass
from optroute.search.passage_kernels import MODE_CHEAPEST, MODE_TIME
from optroute.search.piece_geometry import cumulative, piece_points, points_along
from optroute.search.route import Corridor, Route
from optroute.search.sailing import SailingGraph, SailingGrid, SailingRoute, SailObjective, search_sailing_route
from optroute.units import as_utc_time as _as_time
from optroute.units import h_to_timedelta as _h_to_td
from optroute.weather.sample import WeatherSampler
from optroute.weather.schema import VARIABLES

Objective = Literal["time", "fuel", "cost"]
Method = Literal["astar", "dijkstra", "dp"]

_SEA_VARS = tuple(VARIABLES)  # every canonical weather variable


def as_sampler(weather: xr.Dataset | WeatherSampler) -> WeatherSampler:
    """A :class:`WeatherSampler` for a canonical dataset (or the sampler itself)."""
    if isinstance(weather, WeatherSampler):
        return weather
    if isinstance(weather, xr.Dataset):
        return WeatherSampler(weather)
    raise ConfigError(f"weather must be a canonical xarray.Dataset or a WeatherSampler, got {type(weather).__name__}")


@dataclass
class PassagePhysics:
    """Everything needed to cost a piece of passage: ship, model, rules, weather and clock.

    Parameters
    ----------
    ship : Ship
    model : PerformanceModel
    rules : BandRules
    sampler : WeatherSampler
    departure : numpy.datetime64
        Time zero of the search's clock [UTC].
    compiled : bool
        Give the search callbacks their compiled batch form
        (:mod:`optroute.search.passage_kernels`) where it applies; False keeps the
        numpy callbacks only, with the vectorised model and band functions
        (``evaluate_speeds(engine="numpy")``): the search as it was before the
        kernels, the same costs to rounding, much slower.
    """

    ship: Ship
    model: PerformanceModel
    rules: BandRules
    sampler: WeatherSampler
    departure: np.datetime64
    compiled: bool = True
    calls: int = field(default=0, init=False)
    uncovered: int = field(default=0, init=False)

    @property
    def engine(self) -> str:
        """``evaluate_speeds``'s engine for the numpy callbacks: the point functions, or (not compiled) numpy."""
        return "auto" if self.compiled else "numpy"

    def sea(self, lat_deg: np.ndarray, lon_deg: np.ndarray, t_h: np.ndarray) -> SeaState:
        """Sea state at positions [deg] and times [h from departure].

        Points outside the weather's area or time span get NaN ("no passage")
        and are counted in :attr:`uncovered`, so that a search exploring slow
        or wide alternatives is not aborted by them; a search that fails
        because of them says so (see :func:`search_route`).
        """
        self.calls += 1
        lat = np.asarray(lat_deg, dtype=float)
        lon = np.asarray(lon_deg, dtype=float)
        when = np.broadcast_to(self.departure + _h_to_td(t_h), lat.shape)
        names = [v for v in _SEA_VARS if v in self.sampler.variables]
        inside = self.sampler.covers(when, lat, lon)
        if inside.all():
            return SeaState.from_sample(self.sampler.sample(when, lat, lon, variables=names))
        self.uncovered += int((~inside).sum())
        out = {v: np.full(lat.shape, np.nan) for v in names}
        if inside.any():
            got = self.sampler.sample(when[inside], lat[inside], lon[inside], variables=names)
            for v in names:
                out[v][inside] = got[v]
        return SeaState.from_sample(out)

    def _record(self, choice: SpeedChoice, sea: SeaState, length_nm: np.ndarray) -> tuple:
        feas = choice.feasible & (choice.sog_kn > 0)
        with np.errstate(invalid="ignore", divide="ignore"):
            dur = np.where(feas, length_nm / choice.sog_kn, np.nan)
        fuel = np.where(feas, choice.fuel_tph * dur, np.nan)
        extra = {
            "stw_kn": choice.stw_kn,
            "heading_deg": choice.heading_deg,
            "power_kw": choice.power_kw,
            "hs_m": sea.hs_m,
            "period_s": sea.period_s,
            "wave_from_deg": sea.wave_from_deg,
        }
        return dur, fuel, feas, extra

    def segment_time(
        self, desired_stw_kn: float, step_kn: float, min_stw_kn: float, check_nm: float | None = None
    ) -> Callable:
        """Segment-cost callback: Boeing speed reduction from the desired speed.

        With ``check_nm`` the speed is checked along the piece, see :meth:`segment_checked`.
        """

        def first(lat, lon, course, t_h):
            sea = self.sea(lat, lon, t_h)
            choice = best_speed(
                self.ship, self.model, self.rules, course, sea, desired_stw_kn, step_kn=step_kn, min_stw_kn=min_stw_kn,
                engine=self.engine,
            )  # fmt: skip
            return choice, sea

        ladder = desired_stw_kn - step_kn * np.arange(int(np.floor((desired_stw_kn - min_stw_kn) / step_kn + 1e-9)) + 1)
        if check_nm is not None:
            cb = self.segment_checked(first, ladder, None, check_nm)
        else:

            def cb(lat, lon, course, length_nm, t_h):
                return self._record(*first(lat, lon, course, t_h), length_nm)

        return self._with_kernel(cb, MODE_TIME, ladder, 0.0, (desired_stw_kn, step_kn, min_stw_kn), check_nm)

    def segment_cheapest(self, speeds_kn: np.ndarray, lambda_t_per_h: float, check_nm: float | None = None) -> Callable:
        """Segment-cost callback: the speed of the set minimising fuel + λ·time.

        With ``check_nm`` the speed is checked along the piece, see :meth:`segment_checked`.
        """

        def first(lat, lon, course, t_h):
            sea = self.sea(lat, lon, t_h)
            choice = cheapest_speed(
                self.ship, self.model, self.rules, course, sea, speeds_kn, lambda_t_per_h, engine=self.engine
            )
            return choice, sea

        speeds = np.asarray(speeds_kn, dtype=float).ravel()
        if check_nm is not None:
            cb = self.segment_checked(first, speeds, lambda_t_per_h, check_nm)
        else:

            def cb(lat, lon, course, length_nm, t_h):
                return self._record(*first(lat, lon, course, t_h), length_nm)

        return self._with_kernel(cb, MODE_CHEAPEST, speeds, float(lambda_t_per_h), (0.0, 1.0, 0.0), check_nm)

    def cost_floor_per_nm(self, speeds_kn: np.ndarray, lambda_t_per_h: float, current_kn: float) -> float | None:
        """A lower bound on (fuel + λ·time) per nm of any leg at the speeds given [t/nm], or None.

        :func:`optroute.physics.pointwise.least_cost_per_nm` for the built-in
        performance models (``current_kn`` at least the strongest current [kn]);
        None for a model it does not cover (the search then bounds by λ / v_max).
        """
        params = pointwise.cached_point_params(self.ship, self.model, self.rules)
        if params is None:
            return None
        return pointwise.least_cost_per_nm(params, speeds_kn, lambda_t_per_h, current_kn)

    def kernel_inputs(self) -> tuple[np.ndarray, tuple] | None:
        """(point parameters, weather arrays) of the compiled kernels, or None where they do not apply.

        They apply to the built-in performance models
        (:func:`optroute.physics.pointwise.point_params`) and an in-memory weather
        dataset (:meth:`optroute.weather.sample.WeatherSampler.point_weather`).
        """
        params = pointwise.cached_point_params(self.ship, self.model, self.rules)
        if params is None or not self.compiled:
            return None
        pw = self.sampler.point_weather(self.departure)
        return None if pw is None else (params, tuple(pw))

    def _with_kernel(self, cb: Callable, mode: int, speeds: np.ndarray, lam: float, boeing: tuple, check_nm):
        """``cb`` with its compiled batch form as ``cb.leg_batch`` (see :mod:`optroute.search.costs`) where available."""
        inputs = self.kernel_inputs()
        if inputs is None:
            return cb
        params, weather = inputs
        desired, step, vmin = (float(x) for x in boeing)
        speeds = np.ascontiguousarray(speeds, dtype=float)

        def leg_batch(lat, lon, course, length, n_pieces, t0_h):
            dur, fuel, feas, uncovered = passage_kernels.cost_legs(
                params, weather, mode, -1.0 if check_nm is None else float(check_nm), speeds, lam, desired, step,
                vmin, *(np.ascontiguousarray(a, dtype=float) for a in (lat, lon, course, length)),
                n_pieces, np.ascontiguousarray(t0_h, dtype=float),
            )  # fmt: skip
            self.calls += 1
            self.uncovered += int(uncovered)
            return dur, fuel, feas

        def uncovered(n: int) -> None:
            self.calls += 1
            self.uncovered += n

        cb.leg_batch = leg_batch  # type: ignore[attr-defined]
        cb.leg_kernel = LegKernel(  # type: ignore[attr-defined]
            params,
            weather,
            mode,
            -1.0 if check_nm is None else float(check_nm),
            speeds,
            lam,
            desired,
            step,
            vmin,
            uncovered,
        )
        return cb

    def segment_checked(
        self, first: Callable, speeds_kn: np.ndarray, lambda_t_per_h: float | None, check_nm: float
    ) -> Callable:
        """Segment-cost callback whose one speed per piece holds along the whole piece, not only at its midpoint.

        ``first(lat, lon, course, t_h) -> (SpeedChoice, SeaState)`` proposes a
        speed from the piece's midpoint at the time the ship enters it (one sea
        state per cell, as Boeing's Fig. 22).  The proposal is then checked
        (danger bands, power within [min load, MCR], course held) at points
        every ``check_nm`` [nm] or less along the piece, both ends included,
        each at the time the ship reaches it at that speed.  A speed that fails
        is struck out and the next one is taken from ``speeds_kn`` — the fastest
        allowed at every point (``lambda_t_per_h`` None) or the one with the
        least mean fuel + λ·time per mile over the points — and checked again at
        its own times.  A piece where no speed survives (or that is still
        unresolved after ``len(speeds_kn) + 10`` rounds) is infeasible.

        Duration and fuel integrate 1/SOG and fuel rate over the points
        (trapezoidal rule); heading, Hs, period and wave direction are reported
        at the piece's midpoint.  The check is a sampling at ``check_nm``: a
        band met between two points for less than their spacing can be missed.
        The case seen in practice is the bands switching on where Hs reaches
        their threshold (0.04 L): a speed allowed at the last point below it
        and again at the next point, where the band has moved on, can lie in
        the band for the few miles just past the crossing (5 of 62 routes
        through random seas, at most 5 of ~1000 points re-checked every
        1 nm, margins down to -0.005; a planning buffer such as
        ``BandRules(margin=0.205)`` removed them all).
        """
        ship, model, rules, engine = self.ship, self.model, self.rules, self.engine
        speeds = np.asarray(speeds_kn, dtype=float).ravel()
        score = -speeds if lambda_t_per_h is None else None

        def cost(lat, lon, course, length_nm, t_h):
            n, k_n = lat.size, speeds.size
            n_pts = 1 + 2 * np.maximum(1, np.ceil(length_nm / (2.0 * check_nm))).astype(int)  # odd: the midpoint is one
            m = int(n_pts.max(initial=3))
            frac = np.minimum(np.arange(m)[None, :], n_pts[:, None] - 1) / (n_pts[:, None] - 1)  # padded with the end
            la, lo, crs = piece_points(lat, lon, course, length_nm, frac)
            seg = np.diff(frac, axis=1) * length_nm[:, None]
            mid = ((n_pts - 1) // 2)[:, None]
            choice, _ = first(lat, lon, course, t_h)
            go = choice.feasible & (choice.sog_kn > 0)
            guess = np.argmin(np.abs(speeds[None, :] - np.where(go, choice.stw_kn, -1.0)[:, None]), axis=1)
            inv = np.repeat(np.where(go, 1.0 / np.where(go, choice.sog_kn, 1.0), 0.0)[:, None], m, axis=1)
            struck = np.zeros((n, k_n), dtype=bool)
            out = {k: np.full(n, np.nan) for k in ("dur", "fuel", "stw_kn", "power_kw", "heading_deg", "hs_m",
                                                    "period_s", "wave_from_deg")}  # fmt: skip
            feas = np.zeros(n, dtype=bool)
            todo = np.flatnonzero(go)
            for _ in range(k_n + 10):
                if todo.size == 0:
                    break
                p = todo
                tt = t_h[p, None] + cumulative(0.5 * (inv[p, 1:] + inv[p, :-1]) * seg[p])
                sea = self.sea(la[p].ravel(), lo[p].ravel(), tt.ravel())
                spd = speeds[guess[p]]
                head, sog, power, fuel, ok = (
                    a.reshape(p.size, m)
                    for a in evaluate_speeds(ship, model, rules, crs[p].ravel(), sea, np.repeat(spd, m), engine=engine)
                )
                with np.errstate(invalid="ignore", divide="ignore"):
                    ok = (ok & (sog > 0)).all(axis=1)
                    inv_new = np.where(ok[:, None], 1.0 / sog, 0.0)
                dt = 0.5 * (inv_new[:, 1:] + inv_new[:, :-1]) * seg[p]
                done = ok & (np.abs(t_h[p, None] + cumulative(dt) - tt).max(axis=1) <= 1e-3)
                d, idx = np.flatnonzero(done), p[done]
                out["dur"][idx] = dt[d].sum(axis=1)
                out["fuel"][idx] = (0.5 * (fuel[d, 1:] + fuel[d, :-1]) * dt[d]).sum(axis=1)
                out["power_kw"][idx] = (0.5 * (power[d, 1:] + power[d, :-1]) * dt[d]).sum(axis=1) / out["dur"][idx]
                out["stw_kn"][idx] = spd[d]
                out["heading_deg"][idx] = np.take_along_axis(head[d], mid[idx], axis=1)[:, 0]
                for name in ("hs_m", "period_s", "wave_from_deg"):
                    out[name][idx] = np.take_along_axis(getattr(sea, name).reshape(p.size, m)[d], mid[idx], axis=1)[
                        :, 0
                    ]
                feas[idx] = True
                again = ok & ~done  # allowed, but the times were not yet its own: check again at them
                inv[p[again]] = inv_new[again]
                bad = np.flatnonzero(~ok)
                struck[p[bad], guess[p[bad]]] = True
                found = np.zeros(0, dtype=int)
                if bad.size:
                    sub = SeaState(*(np.asarray(getattr(sea, f)).reshape(p.size, m)[bad].ravel()
                                     for f in SeaState.__dataclass_fields__))  # fmt: skip
                    _, sog_k, _, fuel_k, ok_k = evaluate_speeds(
                        ship, model, rules, crs[p[bad]].ravel(), sub, np.broadcast_to(speeds, (bad.size * m, k_n)),
                        engine=engine,
                    )  # fmt: skip
                    sog_k, fuel_k, ok_k = (a.reshape(bad.size, m, k_n) for a in (sog_k, fuel_k, ok_k))
                    with np.errstate(invalid="ignore", divide="ignore"):
                        ok_k = (ok_k & (sog_k > 0)).all(axis=1) & ~struck[p[bad]]
                        own = (np.arange(m)[None, :] < n_pts[p[bad], None])[:, :, None]  # the piece's own points
                        rank = (np.broadcast_to(score, ok_k.shape) if score is not None
                                else np.where(own, (fuel_k + lambda_t_per_h) / sog_k, 0.0).sum(axis=1)
                                / n_pts[p[bad], None])  # fmt: skip
                    rank = np.where(ok_k, rank, np.inf)
                    k = np.argmin(rank, axis=1)
                    has = np.isfinite(rank[np.arange(bad.size), k])
                    found = p[bad[has]]
                    guess[found] = k[has]
                    inv[found] = 1.0 / np.take_along_axis(sog_k[has], k[has, None, None], axis=2)[:, :, 0]
                todo = np.concatenate([p[again], found])
            extra = {k: v for k, v in out.items() if k not in ("dur", "fuel")}
            return np.where(feas, out["dur"], np.nan), np.where(feas, out["fuel"], np.nan), feas, extra

        return cost

    def dp_leg(self, piece_nm: float) -> Callable:
        """Leg-cost callback of the 3D DP: a commanded speed over ground, checked piece by piece.

        Shao et al. (3-D DP) simulate each stage in time steps: here each leg is cut into
        pieces of at most ``piece_nm``; at each piece, at the time the ship is
        there, the STW needed to make the SOG good against the current, its
        power (within [min load, MCR]) and the danger bands are checked.  The
        number of pieces is each leg's own (the legs of one call are padded to
        the longest), so a leg costs the same whichever legs it is batched with.
        """
        from optroute.physics.currents import stw_for_sog
        from optroute.physics.passage import evaluate_speeds

        inputs = self.kernel_inputs()

        def pieces(lat0, lon0, lat1, lon1):
            dist = geo.distance_nm(lat0, lon0, lat1, lon1)
            n_pc = np.maximum(1, np.ceil(dist / piece_nm)).astype(int)[:, None]
            m = int(n_pc.max(initial=1))
            f = (np.minimum(np.arange(m)[None, :], n_pc - 1) + 0.5) / n_pc  # padded with the last piece
            return dist, n_pc, f, *points_along(lat0, lon0, lat1, lon1, f)

        def compiled(lat0, lon0, lat1, lon1, t0_h, sog_kn):
            # the DP costs each stage-to-stage leg at many times and speeds: its geometry once per leg
            legs, leg_of = np.unique(np.stack([lat0, lon0, lat1, lon1], axis=1), axis=0, return_inverse=True)
            dist, n_pc, f, lat, lon, course = pieces(*legs.T)
            dur, fuel, feas, stw_m, power_m, uncovered = passage_kernels.cost_dp_legs(
                *inputs, *(np.ascontiguousarray(a, dtype=float) for a in (lat, lon, course, f)),
                n_pc[:, 0].astype(np.int64), leg_of.ravel().astype(np.int64), np.ascontiguousarray(t0_h, dtype=float),
                np.ascontiguousarray(sog_kn, dtype=float), dist,
            )  # fmt: skip
            self.calls += 1
            self.uncovered += int(uncovered)
            return dur, fuel, feas, {"stw_kn": stw_m, "power_kw": power_m}

        def cost(lat0, lon0, lat1, lon1, t0_h, sog_kn):
            if inputs is not None:  # compiled: the same pieces, sampled and costed in one call
                return compiled(lat0, lon0, lat1, lon1, t0_h, sog_kn)
            n = lat0.shape[0]
            dist, n_pc, f, lat, lon, course = pieces(lat0, lon0, lat1, lon1)
            m = f.shape[1]
            w = (np.arange(m)[None, :] < n_pc) / n_pc
            t = t0_h[:, None] + (f * dist[:, None]) / sog_kn[:, None]
            sea = self.sea(lat.ravel(), lon.ravel(), t.ravel())
            sog = np.repeat(sog_kn, m)
            stw, _ = stw_for_sog(course.ravel(), sog, sea.current_u_ms, sea.current_v_ms)
            ok_stw = np.isfinite(stw) & (stw > 0)
            stw_safe = np.where(ok_stw, stw, 1.0)
            _, _, power, fuel_tph, allowed = evaluate_speeds(
                self.ship, self.model, self.rules, course.ravel(), sea, stw_safe, engine=self.engine
            )
            allowed = (allowed & ok_stw).reshape(n, m)
            dur = dist / sog_kn
            fuel = (np.where(np.isfinite(fuel_tph), fuel_tph, 0.0).reshape(n, m) * w).sum(axis=1) * dur
            feas = allowed.all(axis=1)
            extra = {"stw_kn": (stw.reshape(n, m) * w).sum(axis=1), "power_kw": (power.reshape(n, m) * w).sum(axis=1)}
            return dur, np.where(feas, fuel, np.nan), feas, extra

        if inputs is not None:  # solve_dp's compiled transitions (optroute.search.dp_kernels)
            cost.dp_kernel = DPLegKernel(*inputs, pieces, self._count_uncovered)  # type: ignore[attr-defined]
        return cost

    def _count_uncovered(self, n: int) -> None:
        self.calls += 1
        self.uncovered += n


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


def _leg_band_sides(ship: Ship, rules: BandRules, extra: dict[str, np.ndarray], leg_of: np.ndarray, n_legs: int):
    """Per leg and band, the side kept where the band binds most (smallest margin); 0 where it never applies."""
    sides = {b: np.zeros(n_legs, dtype=np.int8) for b in BANDS}
    if not len(leg_of):
        return sides
    margins = band_margins(
        ship,
        speed_kn=extra["stw_kn"],
        hs_m=extra["hs_m"],
        period_s=extra["period_s"],
        wave_from_deg=extra["wave_from_deg"],
        heading_deg=extra["heading_deg"],
        rules=rules,
    )
    for band, bm in margins.items():
        best = np.full(n_legs, np.inf)
        for k in np.argsort(-np.asarray(bm.margin)):  # ascending margin wins last
            leg = int(leg_of[k])
            if np.isfinite(bm.margin[k]) and bm.margin[k] <= best[leg]:
                best[leg] = bm.margin[k]
                sides[band][leg] = bm.side[k]
    return sides


def _per_leg(extra: dict[str, np.ndarray], key: str, weights: np.ndarray, leg_of: np.ndarray, n_legs: int):
    w = np.bincount(leg_of, weights=weights, minlength=n_legs)
    s = np.bincount(leg_of, weights=weights * extra[key], minlength=n_legs)
    with np.errstate(invalid="ignore", divide="ignore"):
        return s / w


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
        20 nm plus two grid cells.  The grid search needs open water of about
        one cell around its end points (a 20 nm cell cannot enter Tokyo Bay),
        so ports are snapped with a clearance of half a cell; the last miles
        into port are pilotage, outside the routing problem.
    band_check_nm : float or None
        Grid search: each piece's speed is checked (danger bands, MCR) at
        points at most this far apart along the piece [nm], ends included, at
        the times the ship passes them (:meth:`PassagePhysics.segment_checked`).
        ``None`` checks the piece's midpoint at its entry time only (Boeing's
        one sea state per cell): faster, but a route can then cross a band
        between midpoints.
    dp_options : dict, optional
        Passed to :func:`optroute.search.dp.solve_dp` (``dx_nm``, ``dy_nm``,
        ``half_width_nm``, ``dt_h`` …) for ``method="dp"``.
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

    Returns
    -------
    Route or SailingRoute
        For the grid search, ``stats["pieces"]`` holds the per-piece records
        of the route (``leg``, ``lat_deg``/``lon_deg`` of the midpoint,
        ``course_deg``, ``length_nm``, ``t_h`` entry [h from departure],
        ``duration_h``, ``stw_kn``, ``heading_deg``, ``power_kw``, …): the
        speed actually sailed on each piece.

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
    t0 = _as_time(departure, "departure")
    eta_h = None
    if eta is not None:
        eta_t = _as_time(eta, "eta")
        eta_h = float((eta_t - t0) / np.timedelta64(1, "s")) / 3600.0
        if eta_h <= 0:
            raise ConfigError(
                f"eta={units.format_utc(eta_t)} is not after departure={units.format_utc(t0)}; give an arrival later than the departure"
            )
    ds = weather if isinstance(weather, xr.Dataset) else None
    sampler = as_sampler(weather)
    first_t, last_t = sampler.extent["time"]
    if sampler.time_policy == "raise" and not first_t <= t0 <= last_t:
        raise WeatherCoverageError(
            f"departure={units.format_utc(t0)} lies outside the weather's time span {units.format_utc(first_t)} to "
            f"{units.format_utc(last_t)}; give a departure inside "
            "it or a forecast that covers it"
        )
    model = model if model is not None else default_model(ship)
    rules = rules if rules is not None else BandRules()
    desired = float(desired_speed_kn if desired_speed_kn is not None else ship.design_speed_kn)
    finite("desired_speed_kn", desired, minimum=0.0, strict=True, error=ConfigError)
    top = min(ship.max_calm_speed_kn, 40.0)
    speeds = (
        finite("speeds_kn", speeds_kn, minimum=0.0, strict=True, error=ConfigError).ravel()
        if speeds_kn is not None
        else np.arange(5.0, np.floor(top * 2) / 2 + 1e-9, 0.5)
    )
    physics = PassagePhysics(ship, model, rules, sampler, t0, compiled=bool(compiled))

    clearance = 0.5 * cell_nm if method != "dp" else 0.5
    snap_nm = float(snap_max_nm) if snap_max_nm is not None else 20.0 + 2.0 * cell_nm
    for p, w in ((start, "start"), (end, "end")):  # outside the weather is not "on land": say which it is
        sampler.require_area(*p, what=w)
    start, end = (
        land.snap_to_sea(
            *p,
            snap_nm,
            clearance_nm=clearance,
            weather=ds,
            time=t0,
            use_land_mask=use_land_mask,
            what=w,
            fix="give a position at sea, e.g. a pilot station off the port",
        )
        for p, w in ((start, "start"), (end, "end"))
    )
    # the fastest any leg can go over ground: the speed ceiling of the objective plus the strongest current
    ceiling = desired if objective == "time" and lambda_t_per_h is None else float(speeds.max())
    v_bound = ceiling + _max_current_kn(ds) + 1e-6

    if method == "dp":
        coast = (
            use_land_mask
            if use_land_mask is not None
            else not (ds is not None and ds.attrs.get("geography") == land.SYNTHETIC_GEOGRAPHY)
        )
        return _search_dp(
            physics, start, end, eta_h, speeds, dict(dp_options or {}), objective, t_start, bool(coast), exclusion
        )

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

    grid = RouteGrid.build(start, end, cell_nm=cell_nm, margin_nm=margin_nm, navigable=nav)
    hood = _neighbourhood(angular_resolution_deg, directions, radius_cells)

    check = (
        None
        if band_check_nm is None
        else float(finite("band_check_nm", band_check_nm, minimum=0.0, strict=True, error=ConfigError))
    )

    def run(lam: float | None):
        if objective == "time" and lam is None:
            cb = _avoid(physics.segment_time(desired, speed_step_kn, min_speed_kn, check), exclusion, t0)
            return shortest_path(
                grid, hood, v_max_kn=v_bound, segment_cost=cb, method=method, objective="time", eta_h=eta_h
            )
        cb = _avoid(physics.segment_cheapest(speeds, lam, check), exclusion, t0)
        return shortest_path(
            grid, hood, v_max_kn=v_bound, segment_cost=cb, method=method, objective="cost", lambda_t_per_h=lam,
            cost_floor_per_nm=physics.cost_floor_per_nm(speeds, lam, v_bound - ceiling),
        )  # fmt: skip

    try:
        res, lam_used = _run_objective(run, objective, eta_h, t0, lambda_t_per_h, hourly_cost_per_h, fuel_price_per_t)
    except NoSafePassage as exc:
        raise _explain(exc, physics) from None
    except InfeasibleETA as exc:
        raise _eta_as_time(exc, t0) from None
    return _route_from_search(res, physics, t0, objective, method, lam_used, t_start)


def _avoid(cb: Callable, exclusion: Exclusion | None, t0: np.datetime64) -> Callable:
    """``cb`` with the moving exclusion's edge-feasibility check (:mod:`optroute.search.exclusion`), if any."""
    return cb if exclusion is None else avoiding(cb, exclusion, t0)


def _eta_as_time(exc: InfeasibleETA, t0: np.datetime64) -> InfeasibleETA:
    """The search's :class:`InfeasibleETA` with ``earliest_arrival`` as a UTC time (the searches give hours)."""
    early = exc.earliest_arrival
    if early is None or isinstance(early, np.datetime64):
        return exc
    out = InfeasibleETA(
        f"{exc} (at {units.format_utc(t0 + _h_to_td(float(early)))})", earliest_arrival=t0 + _h_to_td(float(early))
    )
    out.earliest_arrival_h = float(early)  # type: ignore[attr-defined]
    return out


def _explain(exc: NoSafePassage, physics: PassagePhysics) -> Exception:
    """Say when the weather's extent, not the sea, stopped the search."""
    if physics.uncovered:
        ext = physics.sampler.extent
        return NoSafePassage(
            f"{exc} — {physics.uncovered} sampled points fell outside the weather data "
            f"(lat {ext['lat']}, lon {ext['lon']}, time {units.format_utc(ext['time'][0])} to {units.format_utc(ext['time'][1])}) and counted as no "
            "passage; extend the forecast in space or time"
        )
    return exc


def _run_objective(run, objective, eta_h, t0, lambda_t_per_h, hourly_cost_per_h, fuel_price_per_t):
    lam_used = 0.0
    if objective == "time":
        res = run(None)
    elif lambda_t_per_h is not None or objective == "cost":
        lam_used = float(lambda_t_per_h if lambda_t_per_h is not None else hourly_cost_per_h / fuel_price_per_t)
        res = run(lam_used)
        if eta_h is not None and res.arrival_h > eta_h + 1e-9:
            raise InfeasibleETA(
                f"with lambda {lam_used:.3g} t/h the least-cost route arrives after {res.arrival_h:.1f} h, later than "
                f"the ETA {eta_h:.1f} h after departure; raise the hourly cost or give a later ETA",
                earliest_arrival=t0 + _h_to_td(res.arrival_h),
            )
    else:
        res, lam_used = _bisect_lambda(run, eta_h, t0)
    return res, lam_used


def _bisect_lambda(run: Callable, eta_h: float | None, t0: np.datetime64):
    """Least λ whose least-cost route arrives by the ETA (fuel objective).

    A λ whose route cannot be completed (too slow to finish inside the
    forecast, say) counts as arriving too late; only when even the fastest
    choice fails is the search's :class:`NoSafePassage` raised.
    """
    failure: list[NoSafePassage] = []

    def attempt(lam: float):
        try:
            return run(lam)
        except NoSafePassage as exc:
            failure[:] = [exc]
            return None

    def late(r) -> bool:
        return r is None or (eta_h is not None and r.arrival_h > eta_h)

    slow = attempt(0.0)
    if not late(slow):
        return slow, 0.0
    lo, hi = 0.0, 1.0
    fast = attempt(hi)
    while late(fast) and hi < 1e4:
        lo, hi = hi, hi * 4.0
        fast = attempt(hi)
    if fast is None:
        raise failure[0]
    if late(fast):
        raise InfeasibleETA(
            f"even valuing an hour at {hi:.0f} t of fuel the route arrives {fast.arrival_h:.1f} h after departure, "
            f"later than the ETA {eta_h:.1f} h; give a later ETA",
            earliest_arrival=t0 + _h_to_td(fast.arrival_h),
        )
    best = fast
    for _ in range(12):
        mid = 0.5 * (lo + hi)
        r = attempt(mid)
        if late(r):
            lo = mid
        else:
            hi, best = mid, r
    return best, hi


def _route_from_search(res, physics: PassagePhysics, t0, objective, method, lam, t_start) -> Route:
    n_legs = res.lat_deg.size - 1
    extra = res.extra
    leg_of = np.asarray(extra.get("piece_leg", np.zeros(0, dtype=int)), dtype=int)
    piece_extra = {k.removeprefix("piece_"): np.asarray(v) for k, v in extra.items() if k.startswith("piece_")}
    dur = np.asarray(piece_extra.get("duration_h", np.ones(leg_of.size)), dtype=float)
    stw = _per_leg(piece_extra, "stw_kn", dur, leg_of, n_legs) if leg_of.size else np.full(n_legs, np.nan)
    power = _per_leg(piece_extra, "power_kw", dur, leg_of, n_legs) if leg_of.size else np.full(n_legs, np.nan)
    sides = _leg_band_sides(physics.ship, physics.rules, piece_extra, leg_of, n_legs)
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
            "neighbourhood": res.neighbourhood,
            "runtime_s": _time.perf_counter() - t_start,
            "pieces": piece_extra,
        },
    )


def _search_dp(
    physics: PassagePhysics, start, end, eta_h, speeds, opts, objective, t_start, coast: bool, exclusion=None
) -> Route:
    if objective == "time" and eta_h is not None:
        raise ConfigError("the DP minimises fuel for an ETA; use objective='fuel' with method='dp'")
    piece_nm = float(opts.pop("piece_nm", 30.0))
    sampler = physics.sampler

    def navigable(lat, lon, t_h):  # the weather's no-passage cells, and the coastline as in the grid search
        when = np.broadcast_to(t_h, np.shape(lat))
        ok = physics.sea(lat, lon, when).navigable
        if exclusion is not None:
            clat, clon, rad = exclusion.at(physics.departure + _h_to_td(when))
            ok = ok & (geo.distance_nm(lat, lon, clat, clon) >= rad)
        return ok & ~land.is_land(lat, lon) if coast else ok

    t_last = (sampler.extent["time"][1] - physics.departure) / np.timedelta64(1, "s") / 3600.0
    opts.setdefault("horizon_h", float(t_last))
    try:
        res = solve_dp(start, end, physics.dp_leg(piece_nm), eta_h=eta_h, speeds_kn=speeds, navigable=navigable, **opts)
    except NoSafePassage as exc:
        raise _explain(exc, physics) from None
    except InfeasibleETA as exc:
        raise _eta_as_time(exc, physics.departure) from None
    p = res.path
    n_legs = p.lat_deg.size - 1
    wp = np.column_stack([p.lat_deg, p.lon_deg])
    return Route(
        waypoints=wp,
        times=physics.departure + _h_to_td(p.times_h),
        sog_kn=p.sog_kn,
        stw_kn=np.asarray(p.extra.get("stw_kn", np.full(n_legs, np.nan)), dtype=float),
        power_kw=np.asarray(p.extra.get("power_kw", np.full(n_legs, np.nan)), dtype=float),
        fuel_t=p.leg_fuel_t,
        duration_h=p.leg_duration_h,
        distance_nm=p.leg_distance_nm,
        cost=float(p.total_fuel_t),
        objective="fuel",
        method="dp",
        band_side={b: np.zeros(n_legs, dtype=np.int8) for b in BANDS},
        stats={
            "n_states": res.n_states,
            "n_transitions": res.n_transitions,
            "earliest_arrival_h": res.earliest_arrival_h,
            "curve_bin_end_h": res.curve_bin_end_h,
            "curve_fuel_t": res.curve_fuel_t,
            "runtime_s": _time.perf_counter() - t_start,
        },
    )


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
        stw_kn=_per_leg(piece, "stw_kn", piece["duration_h"], leg_idx, n_legs),
        power_kw=_per_leg(piece, "power_kw", piece["duration_h"], leg_idx, n_legs),
        fuel_t=np.asarray(leg_fuel),
        duration_h=dur,
        distance_nm=np.asarray(leg_dist),
        cost=float(t_h),
        objective="time",
        method="fixed",
        band_side=_leg_band_sides(ship, rules, piece, leg_idx, n_legs),
        stats={
            "pieces": int(leg_idx.size),
            "min_stw_kn": float(piece["stw_kn"].min()),
            "runtime_s": _time.perf_counter() - t_start,
        },
    )
