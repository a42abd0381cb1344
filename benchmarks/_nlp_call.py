"""The whole ``optroute.optimise_corridor`` call timed, for ``bench_nlp`` (issue 22, item 3).

``bench_nlp``'s §1–2 time one :meth:`formulations.speed_nlp.SpeedNLP.solve` (2 samples per leg, one Ipopt
call); a user's call prepares the weather grid and power table, searches the starts, solves several times
(3 samples per leg, the band outer loop, re-solves after verification) and verifies. This section times that
call itself on ``bench_nlp``'s §4 great circle (2 477 nm at 30° N through the moving 13 m storm, ETA at 18 kn,
±40 nm), cut into N legs: ``jit=False`` against ``jit=True`` alternated (full mode; quick mode: ``jit=False``
alone), min and median of the whole call after a warm-up call of each, and the build and Ipopt times from
``solver_stats`` beside them, reported separately. The leg functions are compiled once per machine and ship
(:mod:`formulations.compiled`'s disk cache): where the cache is cold, in the warm-up call, whose time is reported.
"""

from __future__ import annotations

import statistics
import time
from typing import Any

import numpy as np

from benchmarks._measure import alternate


def _case() -> dict[str, Any]:
    import optroute as orx
    from benchmarks.bench_nlp import BAND_FRACTION, DP_END, DP_START, DP_T0, STORM_LAT
    from optroute import geodesy as geo

    wx = orx.scenarios.moving_storm(STORM_LAT, -160.0, 120.0, 12.0, peak_hs_m=13.0, radius_nm=250.0, start=DP_T0,
                                    duration_h=240.0, step_h=3.0, resolution_deg=0.5, bbox=(15, 45, -178, -115))  # fmt: skip
    length = float(geo.distance_nm(*DP_START, *DP_END))
    return {
        "corridor": orx.Corridor.from_waypoints([DP_START, DP_END], width_nm=80.0),
        "weather": wx,
        "ship": orx.Ship.preset("container_54k_dwt"),
        "departure": DP_T0,
        "eta": DP_T0 + np.timedelta64(int(round(length / 18.0)), "h"),
        "rules": orx.BandRules(hs_threshold_fraction=BAND_FRACTION),
        "length_nm": length,
    }


def whole_call(
    quick: bool,
    sizes: tuple[int, ...] | None = None,
    jits: tuple[bool, ...] | None = None,
    repeats: int | None = None,
) -> dict[str, Any]:
    """Time ``optimise_corridor`` at a few leg counts (jit off and on alternated in full mode), ``repeats`` rounds."""
    import optroute as orx

    c = _case()
    length = c.pop("length_nm")
    sizes = sizes or ((21, 125) if quick else (21, 125, 500, 2000, 5000))  # 21: a WeatherRoutingTool-sized path
    jits = jits or ((False,) if quick else (False, True))
    repeats = repeats or (2 if quick else 3)
    rows = []
    for n in sizes:
        kw = {**c, "max_leg_nm": length / n * (1 + 1e-9)}
        cpu: dict[str, list[float]] = {}

        def call(j: bool, kw: dict[str, Any] = kw, cpu: dict[str, list[float]] = cpu) -> Any:
            started = time.process_time()
            plan = orx.optimise_corridor(**kw, jit=j)
            cpu.setdefault(f"jit={j}", []).append(time.process_time() - started)  # the warm-up's first
            return plan

        variants = {f"jit={j}": (lambda j=j: call(j)) for j in jits}
        alt = alternate(variants, repeats=repeats)
        for name, t in alt.timings.items():
            st = alt.results[name].solver_stats
            rows.append({
                "legs": int(st["n_legs"]), "variant": name, "min_s": t.min_s, "median_s": t.median_s,
                "cpu_median_s": statistics.median(cpu[name][1:]),
                "warmup_s": alt.warmup_s[name], "build_s": float(st["build_time_s"]),
                "ipopt_s": float(st["solve_time_s"]),
                "rest_s": t.median_s - float(st["build_time_s"]) - float(st["solve_time_s"]), "nlp_solves": int(st["nlp_solves"]),
                "iterations": int(st["iterations"]), "samples_per_leg": int(st["samples_per_leg"]),
                "status": alt.results[name].status, "load_before": alt.load_before[0], "load_after": alt.load_after[0],
                "ratio_to_jit_off": alt.ratio(name, "jit=False"),
            })  # fmt: skip
    off = [r for r in rows if r["variant"] == "jit=False"]
    exponent = (float(np.polyfit(np.log([r["legs"] for r in off]), np.log([r["cpu_median_s"] for r in off]), 1)[0])
                if len(off) > 1 else float("nan"))  # fmt: skip
    return {"rows": rows, "exponent": exponent, "repeats": repeats}


def print_whole_call(w: dict[str, Any]) -> None:
    """The whole-call table."""
    print("\n### The whole `optimise_corridor` call (§4's great circle, N legs)\n")
    print("_What a user's call costs: weather grid, power table, starts, every Ipopt solve (3 samples per leg) and "
          f"the verification, timed whole; variants alternated × {w['repeats']} after a warm-up call of each; "
          "build and Ipopt time from `solver_stats`, per call, reported beside it (jit=True compiles in its warm-up "
          "call where the disk cache does not hold its leg functions yet). "
          "Not the same work as §1–2's single `SpeedNLP.solve`._\n")  # fmt: skip
    print("| legs | variant | min [s] | median [s] | median CPU [s] | median / jit=False | build [s] | Ipopt [s] | "
          "Ipopt solves | rest [s] | iterations | status | load (1 min) before → after |")  # fmt: skip
    print("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|")
    for r in w["rows"]:
        print(f"| {r['legs']} | {r['variant']} | {r['min_s']:.2f} | {r['median_s']:.2f} | {r['cpu_median_s']:.2f} | "
              f"{r['ratio_to_jit_off']:.2f} | "
              f"{r['build_s']:.2f} | {r['ipopt_s']:.2f} | {r['nlp_solves']} | {r['rest_s']:.2f} | {r['iterations']} | {r['status']} | "
              f"{r['load_before']:.1f} → {r['load_after']:.1f} |")  # fmt: skip
    if not any(r["variant"] == "jit=True" for r in w["rows"]):
        print("\n(jit=True not timed here; `python -m benchmarks.bench_nlp --jit` times it.)")
    med = statistics.median(r["median_s"] for r in w["rows"])
    print(
        f"\nfitted exponent of the whole call (jit=False): CPU seconds ∝ N^{w['exponent']:.2f}; median of the medians "
        f"{med:.2f} s (wall); `python -m benchmarks.bench_nlp --scaling [--baseline main] [--full]` times 21 … 5 000 "
        "legs against a baseline commit"
    )


JIT_SIZES = (100, 300)
"""The corridors of the ``jit`` measurement (``python -m benchmarks.bench_nlp --jit``): ~100 and ~300 legs."""


def jit_whole_call(repeats: int = 2) -> dict[str, Any]:
    """``jit=False`` against ``jit=True``, whole calls alternated after a warm-up of each, per size printed as it ends.

    The C compilation (where the disk cache of :mod:`formulations.compiled` is cold) is in the first ``jit=True``
    call, the warm-up: its wall time is reported beside the warm-up without jit.
    """
    rows, summary = [], []
    for n in JIT_SIZES:
        w = whole_call(False, sizes=(n,), jits=(False, True), repeats=repeats)
        print_whole_call(w)
        rows += w["rows"]
        off, on = (next(r for r in w["rows"] if r["variant"] == v) for v in ("jit=False", "jit=True"))
        summary.append({
            "legs": off["legs"], "median_ratio_on_to_off": on["median_s"] / off["median_s"],
            "min_ratio_on_to_off": on["min_s"] / off["min_s"], "warmup_off_s": off["warmup_s"],
            "ipopt_ratio_on_to_off": on["ipopt_s"] / off["ipopt_s"], "warmup_on_s": on["warmup_s"],
        })  # fmt: skip
    print("\n| legs | whole call jit=True / jit=False (median, min) | Ipopt time jit=True / jit=False | "
          "warm-up call jit=True (compiles where the cache is cold), jit=False [s] |")  # fmt: skip
    print("|---:|---:|---:|---:|")
    for s in summary:
        print(f"| {s['legs']} | {s['median_ratio_on_to_off']:.2f}, {s['min_ratio_on_to_off']:.2f} | "
              f"{s['ipopt_ratio_on_to_off']:.2f} | {s['warmup_on_s']:.1f}, {s['warmup_off_s']:.1f} |")  # fmt: skip
    return {"rows": rows, "summary": summary, "repeats": repeats}
