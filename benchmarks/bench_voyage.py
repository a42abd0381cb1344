"""Voyage simulator: the value of re-planning on each forecast when the forecast misplaces a storm.

Hidden-truth suite: a 12.5 m storm (:func:`optroute.scenarios.moving_storm_spec`) moving south at
10 kn across a 520 nm passage at 30° N (container_54k_dwt, ETA 42 h); the ship sees only forecasts
(:func:`optroute.scenarios.converging_forecasts`) that displace, delay or weaken the storm and
converge on the truth by a stated time. For every case: (a) plan once on the first forecast and
sail it blind, (b) re-plan on each forecast (:class:`optroute.voyage.ReplanPolicy`) warm-started from the
plan being sailed, (b') the same from cold starts, (c) plan once robustly on a 10-member ensemble about the first
forecast with ``optimise_corridor(..., robust="all")`` in the 400 nm corridor about the great circle, and sail it
blind. The ensemble's spread is the suite's forecast-error distribution (:func:`suite_error_spread`: the maximum
likelihood fit to the three cases' errors, the same for every case: the track moved by N(0, 191.5 nm) east and
north, the timing by N(0, 3.46 h), the intensity by a log-normal factor of sigma 0.129, as
:func:`optroute.weather.scenarios.ensemble` draws), seed = case index + 1; (c)'s row says whether that draw covers
the truth and, over :data:`COVERAGE_SEEDS` draws, how often an ensemble of this distribution does against how often
a calibrated one would (:func:`coverage_rate`). Where the members have no common schedule on the 3-D DP's lattice
(the robust call's InfeasibleETA/NoSafePassage), the members without a schedule of their own are named and left
out (:func:`no_passage_alone`). The table gives the time sailed inside a danger band of the truth, the time the
plan's speed met a band, the ETA miss, the fuel, the re-plans, and the simulation CPU per simulated day, with (a) as
the baseline of the fuel and CPU (same process, same truth); (c)'s CPU is the robust planning plus the sailing, and
its row says how many of the members the robust plan is clean in and how many (a)'s plan breaks
(:func:`optroute.member_violations`), how often robust.py's tightening loop fired and for what, the plan's status
(``"start"``: no robust solve was clean in every member and the joint 3-D DP's schedule, clean in all, is sailed), the
start used and its CPU; a robust failure prints its whole message. Quick mode:
4 members. CPU [s] is this process's (the machine is shared: compare CPU, not wall); each case's ratios are to its
own (a), so the cases may run in separate processes (``run(False, only=k)``), and a case's rows too
(``policies="b"`` or ``"c"``: (a) is run in each).

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


#: The robust plan's corridor (total width [nm]).
ROBUST_WIDTH_NM = 400.0
#: Hour [h since departure] at which the storms' centres are compared (the true storm crosses 30° N then).
CROSSING_H = 24.0
#: Ensembles drawn per case by :func:`coverage_rate` (the share of seeds whose members cover the truth).
COVERAGE_SEEDS = 100


def suite_error_spread(cases: tuple = CASES) -> dict[str, float]:
    """The forecast-error distribution of the suite, fitted to its cases by maximum likelihood: the ensemble's spread.

    The forecasts of the suite err as :func:`optroute.weather.forecast.displaced_storms` makes them (a track
    displacement, a delay, an intensity factor), which are the three perturbations
    :func:`optroute.weather.scenarios.ensemble` draws: the track moved by an isotropic Gaussian east and north,
    ``σ_p² = Σ d² / (2K)`` over the K cases' displacements ``d`` [nm]; the timing by N(0, σ_t),
    ``σ_t² = Σ delay² / K`` [h]; the intensity by a log-normal factor, ``σ_i² = Σ ln(factor)² / K``. One
    distribution for every case (no case's own error sets its ensemble), so each case's truth is one draw of the
    error the ensemble describes: 191.5 nm, 3.46 h and 0.129 for the three cases.
    """
    d = np.array([c[1] for c in cases])
    delay = np.array([c[3] for c in cases])
    fac = np.array([c[4] for c in cases])
    return {
        "position_sigma_nm": float(np.sqrt(np.mean(d**2) / 2.0)),
        "timing_sigma_h": float(np.sqrt(np.mean(delay**2))),
        "intensity_sigma": float(np.sqrt(np.mean(np.log(fac) ** 2))),
    }


def _centre(track: Any, hour: float) -> tuple[float, float]:
    tr = np.asarray(track, dtype=float)
    return float(np.interp(hour, tr[:, 0], tr[:, 1])), float(np.interp(hour, tr[:, 0], tr[:, 2]))


def _crossing(storms: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """Storm centres at :data:`CROSSING_H` in the true storm's east/north frame [nm], and the peaks [m]."""
    lat0, lon0 = _centre(_storm().track, CROSSING_H)
    xy, peaks = [], []
    for st in storms:
        lat, lon = _centre(st["track"], CROSSING_H)
        xy.append(((lon - lon0) * 60.0 * np.cos(np.radians(lat0)), (lat - lat0) * 60.0))
        peaks.append(float(st["peak_hs_m"]))
    return np.array(xy), np.array(peaks)


def _covers(pts: np.ndarray, peaks: np.ndarray, at: np.ndarray, peak: float) -> dict[str, Any]:
    from scipy.spatial import Delaunay

    return {
        "inside": bool(len(pts) >= 3 and Delaunay(pts).find_simplex(at[None, :])[0] >= 0),
        "in_range": bool(np.all((pts.min(axis=0) <= at) & (at <= pts.max(axis=0)))),
        "intensity": bool(peaks.min() <= peak <= peaks.max()),
        "nearest_nm": float(np.min(np.hypot(*(pts - at).T))),
    }


def coverage(ens: Any) -> dict[str, Any]:
    """Whether the ensemble's spread covers the truth: its members' storm centres at :data:`CROSSING_H` (timing
    errors included: a late storm is further north) against the true storm's, in a local east/north frame [nm].

    ``inside``: the truth's centre lies inside the convex hull of the members' (``scipy.spatial.Delaunay``);
    ``in_range``: inside the members' range east and north (the rank-histogram sense: the truth is no outlier on
    either axis); ``intensity``: the true peak within the members' peaks; ``nearest_nm``: the distance from the
    truth's centre to the nearest member's.
    """
    import json

    pts, peaks = _crossing([m["storms"][0] for m in json.loads(ens.attrs["ensemble"])["members"]])
    return _covers(pts, peaks, np.zeros(2), _storm().peak_hs_m)


def _no_field(storms: list, **kwargs: Any) -> Any:
    import xarray as xr

    return xr.Dataset()  # the members' specifications only (ensemble's attrs): coverage needs no field


def coverage_rate(spec: tuple, spread: dict[str, float], members: int, seeds: int = COVERAGE_SEEDS) -> dict:
    """Over ``seeds`` ensembles (seeds 0, 1, ...) about the case's first forecast, the share in which the truth is
    ``inside`` / ``in_range`` / within the ``intensity`` range (:func:`coverage`); and ``calibrated_*``: the same
    shares for a truth drawn from the ensemble's own distribution (member ``members`` of a ``members + 1`` draw) —
    what a calibrated ensemble of this size achieves (about 1 − E[hull vertices of M+1 points]/(M+1) for the hull,
    ((M−1)/(M+1))² for the ranges of a Gaussian)."""
    import json

    _, dist, brg, delay, fac, _, _ = spec
    first = fc.displaced_storms([_storm()], displacement_nm=dist, bearing_deg=brg, delay_h=delay, intensity_factor=fac)
    keys = ("inside", "in_range", "intensity")
    got = {k: 0 for k in keys} | {f"calibrated_{k}": 0 for k in keys}
    for seed in range(seeds):
        info = json.loads(sc.ensemble(_no_field, members + 1, seed=seed, storms=first, **spread).attrs["ensemble"])
        pts, peaks = _crossing([m["storms"][0] for m in info["members"]])
        real = _covers(pts[:members], peaks[:members], np.zeros(2), _storm().peak_hs_m)
        drawn = _covers(pts[:members], peaks[:members], pts[members], float(peaks[members]))
        for k in keys:
            got[k] += real[k]
            got[f"calibrated_{k}"] += drawn[k]
    return {k: v / seeds for k, v in got.items()}


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


def no_passage_alone(ens: Any) -> list[int]:
    """The members in which the 3-D DP on that member alone finds no safe schedule by the ETA
    (:func:`optroute.optimise.robust_start.members_with_passage`): no plan robust over a set of members containing one
    of them exists on the lattice."""
    from optroute.optimise.robust import member_datasets, prepare_members
    from optroute.optimise.robust_start import members_with_passage

    corridor = orx.Corridor.from_waypoints([A, B], width_nm=ROBUST_WIDTH_NM)
    prepared, _, _ = prepare_members(corridor, member_datasets(ens), SHIP, shared_options(), 0)
    ref = prepared[0]
    eta_h = float((ETA - T0) / np.timedelta64(1, "h"))
    ok = members_with_passage(prepared, ref.frame, eta_h, float(np.min(ref.v_min)), float(np.max(ref.v_max)))
    return [k for k, o in enumerate(ok) if not o]


def _robust_plan(spec: tuple, members: int, spread: dict[str, float]) -> dict[str, Any]:
    """(c): the robust plan on an ensemble about the first forecast (issued at departure), and its wall time.

    ``robust="all"`` on every member; where the members' joint lattice has no common schedule (InfeasibleETA or
    NoSafePassage from :func:`optroute.optimise.robust_start.ensemble_dp_path`), the members without a schedule of
    their own (:func:`no_passage_alone`) are left out, named in ``screened``, and the plan is made on the rest.
    The ensemble's seed is the case's index + 1 (cases do not share one draw)."""
    _, dist, brg, delay, fac, _, _ = spec
    first = fc.displaced_storms([_storm()], displacement_nm=dist, bearing_deg=brg, delay_h=delay, intensity_factor=fac)
    t, cpu = time.perf_counter(), time.process_time()
    seed = 1 + CASES.index(spec)
    ens = sc.ensemble(_storm_dataset, members, seed=seed, storms=first, background_hs_m=1.5, **spread, **KW)
    corridor = orx.Corridor.from_waypoints([A, B], width_nm=ROBUST_WIDTH_NM)
    out: dict[str, Any] = {"ensemble": ens, "coverage": coverage(ens), "screened": [], "seed": seed}
    sub = ens
    try:
        try:
            plan = orx.optimise_corridor(corridor, ens, SHIP, departure=T0, eta=ETA, robust="all", **OPTS)
        except (orx.InfeasibleETA, orx.NoSafePassage) as exc:
            out["first_error"] = f"{type(exc).__name__}: {str(exc)[:300]}"
            out["screened"] = no_passage_alone(ens)
            kept = [k for k in range(members) if k not in out["screened"]]
            if not out["screened"] or not kept:
                raise
            sub = ens.isel(member=kept)
            sub.attrs = dict(ens.attrs)
            plan = orx.optimise_corridor(corridor, sub, SHIP, departure=T0, eta=ETA, robust="all", **OPTS)
    except orx.OptrouteError as exc:  # the whole message: what failed, in which members, and why
        return {"error": f"{type(exc).__name__}: {exc}", "wall_s": time.perf_counter() - t,
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
    rate = coverage_rate(spec, spread, members)
    covers = (
        f"seed {robust['seed']}: truth {'inside' if cov['inside'] else 'outside'} the members' hull, "
        f"{'inside' if cov['in_range'] else 'outside'} their east/north ranges, nearest member "
        f"{cov['nearest_nm']:.0f} nm{'' if cov['intensity'] else ', intensity outside'}; over {COVERAGE_SEEDS} seeds "
        f"inside the hull {rate['inside']:.0%} (calibrated {rate['calibrated_inside']:.0%}), the ranges "
        f"{rate['in_range']:.0%} ({rate['calibrated_in_range']:.0%}), the intensities {rate['intensity']:.0%} "
        f"({rate['calibrated_intensity']:.0%})"
    )
    screened = robust["screened"]
    label = f"(c) robust='all', {members} members, spread {name} ({covers})" + (
        f"; {len(screened)} left out {screened} (no lattice schedule alone; first: {robust['first_error']})"
        if screened
        else ""
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
    sailed["coverage"], sailed["coverage_rate"] = cov, rate
    sailed["members_clean"] = f"{checked}/{members}"
    sailed["screened"] = screened
    stats = robust["plan"].solver_stats
    sailed["tightenings"] = int(stats.get("retries", 0))
    sailed["tightened_for"] = sorted({k for e in stats.get("tightening", []) for k in _kinds(e)})
    sailed["robust_solves"] = int(stats.get("nlp_solves", 0))
    sailed["robust_iterations"] = int(stats.get("iterations", 0))
    sailed["robust_start"], sailed["robust_start_cpu_s"] = stats.get("start"), float(stats.get("start_cpu_s", 0.0))
    violated = f" (violated: {r['violated_members']}, {r['kinds']})" if r["members_violated"] else ""
    versus = ""
    if once is not None:
        a = table.loc["(a)"]
        versus = f"; (a)'s plan breaks {int(a['members_violated'])}/{members}" + (
            f" ({a['violated_members']})" if a["members_violated"] else ""
        )
    return (
        f"{label}, status {robust['plan'].status}, {checked}/{members} clean{violated}{versus}, "
        f"{sailed['tightenings']} tightening(s) "
        f"{sailed['tightened_for']}, "
        f"{sailed['robust_solves']} NLP solves, {sailed['robust_iterations']} Ipopt iterations, {robust_cpu:.0f} "
        f"CPU-s to plan (start: {sailed['robust_start']}, {sailed['robust_start_cpu_s']:.1f} CPU-s), sailed blind"
    ), sailed


def _kinds(entry: str) -> list[str]:
    """The violation kinds of one line of robust.py's tightening log (``"tightened for ['band:...', ...]: {...}"``)."""
    import ast

    if not entry.startswith("tightened for "):
        return []
    return list(ast.literal_eval(entry[len("tightened for ") : entry.index("]:") + 1]))


def _case_rows(spec: tuple, quick: bool, policies: str = "bc") -> Iterator[tuple[str, dict[str, Any]]]:
    """Every policy's row of one case, each as soon as it is measured ((a) first: the baseline, always run)."""
    truth, fcs = _case(spec)
    once = _sail(truth, fcs, ReplanPolicy.never())
    yield "(a) plan once", once
    if "b" in policies:
        yield "(b) re-plan on each forecast (warm)", _sail(truth, fcs, ReplanPolicy())
        if not quick:
            yield "(b') re-plan on each forecast (cold)", _sail(truth, fcs, ReplanPolicy(), warm=False)
    if "c" not in policies:
        return
    members = 4 if quick else 10
    yield _robust_row(spec, truth, fcs, members, "= the suite's error", suite_error_spread(), once.get("plan"))


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


def run(quick: bool, *, n_cases: int | None = None, only: int | None = None, policies: str = "bc") -> dict[str, Any]:
    """The table; ``n_cases`` (reduced full mode) keeps the full mode's policies and 10 members on fewer cases;
    ``only`` runs case ``only`` alone (its rows' ratios are to its own (a) in the same process either way);
    ``policies`` ("b": the re-planning rows, "c": the robust rows; (a) always) splits a case over processes."""
    cases = CASES[:1] if quick else CASES[: n_cases or len(CASES)]
    cases = cases if only is None else (CASES[only],)
    rows = []
    print("| forecast error | policy | in band [h] | band met [h] | ETA miss [h] | fuel [t] | fuel / (a) | re-plans "
          "(failed) | wall [s] | CPU [s] | CPU per sim. day [s] | CPU / (a) |")  # fmt: skip
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for spec in cases:
        base: dict[str, Any] = {}
        for label, r in _case_rows(spec, quick, policies):
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
