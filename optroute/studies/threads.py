"""One BLAS thread for Ipopt's linear algebra, in this process and in every Dask worker.

Ipopt (through CasADi) factorises its KKT systems with MUMPS, whose dense kernels call the
OpenBLAS that the CasADi wheel bundles (``libcasadi-tp-openblas``; MUMPS itself is built
without OpenMP).  A multi-threaded BLAS splits its sums by thread, so the same solve run
with another thread count rounds differently, and Ipopt's iterates — hence a front's fuel
in the last bits and, through the band outer loop, sometimes more — depend on the number
of cores.  Dask's nanny starts workers with ``OPENBLAS_NUM_THREADS=1``
(``distributed.nanny.pre-spawn-environ``) while an interactive process has one thread per
core: :func:`pin_solver_threads` sets the bundled OpenBLAS to one thread in whatever
process solves, so a front is the same serial, on a cluster and on another machine.
"""

from __future__ import annotations

import ctypes
import glob
import os
import threading

__all__ = ["pin_solver_threads", "solver_blas_threads"]

_LOCK = threading.Lock()
_PINNED: list[bool] = []


def _casadi_openblas() -> ctypes.CDLL | None:
    """CasADi's bundled OpenBLAS (the copy Ipopt and MUMPS use), or None when the wheel has none."""
    try:
        import casadi
    except ImportError:  # pragma: no cover - casadi is a dependency
        return None
    folder = os.path.dirname(casadi.__file__)
    found = sorted(glob.glob(os.path.join(folder, "libcasadi-tp-openblas.so.0")))
    found += sorted(glob.glob(os.path.join(folder, "libcasadi-tp-openblas*.so*")))
    found += sorted(glob.glob(os.path.join(folder, "libcasadi-tp-openblas*.dylib")))
    for path in found:
        try:
            # the soname Ipopt links against: dlopen returns the instance already loaded, or the one it will use
            return ctypes.CDLL(path)
        except OSError:
            continue
    return None


def pin_solver_threads() -> bool:
    """Set the OpenBLAS that Ipopt uses to one thread in this process (once); True when it was found.

    Other BLAS libraries (NumPy's) are left alone: only Ipopt's factorisations decide a solve's iterates.
    """
    with _LOCK:
        if _PINNED:
            return _PINNED[0]
        lib = _casadi_openblas()
        ok = lib is not None and hasattr(lib, "openblas_set_num_threads")
        if ok:
            lib.openblas_set_num_threads(ctypes.c_int(1))  # type: ignore[union-attr]
        _PINNED.append(bool(ok))
        return bool(ok)


def solver_blas_threads() -> int | None:
    """The thread count of Ipopt's OpenBLAS in this process (None when it cannot be read)."""
    lib = _casadi_openblas()
    if lib is None or not hasattr(lib, "openblas_get_num_threads"):
        return None
    return int(lib.openblas_get_num_threads())
