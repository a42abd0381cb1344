"""What a band side is worth: the side search's reach test and its Lagrangian estimates of a move.

The side search (:func:`formulations.disjunctive.improve_sides`) moves (leg, band) groups between the sides of a
danger band (Boeing EP 2145155: ``ratio ≤ lower``, ``ratio ≥ upper``, or ``Hs`` below the band's threshold). Each
move it tries costs a full NLP solve, so it tries only those these estimates do not rule out:

* :func:`flippable_groups`: the groups whose both sides a speed within the power limits reaches;
* :func:`flip_gains`: the change of the objective when a group moves to the other ratio side;
* :func:`release_gains`: the change when a group held below the band's threshold ("Hs below", where the start lay
  inside the band's ratio interval) takes the ratio side its samples are on instead.

Both estimates price a leg by its Lagrangian cost over a grid of speeds, with the NLP's own tabulated model and
its samples held where and when they are (:func:`leg_costs`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from formulations.common import BELOW_SIDE, PowerModel
from formulations.speed_nlp import NLPResult, SpeedNLP

__all__ = ["LegCosts", "flip_gains", "flippable_groups", "leg_costs", "release_gains"]


def flippable_groups(
    nlp: SpeedNLP, state: Any, offset_nm: np.ndarray, time_h: np.ndarray, n_speeds: int = 24
) -> np.ndarray:
    """(leg, band) groups whose both sides a ship can reach at every sample (speed and power bounds).

    At the samples of ``state`` (the warm start: offsets (N+1,) [nm], times (N+1,) [h]) each side of a
    band is tested on ``n_speeds`` speeds in the NLP's speed range, with the NLP's own power
    (:meth:`SpeedNLP.power_at_speeds`, the tabulated ship model) within the load limits. A side no
    allowed speed reaches cannot be flipped to: the flip would only cost a failed solve. The side a sample of the
    start is on counts as reachable. Shape
    (N, m, B), constant over the samples of a group.
    """
    n, m, nb = nlp.n_legs, nlp.samples_per_leg, nlp.n_bands
    speeds = np.linspace(float(np.min(nlp.v_min_kn)), float(np.max(nlp.v_max_kn)), n_speeds)
    power, _ = nlp.power_at_speeds(offset_nm, time_h, speeds)
    ok_power = _load_ok(nlp.power, power)
    ratio = _ratios_at_speeds(nlp, state, speeds)
    out = np.zeros((n, m, nb), dtype=bool)
    lower, upper = nlp.sample_edges()
    for i, b in enumerate(nlp.bands):
        if len(b.allowed_sides) < 2:
            continue
        # a side the start is on is reachable (the speed grid can miss a narrow window: above the surf-riding band
        # and below the engine's limit, 25.60-25.62 kn for the 54 000 dwt ship in a following-seas case)
        lo, hi = lower[:, :, i], upper[:, :, i]
        low = (state.ratio[:, :, i] <= lo) | np.any(ok_power & (ratio[:, :, i] <= lo[:, :, None]), axis=-1)
        high = (state.ratio[:, :, i] >= hi) | np.any(ok_power & (ratio[:, :, i] >= hi[:, :, None]), axis=-1)
        both = low & high
        out[:, :, i] = np.all(both | ~state.applies[:, :, i], axis=1)[:, None]
    return out


@dataclass(frozen=True)
class LegCosts:
    """Each leg's Lagrangian cost over a grid of speeds through water, the samples held (:func:`leg_costs`).

    Attributes
    ----------
    cost : numpy.ndarray, shape (N, K)
        ``w_f · (d/V) · r(V) + (w_t + λ) · d/V`` at each leg and grid speed V [objective units].
    cost_now : numpy.ndarray, shape (N,)
        The same at the solution's speed.
    step : numpy.ndarray, shape (N,)
        The largest change of ``cost`` between neighbouring grid speeds in the leg's range (the grid can miss a
        band's edge by one step).
    allowed : numpy.ndarray of bool, shape (N, K)
        The speed is within the leg's speed range and every sample's power within the load limits.
    keep : numpy.ndarray of bool, shape (N, m, B, K)
        The sample stays on its imposed side of the band (True where the band is not imposed).
    low, high : numpy.ndarray of bool, shape (N, m, B, K)
        The sample's ratio is at or below the band's lower edge, at or above its upper edge.
    """

    cost: np.ndarray
    cost_now: np.ndarray
    step: np.ndarray
    allowed: np.ndarray
    keep: np.ndarray
    low: np.ndarray
    high: np.ndarray


def leg_costs(
    nlp: SpeedNLP, res: NLPResult, *, objective: str, fuel_price: float, hourly_cost: float, n_speeds: int = 96
) -> LegCosts | None:
    """The Lagrangian cost table of a solve's legs (:class:`LegCosts`); None where no estimate is made.

    With the ETA's multiplier λ of the solve ``res`` (objective units per h) a leg's Lagrangian cost at speed
    through water V [kn] is ``w_f · (d/V) · r(V) + (w_t + λ) · d/V`` (``d`` the leg's length [nm], ``r`` its
    fuel rate [t/h] at its samples, the NLP's own model with the samples held where and when they are;
    ``w_f, w_t`` = 1, 0 for fuel, the fuel price and hourly cost for cost), on ``n_speeds`` speeds over the NLP's
    range. None for the time objective, without bands, and where a current makes the speed over ground differ
    from the speed through water.
    """
    if objective == "time" or nlp.n_bands == 0 or nlp.has_current_rows:
        return None
    n, m = nlp.n_legs, nlp.samples_per_leg
    w_f, w_t = (float(fuel_price), float(hourly_cost)) if objective == "cost" else (1.0, 0.0)
    lam = max(float(res.eta_multiplier), 0.0)
    st = res.samples
    d = np.asarray(res.distance_nm, dtype=float)
    lo, hi = np.broadcast_to(nlp.v_min_kn, (n,)), np.broadcast_to(nlp.v_max_kn, (n,))
    speeds = np.linspace(float(np.min(lo)), float(np.max(hi)), n_speeds)
    power, rate = nlp.power_at_speeds(res.offset_nm, res.time_h, speeds)
    weight = np.broadcast_to(np.asarray(nlp.sample_layout.weight, dtype=float), (n, m))
    hours = d[:, None] / speeds[None, :]  # (N, K)
    cost = w_f * hours * np.einsum("ijk,ij->ik", rate, weight) + (w_t + lam) * hours
    now = d / np.asarray(res.stw_kn, dtype=float)
    cost_now = w_f * now * np.sum(st.fuel_rate_tph * weight, axis=1) + (w_t + lam) * now
    in_range = (speeds[None, :] >= lo[:, None] - 1e-9) & (speeds[None, :] <= hi[:, None] + 1e-9)
    jumps = np.abs(np.diff(np.where(in_range, cost, np.nan), axis=1))
    step = np.max(np.where(np.isfinite(jumps), jumps, 0.0), axis=1)
    ratio = _ratios_at_speeds(nlp, st, speeds)  # (N, m, B, K)
    lower, upper = (e[..., None] for e in nlp.sample_edges())  # (N, m, B, 1), as the rows impose them
    low, high = ratio <= lower, ratio >= upper
    side, app = res.sides[..., None], res.applies[..., None]
    keep = ~app | np.where(side < 0, low, high)
    allowed = np.all(_load_ok(nlp.power, power), axis=1) & in_range
    return LegCosts(cost, cost_now, step, allowed, keep, low, high)


def flip_gains(
    nlp: SpeedNLP,
    res: NLPResult,
    *,
    objective: str,
    fuel_price: float,
    hourly_cost: float,
    n_speeds: int = 96,
    costs: LegCosts | None = None,
) -> np.ndarray | None:
    """Lagrangian estimate of the objective change of flipping each (leg, band) group of a solve; None where none.

    Flipping the group (leg ``i``, band ``b``) moves leg ``i`` to the other side of band ``b``, keeping the sides
    of its other bands and the load limits: its estimate is the least Lagrangian cost (:func:`leg_costs`) over
    the speeds allowed there, less the largest step of the cost between neighbouring speeds, minus the leg's cost
    at the solution.

    On a fixed path in static weather without current, where each leg's cost is convex in its time, the rest
    of the passage's least cost is convex in the time left to it with slope −λ, so a flip of any set of
    groups on different legs gives at least the solution's objective plus the sum of their estimates
    (Lagrangian duality, as the ship's certificate): a move whose estimate is not negative cannot improve.
    Elsewhere (time-varying weather, lateral freedom) it is the first-order estimate of the same change.
    Shape (N, m, B), equal over a group's samples; +inf where the other side has no allowed speed. None where
    :func:`leg_costs` makes no table. ``costs``: that table, when already made for ``res``.
    """
    c = costs or leg_costs(nlp, res, objective=objective, fuel_price=fuel_price, hourly_cost=hourly_cost,
                           n_speeds=n_speeds)  # fmt: skip
    if c is None:
        return None
    side, app = res.sides[..., None], res.applies[..., None]
    flip = ~app | np.where(side < 0, c.high, c.low)
    return _gains(c, lambda b: flip[:, :, b])


def release_gains(nlp: SpeedNLP, res: NLPResult, take: np.ndarray, costs: LegCosts | None) -> np.ndarray | None:
    """Lagrangian estimate of releasing each (leg, band) group held below the band's threshold; None where none.

    A sample on the third side of a band ("Hs below the threshold", :data:`~formulations.common.BELOW_SIDE`,
    not imposed as a ratio side) is released to the ratio side ``take`` gives it (−1: ``ratio ≤ lower``, +1:
    ``ratio ≥ upper``; the side it is on at the solution), so that the ship may sail into the band's seas there.
    The estimate of releasing group (leg ``i``, band ``b``) is :func:`flip_gains`' with the released samples on
    their new side and every imposed side kept: the least Lagrangian cost over the speeds allowed there, less the
    grid's step, minus the leg's cost at the solution. The samples are held where and when they are, so the
    estimate prices the speed a release needs and not what the ship gains by then moving into the higher seas: a
    release that no speed at the held heading makes possible is +inf, as a flip to a side no speed reaches.
    Shape (N, m, B), equal over a group's samples; +inf where the group holds no sample below the threshold.
    ``costs``: :func:`leg_costs` of ``res`` (None: no estimate).
    """
    if costs is None:
        return None
    below = (res.sides == BELOW_SIDE) & ~res.applies
    side = np.asarray(take)[..., None]
    on_side = np.where(side < 0, costs.low, np.where(side > 0, costs.high, False))  # (N, m, B, K)
    gain = _gains(costs, lambda b: np.where(below[:, :, b, None], on_side[:, :, b], costs.keep[:, :, b]))
    return np.where(below.any(axis=1, keepdims=True), gain, np.inf)


def _gains(c: LegCosts, band_ok: Any) -> np.ndarray:
    """Per (leg, band): the least cost over the speeds where ``band_ok(b)`` (N, m, K) holds at every sample of the
    leg, the other bands keep their sides and the speed is allowed, less the grid's step and the cost now.
    Shape (N, m, B), equal over a leg's samples."""
    n, m, nb = c.keep.shape[:3]
    gain = np.full((n, nb), np.inf)
    for b in range(nb):
        others = np.all(np.delete(c.keep, b, axis=2), axis=2)
        ok = np.all(others & band_ok(b), axis=1) & c.allowed  # (N, K)
        best = np.min(np.where(ok, c.cost, np.inf), axis=1)
        gain[:, b] = best - c.step - c.cost_now
    return np.broadcast_to(gain[:, None, :], (n, m, nb)).copy()


def _load_ok(pw: PowerModel, power_kw: np.ndarray) -> np.ndarray:
    """Brake powers [kW] within the NLP's load limits (P/MCR in [min_load, max_load])."""
    load = power_kw / pw.mcr_kw
    return (load <= pw.max_load) & (load >= pw.min_load)


def _ratios_at_speeds(nlp: SpeedNLP, state: Any, speeds: np.ndarray) -> np.ndarray:
    """Every band's ratio (:class:`formulations.common.Band`) at the samples of ``state`` for speeds through water
    ``speeds`` (K,) [kn], the heading and sea held: shape (N, m, B, K), the NLP's own expressions."""
    v = np.asarray(speeds, dtype=float)[None, None, :]
    per = state.period_s[..., None]
    along = v * state.cos_chi[..., None]
    a = nlp.g_over_2pi
    out = np.empty((*np.shape(state.period_s), nlp.n_bands, v.size))
    for i, b in enumerate(nlp.bands):
        if b.kind == "te_over_tr":
            out[:, :, i] = a * per**2 / (b.param * np.maximum(np.abs(a * per - along), 1e-9))
        else:
            out[:, :, i] = along / {"v_over_c": a * per, "v_over_cg": 0.5 * a * per}.get(b.kind, b.param)
    return out
