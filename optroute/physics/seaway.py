"""Deep-water linear wave relations, encounter period and the Beaufort scale.

All functions are vectorised over numpy arrays.  Angles follow
``shared/design.md``: the relative wave angle α is 0° for head seas, 90° for
a sea from starboard and 180° for following seas (IMO MSC.1/Circ.1228).

Sources
-------
* Deep-water dispersion ω² = g k: any text on linear waves, e.g.
  Faltinsen (1990), *Sea Loads on Ships and Offshore Structures*, ch. 2.
* Encounter period: IMO MSC.1/Circ.1228 (2007), Fig. 1, and its exact form
  T_E = T / |1 + V cos α / c|.
* Beaufort scale: WMO No. 306 / Met Office *Marine observer's handbook*,
  wind at 10 m and probable wave height.
* Pierson–Moskowitz spectrum period ratios: T01 = 0.7718 Tp, T02 = 0.7104 Tp;
  Tp = 5.00 √Hs for a fully developed sea (DNV-RP-C205 §3.5).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from optroute import units
from optroute._checks import finite

G_MS2 = 9.80665
"""Standard gravity [m/s²] (CGPM 1901)."""

IMO_G_OVER_2PI_KN_S = 3.0
"""The rounded g/2π [kn/s] of IMO MSC.1/Circ.1228 Fig. 1 (exact: 3.0348)."""


def wavelength_m(period_s: ArrayLike) -> np.ndarray:
    """Deep-water wavelength λ = g T² / 2π.

    Parameters
    ----------
    period_s : array_like
        Wave period T [s], > 0.

    Returns
    -------
    ndarray
        Wavelength [m] (1.5613 T²).
    """
    t = finite("period_s", period_s, minimum=0.0, strict=True)
    return G_MS2 * t**2 / (2.0 * np.pi)


def period_from_wavelength_s(wavelength_m_: ArrayLike) -> np.ndarray:
    """Deep-water period T = √(2π λ / g) [s] for a wavelength λ [m], > 0."""
    lam = finite("wavelength_m", wavelength_m_, minimum=0.0, strict=True)
    return np.sqrt(2.0 * np.pi * lam / G_MS2)


def phase_speed_ms(period_s: ArrayLike) -> np.ndarray:
    """Deep-water phase speed c = g T / 2π [m/s] (1.5613 T) for a period T [s], > 0."""
    t = finite("period_s", period_s, minimum=0.0, strict=True)
    return G_MS2 * t / (2.0 * np.pi)


def group_speed_ms(period_s: ArrayLike) -> np.ndarray:
    """Deep-water group speed c_g = c / 2 = g T / 4π [m/s] for a period T [s], > 0."""
    return 0.5 * phase_speed_ms(period_s)


def relative_wave_angle_deg(heading_deg: ArrayLike, wave_from_deg: ArrayLike) -> np.ndarray:
    """IMO angle of encounter α between the ship and the waves.

    Parameters
    ----------
    heading_deg : array_like
        Ship heading [deg true, the direction the ship goes to].
    wave_from_deg : array_like
        Mean wave direction [deg true, the direction the waves come from].

    Returns
    -------
    ndarray
        α in [0, 360) [deg]: 0 head sea, 90 sea from starboard, 180 following
        (IMO MSC.1/Circ.1228 §1).
    """
    h = finite("heading_deg", heading_deg)
    w = finite("wave_from_deg", wave_from_deg)
    return units.wrap_360(w - h)


def speed_along_waves_kn(speed_kn: ArrayLike, alpha_deg: ArrayLike) -> np.ndarray:
    """Ship velocity component along the wave **propagation** direction.

    V cos(180° − α) = −V cos α [kn]: positive when the ship runs with the
    waves (following seas), negative into them.  This is the V_s cos χ of
    the Boeing patent (EP 2145155), χ = heading − wave propagation direction.

    Parameters
    ----------
    speed_kn : array_like
        Ship speed [kn].
    alpha_deg : array_like
        IMO angle of encounter α [deg, 0 = head sea].
    """
    v = np.asarray(speed_kn, dtype=float)
    return -v * np.cos(np.radians(np.asarray(alpha_deg, dtype=float)))


def encounter_period_s(
    period_s: ArrayLike,
    speed_kn: ArrayLike,
    alpha_deg: ArrayLike,
    *,
    form: str = "exact",
) -> np.ndarray:
    """Wave encounter period.

    T_E = T² g/2π / |g/2π T + V cos α|; ``form="imo"`` uses IMO's rounded
    3 for g/2π [kn/s] (MSC.1/Circ.1228 Fig. 1: T_E = 3T² / (3T + V cos α)),
    ``form="exact"`` uses 3.0348.  When the denominator changes sign (the
    ship overtakes the waves) the absolute value is taken: T_E is then the
    period of overtaking.  When it is zero (the ship rides with the wave
    crest) T_E is infinite.

    Parameters
    ----------
    period_s : array_like
        Wave period T [s], > 0.
    speed_kn : array_like
        Ship speed V [kn], >= 0.
    alpha_deg : array_like
        IMO angle of encounter α [deg, 0 = head sea, 180 = following].
    form : {"exact", "imo"}
        Which g/2π to use.

    Returns
    -------
    ndarray
        Encounter period T_E [s]; ``inf`` where the ship moves with the waves.
    """
    t = finite("period_s", period_s, minimum=0.0, strict=True)
    v = finite("speed_kn", speed_kn, minimum=0.0)
    a = finite("alpha_deg", alpha_deg)
    if form == "exact":
        k = units.ms_to_kn(G_MS2 / (2.0 * np.pi))
    elif form == "imo":
        k = IMO_G_OVER_2PI_KN_S
    else:
        from optroute.errors import ConfigError

        raise ConfigError(f"form={form!r} is not known; use 'exact' or 'imo'")
    denom = np.abs(k * t + v * np.cos(np.radians(a)))
    with np.errstate(divide="ignore"):
        return np.where(denom > 0.0, k * t**2 / np.where(denom > 0.0, denom, 1.0), np.inf)


# Beaufort scale (WMO): upper wind limit [m/s] of each force 0..11 and the
# Met Office probable wave height [m] of each force 0..12.
BEAUFORT_WIND_UPPER_MS = np.array([0.25, 1.55, 3.35, 5.45, 7.95, 10.75, 13.85, 17.15, 20.75, 24.45, 28.45, 32.65])
BEAUFORT_WAVE_HEIGHT_M = np.array([0.0, 0.1, 0.2, 0.6, 1.0, 2.0, 3.0, 4.0, 5.5, 7.0, 9.0, 11.5, 14.0])
BEAUFORT_HS_EDGES_M = 0.5 * (BEAUFORT_WAVE_HEIGHT_M[1:] + BEAUFORT_WAVE_HEIGHT_M[:-1])
"""Hs where :func:`beaufort_from_hs` steps [m]: midway between neighbouring probable wave heights."""


def beaufort_from_wind(wind_speed_ms: ArrayLike) -> np.ndarray:
    """Beaufort number of a 10 m wind speed.

    The WMO table gives the bands to 0.1 m/s (force 6 = 10.8–13.8 m/s); a
    speed between two printed bands (13.85) goes to the upper force at the
    band mid-point.

    Parameters
    ----------
    wind_speed_ms : array_like
        Wind speed at 10 m [m/s], >= 0.

    Returns
    -------
    ndarray of int
        Beaufort number 0–12.
    """
    u = finite("wind_speed_ms", wind_speed_ms, minimum=0.0)
    return np.searchsorted(BEAUFORT_WIND_UPPER_MS, u, side="right").astype(int)


def beaufort_from_hs(hs_m: ArrayLike) -> np.ndarray:
    """Beaufort number whose probable wave height is nearest to Hs.

    Used where the wind is not known (physics.md §5).  Ties go to the lower
    force.

    Parameters
    ----------
    hs_m : array_like
        Significant wave height [m], >= 0.

    Returns
    -------
    ndarray of int
        Beaufort number 0–12.
    """
    hs = finite("hs_m", hs_m, minimum=0.0)
    dist = np.abs(hs[..., None] - BEAUFORT_WAVE_HEIGHT_M)
    return np.argmin(dist, axis=-1).astype(int)


PM_T01_OVER_TP = 0.7718
PM_T02_OVER_TP = 0.7104
PM_TP_PER_SQRT_HS = 5.00


def pm_t01_from_tp(tp_s: ArrayLike) -> np.ndarray:
    """Pierson–Moskowitz mean period T01 = 0.7718 Tp [s] from peak period Tp [s]."""
    return PM_T01_OVER_TP * finite("tp_s", tp_s, minimum=0.0, strict=True)


def pm_t02_from_tp(tp_s: ArrayLike) -> np.ndarray:
    """Pierson–Moskowitz zero-crossing period T02 = 0.7104 Tp [s] from Tp [s]."""
    return PM_T02_OVER_TP * finite("tp_s", tp_s, minimum=0.0, strict=True)


def pm_tp_from_t01(t01_s: ArrayLike) -> np.ndarray:
    """Pierson–Moskowitz peak period Tp = T01 / 0.7718 [s] from T01 [s]."""
    return finite("t01_s", t01_s, minimum=0.0, strict=True) / PM_T01_OVER_TP


def pm_tp_from_t02(t02_s: ArrayLike) -> np.ndarray:
    """Pierson–Moskowitz peak period Tp = T02 / 0.7104 [s] from T02 [s]."""
    return finite("t02_s", t02_s, minimum=0.0, strict=True) / PM_T02_OVER_TP


def pm_tp_from_hs(hs_m: ArrayLike) -> np.ndarray:
    """Fully developed Pierson–Moskowitz peak period Tp = 5.00 √Hs [s] from Hs [m]."""
    return PM_TP_PER_SQRT_HS * np.sqrt(finite("hs_m", hs_m, minimum=0.0))


def pm_t01_from_hs(hs_m: ArrayLike) -> np.ndarray:
    """Fully developed Pierson–Moskowitz mean period T01 = 3.86 √Hs [s] from Hs [m]."""
    return pm_t01_from_tp(np.maximum(pm_tp_from_hs(hs_m), 1e-12))
