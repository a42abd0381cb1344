"""The elastic phase-1 problem of the corridor NLP: a feasible start, or where and why there is none.

Ipopt's phase 2 (:meth:`formulations.speed_nlp.SpeedNLP.solve`) needs a start from which the rows can
be satisfied, and says little when they cannot (``Infeasible_Problem_Detected``: which row, where?).
The elastic problem gives every safety row a slack ``σ ≥ 0`` and the ETA one hour-slack ``σ_T ≥ 0``,
keeps the ship's kinematics exact (the time dynamics, the drift and SOG rows), and minimises

    Σ σ_load + Σ σ_band + Σ σ_excl + w_T σ_T          (w_T ≪ 1: the ETA gives way first)

over the same variables (offsets, speeds, times) and the same model
(:meth:`SpeedNLP.symbolic_model`, the rows of :meth:`SpeedNLP.solve`):

* engine load ``min_load − σ ≤ P/MCR ≤ max_load + σ`` (one slack per sample);
* danger bands **without a side**: where both edges are finite, ``4 (ρ − lower)(upper − ρ) /
  (upper − lower)² ≤ σ`` (≤ 0 exactly outside the band; 1 at its centre), written with the NLP's own
  scaled residuals at either edge; a band with one edge, that edge's one-sided row; only where the band
  is declared applicable (``applies``, as the NLP);
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

from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from formulations.common import FormulationInputError, broadcast_legs
from formulations.speed_nlp import IPOPT_DEFAULTS, SpeedNLP

__all__ = ["ETA_WEIGHT", "SLACK_TOL", "Phase1Result", "solve_phase1"]

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

    @property
    def safety_slack(self) -> float:
        """The largest slack of a load, band or exclusion row."""
        parts = [self.load_slack.ravel(), self.excl_slack.ravel(), self.band_slack.ravel(), [0.0]]
        return float(np.max(np.concatenate(parts)))

    @property
    def feasible(self) -> bool:
        """Every slack (the ETA's included) within :data:`SLACK_TOL`, at a converged point."""
        return self.success and self.safety_slack <= SLACK_TOL and self.eta_slack_h <= SLACK_TOL

    def worst(self) -> tuple[str, int, float, float, float]:
        """The worst safety row: (kind ``"load"``, ``"exclusion"`` or ``"band:<name>"``, leg, fraction, time [h], slack)."""
        cands = [("load", self.load_slack), ("exclusion", self.excl_slack)]
        cands += [(f"band:{name}", self.band_slack[:, :, b]) for b, name in enumerate(self.band_names)]
        kind, arr = max(cands, key=lambda c: float(np.max(c[1])) if c[1].size else -np.inf)
        k, j = np.unravel_index(int(np.argmax(arr)), arr.shape)
        return kind, int(k), float(self.sample_fraction[k, j]), float(self.sample_time_h[k, j]), float(arr[k, j])


def _band_rows(nlp: SpeedNLP, res_lo: Any, res_hi: Any) -> Any:
    """Side-free band rows (band-major, N·M·B): ≤ 0 outside the band (module docstring)."""
    k_ = nlp.n_legs * nlp.samples_per_leg
    rows = []
    for b, band in enumerate(nlp.bands):
        lo, hi = res_lo[b * k_ : (b + 1) * k_], res_hi[b * k_ : (b + 1) * k_]
        if np.isfinite(band.lower) and np.isfinite(band.upper):
            rows.append(-4.0 * lo * hi / (lo - hi) ** 2)
        elif np.isfinite(band.lower):
            rows.append(lo)
        else:
            rows.append(-hi)
    return ca.vertcat(*rows)


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
    """Solve the elastic problem of ``nlp`` (its model, bounds, load limits and bands) from a start.

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
    n, m, nb = nlp.n_legs, nlp.samples_per_leg, nlp.n_bands
    k_ = n * m
    app = np.asarray(applies, dtype=bool)
    if app.shape != (n, m, nb):
        raise FormulationInputError(f"applies must have shape {(n, m, nb)}, got {app.shape}")
    y0 = broadcast_legs(offset0_nm, n + 1, "offset0_nm")
    v0 = broadcast_legs(stw0_kn, n, "stw0_kn")
    t0 = nlp.consistent_times(y0, v0) if time0_h is None else broadcast_legs(time0_h, n + 1, "time0_h")
    nx = 3 * n + 2
    x = ca.MX.sym("x", nx)
    y, v, t = x[: n + 1], x[n + 1 : 2 * n + 1], x[2 * n + 1 :]
    s_load, s_excl = ca.MX.sym("s_load", k_), ca.MX.sym("s_excl", k_)
    s_band, s_eta = ca.MX.sym("s_band", k_ * nb), ca.MX.sym("s_eta")
    fac = ca.DM(nlp.leg_power_factor)
    lower = np.array([b.lower if np.isfinite(b.lower) else 0.0 for b in nlp.bands])
    upper = np.array([b.upper if np.isfinite(b.upper) else 0.0 for b in nlp.bands])
    mdl = nlp.symbolic_model(y, v, t, ca.DM(np.repeat(lower, k_)), fac)
    parts = [(t[1:] - t[:-1]) - mdl["dt_leg"], mdl["load"] + s_load, mdl["load"] - s_load]
    pw = nlp.power
    lbg = [np.zeros(n), np.full(k_, pw.min_load), np.full(k_, -np.inf)]
    ubg = [np.zeros(n), np.full(k_, np.inf), np.full(k_, pw.max_load)]
    if nb:
        hi_model = nlp.symbolic_model(y, v, t, ca.DM(np.repeat(upper, k_)), fac)
        parts.append(_band_rows(nlp, mdl["band_res"], hi_model["band_res"]) - s_band)
        on = np.transpose(app.reshape(k_, nb)).ravel()  # band-major
        lbg.append(np.full(k_ * nb, -np.inf))
        ubg.append(np.where(on, 0.0, np.inf))
    if nlp.has_current_rows:
        parts += [mdl["h_perp"], mdl["sog"]]
        lbg += [np.full(k_, -np.sqrt(0.75)), np.full(k_, nlp.sog_min_kn)]
        ubg += [np.full(k_, np.sqrt(0.75)), np.full(k_, np.inf)]
    if nlp.exclusion is not None:
        parts.append(mdl["excl_res"] + s_excl)
        lbg.append(np.zeros(k_))
        ubg.append(np.full(k_, np.inf))
    if eta_h is not None:
        parts.append(t[n] - s_eta)
        lbg.append([-np.inf])
        ubg.append([float(eta_h)])
    z = ca.vertcat(x, s_load, s_excl, s_band, s_eta)
    objective = ca.sum1(s_load) + ca.sum1(s_excl) + ca.sum1(s_band) + float(eta_weight) * s_eta
    opts = dict(IPOPT_DEFAULTS)
    opts.update(ipopt_options or {})
    solver = ca.nlpsol("phase1", "ipopt", {"x": z, "f": objective, "g": ca.vertcat(*parts)}, opts)
    y_lo, y_hi = nlp.corridor.offset_bounds()
    t_hi = np.full(n + 1, np.inf)
    t_hi[0] = 0.0
    zeros = np.zeros(2 * k_ + k_ * nb + 1)
    slack_hi = np.concatenate([
        np.full(k_, np.inf),
        np.full(k_, np.inf if nlp.exclusion is not None else 0.0),
        np.full(k_ * nb, np.inf),
        [np.inf if eta_h is not None else 0.0],
    ])  # fmt: skip
    lbx = np.concatenate([y_lo, nlp.v_min_kn, np.zeros(n + 1), zeros])
    ubx = np.concatenate([y_hi, nlp.v_max_kn, t_hi, slack_hi])
    start = np.concatenate([np.clip(y0, y_lo, y_hi), np.clip(v0, nlp.v_min_kn, nlp.v_max_kn), t0, zeros])
    sol = solver(x0=start, lbx=lbx, ubx=ubx, lbg=np.concatenate(lbg), ubg=np.concatenate(ubg))
    stats = solver.stats()
    zz = np.asarray(sol["x"], dtype=float).ravel()
    yy, vv, tt = zz[: n + 1], zz[n + 1 : 2 * n + 1], zz[2 * n + 1 : nx]
    sl = zz[nx:]
    frac = nlp.sample_layout.fraction
    return Phase1Result(
        status=str(stats.get("return_status", "unknown")),
        success=bool(stats.get("success", False)),
        iterations=int(stats.get("iter_count", -1)),
        offset_nm=yy,
        stw_kn=vv,
        time_h=tt,
        load_slack=np.maximum(sl[:k_], 0.0).reshape(n, m),
        excl_slack=np.maximum(sl[k_ : 2 * k_], 0.0).reshape(n, m),
        band_slack=np.maximum(np.transpose(sl[2 * k_ : 2 * k_ + k_ * nb].reshape(nb, k_)), 0.0).reshape(n, m, nb),
        eta_slack_h=max(float(sl[-1]), 0.0),
        sample_time_h=tt[:-1, None] + frac * np.diff(tt)[:, None],
        sample_fraction=frac,
        band_names=tuple(b.name or b.kind for b in nlp.bands),
    )
