"""The 3-D DP against the analytic constant-speed optimum, brute-force enumeration and dense no-go checks.

Cubic fuel law: a leg of d nm sailed in t h burns k·d³/t² t (fuel rate ∝ v³).
For a voyage of D nm in T h the optimum is the constant speed D/T (Jensen's
inequality), with fuel k·D³/T²; any route of length ≥ D arriving at T burns
at least that.
"""

import itertools

import numpy as np
import pytest

from optroute import geodesy as geo
from optroute.errors import ConfigError, InfeasibleETA, NoSafePassage
from optroute.search import solve_dp

K = 1e-4
START, END = (0.0, 0.0), (0.0, 20.0)
D = float(geo.distance_nm(*START, *END))


def cubic(lat0, lon0, lat1, lon1, t0, sog):
    d = geo.distance_nm(lat0, lon0, lat1, lon1)
    t = d / sog
    return t, K * d**3 / t**2, np.ones(d.shape, dtype=bool)


def analytic(t_h):
    return K * D**3 / np.asarray(t_h) ** 2


def test_converges_to_the_constant_speed_optimum_as_the_steps_shrink():
    eta = 80.0
    errors = []
    for dv, dy in ((2.0, 60.0), (1.0, 40.0), (0.5, 30.0), (0.25, 20.0)):
        r = solve_dp(
            START,
            END,
            cubic,
            eta_h=eta,
            dx_nm=200,
            dy_nm=dy,
            half_width_nm=60,
            speeds_kn=np.arange(8, 22.01, dv),
            dt_h=0.25,
        )
        assert r.path.arrival_h <= eta
        np.testing.assert_array_equal(r.path.lateral_nm, 0.0)  # uniform weather: the great circle
        assert r.path.total_fuel_t >= analytic(eta) * (1 - 1e-12)
        errors.append(r.path.total_fuel_t / analytic(eta) - 1)
    assert errors[-1] < 0.005
    assert errors[0] > errors[2] > errors[3]
    assert np.all(np.diff(errors) <= 1e-12)


def test_fuel_versus_eta_curve_is_non_increasing_and_above_the_analytic_bound():
    r = solve_dp(
        START, END, cubic, eta_h=80.0, dx_nm=200, dy_nm=50, half_width_nm=50, speeds_kn=np.arange(8, 22.01, 0.5)
    )
    ok = np.isfinite(r.curve_fuel_t)
    fuel, eta = r.curve_fuel_t[ok], r.curve_bin_end_h[ok]
    assert np.all(np.diff(fuel) <= 0.0)
    assert np.all(fuel >= analytic(eta) * (1 - 1e-12))  # arriving by the ETA costs at least k D³ / ETA²
    inner = (eta > 60) & (eta < 140)
    assert np.all(fuel[inner] <= analytic(eta[inner]) * 1.03)
    # the raw per-bin labels obey the bound at their exact arrival time
    raw = np.isfinite(r.curve_fuel_in_bin_t)
    assert np.all(r.curve_fuel_in_bin_t[raw] >= analytic(r.curve_arrival_h[raw]) * (1 - 1e-12))
    assert r.earliest_arrival_h == pytest.approx(D / 22.0)
    assert fuel[0] == pytest.approx(analytic(D / 22.0))
    # another ETA from the same pass
    p = r.path_for_eta(100.0)
    assert p.arrival_h <= 100.0 and analytic(100.0) <= p.total_fuel_t <= analytic(100.0) * 1.02


@pytest.mark.parametrize("eta_h", [None, 100.0, 100.5])
def test_an_arrival_exactly_at_a_bin_end_is_in_that_bin(eta_h):
    """Bins are (end - dt, end]: the constant speed D / 100 kn arrives at 100 h, the end of its bin.

    With bins [start, end) the label fell into the bin ending at 101 h, and the curve's point
    "arrives by 100 h" missed the one schedule that does (the constant-speed baseline at that ETA).
    """
    r = solve_dp(START, END, cubic, eta_h=eta_h, dx_nm=400, dy_nm=50, half_width_nm=0, speeds_kn=[D / 100.0], dt_h=1.0)
    assert r.path.arrival_h == pytest.approx(100.0, abs=1e-9)
    at = np.flatnonzero(np.isfinite(r.curve_fuel_in_bin_t))
    assert at.size == 1  # one speed, one route: one label
    expected_end = 100.0 if eta_h != 100.5 else 100.5  # with the ETA 100.5 h the bin edges are at x.5 h
    assert r.curve_bin_end_h[at[0]] == pytest.approx(expected_end, abs=1e-9)
    assert r.curve_arrival_h[at[0]] == pytest.approx(100.0, abs=1e-9)
    assert r.curve_fuel_in_bin_t[at[0]] == pytest.approx(analytic(100.0), rel=1e-9)


def test_impossible_eta_reports_the_earliest_arrival():
    with pytest.raises(InfeasibleETA) as exc:
        solve_dp(START, END, cubic, eta_h=40.0, dx_nm=300, dy_nm=60, half_width_nm=60, speeds_kn=[10.0, 15.0, 20.0])
    assert exc.value.earliest_arrival_h == pytest.approx(D / 20.0)
    assert exc.value.earliest_arrival == pytest.approx(D / 20.0)
    assert f"{D / 20.0:.2f} h" in str(exc.value)


def _weather_cost(lat0, lon0, lat1, lon1, t0, sog):
    """Time- and place-dependent: head seas north of the equator in the first day, an MCR cap of 18 kn."""
    d = geo.distance_nm(lat0, lon0, lat1, lon1)
    v = np.minimum(sog, 18.0)
    rough = 1.0 + 0.8 * ((lat0 + lat1) > 0.1) * (t0 < 24.0) + 0.02 * np.sin(0.1 * t0 + lon0)
    t = d / v
    return t, K * d**3 / t**2 * rough, np.ones(d.shape, dtype=bool)


def test_matches_brute_force_enumeration_with_time_dependent_costs():
    speeds = np.array([10.0, 14.0, 18.0, 22.0])
    kw = dict(dx_nm=450, dy_nm=60, half_width_nm=60, speeds_kn=speeds, dt_h=1e-3, horizon_h=140.0)
    eta = 90.0
    r = solve_dp(START, END, _weather_cost, eta_h=eta, **kw)
    lat, lon = r.stage_lat_deg, r.stage_lon_deg
    n_st = lat.shape[0] - 1
    best = np.inf
    for lats in itertools.product(range(3), repeat=n_st - 1):
        path = (1, *lats, 1)
        for vs in itertools.product(speeds, repeat=n_st):
            t, f = 0.0, 0.0
            for k in range(n_st):
                a, b = path[k], path[k + 1]
                dur, fu, _ = _weather_cost(
                    np.array([lat[k, a]]),
                    np.array([lon[k, a]]),
                    np.array([lat[k + 1, b]]),
                    np.array([lon[k + 1, b]]),
                    np.array([t]),
                    np.array([vs[k]]),
                )
                t, f = t + float(dur[0]), f + float(fu[0])
            if t <= eta:
                best = min(best, f)
    assert r.path.total_fuel_t == pytest.approx(best, rel=1e-12)


def _island_and_storm(lat, lon, t, shrink_deg=0.0):
    """Seed 001 case I, scaled: an island on the great circle, a storm south of it moving south at 3 kn after 20 h."""
    m = shrink_deg
    lon_in = (lon >= 6 + m) & (lon <= 12 - m)
    island = lon_in & (lat >= -0.5 + m) & (lat <= 2 - m)
    shift = np.where(t > 20.0, (t - 20.0) * 3.0 / 60.0, 0.0)
    storm = lon_in & (lat <= -0.5 - shift - m) & (lat >= -3 - shift + m)
    return ~(island | storm)


def test_no_go_areas_are_avoided_when_sampled_densely_in_space_and_time():
    kw = dict(dx_nm=150, dy_nm=40, half_width_nm=240, speeds_kn=np.arange(8, 22.01, 1.0))
    r = solve_dp(START, END, cubic, eta_h=110.0, navigable=_island_and_storm, nogo_step_nm=10.0, **kw)
    p = r.path
    assert np.any(p.lateral_nm != 0)
    for k in range(len(p.sog_kn)):
        f = np.linspace(0, 1, 2000)
        lat, lon = geo.intermediate_points(p.lat_deg[k], p.lon_deg[k], p.lat_deg[k + 1], p.lon_deg[k + 1], f)
        t = p.times_h[k] + f * p.leg_duration_h[k]
        # checks every 10 nm along a leg: it can clip a corner by less than that, never go deeper
        assert _island_and_storm(lat, lon, t, shrink_deg=10.0 / 60.0).all()
    free = solve_dp(
        START, END, cubic, eta_h=110.0, dx_nm=150, dy_nm=40, half_width_nm=240, speeds_kn=np.arange(8, 22.01, 1.0)
    )
    assert np.all(free.path.lateral_nm == 0) and p.total_fuel_t > free.path.total_fuel_t


def _reef(lat0, lon0, lat1, lon1):
    """A reef of no width on the meridian 10° E from 0.3° S to 0.3° N: True for the legs that cross it (their
    latitude at 10° E, linear in longitude, within it), a test no point sampling can pass."""
    lat0, lon0, lat1, lon1 = np.broadcast_arrays(lat0, lon0, lat1, lon1)
    across = (lon0 - 10.0) * (lon1 - 10.0) <= 0.0
    f = np.where(lon1 != lon0, (10.0 - lon0) / np.where(lon1 != lon0, lon1 - lon0, 1.0), 0.0)
    return across & (np.abs(lat0 + f * (lat1 - lat0)) <= 0.3)


def test_legs_blocked_keeps_every_leg_off_an_obstacle_between_the_states():
    """A reef across the great circle, narrower than any no-go step: no leg of the path crosses it, the path leaves
    the great circle and costs more than the free one, and the cheapest of all paths that avoid it (exhaustive
    enumeration of the lateral sequences at one speed) is the one returned."""
    kw = dict(eta_h=None, dx_nm=300, dy_nm=40, half_width_nm=80, speeds_kn=[14.0], horizon_h=200.0)
    r = solve_dp(START, END, cubic, legs_blocked=_reef, **kw)
    p = r.path
    assert not _reef(p.lat_deg[:-1], p.lon_deg[:-1], p.lat_deg[1:], p.lon_deg[1:]).any()
    free = solve_dp(START, END, cubic, **kw).path
    assert _reef(free.lat_deg[:-1], free.lon_deg[:-1], free.lat_deg[1:], free.lon_deg[1:]).any()
    assert p.total_fuel_t > free.total_fuel_t
    lat, lon = r.stage_lat_deg, r.stage_lon_deg
    n_stages, n_lat = lat.shape
    centre = n_lat // 2
    best = np.inf
    for inner in itertools.product(range(n_lat), repeat=n_stages - 2):
        seq = (centre, *inner, centre)
        la, lo = lat[np.arange(n_stages), seq], lon[np.arange(n_stages), seq]
        if _reef(la[:-1], lo[:-1], la[1:], lo[1:]).any():
            continue
        d = geo.distance_nm(la[:-1], lo[:-1], la[1:], lo[1:])
        best = min(best, float(np.sum(K * d**3 / (d / 14.0) ** 2)))
    assert p.total_fuel_t == pytest.approx(best, rel=1e-12)


def test_legs_blocked_breaking_its_contract_is_named():
    with pytest.raises(ConfigError, match=r"legs_blocked\(lat0, lon0, lat1, lon1\) returned"):
        solve_dp(START, END, cubic, dx_nm=200, dy_nm=50, half_width_nm=100, speeds_kn=[10.0],
                 legs_blocked=lambda *legs: np.zeros(3, dtype=bool))  # fmt: skip


def test_unreachable_end_raises_no_safe_passage():
    def walled(lat, lon, t):
        return lon < 15.0

    with pytest.raises(NoSafePassage, match="stopped at stage"):
        solve_dp(START, END, cubic, dx_nm=200, dy_nm=50, half_width_nm=100, speeds_kn=[10.0, 20.0], navigable=walled)


def _band_clears_at_1_5_h(lat0, lon0, lat1, lon1, t0, sog):
    """``cubic``, with every leg that leaves the first stage before 1.5 h infeasible (a band there that clears)."""
    t, fuel, ok = cubic(lat0, lon0, lat1, lon1, t0, sog)
    return t, fuel, ok & ~((np.asarray(lon0) > 0.05) & (np.asarray(t0) < 1.5))


def test_a_later_label_passes_where_the_earliest_is_stopped_by_a_band_that_clears():
    """Not FIFO, worked by hand: two 10 nm legs at 5 or 10 kn; at 10 kn the first stage is reached at 1 h, when the
    second leg is still closed, at 5 kn at 2 h, after it clears. The earliest arrival is 5 kn then 10 kn,
    d/5 + d/10 with d half the distance; the earliest-arrival label alone (10 kn first) finds no route."""
    end = (0.0, 0.3335)
    dist = float(geo.distance_nm(*START, *end))
    r = solve_dp(START, end, _band_clears_at_1_5_h, dx_nm=dist / 2, half_width_nm=0, speeds_kn=[5.0, 10.0], dt_h=0.5)
    expected = 0.5 * dist / 5.0 + 0.5 * dist / 10.0
    assert r.earliest_arrival_h == pytest.approx(expected, rel=1e-9)
    fastest = r.path_for_eta(r.earliest_arrival_h)
    np.testing.assert_allclose(fastest.sog_kn, [5.0, 10.0])
    assert fastest.arrival_h == pytest.approx(expected, rel=1e-9)
    late = solve_dp(START, end, _band_clears_at_1_5_h, eta_h=3.5, dx_nm=dist / 2, half_width_nm=0,
                    speeds_kn=[5.0, 10.0], dt_h=0.5)  # fmt: skip
    np.testing.assert_allclose(late.path.sog_kn, [5.0, 10.0])  # the only route by 3.5 h


def _open_from_1_1_to_1_9_h(lat0, lon0, lat1, lon1, t0, sog):
    """``cubic``, with the second leg open only when left between 1.1 and 1.9 h (a gap between two bands)."""
    t, fuel, ok = cubic(lat0, lon0, lat1, lon1, t0, sog)
    t0 = np.asarray(t0)
    return t, fuel, ok & ((np.asarray(lon0) < 0.05) | ((t0 >= 1.1) & (t0 < 1.9)))


def test_time_ranked_labels_keep_each_bins_earliest_where_the_cheapest_is_stopped():
    """Worked by hand: two legs of d ≈ 10 nm at 5, 8 or 10 kn, the second open only when left between 1.1 and
    1.9 h; bins of 1.1 h. The first stage is reached at d/10 ≈ 1.00 h (bin (0, 1.1], stopped), d/8 ≈ 1.25 h and
    d/5 ≈ 2.00 h (both in (1.1, 2.2]; only 1.25 passes). Ranked by fuel the bin keeps 5 kn and no route is left;
    ranked by time it keeps 8 kn, and the earliest arrival is d/8 + d/10, its fuel the cubic law's K d (8² + 10²)."""
    end = (0.0, 0.3335)
    dist = float(geo.distance_nm(*START, *end))
    kw = dict(dx_nm=dist / 2, half_width_nm=0, speeds_kn=[5.0, 8.0, 10.0], dt_h=1.1)
    with pytest.raises(NoSafePassage):
        solve_dp(START, end, _open_from_1_1_to_1_9_h, **kw)
    r = solve_dp(START, end, _open_from_1_1_to_1_9_h, label_value="time", **kw)
    d = dist / 2
    assert r.earliest_arrival_h == pytest.approx(d / 8.0 + d / 10.0, rel=1e-9)
    assert r.path.arrival_h == pytest.approx(r.earliest_arrival_h, rel=1e-12)
    np.testing.assert_allclose(r.path.sog_kn, [8.0, 10.0])
    assert r.path.total_fuel_t == pytest.approx(K * d * (8.0**2 + 10.0**2), rel=1e-9)
    assert np.isnan(r.curve_fuel_t).all()  # no fuel curve from time-ranked labels
    with pytest.raises(ConfigError, match="label_value"):
        solve_dp(START, end, cubic, label_value="cost", **kw)
    with pytest.raises(ConfigError, match="least_fuel_only"):
        solve_dp(START, end, cubic, label_value="time", least_fuel_only=True, **kw)


def test_leg_cost_contract_is_enforced():
    def too_fast(lat0, lon0, lat1, lon1, t0, sog):
        d = geo.distance_nm(lat0, lon0, lat1, lon1)
        return d / (sog + 1.0), 0 * d, np.ones(d.shape, dtype=bool)

    with pytest.raises(ConfigError, match="only lower"):
        solve_dp(START, END, too_fast, dx_nm=300, speeds_kn=[10.0])
    with pytest.raises(ConfigError, match="dx_nm"):
        solve_dp(START, END, cubic, dx_nm=0.0)
    with pytest.raises(ConfigError, match="callable"):
        solve_dp(START, END, None)


def _bent_stations(lat_mid: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """START → (lat_mid, 10°E) → END: one station at the bend, three lateral states 0.5° apart in latitude."""
    lateral = np.array([-30.0, 0.0, 30.0])
    lat = np.array([[0.0] * 3, [lat_mid - 0.5, lat_mid, lat_mid + 0.5], [0.0] * 3])
    lon = np.array([[0.0] * 3, [10.0] * 3, [20.0] * 3])
    return lat, lon, lateral


def test_given_stations_match_brute_force_enumeration_on_a_bent_lattice():
    # stations off the great circle (a bend 2° north at 10°E): the DP over them is exhaustive enumeration of the
    # 3 paths × speed pairs, with the time-dependent costs
    speeds = np.array([10.0, 14.0, 18.0, 22.0])
    stations = _bent_stations(2.0)
    eta = 90.0
    r = solve_dp(START, END, _weather_cost, eta_h=eta, speeds_kn=speeds, dt_h=1e-3, horizon_h=140.0,
                 stations=stations)  # fmt: skip
    lat, lon, _ = stations
    best = np.inf
    for mid in range(3):
        for v0, v1 in itertools.product(speeds, repeat=2):
            t, f = 0.0, 0.0
            for k, (a, b), v in ((0, (1, mid), v0), (1, (mid, 1), v1)):
                dur, fu, _ = _weather_cost(np.array([lat[k, a]]), np.array([lon[k, a]]), np.array([lat[k + 1, b]]),
                                           np.array([lon[k + 1, b]]), np.array([t]), np.array([v]))  # fmt: skip
                t, f = t + float(dur[0]), f + float(fu[0])
            if t <= eta:
                best = min(best, f)
    assert r.path.total_fuel_t == pytest.approx(best, rel=1e-12)
    assert np.allclose(r.path.lat_deg[1], lat[1, r.path.lateral_index[1]])


def test_stations_on_the_great_circle_give_the_dps_own_lattice_and_route():
    kw = dict(dx_nm=450, dy_nm=60, half_width_nm=60, speeds_kn=[10.0, 14.0, 18.0], dt_h=0.5, horizon_h=140.0)
    own = solve_dp(START, END, _weather_cost, eta_h=100.0, **kw)
    given = solve_dp(START, END, _weather_cost, eta_h=100.0, **kw,
                     stations=(own.stage_lat_deg, own.stage_lon_deg, 60.0 * np.arange(-1.0, 2.0)))  # fmt: skip
    assert given.path.total_fuel_t == own.path.total_fuel_t
    assert np.array_equal(given.path.lat_deg, own.path.lat_deg) and np.array_equal(given.path.sog_kn, own.path.sog_kn)


def test_bad_stations_are_refused():
    lat, lon, lateral = _bent_stations(2.0)
    with pytest.raises(ConfigError, match="start"):
        solve_dp((0.5, 0.0), END, cubic, stations=(lat, lon, lateral))
    with pytest.raises(ConfigError, match="odd"):
        solve_dp(START, END, cubic, stations=(lat[:, :2], lon[:, :2], lateral[:2]))
    with pytest.raises(ConfigError, match="rise through 0"):
        solve_dp(START, END, cubic, stations=(lat, lon, lateral[::-1]))
    with pytest.raises(ConfigError, match="finite"):
        solve_dp(START, END, cubic, stations=(np.where(lat > 1.9, np.nan, lat), lon, lateral))


def test_a_fuel_cut_keeps_the_least_fuel_route_under_it_and_costs_fewer_legs():
    # without an ETA the DP's route is the least fuel over every arrival; a cut 1 % above it keeps that route (the
    # labels dropped are those whose fuel already exceeds it) and costs fewer legs; a cut below every route leaves
    # the earliest route, and the curve is not kept
    kw = dict(dx_nm=450, dy_nm=60, half_width_nm=60, speeds_kn=[10.0, 14.0, 18.0, 22.0], dt_h=0.5, horizon_h=140.0)
    full = solve_dp(START, END, _weather_cost, **kw)
    cut = solve_dp(START, END, _weather_cost, **kw, fuel_cut_t=full.path.total_fuel_t * 1.01)
    assert cut.path.total_fuel_t == full.path.total_fuel_t and np.array_equal(cut.path.sog_kn, full.path.sog_kn)
    assert cut.n_transitions < full.n_transitions
    with pytest.raises(ConfigError, match="fuel_cut_t"):
        cut.path_for_eta(100.0)
    low = solve_dp(START, END, _weather_cost, **kw, fuel_cut_t=full.path.total_fuel_t * 0.5)
    assert low.path.arrival_h == pytest.approx(full.earliest_arrival_h, abs=1e-9)
    with pytest.raises(ConfigError, match="fuel_cut_t"):
        solve_dp(START, END, _weather_cost, **kw, fuel_cut_t=-1.0)
