"""Suite-wide settings.

Under CI (the ``CI`` environment variable set, as ``.ci/run`` runs), hypothesis draws the same
examples on every run (``derandomize``), so a run on main is reproducible; a developer's run
keeps exploring new examples.
"""

import os
import subprocess
import sys
from pathlib import Path

from hypothesis import settings

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")


# ---------------------------------------------------------------------------
# CPU time per test: ``python -m pytest --cpu-durations=N`` lists the N tests that cost the most CPU
# (the process that ran the test and its waited-for children, setup + call + teardown, so fixtures and
# subprocesses count). Wall time on a shared machine says little about cost; CPU time is what the budget
# counts. Under pytest-xdist each worker measures its own tests and sends the figure to the controller on
# the test's reports (``user_properties``), so ``-n 2 --cpu-durations=N`` ranks the whole run.
# A module-scoped fixture is charged to the first test that builds it.
# ---------------------------------------------------------------------------
import resource  # noqa: E402

import pytest  # noqa: E402

_CPU_S: dict[str, float] = {}
_CPU_KEY = "cpu_s"


def _cpu_now_s() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def pytest_addoption(parser):
    parser.addoption(
        "--cpu-durations",
        type=int,
        default=None,
        metavar="N",
        help="list the N tests with the most CPU time (process + children, fixtures included); 0 for all",
    )


def _timed_phase(item):
    if item.config.getoption("--cpu-durations") is None:
        yield
        return
    start_s = _cpu_now_s()
    yield
    item._cpu_phase_s = _cpu_now_s() - start_s


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_setup(item):
    yield from _timed_phase(item)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_call(item):
    yield from _timed_phase(item)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_teardown(item):
    yield from _timed_phase(item)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    cpu_s = getattr(item, "_cpu_phase_s", None)
    if cpu_s is not None:
        outcome.get_result().user_properties.append((_CPU_KEY, cpu_s))
        item._cpu_phase_s = None


def pytest_runtest_logreport(report):
    for key, value in report.user_properties:
        if key == _CPU_KEY:
            _CPU_S[report.nodeid] = _CPU_S.get(report.nodeid, 0.0) + value


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    n = config.getoption("--cpu-durations")
    if n is None or not _CPU_S:
        return
    ranked = sorted(_CPU_S.items(), key=lambda kv: kv[1], reverse=True)
    shown = ranked if n == 0 else ranked[:n]
    per_file: dict[str, float] = {}
    for nodeid, cpu_s in ranked:
        per_file[nodeid.split("::")[0]] = per_file.get(nodeid.split("::")[0], 0.0) + cpu_s
    terminalreporter.write_sep("=", f"CPU time per test (total {sum(_CPU_S.values()):.1f} CPU-s)")
    for nodeid, cpu_s in shown:
        terminalreporter.write_line(f"{cpu_s:8.2f} CPU-s  {nodeid}")
    terminalreporter.write_sep("=", "CPU time per file")
    for path, cpu_s in sorted(per_file.items(), key=lambda kv: kv[1], reverse=True):
        terminalreporter.write_line(f"{cpu_s:8.2f} CPU-s  {path}")


# ---------------------------------------------------------------------------
# numba's kernels compiled once for all xdist workers: on a clean clone there is no on-disk cache, and each
# worker would compile every kernel it meets (tens of CPU-seconds each) until another process has cached it.
# The controller compiles them first (tests/warm_kernels.py, in a subprocess, before the workers start).
# Serial runs skip this: a run of one test file would compile kernels it never uses.
# ---------------------------------------------------------------------------
def pytest_configure(config):
    workers = getattr(config.option, "numprocesses", None)
    if hasattr(config, "workerinput") or not workers or workers in ("0", 0):
        return
    root = Path(__file__).resolve().parents[1]
    done = subprocess.run(
        [sys.executable, "-m", "tests.warm_kernels"], cwd=root, capture_output=True, text=True, timeout=900, check=False
    )
    if done.returncode != 0:  # the tests compile what they need themselves; say why the warm-up did not help
        tail = "\n".join(done.stderr.strip().splitlines()[-5:])
        config.issue_config_time_warning(
            pytest.PytestWarning(f"numba warm-up failed (tests/warm_kernels.py):\n{tail}"), 2
        )


# ---------------------------------------------------------------------------
# Weather built once per test process and shared by the files that need the same one (read only: the tests
# sample it, none changes it). Under ``--dist loadfile`` two files on one worker share it; the North Pacific
# storms (about 6 CPU-s to build, 64 MB) are built once per run: the first xdist worker that needs them builds
# and pickles them into the run's temporary folder, the other loads that pickle (an exact copy: values, coordinates,
# attributes and encodings) instead of building them a second time.
# ---------------------------------------------------------------------------
def _built_once_per_run(tmp_path_factory, name: str, build):
    """``build()``, or under pytest-xdist the value another worker of this run built, loaded from its pickle."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - no flock (Windows): each worker builds its own
        return build()
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return build()
    import pickle

    root = tmp_path_factory.getbasetemp().parent  # this run's folder, shared by its workers
    path = root / f"{name}.pickle"
    with open(root / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # the other worker waits (no CPU) while the first builds
        if path.exists():
            return pickle.loads(path.read_bytes())
        value = build()
        part = root / f"{name}.pickle.part"
        part.write_bytes(pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL))
        part.replace(path)
        return value


@pytest.fixture(scope="session")
def north_pacific_storms(tmp_path_factory):
    """Boeing EP 2145155's San Diego -> Tokyo storms, ``scenarios.north_pacific_storms()`` at its defaults."""
    from optroute.weather import scenarios

    return _built_once_per_run(tmp_path_factory, "north_pacific_storms", scenarios.north_pacific_storms)


@pytest.fixture(scope="session")
def shao_case_1():
    """Shao et al.'s case I sea (158 MB), ``scenarios.shao_case(1)`` at its defaults (read only)."""
    from optroute.weather import scenarios

    return scenarios.shao_case(1)


@pytest.fixture(scope="session")
def shao_case_2():
    """Shao et al.'s case II sea (158 MB), ``scenarios.shao_case(2)`` at its defaults (read only)."""
    from optroute.weather import scenarios

    return scenarios.shao_case(2)
