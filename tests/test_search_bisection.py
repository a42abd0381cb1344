"""The fuel objective's λ bisection stopped at the track (``stop_at_track``, as :func:`optroute.plan_voyage` runs it).

Reference: the textbook bisection written out here — λ = 0, then 1, 4, 16 … until a route is in
time, then 12 halvings — over the public search at a fixed λ (``search_route(lambda_t_per_h=λ)``; a
round is late when it raises :class:`InfeasibleETA` or :class:`NoSafePassage`, or arrives after the
deadline).  The stopped bisection must give the same track (waypoints, cell by cell) with fewer
searches, counted; the full one (the default) the reference's route and λ exactly.  The deadlines are
an ETA and, without one, the weather's end (a forecast shorter than the least-fuel passage).
"""

import warnings

import numpy as np
import pytest

from optroute.errors import InfeasibleETA, NoSafePassage
from optroute.search.routing import search_route
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
