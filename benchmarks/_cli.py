"""What every ``python -m benchmarks.bench_<name>`` module shares: the command line and the results folder."""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

DEFAULT_RESULTS = Path(__file__).resolve().parent / "results"
RESULTS_ENV = "OPTROUTE_BENCH_RESULTS"
"""Environment variable naming the results folder (``--results DIR`` sets it for the whole run)."""


def jsonable(obj: Any) -> Any:
    """``obj`` with numpy arrays and scalars as lists and floats, other unknown objects as text (for ``json.dumps``)."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if hasattr(obj, "tolist"):  # numpy arrays and scalars, datetime64 included
        return jsonable(obj.tolist())
    if obj is None or isinstance(obj, bool | int | float | str):
        return obj
    return str(obj)


def results_dir() -> Path:
    """The folder the benchmarks write JSON, PNG and the report into (created on demand).

    ``$OPTROUTE_BENCH_RESULTS`` when set (``python -m benchmarks --results DIR`` sets it), else the
    git-ignored ``benchmarks/results/``.
    """
    folder = Path(os.environ.get(RESULTS_ENV) or DEFAULT_RESULTS)
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def set_results_dir(path: str | os.PathLike[str] | None) -> Path:
    """Point :func:`results_dir` at ``path`` (for this process and its children) and return it."""
    if path is not None:
        os.environ[RESULTS_ENV] = str(Path(path).resolve())
    return results_dir()


def bench_main(run: Callable[[bool], Any], description: str, quick_help: str, argv: list[str] | None = None) -> None:
    """Parse ``--quick``, ``--json`` and ``--results``, run the benchmark, print its figures as JSON on request."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--quick", action="store_true", help=quick_help)
    parser.add_argument("--json", action="store_true", help="also print the figures as JSON")
    parser.add_argument("--results", default=None, help=f"folder for figures and JSON (default {DEFAULT_RESULTS})")
    args = parser.parse_args(argv)
    set_results_dir(args.results)
    out = run(args.quick)
    if args.json:
        print(json.dumps(jsonable(out), indent=1))
