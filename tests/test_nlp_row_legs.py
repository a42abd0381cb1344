"""Band and exclusion rows only on the legs where they can bind (formulations.row_layout, issue 13).

A row whose bounds are −∞…+∞ at every solve constrains nothing: the NLP without it must have the same optimum as the
NLP with it (the independent reference here is the full NLP, every row on every leg), with fewer rows; and its
leg-by-leg derivatives must still equal CasADi's automatic derivatives of the same rows.
"""

from __future__ import annotations

import numpy as np
import pytest

from formulations.common import Band, CorridorGeometry, FormulationInputError, MovingExclusion, PowerModel
from formulations.phase1 import Phase1Problem
from formulations.row_layout import RowLegs
from formulations.speed_nlp import SpeedNLP
from formulations.weather_grid import WeatherGrid
from optroute.optimise.rows import legs_near_exclusion, legs_that_can_bind
from tests.test_formulations_nlp import assert_same_derivatives

N_LEGS = 30
HS_MIN_M = 3.0
BANDS = (Band("te_over_tr", 0.8, 1.2, param=20.0, hs_min_m=HS_MIN_M), Band("v_over_c", 0.8, 1.2, hs_min_m=HS_MIN_M))
POWER = PowerModel(calm_coef=[2.2], calm_exp=[3.0], mcr_kw=36000, min_load=0.1)
EXCL = MovingExclusion(t_h=[0.0, 20.0, 40.0], centre_xy_nm=[[5.0, 80.0], [0.0, 110.0], [-5.0, 140.0]],
                       radius_nm=[15.0, 15.0, 15.0])  # fmt: skip


def _problem(**kw: object) -> tuple[SpeedNLP, float]:
    """A straight 600 nm corridor, ±30 nm, 20 nm legs: a storm (Hs up to 6 m) passing its middle, 2 m seas elsewhere
    (below the bands' threshold), a moving circle near its first third."""
    cor = CorridorGeometry.straight(np.full(N_LEGS, 20.0), half_width_nm=30.0)
    tg, sg, yg = np.arange(0.0, 61.0, 6.0), np.arange(0.0, 601.0, 20.0), np.linspace(-40.0, 40.0, 5)
    tt, ss, yy = np.meshgrid(tg, sg, yg, indexing="ij")
    hs = 2.0 + 4.0 * np.exp(-(((ss - 380.0 - 2.0 * tt) / 50.0) ** 2) - ((yy - 10.0) / 40.0) ** 2)
    th = np.radians(10.0 + tt / 2.0 + ss / 60.0)  # following seas: the synchronous band (Te/Tr) near 15 kn
    wx = WeatherGrid(t_h=tg, s_nm=sg, y_nm=yg, hs_m=hs, period_s=4.5 * np.sqrt(hs) + 1.0, wave_to_along=np.cos(th),
                     wave_to_across=np.sin(th))  # fmt: skip
    nlp = SpeedNLP(cor, wx, POWER, bands=BANDS, exclusion=EXCL, samples_per_leg=3, v_min_kn=6, v_max_kn=24, **kw)  # type: ignore[arg-type]
    return nlp, float(cor.s_nm[-1] / 15.0)


def _row_legs(nlp: SpeedNLP) -> tuple[np.ndarray, np.ndarray]:
    """The domain layer's rule (optroute.optimise.rows): band rows where Hs near the leg can reach the threshold,
    exclusion rows where the circle comes within reach of the leg's corridor."""
    w, cor = nlp.weather, nlp.corridor
    band = legs_that_can_bind(cor.s_nm, w.s_nm, w.hs_m, HS_MIN_M)
    excl = legs_near_exclusion(cor.centre_xy_nm, np.full(cor.n_legs + 1, 30.0), EXCL.centre_xy_nm, EXCL.radius_nm)
    return band, excl


def test_rows_only_where_they_can_bind_give_the_full_problems_optimum_with_fewer_rows() -> None:
    full, eta = _problem()
    band, excl = _row_legs(full)
    assert 0 < band.sum() < N_LEGS and 0 < excl.sum() < N_LEGS  # the case leaves rows out of both blocks
    lean, _ = _problem(band_legs=band, exclusion_legs=excl)
    assert lean._ng == full._ng - 3 * (2 * (N_LEGS - band.sum()) + (N_LEGS - excl.sum()))
    a, b = full.solve(eta_h=eta), lean.solve(eta_h=eta)
    assert a.success and b.success, (a.status, b.status)
    assert a.samples.applies.any() and a.band_active.any()  # a band binds somewhere: the rows kept do work
    assert not a.samples.applies[~band].any()  # and never where the rows were left out
    assert (a.samples.exclusion_margin_nm[excl] < 1e-3).any()  # the circle binds too
    assert b.objective == pytest.approx(a.objective, rel=1e-8)
    np.testing.assert_allclose(b.x_opt, a.x_opt, atol=1e-5)
    np.testing.assert_allclose(
        b.band_multiplier, a.band_multiplier, atol=1e-6 * max(1.0, np.abs(a.band_multiplier).max())
    )
    np.testing.assert_array_equal(b.band_active, a.band_active)
    assert b.max_violation <= 1e-6


@pytest.mark.parametrize("which", ["structured", "phase1"])
def test_leg_by_leg_derivatives_with_rows_on_some_legs_equal_casadis_automatic_ones(which: str) -> None:
    band = np.zeros(N_LEGS, dtype=bool)
    band[[3, 4, 5, 17, 29]] = True  # arbitrary masks: every group of legs (bands only, circle only, both, neither)
    excl = np.zeros(N_LEGS, dtype=bool)
    excl[[0, 4, 5, 6, 20]] = True
    rng = np.random.default_rng(7)
    n = N_LEGS
    x = np.concatenate([rng.uniform(-20, 20, n + 1), rng.uniform(10, 20, n), np.linspace(0, 40, n + 1)])
    p = np.concatenate([[1.3, 0.7], rng.uniform(0.5, 1.5, n * 3 * 2), rng.uniform(0.5, 1.5, n)])
    if which == "structured":
        mine, _ = _problem(band_legs=band, exclusion_legs=excl, exact_hessian=True)
        ref, _ = _problem(band_legs=band, exclusion_legs=excl, structured=False)
        s_mine, s_ref, ng = mine._solver, ref._solver, mine._ng
    else:  # the elastic phase-1 problem shares the NLP's rows and derivatives
        ph_mine = Phase1Problem(_problem(band_legs=band, exclusion_legs=excl)[0])
        ph_ref = Phase1Problem(_problem(band_legs=band, exclusion_legs=excl, structured=False)[0])
        s_mine, s_ref, ng = ph_mine._solver, ph_ref._solver, ph_mine._ng + 1
        x = np.concatenate([x, rng.uniform(0.0, 1.0, ph_mine._ns)])
        assert ph_mine._ns == 2 * n * 3 + 3 * excl.sum() + 3 * 2 * band.sum() + 1  # a slack per row
    assert_same_derivatives(s_mine, s_ref, x, p, rng.normal(size=ng))


def test_row_legs_map_samples_to_rows_and_back_and_check_their_masks() -> None:
    legs = RowLegs.of(np.array([True, False, True]), None, 3, 2, 2)
    vals = np.arange(12.0).reshape(3, 2, 2)  # (leg, sample, band)
    rows = legs.band_rows_of(vals)
    np.testing.assert_array_equal(rows, [0, 2, 8, 10, 1, 3, 9, 11])  # band-major over legs 0 and 2
    back = legs.band_samples_of(rows, fill=-1.0)
    np.testing.assert_array_equal(back[[0, 2]], vals[[0, 2]])
    assert (back[1] == -1.0).all()
    with pytest.raises(FormulationInputError, match="band_legs"):
        RowLegs.of(np.array([1, 0, 1]), None, 3, 2, 2)
