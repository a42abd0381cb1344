"""The benchmarks' shared rules (issue 22): failures and unverified plans counted, means over common cases, ABAB order.

Cheap: the table helper and the benchmarks' own summary functions are fed planted outcomes (no quick mode is run).
The means are checked against hand arithmetic on the planted figures; the alternation against a recorded call order.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from benchmarks import bench_compare, bench_shao
from benchmarks._measure import FAILED, OK, STATES, UNVERIFIED, Outcome, alternate, compare, comparison_lines
from optroute.errors import ConfigError

METHODS = ("NLP", "grid", "broken")


def _planted() -> list[dict[str, Outcome]]:
    """Three cases: 'broken' always raises; 'grid' is unverified in the second case."""
    return [
        {
            "NLP": Outcome.scored("NLP", fuel_t=100.0, runtime_s=10.0, violations=0),
            "grid": Outcome.scored("grid", fuel_t=110.0, runtime_s=40.0, violations=0),
            "broken": Outcome.failed("broken", runtime_s=3.0, error=RuntimeError("planted")),
        },
        {
            "NLP": Outcome.scored("NLP", fuel_t=200.0, runtime_s=20.0, violations=0),
            "grid": Outcome.scored("grid", fuel_t=190.0, runtime_s=20.0, violations=4),
            "broken": Outcome.failed("broken", runtime_s=3.0, error="planted"),
        },
        {
            "NLP": Outcome.scored("NLP", fuel_t=300.0, runtime_s=30.0, violations=0),
            "grid": Outcome.scored("grid", fuel_t=330.0, runtime_s=60.0, violations=0),
        },  # 'broken' left no result at all here
    ]


def test_a_planted_failing_method_is_counted_not_dropped():
    summ = compare(_planted(), METHODS, "NLP", "planted")
    broken = summ["methods"]["broken"]
    assert (broken["cases"], broken["ok"], broken["unverified"], broken["failed"]) == (3, 0, 0, 3)
    grid = summ["methods"]["grid"]
    assert (grid["ok"], grid["unverified"], grid["failed"]) == (2, 1, 0)
    # no case where every method gave a clean plan: no mean at all rather than a mean over a subset of methods
    assert summ["common_cases"] == 0 and math.isnan(grid["mean_fuel_t"]) and math.isnan(grid["fuel_ratio_gmean"])
    table = "\n".join(comparison_lines(summ))
    assert "| broken | 0/3 | 0/3 | 3/3 |" in table and "| grid | 2/3 | 1/3 | 0/3 |" in table


def test_means_are_over_the_cases_every_method_solved():
    cases = [{m: o for m, o in c.items() if m != "broken"} for c in _planted()]
    summ = compare(cases, ("NLP", "grid"), "NLP", "planted")
    assert summ["common_cases"] == 2  # the unverified second case is left out of every method's mean
    grid, nlp = summ["methods"]["grid"], summ["methods"]["NLP"]
    assert grid["mean_fuel_t"] == pytest.approx((110.0 + 330.0) / 2)
    assert nlp["mean_fuel_t"] == pytest.approx((100.0 + 300.0) / 2)  # the NLP's mean over the same two cases
    assert grid["mean_runtime_s"] == pytest.approx((40.0 + 60.0) / 2)
    assert grid["fuel_ratio_gmean"] == pytest.approx(1.1)  # 110/100 and 330/300
    assert grid["runtime_ratio_gmean"] == pytest.approx(math.sqrt(4.0 * 2.0))
    assert nlp["fuel_ratio_gmean"] == pytest.approx(1.0)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.lists(st.sampled_from(STATES), min_size=3, max_size=3), min_size=1, max_size=8))
def test_counts_add_up_to_the_cases(states):
    cases = []
    for row in states:
        case = {}
        for m, s in zip(METHODS, row, strict=True):
            if s == FAILED:
                case[m] = Outcome.failed(m, runtime_s=1.0, error="x")
            else:
                case[m] = Outcome.scored(m, fuel_t=5.0, runtime_s=1.0, violations=0 if s == OK else 1)
        cases.append(case)
    summ = compare(cases, METHODS, "NLP", "random")
    for k, m in enumerate(METHODS):
        s = summ["methods"][m]
        assert s["ok"] + s["unverified"] + s["failed"] == len(cases)
        assert s["failed"] == sum(row[k] == FAILED for row in states)
    assert summ["common_cases"] == sum(all(x == OK for x in row) for row in states)


def test_an_outcome_without_fuel_is_not_clean_and_bad_arguments_say_so():
    assert Outcome.scored("x", fuel_t=float("nan"), runtime_s=1.0, violations=0).state == UNVERIFIED
    with pytest.raises(ConfigError, match="baseline 'z'"):
        compare(_planted(), METHODS, "z", "planted")
    with pytest.raises(ConfigError, match="state='done'"):
        Outcome("x", "done", 1.0, 1.0)
    with pytest.raises(ConfigError, match="repeats=0"):
        alternate({"a": lambda: None}, repeats=0)


def test_alternation_warms_up_each_variant_then_runs_abab():
    calls: list[str] = []
    alt = alternate({"A": lambda: calls.append("A") or 1, "B": lambda: calls.append("B") or 2}, repeats=3)
    assert calls == ["A", "B"] + ["A", "B"] * 3  # one untimed warm-up of each exact code path, then A B A B A B
    assert [len(t.times_s) for t in alt.timings.values()] == [3, 3]
    assert alt.results == {"A": 1, "B": 2} and set(alt.warmup_s) == {"A", "B"}
    t = alt.timings["A"]
    assert t.min_s == min(t.times_s) and t.median_s == sorted(t.times_s)[1]


def _compare_row(method: str, state: str, fuel: float) -> dict:
    return {"method": method, "state": state, "fuel_t": fuel, "runtime_s": 2.0,
            "violations": {OK: 0, UNVERIFIED: 3, FAILED: None}[state], "verify": state}  # fmt: skip


def test_bench_compare_json_counts_a_planted_failure():
    # the summary bench_compare writes to compare.json, from planted rows (no run)
    rows = [_compare_row("NLP", OK, 80.0), _compare_row("speed stepping", UNVERIFIED, 85.0),
            _compare_row("DP coarse", FAILED, float("nan"))]  # fmt: skip
    summ = bench_compare.summary([{"scenario": "planted", "eta_h": 50.0, "rows": rows}])
    assert summ["baseline"] == "NLP" and summ["cases"] == 1 and summ["common_cases"] == 0
    for m, (un, fa) in {"NLP": (0, 0), "speed stepping": (1, 0), "DP coarse": (0, 1)}.items():
        assert (summ["methods"][m]["unverified"], summ["methods"][m]["failed"]) == (un, fa)


def test_bench_shao_json_counts_a_planted_nlp_failure():
    rows = [
        {"eta_h": 240.0, "baseline_t": 900.0, "baseline_ref_t": 905.0, "baseline_violations": 0, "dp_t": 880.0, "nlp_t": float("nan"),
         "nlp_state": FAILED, "nlp_violations": None, "nlp_s": 1.0},
        {"eta_h": 256.0, "baseline_t": 850.0, "baseline_ref_t": 851.0, "baseline_violations": 2, "dp_t": 840.0, "nlp_t": 830.0,
         "nlp_state": OK, "nlp_violations": 0, "nlp_s": 1.0},
    ]  # fmt: skip
    summ = bench_shao.comparison(rows)
    assert summ["methods"]["NLP"]["failed"] == 1 and summ["methods"]["baseline"]["unverified"] == 1
    assert summ["cases"] == 2 and summ["common_cases"] == 0
