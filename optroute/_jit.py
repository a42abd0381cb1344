"""Lazy numba compilation with an on-disk cache where one can be written.

``jit(fn)`` returns a numba dispatcher that compiles ``fn`` on its first call
(never at import), caching the machine code next to the module
(``__pycache__``) or in numba's user-wide cache directory.  Where neither is
writable (a read-only installation, a locked-down container) numba refuses
``cache=True`` with a :class:`RuntimeError` when the dispatcher is made; the
function is then compiled without a cache, at every new process, and works
the same.  :data:`CACHE_FALLBACKS` names the functions that took that path.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numba

CACHE_FALLBACKS: list[str] = []
"""Qualified names of the functions compiled without an on-disk cache (no writable cache folder)."""


def jit(fn: Callable[..., Any] | None = None, *, cache: bool = True, **options: Any) -> Any:
    """``numba.njit(cache=True, **options)(fn)``, falling back to no cache when no cache folder is writable.

    Usable as ``@jit`` or ``@jit(inline="always")``; compilation happens at the first call.
    """

    def wrap(f: Callable[..., Any]) -> Any:
        if cache:
            try:
                return numba.njit(cache=True, **options)(f)
            except RuntimeError:  # numba: "cannot cache function ...: no locator available"
                CACHE_FALLBACKS.append(f"{f.__module__}.{f.__qualname__}")
        return numba.njit(**options)(f)

    return wrap if fn is None else wrap(fn)
