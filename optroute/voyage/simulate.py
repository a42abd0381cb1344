"""Sail a plan through a "truth" weather in time steps, re-planning as forecasts arrive.

Each time step the ship is on a leg of its current plan, on the great circle to the leg's end.
The sea is sampled from the truth (:class:`~optroute.weather.WeatherSampler`) at the step's
midpoint (the position and time half a step on at the speed chosen at its start: the midpoint
rule, second order in the step). The speed through water is the plan's for the leg, reduced where
the truth forbids it by the same Boeing speed reduction the search uses
(:func:`optroute.physics.passage.best_speed` on :func:`~optroute.physics.passage.evaluate_speeds`:
the fastest speed at or below the plan's that is outside every danger band, within [minimum load,
MCR] and holds the course against the current), down to ``min_stw_kn``, the slowest speed the
master will use. Where no such speed exists the ship keeps the fastest speed within its power
limits at or below the plan's (the same reduction with the bands off): it sails *inside* a danger
band, and the log and the outcome count that time. Where only the engine's minimum load rules
out the plan's speed (a light following sea), the ship keeps the plan's speed. The heading is crabbed against the current,
the power and fuel are the true model's (the same functions :meth:`optroute.Plan.verify` uses).

Re-plans start from the current position and time with the same absolute ETA, on the newest
forecast issued by then (:class:`~optroute.voyage.policy.ForecastSequence`), with
:func:`optroute.optimise_corridor` in a corridor about the great circle to the destination or,
with ``search_options``, :func:`optroute.search_route` and the optimiser in the corridor about
the route (the route itself when the optimiser finds no verified plan). When the ETA cannot be met any more the
re-plan is a minimum-time plan and its arrival is reported as the earliest arrival.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import xarray as xr

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError, InfeasibleETA, OptrouteError, SolverFailure, WeatherCoverageError
from optroute.optimise.api import optimise_corridor
from optroute.physics.passage import SpeedChoice, best_speed, evaluate_speeds
from optroute.physics.performance import PerformanceModel, default_model
from optroute.physics.safety import BandRules, band_margins, is_speed_forbidden
from optroute.physics.ship import Ship
from optroute.plan.evaluate import sample_sea
from optroute.plan.result import Plan
from optroute.search.route import Corridor, Route
from optroute.search.routing import search_route
from optroute.units import as_utc_time as _as_time
from optroute.units import h_to_timedelta as _h_to_td
from optroute.units import timedelta_to_h as _td_to_h
from optroute.voyage.cyclone import CycloneWatch, cyclone_encounter
from optroute.voyage.log import StepRecord, replan_record, voyage_dataset
from optroute.voyage.onboard import ObserverWatch, OnboardObserver, intervention_speed_kn, unstable
from optroute.voyage.policy import ForecastSequence, ReplanPolicy, VoyageOutcome
from optroute.weather.sample import WeatherSampler

__all__ = ["VoyageError", "VoyageResult", "simulate_voyage"]

_NO_BANDS = BandRules(synchronous_roll=False, parametric_roll=False, surf_riding=False, high_wave_attack=False)
_ARRIVED_NM = 1e-6


class VoyageError(OptrouteError):
    """The simulated ship cannot go on: no speed within its power limits holds the course, or no passage."""


@dataclass(frozen=True, eq=False)
class VoyageResult:
    """A simulated voyage.

    Attributes
    ----------
    outcome : VoyageOutcome
        Arrival, fuel, time in danger bands, ETA met or missed.
    log : xarray.Dataset
        The voyage log (:func:`optroute.voyage.log.voyage_dataset`): the track sailed on ``step``,
        every plan on ``replan`` (its reason, forecast, fuel, arrival and waypoints).
    plans : tuple of Plan
        Every plan sailed, the first one first.
    """

    outcome: VoyageOutcome
    log: xr.Dataset = field(repr=False)
    plans: tuple[Plan, ...] = field(repr=False)


@dataclass
class _Sailing:
    """The plan being sailed: its remaining waypoints from where it was made, and the leg the ship is on."""

    plan: Plan
    forecast_index: int | None
    made_at: np.datetime64
    leg: int = 0
    track_index: int | None = None  # the cyclone forecast track the plan kept out of (None: the truth or none)

    @property
    def target(self) -> np.ndarray:
        return self.plan.waypoints[self.leg + 1]

    @property
    def commanded_kn(self) -> float:
        return float(self.plan.stw_kn[self.leg])


@dataclass(frozen=True)
class _Setup:
    ship: Ship
    model: PerformanceModel
    rules: BandRules
    truth: WeatherSampler
    destination: tuple[float, float]
    eta: np.datetime64 | None
    min_stw_kn: float
    speed_step_kn: float
    corridor_width_nm: float
    search_options: Mapping[str, Any] | None
    optimise_options: Mapping[str, Any]
    master_rules: BandRules  # the bands the master's speed reduction applies (the observer may take one over)
    cyclone: CycloneWatch | None = None


# --------------------------------------------------------------------------- one step in the truth


def _speed_at(s: _Setup, when: np.datetime64, lat: float, lon: float, course: float, commanded: float) -> dict:
    """Sea of the truth and the speed sailed at one point (Boeing speed reduction, bands off as a last resort)."""
    sea, inside = sample_sea(s.truth, np.array([when]), np.array([lat]), np.array([lon]))
    if not inside[0]:
        raise WeatherCoverageError(
            f"the simulated ship is at ({lat:.4f}, {lon:.4f}) at {units.format_utc(when)}, outside the truth "
            "weather; give a truth dataset covering the whole voyage (area and time)"
        )
    if not sea.navigable[0]:
        raise VoyageError(
            f"the simulated ship reached no-passage water (NaN weather) at ({lat:.4f}, {lon:.4f}) "
            f"{units.format_utc(when)}; the plan crosses a no-go area of the truth"
        )
    floor = min(s.min_stw_kn, commanded)
    c = np.array([course])
    met = _forbidden(s, sea, np.array([commanded]), c)
    choice = best_speed(s.ship, s.model, s.master_rules, c, sea, commanded, step_kn=s.speed_step_kn, min_stw_kn=floor)
    in_band = False
    if not choice.feasible[0]:
        choice = best_speed(s.ship, s.model, _NO_BANDS, c, sea, commanded, step_kn=s.speed_step_kn, min_stw_kn=floor)
        if not choice.feasible[0]:
            choice = _below_min_load(s, c, sea, commanded)
        if choice is None:
            raise VoyageError(
                f"no speed from {floor:.3g} to {commanded:.3g} kn holds the course {course:.1f} deg within the power "
                f"limits at ({lat:.4f}, {lon:.4f}) {units.format_utc(when)} in the truth; lower min_stw_kn"
            )
        in_band = _forbidden(s, sea, choice.stw_kn, choice.heading_deg)
    stw = float(choice.stw_kn[0])
    margins = band_margins(
        s.ship,
        speed_kn=choice.stw_kn,
        hs_m=sea.hs_m,
        period_s=sea.period_s,
        wave_from_deg=sea.wave_from_deg,
        heading_deg=choice.heading_deg,
        rules=s.rules,
    )
    return {
        "stw_kn": stw,
        "sog_kn": float(choice.sog_kn[0]),
        "heading_deg": float(choice.heading_deg[0]),
        "power_kw": float(choice.power_kw[0]),
        "fuel_tph": float(choice.fuel_tph[0]),
        "hs_m": float(sea.hs_m[0]),
        "period_s": float(sea.period_s[0]),
        "wave_from_deg": float(sea.wave_from_deg[0]),
        "in_band": in_band,
        "band_met": met,
        "slowed": stw < commanded - 1e-9,
        "margins": {b: float(np.asarray(m.margin, dtype=float).ravel()[0]) for b, m in margins.items()},
    }


def _forbidden(s: _Setup, sea: Any, stw_kn: np.ndarray, heading_deg: np.ndarray) -> bool:
    """Whether the speed lies inside an enforced danger band of the truth (heading as given)."""
    return bool(
        is_speed_forbidden(
            s.ship,
            speed_kn=stw_kn,
            hs_m=sea.hs_m,
            period_s=sea.period_s,
            wave_from_deg=sea.wave_from_deg,
            heading_deg=heading_deg,
            rules=s.rules,
        )[0]
    )


def _below_min_load(s: _Setup, course: np.ndarray, sea: Any, commanded: float) -> SpeedChoice | None:
    """The commanded speed when only the engine's minimum load rules it out (a light sea astern); else None."""
    heading, sog, power, fuel, _ = evaluate_speeds(s.ship, s.model, _NO_BANDS, course, sea, np.array([commanded]))
    if not (np.isfinite(heading[0]) and sog[0] > 0 and power[0] <= s.model.mcr_kw):
        return None
    return SpeedChoice(np.array([commanded]), sog, heading, power, fuel, np.array([True]))


def _sail_piece(
    s: _Setup, sailing: _Sailing, t: np.datetime64, pos: np.ndarray, budget_h: float, commanded: float | None = None
) -> StepRecord:
    """Sail at most ``budget_h`` along the current leg (stopping at its end), speed and sea at the midpoint.

    ``commanded`` overrides the plan's speed [kn] (the observer's intervention).
    """
    target = sailing.target
    d = float(geo.distance_nm(pos[0], pos[1], target[0], target[1]))
    commanded = sailing.commanded_kn if commanded is None else commanded
    course0 = float(geo.initial_course_deg(pos[0], pos[1], target[0], target[1]))
    first = _speed_at(s, t, float(pos[0]), float(pos[1]), course0, commanded)
    h = min(budget_h, d / first["sog_kn"]) if first["sog_kn"] > 0 else budget_h
    mlat, mlon = geo.destination(pos[0], pos[1], course0, min(first["sog_kn"] * 0.5 * h, d))
    course_m = float(geo.initial_course_deg(mlat, mlon, target[0], target[1])) if d > 0 else course0
    mid = _speed_at(s, t + _h_to_td(0.5 * h), float(mlat), float(mlon), course_m, commanded)
    sog = mid["sog_kn"]
    if not sog > 0:
        raise VoyageError(
            f"the simulated ship makes no way over ground at ({float(mlat):.4f}, {float(mlon):.4f}) "
            f"{units.format_utc(t)} in the truth (SOG {sog:.3g} kn)"
        )
    h = min(budget_h, d / sog)
    reached = d / sog <= budget_h
    if reached:
        end = np.array(target, dtype=float)
    else:
        elat, elon = geo.destination(pos[0], pos[1], course0, sog * h)
        end = np.array([float(elat), float(units.wrap_180(elon))])
    return StepRecord(
        time=t,
        lat=float(pos[0]),
        lon=float(pos[1]),
        duration_h=h,
        distance_nm=sog * h,
        commanded_stw_kn=commanded,
        leg=sailing.leg,
        end=end,
        reached=reached,
        **mid,
    )


# --------------------------------------------------------------------------- planning


def _route_plan(s: _Setup, route: Route, weather: xr.Dataset, eta: Any, exclusion: Any) -> Plan | None:
    """The search route itself as a plan (its leg speeds, sailed through the forecast), if it verifies."""
    plan = Plan.from_schedule(
        route.waypoints,
        route.stw_kn,
        departure=route.departure,
        ship=s.ship,
        weather=weather,
        model=s.model,
        rules=s.rules,
        eta=eta,
        exclusion=exclusion,
        use_land_mask=s.optimise_options.get("use_land_mask"),
        status="search route (the optimiser found no verified plan)",
    )
    return plan if not plan.verify() else None


def _plan(
    s: _Setup, start: np.ndarray, weather: xr.Dataset, t: np.datetime64, warm: Plan | None = None
) -> tuple[Plan, str, Any]:
    """A plan from ``start`` at ``t`` to the destination on ``weather``: (plan, status, earliest arrival).

    With ``search_options``: :func:`optroute.search_route`, then :func:`optroute.optimise_corridor` in
    the corridor about the route, warm-started from it; when the optimiser returns no verified plan
    the route itself is sailed if it verifies. Without: the optimiser in a corridor about the great
    circle, warm-started from ``warm`` (the plan being sailed; its speeds interpolated along track).
    An infeasible ETA gives a minimum-time plan and the earliest arrival. With a cyclone, the search,
    the optimiser and the plan's check keep out of the circle of the track known at ``t``.
    """
    exclusion = None if s.cyclone is None else s.cyclone.exclusion(t)[0]
    common = {"model": s.model, "rules": s.rules, "exclusion": exclusion}
    start_t = (float(start[0]), float(start[1]))

    def solve(eta: Any, objective: str) -> Plan:
        route = None
        if s.search_options is not None:
            route = search_route(
                start_t,
                s.destination,
                weather,
                s.ship,
                departure=t,
                eta=eta,
                objective=objective,
                **common,
                **s.search_options,
            )
            corridor = route.corridor(width_nm=s.corridor_width_nm)
        else:
            corridor = Corridor.from_waypoints([start_t, s.destination], width_nm=s.corridor_width_nm)
        try:
            return optimise_corridor(
                corridor,
                weather,
                s.ship,
                departure=t,
                eta=eta,
                objective=objective,
                route=route,
                warm_plan=warm if route is None and objective == "fuel" else None,
                **common,
                **s.optimise_options,
            )
        except SolverFailure as exc:
            fallback = exc.best_plan if exc.best_plan is not None else None
            if fallback is None and route is not None:
                fallback = _route_plan(s, route, weather, eta, exclusion)
            if fallback is None:
                raise
            return fallback

    eta_left = None if s.eta is None else float(_td_to_h(s.eta - t))
    try:
        if eta_left is not None and eta_left <= 0:
            raise InfeasibleETA(f"the ETA {units.format_utc(s.eta)} has passed")
        plan = solve(s.eta, "fuel")
        return plan, plan.status, None
    except InfeasibleETA as exc:
        plan = solve(None, "time")
        earliest = exc.earliest_arrival if exc.earliest_arrival is not None else plan.arrival
        return plan, f"ETA infeasible, minimum time: {plan.status}", _as_time(earliest, "earliest arrival")


def _weather_trigger(policy: ReplanPolicy, s: _Setup, sailing: _Sailing, t: np.datetime64, pos: np.ndarray) -> str:
    """The re-plan reason when the truth met differs from the current plan's forecast beyond a threshold, else ''."""
    if policy.hs_threshold_m is None and policy.direction_threshold_deg is None and policy.period_threshold_s is None:
        return ""
    when, lat, lon = np.array([t]), np.array([pos[0]]), np.array([pos[1]])
    met, inside_t = sample_sea(s.truth, when, lat, lon)
    fc, inside_f = sample_sea(sailing.plan.context.sampler, when, lat, lon)
    if not (inside_t[0] and inside_f[0] and met.navigable[0] and fc.navigable[0]):
        return ""
    d_hs = abs(float(met.hs_m[0] - fc.hs_m[0]))
    d_dir = abs(float((met.wave_from_deg[0] - fc.wave_from_deg[0] + 180.0) % 360.0 - 180.0))
    d_per = abs(float(met.period_s[0] - fc.period_s[0]))
    for name, diff, limit, unit in (
        ("Hs", d_hs, policy.hs_threshold_m, "m"),
        ("wave direction", d_dir, policy.direction_threshold_deg, "deg"),
        ("period", d_per, policy.period_threshold_s, "s"),
    ):
        if limit is not None and diff > limit:
            return f"weather met: {name} differs from the plan's forecast by {diff:.3g} {unit} > {limit:.3g} {unit}"
    return ""


def _replan_reason(
    policy: ReplanPolicy, s: _Setup, sailing: _Sailing, forecasts: ForecastSequence, t: np.datetime64, pos: np.ndarray
) -> str:
    since = float(_td_to_h(t - sailing.made_at))
    if not policy.replans or since < policy.min_interval_h or since <= 0:
        return ""
    k = forecasts.latest_index(t) if len(forecasts) else None
    if policy.on_forecast and k is not None and (sailing.forecast_index is None or k > sailing.forecast_index):
        return f"new forecast issued {units.format_utc(forecasts.issue_times[k])}"
    kt = None if s.cyclone is None else s.cyclone.latest_index(t)
    if policy.on_forecast and kt is not None and (sailing.track_index is None or kt > sailing.track_index):
        return f"new cyclone track issued {units.format_utc(s.cyclone.issue_times[kt])}"  # type: ignore[union-attr]
    if policy.every_h is not None and since >= policy.every_h - 1e-9:
        return f"periodic: {since:.3g} h since the last plan"
    return _weather_trigger(policy, s, sailing, t, pos)


# --------------------------------------------------------------------------- the voyage


def _initial(
    plan_or_endpoints: Plan | Sequence[Any], departure: Any
) -> tuple[Plan | None, np.datetime64, tuple[float, float], tuple[float, float]]:
    if isinstance(plan_or_endpoints, Plan):
        p = plan_or_endpoints
        if departure is not None and _as_time(departure, "departure") != p.departure:
            raise ConfigError(
                f"departure={departure!r} differs from the plan's departure {units.format_utc(p.departure)}; "
                "leave departure out when passing a plan"
            )
        start = tuple(float(x) for x in p.waypoints[0])
        return p, p.departure, start, tuple(float(x) for x in p.waypoints[-1])  # type: ignore[return-value]
    try:
        start, end = plan_or_endpoints
        start = (float(start[0]), float(start[1]))
        end = (float(end[0]), float(end[1]))
    except (TypeError, ValueError, IndexError):
        raise ConfigError(
            f"plan_or_endpoints={plan_or_endpoints!r} is neither a Plan nor ((lat, lon), (lat, lon)) endpoints"
        ) from None
    if departure is None:
        raise ConfigError("departure is required with endpoints; pass departure='YYYY-MM-DDTHH:MM'")
    return None, _as_time(departure, "departure"), start, end


def simulate_voyage(
    plan_or_endpoints: Plan | Sequence[Any],
    truth: xr.Dataset,
    ship: Ship,
    *,
    forecasts: Sequence[tuple[Any, xr.Dataset]] = (),
    replan: ReplanPolicy | None = None,
    departure: Any = None,
    eta: Any = None,
    model: PerformanceModel | None = None,
    rules: BandRules | None = None,
    step_h: float = 0.5,
    min_stw_kn: float = 8.0,
    speed_step_kn: float = 0.25,
    corridor_width_nm: float = 300.0,
    search_options: Mapping[str, Any] | None = None,
    optimise_options: Mapping[str, Any] | None = None,
    min_replan_distance_nm: float = 30.0,
    warm_start: bool = True,
    observer: OnboardObserver | None = None,
    cyclone: CycloneWatch | None = None,
) -> VoyageResult:
    """Sail a voyage through the truth weather, re-planning on new forecasts under a policy.

    Parameters
    ----------
    plan_or_endpoints : Plan or ((lat, lon), (lat, lon))
        The first plan, or the ports [deg]: the first plan is then made at ``departure`` on the
        newest forecast issued by then.
    truth : xarray.Dataset
        The weather the ship really meets (canonical; an analysis, another member, the storm
        where it really went); it must cover the voyage.
    ship : Ship
    forecasts : sequence of (issue time, xarray.Dataset)
        Forecasts [UTC], each usable only from its issue time on.
    replan : ReplanPolicy, optional
        Default: re-plan on each new forecast.
    departure : datetime64 or str, optional
        [UTC]; required with endpoints, else the plan's.
    eta : datetime64 or str, optional
        Required arrival [UTC] (default: the plan's context's ETA, if any).
    model, rules
        True performance model (default Kwon) and danger-band rules (default Boeing).
    step_h : float
        Simulator time step [h], > 0 (the ship also stops a step at every waypoint).
    min_stw_kn : float
        Slowest speed through water the Boeing speed reduction goes to [kn], > 0.
    speed_step_kn : float
        Decrement of the speed reduction [kn], > 0.
    corridor_width_nm : float
        Total width of the re-planning corridor [nm] (about the great circle to the destination,
        or the searched route with ``search_options``).
    search_options : mapping, optional
        Plan with :func:`optroute.search_route` and these options, then the optimiser in the
        corridor about the route (default: the optimiser on the great circle, no search).
    optimise_options : mapping, optional
        Further keyword arguments of :func:`optroute.optimise_corridor` (``max_leg_nm``, ...).
    min_replan_distance_nm : float
        No re-plan when less than this distance is left [nm], >= 0.
    warm_start : bool
        Warm-start every re-plan from the plan being sailed (``warm_plan`` of
        :func:`optroute.optimise_corridor`, its speeds interpolated along the new corridor; without
        ``search_options``); False: cold starts.
    observer : OnboardObserver, optional
        Run the onboard parametric-roll observer of thyssenkrupp EP 2377756 on the simulated
        motions, with its short intervention and a re-plan after it
        (:mod:`optroute.voyage.onboard`); the log then carries RL, the roll and the alarms.
    cyclone : CycloneWatch, optional
        A tropical cyclone: every plan keeps out of R + margin (+ the cone) of the track known when
        it is made (:mod:`optroute.voyage.cyclone`), a new forecast track triggers a re-plan under
        ``on_forecast``, and the outcome and the log report the closest approach to the TRUE centre
        and the time inside R and inside R + margin (brute force along the track sailed).

    Returns
    -------
    VoyageResult

    Raises
    ------
    ForecastTimeError
        The first plan would use a forecast before its issue time (the message names both times).
    ConfigError
        A bad argument (named, with its value).
    VoyageError, WeatherCoverageError
        The ship cannot go on in the truth, or leaves it.
    """
    policy = replan if replan is not None else ReplanPolicy()
    if not isinstance(policy, ReplanPolicy):
        raise ConfigError(f"replan must be a ReplanPolicy, got {type(policy).__name__}")
    if not isinstance(truth, xr.Dataset):
        raise ConfigError(f"truth must be a canonical xarray.Dataset, got {type(truth).__name__}")
    if policy.wind_speed_threshold_kn is not None or policy.wind_direction_threshold_deg is not None:
        raise ConfigError(
            "ReplanPolicy wind thresholds are the sailing simulator's trigger (optroute.voyage.sailing_sim); the ship "
            "simulator re-plans on the sea met: use hs_threshold_m, direction_threshold_deg or period_threshold_s"
        )
    if cyclone is not None and not isinstance(cyclone, CycloneWatch):
        raise ConfigError(f"cyclone must be a CycloneWatch or None, got {type(cyclone).__name__}")
    if observer is not None and not isinstance(observer, OnboardObserver):
        raise ConfigError(f"observer must be an OnboardObserver or None, got {type(observer).__name__}")
    fseq = forecasts if isinstance(forecasts, ForecastSequence) else ForecastSequence(forecasts)
    step = float(finite("step_h", step_h, minimum=0.0, strict=True, error=ConfigError, fix="pass a step > 0 h"))
    floor = float(finite("min_stw_kn", min_stw_kn, minimum=0.0, strict=True, error=ConfigError))
    dstep = float(finite("speed_step_kn", speed_step_kn, minimum=0.0, strict=True, error=ConfigError))
    width = float(finite("corridor_width_nm", corridor_width_nm, minimum=0.0, error=ConfigError))
    min_left = float(finite("min_replan_distance_nm", min_replan_distance_nm, minimum=0.0, error=ConfigError))
    first, t0, start, dest = _initial(plan_or_endpoints, departure)
    if eta is None and first is not None:
        eta = first.context.eta
    model = model if model is not None else (first.context.model if first is not None else default_model(ship))
    rules = rules if rules is not None else (first.context.rules if first is not None else BandRules())
    s = _Setup(
        ship,
        model,
        rules,
        WeatherSampler(truth),
        dest,
        None if eta is None else _as_time(eta, "eta"),
        floor,
        dstep,
        width,
        search_options,
        dict(optimise_options or {}),
        rules if observer is None or observer.master_sees_parametric_band else replace(rules, parametric_roll=False),
        cyclone,
    )
    watch = None if observer is None else ObserverWatch(observer, ship)
    replans: list[dict[str, Any]] = []
    earliest = None
    if first is None:
        k, ds = fseq.latest(t0)
        first, status, earliest = _plan(s, np.asarray(start), ds, t0)
        sailing = _Sailing(first, k, t0, track_index=_track_index(s, t0))
    else:
        k = _plan_forecast_index(first, fseq)
        status = first.status
        sailing = _Sailing(first, k, t0, track_index=_track_index(s, t0))
    replans.append(replan_record(first, "initial plan", status, t0, k, fseq, earliest))
    _note_track(s, replans[-1], t0)
    plans = [first]
    records, t, earliest = _sail_voyage(
        s, policy, fseq, sailing, np.asarray(start, dtype=float), step, min_left, warm_start, replans, plans, earliest,
        watch,
    )  # fmt: skip
    log = voyage_dataset(records, replans, rules, observed=watch is not None)
    met = None if cyclone is None else cyclone_encounter(records, cyclone.truth, cyclone.margin_km)
    outcome = VoyageOutcome(
        departure=t0,
        arrival=t,
        fuel_t=float(sum(r.fuel_tph * r.duration_h for r in records)),
        distance_nm=float(sum(r.distance_nm for r in records)),
        time_in_band_h=float(sum(r.duration_h for r in records if r.in_band)),
        time_slowed_h=float(sum(r.duration_h for r in records if r.slowed)),
        time_band_met_h=float(sum(r.duration_h for r in records if r.band_met)),
        eta=s.eta,
        n_replans=len(plans) - 1,
        earliest_arrival=earliest,
        n_observer_alarms=0 if watch is None else watch.alarms,
        max_roll_deg=float(max((r.roll_max_deg for r in records), default=np.nan)) if watch is not None else np.nan,
        **({} if met is None else met.outcome_fields()),
    )
    if met is not None:
        log = met.into_log(log, cyclone)
    log.attrs.update(_outcome_attrs(outcome))
    return VoyageResult(outcome=outcome, log=log, plans=tuple(plans))


def _sail_voyage(
    s: _Setup,
    policy: ReplanPolicy,
    fseq: ForecastSequence,
    sailing: _Sailing,
    start: np.ndarray,
    step: float,
    min_left: float,
    warm_start: bool,
    replans: list[dict[str, Any]],
    plans: list[Plan],
    earliest: Any,
    watch: ObserverWatch | None = None,
) -> tuple[list[StepRecord], np.datetime64, Any]:
    """The stepping loop: re-plan when the policy says, sail a step, until the destination; appends to the lists."""
    t0 = t = sailing.made_at
    pos = start
    dest = s.destination
    records: list[StepRecord] = []
    while True:
        left = float(geo.distance_nm(pos[0], pos[1], dest[0], dest[1]))
        if left <= _ARRIVED_NM and sailing.leg >= sailing.plan.waypoints.shape[0] - 1:
            break
        reason = _replan_reason(policy, s, sailing, fseq, t, pos) if left >= max(min_left, _ARRIVED_NM) else ""
        if watch is not None and watch.pending_reason:
            reason, watch.pending_reason = (watch.pending_reason if left >= max(min_left, _ARRIVED_NM) else ""), ""
        if reason:
            k, ds = fseq.latest(t) if len(fseq) else (None, sailing.plan.context.dataset)
            try:
                new, status, e = _plan(s, pos, ds, t, sailing.plan if warm_start else None)
            except OptrouteError as exc:  # keep sailing the plan we have; the log says why
                replans.append(replan_record(None, reason, f"failed: {exc}", t, k, fseq, None))
                _note_track(s, replans[-1], t)
                sailing.made_at, sailing.forecast_index = t, k  # this forecast is spent; the next trigger tries again
                sailing.track_index = _track_index(s, t)
            else:
                earliest = e if e is not None else earliest
                sailing = _Sailing(new, k, t, track_index=_track_index(s, t))
                plans.append(new)
                replans.append(replan_record(new, reason, status, t, k, fseq, e))
                _note_track(s, replans[-1], t)
        budget = step - _elapsed_in_step(t, t0, step)
        rec = _sail_piece(s, sailing, t, pos, budget, None if watch is None else watch.intervention_kn)
        if watch is not None:
            rec = _observe(s, watch, sailing, t, pos, rec, float(_td_to_h(t - t0)))
        records.append(rec)
        t = t + _h_to_td(rec.duration_h)
        pos = rec.end
        if rec.reached:
            sailing.leg += 1
            if sailing.leg >= sailing.plan.waypoints.shape[0] - 1:
                break
    return records, t, earliest


def _observe(
    s: _Setup, watch: ObserverWatch, sailing: _Sailing, t: np.datetime64, pos: np.ndarray, rec: StepRecord, at_h: float
) -> StepRecord:
    """Run the observer on a sailed piece; at an alarm cut the piece there and start the intervention.

    ``at_h`` is the piece's start in hours since departure.
    """
    cfg = watch.config
    sea = {"hs_m": rec.hs_m, "period_s": rec.period_s, "wave_from_deg": rec.wave_from_deg}
    acting = watch.intervention_kn is not None
    seen = watch.watch(sea, rec.heading_deg, rec.stw_kn, rec.duration_h * 3600.0)
    plan_kn = sailing.commanded_kn
    if seen["alarm_s"] is not None:
        cut_h = seen["alarm_s"] / 3600.0
        if cut_h < rec.duration_h:
            rec = _sail_piece(s, sailing, t, pos, cut_h)
        v = intervention_speed_kn(
            s.ship, watch.roll_model, sea, rec.heading_deg, rec.stw_kn,
            lowest_kn=min(s.min_stw_kn, rec.stw_kn), highest_kn=rec.stw_kn, step_kn=cfg.speed_step_kn,
        )  # fmt: skip
        watch.intervention_kn = v if v is not None else min(s.min_stw_kn, rec.stw_kn)
        watch.until_h = at_h + rec.duration_h + cfg.hold_h
        watch.alarms += 1
        found = "" if v is not None else " (no speed down to the slowest damps the roll: the slowest)"
        watch.note = (
            f"observer: RL reached {cfg.threshold:g} at {units.format_utc(t + _h_to_td(rec.duration_h))} at "
            f"{rec.stw_kn:.3g} kn; held {watch.intervention_kn:.3g} kn{found}"
        )
        return replace(rec, rl_max=seen["rl_max"], roll_max_deg=seen["roll_max_deg"], observer_alarm=True)
    rec = replace(
        rec, rl_max=seen["rl_max"], roll_max_deg=seen["roll_max_deg"], intervention=acting, commanded_stw_kn=plan_kn
    )
    if (
        acting
        and at_h + rec.duration_h >= watch.until_h - 1e-9
        and not unstable(s.ship, watch.roll_model, sea, rec.heading_deg, plan_kn)
    ):
        watch.intervention_kn = None
        if cfg.replan:
            watch.pending_reason = watch.note
    return rec


def _note_track(s: _Setup, row: dict[str, Any], t: np.datetime64) -> None:
    """Mark a ``replan`` row with the cyclone track its plan kept out of (-1 the true track), with a cyclone."""
    if s.cyclone is not None:
        k = s.cyclone.latest_index(t)
        row["cyclone_track"] = -1 if k is None else k


def _track_index(s: _Setup, t: np.datetime64) -> int | None:
    """The cyclone forecast track known at ``t`` (None: no cyclone, or the planner knows the true track)."""
    return None if s.cyclone is None else s.cyclone.latest_index(t)


def _elapsed_in_step(t: np.datetime64, t0: np.datetime64, step: float) -> float:
    """Hours already sailed in the current simulator step (steps are aligned on the departure)."""
    h = float(_td_to_h(t - t0))
    r = h - step * np.floor(h / step + 1e-9)
    return 0.0 if r < 1e-9 or step - r < 1e-9 else r


def _plan_forecast_index(plan: Plan, fseq: ForecastSequence) -> int | None:
    """Which forecast a given plan was made on (by identity of its dataset); checked against its issue time."""
    k = fseq.index_of(plan.context.dataset)
    if k is not None:
        fseq.get(k, plan.departure)
    return k


def _outcome_attrs(o: VoyageOutcome) -> dict[str, Any]:
    return {
        "departure": units.format_utc(o.departure),
        "arrival": units.format_utc(o.arrival),
        "fuel_t": o.fuel_t,
        "distance_nm": o.distance_nm,
        "time_in_band_h": o.time_in_band_h,
        "time_slowed_h": o.time_slowed_h,
        "time_band_met_h": o.time_band_met_h,
        "eta": "" if o.eta is None else units.format_utc(o.eta),
        "eta_met": "" if o.eta_met is None else str(o.eta_met),
        "n_replans": o.n_replans,
        "earliest_arrival": "" if o.earliest_arrival is None else units.format_utc(o.earliest_arrival),
    }
