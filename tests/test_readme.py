"""The README, run as a newcomer would: every Python block and the cheap command lines, in an empty folder.

Each ```python block is written to a file in a fresh temporary folder and run with
``python FILE`` (a new interpreter, so a block that leans on another block's imports
or files fails here as it would for a user; the study block's local Dask cluster
needs its ``__main__`` guard for the same reason).  The ```toml ship file is saved
as ``my_ship.toml`` and read with :meth:`optroute.Ship.from_toml`.  Every
``optroute ...`` line of the ```bash command-line tour is parsed by the real
argument parser, and the cheap ones (:data:`RUN`) are run in order, as
``python -m optroute ...``, in one folder.  The others are parsed only, for the
reasons in :data:`NOT_RUN`.

The subprocesses import this checkout (``PYTHONPATH``) and run one BLAS/OpenMP
thread each, so the test's CPU stays modest on a shared machine.  No timing is
asserted.  The sources are cited by name, never by an internal number: checked
in the README, ``docs/``, the command-line help and the package's text.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

#: Command-line tour subcommands run by the test (seconds each on a short voyage).
RUN = ("bands", "plan")
#: Subcommands of the tour parsed but not run here, and where they are run instead.
NOT_RUN = {
    "optimise": "reads the plan's GeoJSON; tests/test_cli.py feeds a plan's GeoJSON to optimise",
    "demo": "about a minute of CPU at 40 nm cells; tests/test_demo.py runs it on a coarse grid",
    "tradeoff": "the README's first Python block draws a front; tests/test_cli.py runs the command",
    "study": "the README's study block runs a local Dask cluster; tests/test_cli.py runs the command",
    "bench": "the benchmarks; tests/test_benchmarks.py runs their quick mode",
}
#: An internal number for a source document ("seed 000"), which a reader cannot look up.
SEED_NUMBER = re.compile(r"seed\s*0\d\d", re.IGNORECASE)


def fenced_blocks(text: str) -> list[tuple[str, str]]:
    """(language, body) of every fenced code block of a markdown text, in order."""
    return [(m[1], m[2]) for m in re.finditer(r"^```(\w*)\n(.*?)^```\s*$", text, re.MULTILINE | re.DOTALL)]


def cli_lines(body: str) -> list[list[str]]:
    """The ``optroute ...`` commands of a shell block: continuation lines joined, comments dropped."""
    joined = re.sub(r"\\\n", " ", body)
    commands = [shlex.split(line, comments=True) for line in joined.splitlines()]
    return [c for c in commands if c and c[0] == "optroute"]


def _blocks(lang: str) -> list[str]:
    return [body for kind, body in fenced_blocks(README.read_text(encoding="utf-8")) if kind == lang]


def _tour() -> list[list[str]]:
    """The command-line tour: the shell block with more than one ``optroute`` command."""
    tours = [lines for lines in map(cli_lines, _blocks("bash")) if len(lines) > 1]
    assert len(tours) == 1, f"expected one command-line tour in README.md, found {len(tours)}"
    return tours[0]


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)
    env.update(MPLBACKEND="Agg", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    return env


def _run(argv: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    done = subprocess.run(argv, cwd=cwd, env=_env(), capture_output=True, text=True, check=False)
    assert done.returncode == 0, (
        f"{shlex.join(argv)} exited {done.returncode}\n--- stdout\n{done.stdout}\n--- stderr\n{done.stderr}"
    )
    return done


def _files_named(code: str) -> list[str]:
    """Files a block says it writes: savefig/to_csv/to_netcdf/Path(...).write_text, store= folders."""
    calls = r'(?:savefig|to_csv|to_netcdf|Path)\("([^"{}]+)"\)'
    return re.findall(calls, code) + [f"{d}/study.nc" for d in re.findall(r'store="([^"]+)"', code)]


PYTHON_BLOCKS = _blocks("python")


def test_readme_has_the_blocks_it_promises():
    assert len(PYTHON_BLOCKS) >= 3  # fixed corridor, search, study
    assert len(_blocks("toml")) == 1
    assert {c[1] for c in _tour()} == set(RUN) | set(NOT_RUN)


@pytest.mark.parametrize("index", range(len(PYTHON_BLOCKS)), ids=lambda i: f"python-block-{i + 1}")
def test_python_block_runs_in_an_empty_folder(index, tmp_path):
    code = PYTHON_BLOCKS[index]
    script = tmp_path / f"block_{index + 1}.py"
    script.write_text(code, encoding="utf-8")
    done = _run([sys.executable, script.name], tmp_path)
    assert done.stdout.strip(), "a README block should show its result"
    for name in _files_named(code):
        path = tmp_path / name
        assert path.is_file() and path.stat().st_size > 0, f"block {index + 1} did not write {name}"
        if path.suffix == ".png":
            assert path.read_bytes()[:8] == PNG_MAGIC, f"{name} is not a PNG"


def test_figures_are_written_to_files_not_shown():
    """``plot()`` in a script shows nothing: every block that plots saves the figure."""
    for code in PYTHON_BLOCKS:
        plots = len(re.findall(r"\.plot\(\)", code))
        saved = len(re.findall(r"\.plot\(\)\.savefig\(\"[^\"]+\.png\"\)", code))
        assert plots == saved, code


def test_study_block_uses_a_local_cluster_behind_the_main_guard():
    (study,) = [c for c in PYTHON_BLOCKS if "orx.study(" in c]
    guard = study.index('if __name__ == "__main__":')
    assert guard < study.index("orx.study(")
    assert "scheduler_address" not in study and "tcp://" not in study  # no placeholder address to replace
    assert ".to_netcdf(" in study  # it makes its own ensemble members as files
    assert "scheduler_address=" in README.read_text(encoding="utf-8")  # the prose says how to use a cluster


def test_ship_file_reads(tmp_path):
    from optroute import Ship

    (body,) = _blocks("toml")
    path = tmp_path / "my_ship.toml"
    path.write_text(body, encoding="utf-8")
    ship = Ship.from_toml(path)
    assert (ship.name, ship.length_m, ship.mcr_kw) == ("my_ship", 294.1, 36000.0)  # the values in the block


def test_every_tour_line_parses():
    from optroute.cli import build_parser

    for argv in _tour():
        args = build_parser().parse_args(argv[1:])
        assert args.command == argv[1]


def test_cheap_tour_lines_run_in_order(tmp_path):
    (ship_file,) = _blocks("toml")
    (tmp_path / "my_ship.toml").write_text(ship_file, encoding="utf-8")
    ran = []
    for argv in _tour():
        if argv[1] not in RUN:
            continue
        done = _run([sys.executable, "-m", "optroute", *argv[1:]], tmp_path)
        ran.append(argv[1])
        if "--out" in argv:
            out = tmp_path / argv[argv.index("--out") + 1]
            assert sorted(p.name for p in out.iterdir()) == ["plan.csv", "plan.geojson", "plan.nc"], done.stdout
        if "--plot" in argv:
            assert (tmp_path / argv[argv.index("--plot") + 1]).read_bytes()[:8] == PNG_MAGIC
    assert sorted(ran) == sorted(RUN)


#: Being rewritten on other branches (the optimiser; the command line, whose help and the demo's
#: printed text are checked here through the parser and demo.py): their docstrings follow there.
def _text_files() -> list[Path]:
    files = [README, *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "docs").glob("*.py"))]
    files += sorted((ROOT / "optroute").rglob("*.py")) + sorted((ROOT / "formulations").rglob("*.py"))
    return files


def test_sources_are_cited_by_name_not_by_number():
    found = []
    for path in _text_files():
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if SEED_NUMBER.search(line):
                found.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert not found, "cite the patent or paper by name (see docs/design.md):\n" + "\n".join(found)


def test_command_line_help_cites_sources_by_name(capsys):
    from optroute.cli import build_parser

    texts = {}
    for command in ("", *RUN, *NOT_RUN):
        with pytest.raises(SystemExit):
            build_parser().parse_args([command, "--help"] if command else ["--help"])
        texts[command or "optroute"] = capsys.readouterr().out
    assert {c: SEED_NUMBER.findall(t) for c, t in texts.items() if SEED_NUMBER.search(t)} == {}
    assert "EP 2145155" in texts["optroute"]  # the demo is cited by its patent
