"""The demo voyage end to end on a reduced grid: search, baseline, optimised plan, files and figures.

Checked against numbers worked here, not against the demo's own code: the great circle's length
by the WGS84 geodesic (pyproj directly), the patent's published transit times (EP 2145155: the great circle takes
more than 12 days, the routed ship 8 d 8 h), the 25 kn speed limit, and the least fuel any speed
profile can burn over the plan's distance and time (Jensen's inequality for the convex
fuel-rate curve: constant speed is optimal when no band or weather effect binds).
"""

import json
import re

import numpy as np
import pandas as pd
import pytest
import xarray as xr

import optroute.cli.demo as demo
from optroute.cli import main
from optroute.errors import ConfigError

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _geodesic_nm(lat1, lon1, lat2, lon2):
    """WGS84 geodesic length [nm] by pyproj directly (Karney 2013), independent of optroute.geodesy."""
    from pyproj import Geod

    return Geod(ellps="WGS84").inv(lon1, lat1, lon2, lat2)[2] / 1852.0


@pytest.fixture(scope="module")
def result(tmp_path_factory, north_pacific_storms):
    """The demo run once; its weather, ``scenarios.north_pacific_storms()`` at its defaults, is the suite's copy
    (tests/conftest.py, read only), not a second build of the same dataset in this process."""
    out = tmp_path_factory.mktemp("demo")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(demo.scenarios, "north_pacific_storms", lambda: north_pacific_storms)
        return demo.run_demo(out, cell_nm=120.0, max_leg_nm=200.0)


def test_files_are_written_whole(result):
    names = sorted(p.name for p in result.files)
    assert names == [
        "plan.csv",
        "plan.geojson",
        "plan.nc",
        "polar_storm.png",
        "profile_great_circle.png",
        "profile_plan.png",
        "route_map.png",
    ]
    folder = result.files[0].parent
    assert sorted(p.name for p in folder.iterdir()) == names  # no temporary files left behind
    for p in result.files:
        if p.suffix == ".png":
            data = p.read_bytes()
            assert data[:8] == PNG_MAGIC and 20_000 < len(data) < 300_000
    n_legs = len(result.plan.legs)
    gj = json.loads((folder / "plan.geojson").read_text())
    assert gj["type"] == "FeatureCollection"
    assert sum(f["properties"].get("kind") == "leg" for f in gj["features"]) == n_legs
    assert len(pd.read_csv(folder / "plan.csv")) == n_legs
    with xr.open_dataset(folder / "plan.nc") as ds:
        assert float(ds["fuel_t"].sum()) == pytest.approx(result.plan.total_fuel_t, rel=1e-9)


def test_plan_verifies_meets_the_eta_and_the_speed_limit(result):
    plan = result.plan
    assert plan.verify() == []
    t0 = result.great_circle.times[0]
    assert plan.departure == t0
    assert plan.arrival <= t0 + np.timedelta64(8 * 24 + 8, "h") + np.timedelta64(1, "s")
    assert plan.stw_kn.max() <= 25.0 + 1e-6


def test_the_band_side_search_finishes_within_the_demos_budget(result):
    """The demo's plan is labelled by its own solve: "optimal" only where Ipopt converged and the search over the
    band sides stopped by its rule (no flip improves), not on ``demo.BAND_SOLVES``."""
    stats = result.plan.solver_stats
    assert stats["outer_solves"] < demo.BAND_SOLVES
    assert stats["sides_settled"] and stats["ipopt_status"] == "Solve_Succeeded"
    assert result.plan.status == "optimal"


def test_great_circle_baseline_against_the_geodesic_and_the_patent(result):
    gc = result.great_circle
    (la0, lo0), (la1, lo1) = gc.waypoints[0], gc.waypoints[-1]
    # its legs follow one geodesic (the ellipsoid's great circle): their sum is the endpoints' distance
    assert gc.total_distance_nm == pytest.approx(_geodesic_nm(la0, lo0, la1, lo1), rel=1e-6)
    assert 4_700 < gc.total_distance_nm < 4_900  # San Diego - Tokyo, about 4 800 nm
    assert gc.total_duration_h >= gc.total_distance_nm / 25.0  # never faster than 25 kn
    assert gc.total_duration_h > 12 * 24  # EP 2145155: "more than 12 days"
    assert np.nanmin(gc.stw_kn) < 10.0  # the storms force it below 10 kn


def test_optimised_plan_beats_the_great_circle_and_spends_the_saved_hours_on_fuel(result):
    gc, searched, plan = result.great_circle, result.optimised, result.plan
    assert searched.total_duration_h < 8.5 * 24  # the routed ship of EP 2145155: about 8 d 8 h
    assert plan.duration_h < gc.total_duration_h - 3 * 24  # at least 3 days earlier (patent: 3 d 16 h)
    assert plan.total_fuel_t < searched.total_fuel_t  # a later arrival than the flat-out search: less fuel
    # the least fuel any speed profile burns over distance D in time T is the constant speed D / T's
    # (Jensen: fuel rate convex in speed, calm-water model, no band on the plan's legs)
    ship = plan.context.ship
    rate = lambda v: float(ship.fuel_rate_tph(ship.calm_power_kw(v)))  # noqa: E731
    speeds = np.linspace(3.0, 25.0, 89)
    assert np.all(np.diff([rate(v) for v in speeds], 2) > 0)  # the convexity Jensen needs
    d_nm, t_h = plan.distance_nm, plan.duration_h
    bound = rate(d_nm / t_h) * t_h
    assert bound * (1 - 1e-9) <= plan.total_fuel_t <= bound * 1.01


def test_table_and_cli(result, monkeypatch, capsys, tmp_path):
    monkeypatch.setattr(demo, "run_demo", lambda out_dir, **kw: result)
    assert main(["demo", "--out", str(tmp_path / "x"), "--cell-nm", "120"]) == 0
    out = capsys.readouterr().out

    def transit_h(name):
        m = re.search(rf"{re.escape(name)}\s+([\d,]+)\s+(\d+) d (\d+) h\s+([\d,]+)", out)
        assert m, out
        return int(m.group(2)) * 24 + int(m.group(3)), float(m.group(4).replace(",", ""))

    gc_h, gc_fuel = transit_h("great circle, forced slow-downs")
    plan_h, plan_fuel = transit_h("optimised plan (least fuel by ETA)")
    assert gc_h == round(result.great_circle.total_duration_h)
    assert plan_h == round(result.plan.duration_h) and plan_fuel == round(result.plan.total_fuel_t)
    assert "60 kUSD/h" in out and "600 USD/t" in out and "verified: 0 violations" in out


def test_demo_help():
    assert main(["demo", "--help"]) == 0


@pytest.mark.parametrize("kw", [{"cell_nm": 0.0}, {"max_leg_nm": float("nan")}, {"cell_nm": "40"}])
def test_bad_grid_is_a_config_error(kw):
    name = next(iter(kw))
    with pytest.raises(ConfigError, match=name):
        demo.run_demo(None, **kw)
