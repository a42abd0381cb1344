"""Route figures render offline to non-empty PNGs, across the antimeridian."""

import numpy as np

import optroute as orx
from optroute import geodesy as geo
from optroute.plot.common import save_png
from optroute.plot.route import route_map_figure, route_profile_figure
from optroute.search.routing import sail_route


def _pacific_route():
    ship = orx.Ship.preset("container_54k_dwt")
    wx = orx.scenarios.uniform(hs_m=2.0, tp_s=8.0, bbox=(20, 50, 130, 250), duration_h=480, resolution_deg=2.0)
    lat, lon = geo.great_circle_points(35.0, 141.0, 34.0, -121.0, 12)  # Tokyo offing → California, across 180°
    return ship, wx, sail_route(np.column_stack([lat, lon]), wx, ship, departure=wx.time.values[0])


def test_route_map_and_profile_are_non_empty_pngs(tmp_path):
    ship, wx, route = _pacific_route()
    map_png = save_png(route_map_figure(route, wx, others={"same": route}), tmp_path / "map.png")
    prof_png = save_png(route_profile_figure(route, mcr_kw=ship.mcr_kw), tmp_path / "profile.png")
    for p in (map_png, prof_png):
        data = p.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
    assert sorted(x.name for x in tmp_path.iterdir()) == ["map.png", "profile.png"]  # no temp files left


def test_route_map_keeps_a_pacific_crossing_in_one_piece():
    _, wx, route = _pacific_route()
    fig = route_map_figure(route, wx)
    line = fig.axes[0].lines[0]
    x = np.asarray(line.get_xdata())
    assert np.all(np.abs(np.diff(x)) < 180.0)  # no jump at the antimeridian
