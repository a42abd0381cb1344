"""WeatherSampler against hand-worked interpolation, a brute-force reference, and its coverage rules."""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest
import xarray as xr
from scipy.interpolate import RegularGridInterpolator

from optroute.errors import ConfigError, WeatherCoverageError, WeatherSchemaError
from optroute.weather import WeatherSampler, open_weather, sample_weather
from optroute.weather import io as wio
from optroute.weather.schema import canonical_dataset

T0 = np.datetime64("2024-01-10T00:00", "ns")
H = np.timedelta64(1, "h")


def _ds(times, lat, lon, hs, tp=10.0, direction=270.0, **more):
    return canonical_dataset(times, lat, lon, {"hs_m": hs, "tp_s": tp, "wave_from_deg": direction, **more})


def _angle_close(a, b, tol=1e-9):
    return abs((a - b + 180.0) % 360.0 - 180.0) < tol


def test_trilinear_against_hand_arithmetic():
    h0 = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]])
    h1 = 4.0 * h0
    ds = _ds([T0, T0 + 6 * H], [10.0, 12.0, 14.0], [20.0, 24.0, 28.0], np.stack([h0, h1]))
    got = WeatherSampler(ds).sample(T0 + np.timedelta64(90, "m"), 11.0, 27.0)["hs_m"]
    # time weight 1.5/6 = 0.25; lat 11 is halfway 10..12; lon 27 is 3/4 of the way 24..28
    t0_lat10 = 2.0 + 0.75 * (3.0 - 2.0)  # 2.75
    t0_lat12 = 5.0 + 0.75 * (6.0 - 5.0)  # 5.75
    t0 = t0_lat10 + 0.5 * (t0_lat12 - t0_lat10)  # 4.25
    t1_lat10 = 8.0 + 0.75 * (12.0 - 8.0)  # 11
    t1_lat12 = 20.0 + 0.75 * (24.0 - 20.0)  # 23
    t1 = t1_lat10 + 0.5 * (t1_lat12 - t1_lat10)  # 17
    assert got == pytest.approx(t0 + 0.25 * (t1 - t0))
    assert got == pytest.approx(7.4375)
    # on a node the grid value comes back exactly; the upper corner of the grid too
    s = WeatherSampler(ds)
    assert s.sample(T0 + 6 * H, 12.0, 24.0)["hs_m"] == pytest.approx(20.0)
    assert s.sample(T0 + 6 * H, 14.0, 28.0)["hs_m"] == pytest.approx(36.0)


def test_matches_a_brute_force_reference_on_a_non_uniform_grid():
    rng = np.random.default_rng(3)
    times = T0 + np.array([0, 3, 9, 12]) * H  # non-uniform in time
    lat = np.array([-5.0, -4.0, -1.5, 0.0, 2.5, 3.0])  # non-uniform in lat
    lon = np.linspace(30.0, 40.0, 11)
    hs = rng.uniform(0.5, 6.0, (4, 6, 11))
    u = rng.normal(0.0, 8.0, (4, 6, 11))
    ds = _ds(times, lat, lon, hs, wind_u_ms=u, wind_v_ms=-u)
    n = 500
    th = rng.uniform(0.0, 12.0, n)
    pla, plo = rng.uniform(-5.0, 3.0, n), rng.uniform(30.0, 40.0, n)
    got = WeatherSampler(ds).sample(T0 + (th * 3.6e12).astype("timedelta64[ns]"), pla, plo)
    pts = np.column_stack([th, pla, plo])
    for name, field in (("hs_m", hs), ("wind_u_ms", u)):
        ref = RegularGridInterpolator(([0.0, 3.0, 9.0, 12.0], lat, lon), field)(pts)
        np.testing.assert_allclose(got[name], ref, rtol=1e-10, atol=1e-10, err_msg=name)
    # and plain xarray interpolation agrees on the same points
    ref = (
        ds["hs_m"]
        .interp(
            time=xr.DataArray(T0 + (th * 3.6e12).astype("timedelta64[ns]"), dims="p"),
            lat=xr.DataArray(pla, dims="p"),
            lon=xr.DataArray(plo, dims="p"),
        )
        .values
    )
    np.testing.assert_allclose(got["hs_m"], ref, rtol=1e-9)


def test_directions_are_averaged_as_unit_vectors():
    d = np.array([[350.0, 10.0], [350.0, 10.0]])
    ds = _ds([T0], [0.0, 1.0], [0.0, 1.0], 1.0, direction=d)
    s = WeatherSampler(ds, time_policy="hold")
    mid = s.sample(T0, 0.5, 0.5)["wave_from_deg"]
    assert _angle_close(mid, 0.0)  # not 180
    quarter = s.sample(T0, 0.5, 0.25)["wave_from_deg"]
    sn = 0.75 * math.sin(math.radians(350.0)) + 0.25 * math.sin(math.radians(10.0))
    cs = 0.75 * math.cos(math.radians(350.0)) + 0.25 * math.cos(math.radians(10.0))
    assert _angle_close(quarter, math.degrees(math.atan2(sn, cs)) % 360.0)  # about 355
    assert _angle_close(quarter, 355.0, tol=0.05)
    ds2 = _ds([T0], [0.0, 1.0], [0.0, 1.0], 1.0, direction=np.array([[90.0, 180.0], [90.0, 180.0]]))
    assert WeatherSampler(ds2, time_policy="hold").sample(T0, 0.0, 0.5)["wave_from_deg"] == pytest.approx(135.0)


def test_global_grid_wraps_across_the_antimeridian():
    lon = np.arange(-180.0, 180.0, 1.0)  # 360 columns, periodic
    col = 1.0 + 0.1 * (np.arange(360) % 7)
    ds = _ds([T0], [0.0, 1.0], lon, np.broadcast_to(col, (1, 2, 360)))
    s = WeatherSampler(ds, time_policy="hold")
    assert s.periodic
    got = s.sample(T0, 0.5, [179.9, -179.9, 180.1, 359.9, -180.0])["hs_m"]
    hs_179, hs_m180, hs_m179, hs_m1, hs_0 = col[359], col[0], col[1], col[179], col[180]
    assert got[0] == pytest.approx(0.1 * hs_179 + 0.9 * hs_m180)  # between 179 E and 180 (= -180)
    assert got[1] == pytest.approx(0.9 * hs_m180 + 0.1 * hs_m179)  # between -180 and -179
    assert got[2] == pytest.approx(got[1])  # 180.1 E is 179.9 W
    assert got[3] == pytest.approx(0.1 * hs_m1 + 0.9 * hs_0)  # 359.9 E is 0.1 W
    assert got[4] == pytest.approx(hs_m180)


def test_regional_domain_across_the_antimeridian(tmp_path):
    # a WAVEWATCH III-style file in 0..360: 170 E .. 170 W
    lon = np.array([170.0, 175.0, 180.0, 185.0, 190.0])
    hs = np.broadcast_to(np.array([1.0, 2.0, 4.0, 8.0, 16.0]), (2, 2, 5)).astype(np.float32)
    raw = xr.Dataset(
        {
            "hs": (("time", "latitude", "longitude"), hs, {"units": "m"}),
            "tp": (("time", "latitude", "longitude"), np.full((2, 2, 5), 9.0), {"units": "s"}),
            "dir": (("time", "latitude", "longitude"), np.full((2, 2, 5), 45.0), {"units": "degree"}),
        },
        coords={"time": [T0, T0 + 3 * H], "latitude": [40.0, 41.0], "longitude": lon},
    )
    raw.to_netcdf(tmp_path / "np.nc")
    ds = open_weather(tmp_path / "np.nc")
    s = WeatherSampler(ds)
    assert not s.periodic
    got = s.sample(T0 + H, 40.5, [179.9, -179.9, 180.1, -172.5])["hs_m"]
    assert got[0] == pytest.approx(2.0 + (179.9 - 175.0) / 5.0 * (4.0 - 2.0))  # 3.96
    assert got[1] == pytest.approx(4.0 + (180.1 - 180.0) / 5.0 * (8.0 - 4.0))  # 4.08
    assert got[2] == pytest.approx(got[1])
    assert got[3] == pytest.approx(8.0 + 0.5 * (16.0 - 8.0))  # 172.5 W = 187.5 unwrapped
    with pytest.raises(
        WeatherCoverageError, match=r"lon=-160.*lon 170 to 190 deg E unwrapped \(across the antimeridian, to -170\)"
    ):
        s.sample(T0, 40.5, -160.0)


def test_nan_cells_mean_no_passage_never_zero():
    hs = np.ones((2, 4, 4))
    hs[:, 2, 2] = np.nan  # land at (lat 2, lon 2)
    ds = _ds([T0, T0 + 3 * H], [0.0, 1.0, 2.0, 3.0], [0.0, 1.0, 2.0, 3.0], hs)
    got = WeatherSampler(ds).sample(T0 + H, [1.5, 2.5, 2.5, 0.5, 1.0], [1.5, 2.5, 1.5, 0.5, 0.2])
    np.testing.assert_array_equal(np.isnan(got["hs_m"]), [True, True, True, False, False])
    assert np.all(got["hs_m"][~np.isnan(got["hs_m"])] == pytest.approx(1.0))
    assert np.all(np.isfinite(got["tp_s"]))  # only the variable with the hole is NaN


def test_missing_current_is_zero_missing_wind_is_unknown_and_nothing_else_may_be_missing():
    ds = canonical_dataset([T0], [0.0, 1.0], [0.0, 1.0], {"hs_m": 2.0, "tm_s": 8.0, "wave_from_deg": 90.0})
    s = WeatherSampler(ds, time_policy="hold")
    got = s.sample(T0, [[0.2, 0.4]], [0.5])
    assert got["hs_m"].shape == (1, 2)
    for name in ("current_u_ms", "current_v_ms"):
        np.testing.assert_array_equal(got[name], 0.0)
    for name in ("wind_u_ms", "wind_v_ms"):  # a wave file says nothing of the wind: not calm air
        assert np.isnan(got[name]).all()
    assert "tp_s" not in got and got["tm_s"] == pytest.approx(8.0)
    with pytest.raises(WeatherSchemaError, match="tp_s is not in the dataset"):
        s.sample(T0, 0.5, 0.5, variables=["tp_s"])
    with pytest.raises(WeatherSchemaError, match="hs_m is missing.*VHM0 \\(CMEMS\\)"):
        WeatherSampler(ds.drop_vars("hs_m"))


def _box():
    times = T0 + np.array([0, 6, 12]) * H
    hs = np.stack([np.full((2, 2), v) for v in (1.0, 2.0, 5.0)])
    return _ds(times, [10.0, 20.0], [-30.0, -20.0], hs)


def test_coverage_errors_name_point_time_and_extent():
    s = WeatherSampler(_box())
    with pytest.raises(WeatherCoverageError) as err:
        s.sample(T0 + 3 * H, [15.0, 25.0], [-25.0, -25.0])
    msg = str(err.value)
    for part in (
        "lat=25",
        "lon=-25",
        "2024-01-10T03:00:00",
        "area",
        "lat 10 to 20 deg N",
        "lon -30 to -20 deg E",
        "time 2024-01-10T00:00:00Z to 2024-01-10T12:00:00Z",
        "1 of 2 points",
    ):
        assert part in msg, part
    with pytest.raises(WeatherCoverageError, match=r"lon=-35\) at 2024-01-10T03:00:00"):
        s.sample(T0 + 3 * H, 15.0, -35.0)
    with pytest.raises(
        WeatherCoverageError,
        match=r"2024-01-10T13:00:00Z lies outside the weather dataset's time span.*time_policy='hold'",
    ):
        s.sample(T0 + 13 * H, 15.0, -25.0)
    with pytest.raises(WeatherCoverageError, match=r"2024-01-09T23:00:00"):
        s.sample(T0 - H, 15.0, -25.0)
    np.testing.assert_array_equal(s.covers([T0, T0 + 13 * H, T0], 15.0, [-25.0, -25.0, 0.0]), [True, False, False])


def test_hold_policy_holds_the_first_and_last_slices():
    s = WeatherSampler(_box(), time_policy="hold")
    np.testing.assert_allclose(s.sample([T0 - 5 * H, T0 + 99 * H], 15.0, -25.0)["hs_m"], [1.0, 5.0])
    with pytest.raises(WeatherCoverageError, match="area"):  # holding time never extends the area
        s.sample(T0 + 99 * H, 25.0, -25.0)
    # the policy recorded by open_weather is the default
    assert WeatherSampler(open_weather(_box(), time_policy="hold")).time_policy == "hold"


def test_static_dataset_covers_all_times_only_when_asked():
    ds = _ds([T0], [0.0, 1.0], [0.0, 1.0], 3.0)
    assert WeatherSampler(ds).sample(T0, 0.5, 0.5)["hs_m"] == pytest.approx(3.0)
    with pytest.raises(WeatherCoverageError, match="time span"):
        WeatherSampler(ds).sample(T0 + H, 0.5, 0.5)
    assert sample_weather(ds, T0 + 1000 * H, 0.5, 0.5, time_policy="hold")["hs_m"] == pytest.approx(3.0)


def test_bad_query_points():
    s = WeatherSampler(_box())
    with pytest.raises(ConfigError, match="NaT"):
        s.sample(np.datetime64("NaT"), 15.0, -25.0)
    with pytest.raises(ConfigError, match=r"lat=95"):
        s.sample(T0, 95.0, -25.0)
    with pytest.raises(ConfigError, match="do not broadcast"):
        s.sample([T0, T0], [15.0, 15.0, 15.0], -25.0)
    with pytest.raises(ConfigError, match="time_policy='later'"):
        WeatherSampler(_box(), time_policy="later")


def test_lazy_sampler_reads_slices_keeps_a_bounded_cache_and_checks_them(tmp_path, monkeypatch):
    rng = np.random.default_rng(0)
    times = T0 + np.arange(8) * 3 * H
    hs = rng.uniform(1.0, 3.0, (8, 5, 6))
    hs[5] = np.nan  # one all-NaN time slice, only found when read
    _ds(times, np.linspace(0, 4, 5), np.linspace(0, 5, 6), hs).to_netcdf(tmp_path / "w.nc")
    monkeypatch.setattr(wio, "_CHECK_ALL_BYTES", 0)  # treat the file as big: open_weather checks two slices only
    ds = open_weather(tmp_path / "w.nc", chunks={"time": 1})  # the first and last slices are fine
    slice_bytes = 5 * 6 * 8 * 4  # hs, tp, sin, cos
    s = WeatherSampler(ds, load_bytes=0, cache_bytes=3 * slice_bytes)
    eager = WeatherSampler(_ds(times, np.linspace(0, 4, 5), np.linspace(0, 5, 6), np.nan_to_num(hs)))
    for hour in (1.0, 4.0, 7.0, 10.0, 2.0):
        t = T0 + np.timedelta64(int(hour * 60), "m")
        np.testing.assert_allclose(
            s.sample(t, [1.2, 3.3], [0.4, 4.9])["hs_m"], eager.sample(t, [1.2, 3.3], [0.4, 4.9])["hs_m"]
        )
        assert len(s._cache) <= 3
    with pytest.raises(WeatherSchemaError, match=r"at 2024-01-10T15:00:00Z: hs_m is NaN everywhere"):
        s.sample(T0 + 14 * H, 1.0, 1.0)


@pytest.mark.skipif(
    importlib.util.find_spec("numba") is None, reason="numba is optional; the numpy kernel is the fallback"
)
@pytest.mark.parametrize("parallel_from", [10**9, 1000])
def test_numba_and_numpy_kernels_agree(monkeypatch, parallel_from):
    from optroute.weather import sample as sm

    monkeypatch.setattr(sm, "_NUMBA_PARALLEL_POINTS", parallel_from)  # serial, then threaded
    rng = np.random.default_rng(5)
    lon = np.arange(-180.0, 180.0, 10.0)
    hs = rng.uniform(0.5, 5.0, (3, 5, lon.size)).astype(np.float32)
    hs[1, 2, 3] = np.nan
    ds = _ds(
        T0 + np.arange(3) * 3 * H, np.linspace(-20, 20, 5), lon, hs, direction=rng.uniform(0, 360, (3, 5, lon.size))
    )
    n = 2000
    t = T0 + rng.integers(0, 6 * 3600, n).astype("timedelta64[s]")
    la, lo = rng.uniform(-20, 20, n), rng.uniform(-180, 180, n)
    a = WeatherSampler(ds, engine="numpy").sample(t, la, lo)
    b = WeatherSampler(ds, engine="numba").sample(t, la, lo)
    assert np.isnan(a["hs_m"]).any()
    for name in a:
        np.testing.assert_allclose(a[name], b[name], rtol=1e-12, atol=1e-12, equal_nan=True, err_msg=name)
    with pytest.raises(ConfigError, match="engine='fast'"):
        WeatherSampler(ds, engine="fast")


def test_waves_without_a_wind_variable_cost_what_kwon_gives_for_the_beaufort_number_of_their_hs():
    """Kwon's method with the wind unknown takes BN from Hs (Met Office probable wave heights): a wave-only
    file must not plan as if the air were calm (the power at BN 0 is the calm-water power)."""
    import optroute as orx
    from optroute.physics import seaway
    from optroute.physics.performance import KwonModel

    ship = orx.Ship.preset("container_54k_dwt")
    ds = canonical_dataset([T0], [29.0, 31.0], [-151.0, -147.0], {"hs_m": 5.0, "tp_s": 10.0, "wave_from_deg": 90.0})
    plan = orx.Plan.from_schedule(
        np.array([[30.0, -150.0], [30.0, -148.0]]),
        np.array([16.0]),
        departure=T0,
        ship=ship,
        weather=ds.assign_attrs(time_policy="hold"),
    )
    model = KwonModel(ship)
    alpha = 0.0  # due east into waves from the east: head seas
    bn = float(seaway.beaufort_from_hs(5.0))
    assert bn >= 6
    expected = float(model.brake_power_kw(16.0, hs_m=5.0, wave_angle_deg=alpha, wind_speed_ms=None))
    calm = float(ship.calm_power_kw(16.0))
    assert float(plan.legs["power_kw"].iloc[0]) == pytest.approx(expected, rel=2e-3)  # the course swings < 1 deg
    assert expected > 1.3 * calm
