"""SpeedNLP.with_edges: band edges per sample, against a hand-worked fixed path and the problem's own edges.

The sea is uniform following seas (wave propagation along the track), Tp 8 s and Hs 5 m, so the surf-riding ratio
``V cos χ / (A T)`` is ``V / (8 A)`` at every sample; with the band (0.4, 0.6) the speeds 9.71–14.56 kn are
forbidden. The fuel rate is ``k V³`` [t/h] (a constant SFOC), so a leg of ``d`` nm at ``V`` kn burns ``k d V²`` t.
"""

from __future__ import annotations

import numpy as np
import pytest

from formulations.common import (
    G_OVER_2PI_KN_S,
    Band,
    CorridorGeometry,
    FormulationInputError,
    PowerModel,
)
from formulations.speed_nlp import SpeedNLP
from formulations.weather_grid import WeatherGrid
from optroute.optimise.nlp_solve import edges_through

D_NM = np.array([100.0, 100.0])
K = 1e-3
CUBIC = PowerModel(calm_coef=[1.0], calm_exp=[3.0], mcr_kw=1e12, sfc_base_gpkwh=1e6, sfc_quad=(0.0, 0.0, 1.0))
FOLLOWING = WeatherGrid(
    t_h=[0.0], s_nm=[0.0], y_nm=[0.0], hs_m=5.0, period_s=8.0, wave_to_along=1.0, wave_to_across=0.0
)
SURF = Band("v_over_c", 0.4, 0.6, hs_min_m=4.0)
V_START_KN = 12.0  # inside the band: 12 / (8 A) = 0.494


def _nlp() -> SpeedNLP:
    return SpeedNLP(CorridorGeometry.straight(D_NM), FOLLOWING, CUBIC, bands=(SURF,), leg_power_factor=K,
                    samples_per_leg=2, v_min_kn=5.0, v_max_kn=25.0)  # fmt: skip


def _start(nlp: SpeedNLP):
    v = np.full(2, V_START_KN)
    t = np.concatenate([[0.0], np.cumsum(D_NM / v)])
    return np.zeros(3), v, t


def test_edges_through_a_start_inside_the_band_let_the_nlp_sail_it_and_reach_the_hand_worked_optimum() -> None:
    nlp = _nlp()
    y0, v0, t0 = _start(nlp)
    state = nlp.evaluate(y0, v0, t0)
    ratio = V_START_KN / (8.0 * G_OVER_2PI_KN_S)
    np.testing.assert_allclose(state.ratio, ratio, rtol=1e-12)
    assert state.inside.all()
    edges = edges_through(nlp, state)
    assert edges is not None
    lo, hi = edges
    np.testing.assert_allclose(lo, ratio, rtol=1e-12)  # the nearer edge (lower: 0.094 against 0.106) moved
    np.testing.assert_array_equal(hi, 0.6)
    through = nlp.with_edges(lo, hi)
    assert through._warm_solver is nlp._warm_solver  # the copy shares the built solvers, the warm-start one included
    assert not through.evaluate(y0, v0, t0).inside.any()
    assert nlp.evaluate(y0, v0, t0).inside.all()  # the original problem is unchanged
    eta_h = float(t0[-1])
    res = through.solve(eta_h=eta_h, offset0_nm=y0, stw0_kn=v0, time0_h=t0, fix_offsets=True)
    assert res.success, res.status
    # V ≤ 12 kn on both legs and 200 nm in 200/12 h: 12 kn on both, k d V² each
    np.testing.assert_allclose(res.stw_kn, V_START_KN, rtol=1e-6)
    np.testing.assert_allclose(res.total_fuel_t, K * D_NM.sum() * V_START_KN**2, rtol=1e-6)
    # the problem with its own edges cannot sail 12 kn: the start breaks its rows, and its optimum is another
    own = nlp.solve(eta_h=eta_h, offset0_nm=y0, stw0_kn=v0, time0_h=t0, fix_offsets=True)
    assert not own.success or not np.allclose(own.stw_kn, V_START_KN, rtol=1e-3)


def test_the_problems_own_edges_give_the_same_solution_bit_for_bit() -> None:
    nlp = _nlp()
    y0, v0, t0 = _start(nlp)
    v0 = np.full(2, 16.0)  # above the band
    t0 = np.concatenate([[0.0], np.cumsum(D_NM / v0)])
    kw = dict(eta_h=14.0, offset0_nm=y0, stw0_kn=v0, time0_h=t0, fix_offsets=True)
    a = nlp.solve(**kw)
    b = nlp.with_edges(*nlp.sample_edges()).solve(**kw)
    assert a.success and a.status == b.status
    np.testing.assert_array_equal(a.stw_kn, b.stw_kn)
    assert edges_through(nlp, nlp.evaluate(y0, v0, t0)) is None  # a start outside every band moves no edge


@pytest.mark.parametrize(
    "lower, upper, says",
    [
        (np.full((2, 2), 0.4), np.full((2, 2), 0.6), "shape"),
        (np.full((2, 2, 1), 0.7), np.full((2, 2, 1), 0.6), "lower <= upper"),
        (np.full((2, 2, 1), -np.inf), np.full((2, 2, 1), 0.6), "finite exactly where"),
    ],
)
def test_bad_sample_edges_are_refused(lower, upper, says) -> None:
    with pytest.raises(FormulationInputError, match=says):
        _nlp().with_edges(lower, upper)
