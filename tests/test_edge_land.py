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
from optroute.search.edge_land import WALK_STEP_NM, EdgeLand, legs_on_land, on_land
from optroute.search.grid import RouteGrid, unit_xyz

DENSE_NM = 0.02


@pytest.fixture(scope="module")
def japan():
    grid = RouteGrid.build((33.0, 128.0), (35.5, 141.0), cell_nm=20.0)
    return grid, EdgeLand.build(grid)


def _walk(edge_land, a, b):
    bits, blocks, par = edge_land.walk.arrays()
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
    lo, hi = edge_land.walk.packed.lat_deg_bounds()
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


@settings(max_examples=40, deadline=None)
@given(
    region=st.sampled_from([(31.5, 36.5, 129.0, 140.0), (58.0, 70.0, 2.0, 20.0)]),
    u=st.floats(0.0, 1.0),
    v=st.floats(0.0, 1.0),
    course=st.floats(0.0, 360.0),
    length_nm=st.floats(1.0, 400.0),
)
def test_legs_on_land_finds_the_land_the_mask_has_on_long_legs(region, u, v, course, length_nm):
    """The 3-D DP's leg test (:func:`legs_on_land`, rows loaded for the legs themselves, their bulge included) on
    legs up to 400 nm, in southern Japan and along Norway's coast (where an east-west leg rises several nm
    above its ends): land it finds is on the leg, and a leg it calls clear has no stretch of land longer than
    the walk's step, against the mask every 0.02 nm."""
    lat = region[0] + u * (region[1] - region[0])
    lon = region[2] + v * (region[3] - region[2])
    b = geo.destination(lat, lon, course, length_nm)[:2]
    legs = (np.array([lat, lat]), np.array([lon, lon]), np.array([float(b[0]), lat]), np.array([float(b[1]), lon]))
    found = legs_on_land(*legs)
    assert found.shape == (2,) and found[1] == bool(land.is_land(np.array(lat), np.array(lon)))
    n = int(np.ceil(float(geo.distance_nm(lat, lon, *b)) / DENSE_NM)) + 1
    dense = land.is_land(*geo.great_circle_points(lat, lon, float(b[0]), float(b[1]), n))
    if found[0]:
        assert dense.any()
    else:
        run = np.diff(np.flatnonzero(np.diff(np.concatenate([[0], dense.astype(int), [0]]))))[::2]
        assert run.size == 0 or run.max() <= WALK_STEP_NM / DENSE_NM + 1


def test_legs_on_land_loads_the_rows_a_long_leg_rises_into():
    """An east-west leg of 317 nm across the open Norwegian Sea at 66° N rises about 8 nm above its ends: rows not
    loaded would count as land; it is clear, as the mask every 0.02 nm says, while a leg from it onto the coast
    at Bodø is not."""
    a, b = (66.0, -5.0), (66.0, 8.0)
    n = int(np.ceil(float(geo.distance_nm(*a, *b)) / DENSE_NM)) + 1
    lat, _ = geo.great_circle_points(*a, *b, n)
    assert lat.max() > 66.1 and not land.is_land(*geo.great_circle_points(*a, *b, n)).any()
    assert not legs_on_land(*(np.array([v]) for v in (*a, *b)))[0]  # alone: only its own rows are loaded
    assert legs_on_land(*(np.array([v]) for v in (*a, 67.28, 14.4)))[0]
