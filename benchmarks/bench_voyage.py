"""Voyage simulator: the value of re-planning on each forecast when the forecast misplaces a storm.

Hidden-truth suite: a 12.5 m storm (:func:`optroute.scenarios.moving_storm_spec`) moving south at
10 kn across a 520 nm passage at 30° N (container_54k_dwt, ETA 42 h); the ship sees only forecasts
(:func:`optroute.scenarios.converging_forecasts`) that displace, delay or weaken the storm and
converge on the truth by a stated time. For every case: (a) plan once on the first forecast and
sail it blind, (b) re-plan on each forecast (:class:`optroute.voyage.ReplanPolicy`) warm-started from the
plan being sailed, (b') the same from cold starts, (c) plan once robustly on an ensemble about the
first forecast (its storm's track moved by N(0, 150 nm) east and north, its timing by N(0, 3 h), its
intensity by a log-normal factor of sigma 0.1: :func:`optroute.weather.scenarios.ensemble`) with
``optimise_corridor(..., robust="all")`` in the 400 nm corridor about the great circle on the members that
:func:`unsolved_alone` keeps (those screened out are named and counted in the row), and sail it blind; the table
gives the time sailed inside a danger band of the truth, the time the plan's speed met a band, the ETA miss, the
fuel, the re-plans, and the simulation CPU per simulated day, with (a) as the baseline of the fuel and CPU (same
process, same truth); (c)'s CPU is the screening and the robust planning plus the sailing, and its row says how many
of all the members (the screened ones too) the robust plan is clean in and how many (a)'s plan breaks
(:func:`optroute.member_violations`), how often robust.py's tightening loop fired, and whether the ensemble's spread
covers the truth (:func:`coverage`: the true storm centre inside the hull of the members' at the crossing hour, the
nearest member's distance). Full mode: 10 members, on the 150 nm spread and on a spread as large as the case's
forecast error (:func:`covering_spread`); quick mode: 4 members, the 150 nm spread. CPU [s] is this process's (the
machine is shared: compare CPU, not wall); each case's ratios are to its own (a), so the cases may run in separate
processes (``run(False, only=k)``).

Run ``python -m benchmarks.bench_voyage [--quick]``; the reduced full mode (the first case only, with the cold
re-plans and the 10-member robust plan) is ``python -c "from benchmarks.bench_voyage import run; run(False, n_cases=1)"``.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import numpy as np

import optroute as orx
from benchmarks._cli import bench_main
from optroute.voyage import ReplanPolicy
from optroute.weather import forecast as fc
from optroute.weather import scenarios as sc
from optroute.weather import storms as stm

SHIP = orx.Ship.preset("container_54k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")
A, B = (30.0, -150.0), (30.0, -140.0)
ETA = T0 + np.timedelta64(42, "h")
OPTS = {
    "max_leg_nm": 30.0,
    "samples_per_leg": 5,
    "band_margin": 0.05,
    "band_hs_margin": 0.1,
    "use_land_mask": False,
}
KW = {"start": T0, "duration_h": 60.0, "step_h": 3.0, "resolution_deg": 0.5, "bbox": (18, 42, -156, -134)}

#: (name, displacement [nm], bearing [deg], delay [h], intensity factor, issue hours, converged [h])
CASES = (
    ("300 nm north", 300.0, 0.0, 0.0, 1.0, (0.0, 3.0), 3.0),
    ("300 nm south, 6 h early", 300.0, 180.0, -6.0, 1.0, (0.0, 6.0, 12.0), 12.0),
    ("200 nm east, under-forecast x0.8", 200.0, 90.0, 0.0, 0.8, (0.0, 6.0), 6.0),
)


#: The robust plan's ensemble spread about the first forecast's storm and its corridor (total width [nm]).
ENSEMBLE = {"position_sigma_nm": 150.0, "timing_sigma_h": 3.0, "intensity_sigma": 0.1}
ROBUST_WIDTH_NM = 400.0
#: Hour [h since departure] at which the storms' centres are compared (the true storm crosses 30° N then).
CROSSING_H = 24.0


def covering_spread(spec: tuple) -> dict[str, float]:
    """An ensemble spread as large as the case's forecast error: the distance between the first forecast's and the
    true storm centre at :data:`CROSSING_H` (displacement and timing error together) as the position sigma [nm], the
    delay as the timing sigma (at least 3 h), |ln intensity factor| as the intensity sigma (at least 0.1)."""
    from optroute.geodesy import inverse

    _, dist, brg, delay, fac, _, _ = spec
    first = fc.displaced_storms([_storm()], displacement_nm=dist, bearing_deg=brg, delay_h=delay, intensity_factor=fac)
    (la, lo), (lb, lb_lon) = _centre(first[0].track, CROSSING_H), _centre(_storm().track, CROSSING_H)
    error_nm = float(inverse(la, lo, lb, lb_lon)[0])
    return {
        "position_sigma_nm": max(150.0, error_nm),
        "timing_sigma_h": max(3.0, abs(float(delay))),
        "intensity_sigma": max(0.1, abs(float(np.log(fac)))),
    }


def _centre(track: Any, hour: float) -> tuple[float, float]:
    tr = np.asarray(track, dtype=float)
    return float(np.interp(hour, tr[:, 0], tr[:, 1])), float(np.interp(hour, tr[:, 0], tr[:, 2]))


def coverage(ens: Any) -> dict[str, Any]:
    """Whether the ensemble's spread covers the truth: its members' storm centres at :data:`CROSSING_H` (timing
    errors included: a late storm is further north) against the true storm's, in a local east/north frame [nm].

    ``inside``: the truth's centre lies inside the convex hull of the members' (``scipy.spatial.Delaunay``);
    ``nearest_nm``: the distance from the truth's centre to the nearest member's; ``intensity``: whether the true
    peak lies within the members' peaks.
    """
    import json

    from scipy.spatial import Delaunay

    truth = _storm()
    lat0, lon0 = _centre(truth.track, CROSSING_H)
    members = json.loads(ens.attrs["ensemble"])["members"]
    xy, peaks = [], []
    for m in members:
        st = m["storms"][0]
        lat, lon = _centre(st["track"], CROSSING_H)
        xy.append(((lon - lon0) * 60.0 * np.cos(np.radians(lat0)), (lat - lat0) * 60.0))
        peaks.append(float(st["peak_hs_m"]))
    pts = np.array(xy)
    inside = bool(len(pts) >= 3 and Delaunay(pts).find_simplex(np.zeros((1, 2)))[0] >= 0)
    return {
        "inside": inside,
        "nearest_nm": float(np.min(np.hypot(pts[:, 0], pts[:, 1]))),
        "intensity": bool(min(peaks) <= truth.peak_hs_m <= max(peaks)),
    }


def _storm() -> Any:
    return sc.moving_storm_spec(34.0, -145.0, 180.0, 10.0, peak_hs_m=12.5, radius_nm=150.0, duration_h=60.0)


def _storm_dataset(storms: list, **kwargs: Any) -> Any:
    return stm.storm_dataset(storms, **kwargs)


def shared_options() -> dict[str, Any]:
    """``prepare_members``' options of the robust plan (c): :data:`OPTS` with the ETA and the defaults spelt out."""
    o = OPTS
    return {
        "departure": T0, "latest_eta": ETA, "objective": "fuel", "model": None, "rules": None,
        "max_leg_nm": o["max_leg_nm"], "samples_per_leg": o["samples_per_leg"], "fuel_price_per_t": 600.0,
        "hourly_cost_per_h": 0.0, "exclusion": None, "speed_range_kn": None, "band_margin": o["band_margin"],
        "band_hs_margin": o["band_hs_margin"], "verify_step_nm": 5.0, "use_land_mask": False,
    }  # fmt: skip


def unsolved_alone(ens: Any) -> list[int]:
    """The members whose own problem (the robust NLP on that member alone, the lateral bounds of all) Ipopt does not
    solve from the ETA's constant-speed centreline start: one plan for every member cannot be found while one of them
    alone is not. Not a proof that no plan exists in the member (seed 1's member 8 of the 300 nm north case puts the
    storm over the destination, where only racing ahead of it is safe), which is why (c) names and counts them and
    reports the plan's violations in them too."""
    from formulations.robust_nlp import RobustSpeedNLP
    from optroute.optimise.nlp_inputs import formulation_bands
    from optroute.optimise.robust import member_datasets, prepare_members

    corridor = orx.Corridor.from_waypoints([A, B], width_nm=ROBUST_WIDTH_NM)
    prepared, y_lo, y_hi = prepare_members(corridor, member_datasets(ens), SHIP, shared_options(), 0)
    ref = prepared[0]
    bands, _, a = formulation_bands(ref.ship, ref.rules, widen=ref.margin0, hs_margin=ref.hs_margin0)
    eta_h, n = float((ETA - T0) / np.timedelta64(1, "h")), ref.frame.n_legs
    out = []
    for k, p in enumerate(prepared):
        nlp = RobustSpeedNLP(
            ref.frame.geometry(y_lo, y_hi), [p.grid], ref.power, bands=bands, samples_per_leg=ref.samples_per_leg,
            v_min_kn=ref.v_min, v_max_kn=ref.v_max, g_over_2pi_kn_s=a,
        )  # fmt: skip
        res = nlp.solve_sides(
            eta_h=eta_h, offset0_nm=np.zeros(n + 1), stw0_kn=np.full(n, ref.length_nm / eta_h), max_solves=6
        )
        if res.status != "Solve_Succeeded":
            out.append(k)
    return out


def _robust_plan(spec: tuple, members: int, spread: dict[str, float]) -> dict[str, Any]:
    """(c): the robust plan on an ensemble about the first forecast (issued at departure), and its wall time.

    ``robust="all"`` on the members :func:`unsolved_alone` keeps (the screened ones named in ``screened``)."""
    _, dist, brg, delay, fac, _, _ = spec
    first = fc.displaced_storms([_storm()], displacement_nm=dist, bearing_deg=brg, delay_h=delay, intensity_factor=fac)
    t, cpu = time.perf_counter(), time.process_time()
    ens = sc.ensemble(_storm_dataset, members, seed=1, storms=first, background_hs_m=1.5, **spread, **KW)
    corridor = orx.Corridor.from_waypoints([A, B], width_nm=ROBUST_WIDTH_NM)
    cover = coverage(ens)
    screened = unsolved_alone(ens)
    kept = [k for k in range(members) if k not in screened]
    out = {"ensemble": ens, "coverage": cover, "screened": screened}
    try:
        if not kept:
            raise orx.OptrouteError(f"every member screened out: {screened}")
        sub = ens.isel(member=kept)
        sub.attrs = dict(ens.attrs)
        plan = orx.optimise_corridor(corridor, sub, SHIP, departure=T0, eta=ETA, robust="all", **OPTS)
    except orx.OptrouteError as exc:
        return {"error": f"{type(exc).__name__}: {str(exc)[:200]}", "wall_s": time.perf_counter() - t,
                "cpu_s": time.process_time() - cpu, **out}  # fmt: skip
    return {"plan": plan, "wall_s": time.perf_counter() - t, **out}


def _case(spec: tuple) -> tuple[Any, list]:
    _, dist, brg, delay, fac, hours, conv = spec
    storm = _storm()
    truth = sc.storm_dataset([storm], background_hs_m=1.5, **KW)
    fcs = sc.converging_forecasts(
        [storm], list(hours), converged_h=conv, displacement_nm=dist, bearing_deg=brg, delay_h=delay,
        intensity_factor=fac, background_hs_m=1.5, **KW,
    )  # fmt: skip
    return truth, fcs


def _sail(truth: Any, fcs: list, policy: ReplanPolicy, warm: bool = True, plan: Any = None) -> dict[str, Any]:
    t, cpu = time.perf_counter(), time.process_time()
    try:
        res = orx.simulate_voyage(
            plan if plan is not None else (A, B), truth, SHIP, forecasts=fcs, replan=policy,
            departure=T0, eta=ETA, optimise_options=OPTS, corridor_width_nm=400.0, step_h=0.5, warm_start=warm,
        )  # fmt: skip
    except orx.OptrouteError as exc:
        return {"error": f"{type(exc).__name__}: {str(exc)[:200]}", "wall_s": time.perf_counter() - t,
                "cpu_s": time.process_time() - cpu}  # fmt: skip
    wall, cpu = time.perf_counter() - t, time.process_time() - cpu
    o = res.outcome
    failed = [str(s) for s in res.log["replan_status"].values if str(s).startswith("failed")]
    return {
        "time_in_band_h": o.time_in_band_h,
        "time_band_met_h": o.time_band_met_h,
        "eta_miss_h": o.eta_miss_h,
        "eta_met": bool(o.eta_met),
        "fuel_t": o.fuel_t,
        "replans": o.n_replans,
        "failed_replans": len(failed),
        "wall_s": wall,
        "wall_s_per_sim_day": wall / (o.duration_h / 24.0),
        "cpu_s": cpu,
        "cpu_s_per_sim_day": cpu / (o.duration_h / 24.0),
        "sim_days": o.duration_h / 24.0,
        "plan": res.plans[0],
        "fuel_planned_t": [float(p.total_fuel_t) for p in res.plans],
    }


def _robust_row(
    spec: tuple, truth: Any, fcs: list, members: int, name: str, spread: dict, once: Any = None
) -> tuple[str, dict]:
    """(c) on one ensemble spread: the robust plan, checked in every member (the screened ones too, by
    :func:`optroute.member_violations`, beside (a)'s plan ``once``), sailed blind through the truth."""
    cpu = time.process_time()
    robust = _robust_plan(spec, members, spread)
    robust_cpu = time.process_time() - cpu
    cov = robust["coverage"]
    covers = (
        f"truth {'inside' if cov['inside'] else 'outside'} the members' hull, nearest member {cov['nearest_nm']:.0f} nm"
        f"{'' if cov['intensity'] else ', intensity outside'}"
    )
    screened = robust["screened"]
    label = (
        f"(c) robust='all', {members} members, spread {name} ({covers}); {len(screened)} screened out "
        f"{screened} (unsolved alone)"
    )
    if "error" in robust:
        return label, robust
    plans = {"robust": robust["plan"], **({} if once is None else {"(a)": once})}
    table = orx.member_violations(plans, robust["ensemble"])
    r = table.loc["robust"]
    checked = members - int(r["members_violated"])
    sailed = _sail(truth, fcs, ReplanPolicy.never(), plan=robust["plan"])
    if "error" not in sailed:
        sailed["wall_s"] += robust["wall_s"]  # planning included: (a)'s wall includes its first plan too
        sailed["wall_s_per_sim_day"] = sailed["wall_s"] / sailed["sim_days"]
        sailed["cpu_s"] += robust_cpu
        sailed["cpu_s_per_sim_day"] = sailed["cpu_s"] / sailed["sim_days"]
    sailed["robust_plan_wall_s"], sailed["robust_plan_cpu_s"] = robust["wall_s"], robust_cpu
    sailed["members_clean"] = f"{checked}/{members}"
    sailed["screened"] = screened
    stats = robust["plan"].solver_stats
    sailed["tightenings"] = int(stats.get("retries", 0))
    sailed["robust_solves"] = int(stats.get("nlp_solves", 0))
    sailed["robust_iterations"] = int(stats.get("iterations", 0))
    violated = f" (violated: {r['violated_members']}, {r['kinds']})" if r["members_violated"] else ""
    versus = ""
    if once is not None:
        a = table.loc["(a)"]
        versus = f"; (a)'s plan breaks {int(a['members_violated'])}/{members}" + (
            f" ({a['violated_members']})" if a["members_violated"] else ""
        )
    return (
        f"{label}, {checked}/{members} clean{violated}{versus}, {sailed['tightenings']} tightening(s), "
        f"{sailed['robust_solves']} NLP solves, {sailed['robust_iterations']} Ipopt iterations, {robust_cpu:.0f} "
        "CPU-s to plan, sailed blind"
    ), sailed


def _case_rows(spec: tuple, quick: bool) -> Iterator[tuple[str, dict[str, Any]]]:
    """Every policy's row of one case, each as soon as it is measured ((a) first: the baseline)."""
    truth, fcs = _case(spec)
    once = _sail(truth, fcs, ReplanPolicy.never())
    yield "(a) plan once", once
    yield "(b) re-plan on each forecast (warm)", _sail(truth, fcs, ReplanPolicy())
    if not quick:
        yield "(b') re-plan on each forecast (cold)", _sail(truth, fcs, ReplanPolicy(), warm=False)
    members = 4 if quick else 10
    for name, spread in [("150 nm", ENSEMBLE)] + ([] if quick else [("= forecast error", covering_spread(spec))]):
        yield _robust_row(spec, truth, fcs, members, name, spread, once.get("plan"))


def _print_row(case: str, label: str, r: dict, base: dict) -> None:
    if "error" in r or "error" in base:
        print(
            f"| {case} | {label} | {r.get('error', base.get('error'))} | | | | | | "
            f"{r.get('wall_s', float('nan')):.1f} | {r.get('cpu_s', float('nan')):.1f} | | |",
            flush=True,
        )
        return
    print(
        f"| {case} | {label} | {r['time_in_band_h']:.1f} | {r['time_band_met_h']:.1f} | "
        f"{r['eta_miss_h']:+.2f} | {r['fuel_t']:.1f} | {r['fuel_t'] / base['fuel_t']:.3f} | "
        f"{r['replans']} ({r['failed_replans']}) | {r['wall_s']:.1f} | {r['cpu_s']:.1f} | "
        f"{r['cpu_s_per_sim_day']:.1f} | {r['cpu_s'] / base['cpu_s']:.2f} |",
        flush=True,
    )


def run(quick: bool, *, n_cases: int | None = None, only: int | None = None) -> dict[str, Any]:
    """The table; ``n_cases`` (reduced full mode) keeps the full mode's policies and 10 members on fewer cases;
    ``only`` runs case ``only`` alone (its rows' ratios are to its own (a) in the same process either way)."""
    cases = CASES[:1] if quick else CASES[: n_cases or len(CASES)]
    cases = cases if only is None else (CASES[only],)
    rows = []
    print("| forecast error | policy | in band [h] | band met [h] | ETA miss [h] | fuel [t] | fuel / (a) | re-plans "
          "(failed) | wall [s] | CPU [s] | CPU per sim. day [s] | CPU / (a) |")  # fmt: skip
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for spec in cases:
        base: dict[str, Any] = {}
        for label, r in _case_rows(spec, quick):
            base = base or r
            rows.append({"case": spec[0], "policy": label, **{k: v for k, v in r.items() if k != "plan"}})
            _print_row(spec[0], label, r, base)
    print(
        "\n(b) warm-starts every re-plan from the plan being sailed (optimise_corridor's warm_plan); (b') starts cold"
        + (" (full mode only)." if quick else ".")
    )
    for case in dict.fromkeys(r["case"] for r in rows):
        by = {r["policy"][:4]: r for r in rows if r["case"] == case and "error" not in r}
        if "(b) " in by and "(b')" in by:
            ratio = by["(b')"]["wall_s"] / by["(b) "]["wall_s"]
            ratio_cpu = by["(b')"]["cpu_s"] / by["(b) "]["cpu_s"]
            print(
                f"{case}: cold re-planning / warm = {ratio_cpu:.2f} in CPU, {ratio:.2f} in wall (same process, same "
                "truth and forecasts)"
            )
    robust_rows = [r for r in rows if r["policy"].startswith("(c)") and "tightenings" in r]
    if robust_rows:
        fired = sum(1 for r in robust_rows if r["tightenings"] > 0)
        print(f"robust.py's tightening loop fired on {fired} of {len(robust_rows)} robust plans made.")
    print(
        "(c) plans once on the ensemble (robust='all': bands, engine range and ETA in every member, mean fuel) and "
        "sails blind; its wall includes building the ensemble and the robust plan."
    )
    return {"cases": rows}


def main(argv: list[str] | None = None) -> None:
    bench_main(run, __doc__.splitlines()[0], "one forecast-error case instead of three, no cold re-plans", argv)


if __name__ == "__main__":
    main()
