"""Lower bound on the least fuel of a fixed path in static weather: the Lagrangian dual, any fuel curve.

On a fixed path with static weather and no current, leg ``k`` sailed at the
constant speed through water ``v_k`` [kn] takes ``t_k = d_k / v_k`` [h] and burns
``F_k(v_k) = t_k · r_k(v_k)`` [t], with ``r_k`` the leg's fuel rate [t/h] (the
length-weighted mean of the rate along the leg). The passage problem

    minimise    Σ_k [ w F_k(v_k) + c t_k ]
    subject to  Σ_k t_k ≤ T   (or = T)
                v_k ∈ A_k  (a union of closed speed intervals: load limits, outside every band)

separates per leg but for the one coupling row. Its Lagrangian dual function

    g(λ) = Σ_k min_{v ∈ A_k} (d_k / v) [ w r_k(v) + c + λ ] − λ T

is a lower bound on the optimum for every λ ≥ 0 (every real λ for ``= T``) by weak
duality, whatever the shape of ``r_k``: no convexity is needed, only that each
leg's inner minimum is taken *globally* over ``A_k`` (Bertsekas, *Nonlinear
Programming*, §6.1; Everett 1963 for the separable form). ``g`` is concave in λ
(a minimum of affine functions), so its maximum is found by a bracketed search
on the supergradient ``Σ_k t_k(λ) − T``.

The inner minima
----------------
* **Tabulated rates** (:class:`TabulatedFuelRate`: ``r_k`` linear between speed
  nodes): on each linear piece ``(d/v)(α + β v + μ)`` is monotone in ``v``, so the
  minimum over ``A_k`` is attained at a node or an interval end. Evaluating those
  is exact; no sampling error.
* **Callables**: every allowed interval is sampled uniformly, then refined
  (Piyavskii–Shubert style): each cell ``[v_a, v_b]`` of width ``δ`` between two
  samples has the lower bound ``(h_a + h_b)/2 − L δ / 2`` of an ``L``-Lipschitz
  function, with ``L = κ · max |secant slope|`` of the cell and its two neighbours
  (``κ = lipschitz_factor``, 2 by default); every cell whose lower bound lies
  more than ``rtol`` below the best sample is split, until none is or the round
  budget is spent. The bound reported subtracts those cell lower bounds, so its
  only assumption is stated: *within each final cell the slope of the leg's
  cost is at most κ times the largest secant slope of that cell and its
  neighbours*. For a convex cost that holds with κ = 1 in interior cells; for a
  smooth one it holds once the cells resolve its curvature; it can fail only for
  a feature narrower than a cell that no sample sees. ``sampling_margin`` is
  the part of the bound given up for it.

The primal schedule is recovered from the dual: every leg at its minimiser for
λ just above λ* (so ``Σ t ≤ T``), then the slack handed greedily to the legs
that gain most from it; with ``eta_mode="eq"`` the slack left is absorbed by
slowing legs inside their own interval. Its objective is an upper bound, so
``primal_objective − bound`` brackets the optimum. With bands the allowed sets
are not convex and the duality gap need not vanish (one coupling row: at most
about one leg's non-convexity, Shapley–Folkman).

Units: distances [nm], times [h], speeds [kn], fuel [t], rates [t/h]. This
module never imports :mod:`optroute`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from formulations.common import FormulationInputError, as_float_array

__all__ = ["ShipBoundResult", "TabulatedFuelRate", "lagrangian_bound"]

#: A vectorised fuel rate: ``rate(leg, v)`` with ``leg`` an int array and ``v`` [kn] a float array of one shape,
#: returning the fuel rate [t/h] of leg ``leg[i]`` at speed ``v[i]``.
FuelRateFn = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class TabulatedFuelRate:
    """Per-leg fuel rate tabulated over speed, linear between the nodes.

    Attributes
    ----------
    speed_kn : numpy.ndarray, shape (K,)
        Speed nodes [kn], strictly increasing, > 0.
    rate_tph : numpy.ndarray, shape (n, K)
        Fuel rate of every leg at every node [t/h], finite and ≥ 0.
    """

    speed_kn: np.ndarray
    rate_tph: np.ndarray

    def __post_init__(self) -> None:
        v = as_float_array(self.speed_kn, "speed_kn", ndim=1)
        r = as_float_array(self.rate_tph, "rate_tph", ndim=2)
        if v.size < 2 or np.any(np.diff(v) <= 0) or v[0] <= 0:
            raise FormulationInputError(f"speed_kn must be > 0 and strictly increasing with 2+ nodes, got {v}")
        if r.shape[1] != v.size or np.any(r < 0):
            raise FormulationInputError(f"rate_tph must have shape (n, {v.size}) and be >= 0, got {r.shape}")
        object.__setattr__(self, "speed_kn", v)
        object.__setattr__(self, "rate_tph", r)

    def __call__(self, leg: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Linear interpolation of leg ``leg[i]``'s rate at ``v[i]`` [t/h]; NaN outside the nodes."""
        sp = self.speed_kn
        j = np.clip(np.searchsorted(sp, v, side="right") - 1, 0, sp.size - 2)
        f = (v - sp[j]) / (sp[j + 1] - sp[j])
        out = (1.0 - f) * self.rate_tph[leg, j] + f * self.rate_tph[leg, j + 1]
        return np.where((v >= sp[0]) & (v <= sp[-1]), out, np.nan)


@dataclass(frozen=True)
class ShipBoundResult:
    """Result of :func:`lagrangian_bound`.

    Attributes
    ----------
    status : str
        ``"converged"`` (λ maximised, every inner minimum certified to ``rtol``),
        ``"refinement_budget"`` (the bound is valid under the Lipschitz assumption but the
        sampling margin is above ``rtol``), ``"infeasible"`` (no allowed speeds meet the
        ETA: the dual is unbounded, ``bound = inf``) or ``"empty_leg"`` (a leg has no
        allowed speed at all, ``bound = inf``).
    bound : float
        Lower bound on the optimal objective (fuel [t] for the default weights).
    lambda_tph : float
        The maximising multiplier of the ETA row [objective units per hour, t/h for fuel].
    minimiser_speed_kn, minimiser_time_h : numpy.ndarray, shape (n,)
        Each leg's inner minimiser at λ* (the faster one where two tie).
    primal_speed_kn, primal_time_h : numpy.ndarray, shape (n,)
        The feasible schedule recovered from the dual (NaN when none was found).
    primal_objective : float
        Its objective (evaluated from the rate function); ``nan`` when none.
    duality_gap : float
        ``(primal_objective − bound) / |primal_objective|``: how far the bound may be
        from the optimum, at most.
    sampling_margin : float
        ``Σ_k (best sample_k − certified minimum_k)`` at λ*: what the bound gives up for
        the sampling (0 for a tabulated rate).
    evaluations : int
        Number of fuel-rate evaluations (leg, speed pairs).
    rounds : int
        Refinement rounds made.
    solve_time_s : float
        Wall-clock time [s].
    """

    status: str
    bound: float
    lambda_tph: float
    minimiser_speed_kn: np.ndarray
    minimiser_time_h: np.ndarray
    primal_speed_kn: np.ndarray
    primal_time_h: np.ndarray
    primal_objective: float
    duality_gap: float
    sampling_margin: float
    evaluations: int
    rounds: int
    solve_time_s: float


# --------------------------------------------------------------------------- samples


class _Points:
    """Speed samples of the legs with their fuel rates, sorted by leg: ``leg``, ``v`` [kn], ``r`` [t/h]."""

    def __init__(self, d: np.ndarray, leg: np.ndarray, v: np.ndarray, r: np.ndarray) -> None:
        self.d, self.leg, self.v, self.r = d, leg, v, r

    @property
    def t(self) -> np.ndarray:
        """Leg time at each sample [h]."""
        return self.d[self.leg] / self.v

    def cost(self, mu: float, w: float) -> np.ndarray:
        """``(d/v)(w r + μ)`` at every sample (μ = hourly cost + λ)."""
        return self.t * (w * self.r + mu)


def _lower_hulls(pts: _Points, w: float, c: float) -> _Points:
    """Per leg, the vertices of the lower convex hull of (t, t (w r + c)), sorted by leg then time.

    These are the only samples that minimise ``f + λ t`` for some λ. Points on or above the chord of
    their two neighbours are not vertices (whether or not the neighbours are), so all of them go at
    once; the pass is repeated until none is left (one pass for convex data).
    """
    t, f = pts.t, pts.cost(c, w)
    order = np.lexsort((f, t, pts.leg))
    order = order[np.isfinite(f[order])]
    leg, tt = pts.leg[order], t[order]
    first = np.concatenate([[True], (leg[1:] != leg[:-1]) | (tt[1:] != tt[:-1])])
    idx = order[first]  # one point per (leg, time): the cheapest
    while idx.size > 2:
        leg, tt, ff = pts.leg[idx], t[idx], f[idx]
        inner = np.flatnonzero((leg[1:-1] == leg[:-2]) & (leg[1:-1] == leg[2:])) + 1
        o, m, j = inner - 1, inner, inner + 1
        cross = (tt[m] - tt[o]) * (ff[j] - ff[o]) - (ff[m] - ff[o]) * (tt[j] - tt[o])
        drop = inner[cross <= 0.0]
        if drop.size == 0:
            break
        keep = np.ones(idx.size, dtype=bool)
        keep[drop] = False
        idx = idx[keep]
    return _Points(pts.d, pts.leg[idx], pts.v[idx], pts.r[idx])


class _Samples(_Points):
    """Flat samples of every allowed interval, sorted by (interval, speed), with their lower hulls."""

    def __init__(
        self, rate: FuelRateFn, d: np.ndarray, ivls: tuple[np.ndarray, np.ndarray, np.ndarray], w: float, c: float
    ) -> None:
        super().__init__(d, np.zeros(0, dtype=int), np.zeros(0), np.zeros(0))
        self.rate, self.w, self.c = rate, w, c
        self.ivl_leg, self.ivl_lo, self.ivl_hi = ivls
        self.ivl = np.zeros(0, dtype=int)
        self.hull = _Points(d, self.leg, self.v, self.r)
        self.evaluations = 0

    def add(self, ivl: np.ndarray, v: np.ndarray) -> None:
        """Evaluate the rate at new samples of intervals ``ivl`` and merge them in."""
        r = np.asarray(self.rate(self.ivl_leg[ivl], v), dtype=float)
        self.evaluations += v.size
        if r.shape != v.shape or np.isnan(r).any() or np.any(r < 0):
            bad = np.flatnonzero(~(r >= 0)) if r.shape == v.shape else np.zeros(1, dtype=int)
            raise FormulationInputError(
                f"the fuel rate must be a value >= 0 (or +inf) of shape {v.shape} at every allowed speed; it is "
                f"{r.ravel()[bad[0]] if r.shape == v.shape else r.shape} for leg {int(self.ivl_leg[ivl[bad[0]]])} "
                f"at {v[bad[0]]:.6g} kn: check the fuel-rate function and the allowed intervals"
            )
        ivl_all = np.concatenate([self.ivl, ivl])
        v_all = np.concatenate([self.v, v])
        order = np.lexsort((v_all, ivl_all))
        self.ivl, self.v, self.r = ivl_all[order], v_all[order], np.concatenate([self.r, r])[order]
        self.leg = self.ivl_leg[self.ivl]
        # the hull of the union is the hull of the old hull and the new points
        h = self.hull
        new = _Points(
            self.d, np.concatenate([h.leg, self.ivl_leg[ivl]]), np.concatenate([h.v, v]), np.concatenate([h.r, r])
        )
        self.hull = _lower_hulls(new, self.w, self.c)


def _maximise_lambda(
    hull: _Points, w: float, c: float, eta_h: float | None, mode: str
) -> tuple[float, np.ndarray, np.ndarray]:
    """λ* maximising the dual over the sampled speeds, exactly, from the legs' lower hulls.

    Along a leg's hull (time increasing) the edges save ``σ = −Δf/Δt`` per hour, decreasing; at
    λ a leg takes every edge with ``σ > λ``. The dual's maximum is where the edges taken, most
    saving first, use up ``T − Σ t_fastest``: λ* is the σ of the edge that does not fit
    (a fractional knapsack; ``max(·, 0)`` for ``Σ t ≤ T``).

    Returns
    -------
    (λ*, fast, slow)
        ``fast``/``slow``: per leg the index into ``hull`` of the minimiser at λ* taking the edges
        with σ > λ* (resp. σ ≥ λ*); ``Σ t`` over ``fast`` is at most ``T``.
    """
    t, f, leg = hull.t, hull.cost(c, w), hull.leg
    start = np.flatnonzero(np.concatenate([[True], leg[1:] != leg[:-1]]))
    edge = np.flatnonzero(leg[1:] == leg[:-1])  # edge e joins hull points e and e + 1
    dt = t[edge + 1] - t[edge]
    sigma = -(f[edge + 1] - f[edge]) / dt
    if eta_h is None:
        lam = 0.0
    else:
        order = np.argsort(-sigma, kind="stable")
        budget = eta_h - float(t[start].sum())
        over = np.flatnonzero(np.cumsum(dt[order]) > budget * (1.0 + 1e-15))
        lam = float(sigma[order[over[0]]]) if over.size else (0.0 if mode == "le" else float(sigma.min(initial=0.0)))
        if mode == "le":
            lam = max(lam, 0.0)

    def vertex(taken: np.ndarray) -> np.ndarray:
        return start + np.bincount(leg[edge[taken]], minlength=hull.d.size)[leg[start]]

    return lam, vertex(sigma > lam), vertex(sigma >= lam)


def _cell_bounds(
    s: _Samples, mu: float, w: float, kappa: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Lipschitz lower bound of every cell: (cell's first sample index, lower bound, width, point costs)."""
    h = s.cost(mu, w)
    same = s.ivl[1:] == s.ivl[:-1]
    a = np.flatnonzero(same)
    width = s.v[a + 1] - s.v[a]
    slope = np.abs(h[a + 1] - h[a]) / np.where(width > 0, width, 1.0)
    prev = np.zeros_like(slope)
    nxt = np.zeros_like(slope)
    if a.size > 1:
        joined = a[1:] == a[:-1] + 1  # consecutive cells of one interval
        prev[1:] = np.where(joined, slope[:-1], 0.0)
        nxt[:-1] = np.where(joined, slope[1:], 0.0)
    lip = kappa * np.maximum(slope, np.maximum(prev, nxt))
    lb = 0.5 * (h[a] + h[a + 1]) - 0.5 * lip * width
    lb = np.where(np.isfinite(lb), lb, np.minimum(h[a], h[a + 1]))
    return a, lb, width, h


def _leg_lower(s: _Samples, mu: float, w: float, kappa: float, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per leg: best sample, certified lower bound, and the cells that hold the bound down."""
    a, lb, _, h = _cell_bounds(s, mu, w, kappa)
    leg = s.leg
    best = np.full(n, np.inf)
    np.minimum.at(best, leg, h)
    low = best.copy()
    np.minimum.at(low, leg[a], lb)
    return best, low, a[lb < best[leg[a]]] if a.size else a


def _refine(
    s: _Samples, mu: float, w: float, kappa: float, n: int, rtol: float, per_cell: int
) -> tuple[np.ndarray, np.ndarray, bool]:
    """One refinement round at μ = c + λ; returns (best, lower, converged)."""
    a, lb, _, h = _cell_bounds(s, mu, w, kappa)
    leg = s.leg
    best = np.full(n, np.inf)
    np.minimum.at(best, leg, h)
    low = best.copy()
    if a.size:
        np.minimum.at(low, leg[a], lb)
    tol = rtol * np.abs(best) + 1e-300
    split = a[lb < best[leg[a]] - tol[leg[a]]] if a.size else a
    if split.size == 0:
        return best, low, True
    f = np.arange(1, per_cell + 1) / (per_cell + 1)
    v_new = s.v[split, None] + f[None, :] * (s.v[split + 1] - s.v[split])[:, None]
    ivl_new = np.repeat(s.ivl[split], per_cell)
    s.add(ivl_new, v_new.ravel())
    return best, low, False


# --------------------------------------------------------------------------- inputs


def _intervals(allowed_kn: Sequence[Sequence[tuple[float, float]]], n: int) -> tuple[np.ndarray, ...]:
    if len(allowed_kn) != n:
        raise FormulationInputError(
            f"allowed_kn must hold one list of (lo, hi) intervals per leg ({n}), got {len(allowed_kn)}"
        )
    leg, lo, hi = [], [], []
    for k, ivls in enumerate(allowed_kn):
        for pair in ivls:
            a, b = float(pair[0]), float(pair[1])
            if not (math.isfinite(a) and math.isfinite(b) and 0.0 < a <= b):
                raise FormulationInputError(
                    f"allowed interval ({a}, {b}) of leg {k} must satisfy 0 < lo <= hi < inf [kn]; "
                    "cut speeds at a positive minimum and a finite maximum"
                )
            leg.append(k)
            lo.append(a)
            hi.append(b)
    return np.array(leg, dtype=int), np.array(lo), np.array(hi)


def _initial_samples(s: _Samples, rate: FuelRateFn | TabulatedFuelRate, per_interval: int) -> None:
    """Every interval's ends and, for a table, its nodes inside; for a callable, ``per_interval`` uniform points."""
    ivl, v = [], []
    for i, (a, b) in enumerate(zip(s.ivl_lo, s.ivl_hi, strict=True)):
        if isinstance(rate, TabulatedFuelRate):
            sp = rate.speed_kn
            if a < sp[0] or b > sp[-1]:
                raise FormulationInputError(
                    f"allowed interval ({a}, {b}) of leg {int(s.ivl_leg[i])} leaves the table's speeds "
                    f"{sp[0]}–{sp[-1]} kn: extend the table or cut the interval"
                )
            pts = np.unique(np.concatenate([[a, b], sp[(sp > a) & (sp < b)]]))
        else:
            pts = np.unique(np.linspace(a, b, per_interval if b > a else 1))
        ivl.append(np.full(pts.size, i))
        v.append(pts)
    s.add(np.concatenate(ivl), np.concatenate(v))


# --------------------------------------------------------------------------- primal recovery


def _greedy(
    s: _Points, v: np.ndarray, r: np.ndarray, slack: float, w: float, c: float, tol_h: float, by_rate: bool
) -> tuple[np.ndarray, np.ndarray, float]:
    """Move legs to other samples that fit in the slack and lower the objective, best move first.

    ``by_rate``: best saving per hour of slack used (moves that also save time first); else the
    largest saving.
    """
    d, leg_of = s.d, s.leg
    v, r = v.copy(), r.copy()
    t_all = d[leg_of] / s.v
    obj_all = t_all * (w * s.r + c)
    for _ in range(4 * d.size + 10):
        t_cur = d / v
        cur = (t_cur * (w * r + c))[leg_of]
        extra = t_all - t_cur[leg_of]
        saving = cur - obj_all
        good = (extra <= slack + tol_h) & (saving > 1e-15 * np.maximum(1.0, np.abs(cur)))
        if not good.any():
            break
        free = good & (extra <= 0)
        if by_rate and free.any():
            j = int(np.argmax(np.where(free, saving, -np.inf)))
        elif by_rate:
            j = int(np.argmax(np.where(good, saving / np.where(extra > 0, extra, 1.0), -np.inf)))
        else:
            j = int(np.argmax(np.where(good, saving, -np.inf)))
        k = int(leg_of[j])
        slack -= t_all[j] - t_cur[k]
        v[k], r[k] = s.v[j], s.r[j]
    return v, r, slack


def _repair(
    s: _Points, v: np.ndarray, r: np.ndarray, excess: float, w: float, c: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """Speed legs up until ``Σ t`` is back within ``T``: the cheapest single move that does it, else per hour."""
    d, leg_of = s.d, s.leg
    v, r = v.copy(), r.copy()
    t_all = d[leg_of] / s.v
    obj_all = t_all * (w * s.r + c)
    for _ in range(4 * d.size + 10):
        if excess <= 0:
            break
        t_cur = d / v
        saved = t_cur[leg_of] - t_all
        added = obj_all - (t_cur * (w * r + c))[leg_of]
        # the cheapest move that alone ends the excess; failing that, the cheapest per hour saved
        ends = saved >= excess
        if ends.any():
            score = np.where(ends, added, np.inf)
        else:
            score = np.where(saved > 0, added / np.where(saved > 0, saved, 1.0), np.inf)
        j = int(np.argmin(score))
        if not np.isfinite(score[j]):
            break
        k = int(leg_of[j])
        excess -= saved[j]
        v[k], r[k] = s.v[j], s.r[j]
    return v, r, -excess


def _candidates(s: _Samples, lam: float) -> _Points:
    """The moves the greedy steps consider: every sample on small problems, else per allowed interval its
    ends and its own minimisers at prices about λ*.

    Within an interval the speed is settled afterwards by the re-solve with the intervals held
    (:func:`lagrangian_bound`'s ``polish_primal``), so the steps need mainly choose the intervals.
    """
    ivl = s.ivl
    starts = np.flatnonzero(np.concatenate([[True], ivl[1:] != ivl[:-1]]))
    ends = np.concatenate([starts[1:], [ivl.size]]) - 1
    if s.v.size * (4 * s.d.size + 10) <= 2e7:  # small enough for the steps to scan every sample
        return _Points(s.d, s.leg, s.v, s.r)
    # the interval's minimisers at prices about λ*: where a leg would go if time were dearer or cheaper
    inner = [_group_argmin(s.cost(s.c + f * lam, s.w), ivl, s.t) for f in (0.0, 0.5, 0.8, 0.9, 1.0, 1.1, 1.25, 2.0)]
    idx = np.unique(np.concatenate([starts, ends, *inner]))
    return _Points(s.d, s.leg[idx], s.v[idx], s.r[idx])


def _group_argmin(cost: np.ndarray, group: np.ndarray, tiebreak: np.ndarray) -> np.ndarray:
    """Index of the smallest cost per group (sorted by group); ties: smallest ``tiebreak``."""
    starts = np.flatnonzero(np.concatenate([[True], group[1:] != group[:-1]]))
    low = np.minimum.reduceat(cost, starts)
    key = np.where(cost == np.repeat(low, np.diff(np.concatenate([starts, [cost.size]]))), tiebreak, np.inf)
    best = np.minimum.reduceat(key, starts)
    pos = np.where(
        key == np.repeat(best, np.diff(np.concatenate([starts, [cost.size]]))), np.arange(cost.size), cost.size
    )
    return np.minimum.reduceat(pos, starts)


def _recover_primal(
    s: _Samples,
    lam: float,
    fast: tuple[np.ndarray, np.ndarray],
    slow: tuple[np.ndarray, np.ndarray],
    w: float,
    c: float,
    eta_h: float | None,
    mode: str,
) -> tuple[np.ndarray, np.ndarray, float]:
    """A feasible schedule from the dual's minimisers (speeds and rates, faster and slower ones on ties).

    The best of: the fast ones with the slack handed out greedily (per hour, or by size), and the slow
    ones sped up where cheapest until ``Σ t ≤ T``, then the same.
    """
    (v_fast, r_fast), (v_slow, r_slow) = fast, slow
    d = s.d
    n = d.size
    nan = (np.full(n, np.nan), np.full(n, np.nan), math.nan)
    v, r = v_fast.copy(), r_fast.copy()
    if eta_h is not None:
        slack0 = eta_h - float((d / v).sum())
        if slack0 < -1e-9 * eta_h:
            return nan
        tol = 1e-12 * eta_h
        cand = _candidates(s, lam)
        tries = [_greedy(cand, v_fast, r_fast, slack0, w, c, tol, by) for by in (True, False)]
        # from the slower minimisers (Σ t ≥ T): speed the cheapest legs up, then hand out what is left
        v_s, r_s, slack_s = _repair(cand, v_slow, r_slow, float((d / v_slow).sum()) - eta_h, w, c)
        if slack_s >= -tol:
            tries.append(_greedy(cand, v_s, r_s, slack_s, w, c, tol, True))
        v, r, slack = min(tries, key=lambda x: float((d / x[0] * (w * x[1] + c)).sum()))
        if mode == "eq" and slack > 1e-12 * eta_h:
            for k in range(n):  # slow legs inside their own interval until Σ t = T
                if slack <= 1e-12 * eta_h:
                    break
                inside = (s.ivl_leg == k) & (s.ivl_lo <= v[k] + 1e-12) & (s.ivl_hi >= v[k] - 1e-12)
                a = float(s.ivl_lo[np.flatnonzero(inside)[0]])
                t_new = min(d[k] / a, d[k] / v[k] + slack)
                slack -= t_new - d[k] / v[k]
                v[k] = d[k] / t_new
                r[k] = float(s.rate(np.array([k]), np.array([v[k]]))[0])
                s.evaluations += 1
            if slack > 1e-9 * eta_h:  # the chosen intervals cannot take T: choose intervals that can
                exact = _exact_time_schedule(s, eta_h, w, c)
                if exact is None:
                    return nan
                v, r = exact
    t = d / v
    return v, t, float((t * (w * r + c)).sum())


#: Most combinations of the legs' allowed intervals :func:`_exact_time_schedule` enumerates.
MAX_INTERVAL_COMBINATIONS = 4096


def _exact_time_schedule(s: _Samples, eta_h: float, w: float, c: float) -> tuple[np.ndarray, np.ndarray] | None:
    """A schedule with ``Σ t = T`` exactly, where the greedy steps' intervals cannot absorb the slack.

    Every combination of one allowed interval per leg whose passage times bracket ``T`` is feasible:
    each leg's time moves the same fraction θ from its fastest to its slowest end of the interval so that
    ``Σ t = T``; the cheapest such schedule is returned (the re-solve with the intervals held,
    ``polish_primal``, settles the speeds inside them). ``None`` when no combination brackets ``T``, or
    when there are more than :data:`MAX_INTERVAL_COMBINATIONS` of them.
    """
    d, n = s.d, s.d.size
    per_leg = [np.flatnonzero(s.ivl_leg == k) for k in range(n)]
    if math.prod(len(p) for p in per_leg) > MAX_INTERVAL_COMBINATIONS:
        return None
    combos = np.stack(np.meshgrid(*per_leg, indexing="ij"), axis=-1).reshape(-1, n)
    t_lo, t_hi = d / s.ivl_hi[combos], d / s.ivl_lo[combos]
    lo_sum, hi_sum = t_lo.sum(axis=1), t_hi.sum(axis=1)
    ok = (lo_sum <= eta_h) & (eta_h <= hi_sum)
    if not ok.any():
        return None
    t_lo, t_hi, lo_sum, hi_sum = t_lo[ok], t_hi[ok], lo_sum[ok], hi_sum[ok]
    span = hi_sum - lo_sum
    theta = np.where(span > 0, (eta_h - lo_sum) / np.where(span > 0, span, 1.0), 0.0)
    t = t_lo + theta[:, None] * (t_hi - t_lo)
    v = d / t
    r = np.asarray(s.rate(np.tile(np.arange(n), v.shape[0]), v.ravel()), dtype=float).reshape(v.shape)
    s.evaluations += v.size
    k = int(np.argmin((t * (w * r + c)).sum(axis=1)))
    return v[k].copy(), r[k].copy()


# --------------------------------------------------------------------------- the bound


def _check_options(
    d: np.ndarray,
    fuel_rate: FuelRateFn | TabulatedFuelRate,
    eta_h: float | None,
    eta_mode: str,
    reals: tuple[float, float, float, float],
    counts: tuple[int, int, int],
) -> None:
    """Raise FormulationInputError naming the first bad input of :func:`lagrangian_bound`."""
    if d.size == 0 or np.any(d <= 0):
        raise FormulationInputError(f"distance_nm must be non-empty and > 0 [nm], got {d}")
    if eta_mode not in ("le", "eq"):
        raise FormulationInputError(f"eta_mode must be 'le' or 'eq', got {eta_mode!r}")
    if eta_h is not None and not (math.isfinite(eta_h) and eta_h > 0):
        raise FormulationInputError(f"eta_h must be a positive number of hours or None, got {eta_h}")
    price, hourly, kappa, rtol = reals
    if not (price > 0 and hourly >= 0 and kappa >= 1 and rtol > 0):
        raise FormulationInputError(
            f"need fuel_price > 0, hourly_cost >= 0, lipschitz_factor >= 1 and rtol > 0; got {price}, {hourly}, "
            f"{kappa}, {rtol}"
        )
    if counts[0] < 2 or counts[1] < 1 or counts[2] < 0:
        raise FormulationInputError(
            f"samples_per_interval >= 2, refine_per_cell >= 1 and max_rounds >= 0 are needed, got {counts}"
        )
    if isinstance(fuel_rate, TabulatedFuelRate) and fuel_rate.rate_tph.shape[0] != d.size:
        raise FormulationInputError(f"the fuel-rate table has {fuel_rate.rate_tph.shape[0]} legs, not {d.size}")


def _certify(
    s: _Samples, eta_h: float | None, mode: str, kappa: float, rtol: float, per_cell: int, max_rounds: int
) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool, int]:
    """Refine at λ* until every leg's inner minimum is certified; (λ*, fast, slow, best, lower, converged, rounds)."""
    n, w, c = s.d.size, s.w, s.c
    tabulated = isinstance(s.rate, TabulatedFuelRate)
    rounds, converged = 0, tabulated
    lam, fast, slow = _maximise_lambda(s.hull, w, c, eta_h, mode)
    while not tabulated and rounds < max_rounds:
        _, _, converged = _refine(s, c + lam, w, kappa, n, rtol, per_cell)
        rounds += 1
        lam, fast, slow = _maximise_lambda(s.hull, w, c, eta_h, mode)
        if converged:
            break
    best, low, _ = _leg_lower(s, c + lam, w, kappa, n)
    if tabulated:
        low = best  # exact: the minimum over a linear piece is at its ends, all sampled
    else:
        converged = bool(np.all(best - low <= rtol * np.abs(best) + 1e-300))
    return lam, fast, slow, best, low, converged, rounds


def _no_bound(status: str, n: int, evaluations: int, started: float) -> ShipBoundResult:
    nan = np.full(n, np.nan)
    elapsed = time.perf_counter() - started
    return ShipBoundResult(
        status, math.inf, math.nan, nan, nan, nan, nan, math.nan, math.nan, 0.0, evaluations, 0, elapsed
    )


def lagrangian_bound(
    distance_nm: ArrayLike,
    allowed_kn: Sequence[Sequence[tuple[float, float]]],
    fuel_rate: FuelRateFn | TabulatedFuelRate,
    *,
    eta_h: float | None,
    eta_mode: Literal["le", "eq"] = "le",
    fuel_price: float = 1.0,
    hourly_cost: float = 0.0,
    samples_per_interval: int = 65,
    refine_per_cell: int = 8,
    rtol: float = 1e-10,
    lipschitz_factor: float = 2.0,
    max_rounds: int = 60,
    polish_primal: bool = True,
) -> ShipBoundResult:
    """Lower bound on the least objective of a fixed path in static weather (Lagrangian dual).

    Parameters
    ----------
    distance_nm : array_like, shape (n,)
        Leg lengths ``d_k`` [nm], > 0.
    allowed_kn : sequence of n sequences of (lo, hi)
        Each leg's allowed speeds through water [kn] as closed intervals with
        ``0 < lo <= hi < inf``: between the engine's load limits and outside every danger band
        (their closure: a bound over a superset of the feasible speeds stays a bound).
    fuel_rate : callable or TabulatedFuelRate
        ``fuel_rate(leg, v)`` → rate [t/h] of leg ``leg[i]`` at ``v[i]`` [kn], vectorised over
        equal-shaped arrays (``+inf`` allowed where no engine makes the speed); or a table.
    eta_h : float or None
        Passage time allowed ``T`` [h]; ``None``: no ETA row (λ = 0).
    eta_mode : {"le", "eq"}
        ``Σ t ≤ T`` (λ ≥ 0) or ``Σ t = T`` (λ free).
    fuel_price, hourly_cost : float
        Objective ``fuel_price · Σ F_k + hourly_cost · Σ t_k`` (default: fuel [t]).
    samples_per_interval : int
        Uniform samples of every allowed interval to start from (callables).
    refine_per_cell : int
        Points inserted into every cell that still holds the bound down.
    rtol : float
        Relative tolerance of each leg's certified inner minimum.
    lipschitz_factor : float
        κ ≥ 1: the assumed ratio of the cost's slope inside a cell to the largest nearby secant
        slope (see the module docstring).
    max_rounds : int
        Refinement rounds at most.
    polish_primal : bool
        Improve the recovered schedule by a second dual solve with every leg held to the allowed
        interval its recovered speed lies in (the bound itself is not changed by it).

    Returns
    -------
    ShipBoundResult

    Raises
    ------
    FormulationInputError
        Non-positive distances, bad intervals, a NaN or negative fuel rate, or bad options.
    """
    started = time.perf_counter()
    d = as_float_array(distance_nm, "distance_nm", ndim=1)
    n = d.size
    _check_options(d, fuel_rate, eta_h, eta_mode, (fuel_price, hourly_cost, lipschitz_factor, rtol),
                   (samples_per_interval, refine_per_cell, max_rounds))  # fmt: skip
    ivl_leg, ivl_lo, ivl_hi = _intervals(allowed_kn, n)
    w, c = float(fuel_price), float(hourly_cost)
    empty = np.setdiff1d(np.arange(n), ivl_leg)
    if empty.size:
        return _no_bound("empty_leg", n, 0, started)
    s = _Samples(fuel_rate, d, (ivl_leg, ivl_lo, ivl_hi), w, c)
    _initial_samples(s, fuel_rate, samples_per_interval)
    if eta_h is not None:
        fastest = float(sum(d[k] / ivl_hi[ivl_leg == k].max() for k in range(n)))
        slowest = float(sum(d[k] / ivl_lo[ivl_leg == k].min() for k in range(n)))
        if fastest > eta_h * (1 + 1e-12) or (eta_mode == "eq" and slowest < eta_h * (1 - 1e-12)):
            return _no_bound("infeasible", n, s.evaluations, started)
    lam, fast, slow, best, low, converged, rounds = _certify(
        s, eta_h, eta_mode, lipschitz_factor, rtol, refine_per_cell, max_rounds
    )
    bound = float(low.sum() - (lam * eta_h if eta_h is not None else 0.0))
    v_fast, r_fast = s.hull.v[fast], s.hull.r[fast]
    slow_vr = (s.hull.v[slow], s.hull.r[slow])
    v_p, t_p, obj_p = _recover_primal(s, lam, (v_fast, r_fast), slow_vr, w, c, eta_h, eta_mode)
    evaluations = s.evaluations
    if polish_primal and eta_h is not None and math.isfinite(obj_p) and ivl_leg.size > n:
        # every leg held to the interval its recovered speed is in: no band left to jump, so for convex
        # curves this dual has no gap and its recovered schedule is the optimum of that choice of sides
        held = [[(float(a), float(b)) for a, b in zip(ivl_lo[ivl_leg == k], ivl_hi[ivl_leg == k], strict=True)
                 if a - 1e-12 <= v_p[k] <= b + 1e-12][:1] for k in range(n)]  # fmt: skip
        sub = lagrangian_bound(
            d, held, fuel_rate, eta_h=eta_h, eta_mode=eta_mode, fuel_price=w, hourly_cost=c,
            samples_per_interval=samples_per_interval, refine_per_cell=refine_per_cell, rtol=rtol,
            lipschitz_factor=lipschitz_factor, max_rounds=max_rounds, polish_primal=False,
        )  # fmt: skip
        evaluations += sub.evaluations
        if sub.primal_objective < obj_p:
            v_p, t_p, obj_p = sub.primal_speed_kn, sub.primal_time_h, sub.primal_objective
    gap = (obj_p - bound) / abs(obj_p) if math.isfinite(obj_p) and obj_p != 0 else math.nan
    return ShipBoundResult(
        status="converged" if converged else "refinement_budget",
        bound=bound,
        lambda_tph=float(lam),
        minimiser_speed_kn=v_fast,
        minimiser_time_h=d / v_fast,
        primal_speed_kn=v_p,
        primal_time_h=t_p,
        primal_objective=obj_p,
        duality_gap=float(gap),
        sampling_margin=float((best - low).sum()),
        evaluations=evaluations,
        rounds=rounds,
        solve_time_s=time.perf_counter() - started,
    )
