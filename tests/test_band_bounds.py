"""The node-bound certificate of the search's band check (optroute.search.band_bounds) against the full refinement.

References: the referee's rule compiled without the certificate (``piece_clear`` with
:data:`~optroute.search.band_bounds.NO_BOUNDS`: regime crossings and halving until certified, every
point evaluated); brute force — the weather sampled at many points along a piece, the brake power
at every Beaufort number and wave angle; and, for the 3-D DP, a band placed by hand between two
piece midpoints (the exact geometry of ``dp_leg``'s pieces).
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import optroute as orx
from optroute.physics.performance import KwonModel
from optroute.physics.pointwise import allowed_speed, brake_power, brake_power_bound, cached_point_params
from optroute.physics.safety import BandRules
from optroute.physics.seaway import BEAUFORT_WAVE_HEIGHT_M
from optroute.search import passage_kernels as pk
from optroute.search.band_bounds import NO_BOUNDS, piece_certified, weather_with_bounds
from optroute.search.edge_geometry import piece_point
from optroute.search.refine_kernels import CAPACITY, piece_clear
from optroute.search.refine_kernels import workspace as refine_workspace
from optroute.units import h_to_timedelta
from optroute.weather import WeatherSampler
from optroute.weather.sample import sample_at
from optroute.weather.schema import canonical_dataset
from tests.test_search_kernels import CARGO, T0, _physics, sea_fields

# the search's own (read-only) parameter vector: a writable copy is another numba signature, and every kernel
# it reaches would be compiled a second time on a clean cache
PARAMS = cached_point_params(CARGO, KwonModel(CARGO), BandRules())  # bands where Hs >= 6.8 m


@pytest.fixture(scope="module")
def weather():
    """Hs 2-9 m (either side of the 6.8 m threshold), 0.8 m/s currents: with its bounds and without."""
    pw = WeatherSampler(sea_fields(7, hs_m=(2.0, 9.0))).point_weather(T0)
    on = weather_with_bounds(pw)
    return on, (*on[:6], NO_BOUNDS)


def _piece(w, lat, lon, course, length, spd, t0, check_nm=15.0):
    """The piece's check points as ``cost_leg`` puts them, the times at ``spd`` and the sea there; None if not allowed."""
    n = int(pk.check_count(length, check_nm))
    s = np.array([j / (n - 1.0) * length for j in range(n)])
    pts = np.array([piece_point(lat, lon, course, x - 0.5 * length) for x in s])
    t = t0 + s / spd
    sea = np.empty((n, 9))
    for j in range(n):
        sample_at(*w[:6], t[j], pts[j, 0], pts[j, 1], sea[j])
        _, _, ok = allowed_speed(PARAMS, pts[j, 2], *sea[j, :7], spd)
        if not ok:
            return None
    return s, t, pts[:, 0].copy(), pts[:, 1].copy(), pts[:, 2].copy(), sea


def _clear(w, piece, lat, lon, course, length, spd, sog_mode=False):
    s, t, la, lo, crs, sea = piece
    ws, sl, scratch = refine_workspace(True)
    return piece_clear(
        PARAMS, w, spd, sog_mode, lat, lon, course, length, s, t, s.size, la, lo, crs, sea, ws, sl, scratch
    )


def _certified(w, piece, lat, lon, length, spd, sog_mode=False):
    s, t, la, lo, _, _ = piece
    return piece_certified(PARAMS, w, spd, sog_mode, la, lo, t, s, s.size, lat, lon, length, CAPACITY, np.empty(6))


@settings(max_examples=150, deadline=None)
@given(
    lat=st.floats(-10.0, 12.0),
    lon=st.floats(148.0, 176.0),
    course=st.floats(0.0, 359.9),
    length=st.floats(1.0, 30.0),
    spd=st.floats(6.0, 16.0),
    t0=st.floats(0.0, 200.0),
)
def test_a_certified_piece_is_one_the_full_refinement_clears(weather, lat, lon, course, length, spd, t0):
    on, off = weather
    piece = _piece(on, lat, lon, course, length, spd, t0)
    if piece is None:
        return  # the refinement's precondition: the speed allowed at the check points
    full = _clear(off, piece, lat, lon, course, length, spd)
    assert _clear(on, piece, lat, lon, course, length, spd) == full
    if _certified(on, piece, lat, lon, length, spd):
        assert full


def _outcomes(on, off, rng, n, draw):
    seen = {"certified": 0, "refined clear": 0, "refined failing": 0}
    for _ in range(n):
        lat, lon, course, length, spd, t0 = draw(rng)
        piece = _piece(on, lat, lon, course, length, spd, t0)
        if piece is None:
            continue
        full = _clear(off, piece, lat, lon, course, length, spd)
        assert _clear(on, piece, lat, lon, course, length, spd) == full
        if _certified(on, piece, lat, lon, length, spd):
            assert full
            seen["certified"] += 1
        else:
            seen["refined clear" if full else "refined failing"] += 1
    return seen


def test_the_certificate_decides_most_pieces_and_every_outcome_occurs(weather):
    on, off = weather
    seen = _outcomes(on, off, np.random.default_rng(5), 300, lambda r: (
        r.uniform(-10.0, 12.0), r.uniform(148.0, 176.0), r.uniform(0.0, 360.0), r.uniform(2.0, 25.0),
        r.uniform(6.0, 16.0), r.uniform(0.0, 200.0)))  # fmt: skip
    assert seen["certified"] > 2 * seen["refined clear"] > 0, seen  # the table lookup decides most pieces
    ridge = weather_with_bounds(WeatherSampler(_ridge(9.0)).point_weather(T0))
    across = _outcomes(ridge, (*ridge[:6], NO_BOUNDS), np.random.default_rng(6), 60, lambda r: (
        r.uniform(-1.0, 1.0), r.uniform(150.3, 150.7), r.uniform(85.0, 95.0), r.uniform(15.0, 28.0),
        r.uniform(11.8, 12.2), r.uniform(0.0, 60.0)))  # fmt: skip
    assert across["refined failing"] > 0 and across["certified"] == 0, across  # a band between the check points


def test_the_pieces_box_holds_every_point_sampled_along_it(weather):
    """Brute force: Hs, wind and current at 200 points along certified pieces stay within the box's node bounds."""
    on, _ = weather
    rng = np.random.default_rng(8)
    hs_thr = PARAMS[16]
    checked = 0
    for _ in range(60):
        lat, lon, course = rng.uniform(-10.0, 12.0), rng.uniform(148.0, 176.0), rng.uniform(0.0, 360.0)
        length, spd, t0 = rng.uniform(2.0, 30.0), rng.uniform(6.0, 16.0), rng.uniform(0.0, 200.0)
        piece = _piece(on, lat, lon, course, length, spd, t0)
        if piece is None or not _certified(on, piece, lat, lon, length, spd):
            continue
        checked += 1
        sea = np.empty(9)
        for x in np.linspace(0.0, length, 200):
            la, lo, crs = piece_point(lat, lon, course, x - 0.5 * length)
            assert sample_at(*on[:6], t0 + x / spd, la, lo, sea)
            assert sea[0] < hs_thr  # no band can apply
            _, _, ok = allowed_speed(PARAMS, crs, *sea[:7], spd)
            assert ok
    assert checked > 10


@pytest.mark.parametrize("ship", [CARGO, orx.Ship.preset("container_8000teu")])
def test_power_bound_is_above_the_power_at_every_angle_and_beaufort_number(ship):
    p = cached_point_params(ship, KwonModel(ship), BandRules())
    angles = np.arange(0.0, 360.0, 7.5)
    for bn_max in range(0, 13):
        for v in (6.0, 12.0, 18.0, 22.0):
            bound = brake_power_bound(p, v, v, float(bn_max))
            # every Beaufort number up to bn_max (from Hs: the wind unknown) at every angle
            worst = max(brake_power(p, v, h, a, np.nan) for a in angles for h in BEAUFORT_WAVE_HEIGHT_M[: bn_max + 1])
            assert bound >= worst
            if bn_max <= 6:
                assert bound <= worst * (1.0 + 1e-8)  # a bound that certifies: head seas at bn_max are the worst


def test_search_costs_with_the_certificate_are_those_without(weather):
    """The compiled leg costing with and without the node bounds: bit-identical durations, fuel, feasibility."""
    on, off = weather
    rng = np.random.default_rng(3)
    n, k = 200, 4
    lat, lon = rng.uniform(-9.0, 10.0, (n, k)), rng.uniform(150.0, 174.0, (n, k))
    course, length = rng.uniform(0.0, 360.0, (n, k)), rng.uniform(3.0, 25.0, (n, k))
    n_pieces, t0 = rng.integers(1, k + 1, n).astype(np.int64), rng.uniform(0.0, 200.0, n)
    ladder = 14.0 - 0.5 * np.arange(23)
    a = pk.cost_legs(PARAMS, on, 0, 10.0, ladder, 0.0, 14.0, 0.5, 3.0, lat, lon, course, length, n_pieces, t0)
    b = pk.cost_legs(PARAMS, off, 0, 10.0, ladder, 0.0, 14.0, 0.5, 3.0, lat, lon, course, length, n_pieces, t0)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    np.testing.assert_array_equal(a[2], b[2])
    assert 0.2 < a[2].mean() < 1.0


def _ridge(hs_peak):
    """Beam seas from the north (Tp 9 s: a band of the cargo ship at 12 kn where Hs >= 6.8 m), Hs 2 m but on the
    meridian 150.5 E, where it is ``hs_peak``: trilinear, Hs exceeds 6.8 m within ~4.7 nm of it (hs_peak 9 m)."""
    lat, lon, hr = np.arange(-2.0, 2.01, 0.25), np.arange(148.0, 153.01, 0.25), np.arange(0.0, 96.01, 6.0)
    hs = np.full((hr.size, lat.size, lon.size), 2.0)
    hs[:, :, np.isclose(lon, 150.5)] = hs_peak
    variables = {"hs_m": hs, "tp_s": np.full(hs.shape, 9.0), "wave_from_deg": np.zeros(hs.shape)}
    return canonical_dataset(
        T0 + h_to_timedelta(hr), lat, lon, variables, {"geography": "synthetic", "source": "ridge"}
    )


@pytest.mark.parametrize("compiled", [True, False])
def test_dp_rejects_a_leg_whose_band_lies_between_two_piece_midpoints(compiled):
    """(0, 150) -> (0, 151) at 12 kn: 60 nm in two 30 nm pieces whose midpoints (150.25, 150.75 E) see Hs 2 m; the
    ridge at their common end puts ~9 nm in the band.  Checked at the midpoints only (before) the leg was feasible."""
    leg = (np.array([0.0]), np.array([150.0]), np.array([0.0]), np.array([151.0]), np.array([10.0]), np.array([12.0]))
    sea = np.empty(9)
    pw = WeatherSampler(_ridge(9.0)).point_weather(T0)
    for lon, hs in ((150.25, 2.0), (150.75, 2.0), (150.5, 9.0)):  # the geometry the test stands on
        assert sample_at(*pw, 11.0, 0.0, lon, sea) and sea[0] == pytest.approx(hs)
    _, _, feas, _ = _physics(_ridge(9.0), compiled=compiled).dp_leg(30.0)(*leg)
    assert not feas[0]
    _, _, feas_low, _ = _physics(_ridge(6.0), compiled=compiled).dp_leg(30.0)(*leg)  # below the threshold: no band
    assert feas_low[0]
