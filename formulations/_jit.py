"""numba for the formulations' numeric kernels: on-disk cache where numba can write one.

:mod:`formulations` never imports :mod:`optroute`, whose ``_numba`` module finds numba a cache folder; a
read-only installation, where numba finds none, must not fail to import for it: there a kernel is compiled once
per process instead.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["njit"]


def njit(fn: Callable[..., Any]) -> Any:
    """``fn`` compiled by numba (``error_model="numpy"``), kept in numba's on-disk cache where it can write one."""
    import numba

    try:
        return numba.njit(cache=True, error_model="numpy")(fn)
    except RuntimeError:  # numba found no cache folder it can write
        return numba.njit(error_model="numpy")(fn)
