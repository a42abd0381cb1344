"""The grid search's coastline walk between nodes (optroute.search.edge_land).

References: the GLOBE mask's own point look-up (:func:`optroute.geo.land.is_land`) at points every 0.02 nm of
each leg's great circle (:func:`optroute.geodesy.great_circle_points`), and at random points of a grid's cells;
southern Japan (Kyushu to the Izu peninsula), where islands, straits and peninsulas lie between 20 nm nodes.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optroute import geodesy as geo
from optroute.geo import land
from optroute.search.edge_land import WALK_STEP_NM, EdgeLand, on_land
from optroute.search.grid import RouteGrid, unit_xyz

DENSE_NM = 0.02


@pytest.fixture(scope="module")
def japan():
    grid = RouteGrid.build((33.0, 128.0), (35.5, 141.0), cell_nm=20.0)
    return grid, EdgeLand.build(grid)


def _walk(edge_land, a, b):
    bits, blocks, par = edge_land.walk_arrays()
    return bool(on_land(unit_xyz(np.array(a[0]), np.array(a[1])), unit_xyz(np.array(b[0]), np.array(b[1])), bits,
                        blocks, par))  # fmt: skip


@settings(max_examples=60, deadline=None)
@given(
    lat=st.floats(31.5, 36.5),
    lon=st.floats(129.0, 140.0),
    course=st.floats(0.0, 360.0),
    length_nm=st.floats(1.0, 150.0),
)
def test_the_walk_finds_the_land_the_mask_has_on_a_leg(japan, lat, lon, course, length_nm):
    """Land found by the walk is land of the mask on the leg, and a leg the walk calls clear has no stretch of
    land longer than its step (0.1 nm: at most 0.1 / 0.02 + 1 dense points)."""
    _, edge_land = japan
    a = (lat, lon)
    b = tuple(float(v) for v in geo.destination(lat, lon, course, length_nm)[:2])
    lo, hi = edge_land.packed.lat_deg_bounds()
    if not (lo < min(a[0], b[0]) and max(a[0], b[0]) < hi):
        return  # outside the rows loaded for the grid (counted as land there by design)
    n = int(np.ceil(float(geo.distance_nm(*a, *b)) / DENSE_NM)) + 1
    dense = int(land.is_land(*geo.great_circle_points(*a, *b, n)).sum())
    if _walk(edge_land, a, b):
        assert dense > 0
    else:
        assert dense <= WALK_STEP_NM / DENSE_NM + 1


def test_every_land_point_of_the_grid_lies_in_a_coastal_cell(japan):
    """The cells flagged coastal hold all the land of the grid: random points of every cell, looked up in the
    mask, land only in coastal cells; and open-ocean cells are not flagged wholesale."""
    grid, edge_land = japan
    rng = np.random.default_rng(7)
    ny, nx = grid.shape
    i = rng.integers(0, ny, 200_000)
    j = rng.integers(0, nx, 200_000)
    fi, fj = i + rng.uniform(-0.5, 0.5, i.size), j + rng.uniform(-0.5, 0.5, j.size)
    lat, lon = grid.xy_to_latlon(*grid.node_xy_nm(fi, fj))
    on = land.is_land(lat, lon)
    assert on.any() and (~on).any()
    assert edge_land.coastal[i[on], j[on]].all()
    assert not edge_land.coastal.all()


def test_a_leg_over_the_kanmon_strait_land_and_one_at_sea():
    """Hand-picked: a leg from the Sea of Japan to the Seto Inland Sea across Honshu's western tip is on land;
    one along the open Pacific south of Shikoku is not."""
    grid = RouteGrid.build((34.5, 130.0), (32.5, 134.0), cell_nm=20.0)
    edge_land = EdgeLand.build(grid)
    assert _walk(edge_land, (34.3, 130.6), (33.8, 131.6))
    assert not land.is_land(np.array([32.6, 32.6]), np.array([132.6, 134.0])).any()
    assert not _walk(edge_land, (32.6, 132.6), (32.6, 134.0))
