"""Time-dependent Dijkstra / A* on the route grid, against independent references.

References: the great-circle distance (calm water), the two-direction mixing
theory of lattice paths, scipy's compiled static Dijkstra, a brute-force
label-correcting (Bellman–Ford) search for a FIFO time-dependent field, and
dense re-sampling of the returned legs against the obstacles.
"""

import numpy as np
import pytest
from scipy.sparse import csgraph, csr_matrix

from optroute import geodesy as geo
from optroute.errors import ConfigError, InfeasibleETA, NoSafePassage
from optroute.search import RouteGrid, _kernels, angular_resolution, compass, grid_edges, shortest_path
from optroute.search.costs import LegEvaluator

ENGINES = ["numpy", "numba"] if _kernels.AVAILABLE else ["numpy"]

SAN_DIEGO = (32.7, -117.2)
TOKYO = (35.6, 139.8)
V = 20.0


def calm(lat0, lon0, lat1, lon1, t0):
    d = geo.distance_nm(lat0, lon0, lat1, lon1)
    return d / V, 0.01 * d, np.ones(d.shape, dtype=bool)


def calm_pieces(lat, lon, course, length, t):
    return length / V, 0.01 * length, np.ones(length.shape, dtype=bool)


class SpeedField:
    """A smooth random speed field [kn] in (vmin, V], varying in space and time."""

    def __init__(self, seed, period_h=60.0, vmin=6.0):
        rng = np.random.default_rng(seed)
        self.k = rng.uniform(0.2, 0.8, (4, 2))
        self.ph = rng.uniform(0, 2 * np.pi, 4)
        self.w = 2 * np.pi / period_h * rng.uniform(0.5, 1.5, 4)
        self.vmin = vmin

    def __call__(self, lat, lon, t):
        s = sum(np.sin(self.k[i, 0] * lat + self.k[i, 1] * lon + self.w[i] * t + self.ph[i]) for i in range(4))
        return self.vmin + (V - self.vmin) * (0.5 + s / 8.0)

    def edge_cost(self, lat0, lon0, lat1, lon1, t0):
        d = geo.distance_nm(lat0, lon0, lat1, lon1)
        v = self(0.5 * (lat0 + lat1), 0.5 * (lon0 + lon1), t0)
        return d / v, 1e-3 * d * v**2, np.ones(d.shape, dtype=bool), {"speed_kn": v}

    def piece_cost(self, lat, lon, course, length, t):
        v = self(lat, lon, t)
        return length / v, 1e-3 * length * v**2, np.ones(length.shape, dtype=bool)


@pytest.fixture(scope="module")
def small_grid():
    return RouteGrid.build((10.0, 20.0), (12.0, 30.0), cell_nm=30.0, margin_nm=90.0)


# ------------------------------------------------------------------ calm water
@pytest.mark.parametrize("angle", [0.0, 22.5])
def test_calm_san_diego_tokyo_within_half_a_percent_at_five_degrees(angle):
    g = RouteGrid.build(SAN_DIEGO, TOKYO, cell_nm=40.0, margin_nm=200.0, route_angle_deg=angle)
    r = shortest_path(g, angular_resolution(5.0), edge_cost=calm, v_max_kn=V)
    gc = float(geo.distance_nm(*SAN_DIEGO, *TOKYO))
    assert r.distance_nm == pytest.approx(gc, rel=0.005)
    assert r.distance_nm >= gc * (1 - 1e-12)
    assert r.arrival_h == pytest.approx(r.distance_nm / V)
    assert (r.lat_deg[0], r.lon_deg[0]) == pytest.approx(SAN_DIEGO) and (r.lat_deg[-1], r.lon_deg[-1]) == pytest.approx(
        TOKYO
    )
    assert np.all((r.lon_deg >= -180) & (r.lon_deg < 180))


def test_excess_of_8_16_32_directions_decreases_as_the_mixing_theory_says():
    """At 22.5° off the lattice axis: the two-direction mix gives 8.2 %, 1.4 %, 0.25 %, 0.04 % (5°)."""
    # a short voyage: the gnomonic scale is within 0.1 % of 1, so the plane theory applies
    start, end = (40.0, -30.0), (41.0, -25.0)
    excess, theory = [], []
    for nb in (compass(8), compass(16), compass(32), angular_resolution(5.0)):
        g = RouteGrid.build(start, end, cell_nm=3.0, margin_nm=40.0, route_angle_deg=22.5)
        ang = np.degrees(np.arctan2(g.end[0] - g.start[0], g.end[1] - g.start[1]))
        r = shortest_path(g, nb, edge_cost=calm, v_max_kn=V)
        excess.append(r.distance_nm / float(geo.distance_nm(*start, *end)) - 1)
        theory.append(nb.excess_for_direction(ang))
        assert excess[-1] <= nb.worst_case_excess() + 2e-3
    assert excess[0] > excess[1] > excess[2] > excess[3]
    np.testing.assert_allclose(excess, theory, rtol=0.05, atol=2e-4)


def test_excess_ordering_on_the_pacific_crossing():
    g = RouteGrid.build(SAN_DIEGO, TOKYO, cell_nm=60.0, margin_nm=200.0, route_angle_deg=22.5)
    gc = float(geo.distance_nm(*SAN_DIEGO, *TOKYO))
    ex = [
        shortest_path(g, nb, edge_cost=calm, v_max_kn=V).distance_nm / gc - 1
        for nb in (compass(8), compass(16), compass(32))
    ]
    assert ex[0] > ex[1] > ex[2] > 0
    # gnomonic scale far from the centre makes the sphere excess up to ~25 % larger than the plane theory
    for e, nb in zip(ex, (compass(8), compass(16), compass(32)), strict=True):
        assert nb.excess_for_direction(22.5) * 0.9 < e < nb.excess_for_direction(22.5) * 1.3


# --------------------------------------------------------- exactness and A*
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_astar_and_dijkstra_equal_cost_on_time_varying_fields(small_grid, seed):
    field = SpeedField(seed)
    nb = angular_resolution(10.0, 6)
    runs = {
        (m, b, e): shortest_path(small_grid, nb, edge_cost=field.edge_cost, v_max_kn=V, method=m, batched=b, engine=e)
        for m in ("dijkstra", "astar")
        for b in (True, False)
        for e in ENGINES
    }
    costs = [r.cost for r in runs.values()]
    np.testing.assert_allclose(costs, costs[0], rtol=1e-12)
    for e in ENGINES:
        assert runs[("astar", False, e)].expanded < runs[("dijkstra", False, e)].expanded
        assert runs[("astar", True, e)].expanded < runs[("dijkstra", True, e)].expanded
        assert runs[("dijkstra", True, e)].batches < runs[("dijkstra", False, e)].batches
    r = runs[("astar", True, "numpy")]
    np.testing.assert_allclose(np.diff(r.times_h), r.leg_duration_h)
    np.testing.assert_allclose(r.extra["speed_kn"], r.leg_distance_nm / r.leg_duration_h)


def test_cost_objective_astar_equals_dijkstra(small_grid):
    field = SpeedField(7)
    nb = compass(16)
    a = shortest_path(small_grid, nb, edge_cost=field.edge_cost, v_max_kn=V, objective="cost", lambda_t_per_h=2.0)
    d = shortest_path(
        small_grid, nb, edge_cost=field.edge_cost, v_max_kn=V, objective="cost", lambda_t_per_h=2.0, method="dijkstra"
    )
    assert a.cost == pytest.approx(d.cost, rel=1e-12)
    assert a.cost == pytest.approx(a.total_fuel_t + 2.0 * a.arrival_h)
    assert a.expanded < d.expanded


def test_static_weights_match_scipy_compiled_dijkstra(small_grid):
    """A static field: our label-setting search and scipy's csgraph agree on the same graph."""
    field = SpeedField(3)

    def static(lat0, lon0, lat1, lon1, t0):
        return field.edge_cost(lat0, lon0, lat1, lon1, 0.0 * t0)

    nb = angular_resolution(10.0, 6)
    u, v, o = grid_edges(small_grid, nb)
    ev = LegEvaluator(small_grid, nb, edge_cost=static)
    w, _, _, _ = ev.evaluate(u, v, o, np.zeros(u.size))
    n = small_grid.n_nodes
    dist = csgraph.dijkstra(csr_matrix((w, (u, v)), shape=(n, n)), indices=int(small_grid.flat(*small_grid.start)))
    ref = dist[int(small_grid.flat(*small_grid.end))]
    for m in ("astar", "dijkstra"):
        assert shortest_path(small_grid, nb, edge_cost=static, v_max_kn=V, method=m).cost == pytest.approx(
            ref, rel=1e-12
        )


def test_time_dependent_fifo_field_matches_brute_force_label_correcting():
    """Bellman–Ford on arrival times (iterate every edge until nothing changes) is the reference."""
    g = RouteGrid.build((0.0, 0.0), (1.5, 2.5), cell_nm=25.0, margin_nm=40.0)
    field = SpeedField(11, period_h=400.0, vmin=10.0)  # slow change: FIFO on every edge
    nb = compass(16)
    u, v, o = grid_edges(g, nb)
    ev = LegEvaluator(g, nb, edge_cost=field.edge_cost)
    t = np.full(g.n_nodes, np.inf)
    t[int(g.flat(*g.start))] = 0.0
    for _ in range(g.n_nodes):
        src = np.isfinite(t[u])
        dur, _, _, _ = ev.evaluate(u[src], v[src], o[src], t[u[src]])
        cand = np.full(g.n_nodes, np.inf)
        np.minimum.at(cand, v[src], t[u[src]] + dur)
        new = np.minimum(t, cand)
        if np.array_equal(new, t):
            break
        t = new
    for m in ("astar", "dijkstra"):
        for e in ENGINES:
            r = shortest_path(g, nb, edge_cost=field.edge_cost, v_max_kn=V, method=m, engine=e)
            assert r.arrival_h == pytest.approx(t[int(g.flat(*g.end))], rel=1e-12)


# ------------------------------------------------------------ segment form
def test_segment_form_walks_the_cells_in_time(small_grid):
    field = SpeedField(5)
    nb = angular_resolution(10.0, 6)
    r = shortest_path(small_grid, nb, segment_cost=field.piece_cost, v_max_kn=V)
    d = shortest_path(small_grid, nb, segment_cost=field.piece_cost, v_max_kn=V, method="dijkstra")
    assert r.cost == pytest.approx(d.cost, rel=1e-12)
    p = r.extra
    for leg in range(len(r.leg_duration_h)):
        k = p["piece_leg"] == leg
        # pieces on the gnomonic sphere taken to WGS84 by the local factor (geodesy.sphere_to_wgs84): 1e-6
        assert p["piece_length_nm"][k].sum() == pytest.approx(r.leg_distance_nm[leg], rel=1e-6)
        assert p["piece_duration_h"][k].sum() == pytest.approx(r.leg_duration_h[leg], rel=1e-9)
        t = p["piece_t_h"][k]
        np.testing.assert_allclose(t[1:], t[:-1] + p["piece_duration_h"][k][:-1])
        assert t[0] == pytest.approx(r.times_h[leg])
        # piece midpoints lie on the leg's great circle of the gnomonic sphere (the grid's straight line)
        a, b = (r.lat_deg[leg], r.lon_deg[leg]), (r.lat_deg[leg + 1], r.lon_deg[leg + 1])
        plat, plon = p["piece_lat_deg"][k], p["piece_lon_deg"][k]
        d13 = geo.sphere_distance_nm(a[0], a[1], plat, plon) / geo.EARTH_RADIUS_NM
        t13 = np.radians(geo.sphere_initial_course_deg(a[0], a[1], plat, plon))
        t12 = np.radians(geo.sphere_initial_course_deg(a[0], a[1], b[0], b[1]))
        assert np.abs(np.arcsin(np.sin(d13) * np.sin(t13 - t12))).max() * geo.EARTH_RADIUS_NM < 1e-6


def test_segment_form_equals_edge_form_in_calm_water(small_grid):
    nb = compass(32)
    a = shortest_path(small_grid, nb, edge_cost=calm, v_max_kn=V)
    b = shortest_path(small_grid, nb, segment_cost=calm_pieces, v_max_kn=V)
    # the pieces' WGS84 lengths sum to the geodesic's within 1e-6 (geodesy.sphere_to_wgs84)
    assert a.cost == pytest.approx(b.cost, rel=1e-6)


# --------------------------------------------------------------- obstacles
@pytest.mark.parametrize("engine", ENGINES)
def test_obstacle_is_routed_around_and_legs_stay_in_open_water(engine):
    start, end = (0.0, 0.0), (0.0, 6.0)

    def block(lat, lon):
        return ~((np.abs(lat) < 1.0) & (np.abs(lon - 3.0) < 0.5))

    g = RouteGrid.build(start, end, cell_nm=15.0, margin_nm=120.0, navigable=block)
    nb = angular_resolution(10.0, 6)
    r = shortest_path(g, nb, edge_cost=calm, v_max_kn=V, engine=engine)
    free = shortest_path(g.with_navigable(np.ones(g.shape, dtype=bool)), nb, edge_cost=calm, v_max_kn=V)
    assert r.cost > free.cost * 1.005
    # dense re-sampling of every leg: each sample's cell must be navigable (cells, not points: Boeing Fig. 14)
    for k in range(len(r.leg_duration_h)):
        lat, lon = geo.intermediate_points(
            r.lat_deg[k], r.lon_deg[k], r.lat_deg[k + 1], r.lon_deg[k + 1], np.linspace(0, 1, 200)
        )
        i, j = g.nearest_node(lat, lon)
        assert g.navigable[i, j].all()
        # the mask is per cell (its centre): the block shrunk by one cell is never entered
        assert not ((np.abs(lat) < 0.75) & (np.abs(lon - 3.0) < 0.25)).any()


@pytest.mark.parametrize("engine", ENGINES)
def test_a_diagonal_step_cannot_slip_between_two_cells_touching_at_a_corner(engine):
    g = RouteGrid.build((0.0, 0.0), (0.0, 1.0), cell_nm=6.0, extent_nm=(-40, 40, -40, 40))
    mask = np.ones(g.shape, dtype=bool)
    # a wall of cells along the anti-diagonal, only corner-connected, separating start and end
    ci, cj = g.start[0], (g.start[1] + g.end[1]) // 2
    for d in range(-g.ny, g.ny):
        if 0 <= ci + d < g.ny and 0 <= cj - d < g.nx:
            mask[ci + d, cj - d] = False
    with pytest.raises(NoSafePassage):
        shortest_path(g.with_navigable(mask), compass(8), edge_cost=calm, v_max_kn=V, engine=engine)


def test_enclosed_start_raises_no_safe_passage_naming_where_it_stopped():
    start, end = (0.0, 0.0), (0.0, 5.0)

    def moat(lat, lon):
        d = np.hypot(lat, lon)
        return ~((d > 0.6) & (d < 1.0))

    g = RouteGrid.build(start, end, cell_nm=10.0, margin_nm=60.0, navigable=moat)
    with pytest.raises(NoSafePassage, match=r"stopped at node .* nm from the end"):
        shortest_path(g, compass(16), edge_cost=calm, v_max_kn=V)
    g2 = RouteGrid.build(start, end, cell_nm=10.0, margin_nm=60.0, navigable=lambda la, lo: lo > -0.05)
    with pytest.raises(NoSafePassage, match="start"):
        shortest_path(g2.with_navigable(~g2.navigable), compass(8), edge_cost=calm, v_max_kn=V)


def test_infeasible_legs_everywhere_raise_no_safe_passage(small_grid):
    def storm(lat0, lon0, lat1, lon1, t0):
        d, f, ok = calm(lat0, lon0, lat1, lon1, t0)
        return d, f, ok & (lon1 < 24.0)

    with pytest.raises(NoSafePassage):
        shortest_path(small_grid, compass(16), edge_cost=storm, v_max_kn=V)


# ------------------------------------------------------------------ errors
def test_impossible_eta_reports_the_earliest_arrival(small_grid):
    r = shortest_path(small_grid, compass(16), edge_cost=calm, v_max_kn=V)
    with pytest.raises(InfeasibleETA) as exc:
        shortest_path(small_grid, compass(16), edge_cost=calm, v_max_kn=V, eta_h=r.arrival_h - 1.0)
    assert exc.value.earliest_arrival_h == pytest.approx(r.arrival_h)
    assert f"{r.arrival_h:.2f} h" in str(exc.value)


@pytest.mark.parametrize("engine", ["numpy", "numba"])
def test_a_cost_to_go_bound_is_taken_where_consistent_and_refused_where_an_edge_costs_less_than_it_drops(
    small_grid, engine
):
    """A consistent bound (half of λ times the WGS84 distance to the end over v_max, worked here) gives the same
    route; a bound that drops by more than an edge's cost along it raises."""
    field = SpeedField(7)
    nb = compass(16)
    kw = dict(edge_cost=field.edge_cost, v_max_kn=V, objective="cost", lambda_t_per_h=2.0, engine=engine)
    plain = shortest_path(small_grid, nb, **kw)
    end = small_grid.end_latlon
    h = 0.5 * 2.0 / V * geo.distance_nm(small_grid.lat_deg.ravel(), small_grid.lon_deg.ravel(), *end)
    bounded = shortest_path(small_grid, nb, cost_to_go=h, **kw)
    assert bounded.cost == pytest.approx(plain.cost, rel=1e-12)
    np.testing.assert_array_equal(bounded.nodes, plain.nodes)
    bad = np.zeros(small_grid.n_nodes)
    bad[small_grid.flat(*small_grid.start)] = 10.0 * plain.cost  # the start's edges all cost less than that drop
    with pytest.raises(ConfigError, match="cost_to_go"):
        shortest_path(small_grid, nb, cost_to_go=bad, **kw)
    with pytest.raises(ConfigError, match="one finite bound"):
        shortest_path(small_grid, nb, cost_to_go=np.zeros(3), **kw)


@pytest.mark.parametrize("engine", ["numpy", "numba"])
def test_an_edge_cost_floor_is_taken_where_below_every_edges_cost_and_refused_where_an_edge_costs_less(
    small_grid, engine
):
    """Each edge floored at half of λ times its WGS84 length over v_max (worked here, below any cost of the speed
    field) beside the matching cost-to-go: the same route; a floor above an edge's cost, a floor of the wrong shape
    or one without a cost-to-go raise."""
    field = SpeedField(7)
    nb = compass(16)
    kw = dict(edge_cost=field.edge_cost, v_max_kn=V, objective="cost", lambda_t_per_h=2.0, engine=engine)
    plain = shortest_path(small_grid, nb, **kw)
    lat, lon = small_grid.lat_deg.ravel(), small_grid.lon_deg.ravel()
    h = 0.5 * 2.0 / V * geo.distance_nm(lat, lon, *small_grid.end_latlon)
    ny, nx = small_grid.shape
    ii, jj = np.divmod(np.arange(small_grid.n_nodes), nx)
    floor = np.zeros((small_grid.n_nodes, nb.offsets.shape[0]))
    for q, (di, dj) in enumerate(nb.offsets):
        i2, j2 = ii + di, jj + dj
        on = (i2 >= 0) & (i2 < ny) & (j2 >= 0) & (j2 < nx)
        k = np.flatnonzero(on)
        floor[k, q] = 0.5 * 2.0 / V * geo.distance_nm(lat[k], lon[k], lat[i2[k] * nx + j2[k]], lon[i2[k] * nx + j2[k]])
    floored = shortest_path(small_grid, nb, cost_to_go=h, edge_cost_floor=floor, **kw)
    assert floored.cost == pytest.approx(plain.cost, rel=1e-12)
    np.testing.assert_array_equal(floored.nodes, plain.nodes)
    bad = floor.copy()
    bad[small_grid.flat(*small_grid.start)] = 10.0 * plain.cost  # above every edge out of the start
    with pytest.raises(ConfigError, match="edge_cost_floor"):
        shortest_path(small_grid, nb, cost_to_go=h, edge_cost_floor=bad, **kw)
    with pytest.raises(ConfigError, match="one finite bound >= 0 per grid node and offset"):
        shortest_path(small_grid, nb, cost_to_go=h, edge_cost_floor=floor[:, :3], **kw)
    with pytest.raises(ConfigError, match="pass cost_to_go with it"):
        shortest_path(small_grid, nb, edge_cost_floor=floor, **kw)


def test_callback_contract_is_enforced(small_grid):
    nb = compass(8)
    with pytest.raises(ConfigError, match="v_max_kn"):
        shortest_path(small_grid, nb, edge_cost=calm, v_max_kn=V / 2)
    with pytest.raises(ConfigError, match="exactly one"):
        shortest_path(small_grid, nb, edge_cost=calm, segment_cost=calm_pieces, v_max_kn=V)
    with pytest.raises(ConfigError, match="return"):
        shortest_path(small_grid, nb, edge_cost=lambda *a: 1.0, v_max_kn=V)
    with pytest.raises(ConfigError, match="duration_h"):
        shortest_path(small_grid, nb, edge_cost=lambda a, b, c, d, t: (-t - 1, t, np.ones(t.shape, bool)), v_max_kn=V)
    with pytest.raises(ConfigError, match="method"):
        shortest_path(small_grid, nb, edge_cost=calm, v_max_kn=V, method="bfs")
    with pytest.raises(ConfigError, match="engine"):
        shortest_path(small_grid, nb, edge_cost=calm, v_max_kn=V, engine="cuda")
