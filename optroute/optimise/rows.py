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

Only rows that can bind are kept (:func:`binding_legs`): every leg keeps its ends (the engine load is checked
there with the leg's own speed), and the crossings and refinement points only where a danger band can apply
(Hs in the NLP's weather grid reaches the bands' threshold near the leg at some time) or the exclusion circle
comes within :data:`EXCLUSION_REACH_NM` of the leg's corridor. The NLP's arrays have as many samples on every
leg as on its busiest one, so this trims the legs' row points, not always the per-leg sample count.

The same test decides which legs carry band and exclusion rows at all (:func:`nlp_row_legs`, the NLP's
``band_legs`` and ``exclusion_legs``, :class:`formulations.row_layout.RowLegs`): on the others those rows would be
−∞…+∞ at every solve and still cost Ipopt and MUMPS at every iteration. It is taken per build, at the build's own
band thresholds and circle (a tightened Hs back-off or radius widens it), plus the legs the referee rejected a plan
on (``Tightening.forced_legs``).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from formulations.common import Band, MovingExclusion
from formulations.sample_layout import SampleLayout, midpoint_layout, with_points
from optroute import geodesy as geo
from optroute._checks import finite
from optroute.errors import ConfigError, OptrouteError
from optroute.optimise.nlp_inputs import CorridorFrame, formulation_bands, moving_exclusion
from optroute.physics.safety import BandRules
from optroute.physics.ship import Ship
from optroute.plan.checkpoints import CheckPoints, row_points
from optroute.plan.result import Exclusion, Plan, PlanContext

__all__ = [
    "MAX_ROW_POINTS",
    "ROW_PLACEMENTS",
    "canonical_rows",
    "BAND_LEG_NM",
    "band_leg_for",
    "binding_legs",
    "check_band_leg_nm",
    "cut_where_binding",
    "exclusion_legs",
    "nlp_row_legs",
    "legs_near_exclusion",
    "legs_that_can_bind",
    "only_where_binding",
    "points_of",
    "referee_rows",
    "sample_layout",
]

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


#: Slack on the bands' Hs threshold when deciding where a band can apply at all [-]: the NLP's weather is a cubic
#: B-spline quasi-interpolant of the grid nodes (it can rise above the largest node nearby, by far less than this).
HS_SLACK = 0.2
#: Distance beyond the exclusion's radius within which a leg keeps its exclusion rows [nm].
EXCLUSION_REACH_NM = 30.0


def legs_that_can_bind(
    s_nm: np.ndarray,
    grid_s_nm: np.ndarray,
    grid_hs_m: np.ndarray,
    hs_apply_m: float | None,
    near_exclusion: np.ndarray | None = None,
) -> np.ndarray:
    """Per leg, whether a band or the exclusion can bind anywhere on it; elsewhere the engine load alone can.

    Parameters
    ----------
    s_nm : ndarray, shape (N+1,)
        Along-track position of the centreline waypoints [nm].
    grid_s_nm : ndarray, shape (ns,)
        Along-track nodes of the NLP's weather grid [nm].
    grid_hs_m : ndarray, shape (nt, ns, ny)
        Hs at the grid's nodes [m], every time and lateral offset.
    hs_apply_m : float or None
        Hs from which the NLP applies a band [m] (the rules' threshold with the applicability back-off);
        None: no band enabled.
    near_exclusion : ndarray of bool, shape (N,), optional
        Legs within reach of the exclusion (:func:`legs_near_exclusion`).

    Returns
    -------
    ndarray of bool, shape (N,)
        A band can apply on leg k when Hs at some node within two grid cells of the leg (the support of the
        cubic B-spline the NLP reads the weather through), at any time and offset, reaches
        ``(1 − HS_SLACK) · hs_apply_m``. On a leg where none can, the NLP's band rows are inactive (its outer
        loop applies a band only where its own Hs reaches the threshold) and rows at the weather's crossings
        and near band edges constrain nothing the midpoints and leg ends do not.
    """
    s = np.asarray(s_nm, dtype=float)
    n = s.size - 1
    out = np.zeros(n, dtype=bool) if near_exclusion is None else np.asarray(near_exclusion, dtype=bool).copy()
    if hs_apply_m is None:
        return out
    gs = np.asarray(grid_s_nm, dtype=float)
    peak = np.max(np.asarray(grid_hs_m, dtype=float), axis=(0, 2))  # (ns,): over every time and offset
    lo = np.clip(np.searchsorted(gs, s[:-1], side="right") - 3, 0, gs.size - 1)
    hi = np.clip(np.searchsorted(gs, s[1:], side="left") + 3, 1, gs.size)
    for k in range(n):
        if np.nanmax(peak[lo[k] : hi[k]]) >= (1.0 - HS_SLACK) * hs_apply_m:
            out[k] = True
    return out


def legs_near_exclusion(
    centre_xy_nm: np.ndarray, half_width_nm: np.ndarray, circle_xy_nm: np.ndarray, radius_nm: np.ndarray
) -> np.ndarray:
    """Per leg, whether the exclusion circle comes within :data:`EXCLUSION_REACH_NM` of the leg's corridor at any time.

    ``centre_xy_nm`` (N+1, 2) are the centreline's waypoints and ``half_width_nm`` (N+1,) the corridor's half-widths
    [nm] in the NLP's flat frame; ``circle_xy_nm`` (nc, 2) and ``radius_nm`` (nc,) the circle's track in the same
    frame, sampled densely enough that the centre moves less than the reach between samples.
    """
    a, b = centre_xy_nm[:-1], centre_xy_nm[1:]
    ab = b - a
    c = np.asarray(circle_xy_nm, dtype=float)[:, None, :]
    t = np.clip(np.sum((c - a) * ab, axis=-1) / np.maximum(np.sum(ab * ab, axis=-1), 1e-12), 0.0, 1.0)
    dist = np.linalg.norm(c - (a + t[..., None] * ab), axis=-1)  # (nc, N)
    hw = np.maximum(half_width_nm[:-1], half_width_nm[1:])
    return np.any(dist - hw[None, :] <= np.asarray(radius_nm, dtype=float)[:, None] + EXCLUSION_REACH_NM, axis=0)


def binding_legs(
    frame: CorridorFrame,
    grid_s_nm: np.ndarray,
    grid_hs_m: np.ndarray,
    ship_rules_exclusion: tuple[Ship, BandRules, Exclusion | None],
    hs_margin: float,
    departure: np.datetime64,
) -> np.ndarray:
    """Per leg of a prepared corridor, whether a band or the exclusion can bind on it (:func:`legs_that_can_bind`).

    ``grid_s_nm`` and ``grid_hs_m`` are the NLP's weather grid (along-track nodes [nm], Hs (t, s, y) [m]),
    ``ship_rules_exclusion`` the ship, band rules and exclusion (or None), ``hs_margin`` the applicability back-off
    [-] (:func:`optroute.optimise.nlp_inputs.formulation_bands`), ``departure`` [UTC].
    """
    ship, rules, exclusion = ship_rules_exclusion
    bands, _, _ = formulation_bands(ship, rules, hs_margin=hs_margin)
    mv = moving_exclusion(exclusion, frame, departure) if exclusion is not None else None
    band, near = nlp_row_legs(frame, grid_s_nm, grid_hs_m, bands, mv)
    return band | near


#: The longest NLP leg where a danger band or the exclusion can bind [nm] (``band_leg_nm`` of
#: :func:`optroute.optimise_corridor`): the 3-D DP start's shortest stage spacing (:func:`optroute.optimise.starts.dp_route`).
BAND_LEG_NM = 20.0


def check_band_leg_nm(band_leg_nm: float) -> float:
    """``band_leg_nm`` [nm] as a float; ConfigError unless it is a finite length > 0."""
    return float(
        finite("band_leg_nm", band_leg_nm, minimum=0.0, strict=True, error=ConfigError,
               fix="give a length in nm (20 by default), or None to keep max_leg_nm on every leg")
    )  # fmt: skip


def band_leg_for(band_leg_nm: float | None, *, objective: str, eta_given: bool) -> float | None:
    """The ``band_leg_nm`` [nm] a corridor prepared for ``objective`` (with an ETA or not) is cut to, checked
    (:func:`check_band_leg_nm`); None where it keeps its legs whole: without a length, and for a free-arrival minimum
    time, whose 3-D DP start runs only where no local start verifies (cut legs let a poorer local start verify in its
    place: harness seeds 13 and 17)."""
    if band_leg_nm is None:
        return None
    step = check_band_leg_nm(band_leg_nm)
    return step if (eta_given or objective != "time") else None


def cut_where_binding(binding: np.ndarray, leg_nm: np.ndarray, band_leg_nm: float) -> np.ndarray | None:
    """Per leg, the longest piece [nm] it is cut into (:meth:`optroute.search.route.Corridor.resample`):
    ``band_leg_nm`` where a band or the exclusion can bind (``binding`` (N,), :func:`binding_legs`), twice the leg
    elsewhere (``leg_nm`` (N,) [nm], at least ``band_leg_nm``: the leg stays whole whatever the rounding of its
    length in the resampling); None where no binding leg is longer than ``band_leg_nm``.

    A leg holds one speed and heading. Where a band binds, the 3-D DP's plan (the start of an ETA's solve there, its
    stages about 20 nm apart) changes speed more often than a 50 nm leg can, and the NLP started from it cannot keep
    it (``python -m benchmarks --only compare`` measures the NLP against the DP where the bands bind). The other legs
    stay long: there only the engine load binds, and shorter legs would cost solve time and gain nothing.
    """
    step = check_band_leg_nm(band_leg_nm)
    binding = np.asarray(binding, dtype=bool)
    leg = np.asarray(leg_nm, dtype=float)
    if not np.any(binding & (leg > step * (1.0 + 1e-9))):
        return None
    return np.where(binding, step, 2.0 * np.maximum(leg, step))


def exclusion_legs(frame: CorridorFrame, mv: MovingExclusion) -> np.ndarray:
    """Per leg, whether the moving circle ``mv`` (the NLP's, in ``frame``'s flat frame) comes within
    :data:`EXCLUSION_REACH_NM` of the leg's corridor at any time (:func:`legs_near_exclusion`, its track sampled so
    that the centre moves at most a tenth of the reach between samples)."""
    t = mv.t_h
    if t.size > 1:
        step = np.linalg.norm(np.diff(mv.centre_xy_nm, axis=0), axis=1)
        n_sub = max(2, int(np.ceil(np.max(step) / (0.1 * EXCLUSION_REACH_NM))) + 1)
        t = np.unique(np.concatenate([np.linspace(a, b, n_sub) for a, b in zip(t[:-1], t[1:], strict=True)]))
    xy = np.column_stack([np.interp(t, mv.t_h, mv.centre_xy_nm[:, j]) for j in range(2)])
    return legs_near_exclusion(
        frame.centre_xy_nm, np.asarray(frame.corridor.half_width_nm, dtype=float), xy,
        np.interp(t, mv.t_h, mv.radius_nm),
    )  # fmt: skip


def nlp_row_legs(
    frame: CorridorFrame,
    grid_s_nm: np.ndarray,
    grid_hs_m: np.ndarray,
    bands: tuple[Band, ...],
    exclusion: MovingExclusion | None,
    forced: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The legs that carry the NLP's band rows and its exclusion rows (``SpeedNLP``'s ``band_legs`` and
    ``exclusion_legs``): where one of the NLP's ``bands`` can apply (:func:`legs_that_can_bind` at their lowest Hs
    threshold on the NLP's weather grid: along-track nodes ``grid_s_nm`` [nm], Hs ``grid_hs_m`` (t, s, y) [m]),
    where its circle ``exclusion`` comes near (:func:`exclusion_legs`), and the legs ``forced`` (N,) (the referee
    rejected a plan there). Elsewhere those rows could never bind: their bounds would be −∞…+∞ at every solve, and
    Ipopt and MUMPS would still carry them at every iteration. :func:`binding_legs` is the union of the two."""
    hs_apply = min((float(b.hs_min_m) for b in bands), default=None)
    band = legs_that_can_bind(frame.s_nm, grid_s_nm, grid_hs_m, hs_apply)
    excl = exclusion_legs(frame, exclusion) if exclusion is not None else np.zeros(frame.n_legs, dtype=bool)
    if forced is not None:
        band, excl = band | forced, excl | forced
    return band, excl


def leg_end_rows(binding: np.ndarray) -> list[np.ndarray] | None:
    """The default NLP's row-only points (``constraint_rows="midpoints"``): where a band or the exclusion can bind on
    some leg (``binding`` (N,), :func:`binding_legs`), both ends of every leg, as fractions (0 and 1), beside the
    quadrature's midpoints; None where nothing can (the midpoints alone, the engine's range mended on the referee's
    plan).

    A leg's speed holds up to its end, where the next leg's begins: a sea that rises through a band's threshold
    near a waypoint puts the stretch between the last midpoint of one leg and the first of the next in the band
    unseen by midpoint rows (the head storm of ``benchmarks/bench_compare.py``: Hs 4.9 m at the last midpoint, 5.3 m
    at the next, the parametric-roll ratio 0.56-0.59 at the waypoint between, where the referee rejected every
    plan). With the ends carried, every leg's rows hold at its whole extent's two ends at its own speed, and
    :func:`formulations.disjunctive.held_across_crossings` holds a band's side across a threshold crossing between
    two samples of a leg.
    """
    ends = np.asarray(binding, dtype=bool)
    return [np.array([0.0, 1.0])] * ends.size if ends.any() else None


def only_where_binding(points: list[np.ndarray] | None, binding: np.ndarray) -> list[np.ndarray] | None:
    """``points`` with the legs where nothing but the engine load can bind reduced to their ends (0 and 1)."""
    if points is None:
        return None
    return [p if binding[k] else np.array([0.0, 1.0]) for k, p in enumerate(points)]


def sample_layout(points: list[np.ndarray] | None, n_legs: int, samples_per_leg: int) -> SampleLayout:
    """The NLP's samples: ``samples_per_leg`` midpoints per leg (the quadrature) and ``points`` as row-only samples."""
    base = midpoint_layout(n_legs, samples_per_leg)
    if points is None:
        return base
    return with_points(base, points, max_points=MAX_ROW_POINTS)
