"""What the benchmarks share for figures a sceptical reader can trust: alternated timings and referee-scored tables.

Issue 22. Two rules, written once here and used by every benchmark that compares:

* **Timings** (:func:`alternate`): the compared variants run in turn, A B A B …, over repetitions,
  after one untimed warm-up call of *each variant's exact code path* (numba kernels compiled, CasADi
  plugins loaded, caches filled), so that a change of the machine's load falls on every variant
  alike; the minimum and the median of each variant are reported with the load average before and
  after. A one-off cost (a build, a compilation) is measured on its own with :func:`timed_once` and
  reported separately, never inside a timed repetition.
* **Comparison tables** (:func:`compare`): every method of every case is an :class:`Outcome` scored by
  the referee (``Plan.verify()`` and the plan evaluator's fuel) on the same corridor, ETA and model;
  a method that raised is ``failed`` and a plan that fails verification is ``unverified``, and both
  are counted and shown, never averaged away; means are taken over the cases *every* method solved
  with a clean plan, with that count beside them. Each table carries one line saying what is
  compared with what (``what``), and a baseline that is not the same work is labelled as such.

Everything here takes plain numbers and callables; bad arguments raise :class:`optroute.errors.ConfigError`.
"""

from __future__ import annotations

import math
import os
import statistics
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from optroute.errors import ConfigError

OK, UNVERIFIED, FAILED = "ok", "unverified", "failed"
STATES = (OK, UNVERIFIED, FAILED)
"""An outcome's state: a clean plan, a plan that fails the referee's ``verify()``, no plan (the method raised)."""


# --------------------------------------------------------------------------- timings
def load_average() -> tuple[float, float, float]:
    """The 1, 5 and 15 minute load averages (NaN where the platform has none)."""
    try:
        return os.getloadavg()
    except (AttributeError, OSError):  # Windows
        return (math.nan, math.nan, math.nan)


def load_line(label: str = "load average") -> str:
    """``"load average 1.52 / 1.70 / 1.81 (1, 5, 15 min) on 2 cores"``."""
    one, five, fifteen = load_average()
    return f"{label} {one:.2f} / {five:.2f} / {fifteen:.2f} (1, 5, 15 min) on {os.cpu_count()} cores"


def timed_once(fn: Callable[[], Any]) -> tuple[Any, float]:
    """``(fn(), wall-clock seconds)``: for a one-off cost (a build, a compilation) reported on its own."""
    started = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - started


@dataclass(frozen=True)
class Timing:
    """The wall-clock times [s] of one variant over the alternated repetitions."""

    name: str
    times_s: tuple[float, ...]

    def __post_init__(self) -> None:
        if not self.times_s or not all(math.isfinite(t) and t >= 0.0 for t in self.times_s):
            raise ConfigError(
                f"timing {self.name!r}: times_s={self.times_s!r} must be finite, >= 0 and not empty: time each variant at least once"
            )

    @property
    def min_s(self) -> float:
        return min(self.times_s)

    @property
    def median_s(self) -> float:
        return statistics.median(self.times_s)

    def as_dict(self) -> dict[str, Any]:
        return {"times_s": list(self.times_s), "min_s": self.min_s, "median_s": self.median_s}


@dataclass(frozen=True)
class Alternated:
    """Timings of variants run A B A B … after a warm-up; ``results`` holds each variant's last return value."""

    timings: dict[str, Timing]
    results: dict[str, Any]
    repeats: int
    order: tuple[str, ...]
    load_before: tuple[float, float, float]
    load_after: tuple[float, float, float]
    warmup_s: dict[str, float] = field(default_factory=dict)

    def ratio(self, name: str, baseline: str, stat: str = "median_s") -> float:
        """``name``'s time over ``baseline``'s (``stat`` ``"median_s"`` or ``"min_s"``)."""
        return getattr(self.timings[name], stat) / getattr(self.timings[baseline], stat)

    def as_dict(self) -> dict[str, Any]:
        return {
            "repeats": self.repeats,
            "order": list(self.order),
            "load_before": list(self.load_before),
            "load_after": list(self.load_after),
            "warmup_s": dict(self.warmup_s),
            **{name: t.as_dict() for name, t in self.timings.items()},
        }


def alternate(variants: Mapping[str, Callable[[], Any]], *, repeats: int, warmup: bool = True) -> Alternated:
    """Time the variants in turn (A B A B …) ``repeats`` times each, after one untimed call of each.

    Parameters
    ----------
    variants : mapping of str to callable
        The code paths compared, each called with no argument; the warm-up calls exactly these.
    repeats : int
        Timed calls of each variant (>= 1; 2 or more for the alternation to mean anything).
    warmup : bool
        Call each variant once, untimed, before the timed rounds (its time is kept in ``warmup_s``:
        compilation and first-call costs, reported separately).

    Returns
    -------
    Alternated
        Per variant its times [s] (min, median), the last call's result, the order of the rounds and the
        load average before and after.
    """
    if not variants:
        raise ConfigError("alternate() got no variant: pass a mapping of name to a callable taking no argument")
    if int(repeats) < 1:
        raise ConfigError(f"repeats={repeats!r} must be at least 1 (2 or more for the alternation to mean anything)")
    names = tuple(variants)
    results: dict[str, Any] = {}
    warm: dict[str, float] = {}
    if warmup:
        for name in names:
            results[name], warm[name] = timed_once(variants[name])
    before = load_average()
    times: dict[str, list[float]] = {name: [] for name in names}
    for _ in range(int(repeats)):
        for name in names:
            results[name], sec = timed_once(variants[name])
            times[name].append(sec)
    return Alternated(
        timings={n: Timing(n, tuple(t)) for n, t in times.items()},
        results=results,
        repeats=int(repeats),
        order=names,
        load_before=before,
        load_after=load_average(),
        warmup_s=warm,
    )


def timing_table(alt: Alternated, baseline: str, what: str, labels: Mapping[str, str] | None = None) -> list[str]:
    """Markdown lines: one line saying what is compared, then per variant min, median and ratios to ``baseline``."""
    labels = dict(labels or {})
    lines = [
        f"_{what}; the variants alternated {' '.join(alt.order)} × {alt.repeats} after a warm-up of each; "
        f"ratios to **{labels.get(baseline, baseline)}** (baseline)._",
        "",
        "| variant | min [s] | median [s] | min / baseline | median / baseline |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, t in alt.timings.items():
        lines.append(
            f"| {labels.get(name, name)} | {t.min_s:.3f} | {t.median_s:.3f} | {alt.ratio(name, baseline, 'min_s'):.2f} "
            f"| {alt.ratio(name, baseline):.2f} |"
        )
    b, a = alt.load_before, alt.load_after
    lines.append(f"\nload average (1 min) {b[0]:.2f} before, {a[0]:.2f} after, on {os.cpu_count()} cores")
    return lines


# --------------------------------------------------------------------------- comparison tables
@dataclass(frozen=True)
class Outcome:
    """One method on one case, as the referee scores it.

    ``fuel_t`` is the referee's fuel [t] of the method's plan (NaN without a plan); ``runtime_s`` the
    method's wall-clock time [s] (also when it failed); ``violations`` the number of ``verify()``
    findings (None when there is no plan); ``note`` a short text for the table.
    """

    method: str
    state: str
    fuel_t: float
    runtime_s: float
    violations: int | None = None
    note: str = ""

    def __post_init__(self) -> None:
        if self.state not in STATES:
            raise ConfigError(f"outcome {self.method!r}: state={self.state!r} is not known: use one of {STATES}")
        if self.state == OK and not math.isfinite(self.fuel_t):
            raise ConfigError(
                f"outcome {self.method!r}: a clean plan needs a finite fuel, got {self.fuel_t!r}: score it with Outcome.scored or mark it Outcome.failed"
            )

    @classmethod
    def scored(cls, method: str, *, fuel_t: float, runtime_s: float, violations: int, note: str = "") -> Outcome:
        """A plan scored by the referee: clean when it has no violation."""
        state = OK if violations == 0 and math.isfinite(fuel_t) else UNVERIFIED
        return cls(
            method,
            state,
            float(fuel_t),
            float(runtime_s),
            int(violations),
            note or ("clean" if state == OK else f"{violations} violations"),
        )

    @classmethod
    def failed(cls, method: str, *, runtime_s: float, error: BaseException | str) -> Outcome:
        """A method that gave no plan (it raised)."""
        why = error if isinstance(error, str) else f"{type(error).__name__}"
        return cls(method, FAILED, math.nan, float(runtime_s), None, f"failed: {why}")

    def as_dict(self) -> dict[str, Any]:
        return {
            "method": self.method,
            "state": self.state,
            "fuel_t": self.fuel_t,
            "runtime_s": self.runtime_s,
            "violations": self.violations,
            "note": self.note,
        }


def _gmean(x: Sequence[float]) -> float:
    return math.exp(statistics.fmean(math.log(v) for v in x)) if x else math.nan


def compare(
    cases: Sequence[Mapping[str, Outcome]],
    methods: Sequence[str],
    baseline: str,
    what: str,
    *,
    not_same_work: Sequence[str] = (),
) -> dict[str, Any]:
    """Count and average a comparison: per method its clean, unverified and failed plans over all cases.

    Parameters
    ----------
    cases : sequence of mappings method → Outcome
        One mapping per case (scenario, ETA); a method missing from a case counts as failed there
        (never dropped).
    methods : sequence of str
        The methods compared, in table order; ``baseline`` among them.
    baseline : str
        The method the ratios are to.
    what : str
        One line: what is compared with what (corridor, ETA, model, referee).
    not_same_work : sequence of str
        Methods that do not do the same work as the baseline (labelled so in the table).

    Returns
    -------
    dict
        ``what``, ``baseline``, ``cases``, ``common_cases`` (the cases where every method gave a clean
        plan) and per method ``ok``, ``unverified``, ``failed``, ``cases`` and, over the common cases,
        ``mean_fuel_t``, ``mean_runtime_s``, ``fuel_ratio_gmean`` and ``runtime_ratio_gmean`` (to the
        baseline, geometric means of the per-case ratios).
    """
    if baseline not in methods:
        raise ConfigError(f"baseline {baseline!r} is not among the methods {list(methods)}: name one of them")
    full = [{m: c.get(m) or Outcome.failed(m, runtime_s=math.nan, error="no result") for m in methods} for c in cases]
    common = [c for c in full if all(o.state == OK for o in c.values())]
    per: dict[str, dict[str, Any]] = {}
    for m in methods:
        states = [c[m].state for c in full]
        fuel = [c[m].fuel_t for c in common]
        run = [c[m].runtime_s for c in common]
        fr = [c[m].fuel_t / c[baseline].fuel_t for c in common]
        rr = [c[m].runtime_s / c[baseline].runtime_s for c in common if c[baseline].runtime_s > 0]
        per[m] = {
            "cases": len(full),
            "ok": states.count(OK),
            "unverified": states.count(UNVERIFIED),
            "failed": states.count(FAILED),
            "common_cases": len(common),
            "mean_fuel_t": statistics.fmean(fuel) if fuel else math.nan,
            "mean_runtime_s": statistics.fmean(run) if run else math.nan,
            "fuel_ratio_gmean": _gmean(fr),
            "runtime_ratio_gmean": _gmean(rr),
            "same_work_as_baseline": m not in not_same_work,
        }
    return {"what": what, "baseline": baseline, "cases": len(full), "common_cases": len(common), "methods": per}


def _f(x: float, fmt: str) -> str:
    return format(x, fmt) if math.isfinite(x) else "–"


def comparison_lines(summary: Mapping[str, Any]) -> list[str]:
    """The summary of :func:`compare` as markdown: the ``what`` line, then one row per method with its counts."""
    n, k, base = summary["cases"], summary["common_cases"], summary["baseline"]
    lines = [
        f"_{summary['what']}. Means over the {k} of {n} cases where every method gave a clean plan; "
        f"ratios to **{base}**; failed (no plan) and unverified (fails `verify()`) plans counted, never averaged._",
        "",
        f"| method | clean | unverified | failed | mean fuel [t] ({k} cases) | fuel / {base} | "
        f"mean runtime [s] ({k} cases) | runtime / {base} |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for m, s in summary["methods"].items():
        label = m if s["same_work_as_baseline"] else f"{m} (not the same work as {base})"
        lines.append(
            f"| {label} | {s['ok']}/{n} | {s['unverified']}/{n} | {s['failed']}/{n} | {_f(s['mean_fuel_t'], '.2f')} | "
            f"{_f(s['fuel_ratio_gmean'], '.3f')} | {_f(s['mean_runtime_s'], '.2f')} | {_f(s['runtime_ratio_gmean'], '.2f')} |"
        )
    return lines
