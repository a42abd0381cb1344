"""Fixed-path speed profile as a convex programme (CVXPY + Clarabel): the global optimum.

On a fixed path with static weather per leg and every band side fixed, the
only decisions are the leg times ``t_i`` [h]. The fuel of a leg is the
perspective ``t · r(d/t)`` of a convex fuel-rate curve ``r`` (see
:class:`formulations.common.PowerLawFuel`), hence convex in ``t``
(Norstad, Fagerholt & Laporte 2011; Hvattum, Norstad, Fagerholt & Laporte
2013), and the problem

    minimise    Σ_i F_i(t_i)  [+ hourly_cost · Σ_i t_i]        (objective "fuel" / "cost")
    subject to  Σ_i t_i ≤ T_eta   (or = T_eta)
                d_i / v_max_i ≤ t_i ≤ d_i / v_min_i

is convex: its Clarabel solution is the global optimum and certifies the
local NLP of :mod:`formulations.speed_nlp` on the same instance. The speed
bounds carry everything that limits a leg's speed on a fixed path: the MCR,
the minimum engine load, the maximum speed and the chosen side of every
danger band (a band side is a speed bound on that leg, see
:mod:`formulations.disjunctive`).

Two equivalent conic models are offered (physics.md §9):

* ``"powcone"``: each term ``a d^p t^(1-p)`` is an epigraph variable in
  Clarabel's 3-D power cone, ``cp.constraints.PowCone3D(s, τ, 1, 1/p)``
  (``s τ^(p-1) ≥ 1``, for the cubic law ``s τ² ≥ 1``), or
  ``PowCone3D(s, 1, τ, 1/(1-p))`` for ``p < 0``;
* ``"power"``: ``cp.power(τ, 1 - p)``, which CVXPY compiles to second-order
  cones for rational exponents.

Both use the scaled time ``τ_i = t_i v_ref / d_i`` (≈ 1) so that the cone
variables are of order one; the results are reported in hours.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Literal

import cvxpy as cp
import numpy as np
from numpy.typing import ArrayLike

from formulations.common import FormulationInputError, PowerLawFuel, as_float_array, broadcast_legs

__all__ = ["ConvexSpeedResult", "solve_speed_convex"]

Objective = Literal["fuel", "cost", "time"]

#: Default Clarabel tolerances: tighter than Clarabel's own (1e-8) so that the
#: leg times, not only the objective, agree with an analytic optimum to ~1e-6.
_CLARABEL_DEFAULTS: dict[str, float] = {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10}
#: Clarabel's iterative refinement of its KKT solves, tightened (its defaults: 1e-13 relative, 1e-12 absolute): the
#: retry of a solve that stopped at ``AlmostSolved`` (hypothesis found 3 of 1 200 random cube-law problems that did).
_CLARABEL_REFINED: dict[str, float] = {"iterative_refinement_reltol": 1e-14, "iterative_refinement_abstol": 1e-14}


@dataclass(frozen=True)
class ConvexSpeedResult:
    """Solution of :func:`solve_speed_convex`.

    Attributes
    ----------
    status : str
        CVXPY's status, verbatim (``"optimal"``, ``"infeasible"``, ``"optimal_inaccurate"``...).
    solver_status : str
        Clarabel's own status, verbatim (``"Solved"``, ``"PrimalInfeasible"``...).
    time_h : numpy.ndarray, shape (n,)
        Leg durations [h] (NaN when no solution).
    speed_kn : numpy.ndarray, shape (n,)
        Leg speeds ``d / t`` [kn].
    fuel_t : numpy.ndarray, shape (n,)
        Leg fuel [t], re-evaluated from the fuel model at ``time_h`` (not read from the cone variables).
    total_fuel_t : float
        ``Σ fuel_t`` [t].
    duration_h : float
        ``Σ time_h`` [h].
    objective : float
        The optimal objective as CVXPY reports it (fuel [t], cost [currency] or time [h]).
    eta_multiplier : float
        The ETA constraint's dual, ``-d(objective*)/d(T_eta)``: for ``"fuel"`` the fuel
        saved by one more hour of passage [t/h] (≥ 0 for ``eta_mode="le"``); 0 when no ETA;
        NaN when not solved.
    time_lower_dual, time_upper_dual : numpy.ndarray, shape (n,)
        Duals of ``t_i ≥ d_i/v_max_i`` and ``t_i ≤ d_i/v_min_i`` [objective units per hour of
        the bound]; positive where the bound binds (used to rank band flips).
    iterations : int
        Clarabel iterations.
    solve_time_s : float
        Wall-clock time of model build, compilation and solve [s].
    formulation : str
        ``"powcone"`` or ``"power"``.
    """

    status: str
    solver_status: str
    time_h: np.ndarray
    speed_kn: np.ndarray
    fuel_t: np.ndarray
    total_fuel_t: float
    duration_h: float
    objective: float
    eta_multiplier: float
    time_lower_dual: np.ndarray
    time_upper_dual: np.ndarray
    iterations: int
    solve_time_s: float
    formulation: str

    @property
    def success(self) -> bool:
        """True when CVXPY reports ``"optimal"``."""
        return self.status == cp.OPTIMAL


def _dual(con: cp.Constraint | None, n: int | None = None) -> np.ndarray | float:
    if con is None or con.dual_value is None:
        return np.zeros(n) if n is not None else 0.0
    val = np.asarray(con.dual_value, dtype=float)
    return val.reshape(n) if n is not None else float(val.reshape(-1)[0])


def solve_speed_convex(
    distance_nm: ArrayLike,
    fuel: PowerLawFuel,
    *,
    eta_h: float | None = None,
    eta_mode: Literal["le", "eq"] = "le",
    v_min_kn: ArrayLike = 0.0,
    v_max_kn: ArrayLike = np.inf,
    objective: Objective = "fuel",
    fuel_price: float = 1.0,
    hourly_cost: float = 0.0,
    formulation: Literal["powcone", "power"] = "powcone",
    solver_options: dict[str, float] | None = None,
) -> ConvexSpeedResult:
    """Solve the fixed-path speed profile to global optimality.

    Parameters
    ----------
    distance_nm : array_like, shape (n,)
        Leg lengths ``d_i`` [nm], > 0.
    fuel : PowerLawFuel
        Per-leg fuel-rate curve ``r_i(v)`` [t/h] with ``v`` in [kn]; convex by construction.
    eta_h : float, optional
        Passage time allowed [h] (ETA − departure). ``None``: no ETA constraint.
    eta_mode : {"le", "eq"}
        ``Σ t ≤ T_eta`` (arrive no later) or ``Σ t = T_eta`` (arrive exactly).
    v_min_kn, v_max_kn : float or array_like, shape (n,)
        Speed bounds per leg [kn]; ``v_min = 0`` means no upper bound on the leg time.
        They carry MCR, minimum load, maximum speed and band sides.
    objective : {"fuel", "cost", "time"}
        ``"fuel"``: Σ F_i [t]; ``"cost"``: ``fuel_price · Σ F_i + hourly_cost · Σ t_i``;
        ``"time"``: Σ t_i [h] (every leg at its maximum speed).
    fuel_price : float
        Price per tonne of fuel [currency/t] (``"cost"`` only).
    hourly_cost : float
        Time-charter or running cost [currency/h] (``"cost"`` only).
    formulation : {"powcone", "power"}
        Explicit Clarabel power cones, or CVXPY's ``cp.power`` atom.
    solver_options : dict, optional
        Clarabel settings overriding the defaults (tolerances 1e-10; when Clarabel stops at
        ``AlmostSolved`` with them, the solve is repeated with Clarabel's own defaults).

    Returns
    -------
    ConvexSpeedResult
        With CVXPY's and Clarabel's statuses verbatim; arrays are NaN when not solved.

    Raises
    ------
    FormulationInputError
        On a non-positive distance, NaN input, ``v_max ≤ 0`` or an unknown option.
    """
    d, vmin, vmax = _checked_inputs(distance_nm, v_min_kn, v_max_kn, eta_h, eta_mode, objective, formulation)
    n = d.size
    coef = fuel.for_legs(n)
    p = fuel.exponent

    started = time.perf_counter()
    # Scaling: τ_i = t_i · v_ref / d_i is about 1 at the optimum.
    if eta_h is not None:
        v_ref = float(d.sum() / eta_h)
    else:
        finite = np.concatenate([vmax[np.isfinite(vmax)], vmin[vmin > 0]])
        v_ref = float(np.mean(finite)) if finite.size else 10.0
    scale = d / v_ref  # hours per unit of τ
    tau = cp.Variable(n, name="tau")
    fuel_expr, cones = _fuel_expression(tau, coef * (d * 1.0)[:, None], p, v_ref, formulation)
    total_time = scale @ tau
    if objective == "fuel":
        obj = fuel_expr
    elif objective == "cost":
        obj = fuel_price * fuel_expr + hourly_cost * total_time
    else:
        obj = total_time

    lo = v_ref / vmax  # τ bounds; v_max = inf gives 0
    lower = tau >= lo
    constraints: list[cp.Constraint] = [lower, *cones]
    upper = None
    has_upper = vmin > 0.0
    if has_upper.any():
        idx = np.flatnonzero(has_upper)
        upper = tau[idx] <= v_ref / vmin[idx]
        constraints.append(upper)
    eta_con = None
    if eta_h is not None:
        eta_con = total_time <= eta_h if eta_mode == "le" else total_time == eta_h
        constraints.append(eta_con)
    problem = cp.Problem(cp.Minimize(obj), constraints)
    raw = _solve_clarabel(problem, solver_options)
    elapsed = time.perf_counter() - started

    status = str(problem.status)
    solver_status = str(raw.status)
    common = {"status": status, "solver_status": solver_status, "iterations": int(raw.iterations),
              "solve_time_s": elapsed, "formulation": formulation}  # fmt: skip
    if tau.value is None or status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        nan = np.full(n, np.nan)
        value = float("nan") if problem.value is None else float(problem.value)
        return ConvexSpeedResult(time_h=nan, speed_kn=nan, fuel_t=nan, total_fuel_t=float("nan"),
                                 duration_h=float("nan"), objective=value, eta_multiplier=float("nan"),
                                 time_lower_dual=nan, time_upper_dual=nan, **common)  # fmt: skip
    t = np.asarray(tau.value, dtype=float) * scale
    leg_fuel = PowerLawFuel(coef, p).leg_fuel(d, t)
    # Duals are per unit of τ; per hour of the leg's time bound they are divided by dt/dτ = scale.
    lo_dual = np.asarray(_dual(lower, n)) / scale
    up_dual = np.zeros(n)
    if upper is not None:
        up_dual[has_upper] = np.asarray(_dual(upper, int(has_upper.sum()))) / scale[has_upper]
    return ConvexSpeedResult(
        time_h=t,
        speed_kn=d / t,
        fuel_t=leg_fuel,
        total_fuel_t=float(leg_fuel.sum()),
        duration_h=float(t.sum()),
        objective=float(problem.value),
        eta_multiplier=float(_dual(eta_con)) if eta_con is not None else 0.0,
        time_lower_dual=lo_dual,
        time_upper_dual=up_dual,
        **common,
    )


def _checked_inputs(
    distance_nm: ArrayLike, v_min_kn: ArrayLike, v_max_kn: ArrayLike, eta_h: float | None, eta_mode: str,
    objective: str, formulation: str,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """:func:`solve_speed_convex`'s legs and options checked: (distances [nm], v_min [kn], v_max [kn]) per leg."""
    d = as_float_array(distance_nm, "distance_nm", ndim=1)
    n = d.size
    if n == 0 or (d <= 0.0).any():
        raise FormulationInputError(f"distance_nm must be non-empty and positive, got {d}")
    vmin = broadcast_legs(v_min_kn, n, "v_min_kn")
    vmax = broadcast_legs(v_max_kn, n, "v_max_kn", finite=False)
    if (vmin < 0.0).any() or (vmax <= 0.0).any():
        raise FormulationInputError(f"speed bounds must satisfy 0 <= v_min and v_max > 0, got {vmin}, {vmax}")
    if objective not in ("fuel", "cost", "time"):
        raise FormulationInputError(f"objective must be 'fuel', 'cost' or 'time', got {objective!r}")
    if eta_mode not in ("le", "eq"):
        raise FormulationInputError(f"eta_mode must be 'le' or 'eq', got {eta_mode!r}")
    if formulation not in ("powcone", "power"):
        raise FormulationInputError(f"formulation must be 'powcone' or 'power', got {formulation!r}")
    if eta_h is not None and not (np.isfinite(eta_h) and eta_h > 0):
        raise FormulationInputError(f"eta_h must be a positive finite number of hours, got {eta_h}")
    return d, vmin, vmax


def _fuel_expression(
    tau: cp.Variable, coef_d: np.ndarray, p: np.ndarray, v_ref: float, formulation: str
) -> tuple[cp.Expression, list[cp.Constraint]]:
    """Σ_i F_i as a CVXPY expression of the scaled leg times ``tau`` and the power cones it needs.

    ``coef_d`` (n, terms) are the rate coefficients times each leg's length [nm], ``p`` the terms' speed exponents:
    ``F_ij = w_ij τ_i^(1 - p_j)`` with ``w_ij = c_ij d_i v_ref^(p_j - 1)``; ``formulation`` "powcone" writes each
    ``τ^(1-p)`` as a 3-D power cone (Clarabel's own), "power" through CVXPY's ``cp.power`` atom.
    """
    n = coef_d.shape[0]
    fuel_terms: list[cp.Expression] = []
    constant = 0.0
    cones: list[cp.Constraint] = []
    for j, pj in enumerate(p):
        w = coef_d[:, j] * v_ref ** (pj - 1.0)  # F_ij = w_ij τ_i^(1 - p_j)
        if not np.any(w > 0.0):
            continue
        if pj == 1.0:
            constant += float(w.sum())
        elif pj == 0.0:
            fuel_terms.append(w @ tau)
        elif formulation == "power":
            fuel_terms.append(w @ cp.power(tau, 1.0 - pj))
        else:
            s = cp.Variable(n, name=f"s{j}")
            if pj > 1.0:  # s^(1/p) τ^(1 - 1/p) ≥ 1  ⇔  s ≥ τ^(1-p)
                cones.append(cp.constraints.PowCone3D(s, tau, np.ones(n), np.full(n, 1.0 / pj)))
            else:  # p < 0, q = 1 - p > 1: s^(1/q) · 1 ≥ |τ|  ⇔  s ≥ τ^q
                q = 1.0 - pj
                cones.append(cp.constraints.PowCone3D(s, np.ones(n), tau, np.full(n, 1.0 / q)))
            fuel_terms.append(w @ s)
    fuel_expr = cp.sum(cp.hstack(fuel_terms)) + constant if fuel_terms else cp.Constant(constant)
    return fuel_expr, cones


def _solve_clarabel(problem: cp.Problem, solver_options: dict[str, float] | None):
    """Clarabel's raw result of ``problem`` (unpacked into it) with :data:`_CLARABEL_DEFAULTS` and the caller's
    options; where it stops at ``AlmostSolved`` with the default tight tolerances, solved again with its linear
    systems refined further (:data:`_CLARABEL_REFINED`), then with Clarabel's own tolerances."""
    opts = dict(_CLARABEL_DEFAULTS)
    opts.update(solver_options or {})
    data, chain, inverse = problem.get_problem_data(cp.CLARABEL, solver_opts=opts)
    raw = chain.solve_via_data(problem, data, False, False, opts)
    if solver_options is None:
        # the tight tolerances not reached: first with the linear systems refined further (the usual cause: the
        # KKT solves' residual above the tolerances near the optimum), then with Clarabel's own defaults (1e-8)
        for retry in (dict(opts, **_CLARABEL_REFINED), {}):
            if str(raw.status) != "AlmostSolved":
                break
            raw = chain.solve_via_data(problem, data, False, False, retry)
    problem.unpack_results(raw, chain, inverse)
    return raw
