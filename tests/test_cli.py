"""The ``optroute`` command line: every command's help, exit codes 0/2/3/4, outputs and one-line errors.

Commands run in-process through :func:`optroute.cli.main` on tiny weather files (a 12° × 20°
box of the mid-Pacific, 1° grid, 5 days) and three-waypoint corridors; one smoke test runs the
installed console script. Independent references: in calm water on a fixed path the least-fuel
plan for an ETA is the constant speed D/T and burns T · fuel_rate(calm_power(D/T)) (the
ship's own calm-water curve, no optimiser involved); hand-written positions and times.
"""

from __future__ import annotations

import contextlib
import json
import re
import shutil
import socket
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

import optroute as orx
from optroute import geodesy as geo
from optroute import units
from optroute.cli import exit_code, main
from optroute.cli import tools as cli_tools
from optroute.cli._common import parse_eta, parse_etas, parse_position, parse_time, read_waypoints
from optroute.cli._status import explain_status, status_legend
from optroute.cli._voice import CLI_FIXES
from optroute.errors import ConfigError, InfeasibleETA, NoSafePassage, OnLandError, SolverFailure
from optroute.geo.land import SYNTHETIC_GEOGRAPHY
from optroute.weather.catalogue import scenario_names
from tests.test_outputs import check_rfc7946

T0 = np.datetime64("2024-01-10T00:00", "ns")
CORRIDOR = [(30.0, -150.0), (31.0, -145.0), (32.0, -140.0)]
COMMANDS = ("plan", "optimise", "tradeoff", "study", "bands", "demo", "bench", "simulate")
ROOT = Path(__file__).resolve().parents[1]
#: Python-API parameters that no option of the command line sets: a CLI error's fix must not name them.
API_ONLY = re.compile(
    r"\b(max_distance_nm|snap_max_nm|scheduler_address|time_policy|solver_options|on_unreachable|timeout_s"
    r"|plan_voyage|max_leg_nm)\b"
)
SHIP = orx.Ship.preset("container_54k_dwt")


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_error_line(err: str) -> str:
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("optroute: error: ")
    return lines[0]


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("cli")
    box = {"bbox": (25.0, 37.0, -155.0, -135.0), "start": T0, "duration_h": 120.0, "resolution_deg": 1.0}
    paths = {"rough": folder / "rough.nc", "calm": folder / "calm.nc", "csv": folder / "corridor.csv"}
    orx.scenarios.uniform(hs_m=2.0, **box).to_netcdf(paths["rough"])
    orx.scenarios.calm(**box).to_netcdf(paths["calm"])
    paths["csv"].write_text("lat,lon\n" + "".join(f"{la},{lo}\n" for la, lo in CORRIDOR))
    return paths


def corridor_nm() -> float:
    wp = np.array(CORRIDOR)
    return float(np.sum(geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])))


# --------------------------------------------------------------------------- help


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_has_help_with_examples(capsys, command):
    code, out, err = run(capsys, command, "--help")
    assert code == 0 and err == ""
    assert f"usage: optroute {command}" in out
    assert "examples:\n  optroute " + command in out


def test_top_level_help_lists_every_command_and_the_exit_codes(capsys):
    code, out, _ = run(capsys, "--help")
    assert code == 0
    for command in COMMANDS:
        assert command in out
    assert "2 bad input, 3 infeasible" in out


# --------------------------------------------------------------------------- success (exit 0)


def test_optimise_calm_fixed_path_is_constant_speed_and_writes_three_files(capsys, files, tmp_path):
    code, out, err = run(
        capsys,
        "optimise",
        "--ship",
        "container_54k_dwt",
        "--corridor",
        files["csv"],
        "--width-nm",
        "0",
        "--weather",
        files["calm"],
        "--eta",
        "+36",
        "--out",
        tmp_path / "leg",
        "--progress",
    )
    assert code == 0
    assert "100%" in err  # the progress bar ran to the end
    csv = pd.read_csv(tmp_path / "leg.csv")
    d, t = corridor_nm(), 36.0
    v = d / t
    np.testing.assert_allclose(csv["stw_kn"], v, rtol=2e-4)
    fuel = t * float(SHIP.fuel_rate_tph(SHIP.calm_power_kw(v)))
    assert csv["fuel_t"].sum() == pytest.approx(fuel, rel=1e-3)
    assert re.search(rf"fuel\s+{csv['fuel_t'].sum():,.2f} t", out)
    assert "arrival    2024-01-11T12:00:00Z (ETA 2024-01-11T12:00:00Z, le)" in out
    assert "status     optimal: Ipopt converged" in out
    check_rfc7946(json.loads((tmp_path / "leg.geojson").read_text()))
    nc = pd.read_csv(tmp_path / "leg.csv")  # the NetCDF agrees with the CSV
    with xr.open_dataset(tmp_path / "leg.nc") as ds:
        assert ds.attrs["Conventions"] == "CF-1.8"
        np.testing.assert_allclose(ds["fuel_t"].values, nc["fuel_t"].to_numpy())


def test_plan_with_the_default_grid_search(capsys, files, tmp_path):
    # the default --search grid is the time-dependent A* (a minimum-time plan: one search, no λ bisection);
    # no plan can beat the great circle at the top calm-water speed
    code, out, err = run(
        capsys,
        "plan",
        "--ship",
        "container_54k_dwt",
        "--from",
        "30,-150",
        "--to",
        "32N,140W",
        "--weather",
        files["rough"],
        "--cell-nm",
        "60",
        "--objective",
        "time",
        "--out",
        f"{tmp_path}/grid/",
    )
    assert code == 0, err
    csv = pd.read_csv(tmp_path / "grid" / "plan.csv")
    hours = csv["duration_h"].sum()
    gc_nm = float(geo.distance_nm(30.0, -150.0, 32.0, -140.0))
    assert hours >= gc_nm / orx.Ship.preset("container_54k_dwt").max_calm_speed_kn * (1 - 1e-6)


def test_plan_searches_optimises_and_meets_the_eta(capsys, files, tmp_path):
    code, out, err = run(
        capsys,
        "plan",
        "--ship",
        "container_54k_dwt",
        "--from",
        "30,-150",
        "--to",
        "32N,140W",
        "--weather",
        files["rough"],
        "--search",
        "dp",
        "--cell-nm",
        "120",
        "--eta",
        "2024-01-11T16:00",
        "--out",
        f"{tmp_path}/run/",
    )
    assert code == 0, err
    names = sorted(p.name for p in (tmp_path / "run").iterdir())
    assert names == ["plan.csv", "plan.geojson", "plan.nc"]
    csv = pd.read_csv(tmp_path / "run" / "plan.csv")
    arrival = pd.Timestamp(csv["end_time_utc"].iloc[-1]).tz_localize(None)
    assert arrival <= pd.Timestamp("2024-01-11T16:00") + pd.Timedelta(minutes=1)
    assert (csv["start_lat_deg"].iloc[0], csv["start_lon_deg"].iloc[0]) == pytest.approx((30.0, -150.0), abs=1e-9)
    assert (csv["end_lat_deg"].iloc[-1], csv["end_lon_deg"].iloc[-1]) == pytest.approx((32.0, -140.0), abs=1e-9)
    doc = json.loads((tmp_path / "run" / "plan.geojson").read_text())
    check_rfc7946(doc)
    assert doc["features"][0]["properties"]["total_fuel_t"] == pytest.approx(csv["fuel_t"].sum())
    # the NLP's plan, or its verified start when the NLP did not improve on it (never a worse plan)
    status = re.search(r"^status     (optimal|start): ", out, re.M)
    assert status and (status.group(1) == "start" or "ETA value" in out)  # a start has no ETA multiplier


def test_a_plan_geojson_is_a_corridor_for_optimise(capsys, files, tmp_path):
    assert (
        run(
            capsys,
            "optimise",
            "--ship",
            "container_54k_dwt",
            "--corridor",
            files["csv"],
            "--width-nm",
            "0",
            "--weather",
            files["calm"],
            "--objective",
            "time",
            "--out",
            tmp_path / "a",
        )[0]
        == 0
    )
    code, out, _ = run(
        capsys,
        "optimise",
        "--ship",
        "container_54k_dwt",
        "--corridor",
        tmp_path / "a.geojson",
        "--width-nm",
        "0",
        "--weather",
        files["calm"],
        "--objective",
        "time",
        "--out",
        tmp_path / "b",
    )
    assert code == 0
    a, b = pd.read_csv(tmp_path / "a.csv"), pd.read_csv(tmp_path / "b.csv")
    assert b["distance_nm"].sum() == pytest.approx(a["distance_nm"].sum(), rel=1e-9)
    # minimum time in calm water: the calm-water speed at MCR all the way
    np.testing.assert_allclose(b["stw_kn"], SHIP.max_calm_speed_kn, rtol=1e-3)


def test_tradeoff_writes_a_monotone_front(capsys, files, tmp_path):
    code, out, err = run(
        capsys,
        "tradeoff",
        "--ship",
        "container_54k_dwt",
        "--corridor",
        files["csv"],
        "--width-nm",
        "0",
        "--weather",
        files["calm"],
        "--n",
        "3",
        "--out",
        f"{tmp_path}/front/",
    )
    assert code == 0, err
    front = pd.read_csv(tmp_path / "front" / "front.csv")
    assert {"eta_utc", "eta_h", "fuel_t", "duration_h", "status"} <= set(front.columns)
    assert len(front) == 3 and np.all(np.diff(front["fuel_t"]) <= 1e-9)
    # the first point is the minimum-time passage: calm-water speed at MCR
    assert front["eta_h"].iloc[0] == pytest.approx(corridor_nm() / SHIP.max_calm_speed_kn, rel=1e-3)
    png = (tmp_path / "front" / "front.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    assert (tmp_path / "front" / "front.nc").stat().st_size > 0
    assert "knee" in out
    assert "status     optimal: Ipopt converged" in out  # the legend of the status column


@pytest.mark.skipif(not hasattr(orx, "study"), reason="orx.study is not in this tree yet")
def test_study_runs_every_case_into_the_store(capsys, files, tmp_path):
    code, out, err = run(
        capsys,
        "study",
        "--ships",
        "container_54k_dwt",
        "--scenarios",
        f"{files['calm']},{files['rough']}",
        "--corridor",
        files["csv"],
        "--width-nm",
        "0",
        "--etas",
        "+36,+40",
        "--store",
        tmp_path / "store",
        "--workers",
        "0",
    )
    assert code == 0, err
    assert "= 4 cases" in out and "outcome    4 optimal" in out
    assert "status     optimal: Ipopt converged" in out
    # calm water, fixed path: the container ship's rows are the constant-speed fuel T · fuel_rate(P_calm(D/T))
    ds = xr.load_dataset(tmp_path / "store" / "study.nc")
    for hours in (36.0, 40.0):
        fuel = hours * float(SHIP.fuel_rate_tph(SHIP.calm_power_kw(corridor_nm() / hours)))
        got = ds["fuel_t"].sel(ship="container_54k_dwt", scenario=str(files["calm"]), eta_h=hours)
        assert float(got) == pytest.approx(fuel, rel=1e-3)
    assert (tmp_path / "store").is_dir()
    # the same store with another option: the stored cases are not those of this call (issue 14, failure 2)
    again = ["--ships", "container_54k_dwt", "--scenarios", f"{files['calm']},{files['rough']}", "--corridor"]
    again += [files["csv"], "--width-nm", "0", "--etas", "+36,+40", "--store", tmp_path / "store", "--workers", "0"]
    code, out, err = run(capsys, "study", *again, "--max-leg-nm", "25")
    line = one_error_line(err)
    assert code == 2 and "computed from other inputs" in line and "max_leg_nm=50.0" in line
    assert "--recompute-changed" in line
    code, out, err = run(capsys, "study", *again, "--max-leg-nm", "25", "--recompute-changed")
    assert "optroute: warning: study store" in err and "computing 4 case(s) again" in err
    assert code == 0 and "outcome    4 optimal" in out


# --------------------------------------------------------------------------- exit 3 and 4


def test_unreachable_eta_exits_3_naming_the_earliest_arrival(capsys, files, tmp_path):
    code, out, err = run(
        capsys,
        "optimise",
        "--ship",
        "container_54k_dwt",
        "--corridor",
        files["csv"],
        "--width-nm",
        "0",
        "--weather",
        files["calm"],
        "--eta",
        "+10",
        "--out",
        f"{tmp_path}/run/",
    )
    assert code == 3 and out == ""
    line = one_error_line(err)
    assert "cannot be met" in line and "arrives" in line
    # the minimum-time passage in calm water: the calm-water speed at MCR over the corridor
    earliest_h = corridor_nm() / SHIP.max_calm_speed_kn
    assert f"arrives {earliest_h:.2f} h after departure" in line
    assert not list(tmp_path.iterdir())  # nothing written, not even the output folder


def test_ipopt_stopped_after_one_iteration_returns_the_verified_start_not_a_failure(capsys, files, tmp_path):
    # Ipopt stopped at once: the optimiser returns its best verified start (exit 0), labelled as such, never an
    # unverified iterate and never a failure while a verified plan exists
    code, out, err = run(
        capsys, "optimise", "--ship", "container_54k_dwt", "--corridor", files["csv"], "--width-nm", "20",
        "--weather", files["rough"], "--eta", "+40", "--max-iter", "1", "--out", tmp_path / "x",
    )  # fmt: skip
    assert code == 0, err
    assert re.search(r"^status     start: the NLP did not improve on its best verified start", out, re.M)


def test_exit_codes_of_the_error_family():
    assert exit_code(InfeasibleETA("late")) == 3
    assert exit_code(NoSafePassage("storm everywhere")) == 3
    assert exit_code(SolverFailure("ipopt", "Restoration_Failed")) == 4
    assert exit_code(ConfigError("bad")) == 2
    assert exit_code(OnLandError("land")) == 2


def test_debug_shows_the_traceback(capsys, files):
    code, _, err = run(
        capsys,
        "optimise",
        "--ship",
        "container_54k_dwt",
        "--corridor",
        files["csv"],
        "--weather",
        "atlantis",
        "--debug",
    )
    assert code == 2 and "Traceback" in err
    assert err.rstrip().splitlines()[-1].startswith("optroute: error: ")


# --------------------------------------------------------------------------- bad input (exit 2)

SHIP_TOML = """\
length_m = 250.0
beam_m = 32.2
draught_m = 12.5
gm_m = 1.5
block_coefficient = 0.65
displacement_t = 67040.0
design_speed_kn = 24.0
mcr_kw = 36500.0
"""


def bad_inputs(files: dict[str, Path], tmp: Path) -> list[tuple[list[str], list[str]]]:
    missing = tmp / "missing_gm.toml"
    missing.write_text(SHIP_TOML.replace("gm_m = 1.5\n", ""))
    negative = tmp / "negative_gm.toml"
    negative.write_text(SHIP_TOML.replace("gm_m = 1.5", "gm_m = -1.5"))
    one = tmp / "one.csv"
    one.write_text("lat,lon\n30,-150\n")
    inland = tmp / "inland.geojson"  # Kansas
    inland.write_text(json.dumps({"type": "LineString", "coordinates": [[-150.0, 30.0], [-98.0, 38.5]]}))
    empty = tmp / "empty.geojson"
    empty.write_text(json.dumps({"type": "FeatureCollection", "features": []}))
    opt = [
        "optimise",
        "--ship",
        "container_54k_dwt",
        "--corridor",
        str(files["csv"]),
        "--weather",
        str(files["calm"]),
        "--out",
        str(tmp / "o"),
    ]
    return [
        (opt + ["--eta", "2024-01-09T12:00"], ["(2024-01-09T12:00:00Z)", "departure 2024-01-10T00:00:00Z"]),
        (opt + ["--departure", "2024-01-10T06:00", "--eta", "2024-01-10T05:00Z"], ["departure 2024-01-10T06:00:00Z"]),
        (opt + ["--eta", "+0"], ["is not after the departure"]),
        (opt + ["--eta", "tomorrow"], ["'tomorrow' is not a time"]),
        (opt + ["--ship", "titanic"], ["'titanic'", *orx.Ship.presets()]),
        (opt + ["--ship", str(missing)], [str(missing), "missing", "gm_m"]),
        (opt + ["--ship", str(negative)], [str(negative), "gm_m=-1.5"]),
        (
            ["optimise", "--ship", "container_54k_dwt", "--corridor", str(files["csv"]), "--weather", "atlantis"],
            ["'atlantis'", *scenario_names()],
        ),
        (
            ["optimise", "--ship", "container_54k_dwt", "--corridor", str(one), "--weather", str(files["calm"])],
            [str(one), "1 point(s)", "two"],
        ),
        (
            ["optimise", "--ship", "container_54k_dwt", "--corridor", str(empty), "--weather", str(files["calm"])],
            ["no LineString"],
        ),
        (
            ["optimise", "--ship", "container_54k_dwt", "--corridor", str(inland), "--weather", str(files["calm"])],
            ["1 (38.5000, -98.0000)", "land"],
        ),
        (
            [
                "optimise",
                "--ship",
                "container_54k_dwt",
                "--corridor",
                str(tmp / "nope.csv"),
                "--weather",
                str(files["calm"]),
            ],
            ["does not exist"],
        ),
        (opt + ["--width-nm", "-5"], ["--width-nm -5.0"]),
        # a fuel price of 0 leaves the cost objective (an hour worth hourly cost / price tonnes) undefined
        (opt + ["--objective", "cost", "--fuel-price", "0"], ["--fuel-price 0.0", "> 0", "--objective time"]),
        (opt + ["--hourly-cost", "-1"], ["--hourly-cost -1.0", ">= 0"]),
        (opt + ["--band-leg-nm", "0"], ["--band-leg-nm 0.0", "> 0", "one leg length everywhere"]),
        (
            ["plan", "--ship", "container_54k_dwt", "--weather", "calm", "--from", "95,10", "--to", "0,0"],
            ["latitude 95 is outside [-90, 90]"],
        ),
        (["plan", "--ship", "container_54k_dwt", "--weather", "calm", "--from", "30,-150"], ["--to"]),
        (
            ["plan", "--ship", "container_54k_dwt", "--weather", "calm", "--from", "30W,150N", "--to", "0,0"],
            ["'W' is not a hemisphere of latitude"],
        ),
        (
            ["tradeoff", "--ship", "container_54k_dwt", "--weather", str(files["calm"])],
            ["--from LAT,LON --to LAT,LON, or --corridor"],
        ),
        (
            [
                "study",
                "--ships",
                "container_54k_dwt,container_54k_dwt",
                "--scenarios",
                "calm",
                "--etas",
                "+30",
                "--store",
                str(tmp / "s"),
                "--corridor",
                str(files["csv"]),
            ],
            ["names a ship twice"],
        ),
        (["bench", "--only", "nope"], ["unknown benchmark(s) ['nope']"]),
    ]


def test_bad_input_exits_2_with_one_line_naming_the_problem(capsys, files, tmp_path):
    for argv, needles in bad_inputs(files, tmp_path):
        code, out, err = run(capsys, *argv)
        assert code == 2, (argv, err)
        assert out == "", argv
        line = one_error_line(err)
        for needle in needles:
            assert needle in line, (argv, line)
        assert not API_ONLY.search(line), (argv, line)  # a fix names only options the command line has
    assert not (tmp_path / "o").exists() and not list(tmp_path.glob("o.*"))


# --------------------------------------------------------------------------- parsing


def test_positions_in_decimal_degrees_or_with_hemisphere_letters():
    assert parse_position("32.71,-117.17", "p") == (32.71, -117.17)
    assert parse_position("32.71N, 117.17W", "p") == (32.71, -117.17)
    assert parse_position("33.9s,151.2e", "p") == (-33.9, 151.2)
    assert parse_position("0,190", "p") == (0.0, -170.0)  # wrapped to [-180, 180)
    for bad in ("32.71", "a,b", "-1N,5E", "10E,5N", "1,2,3"):
        with pytest.raises(ConfigError):
            parse_position(bad, "p")


def test_negative_positions_after_an_option_are_values(capsys, files, tmp_path):
    # argparse would read "-33.9,151.2" as an option; main joins it to its option
    code, _, err = run(
        capsys, "plan", "--ship", "container_54k_dwt", "--weather", "calm", "--from", "-95,10", "--to", "-1,-1"
    )
    assert code == 2 and "latitude -95 is outside" in one_error_line(err)


def test_etas_as_times_offsets_and_ranges():
    assert parse_eta("+36", T0) == np.datetime64("2024-01-11T12:00", "ns")
    assert parse_eta("+0.5", T0) == np.datetime64("2024-01-10T00:30", "ns")
    assert parse_eta("2024-01-12T00:00Z", T0) == np.datetime64("2024-01-12T00:00", "ns")
    with pytest.raises(ConfigError, match="time-zone offset"):
        parse_eta("2024-01-12T00:00+02:00", T0)
    got = parse_etas("+240:+260:10", T0)
    assert got == [T0 + np.timedelta64(h, "h") for h in (240, 250, 260)]
    assert parse_etas("+30, 2024-01-12T00:00", T0) == [T0 + np.timedelta64(30, "h"), T0 + np.timedelta64(48, "h")]


def test_a_line_split_at_the_antimeridian_reads_back_as_one_corridor(tmp_path):
    doc = {
        "type": "FeatureCollection",
        "features": [
            {
                "type": "Feature",
                "properties": {},
                "geometry": {
                    "type": "MultiLineString",
                    "coordinates": [[[175.0, 35.0], [180.0, 35.5]], [[-180.0, 35.5], [-175.0, 36.0]]],
                },
            }
        ],
    }
    path = tmp_path / "across.geojson"
    path.write_text(json.dumps(doc))
    wp = read_waypoints(path)
    np.testing.assert_array_equal(wp, [[35.0, 175.0], [35.5, -180.0], [36.0, -175.0]])


def test_corridor_files_points_csv_aliases_and_bad_rows(tmp_path):
    points = {
        "type": "FeatureCollection",
        "features": [
            {"type": "Feature", "properties": {"n": k}, "geometry": {"type": "Point", "coordinates": [lon, lat]}}
            for k, (lat, lon) in enumerate(CORRIDOR)
        ],
    }
    (tmp_path / "points.json").write_text(json.dumps(points))
    np.testing.assert_array_equal(read_waypoints(tmp_path / "points.json"), CORRIDOR)
    (tmp_path / "aliases.csv").write_text("name, Latitude, Longitude\na,30,210\nb,31,-145\n")
    np.testing.assert_array_equal(read_waypoints(tmp_path / "aliases.csv"), [[30.0, -150.0], [31.0, -145.0]])
    (tmp_path / "bad.csv").write_text("lat,lon\n30,-150\n31,east\n")
    with pytest.raises(ConfigError, match="row 2 has lat=31"):
        read_waypoints(tmp_path / "bad.csv")
    (tmp_path / "nolat.csv").write_text("x,y\n30,-150\n31,-145\n")
    with pytest.raises(ConfigError, match="needs a latitude column"):
        read_waypoints(tmp_path / "nolat.csv")
    (tmp_path / "swapped.geojson").write_text(
        json.dumps({"type": "LineString", "coordinates": [[30, -150], [31, 145]]})
    )
    with pytest.raises(ConfigError, match="latitude -150 outside"):
        read_waypoints(tmp_path / "swapped.geojson")
    gabon = _write(tmp_path / "gabon.csv", "lat,lon\n-1.0,11.5\n0,0\n")  # inland Gabon, then the sea
    with pytest.raises(OnLandError, match=r"point\(s\) 0 \(-1.0000, 11.5000\)"):
        read_waypoints(gabon)
    synthetic = orx.scenarios.calm(bbox=(-5, 5, -5, 15))
    synthetic.attrs["geography"] = SYNTHETIC_GEOGRAPHY  # its own no-go cells are the land, not the coastline
    assert read_waypoints(gabon, synthetic).shape == (2, 2)


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


# --------------------------------------------------------------------------- bench, warnings, interrupts


def test_bench_runs_the_checkout_benchmarks(capsys, monkeypatch):
    root = cli_tools.find_benchmarks()
    assert root is not None and (root / "benchmarks" / "__main__.py").is_file()
    module = cli_tools._benchmarks_main(root)
    calls = []
    monkeypatch.setattr(module, "main", lambda argv: calls.append(argv) or 0)
    code, _, err = run(capsys, "bench", "--quick", "--only", "nlp, search")
    assert code == 0 and err == ""
    assert calls == [["--quick", "--only", "nlp,search"]]


def test_bench_outside_a_checkout_says_where_the_benchmarks_are(capsys, monkeypatch):
    monkeypatch.setattr(cli_tools, "find_benchmarks", lambda cwd=None: None)
    code, _, err = run(capsys, "bench")
    assert code == 2 and "not installed with optroute" in one_error_line(err)


def test_warnings_are_one_line_and_ctrl_c_exits_130(capsys, monkeypatch):
    def warn_then_succeed(args, out=None):
        warnings.warn("start (32.7, -117.2) is on land;\n moved 3.2 nm", UserWarning, stacklevel=1)
        return 0

    monkeypatch.setattr(cli_tools, "cmd_bench", warn_then_succeed)
    code, _, err = run(capsys, "bench")
    assert code == 0 and err == "optroute: warning: start (32.7, -117.2) is on land; moved 3.2 nm\n"

    def interrupted(args, out=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_tools, "cmd_bench", interrupted)
    code, _, err = run(capsys, "bench")
    assert code == 130 and err.startswith("optroute: interrupted") and err.count("\n") == 1


def _console_script() -> str | None:
    beside = Path(sys.executable).with_name("optroute")  # skip the pyenv shim when there is one
    return str(beside) if beside.is_file() else shutil.which("optroute")


@pytest.mark.skipif(_console_script() is None, reason="the console script is not installed")
def test_console_script(tmp_path):
    # one run (importing optroute takes seconds): the entry point works and a bad input is exit 2, one line
    bad = subprocess.run(
        [
            _console_script(),
            "plan",
            "--ship",
            "container_54k_dwt",
            "--weather",
            "calm",
            "--from",
            "30,-150",
            "--to",
            "32,-140",
            "--ship",
            "titanic",
        ],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert bad.returncode == 2 and bad.stdout == ""
    assert bad.stderr.count("\n") == 1 and "container_8000teu" in bad.stderr


# --------------------------------------------------------------------------- a CLI that answers at once

#: What ``optroute --help`` must not wait for (issue 12): each takes from 0.3 s to seconds to import.
HEAVY = ("numpy", "xarray", "pandas", "casadi", "cvxpy", "matplotlib", "dask", "distributed", "numba", "scipy")


def _python(*args: str) -> subprocess.CompletedProcess:
    # from the checkout's root, so that this tree's optroute is the one imported (python -m puts the cwd first)
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, cwd=ROOT, timeout=300)


def test_help_and_version_in_a_fresh_interpreter():
    version = re.search(r'__version__ = "([^"]+)"', (ROOT / "optroute" / "_version.py").read_text()).group(1)
    got = _python("-m", "optroute", "--version")
    assert got.returncode == 0 and got.stdout == f"optroute {version}\n" and got.stderr == ""
    got = _python("-m", "optroute", "--help")
    assert got.returncode == 0 and got.stderr == ""
    assert got.stdout.startswith("usage: optroute [-h] [--debug] [--version] COMMAND")
    assert all(command in got.stdout for command in COMMANDS)
    got = _python("-m", "optroute", "bands", "--help")
    assert got.returncode == 0 and "--rules {boeing,imo}" in got.stdout and "--period-form {exact,imo}" in got.stdout


def test_the_parser_loads_no_heavy_module():
    # every command's --help builds the whole parser: none of it may import numpy and the rest
    code = (
        "import json, sys, contextlib, io\n"
        "import optroute.cli as cli\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        f"    codes = [cli.main([c, '--help']) for c in {COMMANDS!r}] + [cli.main(['--help']), cli.main(['--version'])]\n"
        f"print(json.dumps([codes, [m for m in {HEAVY!r} if m in sys.modules], cli.__file__]))"
    )
    got = _python("-c", code)
    assert got.returncode == 0, got.stderr
    codes, loaded, where = json.loads(got.stdout)
    assert Path(where).resolve().is_relative_to(ROOT)
    assert codes == [0] * (len(COMMANDS) + 2) and loaded == []


def test_heavy_dependencies_load_only_where_they_are_used():
    # the optimiser builds no convex problem and draws nothing when imported; the tradeoff draws only in plot()
    code = (
        "import json, sys\n"
        "import optroute.optimise.api, optroute.studies.tradeoff, optroute.plan.outputs\n"
        "print(json.dumps([m for m in ('cvxpy', 'matplotlib', 'dask', 'distributed') if m in sys.modules]))"
    )
    got = _python("-c", code)
    assert got.returncode == 0, got.stderr
    assert json.loads(got.stdout) == []


# --------------------------------------------------------------------------- times, ETAs, statuses, fixes


@pytest.mark.parametrize(
    ("t", "text"),
    [
        (np.datetime64("2024-01-18T09:14:00.123456789", "ns"), "2024-01-18T09:14:00Z"),
        (np.datetime64("2024-01-18T09:13:59.5", "ns"), "2024-01-18T09:14:00Z"),  # half a second rounds up
        (np.datetime64("2024-01-18T09:13:59.499999999", "ns"), "2024-01-18T09:13:59Z"),
        (np.datetime64("1969-12-31T23:59:59.6", "ns"), "1970-01-01T00:00:00Z"),  # before the epoch too
        (np.datetime64("2024-02-29", "D"), "2024-02-29T00:00:00Z"),
        ("2024-01-10T06:00", "2024-01-10T06:00:00Z"),
        (np.datetime64("NaT"), "NaT"),
    ],
)
def test_times_print_as_iso_8601_utc_to_the_second(t, text):
    assert units.format_utc(t) == text


@pytest.mark.parametrize(
    ("eta", "needles"),
    [
        ("-5", ["'-5' would be 5 h before the departure 2024-01-10T00:00:00Z", "give +HOURS"]),
        ("-0.5", ["'-0.5' would be 0.5 h before the departure"]),
        ("+-5", ["'+-5' (-5 h) is not after the departure 2024-01-10T00:00:00Z", "give +HOURS"]),
        ("+0", ["'+0' (0 h) is not after the departure"]),
        ("1748", ["'1748' is not a time", "ISO 8601"]),  # numpy would read a year
        ("20240110", ["'20240110' is not a time"]),  # numpy would wrap it round to 1679
        ("3000-01-01", ["outside the years 1678-2262"]),
        ("+1e9", ["falls after 2262"]),
    ],
)
def test_an_eta_before_the_departure_or_out_of_range_is_a_usage_error(capsys, files, eta, needles):
    code, out, err = run(
        capsys, "optimise", "--ship", "container_54k_dwt", "--corridor", files["csv"], "--weather", files["calm"],
        "--eta", eta,
    )  # fmt: skip
    assert code == 2 and out == ""
    line = one_error_line(err)
    assert "1748-" not in line and "1679-" not in line
    for needle in needles:
        assert needle in line, line


def test_relative_eta_lists_and_ranges_refuse_times_before_the_departure():
    with pytest.raises(ConfigError, match=r"'-5:\+10:5': need 0 < FIRST <= LAST"):
        parse_etas("-5:+10:5", T0)
    with pytest.raises(ConfigError, match=r"'\+-5:\+10:5': need 0 < FIRST"):
        parse_etas("+-5:+10:5", T0)
    with pytest.raises(ConfigError, match="'-5' would be 5 h before the departure"):
        parse_etas("+30,-5", T0)
    with pytest.raises(ConfigError, match="'-5' is not a time"):
        parse_time("-5", "--departure")


def test_a_start_or_end_outside_the_weather_is_a_coverage_error_naming_the_area(capsys, files, tmp_path):
    area = "lat 25 to 37 deg N, lon -155 to -135 deg E"  # the fixture's box
    plan = ["plan", "--ship", "container_54k_dwt", "--weather", str(files["calm"]), "--out", str(tmp_path / "p")]
    for ends, where in (
        (["--from", "10,-150", "--to", "32,-140"], "start (10.0000, -150.0000)"),
        (["--from", "30,-150", "--to", "32,-120"], "end (32.0000, -120.0000)"),
    ):
        code, out, err = run(capsys, *plan, *ends)
        line = one_error_line(err)
        assert code == 2 and f"{where} lies outside the weather's area" in line and area in line
        assert "land" not in line and not API_ONLY.search(line)
    outside = _write(tmp_path / "outside.csv", "lat,lon\n30,-150\n31,-145\n32,-120\n")
    code, _, err = run(
        capsys, "optimise", "--ship", "container_54k_dwt", "--corridor", outside, "--weather", files["calm"]
    )
    line = one_error_line(err)
    assert code == 2 and "end, corridor point 2 (32.0000, -120.0000) lies outside the weather's area" in line
    assert area in line


def test_an_end_on_land_names_a_fix_the_user_has(capsys, tmp_path):
    code, _, err = run(
        capsys, "plan", "--ship", "container_54k_dwt", "--weather", "calm", "--from", "30,-150",
        "--to", "38.5,-98", "--out", tmp_path / "p",
    )  # fmt: skip
    line = one_error_line(err)  # Kansas
    assert code == 2 and "end (38.5000, -98.0000) is on land" in line and "give a position at sea" in line
    assert not API_ONLY.search(line)


def test_an_iteration_limited_plan_says_what_feasible_means(capsys, files, tmp_path):
    code, out, err = run(
        capsys, "optimise", "--ship", "container_54k_dwt", "--corridor", files["csv"], "--width-nm", "20",
        "--weather", files["rough"], "--eta", "+40", "--max-iter", "15", "--out", tmp_path / "x",
    )  # fmt: skip
    assert code == 0, err
    # an iteration-limited iterate that verifies is "feasible", explained; a verified start that beats it is
    # "start"; the one-model NLP may also converge within the 15 iterations
    line = re.search(r"^status     (feasible|start|optimal): (.*)$", out, re.M)
    assert line, out
    if line.group(1) == "feasible":
        assert line.group(2) == (
            "Ipopt stopped at its iteration limit at a point that verifies; the plan is safe but not proven least-fuel"
        )
    elif line.group(1) == "start":
        assert "not proven least-fuel" in line.group(2)


def test_every_status_has_an_explanation():
    known = {
        "optimal": "Ipopt converged",
        "optimal; the plan of the earlier ETA 30 h (arrives earlier): fuel rose": "front never rises",
        "mended; solved again from the plan of the earlier ETA 30 h: its first solve ended 2 t": "solved once more",
        "optimal; solved again from the plan of the earlier ETA 30 h: its first solve ended 2 t": "Ipopt converged",
        "feasible": "not proven least-fuel",
        "feasible: fastest verified plan known (optimal); the minimum-time solve failed: x": "upper bound",
        "minimum time": "fastest verified passage",
        "sides_unsettled": "solve budget",
        "start": "best verified start",
        "mended": "speeds of those legs were moved",
        "infeasible: earliest arrival 2024-01-11T07:23:47Z (31.40 h after departure)": "no verified passage",
        "solver failure: Restoration_Failed": "no verified plan",
        "ok": "stored",
        "failed: ValueError('x')": "raised an error",
    }
    for status, needle in known.items():
        assert needle in explain_status(status), status
    assert "least-cost" in explain_status("feasible", objective="cost")
    stops = {"Maximum_Iterations_Exceeded": "iteration limit", "Solved_To_Acceptable_Level": "'acceptable'"}
    for ipopt, needle in stops.items():
        assert needle in explain_status("feasible", ipopt_status=ipopt)
    assert explain_status("something new") == "a status this version of optroute does not explain"
    legend = status_legend(["optimal", "infeasible: earliest arrival x", "optimal", "solver failure: y"])
    assert [x.split(":")[0].strip() for x in legend] == ["optimal", "infeasible", "solver failure"]


def test_every_library_phrase_the_cli_rewords_is_still_in_the_sources():
    sources = "".join(
        p.read_text().replace("{SYNCHRONOUS!r}", "'synchronous'")
        for p in (ROOT / "optroute").rglob("*.py")
        if "cli" not in p.relative_to(ROOT / "optroute").parts
    )
    for library, cli in CLI_FIXES:
        assert library in sources, library
        assert not API_ONLY.search(cli), cli


def test_a_scheduler_error_names_the_study_commands_options(capsys, files, tmp_path):
    pytest.importorskip("distributed")
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    server.settimeout(60.0)

    def greet_with_http() -> None:  # one connection: the probe's
        with contextlib.suppress(OSError):
            conn, _ = server.accept()
            with conn:
                conn.sendall(b"HTTP/1.1 400 Bad Request\r\n\r\n")

    thread = threading.Thread(target=greet_with_http, daemon=True)
    thread.start()
    try:
        code, out, err = run(
            capsys, "study", "--ships", "container_54k_dwt", "--scenarios", files["calm"], "--corridor",
            files["csv"], "--width-nm", "0", "--etas", "+36", "--store", tmp_path / "s", "--scheduler", address,
        )  # fmt: skip
    finally:
        thread.join(timeout=70.0)
        server.close()
    line = one_error_line(err)
    assert code == 2 and out == "" and f"{address!r} answers, but not as a Dask scheduler" in line
    assert "leave out --scheduler for a local cluster (--workers 0 runs in this process)" in line
    assert not API_ONLY.search(line)


def test_band_leg_nm_reaches_the_optimiser_only_when_given(files):
    from optroute.cli import build_parser
    from optroute.cli.voyage import optimise_kwargs

    base = ["optimise", "--ship", "container_54k_dwt", "--corridor", str(files["csv"]), "--weather", "calm"]
    given_ = optimise_kwargs(build_parser().parse_args([*base, "--band-leg-nm", "20"]))
    assert given_["band_leg_nm"] == 20.0 and given_["max_leg_nm"] == 50.0
    assert "band_leg_nm" not in optimise_kwargs(build_parser().parse_args(base))  # optimise_corridor's default
