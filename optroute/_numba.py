"""Numba's on-disk cache where a cache folder can be written, and compiled kernels without one where none can.

optroute's kernels are compiled with ``numba.njit(cache=True)``.  Numba looks
for a folder to cache them in — ``NUMBA_CACHE_DIR`` if set, the
``__pycache__`` beside the source, the user's cache folder
(``$XDG_CACHE_HOME/numba`` or ``~/.cache/numba``) — and when none of them is
writable (a read-only installation, a sandbox with a read-only home) it
refuses to *decorate* the function: ``RuntimeError: cannot cache function
...: no locator available``, raised while importing the module, so that
``optroute`` could not be used at all (issue 14, failure 8).

Two defences, neither importing numba when it is not needed:

* :func:`ensure_cache_dir`, called by ``optroute/__init__.py`` before any
  kernel module is imported, checks the folders numba would use (as numba
  does, by creating a temporary file in them) and, when none is writable,
  points ``NUMBA_CACHE_DIR`` at ``<temp dir>/optroute-numba-<uid>`` — a
  folder of the user's own that survives between runs, so the cache still
  works.  Kernels elsewhere (``optroute.search._kernels``) benefit as well.
* :func:`njit`, the decorator of the physics and weather kernels, compiles
  without a cache (each run then compiles again, a few seconds) when even that
  fallback cannot be written, instead of failing.
"""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["ensure_cache_dir", "jit", "njit"]

#: The subpackages holding ``cache=True`` kernels (their ``__pycache__`` is numba's in-tree cache); ``""`` is the
#: package itself (``geodesy``'s local WGS84 factor, compiled by ``optroute.search.edge_geometry``).
KERNEL_PACKAGES = ("", "physics", "weather", "search")
_LOCATORS = ("UserProvidedCacheLocator", "InTreeCacheLocator", "UserWideCacheLocator")
_warned = False


def _writable(folder: Path) -> bool:
    """Whether a file can be created in ``folder`` (created if missing), tested the way numba tests it."""
    probe = folder / f".optroute-write-probe-{os.getpid()}-{os.urandom(6).hex()}"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        os.close(os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))  # as tempfile.TemporaryFile does,
        os.unlink(probe)  # without importing tempfile (random, shutil, bz2, lzma) at every ``import optroute``
    except OSError:
        return False
    return True


def _user_wide() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "numba"


def fallback_dir() -> Path:
    """``<temp dir>/optroute-numba-<uid>``: the cache folder used when numba has none."""
    import tempfile

    uid = getattr(os, "getuid", lambda: "user")()
    return Path(tempfile.gettempdir()) / f"optroute-numba-{uid}"


def ensure_cache_dir() -> Path | None:
    """Give numba a writable cache folder when none of its own is writable.

    Follows numba's own search (``NUMBA_CACHE_LOCATOR_CLASSES`` when set, else
    its default locators): if ``NUMBA_CACHE_DIR``, every kernel package's
    ``__pycache__`` or the user-wide numba cache can be written, nothing
    changes.  Otherwise ``NUMBA_CACHE_DIR`` (and numba's configuration, if
    numba is already imported) is set to :func:`fallback_dir`.

    Returns
    -------
    Path or None
        The folder set, or None when numba's own search succeeds or nothing at all is writable.
    """
    wanted = os.environ.get("NUMBA_CACHE_LOCATOR_CLASSES")
    locators = [s.strip().rsplit(".", 1)[-1] for s in wanted.split(",")] if wanted else list(_LOCATORS)
    user_dir = os.environ.get("NUMBA_CACHE_DIR")
    package = Path(__file__).resolve().parent
    if "UserProvidedCacheLocator" in locators and user_dir and _writable(Path(user_dir)):
        return None
    if "InTreeCacheLocator" in locators and all(_writable(package / p / "__pycache__") for p in KERNEL_PACKAGES):
        return None
    if "UserWideCacheLocator" in locators and _writable(_user_wide()):
        return None
    folder = fallback_dir()
    if "UserProvidedCacheLocator" not in locators or not _writable(folder):
        return None
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    config = sys.modules.get("numba.core.config")
    if config is not None:
        config.CACHE_DIR = str(folder)
    return folder


def njit(**options: Any) -> Callable[[Callable[..., Any]], Any]:
    """``numba.njit(cache=True, **options)``, or without the cache when numba can write no cache folder.

    Raises
    ------
    ImportError
        numba is not installed (callers that treat it as optional catch this).

    Warns
    -----
    RuntimeWarning
        Once per process, when the kernels are compiled without a cache.
    """
    import numba

    def decorate(func: Callable[..., Any]) -> Any:
        global _warned
        try:
            return numba.njit(cache=True, **options)(func)
        except RuntimeError as exc:
            if "cannot cache" not in str(exc):
                raise
            if not _warned:
                _warned = True
                warnings.warn(
                    f"numba can write no cache folder ({exc}); optroute's kernels are compiled on each run "
                    f"(a few seconds): set NUMBA_CACHE_DIR to a writable folder to cache them",
                    RuntimeWarning,
                    stacklevel=3,
                )
            return numba.njit(cache=False, **options)(func)

    return decorate


def jit(fn: Callable[..., Any] | None = None, **options: Any) -> Any:
    """:func:`njit` as ``@jit`` or ``@jit(inline="always")``: numba compiles the function at its first call.

    Cached on disk where a cache folder can be written, else compiled on each run (see :func:`njit`).
    """
    decorate = njit(**options)
    return decorate if fn is None else decorate(fn)
