"""Plan figures render offline to non-empty PNGs, draw what the plan says, and survive the antimeridian."""

import math

import numpy as np
import pytest
import xarray as xr

import optroute as orx
from optroute.errors import ConfigError
from optroute.plot.common import save_png
from optroute.plot.plan import plan_map_figure, plan_profile_figure
from optroute.plot.route import lon_label

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _haversine_nm(lat1, lon1, lat2, lon2):
    """Great-circle distance by the haversine formula on a sphere of 3440.065 nm (written out here, not optroute.geodesy)."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    dp, dl = p2 - p1, math.radians(lon2 - lon1)
    a = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * 3440.065 * math.asin(math.sqrt(a))


def _plan(hs_m: float, waypoints) -> orx.Plan:
    """A general-cargo ship (L = 170 m, band threshold 0.04 L = 6.8 m) at 12 kn through uniform seas."""
    ship = orx.Ship.preset("general_cargo_25k_dwt")
    wx = orx.scenarios.uniform(
        hs_m=hs_m, tp_s=11.0, wave_from_deg=200.0, bbox=(20, 50, 130, 250), duration_h=480, resolution_deg=2.0
    )
    return orx.Plan.from_schedule(
        waypoints,
        [12.0] * (len(waypoints) - 1),
        departure=wx.time.values[0],
        ship=ship,
        weather=wx,
        model=orx.CalmWaterModel(ship),
        step_nm=20.0,
    )


PACIFIC = [(35.0, 160.0), (38.0, 175.0), (39.0, -170.0), (37.0, -155.0)]  # crosses 180°


@pytest.fixture(scope="module")
def rough_plan():
    return _plan(8.0, PACIFIC)


def test_profile_and_map_are_non_empty_pngs(tmp_path, rough_plan):
    wx = rough_plan.context.dataset
    paths = [
        save_png(plan_profile_figure(rough_plan), tmp_path / "profile_time.png"),
        save_png(plan_profile_figure(rough_plan, x="distance"), tmp_path / "profile_distance.png"),
        save_png(plan_map_figure(rough_plan, wx, compare=rough_plan), tmp_path / "map.png"),
    ]
    for p in paths:
        data = p.read_bytes()
        assert data[:8] == PNG_MAGIC and len(data) > 20_000
    assert sorted(x.name for x in tmp_path.iterdir()) == ["map.png", "profile_distance.png", "profile_time.png"]


def test_profile_axes_against_hand_values(rough_plan):
    fig = plan_profile_figure(rough_plan, x="distance")
    ax_v, ax_p, ax_h, ax_m = fig.axes[:4]
    # the distance axis ends at the sum of the legs' WGS84 geodesics (Karney's, through pyproj here, not
    # optroute.geodesy); the haversine sphere is within its known -0.56 %..+0.45 % of it
    from pyproj import Geod

    wgs84 = Geod(ellps="WGS84")
    total = sum(wgs84.inv(a[1], a[0], b[1], b[0])[2] / 1852.0 for a, b in zip(PACIFIC[:-1], PACIFIC[1:], strict=True))
    sphere = sum(_haversine_nm(*a, *b) for a, b in zip(PACIFIC[:-1], PACIFIC[1:], strict=True))
    assert ax_m.get_xlim()[1] == pytest.approx(total, rel=2e-3)
    assert 1 - 0.0056 <= total / sphere <= 1 + 0.0045
    # MCR line at the preset's MCR; Hs threshold line at 0.04 L = 0.04 * 170 m = 6.8 m
    ship = rough_plan.context.ship
    assert any(line.get_ydata()[0] == pytest.approx(ship.mcr_kw / 1000.0) for line in ax_p.lines)
    assert any(line.get_ydata()[0] == pytest.approx(6.8) for line in ax_h.lines)
    # Hs 8 m >= 6.8 m: bands apply and their margins are drawn (one step line per band that applies)
    legend = [t.get_text() for t in ax_m.get_legend().get_texts()]
    assert "band edge (margin 0)" in legend
    assert len(legend) >= 3  # at least one band besides the edge and the forbidden shading


def test_profile_says_when_no_band_applies():
    calm = _plan(3.0, PACIFIC[:2])  # 3 m < 6.8 m
    ax_m = plan_profile_figure(calm).axes[3]
    texts = [t.get_text() for t in ax_m.texts]
    assert any("no danger band applies" in t and "6.8 m" in t for t in texts)


def test_map_is_continuous_across_the_antimeridian_with_a_split_weather_grid(rough_plan):
    # the same weather, its longitudes wrapped to [-180, 180) and sorted: the Pacific grid falls apart
    # into 130..178 and -180..-110; the map must put it back together in one frame
    wx = rough_plan.context.dataset
    wrapped = wx.assign_coords(lon=((wx.lon + 180.0) % 360.0) - 180.0).sortby("lon")
    assert float(wrapped.lon.min()) < -170 and float(wrapped.lon.max()) > 170
    fig = plan_map_figure(rough_plan, wrapped)
    ax = fig.axes[0]
    (track,) = [line for line in ax.lines if line.get_label().startswith("optimised plan")]
    x = np.asarray(track.get_xdata(), dtype=float)
    assert np.all(np.abs(np.diff(x)) < 180.0)
    x0, x1 = ax.get_xlim()
    assert x0 <= x.min() and x.max() <= x1 and x1 - x0 < 180.0  # one frame around the track, not the globe
    labels = [t.get_text() for t in ax.get_xticklabels()]
    assert "180°" in labels


def test_lon_labels():
    assert [lon_label(v) for v in (150.0, 180.0, 200.0, -120.0, 0.0, 250.0)] == [
        "150°E",
        "180°",
        "160°W",
        "120°W",
        "0°",
        "110°W",
    ]


def test_bad_inputs_are_config_errors(rough_plan):
    with pytest.raises(ConfigError, match="x='space'"):
        plan_profile_figure(rough_plan, x="space")
    with pytest.raises(ConfigError, match="needs an optroute Plan"):
        plan_profile_figure("plan.geojson")
    with pytest.raises(ConfigError, match="hs_m"):
        plan_map_figure(rough_plan, xr.Dataset(coords={"time": rough_plan.context.dataset.time}))
    with pytest.raises(ConfigError, match="cannot draw a str"):
        plan_map_figure(rough_plan, rough_plan.context.dataset, compare={"x": "route.csv"})
