"""Ship performance in a seaway: brake power for a speed through water.

Everything downstream (the route search's edge cost, the optimiser, plan
verification) asks a :class:`PerformanceModel` — and only it — how much
power a speed through water needs in given wind and waves, and how much
fuel that power burns.  optroute ships two models and a user can plug in a
third:

* :class:`CalmWaterModel` — the ship's calm-water curve, weather ignored;
* :class:`KwonModel` (the default) — calm water plus Kwon's (2008)
  involuntary speed loss: to make good a speed V₂ through water in weather,
  the engine must deliver the calm-water power of the speed V₁ for which
  Kwon's method gives V₂ = V₁ (1 − ΔV/V₁);
* :class:`PowerTableModel` — brake power tabulated over speed, Hs and
  relative wave angle, as fitted from noon reports or model tests.

A user model need only provide the attributes and methods of the protocol.

Angles: ``wave_angle_deg`` and ``wind_angle_deg`` are relative to the bow,
0° = head (from ahead), 180° = following, IMO MSC.1/Circ.1228; 0–360 is
accepted and folded by port/starboard symmetry where a model needs it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import RegularGridInterpolator

from optroute._checks import finite
from optroute.errors import SeaStateError, ShipSpecError
from optroute.physics import seaway, speed_loss
from optroute.physics.ship import Ship


@runtime_checkable
class PerformanceModel(Protocol):
    """What optroute needs to know about a ship's propulsion in a seaway.

    Attributes
    ----------
    mcr_kw : float
        Maximum continuous rating [kW]: the upper power limit.
    min_power_kw : float
        Lowest sustained brake power [kW]: the lower power limit.

    Methods
    -------
    brake_power_kw(stw_kn, *, hs_m, wave_angle_deg, wind_speed_ms, wind_angle_deg)
        Brake power [kW] to make good ``stw_kn`` [kn] through the water in
        that sea (Hs [m], relative wave angle [deg, 0 = head]) and wind
        (speed at 10 m [m/s] or None, relative angle [deg, 0 = head]; NaN
        where the weather has no wind: not known, to be estimated from the
        sea, never read as calm air). Vectorised and broadcasting over all arguments; non-decreasing in
        ``stw_kn``.
    fuel_rate_tph(power_kw)
        Main-engine fuel consumption [t/h] at a brake power [kW].
    """

    mcr_kw: float
    min_power_kw: float

    def brake_power_kw(
        self,
        stw_kn: ArrayLike,
        *,
        hs_m: ArrayLike = 0.0,
        wave_angle_deg: ArrayLike = 0.0,
        wind_speed_ms: ArrayLike | None = None,
        wind_angle_deg: ArrayLike | None = None,
    ) -> np.ndarray: ...

    def fuel_rate_tph(self, power_kw: ArrayLike) -> np.ndarray: ...


def _fold_angle_deg(angle_deg: ArrayLike, name: str) -> np.ndarray:
    """Fold a relative angle [deg] into [0, 180] by port/starboard symmetry."""
    a = np.mod(finite(name, angle_deg), 360.0)
    return np.where(a > 180.0, 360.0 - a, a)


class _ShipEngine:
    """The engine side every built-in model shares: MCR, minimum load and SFOC come from ``self.ship``."""

    ship: Ship

    @property
    def mcr_kw(self) -> float:
        """Maximum continuous rating [kW]."""
        return self.ship.mcr_kw

    @property
    def min_power_kw(self) -> float:
        """Lowest sustained brake power [kW]."""
        return self.ship.min_power_kw

    def fuel_rate_tph(self, power_kw):
        """Fuel rate [t/h] at a brake power [kW] from the ship's SFOC curve."""
        return self.ship.fuel_rate_tph(power_kw)


@dataclass(frozen=True)
class CalmWaterModel(_ShipEngine):
    """The ship's calm-water power curve; wind and waves are ignored.

    Parameters
    ----------
    ship : Ship
        Supplies ``calm_power_kw``, ``fuel_rate_tph``, MCR and minimum load.
    """

    ship: Ship

    def brake_power_kw(self, stw_kn, *, hs_m=0.0, wave_angle_deg=0.0, wind_speed_ms=None, wind_angle_deg=None):
        """Calm-water brake power [kW] at ``stw_kn`` [kn]; the sea arguments are checked, then ignored."""
        finite("hs_m", hs_m, minimum=0.0)
        return self.ship.calm_power_kw(stw_kn)


@dataclass(frozen=True)
class KwonModel(_ShipEngine):
    """Calm water plus Kwon's (2008) involuntary speed loss.

    The Beaufort number comes from the 10 m wind where it is given and
    finite, otherwise from Hs (the force whose probable wave height is
    nearest, physics.md §5).  Kwon's weather direction is taken as the
    relative wave angle (waves carry most of the added resistance; Kwon
    assumes wind and sea aligned).

    Parameters
    ----------
    ship : Ship
        Supplies L, C_b, ∇, ship type, loading and the calm-water curve.

    References
    ----------
    Kwon, Y. J. (2008). Speed loss due to added resistance in wind and
    waves. *The Naval Architect*, March 2008, 14–16 (physics.md §6).
    """

    ship: Ship

    #: Edges of the wave-angle sectors [deg] where the model steps (Kwon's direction coefficient; constant inside
    #: each sector): the corridor NLP's power table keeps one field per sector (:mod:`optroute.optimise.power_table`).
    wave_sector_edges_deg = speed_loss.KWON_SECTOR_EDGES_DEG
    #: The brake power depends on the sea only through :meth:`power_regime`: two sea states of the same regime
    #: give the same power at every speed, to the bit. Kwon (2008) reads the sea only as the integer Beaufort
    #: number (its form coefficient and C_β) and the sector of the weather angle (C_β constant inside each), and
    #: the wind angle not at all. The corridor NLP's power table evaluates the model once per regime
    #: (:mod:`optroute.optimise.power_table`); tests/test_power_table.py checks the claim on random seas.
    power_by_regime = True

    def beaufort(self, hs_m: ArrayLike, wind_speed_ms: ArrayLike | None) -> np.ndarray:
        """Beaufort number [-] from the wind [m/s] where known, else from Hs [m]."""
        hs = finite("hs_m", hs_m, minimum=0.0)
        bn_hs = seaway.beaufort_from_hs(hs)
        if wind_speed_ms is None:
            return bn_hs
        wind = np.asarray(wind_speed_ms, dtype=float)
        known = np.isfinite(wind)
        bn_wind = seaway.beaufort_from_wind(np.where(known, wind, 0.0))
        return np.where(known, bn_wind, bn_hs)

    def power_regime(self, *, hs_m=0.0, wave_angle_deg=0.0, wind_speed_ms=None) -> np.ndarray:
        """Which of Kwon's tabulated cases applies: ``4 · BN + sector`` (int); the power jumps only where it changes.

        Kwon (2008) takes the Beaufort number as an integer (from the wind where known, else from Hs:
        :meth:`beaufort`) and the direction coefficient C_β by sector of the weather angle (head
        [0°, 30°], bow (30°, 60°], beam (60°, 150°], following (150°, 180°]:
        :func:`optroute.physics.speed_loss.kwon_direction_coefficient`); between changes of either the
        brake power is smooth in the sea state.  The plan's fuel integration
        (:func:`optroute.plan.evaluate.evaluate_track`) refines its pieces where this changes.
        """
        bn = self.beaufort(hs_m, wind_speed_ms)
        a = _fold_angle_deg(wave_angle_deg, "wave_angle_deg")
        bn, a = np.broadcast_arrays(bn, a)
        head, bow, beam = speed_loss.KWON_SECTOR_EDGES_DEG
        sector = np.select([a <= head, a <= bow, a <= beam], [0, 1, 2], default=3)
        return (4 * np.asarray(bn, dtype=np.int64) + sector).astype(np.int64)

    def regime_distances(self, *, hs_m=0.0, wave_angle_deg=0.0, wind_speed_ms=None) -> tuple[np.ndarray, np.ndarray]:
        """How far the sea state is from the nearest change of :meth:`power_regime`: (Beaufort driver, angle).

        The first array is the distance of the Beaufort number's driver to the nearest Beaufort edge: of
        the wind speed [m/s] to the WMO band edges where the wind is known, else of Hs [m] to the
        midpoints between the probable wave heights (:func:`optroute.physics.seaway.beaufort_from_hs`).
        The second is the distance of the folded wave angle to the nearest sector edge of Kwon (2008)
        [deg]. Both are continuous along a track and zero exactly where the regime can change, so a
        slope bound on them tells where the regime may change and change back between two points
        (:func:`optroute.plan.checkpoints.check_points`).
        """
        hs = finite("hs_m", hs_m, minimum=0.0)
        d_hs = np.min(np.abs(hs[..., None] - seaway.BEAUFORT_HS_EDGES_M), axis=-1)
        if wind_speed_ms is None:
            driver = d_hs
        else:
            wind = np.asarray(wind_speed_ms, dtype=float)
            known = np.isfinite(wind)
            d_wind = np.min(np.abs(np.where(known, wind, 0.0)[..., None] - seaway.BEAUFORT_WIND_UPPER_MS), axis=-1)
            driver = np.where(known, d_wind, d_hs)
        a = _fold_angle_deg(wave_angle_deg, "wave_angle_deg")
        d_angle = np.min(np.abs(a[..., None] - np.asarray(speed_loss.KWON_SECTOR_EDGES_DEG)), axis=-1)
        driver, d_angle = np.broadcast_arrays(driver, d_angle)
        return np.asarray(driver, dtype=float), np.asarray(d_angle, dtype=float)

    def calm_equivalent_speed_kn(
        self, stw_kn, *, hs_m=0.0, wave_angle_deg=0.0, wind_speed_ms=None, wind_angle_deg=None
    ):
        """Calm-water speed V₁ [kn] whose speed in this weather is ``stw_kn`` [kn].

        NaN where no calm-water speed within Kwon's range (Fn ≤ 0.30) makes
        good ``stw_kn`` in this weather.
        """
        stw = finite("stw_kn", stw_kn, minimum=0.0)
        bn = self.beaufort(hs_m, wind_speed_ms)
        angle = _fold_angle_deg(wave_angle_deg, "wave_angle_deg")
        stw, bn, angle = np.broadcast_arrays(stw, bn, angle)
        return speed_loss.calm_speed_for_weather_kn(
            stw,
            self.ship.length_m,
            self.ship.block_coefficient,
            self.ship.volume_m3,
            bn,
            angle,
            ship_type=self.ship.ship_type,
            loading=self.ship.loading,
            on_unreachable="nan",
        )

    def brake_power_kw(self, stw_kn, *, hs_m=0.0, wave_angle_deg=0.0, wind_speed_ms=None, wind_angle_deg=None):
        """Brake power [kW]: the calm-water power of Kwon's equivalent calm speed.

        ``inf`` where the speed cannot be made in this weather within Kwon's
        range: no engine reaches it, so every power limit rejects it.
        """
        v1 = self.calm_equivalent_speed_kn(
            stw_kn, hs_m=hs_m, wave_angle_deg=wave_angle_deg, wind_speed_ms=wind_speed_ms, wind_angle_deg=wind_angle_deg
        )
        reachable = np.isfinite(v1)
        return np.where(reachable, self.ship.calm_power_kw(np.where(reachable, v1, 0.0)), np.inf)


@dataclass(frozen=True)
class PowerTableModel(_ShipEngine):
    """Brake power tabulated over (speed through water, Hs, relative wave angle).

    The table is what a performance engineer fits from noon reports or
    model tests; it is interpolated linearly inside its grid and a query
    outside it raises (nothing is extrapolated silently).

    Parameters
    ----------
    stw_kn : array_like, shape (n,)
        Speeds through water [kn], strictly increasing.
    hs_m : array_like, shape (m,)
        Significant wave heights [m], strictly increasing, starting at 0.
    wave_angle_deg : array_like, shape (k,)
        Relative wave angles [deg, 0 = head, 180 = following], strictly
        increasing, spanning 0–180 (port/starboard symmetry is assumed).
    power_kw : array_like, shape (n, m, k)
        Brake power [kW], strictly increasing along the speed axis.
    ship : Ship
        Supplies MCR, minimum load and the SFOC curve.
    """

    stw_kn: tuple[float, ...]
    hs_m: tuple[float, ...]
    wave_angle_deg: tuple[float, ...]
    power_kw: np.ndarray
    ship: Ship

    def __post_init__(self) -> None:
        axes = {"stw_kn": self.stw_kn, "hs_m": self.hs_m, "wave_angle_deg": self.wave_angle_deg}
        for name, ax in axes.items():
            arr = finite(name, ax, minimum=0.0, error=ShipSpecError)
            if arr.ndim != 1 or arr.size < 2 or np.any(np.diff(arr) <= 0):
                raise ShipSpecError(
                    f"PowerTableModel.{name}={list(np.ravel(arr))} must be a strictly increasing 1-D axis"
                )
            object.__setattr__(self, name, tuple(float(x) for x in arr))
        if self.hs_m[0] != 0.0 or self.wave_angle_deg[0] != 0.0 or self.wave_angle_deg[-1] != 180.0:
            raise ShipSpecError(
                "PowerTableModel: hs_m must start at 0 and wave_angle_deg must span 0–180, "
                f"got hs_m from {self.hs_m[0]} and angles {self.wave_angle_deg[0]}–{self.wave_angle_deg[-1]}"
            )
        p = finite("power_kw", self.power_kw, minimum=0.0, strict=True, error=ShipSpecError)
        shape = (len(self.stw_kn), len(self.hs_m), len(self.wave_angle_deg))
        if p.shape != shape:
            raise ShipSpecError(f"PowerTableModel.power_kw has shape {p.shape}; expected {shape} (stw, hs, angle)")
        if np.any(np.diff(p, axis=0) <= 0):
            raise ShipSpecError("PowerTableModel.power_kw must increase strictly with speed at every Hs and angle")
        p.setflags(write=False)
        object.__setattr__(self, "power_kw", p)

    def brake_power_kw(self, stw_kn, *, hs_m=0.0, wave_angle_deg=0.0, wind_speed_ms=None, wind_angle_deg=None):
        """Brake power [kW] by trilinear interpolation; outside the table: SeaStateError."""
        stw = finite("stw_kn", stw_kn, minimum=0.0)
        hs = finite("hs_m", hs_m, minimum=0.0)
        angle = _fold_angle_deg(wave_angle_deg, "wave_angle_deg")
        stw, hs, angle = np.broadcast_arrays(stw, hs, angle)
        for name, vals, ax in (("stw_kn", stw, self.stw_kn), ("hs_m", hs, self.hs_m)):
            out = (vals < ax[0]) | (vals > ax[-1])
            if np.any(out):
                raise SeaStateError(
                    f"{name}={float(vals[out].flat[0])} lies outside the power table's range {ax[0]}–{ax[-1]}; "
                    "extend the table or use KwonModel"
                )
        interp = RegularGridInterpolator((self.stw_kn, self.hs_m, self.wave_angle_deg), self.power_kw)
        pts = np.stack([stw.ravel(), hs.ravel(), angle.ravel()], axis=-1)
        return interp(pts).reshape(stw.shape)


def default_model(ship: Ship) -> KwonModel:
    """The model optroute uses when none is given: calm water + Kwon."""
    return KwonModel(ship)


def max_stw_kn(
    model: PerformanceModel,
    power_kw: ArrayLike,
    *,
    hs_m: ArrayLike = 0.0,
    wave_angle_deg: ArrayLike = 0.0,
    wind_speed_ms: ArrayLike | None = None,
    wind_angle_deg: ArrayLike | None = None,
    upper_kn: float = 40.0,
    tol_kn: float = 1e-6,
) -> np.ndarray:
    """Highest speed through water whose brake power does not exceed ``power_kw``.

    Vectorised bisection on the protocol's ``brake_power_kw`` alone (it is
    non-decreasing in speed), so it serves any model.

    Parameters
    ----------
    model : PerformanceModel
        The ship's performance model.
    power_kw : array_like
        Available brake power [kW] (MCR, say).
    hs_m, wave_angle_deg, wind_speed_ms, wind_angle_deg : array_like
        The sea state, as in :meth:`PerformanceModel.brake_power_kw`.
    upper_kn : float
        Search bound [kn]; a speed needing less power than ``power_kw`` even
        at this bound returns the bound.
    tol_kn : float
        Bisection tolerance [kn].

    Returns
    -------
    ndarray
        Speed through water [kn]; 0 where even the slowest speed needs more
        power than given.
    """
    p = finite("power_kw", power_kw, minimum=0.0)
    sea = {
        "hs_m": hs_m,
        "wave_angle_deg": wave_angle_deg,
        "wind_speed_ms": wind_speed_ms,
        "wind_angle_deg": wind_angle_deg,
    }
    shape = np.broadcast_shapes(p.shape, np.shape(hs_m), np.shape(wave_angle_deg))
    lo = np.zeros(shape)
    hi = np.full(shape, float(upper_kn))
    ok_hi = model.brake_power_kw(hi, **sea) <= p
    n_iter = int(np.ceil(np.log2(upper_kn / tol_kn))) + 1
    for _ in range(n_iter):
        mid = 0.5 * (lo + hi)
        ok = model.brake_power_kw(mid, **sea) <= p
        lo = np.where(ok, mid, lo)
        hi = np.where(ok, hi, mid)
    return np.where(ok_hi, float(upper_kn), lo)
