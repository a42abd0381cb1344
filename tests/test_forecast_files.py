"""Forecast runs with their issue times read from the files (CF forecast_reference_time, the cfgrib layout).

The files are written here in the layouts the providers use: a CF NetCDF with a scalar
``forecast_reference_time`` coordinate (CF conventions 1.8 §4.4, as THREDDS subsets of GFS write
it), and the cfgrib layout of a GRIB run (scalar ``time`` = the run's reference time, a ``step``
dimension, ``valid_time = time + step``), built as an in-memory dataset.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import optroute as orx
from optroute.errors import ConfigError, WeatherSchemaError
from optroute.weather import scenarios as sc

T0 = np.datetime64("2024-01-10T00:00", "ns")
H6 = np.timedelta64(6, "h")


def _run(issued: np.datetime64) -> xr.Dataset:
    return sc.uniform(
        hs_m=2.0, start=issued, duration_h=24.0, step_h=6.0, resolution_deg=5.0, bbox=(20, 40, -160, -130)
    )


def _cf_file(tmp_path, issued, name):
    ds = _run(issued).assign_coords(forecast_reference_time=issued)
    path = tmp_path / name
    ds.to_netcdf(path)
    return path


def _cfgrib_layout(issued: np.datetime64) -> xr.Dataset:
    """hs etc. over (step, latitude, longitude) with ERA5/ECMWF short names, as cfgrib opens a GRIB run."""
    base = _run(issued)
    steps = (base.time.values - issued).astype("timedelta64[ns]")
    ds = xr.Dataset(
        {
            "swh": (("step", "latitude", "longitude"), base.hs_m.values, {"units": "m"}),
            "pp1d": (("step", "latitude", "longitude"), base.tp_s.values, {"units": "s"}),
            "mwd": (("step", "latitude", "longitude"), base.wave_from_deg.values, {"units": "degree true"}),
        },
        coords={
            "time": issued,
            "step": steps,
            "latitude": base.lat.values[::-1],
            "longitude": base.lon.values,
            "valid_time": ("step", issued + steps),
        },
    )
    for v in ("swh", "pp1d", "mwd"):
        ds[v].values = ds[v].values[:, ::-1, :]
    return ds


def test_runs_come_back_in_issue_order_with_the_time_each_file_states(tmp_path):
    late = _cf_file(tmp_path, T0 + H6, "gfs_06z.nc")
    early = _cf_file(tmp_path, T0, "gfs_00z.nc")
    runs = orx.open_forecasts([late, early, _cfgrib_layout(T0 + 2 * H6)])
    assert [t for t, _ in runs] == [T0, T0 + H6, T0 + 2 * H6]
    assert runs[2][1].attrs["forecast_reference_time"] == "2024-01-10T12:00:00Z"
    assert runs[2][1].time.values[0] == T0 + 2 * H6  # valid times, from time + step
    assert float(runs[0][1].hs_m.max()) == 2.0
    # a plain open_weather of a forecast file records its issue time too
    assert orx.open_weather(early).attrs["forecast_reference_time"] == "2024-01-10T00:00:00Z"


def test_a_file_without_an_issue_time_needs_one_given(tmp_path):
    path = tmp_path / "analysis.nc"
    _run(T0).to_netcdf(path)
    with pytest.raises(WeatherSchemaError, match=r"analysis\.nc does not state its issue time.*issue_times"):
        orx.open_forecasts([path])
    ((t, _),) = orx.open_forecasts([path], issue_times=["2024-01-10T00:00"])
    assert t == T0


def test_a_given_time_that_contradicts_the_file_is_an_error_naming_both(tmp_path):
    path = _cf_file(tmp_path, T0, "gfs_00z.nc")
    with pytest.raises(ConfigError, match=r"gfs_00z\.nc states its issue time 2024-01-10T00:00:00Z but 2024-01-10T06"):
        orx.open_forecasts([path], issue_times=[T0 + H6])


def test_two_runs_with_one_issue_time_and_several_runs_in_one_file_are_errors(tmp_path):
    a, b = _cf_file(tmp_path, T0, "a.nc"), _cf_file(tmp_path, T0, "b.nc")
    with pytest.raises(ConfigError, match=r"a\.nc and .*b\.nc are both issued 2024-01-10T00:00:00Z"):
        orx.open_forecasts([a, b])
    two = _run(T0).assign_coords(forecast_reference_time=("time", [T0, T0, T0 + H6, T0 + H6, T0 + H6]))
    with pytest.raises(WeatherSchemaError, match="does not state its issue time"):  # two runs: no one time
        orx.open_forecasts([two])
    with pytest.raises(ConfigError, match="a list of forecast files"):
        orx.open_forecasts(a)
    with pytest.raises(ConfigError, match="issue_times has 2 entries for 1"):
        orx.open_forecasts([a], issue_times=[T0, T0])


def test_the_cli_reads_issue_times_from_the_files_and_the_simulator_takes_the_runs(tmp_path):
    from optroute.cli.simulate import _forecasts

    f00 = _cf_file(tmp_path, T0, "fc00.nc")
    f06 = _cf_file(tmp_path, T0 + H6, "fc06.nc")
    runs = _forecasts([str(f06), f"2024-01-10T00:00={f00}"])
    assert sorted(t for t, _ in runs) == [T0, T0 + H6]
    ship = orx.Ship.preset("container_54k_dwt")
    first = orx.open_forecasts([f00, f06])
    plan = orx.Plan.from_schedule(
        np.array([[30.0, -150.0], [30.0, -149.5]]), np.array([15.0]), departure=T0, ship=ship, weather=first[0][1]
    )
    r = orx.simulate_voyage(plan, first[0][1], ship, forecasts=first, replan=orx.ReplanPolicy.never())
    assert r.outcome.n_replans == 0 and r.outcome.distance_nm == pytest.approx(plan.distance_nm, rel=1e-9)
