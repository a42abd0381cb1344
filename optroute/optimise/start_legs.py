"""The NLP's legs cut at a discrete plan's own stages, so that the corridor NLP starts from that plan itself.

A free-arrival minimum time keeps the corridor's legs whole (:func:`optroute.optimise.rows.band_leg_for`), and where
no local start verifies its start is the 3-D DP's plan (:mod:`optroute.optimise.start_stage`), which changes speed
at every stage. Averaged onto 50 nm legs (:func:`~optroute.optimise.starts.track_warm_start`) such a plan, slowing
for a band at one stage, sails through the band at the leg's mean speed: on harness seed 10 the averaged start
arrives 1.3 h before the DP's verified plan and lies inside three bands, and Ipopt, started there, reports the
problem infeasible. :func:`plan_on_own_legs` cuts the legs where the plan changes speed or lateral offset (a run of
stages at one speed and offset is one leg), or, where that does not verify, at every stage, and verifies the plan
again on those legs: the NLP then starts from a plan the referee passed, with its band sides.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optroute.geo.tracks import project_to_polyline
from optroute.optimise.nlp_inputs import CorridorFrame, build_frame
from optroute.optimise.starts import track_warm_start, verified_plan
from optroute.plan.result import Plan, PlanContext

__all__ = ["OWN_LEGS_BAND_SOLVES", "OwnLegs", "plan_on_own_legs"]

#: The band-side search's budget of solves from a discrete plan on its own legs: the 3-D DP chose those sides on its
#: lattice across the whole corridor, so fewer flips are worth trying from them.
OWN_LEGS_BAND_SOLVES = 3

#: A change of lateral offset [nm] between a plan's vertices that makes a vertex a leg end.
OFFSET_CHANGE_NM = 0.01


@dataclass(frozen=True)
class OwnLegs:
    """A plan on legs cut at its own stages.

    Attributes
    ----------
    frame : CorridorFrame
        The corridor's legs cut there (on the centreline's great circles).
    warm : dict of str to numpy.ndarray
        ``offset_nm`` (N+1,) [nm, port +] and ``stw_kn`` (N,) [kn] of the plan on those legs.
    plan : Plan
        The plan on those legs, verified by the referee.
    """

    frame: CorridorFrame
    warm: dict[str, np.ndarray]
    plan: Plan


def plan_on_own_legs(
    ctx: PlanContext, frame: CorridorFrame, plan: Plan, departure: np.datetime64, step_nm: float
) -> OwnLegs | None:
    """``plan`` on ``frame``'s legs cut at its own vertices, verified again there.

    The cuts are first the vertices where the plan changes speed through water or lateral offset (by more than
    :data:`OFFSET_CHANGE_NM`), then every vertex.

    Parameters
    ----------
    ctx : PlanContext
        The solve's context (ship, model, rules, weather, ETA) the plan is verified in.
    frame : CorridorFrame
        The NLP's legs; the plan's vertices are projected on its centreline.
    plan : Plan
        A verified plan on the corridor (the 3-D DP's), its vertices anywhere along it.
    departure : numpy.datetime64
        Departure [UTC].
    step_nm : float
        The referee's check spacing [nm].

    Returns
    -------
    OwnLegs or None
        None where no vertex falls between ``frame``'s waypoints, or the plan verifies on neither cut.
    """
    wp = np.asarray(plan.waypoints, dtype=float)
    stw = np.asarray(plan.stw_kn, dtype=float)
    s_nm, xt_nm, _, _ = project_to_polyline(frame.corridor.waypoints, wp[:, 0], wp[:, 1])
    moved = np.abs(np.diff(xt_nm)) > OFFSET_CHANGE_NM
    turns = (np.abs(np.diff(stw)) > 1e-6) | moved[:-1] | moved[1:]
    for cuts in (s_nm[1:-1][turns], s_nm[1:-1]):
        corridor = frame.corridor.cut_at(cuts)
        if corridor is frame.corridor:
            continue
        cut = build_frame(corridor)
        warm = track_warm_start(wp, stw, cut)
        kept = verified_plan(ctx, cut.waypoints(warm["offset_nm"]), warm["stw_kn"], departure, step_nm, "start")
        if kept is not None:
            return OwnLegs(cut, warm, kept)
    return None
