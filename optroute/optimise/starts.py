"""The corridor NLP's start: the best verified discrete plan on the same corridor.

:meth:`optroute.optimise.corridor_problem.PreparedCorridor.solve` starts Ipopt from the best of these
candidates *as scored by the referee* (the plan evaluator and :meth:`Plan.verify`, the same that
scores the NLP's plan), and never returns a plan worse than the best verified one:

* ``"warm plan"`` — a given previous plan (a neighbouring ETA's, :func:`optroute.studies.tradeoff`);
* ``"search route"`` — a given search route, its waypoints and speeds through water;
* ``"3-D DP"`` — the 3-D dynamic programme (:mod:`optroute.search.dp`, via
  :func:`optroute.search_route` with ``method="dp"``) run on the corridor itself (its stages on the
  great circle from start to end, or following the centreline's bends, :func:`corridor_stations`):
  least fuel (or cost) by the ETA, or without one, the danger bands and the MCR inside;
* ``"minimum-time plan"`` — the corridor's minimum-time plan, where it meets the ETA;
* ``"ship dual"`` — on a fixed path in static weather, the schedule of the ship's own dual bound;
* ``"minimum-load schedule"`` — for least fuel without an ETA, the centreline sailed at the engine's minimum
  load (:func:`minimum_load_plan`);
* ``"centreline start"`` — the NLP's own safe start on the centreline
  (:func:`optroute.optimise.min_time.clean_start`).

Which of them are made, and when the costly ones (the DP, the minimum-time plan) are: the start stage,
:mod:`optroute.optimise.start_stage`.

A discrete candidate (a search route, the 3-D DP) is checked by its search at its own points only; where
the referee finds the engine outside its range between them, or a danger band only grazed, its speeds are mended
leg by leg (:func:`repaired_plan`) before it is scored. Each candidate becomes a warm start on the NLP's legs — its lateral offsets at the corridor's
waypoints (its track projected on the centreline) and, for every NLP leg, the speed that sails it in the time
the candidate takes there (:func:`track_warm_start`) — so the NLP starts on the band sides the candidate keeps and
arrives when it does. Its plan is scored on its own waypoints: that is the plan a user would get from it; where
its legs are not the NLP's, the warm start is not that plan (:func:`warm_is_plan`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from optroute import geodesy as geo
from optroute import units
from optroute.errors import NoSafePassage, OptrouteError
from optroute.geo.tracks import inner_offset_nm, project_to_polyline
from optroute.optimise.nlp_inputs import CorridorFrame
from optroute.plan.result import Plan, PlanContext
from optroute.search.route import Route

__all__ = [
    "ENGINE_KINDS",
    "Candidate",
    "corridor_stations",
    "dp_route",
    "evaluated_plan",
    "great_circle_corridor",
    "minimum_load_plan",
    "repaired_plan",
    "score",
    "track_warm_start",
    "verified_plan",
    "warm_is_plan",
]

#: Largest distance of a corridor's centreline from the 3-D DP's chord between two stations, as a share of the
#: half-width (:func:`corridor_stations`); at least :data:`CHORD_TOL_MIN_NM`.
CHORD_TOL_SHARE = 0.1
#: Least chord tolerance [nm] (a fixed path: the chords follow the centreline's bends to this).
CHORD_TOL_MIN_NM = 0.05
#: The violations :func:`repaired_plan` mends: the engine's range, by the leg's speed alone.
ENGINE_KINDS = ("power_below_min", "power_above_mcr")
#: Rounds of :func:`repaired_plan` (each one evaluation and verification by the referee).
REPAIR_ROUNDS = 12
#: Smallest speed move of a repair round [kn].
REPAIR_STEP_KN = 0.05
#: A danger band entered by at most this share of its edge's value [-] is a graze: a discrete plan's own checks (the
#: search's points, the kernels' arithmetic) and the referee's can disagree that close to an edge (the head storm of
#: ``benchmarks/bench_compare.py``: the start stage's 3-D DP plan at T_E/T_R 0.599995 against 0.6).
GRAZE_SHARE = 1e-3
#: Rounds of :func:`minimum_load_plan` (each one evaluation and verification by the referee).
MIN_LOAD_ROUNDS = 10
#: :func:`minimum_load_plan` aims each leg's lowest power this far above the minimum power [-], and stops when every
#: leg's lies within :data:`MIN_LOAD_SLACK` of it.
MIN_LOAD_AIM = 5e-4
MIN_LOAD_SLACK = 2e-3


@dataclass(frozen=True)
class Candidate:
    """A start of the NLP: where it comes from, its warm start and its verified plan (None if it does not verify).

    Attributes
    ----------
    label : str
        ``"warm plan"``, ``"search route"``, ``"3-D DP"``, ``"minimum-time plan"``, ``"ship dual"`` or
        ``"centreline start"`` (:mod:`optroute.optimise.start_stage`).
    warm : dict of str to numpy.ndarray
        ``offset_nm`` (N+1,) [nm, port +] and ``stw_kn`` (N,) [kn] on the NLP's legs.
    plan : Plan or None
        The candidate scored by the referee, when it passes :meth:`Plan.verify`.
    score : float
        The plan's objective (fuel [t], time [h] or cost); ``inf`` without a verified plan.
    estimate : float
        The candidate's own figure of that objective (a search's or the DP's), used to order the warm
        starts when it does not verify (the DP's 30 nm pieces can miss a point the referee finds).
    cpu_s : float
        CPU seconds it took to make and score (``time.process_time``; a global start's search or solve included).
    """

    label: str
    warm: dict[str, np.ndarray]
    plan: Plan | None
    score: float
    estimate: float = float("inf")
    cpu_s: float = 0.0


def score(plan: Plan, objective: str, fuel_price: float, hourly: float) -> float:
    """The objective of a plan by the referee: fuel [t], passage time [h] or cost [currency]."""
    if objective == "time":
        return plan.duration_h
    if objective == "fuel":
        return plan.total_fuel_t
    return fuel_price * plan.total_fuel_t + hourly * plan.duration_h


def evaluated_plan(
    ctx: PlanContext, waypoints: np.ndarray, stw_kn: np.ndarray, departure: np.datetime64, step_nm: float, status: str
) -> Plan | None:
    """The plan of a track and speeds through water as the referee evaluates it (not verified); None where it cannot
    even be evaluated (past the weather's end, off its area): such a candidate is no start."""
    try:
        return Plan.from_context(
            ctx, np.asarray(waypoints, dtype=float), stw_kn, departure=departure, status=status, step_nm=step_nm
        )
    except OptrouteError:
        return None


def verified_plan(
    ctx: PlanContext,
    waypoints: np.ndarray,
    stw_kn: np.ndarray,
    departure: np.datetime64,
    step_nm: float,
    status: str,
) -> Plan | None:
    """The plan of a track and speeds through water scored by the referee, if it passes verification."""
    stw = np.asarray(stw_kn, dtype=float)
    if not np.all(np.isfinite(stw) & (stw > 0)):
        return None
    plan = evaluated_plan(ctx, waypoints, stw, departure, step_nm, status)
    return plan if plan is not None and not plan.verify(step_nm=step_nm) else None


def repaired_plan(
    ctx: PlanContext,
    waypoints: np.ndarray,
    stw_kn: np.ndarray,
    departure: np.datetime64,
    step_nm: float,
    status: str,
    *,
    v_min_kn: float,
    v_max_kn: float,
) -> tuple[Plan | None, int]:
    """The plan of a track and speeds, its engine-range violations mended leg by leg; None if it cannot be.

    A discrete plan (the 3-D DP's, a search route's) is checked by its own search at its own points;
    the referee (:meth:`Plan.verify`) checks every ``step_nm`` and at both ends of every leg, and can
    find the engine below its minimum power (or above the MCR) at a point the search never looked at
    (the storm crossing of ``benchmarks/bench_nlp.py``: the 3-D DP's plan is 2 % under the minimum power
    at the start of one leg and 14 % under it at the end of another, in following seas). Where the
    referee finds only such violations, the leg's speed through water moves by the propeller law
    toward the limit it broke, ``V ← V (P_limit / P_found)^{1/3}`` (at least :data:`REPAIR_STEP_KN`,
    0.2 % beyond the limit; brake power rises with speed, physics.md §8), and the plan is evaluated
    and verified again, at most :data:`REPAIR_ROUNDS` times. A danger band only grazed (entered by at most
    :data:`GRAZE_SHARE` of its edge) moves the leg's speed :data:`REPAIR_STEP_KN` down, or up where down
    does not clear the leg. Any other violation (a band entered further, the ETA, the schedule, land) is not
    mended here: None. Speeds stay within ``[v_min_kn, v_max_kn]``.

    Returns
    -------
    plan : Plan or None
        The verified plan (the given one when it verifies as it is), else None.
    legs_changed : int
        Legs whose speed was moved.
    """
    stw = np.asarray(stw_kn, dtype=float).copy()
    if not np.all(np.isfinite(stw) & (stw > 0)):
        return None, 0
    moved: set[int] = set()
    for _ in range(REPAIR_ROUNDS + 1):
        plan = evaluated_plan(ctx, waypoints, stw, departure, step_nm, status)
        if plan is None:
            return None, len(moved)
        found = plan.verify(step_nm=step_nm)
        if not found:
            return plan, len(moved)
        if any(v.kind not in ENGINE_KINDS and not _graze(v) for v in found):
            return None, len(moved)
        before = stw.copy()
        for leg in sorted({int(v.leg) for v in found if _graze(v)}):
            stw[leg] = _off_the_edge(ctx, waypoints, stw, leg, departure, step_nm, v_min_kn, v_max_kn)
            moved.add(leg)
        for v in (v for v in found if v.kind in ENGINE_KINDS):
            up = v.kind == "power_below_min"
            target = propeller_speed(stw[v.leg], v.limit, v.value) * (1.002 if up else 0.998)
            step = max(abs(target - stw[v.leg]), REPAIR_STEP_KN)
            stw[v.leg] = float(np.clip(stw[v.leg] + (step if up else -step), v_min_kn, v_max_kn))
            moved.add(int(v.leg))
        if np.array_equal(stw, before):  # held at a speed bound: nothing left to move
            return None, len(moved)
    return None, len(moved)


def _graze(v: Any) -> bool:
    """Whether a violation is a danger band entered by at most :data:`GRAZE_SHARE` of its edge's value."""
    return str(v.kind).startswith("band:") and abs(float(v.value) - float(v.limit)) <= GRAZE_SHARE * abs(float(v.limit))


def _off_the_edge(
    ctx: PlanContext, waypoints: np.ndarray, stw: np.ndarray, leg: int, departure: np.datetime64, step_nm: float,
    v_min_kn: float, v_max_kn: float,
) -> float:  # fmt: skip
    """Leg ``leg``'s speed :data:`REPAIR_STEP_KN` slower, or faster where slower leaves a violation on that leg
    (by the referee) and faster does not; the slower where neither clears it (the next round sees what is left)."""
    options = [float(np.clip(stw[leg] + d, v_min_kn, v_max_kn)) for d in (-REPAIR_STEP_KN, REPAIR_STEP_KN)]
    for v in options:
        trial = stw.copy()
        trial[leg] = v
        plan = evaluated_plan(ctx, waypoints, trial, departure, step_nm, "candidate")
        if plan is not None and not any(int(x.leg) == leg for x in plan.verify(step_nm=step_nm)):
            return v
    return options[0]


def propeller_speed(stw_kn: Any, power_kw: Any, found_kw: Any) -> Any:
    """The speed through water [kn] whose brake power is ``power_kw``, from ``stw_kn`` where it is ``found_kw``.

    The propeller law ``P ∝ V³`` (physics.md §8): ``V (P / P_found)^{1/3}``; 0.9 ``V`` where ``found_kw`` is not
    finite (the power could not be evaluated there).
    """
    found = np.asarray(found_kw, dtype=float)
    finite = np.isfinite(found)
    ratio = np.where(finite, power_kw / np.maximum(np.where(finite, found, 1.0), 1e-9), 1.0) ** (1.0 / 3.0)
    return np.asarray(stw_kn, dtype=float) * np.where(finite, ratio, 0.9)


def minimum_load_plan(
    ctx: PlanContext,
    waypoints: np.ndarray,
    departure: np.datetime64,
    step_nm: float,
    *,
    v_min_kn: float,
    v_max_kn: float,
) -> Plan | None:
    """A track sailed at the engine's minimum load, verified by the referee: the least-fuel problem's start.

    Without an ETA fuel falls as the ship slows until the engine's minimum power
    (:attr:`~optroute.physics.performance.PerformanceModel.min_power_kw`) stops it, so the slowest schedule the engine
    allows is where a least-fuel solve without an ETA begins. Each leg starts at the calm-water speed of the minimum
    power (:meth:`~optroute.physics.ship.Ship.calm_speed_kn`); then, :data:`MIN_LOAD_ROUNDS` times at most, the plan is
    evaluated and verified by the referee (:meth:`Plan.verify`) and each leg's speed moves by the propeller law
    (:func:`propeller_speed`) until the lowest power the referee finds on it is :data:`MIN_LOAD_AIM` above the minimum
    power (every leg within :data:`MIN_LOAD_SLACK`: done). The weather met moves with the schedule, so the rounds
    are a fixed point, not a closed form; the least-fuel verified plan of the rounds is returned.

    Returns
    -------
    Plan or None
        None when the ship has no minimum power, or no round verifies (a band at those speeds, the weather's end).
    """
    pmin = float(ctx.model.min_power_kw)
    wp = np.asarray(waypoints, dtype=float)
    if not pmin > 0.0:
        return None
    v0 = float(np.clip(ctx.ship.calm_speed_kn(pmin), v_min_kn, v_max_kn))
    stw = np.full(wp.shape[0] - 1, v0)
    best: Plan | None = None
    for _ in range(MIN_LOAD_ROUNDS):
        plan = evaluated_plan(ctx, wp, stw, departure, step_nm, "start")
        if plan is None:
            return best
        found = plan.verify(step_nm=step_nm)
        if any(v.kind not in ENGINE_KINDS for v in found):
            return best
        pts = found.points
        ok = np.isfinite(pts.power)
        lowest = np.full(stw.size, np.inf)
        np.minimum.at(lowest, pts.leg[ok], pts.power[ok])
        if not found and (best is None or plan.total_fuel_t < best.total_fuel_t):
            best = plan
            if np.all(lowest <= pmin * (1.0 + MIN_LOAD_SLACK)):
                break
        stw = np.clip(propeller_speed(stw, pmin * (1.0 + MIN_LOAD_AIM), lowest), v_min_kn, v_max_kn)
    return best


def track_warm_start(waypoints: np.ndarray, stw_kn: np.ndarray, frame: CorridorFrame) -> dict[str, np.ndarray]:
    """A track and its speeds as a warm start on the NLP's legs: lateral offsets and leg speeds.

    The track's vertices are projected on the centreline; its cross-track offset is interpolated
    (linearly in along-track distance) at the corridor's waypoints and clipped to the half-width;
    each NLP leg takes the speed that sails it in the time the track takes over the same stretch
    (:func:`_time_kept_speeds`; the track's arrival is kept where its legs and the NLP's differ), or, for a
    track that doubles back along the centreline, the speed of the track leg nearest its midpoint.
    """
    wp = np.asarray(waypoints, dtype=float)
    stw = np.asarray(stw_kn, dtype=float)
    centre = frame.corridor.waypoints
    s_t, xt_t, _, _ = project_to_polyline(centre, wp[:, 0], wp[:, 1])
    order = np.argsort(s_t, kind="stable")
    offset = -np.interp(frame.s_nm, s_t[order], xt_t[order])  # port-positive
    hw = np.asarray(frame.corridor.half_width_nm, dtype=float)
    offset = np.clip(offset, -hw, hw)
    offset[0] = offset[-1] = 0.0
    speed = _time_kept_speeds(s_t, stw, frame.s_nm) if np.all(np.diff(s_t) > 0) else np.full(frame.n_legs, np.nan)
    if not np.all(np.isfinite(speed)):  # a track that doubles back along the centreline: the nearest leg's speed
        mid_lat = 0.5 * (centre[:-1, 0] + centre[1:, 0])
        mid_lon = units.wrap_180(centre[:-1, 1] + 0.5 * units.wrap_180(centre[1:, 1] - centre[:-1, 1]))
        _, _, _, k = project_to_polyline(wp, mid_lat, mid_lon)
        speed = stw[np.clip(k, 0, stw.size - 1)]
    fallback = float(np.nanmean(stw[np.isfinite(stw) & (stw > 0)])) if np.any(np.isfinite(stw) & (stw > 0)) else 10.0
    speed = np.where(np.isfinite(speed) & (speed > 0), speed, fallback)
    return {"offset_nm": offset, "stw_kn": speed}


def warm_is_plan(cand: Candidate, frame: CorridorFrame) -> bool:
    """Whether a candidate's warm start on the NLP's legs is its verified plan itself: the same waypoints (to 1e-9°)
    and speeds (to 1e-9 kn). True of the starts made on the NLP's legs (the centreline start, the minimum-time plan);
    false of a track mapped onto them (:func:`track_warm_start`: a 3-D DP's plan on its own stages takes one speed per
    NLP leg), whose warm start the referee has not passed."""
    plan = cand.plan
    if plan is None:
        return False
    stw = np.asarray(cand.warm["stw_kn"], dtype=float)
    wp = np.asarray(plan.waypoints, dtype=float)
    if np.shape(plan.stw_kn) != stw.shape or wp.shape[0] != frame.n_legs + 1:
        return False
    track = np.asarray(frame.waypoints(np.asarray(cand.warm["offset_nm"], dtype=float)), dtype=float)
    return bool(np.allclose(plan.stw_kn, stw, rtol=0.0, atol=1e-9) and np.allclose(wp, track, rtol=0.0, atol=1e-9))


def _time_kept_speeds(s_track_nm: np.ndarray, stw_kn: np.ndarray, s_legs_nm: np.ndarray) -> np.ndarray:
    """Each NLP leg's speed [kn] that sails it in the time the track's own speeds take over the same stretch of the
    centreline (``s_legs_nm`` (N+1,) its ends; ``s_track_nm`` (M+1,) the track's vertices projected on it,
    increasing; ``stw_kn`` (M,) its legs' speeds): the distance-weighted harmonic mean of the track's speeds over
    the leg. NaN where a track speed is not positive and finite."""
    hours = np.concatenate([[0.0], np.cumsum(np.diff(s_track_nm) / np.where(stw_kn > 0, stw_kn, np.nan))])
    s = np.clip(s_legs_nm, s_track_nm[0], s_track_nm[-1])
    t = np.interp(s, s_track_nm, hours)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.diff(s_legs_nm) / np.diff(t)


def great_circle_corridor(frame: CorridorFrame, tol_nm: float = 0.5) -> bool:
    """Whether the corridor's centreline is one great circle from its start to its end (the 3-D DP's geometry)."""
    wp = frame.corridor.waypoints
    if wp.shape[0] <= 2:
        return True
    _, xt, _, _ = project_to_polyline(np.vstack([wp[0], wp[-1]]), wp[:, 0], wp[:, 1])
    return bool(np.max(np.abs(xt)) <= tol_nm)


def corridor_stations(frame: CorridorFrame, dx_nm: float, per_side: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 3-D DP's stages along a corridor whose centreline is not one great circle (``stations`` of
    :func:`optroute.search.dp.solve_dp`).

    The stations are centreline waypoints, chosen from the start: each is the farthest waypoint at most ``dx_nm``
    along from the last whose chord (the great circle between the two) keeps every centreline waypoint between
    within ``tol`` of it, ``tol`` :data:`CHORD_TOL_SHARE` of the least half-width (at least
    :data:`CHORD_TOL_MIN_NM`), so that the stages follow the bends. Each station has ``per_side`` lateral states
    each side on the corridor's bisecting normal there, evenly apart, the outermost inside the least half-width by
    ``tol`` and the bulge of a chord between two offset points (:func:`~optroute.geo.tracks.inner_offset_nm`): a DP
    leg stays in the corridor.

    Returns
    -------
    lat_deg, lon_deg : numpy.ndarray, shape (K+1, 2n+1)
        The lateral states of every stage [deg].
    lateral_nm : numpy.ndarray, shape (2n+1,)
        Their offsets [nm, starboard +].
    """
    wp = frame.corridor.waypoints
    s_nm = frame.s_nm
    hw = np.asarray(frame.corridor.half_width_nm, dtype=float) * np.ones(wp.shape[0])
    half = float(np.min(hw[1:-1])) if wp.shape[0] > 2 else 0.0
    tol = max(CHORD_TOL_SHARE * half, CHORD_TOL_MIN_NM)
    nodes, i = [0], 0
    while i < wp.shape[0] - 1:
        j = i + 1
        while j + 1 < wp.shape[0] and s_nm[j + 1] - s_nm[i] <= dx_nm:
            _, xt, _, _ = project_to_polyline(wp[[i, j + 1]], wp[i + 1 : j + 1, 0], wp[i + 1 : j + 1, 1])
            if np.max(np.abs(xt)) > tol:
                break
            j += 1
        nodes.append(j)
        i = j
    k = np.asarray(nodes)
    longest = float(np.max(np.diff(s_nm[k])))
    room = max(inner_offset_nm(half, longest) - tol, 0.0)
    p = int(per_side) if room > 0.0 else 0
    lateral = room * (np.arange(2 * p + 1) - p) / max(p, 1)
    lat, lon = frame.normal_points(k[:, None], -lateral[None, :])  # port + in the frame
    return np.asarray(lat, dtype=float), np.asarray(lon, dtype=float), lateral


#: Labels the start stage's 3-D DP keeps per (stage, lateral, arrival bin) for fuel or cost: up to 4 of the bin's
#: Pareto set on (fuel, time), cheapest first (:func:`optroute.search.solve_dp`'s ``labels_per_bin``). With one, a
#: cheaper label that arrives later wins a bin on the way and the route that meets the ETA more cheaply is lost; 4
#: costs the DP about twice its CPU. A minimum time ranks its bins by arrival (``label_value="time"``) and keeps one.
DP_LABELS_PER_BIN = 4


def dp_route(
    ctx: PlanContext,
    frame: CorridorFrame,
    *,
    departure: np.datetime64,
    eta: np.datetime64 | None,
    objective: str,
    v_min_kn: float,
    v_max_kn: float,
    fuel_price: float,
    hourly: float,
    options: dict[str, Any] | None = None,
) -> Route | None:
    """The 3-D DP's least-fuel (or cost) route on the corridor by the ETA; None where it finds none.

    With ``objective="time"`` and no ETA: its earliest route within the weather's span (the free-arrival
    minimum time's start where no local start verifies, :mod:`optroute.optimise.start_stage`), the top speed
    ``v_max_kn`` on its ladder. Where the DP reaches no end state at all within the weather's span,
    :class:`~optroute.errors.NoSafePassage` whose message states the lattice searched: a statement about that
    lattice, not about every passage (the caller keeps it as such).

    Resolution (``options`` overrides, keys of :func:`optroute.search.dp.solve_dp` via ``dp_options``
    plus ``speed_step_kn``): stages about 1/12 of the corridor apart (at least 20 nm; on a centreline that is not
    one great circle, at its waypoints, :func:`corridor_stations`), 3 lateral states per side of the half-width
    (the outer ones inside it by the bulge of a leg between two of them,
    :func:`optroute.geo.tracks.inner_offset_nm`, so that the legs stay in the corridor), 1 h time bins, speeds
    every 2 kn over the NLP's range, and for fuel or cost :data:`DP_LABELS_PER_BIN` labels per arrival bin (one per
    bin, the DP's default, loses routes: a cheaper label that arrives later wins a bin on the way). A start, not the
    answer: it has to find the side of a storm or band, and the NLP refines it; where the NLP's plan is rejected by
    the referee in a storm this start is the plan returned, so its quality shows in the result.
    """
    from optroute.search.routing import search_route

    wp = frame.corridor.waypoints
    length = float(frame.s_nm[-1])
    half = float(np.max(frame.corridor.half_width_nm))
    opts = dict(options or {})
    step = float(opts.pop("speed_step_kn", 2.0))
    # the DP's legs join lateral states on the stages; a leg between two edge states bulges beyond them (a great
    # circle between two points of a parallel), so the edge states lie inside the half-width by that bulge and
    # the DP's plan stays in the corridor the referee checks; as many states per side as the half-width holds
    dx = float(opts.get("dx_nm", max(20.0, length / 12.0)))
    hw = float(opts.get("half_width_nm", half))
    dy = float(opts.get("dy_nm", max(hw / 3.0, 1.0)))
    inner = inner_offset_nm(hw, dx)
    per_side = int(np.floor(hw / dy + 1e-9)) if dy > 0 else 0
    labels = {} if objective == "time" else {"labels_per_bin": DP_LABELS_PER_BIN}
    dp_opts = {"dx_nm": dx, "dt_h": 1.0, **labels, **opts, "half_width_nm": inner}
    dp_opts["dy_nm"] = min(dy, inner / per_side) if per_side > 0 else dy
    if not great_circle_corridor(frame):  # the stages follow the centreline's bends
        stations = corridor_stations(frame, dx, per_side)
        dp_opts["stations"] = stations
        per_side = stations[2].size // 2
        dp_opts["dx_nm"] = float(np.max(geo.distance_nm(stations[0][:-1, per_side], stations[1][:-1, per_side],
                                                        stations[0][1:, per_side], stations[1][1:, per_side])))  # fmt: skip
        dp_opts["dy_nm"] = float(np.diff(stations[2])[0]) if per_side > 0 else dp_opts["dy_nm"]
    speeds = np.arange(max(v_min_kn, 3.0), v_max_kn + 1e-9, step)
    if objective == "time":  # racing past a storm can need the top speed itself (harness seed 20: 15.48 kn, not 15)
        speeds = np.unique(np.append(speeds, v_max_kn))
    try:
        return search_route(
            (float(wp[0, 0]), float(wp[0, 1])),
            (float(wp[-1, 0]), float(wp[-1, 1])),
            ctx.sampler,
            ctx.ship,
            departure=departure,
            objective=objective if objective in ("cost", "time") else "fuel",
            eta=eta,
            method="dp",
            speeds_kn=speeds,
            fuel_price_per_t=fuel_price,
            hourly_cost_per_h=hourly,
            model=ctx.model,
            rules=ctx.rules,
            use_land_mask=ctx.use_land_mask,
            dp_options=dp_opts,
        )
    except NoSafePassage as exc:  # no route at all within the weather's span: a statement about this lattice
        n_lat = 2 * per_side + 1 if inner > 0 else 1
        lattice = (
            f"stages about {dp_opts['dx_nm']:.3g} nm apart, {n_lat} lateral position{'s' * (n_lat > 1)}"
            + (f" {dp_opts['dy_nm']:.3g} nm apart" if n_lat > 1 else "")
            + f", one speed over ground per stage every {step:g} kn from {speeds[0]:g} to {speeds[-1]:.4g} kn, arrivals "
            f"in {float(dp_opts['dt_h']):g} h bins keeping the cheapest of each, and the earliest arrival at each "
            "position"
        )
        raise NoSafePassage(f"on the 3-D DP's lattice of this corridor ({lattice}) {exc}") from exc
    except OptrouteError:  # no passage by the ETA on the DP's grid: the other candidates remain
        return None


def route_stw(route: Route) -> np.ndarray:
    """A route's speeds through water per leg [kn] (its SOG where the STW is not known)."""
    stw = np.asarray(route.stw_kn, dtype=float)
    return np.where(np.isfinite(stw) & (stw > 0), stw, np.asarray(route.sog_kn, dtype=float))


def plan_distance_nm(plan: Plan) -> float:
    """Length of a plan's track [nm]."""
    wp = np.asarray(plan.waypoints, dtype=float)
    return float(np.sum(geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])))
