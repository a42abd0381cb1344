"""The 3-D DP's stage transitions: costing the legs between two stages and keeping each bin's Pareto labels.

:func:`optroute.search.dp.solve_dp` runs the forward recursion; this module is its inner step.
:class:`Transition` costs legs from stage k to k+1 through the leg-cost callback, checks the speed
contract, the horizon and the no-go areas along each leg; :class:`CompiledStages` does the same with
the compiled kernels of :mod:`optroute.search.dp_kernels` (best first under a fuel floor).
:func:`pareto_winners` keeps, per (lateral, arrival-time bin), up to ``labels_per_bin`` labels of the
bin's Pareto set on (fuel, time) that pass the no-go test, testing lazily (:func:`lazy_winners`);
:func:`stage_tables` lays them out as one stage's tables.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from optroute import geodesy as geo
from optroute.errors import ConfigError
from optroute.search.costs import unpack_cost
from optroute.search.dp_kernels import DPLegKernel, JointLegKernel, enumerate_candidates, resolve
from optroute.search.passage_kernels import clear_dp_legs, cost_dp_legs

__all__ = ["CompiledStages", "LegCostFn", "LegsBlockedFn", "NoGoFn", "Transition", "append_stage", "combos", "empty_stage",
           "in_every_member", "lazy_winners", "nav_check", "pareto_winners", "stage_tables"]  # fmt: skip

LegCostFn = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], Any]
NoGoFn = Callable[[np.ndarray, np.ndarray, np.ndarray], ArrayLike]
LegsBlockedFn = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], ArrayLike]

_SPEED_TOL = 1e-9


def stage_tables(n_lat, n_bins, lateral, bins, slot, fuel, time, back_l, back_b, speed_i) -> tuple:
    """One stage's (fuel, time, back lateral, back column, speed index) tables, (n_lat, n_bins × width), and the width.

    A label in bin ``b``, slot ``j`` (its place in the bin's Pareto set) is column ``b × width + j``,
    the width the largest slot + 1.
    """
    width = int(slot.max()) + 1 if slot.size else 1
    col = bins * width + slot
    out = (np.full((n_lat, n_bins * width), np.inf), np.full((n_lat, n_bins * width), np.nan),
           np.full((n_lat, n_bins * width), -1, dtype=np.int32), np.full((n_lat, n_bins * width), -1, dtype=np.int64),
           np.full((n_lat, n_bins * width), -1, dtype=np.int16))  # fmt: skip
    for table, values in zip(out, (fuel, time, back_l, back_b, speed_i), strict=True):
        table[lateral, col] = values
    return (*out, width)


def empty_stage(n_lat: int, n_bins: int) -> tuple:
    """A stage's tables without a label (width 1)."""
    none_i, none_f = np.zeros(0, dtype=np.int64), np.zeros(0)
    return stage_tables(n_lat, n_bins, none_i, none_i, none_i, none_f, none_f, none_i, none_i, none_i)


def append_stage(tables: tuple, widths: list[int], stage: tuple) -> None:
    for table, new in zip(tables, stage[:-1], strict=True):
        table.append(new)
    widths.append(stage[-1])


def pareto_winners(
    key: np.ndarray, f: np.ndarray, t: np.ndarray, clear: Callable[[np.ndarray], np.ndarray], labels: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """Per key, up to ``labels`` candidates of its Pareto set on (f, t) that pass ``clear``: (indices, slot).

    Slot 0 is the least (f, t) candidate that is clear (:func:`lazy_winners`); slot j + 1 the least
    (f, t) clear one strictly earlier than slot j's.
    """
    alive = np.ones(key.size, dtype=bool)
    won, slots = [], []
    for slot in itertools.count() if labels is None else range(labels):
        q = np.nonzero(alive)[0]
        if q.size == 0:
            break
        w = q[lazy_winners(key[q], f[q], t[q], lambda r, q=q: clear(q[r]))]
        if w.size == 0:
            break
        won.append(w)
        slots.append(np.full(w.size, slot, dtype=np.int64))
        cut_keys, cut_t = key[w], t[w]
        o = np.argsort(cut_keys)
        i = np.searchsorted(cut_keys[o], key)
        has = (i < o.size) & (cut_keys[o][np.minimum(i, o.size - 1)] == key)
        alive &= has & (t < cut_t[o][np.minimum(i, o.size - 1)])
    if not won:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    return np.concatenate(won), np.concatenate(slots)


def lazy_winners(
    key: np.ndarray, f: np.ndarray, t: np.ndarray, clear: Callable[[np.ndarray], np.ndarray]
) -> np.ndarray:
    """Per key, the candidate of least (f, t) that passes ``clear``; the no-go test runs lazily.

    Candidates are ranked within their key; windows of ranks 0, 1–2, 3–6, …
    are tested until every key has a winner or runs out, so the (costly)
    no-go test mostly runs once per key instead of once per candidate.
    Returns the indices of the winners.
    """
    if key.size == 0:
        return np.zeros(0, dtype=np.int64)
    order = np.lexsort((t, f, key))
    ks = key[order]
    start = np.ones(ks.size, dtype=bool)
    start[1:] = ks[1:] != ks[:-1]
    group = np.cumsum(start) - 1
    rank = np.arange(ks.size) - np.nonzero(start)[0][group]
    resolved = np.zeros(int(group[-1]) + 1, dtype=bool)
    winners = []
    lo, width = 0, 1
    while True:
        window = (rank >= lo) & (rank < lo + width) & ~resolved[group]
        if not window.any():
            break
        q = np.nonzero(window)[0]
        good = q[clear(order[q])]
        if good.size:
            g = group[good]
            first = np.ones(good.size, dtype=bool)
            first[1:] = g[1:] != g[:-1]
            winners.append(order[good[first]])
            resolved[g[first]] = True
        lo, width = lo + width, 2 * width
    return np.concatenate(winners) if winners else np.zeros(0, dtype=np.int64)


def combos(src: np.ndarray, dest: np.ndarray, n_speeds: int, step: int | None) -> tuple[np.ndarray, ...]:
    """All (source, destination lateral, speed index) triples, flat; lateral step limited if ``step``."""
    a, b, v = np.meshgrid(src, dest, np.arange(n_speeds), indexing="ij")
    a, b, v = a.ravel(), b.ravel(), v.ravel()
    if step is not None:
        keep = np.abs(b - a) <= step
        a, b, v = a[keep], b[keep], v[keep]
    return a, b, v


class Transition:
    """Cost legs from stage k to k+1, check the speed contract, the horizon and the no-go areas."""

    def __init__(
        self,
        lat: np.ndarray,
        lon: np.ndarray,
        dists: list[np.ndarray],
        speeds: np.ndarray,
        leg_cost: LegCostFn,
        navigable: NoGoFn | None,
        nogo_step: float,
        rem_nm: np.ndarray,
        vmax: float,
        horizon: float,
        legs_blocked: LegsBlockedFn | None = None,
    ) -> None:
        self.lat, self.lon, self.dists, self.speeds = lat, lon, dists, speeds
        self.leg_cost, self.navigable, self.nogo_step = leg_cost, navigable, nogo_step
        self.rem_nm, self.vmax, self.horizon = rem_nm, vmax, horizon
        self.legs_blocked = legs_blocked
        self.count = 0
        self.stages: CompiledStages | None = None
        self._samples: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._open: dict[int, np.ndarray] = {}

    def _open_legs(self, k: int) -> np.ndarray:
        """Which legs from stage k's states to stage k+1's (La, Lb) ``legs_blocked`` lets through, once per stage."""
        if k not in self._open:
            la0, lb0 = np.meshgrid(self.lat[k], self.lat[k + 1], indexing="ij")
            lo0, lo1 = np.meshgrid(self.lon[k], self.lon[k + 1], indexing="ij")
            out = np.asarray(self.legs_blocked(la0, lo0, lb0, lo1))  # type: ignore[misc]
            if out.shape != la0.shape or out.dtype != bool:
                raise ConfigError(
                    f"legs_blocked(lat0, lon0, lat1, lon1) returned {out.dtype} of shape {out.shape}; "
                    f"return a bool array of shape {la0.shape}"
                )
            self._open[k] = ~out
        return self._open[k]

    def _samples_for(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if k not in self._samples:
            n = max(0, int(np.ceil(float(self.dists[k].max()) / self.nogo_step)) - 1)
            fr = (np.arange(n) + 1.0) / (n + 1.0)
            plat, plon = (
                _leg_samples(self.lat[k], self.lon[k], self.lat[k + 1], self.lon[k + 1], n) if n else (None, None)
            )
            self._samples[k] = (fr, plat, plon)
        return self._samples[k]

    def cost(
        self, k: int, l0: np.ndarray, lj: np.ndarray, vi: np.ndarray, t0: np.ndarray, check: bool = True
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Cost legs; return (ok, t1, fuel, duration) with ok = feasible and within the horizon.

        Without ``check`` the compiled legs are checked at their pieces' midpoints only (the callback's are checked
        in full): :meth:`clear` with ``between`` checks the rest.
        """
        sog = self.speeds[vi]
        if self.stages is not None:  # the compiled legs, their pieces computed once per stage
            dur, fu, feas = self.stages.cost_legs(k, l0, lj, vi, t0, check)
        else:
            out = self.leg_cost(self.lat[k, l0], self.lon[k, l0], self.lat[k + 1, lj], self.lon[k + 1, lj], t0, sog)
            dur, fu, feas, _ = unpack_cost(out, l0.size, "leg_cost")
        self.count += l0.size
        dd = self.dists[k][l0, lj]
        fast = feas & (dur * sog < dd * (1.0 - _SPEED_TOL))
        if fast.any():
            q = int(np.argmax(fast))
            raise ConfigError(
                f"leg_cost sailed a {dd[q]:.1f} nm leg in {dur[q]:.4g} h at a commanded {sog[q]} kn; the "
                "physics may only lower the commanded speed over ground (duration >= distance / sog_kn)"
            )
        t1 = t0 + dur
        ok = feas & (t1 + self.rem_nm[k + 1, lj] / self.vmax <= self.horizon + 1e-9)
        return ok, t1, fu, dur

    def clear(
        self, k: int, l0: np.ndarray, lj: np.ndarray, t0: np.ndarray, dur: np.ndarray, between: np.ndarray | None = None
    ) -> np.ndarray:
        """Whether each leg stays out of the no-go areas (samples along it and the state reached); with ``between``
        (the legs' speed indices), also clear between their pieces' midpoints (legs :meth:`cost` left unchecked)."""
        good = self._clear_of_no_go(k, l0, lj, t0, dur)
        if between is not None and self.stages is not None and good.any():
            q = np.flatnonzero(good)
            good[q] = self.stages.clear_legs(k, l0[q], lj[q], between[q], t0[q])
        return good

    def _clear_of_no_go(self, k: int, l0: np.ndarray, lj: np.ndarray, t0: np.ndarray, dur: np.ndarray) -> np.ndarray:
        good = np.ones(l0.size, dtype=bool) if self.legs_blocked is None else self._open_legs(k)[l0, lj]
        if self.navigable is None or not good.any():
            return good
        fr, plat, plon = self._samples_for(k)
        q = np.flatnonzero(good)
        good[q] = nav_check(self.navigable, self.lat[k + 1, lj[q]], self.lon[k + 1, lj[q]], t0[q] + dur[q])
        if plat is not None and good.any():
            q = np.nonzero(good)[0]
            pt = t0[q, None] + fr[None, :] * dur[q, None]
            good[q] = nav_check(self.navigable, plat[l0[q], lj[q]], plon[l0[q], lj[q]], pt).all(axis=1)
        return good


def in_every_member(n_legs: int, costs: list[Callable[[np.ndarray], tuple]], extras: tuple[str, ...]) -> tuple:
    """Legs costed in several members (an ensemble's): feasible only where feasible in every member.

    ``costs[m](idx) -> (fuel [t], feasible, {name: value})`` costs legs ``idx`` in member m; each member costs only
    the legs every member before it allowed (a leg one member forbids is not costed in the rest). Returns the
    members' mean fuel, the feasibility and the members' mean of each of ``extras`` (NaN where infeasible).
    """
    feas = np.ones(n_legs, dtype=bool)
    fuel = np.zeros(n_legs)
    sums = {name: np.zeros(n_legs) for name in extras}
    for cost in costs:
        idx = np.flatnonzero(feas)
        if idx.size == 0:
            break
        f, ok, extra = cost(idx)
        feas[idx] = ok
        fuel[idx] += np.where(ok, f, 0.0)
        for name in extras:
            sums[name][idx] += np.where(ok, extra[name], 0.0)
    n = len(costs)
    return np.where(feas, fuel / n, np.nan), feas, {name: np.where(feas, v / n, np.nan) for name, v in sums.items()}


def nav_check(fn: NoGoFn, lat: np.ndarray, lon: np.ndarray, t: np.ndarray) -> np.ndarray:
    lat, lon, t = np.broadcast_arrays(lat, lon, t)
    out = np.asarray(fn(lat, lon, t))
    if out.shape != lat.shape or out.dtype != bool:
        raise ConfigError(
            f"navigable(lat, lon, t_h) returned {out.dtype} of shape {out.shape}; "
            f"return a bool array of shape {lat.shape}"
        )
    return out


def _leg_samples(
    la: np.ndarray, lo_a: np.ndarray, lb: np.ndarray, lo_b: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """Points at fractions (1..n)/(n+1) of the WGS84 geodesic between every pair of states, (La, Lb, n)."""
    f = ((np.arange(n) + 1.0) / (n + 1.0))[None, None, :]
    lat, lon, _ = geo.points_along(la[:, None, None], lo_a[:, None, None], lb[None, :, None], lo_b[None, :, None], f)
    return lat, lon


class CompiledStages:
    """The binned labels of a stage from the compiled transitions (:mod:`optroute.search.dp_kernels`).

    The same winners as the loop over every transition: per (destination lateral, bin), the
    transition of least (value, time, order) that is feasible and clear of the no-go areas; the value is
    the fuel, or with ``by_time`` the arrival (the labels' "fuel" then holds their times, the floor is 1 h/h).
    """

    def __init__(
        self, kernel: DPLegKernel | JointLegKernel, inputs: tuple, step_fn: Transition, bins: tuple, labels: int | None,
        by_time: bool = False,
    ) -> None:  # fmt: skip
        self.kernel, self.step_fn, self.labels = kernel, step_fn, labels
        self.t_ref, self.dt, self.n_bins = bins
        self.speeds = np.ascontiguousarray(step_fn.speeds, dtype=float)
        self.by_time = np.bool_(by_time)
        self.floor = np.ones(self.speeds.size) if by_time else kernel.floor_tph(self.speeds)
        self.inputs = inputs  # the members' (one for a single weather): dp_kernels.stacked_inputs
        self._geom_k: int = -1
        self._geom: tuple = ()

    def _geometry(self, k: int):
        """The pieces of every leg from stage k to k+1 (its ends: the centre only), computed once per stage."""
        if self._geom_k != k:
            lat, lon = self.step_fn.lat, self.step_fn.lon
            n_stages, n_lat = lat.shape[0] - 1, lat.shape[1]
            src = np.array([n_lat // 2]) if k == 0 else np.arange(n_lat)
            dst = np.array([n_lat // 2]) if k + 1 == n_stages else np.arange(n_lat)
            a, b = np.meshgrid(src, dst, indexing="ij")
            a, b = a.ravel(), b.ravel()
            geom = self.kernel.geometry(lat[k, a], lon[k, a], lat[k + 1, b], lon[k + 1, b])
            geom_of = np.full((n_lat, n_lat), -1, dtype=np.int64)
            geom_of[a, b] = np.arange(a.size)
            self._geom, self._geom_k = (geom, geom_of), k
        return self._geom

    def cost_legs(
        self, k: int, l0: np.ndarray, lj: np.ndarray, vi: np.ndarray, t0: np.ndarray, check: bool = True
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(duration [h], fuel [t], feasible) of legs from stage k, as the callback costs them: in every member,
        each member costing only the legs the members before it allow; the fuel the members' mean.  Without
        ``check``, feasible at the pieces' midpoints only (:meth:`clear_legs` checks the rest)."""

        def run(args: tuple) -> tuple:
            _, f, ok, _, _, unc = cost_dp_legs(*args, bool(check))
            return f, ok, unc

        dist, fuel, feas = self._in_members(k, l0, lj, vi, t0, run)
        return dist / self.speeds[vi], fuel, feas  # cost_dp_legs's duration

    def clear_legs(self, k: int, l0: np.ndarray, lj: np.ndarray, vi: np.ndarray, t0: np.ndarray) -> np.ndarray:
        """Whether legs from stage k that :meth:`cost_legs` without ``check`` found feasible are clear between their
        pieces' midpoints in every member (:func:`~optroute.search.passage_kernels.clear_dp_legs`)."""

        def run(args: tuple) -> tuple:
            ok, unc = clear_dp_legs(*args)
            return np.zeros(ok.size), ok, unc  # (no fuel: only whether the legs are clear)

        return self._in_members(k, l0, lj, vi, t0, run)[2]

    def _in_members(
        self, k: int, l0: np.ndarray, lj: np.ndarray, vi: np.ndarray, t0: np.ndarray, run: Callable[[tuple], tuple]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A DP leg kernel ``run`` on the legs from stage k in every member (:func:`in_every_member`).

        ``run(args)`` takes the kernel arguments of one member and a batch of legs (its parameters and weather, the
        legs' pieces, departures [h] and SOG [kn], as :func:`~optroute.search.passage_kernels.clear_dp_legs` takes
        them) and returns ``(fuel [t], feasible, uncovered points)``. Returns the legs' lengths [nm], the members'
        mean fuel [t] and whether feasible in every member.
        """
        geom, geom_of = self._geometry(k)
        g, t0, sog = np.ascontiguousarray(geom_of[l0, lj]), np.ascontiguousarray(t0, dtype=float), self.speeds[vi]

        def member(m: DPLegKernel) -> Callable[[np.ndarray], tuple]:
            def call(idx: np.ndarray) -> tuple:
                f, ok, unc = run((
                    np.ascontiguousarray(m.params, dtype=float), tuple(m.weather), geom.lat_deg, geom.lon_deg,
                    geom.course_deg, geom.frac, geom.n_pieces, np.ascontiguousarray(g[idx]), t0[idx],
                    np.ascontiguousarray(sog[idx]), geom.dist_nm,
                ))  # fmt: skip
                self.kernel.uncovered(int(unc))
                return f, ok, {}

            return call

        fuel, feas, _ = in_every_member(l0.size, [member(m) for m in self.kernel.members], ())
        return geom.dist_nm[g], fuel, feas

    def stage(self, k: int, src: tuple, dest: np.ndarray, step: int | None, max_batch: int, rem_next: np.ndarray,
              cut: tuple[np.ndarray, float] | None = None):  # fmt: skip
        """Yield, per batch of destination laterals, the winners: (lateral, bin, fuel, time, source, speed index).

        ``cut``: (lower bound on the fuel from each lateral of stage k + 1 to the end [t], the fuel [t]
        above which no route is wanted); the transitions whose fuel floor plus that bound exceeds it
        are not listed (:func:`~optroute.search.dp_kernels.enumerate_candidates`).
        """
        tail_next, fuel_cut = (np.zeros(self.step_fn.lat.shape[1]), np.inf) if cut is None else cut
        src_l, src_t, src_f = (np.ascontiguousarray(a) for a in src)
        src_l = src_l.astype(np.int64)
        geom, geom_of = self._geometry(k)
        per_dest = max(src_l.size * self.speeds.size, 1)
        chunk = max(1, max_batch // per_dest)
        for a in range(0, dest.size, chunk):
            cand = enumerate_candidates(
                src_l, src_t, src_f, np.ascontiguousarray(dest[a : a + chunk], dtype=np.int64), self.speeds,
                self.floor, geom_of, geom.dist_nm, -1 if step is None else int(step),
                np.ascontiguousarray(rem_next, dtype=float), self.step_fn.vmax, self.step_fn.horizon, self.t_ref,
                self.dt, self.n_bins, np.ascontiguousarray(tail_next, dtype=float), float(fuel_cut),
            )  # fmt: skip
            won = self._winners(k, src_l, src_t, src_f, geom, geom_of, *cand)
            if won is not None:
                yield won

    def _winners(self, k, src_l, src_t, src_f, geom, geom_of, c_src, c_lj, c_vi, t1, key, lb):
        if key.size == 0:
            return None
        order = np.lexsort((lb, key))  # stable: ties keep the order (source, destination, speed)
        ks = key[order]
        starts = np.flatnonzero(np.r_[True, ks[1:] != ks[:-1]])
        group_start = np.r_[starts, ks.size].astype(np.int64)
        n_groups = starts.size
        ptr = group_start[:-1].copy()
        costed = np.zeros(key.size, dtype=bool)
        cleared = np.zeros(key.size, dtype=bool)
        fuel1 = np.full(key.size, np.nan)
        rejected = np.zeros(key.size, dtype=bool)
        won, slots = [], []
        todo = np.arange(n_groups, dtype=np.int64)
        for slot in itertools.count() if self.labels is None else range(self.labels):
            winner = self._round(k, todo, src_l, src_t, src_f, geom, geom_of, order, group_start, ptr,
                                 (costed, cleared, fuel1, rejected), c_src, c_lj, c_vi, t1, lb)  # fmt: skip
            has = winner >= 0
            todo, w = todo[has], winner[has]
            if w.size == 0:
                break
            won.append(w)
            slots.append(np.full(w.size, slot, dtype=np.int64))
            # the next label of the bin's Pareto set must be strictly earlier than this (cheapest) one
            grp_of = np.repeat(np.arange(n_groups), np.diff(group_start))
            t_cut = np.full(n_groups, np.inf)
            t_cut[todo] = t1[w]
            rejected[order] |= t1[order] >= t_cut[grp_of]
        if not won:
            return None
        w, slot = np.concatenate(won), np.concatenate(slots)
        return c_lj[w], key[w] - c_lj[w] * self.n_bins, slot, fuel1[w], t1[w], c_src[w], c_vi[w]

    def _round(self, k, todo, src_l, src_t, src_f, geom, geom_of, order, group_start, ptr, labels, c_src, c_lj, c_vi,
               t1, lb):  # fmt: skip
        """Per group in ``todo``, its least (fuel, time, order) candidate not struck out and clear of the no-go areas (-1: none)."""
        costed, cleared, fuel1, rejected = labels  # resolve's per-candidate state (see its docstring)
        winner = np.full(todo.size, -1, dtype=np.int64)
        pos = np.arange(todo.size)
        while todo.size:
            best, n_costed, unc = resolve(
                *self.inputs, geom.lat_deg, geom.lon_deg, geom.course_deg, geom.frac, geom.n_pieces, geom.dist_nm,
                geom_of, self.speeds, order, group_start, todo, ptr, costed, cleared, fuel1, rejected,
                c_src, c_lj, c_vi, t1, lb, src_l, src_t, src_f, self.by_time,
            )  # fmt: skip
            self.step_fn.count += int(n_costed)
            self.kernel.uncovered(int(unc))
            has = best >= 0
            todo, best, pos = todo[has], best[has], pos[has]
            if best.size == 0:
                break
            s = c_src[best]
            dur = geom.dist_nm[geom_of[src_l[s], c_lj[best]]] / self.speeds[c_vi[best]]  # the leg kernel's
            clear = self.step_fn.clear(k, src_l[s], c_lj[best], src_t[s], dur)
            winner[pos[clear]] = best[clear]
            rejected[best[~clear]] = True
            todo, pos = todo[~clear], pos[~clear]
        return winner
