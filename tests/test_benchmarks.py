"""The benchmarks' quick mode: the sections with published figures run to the end and leave a report, JSON and figures.

Issue 6 (Tests): "the benchmarks' quick mode runs in CI in under 2 minutes". The run is a
subprocess, as a user runs it (``python -m benchmarks --quick``), writing into a temporary folder
(``--results``) so the git-ignored ``benchmarks/results/`` is left alone. What is checked is
independent of the benchmark code: the exit code of the subprocess, the files on disk, the PNG
signature, and that the JSON holds the run's own figures (finite fuel for the optimiser
comparison, the seed's published numbers quoted back).
"""

from __future__ import annotations

import importlib
import inspect
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks.__main__ import BENCHES, OPTIONAL

ROOT = Path(__file__).resolve().parents[1]
#: A ceiling that only guards against a hang; how long the run takes is the benchmarks' own report.
HANG_S = 1800.0
#: The sections the suite runs in quick mode (their figures are checked below); every other section's module is
#: imported and its entry point checked, and the whole quick run is ``python -m benchmarks --quick`` (minutes of CPU,
#: which the suite's budget cannot carry).
RUN = ("compare", "shao", "seed000")
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str]]:
    out = tmp_path_factory.mktemp("bench")
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.run(
        [sys.executable, "-m", "benchmarks", "--quick", "--only", ",".join(RUN), "--results", str(out)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=HANG_S,
    )
    return out, proc


def test_quick_mode_runs_the_sections_to_the_end(quick_run):
    _, proc = quick_run
    assert proc.returncode == 0, proc.stderr[-3000:]


@pytest.mark.parametrize("name", [n for n in BENCHES if n not in OPTIONAL])
def test_every_section_has_a_runnable_module(name):
    module = importlib.import_module(f"benchmarks.bench_{name}")
    assert callable(module.run) and list(inspect.signature(module.run).parameters)[:1] == ["quick"]


def test_quick_mode_writes_the_report_json_and_figures(quick_run):
    out, _ = quick_run
    report = (out / "report.md").read_text()
    for name in RUN:
        assert f"\n## {name}\n" in report  # every section run has its heading
        if name not in OPTIONAL:
            payload = json.loads((out / f"{name}.json").read_text())
            assert payload["benchmark"] == name and payload["quick"] is True
    assert report.count("|---") >= 8  # markdown tables, not only headings
    for png in ("compare.png", "shao_case1.png", "seed000.png"):
        assert (out / png).read_bytes()[:8] == PNG_SIGNATURE
    assert not list(out.glob("*.tmp*"))  # atomic writes leave no temporaries behind


def test_quick_figures_are_the_runs_own(quick_run):
    out, _ = quick_run
    compare = json.loads((out / "compare.json").read_text())["result"]
    nlp = [r for c in compare["cases"] for r in c["rows"] if r["method"] == "NLP"]
    assert nlp and all(math.isfinite(r["fuel_t"]) and r["fuel_t"] > 0 for r in nlp)
    assert all(r["fuel_ratio"] == pytest.approx(1.0) for r in nlp)
    # every comparison carries its counts of clean, unverified and failed plans (issue 22), one per case and method
    comparison = compare["comparison"]
    assert comparison["cases"] == len(compare["cases"])
    for counts in comparison["methods"].values():
        assert counts["ok"] + counts["unverified"] + counts["failed"] == comparison["cases"]
    seed = json.loads((out / "seed000.json").read_text())["result"]
    assert seed["seed_time_ratio_min"] == pytest.approx(288.0 / 200.0)  # EP 2145155: > 12 d against 8 d 8 h
    shao = json.loads((out / "shao.json").read_text())["result"]
    assert shao["cases"][0]["paper"]["window_h"] == [233.0, 272.0]  # seed 001, case I
    for counts in shao["cases"][0]["comparison"]["methods"].values():
        assert {"ok", "unverified", "failed"} <= set(counts)
