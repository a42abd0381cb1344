"""The corridor NLP's build: the weather read in numpy equals CasADi's splines, and one build serves many ETAs.

References: the quasi-interpolant reproduces linear data exactly (Schoenberg; ``formulations.splines``), so its
derivatives on a linear field are the field's slopes; CasADi's ``Function.bspline`` of the same control points
and its derivative splines (de Boor 1978, ch. X) are the independent evaluation of the rest; a fresh build of
the same problem is the reference of a re-solve. The structured derivatives' contracted power-ratio table
(``formulations._ratio_table.ratio_taylor_data``) is checked against CasADi's automatic differentiation of the
table's own formula (``power_ratio``, ``spline_weights``).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import formulations.speed_nlp as speed_nlp
from formulations._ratio_table import power_ratio, ratio_taylor_data, sector_taylor_data
from formulations.common import Band, CorridorGeometry, PowerModel
from formulations.speed_nlp import SpeedNLP
from formulations.splines import spline_weight_derivatives, spline_weights
from formulations.weather_grid import WeatherGrid

T_AXIS, S_AXIS, Y_AXIS = np.arange(0.0, 49.0, 6.0), np.linspace(0.0, 300.0, 7), np.linspace(-20.0, 20.0, 5)


def _grid(seed: int = 0, sectors: bool = False) -> WeatherGrid:
    rng = np.random.default_rng(seed)
    shape = (T_AXIS.size, S_AXIS.size, Y_AXIS.size)
    tt = T_AXIS[:, None, None] + np.zeros(shape)
    hs = 2.0 + 4.0 * np.exp(-(((tt - 20.0) / 12.0) ** 2)) + rng.uniform(0.0, 0.5, shape)
    ratio = 1.0 + 0.08 * (hs[..., None, None] - 2.0) * np.ones((1, 1, 1, 3, 2)) + rng.uniform(0, 0.02, (*shape, 3, 2))
    # with sectors: one table per wave-angle sector (Kwon's edges), the waves about 29 deg off the bow on the
    # centreline, so the legs' headings put the samples on both sides of the 30 deg edge and in its ramp
    table = {
        "power_ratio": ratio[..., None] * np.array([1.3, 1.0, 0.8, 0.6]),
        "ratio_sector_edges_deg": (30.0, 60.0, 150.0),
    }
    return WeatherGrid(
        t_h=T_AXIS, s_nm=S_AXIS, y_nm=Y_AXIS, hs_m=hs, period_s=9.0 + rng.uniform(0.0, 1.0, shape),
        wave_to_along=-1.0, wave_to_across=0.55 if sectors else 0.3, ratio_speed_kn=[8.0, 13.0, 18.0],
        ratio_heading_deg=[-10.0, 10.0], **(table if sectors else {"power_ratio": ratio}),
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


@pytest.mark.parametrize("sectors", [False, True])
def test_numpy_spline_at_interior_nodes_is_each_fields_own_1_4_1_stencil(sectors: bool) -> None:
    # a cubic B-spline whose control points are the data has, at an interior node, the value of the tensor stencil
    # (1, 4, 1)/6 of the data around it (Schoenberg's quasi-interpolant); worked here from each field's own array
    # (the table entry [..., j, k(, q)] of field ratio_j_k(_sq)), whatever order the spline keeps its fields in
    wx = _grid(3, sectors)
    tt, ss, yy = np.meshgrid(T_AXIS[1:-1], S_AXIS[1:-1], Y_AXIS[1:-1], indexing="ij")
    got = dict(
        zip(wx.field_names, wx.tensor_spline().evaluate(np.vstack([tt.ravel(), ss.ravel(), yy.ravel()])), strict=True)
    )
    w = np.array([1.0, 4.0, 1.0]) / 6.0
    stencil = w[:, None, None] * w[None, :, None] * w[None, None, :]

    def at_nodes(f: np.ndarray) -> np.ndarray:
        n0, n1, n2 = (n - 2 for n in f.shape)
        return sum(
            stencil[a, b, c] * f[a : a + n0, b : b + n1, c : c + n2]
            for a in range(3)
            for b in range(3)
            for c in range(3)
        )

    table = np.asarray(wx.power_ratio)
    want = {"hs_m": at_nodes(np.asarray(wx.hs_m)), "period_s": at_nodes(np.asarray(wx.period_s))}
    for j in range(3):
        for k in range(2):
            for q in range(4 if sectors else 1):
                name = f"ratio_{j}_{k}" + (f"_s{q}" if sectors else "")
                want[name] = at_nodes(table[..., j, k, q] if sectors else table[..., j, k])
    assert set(want) <= set(got)
    for name, value in want.items():
        np.testing.assert_allclose(got[name], value.ravel(), rtol=1e-12, err_msg=name)


def test_numpy_spline_reusing_its_cells_control_points_never_serves_another_cells() -> None:
    """TensorSpline keeps the last gather of control points per chunk of a call and serves it while the cells are the
    same: the same points again, other points in the same cells, points in other cells, then the first again, in
    turn at orders 0 and 2 — every answer must be CasADi's spline at those points."""
    wx = _grid(seed=3)
    spline = wx.tensor_spline()
    rng = np.random.default_rng(2)
    a = np.vstack([rng.uniform(1.0, 47.0, 60), rng.uniform(5.0, 295.0, 60), rng.uniform(-19.0, 19.0, 60)])
    same_cells = a + rng.uniform(-1e-6, 1e-6, a.shape)  # almost surely in the cells of a
    other = np.vstack([rng.uniform(1.0, 47.0, 60), rng.uniform(5.0, 295.0, 60), rng.uniform(-19.0, 19.0, 60)])
    for pts, order in [(a, 0), (a, 2), (same_cells, 2), (other, 0), (a, 2), (other, 2), (a[:, :7], 1), (a, 0)]:
        ref = np.array(wx.taylor_function(2).map(pts.shape[1])(pts).full())
        rows = {0: 1, 1: 3, 2: 6}[order] * len(wx.field_names)
        np.testing.assert_allclose(spline.evaluate(pts, order), ref[:rows], rtol=1e-12, atol=1e-12)


def test_compiled_spline_of_points_moving_across_cells_between_calls_equals_casadis_spline() -> None:
    """Successive calls of TensorSpline as an NLP makes them (an iterate moves a few samples across a cell edge):
    every other point moved, then all back, at orders 0, 1 and 2 — every answer is CasADi's spline at those
    points."""
    wx = _grid(seed=4)
    spline = wx.tensor_spline()
    rng = np.random.default_rng(5)

    def draw() -> np.ndarray:
        return np.vstack([rng.uniform(1.0, 47.0, 50), rng.uniform(5.0, 295.0, 50), rng.uniform(-19.0, 19.0, 50)])

    a = draw()
    mixed = a.copy()
    mixed[:, ::2] = draw()[:, ::2]  # half the points in other cells (almost surely), half where they were
    for pts, order in [(a, 0), (mixed, 0), (mixed, 2), (a, 2), (a[:, :40], 0), (mixed, 1)]:
        ref = np.array(wx.taylor_function(2).map(pts.shape[1])(pts).full())
        rows = {0: 1, 1: 3, 2: 6}[order] * len(wx.field_names)
        np.testing.assert_allclose(spline.evaluate(pts, order), ref[:rows], rtol=1e-12, atol=1e-12)


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


@pytest.mark.parametrize("sectors", [False, True])
def test_the_numpy_weather_and_casadis_give_the_same_solution(sectors: bool) -> None:
    wx = _grid(2, sectors)
    numeric = _nlp(wx)
    assert numeric.numeric_weather
    power = numeric.power
    automatic = SpeedNLP(
        numeric.corridor, wx, power, bands=numeric.bands, v_min_kn=6.0, v_max_kn=22.0, structured=False
    )
    assert not automatic.numeric_weather
    a = numeric.solve(eta_h=22.0)
    # a 30 % step between sectors makes the problem multimodal (two solves from the same start reach 58.587 and
    # 58.531 t, each a KKT point of both derivative paths): with sectors, CasADi's own derivatives start at the
    # structured solution and must stay there
    warm = {"offset0_nm": a.offset_nm, "stw0_kn": a.stw_kn, "time0_h": a.time_h} if sectors else {}
    b = automatic.solve(eta_h=22.0, **warm)
    assert a.success and b.success
    assert a.objective == pytest.approx(b.objective, rel=1e-7)
    np.testing.assert_allclose(a.stw_kn, b.stw_kn, rtol=1e-5)


@pytest.mark.parametrize("n", [1, 2, 3, 8])
def test_spline_weight_derivatives_equal_casadis_automatic_derivatives(n: int) -> None:
    x0, h = 3.0, 3.3634679611247966  # the speed axis of a corridor's power table: 3 kn, 8 nodes
    xs = np.concatenate([np.linspace(0.0, x0 + (n + 1) * h, 97), x0 + h * np.arange(n)])  # nodes and ends included
    x = ca.SX.sym("x")
    w = ca.vertcat(*spline_weights(x, x0, h, n, ca))
    ref_fn = ca.Function("w", [x], [w, ca.jacobian(w, x), ca.jacobian(ca.jacobian(w, x), x)])
    ref = np.array([[np.array(ca.densify(a)).ravel() for a in ref_fn(xi)] for xi in xs]).transpose(1, 2, 0)
    np.testing.assert_allclose(spline_weight_derivatives(xs, x0, h, n), ref, rtol=0.0, atol=1e-13)


def test_contracted_ratio_has_the_value_gradient_and_hessian_of_the_table() -> None:
    rng = np.random.default_rng(5)
    axes = (6.0, 6.0, 4, -30.0, 30.0, 3)  # 4 speeds × 3 headings
    v, dev, t, y = ca.SX.sym("v"), ca.SX.sym("dev"), ca.SX.sym("t"), ca.SX.sym("y")
    # a table whose every entry is a quadratic in (t, y): its Taylor coefficients are known exactly
    c = rng.uniform(-1.0, 1.0, (6, 4, 3))
    col = {f"ratio_{j}_{k}": c[0, j, k] + c[1, j, k] * t + c[2, j, k] * y + 0.5 * c[3, j, k] * t**2
           + c[4, j, k] * t * y + 0.5 * c[5, j, k] * y**2 for j in range(4) for k in range(3)}  # fmt: skip
    r = power_ratio(col, v, dev, axes, ca)
    z = ca.vertcat(v, dev, t, y)
    ref_fn = ca.Function("r", [z], [r, ca.gradient(r, z), ca.hessian(r, z)[0]])
    for point in ([7.5, 12.0], [6.0, -30.0], [20.0, 3.0], [25.0, 40.0]):  # inside, on the first nodes, outside
        val, grad, hess = (np.array(a) for a in ref_fn([*point, 0.0, 0.0]))
        blk = ratio_taylor_data(c[:, :, :, None], np.array(point[:1]), np.array(point[1:]), axes)[:, 0]
        np.testing.assert_allclose(blk[:2], point, rtol=0, atol=0)
        np.testing.assert_allclose(blk[2], val.item(), rtol=1e-13)
        np.testing.assert_allclose(blk[3:7], grad.ravel(), rtol=1e-12, atol=1e-13)
        order = [(0, 0), (0, 1), (0, 2), (0, 3), (1, 1), (1, 2), (1, 3), (2, 2), (2, 3), (3, 3)]  # R_VV … R_yy
        want = [hess[a, b] for a, b in order]
        np.testing.assert_allclose(blk[7:], want, rtol=1e-12, atol=1e-13)


def test_every_sectors_taylor_data_at_once_equals_casadis_derivatives_of_that_sectors_table() -> None:
    """sector_taylor_data contracts all sectors and samples together (the weights computed once): each sector's block
    at each sample must be the value, gradient and Hessian CasADi differentiates from that sector's table alone."""
    rng = np.random.default_rng(11)
    axes = (6.0, 6.0, 4, -30.0, 30.0, 3, (30.0, 60.0))  # 3 sectors × 4 speeds × 3 headings
    points = np.array([[7.5, 12.0], [6.0, -30.0], [20.0, 3.0], [25.0, 40.0], [11.0, -7.0]])  # inside, nodes, out
    c = rng.uniform(-1.0, 1.0, (6, 3, 4, 3, points.shape[0]))  # (blocks, sector, speed, heading, sample)
    got = sector_taylor_data(c, points[:, 0], points[:, 1], axes)  # (3 · 17, K)
    v, dev, t, y = ca.SX.sym("v"), ca.SX.sym("dev"), ca.SX.sym("t"), ca.SX.sym("y")
    z = ca.vertcat(v, dev, t, y)
    order = [(0, 0), (0, 1), (0, 2), (0, 3), (1, 1), (1, 2), (1, 3), (2, 2), (2, 3), (3, 3)]  # R_VV … R_yy
    for q in range(3):
        for i, point in enumerate(points):
            e = c[:, q, :, :, i]
            col = {f"ratio_{j}_{k}": e[0, j, k] + e[1, j, k] * t + e[2, j, k] * y + 0.5 * e[3, j, k] * t**2
                   + e[4, j, k] * t * y + 0.5 * e[5, j, k] * y**2 for j in range(4) for k in range(3)}  # fmt: skip
            r = power_ratio(col, v, dev, axes[:6], ca)
            val, grad, hess = (
                np.array(a)
                for a in ca.Function("r", [z], [r, ca.gradient(r, z), ca.hessian(r, z)[0]])([*point, 0.0, 0.0])
            )
            blk = got[q * 17 : (q + 1) * 17, i]
            np.testing.assert_allclose(blk[:2], point, rtol=0, atol=0)
            np.testing.assert_allclose(blk[2], val.item(), rtol=1e-13)
            np.testing.assert_allclose(blk[3:7], grad.ravel(), rtol=1e-12, atol=1e-13)
            np.testing.assert_allclose(blk[7:], [hess[a, b] for a, b in order], rtol=1e-12, atol=1e-13)
