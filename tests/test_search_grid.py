"""The gnomonic route grid and the supercover cell walk, against independent geometry."""

import numpy as np
import pytest

from optroute import geodesy as geo
from optroute.errors import ConfigError
from optroute.search import RouteGrid, segment_cells

SAN_DIEGO = (32.7, -117.2)
TOKYO = (35.6, 139.8)


def _cross_track_nm(lat, lon, a, b):
    """Cross-track distance from the sphere's great circle a→b, on which the gnomonic grid is laid (aviation formulary)."""
    d13 = geo.sphere_distance_nm(a[0], a[1], lat, lon) / geo.EARTH_RADIUS_NM
    t13 = np.radians(geo.sphere_initial_course_deg(a[0], a[1], lat, lon))
    t12 = np.radians(geo.sphere_initial_course_deg(a[0], a[1], b[0], b[1]))
    return geo.EARTH_RADIUS_NM * np.arcsin(np.sin(d13) * np.sin(t13 - t12))


@pytest.fixture(scope="module")
def pacific():
    return RouteGrid.build(SAN_DIEGO, TOKYO, cell_nm=40.0, margin_nm=400.0)


def test_start_and_end_are_exact_nodes_and_the_cell_is_barely_adjusted(pacific):
    g = pacific
    assert (g.lat_deg[g.start], g.lon_deg[g.start]) == pytest.approx(SAN_DIEGO, abs=1e-12)
    assert (g.lat_deg[g.end], g.lon_deg[g.end]) == pytest.approx(TOKYO, abs=1e-12)
    assert g.start[0] == g.end[0]  # route_angle 0: the great circle is a grid row
    n_cells = g.end[1] - g.start[1]
    assert abs(g.cell_nm - 40.0) * n_cells <= 0.5 * 40.0 + 1e-9


def test_the_start_row_is_the_great_circle_and_the_grid_crosses_the_antimeridian(pacific):
    g = pacific
    i = g.start[0]
    cols = np.arange(g.start[1], g.end[1] + 1)
    xt = _cross_track_nm(g.lat_deg[i, cols], g.lon_deg[i, cols], SAN_DIEGO, TOKYO)
    assert np.abs(xt).max() < 1e-6
    assert np.all((g.lon_deg >= -180.0) & (g.lon_deg < 180.0))
    assert g.lon_deg[i, cols].min() < -170.0 and g.lon_deg[i, cols].max() > 170.0


def test_any_grid_row_or_column_is_a_great_circle(pacific):
    g = pacific
    for line_lat, line_lon in ((g.lat_deg[3, :], g.lon_deg[3, :]), (g.lat_deg[:, 50], g.lon_deg[:, 50])):
        a, b = (line_lat[0], line_lon[0]), (line_lat[-1], line_lon[-1])
        assert np.abs(_cross_track_nm(line_lat, line_lon, a, b)).max() < 1e-6


def test_xy_latlon_round_trip_and_nearest_node(pacific):
    g = pacific
    rng = np.random.default_rng(1)
    i = rng.integers(0, g.ny, 50)
    j = rng.integers(0, g.nx, 50)
    x, y = g.node_xy_nm(i, j)
    lat, lon = g.xy_to_latlon(x, y)
    np.testing.assert_allclose(lat, g.lat_deg[i, j], atol=1e-9)
    np.testing.assert_allclose(np.mod(lon - g.lon_deg[i, j] + 180, 360) - 180, 0.0, atol=1e-9)
    x2, y2 = g.latlon_to_xy(lat, lon)
    np.testing.assert_allclose(x2, x, atol=1e-6)
    np.testing.assert_allclose(y2, y, atol=1e-6)
    ii, jj = g.nearest_node(lat, lon)
    np.testing.assert_array_equal(ii, i)
    np.testing.assert_array_equal(jj, j)


def test_route_angle_puts_the_end_on_a_lattice_point_in_that_direction():
    g = RouteGrid.build(SAN_DIEGO, TOKYO, cell_nm=40.0, margin_nm=100.0, route_angle_deg=22.5)
    di, dj = g.end[0] - g.start[0], g.end[1] - g.start[1]
    assert np.degrees(np.arctan2(di, dj)) == pytest.approx(22.5, abs=0.5)
    assert (g.lat_deg[g.end], g.lon_deg[g.end]) == pytest.approx(TOKYO, abs=1e-12)


def test_navigable_callable_and_its_errors():
    g = RouteGrid.build((0.0, 0.0), (0.0, 10.0), cell_nm=30.0, margin_nm=60.0, navigable=lambda la, lo: lo < 5.0)
    assert g.navigable[g.start] and not g.navigable[g.end]
    g2 = g.with_navigable(np.ones(g.shape, dtype=bool))
    assert g2.navigable.all()
    with pytest.raises(ConfigError, match="shape"):
        RouteGrid.build((0.0, 0.0), (0.0, 10.0), cell_nm=30.0, navigable=lambda la, lo: np.ones(3, dtype=bool))
    with pytest.raises(ConfigError, match="bool"):
        RouteGrid.build((0.0, 0.0), (0.0, 10.0), cell_nm=30.0, navigable=lambda la, lo: la * 0.0)
    with pytest.raises(ConfigError, match="does not contain"):
        RouteGrid.build((0.0, 0.0), (0.0, 10.0), cell_nm=30.0, extent_nm=(0.0, 100.0, -50.0, 50.0))
    with pytest.raises(ConfigError, match="cell_nm"):
        RouteGrid.build((0.0, 0.0), (0.0, 10.0), cell_nm=-1.0)
    with pytest.raises(ConfigError, match="split the voyage"):
        RouteGrid.build((0.0, 0.0), (0.0, 179.0), cell_nm=30.0)


def _clip_fractions(di, dj, ci, cj):
    """Liang–Barsky: the fraction interval of the segment (0,0)→(dj,di) inside the closed unit square at (cj, ci)."""
    lo, hi = 0.0, 1.0
    for p, q0, q1 in ((dj, cj - 0.5, cj + 0.5), (di, ci - 0.5, ci + 0.5)):
        if p == 0:
            if not (q0 <= 0.0 <= q1):
                return None
            continue
        a, b = sorted((q0 / p, q1 / p))
        lo, hi = max(lo, a), min(hi, b)
    return (lo, hi) if lo <= hi + 1e-12 else None


@pytest.mark.parametrize("di,dj", [(0, 1), (1, 1), (1, 2), (-2, 5), (3, -3), (5, 12), (-7, -4), (12, 1), (0, -5)])
def test_segment_cells_is_the_closed_supercover(di, dj):
    cells, f0, f1 = segment_cells(di, dj)
    got = {tuple(c) for c in cells}
    ref = {}
    for ci in range(min(0, di) - 1, max(0, di) + 2):
        for cj in range(min(0, dj) - 1, max(0, dj) + 2):
            iv = _clip_fractions(di, dj, ci, cj)
            if iv is not None:
                ref[(ci, cj)] = iv
    assert got == set(ref)
    for c, a, b in zip(cells, f0, f1, strict=True):
        assert (a, b) == pytest.approx(ref[tuple(c)], abs=1e-12)
    assert np.sum(f1 - f0) == pytest.approx(1.0)
    assert np.all(np.diff(f0) >= 0)  # in the order sailed
