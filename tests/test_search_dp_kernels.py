"""The 3-D DP's compiled transitions (optroute.search.dp_kernels) against every transition costed.

References: ``solve_dp`` with the same leg callback stripped of its compiled
form (a plain function: the DP then costs every transition through the
callback, as before the stage kernels); the numpy DP callback
(``PassagePhysics(compiled=False).dp_leg``, the vectorised referee functions
``evaluate_speeds(engine="numpy")``); for the fuel floor, the fuel of every
feasible random leg by that referee.
"""

import numpy as np
import pytest

from optroute.errors import NoSafePassage
from optroute.geodesy import distance_nm
from optroute.search import solve_dp
from optroute.search.passage_kernels import cost_dp_legs
from tests.test_search_kernels import _physics, sea_fields

START, END = (-6.0, 151.0), (4.0, 171.0)


@pytest.fixture(scope="module")
def sea():
    return sea_fields(5, hs_m=(2.0, 9.0), hours=360.0)


def _plain(cb):
    """The callback as a plain function: no compiled form for solve_dp to find."""
    return lambda *a: cb(*a)


def _storm(lat, lon, t):
    """A no-go disk of 150 nm drifting north-east at 8 kn (case I of Shao et al. in spirit)."""
    clat, clon = -2.0 + 8.0 * t / 60.0 / 2.0, 158.0 + 8.0 * t / 60.0 / 2.0
    return distance_nm(lat, lon, clat, clon) >= 150.0


CASES = {
    "free, eta": {"eta_h": 150.0},
    "no-go, any arrival": {"navigable": _storm, "nogo_step_nm": 25.0},
    "no-go, +-2 laterals, eta": {"navigable": _storm, "max_lateral_step": 2, "eta_h": 160.0},
}
#: ``CASES`` and the labels ranked by arrival time (not for least_fuel_only, which cuts by fuel)
RANKED = {**CASES, "no-go, earliest per bin": {"navigable": _storm, "nogo_step_nm": 25.0, "label_value": "time"}}


@pytest.mark.parametrize("case", RANKED)
def test_compiled_stages_keep_every_label_of_the_dp_that_costs_every_transition(sea, case):
    cb = _physics(sea).dp_leg(30.0)
    assert hasattr(cb, "dp_kernel")
    # six speeds, 6-16 kn in 2 kn steps: some 2 000 labels and 17 000-78 000 transitions compared table by table
    kw = dict(dx_nm=180.0, dy_nm=45.0, half_width_nm=135.0, speeds_kn=np.arange(6.0, 16.5, 2.0), **RANKED[case])
    fast, slow = solve_dp(START, END, cb, **kw), solve_dp(START, END, _plain(cb), **kw)
    for name in ("fuel", "time", "back_l", "back_b", "speed_i"):
        for a, b in zip(getattr(fast._tables, name), getattr(slow._tables, name), strict=True):
            np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(fast._tables.early_back, slow._tables.early_back)
    for name in ("lat_deg", "lon_deg", "times_h", "sog_kn", "leg_fuel_t"):
        np.testing.assert_array_equal(getattr(fast.path, name), getattr(slow.path, name))
    np.testing.assert_array_equal(fast.curve_fuel_t, slow.curve_fuel_t)
    assert fast.n_states == slow.n_states
    assert fast.n_transitions < slow.n_transitions  # the floor spared some legs
    # the labels are the referee's: the path's legs re-costed by the numpy callback
    ref = _physics(sea, compiled=False).dp_leg(30.0)
    p = fast.path
    dur, fuel, feas, _ = ref(p.lat_deg[:-1], p.lon_deg[:-1], p.lat_deg[1:], p.lon_deg[1:], p.times_h[:-1], p.sog_kn)
    assert feas.all()
    np.testing.assert_allclose(fuel, p.leg_fuel_t, rtol=1e-9)
    np.testing.assert_allclose(dur, p.leg_duration_h, rtol=1e-12)


def test_stage_legs_cost_random_transitions_as_the_referee_and_above_the_fuel_floor(sea):
    kernel = _physics(sea).dp_leg(30.0).dp_kernel
    ref = _physics(sea, compiled=False).dp_leg(30.0)
    rng = np.random.default_rng(11)
    n_geom, n = 60, 400
    lat0, lon0 = rng.uniform(-8.0, 8.0, n_geom), rng.uniform(150.0, 168.0, n_geom)
    lat1, lon1 = lat0 + rng.uniform(-2.0, 2.0, n_geom), lon0 + rng.uniform(0.5, 3.0, n_geom)
    geom = kernel.geometry(lat0, lon0, lat1, lon1)
    g = rng.integers(0, n_geom, n)
    t0, sog = rng.uniform(0.0, 300.0, n), rng.uniform(5.0, 16.0, n)
    dur, fuel, feas, _, _, _ = cost_dp_legs(
        kernel.params, tuple(kernel.weather), geom.lat_deg, geom.lon_deg, geom.course_deg, geom.frac, geom.n_pieces,
        g, t0, sog, geom.dist_nm, True,
    )  # fmt: skip
    r_dur, r_fuel, r_feas, _ = ref(lat0[g], lon0[g], lat1[g], lon1[g], t0, sog)
    np.testing.assert_array_equal(feas, r_feas)
    assert 0.2 < feas.mean() < 1.0
    np.testing.assert_allclose(dur, r_dur, rtol=1e-12)
    np.testing.assert_allclose(fuel[feas], r_fuel[feas], rtol=1e-9)
    floor = np.array([kernel.floor_tph(np.array([v]))[0] for v in sog]) * dur
    assert kernel.current_kn() > 0.5  # the floor allows for the current
    assert (r_fuel[feas] >= floor[feas]).all()
    assert (r_fuel[feas] < 3.0 * floor[feas]).all()  # a floor that prunes, not zero


def test_unreachable_end_is_no_safe_passage_with_the_compiled_stages(sea):
    cb = _physics(sea).dp_leg(30.0)

    def walled(lat, lon, t):
        return (lon < 160.0) | (lon > 161.0)

    with pytest.raises(NoSafePassage, match="stopped at stage"):
        solve_dp(START, END, cb, dx_nm=300.0, dy_nm=60.0, half_width_nm=120.0, speeds_kn=[10.0, 14.0], navigable=walled)
