"""One speed-and-offset schedule over the members of an ensemble: the corridor NLP stacked per member.

The members ``m = 1..M`` of an ensemble are ``M`` weather grids (:class:`formulations.weather_grid.WeatherGrid`, each
with the ship's power table tabulated in that member's sea) on the same corridor and the same (t, s, y) grid. The
decision is one plan — the lateral offsets ``y_k`` and the speeds through water ``V_k`` of
:mod:`formulations.speed_nlp` — and, because the speed over ground depends on each member's current, one
arrival-time vector ``t^m`` per member. Every row of :class:`formulations.speed_nlp.SpeedNLP` (time dynamics,
engine load, danger bands with their sides, drift and SOG, moving exclusion) is imposed in every member, with that
member's weather, and the ETA bounds every member's arrival ``t^m_N``.

**One member function, mapped, for the values; the single-weather derivatives, per member.** The model of one
member is one CasADi function of the plan, that member's times, band edges and the member's index, which selects
its weather through one ``Function.conditional`` node; ``Function.map`` applies it to the M members. It gives the
values (objective, rows, diagnostics); each member's weather is read in numpy
(:class:`formulations._nlp_model.WeatherValues`, the grid's :meth:`WeatherGrid.tensor_spline`), so no member needs
a CasADi spline. The derivatives Ipopt asks for are not CasADi's of that graph: they are the single-weather NLP's
exact leg-by-leg derivative cores (:func:`formulations._nlp_model.structured_cores`, built once from the template
:class:`SpeedNLP`), evaluated per member at its variables ``(y, V, t^m)`` with its own weather's Taylor data and
scattered into the stacked gradient, Jacobian and Hessian (:meth:`RobustSpeedNLP._member_derivatives`). Measured on
``benchmarks.bench_robust``'s 18-leg, 44-field storm case at two members, same machine, same run: the build fell
from 2.6 to 0.4 CPU-s (the previous stated-derivative splines: six CasADi B-splines per member) and the band loop's
Ipopt from 4.5 to 0.8 CPU-s (CasADi's Hessian through the members' derivative callbacks took 0.21 s a call), same
optimum to 1e-12 relative. The exact Hessian of the Lagrangian is used by default: with Ipopt's limited-memory
approximation the stacked problem needed about ten times the iterations (135 against 18 at two members, the same
optimum). The members must carry the same fields and power-table axes (an ensemble's members do).

With ``J_m = w_f · fuel_m + w_t · t^m_N`` (fuel [t], time [h], or cost) the objective is

* ``"mean"``: ``(1/M) Σ_m J_m`` (equally likely members);
* ``"cvar"``: the conditional value at risk at level α by the Rockafellar–Uryasev auxiliary variable
  (Rockafellar & Uryasev 2000, "Optimization of conditional value-at-risk", J. Risk 2(3)),

      CVaR_α = min_z  z + 1/((1 − α) M) Σ_m max(J_m − z, 0),

  written smoothly with ``u_m ≥ 0``, ``u_m ≥ J_m − z``. α = 0 gives the mean; with two members, α = ½ gives
  the worse member's ``J``; α → 1 tends to the worst member.

**All but k members** (:meth:`RobustSpeedNLP.solve_chance`): the safety rows (band, engine load, exclusion) and
the ETA of up to ``k`` members may be dropped; the time dynamics, drift and SOG rows of every member stay (they
define its arrival and fuel, which the mean still counts). Dropping more members only relaxes the problem, so the
optimum drops exactly ``k``: the ``C(M, k)`` choices are enumerated (exact in the choice of members; each solve a
local NLP optimum), every one solved with the same solver (the dropped rows are bounds, not structure).

Band sides and applicability are per member (M, N, m, B) and are run-time data, as in :class:`SpeedNLP`;
:meth:`RobustSpeedNLP.solve_sides` re-imposes a band where a member's solution has moved into a sea where it
applies (sides from :func:`formulations.disjunctive.select_sides`) until no new band applies. It does not
search the band sides (no flips): a local optimum for the sides found.

Ipopt with MUMPS and the options of :mod:`formulations.speed_nlp`; exact Hessian by default.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from formulations._buffers import CoreCallback, WeatherValues
from formulations._nlp_model import structured_cores
from formulations.common import (
    G_OVER_2PI_KN_S,
    Band,
    CorridorGeometry,
    FormulationInputError,
    MovingExclusion,
    PowerModel,
    broadcast_legs,
)
from formulations.disjunctive import held_across_crossings, select_sides
from formulations.ipopt_options import IPOPT_DEFAULTS
from formulations.nlp_result import max_violation
from formulations.row_layout import row_blocks, row_bounds
from formulations.sample_layout import SampleLayout
from formulations.speed_nlp import SampleState, SpeedNLP
from formulations.weather_grid import WeatherGrid

__all__ = ["MAX_DROP_CHOICES", "RobustResult", "RobustSpeedNLP"]

Risk = Literal["mean", "cvar"]

#: The most choices of dropped members :meth:`RobustSpeedNLP.solve_chance` enumerates (one solve each).
MAX_DROP_CHOICES = 64

_SAFETY_ROWS = ("load", "band", "excl")  # what a dropped member no longer has to satisfy (with its ETA)
_STATE_EXTRA = ("ratio", "excl_margin")


@dataclass(frozen=True)
class RobustResult:
    """Solution of :meth:`RobustSpeedNLP.solve`.

    Attributes
    ----------
    status : str
        Ipopt's ``return_status``, verbatim.
    success : bool
        CasADi's ``stats()["success"]``.
    iterations, solves : int
        Ipopt iterations (all solves) and Ipopt calls.
    solve_time_s : float
        Wall-clock time of the Ipopt calls [s].
    objective : float
        The mean or CVaR of the members' objectives [t, h or currency].
    member_objective : numpy.ndarray, shape (M,)
        Every member's ``J_m`` at the solution (its own model: fuel [t], time [h] or cost).
    member_fuel_t : numpy.ndarray, shape (M,)
        Every member's fuel [t] by the NLP's model.
    var : float
        The auxiliary ``z`` at the solution (the value at risk for ``"cvar"``; NaN for ``"mean"``).
    offset_nm, stw_kn : numpy.ndarray
        The plan: lateral offsets (N+1,) [nm, port +] and leg speeds through water (N,) [kn].
    time_h : numpy.ndarray, shape (M, N+1)
        Every member's arrival time at every waypoint [h since departure].
    states : tuple of SampleState
        Per member, the conditions at every sample (:meth:`SpeedNLP.evaluate`).
    sides, applies : numpy.ndarray, shape (M, N, m, B)
        Sides and applicability imposed in the last solve.
    sides_settled : bool
        No kept member's solution met a band that was not imposed (the last re-imposition changed nothing).
    max_violation : float
        Largest violation of the rows imposed at the returned point (scaled units of each row).
    dropped : numpy.ndarray of bool, shape (M,)
        Members whose safety rows and ETA were not imposed (all False but in :meth:`solve_chance`).
    """

    status: str
    success: bool
    iterations: int
    solves: int
    solve_time_s: float
    objective: float
    member_objective: np.ndarray
    member_fuel_t: np.ndarray
    var: float
    offset_nm: np.ndarray
    stw_kn: np.ndarray
    time_h: np.ndarray
    states: tuple[SampleState, ...]
    sides: np.ndarray
    applies: np.ndarray
    sides_settled: bool
    max_violation: float
    dropped: np.ndarray
    x_opt: np.ndarray = field(repr=False)


def _member_weather(weathers: Sequence[WeatherGrid], k_: int) -> tuple[Any, list]:
    """``(member index, (3, K) points) ↦ (n_fields, K)``: the members' weather values behind one
    ``Function.conditional``; and the per-member functions (to be kept alive).

    Values only: the NLP's derivatives come from :class:`_MemberDerivatives`, so no member needs a CasADi spline.
    A ``"smooth"`` member is read in numpy (:class:`formulations._nlp_model.WeatherValues`, its
    :meth:`WeatherGrid.tensor_spline`), any other through its CasADi interpolant.
    """
    first = weathers[0]
    for k, w in enumerate(weathers):
        if w.field_names != first.field_names or w.ratio_axes != first.ratio_axes:
            raise FormulationInputError(
                f"member {k}'s weather has other fields or power-table axes than member 0's ({len(w.field_names)} "
                f"against {len(first.field_names)} fields): the members of one robust NLP must carry the same fields "
                "and tabulate the ship's power at the same speeds and headings"
            )
    cases = [WeatherValues(w, k_) if w.method == "smooth" else w.interpolant().map(k_) for w in weathers]
    return ca.Function.conditional("member_weather", cases, cases[0]), cases


class _MemberDerivatives(CoreCallback):
    """``grad_f``, ``jac_g`` or ``hess_lag`` of the robust NLP for ``nlpsol``: the single-weather NLP's leg-by-leg
    derivative cores (:func:`formulations._nlp_model.structured_cores`) evaluated per member at that member's
    variables and with that member's weather Taylor data, scattered into the stacked problem.

    ``core`` is an MX function of ``(*inputs, theta_1, …, theta_M)``; ``taylors[m]`` gives member ``m``'s Taylor
    data at its variables ``x[index[m]]`` (``first`` for the gradient and Jacobian, ``hessian`` for the Hessian).
    """

    def __init__(
        self, name: str, core: Any, taylors: list, index: list[np.ndarray], names: tuple[list, list], hessian: bool
    ) -> None:
        ca.Callback.__init__(self)
        self._core, self._taylors, self._index, self._names, self._hessian = core, taylors, index, names, hessian
        self.construct(name, {})

    def eval(self, arg: list[Any]) -> list[Any]:
        x = np.asarray(arg[0], dtype=float).ravel()
        which = "hessian" if self._hessian else "first"
        thetas = [getattr(tay, which)(x[idx]) for tay, idx in zip(self._taylors, self._index, strict=True)]
        first = len(arg)  # the Taylor data may come flat, column-major (formulations._buffers): shape it
        thetas = [
            ca.DM(self._core.sparsity_in(first + k), np.asarray(t, dtype=float).ravel(order="F"))
            if np.size(t) == self._core.sparsity_in(first + k).nnz() and np.ndim(t) != 2
            else t
            for k, t in enumerate(thetas)
        ]
        return self._core.call([*arg, *thetas])


def _current_rows(weathers: Sequence[WeatherGrid], v_min_kn: np.ndarray, sog_min_kn: float) -> bool:
    """Whether any member's current can bind the drift-angle and SOG rows (the rule of :class:`SpeedNLP`:
    ``|u| ≤ v_min/2`` keeps the drift angle ≤ 30° and ``SOG ≥ 0.366 v_min``)."""
    v_min = float(np.min(v_min_kn))
    for w in weathers:
        if w.current_along_kn is None:
            continue
        speed = np.hypot(np.asarray(w.current_along_kn), np.asarray(w.current_across_kn))
        if not (float(speed.max()) <= 0.5 * v_min and 0.366 * v_min >= sog_min_kn):
            return True
    return False


class RobustSpeedNLP:
    """The corridor NLP over the members of an ensemble: one plan, every member's rows (module docstring).

    Parameters
    ----------
    corridor : CorridorGeometry
        Centreline, normals and lateral bounds (N legs), shared by the members.
    weathers : sequence of WeatherGrid
        One grid per member (M ≥ 1), each with its own power table, all ``method="smooth"`` on the same axes.
    power : PowerModel
        Calm-water baseline, load limits and SFOC (shared).
    risk : {"mean", "cvar"}
        The members' objectives combined as their mean or their CVaR at ``alpha``.
    alpha : float
        CVaR level in [0, 1) (only for ``"cvar"``).
    bands, exclusion, samples_per_leg, v_min_kn, v_max_kn, g_over_2pi_kn_s, sog_min_kn
        As in :class:`formulations.speed_nlp.SpeedNLP`.
    exact_hessian : bool
        Ipopt's exact Hessian of the Lagrangian (default) or its limited-memory (L-BFGS) approximation.
    weather_curvature : bool
        With the exact Hessian, keep the weather's second derivatives in t and y in it (default: the exact Hessian);
        False leaves them out, as :class:`SpeedNLP` does by default. Gradients and Jacobians are exact either way,
        so Ipopt converges to the same KKT point; on ``benchmarks.bench_robust``'s storm case the curvature saved
        iterations (12/15/15 against 19/18/19 at 1/2/4 members, same optimum).
    ipopt_options : dict, optional
        Overrides of the Ipopt/CasADi options.
    sample_layout : SampleLayout, optional
        Where every leg is sampled, as in :class:`SpeedNLP` (the same for every member): the quadrature and
        row-only points (weight 0) where the rows are imposed too; replaces ``samples_per_leg``.
    """

    def __init__(
        self,
        corridor: CorridorGeometry,
        weathers: Sequence[WeatherGrid],
        power: PowerModel,
        *,
        risk: Risk = "mean",
        alpha: float = 0.0,
        bands: Sequence[Band] = (),
        exclusion: MovingExclusion | None = None,
        samples_per_leg: int = 2,
        v_min_kn: ArrayLike = 1.0,
        v_max_kn: ArrayLike = 30.0,
        g_over_2pi_kn_s: float = G_OVER_2PI_KN_S,
        sog_min_kn: float = 1.0,
        exact_hessian: bool = True,
        weather_curvature: bool = True,
        ipopt_options: dict[str, Any] | None = None,
        sample_layout: SampleLayout | None = None,
    ) -> None:
        started = time.perf_counter()
        weathers = list(weathers)
        if not weathers or not all(isinstance(w, WeatherGrid) for w in weathers):
            raise FormulationInputError("weathers must be a non-empty sequence of WeatherGrid, one per member")
        if risk not in ("mean", "cvar"):
            raise FormulationInputError(f"risk must be 'mean' or 'cvar', got {risk!r}")
        if not (np.isfinite(alpha) and 0.0 <= float(alpha) < 1.0):
            raise FormulationInputError(f"alpha must be in [0, 1), got {alpha!r}")
        self.risk, self.alpha = risk, float(alpha)
        v_lo = broadcast_legs(v_min_kn, corridor.n_legs, "v_min_kn")
        self.has_current_rows = _current_rows(weathers, v_lo, float(sog_min_kn))
        # the template's model is every member's, read with that member's weather; its weather decides whether
        # it has the current rows, so it is a member whose currents need them when any member's do
        lead = next((k for k, w in enumerate(weathers) if _current_rows([w], v_lo, float(sog_min_kn))), 0)
        self.template = SpeedNLP(
            corridor,
            weathers[lead],
            power,
            bands=bands,
            exclusion=exclusion,
            samples_per_leg=samples_per_leg,
            v_min_kn=v_min_kn,
            v_max_kn=v_max_kn,
            g_over_2pi_kn_s=g_over_2pi_kn_s,
            sog_min_kn=sog_min_kn,
            build_solver=False,
            sample_layout=sample_layout,
        )
        tpl = self.template
        self.corridor, self.power, self.bands = corridor, power, tpl.bands
        self.n_members, self.n_legs = len(weathers), tpl.n_legs
        self.samples_per_leg, self.n_bands = tpl.samples_per_leg, tpl.n_bands
        self.v_min_kn, self.v_max_kn, self.sog_min_kn = tpl.v_min_kn, tpl.v_max_kn, float(sog_min_kn)
        self._weathers = weathers
        self._weather, self._weather_cases = _member_weather(weathers, self.n_legs * self.samples_per_leg)
        self.exact_hessian, self.weather_curvature = bool(exact_hessian), bool(weather_curvature)
        self._build(dict(ipopt_options or {}))
        self.build_time_s = time.perf_counter() - started

    # ------------------------------------------------------------------ build
    def _member_functions(self) -> tuple[Any, Any]:
        """The member's rows and fuel, and its diagnostics, as functions of (y, v, t, beta, fac, member index)."""
        n, m, nb = self.n_legs, self.samples_per_leg, self.n_bands
        k_ = n * m
        y, v, t = ca.MX.sym("y", n + 1), ca.MX.sym("v", n), ca.MX.sym("t", n + 1)
        beta, fac, index = ca.MX.sym("beta", k_ * nb), ca.MX.sym("f", n), ca.MX.sym("member")
        mdl = self.template.symbolic_model(y, v, t, beta, fac, weather=lambda pts: self._weather(index, pts))
        parts, rows = row_blocks(mdl, t, bands=bool(nb), current=self.has_current_rows,
                                 exclusion=self.template.exclusion is not None)  # fmt: skip
        self._rows, self._ng_member = rows, sum(p.shape[0] for p in parts)
        member = ca.Function("member", [y, v, t, beta, fac, index], [ca.vertcat(*parts), ca.sum1(mdl["fuel_leg"])])
        names = [*SpeedNLP.STATE_KEYS, "dt_leg", "fuel_leg"] + [k for k in _STATE_EXTRA if k in mdl]
        self._diag_names = names
        diag = ca.Function("member_diag", [y, v, t, beta, fac, index], [mdl[k] for k in names])
        return member, diag

    def _build(self, ipopt_options: dict[str, Any]) -> None:
        n, mm, nb = self.n_legs, self.n_members, self.n_bands
        kb = n * self.samples_per_leg * nb
        member, diag = self._member_functions()
        if self._rows != self.template._rows:
            raise FormulationInputError(  # cannot happen with the template chosen above: the cores would misread
                f"the member rows {self._rows} differ from the template NLP's {self.template._rows}"
            )
        cvar = self.risk == "cvar"
        nx = (n + 1) + n + mm * (n + 1) + ((1 + mm) if cvar else 0)
        x = ca.MX.sym("x", nx)
        y, v = x[: n + 1], x[n + 1 : 2 * n + 1]
        t = ca.reshape(x[2 * n + 1 : 2 * n + 1 + mm * (n + 1)], n + 1, mm)
        weights, beta, fac = ca.MX.sym("w", 2), ca.MX.sym("beta", mm * kb), ca.MX.sym("f", n)
        mapped = member.map("members", "serial", mm, [0, 1, 4], [])  # y, v and the leg factors are shared
        g_all, fuel = mapped(y, v, t, ca.reshape(beta, kb, mm), fac, ca.DM(np.arange(mm)[None, :]))
        j = (weights[0] * fuel + weights[1] * (t[n, :] - t[0, :])).T  # (M, 1)
        g = ca.vec(g_all)  # member-major: member k's rows at k·ng_member + r
        if cvar:
            z, u = x[nx - 1 - mm], x[nx - mm :]
            self._cvar_rows = (g.shape[0], g.shape[0] + mm)
            g = ca.vertcat(g, u - j + z)  # u_m ≥ J_m − z
            objective = z + ca.sum1(u) / ((1.0 - self.alpha) * mm)
        else:
            objective = ca.sum1(j) / mm
        self._ng, self._nx, self._kb = g.shape[0], nx, kb
        opts = dict(IPOPT_DEFAULTS)
        opts["ipopt.hessian_approximation"] = "exact" if self.exact_hessian else "limited-memory"
        opts.update(ipopt_options)
        self._derivatives = self._member_derivatives(nx, self._ng)  # keep alive: nlpsol holds no Python reference
        opts.update(self._derivatives if self.exact_hessian else {k: self._derivatives[k] for k in ("grad_f", "jac_g")})
        param = ca.vertcat(weights, beta, fac)
        self._solver = ca.nlpsol("robust_speed_nlp", "ipopt", {"x": x, "p": param, "f": objective, "g": g}, opts)
        self._objectives = ca.Function("member_objectives", [x, param], [j])
        self._diag = diag.map("member_diags", "serial", mm, [0, 1, 4], [])

    def _member_derivatives(self, nx: int, ng: int) -> dict[str, Any]:
        """``grad_f``, ``jac_g`` and ``hess_lag`` for ``nlpsol`` from the template's per-leg cores, per member.

        Member ``m`` sees the variables ``x_m = (y, V, t^m)`` (the single-weather layout) and the parameters
        ``(w, β_m, f)``; its gradient, Jacobian rows and Hessian are the template's cores at ``x_m`` with its own
        weather's Taylor data, scattered by the constant selection ``P_m`` (``x_m = P_mᵀ x``): ``∇f = Σ_m c_m P_m
        ∇J_m``, rows ``J_m P_mᵀ``, ``∇²L = Σ_m P_m ∇²L_m P_mᵀ`` (``P_m`` keeps the variables' order, so the upper
        triangle stays upper). Mean: ``c_m = 1/M``; CVaR: the objective is ``z + Σ u_m/((1−α)M)`` and ``J_m`` enters
        the rows ``u_m − J_m + z`` (their multipliers weight ``∇²J_m``).
        """
        n, mm, kb = self.n_legs, self.n_members, self._kb
        cores = structured_cores(self.template, exact_hessian=self.weather_curvature)
        nxm, ngm = 3 * n + 2, self._ng_member
        index = [np.concatenate([np.arange(2 * n + 1), 2 * n + 1 + k * (n + 1) + np.arange(n + 1)]) for k in range(mm)]
        sel = [ca.DM(ca.Sparsity.triplet(nx, nxm, idx.tolist(), list(range(nxm))), 1.0) for idx in index]
        x, p = ca.MX.sym("x", nx), ca.MX.sym("p", 2 + mm * kb + n)
        lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", ng)
        th = [ca.MX.sym(f"theta_{k}", cores.grad.sparsity_in(2)) for k in range(mm)]
        th_h = [ca.MX.sym(f"theta_h_{k}", cores.hess.sparsity_in(4)) for k in range(mm)]
        pm = [ca.vertcat(p[:2], p[2 + k * kb : 2 + (k + 1) * kb], p[2 + mm * kb :]) for k in range(mm)]
        xm = [x[idx.tolist()] for idx in index]
        cvar = self.risk == "cvar"
        jm, grads, gs, jacs = [], [], [], []
        for k in range(mm):
            f_k, grad_k = cores.grad(xm[k], pm[k], th[k])
            g_k, jac_k = cores.jac(xm[k], pm[k], th[k])
            jm.append(f_k)
            grads.append(ca.mtimes(sel[k], grad_k))
            gs.append(g_k)
            jacs.append(ca.mtimes(jac_k, sel[k].T))
        if cvar:
            z_col, u_cols = nx - 1 - mm, nx - mm + np.arange(mm)
            e = np.zeros((mm, nx))
            e[np.arange(mm), u_cols], e[:, z_col] = 1.0, 1.0
            u, z = x[nx - mm :], x[nx - 1 - mm]
            f = z + ca.sum1(u) / ((1.0 - self.alpha) * mm)
            c_obj = np.zeros(nx)
            c_obj[u_cols], c_obj[z_col] = 1.0 / ((1.0 - self.alpha) * mm), 1.0
            grad = ca.DM(c_obj)
            gs.append(u - ca.vertcat(*jm) + z)
            jacs.append(ca.sparsify(ca.DM(e)) - ca.horzcat(*grads).T)
            lam_obj = [-lam_g[ngm * mm + k] for k in range(mm)]
        else:
            f = sum(jm) / mm
            grad = sum(grads) / mm
            lam_obj = [lam_f / mm] * mm
        hess = 0
        for k in range(mm):
            h_k = cores.hess(xm[k], pm[k], lam_obj[k], lam_g[k * ngm : (k + 1) * ngm], th_h[k])
            hess = hess + ca.mtimes(ca.mtimes(sel[k], h_k), sel[k].T)
        taylors = [cores.taylor(w, numeric=True) for w in self._weathers]
        first = ca.Function("robust_grad_f", [x, p, *th], [f, ca.densify(grad)])
        jac = ca.Function("robust_jac_g", [x, p, *th], [ca.vertcat(*gs), ca.vertcat(*jacs)])
        hess_fn = ca.Function("robust_hess_lag", [x, p, lam_f, lam_g, *th_h], [ca.triu(hess)])
        io = (["x", "p"], ["f", "grad_f_x"]), (["x", "p"], ["g", "jac_g_x"])
        return {
            "grad_f": _MemberDerivatives("grad_f", first, taylors, index, io[0], hessian=False),
            "jac_g": _MemberDerivatives("jac_g", jac, taylors, index, io[1], hessian=False),
            "hess_lag": _MemberDerivatives(
                "hess_lag", hess_fn, taylors, index, (["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"]), True
            ),
        }

    # ------------------------------------------------------------------ helpers
    def _split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n, mm = self.n_legs, self.n_members
        y, v = x[: n + 1], x[n + 1 : 2 * n + 1]
        t = x[2 * n + 1 : 2 * n + 1 + mm * (n + 1)].reshape(mm, n + 1)
        return y, v, t

    def _values(self, y: np.ndarray, v: np.ndarray, t: np.ndarray, fac: np.ndarray | None = None) -> list[dict]:
        """Every member's diagnostic values (one dict per member) at offsets, speeds and times (M, N+1)."""
        n, mm = self.n_legs, self.n_members
        fac = np.ones(n) if fac is None else fac
        out = self._diag(y, v, np.asarray(t, dtype=float).T, np.zeros((self._kb, mm)), fac, np.arange(mm)[None, :])
        out = out if isinstance(out, tuple | list) else [out]
        arrays = [np.asarray(o, dtype=float) for o in out]
        per = []
        for k in range(mm):
            vals = {}
            for name, a in zip(self._diag_names, arrays, strict=True):
                cols = a.shape[1] // mm  # the map stacks the members' outputs side by side
                vals[name] = a[:, k * cols : (k + 1) * cols]
            per.append(vals)
        return per

    def consistent_times(self, offset_nm: ArrayLike, stw_kn: ArrayLike, *, iterations: int = 3) -> np.ndarray:
        """Every member's arrival times (M, N+1) [h] that satisfy its time dynamics for one plan (the fixed point
        of :meth:`SpeedNLP.consistent_times`, all members at once)."""
        y = broadcast_legs(offset_nm, self.n_legs + 1, "offset_nm")
        v = broadcast_legs(stw_kn, self.n_legs, "stw_kn")
        t0 = np.concatenate([[0.0], np.cumsum(np.diff(self.corridor.s_nm) / v)])
        t = np.tile(t0, (self.n_members, 1))
        for _ in range(max(1, iterations)):
            vals = self._values(y, v, t)
            t = np.array([np.concatenate([[0.0], np.cumsum(d["dt_leg"].ravel())]) for d in vals])
        return t

    def evaluate(self, offset_nm: ArrayLike, stw_kn: ArrayLike) -> tuple[tuple[SampleState, ...], np.ndarray]:
        """Every member's sample conditions and consistent times (M, N+1) [h] for one plan (offsets, speeds)."""
        y = broadcast_legs(offset_nm, self.n_legs + 1, "offset_nm")
        v = broadcast_legs(stw_kn, self.n_legs, "stw_kn")
        times = self.consistent_times(y, v)
        return self._states(y, v, times), times

    def _states(self, y: np.ndarray, v: np.ndarray, t: np.ndarray) -> tuple[SampleState, ...]:
        return tuple(self.template.sample_state(d) for d in self._values(y, v, t))

    def default_sides(self, states: Sequence[SampleState]) -> tuple[np.ndarray, np.ndarray]:
        """Sides and applicability (M, N, m, B) from every member's conditions (:meth:`SpeedNLP.default_sides`)."""
        pairs = [self.template.default_sides(s) for s in states]
        return np.stack([p[0] for p in pairs]), np.stack([p[1] for p in pairs])

    # ------------------------------------------------------------------ solve
    def _bounds(
        self, sides: np.ndarray, applies: np.ndarray, dropped: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Row bounds of every member (dropped members: no safety rows) and the band edges (M·kb,)."""
        lbg, ubg = np.zeros(self._ng), np.zeros(self._ng)
        betas = []
        for k in range(self.n_members):
            base = k * self._ng_member
            beta, band_lo, band_hi = self.template.band_edges(sides[k], applies[k])
            betas.append(beta)
            rows = self._rows
            lo, hi = row_bounds(rows, self._ng_member, self.power, band=(band_lo, band_hi) if "band" in rows else None,
                                sog_min_kn=self.sog_min_kn if "sog" in rows else None,
                                exclusion="excl" in rows)  # fmt: skip
            for name in _SAFETY_ROWS if dropped[k] else ():
                r0, r1 = rows.get(name, (0, 0))
                lo[r0:r1], hi[r0:r1] = -np.inf, np.inf
            lbg[base : base + self._ng_member], ubg[base : base + self._ng_member] = lo, hi
        if self.risk == "cvar":
            a, b = self._cvar_rows
            lbg[a:b], ubg[a:b] = 0.0, np.inf
        return lbg, ubg, np.concatenate(betas) if betas else np.zeros(0)

    def solve(
        self,
        *,
        eta_h: float | None,
        objective: Literal["time", "fuel", "cost"] = "fuel",
        fuel_price: float = 1.0,
        hourly_cost: float = 0.0,
        sides: np.ndarray,
        applies: np.ndarray,
        offset0_nm: ArrayLike,
        stw0_kn: ArrayLike,
        leg_power_factor: ArrayLike | None = None,
        dropped: ArrayLike | None = None,
    ) -> RobustResult:
        """One Ipopt solve for given sides and applicability (M, N, m, B) from a warm start (offsets, speeds).

        ``eta_h`` bounds every kept member's arrival [h since departure] (``None``: free arrival); ``dropped``
        (M,) bool: members whose safety rows and ETA are not imposed (default none).
        """
        n, mm = self.n_legs, self.n_members
        if objective not in ("time", "fuel", "cost"):
            raise FormulationInputError(f"objective must be 'time', 'fuel' or 'cost', got {objective!r}")
        if eta_h is not None and not (np.isfinite(eta_h) and eta_h > 0):
            raise FormulationInputError(f"eta_h must be a positive number of hours, got {eta_h}")
        drop = np.zeros(mm, dtype=bool) if dropped is None else np.asarray(dropped, dtype=bool)
        if drop.shape != (mm,):
            raise FormulationInputError(f"dropped must be {mm} booleans (one per member), got shape {drop.shape}")
        weights = {"fuel": (1.0, 0.0), "time": (0.0, 1.0), "cost": (float(fuel_price), float(hourly_cost))}[objective]
        shape = (mm, n, self.samples_per_leg, self.n_bands)
        sides, applies = np.asarray(sides), np.asarray(applies, dtype=bool)
        if sides.shape != shape or applies.shape != shape:
            raise FormulationInputError(
                f"sides and applies must have shape {shape}, got {sides.shape}, {applies.shape}"
            )
        if self.n_bands:  # each member's sides held across its seas' threshold crossings, as SpeedNLP.solve holds them
            sides, applies = held_across_crossings(sides, applies)
        y0 = np.clip(broadcast_legs(offset0_nm, n + 1, "offset0_nm"), *self.corridor.offset_bounds())
        v0 = np.clip(broadcast_legs(stw0_kn, n, "stw0_kn"), self.v_min_kn, self.v_max_kn)
        fac = broadcast_legs(1.0 if leg_power_factor is None else leg_power_factor, n, "leg_power_factor")
        t0 = self.consistent_times(y0, v0)
        lbg, ubg, beta = self._bounds(sides, applies, drop)
        y_lo, y_hi = self.corridor.offset_bounds()
        t_lo, t_hi = np.zeros((mm, n + 1)), np.full((mm, n + 1), np.inf)
        t_hi[:, 0] = 0.0
        if eta_h is not None:
            t_hi[~drop, n] = eta_h
        lbx = [y_lo, self.v_min_kn, t_lo.ravel()]
        ubx = [y_hi, self.v_max_kn, t_hi.ravel()]
        x0 = [y0, v0, t0.ravel()]
        p = np.concatenate([weights, beta, fac])
        if self.risk == "cvar":
            j0 = np.asarray(self._objectives(np.concatenate([*x0, np.zeros(1 + mm)]), p), dtype=float).ravel()
            lbx += [np.array([-np.inf]), np.zeros(mm)]
            ubx += [np.array([np.inf]), np.full(mm, np.inf)]
            z0 = float(np.quantile(j0, self.alpha))
            x0 += [np.array([z0]), np.maximum(j0 - z0, 0.0)]
        lbx_a, ubx_a = np.concatenate(lbx), np.concatenate(ubx)
        x0_a = np.clip(np.concatenate(x0), lbx_a, ubx_a)
        started = time.perf_counter()
        sol = self._solver(x0=x0_a, p=p, lbx=lbx_a, ubx=ubx_a, lbg=lbg, ubg=ubg)
        elapsed = time.perf_counter() - started
        stats = self._solver.stats()
        x = np.asarray(sol["x"], dtype=float).ravel()
        g = np.asarray(sol["g"], dtype=float).ravel()
        viol = max_violation(x, lbx_a, ubx_a, g, lbg, ubg)
        y, v, t = self._split(x)
        vals = self._values(y, v, t, fac)
        return RobustResult(
            status=str(stats.get("return_status", "unknown")),
            success=bool(stats.get("success", False)),
            iterations=int(stats.get("iter_count", -1)),
            solves=1,
            solve_time_s=elapsed,
            objective=float(sol["f"]),
            member_objective=np.asarray(self._objectives(x, p), dtype=float).ravel(),
            member_fuel_t=np.array([float(np.sum(d["fuel_leg"])) for d in vals]),
            var=float(x[self._nx - 1 - mm]) if self.risk == "cvar" else float("nan"),
            offset_nm=y,
            stw_kn=v,
            time_h=t,
            states=tuple(self.template.sample_state(d) for d in vals),
            sides=sides.astype(np.int8),
            applies=applies,
            sides_settled=True,
            max_violation=viol,
            dropped=drop,
            x_opt=x,
        )

    def solve_sides(
        self,
        *,
        offset0_nm: ArrayLike,
        stw0_kn: ArrayLike,
        max_solves: int = 6,
        **kwargs: Any,
    ) -> RobustResult:
        """Solve, then re-impose every band a member's solution met where it was not imposed; repeat.

        Sides start from every member's conditions at the warm start (:meth:`default_sides`); after a
        solve, a sample where a band now applies in a kept member (``Hs ≥ hs_min`` there) is added to that
        member's imposed rows with the side the solution is on (:func:`select_sides`, the nearer edge
        inside the band). Stops when nothing is added or after ``max_solves`` solves
        (``sides_settled`` False). Keyword arguments as :meth:`solve`.
        """
        states, _ = self.evaluate(offset0_nm, stw0_kn)
        sides, applies = self.default_sides(states)
        drop = np.zeros(self.n_members, dtype=bool) if kwargs.get("dropped") is None else np.asarray(kwargs["dropped"])
        y0, v0 = offset0_nm, stw0_kn
        iterations, elapsed, solves = 0, 0.0, 0
        while True:
            res = self.solve(sides=sides, applies=applies, offset0_nm=y0, stw0_kn=v0, **kwargs)
            iterations, elapsed, solves = iterations + res.iterations, elapsed + res.solve_time_s, solves + 1
            new = np.stack([s.applies for s in res.states]) & ~applies & ~drop[:, None, None, None]
            if self.n_bands:
                lower = np.array([b.lower for b in self.bands])
                upper = np.array([b.upper for b in self.bands])
                ratio = np.stack([s.ratio for s in res.states])
                sides = np.where(new, select_sides(ratio, lower, upper), sides).astype(np.int8)
            settled = not new.any()
            if settled or solves >= max_solves:
                break
            applies = applies | new
            y0, v0 = res.offset_nm, res.stw_kn
        return replace(res, iterations=iterations, solve_time_s=elapsed, solves=solves, sides_settled=settled)

    def solve_chance(self, *, max_dropped: int, **kwargs: Any) -> tuple[RobustResult, ...]:
        """Every choice of exactly ``max_dropped`` members to drop, solved (:meth:`solve_sides`); best first.

        The exact "all but k members" problem for small M (module docstring): ``C(M, k)`` solves of the same
        solver, at most :data:`MAX_DROP_CHOICES`. Results are ordered by usable (Ipopt converged or stopped at a
        limit with the rows held to 1e-6) and then by objective; the caller checks them in that order. Keyword
        arguments as :meth:`solve_sides` (without ``dropped``); ``iterations``/``solve_time_s`` of the first
        result are those of all solves.
        """
        mm = self.n_members
        if not (isinstance(max_dropped, int | np.integer) and 0 <= max_dropped < mm):
            raise FormulationInputError(f"max_dropped must be an integer in [0, {mm - 1}], got {max_dropped!r}")
        count = math.comb(mm, int(max_dropped))
        if count > MAX_DROP_CHOICES:
            raise FormulationInputError(
                f"dropping {max_dropped} of {mm} members has {count} choices, more than the {MAX_DROP_CHOICES} this "
                "enumeration solves; ask for a smaller fraction or fewer members, or use the CVaR objective"
            )
        results = []
        for combo in itertools.combinations(range(mm), int(max_dropped)):
            drop = np.zeros(mm, dtype=bool)
            drop[list(combo)] = True
            results.append(self.solve_sides(dropped=drop, **kwargs))
        iterations = sum(r.iterations for r in results)
        elapsed = sum(r.solve_time_s for r in results)
        solves = sum(r.solves for r in results)
        order = sorted(results, key=lambda r: (not (r.success and r.max_violation <= 1e-6), r.objective))
        return (replace(order[0], iterations=iterations, solve_time_s=elapsed, solves=solves), *order[1:])
