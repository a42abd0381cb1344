"""The typhoon-avoidance patent's dynamic artificial potential field (APF), sailed through the weather: a baseline.

The Chinese typhoon-avoidance route patent (dynamic artificial potential field) sails the planned
route (here the great circle to the destination) until its trigger holds — DCPA ≤ R and the
centre within the safe distance R + 30 km (:func:`optroute.geo.encounter.patent_trigger`) — then
keeps its speed and steers by the potential field until it is behind the typhoon and its heading
has settled, and then sails a new shortest route (the great circle) from there to the destination
([0076]–[0087], [0123]–[0131]).

The field ([0099]–[0121]; the formulas are figures the text we hold does not carry, so they are
written here in the form the text describes, the dynamic APF of Ge and Cui (2002)):

* attraction U_att = ½ k_a d(X_R, X_G)², force F_att = k_a (X_G − X_R);
* repulsion by position, acting within the influence range d_n of the circle:
  U_repX = ½ η_X (1/ρ − 1/d_n)², ρ = d(X_R, X_O) − R the distance to the circle, force
  F_repX = η_X (1/ρ − 1/d_n) / ρ² along the line from the centre to the ship;
* repulsion by relative velocity, while the ship closes on the centre (V_RO = (V_R − V_O)·e_RO > 0)
  within d_n: U_repV = η_V V_RO, force F_repV = −∇_V U_repV = −η_V e_RO (away from the centre).

Gains k_a = 10, η_X = 10, η_V = 12 as the patent ([0139]).  The gains are dimensional; the patent
plots and steps in degrees, so positions here are in degrees of latitude on the ship's local plane
(60 nm), a choice without which the published gains do nothing (in km the attraction outweighs the
repulsion by orders of magnitude).

The influence range d_n.  [0104] says d_n "is the R + 30 km safe distance set in the model" and
that the ship avoids "only when d(X_R, X_O, R) ≤ d_n", d being the distance to the circle (centre
distance minus R, [0112]); [0113] (c) calls it "the safe distance between the ship and the wind
circle"; the trigger ([0084], [0124]) fires when the *centre* is within R + 30 km.  The text is
not consistent, and the two readings differ by an order of magnitude:

* ``d_n_km=None`` (default): the number [0104] states, d_n = R + margin (R + 30 km) on ρ.  At the
  trigger (ρ = 30 km) the repulsion already acts, so the ship turns away on the circle R + 30 km;
* ``d_n_km=30``: the margin alone (ρ ≤ 30 km, the trigger's own circle), our first reconstruction.
  The repulsion is zero at the trigger and grows only as the ship sails into R + 30 km, so the
  track enters R + 30 km by design and, where the typhoon outruns the turn, R itself.

On the 14 synthetic crossings of ``bench_cyclone``'s suite (1° weather) the first reading spends
0–1.7 h inside R + 30 km on 11 of them, where the second spent 0–37 h (2.8–37 h on the 10 where
it triggered); on the antimeridian crossing (a 17.9 kn typhoon, the ship at 14 kn) 9.9 h, outside R
(the second: 14.2 h, 3.4 h inside R); on the overtaking crossing with a 24.5 kn typhoon both spend
13.3 h inside R, where no heading at the kept 12.5 kn can keep out
(:func:`optroute.geo.encounter.best_closest_approach`); on the 13th (a typhoon on the route) the first
reading steers onto a heading where no speed down to 3 kn is allowed (NoSafePassage), which the second
did not.  Both readings dip into R + 30 km:
the trigger fires on that circle with the centre closing, and the field's heading is the sum of the
attraction to the destination and the repulsion, not the heading that opens the distance fastest.

The ship holds its speed through the water (the patent: "keep speed, change course") with Boeing's
speed reduction (:func:`optroute.physics.passage.best_speed`) where the weather does not allow it
(power above MCR, a danger band): the same physics functions as the referee, which then evaluates
the sailed track (:meth:`optroute.plan.result.Plan.from_schedule`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError, NoSafePassage
from optroute.geo.encounter import encounter, local_xy_nm, patent_trigger
from optroute.geo.tracks import Exclusion
from optroute.physics.passage import best_speed
from optroute.physics.performance import PerformanceModel, default_model
from optroute.physics.safety import BandRules
from optroute.physics.ship import Ship
from optroute.plan.evaluate import sample_sea
from optroute.plan.result import Plan
from optroute.units import as_utc_time as _as_time
from optroute.units import h_to_timedelta as _h_to_td
from optroute.weather.cyclone_tracks import CycloneTrack
from optroute.weather.sample import WeatherSampler

__all__ = ["APFGains", "AvoidanceRun", "apf_avoidance", "sail_track"]

KM_PER_DEG = 60.0 * 1.852


@dataclass(frozen=True)
class APFGains:
    """Gains of the patent's dynamic APF ([0139]) and its influence range d_n ([0104]).

    Attributes
    ----------
    k_a, eta_x, eta_v : float
        Attraction, position-repulsion and velocity-repulsion gains (the patent: 10, 10, 12).
    d_n_km : float or None
        Influence range beyond the circle R [km]; None (default): the safe distance R + margin,
        as [0104] states it (see the module docstring for the two readings).
    """

    k_a: float = 10.0
    eta_x: float = 10.0
    eta_v: float = 12.0
    d_n_km: float | None = None

    def __post_init__(self) -> None:
        for name in ("k_a", "eta_x", "eta_v"):
            finite(name, getattr(self, name), minimum=0.0, strict=True, error=ConfigError)
        if self.d_n_km is not None:
            finite("d_n_km", self.d_n_km, minimum=0.0, strict=True, error=ConfigError)

    def d_n_deg(self, r7_km: float, margin_km: float) -> float:
        """The influence range on the distance to the circle [deg of latitude]: R + margin, or ``d_n_km``."""
        d_n = float(r7_km) + float(margin_km) if self.d_n_km is None else float(self.d_n_km)
        return d_n / KM_PER_DEG


@dataclass(frozen=True)
class AvoidanceRun:
    """A track sailed by a steering rule, evaluated by the referee.

    Attributes
    ----------
    plan : Plan
        The sailed track as a plan (waypoints every step, the speed sailed on each): its fuel,
        times and :meth:`~optroute.plan.result.Plan.verify` are the referee's.
    phase : ndarray of str
        Per waypoint: ``"planned"``, ``"avoid"`` (APF) or ``"resumed"``.
    distance_km, r7_km : ndarray
        Distance to the centre and the force-7 radius R at each waypoint at the plan's times [km].
    trigger_time, resume_time : numpy.datetime64 or None
        When the APF started and when the ship resumed (None when it never did).
    """

    plan: Plan
    phase: np.ndarray
    distance_km: np.ndarray
    r7_km: np.ndarray
    trigger_time: np.datetime64 | None
    resume_time: np.datetime64 | None

    @property
    def closest_km(self) -> float:
        """Closest approach to the circle R: min(distance − R) over the waypoints [km]."""
        return float(np.min(self.distance_km - self.r7_km))

    def hours_inside(self, extra_km: float = 0.0) -> float:
        """Hours spent inside R + ``extra_km`` (waypoint sampling, each leg's duration to its start)."""
        inside = (self.distance_km - self.r7_km < extra_km)[:-1]
        return float(np.sum(np.diff(self.plan.times) / np.timedelta64(1, "h") * inside))


def _goal_vector_deg(lat: float, lon: float, goal: tuple[float, float]) -> np.ndarray:
    d = float(geo.distance_nm(lat, lon, *goal)) / 60.0
    b = np.radians(float(geo.initial_course_deg(lat, lon, *goal)))
    return d * np.array([np.sin(b), np.cos(b)])


def _apf_heading(
    lat: float, lon: float, v_ship_kn: np.ndarray, goal: tuple[float, float], st: dict, gains: APFGains,
    margin_km: float,
) -> float:  # fmt: skip
    """Direction of the total force F_att + F_repX + F_repV [deg true]."""
    force = gains.k_a * _goal_vector_deg(lat, lon, goal)
    rel = local_xy_nm(lat, lon, st["lat"], st["lon"]) / 60.0  # centre − ship [deg]
    dist = float(np.hypot(*rel))
    e_ro = rel / dist if dist > 0 else np.array([0.0, 1.0])
    rho = dist - float(st["r7_km"]) / KM_PER_DEG
    d_n = gains.d_n_deg(float(st["r7_km"]), margin_km)
    if rho <= d_n:
        rho = max(rho, 1e-6)
        force = force - gains.eta_x * (1.0 / rho - 1.0 / d_n) / rho**2 * e_ro
        v_ro = float(np.dot(v_ship_kn - np.array([st["u_kn"], st["v_kn"]], dtype=float), e_ro))
        if v_ro > 0:
            force = force - gains.eta_v * e_ro
    return float(units.wrap_360(np.degrees(np.arctan2(force[0], force[1]))))


def _behind(lat: float, lon: float, st: dict) -> bool:
    """The ship is behind the typhoon: on the rear side of the line through the centre across its motion."""
    v = np.array([st["u_kn"], st["v_kn"]], dtype=float)
    rel = -local_xy_nm(lat, lon, st["lat"], st["lon"])  # ship − centre
    return bool(np.dot(rel, v) < 0) if np.hypot(*v) > 0 else True


def sail_track(
    start: tuple[float, float],
    end: tuple[float, float],
    weather: xr.Dataset | WeatherSampler,
    ship: Ship,
    *,
    departure: Any,
    speed_kn: float,
    track: CycloneTrack | None = None,
    avoid: bool = True,
    margin_km: float = 30.0,
    gains: APFGains | None = None,
    step_h: float = 0.25,
    arrive_nm: float = 5.0,
    max_hours: float | None = None,
    settle_deg: float = 5.0,
    min_speed_kn: float = 3.0,
    model: PerformanceModel | None = None,
    rules: BandRules | None = None,
    use_land_mask: bool | None = None,
) -> AvoidanceRun:
    """Sail from ``start`` to ``end`` at ``speed_kn`` (Boeing speed reduction where not allowed), by the patent's rule.

    With ``avoid`` False the ship holds the great circle to ``end`` whatever the cyclone (the naive
    track: it slows where the weather forces it).  With ``avoid`` the patent's APF takes over on its
    trigger and hands back on resumption (see the module docstring).

    Raises
    ------
    NoSafePassage
        Where no speed down to ``min_speed_kn`` is allowed on the heading steered (the message
        names the time and position).
    """
    g = gains if gains is not None else APFGains()
    t0 = _as_time(departure, "departure")
    v = float(finite("speed_kn", speed_kn, minimum=0.0, strict=True, error=ConfigError))
    dt = float(finite("step_h", step_h, minimum=0.0, strict=True, error=ConfigError))
    sampler = weather if isinstance(weather, WeatherSampler) else WeatherSampler(weather)
    model = model if model is not None else default_model(ship)
    rules = rules if rules is not None else BandRules()
    limit = float(max_hours) if max_hours is not None else 3.0 * float(geo.distance_nm(*start, *end)) / v
    lat, lon, h = float(start[0]), float(start[1]), 0.0
    pts, stws, phases = [(lat, lon)], [], ["planned"]
    mode, trig, resume, v_ship = "planned", None, None, np.zeros(2)
    last_heading: list[float] = []
    while float(geo.distance_nm(lat, lon, *end)) > arrive_nm:
        if h > limit:
            raise NoSafePassage(f"the ship did not arrive within {limit:.0f} h; raise max_hours or check the track")
        when = t0 + _h_to_td(h)
        st = track.at(when) if track is not None else None
        course = float(geo.initial_course_deg(lat, lon, *end))
        if avoid and st is not None and bool(track.covers(when)):
            enc = encounter(lat, lon, np.hypot(*v_ship), np.degrees(np.arctan2(*v_ship)), when, track)
            if mode != "avoid" and patent_trigger(enc.dcpa_km, enc.distance_km, enc.r7_km, margin_km):
                mode, trig = "avoid", trig if trig is not None else when
            if mode == "avoid":
                course = _apf_heading(lat, lon, v_ship, end, st, g, margin_km)
                last_heading = (last_heading + [course])[-int(round(1.0 / dt)) - 1 :]
                settled = len(last_heading) > 1 and np.ptp(np.unwrap(np.radians(last_heading))) <= np.radians(
                    settle_deg
                )
                if settled and _behind(lat, lon, st) and float(enc.distance_km) > float(enc.r7_km) + margin_km:
                    mode, resume = "resumed", when
                    course = float(geo.initial_course_deg(lat, lon, *end))
        sea, covered = sample_sea(sampler, np.array([when]), np.array([lat]), np.array([lon]))
        choice = best_speed(ship, model, rules, np.array([course]), sea, v, step_kn=0.5, min_stw_kn=min_speed_kn)
        if not (covered[0] and choice.feasible[0] and choice.sog_kn[0] > 0):
            raise NoSafePassage(
                f"no speed down to {min_speed_kn} kn is allowed at ({lat:.2f}, {lon:.2f}) on {units.format_utc(when)} "
                f"heading {course:.0f}°; the {'APF' if mode == 'avoid' else 'great-circle'} track cannot be sailed there"
            )
        sog = float(choice.sog_kn[0])
        step_nm = min(sog * dt, float(geo.distance_nm(lat, lon, *end)))
        nlat, nlon = geo.destination(lat, lon, course, step_nm)
        v_ship = sog * np.array([np.sin(np.radians(course)), np.cos(np.radians(course))])
        lat, lon, h = float(nlat), float(nlon), h + step_nm / sog
        pts.append((lat, lon))
        stws.append(float(choice.stw_kn[0]))
        phases.append(mode)
    pts[-1] = (float(end[0]), float(end[1]))
    exclusion = None if track is None else Exclusion.from_track(track, margin_km=0.0, cone_km_per_h=0.0)
    plan = Plan.from_schedule(
        np.array(pts), np.array(stws), departure=t0, ship=ship, weather=sampler, model=model, rules=rules,
        exclusion=exclusion, use_land_mask=use_land_mask, status="simulated", solver_stats={"rule": "apf" if avoid else "great circle"},
    )  # fmt: skip
    return _run(plan, np.array(phases), track, trig, resume)


def _run(plan: Plan, phase: np.ndarray, track: CycloneTrack | None, trig, resume) -> AvoidanceRun:
    wp = plan.waypoints
    if track is None:
        dist = np.full(wp.shape[0], np.inf)
        r7 = np.zeros(wp.shape[0])
    else:
        s = track.at(plan.times)
        dist = np.asarray(geo.distance_nm(wp[:, 0], wp[:, 1], s["lat"], s["lon"])) * 1.852
        r7 = s["r7_km"]
    return AvoidanceRun(plan, phase, dist, r7, trig, resume)


def apf_avoidance(
    start: tuple[float, float],
    end: tuple[float, float],
    weather: xr.Dataset | WeatherSampler,
    ship: Ship,
    track: CycloneTrack,
    *,
    departure: Any,
    speed_kn: float | None = None,
    margin_km: float = 30.0,
    gains: APFGains | None = None,
    **kwargs: Any,
) -> AvoidanceRun:
    """The typhoon-avoidance patent's dynamic APF route from ``start`` to ``end`` around ``track``'s cyclone.

    Parameters
    ----------
    start, end : (float, float)
        (lat, lon) [deg].
    weather : xarray.Dataset or WeatherSampler
        The weather sailed through (the cyclone's wind and sea included).
    ship : Ship
    track : CycloneTrack
        The cyclone (:func:`optroute.weather.cyclone_tracks.read_track`).
    departure : datetime64 or str
        [UTC].
    speed_kn : float, optional
        Speed through the water held [kn]; default the ship's design speed.
    margin_km : float
        Safe distance beyond R [km] (the patent: 30): the trigger's circle R + margin and, unless
        ``gains`` says otherwise, the APF's influence range d_n = R + margin ([0104]).
    gains : APFGains, optional
        Default k_a = 10, η_X = 10, η_V = 12, d_n = R + ``margin_km``.
    **kwargs
        Of :func:`sail_track` (``step_h``, ``model``, ``rules``, ...).

    Returns
    -------
    AvoidanceRun
        The APF track; its plan's exclusion is the circle R (the APF's own limit), so
        ``run.plan.verify()`` reports any entry into R.
    """
    g = gains if gains is not None else APFGains()
    v = float(speed_kn) if speed_kn is not None else float(ship.design_speed_kn)
    return sail_track(
        start, end, weather, ship, departure=departure, speed_kn=v, track=track, avoid=True, margin_km=margin_km,
        gains=g, **kwargs,
    )  # fmt: skip
