"""The compiled passage kernels against the numpy referee they replace in the search's inner loop.

References: the vectorised numpy composition of the performance model and the
band conditions (``evaluate_speeds(engine="numpy")``: ``KwonModel.brake_power_kw``,
:func:`~optroute.physics.safety.is_speed_forbidden`); the sampler's own
vectorised interpolation; the numpy segment and DP callbacks of
:class:`~optroute.search.routing.PassagePhysics` (``compiled=False``), the path
the search took before the kernels; Dijkstra for A* (hypothesis).
"""

import warnings

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import optroute as orx
from optroute import _numba
from optroute.physics.passage import SeaState, evaluate_speeds
from optroute.physics.performance import CalmWaterModel, KwonModel, PowerTableModel
from optroute.physics.pointwise import cached_point_params, point_params
from optroute.physics.safety import BandRules
from optroute.search import RouteGrid, angular_resolution, compass, shortest_path
from optroute.search.costs import LegEvaluator
from optroute.search.routing import PassagePhysics, search_route
from optroute.units import h_to_timedelta
from optroute.weather import WeatherSampler
from optroute.weather.sample import sample_at
from optroute.weather.schema import canonical_dataset

T0 = np.datetime64("2024-03-01T00:00", "ns")
CARGO = orx.Ship.preset("general_cargo_25k_dwt")  # L 170 m: bands where Hs >= 6.8 m
BOX = ((-2.0, 150.0), (3.0, 164.0))


def sea_fields(seed, hs_m=(3.0, 10.0), current_ms=0.8, hours=240.0, land=False):
    """Smooth random (seeded) Hs, Tp, wave direction, wind and current on a 0.5° x 6 h grid, as in test_routing."""
    rng = np.random.default_rng(seed)
    lat = np.arange(-12.0, 14.0 + 1e-9, 0.5)
    lon = np.arange(146.0, 178.0 + 1e-9, 0.5)
    hr = np.arange(0.0, hours + 1e-9, 6.0)
    t, la, lo = np.meshgrid(hr, lat, lon, indexing="ij")

    def smooth():
        k = rng.uniform(-0.25, 0.25, (4, 2))
        w = rng.uniform(-0.05, 0.05, 4)
        ph = rng.uniform(0.0, 2.0 * np.pi, 4)
        return sum(np.sin(k[i, 0] * lo + k[i, 1] * la + w[i] * t + ph[i]) for i in range(4)) / 4.0

    hs = hs_m[0] + (hs_m[1] - hs_m[0]) * np.clip(0.5 + 1.2 * smooth(), 0.0, 1.0)
    if land:
        hs[:, (la[0] > 5.0) & (lo[0] > 170.0)] = np.nan  # an island: no passage
    wave_from = np.mod(200.0 + 150.0 * smooth(), 360.0)
    wind = 2.0 * np.sqrt(np.nan_to_num(hs))
    variables = {
        "hs_m": hs,
        "tp_s": 10.5 + 2.5 * smooth(),
        "wave_from_deg": wave_from,
        "wind_u_ms": -wind * np.sin(np.radians(wave_from)),
        "wind_v_ms": -wind * np.cos(np.radians(wave_from)),
        "current_u_ms": current_ms * smooth(),
        "current_v_ms": current_ms * smooth(),
    }
    return canonical_dataset(
        T0 + h_to_timedelta(hr), lat, lon, variables, {"geography": "synthetic", "source": f"sea_fields({seed})"}
    )


@pytest.fixture(scope="module")
def sea():
    return sea_fields(3)


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ports snapped to open water, with a warning
        return fn(*args, **kwargs)


# ------------------------------------------------------------------ one point
@pytest.mark.parametrize(
    "ship,model_cls,rules",
    [
        (CARGO, KwonModel, BandRules()),
        (CARGO, CalmWaterModel, BandRules(rule_set="imo", hs_threshold_fraction=0.0)),
        (orx.Ship.preset("container_8000teu"), KwonModel, BandRules(period_form="imo", margin=0.3)),
        (orx.Ship.preset("container_54k_dwt").replace(loading="ballast", ship_type="tanker", block_coefficient=0.8,
                                                      displacement_t=84_000.0), KwonModel, BandRules(rule_set="imo")),
    ],
)  # fmt: skip
def test_point_functions_match_the_vectorised_model_and_band_conditions(ship, model_cls, rules):
    rng = np.random.default_rng(7)
    n = 4000
    sea = SeaState(
        rng.uniform(0.0, 13.0, n), rng.uniform(4.0, 18.0, n), rng.uniform(0.0, 360.0, n), rng.normal(0.0, 12.0, n),
        rng.normal(0.0, 12.0, n), rng.normal(0.0, 1.5, n), rng.normal(0.0, 1.5, n),
    )  # fmt: skip
    sea.hs_m[::53] = np.nan  # no passage
    course, stw = rng.uniform(0.0, 360.0, n), rng.uniform(0.3, 30.0, n)
    model = model_cls(ship)
    assert point_params(ship, model, rules) is not None
    got = evaluate_speeds(ship, model, rules, course, sea, stw)
    ref = evaluate_speeds(ship, model, rules, course, sea, stw, engine="numpy")
    for a, b in zip(got[:4], ref[:4], strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=0.0, equal_nan=True)
    np.testing.assert_array_equal(got[4], ref[4])
    assert 0.05 < got[4].mean() < 0.95  # both outcomes were exercised


def test_models_the_point_functions_do_not_cover_keep_the_numpy_path():
    table = PowerTableModel((5.0, 15.0, 25.0), (0.0, 10.0), (0.0, 180.0), np.full((3, 2, 2), 1.0) * [[[1]], [[5]], [[9]]]
                            * 3000.0, CARGO)  # fmt: skip
    assert point_params(CARGO, table, BandRules()) is None
    assert point_params(CARGO.replace(speed_power_table=((5.0, 900.0), (10.0, 2500.0), (15.0, 7000.0))),
                        KwonModel(CARGO), BandRules()) is None  # fmt: skip


def test_weather_at_one_point_is_the_samplers_interpolation(sea):
    s = WeatherSampler(sea)
    dep = T0 + h_to_timedelta(5.25)
    pw = s.point_weather(dep)
    rng = np.random.default_rng(2)
    n = 400
    lat, lon, t_h = rng.uniform(-13.0, 15.0, n), rng.uniform(145.0, 179.0, n), rng.uniform(-8.0, 245.0, n)
    out, got, cov = np.empty(9), np.empty((n, 7)), np.empty(n, dtype=bool)
    for i in range(n):
        cov[i] = sample_at(*pw, t_h[i], lat[i], lon[i], out)
        got[i] = out[:7]
    when = dep + h_to_timedelta(t_h)
    inside = s.covers(when, lat, lon)
    np.testing.assert_array_equal(cov, inside)
    assert 0.2 < inside.mean() < 0.95
    names = ["hs_m", "tp_s", "wave_from_deg", "wind_u_ms", "wind_v_ms", "current_u_ms", "current_v_ms"]
    ref = s.sample(when[inside], lat[inside], lon[inside], variables=names)
    for k, name in enumerate(names):
        np.testing.assert_allclose(got[inside, k], ref[name], rtol=1e-12, atol=1e-9)
    assert np.isnan(got[~inside]).all()


# ------------------------------------------------------------------ legs
def _physics(ds, ship=CARGO, compiled=True):
    return PassagePhysics(ship, KwonModel(ship), BandRules(), WeatherSampler(ds), T0, compiled=compiled)


CALLBACKS = {
    "time, midpoint": lambda ph: ph.segment_time(14.0, 0.5, 3.0, None),
    "time, checked": lambda ph: ph.segment_time(14.0, 0.5, 3.0, 10.0),
    "cheapest, midpoint": lambda ph: ph.segment_cheapest(np.arange(5.0, 15.01, 0.5), 2.5, None),
    "cheapest, checked": lambda ph: ph.segment_cheapest(np.arange(5.0, 15.01, 0.5), 0.4, 10.0),
}


@pytest.mark.parametrize("which", list(CALLBACKS))
def test_kernel_costs_random_legs_as_the_numpy_callback(which):
    ds = sea_fields(5, hs_m=(4.0, 11.0), land=True)
    physics = _physics(ds)
    cb = CALLBACKS[which](physics)
    assert hasattr(cb, "leg_batch")
    grid = RouteGrid.build(*BOX, cell_nm=25.0)
    nb = angular_resolution(10.0, 6)
    ev = LegEvaluator(grid, nb, segment_cost=cb)
    rng = np.random.default_rng(11)
    n = 300
    u = rng.integers(0, grid.n_nodes, 4 * n)
    o = rng.integers(0, nb.m, 4 * n)
    i, j = grid.unflat(u)
    i1, j1 = i + nb.offsets[o, 0], j + nb.offsets[o, 1]
    on = (i1 >= 0) & (i1 < grid.ny) & (j1 >= 0) & (j1 < grid.nx)
    u, o = u[on][:n], o[on][:n]
    v = grid.flat(i1[on][:n], j1[on][:n])
    t0 = rng.uniform(0.0, 200.0, u.size)
    t0[:20] = 236.0  # legs running out of the forecast: no passage
    dur, fuel, feas, _ = ev.evaluate(u, v, o, t0)
    ref_dur, ref_fuel, ref_feas, _ = ev.evaluate(u, v, o, t0, detail=True)  # the numpy callback, piece by piece
    np.testing.assert_array_equal(feas, ref_feas)
    assert 0.2 < feas.mean() < 1.0
    np.testing.assert_allclose(dur[feas], ref_dur[feas], rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(fuel[feas], ref_fuel[feas], rtol=1e-9, atol=1e-9)
    assert physics.uncovered > 0


def test_dp_kernel_costs_random_legs_as_the_numpy_callback(sea):
    fast, slow = _physics(sea).dp_leg(30.0), _physics(sea, compiled=False).dp_leg(30.0)
    rng = np.random.default_rng(4)
    n = 500
    lat0, lon0 = rng.uniform(-8.0, 8.0, n), rng.uniform(150.0, 170.0, n)
    lat1, lon1 = lat0 + rng.uniform(-2.0, 2.0, n), lon0 + rng.uniform(-3.0, 3.0, n)
    t0, sog = rng.uniform(0.0, 200.0, n), rng.uniform(5.0, 16.0, n)
    a, b = fast(lat0, lon0, lat1, lon1, t0, sog), slow(lat0, lon0, lat1, lon1, t0, sog)
    np.testing.assert_array_equal(a[2], b[2])
    assert 0.2 < a[2].mean() < 1.0
    ok = a[2]
    np.testing.assert_allclose(a[0], b[0], rtol=1e-15)
    np.testing.assert_allclose(a[1][ok], b[1][ok], rtol=1e-9)
    for key in ("stw_kn", "power_kw"):
        np.testing.assert_allclose(a[3][key][ok], b[3][key][ok], rtol=1e-9)


# ------------------------------------------------------------------ whole searches
@pytest.mark.parametrize(
    "kw",
    [
        {"objective": "time"},
        {"objective": "time", "band_check_nm": None, "method": "dijkstra"},
        {"objective": "cost", "hourly_cost_per_h": 2400.0},
        {"method": "dp", "objective": "fuel", "dp_options": {"dx_nm": 150.0, "dy_nm": 50.0, "half_width_nm": 100.0},
         "speeds_kn": np.arange(6.0, 16.01, 2.0)},
    ],
)  # fmt: skip
def test_search_routes_are_those_of_the_numpy_callbacks(sea, kw):
    # 60 nm cells (were 40): still a search across the 850 nm box with every edge costed by both paths, on fewer
    # edges; the numpy path (compiled=False) is the slow one and its cost scales with the edges. The DP on six
    # speeds (6-16 kn; the default ladder is 5 kn to the top speed in 0.5 kn steps): the same lattice, every
    # transition still costed by both paths, its route still weaving off the centreline (6 legs, 29.56 t)
    base = dict(departure=T0, cell_nm=60.0, snap_max_nm=400.0, **kw)
    fast = _quiet(search_route, *BOX, sea, CARGO, **base)
    slow = _quiet(search_route, *BOX, sea, CARGO, compiled=False, **base)
    np.testing.assert_array_equal(fast.waypoints, slow.waypoints)
    assert fast.total_duration_h == pytest.approx(slow.total_duration_h, rel=0.0, abs=1e-9)
    assert fast.total_fuel_t == pytest.approx(slow.total_fuel_t, rel=1e-9)
    assert fast.cost == pytest.approx(slow.cost, rel=1e-12)


# ------------------------------------------------------------------ A* against Dijkstra
@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    cell=st.sampled_from([40.0, 60.0, 90.0]),
    directions=st.sampled_from([8, 16, 32]),
    objective=st.sampled_from(["time", "cost"]),
)
def test_astar_label_never_exceeds_dijkstras(seed, cell, directions, objective):
    """Random time-varying speed fields: A* (admissible heuristic, batched settling) settles Dijkstra's label."""
    rng = np.random.default_rng(seed)
    k = rng.uniform(-0.3, 0.3, (3, 3))
    v_max = 20.0

    def speed(lat, lon, t):
        s = sum(np.sin(k[i, 0] * lat + k[i, 1] * lon + 0.05 * k[i, 2] * t + i) for i in range(3)) / 3.0
        return 8.0 + 11.0 * (0.5 + 0.5 * s)

    def segment_cost(lat, lon, course, length, t):
        v = speed(lat, lon, t)
        return length / v, 1e-4 * length * v**2, v > 9.0

    grid = RouteGrid.build((0.0, 150.0), (2.0, 157.0), cell_nm=cell, margin_nm=3 * cell)
    nb = compass(directions)
    kw = dict(v_max_kn=v_max, segment_cost=segment_cost, objective=objective, lambda_t_per_h=0.3)
    try:
        d = shortest_path(grid, nb, method="dijkstra", **kw)
    except orx.errors.NoSafePassage:
        with pytest.raises(orx.errors.NoSafePassage):
            shortest_path(grid, nb, method="astar", **kw)
        return
    a = shortest_path(grid, nb, method="astar", **kw)
    assert a.cost <= d.cost + 1e-9 * max(1.0, d.cost)
    if objective == "time":  # label-setting on FIFO legs: both are the earliest arrival
        assert a.cost == pytest.approx(d.cost, rel=1e-12)


# ------------------------------------------------------------------ compilation
def test_compilation_falls_back_to_no_cache_where_no_cache_folder_is_writable(monkeypatch):
    real = numba.njit

    def njit(*args, **kw):
        if kw.get("cache"):
            raise RuntimeError("cannot cache function 'f': no locator available for file '/ro/f.py'")
        return real(*args, **kw)

    monkeypatch.setattr(numba, "njit", njit)
    monkeypatch.setattr(_numba, "_warned", False)

    def double(x):
        return 2.0 * x

    with pytest.warns(RuntimeWarning, match="NUMBA_CACHE_DIR"):
        f = _numba.jit(double)
    assert f(1.5) == 3.0


def test_importing_optroute_compiles_nothing():
    import subprocess
    import sys

    code = (
        "import sys, optroute, optroute.search.routing; "
        "from optroute.physics import pointwise; from optroute.search import passage_kernels as k; "
        "print(len(pointwise.evaluate_speed.signatures), len(k.cost_legs.signatures))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["0", "0"]


def test_cheapest_speed_kernel_is_the_brute_force_argmin():
    # cheapest_speed_at tries the speed of the least cost floor first and skips by the floor: its choice must be
    # that of trying every speed of the set, the least (fuel + λ) / SOG
    from optroute.search.passage_kernels import _eval_at, cheapest_speed_at

    # read only, as the search passes them, so the kernels are not compiled a second time for a writable array
    p = cached_point_params(CARGO, KwonModel(CARGO), BandRules())
    rng = np.random.default_rng(15)
    speeds = np.arange(5.0, 15.01, 0.5)
    chosen = []
    for _ in range(400):
        sea = np.zeros(9)
        sea[:7] = (rng.uniform(0.0, 11.0), rng.uniform(5.0, 15.0), rng.uniform(0.0, 360.0),
                   *rng.uniform(-20.0, 20.0, 2), *rng.uniform(-1.0, 1.0, 2))  # fmt: skip
        course, lam = rng.uniform(0.0, 360.0), rng.choice([0.0, 0.4, 2.5, 40.0])
        rate = np.full(speeds.size, np.inf)
        for k, v in enumerate(speeds):
            sog, fuel, ok = _eval_at(p, course, sea, v)
            if ok and sog > 0.0:
                rate[k] = (fuel + lam) / sog
        stw, sog, fuel, ok = cheapest_speed_at(p, course, sea, speeds, lam, np.empty(speeds.size))
        assert ok == np.isfinite(rate).any()
        if ok:
            k = int(np.argmin(rate))
            assert stw == speeds[k] and (fuel + lam) / sog == rate[k]
            chosen.append(k)
    # not trivial: many different choices, neither always the slowest nor the fastest
    assert len(set(chosen)) > 8 and len(chosen) > 200
