"""The corridor NLP's build: the weather read in numpy equals CasADi's splines, and one build serves many ETAs.

References: the quasi-interpolant reproduces linear data exactly (Schoenberg; ``formulations.splines``), so its
derivatives on a linear field are the field's slopes; CasADi's ``Function.bspline`` of the same control points
and its derivative splines (de Boor 1978, ch. X) are the independent evaluation of the rest; a fresh build of
the same problem is the reference of a re-solve.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import formulations.speed_nlp as speed_nlp
from formulations.common import Band, CorridorGeometry, PowerModel, WeatherGrid
from formulations.speed_nlp import SpeedNLP

T_AXIS, S_AXIS, Y_AXIS = np.arange(0.0, 49.0, 6.0), np.linspace(0.0, 300.0, 7), np.linspace(-20.0, 20.0, 5)


def _grid(seed: int = 0) -> WeatherGrid:
    rng = np.random.default_rng(seed)
    shape = (T_AXIS.size, S_AXIS.size, Y_AXIS.size)
    tt = T_AXIS[:, None, None] + np.zeros(shape)
    hs = 2.0 + 4.0 * np.exp(-(((tt - 20.0) / 12.0) ** 2)) + rng.uniform(0.0, 0.5, shape)
    ratio = 1.0 + 0.08 * (hs[..., None, None] - 2.0) * np.ones((1, 1, 1, 3, 2)) + rng.uniform(0, 0.02, (*shape, 3, 2))
    return WeatherGrid(
        t_h=T_AXIS, s_nm=S_AXIS, y_nm=Y_AXIS, hs_m=hs, period_s=9.0 + rng.uniform(0.0, 1.0, shape),
        wave_to_along=-1.0, wave_to_across=0.3, power_ratio=ratio,
        ratio_speed_kn=[8.0, 13.0, 18.0], ratio_heading_deg=[-10.0, 10.0],
    )  # fmt: skip


def test_numpy_spline_reproduces_a_linear_field_and_its_slopes_exactly() -> None:
    shape = (T_AXIS.size, S_AXIS.size, Y_AXIS.size)
    t, s, y = np.meshgrid(T_AXIS, S_AXIS, Y_AXIS, indexing="ij")
    wx = WeatherGrid(
        t_h=T_AXIS, s_nm=S_AXIS, y_nm=Y_AXIS, hs_m=1.0 + 0.05 * t + 0.01 * s - 0.02 * y, period_s=np.full(shape, 8.0)
    )
    pts = np.vstack([np.linspace(0.0, 48.0, 31), np.linspace(5.0, 295.0, 31), np.linspace(-19.0, 19.0, 31)])
    out = wx.tensor_spline().evaluate(pts, 2)  # rows: [F, F_t, F_y, F_tt, F_ty, F_yy] × (hs, period)
    np.testing.assert_allclose(out[0], 1.0 + 0.05 * pts[0] + 0.01 * pts[1] - 0.02 * pts[2], rtol=1e-12)
    np.testing.assert_allclose(out[2], 0.05, rtol=1e-10)
    np.testing.assert_allclose(out[4], -0.02, rtol=1e-10)
    np.testing.assert_allclose(out[6:], 0.0, atol=1e-12)


def test_numpy_spline_equals_casadis_splines_inside_on_the_edges_and_outside() -> None:
    wx = _grid()
    rng = np.random.default_rng(1)
    pts = np.vstack([rng.uniform(-6.0, 54.0, 200), rng.uniform(-20.0, 320.0, 200), rng.uniform(-25.0, 25.0, 200)])
    pts[:, :3] = [[0.0, 48.0, 48.0], [0.0, 300.0, 150.0], [-20.0, 20.0, 0.0]]  # corners and an edge: held there
    ref = np.array(wx.taylor_function(2).map(pts.shape[1])(pts).full())
    np.testing.assert_allclose(wx.tensor_spline().evaluate(pts, 2), ref, rtol=1e-12, atol=1e-12)


def _nlp(wx: WeatherGrid) -> SpeedNLP:
    bands = (Band("v_over_c", 0.8, 1.2, hs_min_m=4.0, name="surf_riding"),)
    power = PowerModel(calm_coef=[4.0], calm_exp=[3.0], mcr_kw=40000.0)
    geometry = CorridorGeometry.straight(np.full(6, 50.0), course_deg=80.0, half_width_nm=15.0)
    return SpeedNLP(geometry, wx, power, bands=bands, v_min_kn=6.0, v_max_kn=22.0, exact_hessian=True)


def test_a_new_eta_reuses_the_built_solver_and_equals_a_fresh_build(monkeypatch: pytest.MonkeyPatch) -> None:
    built = []
    real = ca.nlpsol
    monkeypatch.setattr(speed_nlp.ca, "nlpsol", lambda *a, **k: built.append(a[0]) or real(*a, **k))
    wx = _grid()
    nlp = _nlp(wx)
    first = nlp.solve(eta_h=24.0)
    second = nlp.solve(eta_h=20.0)
    assert built == ["speed_nlp"]  # one nlpsol for both ETAs: the ETA is a bound, set per solve
    assert first.success and second.success
    assert second.duration_total_h <= 20.0 + 1e-9 < first.duration_total_h
    fresh = _nlp(wx).solve(eta_h=20.0)
    assert built == ["speed_nlp", "speed_nlp"]
    np.testing.assert_allclose(second.x_opt, fresh.x_opt, rtol=0.0, atol=1e-9)
    assert second.objective == pytest.approx(fresh.objective, rel=1e-12)


def test_the_numpy_weather_and_casadis_give_the_same_solution() -> None:
    wx = _grid(2)
    numeric = _nlp(wx)
    assert numeric.numeric_weather
    power = numeric.power
    automatic = SpeedNLP(
        numeric.corridor, wx, power, bands=numeric.bands, v_min_kn=6.0, v_max_kn=22.0, structured=False
    )
    assert not automatic.numeric_weather
    a, b = numeric.solve(eta_h=22.0), automatic.solve(eta_h=22.0)
    assert a.success and b.success
    assert a.objective == pytest.approx(b.objective, rel=1e-7)
    np.testing.assert_allclose(a.stw_kn, b.stw_kn, rtol=1e-5)
