"""No passage along a fixed path: the reachable (distance, time) set of every schedule, over-approximated, dies.

Why
---
:func:`optroute.optimise.min_time.blocked_section` proves a corridor closed only where one cross-section allows
no speed at *any* time. A moving storm rarely does that: it closes a strip of the (along-track, time) plane that
moves towards the ship, and the ship can neither outrun it nor wait for it to pass (the engine's minimum load
keeps it above some speed; harness seeds 8, 30 and 94: a fixed path, a storm crossing it). The lattice searches of
the start stage (the 3-D DP, the centreline's timed passage) find nothing there, but a lattice's silence proves
nothing (harness seed 20: a passage in blocks of 9.78 nm and none in blocks of 9 nm).

What
----
On a fixed path (no lateral freedom: the heading is the path's course) a schedule is the ship's time at every
distance along the path, and its speed at a point is a speed the true model allows there at that time
(:func:`optroute.physics.passage.evaluate_speeds`: outside every band, power within [minimum load, MCR], course held,
sea navigable). :func:`fixed_path_barrier` propagates the *set* of times at which some schedule can be at each
section of the path (sections ``ds_nm`` apart), as a union of intervals, without choosing speeds:

* between two sections a schedule sails at speeds over ground within the hull of the speeds allowed at the two
  sections over the times it can be there, so it arrives at the next section within ``[t + Δs / v_hi,
  t + Δs / v_lo]`` (each reachable interval cut into pieces of at most ``split_h``, each with its own hull);
* at a section the times at which no speed is allowed are removed (a run of blocked samples ``dt_h`` apart is
  taken as blocked between them), and times after the weather's end (or the ETA) are dropped.

The propagation only *adds* schedules (any speed in the hull, at any time in an interval), so when the set is empty
at some section no schedule passes it: :class:`~optroute.errors.NoSafePassage`. The claim is up to the sampling,
which the message states: sections every ``ds_nm``, times every ``dt_h``, speeds every ``speed_step_kn`` — a
narrower window in speed or time than those can be missed, so the message names them and the claim is scoped to
them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optroute.optimise.min_time import centreline_points
from optroute.optimise.nlp_inputs import CorridorFrame
from optroute.physics.passage import evaluate_speeds
from optroute.plan.evaluate import PlanContext, sample_sea
from optroute.units import NS_PER_H as _NS_PER_H

__all__ = ["Barrier", "fixed_path_barrier"]

Intervals = list[tuple[float, float]]


@dataclass(frozen=True)
class Barrier:
    """Where every schedule along a fixed path is stopped.

    Attributes
    ----------
    s_nm, lat, lon : float
        The section no schedule reaches [nm along the path; deg].
    before_nm : float
        The section before it [nm along the path].
    reach_from_h, reach_to_h : float
        The times [h after departure] some schedule can be at the section before it, its hull.
    end_h : float
        The latest time a passage may take [h after departure] (the weather's end, or the ETA).
    v_min_kn, v_max_kn : float
        The speeds through water checked [kn].
    ds_nm, dt_h, speed_step_kn : float
        The sampling the claim rests on.
    """

    s_nm: float
    lat: float
    lon: float
    before_nm: float
    reach_from_h: float
    reach_to_h: float
    end_h: float
    v_min_kn: float
    v_max_kn: float
    ds_nm: float
    dt_h: float
    speed_step_kn: float

    def __str__(self) -> str:
        return (
            f"no schedule along this fixed path reaches {self.s_nm:.1f} nm along it (near {self.lat:.2f}, "
            f"{self.lon:.2f}) by {self.end_h:.1f} h after departure: a ship sailing through the water at "
            f"{self.v_min_kn:g} to {self.v_max_kn:.1f} kn is {self.before_nm:.1f} nm along only between "
            f"{self.reach_from_h:.3f} and {self.reach_to_h:.3f} h, and from there every speed the danger bands, the "
            "engine's load range and the sea state allow leads into times and places where none is allowed "
            f"(checked at most every {self.ds_nm:g} nm along the path, every {self.dt_h:g} h, speeds every "
            f"{self.speed_step_kn:g} kn; a narrower window than that is not excluded)"
        )


def _sections(frame: CorridorFrame, ds_nm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(s [nm], lat, lon, course [deg]) every ``ds_nm`` or less along the centreline, every node included."""
    nodes = np.asarray(frame.s_nm, dtype=float)
    pieces = [
        np.linspace(a, b, max(2, int(np.ceil((b - a) / ds_nm)) + 1))[:-1]
        for a, b in zip(nodes[:-1], nodes[1:], strict=True)
    ]
    s = np.concatenate([*pieces, nodes[-1:]])
    return (s, *centreline_points(frame, s))


def _allowed_sog(ctx: PlanContext, t0, lat, lon, crs, times_h, speeds) -> tuple[np.ndarray, np.ndarray]:
    """At one section, per time: the lowest and highest speed over ground among the allowed speeds (NaN: none)."""
    n = times_h.size
    when = t0 + (times_h * _NS_PER_H).astype("timedelta64[ns]")
    sea, covered = sample_sea(ctx.sampler, when, np.full(n, lat), np.full(n, lon))
    stw = np.broadcast_to(speeds[None, :], (n, speeds.size))
    _, sog, _, _, allowed = evaluate_speeds(ctx.ship, ctx.model, ctx.rules, np.full(n, crs), sea, stw)
    allowed &= covered[:, None] & np.isfinite(sog)
    lo = np.where(allowed, sog, np.inf).min(axis=1)
    hi = np.where(allowed, sog, -np.inf).max(axis=1)
    none = ~allowed.any(axis=1)
    return np.where(none, np.nan, lo), np.where(none, np.nan, hi)


def _merge(iv: Intervals) -> Intervals:
    out: Intervals = []
    for a, b in sorted(iv):
        if out and a <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


def _open_times(iv: Intervals, times_h: np.ndarray, blocked: np.ndarray) -> Intervals:
    """``iv`` less the runs of blocked samples (each run ``[t_first, t_last]`` taken as blocked throughout)."""
    edges = np.diff(np.concatenate([[0], blocked.astype(np.int8), [0]]))
    runs = list(zip(times_h[np.flatnonzero(edges == 1)], times_h[np.flatnonzero(edges == -1) - 1], strict=True))
    for c, d in runs:
        nxt: Intervals = []
        for a, b in iv:
            if b < c or a > d:
                nxt.append((a, b))
                continue
            nxt += [(a, c)] if a < c else []
            nxt += [(d, b)] if b > d else []
        iv = nxt
    return iv


def fixed_path_barrier(
    ctx: PlanContext,
    frame: CorridorFrame,
    t0: np.datetime64,
    *,
    v_min_kn: float,
    v_max_kn: float,
    end_h: float,
    ds_nm: float = 1.0,
    dt_h: float = 0.05,
    speed_step_kn: float = 0.1,
    split_h: float = 0.1,
) -> Barrier | None:
    """The section of a fixed path that no schedule reaches by ``end_h`` (module docstring), or None.

    Parameters
    ----------
    ctx : PlanContext
        The true model, the bands and the weather (the referee's).
    frame : CorridorFrame
        The path: its centreline (the corridor has no lateral freedom).
    t0 : datetime64
        Departure [UTC].
    v_min_kn, v_max_kn : float
        Speed-through-water range [kn].
    end_h : float
        Latest arrival [h after departure] (within the weather's span).
    ds_nm, dt_h, speed_step_kn : float
        The sampling: sections along the path [nm], times [h], speeds [kn].
    split_h : float
        Longest piece of a reachable interval given its own speed hull [h].
    """
    s, lat, lon, crs = _sections(frame, ds_nm)
    times = np.arange(0.0, end_h + 1e-9, dt_h)
    speeds = np.unique(np.append(np.arange(v_min_kn, v_max_kn, speed_step_kn), v_max_kn))
    lo0, hi0 = _allowed_sog(ctx, t0, lat[0], lon[0], crs[0], times, speeds)
    reach: Intervals = [(0.0, 0.0)]
    if not np.isfinite(lo0[0]):  # no speed allowed at the departure itself
        return Barrier(float(s[0]), float(lat[0]), float(lon[0]), float(s[0]), 0.0, 0.0, float(end_h),
                       float(speeds[0]), float(speeds[-1]), float(ds_nm), float(dt_h), float(speed_step_kn))  # fmt: skip
    for i in range(s.size - 1):
        step, nxt = float(s[i + 1] - s[i]), []
        slow = max(min(v_min_kn, float(np.nanmin(np.append(lo0, np.inf)))), 1e-3)  # the lowest SOG, a current's too
        # only the times a schedule can be at the next section are sampled there (the others cannot be reached)
        wanted = (times >= reach[0][0] - 3 * dt_h) & (times <= reach[-1][1] + step / slow + 2 * dt_h) if reach else []
        lo1, hi1 = np.full(times.size, np.nan), np.full(times.size, np.nan)
        if np.any(wanted):
            lo1[wanted], hi1[wanted] = _allowed_sog(ctx, t0, lat[i + 1], lon[i + 1], crs[i + 1], times[wanted], speeds)
        for a, b in reach:
            cuts = np.linspace(a, b, max(1, int(np.ceil((b - a) / split_h))) + 1)
            for p, q in zip(cuts[:-1], cuts[1:], strict=True):
                here = (times >= p - dt_h) & (times <= q + dt_h)
                there = (times >= p + step / v_max_kn - 2 * dt_h) & (times <= q + step / slow + dt_h)
                v_lo = np.nanmin(np.concatenate([lo0[here], lo1[there], [np.inf]]))
                v_hi = np.nanmax(np.concatenate([hi0[here], hi1[there], [-np.inf]]))
                if np.isfinite(v_lo) and np.isfinite(v_hi) and v_hi > 0.0:
                    nxt.append((p + step / v_hi, q + step / max(v_lo, 1e-3)))  # the hull's bounds
        before, reach = reach, _open_times([(a, min(b, end_h)) for a, b in _merge(nxt) if a <= end_h], times,
                                           np.isnan(lo1))  # fmt: skip
        if not reach:
            return Barrier(float(s[i + 1]), float(lat[i + 1]), float(lon[i + 1]), float(s[i]), float(before[0][0]),
                           float(before[-1][1]), float(end_h), float(speeds[0]), float(speeds[-1]), float(ds_nm),
                           float(dt_h), float(speed_step_kn))  # fmt: skip
        lo0, hi0 = lo1, hi1
    return None
