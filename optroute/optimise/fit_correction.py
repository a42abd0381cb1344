"""First-order defect correction of the NLP's fitted power model at a solution.

The corridor NLP sees the performance model (e.g. Kwon's speed loss, physics.md §6) through a
least-squares fit of a closed form (:func:`optroute.optimise.nlp_inputs.fit_power_model`; its largest error
is ~16 % on the benchmark corridors). Its optimum is the fit's, not the model's. The verification
loop of :meth:`optroute.optimise.corridor_problem.PreparedCorridor.solve` corrects it per leg with the
NLP's multiplier ``M_k = f_k (V/V_k)^{e_k} exp(a_k τ tanh((t̄ − T_k)/τ))``
(:class:`formulations.speed_nlp.SpeedNLP`; ``t̄`` the leg's mid-time [h], ``τ`` = 1 h), chosen so
that at the solution (speed ``V_k*``, mid-time ``t̄_k*``) the corrected fitted leg-mean power
matches the model's

* in level: ``f_k ← M_k(V_k*, t̄_k*) · P_true / P_nlp``, ``V_k ← V_k*``, ``T_k ← t̄_k*``;
* in speed elasticity: ``e_k ← e_k + E_true − E_nlp`` with ``E = ∂ ln P / ∂ ln V``;
* in time slope, relaxed: ``a_k ← a_k + κ (A_true − A_nlp)`` with ``A = ∂ ln P / ∂t`` [1/h] and
  ``κ`` = :data:`TIME_RELAXATION`;

each derivative by a central difference of both models on the same track and schedule (speed
×(1 ± ε), schedule shifted by ± δt). The time slope is how the weather met on a leg changes with
its timing: the fit's error in it (its sea-state and encounter-angle dependence) is what decides
when to meet a moving storm. Its term saturates beyond ``τ`` (tanh) so that the optimiser cannot
ride a linear extrapolation hours away, and is relaxed because the full step oscillates.

At a fixed point the corrected model and the true one agree in value and in these derivatives
on every leg at the solution, so the solution satisfies the first-order optimality conditions in
speed and timing under the true model, not only under the fit — the modifier-adaptation idea of
Roberts' ISOPE (Roberts 1979, *Int. J. Control* 29, 189; Marchetti, Chachuat & Bonvin 2009, *Ind.
Eng. Chem. Res.* 48, 6022, where the filter gain is ``κ``). The true model (Kwon's piecewise
direction coefficients) is not smooth, so the iteration need not converge: the caller keeps the best
verified plan by the true model and stops when two corrected solves in a row do not improve it.

Measured on the storm benchmark (``benchmarks/bench_nlp.py`` section 4, 124 legs, true-model
fuel of the verified plan): fit optimum 338.31 t; level-only correction 338.31 t; level and speed
elasticity 338.00 t (converged in three corrections: level error 12.8 % → 2.1 % → 0.03 %); with the
relaxed time slope 336.58 t after three corrections — below the finest 3-D DP's 337.20 t. With
``κ`` = 1 the iteration oscillated (best 337.45 t), with 0.5 it reached 337.15 t.

A trust-region variant (each correction step solved in a box around the best verified point,
widened after an improving step and halved otherwise) was tried: on the benchmark it reached the same
336.58 t; on a storm crossing its track it stopped at 82.74 t against 81.95 t for the plain iteration,
because Kwon's steps make even small corrected steps unreliable — exploring with whole corrected
solves and keeping the best does better there.

Not corrected: the derivative in lateral offset (tried, with no gain on the benchmark: 338.00 →
337.97 t) and the band, load and drift constraints (the verification re-checks them with the true
model).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from formulations.speed_nlp import SpeedNLP
from optroute.plan.evaluate import evaluate_track
from optroute.plan.result import Plan, PlanContext
from optroute.units import timedelta_to_h as _td_h

__all__ = ["FitCorrection", "fit_correction"]

REL_STEP = 0.01  # ε of the central difference in speed [-]
MAX_EXPONENT_STEP = 1.0  # largest change of e_k in one correction [-]
MAX_EXPONENT = 4.0  # |e_k| bound [-]
TIME_STEP_H = 0.25  # δt of the central difference in time [h]
MAX_TIME_SLOPE_STEP = 0.1  # largest change of a_k in one correction [1/h]
MAX_TIME_SLOPE = 0.5  # |a_k| bound [1/h]
TIME_RELAXATION = 0.3  # κ: the share of the time-slope defect corrected per step (1 oscillates on the benchmark)


@dataclass(frozen=True)
class FitCorrection:
    """The corrected per-leg multiplier and how far the fit was off at the solution.

    Attributes
    ----------
    factor : numpy.ndarray
        ``f_k`` [-], shape (N,).
    terms : dict of str to numpy.ndarray
        The multiplier's other terms by name (:data:`formulations.speed_nlp.POWER_TERMS`), shape (N,) each.
    level_error : float
        Largest ``|P_true / P_nlp − 1|`` over the legs at the solution [-].
    slope_error : float
        Largest ``|E_true − E_nlp|``, the change of the speed elasticity ``e_k`` [-].
    time_slope_error : float
        Largest ``|∂ ln P_true/∂t − ∂ ln P_nlp/∂t|`` [1/h] (before relaxation and clipping).
    """

    factor: np.ndarray
    terms: dict[str, np.ndarray]
    level_error: float
    slope_error: float
    time_slope_error: float


def _leg_means(leg: np.ndarray, weights: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    p = np.where(np.isfinite(values), values, np.nan)
    w = np.where(np.isfinite(p), weights, 0.0)
    wsum = np.bincount(leg, weights=w, minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.bincount(leg, weights=w * np.nan_to_num(p), minlength=n) / wsum


def _true_power(ctx: PlanContext, plan: Plan, stw_kn: np.ndarray, step_nm: float, shift_h: float = 0.0) -> np.ndarray:
    """Time-weighted leg-mean power of the true model [kW] at speeds ``stw_kn`` on the plan's track and schedule."""
    sched_h = _td_h(plan.times - plan.times[0]) + shift_h
    ev = evaluate_track(ctx, plan.waypoints, stw_kn, plan.departure, sched_h, step_nm)
    return _leg_means(ev.leg, ev.dt_h, ev.power, stw_kn.size)


def _log_ratio(up: np.ndarray, down: np.ndarray) -> np.ndarray:
    ok = np.isfinite(up) & np.isfinite(down) & (up > 0) & (down > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(ok, np.log(np.where(ok, up / np.where(ok, down, 1.0), 1.0)), np.nan)


def fit_correction(
    ctx: PlanContext,
    plan: Plan,
    nlp: SpeedNLP,
    offset_nm: np.ndarray,
    stw_kn: np.ndarray,
    time_h: np.ndarray,
    *,
    step_nm: float,
) -> FitCorrection:
    """The first-order correction of the NLP's power multiplier at a solution (see the module docstring).

    Parameters
    ----------
    ctx : PlanContext
        The true model and weather the plan is evaluated with.
    plan : Plan
        The plan of that point evaluated by the true model (its leg powers are ``P_true(V*)``).
    nlp : SpeedNLP
        The NLP, with the multiplier it was solved with.
    offset_nm, stw_kn, time_h : numpy.ndarray
        The point to correct at (a solution, or a given start): offsets (N+1,) [nm, port +], speeds
        ``V*`` (N,) [kn], waypoint times (N+1,) [h since departure].
    step_nm : float
        Resampling step of the true-model evaluation [nm] (the plan's).

    Returns
    -------
    FitCorrection
        Legs where either model gives no finite positive power keep their elasticity (and their
        level where ``P_true`` is missing); the level ratio is clipped to [0.5, 2] and the elasticity
        step to ±:data:`MAX_EXPONENT_STEP`, its value to ±:data:`MAX_EXPONENT` (a safeguard against a
        wild first iterate).
    """
    v = np.asarray(stw_kn, dtype=float)
    p_true = plan.legs["power_kw"].to_numpy(dtype=float)
    p_nlp = nlp.evaluate(offset_nm, v, time_h).power_kw.mean(axis=1)
    good = np.isfinite(p_true) & (p_true > 0) & (p_nlp > 0)
    up, down = v * (1.0 + REL_STEP), v * (1.0 - REL_STEP)
    e_true = _log_ratio(_true_power(ctx, plan, up, step_nm), _true_power(ctx, plan, down, step_nm))
    e_nlp = _log_ratio(
        nlp.evaluate(offset_nm, up, time_h).power_kw.mean(axis=1),
        nlp.evaluate(offset_nm, down, time_h).power_kw.mean(axis=1),
    )
    t = np.asarray(time_h, dtype=float)
    a_true = _log_ratio(
        _true_power(ctx, plan, v, step_nm, TIME_STEP_H), _true_power(ctx, plan, v, step_nm, -TIME_STEP_H)
    )
    a_nlp = _log_ratio(
        nlp.evaluate(offset_nm, v, t + TIME_STEP_H).power_kw.mean(axis=1),
        nlp.evaluate(offset_nm, v, t - TIME_STEP_H).power_kw.mean(axis=1),
    )
    d_a = (a_true - a_nlp) / (2.0 * TIME_STEP_H)
    d_a = TIME_RELAXATION * np.clip(
        np.where(good & np.isfinite(d_a), d_a, 0.0), -MAX_TIME_SLOPE_STEP, MAX_TIME_SLOPE_STEP
    )
    slope_a = np.clip(nlp.leg_power_terms["time_slope_per_h"] + d_a, -MAX_TIME_SLOPE, MAX_TIME_SLOPE)
    t_mid = 0.5 * (t[:-1] + t[1:])
    ratio = np.clip(np.where(good, p_true / np.where(good, p_nlp, 1.0), 1.0), 0.5, 2.0)
    d_e = (e_true - e_nlp) / np.log((1.0 + REL_STEP) / (1.0 - REL_STEP))
    d_e = np.clip(np.where(good & np.isfinite(d_e), d_e, 0.0), -MAX_EXPONENT_STEP, MAX_EXPONENT_STEP)
    exponent = np.clip(nlp.leg_power_terms["exponent"] + d_e, -MAX_EXPONENT, MAX_EXPONENT)
    return FitCorrection(
        factor=nlp.leg_power_multiplier(v, t_mid) * ratio,
        terms={"exponent": exponent, "ref_kn": v.copy(), "time_slope_per_h": slope_a, "ref_time_h": t_mid},
        level_error=float(np.max(np.abs(ratio - 1.0), initial=0.0)),
        slope_error=float(np.max(np.abs(d_e), initial=0.0)),
        time_slope_error=float(np.max(np.abs(d_a), initial=0.0) / TIME_RELAXATION),
    )
