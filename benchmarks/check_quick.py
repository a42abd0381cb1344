"""Check the figures of a quick benchmark run: ``python -m benchmarks.check_quick RESULTS_DIR``.

CI runs ``python -m benchmarks --quick --only compare,shao,seed000`` after the suite and then this
check, which asserts what the published figures must carry (issue 22): every comparison's counts of
clean, unverified and failed plans adding up to its cases, the NLP's own fuel finite and its ratio
to itself 1, and the quotes of the sources (Boeing EP 2145155: more than 12 days against 8 d 8 h;
Shao et al.: the window of arrival times 233–272 h of case I, and at least one NLP plan set against its
baseline). Exit 1 naming the first failed check.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path


def _result(folder: Path, name: str) -> dict:
    return json.loads((folder / f"{name}.json").read_text())["result"]


def _counts_add_up(comparison: dict, where: str) -> None:
    cases = comparison["cases"]
    for method, counts in comparison["methods"].items():
        total = counts["ok"] + counts["unverified"] + counts["failed"]
        if total != cases:
            raise AssertionError(f"{where}: {method} counts {counts} do not add up to {cases} cases")


def check(folder: Path) -> None:
    """Raise AssertionError naming the first figure that is missing or wrong."""
    compare = _result(folder, "compare")
    nlp = [r for c in compare["cases"] for r in c["rows"] if r["method"] == "NLP"]
    if not nlp or not all(math.isfinite(r["fuel_t"]) and r["fuel_t"] > 0 for r in nlp):
        raise AssertionError(f"compare: the NLP's fuel is missing or not a positive number: {nlp}")
    if not all(abs(r["fuel_ratio"] - 1.0) < 1e-9 for r in nlp):
        raise AssertionError("compare: the NLP's fuel ratio to itself is not 1")
    if compare["comparison"]["cases"] != len(compare["cases"]):
        raise AssertionError("compare: the comparison counts another number of cases than were run")
    _counts_add_up(compare["comparison"], "compare")
    seed = _result(folder, "seed000")
    if abs(seed["seed_time_ratio_min"] - 288.0 / 200.0) > 1e-9:
        raise AssertionError(f"seed000: the EP 2145155 time ratio is {seed['seed_time_ratio_min']}, not 288/200")
    shao = _result(folder, "shao")
    if shao["cases"][0]["paper"]["window_h"] != [233.0, 272.0]:
        raise AssertionError(f"shao: the paper's window of case I is {shao['cases'][0]['paper']['window_h']}")
    for case in shao["cases"]:
        _counts_add_up(case["comparison"], "shao")
    if shao["cases"][0]["comparison"]["cases"] < 1:
        raise AssertionError(
            "shao: the quick run compared no NLP plan with the baseline (NLP against the baseline 0 of 0)"
        )


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python -m benchmarks.check_quick RESULTS_DIR")
    try:
        check(Path(sys.argv[1]))
    except (AssertionError, KeyError, FileNotFoundError) as exc:
        sys.exit(f"benchmark check failed: {type(exc).__name__}: {exc}")
    print(f"benchmark figures checked in {sys.argv[1]}")
