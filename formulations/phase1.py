"""The elastic phase-1 problem of the corridor NLP: a feasible start, or where and why there is none.

Ipopt's phase 2 (:meth:`formulations.speed_nlp.SpeedNLP.solve`) needs a start from which the rows can
be satisfied, and says little when they cannot (``Infeasible_Problem_Detected``: which row, where?).
The elastic problem gives every safety row a slack ``σ ≥ 0`` and the ETA one hour-slack ``σ_T ≥ 0``,
keeps the ship's kinematics exact (the time dynamics, the drift and SOG rows), and minimises

    Σ σ_load + Σ σ_band + Σ σ_excl + w_T σ_T          (w_T ≪ 1: the ETA gives way first)

over the same variables (offsets, speeds, times), the same model and the same rows
(:meth:`SpeedNLP.symbolic_model` stacked by :func:`formulations._nlp_model.row_blocks`, the NLP's own) with
the same leg-by-leg derivatives (:class:`Phase1Problem`):

* engine load ``min_load ≤ P/MCR + σ⁺ − σ⁻ ≤ max_load`` (two slacks per sample, reported as their sum);
* danger bands **without a side**: where both edges are finite, ``4 (ρ − lower)(upper − ρ) /
  (upper − lower)² ≤ σ`` (≤ 0 exactly outside the band; 1 at its centre); a band with one edge, that
  edge's one-sided row (:func:`formulations._nlp_model.side_free_row`); only where the band is declared
  applicable (``applies``, as the NLP);
* exclusion circle ``excl_res + σ ≥ 0``;
* ETA ``t_N − σ_T ≤ T``.

At its optimum (a local one: Ipopt's):

* every slack 0: the point is feasible for the real problem, a start for phase 2 (its band sides are
  the sides it is on);
* safety slacks 0 and ``σ_T > 0``: no safe passage arrives by the ETA from here; the earliest arrival
  found is ``T + σ_T``;
* a safety slack > 0: no allowed speed was found at that sample: the leg, fraction and time name where.

Nothing here imports :mod:`optroute`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from formulations._nlp_model import side_free_row, structured_derivatives
from formulations.common import FormulationInputError, broadcast_legs
from formulations.ipopt_options import IPOPT_DEFAULTS
from formulations.row_layout import row_blocks, row_bounds
from formulations.speed_nlp import SpeedNLP

__all__ = ["ETA_WEIGHT", "SLACK_TOL", "Phase1Problem", "Phase1Result", "solve_phase1"]

#: Weight of the ETA's hour-slack against the safety slacks [1/h].
ETA_WEIGHT = 1e-3
#: A slack above this is a broken row at the phase-1 optimum (scaled units of the row).
SLACK_TOL = 1e-6


@dataclass(frozen=True)
class Phase1Result:
    """The elastic problem's optimum.

    Attributes
    ----------
    status : str
        Ipopt's ``return_status`` verbatim.
    success : bool
        CasADi's ``stats()["success"]``.
    iterations : int
        Ipopt iterations.
    offset_nm, stw_kn, time_h : numpy.ndarray
        The point: offsets (N+1,) [nm, port +], speeds (N,) [kn], waypoint times (N+1,) [h].
    load_slack, excl_slack : numpy.ndarray, shape (N, M)
        Slack of the engine-load row [fraction of MCR] and of the exclusion row (scaled) per sample.
    band_slack : numpy.ndarray, shape (N, M, B)
        Slack of each band's side-free row [-] (1: the band's centre).
    eta_slack_h : float
        Hours after the ETA [h] (0 without an ETA or when it is met).
    sample_time_h : numpy.ndarray, shape (N, M)
        When the ship is at each sample [h after departure].
    sample_fraction : numpy.ndarray, shape (N, M)
        Where each sample is along its leg [-].
    band_names : tuple of str
    solve_time_s : float
        Ipopt's wall-clock time [s].
    """

    status: str
    success: bool
    iterations: int
    offset_nm: np.ndarray
    stw_kn: np.ndarray
    time_h: np.ndarray
    load_slack: np.ndarray
    excl_slack: np.ndarray
    band_slack: np.ndarray
    eta_slack_h: float
    sample_time_h: np.ndarray
    sample_fraction: np.ndarray
    band_names: tuple[str, ...] = field(default=())
    solve_time_s: float = 0.0

    @property
    def safety_slack(self) -> float:
        """The largest slack of a load, band or exclusion row."""
        parts = [self.load_slack.ravel(), self.excl_slack.ravel(), self.band_slack.ravel(), [0.0]]
        return float(np.max(np.concatenate(parts)))

    @property
    def feasible(self) -> bool:
        """Every slack (the ETA's included) within :data:`SLACK_TOL`, at a converged point."""
        return self.success and self.safety_slack <= SLACK_TOL and self.eta_slack_h <= SLACK_TOL

    def worst(self, leg: int | None = None) -> tuple[str, int, float, float, float]:
        """The worst safety row (of ``leg``, or of all): (kind ``"load"``, ``"exclusion"`` or ``"band:<name>"``,
        leg, fraction, time [h], slack)."""
        sel = slice(None) if leg is None else slice(leg, leg + 1)
        cands = [("load", self.load_slack[sel]), ("exclusion", self.excl_slack[sel])]
        cands += [(f"band:{name}", self.band_slack[sel, :, b]) for b, name in enumerate(self.band_names)]
        kind, arr = max(cands, key=lambda c: float(np.max(c[1])) if c[1].size else -np.inf)
        k, j = np.unravel_index(int(np.argmax(arr)), arr.shape)
        at = int(k) if leg is None else leg
        return kind, at, float(self.sample_fraction[at, j]), float(self.sample_time_h[at, j]), float(arr[k, j])

    def slack_legs(self) -> np.ndarray:
        """The legs with a safety slack above :data:`SLACK_TOL`, in sailing order."""
        per_leg = np.maximum(self.load_slack.max(axis=1), self.excl_slack.max(axis=1))
        if self.band_slack.size:
            per_leg = np.maximum(per_leg, self.band_slack.max(axis=(1, 2)))
        return np.flatnonzero(per_leg > SLACK_TOL)


class Phase1Problem:
    """The elastic problem of ``nlp`` built once (its rows, model and bounds), solved for any applicability, ETA
    and start (:meth:`solve`).

    The rows are :meth:`SpeedNLP.symbolic_model`'s, stacked by the NLP's own
    :func:`formulations._nlp_model.row_blocks` (the band block side-free, :func:`side_free_row`), plus a constant
    slack matrix ``S``: ``g₁(x, σ) = g(x) + S σ`` and the ETA row ``t_N − σ_T``. Its derivatives are the NLP's
    leg-by-leg ones (:func:`formulations._nlp_model.structured_derivatives` with ``side_free_bands``) with ``S``
    beside the Jacobian and a zero block for the slacks in the Hessian (they enter linearly), so nothing
    differentiates the weather through CasADi (the corridor's weather is a numpy spline without CasADi
    derivatives, :class:`formulations._nlp_model.WeatherValues`).

    Parameters
    ----------
    nlp : SpeedNLP
        The problem (built with or without its solver).
    eta_weight : float
        :data:`ETA_WEIGHT`.
    ipopt_options : dict, optional
        Overrides of the Ipopt options.
    """

    def __init__(self, nlp: SpeedNLP, *, eta_weight: float = ETA_WEIGHT, ipopt_options: dict[str, Any] | None = None):
        self.nlp = nlp
        n, m, nb = nlp.n_legs, nlp.samples_per_leg, nlp.n_bands
        k_ = n * m
        has_excl = nlp.exclusion is not None
        nx = 3 * n + 2
        # slacks: load up, load down (K each), exclusion (one per sample on nlp.exclusion_legs, with a circle), bands
        # (B per sample on nlp.band_legs, band-major), ETA (1): one per row of the NLP's blocks
        self._n_excl = nlp.row_legs.exclusion_samples.size if has_excl else 0
        self._n_band = nlp.row_legs.band_samples.size * nb
        ns = 2 * k_ + self._n_excl + self._n_band + 1
        z = ca.MX.sym("x", nx + ns)
        p = ca.MX.sym("p", 2 + k_ * nb + n)  # SpeedNLP's parameters: weights, band edges, leg power factors
        y, v, t = z[: n + 1], z[n + 1 : 2 * n + 1], z[2 * n + 1 : nx]
        mdl = dict(nlp.symbolic_model(y, v, t, p[2 : 2 + k_ * nb], p[2 + k_ * nb :]))
        if nb:
            res, on = mdl["band_res"], nlp.row_legs.band_samples  # the band rows: on the samples of band_legs
            ratio, k_b = nlp.row_legs.select(mdl["ratio"], on), on.size
            mdl["band_res"] = ca.vertcat(*[
                side_free_row(b, ratio[:, i], res[i * k_b : (i + 1) * k_b]) for i, b in enumerate(nlp.bands)
            ])  # fmt: skip
        parts, rows = row_blocks(mdl, t, bands=bool(nb), current=nlp.has_current_rows, exclusion=has_excl)
        g_model = ca.vertcat(*parts)
        ng = g_model.shape[0]
        # S: which slack moves which row, and how
        r_idx, c_idx, val = [], [], []

        def couple(block: str, first_slack: int, sign: float) -> None:
            a, b = rows[block]
            r_idx.extend(range(a, b))
            c_idx.extend(range(first_slack, first_slack + b - a))
            val.extend([sign] * (b - a))

        couple("load", 0, 1.0)  # load + σ⁺ ≥ min_load
        couple("load", k_, -1.0)  # load − σ⁻ ≤ max_load
        if has_excl:
            couple("excl", 2 * k_, 1.0)
        if nb:
            couple("band", 2 * k_ + self._n_excl, -1.0)
        smat = ca.DM(ca.Sparsity.triplet(ng, ns, r_idx, c_idx), val)
        e_eta = np.zeros((1, nx + ns))
        e_eta[0, nx - 1], e_eta[0, -1] = 1.0, -1.0
        sig = z[nx:]
        g_all = ca.vertcat(g_model + ca.mtimes(smat, sig), ca.mtimes(ca.DM(e_eta), z))
        cost = np.concatenate([np.zeros(nx), np.ones(ns - 1), [float(eta_weight)]])
        der = structured_derivatives(nlp, exact_hessian=True, side_free_bands=True)
        self._keep = der  # the callbacks must outlive the solver that calls them
        g_m, j_m = der["jac_g"](z[:nx], p)
        lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", ng + 1)
        h_m = der["hess_lag"](z[:nx], p, lam_f, lam_g[:ng])
        funcs = {
            "grad_f": ca.Function(
                "grad_f", [z, p], [ca.dot(ca.DM(cost), z), ca.densify(ca.DM(cost))], ["x", "p"], ["f", "grad_f_x"]
            ),
            "jac_g": ca.Function(
                "jac_g",
                [z, p],
                [
                    ca.vertcat(g_m + ca.mtimes(smat, sig), ca.mtimes(ca.DM(e_eta), z)),
                    ca.vertcat(ca.horzcat(j_m, smat), ca.DM(ca.sparsify(ca.DM(e_eta)))),
                ],
                ["x", "p"],
                ["g", "jac_g_x"],
            ),  # fmt: skip
            "hess_lag": ca.Function(
                "hess_lag",
                [z, p, lam_f, lam_g],
                [ca.diagcat(h_m, ca.MX(ns, ns))],
                ["x", "p", "lam_f", "lam_g"],
                ["triu_hess_gamma_x_x"],
            ),
        }
        opts = dict(IPOPT_DEFAULTS)
        # a start on a band's centre (where its side-free row is stationary) is left for either edge: the adaptive
        # barrier's first steps took some legs to the lower edge, a local optimum with a load slack, where the
        # monotone barrier, keeping the iterates central longer, reached the feasible upper side
        # (tests/test_check_rows.py); from a ladder of starts both reach a feasible point equally often
        opts["ipopt.mu_strategy"] = "monotone"
        opts.update(ipopt_options or {})
        opts.update(funcs)
        nlp_def = {"x": z, "p": p, "f": ca.dot(ca.DM(cost), z), "g": g_all}
        self._solver = ca.nlpsol("phase1", "ipopt", nlp_def, opts)
        self._g_model = ca.Function("phase1_rows", [z, p], [g_model])
        self._rows, self._nx, self._ns, self._ng = rows, nx, ns, ng

    def solve(
        self,
        *,
        applies: np.ndarray,
        eta_h: float | None,
        offset0_nm: np.ndarray,
        stw0_kn: np.ndarray,
        time0_h: np.ndarray | None = None,
    ) -> Phase1Result:
        """The elastic problem's optimum from a start (arguments as :func:`solve_phase1`)."""
        nlp = self.nlp
        n, m, nb = nlp.n_legs, nlp.samples_per_leg, nlp.n_bands
        k_, nx, ns, ne = n * m, self._nx, self._ns, self._n_excl
        app = np.asarray(applies, dtype=bool)
        if app.shape != (n, m, nb):
            raise FormulationInputError(f"applies must have shape {(n, m, nb)}, got {app.shape}")
        if eta_h is not None and not (np.isfinite(eta_h) and eta_h > 0):
            raise FormulationInputError(f"eta_h must be a positive number of hours, got {eta_h}")
        y0 = broadcast_legs(offset0_nm, n + 1, "offset0_nm")
        v0 = broadcast_legs(stw0_kn, n, "stw0_kn")
        y_lo, y_hi = nlp.corridor.offset_bounds()
        y0, v0 = np.clip(y0, y_lo, y_hi), np.clip(v0, nlp.v_min_kn, nlp.v_max_kn)
        t0 = nlp.consistent_times(y0, v0) if time0_h is None else broadcast_legs(time0_h, n + 1, "time0_h")
        edge = [b.lower if np.isfinite(b.lower) else b.upper for b in nlp.bands]  # a one-edge band's residual
        p = np.concatenate([[0.0, 0.0], np.repeat(edge, k_), nlp.leg_power_factor])
        band = (
            (-np.inf, np.where(nlp.row_legs.band_rows_of(app & nlp.row_legs.band_legs[:, None, None]), 0.0, np.inf))
            if nb
            else None
        )
        lbg, ubg = row_bounds(self._rows, self._ng + 1, nlp.power, band=band,
                              sog_min_kn=nlp.sog_min_kn if nlp.has_current_rows else None,
                              exclusion=bool(ne))  # fmt: skip
        lbg[-1], ubg[-1] = -np.inf, (np.inf if eta_h is None else float(eta_h))
        t_hi = np.full(n + 1, np.inf)
        t_hi[0] = 0.0
        slack_hi = np.full(ns, np.inf)
        slack_hi[-1] = np.inf if eta_h is not None else 0.0
        lbx = np.concatenate([y_lo, nlp.v_min_kn, np.zeros(n + 1), np.zeros(ns)])
        ubx = np.concatenate([y_hi, nlp.v_max_kn, t_hi, slack_hi])
        x0 = np.concatenate([y0, v0, t0, np.zeros(ns)])
        x0[nx:] = self._start_slacks(x0, p, lbg, ubg, eta_h)
        started = time.perf_counter()
        sol = self._solver(x0=x0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        elapsed = time.perf_counter() - started
        stats = self._solver.stats()
        zz = np.asarray(sol["x"], dtype=float).ravel()
        yy, vv, tt = zz[: n + 1], zz[n + 1 : 2 * n + 1], zz[2 * n + 1 : nx]
        sl = np.maximum(zz[nx:], 0.0)
        frac = nlp.sample_layout.fraction
        band = sl[2 * k_ + ne : 2 * k_ + ne + self._n_band]
        return Phase1Result(
            status=str(stats.get("return_status", "unknown")),
            success=bool(stats.get("success", False)),
            iterations=int(stats.get("iter_count", -1)),
            offset_nm=yy,
            stw_kn=vv,
            time_h=tt,
            load_slack=(sl[:k_] + sl[k_ : 2 * k_]).reshape(n, m),
            excl_slack=nlp.row_legs.exclusion_samples_of(sl[2 * k_ : 2 * k_ + ne]) if ne else np.zeros((n, m)),
            band_slack=nlp.row_legs.band_samples_of(band) if nb else np.zeros((n, m, 0)),
            eta_slack_h=float(sl[-1]),
            sample_time_h=tt[:-1, None] + frac * np.diff(tt)[:, None],
            sample_fraction=frac,
            band_names=tuple(b.name or b.kind for b in nlp.bands),
            solve_time_s=elapsed,
        )

    def _start_slacks(
        self, x0: np.ndarray, p: np.ndarray, lbg: np.ndarray, ubg: np.ndarray, eta_h: float | None
    ) -> np.ndarray:
        """Slacks that make the start feasible for the elastic rows (each row's violation at the start)."""
        k_ = self.nlp.n_legs * self.nlp.samples_per_leg
        ne = self._n_excl
        g = np.asarray(self._g_model(x0, p), dtype=float).ravel()
        g = np.where(np.isfinite(g), g, 0.0)
        out = np.zeros(self._ns)
        a, b = self._rows["load"]
        out[:k_] = np.maximum(lbg[a:b] - g[a:b], 0.0)
        out[k_ : 2 * k_] = np.maximum(g[a:b] - ubg[a:b], 0.0)
        if ne:
            a, b = self._rows["excl"]
            out[2 * k_ : 2 * k_ + ne] = np.maximum(-g[a:b], 0.0)
        if self.nlp.n_bands:
            a, b = self._rows["band"]
            out[2 * k_ + ne : -1] = np.maximum(g[a:b] - ubg[a:b], 0.0)
        if eta_h is not None:
            out[-1] = max(float(x0[self._nx - 1]) - float(eta_h), 0.0)
        return out


def solve_phase1(
    nlp: SpeedNLP,
    *,
    applies: np.ndarray,
    eta_h: float | None,
    offset0_nm: np.ndarray,
    stw0_kn: np.ndarray,
    time0_h: np.ndarray | None = None,
    eta_weight: float = ETA_WEIGHT,
    ipopt_options: dict[str, Any] | None = None,
) -> Phase1Result:
    """Build the elastic problem of ``nlp`` (:class:`Phase1Problem`) and solve it once from a start.

    Parameters
    ----------
    nlp : SpeedNLP
        The problem (built with or without its solver).
    applies : numpy.ndarray of bool, shape (N, M, B)
        Where each band's row is imposed (as :meth:`SpeedNLP.solve`'s ``applies``).
    eta_h : float or None
        The ETA [h after departure] (arrive no later); None: no ETA row.
    offset0_nm, stw0_kn, time0_h : numpy.ndarray
        The start, shapes (N+1,), (N,), (N+1,) (times: consistent with the speeds by default).
    eta_weight : float
        :data:`ETA_WEIGHT`.
    ipopt_options : dict, optional
        Overrides of the Ipopt options.
    """
    return Phase1Problem(nlp, eta_weight=eta_weight, ipopt_options=ipopt_options).solve(
        applies=applies, eta_h=eta_h, offset0_nm=offset0_nm, stw0_kn=stw0_kn, time0_h=time0_h
    )
