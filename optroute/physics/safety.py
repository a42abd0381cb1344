"""The four wave-encounter danger bands: conditions, margins and forbidden speeds.

For one sea state (significant height Hs, period T, direction) and one ship
heading, each band forbids a set of ship speeds.  This module gives that set
exactly, in closed form (:func:`forbidden_speed_intervals`), an independent
direct evaluation of the band conditions (:func:`is_speed_forbidden`), and
the signed distances to the bands the optimiser uses as constraints
(:func:`band_margins`).

Conventions
-----------
* Speeds V in knots [kn] (speed through the water), ``V >= 0``.
* α is the IMO angle of encounter (MSC.1/Circ.1228 §1): 0° head sea, 90°
  sea from starboard, 180° following sea; α = wave_from − heading (mod 360),
  see :func:`optroute.physics.seaway.relative_wave_angle_deg`.
* s = −cos α = cos(180° − α) = cos χ, with χ the Boeing patent's angle
  between the ship's heading and the wave **propagation** direction.
  u = V s [kn] is the ship's velocity component along the propagation
  direction: u > 0 running with the waves, u < 0 into them.
* c = g T / 2π is the deep-water phase speed and c_g = c / 2 the group
  speed [kn] (:mod:`optroute.physics.seaway`).
* T_E = T c_E / |c_E − u| is the encounter period [s]
  (:func:`optroute.physics.seaway.encounter_period_s`); c_E = k T with k = g/2π =
  3.0339 kn/s (``period_form="exact"``) or IMO's rounded 3 kn/s
  (``period_form="imo"``).  When the ship overtakes the waves (u > c_E)
  T_E is the period of overtaking; at u = c_E it is infinite.
* Bands are **closed** sets, as the patent's ``0.8 <= ratio <= 1.2``: a
  speed on a band's edge is forbidden.

Rule sets
---------
``"boeing"`` (default) — Boeing EP 2145155 (ES 2 721 598), applied where
Hs >= 0.04 L (0.02 L is the patent's alternative), each band ±20 %:

================  =====================  ====================
band              ratio r                forbidden
================  =====================  ====================
synchronous_roll  T_E / T_R              [1 − m, 1 + m]
parametric_roll   T_E / T_R              [0.5 (1 − m), 0.5 (1 + m)]
surf_riding       V cos χ / c            [1 − m, 1 + m]
high_wave_attack  V cos χ / c_g          [1 − m, 1 + m]
================  =====================  ====================

with m = :attr:`BandRules.margin` (0.2 gives the patent's [0.8, 1.2] and
[0.4, 0.6]).  The phase and group speeds of the two speed-ratio bands are
always the exact deep-water ones; ``period_form`` only changes T_E.

``"imo"`` — IMO MSC.1/Circ.1228 (2007), *Revised guidance to the master
for avoiding dangerous situations in adverse weather and sea conditions*:

* surf_riding (§4.2.1): for 135° < α < 225°, V >= 1.8 √L / cos(180° − α)
  [kn, L in m] is forbidden.  r = V cos(180° − α) / (1.8 √L), band
  [1, ∞).  IMO writes "V >"; the limit speed itself is included here so
  that every band is closed (it changes a single speed).
* high_wave_attack (§4.2.2): where the wavelength λ > 0.8 L, the zone
  1.8 T <= T_E <= 3.0 T is forbidden (IMO Fig. 3, "T_E ≈ 2 T").
  T_E here is IMO's *signed* Fig. 1 formula T_E = T c_E / (c_E − u),
  negative when the ship overtakes the waves, so r = c_E / (c_E − u) and
  only speeds slower than the waves can be in the zone, i.e.
  u ∈ [c_E (1 − 1/1.8), c_E (1 − 1/3)] = [1.333 T, 2.0 T] kn with IMO's
  c_E = 3 T: the ship travels with a wave group at about the group
  velocity.  (The |T_E| of the roll bands would re-enter [1.8 T, 3 T] when
  overtaking at 1.33–1.56 c, a speed at which the ship does *not* ride with
  a wave group; it is left out on purpose.)
* synchronous_roll / parametric_roll (§4.3): IMO says "avoid T_E ≈ T_R"
  and "T_E ≈ T_R / 2" without a tolerance; the same ±``margin`` bands as
  the Boeing rule set are used.  (IMO also names parametric roll at
  T_E ≈ T_R; that zone is the synchronous_roll band here.)

Applicability
-------------
Every band, in both rule sets, applies only where
Hs >= ``hs_threshold_fraction`` · L (the patent's condition; IMO §4.2.2
states Hs > 0.04 L for the high-wave attack only, and gives no height
condition for the others — applying one threshold to every band keeps
"calm sea, no band" true for either rule set).  Below it no speed is
forbidden.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError, SeaStateError, ShipSpecError
from optroute.physics import seaway
from optroute.physics.names import BANDS, PERIOD_FORMS, RULE_SETS

IMO_SURF_RIDING_KN_PER_SQRT_M = 1.8
"""IMO MSC.1/Circ.1228 §4.2.1: surf-riding above V cos(180° − α) = 1.8 √L [kn, L in m]."""

IMO_SURF_RIDING_SECTOR_DEG = (135.0, 225.0)
"""IMO MSC.1/Circ.1228 §4.2.1: the open α sector (following/quartering seas) where surf-riding applies [deg]."""

IMO_HIGH_WAVE_TE_OVER_T = (1.8, 3.0)
"""IMO MSC.1/Circ.1228 §4.2.2 / Fig. 3: the successive high-wave attack zone of T_E / T."""

IMO_HIGH_WAVE_MIN_WAVELENGTH_FRACTION = 0.8
"""IMO MSC.1/Circ.1228 §4.2.2: the high-wave attack zone applies where λ > 0.8 L."""

_PERIOD_RATIO_CENTRE = {"synchronous_roll": 1.0, "parametric_roll": 0.5}
_BEAM_SEA_EPS = 1e-12  # |cos α| below this counts as exactly beam seas (cos 90° is 6e-17 in floats)


def _g_over_2pi_kn_s(period_form: str) -> float:
    """k = g/2π [kn/s] used in T_E: exact 3.0339 or IMO's rounded 3 (MSC.1/Circ.1228 Fig. 1)."""
    if period_form == "imo":
        return seaway.IMO_G_OVER_2PI_KN_S
    return float(units.ms_to_kn(seaway.G_MS2 / (2.0 * math.pi)))


# --------------------------------------------------------------------------- rules
@dataclass(frozen=True)
class BandRules:
    """Which danger bands apply, and how wide they are.

    Parameters
    ----------
    rule_set : {"boeing", "imo"}
        ``"boeing"``: the four ratio bands of EP 2145155; ``"imo"``: the
        surf-riding speed limit and high-wave attack zone of IMO
        MSC.1/Circ.1228 plus the roll bands (see the module docstring).
    hs_threshold_fraction : float
        Bands apply where Hs >= fraction · L [-], 0 <= fraction <= 1.
        0.04 is the patent's (and IMO's) value, 0.02 the patent's
        alternative; 0 makes every band apply in any sea.
    margin : float
        Relative half-width m of the ratio bands [-], 0 < m < 1: the
        synchronous-roll band is [1 − m, 1 + m] of T_R, the parametric-roll
        band [0.5 (1 − m), 0.5 (1 + m)] of T_R.  0.2 is the patent's ±20 %.
        In the ``"imo"`` rule set it sets only the roll bands.
    synchronous_roll, parametric_roll, surf_riding, high_wave_attack : bool
        Whether each band is enforced.
    period_form : {"exact", "imo"}
        g/2π in the encounter period: exact 3.0339 kn/s or IMO's 3 kn/s.

    Raises
    ------
    ConfigError
        Naming the field, the value and the allowed range.
    """

    rule_set: str = "boeing"
    hs_threshold_fraction: float = 0.04
    margin: float = 0.2
    synchronous_roll: bool = True
    parametric_roll: bool = True
    surf_riding: bool = True
    high_wave_attack: bool = True
    period_form: str = "exact"

    def __post_init__(self) -> None:
        if self.rule_set not in RULE_SETS:
            raise ConfigError(f"BandRules.rule_set={self.rule_set!r} is not known; use one of {list(RULE_SETS)}")
        if self.period_form not in PERIOD_FORMS:
            raise ConfigError(
                f"BandRules.period_form={self.period_form!r} is not known; use one of {list(PERIOD_FORMS)}"
            )
        object.__setattr__(
            self,
            "hs_threshold_fraction",
            self._number("hs_threshold_fraction", 0.0, 1.0, "0 <= hs_threshold_fraction <= 1 (0.04 or 0.02)"),
        )
        margin = self._number("margin", 0.0, 1.0, "0 < margin < 1 (0.2 is the patent's ±20 %)")
        if not 0.0 < margin < 1.0:
            raise ConfigError(
                f"BandRules.margin={margin!r} is outside the allowed range 0 < margin < 1 (0.2 is the patent's ±20 %)"
            )
        object.__setattr__(self, "margin", margin)
        for band in BANDS:
            value = getattr(self, band)
            if not isinstance(value, bool | np.bool_):
                raise ConfigError(f"BandRules.{band}={value!r} must be True or False")
            object.__setattr__(self, band, bool(value))

    def _number(self, name: str, lo: float, hi: float, allowed: str) -> float:
        value = getattr(self, name)
        if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
            raise ConfigError(f"BandRules.{name}={value!r} is not a number; allowed range {allowed}")
        value = float(value)
        if not (math.isfinite(value) and lo <= value <= hi):
            raise ConfigError(f"BandRules.{name}={value!r} is outside the allowed range {allowed}")
        return value

    @property
    def enabled_bands(self) -> tuple[str, ...]:
        """The enforced bands, in :data:`BANDS` order."""
        return tuple(b for b in BANDS if getattr(self, b))

    def ratio_band(self, band: str) -> tuple[float, float]:
        """Forbidden closed range [lo, hi] of ``band``'s ratio r (see :func:`band_margins`) [-]."""
        _check_band(band)
        m = self.margin
        if band in _PERIOD_RATIO_CENTRE:
            centre = _PERIOD_RATIO_CENTRE[band]
            return centre * (1.0 - m), centre * (1.0 + m)
        if self.rule_set == "imo":
            if band == "surf_riding":
                return 1.0, math.inf
            return IMO_HIGH_WAVE_TE_OVER_T
        return 1.0 - m, 1.0 + m


DEFAULT_RULES = BandRules()
"""Boeing EP 2145155 bands, Hs >= 0.04 L, ±20 %, exact encounter period."""


def _check_band(band: str) -> None:
    if band not in BANDS:
        raise ConfigError(f"band={band!r} is not known; use one of {list(BANDS)}")


def _check_rules(rules: Any) -> BandRules:
    if not isinstance(rules, BandRules):
        raise ConfigError(f"rules={rules!r} is not a BandRules; pass optroute.physics.safety.BandRules(...)")
    return rules


def _ship_particulars(ship: Any) -> tuple[float, float]:
    """(L [m], T_R [s]) of a ship-like object, checked finite and > 0."""
    try:
        length, roll = ship.length_m, ship.roll_period_s
    except AttributeError as exc:
        raise ShipSpecError(
            f"ship={ship!r} lacks length_m or roll_period_s; pass an optroute.Ship (e.g. Ship.preset(...))"
        ) from exc
    length = float(finite("ship.length_m", length, minimum=0.0, strict=True, error=ShipSpecError))
    roll = float(finite("ship.roll_period_s", roll, minimum=0.0, strict=True, error=ShipSpecError))
    return length, roll


def _scalar(name: str, value: ArrayLike, **kw: Any) -> float:
    arr = finite(name, value, **kw)
    if arr.ndim != 0:
        raise SeaStateError(f"{name} must be a single number here, got an array of shape {arr.shape}")
    return float(arr)


def _along_factor(alpha_deg: ArrayLike) -> np.ndarray:
    """s = −cos α [-], set to exactly 0 in beam seas (|cos α| < 1e-12)."""
    s = -np.cos(np.radians(np.asarray(alpha_deg, dtype=float)))
    return np.where(np.abs(s) < _BEAM_SEA_EPS, 0.0, s)


# --------------------------------------------------------------------------- intervals
@dataclass(frozen=True)
class ForbiddenInterval:
    """A closed interval of forbidden ship speeds [lo_kn, hi_kn] and its band.

    Parameters
    ----------
    lo_kn, hi_kn : float
        Interval ends [kn], 0 <= lo_kn <= hi_kn; ``hi_kn`` may be ``inf``.
    band : str
        One of :data:`BANDS`.
    """

    lo_kn: float
    hi_kn: float
    band: str

    def __post_init__(self) -> None:
        _check_band(self.band)
        lo, hi = float(self.lo_kn), float(self.hi_kn)
        if not (math.isfinite(lo) and lo >= 0.0 and not math.isnan(hi) and hi >= lo):
            raise ConfigError(f"ForbiddenInterval needs 0 <= lo_kn <= hi_kn, got lo_kn={lo!r}, hi_kn={hi!r}")
        object.__setattr__(self, "lo_kn", lo)
        object.__setattr__(self, "hi_kn", hi)

    def contains(self, speed_kn: ArrayLike) -> np.ndarray:
        """Whether each speed [kn] lies in the closed interval."""
        v = np.asarray(speed_kn, dtype=float)
        return (v >= self.lo_kn) & (v <= self.hi_kn)


def _u_intervals(
    band: str, rules: BandRules, *, length_m: float, roll_s: float, period_s: float, alpha_deg: float
) -> list[tuple[float, float]]:
    """Forbidden closed intervals of u = V s [kn] for one band (before mapping to V).

    Derivation (c_E = k T, d = |c_E − u|, T_E = T c_E / d):

    * T_E / T_R ∈ [a, b]  ⟺  d ∈ [T c_E / (b T_R), T c_E / (a T_R)] = [d_lo, d_hi]
      ⟺  u ∈ [c_E − d_hi, c_E − d_lo] ∪ [c_E + d_lo, c_E + d_hi]
      (the second piece is the ship overtaking the waves; d = 0, T_E = ∞,
      is never in a band since d_lo > 0);
    * u / c ∈ [a, b]  ⟺  u ∈ [a c, b c]; likewise with c_g;
    * IMO surf-riding: u >= 1.8 √L, only for 135° < α < 225°;
    * IMO high-wave attack: c_E / (c_E − u) ∈ [1.8, 3.0]  ⟺
      u ∈ [c_E (1 − 1/1.8), c_E (1 − 1/3)], only where λ > 0.8 L.
    """
    lo, hi = rules.ratio_band(band)
    if band in _PERIOD_RATIO_CENTRE:
        c_e = _g_over_2pi_kn_s(rules.period_form) * period_s
        d_lo = period_s * c_e / (hi * roll_s)
        d_hi = period_s * c_e / (lo * roll_s)
        return [(c_e - d_hi, c_e - d_lo), (c_e + d_lo, c_e + d_hi)]
    if rules.rule_set == "boeing":
        c = float(units.ms_to_kn(seaway.phase_speed_ms(period_s)))
        ref = c if band == "surf_riding" else 0.5 * c
        return [(lo * ref, hi * ref)]
    if band == "surf_riding":
        a_lo, a_hi = IMO_SURF_RIDING_SECTOR_DEG
        if not a_lo < alpha_deg < a_hi:
            return []
        return [(IMO_SURF_RIDING_KN_PER_SQRT_M * math.sqrt(length_m), math.inf)]
    if not float(seaway.wavelength_m(period_s)) > IMO_HIGH_WAVE_MIN_WAVELENGTH_FRACTION * length_m:
        return []
    c_e = _g_over_2pi_kn_s(rules.period_form) * period_s
    return [(c_e * (1.0 - 1.0 / lo), c_e * (1.0 - 1.0 / hi))]


def _u_to_speed(u_lo: float, u_hi: float, s: float) -> tuple[float, float] | None:
    """Map a closed u-interval to the closed interval of speeds V >= 0 with V s in it (None if empty)."""
    if s == 0.0:
        return (0.0, math.inf) if u_lo <= 0.0 <= u_hi else None
    lo, hi = (u_lo / s, u_hi / s) if s > 0.0 else (u_hi / s, u_lo / s)
    if hi < 0.0:
        return None
    return max(lo, 0.0), hi


def forbidden_speed_intervals(
    ship: Any,
    *,
    hs_m: float,
    period_s: float,
    wave_from_deg: float,
    heading_deg: float,
    rules: BandRules = DEFAULT_RULES,
    max_speed_kn: float | None = None,
) -> tuple[ForbiddenInterval, ...]:
    """The exact set of forbidden speeds for one heading in one sea state, in closed form.

    Every band condition is a condition on u = V s, the ship's velocity
    along the wave propagation direction (s = −cos α), and inverts to one
    or two closed u-intervals (see :func:`_u_intervals`); each maps to
    V = u / s, with the ends swapped when s < 0 (head/bow seas) and cut at
    V = 0.  In beam seas (s = 0) u = 0 and T_E = T at every speed, so a
    band either forbids every speed, [0, inf), or none.

    Parameters
    ----------
    ship : Ship
        Needs ``length_m`` (L between perpendiculars [m]) and
        ``roll_period_s`` (natural roll period T_R [s]).
    hs_m : float
        Significant wave height [m], >= 0.
    period_s : float
        Wave period T [s], > 0 (the peak or mean period the forecast gives).
    wave_from_deg : float
        Direction the waves come from [deg true].
    heading_deg : float
        Ship heading, the direction it goes to [deg true].
    rules : BandRules
        Rule set, threshold, margin, enabled bands.
    max_speed_kn : float, optional
        Clip intervals to [0, max_speed_kn] [kn] and drop those above it;
        by default intervals are unbounded (``hi_kn`` may be ``inf``).

    Returns
    -------
    tuple of ForbiddenInterval
        Closed intervals sorted by (lo_kn, hi_kn, band order); intervals of
        different bands may overlap (see :func:`merged_intervals`).  Empty
        when Hs < ``rules.hs_threshold_fraction`` · L.

    Raises
    ------
    SeaStateError
        NaN, infinite or negative Hs, non-positive period or max speed below 0.
    ShipSpecError
        The ship has no usable length or roll period.
    """
    rules = _check_rules(rules)
    length, roll = _ship_particulars(ship)
    hs = _scalar("hs_m", hs_m, minimum=0.0, fix="give Hs in metres, 0 or more")
    period = _scalar("period_s", period_s, minimum=0.0, strict=True, fix="give the wave period in seconds, more than 0")
    alpha = float(
        seaway.relative_wave_angle_deg(_scalar("heading_deg", heading_deg), _scalar("wave_from_deg", wave_from_deg))
    )
    vmax = math.inf if max_speed_kn is None else _scalar("max_speed_kn", max_speed_kn, minimum=0.0)
    if hs < rules.hs_threshold_fraction * length:
        return ()
    s = float(_along_factor(alpha))
    out: list[ForbiddenInterval] = []
    for band in rules.enabled_bands:
        for u_lo, u_hi in _u_intervals(band, rules, length_m=length, roll_s=roll, period_s=period, alpha_deg=alpha):
            v = _u_to_speed(u_lo, u_hi, s)
            if v is None or v[0] > vmax:
                continue
            out.append(ForbiddenInterval(v[0], min(v[1], vmax), band))
    out.sort(key=lambda iv: (iv.lo_kn, iv.hi_kn, BANDS.index(iv.band)))
    return tuple(out)


def merged_intervals(intervals: Iterable[ForbiddenInterval | tuple[float, float]]) -> tuple[tuple[float, float], ...]:
    """Union of closed speed intervals, as disjoint sorted (lo_kn, hi_kn) pairs [kn].

    Intervals that overlap or touch (next lo <= current hi) are joined.
    """
    pairs = sorted(
        (iv.lo_kn, iv.hi_kn) if isinstance(iv, ForbiddenInterval) else (float(iv[0]), float(iv[1])) for iv in intervals
    )
    out: list[list[float]] = []
    for lo, hi in pairs:
        if out and lo <= out[-1][1]:
            out[-1][1] = max(out[-1][1], hi)
        else:
            out.append([lo, hi])
    return tuple((lo, hi) for lo, hi in out)


def safe_speed_ranges(
    intervals: Iterable[ForbiddenInterval | tuple[float, float]], max_speed_kn: float
) -> tuple[tuple[float, float], ...]:
    """The speeds in [0, max_speed_kn] outside every forbidden interval, as (lo_kn, hi_kn) pairs.

    The forbidden intervals are closed, so a returned range is *open* at an
    end it shares with a forbidden interval (that speed itself is
    forbidden) and closed at 0 and at ``max_speed_kn`` otherwise.

    Parameters
    ----------
    intervals : iterable of ForbiddenInterval or (lo, hi)
        Forbidden speeds [kn].
    max_speed_kn : float
        Top of the speed range considered [kn], >= 0.
    """
    vmax = _scalar("max_speed_kn", max_speed_kn, minimum=0.0)
    out: list[tuple[float, float]] = []
    start = 0.0
    start_free = True  # whether `start` itself is a safe speed
    for lo, hi in merged_intervals(intervals):
        if lo > vmax:
            break
        if lo > start:
            out.append((start, lo))
        start, start_free = hi, False
        if hi >= vmax:
            return tuple(out)
    if start < vmax or (start == vmax and start_free):
        out.append((start, vmax))
    return tuple(out)


def max_safe_speed_kn(
    desired_kn: float,
    intervals: Iterable[ForbiddenInterval | tuple[float, float]],
    *,
    clearance_kn: float = 0.0,
) -> float | None:
    """The highest speed <= ``desired_kn`` outside every forbidden interval.

    Boeing EP 2145155 (Fig. 22): start at the desired speed and reduce it
    until every band condition holds.  Because the intervals are closed, a
    desired speed inside [lo, hi] has no highest safe speed below it, only
    a supremum lo; the speed returned is ``lo − clearance_kn`` or, with no
    clearance, the largest float below lo.

    Parameters
    ----------
    desired_kn : float
        Speed wanted [kn], >= 0.
    intervals : iterable of ForbiddenInterval or (lo, hi)
        Forbidden speeds [kn].
    clearance_kn : float
        How far below a band's lower edge to settle when the speed has to
        be reduced [kn], >= 0.

    Returns
    -------
    float or None
        The speed [kn], or ``None`` when no speed > 0 is left: a ship
        stopped in the water makes no progress, so a route search should
        treat the cell as impassable rather than divide by a zero speed.
    """
    v = _scalar("desired_kn", desired_kn, minimum=0.0)
    gap = _scalar("clearance_kn", clearance_kn, minimum=0.0)
    for lo, hi in reversed(merged_intervals(intervals)):
        if lo <= v <= hi:
            v = lo - gap if gap > 0.0 else math.nextafter(lo, -math.inf)
    return v if v > 0.0 else None


# --------------------------------------------------------------------------- direct evaluation and margins
def _band_ratios(
    ship: Any,
    rules: BandRules,
    speed_kn: ArrayLike,
    hs_m: ArrayLike,
    period_s: ArrayLike,
    wave_from_deg: ArrayLike,
    heading_deg: ArrayLike,
) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], np.ndarray, np.ndarray, np.ndarray]:
    """Each band's ratio r and where the band applies, from the seaway relations directly.

    Returns ``({band: (ratio, applies)}, s, u, c_e)`` broadcast to one shape.
    """
    rules = _check_rules(rules)
    length, roll = _ship_particulars(ship)
    v = finite("speed_kn", speed_kn, minimum=0.0, fix="give speeds through the water in knots, 0 or more")
    hs = finite("hs_m", hs_m, minimum=0.0, fix="give Hs in metres, 0 or more")
    t = finite("period_s", period_s, minimum=0.0, strict=True, fix="give the wave period in seconds, more than 0")
    alpha = seaway.relative_wave_angle_deg(heading_deg, wave_from_deg)
    v, hs, t, alpha = np.broadcast_arrays(v, hs, t, alpha)
    in_sea = hs >= rules.hs_threshold_fraction * length
    u = seaway.speed_along_waves_kn(v, alpha)
    t_e = seaway.encounter_period_s(t, v, alpha, form=rules.period_form)
    c_e = _g_over_2pi_kn_s(rules.period_form) * t
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for band in BANDS:
        applies = in_sea & getattr(rules, band)
        if band in _PERIOD_RATIO_CENTRE:
            ratio = t_e / roll
        elif rules.rule_set == "boeing":
            c = units.ms_to_kn(seaway.phase_speed_ms(t))
            ratio = u / (c if band == "surf_riding" else 0.5 * c)
        elif band == "surf_riding":
            a_lo, a_hi = IMO_SURF_RIDING_SECTOR_DEG
            applies = applies & (alpha > a_lo) & (alpha < a_hi)
            ratio = u / (IMO_SURF_RIDING_KN_PER_SQRT_M * math.sqrt(length))
        else:
            applies = applies & (seaway.wavelength_m(t) > IMO_HIGH_WAVE_MIN_WAVELENGTH_FRACTION * length)
            # IMO's signed T_E / T = c_E / (c_E − u): negative when overtaking, +inf riding the crest.
            ratio = np.where(c_e - u > 0.0, t_e / t, -t_e / t)
        out[band] = (np.asarray(ratio, dtype=float), np.asarray(applies, dtype=bool))
    return out, _along_factor(alpha), u, c_e


def is_speed_forbidden(
    ship: Any,
    *,
    speed_kn: ArrayLike,
    hs_m: ArrayLike,
    period_s: ArrayLike,
    wave_from_deg: ArrayLike,
    heading_deg: ArrayLike,
    rules: BandRules = DEFAULT_RULES,
    band: str | None = None,
) -> np.ndarray:
    """Whether each speed lies in a danger band, by evaluating the band conditions directly.

    This computes T_E, V cos χ, c, c_g from :mod:`optroute.physics.seaway` and tests
    ``lo <= r <= hi`` for each band — no inversion — so it is the
    independent check of :func:`forbidden_speed_intervals`.

    Parameters
    ----------
    ship : Ship
        Needs ``length_m`` [m] and ``roll_period_s`` [s].
    speed_kn : array_like
        Ship speeds [kn], >= 0.
    hs_m, period_s, wave_from_deg, heading_deg : array_like
        Sea state and heading as in :func:`forbidden_speed_intervals`;
        everything broadcasts together.
    rules : BandRules
        Rule set, threshold, margin, enabled bands.
    band : str, optional
        Test only this band (it still has to be enabled in ``rules``); by
        default any enabled band.

    Returns
    -------
    ndarray of bool
        True where the speed is forbidden.
    """
    if band is not None:
        _check_band(band)
    ratios, _, _, _ = _band_ratios(ship, rules, speed_kn, hs_m, period_s, wave_from_deg, heading_deg)
    hit = np.zeros(next(iter(ratios.values()))[0].shape, dtype=bool)
    for name, (r, applies) in ratios.items():
        if band is not None and name != band:
            continue
        lo, hi = rules.ratio_band(name)
        hit |= applies & (r >= lo) & (r <= hi)
    return hit


@dataclass(frozen=True)
class BandMargin:
    """Signed distance of a speed to one band, in the band's ratio units.

    Attributes
    ----------
    margin : ndarray
        ``max(lo − r, r − hi)`` [-]: > 0 outside the band (safe), <= 0 inside
        (0 on an edge, which is forbidden), ``+inf`` where the band does not
        apply (Hs below threshold, band disabled, outside its α sector or
        wavelength condition).
    side : ndarray of int8
        Where the speed lies relative to the band's forbidden speed
        interval on the same monotone branch of r(V): −1 below it (the band
        lies at higher speeds), +1 above it, 0 where the band does not apply
        or r does not depend on V (beam seas).  Inside the band it names the
        nearer edge.
    ratio : ndarray
        The band's ratio r [-]: T_E / T_R (roll bands), V cos χ / c or
        V cos χ / c_g (Boeing), V cos(180° − α) / (1.8 √L) or signed
        T_E / T (IMO).
    lo, hi : float
        The forbidden closed range of r [-] (``hi`` may be ``inf``).
    """

    margin: np.ndarray
    side: np.ndarray
    ratio: np.ndarray
    lo: float
    hi: float


def band_margins(
    ship: Any,
    *,
    speed_kn: ArrayLike,
    hs_m: ArrayLike,
    period_s: ArrayLike,
    wave_from_deg: ArrayLike,
    heading_deg: ArrayLike,
    rules: BandRules = DEFAULT_RULES,
) -> dict[str, BandMargin]:
    """Signed distance to every band, in ratio units, vectorised over all inputs.

    The margin of a band [lo, hi] on its ratio r is ``max(lo − r, r − hi)``:
    the constraint ``margin >= 0`` with the disjunction
    ``r <= lo`` (side chosen below) or ``r >= hi`` (above) is what the
    optimiser enforces.  r is monotone in V on each branch (u < c_E and
    u > c_E for the roll bands; everywhere for the others); ``side``
    translates the ratio side into the speed side.

    Parameters
    ----------
    ship : Ship
        Needs ``length_m`` [m] and ``roll_period_s`` [s].
    speed_kn : array_like
        Ship speed through water [kn], >= 0.
    hs_m : array_like
        Significant wave height [m], >= 0.
    period_s : array_like
        Wave period [s], > 0.
    wave_from_deg : array_like
        Direction the waves come from [deg true].
    heading_deg : array_like
        Ship heading [deg true].
    rules : BandRules
        Rule set, threshold, margin, enabled bands.

    Returns
    -------
    dict of str to BandMargin
        One entry per name in :data:`BANDS` (disabled bands have ``+inf``
        margins), each array broadcast to the inputs' common shape.
    """
    ratios, s, u, c_e = _band_ratios(ship, rules, speed_kn, hs_m, period_s, wave_from_deg, heading_deg)
    sign_s = np.sign(s)
    out: dict[str, BandMargin] = {}
    for band, (r, applies) in ratios.items():
        lo, hi = rules.ratio_band(band)
        with np.errstate(invalid="ignore"):
            dist = np.maximum(lo - r, r - hi)
        margin = np.where(applies, dist, np.inf)
        ratio_side = np.where(r < 0.5 * (lo + hi), -1, 1)
        if band in _PERIOD_RATIO_CENTRE:
            # T_E = T c_E / |c_E − u| grows with u below the wave speed and falls above it.
            slope = sign_s * np.where(u < c_e, 1.0, -1.0)
        else:
            slope = sign_s
        side = np.where(applies, ratio_side * slope, 0).astype(np.int8)
        out[band] = BandMargin(margin=margin, side=side, ratio=r, lo=lo, hi=hi)
    return out
