"""A schedule sailed through the weather with the true ship model: the dense evaluation behind :class:`~optroute.plan.result.Plan`.

:func:`evaluate_track` puts the ship on every leg's geodesic, cut into pieces, at the time the
schedule has it there; samples the weather there (:class:`~optroute.weather.WeatherSampler`);
crabs the heading against the current and takes the true model's power and fuel
(:func:`optroute.physics.passage.evaluate_speeds`). :func:`legs_table` turns that into the per-leg
table of a plan; :meth:`optroute.plan.result.Plan.verify` checks every constraint on it. Nothing
here uses the NLP or its power table (which is built from the same model through the same
:func:`optroute.physics.passage.power_at_heading`).

**The fuel and time integrals and their error.** A leg's fuel is ``∫ q(s) ds`` and its time
``∫ 1/SOG(s) ds`` along its length, ``q`` = fuel rate / SOG [t/nm], each by the midpoint rule on
pieces that start at most ``step_nm`` long and are cut adaptively (down to
:data:`MIN_PIECE_NM`, and about a large jump further):

* where the integrand is smooth, a piece's midpoint error is 4/3 of the difference between its
  midpoint value and the mean of its two quarter points (the midpoint rule's error grows as the
  cube of the piece's length: Richardson extrapolation); a piece is halved while that exceeds its
  share (its length / the leg's) of :data:`FUEL_RTOL` times the leg's fuel or time, so the smooth
  part of a leg's fuel is within :data:`FUEL_RTOL` of its integral;
* the integrand jumps where the model's regime changes (Kwon 2008 takes the Beaufort number as an
  integer and the direction coefficient by sector: :func:`optroute.physics.passage.power_regime`;
  a cyclone's sharp wind field changes it every few nm) or the sea stops being navigable. Where the
  regime differs between two consecutive samples (the leg's ends, the pieces' quarter points and
  midpoints) the pieces around them are halved down to :data:`REGIME_TOL_NM` whatever the jump of
  ``q`` between the two (a third regime may lie between them); down to :data:`MIN_PIECE_NM` where the
  jump exceeds :data:`FUEL_RTOL` times the leg's mean; and further (down to
  :data:`MIN_JUMP_PIECE_NM`) while half the piece times the jump exceeds :data:`JUMP_SHARE` of the
  leg's tolerance: a bisection of the jump, each piece then off by at most half its length times
  the jump. A piece with a change to locate far below its length is cut in eight at once;
* between two samples of one regime the regime may still change and change back (a stretch of a
  higher Beaufort number a few hundred metres long, between the quarter points of a piece): the
  distances of Kwon's two drivers (wind speed or Hs, wave angle) to their nearest edges
  (:func:`optroute.physics.passage.regime_distances`) are certified positive over every stretch
  longer than :data:`REGIME_TOL_NM` by the referee's Lipschitz rule
  (:func:`optroute.search.band_refine.certified`, as :mod:`optroute.plan.checkpoints` checks the
  engine's range), and the pieces around an interval that is not are halved.

* an excursion that no sample sees (shorter than :data:`REGIME_TOL_NM` between two samples of one
  regime, or, across a change, a second driver crossing too: a third regime between the two) is
  bounded instead: its longest possible length by the same Lipschitz rule
  (:func:`optroute.search.band_refine.excursion_lengths`) times the largest jump of ``q`` into a regime
  neither sample is in (the model evaluated with each driver just across its nearest edge). The pieces
  about one whose bound exceeds :data:`JUMP_SHARE` of the leg's tolerance are cut until it does not.

The estimate of a leg's error (the Richardson terms, the seen jumps' terms and the unseen excursions'
bounds) is :attr:`DenseTrack.fuel_err_t`; ``tests/test_fuel_integration.py`` compares both with an
independent brute force (every 0.01 nm, finer across jumps) on random legs through a cyclone. An
excursion the slope bound underestimates can still be missed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
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
from optroute.physics.passage import (
    SeaState,
    across_regime_edges,
    evaluate_speeds,
    power_regime,
    regime_distances,
)
from optroute.physics.performance import PerformanceModel
from optroute.physics.safety import BANDS, BandRules, band_margins
from optroute.physics.ship import Ship
from optroute.search.band_refine import BAND_TOL_NM, excursion_lengths, regime_doubts
from optroute.search.route import Corridor
from optroute.units import as_utc_time as _as_time
from optroute.units import h_to_timedelta as _h_to_td
from optroute.units import timedelta_to_h as _td_to_h
from optroute.weather.sample import WeatherSampler
from optroute.weather.schema import VARIABLES

__all__ = [
    "FUEL_RTOL",
    "JUMP_SHARE",
    "MIN_JUMP_PIECE_NM",
    "MIN_PIECE_NM",
    "REGIME_TOL_NM",
    "DenseTrack",
    "PlanContext",
    "Violation",
    "dense_points",
    "evaluate_track",
    "legs_table",
    "sample_sea",
]

_SEA_VARS = tuple(VARIABLES)  # every canonical weather variable

FUEL_RTOL = 1e-3
"""Relative tolerance of every leg's fuel and time integrals where the integrand is smooth [-]."""
MIN_PIECE_NM = 0.02
"""Shortest piece of the fuel integration where the integrand is smooth or jumps by more than the tolerance [nm]."""
MIN_JUMP_PIECE_NM = 1e-4
"""Shortest piece about a seen jump of the fuel rate [nm]: the jump costs at most half of it times the jump."""
JUMP_SHARE = 0.1
"""A seen jump is located until its piece's error is at most this share of the leg's tolerance [-]."""
REGIME_TOL_NM = BAND_TOL_NM
"""A change of the model's regime, or an excursion into another regime between samples, is located to this [nm]:
the referee's tolerance for a band or the engine's range (:mod:`optroute.plan.checkpoints`)."""
_EAGER_PARTS = 8
"""Parts a piece is cut into at once where a regime change is to be located far below its length."""
_MAX_PARTS = 64
"""Most parts a piece is cut into at once where an unseen excursion's bound is far above its share."""


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
        return land.coastline_applies(self.dataset, self.use_land_mask)


# --------------------------------------------------------------------------- dense evaluation


@dataclass(frozen=True)
class DenseTrack:
    """Points along every leg: the piece midpoints (weight = piece length) and the leg ends (weight 0).

    ``fuel_err_t`` is the estimate of every leg's fuel integration error [t] (module text) and ``rtol``
    the relative tolerance it was integrated to; None and NaN where not computed.
    """

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
    fuel_err_t: np.ndarray | None = None
    rtol: float = float("nan")


def dense_points(waypoints: np.ndarray, step_nm: float) -> tuple[np.ndarray, ...]:
    """Leg ends and the midpoints of every leg cut into equal pieces of at most ``step_nm`` [nm] (the referee's
    first pieces, before :func:`evaluate_track` halves them): (leg, fraction, piece length [nm], lat, lon,
    course, leg lengths [nm])."""
    wp = np.asarray(waypoints, dtype=float)
    d = geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
    return (*_piece_points(wp, d, _uniform_pieces(d, float(step_nm))), d)


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


def _uniform_pieces(d_nm: np.ndarray, step_nm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every leg cut into equal pieces of at most ``step_nm``: (leg, start fraction, end fraction)."""
    m = np.maximum(1, np.ceil(d_nm / step_nm - 1e-9)).astype(np.int64)
    leg = np.repeat(np.arange(d_nm.size), m)
    j = np.arange(leg.size) - np.repeat(np.concatenate([[0], np.cumsum(m)[:-1]]), m)
    return leg, j / m[leg], (j + 1) / m[leg]


def step_midpoints(d_nm: np.ndarray, step_nm: float) -> tuple[np.ndarray, np.ndarray]:
    """(leg, fraction) of the midpoints of every leg cut into equal pieces of at most ``step_nm``, leg ends included.

    The first check points of :meth:`~optroute.plan.result.Plan.verify` besides its even spacing
    (:func:`optroute.plan.checkpoints.check_points`): fixed by ``step_nm``, not by where the fuel
    integration halved its pieces.
    """
    leg, a, b = _uniform_pieces(np.asarray(d_nm, dtype=float), float(step_nm))
    n = np.asarray(d_nm).size
    return np.concatenate([np.arange(n), leg, np.arange(n)]), np.concatenate([np.zeros(n), 0.5 * (a + b), np.ones(n)])


def _piece_points(waypoints: np.ndarray, d_nm: np.ndarray, pieces: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
    """Leg ends (length 0) and piece midpoints (length = the piece's [nm]), sorted by (leg, fraction)."""
    pleg, a, b = pieces
    n = d_nm.size
    leg = np.concatenate([np.arange(n), pleg, np.arange(n)])
    frac = np.concatenate([np.zeros(n), 0.5 * (a + b), np.ones(n)])
    length = np.concatenate([np.zeros(n), (b - a) * d_nm[pleg], np.zeros(n)])
    order = np.lexsort((frac, leg))
    leg, frac, length = leg[order], frac[order], length[order]
    lat, lon, course = gc_points(
        waypoints[leg, 0], waypoints[leg, 1], waypoints[leg + 1, 0], waypoints[leg + 1, 1], frac
    )
    return leg, frac, length, lat, lon, course


def evaluate_track(
    ctx: PlanContext,
    waypoints: np.ndarray,
    stw_kn: np.ndarray,
    departure: np.datetime64,
    times_h: np.ndarray | None,
    step_nm: float,
    iterations: int = 3,
    rtol: float = FUEL_RTOL,
) -> DenseTrack:
    """Sea, heading, SOG, power and fuel at the midpoints of adaptive pieces, at the times the ship is there.

    Every leg starts as pieces of at most ``step_nm``; a piece is halved (down to
    :data:`MIN_PIECE_NM`) where its fuel or time is not yet integrated to ``rtol`` or the model's
    power regime changes across it (:func:`_refine`; the error bound is in the module text), and the
    final pieces are evaluated again.

    ``times_h`` (waypoint times [h since departure]) fixes the schedule: inside each leg the
    duration is shared in proportion to the piece times at the planned speed. Without it the
    schedule is integrated from the piece times themselves (``Σ piece / SOG``). The piece times
    depend on the current at the time the ship is there, so the two are iterated to a fixed point.
    """
    wp = np.asarray(waypoints, dtype=float)
    stw = np.asarray(stw_kn, dtype=float)
    d = geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
    pieces = _uniform_pieces(d, float(step_nm))
    ev = _evaluate_pieces(ctx, wp, d, pieces, stw, departure, times_h, iterations)
    refined, err = _refine(ctx, wp, d, pieces, ev, departure, float(rtol))
    if refined[0].size != pieces[0].size:
        # the refined pieces start from the first pass's time per nm (not from "no current"), so that the fixed
        # point converges in as few iterations as the first pass did, also where a no-current guess would put
        # the last pieces past the weather's end
        ev = _evaluate_pieces(ctx, wp, d, refined, stw, departure, times_h, iterations, seed=ev)
    return replace(ev, fuel_err_t=err, rtol=float(rtol))


def _evaluate_pieces(ctx, wp, d, pieces, stw_kn, departure, times_h, iterations, seed=None) -> DenseTrack:
    """The fixed point of schedule and piece times on given pieces (:func:`evaluate_track`); ``seed``: an
    evaluation on other pieces whose time per nm is the first guess (else no current)."""
    leg, frac, length, lat, lon, course = _piece_points(wp, d, pieces)
    stw = stw_kn[leg]
    n = d.size
    dt = length / stw  # first guess: no current
    if seed is not None:
        offset = np.concatenate([[0.0], np.cumsum(d)])
        sm = seed.length_nm > 0
        h_per_nm = np.interp(offset[leg] + frac * d[leg], (offset[seed.leg] + seed.frac * d[seed.leg])[sm],
                             seed.dt_h[sm] / seed.length_nm[sm])  # fmt: skip
        dt = np.where(np.isfinite(h_per_nm) & (h_per_nm > 0), length * h_per_nm, dt)
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
    dur = np.bincount(leg, weights=dt, minlength=n)
    return DenseTrack(leg, frac, length, lat, lon, course, t_h, sea, covered, heading, sog, power, fuel, dt, dur, stw)


def _per_nm(ctx: PlanContext, course: np.ndarray, sea: SeaState, stw: np.ndarray) -> tuple[np.ndarray, ...]:
    """Fuel [t/nm] and time [h/nm] per distance sailed, the model's power regime and the distances of the
    regime's two drivers to their nearest edges (:func:`optroute.physics.passage.regime_distances`; +inf for
    a model that declares none), at points."""
    heading, sog, _, fuel, _ = evaluate_speeds(ctx.ship, ctx.model, ctx.rules, course, sea, stw)
    usable = np.isfinite(sog) & (sog > 0) & np.isfinite(heading)
    inv = np.where(usable, 1.0 / np.where(usable, sog, 1.0), np.inf)
    at = np.where(np.isfinite(heading), heading, course)
    dist = regime_distances(ctx.model, at, sea) or (np.full(course.shape, np.inf),) * 2
    return np.where(usable, fuel * inv, np.inf), inv, _regime(ctx, heading, at, sea), *dist


def _regime(ctx: PlanContext, heading: np.ndarray, at: np.ndarray, sea: SeaState) -> np.ndarray:
    """The model's power regime at the heading ``at`` [deg]; -2 where the course is not held (``heading`` NaN)."""
    return np.where(np.isfinite(heading), power_regime(ctx.model, at, sea), -2)


def _refine(ctx, wp, d, pieces, ev: DenseTrack, departure, rtol) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """The pieces cut until none is loose (:func:`_loose`), and every leg's fuel error estimate [t].

    The ship is at a point at the time of ``ev``'s schedule (linear in distance between its points). A loose
    piece is halved (its halves' midpoints are its quarter points: each round evaluates only the halves'
    quarter points), or cut into :data:`_EAGER_PARTS` where a regime change is to be located far below its
    length (one round instead of three; each round costs about as much however few its points).
    """
    offset = np.concatenate([[0.0], np.cumsum(d)])
    x_clock, t_clock = offset[ev.leg] + ev.frac * d[ev.leg], ev.time_h

    def locate(leg: np.ndarray, frac: np.ndarray) -> tuple[np.ndarray, SeaState, np.ndarray]:
        """The course [deg], the sea and the speed through water [kn] at fractions of legs, when the ship is there."""
        lat, lon, course = gc_points(wp[leg, 0], wp[leg, 1], wp[leg + 1, 0], wp[leg + 1, 1], frac)
        t_h = np.interp(offset[leg] + frac * d[leg], x_clock, t_clock)
        sea, _ = sample_sea(ctx.sampler, departure + _h_to_td(t_h), lat, lon)
        return course, sea, ev.stw[np.searchsorted(ev.leg, leg)]

    def probe(leg: np.ndarray, frac: np.ndarray) -> tuple[np.ndarray, ...]:
        return _per_nm(ctx, *locate(leg, frac))

    def samples(pleg, a, b, where=(0.25, 0.75)) -> list[np.ndarray]:
        """Every quantity of :func:`_per_nm` at the fractions ``where`` of each piece, one column each."""
        at = probe(np.tile(pleg, len(where)), np.concatenate([a + f * (b - a) for f in where]))
        return [x.reshape(len(where), -1).T for x in at]

    mid = ev.length_nm > 0
    ends = (ev.length_nm == 0) & (ev.frac <= 0.0), (ev.length_nm == 0) & (ev.frac >= 1.0)
    at_points = _per_nm(ctx, ev.course, ev.sea, ev.stw)
    end_vals = tuple(x[ends[0]] for x in at_points), tuple(x[ends[1]] for x in at_points)
    pleg, a, b = pieces
    # (fuel per nm, time per nm, regime, regime distances...) x (first quarter, middle, third quarter)
    vals = [np.column_stack([q[:, 0], x[mid], q[:, 1]]) for q, x in zip(samples(pleg, a, b), at_points, strict=True)]
    while True:
        halve, eager, err = _loose(pleg, a, b, d, vals, end_vals, rtol)
        cuts = np.where(eager, _EAGER_PARTS, 2)
        if not halve.any():
            # only then: what an excursion the samples cannot see may cost (model evaluations about every doubt)
            missed, cuts = _missed_excursions(ctx, locate, pleg, a, b, d, vals, end_vals, rtol)
            halve = cuts >= 2
            if not halve.any():
                return (pleg, a, b), err + missed
        c = 0.5 * (a + b)
        half, many = halve & (cuts == 2), halve & (cuts > 2)
        h_leg, h_a, h_b = pleg[half], a[half], b[half]
        nl = samples(np.concatenate([h_leg, h_leg]), np.concatenate([h_a, c[half]]), np.concatenate([c[half], h_b]))
        k = h_leg.size
        halves = [
            np.column_stack([q[:, 0], np.concatenate([v[half, 0], v[half, 2]]), q[:, 1]])
            for q, v in zip(nl, vals, strict=True)
        ]
        rep = np.repeat(np.flatnonzero(many), cuts[many])
        n_cut = cuts[rep]
        j = np.arange(rep.size) - np.repeat(np.cumsum(cuts[many]) - cuts[many], cuts[many])  # each part's rank
        m_leg = pleg[rep]
        m_a = a[rep] + (b[rep] - a[rep]) * j / n_cut
        m_b = np.where(j + 1 == n_cut, b[rep], a[rep] + (b[rep] - a[rep]) * (j + 1) / n_cut)
        parts = samples(m_leg, m_a, m_b, (0.25, 0.5, 0.75))
        leg = np.concatenate([pleg[~halve], h_leg, h_leg, m_leg])
        lo = np.concatenate([a[~halve], h_a, c[half], m_a])
        hi = np.concatenate([b[~halve], c[half], h_b, m_b])
        order = np.lexsort((lo, leg))
        pleg, a, b = leg[order], lo[order], hi[order]
        vals = [
            np.concatenate([v[~halve], hv[:k], hv[k:], pv])[order]
            for v, hv, pv in zip(vals, halves, parts, strict=True)
        ]


def _loose(pleg, a, b, d, vals, end_vals, rtol) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which pieces to cut, which of them in :data:`_EAGER_PARTS` rather than two, and every leg's fuel error
    estimate [t] (the module text's rule).

    ``pleg, a, b``: each piece's leg and its ends as fractions of the leg; ``vals``: fuel per nm, time per
    nm, regime and the regime distances at each piece's (first quarter, middle, third quarter);
    ``end_vals``: the same at every leg's start and end.
    """
    g, u, r = vals[:3]
    h = (b - a) * d[pleg]
    n = d.size
    with np.errstate(invalid="ignore"):
        fuel_err = 4.0 / 3.0 * np.abs(0.5 * (g[:, 0] + g[:, 2]) - g[:, 1]) * h  # Richardson: midpoint error ∝ h³
        time_err = 4.0 / 3.0 * np.abs(0.5 * (u[:, 0] + u[:, 2]) - u[:, 1]) * h
    fuel_leg = np.bincount(pleg, weights=h * g[:, 1], minlength=n)
    time_leg = np.bincount(pleg, weights=h * u[:, 1], minlength=n)
    share = h / np.where(d > 0, d, 1.0)[pleg]
    loose = (fuel_err > rtol * fuel_leg[pleg] * share) | (time_err > rtol * time_leg[pleg] * share)
    # a regime change between consecutive samples of a leg (its ends included): the integrand jumps there
    (g_start, r_start, *_), (g_stop, r_stop, *_) = end_vals
    jump = _jumps(pleg, r, g, g_start, r_start, g_stop, r_stop)
    err_piece = np.where(jump > 0, np.maximum(fuel_err, 0.5 * jump * h), fuel_err)
    err = np.bincount(pleg, weights=np.where(np.isfinite(err_piece), err_piece, 0.0), minlength=n)
    err = np.where(np.isfinite(fuel_leg), err, np.inf)
    navigable = np.isfinite(fuel_leg[pleg])
    # a jump is located further while its piece's share of the error exceeds JUMP_SHARE of the leg's tolerance
    pinned = (0.5 * jump * h > JUMP_SHARE * rtol * fuel_leg[pleg]) & (h >= 2.0 * MIN_JUMP_PIECE_NM)
    mean_g = fuel_leg / np.where(d > 0, d, 1.0)
    jumping = jump > rtol * mean_g[pleg]  # a smaller seen jump costs less than the tolerance over the whole leg
    # any regime change, or one that may happen and be undone between samples: located to REGIME_TOL_NM
    changing = _regime_changes(pleg, a, b, d, vals, end_vals) & (h >= 2.0 * REGIME_TOL_NM)
    halve = (((loose | jumping) & (h >= 2.0 * MIN_PIECE_NM)) | changing | pinned) & navigable
    # a change to locate far below the piece's length: cut it in _EAGER_PARTS at once
    eager = (
        (changing & (h >= 2.0 * _EAGER_PARTS * REGIME_TOL_NM))
        | (jumping & (h >= 2.0 * _EAGER_PARTS * MIN_PIECE_NM))
        | (pinned & (h >= 2.0 * _EAGER_PARTS * MIN_JUMP_PIECE_NM))
    )
    return halve, eager & halve, err


def _regime_changes(pleg, a, b, d, vals, end_vals) -> np.ndarray:
    """Per piece, whether the model's regime changes, or may change and change back, next to one of its samples.

    Between two samples (:func:`_sample_sequence`) of different regimes the change is to be located
    (whatever the jump of the fuel per nm: the regime may pass through a third one in between); between
    two of one regime, each distance of a regime driver to its nearest edge must be certified positive
    over every stretch longer than :data:`REGIME_TOL_NM`: the referee's rule for the engine's range,
    :func:`optroute.search.band_refine.regime_doubts`. A piece that owns an end of such an interval is flagged.
    """
    leg_s, s_nm, owner, seq = _sample_sequence(pleg, a, b, d, vals, end_vals)
    r = seq(2)  # where the course is not held or the sea not navigable (r < 0) the leg's fuel is infinite: not cut
    dists = [seq(k) for k in range(3, len(vals))]
    doubt = regime_doubts(leg_s[1:] == leg_s[:-1], r >= 0, r, dists, s_nm, REGIME_TOL_NM)
    out = np.zeros(pleg.size, dtype=bool)
    for side in (owner[:-1], owner[1:]):
        hit = doubt & (side >= 0)
        out[side[hit]] = True
    return out


def _sample_sequence(pleg, a, b, d, vals, end_vals):
    """Every leg's samples in sailing order: its start, each piece's quarter points and midpoint, its end.

    Returns each sample's leg, its distance along the leg [nm], the piece it belongs to (-1: a leg's end) and
    ``seq(k)``, the quantity ``k`` of ``vals`` (:func:`_per_nm`'s order) along the sequence.
    """
    p = pleg.size
    starts = np.flatnonzero(np.r_[True, pleg[1:] != pleg[:-1]])
    stops = np.r_[starts[1:], p] - 1
    pos = a[:, None] + np.array([0.25, 0.5, 0.75]) * (b - a)[:, None]
    n_s = 3 * p + 2 * starts.size
    group = np.searchsorted(starts, np.arange(p), "right") - 1  # each piece's leg, counted among the legs here
    slot = (3 * np.arange(p) + 2 * group + 1)[:, None] + np.arange(3)
    first_slot, last_slot = slot[starts, 0] - 1, slot[stops, 2] + 1
    leg_s = np.empty(n_s, dtype=pleg.dtype)
    s_nm = np.empty(n_s)
    owner = np.full(n_s, -1)
    leg_s[slot], s_nm[slot], owner[slot] = pleg[:, None], pos * d[pleg][:, None], np.arange(p)[:, None]
    leg_s[first_slot], s_nm[first_slot] = pleg[starts], 0.0
    leg_s[last_slot], s_nm[last_slot] = pleg[stops], d[pleg[stops]]

    def seq(k: int) -> np.ndarray:
        out = np.empty(n_s)
        out[slot] = vals[k]
        out[first_slot], out[last_slot] = end_vals[0][k][pleg[starts]], end_vals[1][k][pleg[stops]]
        return out

    return leg_s, s_nm, owner, seq


def _missed_excursions(ctx, locate, pleg, a, b, d, vals, end_vals, rtol) -> tuple[np.ndarray, np.ndarray]:
    """Every leg's bound on the fuel [t] of regime excursions too short for the samples to see (the module text),
    and in how many parts to cut each piece (0: none) because its share of it is too large.

    Between two samples a driver may cross its edge and come back (or, across a change of regime, a second driver
    cross too) over a stretch no longer than :func:`optroute.search.band_refine.excursion_lengths` allows; there the
    fuel per nm is another regime's than either sample's. Each such stretch costs at most its length times the
    largest jump of the fuel per nm, at the interval's two ends, into a regime that neither end is in (the model
    evaluated with each driver just across its nearest edge: :func:`optroute.physics.passage.across_regime_edges`).
    The pieces around an interval whose bound exceeds :data:`JUMP_SHARE` of the leg's tolerance are cut, down to
    :data:`MIN_JUMP_PIECE_NM` as about a seen jump, in twice as many parts as the excess (up to :data:`_MAX_PARTS`):
    the bound shrinks at least in proportion to the interval. A regime with no finite fuel (no speed the model can
    make there) adds nothing: the referee's check of the engine's range owns that, to the same tolerance.
    """
    leg_s, s_nm, owner, seq = _sample_sequence(pleg, a, b, d, vals, end_vals)
    r = seq(2)
    lengths = excursion_lengths(leg_s[1:] == leg_s[:-1], r >= 0, r, [seq(k) for k in range(3, len(vals))], s_nm)
    cuts = np.zeros(pleg.size, dtype=int)
    doubt = np.flatnonzero(np.any(np.array(lengths) > 0.0, axis=0)) if lengths else np.zeros(0, dtype=int)
    if doubt.size == 0:
        return np.zeros(d.size), cuts
    pts = np.unique(np.r_[doubt, doubt + 1])
    q = seq(0)[pts]  # the fuel per nm the refinement sampled there
    course, sea, stw = locate(leg_s[pts], s_nm[pts] / d[leg_s[pts]])  # the sea there, to move its drivers
    heading = evaluate_speeds(ctx.ship, ctx.model, ctx.rules, course, sea, stw)[0]
    at = np.where(np.isfinite(heading), heading, course)
    # every driver moved down and up at every point; the model evaluated (once, all together) where the regime moves
    moved = [m for pair in across_regime_edges(ctx.model, at, sea) for m in pair]
    r2 = np.array([_regime(ctx, heading, at, m) for m in moved])
    k, i = np.nonzero(r2 != r[pts])  # (row-major: grouped by the moved state, as concatenated below)
    q2 = np.full(r2.shape, np.nan)
    if k.size:
        fields = SeaState.__dataclass_fields__
        sel = SeaState(
            *(np.concatenate([np.asarray(getattr(m, f))[i[k == j]] for j, m in enumerate(moved)]) for f in fields)
        )
        q2[k, i] = _per_nm(ctx, course[i], sel, stw[i])[0]
    cost = np.zeros(doubt.size)
    ends = np.searchsorted(pts, doubt), np.searchsorted(pts, doubt + 1)  # each interval's two points among pts
    for j, length in enumerate(lengths):
        worst = np.zeros(doubt.size)
        for end in ends:
            for row in (2 * j, 2 * j + 1):
                with np.errstate(invalid="ignore"):  # (inf - inf: no fuel figure on either side)
                    jump = q2[row, end] - q[end]
                third = (r2[row, end] != r[doubt]) & (r2[row, end] != r[doubt + 1]) & np.isfinite(jump)
                worst = np.maximum(worst, np.where(third, np.abs(jump), 0.0))
        cost += length[doubt] * worst
    err = np.bincount(leg_s[doubt], weights=cost, minlength=d.size)
    fuel_leg = np.bincount(pleg, weights=(b - a) * d[pleg] * vals[0][:, 1], minlength=d.size)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = cost / (JUMP_SHARE * rtol * fuel_leg[leg_s[doubt]])
    # a stretch's bound shrinks at least as its piece does: cut each piece in enough parts at once
    want = np.where(share > 1.0, 2.0 ** np.ceil(np.log2(np.clip(2.0 * share, 2.0, _MAX_PARTS))), 0.0)
    for side in (owner[doubt], owner[doubt + 1]):
        np.maximum.at(cuts, side[side >= 0], want[side >= 0].astype(int))
    h = (b - a) * d[pleg]
    return err, np.where(h >= cuts * MIN_JUMP_PIECE_NM, cuts, np.where(h >= 2.0 * MIN_JUMP_PIECE_NM, 2, 0))


def _jumps(pleg, r, g, g_start, r_start, g_stop, r_stop) -> np.ndarray:
    """Per piece, the largest jump of the fuel per nm across a regime change seen at or next to it (0: none)."""
    first = np.r_[True, pleg[1:] != pleg[:-1]]
    last = np.r_[pleg[1:] != pleg[:-1], True]
    # each piece's samples with the previous sample in sailing order (the previous piece's third quarter, or the leg start)
    prev_r = np.where(first, r_start[pleg], np.roll(r[:, 2], 1))
    prev_g = np.where(first, g_start[pleg], np.roll(g[:, 2], 1))
    rr = np.column_stack([prev_r, r])
    gg = np.column_stack([prev_g, g])
    change = rr[:, 1:] != rr[:, :-1]
    with np.errstate(invalid="ignore"):
        dg = np.where(change, np.abs(gg[:, 1:] - gg[:, :-1]), 0.0)
    dg = np.where(change & ~np.isfinite(dg), np.inf, dg)
    out = dg[:, 1:].max(axis=1)  # inside the piece
    # a change between a piece and the previous one: both pieces
    out = np.maximum(out, dg[:, 0])
    nxt = np.r_[dg[1:, 0], 0.0]
    out = np.maximum(out, np.where(last, 0.0, nxt))
    stop_change = last & (r[:, 2] != r_stop[pleg])
    with np.errstate(invalid="ignore"):
        ds = np.abs(g_stop[pleg] - g[:, 2])
    return np.maximum(out, np.where(stop_change, np.where(np.isfinite(ds), ds, np.inf), 0.0))


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
