"""The elastic phase-1 problem on a corridor: a start where none verifies, and what it proves (issue 13 item 3, issue 14 item 4).

When the first solve fails and no start candidate verifies,
:func:`optroute.optimise.rescue.first_failure` solves the elastic problem of the same NLP
(:class:`formulations.phase1.Phase1Problem`: slacks on the load, band, exclusion and ETA rows, the same
model, rows and derivatives) from the failed solve's start (:func:`phase1_point`). At its optimum:

* a load or band slack > 0 on the first leg where the **true model** (the referee's physics) allows no
  constant speed all along it, entered at departure, to any end across the corridor
  (:func:`_allowed_on_leg`): :class:`~optroute.errors.NoSafePassage` naming the leg, the position and the
  time (a later leg is entered at phase-1's time, which proves nothing of other passages);
* a slack > 0 that the true model does not confirm (the NLP's table or sides, not the sea): phase-1
  starts again with those legs at the true model's nearest allowed speed (:data:`REPAIR_ROUNDS`); else
  nothing is claimed, no point is returned (the caller's SolverFailure stands);
* every safety slack 0: its point is a safe start (its band sides the sides it is on); an ETA slack > 0
  says that from there the ETA is not met, and the caller solves for the minimum time from that point
  (:func:`infeasible_eta` words the outcome).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from formulations.phase1 import SLACK_TOL, Phase1Problem, Phase1Result
from formulations.speed_nlp import SpeedNLP
from optroute import geodesy as geo
from optroute import units
from optroute.errors import InfeasibleETA, NoSafePassage, WeatherCoverageError
from optroute.geo.tracks import gc_points
from optroute.optimise.nlp_solve import Problem
from optroute.physics.passage import evaluate_speeds
from optroute.plan.evaluate import PlanContext, sample_sea
from optroute.units import h_to_timedelta as _h_to_td

__all__ = ["PROOF_STEP_KN", "infeasible_eta", "phase1_point"]

#: Speed ladder of the true model's check of a leg phase-1 could not clear [kn].
PROOF_STEP_KN = 0.1
#: End offsets across the corridor of that check.
PROOF_OFFSETS = 9
#: Legs with a safety slack checked by the true model, the earliest first.
PROOF_LEGS = 8
#: Phase-1 restarts from its point with the legs it could not clear at the true model's nearest allowed speed.
REPAIR_ROUNDS = 2
#: Entry-time ladder of a leg phase-1 enters when the true model allows no speed on it [h].
RETIME_STEP_H = 0.25
#: Phase-1 solves, each with the bands added where they apply at the last one's point.
APPLICABILITY_ROUNDS = 3


def _allowed_on_leg(
    prob: Problem, ctx: PlanContext, res: Phase1Result, t0: np.datetime64, leg: int, shift_h: float = 0.0
) -> tuple[float, float] | None:
    """The true model's allowed (speed [kn], end offset [nm]) on ``leg`` entered where phase-1 enters it and
    ``shift_h`` [h] after it does, nearest phase-1's own; None when it allows none (the leg is closed then).

    Every speed through water on a :data:`PROOF_STEP_KN` ladder over the NLP's range, to every end offset on
    a ladder of :data:`PROOF_OFFSETS` across the corridor, the leg sailed from phase-1's waypoint ``leg`` at
    phase-1's time there, checked every nm (timing by the speed through water): a (speed, end) pair is allowed
    when every point is (:func:`optroute.physics.passage.evaluate_speeds`: bands, load range, course held, sea
    navigable). Nearest: in speed, then in end offset.
    """
    frame = prob.frame
    y = np.asarray(res.offset_nm, dtype=float)
    ends = np.unique(np.linspace(prob.y_lo[leg + 1], prob.y_hi[leg + 1], PROOF_OFFSETS))
    speeds = np.arange(prob.v_min, prob.v_max + 1e-9, PROOF_STEP_KN)
    start = frame.waypoints(y)[leg]
    t_leg = float(res.time_h[leg]) + shift_h
    found: list[tuple[float, float, float, float]] = []
    for e in ends:
        yy = y.copy()
        yy[leg + 1] = e
        end = frame.waypoints(yy)[leg + 1]
        length = float(geo.distance_nm(start[0], start[1], end[0], end[1]))  # [nm]
        f = np.linspace(0.0, 1.0, max(2, int(np.ceil(length)) + 1))
        lat, lon, course = gc_points(np.full(f.size, start[0]), np.full(f.size, start[1]), end[0], end[1], f)
        v = np.repeat(speeds, f.size)
        ff = np.tile(f, speeds.size)
        when = t0 + _h_to_td(t_leg + ff * length / v)
        sea, covered = sample_sea(ctx.sampler, when, np.tile(lat, speeds.size), np.tile(lon, speeds.size))
        allowed = evaluate_speeds(ctx.ship, ctx.model, ctx.rules, np.tile(course, speeds.size), sea, v)[4] & covered
        ok = speeds[np.all(allowed.reshape(speeds.size, f.size), axis=1)]
        found += [(abs(float(u) - float(res.stw_kn[leg])), abs(float(e) - float(y[leg + 1])), float(u), float(e))
                  for u in ok]  # fmt: skip
    if not found:
        return None
    best = min(found)
    return best[2], best[3]


def _entry_window(prob: Problem, ctx: PlanContext, res: Phase1Result, t0: np.datetime64, leg: int) -> np.ndarray:
    """Every time [h after departure] the ship can enter ``leg`` from phase-1's waypoints, every :data:`RETIME_STEP_H`:
    from the earliest (the NLP's top speed through water plus the strongest current) to the latest (its lowest speed
    less that current) or the weather's end, whichever is first."""
    wp = prob.frame.waypoints(np.asarray(res.offset_nm, dtype=float))
    before_nm = float(np.sum(geo.distance_nm(wp[:leg, 0], wp[:leg, 1], wp[1 : leg + 1, 0], wp[1 : leg + 1, 1])))
    current = prob.grid.current_along_kn
    drift_kn = 0.0 if current is None else float(np.max(np.hypot(current, prob.grid.current_across_kn)))
    first = before_nm / (prob.v_max + drift_kn)
    last = units.timedelta_to_h(ctx.sampler.extent["time"][1] - t0)
    if prob.v_min > drift_kn:
        last = min(last, before_nm / (prob.v_min - drift_kn))
    return np.arange(first, last + 1e-9, RETIME_STEP_H)


def _retimed(
    prob: Problem, ctx: PlanContext, res: Phase1Result, t0: np.datetime64, leg: int
) -> tuple[float, float, float] | None:
    """The entry time nearest phase-1's (:func:`_entry_window`) at which the true model allows a speed on ``leg``
    (:func:`_allowed_on_leg`): (shift [h], speed [kn], end offset [nm]); None when it allows none at any."""
    times = _entry_window(prob, ctx, res, t0, leg)
    t_leg = float(res.time_h[leg])
    for t in times[np.argsort(np.abs(times - t_leg), kind="stable")]:
        allowed = _allowed_on_leg(prob, ctx, res, t0, leg, float(t) - t_leg)
        if allowed is not None:
            return float(t) - t_leg, allowed[0], allowed[1]
    return None


def _no_safe_passage(
    prob: Problem, ctx: PlanContext, res: Phase1Result, t0: np.datetime64, log: list[str]
) -> dict[int, tuple[float, float, float]]:
    """Raise :class:`NoSafePassage` where the true model closes the first leg (:func:`_allowed_on_leg`) when phase-1
    keeps a slack there (entered at departure from the corridor's start: the proof holds for every passage); else
    the repairs of the legs with a slack (at most :data:`PROOF_LEGS`, in sailing order): leg ↦ (entry shift [h],
    speed [kn], end offset [nm]), the true model's allowed speed nearest phase-1's at phase-1's entry time, or
    else at the nearest entry time that allows one (:func:`_retimed`; the legs after the first retimed one are left
    to the next phase-1 solve). A later leg closed at phase-1's time only is no proof (the ship can enter it at
    another time: the beam-seas case of tests/test_band_suite.py); closed at every time it can be entered from a
    fixed start (:func:`_entry_window`), it is."""
    repairs: dict[int, tuple[float, float, float]] = {}
    for leg in res.slack_legs()[:PROOF_LEGS]:
        kind, leg, frac, time_h, slack = res.worst(int(leg))
        allowed = _allowed_on_leg(prob, ctx, res, t0, leg)
        fix = (0.0, *allowed) if allowed is not None else (_retimed(prob, ctx, res, t0, leg) if leg > 0 else None)
        log.append(f"phase-1: {kind} slack {slack:.3g} on leg {leg} at {frac:.3f} of it, {time_h:.2f} h; true model: "
                   + ("no constant speed allowed on the leg" if fix is None else
                      f"{fix[1]:.1f} kn to offset {fix[2]:.1f} nm allowed, entered {fix[0]:+.2f} h later"))  # fmt: skip
        if fix is not None:
            repairs[leg] = fix
            if fix[0] != 0.0:
                break
            continue
        if leg > 0 and prob.y_hi[leg] - prob.y_lo[leg] > 1e-9:  # its start could move across: no proof
            continue
        times = _entry_window(prob, ctx, res, t0, leg) if leg > 0 else np.zeros(1)
        window = (float(times[0]), float(times[-1])) if times.size else (0.0, 0.0)
        wp = prob.frame.waypoints(res.offset_nm)
        lat, lon, _ = gc_points(
            wp[leg : leg + 1, 0], wp[leg : leg + 1, 1], wp[leg + 1, 0], wp[leg + 1, 1], np.array([frac])
        )
        when = units.format_utc(t0 + _h_to_td(time_h))
        length_nm = float(geo.distance_nm(wp[leg, 0], wp[leg, 1], wp[leg + 1, 0], wp[leg + 1, 1]))
        entered = (
            f"entered at {units.format_utc(t0)}, the departure"
            if leg == 0
            else f"entered at any time from {units.format_utc(t0 + _h_to_td(window[0]))} (the earliest at the top "
            f"speed) to {units.format_utc(t0 + _h_to_td(window[1]))} (the latest at the lowest, or the weather's end), "
            f"every {RETIME_STEP_H:g} h"
        )
        raise NoSafePassage(
            f"no speed through the water from {prob.v_min:g} to {prob.v_max:.1f} kn is allowed all along leg {leg} "
            f"{entered} ({kind}, phase-1's worst point ({float(lat[0]):.3f}, {float(lon[0]):.3f}) at {when}, "
            f"{time_h:.2f} h after departure; every end of the leg across the corridor tried): no safe passage "
            f"through this corridor in this weather at one speed over each leg (this one {length_nm:.1f} nm long; a "
            "ship that changes speed inside it is not covered by this proof); take a shorter max_leg_nm, another "
            "route, a wider corridor or another departure"
        )
    return repairs


def _applicable_phase1(
    problem: Phase1Problem,
    y0: np.ndarray,
    v0: np.ndarray,
    cap_h: float | None,
    count: Callable[[Phase1Result], None],
) -> Phase1Result:
    """Phase-1 with the bands imposed where they apply at its own point: where its samples moved (in time, across)
    into seas over a band's threshold, the band is added there and phase-1 solved again from its point, at most
    :data:`APPLICABILITY_ROUNDS` times (the NLP's own rule, :meth:`SpeedNLP.default_sides`)."""
    nlp = problem.nlp
    applies = nlp.default_sides(nlp.evaluate(y0, v0, nlp.consistent_times(y0, v0)))[1]
    for _ in range(APPLICABILITY_ROUNDS):
        res = problem.solve(
            applies=applies,
            eta_h=cap_h,
            offset0_nm=y0,
            stw0_kn=v0,
        )
        count(res)
        now = nlp.default_sides(nlp.evaluate(res.offset_nm, res.stw_kn, res.time_h))[1]
        if not res.success or not np.any(now & ~applies):
            break
        applies, y0, v0 = applies | now, res.offset_nm, res.stw_kn
    return res


def phase1_point(
    prob: Problem,
    nlp: SpeedNLP,
    *,
    ctx: PlanContext,
    warm: Mapping[str, np.ndarray],
    cap_h: float | None,
    t0: np.datetime64,
    log: list[str],
) -> Phase1Result | None:
    """The elastic phase-1 problem from ``warm`` (ETA row at ``cap_h`` [h], elastic): its point when every safety
    slack is 0 (the ETA's may not be), None when it fails or keeps a slack the true model does not confirm.

    Every phase-1 solve counts in ``prob``'s solves and iterations (``solver_stats``).

    Raises
    ------
    NoSafePassage
        A leg where phase-1 keeps a safety slack and the true model allows no speed (:func:`_no_safe_passage`).
    """
    y_lo, y_hi = nlp.corridor.offset_bounds()
    y0 = np.clip(np.asarray(warm["offset_nm"], dtype=float), y_lo, y_hi)
    v0 = np.clip(np.asarray(warm["stw_kn"], dtype=float), nlp.v_min_kn, nlp.v_max_kn)
    problem = Phase1Problem(nlp)
    for _ in range(REPAIR_ROUNDS + 1):
        res = _applicable_phase1(problem, y0, v0, cap_h, prob.count)
        log.append(
            f"phase-1: Ipopt {res.status}, largest safety slack {res.safety_slack:.3g}, "
            f"ETA slack {res.eta_slack_h:.3g} h"
        )
        if not res.success:
            return None
        if res.safety_slack <= SLACK_TOL:
            return res
        # a slack the true model does not confirm: phase-1 stopped at a local optimum (a band's centre, where its
        # side-free row is stationary): it starts again with those legs at the true model's nearest allowed speed
        repairs = _no_safe_passage(prob, ctx, res, t0, log)
        if not repairs:
            return None
        y0, v0 = res.offset_nm.copy(), res.stw_kn.copy()
        for leg, (shift, speed, end) in repairs.items():
            if shift:  # the legs before it sailed slower or faster to enter it then
                v0[:leg] *= float(res.time_h[leg]) / (float(res.time_h[leg]) + shift)
            v0[leg] = speed
            y0[leg + 1] = float(np.clip(end, y_lo[leg + 1], y_hi[leg + 1]))
        v0 = np.clip(v0, nlp.v_min_kn, nlp.v_max_kn)
    return None


def infeasible_eta(arrival_h: float, *, cap_h: float, eta_user_h: float | None, t0: np.datetime64, what: str) -> None:
    """Raise that the ETA (or, without one, the weather's end) ``cap_h`` [h after departure] is not met by the
    earliest passage found, arriving ``arrival_h`` [h after departure]; ``what`` names that passage.

    Raises
    ------
    InfeasibleETA
        With an ETA; ``earliest_arrival`` is that arrival.
    WeatherCoverageError
        Without one: the passage cannot end inside the weather's time span.
    """
    earliest = t0 + _h_to_td(arrival_h)
    if eta_user_h is None:
        raise WeatherCoverageError(
            f"the passage cannot be completed within the weather's time span ({cap_h:.1f} h after departure): "
            f"{what} arrives {arrival_h:.1f} h after departure, at {units.format_utc(earliest)}; "
            "extend the forecast or pass an ETA"
        )
    raise InfeasibleETA(
        f"the ETA {cap_h:.2f} h after departure cannot be met: {what} arrives {arrival_h:.2f} h after departure, "
        f"at {units.format_utc(earliest)}; give an ETA at or after that, or widen the corridor",
        earliest_arrival=earliest,
    )
