"""search_route: the physics wiring of the grid search and the 3-D DP, against independent references.

References: the great-circle distance and the ship's own calm-water power and
SFOC (calm water); the two-direction mixing theory of lattice paths; Dijkstra
for A* (the same labels); an independent dense re-sampling of the weather
along every returned leg, at the time the ship is there, checked with
:func:`optroute.physics.safety.is_speed_forbidden` at the speed sailed there; the
constant-speed fuel optimum worked by hand from ``calm_power_kw`` and
``fuel_rate_tph``; the scenarios' exact no-go rectangles
(:func:`~optroute.weather.scenarios.in_no_go_area`); and the time-optimal
route's fuel.

Ports in open water are never moved by the snapping; the tests that use them
pass ``snap_max_nm=400`` (``OPEN_SEA``) only because the snapping's candidate
grid is then coarse and cheap (at the default radius it costs seconds per port).
"""

import re
import warnings

import numpy as np
import pytest

import optroute as orx
from optroute import geodesy as geo
from optroute.errors import ConfigError, InfeasibleETA, NoSafePassage, WeatherCoverageError
from optroute.geo import land
from optroute.physics.performance import default_model
from optroute.physics.safety import BandRules, band_margins, is_speed_forbidden
from optroute.search import RouteGrid, angular_resolution, compass, dp_route, routing, shortest_path
from optroute.search.routing import PassagePhysics, search_route
from optroute.weather import WeatherSampler, scenarios
from optroute.weather.schema import canonical_dataset

T0 = np.datetime64("2024-03-01T00:00", "ns")
OPEN_SEA = {"snap_max_nm": 400.0}
CARGO = orx.Ship.preset("general_cargo_25k_dwt")  # L 170 m: the bands apply where Hs >= 6.8 m


def _h(hours):
    return (np.asarray(hours, dtype=float) * 3.6e12).astype("timedelta64[ns]")


def _hours(route):
    return (route.times - route.times[0]) / np.timedelta64(1, "h")


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ports snapped to open water, with a warning
        return fn(*args, **kwargs)


def random_sea(seed, *, hs_m=(1.0, 9.0), current_ms=0.0, bbox=(-12.0, 14.0, 146.0, 178.0), hours=240.0):
    """Smooth random (seeded) fields of Hs, peak period, wave direction, wind and current, changing in time.

    Each field is a mean of four plane waves in (lat, lon, t) with random
    wavenumbers (wavelengths >= 25° and periods >= 125 h) on a 0.5° x 6 h grid.
    """
    rng = np.random.default_rng(seed)
    lat = np.arange(bbox[0], bbox[1] + 1e-9, 0.5)
    lon = np.arange(bbox[2], bbox[3] + 1e-9, 0.5)
    hr = np.arange(0.0, hours + 1e-9, 6.0)
    t, la, lo = np.meshgrid(hr, lat, lon, indexing="ij")

    def smooth():
        k = rng.uniform(-0.25, 0.25, (4, 2))
        w = rng.uniform(-0.05, 0.05, 4)
        ph = rng.uniform(0.0, 2.0 * np.pi, 4)
        return sum(np.sin(k[i, 0] * lo + k[i, 1] * la + w[i] * t + ph[i]) for i in range(4)) / 4.0

    hs = hs_m[0] + (hs_m[1] - hs_m[0]) * np.clip(0.5 + 1.2 * smooth(), 0.0, 1.0)
    wave_from = np.mod(200.0 + 150.0 * smooth(), 360.0)
    wind = 2.0 * np.sqrt(hs)
    variables = {
        "hs_m": hs,
        "tp_s": 10.5 + 2.5 * smooth(),
        "wave_from_deg": wave_from,
        "wind_u_ms": -wind * np.sin(np.radians(wave_from)),
        "wind_v_ms": -wind * np.cos(np.radians(wave_from)),
    }
    if current_ms:
        variables["current_u_ms"] = current_ms * smooth()
        variables["current_v_ms"] = current_ms * smooth()
    time = T0 + _h(hr)
    return canonical_dataset(time, lat, lon, variables, {"geography": "synthetic", "source": f"random_sea({seed})"})


def _course_along(lat, lon, leg_start, leg_end):
    """Course of the great circle from ``leg_start`` to ``leg_end`` at points on it [deg true]."""
    final = geo.initial_course_deg(*leg_end, *leg_start) + 180.0
    far_lat, far_lon = geo.destination(*leg_end, final, 60.0)  # beyond the end, on the same great circle
    return geo.initial_course_deg(lat, lon, far_lat, far_lon)


def dense_legs(route, step_nm, speed_and_time):
    """Points every <= ``step_nm`` along every leg (its great circle, from the waypoints), with heading, speed, time.

    ``speed_and_time(k, s)`` gives the speed through water [kn] and the time
    [h from departure] at along-leg distances ``s`` [nm] of leg ``k``.
    """
    out = {k: [] for k in ("lat", "lon", "heading", "stw", "t_h")}
    for k in range(route.distance_nm.size):
        a, b = route.waypoints[k], route.waypoints[k + 1]
        d = route.distance_nm[k]
        s = np.linspace(0.0, d, int(np.ceil(d / step_nm)) + 1)
        lat, lon = geo.intermediate_points(*a, *b, s / d)
        stw, t_h = speed_and_time(k, s)
        for key, val in zip(out, (lat, lon, _course_along(lat, lon, a, b), stw, t_h), strict=True):
            out[key].append(np.broadcast_to(val, s.shape))
    return {k: np.concatenate(v) for k, v in out.items()}


def grid_route_points(route, step_nm=2.5):
    """Dense points of a grid-search route; speed and time from its piece records (``stats["pieces"]``).

    A point at along-leg distance s lies in the piece covering s; the ship
    passes it at the piece's entry time plus the covered fraction of its
    duration (constant speed within a piece).
    """
    pc = route.stats["pieces"]
    hours = _hours(route)

    def speed_and_time(k, s):
        sel = np.flatnonzero(pc["leg"] == k)
        sel = sel[np.argsort(pc["index"][sel])]
        length = pc["length_nm"][sel]
        edges = np.concatenate([[0.0], np.cumsum(length)])
        # the pieces tile the leg, and their clock runs from the leg's first waypoint to its last
        # (to 1e-6: each piece is taken from the gnomonic sphere to WGS84 by the local factor, geodesy.sphere_to_wgs84)
        assert edges[-1] == pytest.approx(route.distance_nm[k], rel=1e-6)
        assert pc["t_h"][sel[0]] == pytest.approx(hours[k], abs=1e-6)
        assert pc["t_h"][sel[-1]] + pc["duration_h"][sel[-1]] == pytest.approx(hours[k + 1], abs=1e-6)
        j = np.clip(np.searchsorted(edges, s, side="right") - 1, 0, sel.size - 1)
        frac = np.clip((s - edges[j]) / length[j], 0.0, 1.0)
        return pc["stw_kn"][sel][j], pc["t_h"][sel][j] + frac * pc["duration_h"][sel][j]

    return dense_legs(route, step_nm, speed_and_time)


def dp_route_points(route, step_nm=2.5):
    """Dense points of a DP route: each leg at its commanded speed (no current: STW = SOG), linear in time."""
    hours = _hours(route)
    return dense_legs(
        route, step_nm, lambda k, s: (route.sog_kn[k], hours[k] + s / route.distance_nm[k] * route.duration_h[k])
    )


def band_check(pts, wx, ship):
    """Independent check: sample the weather where and when the ship is; forbidden flags, min margins and Hs."""
    sea = WeatherSampler(wx).sample(T0 + _h(pts["t_h"]), pts["lat"], pts["lon"])
    kw = dict(
        speed_kn=pts["stw"],
        hs_m=sea["hs_m"],
        period_s=sea["tp_s"],
        wave_from_deg=sea["wave_from_deg"],
        heading_deg=pts["heading"],
        rules=BandRules(),
    )
    margin = np.min([b.margin for b in band_margins(ship, **kw).values()], axis=0)
    return is_speed_forbidden(ship, **kw), margin, sea["hs_m"]


# ------------------------------------------------------------------------------------------- 1. calm water
@pytest.fixture(scope="module")
def calm_pacific():
    return scenarios.calm(bbox=(10.0, 65.0, 110.0, -100.0), start=T0, duration_h=400.0, resolution_deg=5.0)


def test_calm_san_diego_tokyo_is_the_great_circle_at_design_speed_and_calm_fuel(calm_pacific):
    ship = orx.Ship.preset("container_8000teu")
    # without the coastline the ports stay where they are and the route is their great circle
    r = search_route(scenarios.SAN_DIEGO, scenarios.TOKYO, calm_pacific, ship, departure=T0, cell_nm=80.0,
                     use_land_mask=False)  # fmt: skip
    np.testing.assert_allclose(r.waypoints[[0, -1]], [scenarios.SAN_DIEGO, scenarios.TOKYO], atol=1e-9)
    np.testing.assert_allclose(r.stats["ends_moved_nm"], 0.0, atol=1e-9)
    gc = float(geo.distance_nm(*scenarios.SAN_DIEGO, *scenarios.TOKYO))
    assert gc * (1 - 1e-9) <= r.total_distance_nm <= gc * 1.005
    # calm sea: the design speed all the way, the calm-water power and SFOC of the ship
    # the pieces' WGS84 lengths (local factor) sum to the legs' geodesic lengths within 1e-6
    assert r.total_duration_h == pytest.approx(r.total_distance_nm / ship.design_speed_kn, rel=1e-6)
    fuel_rate = float(ship.fuel_rate_tph(ship.calm_power_kw(ship.design_speed_kn)))
    assert r.total_fuel_t == pytest.approx(fuel_rate * r.total_duration_h, rel=1e-9)
    np.testing.assert_allclose(r.stw_kn, ship.design_speed_kn, rtol=1e-12)
    assert r.cost == pytest.approx(r.total_duration_h)
    assert np.all((r.waypoints[:, 1] >= -180.0) & (r.waypoints[:, 1] < 180.0))  # across the antimeridian
    # with it, the ports (on land by GLOBE) are snapped to open water, PORT_CLEARANCE_NM of it about them (not half
    # a cell: the legs are walked on the coastline), and the route keeps off the land between them
    land_r = _quiet(search_route, scenarios.SAN_DIEGO, scenarios.TOKYO, calm_pacific, ship, departure=T0, cell_nm=80.0)
    a, b = land_r.waypoints[0], land_r.waypoints[-1]
    moved = [geo.distance_nm(*scenarios.SAN_DIEGO, *a), geo.distance_nm(*scenarios.TOKYO, *b)]
    np.testing.assert_allclose(land_r.stats["ends_moved_nm"], moved, rtol=1e-12)
    assert land_r.stats["ends_clearance_nm"] == routing.PORT_CLEARANCE_NM < 40.0
    assert 0.0 < min(moved) and max(moved) <= 20.0 + 2 * 80.0
    assert land_r.stats["legs_crossing_land"] == [] and not land.is_land(*np.transpose(land_r.waypoints)).any()


def test_ports_a_grid_cannot_leave_are_snapped_half_a_cell_out(calm_pacific, monkeypatch):
    """With 2 nm of clearance Tokyo is snapped inside Tokyo Bay, where no edge of a 120 nm lattice leaves it (the
    Uraga channel is 4 nm wide): the search then snaps the ports half a cell out, as it did before
    PORT_CLEARANCE_NM, and says so in its stats."""
    ship = orx.Ship.preset("container_8000teu")
    monkeypatch.setattr(routing, "PORT_CLEARANCE_NM", 2.0)
    r = _quiet(search_route, scenarios.SAN_DIEGO, scenarios.TOKYO, calm_pacific, ship, departure=T0, cell_nm=120.0)
    assert r.stats["ends_clearance_nm"] == 60.0
    assert r.stats["ends_moved_nm"][1] > 60.0 and r.stats["legs_crossing_land"] == []


def test_calm_direction_sets_follow_the_mixing_theory():
    """The physics callback search_route uses, on a grid turned 22.5° off the voyage (search_route lays the
    great circle along a grid row, where every set is exact): 8 > 16 > 32 > 5°, as the two-direction mix says."""
    ship = orx.Ship.preset("container_54k_dwt")
    wx = scenarios.calm(bbox=(35.0, 45.0, -35.0, -20.0), start=T0, duration_h=100.0, resolution_deg=5.0)
    physics = PassagePhysics(ship, default_model(ship), BandRules(), WeatherSampler(wx), T0)
    start, end = (40.0, -30.0), (41.0, -25.0)  # 240 nm: the gnomonic scale is within 0.1 % of 1
    cb = physics.segment_time(ship.design_speed_kn, 0.5, 3.0, 10.0)
    excess, theory = [], []
    for nb in (compass(8), compass(16), compass(32), angular_resolution(5.0)):
        g = RouteGrid.build(start, end, cell_nm=6.0, margin_nm=30.0, route_angle_deg=22.5)
        angle = np.degrees(np.arctan2(g.end[0] - g.start[0], g.end[1] - g.start[1]))
        r = shortest_path(g, nb, segment_cost=cb, v_max_kn=ship.design_speed_kn + 1e-6)
        assert r.arrival_h == pytest.approx(
            r.distance_nm / ship.design_speed_kn, rel=1e-6
        )  # pieces on WGS84 within 1e-6
        excess.append(r.distance_nm / float(geo.distance_nm(*start, *end)) - 1.0)
        theory.append(nb.excess_for_direction(angle))
        assert excess[-1] <= nb.worst_case_excess() + 2e-3
    assert excess[0] > excess[1] > excess[2] > excess[3] >= -1e-9
    np.testing.assert_allclose(excess, theory, rtol=0.05, atol=3e-4)


# ------------------------------------------------------------------------------ 2. A* and Dijkstra
def test_astar_and_dijkstra_agree_on_random_time_varying_weather():
    wx = random_sea(11, hs_m=(1.0, 9.0), current_ms=0.6)
    kw = dict(departure=T0, cell_nm=50.0, **OPEN_SEA)
    a = search_route((-2.0, 150.0), (3.0, 165.0), wx, CARGO, method="astar", **kw)
    d = search_route((-2.0, 150.0), (3.0, 165.0), wx, CARGO, method="dijkstra", **kw)
    assert a.cost == pytest.approx(d.cost, rel=1e-9)
    assert a.stats["expanded"] < d.stats["expanded"]
    # the weather mattered: not the calm great circle at the desired speed
    calm_h = float(geo.distance_nm(*a.waypoints[0], *a.waypoints[-1])) / CARGO.design_speed_kn
    assert a.cost > calm_h * 1.01


# ------------------------------------------------------------------------------- 3. danger bands
@pytest.fixture(scope="module")
def rough():
    """Seas over the band threshold (6.8 m) on most of the area: every leg must keep out of the bands."""
    return random_sea(4, hs_m=(6.0, 10.0))


ROUGH_VOYAGE = ((-2.0, 150.0), (3.0, 166.0))


@pytest.mark.parametrize("objective", ["time", "cost"])
def test_every_grid_leg_keeps_out_of_the_bands_on_dense_resampling(rough, objective):
    kw = dict(lambda_t_per_h=0.3) if objective == "cost" else {}
    r = search_route(*ROUGH_VOYAGE, rough, CARGO, departure=T0, objective=objective, cell_nm=60.0, **kw, **OPEN_SEA)
    pc = r.stats["pieces"]
    np.testing.assert_allclose(pc["heading_deg"], pc["course_deg"], atol=1e-9)  # no current: heading = course
    if objective == "time":
        assert pc["stw_kn"].min() < CARGO.design_speed_kn  # it had to slow down somewhere
    pts = grid_route_points(r, step_nm=2.5)
    forbidden, margin, hs = band_check(pts, rough, CARGO)
    applies = hs >= 0.04 * CARGO.length_m
    assert applies.mean() > 0.3  # the bands bind on much of the route
    assert forbidden.sum() == 0, f"{forbidden.sum()} of {forbidden.size} points in a band, worst margin {margin.min()}"


def test_band_threshold_crossing_between_check_points():
    """Just past where Hs reaches the bands' threshold a speed allowed at two check points 10 nm apart can sit in
    a band for ~3 nm between them (issue 14 item 1): the search checks between them where the referee looks
    (optroute.search.band_refine), so resampling every 1 nm finds no point in a band."""
    wx = random_sea(3, hs_m=(2.0, 10.0))
    r = search_route(*ROUGH_VOYAGE, wx, CARGO, departure=T0, cell_nm=30.0, **OPEN_SEA)
    forbidden, margin, _ = band_check(grid_route_points(r, step_nm=1.0), wx, CARGO)
    assert forbidden.sum() == 0, f"{forbidden.sum()} of {forbidden.size} points in a band, worst margin {margin.min()}"


def test_midpoint_only_evaluation_crosses_bands_between_midpoints(rough):
    """Why ``band_check_nm`` exists: Boeing's one sea state per cell picks the fastest speed allowed at the
    piece's midpoint, often right at a band's edge, and the band moves across the piece."""
    r = search_route(*ROUGH_VOYAGE, rough, CARGO, departure=T0, cell_nm=60.0, band_check_nm=None, **OPEN_SEA)
    forbidden, margin, _ = band_check(grid_route_points(r, step_nm=2.5), rough, CARGO)
    assert forbidden.sum() > 0 and margin.min() < 0


def test_every_dp_leg_keeps_out_of_the_bands_on_dense_resampling(rough):
    r = search_route(
        *ROUGH_VOYAGE,
        rough,
        CARGO,
        departure=T0,
        method="dp",
        objective="fuel",
        eta=T0 + _h(120.0),
        speeds_kn=np.arange(6.0, 15.0, 1.0),
        dp_options=dict(dx_nm=120, dy_nm=60, half_width_nm=180, dt_h=2, piece_nm=10),
    )
    assert r.arrival <= T0 + _h(120.0)
    forbidden, margin, hs = band_check(dp_route_points(r, step_nm=2.5), rough, CARGO)
    assert (hs >= 0.04 * CARGO.length_m).mean() > 0.3
    assert forbidden.sum() == 0, f"{forbidden.sum()} of {forbidden.size} points in a band, worst margin {margin.min()}"


# ------------------------------------------------------------------------ 4. DP against the analytic optimum
def test_dp_converges_to_the_constant_speed_optimum_in_calm_water():
    """D nm in T h: with a convex fuel rate F(v) and F(v)/v increasing, no speed profile and no longer path beats
    sailing the great circle at D/T; F is the ship's calm power through its SFOC, worked here by hand.  What is
    left at the finest speed step is the mix of set speeds over 7 equal stages that arrives just in time."""
    ship = orx.Ship.preset("container_54k_dwt")
    wx = scenarios.calm(bbox=(-10.0, 10.0, -45.0, -15.0), start=T0, duration_h=150.0, resolution_deg=5.0)
    start, end = (0.0, -40.0), (0.0, -20.0)
    dist = float(geo.distance_nm(*start, *end))
    eta_h = 70.0
    v = np.arange(ship.calm_speed_kn(ship.min_power_kw), 26.0, 0.05)
    rate = ship.fuel_rate_tph(ship.calm_power_kw(v))
    assert np.diff(rate, 2).min() > 0 and np.diff(rate / v).min() > 0  # the premises of the bound
    best = float(ship.fuel_rate_tph(ship.calm_power_kw(dist / eta_h))) * eta_h
    gaps = []
    for dv, dy in ((2.0, 60.0), (1.0, 40.0), (0.5, 30.0), (0.25, 20.0)):
        r = search_route(
            start,
            end,
            wx,
            ship,
            departure=T0,
            method="dp",
            objective="fuel",
            eta=T0 + _h(eta_h),
            use_land_mask=False,
            speeds_kn=np.arange(13.0, 24.01, dv),
            dp_options=dict(dx_nm=200, dy_nm=dy, half_width_nm=60, dt_h=0.25, piece_nm=400),
        )
        assert r.arrival <= T0 + _h(eta_h)
        np.testing.assert_allclose(r.waypoints[:, 0], 0.0, atol=1e-9)  # uniform weather: the great circle
        assert r.total_fuel_t >= best * (1 - 1e-9)
        gaps.append(r.total_fuel_t / best - 1.0)
    assert np.all(np.diff(gaps) <= 1e-12) and gaps[0] > 4 * gaps[-1]
    assert gaps[-1] < 0.003


def test_dp_goes_round_land_like_the_grid_search():
    """West of Sri Lanka to east of it: the great circle crosses the island; the DP's route keeps to the sea
    (GLOBE coastline, checked every 2 nm independently of the DP's own no-go checks)."""
    ship = orx.Ship.preset("container_54k_dwt")
    wx = scenarios.calm(bbox=(-5.0, 20.0, 70.0, 95.0), start=T0, duration_h=100.0, resolution_deg=5.0)
    start, end = (6.0, 79.0), (8.0, 82.5)
    assert land.is_land(*geo.great_circle_points(*start, *end, 50)).any()
    r = search_route(start, end, wx, ship, departure=T0, method="dp", objective="fuel",
                     speeds_kn=np.arange(12.0, 20.1, 2.0),
                     dp_options=dict(dx_nm=40, dy_nm=20, half_width_nm=120, dt_h=1, piece_nm=10))  # fmt: skip
    pts = dp_route_points(r, step_nm=2.0)
    assert not land.is_land(pts["lat"], pts["lon"]).any()


def _land_points(wp, step_nm):
    """Per leg of ``wp``, the GLOBE land points on its great circle every ``step_nm`` or less (independent of the
    search's own walk: :func:`optroute.geodesy.great_circle_points` and :func:`optroute.geo.land.is_land`)."""
    out = []
    for k in range(len(wp) - 1):
        n = int(np.ceil(float(geo.distance_nm(*wp[k], *wp[k + 1])) / step_nm)) + 1
        out.append(int(land.is_land(*geo.great_circle_points(*wp[k], *wp[k + 1], n)).sum()))
    return out


def test_dp_legs_keep_off_islands_between_their_states(monkeypatch):
    """San Diego towards Point Conception on a 20 nm x 10 nm lattice: the Channel Islands lie between lattice
    states whose no-go samples (every 10 nm) are at sea. The DP walks every leg on the coastline, so its route
    touches no land (GLOBE every 0.05 nm along each leg, independent sampling); without the walk the least-fuel
    route crosses an island on a leg."""
    ship = orx.Ship.preset("container_8000teu")
    wx = scenarios.calm(bbox=(27.0, 40.0, -126.0, -112.0), start=T0, duration_h=100.0, resolution_deg=1.0)
    start, end = (32.7, -117.4604), (34.3, -121.0)
    kw = dict(
        departure=T0,
        method="dp",
        objective="fuel",
        eta=T0 + np.timedelta64(16, "h"),
        speeds_kn=np.arange(14.0, 20.1, 3.0),
        dp_options=dict(dx_nm=20, dy_nm=10, half_width_nm=60, piece_nm=5),
    )
    r = search_route(start, end, wx, ship, **kw)
    assert not any(_land_points(r.waypoints, 0.05))
    np.testing.assert_allclose(r.stats["ends_moved_nm"], [geo.distance_nm(*start, *r.waypoints[0]),
                                                          geo.distance_nm(*end, *r.waypoints[-1])], atol=1e-9)  # fmt: skip
    monkeypatch.setattr(dp_route, "legs_on_land", lambda *legs: np.zeros(np.broadcast(*legs).shape, dtype=bool))
    bare = search_route(start, end, wx, ship, **kw)
    assert any(_land_points(bare.waypoints, 0.05))
    assert bare.total_fuel_t <= r.total_fuel_t


def test_grid_routes_keep_off_islands_between_their_nodes(monkeypatch):
    """San Diego towards Point Conception on 20 nm cells: the Channel Islands lie between open-water nodes. The
    grid search walks each leg across a coastal cell on the coastline, so its route touches no land (GLOBE every
    0.05 nm along each leg); the compiled (lazy) loop and the Python loop find the same route. Without the walk
    (a coastline with no packed cells) the route crosses the islands: it names exactly those legs (against the
    same independent sampling) and warns, and plan_voyage, whose ±2 nm corridor about it is then closed by an
    island, says so instead of advising plan_voyage."""
    ship = orx.Ship.preset("container_8000teu")
    wx = scenarios.calm(bbox=(27.0, 40.0, -126.0, -112.0), start=T0, duration_h=100.0, resolution_deg=1.0)
    start, end = (32.7, -117.4604), (34.3, -121.0)
    kw = dict(departure=T0, objective="time", cell_nm=20.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = search_route(start, end, wx, ship, **kw)
    assert r.stats["legs_crossing_land"] == [] and not any(_land_points(r.waypoints, 0.05))
    # the Python loop (batched, its edges tested as they are generated) settles the same route
    inner = routing.shortest_path

    def python_loop(*args, **kwargs):
        cb = kwargs["segment_cost"]

        def plain(*a):
            return cb(*a)

        plain.leg_batch = cb.leg_batch
        return inner(*args, **{**kwargs, "segment_cost": plain})

    with monkeypatch.context() as m:
        m.setattr(routing, "shortest_path", python_loop)
        slow = search_route(start, end, wx, ship, **kw)
    np.testing.assert_array_equal(slow.waypoints, r.waypoints)
    assert slow.total_duration_h == pytest.approx(r.total_duration_h, rel=1e-12)
    # without the walk
    monkeypatch.setattr(routing.EdgeLand, "build", classmethod(lambda cls, grid, **k: None))
    with pytest.warns(UserWarning, match="crosses land between its grid nodes"):
        bare = search_route(start, end, wx, ship, **kw)
    on_land = [k for k, n in enumerate(_land_points(bare.waypoints, 0.05)) if n]
    assert on_land and bare.stats["legs_crossing_land"] == on_land
    with pytest.warns(UserWarning, match="crosses land"), pytest.raises(NoSafePassage) as err:
        orx.plan_voyage(start, end, wx, ship, departure=T0, objective="time", corridor_width_nm=4.0,
                        search_options={"cell_nm": 20.0})  # fmt: skip
    text = str(err.value)
    assert f"crosses land between its grid nodes on legs {on_land}" in text and "plan_voyage" not in text


def test_dp_leg_cost_does_not_depend_on_the_legs_it_is_batched_with(rough):
    """A leg is cut into its own number of pieces: costed alone or beside a 10x longer leg, the same answer."""
    physics = PassagePhysics(CARGO, default_model(CARGO), BandRules(), WeatherSampler(rough), T0)
    leg = physics.dp_leg(10.0)
    short = [np.array([v]) for v in (0.0, 150.0, 1.0, 151.5, 12.0, 9.0)]  # lat0, lon0, lat1, lon1, t0 [h], SOG [kn]
    both = [np.array([v, w]) for v, w in zip((0.0, 150.0, 1.0, 151.5, 12.0, 9.0), (-5.0, 150.0, 5.0, 165.0, 0.0, 9.0),
                                             strict=True)]  # fmt: skip
    alone, batched = leg(*short), leg(*both)
    for a, b in zip(alone[:3], batched[:3], strict=True):
        np.testing.assert_allclose(a, b[:1], rtol=1e-12)


# ------------------------------------------------------------------------------ 5. Shao's case studies
SHAO_DP = dict(dx_nm=540, dy_nm=150, half_width_nm=600, dt_h=3, piece_nm=120, max_lateral_step=2)


@pytest.mark.parametrize("case", [1, 2])
def test_shao_cases_give_a_fuel_eta_curve_and_avoid_the_no_go_areas(case, request):
    ship = orx.Ship.preset("container_54k_dwt")
    wx = request.getfixturevalue(f"shao_case_{case}")  # scenarios.shao_case(case), the session's copy
    t0 = wx.time.values[0]
    start, end = scenarios.SHAO_START_END
    eta = t0 + _h(264.0)
    r = search_route(start, end, wx, ship, departure=t0, method="dp", objective="fuel", eta=eta,
                     speeds_kn=np.arange(8.0, 27.0, 2.0), dp_options=SHAO_DP)  # fmt: skip
    fuel, bin_end = r.stats["curve_fuel_t"], r.stats["curve_bin_end_h"]
    ok = np.isfinite(fuel)
    assert ok.sum() >= 10
    assert np.all(np.diff(fuel[ok]) <= 1e-9)  # non-increasing in the ETA
    assert fuel[ok][-1] < 0.7 * fuel[ok][0]  # slow steaming: the latest arrival burns far less than the earliest
    assert bin_end[ok][0] >= r.stats["earliest_arrival_h"] - 1e-9
    assert r.arrival <= eta
    curve_at_eta = fuel[np.searchsorted(bin_end, 264.0 - 1e-9)]
    assert r.total_fuel_t == pytest.approx(curve_at_eta, rel=1e-9)
    # the exact moving rectangles, densely along the route at the times the ship is there
    pts = dp_route_points(r, step_nm=5.0)
    assert not scenarios.in_no_go_area(wx, pts["lat"], pts["lon"], t0 + _h(pts["t_h"])).any()
    # the great circle (the equator) runs through the islands (lat -1..7, lon 50..70): the route goes round them
    across = (pts["lon"] >= 50.0) & (pts["lon"] <= 70.0)
    assert across.any() and np.all((pts["lat"][across] < -1.0) | (pts["lat"][across] > 7.0))


# ------------------------------------------------------------------------------------ 6. bad input
def _ring_sea(centre, inner_deg, outer_deg, *, hs_ring=None):
    """2 m seas, with a ring around ``centre`` of land (NaN: no passage) or of ``hs_ring`` m seas."""
    lat = np.arange(-10.0, 10.01, 0.25)
    lon = np.arange(140.0, 170.01, 0.25)
    time = T0 + _h(np.arange(0.0, 241.0, 6.0))
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    r = np.hypot(la - centre[0], (lo - centre[1]) * np.cos(np.radians(centre[0])))
    ring = (r >= inner_deg) & (r <= outer_deg)
    hs = np.where(ring, np.nan if hs_ring is None else hs_ring, 2.0)
    tp = np.where(np.isnan(hs), np.nan, 10.0)
    wave_from = np.where(np.isnan(hs), np.nan, 45.0)
    return canonical_dataset(time, lat, lon, {"hs_m": hs[None], "tp_s": tp[None], "wave_from_deg": wave_from[None]},
                             {"geography": "synthetic"})  # fmt: skip


def _plain_sea():
    return _ring_sea((5.0, 145.0), 0.5, 0.6, hs_ring=2.0)  # 2 m seas everywhere


def _stopped_at(message):
    m = re.search(r"stopped at node \(\d+, \d+\) = \((-?[\d.]+), (-?[\d.]+)\), ([\d.]+) nm from the end", message)
    assert m, message
    return float(m[1]), float(m[2]), float(m[3])


def test_start_enclosed_by_land_names_where_the_search_stopped():
    start, end = (0.0, 150.0), (2.0, 160.0)
    wx = _ring_sea(start, 1.5, 2.0)
    with pytest.raises(NoSafePassage) as err:
        search_route(start, end, wx, CARGO, departure=T0, cell_nm=30.0, **OPEN_SEA)
    lat, lon, _ = _stopped_at(str(err.value))
    assert geo.distance_nm(*start, lat, lon) < 1.5 * 60.0  # inside the ring, where the search was shut in


def test_end_enclosed_by_seas_no_speed_survives_names_where_the_search_stopped():
    """The bands widened to ±90 % forbid every speed wherever they apply (Hs 8 m >= 0.04 L): a ring of such
    seas round the end lets no ship through, although the water is open."""
    start, end = (0.0, 150.0), (2.0, 160.0)
    wx = _ring_sea(end, 1.0, 1.5, hs_ring=8.0)
    rules = BandRules(margin=0.9)
    with pytest.raises(NoSafePassage) as err:
        search_route(start, end, wx, CARGO, departure=T0, cell_nm=30.0, rules=rules, **OPEN_SEA)
    lat, lon, from_end = _stopped_at(str(err.value))
    assert 1.5 * 60.0 - 30.0 < from_end < 2.0 * 60.0  # just outside the ring (the 30 nm cells blur its edge)
    assert from_end == pytest.approx(float(geo.distance_nm(lat, lon, *end)), abs=1.0)
    # the same seas under the patent's ±20 % bands leave speeds to sail through
    assert search_route(start, end, wx, CARGO, departure=T0, cell_nm=30.0, **OPEN_SEA).arrival > T0


def test_impossible_eta_gives_the_earliest_arrival_as_a_time():
    wx = _plain_sea()
    start, end = (0.0, 150.0), (2.0, 160.0)
    eta = T0 + _h(10.0)
    for kw in (dict(cell_nm=30.0, **OPEN_SEA),
               dict(method="dp", objective="fuel", dp_options=dict(dx_nm=150, dy_nm=60, half_width_nm=60))):  # fmt: skip
        with pytest.raises(InfeasibleETA) as err:
            search_route(start, end, wx, CARGO, departure=T0, eta=eta, **kw)
        early = err.value.earliest_arrival
        assert isinstance(early, np.datetime64) and early > eta
        # no ship makes the distance faster than at its top calm speed
        fastest_h = float(geo.distance_nm(*start, *end)) / CARGO.max_calm_speed_kn
        assert early >= T0 + _h(fastest_h)


def test_departure_outside_the_weather_and_eta_before_departure_are_clear_errors():
    wx = _plain_sea()
    start, end = (0.0, 150.0), (2.0, 160.0)
    for dep in (T0 - _h(24.0), T0 + _h(500.0)):
        with pytest.raises(WeatherCoverageError, match="outside the weather's time span"):
            search_route(start, end, wx, CARGO, departure=dep, cell_nm=30.0)
    with pytest.raises(ConfigError, match="not after departure"):
        search_route(start, end, wx, CARGO, departure=T0 + _h(24.0), eta=T0 + _h(12.0), cell_nm=30.0)


@pytest.mark.parametrize(
    ("price", "hourly", "named"),
    [(0.0, 1000.0, "fuel_price_per_t"), (-5.0, 100.0, "fuel_price_per_t"), (float("nan"), 1.0, "fuel_price_per_t"),
     (600.0, -3.0, "hourly_cost_per_h")],
)  # fmt: skip
def test_the_cost_objective_names_a_bad_fuel_price_or_hourly_cost(price, hourly, named):
    # λ = hourly cost / fuel price: a zero price was a ZeroDivisionError, a negative one an error about "lambda"
    with pytest.raises(ConfigError, match=rf"^{named} .*; give ") as err:
        search_route((0.0, 150.0), (2.0, 160.0), _plain_sea(), CARGO, departure=T0, objective="cost",
                     fuel_price_per_t=price, hourly_cost_per_h=hourly, cell_nm=30.0)  # fmt: skip
    assert "lambda" not in str(err.value)


# ----------------------------------------------------------------------------- 7. fuel objective and ETA
def test_fuel_objective_meets_the_eta_and_burns_less_than_the_fastest_route():
    wx = random_sea(5, hs_m=(1.0, 5.0))
    start, end = (0.0, 152.0), (1.0, 158.0)
    kw = dict(departure=T0, cell_nm=40.0, directions=16, **OPEN_SEA)  # a small graph: the λ bisection runs ~15 searches
    fast = search_route(start, end, wx, CARGO, **kw)
    fuels = []
    for extra_h in (4.0, 15.0):
        eta = fast.arrival + _h(extra_h)
        r = search_route(start, end, wx, CARGO, objective="fuel", eta=eta, **kw)
        assert r.arrival <= eta
        assert r.total_fuel_t < fast.total_fuel_t
        fuels.append(r.total_fuel_t)
    assert np.all(np.diff(fuels) <= 1e-9)
