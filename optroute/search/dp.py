"""The 3-D dynamic programme of Shao et al.: stage × lateral position × arrival time.

Ship routing as a multi-stage decision process (Shao et al.'s 3-D DP, after their
3-D DP): stages every ΔX along the great circle from start to end, lateral
states every ΔY on the great circle perpendicular to it at each stage (within
± a half-width), and the control between two stages is the speed over ground,
chosen from a discrete set (5–30 kn in the paper); the heading is fixed by the
two grid points (or, given ``stations``, the lateral states of stages that
follow a corridor's bends).  The forward recursion runs over stage × lateral
position × arrival time, so it gives, in one pass, the least fuel to reach the end in
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
earlier label cannot always imitate a later one). For a minimum time the bins
can rank their labels by arrival instead (``label_value="time"``): each bin
then keeps its earliest labels, the ones that a band clearing in time lets
through where the cheapest (the slowest) and the single earliest-arrival label
of each position are both stopped.

The bins are aligned so that the required ETA is a bin edge, and they are
closed at their end: a bin holds the arrivals after its start up to *and at*
its end (``(end - dt_h, end]``), i.e. an arrival time is rounded up to the end
of its bin (within :data:`~optroute.search.dp_kernels.BIN_TOL_H`).  So every
label in a bin that ends at or before the ETA arrives in time, and a label
arriving exactly at the ETA (a constant speed of distance / ETA) is in the
ETA's bin, not the next one.

Waiting is not allowed: "arrive by the ETA" means arriving at or before it,
with the fuel burnt on the way (no loitering at sea or at the port).

When only the route is wanted (``least_fuel_only``: one speed, as the
constant-speed baseline of Shao et al.), the earliest-arrival labels run first
and bound the rest: a label whose fuel plus the fuel floor per mile times the
distance to the end exceeds the earliest route's fuel cannot lead to the
route returned, and neither can anything it leads to; every cheaper label of
its bin is below the bound, so dropping it changes no other label.

Leg cost callback (vectorised over flat arrays of one length)::

    leg_cost(lat0_deg, lon0_deg, lat1_deg, lon1_deg, t0_h, sog_kn)
        -> (duration_h, fuel_t, feasible[, extra])

the cost of the great-circle leg (lat0, lon0) → (lat1, lon1) left at ``t0_h``
[h from departure] with the commanded speed over ground ``sog_kn`` [kn].  The
physics layer runs the MCR loop and the danger bands inside it and may only
*lower* the speed (``duration_h >= distance / sog_kn``, checked); where no
safe speed exists it returns ``feasible = False``.

A callback carrying a compiled form (``leg_cost.dp_kernel``, a
:class:`~optroute.search.dp_kernels.DPLegKernel`: ``PassagePhysics.dp_leg``;
or a :class:`~optroute.search.dp_kernels.JointLegKernel` of several members on
one grid: the robust start's joint cost) has the binned transitions costed by
:mod:`optroute.search.dp_kernels`, best first under a fuel floor: the same
labels, with the legs that cannot win left uncosted.

No-go areas (islands, moving storms) are a callable ``navigable(lat_deg,
lon_deg, t_h) -> bool array``, checked at the state reached and at points
along each leg every ``nogo_step_nm`` at the time the ship passes them
(constant speed along the leg).  A fixed obstacle narrower than that step
(an island, a cape) is a callable ``legs_blocked`` that tests whole legs: the
coastline walked every 0.1 nm (:func:`optroute.search.edge_land.legs_on_land`).

Sources: Shao et al. (3-D DP vs the IMO MEPC method; ΔX = 360 nm, ΔY = 75 nm,
Δt = 1 h, speeds 5–30 kn); Bellman (1957).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from optroute._checks import finite
from optroute.errors import ConfigError, InfeasibleETA, NoSafePassage
from optroute.search.costs import unpack_cost
from optroute.search.dp_kernels import BIN_TOL_H, stacked_inputs
from optroute.search.dp_lattice import Lattice, Options, checked_options, lattice
from optroute.search.dp_stages import (
    CompiledStages,
    LegCostFn,
    LegsBlockedFn,
    NoGoFn,
    Transition,
    append_stage,
    combos,
    empty_stage,
    lazy_winners,
    nav_check,
    pareto_winners,
    stage_tables,
)

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
        Earliest arrival [h]: of an earliest-arrival label propagated
        alongside the binned ones (exact for FIFO legs), or of a binned label
        where that is earlier (a leg that is not FIFO, as where a band clears
        in time, can stop the earliest label and let a later one through).
    stage_lat_deg, stage_lon_deg : ndarray, shape (K+1, L)
        Positions of every state [deg] (end stages: only the centre is used).
    n_states : int
        (stage, lateral, bin) states reached.
    n_transitions : int
        Legs costed (with the compiled stages, only those that could still win their bin).
    least_fuel_only : bool
        Whether the DP kept only the labels its route needed (the curve is then NaN).
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
    least_fuel_only: bool
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
        ConfigError
            The DP ran with ``least_fuel_only`` or ``fuel_cut_t`` (it kept only the labels its own route needed).
        """
        if self.least_fuel_only:
            raise ConfigError(
                f"path_for_eta({eta_h}) needs every label, and this DP ran with least_fuel_only=True or a "
                f"fuel_cut_t; run solve_dp without them, or with eta_h={eta_h}"
            )
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
    by_time: bool = False  # the binned labels' "fuel" holds their arrival times (``label_value="time"``)

    def earliest(self) -> float:
        """The earliest arrival found [h]: the earliest-arrival label's, or a binned label's where that is earlier
        (legs that are not FIFO: where a band clears, the earliest label can be stopped and a later one pass)."""
        binned = self.time[-1][self.centre][np.isfinite(self.fuel[-1][self.centre])]
        return float(min(self.early_t[-1, self.centre], binned.min(initial=np.inf)))

    def path_for(self, eta_h: float | None) -> DPPath:
        k_end = len(self.fuel) - 1
        f = self.fuel[k_end][self.centre]
        t = self.time[k_end][self.centre]
        ok = np.isfinite(f) if eta_h is None else np.isfinite(f) & (t <= eta_h + 1e-9)
        early = self.earliest()
        fifo = float(self.early_t[-1, self.centre])  # inf where a later leg than the earliest label's got through
        beats = (lambda: fifo < t[ok].min()) if self.by_time else (lambda: self.early_f[-1, self.centre] < f[ok].min())
        use_early = np.isfinite(fifo) and (eta_h is None or fifo <= eta_h + 1e-9) and (not ok.any() or beats())
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
        return self._make_path(np.array(lat_idx), np.array(spd), times, fuel, binned=True)

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

    def _make_path(
        self, li: np.ndarray, spd: np.ndarray, times: np.ndarray, fuel: np.ndarray, binned: bool = False
    ) -> DPPath:
        k_end = len(self.fuel) - 1
        lat = self.lat[np.arange(k_end + 1), li]
        lon = self.lon[np.arange(k_end + 1), li]
        dist = np.array([self.dist[k][li[k], li[k + 1]] for k in range(k_end)])
        sog = self.speeds[spd]
        out = self.leg_cost(lat[:-1], lon[:-1], lat[1:], lon[1:], times[:-1], sog)
        _, leg_fuel, _, extra = unpack_cost(out, k_end, "leg_cost")
        if binned and self.by_time:  # the binned labels' values are their times: the fuel is the legs'
            fuel = np.concatenate([[0.0], np.cumsum(leg_fuel)])
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


def _early_step(step_fn: Transition, k: int, early: tuple, dest: np.ndarray, step: int | None) -> None:
    """The earliest-arrival labels of stage k + 1 from those of stage k (every reached lateral, destination, speed).

    ``early``: the (time [h], fuel [t], back pointer) tables, filled in place; ties of time go to the
    least fuel.  Exact for legs where leaving later never arrives earlier (FIFO).
    """
    early_t, early_f, early_back = early
    el = np.nonzero(np.isfinite(early_t[k]))[0]
    l0, lj, vi = combos(el, dest, step_fn.speeds.size, step)
    if l0.size == 0:
        return
    t0 = early_t[k, l0]
    # the legs checked at their pieces' midpoints first, and in full only as each lateral's candidate: the same winners
    ok, t1, fu, dur = step_fn.cost(k, l0, lj, vi, t0, check=False)
    q = np.nonzero(ok)[0]
    f1 = early_f[k, l0[q]] + fu[q]

    def clear(r: np.ndarray) -> np.ndarray:
        i = q[r]
        return step_fn.clear(k, l0[i], lj[i], t0[i], dur[i], between=vi[i])

    q = q[lazy_winners(lj[q], t1[q], f1, clear)]  # per lateral, the earliest clear leg; ties: the least fuel
    early_t[k + 1, lj[q]] = t1[q]
    early_f[k + 1, lj[q]] = early_f[k, l0[q]] + fu[q]
    early_back[k + 1, lj[q], 0] = l0[q]
    early_back[k + 1, lj[q], 1] = vi[q]


_TAIL_SLACK = 1.0 - 1e-9
"""The lower bound on the fuel to the end is lowered by this factor: rounding room in the triangle inequality."""


def _fuel_cut(
    early_t_h: float, early_fuel_t: float, eta_h: float | None, floor_t_per_nm: float, rem_nm: np.ndarray
) -> tuple[np.ndarray, float]:
    """(lower bound on the fuel from every state to the end [t], the cut [t]) of ``least_fuel_only``.

    The cut is the earliest route's fuel when it arrives by ``eta_h`` (else ``inf``: nothing is
    dropped): the route returned costs at most that.  The bound is ``floor_t_per_nm`` (the least
    fuel floor per mile over the speed set, :func:`~optroute.search.dp_kernels.fuel_floor_tph` over
    the speed; 0 without the compiled stages) times the geodesic distance to the end, which no
    lattice path is shorter than.  A label whose fuel plus the bound exceeds the cut is hopeless,
    and so is every label it leads to; a cheaper label of its bin is never hopeless, so dropping the
    hopeless ones changes no other bin's label: the labels kept, and the route, are the DP's own.
    """
    arrives = np.isfinite(early_t_h) and (eta_h is None or early_t_h <= eta_h + 1e-9)
    tail = floor_t_per_nm * _TAIL_SLACK * np.asarray(rem_nm, dtype=float)
    return tail, float(early_fuel_t) if arrives else np.inf


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
    legs_blocked: LegsBlockedFn | None = None,
    max_lateral_step: int | None = None,
    horizon_h: float | None = None,
    max_batch: int = 400_000,
    labels_per_bin: int | None = DEFAULT_LABELS_PER_BIN,
    least_fuel_only: bool = False,
    stations: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
    fuel_cut_t: float | None = None,
    label_value: str = "fuel",
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
    legs_blocked : callable, optional
        ``legs_blocked(lat0_deg, lon0_deg, lat1_deg, lon1_deg) -> bool array``, True for a great-circle leg
        that crosses a fixed obstacle anywhere along it (the coastline:
        :func:`optroute.search.edge_land.legs_on_land`); called once per stage on all its (La, Lb) state pairs,
        and such a leg does not exist. Default: none.
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
    least_fuel_only : bool
        Only the route for ``eta_h`` is wanted, not the curve: the earliest-arrival labels are
        propagated first, and a label is dropped (or, by its fuel floor, never costed) when its
        fuel plus a lower bound on the fuel to the end exceeds the earliest route's fuel (see
        :func:`_fuel_cut`).  The route returned is the one found without it; the curve is NaN and
        :meth:`DPResult.path_for_eta` refuses.
    stations : (lat_deg, lon_deg, lateral_nm), optional
        The stages' lateral states themselves, for a centreline that is not one great circle (a corridor's,
        :func:`optroute.optimise.starts.corridor_stations`): ``lat_deg``, ``lon_deg`` (K+1, 2n+1) [deg], row k
        stage k, column j the lateral state ``lateral_nm[j]`` [nm, starboard +], rising through 0 at column n; the
        centres of the first and last rows are ``start`` and ``end``. Replaces ``dx_nm``, ``dy_nm`` and
        ``half_width_nm``'s great-circle lattice (``dy_nm`` still spaces the no-go checks by default).
    fuel_cut_t : float, optional
        A fuel [t] no route of interest exceeds (an incumbent plan's): a label whose fuel plus the lower bound on
        the fuel to the end (as ``least_fuel_only``'s, :func:`_fuel_cut`) exceeds it is dropped, so the binned
        labels are those of the routes under it; where none arrives, the route returned is the earliest. The curve is
        then NaN and :meth:`DPResult.path_for_eta` refuses, as with ``least_fuel_only``.
    label_value : {"fuel", "time"}
        What ranks a bin's labels: their fuel (the fuel-versus-ETA curve), or their arrival time, so that every bin
        keeps its earliest labels: for a minimum time where the legs are not FIFO (a band that clears lets a later
        label through where the earliest is stopped, which the earliest-arrival label alone cannot follow). With
        ``"time"`` the curve is NaN, the route's fuel is its legs' costed again, and neither ``least_fuel_only``
        nor ``fuel_cut_t`` applies.

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
    opt = checked_options(
        leg_cost, start, end, eta_h, (dx_nm, dy_nm, half_width_nm, dt_h), speeds_kn, nogo_step_nm, max_lateral_step,
        labels_per_bin, label_value,
    )  # fmt: skip
    if opt.by_time and (least_fuel_only or fuel_cut_t is not None):
        raise ConfigError(
            "least_fuel_only and fuel_cut_t cut labels by their fuel; with label_value='time' give neither"
        )
    lat_ = lattice(opt, stations, horizon_h)
    labels = _Labels.at_departure(lat_)
    if navigable is not None and not nav_check(navigable, np.array([opt.start[0]]), np.array([opt.start[1]]),
                                               np.array([0.0]))[0]:  # fmt: skip
        raise NoSafePassage(f"the start {opt.start} is in a no-go area at departure; move it or change the no-go mask")
    step_fn = Transition(
        lat_.lat, lat_.lon, lat_.dists, opt.speeds, leg_cost, navigable, opt.nogo_step, lat_.rem_nm,
        float(opt.speeds.max()), lat_.horizon, legs_blocked,
    )  # fmt: skip
    kernel = getattr(leg_cost, "dp_kernel", None)
    inputs = None if kernel is None else stacked_inputs(kernel.members)
    stages = None if inputs is None else CompiledStages(kernel, inputs, step_fn, lat_.bins, opt.n_labels, opt.by_time)
    step_fn.stages = stages
    if least_fuel_only:  # the earliest route first: its fuel bounds the labels worth keeping
        for k in range(lat_.n_stages):
            if not np.isfinite(labels.early_t[k]).any():
                break
            _early_step(step_fn, k, labels.early, lat_.destinations(k), opt.step)
    cut = None
    if least_fuel_only or fuel_cut_t is not None:
        floor_per_nm = 0.0 if stages is None else float(np.min(stages.floor / stages.speeds))
        c = lat_.centre
        e_t, e_f = (labels.early_t[-1, c], labels.early_f[-1, c]) if least_fuel_only else (np.inf, np.inf)
        tail, value = _fuel_cut(e_t, e_f, opt.eta_h, floor_per_nm, lat_.rem_nm)
        if fuel_cut_t is not None:
            cut_t = finite("fuel_cut_t", fuel_cut_t, minimum=0.0, strict=True, error=ConfigError,
                           fix="give an incumbent plan's fuel [t], or None for no cut")  # fmt: skip
            value = min(value, float(cut_t))
        cut = (tail, value)
    for k in range(lat_.n_stages):
        src_l, src_b = np.nonzero(np.isfinite(labels.fuel[k]))
        dest = lat_.destinations(k)
        if src_l.size == 0 and cut is not None and not least_fuel_only and np.isfinite(labels.early_t[k]).any():
            # a fuel cut dropped every label: the earliest-arrival labels go on alone (the route is the earliest)
            _early_step(step_fn, k, labels.early, dest, opt.step)
            labels.append(empty_stage(lat_.n_lat, lat_.n_bins))
            continue
        if src_l.size == 0:
            break
        if not least_fuel_only:  # earliest arrival: every reached lateral x every destination x every speed
            _early_step(step_fn, k, labels.early, dest, opt.step)
        stage_cut = None if cut is None else (cut[0][k + 1], cut[1])
        if stages is not None:
            labels.append(
                _compiled_stage(stages, labels, lat_, k, (src_l, src_b), dest, opt.step, max_batch, stage_cut)
            )
        else:
            labels.append(_callback_stage(step_fn, labels, lat_, opt, k, (src_l, src_b), dest, max_batch, stage_cut))
    while len(labels.fuel) < lat_.n_stages + 1:  # stages never reached
        labels.append(empty_stage(lat_.n_lat, lat_.n_bins))
    if not (np.isfinite(labels.early_t[-1, lat_.centre]) or np.isfinite(labels.fuel[-1][lat_.centre]).any()):
        raise _no_route(labels, lat_, opt)
    return _result(labels, lat_, opt, leg_cost, step_fn.count, cut is not None)


@dataclass(eq=False)
class _Labels:
    """The binned labels stage by stage (:func:`~optroute.search.dp_stages.stage_tables`: fuel [t], time [h], back
    lateral, back column, speed index, each (n_lat, n_bins × width)), and the earliest-arrival label of every
    (stage, lateral): time [h], fuel [t], back pointer (lateral, speed index), propagated alongside (exact under
    FIFO)."""

    fuel: list[np.ndarray]
    time: list[np.ndarray]
    back_l: list[np.ndarray]
    back_b: list[np.ndarray]
    speed_i: list[np.ndarray]
    widths: list[int]
    early_t: np.ndarray
    early_f: np.ndarray
    early_back: np.ndarray

    @classmethod
    def at_departure(cls, lat_: Lattice) -> _Labels:
        """Stage 0: the start's one label, at time 0 with no fuel."""
        n, c = lat_.n_stages, lat_.centre
        fuel, time, back_l, back_b, speed_i = ([a] for a in empty_stage(lat_.n_lat, lat_.n_bins)[:-1])
        early_t = np.full((n + 1, lat_.n_lat), np.inf)
        early_f = np.full((n + 1, lat_.n_lat), np.inf)
        b0 = lat_.bin_of(0.0)
        fuel[0][c, b0], time[0][c, b0] = 0.0, 0.0
        early_t[0, c], early_f[0, c] = 0.0, 0.0
        early_back = np.full((n + 1, lat_.n_lat, 2), -1, dtype=np.int64)
        return cls(fuel, time, back_l, back_b, speed_i, [1], early_t, early_f, early_back)

    @property
    def early(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.early_t, self.early_f, self.early_back

    def append(self, stage: tuple) -> None:
        """Append the next stage's tables (:func:`~optroute.search.dp_stages.stage_tables`)."""
        append_stage((self.fuel, self.time, self.back_l, self.back_b, self.speed_i), self.widths, stage)


def _compiled_stage(
    stages: CompiledStages,
    labels: _Labels,
    lat_: Lattice,
    k: int,
    sources: tuple[np.ndarray, np.ndarray],
    dest: np.ndarray,
    step: int | None,
    max_batch: int,
    cut: tuple[np.ndarray, float] | None,
) -> tuple:
    """Stage k + 1's binned labels by the compiled stages (best first under the fuel floor) from stage k's
    ``sources`` (lateral, column); ``cut``: the lower bound on the fuel to the end from each of its laterals [t]
    and the cut [t], the winners above it dropped."""
    src_l, src_b = sources
    src = (src_l, labels.time[k][src_l, src_b], labels.fuel[k][src_l, src_b])
    won = list(stages.stage(k, src, dest, step, max_batch, lat_.rem_nm[k + 1], cut))
    dl, db, slot, f1, tt, w_src, w_v = (np.concatenate(x) for x in zip(*won, strict=True)) if won else (
        np.zeros(0, int), np.zeros(0, int), np.zeros(0, int), np.zeros(0), np.zeros(0), np.zeros(0, int),
        np.zeros(0, int))  # fmt: skip
    if cut is not None:  # the winners whose every route ends above the cut: dropped
        keep = f1 + cut[0][dl] <= cut[1]
        dl, db, slot, f1, tt, w_src, w_v = (a[keep] for a in (dl, db, slot, f1, tt, w_src, w_v))
    return stage_tables(lat_.n_lat, lat_.n_bins, dl, db, slot, f1, tt, src_l[w_src], src_b[w_src], w_v)


def _callback_stage(
    step_fn: Transition,
    labels: _Labels,
    lat_: Lattice,
    opt: Options,
    k: int,
    sources: tuple[np.ndarray, np.ndarray],
    dest: np.ndarray,
    max_batch: int,
    cut: tuple[np.ndarray, float] | None,
) -> tuple:
    """Stage k + 1's binned labels through the ``leg_cost`` callback: every transition from stage k's ``sources``
    costed in batches of at most ``max_batch``, then each bin's Pareto winners that pass the no-go checks; ``cut``
    as :func:`_compiled_stage`'s."""
    src_l, src_b = sources
    t_ref, dt, n_bins = lat_.bins
    chunk = max(1, max_batch // max(dest.size * opt.speeds.size, 1))
    parts = []
    for a in range(0, src_l.size, chunk):
        sl, sb = src_l[a : a + chunk], src_b[a : a + chunk]
        pos, lj, vi = combos(np.arange(sl.size), dest, opt.speeds.size, None)
        l0, b_src = sl[pos], sb[pos]
        if opt.step is not None:
            keep = np.abs(lj - l0) <= opt.step
            l0, b_src, lj, vi = l0[keep], b_src[keep], lj[keep], vi[keep]
        if l0.size == 0:
            continue
        t0 = labels.time[k][l0, b_src]
        ok, t1, fu, dur = step_fn.cost(k, l0, lj, vi, t0)
        sel = np.nonzero(ok)[0]
        f1 = labels.fuel[k][l0[sel], b_src[sel]] + (dur if opt.by_time else fu)[sel]  # fuel [t], or time [h]
        tt = t1[sel]
        b1 = np.ceil((tt - t_ref) / dt - BIN_TOL_H / dt).astype(np.int64) - 1
        inside = (b1 >= 0) & (b1 < n_bins)
        sel = sel[inside]
        parts.append((f1[inside], tt[inside], b1[inside], l0[sel], lj[sel], vi[sel], b_src[sel], t0[sel], dur[sel]))
    if not parts:
        return empty_stage(lat_.n_lat, n_bins)
    f1, tt, b1, cl0, clj, cvi, cb, ct0, cdur = (np.concatenate(x) for x in zip(*parts, strict=True))
    win, slot = pareto_winners(
        clj * n_bins + b1,
        f1,
        tt,
        lambda q: step_fn.clear(k, cl0[q], clj[q], ct0[q], cdur[q]),
        opt.n_labels,
    )
    if cut is not None:  # the winners whose every route ends above the cut: dropped
        keep = f1[win] + cut[0][clj[win]] <= cut[1]
        win, slot = win[keep], slot[keep]
    return stage_tables(lat_.n_lat, n_bins, clj[win], b1[win], slot, f1[win], tt[win], cl0[win], cb[win], cvi[win])


def _no_route(labels: _Labels, lat_: Lattice, opt: Options) -> NoSafePassage:
    """NoSafePassage naming the last stage reached and its reachable state closest to the end."""
    reached = [
        np.isfinite(labels.early_t[k]) | np.isfinite(labels.fuel[k]).any(axis=1) for k in range(len(labels.fuel))
    ]
    k_reach = max(k for k, r in enumerate(reached) if r.any())
    reach_l = np.nonzero(reached[k_reach])[0]
    q = int(reach_l[np.argmin(lat_.rem_nm[k_reach, reach_l])])
    return NoSafePassage(
        f"the DP found no route from {opt.start} to {opt.end} within {lat_.horizon:.1f} h: it stopped at stage "
        f"{k_reach} of {lat_.n_stages}; the reachable state closest to the end is ({lat_.lat[k_reach, q]:.3f}, "
        f"{lat_.lon[k_reach, q]:.3f}), {float(lat_.rem_nm[k_reach, q]):.1f} nm from it; widen half_width_nm, add "
        "speeds, raise horizon_h or relax the no-go areas"
    )


def _result(
    labels: _Labels, lat_: Lattice, opt: Options, leg_cost: LegCostFn, n_transitions: int, cut: bool
) -> DPResult:
    """The route for the ETA and the fuel-versus-arrival curve (NaN where a fuel ``cut`` dropped labels)."""
    c, (t_ref, dt, n_bins) = lat_.centre, lat_.bins
    final_all = labels.fuel[-1][c].reshape(n_bins, labels.widths[-1])
    best_slot = np.argmin(final_all, axis=1)
    final_f = final_all[np.arange(n_bins), best_slot]
    final_t = labels.time[-1][c].reshape(n_bins, labels.widths[-1])[np.arange(n_bins), best_slot]
    tables = _Tables(
        fuel=labels.fuel,
        time=labels.time,
        back_l=labels.back_l,
        back_b=labels.back_b,
        speed_i=labels.speed_i,
        lat=lat_.lat,
        lon=lat_.lon,
        lateral_nm=lat_.lateral,
        dist=lat_.dists,
        speeds=opt.speeds,
        centre=c,
        leg_cost=leg_cost,
        early_t=labels.early_t,
        early_f=labels.early_f,
        early_back=labels.early_back,
        by_time=opt.by_time,
    )
    path = tables.path_for(opt.eta_h)
    bin_end = t_ref + dt * (np.arange(n_bins) + 1.0)
    by_eta = np.minimum.accumulate(final_f)
    early_t, early_f = labels.early_t[-1, c], labels.early_f[-1, c]
    by_eta = np.where(bin_end >= early_t - 1e-9, np.minimum(by_eta, early_f), by_eta)
    if cut or opt.by_time:  # the labels above the cut were dropped, or ranked by time: no fuel curve
        final_t, final_f, by_eta = (np.full(n_bins, np.nan) for _ in range(3))
    return DPResult(
        path=path,
        eta_h=opt.eta_h,
        curve_bin_end_h=bin_end,
        curve_arrival_h=final_t,
        curve_fuel_t=by_eta,
        curve_fuel_in_bin_t=final_f.copy(),
        earliest_arrival_h=tables.earliest(),
        stage_lat_deg=lat_.lat,
        stage_lon_deg=lat_.lon,
        n_states=int(sum(np.isfinite(f).sum() for f in labels.fuel)),
        n_transitions=n_transitions,
        least_fuel_only=cut,
        _tables=tables,
    )
