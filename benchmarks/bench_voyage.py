"""Voyage simulator: the value of re-planning on each forecast when the forecast misplaces a storm.

Hidden-truth suite: a 12.5 m storm (:func:`optroute.scenarios.moving_storm_spec`) moving south at
10 kn across a 520 nm passage at 30° N (container_54k_dwt, ETA 42 h); the ship sees only forecasts
(:func:`optroute.scenarios.converging_forecasts`) that displace, delay or weaken the storm and
converge on the truth by a stated time. For every case: (a) plan once on the first forecast and
sail it blind, (b) re-plan on each forecast (:class:`optroute.voyage.ReplanPolicy`) warm-started from the
plan being sailed, (b') the same from cold starts, (c) plan once robustly on an ensemble about the
first forecast (its storm's track moved by N(0, 150 nm) east and north, its timing by N(0, 3 h), its
intensity by a log-normal factor of sigma 0.1: :func:`optroute.weather.scenarios.ensemble`) with
``optimise_corridor(..., robust="all")`` in the 400 nm corridor about the great circle, and sail it
blind; the table gives the time sailed inside a danger band of the truth, the time the plan's speed
met a band, the ETA miss, the fuel, the re-plans, and the simulation wall time per simulated day,
with (a) as the baseline of the fuel and wall times (same process, same truth); (c)'s wall time is
the robust planning plus the sailing, and its row says how many members the robust plan was checked
in (all of them clean, by :meth:`optroute.Plan.verify` with ``weather=member``). Full mode: 10
members; quick mode: 4.

Run ``python -m benchmarks.bench_voyage [--quick]``; the reduced full mode (the first case only, with the cold
re-plans and the 10-member robust plan) is ``python -c "from benchmarks.bench_voyage import run; run(False, n_cases=1)"``.
"""

from __future__ import annotations

import time
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


def _storm() -> Any:
    return sc.moving_storm_spec(34.0, -145.0, 180.0, 10.0, peak_hs_m=12.5, radius_nm=150.0, duration_h=60.0)


def _storm_dataset(storms: list, **kwargs: Any) -> Any:
    return stm.storm_dataset(storms, **kwargs)


def _robust_plan(spec: tuple, members: int) -> dict[str, Any]:
    """(c): the robust plan on an ensemble about the first forecast (issued at departure), and its wall time."""
    _, dist, brg, delay, fac, _, _ = spec
    first = fc.displaced_storms([_storm()], displacement_nm=dist, bearing_deg=brg, delay_h=delay, intensity_factor=fac)
    t = time.perf_counter()
    ens = sc.ensemble(_storm_dataset, members, seed=1, storms=first, background_hs_m=1.5, **ENSEMBLE, **KW)
    corridor = orx.Corridor.from_waypoints([A, B], width_nm=ROBUST_WIDTH_NM)
    try:
        plan = orx.optimise_corridor(corridor, ens, SHIP, departure=T0, eta=ETA, robust="all", **OPTS)
    except orx.OptrouteError as exc:
        return {"error": f"{type(exc).__name__}: {str(exc)[:200]}", "wall_s": time.perf_counter() - t}
    return {"plan": plan, "ensemble": ens, "wall_s": time.perf_counter() - t}


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
    t = time.perf_counter()
    try:
        res = orx.simulate_voyage(
            plan if plan is not None else (A, B), truth, SHIP, forecasts=fcs, replan=policy,
            departure=T0, eta=ETA, optimise_options=OPTS, corridor_width_nm=400.0, step_h=0.5, warm_start=warm,
        )  # fmt: skip
    except orx.OptrouteError as exc:
        return {"error": f"{type(exc).__name__}: {str(exc)[:200]}", "wall_s": time.perf_counter() - t}
    wall = time.perf_counter() - t
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
        "sim_days": o.duration_h / 24.0,
    }


def run(quick: bool, *, n_cases: int | None = None) -> dict[str, Any]:
    """The table; ``n_cases`` (reduced full mode) keeps the full mode's policies and 10 members on fewer cases."""
    cases = CASES[:1] if quick else CASES[: n_cases or len(CASES)]
    rows = []
    print("| forecast error | policy | in band [h] | band met [h] | ETA miss [h] | fuel [t] | fuel / (a) | re-plans "
          "(failed) | wall [s] | wall per sim. day [s] | wall / (a) |")  # fmt: skip
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for spec in cases:
        truth, fcs = _case(spec)
        base = _sail(truth, fcs, ReplanPolicy.never())
        runs = [("(a) plan once", base), ("(b) re-plan on each forecast (warm)", _sail(truth, fcs, ReplanPolicy()))]
        if not quick:
            runs.append(("(b') re-plan on each forecast (cold)", _sail(truth, fcs, ReplanPolicy(), warm=False)))
        members = 4 if quick else 10
        robust = _robust_plan(spec, members)
        if "error" in robust:
            runs.append((f"(c) robust plan on {members} members, sailed blind", robust))
        else:
            checked = sum(
                1 for m in range(members) if not robust["plan"].verify(weather=sc.member(robust["ensemble"], m))
            )
            sailed = _sail(truth, fcs, ReplanPolicy.never(), plan=robust["plan"])
            if "error" not in sailed:
                sailed["wall_s"] += robust["wall_s"]  # planning included: (a)'s wall includes its first plan too
                sailed["wall_s_per_sim_day"] = sailed["wall_s"] / sailed["sim_days"]
            sailed["robust_plan_wall_s"] = robust["wall_s"]
            sailed["members_clean"] = f"{checked}/{members}"
            runs.append((f"(c) robust plan on {members} members ({checked}/{members} clean), sailed blind", sailed))
        for label, r in runs:
            rows.append({"case": spec[0], "policy": label, **r})
            if "error" in r or "error" in base:
                print(f"| {spec[0]} | {label} | {r.get('error', base.get('error'))} |")
                continue
            print(
                f"| {spec[0]} | {label} | {r['time_in_band_h']:.1f} | {r['time_band_met_h']:.1f} | "
                f"{r['eta_miss_h']:+.2f} | {r['fuel_t']:.1f} | {r['fuel_t'] / base['fuel_t']:.3f} | "
                f"{r['replans']} ({r['failed_replans']}) | {r['wall_s']:.1f} | {r['wall_s_per_sim_day']:.1f} | "
                f"{r['wall_s'] / base['wall_s']:.2f} |"
            )
    print(
        "\n(b) warm-starts every re-plan from the plan being sailed (optimise_corridor's warm_plan); (b') starts cold"
        + (" (full mode only)." if quick else ".")
    )
    for case in dict.fromkeys(r["case"] for r in rows):
        by = {r["policy"][:4]: r for r in rows if r["case"] == case and "error" not in r}
        if "(b) " in by and "(b')" in by:
            ratio = by["(b')"]["wall_s"] / by["(b) "]["wall_s"]
            print(f"{case}: cold re-planning wall / warm = {ratio:.2f} (same process, same truth and forecasts)")
    print(
        "(c) plans once on the ensemble (robust='all': bands, engine range and ETA in every member, mean fuel) and "
        "sails blind; its wall includes building the ensemble and the robust plan."
    )
    return {"cases": rows}


def main(argv: list[str] | None = None) -> None:
    bench_main(run, __doc__.splitlines()[0], "one forecast-error case instead of three, no cold re-plans", argv)


if __name__ == "__main__":
    main()
