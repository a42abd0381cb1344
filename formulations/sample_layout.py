"""Where the corridor NLP samples each leg: quadrature points and constraint points (issue 13 item 3).

:class:`formulations.speed_nlp.SpeedNLP` evaluates the weather and the ship at *samples* along every
leg, at fractions of the leg's length (0 at its first waypoint, 1 at its second), and uses them for
two things:

* the **quadrature** of the leg's time and fuel, ``t_{k+1} − t_k = Σ_j w_kj L_k / SOG_kj`` (weights
  ``w_kj ≥ 0`` summing to 1 over the leg);
* the **rows**: engine load, danger bands, exclusion circle (and drift, SOG) at every sample.

The default layout is the midpoint rule: ``m`` samples at ``(j + ½)/m``, weight ``1/m`` each. A
referee that checks elsewhere (the plan's own check points: leg ends, weather-grid crossings,
refinement near band edges; :func:`optroute.plan.checkpoints.check_points`) can reject a converged
plan between the NLP's samples. :func:`with_points` keeps the midpoints for the quadrature and adds
given points per leg with weight 0: they are rows only, and they sit at fractions of the leg, so they
move with the leg's ends when Ipopt moves the offsets. Every leg has the same number of samples
``M`` (the NLP's arrays are (N, M)): a leg with fewer points is padded by halving its widest gaps
between samples (real points of the leg, not repeats: repeated rows would be linearly dependent).

Nothing here imports :mod:`optroute`; fractions are plain numbers in [0, 1].
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from formulations.common import FormulationInputError

__all__ = ["SampleLayout", "midpoint_layout", "with_points"]

#: Points closer than this fraction of their leg are merged (one row serves both) [-].
MERGE_FRACTION = 1e-3


@dataclass(frozen=True)
class SampleLayout:
    """Samples of every leg: fractions along it and quadrature weights.

    Attributes
    ----------
    fraction : numpy.ndarray, shape (N, M)
        Fraction of the leg's length from its first waypoint [-], in [0, 1], sorted along each leg.
    weight : numpy.ndarray, shape (N, M)
        Quadrature weight [-], >= 0, summing to 1 over each leg (0: a row-only point).
    """

    fraction: np.ndarray
    weight: np.ndarray

    def __post_init__(self) -> None:
        f = np.asarray(self.fraction, dtype=float)
        w = np.asarray(self.weight, dtype=float)
        if f.ndim != 2 or f.shape != w.shape or f.shape[1] < 1:
            raise FormulationInputError(
                f"fraction and weight must both have shape (N, M) with M >= 1, got {f.shape} and {w.shape}"
            )
        if not (np.all(np.isfinite(f)) and np.all((f >= 0.0) & (f <= 1.0))):
            raise FormulationInputError("sample fractions must be finite and in [0, 1]")
        if not (np.all(np.isfinite(w)) and np.all(w >= 0.0)):
            raise FormulationInputError("sample weights must be finite and >= 0")
        if not np.allclose(w.sum(axis=1), 1.0, rtol=0.0, atol=1e-12):
            raise FormulationInputError(f"sample weights must sum to 1 on every leg, got {w.sum(axis=1).min():g}..")
        object.__setattr__(self, "fraction", f)
        object.__setattr__(self, "weight", w)

    @property
    def n_legs(self) -> int:
        return int(self.fraction.shape[0])

    @property
    def per_leg(self) -> int:
        """``M``, samples per leg."""
        return int(self.fraction.shape[1])

    @property
    def uniform(self) -> bool:
        """Whether every leg has the same fractions and weights."""
        return bool(np.all(self.fraction == self.fraction[:1]) and np.all(self.weight == self.weight[:1]))

    def key(self) -> bytes:
        """Bytes identifying the layout (a build cache key)."""
        return self.fraction.tobytes() + self.weight.tobytes()


def midpoint_layout(n_legs: int, m: int) -> SampleLayout:
    """The midpoint rule: ``m`` samples at ``(j + ½)/m`` on each of ``n_legs`` legs, weight ``1/m``."""
    if not (isinstance(m, int | np.integer) and m >= 1):
        raise FormulationInputError(f"samples_per_leg must be an integer >= 1, got {m!r}")
    frac = (np.arange(m) + 0.5) / m
    return SampleLayout(np.tile(frac, (n_legs, 1)), np.full((n_legs, m), 1.0 / m))


def _pad(frac: np.ndarray, weight: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Add weight-0 points at the middle of the widest gaps (leg ends included as gap ends) up to ``size``."""
    f, w = list(frac), list(weight)
    while len(f) < size:
        nodes = np.concatenate([[0.0], np.asarray(f), [1.0]])
        gaps = np.diff(nodes)
        i = int(np.argmax(gaps))
        new = 0.5 * (nodes[i] + nodes[i + 1])
        f.insert(i, new)
        w.insert(i, 0.0)
    return np.asarray(f), np.asarray(w)


def with_points(base: SampleLayout, points: Sequence[np.ndarray], *, max_points: int = 24) -> SampleLayout:
    """``base`` (the quadrature) with row-only points added on every leg.

    Parameters
    ----------
    base : SampleLayout
        The quadrature samples (kept with their weights).
    points : sequence of numpy.ndarray
        Per leg, fractions along it [-] where the rows are wanted (any order; values are clipped to
        [0, 1]; a point within :data:`MERGE_FRACTION` of a sample or of another point is merged into it).
    max_points : int
        At most this many added points per leg: where a leg has more, an evenly spread subset of them
        (in their order along the leg) is kept, the leg ends always among them.

    Returns
    -------
    SampleLayout
        Shape (N, M), M the largest count of any leg; every leg padded to M by :func:`_pad`.
    """
    n = base.n_legs
    if len(points) != n:
        raise FormulationInputError(f"points must give one array per leg ({n}), got {len(points)}")
    rows = []
    for k in range(n):
        p = np.unique(np.clip(np.asarray(points[k], dtype=float).ravel(), 0.0, 1.0))
        if p.size > max_points:
            keep = np.unique(np.round(np.linspace(0, p.size - 1, max_points)).astype(int))
            p = p[keep]
        f, w = base.fraction[k], base.weight[k]
        for q in p:
            if np.min(np.abs(f - q)) > MERGE_FRACTION:
                f, w = np.append(f, q), np.append(w, 0.0)
        order = np.argsort(f, kind="stable")
        rows.append((f[order], w[order]))
    size = max(r[0].size for r in rows)
    padded = [_pad(f, w, size) for f, w in rows]
    return SampleLayout(np.vstack([p[0] for p in padded]), np.vstack([p[1] for p in padded]))
