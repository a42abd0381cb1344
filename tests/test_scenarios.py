"""Synthetic scenarios against the seed documents (reference.md), hand-worked formulas and round trips."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr

from optroute import geodesy as geo
from optroute.errors import ConfigError
from optroute.geo import land
from optroute.physics import safety
from optroute.physics.ship import Ship
from optroute.weather import WeatherSampler, open_weather
from optroute.weather import cyclone as tc
from optroute.weather import scenarios as sc

H = np.timedelta64(1, "h")
T0 = sc.DEFAULT_START


# --------------------------------------------------------------------------- seed 001: Shao case studies


def _box(area):
    return (area.lat_min, area.lat_max, area.lon_min, area.lon_max)


def test_shao_geometry_against_reference_md():
    # reference.md §001: islands lon 50–70, lat −1..7; case I weather lon 50–70, lat −1..−9 at t = 0,
    # 60 h still, then south at 3 kn; case II lat −7..−15 moving north at 3 kn.
    islands, weather = sc.shao_no_go(1, 0.0)
    assert _box(islands) == (-1.0, 7.0, 50.0, 70.0)
    assert _box(weather) == (-9.0, -1.0, 50.0, 70.0)
    assert islands.corners() == ((-1.0, 50.0), (-1.0, 70.0), (7.0, 70.0), (7.0, 50.0))
    assert _box(sc.shao_no_go(1, 60.0)[1]) == (-9.0, -1.0, 50.0, 70.0)
    # by hand: 3 kn = 3 nm/h = 0.05 deg of latitude per hour; at t = 100 h it has moved 40 h = 2 deg south
    assert _box(sc.shao_no_go(1, 100.0)[1]) == pytest.approx((-11.0, -3.0, 50.0, 70.0))
    assert _box(sc.shao_no_go(1, 100.0)[0]) == (-1.0, 7.0, 50.0, 70.0)
    # case II moves from t = 0: at 100 h, 5 deg north
    assert _box(sc.shao_no_go(2, 0.0)[1]) == (-15.0, -7.0, 50.0, 70.0)
    assert _box(sc.shao_no_go(2, 100.0)[1]) == pytest.approx((-10.0, -2.0, 50.0, 70.0))
    # a datetime works as well as hours
    assert _box(sc.shao_no_go(1, T0 + 100 * H)[1]) == pytest.approx((-11.0, -3.0, 50.0, 70.0))


def test_shao_dataset_nan_cells_follow_the_rectangles():
    ds = sc.shao_case(1)
    assert ds.attrs["geography"] == "synthetic"
    assert json.loads(ds.attrs["start_lat_lon"]) == [0.0, 0.0] and json.loads(ds.attrs["end_lat_lon"]) == [0.0, 90.0]
    hs = ds["hs_m"]

    def at(h, lat, lon):
        return float(hs.sel(time=T0 + h * H, lat=lat, lon=lon))

    # islands, at every time
    assert math.isnan(at(0, 0.0, 60.0)) and math.isnan(at(300, 7.0, 50.0))
    # weather box at t = 0, edges included, just outside finite
    assert math.isnan(at(0, -9.0, 70.0)) and math.isnan(at(0, -5.0, 60.0))
    assert (
        not math.isnan(at(0, -9.25, 60.0)) and not math.isnan(at(0, -5.0, 70.25)) and not math.isnan(at(0, -5.0, 49.75))
    )
    # t = 102 h: moved 42 h x 0.05 = 2.1 deg south: lat -11.1 .. -3.1
    assert not math.isnan(at(102, -3.0, 60.0))  # between the box and the islands
    assert math.isnan(at(102, -3.25, 60.0)) and math.isnan(at(102, -11.0, 60.0))
    assert not math.isnan(at(102, -11.25, 60.0))
    # the background sea: 2.0 m, Tp 5 sqrt(2), from 090, wind 8.92 m/s blowing to the west
    u10 = math.sqrt(9.80665 * 2.0 / 0.21) / 1.083  # 8.924 m/s
    assert at(0, 10.0, 20.0) == 2.0
    assert float(ds["tp_s"].sel(time=T0, lat=10.0, lon=20.0)) == pytest.approx(5.0 * math.sqrt(2.0))
    assert float(ds["wave_from_deg"].sel(time=T0, lat=10.0, lon=20.0)) == 90.0
    assert float(ds["wind_u_ms"].sel(time=T0, lat=10.0, lon=20.0)) == pytest.approx(-u10, abs=1e-9)
    assert float(ds["wind_v_ms"].sel(time=T0, lat=10.0, lon=20.0)) == pytest.approx(0.0, abs=1e-9)
    # the exact geometry from attrs equals the function's
    assert sc.no_go_areas(ds, T0 + 100 * H) == sc.shao_no_go(1, 100.0)
    # and, vectorised over points and times, marks exactly the NaN grid points
    tt, la, lo = np.meshgrid(ds.time.values[::5], ds.lat.values, ds.lon.values, indexing="ij")
    np.testing.assert_array_equal(sc.in_no_go_area(ds, la, lo, tt), np.isnan(hs.values[::5]))
    assert sc.in_no_go_area(ds, [-2.0, -2.0], [60.0, 60.0], [59.0, 90.0]).tolist() == [
        True,
        False,
    ]  # t=90 h: -2.5 .. -10.5


def test_shao_no_go_is_no_passage_for_the_sampler_and_navigable():
    ds = sc.shao_case(2, resolution_deg=0.5, duration_h=48)
    sampler = WeatherSampler(ds)
    wx = sampler.sample(T0, np.array([0.0, -10.0, -20.0]), np.array([60.0, 60.0, 60.0]))
    assert np.isnan(wx["hs_m"][:2]).all() and wx["hs_m"][2] == 2.0
    # synthetic geography: the real coast (Africa lies on the seed's equator) is ignored
    ok = land.navigable([0.0, 0.0, -10.0], [0.0, 30.0, 60.0], weather=ds, time=T0)
    assert ok.tolist() == [True, True, False]
    assert bool(land.is_land(0.0, 30.0))


def test_shao_is_deterministic_and_checks_its_case():
    xr.testing.assert_identical(sc.shao_case(1, resolution_deg=1.0), sc.shao_case(1, resolution_deg=1.0))
    with pytest.raises(ConfigError, match="case 1 and case 2"):
        sc.shao_case(3)


def test_netcdf_round_trip_shao(tmp_path):
    ds = sc.shao_case(1, resolution_deg=1.0, duration_h=96)
    path = tmp_path / "shao1.nc"
    ds.to_netcdf(path)
    with xr.open_dataset(path) as back:
        xr.testing.assert_identical(back.load(), ds)
        assert sc.no_go_areas(back, 80.0) == sc.shao_no_go(1, 80.0)
    canon = open_weather(path).load()
    for name in ds.data_vars:
        np.testing.assert_array_equal(canon[name].values, ds[name].values)
    np.testing.assert_array_equal(canon["time"].values, ds["time"].values)


# --------------------------------------------------------------------------- calm, uniform


def test_uniform_and_calm_values():
    ds = sc.uniform(hs_m=3.0, wave_from_deg=250.0, current_speed_ms=1.0, current_to_deg=90.0, duration_h=24)
    assert float(ds.hs_m.max()) == float(ds.hs_m.min()) == 3.0
    assert float(ds.tp_s[0, 0, 0]) == pytest.approx(5.0 * math.sqrt(3.0))
    # wind from 250 deg at the fully developed speed sqrt(g*3/0.21)/1.083 = 10.93 m/s blows to 070
    u10 = math.sqrt(9.80665 * 3.0 / 0.21) / 1.083
    assert float(ds.wind_u_ms[0, 0, 0]) == pytest.approx(u10 * math.sin(math.radians(70.0)))
    assert float(ds.wind_v_ms[0, 0, 0]) == pytest.approx(u10 * math.cos(math.radians(70.0)))
    assert float(ds.current_u_ms[0, 0, 0]) == pytest.approx(1.0) and abs(float(ds.current_v_ms[0, 0, 0])) < 1e-12
    assert ds.lon.size == 72 and ds.lon.values[0] == -180.0  # global, periodic
    calm = sc.calm(duration_h=24)
    assert float(calm.hs_m.max()) == 0.0 and "current_u_ms" not in calm
    assert float(np.hypot(calm.wind_u_ms, calm.wind_v_ms).max()) == 0.0


def test_bad_scenario_arguments():
    with pytest.raises(ConfigError, match="lat_min < lat_max"):
        sc.uniform(bbox=(10.0, 5.0, 0.0, 10.0))
    with pytest.raises(ConfigError, match="step_h"):
        sc.uniform(step_h=0.0)
    with pytest.raises(ConfigError, match="start"):
        sc.calm(start="yesterday")


# --------------------------------------------------------------------------- seed 000: North Pacific storms

SHIP = Ship.preset("container_8000teu")


@pytest.fixture(scope="module")
def npac(north_pacific_storms):
    return north_pacific_storms  # the suite's one copy (tests/conftest.py), shared with test_sail_route


def _gc(n=241):
    frac = np.linspace(0.0, 1.0, n)[:-1]
    lat, lon = geo.intermediate_points(*sc.SAN_DIEGO, *sc.TOKYO, frac)
    lat2, lon2 = geo.intermediate_points(*sc.SAN_DIEGO, *sc.TOKYO, frac + 1e-4)
    return frac, lat, lon, geo.initial_course_deg(lat, lon, lat2, lon2)


def test_north_pacific_domain_crosses_the_antimeridian(npac):
    lon = npac.lon.values
    assert lon[0] == 115.0 and lon[-1] == 250.0 and np.all(np.diff(lon) > 0)
    assert "unwrapped" in npac.attrs["lon_convention"]
    assert npac.lat.values[0] == 15.0 and npac.lat.values[-1] == 60.0
    assert (npac.time.values[-1] - npac.time.values[0]) / H >= 14 * 24
    s = WeatherSampler(npac)
    a = s.sample(T0 + 30 * H, 47.0, -170.0)["hs_m"]
    b = s.sample(T0 + 30 * H, 47.0, 190.0)["hs_m"]
    assert a == b


def test_north_pacific_round_trip_through_open_weather(tmp_path):
    ds = sc.north_pacific_storms(resolution_deg=2.5, duration_h=24.0)
    path = tmp_path / "npac.nc"
    ds.to_netcdf(path)
    back = open_weather(path).load()
    np.testing.assert_array_equal(back.lon.values, ds.lon.values)  # still one piece, 115 ... 250
    for name in ds.data_vars:
        np.testing.assert_allclose(back[name].values, ds[name].values, rtol=0, atol=1e-12)
    assert json.loads(back.attrs["storms"]) == json.loads(ds.attrs["storms"])


def test_moving_storm_moves_at_its_speed():
    ds = sc.moving_storm(40.0, -150.0, 90.0, 20.0, peak_hs_m=9.0, radius_nm=200.0, duration_h=24.0, resolution_deg=0.25)
    for h in (0, 24):
        hs = ds.hs_m.sel(time=T0 + h * H)
        i, j = np.unravel_index(int(np.argmax(hs.values)), hs.shape)
        lat_c, lon_c = geo.destination(40.0, -150.0, 90.0, 20.0 * h)  # 480 nm along the great circle after 24 h
        assert float(geo.distance_nm(lat_c, lon_c, float(ds.lat[i]), float(ds.lon[j]))) < 15.0
        assert float(hs.max()) == pytest.approx(math.sqrt(9.0**2 + 1.5**2), abs=0.05)


def test_two_storms_lie_across_the_great_circle(npac):
    # bands apply where Hs >= 0.04 L (Boeing EP 2145155; L = 320 m -> 12.8 m)
    frac, lat, lon, _ = _gc()
    s = WeatherSampler(npac)
    hs = s.sample(T0 + 72 * H, lat, lon)["hs_m"]
    band = hs >= 0.04 * SHIP.length_m
    # two separate stretches, one per storm, each several hundred nm long
    edges = np.flatnonzero(np.diff(band.astype(int)))
    assert band.any() and edges.size == 4, edges
    d = float(geo.distance_nm(*sc.SAN_DIEGO, *sc.TOKYO))
    lengths = [(frac[edges[i + 1]] - frac[edges[i]]) * d for i in (0, 2)]
    assert min(lengths) > 500.0, lengths
    assert 0.1 < frac[edges[0]] < 0.45 and 0.5 < frac[edges[2]] < 0.9


def _brute_force_max_speed(ship, hs, period, wave_from, heading, top=25.0):
    """Fastest speed <= top outside the four Boeing bands, by sampling speeds (physics.md §2–3)."""
    if hs < 0.04 * ship.length_m:
        return top
    v = np.arange(0.0, top + 1e-9, 0.01)
    alpha = math.radians(((wave_from - heading + 180.0) % 360.0) - 180.0)  # 0 = head seas
    c_kn = 9.80665 * period / (2 * math.pi) / (1852.0 / 3600.0)
    te = period / np.abs(1.0 + v * math.cos(alpha) / c_kn)
    ratio = te / ship.roll_period_s
    along = -v * math.cos(alpha)  # speed along the wave propagation
    bad = (
        ((ratio >= 0.8) & (ratio <= 1.2))
        | ((ratio >= 0.4) & (ratio <= 0.6))
        | ((along / c_kn >= 0.8) & (along / c_kn <= 1.2))
        | ((along / (c_kn / 2) >= 0.8) & (along / (c_kn / 2) <= 1.2))
    )
    ok = v[~bad]
    return float(ok.max()) if ok.size else 0.0


def test_bands_force_a_25kn_ship_below_10kn_inside_the_storms(npac):
    frac, lat, lon, heading = _gc(161)
    s = WeatherSampler(npac)
    checked = 0
    for h in range(0, 300, 12):
        wx = s.sample(T0 + h * H, lat, lon)
        for k in np.flatnonzero(wx["hs_m"] >= 0.04 * SHIP.length_m):
            args = {
                "hs_m": float(wx["hs_m"][k]),
                "period_s": float(wx["tp_s"][k]),
                "wave_from_deg": float(wx["wave_from_deg"][k]),
                "heading_deg": float(heading[k]),
            }
            iv = safety.forbidden_speed_intervals(SHIP, max_speed_kn=25.0, **args)
            v = safety.max_safe_speed_kn(25.0, iv)
            assert v < 10.0, (h, frac[k], args, iv)
            if checked % 25 == 0:  # an independent brute-force check of the same claim
                assert (
                    _brute_force_max_speed(
                        SHIP, args["hs_m"], args["period_s"], args["wave_from_deg"], args["heading_deg"]
                    )
                    < 10.0
                )
            checked += 1
    assert checked > 500


def test_great_circle_at_band_free_speed_takes_more_than_12_days(npac):
    # seed 000: 8 days in calm water, more than 12 days on the great circle through the storms
    s = WeatherSampler(npac)
    d = float(geo.distance_nm(*sc.SAN_DIEGO, *sc.TOKYO))
    assert d / 25.0 / 24.0 == pytest.approx(8.10, abs=0.01)  # WGS84 geodesic (8.08 d on the R1 sphere): "about 8 days"
    sailed, t, dt = 0.0, 0.0, 0.5
    while sailed < d:
        f = min(sailed / d, 1.0 - 2e-4)
        la, lo = geo.intermediate_points(*sc.SAN_DIEGO, *sc.TOKYO, [f, f + 1e-4])
        heading = float(geo.initial_course_deg(la[0], lo[0], la[1], lo[1]))
        wx = s.sample(T0 + np.timedelta64(int(t * 3600), "s"), la[0], lo[0])
        iv = safety.forbidden_speed_intervals(
            SHIP,
            hs_m=float(wx["hs_m"]),
            period_s=float(wx["tp_s"]),
            wave_from_deg=float(wx["wave_from_deg"]),
            heading_deg=heading,
            max_speed_kn=25.0,
        )
        sailed += max(safety.max_safe_speed_kn(25.0, iv), 0.5) * dt
        t += dt
    assert t / 24.0 > 12.0


# --------------------------------------------------------------------------- seed 004: tropical cyclone


def test_holland_peak_at_rmax_equals_vmax_by_hand():
    # Holland (1980) without Coriolis: V(Rmax) = sqrt(B dp / (rho e)); B 1.5, dp 50 hPa, rho 1.15
    vmax = math.sqrt(1.5 * 5000.0 / (1.15 * math.e))  # 48.98 m/s
    assert tc.holland_vmax_ms(50.0, 1.5) == pytest.approx(vmax, rel=1e-12)
    assert float(tc.holland_gradient_wind_ms(40.0, 50.0, 40.0, 1.5, 0.0)) == pytest.approx(vmax, rel=1e-12)
    r = np.linspace(1.0, 400.0, 39901)
    v = tc.holland_gradient_wind_ms(r, 50.0, 40.0, 1.5, 0.0)
    assert r[np.argmax(v)] == pytest.approx(40.0, abs=0.02)
    # with Coriolis at 20 N: V = sqrt(V0^2 + (r f/2)^2) - r f/2 at r = Rmax
    f = 2 * 7.2921e-5 * math.sin(math.radians(20.0))
    half_rf = 40e3 * f / 2
    assert float(tc.holland_gradient_wind_ms(40.0, 50.0, 40.0, 1.5, 20.0)) == pytest.approx(
        math.sqrt(vmax**2 + half_rf**2) - half_rf, rel=1e-12
    )


def test_holland_wind_decays_far_out():
    r = np.linspace(50.0, 3000.0, 600)
    v = tc.holland_gradient_wind_ms(r, 57.0, 45.0, 1.3, 20.0)
    assert np.all(np.diff(v) < 0)
    assert v[-1] < 0.05 * v.max()
    assert float(tc.holland_gradient_wind_ms(0.0, 57.0, 45.0, 1.3, 20.0)) == 0.0


def test_force7_radius():
    r7 = tc.cyclone_radius_km(57.0, 45.0, 1.3, 20.0)
    wind = lambda r: 0.8 * float(tc.holland_gradient_wind_ms(r, 57.0, 45.0, 1.3, 20.0))  # noqa: E731
    assert wind(r7) == pytest.approx(13.9, abs=1e-6)
    assert wind(r7 - 1.0) > 13.9 > wind(r7 + 1.0)
    assert r7 == pytest.approx(280.0, abs=2.0)  # seed 004's test typhoon: force-7 circle 280 km
    assert tc.cyclone_radius_km(5.0, 45.0, 1.3, 20.0) == 0.0  # too weak for force 7


def test_fetch_limited_waves_by_hand():
    # JONSWAP / SPM (CERC 1984): g Hs/U^2 = 1.6e-3 sqrt(g F/U^2), g Tp/U = 0.2857 (g F/U^2)^(1/3)
    g, u, f = 9.80665, 20.0, 100e3
    x = g * f / u**2
    hs, tp = tc.cyclone_waves(u, 100.0)
    assert float(hs) == pytest.approx(1.6e-3 * math.sqrt(x) * u**2 / g)
    assert float(tp) == pytest.approx(0.2857 * x ** (1 / 3) * u / g)
    # fully developed cap: g Hs/U^2 = 0.2433, g Tp/U = 8.134
    hs, tp = tc.cyclone_waves(10.0, 1e5)
    assert float(hs) == pytest.approx(0.2433 * 100.0 / g) and float(tp) == pytest.approx(8.134 * 10.0 / g)


def test_cyclone_turns_counter_clockwise_in_the_north():
    cyc = tc.Cyclone(track=((0.0, 20.0, 130.0),), translation_asymmetry=False)
    east = geo.destination(20.0, 130.0, 90.0, 100.0)
    south = geo.destination(20.0, 130.0, 180.0, 100.0)
    u, v = tc.cyclone_wind(cyc, 0.0, np.array([east[0], south[0]]), np.array([east[1], south[1]]))
    assert v[0] > 0 and u[0] < 0  # east of the centre: northward, turned 20 deg in (westward)
    assert u[1] > 0 and v[1] > 0  # south of the centre: eastward, turned in (northward)
    assert math.degrees(math.atan2(-u[0], v[0])) == pytest.approx(20.0, abs=0.5)
    sh = tc.Cyclone(track=((0.0, -20.0, 130.0),), translation_asymmetry=False)
    e2 = geo.destination(-20.0, 130.0, 90.0, 100.0)
    u2, v2 = tc.cyclone_wind(sh, 0.0, np.array([e2[0]]), np.array([e2[1]]))
    assert v2[0] < 0  # clockwise in the south


def test_tropical_cyclone_dataset_and_its_track(tmp_path):
    ds = sc.tropical_cyclone(duration_h=24.0, resolution_deg=0.5)
    track = sc.cyclone_track(ds)
    assert track["lat"][0] == pytest.approx(20.0) and track["lon"][0] == pytest.approx(130.0)
    # moves north-west at 10 kn: after 24 h, 240 nm along 315 deg
    assert float(geo.distance_nm(20.0, 130.0, track["lat"][-1], track["lon"][-1])) == pytest.approx(240.0, rel=1e-6)
    assert track["r7_km"][0] == pytest.approx(280.0, abs=2.0)
    lat, lon, radius = sc.cyclone_exclusion(ds, T0)
    assert (lat, lon) == pytest.approx((20.0, 130.0)) and radius == pytest.approx(track["r7_km"][0] + 30.0)
    # the highest sea lies within 100 km of the centre, waves are low far away
    hs0 = ds.hs_m.isel(time=0)
    k = np.unravel_index(int(np.argmax(hs0.values)), hs0.shape)
    assert float(geo.distance_nm(20.0, 130.0, float(ds.lat[k[0]]), float(ds.lon[k[1]]))) * 1.852 < 100.0
    assert float(hs0.sel(lat=6.0, lon=106.0)) < 2.0
    path = tmp_path / "tc.nc"
    ds.to_netcdf(path)
    with xr.open_dataset(path) as back:
        xr.testing.assert_identical(back.load(), ds)
        np.testing.assert_array_equal(sc.cyclone_track(back)["r7_km"], track["r7_km"])


# --------------------------------------------------------------------------- ensembles


def test_ensemble_is_reproducible_and_perturbs(tmp_path):
    kw = {"resolution_deg": 1.0, "duration_h": 24.0, "step_h": 6.0}
    a = sc.ensemble("tropical_cyclone", 3, seed=7, **kw)
    b = sc.ensemble("tropical_cyclone", 3, seed=7, **kw)
    c = sc.ensemble("tropical_cyclone", 3, seed=8, **kw)
    xr.testing.assert_identical(a, b)
    assert not np.allclose(a.hs_m.isel(member=1), c.hs_m.isel(member=1))
    assert a.hs_m.dims == ("member", "time", "lat", "lon")
    # member 0 is the control, identical to the plain scenario
    np.testing.assert_array_equal(a.hs_m.isel(member=0).values, sc.tropical_cyclone(**kw).hs_m.values)
    meta = json.loads(a.attrs["ensemble"])
    p1 = meta["members"][1]["perturbations"][0]
    m1 = sc.member(a, 1)
    tr = sc.cyclone_track(m1)
    assert tr["lat"][0] == pytest.approx(20.0 + p1["dlat_deg"]) and tr["lon"][0] == pytest.approx(
        130.0 + p1["dlon_deg"]
    )
    assert "member" not in m1.dims
    members = sc.ensemble(sc.north_pacific_storms, 2, seed=1, stack=False, resolution_deg=2.0, duration_h=12.0)
    assert isinstance(members, list) and len(members) == 2
    peaks = [s["peak_hs_m"] for s in json.loads(members[1].attrs["ensemble"])["members"][1]["storms"]]
    assert all(p != 14.0 for p in peaks)
    with pytest.raises(ConfigError, match="n >= 1"):
        sc.ensemble("tropical_cyclone", 0)
    with pytest.raises(ConfigError, match="unknown scenario"):
        sc.ensemble("shao", 2)
