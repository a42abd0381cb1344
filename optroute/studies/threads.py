"""The process settings a solve needs, in this process and in every Dask worker: one BLAS thread for Ipopt's
linear algebra, and glibc's allocator thresholds where Dask's nanny pinned them low.

Ipopt (through CasADi) factorises its KKT systems with MUMPS, whose dense kernels call the
OpenBLAS that the CasADi wheel bundles (``libcasadi-tp-openblas``; MUMPS itself is built
without OpenMP).  A multi-threaded BLAS splits its sums by thread, so the same solve run
with another thread count rounds differently, and Ipopt's iterates — hence a front's fuel
in the last bits and, through the band outer loop, sometimes more — depend on the number
of cores.  Dask's nanny starts workers with ``OPENBLAS_NUM_THREADS=1``
(``distributed.nanny.pre-spawn-environ``) while an interactive process has one thread per
core: :func:`pin_solver_threads` sets the bundled OpenBLAS to one thread in whatever
process solves, so a front is the same serial, on a cluster and on another machine.

The same nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_=65536`` (Dask's remedy for unmanaged memory). Any
such variable turns off glibc's dynamic mmap threshold, which stays at 128 KiB: every larger array (the NLP's
weather blocks and buffers) is then mapped and unmapped, its pages zeroed, at every allocation, and a worker's
solves run markedly slower than the same solves in a plain process (``python -m benchmarks.bench_front`` times a
front serial and on 2 workers). :func:`solver_malloc` sets the two thresholds where glibc's dynamic rule would take
them.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import glob
import os
import threading

__all__ = ["MMAP_THRESHOLD_BYTES", "pin_solver_threads", "solver_blas_threads", "solver_malloc", "solver_process"]

#: glibc's mmap threshold for a solving process [bytes]: the largest its dynamic rule reaches on a 64-bit machine
#: (``DEFAULT_MMAP_THRESHOLD_MAX``, mallopt(3)); the trim threshold is set to twice it, as that rule sets it.
MMAP_THRESHOLD_BYTES = 32 * 2**20
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # mallopt parameters (malloc.h)
#: the environment variables that turn glibc's dynamic mmap threshold off (mallopt(3))
_MALLOC_VARIABLES = ("MALLOC_TRIM_THRESHOLD_", "MALLOC_MMAP_THRESHOLD_", "MALLOC_TOP_PAD_", "MALLOC_MMAP_MAX_")

_LOCK = threading.Lock()
_PINNED: list[bool] = []
_MALLOC_SET: list[bool] = []


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


def solver_malloc() -> bool:
    """Raise glibc's mmap and trim thresholds in this process (once) where an environment variable pinned them;
    True when they were set.

    Only where one of ``MALLOC_TRIM_THRESHOLD_``, ``MALLOC_MMAP_THRESHOLD_``, ``MALLOC_TOP_PAD_`` or
    ``MALLOC_MMAP_MAX_`` is set (a Dask worker: the nanny's ``distributed.nanny.pre-spawn-environ``) and the C
    library has ``mallopt`` (glibc): elsewhere the allocator's own rule is left alone. The mmap threshold becomes
    :data:`MMAP_THRESHOLD_BYTES`, the trim threshold twice it: memory up to that much stays with the process
    between solves instead of going back to the system at every free.
    """
    with _LOCK:
        if _MALLOC_SET:
            return _MALLOC_SET[0]
        ok = False
        if any(name in os.environ for name in _MALLOC_VARIABLES):
            try:
                libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
                mallopt = libc.mallopt
            except (OSError, AttributeError):  # not glibc (macOS, musl without mallopt): nothing to set
                mallopt = None
            if mallopt is not None:
                ok = bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(
                    mallopt(_M_TRIM_THRESHOLD, 2 * MMAP_THRESHOLD_BYTES)
                )
        _MALLOC_SET.append(ok)
        return ok


def solver_process() -> None:
    """This process set up for solves: Ipopt's BLAS on one thread (:func:`pin_solver_threads`) and the allocator's
    thresholds (:func:`solver_malloc`); cheap after the first call."""
    pin_solver_threads()
    solver_malloc()
