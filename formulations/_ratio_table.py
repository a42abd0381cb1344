"""The ship's power-ratio table at a sample: its value and its second-order Taylor coefficients.

The corridor NLP reads the ship's power as ``P = P_calm(V) · R`` with ``R`` tabulated on the weather grid at a few
speeds through water, headings relative to the centreline and wave-angle sectors
(:class:`formulations.weather_grid.WeatherGrid`'s ``ratio_axes``; :mod:`optroute.optimise.power_table` fills it from
the ship's own performance model). :func:`power_ratio` is ``R`` itself, one formula for the NLP's symbolic graph and
its numeric checks; :func:`ratio_taylor_data` and :func:`sector_taylor_data` give, per sample, the coefficients of
its Taylor polynomial about the sample's speed and heading, which the leg functions of
:mod:`formulations._nlp_model` read (:func:`ratio_taylor`), so that their derivatives are exact at the point.

Split out of :mod:`formulations._nlp_model` to keep modules short.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

from formulations._jit import njit
from formulations.common import spline_weights
from formulations.splines import ratio_field_names, sector_weights, spline_weight_derivatives

__all__ = [
    "RATIO_BLOCK",
    "power_ratio",
    "ratio_taylor",
    "ratio_taylor_data",
    "sector_taylor_data",
    "sector_taylor_data_at",
]


def power_ratio(
    col: dict[str, Any], v: Any, heading_dev_deg: Any, axes: tuple | None, lib: Any, cos_alpha: Any = None
) -> Any:
    """The tabulated ``R = P_ship / P_calm`` [-] at a sample (:class:`formulations.weather_grid.WeatherGrid`).

    ``col`` holds the table's values ``ratio_j_k`` (``ratio_j_k_sq`` per wave-angle sector q) interpolated to the
    sample's (t, s, y); ``v`` the speed through water [kn], ``heading_dev_deg`` the heading minus the centreline
    direction [deg, to port +]; ``axes`` is :attr:`WeatherGrid.ratio_axes` (None: ``R = 1``); ``cos_alpha`` the
    cosine of the wave angle from the bow (0 = head sea), which blends the sectors' tables
    (:func:`formulations.splines.sector_weights`); ``lib`` is ``numpy`` or ``casadi``. One formula for the NLP
    and its numeric checks.
    """
    if axes is None:
        return 1.0
    v0, dv, nv, d0, dd, nd = axes[:6]
    edges = axes[6] if len(axes) > 6 else ()
    wv = spline_weights(v, v0, dv, nv, lib)
    wd = spline_weights(heading_dev_deg, d0, dd, nd, lib)
    names = ratio_field_names(axes)
    ws = sector_weights(cos_alpha, edges, lib) if edges else [1.0]
    total = 0.0
    for q, w_q in enumerate(ws):
        part = 0.0
        for j in range(nv):
            inner = 0.0
            for k in range(nd):
                inner = inner + wd[k] * col[names[(q * nv + j) * nd + k]]
            part = part + wv[j] * inner
        total = total + w_q * part
    return total


#: The coefficients of a sector's power-ratio Taylor block after the expansion point ``(V*, δ*)``, in the order the
#: leg functions read them (:func:`ratio_taylor`): per coefficient, the order of the speed weights' derivative, of
#: the heading weights' and the table's block (F, F_t, F_y, F_tt, F_ty, F_yy): ``R, R_V, R_δ, R_t, R_y, R_VV, R_Vδ,
#: R_Vt, R_Vy, R_δδ, R_δt, R_δy`` (first derivatives of the weather only), then ``R_tt, R_ty, R_yy`` (with the
#: weather's second derivatives).
_RATIO_TERMS = np.array(
    [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, 2), (2, 0, 0), (1, 1, 0), (1, 0, 1), (1, 0, 2), (0, 2, 0),
     (0, 1, 1), (0, 1, 2), (0, 0, 3), (0, 0, 4), (0, 0, 5)], dtype=np.int64,
)  # fmt: skip
#: Length of a sample's power-ratio Taylor block (:func:`ratio_taylor_data`) by the weather's derivative order:
#: the expansion point and the coefficients of :data:`_RATIO_TERMS` that read the weather's blocks up to it.
RATIO_BLOCK = {order: 2 + int(np.sum(_RATIO_TERMS[:, 2] < 3 * order)) for order in (1, 2)}


def ratio_taylor_data(fields: np.ndarray, v: np.ndarray, heading_dev_deg: np.ndarray, axes: tuple) -> np.ndarray:
    """The second-order Taylor coefficients of :func:`power_ratio` at K samples, numpy: (``RATIO_BLOCK[order]``, K).

    ``fields`` holds the table's values ``ratio_j_k`` and their partial derivatives in time and across-track
    position at the samples, (blocks, nv, nd, K) with blocks ``F, F_t, F_y`` (order 1) or also ``F_tt, F_ty, F_yy``
    (order 2; :meth:`formulations.splines.TensorSpline.evaluate`'s order); ``v`` [kn] and ``heading_dev_deg``
    [deg] the samples' speed through water and heading relative to the centreline (the expansion point). ``R`` is
    bilinear in the speed and heading weights (:func:`formulations.splines.spline_weights`) and linear in the
    table, so every coefficient is one weighted sum of the table's derivatives with the weights' derivatives
    (:func:`formulations.splines.spline_weight_derivatives`).
    """
    return sector_taylor_data(fields[:, None], v, heading_dev_deg, axes)


def sector_taylor_data(fields: np.ndarray, v: np.ndarray, heading_dev_deg: np.ndarray, axes: tuple) -> np.ndarray:
    """:func:`ratio_taylor_data` of every wave-angle sector's table at once: ``fields`` (blocks, nq, nv, nd, K),
    returns the nq blocks one after the other, (nq · ``RATIO_BLOCK[order]``, K)."""
    blocks, nq, nv, nd, k_ = fields.shape
    flat = np.ascontiguousarray(fields).reshape(blocks, nq * nv * nd, k_)
    return sector_taylor_data_at(flat, np.arange(nq * nv * nd).reshape(nq, nv, nd), v, heading_dev_deg, axes)


def sector_taylor_data_at(
    values: np.ndarray, table: np.ndarray, v: np.ndarray, heading_dev_deg: np.ndarray, axes: tuple
) -> np.ndarray:
    """:func:`sector_taylor_data` of the table's fields read from ``values`` (blocks, n_fields, K) where ``table``
    (nq, nv, nd) says (the weather's own evaluation, :meth:`formulations.splines.TensorSpline.evaluate`: no copy of
    the table's fields).

    The speed and heading weights and their derivatives are the same for every sector: computed once; each
    coefficient is one weighted sum over the table's nodes (:func:`_sector_terms`, compiled).
    """
    v0, dv, nv, d0, dd, nd = axes[:6]
    wv = spline_weight_derivatives(v, v0, dv, nv)  # (3, nv, K)
    wd = spline_weight_derivatives(heading_dev_deg, d0, dd, nd)  # (3, nd, K)
    terms = _RATIO_TERMS[: RATIO_BLOCK[values.shape[0] // 3] - 2]
    nq, k_ = table.shape[0], values.shape[2]
    out = np.empty((nq, 2 + terms.shape[0], k_))
    out[:, 0], out[:, 1] = v, heading_dev_deg
    _sector_terms(np.ascontiguousarray(values), np.ascontiguousarray(table, dtype=np.int64), wv, wd, terms, out)
    return out.reshape(-1, k_)


@njit
def _sector_terms(
    values: np.ndarray, table: np.ndarray, wv: np.ndarray, wd: np.ndarray, terms: np.ndarray, out: np.ndarray
) -> None:  # pragma: no cover - compiled
    """``out[q, 2 + t, :] = Σ_jk ∂^a w_j(V*) ∂^b w_k(δ*) ∂F_{q j k}`` for each term ``t = (a, b, block)``, summed
    over the speed nodes ``j`` and heading nodes ``k`` point by point (the points' axis last, contiguous)."""
    nq, nv, nd = table.shape
    k_ = values.shape[2]
    for q in range(nq):
        for t in range(terms.shape[0]):
            a, b, blk = terms[t, 0], terms[t, 1], terms[t, 2]
            row = out[q, 2 + t]
            row[:] = 0.0
            for j in range(nv):
                for k in range(nd):
                    field = values[blk, table[q, j, k]]
                    for p in range(k_):
                        row[p] += wv[a, j, p] * wd[b, k, p] * field[p]


def ratio_taylor(block: Any, d_t: Any, d_y: Any, edges: tuple = ()) -> Callable[[Any, Any, Any], Any]:
    """``(v, heading_dev_deg, cos_alpha) ↦ R``: the Taylor polynomials of :func:`ratio_taylor_data`'s coefficients
    ``block`` (SX; one block per wave-angle sector between ``edges``, one after the other) blended by the sectors'
    weights (:func:`formulations.splines.sector_weights`), the sample's time and offset being ``d_t`` [h] and
    ``d_y`` [nm] from the expansion point.

    It shares the value, gradient and Hessian of :func:`power_ratio` at the expansion point, so the leg
    functions' derivatives there are exact (:func:`formulations._nlp_model.structured_derivatives`), at a
    fraction of the work of evaluating the whole table in SX (8 speeds × 5 headings of weather Taylor polynomials
    per sample).
    """
    nq = len(edges) + 1
    size = block.shape[0] // nq
    second = size == RATIO_BLOCK[2]

    def ratio_of(v: Any, dev: Any, cos_alpha: Any = None) -> Any:
        parts = [one(block[q * size : (q + 1) * size], v, dev) for q in range(nq)]
        if not edges:
            return parts[0]
        return sum(w * p for w, p in zip(sector_weights(cos_alpha, edges, ca), parts, strict=True))

    def one(blk: Any, v: Any, dev: Any) -> Any:
        c = [blk[i] for i in range(size)]
        d_v, d_d = v - c[0], dev - c[1]
        out = c[2] + c[3] * d_v + c[4] * d_d + c[5] * d_t + c[6] * d_y
        out = out + 0.5 * c[7] * d_v**2 + c[8] * d_v * d_d + c[9] * d_v * d_t + c[10] * d_v * d_y
        out = out + 0.5 * c[11] * d_d**2 + c[12] * d_d * d_t + c[13] * d_d * d_y
        if second:
            out = out + 0.5 * c[14] * d_t**2 + c[15] * d_t * d_y + 0.5 * c[16] * d_y**2
        return out

    return ratio_of
