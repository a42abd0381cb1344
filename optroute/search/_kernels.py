"""Compiled bookkeeping of the grid search (numba, optional).

Two loops of :class:`optroute.search.dijkstra._Search` are the same
arithmetic as its numpy code path, written element by element for numba:

* :func:`candidates` — for a batch of settled nodes, the edges that exist
  (destination on the grid, every crossed cell navigable, destination not
  settled) and are worth costing (their cost at ``v_max`` could still beat
  the destination's label and the goal's, and the goal could still be
  reached by the time limit — the weather's end — at ``v_max``), with their
  great-circle lengths;
* :func:`apply` — write the improved labels, keeping per destination the
  least (label, arrival time), the first such candidate on ties, exactly as
  the stable lexicographic sort of the numpy path does;
* :func:`select` — the nodes of the open set that are provably final.

numba is optional: without it :data:`AVAILABLE` is False and the search
uses numpy (same results).
"""

from __future__ import annotations

from typing import Any

import numpy as np

try:  # numba is optional: the numpy path gives the same labels
    import numba
except ImportError:  # pragma: no cover - depends on the environment
    numba = None

AVAILABLE = numba is not None


def _candidates(
    batch: np.ndarray,
    ii: np.ndarray,
    jj: np.ndarray,
    di: np.ndarray,
    dj: np.ndarray,
    off: np.ndarray,
    ny: int,
    nx: int,
    nav_pad: np.ndarray,
    base_pad: np.ndarray,
    cell_off: np.ndarray,
    cell_n: np.ndarray,
    all_nav: bool,
    state: np.ndarray,
    label: np.ndarray,
    h: np.ndarray,
    goal_label: float,
    xyz: np.ndarray,
    w_over_v: float,
    two_r: float,
    tarr: np.ndarray,
    t_goal: np.ndarray,
    t_limit: float,
    inv_v: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    # t_goal[y]: a lower bound on the time from y to the goal [h]; inv_v: a lower bound on the hours per nm
    # of any leg; an edge whose departure plus both bounds passes t_limit cannot end inside it
    m = di.size
    cap = batch.size * m
    u = np.empty(cap, dtype=np.int64)
    v = np.empty(cap, dtype=np.int64)
    o = np.empty(cap, dtype=np.int64)
    dist = np.empty(cap)
    k = 0
    for a in range(batch.size):
        x = batch[a]
        i0, j0, lx = ii[x], jj[x], label[x]
        for q in range(m):
            i1 = i0 + di[q]
            j1 = j0 + dj[q]
            if i1 < 0 or i1 >= ny or j1 < 0 or j1 >= nx:
                continue
            y = x + off[q]
            if state[y] == 2:
                continue
            if not all_nav:
                base = base_pad[x]
                clear = True
                for c in range(cell_n[q]):
                    if not nav_pad[base + cell_off[q, c]]:
                        clear = False
                        break
                if not clear:
                    continue
            ex = xyz[x, 0] - xyz[y, 0]
            ey = xyz[x, 1] - xyz[y, 1]
            ez = xyz[x, 2] - xyz[y, 2]
            half = np.sqrt(ex * ex + ey * ey + ez * ez) / 2.0
            d = two_r * np.arcsin(min(max(half, 0.0), 1.0))
            lb = lx + w_over_v * d
            if lb >= label[y] or lb + h[y] >= goal_label:
                continue
            if tarr[x] + inv_v * d + t_goal[y] > t_limit:
                continue
            u[k], v[k], o[k], dist[k] = x, y, q, d
            k += 1
    return u[:k], v[:k], o[:k], dist[:k]


def _apply(
    u: np.ndarray,
    v: np.ndarray,
    o: np.ndarray,
    new: np.ndarray,
    t1: np.ndarray,
    fu: np.ndarray,
    feas: np.ndarray,
    label: np.ndarray,
    tarr: np.ndarray,
    fuel: np.ndarray,
    parent: np.ndarray,
    poff: np.ndarray,
    state: np.ndarray,
    touched: np.ndarray,
    stamp: int,
) -> np.ndarray:
    opened = np.empty(u.size, dtype=np.int64)
    n_open = 0
    for k in range(u.size):
        if not feas[k]:
            continue
        y = v[k]
        nk, tk = new[k], t1[k]
        if touched[y] == stamp:
            better = nk < label[y] or (nk == label[y] and tk < tarr[y])
        else:
            better = nk < label[y]
        if not better:
            continue
        touched[y] = stamp
        label[y] = nk
        tarr[y] = tk
        fuel[y] = fuel[u[k]] + fu[k]
        parent[y] = u[k]
        poff[y] = o[k]
        if state[y] == 0:
            opened[n_open] = y
            n_open += 1
            state[y] = 1
    return opened[:n_open]


def _select(
    open_nodes: np.ndarray, label: np.ndarray, h: np.ndarray, delta: np.ndarray, slack: float, mode: int
) -> tuple[np.ndarray, np.ndarray]:
    """Split the open set into (nodes to settle now, the rest); see ``_Search._loop`` for the rule.

    ``mode``: 0 the least f only (textbook), 1 Dijkstra batches, 2 A* batches.
    """
    n = open_nodes.size
    g = np.empty(n)
    f = np.empty(n)
    k0 = 0
    for a in range(n):
        g[a] = label[open_nodes[a]]
        f[a] = g[a] + h[open_nodes[a]]
        if f[a] < f[k0]:
            k0 = a
    sel = np.zeros(n, dtype=np.bool_)
    if mode == 0:
        sel[k0] = True
    elif mode == 1:
        thr = np.inf
        for a in range(n):
            thr = min(thr, g[a] + delta[open_nodes[a]])
        for a in range(n):
            sel[a] = g[a] <= thr
        sel[k0] = True
    else:
        lim = f[k0] + slack * delta[open_nodes[k0]]
        cand = np.nonzero(f <= lim)[0]
        order = cand[np.argsort(f[cand], kind="mergesort")]
        prior = np.inf
        for r in range(order.size):
            a = order[r]
            if r == 0 or g[a] <= prior:
                sel[a] = True
            prior = min(prior, g[a] + delta[open_nodes[a]])
    return open_nodes[sel], open_nodes[~sel]


def _compile() -> tuple[Any, Any, Any]:
    if numba is None:  # pragma: no cover - depends on the environment
        return None, None, None
    jit = numba.njit(cache=True, nogil=True)
    return jit(_candidates), jit(_apply), jit(_select)


candidates, apply, select = _compile()
