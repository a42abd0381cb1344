"""The package's layering (pyproject's ``[tool.importlinter]``, drawn in docs/design.md) holds.

The contracts are import-linter's: the pipeline's layers (physics → weather → geo → search →
plot → plan → optimise → studies → cli, over errors/units/geodesy), ``formulations`` never
importing ``optroute``, no import circles between sibling modules, private modules used only inside
their package. The second test checks the same boundary the way a user meets it: importing every
formulation module loads no optroute module.
"""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(shutil.which("lint-imports") is None, reason="import-linter is installed by the 'test' extra")
def test_import_linter_contracts_are_kept():
    out = subprocess.run(["lint-imports", "--no-cache"], cwd=ROOT, capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-2000:]
    assert "0 broken" in out.stdout


def test_importing_formulations_pulls_in_no_optroute_module():
    code = (
        "import sys, pkgutil, importlib, formulations\n"
        "for m in pkgutil.walk_packages(formulations.__path__, 'formulations.'):\n"
        "    importlib.import_module(m.name)\n"
        "bad = sorted(n for n in sys.modules if n == 'optroute' or n.startswith('optroute.'))\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"formulations imported optroute modules: {out.stdout.strip()}"
