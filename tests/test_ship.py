"""Ship particulars, calm-water power, SFOC and roll period against physics.md."""

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optroute import ConfigError, ShipSpecError
from optroute.physics.ship import Ship, is_code_roll_period_s, sfoc_ratio

# physics.md §4: IS Code 2008 Part A §2.3.4, checked rows (B, d, L_wl, GM, C, T_R).
IS_CODE_CHECKED_ROWS = [
    (32.2, 10.8, 232.5, 0.60, 0.341599, 28.401),
    (32.25, 12.0, 240.0, 1.50, 0.3316125, 17.464),
    (25.4, 9.5, 175.0, 1.02, 0.359245, 18.070),
]


@pytest.mark.parametrize(("b", "d", "lwl", "gm", "c", "tr"), IS_CODE_CHECKED_ROWS)
def test_is_code_2008_roll_period_checked_rows(b, d, lwl, gm, c, tr):
    assert is_code_roll_period_s(b, d, lwl, gm) == pytest.approx(tr, abs=5e-4)
    assert 2 * c * b / math.sqrt(gm) == pytest.approx(tr, abs=5e-4)


def test_general_cargo_preset_uses_the_checked_is_code_hull():
    assert Ship.preset("general_cargo_25k_dwt").roll_period_s == pytest.approx(18.070, abs=5e-4)


def test_fourth_imo_ghg_study_sfoc_curve_checked_points():
    # physics.md §8: 1.039 at 50 % load, minimum 1.003 at 78 %, 1.025 at 100 %.
    assert sfoc_ratio(0.5) == pytest.approx(1.03875, abs=1e-9)
    assert sfoc_ratio(1.0) == pytest.approx(1.025, abs=1e-9)
    loads = np.linspace(0.1, 1.0, 9001)
    assert loads[np.argmin(sfoc_ratio(loads))] == pytest.approx(0.780, abs=1e-3)
    assert sfoc_ratio(0.78) == pytest.approx(1.003, abs=5e-4)


def test_fuel_rate_by_hand():
    ship = Ship.preset("container_54k_dwt")
    p = 0.5 * ship.mcr_kw  # 18 250 kW at 50 % load: 175 g/kWh * 1.03875 * 18250 kW / 1e6
    assert ship.fuel_rate_tph(p) == pytest.approx(175 * 1.03875 * 18250 / 1e6, rel=1e-12)


def test_admiralty_law_calibrated_to_service_point():
    ship = Ship.preset("container_8000teu")
    # 85 % MCR includes a 15 % sea margin: calm power at 25 kn = 0.85 * 68 640 / 1.15 kW.
    assert ship.calm_power_kw(25.0) == pytest.approx(0.85 * 68_640 / 1.15, rel=1e-12)
    # cube law: 20 kn needs (20/25)^3 of it.
    assert ship.calm_power_kw(20.0) == pytest.approx(0.512 * 0.85 * 68_640 / 1.15, rel=1e-12)
    assert ship.calm_power_kw(ship.max_calm_speed_kn) == pytest.approx(ship.mcr_kw, rel=1e-9)


def test_speed_power_table_is_monotone_and_exact_at_its_points():
    table = ((10.0, 3000.0), (14.0, 8000.0), (18.0, 15000.0), (24.5, 31000.0))
    ship = Ship.preset("container_54k_dwt").replace(speed_power_table=table)
    for v, p in table:
        assert ship.calm_power_kw(v) == pytest.approx(p)
    v = np.linspace(0.0, 30.0, 601)
    assert np.all(np.diff(ship.calm_power_kw(v)) > 0)
    # beyond the ends: the cube law through the end points
    assert ship.calm_power_kw(5.0) == pytest.approx(3000.0 / 8.0)
    assert ship.calm_power_kw(26.0) == pytest.approx(31000.0 * (26 / 24.5) ** 3)


@settings(max_examples=200, deadline=None)
@given(st.floats(1000.0, 60_000.0))
def test_calm_speed_inverts_calm_power(power_kw):
    for name in Ship.presets():
        ship = Ship.preset(name)
        assert ship.calm_power_kw(ship.calm_speed_kn(power_kw)) == pytest.approx(power_kw, rel=1e-9)


def test_presets_listed_and_unknown_preset_lists_valid_names():
    assert set(Ship.presets()) == {"container_54k_dwt", "container_8000teu", "general_cargo_25k_dwt"}
    with pytest.raises(ConfigError, match="container_54k_dwt"):
        Ship.preset("titanic")


@pytest.mark.parametrize(
    ("field", "value", "pattern"),
    [
        ("length_m", 0.0, "length_m=0.0"),
        ("length_m", -5.0, "length_m=-5.0"),
        ("block_coefficient", 0.3, r"block_coefficient=0.3 .*\[0.35, 0.95\]"),
        ("block_coefficient", 0.97, "block_coefficient"),
        ("gm_m", 0.0, "gm_m=0.0"),
        ("mcr_kw", -1.0, "mcr_kw"),
        ("mcr_kw", float("nan"), "mcr_kw=nan"),
        ("displacement_t", 670_400.0, "check the units"),
        ("ship_type", "yacht", "ship_type='yacht'"),
        ("loading", "half", "loading='half'"),
        ("speed_power_table", ((10, 100), (9, 200), (12, 300)), "strictly increasing"),
    ],
)
def test_non_physical_values_raise_naming_field_and_value(field, value, pattern):
    with pytest.raises(ShipSpecError, match=pattern):
        Ship.preset("container_54k_dwt").replace(**{field: value})


def test_from_mapping_names_the_source():
    data = {f: getattr(Ship.preset("container_54k_dwt"), f) for f in ("name", "length_m", "beam_m", "draught_m")}
    with pytest.raises(ShipSpecError, match="ship.toml: missing required ship field"):
        Ship.from_mapping(data, source="ship.toml")
    with pytest.raises(ShipSpecError, match="unknown ship field"):
        Ship.from_mapping({**data, "colour": "red"}, source="ship.toml")


def test_design_speed_beyond_what_the_mcr_reaches_raises():
    table = ((10.0, 3000.0), (14.0, 8000.0), (18.0, 15000.0), (24.5, 31000.0))
    ship = Ship.preset("container_54k_dwt").replace(speed_power_table=table)
    with pytest.raises(ShipSpecError, match=r"design_speed_kn=26.0 kn needs .* above mcr_kw.*reaches 25.\d\d kn"):
        ship.replace(design_speed_kn=26.0)


# --------------------------------------------------------------------------- TOML files

PANAMAX_TOML = """\
# seed 001's Panamax container ship, physics.md §8
length_m = 250.0
beam_m = 32.2
draught_m = 12.5
gm_m = 1.5
block_coefficient = 0.65
displacement_t = 67040.0
design_speed_kn = 24.0
mcr_kw = 36500.0
ship_type = "container"
dwt_t = 54000.0
speed_power_table = [[12.0, 4200.0], [18.0, 13000.0], [24.0, 31000.0]]
"""


def test_from_toml_reads_the_documented_schema(tmp_path):
    path = tmp_path / "panamax.toml"
    path.write_text(PANAMAX_TOML)
    ship = Ship.from_toml(path)
    assert ship.name == "panamax"  # the file's stem when the file names none
    assert (ship.length_m, ship.beam_m, ship.draught_m, ship.gm_m) == (250.0, 32.2, 12.5, 1.5)
    assert ship.speed_power_table == ((12.0, 4200.0), (18.0, 13000.0), (24.0, 31000.0))
    assert float(ship.calm_power_kw(18.0)) == pytest.approx(13000.0)  # the table's own point
    assert ship.min_load_fraction == 0.10  # a default of the dataclass
    named = tmp_path / "other.toml"
    named.write_text('name = "my_panamax"\n' + PANAMAX_TOML)
    assert Ship.from_toml(named).name == "my_panamax"


def test_the_docstring_example_is_a_valid_ship(tmp_path):
    doc = Ship.from_toml.__doc__
    block = doc.split("::", 1)[1].split("Required:", 1)[0]
    lines = [ln[12:] for ln in block.splitlines() if ln.strip()]
    path = tmp_path / "doc.toml"
    path.write_text("\n".join(lines) + "\n")
    ship = Ship.from_toml(path)
    assert ship.name == "my_panamax" and ship.mcr_kw == 36500.0


@pytest.mark.parametrize(
    ("edit", "needles"),
    [
        (lambda t: t.replace("gm_m = 1.5\n", ""), ["missing", "gm_m (0, 15]"]),
        (lambda t: t.replace("mcr_kw = 36500.0\n", "").replace("beam_m = 32.2\n", ""), ["beam_m", "mcr_kw"]),
        (lambda t: t.replace("gm_m = 1.5", "gm_m = -1.5"), ["gm_m=-1.5", "(0, 15]"]),
        (lambda t: t.replace("draught_m = 12.5", 'draught_m = "deep"'), ["draught_m='deep'", "not a number"]),
        (lambda t: t + "speed_kn = 20.0\n", ["unknown ship field", "speed_kn"]),
        (lambda t: t.replace("block_coefficient = 0.65", "block_coefficient = 0.65 0.7"), ["not valid TOML"]),
        (
            lambda t: t.replace("displacement_t = 67040.0", "displacement_t = 6704.0").replace("dwt_t = 54000.0\n", ""),
            ["displacement_t=6704.0", "disagrees"],
        ),
    ],
)
def test_bad_toml_names_the_file_and_the_field(tmp_path, edit, needles):
    path = tmp_path / "bad.toml"
    path.write_text(edit(PANAMAX_TOML))
    with pytest.raises(ShipSpecError) as info:
        Ship.from_toml(path)
    message = str(info.value)
    assert str(path) in message
    for needle in needles:
        assert needle in message


def test_missing_toml_file_lists_the_presets(tmp_path):
    with pytest.raises(ShipSpecError, match="does not exist") as info:
        Ship.from_toml(tmp_path / "nope.toml")
    assert all(name in str(info.value) for name in Ship.presets())


# --------------------------------------------------------------------------- plausibility (issue 14, failure 3)

README_TOML = Path(__file__).resolve().parents[1] / "README.md"


def _readme_ship() -> Ship:
    text = README_TOML.read_text()
    block = text.split("```toml\n", 1)[1].split("```", 1)[0]
    return Ship.from_mapping(tomllib.loads(block), source="README.md")


def test_presets_and_documented_ships_are_plausible():
    ships = [Ship.preset(n) for n in Ship.presets()]
    ships.append(_readme_ship())
    ships.append(Ship.from_mapping({"name": "doc", **tomllib.loads(PANAMAX_TOML)}))
    ships.append(Ship.preset("container_54k_dwt").replace(name="small_feeder", mcr_kw=20000.0))  # test_voyage_study
    for ship in ships:  # construction is the check; the figures by hand for the record
        p = float(ship.calm_power_kw(ship.design_speed_kn))
        c_adm = ship.displacement_t ** (2 / 3) * ship.design_speed_kn**3 / p
        assert 150.0 <= c_adm <= 2500.0 and 0.01 <= p / ship.displacement_t <= 5.0, ship.name
    # the Panamax preset by hand: 67 040^(2/3) = 1650.3, 24³ = 13 824, P = 0.85·36 500/1.15 = 26 978 kW
    assert Ship.preset("container_54k_dwt").admiralty_coefficient == pytest.approx(1650.3 * 13824 / 26978.3, rel=1e-4)


@pytest.mark.parametrize(
    ("preset", "changes", "needles"),
    [
        # the case: MW typed as kW for a 67 000 t, 24 kn ship
        ("container_54k_dwt", {"mcr_kw": 36.5}, ["36.5 kW looks like MW; did you mean 36 500 kW?", "admiralty"]),
        ("general_cargo_25k_dwt", {"mcr_kw": 7.0}, ["7 kW looks like MW; did you mean 7 000 kW?"]),
        ("container_54k_dwt", {"design_speed_kn": 12.35}, ["12.35 looks like m/s; did you mean 24.0 kn?"]),
        ("general_cargo_25k_dwt", {"design_speed_kn": 25.93}, ["25.93 looks like km/h; did you mean 14.0 kn?"]),
        (
            "container_54k_dwt",
            {"speed_power_table": ((12.0, 4.2), (18.0, 13.0), (24.0, 31.0)), "mcr_kw": 36.5},
            ["mcr_kw and the speed-power table's powers: 36.5 kW looks like MW"],
        ),
    ],
)
def test_unit_slips_are_refused_naming_the_likely_slip(preset, changes, needles):
    with pytest.raises(ShipSpecError) as info:
        Ship.preset(preset).replace(**changes)
    for needle in needles:
        assert needle in str(info.value)


def test_an_engine_far_too_big_for_the_design_speed_is_refused():
    # 24 kn needs 31 MW in calm water by this table; a 200 MW engine is no design
    table = ((12.0, 4200.0), (18.0, 13000.0), (24.0, 31000.0))
    with pytest.raises(ShipSpecError, match=r"needs 0.155 of MCR in calm water, outside 0.2–1"):
        Ship.preset("container_54k_dwt").replace(speed_power_table=table, mcr_kw=200_000.0)
