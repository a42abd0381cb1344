"""Unit/angle round trips and the deep-water wave relations against physics.md §2 and §5."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optroute import SeaStateError, units
from optroute.physics import seaway

finite_speeds = st.floats(0.0, 1e4, allow_nan=False)
angles = st.floats(-1e4, 1e4, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(finite_speeds)
def test_speed_distance_time_round_trips(x):
    assert units.ms_to_kn(units.kn_to_ms(x)) == pytest.approx(x, rel=1e-12, abs=1e-12)
    assert units.m_to_nm(units.nm_to_m(x)) == pytest.approx(x, rel=1e-12, abs=1e-12)
    assert units.s_to_h(units.h_to_s(x)) == pytest.approx(x, rel=1e-12, abs=1e-12)


def test_knot_is_1852_m_per_hour():
    assert units.kn_to_ms(1.0) == pytest.approx(1852.0 / 3600.0, rel=1e-15)
    assert units.kn_to_ms(3600.0) == pytest.approx(1852.0)


@settings(max_examples=300, deadline=None)
@given(angles)
def test_angle_wraps_and_from_to_flip(a):
    w360, w180 = float(units.wrap_360(a)), float(units.wrap_180(a))
    assert 0.0 <= w360 < 360.0 and -180.0 <= w180 < 180.0
    assert math.isclose(math.cos(math.radians(w360)), math.cos(math.radians(a)), abs_tol=1e-9)
    assert math.isclose(math.sin(math.radians(w180)), math.sin(math.radians(a)), abs_tol=1e-9)
    back = float(units.from_to_flip_deg(units.from_to_flip_deg(a)))
    assert math.isclose(math.cos(math.radians(back - a)), 1.0, abs_tol=1e-9)


@settings(max_examples=300, deadline=None)
@given(st.floats(0.0, 100.0), st.floats(0.0, 360.0, exclude_max=True))
def test_uv_round_trip(speed, to_deg):
    u, v = units.speed_to_deg_to_uv(speed, to_deg)
    s2, d2 = units.uv_to_speed_to_deg(u, v)
    assert float(s2) == pytest.approx(speed, abs=1e-9)
    if speed > 1e-6:
        assert math.cos(math.radians(float(d2) - to_deg)) == pytest.approx(1.0, abs=1e-9)


def test_wind_uv_convention_by_hand():
    # A westerly (from 270) blows to the east: u > 0, v = 0.
    speed, frm = units.wind_uv_to_speed_from_deg(10.0, 0.0)
    assert float(speed) == pytest.approx(10.0) and float(frm) == pytest.approx(270.0)
    # A northerly (from 0) blows to the south: v < 0.
    _, frm = units.wind_uv_to_speed_from_deg(0.0, -5.0)
    assert float(frm) == pytest.approx(0.0, abs=1e-12)


def test_deep_water_relations_physics_md_coefficients():
    # physics.md §2: λ = 1.5613 T², c = 1.5613 T m/s = 3.035 T kn, c_g = 1.517 T kn (g rounded to 9.81 there).
    t = np.array([4.0, 8.0, 12.0, 16.0])
    assert seaway.wavelength_m(t) == pytest.approx(1.5613 * t**2, rel=5e-4)
    assert units.ms_to_kn(seaway.phase_speed_ms(t)) == pytest.approx(3.035 * t, rel=5e-4)
    assert units.ms_to_kn(seaway.group_speed_ms(t)) == pytest.approx(1.517 * t, rel=5e-4)
    assert seaway.period_from_wavelength_s(seaway.wavelength_m(t)) == pytest.approx(t, rel=1e-12)


# physics.md §2 checked table: (T, V, α, T_E IMO, T_E exact).
IMO_CIRC_1228_CHECKED = [
    (10, 20, 0, 6.000, 6.028),
    (10, 20, 180, 30.000, 29.325),
    (10, 20, 90, 10.000, 10.000),
    (8, 15, 150, 17.439, 17.206),
]


@pytest.mark.parametrize(("t", "v", "alpha", "te_imo", "te_exact"), IMO_CIRC_1228_CHECKED)
def test_imo_circ_1228_encounter_period_checked_values(t, v, alpha, te_imo, te_exact):
    assert seaway.encounter_period_s(t, v, alpha, form="imo") == pytest.approx(te_imo, abs=5e-4)
    # physics.md computed the exact form with g/2π = 3.035 kn/s (g = 9.81); optroute uses
    # standard gravity 9.80665 (3.0339 kn/s), which moves the following-sea value by 0.07 %.
    assert seaway.encounter_period_s(t, v, alpha) == pytest.approx(te_exact, rel=1e-3)


def test_encounter_period_overtaking_takes_absolute_value_and_is_infinite_at_crest_speed():
    c_kn = float(units.ms_to_kn(seaway.phase_speed_ms(8.0)))
    assert np.isinf(seaway.encounter_period_s(8.0, c_kn, 180.0))
    te = seaway.encounter_period_s(8.0, 2 * c_kn, 180.0)
    assert te == pytest.approx(8.0, rel=1e-12)  # ω_e = |ω − k U|: twice the crest speed → period T


def test_relative_wave_angle_convention():
    # Ship heading north; waves from north = head sea, from east = sea from starboard, from south = following.
    assert seaway.relative_wave_angle_deg(0.0, [0.0, 90.0, 180.0, 270.0]) == pytest.approx([0, 90, 180, 270])
    assert seaway.speed_along_waves_kn(10.0, 180.0) == pytest.approx(10.0)
    assert seaway.speed_along_waves_kn(10.0, 0.0) == pytest.approx(-10.0)


@pytest.mark.parametrize(
    ("u10", "bn"),
    [
        (0.0, 0),
        (0.2, 0),
        (0.3, 1),
        (1.5, 1),
        (1.6, 2),
        (3.3, 2),
        (3.4, 3),
        (5.4, 3),
        (5.5, 4),
        (7.9, 4),
        (8.0, 5),
        (10.7, 5),
        (10.8, 6),
        (13.8, 6),
        (13.9, 7),
        (17.1, 7),
        (17.2, 8),
        (20.7, 8),
        (20.8, 9),
        (24.4, 9),
        (24.5, 10),
        (28.4, 10),
        (28.5, 11),
        (32.6, 11),
        (32.7, 12),
        (60.0, 12),
    ],
)
def test_beaufort_from_wind_wmo_table_edges(u10, bn):
    assert seaway.beaufort_from_wind(u10) == bn


@pytest.mark.parametrize(
    ("hs", "bn"), [(0.0, 0), (0.1, 1), (0.6, 3), (3.0, 6), (3.4, 6), (3.6, 7), (5.5, 8), (9.0, 10), (20.0, 12)]
)
def test_beaufort_from_hs_nearest_probable_height(hs, bn):
    assert seaway.beaufort_from_hs(hs) == bn


def test_pierson_moskowitz_conversions_and_eedi_sea():
    tp = 12.0
    assert seaway.pm_t01_from_tp(tp) == pytest.approx(0.7718 * 12)
    assert seaway.pm_tp_from_t02(seaway.pm_t02_from_tp(tp)) == pytest.approx(tp)
    assert seaway.pm_tp_from_t01(seaway.pm_t01_from_tp(tp)) == pytest.approx(tp)
    # EEDI representative sea BF6: Hs 3.0 m → T01 = 3.86 √3 = 6.69 s ≈ 6.7 s (physics.md §2, §7).
    assert seaway.pm_t01_from_hs(3.0) == pytest.approx(3.86 * math.sqrt(3.0), rel=2e-3)
    assert round(float(seaway.pm_t01_from_hs(3.0)), 1) == 6.7


@pytest.mark.parametrize("bad", [float("nan"), -1.0, 0.0])
def test_bad_periods_raise(bad):
    with pytest.raises(SeaStateError, match="period_s"):
        seaway.encounter_period_s(bad, 10.0, 0.0)


def test_negative_hs_and_speed_raise():
    with pytest.raises(SeaStateError, match="hs_m must be >= 0.0, got -0.5"):
        seaway.beaufort_from_hs([1.0, -0.5])
    with pytest.raises(SeaStateError, match="speed_kn"):
        seaway.encounter_period_s(10.0, -3.0, 0.0)
