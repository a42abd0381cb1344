"""The optimiser's result: a :class:`Plan`, and its independent verification.

A :class:`Plan` is a voyage fixed down to the leg: waypoints, the time the
ship passes each, and per leg a constant speed through the water.  Whatever
produced it (the corridor NLP of :func:`optroute.optimise_corridor`, the
search, a user's own schedule through :meth:`Plan.from_schedule`), the leg
quantities in :attr:`Plan.legs` are computed here from the *true* ship
model (:class:`~optroute.physics.performance.PerformanceModel`, not the NLP's fitted
power model) on a dense resampling of every leg, and :meth:`Plan.verify`
re-checks every constraint on such a resampling with code that shares
nothing with the NLP:

* each leg is a geodesic between its waypoints, cut into pieces of at
  most ``step_nm`` that are halved where the fuel or time integral needs it
  (every leg's fuel to about 0.1 %, :mod:`optroute.plan.evaluate`); the ship is
  at a piece at the time the plan's schedule puts it there (the leg's duration
  shared out in proportion to the piece times at the planned speed);
* the sea state there comes from :class:`~optroute.weather.WeatherSampler`;
  the heading is crabbed against the current
  (:func:`optroute.physics.currents.heading_for_course`), the brake power is the
  true model's (:func:`optroute.physics.passage.evaluate_speeds`);
* checked: minimum load ≤ power ≤ MCR, no danger band
  (:func:`optroute.physics.safety.is_speed_forbidden`, closed bands), navigable
  water (land mask, NaN weather, weather coverage), the course can be held
  against the current, within the corridor, the exclusion circle, the
  schedule is sailable at the planned speeds, and the ETA.

Conventions: positions (lat, lon) [deg], lon in [-180, 180); times
timezone-naive UTC ``datetime64[ns]``; headings and courses degrees true, the
direction the ship goes **to**; wave and wind directions where they come
**from**; IMO angle of encounter α, 0 = head sea (MSC.1/Circ.1228).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from numpy.typing import ArrayLike

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.geo import land
from optroute.geo.tracks import Exclusion, gc_points, project_to_polyline
from optroute.physics.performance import PerformanceModel, default_model
from optroute.physics.safety import BandRules
from optroute.physics.ship import Ship
from optroute.plan.checkpoints import BAND_TOL_NM, CheckPoints, check_points
from optroute.plan.evaluate import DenseTrack, PlanContext, Violation, evaluate_track, legs_table, step_midpoints
from optroute.plan.referee_checks import Findings, check_bands, check_engine, check_geometry, check_sea
from optroute.search.route import Corridor
from optroute.units import as_utc_time as _as_time
from optroute.units import h_to_timedelta as _h_to_td
from optroute.units import timedelta_to_h as _td_to_h
from optroute.weather.sample import WeatherSampler
from optroute.weather.schema import VARIABLES

__all__ = [
    "LEG_COLUMNS",
    "Exclusion",
    "Plan",
    "PlanContext",
    "Verification",
    "Violation",
    "gc_points",
    "project_to_polyline",
]

#: Columns of :attr:`Plan.legs`, in order (followed by ``margin_<band>`` for every band of
#: :data:`optroute.physics.safety.BANDS`).
LEG_COLUMNS: tuple[str, ...] = (
    "lat",
    "lon",
    "time",
    "heading_deg",
    "sog_kn",
    "stw_kn",
    "distance_nm",
    "duration_h",
    "power_kw",
    "fuel_t",
    "hs_m",
    "period_s",
    "wave_from_deg",
    "encounter_period_s",
)

_SEA_VARS = tuple(VARIABLES)  # every canonical weather variable


def _as_sampler(weather: xr.Dataset | WeatherSampler) -> tuple[WeatherSampler, xr.Dataset | None]:
    if isinstance(weather, WeatherSampler):
        return weather, None
    if isinstance(weather, xr.Dataset):
        if "member" in weather.dims:
            raise ConfigError(
                f"the weather holds {weather.sizes['member']} ensemble members (dimension 'member'); a plan is "
                "evaluated in one weather: pick a member (optroute.weather.scenarios.member(ds, k) or "
                "ds.isel(member=k)), and check a plan against every member with plan.verify(weather=member)"
            )
        return WeatherSampler(weather), weather
    raise ConfigError(f"weather must be a canonical xarray.Dataset or a WeatherSampler, got {type(weather).__name__}")


# --------------------------------------------------------------------------- the plan


class Verification(list):
    """What :meth:`Plan.verify` found: a list of :class:`Violation` (empty when the plan is clean).

    Attributes
    ----------
    tol_nm : float
        Every stretch of a leg longer than this [nm] inside a danger band was found.
    points : CheckPoints
        The points checked (:func:`optroute.plan.checkpoints.check_points`).
    """

    def __init__(self, violations: list[Violation], *, tol_nm: float, points: CheckPoints) -> None:
        super().__init__(violations)
        self.tol_nm = float(tol_nm)
        self.points = points


@dataclass(frozen=True, eq=False)
class Plan:
    """A voyage plan: waypoints, schedule and per-leg speeds, with the true model's leg quantities.

    Build one with :func:`optroute.optimise_corridor`, :func:`optroute.plan_voyage` or
    :meth:`Plan.from_schedule`; every plan returned by the optimiser has passed :meth:`verify`.

    Attributes
    ----------
    legs : pandas.DataFrame
        One row per leg, columns :data:`LEG_COLUMNS` then ``margin_<band>`` for every band of
        :data:`optroute.physics.safety.BANDS`: ``lat``, ``lon`` of the leg start [deg]; ``time`` of the
        leg start [UTC]; ``heading_deg`` (time-mean heading crabbed against the current [deg true,
        to]); ``sog_kn`` (distance / duration [kn]); ``stw_kn`` (speed through the water, constant
        on the leg [kn]); ``distance_nm`` (great circle [nm]); ``duration_h`` [h]; ``power_kw``
        (time-mean brake power of the true model [kW]); ``fuel_t`` (fuel of the true model [t]);
        ``hs_m``, ``period_s`` (time-mean sea [m], [s]); ``wave_from_deg`` (circular mean [deg
        true, from]); ``encounter_period_s`` (at those means [s]); ``margin_<band>`` (the smallest
        signed distance to the band along the leg in its ratio units, > 0 safe, ``inf`` where it
        never applies; :func:`optroute.physics.safety.band_margins`).
    waypoints : numpy.ndarray, shape (n, 2)
        (lat, lon) [deg].
    times : numpy.ndarray of datetime64[ns], shape (n,)
        When the ship passes each waypoint [UTC].
    total_fuel_t : float
        Voyage fuel [t] (true model).
    duration_h : float
        Passage time [h].
    departure, arrival : numpy.datetime64
        [UTC].
    status : str
        ``"optimal"`` (Ipopt converged: a local optimum for the band sides chosen, refined by the
        side-flip search), ``"feasible"`` (a verified plan Ipopt only solved to its acceptable
        level) or, for :meth:`from_schedule`, the caller's label.
    solver_stats : mapping
        Ipopt's status verbatim, iterations, times, outer-loop flips, the power-fit error, the
        convex certificate gap... (see :func:`optroute.optimise_corridor`).
    eta_shadow_price_t_per_h : float
        Fuel saved per extra hour of passage [t/h] (the ETA constraint's multiplier); NaN when
        there is no ETA or the objective is time.
    context : PlanContext
        Ship, models, rules, weather and requirements :meth:`verify` checks against.
    """

    legs: pd.DataFrame
    waypoints: np.ndarray
    times: np.ndarray
    total_fuel_t: float
    duration_h: float
    departure: np.datetime64
    arrival: np.datetime64
    status: str
    solver_stats: Mapping[str, Any]
    eta_shadow_price_t_per_h: float
    context: PlanContext = field(repr=False)

    def __post_init__(self) -> None:
        wp = np.asarray(self.waypoints, dtype=float)
        if wp.ndim != 2 or wp.shape[1] != 2 or wp.shape[0] < 2:
            raise ConfigError(f"Plan.waypoints must be an (n, 2) array of (lat, lon) with n >= 2, got {wp.shape}")
        times = np.asarray(self.times, dtype="datetime64[ns]")
        if times.shape != (wp.shape[0],) or np.any(np.diff(times) <= np.timedelta64(0, "ns")):
            raise ConfigError(f"Plan.times must be {wp.shape[0]} strictly increasing UTC times")
        if not isinstance(self.legs, pd.DataFrame) or len(self.legs) != wp.shape[0] - 1:
            raise ConfigError(f"Plan.legs must be a DataFrame with one row per leg ({wp.shape[0] - 1})")
        missing = [c for c in LEG_COLUMNS if c not in self.legs.columns]
        if missing:
            raise ConfigError(f"Plan.legs lacks the columns {missing}")
        if not isinstance(self.context, PlanContext):
            raise ConfigError("Plan.context must be a PlanContext (build plans with Plan.from_schedule)")
        wp = wp.copy()
        wp.setflags(write=False)
        times.setflags(write=False)
        object.__setattr__(self, "waypoints", wp)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "solver_stats", dict(self.solver_stats))

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_schedule(
        cls,
        waypoints: ArrayLike,
        stw_kn: ArrayLike,
        *,
        departure: Any,
        ship: Ship,
        weather: xr.Dataset | WeatherSampler,
        model: PerformanceModel | None = None,
        rules: BandRules | None = None,
        times: ArrayLike | None = None,
        corridor: Corridor | None = None,
        eta: Any = None,
        eta_mode: str = "le",
        exclusion: Exclusion | None = None,
        use_land_mask: bool | None = None,
        status: str = "unverified",
        solver_stats: Mapping[str, Any] | None = None,
        eta_shadow_price_t_per_h: float = float("nan"),
        step_nm: float = 5.0,
    ) -> Plan:
        """A plan from waypoints and leg speeds, its leg quantities computed with the true model.

        Parameters
        ----------
        waypoints : array_like, shape (n, 2)
            (lat, lon) [deg]; the legs are the great circles between them.
        stw_kn : array_like, shape (n - 1,)
            Speed through the water of every leg [kn], > 0.
        departure : datetime64 or str
            [UTC].
        ship, weather, model, rules
            The ship, the weather (canonical dataset or sampler), its performance model (default
            :class:`~optroute.physics.performance.KwonModel`) and danger-band rules (default Boeing).
        times : array_like of datetime64, shape (n,), optional
            The schedule (first = departure). Default: sailed at ``stw_kn`` through the weather
            (``Σ piece / SOG`` on pieces of at most ``step_nm``, the SOG at the time the ship is
            there). A given schedule is kept as is; :meth:`verify` reports it when the speeds
            cannot sail it (``"schedule"``).
        corridor, eta, eta_mode, exclusion, use_land_mask
            What :meth:`verify` checks (see :class:`PlanContext`).
        status, solver_stats, eta_shadow_price_t_per_h
            Stored as given.
        step_nm : float
            Longest piece of the dense resampling [nm], before the fuel integration halves pieces
            where it needs (:func:`optroute.plan.evaluate.evaluate_track`).
        """
        wp = np.asarray(waypoints, dtype=float)
        if wp.ndim != 2 or wp.shape[1] != 2 or wp.shape[0] < 2:
            raise ConfigError(f"waypoints must be an (n, 2) array of (lat, lon) with n >= 2, got shape {wp.shape}")
        finite("waypoints", wp, error=ConfigError)
        wp = np.column_stack([wp[:, 0], units.wrap_180(wp[:, 1])])
        stw = finite("stw_kn", stw_kn, minimum=0.0, strict=True, error=ConfigError, fix="give one speed > 0 per leg")
        stw = np.broadcast_to(stw, (wp.shape[0] - 1,)).astype(float)
        step = float(finite("step_nm", step_nm, minimum=0.0, strict=True, error=ConfigError))
        t0 = _as_time(departure, "departure")
        sampler, ds = _as_sampler(weather)
        ctx = PlanContext(
            ship=ship,
            model=model if model is not None else default_model(ship),
            rules=rules if rules is not None else BandRules(),
            sampler=sampler,
            dataset=ds,
            corridor=corridor,
            eta=eta,
            eta_mode=eta_mode,
            exclusion=exclusion,
            use_land_mask=use_land_mask,
        )
        tt = None
        if times is not None:
            tt = np.asarray(times, dtype="datetime64[ns]")
            if tt.shape != (wp.shape[0],) or tt[0] != t0:
                raise ConfigError(
                    f"times must hold {wp.shape[0]} UTC times starting at the departure {units.format_utc(t0)}"
                )
        return cls.from_context(
            ctx,
            wp,
            stw,
            departure=t0,
            times=tt,
            status=status,
            solver_stats=solver_stats,
            eta_shadow_price_t_per_h=eta_shadow_price_t_per_h,
            step_nm=step,
        )

    @classmethod
    def from_context(
        cls,
        context: PlanContext,
        waypoints: np.ndarray,
        stw_kn: np.ndarray,
        *,
        departure: np.datetime64,
        times: np.ndarray | None = None,
        status: str = "unverified",
        solver_stats: Mapping[str, Any] | None = None,
        eta_shadow_price_t_per_h: float = float("nan"),
        step_nm: float = 5.0,
    ) -> Plan:
        """:meth:`from_schedule` with a ready :class:`PlanContext` (checked inputs: (n, 2) waypoints, n − 1 speeds)."""
        wp = np.asarray(waypoints, dtype=float)
        stw = np.asarray(stw_kn, dtype=float)
        sched_h = None if times is None else _td_to_h(np.asarray(times, dtype="datetime64[ns]") - departure)
        ev = evaluate_track(context, wp, stw, departure, sched_h, step_nm)
        if sched_h is None:
            sched_h = np.concatenate([[0.0], np.cumsum(ev.leg_duration_h)])
        tt = departure + _h_to_td(sched_h)
        d = geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
        legs = legs_table(context, wp, tt, ev, d)
        plan = cls(
            legs=legs,
            waypoints=wp,
            times=tt,
            total_fuel_t=float(legs["fuel_t"].sum()),
            duration_h=float(sched_h[-1]),
            departure=departure,
            arrival=tt[-1],
            status=status,
            solver_stats=dict(solver_stats or {}),
            eta_shadow_price_t_per_h=float(eta_shadow_price_t_per_h),
            context=context,
        )
        object.__setattr__(
            plan, "_dense", (float(step_nm), stw.copy(), wp.copy(), ev)
        )  # shared with verify at this spacing
        return plan

    def __getstate__(self) -> dict[str, Any]:
        """The plan's fields for pickling, without the dense evaluation :meth:`verify` shares (a worker's payload)."""
        return {k: v for k, v in self.__dict__.items() if k != "_dense"}

    def _dense_track(self, stw: np.ndarray, sched_h: np.ndarray, step_nm: float) -> DenseTrack:
        """The referee's dense evaluation of this plan at ``step_nm``: the one :meth:`from_context` made when it is of
        this plan's speeds, waypoints and spacing (:meth:`verify`), else :func:`evaluate_track` again."""
        held = getattr(self, "_dense", None)
        if (
            held is not None
            and held[0] == step_nm
            and np.array_equal(held[1], stw)
            and np.array_equal(held[2], self.waypoints)
        ):
            return held[3]
        return evaluate_track(self.context, self.waypoints, stw, self.departure, sched_h, step_nm)

    # ------------------------------------------------------------------ properties
    @property
    def distance_nm(self) -> float:
        """Distance sailed [nm]."""
        return float(self.legs["distance_nm"].sum())

    @property
    def stw_kn(self) -> np.ndarray:
        """Speed through the water of every leg [kn]."""
        return self.legs["stw_kn"].to_numpy(dtype=float)

    def for_later_eta(self, eta: np.datetime64, *, status: str) -> Plan | None:
        """The same plan judged against a later ETA, without evaluating it again; None where that is not one.

        :meth:`verify` reads the ETA only in its arrival check, "by the ETA" in mode ``"le"``: the legs, their sea
        and every band, engine, land and corridor check belong to the track, speeds and departure alone. A plan
        whose context has an ETA in mode ``"le"`` therefore gets, against any ``eta`` [UTC] at or after it, the
        verdict it gets now. The result shares this plan's legs and its dense evaluation (which
        :meth:`verify` reads); its ``status`` is the one given, with no solver statistics and no shadow price
        (they were this plan's solve's). None for an earlier ``eta``, one before the plan's arrival, an ETA in mode
        ``"eq"``, or no ETA.
        """
        ctx = self.context
        if ctx.eta is None or ctx.eta_mode != "le" or eta < ctx.eta or self.arrival > eta:
            return None
        out = replace(self, status=status, solver_stats={}, eta_shadow_price_t_per_h=float("nan"),
                      context=replace(ctx, eta=eta))  # fmt: skip
        held = getattr(self, "_dense", None)
        if held is not None:
            object.__setattr__(out, "_dense", held)
        return out

    def in_weather(self, weather: xr.Dataset | WeatherSampler, *, step_nm: float = 5.0) -> Plan:
        """The same track and speeds through water sailed in another weather (an ensemble member, the truth).

        The waypoints and leg speeds through water [kn] are kept; the schedule, power and fuel are the true
        model's in ``weather`` (:meth:`from_context` without times: the speed over ground of that weather's
        current), and the context's requirements (ETA, corridor, exclusion, land) are kept, so
        :meth:`verify` of the result checks the plan there.

        Raises
        ------
        ConfigError
            ``weather`` is not one weather (a dataset with a ``member`` dimension: pick a member).
        """
        sampler, ds = _as_sampler(weather)
        step = float(finite("step_nm", step_nm, minimum=0.0, strict=True, error=ConfigError))
        ctx = replace(self.context, sampler=sampler, dataset=ds)
        return Plan.from_context(
            ctx,
            np.asarray(self.waypoints, dtype=float),
            self.stw_kn,
            departure=self.departure,
            status=self.status,
            solver_stats=self.solver_stats,
            eta_shadow_price_t_per_h=self.eta_shadow_price_t_per_h,
            step_nm=step,
        )

    # ------------------------------------------------------------------ verification
    def _land_between(
        self, found: dict[tuple[str, int], tuple[float, Violation]], step: float, sched_h: np.ndarray
    ) -> None:
        """Land checks at the land mask's own spacing where ``step`` is coarser (an island between two points).

        Every leg is checked every :data:`optroute.geo.land.DEFAULT_LEG_RESOLUTION_NM` (about one GLOBE cell);
        the first land point of a leg not yet reported is added to ``found``.
        """
        res = land.DEFAULT_LEG_RESOLUTION_NM
        if step <= res:
            return
        wp = np.asarray(self.waypoints, dtype=float)
        lat, lon, leg = land._leg_points(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1], res)
        hit = land.is_land(lat, lon)
        for i in np.flatnonzero(hit):
            k = int(leg[i])
            if ("land", k) in found:
                continue
            d = float(geo.distance_nm(wp[k, 0], wp[k, 1], wp[k + 1, 0], wp[k + 1, 1]))
            f = float(geo.distance_nm(wp[k, 0], wp[k, 1], lat[i], lon[i])) / d if d > 0 else 0.0
            when = self.departure + _h_to_td(float(sched_h[k] + f * (sched_h[k + 1] - sched_h[k])))
            found[("land", k)] = (1.0, Violation("land", k, (float(lat[i]), float(lon[i])), when, 1.0, 0.0))

    def _check_schedule(
        self,
        found: dict[tuple[str, int], tuple[float, Violation]],
        leg_duration_h: np.ndarray,
        sched: np.ndarray,
        tol_h: float,
        eta_t: np.datetime64 | None,
        mode: str,
    ) -> None:
        """The planned times [h after departure] against those the planned speeds give (``leg_duration_h``) and the
        arrival against the ETA (by it with ``mode`` ``"le"``, at it with ``"eq"``), within ``tol_h``; into
        ``found``."""
        # schedule: the planned times against the times the planned speeds give
        sailed = np.concatenate([[0.0], np.cumsum(leg_duration_h)])
        err = sailed - sched
        bad = np.flatnonzero(np.abs(err) > tol_h)
        if bad.size:
            k = int(bad[np.argmax(np.abs(err[bad]))])
            leg = max(k - 1, 0)
            v = Violation(
                "schedule", leg, tuple(float(x) for x in self.waypoints[k]), self.times[k], float(err[k]), tol_h
            )
            found[("schedule", leg)] = (abs(float(err[k])), v)
        if eta_t is not None:
            eta_h = float(_td_to_h(eta_t - self.departure))
            offsets = [float(sched[-1]) - eta_h, float(sailed[-1]) - eta_h]  # planned and sailed arrival − ETA
            late = max(offsets) if mode == "le" else max(offsets, key=abs)
            if (mode == "le" and late > tol_h) or (mode == "eq" and abs(late) > tol_h):
                leg = self.waypoints.shape[0] - 2
                v = Violation("eta", leg, tuple(float(x) for x in self.waypoints[-1]), self.arrival, late, tol_h)
                found[("eta", leg)] = (abs(late), v)

    def verify(
        self,
        *,
        step_nm: float = 5.0,
        time_tol_h: float = 1.0 / 60.0,
        power_rtol: float = 1e-6,
        corridor_tol_nm: float = 0.01,
        eta: Any = None,
        eta_mode: str | None = None,
        tol_nm: float = BAND_TOL_NM,
        weather: xr.Dataset | WeatherSampler | None = None,
    ) -> Verification:
        """Re-check every constraint on a dense resampling, independently of the optimiser.

        The checks are made at the referee's check points (:func:`optroute.plan.checkpoints.check_points`):
        both ends of every leg, the midpoints of equal pieces of at most ``step_nm``
        (:func:`optroute.plan.evaluate.step_midpoints`, not the fuel integration's halved pieces), points at most 1 nm
        apart, both sides of every change of the weather's interpolation cell (grid row, column, time
        slice) and, halved adaptively, wherever a band's ratio or Hs nears the band's edge or
        threshold or the wave direction turns fast: **every stretch of a leg longer than**
        ``tol_nm`` **(0.1 nm by default) inside a danger band is found**; a shorter one may be. The
        engine's range is searched the same way (:func:`optroute.plan.checkpoints.engine_intervals_to_halve`):
        halved where the power nears the MCR or the minimum load, or the model's power regime (Kwon's
        Beaufort number, wave sector) changes or may change between points, so every stretch longer
        than ``tol_nm`` above the MCR or below the minimum load is found too.

        A plan made by :meth:`from_context` (every plan of the optimiser and of its start candidates) keeps the dense
        evaluation it was made from, and a check at the same ``step_nm`` (and speeds) reads it instead of evaluating
        the track a second time: the same function (:func:`optroute.plan.evaluate.evaluate_track`) on the same
        pieces, at the times of the schedule that evaluation sailed (the plan's ``times`` are that schedule rounded
        to the nanosecond). A plan built another way (:func:`dataclasses.replace`, unpickled) is evaluated afresh.

        Parameters
        ----------
        step_nm : float
            Longest piece of the dense evaluation [nm] (the schedule's timing inside each leg; the
            midpoints of equal pieces this long are check points too). Land is also checked every
            :data:`optroute.geo.land.DEFAULT_LEG_RESOLUTION_NM` (0.5 nm, about one GLOBE cell) along the legs.
        time_tol_h : float
            Tolerance of the ETA and of the schedule [h] (default one minute).
        power_rtol : float
            Relative tolerance of the power limits [-].
        corridor_tol_nm : float
            Tolerance of the corridor's half-width [nm].
        eta, eta_mode : optional
            Override the plan's ETA requirement (default: the context's).
        tol_nm : float
            Band stretches longer than this are found [nm] (:data:`optroute.plan.checkpoints.BAND_TOL_NM`).
        weather : xarray.Dataset or WeatherSampler, optional
            Check the plan in another weather than the one it was planned in (an ensemble member, the
            truth): its track and speeds through water are sailed there (:meth:`in_weather`: the
            schedule is the one those speeds make in that weather, so a current changes the arrival) and
            every constraint of the plan's context (ship, rules, corridor, ETA, exclusion) is checked
            there by the same referee.

        Returns
        -------
        Verification
            A list of :class:`Violation`, the worst point of every (kind, leg) that breaks a constraint;
            empty (``== []``) when the plan is clean; ``tol_nm`` and ``points`` say where it looked.
        """
        ctx = self.context
        step = float(finite("step_nm", step_nm, minimum=0.0, strict=True, error=ConfigError))
        if weather is not None:
            return self.in_weather(weather, step_nm=step).verify(
                step_nm=step,
                time_tol_h=time_tol_h,
                power_rtol=power_rtol,
                corridor_tol_nm=corridor_tol_nm,
                eta=eta,
                eta_mode=eta_mode,
                tol_nm=tol_nm,
            )
        tol_h = float(finite("time_tol_h", time_tol_h, minimum=0.0, error=ConfigError))
        tol_nm = float(finite("tol_nm", tol_nm, minimum=0.0, strict=True, error=ConfigError))
        eta_t = _as_time(eta, "eta") if eta is not None else ctx.eta
        mode = eta_mode or ctx.eta_mode
        if mode not in ("le", "eq"):
            raise ConfigError(f"eta_mode={mode!r} is not known; use 'le' or 'eq'")
        t0 = self.departure
        sched = _td_to_h(self.times - t0)
        stw = self.stw_kn
        ev = self._dense_track(stw, sched, step)
        wp = np.asarray(self.waypoints, dtype=float)
        d = geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
        pts = check_points(
            ctx, wp, stw, t0, d, ev, tol_nm=tol_nm, nodes=step_midpoints(d, step), power_rtol=float(power_rtol)
        )
        findings = Findings(pts, t0)
        nav, held, ok = check_sea(findings, ctx)
        if ctx.land_mask_applies:
            self._land_between(findings.found, step, sched)
        check_engine(findings, ctx, ok, float(power_rtol))
        check_bands(findings, ctx, nav, held)
        check_geometry(findings, ctx, corridor_tol_nm)
        self._check_schedule(findings.found, ev.leg_duration_h, sched, tol_h, eta_t, mode)
        return Verification(findings.listed(), tol_nm=pts.tol_nm, points=pts)

    # ------------------------------------------------------------------ export
    def to_geojson(self) -> dict[str, Any]:
        """The plan as an RFC 7946 GeoJSON FeatureCollection (:func:`optroute.plan.outputs.geojson`).

        A ``track`` feature (``LineString`` of [lon, lat] positions, a ``MultiLineString`` split
        at the antimeridian, RFC 7946 §3.1.9, the crossing latitude on the leg's great circle),
        one ``leg`` feature per leg and one ``waypoint`` ``Point`` per waypoint, with the leg
        quantities under their unit-suffixed names; NaN and infinite values are ``null``.

        Returns
        -------
        dict
            JSON-serialisable (``json.dumps(..., allow_nan=False)``).
        """
        from optroute.plan import outputs

        return outputs.geojson(self)

    def to_dataset(self) -> xr.Dataset:
        """The plan as a CF-1.8 ``xarray.Dataset`` (:func:`optroute.plan.outputs.plan_dataset`).

        Leg variables on ``leg`` (``leg_time``, ``leg_start_lat``, ``leg_start_lon`` and the
        quantities of :attr:`legs`), waypoints on ``waypoint`` (``waypoint_lat``,
        ``waypoint_lon``, ``waypoint_time``), each with ``units`` and ``long_name``.
        """
        from optroute.plan import outputs

        return outputs.plan_dataset(self)

    def to_netcdf(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`to_dataset` to NetCDF-4, atomically (temporary name in the same folder, then rename).

        Returns
        -------
        pathlib.Path
            The path written.

        Raises
        ------
        ConfigError
            The folder does not exist or cannot be written; an earlier file is left intact.
        """
        from optroute.plan import outputs

        return outputs.write_netcdf(self, path)

    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write one CSV row per leg, units in the headers (:func:`optroute.plan.outputs.csv_frame`), atomically.

        Columns: ``leg``, ``start_time_utc``, ``end_time_utc`` (ISO 8601 ``Z``),
        ``start_lat_deg``, ``start_lon_deg``, ``end_lat_deg``, ``end_lon_deg`` [deg], then
        ``heading_deg``, ``sog_kn``, ``stw_kn``, ``distance_nm``, ``duration_h``, ``power_kw``,
        ``fuel_t``, ``hs_m``, ``period_s``, ``wave_from_deg``, ``encounter_period_s`` and
        ``margin_<band>`` [-].

        Returns
        -------
        pathlib.Path
            The path written.
        """
        from optroute.plan import outputs

        return outputs.write_csv(self, path)

    def plot(self, *, title: str | None = None) -> Any:
        """The profile of the passage along the route (:func:`optroute.plot.plan.plan_profile_figure`).

        Speed, power against MCR, Hs and the margin to each danger band against time.

        Parameters
        ----------
        title : str, optional
            Figure title.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from optroute.plot.plan import plan_profile_figure

        return plan_profile_figure(self, title=title)
