"""Tests of optroute.physics.speed_loss, each against an independent reference.

References: the checked KCS values of Kwon (2008) in shared/physics.md §6,
Kwon's tables evaluated by hand, the IMO MEPC.1/Circ.796 example and formula
evaluated by hand, a hand-worked velocity triangle, and (for the inverse) a
root found by scipy's brentq on a Kwon formula written out in this file.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from optroute.errors import ConfigError, SeaStateError, ShipSpecError
from optroute.physics import currents
from optroute.physics import speed_loss as sl
from optroute.physics.seaway import G_MS2

KN = 1852.0 / 3600.0  # m/s per knot, written out independently of optroute.units

# KCS-like container ship of physics.md §6.
KCS = dict(length_m=230.0, block_coefficient=0.65, volume_m3=52030.0)
KCS_KW = dict(ship_type="container", loading="normal")


def _kcs_loss(bn: float, angle: float, v1_kn: float = 24.0) -> float:
    return float(sl.kwon_speed_loss_pct(v1_kn, KCS["length_m"], 0.65, 52030.0, bn, angle, **KCS_KW))


# ---------------------------------------------------------------- Kwon 2008, KCS


# physics.md prints the values to 4 significant figures, computed with
# g = 9.81 (its Fn is 0.25993); optroute uses standard gravity 9.80665, which
# raises Fn by 1.7e-4 relative and lowers C_U and the loss by ~5.5e-4
# relative.  Hence rel tol 1e-3 here, and an exact-g check below at 2e-4.
KCS_REL_TOL = 1e-3


@pytest.mark.parametrize("bn, expected", [(5, 3.965), (6, 6.774), (7, 12.863), (8, 25.450)])
def test_kwon_2008_kcs_head_seas(bn, expected):
    assert _kcs_loss(bn, 0.0) == pytest.approx(expected, rel=KCS_REL_TOL)


def test_kwon_2008_kcs_beam_bn6_and_following_bn8():
    assert _kcs_loss(6, 90.0) == pytest.approx(3.048, rel=KCS_REL_TOL)
    assert _kcs_loss(8, 180.0) == pytest.approx(5.090, rel=KCS_REL_TOL)


def test_kwon_2008_kcs_speed_coefficient():
    fn = 24.0 * KN / math.sqrt(G_MS2 * 230.0)
    assert float(sl.kwon_speed_coefficient(fn, 0.65, "normal")) == pytest.approx(0.85458, rel=KCS_REL_TOL)


def test_kwon_2008_kcs_values_reproduce_to_print_precision_with_g_981(monkeypatch):
    # The same checked values with physics.md's own g = 9.81: they then agree
    # to the printed precision, which confirms the tolerance reason above.
    monkeypatch.setattr(sl, "G_MS2", 9.81)
    got = [_kcs_loss(bn, 0.0) for bn in (5, 6, 7, 8)] + [_kcs_loss(6, 90.0), _kcs_loss(8, 180.0)]
    want = [3.965, 6.774, 12.863, 25.450, 3.048, 5.090]
    np.testing.assert_allclose(got, want, rtol=2e-4)


def test_kwon_2008_kcs_bn6_head_speed_ratio_matches_published_kcs():
    # physics.md §6: V2/V1 = 0.932 at BN 6 head seas, 24 kn.
    v2 = sl.speed_in_weather_kn(24.0, 230.0, 0.65, 52030.0, 6, 0.0, **KCS_KW)
    assert float(v2) / 24.0 == pytest.approx(0.932, abs=5e-4)


# ---------------------------------------------------------------- Kwon tables by hand


@pytest.mark.parametrize(
    "angle, bn, expected",
    [
        # 2·Cβ from the table of physics.md §6, halved by hand:
        (0.0, 6, 1.0),  # head: 2.0 / 2
        (45.0, 6, 0.79),  # bow: (1.7 − 0.03·4) / 2
        (90.0, 6, 0.45),  # beam: (0.9 − 0) / 2
        (170.0, 6, 0.14),  # following: (0.4 − 0.03·4) / 2
        (45.0, 4, 0.85),  # bow at its peak: 1.7 / 2
        (170.0, 8, 0.20),  # following at its peak: 0.4 / 2
        (45.0, 12, 0.0),  # bow BN 12: 1.7 − 0.03·64 = −0.22 → clipped to 0
        (90.0, 12, 0.0),  # beam BN 12: 0.9 − 0.06·36 = −1.26 → 0
        (170.0, 0, 0.0),  # following BN 0: 0.4 − 0.03·64 = −1.52 → 0
        # boundaries belong to the sector nearer the bow
        (30.0, 6, 1.0),  # head
        (30.001, 6, 0.79),  # bow
        (60.0, 6, 0.79),  # bow
        (60.001, 6, 0.45),  # beam
        (150.0, 8, (0.9 - 0.06 * 4) / 2),  # beam: 0.33
        (150.001, 8, 0.20),  # following
        (180.0, 8, 0.20),
        # folding by symmetry and wrapping
        (315.0, 6, 0.79),  # 315 → 45, bow
        (210.0, 8, 0.33),  # 210 → 150, beam
        (-30.0, 6, 1.0),  # −30 → 330 → 30, head
        (400.0, 6, 0.79),  # 400 → 40, bow
    ],
)
def test_kwon_2008_direction_coefficient_table_by_hand(angle, bn, expected):
    assert float(sl.kwon_direction_coefficient(angle, bn)) == pytest.approx(expected, abs=1e-12)


def test_kwon_2008_direction_coefficient_vectorised_over_angle_and_bn():
    got = sl.kwon_direction_coefficient(np.array([[0.0], [90.0]]), np.array([4, 6, 8]))
    np.testing.assert_allclose(got, [[1.0, 1.0, 1.0], [0.33, 0.45, 0.33]], atol=1e-12)


@pytest.mark.parametrize(
    "fn, cb, loading, expected",
    [
        # table rows evaluated by hand at Fn 0.2 (Fn² = 0.04)
        (0.2, 0.55, "normal", 1.7 - 0.28 - 0.296),  # 1.124
        (0.2, 0.60, "normal", 2.2 - 0.50 - 0.388),  # 1.312
        (0.2, 0.60, "ballast", 2.2 - 0.50 - 0.388),  # ballast below Cb 0.75 uses the normal row
        (0.2, 0.70, "normal", 3.1 - 1.06 - 0.496),  # 1.544
        (0.2, 0.75, "loaded", 2.4 - 2.12 - 0.380),  # −0.100 (C_U itself is not clipped)
        (0.2, 0.75, "ballast", 2.6 - 2.50 - 0.540),  # −0.440
        (0.2, 0.80, "normal", 2.6 - 2.62 - 0.604),  # −0.624
        (0.2, 0.85, "ballast", 3.4 - 4.18 + 1.272),  # 0.492, c = +31.8 (flag)
        # Cb 0.85 loaded at a tanker's Fn 0.15: +28.0 gives 0.925; the
        # misprint −28.0 would give −0.335, a speed gain in any storm.
        (0.15, 0.85, "normal", 3.1 - 2.805 + 0.630),
        # linear interpolation of C_U in Cb, by hand: midway 0.70 normal /
        # 0.75 loaded: (1.544 − 0.100)/2; 0.70 normal / 0.75 ballast: (1.544 − 0.440)/2
        (0.2, 0.725, "normal", 0.722),
        (0.2, 0.725, "ballast", 0.552),
        # a quarter of the way from 0.55 to 0.60: 0.75·1.124 + 0.25·1.312
        (0.2, 0.5625, "normal", 1.171),
        # Fn 0: C_U = a
        (0.0, 0.65, "normal", 2.6),
    ],
)
def test_kwon_2008_speed_coefficient_table_by_hand(fn, cb, loading, expected):
    assert float(sl.kwon_speed_coefficient(fn, cb, loading)) == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize(
    "bn, vol, ship_type, loading, expected",
    [
        # ∇ = 1e6 m³ so ∇^(2/3) = 1e4; 4^6.5 = 4^6·2 = 8192; 9^6.5 = 9^6·3 = 1 594 323
        (4, 1e6, "container", "normal", 2.8 + 8192 / 220_000),  # 0.7·4 + 8192/(22·1e4)
        (4, 1e6, "container", "ballast", 2.8 + 8192 / 220_000),  # containers: one formula
        (4, 1e6, "bulk_carrier", "loaded", 2.0 + 8192 / 27_000),  # 0.5·4 + 8192/(2.7·1e4)
        (4, 1e6, "tanker", "ballast", 2.8 + 8192 / 27_000),  # 0.7·4 + ...
        (4, 1e6, "general_cargo", "normal", 2.0 + 8192 / 27_000),
        (9, 1e6, "container", "normal", 6.3 + 1_594_323 / 220_000),  # 13.5469...
        (9, 8000.0, "bulk_carrier", "normal", 4.5 + 1_594_323 / 1080.0),  # ∇^(2/3) = 400
        (0, 1e6, "tanker", "normal", 0.0),
    ],
)
def test_kwon_2008_form_coefficient_by_hand(bn, vol, ship_type, loading, expected):
    assert float(sl.kwon_form_coefficient(bn, vol, ship_type, loading)) == pytest.approx(expected, rel=1e-12)


def test_kwon_2008_loss_is_floored_at_zero_where_cu_is_negative():
    # Cb 0.80 loaded at Fn 0.2: C_U = −0.624 (above); the loss is 0, never a gain.
    length = 200.0
    v1 = 0.2 * math.sqrt(G_MS2 * length) / KN
    loss = sl.kwon_speed_loss_pct(v1, length, 0.80, 60000.0, 8, 0.0, ship_type="bulk_carrier")
    assert float(loss) == 0.0
    assert float(sl.speed_in_weather_kn(v1, length, 0.80, 60000.0, 8, 0.0, ship_type="bulk_carrier")) == v1


# ---------------------------------------------------------------- inverse


def _kwon_kcs_by_hand(v1_kn: float, bn: int) -> float:
    """Weather speed of the KCS in head seas, Kwon's formulas written out here."""
    fn = v1_kn * KN / math.sqrt(G_MS2 * 230.0)
    cu = 2.6 - 3.7 * fn - 11.6 * fn**2
    cform = 0.7 * bn + bn**6.5 / (22.0 * 52030.0 ** (2.0 / 3.0))
    return v1_kn * (1.0 - 1.0 * cu * cform / 100.0)


@pytest.mark.parametrize("bn", [3, 6, 8])
def test_calm_speed_for_weather_matches_brentq_on_hand_written_kwon(bn):
    v2 = 22.0
    ref = brentq(lambda v1: _kwon_kcs_by_hand(v1, bn) - v2, v2, 60.0, xtol=1e-13)
    got = sl.calm_speed_for_weather_kn(v2, 230.0, 0.65, 52030.0, bn, 0.0, **KCS_KW)
    assert float(got) == pytest.approx(ref, rel=1e-10)


def test_calm_speed_for_weather_vectorised_grid_round_trip():
    bn = np.arange(0, 10)[:, None]
    angle = np.array([0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 300.0])[None, :]
    v2 = sl.speed_in_weather_kn(20.0, 230.0, 0.65, 52030.0, bn, angle, **KCS_KW)
    v1 = sl.calm_speed_for_weather_kn(v2, 230.0, 0.65, 52030.0, bn, angle, **KCS_KW)
    assert v1.shape == (10, 7)
    np.testing.assert_allclose(v1, 20.0, rtol=1e-10)


def test_calm_speed_for_zero_speed_and_calm_weather_is_identity():
    assert float(sl.calm_speed_for_weather_kn(0.0, 230.0, 0.65, 52030.0, 8, 0.0)) == 0.0
    assert float(sl.calm_speed_for_weather_kn(17.5, 230.0, 0.65, 52030.0, 0, 0.0)) == 17.5


@settings(max_examples=150, deadline=None)
@given(
    fn=st.floats(0.05, 0.30),
    length=st.floats(60.0, 400.0),
    cb=st.floats(0.55, 0.85),
    vol=st.floats(2e3, 4e5),
    bn=st.one_of(st.integers(0, 12), st.floats(0.0, 12.0)),
    angle=st.floats(-360.0, 720.0),
    ship_type=st.sampled_from(["container", "bulk_carrier", "tanker", "general_cargo"]),
    loading=st.sampled_from(["normal", "loaded", "ballast"]),
)
def test_hypothesis_calm_speed_inverts_speed_in_weather(fn, length, cb, vol, bn, angle, ship_type, loading):
    # Within Kwon's Fn range the weather speed rises with V1 wherever it is
    # positive, so V1 is the unique preimage and the round trip is exact.
    v1 = fn * math.sqrt(G_MS2 * length) / KN
    kw = dict(ship_type=ship_type, loading=loading)
    v2 = sl.speed_in_weather_kn(v1, length, cb, vol, bn, angle, on_unreachable="nan", **kw)
    assume(np.isfinite(v2) and v2 > 1e-3 * v1)
    back = sl.calm_speed_for_weather_kn(v2, length, cb, vol, bn, angle, **kw)
    assert float(back) == pytest.approx(v1, rel=1e-9)


# ---------------------------------------------------------------- IMO f_w


def test_imo_circ796_container_54k_dwt():
    # physics.md §7: 54 000 DWT container ship → Capacity 37 800 t → f_w 0.852.
    cap = sl.imo_fw_capacity("container", 54_000.0)
    assert float(cap) == pytest.approx(37_800.0, rel=1e-12)
    assert float(sl.imo_fw("container", cap)) == pytest.approx(0.852, abs=5e-4)


def test_imo_circ796_bulk_and_tanker_by_hand():
    # Circ.796 Table 1 by hand: ln 80 000 = 11.289782, ln 100 000 = 11.512925
    # bulk:   0.0429 · 11.289782 + 0.294 = 0.778332
    # tanker: 0.0238 · 11.512925 + 0.526 = 0.800008
    assert float(sl.imo_fw("bulk_carrier", sl.imo_fw_capacity("bulk_carrier", 80_000.0))) == pytest.approx(
        0.778332, abs=1e-6
    )
    assert float(sl.imo_fw("tanker", sl.imo_fw_capacity("tanker", 100_000.0))) == pytest.approx(0.800008, abs=1e-6)
    np.testing.assert_allclose(
        sl.imo_fw("tanker", [1e4, 1e5]), [0.0238 * math.log(1e4) + 0.526, 0.0238 * math.log(1e5) + 0.526]
    )


def test_imo_circ796_has_no_general_cargo_curve():
    assert float(sl.imo_fw_capacity("general_cargo", 12_000.0)) == 12_000.0  # EEDI Capacity = DWT
    with pytest.raises(ConfigError, match="general_cargo"):
        sl.imo_fw("general_cargo", 12_000.0)


# ---------------------------------------------------------------- currents


def test_hand_worked_current_example_course_090_current_from_south():
    # STW 10 kn, course 090, current 1 kn from the south (flowing north:
    # u = 0, v = 1 kn = 0.514444 m/s).  The current pushes the ship to port
    # at 1 kn, so it crabs to starboard by δ = arcsin(1/10) = 5.7392°:
    # heading 095.7392°; SOG = √(10² − 1²) = √99 = 9.949874 kn.
    heading, sog = currents.heading_for_course(90.0, 10.0, 0.0, 1.0 * KN)
    assert float(heading) == pytest.approx(95.739170, abs=1e-6)
    assert float(sog) == pytest.approx(9.949874, abs=1e-6)
    # Forward: 10 kn on 095.7392 plus 1 kn north → east 9.949874, north 0.
    sog2, cog = currents.sog_from_stw(10.0, heading, 0.0, 1.0 * KN)
    assert float(cog) == pytest.approx(90.0, abs=1e-9)
    assert float(sog2) == pytest.approx(9.949874, abs=1e-6)


def test_hand_worked_stw_for_sog_course_000_current_to_east():
    # SOG 10 kn due north against a 1 kn current flowing east: the water
    # velocity is (−1, 10) kn → STW √101 = 10.049876 kn, heading
    # 360° − atan(1/10) = 354.289407°.
    stw, heading = currents.stw_for_sog(0.0, 10.0, 1.0 * KN, 0.0)
    assert float(stw) == pytest.approx(10.049876, abs=1e-6)
    assert float(heading) == pytest.approx(354.289407, abs=1e-6)


def test_hand_worked_head_and_following_currents():
    # 2 kn current flowing south; ship heading north at 12 kn → SOG 10 kn, COG 000.
    sog, cog = currents.sog_from_stw(12.0, 0.0, 0.0, -2.0 * KN)
    assert float(sog) == pytest.approx(10.0, abs=1e-12)
    assert float(cog) == pytest.approx(0.0, abs=1e-9)
    heading, sog = currents.heading_for_course(180.0, 12.0, 0.0, -2.0 * KN)  # with the current
    assert float(heading) == pytest.approx(180.0, abs=1e-9)
    assert float(sog) == pytest.approx(14.0, abs=1e-12)


def _angle_diff(a, b):
    return abs((float(a) - float(b) + 180.0) % 360.0 - 180.0)


@settings(max_examples=200, deadline=None)
@given(
    course=st.floats(0.0, 360.0, exclude_max=True),
    stw=st.floats(6.0, 30.0),
    cur_ms=st.floats(0.0, 3.0),  # 3 m/s = 5.83 kn < STW: always feasible
    cur_to=st.floats(0.0, 360.0),
)
def test_hypothesis_current_triangle_round_trips(course, stw, cur_ms, cur_to):
    u, v = cur_ms * math.sin(math.radians(cur_to)), cur_ms * math.cos(math.radians(cur_to))
    heading, sog = currents.heading_for_course(course, stw, u, v)
    assert sog > 0.0
    # flying the crabbed heading at that STW tracks the course at that SOG
    sog2, cog = currents.sog_from_stw(stw, heading, u, v)
    assert _angle_diff(cog, course) < 1e-9
    assert float(sog2) == pytest.approx(float(sog), rel=1e-12, abs=1e-12)
    # and asking for that SOG along the course needs that STW and heading
    stw3, heading3 = currents.stw_for_sog(course, sog, u, v)
    assert float(stw3) == pytest.approx(stw, rel=1e-12)
    assert _angle_diff(heading3, heading) < 1e-9


# ---------------------------------------------------------------- bad inputs


@pytest.mark.parametrize(
    "kwargs, error, text",
    [
        (dict(calm_stw_kn=np.nan), SeaStateError, "calm_stw_kn must be finite, got nan"),
        (dict(calm_stw_kn=-1.0), SeaStateError, "calm_stw_kn must be >= 0.0, got -1.0"),
        (dict(length_m=0.0), ShipSpecError, "length_m must be > 0.0, got 0.0"),
        (dict(volume_m3=-5.0), ShipSpecError, "volume_m3 must be > 0.0, got -5.0"),
        (dict(beaufort=13), SeaStateError, "beaufort must be <= 12.0, got 13"),
        (dict(beaufort=-1), SeaStateError, "beaufort must be >= 0.0, got -1"),
        (dict(beaufort=[3, np.nan]), SeaStateError, r"beaufort must be finite, got nan at index \(1,\)"),
        (dict(weather_angle_deg=np.inf), SeaStateError, "weather_angle_deg must be finite, got inf"),
        (dict(block_coefficient=0.9), ConfigError, "block_coefficient must be <= 0.85, got 0.9.*PerformanceModel"),
        (dict(block_coefficient=0.5), ConfigError, "block_coefficient must be >= 0.55, got 0.5.*PerformanceModel"),
        (dict(ship_type="ferry"), ConfigError, "ship_type='ferry' is not known"),
        (dict(loading="heavy"), ConfigError, "loading='heavy' is not known"),
    ],
)
def test_bad_kwon_inputs_raise_naming_the_value(kwargs, error, text):
    args = dict(
        calm_stw_kn=20.0,
        length_m=230.0,
        block_coefficient=0.65,
        volume_m3=52030.0,
        beaufort=6,
        weather_angle_deg=0.0,
        ship_type="container",
        loading="normal",
    )
    args.update(kwargs)
    with pytest.raises(error, match=text):
        sl.kwon_speed_loss_pct(**args)


def test_no_headway_raises_or_marks_nan():
    # KCS at 5 kn in BN 12 head seas: C_U ≈ 2.6, C_Form ≈ 8.4 + 337 → loss ≫ 100 %.
    with pytest.raises(SeaStateError, match=r"> 100 %.*calm_stw_kn=5\.0"):
        sl.speed_in_weather_kn(5.0, 230.0, 0.65, 52030.0, 12, 0.0)
    got = sl.speed_in_weather_kn([5.0, 24.0], 230.0, 0.65, 52030.0, [12, 6], 0.0, on_unreachable="nan")
    assert np.isnan(got[0]) and np.isfinite(got[1])


def test_unreachable_weather_speed_raises_naming_the_value():
    # A 60 m coaster (∇ 2000 m³) in BN 11 head seas: C_Form ≈ 5.5 + 13 711,
    # C_U(Fn 0.30) = 3.1 − 1.59 − 1.116 = 0.394, so the loss is far above
    # 100 % at every V1 up to Fn 0.30 (14.15 kn): 8 kn cannot be made.
    with pytest.raises(SeaStateError, match=r"stw_kn=8\.0 cannot be made.*Fn 0\.3 \(14\.15 kn"):
        sl.calm_speed_for_weather_kn(8.0, 60.0, 0.70, 2000.0, 11, 0.0, ship_type="general_cargo")
    # faster than the bound itself (Fn 0.30 of 230 m = 27.70 kn)
    with pytest.raises(SeaStateError, match=r"stw_kn=40\.0"):
        sl.calm_speed_for_weather_kn(40.0, 230.0, 0.65, 52030.0, 0, 0.0)
    got = sl.calm_speed_for_weather_kn([8.0, 40.0, 5.0], 60.0, 0.70, 2000.0, [11, 0, 0], 0.0, on_unreachable="nan")
    assert np.isnan(got[0]) and np.isnan(got[1]) and got[2] == 5.0


def test_infeasible_current_raises_with_fix():
    # 1 kn STW across a 2 m/s (3.89 kn) beam current
    with pytest.raises(
        SeaStateError, match=r"cross-current 3\.888 kn exceeds stw_kn=1\.0.*more speed or another course"
    ):
        currents.heading_for_course(0.0, 1.0, 2.0, 0.0)
    # 2 kn STW into a 3.89 kn head current: set back
    with pytest.raises(SeaStateError, match=r"SOG along course_deg=0\.0 would be -1\.888 kn.*more speed"):
        currents.heading_for_course(0.0, 2.0, 0.0, -2.0)
    with pytest.raises(SeaStateError, match="stw_kn must be > 0.0, got 0.0"):
        currents.heading_for_course(0.0, 0.0, 0.0, 0.0)
    with pytest.raises(SeaStateError, match="sog_kn must be >= 0.0, got -3.0"):
        currents.stw_for_sog(0.0, -3.0, 0.0, 0.0)
    with pytest.raises(SeaStateError, match=r"current_v_ms must be finite, got nan"):
        currents.sog_from_stw(10.0, 0.0, 0.0, np.nan)


def test_bad_fw_inputs_raise_naming_the_value():
    with pytest.raises(ShipSpecError, match="capacity must be > 0.0, got -1.0"):
        sl.imo_fw("tanker", -1.0)
    with pytest.raises(ShipSpecError, match="dwt_t must be finite, got nan"):
        sl.imo_fw_capacity("container", np.nan)
    with pytest.raises(ConfigError, match="ship_type='ferry'"):
        sl.imo_fw_capacity("ferry", 1000.0)


def test_heading_for_course_nan_mode_marks_unholdable_courses():
    # 2 kn STW against a 3 kn cross-current (current to the north, course east): cannot hold; 10 kn can.
    heading, sog = currents.heading_for_course(90.0, [2.0, 10.0], 0.0, 3.0 * 1852 / 3600, on_unreachable="nan")
    assert np.isnan(heading[0]) and np.isnan(sog[0])
    # by hand: the set is to port (north) of an eastbound ship, so it heads south of east:
    # sin δ = 3/10 → δ = +17.46°, heading 107.46°, SOG = 10 cos δ = 9.539 kn
    assert heading[1] == pytest.approx(90.0 + np.degrees(np.arcsin(0.3)))
    assert sog[1] == pytest.approx(10.0 * np.sqrt(1 - 0.09))
