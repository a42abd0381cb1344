"""The whole grid search in one compiled call: settling, edge tests, pruning, lazy edge costing and label updates.

:class:`optroute.search.dijkstra._Search` alternates Python and compiled code
per batch of settled nodes: select the batch, find the edges worth costing,
cost them all through the segment callback (whose compiled form walks the legs
piece by piece, :func:`optroute.search.passage_kernels.cost_legs`), update the
labels.  When the callback carries a :class:`LegKernel` (the physics callbacks
of :mod:`optroute.search.passage_physics` do), :func:`run` does the search in
numba with the same edge tests (:func:`optroute.search._kernels.candidates`),
the same leg costing (:func:`optroute.search.passage_kernels.cost_leg`) and the
same piece geometry (:func:`optroute.search.edge_geometry.edge_pieces`), so the
labels are those of the Python loop; but it costs an edge only when the edge's
lower bound is the least of the open set and its head is not settled yet (lazy
A*), so most edges to a node that a better edge reaches first are never costed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from optroute._numba import jit
from optroute.search import _heap, _kernels
from optroute.search.edge_geometry import edge_pieces
from optroute.search.edge_land import edge_on_land
from optroute.search.passage_kernels import cost_leg, leg_points, leg_workspace
from optroute.search.refine_kernels import workspace as refine_workspace

__all__ = ["LegKernel", "run"]

ERR_NONE = 0
ERR_TOO_FAST = 1
"""A feasible edge sailed faster than ``v_max_kn``."""
ERR_TOO_CHEAP = 2
"""A feasible edge cost less than the cost floor per nm times its length."""
ERR_BELOW_BOUND = 3
"""A feasible edge cheaper than the heuristic drops along it (``h`` inconsistent with the costs)."""
ERR_BELOW_FLOOR = 4
"""A feasible edge cheaper than its own lower bound (``edge_floor``)."""


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
def _cost_edge(
    k, x, y, q, tarr, tangent, pf0, pf1, pn, buf, refine, label, time_obj, rest_rate, ws
):  # pragma: no cover - compiled
    """Cost the edge ``x → y`` along offset ``q`` departing at ``tarr[x]`` (``refine``:
    :func:`optroute.search.refine_kernels.workspace`, ``ws``: :func:`~optroute.search.passage_kernels.leg_workspace`);
    returns (duration [h], fuel [t], feasible, uncovered points, the work arrays, grown to the leg's largest piece).

    An edge that cannot improve ``label[y]`` is dropped as soon as its cost so far plus ``rest_rate`` times the
    length still to sail shows it (:func:`~optroute.search.passage_kernels.cost_leg`'s ``stop``): returned
    infeasible, which the label update (strictly better only) treats as it would the edge's full cost.
    ``rest_rate`` is the search's lower bound of the objective per nm of any leg, less the speed check's
    tolerance: 1 / ``v_max`` [h/nm] for time, the cost floor ρ [t/nm] for the cost objectives.
    """
    p, w, mode, check_nm, speeds, lam, desired, step, vmin = k
    edge_pieces(tangent[x], tangent[y], pf0[q], pf1[q], pn[q], buf[0], buf[1], buf[2], buf[3])
    m = leg_points(buf[3], pn[q], check_nm)
    if ws[1].shape[0] < m:
        ws = leg_workspace(m, speeds.size)
    stop = (label[x], label[y], time_obj, rest_rate)
    d, f, ok, c = cost_leg(
        p, w, mode, check_nm, speeds, lam, desired, step, vmin, buf[0], buf[1], buf[2], buf[3], pn[q], tarr[x],
        refine, stop, ws,
    )  # fmt: skip
    return d, f, ok, c, ws


# --------------------------------------------------------------------------- the open set
# The heap (:mod:`optroute.search._heap`) orders entries by (key, push number) and carries the push number; the
# entry itself is kept at that number in ``entries = (value, node, parent, offset)``.  A node's *label* entry has
# parent -1 and its label as value; an *edge* entry has the edge's tail as parent and its great-circle length [nm]
# as value.


@jit
def _enter(heap, entries, n, pushed, key, value, node, parent, offset):  # pragma: no cover - compiled
    """Push one entry (growing the arrays when full); returns the heap, the entries and both counts."""
    h1, h2, hs = heap
    val, node_of, parent_of, offset_of = entries
    if n == h1.size:
        h1, h2, hs = _heap.grown(h1, n), _heap.grown(h2, n), _heap.grown(hs, n)
    if pushed == val.size:
        val, node_of = _heap.grown(val, pushed), _heap.grown(node_of, pushed)
        parent_of, offset_of = _heap.grown(parent_of, pushed), _heap.grown(offset_of, pushed)
    val[pushed], node_of[pushed], parent_of[pushed], offset_of[pushed] = value, node, parent, offset
    n = _heap.push(h1, h2, hs, n, key, float(pushed), pushed)
    return (h1, h2, hs), (val, node_of, parent_of, offset_of), n, pushed + 1


@jit
def run(graph, search, k, label, tarr, fuel, parent, poff, state):  # pragma: no cover - compiled
    """Settle nodes until the goal is settled or the open set is empty, costing each edge only when it is due.

    Label-setting A* (Dijkstra with ``h = 0``) with lazy edge costing: settling a node pushes each of its edges
    worth costing (:func:`optroute.search._kernels.candidates`) with its lower bound ``label[x] + b(x, y) + h[y]``
    as key, not its cost, ``b`` the larger of ρ·length and the edge's own floor (``floor``, checked on every costed
    edge).  The edge is costed only when its key is the least of the open set and its head ``y`` is not yet
    settled; an improved ``label[y]`` pushes ``y``'s label entry (key ``label[y] + h[y]``), and ``y`` is settled
    when that entry is the least.  Exact: with ``h`` consistent with the true costs (``h(x) <= cost(x, y) + h(y)``:
    the geodesic heuristic is, being consistent with the bound, which the costs do not undercut; a ``cost_to_go``
    bound is checked on every costed edge), every edge that could still improve ``y`` has a smaller key than
    ``y``'s label entry (its key is at most its tail's label plus its cost plus ``h(y)``, ``b`` being at most the
    cost; an unsettled tail's own entry is smaller still, by consistency), so it is costed first.  The labels are
    therefore those of the batched loop of
    :meth:`optroute.search.dijkstra._Search._loop` (the same edge tests and leg costing,
    :func:`optroute.search.passage_kernels.cost_leg`), which costs every edge its bounds allow into a node not yet
    settled, many of them into nodes that a better edge reaches first.  On an exact tie between two parents'
    labels the one costed first is kept (the batched loop keeps the earlier arrival within a batch).

    Parameters
    ----------
    graph : tuple
        ``(ii, jj, di, dj, off, ny, nx, nav_pad, base_pad, cell_off, cell_n, all_navigable, xyz, tangent,
        piece_f0, piece_f1, piece_n, coastal_pad, land_bits, land_blocks, land_par)`` as held by ``_Search`` and
        ``LegEvaluator`` (the last four: :meth:`optroute.search.edge_land.EdgeLand.kernel_arrays`; an edge across
        a coastal cell is walked on the coastline when it is due, and does not exist where it touches land).
    search : tuple
        ``(start, goal, h, rho, two_r, time_objective, lam, v_max, tol, t_goal, t_limit, inv_v, floor)``: ``rho``
        the objective's lower bound per nm [h/nm or t/nm]; ``t_goal`` a lower bound on each node's time to the goal
        [h], ``t_limit`` the time limit [h] (inf for none), ``inv_v`` = 1 / v_max less the speed check's
        tolerance [h/nm] (see :func:`optroute.search._kernels.candidates`); ``floor`` a lower bound on each edge's
        cost [t] at ``x · n_offsets + q`` for the edge ``x → x + off[q]`` (``shortest_path``'s
        ``edge_cost_floor``), or empty.
    k : tuple
        :class:`LegKernel`'s fields but the callback.
    label, tarr, fuel, parent, poff, state : ndarray
        The search's state, updated in place (start already open).

    Returns
    -------
    counts : ndarray of int, shape (6,)
        Nodes settled, edges costed, settling steps (one a node), points outside the weather,
        error code (``ERR_*``), heap entries pushed.
    bad : ndarray, shape (3,)
        Length [nm], duration [h] (for ``ERR_BELOW_BOUND`` the heuristic's drop along it [t]) and cost of the edge
        that broke a bound (error only).
    """
    ii, jj, di, dj, off, ny, nx, nav_pad, base_pad, cell_off, cell_n, all_nav, xyz, tangent, pf0, pf1, pn = graph[:17]
    coastal_pad, land_bits, land_blocks, land_par = graph[17:]
    walk = land_par[0] > 0.0
    s, g, h, rho, two_r, time_obj, lam, vmax, tol, t_goal, t_limit, inv_v, floor = search
    m_off = di.size if floor.size else 0  # floor[x · m + q]: edge x → x + off[q]'s lower bound; empty: ρ · length
    # a lower bound on the objective per nm still to sail on any leg (the bound every costed edge is checked against)
    rest = inv_v if time_obj else rho * (1.0 - tol)
    counts = np.zeros(6, dtype=np.int64)
    bad = np.zeros(3)
    buf = np.empty((4, pf0.shape[1]))
    refine = refine_workspace(k[3] > 0.0)
    ws = leg_workspace(np.int64(1), k[4].size)  # grown to the largest piece met (leg_points); typed: one signature
    none = np.int64(-1)
    heap = (np.empty(1024), np.empty(1024), np.empty(1024, dtype=np.int64))
    entries = (np.empty(1024), np.empty(1024, dtype=np.int64), np.empty(1024, dtype=np.int64),
               np.empty(1024, dtype=np.int64))  # fmt: skip
    heap, entries, n, pushed = _enter(heap, entries, np.int64(0), np.int64(0), label[s] + h[s], label[s], s, none,
                                      none)  # fmt: skip
    one = np.empty(1, dtype=np.int64)
    while n:
        _, _, a, n = _heap.pop(heap[0], heap[1], heap[2], n)
        y, x, q = entries[1][a], entries[2][a], entries[3][a]
        if state[y] == 2:
            continue
        if x < 0:  # y's label entry: y is final unless a better label was pushed since
            if entries[0][a] != label[y]:
                continue
            state[y] = 2
            counts[0] += 1
            counts[2] += 1
            if y == g:
                break
            one[0] = y
            _, v, o, dist = _kernels.candidates(
                one, ii, jj, di, dj, off, ny, nx, nav_pad, base_pad, cell_off, cell_n, all_nav, state, label, h,
                label[g], xyz, rho, two_r, tarr, t_goal, t_limit, inv_v,
            )  # fmt: skip
            for e in range(v.size):
                lb_e = max(rho * dist[e], floor[y * m_off + o[e]]) if m_off else rho * dist[e]
                key = label[y] + lb_e + h[v[e]]
                heap, entries, n, pushed = _enter(heap, entries, n, pushed, key, dist[e], v[e], y, o[e])
            continue
        # an edge x → y whose bound is the least: the labels may have moved since it was pushed
        d_nm = entries[0][a]
        floor_e = floor[x * m_off + q] if m_off else 0.0
        lb = label[x] + max(rho * d_nm, floor_e)
        if lb >= label[y] or lb + h[y] >= label[g]:
            continue
        if walk and edge_on_land(xyz[x], xyz[y], base_pad[x], q, cell_off, cell_n, coastal_pad, land_bits, land_blocks,
                                 land_par):  # fmt: skip
            continue  # no such edge: it touches land between its nodes
        dur, fu, feas, unc, ws = _cost_edge(k, x, y, q, tarr, tangent, pf0, pf1, pn, buf, refine, label, time_obj,
                                            rest, ws)  # fmt: skip
        counts[1] += 1
        counts[3] += unc
        if not feas:
            continue
        c = dur if time_obj else fu + lam * dur
        if dur * vmax < d_nm * (1.0 - tol):
            counts[4] = ERR_TOO_FAST
        elif not time_obj and c < rho * d_nm * (1.0 - tol):
            counts[4] = ERR_TOO_CHEAP
        elif not time_obj and h[x] - h[y] > c * (1.0 + tol) + 1e-9 * h[x]:
            counts[4] = ERR_BELOW_BOUND
        elif floor_e > c * (1.0 + tol) + 1e-12:
            counts[4] = ERR_BELOW_FLOOR
        if counts[4] != ERR_NONE:  # (length, duration or, below a bound, the bound's drop or the floor, cost)
            bad[0], bad[2] = d_nm, c
            bad[1] = h[x] - h[y] if counts[4] == ERR_BELOW_BOUND else (floor_e if counts[4] == ERR_BELOW_FLOOR else dur)
            return counts, bad
        new = label[x] + c
        if new < label[y]:
            label[y] = new
            tarr[y] = tarr[x] + dur
            fuel[y] = fuel[x] + fu
            parent[y] = x
            poff[y] = q
            state[y] = 1
            heap, entries, n, pushed = _enter(heap, entries, n, pushed, new + h[y], new, y, none, none)
    counts[5] = pushed
    return counts, bad
