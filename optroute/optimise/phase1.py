"""What a corridor solve that found nothing learns from the elastic phase-1 problem (issue 13 item 3, issue 14 item 4).

When the first solve fails and no start verifies, :func:`optroute.optimise.rescue.first_failure` tries
the minimum-time solve from several starts; where every one fails it used to raise
:class:`~optroute.errors.SolverFailure`, which says nothing about the passage. :func:`diagnose`
solves the elastic problem of the same NLP (:func:`formulations.phase1.solve_phase1`: slacks on the
load, band, exclusion and ETA rows, the same model and rows) from the failed solve's start, and at its
optimum:

* a load or band slack > 0 on a leg where the **true model** (the referee's physics) allows no constant
  speed all along the leg, entered where and when phase-1 enters it, to any end across the corridor
  (:func:`_leg_closed`): :class:`~optroute.errors.NoSafePassage` naming the leg, the position and the
  time;
* the safety slacks 0 and the ETA slack > 0: :class:`~optroute.errors.InfeasibleETA` with the
  earliest arrival phase-1 found (the caller, :func:`optroute.optimise.api.optimise_corridor`, checks it
  against the verified minimum-time plan);
* every slack 0: the point is a feasible start; the real problem is solved again from it.

A slack > 0 that the true model does not confirm (the NLP's table or sides, not the sea) is not
claimed: the caller's SolverFailure stands.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from formulations.phase1 import SLACK_TOL, Phase1Result, solve_phase1
from formulations.speed_nlp import SpeedNLP
from optroute import geodesy as geo
from optroute import units
from optroute.errors import InfeasibleETA, NoSafePassage, WeatherCoverageError
from optroute.geo.tracks import gc_points
from optroute.optimise.nlp_solve import Problem, Solved
from optroute.physics.passage import evaluate_speeds
from optroute.plan.evaluate import PlanContext, sample_sea
from optroute.units import h_to_timedelta as _h_to_td

__all__ = ["PROOF_STEP_KN", "diagnose"]

#: Speed ladder of the true model's check of a leg phase-1 could not clear [kn].
PROOF_STEP_KN = 0.1
#: End offsets across the corridor of that check.
PROOF_OFFSETS = 9
#: Legs with a safety slack checked by the true model, the earliest first.
PROOF_LEGS = 8
#: Phase-1 solves, each with the bands added where they apply at the last one's point.
APPLICABILITY_ROUNDS = 3


def _leg_closed(prob: Problem, ctx: PlanContext, res: Phase1Result, t0: np.datetime64, leg: int) -> bool:
    """Whether the true model allows no constant speed on ``leg`` entered where and when phase-1 enters it.

    Every speed through water on a :data:`PROOF_STEP_KN` ladder over the NLP's range, to every end offset on
    a ladder of :data:`PROOF_OFFSETS` across the corridor, the leg sailed from phase-1's waypoint ``leg`` at
    phase-1's time there, checked every nm (timing by the speed through water): closed when no (speed,
    end) pair has every point allowed (:func:`optroute.physics.passage.evaluate_speeds`: bands, load range,
    course held, sea navigable).
    """
    frame = prob.frame
    y = np.asarray(res.offset_nm, dtype=float)
    ends = np.unique(np.linspace(prob.y_lo[leg + 1], prob.y_hi[leg + 1], PROOF_OFFSETS))
    speeds = np.arange(prob.v_min, prob.v_max + 1e-9, PROOF_STEP_KN)
    start = frame.waypoints(y)[leg]
    t_leg = float(res.time_h[leg])
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
        if np.any(np.all(allowed.reshape(speeds.size, f.size), axis=1)):
            return False
    return True


def _no_safe_passage(prob: Problem, ctx: PlanContext, res: Phase1Result, t0: np.datetime64, log: list[str]) -> None:
    """Raise :class:`NoSafePassage` at the first leg (of at most :data:`PROOF_LEGS` with a safety slack, in sailing
    order) the true model closes (:func:`_leg_closed`); return when none is."""
    for leg in res.slack_legs()[:PROOF_LEGS]:
        kind, leg, frac, time_h, slack = res.worst(int(leg))
        blocked = _leg_closed(prob, ctx, res, t0, leg)
        log.append(f"phase-1: {kind} slack {slack:.3g} on leg {leg} at {frac:.3f} of it, {time_h:.2f} h; true model: "
                   + ("no constant speed allowed on the leg" if blocked else "a speed is allowed"))  # fmt: skip
        if not blocked:
            continue
        wp = prob.frame.waypoints(res.offset_nm)
        lat, lon, _ = gc_points(
            wp[leg : leg + 1, 0], wp[leg : leg + 1, 1], wp[leg + 1, 0], wp[leg + 1, 1], np.array([frac])
        )
        when = units.format_utc(t0 + _h_to_td(time_h))
        raise NoSafePassage(
            f"no speed through the water from {prob.v_min:g} to {prob.v_max:.1f} kn is allowed all along leg {leg} "
            f"entered at {units.format_utc(t0 + _h_to_td(float(res.time_h[leg])))} ({kind}, worst at "
            f"({float(lat[0]):.3f}, {float(lon[0]):.3f}) at {when}, {time_h:.2f} h after departure; every end of "
            "the leg across the corridor tried; the time the leg is entered is the elastic phase-1 problem's, a "
            "local optimum): no safe passage through this corridor in this weather was found; take another "
            "route, a wider corridor or another departure"
        )


def _applicable_phase1(nlp: SpeedNLP, y0: np.ndarray, v0: np.ndarray, cap_h: float | None) -> Phase1Result:
    """Phase-1 with the bands imposed where they apply at its own point: where its samples moved (in time, across)
    into seas over a band's threshold, the band is added there and phase-1 solved again from its point, at most
    :data:`APPLICABILITY_ROUNDS` times (the NLP's own rule, :meth:`SpeedNLP.default_sides`)."""
    applies = nlp.default_sides(nlp.evaluate(y0, v0, nlp.consistent_times(y0, v0)))[1]
    for _ in range(APPLICABILITY_ROUNDS):
        res = solve_phase1(nlp, applies=applies, eta_h=cap_h, offset0_nm=y0, stw0_kn=v0)
        now = nlp.default_sides(nlp.evaluate(res.offset_nm, res.stw_kn, res.time_h))[1]
        if not res.success or not np.any(now & ~applies):
            break
        applies, y0, v0 = applies | now, res.offset_nm, res.stw_kn
    return res


def diagnose(
    prob: Problem,
    nlp: SpeedNLP,
    *,
    ctx: PlanContext,
    warm: Mapping[str, np.ndarray],
    cap_h: float | None,
    eta_user_h: float | None,
    t0: np.datetime64,
    budget: int,
    solve_kw: Mapping[str, Any],
    log: list[str],
) -> Solved | None:
    """The elastic phase-1 problem from ``warm``: raise what it proves, else a solve from its feasible point, else None.

    Raises
    ------
    NoSafePassage
        A sample where phase-1 keeps a safety slack and the true model allows no speed.
    InfeasibleETA, WeatherCoverageError
        Phase-1 is safe but arrives after the ETA (after the weather's span without an ETA).
    """
    y0 = np.clip(np.asarray(warm["offset_nm"], dtype=float), *nlp.corridor.offset_bounds())
    v0 = np.clip(np.asarray(warm["stw_kn"], dtype=float), nlp.v_min_kn, nlp.v_max_kn)
    try:
        res = _applicable_phase1(nlp, y0, v0, cap_h)
    except RuntimeError as exc:  # CasADi cannot build its derivatives (see the report): the caller's failure stands
        log.append(f"phase-1 not built: {str(exc).splitlines()[0][:160]}")
        return None
    log.append(
        f"phase-1: Ipopt {res.status}, largest safety slack {res.safety_slack:.3g}, ETA slack {res.eta_slack_h:.3g} h"
    )
    if not res.success:
        return None
    if res.safety_slack > SLACK_TOL:
        _no_safe_passage(prob, ctx, res, t0, log)
        return None
    if res.eta_slack_h > SLACK_TOL and cap_h is not None:
        arrival_h = float(res.time_h[-1])
        earliest = t0 + _h_to_td(arrival_h)
        if eta_user_h is None:
            raise WeatherCoverageError(
                f"the passage cannot be completed within the weather's time span ({cap_h:.1f} h after departure): "
                f"the earliest safe passage phase-1 found arrives {arrival_h:.1f} h after departure, at "
                f"{units.format_utc(earliest)}; extend the forecast or pass an ETA"
            )
        raise InfeasibleETA(
            f"the ETA {cap_h:.2f} h after departure cannot be met: the earliest safe passage the elastic phase-1 "
            f"problem found arrives {arrival_h:.2f} h after departure, at {units.format_utc(earliest)}; give an "
            "ETA at or after that, or widen the corridor",
            earliest_arrival=earliest,
        )
    again = prob.solve(
        nlp, eta_h=cap_h, warm={"offset_nm": res.offset_nm, "stw_kn": res.stw_kn}, budget=budget, **solve_kw
    )
    log.append(f"solve from the phase-1 point: Ipopt {again.res.status}")
    return again if again.ok else None
