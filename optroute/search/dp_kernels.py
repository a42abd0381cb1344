"""Compiled stage-to-stage transitions of the 3-D DP (Shao et al.), best first under a fuel floor.

:func:`optroute.search.dp.solve_dp` keeps, per (stage, lateral, arrival-time
bin), the bin's Pareto set on (fuel, arrival time), cheapest first; each
label of it is the least (fuel, time) one among the candidates left once those
no earlier than the previous label are struck out; the transitions into one bin
come from every source state and speed whose leg ends in it.  With the
compiled leg costing (:func:`optroute.search.passage_kernels.cost_dp_leg`,
the physics functions the referee uses) the DP costed *every* such
transition, and spent as long again finding each leg's piece geometry
(``numpy.unique`` over millions of rows).  Here, per stage:

1. :func:`enumerate_candidates` lists the transitions (source state,
   destination lateral, speed) whose arrival time — the leg's length over the
   commanded speed over ground, known before any physics — falls inside the
   horizon and a bin, with a lower bound on the fuel label they would reach:
   the source's fuel plus the leg's duration times :func:`fuel_floor_tph`;
2. :func:`resolve` takes each destination bin's candidates in order of that
   bound and costs them (:func:`~optroute.search.passage_kernels.cost_dp_leg`,
   each leg's pieces computed once per stage) only while the bound does not
   exceed the best label found, so every candidate left uncosted would have
   lost; ties of (fuel, time) go to the first candidate in the order
   (source state, destination, speed), as the DP's stable sort does;
3. the caller checks the winner against the no-go areas (a Python callable)
   and, where it fails, :func:`resolve` resumes with it struck out; for the
   bin's next Pareto label the caller strikes out every candidate no earlier
   than the winner and resumes (struck-out candidates are never costed).

The winner of each bin is therefore the candidate of least (fuel, time,
order) that is feasible and clear of the no-go areas, as with every
transition costed.  The bound: a feasible piece's fuel rate is at least
``fuel_rate(max(P_calm(v), P_min))`` at its speed through water ``v``
(Kwon's loss is floored at 0, an allowed power is at least the minimum load,
the IMO GHG4 fuel rate increases with the power), and ``v >= SOG - |current|``
(the velocity triangle); see :func:`optroute.physics.pointwise.cost_rate_floor`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from optroute import units
from optroute._numba import jit
from optroute.physics.pointwise import P_MIN_POWER, calm_power, fuel_rate
from optroute.search.passage_kernels import dp_leg_clear, dp_leg_midpoints, dp_workspace

_FLOOR_SLACK = 1.0 - 1e-9  # rounding room: the bound stays below the kernel's sum over pieces
_CURRENT_SLACK = 1.0 + 1e-9
BIN_TOL_H = 1e-9
"""An arrival this close after a bin's end [h] is in that bin (the rounding of a sum of leg durations)."""


@dataclass(frozen=True, eq=False)
class LegGeometry:
    """The pieces of a set of DP legs (``PassagePhysics.dp_leg``'s): length [nm], midpoints [deg], course [deg true]."""

    dist_nm: np.ndarray
    n_pieces: np.ndarray
    frac: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    course_deg: np.ndarray


@dataclass(frozen=True, eq=False)
class DPLegKernel:
    """What :func:`optroute.search.dp.solve_dp` needs to cost its transitions in compiled code.

    Attached as ``leg_cost.dp_kernel`` by :meth:`optroute.search.routing.PassagePhysics.dp_leg`
    when the compiled kernels apply; the callback itself stays the reference (and costs the path).

    Attributes
    ----------
    params : ndarray
        :func:`optroute.physics.pointwise.point_params`.
    weather : tuple
        :class:`optroute.weather.sample.PointWeather` fields and their node bounds
        (:func:`optroute.search.band_bounds.weather_with_bounds`).
    pieces : callable
        ``pieces(lat0, lon0, lat1, lon1) -> (dist_nm, n_pieces (n, 1), frac, lat, lon, course)``,
        the callback's own leg geometry.
    uncovered : callable
        ``uncovered(n)``: records ``n`` points sampled outside the weather (and one call).
    """

    params: np.ndarray
    weather: tuple
    pieces: Callable
    uncovered: Callable[[int], None]

    def geometry(self, lat0: np.ndarray, lon0: np.ndarray, lat1: np.ndarray, lon1: np.ndarray) -> LegGeometry:
        """The pieces of the legs (lat0, lon0) → (lat1, lon1) [deg], as contiguous arrays."""
        dist, n_pc, f, lat, lon, course = self.pieces(lat0, lon0, lat1, lon1)
        c = np.ascontiguousarray
        return LegGeometry(
            c(dist, dtype=float),
            c(n_pc[:, 0], dtype=np.int64),
            c(f, dtype=float),
            c(lat, dtype=float),
            c(lon, dtype=float),
            c(course, dtype=float),
        )

    def current_kn(self) -> float:
        """The strongest current of the weather [kn] (interpolation never exceeds its grid's largest)."""
        fields = self.weather[0]
        speed = np.hypot(fields[:, 6], fields[:, 7])  # node-major (PointWeather.fields)
        return float(np.nanmax(speed)) / units.MS_PER_KN if np.isfinite(speed).any() else 0.0

    def floor_tph(self, speeds_kn: np.ndarray) -> np.ndarray:
        """A lower bound on the fuel rate [t/h] of any feasible leg at each commanded SOG [kn]."""
        return fuel_floor_tph(self.params, np.ascontiguousarray(speeds_kn, dtype=float), self.current_kn())

    @property
    def members(self) -> tuple[DPLegKernel, ...]:
        """The weathers a leg is costed in: this one."""
        return (self,)


@dataclass(frozen=True, eq=False)
class JointLegKernel:
    """The compiled form of a leg cost over several members (an ensemble's): feasible only where feasible in every
    member, the fuel the members' mean (:func:`optroute.optimise.robust_start.ensemble_dp_path`'s joint leg cost).

    The members' own :class:`DPLegKernel` (one ship, one weather grid: :func:`stacked_inputs`); the pieces and
    the uncovered points are the first member's (the pieces depend on the leg only).
    """

    members: tuple[DPLegKernel, ...]

    def geometry(self, lat0: np.ndarray, lon0: np.ndarray, lat1: np.ndarray, lon1: np.ndarray) -> LegGeometry:
        """The pieces of the legs [deg], as every member's (:meth:`DPLegKernel.geometry`)."""
        return self.members[0].geometry(lat0, lon0, lat1, lon1)

    def floor_tph(self, speeds_kn: np.ndarray) -> np.ndarray:
        """The members' mean of their fuel-rate floors [t/h]: a floor of the mean fuel rate of a leg feasible in all."""
        return np.mean([m.floor_tph(speeds_kn) for m in self.members], axis=0)

    def uncovered(self, n: int) -> None:
        """Record ``n`` points sampled outside the weather (on the first member)."""
        self.members[0].uncovered(n)


def stacked_inputs(members: tuple[DPLegKernel, ...]) -> tuple | None:
    """The members' parameters and weathers as :func:`resolve` takes them, or None where they differ beyond the fields.

    ``(params (M, P), fields (M, n_nodes, 9), node tables (M, n_nodes, 3), (time_s, lat_deg, lon_deg, meta,
    offset_ns))``: the members must share the ship's parameters' length and the weather's axes, area and departure
    (an ensemble's members on one grid do).
    """
    first = members[0].weather
    axes = first[1:6]
    for m in members[1:]:
        w = m.weather
        same = all(np.array_equal(a, b) for a, b in zip(w[1:5], axes[:4], strict=True)) and w[5] == axes[4]
        if not same or w[0].shape != first[0].shape or w[6].shape != first[6].shape:
            return None
        if m.params.shape != members[0].params.shape:
            return None
    return (
        _along_members([m.params for m in members], read_only=True),
        _along_members([m.weather[0] for m in members]),
        _along_members([m.weather[6] for m in members]),
        tuple(axes),
    )


def _along_members(arrays: list[np.ndarray], *, read_only: bool = False) -> np.ndarray:
    """The members' arrays along a new first axis, C-contiguous float64, writable unless ``read_only``.

    The flags are part of a numba signature, so they follow the other callers of the same kernels: the weather's
    fields and node tables writable (as :class:`~optroute.weather.sample.PointWeather` holds them), the ship's
    parameters read only (as :func:`~optroute.physics.pointwise.cached_point_params` hands them to every search
    kernel); otherwise each one-point function the DP shares with the searches is compiled twice. One member (a
    single weather): a view of its array where that is already such an array, not a copy of the whole weather field
    on every search (the kernels only read it). Several members are stacked (copied).
    """
    if len(arrays) == 1 and (read_only or arrays[0].flags.writeable):
        out = np.ascontiguousarray(arrays[0][None], dtype=float)  # a view when the member's is C-contiguous float64
    else:
        out = np.ascontiguousarray(np.stack(arrays), dtype=float)
    if read_only:
        out.setflags(write=False)
    return out


@jit
def fuel_floor_tph(p, sog_kn, current_kn):  # pragma: no cover - compiled
    """``fuel_rate(max(P_calm(max(SOG - |c|, 0)), P_min))`` per commanded SOG, lowered by a rounding slack [t/h]."""
    out = np.empty(sog_kn.size)
    for i in range(sog_kn.size):
        v = max(sog_kn[i] - current_kn * _CURRENT_SLACK, 0.0)
        out[i] = fuel_rate(p, max(calm_power(p, v), p[P_MIN_POWER])) * _FLOOR_SLACK
    return _nonnegative(out)


@jit
def _nonnegative(a):  # pragma: no cover - compiled
    """``a`` with negative and NaN entries set to 0 (a floor must never be above the truth)."""
    for i in range(a.size):
        if not a[i] > 0.0:
            a[i] = 0.0
    return a


@jit
def enumerate_candidates(
    src_l, src_t, src_f, dest, speeds, floor_tph, geom_of, dist, step, rem_next, vmax, horizon, t_ref, dt, n_bins,
    tail_next, cut,
):  # fmt: skip  # pragma: no cover - compiled
    """The transitions of one stage that end inside the horizon and a bin, in the order (source, destination, speed).

    Without a ``cut`` (``inf``) every such transition; with one, only those whose fuel floor plus
    ``tail_next`` (a lower bound on the fuel from the destination to the end) is at most ``cut``.

    Parameters
    ----------
    src_l, src_t, src_f : ndarray, shape (n_src,)
        Source states: lateral index, exact time [h], fuel [t].
    dest : ndarray of int
        Destination laterals.
    speeds, floor_tph : ndarray, shape (n_speeds,)
        Commanded SOG [kn] and the fuel-rate floor there [t/h].
    geom_of : ndarray of int, shape (n_lat, n_lat)
        Geometry index of the leg (source lateral, destination lateral).
    dist : ndarray
        Leg lengths [nm] by geometry.
    step : int
        Largest lateral change (< 0: any).
    rem_next : ndarray
        Distance from each destination lateral to the end [nm].
    vmax, horizon, t_ref, dt : float
        Top speed [kn], horizon [h], bin origin [h] and width [h]: bin ``b`` holds the arrivals in
        ``(t_ref + b dt, t_ref + (b + 1) dt]``.
    n_bins : int
    tail_next : ndarray
        Lower bound on the fuel from each destination lateral to the end [t].
    cut : float
        Fuel no route of interest exceeds [t] (``inf``: none).

    Returns
    -------
    src, lj, vi : ndarray of int
        Source index, destination lateral, speed index of each candidate.
    t1 : ndarray
        Arrival [h] (source time + length / SOG, as the leg kernel's duration).
    key : ndarray of int
        ``lj * n_bins + bin``.
    lb : ndarray
        Lower bound of the fuel label reached [t].
    """
    cap = src_l.size * dest.size * speeds.size
    o_src = np.empty(cap, dtype=np.int64)
    o_lj = np.empty(cap, dtype=np.int64)
    o_vi = np.empty(cap, dtype=np.int64)
    o_t1 = np.empty(cap)
    o_key = np.empty(cap, dtype=np.int64)
    o_lb = np.empty(cap)
    n = 0
    for s in range(src_l.size):
        l0 = src_l[s]
        for a in range(dest.size):
            lj = dest[a]
            if step >= 0 and abs(lj - l0) > step:
                continue
            g = geom_of[l0, lj]
            tail = rem_next[lj] / vmax
            for v in range(speeds.size):
                dur = dist[g] / speeds[v]
                t1 = src_t[s] + dur
                if not t1 + tail <= horizon + 1e-9:
                    continue
                b = math.ceil((t1 - t_ref) / dt - BIN_TOL_H / dt) - 1  # bins (start, end]: up to the end
                if b < 0 or b >= n_bins:
                    continue
                lb = src_f[s] + floor_tph[v] * dur
                if lb + tail_next[lj] > cut:  # every route through it ends above the cut
                    continue
                o_src[n], o_lj[n], o_vi[n], o_t1[n] = s, lj, v, t1
                o_key[n] = lj * n_bins + b
                o_lb[n] = lb
                n += 1
    return o_src[:n], o_lj[:n], o_vi[:n], o_t1[:n], o_key[:n], o_lb[:n]


@jit
def _beats(f, t, i, bf, bt, bi):  # pragma: no cover - compiled
    """(f, t, i) before (bf, bt, bi) lexicographically."""
    return f < bf or (f == bf and (t < bt or (t == bt and i < bi)))


@jit
def joint_dp_leg(
    ps, fields, tables, axes, geo_lat, geo_lon, geo_course, geo_frac, geo_n, g, t0_h, sog_kn, dist, work
):  # fmt: skip  # pragma: no cover - compiled
    """One DP leg at its pieces' midpoints (:func:`~optroute.search.passage_kernels.dp_leg_midpoints`) in every
    member of :func:`stacked_inputs`.

    Returns ``(allowed at the midpoints in every member, the members' mean fuel rate [t/h], uncovered points)``;
    the members after the first in which the leg is not allowed are not costed.
    """
    time_s, lat_deg, lon_deg, meta, offset_ns = axes
    total = 0.0
    uncovered = 0
    for m in range(ps.shape[0]):
        w = (fields[m], time_s, lat_deg, lon_deg, meta, offset_ns, tables[m])
        ok, f_sum, _, _, unc = dp_leg_midpoints(
            ps[m], w, geo_lat, geo_lon, geo_course, geo_frac, geo_n, g, t0_h, sog_kn, dist, work
        )
        uncovered += unc
        if not ok:
            return False, np.nan, uncovered
        total += f_sum
    return True, total / ps.shape[0], uncovered


@jit
def joint_dp_clear(
    ps, fields, tables, axes, geo_lat, geo_lon, geo_course, geo_frac, geo_n, g, t0_h, sog_kn, dist, work
):  # fmt: skip  # pragma: no cover - compiled
    """Whether a leg allowed at its midpoints in every member (:func:`joint_dp_leg`) is clear between them in every
    member (:func:`~optroute.search.passage_kernels.dp_leg_clear`); ``(clear, uncovered points)``."""
    time_s, lat_deg, lon_deg, meta, offset_ns = axes
    uncovered = 0
    for m in range(ps.shape[0]):
        w = (fields[m], time_s, lat_deg, lon_deg, meta, offset_ns, tables[m])
        clear, unc = dp_leg_clear(ps[m], w, geo_lat, geo_lon, geo_course, geo_frac, geo_n, g, t0_h, sog_kn, dist, work)
        uncovered += unc
        if not clear:
            return False, uncovered
    return True, uncovered


@jit
def resolve(
    ps, fields, tables, axes, geo_lat, geo_lon, geo_course, geo_frac, geo_n, dist, geom_of, speeds,
    order, group_start, unresolved, ptr, costed, cleared, fuel1, rejected,
    src, lj, vi, t1, lb, src_l, src_t, src_f, by_time,
):  # fmt: skip  # pragma: no cover - compiled
    """Per unresolved group (one destination bin), its best (value, time, order) candidate not yet struck out.

    The legs are costed in every member of ``ps, fields, tables, axes`` (:func:`stacked_inputs`, one member for a
    single weather) at their pieces' midpoints by :func:`joint_dp_leg`. Costs each group's candidates in order of
    their bound ``lb`` only while the bound does not exceed the best label found (``ptr`` holds each group's
    progress, ``costed`` / ``fuel1`` the labels: NaN where infeasible).  A label's value is its fuel [t], or with
    ``by_time`` its arrival [h] (``src_f`` then holds the sources' times and ``lb`` the arrivals: each bin's
    earliest labels).

    The rest of a leg's check (:func:`joint_dp_clear`: its pieces' ends and between) does not change its value,
    only whether it is feasible, so it is run only on a label about to become its group's best (``cleared``
    records it): a label that never leads its group cannot be the group's best clear label, and its check is
    spared.  The best labels are those of a DP that checks every leg in full.
    Returns ``(best candidate per group or -1, legs costed, uncovered points)``.
    """
    work = dp_workspace()
    best_out = np.full(unresolved.size, -1, dtype=np.int64)
    n_costed = 0
    uncovered = 0
    for u in range(unresolved.size):
        grp = unresolved[u]
        lo, hi = group_start[grp], group_start[grp + 1]
        bf, bt, bi = np.inf, np.inf, np.int64(-1)
        for r in range(lo, hi):
            if r >= ptr[grp]:  # the labels already found first, then the next candidates by their bound
                c = order[r]
                if lb[c] > bf:
                    break
                ptr[grp] = r + 1
                if rejected[c]:  # struck out before costing (a later label of a bin's Pareto set): never costed
                    continue
                s = src[c]
                g = geom_of[src_l[s], lj[c]]
                sog = speeds[vi[c]]
                ok, f_sum, unc = joint_dp_leg(
                    ps, fields, tables, axes, geo_lat, geo_lon, geo_course, geo_frac, geo_n, g, src_t[s], sog, dist,
                    work,
                )  # fmt: skip
                uncovered += unc
                n_costed += 1
                costed[c] = True
                fuel1[c] = src_f[s] + (1.0 if by_time else f_sum) * (dist[g] / sog) if ok else np.nan
            c = order[r]
            if not (costed[c] and not rejected[c] and math.isfinite(fuel1[c])):
                continue
            if not _beats(fuel1[c], t1[c], c, bf, bt, bi):
                continue
            if not cleared[c]:
                s = src[c]
                g = geom_of[src_l[s], lj[c]]
                clear, unc = joint_dp_clear(
                    ps, fields, tables, axes, geo_lat, geo_lon, geo_course, geo_frac, geo_n, g, src_t[s], speeds[vi[c]],
                    dist, work,
                )  # fmt: skip
                uncovered += unc
                if not clear:
                    fuel1[c] = np.nan
                    continue
                cleared[c] = True
            bf, bt, bi = fuel1[c], t1[c], c
        best_out[u] = bi
    return best_out, n_costed, uncovered
