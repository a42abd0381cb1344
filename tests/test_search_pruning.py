"""The search's exact pruning: the time limit (the weather's end) and the cost ceiling.

References: the search without the limit or the ceiling (the same route and
times where they do not bind, and no route either where the limit does); the bound recomputed
independently on every edge handed to the callback (WGS84 geodesic lengths
from :func:`optroute.geodesy.distance_nm` at ``v_max``); a weather file too
short for the great circle at the ship's top speed (hand-worked: 840 nm at
16 kn is 52 h, the file lasts 24 h).
"""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optroute import geodesy as geo
from optroute.errors import NoSafePassage, WeatherCoverageError
from optroute.search import RouteGrid, _kernels, compass, shortest_path
from optroute.search.dijkstra import TIME_LIMIT_SLACK_H
from optroute.search.routing import search_route
from tests.test_search_dijkstra import SpeedField
from tests.test_search_kernels import BOX, CARGO, T0, sea_fields

ENGINES = ["numpy", "numba"] if _kernels.AVAILABLE else ["numpy"]
V_MAX = 20.0


@pytest.fixture(scope="module")
def grid():
    return RouteGrid.build((10.0, 20.0), (12.0, 30.0), cell_nm=40.0, margin_nm=80.0)


class Recorder:
    """A cell-by-cell speed field that is no passage past ``end_h`` (as weather past its end), recording legs."""

    def __init__(self, seed, end_h):
        self.field, self.end_h = SpeedField(seed), end_h
        self.calls = 0

    def __call__(self, lat, lon, course, length, t):
        self.calls += 1
        dur, fuel, ok = self.field.piece_cost(lat, lon, course, length, t)
        return dur, fuel, ok & (t + dur <= self.end_h)


def _route(grid, cb, limit, objective, engine):
    kw = {"lambda_t_per_h": 0.5} if objective == "cost" else {}
    return shortest_path(grid, compass(16), segment_cost=cb, v_max_kn=V_MAX, objective=objective,
                         time_limit_h=limit, engine=engine, **kw)  # fmt: skip


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 500), spare_h=st.floats(0.0, 30.0), objective=st.sampled_from(["time", "cost"]),
       engine=st.sampled_from(ENGINES))  # fmt: skip
def test_limit_keeps_the_route_and_times_where_it_does_not_bind(grid, seed, spare_h, objective, engine):
    free = _route(grid, Recorder(seed, np.inf), None, objective, engine)
    end_h = free.arrival_h + spare_h
    cb = Recorder(seed, end_h)
    cut = _route(grid, cb, end_h, objective, engine)
    np.testing.assert_array_equal(cut.nodes, free.nodes)
    np.testing.assert_allclose(cut.times_h, free.times_h, rtol=0.0, atol=1e-9)
    assert cut.cost == pytest.approx(free.cost, rel=1e-12)
    assert cut.evaluated_edges <= free.evaluated_edges


class LegRecorder:
    """The whole-leg form of :class:`Recorder`: records every leg handed to it (departure and ends)."""

    def __init__(self, seed, end_h):
        self.field, self.end_h = SpeedField(seed), end_h
        self.legs = []

    def __call__(self, lat0, lon0, lat1, lon1, t0):
        self.legs.append(np.column_stack([lat0, lon0, lat1, lon1, t0]))
        dur, fuel, ok, _ = self.field.edge_cost(lat0, lon0, lat1, lon1, t0)
        return dur, fuel, ok & (t0 + dur <= self.end_h)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("objective", ["time", "cost"])
def test_binding_limit_fails_as_before_and_costs_only_legs_that_could_fit(grid, engine, objective):
    """Where the limit binds both searches find no route; the pruned one costs fewer legs, each able to fit."""
    kw = {"lambda_t_per_h": 0.5} if objective == "cost" else {}

    def run(cb, limit):
        return shortest_path(grid, compass(16), edge_cost=cb, v_max_kn=V_MAX, objective=objective,
                             time_limit_h=limit, engine=engine, **kw)  # fmt: skip

    end_h = run(LegRecorder(5, np.inf), None).arrival_h - 2.0
    free, cut = LegRecorder(5, end_h), LegRecorder(5, end_h)
    with pytest.raises(NoSafePassage):
        run(free, None)
    with pytest.raises(NoSafePassage):
        run(cut, end_h)
    legs = np.concatenate(cut.legs)
    assert legs.shape[0] < sum(leg.shape[0] for leg in free.legs)
    lat0, lon0, lat1, lon1, t0 = legs.T
    # departure + the leg + the rest to the end, at v_max over WGS84 lengths (the search's own length bound
    # may be shorter by the sphere-to-WGS84 factors, so this takes their ratio as the margin)
    rest = geo.distance_nm(lat0, lon0, lat1, lon1) + geo.distance_nm(lat1, lon1, *grid.end_latlon)
    earliest = t0 + rest * geo.SPHERE_TO_WGS84_MIN / geo.SPHERE_TO_WGS84_MAX * (1.0 - 1e-5) / V_MAX
    assert np.all(earliest <= end_h + TIME_LIMIT_SLACK_H)
    assert earliest.max() > end_h - 1.0  # the bound was tested near the limit, not far from it


def test_end_out_of_reach_before_the_weather_ends_raises_at_once(grid):
    cb = Recorder(1, 10.0)
    with pytest.raises(WeatherCoverageError, match=r"ends 10\.00 h after departure.* arrives \d+\.\d\d h"):
        _route(grid, cb, 10.0, "time", "numba" if _kernels.AVAILABLE else "numpy")
    assert cb.calls == 0


def test_search_route_names_the_weather_end_in_utc():
    ds = sea_fields(2, hours=24.0)  # BOX is about 840 nm: 52 h at 16 kn, past the file's 24 h
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(WeatherCoverageError, match=r"ends 24\.00 h after departure.*2024-03-02T00:00"):
            search_route(*BOX, ds, CARGO, departure=T0, cell_nm=60.0, objective="time")


# ------------------------------------------------------------------ the cost ceiling
@pytest.mark.parametrize("objective", ["time", "cost"])
def test_ceiling_above_the_cost_keeps_the_route_and_below_it_finds_none(grid, objective):
    free = _route(grid, Recorder(7, np.inf), None, objective, ENGINES[-1])
    kw = {"lambda_t_per_h": 0.5} if objective == "cost" else {}

    def run(ceiling):
        return shortest_path(grid, compass(16), segment_cost=Recorder(7, np.inf), v_max_kn=V_MAX,
                             objective=objective, cost_ceiling=ceiling, **kw)  # fmt: skip

    above = run(free.cost * (1.0 + 1e-9))
    np.testing.assert_array_equal(above.nodes, free.nodes)
    np.testing.assert_allclose(above.times_h, free.times_h, rtol=0.0, atol=1e-9)
    assert above.evaluated_edges <= free.evaluated_edges
    with pytest.raises(NoSafePassage, match="cheaper than the cost ceiling"):
        run(free.cost * (1.0 - 1e-9))
