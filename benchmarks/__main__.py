"""Run every benchmark in one process and write the results as JSON.

Usage: ``python -m benchmarks [--quick] [--only weather,search,nlp]``.

Each benchmark prints a markdown table with ratios to a named baseline run
side by side in the same process (scipy's compiled Dijkstra, xarray's interp,
CasADi's automatic derivatives); the collected figures go to
``benchmarks/results/<name>.json`` (git-ignored).
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import tempfile
import time
from pathlib import Path

BENCHES = ("weather", "search", "nlp")
RESULTS = Path(__file__).resolve().parent / "results"


def _jsonable(obj):
    try:
        json.dumps(obj)
        return obj
    except TypeError:
        if isinstance(obj, dict):
            return {str(k): _jsonable(v) for k, v in obj.items()}
        if isinstance(obj, list | tuple):
            return [_jsonable(v) for v in obj]
        if hasattr(obj, "tolist"):
            return obj.tolist()
        return str(obj)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, for CI (minutes, not tens of minutes)")
    parser.add_argument("--only", default=",".join(BENCHES), help=f"comma-separated subset of {','.join(BENCHES)}")
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.only.split(",") if n.strip()]
    unknown = sorted(set(names) - set(BENCHES))
    if unknown:
        parser.error(f"unknown benchmark(s) {unknown}; choose from {list(BENCHES)}")
    RESULTS.mkdir(exist_ok=True)
    for name in names:
        module = importlib.import_module(f"benchmarks.bench_{name}")
        print(f"\n## {name}\n", flush=True)
        t0 = time.perf_counter()
        result = module.run(args.quick)
        payload = {"benchmark": name, "quick": args.quick, "wall_s": time.perf_counter() - t0, "result": _jsonable(result)}
        fd, tmp = tempfile.mkstemp(dir=RESULTS, suffix=".tmp")
        with os.fdopen(fd, "w") as fh:
            json.dump(payload, fh, indent=2)
        os.replace(tmp, RESULTS / f"{name}.json")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
