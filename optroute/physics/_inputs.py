"""Input checks shared by the speed-loss methods and the velocity triangle.

Used by :mod:`optroute.physics.speed_loss` (Kwon 2008), :mod:`optroute.physics.imo_fw`
(IMO MEPC.1/Circ.796) and :mod:`optroute.physics.currents`; a private module of
:mod:`optroute.physics`, imported only inside it.  Every check raises an
:class:`~optroute.errors.OptrouteError` subclass whose message names the argument,
the offending value (and its index in an array) and the fix; nothing is clipped.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from optroute._checks import finite
from optroute.errors import ConfigError, OptrouteError, ShipSpecError

ShipType = Literal["container", "bulk_carrier", "tanker", "general_cargo"]
OnUnreachable = Literal["raise", "nan"]

SHIP_TYPES: tuple[str, ...] = ("container", "bulk_carrier", "tanker", "general_cargo")


def known_ship_type(ship_type: str) -> str:
    """``ship_type`` itself, or :class:`~optroute.errors.ConfigError` naming the known types."""
    if ship_type not in SHIP_TYPES:
        raise ConfigError(f"ship_type={ship_type!r} is not known; use one of {', '.join(map(repr, SHIP_TYPES))}")
    return ship_type


def first_true(bad: np.ndarray) -> tuple[tuple[int, ...], str]:
    """Index of the first True in ``bad`` and its " at index (...)" text (empty for 0-d)."""
    idx = tuple(int(i) for i in np.argwhere(bad)[0])
    return idx, ("" if bad.ndim == 0 else f" at index {idx}")


def at_most(name: str, arr: np.ndarray, maximum: float, error: type[OptrouteError], fix: str) -> None:
    """Raise ``error`` naming the first value of ``arr`` above ``maximum`` (there is none: nothing)."""
    bad = arr > maximum
    if bad.any():
        idx, where = first_true(bad)
        raise error(f"{name} must be <= {maximum}, got {float(arr[idx])!r}{where}; {fix}")


def speed_kn(name: str, value: ArrayLike) -> np.ndarray:
    """A finite speed through the water [kn], >= 0, as a float array."""
    return finite(name, value, minimum=0.0, fix="pass a speed through the water in knots, >= 0")


def particular(name: str, value: ArrayLike, what: str) -> np.ndarray:
    """A finite, positive ship particular (``what`` names it with its unit), as a float array."""
    return finite(name, value, minimum=0.0, strict=True, error=ShipSpecError, fix=f"pass the ship's {what}, > 0")


def on_unreachable_mode(mode: str) -> str:
    """``mode`` itself when it is 'raise' or 'nan', else :class:`~optroute.errors.ConfigError`."""
    if mode not in ("raise", "nan"):
        raise ConfigError(f"on_unreachable={mode!r} is not known; use 'raise' or 'nan'")
    return mode
