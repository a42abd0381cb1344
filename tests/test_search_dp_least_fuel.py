"""The 3-D DP's ``least_fuel_only`` (labels above the earliest route's fuel dropped) against the DP that keeps them.

Reference: ``solve_dp`` without it, on the same lattice, callback and no-go areas, every label
kept. Compared exhaustively: every single speed of the set and the whole set, with and without a
moving no-go disk and an ETA, compiled and plain callbacks. The route must be the same to the
bit; every label the pruned DP keeps must be the unpruned DP's label of that bin, and every label
it drops must be hopeless by an independent check: its fuel plus the calm-water fuel floor
(:func:`optroute.search.dp_kernels.fuel_floor_tph`) times the geodesic distance to the end exceeds
the fuel of the unpruned DP's earliest route.
"""

import numpy as np
import pytest

from optroute.errors import ConfigError
from optroute.geodesy import distance_nm
from optroute.search import solve_dp
from tests.test_search_dp_kernels import CASES, END, START, _plain, _storm
from tests.test_search_kernels import _physics, sea_fields

SPEEDS = np.array([6.0, 9.0, 12.0, 15.0])
LATTICE = {"dx_nm": 180.0, "dy_nm": 45.0, "half_width_nm": 135.0, "horizon_h": 330.0}


@pytest.fixture(scope="module")
def cb():
    return _physics(sea_fields(5, hs_m=(2.0, 9.0), hours=360.0)).dp_leg(30.0)


def _same_route(a, b):
    for name in ("lat_deg", "lon_deg", "times_h", "sog_kn", "leg_fuel_t", "leg_duration_h"):
        np.testing.assert_array_equal(getattr(a.path, name), getattr(b.path, name))
    assert a.path.total_fuel_t == b.path.total_fuel_t


def _kept_labels_are_the_dps_and_dropped_ones_hopeless(pruned, full, floor_t_per_nm):
    cut = float(full._tables.early_f[-1, full._tables.centre])
    for k, (fp, ff) in enumerate(zip(pruned._tables.fuel, full._tables.fuel, strict=True)):
        kept = np.isfinite(fp)
        assert fp.shape == ff.shape
        for name in ("fuel", "time", "back_l", "back_b", "speed_i"):
            np.testing.assert_array_equal(getattr(pruned._tables, name)[k][kept], getattr(full._tables, name)[k][kept])
        dropped = np.isfinite(ff) & ~kept
        lat_i = np.nonzero(dropped)[0]
        rem = distance_nm(full.stage_lat_deg[k, lat_i], full.stage_lon_deg[k, lat_i], *END)
        assert (ff[dropped] + floor_t_per_nm * rem * (1.0 - 1e-9) > cut).all()


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("speeds", [[v] for v in SPEEDS] + [SPEEDS], ids=lambda s: "+".join(f"{v:g}" for v in s))
def test_least_fuel_only_returns_the_dps_route_and_keeps_its_labels(cb, case, speeds):
    kw = dict(LATTICE, speeds_kn=speeds, **CASES[case])
    try:
        full = solve_dp(START, END, cb, **kw)
    except Exception as exc:  # noqa: BLE001 - the pruned DP must fail the same way
        with pytest.raises(type(exc)):
            solve_dp(START, END, cb, least_fuel_only=True, **kw)
        return
    pruned = solve_dp(START, END, cb, least_fuel_only=True, **kw)
    _same_route(pruned, full)
    np.testing.assert_array_equal(pruned._tables.early_t, full._tables.early_t)
    np.testing.assert_array_equal(pruned._tables.early_f, full._tables.early_f)
    floor = float(np.min(cb.dp_kernel.floor_tph(np.asarray(speeds, float)) / np.asarray(speeds, float)))
    _kept_labels_are_the_dps_and_dropped_ones_hopeless(pruned, full, floor)
    assert pruned.n_states <= full.n_states
    assert pruned.n_transitions <= full.n_transitions


def test_least_fuel_only_prunes_a_single_speed_search(cb):
    kw = dict(LATTICE, speeds_kn=[12.0], navigable=_storm, nogo_step_nm=25.0)
    full, pruned = solve_dp(START, END, cb, **kw), solve_dp(START, END, cb, least_fuel_only=True, **kw)
    _same_route(pruned, full)
    assert pruned.n_transitions < 0.8 * full.n_transitions  # the point of it
    assert np.isnan(pruned.curve_fuel_t).all()  # no curve: not every label was kept
    with pytest.raises(ConfigError, match="least_fuel_only"):
        pruned.path_for_eta(200.0)


@pytest.mark.parametrize("case", CASES)
def test_least_fuel_only_with_the_plain_callback(cb, case):
    kw = dict(LATTICE, speeds_kn=[10.0], **CASES[case])
    full = solve_dp(START, END, _plain(cb), **kw)
    pruned = solve_dp(START, END, _plain(cb), least_fuel_only=True, **kw)
    _same_route(pruned, full)
    _kept_labels_are_the_dps_and_dropped_ones_hopeless(pruned, full, 0.0)


@pytest.mark.parametrize("labels", [3, None])
def test_least_fuel_only_with_a_pareto_set_per_bin(cb, labels):
    kw = dict(LATTICE, speeds_kn=[8.0, 12.0], navigable=_storm, nogo_step_nm=25.0, labels_per_bin=labels)
    full, pruned = solve_dp(START, END, cb, **kw), solve_dp(START, END, cb, least_fuel_only=True, **kw)
    _same_route(pruned, full)
    assert pruned.n_transitions < full.n_transitions
