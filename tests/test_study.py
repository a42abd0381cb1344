"""Studies: Cartesian product of axes on Dask, incremental atomic storage, resume, failures.

The case functions are small deterministic numpy computations with a closed
form: the fuel of a passage of ``d`` nautical miles in ``eta`` hours at
constant speed with a cubic propulsion law, ``fuel = k d³ / eta²``
(rate ``k v³`` [t/h] times time ``d / v``) — the independent reference every
study result is checked against.  They live at module level so that Dask
workers can import them.  Every address used is on 127.0.0.1.
"""

from __future__ import annotations

import functools
import io
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
import warnings
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from optroute import _store
from optroute.errors import ConfigError, InfeasibleETA, OptrouteError
from optroute.studies.cluster import SCHEDULER_HTTP_ADDRESS, dask_client
from optroute.studies.study import SchedulerUnreachable, StudyError, load_study, run_study

ROOT = Path(__file__).resolve().parents[1]

SHIP_K = {"feeder": 1.0e-6, "panamax": 2.0e-6, "vlcc": 3.5e-6}  # t / (nm³ h⁻²)
DISTANCE_NM = [1000.0, 2500.0]
ETA_H = [100.0, 150.0, 200.0, 250.0]
MAX_SPEED_KN = 20.0
N_LEGS = 4
AXES = {"ship": list(SHIP_K), "distance_nm": DISTANCE_NM, "eta_h": ETA_H}
N_CASES = len(SHIP_K) * len(DISTANCE_NM) * len(ETA_H)


# --------------------------------------------------------------------------- case functions (module level)


def _key(case: dict) -> str:
    return f"{case['ship']}|{case['distance_nm']:g}|{case['eta_h']:g}"


def _log(log: str | None, line: str) -> None:
    if log is not None:  # O_APPEND: one short write per line, safe across processes
        fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_APPEND)
        try:
            os.write(fd, (line + "\n").encode())
        finally:
            os.close(fd)


def fuel_case(case: dict, log: str | None = None, delay_s: float = 0.0) -> dict:
    """Fuel of a constant-speed passage; logs the case key (and where it ran) when ``log`` is given."""
    k = SHIP_K[case["ship"]]
    d, eta = case["distance_nm"], case["eta_h"]
    if d / eta > MAX_SPEED_KN:
        raise InfeasibleETA(f"eta_h={eta:g} needs {d / eta:g} kn over {d:g} nm, above the {MAX_SPEED_KN:g} kn limit")
    if delay_s:
        time.sleep(delay_s)
    try:
        from distributed import get_worker

        where = get_worker().address
    except (ImportError, ValueError):
        where = "local"
    _log(log, f"{_key(case)} {where} {os.getpid()}")
    fuel = k * d**3 / eta**2
    return {
        "fuel_t": fuel,
        "speed_kn": d / eta,
        "cumulative_fuel_t": fuel * np.arange(1, N_LEGS + 1) / N_LEGS,  # equal legs
    }


def kill_worker_once_case(case: dict, log: str, marker: str, victim: str) -> dict:
    """Like :func:`fuel_case`, but the first attempt at case ``victim`` kills its worker process."""
    if _key(case) == victim:
        try:
            fd = os.open(marker, os.O_WRONLY | os.O_CREAT | os.O_EXCL)
        except FileExistsError:
            pass
        else:
            os.close(fd)
            _log(log, f"{_key(case)} killed {os.getpid()}")
            os._exit(1)
    return fuel_case(case, log)


def reserved_name_case(case: dict) -> dict:
    return {"status": 1.0}


def ragged_case(case: dict) -> xr.Dataset:
    """A front whose number of points and ETAs depend on the case (like a trade-off curve)."""
    n = int(case["n"])
    etas = case["start_h"] + 10.0 * np.arange(n)
    return xr.Dataset(
        {"fuel_t": ("point", 100.0 / etas), "feasible": ("point", np.ones(n, dtype=bool))},
        coords={"point": np.arange(n), "eta_h": ("point", etas)},
    )


def ragged_index_case(case: dict) -> xr.Dataset:
    etas = case["start_h"] + 10.0 * np.arange(3)
    return xr.Dataset({"fuel_t": ("eta_front", 100.0 / etas)}, coords={"eta_front": etas})


def time_case(case: dict) -> dict:
    hours = (case["eta"] - np.datetime64("2024-01-01T00:00")) / np.timedelta64(1, "h")
    return {"hours": hours, "ship_length_m": case["ship"].length_m}


class _NamedShip:
    def __init__(self, name: str, length_m: float) -> None:
        self.name = name
        self.length_m = length_m


def analytic_fuel() -> np.ndarray:
    """``k d³ / eta²`` on the (ship, distance, eta) grid, NaN where the ETA needs more than the speed limit."""
    k = np.array(list(SHIP_K.values()))[:, None, None]
    d = np.array(DISTANCE_NM)[None, :, None]
    eta = np.array(ETA_H)[None, None, :]
    fuel = k * d**3 / eta**2
    return np.where(d / eta > MAX_SPEED_KN, np.nan, fuel)


def log_counts(log: Path) -> Counter:
    lines = log.read_text().splitlines() if log.exists() else []
    return Counter(line.split(" ")[0] for line in lines if " killed " not in line)


def case_files(store: Path) -> list[str]:
    return sorted(p.name for p in (store / "cases").iterdir() if not p.name.startswith("."))


def all_keys() -> list[str]:
    return [f"{s}|{d:g}|{e:g}" for s in SHIP_K for d in DISTANCE_NM for e in ETA_H]


def stored_keys(store: Path) -> set[str]:
    keys = set()
    names = list(SHIP_K)
    for name in case_files(store):
        i, j, k = _store.parse_case_name(name)
        keys.add(f"{names[i]}|{DISTANCE_NM[j]:g}|{ETA_H[k]:g}")
    return keys


# --------------------------------------------------------------------------- serial reference


def test_serial_study_matches_closed_form(tmp_path):
    calls = []
    ds = run_study(
        AXES, fuel_case, tmp_path / "s", scheduler_address="synchronous", progress=lambda *a: calls.append(a)
    )
    assert ds.fuel_t.dims == ("ship", "distance_nm", "eta_h")
    assert list(ds.ship.values) == list(SHIP_K)
    np.testing.assert_allclose(ds.fuel_t.values, analytic_fuel(), rtol=1e-15)
    # one value by hand: 2e-6 * 2500³ / 250² = 2e-6 * 1.5625e10 / 62500 = 0.5 t
    assert ds.fuel_t.sel(ship="panamax", distance_nm=2500.0, eta_h=250.0).item() == pytest.approx(0.5, rel=1e-15)
    assert ds.cumulative_fuel_t.dims == ("ship", "distance_nm", "eta_h", "cumulative_fuel_t_dim_0")
    np.testing.assert_allclose(ds.cumulative_fuel_t.isel(cumulative_fuel_t_dim_0=-1), ds.fuel_t)
    # 2500 nm in 100 h needs 25 kn > 20 kn: recorded as failed, never dropped
    bad = ds.status.sel(distance_nm=2500.0, eta_h=100.0)
    assert all(str(s).startswith("failed: InfeasibleETA: eta_h=100 needs 25 kn") for s in bad.values)
    assert int((ds.status == "ok").sum()) == N_CASES - len(SHIP_K)
    assert calls == [(i, N_CASES) for i in range(N_CASES + 1)]
    assert len(case_files(tmp_path / "s")) == N_CASES
    manifest = json.loads((tmp_path / "s" / "manifest.json").read_text())
    assert manifest["shape"] == [3, 2, 4] and manifest["case_fn"].endswith("fuel_case")
    on_disk = xr.load_dataset(tmp_path / "s" / "study.nc")
    xr.testing.assert_identical(on_disk, ds)
    xr.testing.assert_identical(load_study(tmp_path / "s"), ds)


def test_a_resumed_study_reads_each_stored_case_once_and_combines_the_same_dataset(tmp_path, monkeypatch):
    # the check of the stored cases' inputs loads each case; the combination takes those, not the files again
    first = run_study(AXES, fuel_case, tmp_path / "s", scheduler_address="synchronous")
    reads: list[str] = []
    real = _store.read_case
    monkeypatch.setattr(_store, "read_case", lambda path: reads.append(Path(path).name) or real(path))
    again = run_study(AXES, fuel_case, tmp_path / "s", scheduler_address="synchronous")
    assert sorted(Counter(reads).values()) == [1] * N_CASES
    xr.testing.assert_identical(again, first)
    np.testing.assert_allclose(again.fuel_t.values, analytic_fuel(), rtol=1e-15)


def test_n_workers_zero_is_synchronous(tmp_path):
    ds = run_study(AXES, fuel_case, tmp_path / "s", n_workers=0)
    np.testing.assert_allclose(ds.fuel_t.values, analytic_fuel(), rtol=1e-15)


# --------------------------------------------------------------------------- on a local cluster


def test_two_worker_local_cluster_gives_exactly_the_serial_results_even_when_a_worker_dies(tmp_path):
    pytest.importorskip("distributed")
    log, marker = tmp_path / "cluster.log", tmp_path / "marker"
    victim = "vlcc|1000|150"  # its first attempt kills the worker process running it
    serial = run_study(AXES, fuel_case, tmp_path / "serial", scheduler_address="synchronous")
    calls = []
    par = run_study(
        AXES,
        functools.partial(kill_worker_once_case, log=str(log), marker=str(marker), victim=victim),
        tmp_path / "par",
        n_workers=2,
        progress=lambda *a: calls.append(a),
    )
    assert par.attrs.pop("optroute_study_case_fn") == "tests.test_study.kill_worker_once_case"
    assert serial.attrs.pop("optroute_study_case_fn") == "tests.test_study.fuel_case"
    xr.testing.assert_identical(par.drop_vars("runtime_s"), serial.drop_vars("runtime_s"))  # bit for bit
    np.testing.assert_allclose(par.fuel_t.values, analytic_fuel(), rtol=1e-15)
    assert calls == [(i, N_CASES) for i in range(N_CASES + 1)]
    assert len(case_files(tmp_path / "par")) == N_CASES
    lines = log.read_text().splitlines()
    assert marker.exists() and f"{victim} killed" in log.read_text()  # a worker really died mid-case
    done = [line.split(" ") for line in lines if " killed " not in line]
    assert all(w.startswith("tcp://127.0.0.1:") for _, w, _ in done), done  # workers on loopback only
    assert {pid for *_, pid in done} - {str(os.getpid())}  # run in other processes
    # every feasible case computed to completion exactly once, the victim included (on its second attempt)
    assert log_counts(log) == Counter({k: 1 for k in all_keys() if "|2500|100" not in k})


_KILL_SCRIPT = """
import functools, sys
sys.path.insert(0, {root!r})
from optroute.studies.study import run_study
from tests.test_study import AXES, fuel_case

if __name__ == "__main__":
    run_study(AXES, functools.partial(fuel_case, log={log!r}, delay_s={delay}), {store!r}, {how})
"""


def _start_study_subprocess(tmp_path: Path, store: Path, log: Path, delay: float, how: str) -> subprocess.Popen:
    script = tmp_path / "run.py"
    script.write_text(_KILL_SCRIPT.format(root=str(ROOT), log=str(log), store=str(store), delay=delay, how=how))
    stderr = open(tmp_path / "stderr.txt", "wb")  # noqa: SIM115 - the child owns it
    return subprocess.Popen([sys.executable, str(script)], cwd=tmp_path, stderr=stderr)


def _wait_for_cases(proc: subprocess.Popen, store: Path, n: int, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if (store / "cases").is_dir() and len(case_files(store)) >= n:
            return
        if proc.poll() is not None:
            raise AssertionError(f"study exited early: {(store.parent / 'stderr.txt').read_text()[-2000:]}")
        time.sleep(0.01)
    proc.kill()
    raise AssertionError(f"no {n} case files after {timeout_s} s")


def test_study_killed_halfway_resumes_with_every_case_once(tmp_path):
    psutil = pytest.importorskip("psutil")
    pytest.importorskip("distributed")
    store, log = tmp_path / "s", tmp_path / "log"
    proc = _start_study_subprocess(tmp_path, store, log, delay=0.2, how="n_workers=2")
    _wait_for_cases(proc, store, 6, timeout_s=600)  # a ceiling against a hang, not a speed limit
    workers = psutil.Process(proc.pid).children(recursive=True)
    os.kill(proc.pid, signal.SIGKILL)  # the client stops dead: no cleanup, no final combine
    proc.wait(timeout=10)
    _, alive = psutil.wait_procs(workers, timeout=15)  # orphaned workers notice their parent is gone
    for p in alive:  # pragma: no cover - would be a leak of our own subprocesses
        p.kill()
    assert not alive, "worker processes outlived the killed client"
    first = stored_keys(store)
    assert 6 <= len(first) < N_CASES
    assert not (store / "study.nc").exists()
    partial = load_study(store)
    assert int((partial.status == "missing").sum()) == N_CASES - len(first)
    assert np.isnan(partial.fuel_t.where(partial.status == "missing")).all()

    ds = run_study(AXES, functools.partial(fuel_case, log=str(log)), store, scheduler_address="synchronous")
    np.testing.assert_allclose(ds.fuel_t.values, analytic_fuel(), rtol=1e-15)
    statuses = ds.status.values.astype(str).ravel()
    assert sum(s == "ok" for s in statuses) == N_CASES - len(SHIP_K)
    assert all(s == "ok" or s.startswith("failed: InfeasibleETA") for s in statuses)
    assert int((ds.status == "missing").sum()) == 0
    assert len(case_files(store)) == N_CASES  # every case present, once (one file per key)
    counts = log_counts(log)
    assert {k for k in first if "|2500|100" not in k} <= set(counts)
    assert all(counts[k] == 1 for k in first if "|2500|100" not in k)  # stored cases were not recomputed
    assert all(counts[k] >= 1 for k in all_keys() if "|2500|100" not in k)


# --------------------------------------------------------------------------- atomic writes


def test_interrupted_case_write_leaves_no_case_file(tmp_path, monkeypatch):
    store, log = tmp_path / "s", tmp_path / "log"
    real = _store._write_all
    writes = []

    def interrupted(fh, data):
        writes.append(fh.name)
        if len([w for w in writes if "/cases/" in w]) == 3:  # the third case: half its bytes, then the user hits Ctrl-C
            fh.write(memoryview(data)[: len(data) // 2])
            fh.flush()
            raise KeyboardInterrupt
        real(fh, data)

    monkeypatch.setattr(_store, "_write_all", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_study(AXES, functools.partial(fuel_case, log=str(log)), store, scheduler_address="synchronous")
    assert case_files(store) == ["0-0-0.nc", "0-0-1.nc"]
    assert not [p for p in (store / "cases").iterdir() if p.name.startswith(".tmp-")]
    assert "0-0-2.nc" not in os.listdir(store / "cases")
    monkeypatch.setattr(_store, "_write_all", real)

    ds = run_study(AXES, functools.partial(fuel_case, log=str(log)), store, scheduler_address="synchronous")
    np.testing.assert_allclose(ds.fuel_t.values, analytic_fuel(), rtol=1e-15)
    counts = log_counts(log)
    assert counts["feeder|1000|100"] == counts["feeder|1000|150"] == 1
    assert counts["feeder|1000|200"] == 2  # computed, never stored, computed again


_CRASH_SCRIPT = """
import functools, os, signal, sys
sys.path.insert(0, {root!r})
from optroute import _store
from optroute.studies.study import run_study
from tests.test_study import AXES, fuel_case

real, n = _store._write_all, []

def crash(fh, data):
    n.append("/cases/" in fh.name)
    if sum(n) == 4:  # the process dies half-way through the fourth case file
        fh.write(memoryview(data)[: len(data) // 2])
        fh.flush()
        os.fsync(fh.fileno())
        os.kill(os.getpid(), signal.SIGKILL)
    real(fh, data)

_store._write_all = crash
run_study(AXES, fuel_case, {store!r}, scheduler_address="synchronous")
"""


def test_process_killed_during_a_write_leaves_only_a_temporary(tmp_path):
    store = tmp_path / "s"
    script = tmp_path / "crash.py"
    script.write_text(_CRASH_SCRIPT.format(root=str(ROOT), store=str(store)))
    out = subprocess.run([sys.executable, str(script)], capture_output=True, timeout=60)
    assert out.returncode == -signal.SIGKILL, out.stderr.decode()[-2000:]
    assert case_files(store) == ["0-0-0.nc", "0-0-1.nc", "0-0-2.nc"]
    tmp = [p for p in (store / "cases").iterdir() if p.name.startswith(".tmp-")]
    assert len(tmp) == 1 and tmp[0].name.startswith(".tmp-0-0-3.nc")  # the half-written bytes, under a temp name
    assert load_study(store).status.sel(ship="feeder", distance_nm=1000.0, eta_h=250.0).item() == "missing"
    ds = run_study(AXES, fuel_case, store, scheduler_address="synchronous")
    assert not [p for p in (store / "cases").iterdir() if p.name.startswith(".")]
    np.testing.assert_allclose(ds.fuel_t.values, analytic_fuel(), rtol=1e-15)


def test_failed_store_write_is_a_study_error_naming_the_fix(tmp_path, monkeypatch):
    real = _store._write_all

    def disk_full(fh, data):
        if "/cases/" not in fh.name:
            return real(fh, data)
        fh.write(memoryview(data)[:10])
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(_store, "_write_all", disk_full)
    with pytest.raises(StudyError, match="No space left on device.*free disk space.*resume"):
        run_study(AXES, fuel_case, tmp_path / "s", scheduler_address="synchronous")
    assert case_files(tmp_path / "s") == []
    assert not list((tmp_path / "s" / "cases").iterdir())


# --------------------------------------------------------------------------- failures per case


def test_failing_cases_are_recorded_not_retried_unless_asked(tmp_path):
    store, log = tmp_path / "s", tmp_path / "log"
    case = functools.partial(fuel_case, log=str(log))
    ds = run_study(AXES, case, store, scheduler_address="synchronous")
    failed = ds.status.values.astype(str)
    assert sum(s.startswith("failed: InfeasibleETA") for s in failed.ravel()) == len(SHIP_K)
    assert np.isnan(ds.fuel_t.sel(distance_nm=2500.0, eta_h=100.0)).all()
    tb = xr.open_dataset(store / "cases" / "0-1-0.nc", engine="h5netcdf").attrs[_store.TRACEBACK_ATTR]
    assert "InfeasibleETA" in tb and "fuel_case" in tb
    calls = []
    again = run_study(AXES, case, store, scheduler_address="synchronous", progress=lambda *a: calls.append(a))
    assert calls == [(N_CASES, N_CASES)]  # nothing left to do; failed cases are done
    xr.testing.assert_identical(again.drop_vars("runtime_s"), ds.drop_vars("runtime_s"))
    assert log_counts(log) == Counter({k: 1 for k in all_keys() if "|2500|100" not in k})
    calls.clear()
    run_study(
        AXES, case, store, scheduler_address="synchronous", retry_failed=True, progress=lambda *a: calls.append(a)
    )
    assert calls[0] == (N_CASES - len(SHIP_K), N_CASES) and calls[-1] == (N_CASES, N_CASES)


def test_reserved_result_name_fails_that_case_with_the_fix(tmp_path):
    ds = run_study({"a": [1, 2]}, reserved_name_case, tmp_path / "s", scheduler_address="synchronous")
    assert all("reserves" in s and "rename it" in s for s in ds.status.values.astype(str))


def test_unpicklable_case_fn_is_refused_before_any_cluster_starts(tmp_path):
    pytest.importorskip("distributed")
    case = functools.partial(fuel_case, log=threading.Lock())
    with pytest.raises(ConfigError, match="cannot be pickled.*module-level"):
        run_study(AXES, case, tmp_path / "s", n_workers=2)
    assert not (tmp_path / "s" / "cases").exists() or case_files(tmp_path / "s") == []


# --------------------------------------------------------------------------- schedulers


def test_unreachable_scheduler_fails_fast_naming_the_address(tmp_path):
    pytest.importorskip("distributed")
    address = "tcp://127.0.0.1:1"
    with pytest.raises(SchedulerUnreachable, match="tcp://127.0.0.1:1") as info:
        run_study(AXES, fuel_case, tmp_path / "s", scheduler_address=address, timeout_s=5)
    assert isinstance(info.value, OptrouteError) and info.value.address == address
    assert "dask scheduler" in str(info.value) and "scheduler_address=None" in str(info.value)
    assert case_files(tmp_path / "s") == []


def test_silent_scheduler_times_out_within_timeout(tmp_path):
    """A port that accepts connections but never speaks Dask: fail after ~timeout_s, not hang."""
    pytest.importorskip("distributed")
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    try:
        with pytest.raises(SchedulerUnreachable, match=address):
            run_study(AXES, fuel_case, tmp_path / "s", scheduler_address=address, timeout_s=2)
    finally:
        server.close()


class _LoopbackServer:
    """A TCP server on 127.0.0.1 that is not Dask: it sends ``reply`` at once, or after the client speaks."""

    def __init__(self, reply: bytes, *, after_request: bool) -> None:
        self.reply, self.after_request = reply, after_request
        self.stop = threading.Event()
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.sock.settimeout(0.1)  # accept() polls the stop flag
        self.address = f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        deadline = time.monotonic() + 120.0  # a ceiling against a hang, should the test never stop it
        while not self.stop.is_set() and time.monotonic() < deadline:
            try:
                conn, _ = self.sock.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            with conn:
                try:
                    conn.settimeout(10.0)
                    if self.after_request:
                        conn.recv(65536)
                    conn.sendall(self.reply)
                except OSError:
                    pass

    def close(self) -> None:
        self.stop.set()
        self.thread.join(timeout=15.0)
        self.sock.close()


HTTP_400 = b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"


@pytest.mark.parametrize(
    ("reply", "after_request", "match"),
    [
        # a web server answering what it is sent: read by Dask as an 8-byte length, "HTTP/1.1" asks for 3 EiB
        (HTTP_400, False, r"not as a Dask scheduler \(an HTTP server.*length of 3543824036068086856 bytes"),
        (bytes(range(255, 191, -1)), False, r"not as a Dask scheduler: its first 8 bytes give a message length"),
        # a plausible length prefix, then bytes that are not Dask frames: Dask's own read fails on them
        (struct.pack("Q", 16) + b"\x01" * 16, False, r"not as a Dask scheduler: its answer to Dask's handshake"),
        # a server that speaks only when spoken to: no greeting within timeout_s
        (HTTP_400, True, r"not as a Dask scheduler: it sent nothing within timeout_s=2 s"),
    ],
    ids=["http-text", "garbage-bytes", "bad-frames", "silent-until-asked"],
)
def test_a_service_that_is_not_dask_is_scheduler_unreachable(tmp_path, reply, after_request, match):
    pytest.importorskip("distributed")
    server = _LoopbackServer(reply, after_request=after_request)
    try:
        with pytest.raises(SchedulerUnreachable, match=match) as info:
            run_study(AXES, fuel_case, tmp_path / "s", scheduler_address=server.address, timeout_s=2)
    finally:
        server.close()
    message = str(info.value)
    assert info.value.address == server.address and server.address in message
    assert "port 8786 by default" in message and "scheduler_address=None" in message  # the fix
    assert "EiB" not in message and case_files(tmp_path / "s") == []


def test_bad_options_are_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="n_workers=2 applies to the local cluster only"):
        run_study(AXES, fuel_case, tmp_path / "s", scheduler_address="tcp://127.0.0.1:1", n_workers=2)
    with pytest.raises(ConfigError, match="timeout_s"):
        run_study(AXES, fuel_case, tmp_path / "s", timeout_s=0)
    with pytest.raises(StudyError, match="suffix '.csv'"):
        run_study(AXES, fuel_case, tmp_path / "s", scheduler_address="synchronous", output=tmp_path / "x.csv")


# --------------------------------------------------------------------------- store and axes


def test_resume_refuses_other_axes_and_resume_false_starts_over(tmp_path):
    store = tmp_path / "s"
    run_study({"ship": ["feeder"], "distance_nm": [1000.0], "eta_h": [100.0, 200.0]}, fuel_case, store, n_workers=0)
    with pytest.raises(StudyError, match=r"axis 'eta_h' value #1 is 200.0 in the store but 250.0.*resume=False"):
        run_study({"ship": ["feeder"], "distance_nm": [1000.0], "eta_h": [100.0, 250.0]}, fuel_case, store, n_workers=0)
    with pytest.raises(StudyError, match="axes"):
        run_study({"ship": ["feeder"], "eta_h": [100.0, 200.0]}, fuel_case, store, n_workers=0)
    ds = run_study(
        {"ship": ["feeder"], "distance_nm": [1000.0], "eta_h": [100.0, 250.0]},
        fuel_case,
        store,
        n_workers=0,
        resume=False,
    )
    assert ds.fuel_t.sel(eta_h=250.0).item() == pytest.approx(1e-6 * 1e9 / 250.0**2)


def test_store_is_locked_while_a_run_writes_it(tmp_path):
    store = tmp_path / "s"
    store.mkdir()
    with _store.locked(store), pytest.raises(StudyError, match="another run"):
        run_study(AXES, fuel_case, store, n_workers=0)


def test_load_study_without_a_store_says_so(tmp_path):
    with pytest.raises(StudyError, match="manifest.json is missing"):
        load_study(tmp_path)


def test_zarr_output_by_suffix(tmp_path):
    pytest.importorskip("zarr")
    out = tmp_path / "front.zarr"
    ds = run_study(AXES, fuel_case, tmp_path / "s", n_workers=0, output=out)
    back = xr.open_zarr(out).load()
    np.testing.assert_array_equal(back.fuel_t.values, ds.fuel_t.values)
    assert [str(v) for v in back.status.values.ravel()] == [str(v) for v in ds.status.values.ravel()]
    again = load_study(tmp_path / "s", output=out)  # replaces the existing Zarr store atomically
    xr.testing.assert_equal(xr.open_zarr(out).fuel_t.load(), again.fuel_t)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".tmp-")]


def test_ragged_fronts_are_padded_and_keep_their_own_coordinates(tmp_path):
    ds = run_study({"n": [2, 4], "start_h": [100.0, 200.0]}, ragged_case, tmp_path / "s", n_workers=0)
    assert ds.fuel_t.dims == ("n", "start_h", "point") and ds.sizes["point"] == 4
    np.testing.assert_array_equal(ds.point.values, np.arange(4))
    row = ds.sel(n=2, start_h=200.0)
    np.testing.assert_allclose(row.fuel_t.values[:2], 100.0 / np.array([200.0, 210.0]))
    assert np.isnan(row.fuel_t.values[2:]).all() and np.isnan(row.eta_h.values[2:]).all()
    assert ds.feasible.dtype == float  # bool with holes → float with NaN
    ds2 = run_study({"start_h": [100.0, 200.0]}, ragged_index_case, tmp_path / "t", n_workers=0)
    assert "case_eta_front" in ds2.coords and "eta_front" not in ds2.indexes
    np.testing.assert_allclose(ds2.case_eta_front.sel(start_h=200.0), [200.0, 210.0, 220.0])


def test_time_and_object_axes(tmp_path):
    etas = np.array(["2024-01-02T00:00", "2024-01-03T12:00"], dtype="datetime64[s]")
    ships = [_NamedShip("feeder", 120.0), _NamedShip("vlcc", 330.0)]
    ds = run_study({"ship": ships, "eta": etas}, time_case, tmp_path / "s", n_workers=0)
    assert list(ds.ship.values) == ["feeder", "vlcc"] and ds.eta.dtype == np.dtype("datetime64[ns]")
    np.testing.assert_allclose(ds.hours.sel(ship="vlcc").values, [24.0, 60.0])
    np.testing.assert_allclose(ds.ship_length_m.sel(eta=etas[0]).values, [120.0, 330.0])
    by_map = run_study({"ship": {"a": ships[0], "b": ships[1]}, "eta": etas}, time_case, tmp_path / "m", n_workers=0)
    assert list(by_map.ship.values) == ["a", "b"]


@pytest.mark.parametrize(
    ("axes", "match"),
    [
        ({}, "non-empty mapping"),
        ({"eta": []}, "empty"),
        ({"eta": [1.0, 1.0]}, "twice"),
        ({"eta": {1.0, 2.0}}, "order is not stable"),
        ({"eta": "abc"}, "wrap a single value"),
        ({"wx": [object(), object()]}, "mapping"),
        ({"status": [1]}, "reserved"),
        ({"eta": [1.0, float("nan")]}, "non-finite"),
    ],
)
def test_bad_axes_are_config_errors(tmp_path, axes, match):
    with pytest.raises(ConfigError, match=match):
        run_study(axes, fuel_case, tmp_path / "s", n_workers=0)


def _threaded_cluster(distributed):
    """A 2-worker cluster of threads in this process on the loopback interface, its scheduler's HTTP routes on a free
    port (as a study's own cluster: :data:`~optroute.studies.cluster.SCHEDULER_HTTP_ADDRESS`)."""
    return distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, protocol="tcp", host="127.0.0.1", dashboard_address=None,
        scheduler_kwargs={"dashboard_address": SCHEDULER_HTTP_ADDRESS},
    )  # fmt: skip


def test_existing_cluster_through_its_address(tmp_path, monkeypatch):
    distributed = pytest.importorskip("distributed")
    with _threaded_cluster(distributed) as cluster:
        ds = run_study(AXES, fuel_case, tmp_path / "s", scheduler_address=cluster.scheduler_address)
        worker = next(iter(cluster.workers.values())).address
        with pytest.raises(SchedulerUnreachable, match="answers as a Dask Worker, not a scheduler"):
            run_study(AXES, fuel_case, tmp_path / "t", scheduler_address=worker)
        # workers that cannot write the store stop the study with the fix, recording no case as failed
        real = _store._write_all

        def read_only_cases(fh, data):
            if "/cases/" in fh.name:
                raise PermissionError(13, "Permission denied")
            real(fh, data)

        monkeypatch.setattr(_store, "_write_all", read_only_cases)
        with pytest.raises(StudyError, match="shared filesystem.*store_on_workers=False"):
            run_study(
                AXES, fuel_case, tmp_path / "u", scheduler_address=cluster.scheduler_address, store_on_workers=True
            )
        assert case_files(tmp_path / "u") == []
    np.testing.assert_allclose(ds.fuel_t.values, analytic_fuel(), rtol=1e-15)
    assert int((ds.status == "ok").sum()) == N_CASES - len(SHIP_K)


# --------------------------------------------------------------------------- stale, corrupt and unwritable stores


def scaled_fuel_case(case: dict, scale: float, log: str | None = None) -> dict:
    """:func:`fuel_case` with every ship's coefficient ``k`` multiplied by ``scale`` (an input beyond the labels)."""
    out = fuel_case(case, log)
    return {**out, "fuel_t": scale * out["fuel_t"], "cumulative_fuel_t": scale * out["cumulative_fuel_t"]}


def _scaled_study(store: Path, scale: float, **kw) -> xr.Dataset:
    from optroute.studies.fingerprint import CaseInput, digest

    return run_study(
        AXES,
        functools.partial(scaled_fuel_case, scale=scale, log=kw.pop("log", None)),
        store,
        scheduler_address="synchronous",
        case_inputs=lambda case: {"scale": CaseInput(digest(scale), f"k scaled by {scale:g}")},
        **kw,
    )


def test_changed_inputs_are_refused_naming_what_changed_or_recomputed_when_asked(tmp_path):
    store = tmp_path / "s"
    first = _scaled_study(store, 1.0)
    np.testing.assert_allclose(first.fuel_t.values, analytic_fuel(), rtol=1e-15)
    # same labels, another input: matching on labels alone would return the scale-1 fuel
    with pytest.raises(
        StudyError, match=r"computed from other inputs.*scale: k scaled by 1 in the store, now k scaled by 2"
    ):
        _scaled_study(store, 2.0)
    log = tmp_path / "log"
    with pytest.warns(UserWarning, match="computing 24 case.*inputs changed"):
        again = _scaled_study(store, 2.0, on_changed_inputs="recompute", log=str(log))
    np.testing.assert_allclose(again.fuel_t.values, 2.0 * analytic_fuel(), rtol=1e-15)
    assert sum(log_counts(log).values()) == N_CASES - len(SHIP_K)  # every feasible case computed again
    calls = []
    _scaled_study(store, 2.0, progress=lambda *a: calls.append(a))  # now consistent: nothing to do
    assert calls == [(N_CASES, N_CASES)]


def test_cases_stored_without_a_record_of_their_inputs_are_not_reused_silently(tmp_path):
    store = tmp_path / "s"
    run_study(AXES, functools.partial(scaled_fuel_case, scale=1.0), store, scheduler_address="synchronous")
    with pytest.raises(StudyError, match="scale: not recorded in the store"):
        _scaled_study(store, 1.0)


@pytest.mark.parametrize(
    "damage",
    [
        pytest.param(lambda b: b[: len(b) // 2], id="truncated"),
        pytest.param(lambda b: b"not a netcdf file\n", id="garbage"),
        pytest.param(lambda b: b"", id="empty"),
    ],
)
def test_corrupt_case_file_is_recomputed_at_open_with_a_warning(tmp_path, damage):
    store, log = tmp_path / "s", tmp_path / "log"
    _scaled_study(store, 1.0)
    victim = store / "cases" / "1-0-2.nc"  # panamax, 1000 nm, 200 h
    victim.write_bytes(damage(victim.read_bytes()))
    with pytest.warns(UserWarning, match=r"case ship=panamax, distance_nm=1000.0, eta_h=200.0 .* unreadable"):
        ds = _scaled_study(store, 1.0, log=str(log))
    assert log_counts(log) == Counter({"panamax|1000|200": 1})  # only that case, before combining
    np.testing.assert_allclose(ds.fuel_t.values, analytic_fuel(), rtol=1e-15)
    assert (store / "cases" / "1-0-2.nc.corrupt").exists() and len(case_files(store)) == N_CASES + 1


def test_unwritable_store_is_a_study_error_naming_the_path(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    with pytest.raises(StudyError, match=r"study store '.*a_file/store' is not writable"):
        run_study(AXES, fuel_case, blocker / "store", scheduler_address="synchronous")


def test_read_only_store_is_a_study_error_naming_the_path(tmp_path, monkeypatch):
    store = tmp_path / "s"
    run_study(AXES, fuel_case, store, scheduler_address="synchronous")
    os.chmod(store / "cases", 0o555)
    os.chmod(store, 0o555)
    try:
        if os.geteuid() == 0:  # root writes through permissions: refuse like a read-only mount would
            real_touch = Path.touch

            def read_only(self, *a, **kw):
                if str(self).startswith(str(store)):
                    raise PermissionError(13, "Permission denied", str(self))
                return real_touch(self, *a, **kw)

            monkeypatch.setattr(Path, "touch", read_only)
        with pytest.raises(StudyError, match=rf"study store '{store}' is not writable.*Permission denied"):
            run_study(AXES, fuel_case, store, scheduler_address="synchronous")
        xr.testing.assert_identical(load_study(store), xr.load_dataset(store / "study.nc"))  # still readable
    finally:
        os.chmod(store, 0o755)
        os.chmod(store / "cases", 0o755)


# --------------------------------------------------------------------------- the fingerprints themselves


def test_digests_follow_content_not_identity_and_are_the_same_in_another_process(tmp_path):
    from optroute.physics.ship import Ship
    from optroute.studies.fingerprint import dataset_digest, digest, file_digest

    assert len({digest(1), digest(1.0), digest("1"), digest(True), digest([1]), digest((1,))}) == 6
    assert digest({"a": 1, "b": 2}) == digest({"b": 2, "a": 1})  # mappings in key order
    ship = Ship.preset("container_54k_dwt")
    assert digest(ship.replace(description="renamed in the notes")) == digest(ship)  # not a compared field
    assert digest(ship.replace(mcr_kw=36_501.0)) != digest(ship)
    ds = xr.Dataset(
        {"hs_m": (("time", "lat"), np.array([[1.0, 2.0], [3.0, 4.0]]))},
        coords={"time": np.array(["2024-01-10T00", "2024-01-10T06"], dtype="datetime64[ns]"), "lat": [0.0, 1.0]},
    )
    ds.to_netcdf(tmp_path / "wx.nc")
    assert dataset_digest(xr.load_dataset(tmp_path / "wx.nc")) == dataset_digest(ds)  # exact round trip
    assert dataset_digest(ds.assign(hs_m=ds.hs_m + np.array([[0.0, 0.0], [0.0, 1e-12]]))) != dataset_digest(ds)
    assert dataset_digest(ds.assign_coords(lat=[0.0, 1.5])) != dataset_digest(ds)
    before = file_digest(tmp_path / "wx.nc")
    ds.assign(hs_m=ds.hs_m * 7.0).to_netcdf(tmp_path / "wx.nc")
    assert file_digest(tmp_path / "wx.nc") != before
    code = (
        "from optroute.physics.ship import Ship\n"
        "from optroute.studies.fingerprint import digest\n"
        "print(digest(Ship.preset('container_54k_dwt')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == digest(ship)  # a store resumed by another process recognises its inputs


# --------------------------------------------------------------------------- scale: a loopback scheduler, a progress bar


def test_text_progress_bar_by_hand():
    from optroute.studies.progress import TextProgress

    out = io.StringIO()  # not a terminal: one line per call with every_s=0
    bar = TextProgress("study", stream=out, width=10, every_s=0.0)
    for done in (0, 2, 4):
        bar(done, 4)
    lines = out.getvalue().splitlines()
    assert lines[0] == "study 0/4 [..........]   0%"
    assert lines[1].startswith("study 2/4 [#####.....]  50% ") and "cases/min" in lines[1] and "left" in lines[1]
    assert lines[2].startswith("study 4/4 [##########] 100% ") and "left" not in lines[2]
    quiet = io.StringIO()
    bar = TextProgress(stream=quiet, every_s=3600.0)
    for done in range(5):
        bar(done, 4)
    assert bar.lines == 2  # the first and the last line only, within the hour
    with pytest.raises(ConfigError, match="width=0"):
        TextProgress(width=0)


def test_study_on_a_loopback_scheduler_with_a_progress_bar_resumes_without_recomputing(tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    axes = {"ship": list(SHIP_K), "distance_nm": DISTANCE_NM, "eta_h": [150.0 + 10.0 * i for i in range(10)]}
    total = 3 * 2 * 10
    log = tmp_path / "log.txt"
    with _threaded_cluster(distributed) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        fn = functools.partial(fuel_case, log=str(log))
        ds = run_study(axes, fn, tmp_path / "s", scheduler_address=cluster.scheduler_address, progress=True)
        err = capsys.readouterr().err
        assert f"study {total}/{total} [" in err and "100%" in err
        again = run_study(axes, fn, tmp_path / "s", scheduler_address=cluster.scheduler_address, progress=True)
        err = capsys.readouterr().err
    assert f"study {total}/{total} [" in err  # all stored: the bar starts full
    assert sum(log_counts(log).values()) == total  # every case computed once, none again on resume
    k = np.array(list(SHIP_K.values()))[:, None, None]
    d = np.array(DISTANCE_NM)[None, :, None]
    eta = np.array(axes["eta_h"])[None, None, :]
    np.testing.assert_allclose(
        ds.fuel_t.values, np.where(d / eta > MAX_SPEED_KN, np.nan, k * d**3 / eta**2), rtol=1e-15
    )
    xr.testing.assert_identical(again, ds)


def test_two_local_clusters_at_once_take_free_loopback_ports_without_a_warning():
    """Each study's local cluster serves its scheduler's HTTP routes (health, metrics; no dashboard) on a free port of
    the loopback interface, so a second study at the same time, or a notebook's cluster on Dask's default port 8787,
    starts without Dask's "Port 8787 is already in use" warning (clusters without workers: no process is spawned)."""
    pytest.importorskip("distributed")

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with dask_client(None, 0, 1, 10.0) as first, dask_client(None, 0, 1, 10.0) as second:
            servers = [c.cluster.scheduler.http_server for c in (first, second)]
            assert [s.address for s in servers] == ["127.0.0.1", "127.0.0.1"]
            assert servers[0].port != servers[1].port
