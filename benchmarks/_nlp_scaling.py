"""The whole ``optimise_corridor`` call from 21 to 5 000 legs, this tree against a baseline commit (issue 13, performance).

``python -m benchmarks.bench_nlp --scaling [--baseline REF] [--full] [--sizes N …]``: ``bench_nlp``'s §4 great
circle through the moving 13 m storm (:func:`benchmarks._nlp_call._case`, ETA at 18 kn, ±40 nm), cut into N legs,
one ``optimise_corridor`` call per size and variant, each in a fresh process (``python -c`` of :func:`_child`) that
first makes one untimed 21-leg call (imports, numba kernels, CasADi plugins) and then times the N-leg call: wall
seconds and the process's CPU seconds (``time.process_time``: on a shared machine the wall clock also counts the
other users' load). With ``--baseline REF`` the same call of the commit ``REF`` (``git archive`` into a temporary
directory, removed afterwards) runs before this tree's at every size, so both meet much the same load; the table
gives the ratio of the CPU seconds, and checks that both return the same plan (fuel to 1e-9 relative, status).

Sizes: quick 21, 125, 500; ``--full`` adds 2 000 and 5 000. The fitted exponent is the slope of log CPU seconds
against log legs, over all sizes and over the sizes from 500 up. Targets (issue 13): ≤ 1 s at 21 legs, ≤ 2 s at
500 legs on this 2-core machine, exponent ≤ 1.2.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks._measure import load_line

QUICK_SIZES = (21, 125, 500)
FULL_SIZES = (21, 125, 500, 2000, 5000)
_ROOT = Path(__file__).resolve().parents[1]

_CHILD = """
import json, sys, time
sys.path.insert(0, {root!r})
import optroute as orx
from benchmarks._nlp_call import _case
assert orx.__file__.startswith({root!r}), orx.__file__
c = _case()
length = c.pop("length_nm")
orx.optimise_corridor(**c, max_leg_nm=length / 21 * (1 + 1e-9))  # warm-up: imports, numba, CasADi plugins
wall, cpu = time.perf_counter(), time.process_time()
plan = orx.optimise_corridor(**c, max_leg_nm=length / {legs} * (1 + 1e-9))
cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
st = plan.solver_stats
print(json.dumps({{"legs": int(st["n_legs"]), "wall_s": wall, "cpu_s": cpu, "fuel_t": plan.total_fuel_t,
                  "status": plan.status, "nlp_solves": int(st["nlp_solves"]), "iterations": int(st["iterations"]),
                  "ipopt_s": float(st["solve_time_s"]), "build_s": float(st["build_time_s"])}}))
"""


def _child(root: Path, legs: int) -> dict[str, Any]:
    """One timed call in a fresh process whose ``optroute`` is the one under ``root``."""
    code = _CHILD.format(root=str(root), legs=int(legs))
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, check=False)
    if out.returncode != 0:
        return {"legs": legs, "error": out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "failed"}
    return json.loads(out.stdout.strip().splitlines()[-1])


def _baseline_tree(ref: str) -> Path:
    """The files of commit ``ref`` in a temporary directory (``git archive``)."""
    tmp = Path(tempfile.mkdtemp(prefix="optroute-baseline-"))
    archive = subprocess.run(["git", "-C", str(_ROOT), "archive", ref], capture_output=True, check=True)
    subprocess.run(["tar", "-x", "-C", str(tmp)], input=archive.stdout, check=True)
    return tmp


def _exponent(rows: list[dict[str, Any]], smallest: int = 0) -> float:
    pts = [(r["legs"], r["cpu_s"]) for r in rows if "cpu_s" in r and r["legs"] >= smallest]
    if len(pts) < 2:
        return float("nan")
    legs, cpu = np.log(np.array(pts, dtype=float)).T
    return float(np.polyfit(legs, cpu, 1)[0])


def scaling(sizes: tuple[int, ...], baseline: str | None = None) -> dict[str, Any]:
    """Per size: the baseline's call (if any), then this tree's, each in a fresh process."""
    base_root = _baseline_tree(baseline) if baseline else None
    rows: dict[str, list[dict[str, Any]]] = {"this tree": []} | ({baseline: []} if baseline else {})
    try:
        for n in sizes:
            if base_root is not None:
                rows[str(baseline)].append(_child(base_root, n))
            rows["this tree"].append(_child(_ROOT, n))
            print(f"  {n} legs done ({load_line()})", flush=True)
    finally:
        if base_root is not None:
            shutil.rmtree(base_root, ignore_errors=True)
    fits = {name: {"all": _exponent(r), "from_500": _exponent(r, 500)} for name, r in rows.items()}
    return {"rows": rows, "exponent": fits, "baseline": baseline, "load": load_line()}


def print_scaling(s: dict[str, Any]) -> None:
    """The table: per size and variant, CPU and wall seconds, solves, iterations, status; the ratio to the baseline."""
    print("\n### The whole `optimise_corridor` call, 21 … 5 000 legs (§4's great circle through the storm)\n")
    print("_One call per size and variant, each in a fresh process after an untimed 21-leg call; CPU seconds of the "
          "process (the wall clock also counts the other users of the 2 shared cores)._\n")  # fmt: skip
    base = s["baseline"]
    print("| legs | variant | CPU [s] | wall [s] | CPU / baseline | Ipopt solves | iterations | status | fuel [t] |")
    print("|---:|---|---:|---:|---:|---:|---:|---|---:|")
    mine = s["rows"]["this tree"]
    for i in range(len(mine)):
        for name in [base, "this tree"] if base else ["this tree"]:
            row = s["rows"][name][i]
            if "error" in row:
                print(f"| {row['legs']} | {name} | | | | | | failed: {row['error']} | |")
                continue
            ref = s["rows"][base][i] if base else None
            ratio = f"{row['cpu_s'] / ref['cpu_s']:.2f}" if ref and "cpu_s" in ref else ""
            print(f"| {row['legs']} | {name} | {row['cpu_s']:.2f} | {row['wall_s']:.2f} | {ratio} | "
                  f"{row['nlp_solves']} | {row['iterations']} | {row['status']} | {row['fuel_t']:.6f} |")  # fmt: skip
    for name, fit in s["exponent"].items():
        print(f"\n{name}: CPU seconds ∝ N^{fit['all']:.2f} over all sizes, N^{fit['from_500']:.2f} from 500 legs up")
    if base:
        same = [
            abs(a["fuel_t"] / b["fuel_t"] - 1.0) <= 1e-9 and a["status"] == b["status"]
            for a, b in zip(mine, s["rows"][base], strict=True)
            if "fuel_t" in a and "fuel_t" in b
        ]
        print(f"same plan as {base} (fuel to 1e-9 relative, status): {sum(same)} of {len(same)} sizes")
    print(f"\n(targets: ≤ 1 s at 21 legs, ≤ 2 s at 500 legs, exponent ≤ 1.2; {s['load']})")


def main(argv: list[str]) -> dict[str, Any]:
    """``--full`` (2 000 and 5 000 legs too), ``--baseline REF``, ``--sizes N …``."""
    sizes = FULL_SIZES if "--full" in argv else QUICK_SIZES
    if "--sizes" in argv:
        sizes = tuple(int(a) for a in argv[argv.index("--sizes") + 1 :] if a.isdigit())
    baseline = argv[argv.index("--baseline") + 1] if "--baseline" in argv else None
    s = scaling(sizes, baseline)
    print_scaling(s)
    return s


if __name__ == "__main__":
    main(sys.argv[1:])
