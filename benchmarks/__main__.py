"""Run every benchmark in one process; write one markdown report, a JSON file per benchmark and the figures.

Usage: ``python -m benchmarks [--quick] [--only startup,weather,search,nlp,compare,shao,seed000,front,certificate,observer,voyage,cyclone,sailing,harness,bands] [--results DIR]``.

Each benchmark prints markdown tables with ratios to a named baseline run side by side in the
same process (``import xarray`` for the start-up, scipy's compiled Dijkstra, xarray's interp,
CasADi's automatic derivatives, Boeing speed stepping and the 3-D DP, the seeds' published figures). Everything printed is collected in
``<results>/report.md``; each benchmark's figures go to ``<results>/<name>.json`` and its PNG
figures beside them. ``<results>`` is the git-ignored ``benchmarks/results/`` unless ``--results``
names another folder. A benchmark that raises is reported as failed (the traceback on stderr), the
others still run, and the exit status is 1.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import json
import platform
import sys
import time
import traceback
from typing import Any, TextIO

from benchmarks._cli import DEFAULT_RESULTS, jsonable, set_results_dir
from optroute._store import atomic_write_bytes

BENCHES = (
    "startup",
    "weather",
    "search",
    "nlp",
    "compare",
    "shao",
    "seed000",
    "front",
    "certificate",
    "observer",
    "voyage",
    "cyclone",
    "sailing",
    "harness",
    "bands",
)
OPTIONAL = {"front": "benchmarks.bench_front"}
"""Benchmarks whose module may not exist yet: skipped with a message instead of failing the run."""


class _Tee(io.TextIOBase):
    """Write to the terminal and keep a copy (the report)."""

    def __init__(self, out: TextIO) -> None:
        self.out, self.copy = out, io.StringIO()

    def write(self, s: str) -> int:
        self.out.write(s)
        self.copy.write(s)
        return len(s)

    def flush(self) -> None:
        self.out.flush()


def _load(name: str) -> Any | None:
    """The benchmark's module, or None (with a message) when an optional one is not there yet."""
    module = OPTIONAL.get(name, f"benchmarks.bench_{name}")
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if name in OPTIONAL and exc.name == module:
            print(f"_skipped: `{module}` is not there yet._\n")
            return None
        raise


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, for CI (about a minute, not an hour)")
    parser.add_argument("--only", default=",".join(BENCHES), help=f"comma-separated subset of {','.join(BENCHES)}")
    parser.add_argument(
        "--results", default=None, help=f"folder for the report, JSON and PNG (default {DEFAULT_RESULTS})"
    )
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.only.split(",") if n.strip()]
    unknown = sorted(set(names) - set(BENCHES))
    if unknown:
        parser.error(f"unknown benchmark(s) {unknown}; choose from {list(BENCHES)}")
    results = set_results_dir(args.results)
    started = time.perf_counter()
    sections: list[str] = []
    walls: dict[str, float | None] = {}
    status: dict[str, str] = {}
    for name in names:
        tee = _Tee(sys.stdout)
        with contextlib.redirect_stdout(tee):
            print(f"\n## {name}\n", flush=True)
            module = _load(name)
            walls[name], status[name] = None, "skipped"
            if module is not None:
                t0 = time.perf_counter()
                try:
                    result = module.run(args.quick)
                except Exception as exc:  # one broken benchmark must not lose the others' figures
                    walls[name], status[name] = time.perf_counter() - t0, "**failed**"
                    traceback.print_exc()
                    print(f"\n**failed** after {walls[name]:.1f} s: `{type(exc).__name__}: {str(exc)[:500]}`\n")
                else:
                    walls[name], status[name] = time.perf_counter() - t0, f"`{name}.json`"
                    payload = {"benchmark": name, "quick": args.quick, "wall_s": walls[name],
                               "result": jsonable(result)}  # fmt: skip
                    atomic_write_bytes(results / f"{name}.json", json.dumps(payload, indent=2).encode())
        sections.append(tee.copy.getvalue())
    head = [
        f"# optroute benchmarks ({'quick' if args.quick else 'full'} mode)\n",
        f"Python {platform.python_version()} on {platform.machine()}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; "
        f"total wall time {time.perf_counter() - started:.0f} s. Absolute times are noisy on a shared machine; "
        "the tables' ratios are measured side by side in one process.\n",
        "| benchmark | wall time [s] | result |",
        "|---|---:|---|",
        *(f"| {n} | {'–' if w is None else f'{w:.1f}'} | {status[n]} |" for n, w in walls.items()),
    ]  # fmt: skip
    report = "\n".join(head) + "\n" + "".join(sections)
    atomic_write_bytes(results / "report.md", report.encode())
    print(f"\nreport: {results / 'report.md'}")
    failed = [n for n, st in status.items() if st == "**failed**"]
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
