"""The fuel objective's λ bisection stopped at the track (``stop_at_track``, as :func:`optroute.plan_voyage` runs it).

Reference: the textbook bisection written out here — λ = 0, then 1, 4, 16 … until a route is in
time, then 12 halvings — over the public search at a fixed λ (``search_route(lambda_t_per_h=λ)``; a
round is late when it raises :class:`InfeasibleETA` or :class:`NoSafePassage`, or arrives after the
deadline).  The stopped bisection must give the same track (waypoints, cell by cell) with fewer
searches, counted; the full one (the default) the reference's route and λ exactly.  Its calm-speed rule is
checked against the bisection without it on a model of rounds, and the calm-water speed against the
referee's speeds evaluated one by one. The bisection on a coarser grid first (``lambda_cell_nm``,
:func:`~optroute.search.objective_search.bisect_on_coarse`) is checked against the plain bisection on models of
both grids' rounds, and its route against the fixed-λ search at the λ it reports.  The deadlines are
an ETA and, without one, the weather's end (a forecast shorter than the least-fuel passage).
"""

import warnings

import numpy as np
import pytest

from optroute import geodesy as geo
from optroute.errors import ConfigError, InfeasibleETA, NoSafePassage
from optroute.physics.passage import SeaState, evaluate_speeds
from optroute.physics.performance import KwonModel
from optroute.physics.safety import BandRules
from optroute.search.objective_search import bisect_lambda, bisect_on_coarse
from optroute.search.passage_physics import PassagePhysics
from optroute.search.routing import LAMBDA_CELL_MAX_NM, LAMBDA_CELLS_ALONG, _lambda_cell_nm, search_route
from optroute.weather import WeatherSampler
from tests.test_routing import CARGO, OPEN_SEA, T0, _h, random_sea

START, END = (0.0, 152.0), (1.0, 158.0)
KW = dict(departure=T0, cell_nm=40.0, directions=16, **OPEN_SEA)  # a small graph: ~15 searches per bisection


def _search(wx, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ports snapped to open water
        return search_route(START, END, wx, CARGO, **KW, **kw)


def _reference(wx, eta, deadline_h):
    """The textbook bisection over fixed-λ searches: (route of the least in-time λ found, that λ, searches)."""
    rounds = []

    def attempt(lam):
        rounds.append(lam)
        try:
            r = _search(wx, objective="fuel", lambda_t_per_h=lam, eta=eta)
        except (InfeasibleETA, NoSafePassage):
            return None
        return None if r.total_duration_h > deadline_h else r

    best = attempt(0.0)
    if best is not None:
        return best, 0.0, len(rounds)
    lo, hi = 0.0, 1.0
    best = attempt(hi)
    while best is None:
        lo, hi = hi, 4.0 * hi
        best = attempt(hi)
    for _ in range(12):
        mid = 0.5 * (lo + hi)
        r = attempt(mid)
        if r is None:
            lo = mid
        else:
            hi, best = mid, r
    return best, hi, len(rounds)


@pytest.fixture(scope="module")
def fastest():
    return _search(random_sea(5, hs_m=(1.0, 5.0)))


@pytest.mark.parametrize("deadline", ["eta+4h", "eta+15h", "weather 36h"])
def test_stopping_at_the_track_keeps_the_track_of_the_full_bisection(fastest, deadline):
    if deadline.startswith("eta"):
        wx = random_sea(5, hs_m=(1.0, 5.0))
        eta = fastest.arrival + _h(float(deadline[4:-1]))
        deadline_h = fastest.total_duration_h + float(deadline[4:-1])
    else:  # no ETA: the forecast ends before the least-fuel passage (43 h) but after the fastest (26 h)
        wx = random_sea(5, hs_m=(1.0, 5.0), hours=36.0)
        eta, deadline_h = None, 36.0
    ref, ref_lam, ref_searches = _reference(wx, eta, deadline_h)
    assert ref_lam > 0.0  # the deadline binds: the bisection ran
    full = _search(wx, objective="fuel", eta=eta)
    stopped = _search(wx, objective="fuel", eta=eta, stop_at_track=True)
    # the default is the reference, round for round
    np.testing.assert_array_equal(full.waypoints, ref.waypoints)
    assert full.stats["lambda_t_per_h"] == ref_lam
    assert full.total_fuel_t == ref.total_fuel_t
    assert full.stats["searches"] == ref_searches
    # stopped at the track: the same waypoints, in time, in fewer searches, at a λ no lower than the reference's
    np.testing.assert_array_equal(stopped.waypoints, ref.waypoints)
    assert stopped.total_duration_h <= deadline_h
    assert stopped.stats["searches"] < ref_searches
    assert stopped.stats["lambda_t_per_h"] >= ref_lam


# ------------------------------------------------------------------ the calm-speed rule (bisect_lambda)
def _calm_kn(lam):
    """A calm-water speed that steps up by 0.5 kn at λ = 2.9, 3.2, 3.5, … (as a speed set's choice does)."""
    return 13.0 + 0.5 * max(0.0, np.floor((lam - 2.6) / 0.3))


class _Round:
    """A fixed-λ round's result as bisect_lambda reads it: 40 h earlier per knot of calm speed, 2 h per unit of λ."""

    def __init__(self, lam):
        self.arrival_h = 400.0 - 40.0 * (_calm_kn(lam) - 13.0) - 2.0 * lam
        self.total_fuel_t = 100.0 + 20.0 * lam
        self.nodes = np.array([[int(lam >= 3.3)]])  # the track changes at λ = 3.3


@pytest.mark.parametrize("eta_h", [370.0, 385.0, 397.0])
def test_a_lambda_sailing_no_faster_than_a_late_lambda_zero_is_taken_late_unsearched(eta_h):
    """The rule against the bisection without it (the same rounds): the same λ and track where every λ of λ = 0's
    calm speed is late (ETA 370 h, 385 h), fewer searches, and only λs of λ = 0's calm speed skipped; where such a λ
    is in time (ETA 397 h: λ = 1.5 arrives at 397 h), the λ found is the next calm speed's, higher, and in time."""

    def search(calm):
        ran = []

        def run(lam, ceiling=None):
            ran.append(lam)
            return _Round(lam)

        best, lam = bisect_lambda(run, eta_h, np.datetime64("2024-01-01"), stop_at_track=True, calm_speed_kn=calm)
        return best, lam, ran

    ref, ref_lam, ref_ran = search(None)
    best, lam, ran = search(_calm_kn)
    assert all(_calm_kn(x) > _calm_kn(0.0) for x in ran[1:])  # every λ searched after λ = 0 sails faster in calm
    assert set(ran) <= set(ref_ran) or eta_h == 397.0
    if eta_h < 397.0:
        assert lam == ref_lam and best.nodes.tolist() == ref.nodes.tolist()
        assert len(ran) < len(ref_ran)
    else:
        assert ref_lam < 2.9 <= lam and best.arrival_h <= eta_h


def test_calm_cheapest_speed_is_the_least_cost_per_mile_of_the_set_in_calm_water():
    """Against the referee's speeds evaluated one by one in a calm sea (numpy engine), the least (fuel + λ) / SOG."""
    speeds = np.arange(5.0, 16.01, 0.5)
    ph = PassagePhysics(CARGO, KwonModel(CARGO), BandRules(), WeatherSampler(random_sea(5)), T0)
    zero, one = np.zeros(speeds.size), np.ones(speeds.size)
    calm = SeaState(zero, one, zero, zero, zero, zero, zero)
    _, sog, _, fuel, allowed = evaluate_speeds(CARGO, KwonModel(CARGO), BandRules(), zero, calm, speeds, engine="numpy")
    chosen = set()
    for lam in (0.0, 0.5, 2.0, 8.0, 50.0):
        rate = np.where(allowed, (fuel + lam) / sog, np.inf)
        chosen.add(ph.calm_cheapest_speed_kn(speeds, lam))
        assert ph.calm_cheapest_speed_kn(speeds, lam) == speeds[int(np.argmin(rate))]
    assert len(chosen) >= 3  # λ moves the choice


# ------------------------------------------------------------------ λ bisected on a coarser grid (bisect_on_coarse)
class _GridRound:
    """A round of a grid whose routes arrive ``late_h`` after :class:`_Round`'s (a coarser or finer grid)."""

    def __init__(self, lam, late_h):
        base = _Round(lam)
        self.arrival_h, self.total_fuel_t, self.nodes = base.arrival_h + late_h, base.total_fuel_t, base.nodes


def _grid(late_h, ran, fails=False):
    def run(lam, ceiling=None):
        ran.append(lam)
        if fails:
            raise NoSafePassage("no passage between this grid's cells")
        return _GridRound(lam, late_h)

    return run


@pytest.mark.parametrize(
    "fine_late_h, coarse_fails", [(-3.0, False), (0.0, False), (12.0, False), (0.0, True)], ids=["fine earlier",
    "same", "fine later", "coarse finds none"]
)  # fmt: skip
def test_a_coarse_grids_lambda_is_searched_once_on_the_route_grid_and_bisected_there_only_when_late(
    fine_late_h, coarse_fails
):
    """Against :func:`bisect_lambda` run on each model grid alone (ETA 385 h): the coarse grid's λ where the route's
    own grid's route at it is in time, after one search there; otherwise exactly the route grid's own bisection,
    its rounds after the one at the coarse λ."""
    t0, eta_h = np.datetime64("2024-01-01"), 385.0
    coarse_alone, fine_alone = [], []
    if not coarse_fails:
        _, lam_coarse = bisect_lambda(_grid(0.0, coarse_alone), eta_h, t0, stop_at_track=True)
    else:
        with pytest.raises(NoSafePassage):
            bisect_lambda(_grid(0.0, coarse_alone, fails=True), eta_h, t0, stop_at_track=True)
    ref, ref_lam = bisect_lambda(_grid(fine_late_h, fine_alone), eta_h, t0, stop_at_track=True)
    coarse, fine = [], []
    best, lam = bisect_on_coarse(_grid(fine_late_h, fine), _grid(0.0, coarse, coarse_fails), eta_h, t0)
    assert coarse == coarse_alone
    if not coarse_fails and _GridRound(lam_coarse, fine_late_h).arrival_h <= eta_h:
        assert lam == lam_coarse and fine == [lam_coarse] and best.arrival_h <= eta_h  # one round on the route grid
    else:
        assert (lam, best.arrival_h, best.nodes.tolist()) == (ref_lam, ref.arrival_h, ref.nodes.tolist())
        assert fine == ([lam_coarse] if not coarse_fails else []) + fine_alone


def test_the_lambda_grid_has_forty_cells_along_the_great_circle_at_most_120_nm_and_only_where_twice_as_coarse():
    """The rule of ``search_route``'s default, worked by hand on WGS84 distances (geodesy)."""
    sd, tokyo = (32.6, -117.4), (35.2, 140.0)
    d = float(geo.distance_nm(*sd, *tokyo))  # about 4 800 nm
    assert LAMBDA_CELLS_ALONG == 40 and LAMBDA_CELL_MAX_NM == 120.0
    assert _lambda_cell_nm(None, 20.0, sd, tokyo) == 120.0 == min(120.0, d / 40.0)
    short = (32.6, -117.4), (33.0, -135.0)  # about 890 nm: 22 nm cells, not twice 20
    assert _lambda_cell_nm(None, 20.0, *short) == 20.0
    assert _lambda_cell_nm(None, 10.0, *short) == pytest.approx(float(geo.distance_nm(*short[0], *short[1])) / 40.0)
    assert _lambda_cell_nm(60.0, 20.0, *short) == 60.0  # given: used as it is
    assert _lambda_cell_nm(10.0, 20.0, *short) == 20.0  # finer than the route's grid: the route's own


def test_a_route_whose_lambda_was_bisected_on_a_coarser_grid_is_the_fixed_lambda_search_at_that_lambda():
    """On a random sea with an ETA: the λ bisected on 40 nm cells, then the 20 nm grid's route; that route is the
    fixed-λ search at the reported λ (the independent reference), in time, and the rounds of both grids are
    counted. ``lambda_cell_nm`` = the route's own cell bisects there as before (no coarse round)."""
    wx = random_sea(5, hs_m=(1.0, 5.0))
    kw = dict(KW, cell_nm=20.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fastest = search_route(START, END, wx, CARGO, **kw)
        eta = fastest.arrival + _h(6.0)
        route = search_route(START, END, wx, CARGO, **kw, objective="fuel", eta=eta, stop_at_track=True,
                             lambda_cell_nm=40.0)  # fmt: skip
        lam = route.stats["lambda_t_per_h"]
        fixed = search_route(START, END, wx, CARGO, **kw, objective="fuel", eta=eta, lambda_t_per_h=lam)
        own = search_route(START, END, wx, CARGO, **kw, objective="fuel", eta=eta, stop_at_track=True)
    assert lam > 0.0 and route.arrival <= eta
    np.testing.assert_array_equal(route.waypoints, fixed.waypoints)
    assert route.total_fuel_t == fixed.total_fuel_t
    assert route.stats["lambda_cell_nm"] == 40.0 and route.stats["coarse_searches"] >= 2
    assert route.stats["searches"] == route.stats["coarse_searches"] + 1
    assert own.stats["lambda_cell_nm"] == 20.0 and own.stats["coarse_searches"] == 0


@pytest.mark.parametrize("bad", [0.0, -20.0, float("nan")])
def test_a_lambda_cell_that_is_no_length_is_refused_naming_it_and_the_fix(bad):
    with pytest.raises(ConfigError, match=r"lambda_cell_nm .*got .*give the cell \[nm\]"):
        _search(random_sea(5, hs_m=(1.0, 5.0)), objective="fuel", stop_at_track=True, lambda_cell_nm=bad)
