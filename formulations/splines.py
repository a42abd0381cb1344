"""The B-spline machinery of the weather tables: Schoenberg's cubic quasi-interpolant, its derivatives, and
its evaluation in numpy.

Split out of :mod:`formulations.common`; it serves :class:`~formulations.weather_grid.WeatherGrid`.
Two ways to evaluate the same spline:

* CasADi's ``Function.bspline`` (:func:`bspline_function`), differentiable by CasADi: what a caller that lets
  CasADi differentiate the graph needs (``SpeedNLP(structured=False)``, ``expand=True``, the robust NLP);
* :class:`TensorSpline`, a compiled kernel (numba) over arrays of points, with the first and second partial
  derivatives in time and across-track position from the derivatives of the basis functions. It holds the
  control points once;
  building it costs the padding of the data, nothing more. ``Function.bspline`` copies its coefficients
  through a Python list and, per derivative, builds another spline of the differenced coefficients: on a
  corridor's grid of ten million values that was most of the NLP's build time.

Both evaluate ``Σ c_abc B_a(t) B_b(s) B_c(y)`` with the uniform cubic B-spline ``B`` (de Boor 1978, ch. IX–X);
they agree to rounding (the test suite compares them).

Units: whatever the axes and data carry (the corridor NLP: hours, nautical miles, the fields' own units).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from formulations._jit import njit

__all__ = [
    "TensorSpline",
    "bspline_function",
    "is_uniform",
    "pad_quasi_spline",
    "quasi_spline",
    "ratio_field_names",
    "resample_linear",
    "sector_weights",
    "spline_derivative",
    "spline_weight_derivatives",
    "spline_weights",
]


def spline_weights(x: Any, x0: float, h: float, n: int, lib: Any) -> list[Any]:
    """Weights ``w_i(x)`` of the uniform cubic B-spline quasi-interpolant ``Σ_i w_i(x) f_i`` of nodes ``x0 + i h``.

    Schoenberg's quasi-interpolant with the data ``f_i`` as control points, extended linearly by one
    node at either end (``f_{-1} = 2f_0 − f_1``), as :class:`formulations.weather_grid.WeatherGrid`'s spline along
    its axes: C², exact for linear data, within the data's range away from the ends. The centred cubic B-spline
    is written with truncated powers, ``B(u) = [(u+2)₊³ − 4(u+1)₊³ + 6u₊³ − 4(u−1)₊³]/6`` for
    ``|u| ≤ 2`` (0 beyond), so that the same expression serves ``numpy`` and CasADi (``lib`` provides
    ``fmax`` and ``fmin``). ``x`` is held at the nearest node outside ``[x0, x0 + (n−1)h]``.
    """
    if n == 1:
        return [1.0]
    xc = lib.fmin(lib.fmax(x, x0), x0 + (n - 1) * h)
    u = (xc - x0) / h

    def b(d: Any) -> Any:
        d = lib.fmin(lib.fmax(d, -2.0), 2.0)
        p = [lib.fmax(d + k, 0.0) ** 3 for k in (2.0, 1.0, 0.0, -1.0)]
        return (p[0] - 4.0 * p[1] + 6.0 * p[2] - 4.0 * p[3]) / 6.0

    return _end_extended([b(u - i) for i in range(-1, n + 1)], n)  # f_{-1} … f_n


#: Half-width of the ramps of :func:`sector_weights` in the wave angle [deg]. Narrower ramps are exact closer to
#: the edges but steeper: on bench_nlp's storm corridor ±2° took Ipopt 77 iterations at 21 legs (23 with the old
#: heading-node table) and hit the 500-iteration limit at 500 legs; ±10° took 29 and 62 at 21 and 125 legs.
SECTOR_RAMP_DEG = 10.0


def sector_weights(cos_alpha: Any, edges_deg: tuple[float, ...], lib: Any, ramp_deg: float = SECTOR_RAMP_DEG) -> list:
    """Weights of the wave-angle sectors between ``edges_deg`` at the cosine of the wave angle α (0 = head sea).

    The power table keeps one field per sector of a model that steps at these edges (Kwon 2008: 30°, 60°,
    150°); the weights blend them. At each edge ``e`` a C² ramp ``H_e = S((x − cos e + h_e) / 2h_e)`` of
    ``x = cos α``, ``S(u) = 10u³ − 15u⁴ + 6u⁵`` on ``[0, 1]`` (held at 0 and 1 outside), rises from 0 (α beyond
    the edge) to 1 (α inside it); ``h_e = sin e · ramp_deg`` (in radians), so the ramp spans ``e ± ramp_deg`` to
    first order. Sector q's weight is ``H_{e_q} − H_{e_{q−1}}`` (``H = 0`` before the first edge, 1 after the
    last): the weights sum to 1 exactly, each is in [0, 1] while the ramps do not overlap, and exactly one is 1
    wherever α is more than about ``ramp_deg`` from every edge. A function of cos α, it needs no folding or
    wrapping of the angle. ``lib`` is ``numpy`` or ``casadi`` (``fmin``, ``fmax``).
    """
    steps = [0.0]
    for e in edges_deg:
        h = np.sin(np.radians(e)) * np.radians(ramp_deg)
        u = lib.fmin(lib.fmax((cos_alpha - np.cos(np.radians(e)) + h) / (2.0 * h), 0.0), 1.0)
        steps.append(u**3 * (10.0 - 15.0 * u + 6.0 * u**2))
    steps.append(1.0)
    return [steps[q + 1] - steps[q] for q in range(len(edges_deg) + 1)]


def ratio_field_names(axes: tuple) -> tuple[str, ...]:
    """The power-ratio table's field names by sector, speed node and heading node (:attr:`WeatherGrid.ratio_axes`)."""
    nv, nd, edges = axes[2], axes[5], axes[6] if len(axes) > 6 else ()
    sfx = [f"_s{q}" for q in range(len(edges) + 1)] if edges else [""]
    return tuple(f"ratio_{j}_{k}{x}" for x in sfx for j in range(nv) for k in range(nd))


def _end_extended(basis: list[Any], n: int) -> list[Any]:
    """The n weights of the data from the n + 2 basis values of ``f_{-1} … f_n`` (``f_{-1} = 2f_0 − f_1``)."""
    w = basis[1 : n + 1]
    w[0], w[1] = w[0] + 2.0 * basis[0], w[1] - basis[0]
    w[n - 1], w[n - 2] = w[n - 1] + 2.0 * basis[n + 1], w[n - 2] - basis[n + 1]
    return w


def spline_weight_derivatives(x: np.ndarray, x0: float, h: float, n: int) -> np.ndarray:
    """The weights of :func:`spline_weights` and their first and second derivatives in ``x``, numpy: (3, n, K).

    The derivatives of the same truncated-power expression, ``B'(u) = [3(u+2)₊² − 12(u+1)₊² + 18u₊² −
    12(u−1)₊²]/6`` and ``B''(u) = [6(u+2)₊ − 24(u+1)₊ + 36u₊ − 24(u−1)₊]/6``, chained through ``u = (x − x0)/h``;
    where ``x`` is held at an end node the derivative is that of CasADi's ``fmin``/``fmax`` (0 outside, ½ on the
    node itself), so that these are the numbers CasADi's automatic derivatives of :func:`spline_weights` give.
    """
    x = np.asarray(x, dtype=float).ravel()
    out = np.zeros((3, n, x.size))
    if n == 1:
        out[0] = 1.0
        return out
    xe = x0 + (n - 1) * h
    slope = np.where((x > x0) & (x < xe), 1.0, np.where((x == x0) | (x == xe), 0.5, 0.0)) / h
    u = (np.minimum(np.maximum(x, x0), xe) - x0) / h
    # all n + 2 basis functions at once, (n + 2, K): the same operations per element as spline_weights' ``b``
    d = np.minimum(np.maximum(u[None, :] - np.arange(-1.0, n + 1.0)[:, None], -2.0), 2.0)
    p = [np.maximum(d + k, 0.0) for k in (2.0, 1.0, 0.0, -1.0)]
    cubes = [pk**3 for pk in p]
    basis = [(cubes[0] - 4.0 * cubes[1] + 6.0 * cubes[2] - 4.0 * cubes[3]) / 6.0]
    squares = [pk**2 for pk in p]
    basis.append((3.0 * squares[0] - 12.0 * squares[1] + 18.0 * squares[2] - 12.0 * squares[3]) / 6.0)
    basis.append((6.0 * p[0] - 24.0 * p[1] + 36.0 * p[2] - 24.0 * p[3]) / 6.0)
    for order, b in enumerate(basis):
        out[order] = _end_extended(list(b), n)
        if order:
            out[order] *= slope**order
    return out


def is_uniform(g: np.ndarray) -> bool:
    """Whether the nodes ``g`` are equally spaced (to 1e-9 relative)."""
    d = np.diff(g)
    return bool(np.allclose(d, d[0], rtol=1e-9, atol=0.0))


def resample_linear(data: np.ndarray, g: np.ndarray, new: np.ndarray, axis: int) -> np.ndarray:
    """Linear interpolation of ``data`` along ``axis`` from nodes ``g`` to nodes ``new``."""
    idx = np.clip(np.searchsorted(g, new, side="right") - 1, 0, g.size - 2)
    w = (new - g[idx]) / (g[idx + 1] - g[idx])
    shape = [1] * data.ndim
    shape[axis] = new.size
    w = w.reshape(shape)
    return np.take(data, idx, axis=axis) * (1.0 - w) + np.take(data, idx + 1, axis=axis) * w


def quasi_spline(grids: list[np.ndarray], data: np.ndarray) -> tuple[list[np.ndarray], np.ndarray, list[int]]:
    """Cubic tensor B-spline whose control points are the data (Schoenberg's quasi-interpolant).

    On a uniform axis with spacing ``h`` the knots are the grid nodes extended by ``3h`` on either
    side and the data are padded by one linearly extrapolated node per side, so every grid node is
    the centre of one cubic B-spline. The result is C², reproduces linear fields exactly, stays
    within the range of the data away from the outermost cells (no overshoot), and differs from
    the multilinear interpolant by ``O(h²)`` (at a node, by ``(f_{i-1} − 2 f_i + f_{i+1})/6``). It
    needs no fitting, so it is built instantly.

    Returns
    -------
    knots : list of numpy.ndarray
        Knot vector per axis.
    coef : numpy.ndarray, shape (n_fields, n0 + 2, n1 + 2, n2 + 2)
        Control points: a view of a fields-last array (one contiguous row of fields per node, the layout
        :class:`TensorSpline` keeps, so it takes them without a copy).
    degree : list of int
        ``[3, 3, 3]``.
    """
    coef = np.moveaxis(np.empty((*(n + 2 for n in data.shape[1:]), data.shape[0])), -1, 0)
    coef[:, 1:-1, 1:-1, 1:-1] = data
    return pad_quasi_spline(grids, coef)


def pad_quasi_spline(grids: list[np.ndarray], coef: np.ndarray) -> tuple[list[np.ndarray], np.ndarray, list[int]]:
    """:func:`quasi_spline` of the data already in the interior of its control points ``coef`` (n_fields, n0 + 2,
    n1 + 2, n2 + 2): the pads are written in place and ``coef`` itself is returned (no copy of the data)."""
    knots = []
    # the padded control points written in place (one array, not a copy per axis): axis by axis, each pad over the
    # axes padded before it and the interior of those after it, as concatenating per axis would give
    for axis, g in enumerate(grids):
        h = float(g[1] - g[0])

        def at(i: int, axis: int = axis) -> tuple:
            return (slice(None), *(i if b == axis else slice(None) if b < axis else slice(1, -1) for b in range(3)))

        coef[at(0)] = 2.0 * coef[at(1)] - coef[at(2)]
        coef[at(-1)] = 2.0 * coef[at(-2)] - coef[at(-3)]
        knots.append(np.concatenate([g[0] + h * np.arange(-3, 0), g, g[-1] + h * np.arange(1, 4)]))
    return knots, coef, [3, 3, 3]


def spline_derivative(
    knots: list[np.ndarray], coef: np.ndarray, degree: list[int], axis: int
) -> tuple[list[np.ndarray], np.ndarray, list[int]]:
    """Partial derivative of a tensor B-spline along ``axis``: degree − 1, differenced coefficients.

    ``d/dx Σ c_i B_{i,p} = Σ p (c_{i+1} − c_i) / (t_{i+p+1} − t_{i+1}) B_{i+1,p−1}`` on the knots
    without their first and last entries (de Boor 1978, ch. X).
    """
    t, p = knots[axis], degree[axis]
    diff = np.diff(coef, axis=axis + 1)
    span = (t[p + 1 : -1] - t[1 : -p - 1])[: diff.shape[axis + 1]]
    shape = [1] * coef.ndim
    shape[axis + 1] = span.size
    new_knots = list(knots)
    new_knots[axis] = t[1:-1]
    new_degree = list(degree)
    new_degree[axis] = p - 1
    return new_knots, p * diff / span.reshape(shape), new_degree


def bspline_function(name: str, knots: list[np.ndarray], coef: np.ndarray, degree: list[int]) -> Any:
    """``casadi.Function.bspline`` from per-axis knots and coefficients (n_out, n0, n1, n2).

    The coefficients go in as a numpy array (CasADi's wrapper accepts it for its list of floats; a
    ``.tolist()`` first would make ten million Python floats on a corridor's grid).
    """
    import casadi as ca

    opts = {"lookup_mode": ["exact"] * len(knots)}  # uniform knots: O(1) cell lookup (the default scans)
    flat = np.ravel(coef, order="F")  # outputs fastest, then the axes in Fortran order
    return ca.Function.bspline(
        name, [np.asarray(k, dtype=float) for k in knots], flat, list(degree), coef.shape[0], opts
    )


@njit
def _cubic_weights(u: float, h: float, order: int, w: np.ndarray) -> None:  # pragma: no cover - compiled
    """The four uniform cubic B-spline weights on a cell at the local coordinate ``u`` in [0, 1] and, up to
    ``order``, their derivatives along the axis of node spacing ``h``: ``w[r, a] = d^r/dx^r B_{i+a}`` (rows 0..order
    of ``w`` (3, 4); ``B`` centred on the padded control points ``i .. i+3`` of the cell ``[i, i+1]``)."""
    v = 1.0 - u
    u2 = u * u
    u3 = u2 * u
    w[0, 0] = v * v * v / 6.0
    w[0, 1] = (3.0 * u3 - 6.0 * u2 + 4.0) / 6.0
    w[0, 2] = (-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) / 6.0
    w[0, 3] = u3 / 6.0
    if order >= 1:
        w[1, 0] = -0.5 * v * v / h
        w[1, 1] = (1.5 * u2 - 2.0 * u) / h
        w[1, 2] = (-1.5 * u2 + u + 0.5) / h
        w[1, 3] = 0.5 * u2 / h
    if order >= 2:
        h2 = h * h
        w[2, 0] = v / h2
        w[2, 1] = (3.0 * u - 2.0) / h2
        w[2, 2] = (1.0 - 3.0 * u) / h2
        w[2, 3] = u / h2


#: The (t, y) derivative orders of the blocks of :meth:`TensorSpline.evaluate`: F, F_t, F_y, F_tt, F_ty, F_yy.
_BLOCK_ORDERS = np.array([[0, 0], [1, 0], [0, 1], [2, 0], [1, 1], [0, 2]], dtype=np.int64)


@njit
def _evaluate_points(
    rows: np.ndarray, strides: np.ndarray, x0: np.ndarray, h: np.ndarray, hi: np.ndarray, n_cells: np.ndarray,
    points: np.ndarray, n_blocks: int, out: np.ndarray,
) -> None:  # fmt: skip  # pragma: no cover - compiled
    """:meth:`TensorSpline.evaluate` into ``out`` (n_blocks, n_fields, K): per point, its cell, the basis weights
    along each axis and the sum over the cell's 4 × 4 × 4 control points (``rows``, one contiguous row of fields
    per node), each block's derivative zero along an axis where the point is held at the grid's edge."""
    n_fields = rows.shape[1]
    order = 2 if n_blocks > 3 else (1 if n_blocks > 1 else 0)
    wts = np.zeros((3, 3, 4))  # per axis (t, s, y): derivative order × 4 weights
    acc = np.zeros((n_blocks, n_fields))
    wgt = np.zeros(n_blocks)
    cell = np.zeros(3, dtype=np.int64)
    held = np.zeros(3, dtype=np.bool_)
    for k in range(points.shape[1]):
        for ax in range(3):
            p = points[ax, k]
            held[ax] = p < x0[ax] or p > hi[ax]
            r = (min(max(p, x0[ax]), hi[ax]) - x0[ax]) / h[ax]
            cell[ax] = min(max(int(np.floor(r)), 0), n_cells[ax] - 1)
            _cubic_weights(r - cell[ax], h[ax], order if ax != 1 else 0, wts[ax])
        acc[:, :] = 0.0
        base = cell[0] * strides[0] + cell[1] * strides[1] + cell[2]
        for a in range(4):
            for b in range(4):
                for c in range(4):
                    row = rows[base + a * strides[0] + b * strides[1] + c]
                    for i in range(n_blocks):
                        wgt[i] = wts[0, _BLOCK_ORDERS[i, 0], a] * wts[1, 0, b] * wts[2, _BLOCK_ORDERS[i, 1], c]
                    if n_blocks == 1:  # one loop over the fields per block count: vectorised by the compiler
                        for f in range(n_fields):
                            acc[0, f] += wgt[0] * row[f]
                    elif n_blocks == 3:
                        for f in range(n_fields):
                            x = row[f]
                            acc[0, f] += wgt[0] * x
                            acc[1, f] += wgt[1] * x
                            acc[2, f] += wgt[2] * x
                    else:
                        for f in range(n_fields):
                            x = row[f]
                            acc[0, f] += wgt[0] * x
                            acc[1, f] += wgt[1] * x
                            acc[2, f] += wgt[2] * x
                            acc[3, f] += wgt[3] * x
                            acc[4, f] += wgt[4] * x
                            acc[5, f] += wgt[5] * x
        for i in range(n_blocks):
            flat = (_BLOCK_ORDERS[i, 0] > 0 and held[0]) or (_BLOCK_ORDERS[i, 1] > 0 and held[2])
            for f in range(n_fields):
                out[i, f, k] = 0.0 if flat else acc[i, f]


class TensorSpline:
    """A uniform cubic tensor B-spline on (t, s, y) evaluated by a compiled kernel, with its derivatives in t and y.

    Parameters
    ----------
    grids : list of three numpy.ndarray
        Uniform, increasing axes, at least 2 nodes each (the data's nodes; :func:`quasi_spline` pads them).
    coef : numpy.ndarray, shape (n_fields, n0 + 2, n1 + 2, n2 + 2)
        Control points, as :func:`quasi_spline` returns them.

    Notes
    -----
    The same function as :func:`bspline_function` of ``quasi_spline(grids, data)``, held at the nearest
    edge outside the grid (as :meth:`formulations.weather_grid.WeatherGrid.interpolant`), with the derivative
    along an axis zero where the point is clamped on it (as ``WeatherGrid.taylor_function``).
    """

    def __init__(self, grids: list[np.ndarray], coef: np.ndarray) -> None:
        self.n_fields = int(coef.shape[0])
        self.x0 = np.array([float(g[0]) for g in grids])
        self.h = np.array([float(g[1] - g[0]) for g in grids])
        self.hi = np.array([float(g[-1]) for g in grids])
        self.n_cells = np.array([g.size - 1 for g in grids], dtype=np.int64)
        shape = coef.shape[1:]
        # control points as rows of fields: one contiguous row per (t, s, y) node, read 64 at a time
        self._rows = np.ascontiguousarray(np.moveaxis(coef, 0, -1)).reshape(-1, self.n_fields)
        #: the control points (n_fields, n0 + 2, n1 + 2, n2 + 2), a view of the rows (no second copy)
        self.coef = np.moveaxis(self._rows.reshape(*shape, self.n_fields), -1, 0)
        self._strides = np.array([shape[1] * shape[2], shape[2], 1], dtype=np.int64)

    def evaluate(self, points: np.ndarray, order: int = 0) -> np.ndarray:
        """Values and partial derivatives at points (3, K) [t, s, y].

        Returns
        -------
        numpy.ndarray
            ``order=0``: (n_fields, K), the values ``F``. ``order=1``: (3·n_fields, K), ``[F, F_t, F_y]``
            stacked by block; ``order=2``: (6·n_fields, K), ``[F, F_t, F_y, F_tt, F_ty, F_yy]``.
        """
        # C order and writable: a read-only array (a broadcast, xarray's values) would compile a second signature
        pts = np.require(points, dtype=float, requirements=("C", "W"))
        k_ = pts.shape[1]
        n_blocks = (1, 3, 6)[order]
        out = np.empty((n_blocks, self.n_fields, k_))
        _evaluate_points(self._rows, self._strides, self.x0, self.h, self.hi, self.n_cells, pts, n_blocks, out)
        return out.reshape(n_blocks * self.n_fields, k_)
