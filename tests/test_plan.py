"""Plan: leg quantities against hand values, verify() against planted violations, GeoJSON and NetCDF export.

Every planted violation is built with :meth:`Plan.from_schedule` (no optimiser involved) in a sea
whose answer is known independently: the closed-form forbidden speed intervals of
:func:`optroute.forbidden_speed_intervals`, the ship's calm-water power at MCR, a point inland in
Gabon, an ETA before the arrival.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

import optroute as orx
from optroute import geodesy as geo
from optroute.physics.safety import BANDS
from optroute.plan.result import LEG_COLUMNS, Exclusion, Plan, gc_points, project_to_polyline

SHIP = orx.Ship.preset("container_54k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")


@pytest.fixture(scope="module")
def calm() -> xr.Dataset:
    return orx.scenarios.uniform(
        hs_m=0.0, tp_s=6.0, bbox=(-10, 10, -40, 20), start=T0, duration_h=240, resolution_deg=1.0
    )


@pytest.fixture(scope="module")
def rough() -> xr.Dataset:
    # Hs 12 m (≥ 0.04 L = 10 m: every band applies), 14 s, from the west: following seas eastbound
    return orx.scenarios.uniform(
        hs_m=12.0, tp_s=14.0, wave_from_deg=270.0, bbox=(-10, 10, -40, 0), start=T0, duration_h=240, resolution_deg=1.0
    )


def _kinds(violations, leg=None):
    return {v.kind for v in violations if leg is None or v.leg == leg}


def test_calm_legs_are_distance_over_speed_and_calm_fuel(calm):
    wp = np.array([[0.0, -30.0], [0.0, -25.0], [2.0, -20.0]])
    model = orx.CalmWaterModel(SHIP)
    plan = Plan.from_schedule(wp, [18.0, 15.0], departure=T0, ship=SHIP, weather=calm, model=model)
    d = geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
    legs = plan.legs
    assert list(legs.columns[: len(LEG_COLUMNS)]) == list(LEG_COLUMNS)
    assert [c for c in legs.columns if c.startswith("margin_")] == [f"margin_{b}" for b in BANDS]
    np.testing.assert_allclose(legs["distance_nm"], d, rtol=1e-12)
    np.testing.assert_allclose(legs["duration_h"], d / [18.0, 15.0], rtol=1e-9)
    rate = SHIP.fuel_rate_tph(SHIP.calm_power_kw(np.array([18.0, 15.0])))
    np.testing.assert_allclose(legs["fuel_t"], rate * d / [18.0, 15.0], rtol=1e-9)
    np.testing.assert_allclose(legs["power_kw"], SHIP.calm_power_kw(np.array([18.0, 15.0])), rtol=1e-9)
    assert legs["heading_deg"].iloc[0] == pytest.approx(90.0, abs=1e-6)  # along the equator, no current
    assert plan.total_fuel_t == pytest.approx(float(np.sum(rate * d / [18.0, 15.0])), rel=1e-9)
    assert plan.arrival - plan.departure == plan.times[-1] - plan.times[0]
    assert np.isinf(legs[[f"margin_{b}" for b in BANDS]].to_numpy()).all()  # Hs 0: no band applies
    assert plan.verify() == []


def test_current_sets_the_schedule_by_the_speed_over_ground():
    # a 1 m/s current setting east along an eastbound leg: SOG = STW + 1.944 kn, heading unchanged
    wx = orx.scenarios.uniform(
        hs_m=0.0,
        tp_s=6.0,
        current_speed_ms=1.0,
        current_to_deg=90.0,
        bbox=(-10, 10, -40, 0),
        start=T0,
        duration_h=240,
        resolution_deg=1.0,
    )
    wp = np.array([[0.0, -30.0], [0.0, -25.0]])
    plan = Plan.from_schedule(wp, [12.0], departure=T0, ship=SHIP, weather=wx, model=orx.CalmWaterModel(SHIP))
    sog = 12.0 + 3600.0 / 1852.0
    assert plan.legs["sog_kn"].iloc[0] == pytest.approx(sog, rel=1e-9)
    assert plan.duration_h == pytest.approx(geo.distance_nm(0, -30, 0, -25) / sog, rel=1e-9)


def test_verify_finds_a_leg_moved_into_a_band(rough):
    wp = np.array([[0.0, -30.0], [0.0, -28.0], [0.0, -26.0]])
    # forbidden speeds on an eastbound heading in this sea, in closed form
    ivs = orx.forbidden_speed_intervals(SHIP, hs_m=12.0, period_s=14.0, wave_from_deg=270.0, heading_deg=90.0)
    iv = next(i for i in ivs if i.band == "high_wave_attack")
    inside = 0.5 * (iv.lo_kn + iv.hi_kn)
    outside = 0.95 * min(i.lo_kn for i in ivs if i.lo_kn > 1.0)
    plan = Plan.from_schedule(wp, [outside, inside], departure=T0, ship=SHIP, weather=rough)
    found = plan.verify()
    assert "band:high_wave_attack" in _kinds(found, leg=1)
    assert not any(k.startswith("band:") for k in _kinds(found, leg=0))
    v = next(v for v in found if v.kind == "band:high_wave_attack")
    assert iv.lo_kn / (0.5 * 3.0339 * 14.0) <= v.value <= 1.2 + 1e-9  # the ratio V cos χ / c_g, inside [0.8, 1.2]
    assert plan.legs["margin_high_wave_attack"].iloc[1] <= 0.0 < plan.legs["margin_high_wave_attack"].iloc[0]


def test_verify_finds_power_above_mcr_and_below_the_minimum_load(calm):
    wp = np.array([[0.0, -30.0], [0.0, -29.0], [0.0, -28.0], [0.0, -27.0]])
    too_fast = SHIP.max_calm_speed_kn * 1.02
    too_slow = SHIP.calm_speed_kn(SHIP.min_power_kw) * 0.9
    plan = Plan.from_schedule(
        wp, [15.0, too_fast, too_slow], departure=T0, ship=SHIP, weather=calm, model=orx.CalmWaterModel(SHIP)
    )
    found = plan.verify()
    assert _kinds(found, leg=0) == set()
    assert _kinds(found, leg=1) == {"power_above_mcr"}
    assert _kinds(found, leg=2) == {"power_below_min"}
    hi = next(v for v in found if v.kind == "power_above_mcr")
    assert hi.value == pytest.approx(float(SHIP.calm_power_kw(too_fast)), rel=1e-9)
    assert hi.limit == SHIP.mcr_kw


def test_verify_finds_a_missed_eta_and_an_unsailable_schedule(calm):
    wp = np.array([[0.0, -30.0], [0.0, -28.0]])
    d = float(geo.distance_nm(0, -30, 0, -28))
    model = orx.CalmWaterModel(SHIP)
    sailed = d / 15.0
    late = Plan.from_schedule(
        wp,
        [15.0],
        departure=T0,
        ship=SHIP,
        weather=calm,
        model=model,
        eta=T0 + np.timedelta64(int(3600 * (sailed - 0.5)), "s"),
    )
    (v,) = late.verify()
    assert v.kind == "eta" and v.value == pytest.approx(0.5, abs=1e-3)
    assert late.verify(eta=T0 + np.timedelta64(int(3600 * (sailed + 0.1)), "s")) == []
    # eq mode: arriving 0.1 h early is a miss too
    assert _kinds(late.verify(eta=T0 + np.timedelta64(int(3600 * (sailed + 0.1)), "s"), eta_mode="eq")) == {"eta"}
    # a schedule claiming 10 % less time than 15 kn needs
    times = T0 + np.array([0, int(sailed * 0.9 * 3.6e12)]).astype("timedelta64[ns]")
    fast = Plan.from_schedule(wp, [15.0], departure=T0, ship=SHIP, weather=calm, model=model, times=times)
    (s,) = fast.verify()
    assert s.kind == "schedule" and s.value == pytest.approx(0.1 * sailed, rel=1e-6)


def test_verify_finds_a_waypoint_on_land(calm):
    # (-1.0, 12.0) lies inland in Gabon
    wp = np.array([[0.0, 2.0], [-1.0, 12.0], [-3.0, 8.0]])
    plan = Plan.from_schedule(wp, [15.0, 15.0], departure=T0, ship=SHIP, weather=calm, model=orx.CalmWaterModel(SHIP))
    found = plan.verify()
    land = [v for v in found if v.kind == "land"]
    assert {v.leg for v in land} == {0, 1}
    assert any(v.position == (-1.0, 12.0) for v in land)
    # the same track with the land mask off is clean: the check is the mask's
    plan_off = Plan.from_schedule(
        wp, [15.0, 15.0], departure=T0, ship=SHIP, weather=calm, model=orx.CalmWaterModel(SHIP), use_land_mask=False
    )
    assert plan_off.verify() == []


def test_verify_finds_nan_weather_corridor_and_exclusion(calm):
    wx = calm.copy(deep=True)
    wx["hs_m"].loc[{"lat": 0.0, "lon": -28.0}] = np.nan  # a no-passage cell on the track
    wp = np.array([[0.0, -30.0], [0.0, -26.0]])
    model = orx.CalmWaterModel(SHIP)
    nan_plan = Plan.from_schedule(wp, [15.0], departure=T0, ship=SHIP, weather=wx, model=model)
    assert "no_passage" in _kinds(nan_plan.verify())
    # 30 nm off a corridor 20 nm wide (half-width 10 nm)
    off = np.array([[0.5, -30.0], [0.5, -26.0]])
    corridor = orx.Corridor(np.array([[0.0, -30.0], [0.0, -26.0]]), 10.0)
    out = Plan.from_schedule(off, [15.0], departure=T0, ship=SHIP, weather=calm, model=model, corridor=corridor)
    (c,) = [v for v in out.verify() if v.kind == "corridor"]
    # 0.5° of latitude off at the ends; the great circle between them bulges a little further off
    end_off = float(geo.distance_nm(0.0, -30.0, 0.5, -30.0))
    assert end_off <= c.value <= end_off + 0.05 and c.limit == pytest.approx(10.0)
    # a storm centre parked on the track with a 20 nm radius
    excl = Exclusion(np.array([T0, T0 + np.timedelta64(240, "h")]), 0.0, -28.0, 20.0)
    hit = Plan.from_schedule(wp, [15.0], departure=T0, ship=SHIP, weather=calm, model=model, exclusion=excl)
    (e,) = [v for v in hit.verify() if v.kind == "exclusion"]
    assert e.value < 20.0 and e.limit == pytest.approx(20.0)


def test_project_to_polyline_against_hand_values():
    wp = np.array([[0.0, 0.0], [0.0, 10.0]])
    s, xt, dist, leg = project_to_polyline(wp, [1.0, -1.0, 0.0], [5.0, 5.0, 12.0])
    assert s[0] == pytest.approx(geo.distance_nm(0, 0, 0, 5), rel=1e-9)
    assert xt[0] == pytest.approx(-geo.distance_nm(0, 5, 1, 5), rel=1e-6)  # north of an eastbound line: port
    assert xt[1] == pytest.approx(geo.distance_nm(0, 5, 1, 5), rel=1e-6)
    assert dist[2] == pytest.approx(geo.distance_nm(0, 10, 0, 12), rel=1e-9)
    assert leg.tolist() == [0, 0, 0]


def test_gc_points_course_matches_initial_course():
    lat, lon, course = gc_points(30.0, -40.0, 50.0, 10.0, np.array([0.0, 0.3, 1.0]))
    assert course[0] == pytest.approx(float(geo.initial_course_deg(30.0, -40.0, 50.0, 10.0)), abs=1e-9)
    ahead = geo.initial_course_deg(lat[1], lon[1], 50.0, 10.0)
    assert course[1] == pytest.approx(float(ahead), abs=1e-9)
    assert (lat[2], lon[2]) == pytest.approx((50.0, 10.0))


def test_geojson_splits_at_the_antimeridian_and_netcdf_round_trips(tmp_path):
    wx = orx.scenarios.uniform(
        hs_m=1.0, tp_s=6.0, bbox=(20, 50, 160, -160), start=T0, duration_h=120, resolution_deg=1.0
    )
    wp = np.array([[35.0, 175.0], [36.0, -178.0], [37.0, -170.0]])
    plan = Plan.from_schedule(wp, [16.0, 16.0], departure=T0, ship=SHIP, weather=wx)
    gj = json.loads(json.dumps(plan.to_geojson()))
    assert gj["type"] == "FeatureCollection"
    track = gj["features"][0]["geometry"]
    assert track["type"] == "MultiLineString" and len(track["coordinates"]) == 2
    west, east = track["coordinates"]
    assert west[0] == [175.0, 35.0] and west[-1][0] == 180.0
    assert east[0][0] == -180.0 and east[-1] == [-170.0, 37.0]
    assert west[-1][1] == east[0][1]
    # the crossing is on the leg's great circle
    _, _, _ = gc_points(35.0, 175.0, 36.0, -178.0, 0.5)
    lat_x = west[-1][1]
    s, xt, dist, _ = project_to_polyline(wp[:2], [lat_x], [180.0])
    assert dist[0] < 1e-6
    points = [f for f in gj["features"] if f["geometry"]["type"] == "Point"]
    assert len(points) == 3 and points[0]["properties"]["stw_kn"] == 16.0
    path = plan.to_netcdf(tmp_path / "plan.nc")
    assert not list(tmp_path.glob(".plan.nc.*"))  # the temporary name is gone
    back = xr.open_dataset(path)
    np.testing.assert_allclose(back["fuel_t"].values, plan.legs["fuel_t"].to_numpy())
    np.testing.assert_array_equal(back["waypoint_time"].values, plan.times)
    assert back.attrs["total_fuel_t"] == pytest.approx(plan.total_fuel_t)
    back.close()


def test_bad_inputs_name_the_value():
    with pytest.raises(orx.ConfigError, match="stw_kn"):
        Plan.from_schedule(
            [[0, 0], [0, 1]], [0.0], departure=T0, ship=SHIP, weather=orx.scenarios.calm(bbox=(-5, 5, -5, 5))
        )
    with pytest.raises(orx.ConfigError, match="strictly increasing"):
        Exclusion(np.array([T0, T0]), 0.0, 0.0, 10.0)


def _storm_with_current() -> xr.Dataset:
    """A storm moving east across a 1.5 m/s current to the north-east: every evaluation iterates its schedule."""
    ds = orx.scenarios.moving_storm(
        0.0, -32.0, 90.0, 8.0, peak_hs_m=11.0, radius_nm=240.0, start=T0, duration_h=120.0, step_h=3.0,
        resolution_deg=0.5, bbox=(-8.0, 8.0, -40.0, -10.0),
    )  # fmt: skip
    u, v = 1.5 * np.sin(np.radians(45.0)), 1.5 * np.cos(np.radians(45.0))
    shape = ds["hs_m"].shape
    ds["current_u_ms"] = (ds["hs_m"].dims, np.full(shape, u), {"units": "m s-1"})
    ds["current_v_ms"] = (ds["hs_m"].dims, np.full(shape, v), {"units": "m s-1"})
    return ds


def test_verify_reads_the_evaluation_the_plan_was_made_from_and_finds_what_a_fresh_evaluation_finds(monkeypatch):
    """A plan made by from_context keeps its dense evaluation and verify at the same spacing reads it (one
    evaluation of the track, not two); a copy without it (dataclasses.replace, or unpickled) is evaluated afresh,
    and both find the same violations — kinds, legs, worst values — in a time-varying storm with a current (the
    schedule a fixed point), with slow legs below the minimum load, bands, and an ETA missed."""
    import dataclasses
    import pickle

    import optroute.plan.result as result_mod

    wx = _storm_with_current()
    wp = np.column_stack([np.linspace(0.0, 1.5, 9), np.linspace(-38.0, -14.0, 9)])
    calls = []
    real = result_mod.evaluate_track

    def counted(*args, **kw):
        calls.append(1)
        return real(*args, **kw)

    monkeypatch.setattr(result_mod, "evaluate_track", counted)
    for stw, eta_h in (([4.0, 6.0, 20.0, 12.0, 5.0, 22.0, 9.0, 14.0], 90.0), ([15.0] * 8, None)):
        eta = None if eta_h is None else T0 + np.timedelta64(int(eta_h * 3600), "s")
        plan = Plan.from_schedule(wp, stw, departure=T0, ship=SHIP, weather=wx, eta=eta, step_nm=5.0)
        calls.clear()
        shared = plan.verify(step_nm=5.0)
        assert not calls  # read, not evaluated again
        fresh_copies = (dataclasses.replace(plan), pickle.loads(pickle.dumps(plan)))
        assert "_dense" not in fresh_copies[1].__dict__  # not shipped with the plan
        for fresh in fresh_copies:
            calls.clear()
            again = fresh.verify(step_nm=5.0)
            assert len(calls) == 1
            assert [(v.kind, v.leg) for v in again] == [(v.kind, v.leg) for v in shared]
            for a, b in zip(again, shared, strict=True):
                assert a.value == pytest.approx(b.value, rel=1e-9, abs=1e-12) and a.limit == b.limit
                assert abs((a.time - b.time) / np.timedelta64(1, "s")) < 1e-3
            assert again.points.leg.size == shared.points.leg.size
        if eta_h is not None:  # the planted ones are there
            assert {"power_below_min", "eta"} <= _kinds(shared)
        calls.clear()
        plan.verify(step_nm=2.5)  # another spacing: evaluated at it
        assert len(calls) == 1
        calls.clear()
        moved = np.array(plan.waypoints, dtype=float)  # waypoints changed in place: evaluated again
        moved[1:-1, 0] += 0.05
        object.__setattr__(plan, "waypoints", moved)
        plan.verify(step_nm=5.0)
        assert len(calls) == 1
