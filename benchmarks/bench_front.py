"""Fuel-versus-ETA front benchmark: the continuation's solves per point, warm against cold, serial against 2 workers.

One front (:func:`optroute.studies.tradeoff`) of 30 ETAs on a 300-leg, ~3 300 nm corridor (±20 nm lateral
freedom) through time-varying weather — a storm of 6 m peak H_s moving east at 8 kn across the
track — for ``container_54k_dwt``, four ways, alternated in the same process after one untimed run of
each (:func:`benchmarks._measure.alternate`, issue 22):

1. serial, the continuation (the default, the baseline): each point from its neighbour's plan and Ipopt
   multipliers; solves per point (optimiser calls and Ipopt calls), the share of points whose Ipopt start
   was the neighbour's plan and of those that took its multipliers too, the points that rose and were solved
   again from the earlier ETA's plan, and those that rose all the same;
2. on a 2-worker :class:`distributed.LocalCluster` on 127.0.0.1 started once (its start-up timed apart),
   reached through ``scheduler_address`` as an existing cluster is: the speed-up over (1), target
   >= 1.6×, and whether the front is bit-identical to (1);
3. serial, each point from its neighbour's plan alone (``warm_start="primal"``);
4. serial, each point from the optimiser's own start (``warm_start=False``).

The warm-up runs are the first of each: there each process prepares the corridor once (weather grid, power
table, CasADi functions — the build is most of a cold front: 83 % of the samples of a 16-leg serial front
under load), and solves the two ends and every point between on it; in the timed runs it keeps it (keyed
by the fingerprint of the inputs), as a worker does across the chains and fronts of a study.  Both are
reported, with this process's CPU seconds of each serial run and the points where the warm-started
front ends above (or below) the cold one.  The corridor is open ocean with
synthetic weather, so the coastline is not applied (``use_land_mask=False``).  Min and median of each
over the repetitions, with the load average before and after.  ``--quick``: the first half of the corridor
in 16 legs, 6 ETAs, one repetition.

Beside the front, each of its last three ETAs before the slow-steaming end (where the engine's minimum load binds
on most legs) is solved as a single :func:`optroute.optimise_corridor` call from the optimiser's own start, in
this process after the front: fuel against the front's point at the same ETA (its continuation and monotone
re-solves reach basins a single call need not), CPU seconds, Ipopt iterations and status.

Then a study of 1 200 cases (3 ships × 4 distances × 100 ETAs; quick: 240) through
:func:`optroute.studies.study.run_study` with its resumable store and text progress bar: serial
(``"synchronous"``) against a 2-worker local cluster (start-up included), each run again on its
full store (resumed: nothing computed), in cases per minute; on the cluster the cases go in tasks of up
to 16 (:func:`optroute.studies.study.cases_per_task`).  The case is the calm-water fuel from
the ship's own curves, cheap on purpose: the figure is the engine's (scheduling and atomic case
files); an optimiser case adds its solve time on top.  The front's figure goes to
``<results>/front.png`` (``front_quick.png`` in quick mode).  Run
``python -m benchmarks.bench_front [--quick] [--results DIR]``.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

import optroute as orx
from benchmarks._cli import bench_main, results_dir
from benchmarks._measure import alternate, load_line, timed_once, timing_table
from optroute.plot.common import save_png
from optroute.studies.cluster import SCHEDULER_HTTP_ADDRESS

T0 = np.datetime64("2024-01-10T00:00", "ns")
QUICK, FULL = (16, 6, 1), (300, 30, 2)
"""(legs, ETAs, timed repetitions of each variant after its warm-up) of the quick and the full mode."""


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


def _identical(a: Any, b: Any) -> bool:
    """Every variable but the clock's equal with ``==`` (NaN equal to NaN), and the attributes."""
    for name in a.data_vars:
        if name == "runtime_s":
            continue
        x, y = a[name].values, b[name].values
        if x.shape != y.shape or not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
            return False
    return a.attrs == b.attrs


def _continuation(front: Any) -> dict[str, Any]:
    """Solves per point of the points between the two end solves."""
    interior = front.solve.values == "eta"
    k = max(int(interior.sum()), 1)
    return {
        "interior_points": int(interior.sum()),
        "optimiser_solves_per_point": (
            int(interior.sum()) + int(front.attrs["monotonicity_resolves"]) + int(front.attrs["risen_resolves"])
        )
        / k,
        "risen_resolves": int(front.attrs["risen_resolves"]),
        "ipopt_calls_per_point": float(front.nlp_solves.values[interior].sum()) / k,
        "iterations_per_point": float(front.iterations.values[interior].sum()) / k,
        "started_from_neighbour": float(np.mean(front.warm_start.values[interior] == "warm plan")),
        "started_from_multipliers": float(np.mean(front.dual_starts.values[interior] >= 1)),
        "risen_points": int(front.attrs["risen_points"]),
        "interior_s": float(front.runtime_s.values[interior].sum()),
        "end_solves_s": float(front.runtime_s.values[~interior].sum()),
    }


#: A point whose solve takes more Ipopt iterations than this is listed by :func:`_by_point`.
MANY_ITERATIONS = 30


def _by_point(front: Any) -> list[dict[str, Any]]:
    """Each point's ETA [h], Ipopt iterations and calls, the start Ipopt took and the head of its status."""
    return [
        {
            "eta_h": round(float(h), 2),
            "iterations": int(it),
            "ipopt_calls": int(calls),
            "start": str(start),
            "status": str(status).split(";")[0] + ("; re-solved" if "solved again" in str(status) else ""),
        }
        for h, it, calls, start, status in zip(
            front.eta_h.values,
            front.iterations.values,
            front.nlp_solves.values,
            front.warm_start.values,
            front.status.values,
            strict=True,
        )
    ]


def run(quick: bool) -> dict[str, Any]:
    """Compute the front the four ways, alternated; print markdown tables; return the figures."""
    import distributed

    n_legs, n, repeats = QUICK if quick else FULL
    corridor, wx, ship, kw = case(n_legs, half=quick)
    common = {"corridor_or_endpoints": corridor, "weather": wx, "ship": ship, "departure": T0, "n": n, **kw}
    print(load_line("load average at start"))
    cluster, t_cluster = timed_once(
        lambda: distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            worker_dashboard_address=None,
            scheduler_kwargs={"dashboard_address": SCHEDULER_HTTP_ADDRESS},  # any free port, as a study's cluster
        )
    )
    cpu_serial: list[float] = []

    def serial() -> Any:  # this process's CPU seconds of each serial front, beside its wall-clock time
        started = time.process_time()
        out = orx.tradeoff(**common)
        cpu_serial.append(time.process_time() - started)
        return out

    try:
        address = cluster.scheduler_address
        alt = alternate(
            {
                "serial": serial,
                "parallel": lambda: orx.tradeoff(**common, scheduler_address=address),
                "primal": lambda: orx.tradeoff(**common, warm_start="primal"),
                "cold": lambda: orx.tradeoff(**common, warm_start=False),
            },
            repeats=repeats,
        )
    finally:
        cluster.close()
    warm, par, primal, cold = (alt.results[k] for k in ("serial", "parallel", "primal", "cold"))
    ok = np.isfinite(warm.fuel_t.values)
    cont, cont_primal, cont_cold = _continuation(warm), _continuation(primal), _continuation(cold)
    out = {
        "n_legs": int(warm.sizes["leg"]),
        "n_points": int(warm.sizes["eta"]),
        "points_solved": int(ok.sum()),
        "earliest_arrival_h": float(warm.attrs["earliest_arrival_h"]),
        "slow_steaming_limit_h": float(warm.attrs["slow_steaming_limit_h"]),
        "chains": int(warm.attrs["chains"]),
        "alternated": alt.as_dict(),
        "cluster_start_s": t_cluster,
        "serial_first_s": alt.warmup_s["serial"],
        "parallel_first_s": alt.warmup_s["parallel"],
        "serial_s": alt.timings["serial"].median_s,
        "parallel_2_workers_s": alt.timings["parallel"].median_s,
        "speedup_2_workers": 1.0 / alt.ratio("parallel", "serial"),
        "speedup_2_workers_min": 1.0 / alt.ratio("parallel", "serial", "min_s"),
        "speedup_2_workers_first": alt.warmup_s["serial"] / alt.warmup_s["parallel"],
        "warm_over_cold": alt.ratio("serial", "cold"),
        "warm_over_primal": alt.ratio("serial", "primal"),
        "continuation": cont,
        "primal": cont_primal,
        "cold": cont_cold,
        "bit_identical_parallel": _identical(warm, par),
        "serial_cpu_s": cpu_serial,
        "points_warm_worse_than_cold": int(
            np.sum(warm.fuel_t.values > cold.fuel_t.values * (1.0 + 1e-6))  # NaN compares False either way
        ),
        "points_warm_better_than_cold": int(np.sum(warm.fuel_t.values < cold.fuel_t.values * (1.0 - 1e-6))),
        "max_rel_fuel_diff_cold": float(
            np.nanmax(np.abs(cold.fuel_t.values - warm.fuel_t.values) / warm.fuel_t.values)
        ),
        "monotone": bool(np.all(np.diff(warm.fuel_t.values[ok]) <= 1e-6 * warm.fuel_t.values[ok][:-1])),
        "statuses": sorted({str(s).split(";")[0] for s in warm.status.values}),
        "by_point": _by_point(warm),
    }
    print(
        f"\n### Fuel-versus-ETA front: {out['n_points']} ETAs, {out['n_legs']} legs, "
        f"{out['earliest_arrival_h']:.1f}–{out['slow_steaming_limit_h']:.1f} h, {out['chains']} chains\n"
    )
    labels = {
        "serial": "serial, the continuation",
        "parallel": "2 workers (a cluster started once, by address)",
        "primal": "serial, from the neighbour's plan alone",
        "cold": "serial, cold-started",
    }
    what = (
        "The same front (corridor, ETAs, ship, weather) four ways, each run's whole `tradeoff` call; after the "
        "warm-up each process keeps the prepared corridor (the fingerprint of the inputs is the key)"
    )
    print("\n".join(timing_table(alt, "serial", what, labels)))
    print(
        f"\nfirst runs (the warm-up: each process prepares the corridor): serial {out['serial_first_s']:.1f} s, "
        f"2 workers {out['parallel_first_s']:.1f} s (speed-up {out['speedup_2_workers_first']:.2f}×); the cluster's "
        f"start-up apart: {t_cluster:.1f} s\n"
    )
    print(
        "| points between the ends | solves per point | Ipopt calls per point | iterations per point | "
        "Ipopt started from the neighbour | and its multipliers | risen, solved again | risen points | "
        "their solves [s] |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, c in (("continuation (baseline)", cont), ("plan alone", cont_primal), ("cold", cont_cold)):
        print(
            f"| {name} | {c['optimiser_solves_per_point']:.2f} | {c['ipopt_calls_per_point']:.2f} | "
            f"{c['iterations_per_point']:.1f} | {100 * c['started_from_neighbour']:.0f} % | "
            f"{100 * c['started_from_multipliers']:.0f} % | {c['risen_resolves']} | {c['risen_points']} | "
            f"{c['interior_s']:.1f} |"
        )
    print(
        f"\nspeed-up on 2 workers {out['speedup_2_workers']:.2f}× (medians; minima {out['speedup_2_workers_min']:.2f}×; "
        f"target 1.6×); bit-identical to serial: {out['bit_identical_parallel']}; warm/cold "
        f"{out['warm_over_cold']:.2f}; warm/plan alone {out['warm_over_primal']:.2f}; max rel. fuel diff cold vs warm {out['max_rel_fuel_diff_cold']:.1e}; "
        f"end solves {cont['end_solves_s']:.1f} s of the last serial run; monotone: {out['monotone']}; "
        f"statuses: {', '.join(out['statuses'])}"
    )
    print(
        f"serial CPU [s] of this process per run (warm-up first): {', '.join(f'{c:.1f}' for c in cpu_serial)}; "
        f"point by point, warm against cold: {out['points_warm_worse_than_cold']} worse, "
        f"{out['points_warm_better_than_cold']} better (relative 1e-6) of {out['n_points']}"
    )
    many = [p for p in out["by_point"] if p["iterations"] > MANY_ITERATIONS]
    listed = ", ".join(f"{p['eta_h']:.0f}: {p['iterations']}" for p in out["by_point"])
    print(
        f"\nIpopt iterations point by point (serial, the continuation; ETA h: iterations): {listed}; "
        f"{len(many)} points over {MANY_ITERATIONS} iterations, {sum(p['iterations'] for p in many)} of "
        f"{sum(p['iterations'] for p in out['by_point'])}"
    )
    out["single_calls"] = single_calls(warm, corridor, wx, ship, kw)
    save_png(warm.plot(), results_dir() / ("front_quick.png" if quick else "front.png"))
    with tempfile.TemporaryDirectory(prefix="optroute-bench-study-") as folder:
        out["study"] = study_throughput(quick, Path(folder))
    return out


def single_calls(front: Any, corridor: Any, wx: Any, ship: Any, kw: dict[str, Any], k: int = 3) -> list[dict[str, Any]]:
    """The front's last ``k`` interior ETAs each solved by one ``optimise_corridor`` call; fuel against the front's."""
    interior = [i for i, kind in enumerate(front.solve.values) if str(kind) == "eta"][-k:]
    rows = []
    for i in interior:
        eta_h = float(front.eta_h.values[i])
        eta = T0 + np.timedelta64(int(round(eta_h * 3600.0)), "s")
        cpu = time.process_time()
        plan = orx.optimise_corridor(corridor, wx, ship, departure=T0, eta=eta, objective="fuel", **kw)
        cpu = time.process_time() - cpu
        st = plan.solver_stats
        rows.append({"eta_h": eta_h, "single_fuel_t": plan.total_fuel_t, "front_fuel_t": float(front.fuel_t.values[i]),
                     "cpu_s": cpu, "iterations": int(st["iterations"]), "status": plan.status,
                     "start": str(st.get("start")), "arrival_h": plan.duration_h})  # fmt: skip
    print("\n| ETA [h] | single call [t] | the front's point [t] | single / front | arrives [h] | CPU [s] | "
          "iterations | status | start |")  # fmt: skip
    print("|---:|---:|---:|---:|---:|---:|---:|---|---|")
    for r in rows:
        print(f"| {r['eta_h']:.1f} | {r['single_fuel_t']:.3f} | {r['front_fuel_t']:.3f} | "
              f"{r['single_fuel_t'] / r['front_fuel_t']:.4f} | {r['arrival_h']:.1f} | {r['cpu_s']:.1f} | "
              f"{r['iterations']} | {r['status']} | {r['start']} |")  # fmt: skip
    return rows


def calm_case(case: dict[str, Any]) -> dict[str, Any]:
    """One study case: least fuel [t] at constant speed D/T in calm water from the ship's own curves.

    Module-level, so that Dask workers import it by name; cheap, so that the study's throughput
    measures the engine (scheduling, the store's atomic writes), not the optimiser.
    """
    ship = orx.Ship.preset(case["ship"])
    d_nm, eta_h = float(case["distance_nm"]), float(case["eta_h"])
    v = d_nm / eta_h
    if v > ship.max_calm_speed_kn:
        return {"fuel_t": float("nan"), "stw_kn": v}
    return {"fuel_t": eta_h * float(ship.fuel_rate_tph(ship.calm_power_kw(v))), "stw_kn": v}


def study_throughput(quick: bool, folder: Path) -> dict[str, Any]:
    """A study of 1 200 cases (quick: 240): serial against a 2-worker local cluster, then resumed; cases per minute."""
    from optroute.studies.study import run_study

    n_eta = 40 if quick else 100
    axes = {
        "ship": list(orx.Ship.presets()),
        "distance_nm": [1500.0, 3000.0, 4500.0, 6000.0][: 2 if quick else 4],
        "eta_h": [150.0 + 5.0 * i for i in range(n_eta)],
    }
    n_cases = int(np.prod([len(v) for v in axes.values()]))
    times = {}
    for name, kw in (("serial", {"scheduler_address": "synchronous"}), ("2 workers", {"n_workers": 2})):
        store = folder / f"study_{name.replace(' ', '_')}"
        shutil.rmtree(store, ignore_errors=True)
        started = time.perf_counter()
        ds = run_study(axes, calm_case, store, progress=True, **kw)
        times[name] = time.perf_counter() - started
        started = time.perf_counter()
        again = run_study(axes, calm_case, store, progress=True, **kw)  # all stored: nothing computed
        times[f"{name}, resumed"] = time.perf_counter() - started
        if name == "serial":
            reference = ds
        elif not (np.array_equal(ds.fuel_t.values, reference.fuel_t.values, equal_nan=True) and again.equals(ds)):
            raise RuntimeError("the 2-worker study differs from the serial one")
    out = {"cases": n_cases, **{f"{k}_s": v for k, v in times.items()}}
    out["serial_cases_per_min"] = n_cases / times["serial"] * 60.0
    out["two_workers_cases_per_min"] = n_cases / times["2 workers"] * 60.0
    print(f"\n### Study throughput: {n_cases} cases (calm-water fuel from the ship's curves), atomic case files\n")
    print("| run | total [s] | cases per minute | ratio to serial |")
    print("|---|---:|---:|---:|")
    for k, v in times.items():
        rate = f"{n_cases / v * 60.0:.0f}" if "resumed" not in k else "(nothing computed)"
        base = " (baseline)" if k == "serial" else ""
        print(f"| {k}{base} | {v:.1f} | {rate} | {v / times['serial']:.2f} |")
    return out


def main(argv: list[str] | None = None) -> None:
    bench_main(
        run, __doc__.splitlines()[0], "half the corridor, 16 legs, 6 ETAs, one repetition; 240 study cases", argv
    )


if __name__ == "__main__":
    main()
