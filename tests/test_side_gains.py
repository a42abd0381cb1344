"""The side search's estimate of a release, and the search trying only the releases it estimates to improve.

A release moves a (leg, band) group held below the band's threshold (the third disjunct of Boeing EP 2145155's
band, "Hs < 0.04 L") to the ratio side its samples are on. Its estimate is checked against the NLP's own
evaluation of the leg at every speed of the grid, one speed at a time (``SpeedNLP.evaluate``, a path apart from the
estimate's vectorised one); the search's use of it on a two-solve toy whose outcomes are written out by hand.
"""

from __future__ import annotations

import numpy as np
import pytest

from formulations.common import BELOW_SIDE
from formulations.disjunctive import InnerOutcome, improve_sides
from optroute.optimise.side_gains import leg_costs, release_gains
from tests.test_nlp_row_legs import _problem


def test_release_estimate_is_the_legs_least_lagrangian_cost_by_the_nlps_own_evaluation_at_each_speed() -> None:
    nlp, _ = _problem()
    n = nlp.n_legs
    v0 = np.full(n, 15.0)  # following seas: inside the synchronous band where the storm's seas stay below 3 m
    y0 = np.zeros(n + 1)
    t0 = nlp.consistent_times(y0, v0)
    sides, applies = nlp.default_sides(nlp.evaluate(y0, v0, t0))
    res = nlp.solve(eta_h=float(t0[-1]), sides=sides, applies=applies, offset0_nm=y0, stw0_kn=v0, time0_h=t0)
    assert res.success
    below = (res.sides == BELOW_SIDE) & ~res.applies
    assert below.any()
    lower, upper = nlp.sample_edges()
    take = np.where(res.samples.ratio <= 0.5 * (lower + upper), -1, 1).astype(np.int8)  # the nearer ratio side
    costs = leg_costs(nlp, res, objective="fuel", fuel_price=1.0, hourly_cost=0.0)
    gain = release_gains(nlp, res, take, costs)
    lam, d = max(res.eta_multiplier, 0.0), res.distance_nm
    w = np.broadcast_to(nlp.sample_layout.weight, (n, nlp.samples_per_leg))
    speeds = np.linspace(float(np.min(nlp.v_min_kn)), float(np.max(nlp.v_max_kn)), 96)
    finite = 0
    for i, b in zip(*np.nonzero(below.any(axis=1)), strict=True):
        cost, ok = np.empty(speeds.size), np.empty(speeds.size, dtype=bool)
        for k, v in enumerate(speeds):
            stw = res.stw_kn.copy()
            stw[i] = v
            st = nlp.evaluate(res.offset_nm, stw, res.time_h)  # the samples held where and when they are
            r, lo, up = st.ratio[i], lower[i], upper[i]
            on = np.where(take[i] < 0, r <= lo, r >= up)
            kept = np.where(res.sides[i] < 0, r <= lo, r >= up)
            sides_ok = np.where(below[i], on, ~res.applies[i] | kept).all()
            load_ok = ((st.load[i] >= nlp.power.min_load) & (st.load[i] <= nlp.power.max_load)).all()
            ok[k] = sides_ok and load_ok
            cost[k] = d[i] / v * (np.sum(w[i] * st.fuel_rate_tph[i]) + lam)
        now = d[i] / res.stw_kn[i] * (np.sum(w[i] * res.samples.fuel_rate_tph[i]) + lam)
        step = np.max(np.abs(np.diff(cost)))
        want = np.min(np.where(ok, cost, np.inf)) - step - now
        assert gain[i, 0, b] == pytest.approx(want, rel=1e-9, abs=1e-9), (i, b)
        finite += np.isfinite(want)
    assert finite > 0  # some release is priced, not only ruled out
    assert np.isinf(gain[:, 0, :][~below.any(axis=1)]).all()  # a group with nothing to release


def _toy(release_objective: float, release_estimate: float, calls: list[str]):
    """One group on the third side with a binding row; its release (side -1, the band imposed) gives
    ``release_objective`` against 10.0 held below. Every estimate the search asks for is logged in ``calls``."""

    def estimate(name: str, value: float):
        def made() -> np.ndarray:
            calls.append(name)
            return np.full((1, 1, 1), value)

        return made

    def solve(sides: np.ndarray, applies: np.ndarray) -> InnerOutcome:
        released = bool(applies.all())
        name = "release" if released else "held"
        return InnerOutcome(
            feasible=True,
            objective=release_objective if released else 10.0,
            active=np.full((1, 1, 1), not released),
            weight=np.ones((1, 1, 1)),
            applies=applies.copy(),
            side_at_solution=np.full((1, 1, 1), -1, dtype=np.int8),
            gain=estimate(f"{name} flip", np.inf),
            release_gain=estimate(f"{name} release", np.inf if released else release_estimate),
        )

    sides, applies = np.full((1, 1, 1), BELOW_SIDE, dtype=np.int8), np.zeros((1, 1, 1), dtype=bool)
    return improve_sides(solve, sides, applies, flippable=np.zeros((1, 1, 1), dtype=bool), pairs=False)


def test_a_release_estimated_not_to_improve_is_not_solved() -> None:
    calls: list[str] = []
    out = _toy(release_objective=9.0, release_estimate=np.inf, calls=calls)
    assert (out.n_solves, out.objective, out.finished) == (1, 10.0, True)
    assert calls == ["held release"]


def test_a_release_estimated_to_improve_is_solved_and_kept_when_it_does() -> None:
    calls: list[str] = []
    out = _toy(release_objective=9.0, release_estimate=-0.5, calls=calls)
    assert (out.n_solves, out.objective, out.finished) == (2, 9.0, True)
    assert out.sides.item() == -1 and out.applies.item()
    assert calls == ["held release"]  # no flip to screen, and the release solution has nothing to release


def test_a_trial_the_search_rejects_is_never_estimated() -> None:
    calls: list[str] = []
    out = _toy(release_objective=11.0, release_estimate=-0.5, calls=calls)
    assert (out.n_solves, out.objective, out.finished) == (2, 10.0, True)
    assert calls == ["held release"]  # the rejected release's own estimates are never made
