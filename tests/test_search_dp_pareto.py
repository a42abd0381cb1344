"""The DP's Pareto labels per arrival-time bin: never worse than any path on its lattice, at any bin width.

With one label per (stage, lateral, bin) a cheaper but later label wins the bin and the path that,
continued, arrives by the ETA is lost (Shao et al.'s case II at 240 h: 1 140.7 t against 1 140.1 t
for the DP's own constant-speed candidate).  With costs that do not depend on the time a leg is
sailed, dominance on (fuel, time) is exact, so the DP's fuel-versus-ETA curve equals brute-force
enumeration of every path at every bin end, whatever the bin width.
"""

import itertools

import numpy as np
import pytest

from optroute import geodesy as geo
from optroute.errors import ConfigError
from optroute.search import solve_dp

K = 1e-4
START, END = (0.0, 0.0), (0.0, 20.0)
SPEEDS = np.array([10.0, 13.0, 17.0, 22.0])


def _lateral_cost(lat0, lon0, lat1, lon1, t0, sog):
    """Cubic fuel law (k d³ / t²), rougher north of the great circle; no dependence on the time sailed."""
    d = geo.distance_nm(lat0, lon0, lat1, lon1)
    t = d / sog
    rough = 1.0 + 0.3 * ((lat0 + lat1) > 0.1) + 0.05 * np.cos(3.0 * lon1)
    return t, K * d**3 / t**2 * rough, np.ones(d.shape, dtype=bool)


def _brute_force(r):
    """(arrival [h], fuel [t]) of every path on the DP's lattice (3 laterals, 3 legs, 4 speeds)."""
    lat, lon = r.stage_lat_deg, r.stage_lon_deg
    n_st = lat.shape[0] - 1
    out = []
    for lats in itertools.product(range(lat.shape[1]), repeat=n_st - 1):
        path = (lat.shape[1] // 2, *lats, lat.shape[1] // 2)
        for vs in itertools.product(SPEEDS, repeat=n_st):
            a, b = np.array(path[:-1]), np.array(path[1:])
            ks = np.arange(n_st)
            dur, fu, _ = _lateral_cost(lat[ks, a], lon[ks, a], lat[ks + 1, b], lon[ks + 1, b], np.zeros(n_st),
                                       np.array(vs))  # fmt: skip
            out.append((float(dur.sum()), float(fu.sum())))
    return np.array(out)


@pytest.mark.parametrize("dt_h", [0.5, 5.0, 20.0])
def test_curve_equals_brute_force_at_every_bin_end_with_pareto_labels(dt_h):
    kw = dict(dx_nm=450, dy_nm=60, half_width_nm=60, speeds_kn=SPEEDS, dt_h=dt_h, horizon_h=140.0)
    r = solve_dp(START, END, _lateral_cost, labels_per_bin=None, **kw)
    paths = _brute_force(r)
    for end_h, fuel in zip(r.curve_bin_end_h, r.curve_fuel_t, strict=True):
        ok = paths[:, 0] <= end_h + 1e-9
        assert fuel == (pytest.approx(paths[ok, 1].min(), rel=1e-12) if ok.any() else np.inf)


def test_one_label_per_bin_loses_a_path_that_the_pareto_labels_keep():
    """The artefact itself: at 20 h bins one label per bin is worse than enumeration at some bin end."""
    kw = dict(dx_nm=450, dy_nm=60, half_width_nm=60, speeds_kn=SPEEDS, dt_h=20.0, horizon_h=140.0)
    one = solve_dp(START, END, _lateral_cost, labels_per_bin=1, **kw)
    paths = _brute_force(one)
    truth = np.array([paths[paths[:, 0] <= e + 1e-9, 1].min() for e in one.curve_bin_end_h if e >= paths[:, 0].min()])
    got = one.curve_fuel_t[one.curve_bin_end_h >= paths[:, 0].min()]
    assert np.all(got >= truth * (1 - 1e-12)) and np.any(got > truth * (1 + 1e-6))


@pytest.mark.parametrize("bad", [0, 1.5, -2])
def test_labels_per_bin_must_be_a_whole_number_of_at_least_one(bad):
    with pytest.raises(ConfigError, match="labels_per_bin"):
        solve_dp(START, END, _lateral_cost, labels_per_bin=bad, dx_nm=450, dy_nm=60, half_width_nm=60)
