"""A study's axes: the values each axis sweeps, their labels, and the manifest a store records.

:func:`make_axes` checks ``run_study``'s ``axes`` (a mapping of axis name → values or
``{label: value}``) and gives each axis the labels the combined dataset uses as coordinates and the
store's manifest records (:func:`study_manifest`); :func:`axes_difference` names the first axis where a
store's manifest and a new call disagree, so a resumed study refuses other axes instead of mixing
cases.  Used by :func:`optroute.studies.study.run_study`.
"""

from __future__ import annotations

import datetime as _dt
import functools
import math
import numbers
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from optroute import _store
from optroute.errors import ConfigError

__all__ = ["Axis", "axes_difference", "axis_labels", "make_axes", "object_label", "study_manifest"]


@dataclass(frozen=True)
class Axis:
    name: str
    labels: np.ndarray  # what the combined dataset uses as coordinate, and the manifest records
    values: tuple[Any, ...]  # what case_fn receives


_PRIMITIVE = (numbers.Number, np.number, np.bool_, np.datetime64, np.timedelta64, _dt.datetime, _dt.timedelta)
_LABEL_TYPES = (str, *_PRIMITIVE)


def object_label(axis: str, value: Any) -> str:
    if isinstance(value, _LABEL_TYPES):
        return str(value)
    name = getattr(value, "name", None)
    if isinstance(name, str) and name:
        return name
    if isinstance(value, tuple) and all(isinstance(v, _LABEL_TYPES) for v in value):
        return str(value)
    raise ConfigError(
        f"axis {axis!r} holds a value of type {type(value).__name__} with no `name` to label it by; "
        f"pass the axis as a mapping {{label: value}} (e.g. {{'storm_a': ds_a, 'storm_b': ds_b}}) "
        "so that every case has a stable label"
    )


def axis_labels(axis: str, items: Sequence[Any]) -> np.ndarray:
    if all(isinstance(v, str) for v in items):
        labels = np.array(items, dtype=str)
    elif all(isinstance(v, _PRIMITIVE) and not isinstance(v, complex | np.complexfloating) for v in items):
        index = pd.Index(list(items))
        if isinstance(index.dtype, pd.DatetimeTZDtype):
            index = index.tz_convert("UTC").tz_localize(None)
        kind = index.dtype.kind
        if kind == "M":
            labels = index.to_numpy().astype("datetime64[ns]")
        elif kind == "m":
            labels = index.to_numpy().astype("timedelta64[ns]")
        elif kind in "biuf":
            labels = index.to_numpy()
            if kind == "f" and not np.isfinite(labels).all():
                raise ConfigError(f"axis {axis!r} has a non-finite value {labels.tolist()}; give finite values")
        else:
            raise ConfigError(
                f"axis {axis!r} mixes values of several kinds ({sorted({type(v).__name__ for v in items})}); "
                "give values of one kind: numbers, strings or times"
            )
    else:
        labels = np.array([object_label(axis, v) for v in items], dtype=str)
    if labels.dtype.kind in "mM" and np.isnat(labels).any():
        raise ConfigError(f"axis {axis!r} holds NaT; give valid times")
    seen: set[Any] = set()
    for label in labels.tolist():
        if label in seen:
            raise ConfigError(
                f"axis {axis!r} has the label {label!r} twice; every case needs a distinct key: drop the duplicate "
                "or pass a mapping {label: value} with distinct labels"
            )
        seen.add(label)
    return labels


def make_axes(axes: Mapping[str, Any]) -> list[Axis]:
    if not isinstance(axes, Mapping) or not axes:
        raise ConfigError(
            f"axes={axes!r} must be a non-empty mapping of axis name → sequence of values, "
            "e.g. {'ship': ships, 'eta': etas}"
        )
    out = []
    for name, values in axes.items():
        if not isinstance(name, str) or not name.isidentifier():
            raise ConfigError(f"axis name {name!r} must be a string usable as a variable name, e.g. 'eta'")
        if name in _store.RESERVED_VARS:
            raise ConfigError(f"axis name {name!r} is reserved for the study's own variable; rename the axis")
        if isinstance(values, Mapping):
            keys = list(values.keys())
            vals = tuple(values.values())
        elif isinstance(values, str | bytes) or not isinstance(values, Iterable):
            raise ConfigError(
                f"axis {name!r} must be a sequence of values, got {type(values).__name__} {values!r}; "
                f"wrap a single value in a list: [{values!r}]"
            )
        elif isinstance(values, set | frozenset):
            raise ConfigError(
                f"axis {name!r} is a {type(values).__name__}, whose order is not stable between runs and would "
                "change the case keys; pass a list (e.g. sorted(values))"
            )
        else:
            keys = list(values)
            vals = tuple(keys)
        if not keys:
            raise ConfigError(f"axis {name!r} is empty; give it at least one value")
        out.append(Axis(name, axis_labels(name, keys), vals))
    return out


def study_manifest(axes: list[Axis], case_fn: Callable[..., Any]) -> dict[str, Any]:
    while isinstance(case_fn, functools.partial):
        case_fn = case_fn.func
    qualname = getattr(case_fn, "__qualname__", None) or type(case_fn).__qualname__
    module = getattr(case_fn, "__module__", None) or type(case_fn).__module__
    return {
        "format": _store.FORMAT,
        "axes": [{"name": a.name, **_store.encode_labels(a.labels)} for a in axes],
        "shape": [len(a.values) for a in axes],
        "n_cases": math.prod(len(a.values) for a in axes),
        "case_fn": f"{module}.{qualname}",
        "created_utc": _dt.datetime.now(_dt.UTC).replace(tzinfo=None).isoformat(timespec="seconds"),
    }


def axes_difference(old: list[dict[str, Any]], new: list[dict[str, Any]]) -> str | None:
    old_names = [a["name"] for a in old]
    new_names = [a["name"] for a in new]
    if old_names != new_names:
        return f"axes {old_names} in the store but {new_names} in this call"
    for a, b in zip(old, new, strict=True):
        if a["dtype"] != b["dtype"]:
            return f"axis {a['name']!r} holds {a['dtype']} labels in the store but {b['dtype']} in this call"
        if a["labels"] != b["labels"]:
            if len(a["labels"]) != len(b["labels"]):
                return (
                    f"axis {a['name']!r} has {len(a['labels'])} values in the store but {len(b['labels'])} in this call"
                )
            i = next(i for i, (x, y) in enumerate(zip(a["labels"], b["labels"], strict=True)) if x != y)
            return (
                f"axis {a['name']!r} value #{i} is {a['labels'][i]!r} in the store but {b['labels'][i]!r} in this call"
            )
    return None
