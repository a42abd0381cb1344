"""The scenario catalogue: names, datasets and the name-or-file loader."""

from __future__ import annotations

import numpy as np
import pytest

import optroute as orx
from optroute.errors import ConfigError
from optroute.weather import catalogue, scenarios


def test_names_cover_the_contract():
    names = catalogue.scenario_names()
    for required in ("calm", "uniform", "north_pacific_storms", "shao_case_1", "shao_case_2"):
        assert required in names
    assert len(set(names)) == len(names)


def test_scenario_equals_the_function_with_defaults_and_is_a_copy():
    a = catalogue.scenario("uniform")
    ref = scenarios.uniform()
    np.testing.assert_array_equal(a["hs_m"].values, ref["hs_m"].values)
    assert a.attrs["scenario_name"] == "uniform"
    a["hs_m"].values[:] = 99.0  # the caller's copy only
    assert float(catalogue.scenario("uniform")["hs_m"].max()) == pytest.approx(2.0)


def test_unknown_name_lists_valid_names():
    with pytest.raises(ConfigError) as e:
        catalogue.scenario("hurricane_x")
    msg = str(e.value)
    assert "hurricane_x" in msg and all(n in msg for n in catalogue.scenario_names())


def test_load_weather_name_file_and_neither(tmp_path):
    assert orx.load_weather("calm").attrs["scenario_name"] == "calm"
    path = tmp_path / "wx.nc"
    scenarios.uniform(hs_m=3.0, bbox=(0.0, 10.0, 0.0, 10.0), duration_h=24.0).to_netcdf(path)
    ds = orx.load_weather(path)
    assert float(ds["hs_m"].max()) == pytest.approx(3.0)
    with pytest.raises(ConfigError) as e:
        orx.load_weather(str(tmp_path / "missing.nc"))
    assert "missing.nc" in str(e.value) and "shao_case_1" in str(e.value)
    with pytest.raises(ConfigError):
        orx.load_weather(3.0)  # type: ignore[arg-type]
