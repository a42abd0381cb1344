"""The package boundary of shared/design.md: formulations never import optroute."""

import subprocess
import sys


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
