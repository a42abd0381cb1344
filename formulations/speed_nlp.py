"""Speed-and-lateral-offset NLP over a corridor (CasADi + Ipopt/MUMPS).

The corridor is a centreline of ``N`` legs, waypoints ``k = 0..N``. The
decision variables are

* ``y_k`` [nm], the lateral offset of every interior waypoint from the
  centreline (``y_0 = y_N = 0``), positive to port (left of the direction of
  travel), bounded by the corridor half-width and per-waypoint navigable bounds;
* ``V_k`` [kn], the speed through water of every leg (constant along a leg);
* ``t_k`` [h], the arrival time at every waypoint, ``t_0 = 0`` at departure.

Geometry uses a locally flat frame (the caller's projection, e.g. gnomonic,
in [nm]): waypoint ``P_k = c_k + y_k n_k`` with ``c_k`` the centreline point
and ``n_k`` the unit normal (to port); a leg is the straight segment
``P_k → P_{k+1}``, its length ``L_k = |P_{k+1} − P_k|`` and its course ``e_k``
follow from the offsets. Every leg is sub-sampled at ``m`` points at
fractions ``(j + ½)/m``; at each sample the position in corridor
coordinates ``(s, y)`` and the time are interpolated linearly, the weather is
read from a CasADi spline/interpolant over the corridor's ``(t, s, y)`` grid
(:class:`formulations.weather_grid.WeatherGrid`; so the conditions move with the
ship's timing), and every constraint is imposed.
Leg time and fuel are midpoint-rule integrals over the samples:

    t_{k+1} − t_k = Σ_j (L_k/m) / SOG_kj,    fuel_k = Σ_j q_kj (L_k/m) / SOG_kj.

Ship kinematics with a current ``u`` (components along ``e_k`` and to its
port side ``u∥, u⊥``): the ship heads so as to cancel the cross-current,
``h⊥ = −u⊥/V``, ``h∥ = √(1 − h⊥²)``, ``SOG = V h∥ + u∥``.

Power model: the ship's own, tabulated. The caller (the domain layer) evaluates its performance
model — the same one that scores the plan — at every node of the corridor's weather grid for a
handful of speeds through water and heading deviations from the centreline, and passes the ratio
to a calm-water baseline (:class:`formulations.weather_grid.WeatherGrid`, ``power_ratio``):

    P = f_k · P_calm(V) · R(t, s, y, V, ψ)     [kW]
    P_calm(V) = Σ_j c_j V^{n_j}                 calm-water baseline (:class:`formulations.common.PowerModel`)
    R                                          the table: the weather's cubic B-spline quasi-interpolant
                                               in (t, s, y), V and ψ

with ``ψ`` the ship's heading minus the centreline direction (the leg's course turned by the crab
angle against the current; positive to port) and ``f_k`` a static per-leg factor (default 1; e.g.
a hull-fouling factor). Nothing is fitted: the table's error is a grid-resolution choice, measured
by the caller against its own evaluation of the plan. Fuel rate ``q = P · SFOC(P/MCR) · 1e-6`` [t/h] with
the Fourth IMO GHG Study curve ``SFOC(L) = SFC_base (0.455 L² − 0.710 L + 1.280)``
(physics.md §8).

Danger bands (:class:`formulations.common.Band`) are imposed per leg, sample
and band with the side fixed by the caller (``ratio ≤ lower`` or ``ratio ≥
upper``) as smooth one-sided constraints, only where the band is declared
applicable (and only on the legs the caller says a band can apply on at all,
``band_legs``; :mod:`formulations.row_layout`). A sample where the band does not apply may
instead take the band's third disjunct, ``Hs`` below its threshold
(:data:`formulations.common.BELOW_SIDE`, a row ``(Hs − hs_min)/hs_min ≤ −ε``):
:meth:`SpeedNLP.default_sides` gives it where the start lies inside the band's
ratio interval in seas below the threshold. :meth:`SpeedNLP.solve` reports the ratios and the Hs at every
sample so that the outer loop (:mod:`formulations.disjunctive`) can re-check
applicability, which moves with the route, and flip sides.

The model is built once per corridor/weather/ship: objective and constraints
in vectorised MX expressions (weather and per-sample physics ``Function.map``-ped
over all samples), derivatives assembled leg by leg from SX functions mapped over
the legs (:mod:`formulations._nlp_model`). ETA, objective, sides, applicability
and the warm start are run-time inputs of the same Ipopt instance, so repeated
solves (outer loop, fuel-versus-ETA sweeps) cost no rebuild. Ipopt runs with
MUMPS, ``print_level 0``, ``tol 1e-9``, adaptive barrier and
``bound_relax_factor 0`` (bounds such as the ETA hold exactly at the solution).

Sources: the convexity of fuel in leg time and speed optimisation on a fixed
path (Norstad, Fagerholt & Laporte 2011; Hvattum et al. 2013); encounter period
and bands (IMO MSC.1/Circ.1228, Boeing EP 2145155; physics.md §2–3); SFOC
(Fourth IMO GHG Study; physics.md §8); Kwon's speed loss (physics.md §6).
"""

from __future__ import annotations

import copy
import time
from typing import Any, Literal

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from formulations._buffers import SharedMap, WeatherValues
from formulations._nlp_model import heading_dev_deg, sample_physics, structured_derivatives
from formulations.common import (
    BELOW_SIDE,
    G_OVER_2PI_KN_S,
    Band,
    CorridorGeometry,
    FormulationInputError,
    MovingExclusion,
    PowerModel,
    broadcast_legs,
)
from formulations.disjunctive import held_across_crossings
from formulations.ipopt_options import (
    IPOPT_DEFAULTS,
    PRIMAL_START_OPTIONS,
    WARM_START_OPTIONS,
    checked_duals,
)
from formulations.nlp_result import NLPResult, SampleState, max_violation
from formulations.row_layout import RowLegs, row_blocks, row_bounds, waypoint_time_bounds
from formulations.sample_layout import SampleLayout, midpoint_layout
from formulations.weather_grid import WeatherGrid

__all__ = [
    "CorridorGeometry",
    "MovingExclusion",
    "NLPResult",
    "PowerModel",
    "SampleState",
    "SpeedNLP",
    "WeatherGrid",
    "solve_speed_nlp",
]

Objective = Literal["time", "fuel", "cost"]


def _rep(col: Any, m: int) -> Any:
    """Repeat every entry of an (N,1) column m times: (N·m,1), sample index k·m + j."""
    n = col.shape[0]
    return ca.reshape(ca.repmat(col.T, m, 1), n * m, 1)


def _leg_sum(col: Any, n: int, m: int) -> Any:
    """Sum an (N·m,1) sample column over the m samples of each leg: (N,1)."""
    return ca.sum1(ca.reshape(col, m, n)).T


class SpeedNLP:
    """The corridor NLP, built once and solved many times.

    Parameters
    ----------
    corridor : CorridorGeometry
        Centreline, normals, along-track coordinates and lateral bounds (N legs).
    weather : WeatherGrid
        Fields on the corridor's (t, s, y) grid.
    power : PowerModel
        Power, fuel and engine-load model.
    bands : sequence of Band, optional
        The danger bands (B of them).
    exclusion : MovingExclusion, optional
        A moving circle the samples must stay out of.
    samples_per_leg : int
        ``m`` ≥ 1, samples per leg at fractions ``(j + ½)/m`` (default 2) for the midpoint-rule
        quadrature of time and fuel and for every per-sample constraint. Choose ``m`` so that
        the samples are closer than the weather grid spacing; the domain layer re-checks
        constraints on a denser resampling.
    v_min_kn, v_max_kn : float or array_like, shape (N,)
        Bounds on the speed through water [kn]; ``v_min > 0``.
    leg_power_factor : array_like, shape (N,), optional
        Static factor ``f_k`` on the power of every leg [-] (default 1), finite and positive.
    g_over_2pi_kn_s : float
        ``A = g/2π`` [kn/s] in the wave relations (default 3.0339; IMO's rounded form is 3.0).
    sog_min_kn : float
        Lower bound on the speed over ground at every sample [kn] (rows only when currents
        can exceed half the minimum speed).
    ipopt_options : dict, optional
        Overrides of the Ipopt/CasADi options (keys as for ``nlpsol``, e.g. ``"ipopt.tol"``).
    expand : bool
        Expand the MX graph of the objective and constraints to SX (default False).
    structured : bool
        Use the exact leg-by-leg derivatives of :func:`formulations._nlp_model.structured_derivatives`
        (default); ``False`` lets CasADi differentiate the MX graph (slower, same values).
    jit : bool
        Compile the per-leg derivative functions to C with the system compiler, once per machine
        (:func:`formulations.compiled.compiled_function`'s disk cache); each stays interpreted where it cannot be.
    exact_hessian : bool
        Keep the weather's second derivatives in the Hessian (see
        :func:`formulations._nlp_model.structured_derivatives`; default False).
    sample_layout : SampleLayout, optional
        Where every leg is sampled (:mod:`formulations.sample_layout`): fractions (N, M) along the leg and
        quadrature weights; replaces the midpoint rule of ``samples_per_leg`` (then ``samples_per_leg``
        becomes ``M``). Row-only points (weight 0) put the load, band and exclusion rows where a referee
        checks the plan.
    band_legs, exclusion_legs : array_like of bool, shape (N,), optional
        The legs that carry the band rows and the exclusion rows (default: every leg). A caller leaves a leg out
        where the row can never bind (no band can apply anywhere near it, the circle never comes near it); such a
        leg's band applicability is then not imposed (:meth:`band_edges`), and its rows cost Ipopt nothing.
    """

    def __init__(
        self,
        corridor: CorridorGeometry,
        weather: WeatherGrid,
        power: PowerModel,
        *,
        bands: tuple[Band, ...] | list[Band] = (),
        exclusion: MovingExclusion | None = None,
        samples_per_leg: int = 2,
        v_min_kn: ArrayLike = 1.0,
        v_max_kn: ArrayLike = 30.0,
        leg_power_factor: ArrayLike | None = None,
        g_over_2pi_kn_s: float = G_OVER_2PI_KN_S,
        sog_min_kn: float = 1.0,
        ipopt_options: dict[str, Any] | None = None,
        expand: bool = False,
        structured: bool = True,
        jit: bool = False,
        exact_hessian: bool = False,
        build_solver: bool = True,
        sample_layout: SampleLayout | None = None,
        band_legs: ArrayLike | None = None,
        exclusion_legs: ArrayLike | None = None,
    ) -> None:
        started = time.perf_counter()
        n = corridor.n_legs
        layout = midpoint_layout(n, samples_per_leg) if sample_layout is None else sample_layout
        if not isinstance(layout, SampleLayout) or layout.n_legs != n:
            raise FormulationInputError(f"sample_layout must be a SampleLayout of {n} legs, got {layout!r}")
        m = layout.per_leg
        self.sample_layout = layout
        self.corridor, self.weather, self.power = corridor, weather, power
        self.bands = tuple(bands)
        self.exclusion = exclusion
        self.n_legs, self.samples_per_leg, self.n_bands = n, m, len(self.bands)
        # (M,) for a layout that is the same on every leg (the midpoint rule), else (N, M)
        self.sample_fraction = layout.fraction[0] if layout.uniform else layout.fraction
        self.v_min_kn = broadcast_legs(v_min_kn, n, "v_min_kn")
        self.v_max_kn = broadcast_legs(v_max_kn, n, "v_max_kn")
        if (self.v_min_kn <= 0).any() or (self.v_max_kn < self.v_min_kn).any():
            raise FormulationInputError(
                f"need 0 < v_min_kn <= v_max_kn, got v_min {self.v_min_kn.min():g}, v_max {self.v_max_kn.min():g}"
            )
        f = broadcast_legs(1.0 if leg_power_factor is None else leg_power_factor, n, "leg_power_factor")
        if not (np.isfinite(f).all() and (f > 0).all()):
            raise FormulationInputError(f"leg_power_factor must be finite and positive, got {f!r}")
        self.leg_power_factor = f
        #: the legs that carry the band and the exclusion rows, and those rows' order
        self.row_legs = RowLegs.of(band_legs, exclusion_legs, n, m, len(self.bands))
        self.g_over_2pi = float(g_over_2pi_kn_s)
        self.sog_min_kn = float(sog_min_kn)
        self._edges: tuple[np.ndarray, np.ndarray] | None = None  # per-sample band edges (:meth:`with_edges`)
        for b in self.bands:
            if not isinstance(b, Band):
                raise FormulationInputError(f"bands must be Band instances, got {type(b).__name__}")
        self._build(
            expand=expand,
            structured=structured and build_solver,
            jit=jit,
            exact_hessian=exact_hessian,
            ipopt_options=ipopt_options or {},
            build_solver=build_solver,
        )
        self.build_time_s = time.perf_counter() - started

    # ------------------------------------------------------------------ model
    def _sample_function(self) -> Any:
        """Per-sample physics (:func:`formulations._nlp_model.sample_physics`) as an SX function.

        Input (column): ``V, cos δ, sin δ, L/m, f_k``, the interpolated weather fields (and power-ratio
        coefficients), ``β`` (B band edges). Output (column): ``dt, fuel, load, power, rate, cos χ,
        sog, h⊥``, B band residuals, B band ratios.
        """
        names = self.weather.field_names
        nb = self.n_bands
        inp = ca.SX.sym("in", 5 + len(names) + nb)
        col = {name: inp[5 + i] for i, name in enumerate(names)}
        beta = [inp[5 + len(names) + i] for i in range(nb)]
        ph = sample_physics(
            inp[0],
            inp[1],
            inp[2],
            inp[3],
            inp[4],
            col,
            beta,
            self.power,
            self.bands,
            self.g_over_2pi,
            self.weather.ratio_axes,
        )
        keys = ("dt", "fuel", "load", "power", "rate", "cos_chi", "sog", "h_perp")
        out = ca.vertcat(*[ph[k] for k in keys], *ph["res"], *ph["ratio"])
        return ca.Function("sample", [inp], [out])

    def _model(self, y: Any, v: Any, t: Any, beta: Any, fac: Any, weather: Any = None) -> dict[str, Any]:
        """The symbolic model: leg geometry in vectorised MX, per-sample physics mapped; columns of length N·m.

        ``weather`` maps the (3, N·m) sample points ``(t, s, y)`` to the (n_fields, N·m) fields (default: this
        NLP's own interpolant, mapped)."""
        cor = self.corridor
        n, m, nb = self.n_legs, self.samples_per_leg, self.n_bands
        k_ = n * m
        frac = self.sample_layout.fraction.reshape(-1, 1)  # leg-major: k·M + j
        weight = ca.DM(self.sample_layout.weight.reshape(-1, 1))
        c, nrm, tau, s = cor.centre_xy_nm, cor.normal_xy, cor.tangent_xy, cor.s_nm
        px = c[:, 0:1] + y * nrm[:, 0:1]
        py = c[:, 1:2] + y * nrm[:, 1:2]
        dx, dy = px[1:] - px[:-1], py[1:] - py[:-1]
        length = ca.sqrt(dx**2 + dy**2)
        cos_d = (tau[:, 0:1] * dx + tau[:, 1:2] * dy) / length  # δ: from the centreline tangent to the leg
        sin_d = (tau[:, 0:1] * dy - tau[:, 1:2] * dx) / length
        s_s = np.repeat(s[:-1], m)[:, None] + frac * np.repeat(np.diff(s), m)[:, None]
        y_s = _rep(y[:-1], m) + frac * _rep(y[1:] - y[:-1], m)
        t_s = _rep(t[:-1], m) + frac * _rep(t[1:] - t[:-1], m)
        x_s = _rep(px[:-1], m) + frac * _rep(dx, m)
        yf_s = _rep(py[:-1], m) + frac * _rep(dy, m)
        fields = (self._interp_map if weather is None else weather)(ca.horzcat(t_s, s_s, y_s).T)  # (n_fields, K)
        rows = ca.vertcat(
            _rep(v, m).T, _rep(cos_d, m).T, _rep(sin_d, m).T, (_rep(length, m) * weight).T, _rep(fac, m).T, fields
        )
        if nb:
            rows = ca.vertcat(rows, ca.reshape(beta, k_, nb).T)
        out = self._sample_map(rows).T  # (K, n_out)
        names = ("dt", "fuel", "load", "power", "rate", "cos_chi", "sog", "h_perp")
        col = {name: out[:, i] for i, name in enumerate(names)}
        res = {
            "length": length,
            "px": px,
            "py": py,
            "t_s": t_s,
            "s_s": ca.DM(s_s),
            "y_s": y_s,
            "x_s": x_s,
            "yf_s": yf_s,
            "hs": fields[0, :].T,
            "per": fields[1, :].T,
            "dt_leg": _leg_sum(col["dt"], n, m),
            "fuel_leg": _leg_sum(col["fuel"], n, m),
            **{k_name: col[k_name] for k_name in ("load", "power", "rate", "cos_chi", "sog", "h_perp")},
            "dev_deg": heading_dev_deg(_rep(sin_d, m), _rep(cos_d, m), col["h_perp"]),
        }
        if nb:
            # band-major over the samples that carry band rows: b·K_b + i (i: the sample's rank among them)
            res["band_res"] = ca.vec(self.row_legs.select(out[:, 8 : 8 + nb], self.row_legs.band_samples))
            res["ratio"] = out[:, 8 + nb : 8 + 2 * nb]
        if self.exclusion is not None:
            centre = self._excl_map(t_s.T).T  # (K, 3): cx, cy, r
            d2 = (x_s - centre[:, 0]) ** 2 + (yf_s - centre[:, 1]) ** 2
            res["excl_margin"] = ca.sqrt(d2 + 1e-12) - centre[:, 2]
            excl_res = (d2 - centre[:, 2] ** 2) / self.exclusion.radius_scale_nm**2
            res["excl_res"] = self.row_legs.select(excl_res, self.row_legs.exclusion_samples)
        return res

    # ------------------------------------------------------------------ build
    def symbolic_model(self, y: Any, v: Any, t: Any, beta: Any, fac: Any, weather: Any = None) -> dict[str, Any]:
        """The model's CasADi expressions for symbolic offsets ``y`` (N+1), speeds ``v`` (N), times ``t`` (N+1),
        band edges ``beta`` (N·m·B, band-major) and leg power factors ``fac`` (N).

        ``weather``, optional: a callable taking the (3, N·m) sample points ``(t [h], s [nm], y [nm])`` to the
        (n_fields, N·m) fields in :attr:`WeatherGrid.field_names` order, in place of this NLP's own interpolant
        (:mod:`formulations.robust_nlp` passes one whose spline coefficients are a parameter, one per member).

        Keys: ``dt_leg`` and ``fuel_leg`` [h], [t] (N), ``load``, ``sog``, ``h_perp`` (N·m), ``band_res`` (N·m·B,
        band-major; with bands), ``excl_res`` (N·m; with an exclusion), and the diagnostics of :meth:`evaluate`.
        The rows this NLP imposes on them are those of :meth:`solve`; :mod:`formulations.robust_nlp` stacks them.
        """
        return self._model(y, v, t, beta, fac, weather)

    #: The keys of :meth:`symbolic_model` that :meth:`sample_state` reads.
    STATE_KEYS = (
        "t_s", "s_s", "y_s", "x_s", "yf_s", "hs", "per", "sog", "power", "load", "rate", "cos_chi", "dev_deg",
    )  # fmt: skip

    def sample_state(self, values: dict[str, np.ndarray]) -> SampleState:
        """The :class:`SampleState` of numeric values of :meth:`symbolic_model`'s outputs (keys :attr:`STATE_KEYS`,
        ``ratio`` with bands, ``excl_margin`` with an exclusion), as :meth:`evaluate` builds it."""
        return self._state(values)

    @property
    def n_rows(self) -> int:
        """The number of constraint rows Ipopt sees (:func:`formulations.row_layout.row_blocks`)."""
        return int(self._ng)

    @property
    def has_current_rows(self) -> bool:
        """Whether the drift-angle and SOG rows are imposed (a current that can bind them)."""
        return bool(self._has_current)

    def band_edges(self, sides: np.ndarray, applies: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The band-edge parameter ``beta`` (band-major) and the band rows' bounds for sides and applicability
        (N, m, B), as :meth:`solve` sets them (:meth:`formulations.row_layout.RowLegs.band_edges`), at the
        edges of :meth:`sample_edges`."""
        return self.row_legs.band_edges(self.bands, sides, applies, edges=self._edges)

    def sample_edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Every sample's band edges, lower and upper, shape (N, m, B) each: the bands' own, or those of
        :meth:`with_edges`."""
        if self._edges is not None:
            return self._edges
        shape = (self.n_legs, self.samples_per_leg, self.n_bands)
        lower = np.broadcast_to(np.array([b.lower for b in self.bands], dtype=float), shape)
        upper = np.broadcast_to(np.array([b.upper for b in self.bands], dtype=float), shape)
        return lower, upper

    def with_edges(self, lower: ArrayLike, upper: ArrayLike) -> SpeedNLP:
        """This problem with its band edges set per sample: ``lower`` and ``upper`` of shape (N, m, B) [ratio].

        The edges are a parameter of the built problem (the rows' ``β``), so nothing is rebuilt: the copy shares
        the solver. Its sides, applicability, sample states (``inside``) and rows all use these edges. Each
        sample's edge must keep the band's finite edges finite and ``lower ≤ upper``; use it to loosen a band
        at a few samples (a start that an independent check passed lies inside the problem's band there).
        """
        shape = (self.n_legs, self.samples_per_leg, self.n_bands)
        lo, hi = np.array(lower, dtype=float), np.array(upper, dtype=float)
        if lo.shape != shape or hi.shape != shape:
            raise FormulationInputError(f"lower and upper must have shape {shape}, got {lo.shape} and {hi.shape}")
        own_lo, own_hi = self.sample_edges()
        if (np.isfinite(lo) != np.isfinite(own_lo)).any() or (np.isfinite(hi) != np.isfinite(own_hi)).any():
            raise FormulationInputError("per-sample band edges must be finite exactly where the band's own edges are")
        if (lo > hi).any() or np.isnan(lo).any() or np.isnan(hi).any():
            raise FormulationInputError("per-sample band edges need lower <= upper at every sample, without NaN")
        out = copy.copy(self)
        out._edges = (lo, hi)
        return out

    def _build(
        self,
        *,
        expand: bool,
        structured: bool,
        jit: bool,
        exact_hessian: bool,
        ipopt_options: dict[str, Any],
        build_solver: bool = True,
    ) -> None:
        n, m, nb = self.n_legs, self.samples_per_leg, self.n_bands
        k_ = n * m
        # with the structured derivatives nothing differentiates the weather through CasADi: read it in numpy
        # (no CasADi spline of the grid is built; WeatherGrid.tensor_spline is built once per grid)
        self.numeric_weather = bool(structured and not expand and self.weather.method == "smooth")
        #: with ``jit``: how each leg function was compiled, or why it stays interpreted (formulations.compiled)
        self.compiled_functions: tuple[str, ...] = ()
        if self.numeric_weather:
            self._weather_values = WeatherValues(self.weather, k_)  # keep alive: the graphs call it
            self._interp_map = self._weather_values
        else:
            self._interp_map = self.weather.interpolant().map(k_)
        self._sample_map = self._sample_function().map(k_)
        if self.numeric_weather:  # nothing differentiates the graph: f and g at one point share one evaluation
            self._sample_map = SharedMap(self._sample_map)
        if self.exclusion is not None:
            self.exclusion_function = self.exclusion.interpolant()
            self._excl_map = self.exclusion_function.map(k_)
        nx = 3 * n + 2
        x = ca.MX.sym("x", nx)
        y, v, t = x[: n + 1], x[n + 1 : 2 * n + 1], x[2 * n + 1 :]
        beta = ca.MX.sym("beta", k_ * nb)
        weights = ca.MX.sym("w", 2)  # fuel weight, time weight
        fac = ca.MX.sym("f", n)  # the static per-leg power factors f_k (a parameter)
        mdl = self._model(y, v, t, beta, fac)
        objective = weights[0] * ca.sum1(mdl["fuel_leg"]) + weights[1] * (t[n] - t[0])
        self._has_current = self._needs_current_rows()
        parts, rows = row_blocks(
            mdl, t, bands=bool(nb), current=self._has_current, exclusion=self.exclusion is not None
        )
        g = ca.vertcat(*parts)
        self._rows, self._ng, self._nx = rows, g.shape[0], nx
        opts = {**IPOPT_DEFAULTS, **PRIMAL_START_OPTIONS}
        opts.update(ipopt_options)
        opts["expand"] = expand
        if structured:
            how: list[str] = []
            self._derivatives = structured_derivatives(self, jit=jit, exact_hessian=exact_hessian, compiled=how)
            self.compiled_functions = tuple(how)
            opts.update(self._derivatives)
        param = ca.vertcat(weights, beta, fac)
        self._nlp_def = {"x": x, "p": param, "f": objective, "g": g}
        # the primal-dual warm start's solver (made on its first use): the same functions, WARM_START_OPTIONS
        # under the caller's options
        self._warm_opts = {**opts, **{k: v for k, v in WARM_START_OPTIONS.items() if k not in ipopt_options}}
        self._warm_solver: list[Any] = [None]  # built on first use; shared with the copies of with_edges
        self._solver = ca.nlpsol("speed_nlp", "ipopt", self._nlp_def, opts) if build_solver else None
        names = [*self.STATE_KEYS, "length", "dt_leg", "fuel_leg", "px", "py"]
        outs = [mdl[k] for k in names]
        if nb:
            names.append("ratio")
            outs.append(mdl["ratio"])
        if self.exclusion is not None:
            names.append("excl_margin")
            outs.append(mdl["excl_margin"])
        diag = ca.Function("speed_nlp_diag", [x, beta, fac], outs)
        self._diag = diag.expand() if expand else diag
        self._diag_names = names

    @property
    def weather_function(self) -> Any:
        """CasADi function ``(t, s, y) ↦ fields`` of the weather (:meth:`WeatherGrid.interpolant`, built once per grid)."""
        return self.weather.interpolant()

    # ------------------------------------------------------------------ helpers
    def _needs_current_rows(self) -> bool:
        """Whether the drift-angle and SOG rows can ever bind.

        With ``|u| ≤ v_min/2`` everywhere the drift angle stays ≤ 30° and
        ``SOG ≥ V cos 30° − v_min/2 ≥ 0.366 v_min``; when that is at least ``sog_min_kn`` the rows
        are left out (fewer rows, same solution).
        """
        wx = self.weather
        if wx.current_along_kn is None:
            return False
        speed = np.hypot(np.asarray(wx.current_along_kn), np.asarray(wx.current_across_kn))
        v_min = float(np.min(self.v_min_kn))
        return not (float(speed.max()) <= 0.5 * v_min and 0.366 * v_min >= self.sog_min_kn)

    def _pack(self, y: np.ndarray, v: np.ndarray, t: np.ndarray) -> np.ndarray:
        return np.concatenate([y, v, t])

    def _unpack(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = self.n_legs
        return x[: n + 1], x[n + 1 : 2 * n + 1], x[2 * n + 1 :]

    def _eval(self, x: np.ndarray, names: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
        """The diagnostic outputs at ``x``; only those in ``names`` when given (each output's conversion from
        CasADi to numpy costs about as much as evaluating it, and most callers read one or two)."""
        beta = np.zeros(self.n_legs * self.samples_per_leg * self.n_bands)
        vals = self._diag(x, beta, self._factor_parameter())
        vals = vals if isinstance(vals, tuple | list) else [vals]
        return {
            k: np.asarray(val, dtype=float)
            for k, val in zip(self._diag_names, vals, strict=True)
            if names is None or k in names
        }

    def evaluate(self, offset_nm: ArrayLike, stw_kn: ArrayLike, time_h: ArrayLike) -> SampleState:
        """Per-sample conditions for given offsets (N+1,) [nm], speeds (N,) [kn] and times (N+1,) [h].

        Uses the same expressions as the NLP; the outer loop uses it to re-check where each
        band applies and which side a sample is on.
        """
        n = self.n_legs
        y = broadcast_legs(offset_nm, n + 1, "offset_nm")
        v = broadcast_legs(stw_kn, n, "stw_kn")
        t = broadcast_legs(time_h, n + 1, "time_h")
        return self._state(self._eval(self._pack(y, v, t)))

    def leg_fuel_t(self, offset_nm: ArrayLike, stw_kn: ArrayLike, time_h: ArrayLike) -> np.ndarray:
        """Fuel of every leg [t] by the NLP's own model (the objective's terms) at offsets (N+1,) [nm], speeds (N,)
        [kn] and times (N+1,) [h]: to compare the model with another evaluation of the same track and schedule."""
        n = self.n_legs
        y = broadcast_legs(offset_nm, n + 1, "offset_nm")
        v = broadcast_legs(stw_kn, n, "stw_kn")
        t = broadcast_legs(time_h, n + 1, "time_h")
        return np.ravel(self._eval(self._pack(y, v, t), ("fuel_leg",))["fuel_leg"])

    def _state(self, ev: dict[str, np.ndarray]) -> SampleState:
        n, m, nb = self.n_legs, self.samples_per_leg, self.n_bands

        def sh(a: np.ndarray) -> np.ndarray:
            return np.reshape(a, (n, m))

        hs = sh(ev["hs"])
        if nb:
            ratio = np.reshape(ev["ratio"], (n, m, nb))
        else:
            ratio = np.zeros((n, m, 0))
        hs_min = np.array([b.hs_min_m for b in self.bands])
        lower, upper = self.sample_edges()
        applies = hs[:, :, None] >= hs_min[None, None, :]
        tol = 1e-6 * np.maximum(1.0, np.abs(np.where(np.isfinite(lower), lower, 0.0)))  # solver tolerance
        inside = applies & (ratio > lower + tol) & (ratio < upper - tol)
        wx = self.weather
        t_s, s_s, y_s = sh(ev["t_s"]), sh(ev["s_s"]), sh(ev["y_s"])
        tol = 1e-9
        outside = (
            (t_s < wx.t_h[0] - tol)
            | (t_s > wx.t_h[-1] + tol)
            | (s_s < wx.s_nm[0] - tol)
            | (s_s > wx.s_nm[-1] + tol)
            | (y_s < wx.y_nm[0] - tol)
            | (y_s > wx.y_nm[-1] + tol)
        )
        margin = sh(ev["excl_margin"]) if "excl_margin" in ev else np.full((n, m), np.inf)
        return SampleState(
            time_h=t_s,
            s_nm=s_s,
            y_nm=y_s,
            x_nm=sh(ev["x_s"]),
            y_flat_nm=sh(ev["yf_s"]),
            hs_m=hs,
            period_s=sh(ev["per"]),
            sog_kn=sh(ev["sog"]),
            power_kw=sh(ev["power"]),
            load=sh(ev["load"]),
            fuel_rate_tph=sh(ev["rate"]),
            cos_chi=sh(ev["cos_chi"]),
            dev_deg=sh(ev["dev_deg"]),
            ratio=ratio,
            applies=applies,
            inside=inside,
            exclusion_margin_nm=margin,
            outside_grid=outside,
        )

    def _factor_parameter(self) -> np.ndarray:
        return self.leg_power_factor

    def power_at_speeds(
        self, offset_nm: ArrayLike, time_h: ArrayLike, stw_kn: ArrayLike
    ) -> tuple[np.ndarray, np.ndarray]:
        """Brake power [kW] and fuel rate [t/h] of the NLP's model at every sample for other speeds.

        The samples stay where and when they are for the offsets (N+1,) [nm] and times (N+1,) [h];
        every leg is given each of the speeds ``stw_kn`` (K,) [kn] in turn (the same expressions as
        the NLP). Returns two arrays of shape (N, m, K).
        """
        n, m = self.n_legs, self.samples_per_leg
        y = broadcast_legs(offset_nm, n + 1, "offset_nm")
        t = broadcast_legs(time_h, n + 1, "time_h")
        speeds = np.atleast_1d(np.asarray(stw_kn, dtype=float))
        power = np.empty((n, m, speeds.size))
        rate = np.empty((n, m, speeds.size))
        for i, v in enumerate(speeds):
            ev = self._eval(self._pack(y, np.full(n, v), t), ("power", "rate"))
            power[:, :, i] = np.reshape(ev["power"], (n, m))
            rate[:, :, i] = np.reshape(ev["rate"], (n, m))
        return power, rate

    def consistent_times(self, offset_nm: ArrayLike, stw_kn: ArrayLike, *, iterations: int = 3) -> np.ndarray:
        """Arrival times [h] (N+1,) that satisfy the NLP's time dynamics for given offsets and speeds.

        A fixed-point iteration of ``t_{k+1} = t_k + Σ_j (L_k/m)/SOG_kj`` (the SOG depends on the time
        through the current); used to build a consistent warm start.
        """
        n = self.n_legs
        y = broadcast_legs(offset_nm, n + 1, "offset_nm")
        v = broadcast_legs(stw_kn, n, "stw_kn")
        t = np.concatenate([[0.0], np.cumsum(np.diff(self.corridor.s_nm) / v)])
        for _ in range(max(1, iterations)):
            ev = self._eval(self._pack(y, v, t), ("dt_leg",))
            t = np.concatenate([[0.0], np.cumsum(ev["dt_leg"].ravel())])
        return t

    def default_sides(self, state: SampleState) -> tuple[np.ndarray, np.ndarray]:
        """Sides (−1/+1, or :data:`~formulations.common.BELOW_SIDE`) and applicability (N, m, B) from the conditions
        of a (warm-start) state.

        A sample takes the side it is on; inside a band, the nearer edge (in ratio) among the band's allowed sides
        (:func:`formulations.disjunctive.select_sides`), except where the band does not apply because the sea is
        below its threshold: there the third disjunct, "Hs stays below the threshold", is the side the start is on
        (imposed as a row, so that the solve cannot carry that sample into the band's seas unseen).
        """
        from formulations.disjunctive import select_sides, strictly_inside

        lower, upper = self.sample_edges()
        hs_min = np.array([b.hs_min_m for b in self.bands])
        sides = select_sides(state.ratio, lower, upper)
        inside = strictly_inside(state.ratio, lower, upper)
        below = inside & ~state.applies & (hs_min > 0.0)[None, None, :]
        return np.where(below, np.int8(BELOW_SIDE), sides).astype(np.int8), state.applies.copy()

    # ------------------------------------------------------------------ solve
    def dual_key(self) -> tuple[Any, ...]:
        """What the meaning of the multipliers depends on: the variables, the row blocks and the sample layout.

        Two problems with equal keys (the same corridor's NLP for two ETAs) can share ``lam_x``/``lam_g``
        (:meth:`solve`'s ``lam_x0``/``lam_g0``).
        """
        layout = self.sample_layout
        rows = tuple(sorted((k, tuple(np.ravel(v).tolist())) for k, v in self._rows.items()))
        masks = (self.row_legs.band_legs.tobytes(), self.row_legs.exclusion_legs.tobytes())
        return (self._nx, self._ng, rows, layout.fraction.tobytes(), layout.weight.tobytes(), self.n_bands, *masks)

    def _warm_start(
        self, eta_h: float | None, offset0_nm: ArrayLike | None, stw0_kn: ArrayLike | None, time0_h: ArrayLike | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`solve`'s warm start: the offsets [nm] and the packed point (see its ``offset0_nm``, ``stw0_kn``,
        ``time0_h``)."""
        n = self.n_legs
        y0 = np.zeros(n + 1) if offset0_nm is None else broadcast_legs(offset0_nm, n + 1, "offset0_nm")
        if stw0_kn is None:
            total = float(self.corridor.s_nm[-1] - self.corridor.s_nm[0])
            guess = total / eta_h if eta_h is not None else 0.9 * float(np.mean(self.v_max_kn))
            v0 = np.clip(np.full(n, guess), self.v_min_kn, self.v_max_kn)
        else:
            v0 = broadcast_legs(stw0_kn, n, "stw0_kn")
        t0 = self.consistent_times(y0, v0) if time0_h is None else broadcast_legs(time0_h, n + 1, "time0_h")
        return y0, self._pack(y0, v0, t0)

    def solve(
        self,
        *,
        eta_h: float | None = None,
        eta_mode: Literal["le", "eq"] = "le",
        objective: Objective = "fuel",
        fuel_price: float = 1.0,
        hourly_cost: float = 0.0,
        sides: ArrayLike | None = None,
        applies: ArrayLike | None = None,
        offset0_nm: ArrayLike | None = None,
        stw0_kn: ArrayLike | None = None,
        time0_h: ArrayLike | None = None,
        fix_offsets: bool = False,
        time_lo_h: ArrayLike | None = None,
        time_hi_h: ArrayLike | None = None,
        lam_x0: ArrayLike | None = None,
        lam_g0: ArrayLike | None = None,
    ) -> NLPResult:
        """Solve for one ETA, objective, band sides and warm start.

        Parameters
        ----------
        eta_h : float, optional
            Passage time allowed [h since departure]; ``None``: free arrival (minimum time with
            ``objective="time"``).
        eta_mode : {"le", "eq"}
            Arrive no later than, or exactly at, ``eta_h``.
        objective : {"time", "fuel", "cost"}
            Minimise the passage time [h], the fuel [t], or
            ``fuel_price · fuel + hourly_cost · time`` [currency].
        fuel_price, hourly_cost : float
            [currency/t] and [currency/h], for ``"cost"``.
        sides : array_like of int, shape (N, m, B), optional
            −1: ``ratio ≤ lower``, +1: ``ratio ≥ upper``, :data:`~formulations.common.BELOW_SIDE`: ``Hs`` below
            the band's threshold (where the band does not apply) per leg, sample and band; default from the warm
            start (:meth:`default_sides`). A sample on the third side next to one of its leg where the band
            applies on −1/+1 is imposed on that side instead
            (:func:`formulations.disjunctive.held_across_crossings`; the result's ``sides`` and ``applies`` are
            those imposed).
        applies : array_like of bool, shape (N, m, B), optional
            Where each band constraint is imposed; default ``Hs ≥ hs_min`` at the warm start.
        offset0_nm, stw0_kn, time0_h : array_like, optional
            Warm start, shapes (N+1,), (N,), (N+1,); defaults: centreline, the constant
            speed that makes the ETA (clipped to the speed bounds), consistent times.
        fix_offsets : bool
            Hold the offsets at ``offset0_nm`` (a fixed path).
        time_lo_h, time_hi_h : array_like, shape (N+1,), optional
            Bounds on the waypoint times [h since departure] (``-inf`` / ``inf`` where none), beside
            departure at 0 and the ETA: time windows, e.g. leave a leg before a moving no-go area
            reaches it or enter it after the area has gone.
        lam_x0, lam_g0 : array_like, optional
            Multipliers of the variable bounds, shape (3N+2,), and of the rows, shape (ng,), of an earlier
            solve of a problem with the same rows (:meth:`dual_key`), e.g. the neighbouring ETA's
            ``NLPResult.lam_x``/``lam_g`` [objective units per variable/row unit]: with both, Ipopt starts from
            them and the warm start (``warm_start_init_point``, :data:`WARM_START_OPTIONS`).

        Returns
        -------
        NLPResult
            Including Ipopt's status verbatim; check ``success`` and ``max_violation``.
        """
        n, m, nb = self.n_legs, self.samples_per_leg, self.n_bands
        if self._solver is None:
            raise FormulationInputError("this SpeedNLP was built with build_solver=False: it has no solver")
        if objective not in ("time", "fuel", "cost"):
            raise FormulationInputError(f"objective must be 'time', 'fuel' or 'cost', got {objective!r}")
        if eta_mode not in ("le", "eq"):
            raise FormulationInputError(f"eta_mode must be 'le' or 'eq', got {eta_mode!r}")
        if eta_h is not None and not (np.isfinite(eta_h) and eta_h > 0):
            raise FormulationInputError(f"eta_h must be a positive number of hours, got {eta_h}")
        weights = {"fuel": (1.0, 0.0), "time": (0.0, 1.0), "cost": (float(fuel_price), float(hourly_cost))}[objective]
        y0, x0 = self._warm_start(eta_h, offset0_nm, stw0_kn, time0_h)
        # sides and applicability
        if nb and (sides is None or applies is None):
            d_sides, d_app = self.default_sides(self._state(self._eval(x0)))
            sides = d_sides if sides is None else sides
            applies = d_app if applies is None else applies
        side_arr = np.zeros((n, m, nb), dtype=np.int8) if nb == 0 else np.asarray(sides).astype(np.int8)
        app_arr = np.zeros((n, m, nb), dtype=bool) if nb == 0 else np.asarray(applies, dtype=bool)
        if nb and side_arr.shape == (n, m, nb):
            side_arr, app_arr = held_across_crossings(side_arr, app_arr)
        beta, band_lo, band_hi = self.band_edges(side_arr, app_arr)  # band-major
        # variable bounds
        cor = self.corridor
        y_lo, y_hi = cor.offset_bounds()
        if fix_offsets:
            y_lo, y_hi = y0.copy(), y0.copy()
        t_lo, t_hi = waypoint_time_bounds(n, eta_h, eta_mode, time_lo_h, time_hi_h)
        lbx = np.concatenate([y_lo, self.v_min_kn, t_lo])
        ubx = np.concatenate([y_hi, self.v_max_kn, t_hi])
        x0 = np.clip(x0, lbx, ubx)
        lbg, ubg = row_bounds(self._rows, self._ng, self.power, band=(band_lo, band_hi) if nb else None,
                              sog_min_kn=self.sog_min_kn if self._has_current else None,
                              exclusion=self.exclusion is not None)  # fmt: skip
        p = np.concatenate([weights, beta, self._factor_parameter()])
        solver, duals = self._solver, checked_duals(lam_x0, lam_g0, self._nx, self._ng)
        if duals:
            if self._warm_solver[0] is None:
                self._warm_solver[0] = ca.nlpsol("speed_nlp_warm", "ipopt", self._nlp_def, self._warm_opts)
            solver = self._warm_solver[0]
        started = time.perf_counter()
        sol = solver(x0=x0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, **duals)
        elapsed = time.perf_counter() - started
        return self._result(sol, solver.stats(), elapsed, (lbx, ubx, lbg, ubg), side_arr, app_arr, eta_h)

    def _result(
        self, sol: Any, stats: dict, elapsed: float, bounds: tuple, side_arr: np.ndarray, app_arr: np.ndarray,
        eta_h: float | None,
    ) -> NLPResult:  # fmt: skip
        """:meth:`solve`'s result from Ipopt's solution ``sol`` and ``stats`` (its status verbatim), the bounds
        ``(lbx, ubx, lbg, ubg)`` it was solved under (the largest violation) and the sides imposed."""
        n, m, nb = self.n_legs, self.samples_per_leg, self.n_bands
        lbx, ubx, lbg, ubg = bounds
        x = np.asarray(sol["x"], dtype=float).ravel()
        lam_x = np.asarray(sol["lam_x"], dtype=float).ravel()
        lam_g = np.asarray(sol["lam_g"], dtype=float).ravel()
        g = np.asarray(sol["g"], dtype=float).ravel()
        viol = max_violation(x, lbx, ubx, g, lbg, ubg)
        ev = self._eval(x)
        state = self._state(ev)
        y, v, t = self._unpack(x)
        if nb:
            a, b = self._rows["band"]
            lam_b, active = self.row_legs.band_activity(lam_g[a:b], g[a:b], side_arr, app_arr)
        else:
            lam_b, active = np.zeros((n, m, 0)), np.zeros((n, m, 0), dtype=bool)
        eta_mult = float(lam_x[2 * n + 1 + n]) if eta_h is not None else 0.0
        fuel_leg = ev["fuel_leg"].ravel()
        return NLPResult(
            status=str(stats.get("return_status", "unknown")),
            success=bool(stats.get("success", False)),
            iterations=int(stats.get("iter_count", -1)),
            solve_time_s=elapsed,
            objective=float(sol["f"]),
            offset_nm=y,
            position_xy_nm=np.column_stack([ev["px"].ravel(), ev["py"].ravel()]),
            stw_kn=v,
            time_h=t,
            distance_nm=ev["length"].ravel(),
            duration_h=np.diff(t),
            fuel_t=fuel_leg,
            total_fuel_t=float(fuel_leg.sum()),
            duration_total_h=float(t[-1] - t[0]),
            eta_multiplier=eta_mult,
            band_multiplier=lam_b,
            band_active=active,
            sides=side_arr,
            applies=app_arr,
            samples=state,
            max_violation=viol,
            x_opt=x,
            lam_x=lam_x,
            lam_g=lam_g,
        )


def solve_speed_nlp(
    corridor: CorridorGeometry,
    weather: WeatherGrid,
    power: PowerModel,
    *,
    build: dict[str, Any] | None = None,
    **solve_kwargs: Any,
) -> NLPResult:
    """Build a :class:`SpeedNLP` (keyword arguments ``build``) and solve it once (``solve_kwargs``)."""
    return SpeedNLP(corridor, weather, power, **(build or {})).solve(**solve_kwargs)
