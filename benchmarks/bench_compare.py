"""Optimiser vs grid search: the corridor NLP against Boeing speed stepping and the 3-D DP at three resolutions.

Two scenarios with time-varying weather in which the danger bands apply: a 717 nm corridor along
5° N (150° W → 138° W, 40 nm wide) crossed by a storm (peak H_s 8 m over a 3 m sea, Gaussian
1.5° in longitude and 3° in latitude, T_p = 3.85 sqrt(H_s)) that drifts

* **following storm**: east at 5 kn, waves from the west (following seas: the successive
  high-wave-attack and surf-riding bands lie across the passage speeds);
* **head storm**: west at 5 kn towards the ship, waves from the east (head seas: the
  parametric-roll band lies across the passage speeds).

The ship is ``Ship.preset("container_54k_dwt")`` made stiff (GM 4.5 m, T_R ≈ 9.9 s) with the bands
applied from H_s ≥ 2 % of its length (5 m; EP 2145155's alternative threshold), so the storm's sea
switches the bands on. For every scenario and ETA, side by side in one process:

* **NLP**: ``optimise_corridor(objective="fuel", max_leg_nm=30)`` on the corridor (verified plan; its legs
  cut to 20 nm or shorter where a band can bind, ``band_leg_nm``), and again with ``band_leg_nm=None``
  (30 nm legs everywhere);
* **speed stepping** (Boeing): the corridor's centreline (cut into 10 nm legs, one sea state
  each) sailed with ``optroute.search.routing.sail_route`` at the lowest desired speed on a 0.5 kn step
  whose arrival meets the ETA, forced slow-downs out of the bands included; its runtime is the
  whole scan of desired speeds, starting at the slowest one that could meet the ETA in calm water;
* **DP coarse / medium / fine**: ``search_route(method="dp", objective="fuel", eta=)`` in the same
  corridor (half-width 20 nm) with (dx, dy, dt, speed step) = (120 nm, 20 nm, 2 h, 1 kn),
  (60 nm, 10 nm, 1 h, 0.5 kn), (30 nm, 5 nm, 0.5 h, 0.25 kn).

Every result is scored by the referee: turned into a :class:`optroute.Plan` (``Plan.from_schedule``
with its waypoints and leg speeds, sailed through the same weather with the same performance model)
and checked with ``Plan.verify()`` against the corridor, the ETA, the MCR and the bands. Fuel is the
referee's (the plan evaluator's) for every method, the method's own figure kept beside it
(``own_fuel_t``); the ratios are to the NLP's. A method that raises is *failed*, a plan that fails
``verify()`` *unverified*: both are counted in the summary (:func:`benchmarks._measure.compare`),
whose means are over the cases where every method gave a clean plan, with that count beside them.
Each method runs once untimed on a short piece of the corridor first (its exact code path: numba
kernels, CasADi plugins). The figure ``compare.png`` plots fuel ratio against runtime ratio.

Run ``python -m benchmarks.bench_compare [--quick]`` (quick: the head storm at one ETA, 54 h, the DP
at its coarse and medium resolutions only).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

import optroute as orx
from benchmarks._cli import bench_main, results_dir
from benchmarks._measure import FAILED, OK, UNVERIFIED, Outcome, compare, comparison_lines, load_line
from optroute import geodesy as geo
from optroute.search.routing import sail_route
from optroute.weather import schema

T0 = np.datetime64("2024-01-10T00:00", "ns")
START, END = (5.0, -150.0), (5.0, -138.0)
WIDTH_NM = 40.0
PIECE_NM = 10.0
DP_RESOLUTIONS = {  # name: (dx [nm], dy [nm], dt [h], speed step [kn])
    "coarse": (120.0, 20.0, 2.0, 1.0),
    "medium": (60.0, 10.0, 1.0, 0.5),
    "fine": (30.0, 5.0, 0.5, 0.25),
}
DP_SPEEDS_KN = (6.0, 26.0)
#: The NLP again with its 30 nm legs left whole where a band can bind (``band_leg_nm=None``; the default cuts them)
NLP_WHOLE = "NLP, 30 nm legs everywhere"
METHODS = ("NLP", NLP_WHOLE, "speed stepping", *(f"DP {k}" for k in DP_RESOLUTIONS))


def storm_sea(speed_kn: float, lon0_deg: float, wave_from_deg: float, *, peak_hs_m: float = 8.0,
              background_hs_m: float = 3.0) -> xr.Dataset:  # fmt: skip
    """A storm drifting along 5° N at ``speed_kn`` (> 0 east) from ``lon0_deg``; waves from ``wave_from_deg``.

    H_s [m] = background + (peak − background) · exp(−Δlon²/(2·1.5²)) · exp(−(lat − 5)²/(2·3²)),
    T_p = 3.85 sqrt(H_s) [s] (a young storm sea), a 10 m/s wind blowing with the waves; 3-hourly
    for 150 h on a 0.5° grid.
    """
    time_ = T0 + (np.arange(0.0, 151.0, 3.0) * 3.6e12).astype("timedelta64[ns]")
    lat = np.arange(0.0, 10.01, 0.5)
    lon = np.arange(-155.0, -125.0 + 1e-9, 0.5)
    lon_c = lon0_deg + (np.arange(time_.size) * 3.0) * speed_kn / 60.0  # 1° of longitude ≈ 60 nm at 5° N
    bump = np.exp(-((lon[None, None, :] - lon_c[:, None, None]) ** 2) / (2 * 1.5**2))
    hs = background_hs_m + (peak_hs_m - background_hs_m) * bump * np.exp(-((lat[None, :, None] - 5.0) ** 2) / 18.0)
    to = np.radians(wave_from_deg + 180.0)  # the wind blows towards where the waves go
    return schema.canonical_dataset(
        time_, lat, lon,
        {"hs_m": hs, "tp_s": 3.85 * np.sqrt(hs), "wave_from_deg": float(wave_from_deg),
         "wind_u_ms": 10.0 * float(np.sin(to)), "wind_v_ms": 10.0 * float(np.cos(to))},
        {"title": f"storm drifting at {speed_kn:+g} kn along 5 N, waves from {wave_from_deg:g} deg",
         "source": "benchmarks.bench_compare", "geography": "synthetic"},
    )  # fmt: skip


@dataclass(frozen=True)
class Scenario:
    """One corridor, its weather, ship, band rules and the ETAs compared [h after departure]."""

    name: str
    weather: xr.Dataset
    etas_h: tuple[float, ...]
    ship: orx.Ship = field(default_factory=lambda: orx.Ship.preset("container_54k_dwt").replace(gm_m=4.5))
    rules: orx.BandRules = field(default_factory=lambda: orx.BandRules(hs_threshold_fraction=0.02))
    end: tuple[float, float] = END

    @property
    def corridor(self) -> orx.Corridor:
        return orx.Corridor.from_waypoints([START, self.end], width_nm=WIDTH_NM)


def scenarios(quick: bool) -> list[Scenario]:
    """The scenarios (one at one ETA with ``quick``)."""
    head = storm_sea(-5.0, -140.0, 90.0)
    if quick:
        return [Scenario("head storm", head, (54.0,))]
    return [
        Scenario("following storm", storm_sea(5.0, -146.0, 270.0), (38.0, 42.0, 46.0)),
        Scenario("head storm", head, (42.0, 46.0, 50.0)),
    ]


def warm_up(levels: tuple[str, ...]) -> None:
    """Run every method once, untimed, on the first 180 nm of the head storm's corridor (the same code paths)."""
    short = Scenario("warm-up", storm_sea(-5.0, -140.0, 90.0), (14.0,), end=(START[0], START[1] + 3.0))
    run_nlp(short, 14.0)
    run_stepping(short, 14.0)
    for lv in levels:
        run_dp(short, 14.0, lv)


# --------------------------------------------------------------------------- one method, one row
def _check(
    waypoints: np.ndarray, stw_kn: np.ndarray, sc: Scenario, eta: np.datetime64
) -> tuple[float, int | None, str]:
    """Sail the waypoints at the leg speeds through the weather as a Plan: (referee's fuel [t], violations, summary).

    ``violations`` is None (fuel NaN) when the schedule cannot be sailed as a plan at all.
    """
    try:
        plan = orx.Plan.from_schedule(waypoints, stw_kn, departure=T0, ship=sc.ship, weather=sc.weather,
                                      rules=sc.rules, corridor=sc.corridor, eta=eta)  # fmt: skip
    except orx.OptrouteError as exc:
        return float("nan"), None, f"not sailable as a plan ({type(exc).__name__})"
    bad = plan.verify()
    if not bad:
        return plan.total_fuel_t, 0, "clean"
    kinds = sorted({v.kind for v in bad})
    return plan.total_fuel_t, len(bad), f"{len(bad)} violations ({', '.join(kinds)})"


def _row(method: str, fuel_t: float, arrival_h: float, eta_h: float, runtime_s: float, violations: int | None,
         note: str, **extra: Any) -> dict[str, Any]:  # fmt: skip
    """One method's row; ``fuel_t`` is the referee's, ``state`` ok (clean plan), unverified or failed."""
    state = OK if violations == 0 and np.isfinite(fuel_t) else UNVERIFIED
    return {"method": method, "state": state, "fuel_t": fuel_t, "arrival_h": arrival_h,
            "eta_met": bool(arrival_h <= eta_h + 1 / 60), "runtime_s": runtime_s, "verify_clean": state == OK,
            "violations": violations, "verify": note, **extra}  # fmt: skip


def _failed(method: str, runtime_s: float, exc: Exception) -> dict[str, Any]:
    return {"method": method, "state": FAILED, "fuel_t": float("nan"), "arrival_h": float("nan"), "eta_met": False,
            "runtime_s": runtime_s, "verify_clean": False, "violations": None,
            "verify": f"failed: {type(exc).__name__}", "error": str(exc)[:300]}  # fmt: skip


def outcome(row: dict[str, Any]) -> Outcome:
    """A row as the comparison's :class:`~benchmarks._measure.Outcome`."""
    return Outcome(row["method"], row["state"], float(row["fuel_t"]), float(row["runtime_s"]), row["violations"],
                   row["verify"])  # fmt: skip


def run_nlp(sc: Scenario, eta_h: float, whole_legs: bool = False) -> dict[str, Any]:
    eta = T0 + np.timedelta64(int(round(eta_h * 3600)), "s")
    name, kw = (NLP_WHOLE, {"band_leg_nm": None}) if whole_legs else ("NLP", {})
    t = time.perf_counter()
    try:
        plan = orx.optimise_corridor(sc.corridor, sc.weather, sc.ship, departure=T0, eta=eta, rules=sc.rules,
                                     objective="fuel", max_leg_nm=30.0, **kw)  # fmt: skip
    except orx.OptrouteError as exc:
        return _failed(name, time.perf_counter() - t, exc)
    sec = time.perf_counter() - t
    bad = plan.verify()
    st = plan.solver_stats
    return _row(name, plan.total_fuel_t, plan.duration_h, eta_h, sec, len(bad), "clean" if not bad else f"{len(bad)}",
                own_fuel_t=plan.total_fuel_t, legs=int(plan.legs.shape[0]), status=plan.status,
                nlp_solves=st.get("nlp_solves"), ipopt_s=st.get("solve_time_s"))  # fmt: skip


def run_stepping(sc: Scenario, eta_h: float) -> dict[str, Any]:
    """The lowest desired speed on a 0.5 kn step whose Boeing passage along the centreline meets the ETA."""
    eta = T0 + np.timedelta64(int(round(eta_h * 3600)), "s")
    wp = np.asarray(sc.corridor.resample(PIECE_NM).waypoints)
    d_nm = float(np.sum(geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])))
    top = float(min(sc.ship.max_calm_speed_kn, 40.0))
    # no slower desired speed can arrive in time (SOG ≤ STW ≤ desired, no current)
    v = np.floor(2.0 * d_nm / eta_h) / 2.0
    t = time.perf_counter()
    tried, route, last_exc = 0, None, None
    while v <= top + 1e-9:
        tried += 1
        try:
            r = sail_route(wp, sc.weather, sc.ship, departure=T0, desired_speed_kn=float(v), rules=sc.rules,
                           piece_nm=PIECE_NM * 1.05, speed_step_kn=0.5)  # fmt: skip
        except orx.NoSafePassage as exc:
            last_exc = exc
            v += 0.5
            continue
        if r.total_duration_h <= eta_h + 1 / 60:
            route = r
            break
        route = r  # the latest (fastest) attempt so far, reported as missing the ETA if nothing meets it
        v += 0.5
    sec = time.perf_counter() - t
    if route is None:
        return _failed("speed stepping", sec, last_exc or orx.NoSafePassage("no desired speed could sail the route"))
    fuel, violations, note = _check(route.waypoints, route.stw_kn, sc, eta)
    return _row("speed stepping", fuel, route.total_duration_h, eta_h, sec, violations, note,
                own_fuel_t=route.total_fuel_t, desired_kn=float(min(v, top)), speeds_tried=tried,
                min_stw_kn=route.stats["min_stw_kn"])  # fmt: skip


def run_dp(sc: Scenario, eta_h: float, level: str) -> dict[str, Any]:
    dx, dy, dt, step = DP_RESOLUTIONS[level]
    eta = T0 + np.timedelta64(int(round(eta_h * 3600)), "s")
    speeds = np.arange(DP_SPEEDS_KN[0], DP_SPEEDS_KN[1] + 1e-9, step)
    start, end = (np.asarray(w, float) for w in sc.corridor.waypoints[[0, -1]])
    t = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            r = orx.search_route(tuple(start), tuple(end), sc.weather, sc.ship, departure=T0, method="dp",
                                 objective="fuel", eta=eta, rules=sc.rules, speeds_kn=speeds,
                                 dp_options={"dx_nm": dx, "dy_nm": dy, "half_width_nm": WIDTH_NM / 2, "dt_h": dt})  # fmt: skip
    except orx.OptrouteError as exc:
        return _failed(f"DP {level}", time.perf_counter() - t, exc)
    sec = time.perf_counter() - t
    stw = np.where(np.isfinite(r.stw_kn) & (r.stw_kn > 0), r.stw_kn, r.sog_kn)
    fuel, violations, note = _check(r.waypoints, stw, sc, eta)
    return _row(f"DP {level}", fuel, r.total_duration_h, eta_h, sec, violations, note, own_fuel_t=r.total_fuel_t,
                resolution=f"{dx:g} nm, {dy:g} nm, {dt:g} h, {step:g} kn", transitions=r.stats["n_transitions"])  # fmt: skip


# --------------------------------------------------------------------------- the table and the figure
def _ratios(rows: list[dict[str, Any]]) -> None:
    nlp = rows[0]
    for r in rows:
        r["fuel_ratio"] = r["fuel_t"] / nlp["fuel_t"] if np.isfinite(nlp["fuel_t"]) else float("nan")
        r["runtime_ratio"] = r["runtime_s"] / nlp["runtime_s"]


def _f(x: float, fmt: str) -> str:
    return format(x, fmt) if np.isfinite(x) else "–"


def _yes(flag: bool) -> str:
    return "yes" if flag else "**no**"


def print_table(cases: list[dict[str, Any]]) -> None:
    print("| scenario | ETA [h] | method | fuel [t] | fuel / NLP | ETA met (arrival [h]) | runtime [s] | "
          "runtime / NLP | referee |")  # fmt: skip
    print("|---|---:|---|---:|---:|---|---:|---:|---|")
    for c in cases:
        for r in c["rows"]:
            met = f"{_yes(r['eta_met'])} ({r['arrival_h']:.2f})" if np.isfinite(r["arrival_h"]) else "–"
            print(f"| {c['scenario']} | {c['eta_h']:g} | {r['method']} | {_f(r['fuel_t'], '.2f')} | "
                  f"{_f(r['fuel_ratio'], '.3f')} | {met} | {r['runtime_s']:.2f} | {r['runtime_ratio']:.2f} | "
                  f"{r['state']} ({r['verify']}) |")  # fmt: skip


WHAT = (
    "Each method's plan scored by the referee (plan evaluator and `Plan.verify()`) on the same corridor, ETA, "
    "ship model and band rules; runtime is each method's whole call (the stepping: its scan of desired speeds)"
)


def summary(cases: list[dict[str, Any]]) -> dict[str, Any]:
    """The comparison over the cases: per method clean, unverified and failed plans, means over the common cases."""
    methods = [m for m in METHODS if any(r["method"] == m for c in cases for r in c["rows"])]
    return compare([{r["method"]: outcome(r) for r in c["rows"]} for c in cases], methods, "NLP", WHAT)


def figure(cases: list[dict[str, Any]], path: Any) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from optroute.plot.common import save_png

    fig = Figure(figsize=(7.5, 5.0))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    colours = dict(zip(METHODS, ("black", "tab:grey", "tab:red", "tab:blue", "tab:green", "tab:purple"), strict=True))
    markers = ["o", "s", "^", "D"]
    names = list(dict.fromkeys(c["scenario"] for c in cases))
    for c in cases:
        for r in c["rows"]:
            if not np.isfinite(r["fuel_ratio"]):
                continue
            ax.scatter(r["runtime_ratio"], r["fuel_ratio"], color=colours[r["method"]],
                       marker=markers[names.index(c["scenario"]) % len(markers)],
                       facecolors="none" if not (r["eta_met"] and r["verify_clean"]) else colours[r["method"]])  # fmt: skip
    for m in METHODS:
        ax.scatter([], [], color=colours[m], label=m)
    for k, n in enumerate(names):
        ax.scatter([], [], color="grey", marker=markers[k % len(markers)], label=n)
    ax.axhline(1.0, color="grey", lw=0.8)
    ax.set_xscale("log")
    ax.set_xlabel("runtime / NLP runtime [-]")
    ax.set_ylabel("fuel / NLP fuel [-]")
    ax.set_title("Optimiser vs grid search (hollow: ETA missed or plan not clean)")
    ax.legend(fontsize=8)
    return save_png(fig, path)


def run(quick: bool) -> dict[str, Any]:
    """Run every scenario, ETA and method; print the table; write ``compare.png``; return the figures."""
    levels = ("coarse", "medium") if quick else tuple(DP_RESOLUTIONS)
    warm_up(levels)  # numba kernels, CasADi plugins and caches loaded outside the timings
    print(load_line("load average after the warm-up"))
    cases = []
    for sc in scenarios(quick):
        for eta_h in sc.etas_h:
            rows = [run_nlp(sc, eta_h), run_nlp(sc, eta_h, whole_legs=True), run_stepping(sc, eta_h),
                    *(run_dp(sc, eta_h, lv) for lv in levels)]  # fmt: skip
            _ratios(rows)
            cases.append({"scenario": sc.name, "eta_h": eta_h, "rows": rows})
    print(load_line("load average at the end"))
    print(f"\n### NLP vs speed stepping vs 3-D DP — {START} → {END}, corridor {WIDTH_NM:g} nm wide, "
          "`container_54k_dwt` with GM 4.5 m, bands from Hs ≥ 0.02 L\n")  # fmt: skip
    print(f"_{WHAT}; fuel [t] is the referee's, the method's own figure in the JSON (`own_fuel_t`)._\n")
    print_table(cases)
    summ = summary(cases)
    print()
    print("\n".join(comparison_lines(summ)))
    png = figure(cases, results_dir() / "compare.png")
    print(f"\nfigure: `{png.name}`\n")
    return {"cases": cases, "comparison": summ, "figures": [str(png)]}


def main(argv: list[str] | None = None) -> None:
    bench_main(run, __doc__.splitlines()[0], "one scenario at one ETA, the DP at two resolutions", argv)


if __name__ == "__main__":
    main()
