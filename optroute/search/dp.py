"""The 3-D dynamic programme of Shao et al.: stage × lateral position × arrival time.

Ship routing as a multi-stage decision process (Shao et al.'s 3-D DP, after their
3-D DP): stages every ΔX along the great circle from start to end, lateral
states every ΔY on the great circle perpendicular to it at each stage (within
± a half-width), and the control between two stages is the speed over ground,
chosen from a discrete set (5–30 kn in the paper); the heading is fixed by the
two grid points.  The forward recursion runs over stage × lateral position ×
arrival time, so it gives, in one pass, the least fuel to reach the end in
*every* arrival-time bin — the fuel-versus-ETA curve — and the fuel-minimal
route and speed profile for a required ETA.

Time discretisation (documented choice)
---------------------------------------
Arrival times are grouped in bins of ``dt_h`` (1 h as in the paper).  Each
(stage, lateral, bin) state keeps up to ``labels_per_bin`` labels (default
one: :data:`DEFAULT_LABELS_PER_BIN`), each with the *exact* arrival time of its
path and a back pointer: the bin's Pareto set on (fuel, time) — the least-fuel
label (ties: the earlier one), then the least-fuel label strictly earlier than
it, and so on.  A label is dropped only when another in its bin is no costlier
*and* no later, or when the set is full (the earliest, costliest labels go
first); times are never rounded, so the reported times and ETAs are exact for
the path returned.  One label per bin lets a cheaper but later label win a bin
and lose the path that, continued, arrives by the ETA: on Shao et al.'s case
II at 240 h the DP burnt 1 140.68 t against 1 140.11 t for its own 23 kn
constant-speed candidate (16 labels: 1 140.11 t).  With the whole set
(``labels_per_bin=None``) and costs that do not depend on when a leg is
sailed, the DP equals enumeration of its lattice at every bin end, whatever
the bin width; in time-varying weather and no-go areas dominance on (fuel,
time) is the usual label-setting assumption (waiting is not allowed, so an
earlier label cannot always imitate a later one).

The bins are aligned so that the required ETA is a bin edge, and they are
closed at their end: a bin holds the arrivals after its start up to *and at*
its end (``(end - dt_h, end]``), i.e. an arrival time is rounded up to the end
of its bin (within :data:`~optroute.search.dp_kernels.BIN_TOL_H`).  So every
label in a bin that ends at or before the ETA arrives in time, and a label
arriving exactly at the ETA (a constant speed of distance / ETA) is in the
ETA's bin, not the next one.

Waiting is not allowed: "arrive by the ETA" means arriving at or before it,
with the fuel burnt on the way (no loitering at sea or at the port).

Leg cost callback (vectorised over flat arrays of one length)::

    leg_cost(lat0_deg, lon0_deg, lat1_deg, lon1_deg, t0_h, sog_kn)
        -> (duration_h, fuel_t, feasible[, extra])

the cost of the great-circle leg (lat0, lon0) → (lat1, lon1) left at ``t0_h``
[h from departure] with the commanded speed over ground ``sog_kn`` [kn].  The
physics layer runs the MCR loop and the danger bands inside it and may only
*lower* the speed (``duration_h >= distance / sog_kn``, checked); where no
safe speed exists it returns ``feasible = False``.

A callback carrying a compiled form (``leg_cost.dp_kernel``, a
:class:`~optroute.search.dp_kernels.DPLegKernel`: ``PassagePhysics.dp_leg``)
has the binned transitions costed by :mod:`optroute.search.dp_kernels`, best
first under a fuel floor: the same labels, with the legs that cannot win left
uncosted.

No-go areas (islands, moving storms) are a callable ``navigable(lat_deg,
lon_deg, t_h) -> bool array``, checked at the state reached and at points
along each leg every ``nogo_step_nm`` at the time the ship passes them
(constant speed along the leg).

Sources: Shao et al. (3-D DP vs the IMO MEPC method; ΔX = 360 nm, ΔY = 75 nm,
Δt = 1 h, speeds 5–30 kn); Bellman (1957).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from optroute import geodesy as geo
from optroute._checks import finite
from optroute.errors import ConfigError, InfeasibleETA, NoSafePassage
from optroute.search.costs import unpack_cost
from optroute.search.dp_kernels import BIN_TOL_H, DPLegKernel, enumerate_candidates, resolve
from optroute.search.passage_kernels import cost_dp_legs

LegCostFn = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], Any]
NoGoFn = Callable[[np.ndarray, np.ndarray, np.ndarray], ArrayLike]

_SPEED_TOL = 1e-9
DEFAULT_LABELS_PER_BIN = 1
"""Labels kept per (stage, lateral, arrival-time bin) by default: the cheapest only.

The bin's whole Pareto set (``labels_per_bin=None``) makes the DP exact against every path of its
lattice when the legs' costs do not depend on the time, but it grows with the stages: on Shao et
al.'s case II (15 legs, 75 nm, three speeds) it had not finished after 90 CPU-s where one label took
1 CPU-s and 16 labels 3.7 CPU-s.  A capped set keeps the cheapest labels of it and is a heuristic:
it is not even monotone in the cap (a cheaper, later label can push out of the set the label a
smaller cap kept: 4 labels ended 0.01 t above 1 label at 336 h on case II's full lattice)."""


@dataclass(frozen=True, eq=False)
class DPPath:
    """One route of the DP and its speed profile.

    Attributes
    ----------
    lat_deg, lon_deg : ndarray, shape (K+1,)
        State positions, one per stage [deg].
    lateral_index : ndarray of int, shape (K+1,)
        Lateral state per stage (0 .. 2·n_half; n_half is the centreline).
    lateral_nm : ndarray, shape (K+1,)
        Offset from the great circle [nm], positive to starboard (right of it,
        looking from start to end).
    times_h : ndarray, shape (K+1,)
        Time at each state [h from departure].
    sog_kn : ndarray, shape (K,)
        Commanded speed over ground of each leg [kn] (from the speed set).
    leg_duration_h, leg_fuel_t, leg_distance_nm : ndarray, shape (K,)
        Per leg [h], [t], [nm].
    total_fuel_t, arrival_h : float
        Totals [t] and arrival [h from departure].
    extra : dict of str to ndarray
        The callback's extras for each leg (re-evaluated along the path).
    """

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    lateral_index: np.ndarray
    lateral_nm: np.ndarray
    times_h: np.ndarray
    sog_kn: np.ndarray
    leg_duration_h: np.ndarray
    leg_fuel_t: np.ndarray
    leg_distance_nm: np.ndarray
    total_fuel_t: float
    arrival_h: float
    extra: dict[str, np.ndarray]


@dataclass(frozen=True, eq=False)
class DPResult:
    """The DP's answer: the route for the required ETA and the fuel-versus-ETA curve.

    Attributes
    ----------
    path : DPPath
        Fuel-minimal route arriving by ``eta_h`` (or, without an ETA, the
        least-fuel arrival within the horizon).
    eta_h : float or None
        The required arrival [h from departure].
    curve_bin_end_h : ndarray
        Upper edge of each arrival-time bin [h from departure]; a bin holds the
        arrivals in ``(end - dt_h, end]``.
    curve_arrival_h : ndarray
        Exact arrival of the least-fuel label in each bin [h] (NaN: unreachable).
    curve_fuel_t : ndarray
        The fuel-versus-ETA curve: least fuel of a route found that arrives by
        each bin's upper edge [t] (inf: none), non-increasing in the ETA.
    curve_fuel_in_bin_t : ndarray
        Least fuel of a route arriving *within* each bin [t]; with a discrete
        speed set this is not monotone (some arrival times are only reachable
        by costly speed mixes) — ``curve_fuel_t`` is its running minimum.
    earliest_arrival_h : float
        Earliest arrival [h], from an earliest-arrival label propagated
        alongside the binned ones (exact for FIFO legs).
    stage_lat_deg, stage_lon_deg : ndarray, shape (K+1, L)
        Positions of every state [deg] (end stages: only the centre is used).
    n_states : int
        (stage, lateral, bin) states reached.
    n_transitions : int
        Legs costed (with the compiled stages, only those that could still win their bin).
    """

    path: DPPath
    eta_h: float | None
    curve_bin_end_h: np.ndarray
    curve_arrival_h: np.ndarray
    curve_fuel_t: np.ndarray
    curve_fuel_in_bin_t: np.ndarray
    earliest_arrival_h: float
    stage_lat_deg: np.ndarray
    stage_lon_deg: np.ndarray
    n_states: int
    n_transitions: int
    _tables: _Tables = field(repr=False)

    def path_for_eta(self, eta_h: float) -> DPPath:
        """The least-fuel route among those found arriving at or before ``eta_h`` [h].

        Exact in its arrival time; for an ETA other than the one the DP was run
        with the bins are not aligned to it, so a slightly better route in the
        bin that straddles it may have been discarded.

        Raises
        ------
        InfeasibleETA
            No route found arrives by ``eta_h``.
        """
        return self._tables.path_for(float(eta_h))


@dataclass(frozen=True, eq=False)
class _Tables:
    fuel: list[np.ndarray]
    time: list[np.ndarray]
    back_l: list[np.ndarray]
    back_b: list[np.ndarray]
    speed_i: list[np.ndarray]
    lat: np.ndarray
    lon: np.ndarray
    lateral_nm: np.ndarray
    dist: list[np.ndarray]
    speeds: np.ndarray
    centre: int
    leg_cost: LegCostFn
    early_t: np.ndarray
    early_f: np.ndarray
    early_back: np.ndarray

    def earliest(self) -> float:
        return float(self.early_t[-1, self.centre])

    def path_for(self, eta_h: float | None) -> DPPath:
        k_end = len(self.fuel) - 1
        f = self.fuel[k_end][self.centre]
        t = self.time[k_end][self.centre]
        ok = np.isfinite(f) if eta_h is None else np.isfinite(f) & (t <= eta_h + 1e-9)
        early = self.earliest()
        use_early = (eta_h is None or early <= eta_h + 1e-9) and (
            not ok.any() or self.early_f[-1, self.centre] < f[ok].min()
        )
        if use_early:
            return self._early_path()
        if not ok.any():
            exc = InfeasibleETA(
                f"no route arrives by {eta_h:.2f} h after departure: the earliest arrival the DP found is "
                f"{early:.2f} h after departure; allow a later ETA or add faster speeds",
                earliest_arrival=early,
            )
            exc.earliest_arrival_h = early  # type: ignore[attr-defined]
            raise exc
        cand = np.nonzero(ok)[0]
        b = int(cand[np.lexsort((t[cand], f[cand]))[0]])
        lat_idx = [self.centre]
        bins = [b]
        spd = []
        for k in range(k_end, 0, -1):
            lk, bk = lat_idx[-1], bins[-1]
            spd.append(int(self.speed_i[k][lk, bk]))
            lat_idx.append(int(self.back_l[k][lk, bk]))
            bins.append(int(self.back_b[k][lk, bk]))
        lat_idx, bins, spd = lat_idx[::-1], bins[::-1], spd[::-1]
        times = np.array([self.time[k][lat_idx[k], bins[k]] for k in range(k_end + 1)])
        fuel = np.array([self.fuel[k][lat_idx[k], bins[k]] for k in range(k_end + 1)])
        return self._make_path(np.array(lat_idx), np.array(spd), times, fuel)

    def _early_path(self) -> DPPath:
        k_end = len(self.fuel) - 1
        lat_idx = [self.centre]
        spd = []
        for k in range(k_end, 0, -1):
            lp, vi = self.early_back[k, lat_idx[-1]]
            spd.append(int(vi))
            lat_idx.append(int(lp))
        li = np.array(lat_idx[::-1])
        ks = np.arange(k_end + 1)
        return self._make_path(li, np.array(spd[::-1]), self.early_t[ks, li], self.early_f[ks, li])

    def _make_path(self, li: np.ndarray, spd: np.ndarray, times: np.ndarray, fuel: np.ndarray) -> DPPath:
        k_end = len(self.fuel) - 1
        lat = self.lat[np.arange(k_end + 1), li]
        lon = self.lon[np.arange(k_end + 1), li]
        dist = np.array([self.dist[k][li[k], li[k + 1]] for k in range(k_end)])
        sog = self.speeds[spd]
        out = self.leg_cost(lat[:-1], lon[:-1], lat[1:], lon[1:], times[:-1], sog)
        _, _, _, extra = unpack_cost(out, k_end, "leg_cost")
        return DPPath(
            lat_deg=lat,
            lon_deg=lon,
            lateral_index=li,
            lateral_nm=self.lateral_nm[li],
            times_h=times,
            sog_kn=sog,
            leg_duration_h=np.diff(times),
            leg_fuel_t=np.diff(fuel),
            leg_distance_nm=dist,
            total_fuel_t=float(fuel[-1]),
            arrival_h=float(times[-1]),
            extra=extra,
        )


def _stage_geometry(
    start: tuple[float, float], end: tuple[float, float], dx_nm: float, dy_nm: float, n_half: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    lat_s, lon_s = start
    lat_e, lon_e = end
    dist = float(geo.distance_nm(lat_s, lon_s, lat_e, lon_e))
    n_stages = max(1, int(np.ceil(dist / dx_nm - 1e-9)))
    clat, clon = geo.intermediate_points(lat_s, lon_s, lat_e, lon_e, np.linspace(0.0, 1.0, n_stages + 1))
    course = np.empty(n_stages + 1)
    course[:-1] = geo.initial_course_deg(clat[:-1], clon[:-1], lat_e, lon_e)
    course[-1] = geo.initial_course_deg(lat_s, lon_s, lat_e, lon_e)  # unused: the end has no lateral states
    lateral = dy_nm * (np.arange(2 * n_half + 1) - n_half)
    side = np.where(lateral >= 0, 90.0, -90.0)
    lat, lon = geo.destination(clat[:, None], clon[:, None], course[:, None] + side[None, :], np.abs(lateral)[None, :])
    lat[0], lon[0] = lat_s, lon_s  # only the centre is a state at the two ends
    lat[-1], lon[-1] = lat_e, lon_e
    return lat, lon, lateral, n_stages


def solve_dp(
    start: tuple[float, float],
    end: tuple[float, float],
    leg_cost: LegCostFn,
    *,
    eta_h: float | None = None,
    dx_nm: float = 360.0,
    dy_nm: float = 75.0,
    half_width_nm: float = 600.0,
    speeds_kn: ArrayLike | None = None,
    dt_h: float = 1.0,
    navigable: NoGoFn | None = None,
    nogo_step_nm: float | None = None,
    max_lateral_step: int | None = None,
    horizon_h: float | None = None,
    max_batch: int = 400_000,
    labels_per_bin: int | None = DEFAULT_LABELS_PER_BIN,
) -> DPResult:
    """Forward 3-D DP: least fuel for every arrival time, and the route for ``eta_h``.

    Parameters
    ----------
    start, end : (float, float)
        ``(lat, lon)`` [deg].
    leg_cost : callable
        ``leg_cost(lat0, lon0, lat1, lon1, t0_h, sog_kn) -> (duration_h, fuel_t, feasible[, extra])``,
        see the module docstring.
    eta_h : float, optional
        Required arrival [h from departure]; arrive at or before it.  Without
        it the path returned is the least-fuel arrival within the horizon.
    dx_nm : float
        Stage spacing along the great circle [nm] (360 in Shao et al.); adjusted
        down so that the stages divide the distance evenly.
    dy_nm : float
        Lateral spacing [nm] (75 in Shao et al.).
    half_width_nm : float
        Lateral states span ± this [nm] (``floor(half_width / dy)`` each side).
    speeds_kn : array_like, optional
        Speed set [kn]; default 5, 6, …, 30.
    dt_h : float
        Arrival-time bin [h] (1 in Shao et al.).
    navigable : callable, optional
        ``navigable(lat_deg, lon_deg, t_h) -> bool array``: False inside no-go
        areas at that time.  Default: everywhere navigable.
    nogo_step_nm : float, optional
        Spacing of the no-go checks along each leg [nm]; default ``dy_nm``.
    max_lateral_step : int, optional
        Largest change of lateral index between stages; default: any.
    horizon_h : float, optional
        Latest arrival considered [h]; default the slowest great-circle voyage
        (distance / lowest speed), or the ETA if later.  States that cannot
        reach the end by then, even at the top speed, are dropped.
    max_batch : int
        Legs costed per callback call (memory bound).
    labels_per_bin : int or None
        Labels kept per (stage, lateral, bin): the bin's Pareto set on (fuel, arrival time), cheapest
        first, each next one strictly earlier and costlier (see the module docstring); None keeps
        the whole set, 1 only the cheapest.

    Returns
    -------
    DPResult

    Raises
    ------
    NoSafePassage
        No state of the last stage is reachable; names the stage reached and
        the reachable state closest to the end.
    InfeasibleETA
        Routes exist but none arrives by ``eta_h``; ``earliest_arrival`` and
        ``earliest_arrival_h`` hold the earliest arrival found [h].
    ConfigError
        Bad options, or a callback that breaks its contract.
    """
    if not callable(leg_cost):
        raise ConfigError(f"leg_cost must be callable, got {type(leg_cost).__name__}")
    s = tuple(float(v) for v in finite("start (lat, lon) [deg]", start, error=ConfigError))
    e = tuple(float(v) for v in finite("end (lat, lon) [deg]", end, error=ConfigError))
    dx = float(finite("dx_nm", dx_nm, minimum=0.0, strict=True, error=ConfigError))
    dy = float(finite("dy_nm", dy_nm, minimum=0.0, strict=True, error=ConfigError))
    hw = float(finite("half_width_nm", half_width_nm, minimum=0.0, error=ConfigError))
    dt = float(finite("dt_h", dt_h, minimum=0.0, strict=True, error=ConfigError))
    speeds = np.arange(5.0, 30.5, 1.0) if speeds_kn is None else np.unique(np.asarray(speeds_kn, dtype=float))
    speeds = finite("speeds_kn", speeds, minimum=0.0, strict=True, error=ConfigError)
    if speeds.ndim != 1 or speeds.size == 0:
        raise ConfigError("speeds_kn must be a non-empty 1-D set of speeds [kn]")
    if eta_h is not None:
        eta_h = float(finite("eta_h", eta_h, minimum=0.0, strict=True, error=ConfigError))
    step = None if max_lateral_step is None else int(max_lateral_step)
    n_labels = None
    if labels_per_bin is not None:
        n_labels = int(finite("labels_per_bin", labels_per_bin, minimum=1.0, error=ConfigError))
        if n_labels != labels_per_bin:
            raise ConfigError(f"labels_per_bin={labels_per_bin} must be a whole number >= 1, or None (every label)")
    if step is not None and step < 0:
        raise ConfigError(f"max_lateral_step={max_lateral_step} must be >= 0")
    nogo_step = (
        dy
        if nogo_step_nm is None
        else float(finite("nogo_step_nm", nogo_step_nm, minimum=0.0, strict=True, error=ConfigError))
    )
    if float(geo.distance_nm(*s, *e)) < 1e-6:
        raise ConfigError(f"start {s} and end {e} coincide; there is nothing to route")

    n_half = int(np.floor(hw / dy + 1e-9))
    lat, lon, lateral, n_stages = _stage_geometry(s, e, dx, dy, n_half)
    n_lat = lateral.size
    c = n_half
    rem_nm = geo.distance_nm(lat, lon, e[0], e[1])  # WGS84, as the legs
    vmax, vmin = float(speeds.max()), float(speeds.min())
    dist_total = float(geo.distance_nm(*s, *e))
    horizon = (
        dist_total / vmin
        if horizon_h is None
        else float(finite("horizon_h", horizon_h, minimum=0.0, strict=True, error=ConfigError))
    )
    if eta_h is not None:
        horizon = max(horizon, eta_h)
    # bin b holds the arrivals in (t_ref + b dt, t_ref + (b + 1) dt]: the ETA is a bin end, departure in bin 0
    t_ref = (0.0 if eta_h is None else eta_h - np.ceil(eta_h / dt - 1e-12) * dt) - dt
    n_bins = int(np.ceil((horizon - t_ref) / dt - BIN_TOL_H / dt))

    valid = np.ones((n_stages + 1, n_lat), dtype=bool)
    valid[0], valid[-1] = False, False
    valid[0, c], valid[-1, c] = True, True
    # per stage (n_lat, n_bins × width) tables, column bin × width + slot; a stage's width is its largest Pareto set
    fuel_t, time_t, back_l, back_b, speed_i = ([a] for a in _empty_stage(n_lat, n_bins)[:-1])
    widths = [1]
    # the earliest-arrival labels, one per (stage, lateral), propagated alongside (exact under FIFO)
    early_t = np.full((n_stages + 1, n_lat), np.inf)
    early_f = np.full((n_stages + 1, n_lat), np.inf)
    early_back = np.full((n_stages + 1, n_lat, 2), -1, dtype=np.int64)
    dists = [
        geo.distance_nm(lat[k][:, None], lon[k][:, None], lat[k + 1][None, :], lon[k + 1][None, :])
        for k in range(n_stages)
    ]
    b0 = int(np.ceil((0.0 - t_ref) / dt - BIN_TOL_H / dt)) - 1
    fuel_t[0][c, b0], time_t[0][c, b0] = 0.0, 0.0
    early_t[0, c], early_f[0, c] = 0.0, 0.0
    if navigable is not None and not _nav(navigable, np.array([s[0]]), np.array([s[1]]), np.array([0.0]))[0]:
        raise NoSafePassage(f"the start {s} is in a no-go area at departure; move it or change the no-go mask")
    step_fn = _Transition(lat, lon, dists, speeds, leg_cost, navigable, nogo_step, rem_nm, vmax, horizon)
    kernel = getattr(leg_cost, "dp_kernel", None)
    stages = None if kernel is None else _CompiledStages(kernel, step_fn, (t_ref, dt, n_bins), n_labels)
    step_fn.stages = stages
    for k in range(n_stages):
        src_l, src_b = np.nonzero(np.isfinite(fuel_t[k]))
        if src_l.size == 0:
            break
        dest = np.nonzero(valid[k + 1])[0]
        # earliest arrival: every reached lateral x every destination x every speed
        el = np.nonzero(np.isfinite(early_t[k]))[0]
        l0, lj, vi = _combos(el, dest, speeds.size, step)
        if l0.size:
            ok, t1, fu = step_fn(k, l0, lj, vi, early_t[k, l0])
            q = np.nonzero(ok)[0]
            f1 = early_f[k, l0[q]] + fu[q]
            q = q[np.lexsort((f1, t1[q], lj[q]))]
            first = np.ones(q.size, dtype=bool)
            first[1:] = lj[q][1:] != lj[q][:-1]
            q = q[first]
            early_t[k + 1, lj[q]] = t1[q]
            early_f[k + 1, lj[q]] = early_f[k, l0[q]] + fu[q]
            early_back[k + 1, lj[q], 0] = l0[q]
            early_back[k + 1, lj[q], 1] = vi[q]
        # the binned fuel labels
        if stages is not None:
            src = (src_l, time_t[k][src_l, src_b], fuel_t[k][src_l, src_b])
            won = list(stages.stage(k, src, dest, step, max_batch, rem_nm[k + 1]))
            dl, db, slot, f1, tt, w_src, w_v = (np.concatenate(x) for x in zip(*won, strict=True)) if won else (
                np.zeros(0, int), np.zeros(0, int), np.zeros(0, int), np.zeros(0), np.zeros(0), np.zeros(0, int),
                np.zeros(0, int))  # fmt: skip
            _append(
                (fuel_t, time_t, back_l, back_b, speed_i), widths,
                _stage_tables(n_lat, n_bins, dl, db, slot, f1, tt, src_l[w_src], src_b[w_src], w_v),
            )  # fmt: skip
            continue
        chunk = max(1, max_batch // max(dest.size * speeds.size, 1))
        parts = []
        for a in range(0, src_l.size, chunk):
            sl, sb = src_l[a : a + chunk], src_b[a : a + chunk]
            pos, lj, vi = _combos(np.arange(sl.size), dest, speeds.size, None)
            l0, b_src = sl[pos], sb[pos]
            if step is not None:
                keep = np.abs(lj - l0) <= step
                l0, b_src, lj, vi = l0[keep], b_src[keep], lj[keep], vi[keep]
            if l0.size == 0:
                continue
            t0 = time_t[k][l0, b_src]
            ok, t1, fu, dur = step_fn.cost(k, l0, lj, vi, t0)
            sel = np.nonzero(ok)[0]
            f1 = fuel_t[k][l0[sel], b_src[sel]] + fu[sel]
            tt = t1[sel]
            b1 = np.ceil((tt - t_ref) / dt - BIN_TOL_H / dt).astype(np.int64) - 1
            inside = (b1 >= 0) & (b1 < n_bins)
            sel = sel[inside]
            parts.append((f1[inside], tt[inside], b1[inside], l0[sel], lj[sel], vi[sel], b_src[sel], t0[sel], dur[sel]))
        if not parts:
            _append((fuel_t, time_t, back_l, back_b, speed_i), widths, _empty_stage(n_lat, n_bins))
            continue
        f1, tt, b1, cl0, clj, cvi, cb, ct0, cdur = (np.concatenate(x) for x in zip(*parts, strict=True))
        win, slot = _pareto_winners(
            clj * n_bins + b1,
            f1,
            tt,
            lambda q, k=k, a=cl0, b=clj, c=ct0, d=cdur: step_fn.clear(k, a[q], b[q], c[q], d[q]),
            n_labels,
        )
        _append(
            (fuel_t, time_t, back_l, back_b, speed_i), widths,
            _stage_tables(n_lat, n_bins, clj[win], b1[win], slot, f1[win], tt[win], cl0[win], cb[win], cvi[win]),
        )  # fmt: skip
    while len(fuel_t) < n_stages + 1:  # stages never reached
        _append((fuel_t, time_t, back_l, back_b, speed_i), widths, _empty_stage(n_lat, n_bins))

    final_all = fuel_t[-1][c].reshape(n_bins, widths[-1])
    best_slot = np.argmin(final_all, axis=1)
    final_f = final_all[np.arange(n_bins), best_slot]
    final_t = time_t[-1][c].reshape(n_bins, widths[-1])[np.arange(n_bins), best_slot]
    if not np.isfinite(early_t[-1, c]):
        k_reach = max(k for k in range(n_stages + 1) if np.isfinite(early_t[k]).any())
        reach_l = np.nonzero(np.isfinite(early_t[k_reach]))[0]
        q = int(reach_l[np.argmin(rem_nm[k_reach, reach_l])])
        raise NoSafePassage(
            f"the DP found no route from {s} to {e} within {horizon:.1f} h: it stopped at stage {k_reach} of "
            f"{n_stages}; the reachable state closest to the end is ({lat[k_reach, q]:.3f}, "
            f"{lon[k_reach, q]:.3f}), {float(rem_nm[k_reach, q]):.1f} nm from it; widen half_width_nm, add "
            "speeds, raise horizon_h or relax the no-go areas"
        )
    tables = _Tables(
        fuel=fuel_t,
        time=time_t,
        back_l=back_l,
        back_b=back_b,
        speed_i=speed_i,
        lat=lat,
        lon=lon,
        lateral_nm=lateral,
        dist=dists,
        speeds=speeds,
        centre=c,
        leg_cost=leg_cost,
        early_t=early_t,
        early_f=early_f,
        early_back=early_back,
    )
    path = tables.path_for(eta_h)
    bin_end = t_ref + dt * (np.arange(n_bins) + 1.0)
    by_eta = np.minimum.accumulate(final_f)
    by_eta = np.where(bin_end >= early_t[-1, c] - 1e-9, np.minimum(by_eta, early_f[-1, c]), by_eta)
    return DPResult(
        path=path,
        eta_h=eta_h,
        curve_bin_end_h=bin_end,
        curve_arrival_h=final_t,
        curve_fuel_t=by_eta,
        curve_fuel_in_bin_t=final_f.copy(),
        earliest_arrival_h=tables.earliest(),
        stage_lat_deg=lat,
        stage_lon_deg=lon,
        n_states=int(sum(np.isfinite(f).sum() for f in fuel_t)),
        n_transitions=step_fn.count,
        _tables=tables,
    )


def _stage_tables(n_lat, n_bins, lateral, bins, slot, fuel, time, back_l, back_b, speed_i) -> tuple:
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


def _empty_stage(n_lat: int, n_bins: int) -> tuple:
    """A stage's tables without a label (width 1)."""
    none_i, none_f = np.zeros(0, dtype=np.int64), np.zeros(0)
    return _stage_tables(n_lat, n_bins, none_i, none_i, none_i, none_f, none_f, none_i, none_i, none_i)


def _append(tables: tuple, widths: list[int], stage: tuple) -> None:
    for table, new in zip(tables, stage[:-1], strict=True):
        table.append(new)
    widths.append(stage[-1])


def _pareto_winners(
    key: np.ndarray, f: np.ndarray, t: np.ndarray, clear: Callable[[np.ndarray], np.ndarray], labels: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """Per key, up to ``labels`` candidates of its Pareto set on (f, t) that pass ``clear``: (indices, slot).

    Slot 0 is the least (f, t) candidate that is clear (:func:`_lazy_winners`); slot j + 1 the least
    (f, t) clear one strictly earlier than slot j's.
    """
    alive = np.ones(key.size, dtype=bool)
    won, slots = [], []
    for slot in itertools.count() if labels is None else range(labels):
        q = np.nonzero(alive)[0]
        if q.size == 0:
            break
        w = q[_lazy_winners(key[q], f[q], t[q], lambda r, q=q: clear(q[r]))]
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


def _lazy_winners(
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


def _combos(src: np.ndarray, dest: np.ndarray, n_speeds: int, step: int | None) -> tuple[np.ndarray, ...]:
    """All (source, destination lateral, speed index) triples, flat; lateral step limited if ``step``."""
    a, b, v = np.meshgrid(src, dest, np.arange(n_speeds), indexing="ij")
    a, b, v = a.ravel(), b.ravel(), v.ravel()
    if step is not None:
        keep = np.abs(b - a) <= step
        a, b, v = a[keep], b[keep], v[keep]
    return a, b, v


class _Transition:
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
    ) -> None:
        self.lat, self.lon, self.dists, self.speeds = lat, lon, dists, speeds
        self.leg_cost, self.navigable, self.nogo_step = leg_cost, navigable, nogo_step
        self.rem_nm, self.vmax, self.horizon = rem_nm, vmax, horizon
        self.count = 0
        self.stages: _CompiledStages | None = None
        self._samples: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

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
        self, k: int, l0: np.ndarray, lj: np.ndarray, vi: np.ndarray, t0: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Cost legs; return (ok, t1, fuel, duration) with ok = feasible and within the horizon."""
        sog = self.speeds[vi]
        if self.stages is not None:  # the compiled legs, their pieces computed once per stage
            dur, fu, feas = self.stages.cost_legs(k, l0, lj, vi, t0)
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

    def clear(self, k: int, l0: np.ndarray, lj: np.ndarray, t0: np.ndarray, dur: np.ndarray) -> np.ndarray:
        """Whether each leg stays out of the no-go areas (samples along it and the state reached)."""
        if self.navigable is None:
            return np.ones(l0.size, dtype=bool)
        fr, plat, plon = self._samples_for(k)
        good = _nav(self.navigable, self.lat[k + 1, lj], self.lon[k + 1, lj], t0 + dur)
        if plat is not None and good.any():
            q = np.nonzero(good)[0]
            pt = t0[q, None] + fr[None, :] * dur[q, None]
            good[q] = _nav(self.navigable, plat[l0[q], lj[q]], plon[l0[q], lj[q]], pt).all(axis=1)
        return good

    def __call__(
        self, k: int, l0: np.ndarray, lj: np.ndarray, vi: np.ndarray, t0: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        ok, t1, fu, dur = self.cost(k, l0, lj, vi, t0)
        if ok.any():
            q = np.nonzero(ok)[0]
            ok[q] = self.clear(k, l0[q], lj[q], t0[q], dur[q])
        return ok, t1, fu


def _nav(fn: NoGoFn, lat: np.ndarray, lon: np.ndarray, t: np.ndarray) -> np.ndarray:
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


class _CompiledStages:
    """The binned labels of a stage from the compiled transitions (:mod:`optroute.search.dp_kernels`).

    The same winners as the loop over every transition: per (destination lateral, bin), the
    transition of least (fuel, time, order) that is feasible and clear of the no-go areas.
    """

    def __init__(
        self, kernel: DPLegKernel, step_fn: _Transition, bins: tuple[float, float, int], labels: int | None
    ) -> None:
        self.kernel, self.step_fn, self.labels = kernel, step_fn, labels
        self.t_ref, self.dt, self.n_bins = bins
        self.speeds = np.ascontiguousarray(step_fn.speeds, dtype=float)
        self.floor = kernel.floor_tph(self.speeds)
        self.inputs = (np.ascontiguousarray(kernel.params, dtype=float), tuple(kernel.weather))
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

    def cost_legs(self, k: int, l0: np.ndarray, lj: np.ndarray, vi: np.ndarray, t0: np.ndarray):
        """(duration [h], fuel [t], feasible) of legs from stage k, as the callback costs them."""
        geom, geom_of = self._geometry(k)
        dur, fuel, feas, _, _, unc = cost_dp_legs(
            *self.inputs, geom.lat_deg, geom.lon_deg, geom.course_deg, geom.frac, geom.n_pieces,
            np.ascontiguousarray(geom_of[l0, lj]), np.ascontiguousarray(t0, dtype=float),
            np.ascontiguousarray(self.speeds[vi]), geom.dist_nm,
        )  # fmt: skip
        self.kernel.uncovered(int(unc))
        return dur, fuel, feas

    def stage(self, k: int, src: tuple, dest: np.ndarray, step: int | None, max_batch: int, rem_next: np.ndarray):
        """Yield, per batch of destination laterals, the winners: (lateral, bin, fuel, time, source, speed index)."""
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
                self.dt, self.n_bins,
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
        fuel1 = np.full(key.size, np.nan)
        rejected = np.zeros(key.size, dtype=bool)
        won, slots = [], []
        todo = np.arange(n_groups, dtype=np.int64)
        for slot in itertools.count() if self.labels is None else range(self.labels):
            winner = self._round(k, todo, src_l, src_t, src_f, geom, geom_of, order, group_start, ptr, costed, fuel1,
                                 rejected, c_src, c_lj, c_vi, t1, lb)  # fmt: skip
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

    def _round(self, k, todo, src_l, src_t, src_f, geom, geom_of, order, group_start, ptr, costed, fuel1, rejected,
               c_src, c_lj, c_vi, t1, lb):  # fmt: skip
        """Per group in ``todo``, its least (fuel, time, order) candidate not struck out and clear of the no-go areas (-1: none)."""
        winner = np.full(todo.size, -1, dtype=np.int64)
        pos = np.arange(todo.size)
        while todo.size:
            best, n_costed, unc = resolve(
                *self.inputs, geom.lat_deg, geom.lon_deg, geom.course_deg, geom.frac, geom.n_pieces, geom.dist_nm,
                geom_of, self.speeds, order, group_start, todo, ptr, costed, fuel1, rejected,
                c_src, c_lj, c_vi, t1, lb, src_l, src_t, src_f,
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
