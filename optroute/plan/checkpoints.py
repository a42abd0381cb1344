"""Where the referee looks along a leg: points that sampling cannot fool (issue 14 item 1).

A plan's dense evaluation (:func:`optroute.plan.evaluate.evaluate_track`) samples every leg at the
midpoints of pieces of at most ``step_nm`` (5 nm): enough for fuel and time, not for the danger
bands. Near a storm's centre the wave direction swings through 180° within a few nm, and where Hs
climbs over the bands' threshold (Boeing EP 2145155: Hs >= 0.04 L) a speed can sit inside a band
for 1–3 nm between two midpoints. :func:`check_points` finds every such stretch longer than
:data:`BAND_TOL_NM`:

1. **Start**: every leg end, the dense evaluation's own points and points at most
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

An interval no longer than the tolerance is never halved: a band stretch longer than it contains a
check point. So every band stretch longer than :data:`BAND_TOL_NM` contains a check point, up to the
slope bound's estimate (``tests/test_checkpoints.py`` compares with brute force at 0.01 nm); a
shorter one may or may not be found.

The ship is at a check point at the time of the plan's own schedule: linear in distance between
the dense evaluation's points (whose times are the schedule's), so the check points and the
evaluation agree where they coincide. Everything is vectorised; the point physics is
:func:`optroute.physics.passage.evaluate_speeds` (the compiled one-point functions of
:mod:`optroute.physics.pointwise` for the built-in models), the model that scores the plan.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from optroute import units
from optroute.geo.tracks import gc_points
from optroute.physics.passage import SeaState, evaluate_speeds
from optroute.physics.safety import band_margins
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
    "evaluate_at",
    "track_clock",
]

BAND_TOL_NM = 0.1
"""A band entered over more than this distance along a leg is found [nm]."""
INITIAL_SPACING_NM = 1.0
"""Longest spacing of the first check points along a leg [nm]."""
CROSSING_TOL_NM = 0.01
"""Regime crossings (grid rows, columns, time slices) are located to within this [nm]."""
SLOPE_SAFETY = 2.0
"""Factor on the largest neighbouring secant slope in the Lipschitz bound [-]."""
TURN_DEG = 10.0
"""An interval across which the wave direction turns by more than this is halved [deg]."""
MAX_ROUNDS = 40
"""Bound on the halving rounds (each halves every uncertified interval; 1 nm reaches 0.1 nm in 4)."""


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


def _concat(a: CheckPoints, b: CheckPoints) -> CheckPoints:
    """The points of both, sorted by (leg, distance), duplicates dropped."""
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
    return CheckPoints(**out)


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
    """Add both sides of every change of the weather's interpolation cell along the legs.

    The crossing of a grid line (or time slice) inside an interval is put where the continuous grid
    coordinate, linear between the interval's ends, reaches the line; points ``0.45 tol_nm`` either
    side of it are added; an interval that still changes cell is treated again (a secant search:
    exact in one pass on a uniform grid, up to the great circle's curvature over the interval).
    """

    def coords(lg, ss):
        lat, lon, _, t_h = _positions(waypoints, d_nm, clock, lg, ss)
        return ctx.sampler.grid_coordinates(departure + _h_to_td(t_h), lat, lon)

    c = coords(leg, s)
    for _ in range(12):
        cell = np.where(np.isfinite(c), np.floor(c), -1.0)
        h = s[1:] - s[:-1]
        change = (leg[1:] == leg[:-1]) & np.any(cell[1:] != cell[:-1], axis=1) & (h > tol_nm)
        i = np.flatnonzero(change)
        if i.size == 0:
            break
        ca, cb = c[i], c[i + 1]
        # per dimension that changes: the grid line just past the lower end, as a fraction of the interval
        line = np.where(cb > ca, np.floor(ca) + 1.0, np.ceil(ca) - 1.0 + (ca == np.floor(ca)))
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = (line - ca) / (cb - ca)
        frac = np.where(np.isfinite(frac) & (frac > 0.0) & (frac < 1.0) & (cell[i] != cell[i + 1]), frac, np.inf)
        f = frac.min(axis=1)
        f = np.where(np.isfinite(f), f, 0.5)  # (leaving the data, or a periodic wrap: halve)
        mid = s[i] + f * h[i]
        half = 0.45 * tol_nm
        lo = np.clip(mid - half, s[i] + 0.25 * half, s[i + 1] - 0.25 * half)
        hi = np.clip(mid + half, s[i] + 0.25 * half, s[i + 1] - 0.25 * half)
        new_leg = np.concatenate([leg[i], leg[i]])
        new_s = np.concatenate([lo, hi])
        leg = np.concatenate([leg, new_leg])
        s = np.concatenate([s, new_s])
        c = np.concatenate([c, coords(new_leg, new_s)])
        order = np.lexsort((s, leg))
        leg, s, c = leg[order], s[order], c[order]
        keep = np.ones(leg.size, dtype=bool)
        keep[1:] = (leg[1:] != leg[:-1]) | (s[1:] != s[:-1])
        leg, s, c = leg[keep], s[keep], c[keep]
    return leg, s


def _functions(ctx, pts: CheckPoints) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """(ok, wave direction [deg], Hs's relative distance below the threshold, {band: ratio's distance to it})."""
    sea = pts.sea
    nav = np.isfinite(sea.hs_m) & np.isfinite(sea.period_s) & np.isfinite(sea.wave_from_deg) & pts.covered
    held = np.isfinite(pts.heading)
    ok = nav & held
    thr = ctx.rules.hs_threshold_fraction * ctx.ship.length_m
    hs = np.where(nav, sea.hs_m, 0.0)
    per = np.where(nav & (sea.period_s > 0), sea.period_s, 1.0)
    wfrom = np.where(nav, sea.wave_from_deg, 0.0)
    heading = np.where(held, pts.heading, pts.course)
    # the ratio's distance to each band wherever its other conditions hold (Hs put over the threshold)
    margins = band_margins(
        ctx.ship, speed_kn=pts.stw, hs_m=np.maximum(hs, thr), period_s=per, wave_from_deg=wfrom, heading_deg=heading,
        rules=ctx.rules,
    )  # fmt: skip
    bands = {b: np.asarray(margins[b].margin, dtype=float) for b in ctx.rules.enabled_bands}
    g = (thr - hs) / thr if thr > 0 else np.full(hs.shape, -np.inf)
    return ok, wfrom, g, bands


def _certified(ma, mb, slope_a, slope_b, h, tol):
    """Whether a function positive at both ends cannot be <= 0 over a stretch longer than ``tol``."""
    return (ma > 0) & (mb > 0) & (ma + mb > SLOPE_SAFETY * np.maximum(slope_a, slope_b) * (h - tol))


def _slopes(m: np.ndarray, s: np.ndarray, same: np.ndarray) -> np.ndarray:
    """Per interval, the largest secant slope of it and its neighbours on the same leg (0 where not finite)."""
    h = s[1:] - s[:-1]
    with np.errstate(invalid="ignore", divide="ignore"):
        sl = np.abs(np.diff(m)) / np.where(h > 0, h, np.inf)
    sl = np.where(np.isfinite(sl) & same, sl, 0.0)
    left = np.concatenate([[0.0], np.where(same[:-1], sl[:-1], 0.0)])
    right = np.concatenate([np.where(same[1:], sl[1:], 0.0), [0.0]])
    return np.maximum(sl, np.maximum(left, right))


def _to_halve(ctx, pts: CheckPoints, tol_nm: float) -> np.ndarray:
    """Indices i of the intervals (i, i + 1) that are not certified and longer than ``tol_nm``."""
    ok, wfrom, g, bands = _functions(ctx, pts)
    leg, s = pts.leg, pts.s_nm
    same = leg[1:] == leg[:-1]
    h = s[1:] - s[:-1]
    cand = same & (h > tol_nm)
    a_ok, b_ok = ok[:-1], ok[1:]
    both = a_ok & b_ok  # (an end that is not navigable or cannot hold its course is a violation already)
    need = both & (np.abs(units.wrap_180(wfrom[1:] - wfrom[:-1])) > TURN_DEG)
    g_slope = _slopes(g, s, same)
    hs_cert = _certified(g[:-1], g[1:], g_slope, g_slope, h, tol_nm)
    for m in bands.values():
        inside = (m <= 0) & (g <= 0)
        found = inside[:-1] | inside[1:]
        fin_a, fin_b = np.isfinite(m[:-1]), np.isfinite(m[1:])
        m_slope = _slopes(m, s, same)
        ratio_cert = np.where(fin_a & fin_b, _certified(m[:-1], m[1:], m_slope, m_slope, h, tol_nm), ~fin_a & ~fin_b)
        need |= both & ~found & ~(ratio_cert | hs_cert)
    return np.flatnonzero(cand & need)


def check_points(
    ctx, waypoints: np.ndarray, stw_kn: np.ndarray, departure: np.datetime64, d_nm: np.ndarray, dense,
    *, tol_nm: float = BAND_TOL_NM, spacing_nm: float = INITIAL_SPACING_NM,
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

    Returns
    -------
    CheckPoints
    """
    wp = np.asarray(waypoints, dtype=float)
    stw = np.asarray(stw_kn, dtype=float)
    clock = track_clock(dense.leg, dense.frac, dense.time_h, d_nm)
    leg, s = _start_nodes(dense.leg, dense.frac, d_nm, float(spacing_nm))
    leg, s = _crossings(ctx, wp, d_nm, clock, departure, leg, s, min(CROSSING_TOL_NM, tol_nm))
    pts = evaluate_at(ctx, wp, stw, departure, d_nm, clock, leg, s)
    rounds = 0
    while rounds < MAX_ROUNDS:
        i = _to_halve(ctx, pts, tol_nm)
        if i.size == 0:
            break
        rounds += 1
        new = evaluate_at(ctx, wp, stw, departure, d_nm, clock, pts.leg[i], 0.5 * (pts.s_nm[i] + pts.s_nm[i + 1]))
        pts = _concat(pts, new)
    out = {f.name: getattr(pts, f.name) for f in fields(CheckPoints)}
    out["tol_nm"], out["rounds"] = float(tol_nm), rounds
    return CheckPoints(**out)
