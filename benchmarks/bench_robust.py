"""Robust corridor NLP: build and solve against the number of ensemble members, exact Hessian against L-BFGS.

The members are those of ``benchmarks.bench_voyage``'s robust plan (c) on its first case (the ensemble about the
first forecast of the 300 nm-north storm, ``optroute.weather.scenarios.ensemble`` seed 1), prepared as
``optimise_corridor(robust="all")`` prepares them (18 legs, 5 samples a leg, the 31×36×41-node weather grid with
the ship's power table, 44 fields). For each M: the :class:`formulations.robust_nlp.RobustSpeedNLP` build (wall and
this process's CPU [s]: on a shared machine the CPU is the figure to compare) and
its band re-imposition loop from the constant-speed centreline start (ETA 42 h, fuel objective) — Ipopt iterations,
solves, Ipopt time and objective — with the exact Hessian (default) and, as the baseline of the same run, Ipopt's
limited-memory approximation (what the robust plans used before). Fitted exponents are least squares of log time
on log M.

Run ``python -m benchmarks.bench_robust [--quick]`` (quick: M = 1, 2 and 4; full: 2, 4, 10, 20).
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
    ens = sc.ensemble(bv._storm_dataset, n, seed=1, storms=first, background_hs_m=1.5, **bv.ENSEMBLE, **bv.KW)
    corridor = orx.Corridor.from_waypoints([bv.A, bv.B], width_nm=bv.ROBUST_WIDTH_NM)
    o = bv.OPTS
    shared = {
        "departure": bv.T0, "latest_eta": bv.ETA, "objective": "fuel", "model": None, "rules": None,
        "max_leg_nm": o["max_leg_nm"], "samples_per_leg": o["samples_per_leg"], "fuel_price_per_t": 600.0,
        "hourly_cost_per_h": 0.0, "exclusion": None, "speed_range_kn": None, "band_margin": o["band_margin"],
        "band_hs_margin": o["band_hs_margin"], "verify_step_nm": 5.0, "use_land_mask": False,
    }  # fmt: skip
    prepared, y_lo, y_hi = prepare_members(corridor, member_datasets(ens), bv.SHIP, shared, 0)
    return prepared[0], [p.grid for p in prepared], y_lo, y_hi


def _one(ref: Any, grids: list, y_lo: Any, y_hi: Any, exact: bool) -> dict[str, Any]:
    bands, _, a = formulation_bands(ref.ship, ref.rules, widen=ref.margin0, hs_margin=ref.hs_margin0)
    started, cpu = time.perf_counter(), time.process_time()
    nlp = RobustSpeedNLP(
        ref.frame.geometry(y_lo, y_hi), grids, ref.power, bands=bands, samples_per_leg=ref.samples_per_leg,
        v_min_kn=ref.v_min, v_max_kn=ref.v_max, g_over_2pi_kn_s=a, exact_hessian=exact,
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


def _exponent(ms: list[int], values: list[float]) -> float:
    if len(ms) < 2:
        return float("nan")
    return float(np.polyfit(np.log(ms), np.log(np.maximum(values, 1e-9)), 1)[0])


def run(quick: bool, members: list[int] | None = None) -> dict[str, Any]:
    """The table for M in ``members`` (default: quick 1, 2, 4; full 2, 4, 10, 20)."""
    ms = members or ([1, 2, 4] if quick else [2, 4, 10, 20])
    ref, grids, y_lo, y_hi = _members(max(ms))
    rows = []
    print(
        "| M | Hessian | build [s] | build CPU [s] | Ipopt iterations | solves | Ipopt [s] | solve CPU [s] | status | "
        f"mean fuel [t] | build CPU / exact M={ms[0]} |"
    )
    print("|---:|---|---:|---:|---:|---:|---:|---:|---|---:|---:|")
    for m in ms:
        for exact in (True, False):
            r = {"members": m, "hessian": "exact" if exact else "L-BFGS", **_one(ref, grids[:m], y_lo, y_hi, exact)}
            rows.append(r)
            base = rows[0]["build_cpu_s"]
            print(
                f"| {m} | {r['hessian']} | {r['build_s']:.1f} | {r['build_cpu_s']:.1f} | {r['iterations']} | "
                f"{r['solves']} | {r['ipopt_s']:.1f} | {r['solve_cpu_s']:.1f} | {r['status']} | {r['objective_t']:.4f} | "
                f"{r['build_cpu_s'] / base:.2f} |",
                flush=True,
            )
    for h in ("exact", "L-BFGS"):
        sel = [r for r in rows if r["hessian"] == h]
        mm = [r["members"] for r in sel]
        print(
            f"{h}: fitted exponent in M — build CPU {_exponent(mm, [r['build_cpu_s'] for r in sel]):.2f}, solve CPU "
            f"{_exponent(mm, [r['solve_cpu_s'] for r in sel]):.2f}, iterations {_exponent(mm, [r['iterations'] for r in sel]):.2f}"
        )
    return {"rows": rows}


def main(argv: list[str] | None = None) -> None:
    bench_main(run, __doc__.splitlines()[0], "M = 1, 2, 4 instead of 2, 4, 10, 20", argv)


if __name__ == "__main__":
    main()
