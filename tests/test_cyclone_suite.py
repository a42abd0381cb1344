"""The synthetic-crossing suite of ``bench_cyclone`` (issue 19) and its honest tally (issue 22).

Cheap: no planner runs. The brute-force closest approach and time inside R against a hand-worked chord
(a ship crossing a stationary circle on the equator); the generated tracks against the geometry they
were built from (centre at the pass point at the pass time, the speed of advance, the recurvature);
the suite's tally fed planted outcomes: a method that gave no plan is counted and named as a miss,
never dropped.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from benchmarks._cyclone_suite import KINDS, brute_force, suite, track_through
from benchmarks._measure import Outcome
from benchmarks.bench_cyclone import summarise, target_misses
from optroute import geodesy as geo
from optroute.weather.cyclone_tracks import CycloneTrack

T0 = np.datetime64("2024-08-01T00:00", "ns")


def _stationary_track(lat: float, lon: float) -> CycloneTrack:
    n = 2
    return CycloneTrack(T0 + np.array([0, 10], dtype="timedelta64[h]"), np.full(n, lat), np.full(n, lon), np.nan,
                        975.0, np.full((n, 4), np.nan), np.nan, np.nan, 20.0, 1010.0, 0.0)  # fmt: skip


def test_brute_force_matches_the_hand_worked_chord():
    """A ship sails north along 0° E from 4° S to 4° N in 8 h past a still centre at (0°, 1° E)."""
    track = _stationary_track(0.0, 1.0)
    r_km = float(track.r7_km[0])
    plan = SimpleNamespace(waypoints=np.array([[-4.0, 0.0], [4.0, 0.0]]), times=T0 + np.array([0, 8], "timedelta64[h]"))
    b = brute_force(plan, track, margin_km=30.0, step_nm=0.5)
    d_km = float(geo.distance_nm(0.0, 0.0, 0.0, 1.0)) * 1.852  # closest point of the meridian: the equator
    assert b["closest_centre_km"] == pytest.approx(d_km, abs=0.05)
    assert b["closest_r_km"] == pytest.approx(d_km - r_km, abs=0.05)
    assert b["closest_safe_km"] == pytest.approx(d_km - r_km - 30.0, abs=0.05)
    speed_kmh = float(geo.distance_nm(-4.0, 0.0, 4.0, 0.0)) * 1.852 / 8.0
    assert d_km < r_km < 300.0  # both circles cut a chord shorter than the leg
    for key, radius in (("inside_r_h", r_km), ("inside_safe_h", r_km + 30.0)):
        # the chord 2 sqrt(ρ² − d²) on the plane; the sphere and the 0.5 nm steps differ by < 1 %
        assert b[key] == pytest.approx(2.0 * math.sqrt(radius**2 - d_km**2) / speed_kmh, rel=0.01)


def test_track_through_passes_the_point_at_its_time_at_its_speed_and_turns():
    point, t_pass, adv = (18.0, 140.0), 31.0, 12.0
    straight = np.array(track_through(point, t_pass, 300.0, adv, 0.0, 0.0, 96.0))
    assert np.all(np.diff(straight[:, 0]) == 6.0)
    lat, lon = np.interp(t_pass, straight[:, 0], straight[:, 1]), np.interp(t_pass, straight[:, 0], straight[:, 2])
    assert float(geo.distance_nm(lat, lon, *point)) < 1.0
    legs = geo.distance_nm(straight[:-1, 1], straight[:-1, 2], straight[1:, 1], straight[1:, 2])
    np.testing.assert_allclose(legs, 6.0 * adv, rtol=1e-3)
    turned = np.array(track_through(point, t_pass, 300.0, adv, 80.0, 40.0, 96.0))
    first = float(geo.initial_course_deg(*turned[0, 1:], *turned[1, 1:]))
    last = float(geo.initial_course_deg(*turned[-2, 1:], *turned[-1, 1:]))
    assert first == pytest.approx(300.0, abs=2.0)
    assert (last - first) % 360.0 == pytest.approx(80.0, abs=3.0)


@pytest.fixture(scope="module")
def two_cases():
    return suite(2)


def test_suite_is_seeded_and_starts_clear_of_the_circle(two_cases):
    again = suite(2)
    for (a, ta), (b, tb) in zip(two_cases, again, strict=True):
        assert a.start == b.start and a.end == b.end and a.cyclone == b.cyclone
        np.testing.assert_array_equal(ta.lat_deg, tb.lat_deg)
        s = ta.at(a.departure)
        assert float(geo.distance_nm(*a.start, s["lat"], s["lon"])) * 1.852 > float(s["r7_km"]) + 80.0
    assert [c.kind for c, _ in two_cases] == list(KINDS[:2])


def _row(name: str, apf: Outcome, opt: Outcome, closest_safe_km: float = 10.0, late_h: float = 0.0) -> dict:
    return {
        "case": name, "APF": apf, "optroute": opt, "apf": {"triggered": True},
        "opt_brute": {"closest_safe_km": closest_safe_km, "inside_safe_h": 0.5}, "opt_violations": [],
        "opt_minus_apf_h": late_h,
    }  # fmt: skip


def test_a_planted_failure_is_counted_and_named_never_dropped():
    ok = Outcome.scored("APF", fuel_t=100.0, runtime_s=5.0, violations=0)
    rows = [
        _row("good", ok, Outcome.scored("optroute", fuel_t=90.0, runtime_s=20.0, violations=0)),
        _row("broken", ok, Outcome.failed("optroute", runtime_s=3.0, error="NoSafePassage: planted")),
        _row("costly", ok, Outcome.scored("optroute", fuel_t=101.0, runtime_s=20.0, violations=0)),
        _row("inside", ok, Outcome.scored("optroute", fuel_t=80.0, runtime_s=20.0, violations=0), closest_safe_km=-1.0),
        _row("late", ok, Outcome.scored("optroute", fuel_t=80.0, runtime_s=20.0, violations=0), late_h=0.5),
    ]
    for r in rows:
        r["misses"] = target_misses(r)
    assert [bool(r["misses"]) for r in rows] == [False, True, True, True, True]
    assert "gave no plan" in rows[1]["misses"][0] and "planted" in rows[1]["misses"][0]
    assert "101.0 t > APF 100.0 t" in rows[2]["misses"][0]
    assert "inside R + 30 km by 1.0 km" in rows[3]["misses"][0]
    assert "arrives 0.50 h after" in rows[4]["misses"][0]
    s = summarise(rows)
    assert s["cases"] == 5 and s["target_met"] == 1
    assert s["failed"] == {"APF": 0, "optroute": 1} and s["unverified"] == {"APF": 0, "optroute": 0}
    assert s["comparison"]["common_cases"] == 4  # the failed case is out of the means, in the counts
    assert s["comparison"]["methods"]["optroute"]["mean_fuel_t"] == pytest.approx((90 + 101 + 80 + 80) / 4)
