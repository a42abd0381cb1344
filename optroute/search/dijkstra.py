"""Time-dependent Dijkstra and A* over the routing grid.

Boeing EP 2145155 (Figs. 14–16, 21–22) labels each grid point P with the
cost L(P) of the best route found to it and the time T(P) the ship gets
there; expanding P costs every neighbour N with C(P, N, T(P)), the cost of
crossing the cells cut by P→N with the weather of the time the ship is in
each one.  This module implements that search, generic over the cost of a
leg (see :mod:`optroute.search.costs` for the two callback forms).

Objectives
----------
``"time"``
    Earliest arrival.  Label = arrival time.  Exact when the legs are FIFO (a
    later departure never arrives earlier, true for speed fields that change
    slowly against the leg duration); without FIFO it returns the fixed point
    of ``T(N) = min_P T(P) + C(P, N, T(P))`` that every label-setting method
    returns, as the patent does.
``"cost"``
    Label = fuel + λ·time [t], with ``λ = lambda_t_per_h`` [t/h]; the time is
    carried along with the label.  With time-dependent weather this is a
    heuristic label-setting search (a costlier but earlier partial route can
    lead to a cheaper total, and is discarded), exactly like the patent's
    "lowest cost" variant; with static weather it is exact.  ``λ = 0`` gives
    the "fuel" objective.

Methods
-------
``"dijkstra"``
    Label-setting in increasing label order.  Nodes are settled in *batches*:
    every open node y with ``g(y) <= min over the open set of (g(w) + δ_w)``
    is final, where ``δ_w`` is a lower bound on the cost of any edge out of w
    (a floor of the true edge length there, over ``v_max_kn``; times λ for
    the cost objective): no edge can bring an open node below that.  Batching
    is therefore exact, and lets the callback cost the edges of many nodes in
    one vectorised call.
``"astar"``
    A* with the geodesic heuristic ``E(N) = w · distance_nm(N, end) /
    v_max_kn`` (``w`` = 1 for time, λ for cost; WGS84, shrunk by 1e-5 for the
    pieces' length approximation), consistent because every leg is at least
    as long as the geodesic and is sailed at most at ``v_max_kn``.  It settles the same
    labels as Dijkstra (same cost), batched by the same argument refined by
    the heuristic (see ``_Search._loop``), and expands fewer nodes.

``batched=False`` settles one node per step (the textbook order) for
comparison.  Before the callback is called, edges that could not improve
their end node's label, or the goal's, even at ``v_max_kn`` are dropped
(exact); so are, given ``time_limit_h`` (the weather's end), edges from which
the goal cannot be reached by then even at ``v_max_kn`` along the great
circle (exact: every leg past the limit is infeasible).  The search checks on every costed edge that ``duration_h >=
distance / v_max_kn`` (otherwise the heuristic, the batching and the pruning
would not be exact) and raises :class:`~optroute.errors.ConfigError` if the
callback sails faster.

Performance: the search's own bookkeeping (edge tests, pruning, label
updates, batch selection) runs in numba when it is installed (``engine``),
else in numpy with the same labels; the callback is called once per batch
(whole-leg form) or once per piece position per batch (cell-by-cell form).
The number of batches is bounded below by the voyage's duration over the
shortest edge's duration, whatever the engine.  With the physics' own
callbacks (a compiled leg cost) the whole search runs in numba
(:mod:`optroute.search.compiled_search`) and settles one node a step with
the same labels, but costs an edge only when its bound is the least of the
open set and its end is not settled yet (lazy): a batch costs every edge its
bounds allow, most of them into nodes that a better edge reaches first.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from optroute import geodesy as geo
from optroute._checks import finite
from optroute.errors import ConfigError, InfeasibleETA, NoSafePassage, WeatherCoverageError
from optroute.search import _kernels, compiled_search
from optroute.search.compiled_search import LegKernel
from optroute.search.costs import EdgeCostFn, LegEvaluator, SegmentCostFn
from optroute.search.edge_land import EdgeLand, edges_on_land, no_land_arrays
from optroute.search.grid import RouteGrid, course_between_deg, segment_cells
from optroute.search.neighbourhood import Neighbourhood

_SPEED_TOL = 1e-5  # the pieces of a leg sum to its geodesic length within 1e-6 (costs.LegEvaluator)
# The compiled pruning measures an edge on the gnomonic sphere (chord of unit vectors); times the least
# WGS84/sphere length ratio that is a lower bound of its geodesic length, so the pruning stays exact.
_TWO_R_FLOOR_NM = 2.0 * geo.EARTH_RADIUS_NM * geo.SPHERE_TO_WGS84_MIN
# The A* heuristic is the WGS84 geodesic distance to the end, shrunk by the error bound of the pieces'
# local sphere-to-ellipsoid lengths (geodesy.sphere_to_wgs84, < 1e-6) so that it stays consistent.
_HEURISTIC_SHRINK = 1.0 - 1e-5
_EMPTY = np.zeros(0, dtype=np.int64)
TIME_LIMIT_SLACK_H = 0.01
"""Room past ``time_limit_h`` before an edge is pruned [h]: a checked piece's end is sampled at a time within
1e-3 h of the ship's (:mod:`optroute.search.passage_kernels`), so a leg arriving later than the limit plus this
is certainly sampled past it."""


@dataclass(frozen=True, eq=False)
class SearchResult:
    """A route found on the grid, with the search's statistics.

    Attributes
    ----------
    nodes : ndarray of int, shape (n, 2)
        Grid nodes ``(i, j)`` from start to end.
    lat_deg, lon_deg : ndarray, shape (n,)
        Waypoints [deg], lon in [-180, 180).
    times_h : ndarray, shape (n,)
        Time at each waypoint [h from departure]; ``times_h[0] == 0``.
    leg_duration_h, leg_fuel_t, leg_distance_nm : ndarray, shape (n-1,)
        Per leg: duration [h], fuel [t], great-circle length [nm].
    leg_course_deg : ndarray, shape (n-1,)
        Initial great-circle course of each leg [deg true, to].
    leg_sog_kn : ndarray, shape (n-1,)
        Mean speed over ground of each leg [kn].
    extra : dict of str to ndarray
        The edge callback's extras for each leg (edge form), or the per-piece
        records of the segment form (keys ``piece_*``, ``piece_leg`` = leg index).
    cost : float
        Objective value: arrival time [h] for ``"time"``, fuel + λ·time [t] for ``"cost"``.
    arrival_h, total_fuel_t : float
        Arrival [h from departure] and total fuel [t].
    objective, method, neighbourhood : str
        What was run.
    lambda_t_per_h : float
        λ of the cost objective [t/h] (0 for ``"time"``).
    expanded : int
        Nodes settled (their edges then costed, or with the compiled loop queued to be costed when due).
    evaluated_edges : int
        Edges costed by the callback (including those dropped part way, once they could not improve their end).
    callback_calls : int
        Calls of the cost callback.
    batches : int
        Settling steps (``expanded`` for A* and for the compiled loop; fewer for batched Dijkstra).
    """

    nodes: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    times_h: np.ndarray
    leg_duration_h: np.ndarray
    leg_fuel_t: np.ndarray
    leg_distance_nm: np.ndarray
    leg_course_deg: np.ndarray
    leg_sog_kn: np.ndarray
    extra: dict[str, np.ndarray]
    cost: float
    arrival_h: float
    total_fuel_t: float
    objective: str
    method: str
    neighbourhood: str
    lambda_t_per_h: float
    expanded: int
    evaluated_edges: int
    callback_calls: int
    batches: int

    @property
    def distance_nm(self) -> float:
        """Total great-circle length of the route [nm]."""
        return float(self.leg_distance_nm.sum())


# ------------------------------------------------------------------ graph
def edge_mask(grid: RouteGrid, neighbourhood: Neighbourhood) -> np.ndarray:
    """Which edges exist: ``mask[k, o]`` for flat node ``k`` and offset index ``o``.

    An edge exists when its end node is on the grid and every cell its segment
    crosses (supercover walk, including cells touched at a corner; Boeing
    Fig. 14) is navigable, the start and end cells included.

    Returns
    -------
    ndarray of bool, shape (ny * nx, m)
    """
    ny, nx = grid.shape
    r = neighbourhood.radius_cells
    pad = np.zeros((ny + 2 * r, nx + 2 * r), dtype=bool)
    pad[r : r + ny, r : r + nx] = grid.navigable
    out = np.empty((ny, nx, neighbourhood.m), dtype=bool)
    shifted: dict[tuple[int, int], np.ndarray] = {}
    for o, (di, dj) in enumerate(neighbourhood.offsets):
        cells, _, _ = segment_cells(int(di), int(dj))
        acc = grid.navigable.copy()
        for ci, cj in cells:
            key = (int(ci), int(cj))
            if key not in shifted:
                shifted[key] = pad[r + key[0] : r + key[0] + ny, r + key[1] : r + key[1] + nx]
            acc &= shifted[key]
        out[:, :, o] = acc
    return out.reshape(ny * nx, neighbourhood.m)


def grid_edges(grid: RouteGrid, neighbourhood: Neighbourhood) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All edges of the grid graph as flat ``(source, target, offset index)`` arrays."""
    mask = edge_mask(grid, neighbourhood)
    u, o = np.nonzero(mask)
    off = neighbourhood.offsets[:, 0] * grid.nx + neighbourhood.offsets[:, 1]
    return u, u + off[o], o


def _edge_length_floor_nm(grid: RouteGrid) -> np.ndarray:
    """A lower bound on the true length of every edge leaving each node [nm], shape ``(ny * nx,)``.

    An edge leaves the 3 x 3-cell square around its node after at least one
    cell of plane length, inside a disc of plane radius ``rho + sqrt(2) cell``
    about the projection centre; the gnomonic scale is at most sec² c there
    (Snyder 1987 §22: sec² c radially, sec c across), so the true length is at
    least ``cell · cos²(arctan((rho + sqrt(2) cell) / R))``.
    """
    jj, ii = np.meshgrid(np.arange(grid.nx), np.arange(grid.ny))
    x, y = grid.node_xy_nm(ii, jj)
    rho = np.hypot(x, y).ravel() + np.sqrt(2.0) * grid.cell_nm
    return grid.cell_nm * np.cos(np.arctan(rho / geo.EARTH_RADIUS_NM)) ** 2 * geo.SPHERE_TO_WGS84_MIN


# ----------------------------------------------------------------- search
def shortest_path(
    grid: RouteGrid,
    neighbourhood: Neighbourhood,
    *,
    v_max_kn: float,
    edge_cost: EdgeCostFn | None = None,
    segment_cost: SegmentCostFn | None = None,
    method: Literal["astar", "dijkstra"] = "astar",
    objective: Literal["time", "cost", "fuel"] = "time",
    lambda_t_per_h: float = 0.0,
    eta_h: float | None = None,
    batched: bool = True,
    engine: Literal["auto", "numba", "numpy"] = "auto",
    cost_floor_per_nm: float | None = None,
    time_limit_h: float | None = None,
    cost_ceiling: float | None = None,
    edge_land: EdgeLand | None = None,
    cost_to_go: np.ndarray | None = None,
    edge_cost_floor: np.ndarray | None = None,
) -> SearchResult:
    """Time-dependent shortest path from ``grid.start`` to ``grid.end``.

    Parameters
    ----------
    grid : RouteGrid
        The lattice and its navigable mask.
    neighbourhood : Neighbourhood
        The offsets a leg may take.
    v_max_kn : float
        An upper bound on the speed over ground any leg can make [kn] (the
        ship's top speed plus the strongest following current): it makes the
        A* heuristic admissible and the Dijkstra batches exact, and is checked.
    edge_cost, segment_cost : callable
        Exactly one: the whole-leg or the cell-by-cell callback, see
        :mod:`optroute.search.costs`.  Times are [h from departure].
    method : {"astar", "dijkstra"}
        Search order; both give the same cost.
    objective : {"time", "cost", "fuel"}
        Earliest arrival, or fuel + λ·time (``"fuel"`` is ``"cost"`` with λ = 0;
        with no price on time there is no positive lower bound on an edge's
        cost, so nodes are settled one label at a time and A* has no
        heuristic: slow on big grids).
    lambda_t_per_h : float
        λ, the value of an hour in tonnes of fuel [t/h], for ``"cost"``.
    eta_h : float, optional
        Required arrival [h from departure], ``"time"`` objective only: a later
        earliest arrival raises :class:`InfeasibleETA`.
    batched : bool
        Settle every provably final node at once (default; exact, see
        ``_Search._loop``) or one node per step (the textbook order, slower;
        for checking).
    engine : {"auto", "numba", "numpy"}
        The search's own bookkeeping (which edges to cost, label updates):
        compiled with numba when it is installed ("auto"), or numpy; the same
        labels either way.  With numba, a segment callback carrying a
        compiled leg cost (``segment_cost.leg_kernel``, a
        :class:`~optroute.search.compiled_search.LegKernel`, as the physics
        callbacks of :mod:`optroute.search.passage_physics` do) runs the whole search
        loop compiled (:func:`optroute.search.compiled_search.run`), with the
        same labels.
    cost_floor_per_nm : float, optional
        Objectives "cost" and "fuel": a lower bound ρ on (fuel + λ·time) per
        nautical mile of any feasible leg [t/nm] (default λ / ``v_max_kn``).  It
        is the A* heuristic's weight (ρ times the great-circle distance to the
        end) and the batches' edge floor, so with a positive ρ the fuel
        objective gets both; checked on every costed edge like ``v_max_kn``.
    time_limit_h : float, optional
        A time after which every leg is infeasible [h from departure]: the
        weather's end when points past it count as no passage and each piece
        is checked at its end (``time_policy="raise"``, a band check).  An
        edge whose departure plus its length and its end's great-circle
        distance to the goal, all at ``v_max_kn``, passes the limit (plus
        :data:`TIME_LIMIT_SLACK_H`) is not costed: no route through it ends
        inside the limit (exact, whatever the objective).  If even the start's
        great-circle time to the goal passes it, :class:`WeatherCoverageError`
        is raised at once instead of searching.
    cost_ceiling : float, optional
        Look only for a route whose cost (the objective's label) is below
        this, e.g. the cost of a route already known: the goal's label starts
        there, so the A* pruning drops every edge that cannot beat it.  A route
        cheaper than the ceiling is found exactly as without it; if there is
        none, :class:`NoSafePassage` says so.
    edge_land : EdgeLand, optional
        The coastline between the nodes (:class:`optroute.search.edge_land.EdgeLand`): an edge that crosses a
        cell that may hold land is walked on it and, where it touches land, does not exist.  Without it only
        the navigable mask's nodes are tested.
    cost_to_go : ndarray, optional
        Method ``"astar"``, objectives "cost" and "fuel": a lower bound on the cost from each node to the end
        [t], flat as ``grid.flat``, consistent with every edge (``h(x) <= cost(x, y) + h(y)``; e.g.
        :func:`optroute.search.cost_bound.cost_to_go`). The heuristic is the larger of it and ρ times the
        distance; every costed edge is checked against it.
    edge_cost_floor : ndarray, shape (n_nodes, n_offsets), optional
        With ``cost_to_go``: a lower bound on each edge's cost [t] by its tail (flat as ``grid.flat``) and its
        offset in ``neighbourhood.offsets`` (e.g. :attr:`optroute.search.cost_bound.CostBound.edge_t`), at least
        ``cost_to_go``'s drop along the edge.  The compiled search defers an edge by it rather than by ρ times its
        length (:func:`optroute.search.compiled_search.run`): the same labels, fewer edges costed.  Every costed
        edge is checked against it.

    Returns
    -------
    SearchResult

    Raises
    ------
    NoSafePassage
        Start or end lies in a non-navigable cell, or no feasible route joins
        them; the message names the reached node closest to the end.
    InfeasibleETA
        The earliest arrival is after ``eta_h``; ``earliest_arrival`` and
        ``earliest_arrival_h`` hold it [h from departure].
    ConfigError
        Bad options, or a callback that breaks its contract (including sailing
        faster than ``v_max_kn`` or cheaper than ``cost_floor_per_nm``).
    WeatherCoverageError
        The end cannot be reached by ``time_limit_h`` even along the great circle at ``v_max_kn``.
    """
    if method not in ("astar", "dijkstra"):
        raise ConfigError(f"method={method!r} is not known; use 'astar' or 'dijkstra'")
    if objective not in ("time", "cost", "fuel"):
        raise ConfigError(f"objective={objective!r} is not known; use 'time', 'cost' or 'fuel'")
    vmax = float(finite("v_max_kn", v_max_kn, minimum=0.0, strict=True, error=ConfigError))
    lam = float(finite("lambda_t_per_h", lambda_t_per_h, minimum=0.0, error=ConfigError))
    if objective in ("fuel", "time"):
        lam = 0.0
    if eta_h is not None and objective != "time":
        raise ConfigError("eta_h is only checked for objective='time'; for fuel or cost use the DP or the NLP")
    ev = LegEvaluator(grid, neighbourhood, edge_cost=edge_cost, segment_cost=segment_cost)
    if engine not in ("auto", "numba", "numpy"):
        raise ConfigError(f"engine={engine!r} is not known; use 'auto', 'numba' or 'numpy'")
    if engine == "numba" and not _kernels.AVAILABLE:
        raise ConfigError("engine='numba' needs the numba package; install it or use engine='numpy'")
    eng = "numba" if engine == "auto" and _kernels.AVAILABLE else ("numpy" if engine == "auto" else engine)
    weight = 1.0 if objective == "time" else lam  # the bound per nm is weight / v_max
    if cost_floor_per_nm is not None and objective != "time":
        floor = float(finite("cost_floor_per_nm", cost_floor_per_nm, minimum=0.0, error=ConfigError))
        weight = max(weight, floor * vmax)
    limit = np.inf if time_limit_h is None else float(finite("time_limit_h", time_limit_h, error=ConfigError))
    search = _Search(grid, neighbourhood, ev, vmax, method, objective, lam, batched, eng, weight)
    if edge_land is not None:
        search.land = edge_land.kernel_arrays(search.pad_shape, neighbourhood.radius_cells)
    search.t_limit = limit + TIME_LIMIT_SLACK_H
    if cost_ceiling is not None:
        search.ceiling = float(finite("cost_ceiling", cost_ceiling, error=ConfigError))
    if cost_to_go is not None and method == "astar" and objective != "time":
        bound = np.asarray(cost_to_go, dtype=float)
        if bound.shape != (grid.n_nodes,) or not np.all(np.isfinite(bound) & (bound >= 0.0)):
            raise ConfigError(f"cost_to_go must hold one finite bound >= 0 per grid node ({grid.n_nodes}); got shape "
                              f"{bound.shape}; pass the bound flat as grid.flat (optroute.search.cost_bound.cost_to_go), "
                              "or None")  # fmt: skip
        search.h_bound = bound
        if edge_cost_floor is not None:
            floor_t = np.asarray(edge_cost_floor, dtype=float)
            shape = (grid.n_nodes, neighbourhood.offsets.shape[0])
            if floor_t.shape != shape or not np.all(np.isfinite(floor_t) & (floor_t >= 0.0)):
                raise ConfigError(f"edge_cost_floor must hold one finite bound >= 0 per grid node and offset {shape}; "
                                  f"got shape {floor_t.shape}; pass CostBound.edge_t of "
                                  "optroute.search.cost_bound.cost_to_go, or None")  # fmt: skip
            search.edge_floor = np.ascontiguousarray(floor_t.ravel())
    elif edge_cost_floor is not None:
        raise ConfigError(
            "edge_cost_floor is a bound of the cost objectives' A* beside cost_to_go; pass cost_to_go "
            "with it (method='astar', objective 'cost' or 'fuel'), or neither"
        )
    return search.run(eta_h)


def dijkstra(grid: RouteGrid, neighbourhood: Neighbourhood, **kwargs: object) -> SearchResult:
    """:func:`shortest_path` with ``method="dijkstra"``."""
    return shortest_path(grid, neighbourhood, method="dijkstra", **kwargs)  # type: ignore[arg-type]


def astar(grid: RouteGrid, neighbourhood: Neighbourhood, **kwargs: object) -> SearchResult:
    """:func:`shortest_path` with ``method="astar"``."""
    return shortest_path(grid, neighbourhood, method="astar", **kwargs)  # type: ignore[arg-type]


class _Search:
    def __init__(
        self,
        grid: RouteGrid,
        nb: Neighbourhood,
        ev: LegEvaluator,
        vmax: float,
        method: str,
        objective: str,
        lam: float,
        batched: bool,
        engine: str,
        weight: float,
    ) -> None:
        self.grid, self.nb, self.ev = grid, nb, ev
        self.vmax, self.method, self.objective, self.lam = vmax, method, objective, lam
        self.h_bound: np.ndarray | None = None  # a static lower bound on the cost to the end (cost_to_go)
        self.edge_floor = np.zeros(0)  # a lower bound on each edge's cost, flat by (tail, offset); none: empty
        self.batched = batched
        self.f_slack = 0.5
        self.time_obj = objective == "time"
        n = grid.n_nodes
        ny, nx = grid.shape
        r = nb.radius_cells
        # static edge test on demand: destination on the grid and every crossed cell navigable
        self.ii, self.jj = (a.astype(np.int64) for a in grid.unflat(np.arange(n)))
        self.di = nb.offsets[:, 0].astype(np.int64)
        self.dj = nb.offsets[:, 1].astype(np.int64)
        self.off = self.di * nx + self.dj
        nxp = nx + 2 * r
        pad = np.zeros((ny + 2 * r, nxp), dtype=bool)
        pad[r : r + ny, r : r + nx] = grid.navigable
        self.nav_pad = pad.ravel()
        self.pad_shape = pad.shape
        self.land = no_land_arrays(self.nav_pad.size)  # (coastal cells padded, packed rows, blocks, parameters)
        self.all_navigable = bool(grid.navigable.all())
        self.base_pad = (self.ii + r) * nxp + (self.jj + r)
        walks = [segment_cells(int(a), int(b))[0] for a, b in nb.offsets]
        kmax = max(len(w) for w in walks)
        self.cell_off = np.zeros((nb.m, kmax), dtype=np.int64)  # padded with the start cell (navigable)
        for o, w in enumerate(walks):
            self.cell_off[o, : len(w)] = w[:, 0] * nxp + w[:, 1]
        self.cell_n = np.array([len(w) for w in walks], dtype=np.int64)
        self.compiled = engine == "numba"
        self.touched = np.zeros(n, dtype=np.int64) if self.compiled else None
        self.batches_relaxed = 0
        self.label = np.full(n, np.inf)
        self.tarr = np.full(n, np.nan)
        self.fuel = np.zeros(n)
        self.parent = np.full(n, -1, dtype=np.int64)
        self.poff = np.full(n, -1, dtype=np.int64)
        self.state = np.zeros(n, dtype=np.int8)  # 0 unseen, 1 open, 2 settled
        self.s = int(grid.flat(*grid.start))
        self.g = int(grid.flat(*grid.end))
        self.expanded = 0
        self.evaluated = 0
        self.batches = 0
        self.weight = weight  # weight / v_max: a lower bound on the objective per nm of any leg [h/nm or t/nm]
        self.t_limit = np.inf  # see shortest_path's time_limit_h (plus the slack)
        self.t_goal = np.zeros(n)  # a lower bound on the time from each node to the goal [h] (set by run)
        self.inv_v = (1.0 - _SPEED_TOL) / vmax  # a lower bound on the hours per nm of any costed leg
        self.ceiling = np.inf  # see shortest_path's cost_ceiling: the goal's label before any route reaches it

    # ------------------------------------------------------------ relax
    def _edges_ok(self, batch: np.ndarray) -> np.ndarray:
        i = self.ii[batch, None] + self.di[None, :]
        j = self.jj[batch, None] + self.dj[None, :]
        ny, nx = self.grid.shape
        ok = (i >= 0) & (i < ny) & (j >= 0) & (j < nx)
        if not self.all_navigable:
            cells = self.base_pad[batch, None, None] + self.cell_off[None, :, :]
            ok &= self.nav_pad[cells].all(axis=2)
        return ok

    def _check_speed(self, dist: np.ndarray, dur: np.ndarray, feas: np.ndarray, fu: np.ndarray) -> None:
        fast = feas & (dur * self.vmax < dist * (1.0 - _SPEED_TOL))
        if fast.any():
            k = int(np.argmax(fast))
            self._too_fast(dist[k], dur[k])
        if not self.time_obj:
            cost = fu + self.lam * dur
            cheap = feas & (cost < self.weight / self.vmax * dist * (1.0 - _SPEED_TOL))
            if cheap.any():
                k = int(np.argmax(cheap))
                self._too_cheap(dist[k], cost[k])

    def _too_fast(self, dist: float, dur: float) -> None:
        raise ConfigError(
            f"the cost callback sailed a {dist:.1f} nm leg in {dur:.4g} h, i.e. at "
            f"{dist / dur:.2f} kn > v_max_kn={self.vmax}; raise v_max_kn to a true upper bound "
            "on the speed over ground (it keeps the search exact)"
        )

    def _too_cheap(self, dist: float, cost: float) -> None:
        raise ConfigError(
            f"the cost callback costed a {dist:.1f} nm leg at {cost:.6g} t, {cost / dist:.6g} t/nm, below the "
            f"cost floor {self.weight / self.vmax:.6g} t/nm; pass a true lower bound as cost_floor_per_nm (or none)"
        )

    def _below_bound(self, dist: float, cost: float, drop: float) -> None:
        raise ConfigError(
            f"the cost callback costed a {dist:.1f} nm leg at {cost:.6g} t, below the {drop:.6g} t the cost_to_go "
            "bound drops along it: the bound is not consistent with the costs; pass cost_to_go=None"
        )

    def _below_floor(self, dist: float, cost: float, floor_t: float) -> None:
        raise ConfigError(
            f"the cost callback costed a {dist:.1f} nm leg at {cost:.6g} t, below its edge_cost_floor {floor_t:.6g} t: "
            "the floor is not a lower bound of the costs; pass edge_cost_floor=None"
        )

    def _candidates(self, batch: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Edges out of ``batch`` that exist and could still improve a label: (u, v, offset, length [nm])."""
        if self.compiled:
            ny, nx = self.grid.shape
            return self._off_land(*_kernels.candidates(
                batch, self.ii, self.jj, self.di, self.dj, self.off, ny, nx, self.nav_pad, self.base_pad,
                self.cell_off, self.cell_n, self.all_navigable, self.state, self.label, self.h,
                float(self.label[self.g]), self.ev.xyz, self.weight / self.vmax, _TWO_R_FLOOR_NM, self.tarr,
                self.t_goal, self.t_limit, self.inv_v,
            ))  # fmt: skip
        nbr = batch[:, None] + self.off[None, :]
        ok = self._edges_ok(batch)
        ok &= self.state[np.where(ok, nbr, 0)] != 2
        bi, o = np.nonzero(ok)
        u = batch[bi]
        v = nbr[bi, o]
        # exact pruning before the callback: an edge that cannot beat v's label, or the goal's, even
        # sailed at v_max_kn, is not costed
        dist = self.ev.distance_nm(u, v)
        lb = self.label[u] + self.weight / self.vmax * dist
        useful = (lb < self.label[v]) & (lb + self.h[v] < self.label[self.g])
        useful &= ~(self.tarr[u] + self.inv_v * dist + self.t_goal[v] > self.t_limit)
        useful = np.nonzero(useful)[0]
        if useful.size < u.size:
            u, v, o, dist = u[useful], v[useful], o[useful], dist[useful]
        return self._off_land(u, v, o, dist)

    def _off_land(self, u: np.ndarray, v: np.ndarray, o: np.ndarray, dist: np.ndarray) -> tuple[np.ndarray, ...]:
        """The edges that do not touch land where they cross a coastal cell (:mod:`optroute.search.edge_land`;
        the compiled loop tests each edge when it is due instead, with the same function)."""
        if self.land[-1][0] <= 0.0 or u.size == 0:
            return u, v, o, dist
        wet = ~edges_on_land(u, v, o, self.ev.xyz, self.base_pad, self.cell_off, self.cell_n, *self.land)
        return u[wet], v[wet], o[wet], dist[wet]

    def _relax(self, batch: np.ndarray) -> np.ndarray:
        """Cost the edges out of settled ``batch``; return the nodes opened for the first time."""
        u, v, o, dist = self._candidates(batch)
        if u.size == 0:
            return _EMPTY
        t0 = self.tarr[u]
        dur, fu, feas, _ = self.ev.evaluate(u, v, o, t0)
        self.evaluated += u.size
        self._check_speed(dist, dur, feas, fu)
        cost = dur if self.time_obj else fu + self.lam * dur
        new = self.label[u] + cost
        if self.h_bound is not None:  # (cost objectives only)
            below = feas & (self.h[u] - self.h[v] > cost * (1.0 + _SPEED_TOL) + 1e-9 * self.h[u])
            if below.any():
                k = int(np.argmax(below))
                self._below_bound(dist[k], cost[k], self.h[u[k]] - self.h[v[k]])
            if self.edge_floor.size:
                floor_t = self.edge_floor[u * self.di.size + o]
                below = feas & (floor_t > cost * (1.0 + _SPEED_TOL) + 1e-12)
                if below.any():
                    k = int(np.argmax(below))
                    self._below_floor(dist[k], cost[k], floor_t[k])
        if self.compiled:
            self.batches_relaxed += 1
            return _kernels.apply(
                u, v, o, new, t0 + dur, fu, feas, self.label, self.tarr, self.fuel, self.parent, self.poff,
                self.state, self.touched, self.batches_relaxed,
            )  # fmt: skip
        keep = np.nonzero(feas & (new < self.label[v]))[0]
        if keep.size == 0:
            return _EMPTY
        t1 = t0[keep] + dur[keep]
        new, vk = new[keep], v[keep]
        order = np.lexsort((t1, new, vk))
        vs = vk[order]
        first = np.ones(vs.size, dtype=bool)
        first[1:] = vs[1:] != vs[:-1]
        sel = order[first]
        w = keep[sel]
        v = vs[first]
        opened = v[self.state[v] == 0]
        self.label[v] = new[sel]
        self.tarr[v] = t1[sel]
        self.fuel[v] = self.fuel[u[w]] + fu[w]
        self.parent[v] = u[w]
        self.poff[v] = o[w]
        self.state[v] = 1
        return opened

    # -------------------------------------------------------------- run
    def run(self, eta_h: float | None) -> SearchResult:
        grid = self.grid
        for name, node, pos in (("start", grid.start, grid.start_latlon), ("end", grid.end, grid.end_latlon)):
            if not grid.navigable[node]:
                raise NoSafePassage(
                    f"the {name} ({pos[0]:.4f}, {pos[1]:.4f}) lies in a non-navigable grid cell {node}; "
                    "move it to open water or check the navigable mask"
                )
        n = grid.n_nodes
        self.h = np.zeros(n)
        if self.method == "astar" or np.isfinite(self.t_limit):
            d_goal = self.ev.distance_nm(np.arange(n), np.full(n, self.g))
            if np.isfinite(self.t_limit):
                self.t_goal = _HEURISTIC_SHRINK * d_goal / self.vmax
                self._check_reachable()
            if self.method == "astar":
                self.h = self.weight * _HEURISTIC_SHRINK * d_goal / self.vmax
                if self.h_bound is not None:
                    self.h = np.maximum(self.h, self.h_bound)
        self.label[self.s] = 0.0
        if self.g != self.s:
            self.label[self.g] = self.ceiling
        self.tarr[self.s] = 0.0
        self.state[self.s] = 1
        self._loop()
        if self.state[self.g] != 2:
            self._fail()
        res = self._result()
        if eta_h is not None and res.arrival_h > float(eta_h):
            exc = InfeasibleETA(
                f"the required arrival {float(eta_h):.2f} h after departure cannot be met: the earliest "
                f"arrival found is {res.arrival_h:.2f} h after departure; allow a later ETA",
                earliest_arrival=res.arrival_h,
            )
            exc.earliest_arrival_h = res.arrival_h  # type: ignore[attr-defined]
            raise exc
        return res

    def _check_reachable(self) -> None:
        """Raise at once if the great circle at ``v_max`` cannot reach the goal by the time limit."""
        need = float(self.t_goal[self.s])
        if need > self.t_limit:
            limit = self.t_limit - TIME_LIMIT_SLACK_H
            raise WeatherCoverageError(
                f"the end cannot be reached inside the weather: it ends {limit:.2f} h after departure, but even the "
                f"great circle ({need * self.vmax:.0f} nm) at v_max_kn={self.vmax:.2f} arrives {need:.2f} h after "
                "departure; give a forecast reaching past that arrival (or time_policy='hold'), or an earlier departure"
            )

    def _loop(self) -> None:
        """Settle nodes in batches that provably cannot be improved any more.

        With a consistent heuristic h (h = 0 for Dijkstra) and δ_w a lower
        bound on the cost of every edge out of w (:func:`_edge_length_floor_nm`
        over ``v_max_kn``), a path to open node y through another open node w
        costs at least ``g(w) + δ_w`` and at least ``f(w) - h(y)``.  So y is
        final when every open w with ``f(w) < f(y)`` has ``g(w) + δ_w >= g(y)``:
        with the open set sorted by f, ``g(y) <= min(g + δ over the nodes before
        y)``.  For Dijkstra this is ``g(y) <= min over the open set of (g + δ)``.
        The node of least f is always final; settling all final nodes at once
        stays exact because a path through one of them obeys the same two
        bounds.  A* settles only nodes within ``δ`` of the least f, so that it
        does not expand nodes that textbook A* would never reach.
        """
        kernel = getattr(self.ev.segment_cost, "leg_kernel", None)
        if self.compiled and kernel is not None:
            self._run_compiled(kernel)
            return
        h = self.h
        # δ_w: a lower bound on the cost of any edge out of w (time at v_max; λ·time for "cost")
        delta = _edge_length_floor_nm(self.grid) / self.vmax * (1.0 - 1e-9) * self.weight
        open_nodes = np.array([self.s], dtype=np.int64)
        mode = 0 if not self.batched else (1 if self.method == "dijkstra" else 2)
        while open_nodes.size:
            if self.compiled:
                batch, open_nodes = _kernels.select(open_nodes, self.label, h, delta, self.f_slack, mode)
                self.state[batch] = 2
                self.expanded += batch.size
                self.batches += 1
                if self.state[self.g] == 2:
                    return
                opened = self._relax(batch)
                if opened.size:
                    open_nodes = np.concatenate([open_nodes, opened])
                continue
            g = self.label[open_nodes]
            if not self.batched:
                f = g + h[open_nodes]
                sel = np.zeros(open_nodes.size, dtype=bool)
                sel[int(np.argmin(f))] = True
            elif self.method == "dijkstra":
                sel = g <= (g + delta[open_nodes]).min()
                if not sel.any():  # δ = 0 (fuel objective): the least label only
                    sel = g <= g.min()
            else:
                f = g + h[open_nodes]
                k0 = int(np.argmin(f))
                cand = np.nonzero(f <= f[k0] + self.f_slack * delta[open_nodes[k0]])[0]
                order = cand[np.argsort(f[cand], kind="stable")]
                gs = g[order]
                reach = gs + delta[open_nodes[order]]
                prior = np.empty_like(gs)
                prior[0] = np.inf
                np.minimum.accumulate(reach[:-1], out=prior[1:])
                final = gs <= prior
                final[0] = True
                sel = np.zeros(open_nodes.size, dtype=bool)
                sel[order[final]] = True
            batch = open_nodes[sel]
            open_nodes = open_nodes[~sel]
            self.state[batch] = 2
            self.expanded += batch.size
            self.batches += 1
            if self.state[self.g] == 2:
                return
            opened = self._relax(batch)
            if opened.size:
                open_nodes = np.concatenate([open_nodes, opened])

    def _run_compiled(self, kernel: LegKernel) -> None:
        """The search compiled whole with the leg costing (:func:`compiled_search.run`): :meth:`_loop`'s labels,
        each edge costed only when it is due (lazily, one node settled a step)."""
        ev, (ny, nx) = self.ev, self.grid.shape
        graph = (self.ii, self.jj, self.di, self.dj, self.off, ny, nx, self.nav_pad, self.base_pad, self.cell_off,
                 self.cell_n, self.all_navigable, ev.xyz, ev.tangent, ev.piece_f0, ev.piece_f1,
                 ev.piece_n.astype(np.int64), *self.land)  # fmt: skip
        search = (self.s, self.g, self.h, self.weight / self.vmax, _TWO_R_FLOOR_NM, self.time_obj, self.lam,
                  self.vmax, _SPEED_TOL, self.t_goal, self.t_limit, self.inv_v, self.edge_floor)  # fmt: skip
        k = (kernel.params, kernel.weather, kernel.mode, kernel.check_nm, kernel.speeds, kernel.lam,
             kernel.desired, kernel.step, kernel.vmin)  # fmt: skip
        counts, bad = compiled_search.run(graph, search, k, self.label, self.tarr, self.fuel, self.parent,
                                          self.poff, self.state)  # fmt: skip
        self.expanded += int(counts[0])
        self.evaluated += int(counts[1])
        self.batches += int(counts[2])
        ev.calls += 1
        kernel.on_uncovered(int(counts[3]))
        if counts[4] == compiled_search.ERR_TOO_FAST:
            self._too_fast(float(bad[0]), float(bad[1]))
        if counts[4] == compiled_search.ERR_TOO_CHEAP:
            self._too_cheap(float(bad[0]), float(bad[2]))
        if counts[4] == compiled_search.ERR_BELOW_BOUND:
            self._below_bound(float(bad[0]), float(bad[2]), float(bad[1]))
        if counts[4] == compiled_search.ERR_BELOW_FLOOR:
            self._below_floor(float(bad[0]), float(bad[2]), float(bad[1]))

    # ---------------------------------------------------------- output
    def _fail(self) -> None:
        grid = self.grid
        reached = np.nonzero(np.isfinite(self.label) & (self.state > 0))[0]
        d = self.ev.distance_nm(reached, np.full(reached.size, self.g))
        cheaper = "" if np.isinf(self.ceiling) else f" cheaper than the cost ceiling {self.ceiling:.6g}"

        k = int(reached[int(np.argmin(d))])
        i, j = (int(v) for v in grid.unflat(k))
        raise NoSafePassage(
            f"no feasible route{cheaper} from ({grid.start_latlon[0]:.4f}, {grid.start_latlon[1]:.4f}) to "
            f"({grid.end_latlon[0]:.4f}, {grid.end_latlon[1]:.4f}): the search reached {reached.size} of "
            f"{grid.n_nodes} nodes and stopped at node ({i}, {j}) = ({grid.lat_deg[i, j]:.3f}, "
            f"{grid.lon_deg[i, j]:.3f}), {float(d.min()):.1f} nm from the end; widen the grid "
            "(margin_nm), check the navigable mask, or the conditions that make legs infeasible"
        )

    def _result(self) -> SearchResult:
        grid, ev = self.grid, self.ev
        path = [self.g]
        while path[-1] != self.s:
            path.append(int(self.parent[path[-1]]))
        path = np.array(path[::-1], dtype=np.int64)
        u, v = path[:-1], path[1:]
        o = self.poff[v]
        times = self.tarr[path]
        fuel_cum = self.fuel[path]
        _, _, _, extra = ev.evaluate(u, v, o, times[:-1], detail=True)
        dist = ev.distance_nm(u, v)
        dur = np.diff(times)
        i, j = grid.unflat(path)
        return SearchResult(
            nodes=np.stack([i, j], axis=1),
            lat_deg=ev.lat[path].copy(),
            lon_deg=ev.lon[path].copy(),
            times_h=times,
            leg_duration_h=dur,
            leg_fuel_t=np.diff(fuel_cum),
            leg_distance_nm=dist,
            leg_course_deg=course_between_deg(ev.xyz[u], ev.xyz[v]),
            leg_sog_kn=dist / dur,
            extra=extra,
            cost=float(self.label[self.g]),
            arrival_h=float(times[-1]),
            total_fuel_t=float(fuel_cum[-1]),
            objective=self.objective,
            method=self.method,
            neighbourhood=self.nb.name,
            lambda_t_per_h=self.lam,
            expanded=self.expanded,
            evaluated_edges=self.evaluated,
            callback_calls=ev.calls,
            batches=self.batches,
        )


__all__ = [
    "SearchResult",
    "astar",
    "dijkstra",
    "edge_mask",
    "grid_edges",
    "shortest_path",
]
