"""Tropical-cyclone avoidance: the naive track, the typhoon-avoidance patent's APF and optroute's plan on a Nesat-like case.

The typhoon-avoidance patent's real case (its [0156]–[0166]): a general cargo ship from Qingdao to
Tubay (Mindanao) from 12 October 2022, 22:00, through typhoon Nesat; the actual voyage, slowed to
3–6 kn, burnt 393.39 t; the patent's APF avoidance route 245.43 t and arrived about 6 h earlier,
avoiding a force-7 circle of R = 200 km with the safe distance 230 km.  Neither the real track nor
the ship's data are published with it, so this case is synthetic and says so: a Nesat-like
typhoon (Holland 1980 profile, Δp = 45 hPa, R_max = 35 km, B = 1.3: R ≈ 205 km at 18° N) moving
west-north-west at 9 kn across the route east of Luzon, written as an ATCF b-deck and read back
(:func:`optroute.weather.cyclone_tracks.read_atcf`) for the circle; the preset
``general_cargo_25k_dwt`` (the patent's test ship is "fully loaded, 20–30 kt") at 12 kn.

Rows: (naive) the great circle at 12 kn with Boeing's forced slow-downs; (APF) the patent's
dynamic APF (k_a = 10, η_X = 10, η_V = 12, d_n = 30 km), sailed with the same physics; (optroute)
:func:`optroute.search_route` for the earliest arrival at 12 kn and :func:`optroute.plan_voyage`
for least fuel by the APF's arrival, both with the moving exclusion R + 30 km (in the search, the
NLP and the referee).  The weather is synthetic geography (no coastline is applied to any row).  Fuel and arrival are the referee's (:class:`optroute.Plan`),
the closest approach is min(distance − R) over the waypoints, the time inside R and inside R + 30
km are summed over the legs; "max risk r" is the largest risk degree
(:func:`optroute.geo.encounter.risk_degree`, our reconstruction, T_S = 6 h) at the legs' starts and
"trigger holds" the hours during which the patent's trigger (DCPA ≤ R, distance ≤ R + 30 km) holds.  The patent's own figures are printed beside them as published: they
are not this case's and are no baseline for its numbers.

Run ``python -m benchmarks.bench_cyclone [--quick]`` or ``python -m benchmarks --only cyclone``.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

import optroute as orx
from benchmarks._cli import bench_main
from optroute import errors
from optroute.geo.encounter import encounter, risk_degree
from optroute.geo.tracks import Exclusion
from optroute.voyage.apf import apf_avoidance, sail_track
from optroute.weather.cyclone import Cyclone, holland_vmax_ms, straight_track, tropical_cyclone
from optroute.weather.cyclone_tracks import CycloneTrack, read_atcf, write_atcf

SHIP = orx.Ship.preset("general_cargo_25k_dwt")
T0 = np.datetime64("2022-10-12T18:00", "ns")
DEPART = np.datetime64("2022-10-12T22:00", "ns")
QINGDAO, TUBAY = (35.0, 122.5), (10.0, 126.3)  # off Qingdao; off Surigao, the approach to Tubay
SPEED_KN = 12.0
PATENT = {"actual_fuel_t": 393.39, "apf_fuel_t": 245.43, "apf_earlier_h": 6.0, "r_km": 200.0, "safe_km": 230.0}
DP_HPA, RMAX_KM, HOLLAND_B = 45.0, 35.0, 1.3


def nesat_like(quick: bool) -> tuple[Any, Cyclone]:
    """The Nesat-like typhoon and its weather (0.5° in quick mode, 0.25° in full)."""
    cyc = Cyclone(
        track=straight_track(13.0, 139.0, 290.0, 9.0, duration_h=192.0, step_h=6.0),
        pressure_deficit_hpa=DP_HPA,
        rmax_km=RMAX_KM,
        holland_b=HOLLAND_B,
        name="Nesat-like",
    )
    ds = tropical_cyclone(
        cyc,
        start=T0,
        duration_h=192.0,
        step_h=3.0,
        resolution_deg=0.5 if quick else 0.25,
        bbox=(4.0, 40.0, 112.0, 142.0),
    )
    return ds, cyc


def b_deck(cyc: Cyclone, path: Path) -> CycloneTrack:
    """The typhoon as an ATCF b-deck (pressure, VMAX, RMW, POCI 1010 hPa; no radii) and read back."""
    tr = np.asarray(cyc.track)
    n = tr.shape[0]
    vmax_kn = 0.8 * holland_vmax_ms(DP_HPA, HOLLAND_B) * 3600.0 / 1852.0
    track = CycloneTrack(
        time=T0 + (tr[:, 0] * 3600).astype("timedelta64[s]"),
        lat_deg=tr[:, 1], lon_deg=tr[:, 2], vmax_kn=np.full(n, vmax_kn), pressure_hpa=np.full(n, 1010.0 - DP_HPA),
        r34_nm=np.full((n, 4), np.nan), r50_nm=np.full((n, 4), np.nan), r64_nm=np.full((n, 4), np.nan),
        rmax_nm=np.full(n, RMAX_KM / 1.852), env_pressure_hpa=np.full(n, 1010.0), lead_h=np.zeros(n), name="NESAT-LIKE",
    )  # fmt: skip
    write_atcf(track, path)
    return read_atcf(path)


def _row(name: str, plan: Any, track: CycloneTrack, wall: float) -> dict[str, Any]:
    s = track.at(plan.times)
    wp = plan.waypoints
    dist = np.asarray(orx.geodesy.distance_nm(wp[:, 0], wp[:, 1], s["lat"], s["lon"])) * 1.852
    gap = dist - s["r7_km"]
    dur = np.diff(plan.times) / np.timedelta64(1, "h")
    cog = orx.geodesy.initial_course_deg(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
    enc = encounter(wp[:-1, 0], wp[:-1, 1], plan.legs["sog_kn"].to_numpy(), cog, plan.times[:-1], track)
    return {
        "name": name,
        "fuel_t": float(plan.total_fuel_t),
        "arrival": str(plan.arrival.astype("datetime64[m]")),
        "duration_h": float(plan.duration_h),
        "closest_km": float(gap.min()),
        "inside_r_h": float(np.sum(dur * (gap[:-1] < 0))),
        "inside_safe_h": float(np.sum(dur * (gap[:-1] < 30.0))),
        "min_stw_kn": float(np.min(plan.stw_kn)),
        "max_risk": float(np.max(risk_degree(enc))),
        "triggered_h": float(np.sum(dur * enc.trigger(30.0))),
        "violations": [str(v) for v in plan.verify()][:3],
        "wall_s": wall,
    }


def run(quick: bool) -> dict[str, Any]:
    ds, cyc = nesat_like(quick)
    with tempfile.TemporaryDirectory() as tmp:
        track = b_deck(cyc, Path(tmp) / "bwp202022.dat")
    r_km = float(np.median(track.r7_km))
    print(f"Nesat-like typhoon: R (force 7) = {r_km:.0f} km from the b-deck (Holland profile from its pressure); "
          f"safe distance R + 30 km.\n")  # fmt: skip
    rows = []
    t = time.perf_counter()
    naive = sail_track(
        QINGDAO, TUBAY, ds, SHIP, departure=DEPART, speed_kn=SPEED_KN, track=track, avoid=False, use_land_mask=False
    )
    rows.append(_row("naive great circle (forced slow-downs)", naive.plan, track, time.perf_counter() - t))
    t = time.perf_counter()
    apf = apf_avoidance(QINGDAO, TUBAY, ds, SHIP, track, departure=DEPART, speed_kn=SPEED_KN, use_land_mask=False)
    rows.append(_row("patent APF (k_a 10, eta_X 10, eta_V 12, d_n 30 km)", apf.plan, track, time.perf_counter() - t))
    excl = Exclusion.from_track(track, margin_km=30.0, cone_km_per_h=0.0)
    search = (
        {"cell_nm": 60.0, "angular_resolution_deg": None, "directions": 16, "band_check_nm": None}
        if quick
        else {"cell_nm": 30.0}
    )
    search["use_land_mask"] = False
    t = time.perf_counter()
    try:
        route = orx.search_route(QINGDAO, TUBAY, ds, SHIP, departure=DEPART, objective="time", exclusion=excl,
                                 desired_speed_kn=SPEED_KN, **search)  # fmt: skip
        sailed = orx.Plan.from_schedule(route.waypoints, route.stw_kn, departure=DEPART, ship=SHIP, weather=ds,
                                        exclusion=excl, use_land_mask=False)  # fmt: skip
        rows.append(_row("optroute search_route (time at 12 kn), R + 30 km", sailed, track, time.perf_counter() - t))
    except errors.OptrouteError as exc:
        rows.append({"name": "optroute search_route", "error": f"{type(exc).__name__}: {str(exc)[:300]}"})
    t = time.perf_counter()
    try:
        plan = orx.plan_voyage(
            QINGDAO, TUBAY, ds, SHIP, departure=DEPART, eta=apf.plan.arrival, objective="fuel", exclusion=excl,
            search_options=search, max_leg_nm=60.0 if quick else 40.0, use_land_mask=False,
        )  # fmt: skip
        rows.append(_row(f"optroute plan_voyage, fuel by the APF's arrival, R + 30 km ({plan.status})", plan, track,
                         time.perf_counter() - t))  # fmt: skip
    except errors.OptrouteError as exc:
        rows.append({"name": "optroute plan_voyage", "error": f"{type(exc).__name__}: {str(exc)[:300]}"})
    base = rows[1]
    print("| route | fuel [t] | fuel / APF | arrival (UTC) | vs APF [h] | closest to R [km] | inside R [h] | "
          "inside R+30 km [h] | slowest STW [kn] | max risk r | trigger holds [h] | wall [s] |")  # fmt: skip
    print("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        if "error" in r:
            print(f"| {r['name']} | {r['error']} |")
            continue
        print(
            f"| {r['name']} | {r['fuel_t']:.1f} | {r['fuel_t'] / base['fuel_t']:.3f} | {r['arrival']} | "
            f"{r['duration_h'] - base['duration_h']:+.1f} | {r['closest_km']:.0f} | {r['inside_r_h']:.1f} | "
            f"{r['inside_safe_h']:.1f} | {r['min_stw_kn']:.1f} | {r['max_risk']:.2f} | {r['triggered_h']:.1f} | "
            f"{r['wall_s']:.1f} |"
        )
    print(
        f"\nThe patent's figures for its real case (not this synthetic one): actual track {PATENT['actual_fuel_t']} t "
        f"with slow-downs to 3–6 kn; its APF route {PATENT['apf_fuel_t']} t, about {PATENT['apf_earlier_h']:.0f} h "
        f"earlier; R = {PATENT['r_km']:.0f} km, safe distance {PATENT['safe_km']:.0f} km."
    )
    for r in rows:
        if r.get("violations"):
            print(f"\n{r['name']}: the referee finds {r['violations']}")
    return {"r_km": r_km, "rows": rows, "patent": PATENT, "apf_trigger": str(apf.trigger_time),
            "apf_resume": str(apf.resume_time)}  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    bench_main(run, __doc__.splitlines()[0], "0.5° weather, 60 nm search cells (16 directions), 60 nm NLP legs", argv)


if __name__ == "__main__":
    main()
