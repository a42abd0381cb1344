"""The house style is ruff-clean; this keeps it so."""

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(shutil.which("ruff") is None, reason="ruff is installed by the 'test' extra")
def test_ruff_clean():
    out = subprocess.run(
        ["ruff", "check", "optroute", "formulations", "tests", "benchmarks"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stdout + out.stderr
