"""Observer benchmark: RL lead time and false alarms over encounter conditions, and throughput.

The parametric-roll observer (thyssenkrupp EP 2377756, :mod:`optroute.observer`) on
records of the motion simulator (:mod:`optroute.observer.motions`):

1. **Detection** over a grid of encounter conditions — wave height, wave period
   (λ around the ship length), relative heading (head, bow, beam, quartering,
   following) and speed.  A case is an *event* when the noise-free roll stays
   below 5° for two roll periods and then passes the set angle (15°); the lead
   time is how long before that RL first reached the alarm level (1.0).  A case
   is *quiet* when the roll stays below 5°; a false alarm is a quiet case whose
   RL reaches the alarm level (and, separately, 0.2).  Each combination rule
   (product — the default, weights 0,1,1,1,1 —, the product of all five, sum,
   max) is scored on the same records.
2. **Throughput**: the batch observer (:func:`optroute.observer.level.observe`) on
   an hour-long record, the streaming one (:meth:`ResonanceObserver.update`,
   one sample per call), and the same loop run as plain Python (numba's
   ``py_func``), in samples per second and as multiples of real time at 50 Hz
   (the baseline: 50 samples a second; the issue's target is >= 1000×).

Run ``python -m benchmarks.bench_observer [--quick]``.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from scipy.optimize import brentq

from benchmarks._cli import bench_main
from optroute.errors import OptrouteError
from optroute.observer import criteria
from optroute.observer.level import ObserverSettings, ResonanceObserver, RightingMoment, observe
from optroute.observer.motions import Encounter, simulate_motions
from optroute.physics import seaway
from optroute.physics.ship import Ship

SET_ANGLE_DEG = 15.0
QUIET_DEG = 5.0
ALARM = 1.0
RATE_50HZ = 50.0


def _speed_for_ratio(ship: Ship, period_s: float, alpha_deg: float, ratio: float) -> float | None:
    """The speed [kn] in [0, 25] giving T_E = ratio · T_R at this heading, or None."""
    target = ratio * ship.roll_period_s

    def f(v: float) -> float:
        return float(seaway.encounter_period_s(period_s, v, alpha_deg)) - target

    grid = np.linspace(0.0, 25.0, 51)
    vals = [f(v) for v in grid]
    for a, b, fa, fb in zip(grid[:-1], grid[1:], vals[:-1], vals[1:], strict=True):
        if math.isfinite(fa) and math.isfinite(fb) and fa * fb <= 0:
            return float(brentq(f, a, b))
    return None


def _rules(ship: Ship) -> dict[str, ObserverSettings]:
    base = ObserverSettings.for_ship(ship)
    return {
        "product (default, w = 0,1,1,1,1)": base,
        "product of all five": base.replace(weights=(1.0, 1.0, 1.0, 1.0, 1.0)),
        "sum": base.replace(combine="sum"),
        "max": base.replace(combine="max"),
    }


def bench_detection(quick: bool) -> dict[str, Any]:
    ship = Ship.preset("container_54k_dwt")
    tr = ship.roll_period_s
    lam_l = math.sqrt(2 * math.pi * ship.length_m / seaway.G_MS2)
    periods = [lam_l] if quick else [math.sqrt(0.8) * lam_l, lam_l, math.sqrt(1.3) * lam_l]
    hs_list = [3.0, 5.0] if quick else [2.0, 3.0, 4.0, 5.0, 6.0]
    alphas = [0.0, 30.0, 90.0, 150.0, 180.0]
    speeds = [4.0, 10.0, 16.0, 18.5, 22.0] if quick else [2.0, 6.0, 10.0, 13.0, 16.0, 18.5, 20.0, 22.0, 25.0]
    duration = 420.0 if quick else 900.0
    moment = RightingMoment.from_ship(ship)
    rules = _rules(ship)
    cases, sim_s, obs_s = [], 0.0, 0.0
    for period in periods:
        for alpha in alphas:
            for speed in speeds:
                for hs in hs_list:
                    enc = Encounter(hs_m=hs, period_s=period, alpha_deg=alpha, speed_kn=speed)
                    ratio = enc.encounter_period_s / tr
                    t0 = time.perf_counter()
                    try:
                        m = simulate_motions(ship, enc, duration_s=duration, seed=len(cases))
                    except OptrouteError as exc:  # riding with the waves, or a capsize in the model
                        cases.append({"hs_m": hs, "alpha_deg": alpha, "ratio": ratio, "skipped": str(exc)[:80]})
                        continue
                    sim_s += time.perf_counter() - t0
                    roll = np.abs(m.true_roll_deg)
                    over = np.flatnonzero(roll > SET_ANGLE_DEG)
                    t_set = float(m.time_s[over[0]]) if over.size else math.nan
                    start_deg = float(roll[m.time_s <= 2 * tr].max())
                    case = {"hs_m": hs, "period_s": period, "alpha_deg": alpha, "speed_kn": speed, "ratio": ratio,
                            "h": m.gm_ratio, "max_roll_deg": float(roll.max()), "start_roll_deg": start_deg,
                            "t_set_s": t_set}  # fmt: skip
                    for name, st in rules.items():
                        t0 = time.perf_counter()
                        res = observe(m.time_s, m.heave_m, m.roll_deg, settings=st, moment=moment)
                        obs_s += time.perf_counter() - t0
                        case[name] = {"t_alarm_s": res.first_time_s(ALARM), "t_02_s": res.first_time_s(0.2)}
                    cases.append(case)
    scored = [c for c in cases if "skipped" not in c]
    summary = {}
    for name in rules:
        events = [c for c in scored if math.isfinite(c["t_set_s"]) and c["start_roll_deg"] < QUIET_DEG]
        quiet = [c for c in scored if c["max_roll_deg"] < QUIET_DEG]
        leads = [c["t_set_s"] - c[name]["t_alarm_s"] for c in events if c[name]["t_alarm_s"] < c["t_set_s"]]
        summary[name] = {
            "events": len(events),
            "detected": len(leads),
            "lead_min_s": min(leads) if leads else math.nan,
            "lead_median_s": float(np.median(leads)) if leads else math.nan,
            "lead_min_tr": (min(leads) / tr) if leads else math.nan,
            "events_lead_ge_2tr": sum(1 for x in leads if x >= 2 * tr),
            "quiet": len(quiet),
            "false_alarms": sum(1 for c in quiet if math.isfinite(c[name]["t_alarm_s"])),
            "quiet_above_0_2": sum(1 for c in quiet if math.isfinite(c[name]["t_02_s"])),
        }
    steady = sum(1 for c in scored if c["start_roll_deg"] >= QUIET_DEG)
    return {"ship": ship.name, "roll_period_s": tr, "duration_s": duration, "cases": cases, "summary": summary,
            "simulate_s": sim_s, "observe_s": obs_s, "skipped": len(cases) - len(scored), "steady": steady}  # fmt: skip


def bench_throughput(quick: bool) -> dict[str, Any]:
    ship = Ship.preset("container_54k_dwt")
    lam_l = math.sqrt(2 * math.pi * ship.length_m / seaway.G_MS2)
    speed = _speed_for_ratio(ship, lam_l, 0.0, 0.7)
    duration = 600.0 if quick else 3600.0
    m = simulate_motions(ship, Encounter(hs_m=4.0, period_s=lam_l, alpha_deg=0.0, speed_kn=speed), duration_s=duration)
    st, moment = ObserverSettings.for_ship(ship), RightingMoment.from_ship(ship)
    observe(m.time_s[:100], m.heave_m[:100], m.roll_deg[:100], settings=st, moment=moment)  # compile / load
    n = m.time_s.size
    t0 = time.perf_counter()
    batch = observe(m.time_s, m.heave_m, m.roll_deg, settings=st, moment=moment)
    batch_s = time.perf_counter() - t0
    n_stream = min(n, 10_000 if quick else 60_000)
    obs = ResonanceObserver(st, moment)
    z, r = m.heave_m[:n_stream].tolist(), m.roll_deg[:n_stream].tolist()
    t0 = time.perf_counter()
    for zi, ri in zip(z, r, strict=True):
        obs.update(zi, ri)
    stream_s = time.perf_counter() - t0
    same = bool(np.array_equal([obs.rl], batch.rl[n_stream - 1 : n_stream], equal_nan=True))
    py = getattr(criteria.advance, "py_func", criteria.advance)
    n_py = min(n, 3_000 if quick else 20_000)
    state, prm = criteria.new_state(), st.parameters()
    raw, norm, rl = np.zeros((n_py, 5)), np.zeros((n_py, 5)), np.zeros(n_py)
    t0 = time.perf_counter()
    py(m.heave_m[:n_py], m.roll_deg[:n_py], prm, state, moment.heave_m, np.radians(moment.roll_deg),
       moment.moment_knm, raw, norm, rl)  # fmt: skip
    py_s = time.perf_counter() - t0
    rates = {"batch": n / batch_s, "streaming": n_stream / stream_s, "python loop": n_py / py_s}
    return {
        "samples": {"batch": n, "streaming": n_stream, "python loop": n_py},
        "seconds": {"batch": batch_s, "streaming": stream_s, "python loop": py_s},
        "samples_per_s": rates,
        "x_real_time_50hz": {k: v / RATE_50HZ for k, v in rates.items()},
        "numba": criteria.AVAILABLE,
        "streaming_equals_batch": same,
    }


def run(quick: bool) -> dict[str, Any]:
    """Run both parts, print markdown tables, return the figures."""
    d = bench_detection(quick)
    tr = d["roll_period_s"]
    n_cases = len(d["cases"])
    print(
        f"\n### Detection — {d['ship']} (T_R {tr:.2f} s), {n_cases} simulated encounters of {d['duration_s']:.0f} s "
        f"({d['skipped']} skipped: riding with the waves or capsized); event: roll below {QUIET_DEG:g}° for the first "
        f"2 T_R, then above {SET_ANGLE_DEG:g}°; quiet: roll below {QUIET_DEG:g}° throughout; {d['steady']} cases roll "
        f"{QUIET_DEG:g}° or more from the start (forced roll) and are neither; alarm: RL >= {ALARM:g}\n"
    )
    print(
        "| RL rule | events detected | lead >= 2 T_R | min lead [s] (T_R) | median lead [s] | false alarms (quiet cases) | quiet cases with RL >= 0.2 |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, s in d["summary"].items():
        print(
            f"| {name} | {s['detected']}/{s['events']} | {s['events_lead_ge_2tr']}/{s['events']} | "
            f"{s['lead_min_s']:.1f} ({s['lead_min_tr']:.2f}) | {s['lead_median_s']:.1f} | "
            f"{s['false_alarms']}/{s['quiet']} | {s['quiet_above_0_2']}/{s['quiet']} |"
        )
    default = next(iter(d["summary"]))
    print(f"\nEvents, default rule ({default}):\n")
    print(
        "| Hs [m] | T [s] | alpha [deg] | V [kn] | T_E/T_R | h = dGM/GM | roll > 15° at [s] | RL = 1 at [s] | lead [T_R] |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for c in d["cases"]:
        if "skipped" in c or not math.isfinite(c["t_set_s"]) or c["start_roll_deg"] >= QUIET_DEG:
            continue
        ta = c[default]["t_alarm_s"]
        lead = (c["t_set_s"] - ta) / tr if ta < c["t_set_s"] else math.nan
        print(
            f"| {c['hs_m']:g} | {c['period_s']:.2f} | {c['alpha_deg']:g} | {c['speed_kn']:g} | {c['ratio']:.3f} | "
            f"{c['h']:.2f} | {c['t_set_s']:.1f} | {ta:.1f} | {lead:.2f} |"
        )
    print(f"\nsimulation {d['simulate_s']:.1f} s, observers {d['observe_s']:.1f} s in total\n")
    t = bench_throughput(quick)
    print("### Throughput (baseline: real time at 50 Hz = 50 samples/s; target >= 1000x)\n")
    print("| observer | samples | time [s] | samples/s | x real time at 50 Hz |")
    print("|---|---:|---:|---:|---:|")
    labels = {
        "batch": f"batch `observe` ({'numba' if t['numba'] else 'python'} loop)",
        "streaming": "streaming `ResonanceObserver.update`, one sample per call",
        "python loop": "the same loop as plain Python (`py_func`)",
    }
    for k, label in labels.items():
        print(
            f"| {label} | {t['samples'][k]:,} | {t['seconds'][k]:.3f} | {t['samples_per_s'][k]:,.0f} | "
            f"{t['x_real_time_50hz'][k]:,.0f} |"
        )
    print(f"\nstreaming RL at sample {t['samples']['streaming']:,} equals the batch RL: {t['streaming_equals_batch']}")
    return {"detection": d, "throughput": t}


def main(argv: list[str] | None = None) -> None:
    bench_main(run, __doc__.splitlines()[0], "a smaller grid of encounters, shorter records", argv)


if __name__ == "__main__":
    main()
