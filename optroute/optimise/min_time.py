"""A timed safe start for the corridor NLP: the earliest passage along the centreline, found by a time-expanded DP.

Why
---
The corridor NLP (:class:`formulations.speed_nlp.SpeedNLP`) fixes the side of every danger band from
its warm start, and Ipopt stays on the sides it starts on. Where the sea is heavy enough for the bands
to apply, the allowed speeds at a place can be *none* for hours: every speed between the engine's
minimum load and MCR lies in some band while a storm passes (a moving no-go region in the corridor's
(along-track, time) plane). :func:`optroute.optimise.nlp_solve.safe_warm_start` reduces the speed point by point
(Boeing's rule) and, where nothing is allowed, falls to the lowest speed — below the minimum load, on
band sides no speed can keep — so the NLP starts at a point from which it cannot recover
(``Infeasible_Problem_Detected``), and a start one-quarter slower may reach the storm at another time
and succeed. Which start succeeds is luck.

What
----
:func:`timed_safe_start` searches the passage itself: the centreline is cut into blocks of at most
``block_nm``; each block is sailed at one speed from a ladder between the lowest and the highest speed;
a block at a speed is allowed when every point sampled along it (``step_nm`` apart), at the time the
ship is there, has the speed allowed by :func:`optroute.physics.passage.evaluate_speeds` (outside every band,
power within [minimum load, MCR], course held — the true model and the NLP's backed-off rules). The
states are the arrival times at the block ends, bucketed to ``bucket_h`` (the earliest of a bucket
kept) and kept within ``window_h`` of the earliest arrival at that block end, so that the passage can
slow down before a storm to let it pass. The earliest arrival at the end, traced back, is a passage
whose every sampled point is allowed: its band sides are sides a ship keeps, its timing avoids the
no-go regions, and its arrival bounds the earliest arrival from above (up to the sampling; the NLP's
solution is verified on its dense resampling as always).

Timing uses the speed through water (the current's share is left to the NLP): this is a start, not a
plan.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from optroute.geo.tracks import gc_points
from optroute.optimise.nlp_inputs import CorridorFrame
from optroute.physics.passage import SeaState, evaluate_speeds
from optroute.physics.safety import BandRules
from optroute.plan.checkpoints import CheckPoints, refined
from optroute.plan.evaluate import PlanContext, sample_sea
from optroute.units import NS_PER_H as _NS_PER_H

__all__ = [
    "CROSSING_STEP_NM",
    "BlockedSection",
    "DeadEnd",
    "TimedStart",
    "block_fractions",
    "blocked_section",
    "centreline_points",
    "clean_start",
    "timed_safe_start",
]

CROSSING_STEP_NM = 0.1
"""Spacing [nm] of the ladder on which the timed search locates the weather grid's row and column crossings."""


@dataclass(frozen=True)
class TimedStart:
    """The earliest passage found by :func:`timed_safe_start`.

    Attributes
    ----------
    stw_kn : numpy.ndarray, shape (N,)
        Speed through water of every leg of the corridor frame [kn] (its block's).
    offset_nm : numpy.ndarray, shape (N+1,)
        Lateral offsets [nm]: zero (the centreline).
    arrival_h : float
        Arrival at the corridor's end [h after departure].
    blocks : int
        Number of blocks of the search.
    evaluations : int
        Points × speeds evaluated [-].
    """

    stw_kn: np.ndarray
    offset_nm: np.ndarray
    arrival_h: float
    blocks: int
    evaluations: int

    def warm(self) -> dict[str, np.ndarray]:
        """The warm start of :meth:`optroute.optimise.nlp_solve.Problem.solve`: offsets [nm] and leg speeds [kn]."""
        return {"offset_nm": self.offset_nm.copy(), "stw_kn": self.stw_kn.copy()}


@dataclass(frozen=True)
class DeadEnd:
    """Where :func:`timed_safe_start` found no passage: the block no state could sail.

    Attributes
    ----------
    from_nm, to_nm : float
        The block along the centreline [nm from the start].
    lat, lon : float
        Its midpoint [deg].
    earliest_h, latest_h : float
        The arrival times at its start that were tried [h after departure].
    """

    from_nm: float
    to_nm: float
    lat: float
    lon: float
    earliest_h: float
    latest_h: float

    def __str__(self) -> str:
        return (
            f"no speed is allowed on the centreline between {self.from_nm:.0f} and {self.to_nm:.0f} nm along "
            f"track (near {self.lat:.2f}, {self.lon:.2f}) for any arrival there from {self.earliest_h:.1f} to "
            f"{self.latest_h:.1f} h after departure"
        )


def centreline_points(frame: CorridorFrame, s_nm: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Latitude, longitude [deg] and course [deg true] of centreline points at along-track distances [nm]."""
    wp = frame.corridor.waypoints
    s = np.asarray(frame.s_nm, dtype=float)
    leg = np.clip(np.searchsorted(s, s_nm, side="right") - 1, 0, frame.n_legs - 1)
    d = np.diff(s)
    frac = np.clip((s_nm - s[leg]) / np.where(d[leg] > 0, d[leg], 1.0), 0.0, 1.0)
    return gc_points(wp[leg, 0], wp[leg, 1], wp[leg + 1, 0], wp[leg + 1, 1], frac)


def block_fractions(
    frame: CorridorFrame, sampler: Any, t0: np.datetime64, from_nm: float, to_nm: float, step_nm: float
) -> np.ndarray:
    """Fractions [0, 1] of a centreline block to check: its ends, points ``step_nm`` apart and both sides of
    every crossing of the weather's grid rows and columns (where the referee looks too,
    :mod:`optroute.plan.checkpoints`).

    Between two crossings the interpolated sea at one time is a bilinear function of position, largest
    at the ends of the stretch; sampled ``step_nm`` apart only, a cell's edge (the top of a storm's
    plateau) can be missed. The crossings are found on a :data:`CROSSING_STEP_NM` ladder, so each pair
    of sides is at most that far apart.
    """
    d = float(to_nm - from_nm)
    m = max(2, int(np.ceil(d / step_nm)))
    base = np.linspace(0.0, 1.0, m + 1)
    n_fine = max(2, int(np.ceil(d / CROSSING_STEP_NM)))
    fine = np.linspace(0.0, 1.0, n_fine + 1)
    lat, lon, _ = centreline_points(frame, from_nm + fine * d)
    cell = sampler.grid_coordinates(np.full(fine.shape, t0), lat, lon)[:, 1:]
    cell = np.where(np.isfinite(cell), np.floor(cell), -1.0)
    change = np.flatnonzero(np.any(cell[1:] != cell[:-1], axis=1))
    return np.unique(np.concatenate([base, fine[change], fine[change + 1]]))


def timed_safe_start(
    ctx: PlanContext,
    frame: CorridorFrame,
    t0: np.datetime64,
    *,
    v_min_kn: float,
    v_max_kn: float,
    rules: BandRules | None = None,
    block_nm: float = 30.0,
    step_nm: float = 5.0,
    speed_step_kn: float = 0.5,
    bucket_h: float = 0.5,
    window_h: float = 24.0,
    hs_backoff: float = 0.1,
) -> TimedStart | DeadEnd:
    """The earliest passage along the corridor's centreline whose every sampled point is allowed.

    Parameters
    ----------
    ctx : PlanContext
        Ship, true performance model, weather sampler (and the rules when ``rules`` is None).
    frame : CorridorFrame
        The NLP's corridor frame; the result has one speed per frame leg.
    t0 : numpy.datetime64
        Departure [UTC].
    v_min_kn, v_max_kn : float
        Speed-through-water range [kn] (the NLP's).
    rules : BandRules, optional
        The bands to keep out of (e.g. the NLP's backed-off rules, :func:`optroute.optimise.nlp_solve.warm_rules`).
    block_nm : float
        Longest block sailed at one speed [nm]: consecutive frame legs (a leg longer than this is a block).
    step_nm : float
        Longest spacing of the points checked along a block, its ends included [nm] (the verifier's 5 nm).
    speed_step_kn : float
        Spacing of the speed ladder [kn] (``v_max_kn`` is always on it).
    bucket_h : float
        Arrival times at a block end closer than this share one state (the earliest kept) [h].
    window_h : float
        States later than the earliest arrival at a block end by more than this are dropped [h].
    hs_backoff : float
        The bands are checked from ``(1 − hs_backoff)`` times the rules' Hs threshold [-]: between the
        points checked the sea may cross the threshold, and a start is better a little cautious.

    Returns
    -------
    TimedStart or DeadEnd
        The passage; or, when no passage within the window exists on the ladder (a point outside the
        weather's span is not allowed), the block where every state ended.

    Notes
    -----
    Cost: blocks × states (≤ ``window_h / bucket_h``) × speeds × points per block evaluations of
    :func:`optroute.physics.passage.evaluate_speeds` (about 5 µs each): 1–3 s for a 2 500–5 000 nm corridor
    with the defaults.
    """
    base = ctx.rules if rules is None else rules
    use_rules = replace(base, hs_threshold_fraction=base.hs_threshold_fraction * (1.0 - float(hs_backoff)))
    s_wp = np.asarray(frame.s_nm, dtype=float)
    # blocks of whole frame legs (one speed per block is one speed per leg of the NLP), each at most block_nm
    # unless a single leg is longer
    cut = [0]
    for k in range(1, s_wp.size):
        if k == s_wp.size - 1 or s_wp[k + 1] - s_wp[cut[-1]] > block_nm:
            cut.append(k)
    edges = s_wp[cut]
    n_blocks = edges.size - 1
    speeds = np.unique(np.append(np.arange(v_min_kn, v_max_kn, speed_step_kn), v_max_kn))
    times = np.zeros(1)  # arrival times at the current block end [h]
    back: list[tuple[np.ndarray, np.ndarray]] = []  # per block: (previous state, speed index) of each state
    evaluations = 0
    for b in range(n_blocks):
        d = edges[b + 1] - edges[b]
        frac = block_fractions(frame, ctx.sampler, t0, edges[b], edges[b + 1], step_nm)  # both ends too
        lat, lon, course = centreline_points(frame, edges[b] + frac * d)
        dt = d / speeds  # (K,)
        t_pts = times[:, None, None] + frac[None, None, :] * dt[None, :, None]  # (B, K, m)
        shape = t_pts.shape
        flat_t = t_pts.ravel()
        when = t0 + (flat_t * _NS_PER_H).astype("timedelta64[ns]")
        lat_f = np.broadcast_to(lat, shape).ravel()
        lon_f = np.broadcast_to(lon, shape).ravel()
        course_f = np.broadcast_to(course, shape).ravel()
        speed_f = np.broadcast_to(speeds[None, :, None], shape).ravel()
        sea, covered = sample_sea(ctx.sampler, when, lat_f, lon_f)
        heading, sog, power, _, allowed = evaluate_speeds(ctx.ship, ctx.model, use_rules, course_f, sea, speed_f)
        allowed &= covered
        evaluations += flat_t.size
        ok = allowed.reshape(shape).all(axis=2)  # (B, K)
        first = CheckPoints(
            np.zeros(flat_t.size, dtype=np.int64), np.broadcast_to(frac * d, shape).ravel(), lat_f, lon_f, course_f,
            flat_t, sea, covered, heading, sog, power, speed_f,
        )  # fmt: skip
        prev, spd = np.nonzero(ok)
        arrive = times[prev] + dt[spd]
        # one state per bucket (the earliest whose points and the referee's refinement between them are allowed)
        keep, extra = _earliest_refined(
            ctx, use_rules, frame, t0, (edges[b], d), (frac, times, dt, speeds), (prev, spd, arrive), first, bucket_h
        )  # fmt: skip
        evaluations += extra
        if keep.size == 0:
            mid = centreline_points(frame, np.array([edges[b] + 0.5 * d]))
            return DeadEnd(
                float(edges[b]),
                float(edges[b + 1]),
                float(mid[0][0]),
                float(mid[1][0]),
                float(times.min()),
                float(times.max()),
            )
        # within the window of the earliest arrival
        keep = keep[arrive[keep] <= arrive[keep].min() + window_h]
        times = arrive[keep]
        back.append((prev[keep], spd[keep]))
    # trace the earliest arrival back: the block speeds
    state = int(np.argmin(times))
    arrival = float(times[state])
    block_speed = np.empty(n_blocks)
    for b in range(n_blocks - 1, -1, -1):
        prev, spd = back[b]
        block_speed[b] = speeds[spd[state]]
        state = int(prev[state])
    stw = np.repeat(block_speed, np.diff(cut))
    return TimedStart(
        stw_kn=stw, offset_nm=np.zeros(frame.n_legs + 1), arrival_h=arrival, blocks=n_blocks, evaluations=evaluations
    )


def _earliest_refined(ctx, rules, frame, t0, block, ladder, pairs, first, bucket_h) -> tuple[np.ndarray, int]:
    """Per arrival bucket, the earliest of a block's (state, speed) pairs that neither enters a band of ``rules``
    nor leaves the engine's range between the block's points (:func:`optroute.plan.checkpoints.refined`, the
    referee's rule), and the evaluations this took.

    ``pairs`` is (state, speed index, arrival [h]) of the pairs whose points are allowed; they are taken in the
    order of (bucket, arrival) (ties in the given order), and the refinement checks only each bucket's first pair
    not yet struck, round by round: the pairs kept are those the refinement of every pair would keep.  ``block``
    is (start [nm], length [nm]); ``ladder`` (fractions checked, state times [h], block times [h] per speed,
    speeds [kn]); ``first`` the block's evaluated points, shape (B, K, m) raveled.
    """
    prev, spd, arrive = pairs
    bucket = np.floor(arrive / bucket_h)
    order = np.lexsort((arrive, bucket))
    struck = np.zeros(prev.size, dtype=bool)
    checked = np.zeros(prev.size, dtype=bool)
    count = 0
    while True:
        live = order[~struck[order]]
        heads = live[np.concatenate([[True], bucket[live[1:]] != bucket[live[:-1]]])] if live.size else live
        todo = heads[~checked[heads]]
        if todo.size == 0:
            return heads, count
        bad, extra = _refined_bad(ctx, rules, frame, t0, block, ladder, (prev[todo], spd[todo]), first)
        count += extra
        checked[todo] = True
        struck[todo[bad]] = True


def _refined_bad(ctx, rules, frame, t0, block, ladder, pairs, first) -> tuple[np.ndarray, int]:
    """Which (state, speed) ``pairs`` of a block enter a band of ``rules`` or leave the engine's range between
    the block's points (:func:`optroute.plan.checkpoints.refined`), and the evaluations added; the arguments as
    :func:`_earliest_refined`'s."""
    from_nm, d = block
    frac, times, dt, speeds = ladder
    prev, spd = pairs
    m = frac.size
    flat = ((prev * speeds.size + spd)[:, None] * m + np.arange(m)[None, :]).ravel()
    pts = _take(first, flat, np.repeat(np.arange(prev.size), m))
    bad = np.zeros(prev.size, dtype=bool)
    count = [0]

    def at(g: np.ndarray, s_nm: np.ndarray) -> CheckPoints:
        lat, lon, course = centreline_points(frame, from_nm + s_nm)
        t_h = times[prev[g]] + s_nm / d * dt[spd[g]]
        sea, covered = sample_sea(ctx.sampler, t0 + (t_h * _NS_PER_H).astype("timedelta64[ns]"), lat, lon)
        v = speeds[spd[g]]
        heading, sog, power, _, allowed = evaluate_speeds(ctx.ship, ctx.model, rules, course, sea, v)
        np.logical_or.at(bad, g, ~(allowed & covered))
        count[0] += g.size
        return CheckPoints(g, s_nm, lat, lon, course, t_h, sea, covered, heading, sog, power, v)

    refined(ctx, pts, at, rules=rules)
    return bad, count[0]


def _take(pts: CheckPoints, idx: np.ndarray, group: np.ndarray) -> CheckPoints:
    """Points ``idx`` of ``pts``, grouped by ``group``."""
    sea = SeaState(**{f.name: np.asarray(getattr(pts.sea, f.name))[idx] for f in fields(SeaState)})
    arrays = ("s_nm", "lat", "lon", "course", "time_h", "covered", "heading", "sog", "power", "stw")
    return replace(pts, leg=group, sea=sea, **{name: np.asarray(getattr(pts, name))[idx] for name in arrays})


def clean_start(
    ctx: PlanContext,
    frame: CorridorFrame,
    t0: np.datetime64,
    *,
    desired_kn: float,
    v_min_kn: float,
    v_max_kn: float,
    eta_h: float | None,
    rules: BandRules | None = None,
    log: list[str] | None = None,
    verify: Callable[[dict[str, np.ndarray]], Any] | None = None,
    mend: Callable[[dict[str, np.ndarray]], tuple[dict[str, np.ndarray], Any] | None] | None = None,
) -> tuple[dict[str, np.ndarray], Any]:
    """The centreline start of a solve: Boeing's speed reduction, or the timed passage where that fails.

    :func:`optroute.optimise.nlp_solve.safe_warm_start` at ``desired_kn`` is kept when it found an allowed speed
    at every point (no leg at ``v_min_kn``) and ``verify`` accepts it. Otherwise the passage of
    :func:`timed_safe_start` with speeds up to ``desired_kn`` is taken when it arrives by ``eta_h`` (or
    there is no ETA), else the earliest passage with speeds up to ``v_max_kn`` (the discrete
    minimum-time plan); when neither exists, the earliest passage keeping out of the bands of ``ctx.rules``
    themselves (not ``rules``, no Hs back-off), else the safe start after all.

    Where no passage at speeds up to ``desired_kn`` arrives by ``eta_h`` and ``mend`` is given, the reduction
    with ``desired_kn`` on the legs where it found no allowed speed is handed to ``mend`` first (the referee's
    engine-range repair, :func:`optroute.optimise.starts.repaired_plan`): where the engine's minimum load is what
    forbids the desired speed, the legs are raised to it and the plan arrives a little early, instead of the
    earliest passage flat out, far from the least-fuel plan (``benchmarks/bench_front.py`` compares single calls
    there with the front).

    The reduction is a point-by-point rule: it keeps each point out of the bands at the time of its
    own schedule but not between its points, and its slow legs can fall under the engine's minimum
    load. Where the referee rejects it, the NLP would start on band sides no plan keeps; the timed
    passage is checked where the referee checks (:func:`block_fractions`), so it is the start.

    Parameters
    ----------
    ctx, frame, t0, rules
        As in :func:`timed_safe_start`.
    desired_kn : float
        Speed wanted [kn] (:func:`optroute.optimise.nlp_solve.desired_speed`).
    v_min_kn, v_max_kn : float
        The NLP's speed range [kn].
    eta_h : float, optional
        Arrival wanted [h after departure].
    log : list of str, optional
        Appended with what was chosen.
    verify : callable, optional
        The referee: a warm start's verified plan, or None when it fails verification. Without it
        the reduction is kept whenever it has no leg at ``v_min_kn``.
    mend : callable, optional
        A warm start's speeds moved into the engine's range by the referee: ``(warm start, verified plan)``, or
        None where it cannot be mended (a band, the ETA, a speed bound).

    Returns
    -------
    (dict, object)
        ``offset_nm`` (N+1,) [nm] and ``stw_kn`` (N,) [kn]; and ``verify``'s verdict on it (None
        when it failed or ``verify`` is None).
    """
    from optroute.optimise.nlp_solve import safe_warm_start

    def judged(warm: dict[str, np.ndarray]) -> Any:
        return verify(warm) if verify is not None else None

    safe = safe_warm_start(ctx, frame, t0, desired_kn, v_min_kn, rules=rules)
    clean = bool(np.all(safe["stw_kn"] > v_min_kn + 1e-9))
    verdict = judged(safe) if clean else None
    if clean and (verify is None or verdict is not None):
        return safe, verdict
    found = timed_safe_start(ctx, frame, t0, v_min_kn=v_min_kn, v_max_kn=max(desired_kn, v_min_kn), rules=rules)
    late = not isinstance(found, TimedStart) or (eta_h is not None and found.arrival_h > eta_h)
    if late and desired_kn < v_max_kn:
        raised = np.where(safe["stw_kn"] > v_min_kn + 1e-9, safe["stw_kn"], max(desired_kn, v_min_kn))
        mended = mend({**safe, "stw_kn": raised}) if mend is not None else None
        if mended is not None:
            if log is not None:
                log.append("first start: no passage at the desired speed or below; the speed reduction, mended into "
                           "the engine's range by the referee")  # fmt: skip
            return mended
        found = timed_safe_start(ctx, frame, t0, v_min_kn=v_min_kn, v_max_kn=v_max_kn, rules=rules)
    if not isinstance(found, TimedStart):
        # the backed-off bands (the rules given, from 0.9 of the Hs threshold) can close a passage the true bands leave
        # open (harness seed 22: a dead end at 139-186 nm; with the true bands 20.58 h, verified): the referee judges
        found = timed_safe_start(ctx, frame, t0, v_min_kn=v_min_kn, v_max_kn=v_max_kn, hs_backoff=0.0)
    if not isinstance(found, TimedStart):
        # a finer ladder: a passage can need a speed between the 0.5 kn rungs (harness seed 22: 8 kn dips under the
        # minimum load between the points checked, 8.5 kn meets a band; 8.25 then 7.75 kn passes, 20.59 h)
        found = timed_safe_start(
            ctx, frame, t0, v_min_kn=v_min_kn, v_max_kn=v_max_kn, hs_backoff=0.0, speed_step_kn=0.25
        )  # fmt: skip
    why = "finds no allowed speed somewhere" if not clean else "fails verification"
    if log is not None:
        log.append(
            f"first start: the speed reduction {why}; "
            + (
                f"timed safe start, {found.arrival_h:.3f} h"
                if isinstance(found, TimedStart)
                else f"no timed start either ({found})"
            )
        )
    if isinstance(found, TimedStart):
        return found.warm(), judged(found.warm())
    return safe, verdict


@dataclass(frozen=True)
class BlockedSection:
    """A cross-section of the corridor where no speed is allowed at any time: the passage is closed there.

    Attributes
    ----------
    s_nm : float
        Along the centreline [nm from the start].
    lat, lon : float
        Its centreline point [deg].
    from_h, to_h : float
        The times checked [h after departure].
    v_min_kn, v_max_kn : float
        The speeds checked [kn].
    """

    s_nm: float
    lat: float
    lon: float
    from_h: float
    to_h: float
    v_min_kn: float
    v_max_kn: float

    def __str__(self) -> str:
        return (
            f"no speed through the water from {self.v_min_kn:g} to {self.v_max_kn:.1f} kn is allowed anywhere across "
            f"the corridor {self.s_nm:.0f} nm along track (near {self.lat:.2f}, {self.lon:.2f}) at any time from "
            f"{self.from_h:.1f} to {self.to_h:.1f} h after departure (danger bands, the engine's load range, "
            "the sea state)"
        )


def blocked_section(
    ctx: PlanContext,
    frame: CorridorFrame,
    t0: np.datetime64,
    *,
    y_lo_nm: np.ndarray,
    y_hi_nm: np.ndarray,
    v_min_kn: float,
    v_max_kn: float,
    horizon_h: float,
    lanes: int = 5,
    dt_h: float = 1.0,
    speed_step_kn: float = 0.25,
) -> BlockedSection | None:
    """The first corridor node where no speed is allowed at any lateral offset and any time, or None.

    A ship that passes the node must be somewhere across the corridor at some time in
    ``[0, horizon_h]`` at some speed; when :func:`optroute.physics.passage.evaluate_speeds` (the true
    model and the bands, the ship on the course of the corridor's leg there) allows none of
    ``lanes`` offsets × times every ``dt_h`` × speeds every ``speed_step_kn``, there is no passage
    (up to that sampling): :class:`optroute.errors.NoSafePassage`, not a solver failure.

    Parameters
    ----------
    ctx, frame, t0
        As :func:`timed_safe_start`.
    y_lo_nm, y_hi_nm : ndarray, shape (N+1,)
        The corridor's navigable lateral bounds at its nodes [nm, port positive].
    v_min_kn, v_max_kn : float
        Speed-through-water range [kn].
    horizon_h : float
        Latest time checked [h after departure] (within the weather's span).
    lanes, dt_h, speed_step_kn
        The sampling: offsets across the corridor, time step [h], speed step [kn].
    """
    n = frame.n_legs
    speeds = np.unique(np.append(np.arange(v_min_kn, v_max_kn, speed_step_kn), v_max_kn))
    times = np.arange(0.0, max(horizon_h, 0.0) + 1e-9, dt_h)
    for k in range(n + 1):
        ys = np.linspace(float(y_lo_nm[k]), float(y_hi_nm[k]), lanes if y_hi_nm[k] > y_lo_nm[k] else 1)
        pts = np.array([frame.waypoints(np.full(n + 1, y))[k] for y in ys])
        j = min(k, n - 1)
        nxt = np.array([frame.waypoints(np.full(n + 1, y))[j + 1] for y in ys])
        prv = np.array([frame.waypoints(np.full(n + 1, y))[j] for y in ys])
        course = gc_points(prv[:, 0], prv[:, 1], nxt[:, 0], nxt[:, 1], np.full(ys.size, 1.0 if k == n else 0.0))[2]
        shape = (ys.size, times.size, speeds.size)
        lat = np.broadcast_to(pts[:, 0, None, None], shape).ravel()
        lon = np.broadcast_to(pts[:, 1, None, None], shape).ravel()
        crs = np.broadcast_to(course[:, None, None], shape).ravel()
        t_h = np.broadcast_to(times[None, :, None], shape).ravel()
        v = np.broadcast_to(speeds[None, None, :], shape).ravel()
        when = t0 + (t_h * _NS_PER_H).astype("timedelta64[ns]")
        sea, covered = sample_sea(ctx.sampler, when, lat, lon)
        heading, _, power, _, allowed = evaluate_speeds(ctx.ship, ctx.model, ctx.rules, crs, sea, v)
        allowed &= covered
        heading = np.where(np.isfinite(heading), heading, crs)
        if not allowed.any() and covered.any() and not _any_window(ctx, sea, heading, v, power, covered, speeds.size):
            centre = frame.waypoints(np.zeros(n + 1))[k]
            return BlockedSection(
                float(frame.s_nm[k]), float(centre[0]), float(centre[1]), 0.0, float(times[-1]), float(speeds[0]),
                float(speeds[-1]),
            )  # fmt: skip
    return None


def _any_window(ctx: PlanContext, sea, heading, v, power, covered, k: int) -> bool:
    """Whether some point of a cross-section has an allowed speed between the ladder's rungs.

    Exact per point: the speeds the load range allows (power is increasing in the speed: above the
    highest rung under the minimum load and below the lowest rung over MCR) less the closed band
    intervals of :func:`optroute.physics.safety.forbidden_speed_intervals`.
    """
    from optroute.physics.safety import forbidden_speed_intervals, merged_intervals

    pw = np.where(np.isfinite(power), power, np.inf).reshape(-1, k)
    v2 = v.reshape(-1, k)
    pmin, mcr = float(ctx.model.min_power_kw), float(ctx.model.mcr_kw)
    for i in np.flatnonzero(covered.reshape(-1, k)[:, 0]):
        j = i * k
        if not (np.isfinite(sea.hs_m[j]) and np.isfinite(sea.period_s[j]) and np.isfinite(sea.wave_from_deg[j])):
            continue
        low = v2[i][pw[i] < pmin]
        high = v2[i][pw[i] > mcr]
        lo = float(low.max()) if low.size else float(v2[i][0])
        hi = float(high.min()) if high.size else float(v2[i][-1])
        if hi <= lo:
            continue
        bands = merged_intervals(
            forbidden_speed_intervals(
                ctx.ship, hs_m=float(sea.hs_m[j]), period_s=float(sea.period_s[j]),
                wave_from_deg=float(sea.wave_from_deg[j]), heading_deg=float(heading[j]), rules=ctx.rules,
            )
        )  # fmt: skip
        free = [(lo, hi)]
        for b_lo, b_hi in bands:
            free = [(a, min(b, b_lo)) for a, b in free if a < b_lo] + [(max(a, b_hi), b) for a, b in free if b > b_hi]
        if any(b - a > 1e-9 for a, b in free):
            return True
    return False
