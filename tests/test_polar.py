"""Polar diagrams as data: file round trips, exactness at the table, the no-go sector, VMG angles, the paper's matrix."""

from __future__ import annotations

import numpy as np
import pytest

from optroute.errors import ConfigError, ShipSpecError
from optroute.physics.polar import Polar, read_polar, write_polar
from optroute.physics.yacht import SailingVessel, manoeuvre_kind, tack_of, true_wind_angle_deg

# A cruiser's polar in the layout of an OpenCPN/qtVlm .pol file (hand-made numbers, kn).
CRUISER_TWA = [0.0, 30.0, 40.0, 52.0, 60.0, 75.0, 90.0, 110.0, 120.0, 135.0, 150.0, 165.0, 180.0]
CRUISER_TWS = [6.0, 8.0, 10.0, 12.0, 16.0, 20.0]
CRUISER_BSP = [
    [0.0] * 6,
    [0.0] * 6,
    [3.9, 4.8, 5.4, 5.8, 6.1, 6.2],
    [4.6, 5.6, 6.2, 6.5, 6.8, 6.9],
    [4.9, 5.9, 6.5, 6.8, 7.1, 7.2],
    [5.2, 6.2, 6.8, 7.1, 7.4, 7.6],
    [5.3, 6.3, 6.9, 7.2, 7.6, 7.9],
    [5.2, 6.3, 7.0, 7.4, 7.9, 8.3],
    [5.0, 6.1, 6.9, 7.4, 8.0, 8.5],
    [4.5, 5.6, 6.5, 7.1, 7.9, 8.6],
    [3.8, 4.8, 5.7, 6.5, 7.4, 8.2],
    [3.3, 4.2, 5.1, 5.9, 6.9, 7.6],
    [3.1, 4.0, 4.8, 5.6, 6.6, 7.3],
]
# Życkowski's matrix C, eq. (10), as printed: rows wind speed b = 1..8, columns headings 0, 45, …, 315 deg.
ZYCKOWSKI_C = [
    [0, 0.41, 0.52, 0.53, 0.58, 0.53, 0.52, 0.41],
    [0, 0.45, 0.77, 0.86, 0.79, 0.86, 0.77, 0.45],
    [0, 0.52, 1.16, 1.13, 1.17, 1.13, 1.16, 0.52],
    [0, 0.57, 1.45, 1.33, 1.35, 1.33, 1.45, 0.57],
    [0, 0.65, 1.68, 1.70, 1.47, 1.70, 1.68, 0.65],
    [0, 0.69, 1.93, 1.97, 2.00, 1.97, 1.93, 0.69],
    [0, 0.81, 2.04, 2.05, 2.12, 0.81, 2.04, 0.81],
    [0, 0.83, 2.11, 2.16, 2.26, 0.83, 2.11, 0.83],
]


@pytest.fixture(scope="module")
def cruiser() -> Polar:
    return Polar(CRUISER_TWA, CRUISER_TWS, CRUISER_BSP, name="cruiser")


@pytest.mark.parametrize(("fmt", "delimiter"), [("table", "\t"), ("table", ";"), ("expedition", "\t")])
def test_polar_file_round_trip_is_exact(cruiser, tmp_path, fmt, delimiter):
    path = write_polar(cruiser, tmp_path / "cruiser.pol", fmt=fmt, delimiter=delimiter)
    back = read_polar(path)
    np.testing.assert_array_equal(back.twa_deg, cruiser.twa_deg)
    np.testing.assert_array_equal(back.tws_kn, cruiser.tws_kn)
    np.testing.assert_array_equal(back.speed_kn, cruiser.speed_kn)
    assert back.no_go_deg == 40.0


def test_opencpn_text_as_sailors_write_it(tmp_path):
    text = "TWA\\TWS\t6\t10\n0\t0\t0\n45\t4.1\t5.9\n90\t5.2\t7.0\n180\t3.0\t4.9\n"
    (tmp_path / "boat.pol").write_text(text)
    p = read_polar(tmp_path / "boat.pol")
    assert p.speed_kn_at(90.0, 10.0) == pytest.approx(7.0, abs=1e-12)
    (tmp_path / "gap.pol").write_text("TWA\\TWS\t6\t10\n45\t4.1\n90\t5.2\t7.0\n180\t3.0\t4.9\n")
    with pytest.raises(ConfigError, match=r"gap.pol:2: 1 speeds for 2 wind speeds"):
        read_polar(tmp_path / "gap.pol")


def test_interpolation_is_exact_at_every_table_point_and_symmetric(cruiser):
    a, w = np.meshgrid(cruiser.twa_deg, cruiser.tws_kn, indexing="ij")
    np.testing.assert_allclose(cruiser.speed_kn_at(a, w), cruiser.speed_kn, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cruiser.speed_kn_at(-a, w), cruiser.speed_kn, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cruiser.speed_kn_at(360.0 - a, w), cruiser.speed_kn, rtol=0, atol=1e-12)


def test_interpolation_is_c1_across_table_lines(cruiser):
    """One-sided derivatives agree at interior table angles and wind speeds (Hermite patches share slopes)."""
    h = 1e-6
    for twa in (52.0, 90.0, 135.0):
        left = (cruiser.speed_kn_at(twa, 9.0) - cruiser.speed_kn_at(twa - h, 9.0)) / h
        right = (cruiser.speed_kn_at(twa + h, 9.0) - cruiser.speed_kn_at(twa, 9.0)) / h
        assert left == pytest.approx(right, abs=1e-4)
    for tws in (8.0, 12.0, 16.0):
        left = (cruiser.speed_kn_at(100.0, tws) - cruiser.speed_kn_at(100.0, tws - h)) / h
        right = (cruiser.speed_kn_at(100.0, tws + h) - cruiser.speed_kn_at(100.0, tws)) / h
        assert left == pytest.approx(right, abs=1e-4)


def test_no_go_sector_is_zero_and_wind_outside_the_table(cruiser):
    assert np.all(cruiser.speed_kn_at(np.linspace(-39.99, 39.99, 101), 10.0) == 0.0)
    assert cruiser.speed_kn_at(3.0, 0.0) == 0.0  # no wind, no speed
    assert 0 < cruiser.speed_kn_at(90.0, 3.0) < cruiser.speed_kn_at(90.0, 6.0)  # below the table: towards 0 at 0 kn
    with pytest.raises(ConfigError, match=r"TWS 25.00 kn .* above the polar's largest 20 kn"):
        cruiser.speed_kn_at(90.0, 25.0)
    held = Polar(CRUISER_TWA, CRUISER_TWS, CRUISER_BSP, above_max_tws="hold")
    assert held.speed_kn_at(90.0, 25.0) == pytest.approx(7.9, abs=1e-12)


def test_vmg_angles_of_a_constant_speed_polar_are_the_limit_and_dead_downwind():
    """Hand-worked: with v constant, v·cos(TWA) is largest at the smallest sailable angle and -v·cos at 180."""
    p = Polar([0.0, 42.0, 90.0, 180.0], [5.0, 15.0], [[0, 0], [6.0, 6.0], [6.0, 6.0], [6.0, 6.0]])
    beat, beat_vmg, run, run_vmg = p.vmg_angles_deg(10.0)
    assert beat == pytest.approx(42.0) and beat_vmg == pytest.approx(6.0 * np.cos(np.radians(42.0)), rel=1e-9)
    assert run == pytest.approx(180.0) and run_vmg == pytest.approx(6.0, rel=1e-9)


def test_cruiser_vmg_angles_are_where_a_sailor_expects(cruiser):
    beat, beat_vmg, run, run_vmg = cruiser.vmg_angles_deg(12.0)
    assert 40.0 <= beat <= 60.0 and 130.0 <= run <= 180.0
    grid = np.linspace(40.0, 180.0, 14001)  # brute force over 0.01 deg
    vmg = cruiser.speed_kn_at(grid, 12.0) * np.cos(np.radians(grid))
    assert beat_vmg == pytest.approx(vmg.max(), rel=1e-9) and run_vmg == pytest.approx(-vmg.min(), rel=1e-9)


def test_zyckowski_matrix_reads_with_its_misprint_named():
    with pytest.raises(ConfigError, match=r"row 6 .*135 deg gives 2.05 kn but 225 deg gives 0.81"):
        Polar.from_matrix(ZYCKOWSKI_C, np.arange(1.0, 9.0))
    p = Polar.from_matrix(ZYCKOWSKI_C, np.arange(1.0, 9.0), asymmetric="max")
    assert p.no_go_deg == 45.0
    c = np.array(ZYCKOWSKI_C)
    np.testing.assert_allclose(p.speed_kn, c[:, :5].T, atol=0)  # 0, 45, 90, 135, 180 deg from the starboard half
    np.testing.assert_allclose(p.to_matrix(8)[:6], c[:6], atol=1e-12)  # the symmetric rows come back exactly


def test_bad_tables_say_which_entry():
    with pytest.raises(ConfigError, match=r"speed 0 at TWA 90.0 deg, TWS 10.0 kn lies beyond the no-go limit"):
        Polar([0, 45, 90, 180], [6, 10], [[0, 0], [4, 5], [5, 0], [3, 4]])
    with pytest.raises(ConfigError, match="exactly 180"):
        Polar([0, 45, 90], [6, 10], [[0, 0], [4, 5], [5, 6]])
    with pytest.raises(ShipSpecError, match="motor_speed_kn"):
        SailingVessel(Polar([0, 45, 180], [6], [[0], [4], [3]]), motoring_below_kn=3.0)


def test_wind_angle_conventions():
    # heading north, wind from 045: wind over the starboard bow, TWA +45, starboard tack
    assert true_wind_angle_deg(0.0, 45.0) == pytest.approx(45.0)
    assert true_wind_angle_deg(0.0, 315.0) == pytest.approx(-45.0)
    np.testing.assert_array_equal(tack_of([45.0, -45.0, 180.0, -180.0]), [1, 2, 0, 0])
    assert manoeuvre_kind(45.0, -45.0) == "tack" and manoeuvre_kind(150.0, -150.0) == "gybe"
