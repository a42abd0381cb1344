"""Sailing search (Życkowski): no-go legs never sailed, beating on the best VMG heading, exact manoeuvre counts."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyproj import Geod

from optroute import units
from optroute.errors import ConfigError, NoSafePassage, WeatherCoverageError, WeatherSchemaError
from optroute.physics.polar import Polar
from optroute.physics.yacht import SailingVessel
from optroute.search.routing import search_route
from optroute.search.sailing import GraphWind, SailingGraph, SailingGrid, search_sailing_route
from optroute.weather.schema import canonical_dataset

T0 = np.datetime64("2024-06-01T00:00", "ns")
CELL_DEG = 1.0 / 60.0  # 1 arc-minute cells on the equator: lattice diagonals head 045/315 to 1e-3 deg
# optroute sails on WGS84: one cell north and one lattice diagonal at the equator, by pyproj's Geod directly
# (Karney 2013); the diagonal heads 45.19 deg, not 45, since the meridian radius there is 0.67 % below the
# prime vertical's
_AZ, _, _DIAG_M = Geod(ellps="WGS84").inv(0.0, 0.0, CELL_DEG, CELL_DEG)
DIAG_NM, DIAG_DEG = _DIAG_M / 1852.0, float(_AZ)
NORTH_NM = Geod(ellps="WGS84").inv(0.0, 0.0, 0.0, CELL_DEG)[2] / 1852.0
# Beating polar (hand-made, kn): no-go below 40 deg; v(60) < 1.275 v(45), so no lattice heading beats 45 deg's VMG
BEAT_TWA = [0.0, 40.0, 45.0, 60.0, 90.0, 135.0, 180.0]
BEAT_TWS = [5.0, 10.0, 20.0]
BEAT_BSP = [[0, 0, 0], [2.0, 4.0, 5.0], [3.0, 6.0, 7.0], [3.3, 6.6, 7.7], [3.5, 7.0, 8.0], [3.0, 6.5, 8.0],
            [2.5, 5.0, 7.0]]  # fmt: skip


@pytest.fixture(scope="module")
def yacht() -> SailingVessel:
    return SailingVessel(Polar(BEAT_TWA, BEAT_TWS, BEAT_BSP, name="beater"), name="beater")


def _wind(u_ms, v_ms, times=(T0,), lat=(-0.2, 0.6), lon=(-0.3, 0.3), **attrs):
    lat_ax, lon_ax = np.linspace(*lat, 9), np.linspace(*lon, 7)
    return canonical_dataset(np.array(times, dtype="datetime64[ns]"), lat_ax, lon_ax,
                             {"wind_u_ms": u_ms, "wind_v_ms": v_ms},
                             attrs={"source": "test wind", "geography": "synthetic", **attrs})  # fmt: skip


@pytest.fixture(scope="module")
def north_wind():
    """A steady 10 kn northerly (from 000): the destination due north is dead upwind."""
    return _wind(0.0, -units.kn_to_ms(10.0))


@pytest.fixture(scope="module")
def beat_grid() -> SailingGrid:
    """19 rows north x 7 columns (±3 cells): 18 nm to windward with 3 nm either side."""
    return SailingGrid(np.arange(19) * CELL_DEG, np.arange(-3, 4) * CELL_DEG)


def _beat(yacht, wind, grid, **kw):
    return search_sailing_route((0.0, 0.0), (18 * CELL_DEG, 0.0), wind, yacht, departure=T0, grid=grid, **kw)


@pytest.mark.parametrize("directions", [8, 16, 32])
def test_dead_upwind_route_tacks_on_the_best_vmg_heading(yacht, north_wind, beat_grid, directions):
    """Hand-worked: every leg at |TWA| = 45 deg and T = 18 diagonal legs / v(45 deg, 10 kn) = 18·√2·1 nm / 6 kn."""
    r = _beat(yacht, north_wind, beat_grid, directions=directions)
    np.testing.assert_allclose(np.abs(r.twa_deg), DIAG_DEG, atol=1e-3)  # cos(lat) to 0.3 deg N
    assert r.passage_h == pytest.approx(18 * DIAG_NM / float(yacht.polar.speed_kn_at(DIAG_DEG, 10.0)), rel=1e-4)
    assert r.verify(north_wind, yacht)["ok"]
    assert all(m.kind == "tack" for m in r.manoeuvres)


def test_manoeuvre_penalty_reduces_the_tacks_to_the_hand_count(yacht, north_wind, beat_grid):
    """18 rows to windward, ±3 columns: at most 6 rows per board, 3 from the centre line → ω >= 18 / 6 = 3."""
    fast = _beat(yacht, north_wind, beat_grid, directions=16)
    few = _beat(yacht, north_wind, beat_grid, directions=16, objective="manoeuvres")
    weighted = _beat(yacht, north_wind, beat_grid, directions=16, objective="weighted", manoeuvre_penalty_h=0.1)
    assert few.n_manoeuvres == 3 and weighted.n_manoeuvres == 3
    assert fast.n_manoeuvres >= weighted.n_manoeuvres
    assert weighted.passage_h == pytest.approx(fast.passage_h, rel=1e-12)  # every all-diagonal beat takes as long
    assert weighted.front[0] == (3, pytest.approx(fast.passage_h, rel=1e-12))
    for r in (few, weighted):
        check = r.verify(north_wind, yacht)
        assert check["ok"] and check["manoeuvres"] == 3


@pytest.fixture(scope="module")
def veering():
    """Wind veering from 300 to 060 over 8 h and stronger to the east: time-dependent and spatially varying."""
    times = T0 + np.array([0, 2, 4, 6, 8], dtype="timedelta64[h]").astype("timedelta64[ns]")
    frm = np.radians(np.linspace(300.0, 420.0, 5))[:, None, None]
    spd = units.kn_to_ms(8.0 + 4.0 * np.linspace(0.0, 1.0, 7))[None, None, :]
    return _wind(-spd * np.sin(frm), -spd * np.cos(frm), times=times, lat=(-0.2, 0.6), lon=(-0.3, 0.3))


@pytest.mark.parametrize("directions", [8, 32])
def test_no_leg_lies_in_the_no_go_sector_brute_force(yacht, veering, directions):
    grid = SailingGrid.box(-0.1, 0.5, -0.2, 0.2, 25, 17)
    for end in ((0.3, 0.0), (0.3, 0.15), (-0.05, -0.15)):
        r = search_sailing_route((0.0, 0.0), end, veering, yacht, departure=T0, grid=grid, directions=directions)
        # every leg re-derived from the weather with the sampler: heading vs the wind met at its departure
        legs = zip(r.time[:-1], r.lat_deg[:-1], r.lon_deg[:-1], r.course_deg, strict=True)
        for t, la, lo, course in legs:
            tws, frm = _wind_at(veering, t, la, lo)
            twa = abs((frm - course + 180.0) % 360.0 - 180.0)
            assert twa >= yacht.polar.no_go_deg - 1e-9 and yacht.polar.speed_kn_at(twa, tws) > 0
        check = r.verify(veering, yacht)
        assert check["ok"], check


def _wind_at(ds, t, lat, lon):
    w = ds.interp(time=t, lat=lat, lon=lon)  # xarray's own linear interpolation, independent of the sampler
    u, v = float(w["wind_u_ms"]), float(w["wind_v_ms"])
    return units.ms_to_kn(np.hypot(u, v)), np.degrees(np.arctan2(-u, -v)) % 360.0


@settings(max_examples=8, deadline=None)
@given(st.floats(0.0, 359.0), st.floats(6.0, 18.0))
def test_more_headings_never_give_a_longer_passage(yacht, wind_from, tws):
    """The 8 offsets are a subset of the 16, which are of the 32: the least time can only fall (steady wind)."""
    rad = np.radians(wind_from)
    v = units.kn_to_ms(tws)
    wind = _wind(-v * np.sin(rad), -v * np.cos(rad))
    grid = SailingGrid.box(-0.1, 0.5, -0.2, 0.2, 13, 9)
    times = []
    for d in (8, 16, 32):
        try:
            times.append(search_sailing_route((0.0, -0.1), (0.4, 0.1), wind, yacht, departure=T0, grid=grid,
                                              directions=d).passage_h)  # fmt: skip
        except NoSafePassage:
            times.append(np.inf)
    assert times[2] <= times[1] + 1e-9 and times[1] <= times[0] + 1e-9


def test_search_route_takes_a_vessel_and_refuses_bad_input(yacht, north_wind, beat_grid):
    r = search_route((0.0, 0.0), (18 * CELL_DEG, 0.0), north_wind, vessel=yacht, departure=T0, directions=8,
                     sailing_grid=beat_grid)  # fmt: skip
    assert r.passage_h == pytest.approx(18 * DIAG_NM / float(yacht.polar.speed_kn_at(DIAG_DEG, 10.0)), rel=1e-4)
    with pytest.raises(WeatherSchemaError, match="no wind_u_ms"):
        search_route((0.0, 0.0), (0.3, 0.0), north_wind.drop_vars("wind_u_ms"), vessel=yacht, departure=T0,
                     cell_nm=1.0, margin_nm=3.0)  # fmt: skip
    with pytest.raises(ConfigError, match=r"above the polar's largest 20 kn"):
        search_route((0.0, 0.0), (0.3, 0.0), _wind(0.0, -units.kn_to_ms(30.0)), vessel=yacht, departure=T0,
                     cell_nm=1.0, margin_nm=3.0)  # fmt: skip
    with pytest.raises(ConfigError, match="manoeuvre_penalty_h"):
        _beat(yacht, north_wind, beat_grid, objective="weighted")


def test_a_passage_past_the_forecast_says_so(yacht, veering):
    grid = SailingGrid.box(-0.1, 0.5, -0.2, 0.2, 25, 17)
    late = veering.time.values[-1] - np.timedelta64(30, "m")
    with pytest.raises(WeatherCoverageError, match="after the weather's last time"):
        search_sailing_route((0.0, 0.0), (0.3, 0.0), veering, yacht, departure=late, grid=grid)
    held = veering.assign_attrs(time_policy="hold")
    r = search_sailing_route((0.0, 0.0), (0.3, 0.0), held, yacht, departure=late, grid=grid)
    assert r.verify(held, yacht)["ok"]


def test_calm_is_no_passage_unless_the_boat_motors(yacht, beat_grid):
    calm = _wind(0.0, 0.0)
    with pytest.raises(NoSafePassage, match="motoring_below_kn"):
        _beat(yacht, calm, beat_grid)
    motor = SailingVessel(yacht.polar, motoring_below_kn=2.0, motor_speed_kn=5.0)
    r = _beat(motor, calm, beat_grid, directions=8)
    assert r.passage_h == pytest.approx(18 * NORTH_NM / 5.0, rel=1e-4) and r.n_manoeuvres == 0
    assert r.motoring.all()


def test_refinement_moves_tack_points_and_stays_out_of_the_no_go_sector(yacht, north_wind, beat_grid):
    """Beating 18 nm dead upwind: refined < graph, ≥ the hand bound distance / best VMG, on the polar's beat angle."""
    from optroute.search.sailing_refine import refine_sailing_route

    graph = _beat(yacht, north_wind, beat_grid, directions=8, objective="manoeuvres")
    refined = refine_sailing_route(graph, north_wind, yacht, sub_nm=3.0, max_iter=15)
    beat_deg, vmg_kn, _, _ = yacht.polar.vmg_angles_deg(10.0)
    assert refined.stats["refinement"] == "refined" and refined.n_manoeuvres == graph.n_manoeuvres
    assert 18 * NORTH_NM / vmg_kn * (1 - 1e-6) <= refined.passage_h < graph.passage_h
    assert np.all(np.abs(refined.twa_deg) >= yacht.polar.no_go_deg) and refined.verify(north_wind, yacht)["ok"]
    np.testing.assert_allclose(np.abs(refined.twa_deg), beat_deg, atol=0.05)  # off the lattice: the polar's own


def test_wind_sampled_once_on_the_graph_gives_the_same_route(yacht, veering):
    graph = SailingGraph.build(SailingGrid.box(-0.1, 0.5, -0.2, 0.2, 13, 9), 16, use_land_mask=False)
    direct = search_sailing_route((0.0, 0.0), (0.3, 0.1), veering, yacht, departure=T0, grid=graph)
    wind = GraphWind.sample(graph, veering)
    again = search_sailing_route((0.0, 0.0), (0.3, 0.1), wind, yacht, departure=T0)
    np.testing.assert_array_equal(again.lat_deg, direct.lat_deg)
    assert again.passage_h == direct.passage_h
    other = SailingGraph.build(graph.grid, 8, use_land_mask=False)
    with pytest.raises(ConfigError, match="another graph"):
        search_sailing_route((0.0, 0.0), (0.3, 0.1), wind, yacht, departure=T0, grid=other)


def test_the_route_rounds_the_hel_peninsula(yacht):
    """From the paper's end point B (Gulf of Gdańsk) to open water north of Hel: the straight line crosses the
    peninsula's tip (GLOBE coastline), the route goes round it and no leg touches land (checked every 0.05 nm)."""
    from optroute.geo import land

    b, north = (54.52, 18.76), (54.75, 18.85)
    assert land.leg_crosses_land(*b, *north, 0.05, use_land_mask=True) is not None
    wind = _wind(units.kn_to_ms(10.0), 0.0, lat=(54.3, 55.0), lon=(18.4, 19.2), geography="real")  # from the west
    r = search_route(b, north, wind, vessel=yacht, departure=T0, directions=16, cell_nm=1.0, margin_nm=2.0)
    assert not land.legs_cross_land(r.lat_deg[:-1], r.lon_deg[:-1], r.lat_deg[1:], r.lon_deg[1:], 0.05,
                                    use_land_mask=True).any()  # fmt: skip
    assert r.lon_deg.max() > 18.81 and r.verify(wind, yacht)["ok"]
