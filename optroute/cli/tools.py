"""``optroute demo`` (the worked example of Boeing EP 2145155) and ``optroute bench`` (the benchmarks of a source checkout).

``bench`` runs the ``benchmarks`` package of optroute's *source repository*: it is not
installed with the package (it measures the code, it is no part of it), so the command
looks for it in the current folder and then next to the installed ``optroute`` package (an
editable install), and otherwise says how to get it.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path
from typing import Any, TextIO

from optroute.cli._parser import add_command
from optroute.errors import ConfigError

# --------------------------------------------------------------------------- demo


def add_demo(sub: argparse._SubParsersAction, common: argparse.ArgumentParser) -> None:
    p = add_command(
        sub,
        common,
        "demo",
        help="San Diego -> Tokyo through two winter storms (the worked example of Boeing EP 2145155)",
        description=(
            "Search the route of a 25 kn 8000 TEU container ship from San Diego to Tokyo through the built-in "
            "north_pacific_storms() forecast and compare it with the great circle sailed with forced slow-downs; "
            "print the comparison and write the figures to --out. Needs no data and no network."
        ),
        examples="""
  optroute demo
  optroute demo --out demo_out
  optroute demo --out demo_quick --cell-nm 120 --max-leg-nm 200   (a coarser, faster run)
""",
    )
    p.add_argument("--out", default="optroute_demo", metavar="DIR", help="folder for the figures")
    p.add_argument("--cell-nm", type=float, default=40.0, metavar="NM", help="search grid cell [nm]")
    p.add_argument(
        "--max-leg-nm",
        type=float,
        default=None,
        metavar="NM",
        help="longest optimiser leg [nm] (default: the demo's own)",
    )
    p.set_defaults(func=cmd_demo)


def cmd_demo(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """``optroute demo``: run the demo voyage, print the comparison table, write the figures."""
    from optroute.cli.demo import run_demo

    out = out or sys.stdout
    print("San Diego -> Tokyo, container_8000teu at 25 kn, built-in north_pacific_storms() forecast", file=out)
    print("ship model: calm-water power + danger bands + top speed (EP 2145155's assumptions)\n", file=out)
    kw = {} if args.max_leg_nm is None else {"max_leg_nm": args.max_leg_nm}
    result = run_demo(args.out, cell_nm=args.cell_nm, **kw)
    print(result.table(), file=out)
    print(f"\nfiles: {', '.join(str(f) for f in result.files)}  ({result.runtime_s:.0f} s)", file=out)
    return 0


# --------------------------------------------------------------------------- bench


def _is_checkout(root: Path) -> bool:
    return (root / "benchmarks" / "__main__.py").is_file() and (root / "optroute").is_dir()


def find_benchmarks(cwd: Path | None = None) -> Path | None:
    """The source checkout holding ``benchmarks/``: the current folder, else the one above the installed package."""
    import optroute

    candidates = [Path.cwd() if cwd is None else cwd, Path(optroute.__file__).resolve().parents[1]]
    return next((c for c in candidates if _is_checkout(c)), None)


def _benchmarks_main(root: Path) -> Any:
    """``benchmarks.__main__`` of the checkout at ``root``."""
    if str(root) not in sys.path:
        sys.path.insert(0, str(root))
    module = importlib.import_module("benchmarks.__main__")
    origin = Path(module.__file__).resolve().parents[1]
    if origin != root.resolve():
        raise ConfigError(
            f"a different 'benchmarks' package ({module.__file__}) is already imported; run 'python -m benchmarks' "
            f"in {str(root)!r} instead"
        )
    return module


def add_bench(sub: argparse._SubParsersAction, common: argparse.ArgumentParser) -> None:
    p = add_command(
        sub,
        common,
        "bench",
        help="run the benchmarks of a source checkout (python -m benchmarks)",
        description=(
            "Run optroute's benchmarks, which print markdown tables of ratios measured side by side in one run and "
            "write JSON under benchmarks/results/. They live in the source repository, not in the installed "
            "package: run this from a checkout (or with an editable install)."
        ),
        examples="""
  optroute bench --quick
  optroute bench --only nlp,search
""",
    )
    p.add_argument("--quick", action="store_true", help="small sizes (minutes, for CI)")
    p.add_argument(
        "--only", default=None, metavar="A,B", help="comma-separated subset of the benchmarks (default: all)"
    )
    p.set_defaults(func=cmd_bench)


def cmd_bench(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """``optroute bench``: run ``benchmarks.__main__.main`` of the source checkout."""
    root = find_benchmarks()
    if root is None:
        raise ConfigError(
            f"the benchmarks are not installed with optroute; they live in its source repository: run "
            f"'optroute bench' (or 'python -m benchmarks') in a checkout that holds benchmarks/ "
            f"(current folder: {str(Path.cwd())!r})"
        )
    module = _benchmarks_main(root)
    known = tuple(getattr(module, "BENCHES", ()))
    argv: list[str] = ["--quick"] if args.quick else []
    if args.only is not None:
        names = [n.strip() for n in args.only.split(",") if n.strip()]
        unknown = [n for n in names if known and n not in known]
        if not names or unknown:
            raise ConfigError(
                f"--only {args.only!r}: unknown benchmark(s) {unknown or names}; choose from {', '.join(known)}"
            )
        argv += ["--only", ",".join(names)]
    code = module.main(argv)
    return int(code or 0)
