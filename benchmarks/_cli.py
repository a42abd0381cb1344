"""The command line every ``python -m benchmarks.bench_<name>`` module shares."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from typing import Any


def bench_main(run: Callable[[bool], Any], description: str, quick_help: str, argv: list[str] | None = None) -> None:
    """Parse ``--quick`` and ``--json``, run the benchmark, print its figures as JSON on request."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--quick", action="store_true", help=quick_help)
    parser.add_argument("--json", action="store_true", help="also print the figures as JSON")
    args = parser.parse_args(argv)
    out = run(args.quick)
    if args.json:
        print(json.dumps(out, indent=1, default=float))
