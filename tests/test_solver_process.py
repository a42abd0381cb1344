"""A solving process's settings (:mod:`optroute.studies.threads`), checked by glibc's own accounting.

Dask's nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_=65536``, which pins glibc's mmap threshold at 128 KiB:
every larger array is mapped and unmapped at each allocation. ``solver_malloc`` raises the threshold where such a
variable is set. The check counts the blocks glibc has mapped (``mallinfo2().hblks``, glibc ≥ 2.33) around the
allocation of a 1 MiB buffer, in a fresh process started as a Dask worker is.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import subprocess
import sys

import pytest

_CHILD = """
import ctypes, ctypes.util, json, os
import numpy as np

class Mallinfo2(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in
                ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks",
                 "keepcost")]

libc = ctypes.CDLL(ctypes.util.find_library("c"))
libc.mallinfo2.restype = Mallinfo2

def mapped_by(nbytes):
    before = libc.mallinfo2().hblks
    a = np.ones(nbytes // 8)
    after = libc.mallinfo2().hblks
    del a
    return after - before

from optroute.studies.threads import solver_malloc, solver_process
out = {"before": mapped_by(2**20)}
out["set"] = solver_malloc()
out["after"] = mapped_by(2**20)
out["again"] = solver_malloc()
solver_process()
out["big"] = mapped_by(64 * 2**20)  # above the raised threshold: still mapped
print(json.dumps(out))
"""


def _glibc_with_mallinfo2() -> bool:
    try:
        return hasattr(ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6"), "mallinfo2")
    except OSError:
        return False


def _run(env: dict[str, str]) -> dict:
    import json

    out = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not _glibc_with_mallinfo2(), reason="needs glibc >= 2.33 (mallinfo2)")
def test_a_dask_workers_malloc_threshold_is_raised_and_a_plain_process_is_left_alone():
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    worker = _run({**env, "MALLOC_TRIM_THRESHOLD_": "65536"})  # as distributed.nanny.pre-spawn-environ sets it
    assert worker["before"] == 1  # pinned at 128 KiB: a 1 MiB array is mapped
    assert worker["set"] is True and worker["again"] is True
    assert worker["after"] == 0  # below the raised threshold: from the heap
    assert worker["big"] == 1  # above 32 MiB: mapped, as glibc's own rule maps it
    plain = _run(env)  # no variable: glibc's dynamic rule stays, nothing is set
    assert plain["set"] is False


_STUDY_CHILD = """
import ctypes, json, sys
from optroute.studies.threads import _casadi_openblas, solver_blas_threads
from optroute.studies.study import run_study

lib = _casadi_openblas()
lib.openblas_set_num_threads(ctypes.c_int(2))  # a plain process's thread count on this 2-core machine
before = solver_blas_threads()
ds = run_study({"x": [1.0, 2.0]}, lambda p: {"blas_threads": float(solver_blas_threads())}, sys.argv[1],
               scheduler_address="synchronous")
print(json.dumps({"before": before, "in_case": ds["blas_threads"].values.tolist()}))
"""


def test_a_study_case_solves_with_ipopts_blas_on_one_thread_as_on_a_dask_worker(tmp_path):
    """A user's case function given to ``run_study`` runs in a process set up as a Dask worker's solves are (one
    thread for the OpenBLAS that Ipopt's MUMPS uses), so the same case rounds alike serial and on a cluster. Checked in
    a fresh process, where nothing has pinned the thread count yet, through OpenBLAS's own getter."""
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    done = subprocess.run(
        [sys.executable, "-c", _STUDY_CHILD, str(tmp_path / "store")],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    import json

    out = json.loads(done.stdout.strip().splitlines()[-1])
    if out["before"] < 2:  # OpenBLAS keeps one thread on a one-core machine: nothing to tell apart
        pytest.skip("OpenBLAS runs one thread on this machine whatever is asked")
    assert out["in_case"] == [1.0, 1.0]
