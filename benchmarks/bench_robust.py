"""Robust corridor NLP: build and solve against the number of ensemble members, exact Hessian against L-BFGS.

The members are those of ``benchmarks.bench_voyage``'s robust plan (c) on its first case (the ensemble about the
first forecast of the 300 nm-north storm, ``optroute.weather.scenarios.ensemble`` seed 1 with the suite's forecast-error
spread, ``bench_voyage.suite_error_spread``), prepared as
``optimise_corridor(robust="all")`` prepares them (18 legs, 5 samples a leg, the 31×36×41-node weather grid with
the ship's power table, 44 fields). For each M: the :class:`formulations.robust_nlp.RobustSpeedNLP` build (wall and
this process's CPU [s]: on a shared machine the CPU is the figure to compare) and
its band re-imposition loop from the constant-speed centreline start (ETA 42 h, fuel objective) — Ipopt iterations,
solves, Ipopt time and objective — with the exact Hessian (default: the members' leg-by-leg derivative cores with the
weather's second derivatives), the Hessian without them (``weather_curvature=False``) and, as the baseline of
the same run, Ipopt's limited-memory approximation (what the robust plans used before; full mode: up to 4 members,
it needs ~10x the iterations). The members' preparation (``prepare_members``: each member's corridor weather and
power table) is timed once for the largest M and given per member. Full mode runs the two baselines up to 4
members only, draws 26 members and measures the scaling on those whose own (single-member) problem the NLP solves
from the centreline start — one robust plan for every member is infeasible when one member alone is (seed 1's
member 8 puts the storm over the destination: ``optimise_corridor`` on it alone returns its DP start, racing at
26.5 kn) — and reports the first ten members unscreened as one more line. Fitted exponents are least squares of log time
on log M.

Run ``python -m benchmarks.bench_robust [--quick]`` (quick: M = 1, 2 and 4; full: 1, 2, 4, 10, 20).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

import optroute as orx
from benchmarks import bench_voyage as bv
from benchmarks._cli import bench_main
from formulations.robust_nlp import RobustSpeedNLP
from optroute.optimise.nlp_inputs import formulation_bands
from optroute.optimise.robust import member_datasets, prepare_members
from optroute.weather import forecast as fc
from optroute.weather import scenarios as sc

ETA_H = 42.0


def _members(n: int) -> tuple[Any, list, Any, Any]:
    _, dist, brg, delay, fac, _, _ = bv.CASES[0]
    first = fc.displaced_storms(
        [bv._storm()], displacement_nm=dist, bearing_deg=brg, delay_h=delay, intensity_factor=fac
    )
    ens = sc.ensemble(
        bv._storm_dataset, n, seed=1, storms=first, background_hs_m=1.5, **bv.suite_error_spread(), **bv.KW
    )
    corridor = orx.Corridor.from_waypoints([bv.A, bv.B], width_nm=bv.ROBUST_WIDTH_NM)
    shared = bv.shared_options()
    cpu = time.process_time()
    prepared, y_lo, y_hi = prepare_members(corridor, member_datasets(ens), bv.SHIP, shared, 0)
    print(
        f"prepare_members: {n} members in {time.process_time() - cpu:.1f} CPU-s ({(time.process_time() - cpu) / n:.2f} per member)"
    )
    return prepared[0], [p.grid for p in prepared], y_lo, y_hi


#: Hessian variants: (label, RobustSpeedNLP keywords)
VARIANTS = (
    ("exact", {}),
    ("exact, no weather curvature", {"weather_curvature": False}),
    ("L-BFGS", {"exact_hessian": False}),
)


def _one(ref: Any, grids: list, y_lo: Any, y_hi: Any, variant: dict) -> dict[str, Any]:
    bands, _, a = formulation_bands(ref.ship, ref.rules, widen=ref.margin0, hs_margin=ref.hs_margin0)
    started, cpu = time.perf_counter(), time.process_time()
    nlp = RobustSpeedNLP(
        ref.frame.geometry(y_lo, y_hi), grids, ref.power, bands=bands, samples_per_leg=ref.samples_per_leg,
        v_min_kn=ref.v_min, v_max_kn=ref.v_max, g_over_2pi_kn_s=a, **variant,
    )  # fmt: skip
    build, build_cpu = time.perf_counter() - started, time.process_time() - cpu
    n = ref.frame.n_legs
    cpu = time.process_time()
    res = nlp.solve_sides(
        eta_h=ETA_H, offset0_nm=np.zeros(n + 1), stw0_kn=np.full(n, ref.length_nm / ETA_H), max_solves=6
    )
    return {
        "build_s": build, "build_cpu_s": build_cpu, "solve_cpu_s": time.process_time() - cpu, "iterations": res.iterations, "solves": res.solves, "ipopt_s": res.solve_time_s,
        "status": res.status, "objective_t": res.objective, "max_violation": res.max_violation,
    }  # fmt: skip


#: Members drawn beyond the largest M in full mode, to replace those screened out.
EXTRA = 6


def _exponent(ms: list[int], values: list[float]) -> float:
    if len(ms) < 2:
        return float("nan")
    return float(np.polyfit(np.log(ms), np.log(np.maximum(values, 1e-9)), 1)[0])


def run(quick: bool, members: list[int] | None = None) -> dict[str, Any]:
    """The table for M in ``members`` (default: quick 1, 2, 4; full 1, 2, 4, 10, 20)."""
    ms = members or ([1, 2, 4] if quick else [1, 2, 4, 10, 20])
    ref, grids, y_lo, y_hi = _members(max(ms) + (0 if quick else EXTRA))
    if not quick:  # the scaling is measured on members each solvable alone; the raw first ten are one more row
        solvable = [k for k, g in enumerate(grids) if _one(ref, [g], y_lo, y_hi, {})["status"] == "Solve_Succeeded"]
        print(f"members whose own problem the NLP does not solve from the start (screened out): "
              f"{sorted(set(range(len(grids))) - set(solvable))}")  # fmt: skip
        raw = _one(ref, grids[:10], y_lo, y_hi, {})
        print(f"the first 10 members unscreened: {raw['iterations']} iterations, {raw['solves']} solves, "
              f"{raw['solve_cpu_s']:.1f} CPU-s, {raw['status']}")  # fmt: skip
        grids = [grids[k] for k in solvable]
        ms = [m for m in ms if m <= len(grids)]
    rows = []
    print(
        "| M | Hessian | build [s] | build CPU [s] | Ipopt iterations | solves | Ipopt [s] | solve CPU [s] | status | "
        f"mean fuel [t] | build CPU / exact M={ms[0]} |"
    )
    print("|---:|---|---:|---:|---:|---:|---:|---:|---|---:|---:|")
    for m in ms:
        for label, variant in VARIANTS:
            if label != "exact" and not quick and m > 4:
                continue
            r = {"members": m, "hessian": label, **_one(ref, grids[:m], y_lo, y_hi, variant)}
            rows.append(r)
            base = rows[0]["build_cpu_s"]
            print(
                f"| {m} | {r['hessian']} | {r['build_s']:.1f} | {r['build_cpu_s']:.1f} | {r['iterations']} | "
                f"{r['solves']} | {r['ipopt_s']:.1f} | {r['solve_cpu_s']:.1f} | {r['status']} | {r['objective_t']:.4f} | "
                f"{r['build_cpu_s'] / base:.2f} |",
                flush=True,
            )
    for h, _ in VARIANTS:
        sel = [r for r in rows if r["hessian"] == h]
        mm = [r["members"] for r in sel]
        print(
            f"{h}: fitted exponent in M — build CPU {_exponent(mm, [r['build_cpu_s'] for r in sel]):.2f}, solve CPU "
            f"{_exponent(mm, [r['solve_cpu_s'] for r in sel]):.2f}, iterations {_exponent(mm, [r['iterations'] for r in sel]):.2f}"
        )
    return {"rows": rows}


def main(argv: list[str] | None = None) -> None:
    bench_main(run, __doc__.splitlines()[0], "M = 1, 2, 4 instead of 1, 2, 4, 10, 20", argv)


if __name__ == "__main__":
    main()
