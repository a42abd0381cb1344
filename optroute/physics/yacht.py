"""A sailing vessel: speed from the wind through its polar, no fuel, optional motoring in light air.

Angle conventions: headings and wind directions in degrees true, clockwise
from north; the wind direction is where it blows **from**.  The signed true
wind angle ``TWA = wind_from - heading`` wrapped to (-180, 180] is positive
when the wind comes over the starboard side (starboard tack), negative over
port (port tack); 0 is head to wind, ±180 dead downwind (either gybe).

A manoeuvre is a change of tack between consecutive legs: a **tack** when the
bow turns through the wind (``|TWA₁| + |TWA₂| < 180``, the shorter turn), a
**gybe** when the stern does (≥ 180).  A leg dead downwind or under engine
keeps the tack the boat was on (Życkowski counts manoeuvres ω; a heading change
on the same tack is not one here, but :attr:`heading_changes` of the route
gives the paper's count).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError, ShipSpecError
from optroute.physics.polar import Polar

#: Tack codes used by the search's states.
NO_TACK, STARBOARD, PORT = 0, 1, 2
TACK_NAMES = {NO_TACK: "none", STARBOARD: "starboard", PORT: "port"}
_RUN_TOL_DEG = 1e-9


@dataclass(frozen=True)
class SailingVessel:
    """A yacht: its polar, and an engine only for light air.

    Parameters
    ----------
    polar : Polar
        Boat speed through water [kn] against ``|TWA|`` [deg] and TWS [kn].
    name : str
    motoring_below_kn : float or None
        True wind speed [kn] below which the boat motors (any heading, head
        to wind included) at ``motor_speed_kn``; None: never motors (in no
        wind a leg is not sailable).
    motor_speed_kn : float
        Speed under engine [kn], > 0 when ``motoring_below_kn`` is given.
    """

    polar: Polar
    name: str = "yacht"
    motoring_below_kn: float | None = None
    motor_speed_kn: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.polar, Polar):
            raise ShipSpecError(f"{self.name}: polar must be a Polar (read_polar, Polar.from_matrix), "
                                f"got {type(self.polar).__name__}")  # fmt: skip
        if self.motoring_below_kn is not None:
            finite(f"{self.name}: motoring_below_kn", self.motoring_below_kn, minimum=0.0, strict=True,
                   error=ShipSpecError)  # fmt: skip
            finite(f"{self.name}: motor_speed_kn", self.motor_speed_kn, minimum=0.0, strict=True, error=ShipSpecError,
                   fix="give the speed under engine, or motoring_below_kn=None")  # fmt: skip

    @property
    def motor_kernel(self) -> tuple[float, float]:
        """``(motoring_below_kn, motor_speed_kn)`` for the kernels; (-1, 0) when the boat never motors."""
        if self.motoring_below_kn is None:
            return -1.0, 0.0
        return float(self.motoring_below_kn), float(self.motor_speed_kn)

    def leg_speed_kn(
        self, heading_deg: ArrayLike, wind_from_deg: ArrayLike, tws_kn: ArrayLike, source: str = "the wind"
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Speed on a heading in a given wind, the model the search and the referee share.

        Parameters
        ----------
        heading_deg, wind_from_deg : array_like
            Heading and wind direction (from) [deg true].
        tws_kn : array_like
            True wind speed [kn].
        source : str
            Where the wind came from, for error messages.

        Returns
        -------
        speed_kn : ndarray
            Boat speed [kn]; 0 inside the no-go sector (not sailable).
        twa_deg : ndarray
            Signed true wind angle [deg, (-180, 180], + starboard].
        motoring : ndarray of bool
        """
        twa = true_wind_angle_deg(heading_deg, wind_from_deg)
        w = np.asarray(tws_kn, dtype=float)
        lo, motor = self.motor_kernel
        motoring = np.broadcast_to(w < lo, np.broadcast(twa, w).shape)
        sail = self.polar.speed_kn_at(twa, w)
        return np.where(motoring, motor, sail), np.broadcast_to(twa, motoring.shape), motoring


def true_wind_angle_deg(heading_deg: ArrayLike, wind_from_deg: ArrayLike) -> np.ndarray:
    """Signed true wind angle ``wind_from − heading`` in (-180, 180] [deg]; + = wind over starboard."""
    d = np.mod(np.asarray(wind_from_deg, dtype=float) - np.asarray(heading_deg, dtype=float), 360.0)
    return np.where(d > 180.0, d - 360.0, d)


def tack_of(twa_deg: ArrayLike) -> np.ndarray:
    """Tack code of a signed TWA: STARBOARD (0 < TWA < 180), PORT (< 0), NO_TACK at 0 or dead downwind."""
    a = np.asarray(twa_deg, dtype=float)
    run = np.abs(np.abs(a) - 180.0) <= _RUN_TOL_DEG
    return np.where(run | (a == 0.0), NO_TACK, np.where(a > 0, STARBOARD, PORT))


def manoeuvre_kind(twa_before_deg: float, twa_after_deg: float) -> str:
    """``"tack"`` when the shorter turn between the legs passes head to wind, else ``"gybe"``."""
    return "tack" if abs(twa_before_deg) + abs(twa_after_deg) < 180.0 else "gybe"


def wind_kn_from(u_ms: ArrayLike, v_ms: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """True wind speed [kn] and direction it blows from [deg true] from (u, v) [m/s, the vector it blows to]."""
    speed_ms, from_deg = units.wind_uv_to_speed_from_deg(u_ms, v_ms)
    return units.ms_to_kn(speed_ms), from_deg


def check_vessel(vessel: object) -> SailingVessel:
    """The vessel, or a ConfigError saying what a sailing search needs."""
    if not isinstance(vessel, SailingVessel):
        raise ConfigError(f"vessel must be a SailingVessel (a polar, optional motoring), got {type(vessel).__name__}")
    return vessel
