"""Seed 001 reproduction (Shao et al.'s 3-D DP): fuel-versus-ETA curves of a constant-speed baseline, the DP and the NLP.

``orx.scenarios.shao_case(1)`` and ``shao_case(2)`` (equator, (0°, 0°) → (0°, 90° E), islands
at lon 50–70°, lat −1 to 7°, and a bad-weather rectangle that moves south (case I, after 60 h)
or north (case II) at 3 kn) with ``Ship.preset("container_54k_dwt")``. Over a range of required
arrival times (ETAs), side by side in one process:

(a) **constant-speed shortest safe route on the DP's lattice** (the paper's "MEPC" baseline): for every
    speed of the DP's own speed set that could arrive by the last ETA, the DP lattice's least-fuel
    route at that one speed (``search_route(method="dp", speeds_kn=[v])`` with the DP's ΔX, ΔY and Δt:
    at one speed the fuel is the fuel rate times the distance over the speed and the background sea
    is uniform, so this is the shortest route that keeps out of the no-go areas at the times a ship at
    that speed gets there). Its fuel at an ETA is that of the least-fuel such speed arriving by the
    ETA: a schedule the DP itself can represent, so the DP can only match or beat it (the fuel of a
    speed *between* two lattice speeds, interpolated in arrival time, is not one: issue 22);
(b) **the 3-D DP**: one ``search_route(method="dp", objective="fuel", eta=<latest ETA>)`` run,
    whose least fuel per arrival bin is the whole fuel-versus-ETA curve (the DP's fuel at an ETA
    is the least over the bins that end by it). Lattice ΔX 540 nm, ΔY 150 nm (±600 nm), Δt 2 h,
    speeds 5 kn to the top speed every 1 kn: coarser than the paper's 360 nm / 75 nm / 1 h /
    ±900 nm, one run of which took more than 12 minutes and 2.5 GB here;
(c) **the NLP**: ``optimise_corridor(objective="fuel", eta=)`` in a 150 nm corridor about the
    baseline's route for the ETA, warm-started from it.

The DP and the baseline are compared in the DP's own fuel accounting (the same lattice and model);
the NLP and the baseline are both scored by the referee (``Plan.from_schedule`` through the same
weather and ship, ``Plan.verify()``), and the baseline's and the NLP's failed and unverified plans are
counted (:func:`comparison`, in the JSON under ``comparison``). The DP's curve comes from one run, with
no route per arrival bin, so it is not refereed; an ETA with no DP bin counts as a DP failure
(``dp_missing``).

For each case: the window of ETAs where the DP (and the NLP) use less fuel than the baseline
(by more than 0.5 %), the largest saving [t] and [%], beside what the paper reports (case I:
233–272 h, 1014.54 → 969.25 t at 264 h, 4.5 %; case II: 270–303 h, 898 → 852 t at 278 h,
5.1 %). Absolute fuel differs: the paper's ship model and sea are not given in full (the seed
gives no background sea; ``shao_case`` uses H_s 2 m from the east). ``shao_case<k>.png`` plots
the three curves.

Run ``python -m benchmarks.bench_shao [--quick]`` (quick: case I only, a much coarser lattice, three ETAs,
the NLP at one).
"""

from __future__ import annotations

import time
import warnings
from typing import Any

import numpy as np

import optroute as orx
from benchmarks._cli import bench_main, results_dir
from benchmarks._measure import FAILED, OK, UNVERIFIED, Outcome, compare, comparison_lines, load_line
from optroute import geodesy
from optroute.weather.scenarios import SHAO_START_END

SHIP = "container_54k_dwt"
PAPER = {
    1: {"window_h": (233.0, 272.0), "eta_h": 264.0, "baseline_t": 1014.54, "dp_t": 969.25, "saving_pct": 4.5},
    2: {"window_h": (270.0, 303.0), "eta_h": 278.0, "baseline_t": 898.0, "dp_t": 852.0, "saving_pct": 5.1},
}
"""What seed 001 reports per case: the window of ETAs where the DP saves, and the quoted comparison."""
SAVING_TOL = 0.005
"""A saving counts for the window when it exceeds this fraction of the baseline's fuel [-]."""
CORRIDOR_WIDTH_NM = 150.0


def settings(quick: bool) -> dict[str, Any]:
    """Lattice, speeds and ETAs of the run (the paper's lattice in full mode)."""
    if quick:
        return {"cases": (1,), "dp": {"dx_nm": 1080.0, "dy_nm": 300.0, "half_width_nm": 600.0, "dt_h": 3.0},
                "dp_speeds_kn": (10.0, 2.0),
                "etas_h": (240.0, 256.0, 272.0), "nlp_etas_h": (256.0,)}  # fmt: skip
    return {"cases": (1, 2), "dp": {"dx_nm": 540.0, "dy_nm": 150.0, "half_width_nm": 600.0, "dt_h": 2.0},
            "dp_speeds_kn": (5.0, 1.0),
            "etas_h": tuple(float(e) for e in np.arange(224.0, 336.1, 8.0)), "nlp_etas_h": (248.0, 264.0, 280.0)}  # fmt: skip


def _search(wx: Any, ship: orx.Ship, t0: np.datetime64, dp: dict[str, float], **kw: Any) -> orx.Route:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return orx.search_route(*SHAO_START_END, wx, ship, departure=t0, method="dp", objective="fuel",
                                dp_options=dict(dp), **kw)  # fmt: skip


def lattice_speeds(ship: orx.Ship, cfg: dict[str, Any]) -> np.ndarray:
    """The DP's speed set [kn]: from ``dp_speeds_kn[0]`` every ``dp_speeds_kn[1]`` to the top speed (0.5 kn floor)."""
    top = float(np.floor(min(ship.max_calm_speed_kn, 40.0) * 2) / 2)
    return np.arange(cfg["dp_speeds_kn"][0], top + 1e-9, cfg["dp_speeds_kn"][1])


def baseline_curve(wx: Any, ship: orx.Ship, t0: np.datetime64, cfg: dict[str, Any]) -> dict[str, Any]:
    """Per lattice speed: arrival [h], the DP's own fuel [t], the referee's fuel [t] and violations, route.

    Speeds too slow to arrive by the last ETA even on the great circle are left out (they cannot be the
    baseline at any ETA compared).
    """
    gc_nm = float(geodesy.distance_nm(*SHAO_START_END[0], *SHAO_START_END[1]))
    speeds = lattice_speeds(ship, cfg)
    speeds = speeds[gc_nm / speeds <= max(cfg["etas_h"])]
    arrival, fuel, dist, ref, viol = (np.full(speeds.size, np.nan) for _ in range(5))
    routes: list[orx.Route | None] = []
    for k, v in enumerate(speeds):
        try:
            r = _search(wx, ship, t0, cfg["dp"], speeds_kn=[float(v)])
        except orx.OptrouteError:  # no safe passage at this speed (or beyond the weather's span)
            routes.append(None)
            continue
        routes.append(r)
        arrival[k], fuel[k], dist[k] = r.total_duration_h, r.total_fuel_t, r.total_distance_nm
        ref[k], viol[k] = refereed(r, wx, ship, t0)
    return {"speed_kn": speeds, "arrival_h": arrival, "fuel_t": fuel, "distance_nm": dist, "referee_fuel_t": ref,
            "violations": viol, "routes": routes}  # fmt: skip


def refereed(route: orx.Route, wx: Any, ship: orx.Ship, t0: np.datetime64) -> tuple[float, float]:
    """(the referee's fuel [t], its number of violations) of a DP route sailed as a plan (NaN, NaN if it cannot be)."""
    try:
        plan = orx.Plan.from_schedule(route.waypoints, route.stw_kn, departure=t0, ship=ship, weather=wx,
                                      times=route.times)  # fmt: skip
    except orx.OptrouteError:
        return float("nan"), float("nan")
    return plan.total_fuel_t, float(len(plan.verify()))


def baseline_at(curve: dict[str, Any], eta_h: float) -> int | None:
    """Index of the lattice speed whose constant-speed route arriving by ``eta_h`` uses least fuel (None: none does).

    No interpolation between speeds: the baseline is a schedule the DP's lattice can represent.
    """
    ok = np.isfinite(curve["arrival_h"]) & (curve["arrival_h"] <= eta_h + 1e-9)
    if not ok.any():
        return None
    idx = np.flatnonzero(ok)
    return int(idx[np.argmin(curve["fuel_t"][idx])])


def dp_at(curve_end_h: np.ndarray, curve_fuel_t: np.ndarray, eta_h: float) -> float:
    """The DP's least fuel [t] over its arrival bins that end by ``eta_h`` (NaN when none does)."""
    ok = np.isfinite(curve_fuel_t) & (curve_end_h <= eta_h + 1e-9)
    return float(np.min(curve_fuel_t[ok])) if ok.any() else float("nan")


def _nlp(row: dict[str, Any], route: orx.Route, wx: Any, ship: orx.Ship, t0: np.datetime64, eta_h: float) -> None:
    """The NLP in the baseline route's corridor, scored by the referee; fills the row's ``nlp_*`` fields."""
    eta = t0 + np.timedelta64(int(round(eta_h * 3600)), "s")
    t = time.perf_counter()
    try:
        plan = orx.optimise_corridor(route.corridor(width_nm=CORRIDOR_WIDTH_NM), wx, ship, departure=t0,
                                     eta=eta, objective="fuel", route=route, max_leg_nm=60.0)  # fmt: skip
    except orx.OptrouteError as exc:
        row.update(nlp_state=FAILED, nlp_violations=None, nlp_status=f"failed: {type(exc).__name__}",
                   nlp_error=str(exc)[:300])  # fmt: skip
    else:
        bad = len(plan.verify())
        row.update(nlp_t=plan.total_fuel_t, nlp_arrival_h=plan.duration_h, nlp_violations=bad,
                   nlp_state=OK if bad == 0 else UNVERIFIED, nlp_status=plan.status if bad == 0 else f"{bad} violations")  # fmt: skip
    row["nlp_s"] = time.perf_counter() - t


def run_case(case: int, cfg: dict[str, Any]) -> dict[str, Any]:
    ship = orx.Ship.preset(SHIP)
    wx = orx.scenarios.shao_case(case)
    t0 = wx.time.values[0]
    t = time.perf_counter()
    curve = baseline_curve(wx, ship, t0, cfg)
    baseline_s = time.perf_counter() - t
    # one DP run gives its whole fuel-versus-arrival curve (least fuel per arrival bin of width dt)
    eta_last = t0 + np.timedelta64(int(round(max(cfg["etas_h"]) * 3600)), "s")
    t = time.perf_counter()
    dp = _search(wx, ship, t0, cfg["dp"], eta=eta_last, speeds_kn=lattice_speeds(ship, cfg))
    dp_s = time.perf_counter() - t
    end_h, dp_fuel = np.asarray(dp.stats["curve_bin_end_h"], float), np.asarray(dp.stats["curve_fuel_t"], float)
    rows = []
    for eta_h in cfg["etas_h"]:
        k = baseline_at(curve, eta_h)
        nan = float("nan")
        row: dict[str, Any] = {
            "eta_h": float(eta_h),
            "baseline_t": nan if k is None else float(curve["fuel_t"][k]),
            "baseline_speed_kn": nan if k is None else float(curve["speed_kn"][k]),
            "baseline_arrival_h": nan if k is None else float(curve["arrival_h"][k]),
            "baseline_ref_t": nan if k is None else float(curve["referee_fuel_t"][k]),
            "baseline_violations": None if k is None or not np.isfinite(curve["violations"][k]) else int(curve["violations"][k]),
            "dp_t": dp_at(end_h, dp_fuel, eta_h),
            "nlp_t": nan, "nlp_arrival_h": nan, "nlp_state": "", "nlp_status": "",
        }  # fmt: skip
        if any(abs(eta_h - e) < 1e-9 for e in cfg["nlp_etas_h"]):
            _nlp(row, curve["routes"][k] if k is not None else dp, wx, ship, t0, eta_h)
        rows.append(row)
    curve.pop("routes")
    nlp_s = sum(r.get("nlp_s", 0.0) for r in rows)
    return {"case": case, "rows": rows, "baseline_curve": curve, "dp_curve": {"bin_end_h": end_h, "fuel_t": dp_fuel},
            "dp_transitions": dp.stats["n_transitions"], "baseline_s": baseline_s, "dp_s": dp_s, "nlp_s": nlp_s,
            "dp_missing": sum(not np.isfinite(r["dp_t"]) for r in rows), "comparison": comparison(rows),
            **window(rows), "paper": PAPER[case]}  # fmt: skip


WHAT = (
    "The NLP against the constant-speed baseline on the DP's lattice, both scored by the referee (plan evaluator "
    "and `Plan.verify()`) with the same weather, ship and ETA, at the ETAs where the NLP ran"
)


def comparison(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Baseline and NLP outcomes (clean, unverified, failed) at the ETAs where the NLP ran, by the referee."""
    cases = []
    for r in rows:
        if not r.get("nlp_state"):
            continue
        bv = r["baseline_violations"]
        base = (Outcome.failed("baseline", runtime_s=0.0, error="no lattice speed arrives by the ETA") if bv is None
                else Outcome.scored("baseline", fuel_t=r["baseline_ref_t"],
                                    runtime_s=0.0, violations=bv))  # fmt: skip
        if r["nlp_state"] == FAILED:
            nlp = Outcome.failed("NLP", runtime_s=r["nlp_s"], error=r.get("nlp_status", "failed"))
        else:
            nlp = Outcome.scored("NLP", fuel_t=r["nlp_t"], runtime_s=r["nlp_s"], violations=r["nlp_violations"])
        cases.append({"baseline": base, "NLP": nlp})
    return compare(cases, ("baseline", "NLP"), "baseline", WHAT)


def window(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The ETAs where the DP (and the NLP) save more than :data:`SAVING_TOL` of the baseline, and the largest saving.

    The DP against the baseline's own (lattice) fuel, the NLP against the baseline's referee fuel; an NLP plan
    that is not clean does not count.
    """
    out: dict[str, Any] = {}
    for key, base in (("dp", "baseline_t"), ("nlp", "baseline_ref_t")):
        etas, best = [], {"saving_t": float("nan"), "saving_pct": float("nan"), "eta_h": float("nan")}
        for r in rows:
            b, f = r[base], r[f"{key}_t"]
            if not (np.isfinite(b) and np.isfinite(f)) or (key == "nlp" and r.get("nlp_state") != OK):
                continue
            if b - f > SAVING_TOL * b:
                etas.append(r["eta_h"])
            if not np.isfinite(best["saving_t"]) or b - f > best["saving_t"]:
                best = {"saving_t": b - f, "saving_pct": 100.0 * (b - f) / b, "eta_h": r["eta_h"]}
        out[f"{key}_window_h"] = (min(etas), max(etas)) if etas else None
        out[f"{key}_best"] = best
    return out


def figure(res: dict[str, Any], path: Any) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from optroute.plot.common import save_png

    fig = Figure(figsize=(7.5, 4.8))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    eta = np.array([r["eta_h"] for r in res["rows"]])
    for key, label, style in (("baseline", "constant lattice speed, shortest safe route", "k-o"), ("dp", "3-D DP", "b-s"),
                              ("nlp", "NLP in the baseline route's corridor", "r^")):  # fmt: skip
        y = np.array([r[f"{key}_t"] for r in res["rows"]])
        ok = np.isfinite(y)
        ax.plot(eta[ok], y[ok], style, label=label, ms=4)
    lo, hi = res["paper"]["window_h"]
    ax.axvspan(lo, hi, color="tab:orange", alpha=0.15, label=f"paper's window {lo:g}–{hi:g} h")
    ax.set_xlabel("required arrival time [h]")
    ax.set_ylabel("fuel [t]")
    ax.set_title(f"Seed 001 case {'I' * res['case']}: fuel vs ETA ({SHIP})")
    ax.legend(fontsize=8)
    return save_png(fig, path)


def _f(x: float, fmt: str) -> str:
    return format(x, fmt) if np.isfinite(x) else "–"


def _nlp_cell(r: dict[str, Any]) -> str:
    if not r["nlp_state"]:
        return "–"
    return r["nlp_status"] if r["nlp_state"] == FAILED else f"{r['nlp_state']} ({r['nlp_status']})"


def _fmt_window(w: tuple[float, float] | None) -> str:
    return "none" if w is None else f"{w[0]:g}–{w[1]:g} h"


def run(quick: bool) -> dict[str, Any]:
    """Both cases (case I with ``quick``): curves, windows, figures; print the tables."""
    cfg = settings(quick)
    print(load_line("load average at start"))
    out: dict[str, Any] = {"settings": cfg, "cases": [], "figures": []}
    for case in cfg["cases"]:
        res = run_case(case, cfg)
        png = figure(res, results_dir() / f"shao_case{case}.png")
        out["cases"].append(res)
        out["figures"].append(str(png))
        d = cfg["dp"]
        print(f"\n### Seed 001 case {'I' * case} — `{SHIP}`, DP lattice ΔX {d['dx_nm']:g} nm, ΔY {d['dy_nm']:g} nm "
              f"(±{d['half_width_nm']:g} nm), Δt {d['dt_h']:g} h, speeds every {cfg['dp_speeds_kn'][1]:g} kn\n")  # fmt: skip
        print("_Baseline and DP: the DP's own fuel accounting on the same lattice (the baseline is a schedule the DP "
              "can represent); baseline (referee) and NLP: the plan evaluator's fuel of each plan, `verify()` findings "
              "counted._\n")  # fmt: skip
        print("| ETA [h] | baseline [t] (lattice speed [kn]) | DP [t] | DP / baseline | baseline by referee [t] "
              "(violations) | NLP [t] | NLP / baseline by referee | NLP plan |")  # fmt: skip
        print("|---:|---:|---:|---:|---:|---:|---:|---|")
        for r in res["rows"]:
            b, bref = r["baseline_t"], r["baseline_ref_t"]
            bv = "–" if r["baseline_violations"] is None else r["baseline_violations"]
            print(f"| {r['eta_h']:g} | {_f(b, '.1f')} ({_f(r['baseline_speed_kn'], 'g')}) | {_f(r['dp_t'], '.1f')} | "
                  f"{_f(r['dp_t'] / b, '.3f')} | {_f(bref, '.1f')} ({bv}) | {_f(r['nlp_t'], '.1f')} | "
                  f"{_f(r['nlp_t'] / bref, '.3f')} | {_nlp_cell(r)} |")  # fmt: skip
        print()
        print("\n".join(comparison_lines(res["comparison"])))
        print(f"\nETAs without a DP curve point (DP failures): {res['dp_missing']} of {len(res['rows'])}")
        p = res["paper"]
        for key, name in (("dp", "DP"), ("nlp", "NLP")):
            best = res[f"{key}_best"]
            print(f"\n{name}: saves > {SAVING_TOL:.1%} over ETAs {_fmt_window(res[f'{key}_window_h'])}; largest saving "
                  f"(negative: extra fuel) {_f(best['saving_t'], '.1f')} t ({_f(best['saving_pct'], '.1f')} %) at "
                  f"{_f(best['eta_h'], 'g')} h")  # fmt: skip
        print(f"\npaper: window {p['window_h'][0]:g}–{p['window_h'][1]:g} h; at {p['eta_h']:g} h {p['baseline_t']:g} → "
              f"{p['dp_t']:g} t ({p['saving_pct']:g} %). Runtimes: baseline curve {res['baseline_s']:.1f} s, DP "
              f"{res['dp_s']:.1f} s (one run, {res['dp_transitions']:,} transitions), NLP {res['nlp_s']:.1f} s; figure `{png.name}`\n")  # fmt: skip
    return out


def main(argv: list[str] | None = None) -> None:
    bench_main(run, __doc__.splitlines()[0], "case I only, coarse lattice, three ETAs", argv)


if __name__ == "__main__":
    main()
