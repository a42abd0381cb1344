"""Where a track is checked between given points so that no danger band is missed: the referee's rule, shared.

The referee (:mod:`optroute.plan.checkpoints`, ``Plan.verify()``) and the route search
(:meth:`optroute.search.passage_physics.PassagePhysics.segment_checked` and its compiled form,
:mod:`optroute.search.refine_kernels`) look for danger bands (Boeing EP 2145155; IMO
MSC.1/Circ.1228) along a track at the same points, found by the same rules (issue 14 item 1):

1. **Regime changes** (:func:`crossing_nodes`): where the weather's interpolation cell changes
   between two neighbouring points (a latitude row, a longitude column or a time slice of the data
   is crossed), the crossing is located by a secant on the grid coordinate and both sides, within
   :data:`CROSSING_TOL_NM`, become points: between them the sampled fields are one trilinear
   polynomial, smooth along the track.
2. **Adaptive refinement** (:func:`intervals_to_halve`): an interval between neighbouring points
   longer than the tolerance is halved until it is *certified* (:func:`certified`): for every
   enabled band, either the band's ratio stays outside the band or Hs stays below the band's
   threshold over every stretch longer than the tolerance, by a Lipschitz bound — with end values
   ``m_a, m_b > 0`` and a slope bound ``L``, a stretch of length ``w`` where the function is <= 0
   needs ``m_a + m_b <= L (h − w)``, so ``m_a + m_b > L (h − tol)`` rules out every stretch longer
   than ``tol``; ``L`` is :data:`SLOPE_SAFETY` times the largest secant slope of the interval and its
   two neighbours.  An interval is halved regardless where the wave direction turns by more than
   :data:`TURN_DEG` across it (a storm's centre), or where a band's sector condition (IMO) holds at
   one end only.  An interval with an end inside a band has found it and is not halved.

So every band stretch longer than :data:`BAND_TOL_NM` contains a point, up to the slope bound's
estimate.  This module holds the rule's numpy form (used by the referee and the search's numpy
callbacks); :mod:`optroute.search.refine_kernels` is its compiled form for the search kernels, with
:func:`certified` compiled from this very function.  Distances along the track ``s`` [nm]; points are
grouped (a leg, a piece) and sorted by (group, s).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from optroute import units
from optroute.physics.safety import band_margins

__all__ = [
    "BAND_TOL_NM",
    "CROSSING_PASSES",
    "CROSSING_TOL_NM",
    "MAX_ROUNDS",
    "SLOPE_SAFETY",
    "TURN_DEG",
    "band_functions",
    "certified",
    "crossing_nodes",
    "excursion_lengths",
    "intervals_to_halve",
    "regime_doubts",
    "secant_slopes",
]

BAND_TOL_NM = 0.1
"""A band entered over more than this distance along a track is found [nm]."""
CROSSING_TOL_NM = 0.01
"""Regime crossings (grid rows, columns, time slices) are located to within this [nm]."""
CROSSING_PASSES = 12
"""Secant passes locating the crossings (one suffices on a uniform grid, up to the track's curvature)."""
SLOPE_SAFETY = 2.0
"""Factor on the largest neighbouring secant slope in the Lipschitz bound [-]."""
TURN_DEG = 10.0
"""An interval across which the wave direction turns by more than this is halved [deg]."""
MAX_ROUNDS = 40
"""Bound on the halving rounds (each halves every uncertified interval; 1 nm reaches 0.1 nm in 4)."""


def certified(m_a, m_b, slope, h_nm, tol_nm):
    """Whether a function positive at both ends of an interval cannot be <= 0 over a stretch longer than ``tol_nm``.

    ``m_a, m_b``: the function at the ends; ``slope``: the bound on its slope [1/nm] before
    :data:`SLOPE_SAFETY`; ``h_nm``: the interval's length [nm].  Arithmetic and comparisons only, on
    floats or arrays: compiled as it stands for the search kernels (:mod:`optroute.search.refine_kernels`).
    """
    return (m_a > 0.0) & (m_b > 0.0) & (m_a + m_b > SLOPE_SAFETY * slope * (h_nm - tol_nm))


def secant_slopes(m: np.ndarray, s: np.ndarray, same: np.ndarray) -> np.ndarray:
    """Per interval, the largest secant slope of it and its neighbours in the same group (0 where not finite)."""
    h = s[1:] - s[:-1]
    with np.errstate(invalid="ignore", divide="ignore"):
        sl = np.abs(np.diff(m)) / np.where(h > 0, h, np.inf)
    sl = np.where(np.isfinite(sl) & same, sl, 0.0)
    left = np.concatenate([[0.0], np.where(same[:-1], sl[:-1], 0.0)])
    right = np.concatenate([np.where(same[1:], sl[1:], 0.0), [0.0]])
    return np.maximum(sl, np.maximum(left, right))


def regime_doubts(
    same: np.ndarray, inside: np.ndarray, regime: np.ndarray, dists: list[np.ndarray], s_nm: np.ndarray, tol_nm: float
) -> np.ndarray:
    """Per interval between consecutive points, whether the model's power regime changes across it, or may change and
    change back inside it over a stretch longer than ``tol_nm``.

    ``same``: the interval's two points on one group (leg); ``inside``: the points where the regime counts (both ends
    must be); ``regime``: the key of :func:`~optroute.physics.passage.power_regime`; ``dists``: the distances of its
    drivers to their nearest edges (:func:`~optroute.physics.passage.regime_distances`), certified positive by the
    Lipschitz rule (:func:`certified`, slopes over the intervals with both ends inside:
    a distance is continuous across a change of regime). The rule of the referee's check of the engine's range
    (:func:`optroute.plan.checkpoints.engine_intervals_to_halve`) and of its fuel integral (:mod:`optroute.plan.evaluate`).
    """
    both = same & inside[:-1] & inside[1:]
    jump = both & (regime[1:] != regime[:-1])
    need = jump.copy()
    h = s_nm[1:] - s_nm[:-1]
    for m in dists:
        need |= both & ~jump & ~certified(m[:-1], m[1:], secant_slopes(m, s_nm, both), h, tol_nm)
    return need


def excursion_lengths(
    same: np.ndarray, inside: np.ndarray, regime: np.ndarray, dists: list[np.ndarray], s_nm: np.ndarray
) -> list[np.ndarray]:
    """Per regime driver, per interval between consecutive points of one regime, the longest stretch [nm] over which
    the driver may cross its edge and come back unseen by the points.

    What the Lipschitz rule of :func:`certified` leaves open (with the slopes of :func:`regime_doubts`): an interval
    of one regime with both ends positive is certified to ``tol_nm`` exactly where this is below ``tol_nm``; the
    whole interval where an end is on an edge, and across a change of regime (which :func:`regime_doubts` has
    located: another driver may cross its edge too, into a third regime, anywhere between the two points); 0 where a
    point is not inside. The arguments are those of :func:`regime_doubts`.
    """
    both = same & inside[:-1] & inside[1:]
    change = both & (regime[1:] != regime[:-1])
    h = s_nm[1:] - s_nm[:-1]
    out = []
    for m in dists:
        slope = SLOPE_SAFETY * secant_slopes(m, s_nm, both)
        m_a, m_b = m[:-1], m[1:]
        with np.errstate(invalid="ignore", divide="ignore"):
            free = np.where(slope > 0.0, (m_a + m_b) / np.where(slope > 0.0, slope, 1.0), np.inf)
            length = np.where((m_a > 0.0) & (m_b > 0.0) & ~change, np.clip(h - free, 0.0, h), h)
        out.append(np.where(both, length, 0.0))
    return out


def crossing_nodes(
    group: np.ndarray, s: np.ndarray, coords: Callable[[np.ndarray, np.ndarray], np.ndarray], tol_nm: float
) -> tuple[np.ndarray, np.ndarray]:
    """``(group, s)`` with both sides of every change of the weather's interpolation cell added.

    The crossing of a grid line (or time slice) inside an interval is put where the continuous grid
    coordinate, linear between the interval's ends, reaches the line; points ``0.45 tol_nm`` either
    side of it are added; an interval that still changes cell is treated again (a secant search:
    exact in one pass on a uniform grid, up to the great circle's curvature over the interval).

    Parameters
    ----------
    group, s : ndarray
        Points sorted by (group, distance along it [nm]).
    coords : callable
        ``coords(group, s)`` -> the continuous grid coordinates, shape (n, 3)
        (:meth:`optroute.weather.sample.WeatherSampler.grid_coordinates`; NaN outside the data).
    tol_nm : float
        Half the spacing of the two points put about a crossing, over 0.45 [nm].
    """
    c = coords(group, s)
    for _ in range(CROSSING_PASSES):
        cell = np.where(np.isfinite(c), np.floor(c), -1.0)
        h = s[1:] - s[:-1]
        change = (group[1:] == group[:-1]) & np.any(cell[1:] != cell[:-1], axis=1) & (h > tol_nm)
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
        new_group = np.concatenate([group[i], group[i]])
        new_s = np.concatenate([lo, hi])
        group = np.concatenate([group, new_group])
        s = np.concatenate([s, new_s])
        c = np.concatenate([c, coords(new_group, new_s)])
        order = np.lexsort((s, group))
        group, s, c = group[order], s[order], c[order]
        keep = np.ones(group.size, dtype=bool)
        keep[1:] = (group[1:] != group[:-1]) | (s[1:] != s[:-1])
        group, s, c = group[keep], s[keep], c[keep]
    return group, s


def band_functions(
    ship, rules, sea, covered: np.ndarray, heading_deg: np.ndarray, course_deg: np.ndarray, stw_kn: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """(ok, wave direction [deg], Hs's relative distance below the threshold, {band: ratio's distance to it}).

    ``ok``: navigable (Hs, period and direction finite, inside the data) with the course held
    (``heading_deg`` finite).  The band margins (:func:`optroute.physics.safety.band_margins`) are
    taken wherever the band's other conditions hold (Hs put over the threshold), the heading the
    course where it is not held.
    """
    nav = np.isfinite(sea.hs_m) & np.isfinite(sea.period_s) & np.isfinite(sea.wave_from_deg) & covered
    held = np.isfinite(heading_deg)
    ok = nav & held
    thr = rules.hs_threshold_fraction * ship.length_m
    hs = np.where(nav, sea.hs_m, 0.0)
    per = np.where(nav & (sea.period_s > 0), sea.period_s, 1.0)
    wfrom = np.where(nav, sea.wave_from_deg, 0.0)
    heading = np.where(held, heading_deg, course_deg)
    margins = band_margins(
        ship, speed_kn=stw_kn, hs_m=np.maximum(hs, thr), period_s=per, wave_from_deg=wfrom, heading_deg=heading,
        rules=rules,
    )  # fmt: skip
    bands = {b: np.asarray(margins[b].margin, dtype=float) for b in rules.enabled_bands}
    g = (thr - hs) / thr if thr > 0 else np.full(hs.shape, -np.inf)
    return ok, wfrom, g, bands


def intervals_to_halve(
    group: np.ndarray, s: np.ndarray, ok: np.ndarray, wfrom: np.ndarray, g: np.ndarray, bands: dict, tol_nm: float
) -> np.ndarray:
    """Indices i of the intervals (i, i + 1) that are not certified and longer than ``tol_nm``.

    ``ok, wfrom, g, bands`` are :func:`band_functions` at the points (sorted by (group, s)).
    """
    same = group[1:] == group[:-1]
    h = s[1:] - s[:-1]
    cand = same & (h > tol_nm)
    both = ok[:-1] & ok[1:]  # (an end that is not navigable or cannot hold its course is a violation already)
    need = both & (np.abs(units.wrap_180(wfrom[1:] - wfrom[:-1])) > TURN_DEG)
    g_slope = secant_slopes(g, s, same)
    hs_cert = certified(g[:-1], g[1:], g_slope, h, tol_nm)
    for m in bands.values():
        inside = (m <= 0) & (g <= 0)
        found = inside[:-1] | inside[1:]
        fin_a, fin_b = np.isfinite(m[:-1]), np.isfinite(m[1:])
        m_slope = secant_slopes(m, s, same)
        ratio_cert = np.where(fin_a & fin_b, certified(m[:-1], m[1:], m_slope, h, tol_nm), ~fin_a & ~fin_b)
        need |= both & ~found & ~(ratio_cert | hs_cert)
    return np.flatnonzero(cand & need)
