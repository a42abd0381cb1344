"""The two crossings of the cyclone suite where the patent's APF entered R (issue 19), worked out.

* The antimeridian crossing: the APF's track there is the same as on the crossing shifted 40° west
  (no longitude wrap in the bearing, the relative velocity or the interpolated centre), and with the
  influence range the patent states (d_n = R + 30 km, [0104]) it keeps out of R.
* The overtaking crossing (a 24.5 kn typhoon, the ship at 12.5 kn): from the point where the
  patent's trigger fires (centre within R + 30 km, [0124]) no heading at the kept speed keeps out
  of R — the hand-worked bound (:func:`optroute.geo.encounter.best_closest_approach`), checked by
  brute force over headings on the sphere, with the centre interpolated from the track.

Cheap: the suite's tracks (no planner), 1° weather, two APF runs.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import optroute as orx
from benchmarks._cyclone_suite import b_deck, brute_force, suite, weather
from optroute import geodesy as geo
from optroute import units
from optroute.geo.encounter import best_closest_approach, encounter, local_xy_nm
from optroute.voyage.apf import apf_avoidance


@pytest.fixture(scope="module")
def cases():
    return {c.kind: (c, t) for c, t in suite(8)}


def test_best_closest_approach_by_hand():
    # centre 100 nm due north moving south at 20 kn, ship at 10 kn: θ_m = 30°, β = 0 → 100 sin 30° = 50 nm
    assert best_closest_approach([0.0, 100.0], [0.0, -20.0], 10.0) == pytest.approx(50.0, rel=1e-12)
    # the centre moving away north at 20 kn: the ship's relative velocity points south, the distance opens
    assert best_closest_approach([0.0, 100.0], [0.0, 20.0], 10.0) == pytest.approx(100.0)
    # crossing from the west (β = 90°): a 10 kn ship can hold the distance at 100 nm
    assert best_closest_approach([0.0, 100.0], [20.0, 0.0], 10.0) == pytest.approx(100.0)
    # as fast as the centre: it can always hold the distance
    assert best_closest_approach([30.0, 40.0], [-7.0, -3.0], math.hypot(7.0, 3.0)) == pytest.approx(50.0)
    # β = 30°, θ_m = asin(0.5) = 30°: 100 sin 60°
    v = 20.0 * np.array([math.sin(math.radians(210.0)), math.cos(math.radians(210.0))])  # moving towards 210°
    assert best_closest_approach([0.0, 100.0], v, 10.0) == pytest.approx(100.0 * math.sin(math.radians(60.0)))


def _shifted(case, dlon: float):
    tr = np.asarray(case.cyclone.track).copy()
    tr[:, 2] = units.wrap_180(tr[:, 2] + dlon)
    cyc = replace(case.cyclone, track=tuple(map(tuple, tr)))
    move = lambda p: (p[0], float(units.wrap_180(p[1] + dlon)))  # noqa: E731
    return replace(case, start=move(case.start), end=move(case.end), cyclone=cyc)


def test_apf_across_the_antimeridian_is_the_same_crossing_40_deg_west(cases, tmp_path: Path):
    case, _ = cases["antimeridian"]
    runs, gaps = [], []
    for k, dlon in enumerate((0.0, -40.0)):
        c = _shifted(case, dlon)
        track = b_deck(c.cyclone, c.t0, tmp_path / f"bwp{k}.dat")
        run = apf_avoidance(c.start, c.end, weather(c, 1.0), orx.Ship.preset(c.ship), track, departure=c.departure,
                            speed_kn=c.speed_kn, use_land_mask=False)  # fmt: skip
        runs.append(run)
        gaps.append(brute_force(run.plan, track))
    a, b = runs
    assert abs(float(a.plan.waypoints[0, 1])) > 170.0 and abs(float(b.plan.waypoints[0, 1])) < 150.0
    assert a.trigger_time is not None and a.trigger_time == b.trigger_time and a.resume_time == b.resume_time
    assert a.plan.waypoints.shape == b.plan.waypoints.shape
    np.testing.assert_allclose(a.plan.waypoints[:, 0], b.plan.waypoints[:, 0], atol=1e-7)
    np.testing.assert_allclose(units.wrap_180(a.plan.waypoints[:, 1] - 40.0 - b.plan.waypoints[:, 1]), 0.0, atol=1e-7)
    assert float(a.plan.total_fuel_t) == pytest.approx(float(b.plan.total_fuel_t), rel=1e-9)
    assert gaps[0]["closest_r_km"] == pytest.approx(gaps[1]["closest_r_km"], abs=1e-3)
    assert gaps[0]["closest_r_km"] > 0.0  # d_n = R + 30 km ([0104]): outside R (d_n = 30 km entered it for 3.4 h)


def _trigger_point(case, track):
    """Sail the great circle at the case's speed (geodesy only) until the patent's trigger holds."""
    lat, lon, h = *case.start, 0.0
    while h < 200.0:
        when = case.departure + np.timedelta64(int(round(h * 3600)), "s")
        cog = float(geo.initial_course_deg(lat, lon, *case.end))
        if bool(encounter(lat, lon, case.speed_kn, cog, when, track).trigger(30.0)):
            return lat, lon, when
        lat, lon = (float(x) for x in geo.destination(lat, lon, cog, case.speed_kn * 0.25))
        h += 0.25
    raise AssertionError("the trigger never fired")


def _best_heading_gap_km(lat, lon, when, speed_kn, track, hours=48.0):
    """max over headings (every 1°) of min over 48 h (every 15 min) of (distance to the centre − R), on the sphere."""
    steps = np.arange(int(hours * 4) + 1)
    s = track.at(when + (steps * 900).astype("timedelta64[s]"))
    best = -np.inf
    for hd in np.arange(0.0, 360.0, 1.0):
        la, lo = geo.destination(lat, lon, hd, speed_kn * 0.25 * steps)
        best = max(best, float(np.min(geo.distance_nm(la, lo, s["lat"], s["lon"]) * 1.852 - s["r7_km"])))
    return best, s


@pytest.mark.parametrize("kind", ["overtaking (typhoon faster)", "overtaking (ship faster)"])
def test_from_the_trigger_point_the_bound_says_whether_any_heading_keeps_out_of_r(cases, kind):
    case, track = cases[kind]
    lat, lon, when = _trigger_point(case, track)
    st = track.at(when)
    bound_nm = best_closest_approach(local_xy_nm(lat, lon, st["lat"], st["lon"]), [float(st["u_kn"]),
                                     float(st["v_kn"])], case.speed_kn)  # fmt: skip
    brute, s = _best_heading_gap_km(lat, lon, when, case.speed_kn, track)
    r_km = float(st["r7_km"])
    if kind.endswith("typhoon faster)"):
        # 12.5 kn against 24.5 kn: θ_m = 31°; the best heading passes 171 km from the centre, R = 259 km
        assert case.speed_kn == 12.5 and case.advance_kn == pytest.approx(24.48, abs=0.01)
        assert bound_nm * 1.852 < float(s["r7_km"].min()) - 60.0  # short of R all 48 h (R shrinks to 244 km)
        assert brute < -60.0  # every heading enters R
        assert bound_nm * 1.852 - r_km == pytest.approx(brute, abs=5.0)  # R nearly constant: the bound is the truth
    else:
        assert case.speed_kn > case.advance_kn and bound_nm * 1.852 > r_km + 25.0  # it can hold R + 30 km or so
        assert brute > 0.0


def test_the_bench_names_why_an_apf_track_enters_r_plus_30_km():
    from benchmarks.bench_cyclone import apf_entry_reasons

    def row(name, inside_safe_h, inside_r_h, gap_km, bound_km):
        b = {"inside_safe_h": inside_safe_h, "inside_r_h": inside_r_h, "closest_r_km": -5.0}
        return {"case": name, "apf_brute": b, "apf": {"trigger_gap_km": gap_km, "trigger_bound_km": bound_km},
                "speed_kn": 12.5, "advance_kn": 24.5}  # fmt: skip

    out = apf_entry_reasons([row("a", 15.2, 13.3, 27.0, -88.0), row("b", 9.9, 0.0, 29.0, 13.0),
                             row("c", 0.3, 0.0, 29.0, 28.5), row("d", 0.0, 0.0, 29.0, 29.0)])  # fmt: skip
    assert len(out) == 3  # "d" never enters R + 30 km
    assert "passes -88 km from R" in out[0] and "no heading at the kept speed" in out[0]
    assert "fired 29 km from R" in out[1] and "no heading holds even that distance" in out[1]
    assert "by the field's design" in out[2]
