"""Shared pieces of the formulations: errors, array checks, the fuel-rate model class.

Nothing here imports :mod:`optroute`; units are the ones every formulation
uses: distances in nautical miles [nm], times in hours [h], speeds in knots
[kn] (1 kn = 1 nm/h), fuel in tonnes [t], power in kilowatts [kW].
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from formulations.splines import (
    TensorSpline,
    bspline_function,
    is_uniform,
    pad_quasi_spline,
    quasi_spline,
    ratio_field_names,
    resample_linear,
    spline_derivative,
    spline_weights,
)

__all__ = [
    "BAND_KINDS",
    "Band",
    "CorridorGeometry",
    "FormulationInputError",
    "MovingExclusion",
    "NonConvexFuelModel",
    "PowerLawFuel",
    "PowerModel",
    "WeatherGrid",
    "BELOW_BETA",
    "BELOW_SIDE",
    "G_OVER_2PI_KN_S",
    "as_float_array",
    "broadcast_legs",
    "spline_weights",
]

#: Deep-water phase speed per wave period, g/(2π) with g = 9.80665 m/s², in
#: knots per second (physics.md §2: c = g T / 2π); 3.0339 kn/s.
G_OVER_2PI_KN_S: float = 9.80665 / (2.0 * np.pi) / (1852.0 / 3600.0)


#: A sample's band "side" meaning: the sea stays below the band's threshold there (``Hs < hs_min_m``), where the
#: band does not apply whatever the ratio. The third disjunct of "ratio ≤ lower OR ratio ≥ upper OR Hs < hs_min_m",
#: imposed where a start lies inside the band's ratio interval in seas below the threshold
#: (:meth:`formulations.speed_nlp.SpeedNLP.default_sides`).
BELOW_SIDE: int = 0
#: The band-edge parameter ``β`` of a :data:`BELOW_SIDE` sample: no ratio edge is that large, so the residual
#: (:func:`formulations._nlp_model.sample_physics`) switches to the Hs row on it.
BELOW_BETA: float = 1e6


class FormulationInputError(ValueError):
    """An input array of a formulation has the wrong shape, a NaN or a non-physical value."""


class NonConvexFuelModel(FormulationInputError):
    """A fuel-rate model would make the fuel of a leg non-convex in its time.

    Raised by :class:`PowerLawFuel` naming the offending coefficient or
    exponent, so the caller can refit the model inside the supported class.
    """


def as_float_array(
    value: ArrayLike, name: str, *, ndim: int | None = None, finite: bool = True, copy: bool = True
) -> np.ndarray:
    """Convert ``value`` to a float array and check its rank and finiteness.

    Parameters
    ----------
    value : array_like
        The input.
    name : str
        Argument name used in the error message.
    ndim : int, optional
        Required number of dimensions.
    finite : bool
        Reject NaN and ±inf when true (``+inf`` is allowed when false, NaN never).
    copy : bool
        Copy ``value`` (default); False: ``value`` itself where it is a float64 array already (a large table
        its caller hands over and does not change: no second copy to allocate).

    Returns
    -------
    numpy.ndarray
        A float64 copy of ``value`` (with ``copy=False``, ``value`` itself where it is one).

    Raises
    ------
    FormulationInputError
        On a wrong rank, a NaN, or (``finite=True``) an infinite entry.
    """
    arr = np.array(value, dtype=float) if copy else np.asarray(value, dtype=float)
    if ndim is not None and arr.ndim != ndim:
        raise FormulationInputError(f"{name} must be {ndim}-dimensional, got shape {arr.shape}")
    if np.isnan(arr).any():
        raise FormulationInputError(f"{name} contains NaN at index {np.argwhere(np.isnan(arr))[0].tolist()}")
    if finite and not np.isfinite(arr).all():
        raise FormulationInputError(
            f"{name} contains an infinite value at index {np.argwhere(~np.isfinite(arr))[0].tolist()}"
        )
    return arr


def broadcast_legs(value: ArrayLike, n: int, name: str, *, finite: bool = True) -> np.ndarray:
    """Broadcast a scalar or an (n,) array to shape (n,), with the checks of :func:`as_float_array`."""
    arr = as_float_array(value, name, finite=finite)
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise FormulationInputError(f"{name} must be a scalar or have shape ({n},), got shape {arr.shape}")
    return arr


BAND_KINDS = ("te_over_tr", "v_over_c", "v_over_cg", "v_over_ref")


@dataclass(frozen=True)
class Band:
    """One excluded ratio band: the ship must keep ``ratio ≤ lower`` or ``ratio ≥ upper``.

    The band only applies where the significant wave height is at least
    ``hs_min_m`` (Boeing EP 2145155 and physics.md §3: ``Hs ≥ 0.04 L``).
    Ratios (physics.md §2–3; χ = angle between the ship's heading and the
    wave **propagation** direction, 0 = following sea, so IMO's α = 180° − χ;
    ``V`` the speed through water [kn], ``T`` the wave period [s],
    ``A = g/2π`` [kn/s]):

    ``"te_over_tr"``
        ``T_E / T_R`` with ``T_E = A T² / |A T − V cos χ|`` (the exact form of
        IMO MSC.1/Circ.1228's ``3T²/(3T + V cos α)``) and ``T_R = param`` [s]
        the natural roll period. Synchronous roll: (0.8, 1.2); parametric
        roll: (0.4, 0.6).
    ``"v_over_c"``
        ``V cos χ / c`` with ``c = A T`` the phase speed [kn] (surf-riding; (0.8, 1.2)).
    ``"v_over_cg"``
        ``V cos χ / c_g`` with ``c_g = A T / 2`` (successive high-wave attack; (0.8, 1.2)).
    ``"v_over_ref"``
        ``V cos χ / param`` with a fixed reference speed [kn]; IMO's surf-riding
        limit is ``param = 1.8 √L``, ``lower = 1``, ``upper = inf``.

    Parameters
    ----------
    kind : str
        One of ``BAND_KINDS``.
    lower, upper : float
        Edges of the excluded interval; ``upper = inf`` allows only the lower side,
        ``lower = -inf`` only the upper side.
    param : float
        ``T_R`` [s] for ``"te_over_tr"``, the reference speed [kn] for ``"v_over_ref"``, unused otherwise.
    hs_min_m : float
        Applicability threshold on Hs [m].
    name : str
        Label used in reports.
    """

    kind: str
    lower: float
    upper: float
    param: float = float("nan")
    hs_min_m: float = 0.0
    name: str = ""

    def __post_init__(self) -> None:
        if self.kind not in BAND_KINDS:
            raise FormulationInputError(f"band kind must be one of {BAND_KINDS}, got {self.kind!r}")
        if not self.lower < self.upper or np.isnan(self.lower) or np.isnan(self.upper):
            raise FormulationInputError(
                f"band {self.name or self.kind}: need lower < upper, got {self.lower}, {self.upper}"
            )
        if not (np.isfinite(self.lower) or np.isfinite(self.upper)):
            raise FormulationInputError(f"band {self.name or self.kind}: at least one edge must be finite")
        if self.kind in ("te_over_tr", "v_over_ref") and not (np.isfinite(self.param) and self.param > 0):
            raise FormulationInputError(f"band {self.name or self.kind} needs a positive param, got {self.param}")
        if not np.isfinite(self.hs_min_m):
            raise FormulationInputError(f"band {self.name or self.kind}: hs_min_m must be finite, got {self.hs_min_m}")

    @property
    def allowed_sides(self) -> tuple[int, ...]:
        """The sides that exist: ``-1`` (``ratio ≤ lower``) and/or ``+1`` (``ratio ≥ upper``)."""
        return tuple(s for s, edge in ((-1, self.lower), (1, self.upper)) if np.isfinite(edge))


@dataclass(frozen=True)
class PowerLawFuel:
    """Fuel rate as a sum of power laws of speed, per leg, with convexity enforced.

    The fuel rate of leg ``i`` at speed ``v`` [kn] is

        r_i(v) = Σ_j a[i, j] · v ** p[j]     [t/h]

    so the fuel of a leg of length ``d_i`` [nm] sailed in ``t_i`` [h] at
    constant speed ``v = d_i / t_i`` is the perspective

        F_i(t_i) = t_i · r_i(d_i / t_i) = Σ_j a[i, j] · d_i**p[j] · t_i**(1 − p[j])   [t].

    The perspective of a convex function is convex (Boyd & Vandenberghe 2004,
    §3.2.6), so ``F_i`` is convex in ``t_i > 0`` whenever every ``r_i`` is;
    term by term this holds iff ``a[i, j] ≥ 0`` and ``p[j] ≥ 1`` or ``p[j] ≤ 0``
    (``t**q`` is convex for ``q ≥ 1`` or ``q ≤ 0``, concave in between).
    This is the convexity argument of Norstad, Fagerholt & Laporte (2011) and
    Hvattum et al. (2013) for speed optimisation on a fixed path. Examples
    of the class: the cubic law ``k v³`` (``p = [3]``, fuel ``k d³/t²``,
    physics.md §9), an admiralty-type ``k v^n`` with ``n ≥ 1``, a polynomial
    with non-negative coefficients, a constant hourly consumption
    (``p = 0``: auxiliary engines, fuel ``a t``) and a per-mile constant
    (``p = 1``). Static weather on a leg enters through the per-leg
    coefficients.

    Parameters
    ----------
    coef : array_like, shape (n_legs, n_terms) or (n_terms,)
        ``a[i, j]`` [t/h per kn**p_j]; a 1-D array applies to every leg.
    exponent : array_like, shape (n_terms,)
        ``p[j]`` [-], each ``≥ 1`` or ``≤ 0``.

    Raises
    ------
    NonConvexFuelModel
        Naming the coefficient or exponent that breaks convexity.
    """

    coef: np.ndarray
    exponent: np.ndarray

    def __post_init__(self) -> None:
        p = as_float_array(self.exponent, "exponent", ndim=1)
        a = as_float_array(self.coef, "coef")
        if a.ndim == 1:
            a = a[None, :]
        if a.ndim != 2 or a.shape[1] != p.size:
            raise FormulationInputError(
                f"coef must have shape (n_legs, {p.size}) or ({p.size},) to match exponent, got {a.shape}"
            )
        bad_p = np.flatnonzero((p > 0.0) & (p < 1.0))
        if bad_p.size:
            j = int(bad_p[0])
            raise NonConvexFuelModel(
                f"exponent[{j}] = {p[j]:g} lies in (0, 1): the term a·v**p gives fuel a·d**p·t**(1-p), "
                "concave in the leg time t; refit with exponents >= 1 or <= 0"
            )
        neg = np.argwhere(a < 0.0)
        if neg.size:
            i, j = (int(x) for x in neg[0])
            raise NonConvexFuelModel(
                f"coef[{i}, {j}] = {a[i, j]:g} is negative: a negative term makes the fuel of leg {i} "
                "non-convex in its time; refit with non-negative coefficients"
            )
        object.__setattr__(self, "exponent", p)
        object.__setattr__(self, "coef", a)

    @classmethod
    def cubic(cls, k: ArrayLike) -> PowerLawFuel:
        """The cubic law ``r_i(v) = k_i v³`` [t/h] (physics.md §9), fuel ``k_i d_i³ / t_i²``."""
        k = as_float_array(k, "k")
        return cls(coef=np.reshape(k, (-1, 1)), exponent=np.array([3.0]))

    @classmethod
    def polynomial(cls, coef: Sequence[float] | np.ndarray, powers: Sequence[float] | np.ndarray) -> PowerLawFuel:
        """Alias of the constructor with keyword names that read like a fit ``Σ c_j v**n_j``."""
        return cls(coef=np.asarray(coef, dtype=float), exponent=np.asarray(powers, dtype=float))

    def for_legs(self, n: int) -> np.ndarray:
        """The coefficient matrix broadcast to ``(n, n_terms)``."""
        if self.coef.shape[0] == 1:
            return np.repeat(self.coef, n, axis=0)
        if self.coef.shape[0] != n:
            raise FormulationInputError(f"the fuel model has {self.coef.shape[0]} legs of coefficients, expected {n}")
        return self.coef

    def rate(self, speed_kn: ArrayLike) -> np.ndarray:
        """Fuel rate [t/h] of every leg at the given speed(s) [kn], shape (n_legs,)."""
        v = np.asarray(speed_kn, dtype=float)
        n = v.size if v.ndim else self.coef.shape[0]
        a = self.for_legs(n)
        return np.sum(a * np.power(np.reshape(v, (-1, 1)), self.exponent[None, :]), axis=1)

    def leg_fuel(self, distance_nm: ArrayLike, time_h: ArrayLike) -> np.ndarray:
        """Fuel [t] of every leg sailed at constant speed: ``t · r(d / t)``."""
        d = np.asarray(distance_nm, dtype=float)
        t = np.asarray(time_h, dtype=float)
        return t * self.rate(d / t)


# ---------------------------------------------------------------------------
# Inputs of the corridor NLP (formulations.speed_nlp)
# ---------------------------------------------------------------------------


def _unit_rows(a: np.ndarray) -> np.ndarray:
    return a / np.linalg.norm(a, axis=1, keepdims=True)


def _left(a: np.ndarray) -> np.ndarray:
    """The vectors rotated +90° (to port of a direction of travel in an x-east, y-north frame)."""
    return np.column_stack([-a[:, 1], a[:, 0]])


@dataclass(frozen=True)
class CorridorGeometry:
    """A corridor's centreline in a locally flat frame, with lateral bounds.

    Parameters
    ----------
    centre_xy_nm : array_like, shape (N+1, 2)
        Centreline waypoints ``c_k`` in a flat frame (x east, y north) [nm].
    s_nm : array_like, shape (N+1,), optional
        Along-track coordinate of each centreline waypoint [nm], strictly increasing;
        the ``s`` axis of the weather grid. Default: cumulative centreline length from 0.
    normal_xy : array_like, shape (N+1, 2), optional
        Unit direction of positive lateral offset at each waypoint; must point to port
        (left of the direction of travel). Default: the port normal of the bisector of the
        adjacent centreline segments.
    half_width_nm : float or array_like, shape (N+1,)
        Corridor half-width [nm], ``|y_k| ≤ half_width``.
    y_lo_nm, y_hi_nm : array_like, shape (N+1,), optional
        Navigable lateral bounds per waypoint [nm] (e.g. from a land mask), combined with the
        half-width. The end points are always pinned to ``y = 0``.
    """

    centre_xy_nm: np.ndarray
    s_nm: np.ndarray | None = None
    normal_xy: np.ndarray | None = None
    half_width_nm: float | np.ndarray = 0.0
    y_lo_nm: np.ndarray | None = None
    y_hi_nm: np.ndarray | None = None

    def __post_init__(self) -> None:
        c = as_float_array(self.centre_xy_nm, "centre_xy_nm", ndim=2)
        if c.shape[1] != 2 or c.shape[0] < 2:
            raise FormulationInputError(f"centre_xy_nm must have shape (N+1, 2) with N >= 1, got {c.shape}")
        seg = np.diff(c, axis=0)
        seg_len = np.linalg.norm(seg, axis=1)
        if (seg_len <= 0).any():
            raise FormulationInputError(f"centreline has a zero-length leg at index {int(np.argmin(seg_len))}")
        tangent = seg / seg_len[:, None]
        n1 = c.shape[0]
        s = np.concatenate([[0.0], np.cumsum(seg_len)]) if self.s_nm is None else as_float_array(self.s_nm, "s_nm")
        if s.shape != (n1,) or (np.diff(s) <= 0).any():
            raise FormulationInputError(f"s_nm must be strictly increasing with shape ({n1},)")
        bis = np.vstack([tangent[:1], tangent[:-1] + tangent[1:], tangent[-1:]])
        if self.normal_xy is None:
            normal = _left(_unit_rows(bis))
        else:
            normal = as_float_array(self.normal_xy, "normal_xy", ndim=2)
            if normal.shape != (n1, 2):
                raise FormulationInputError(f"normal_xy must have shape ({n1}, 2), got {normal.shape}")
            normal = _unit_rows(normal)
        port = _left(_unit_rows(bis))
        wrong = np.flatnonzero(np.sum(normal * port, axis=1) <= 0.0)
        if wrong.size:
            raise FormulationInputError(f"normal_xy[{int(wrong[0])}] does not point to port (left of travel)")
        hw = broadcast_legs(self.half_width_nm, n1, "half_width_nm")
        if (hw < 0).any():
            raise FormulationInputError("half_width_nm must be >= 0")
        lo = -hw if self.y_lo_nm is None else np.maximum(-hw, broadcast_legs(self.y_lo_nm, n1, "y_lo_nm"))
        hi = hw if self.y_hi_nm is None else np.minimum(hw, broadcast_legs(self.y_hi_nm, n1, "y_hi_nm"))
        lo[0] = lo[-1] = hi[0] = hi[-1] = 0.0
        bad = np.flatnonzero(lo > hi)
        if bad.size:
            k = int(bad[0])
            raise FormulationInputError(f"waypoint {k}: navigable bounds [{lo[k]:g}, {hi[k]:g}] nm are empty")
        object.__setattr__(self, "centre_xy_nm", c)
        object.__setattr__(self, "s_nm", s)
        object.__setattr__(self, "normal_xy", normal)
        object.__setattr__(self, "half_width_nm", hw)
        object.__setattr__(self, "y_lo_nm", lo)
        object.__setattr__(self, "y_hi_nm", hi)
        object.__setattr__(self, "_tangent", tangent)

    @classmethod
    def straight(
        cls, distance_nm: ArrayLike, *, course_deg: float = 0.0, half_width_nm: ArrayLike = 0.0
    ) -> CorridorGeometry:
        """A straight centreline with the given leg lengths [nm] on a course [deg true, to]."""
        d = as_float_array(distance_nm, "distance_nm", ndim=1)
        s = np.concatenate([[0.0], np.cumsum(d)])
        rad = np.radians(course_deg)
        centre = np.column_stack([s * np.sin(rad), s * np.cos(rad)])
        return cls(centre_xy_nm=centre, s_nm=s, half_width_nm=half_width_nm)

    @property
    def n_legs(self) -> int:
        """Number of legs N."""
        return int(self.centre_xy_nm.shape[0] - 1)

    @property
    def tangent_xy(self) -> np.ndarray:
        """Unit tangent of every centreline segment (N, 2): the 'along' axis of vector fields on leg k."""
        return self._tangent  # type: ignore[attr-defined]

    def offset_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper lateral offset bounds (N+1,) [nm], end points pinned to 0."""
        return np.asarray(self.y_lo_nm).copy(), np.asarray(self.y_hi_nm).copy()


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


@dataclass(frozen=True)
class PowerModel:
    """The engine side of the NLP's power and fuel model and its calm-water baseline.

    The NLP's brake power at a sample is ``P = f_k · P_calm(V) · R`` (see :mod:`formulations.speed_nlp`):
    ``P_calm`` is this closed-form baseline and ``R`` the ratio ``P_ship / P_calm`` tabulated by the
    caller from the ship's own performance model on the corridor's weather grid
    (:class:`WeatherGrid`, ``power_ratio``); without a table ``R = 1``.

    Parameters
    ----------
    calm_coef, calm_exp : array_like, shape (J,)
        ``P_calm(V) = Σ c_j V^{n_j}`` [kW], ``V`` in [kn] (propeller law: ``n = 3``).
    mcr_kw : float
        Maximum continuous rating [kW].
    min_load, max_load : float
        Engine load limits as fractions of MCR [-] (``0 ≤ min_load < max_load``).
    sfc_base_gpkwh : float
        SFC_base [g/kWh] of the IMO GHG curve (physics.md §8; 175 for slow-speed diesels after 2001).
    sfc_quad : array_like, shape (3,)
        ``(a2, a1, a0)`` of ``SFOC/SFC_base = a2 L² + a1 L + a0``; default Fourth IMO GHG Study
        ``(0.455, -0.710, 1.280)``; ``(0, 0, 1)`` for a constant SFOC.
    """

    calm_coef: ArrayLike
    calm_exp: ArrayLike
    mcr_kw: float
    min_load: float = 0.0
    max_load: float = 1.0
    sfc_base_gpkwh: float = 175.0
    sfc_quad: ArrayLike = (0.455, -0.710, 1.280)

    def __post_init__(self) -> None:
        for name in ("calm_coef", "calm_exp", "sfc_quad"):
            object.__setattr__(self, name, as_float_array(getattr(self, name), name, ndim=1))
        cc, ce = np.asarray(self.calm_coef), np.asarray(self.calm_exp)
        if cc.size == 0 or cc.shape != ce.shape:
            raise FormulationInputError("calm_coef and calm_exp must be non-empty and of equal length")
        if np.asarray(self.sfc_quad).size != 3:
            raise FormulationInputError("sfc_quad needs exactly 3 coefficients")
        if not (self.mcr_kw > 0 and 0 <= self.min_load < self.max_load):
            raise FormulationInputError(
                f"need mcr_kw > 0 and 0 <= min_load < max_load, got {self.mcr_kw}, {self.min_load}, {self.max_load}"
            )
        if self.sfc_base_gpkwh <= 0:
            raise FormulationInputError(f"sfc_base_gpkwh must be > 0, got {self.sfc_base_gpkwh}")

    def calm_power_kw(self, stw_kn: ArrayLike) -> np.ndarray:
        """``P_calm(V)`` [kW]."""
        v = np.asarray(stw_kn, dtype=float)
        return sum(c * v**e for c, e in zip(self.calm_coef, self.calm_exp, strict=True))  # type: ignore[return-value]

    def fuel_rate_tph(self, power_kw: ArrayLike) -> np.ndarray:
        """Fuel rate [t/h] at a brake power [kW]: ``P · SFOC(P/MCR) · 1e-6``."""
        p = np.asarray(power_kw, dtype=float)
        a2, a1, a0 = self.sfc_quad
        load = p / self.mcr_kw
        return p * self.sfc_base_gpkwh * (a2 * load**2 + a1 * load + a0) * 1e-6


@dataclass(frozen=True)
class MovingExclusion:
    """A circle that moves in time (storm or cyclone centre plus a safety radius).

    Parameters
    ----------
    t_h : array_like, shape (nc,)
        Times of the track [h since departure], strictly increasing; the centre and radius are
        interpolated linearly and held at the first/last value outside.
    centre_xy_nm : array_like, shape (nc, 2)
        Centre in the corridor's flat frame [nm].
    radius_nm : array_like, shape (nc,)
        Exclusion radius [nm], ≥ 0.
    """

    t_h: np.ndarray
    centre_xy_nm: np.ndarray
    radius_nm: np.ndarray

    def __post_init__(self) -> None:
        t = as_float_array(self.t_h, "t_h", ndim=1)
        c = as_float_array(self.centre_xy_nm, "centre_xy_nm", ndim=2)
        r = broadcast_legs(self.radius_nm, t.size, "radius_nm")
        if t.size == 0 or (np.diff(t) <= 0).any() or c.shape != (t.size, 2) or (r < 0).any():
            raise FormulationInputError("exclusion: need increasing t_h (nc,), centre (nc, 2) and radius >= 0 (nc,)")
        object.__setattr__(self, "t_h", t)
        object.__setattr__(self, "centre_xy_nm", c)
        object.__setattr__(self, "radius_nm", r)

    @property
    def radius_scale_nm(self) -> float:
        """Largest radius [nm] (≥ 1), used to scale the constraint."""
        return max(1.0, float(np.max(self.radius_nm)))

    def interpolant(self) -> Any:
        """CasADi function ``t ↦ (cx, cy, r)``: linear interpolation, constant outside the track's times."""
        import casadi as ca

        t = np.asarray(self.t_h)
        data = np.column_stack([self.centre_xy_nm, self.radius_nm])
        if t.size == 1:
            t = np.array([t[0], t[0] + 1.0])
            data = np.vstack([data, data])
        inner = ca.interpolant("exclusion", "linear", [t], data.T.ravel(order="F"))
        x = ca.MX.sym("t")
        return ca.Function("exclusion", [x], [inner(ca.fmin(ca.fmax(x, t[0]), t[-1]))])
