"""The IMO standard weather factor f_w of the EEDI (MEPC.1/Circ.796) and the Capacity it is read at.

Split from :mod:`optroute.physics.speed_loss`, which re-exports both functions (the public
API is unchanged): f_w is the other speed-loss method beside Kwon (2008), a single
ratio per ship type and size, not a function of the sea state.

Sources
-------
* IMO MEPC.1/Circ.796 (2012), *Interim guidelines for the calculation of the
  coefficient f_w for decrease in ship speed in a representative sea
  condition for trial use*, Part 2, Table 1; Capacity as defined by the EEDI
  calculation guidelines (MEPC.212(63), now MEPC.364(79)) — ``physics.md`` §7.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from optroute.errors import ConfigError, ShipSpecError
from optroute.physics._inputs import ShipType, first_true, known_ship_type, particular

__all__ = ["imo_fw", "imo_fw_capacity"]

# MEPC.1/Circ.796 Part 2 Table 1: standard f_w = a ln(Capacity) + b.  The
# circular gives curves for these three types only; general cargo ships (and
# every other type) need the simulation of Part 1, so they raise ConfigError.
_IMO_FW_AB: dict[str, tuple[float, float]] = {
    "bulk_carrier": (0.0429, 0.294),
    "tanker": (0.0238, 0.526),
    "container": (0.0208, 0.633),
}


def imo_fw_capacity(ship_type: ShipType, dwt_t: ArrayLike) -> np.ndarray:
    """EEDI Capacity used in the standard f_w curve [t].

    Capacity as defined by the EEDI calculation guidelines (MEPC.212(63)
    §2.3, kept in MEPC.245(66), MEPC.308(73), MEPC.364(79)): the deadweight
    for bulk carriers, tankers and general cargo ships, 70 % of the
    deadweight for container ships.

    Parameters
    ----------
    ship_type : {"container", "bulk_carrier", "tanker", "general_cargo"}
        Ship type.
    dwt_t : array_like
        Deadweight [t], > 0.

    Returns
    -------
    ndarray
        Capacity [t].

    Raises
    ------
    ShipSpecError
        A deadweight that is not finite or not positive.
    ConfigError
        An unknown ``ship_type``.
    """
    kind = known_ship_type(ship_type)
    dwt = particular("dwt_t", dwt_t, "deadweight in tonnes")
    # Flag (physics.md §7): Circ.796 itself only says "Capacity as defined in
    # the EEDI guidelines"; the 70 % of DWT for container ships is that
    # definition (checked against the Circ.796 example: 54 000 DWT -> 0.852).
    return 0.7 * dwt if kind == "container" else dwt


def imo_fw(ship_type: ShipType, capacity: ArrayLike) -> np.ndarray:
    """IMO standard weather factor f_w = a ln(Capacity) + b [-].

    MEPC.1/Circ.796 (2012) Part 2, Table 1 (``physics.md`` §7): the ratio of
    the speed in the representative sea (Beaufort 6 head seas: wind
    12.6 m/s, Hs 3.0 m, T 6.7 s) to the calm-water speed, at the same power.

    ==============  =======  =====
    ship type       a        b
    ==============  =======  =====
    bulk carrier    0.0429   0.294
    tanker          0.0238   0.526
    container ship  0.0208   0.633
    ==============  =======  =====

    Parameters
    ----------
    ship_type : {"bulk_carrier", "tanker", "container"}
        Ship type; Circ.796 has no standard curve for "general_cargo" or any
        other type.
    capacity : array_like
        EEDI Capacity [t], > 0 (see :func:`imo_fw_capacity`).

    Returns
    -------
    ndarray
        f_w [-], in (0, 1].

    Raises
    ------
    ConfigError
        ``ship_type`` without a Circ.796 curve ("general_cargo") or unknown.
    ShipSpecError
        A capacity that is not finite, not positive, or so far outside the
        curves' data that f_w leaves (0, 1].
    """
    kind = known_ship_type(ship_type)
    if kind not in _IMO_FW_AB:
        raise ConfigError(
            f"ship_type={ship_type!r} has no standard f_w curve in MEPC.1/Circ.796 (only "
            f"{', '.join(map(repr, _IMO_FW_AB))}); compute f_w by the simulation of Circ.796 Part 1, "
            "or use kwon_speed_loss_pct at Beaufort 6 head seas"
        )
    cap = particular("capacity", capacity, "EEDI Capacity in tonnes")
    a, b = _IMO_FW_AB[kind]
    fw = a * np.log(cap) + b
    bad = (fw <= 0.0) | (fw > 1.0)
    if bad.any():
        idx, where = first_true(bad)
        raise ShipSpecError(
            f"capacity={float(cap[idx])!r}{where} gives f_w = {fw[idx]:.4f}, outside (0, 1]: the Circ.796 curve does "
            "not apply; pass the Capacity in tonnes (imo_fw_capacity)"
        )
    return fw
