"""Involuntary speed loss in weather (Kwon 2008) and the IMO EEDI weather factor.

Two groups of pure, vectorised functions (every numeric argument may be a
scalar or an array; arrays broadcast together and the results are numpy
float arrays of the broadcast shape, 0-d arrays or numpy scalars for scalar
input):

* **Kwon's method** — the percentage by which wind and waves slow a ship
  whose engine keeps its calm-water setting: ΔV/V1 [%] = C_β · C_U · C_Form,
  V2 = V1 (1 − ΔV/V1 / 100).  :func:`calm_speed_for_weather_kn` inverts it:
  the calm-water speed V1 whose speed in weather is a given V2, so that the
  power needed for a speed through the water V2 in weather is the calm-water
  power at V1.
* **IMO f_w** — the standard weather factor of the EEDI (MEPC.1/Circ.796),
  in :mod:`optroute.physics.imo_fw` and re-exported here.
* Currents (the velocity triangle) live in :mod:`optroute.physics.currents`.

Conventions (``shared/design.md``, ``shared/physics.md`` §1)
--------------------------------------------------------------
* Speeds in knots [kn] at the surface; Froude number Fn = V / √(g L) with V in
  m/s, L the length between perpendiculars [m], g = :data:`optroute.physics.seaway.G_MS2`.
* Weather angle (Kwon): the angle of the weather (waves and wind) from the
  bow, 0° = head, 180° = following; this is the IMO angle of encounter α of
  :func:`optroute.physics.seaway.relative_wave_angle_deg`.  Any finite angle is
  accepted: it is wrapped into [0, 360) and folded into [0, 180] by the
  port/starboard symmetry of the method (α and 360° − α give the same loss).
* Headings and courses: degrees true, the direction the ship goes **to**.
* Currents: (u, v) [m/s], east and north components of the vector the water
  flows **to**.

Errors
------
Speeds, Froude numbers, Beaufort numbers and angles that are NaN, infinite,
negative or out of range raise :class:`~optroute.errors.SeaStateError`;
ship particulars (length, volume, capacity) raise
:class:`~optroute.errors.ShipSpecError`; a block coefficient outside Kwon's
tables, or an unknown ship type or loading, raises
:class:`~optroute.errors.ConfigError`.  Every message names the value.  No
input is clipped; the only clips are the two the method defines (negative
C_β is 0, and the loss is never below 0 %).

Sources
-------
* Kwon, Y. J. (2008), "Speed loss due to added resistance in wind and
  waves", *The Naval Architect*, March 2008, pp. 14–16; tables as printed in
  ``shared/physics.md`` §6 (with the sign flag on the Cb 0.85 rows).
* IMO MEPC.1/Circ.796 (2012), *Interim guidelines for the calculation of the
  coefficient f_w for decrease in ship speed in a representative sea
  condition for trial use*, Part 2, Table 1; Capacity as defined by the EEDI
  calculation guidelines (MEPC.212(63), now MEPC.364(79)) — ``physics.md`` §7.
* Velocity triangle: any text on navigation, e.g. Bowditch, *The American
  Practical Navigator* (NGA Pub. 9), ch. 7 "Dead reckoning", current sailing.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from optroute import units
from optroute._checks import finite
from optroute._numba import jit
from optroute.errors import ConfigError, SeaStateError
from optroute.physics._inputs import (
    OnUnreachable,
    ShipType,
    at_most,
    first_true,
    known_ship_type,
    on_unreachable_mode,
    particular,
    speed_kn,
)
from optroute.physics.imo_fw import imo_fw, imo_fw_capacity
from optroute.physics.seaway import G_MS2

__all__ = [
    "BLOCK_COEFFICIENT_RANGE",
    "MAX_CALM_FROUDE",
    "calm_speed_for_weather_kn",
    "calm_speed_point",
    "imo_fw",
    "imo_fw_capacity",
    "KWON_SECTOR_EDGES_DEG",
    "kwon_cu_coefficients",
    "kwon_direction_coefficient",
    "kwon_form_coefficient",
    "kwon_speed_coefficient",
    "kwon_speed_loss_pct",
    "kwon_weather_speed_increasing",
    "speed_in_weather_kn",
]

Loading = Literal["normal", "loaded", "ballast"]

LOADINGS: tuple[str, ...] = ("normal", "loaded", "ballast")

BLOCK_COEFFICIENT_RANGE: tuple[float, float] = (0.55, 0.85)
"""The block coefficients Kwon's speed-coefficient table covers [-]."""

KWON_SECTOR_EDGES_DEG: tuple[float, float, float] = (30.0, 60.0, 150.0)
"""Edges of Kwon's (2008) direction sectors in the weather angle from the bow [deg]: head [0°, 30°], bow
(30°, 60°], beam (60°, 150°], following (150°, 180°] (:func:`kwon_direction_coefficient`); C_β is constant
inside each sector and steps at each edge."""

KWON_FROUDE_RANGE: tuple[float, float] = (0.05, 0.30)
"""Kwon's stated range of validity in Froude number [-]; outside it the
polynomials are extrapolated (no error), see :func:`kwon_speed_coefficient`."""

MAX_CALM_FROUDE = KWON_FROUDE_RANGE[1]
"""Default upper bound of the calm-water Froude number searched by
:func:`calm_speed_for_weather_kn` [-]: the top of Kwon's range of validity,
0.30.  Beyond it the C_U polynomials of the Cb 0.55–0.70 rows fall to zero
(near Fn 0.39, 0.37, 0.34, 0.33), so an extrapolated search would find
"no loss" — and so a reachable speed — in any storm."""

BEAUFORT_MAX = 12.0

# --------------------------------------------------------------------------
# Kwon (2008) speed coefficient C_U = a + b Fn + c Fn², by block coefficient.
# Rows below Cb 0.75 are printed for the "normal" condition only; from 0.75
# up there are separate "loaded or normal" and "ballast" rows.  A ship in
# ballast with Cb < 0.75 uses the normal rows (the table has nothing else).
#
# Flag (physics.md §6): one source prints c = −28.0 (loaded) and −31.8
# (ballast) for Cb 0.85.  With the minus sign C_U becomes negative at
# ordinary tanker Froude numbers (Fn ≈ 0.13–0.15), i.e. a speed *gain* in a
# storm, so the plus sign is the physical reading and is used here.
# --------------------------------------------------------------------------
_CB_GRID = np.array([0.55, 0.60, 0.65, 0.70, 0.75, 0.80, 0.85])
_NORMAL_ROWS = [(1.7, -1.4, -7.4), (2.2, -2.5, -9.7), (2.6, -3.7, -11.6), (3.1, -5.3, -12.4)]
_LOADED_ROWS = [(2.4, -10.6, -9.5), (2.6, -13.1, -15.1), (3.1, -18.7, +28.0)]
_BALLAST_ROWS = [(2.6, -12.5, -13.5), (3.0, -16.3, -21.6), (3.4, -20.9, +31.8)]
_KWON_CU_ROWS: dict[str, np.ndarray] = {
    "normal": np.array(_NORMAL_ROWS + _LOADED_ROWS),
    "ballast": np.array(_NORMAL_ROWS + _BALLAST_ROWS),
}


# ------------------------------------------------------------------ checks


def _loading(loading: str) -> str:
    if loading not in LOADINGS:
        raise ConfigError(f"loading={loading!r} is not known; use one of {', '.join(map(repr, LOADINGS))}")
    return "normal" if loading == "loaded" else loading


def _beaufort(beaufort: ArrayLike) -> np.ndarray:
    fix = "pass a Beaufort number in [0, 12] (optroute.physics.seaway.beaufort_from_wind or beaufort_from_hs)"
    bn = finite("beaufort", beaufort, minimum=0.0, fix=fix)
    at_most("beaufort", bn, BEAUFORT_MAX, SeaStateError, fix)
    return bn


def _block_coefficient(block_coefficient: ArrayLike) -> np.ndarray:
    lo, hi = BLOCK_COEFFICIENT_RANGE
    fix = (
        f"Kwon's speed coefficient is tabulated for Cb {lo}-{hi} only; "
        "for this ship supply a PerformanceModel fitted to its own speed-loss data"
    )
    cb = finite("block_coefficient", block_coefficient, minimum=lo, error=ConfigError, fix=fix)
    at_most("block_coefficient", cb, hi, ConfigError, fix)
    return cb


def _folded_angle(weather_angle_deg: ArrayLike) -> np.ndarray:
    a = units.wrap_360(finite("weather_angle_deg", weather_angle_deg, fix="pass an angle from the bow in degrees"))
    return np.where(a > 180.0, 360.0 - a, a)


def _froude(speed_kn: np.ndarray, length_m: np.ndarray) -> np.ndarray:
    return units.kn_to_ms(speed_kn) / np.sqrt(G_MS2 * length_m)


# ------------------------------------------------------------------ Kwon


def kwon_direction_coefficient(weather_angle_deg: ArrayLike, beaufort: ArrayLike) -> np.ndarray:
    """Kwon's direction reduction coefficient C_β.

    Kwon (2008) tabulates 2·C_β by sector (``physics.md`` §6)::

        head       0°–30°     2.0
        bow       30°–60°     1.7 − 0.03 (BN − 4)²
        beam      60°–150°    0.9 − 0.06 (BN − 6)²
        following 150°–180°   0.4 − 0.03 (BN − 8)²

    This function returns C_β, i.e. half the printed value, with negative
    values (bow sector at BN 12, beam sector far from BN 6, following sector
    at low BN) set to 0 as the method prescribes: weather never speeds the
    ship up.

    Sector boundaries belong to the sector nearer the bow: head is
    [0°, 30°], bow (30°, 60°], beam (60°, 150°], following (150°, 180°].
    At every boundary that sector has the larger coefficient for BN 0–12,
    so a weather angle exactly on a boundary gets the more conservative
    (larger) loss.

    Parameters
    ----------
    weather_angle_deg : array_like
        Angle of the weather from the bow [deg], 0 = head, 180 = following
        (the IMO angle of encounter α).  Wrapped into [0, 360) and folded
        into [0, 180] by symmetry (α and 360° − α are the same sector).
    beaufort : array_like
        Beaufort number BN [-], 0–12; non-integer values are accepted (the
        formulas are polynomials in BN).

    Returns
    -------
    ndarray
        C_β [-], in [0, 1].

    Raises
    ------
    SeaStateError
        A non-finite angle, or a Beaufort number that is not finite or lies outside 0–12.
    """
    a = _folded_angle(weather_angle_deg)
    bn = _beaufort(beaufort)
    a, bn = np.broadcast_arrays(a, bn)
    head, bow, beam = KWON_SECTOR_EDGES_DEG
    two_c = np.select(
        [a <= head, a <= bow, a <= beam],
        [np.full_like(bn, 2.0), 1.7 - 0.03 * (bn - 4.0) ** 2, 0.9 - 0.06 * (bn - 6.0) ** 2],
        default=0.4 - 0.03 * (bn - 8.0) ** 2,
    )
    return np.maximum(0.5 * two_c, 0.0)


def kwon_speed_coefficient(froude: ArrayLike, block_coefficient: ArrayLike, loading: Loading = "normal") -> np.ndarray:
    """Kwon's speed reduction coefficient C_U = a + b Fn + c Fn².

    The coefficients a, b, c come from Kwon's (2008) table, one row per
    block coefficient 0.55, 0.60, …, 0.85 (``physics.md`` §6).  Between two
    rows, C_U is interpolated linearly in Cb: C_U = (1 − t) C_U,i(Fn) +
    t C_U,i+1(Fn) with t = (Cb − Cb_i) / (Cb_i+1 − Cb_i) (equivalently, the
    coefficients a, b, c are interpolated).  Rows below Cb 0.75 exist for the
    normal condition only and are used for every loading; from Cb 0.75 the
    "loaded or normal" or the "ballast" rows are used, so a ship in ballast
    with 0.70 < Cb < 0.75 interpolates between the normal 0.70 row and the
    ballast 0.75 row.  The Cb 0.85 rows take c = +28.0 (loaded) and +31.8
    (ballast), the physical reading of a sign that sources disagree on
    (``physics.md`` §6 flag).

    Kwon states validity for Fn 0.05–0.30; outside it the polynomial is
    extrapolated without error, and C_U may be negative at high Fn (the loss
    function then floors the loss at 0).

    Parameters
    ----------
    froude : array_like
        Froude number Fn = V1 / √(g L) of the calm-water speed [-], >= 0.
    block_coefficient : array_like
        Block coefficient Cb [-], in [0.55, 0.85].
    loading : {"normal", "loaded", "ballast"}
        Loading condition; "loaded" is the same as "normal".

    Returns
    -------
    ndarray
        C_U [-] (not clipped).

    Raises
    ------
    ConfigError
        Cb outside [0.55, 0.85] or not finite (fit a PerformanceModel to that
        ship instead), or an unknown ``loading``.
    SeaStateError
        A Froude number that is not finite or is negative.
    """
    fn = finite("froude", froude, minimum=0.0, fix="pass V1 / sqrt(g L) of the calm-water speed, >= 0")
    a, b, c = _cu_coefficients(_block_coefficient(block_coefficient), _loading(loading))
    return a + b * fn + c * fn**2


def kwon_cu_coefficients(block_coefficient: ArrayLike, loading: Loading = "normal") -> tuple[np.ndarray, ...]:
    """Kwon's (2008) C_U coefficients (a, b, c) for a block coefficient, C_U = a + b Fn + c Fn².

    Interpolated linearly in Cb between the table's rows (see :func:`kwon_speed_coefficient`).

    Raises
    ------
    ConfigError
        Cb outside [0.55, 0.85] or an unknown ``loading``.
    """
    return _cu_coefficients(_block_coefficient(block_coefficient), _loading(loading))


def _cu_coefficients(cb: np.ndarray, loading: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """C_U's a, b, c for validated Cb, interpolated linearly in Cb between Kwon's rows.

    Interpolating the coefficients equals interpolating C_U itself, since C_U
    is linear in them.
    """
    rows = _KWON_CU_ROWS[loading]
    i = np.clip(np.searchsorted(_CB_GRID, cb, side="right") - 1, 0, len(_CB_GRID) - 2)
    t = ((cb - _CB_GRID[i]) / (_CB_GRID[i + 1] - _CB_GRID[i]))[..., None]
    abc = (1.0 - t) * rows[i] + t * rows[i + 1]
    return abc[..., 0], abc[..., 1], abc[..., 2]


def kwon_form_coefficient(
    beaufort: ArrayLike,
    volume_m3: ArrayLike,
    ship_type: ShipType = "container",
    loading: Loading = "normal",
) -> np.ndarray:
    """Kwon's ship form coefficient C_Form.

    Kwon (2008), ``physics.md`` §6, with ∇ the displacement volume [m³]::

        container ships (normal)           0.7 BN + BN^6.5 / (22 ∇^(2/3))
        all other ships, loaded or normal  0.5 BN + BN^6.5 / (2.7 ∇^(2/3))
        all other ships, ballast           0.7 BN + BN^6.5 / (2.7 ∇^(2/3))

    Kwon gives container ships one formula only, so ``ship_type="container"``
    uses it whatever the ``loading``; "bulk_carrier", "tanker" and
    "general_cargo" use the loaded/normal or the ballast formula.

    Parameters
    ----------
    beaufort : array_like
        Beaufort number BN [-], 0–12.
    volume_m3 : array_like
        Displacement volume ∇ [m³], > 0.
    ship_type : {"container", "bulk_carrier", "tanker", "general_cargo"}
        Ship type.
    loading : {"normal", "loaded", "ballast"}
        Loading condition; "loaded" is the same as "normal".

    Returns
    -------
    ndarray
        C_Form [-], >= 0.

    Raises
    ------
    SeaStateError
        A Beaufort number outside 0–12 or not finite.
    ShipSpecError
        A volume that is not finite or not positive.
    ConfigError
        An unknown ``ship_type`` or ``loading``.
    """
    kind = known_ship_type(ship_type)
    load = _loading(loading)
    bn = _beaufort(beaufort)
    vol = particular("volume_m3", volume_m3, "displacement volume in m^3")
    v23 = vol ** (2.0 / 3.0)
    if kind == "container":
        return 0.7 * bn + bn**6.5 / (22.0 * v23)
    linear = 0.7 if load == "ballast" else 0.5
    return linear * bn + bn**6.5 / (2.7 * v23)


def _loss_pct(
    calm_stw_kn: np.ndarray,
    length_m: np.ndarray,
    block_coefficient: np.ndarray,
    c_beta_form: np.ndarray,
    loading: str,
) -> np.ndarray:
    """Loss [%] for already validated inputs, C_β · C_Form precomputed."""
    fn = _froude(calm_stw_kn, length_m)
    a, b, c = _cu_coefficients(block_coefficient, _loading(loading))
    return np.maximum(c_beta_form * (a + b * fn + c * fn**2), 0.0)


def kwon_speed_loss_pct(
    calm_stw_kn: ArrayLike,
    length_m: ArrayLike,
    block_coefficient: ArrayLike,
    volume_m3: ArrayLike,
    beaufort: ArrayLike,
    weather_angle_deg: ArrayLike,
    *,
    ship_type: ShipType = "container",
    loading: Loading = "normal",
) -> np.ndarray:
    """Kwon's involuntary speed loss ΔV/V1 = C_β · C_U · C_Form [%].

    The percentage by which wind and waves of Beaufort number BN, coming at
    ``weather_angle_deg`` from the bow, reduce a ship's calm-water speed V1
    at the same engine setting (Kwon 2008; ``physics.md`` §6).  C_U is taken
    at Fn = V1 / √(g L), g = :data:`optroute.physics.seaway.G_MS2`.

    The loss is floored at 0 %: Kwon's method describes added resistance and
    never predicts a gain, but at Froude numbers above its range C_U can turn
    negative.  It is not capped at 100 %: a loss of 100 % or more means the
    method predicts no headway (see :func:`speed_in_weather_kn`).  Kwon's
    range of validity is Cb 0.55–0.85 (enforced) and Fn 0.05–0.30
    (extrapolated outside, without error).

    Parameters
    ----------
    calm_stw_kn : array_like
        Calm-water speed through the water V1 [kn], >= 0.
    length_m : array_like
        Length between perpendiculars L [m], > 0.
    block_coefficient : array_like
        Block coefficient Cb [-], 0.55–0.85.
    volume_m3 : array_like
        Displacement volume ∇ [m³], > 0.
    beaufort : array_like
        Beaufort number BN [-], 0–12.
    weather_angle_deg : array_like
        Weather angle from the bow [deg], 0 = head, 180 = following
        (folded by symmetry; see :func:`kwon_direction_coefficient`).
    ship_type : {"container", "bulk_carrier", "tanker", "general_cargo"}
        Selects the form coefficient (:func:`kwon_form_coefficient`).
    loading : {"normal", "loaded", "ballast"}
        Loading condition.

    Returns
    -------
    ndarray
        ΔV/V1 [%], >= 0.

    Raises
    ------
    SeaStateError, ShipSpecError, ConfigError
        See the module docstring; every message names the bad value.
    """
    v1 = speed_kn("calm_stw_kn", calm_stw_kn)
    length = particular("length_m", length_m, "length between perpendiculars in m")
    cb = _block_coefficient(block_coefficient)
    c_beta = kwon_direction_coefficient(weather_angle_deg, beaufort)
    c_form = kwon_form_coefficient(beaufort, volume_m3, ship_type, loading)
    return _loss_pct(v1, length, cb, c_beta * c_form, loading)


def speed_in_weather_kn(
    calm_stw_kn: ArrayLike,
    length_m: ArrayLike,
    block_coefficient: ArrayLike,
    volume_m3: ArrayLike,
    beaufort: ArrayLike,
    weather_angle_deg: ArrayLike,
    *,
    ship_type: ShipType = "container",
    loading: Loading = "normal",
    on_unreachable: OnUnreachable = "raise",
) -> np.ndarray:
    """Speed through the water in weather, V2 = V1 (1 − ΔV/V1 / 100) [kn].

    ΔV/V1 is :func:`kwon_speed_loss_pct` (Kwon 2008); the arguments are the
    same.

    Parameters
    ----------
    calm_stw_kn, length_m, block_coefficient, volume_m3, beaufort, weather_angle_deg, ship_type, loading
        As in :func:`kwon_speed_loss_pct`.
    on_unreachable : {"raise", "nan"}
        What to do where the loss exceeds 100 % (Kwon's method outside its
        range: no headway): raise :class:`SeaStateError` (default), or
        return NaN there so that a vectorised caller can mark the case.

    Returns
    -------
    ndarray
        V2 [kn], in [0, V1].

    Raises
    ------
    SeaStateError
        Where the loss exceeds 100 % (with ``on_unreachable="raise"``), and
        for the bad inputs of :func:`kwon_speed_loss_pct`.
    """
    mode = on_unreachable_mode(on_unreachable)
    v1 = speed_kn("calm_stw_kn", calm_stw_kn)
    loss = kwon_speed_loss_pct(
        v1, length_m, block_coefficient, volume_m3, beaufort, weather_angle_deg, ship_type=ship_type, loading=loading
    )
    v1, loss = np.broadcast_arrays(v1, loss)
    v2 = v1 * (1.0 - loss / 100.0)
    bad = loss > 100.0
    if bad.any():
        if mode == "nan":
            return np.where(bad, np.nan, v2)
        idx, where = first_true(bad)
        raise SeaStateError(
            f"Kwon's speed loss is {loss[idx]:.1f} % (> 100 %) for calm_stw_kn={float(v1[idx])!r}{where}: the method "
            "predicts no headway; avoid this sea state or heading, or pass on_unreachable='nan' to mark such cases"
        )
    return v2


def calm_speed_for_weather_kn(
    stw_kn: ArrayLike,
    length_m: ArrayLike,
    block_coefficient: ArrayLike,
    volume_m3: ArrayLike,
    beaufort: ArrayLike,
    weather_angle_deg: ArrayLike,
    *,
    ship_type: ShipType = "container",
    loading: Loading = "normal",
    max_calm_froude: float = MAX_CALM_FROUDE,
    on_unreachable: OnUnreachable = "raise",
) -> np.ndarray:
    """Calm-water speed V1 whose speed in weather (Kwon 2008) is ``stw_kn``.

    Solves V1 (1 − ΔV/V1(V1) / 100) = V2 for V1, the inverse of
    :func:`speed_in_weather_kn`.  The power needed to make a speed through
    the water V2 in this weather is the calm-water power at V1.

    Method: V1 >= V2 because the loss is >= 0, so the root is bracketed from
    below by V2.  The interval from V2 to the bound V1_max = ``max_calm_froude``
    · √(g L) is scanned on 32 equally spaced speeds for the first one whose
    weather speed reaches V2, and the root in the preceding sub-interval is
    refined to a few ulps (Illinois method with bisection steps, :func:`calm_speed_point`).  Where several V1
    give the same V2 (only possible beyond Kwon's Fn range, for the Cb 0.85
    rows) the smallest V1, the one needing the least power, is returned.  For
    V2 = 0 or a loss of 0 % the answer is V1 = V2.

    Parameters
    ----------
    stw_kn : array_like
        Speed through the water wanted in the weather, V2 [kn], >= 0.
    length_m, block_coefficient, volume_m3, beaufort, weather_angle_deg, ship_type, loading
        As in :func:`kwon_speed_loss_pct`.
    max_calm_froude : float
        Upper bound of the calm-water Froude number searched [-]; default
        :data:`MAX_CALM_FROUDE` = 0.30, the top of Kwon's range (see there
        why the search is not extrapolated further by default).
    on_unreachable : {"raise", "nan"}
        Where no V1 up to the bound gives V2: raise :class:`SeaStateError`
        (default) or return NaN there.

    Returns
    -------
    ndarray
        V1 [kn], >= V2.

    Raises
    ------
    SeaStateError
        Where no V1 <= max_calm_froude · √(g L) reaches V2 (with
        ``on_unreachable="raise"``), and for bad inputs.
    """
    mode = on_unreachable_mode(on_unreachable)
    fn_max = float(finite("max_calm_froude", max_calm_froude, minimum=0.0, strict=True, error=ConfigError))
    v2 = speed_kn("stw_kn", stw_kn)
    length = particular("length_m", length_m, "length between perpendiculars in m")
    cb = _block_coefficient(block_coefficient)
    load = _loading(loading)
    c_bf = kwon_direction_coefficient(weather_angle_deg, beaufort) * kwon_form_coefficient(
        beaufort, volume_m3, ship_type, loading
    )
    # C_U's coefficients and 1/√(gL) are fixed along the root search: compute them once, and elementwise on Cb as
    # given (one ship: one Cb), before it is broadcast to the weather's shape
    a, b, c = _cu_coefficients(np.asarray(cb, dtype=float), load)
    v2, length, cb, c_bf = np.broadcast_arrays(v2, length, cb, c_bf)
    # the bound itself is admitted up to rounding, so a V1 at exactly Fn = fn_max inverts
    v_max = fn_max * units.ms_to_kn(np.sqrt(G_MS2 * length)) * (1.0 + 1e-12)
    loss_per_cu = c_bf / 100.0
    inv_sqrt_gl_kn = 1.0 / units.ms_to_kn(np.sqrt(G_MS2 * length))

    too_fast = v2 > v_max * (1.0 + 1e-12)  # slack: a V2 at the bound itself, up to rounding, is allowed
    arrays = np.broadcast_arrays(v2, a, b, c, loss_per_cu, inv_sqrt_gl_kn, v_max)
    flat = [np.array(x, dtype=float, order="C").ravel() for x in arrays]  # writable copies: one kernel signature
    v1 = _invert_kwon(*flat, _N_SCAN, _N_BISECT).reshape(v2.shape)
    v1 = np.where(too_fast, np.nan, v1)
    bad = np.isnan(v1)
    if bad.any() and mode == "raise":
        idx, where = first_true(bad)
        raise SeaStateError(
            f"stw_kn={float(v2[idx])!r}{where} cannot be made in this weather (Beaufort and weather angle as given): "
            f"no calm-water speed up to Fn {fn_max} ({v_max[idx]:.2f} kn for length_m={float(length[idx])!r}) reaches it "
            "by Kwon's method; ask for less speed, take another heading, or pass on_unreachable='nan'"
        )
    return v1


KWON_SCAN_STEPS = 32
"""Equal steps on which :func:`calm_speed_for_weather_kn` scans for the root's bracket."""
KWON_BISECTIONS = 52
"""Halvings the bracket needs at most (it is at most (V_max - V2) / 32 wide: 52 halvings reach 1e-15 of it)."""
_N_SCAN = KWON_SCAN_STEPS
_N_BISECT = KWON_BISECTIONS


@jit
def _kwon_excess(v1, v2, a, b, c, loss_per_cu, inv_sqrt_gl_kn):  # pragma: no cover - compiled
    """Weather speed of the calm speed V1 minus the wanted V2 [kn] (Kwon 2008, loss floored at 0)."""
    fn = v1 * inv_sqrt_gl_kn
    loss = loss_per_cu * (a + fn * (b + c * fn))
    return v1 * (1.0 - max(loss, 0.0)) - v2


@jit
def _kwon_slope_positive(v2, v_max, a, b, c, loss_per_cu, inv_sqrt_gl_kn):  # pragma: no cover - compiled
    """Whether the weather speed V1 (1 − max(k C_U, 0)) strictly increases in V1 on [V2, V_max].

    Its slope is 1 where the loss is floored at 0 and 1 − k (a + 2b Fn + 3c Fn²)
    elsewhere: positive on the whole interval when k times the largest value of
    that quadratic over [Fn(V2), Fn(V_max)] (at an end, or at its vertex
    −b / 3c when c < 0) is below 1.
    """
    f_lo, f_hi = v2 * inv_sqrt_gl_kn, v_max * inv_sqrt_gl_kn
    q = max(a + f_lo * (2.0 * b + 3.0 * c * f_lo), a + f_hi * (2.0 * b + 3.0 * c * f_hi))
    if c < 0.0:
        f_v = -b / (3.0 * c)
        if f_lo < f_v < f_hi:
            q = max(q, a + f_v * (2.0 * b + 3.0 * c * f_v))
    return loss_per_cu * q < 1.0


kwon_weather_speed_increasing = _kwon_slope_positive
"""Public name of the monotonicity test :func:`calm_speed_point` branches on (its unique-root case): where it
holds for a loss ``k``, it holds for every smaller loss, and the calm speed found grows with ``k`` and with V2."""


@jit
def calm_speed_point(v2, a, b, c, loss_per_cu, inv_sqrt_gl_kn, v_max, n_scan, n_bisect):  # pragma: no cover - compiled
    """Smallest V1 in [V2, V_max] with V1 (1 - max(k C_U(Fn(V1)), 0)) >= V2 [kn]; NaN if none.

    One point of :func:`calm_speed_for_weather_kn` (Kwon 2008), numba-compilable and
    shared by the vectorised function, :mod:`optroute.physics.pointwise` and the
    compiled route-search kernels.  ``a, b, c`` are C_U's coefficients
    (:func:`kwon_cu_coefficients`), ``loss_per_cu`` = C_β C_Form / 100,
    ``inv_sqrt_gl_kn`` = 1 / √(g L) in knots.

    Where the weather speed increases with V1 on the whole interval
    (:func:`_kwon_slope_positive`: every tabulated C_U at Kwon's Froude numbers
    and ordinary losses) the root is unique and found by Newton's method on the
    cubic, kept inside a shrinking bracket (a bisection whenever a step leaves
    it), from V2 / (1 − k C_U(V2)).  Elsewhere the weather speed is scanned on
    ``n_scan`` equal steps from V2 to V_max for the first one reaching V2, and
    the root in the step before it refined by the Illinois method (regula falsi
    with halving, a bisection following any step that did not halve the
    bracket, at most ``2 n_bisect`` steps).  Either way the bracket ends a few
    ulps wide and its upper end is returned, so the result never falls short.
    """
    if _kwon_excess(v2, v2, a, b, c, loss_per_cu, inv_sqrt_gl_kn) >= 0.0:
        return v2
    if _kwon_slope_positive(v2, v_max, a, b, c, loss_per_cu, inv_sqrt_gl_kn):
        f_top = _kwon_excess(v_max, v2, a, b, c, loss_per_cu, inv_sqrt_gl_kn)
        if f_top < 0.0:
            return np.nan
        return _kwon_newton(v2, a, b, c, loss_per_cu, inv_sqrt_gl_kn, v_max, f_top, n_bisect)
    lo = v2
    hi = np.nan
    for k in range(1, n_scan + 1):
        v = v_max if k == n_scan else v2 + (v_max - v2) * (k / n_scan)
        if _kwon_excess(v, v2, a, b, c, loss_per_cu, inv_sqrt_gl_kn) >= 0.0:
            hi = v
            break
        lo = v
    if np.isnan(hi):
        return np.nan
    # Illinois (modified regula falsi) on the bracket, falling back to bisection: the bracket
    # [lo, hi] always has excess(lo) < 0 <= excess(hi), and shrinks to a few ulps of the root
    f_lo = _kwon_excess(lo, v2, a, b, c, loss_per_cu, inv_sqrt_gl_kn)
    f_hi = _kwon_excess(hi, v2, a, b, c, loss_per_cu, inv_sqrt_gl_kn)
    side = 0
    bisect = False
    for _ in range(2 * n_bisect):  # a step that does not halve the bracket is followed by a bisection
        width = hi - lo
        if width <= 4.0 * np.finfo(np.float64).eps * hi:
            break
        x = 0.5 * (lo + hi) if bisect else hi - f_hi * (hi - lo) / (f_hi - f_lo)
        if not lo < x < hi:
            x = 0.5 * (lo + hi)
        f_x = _kwon_excess(x, v2, a, b, c, loss_per_cu, inv_sqrt_gl_kn)
        if f_x >= 0.0:
            hi, f_hi = x, f_x
            if side == 1:
                f_lo *= 0.5
            side = 1
        else:
            lo, f_lo = x, f_x
            if side == -1:
                f_hi *= 0.5
            side = -1
        bisect = hi - lo > 0.5 * width
    return hi


@jit
def _kwon_newton(v2, a, b, c, loss_per_cu, inv_sqrt_gl_kn, v_max, f_top, n_bisect):  # pragma: no cover - compiled
    """The root of the increasing excess in (V2, V_max] by bracketed Newton; the bracket's upper end."""
    lo, hi = v2, v_max
    fn = v2 * inv_sqrt_gl_kn
    x = v2 / (1.0 - loss_per_cu * (a + fn * (b + c * fn)))
    if not lo < x < hi:
        x = 0.5 * (lo + hi)
    for _ in range(2 * n_bisect):
        fn = x * inv_sqrt_gl_kn
        cu = a + fn * (b + c * fn)
        loss = loss_per_cu * cu
        f_x = x * (1.0 - max(loss, 0.0)) - v2
        if f_x >= 0.0:
            hi = x
        else:
            lo = x
        if hi - lo <= 4.0 * np.finfo(np.float64).eps * hi:
            break
        slope = 1.0 - loss_per_cu * (a + fn * (2.0 * b + 3.0 * c * fn)) if loss > 0.0 else 1.0
        step = f_x / slope
        if abs(step) <= 2.0 * np.finfo(np.float64).eps * x:  # converged: step just past the root to close the bracket
            nx = x + (-2.0 if f_x >= 0.0 else 2.0) * np.finfo(np.float64).eps * x
        else:
            nx = x - step
        if not lo < nx < hi:
            nx = 0.5 * (lo + hi)
        x = nx
    return hi


@jit
def _invert_kwon(v2, a, b, c, loss_per_cu, inv_sqrt_gl_kn, v_max, n_scan, n_bisect):  # pragma: no cover - compiled
    """:func:`calm_speed_point` element by element."""
    out = np.empty(v2.size)
    for i in range(v2.size):
        out[i] = calm_speed_point(
            v2[i], a[i], b[i], c[i], loss_per_cu[i], inv_sqrt_gl_kn[i], v_max[i], n_scan, n_bisect
        )
    return out
