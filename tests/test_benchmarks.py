"""The benchmarks' harness: every section has a runnable module; ``python -m benchmarks`` writes the report, JSON and figures.

Running the sections themselves is a benchmark, not a test: their quick mode (compare, shao and
seed000 alone took minutes of CPU, the whole suite's budget is five) runs in CI after the suite
(``.ci/run``: ``python -m benchmarks --quick --only compare,shao,seed000``), and each prints its
own figures. What the suite checks here is independent of any section's numbers: every section
has a module with a ``run(quick)`` entry point, and the harness (``benchmarks/__main__.py``), run
on stand-in sections in this process, writes one heading and one JSON file per section, the
figures into the ``--results`` folder, atomically, and reports a failing section without losing
the others.
"""

from __future__ import annotations

import importlib
import inspect
import json
import sys
import types

import numpy as np
import pytest

from benchmarks import __main__ as bench_main
from benchmarks.__main__ import BENCHES, OPTIONAL
from benchmarks._cli import RESULTS_ENV

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: A section's "figure": only its signature is checked, as the harness only moves it into place.
FIGURE = PNG_SIGNATURE + b"a stand-in figure"


@pytest.mark.parametrize("name", [n for n in BENCHES if n not in OPTIONAL])
def test_every_section_has_a_runnable_module(name):
    module = importlib.import_module(f"benchmarks.bench_{name}")
    assert callable(module.run) and list(inspect.signature(module.run).parameters)[:1] == ["quick"]


def _stand_in(name: str, run) -> types.ModuleType:
    module = types.ModuleType(f"benchmarks.bench_{name}")
    module.run = run
    return module


@pytest.fixture
def stand_ins(monkeypatch):
    """Two sections replaced by stand-ins: ``weather`` writes a figure and returns numpy figures, ``search`` fails."""
    calls = []

    def weather(quick):
        from benchmarks._cli import results_dir

        calls.append(("weather", quick))
        (results_dir() / "weather.png").write_bytes(FIGURE)
        print("| case | ratio |\n|---|---:|\n| stand-in | 1.50 |")
        return {"ratio": np.float64(1.5), "sizes": np.arange(3)}

    def search(quick):
        calls.append(("search", quick))
        raise ValueError("a stand-in section that fails")

    monkeypatch.setitem(sys.modules, "benchmarks.bench_weather", _stand_in("weather", weather))
    monkeypatch.setitem(sys.modules, "benchmarks.bench_search", _stand_in("search", search))
    return calls


def test_the_harness_writes_a_report_json_and_figures_per_section(stand_ins, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv(RESULTS_ENV, "")  # main() points it at --results; undone after the test
    code = bench_main.main(["--quick", "--only", "weather", "--results", str(tmp_path)])
    assert code == 0 and stand_ins == [("weather", True)]
    report = (tmp_path / "report.md").read_text()
    assert report.startswith("# optroute benchmarks (quick mode)\n")
    assert "\n## weather\n" in report and "| stand-in | 1.50 |" in report  # the section's own tables
    assert "| weather |" in report and "`weather.json`" in report  # the summary table names its JSON
    payload = json.loads((tmp_path / "weather.json").read_text())
    assert (payload["benchmark"], payload["quick"]) == ("weather", True)
    assert payload["result"] == {"ratio": 1.5, "sizes": [0, 1, 2]}  # numpy figures as JSON numbers and lists
    assert payload["wall_s"] >= 0.0
    assert (tmp_path / "weather.png").read_bytes()[:8] == PNG_SIGNATURE  # figures go to --results
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md", "weather.json", "weather.png"]  # no temporaries
    assert str(tmp_path / "report.md") in capsys.readouterr().out


def test_a_failing_section_is_reported_and_the_others_still_run(stand_ins, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv(RESULTS_ENV, "")  # main() points it at --results; undone after the test
    code = bench_main.main(["--only", "search,weather", "--results", str(tmp_path)])
    assert code == 1 and stand_ins == [("search", False), ("weather", False)]
    err = capsys.readouterr().err
    assert "ValueError: a stand-in section that fails" in err and err.rstrip().endswith("failed: search")
    report = (tmp_path / "report.md").read_text()
    assert report.startswith("# optroute benchmarks (full mode)\n")
    assert "| search |" in report and "**failed**" in report and "`ValueError: a stand-in section that fails`" in report
    assert not (tmp_path / "search.json").exists()
    assert json.loads((tmp_path / "weather.json").read_text())["quick"] is False


def test_an_unknown_section_is_a_usage_error(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv(RESULTS_ENV, "")
    with pytest.raises(SystemExit) as exc:
        bench_main.main(["--only", "weather,nonsense", "--results", str(tmp_path)])
    assert exc.value.code == 2 and "unknown benchmark(s) ['nonsense']" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def _quick_results(folder, shao_nlp_cases: int) -> None:
    """The three JSON files ``check_quick`` reads, with the figures it requires and ``shao_nlp_cases`` NLP comparisons."""
    counts = {"ok": shao_nlp_cases, "unverified": 0, "failed": 0}
    files = {
        "compare": {"cases": [{"rows": [{"method": "NLP", "fuel_t": 10.0, "fuel_ratio": 1.0}]}],
                    "comparison": {"cases": 1, "methods": {"NLP": {"ok": 1, "unverified": 0, "failed": 0}}}},
        "seed000": {"seed_time_ratio_min": 288.0 / 200.0},
        "shao": {"cases": [{"paper": {"window_h": [233.0, 272.0]},
                            "comparison": {"cases": shao_nlp_cases, "methods": {"baseline": counts, "NLP": counts}}}]},
    }  # fmt: skip
    for name, result in files.items():
        (folder / f"{name}.json").write_text(json.dumps({"result": result}))


def test_check_quick_requires_the_shao_quick_run_to_compare_an_nlp_plan(tmp_path):
    """CI's quick Shao et al. run must set at least one NLP plan against its baseline ("0 of 0" fails the check)."""
    from benchmarks import check_quick

    _quick_results(tmp_path, 1)
    check_quick.check(tmp_path)
    _quick_results(tmp_path, 0)
    with pytest.raises(AssertionError, match="no NLP plan"):
        check_quick.check(tmp_path)
