"""Studies: one case function over the Cartesian product of axes, on Dask, resumable.

A *study* sweeps a case function over every combination of the values of its
axes — ships × weather scenarios or ensemble members × ETAs, say — and
collects the results in one :class:`xarray.Dataset` whose dimensions are the
axes.  The engine is generic over what a case computes: a case function takes
a ``dict`` ``{axis name: value}`` and returns an :class:`xarray.Dataset` or a
mapping of variable name → array (a plan's totals, a fuel-versus-ETA front…).

Cases run on Dask: a :class:`distributed.LocalCluster` of worker processes on
the loopback interface by default, an existing cluster through
``scheduler_address=``, or in this process with
``scheduler_address="synchronous"`` (or ``n_workers=0``), which is also the
reference the parallel runs must reproduce exactly.

Every finished case is written at once, atomically, as one small NetCDF file
in the study store (see :mod:`optroute._store` for the layout), so a study
that is interrupted — a worker killed, the client stopped, the machine
rebooted — resumes where it stopped when run again with the same axes and
store: stored cases are not computed again and none is lost.  A case whose
function raises is stored too, with status ``"failed: <exception>"``, and is
not retried unless asked (``retry_failed=True``).

The case function must be picklable so that it can be sent to worker
processes: define it at module level in an importable module (workers import
it by name) and bind fixed arguments — the corridor, the weather, the ship —
with :func:`functools.partial`.  Lambdas and closures work too (they are
shipped by value with cloudpickle) as long as what they capture pickles.  A
script that starts a local cluster must guard its entry point with
``if __name__ == "__main__":`` because the worker processes are spawned.

Examples
--------
>>> def fuel_case(case):                       # module level
...     k, d_nm, eta_h = case["ship"], case["distance_nm"], case["eta_h"]
...     return {"fuel_t": k * d_nm**3 / eta_h**2}
>>> ds = run_study({"ship": [1e-6, 2e-6], "distance_nm": [3000.0], "eta_h": [200.0, 240.0]},
...                fuel_case, "runs/demo")  # doctest: +SKIP
>>> ds.fuel_t.sel(ship=1e-6, eta_h=240.0)        # doctest: +SKIP
"""

from __future__ import annotations

import contextlib
import io
import math
import time
import traceback
import uuid
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import dask
import numpy as np
import xarray as xr

from optroute import _store
from optroute._store import StudyError
from optroute.errors import ConfigError
from optroute.studies import fingerprint
from optroute.studies.cluster import (
    SYNCHRONOUS,
    SchedulerUnreachable,
    check_cluster_options,
    check_picklable,
    dask_client,
    import_distributed,
)
from optroute.studies.fingerprint import CaseInput
from optroute.studies.progress import TextProgress
from optroute.studies.study_axes import axes_difference, make_axes, study_manifest
from optroute.studies.threads import solver_process

__all__ = [
    "SYNCHRONOUS",
    "CaseFunction",
    "ProgressCallback",
    "SchedulerUnreachable",
    "StudyError",
    "load_study",
    "run_study",
]

CaseResult = xr.Dataset | Mapping[str, Any]
#: A case function: ``{axis name: value}`` → dataset or mapping of name → array.
CaseFunction = Callable[[dict[str, Any]], CaseResult]
#: A progress callback: ``(cases done, cases in the study)``.
ProgressCallback = Callable[[int, int], None]


# --------------------------------------------------------------------------- one case (runs on a worker)


class _Outcome(NamedTuple):
    index: tuple[int, ...]
    status: str
    payload: bytes | None  # the encoded case file, or None once a worker has stored it
    runtime_s: float
    case: xr.Dataset | None = None  # the stored file decoded by the worker that wrote it (what read_case gives)


class _WorkerStoreError(StudyError):
    """A worker computed a case but could not write its file into the store."""


def _identity(obj: Any) -> Any:
    return obj


def _as_dataset(result: Any, reserved: Sequence[str]) -> xr.Dataset:
    if isinstance(result, xr.Dataset):
        ds = result.copy()
    elif isinstance(result, xr.DataArray):
        if result.name is None:
            raise StudyError("case_fn returned an unnamed DataArray; give it a name or return a Dataset or a mapping")
        ds = result.to_dataset()
    elif isinstance(result, Mapping):
        data_vars: dict[str, Any] = {}
        for name, value in result.items():
            if not isinstance(name, str):
                raise StudyError(f"case_fn returned a mapping with key {name!r}; variable names must be strings")
            if isinstance(value, xr.DataArray | xr.Variable | tuple):
                data_vars[name] = value
            else:
                arr = np.asarray(value)
                data_vars[name] = (tuple(f"{name}_dim_{k}" for k in range(arr.ndim)), arr)
        ds = xr.Dataset(data_vars)
    else:
        raise StudyError(
            f"case_fn returned {type(result).__name__}; return an xarray.Dataset or a mapping of name → array"
        )
    for name in list(ds.variables) + list(ds.dims):
        if name in reserved:
            raise StudyError(
                f"case_fn returned a variable or dimension named {name!r}, which the study reserves "
                f"(reserved: {sorted(reserved)}); rename it, e.g. ds.rename({{{name!r}: 'case_{name}'}})"
            )
    return ds


def _encode(ds: xr.Dataset) -> bytes:
    # Inside a Dask worker xarray would take a *distributed* write lock named after the target, which
    # fails for an in-memory target; the local synchronous scheduler gives it a plain process lock.
    with dask.config.set(scheduler="synchronous"):
        return bytes(ds.to_netcdf(engine="h5netcdf"))


def _decode(payload: bytes) -> xr.Dataset:
    """A case file's bytes loaded as :func:`optroute._store.read_case` loads the file (same engine)."""
    with dask.config.set(scheduler="synchronous"):  # as _encode: no distributed lock inside a worker
        return xr.load_dataset(io.BytesIO(payload), engine="h5netcdf")


def _failure(
    index: tuple[int, ...], exc: BaseException, runtime_s: float, tb: str | None = None, inputs: str | None = None
) -> _Outcome:
    status = f"failed: {type(exc).__name__}: {exc}"
    if tb is None:
        tb = "".join(traceback.format_exception(exc))
    attrs = {
        _store.KEY_ATTR: "-".join(map(str, index)),
        _store.STATUS_ATTR: status,
        _store.RUNTIME_ATTR: runtime_s,
        _store.TRACEBACK_ATTR: tb,
    }
    if inputs is not None:
        attrs[_store.INPUTS_ATTR] = inputs
    return _Outcome(index, status, _encode(xr.Dataset(attrs=attrs)), runtime_s)


def _compute_case(
    case_fn: CaseFunction,
    index: tuple[int, ...],
    params: dict[str, Any],
    reserved: Sequence[str],
    inputs: str | None = None,
) -> _Outcome:
    """Run one case and encode its outcome as NetCDF bytes; never raises for an error of the case.

    Any :class:`Exception` from ``case_fn``, from converting its result or
    from encoding it becomes a ``"failed: ..."`` outcome (with the traceback),
    so that one bad case is recorded rather than ending the study.
    ``KeyboardInterrupt`` and ``SystemExit`` pass through: they stop the
    study, which resumes later.
    """
    # the case function solves in a process set up as every study's solves are (one BLAS thread for Ipopt, a Dask
    # worker's allocator thresholds): the same case gives the same numbers serial and on a cluster
    solver_process()
    start = time.perf_counter()
    try:
        ds = _as_dataset(case_fn(dict(params)), reserved)
        runtime = time.perf_counter() - start
        ds.attrs.update(
            {
                _store.KEY_ATTR: "-".join(map(str, index)),
                _store.STATUS_ATTR: "ok",
                _store.RUNTIME_ATTR: runtime,
            }
        )
        if inputs is not None:
            ds.attrs[_store.INPUTS_ATTR] = inputs
        return _Outcome(index, "ok", _encode(ds), runtime)
    except Exception as exc:  # noqa: BLE001 - recorded per case, by design
        return _failure(index, exc, time.perf_counter() - start, inputs=inputs)


def _run_case(
    case_fn: CaseFunction,
    index: tuple[int, ...],
    params: dict[str, Any],
    reserved: Sequence[str],
    store: str | None = None,
    replace: bool = False,
    inputs: str | None = None,
) -> _Outcome:
    """The task of one case: compute it and, when ``store`` is given, write its file from here.

    Writing from the worker makes a result durable as soon as it exists, so
    a worker that dies afterwards loses nothing; and a task that Dask runs
    again after such a death finds the file and returns at once instead of
    computing the case a second time (unless ``replace``: a failed case
    being retried).
    """
    if store is not None and not replace and (_store.cases_dir(Path(store)) / _store.case_name(index)).exists():
        return _Outcome(index, "stored", None, math.nan)
    outcome = _compute_case(case_fn, index, params, reserved, inputs)
    if store is None:
        return outcome
    try:
        _store.write_case(Path(store), index, outcome.payload)
    except OSError as exc:
        raise _WorkerStoreError(
            f"a worker could not write case {index} into {store!r} ({type(exc).__name__}: {exc})"
        ) from exc
    # decoded here, on the worker, for the combined dataset: reading every case file back was half of a study's
    # CPU on the client (1 200 calm-water cases), which no number of workers shortened
    return outcome._replace(payload=None, case=_decode(outcome.payload))


# --------------------------------------------------------------------------- execution


def _run_batch(
    case_fn: CaseFunction,
    batch: Sequence[tuple[tuple[int, ...], dict[str, Any], bool, str | None]],
    reserved: Sequence[str],
    store: str | None,
) -> list[_Outcome]:
    """The task of a batch of cases: :func:`_run_case` on each, one after the other, each stored as it finishes."""
    return [_run_case(case_fn, index, params, reserved, store, again, inputs) for index, params, again, inputs in batch]


def cases_per_task(pending: int, workers: int) -> int:
    """Cases per Dask task: about eight tasks per worker, at most :data:`MAX_CASES_PER_TASK` cases each.

    A task costs the scheduler a few milliseconds whatever it computes; a cheap case (a calm-water fuel figure)
    costs less than that, so one task per case made two workers slower than one process.  Eight tasks per
    worker keep the load balanced and the progress bar moving; the ceiling bounds the wait for a batch's
    results (each case is stored by the worker as soon as it is computed, whatever the batch).
    """
    return max(1, min(MAX_CASES_PER_TASK, pending // max(8 * workers, 1)))


MAX_CASES_PER_TASK = 16


def _run_distributed(
    client: Any,
    case_fn: CaseFunction,
    pending: list[tuple[int, ...]],
    params: Callable[[tuple[int, ...]], dict[str, Any]],
    reserved: tuple[str, ...],
    on_outcome: Callable[[_Outcome], None],
    store: str | None,
    replace: set[tuple[int, ...]],
    inputs_of: Callable[[tuple[int, ...]], str | None],
) -> None:
    from distributed import as_completed

    token = uuid.uuid4().hex[:8]
    # The case function travels once per worker (as a task result the scheduler can recompute if the
    # worker holding it dies), not once per case: it may carry a corridor and a weather dataset.
    fn = client.submit(_identity, case_fn, pure=False, key=f"optroute-study-{token}-case_fn")
    size = cases_per_task(len(pending), max(len(client.scheduler_info().get("workers", {})), 1))
    # contiguous batches in C order: a batch's cases share their leading axes (ship, weather), hence a worker's
    # prepared corridor
    batch_of: dict[str, list[tuple[int, ...]]] = {}
    submitted = []
    for first in range(0, len(pending), size):
        indices = pending[first : first + size]
        batch = [(index, params(index), index in replace, inputs_of(index)) for index in indices]
        name = _store.case_name(indices[0])[: -len(".nc")]
        fut = client.submit(
            _run_batch, fn, batch, reserved, store, pure=False, key=f"optroute-study-{token}-{name}-{len(indices)}"
        )
        batch_of[fut.key] = indices
        submitted.append(fut)
    futures = as_completed(submitted, loop=client.loop)
    del submitted  # hold each result only until it is stored
    for fut in futures:
        indices = batch_of.pop(fut.key)
        for outcome in _batch_outcomes(fut, fn, indices, store, inputs_of):
            on_outcome(outcome)
        fut.release()


def _batch_outcomes(
    fut: Any,
    fn: Any,
    indices: list[tuple[int, ...]],
    store: str | None,
    inputs_of: Callable[[tuple[int, ...]], str | None],
) -> list[_Outcome]:
    """The outcomes of a finished batch task; a task that failed fails its cases not yet stored (or raises)."""
    if fut.status == "finished":
        return fut.result()
    if fut.status == "error" and fn.status == "error":
        exc = fn.exception()
        raise StudyError(
            f"the Dask workers could not load case_fn ({type(exc).__name__}: {exc}); make its module importable "
            "on every worker (same code and environment), or bind it with functools.partial to a module-level "
            f"function; no case was recorded as failed: run the study again to resume"
        ) from exc
    if fut.status == "error" and isinstance(fut.exception(), _WorkerStoreError):
        exc = fut.exception()
        raise StudyError(
            f"{exc}; the workers must be able to write the store (on a shared filesystem, at the same path): "
            "fix that, or pass store_on_workers=False to have this process write every case file; "
            "then run the study again to resume"
        ) from exc
    if fut.status == "error":  # the task itself failed: a worker died under it (KilledWorker), SystemExit…
        exc = fut.exception()
        tb = "".join(traceback.format_tb(fut.traceback())) + "".join(traceback.format_exception_only(exc))
        stored = (lambda i: (_store.cases_dir(Path(store)) / _store.case_name(i)).exists()) if store else None
        return [
            _Outcome(index, "stored", None, math.nan)
            if stored is not None and stored(index)  # stored by the worker before the task died
            else _failure(index, exc, math.nan, tb, inputs_of(index))
            for index in indices
        ]
    raise StudyError(
        f"the Dask cluster lost cases {indices[0]} to {indices[-1]} (their task is {fut.status!r}), most likely "
        "because the scheduler went away; the cases finished so far are stored: run the study again to resume"
    )


# --------------------------------------------------------------------------- public API


@contextlib.contextmanager
def _writable_store(store: Path) -> Iterator[None]:
    """Create ``store`` (and its ``cases`` folder) and turn any refusal to write it into a StudyError."""
    try:
        _store.cases_dir(store).mkdir(parents=True, exist_ok=True)
        probe = _store.cases_dir(store) / f"{_store.TMP_PREFIX}probe-{uuid.uuid4().hex[:8]}"
        probe.touch()
        probe.unlink()
    except OSError as exc:
        raise StudyError(
            f"study store {str(store)!r} is not writable ({type(exc).__name__}: {exc}); give a store directory "
            "you can write (or fix its permissions); load_study() reads a finished store without writing it"
        ) from exc
    try:
        yield
    except PermissionError as exc:  # a file of the store refused after the probe (the lock, the manifest)
        raise StudyError(
            f"study store {str(store)!r} is not writable: {exc.filename or store!s} refused ({exc.strerror}); "
            "fix its permissions or give another store"
        ) from exc


def run_study(
    axes: Mapping[str, Sequence[Any] | Mapping[Any, Any]],
    case_fn: CaseFunction,
    store: str | Path,
    *,
    scheduler_address: str | None = None,
    n_workers: int | None = None,
    threads_per_worker: int = 1,
    progress: ProgressCallback | bool | str | None = None,
    resume: bool = True,
    timeout_s: float = 10,
    retry_failed: bool = False,
    output: str | Path | None = None,
    store_on_workers: bool | None = None,
    case_inputs: Callable[[dict[str, Any]], Mapping[str, CaseInput]] | None = None,
    on_changed_inputs: str = "error",
) -> xr.Dataset:
    """Run ``case_fn`` on every combination of the axes' values, resumably, and combine the results.

    Parameters
    ----------
    axes : mapping of str to sequence or mapping
        Axis name → its values, in order; the cases are the Cartesian product,
        in C order (the last axis varies fastest).  Values that are numbers,
        strings or times label themselves; objects are labelled by their
        ``name`` attribute (a :class:`~optroute.Ship` is); anything else is
        given as a mapping ``{label: value}``.  Labels must be distinct within
        an axis.  The case key is the tuple of axis indices, so resuming needs
        the same axes in the same order.
    case_fn : callable
        ``case_fn({axis name: value}) -> xarray.Dataset | Mapping[str, array]``.
        Must be picklable: a module-level function (with
        :func:`functools.partial` for fixed arguments).  A mapping's values
        become variables with dimensions ``<name>_dim_0, ...``.  The names
        ``status``, ``runtime_s`` and the axis names are reserved.  Each case
        runs on its own, so keep its result small (totals, a front, a plan's
        legs — not the weather).  It runs in a process set up for solves
        (:func:`optroute.studies.threads.solver_process`: Ipopt's BLAS on one
        thread), serial as on a cluster, so a case gives the same numbers in both.
    store : str or path
        Directory of the study store, created if needed.  It holds
        ``manifest.json``, ``cases/<i>-<j>-<k>.nc`` (one file per finished
        case) and, by default, the combined ``study.nc``.
    scheduler_address : str, optional
        ``None`` (default) starts a :class:`distributed.LocalCluster` of
        ``n_workers`` processes bound to 127.0.0.1 with no dashboard, for this
        call only.  ``"tcp://host:port"`` uses that existing scheduler (the
        case function's module must be importable on its workers; the store
        needs only be visible to this process, unless ``store_on_workers``).
        ``"synchronous"`` runs the cases in this process, one after another.
    n_workers : int, optional
        Workers of the local cluster; default one per core (``threads_per_worker``
        threads each), never more than the cases left.  ``0`` means
        ``scheduler_address="synchronous"``.  Not allowed with an address.
    threads_per_worker : int
        Threads per local worker process (default 1: the optimiser is
        CPU-bound and not thread-parallel).
    progress : callable, optional
        ``progress(done, total)``, called in this process once at the start
        (``done`` counting the cases already stored) and after each case is
        stored, failed cases included.  ``True`` (or ``"bar"``) draws a text bar with the rate
        and the time left on standard error (:class:`optroute.studies.progress.TextProgress`).
        ``None`` is silent.
    resume : bool
        ``True`` (default): keep the cases already in ``store`` and compute
        only the others; the axes must match the store's manifest.
        ``False``: delete the store's case files and start over.
    timeout_s : float
        Seconds allowed to connect to an existing scheduler, and for it to
        have a worker [s].
    retry_failed : bool
        Compute again the stored cases whose status is ``"failed: ..."``
        (default: keep them as failed).
    output : str or path, optional
        Where to write the combined dataset, atomically: NetCDF for ``.nc``
        (``.nc4``, ``.h5``), Zarr (format 2) for ``.zarr``.  Default
        ``<store>/study.nc``.
    store_on_workers : bool, optional
        Whether the workers write the case files themselves, as soon as each
        case is computed (a worker's death then loses only the case it was
        running), rather than this process as it collects the results.
        Default: True for the local cluster, False with ``scheduler_address``
        (set True when the workers share the store's filesystem at the same
        path).

    Returns
    -------
    xarray.Dataset
        The axes as dimension coordinates (labels as above); every variable
        of the case results with the axes prepended; ``status`` (``"ok"``,
        ``"missing"`` or ``"failed: <exception type>: <message>"``) and
        ``runtime_s`` (wall-clock seconds of each case) over the axes.
        Missing and failed cases hold NaN (integer and boolean variables are
        then promoted to float64; times hold NaT, text "").  A case dimension
        whose size varies between cases is padded likewise; its index
        coordinate is kept when it is the same in every case, and is
        otherwise given per case as ``case_<dim>``.

    Raises
    ------
    ConfigError
        Bad axes (empty, duplicate labels, unlabelled objects), an unpicklable
        ``case_fn`` for a cluster, or inconsistent options.
    SchedulerUnreachable
        ``scheduler_address`` refuses or does not answer within ``timeout_s``.
    StudyError
        The store belongs to a study with other axes, holds cases computed
        from other inputs (see ``case_inputs``), is not writable (the message
        names the path), is being written by another run, or the cluster was
        lost mid-way (the study then resumes when run again).

    Warns
    -----
    UserWarning
        A stored case file is corrupt or truncated: it is moved aside
        (``<name>.corrupt``) and computed again; or cases of changed inputs
        are computed again (``on_changed_inputs="recompute"``).

    Notes
    -----
    Resume semantics.  A case counts as done when its file exists in
    ``<store>/cases/``.  A file is moved into place only once complete (write
    to a temporary name, fsync, :func:`os.replace`) as soon as its case is
    computed: by the worker itself on the local cluster (see
    ``store_on_workers``), by this process otherwise.  Interrupting the study
    (Ctrl-C, killing this process or a worker, losing the cluster) therefore
    loses only the cases that were running, and the next run computes exactly
    the cases without a file; temporary files left by a killed write are
    deleted.  A worker that dies while running a case is replaced and the case
    re-run by Dask (a re-run whose file already exists returns at once); a
    case that kills its worker repeatedly is recorded as ``"failed:
    KilledWorker: ..."``, with the cases of its task not yet stored.  On a
    cluster the cases go in tasks of up to 16 contiguous cases
    (:func:`cases_per_task`: about eight tasks per worker), each case stored as
    soon as it is computed: a task per cheap case cost more in scheduling than
    the case.  An exception raised by ``case_fn`` is recorded as
    that case's status (the traceback is kept in the case file's
    ``optroute_study_traceback`` attribute) and not retried unless
    ``retry_failed=True``.  One run at a time may write a store (an advisory
    lock enforces it).
    """
    store = Path(store)
    if not callable(case_fn):
        raise ConfigError(f"case_fn={case_fn!r} is not callable; pass a function taking a dict of axis values")
    progress = _checked_run_options(progress, timeout_s, threads_per_worker, n_workers, scheduler_address)
    synchronous = scheduler_address == SYNCHRONOUS or n_workers == 0
    out_path = Path(output) if output is not None else store / _store.DEFAULT_OUTPUT
    _store.output_format(out_path)
    study_axes = make_axes(axes)
    if not synchronous:
        import_distributed()
        check_picklable(case_fn)
    shape = tuple(len(a.values) for a in study_axes)
    total = math.prod(shape)
    names = tuple(a.name for a in study_axes)
    reserved = tuple(_store.RESERVED_VARS) + names

    def params(index: tuple[int, ...]) -> dict[str, Any]:
        return {a.name: a.values[i] for a, i in zip(study_axes, index, strict=True)}

    if on_changed_inputs not in ("error", "recompute"):
        raise ConfigError(f"on_changed_inputs={on_changed_inputs!r} is not known; use 'error' or 'recompute'")
    if case_inputs is not None and not callable(case_inputs):
        raise ConfigError(f"case_inputs={case_inputs!r} is not callable; pass a function of the case's axis values")

    def inputs_of(index: tuple[int, ...]) -> str | None:
        return None if case_inputs is None else fingerprint.encode(case_inputs(params(index)))

    def label(index: tuple[int, ...]) -> str:
        return ", ".join(f"{a.name}={a.labels[i]}" for a, i in zip(study_axes, index, strict=True))

    with _writable_store(store), _store.locked(store):
        _store.remove_temporaries(store)
        manifest = _open_manifest(store, study_manifest(study_axes, case_fn), resume)
        expected = None if case_inputs is None else (lambda index: case_inputs(params(index)))
        checked = fingerprint.check_stored_cases(
            store, _store.list_cases(store, shape), expected, label, on_changed_inputs
        )
        existing = {i: path for i, (path, _) in checked.ok.items()}
        done = existing
        if retry_failed:
            done = {i: path for i, (path, status) in checked.ok.items() if status == "ok"}
        pending = [index for index in np.ndindex(*shape) if index not in done]
        n_done = total - len(pending)
        if progress is not None:
            progress(n_done, total)

        recorder = _Recorder(store, total, n_done, progress)
        on_outcome = recorder.record
        if pending and synchronous:
            for index in pending:
                on_outcome(_run_case(case_fn, index, params(index), reserved, inputs=inputs_of(index)))
        elif pending:
            import dask.system

            workers = n_workers if n_workers is not None else max(1, dask.system.CPU_COUNT // threads_per_worker)
            with dask_client(scheduler_address, min(workers, len(pending)), threads_per_worker, timeout_s) as client:
                on_workers = scheduler_address is None if store_on_workers is None else store_on_workers
                store_arg = str(store.resolve()) if on_workers else None
                retried = {index for index in pending if index in existing}
                _run_distributed(client, case_fn, pending, params, reserved, on_outcome, store_arg, retried, inputs_of)

        # the cases kept from the store as the check loaded them, the new ones as the workers decoded them
        kept = {i: case for i, case in checked.decoded.items() if i in done}
        ds = _store.combine(store, manifest, {**kept, **recorder.fresh})
        try:
            _store.write_dataset(ds, out_path)
        except OSError as exc:
            raise StudyError(
                f"all {total} cases are stored in {str(store)!r}, but the combined dataset could not be written "
                f"to {str(out_path)!r} ({type(exc).__name__}: {exc}); fix that and call "
                "load_study(store, output=...) or run the study again (nothing is recomputed)"
            ) from exc
    return ds


class _Recorder:
    """Stores each case's outcome as it arrives (unless a worker has stored it), keeps the cases the workers
    decoded (``fresh``), and reports progress; a store that cannot be written is a :class:`StudyError` that says
    how many cases are safe and how to resume."""

    def __init__(self, store: Path, total: int, n_done: int, progress: ProgressCallback | None) -> None:
        self.store, self.total, self.n_done, self.progress = store, total, n_done, progress
        self.fresh: dict[tuple[int, ...], xr.Dataset] = {}  # cases decoded by the workers that stored them

    def record(self, outcome: _Outcome) -> None:
        if outcome.case is not None:
            self.fresh[outcome.index] = outcome.case
        try:
            if outcome.payload is not None:  # else a worker has stored it
                _store.write_case(self.store, outcome.index, outcome.payload)
        except OSError as exc:
            raise StudyError(
                f"could not store case {outcome.index} in {str(_store.cases_dir(self.store))!r} "
                f"({type(exc).__name__}: {exc}); free disk space or fix permissions, then run the study "
                f"again to resume ({self.n_done} of {self.total} cases are stored)"
            ) from exc
        self.n_done += 1
        if self.progress is not None:
            self.progress(self.n_done, self.total)


def _checked_run_options(
    progress: Any, timeout_s: Any, threads_per_worker: Any, n_workers: Any, scheduler_address: Any
) -> ProgressCallback | None:
    """:func:`run_study`'s execution options checked (ConfigError naming a bad one); the progress callback
    (``True`` or ``"bar"``: a text bar on standard error)."""
    if progress is True or progress == "bar":
        progress = TextProgress("study")
    if progress is not None and not callable(progress):
        raise ConfigError(
            f"progress={progress!r} is not callable; pass a function (done, total) -> None, True (a text bar on "
            "standard error) or None"
        )
    check_cluster_options(n_workers, scheduler_address, timeout_s, threads_per_worker)
    return progress


def _open_manifest(store: Path, manifest: dict[str, Any], resume: bool) -> dict[str, Any]:
    """The study's manifest in ``store``: the stored one when resuming a study of the same axes (StudyError where
    its axes differ); else ``manifest``, written after the stored cases are deleted."""
    stored = _store.read_manifest(store)
    if stored is not None and resume:
        diff = axes_difference(stored["axes"], manifest["axes"])
        if diff is not None:
            raise StudyError(
                f"study store {str(store)!r} holds a study with other axes: {diff}; use another store, or pass "
                "resume=False to delete its cases and start over"
            )
        return stored
    if stored is not None:
        for path in _store.list_cases(store, [len(a["labels"]) for a in stored["axes"]]).values():
            path.unlink()
    try:
        _store.write_json(store / _store.MANIFEST, manifest)
    except OSError as exc:
        raise StudyError(
            f"could not write the manifest of study store {str(store)!r} ({type(exc).__name__}: {exc}); "
            "free disk space or fix permissions, or choose another store"
        ) from exc
    return manifest


def load_study(store: str | Path, *, output: str | Path | None = None) -> xr.Dataset:
    """Combine the cases stored so far in a study store into one dataset.

    Works on a finished, a running or an interrupted study (cases not yet
    stored have status ``"missing"``); it reads the store only, unless
    ``output`` asks for the combined dataset to be written.

    Parameters
    ----------
    store : str or path
        The study store given to :func:`run_study`.
    output : str or path, optional
        Also write the combined dataset there, atomically (NetCDF or Zarr by
        suffix, as in :func:`run_study`).

    Returns
    -------
    xarray.Dataset
        As returned by :func:`run_study`.

    Raises
    ------
    StudyError
        ``store`` is not a study store, or a case file is unreadable.
    """
    store = Path(store)
    manifest = _store.read_manifest(store)
    if manifest is None:
        raise StudyError(
            f"no study in {str(store)!r}: {_store.MANIFEST} is missing; give the store passed to run_study, "
            "or run the study first"
        )
    ds = _store.combine(store, manifest)
    if output is not None:
        _store.write_dataset(ds, Path(output))
    return ds
