"""Fuel-versus-ETA front benchmark: warm against cold starts, serial against a 2-worker local Dask cluster.

One front (:func:`optroute.studies.tradeoff`) of 30 ETAs on a 300-leg, ~3 300 nm corridor (±20 nm lateral
freedom) through time-varying weather — a storm of 6 m peak H_s moving east at 8 kn across the
track — for ``container_54k_dwt``, computed three times in the same process, side by side:

1. serial, each point warm-started from its neighbour's solution (the default);
2. serial, each point from the optimiser's own start (``warm_start=False``): warm/cold ratio of the
   total time and of the Ipopt iterations;
3. on a 2-worker :class:`distributed.LocalCluster` on 127.0.0.1 (``n_workers=2``), cluster start-up
   included: speed-up over (1) (target >= 1.6× on this 2-core machine), and the largest relative
   difference of the fuel from (1).

The corridor is open ocean with synthetic weather, so the coastline is not applied
(``use_land_mask=False``); reading the global land mask would add a one-off ~5 s per process.
Timings on a shared 2-core machine are noisy: the ratios, measured in one run, are the figures.
``--quick``: the first half of the corridor in 16 legs, 4 ETAs (well under a minute unloaded, for CI). The front's figure goes to
``benchmarks/results/front.png``. Run ``python -m benchmarks.bench_front [--quick]``.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

import optroute as orx
from benchmarks._cli import bench_main
from optroute.plot.common import save_png

T0 = np.datetime64("2024-01-10T00:00", "ns")
RESULTS = Path(__file__).resolve().parent / "results"


def case(n_legs: int, *, half: bool = False) -> tuple[orx.Corridor, Any, orx.Ship, dict[str, Any]]:
    """The corridor (``n_legs`` legs after resampling; its first half only with ``half``), weather, ship, options."""
    wx = orx.scenarios.moving_storm(
        2.0,
        -150.0,
        90.0,
        8.0,
        peak_hs_m=6.0,
        radius_nm=300.0,
        start=T0,
        duration_h=400.0,
        step_h=3.0,
        resolution_deg=0.5,
        bbox=(-12.0, 14.0, -160.0, -95.0),
    )
    points = [[0.0, -155.0], [4.0, -127.0], [0.0, -100.0]]
    corridor = orx.Corridor.from_waypoints(points[:2] if half else points, width_nm=40.0)
    kw = {"max_leg_nm": corridor.length_nm / n_legs * (1 + 1e-9), "use_land_mask": False}
    return corridor, wx, orx.Ship.preset("container_54k_dwt"), kw


def _timed(**kw: Any) -> tuple[Any, float]:
    started = time.perf_counter()
    front = orx.tradeoff(**kw)
    return front, time.perf_counter() - started


def run(quick: bool) -> dict[str, Any]:
    """Compute the front three ways, print a markdown table, return the figures."""
    n_legs, n = (16, 4) if quick else (300, 30)
    corridor, wx, ship, kw = case(n_legs, half=quick)
    common = {"corridor_or_endpoints": corridor, "weather": wx, "ship": ship, "departure": T0, "n": n, **kw}
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    warm, t_warm = _timed(**common)
    cold, t_cold = _timed(**common, warm_start=False)
    par, t_par = _timed(**common, n_workers=2)
    n_legs_solved = int(warm.sizes["leg"])
    ok = np.isfinite(warm.fuel_t.values)
    interior = warm.solve.values == "eta"
    fuel_diff = float(np.nanmax(np.abs(par.fuel_t.values - warm.fuel_t.values) / warm.fuel_t.values))
    cold_diff = float(np.nanmax(np.abs(cold.fuel_t.values - warm.fuel_t.values) / warm.fuel_t.values))
    out = {
        "n_legs": n_legs_solved,
        "n_points": int(warm.sizes["eta"]),
        "points_solved": int(ok.sum()),
        "earliest_arrival_h": float(warm.attrs["earliest_arrival_h"]),
        "slow_steaming_limit_h": float(warm.attrs["slow_steaming_limit_h"]),
        "serial_warm_s": t_warm,
        "serial_cold_s": t_cold,
        "warm_over_cold": t_warm / t_cold,
        "interior_warm_s": float(warm.runtime_s.values[interior].sum()),
        "interior_cold_s": float(cold.runtime_s.values[interior].sum()),
        "interior_iterations_warm": int(warm.iterations.values[interior].sum()),
        "interior_iterations_cold": int(cold.iterations.values[interior].sum()),
        "end_solves_s": float(warm.runtime_s.values[~interior].sum()),
        "cluster_2_workers_s": t_par,
        "speedup_2_workers": t_warm / t_par,
        "max_rel_fuel_diff_parallel": fuel_diff,
        "max_rel_fuel_diff_cold": cold_diff,
        "monotone": bool(np.all(np.diff(warm.fuel_t.values[ok]) <= 1e-6 * warm.fuel_t.values[ok][:-1])),
        "monotonicity_resolves": int(warm.attrs["monotonicity_resolves"]),
        "statuses": sorted({str(s) for s in warm.status.values}),
    }
    print(
        f"\n### Fuel-versus-ETA front: {out['n_points']} ETAs, {n_legs_solved} legs, "
        f"{out['earliest_arrival_h']:.1f}–{out['slow_steaming_limit_h']:.1f} h\n"
    )
    print("| run | total [s] | ratio | Ipopt iterations (points between the ends) | max rel. fuel diff |")
    print("|---|---:|---:|---:|---:|")
    print(f"| serial, warm-started (baseline) | {t_warm:.1f} | 1.00 | {out['interior_iterations_warm']} | 0 |")
    print(
        f"| serial, cold-started | {t_cold:.1f} | {t_cold / t_warm:.2f} | {out['interior_iterations_cold']} | "
        f"{cold_diff:.1e} |"
    )
    print(f"| 2-worker local cluster | {t_par:.1f} | {t_par / t_warm:.2f} | | {fuel_diff:.1e} |")
    print(
        f"\nwarm/cold total time {out['warm_over_cold']:.2f} (points between the ends: "
        f"{out['interior_warm_s']:.1f} s warm vs {out['interior_cold_s']:.1f} s cold); the two end solves took "
        f"{out['end_solves_s']:.1f} s of the serial run; speed-up on 2 workers {out['speedup_2_workers']:.2f}× "
        f"(target 1.6×); monotone: {out['monotone']}, re-solves {out['monotonicity_resolves']}; "
        f"statuses: {', '.join(out['statuses'])}"
    )
    RESULTS.mkdir(exist_ok=True)
    save_png(warm.plot(), RESULTS / ("front_quick.png" if quick else "front.png"))
    return out


def main(argv: list[str] | None = None) -> None:
    bench_main(run, __doc__.splitlines()[0], "half the corridor, 16 legs, 4 ETAs (under a minute)", argv)


if __name__ == "__main__":
    main()
