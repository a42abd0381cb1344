"""The fuel objective's static cost-to-go bound (:mod:`optroute.search.cost_bound`), the stronger A* heuristic.

References: the trilinear weather's
convex combinations sampled at random inside each block; and the search itself run without the bound (the
heuristic ρ × distance of :func:`optroute.physics.pointwise.least_cost_per_nm`), whose route's own cost from
each of its nodes to the end the bound may not exceed, and whose route the search with the bound must find.
"""

import warnings

import numpy as np
import pytest

import optroute as orx
from optroute.physics.performance import CalmWaterModel, KwonModel
from optroute.physics.pointwise import (
    P_FORM_DIV,
    P_FORM_LINEAR,
    P_V23,
    beaufort_from_hs,
    kwon_direction_coefficient,
    kwon_form_coefficient,
    point_params,
)
from optroute.physics.safety import BandRules
from optroute.search import cost_bound
from optroute.search.routing import search_route
from optroute.weather.sample import WeatherSampler
from tests.test_routing import OPEN_SEA, T0, random_sea

SHIP = orx.Ship.preset("container_8000teu")
START, END = (-8.0, 150.0), (10.0, 174.0)  # about 1 800 nm across random_sea's box


def _fields(wx):
    pw = WeatherSampler(wx).point_weather(T0)
    return pw, np.ascontiguousarray(pw.fields)


@pytest.mark.parametrize("current_ms", [0.0, 0.8])
def test_each_blocks_wind_speed_and_wave_direction_bound_random_convex_combinations_of_its_nodes(current_ms):
    """The trilinear weather is a convex combination of 8 nodes of a cell: random weights over random nodes of a
    block (any times) never give a wind slower than its bound nor a wave direction outside its cone."""
    wx = random_sea(3, hs_m=(1.0, 9.0), current_ms=current_ms)
    pw, fields = _fields(wx)
    nt, ny, nx = pw.time_s.size, pw.lat_deg.size, pw.lon_deg.size
    b = cost_bound.BLOCK_CELLS
    stats = cost_bound._block_stats(fields, nt, ny, nx, False, b)
    rng = np.random.default_rng(0)
    for by in range(stats.shape[0]):
        for bx in range(stats.shape[1]):
            s = stats[by, bx]
            ys = rng.integers(by * b, min(by * b + b, ny - 1) + 1, (200, 8))
            xs = rng.integers(bx * b, min(bx * b + b, nx - 1) + 1, (200, 8))
            ts = rng.integers(0, nt, (200, 8))
            rows = fields[(ts * ny + ys) * nx + xs]  # (200, 8, 9)
            wt = rng.dirichlet(np.full(8, 0.3), 200)[:, :, None]
            mix = (wt * rows).sum(axis=1)
            assert np.all(np.hypot(mix[:, 4], mix[:, 5]) >= s[0] * (1.0 - 1e-12))
            assert np.all(np.hypot(mix[:, 4], mix[:, 5]) <= s[1] * (1.0 + 1e-12))
            direction = np.degrees(np.arctan2(mix[:, 2], mix[:, 3]))
            off = np.abs((direction - s[5] + 180.0) % 360.0 - 180.0)
            if s[6] < 89.0:  # a cone narrower than a half plane (convex); wider, every angle counts
                assert np.all(off <= s[6] + 1e-9)
            assert np.all(np.hypot(mix[:, 6], mix[:, 7]) <= s[7] * (1.0 + 1e-12))


_COST_TO_GO = cost_bound.cost_to_go


class _Spy:
    """``cost_bound.cost_to_go`` recorded (or switched off): the bound of the last search and its grid."""

    def __init__(self, on: bool):
        self.on, self.h, self.grid = on, None, None

    def __call__(self, *args, **kw):
        if not self.on:
            return None
        self.grid, self.args = args[2], args
        self.bound = _COST_TO_GO(*args, **kw)
        self.h = self.bound.to_end_t
        return self.bound


def _search(monkeypatch, wx, lam, on):
    spy = _Spy(on)
    monkeypatch.setattr(cost_bound, "cost_to_go", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        route = search_route(START, END, wx, SHIP, departure=T0, objective="fuel", lambda_t_per_h=lam, cell_nm=40.0,
                             **OPEN_SEA)  # fmt: skip
    return route, spy


@pytest.mark.parametrize("seed, current_ms, lam", [(1, 0.0, 3.0), (2, 0.7, 1.0), (4, 0.0, 8.0)])
def test_the_bound_stays_below_the_routes_own_cost_from_each_of_its_nodes_and_the_search_finds_the_same_route(
    monkeypatch, seed, current_ms, lam
):
    wx = random_sea(seed, hs_m=(1.0, 9.0), current_ms=current_ms)
    plain, _ = _search(monkeypatch, wx, lam, on=False)
    bounded, spy = _search(monkeypatch, wx, lam, on=True)
    assert spy.h is not None
    # the plain route's cost from each of its nodes to the end, leg by leg
    cost = plain.fuel_t + lam * plain.duration_h
    rest = np.r_[np.cumsum(cost[::-1])[::-1], 0.0]
    grid = spy.grid
    nodes = grid.flat(*grid.nearest_node(plain.waypoints[:, 0], plain.waypoints[:, 1]))
    assert nodes[0] == grid.flat(*grid.start) and nodes[-1] == grid.flat(*grid.end)
    assert np.all(spy.h[nodes] <= rest * (1.0 + 1e-9) + 1e-9)
    assert spy.h[nodes[0]] > 0.0
    # each leg's own bound (the lazy key's) positive and below its cost
    offsets = [tuple(o) for o in np.asarray(spy.args[3])]
    ij = np.column_stack(grid.unflat(nodes))
    q = [offsets.index(tuple(d)) for d in np.diff(ij, axis=0)]
    legs = spy.bound.edge_t[nodes[:-1], q]
    assert np.all(legs <= cost * (1.0 + 1e-9)) and np.all(legs > 0.0)
    # the same route, found costing fewer edges
    np.testing.assert_array_equal(bounded.waypoints, plain.waypoints)
    assert bounded.cost == pytest.approx(plain.cost, rel=1e-12)
    assert bounded.stats["evaluated_edges"] <= plain.stats["evaluated_edges"]


def test_the_calm_water_model_has_no_loss_to_bound():
    wx = random_sea(1)
    pw = WeatherSampler(wx).point_weather(T0)
    params = point_params(SHIP, CalmWaterModel(SHIP), BandRules())
    assert cost_bound.cost_to_go(params, tuple(pw), None, np.zeros((1, 2), dtype=int), np.array([10.0]), 1.0) is None


def test_the_compiled_search_refuses_an_edge_floor_above_the_edges_cost(monkeypatch):
    """The whole-compiled search checks each costed edge against its own floor too."""

    def edge_too_high(params, weather, grid, offsets, speeds, lam):
        bound = _COST_TO_GO(params, weather, grid, offsets, speeds, lam)
        edge = bound.edge_t.copy()
        edge[grid.flat(*grid.start)] = 1e6  # no edge out of the start costs a million tonnes
        return cost_bound.CostBound(bound.to_end_t, edge)

    monkeypatch.setattr(cost_bound, "cost_to_go", edge_too_high)
    with warnings.catch_warnings(), pytest.raises(orx.ConfigError, match="edge_cost_floor"):
        warnings.simplefilter("ignore")
        search_route(START, END, random_sea(1), SHIP, departure=T0, objective="fuel", lambda_t_per_h=3.0, cell_nm=40.0,
                     **OPEN_SEA)  # fmt: skip


def test_the_compiled_search_refuses_a_bound_that_drops_by_more_than_an_edge_costs(monkeypatch):
    """The whole-compiled search (the physics' leg kernel) checks each costed edge against the heuristic."""

    def too_high(params, weather, grid, offsets, speeds, lam):
        h = np.zeros(grid.n_nodes)
        h[grid.flat(*grid.start)] = 1e6  # no edge out of the start costs a million tonnes
        return cost_bound.CostBound(h, np.zeros((grid.n_nodes, len(offsets))))

    monkeypatch.setattr(cost_bound, "cost_to_go", too_high)
    with warnings.catch_warnings(), pytest.raises(orx.ConfigError, match="cost_to_go"):
        warnings.simplefilter("ignore")
        search_route(START, END, random_sea(1), SHIP, departure=T0, objective="fuel", lambda_t_per_h=3.0, cell_nm=40.0,
                     **OPEN_SEA)  # fmt: skip


def test_a_block_where_some_corners_lack_the_wind_counts_both_the_winds_beaufort_number_and_that_of_hs():
    """Hs 6 m everywhere (Beaufort 8 by Hs), the wind calm where known and unknown at one node: the points next to that
    node take Beaufort 8 from Hs, the others Beaufort 0 from the calm wind, so the loss floor is Beaufort 0's, zero;
    where every node lacks the wind, Beaufort 8's: head seas' C_β times C_Form(8), by hand."""
    params = point_params(SHIP, KwonModel(SHIP), BandRules())
    nt, ny, nx = 2, 3, 3
    fields = np.zeros((nt * ny * nx, 9))
    fields[:, 0], fields[:, 1], fields[:, 3] = 6.0, 10.0, 1.0  # Hs, period, waves from the north
    fields[4, 4:6] = np.nan  # one node without the wind
    stats = cost_bound._block_stats(fields, nt, ny, nx, False, 4)
    assert stats[0, 0, 1] == 0.0 and stats[0, 0, 2] == 1.0
    assert np.all(cost_bound._loss_floors(params, stats, 0.0) == 0.0)
    fields[:, 4:6] = np.nan
    stats = cost_bound._block_stats(fields, nt, ny, nx, False, 4)
    assert stats[0, 0, 1] == -1.0
    head = cost_bound._loss_floors(params, stats, 0.0)[0, 0, 0]  # heading north into waves from the north
    bn = beaufort_from_hs(6.0)
    form = kwon_form_coefficient(bn, params[P_FORM_LINEAR], params[P_FORM_DIV], params[P_V23])
    assert head == pytest.approx(kwon_direction_coefficient(0.0, bn) * form / 100.0, rel=1e-12) and head > 0.0


def test_the_bound_at_another_lambda_from_the_kept_edge_floors_equals_one_built_afresh(monkeypatch):
    """A λ bisection asks the same grid at many λ: the edge floors are kept per grid, and the bound they give at a
    second λ is the one a fresh build gives, to the last bit."""
    _, spy = _search(monkeypatch, random_sea(2, current_ms=0.7), 1.0, on=True)
    args = spy.args[:5]  # the search's model, weather, grid, neighbourhood and speeds
    first = _COST_TO_GO(*args, 1.0)
    again = _COST_TO_GO(*args, 4.0)  # from the kept floors
    cost_bound._PREPARED.clear()
    fresh = _COST_TO_GO(*args, 4.0)
    for a, b in ((first, spy.bound), (again, fresh)):
        np.testing.assert_array_equal(a.to_end_t, b.to_end_t)
        np.testing.assert_array_equal(a.edge_t, b.edge_t)
    assert not np.array_equal(first.to_end_t, again.to_end_t)
