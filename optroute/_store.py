"""On-disk layout of a study store, atomic writes and the combination of cases.

A study store is a directory::

    <store>/
        manifest.json       the study's axes (names and labels), shape and format version
        .lock               advisory lock held by the one run writing the store
        cases/
            0-0-0.nc        one small NetCDF file per finished case, named by its axis indices
            0-0-1.nc        (status "ok", or "failed: ..." with the traceback in the attributes)
            .tmp-...        a write in progress; never read, removed by the next run
        study.nc            the combined dataset (default name; ``.zarr`` for Zarr)

Every file is written under a temporary name in its final directory, flushed
to disk and then moved into place with :func:`os.replace`, so a reader (or a
resumed run) sees either the whole file or none of it.  The set of case files
*is* the study's progress: there is no second record that could disagree.

This module knows nothing about Dask; :mod:`optroute.studies.study` drives it.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import uuid
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from optroute.errors import OptrouteError

FORMAT = "optroute.studies.study/1"
MANIFEST = "manifest.json"
CASES = "cases"
LOCK = ".lock"
DEFAULT_OUTPUT = "study.nc"
TMP_PREFIX = ".tmp-"

#: Attributes of a case file (and of nothing else).
KEY_ATTR = "optroute_study_key"
STATUS_ATTR = "optroute_study_status"
RUNTIME_ATTR = "optroute_study_runtime_s"
TRACEBACK_ATTR = "optroute_study_traceback"
#: JSON record of what the case was computed from (see :mod:`optroute.studies.fingerprint`).
INPUTS_ATTR = "optroute_study_inputs"
#: Suffix a corrupt case file is renamed with (kept for inspection, never read as a case).
CORRUPT_SUFFIX = ".corrupt"

#: Variables the study adds to the combined dataset; a case may not return them.
STATUS_VAR = "status"
RUNTIME_VAR = "runtime_s"
RESERVED_VARS = (STATUS_VAR, RUNTIME_VAR)

NETCDF_SUFFIXES = (".nc", ".nc4", ".netcdf", ".h5", ".hdf5")
ZARR_SUFFIXES = (".zarr",)

_CASE_RE = re.compile(r"^(\d+(?:-\d+)*)\.nc$")
_CHUNK_BYTES = 1 << 20


class StudyError(OptrouteError):
    """A study store, its cluster or its cases cannot be used as asked.

    Re-exported as :class:`optroute.studies.study.StudyError`.
    """


# --------------------------------------------------------------------------- paths and names


def case_name(index: Sequence[int]) -> str:
    """File name of the case at axis indices ``index``, e.g. ``(2, 0, 13)`` → ``"2-0-13.nc"``."""
    return "-".join(str(int(i)) for i in index) + ".nc"


def parse_case_name(name: str) -> tuple[int, ...] | None:
    """Axis indices of a case file name, or None for anything else (temporary files included)."""
    match = _CASE_RE.match(name)
    if match is None:
        return None
    return tuple(int(part) for part in match.group(1).split("-"))


def cases_dir(store: Path) -> Path:
    """The directory holding the case files of ``store``."""
    return store / CASES


def list_cases(store: Path, shape: Sequence[int]) -> dict[tuple[int, ...], Path]:
    """The finished cases of ``store``: axis indices → file.

    Raises
    ------
    StudyError
        A case file's name does not fit a study of this ``shape`` (left from another study).
    """
    folder = cases_dir(store)
    found: dict[tuple[int, ...], Path] = {}
    if not folder.is_dir():
        return found
    for entry in os.scandir(folder):
        index = parse_case_name(entry.name)
        if index is None:
            continue
        if len(index) != len(shape) or any(i >= n for i, n in zip(index, shape, strict=True)):
            raise StudyError(
                f"case file {entry.path!r} does not belong to a study of shape {tuple(shape)} "
                f"(axis indices {index}); it was left by another study: remove it, or use a new store"
            )
        found[index] = Path(entry.path)
    return found


def remove_temporaries(store: Path) -> int:
    """Delete the temporary files an interrupted write left in ``store``; return how many."""
    removed = 0
    for folder in (store, cases_dir(store)):
        if not folder.is_dir():
            continue
        for entry in os.scandir(folder):
            if entry.name.startswith(TMP_PREFIX):
                if entry.is_dir(follow_symlinks=False):
                    shutil.rmtree(entry.path, ignore_errors=True)
                else:
                    with contextlib.suppress(FileNotFoundError):
                        os.unlink(entry.path)
                removed += 1
    return removed


# --------------------------------------------------------------------------- atomic writes


def _tmp_path(path: Path) -> Path:
    return path.with_name(f"{TMP_PREFIX}{path.name}-{os.getpid()}-{uuid.uuid4().hex[:8]}")


def _write_all(fh: Any, data: bytes | memoryview) -> None:
    """Write ``data`` to the open binary file ``fh`` in chunks (the seam tests interrupt)."""
    view = memoryview(data)
    for start in range(0, len(view), _CHUNK_BYTES):
        fh.write(view[start : start + _CHUNK_BYTES])


def _fsync_dir(folder: Path) -> None:
    with contextlib.suppress(OSError):  # not every platform/filesystem can open a directory
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def atomic_write_bytes(path: Path, data: bytes | memoryview) -> None:
    """Write ``data`` to ``path`` so that ``path`` holds either all of it or nothing new.

    The bytes go to a temporary file in the same directory, are flushed and
    fsync'ed, then :func:`os.replace` moves the file into place.  If anything
    interrupts the write (an exception, ``KeyboardInterrupt``), the temporary
    file is removed; if the process dies, the temporary file stays under its
    ``.tmp-`` name, which no reader takes for a result and the next run deletes.
    """
    tmp = _tmp_path(path)
    try:
        with open(tmp, "wb") as fh:
            _write_all(fh, data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise


def write_case(store: Path, index: Sequence[int], payload: bytes | memoryview) -> Path:
    """Store one case's encoded NetCDF ``payload`` atomically; return its path."""
    path = cases_dir(store) / case_name(index)
    atomic_write_bytes(path, payload)
    return path


def write_json(path: Path, obj: Mapping[str, Any]) -> None:
    """Write ``obj`` as indented JSON, atomically."""
    atomic_write_bytes(path, (json.dumps(obj, indent=1, allow_nan=False) + "\n").encode())
    _fsync_dir(path.parent)


def output_format(path: Path) -> str:
    """``"netcdf"`` or ``"zarr"`` from the suffix of ``path``.

    Raises
    ------
    StudyError
        The suffix is neither a NetCDF nor a Zarr one.
    """
    suffix = path.suffix.lower()
    if suffix in NETCDF_SUFFIXES:
        return "netcdf"
    if suffix in ZARR_SUFFIXES:
        return "zarr"
    raise StudyError(
        f"output={str(path)!r} has suffix {suffix!r}, which names no known format; "
        f"end it in one of {NETCDF_SUFFIXES} for NetCDF or '.zarr' for Zarr"
    )


def write_dataset(ds: xr.Dataset, path: Path) -> None:
    """Write the combined study ``ds`` to ``path`` atomically, as NetCDF or Zarr by suffix.

    NetCDF (HDF5 via h5netcdf) goes to a temporary file that replaces ``path``.
    A Zarr store is a directory, which :func:`os.replace` cannot swap over a
    non-empty one: the new store is written under a temporary name, the old one
    renamed aside, the new one renamed into place and the old one deleted, so
    ``path`` is at every moment either absent or complete.  Zarr is written in
    format 2 (its string encoding is stable across Zarr libraries).
    """
    fmt = output_format(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _tmp_path(path)
    try:
        if fmt == "netcdf":
            ds.to_netcdf(tmp, engine="h5netcdf")
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
            os.replace(tmp, path)
        else:
            ds.to_zarr(tmp, mode="w", zarr_format=2, consolidated=True)
            old = None
            if path.exists():
                old = _tmp_path(path)
                os.replace(path, old)
            os.replace(tmp, path)
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
        _fsync_dir(path.parent)
    except BaseException:
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
        raise


# --------------------------------------------------------------------------- lock


@contextlib.contextmanager
def locked(store: Path) -> Iterator[None]:
    """Hold the store's advisory lock (POSIX ``flock``) for the duration of a run.

    The operating system releases it when the process dies, so a killed run
    never leaves a stale lock.  On platforms without :mod:`fcntl` no lock is
    taken.

    Raises
    ------
    StudyError
        Another process holds the lock.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    path = store / LOCK
    with open(path, "a+") as fh:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.seek(0)
            holder = fh.read().strip() or "unknown"
            raise StudyError(
                f"study store {str(store)!r} is being written by another run (pid {holder}); "
                "wait for it to finish or stop it, or use another store"
            ) from None
        fh.seek(0)
        fh.truncate()
        fh.write(str(os.getpid()))
        fh.flush()
        try:
            yield
        finally:
            fh.seek(0)
            fh.truncate()
            fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


# --------------------------------------------------------------------------- manifest


def encode_labels(labels: np.ndarray) -> dict[str, Any]:
    """JSON form of an axis's labels (exact: datetimes as integer nanoseconds, floats by repr)."""
    if labels.dtype.kind in "mM":
        return {"dtype": str(labels.dtype), "labels": labels.view("i8").tolist()}
    if labels.dtype.kind == "U":
        return {"dtype": "str", "labels": labels.tolist()}
    return {"dtype": str(labels.dtype), "labels": labels.tolist()}


def decode_labels(entry: Mapping[str, Any]) -> np.ndarray:
    """Inverse of :func:`encode_labels`."""
    dtype = entry["dtype"]
    if dtype == "str":
        return np.array(entry["labels"], dtype=str)
    if dtype.startswith(("datetime64", "timedelta64")):
        return np.array(entry["labels"], dtype="i8").view(dtype)
    return np.array(entry["labels"], dtype=dtype)


def read_manifest(store: Path) -> dict[str, Any] | None:
    """The store's manifest, or None when the store has none yet.

    Raises
    ------
    StudyError
        The manifest is unreadable or of another format.
    """
    path = store / MANIFEST
    try:
        text = path.read_text()
    except FileNotFoundError:
        return None
    try:
        manifest = json.loads(text)
    except json.JSONDecodeError as exc:
        raise StudyError(
            f"study manifest {str(path)!r} is not valid JSON ({exc}); remove the store or restore the file"
        ) from exc
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        found = manifest.get("format") if isinstance(manifest, dict) else type(manifest).__name__
        raise StudyError(
            f"{str(path)!r} has format {found!r}, not {FORMAT!r}: this is not an optroute study store "
            "(or one from another version); use a new store"
        )
    return manifest


# --------------------------------------------------------------------------- combination


def read_case(path: Path) -> xr.Dataset:
    """Load one case file fully into memory.

    Raises
    ------
    StudyError
        The file cannot be read as a case (it should not happen with atomic
        writes; the message says how to have the case computed again).
    """
    try:
        ds = xr.load_dataset(path, engine="h5netcdf")
    except (OSError, ValueError, KeyError, RuntimeError, TypeError) as exc:
        raise StudyError(
            f"case file {str(path)!r} cannot be read ({exc}); delete it and run the study again to recompute that case"
        ) from exc
    if STATUS_ATTR not in ds.attrs:
        raise StudyError(
            f"case file {str(path)!r} has no {STATUS_ATTR!r} attribute, so it was not written by a study; "
            "delete it and run the study again"
        )
    return ds


def quarantine(path: Path) -> Path:
    """Move an unreadable case file aside (``<name>.corrupt``, replacing an older one) and return its new path.

    Raises
    ------
    StudyError
        The file cannot be moved (the store is not writable); the message names it.
    """
    aside = path.with_name(path.name + CORRUPT_SUFFIX)
    try:
        os.replace(path, aside)
    except OSError as exc:
        raise StudyError(
            f"case file {str(path)!r} is unreadable and cannot be moved aside to be recomputed "
            f"({type(exc).__name__}: {exc}); delete it, or make the store writable"
        ) from exc
    return aside


def _fill_value(dtype: np.dtype) -> tuple[np.dtype, Any]:
    """The dtype able to hold a hole, and the hole: NaN, NaT, or "" for text."""
    if dtype.kind in "fc":
        return dtype, np.nan
    if dtype.kind in "mM":
        return dtype, np.array("NaT", dtype=dtype)
    if dtype.kind in "biu":
        return np.dtype("float64"), np.nan
    return np.dtype(object), ""


def _combine_variable(
    name: str,
    parts: dict[tuple[int, ...], xr.Variable],
    axis_dims: tuple[str, ...],
    axis_shape: tuple[int, ...],
    dim_sizes: Mapping[str, int],
) -> xr.Variable:
    first = next(iter(parts.values()))
    own_dims = first.dims
    for index, var in parts.items():
        if var.dims != own_dims:
            raise StudyError(
                f"variable {name!r} has dimensions {var.dims} in case {index} but {own_dims} in another case; "
                "make case_fn return the same dimensions for a variable in every case"
            )
    own_shape = tuple(dim_sizes[d] for d in own_dims)
    dtype = (
        np.result_type(*(var.dtype for var in parts.values())) if first.dtype.kind not in "OSU" else np.dtype(object)
    )
    complete = len(parts) == int(np.prod(axis_shape)) and all(var.shape == own_shape for var in parts.values())
    if complete:
        data = np.empty(axis_shape + own_shape, dtype=dtype)
    else:
        dtype, hole = _fill_value(dtype)
        data = np.full(axis_shape + own_shape, hole, dtype=dtype)
    for index, var in parts.items():
        values = var.values
        if dtype.kind == "O":
            values = values.astype(str).astype(object)
            if values.ndim == 0:  # a 0-d array put into one cell of an object array would be stored as the array
                values = values.item()
        data[index + tuple(slice(0, n) for n in var.shape)] = values
    return xr.Variable(axis_dims + own_dims, data, attrs=dict(first.attrs))


def combine(
    store: Path, manifest: Mapping[str, Any], decoded: Mapping[tuple[int, ...], xr.Dataset] | None = None
) -> xr.Dataset:
    """Combine the case files of ``store`` into one dataset with the study's axes as dimensions.

    ``decoded``: cases already decoded from the bytes of their files (as :func:`read_case` would load them, by
    the worker that wrote them), used instead of reading those files again.

    Each case's variables gain the axes as leading dimensions.  Cases that are
    missing or failed hold NaN (NaT for times, "" for text; integer and boolean
    variables become float64 so they can), and ``status`` says ``"ok"``,
    ``"missing"`` or ``"failed: <exception>"``.  A case dimension whose size
    differs between cases is padded to the largest size the same way.  A
    case's own index coordinate is kept when every case has the same one;
    otherwise its values become the coordinate ``case_<dim>`` over the axes
    and the case dimension.

    Raises
    ------
    StudyError
        A case file is unreadable, or variables disagree in their dimensions.
    """
    names = [axis["name"] for axis in manifest["axes"]]
    labels = [decode_labels(axis) for axis in manifest["axes"]]
    shape = tuple(len(lab) for lab in labels)
    status = np.full(shape, "missing", dtype=object)
    runtime = np.full(shape, np.nan)
    cases: dict[tuple[int, ...], xr.Dataset] = {}
    decoded = decoded or {}
    for index, path in sorted(list_cases(store, shape).items()):
        ds = decoded[index] if index in decoded else read_case(path)
        status[index] = str(ds.attrs[STATUS_ATTR])
        runtime[index] = float(ds.attrs.get(RUNTIME_ATTR, np.nan))
        if status[index] == "ok":
            cases[index] = ds

    # Case dimensions: their largest size, and their index coordinate when all cases agree on it.
    dim_sizes: dict[str, int] = {}
    for ds in cases.values():
        for dim, size in ds.sizes.items():
            dim_sizes[dim] = max(dim_sizes.get(dim, 0), size)
    coords: dict[str, Any] = {name: (name, lab) for name, lab in zip(names, labels, strict=True)}
    per_case: dict[str, dict[tuple[int, ...], xr.Variable]] = {}
    coord_names: set[str] = set()
    for dim in dim_sizes:
        indexes = [ds[dim].variable for ds in cases.values() if dim in ds.coords]
        if not indexes:
            continue
        if len(indexes) == len(cases) and all(ix.equals(indexes[0]) for ix in indexes[1:]):
            coords[dim] = indexes[0].copy()
        else:
            per_case[f"case_{dim}"] = {i: ds[dim].variable for i, ds in cases.items() if dim in ds.coords}
            coord_names.add(f"case_{dim}")
    for index, ds in cases.items():
        for name, var in ds.variables.items():
            if name in dim_sizes:
                continue
            per_case.setdefault(str(name), {})[index] = var
            if name in ds.coords:
                coord_names.add(str(name))

    data_vars: dict[str, xr.Variable] = {}
    axis_dims = tuple(names)
    for name, parts in per_case.items():
        var = _combine_variable(name, parts, axis_dims, shape, dim_sizes)
        if name in coord_names:
            coords[name] = var
        else:
            data_vars[name] = var
    data_vars[STATUS_VAR] = xr.Variable(
        axis_dims,
        status,
        attrs={"long_name": "outcome of the case", "description": 'one of "ok", "missing", "failed: <exception>"'},
    )
    data_vars[RUNTIME_VAR] = xr.Variable(
        axis_dims, runtime, attrs={"long_name": "wall-clock time of case_fn on its worker", "units": "s"}
    )
    attrs: dict[str, Any] = {}
    for ds in cases.values():
        attrs = {k: v for k, v in ds.attrs.items() if not str(k).startswith("optroute_study_")}
        break
    flat = status.ravel()
    attrs.update(
        {
            "optroute_study_format": FORMAT,
            "optroute_study_axes": " ".join(names),
            "optroute_study_case_fn": str(manifest.get("case_fn", "")),
            "optroute_study_n_cases": int(flat.size),
            "optroute_study_n_ok": int(sum(s == "ok" for s in flat)),
            "optroute_study_n_failed": int(sum(str(s).startswith("failed") for s in flat)),
            "optroute_study_n_missing": int(sum(s == "missing" for s in flat)),
        }
    )
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)
