"""optroute imports and runs its numba kernels when numba can write no cache folder (issue 14, failure 8).

Numba refuses to *decorate* a ``cache=True`` function when none of its cache folders is writable, which
made ``import`` of every kernel module fail.  Each case runs in a fresh interpreter (numba's configuration
is read once per process).  ``NUMBA_CACHE_LOCATOR_CLASSES`` restricts numba's search to the folders named,
which stands in for a read-only installation and home folder even when the tests run as root (for whom
permissions do not stop a write); the unwritable ``NUMBA_CACHE_DIR`` lies below a regular file, which no
one can write into.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("numba")

ROOT = Path(__file__).resolve().parents[1]

USE_KERNELS = """
import os, warnings
import numpy as np
import optroute as orx
from optroute.physics.performance import KwonModel
from optroute.weather.sample import WeatherSampler
ship = orx.Ship.preset("container_54k_dwt")
# Kwon's speed loss inverted by a numba kernel: at Hs 0 the brake power is the calm-water power
p = KwonModel(ship).brake_power_kw(np.array([18.0]), hs_m=np.array([0.0]), wave_angle_deg=np.array([0.0]))
assert abs(p[0] / float(ship.calm_power_kw(18.0)) - 1.0) < 1e-9, p
wx = orx.scenarios.uniform(hs_m=2.5, tp_s=8.0, bbox=(-10, 10, -40, 0), start=np.datetime64("2024-01-10"),
                           duration_h=24, resolution_deg=1.0)
n = 5000  # above the sampler's threshold for its numba kernel
got = WeatherSampler(wx, engine="numba").sample(np.full(n, np.datetime64("2024-01-10T05")), np.zeros(n),
                                                np.linspace(-30.0, -20.0, n))
assert np.allclose(got["hs_m"], 2.5), got["hs_m"][:3]
print("kernels ran; NUMBA_CACHE_DIR=" + os.environ.get("NUMBA_CACHE_DIR", ""))
"""


def _run(code: str, env: dict[str, str]) -> subprocess.CompletedProcess:
    full = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")} | env
    return subprocess.run(
        [sys.executable, "-W", "always::RuntimeWarning", "-c", code],
        cwd=ROOT,
        env=full,
        capture_output=True,
        text=True,
        timeout=600,
    )


def _unwritable(tmp_path: Path) -> Path:
    blocker = tmp_path / "a_regular_file"
    blocker.write_text("numba cannot make a folder below a file")
    return blocker / "numba_cache"


def test_unwritable_numba_cache_dir_falls_back_to_a_folder_of_the_users_own(tmp_path):
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = {
        "NUMBA_CACHE_DIR": str(_unwritable(tmp_path)),
        "NUMBA_CACHE_LOCATOR_CLASSES": "UserProvidedCacheLocator",
        "TMPDIR": str(tmp),
    }
    code = USE_KERNELS + "import optroute.search.dijkstra\n"  # the search's cache=True kernels decorate too
    out = _run(code, env)
    assert out.returncode == 0, out.stderr[-3000:]
    fallback = tmp / f"optroute-numba-{os.getuid()}"
    assert f"NUMBA_CACHE_DIR={fallback}" in out.stdout
    assert any(fallback.iterdir())  # the kernels were cached there, for the next run
    assert "Traceback" not in out.stderr


def test_no_cache_folder_at_all_compiles_the_kernels_uncached_with_one_warning(tmp_path):
    env = {"NUMBA_CACHE_DIR": str(_unwritable(tmp_path)), "NUMBA_CACHE_LOCATOR_CLASSES": "ZipCacheLocator"}
    out = _run(USE_KERNELS, env)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "kernels ran" in out.stdout
    assert out.stderr.count("numba can write no cache folder") == 1


def _fake_package(root: Path) -> Path:
    """A package tree like optroute's: a module in each source package and in one outside them, each kernel
    package's ``__pycache__`` holding a numba index and data file."""
    from optroute._numba import KERNEL_PACKAGES, SOURCE_PACKAGES

    for sub in {*SOURCE_PACKAGES, "optimise"}:
        (root / sub).mkdir(parents=True, exist_ok=True)
        (root / sub / "mod.py").write_text("X = 1\n")
    for sub in KERNEL_PACKAGES:
        (root / sub / "__pycache__").mkdir(exist_ok=True)
    return root


def _cache_files(root: Path, make: bool = False) -> list[Path]:
    from optroute._numba import KERNEL_PACKAGES

    files = [
        root / sub / "__pycache__" / f"mod.kernel-1.py311.{ext}" for sub in KERNEL_PACKAGES for ext in ("nbi", "nbc")
    ]
    if make:
        for f in files:
            f.write_bytes(b"compiled")
    return [f for f in files if f.exists()]


def test_the_in_tree_cache_is_cleared_when_a_source_a_kernel_may_compile_in_changes(tmp_path):
    # numba keys a kernel's cache on its own file only: an edited callee in another module kept the old code running
    from optroute._numba import clear_stale_in_tree

    root = _fake_package(tmp_path / "pkg")
    _cache_files(root, make=True)
    assert clear_stale_in_tree(root) and _cache_files(root) == []  # no record yet: the cache predates it
    _cache_files(root, make=True)
    assert not clear_stale_in_tree(root) and len(_cache_files(root)) == 8  # nothing changed: kept
    (root / "optimise" / "mod.py").write_text("X = 2  # not code a kernel compiles in\n")
    assert not clear_stale_in_tree(root) and len(_cache_files(root)) == 8
    (root / "geo" / "mod.py").write_text("X = 22\n")  # a constant a search kernel could read
    assert clear_stale_in_tree(root) and _cache_files(root) == []
    _cache_files(root, make=True)
    stamp = next((root / "__pycache__").glob("*.stamp"))
    os.utime(root / "search" / "mod.py", ns=(0, 0))  # the same text with another time stamp (a checkout)
    assert clear_stale_in_tree(root) and _cache_files(root) == []
    assert stamp.read_text().count("\n") == 5 and not list((root / "__pycache__").glob("*.tmp"))
