"""The third disjunct of a danger band: the sea stays below the band's threshold (issue 13).

Boeing EP 2145155 imposes a band only where Hs ≥ 0.04 L, so a band is the disjunction "ratio ≤ lower OR
ratio ≥ upper OR Hs < threshold". A start (a verified discrete plan) may sail inside a band's ratio interval
where the sea is below the threshold; an NLP that leaves such a sample free can carry it into the band's seas
and only learn it afterwards (the applicability re-check), from a point then inside its new rows. The third
disjunct as a row, ``(Hs − hs_min) / hs_min ≤ −BELOW_MARGIN``, keeps it out. Checked here by hand (the row's
bounds and value, from the sea the NLP's own state reports), against CasADi's automatic derivatives, and on
a storm whose seas a start at 15 kn in following seas would be carried into.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from formulations.common import BELOW_BETA, BELOW_SIDE, Band, FormulationInputError
from formulations.disjunctive import select_sides
from formulations.row_layout import BELOW_MARGIN, RowLegs
from tests.test_formulations_nlp import assert_same_derivatives, rich_pair
from tests.test_nlp_row_legs import _problem

BAND = Band("te_over_tr", 0.8, 1.2, param=20.0, hs_min_m=3.0)


def test_band_edges_of_the_third_disjunct_by_hand() -> None:
    legs = RowLegs.of(np.array([True, False, True]), None, 3, 1, 1)
    sides = np.array([BELOW_SIDE, -1, 1], dtype=np.int8).reshape(3, 1, 1)
    applies = np.array([False, True, True]).reshape(3, 1, 1)
    beta, lo, hi = legs.band_edges((BAND,), sides, applies)
    np.testing.assert_array_equal(beta, [BELOW_BETA, 0.8, 1.2])  # every sample's edge, band-major
    np.testing.assert_array_equal(lo, [-np.inf, 0.0])  # rows on legs 0 and 2 only
    np.testing.assert_array_equal(hi, [-BELOW_MARGIN, np.inf])
    with pytest.raises(FormulationInputError, match="applies at leg 0, sample 0"):
        legs.band_edges((BAND,), sides, np.ones((3, 1, 1), dtype=bool))
    with pytest.raises(FormulationInputError, match="hs_min_m > 0"):
        legs.band_edges((Band("te_over_tr", 0.8, 1.2, param=20.0),), sides, applies)
    with pytest.raises(FormulationInputError, match="sides must be"):
        legs.band_edges((BAND,), np.full((3, 1, 1), 2, dtype=np.int8), applies)


def _start(nlp, stw_kn: float):
    n = nlp.n_legs
    y0, v0 = np.zeros(n + 1), np.full(n, stw_kn)
    t0 = nlp.consistent_times(y0, v0)
    return y0, v0, t0


def test_the_row_is_the_relative_height_of_the_sea_below_the_threshold() -> None:
    nlp, _ = _problem()
    y0, v0, t0 = _start(nlp, 15.0)
    st = nlp.evaluate(y0, v0, t0)
    sides = np.full(st.applies.shape, BELOW_SIDE, dtype=np.int8)  # every sample: "Hs below the threshold"
    beta, _, _ = nlp.band_edges(sides, np.zeros(st.applies.shape, dtype=bool))
    y, v, t = ca.MX.sym("y", y0.size), ca.MX.sym("v", v0.size), ca.MX.sym("t", t0.size)
    b, f = ca.MX.sym("b", beta.size), ca.MX.sym("f", v0.size)
    mdl = nlp.symbolic_model(y, v, t, b, f)
    rows = ca.Function("rows", [y, v, t, b, f], [mdl["band_res"]])(y0, v0, t0, beta, np.ones(v0.size))
    got = nlp.row_legs.band_samples_of(np.asarray(rows, dtype=float).ravel(), np.nan)
    hs_min = np.array([band.hs_min_m for band in nlp.bands])
    want = (st.hs_m[:, :, None] - hs_min) / hs_min
    on = np.isfinite(got)
    assert on.any()
    np.testing.assert_allclose(got[on], np.broadcast_to(want, got.shape)[on], rtol=1e-12, atol=1e-12)


def test_structured_derivatives_of_the_third_disjunct_equal_casadis_automatic_ones() -> None:
    exact, auto, x, rng = rich_pair(11)
    n = exact.n_legs
    beta = rng.uniform(0.5, 1.5, n * 3 * 2)
    beta[rng.uniform(size=beta.size) < 0.5] = BELOW_BETA  # about half the samples on the third disjunct
    p = np.concatenate([[1.3, 0.7], beta, rng.uniform(0.5, 1.5, n)])
    assert_same_derivatives(exact._solver, auto._solver, x, p, rng.normal(size=exact._ng))


def test_a_start_inside_the_ratio_band_in_low_seas_is_kept_out_of_the_band_seas() -> None:
    # 15 kn in following seas: Te/Tr inside the synchronous band (0.8-1.2) on most samples; the storm (Hs up to 6 m,
    # threshold 3 m) passes the corridor's middle. Left free, those samples are carried into Hs 3.04 m.
    nlp, _ = _problem()
    y0, v0, t0 = _start(nlp, 15.0)
    st = nlp.evaluate(y0, v0, t0)
    sides, applies = nlp.default_sides(st)
    below = sides == BELOW_SIDE
    lower, upper = np.array([b.lower for b in nlp.bands]), np.array([b.upper for b in nlp.bands])
    inside = (st.ratio > lower) & (st.ratio < upper)
    np.testing.assert_array_equal(below, inside & ~applies)  # the rule: inside the ratio band, below the threshold
    kw = {"eta_h": float(t0[-1]), "applies": applies, "offset0_nm": y0, "stw0_kn": v0, "time0_h": t0}
    res = nlp.solve(sides=sides, **kw)
    assert res.success and res.max_violation <= 1e-6
    hs_min = np.array([b.hs_min_m for b in nlp.bands])
    hs = np.broadcast_to(res.samples.hs_m[:, :, None], below.shape)
    on_rows = below & nlp.row_legs.band_legs[:, None, None]
    # a sample next to one where the band applies holds that neighbour's ratio side instead (the sea's rise through
    # the threshold lies between them: held_across_crossings); every other one keeps its sea below the threshold
    held = on_rows & (res.sides == BELOW_SIDE)
    moved = on_rows & (res.sides != BELOW_SIDE)
    assert held.any()
    assert (hs[held] < np.broadcast_to(hs_min, below.shape)[held]).all()
    ratio, lo, up = res.samples.ratio, np.broadcast_to(lower, below.shape), np.broadcast_to(upper, below.shape)
    assert (np.where(res.sides > 0, ratio >= up - 1e-6, ratio <= lo + 1e-6)[moved]).all()
    assert not res.samples.inside.any()
    # the same start with those samples free (no third disjunct): the solve takes some of them over the threshold
    free = nlp.solve(sides=select_sides(st.ratio, lower, upper), **kw)
    hs_free = np.broadcast_to(free.samples.hs_m[:, :, None], below.shape)
    assert (hs_free[on_rows] >= np.broadcast_to(hs_min, below.shape)[on_rows]).any()
