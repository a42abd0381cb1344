"""Start-up benchmark: how long ``import optroute`` and ``optroute --help`` make a user wait.

Issue 12 asks for ``import optroute`` ≤ 1 s and ``optroute --help`` ≤ 0.5 s, measured against
``python -c "import xarray"`` in the same run. Each command runs as a fresh subprocess from the
checkout's root (so this tree's optroute is the one imported), the commands interleaved round by
round so that they share the machine's load; the table gives the median wall time and the median
CPU time (user + system, from ``getrusage`` of the child: less sensitive to a busy machine) of
each, and their ratios to ``import xarray``. ``python -c pass`` is the interpreter's own start-up,
the floor every command pays.

Run ``python -m benchmarks.bench_startup [--quick]``.
"""

from __future__ import annotations

import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from benchmarks._cli import bench_main

ROOT = Path(__file__).resolve().parents[1]

#: name → the command's arguments after the interpreter; the baseline is ``import xarray``.
COMMANDS: dict[str, list[str]] = {
    "python -c pass": ["-c", "pass"],
    'python -c "import xarray"': ["-c", "import xarray"],
    'python -c "import optroute"': ["-c", "import optroute"],
    "python -m optroute --help": ["-m", "optroute", "--help"],
    "python -m optroute --version": ["-m", "optroute", "--version"],
}
BASELINE = 'python -c "import xarray"'
#: Issue 12's budgets on its reference machine [s], quoted beside the medians (never asserted).
TARGETS_S = {'python -c "import optroute"': 1.0, "python -m optroute --help": 0.5}


def _run_once(args: list[str]) -> tuple[float, float]:
    """Wall time and child CPU time (user + system) of one fresh interpreter running ``args`` [s]."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=600)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise RuntimeError(f"{args} exited {proc.returncode}: {proc.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def run(quick: bool = False) -> dict[str, Any]:
    """Time every command ``rounds`` times, interleaved; print the table; return the figures."""
    rounds = 3 if quick else 9
    for args in COMMANDS.values():  # warm the file cache and the bytecode once, untimed
        _run_once(args)
    walls: dict[str, list[float]] = {name: [] for name in COMMANDS}
    cpus: dict[str, list[float]] = {name: [] for name in COMMANDS}
    for _ in range(rounds):
        for name, args in COMMANDS.items():
            wall, cpu = _run_once(args)
            walls[name].append(wall)
            cpus[name].append(cpu)
    wall_med = {name: statistics.median(v) for name, v in walls.items()}
    cpu_med = {name: statistics.median(v) for name, v in cpus.items()}
    base_wall, base_cpu = wall_med[BASELINE], cpu_med[BASELINE]
    print(f"Median of {rounds} fresh interpreters per command, interleaved; baseline `{BASELINE}`.\n")
    print("| command | wall [s] | CPU [s] | wall / baseline | CPU / baseline | issue 12 budget |")
    print("|---|---:|---:|---:|---:|---|")
    for name in COMMANDS:
        target = TARGETS_S.get(name)
        budget = "–" if target is None else f"≤ {target:g} s wall ({'met' if wall_med[name] <= target else 'not met'})"
        print(
            f"| `{name}` | {wall_med[name]:.3f} | {cpu_med[name]:.3f} | {wall_med[name] / base_wall:.2f} | "
            f"{cpu_med[name] / base_cpu:.2f} | {budget} |"
        )
    print()
    return {
        "rounds": rounds,
        "baseline": BASELINE,
        "wall_s": walls,
        "cpu_s": cpus,
        "median_wall_s": wall_med,
        "median_cpu_s": cpu_med,
        "wall_ratio_to_baseline": {name: wall_med[name] / base_wall for name in COMMANDS},
        "cpu_ratio_to_baseline": {name: cpu_med[name] / base_cpu for name in COMMANDS},
    }


if __name__ == "__main__":
    bench_main(run, __doc__.splitlines()[0], "3 rounds instead of 9")
