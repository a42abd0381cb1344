"""Compiled edge costing of the route search and the 3-D DP: the passage physics over whole batches of legs.

The Python cost callbacks of :class:`optroute.search.passage_physics.PassagePhysics`
sample the weather and choose the speed piece by piece with numpy arrays; the
kernels here do the same for a whole batch of legs in one numba call, with
the one-point functions the referee uses (:mod:`optroute.physics.pointwise`,
:func:`optroute.weather.sample.sample_at`), so each formula has one source:

* :func:`cost_legs` — the grid search's legs, cell by cell (Boeing EP 2145155
  Figs. 14, 21–22): each piece at the time the ship enters it, its speed
  proposed at its midpoint (Boeing's speed reduction from the desired speed,
  or the cheapest of a speed set for fuel + λ·time) and, with a band check,
  checked at points along the piece at the times the ship passes them, a
  failing speed struck out and the next taken (as
  :meth:`~optroute.search.passage_physics.PassagePhysics.segment_checked`);
* :func:`cost_dp_legs` — the DP's legs at a commanded speed over ground,
  costed at each piece's midpoint and checked along each piece by the referee's rules
  (as :meth:`~optroute.search.passage_physics.PassagePhysics.dp_leg`).

The piece and check-point geometry comes from :mod:`optroute.search.edge_geometry`
(the DP's leg points from :mod:`optroute.search.piece_geometry`).
Everything compiles lazily, at the first search that uses it.
"""

from __future__ import annotations

import math

import numpy as np

from optroute import units
from optroute._numba import jit
from optroute.physics.pointwise import (
    allowed_speed,
    cost_rate_floor,
    cost_rate_floor_in_sea,
    evaluate_speed,
    loss_range_at,
    stw_for_sog,
)
from optroute.search.band_bounds import piece_certified
from optroute.search.edge_geometry import frame_point, piece_frame
from optroute.search.refine_kernels import CAPACITY, piece_clear, refined_clear
from optroute.search.refine_kernels import workspace as refine_workspace
from optroute.weather.sample import N_POINT_FIELDS, sample_at

MODE_TIME = 0
"""Boeing's speed reduction from the desired speed (objective "time")."""
MODE_CHEAPEST = 1
"""The speed of the set minimising fuel + λ·time per mile (objectives "fuel" and "cost")."""

_DONE_TOL_H = 1e-3  # as segment_checked: a speed's own times agree with the times it was checked at
_FLOOR_SLACK = 1.0 - 1e-12  # rounding room for skipping speeds by their cost floor (pointwise.cost_rate_floor)
_MS_PER_KN = units.MS_PER_KN


@jit
def _eval_at(p, course, sea, stw):  # pragma: no cover - compiled
    return allowed_speed(p, course, sea[0], sea[1], sea[2], sea[3], sea[4], sea[5], sea[6], stw)


@jit
def best_speed_at(p, course, sea, desired, step, vmin):  # pragma: no cover - compiled
    """Boeing's speed reduction at one point, as :func:`optroute.physics.passage.best_speed`.

    Returns ``(stw, sog, fuel_tph, feasible)``: the desired speed if allowed
    (and >= ``vmin``), else the first allowed of desired − step·j, j = 1, 2, …
    down to ``vmin``.
    """
    if desired >= vmin:
        sog, fuel, ok = _eval_at(p, course, sea, desired)
        if ok:
            return desired, sog, fuel, True
    k = max(int(math.floor((desired - vmin) / step)) + 1, 1)
    for j in range(1, k + 1):
        v = desired - step * j
        if not v >= vmin - 1e-12:
            break
        sog, fuel, ok = _eval_at(p, course, sea, v)
        if ok:
            return v, sog, fuel, True
    return np.nan, np.nan, np.nan, False


@jit
def cheapest_speed_at(p, course, sea, speeds, lam, floors):  # pragma: no cover - compiled
    """The allowed speed of ``speeds`` minimising (fuel + λ) / SOG, as :func:`~optroute.physics.passage.cheapest_speed`.

    The least rate, the first speed of the set on ties.  Each speed's floor of the rate in this sea
    (:func:`~optroute.physics.pointwise.cost_rate_floor_in_sea`, written into ``floors``) is found first; the speed
    of the least floor is tried first, then the others in order, each skipped when its floor cannot beat the best
    so far: the same choice whatever the order (a skipped speed's rate is above the best; ties go to the lower
    index), with few speeds tried (the floor takes the point's own Kwon loss, so it is close to the rate).
    """
    cur = math.hypot(sea[5], sea[6]) / _MS_PER_KN
    v_lo = np.inf
    for k in range(speeds.size):
        v_lo = min(v_lo, speeds[k])
    loss_lo, loss_hi = loss_range_at(p, course, sea[0], sea[2], sea[3], sea[4], cur, v_lo)
    k0, f0 = 0, np.inf
    for k in range(speeds.size):
        floors[k] = cost_rate_floor_in_sea(p, speeds[k], lam, cur, loss_lo, loss_hi)
        if floors[k] < f0:
            k0, f0 = k, floors[k]
    best, k_best = np.inf, -1
    b_sog, b_fuel = np.nan, np.nan
    for r in range(-1, speeds.size):
        k = k0 if r < 0 else r
        if r == k0 or floors[k] * _FLOOR_SLACK >= best:
            continue  # tried first, or cannot beat the best so far (an infinite floor: not allowed at all)
        sog, fuel, ok = _eval_at(p, course, sea, speeds[k])
        if ok and sog > 0.0:
            rate = (fuel + lam) / sog
            if rate < best or (rate == best and k < k_best):
                best, k_best, b_sog, b_fuel = rate, k, sog, fuel
    if k_best < 0:
        return np.nan, np.nan, np.nan, False
    return speeds[k_best], b_sog, b_fuel, True


@jit
def _first_choice(
    p, w, mode, speeds, lam, desired, step, vmin, lat, lon, course, t_h, sea, floors
):  # pragma: no cover - compiled
    """The speed proposed at a piece's midpoint at its entry time (``floors``: :func:`cheapest_speed_at`'s work
    row); returns (stw, sog, fuel, ok, covered)."""
    covered = sample_at(w[0], w[1], w[2], w[3], w[4], w[5], t_h, lat, lon, sea)
    if mode == MODE_TIME:
        stw, sog, fuel, ok = best_speed_at(p, course, sea, desired, step, vmin)
    else:
        stw, sog, fuel, ok = cheapest_speed_at(p, course, sea, speeds, lam, floors)
    return stw, sog, fuel, ok and sog > 0.0, covered


@jit
def _checked_piece(
    p, w, mode, speeds, lam, t_h, la, lo, crs, seg, npts, stw0, sog0, work, sea_pts, mid, s_pts, refine
):  # pragma: no cover - compiled
    """One piece with its speed checked at ``npts`` points (see ``PassagePhysics.segment_checked``).

    A speed allowed at every point at its own times is then checked between them by the referee's
    rules (:func:`optroute.search.refine_kernels.piece_clear`; ``mid`` = the piece's midpoint lat,
    lon, course and length, ``s_pts`` the points' distances from its start, ``refine`` the workspace).
    Returns ``(duration_h, fuel_t, feasible, uncovered points)``.
    """
    k_n = speeds.size
    inv, tt, inv_new, fuel_pt, struck = work[0], work[1], work[2], work[3], work[4]
    guess = 0
    for k in range(1, k_n):
        if abs(speeds[k] - stw0) < abs(speeds[guess] - stw0):
            guess = k
    for j in range(npts):
        inv[j] = 1.0 / sog0
    struck[:k_n] = 0.0
    uncovered = 0
    for _ in range(k_n + 10):
        cum = 0.0
        tt[0] = t_h
        for j in range(1, npts):
            cum += 0.5 * (inv[j] + inv[j - 1]) * seg[j - 1]
            tt[j] = t_h + cum
        for j in range(npts):
            if not sample_at(w[0], w[1], w[2], w[3], w[4], w[5], tt[j], la[j], lo[j], sea_pts[j]):
                uncovered += 1
        spd = speeds[guess]
        ok = True
        for j in range(npts):
            sog, fuel, allowed = _eval_at(p, crs[j], sea_pts[j], spd)
            if not (allowed and sog > 0.0):
                ok = False
                break
            inv_new[j] = 1.0 / sog
            fuel_pt[j] = fuel
        if ok:
            cum, dur, fu, worst = 0.0, 0.0, 0.0, 0.0
            for j in range(1, npts):
                dt = 0.5 * (inv_new[j] + inv_new[j - 1]) * seg[j - 1]
                cum += dt
                worst = max(worst, abs(t_h + cum - tt[j]))
                dur += dt
                fu += 0.5 * (fuel_pt[j] + fuel_pt[j - 1]) * dt
            if worst > _DONE_TOL_H:  # allowed, but the times were not yet its own: check again at them
                for j in range(npts):
                    inv[j] = inv_new[j]
                continue
            if piece_clear(  # np.bool_(...): see _dp_piece_clear
                p, w, spd, np.bool_(False), mid[0], mid[1], mid[2], mid[3], s_pts, tt, npts, la, lo, crs, sea_pts,
                refine[0], refine[1], refine[2],
            ):  # fmt: skip
                return dur, fu, True, uncovered
            # a band between the check points, where the referee's rules look: strike the speed
        struck[guess] = 1.0
        best, k_best = np.inf, -1
        for k in range(k_n):
            if struck[k] != 0.0:
                continue
            if mode != MODE_TIME and best < np.inf:
                floor = 0.0
                for j in range(npts):
                    floor += cost_rate_floor(p, speeds[k], lam, math.hypot(sea_pts[j, 5], sea_pts[j, 6]) / _MS_PER_KN)
                if floor / npts * _FLOOR_SLACK >= best:
                    continue  # cannot rank better than the best so far (see cheapest_speed_at)
            score = 0.0
            good = True
            for j in range(npts):
                sog, fuel, allowed = _eval_at(p, crs[j], sea_pts[j], speeds[k])
                if not (allowed and sog > 0.0):
                    good = False
                    break
                score += (fuel + lam) / sog
            if not good:
                continue
            if mode == MODE_TIME:  # the ladder descends: the first allowed speed is the fastest
                k_best = k
                break
            rank = score / npts
            if rank < best:
                best, k_best = rank, k
        if k_best < 0:
            return np.nan, np.nan, False, uncovered
        guess = k_best
        for j in range(npts):
            sog, _, _ = _eval_at(p, crs[j], sea_pts[j], speeds[guess])
            inv[j] = 1.0 / sog
    return np.nan, np.nan, False, uncovered


@jit
def check_count(length_nm, check_nm):  # pragma: no cover - compiled
    """Check points of a piece: ``1 + 2 max(1, ceil(length / 2 check_nm))``, evenly spaced, ends included (odd)."""
    return int(1.0 + 2.0 * max(1.0, math.ceil(length_nm / (2.0 * check_nm))))


@jit
def leg_points(length, n_pieces, check_nm):  # pragma: no cover - compiled
    """The most check points of any of a leg's ``n_pieces`` pieces (:func:`check_count`; 1 unchecked)."""
    m = np.int64(1)  # typed: leg_workspace has one signature
    if check_nm > 0.0:
        for k in range(n_pieces):
            m = max(m, check_count(length[k], check_nm))
    return m


@jit
def leg_workspace(m, n_speeds):  # pragma: no cover - compiled
    """Work arrays of :func:`cost_leg` for pieces of up to ``m`` check points, allocated once per batch of legs.

    ``(work (6, max(m, n_speeds)), the sea at the points (m, N_POINT_FIELDS), vectors (7, max(m, N_POINT_FIELDS)))``:
    the work rows are :func:`_checked_piece`'s five and :func:`cheapest_speed_at`'s floors; the vectors' rows hold
    the segment lengths, latitudes, longitudes, courses and distances of the points, the sea at one point and the
    piece's midpoint.
    """
    return np.zeros((6, max(m, n_speeds))), np.empty((m, N_POINT_FIELDS)), np.empty((7, max(m, N_POINT_FIELDS)))


@jit
def cost_leg(
    p, w, mode, check_nm, speeds, lam, desired, step, vmin, lat, lon, course, length, n_pieces, t0_h, refine, stop, ws
):  # pragma: no cover - compiled
    """Duration [h], fuel [t], feasibility and uncovered points of one leg, walked piece by piece in time.

    ``stop = (label_u, label_v, time_objective, rest_per_nm)`` lets the search drop a leg that cannot
    improve its destination: once ``label_u`` + the cost so far (the duration, or fuel + λ·duration)
    + ``rest_per_nm`` times the length still to sail exceeds ``label_v``, the leg's full cost would too
    (both parts only grow; ``rest_per_nm`` a lower bound on the objective per nm of any piece: hours per nm
    for time, the cost floor ρ for fuel + λ·time, which bounds a checked piece's trapezoid sums too since
    (a + b)(1/s + 1/t) / 4 >= ρ when a >= ρ s and b >= ρ t), so the search's label update (strictly better
    only) would not take it: it is returned infeasible.  ``label_v = inf`` costs every leg in full.

    The leg's pieces are given by their midpoints ``lat, lon`` [deg], the course
    there [deg true] and ``length`` [nm] (:func:`optroute.search.edge_geometry.edge_pieces`);
    ``check_nm`` <= 0 proposes and keeps each piece's speed at its midpoint
    only, else the speed is checked at :func:`check_count` points along the
    piece (:func:`optroute.search.edge_geometry.frame_point`, one frame per piece) and between them by the referee's rules
    (``refine``: :func:`optroute.search.refine_kernels.workspace`).  ``ws`` is :func:`leg_workspace` (the
    caller's, reused from leg to leg; a larger one is allocated here if the leg needs more points).
    See :func:`cost_legs`.
    """
    checked = check_nm > 0.0
    m = leg_points(length, n_pieces, check_nm)
    work, sea_pts, vec = ws
    if sea_pts.shape[0] < m or work.shape[1] < max(m, speeds.size):
        work, sea_pts, vec = leg_workspace(m, speeds.size)
    seg, la, lo, crs, s_pts = vec[0], vec[1], vec[2], vec[3], vec[4]
    sea, mid = vec[5], vec[6]
    t = t0_h
    fu = 0.0
    uncovered = 0
    label_u, label_v, time_obj, rest_rate = stop
    for k in range(n_pieces):
        rest = 0.0
        for q in range(k + 1, n_pieces):
            rest += length[q]  # (summed afresh: exactly 0 after the last piece)
        stw0, sog0, f0, go, cov = _first_choice(
            p, w, mode, speeds, lam, desired, step, vmin, lat[k], lon[k], course[k], t, sea, work[5]
        )
        if not cov:
            uncovered += 1
        if not go:
            return np.nan, np.nan, False, uncovered
        if not checked:
            d = length[k] / sog0
            t += d
            fu += f0 * d
            if label_u + ((t - t0_h) if time_obj else fu + lam * (t - t0_h)) + rest_rate * rest > label_v:
                return np.nan, np.nan, False, uncovered
            continue
        npts = check_count(length[k], check_nm)
        frame = piece_frame(lat[k], lon[k], course[k])
        for j in range(npts):
            la[j], lo[j], crs[j] = frame_point(frame, (j / (npts - 1.0) - 0.5) * length[k])
        s_pts[0] = 0.0
        for j in range(npts - 1):
            seg[j] = ((j + 1.0) / (npts - 1.0) - j / (npts - 1.0)) * length[k]
            s_pts[j + 1] = s_pts[j] + seg[j]
        mid[0], mid[1], mid[2], mid[3] = lat[k], lon[k], course[k], length[k]
        d, f, good, unc = _checked_piece(
            p, w, mode, speeds, lam, t, la, lo, crs, seg, npts, stw0, sog0, work, sea_pts, mid, s_pts, refine
        )
        uncovered += unc
        if not good:
            return np.nan, np.nan, False, uncovered
        t += d
        fu += f
        if label_u + ((t - t0_h) if time_obj else fu + lam * (t - t0_h)) + rest_rate * rest > label_v:
            return np.nan, np.nan, False, uncovered
    return t - t0_h, fu, True, uncovered


@jit
def cost_legs(
    p, w, mode, check_nm, speeds, lam, desired, step, vmin, mid_lat, mid_lon, mid_course, length, n_pieces, t0_h
):  # pragma: no cover - compiled
    """Duration [h], fuel [t] and feasibility of a batch of legs, walked piece by piece in time.

    Parameters
    ----------
    p : ndarray
        :func:`optroute.physics.pointwise.point_params`.
    w : tuple
        :class:`optroute.weather.sample.PointWeather` fields.
    mode : int
        :data:`MODE_TIME` or :data:`MODE_CHEAPEST`.
    check_nm : float
        Check each piece's speed at points at most this far apart [nm]; <= 0: at its midpoint only.
    speeds : ndarray
        The speed ladder, descending (time: desired − step·j down to the floor), or the set (cheapest) [kn].
    lam, desired, step, vmin : float
        λ [t/h]; the desired speed, the reduction step and floor [kn].
    mid_lat, mid_lon, mid_course, length : ndarray, shape (n, kmax)
        Each piece's midpoint [deg], course there [deg true] and length [nm].
    n_pieces : ndarray of int, shape (n,)
    t0_h : ndarray, shape (n,)
        Departure of each leg [h from the clock's start].

    Returns
    -------
    duration_h, fuel_t : ndarray
        NaN where infeasible.
    feasible : ndarray of bool
    uncovered : int
        Points sampled outside the weather's coverage.
    """
    n = t0_h.size
    dur = np.full(n, np.nan)
    fuel = np.full(n, np.nan)
    feas = np.zeros(n, dtype=np.bool_)
    uncovered = 0
    refine = refine_workspace(check_nm > 0.0)
    full = (0.0, np.inf, np.bool_(True), 0.0)  # every leg costed in full (typed: the search's cost_leg signature)
    m = np.int64(1)  # typed: leg_workspace has one signature
    for i in range(n):
        m = max(m, leg_points(length[i], n_pieces[i], check_nm))
    ws = leg_workspace(m, speeds.size)
    for i in range(n):
        d, f, ok, unc = cost_leg(
            p, w, mode, check_nm, speeds, lam, desired, step, vmin, mid_lat[i], mid_lon[i], mid_course[i],
            length[i], n_pieces[i], t0_h[i], refine, full, ws,
        )  # fmt: skip
        uncovered += unc
        if ok:
            dur[i], fuel[i], feas[i] = d, f, True
    return dur, fuel, feas, uncovered


@jit
def cost_dp_legs(
    p, w, lat, lon, course, frac, n_pieces, leg_of, t0_h, sog_kn, dist_nm, check
):  # pragma: no cover - compiled
    """The 3-D DP's legs at a commanded SOG, costed at each piece's midpoint and checked along it (``PassagePhysics.dp_leg``).

    Parameters
    ----------
    p, w
        As :func:`cost_legs`.
    lat, lon, course, frac : ndarray, shape (n_geometries, m)
        Each distinct leg's piece midpoints [deg], the course there [deg true]
        and their fraction of the leg.
    n_pieces : ndarray of int, shape (n_geometries,)
    leg_of : ndarray of int, shape (n,)
        The geometry of each leg costed.
    t0_h, sog_kn : ndarray, shape (n,)
        Departure [h] and commanded speed over ground [kn] of each leg.
    dist_nm : ndarray, shape (n_geometries,)
        Leg lengths [nm].
    check : bool
        Check each leg between its pieces' midpoints too (:func:`dp_leg_clear`); without it, only at the
        midpoints (:func:`dp_leg_midpoints`: a leg found feasible is then feasible only if :func:`clear_dp_legs`
        passes it).

    Returns
    -------
    duration_h, fuel_t : ndarray
        dist / SOG, and the pieces' mean fuel rate times it (NaN where infeasible).
    feasible : ndarray of bool
        Every piece, at the time the ship passes it: the STW making the SOG
        good against the current > 0 and allowed at its midpoint, its ends and
        wherever the referee's rules look between (:func:`cost_dp_leg`).
    stw_kn, power_kw : ndarray
        Mean STW [kn] and brake power [kW] over the pieces.
    uncovered : int
    """
    n = sog_kn.size
    dur = np.empty(n)
    for i in range(n):
        dur[i] = dist_nm[leg_of[i]] / sog_kn[i]
    fuel = np.full(n, np.nan)
    stw_mean = np.full(n, np.nan)
    power_mean = np.full(n, np.nan)
    feas = np.zeros(n, dtype=np.bool_)
    work = dp_workspace()
    uncovered = 0
    for i in range(n):
        leg = (p, w, lat, lon, course, frac, n_pieces, leg_of[i], t0_h[i], sog_kn[i], dist_nm, work)
        ok, f_sum, s_sum, p_sum, unc = cost_dp_leg(*leg) if check else dp_leg_midpoints(*leg)
        uncovered += unc
        if ok:
            feas[i] = True
            fuel[i] = f_sum * dur[i]
            stw_mean[i] = s_sum
            power_mean[i] = p_sum
    return dur, fuel, feas, stw_mean, power_mean, uncovered


@jit
def clear_dp_legs(p, w, lat, lon, course, frac, n_pieces, leg_of, t0_h, sog_kn, dist_nm):  # pragma: no cover - compiled
    """Whether each leg of :func:`cost_dp_legs` (the same arguments, without ``check``), allowed at its pieces'
    midpoints, is clear between them (:func:`dp_leg_clear`); ``(clear, uncovered points)``."""
    n = sog_kn.size
    clear = np.zeros(n, dtype=np.bool_)
    work = dp_workspace()
    uncovered = 0
    for i in range(n):
        clear[i], unc = dp_leg_clear(
            p, w, lat, lon, course, frac, n_pieces, leg_of[i], t0_h[i], sog_kn[i], dist_nm, work
        )
        uncovered += unc
    return clear, uncovered


@jit
def dp_workspace():  # pragma: no cover - compiled
    """Work arrays of :func:`cost_dp_leg`: the sea at one point, a piece's three check points, the refinement's."""
    ws, sl, scratch = refine_workspace(np.bool_(True))
    return np.empty(N_POINT_FIELDS), np.empty((3, N_POINT_FIELDS)), np.empty((5, 3)), ws, sl, scratch


@jit
def _dp_piece_clear(p, w, la, lo, crs, length, t_mid, sog_kn, work):  # pragma: no cover - compiled
    """Whether a DP piece (midpoint, course, length [nm], passed at ``t_mid`` [h] at ``sog_kn``) is clear end to end.

    A piece the weather's node bounds certify (:func:`optroute.search.band_bounds.piece_certified`: no point of it,
    its ends included, can have the speed not allowed) is clear without sampling it.  Otherwise its ends are
    checked as its midpoint (the speed through water making the SOG good, allowed), then the stretches between by
    the referee's rules (:func:`optroute.search.refine_kernels.refined_clear`: ``piece_clear`` less the
    certificate already tried).
    Returns ``(clear, uncovered points)``.
    """
    _, sea_pts, pts, ws, sl, scratch = work
    s_pts, t_pts, la_pts, lo_pts, crs_pts = pts[0], pts[1], pts[2], pts[3], pts[4]
    uncovered = 0
    frame = piece_frame(la, lo, crs)
    for j in range(3):
        s_pts[j] = 0.5 * length * j
        t_pts[j] = t_mid + (s_pts[j] - 0.5 * length) / sog_kn
        if j == 1:
            la_pts[j], lo_pts[j], crs_pts[j] = la, lo, crs
        else:
            la_pts[j], lo_pts[j], crs_pts[j] = frame_point(frame, s_pts[j] - 0.5 * length)
    # np.bool_(True), np.int64(3): typed values, not literals. numba compiles a kernel once per argument type, and a
    # literal constant is a type of its own, so with literals piece_certified and refined_clear (and _probe,
    # _crossings, _box under them) compiled twice, once for these calls and once for _checked_piece's piece_clear.
    if piece_certified(
        p, w, sog_kn, np.bool_(True), la_pts, lo_pts, t_pts, s_pts, np.int64(3), la, lo, length, np.int64(CAPACITY),
        scratch,
    ):  # fmt: skip
        return True, uncovered
    for j in range(3):
        sea = sea_pts[j]
        if not sample_at(w[0], w[1], w[2], w[3], w[4], w[5], t_pts[j], la_pts[j], lo_pts[j], sea):
            uncovered += 1
        if j == 1:
            continue  # the midpoint: allowed already
        stw = stw_for_sog(crs_pts[j], sog_kn, sea[5], sea[6])
        if not (math.isfinite(stw) and stw > 0.0):
            return False, uncovered
        sog, _, allowed = _eval_at(p, crs_pts[j], sea, stw)
        if not (allowed and sog > 0.0):
            return False, uncovered
    clear = refined_clear(  # certified above already: the refinement alone
        p, w, sog_kn, np.bool_(True), la, lo, crs, length, s_pts, t_pts, np.int64(3), la_pts, lo_pts, crs_pts, sea_pts,
        ws, sl, scratch,
    )  # fmt: skip
    return clear, uncovered


@jit
def dp_leg_midpoints(
    p, w, lat, lon, course, frac, n_pieces, g, t0_h, sog_kn, dist_nm, work
):  # pragma: no cover - compiled
    """One DP leg of geometry ``g`` (see :func:`cost_dp_legs`) left at ``t0_h`` [h] at ``sog_kn`` [kn], at its pieces' midpoints.

    Returns ``(allowed at every midpoint, mean fuel rate [t/h], mean STW [kn], mean power [kW], uncovered
    points)``; the leg's fuel is the mean rate times ``dist_nm[g] / sog_kn``.  Each piece is costed at its
    midpoint (Shao et al.'s time-stepped simulation) and checked there; :func:`dp_leg_clear` checks the rest
    of it.  ``work`` is :func:`dp_workspace`.
    """
    sea = work[0]
    npc = n_pieces[g]
    f_sum, s_sum, p_sum = 0.0, 0.0, 0.0
    uncovered = 0
    for j in range(npc):
        t = t0_h + (frac[g, j] * dist_nm[g]) / sog_kn
        if not sample_at(w[0], w[1], w[2], w[3], w[4], w[5], t, lat[g, j], lon[g, j], sea):
            uncovered += 1
        stw = stw_for_sog(course[g, j], sog_kn, sea[5], sea[6])
        if not (math.isfinite(stw) and stw > 0.0):
            return False, np.nan, np.nan, np.nan, uncovered
        _, _, power, fuel_tph, allowed = evaluate_speed(
            p, course[g, j], sea[0], sea[1], sea[2], sea[3], sea[4], sea[5], sea[6], stw
        )
        if not allowed:
            return False, np.nan, np.nan, np.nan, uncovered
        share = 1.0 / npc
        f_sum += fuel_tph * share
        s_sum += stw * share
        p_sum += power * share
    return True, f_sum, s_sum, p_sum, uncovered


@jit
def dp_leg_clear(p, w, lat, lon, course, frac, n_pieces, g, t0_h, sog_kn, dist_nm, work):  # pragma: no cover - compiled
    """Whether a DP leg allowed at its midpoints (:func:`dp_leg_midpoints`) is clear at its pieces' ends and between.

    Every piece is checked where the referee's rules look (:func:`_dp_piece_clear`, issue 14 item 1: a band
    entered between two midpoints is found as ``Plan.verify()`` finds it).  Returns ``(clear, uncovered points)``.
    """
    npc = n_pieces[g]
    length = dist_nm[g] / npc
    uncovered = 0
    for j in range(npc):
        t = t0_h + (frac[g, j] * dist_nm[g]) / sog_kn
        clear, unc = _dp_piece_clear(p, w, lat[g, j], lon[g, j], course[g, j], length, t, sog_kn, work)
        uncovered += unc
        if not clear:
            return False, uncovered
    return True, uncovered


@jit
def cost_dp_leg(p, w, lat, lon, course, frac, n_pieces, g, t0_h, sog_kn, dist_nm, work):  # pragma: no cover - compiled
    """One DP leg of geometry ``g`` (see :func:`cost_dp_legs`): :func:`dp_leg_midpoints`, then :func:`dp_leg_clear`.

    Returns ``(feasible, mean fuel rate [t/h], mean STW [kn], mean power [kW], uncovered points)``.
    """
    ok, f_sum, s_sum, p_sum, uncovered = dp_leg_midpoints(
        p, w, lat, lon, course, frac, n_pieces, g, t0_h, sog_kn, dist_nm, work
    )
    if not ok:
        return False, np.nan, np.nan, np.nan, uncovered
    clear, unc = dp_leg_clear(p, w, lat, lon, course, frac, n_pieces, g, t0_h, sog_kn, dist_nm, work)
    uncovered += unc
    if not clear:
        return False, np.nan, np.nan, np.nan, uncovered
    return True, f_sum, s_sum, p_sum, uncovered
