"""The referee's checks at a plan's check points (:meth:`optroute.plan.result.Plan.verify`), one family each.

Split out of :mod:`optroute.plan.result`: each function reads the check points
(:func:`optroute.plan.checkpoints.check_points`: positions, times, the sea sampled there, the speed through
water, heading and brake power of the plan's own physics) and reports into one :class:`Findings`, which keeps
the worst point of each kind on each leg. Units: powers [kW], distances [nm], hours [h], band ratios [-].
"""

from __future__ import annotations

from typing import Any

import numpy as np

from optroute import geodesy as geo
from optroute.geo import land
from optroute.geo.tracks import project_to_polyline, within_distance_of_polyline
from optroute.physics.safety import band_margins, is_speed_forbidden
from optroute.plan.checkpoints import CheckPoints
from optroute.plan.evaluate import PlanContext, Violation
from optroute.units import h_to_timedelta as _h_to_td

__all__ = ["Findings", "check_bands", "check_engine", "check_geometry", "check_sea"]


class Findings:
    """The worst violation of each (kind, leg) found so far at the check points ``pts`` of a plan departing ``t0``."""

    def __init__(self, pts: CheckPoints, t0: np.datetime64) -> None:
        self.pts, self.t0 = pts, t0
        self.found: dict[tuple[str, int], tuple[float, Violation]] = {}

    def report(self, kind: str, mask: np.ndarray, value: np.ndarray, limit: Any, badness: np.ndarray) -> None:
        """Points where ``mask`` holds break ``kind``: each leg keeps its point of the largest ``badness``."""
        pts = self.pts
        limit = np.broadcast_to(np.asarray(limit, dtype=float), mask.shape)
        for i in np.flatnonzero(mask):
            key = (kind, int(pts.leg[i]))
            if key not in self.found or badness[i] > self.found[key][0]:
                when = self.t0 + _h_to_td(pts.time_h[i])
                v = Violation(
                    kind, key[1], (float(pts.lat[i]), float(pts.lon[i])), when, float(value[i]), float(limit[i])
                )
                self.found[key] = (float(badness[i]), v)

    def listed(self) -> list[Violation]:
        """The violations by leg, then kind."""
        return [v for _, v in sorted(self.found.values(), key=lambda item: (item[1].leg, item[1].kind))]


def check_sea(findings: Findings, ctx: PlanContext) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weather coverage, no passage (NaN sea), land at the points and the course held against the current.

    Returns ``(navigable, course held, both)`` per point.
    """
    pts = findings.pts
    sea = pts.sea
    nav = sea.navigable & pts.covered
    ones = np.ones(pts.leg.shape)
    findings.report("weather_coverage", ~pts.covered, ones, 0.0, ones)
    findings.report("no_passage", pts.covered & ~sea.navigable, ones, 0.0, ones)
    if ctx.land_mask_applies:
        findings.report("land", land.is_land(pts.lat, pts.lon), ones, 0.0, ones)
    held = np.isfinite(pts.heading)
    findings.report("course", nav & ~held, ones, 0.0, ones)
    return nav, held, nav & held


def check_engine(findings: Findings, ctx: PlanContext, ok: np.ndarray, power_rtol: float) -> None:
    """Brake power within [minimum power, MCR] (relative tolerance ``power_rtol``) where the sea is navigable."""
    pts = findings.pts
    mcr, pmin = float(ctx.model.mcr_kw), float(ctx.model.min_power_kw)
    p = np.where(np.isfinite(pts.power), pts.power, np.inf)
    high = ok & (p > mcr * (1.0 + power_rtol))
    findings.report("power_above_mcr", high, p, mcr, np.where(np.isfinite(p), p, 1e300))
    low = ok & (p < pmin * (1.0 - power_rtol))
    findings.report("power_below_min", low, p, pmin, pmin - p)


def check_bands(findings: Findings, ctx: PlanContext, nav: np.ndarray, held: np.ndarray) -> None:
    """Every enabled danger band of the rules (IMO MSC.1/Circ.1228) at the points' speed, heading and sea."""
    pts, sea = findings.pts, findings.pts.sea
    ok = nav & held
    heading = np.where(held, pts.heading, pts.course)
    hs = np.where(nav, sea.hs_m, 0.0)
    per = np.where(nav, sea.period_s, 1.0)
    wfrom = np.where(nav, sea.wave_from_deg, 0.0)
    margins = band_margins(
        ctx.ship, speed_kn=pts.stw, hs_m=hs, period_s=per, wave_from_deg=wfrom, heading_deg=heading, rules=ctx.rules
    )
    for band in ctx.rules.enabled_bands:
        hit = ok & is_speed_forbidden(
            ctx.ship,
            speed_kn=pts.stw,
            hs_m=hs,
            period_s=per,
            wave_from_deg=wfrom,
            heading_deg=heading,
            rules=ctx.rules,
            band=band,
        )
        bm = margins[band]
        below = bm.ratio < 0.5 * (bm.lo + bm.hi) if np.isfinite(bm.hi) else np.ones(bm.ratio.shape, dtype=bool)
        edge = np.where(below, bm.lo, bm.hi)
        findings.report(f"band:{band}", hit, bm.ratio, edge, -np.asarray(bm.margin, dtype=float))


def check_geometry(findings: Findings, ctx: PlanContext, corridor_tol_nm: float) -> None:
    """The points within the corridor's half-width (+ ``corridor_tol_nm``) and outside the exclusion circle."""
    pts = findings.pts
    if ctx.corridor is not None:
        cor = ctx.corridor
        # the exact projection (six geodesic problems a point) only where the screen (two) cannot clear a point
        # within the narrowest half-width; 2 mm spare for the rounding of the two measures
        clear_nm = float(np.min(cor.half_width_nm)) + corridor_tol_nm - 1e-6
        near = ~within_distance_of_polyline(cor.waypoints, pts.lat, pts.lon, clear_nm)
        dist, hw = np.zeros(near.shape), np.zeros(near.shape)
        if near.any():
            s, _, dist[near], _ = project_to_polyline(cor.waypoints, pts.lat[near], pts.lon[near])
            hw[near] = np.interp(s, cor.along_track_nm, cor.half_width_nm)
        findings.report("corridor", near & (dist > hw + corridor_tol_nm), dist, hw, dist - hw)
    if ctx.exclusion is not None:
        when = findings.t0 + _h_to_td(pts.time_h)
        clat, clon, rad = ctx.exclusion.at(when)
        dist = geo.distance_nm(pts.lat, pts.lon, clat, clon)
        findings.report("exclusion", dist < rad, dist, rad, rad - dist)
