"""Where the referee looks along a leg: points that sampling cannot fool (issue 14 item 1).

A plan's dense evaluation (:func:`optroute.plan.evaluate.evaluate_track`) samples every leg at the
midpoints of pieces of at most ``step_nm`` (5 nm): enough for fuel and time, not for the danger
bands. Near a storm's centre the wave direction swings through 180° within a few nm, and where Hs
climbs over the bands' threshold (Boeing EP 2145155: Hs >= 0.04 L) a speed can sit inside a band
for 1–3 nm between two midpoints. :func:`check_points` finds every such stretch longer than
:data:`BAND_TOL_NM`:

1. **Start**: every leg end, the dense evaluation's own points (``Plan.verify`` gives the
   midpoints of its equal ``step_nm`` pieces instead: ``nodes``) and points at most
   :data:`INITIAL_SPACING_NM` apart.
2. **Regime changes**: where the weather's interpolation cell changes along the track (a latitude
   row, a longitude column or a time slice of the data is crossed, at the time the ship is there;
   :meth:`optroute.weather.sample.WeatherSampler.grid_coordinates`) the crossing is located (secant on
   the grid coordinate) to :data:`CROSSING_TOL_NM` and both sides become check points: between them the sampled fields
   are one trilinear polynomial, smooth along the track.
3. **Adaptive refinement**: an interval between neighbouring check points (longer than the
   tolerance) is halved until it is *certified*: for every enabled band, either the band's ratio
   stays outside the band or Hs stays below the band's threshold over every stretch longer than the
   tolerance, by a Lipschitz bound. With end values ``m_a, m_b > 0`` of a function (the ratio's
   signed distance to the band, :func:`optroute.physics.safety.band_margins`; or the relative
   distance of Hs below the threshold) and a slope bound ``L``, a stretch of length ``w`` where the
   function is <= 0 needs ``m_a + m_b <= L (h − w)``, ``h`` the interval's length; so
   ``m_a + m_b > L (h − tol)`` rules out every stretch longer than ``tol``. ``L`` is
   :data:`SLOPE_SAFETY` times the largest secant slope of the interval and its two neighbours (a
   minimum inside the interval shows in its neighbours' slopes). An interval is halved regardless
   where the wave direction turns by more than :data:`TURN_DEG` across it (a storm's centre: the
   ratios can go and come back between the ends), where one end is navigable and the other not,
   or where a band's sector condition (IMO) holds at one end only. An interval with an end inside
   a band has already found it and is not halved.
4. **The engine's range** (:func:`engine_intervals_to_halve`): the same rule on the relative margins of
   the brake power to the MCR and to the minimum load, between changes of the model's power regime
   (Kwon 2008: the Beaufort number and the wave sector, where the power steps); an interval is halved
   regardless where the regime differs at its ends, or where it may change and change back inside
   (the distances of the Beaufort driver and of the wave angle to their edges, certified by the rule).

An interval no longer than the tolerance is never halved: a band stretch longer than it contains a
check point. So every band stretch (and every stretch out of the engine's range) longer than
:data:`BAND_TOL_NM` contains a check point, up to the slope bound's estimate (``tests/test_checkpoints.py`` compares with brute force at 0.01 nm); a
shorter one may or may not be found.  Steps 2 and 3 and their constants are
:mod:`optroute.search.band_refine`'s, shared with the route search, which checks its pieces by the
same rules.

The ship is at a check point at the time of the plan's own schedule: linear in distance between
the dense evaluation's points (whose times are the schedule's), so the check points and the
evaluation agree where they coincide. Everything is vectorised; the point physics is
:func:`optroute.physics.passage.evaluate_speeds` (the compiled one-point functions of
:mod:`optroute.physics.pointwise` for the built-in models), the model that scores the plan.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from optroute.errors import ConfigError
from optroute.geo.tracks import gc_points
from optroute.physics.passage import SeaState, evaluate_speeds, power_regime, regime_distances
from optroute.search.band_refine import (
    BAND_TOL_NM,
    CROSSING_TOL_NM,
    MAX_ROUNDS,
    SLOPE_SAFETY,
    TURN_DEG,
    band_functions,
    certified,
    crossing_nodes,
    intervals_to_halve,
    regime_doubts,
    secant_slopes,
)
from optroute.units import h_to_timedelta as _h_to_td

__all__ = [
    "BAND_TOL_NM",
    "CROSSING_TOL_NM",
    "INITIAL_SPACING_NM",
    "MAX_ROUNDS",
    "SLOPE_SAFETY",
    "TURN_DEG",
    "CheckPoints",
    "check_points",
    "engine_intervals_to_halve",
    "refined",
    "evaluate_at",
    "row_points",
    "track_clock",
]

INITIAL_SPACING_NM = 1.0
"""Longest spacing of the first check points along a leg [nm]."""

#: :attr:`CheckPoints.origin` codes: why a point is checked.
ORIGIN_SPACING, ORIGIN_END, ORIGIN_CROSSING, ORIGIN_REFINED = 0, 1, 2, 3


@dataclass(frozen=True)
class CheckPoints:
    """The points the referee checks, sorted by leg and distance along it, with the physics there.

    Attributes
    ----------
    leg : ndarray of int
        Leg index (0-based).
    s_nm : ndarray
        Distance along the leg from its first waypoint [nm].
    lat, lon, course : ndarray
        Position [deg] and the leg's great-circle course there [deg true, to].
    time_h : ndarray
        When the ship is there [h after departure] (the plan's schedule).
    sea : SeaState
        The weather there (NaN outside the data, on land, in ice).
    covered : ndarray of bool
        Inside the weather's area and time span.
    heading, sog, power, stw : ndarray
        Heading crabbed against the current [deg true] (NaN: course not held), SOG [kn], brake
        power [kW] and the leg's speed through the water [kn].
    tol_nm : float
        The tolerance the points were refined to [nm].
    rounds : int
        Halving rounds made.
    origin : ndarray of int8 or None
        Why each point is checked: :data:`ORIGIN_SPACING` (the even spacing and the dense evaluation's
        points), :data:`ORIGIN_END` (a leg end), :data:`ORIGIN_CROSSING` (a side of a weather-grid row,
        column or time-slice crossing), :data:`ORIGIN_REFINED` (added by the adaptive refinement);
        None where not recorded (:func:`evaluate_at` alone).
    """

    leg: np.ndarray
    s_nm: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    course: np.ndarray
    time_h: np.ndarray
    sea: SeaState
    covered: np.ndarray
    heading: np.ndarray
    sog: np.ndarray
    power: np.ndarray
    stw: np.ndarray
    tol_nm: float = BAND_TOL_NM
    rounds: int = 0
    origin: np.ndarray | None = None

    @property
    def size(self) -> int:
        """Number of points."""
        return int(self.leg.size)


def track_clock(leg: np.ndarray, frac: np.ndarray, time_h: np.ndarray, d_nm: np.ndarray) -> tuple[np.ndarray, ...]:
    """The schedule as (distance along the route [nm], time [h]) nodes, from a dense evaluation's points.

    Parameters
    ----------
    leg, frac, time_h : ndarray
        The points of :class:`~optroute.plan.evaluate.DenseTrack` (leg, fraction of the leg, time [h]),
        sorted by leg and fraction, leg ends included.
    d_nm : ndarray
        Leg lengths [nm].

    Returns
    -------
    (ndarray, ndarray)
        Nodes for :func:`numpy.interp`: the time at any point is linear in distance between them.
    """
    offset = np.concatenate([[0.0], np.cumsum(d_nm)])
    return offset[leg] + frac * d_nm[leg], np.asarray(time_h, dtype=float)


def _positions(waypoints: np.ndarray, d_nm: np.ndarray, clock: tuple, leg: np.ndarray, s_nm: np.ndarray):
    dk = d_nm[leg]
    frac = np.clip(np.divide(s_nm, dk, out=np.zeros(s_nm.shape), where=dk > 0), 0.0, 1.0)
    lat, lon, course = gc_points(
        waypoints[leg, 0], waypoints[leg, 1], waypoints[leg + 1, 0], waypoints[leg + 1, 1], frac
    )
    offset = np.concatenate([[0.0], np.cumsum(d_nm)])
    t_h = np.interp(offset[leg] + s_nm, clock[0], clock[1])
    return lat, lon, course, t_h


def evaluate_at(
    ctx, waypoints: np.ndarray, stw_kn: np.ndarray, departure: np.datetime64, d_nm: np.ndarray, clock: tuple,
    leg: np.ndarray, s_nm: np.ndarray,
) -> CheckPoints:  # fmt: skip
    """The physics at given along-leg distances, at the times of the plan's schedule (no refinement).

    Parameters
    ----------
    ctx : PlanContext
        Ship, model, rules and weather.
    waypoints : ndarray, shape (n, 2)
        (lat, lon) [deg].
    stw_kn : ndarray, shape (n - 1,)
        Leg speeds through the water [kn].
    departure : numpy.datetime64
        [UTC].
    d_nm : ndarray, shape (n - 1,)
        Leg lengths [nm].
    clock : (ndarray, ndarray)
        :func:`track_clock`.
    leg, s_nm : ndarray
        Leg index and distance along it [nm] of each point.
    """
    from optroute.plan.evaluate import sample_sea

    leg = np.asarray(leg, dtype=np.int64)
    s_nm = np.asarray(s_nm, dtype=float)
    lat, lon, course, t_h = _positions(waypoints, d_nm, clock, leg, s_nm)
    sea, covered = sample_sea(ctx.sampler, departure + _h_to_td(t_h), lat, lon)
    stw = np.asarray(stw_kn, dtype=float)[leg]
    heading, sog, power, _, _ = evaluate_speeds(ctx.ship, ctx.model, ctx.rules, course, sea, stw)
    return CheckPoints(leg, s_nm, lat, lon, course, t_h, sea, covered, heading, sog, power, stw)


def _concat(a: CheckPoints, b: CheckPoints) -> tuple[CheckPoints, np.ndarray]:
    """The points of both, sorted by (leg, distance), duplicates dropped; and which of ``a`` then ``b``'s points
    each is (indices into their concatenation)."""
    leg = np.concatenate([a.leg, b.leg])
    s = np.concatenate([a.s_nm, b.s_nm])
    order = np.lexsort((s, leg))
    keep = np.ones(order.size, dtype=bool)
    keep[1:] = (leg[order][1:] != leg[order][:-1]) | (s[order][1:] != s[order][:-1])
    idx = order[keep]

    def cat(x, y):
        return np.concatenate([x, y])[idx]

    sea = SeaState(**{f.name: cat(getattr(a.sea, f.name), getattr(b.sea, f.name)) for f in fields(SeaState)})
    out = {f.name: getattr(a, f.name) for f in fields(CheckPoints)}
    for name in ("leg", "s_nm", "lat", "lon", "course", "time_h", "covered", "heading", "sog", "power", "stw"):
        out[name] = cat(getattr(a, name), getattr(b, name))
    out["sea"] = sea
    if a.origin is not None and b.origin is not None:
        out["origin"] = cat(a.origin, b.origin)
    return CheckPoints(**out), idx


def _start_nodes(dense_leg: np.ndarray, dense_frac: np.ndarray, d_nm: np.ndarray, spacing_nm: float):
    """(leg, s) of the dense evaluation's points and an even grid at most ``spacing_nm`` apart on every leg."""
    m = np.maximum(1, np.ceil(d_nm / spacing_nm - 1e-9)).astype(np.int64)
    leg = np.repeat(np.arange(d_nm.size), m + 1)
    start = np.concatenate([[0], np.cumsum(m + 1)[:-1]])
    j = np.arange(leg.size) - np.repeat(start, m + 1)
    s = j / m[leg] * d_nm[leg]
    leg = np.concatenate([leg, dense_leg])
    s = np.concatenate([s, dense_frac * d_nm[dense_leg]])
    order = np.lexsort((s, leg))
    leg, s = leg[order], s[order]
    keep = np.ones(leg.size, dtype=bool)
    keep[1:] = (leg[1:] != leg[:-1]) | (s[1:] - s[:-1] > 1e-9)
    return leg[keep], s[keep]


def _crossings(ctx, waypoints, d_nm, clock, departure, leg, s, tol_nm):
    """Add both sides of every change of the weather's interpolation cell along the legs (:func:`crossing_nodes`)."""

    def coords(lg, ss):
        lat, lon, _, t_h = _positions(waypoints, d_nm, clock, lg, ss)
        return ctx.sampler.grid_coordinates(departure + _h_to_td(t_h), lat, lon)

    return crossing_nodes(leg, s, coords, tol_nm)


def _functions(ctx, pts: CheckPoints, power_rtol: float, rules) -> dict[str, np.ndarray]:
    """Per point, what the halving rules read: the bands' functions (:func:`band_functions`) and the engine's
    (:func:`_engine_functions`); computed once per point and carried through the rounds."""
    ok, wfrom, g, bands = band_functions(ctx.ship, rules, pts.sea, pts.covered, pts.heading, pts.course, pts.stw)
    out = {"ok": ok, "wfrom": wfrom, "g": g, **{"band:" + b: m for b, m in bands.items()}}
    out.update(_engine_functions(ctx, pts, power_rtol))
    return out


def _engine_functions(ctx, pts: CheckPoints, power_rtol: float) -> dict[str, np.ndarray]:
    """Per point: the power's relative margins to the MCR and the minimum load (``margin:*``), whether it is in
    range with the course held (``inside``), the model's power regime and the regime's driver distances (``dist:*``)."""
    held = np.isfinite(pts.heading)
    p = np.where(np.isfinite(pts.power), pts.power, np.nan)
    mcr, pmin = float(ctx.model.mcr_kw), float(ctx.model.min_power_kw)
    margins = [1.0 - p / (mcr * (1.0 + power_rtol))]
    if pmin > 0.0:
        margins.append(p / (pmin * (1.0 - power_rtol)) - 1.0)
    ok = pts.sea.navigable & pts.covered & held & np.isfinite(p)
    out = {f"margin:{j}": m for j, m in enumerate(margins)}
    out["inside"] = ok & np.all([m > 0.0 for m in margins], axis=0)
    heading = np.where(held, pts.heading, pts.course)
    out["regime"] = power_regime(ctx.model, heading, pts.sea).astype(float)
    out.update({f"dist:{j}": d for j, d in enumerate(regime_distances(ctx.model, heading, pts.sea))})
    return out


def _engine_intervals(leg: np.ndarray, s: np.ndarray, f: dict[str, np.ndarray], tol_nm: float) -> np.ndarray:
    """:func:`engine_intervals_to_halve` on the points' :func:`_engine_functions` ``f``."""
    same = leg[1:] == leg[:-1]
    h = s[1:] - s[:-1]
    inside = f["inside"]
    both = same & inside[:-1] & inside[1:]
    smooth = both & (f["regime"][1:] == f["regime"][:-1])
    dists = [m for key, m in f.items() if key.startswith("dist:")]
    need = regime_doubts(same, inside, f["regime"], dists, s, tol_nm)
    for key, m in f.items():
        if key.startswith("margin:"):
            need |= smooth & ~certified(m[:-1], m[1:], secant_slopes(m, s, smooth), h, tol_nm)
    return np.flatnonzero(need & (h > tol_nm))


def engine_intervals_to_halve(ctx, pts: CheckPoints, tol_nm: float, power_rtol: float = 0.0) -> np.ndarray:
    """Indices i of the intervals (i, i + 1) longer than ``tol_nm`` where the engine may leave its range unseen.

    The brake power at the leg's speed through the water must stay within [minimum load, MCR] (each
    widened by ``power_rtol``, as ``Plan.verify`` compares). Between two changes of the model's power
    regime (:func:`optroute.physics.passage.power_regime`: Kwon's Beaufort number and wave sector) the
    power is smooth along the track, and the relative margins to both limits are certified by the
    bands' Lipschitz rule (:func:`optroute.search.band_refine.certified`; slopes from intervals of one
    regime only, a jump being no slope). An interval is halved regardless where the regime differs at
    its ends (the jump is located to ``tol_nm``), or where the regime may change and change back inside
    it: the distances of Beaufort's driver and of the wave angle to their nearest edges
    (:func:`optroute.physics.passage.regime_distances`), certified by the same rule. An interval with an
    end out of range (or where the course is not held) has found its violation and is not halved.
    """
    return _engine_intervals(pts.leg, pts.s_nm, _engine_functions(ctx, pts, power_rtol), tol_nm)


def _halving(ctx, pts: CheckPoints, at, tol_nm: float, power_rtol: float, rules) -> tuple[CheckPoints, int]:
    """``pts`` halved (new points from ``at(group, s_nm)``) until the bands of ``rules`` (:func:`intervals_to_halve`)
    and the engine's range (:func:`engine_intervals_to_halve`) are certified everywhere; and the rounds made."""
    f = _functions(ctx, pts, power_rtol, rules)
    rounds = 0
    while rounds < MAX_ROUNDS:
        bands = {k[5:]: v for k, v in f.items() if k.startswith("band:")}
        i = intervals_to_halve(pts.leg, pts.s_nm, f["ok"], f["wfrom"], f["g"], bands, tol_nm)
        i = np.union1d(i, _engine_intervals(pts.leg, pts.s_nm, f, tol_nm))
        if i.size == 0:
            break
        rounds += 1
        new = at(pts.leg[i], 0.5 * (pts.s_nm[i] + pts.s_nm[i + 1]))
        f_new = _functions(ctx, new, power_rtol, rules)
        pts, idx = _concat(pts, new)
        f = {k: np.concatenate([f[k], f_new[k]])[idx] for k in f}
    return pts, rounds


def refined(
    ctx, pts: CheckPoints, at, *, rules=None, tol_nm: float = BAND_TOL_NM, power_rtol: float = 0.0
) -> CheckPoints:
    """``pts`` with the points the referee's refinement asks for (the bands of ``rules``, default the
    context's, and the engine's range), halved until none is asked for.

    For a checker of other tracks than a plan's (the minimum-time start's centreline blocks,
    :func:`optroute.optimise.min_time.timed_safe_start`): the bands and the engine's range are searched
    between its points as the referee searches them. ``pts`` are sorted by (``leg``: any grouping,
    ``s_nm``) and include the regime crossings; ``at(group, s_nm)`` evaluates further points as
    :func:`evaluate_at` does.
    """
    return _halving(ctx, pts, at, tol_nm, power_rtol, ctx.rules if rules is None else rules)[0]


def check_points(
    ctx, waypoints: np.ndarray, stw_kn: np.ndarray, departure: np.datetime64, d_nm: np.ndarray, dense,
    *, tol_nm: float = BAND_TOL_NM, spacing_nm: float = INITIAL_SPACING_NM, nodes: tuple | None = None,
    power_rtol: float = 0.0,
) -> CheckPoints:  # fmt: skip
    """The referee's check points of a plan: regime changes and adaptive refinement (see the module text).

    Parameters
    ----------
    ctx : PlanContext
        Ship, model, rules and weather.
    waypoints : ndarray, shape (n, 2)
        (lat, lon) [deg].
    stw_kn : ndarray, shape (n - 1,)
        Leg speeds through the water [kn].
    departure : numpy.datetime64
        [UTC].
    d_nm : ndarray, shape (n - 1,)
        Leg lengths [nm].
    dense : DenseTrack
        The plan's dense evaluation (:func:`optroute.plan.evaluate.evaluate_track`): its points are
        check points too, and its times the schedule.
    tol_nm : float
        Every band stretch longer than this contains a check point [nm].
    spacing_nm : float
        Longest spacing of the first check points [nm].
    nodes : (ndarray, ndarray), optional
        (leg, fraction of the leg) of further first check points (default: ``dense``'s points).
    power_rtol : float
        Relative widening of the engine's range [minimum load, MCR] the refinement certifies (``Plan.verify``'s).

    Returns
    -------
    CheckPoints
    """
    wp = np.asarray(waypoints, dtype=float)
    stw = np.asarray(stw_kn, dtype=float)
    clock = track_clock(dense.leg, dense.frac, dense.time_h, d_nm)
    n_leg, n_frac = (dense.leg, dense.frac) if nodes is None else nodes
    leg0, s0 = _start_nodes(np.asarray(n_leg), np.asarray(n_frac, dtype=float), d_nm, float(spacing_nm))
    leg, s = _crossings(ctx, wp, d_nm, clock, departure, leg0, s0, min(CROSSING_TOL_NM, tol_nm))
    pts = replace(evaluate_at(ctx, wp, stw, departure, d_nm, clock, leg, s), origin=_origins(leg0, s0, leg, s, d_nm))

    def at(leg_i: np.ndarray, s_i: np.ndarray) -> CheckPoints:
        new = evaluate_at(ctx, wp, stw, departure, d_nm, clock, leg_i, s_i)
        return replace(new, origin=np.full(new.size, ORIGIN_REFINED, dtype=np.int8))

    pts, rounds = _halving(ctx, pts, at, tol_nm, power_rtol, ctx.rules)
    out = {f.name: getattr(pts, f.name) for f in fields(CheckPoints)}
    out["tol_nm"], out["rounds"] = float(tol_nm), rounds
    return CheckPoints(**out)


def _origins(leg0: np.ndarray, s0: np.ndarray, leg: np.ndarray, s: np.ndarray, d_nm: np.ndarray) -> np.ndarray:
    """:attr:`CheckPoints.origin` of the start nodes ``(leg0, s0)`` with the crossings' points added: ``(leg, s)``."""
    start = np.isin(leg + 1j * s, leg0 + 1j * s0)
    end = (s <= 1e-9) | (s >= d_nm[leg] - 1e-9)
    return np.where(end, ORIGIN_END, np.where(start, ORIGIN_SPACING, ORIGIN_CROSSING)).astype(np.int8)


def row_points(pts: CheckPoints, d_nm: np.ndarray, *, refined_per_leg: int = 4) -> list[np.ndarray]:
    """Where an optimiser's rows should sit so that its plan passes these checks: fractions along every leg.

    The leg ends, both sides of every weather-grid crossing (between them the referee's weather is one
    trilinear polynomial along the track) and, thinned to at most ``refined_per_leg`` evenly spread ones,
    the points the adaptive refinement added (where a band's ratio or Hs came near its edge); not the
    even 1 nm spacing. :mod:`optroute.optimise.rows` turns them into the NLP's sample layout.

    Parameters
    ----------
    pts : CheckPoints
        The check points of a plan (:func:`check_points`, ``Plan.verify().points``).
    d_nm : ndarray, shape (N,)
        The plan's leg lengths [nm].
    refined_per_leg : int
        Most refinement points kept per leg.

    Returns
    -------
    list of ndarray
        Per leg, sorted fractions of the leg's length [-] in [0, 1].
    """
    d = np.asarray(d_nm, dtype=float)
    if pts.origin is None:
        raise ConfigError("these check points carry no origin (evaluate_at alone): take them from check_points()")
    frac = np.clip(np.divide(pts.s_nm, d[pts.leg], out=np.zeros(pts.size), where=d[pts.leg] > 0), 0.0, 1.0)
    out = []
    for k in range(d.size):
        on = pts.leg == k
        base = frac[on & ((pts.origin == ORIGIN_END) | (pts.origin == ORIGIN_CROSSING))]
        refined = np.sort(frac[on & (pts.origin == ORIGIN_REFINED)])
        if refined.size > refined_per_leg:
            refined = refined[np.unique(np.round(np.linspace(0, refined.size - 1, refined_per_leg)).astype(int))]
        out.append(np.unique(np.concatenate([[0.0, 1.0], base, refined])))
    return out
