"""Input checks shared by the physics functions.

They raise :class:`~optroute.errors.SeaStateError` (or the class given) with
a message that names the argument, the offending value and the fix; nothing
is clipped or filled in silently.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from optroute.errors import OptrouteError, SeaStateError


def _first_bad(arr: np.ndarray, bad: np.ndarray) -> str:
    idx = np.argwhere(bad)[0]
    where = "" if arr.ndim == 0 else f" at index {tuple(int(i) for i in idx)}"
    return f"{float(arr[tuple(idx)])!r}{where}"


def finite(
    name: str,
    value: ArrayLike,
    *,
    minimum: float | None = None,
    strict: bool = False,
    error: type[OptrouteError] = SeaStateError,
    fix: str = "",
) -> np.ndarray:
    """Return ``value`` as a float array after checking it is finite and in range.

    Parameters
    ----------
    name : str
        Argument name, with its unit, used in the message (e.g. ``"hs_m"``).
    value : array_like
        The values to check.
    minimum : float, optional
        Lower bound; values below it (or equal to it when ``strict``) are rejected.
    strict : bool
        Whether the bound itself is excluded.
    error : type
        The :class:`OptrouteError` subclass to raise.
    fix : str
        A hint appended to the message.

    Raises
    ------
    OptrouteError
        The given subclass, naming the first bad value.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise error(f"{name}={value!r} is not a number; pass a float or an array of floats") from exc
    tail = f"; {fix}" if fix else ""
    bad = ~np.isfinite(arr)
    if bad.any():
        raise error(f"{name} must be finite, got {_first_bad(arr, bad)}{tail}")
    if minimum is not None:
        bad = arr <= minimum if strict else arr < minimum
        if bad.any():
            op = ">" if strict else ">="
            raise error(f"{name} must be {op} {minimum}, got {_first_bad(arr, bad)}{tail}")
    return arr
