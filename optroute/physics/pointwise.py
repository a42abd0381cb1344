"""The passage physics at one point, as numba-compilable scalar functions.

The referee (:func:`optroute.physics.passage.evaluate_speeds`, hence
``Plan.verify()`` and the plan evaluator), the route search's compiled edge
kernels (:mod:`optroute.search.kernels`) and the 3-D DP's transitions all cost
a speed at a point with the functions of this module, so each formula is
stated once:

* the velocity triangle that holds a course against the current (Bowditch,
  *The American Practical Navigator*, "current sailing");
* the Beaufort number from the 10 m wind (WMO) or, where the wind is
  unknown, from Hs (Met Office probable wave heights, physics.md §5);
* Kwon's (2008) involuntary speed loss, inverted for the calm-water speed
  whose weather speed is the one wanted
  (:func:`optroute.physics.speed_loss.calm_speed_point`), and the calm-water
  power of the admiralty law (Molland et al. 2017 §16.1);
* the IMO Fourth GHG Study SFOC curve;
* the four danger bands of Boeing EP 2145155 or IMO MSC.1/Circ.1228
  (:mod:`optroute.physics.safety` states the conditions and derives them).

Every function takes floats and a parameter vector ``p`` built once per
(ship, model, rules) by :func:`point_params`; indices are the ``P_*``
constants.  Units: speeds [kn], angles [deg true], currents and wind [m/s],
Hs [m], periods [s], power [kW], fuel [t/h].  The functions are numba
dispatchers, compiled lazily at their first call; ``fn.py_func`` is the plain
Python function.

:func:`point_params` returns ``None`` for a model these functions do not
cover (:class:`~optroute.physics.performance.PowerTableModel`, a ship with a
speed-power table, a user model): the vectorised numpy path is then used.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from optroute import units
from optroute._numba import jit
from optroute.physics import seaway
from optroute.physics.performance import CalmWaterModel, KwonModel, PerformanceModel
from optroute.physics.safety import BANDS, IMO_HIGH_WAVE_TE_OVER_T, BandRules
from optroute.physics.ship import Ship
from optroute.physics.speed_loss import (
    KWON_BISECTIONS,
    KWON_SCAN_STEPS,
    MAX_CALM_FROUDE,
    calm_speed_point,
    kwon_cu_coefficients,
    kwon_weather_speed_increasing,
)

__all__ = [
    "N_PARAMS",
    "allowed_speed",
    "band_forbidden",
    "beaufort_from_hs",
    "beaufort_from_wind",
    "brake_power",
    "brake_power_bound",
    "cached_point_params",
    "cost_rate_floor",
    "cost_rate_floor_in_sea",
    "evaluate_speed",
    "heading_for_course",
    "kwon_direction_coefficient",
    "kwon_direction_range",
    "kwon_form_coefficient",
    "kwon_loss_per_cu",
    "least_cost_per_nm",
    "loss_range_at",
    "point_params",
    "rate_floor_at_power",
    "stw_for_sog",
    "wrap_360",
]

# indices of the parameter vector
P_KWON = 0  # 1: KwonModel, 0: CalmWaterModel
P_D23 = 1  # displacement^(2/3) [t^(2/3)]
P_CADM = 2  # admiralty coefficient [t^(2/3) kn^3 / kW]
P_MCR = 3  # [kW]
P_MIN_POWER = 4  # [kW]
P_SFOC_BASE = 5  # [g/kWh]
P_CU_A, P_CU_B, P_CU_C = 6, 7, 8  # Kwon's C_U = a + b Fn + c Fn^2
P_FORM_LINEAR = 9  # C_Form = lin BN + BN^6.5 / (div V^(2/3))
P_FORM_DIV = 10
P_V23 = 11  # displacement volume^(2/3) [m^2]
P_INV_SQRT_GL_KN = 12  # 1 / sqrt(g L) [1/kn]
P_VMAX_KN = 13  # the calm speed at Kwon's top Froude number, with its rounding slack [kn]
P_LENGTH = 14  # L [m]
P_ROLL = 15  # T_R [s]
P_HS_MIN = 16  # bands apply where Hs >= this [m]
P_MARGIN = 17  # band half-width m [-]
P_BAND0 = 18  # 4 flags: synchronous_roll, parametric_roll, surf_riding, high_wave_attack
P_IMO = 22  # 1: IMO rule set, 0: Boeing
P_K_TE = 23  # g / 2 pi in the encounter period [kn/s]
N_PARAMS = 24

_MS_PER_KN = units.MS_PER_KN
_G = seaway.G_MS2
_BEAUFORT_WIND_UPPER = seaway.BEAUFORT_WIND_UPPER_MS.copy()
_BEAUFORT_WAVE = seaway.BEAUFORT_WAVE_HEIGHT_M.copy()
_IMO_HW_LO, _IMO_HW_HI = IMO_HIGH_WAVE_TE_OVER_T


def point_params(ship: Ship, model: PerformanceModel, rules: BandRules) -> np.ndarray | None:
    """The parameter vector of the point functions, or ``None`` for a model they do not cover.

    Covered: :class:`~optroute.physics.performance.KwonModel` and
    :class:`~optroute.physics.performance.CalmWaterModel` of the same ship,
    whose calm-water curve is the admiralty law (no ``speed_power_table``).
    """
    if type(model) not in (KwonModel, CalmWaterModel) or model.ship != ship or ship.speed_power_table is not None:
        return None
    p = np.zeros(N_PARAMS)
    p[P_KWON] = 1.0 if type(model) is KwonModel else 0.0
    p[P_D23] = ship.displacement_t ** (2.0 / 3.0)
    p[P_CADM] = ship.admiralty_coefficient
    p[P_MCR] = ship.mcr_kw
    p[P_MIN_POWER] = ship.min_power_kw
    p[P_SFOC_BASE] = ship.sfoc_base_gpkwh
    if type(model) is KwonModel:
        a, b, c = kwon_cu_coefficients(ship.block_coefficient, ship.loading)  # type: ignore[arg-type]
        p[P_CU_A], p[P_CU_B], p[P_CU_C] = float(a), float(b), float(c)
        container = ship.ship_type == "container"
        p[P_FORM_LINEAR] = 0.7 if container or ship.loading == "ballast" else 0.5
        p[P_FORM_DIV] = 22.0 if container else 2.7
        p[P_V23] = ship.volume_m3 ** (2.0 / 3.0)
    sqrt_gl_kn = float(units.ms_to_kn(np.sqrt(_G * ship.length_m)))
    p[P_INV_SQRT_GL_KN] = 1.0 / sqrt_gl_kn
    p[P_VMAX_KN] = MAX_CALM_FROUDE * sqrt_gl_kn * (1.0 + 1e-12)
    p[P_LENGTH] = ship.length_m
    p[P_ROLL] = ship.roll_period_s
    p[P_HS_MIN] = rules.hs_threshold_fraction * ship.length_m
    p[P_MARGIN] = rules.margin
    for k, band in enumerate(BANDS):
        p[P_BAND0 + k] = 1.0 if getattr(rules, band) else 0.0
    p[P_IMO] = 1.0 if rules.rule_set == "imo" else 0.0
    p[P_K_TE] = seaway.IMO_G_OVER_2PI_KN_S if rules.period_form == "imo" else float(units.ms_to_kn(_G / (2.0 * np.pi)))
    return p


def cached_point_params(ship: Ship, model: PerformanceModel, rules: BandRules) -> np.ndarray | None:
    """:func:`point_params`, remembered for the last (ship, model, rules) asked (a read-only array)."""
    if type(model) not in (KwonModel, CalmWaterModel):
        return None
    return _cached_params(ship, model, rules)


@functools.lru_cache(maxsize=64)
def _cached_params(ship: Ship, model: PerformanceModel, rules: BandRules) -> np.ndarray | None:
    p = point_params(ship, model, rules)
    if p is not None:
        p.setflags(write=False)
    return p


@jit
def wrap_360(angle_deg):  # pragma: no cover - compiled
    """An angle [deg] in [0, 360) (as :func:`optroute.units.wrap_360`)."""
    r = angle_deg % 360.0
    return 0.0 if r >= 360.0 else r


@jit
def heading_for_course(course_deg, stw_kn, cu_kn, cv_kn):  # pragma: no cover - compiled
    """Heading [deg true] and SOG [kn] making good ``course_deg`` at ``stw_kn`` against a current [kn].

    Bowditch, "current sailing": with the current along (c_a) and across (c_x,
    + to starboard) the course, δ = arcsin(−c_x / STW), SOG = STW cos δ + c_a.
    NaN for both where the cross-current exceeds the STW or the SOG is <= 0.
    """
    c = math.radians(course_deg)
    along = cu_kn * math.sin(c) + cv_kn * math.cos(c)
    cross = cu_kn * math.cos(c) - cv_kn * math.sin(c)
    delta = math.asin(min(max(-cross / stw_kn, -1.0), 1.0))
    sog = stw_kn * math.cos(delta) + along
    if abs(cross) > stw_kn or sog <= 0.0 or not (sog == sog):
        return np.nan, np.nan
    return wrap_360(course_deg + math.degrees(delta)), sog


@jit
def stw_for_sog(course_deg, sog_kn, cur_u_ms, cur_v_ms):  # pragma: no cover - compiled
    """Speed through the water [kn] making good ``sog_kn`` along ``course_deg`` against a current [m/s].

    Bowditch, "current sailing": the water velocity is SOG (sin c, cos c) − (u, v)
    (as :func:`optroute.physics.currents.stw_for_sog`).
    """
    c = math.radians(course_deg)
    return math.hypot(sog_kn * math.sin(c) - cur_u_ms / _MS_PER_KN, sog_kn * math.cos(c) - cur_v_ms / _MS_PER_KN)


@jit
def beaufort_from_wind(wind_speed_ms):  # pragma: no cover - compiled
    """Beaufort number of a 10 m wind [m/s] (WMO bands, as :func:`optroute.physics.seaway.beaufort_from_wind`)."""
    return float(np.searchsorted(_BEAUFORT_WIND_UPPER, wind_speed_ms, side="right"))


@jit
def beaufort_from_hs(hs_m):  # pragma: no cover - compiled
    """Beaufort number whose probable wave height is nearest Hs [m], ties to the lower force."""
    best, k_best = np.inf, 0
    for k in range(_BEAUFORT_WAVE.size):
        d = abs(hs_m - _BEAUFORT_WAVE[k])
        if d < best:
            best, k_best = d, k
    return float(k_best)


@jit
def kwon_direction_coefficient(angle_deg, bn):  # pragma: no cover - compiled
    """Kwon's (2008) C_β for a weather angle from the bow [deg, folded to 0–180] and Beaufort number."""
    a = wrap_360(angle_deg)
    if a > 180.0:
        a = 360.0 - a
    if a <= 30.0:
        two_c = 2.0
    elif a <= 60.0:
        two_c = 1.7 - 0.03 * (bn - 4.0) ** 2
    elif a <= 150.0:
        two_c = 0.9 - 0.06 * (bn - 6.0) ** 2
    else:
        two_c = 0.4 - 0.03 * (bn - 8.0) ** 2
    return max(0.5 * two_c, 0.0)


@jit
def kwon_form_coefficient(bn, linear, divisor, v23):  # pragma: no cover - compiled
    """Kwon's (2008) C_Form = linear · BN + BN^6.5 / (divisor · ∇^(2/3)) (0.7/22 container, 0.5 or 0.7/2.7 others)."""
    return linear * bn + bn**6.5 / (divisor * v23)


_SECTOR_EDGES = np.array([30.0, 60.0, 150.0, 210.0, 300.0, 330.0])  # Kwon's C_β sectors from the bow [deg]


@jit
def kwon_direction_range(bn, lo_deg, hi_deg):  # pragma: no cover - compiled
    """Kwon's (2008) least and greatest C_β at Beaufort ``bn`` over wave angles from the bow in [lo, hi] [deg].

    C_β is constant on each sector (:func:`kwon_direction_coefficient`): its values at the ends and on either side
    of every sector edge inside the interval (1e-6° apart) are all it takes.
    """
    least = min(kwon_direction_coefficient(lo_deg, bn), kwon_direction_coefficient(hi_deg, bn))
    most = max(kwon_direction_coefficient(lo_deg, bn), kwon_direction_coefficient(hi_deg, bn))
    for turn in range(int(math.floor(lo_deg / 360.0)), int(math.floor(hi_deg / 360.0)) + 1):
        for e in _SECTOR_EDGES:
            for a in (e - 1e-6, e, e + 1e-6):
                x = a + 360.0 * turn
                if lo_deg <= x <= hi_deg:
                    c = kwon_direction_coefficient(x, bn)
                    least, most = min(least, c), max(most, c)
    return least, most


@jit
def _beaufort_of(hs_m, wind_speed_ms):  # pragma: no cover - compiled
    """The Beaufort number Kwon's loss takes: the wind's where it is known, else that of Hs."""
    return beaufort_from_wind(wind_speed_ms) if math.isfinite(wind_speed_ms) else beaufort_from_hs(hs_m)


@jit
def kwon_loss_per_cu(p, hs_m, wave_angle_deg, wind_speed_ms):  # pragma: no cover - compiled
    """Kwon's (2008) speed loss per C_U, C_β C_Form / 100, of a sea met ``wave_angle_deg`` from the bow [-]."""
    bn = _beaufort_of(hs_m, wind_speed_ms)
    return (
        kwon_direction_coefficient(wave_angle_deg, bn)
        * kwon_form_coefficient(bn, p[P_FORM_LINEAR], p[P_FORM_DIV], p[P_V23])
        / 100.0
    )


@jit
def calm_power(p, stw_kn):  # pragma: no cover - compiled
    """Calm-water brake power by the admiralty law, Δ^(2/3) V³ / C_adm [kW]."""
    return p[P_D23] * stw_kn**3 / p[P_CADM]


@jit
def brake_power(p, stw_kn, hs_m, wave_angle_deg, wind_speed_ms):  # pragma: no cover - compiled
    """Brake power [kW] of the model in ``p``: calm water, or Kwon's equivalent calm speed's (``inf`` if none)."""
    if p[P_KWON] == 0.0:
        return calm_power(p, stw_kn)
    loss_per_cu = kwon_loss_per_cu(p, hs_m, wave_angle_deg, wind_speed_ms)
    v_max = p[P_VMAX_KN]
    if stw_kn > v_max * (1.0 + 1e-12):
        return np.inf
    v1 = calm_speed_point(
        stw_kn,
        p[P_CU_A],
        p[P_CU_B],
        p[P_CU_C],
        loss_per_cu,
        p[P_INV_SQRT_GL_KN],
        v_max,
        np.int64(KWON_SCAN_STEPS),  # typed, not literal: one signature with _invert_kwon's
        np.int64(KWON_BISECTIONS),
    )
    if not math.isfinite(v1):
        return np.inf
    return calm_power(p, v1)


@jit
def brake_power_bound(p, stw_lo_kn, stw_hi_kn, bn_max):  # pragma: no cover - compiled
    """An upper bound on :func:`brake_power` at every speed in [``stw_lo_kn``, ``stw_hi_kn``], any wave angle, BN <= ``bn_max`` [kW].

    Calm water: the admiralty power at ``stw_hi_kn``.  Kwon (2008): C_β <= 1 at every angle and
    C_Form increases with BN, so the loss per C_U is at most ``C_Form(bn_max) / 100``; where the
    weather speed increases with the calm speed over [``stw_lo_kn``, V_max] at that loss (then at
    every smaller loss too), the calm speed :func:`calm_speed_point` finds is unique, grows with the
    loss and with the speed wanted, so its power at (``stw_hi_kn``, the largest loss) bounds every
    other, up to the few ulps the root is found to (a relative 1e-9 is added).  ``inf`` where this
    does not hold (the bound is then unknown).
    """
    if p[P_KWON] == 0.0:
        return calm_power(p, stw_hi_kn) * (1.0 + 1e-9)
    v_max = p[P_VMAX_KN]
    if not (0.0 < stw_lo_kn <= stw_hi_kn <= v_max):
        return np.inf
    loss = kwon_form_coefficient(bn_max, p[P_FORM_LINEAR], p[P_FORM_DIV], p[P_V23]) / 100.0
    a, b, c, inv = p[P_CU_A], p[P_CU_B], p[P_CU_C], p[P_INV_SQRT_GL_KN]
    if not kwon_weather_speed_increasing(stw_lo_kn, v_max, a, b, c, loss * (1.0 + 1e-6), inv):
        return np.inf
    v1 = calm_speed_point(stw_hi_kn, a, b, c, loss, inv, v_max, np.int64(KWON_SCAN_STEPS), np.int64(KWON_BISECTIONS))
    if not math.isfinite(v1):
        return np.inf
    return calm_power(p, v1) * (1.0 + 1e-9)


@jit
def fuel_rate(p, power_kw):  # pragma: no cover - compiled
    """Fuel rate [t/h] = SFOC(P) · P / 10⁶, SFOC = SFC_base (0.455 L² − 0.710 L + 1.280), L = P / MCR (IMO GHG4)."""
    load = power_kw / p[P_MCR]
    return p[P_SFOC_BASE] * (0.455 * load**2 - 0.710 * load + 1.280) * power_kw * 1e-6


@jit
def rate_floor_at_power(p, power_kw, stw_kn, lam_t_per_h, current_kn):  # pragma: no cover - compiled
    """``(fuel_rate(max(P, P_min)) + λ) / (v + c)`` [t/nm]: a lower bound on (fuel + λ) / SOG of ``stw_kn`` [kn]
    where its brake power is at least ``power_kw`` and the current at most ``current_kn`` [kn].

    An allowed speed's power is at least the minimum load, the fuel rate (IMO GHG4 SFOC) increases with the
    power, and the SOG is at most v + |current|.
    """
    return (fuel_rate(p, max(power_kw, p[P_MIN_POWER])) + lam_t_per_h) / (stw_kn + current_kn)


@jit
def cost_rate_floor(p, stw_kn, lam_t_per_h, current_kn):  # pragma: no cover - compiled
    """A lower bound on (fuel + λ) / SOG [t/nm] of ``stw_kn`` wherever the current is at most ``current_kn`` [kn].

    :func:`rate_floor_at_power` at the calm-water power: the brake power of an allowed speed is at least that
    (Kwon's loss is floored at 0; see :func:`least_cost_per_nm`).
    """
    return rate_floor_at_power(p, calm_power(p, stw_kn), stw_kn, lam_t_per_h, current_kn)


@jit
def loss_range_at(
    p, course_deg, hs_m, wave_from_deg, wind_u_ms, wind_v_ms, current_kn, stw_min_kn
):  # pragma: no cover - compiled
    """The least and greatest Kwon loss per C_U [-] of any speed >= ``stw_min_kn`` [kn] making good ``course_deg``
    [deg true] at a point: (0, 0) for the calm-water model or where the sea is not known.

    The heading crabs off the course by at most asin(current / STW) (:func:`heading_for_course`), so the wave angle
    from the bow lies within that (and 1e-6°) of the course's; C_β's range over it (:func:`kwon_direction_range`)
    times C_Form / 100 at the point's Beaufort number (:func:`kwon_loss_per_cu`'s).
    """
    if p[P_KWON] == 0.0 or not (math.isfinite(hs_m) and math.isfinite(wave_from_deg)):
        return 0.0, 0.0
    bn = _beaufort_of(hs_m, math.hypot(wind_u_ms, wind_v_ms))
    crab = math.degrees(math.asin(min(1.0, current_kn / stw_min_kn))) if current_kn > 0.0 else 0.0
    alpha = wrap_360(wave_from_deg - course_deg)
    lo, hi = kwon_direction_range(bn, alpha - crab - 1e-6, alpha + crab + 1e-6)
    form = kwon_form_coefficient(bn, p[P_FORM_LINEAR], p[P_FORM_DIV], p[P_V23]) / 100.0
    return lo * form, hi * form


@jit
def _cu_range(p, fn_lo, fn_hi):  # pragma: no cover - compiled
    """Least and greatest of Kwon's C_U = a + b Fn + c Fn² over [fn_lo, fn_hi] (the ends and the vertex)."""
    a, b, c = p[P_CU_A], p[P_CU_B], p[P_CU_C]
    u1, u2 = a + fn_lo * (b + c * fn_lo), a + fn_hi * (b + c * fn_hi)
    least, most = min(u1, u2), max(u1, u2)
    if c != 0.0:
        f = -b / (2.0 * c)
        if fn_lo < f < fn_hi:
            u = a + f * (b + c * f)
            least, most = min(least, u), max(most, u)
    return least, most


@jit
def cost_rate_floor_in_sea(p, stw_kn, lam_t_per_h, current_kn, loss_lo, loss_hi):  # pragma: no cover - compiled
    """A lower bound on (fuel + λ) / SOG [t/nm] of ``stw_kn`` in a sea whose Kwon loss per C_U lies in
    [``loss_lo``, ``loss_hi``] (:func:`loss_range_at`), the current at most ``current_kn`` [kn]; ``inf`` where no
    calm speed makes ``stw_kn`` good (:func:`brake_power` is then infinite).

    :func:`cost_rate_floor` with the calm speed's floor in place of ``stw_kn``: :func:`brake_power` takes the least
    V1 in [V, V_max] with V1 (1 − L(V1)) >= V, L = max(k C_U(Fn(V1)), 0) (Kwon 2008).  With L_hi the largest L
    over [V, V_max], V1 <= X = min(V / (1 − L_hi), V_max) (X itself makes V good); with L_lo the least L over
    [V, X], V <= V1 (1 − L(V1)) <= V1 (1 − L_lo), so V1 >= V / (1 − L_lo) and the admiralty power at V1 is at
    least P_calm(V) / (1 − L_lo)³.
    """
    if p[P_KWON] == 0.0 or loss_hi <= 0.0:
        return cost_rate_floor(p, stw_kn, lam_t_per_h, current_kn)
    v_max = p[P_VMAX_KN]
    if stw_kn > v_max * (1.0 + 1e-12):
        return np.inf
    inv = p[P_INV_SQRT_GL_KN]
    fn_v = stw_kn * inv
    l_hi = max(loss_hi * _cu_range(p, fn_v, max(fn_v, v_max * inv))[1], 0.0)
    x = v_max if l_hi >= 1.0 else min(stw_kn / (1.0 - l_hi), v_max)
    l_lo = max(loss_lo * _cu_range(p, fn_v, max(fn_v, x * inv))[0], 0.0)
    if l_lo >= 1.0:
        return np.inf
    return rate_floor_at_power(p, calm_power(p, stw_kn) / (1.0 - l_lo) ** 3, stw_kn, lam_t_per_h, current_kn)


@jit
def _band_terms(p, speed_kn, period_s, alpha_deg):  # pragma: no cover - compiled
    """(u, T_E): the speed along the waves [kn] and the encounter period [s] (inf where the waves are met at rest)."""
    cos_a = math.cos(math.radians(alpha_deg))
    u = -speed_kn * cos_a
    k = p[P_K_TE]
    denom = abs(k * period_s + speed_kn * cos_a)
    t_e = k * period_s**2 / denom if denom > 0.0 else np.inf
    return u, t_e


@jit
def _margin_of(p, band, u, t_e, period_s, alpha_deg):  # pragma: no cover - compiled
    """Band ``band``'s ``max(lo − r, r − hi)`` from :func:`_band_terms`; +inf where disabled or its IMO condition fails."""
    if p[P_BAND0 + band] == 0.0:
        return np.inf
    m = p[P_MARGIN]
    if band == 0:
        r = t_e / p[P_ROLL]
        return max(1.0 - m - r, r - (1.0 + m))
    if band == 1:
        r = t_e / p[P_ROLL]
        return max(0.5 * (1.0 - m) - r, r - 0.5 * (1.0 + m))
    if p[P_IMO] == 0.0:
        c = _G * period_s / (2.0 * math.pi) / _MS_PER_KN
        r = u / c if band == 2 else u / (0.5 * c)
        return max(1.0 - m - r, r - (1.0 + m))
    length = p[P_LENGTH]
    if band == 2:
        if not 135.0 < alpha_deg < 225.0:
            return np.inf
        return 1.0 - u / (1.8 * math.sqrt(length))  # the band [1, inf) of u / 1.8 sqrt(L)
    if not _G * period_s**2 / (2.0 * math.pi) > 0.8 * length:
        return np.inf
    r = t_e / period_s if p[P_K_TE] * period_s - u > 0.0 else -t_e / period_s
    return max(_IMO_HW_LO - r, r - _IMO_HW_HI)


@jit
def band_margin(p, band, speed_kn, period_s, alpha_deg):  # pragma: no cover - compiled
    """Signed distance of band ``band``'s ratio to its forbidden range, as :func:`optroute.physics.safety.band_margins`.

    ``band`` indexes :data:`optroute.physics.safety.BANDS`; ``max(lo − r, r − hi)`` (<= 0 inside the
    closed band), +inf where the band is disabled or its IMO condition (sector, wavelength) fails.
    Hs is not looked at: the bands apply where Hs >= the threshold (:func:`band_forbidden`).
    α is the IMO encounter angle [deg].
    """
    u, t_e = _band_terms(p, speed_kn, period_s, alpha_deg)
    return _margin_of(p, band, u, t_e, period_s, alpha_deg)


@jit
def band_forbidden(p, speed_kn, hs_m, period_s, alpha_deg):  # pragma: no cover - compiled
    """Whether ``speed_kn`` lies in an enabled danger band (closed), α the IMO encounter angle [deg].

    The conditions of :func:`optroute.physics.safety.is_speed_forbidden`:
    T_E / T_R in [1 ∓ m] (synchronous) or [0.5 (1 ∓ m)] (parametric roll);
    Boeing: V cos χ / c and V cos χ / c_g in [1 ∓ m]; IMO: V cos(180° − α) >= 1.8 √L
    for 135° < α < 225°, and 1.8 <= T_E / T <= 3 (signed) where λ > 0.8 L: a band's
    :func:`band_margin` <= 0.  Nothing is forbidden where Hs is below the threshold.
    """
    if not hs_m >= p[P_HS_MIN]:
        return False
    u, t_e = _band_terms(p, speed_kn, period_s, alpha_deg)
    for band in range(4):
        if _margin_of(p, band, u, t_e, period_s, alpha_deg) <= 0.0:
            return True
    return False


@jit
def _situation(
    course_deg, hs_m, period_s, wave_from_deg, wind_u_ms, wind_v_ms, cur_u_ms, cur_v_ms, stw_kn
):  # pragma: no cover - compiled
    """(navigable, hs, period, heading or NaN, SOG, α, wind speed) of a speed at a point."""
    nav = math.isfinite(hs_m) and math.isfinite(period_s) and math.isfinite(wave_from_deg)
    if not nav:  # no sea state (land, ice, outside the data): the current there is no number either
        hs_m, period_s, wave_from_deg, cur_u_ms, cur_v_ms = 0.0, 1.0, 0.0, 0.0, 0.0
    heading, sog = heading_for_course(course_deg, stw_kn, cur_u_ms / _MS_PER_KN, cur_v_ms / _MS_PER_KN)
    hdg = heading if math.isfinite(heading) else course_deg
    return nav, hs_m, period_s, heading, sog, wrap_360(wave_from_deg - hdg), math.hypot(wind_u_ms, wind_v_ms)


@jit
def evaluate_speed(
    p, course_deg, hs_m, period_s, wave_from_deg, wind_u_ms, wind_v_ms, cur_u_ms, cur_v_ms, stw_kn
):  # pragma: no cover - compiled
    """Heading, SOG, power, fuel rate and allowedness of one speed through water at one point.

    As :func:`optroute.physics.passage.evaluate_speeds` for one point: the
    heading crabs against the current; the speed is allowed where the sea is
    navigable (Hs, period and direction finite), the course is held with
    positive SOG, no band forbids it and the power is within [min load, MCR].
    Returns ``(heading_deg, sog_kn, power_kw, fuel_tph, allowed)``; heading and
    SOG NaN where the course cannot be held, fuel ``inf`` where the power is.
    """
    nav, hs, period, heading, sog, alpha, wind = _situation(
        course_deg, hs_m, period_s, wave_from_deg, wind_u_ms, wind_v_ms, cur_u_ms, cur_v_ms, stw_kn
    )
    power = brake_power(p, stw_kn, hs, alpha, wind)
    forbidden = band_forbidden(p, stw_kn, hs, period, alpha)
    in_power = p[P_MIN_POWER] <= power <= p[P_MCR]
    allowed = nav and math.isfinite(heading) and not forbidden and in_power
    if not nav:  # no sea state, no power (never the calm-water figure) and no speed over ground
        power, sog = np.nan, np.nan
    fuel = fuel_rate(p, power) if math.isfinite(power) else np.inf
    return heading, sog, power, fuel, allowed


@jit
def allowed_speed(
    p, course_deg, hs_m, period_s, wave_from_deg, wind_u_ms, wind_v_ms, cur_u_ms, cur_v_ms, stw_kn
):  # pragma: no cover - compiled
    """``(sog_kn, fuel_tph, allowed)`` of :func:`evaluate_speed`, skipping the power where a band or the sea already forbids.

    SOG and fuel are NaN where not allowed; where allowed they are
    :func:`evaluate_speed`'s own.  The search kernels' form.
    """
    nav, hs, period, heading, sog, alpha, wind = _situation(
        course_deg, hs_m, period_s, wave_from_deg, wind_u_ms, wind_v_ms, cur_u_ms, cur_v_ms, stw_kn
    )
    if not (nav and math.isfinite(heading)) or band_forbidden(p, stw_kn, hs, period, alpha):
        return np.nan, np.nan, False
    power = brake_power(p, stw_kn, hs, alpha, wind)
    if not p[P_MIN_POWER] <= power <= p[P_MCR]:
        return np.nan, np.nan, False
    return sog, fuel_rate(p, power), True


@jit
def band_state(
    p, course_deg, hs_m, period_s, wave_from_deg, wind_u_ms, wind_v_ms, cur_u_ms, cur_v_ms, stw_kn, margins
):  # pragma: no cover - compiled
    """The referee's band functions at one point, as :func:`optroute.search.band_refine.band_functions`.

    Writes every band's :func:`band_margin` into ``margins[:4]`` (the heading the course where it
    cannot be held) and returns ``(ok, wave_from_deg, g)``: navigable with the course held, the wave
    direction (0 where not navigable) and Hs's relative distance below the bands' threshold
    (−inf where the threshold is 0).
    """
    nav, hs, period, heading, _, alpha, _ = _situation(
        course_deg, hs_m, period_s, wave_from_deg, wind_u_ms, wind_v_ms, cur_u_ms, cur_v_ms, stw_kn
    )
    u, t_e = _band_terms(p, stw_kn, period, alpha)
    for band in range(4):
        margins[band] = _margin_of(p, band, u, t_e, period, alpha)
    thr = p[P_HS_MIN]
    g = (thr - hs) / thr if thr > 0.0 else -np.inf
    return nav and math.isfinite(heading), wave_from_deg if nav else 0.0, g


@jit
def evaluate_speeds_flat(
    p, course, hs, period, wave_from, wind_u, wind_v, cur_u, cur_v, stw
):  # pragma: no cover - compiled
    """:func:`evaluate_speed` over 1-D arrays of one length."""
    n = stw.size
    heading, sog, power, fuel = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    allowed = np.empty(n, dtype=np.bool_)
    for i in range(n):
        heading[i], sog[i], power[i], fuel[i], allowed[i] = evaluate_speed(
            p, course[i], hs[i], period[i], wave_from[i], wind_u[i], wind_v[i], cur_u[i], cur_v[i], stw[i]
        )
    return heading, sog, power, fuel, allowed


def least_cost_per_nm(p: np.ndarray, speeds_kn: np.ndarray, lambda_t_per_h: float, current_kn: float) -> float:
    """A lower bound on (fuel + λ·time) per nautical mile at any allowed speed of ``speeds_kn``, anywhere [t/nm].

    ``min over v of (fuel_rate(max(P_calm(v), P_min)) + λ) / (v + c)`` with
    ``c`` [kn] at least the strongest current.  It holds because, at a speed
    through water v allowed anywhere (:func:`evaluate_speed`):

    * the brake power is at least the calm-water power: Kwon's (2008) loss is
      floored at 0, so the calm speed :func:`brake_power` inverts for is >= v
      (and the calm-water model is the calm power itself);
    * the power is at least the minimum load, or v is not allowed;
    * the fuel rate (IMO GHG4 SFOC times P) increases with P: its derivative in
      the load L is SFC_base (1.365 L² − 1.420 L + 1.280) > 0 (negative discriminant);
    * the speed over ground is at most v + |current| (Bowditch's current triangle).

    Per mile of a leg's integration (:mod:`optroute.search.passage_kernels`:
    a midpoint rate times the piece, or the trapezoidal rule over check points,
    where ``(F_a + F_b)(1/s_a + 1/s_b) / 4 >= r`` whenever ``F_a/s_a, F_b/s_b >= r``)
    the bound holds for the whole leg, so ρ times the great-circle distance to
    the end is an admissible and consistent A* heuristic for the fuel and cost
    objectives.  Units: speeds [kn], λ [t/h], result [t/nm].
    """
    best = np.inf
    for v in np.asarray(speeds_kn, dtype=float).ravel():
        if v > 0.0:
            best = min(best, float(cost_rate_floor(p, float(v), float(lambda_t_per_h), float(current_kn))))
    return float(best) if np.isfinite(best) else 0.0
