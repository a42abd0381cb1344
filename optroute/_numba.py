"""Numba's on-disk cache where a cache folder can be written, and compiled kernels without one where none can.

optroute's kernels are compiled with ``numba.njit(cache=True)``.  Numba looks
for a folder to cache them in — ``NUMBA_CACHE_DIR`` if set, the
``__pycache__`` beside the source, the user's cache folder
(``$XDG_CACHE_HOME/numba`` or ``~/.cache/numba``) — and when none of them is
writable (a read-only installation, a sandbox with a read-only home) it
refuses to *decorate* the function: ``RuntimeError: cannot cache function
...: no locator available``, raised while importing the module, so that
``optroute`` could not be used at all (issue 14, failure 8).

Three defences, none importing numba:

* :func:`ensure_cache_dir`, called by ``optroute/__init__.py`` before any
  kernel module is imported, checks the folders numba would use (as numba
  does, by creating a temporary file in them) and, when none is writable,
  points ``NUMBA_CACHE_DIR`` at ``<temp dir>/optroute-numba-<uid>`` — a
  folder of the user's own that survives between runs, so the cache still
  works.  Kernels elsewhere (``optroute.search._kernels``) benefit as well.
* :func:`njit`, the decorator of the physics and weather kernels, compiles
  without a cache (each run then compiles again, a few seconds) when even that
  fallback cannot be written, instead of failing.
* :func:`clear_stale_in_tree`, called by :func:`ensure_cache_dir` when the
  cache is numba's in-tree one: numba keys a kernel's cache on its own source
  file's time stamp and size alone, so a kernel whose callee (or a constant it
  reads) lives in another, edited module kept running the old code from the
  cache.  The in-tree cache is cleared whenever any module of
  :data:`SOURCE_PACKAGES` has changed since it was written.
"""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["clear_stale_in_tree", "ensure_cache_dir", "jit", "njit", "sources_stamp"]

#: The subpackages holding ``cache=True`` kernels (their ``__pycache__`` is numba's in-tree cache); ``""`` is the
#: package itself (``geodesy``'s local WGS84 factor, compiled by ``optroute.search.edge_geometry``).
KERNEL_PACKAGES = ("", "physics", "weather", "search")
#: The subpackages whose code the kernels compile in (their own modules, the functions and constants they take from
#: other modules): a change to any of their modules clears the in-tree cache (:func:`clear_stale_in_tree`).
SOURCE_PACKAGES = ("", "physics", "weather", "geo", "search")
#: The file in the package's ``__pycache__`` that records the sources the in-tree cache was compiled from.
STAMP_FILE = "optroute-kernel-sources.stamp"
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
        clear_stale_in_tree(package)
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


def sources_stamp(package: Path) -> str:
    """Every module of :data:`SOURCE_PACKAGES` under ``package`` as ``path mtime_ns size`` lines (numba's own key)."""
    rows = []
    for sub in SOURCE_PACKAGES:
        for f in sorted((package / sub).glob("*.py")):
            try:
                st = f.stat()
            except OSError:
                continue
            rows.append(f"{f.relative_to(package).as_posix()} {st.st_mtime_ns} {st.st_size}")
    return "\n".join(rows) + "\n"


def clear_stale_in_tree(package: Path) -> bool:
    """Delete the in-tree kernel cache (``*.nbi``, ``*.nbc`` in :data:`KERNEL_PACKAGES`' ``__pycache__``) when the
    sources it was compiled from have changed; record the sources. Whether it was cleared.

    The record is :data:`STAMP_FILE` in ``package/__pycache__``, written whole (a temporary file renamed over it).
    Best effort: a file that cannot be read, deleted or written is left as it is (numba then recompiles or
    loads as it would without this check), and importing never fails for it.
    """
    stamp = package / "__pycache__" / STAMP_FILE
    now = sources_stamp(package)
    try:
        if stamp.read_text() == now:
            return False
    except (OSError, UnicodeDecodeError):
        pass  # no record yet (a fresh clone or installation): whatever cache there is predates it
    cleared = False
    for sub in KERNEL_PACKAGES:
        for f in [*(package / sub / "__pycache__").glob("*.nbi"), *(package / sub / "__pycache__").glob("*.nbc")]:
            try:
                f.unlink()
                cleared = True
            except OSError:
                pass
    tmp = stamp.with_name(f"{STAMP_FILE}.{os.getpid()}.tmp")
    try:
        tmp.write_text(now)
        os.replace(tmp, stamp)
    except OSError:
        try:
            tmp.unlink()
        except OSError:
            pass
    return cleared


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
