"""Land mask, port snapping and leg checks against known geography and the weather sampler."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optroute import geodesy as geo
from optroute.errors import ConfigError, OnLandError
from optroute.geo import land
from optroute.weather import WeatherSampler
from optroute.weather.schema import canonical_dataset

SAN_DIEGO = (32.71, -117.17)
TOKYO = (35.65, 139.77)

OPEN_OCEAN = [
    (30.0, -150.0),
    (0.0, -140.0),
    (45.0, 179.99),
    (45.0, -180.0),
    (-40.0, 20.0),
    (-50.0, -100.0),
    (10.0, 65.0),
]
LAND = [
    (38.5, -98.0),
    (48.85, 2.35),
    (-25.0, 135.0),
    (35.68, 139.69),
    (28.0, -113.0),
    (44.0, -87.0),
]  # ... Lake Michigan


@pytest.fixture(scope="module")
def globe_source():
    """The installed ``global-land-mask`` data file and its mask streamed whole (about 3 CPU-s, once)."""
    from optroute.geo import _globe_bits

    source = land._package_dir("global_land_mask") / _globe_bits.SOURCE_NAME
    axes = _globe_bits.read_axes(source)
    return source, axes, _globe_bits.stream_packed(source, (int(axes[8]), int(axes[9])))


def test_packaged_bands_equal_the_installed_globe_file_bit_for_bit(globe_source):
    from optroute.geo import _globe_bits

    source, axes, streamed = globe_source
    banded = _globe_bits.BandedBits()
    assert banded.source_sha256 == _globe_bits.sha256_of(source), (
        "the packaged GLOBE bands were built from another global-land-mask file; "
        "regenerate them with python -m optroute.geo._globe_bits"
    )
    np.testing.assert_array_equal(banded.axes, axes)
    assert not banded._loaded.any()
    banded.ensure_rows(np.arange(streamed.shape[0]))
    assert banded._loaded.all()
    np.testing.assert_array_equal(banded.bits, streamed)


def test_a_look_up_inflates_only_the_bands_it_needs():
    mask = land.GlobeLandMask()
    assert mask._banded is not None  # the packaged copy matches the installed file
    # Kansas (38.5 N) and Paris (48.85 N): rows (90 - lat) * 120, bands of 120 rows (1 degree)
    assert mask.is_land(np.array([38.5, 48.85]), np.array([-98.0, 2.35])).tolist() == [True, True]
    assert np.flatnonzero(mask._banded._loaded).tolist() == [41, 51]
    # the box look-up of the lateral bounds inflates the rows of its box: 30-32 N
    assert not mask.any_land_in_box(30.0, 31.9, -150.0, -140.0)
    assert np.flatnonzero(mask._banded._loaded).tolist() == [41, 51, 58, 59, 60]


def test_globe_mask_streams_the_installed_file_when_the_packaged_copy_does_not_match(globe_source, monkeypatch):
    from optroute.geo import _globe_bits

    source, _, streamed = globe_source
    calls = []

    def stream(path, shape):
        calls.append((path, shape))
        return streamed

    monkeypatch.setattr(_globe_bits, "sha256_of", lambda path: "a newer global-land-mask release")
    monkeypatch.setattr(_globe_bits, "stream_packed", stream)
    mask = land.GlobeLandMask()
    assert mask._banded is None and calls == [(source, (21600, 43200))]
    lat, lon = np.array(LAND + OPEN_OCEAN).T
    assert mask.is_land(lat, lon).tolist() == [True] * len(LAND) + [False] * len(OPEN_OCEAN)


def test_known_points():
    lat, lon = np.array(OPEN_OCEAN).T
    assert not land.is_land(lat, lon).any()
    assert land.navigable(lat, lon).all()
    lat, lon = np.array(LAND).T
    assert land.is_land(lat, lon).all()
    # any longitude convention: 190 E is 170 W
    assert land.is_land(38.5, -98.0 + 360.0)
    assert land.is_land(np.zeros((2, 3)), np.zeros((2, 3))).shape == (2, 3)


@pytest.mark.parametrize(
    ("port", "box"), [(SAN_DIEGO, (32.55, 32.75, -117.30, -117.10)), (TOKYO, (35.30, 35.70, 139.60, 140.10))]
)
def test_ports_snap_to_sea_with_a_warning(port, box):
    with pytest.warns(UserWarning, match=r"moved .* nm to the nearest navigable water"):
        lat, lon = land.snap_to_sea(*port, max_distance_nm=10.0, what="start")
    moved = float(geo.distance_nm(*port, lat, lon))
    assert 0.0 < moved <= 10.0
    assert box[0] < lat < box[1] and box[2] < lon < box[3]  # in San Diego Bay / Tokyo Bay, not out at sea
    # clear water all round the snapped point (the default clearance is 0.5 nm)
    ring_lat, ring_lon = geo.destination(np.full(36, lat), np.full(36, lon), np.arange(0, 360, 10), 0.45)
    assert land.navigable(ring_lat, ring_lon).all() and land.navigable(lat, lon)


def test_point_at_sea_is_kept_silently():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert land.snap_to_sea(30.0, -150.0) == (30.0, -150.0)


def test_inland_point_raises_on_land_error():
    with pytest.raises(OnLandError, match=r"\(38\.5000, -98\.0000\).*20 nm.*raise max_distance_nm"):
        land.snap_to_sea(38.5, -98.0)
    with pytest.raises(ConfigError):
        land.snap_to_sea(38.5, -98.0, max_distance_nm=0.0)


def test_leg_across_baja_california_crosses_land():
    # from the Pacific off Ensenada to the Gulf of California: Baja lies in between
    hit = land.leg_crosses_land(31.5, -117.5, 25.0, -110.5, resolution_nm=0.5)
    assert hit is not None
    assert -117.0 < hit[1] < -112.0 and land.is_land(*hit)
    # the first land point: everything before it along the leg is sea
    d = float(geo.distance_nm(31.5, -117.5, *hit))
    lat, lon = geo.intermediate_points(
        31.5, -117.5, 25.0, -110.5, np.linspace(0, d / float(geo.distance_nm(31.5, -117.5, 25.0, -110.5)), 50)[:-2]
    )
    assert not land.is_land(lat, lon).any()


def test_open_pacific_legs_are_clear():
    assert land.leg_crosses_land(30.0, -150.0, 35.0, -140.0) is None
    # across the antimeridian at 50 N (south of the Aleutians); a leg taken the long way round would hit Asia
    assert land.leg_crosses_land(50.0, 170.0, 50.0, -170.0) is None
    assert land.leg_crosses_land(45.0, 175.0, 46.0, 185.0) is None


def test_antimeridian_leg_through_the_aleutians():
    hit = land.leg_crosses_land(52.0, 179.0, 52.0, -178.0, resolution_nm=0.5)
    assert hit is not None and abs(hit[0] - 52.0) < 0.1 and (hit[1] > 179.0 or hit[1] < -178.0)


def test_vectorised_legs_agree_with_single_legs():
    legs = np.array(
        [
            [31.5, -117.5, 25.0, -110.5],
            [30.0, -150.0, 35.0, -140.0],
            [50.0, 170.0, 50.0, -170.0],
            [52.0, 179.0, 52.0, -178.0],
        ]
    )
    many = land.legs_cross_land(*legs.T)
    single = [land.leg_crosses_land(*leg) is not None for leg in legs]
    assert many.tolist() == single == [True, False, False, True]


def _weather():
    t0 = np.datetime64("2024-01-10T00:00", "ns")
    times = t0 + np.arange(3) * np.timedelta64(6, "h")
    lat = np.arange(10.0, 20.1, 1.0)
    lon = np.arange(170.0, 200.1, 1.0)  # across the antimeridian, unwrapped
    hs = np.full((3, lat.size, lon.size), 2.0)
    hs[:, 5, 10] = np.nan  # 15 N, 180: permanently blocked (an atoll in a wave model)
    hs[1, 2, 20] = np.nan  # 12 N, 190 = 170 W: blocked only in the middle slice
    return canonical_dataset(times, lat, lon, {"hs_m": hs, "tp_s": 8.0, "wave_from_deg": 270.0}), t0


def test_navigable_follows_the_weather_nan_cells_like_the_sampler():
    ds, t0 = _weather()
    rng = np.random.default_rng(4)
    n = 4000
    lat = rng.uniform(10.0, 20.0, n)
    lon = rng.uniform(170.0, 200.0, n)
    lon = np.where(lon >= 180.0, lon - 360.0, lon)
    time = t0 + (rng.uniform(0.0, 12.0, n) * 3.6e12).astype("timedelta64[ns]")
    # grid-line points too, where a NaN neighbour with zero weight still spoils the interpolation
    lat[:200] = np.round(lat[:200])
    lon[200:400] = np.round(lon[200:400])
    nan = np.isnan(WeatherSampler(ds).sample(time, lat, lon)["hs_m"])
    ok = land.navigable(lat, lon, weather=ds, time=time, use_land_mask=False)
    np.testing.assert_array_equal(ok, ~nan)
    assert nan.sum() > 50
    # without a time only the cells NaN at every time count
    static = land.navigable(np.array([15.5, 12.5]), np.array([-179.5, -169.5]), weather=ds, use_land_mask=False)
    assert static.tolist() == [False, True]
    # outside the dataset's area or time span: not navigable
    assert not land.navigable(25.0, 175.0, weather=ds, use_land_mask=False)
    assert not land.navigable(12.0, 175.0, weather=ds, time=t0 + np.timedelta64(13, "h"), use_land_mask=False)


def test_snap_and_legs_respect_weather_nan():
    ds, t0 = _weather()
    with pytest.warns(UserWarning, match="moved"):
        lat, lon = land.snap_to_sea(
            15.0, 180.0, max_distance_nm=200.0, weather=ds, use_land_mask=False, clearance_nm=0.0
        )
    assert land.navigable(lat, lon, weather=ds, use_land_mask=False)
    # the sampler's stencil (floor, both neighbours) blocks lon 179..181 and lat 14..16 around the NaN point;
    # the nearest clear point is 1 deg of longitude east: 60 cos(15 deg) = 57.96 nm (to within the 1 nm candidate step)
    assert 57.9 < float(geo.distance_nm(15.0, 180.0, lat, lon)) <= 59.0 and -179.01 < lon < -178.9
    hit = land.leg_crosses_land(15.0, 175.0, 15.0, -175.0, weather=ds, use_land_mask=False)
    assert hit is not None and 178.9 < hit[1] < 180.0


def test_bad_input():
    with pytest.raises(ConfigError, match="latitude"):
        land.is_land(95.0, 0.0)
    with pytest.raises(ConfigError, match="finite"):
        land.navigable(np.nan, 0.0)
    with pytest.raises(ConfigError, match="unknown land mask"):
        land.land_mask("osm")
    with pytest.raises(ConfigError, match="resolution_nm"):
        land.leg_crosses_land(0.0, 0.0, 1.0, 1.0, resolution_nm=0.0)


def test_navigable_matches_the_sampler_on_a_quarter_degree_moving_box():
    from optroute.weather import scenarios

    ds = scenarios.shao_case(1, resolution_deg=0.25, duration_h=120.0)
    t0 = scenarios.DEFAULT_START
    rng = np.random.default_rng(11)
    n = 3000
    lat = np.round(rng.uniform(-12.0, 8.0, n) * 4.0) / 4.0  # on grid lines, where rounding decides the stencil
    lon = rng.uniform(45.0, 75.0, n)
    lon[: n // 2] = np.round(lon[: n // 2] * 4.0) / 4.0
    time = t0 + (np.round(rng.uniform(50.0, 110.0, n)) * 3.6e12).astype("timedelta64[ns]")
    nan = np.isnan(WeatherSampler(ds).sample(time, lat, lon)["hs_m"])
    np.testing.assert_array_equal(land.navigable(lat, lon, weather=ds, time=time), ~nan)
    assert 0.2 < nan.mean() < 0.9


def test_default_backend_choice(monkeypatch):
    monkeypatch.setenv(land.LAND_MASK_ENV, "gshhg")
    assert land.default_land_mask_name() == "gshhg"
    monkeypatch.delenv(land.LAND_MASK_ENV)
    # GLOBE missing, roaring-landmask present (the optional 'gshhg' extra): GSHHG is chosen
    present = object()
    monkeypatch.setattr(land.importlib.util, "find_spec", lambda name: present if name == "roaring_landmask" else None)
    assert land.default_land_mask_name() == "gshhg"
    monkeypatch.setattr(land.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(ConfigError, match="pip install global-land-mask"):
        land.default_land_mask_name()


@settings(max_examples=150, deadline=None)
@given(
    n=st.integers(3, 40),
    seed=st.integers(0, 2**31 - 1),
    blocked=st.floats(0.0, 0.4),
    step=st.floats(0.05, 3.0),
    reach_steps=st.floats(0.0, 8.0),
)
def test_disk_erosion_equals_scipys_binary_erosion(n, seed, blocked, step, reach_steps):
    from scipy import ndimage

    from optroute.geo.land import _erode_disk

    ok = np.random.default_rng(seed).random((n, n)) >= blocked
    reach = reach_steps * step
    r = int(np.ceil(reach / step))
    off = np.arange(-r, r + 1) * step
    disk = np.hypot(*np.meshgrid(off, off)) <= reach + 1e-9
    expected = ndimage.binary_erosion(ok, structure=disk, border_value=0)
    np.testing.assert_array_equal(_erode_disk(ok, reach, step), expected)
