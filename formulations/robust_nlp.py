"""One speed-and-offset schedule over the members of an ensemble: the corridor NLP stacked per member.

The members ``m = 1..M`` of an ensemble are ``M`` weather grids (:class:`formulations.common.WeatherGrid`, each
with the ship's power table tabulated in that member's sea) on the same corridor. The decision is one plan —
the lateral offsets ``y_k`` and the speeds through water ``V_k`` of :mod:`formulations.speed_nlp` — and, because
the speed over ground depends on each member's current, one arrival-time vector ``t^m`` per member. Every
row of :class:`formulations.speed_nlp.SpeedNLP` (time dynamics, engine load, danger bands with their sides,
drift and SOG, moving exclusion) is imposed in every member, with that member's weather, and the ETA bounds
every member's arrival ``t^m_N``.

With ``J_m = w_f · fuel_m + w_t · t^m_N`` (fuel [t], time [h], or cost) the objective is

* ``"mean"``: ``(1/M) Σ_m J_m`` (equally likely members);
* ``"cvar"``: the conditional value at risk at level α by the Rockafellar–Uryasev auxiliary variable
  (Rockafellar & Uryasev 2000, "Optimization of conditional value-at-risk", J. Risk 2(3)),

      CVaR_α = min_z  z + 1/((1 − α) M) Σ_m max(J_m − z, 0),

  written smoothly with ``u_m ≥ 0``, ``u_m ≥ J_m − z``. α = 0 gives the mean; with two members, α = ½ gives
  the worse member's ``J``; α → 1 tends to the worst member.

Band sides and applicability are per member (N, m, B each) and are run-time data, as in :class:`SpeedNLP`;
:meth:`RobustSpeedNLP.solve_sides` re-imposes a band where a member's solution has moved into a sea where it
applies (sides from :func:`formulations.disjunctive.select_sides`) until no new band applies. It does not
search the band sides (no flips): a local optimum for the sides found.

Derivatives: CasADi's automatic differentiation of the stacked MX graph (no structured leg-by-leg
derivatives); Ipopt with MUMPS and the options of :mod:`formulations.speed_nlp`.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from formulations.common import (
    G_OVER_2PI_KN_S,
    Band,
    CorridorGeometry,
    FormulationInputError,
    MovingExclusion,
    PowerModel,
    WeatherGrid,
    broadcast_legs,
)
from formulations.disjunctive import select_sides
from formulations.speed_nlp import IPOPT_DEFAULTS, SampleState, SpeedNLP

__all__ = ["RobustResult", "RobustSpeedNLP"]

Risk = Literal["mean", "cvar"]


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
        No member's solution met a band that was not imposed (the last re-imposition changed nothing).
    max_violation : float
        Largest constraint violation at the returned point (scaled units of each row).
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
    x_opt: np.ndarray = field(repr=False)


class RobustSpeedNLP:
    """The corridor NLP over the members of an ensemble: one plan, every member's rows.

    Parameters
    ----------
    corridor : CorridorGeometry
        Centreline, normals and lateral bounds (N legs), shared by the members.
    weathers : sequence of WeatherGrid
        One grid per member (M ≥ 1), each with its own power table.
    power : PowerModel
        Calm-water baseline, load limits and SFOC (shared).
    risk : {"mean", "cvar"}
        The members' objectives combined as their mean or their CVaR at ``alpha``.
    alpha : float
        CVaR level in [0, 1) (only for ``"cvar"``).
    bands, exclusion, samples_per_leg, v_min_kn, v_max_kn, g_over_2pi_kn_s, sog_min_kn
        As in :class:`formulations.speed_nlp.SpeedNLP`.
    ipopt_options : dict, optional
        Overrides of the Ipopt/CasADi options.
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
        ipopt_options: dict[str, Any] | None = None,
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
        self.members = tuple(
            SpeedNLP(
                corridor,
                w,
                power,
                bands=bands,
                exclusion=exclusion,
                samples_per_leg=samples_per_leg,
                v_min_kn=v_min_kn,
                v_max_kn=v_max_kn,
                g_over_2pi_kn_s=g_over_2pi_kn_s,
                sog_min_kn=sog_min_kn,
                build_solver=False,
            )
            for w in weathers
        )
        first = self.members[0]
        self.corridor, self.power = corridor, power
        self.n_members, self.n_legs = len(self.members), first.n_legs
        self.samples_per_leg, self.n_bands = first.samples_per_leg, first.n_bands
        self.v_min_kn, self.v_max_kn = first.v_min_kn, first.v_max_kn
        self._build(dict(ipopt_options or {}))
        self.build_time_s = time.perf_counter() - started

    # ------------------------------------------------------------------ build
    def _build(self, ipopt_options: dict[str, Any]) -> None:
        n, mm = self.n_legs, self.n_members
        kb = n * self.samples_per_leg * self.n_bands
        cvar = self.risk == "cvar"
        nx = (n + 1) + n + mm * (n + 1) + ((1 + mm) if cvar else 0)
        x = ca.MX.sym("x", nx)
        y, v = x[: n + 1], x[n + 1 : 2 * n + 1]
        weights = ca.MX.sym("w", 2)
        beta = ca.MX.sym("beta", mm * kb)
        fac = ca.MX.sym("f", n)
        parts: list[Any] = []
        rows: list[dict[str, tuple[int, int]]] = []
        objectives = []

        def add(table: dict[str, tuple[int, int]], name: str, expr: Any) -> None:
            start = sum(p.shape[0] for p in parts)
            table[name] = (start, start + expr.shape[0])
            parts.append(expr)

        for k, nlp in enumerate(self.members):
            a = 2 * n + 1 + k * (n + 1)
            t = x[a : a + n + 1]
            mdl = nlp.symbolic_model(y, v, t, beta[k * kb : (k + 1) * kb], fac)
            table: dict[str, tuple[int, int]] = {}
            add(table, "dyn", (t[1:] - t[:-1]) - mdl["dt_leg"])
            add(table, "load", mdl["load"])
            if self.n_bands:
                add(table, "band", mdl["band_res"])
            if nlp.has_current_rows:
                add(table, "drift", mdl["h_perp"])
                add(table, "sog", mdl["sog"])
            if nlp.exclusion is not None:
                add(table, "excl", mdl["excl_res"])
            rows.append(table)
            objectives.append(weights[0] * ca.sum1(mdl["fuel_leg"]) + weights[1] * (t[n] - t[0]))
        j = ca.vertcat(*objectives)
        if cvar:
            z, u = x[nx - 1 - mm], x[nx - mm :]
            cvar_rows: dict[str, tuple[int, int]] = {}
            add(cvar_rows, "cvar", u - j + z)  # u_m ≥ J_m − z
            objective = z + ca.sum1(u) / ((1.0 - self.alpha) * mm)
            self._cvar_rows = cvar_rows["cvar"]
        else:
            objective = ca.sum1(j) / mm
        g = ca.vertcat(*parts)
        self._rows, self._ng, self._nx, self._kb = rows, g.shape[0], nx, kb
        opts = dict(IPOPT_DEFAULTS)
        opts.update(ipopt_options)
        param = ca.vertcat(weights, beta, fac)
        self._solver = ca.nlpsol("robust_speed_nlp", "ipopt", {"x": x, "p": param, "f": objective, "g": g}, opts)
        self._objectives = ca.Function("member_objectives", [x, param], [j])

    # ------------------------------------------------------------------ helpers
    def _split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n, mm = self.n_legs, self.n_members
        y, v = x[: n + 1], x[n + 1 : 2 * n + 1]
        t = x[2 * n + 1 : 2 * n + 1 + mm * (n + 1)].reshape(mm, n + 1)
        return y, v, t

    def evaluate(self, offset_nm: ArrayLike, stw_kn: ArrayLike) -> tuple[tuple[SampleState, ...], np.ndarray]:
        """Every member's sample conditions and consistent times (M, N+1) [h] for one plan (offsets, speeds)."""
        y = broadcast_legs(offset_nm, self.n_legs + 1, "offset_nm")
        v = broadcast_legs(stw_kn, self.n_legs, "stw_kn")
        times = np.array([nlp.consistent_times(y, v) for nlp in self.members])
        states = tuple(nlp.evaluate(y, v, t) for nlp, t in zip(self.members, times, strict=True))
        return states, times

    def default_sides(self, states: Sequence[SampleState]) -> tuple[np.ndarray, np.ndarray]:
        """Sides and applicability (M, N, m, B) from every member's conditions (:meth:`SpeedNLP.default_sides`)."""
        pairs = [nlp.default_sides(s) for nlp, s in zip(self.members, states, strict=True)]
        return np.stack([p[0] for p in pairs]), np.stack([p[1] for p in pairs])

    # ------------------------------------------------------------------ solve
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
    ) -> RobustResult:
        """One Ipopt solve for given sides and applicability (M, N, m, B) from a warm start (offsets, speeds).

        ``eta_h`` bounds every member's arrival [h since departure] (``None``: free arrival).
        """
        n, mm = self.n_legs, self.n_members
        if objective not in ("time", "fuel", "cost"):
            raise FormulationInputError(f"objective must be 'time', 'fuel' or 'cost', got {objective!r}")
        if eta_h is not None and not (np.isfinite(eta_h) and eta_h > 0):
            raise FormulationInputError(f"eta_h must be a positive number of hours, got {eta_h}")
        weights = {"fuel": (1.0, 0.0), "time": (0.0, 1.0), "cost": (float(fuel_price), float(hourly_cost))}[objective]
        shape = (mm, n, self.samples_per_leg, self.n_bands)
        sides, applies = np.asarray(sides), np.asarray(applies, dtype=bool)
        if sides.shape != shape or applies.shape != shape:
            raise FormulationInputError(
                f"sides and applies must have shape {shape}, got {sides.shape}, {applies.shape}"
            )
        y0 = np.clip(broadcast_legs(offset0_nm, n + 1, "offset0_nm"), *self.corridor.offset_bounds())
        v0 = np.clip(broadcast_legs(stw0_kn, n, "stw0_kn"), self.v_min_kn, self.v_max_kn)
        fac = broadcast_legs(1.0 if leg_power_factor is None else leg_power_factor, n, "leg_power_factor")
        _, t0 = self.evaluate(y0, v0)
        lbg, ubg = np.zeros(self._ng), np.zeros(self._ng)
        betas = []
        for k, nlp in enumerate(self.members):
            table = self._rows[k]

            def set_rows(name: str, lo: Any, hi: Any, table: dict[str, tuple[int, int]] = table) -> None:
                a, b = table[name]
                lbg[a:b], ubg[a:b] = lo, hi

            set_rows("load", self.power.min_load, self.power.max_load)
            beta, lo, hi = nlp.band_edges(sides[k], applies[k])
            betas.append(beta)
            if self.n_bands:
                set_rows("band", lo, hi)
            if nlp.has_current_rows:
                set_rows("drift", -np.sqrt(0.75), np.sqrt(0.75))  # drift angle ≤ 60°, as SpeedNLP
                set_rows("sog", nlp.sog_min_kn, np.inf)
            if nlp.exclusion is not None:
                set_rows("excl", 0.0, np.inf)
        y_lo, y_hi = self.corridor.offset_bounds()
        t_lo, t_hi = np.zeros((mm, n + 1)), np.full((mm, n + 1), np.inf)
        t_hi[:, 0] = 0.0
        if eta_h is not None:
            t_hi[:, n] = eta_h
        lbx = [y_lo, self.v_min_kn, t_lo.ravel()]
        ubx = [y_hi, self.v_max_kn, t_hi.ravel()]
        x0 = [y0, v0, t0.ravel()]
        p = np.concatenate([weights, *betas, fac])
        if self.risk == "cvar":
            a, b = self._cvar_rows
            lbg[a:b], ubg[a:b] = 0.0, np.inf
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
        viol = max(
            float(np.max(np.concatenate([[0.0], lbg - g, g - ubg]))),
            float(np.max(np.concatenate([[0.0], lbx_a - x, x - ubx_a]))),
        )
        y, v, t = self._split(x)
        states = tuple(nlp.evaluate(y, v, tk) for nlp, tk in zip(self.members, t, strict=True))
        fuel = np.array([float(np.sum(nlp.leg_fuel_t(y, v, tk))) for nlp, tk in zip(self.members, t, strict=True)])
        return RobustResult(
            status=str(stats.get("return_status", "unknown")),
            success=bool(stats.get("success", False)),
            iterations=int(stats.get("iter_count", -1)),
            solves=1,
            solve_time_s=elapsed,
            objective=float(sol["f"]),
            member_objective=np.asarray(self._objectives(x, p), dtype=float).ravel(),
            member_fuel_t=fuel,
            var=float(x[self._nx - 1 - mm]) if self.risk == "cvar" else float("nan"),
            offset_nm=y,
            stw_kn=v,
            time_h=t,
            states=states,
            sides=sides.astype(np.int8),
            applies=applies,
            sides_settled=True,
            max_violation=viol,
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
        solve, a sample where a band now applies in a member (``Hs ≥ hs_min`` there) is added to that
        member's imposed rows with the side the solution is on (:func:`select_sides`, the nearer edge
        inside the band). Stops when nothing is added or after ``max_solves`` solves
        (``sides_settled`` False). Keyword arguments as :meth:`solve`.
        """
        states, _ = self.evaluate(offset0_nm, stw0_kn)
        sides, applies = self.default_sides(states)
        y0, v0 = offset0_nm, stw0_kn
        iterations, elapsed, solves = 0, 0.0, 0
        while True:
            res = self.solve(sides=sides, applies=applies, offset0_nm=y0, stw0_kn=v0, **kwargs)
            iterations, elapsed, solves = iterations + res.iterations, elapsed + res.solve_time_s, solves + 1
            new = np.stack([s.applies for s in res.states]) & ~applies
            if self.n_bands:
                lower = np.array([b.lower for b in self.members[0].bands])
                upper = np.array([b.upper for b in self.members[0].bands])
                ratio = np.stack([s.ratio for s in res.states])
                sides = np.where(new, select_sides(ratio, lower, upper), sides).astype(np.int8)
            settled = not new.any()
            if settled or solves >= max_solves:
                break
            applies = applies | new
            y0, v0 = res.offset_nm, res.stw_kn
        return replace(res, iterations=iterations, solve_time_s=elapsed, solves=solves, sides_settled=settled)
