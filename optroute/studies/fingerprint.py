"""Fingerprints of a study case's inputs: content digests that change when any input changes.

A study store keys its cases on their axis labels (``ship``, ``scenario``,
``eta_h``), but a label says nothing about what it stood for when the case
ran: the same store reused with another corridor, or a forecast file
overwritten in place, would otherwise hand back results of other inputs.
Each case therefore records, per input, a :class:`CaseInput` — a digest of
the input's *content* and a short human description — and
:func:`optroute.studies.study.run_study` compares them with the inputs of the
call before reusing a stored case.

Digests are SHA-256 (FIPS 180-4) over a canonical byte stream, truncated to
20 hex digits (80 bits: collisions are out of reach for any study's number
of inputs):

* numbers by their exact ``repr`` (``float`` round-trips), text as UTF-8,
  each tagged with its type so that ``1`` and ``"1"`` differ;
* NumPy arrays by dtype, shape and bytes (C order); datetimes as integer
  nanoseconds;
* mappings in sorted key order; sequences in order;
* dataclasses (a :class:`~optroute.Ship`, a ``Corridor``, a performance
  model, band rules) by their type name and compared fields, so a field that
  does not take part in equality (a description) does not count;
* an :class:`xarray.Dataset` by every variable's name, dimensions, dtype and
  values (coordinates included) and its attributes (``time_policy`` and
  ``geography`` change results);
* a weather *file* (or Zarr directory) by its bytes, so overwriting it in
  place changes the digest even when its name, size and shape do not.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import hashlib
import json
import os
import pickle
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from optroute import _store
from optroute.errors import ConfigError

__all__ = ["CaseInput", "dataset_digest", "decode", "describe_changes", "digest", "encode", "file_digest"]

DIGEST_HEX = 20
_CHUNK = 1 << 20


@dataclass(frozen=True)
class CaseInput:
    """One input of a study case as recorded in its case file.

    Parameters
    ----------
    digest : str
        Hex digest of the input's content (see the module docstring).
    about : str
        A short description for messages ("corridor of 1054.2 nm from (0, -30) to (0, -12)").
    """

    digest: str
    about: str


def _hasher() -> Any:
    return hashlib.sha256()


def _feed(h: Any, obj: Any) -> None:  # noqa: PLR0911, PLR0912 - one branch per kind of value
    """Feed the canonical byte form of ``obj`` to the hash ``h``."""
    if obj is None or isinstance(obj, bool | int | float | complex | str | bytes):
        h.update(f"<{type(obj).__name__}:{obj!r}>".encode())
        return
    if isinstance(obj, np.generic):
        _feed(h, np.asarray(obj))
        return
    if isinstance(obj, _dt.datetime | _dt.date | _dt.timedelta):
        h.update(f"<{type(obj).__name__}:{obj.isoformat() if hasattr(obj, 'isoformat') else obj}>".encode())
        return
    if isinstance(obj, os.PathLike):
        h.update(f"<path:{os.fspath(obj)}>".encode())
        return
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind == "O":
            h.update(f"<object-array{obj.shape}>".encode())
            for item in obj.ravel():
                _feed(h, item)
            return
        arr = obj.view("i8") if obj.dtype.kind in "mM" else obj
        h.update(f"<array:{obj.dtype.str}:{obj.shape}>".encode())
        h.update(np.ascontiguousarray(arr).tobytes())
        return
    if isinstance(obj, xr.Dataset | xr.DataArray):
        h.update(f"<dataset:{dataset_digest(obj)}>".encode())
        return
    if isinstance(obj, Mapping):
        h.update(f"<mapping:{len(obj)}>".encode())
        for key in sorted(obj, key=repr):
            _feed(h, key)
            _feed(h, obj[key])
        return
    if isinstance(obj, list | tuple):
        h.update(f"<{type(obj).__name__}:{len(obj)}>".encode())
        for item in obj:
            _feed(h, item)
        return
    if isinstance(obj, set | frozenset):
        _feed(h, sorted(obj, key=repr))
        return
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        h.update(f"<{type(obj).__module__}.{type(obj).__qualname__}>".encode())
        for f in dataclasses.fields(obj):
            if f.compare:
                _feed(h, f.name)
                _feed(h, getattr(obj, f.name))
        return
    try:  # anything else (a callable, an object of the user's): its pickle, which names it and holds its state
        h.update(b"<pickle>" + pickle.dumps(obj, protocol=4))
    except (pickle.PicklingError, TypeError, AttributeError) as exc:
        raise ConfigError(
            f"cannot fingerprint a {type(obj).__name__} ({obj!r:.80}) to key the study's cases on it "
            f"({type(exc).__name__}: {exc}); pass options as numbers, strings, arrays or dataclasses"
        ) from exc


def digest(obj: Any) -> str:
    """Content digest of ``obj`` (see the module docstring for the canonical form).

    Raises
    ------
    ConfigError
        ``obj`` holds a value that has no canonical form and cannot be pickled.
    """
    h = _hasher()
    _feed(h, obj)
    return h.hexdigest()[:DIGEST_HEX]


def dataset_digest(ds: xr.Dataset | xr.DataArray) -> str:
    """Digest of a dataset's variables (values, dims, dtype; coordinates included) and attributes.

    A lazily loaded (Dask) dataset is read in full: the digest is of the data, not of how it is stored.
    """
    if isinstance(ds, xr.DataArray):
        ds = ds.to_dataset(name=str(ds.name or "__array__"))
    h = _hasher()
    for name in sorted(ds.variables, key=str):
        var = ds.variables[name]
        h.update(f"<variable:{name}:{var.dims}>".encode())
        _feed(h, np.asarray(var.values))
        _feed(h, dict(var.attrs))
    _feed(h, {str(k): v for k, v in ds.attrs.items()})
    return h.hexdigest()[:DIGEST_HEX]


def file_digest(path: str | os.PathLike[str]) -> str:
    """Digest of a file's bytes, or of every file of a directory (a Zarr store) by relative path and bytes.

    Raises
    ------
    ConfigError
        ``path`` cannot be read; the message names it.
    """
    root = Path(path)
    h = _hasher()
    try:
        files = [root] if root.is_file() else sorted(p for p in root.rglob("*") if p.is_file())
        for p in files:
            h.update(f"<file:{p.relative_to(root).as_posix() if p != root else ''}>".encode())
            with open(p, "rb") as fh:
                while chunk := fh.read(_CHUNK):
                    h.update(chunk)
    except OSError as exc:
        raise ConfigError(
            f"cannot read weather file {str(root)!r} to fingerprint it ({type(exc).__name__}: {exc}); "
            "check that it exists and is readable"
        ) from exc
    return h.hexdigest()[:DIGEST_HEX]


def encode(inputs: Mapping[str, CaseInput]) -> str:
    """JSON text of a case's inputs, as stored in its case file."""
    return json.dumps({k: [v.digest, v.about] for k, v in sorted(inputs.items())}, ensure_ascii=False)


def decode(text: str) -> dict[str, CaseInput]:
    """Inverse of :func:`encode`.

    Raises
    ------
    ValueError
        ``text`` is not the JSON :func:`encode` writes.
    """
    raw = json.loads(text)
    if not isinstance(raw, dict) or not all(isinstance(v, list) and len(v) == 2 for v in raw.values()):
        raise ValueError(f"not a case fingerprint: {text[:80]!r}")
    return {str(k): CaseInput(str(v[0]), str(v[1])) for k, v in raw.items()}


def describe_changes(stored: Mapping[str, CaseInput], now: Mapping[str, CaseInput]) -> list[str]:
    """What differs between a stored case's inputs and this call's, one phrase per input; [] if nothing."""
    out = []
    for name in sorted(set(stored) | set(now)):
        old, new = stored.get(name), now.get(name)
        if old is None:
            out.append(f"{name}: not recorded in the store, now {new.about}")  # type: ignore[union-attr]
        elif new is None:
            out.append(f"{name}: {old.about} in the store, not given now")
        elif old.digest != new.digest:
            if old.about != new.about:
                out.append(f"{name}: {old.about} in the store, now {new.about}")
            else:
                out.append(
                    f"{name}: {new.about}, with other content (digest {old.digest} in the store, now {new.digest})"
                )
    return out


# --------------------------------------------------------------------------- the stored cases against the call


@dataclass(frozen=True)
class StoredCases:
    """The case files of a store that may be reused, after :func:`check_stored_cases`.

    Parameters
    ----------
    ok : dict
        Axis indices → (path, status) of every readable case computed from this call's inputs.
    recomputed : list
        Axis indices of the cases removed to be computed again (corrupt, or of changed inputs).
    decoded : dict
        Axis indices → the case of ``ok`` as :func:`optroute._store.read_case` loaded it for the check, for the
        combination (:func:`optroute._store.combine`'s ``decoded``) instead of reading the file a second time.
    """

    ok: dict[tuple[int, ...], tuple[Path, str]]
    recomputed: list[tuple[int, ...]]
    decoded: dict[tuple[int, ...], xr.Dataset] = field(default_factory=dict, repr=False)


def check_stored_cases(
    store: Path,
    existing: Mapping[tuple[int, ...], Path],
    expected: Any,
    label: Any,
    on_changed_inputs: str,
) -> StoredCases:
    """Validate every stored case file and compare its recorded inputs with this call's.

    Parameters
    ----------
    store : Path
        The study store.
    existing : mapping
        Axis indices → case file (:func:`optroute._store.list_cases`).
    expected : callable or None
        Axis indices → the inputs of that case in this call (``{name: CaseInput}``); None
        compares nothing.
    label : callable
        Axis indices → a readable name of the case for messages ("ship=a, eta_h=30").
    on_changed_inputs : {"error", "recompute"}
        What a case computed from other inputs leads to.

    Returns
    -------
    StoredCases

    Raises
    ------
    StudyError
        Cases were computed from other inputs and ``on_changed_inputs="error"``: the message names
        the cases and, for the first, every input that changed (old and new); or a corrupt case
        cannot be moved aside.

    Warns
    -----
    UserWarning
        A corrupt or truncated case file was moved aside (``<name>.corrupt``) to be recomputed;
        cases of changed inputs are being recomputed.
    """
    ok: dict[tuple[int, ...], tuple[Path, str]] = {}
    decoded: dict[tuple[int, ...], xr.Dataset] = {}
    changed: list[tuple[tuple[int, ...], Path, list[str]]] = []
    recomputed: list[tuple[int, ...]] = []
    for index, path in sorted(existing.items()):
        try:
            case = _store.read_case(path)
        except _store.StudyError as exc:
            aside = _store.quarantine(path)
            warnings.warn(
                f"case {label(index)} of study store {str(store)!r} is unreadable ({exc}); moved it to "
                f"{aside.name!r} and computing that case again",
                stacklevel=3,
            )
            recomputed.append(index)
            continue
        attrs = case.attrs
        if expected is not None:
            now = expected(index)
            try:
                stored = decode(str(attrs[_store.INPUTS_ATTR])) if _store.INPUTS_ATTR in attrs else {}
            except ValueError:
                stored = {}
            diffs = describe_changes(stored, now)
            if diffs:
                changed.append((index, path, diffs))
                continue
        ok[index] = (path, str(attrs[_store.STATUS_ATTR]))
        decoded[index] = case
    if changed and on_changed_inputs == "error":
        index, path, diffs = changed[0]
        more = f" (and {len(changed) - 1} other case(s))" if len(changed) > 1 else ""
        raise _store.StudyError(
            f"study store {str(store)!r} holds case {label(index)}{more} computed from other inputs than this "
            f"call's — {'; '.join(diffs)}; its results would be stale: use another store, or pass "
            "on_changed_inputs='recompute' (optroute study --recompute-changed) to compute the changed cases "
            "again in this store"
        )
    for index, path, _diffs in changed:
        path.unlink()
        recomputed.append(index)
    if changed:
        warnings.warn(
            f"study store {str(store)!r}: computing {len(changed)} case(s) again because their inputs changed "
            f"(first: {label(changed[0][0])}: {'; '.join(changed[0][2])})",
            stacklevel=3,
        )
    return StoredCases(ok, sorted(recomputed), decoded)
