"""Performance figures of ``optimise_corridor`` for ``bench_bands`` (issue 13, performance).

* **Small calls** (:func:`small_calls`): the README's corridor example (the 6 m storm drifting east, 17 legs of
  ≤ 100 nm, ±20 nm, ETA 100 h) and a WeatherRoutingTool-sized fixed path (the same centreline, half-width 0, cut
  into 21 legs), each timed after import and after one warm-up call of itself, the two alternated (A B A B …,
  :func:`benchmarks._measure.alternate`). Target: ≤ 1 s each on this 2-core machine.
* **Long corridors** (:func:`long_calls`): the whole call on ``bench_nlp``'s §4 great circle through the moving
  13 m storm (time-varying weather) at 500 … 5 000 legs (:func:`benchmarks._nlp_call.whole_call`, ``jit=False``
  against ``jit=True``, what ``jit="auto"`` does there where a C compiler is found),
  time per call, Ipopt solves, and the fitted exponent of time against legs. Targets: ≤ 2 s at 500 legs, exponent
  ≤ 1.2. Quick mode: 62 and 124 legs only (the full sizes take minutes a call on a loaded machine).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from benchmarks._measure import alternate, load_line, timing_table


def _readme_case() -> dict[str, Any]:
    import optroute as orx

    wx = orx.scenarios.moving_storm(2.0, -150.0, 90.0, 8.0, peak_hs_m=6.0, start="2024-01-10", duration_h=150.0,
                                    bbox=(-10, 12, -158, -124))  # fmt: skip
    t0 = wx.time.values[0]
    return {"weather": wx, "ship": orx.Ship.preset("container_54k_dwt"), "departure": t0,
            "eta": t0 + np.timedelta64(100, "h"), "use_land_mask": False}  # fmt: skip


def small_calls(quick: bool) -> dict[str, Any]:
    """The README's corridor example and a 21-leg fixed path, alternated after a warm-up of each."""
    import optroute as orx
    from optroute import geodesy as geo

    kw = _readme_case()
    ends = [(0.0, -155.0), (4.0, -127.0)]
    readme = orx.Corridor.from_waypoints(ends, width_nm=40)
    fixed = orx.Corridor.from_waypoints(ends, width_nm=0.0)
    leg21 = float(geo.distance_nm(*ends[0], *ends[1])) / 21.0 * (1 + 1e-9)
    variants = {
        "README corridor (17 legs)": lambda: orx.optimise_corridor(readme, **kw, objective="fuel", max_leg_nm=100.0),
        "fixed path, 21 legs": lambda: orx.optimise_corridor(fixed, **kw, objective="fuel", max_leg_nm=leg21),
    }
    alt = alternate(variants, repeats=2 if quick else 5)
    rows = {}
    for name, plan in alt.results.items():
        st = plan.solver_stats
        rows[name] = {"legs": int(st["n_legs"]), "nlp_solves": int(st["nlp_solves"]), "status": plan.status,
                      "build_s": float(st["build_time_s"]), "ipopt_s": float(st["solve_time_s"]),
                      "stage_time_s": st.get("stage_time_s"), **alt.timings[name].as_dict()}  # fmt: skip
    return {"alternated": alt.as_dict(), "rows": rows, "table": timing_table(
        alt, "README corridor (17 legs)", "Whole `optimise_corridor` calls after import and a warm-up call of each")}  # fmt: skip


def long_calls(quick: bool) -> dict[str, Any]:
    """The whole call at 500 … 5 000 legs in time-varying weather (quick: 62 and 124 legs) and its fitted exponent."""
    from benchmarks._nlp_call import whole_call

    sizes = (62, 124) if quick else (496, 992, 1984, 4960)
    return whole_call(True, sizes=sizes, jits=(False,)) if quick else whole_call(False, sizes=sizes, jits=(False, True))


def performance(quick: bool) -> dict[str, Any]:
    """Both sections."""
    return {"small": small_calls(quick), "long": long_calls(quick), "load": load_line()}


def print_performance(p: dict[str, Any]) -> None:
    """The performance tables."""
    from benchmarks._nlp_call import print_whole_call

    print("\n### Performance: small calls (target ≤ 1 s each)\n")
    print("\n".join(p["small"]["table"]))
    print("\n| call | legs | Ipopt solves | build [s] | Ipopt [s] | status |")
    print("|---|---:|---:|---:|---:|---|")
    for name, r in p["small"]["rows"].items():
        print(f"| {name} | {r['legs']} | {r['nlp_solves']} | {r['build_s']:.2f} | {r['ipopt_s']:.2f} | {r['status']} |")
    print_whole_call(p["long"])
    print(f"\n(targets: ≤ 2 s per call at 500 legs, exponent ≤ 1.2; {p['load']})")
