"""The compiled label-setting search of the sailing route (numba): states node × tack (× manoeuvres).

A state is ``(node, tack[, ω])`` with tack 0 = none yet (the start), 1 =
starboard, 2 = port, and in the layered mode ω = manoeuvres so far
(0..``layers - 1``).  Keys are compared lexicographically:

* ``MODE_TIME``: (arrival time, manoeuvres) on node × tack;
* ``MODE_FEWEST``: (manoeuvres, arrival time) on node × tack;
* ``MODE_LAYERED``: arrival time on node × tack × ω, ω < ``layers``: the least
  time with exactly ω manoeuvres, i.e. the whole (ω, T) front.

The wind of a leg is the wind at its departure node at its departure time,
linear in time between the forecast's steps (the trilinear interpolation of
:class:`~optroute.weather.sample.WeatherSampler` at a node is exactly that);
the boat speed comes from :func:`optroute.physics.polar.polar_speed_scalar`,
the polar's one implementation.  Departures after the last forecast step are
not expanded (``hold`` = 0) and counted in ``stats[2]``.

With ``h_node`` the great-circle distance to the end over the fastest speed
the boat has (the polar's largest, never exceeded, or the engine's), the
search is A*: the bound is consistent (a leg is never shorter than the great
circle between its ends), so the answer is the same as Dijkstra's.
"""

from __future__ import annotations

import math

import numpy as np

from optroute._numba import jit
from optroute.physics.polar import polar_speed_scalar
from optroute.search._heap import grown, less, pop, push

MODE_TIME, MODE_FEWEST, MODE_LAYERED = 0, 1, 2
_RUN_TOL = 1e-9


@jit(inline="always")
def wind_at(u, v, slice_h, node, t_h, hold):  # pragma: no cover - compiled
    """(TWS [kn], from [deg], ok) at a node and time: linear in time between steps; ok False past the last step."""
    nk = slice_h.size
    if t_h > slice_h[nk - 1] and not hold:
        return 0.0, 0.0, False
    if nk == 1 or t_h >= slice_h[nk - 1]:
        uu, vv = u[nk - 1, node], v[nk - 1, node]
    elif t_h <= slice_h[0]:
        uu, vv = u[0, node], v[0, node]
    else:
        k = 0
        while slice_h[k + 1] <= t_h:  # t_h < slice_h[nk - 1] here
            k += 1
        w = (t_h - slice_h[k]) / (slice_h[k + 1] - slice_h[k])
        uu = u[k, node] + w * (u[k + 1, node] - u[k, node])
        vv = v[k, node] + w * (v[k + 1, node] - v[k, node])
    tws = math.hypot(uu, vv) * 3600.0 / 1852.0
    frm = math.degrees(math.atan2(-uu, -vv)) % 360.0
    return tws, frm, True


@jit(inline="always")
def _leg(course, tws, frm, tables, motor_below, motor_kn):  # pragma: no cover - compiled
    """(speed [kn], signed TWA [deg], tack code of the leg, motoring)."""
    twa_nodes, tws_nodes, f, fa, fw, no_go, tws_cap = tables
    d = (frm - course) % 360.0
    twa = d - 360.0 if d > 180.0 else d
    if tws < motor_below:
        return motor_kn, twa, 0, True
    w = tws if tws < tws_cap else tws_cap
    spd = polar_speed_scalar(abs(twa), w, twa_nodes, tws_nodes, f, fa, fw, no_go)
    if abs(abs(twa) - 180.0) <= _RUN_TOL or twa == 0.0:
        tack = 0
    elif twa > 0.0:
        tack = 1
    else:
        tack = 2
    return spd, twa, tack, False


@jit
def sail_search(
    target, length_nm, course_deg, u, v, slice_h, hold, tables, motor_below, motor_kn,
    src, dst, t0_h, mode, layers, stop_h, h_node,
):  # fmt: skip  # pragma: no cover - compiled
    """Label-setting search from ``src`` at ``t0_h``; returns per-state arrival, manoeuvres, predecessor, leg data.

    ``target[node, d]`` is the node an offset reaches (-1: off the grid);
    ``stop_h`` ends a layered search once the popped key reaches it; ``h_node``
    [h] is a lower bound of the time from each node to ``dst`` (A*; zeros for
    Dijkstra), added to the time in the keys.
    Returns ``(t_h, omega, pred, twa, speed, motoring, settled_dst, stats)``
    with ``stats = [pops, relaxations, cut_past_forecast, max_tws_seen]``.
    """
    n_nodes, n_dir = target.shape
    L = layers if mode == MODE_LAYERED else 1
    n_states = n_nodes * 3 * L
    t_arr = np.full(n_states, np.inf)
    om = np.full(n_states, 1 << 30, dtype=np.int64)
    pred = np.full(n_states, -1, dtype=np.int64)
    twa_in = np.zeros(n_states)
    spd_in = np.zeros(n_states)
    mot_in = np.zeros(n_states, dtype=np.bool_)
    done = np.zeros(n_states, dtype=np.bool_)
    h1 = np.empty(4 * n_nodes + 16)
    h2 = np.empty(h1.size)
    hs = np.empty(h1.size, dtype=np.int64)
    s0 = src * 3 * L
    t_arr[s0], om[s0] = t0_h, 0
    f0 = t0_h + h_node[src]
    n = push(h1, h2, hs, np.int64(0), f0 if mode != MODE_FEWEST else 0.0, 0.0 if mode != MODE_FEWEST else f0, s0)
    stats = np.zeros(4)
    found = -1
    while n > 0:
        k1, k2, s, n = pop(h1, h2, hs, n)
        if done[s]:
            continue
        done[s] = True
        stats[0] += 1
        node = s // (3 * L)
        tack = (s // L) % 3
        layer = s % L
        t, w_om = t_arr[s], om[s]
        if node == dst:
            if mode != MODE_LAYERED:
                found = s
                break
            continue
        if mode == MODE_LAYERED and k1 >= stop_h:
            break
        tws, frm, ok = wind_at(u, v, slice_h, node, t, hold)
        if not ok:
            stats[2] += 1
            continue
        if tws > stats[3]:
            stats[3] = tws
        for d in range(n_dir):
            nxt = target[node, d]
            if nxt < 0:
                continue
            spd, twa, leg_tack, motoring = _leg(course_deg[node, d], tws, frm, tables, motor_below, motor_kn)
            if spd <= 0.0:
                continue
            stats[1] += 1
            new_tack = tack if leg_tack == 0 else leg_tack
            turn = 1 if (tack != 0 and leg_tack != 0 and leg_tack != tack) else 0
            nl = layer + turn if mode == MODE_LAYERED else 0
            if nl >= L:
                continue
            s2 = (nxt * 3 + new_tack) * L + nl
            if done[s2]:
                continue
            t2, o2 = t + length_nm[node, d] / spd, w_om + turn
            if mode == MODE_FEWEST:
                better = less(float(o2), t2, float(om[s2]), t_arr[s2])
            else:
                better = less(t2, float(o2), t_arr[s2], float(om[s2]))
            if better:
                if n == h1.size:  # grow the heap
                    h1, h2, hs = grown(h1, n), grown(h2, n), grown(hs, n)
                t_arr[s2], om[s2], pred[s2] = t2, o2, s
                twa_in[s2], spd_in[s2], mot_in[s2] = twa, spd, motoring
                if mode == MODE_FEWEST:
                    n = push(h1, h2, hs, n, float(o2), t2 + h_node[nxt], s2)
                else:
                    n = push(h1, h2, hs, n, t2 + h_node[nxt], float(o2), s2)
    return t_arr, om, pred, twa_in, spd_in, mot_in, found, stats
