"""The weather on the corridor's (time, along-track, across-track) grid, as the corridor NLPs read it.

Split out of :mod:`formulations.common`. Nothing here imports :mod:`optroute`; units as there: hours [h],
nautical miles [nm], knots [kn], metres [m], seconds [s].
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from formulations.common import FormulationInputError, as_float_array
from formulations.splines import (
    TensorSpline,
    bspline_function,
    is_uniform,
    pad_quasi_spline,
    quasi_spline,
    ratio_field_names,
    resample_linear,
    spline_derivative,
)

__all__ = ["WeatherGrid"]

_WEATHER_FIELDS = (
    "hs_m",
    "period_s",
    "wave_to_along",
    "wave_to_across",
    "current_along_kn",
    "current_across_kn",
    "wind_along_kn",
    "wind_across_kn",
)


@dataclass(frozen=True)
class WeatherGrid:
    """Weather on the corridor's (time, along-track, across-track) grid.

    Vector fields are given by components along the centreline segment's tangent
    ("along", the direction of travel) and to port of it ("across", the direction of
    positive offset). Every field is an array of shape ``(nt, ns, ny)`` or a scalar
    (constant); optional fields may be ``None`` (zero, and left out of the model).

    Parameters
    ----------
    t_h, s_nm, y_nm : array_like, 1-D, strictly increasing
        Grid axes: hours since departure [h], along-track [nm], across-track [nm].
        A single-point axis means "constant along this axis".
    hs_m : array_like
        Significant wave height [m].
    period_s : array_like
        Wave period used for T_E and the wave speeds (peak or mean, the caller's choice) [s], > 0.
    wave_to_along, wave_to_across : array_like, optional
        Components of the direction the waves propagate **to** (any positive magnitude; they are
        normalised after interpolation, so interpolating components avoids the 0/360° wrap).
        ``None``: zero vector, which makes ``cos χ = 0`` (beam sea) everywhere.
    current_along_kn, current_across_kn : array_like, optional
        Surface current [kn] (the vector it flows to).
    wind_along_kn, wind_across_kn : array_like, optional
        Wind at 10 m [kn] (the vector it blows to).
    power_ratio : array_like, optional
        The ship's brake power divided by the calm-water baseline of :class:`PowerModel`,
        ``R = P_ship / P_calm(V)`` [-], tabulated at every grid node for the speeds
        ``ratio_speed_kn`` and the heading deviations ``ratio_heading_deg``: shape
        ``(nt, ns, ny, nv, nd)``, finite and positive. The NLP reads it through the weather's cubic
        B-spline quasi-interpolant in all five directions (the data are the control points, padded
        linearly at the ends; :func:`spline_weights` in speed and heading): C², exact for data linear
        along an axis, and variation-diminishing — no overshoot or ringing between nodes where the
        model steps (Kwon's Beaufort and direction sectors); outside the speed and heading range the
        value at the nearest edge. A float64 array is held, not copied (some 10⁷ values on a corridor):
        do not change it after.
    ratio_speed_kn : array_like, shape (nv,), optional
        Speeds through water of the table [kn], uniformly spaced and increasing.
    ratio_heading_deg : array_like, shape (nd,), optional
        Heading deviations of the table [deg]: the ship's heading minus the centreline direction
        at the node, positive to port (counter-clockwise), uniformly spaced and increasing.
    ratio_sector_edges_deg : tuple of float, optional
        Edges of the wave-angle sectors of a model that steps there (Kwon's 30°, 60°, 150°), increasing in
        (0°, 180°): ``power_ratio`` then has a last axis of one field per sector, ``(nt, ns, ny, nv, nd, nq)``,
        nq = edges + 1, blended by the sample's wave angle (:func:`formulations.splines.sector_weights`).
    method : {"smooth", "linear", "bspline"}
        ``"smooth"`` (default): cubic B-spline quasi-interpolant (``casadi.Function.bspline`` with the
        data as control points; C², no overshoot inside the grid, built instantly; non-uniform axes are first
        resampled linearly to a uniform one). ``"linear"``: CasADi's multilinear interpolant, exact
        at the nodes but with kinks between cells that stall Ipopt's convergence (its second
        derivatives are taken as zero). ``"bspline"``: CasADi's interpolating cubic B-spline (exact at
        the nodes, smooth, but its fit is slow on large grids).
    """

    t_h: np.ndarray
    s_nm: np.ndarray
    y_nm: np.ndarray
    hs_m: ArrayLike
    period_s: ArrayLike
    wave_to_along: ArrayLike | None = None
    wave_to_across: ArrayLike | None = None
    current_along_kn: ArrayLike | None = None
    current_across_kn: ArrayLike | None = None
    wind_along_kn: ArrayLike | None = None
    wind_across_kn: ArrayLike | None = None
    power_ratio: ArrayLike | None = None
    ratio_speed_kn: ArrayLike | None = None
    ratio_heading_deg: ArrayLike | None = None
    ratio_sector_edges_deg: tuple[float, ...] = ()
    method: str = "smooth"

    def __post_init__(self) -> None:
        if self.method not in ("smooth", "linear", "bspline"):
            raise FormulationInputError(f"method must be 'smooth', 'linear' or 'bspline', got {self.method!r}")
        self._check_table()
        axes = []
        for name in ("t_h", "s_nm", "y_nm"):
            ax = as_float_array(getattr(self, name), name, ndim=1)
            if ax.size == 0 or (np.diff(ax) <= 0).any():
                raise FormulationInputError(f"{name} must be non-empty and strictly increasing")
            object.__setattr__(self, name, ax)
            axes.append(ax)
        shape = tuple(a.size for a in axes)
        for name in ("wave_to", "current", "wind"):
            pair = [f for f in _WEATHER_FIELDS if f.startswith(name)]
            given = [getattr(self, f) is not None for f in pair]
            if any(given) and not all(given):
                raise FormulationInputError(f"give both or neither of {pair}")
        for f in _WEATHER_FIELDS:
            val = getattr(self, f)
            if val is None:
                continue
            arr = as_float_array(val, f)
            if arr.ndim == 0:
                arr = np.full(shape, float(arr))
            if arr.shape != shape:
                raise FormulationInputError(f"{f} must have the grid shape (nt, ns, ny) = {shape}, got {arr.shape}")
            object.__setattr__(self, f, arr)
        if (np.asarray(self.hs_m) < 0).any():
            raise FormulationInputError("hs_m must be >= 0")
        if (np.asarray(self.period_s) <= 0).any():
            raise FormulationInputError("period_s must be > 0")

    def _check_table(self) -> None:
        given = [getattr(self, f) is not None for f in ("power_ratio", "ratio_speed_kn", "ratio_heading_deg")]
        if not any(given):
            return
        if not all(given):
            raise FormulationInputError("give power_ratio, ratio_speed_kn and ratio_heading_deg together, or none")
        axes = []
        for name in ("ratio_speed_kn", "ratio_heading_deg"):
            ax = as_float_array(getattr(self, name), name, ndim=1)
            d = np.diff(ax)
            if ax.size == 0 or (d <= 0).any() or (ax.size > 2 and not np.allclose(d, d[0], rtol=1e-9)):
                raise FormulationInputError(f"{name} must be non-empty, increasing and uniformly spaced, got {ax}")
            object.__setattr__(self, name, ax)
            axes.append(ax)
        edges = tuple(float(e) for e in self.ratio_sector_edges_deg)
        if edges and not (0.0 < edges[0] and edges[-1] < 180.0 and np.all(np.diff(edges) > 0)):
            raise FormulationInputError(f"ratio_sector_edges_deg must increase inside (0, 180) deg, got {edges}")
        object.__setattr__(self, "ratio_sector_edges_deg", edges)
        shape = (np.size(self.t_h), np.size(self.s_nm), np.size(self.y_nm), axes[0].size, axes[1].size)
        shape += (len(edges) + 1,) if edges else ()
        r = as_float_array(self.power_ratio, "power_ratio", copy=False)  # held, not copied: some 10⁷ values
        if r.shape != shape:
            raise FormulationInputError(
                f"power_ratio must have shape (nt, ns, ny, nv, nd[, nq]) = {shape}, got {r.shape}"
            )
        if (r <= 0).any():
            k = tuple(int(i) for i in np.argwhere(r <= 0)[0])
            raise FormulationInputError(f"power_ratio must be > 0; it is {r[k]!r} at index {k}")
        object.__setattr__(self, "power_ratio", r)

    @property
    def ratio_axes(self) -> tuple | None:
        """``(V_0, ΔV, nv, δ_0, Δδ, nd, sector edges)`` of the power-ratio table [kn, deg], None without one."""
        if self.power_ratio is None:
            return None
        v, d = np.asarray(self.ratio_speed_kn), np.asarray(self.ratio_heading_deg)
        dv = float(v[1] - v[0]) if v.size > 1 else 1.0
        dd = float(d[1] - d[0]) if d.size > 1 else 1.0
        return float(v[0]), dv, int(v.size), float(d[0]), dd, int(d.size), self.ratio_sector_edges_deg

    @property
    def field_names(self) -> tuple[str, ...]:
        """Names of the fields present, in the interpolant's output order.

        The power-ratio table contributes ``ratio_j_k`` (speed node j, heading node k), or ``ratio_j_k_sq`` per
        wave-angle sector q.
        """
        names = ["hs_m", "period_s"]
        for pair in (("wave_to_along", "wave_to_across"), ("current_along_kn", "current_across_kn")):
            if getattr(self, pair[0]) is not None:
                names += list(pair)
        if self.wind_along_kn is not None:
            names += ["wind_along_kn", "wind_across_kn"]
        if self.power_ratio is not None:
            names += list(ratio_field_names(self.ratio_axes))
        return tuple(names)

    def _field_data(self, pad: int = 0) -> np.ndarray:
        """Every field (nt, ns, ny, n_fields) in :attr:`field_names` order, fields last (one contiguous row per node,
        the layout of :class:`~formulations.splines.TensorSpline`'s control points: no transposing copy after).

        With ``pad``, inside an array ``pad`` nodes larger at either end of every axis (left unset): the
        control points of the quasi-interpolant written once (:func:`~formulations.splines.pad_quasi_spline`)."""
        plain = [f for f in self.field_names if not f.startswith("ratio_")]
        shape = np.shape(getattr(self, plain[0]))
        buf = np.empty((*(n + 2 * pad for n in shape), len(self.field_names)))
        out = buf[(slice(pad, buf.shape[0] - pad), slice(pad, buf.shape[1] - pad), slice(pad, buf.shape[2] - pad))]
        for i, f in enumerate(plain):
            out[..., i] = getattr(self, f)
        if self.power_ratio is not None:
            c = np.asarray(self.power_ratio)
            c = c if c.ndim == 6 else c[..., None]
            # fields ratio_j_k_sq in the order q, j, k (ratio_field_names): a view of the last axis split three ways
            out[..., len(plain) :].reshape(*shape, c.shape[5], c.shape[3], c.shape[4])[...] = np.moveaxis(c, 5, 3)
        return buf

    def _prepared(self) -> tuple[list[np.ndarray], np.ndarray]:
        """Grid axes and data (n_fields, nt, ns, ny) ready for CasADi: no singleton axis, uniform for "smooth".

        The data are a view of a fields-last array (:meth:`_field_data`)."""
        grids = [np.asarray(self.t_h), np.asarray(self.s_nm), np.asarray(self.y_nm)]
        data = self._field_data()
        min_pts = 4 if self.method == "bspline" else 2
        for axis in range(3):
            g = grids[axis]
            if g.size == 1:  # constant along this axis: duplicate the slab
                g = np.array([g[0], g[0] + 1.0])
                data = np.concatenate([data, data], axis=axis)
            if g.size < min_pts or (self.method == "smooth" and not is_uniform(g)):
                # resample linearly (keeps the data's multilinear interpolant between old nodes)
                step = float(np.min(np.diff(g)))
                count = max(min_pts, min(int(np.ceil((g[-1] - g[0]) / step)) + 1, 4 * g.size))
                new = np.linspace(g[0], g[-1], count)
                data = resample_linear(data, g, new, axis)
                g = new
            grids[axis] = g
        return grids, np.moveaxis(data, -1, 0)

    def _memo(self) -> dict[Any, Any]:
        """What is built from the data, once per grid (the data are frozen): the spline's control points, the
        CasADi functions. Not pickled (:meth:`__getstate__`); a ``dataclasses.replace`` copy starts empty."""
        memo = self.__dict__.get("_built")
        if memo is None:
            memo = {}
            object.__setattr__(self, "_built", memo)
        return memo

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state.pop("_built", None)
        return state

    def tensor_spline(self) -> TensorSpline:
        """The ``"smooth"`` quasi-interpolant of every field as a numpy :class:`~formulations.splines.TensorSpline`
        (built once per grid): values and derivatives at many points without building any CasADi function."""
        if self.method != "smooth":
            raise FormulationInputError(f"tensor_spline needs method='smooth', this grid has method={self.method!r}")
        memo = self._memo()
        if "tensor" not in memo:
            grids = [np.asarray(self.t_h), np.asarray(self.s_nm), np.asarray(self.y_nm)]
            if all(g.size > 1 and is_uniform(g) for g in grids):  # the data as they are: written once, padded
                knots, coef, _ = pad_quasi_spline(grids, np.moveaxis(self._field_data(pad=1), -1, 0))
            else:
                grids, data = self._prepared()
                knots, coef, _ = quasi_spline(grids, data)
            memo["tensor"], memo["knots"] = TensorSpline(grids, coef), knots
        return memo["tensor"]

    def _part(self, axes: tuple[int, ...]) -> Any:
        """The CasADi B-spline of the ``"smooth"`` table differentiated along ``axes`` (built once per grid)."""
        memo = self._memo()
        key = ("part", axes)
        if key not in memo:
            spline = self.tensor_spline()
            k, c, d = memo["knots"], spline.coef, [3, 3, 3]
            for ax in axes:
                k, c, d = spline_derivative(k, c, d, ax)
            memo[key] = bspline_function("f" + "".join("tsy"[a] for a in axes), k, c, d)
        return memo[key]

    def _raw_interpolant(self, grids: list[np.ndarray], data: np.ndarray) -> Any:
        import casadi as ca

        if self.method == "smooth":
            return self._part(())
        # CasADi layout: outputs fastest, then the grid axes in Fortran order.
        return ca.interpolant("weather", self.method, grids, data.ravel(order="F"))

    def _axes_bounds(self) -> tuple[list[float], list[float]]:
        """The first and last node of every axis as the interpolants see them (after :meth:`_prepared`)."""
        if self.method == "smooth":
            sp = self.tensor_spline()
            return sp.x0.tolist(), sp.hi.tolist()
        grids, _ = self._prepared()
        return [float(g[0]) for g in grids], [float(g[-1]) for g in grids]

    def interpolant(self) -> Any:
        """A CasADi function ``(t, s, y) ↦ fields`` (3 inputs stacked, ``len(field_names)`` outputs), built once
        per grid.

        Outside the grid every field is held at its value on the nearest edge (the inputs are
        clamped to the grid; a B-spline would otherwise drop to zero there). Solutions report
        samples outside the grid in ``SampleState.outside_grid``.
        """
        import casadi as ca

        memo = self._memo()
        if "interpolant" not in memo:
            lo, hi = self._axes_bounds()
            inner = self._part(()) if self.method == "smooth" else self._raw_interpolant(*self._prepared())
            x = ca.MX.sym("tsy", 3)
            memo["interpolant"] = ca.Function("weather", [x], [inner(ca.fmin(ca.fmax(x, ca.DM(lo)), ca.DM(hi)))])
        return memo["interpolant"]

    def taylor_function(self, order: int = 1) -> Any:
        """CasADi function ``(t, s, y) ↦ [F, F_t, F_y, F_tt, F_ty, F_yy]`` (6·n_fields, stacked by block), built
        once per grid and order.

        The partial derivatives in time and across-track position of every field, consistent with
        :meth:`interpolant` (zero outside the grid along an axis where the field is held constant);
        the second derivatives are zero for ``order=1``. For ``"smooth"`` they are explicit
        derivative splines (lower-degree B-splines with differenced coefficients, cheaper than
        differentiating the spline node); otherwise CasADi's derivatives of the interpolant.
        :meth:`tensor_spline` gives the same numbers in numpy.
        """
        memo = self._memo()
        key = ("taylor", int(order))
        if key not in memo:
            memo[key] = self._taylor_function(order)
        return memo[key]

    def _taylor_function(self, order: int) -> Any:
        import casadi as ca

        nf = len(self.field_names)
        lo, hi = self._axes_bounds()
        x = ca.MX.sym("tsy", 3)
        xc = ca.fmin(ca.fmax(x, ca.DM(lo)), ca.DM(hi))
        inside = [ca.logic_and(x[i] >= lo[i], x[i] <= hi[i]) for i in range(3)]
        zero = ca.MX.zeros(nf, 1)
        if self.method == "smooth":
            blocks = [self._part(axes)(xc) for axes in ((), (0,), (2,))]
            if order > 1:
                blocks += [self._part(axes)(xc) for axes in ((0, 0), (0, 2), (2, 2))]
        else:
            grids, data = self._prepared()
            xs = ca.MX.sym("xs", 3)
            fun = ca.Function("f", [xs], [self._raw_interpolant(grids, data)(xs)])
            val = fun(xc)
            jac = ca.jacobian(fun(xs), xs)
            jf = ca.Function("j", [xs], [jac])(xc)
            blocks = [val, jf[:, 0], jf[:, 2]]
            if order > 1:
                hess_t = ca.Function("h", [xs], [ca.jacobian(jac[:, 0], xs)])(xc)
                hess_y = ca.Function("h", [xs], [ca.jacobian(jac[:, 2], xs)])(xc)
                blocks += [hess_t[:, 0], hess_t[:, 2], hess_y[:, 2]]
        blocks += [zero] * (6 - len(blocks))
        # a derivative along an axis vanishes where the input is clamped on that axis
        masks = [1, inside[0], inside[2], inside[0], inside[0] * inside[2], inside[2]]
        blocks = [blk * mk for blk, mk in zip(blocks, masks, strict=True)]
        return ca.Function("weather_taylor", [x], [ca.densify(ca.vertcat(*blocks))])
