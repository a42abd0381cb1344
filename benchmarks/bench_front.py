"""Fuel-versus-ETA front benchmark: warm against cold starts, serial against a 2-worker local Dask cluster.

One front (:func:`optroute.studies.tradeoff`) of 30 ETAs on a 300-leg, ~3 300 nm corridor (±20 nm lateral
freedom) through time-varying weather — a storm of 6 m peak H_s moving east at 8 kn across the
track — for ``container_54k_dwt``, three ways, alternated in the same process (warm cold parallel × repeats,
after one untimed run of each: issue 22, a single run of each in turn let the machine's load decide):

1. serial, each point warm-started from its neighbour's solution (the default, the baseline);
2. serial, each point from the optimiser's own start (``warm_start=False``): its time and Ipopt
   iterations over (1)'s;
3. on a 2-worker :class:`distributed.LocalCluster` on 127.0.0.1 (``n_workers=2``), cluster start-up
   included (a new cluster per front, as a user's call makes one): its time over (1)'s (a speed-up is a ratio
   below 1; the target is 1 / 1.6 on this 2-core machine, shared with whatever else runs), and the largest
   relative difference of the fuel from (1).

Min and median of each over the repetitions, with the load average before and after. The corridor is open ocean
with synthetic weather, so the coastline is not applied (``use_land_mask=False``); reading the global land mask
would add a one-off ~5 s per process. ``--quick``: the first half of the corridor in 16 legs, 4 ETAs, two
repetitions. The front's figure goes to ``<results>/front.png`` (``front_quick.png`` in quick mode), never into the
source tree. Run ``python -m benchmarks.bench_front [--quick] [--results DIR]``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

import optroute as orx
from benchmarks._cli import bench_main, results_dir
from benchmarks._measure import alternate, load_line, timing_table
from optroute.plot.common import save_png

T0 = np.datetime64("2024-01-10T00:00", "ns")
QUICK, FULL = (16, 4, 2), (300, 30, 3)
"""(legs, ETAs, timed repetitions of each variant) of the quick and the full mode."""


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


def run(quick: bool) -> dict[str, Any]:
    """Compute the front three ways, alternated; print markdown tables; return the figures."""
    n_legs, n, repeats = QUICK if quick else FULL
    corridor, wx, ship, kw = case(n_legs, half=quick)
    common = {"corridor_or_endpoints": corridor, "weather": wx, "ship": ship, "departure": T0, "n": n, **kw}
    print(load_line("load average at start"))
    alt = alternate(
        {
            "warm": lambda: orx.tradeoff(**common),
            "cold": lambda: orx.tradeoff(**common, warm_start=False),
            "parallel": lambda: orx.tradeoff(**common, n_workers=2),
        },
        repeats=repeats,
    )
    warm, cold, par = (alt.results[k] for k in ("warm", "cold", "parallel"))
    tm = alt.timings
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
        "alternated": alt.as_dict(),
        "serial_warm_s": tm["warm"].median_s,
        "serial_cold_s": tm["cold"].median_s,
        "warm_over_cold": alt.ratio("warm", "cold"),
        "interior_warm_s": float(warm.runtime_s.values[interior].sum()),
        "interior_cold_s": float(cold.runtime_s.values[interior].sum()),
        "interior_iterations_warm": int(warm.iterations.values[interior].sum()),
        "interior_iterations_cold": int(cold.iterations.values[interior].sum()),
        "end_solves_s": float(warm.runtime_s.values[~interior].sum()),
        "cluster_2_workers_s": tm["parallel"].median_s,
        "speedup_2_workers": 1.0 / alt.ratio("parallel", "warm"),
        "speedup_2_workers_min": 1.0 / alt.ratio("parallel", "warm", "min_s"),
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
    labels = {"warm": "serial, warm-started", "cold": "serial, cold-started", "parallel": "2-worker local cluster"}
    what = "The same front (corridor, ETAs, ship, weather) computed three ways; each run's whole `tradeoff` call"
    print("\n".join(timing_table(alt, "warm", what, labels)))
    print("\n| run | Ipopt iterations (points between the ends, last run) | max rel. fuel diff to warm |")
    print("|---|---:|---:|")
    print(f"| {labels['warm']} | {out['interior_iterations_warm']} | 0 |")
    print(f"| {labels['cold']} | {out['interior_iterations_cold']} | {cold_diff:.1e} |")
    print(f"| {labels['parallel']} | | {fuel_diff:.1e} |")
    print(
        f"\nwarm/cold total time {out['warm_over_cold']:.2f} (medians; points between the ends in the last runs: "
        f"{out['interior_warm_s']:.1f} s warm vs {out['interior_cold_s']:.1f} s cold); the two end solves took "
        f"{out['end_solves_s']:.1f} s of the last warm run; speed-up on 2 workers {out['speedup_2_workers']:.2f}× "
        f"(medians; minima {out['speedup_2_workers_min']:.2f}×; target 1.6×); monotone: {out['monotone']}, "
        f"re-solves {out['monotonicity_resolves']}; statuses: {', '.join(out['statuses'])}"
    )
    png = save_png(warm.plot(), results_dir() / ("front_quick.png" if quick else "front.png"))
    out["figures"] = [str(png)]
    print(f"\nfigure: `{png.name}`")
    return out


def main(argv: list[str] | None = None) -> None:
    bench_main(run, __doc__.splitlines()[0], "half the corridor, 16 legs, 4 ETAs (under a minute)", argv)


if __name__ == "__main__":
    main()
