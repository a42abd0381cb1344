"""The whole grid search in one compiled call: settling, edge tests, pruning, edge costing and label updates.

:class:`optroute.search.dijkstra._Search` alternates Python and compiled code
per batch of settled nodes: select the batch, find the edges worth costing,
cost them through the segment callback (whose compiled form walks the legs
piece by piece, :func:`optroute.search.passage_kernels.cost_legs`), update the
labels.  When the callback carries a :class:`LegKernel` (the physics callbacks
of :mod:`optroute.search.passage_physics` do), :func:`run` does the same loop in numba,
with the same three bookkeeping functions (:mod:`optroute.search._kernels`), the
same leg costing (:func:`optroute.search.passage_kernels.cost_leg`) and the same
piece geometry (:func:`optroute.search.edge_geometry.edge_pieces`), so the labels
are those of the Python loop; only the interpreter between them is gone.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from optroute._numba import jit
from optroute.search import _kernels
from optroute.search.edge_geometry import edge_pieces
from optroute.search.passage_kernels import cost_leg, leg_points, leg_workspace
from optroute.search.refine_kernels import workspace as refine_workspace

__all__ = ["LegKernel", "run"]

ERR_NONE = 0
ERR_TOO_FAST = 1
"""A feasible edge sailed faster than ``v_max_kn``."""
ERR_TOO_CHEAP = 2
"""A feasible edge cost less than the cost floor per nm times its length."""


@dataclass(frozen=True, eq=False)
class LegKernel:
    """What :func:`run` needs to cost a leg with :func:`~optroute.search.passage_kernels.cost_leg`.

    Attributes
    ----------
    params : ndarray
        :func:`optroute.physics.pointwise.point_params` (the vessel's physics; one vector, one function).
    weather : tuple
        :class:`optroute.weather.sample.PointWeather` fields and their node bounds
        (:func:`optroute.search.band_bounds.weather_with_bounds`).
    mode : int
        :data:`~optroute.search.passage_kernels.MODE_TIME` or ``MODE_CHEAPEST``.
    check_nm : float
        Band-check spacing [nm]; <= 0 for the midpoint only.
    speeds : ndarray
        The speed ladder or set [kn].
    lam, desired, step, vmin : float
        λ [t/h]; Boeing's desired speed, step and floor [kn].
    on_uncovered : callable
        Called once with the number of points sampled outside the weather.
    """

    params: np.ndarray
    weather: tuple
    mode: int
    check_nm: float
    speeds: np.ndarray
    lam: float
    desired: float
    step: float
    vmin: float
    on_uncovered: Callable[[int], None]


@jit
def _cost_batch(
    k, u, v, o, tarr, tangent, piece_f0, piece_f1, piece_n, buf, refine, label, time_obj, rest_rate, ws
):  # pragma: no cover - compiled
    """Cost edges ``u → v`` (``refine``: :func:`optroute.search.refine_kernels.workspace`, ``ws``:
    :func:`~optroute.search.passage_kernels.leg_workspace`); returns (duration, fuel, feasible, uncovered points,
    the work arrays, grown to the batch's largest piece).

    An edge that cannot improve ``label[v]`` (the labels before the batch) is dropped as soon as its cost so far
    plus ``rest_rate`` times the length still to sail shows it (:func:`~optroute.search.passage_kernels.cost_leg`'s
    ``stop``): returned infeasible, which the label update (strictly better only) treats as it would the edge's
    full cost.  ``rest_rate`` is the search's lower bound of the objective per nm of any leg, less the speed
    check's tolerance: 1 / ``v_max`` [h/nm] for time, the cost floor ρ [t/nm] for the cost objectives.
    """
    n = u.size
    dur, fu = np.empty(n), np.empty(n)
    feas = np.zeros(n, dtype=np.bool_)
    unc = 0
    p, w, mode, check_nm, speeds, lam, desired, step, vmin = k
    for e in range(n):
        q = o[e]
        edge_pieces(tangent[u[e]], tangent[v[e]], piece_f0[q], piece_f1[q], piece_n[q], buf[0], buf[1], buf[2], buf[3])
        m = leg_points(buf[3], piece_n[q], check_nm)
        if ws[1].shape[0] < m:
            ws = leg_workspace(m, speeds.size)
        stop = (label[u[e]], label[v[e]], time_obj, rest_rate)
        d, f, ok, c = cost_leg(
            p, w, mode, check_nm, speeds, lam, desired, step, vmin, buf[0], buf[1], buf[2], buf[3], piece_n[q],
            tarr[u[e]], refine, stop, ws,
        )  # fmt: skip
        unc += c
        dur[e], fu[e], feas[e] = d, f, ok
    return dur, fu, feas, unc, ws


@jit
def run(graph, search, k, label, tarr, fuel, parent, poff, state, touched):  # pragma: no cover - compiled
    """Settle nodes until the goal is settled or the open set is empty.

    Parameters
    ----------
    graph : tuple
        ``(ii, jj, di, dj, off, ny, nx, nav_pad, base_pad, cell_off, cell_n, all_navigable, xyz, tangent,
        piece_f0, piece_f1, piece_n)`` as held by ``_Search`` and ``LegEvaluator``.
    search : tuple
        ``(start, goal, h, delta, f_slack, select_mode, rho, two_r, time_objective, lam, v_max, tol, t_goal,
        t_limit, inv_v)``: ``rho`` the objective's lower bound per nm [h/nm or t/nm]; ``t_goal`` a lower bound on
        each node's time to the goal [h], ``t_limit`` the time limit [h] (inf for none), ``inv_v`` = 1 / v_max
        less the speed check's tolerance [h/nm] (see :func:`optroute.search._kernels.candidates`).
    k : tuple
        :class:`LegKernel`'s fields but the callback.
    label, tarr, fuel, parent, poff, state, touched : ndarray
        The search's state, updated in place (start already open).

    Returns
    -------
    counts : ndarray of int, shape (6,)
        Nodes expanded, edges costed, settling steps, points outside the weather,
        error code (``ERR_*``), index of nothing (0).
    bad : ndarray, shape (3,)
        Length [nm], duration [h] and cost of the edge that broke a bound (error only).
    """
    ii, jj, di, dj, off, ny, nx, nav_pad, base_pad, cell_off, cell_n, all_nav, xyz, tangent, pf0, pf1, pn = graph
    s, g, h, delta, slack, mode, rho, two_r, time_obj, lam, vmax, tol, t_goal, t_limit, inv_v = search
    # a lower bound on the objective per nm still to sail on any leg (the bound every costed edge is checked against)
    rest = inv_v if time_obj else rho * (1.0 - tol)
    counts = np.zeros(6, dtype=np.int64)
    bad = np.zeros(3)
    kmax = pf0.shape[1]
    buf = np.empty((4, kmax))
    refine = refine_workspace(k[3] > 0.0)
    ws = leg_workspace(np.int64(1), k[4].size)  # grown to the largest piece met (leg_points); typed: one signature
    open_nodes = np.array([s], dtype=np.int64)
    relaxed = 0
    while open_nodes.size:
        batch, open_nodes = _kernels.select(open_nodes, label, h, delta, slack, mode)
        for b in batch:
            state[b] = 2
        counts[0] += batch.size
        counts[2] += 1
        if state[g] == 2:
            break
        u, v, o, dist = _kernels.candidates(
            batch, ii, jj, di, dj, off, ny, nx, nav_pad, base_pad, cell_off, cell_n, all_nav, state, label, h,
            label[g], xyz, rho, two_r, tarr, t_goal, t_limit, inv_v,
        )  # fmt: skip
        if u.size == 0:
            continue
        dur, fu, feas, unc, ws = _cost_batch(
            k, u, v, o, tarr, tangent, pf0, pf1, pn, buf, refine, label, time_obj, rest, ws
        )  # fmt: skip
        counts[1] += u.size
        counts[3] += unc
        new = np.empty(u.size)
        for e in range(u.size):
            c = dur[e] if time_obj else fu[e] + lam * dur[e]
            new[e] = label[u[e]] + c
            if feas[e] and dur[e] * vmax < dist[e] * (1.0 - tol):
                counts[4] = ERR_TOO_FAST
            elif feas[e] and not time_obj and c < rho * dist[e] * (1.0 - tol):
                counts[4] = ERR_TOO_CHEAP
            if counts[4] != ERR_NONE:
                bad[0], bad[1], bad[2] = dist[e], dur[e], c
                return counts, bad
        relaxed += 1
        t1 = np.empty(u.size)
        for e in range(u.size):
            t1[e] = tarr[u[e]] + dur[e]
        opened = _kernels.apply(u, v, o, new, t1, fu, feas, label, tarr, fuel, parent, poff, state, touched, relaxed)
        if opened.size:
            open_nodes = np.concatenate((open_nodes, opened))
    return counts, bad
