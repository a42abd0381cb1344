"""The physics of a piece of passage for the searches: the weather at the ship, the speed chosen there, its check.

:class:`PassagePhysics` hands the search machinery (which knows nothing of
ships or weather) callbacks that sample the weather at the time the ship is at
each piece of a leg and choose the speed there with
:mod:`optroute.physics.passage` (Boeing EP 2145155 Figs. 21–22; Shao et al.'s
(3-D DP) MCR and ship-motion loop), numpy or compiled
(:mod:`optroute.search.passage_kernels`); :func:`leg_band_sides` and
:func:`per_leg` summarise the pieces sailed per leg of a route.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import xarray as xr

from optroute import geodesy as geo
from optroute.errors import ConfigError
from optroute.physics import pointwise
from optroute.physics.passage import SeaState, SpeedChoice, best_speed, cheapest_speed, evaluate_speeds
from optroute.physics.performance import PerformanceModel
from optroute.physics.safety import BANDS, BandRules, band_margins
from optroute.physics.ship import Ship
from optroute.search import band_refine, passage_kernels
from optroute.search.band_bounds import weather_with_bounds
from optroute.search.compiled_search import LegKernel
from optroute.search.dp_kernels import DPLegKernel
from optroute.search.edge_geometry import piece_points_flat
from optroute.search.passage_kernels import MODE_CHEAPEST, MODE_TIME
from optroute.search.piece_geometry import cumulative, piece_points, points_along
from optroute.units import h_to_timedelta as _h_to_td
from optroute.weather.sample import WeatherSampler
from optroute.weather.schema import VARIABLES

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

    def calm_cheapest_speed_kn(self, speeds_kn: np.ndarray, lambda_t_per_h: float) -> float:
        """The speed of the set :meth:`segment_cheapest` sails at λ in calm water (no waves, wind or current) [kn].

        :func:`optroute.physics.passage.cheapest_speed` at one point of a calm sea (NaN where no speed of the
        set is allowed there).  The λ bisection's stand-in for the speeds a λ's route sails
        (:func:`optroute.search.objective_search.bisect_lambda`).
        """
        zero = np.zeros(1)
        calm = SeaState(zero, np.ones(1), zero, zero, zero, zero, zero)
        choice = cheapest_speed(
            self.ship, self.model, self.rules, zero, calm, speeds_kn, lambda_t_per_h, engine=self.engine
        )
        return float(choice.stw_kn[0])

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
        return None if pw is None else (params, weather_with_bounds(pw))

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
        at the piece's midpoint.  A speed allowed at every point at its own
        times is then checked between them where the referee looks
        (:meth:`clear_between`, :mod:`optroute.search.band_refine`: the weather's
        regime crossings and halving until every interval is certified), so that a
        band entered over more than :data:`~optroute.search.band_refine.BAND_TOL_NM`
        is found as ``Plan.verify()`` finds it; a speed failing there is struck
        out as one failing at a point.  (Sampling at ``check_nm`` alone let a
        speed sit in a band for ~3 nm just past where Hs reaches the bands'
        threshold, issue 14 item 1.)
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
                if done.any():  # and between the points, where the referee's rules look (band_refine)
                    q = np.flatnonzero(done)
                    clear = self.clear_between(
                        lat[p[q]], lon[p[q]], course[p[q]], length_nm[p[q]], n_pts[p[q]], seg[p[q]], tt[q], spd[q]
                    )
                    ok[q[~clear]] = False
                    done[q[~clear]] = False
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

    def clear_between(self, lat, lon, course, length_nm, n_pts, seg_nm, t_h, stw_kn, sog_mode=False) -> np.ndarray:
        """Whether each piece's speed is allowed wherever the referee's rules look between its check points.

        The numpy form of :func:`optroute.search.refine_kernels.piece_clear`: the points of
        :mod:`optroute.search.band_refine` (regime crossings, then halving until certified) between
        the check points (``n_pts`` of them, spaced ``seg_nm`` [nm] along the piece given by its
        midpoint [deg], course [deg true] and length [nm], passed at ``t_h`` [h]; (n, m) arrays
        padded past ``n_pts``), the ship at each at the time linear in distance between them;
        a piece fails where the speed ``stw_kn`` [kn] is not allowed at one of them.  With ``sog_mode``,
        ``stw_kn`` is the speed over ground made good (the 3-D DP's command) and the speed through water
        the one making it good against the current at each point (as ``piece_clear``'s ``sog_mode``).
        """
        n, m = t_h.shape
        own = np.arange(m)[None, :] < n_pts[:, None]
        group = np.repeat(np.arange(n), n_pts)
        s = cumulative(seg_nm)[own]
        t = np.asarray(t_h, dtype=float)[own]
        scale = float(np.max(length_nm, initial=0.0)) + 1.0  # (group, s) as one increasing axis
        x_nodes, t_nodes = group * scale + s, t

        def where(g, ss, tt=None):
            tt = np.interp(g * scale + ss, x_nodes, t_nodes) if tt is None else tt
            la, lo, crs = (np.empty(ss.size) for _ in range(3))
            if ss.size:
                piece_points_flat(
                    *(np.ascontiguousarray(a[g], dtype=float) for a in (lat, lon, course)),
                    np.ascontiguousarray(ss - 0.5 * length_nm[g]), la, lo, crs,
                )  # fmt: skip
            return la, lo, crs, tt

        def coords(g, ss):
            la, lo, _, tt = where(g, ss)
            return self.sampler.grid_coordinates(self.departure + _h_to_td(tt), la, lo)

        group, s = band_refine.crossing_nodes(
            group, s, coords, min(band_refine.CROSSING_TOL_NM, band_refine.BAND_TOL_NM)
        )
        la, lo, crs, t = where(group, s)
        clear = np.ones(n, dtype=bool)
        fn = self._band_functions(la, lo, crs, t, stw_kn[group], group, clear, sog_mode)
        for _ in range(band_refine.MAX_ROUNDS):
            i = band_refine.intervals_to_halve(group, s, *fn, band_refine.BAND_TOL_NM)
            i = i[clear[group[i]]]
            if i.size == 0:
                break
            s_new = 0.5 * (s[i] + s[i + 1])
            t_new = t[i] + (s_new - s[i]) / (s[i + 1] - s[i]) * (t[i + 1] - t[i])
            la_n, lo_n, crs_n, _ = where(group[i], s_new, t_new)
            fn_n = self._band_functions(la_n, lo_n, crs_n, t_new, stw_kn[group[i]], group[i], clear, sog_mode)
            order = np.lexsort((np.concatenate([s, s_new]), np.concatenate([group, group[i]])))
            group, s, t = (np.concatenate([a, b])[order] for a, b in ((group, group[i]), (s, s_new), (t, t_new)))
            fn = tuple(np.concatenate([a, b])[order] for a, b in zip(fn[:3], fn_n[:3], strict=True)) + (
                {k: np.concatenate([fn[3][k], fn_n[3][k]])[order] for k in fn[3]},
            )
        return clear

    def _band_functions(self, la, lo, crs, t, stw, group, clear, sog_mode=False):
        """:func:`optroute.search.band_refine.band_functions` at points; ``clear[group]`` struck where the speed is not allowed.

        With ``sog_mode``, ``stw`` is the speed over ground made good and the speed through water is taken
        against the current at each point (:func:`optroute.physics.currents.stw_for_sog`).
        """
        from optroute.physics.currents import stw_for_sog

        sea = self.sea(la, lo, t)
        ok_stw = np.ones(la.size, dtype=bool)
        if sog_mode:
            stw, _ = stw_for_sog(crs, stw, sea.current_u_ms, sea.current_v_ms)
            ok_stw = np.isfinite(stw) & (stw > 0)
            stw = np.where(ok_stw, stw, 1.0)
        heading, sog, _, _, allowed = evaluate_speeds(
            self.ship, self.model, self.rules, crs, sea, stw, engine=self.engine
        )
        with np.errstate(invalid="ignore"):
            bad = ~(allowed & (sog > 0) & ok_stw)
        clear[group[bad]] = False
        return band_refine.band_functions(self.ship, self.rules, sea, np.ones(la.size, dtype=bool), heading, crs, stw)

    def dp_leg(self, piece_nm: float) -> Callable:
        """Leg-cost callback of the 3D DP: a commanded speed over ground, checked piece by piece.

        Shao et al. (3-D DP) simulate each stage in time steps: here each leg is cut into
        pieces of at most ``piece_nm``; at each piece, at the time the ship is
        there, the STW needed to make the SOG good against the current, its
        power (within [min load, MCR]) and the danger bands are checked at its
        midpoint (which costs it), its ends and between them where the referee's
        rules look (:meth:`clear_between`, as the search's pieces: a band entered
        between two midpoints is found, issue 14 item 1).  The
        number of pieces is each leg's own (the legs of one call are padded to
        the longest), so a leg costs the same whichever legs it is batched with.
        """
        from optroute.physics.currents import stw_for_sog
        from optroute.physics.passage import evaluate_speeds

        inputs = self.kernel_inputs()
        pieces = functools.partial(dp_pieces, piece_nm=float(piece_nm))

        def compiled(lat0, lon0, lat1, lon1, t0_h, sog_kn):
            # the DP costs each stage-to-stage leg at many times and speeds: its geometry once per leg
            legs, leg_of = np.unique(np.stack([lat0, lon0, lat1, lon1], axis=1), axis=0, return_inverse=True)
            dist, n_pc, f, lat, lon, course = pieces(*legs.T)
            dur, fuel, feas, stw_m, power_m, uncovered = passage_kernels.cost_dp_legs(
                *inputs, *(np.ascontiguousarray(a, dtype=float) for a in (lat, lon, course, f)),
                n_pc[:, 0].astype(np.int64), leg_of.ravel().astype(np.int64), np.ascontiguousarray(t0_h, dtype=float),
                np.ascontiguousarray(sog_kn, dtype=float), dist, True,
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
            feas[feas] = self._dp_pieces_clear(dist[feas], n_pc[feas, 0], lat[feas], lon[feas], course[feas], t[feas],
                                               sog_kn[feas])  # fmt: skip
            extra = {"stw_kn": (stw.reshape(n, m) * w).sum(axis=1), "power_kw": (power.reshape(n, m) * w).sum(axis=1)}
            return dur, np.where(feas, fuel, np.nan), feas, extra

        if inputs is not None:  # solve_dp's compiled transitions (optroute.search.dp_kernels)
            cost.dp_kernel = DPLegKernel(*inputs, pieces, self._count_uncovered)  # type: ignore[attr-defined]
        return cost

    def _dp_pieces_clear(self, dist, n_pc, lat, lon, course, t_mid, sog_kn) -> np.ndarray:
        """Per leg of :meth:`dp_leg`'s numpy callback: every own piece (:func:`dp_pieces`) allowed at its ends and
        clear between them (as the compiled ``cost_dp_leg``)."""
        from optroute.physics.currents import stw_for_sog

        length = dist / n_pc
        own = np.arange(lat.shape[1])[None, :] < n_pc[:, None]
        leg = np.nonzero(own)[0]
        la, lo, crs, tm = lat[own], lon[own], course[own], t_mid[own]
        ln, sog = length[leg], sog_kn[leg]
        s = 0.5 * ln[:, None] * np.arange(3)[None, :]
        tt = tm[:, None] + (s - 0.5 * ln[:, None]) / sog[:, None]
        ends = s[:, [0, 2]] - 0.5 * ln[:, None]
        e_la, e_lo, e_crs = (np.empty(ends.shape) for _ in range(3))
        piece_points_flat(*(np.ascontiguousarray(np.repeat(a, 2)) for a in (la, lo, crs)), ends.ravel(),
                          e_la.reshape(-1), e_lo.reshape(-1), e_crs.reshape(-1))  # fmt: skip
        sea = self.sea(e_la.ravel(), e_lo.ravel(), tt[:, [0, 2]].ravel())
        stw, _ = stw_for_sog(e_crs.ravel(), np.repeat(sog, 2), sea.current_u_ms, sea.current_v_ms)
        ok_stw = np.isfinite(stw) & (stw > 0)
        _, e_sog, _, _, allowed = evaluate_speeds(
            self.ship, self.model, self.rules, e_crs.ravel(), sea, np.where(ok_stw, stw, 1.0), engine=self.engine
        )
        with np.errstate(invalid="ignore"):
            clear = (ok_stw & allowed & (e_sog > 0)).reshape(-1, 2).all(axis=1)
        q = np.flatnonzero(clear)
        if q.size:
            seg = np.repeat(0.5 * ln[q, None], 2, axis=1)
            clear[q] = self.clear_between(la[q], lo[q], crs[q], ln[q], np.full(q.size, 3), seg, tt[q], sog[q],
                                          sog_mode=True)  # fmt: skip
        out = np.ones(lat.shape[0], dtype=bool)
        np.logical_and.at(out, leg, clear)
        return out

    def _count_uncovered(self, n: int) -> None:
        self.calls += 1
        self.uncovered += n


def dp_pieces(lat0: np.ndarray, lon0: np.ndarray, lat1: np.ndarray, lon1: np.ndarray, piece_nm: float) -> tuple:
    """The 3-D DP's legs cut into pieces of at most ``piece_nm`` [nm] (each leg its own number, the legs padded to the
    longest with their last piece): (length [nm], pieces per leg (n, 1), the pieces' midpoint fractions (n, m), and
    their midpoints' lat [deg], lon [deg] and course [deg])."""
    dist = geo.distance_nm(lat0, lon0, lat1, lon1)
    n_pc = np.maximum(1, np.ceil(dist / piece_nm)).astype(int)[:, None]
    m = int(n_pc.max(initial=1))
    f = (np.minimum(np.arange(m)[None, :], n_pc - 1) + 0.5) / n_pc  # padded with the last piece
    return dist, n_pc, f, *points_along(lat0, lon0, lat1, lon1, f)


def leg_band_sides(ship: Ship, rules: BandRules, extra: dict[str, np.ndarray], leg_of: np.ndarray, n_legs: int):
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


def per_leg(extra: dict[str, np.ndarray], key: str, weights: np.ndarray, leg_of: np.ndarray, n_legs: int):
    """The ``weights``-weighted mean of the piece records ``extra[key]`` per leg (``leg_of``: each piece's leg); NaN for a leg without pieces."""
    w = np.bincount(leg_of, weights=weights, minlength=n_legs)
    s = np.bincount(leg_of, weights=weights * extra[key], minlength=n_legs)
    with np.errstate(invalid="ignore", divide="ignore"):
        return s / w
