"""``optroute bands``: table, plot, exit codes and one-line errors."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from optroute.cli import main
from optroute.physics.safety import BANDS, is_speed_forbidden
from optroute.physics.ship import Ship

ROOT = Path(__file__).resolve().parents[1]


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def table_rows(out: str) -> list[tuple[str, float, float]]:
    rows = []
    for line in out.splitlines():
        parts = line.split()
        if parts and parts[0] in BANDS:
            rows.append((parts[0], float(parts[1]), float(parts[2])))
    return rows


def test_defaults_work_and_show_bands_that_apply(capsys):
    # container_54k_dwt, L 250 m: 0.04 L = 10.0 m <= Hs 10.5 m; heading 160 into waves from 0: α 200°.
    code, out, err = run(capsys, "bands")
    assert code == 0 and err == ""
    assert "container_54k_dwt" in out and "L 250.0 m" in out
    assert "bands APPLY" in out
    assert "alpha 200 deg" in out
    assert "lambda 224.8 m" in out  # 1.5613 · 12² = 224.8 m
    assert table_rows(out)


def test_below_threshold_says_bands_do_not_apply(capsys):
    # container_8000teu, L 320 m: 0.04 L = 12.8 m > Hs 6 m
    code, out, err = run(
        capsys,
        "bands",
        "--ship",
        "container_8000teu",
        "--hs",
        "6",
        "--period",
        "11",
        "--heading",
        "180",
        "--wave-from",
        "0",
    )
    assert code == 0 and err == ""
    assert "bands do not apply" in out
    assert "forbidden speeds [kn]: none" in out
    assert "alpha 180 deg (following seas" in out


def test_table_rows_are_forbidden_speeds(capsys):
    code, out, err = run(
        capsys,
        "bands",
        "--ship",
        "container_8000teu",
        "--hs",
        "14",
        "--period",
        "11",
        "--heading",
        "180",
        "--wave-from",
        "0",
    )
    assert code == 0 and err == ""
    assert "bands APPLY" in out
    rows = table_rows(out)
    assert {r[0] for r in rows} == set(BANDS)
    ship = Ship.preset("container_8000teu")
    for band, lo, hi in rows:
        mid = 0.5 * (lo + hi) if np.isfinite(hi) else lo + 1.0
        assert is_speed_forbidden(
            ship, speed_kn=mid, hs_m=14.0, period_s=11.0, wave_from_deg=0.0, heading_deg=180.0, band=band
        ), (band, lo, hi)
    # safe ranges lie below the max calm speed and are not forbidden
    assert f"up to {ship.max_calm_speed_kn:.2f} kn" in out
    safe = [ln.strip() for ln in out.split("safe speeds")[1].splitlines()[1:] if ln.strip().startswith(("(", "["))]
    assert safe
    for rng in safe:
        lo, hi = (float(x) for x in rng.strip("[]()").split(","))
        assert hi <= ship.max_calm_speed_kn + 0.01
        assert not is_speed_forbidden(
            ship, speed_kn=0.5 * (lo + hi), hs_m=14.0, period_s=11.0, wave_from_deg=0.0, heading_deg=180.0
        )


def test_imo_rules_and_other_preset(capsys):
    code, out, _ = run(
        capsys,
        "bands",
        "--ship",
        "general_cargo_25k_dwt",
        "--hs",
        "8",
        "--period",
        "9",
        "--heading",
        "200",
        "--rules",
        "imo",
    )
    assert code == 0
    assert "rules      imo" in out
    # IMO surf-riding limit 1.8 √170 / cos(20°) = 24.98 kn, above this ship's top speed
    assert any(r[0] == "surf_riding" and r[1] == pytest.approx(24.98, abs=0.01) for r in table_rows(out))
    assert "(above max speed)" in out


def test_beam_sea_all_forbidden(capsys):
    # general_cargo_25k_dwt T_R 18.07 s; T 18 s beam on: T_E = T at every speed, in the sync band
    code, out, _ = run(
        capsys, "bands", "--ship", "general_cargo_25k_dwt", "--hs", "8", "--period", "18", "--heading", "90"
    )
    assert code == 0
    assert table_rows(out)[0][:2] == ("synchronous_roll", 0.0)
    assert "inf" in out
    assert "safe speeds [kn] up to 15.48 kn: none" in out


def test_plot_writes_png_atomically(capsys, tmp_path):
    target = tmp_path / "bands.png"
    code, out, err = run(capsys, "bands", "--ship", "container_8000teu", "--hs", "14", "--plot", str(target))
    assert code == 0 and err == ""
    data = target.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    assert f"plot written to {target}" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bands.png"]  # no temp file left behind


def test_plot_below_threshold_still_draws(capsys, tmp_path):
    target = tmp_path / "calm.png"
    assert run(capsys, "bands", "--plot", str(target))[0] == 0
    assert target.stat().st_size > 0


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["bands", "--hs", "-1"], "hs_m must be >= 0.0, got -1.0"),
        (["bands", "--hs", "nan"], "hs_m must be finite"),
        (["bands", "--period", "0"], "period_s"),
        (["bands", "--ship", "titanic"], "container_54k_dwt"),
        (["bands", "--hs", "abc"], "invalid float value: 'abc'"),
        (["bands", "--rules", "dnv"], "invalid choice: 'dnv'"),
        (["bands", "--margin", "1.5"], "margin"),
        (["bands", "--bogus"], "unrecognized arguments"),
        ([], "COMMAND"),
    ],
)
def test_bad_input_exit_2_with_one_line(capsys, argv, needle):
    code, out, err = run(capsys, *argv)
    assert code == 2
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("optroute: error: ")
    assert needle in lines[0]


def test_unknown_preset_lists_every_valid_name(capsys):
    _, _, err = run(capsys, "bands", "--ship", "titanic")
    assert "titanic" in err
    for name in Ship.presets():
        assert name in err


def test_bad_plot_path_is_input_error_and_prints_nothing(capsys, tmp_path):
    code, out, err = run(capsys, "bands", "--plot", str(tmp_path / "missing" / "x.png"))
    assert code == 2 and out == "" and len(err.splitlines()) == 1 and "does not exist" in err
    code, out, err = run(capsys, "bands", "--plot", str(tmp_path / "x.jpg"))
    assert code == 2 and ".png" in err
    assert list(tmp_path.iterdir()) == []


def test_debug_shows_traceback(capsys):
    code, _, err = run(capsys, "bands", "--hs", "-1", "--debug")
    assert code == 2
    assert "Traceback" in err and err.rstrip().splitlines()[-1].startswith("optroute: error: ")


def test_help_returns_0(capsys):
    code, out, _ = run(capsys, "bands", "--help")
    assert code == 0 and "--wave-from" in out


def test_python_dash_m(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    # one run (importing optroute takes seconds; the success path is tested in-process above)
    bad = subprocess.run(
        [sys.executable, "-m", "optroute", "bands", "--hs", "-2"], capture_output=True, text=True, env=env, cwd=tmp_path
    )
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and bad.stderr.startswith("optroute: error: ")


def test_ship_from_a_toml_file(capsys, tmp_path):
    # the general cargo preset's hull written as a file: T_R 18.07 s (IS Code row of physics.md §4)
    path = tmp_path / "cargo.toml"
    path.write_text(
        'name = "my_cargo"\nlength_m = 170.0\nbeam_m = 25.4\ndraught_m = 9.5\ngm_m = 1.02\n'
        "block_coefficient = 0.75\ndisplacement_t = 31540.0\ndesign_speed_kn = 14.0\nmcr_kw = 7000.0\n"
        'ship_type = "general_cargo"\nloading = "loaded"\nwaterline_length_m = 175.0\nmin_load_fraction = 0.15\n'
    )
    code, out, err = run(capsys, "bands", "--ship", str(path), "--hs", "8", "--period", "18", "--heading", "90")
    assert code == 0 and err == ""
    assert "my_cargo: L 170.0 m, T_R 18.07 s" in out
    assert table_rows(out)[0][:2] == ("synchronous_roll", 0.0)  # beam seas at T = T_R, as with the preset


def test_bad_ship_file_is_one_line(capsys, tmp_path):
    path = tmp_path / "short.toml"
    path.write_text("length_m = 170.0\n")
    code, out, err = run(capsys, "bands", "--ship", str(path))
    assert code == 2 and out == "" and len(err.splitlines()) == 1
    assert str(path) in err and "beam_m" in err
