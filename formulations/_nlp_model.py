"""Per-sample physics of the corridor NLP and its structure-exploiting derivatives.

Split out of :mod:`formulations.speed_nlp` to keep modules short. Two things live here:

* :func:`sample_physics`, the symbolic (SX) model of one sample of one leg: kinematics with
  current, encounter angle, power, engine load, fuel rate, band residuals and ratios;
* :func:`structured_derivatives`, exact first and second derivatives of the NLP assembled leg
  by leg, passed to ``nlpsol`` as its ``grad_f``, ``jac_g`` and ``hess_lag`` functions.

Why the second: every objective term and constraint row of the NLP depends on the five
variables of one leg, ``z_k = (y_k, y_{k+1}, V_k, t_k, t_{k+1})``; the weather enters through a
spline evaluated at the sample's ``(t, s, y)``, where ``s`` is fixed and ``(t, y)`` are affine in
``z_k``. CasADi's generic Hessian of the mapped MX graph needs one forward-over-reverse sweep
over all samples per colour of the Hessian, which dominated the solve time. Here instead, at
the point ``x`` where Ipopt asks for derivatives,

1. the weather spline and its first and second partial derivatives in ``t`` and ``y`` are
   evaluated once per sample (one batched call);
2. each leg is an SX function of ``z_k`` in which the weather is the second-order Taylor
   polynomial around that very point. A function and its second-order Taylor polynomial share
   value, gradient and Hessian at the expansion point, so by the chain rule the leg's value,
   gradient, Jacobian and Hessian in ``z_k`` are the exact ones of the true composite;
3. the per-leg 5-column Jacobian rows and 5×5 Hessians (``Function.map`` over the legs) are
   scattered into the global sparse matrices with constant sparse matrices.

The test suite checks the result against CasADi's automatic derivatives of the plain model.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import casadi as ca
import numpy as np

from formulations._buffers import Buffered, MemoCallback
from formulations._ratio_table import RATIO_BLOCK, power_ratio, ratio_taylor, sector_taylor_data_at
from formulations.common import BELOW_BETA, Band, PowerModel
from formulations.compiled import compiled_function
from formulations.row_layout import leg_kinds, leg_row_numbers
from formulations.splines import ratio_field_names

__all__ = [
    "ABS_EPS_KN",
    "heading_dev_deg",
    "power_ratio",
    "sample_physics",
    "side_free_row",
    "StructuredCores",
    "structured_cores",
    "structured_derivatives",
]

ABS_EPS_KN = 1e-3  # smoothing of |A T − V cos χ| in T_E [kn]
_N_Z = 5  # y_k, y_{k+1}, V_k, t_k, t_{k+1}
_TRIU = [(a, b) for b in range(_N_Z) for a in range(b + 1)]  # upper triangle, column-major


def heading_dev_deg(sin_d: Any, cos_d: Any, h_perp: Any) -> Any:
    """The heading minus the centreline direction [deg, to port +] (the power table's heading axis): the leg's
    course δ from the centreline tangent (``sin_d``, ``cos_d``) turned by the crab angle ``asin(h_perp)`` against
    the current (``h_perp`` the sine of the drift angle). SX or MX; one formula for the NLP and its diagnostics."""
    return (ca.atan2(sin_d, cos_d) + ca.asin(h_perp)) * (180.0 / np.pi)


def sample_physics(
    v: Any,
    cos_d: Any,
    sin_d: Any,
    ds: Any,
    factor: Any,
    col: dict[str, Any],
    beta: Any,
    power: PowerModel,
    bands: tuple[Band, ...],
    g_over_2pi: float,
    ratio_axes: tuple | None = None,
    ratio_of: Callable[[Any, Any], Any] | None = None,
) -> dict[str, Any]:
    """Symbolic quantities at one sample (see :mod:`formulations.speed_nlp` for the model).

    Parameters
    ----------
    v : SX
        Speed through water [kn].
    cos_d, sin_d : SX
        cos and sin of δ, the angle from the centreline tangent to the leg's course (counter-clockwise).
    ds : SX
        Length represented by the sample, ``L_k / m`` [nm].
    factor : SX or float
        Static per-leg power factor ``f_k`` [-] (1 unless the caller gives one).
    col : dict
        Weather fields at the sample by name (see ``WeatherGrid.field_names``).
    beta : SX
        Band edge used in each band's residual (``lower`` or ``upper`` by side), length B; at least half of
        :data:`formulations.common.BELOW_BETA`: the residual is ``(Hs − hs_min_m) / hs_min_m`` instead (the sea
        below the band's threshold, ``≤ 0`` when satisfied).
    power, bands, g_over_2pi
        The engine and calm-water baseline, the bands and ``A = g/2π`` [kn/s].
    ratio_axes : tuple, optional
        :attr:`formulations.weather_grid.WeatherGrid.ratio_axes`: the tabulated ship power ratio is read from
        ``col`` (:func:`~formulations._ratio_table.power_ratio`); None: ``R = 1``.
    ratio_of : callable, optional
        ``ratio_of(v, heading_dev_deg)``: the power ratio from elsewhere than ``col`` (the leg functions of
        :func:`structured_derivatives`: its second-order Taylor polynomial, :func:`~formulations._ratio_table.ratio_taylor`).

    Returns
    -------
    dict
        ``dt`` [h], ``fuel`` [t], ``load``, ``power`` [kW], ``rate`` [t/h], ``cos_chi``, ``sog`` [kn],
        ``h_perp`` (sine of the drift angle), ``dev_deg`` (heading minus the centreline direction [deg, to
        port +]), ``res`` (B scaled band residuals, ``≤ 0`` on the lower side and ``≥ 0`` on the upper side when
        satisfied), ``ratio`` (B band ratios).
    """
    pw = power
    per = col["period_s"]

    def to_leg(a_name: str, c_name: str) -> tuple[Any, Any]:
        # (along, across) of the centreline → (along, to port of) the leg
        if a_name not in col:
            return 0.0, 0.0
        a, cc = col[a_name], col[c_name]
        return a * cos_d + cc * sin_d, -a * sin_d + cc * cos_d

    u_par, u_perp = to_leg("current_along_kn", "current_across_kn")
    h_perp = -u_perp / v
    h_par = ca.sqrt(1.0 - h_perp**2)
    sog = v * h_par + u_par
    w_par, w_perp = to_leg("wave_to_along", "wave_to_across")
    w_norm = ca.sqrt(w_par**2 + w_perp**2 + 1e-12)
    cos_chi = (h_par * w_par + h_perp * w_perp) / w_norm
    p_calm = sum(cj * v**nj for cj, nj in zip(pw.calm_coef, pw.calm_exp, strict=True))
    # heading relative to the centreline: the leg's course (δ) turned by the crab angle against the current
    dev_deg = heading_dev_deg(sin_d, cos_d, h_perp)
    cos_alpha = -cos_chi  # Kwon's weather angle from the bow: 0 = head sea, χ = 0 following
    if ratio_of is None:
        r_ship = power_ratio(col, v, dev_deg, ratio_axes, ca, cos_alpha)
    else:
        r_ship = ratio_of(v, dev_deg, cos_alpha)
    pwr = factor * p_calm * r_ship
    load = pwr / pw.mcr_kw
    a2, a1, a0 = pw.sfc_quad
    rate = pwr * pw.sfc_base_gpkwh * (a2 * load**2 + a1 * load + a0) * 1e-6  # t/h
    dt = ds / sog
    a_ = g_over_2pi
    along = v * cos_chi
    res, ratio = [], []
    for i, b in enumerate(bands):
        if b.kind == "te_over_tr":
            num = a_ * per**2
            den = b.param * ca.sqrt((a_ * per - along) ** 2 + ABS_EPS_KN**2)
            scl = a_ * per * b.param
        else:
            num = along
            den = {"v_over_c": a_ * per, "v_over_cg": 0.5 * a_ * per}.get(b.kind, b.param)
            scl = den
        res_i = (num - beta[i] * den) / scl
        if b.hs_min_m > 0.0 and "hs_m" in col:  # the third disjunct: Hs below the band's threshold
            res_i = ca.if_else(beta[i] >= 0.5 * BELOW_BETA, (col["hs_m"] - b.hs_min_m) / b.hs_min_m, res_i)
        res.append(res_i)
        ratio.append(num / den)
    return {
        "dt": dt,
        "fuel": rate * dt,
        "load": load,
        "power": pwr,
        "rate": rate,
        "cos_chi": cos_chi,
        "sog": sog,
        "h_perp": h_perp,
        "dev_deg": dev_deg,
        "res": res,
        "ratio": ratio,
    }


def side_free_row(band: Band, ratio: Any, res: Any) -> Any:
    """A band's row without a side, ``≤ 0`` exactly where the ratio is outside the band (the elastic phase-1 problem).

    Both edges finite: ``4 (ρ − lower)(upper − ρ) / (upper − lower)²`` [-] (0 at either edge, 1 at the band's
    centre, negative outside); one edge: that side's scaled residual ``res`` (:func:`sample_physics`'s, ``β`` the
    finite edge), negated for a band with only its upper side allowed. ``ratio`` and ``res`` are the band's ratio
    and residual at the samples (SX or MX); one formula for the phase-1 rows and their leg-by-leg derivatives.
    """
    if np.isfinite(band.lower) and np.isfinite(band.upper):
        return 4.0 * (ratio - band.lower) * (band.upper - ratio) / (band.upper - band.lower) ** 2
    return res if np.isfinite(band.lower) else -res


def _taylor_function(fun: Any, n_out: int, name: str, *, time_only: bool, order: int) -> Any:
    """``(t, s, y) ↦ [F, F_t, F_y, F_tt, F_ty, F_yy]`` stacked (6·n_out); second derivatives 0 if order 1."""
    t, s, y = ca.MX.sym("t"), ca.MX.sym("s"), ca.MX.sym("y")
    val = fun(t) if time_only else fun(ca.vertcat(t, s, y))
    zero = ca.MX.zeros(n_out, 1)
    ft = ca.jacobian(val, t)
    fy = zero if time_only else ca.jacobian(val, y)
    ftt = ca.jacobian(ft, t) if order > 1 else zero
    fty = ca.jacobian(ft, y) if order > 1 and not time_only else zero
    fyy = ca.jacobian(fy, y) if order > 1 and not time_only else zero
    out = ca.densify(ca.vertcat(val, ft, fy, ftt, fty, fyy))
    return ca.Function(name, [ca.vertcat(t, s, y)], [out])


def _scatter(n_rows: int, n_cols: int, rows: np.ndarray, cols: np.ndarray, n_src: int) -> tuple[Any, Any]:
    """Sparsity of the (rows, cols) pattern and the constant matrix summing n_src values into its nonzeros."""
    keys = np.asarray(cols, dtype=np.int64) * n_rows + np.asarray(rows, dtype=np.int64)  # column-major order
    uniq, inverse = np.unique(keys, return_inverse=True)
    sp = ca.Sparsity.triplet(n_rows, n_cols, (uniq % n_rows).tolist(), (uniq // n_rows).tolist())
    gather = ca.DM(ca.Sparsity.triplet(uniq.size, n_src, inverse.tolist(), list(range(n_src))), 1.0)
    return sp, gather


def structured_derivatives(
    nlp: Any,
    *,
    jit: bool = False,
    exact_hessian: bool = False,
    side_free_bands: bool = False,
    compiled: list[str] | None = None,
) -> dict[str, Any]:
    """``grad_f``, ``jac_g`` and ``hess_lag`` functions for ``nlpsol``, exact and assembled per leg.

    :func:`structured_cores` with the Taylor data of ``nlp.weather``, each core wrapped as a function of
    ``(x, p[, lam_f, lam_g])``.

    Parameters
    ----------
    nlp : SpeedNLP
        The problem being built (its geometry, weather, ship, bands, row layout).
    jit : bool
        Compile the per-leg SX functions to C once per machine (:func:`formulations.compiled.compiled_function`;
        a function stays interpreted where no compiler runs).
    exact_hessian : bool
        Include the weather's second derivatives in the Hessian. The default leaves them out
        (the weather enters the Hessian through its first derivatives only, as it does for a
        multilinear interpolant); gradients and Jacobians are exact either way, so Ipopt converges
        to the same KKT point, and on the benchmark corridors in about half the iterations (the
        weather curvature makes the exact Hessian more indefinite).
    side_free_bands : bool
        The band rows are :func:`side_free_row`'s (the elastic phase-1 problem, :mod:`formulations.phase1`)
        instead of the sided residuals.
    compiled : list of str, optional
        With ``jit``, receives :attr:`StructuredCores.compiled` (how each leg function was compiled, or why not).

    Returns
    -------
    dict
        Options ``{"grad_f": ..., "jac_g": ..., "hess_lag": ...}`` for ``casadi.nlpsol``.
    """
    cores = structured_cores(nlp, jit=jit, exact_hessian=exact_hessian, side_free_bands=side_free_bands)
    if compiled is not None:
        compiled.extend(cores.compiled)
    memo = cores.taylor(nlp.weather)
    return {
        "grad_f": MemoCallback("grad_f", cores.grad, memo.first, ["x", "p"], ["f", "grad_f_x"], cache=True),
        "jac_g": MemoCallback("jac_g", cores.jac, memo.first, ["x", "p"], ["g", "jac_g_x"]),
        "hess_lag": MemoCallback(
            "hess_lag", cores.hess, memo.hessian, ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"]
        ),
    }


@dataclass(frozen=True)
class StructuredCores:
    """The weather-independent parts of :func:`structured_derivatives` (:func:`structured_cores`).

    Attributes
    ----------
    grad : casadi.Function
        ``(x, p, theta) ↦ (f, ∇f)``: objective and its gradient (dense, length ``nx``).
    jac : casadi.Function
        ``(x, p, theta) ↦ (g, ∂g/∂x)``: the rows and their sparse Jacobian.
    hess : casadi.Function
        ``(x, p, lam_f, lam_g, theta_h) ↦ triu ∇²(lam_f f + lam_g·g)``: upper triangle, sparse.
    taylor : callable
        ``taylor(weather, numeric=None)`` → an object whose ``first(x)`` and ``hessian(x)`` give the ``theta`` and
        ``theta_h`` inputs for a :class:`~formulations.weather_grid.WeatherGrid` with the NLP's fields and axes
        (so that one set of cores serves several weathers: the members of :mod:`formulations.robust_nlp`);
        ``numeric`` (default: as the NLP reads its own weather) evaluates a ``"smooth"`` weather in numpy
        (:meth:`WeatherGrid.tensor_spline`), else through CasADi's ``WeatherGrid.taylor_function``.
    compiled : tuple of str
        With ``jit``: per leg function, ``"<name>: cached"``, ``"<name>: compiled"`` or why it stays interpreted
        (:func:`formulations.compiled.compiled_function`); empty without.
    """

    grad: Any
    jac: Any
    hess: Any
    taylor: Callable[[Any], Any]
    compiled: tuple[str, ...] = ()


def structured_cores(
    nlp: Any, *, jit: bool = False, exact_hessian: bool = False, side_free_bands: bool = False
) -> StructuredCores:
    """The per-leg derivative functions of :func:`structured_derivatives` with the weather's Taylor data as an
    input (:class:`StructuredCores`); parameters as :func:`structured_derivatives`."""
    n, m, nb = nlp.n_legs, nlp.samples_per_leg, nlp.n_bands
    k_ = n * m
    nx, ng = nlp._nx, nlp._ng
    cor = nlp.corridor
    layout = nlp.sample_layout  # fractions and quadrature weights (N, m): per-leg inputs of the leg function
    # Taylor coefficients per field: (F, F_t, F_y), and (F_tt, F_ty, F_yy) only for the exact Hessian (without it
    # they would be inputs that are always 0: the same numbers, half the data and the leg functions' work)
    n_blk = 6 if exact_hessian else 3
    leg = _leg_graph(nlp, n_blk, side_free_bands)
    z, geo, theta, n_theta = leg.z, leg.geo, leg.theta, leg.n_theta
    sigma = ca.SX.sym("sigma")  # lam_f · fuel weight
    inputs = [z, geo, theta, leg.beta]
    how: list[str] = []

    def leg_function(name: str, ins: list, outs: list) -> Any:  # compiled through the disk cache with jit
        fun = ca.Function(name, ins, outs)
        if not jit:
            return fun
        fun, done = compiled_function(fun)
        how.append(f"{name}: {done}")
        return fun

    leg_grad = leg_function("leg_grad", inputs, [leg.fuel_sum, ca.gradient(leg.fuel_sum, z)]).map(n)
    groups = [_leg_group(nlp, leg.blocks, legs, with_b, with_e, leg.fuel_sum, sigma, inputs, leg_function)
              for legs, with_b, with_e in leg_kinds(nlp.row_legs, nlp.exclusion is not None)]  # fmt: skip
    legs = np.arange(n)
    z_idx = np.vstack([legs, legs + 1, n + 1 + legs, 2 * n + 1 + legs, 2 * n + 2 + legs])  # (5, N)
    c, nrm, tau = cor.centre_xy_nm, cor.normal_xy, cor.tangent_xy
    geo_fixed = ca.DM(np.vstack([c[:-1].T, c[1:].T, nrm[:-1].T, nrm[1:].T, tau.T]))
    beta_idx = np.array([[2 + b * k_ + k * m + j for k in range(n)] for b in range(nb) for j in range(m)])
    # ---- symbolic inputs of the nlpsol derivative functions ---------------------------
    x = ca.MX.sym("x", nx)
    p = ca.MX.sym("p", 2 + k_ * nb + n)  # weights, band edges, per-leg static power factors
    geo_dm = ca.vertcat(geo_fixed, p[2 + k_ * nb :].T, ca.DM(np.vstack([layout.fraction.T, layout.weight.T])))
    lam_f = ca.MX.sym("lam_f")
    lam_g = ca.MX.sym("lam_g", ng)
    zmat = ca.reshape(x[z_idx.T.ravel().tolist()], _N_Z, n)
    beta_mat = ca.reshape(p[beta_idx.T.ravel().tolist()], nb * m, n) if nb else ca.MX.zeros(m, n)
    dev_at = None
    if leg.contract:  # the samples' heading deviations at a point, as the leg functions compute them
        leg_dev = ca.Function("leg_dev", [z, geo, theta], [ca.vertcat(*leg.devs)]).map(n)
        geo_dev = ca.vertcat(geo_fixed, ca.DM.zeros(1, n), ca.DM(np.vstack([layout.fraction.T, layout.weight.T])))
        th_dev = ca.MX.sym("theta", n_theta * m, n)
        dev_at = ca.Function("dev_at", [x, th_dev], [leg_dev(zmat, geo_dev, th_dev)])
    lay = _RatioLayout(leg.plain, leg.r0, leg.n_rat, dev_at)
    th = ca.MX.sym("theta", n_theta * m, n)
    th_h = ca.MX.sym("theta_h", n_theta * m, n)
    args = [zmat, geo_dm, th, beta_mat]
    # grad_f
    fuel_k, grad_k = leg_grad(*args)
    sp_gf, gat_gf = _scatter(nx, 1, z_idx.T.ravel(), np.zeros(_N_Z * n, dtype=int), _N_Z * n)
    grad = ca.densify(ca.MX(sp_gf, ca.mtimes(gat_gf, ca.vec(grad_k)))) * p[0]
    e_t = np.zeros(nx)
    e_t[2 * n + 1 + n], e_t[2 * n + 1] = 1.0, -1.0
    grad = grad + p[1] * ca.DM(e_t)
    f_val = p[0] * ca.sum2(fuel_k) + p[1] * (x[3 * n + 1] - x[2 * n + 1])
    grad_core = ca.Function("grad_f_core", [x, p, th], [f_val, grad])
    jac_core, hess_core = _jac_hess_cores(
        nlp, groups, z_idx, (x, p, lam_f, lam_g), args, [zmat, geo_dm, th_h, beta_mat]
    )

    def taylor(weather: Any, numeric: bool | None = None) -> Any:
        numeric = nlp.numeric_weather if numeric is None else bool(numeric and weather.method == "smooth")
        return _taylor_source(nlp, x, zmat, n_theta, exact_hessian, lay, weather, numeric)

    return StructuredCores(grad_core, jac_core, hess_core, taylor, tuple(how))


class _LegGraph(NamedTuple):
    """One leg's SX graph (:func:`_leg_graph`): its inputs ``z`` (the leg's offsets, speed, times), ``geo``,
    ``theta`` (the samples' Taylor data, ``n_theta`` per sample), ``beta`` (band edges); its fuel [t] and row blocks;
    the samples' heading deviations [deg]; and the layout of the Taylor data (the plain fields, where the ratio
    block begins and its size, whether the power-ratio table comes contracted)."""

    z: Any
    geo: Any
    theta: Any
    beta: Any
    fuel_sum: Any
    blocks: _LegBlocks
    devs: list
    n_theta: int
    plain: tuple[str, ...]
    r0: int
    n_rat: int
    contract: bool


def _leg_graph(nlp: Any, n_blk: int, side_free_bands: bool) -> _LegGraph:
    """The per-leg SX function of z_k: the samples' physics (:func:`sample_physics`) on the weather's Taylor
    polynomials of order ``n_blk // 3``, summed into the leg's fuel and stacked into its row blocks."""
    m, nb = nlp.samples_per_leg, nlp.n_bands
    names = nlp.weather.field_names
    has_excl = nlp.exclusion is not None
    # with the weather read in numpy, the power-ratio table (speeds × headings of fields) comes contracted: one
    # Taylor polynomial of the ratio per sample (ratio_taylor_data) instead of the table's fields
    contract = bool(nlp.numeric_weather and nlp.weather.ratio_axes is not None)
    plain = tuple(nm for nm in names if not (contract and nm.startswith("ratio_")))
    nf_p = len(plain)
    edges = nlp.weather.ratio_axes[6] if contract else ()
    n_rat = RATIO_BLOCK[n_blk // 3] * (len(edges) + 1) if contract else 0
    r0 = 2 + n_blk * nf_p  # where the ratio block begins, then the exclusion's
    n_theta = r0 + n_rat + (3 * n_blk if has_excl else 0)  # t0, y0, weather Taylor, ratio Taylor, exclusion Taylor
    z = ca.SX.sym("z", _N_Z)
    # c_k, c_k+1, n_k, n_k+1, tangent, the static power factor f_k, the samples' fractions and weights
    geo = ca.SX.sym("geo", 11 + 2 * m)
    theta = ca.SX.sym("theta", n_theta * m)
    beta = ca.SX.sym("beta", max(nb, 1) * m)
    ya, yb, v, ta, tb = (z[i] for i in range(_N_Z))
    factor = geo[10]
    pxa, pya = geo[0] + ya * geo[4], geo[1] + ya * geo[5]
    pxb, pyb = geo[2] + yb * geo[6], geo[3] + yb * geo[7]
    dx, dy = pxb - pxa, pyb - pya
    length = ca.sqrt(dx**2 + dy**2)
    cos_d = (geo[8] * dx + geo[9] * dy) / length
    sin_d = (geo[8] * dy - geo[9] * dx) / length
    dt_sum = 0.0
    fuel_sum = 0.0
    loads, bands_res, drifts, sogs, excls, devs = [], [[] for _ in range(nb)], [], [], [], []
    for j in range(m):
        fj, wj = geo[11 + j], geo[11 + m + j]
        th = theta[j * n_theta : (j + 1) * n_theta]
        ts = ta + fj * (tb - ta)
        ys = ya + fj * (yb - ya)
        d_t, d_y = ts - th[0], ys - th[1]

        def taylor(block: Any, count: int, d_t: Any = d_t, d_y: Any = d_y) -> Any:
            f0, ft, fy = block[0:count], block[count : 2 * count], block[2 * count : 3 * count]
            if n_blk == 3:
                return f0 + ft * d_t + fy * d_y
            ftt, fty, fyy = block[3 * count : 4 * count], block[4 * count : 5 * count], block[5 * count : 6 * count]
            return f0 + ft * d_t + fy * d_y + 0.5 * ftt * d_t**2 + fty * d_t * d_y + 0.5 * fyy * d_y**2

        wvals = taylor(th[2:r0], nf_p)
        col = {name: wvals[i] for i, name in enumerate(plain)}
        b_j = [beta[b * m + j] for b in range(nb)]
        ratio_of = ratio_taylor(th[r0 : r0 + n_rat], d_t, d_y, edges) if contract else None
        phys = sample_physics(
            v, cos_d, sin_d, length * wj, factor, col, b_j, nlp.power, nlp.bands, nlp.g_over_2pi,
            nlp.weather.ratio_axes, ratio_of,
        )  # fmt: skip
        devs.append(phys["dev_deg"])
        dt_sum = dt_sum + phys["dt"]
        fuel_sum = fuel_sum + phys["fuel"]
        loads.append(phys["load"])
        for b, band in enumerate(nlp.bands):
            row = phys["res"][b]
            bands_res[b].append(side_free_row(band, phys["ratio"][b], row) if side_free_bands else row)
        drifts.append(phys["h_perp"])
        sogs.append(phys["sog"])
        if has_excl:
            ex = taylor(th[r0 + n_rat : r0 + n_rat + 3 * n_blk], 3)
            xs, yfs = pxa + fj * dx, pya + fj * dy
            excls.append(((xs - ex[0]) ** 2 + (yfs - ex[1]) ** 2 - ex[2] ** 2) / nlp.exclusion.radius_scale_nm**2)
    blocks = _LegBlocks(tb - ta - dt_sum, loads, bands_res, drifts + sogs if nlp._has_current else [], excls)
    return _LegGraph(z, geo, theta, beta, fuel_sum, blocks, devs, n_theta, plain, r0, n_rat, contract)


def _jac_hess_cores(
    nlp: Any, groups: list, z_idx: np.ndarray, syms: tuple, args: list, h_mats: list
) -> tuple[Any, Any]:
    """``jac_g_core`` (x, p, θ) and ``hess_lag_core`` (x, p, λ_f, λ_g, θ_h): per group of legs with the same rows
    (:func:`formulations.row_layout.leg_kinds`), its legs' columns of the leg inputs (``args`` = z, geo, θ, β for
    the Jacobian, ``h_mats`` = z, geo, θ_h, β for the Hessian), scattered into the whole problem's sparsity.
    ``syms``: the symbols x, p, λ_f, λ_g."""
    x, p, lam_f, lam_g = syms
    n, nx, ng = nlp.n_legs, nlp._nx, nlp._ng
    jr, jc, j_src, hr, hc, h_src = [], [], [], [], [], []
    g_full = ca.MX.zeros(ng, 1)
    for grp in groups:
        ks = grp.legs
        # leg_jac output (n_gl, 5·n_k), column c of the group's leg i at 5i + c; vec order (i, c, r)
        g_k, jac_k = grp.jac(*_leg_columns(args, ks, n))
        jr += [np.tile(grp.rows[:, i], _N_Z) for i in range(ks.size)]
        jc += [np.repeat(z_idx[:, k], grp.rows.shape[0]) for k in ks]
        j_src.append(ca.vec(jac_k))
        g_full[grp.rows.T.ravel().tolist()] = ca.vec(g_k)
        # hess_lag: upper triangle of Σ_k ∇²(σ fuel_k + λ_k·g_k)
        lam_mat = ca.reshape(lam_g[grp.rows.T.ravel().tolist()], grp.rows.shape[0], ks.size)
        h_args = _leg_columns(h_mats, ks, n)
        h_src.append(ca.vec(grp.hess(*h_args, lam_f * p[0], lam_mat)))  # (15, n_k)
        for k in ks:
            for a, b in _TRIU:
                ia, ib = z_idx[a, k], z_idx[b, k]
                hr.append(min(ia, ib))
                hc.append(max(ia, ib))
    jr_a, jc_a = np.concatenate(jr), np.concatenate(jc)
    sp_j, gat_j = _scatter(ng, nx, jr_a, jc_a, jr_a.size)
    jac = ca.MX(sp_j, ca.mtimes(gat_j, ca.vertcat(*j_src)))
    jac_core = ca.Function("jac_g_core", [x, p, args[2]], [g_full, jac])
    sp_h, gat_h = _scatter(nx, nx, np.array(hr), np.array(hc), len(hr))
    hess_full = ca.MX(sp_h, ca.mtimes(gat_h, ca.vertcat(*h_src)))
    hess_core = ca.Function("hess_lag_core", [x, p, lam_f, lam_g, h_mats[2]], [hess_full])
    return jac_core, hess_core


def _leg_columns(mats: list, legs: np.ndarray, n: int) -> list:
    """The columns ``legs`` of each of the (·, ``n``) matrices ``mats`` (the matrices themselves when they are all)."""
    return [a[:, legs.tolist()] for a in mats] if legs.size < n else mats


class _LegBlocks(NamedTuple):
    """A leg's row expressions by block (:func:`structured_cores`): in :func:`row_blocks`' order."""

    dyn: Any  # t_{k+1} − t_k − Σ dt
    loads: list  # m engine loads
    bands: list  # per band, m residuals
    current: list  # m drift rows then m SOG rows (empty without current rows)
    excls: list  # m exclusion residuals (empty without an exclusion)


class _LegGroup(NamedTuple):
    """Legs with the same rows: their indices, global row numbers (n_gl, n_k) and mapped leg functions."""

    legs: np.ndarray
    rows: np.ndarray
    jac: Any  # (z, geo, theta, beta) ↦ (g_leg, ∂g_leg/∂z), mapped over the group
    hess: Any  # (z, geo, theta_h, beta, σ, λ) ↦ upper triangle of ∇²(σ fuel + λ·g_leg), mapped


def _leg_group(
    nlp: Any, blocks: _LegBlocks, legs: np.ndarray, with_b: bool, with_e: bool, fuel: Any, sigma: Any,
    inputs: list, leg_function: Callable[[str, list, list], Any],
) -> _LegGroup:  # fmt: skip
    """The mapped Jacobian and Hessian functions of the legs ``legs`` and their rows' global numbers.

    The rows are numbered as :func:`formulations.row_layout.leg_row_numbers` says (:class:`~formulations.row_layout.RowLegs`).
    """
    parts = [blocks.dyn, *blocks.loads]
    if with_b:
        parts += [row for band_rows in blocks.bands for row in band_rows]
    parts += blocks.current
    if with_e:
        parts += blocks.excls
    g_leg = ca.vertcat(*parts)
    lam_leg = ca.SX.sym("lam", g_leg.shape[0])
    hess = ca.hessian(sigma * fuel + ca.dot(lam_leg, g_leg), inputs[0])[0]
    triu = ca.vertcat(*[hess[a, b] for a, b in _TRIU])
    jac = leg_function("leg_jac", inputs, [g_leg, ca.jacobian(g_leg, inputs[0])]).map(legs.size)
    hess_f = leg_function("leg_hess", [*inputs, sigma, lam_leg], [triu]).map(legs.size)
    return _LegGroup(legs, leg_row_numbers(nlp._rows, nlp.row_legs, legs, with_b, with_e), jac, hess_f)


def _sample_coordinates(nlp: Any, zmat: Any) -> tuple[Any, Any, np.ndarray]:
    """Time [h], across-track offset [nm] (MX rows, 1 × N·m, sample k·m + j) and along-track position [nm]
    (numpy, N·m) of every sample, from the legs' variables ``zmat`` (5 × N)."""
    n, m = nlp.n_legs, nlp.samples_per_leg
    frac = nlp.sample_layout.fraction.ravel()  # per-leg fractions (formulations.sample_layout), leg-major: k·m + j
    y_a, y_b = zmat[0, :], zmat[1, :]
    t_a, t_b = zmat[3, :], zmat[4, :]
    fr = ca.DM(frac[None, :])
    rep = np.repeat(np.arange(n), m).tolist()
    t_s = t_a[:, rep] + fr * (t_b[:, rep] - t_a[:, rep])
    y_s = y_a[:, rep] + fr * (y_b[:, rep] - y_a[:, rep])
    s = nlp.corridor.s_nm
    s_s = np.repeat(s[:-1], m) + frac * np.repeat(np.diff(s), m)
    return t_s, y_s, s_s


class _RatioLayout(NamedTuple):
    """Where the leg functions read what in a sample's Taylor data (:func:`structured_derivatives`)."""

    plain: tuple[str, ...]  # the weather fields read one by one (all of them unless the ratio table is contracted)
    start: int  # first row of the power-ratio block (ratio_taylor_data), after t0, y0 and the plain fields
    size: int  # its length (0: the ratio table is read field by field, or there is none)
    dev_at: Any  # CasADi function (x, theta) ↦ the samples' heading deviations (m × N) [deg], with a ratio block


def _taylor_source(
    nlp: Any, x: Any, zmat: Any, n_theta: int, exact_hessian: bool, lay: _RatioLayout, weather: Any, numeric: bool
) -> Any:
    """The per-sample Taylor data ``theta`` (n_theta·m × N) of ``weather`` at a point x, memoised: from the
    weather's numpy :class:`~formulations.splines.TensorSpline` when ``numeric`` (no CasADi spline is built), else
    from CasADi's mapped ``WeatherGrid.taylor_function``."""
    k_ = nlp.n_legs * nlp.samples_per_leg
    has_excl = nlp.exclusion is not None
    t_s, y_s, s_s = _sample_coordinates(nlp, zmat)
    pts = ca.vertcat(t_s, ca.DM(s_s[None, :]), y_s)
    excl: dict[int, Any] = {}
    if has_excl:
        for order in (1, 2) if exact_hessian else (1,):
            efun = _taylor_function(nlp.exclusion_function, 3, "excl_taylor", time_only=True, order=order)
            excl[order] = efun.map(k_)
    if numeric:
        coords = ca.Function("coords", [x], [ca.vertcat(t_s, y_s)])
        return _NumericTaylor(nlp, coords, s_s, excl, n_theta, exact_hessian, lay, weather)
    m, n = nlp.samples_per_leg, nlp.n_legs

    n_blk = 6 if exact_hessian else 3  # Taylor blocks the leg functions read (structured_derivatives)
    nf = len(nlp.weather.field_names)

    def theta_at(order: int) -> Any:
        parts = [t_s, y_s, weather.taylor_function(order).map(k_)(pts)[: n_blk * nf, :]]
        if has_excl:
            parts.append(excl[order](pts)[: 3 * n_blk, :])
        return ca.reshape(ca.vertcat(*parts), n_theta * m, n)

    theta1 = ca.Function("theta1", [x], [theta_at(1)])  # first derivatives: gradient and Jacobian
    theta_h = ca.Function("theta_h", [x], [theta_at(2)]) if exact_hessian else theta1
    return _TaylorMemo(theta1, theta_h)


class _NumericTaylor:
    """The weather's Taylor data at the last point asked for, evaluated in numpy
    (:meth:`formulations.splines.TensorSpline.evaluate`, the same numbers as CasADi's derivative splines),
    one evaluation per point for the gradient, the Jacobian and the Hessian (second derivatives left at 0
    for the first two, as :func:`_taylor_source`'s CasADi branch gives them)."""

    def __init__(
        self,
        nlp: Any,
        coords: Any,
        s_s: np.ndarray,
        excl: dict[int, Any],
        n_theta: int,
        exact_hessian: bool,
        lay: _RatioLayout,
        weather: Any,
    ) -> None:
        self._spline = weather.tensor_spline()
        names = weather.field_names
        self._plain = np.array([names.index(nm) for nm in lay.plain])
        self._lay, self._axes = lay, weather.ratio_axes
        if lay.size:
            nv, nd, nq = self._axes[2], self._axes[5], len(self._axes[6]) + 1
            where = [names.index(nm) for nm in ratio_field_names(self._axes)]
            self._table = np.array(where).reshape(nq, nv, nd)
        self._coords, self._s, self._excl = Buffered(coords), s_s, excl
        self._dev_at = Buffered(lay.dev_at) if lay.size else None
        self._n, self._m, self._n_theta = nlp.n_legs, nlp.samples_per_leg, n_theta
        self._order = 2 if exact_hessian else 1
        self._last: tuple[bytes, Any, Any] | None = None

    def _theta(self, x: Any) -> tuple[Any, Any]:
        key = np.asarray(x).tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1], self._last[2]
        k_, order, lay = self._n * self._m, self._order, self._lay
        nf_p = self._plain.size
        ts_ys = self._coords(x)[0].reshape(k_, 2).T  # (2, K): the (2, K) output's nonzeros, column-major
        pts = np.vstack([ts_ys[0], self._s, ts_ys[1]])
        full = np.zeros((self._n_theta, k_))
        full[:2] = ts_ys
        vals = self._spline.evaluate(pts, order).reshape(3 * order, -1, k_)  # (blocks, fields, K)
        full[2 : lay.start] = vals[:, self._plain].reshape(3 * order * nf_p, k_)
        e0 = lay.start + lay.size
        if self._excl:
            full[e0:] = np.asarray(self._excl[order](pts), dtype=float)[: 9 * order]
        if lay.size:
            dev = self._dev_at(x, self._shaped(full))[0].copy()  # (m, N) column-major: sample k·m + j
            v = np.repeat(np.asarray(x, dtype=float).ravel()[self._n + 1 : 2 * self._n + 1], self._m)
            full[lay.start : e0] = sector_taylor_data_at(vals, self._table, v, dev, self._axes)
        first = full
        if order == 2:  # the gradient's and the Jacobian's data: no second derivatives of the weather
            first = full.copy()
            first[2 + 3 * nf_p : 2 + 6 * nf_p] = 0.0
            size = lay.size // max(len(self._table), 1) if lay.size else 0
            for q in range(len(self._table) if lay.size else 0):  # each sector's R_tt, R_ty, R_yy
                first[lay.start + (q + 1) * size - 3 : lay.start + (q + 1) * size] = 0.0
            if self._excl:
                first[e0 + 9 :] = 0.0
        shaped = [self._shaped(a) for a in (first, full)]
        self._last = (key, shaped[0], shaped[1])
        return shaped[0], shaped[1]

    def _shaped(self, a: np.ndarray) -> np.ndarray:
        """(n_theta, K) → the nonzeros of the leg functions' dense (n_theta·m, N) input, column-major (leg k's
        column is its m samples' data one after the other)."""
        return np.ascontiguousarray(a.T).ravel()

    def first(self, x: Any) -> Any:
        return self._theta(x)[0]

    def hessian(self, x: Any) -> Any:
        return self._theta(x)[1]


class _TaylorMemo:
    """The weather's Taylor data at the last point asked for (Ipopt asks for the gradient, the
    Jacobian and the Hessian at the same iterate: one weather evaluation serves all three)."""

    def __init__(self, first: Any, hessian: Any) -> None:
        self._fns = {"first": first, "hessian": hessian}
        self._last: dict[str, tuple[bytes, Any]] = {}

    def _get(self, which: str, x: Any) -> Any:
        key = np.asarray(x).tobytes()
        hit = self._last.get(which)
        if hit is None or hit[0] != key:
            hit = (key, np.asarray(self._fns[which](x), dtype=float).ravel(order="F"))  # nonzeros, column-major
            self._last[which] = hit
        return hit[1]

    def first(self, x: Any) -> Any:
        return self._get("first", x)

    def hessian(self, x: Any) -> Any:
        if self._fns["hessian"] is self._fns["first"]:
            return self._get("first", x)
        return self._get("hessian", x)
