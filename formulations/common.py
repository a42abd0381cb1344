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
