"""The corridor NLP's rows where the referee checks (issue 13 item 3).

The NLP (:class:`formulations.speed_nlp.SpeedNLP`) imposes its engine-load, danger-band and exclusion
rows at samples along every leg; the referee (:meth:`optroute.plan.result.Plan.verify`) checks the
plan at its own check points (:func:`optroute.plan.checkpoints.check_points`): the leg ends, both
sides of every crossing of the weather's grid rows, columns and time slices, and points added where a
band's ratio nears its edge. Rows only at the NLP's midpoints leave the leg ends and the crossings
unconstrained, so a converged plan can be rejected there (the harness's seeds 4 and 5: a band at the
waypoint shared by two legs).

:func:`referee_rows` takes the referee's check points *of the start's own plan* (its track and speeds
on the NLP's legs, checked by ``Plan.verify``: one source of the positions, nothing re-derived here)
and keeps them as fractions of each leg (:func:`optroute.plan.checkpoints.row_points`);
:func:`sample_layout` adds them to the NLP's midpoint quadrature as row-only samples
(:func:`formulations.sample_layout.with_points`). As fractions of the leg they move with its ends
when Ipopt moves the offsets; the crossings of the time slices move with the schedule, so after a
rejected solve the rows are taken again from the rejected plan's check points.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from formulations.sample_layout import SampleLayout, midpoint_layout, with_points
from optroute import geodesy as geo
from optroute.errors import OptrouteError
from optroute.optimise.nlp_inputs import CorridorFrame
from optroute.plan.checkpoints import CheckPoints, row_points
from optroute.plan.result import Plan, PlanContext

__all__ = ["MAX_ROW_POINTS", "ROW_PLACEMENTS", "canonical_rows", "points_of", "referee_rows", "sample_layout"]

#: Row-only points per leg at most (:func:`formulations.sample_layout.with_points`).
MAX_ROW_POINTS = 16
#: Where :class:`~optroute.optimise.corridor_problem.PreparedCorridor` puts the NLP's rows.
ROW_PLACEMENTS = ("referee", "midpoints")


def points_of(pts: CheckPoints, waypoints: np.ndarray) -> list[np.ndarray]:
    """Per leg, the fractions of the referee's check points ``pts`` of a plan on ``waypoints`` (N+1, 2) [deg]."""
    wp = np.asarray(waypoints, dtype=float)
    d = geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
    return row_points(pts, d)


def referee_rows(
    ctx: PlanContext,
    frame: CorridorFrame,
    warm: Mapping[str, np.ndarray],
    departure: np.datetime64,
    step_nm: float,
) -> list[np.ndarray] | None:
    """The referee's check points of a start (offsets [nm, port +] and leg speeds [kn] on the NLP's legs).

    Returns per leg the fractions along it (:func:`optroute.plan.checkpoints.row_points`), or None where
    the start cannot be evaluated (speeds not positive, a track the weather does not cover): the NLP then
    keeps its midpoint rows.
    """
    stw = np.asarray(warm["stw_kn"], dtype=float)
    if not np.all(np.isfinite(stw) & (stw > 0)):
        return None
    wp = frame.waypoints(np.asarray(warm["offset_nm"], dtype=float))
    try:
        plan = Plan.from_context(ctx, wp, stw, departure=departure, status="candidate", step_nm=step_nm)
        pts = plan.verify(step_nm=step_nm).points
    except OptrouteError:  # a start that cannot be evaluated: the midpoint rows remain
        return None
    return points_of(pts, wp)


def canonical_rows(
    ctx: PlanContext,
    frame: CorridorFrame,
    bounds_nm: tuple[np.ndarray, np.ndarray],
    speed_kn: float,
    departure: np.datetime64,
    step_nm: float,
) -> list[np.ndarray] | None:
    """The row points a prepared corridor keeps for all its solves: the referee's check points of a canonical start.

    The start is the centreline (clipped into the lateral ``bounds_nm`` (low, high) [nm, port +]) at the constant
    speed through water ``speed_kn`` [kn] (the caller's: the one arriving at the prepared corridor's latest ETA).
    Taken from the prepared inputs alone, never from a solve, so that a solve's result depends on its own inputs
    only — not on which ETAs were solved before it in the process (a front is the same serial and on workers) —
    and one build serves every ETA.  The grid-line crossings are the same fractions of the legs at any speed; the
    time-slice crossings are the canonical start's.  A plan the referee rejects moves the rows to its own check
    points for the next attempt (:func:`points_of`).
    """
    n = frame.n_legs
    warm = {"offset_nm": np.clip(np.zeros(n + 1), *bounds_nm), "stw_kn": np.full(n, float(speed_kn))}
    return referee_rows(ctx, frame, warm, departure, step_nm)


def sample_layout(points: list[np.ndarray] | None, n_legs: int, samples_per_leg: int) -> SampleLayout:
    """The NLP's samples: ``samples_per_leg`` midpoints per leg (the quadrature) and ``points`` as row-only samples."""
    base = midpoint_layout(n_legs, samples_per_leg)
    if points is None:
        return base
    return with_points(base, points, max_points=MAX_ROW_POINTS)
