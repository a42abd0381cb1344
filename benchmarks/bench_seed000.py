"""Seed 000 reproduction (Boeing EP 2145155): San Diego → Tokyo through two storms, great circle vs optimised route.

``optroute.cli.demo.run_demo`` composes the steps: ``north_pacific_storms()``,
``Ship.preset("container_8000teu")`` at 25 kn with the patent's ship model (calm-water power,
the four danger bands, no minimum load), and

1. the great circle sailed with forced slow-downs out of the bands
   (``optroute.search.routing.sail_route``, Boeing's speed reduction);
2. the searched route (time-dependent A* on a gnomonic grid, 5° angular resolution, 25 kn);
3. the optimised plan (``optimise_corridor``, least fuel arriving by the patent's 8 d 8 h, verified).

Printed: distance, transit time, fuel and the lowest speed of each, the time ratio great circle /
optimised beside the patent's (> 12 d against 8 d 8 h, i.e. > 1.44; the calm great circle takes
about 8 d), and the runtime of each stage. ``seed000.png`` draws transit time and fuel.

Run ``python -m benchmarks.bench_seed000 [--quick]`` (quick: 120 nm search cells and 200 nm NLP legs
instead of 40 nm and 100 nm).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from benchmarks._cli import bench_main, results_dir
from optroute import geodesy as geo
from optroute.cli.demo import SAN_DIEGO, TOKYO, run_demo

SEED_GC_H = 12 * 24.0
"""EP 2145155: the great circle with forced slow-downs takes "more than 12 days" [h] (a lower bound)."""
SEED_ROUTED_H = 8 * 24 + 8.0
"""EP 2145155: the optimised route arrives after 8 days 8 hours [h]."""
SEED_CALM_GC_H = 8 * 24.0
"""EP 2145155: the great circle in calm weather takes about 8 days [h]."""
SPEED_KN = 25.0


def _dh(hours: float) -> str:
    if not np.isfinite(hours):
        return "–"
    d, h = divmod(round(hours), 24)
    return f"{d} d {h} h"


def run(quick: bool) -> dict[str, Any]:
    """Run the demo's passages; print the comparison with the seed; write ``seed000.png``; return the figures."""
    cell_nm, max_leg_nm = (120.0, 200.0) if quick else (40.0, 100.0)
    t = time.perf_counter()
    res = run_demo(None, cell_nm=cell_nm, figures=False, max_leg_nm=max_leg_nm)
    wall = time.perf_counter() - t
    rows = [{"passage": name, "distance_nm": d, "transit_h": h, "fuel_t": f, "min_stw_kn": v}
            for name, d, h, f, v in res.rows()]  # fmt: skip
    gc_nm = float(geo.distance_nm(*SAN_DIEGO, *TOKYO))
    gc, best = rows[0], rows[-1]
    verified = None if res.plan is None else len(res.plan.verify())
    out = {"cell_nm": cell_nm, "max_leg_nm": max_leg_nm, "rows": rows, "runtime_s": wall,
           "timings_s": dict(getattr(res, "timings_s", {}) or {}), "calm_great_circle_h": gc_nm / SPEED_KN,
           "great_circle_nm": gc_nm, "time_ratio": gc["transit_h"] / best["transit_h"],
           "seed_time_ratio_min": SEED_GC_H / SEED_ROUTED_H, "saved_h": gc["transit_h"] - best["transit_h"],
           "seed_saved_h": 3 * 24 + 16.0, "plan_violations": verified,
           "plan_eta_h": getattr(res, "eta_h", float("nan"))}  # fmt: skip
    print(f"\n### San Diego → Tokyo through `north_pacific_storms()`, `container_8000teu` at {SPEED_KN:g} kn "
          f"(search cells {cell_nm:g} nm, NLP legs ≤ {max_leg_nm:g} nm)\n")  # fmt: skip
    print("| passage | distance [nm] | transit | transit [h] | fuel [t] | lowest STW [kn] | seed 000 (EP 2145155) |")
    print("|---|---:|---|---:|---:|---:|---|")
    seed = {0: f"> 12 d (> {SEED_GC_H:g} h), below 10 kn in the storms", len(rows) - 1: "8 d 8 h (200 h) at 25 kn"}
    for k, r in enumerate(rows):
        print(f"| {r['passage']} | {r['distance_nm']:,.0f} | {_dh(r['transit_h'])} | {r['transit_h']:.1f} | "
              f"{r['fuel_t']:,.0f} | {r['min_stw_kn']:.1f} | {seed.get(k, '–')} |")  # fmt: skip
    print(f"| great circle in calm water at {SPEED_KN:g} kn | {gc_nm:,.0f} | {_dh(out['calm_great_circle_h'])} | "
          f"{out['calm_great_circle_h']:.1f} | – | – | ≈ 8 d |")  # fmt: skip
    print(f"\ngreat circle / optimised transit time: **{out['time_ratio']:.2f}** (seed: > {out['seed_time_ratio_min']:.2f});"
          f" time saved {_dh(out['saved_h'])} (seed: 3 d 16 h); the plan's ETA {_dh(out['plan_eta_h'])}, "
          f"verify: {'–' if verified is None else f'{verified} violations'}; runtime {wall:.1f} s "
          f"({', '.join(f'{k} {v:.1f} s' for k, v in out['timings_s'].items())})")  # fmt: skip
    png = figure(rows, results_dir() / "seed000.png")
    print(f"\nfigure: `{png.name}`\n")
    out["figures"] = [str(png)]
    return out


def figure(rows: list[dict[str, Any]], path: Any) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from optroute.plot.common import save_png

    fig = Figure(figsize=(9.0, 4.0))
    FigureCanvasAgg(fig)
    ax_t, ax_f = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    names = [r["passage"].replace(" (", "\n(").replace(", ", ",\n", 1) for r in rows]
    y = np.arange(len(rows))
    ax_t.barh(y, [r["transit_h"] / 24 for r in rows], color="tab:blue")
    ax_t.axvline(SEED_GC_H / 24, color="tab:red", ls="--", label="seed: great circle > 12 d")
    ax_t.axvline(SEED_ROUTED_H / 24, color="tab:green", ls="--", label="seed: routed 8 d 8 h")
    ax_t.set_yticks(y, names, fontsize=7)
    ax_t.set_xlabel("transit [d]")
    ax_t.legend(fontsize=7)
    ax_f.barh(y, [r["fuel_t"] for r in rows], color="tab:grey")
    ax_f.set_yticks(y, [""] * len(rows))
    ax_f.set_xlabel("fuel [t]")
    fig.suptitle("Seed 000: San Diego → Tokyo through two winter storms")
    fig.tight_layout()
    return save_png(fig, path)


def main(argv: list[str] | None = None) -> None:
    bench_main(run, __doc__.splitlines()[0], "coarse search grid and NLP legs", argv)


if __name__ == "__main__":
    main()
