"""The compiled search loop, the fuel objective's A* bound and the Kwon inversion by bracketed Newton.

References: the Python search loop with the same compiled leg costing
(``leg_batch``, no ``leg_kernel``; batched, every edge its bounds allow costed)
for the compiled loop (lazy edge costing); the standard library's ``heapq`` for
its open set; Dijkstra's label for
A*'s (admissibility, hypothesis); the numpy referee
(``evaluate_speeds(engine="numpy")``) costing random sea states for the fuel
floor, and a hand-worked calm-water minimum; a 200-step bisection of Kwon's
(2008) relation V2 = V1 (1 − max(k C_U(Fn(V1)), 0)) for the Newton inversion;
Bowditch's great-circle formulas (:func:`optroute.geodesy.destination`,
:func:`~optroute.geodesy.initial_course_deg`) for the piece geometry.
"""

import heapq

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import optroute as orx
from optroute import geodesy as geo
from optroute.errors import ConfigError, NoSafePassage
from optroute.physics.passage import SeaState, evaluate_speeds
from optroute.physics.performance import KwonModel
from optroute.physics.pointwise import cached_point_params, least_cost_per_nm
from optroute.physics.safety import BandRules
from optroute.physics.speed_loss import KWON_BISECTIONS, KWON_SCAN_STEPS, calm_speed_point, kwon_cu_coefficients
from optroute.search import RouteGrid, _heap, compass, shortest_path
from optroute.search.edge_geometry import piece_point, sphere_course, wgs84_scale
from optroute.search.routing import PassagePhysics
from optroute.weather import WeatherSampler
from tests.test_search_kernels import BOX, CARGO, T0, sea_fields

SPEEDS = np.arange(5.0, 15.01, 0.5)


@pytest.fixture(scope="module")
def rough():
    return sea_fields(8, hs_m=(3.0, 9.0))


@pytest.fixture(scope="module")
def grid():
    return RouteGrid.build(*BOX, cell_nm=60.0, margin_nm=120.0)


def _physics(ds):
    return PassagePhysics(CARGO, KwonModel(CARGO), BandRules(), WeatherSampler(ds), T0)


def _without_loop_kernel(cb):
    """The same callback with its batch kernel but not its loop kernel: the Python loop of the search."""

    def plain(*args):
        return cb(*args)

    plain.leg_batch = cb.leg_batch
    return plain


def _floor(lam, current_kn=2.0):
    return least_cost_per_nm(cached_point_params(CARGO, KwonModel(CARGO), BandRules()), SPEEDS, lam, current_kn)


# ------------------------------------------------------------------ the loop
@pytest.mark.parametrize(
    "objective,lam,check", [("time", 0.0, 10.0), ("cost", 0.6, 10.0), ("cost", 0.0, None)], ids=str
)
def test_compiled_loop_settles_the_python_loops_labels(rough, grid, objective, lam, check):
    ph = _physics(rough)
    if objective == "time":
        cb = ph.segment_time(14.0, 0.5, 3.0, check)
        kw = {"v_max_kn": 14.0 + 2.0}
    else:
        cb = ph.segment_cheapest(SPEEDS, lam, check)
        kw = {"v_max_kn": 15.0 + 2.0, "lambda_t_per_h": lam, "cost_floor_per_nm": _floor(lam)}
    nb = compass(16)
    fast = shortest_path(grid, nb, segment_cost=cb, objective=objective, **kw)
    slow = shortest_path(grid, nb, segment_cost=_without_loop_kernel(cb), objective=objective, **kw)
    np.testing.assert_array_equal(fast.nodes, slow.nodes)
    np.testing.assert_allclose(fast.times_h, slow.times_h, rtol=0.0, atol=1e-9)
    assert fast.cost == pytest.approx(slow.cost, rel=1e-12)
    assert fast.total_fuel_t == pytest.approx(slow.total_fuel_t, rel=1e-12)
    # the compiled loop costs an edge only when it is due (lazily): fewer edges than the batched loop, which costs
    # every edge its bounds do not rule out, including those into nodes a better edge reaches first
    assert fast.evaluated_edges < slow.evaluated_edges
    assert fast.callback_calls < slow.callback_calls


@settings(max_examples=40, deadline=None)
@given(ops=st.lists(st.one_of(st.integers(0, 6), st.none()), min_size=1, max_size=3000))
def test_the_open_set_pops_its_entries_by_key_then_push_order(ops):
    """The compiled searches' binary heap against the standard library's (``heapq`` on (key, push number)),
    pushes (integers: the key) and pops (None) interleaved, with many ties; grown from one entry as the searches
    grow it."""
    h1, h2, hs = np.empty(1), np.empty(1), np.empty(1, dtype=np.int64)
    n = np.int64(0)
    ref, got, want = [], [], []
    for i, key in enumerate(ops):
        if key is not None:
            if n == h1.size:
                h1, h2, hs = _heap.grown(h1, n), _heap.grown(h2, n), _heap.grown(hs, n)
            n = _heap.push(h1, h2, hs, n, key / 3.0, float(i), np.int64(i))
            heapq.heappush(ref, (key / 3.0, i))
        elif ref:
            _, _, s, n = _heap.pop(h1, h2, hs, n)
            got.append(int(s))
            want.append(heapq.heappop(ref)[1])
    assert (got, int(n)) == (want, len(ref))


def test_a_cost_floor_above_the_true_cost_is_refused(rough, grid):
    cb = _physics(rough).segment_cheapest(SPEEDS, 0.0, None)
    with pytest.raises(ConfigError, match="cost floor"):
        shortest_path(grid, compass(16), segment_cost=cb, objective="fuel", v_max_kn=17.0,
                      cost_floor_per_nm=10.0 * _floor(0.0))  # fmt: skip


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 1000), lam=st.sampled_from([0.0, 0.3]), method=st.sampled_from(["astar", "dijkstra"]))
@example(seed=45, lam=0.3, method="astar")
def test_fuel_bound_keeps_astar_at_dijkstras_label(grid, seed, lam, method):
    """A* with the fuel floor (admissible) settles the label Dijkstra without any heuristic settles."""
    sea = sea_fields(seed, hs_m=(2.0, 8.0), current_ms=0.5)
    ph = _physics(sea)
    cb = ph.segment_cheapest(SPEEDS, lam, None)
    # the floor's current: the field's strongest (each component up to 0.5 m/s, so up to 1.37 kn, not 1 kn: seed 45
    # costed a 131 nm leg below a floor taken at 1 kn)
    current_kn = float(np.max(np.hypot(sea["current_u_ms"], sea["current_v_ms"]))) * 3600.0 / 1852.0
    nb = compass(16)
    kw = dict(segment_cost=cb, objective="cost", lambda_t_per_h=lam, v_max_kn=17.0)
    try:
        bare = shortest_path(grid, nb, method="dijkstra", **kw)  # weight λ / v_max only (0 for fuel)
    except NoSafePassage:  # a sea that closes the grid: the floor must not open a route either
        with pytest.raises(NoSafePassage):
            shortest_path(grid, nb, method=method, cost_floor_per_nm=_floor(lam, current_kn), **kw)
        return
    fast = shortest_path(grid, nb, method=method, cost_floor_per_nm=_floor(lam, current_kn), **kw)
    assert fast.cost <= bare.cost + 1e-9 * bare.cost
    assert fast.cost == pytest.approx(bare.cost, rel=1e-12)
    assert fast.evaluated_edges <= bare.evaluated_edges and fast.batches <= bare.batches


# ------------------------------------------------------------------ the fuel floor
def test_fuel_floor_is_the_calm_water_minimum_and_below_every_allowed_speed_anywhere():
    model = KwonModel(CARGO)
    p = cached_point_params(CARGO, model, BandRules())
    # hand-worked: calm water, no current, every speed of the set above the minimum load
    v = SPEEDS
    power = np.maximum(CARGO.displacement_t ** (2 / 3) * v**3 / CARGO.admiralty_coefficient, CARGO.min_power_kw)
    load = power / CARGO.mcr_kw
    fuel = CARGO.sfoc_base_gpkwh * (0.455 * load**2 - 0.710 * load + 1.280) * power * 1e-6
    assert least_cost_per_nm(p, v, 0.4, 0.0) == pytest.approx(np.min((fuel + 0.4) / v), rel=1e-12)
    # the referee at random sea states, courses and currents up to 1.5 m/s: never cheaper per mile
    rng = np.random.default_rng(3)
    n = 20_000
    cur = rng.uniform(0.0, 1.5, n)
    ang = rng.uniform(0.0, 2.0 * np.pi, n)
    sea = SeaState(rng.uniform(0.0, 9.0, n), rng.uniform(5.0, 15.0, n), rng.uniform(0.0, 360.0, n),
                   rng.normal(0.0, 10.0, n), rng.normal(0.0, 10.0, n), cur * np.sin(ang), cur * np.cos(ang))  # fmt: skip
    stw = rng.choice(SPEEDS, n)
    _, sog, _, fuel_tph, ok = evaluate_speeds(CARGO, model, BandRules(), rng.uniform(0.0, 360.0, n), sea, stw,
                                              engine="numpy")  # fmt: skip
    ok &= sog > 0
    assert ok.mean() > 0.5
    for lam in (0.0, 0.7):
        floor = least_cost_per_nm(p, SPEEDS, lam, 1.5 / 0.514444)
        per_nm = (fuel_tph[ok] + lam) / sog[ok]
        assert floor <= per_nm.min()
        assert floor > 0.5 * per_nm.min()  # and not a trivial bound


# ------------------------------------------------------------------ Kwon by Newton
def _bisect_kwon(v2, a, b, c, k, inv, v_max):
    """Smallest V1 in [V2, V_max] with V1 (1 - max(k C_U, 0)) >= V2 by 200 bisections after a 500-step scan."""

    def excess(v1):
        fn = v1 * inv
        return v1 * (1.0 - max(k * (a + b * fn + c * fn * fn), 0.0)) - v2

    if excess(v2) >= 0.0:
        return v2
    grid = np.linspace(v2, v_max, 501)
    hit = [g for g in grid if excess(g) >= 0.0]
    if not hit:
        return np.nan
    hi = hit[0]
    lo = grid[max(np.searchsorted(grid, hi) - 1, 0)]
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if excess(mid) >= 0.0 else (mid, hi)
    return hi


@settings(max_examples=150, deadline=None)
@given(
    cb=st.sampled_from([0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85]),
    loading=st.sampled_from(["normal", "ballast"]),
    fn2=st.floats(0.02, 0.31),
    k=st.floats(0.0, 0.5),
    length=st.floats(80.0, 400.0),
)
def test_kwon_inversion_is_the_smallest_root(cb, loading, fn2, k, length):
    if loading == "ballast" and cb < 0.75:
        loading = "normal"
    a, b, c = (float(x) for x in kwon_cu_coefficients(cb, loading))
    sqrt_gl_kn = np.sqrt(9.80665 * length) / 0.514444
    inv, v_max = 1.0 / sqrt_gl_kn, 0.3 * sqrt_gl_kn
    v2 = fn2 * sqrt_gl_kn
    got = calm_speed_point(v2, a, b, c, k, inv, v_max, KWON_SCAN_STEPS, KWON_BISECTIONS)
    ref = _bisect_kwon(v2, a, b, c, k, inv, v_max)
    if np.isnan(ref):
        assert np.isnan(got)
        return
    assert got == pytest.approx(ref, rel=1e-13)
    fn = got * inv
    assert got * (1.0 - max(k * (a + fn * (b + c * fn)), 0.0)) >= v2  # never falls short (C_U in Horner form)


# ------------------------------------------------------------------ geometry
def test_piece_points_are_the_great_circle_destination_and_course():
    """A piece point ``s`` [nm, WGS84] from the midpoint on the ellipsoid's course ``crs`` lies on the gnomonic
    sphere's great circle at the arc ``s / scale`` on the sphere's course, both from the local factor of
    :func:`optroute.geodesy.sphere_to_wgs84`; the course returned is the ellipsoid's there."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        lat, lon, crs, s = rng.uniform(-70, 70), rng.uniform(-180, 180), rng.uniform(0, 360), rng.uniform(-40, 40)
        la, lo, c = piece_point(lat, lon, crs, s)
        c_sphere = float(sphere_course(lat, crs))
        scale, back = (float(x) for x in geo.sphere_to_wgs84(lat, c_sphere))
        assert (back - crs + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-9)  # the inverse of sphere_to_wgs84
        assert float(wgs84_scale(lat, c_sphere)) == pytest.approx(scale, rel=1e-14)
        arc = abs(s) / scale
        ref_la, ref_lo = geo.sphere_destination(lat, lon, c_sphere if s >= 0 else c_sphere + 180.0, arc)
        far = geo.sphere_destination(lat, lon, c_sphere, arc + 1.0)
        assert la == pytest.approx(float(ref_la), abs=1e-10)
        assert (lo - float(ref_lo) + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-10)
        course = float(geo.sphere_to_wgs84(la, geo.sphere_initial_course_deg(la, lo, *far))[1])
        assert (c - course + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-8)


def test_search_route_fuel_objective_uses_the_floor_and_matches_dijkstra():
    ds = sea_fields(2, hs_m=(2.0, 7.0))
    kw = dict(departure=T0, cell_nm=60.0, snap_max_nm=400.0, objective="fuel", directions=16)  # fmt: skip
    a = orx.search_route(*BOX, ds, CARGO, method="astar", **kw)
    d = orx.search_route(*BOX, ds, CARGO, method="dijkstra", **kw)
    np.testing.assert_array_equal(a.waypoints, d.waypoints)
    assert a.cost == pytest.approx(d.cost, rel=1e-12)
    assert a.stats["expanded"] < d.stats["expanded"]


@pytest.mark.parametrize("objective", ["time", "cost"])
def test_a_dropped_leg_is_one_whose_full_cost_cannot_improve_the_label(rough, grid, objective):
    """``cost_leg``'s ``stop`` (the compiled loop's early drop) against the leg costed in full (``label_v = inf``).

    A leg is returned only with its full cost, bit for bit, and dropped only where ``label_u`` + its full cost
    exceeds ``label_v``: the search's strictly-better update would not take it either.
    """
    from optroute.search.costs import LegEvaluator
    from optroute.search.edge_geometry import edge_piece_arrays
    from optroute.search.passage_kernels import cost_leg, leg_workspace
    from optroute.search.refine_kernels import workspace

    ph = _physics(rough)
    cb = ph.segment_time(14.0, 0.5, 3.0, 10.0) if objective == "time" else ph.segment_cheapest(SPEEDS, 0.6, 10.0)
    k = cb.leg_kernel
    nb = compass(16)
    ev = LegEvaluator(grid, nb, segment_cost=cb)
    rng = np.random.default_rng(3)
    u = rng.integers(0, grid.n_nodes, 400)
    o = rng.integers(0, nb.m, 400)
    i, j = grid.unflat(u)
    i1, j1 = i + nb.offsets[o, 0], j + nb.offsets[o, 1]
    on = (i1 >= 0) & (i1 < grid.ny) & (j1 >= 0) & (j1 < grid.nx)
    u, o, v = u[on], o[on], grid.flat(i1[on], j1[on])
    lat, lon, crs, length = edge_piece_arrays(ev.tangent, u, v, ev.piece_f0[o], ev.piece_f1[o], ev.piece_n[o])
    npc = ev.piece_n[o].astype(np.int64)
    args = (k.params, k.weather, k.mode, k.check_nm, k.speeds, k.lam, k.desired, k.step, k.vmin)
    ws = workspace(True)
    lws = leg_workspace(1, k.speeds.size)  # reused from leg to leg, grown by cost_leg where a leg needs more
    # the search's bound per nm still to sail: 1 / v_max for time, the cost floor ρ for fuel + λ·time
    rest_rate = (1.0 - 1e-5) * ((1.0 / (14.0 + 2.0)) if objective == "time" else _floor(k.lam))
    dropped = kept = 0
    for e in range(u.size):
        row = (lat[e], lon[e], crs[e], length[e], npc[e], rng.uniform(0.0, 100.0))
        d, f, ok, _ = cost_leg(*args, *row, ws, (0.0, np.inf, True, 0.0), lws)
        if not ok:
            continue
        c = d if objective == "time" else f + k.lam * d
        label_u = rng.uniform(0.0, 50.0)
        for factor in (0.3, 0.9, 0.999, 1.0, 1.001, 2.0):
            label_v = label_u + factor * c
            d2, f2, ok2, _ = cost_leg(*args, *row, ws, (label_u, label_v, objective == "time", rest_rate), lws)
            if ok2:
                assert (d2, f2) == (d, f)
                kept += 1
            else:
                assert label_u + c > label_v
                dropped += 1
    assert dropped > 100 and kept > 100
