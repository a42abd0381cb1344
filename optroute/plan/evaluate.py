"""A schedule sailed through the weather with the true ship model: the dense evaluation behind :class:`~optroute.plan.result.Plan`.

:func:`evaluate_track` puts the ship on every leg's great circle, cut into pieces of at most
``step_nm``, at the time the schedule has it there; samples the weather there
(:class:`~optroute.weather.WeatherSampler`); crabs the heading against the current and takes the
true model's power and fuel (:func:`optroute.physics.passage.evaluate_speeds`). :func:`legs_table` turns that
into the per-leg table of a plan; :meth:`optroute.plan.result.Plan.verify` checks every constraint on it.
Nothing here uses the NLP or its power table (which is built from the same model through the same
:func:`optroute.physics.passage.power_at_heading`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from optroute import geodesy as geo
from optroute import units
from optroute.errors import ConfigError
from optroute.geo import land
from optroute.geo.tracks import Exclusion, gc_points
from optroute.physics import seaway
from optroute.physics.passage import SeaState, evaluate_speeds
from optroute.physics.performance import PerformanceModel
from optroute.physics.safety import BANDS, BandRules, band_margins
from optroute.physics.ship import Ship
from optroute.search.route import Corridor
from optroute.units import as_utc_time as _as_time
from optroute.units import h_to_timedelta as _h_to_td
from optroute.units import timedelta_to_h as _td_to_h
from optroute.weather.sample import WeatherSampler
from optroute.weather.schema import VARIABLES

__all__ = ["DenseTrack", "PlanContext", "Violation", "dense_points", "evaluate_track", "legs_table", "sample_sea"]

_SEA_VARS = tuple(VARIABLES)  # every canonical weather variable


# --------------------------------------------------------------------------- violations and context


@dataclass(frozen=True)
class Violation:
    """One broken constraint found by :meth:`Plan.verify` (the worst point of its kind on its leg).

    Attributes
    ----------
    kind : str
        ``"power_above_mcr"``, ``"power_below_min"``, ``"band:<name>"`` (a danger band of
        :data:`optroute.physics.safety.BANDS`), ``"land"``, ``"no_passage"`` (NaN weather: land, ice, a
        no-go area), ``"weather_coverage"``, ``"course"`` (the current does not let the ship hold
        the course at the planned speed), ``"corridor"``, ``"exclusion"``, ``"schedule"`` (the
        planned times cannot be sailed at the planned speeds), ``"eta"``.
    leg : int
        Leg index (0-based).
    position : (float, float)
        (lat, lon) [deg] of the worst point.
    time : numpy.datetime64
        When the ship is there [UTC].
    value, limit : float
        The offending value and its limit, in the unit of the kind: power [kW]; band ratio [-];
        distance outside the corridor or inside the exclusion [nm] against the allowed [nm];
        hours [h] for ``"eta"`` (arrival − ETA) and ``"schedule"`` (time error).
    """

    kind: str
    leg: int
    position: tuple[float, float]
    time: np.datetime64
    value: float
    limit: float

    def __str__(self) -> str:
        lat, lon = self.position
        return (
            f"{self.kind} on leg {self.leg} at ({lat:.4f}, {lon:.4f}) {units.format_utc(self.time)}: "
            f"{self.value:.6g} against the limit {self.limit:.6g}"
        )


@dataclass(frozen=True)
class PlanContext:
    """What :meth:`Plan.verify` checks a plan against: ship, models, rules, weather and requirements.

    Attributes
    ----------
    ship : Ship
    model : PerformanceModel
        The true performance model (power and fuel).
    rules : BandRules
        Danger-band rules.
    sampler : WeatherSampler
        The weather.
    dataset : xarray.Dataset or None
        The canonical dataset behind the sampler, when known (its ``attrs["geography"]`` decides
        whether the land mask applies by default).
    corridor : Corridor or None
        The corridor the plan must stay within (None: no corridor constraint).
    eta : numpy.datetime64 or None
        Required arrival [UTC].
    eta_mode : {"le", "eq"}
        Arrive no later than, or at, the ETA.
    exclusion : Exclusion or None
        A moving circle to stay out of.
    use_land_mask : bool or None
        Apply the real coastline (None: unless the weather declares synthetic geography).
    """

    ship: Ship
    model: PerformanceModel
    rules: BandRules
    sampler: WeatherSampler
    dataset: xr.Dataset | None = None
    corridor: Corridor | None = None
    eta: np.datetime64 | None = None
    eta_mode: str = "le"
    exclusion: Exclusion | None = None
    use_land_mask: bool | None = None

    def __post_init__(self) -> None:
        if self.eta_mode not in ("le", "eq"):
            raise ConfigError(f"eta_mode={self.eta_mode!r} is not known; use 'le' (arrive by) or 'eq' (arrive at)")
        if self.eta is not None:
            object.__setattr__(self, "eta", _as_time(self.eta, "eta"))

    @property
    def land_mask_applies(self) -> bool:
        """Whether the real coastline is checked."""
        if self.use_land_mask is not None:
            return bool(self.use_land_mask)
        return not (self.dataset is not None and self.dataset.attrs.get("geography") == land.SYNTHETIC_GEOGRAPHY)


# --------------------------------------------------------------------------- dense evaluation


@dataclass(frozen=True)
class DenseTrack:
    """Points along every leg: the piece midpoints (weight = piece length) and the leg ends (weight 0)."""

    leg: np.ndarray
    frac: np.ndarray
    length_nm: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    course: np.ndarray
    time_h: np.ndarray
    sea: SeaState
    covered: np.ndarray
    heading: np.ndarray
    sog: np.ndarray
    power: np.ndarray
    fuel_tph: np.ndarray
    dt_h: np.ndarray
    leg_duration_h: np.ndarray
    stw: np.ndarray


def dense_points(waypoints: np.ndarray, step_nm: float) -> tuple[np.ndarray, ...]:
    d = geo.distance_nm(waypoints[:-1, 0], waypoints[:-1, 1], waypoints[1:, 0], waypoints[1:, 1])
    legs, fracs, lens = [], [], []
    for k, dk in enumerate(d):
        m = max(1, int(math.ceil(dk / step_nm - 1e-9)))
        f = np.concatenate([[0.0], (np.arange(m) + 0.5) / m, [1.0]])
        legs.append(np.full(f.size, k))
        fracs.append(f)
        lens.append(np.concatenate([[0.0], np.full(m, dk / m), [0.0]]))
    leg = np.concatenate(legs)
    frac = np.concatenate(fracs)
    lat, lon, course = gc_points(
        waypoints[leg, 0], waypoints[leg, 1], waypoints[leg + 1, 0], waypoints[leg + 1, 1], frac
    )
    return leg, frac, np.concatenate(lens), lat, lon, course, d


def sample_sea(
    sampler: WeatherSampler, when: np.ndarray, lat: np.ndarray, lon: np.ndarray
) -> tuple[SeaState, np.ndarray]:
    names = [v for v in _SEA_VARS if v in sampler.variables]
    inside = sampler.covers(when, lat, lon)
    out = {v: np.full(lat.shape, np.nan) for v in names}
    if inside.any():
        got = sampler.sample(when[inside], lat[inside], lon[inside], variables=names)
        for v in names:
            out[v][inside] = got[v]
    return SeaState.from_sample(out), inside


def evaluate_track(
    ctx: PlanContext,
    waypoints: np.ndarray,
    stw_kn: np.ndarray,
    departure: np.datetime64,
    times_h: np.ndarray | None,
    step_nm: float,
    iterations: int = 3,
) -> DenseTrack:
    """Sea, heading, SOG, power and fuel at dense points at the times the ship is there.

    ``times_h`` (waypoint times [h since departure]) fixes the schedule: inside each leg the
    duration is shared in proportion to the piece times at the planned speed. Without it the
    schedule is integrated from the piece times themselves (``Σ piece / SOG``). The piece times
    depend on the current at the time the ship is there, so the two are iterated to a fixed point.
    """
    leg, frac, length, lat, lon, course, d = dense_points(waypoints, step_nm)
    stw = stw_kn[leg]
    n = d.size
    dt = length / stw  # first guess: no current
    for it in range(max(1, iterations)):
        dur_int = np.bincount(leg, weights=dt, minlength=n)
        sched = np.concatenate([[0.0], np.cumsum(dur_int)]) if times_h is None else times_h
        scale = np.diff(sched) / np.where(dur_int > 0, dur_int, 1.0)
        # elapsed time inside the leg up to each point (midpoints: half their own piece)
        before = np.cumsum(dt) - dt - np.concatenate([[0.0], np.cumsum(dur_int)])[leg]
        elapsed = np.where(frac >= 1.0, dur_int[leg], before + 0.5 * dt)
        elapsed = np.where(frac <= 0.0, 0.0, elapsed)
        t_h = sched[leg] + elapsed * scale[leg]
        when = departure + _h_to_td(t_h)
        sea, covered = sample_sea(ctx.sampler, when, lat, lon)
        heading, sog, power, fuel, _ = evaluate_speeds(ctx.ship, ctx.model, ctx.rules, course, sea, stw)
        usable = np.isfinite(sog) & (sog > 0)
        new_dt = np.where(length > 0, length / np.where(usable, sog, stw), 0.0)
        converged = np.allclose(new_dt, dt, rtol=1e-12, atol=1e-12)
        dt = new_dt
        if converged or it == max(1, iterations) - 1:
            break
    return DenseTrack(
        leg,
        frac,
        length,
        lat,
        lon,
        course,
        t_h,
        sea,
        covered,
        heading,
        sog,
        power,
        fuel,
        dt,
        np.bincount(leg, weights=dt, minlength=n),
        stw,
    )


def _circular_mean_deg(angle_deg: np.ndarray, weights: np.ndarray, leg: np.ndarray, n: int) -> np.ndarray:
    r = np.radians(angle_deg)
    s = np.bincount(leg, weights=weights * np.sin(r), minlength=n)
    c = np.bincount(leg, weights=weights * np.cos(r), minlength=n)
    return units.wrap_360(np.degrees(np.arctan2(s, c)))


def legs_table(
    ctx: PlanContext, waypoints: np.ndarray, times: np.ndarray, ev: DenseTrack, d: np.ndarray
) -> pd.DataFrame:
    n = d.size
    w = ev.dt_h  # time weights (leg ends carry 0)
    wsum = np.bincount(ev.leg, weights=w, minlength=n)

    def wmean(x: np.ndarray) -> np.ndarray:
        x = np.where(np.isfinite(x), x, 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.bincount(ev.leg, weights=w * x, minlength=n) / wsum

    sea = ev.sea
    nav = sea.navigable
    hs = np.where(nav, sea.hs_m, np.nan)
    period = np.where(nav, sea.period_s, np.nan)
    heading = np.where(np.isfinite(ev.heading), ev.heading, ev.course)
    # a piece with no fuel figure (course not held, no sea state) makes its leg's fuel inf; leg ends weigh 0
    rate = np.where(np.isfinite(ev.fuel_tph), ev.fuel_tph, np.inf)
    fuel = np.bincount(ev.leg, weights=np.multiply(w, rate, out=np.zeros(w.shape), where=w > 0), minlength=n)
    power = wmean(ev.power)
    heading_leg = _circular_mean_deg(heading, w, ev.leg, n)
    wave_from = _circular_mean_deg(np.where(nav, sea.wave_from_deg, 0.0), w, ev.leg, n)
    hs_leg, per_leg = wmean(hs), wmean(period)
    stw = np.asarray(ev.stw[np.searchsorted(ev.leg, np.arange(n))], dtype=float)
    duration = np.diff(_td_to_h(times - times[0]))
    alpha = seaway.relative_wave_angle_deg(heading_leg, wave_from)
    te = seaway.encounter_period_s(np.where(per_leg > 0, per_leg, 1.0), stw, alpha, form=ctx.rules.period_form)
    cols: dict[str, Any] = {
        "lat": waypoints[:-1, 0],
        "lon": waypoints[:-1, 1],
        "time": times[:-1],
        "heading_deg": heading_leg,
        "sog_kn": d / duration,
        "stw_kn": stw,
        "distance_nm": d,
        "duration_h": duration,
        "power_kw": power,
        "fuel_t": fuel,
        "hs_m": hs_leg,
        "period_s": per_leg,
        "wave_from_deg": wave_from,
        "encounter_period_s": np.where(per_leg > 0, te, np.nan),
    }
    margins = band_margins(
        ctx.ship,
        speed_kn=ev.stw,
        hs_m=np.where(nav, sea.hs_m, 0.0),
        period_s=np.where(nav, sea.period_s, 1.0),
        wave_from_deg=np.where(nav, sea.wave_from_deg, 0.0),
        heading_deg=heading,
        rules=ctx.rules,
    )
    for band in BANDS:
        m = np.full(n, np.inf)
        np.minimum.at(m, ev.leg, np.asarray(margins[band].margin, dtype=float))
        cols[f"margin_{band}"] = m
    return pd.DataFrame(cols)
