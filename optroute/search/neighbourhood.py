"""Neighbourhoods of a grid node: which lattice offsets a leg may take.

Two families:

* :func:`compass` — the 8-, 16- and 32-direction sets of Życkowski:
  transitions ``P(i, j) → P(i + p, j + q)`` with ``p, q ∈ −3..3``; the set of
  ``w_r`` directions is exactly the primitive offsets (gcd 1) of Chebyshev
  length ≤ 1, 2, 3 respectively.
* :func:`angular_resolution` — the Boeing minimum-angular-resolution set
  (EP 2145155, Fig. 13 and its text): all cells within a radius (12 grid
  squares in the patent's example) reduced to the smallest set whose adjacent
  headings differ by at most a given angle (5° by default), where cells
  straight along an axis or a diagonal link only to the nearest one.

Angles are in the grid plane, counter-clockwise from the grid's +x axis
(columns), in [0, 360) [deg].  Offsets are ``(di, dj)``: rows (grid y) then
columns (grid x), as in :mod:`optroute.search.grid`.

Approximation error (the reason for the angular resolution): a straight
direction that lies between two available directions ``a`` and ``b``
degrees away on either side is best followed by a mix of the two, of length
``(sin a + sin b) / sin(a + b)`` times the straight distance; the worst case
over a gap ``g = a + b`` is ``1 / cos(g / 2)`` — 8.2 % for the 8-direction
set (g = 45°).  The lattice 16- and 32-direction sets are not uniform: their
largest gaps are 26.6° and 18.4° (worst cases 2.7 % and 1.3 %, not the 2.0 %
and 0.5 % of uniform 16 and 32 headings); a 5° set is within 0.1 %.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from math import gcd

import numpy as np

from optroute._checks import finite
from optroute.errors import ConfigError

_TOL_DEG = 1e-9


@dataclass(frozen=True, eq=False)
class Neighbourhood:
    """A set of lattice offsets, sorted by angle.

    Attributes
    ----------
    offsets : ndarray of int, shape (m, 2)
        ``(di, dj)`` [cells]: rows (grid y), columns (grid x).
    angles_deg : ndarray, shape (m,)
        Direction of each offset in the grid plane [deg, counter-clockwise from
        +x, in [0, 360)], increasing.
    name : str
        A label for tables (``"8"``, ``"16"``, ``"32"``, ``"5deg-r12"``).
    """

    offsets: np.ndarray = dataclasses.field(repr=False)
    angles_deg: np.ndarray = dataclasses.field(repr=False)
    name: str = ""

    @property
    def m(self) -> int:
        """Number of offsets."""
        return int(self.offsets.shape[0])

    @property
    def lengths_cells(self) -> np.ndarray:
        """Length of each offset [cells]."""
        return np.hypot(self.offsets[:, 0], self.offsets[:, 1])

    @property
    def radius_cells(self) -> int:
        """Largest Chebyshev length of an offset [cells]."""
        return int(np.abs(self.offsets).max())

    @property
    def max_gap_deg(self) -> float:
        """Largest angle between adjacent directions [deg]."""
        return max_angular_gap_deg(self.angles_deg)

    def worst_case_excess(self) -> float:
        """Worst relative excess length of a lattice path over a straight line, ``1/cos(g/2) - 1``."""
        return float(1.0 / np.cos(np.radians(self.max_gap_deg) / 2.0) - 1.0)

    def excess_for_direction(self, angle_deg: float) -> float:
        """Relative excess length of the best two-direction mix that follows a straight direction.

        Parameters
        ----------
        angle_deg : float
            Target direction in the grid plane [deg, counter-clockwise from +x].

        Returns
        -------
        float
            ``(sin a + sin b) / sin(a + b) - 1`` for the two available directions
            ``a`` below and ``b`` above the target (0 when the direction is available).
        """
        t = float(np.mod(angle_deg, 360.0))
        ang = self.angles_deg
        if np.any(np.abs(np.mod(ang - t + 180.0, 360.0) - 180.0) < _TOL_DEG):
            return 0.0
        k = int(np.searchsorted(ang, t))
        lo = ang[k - 1] if k > 0 else ang[-1] - 360.0
        hi = ang[k] if k < len(ang) else ang[0] + 360.0
        a, b = np.radians(t - lo), np.radians(hi - t)
        return float((np.sin(a) + np.sin(b)) / np.sin(a + b) - 1.0)


def max_angular_gap_deg(angles_deg: np.ndarray) -> float:
    """Largest gap between cyclically adjacent directions [deg]."""
    ang = np.sort(np.mod(np.asarray(angles_deg, dtype=float), 360.0))
    if ang.size == 0:
        return 360.0
    gaps = np.diff(np.concatenate([ang, [ang[0] + 360.0]]))
    return float(gaps.max())


def _make(offsets: list[tuple[int, int]] | np.ndarray, name: str) -> Neighbourhood:
    off = np.unique(np.asarray(offsets, dtype=np.int64).reshape(-1, 2), axis=0)
    ang = np.mod(np.degrees(np.arctan2(off[:, 0], off[:, 1])), 360.0)
    order = np.argsort(ang, kind="stable")
    off, ang = off[order], ang[order]
    off.setflags(write=False)
    ang.setflags(write=False)
    return Neighbourhood(offsets=off, angles_deg=ang, name=name)


def _symmetric(octant: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Images of first-octant offsets ``(dj >= di >= 0)`` under the 8 lattice symmetries, as ``(di, dj)``."""
    out = set()
    for di, dj in octant:
        for a, b in ((di, dj), (dj, di)):
            for sa in (1, -1):
                for sb in (1, -1):
                    out.add((sa * a, sb * b))
    return sorted(out)


def compass(n: int) -> Neighbourhood:
    """The 8-, 16- or 32-direction neighbourhood of Życkowski.

    Parameters
    ----------
    n : {8, 16, 32}
        Number of directions ``w_r``.

    Returns
    -------
    Neighbourhood
        The primitive offsets with ``max(|di|, |dj|) <= 1, 2, 3``: steps to the
        8 adjacent cells, plus the knight's moves (±1, ±2) for 16, plus (±1, ±3)
        and (±2, ±3) for 32.
    """
    radius = {8: 1, 16: 2, 32: 3}.get(int(n)) if isinstance(n, int | np.integer) else None
    if radius is None:
        raise ConfigError(f"n={n!r} directions is not one of Życkowski's sets; use 8, 16 or 32")
    offs = [
        (p, q)
        for p in range(-radius, radius + 1)
        for q in range(-radius, radius + 1)
        if (p, q) != (0, 0) and gcd(abs(p), abs(q)) == 1
    ]
    return _make(offs, str(n))


def angular_resolution(max_gap_deg: float = 5.0, radius_cells: int = 12) -> Neighbourhood:
    """The Boeing minimum-angular-resolution neighbourhood.

    Start from every offset within ``radius_cells`` grid squares (Chebyshev
    distance ``max(|di|, |dj|)``: the patent's far neighbours near an axis or a
    diagonal are "12 grid squares away", i.e. (1, 12) and (11, 12)), keep only the
    primitive ones (gcd 1: an offset straight along an axis, a diagonal or any
    other lattice direction links only to the nearest cell in that direction),
    always keep the 8 adjacent cells, and between each pair of them (one
    octant, 45°) choose the smallest set of directions whose adjacent angles
    differ by at most ``max_gap_deg``; among smallest sets, the one with the
    shortest total offset length.  The choice is a shortest-path over the
    octant's candidate directions sorted by angle (count first, length
    second), so it is minimal among the sets that contain the 8 adjacent
    cells (the patent keeps them; without them a smaller set can exist, e.g.
    12 of the 16 radius-2 directions keep 40°); the octant's solution is
    mirrored to the other seven by the lattice's symmetry.

    Parameters
    ----------
    max_gap_deg : float
        Largest allowed angle between adjacent headings [deg] (5° in the patent).
    radius_cells : int
        Largest offset considered [grid squares, Chebyshev] (12 in the patent), 1..40.

    Returns
    -------
    Neighbourhood

    Raises
    ------
    ConfigError
        ``max_gap_deg`` is not in (0, 180] or cannot be met within the radius
        (the finest angle near an axis is ``atan(1 / radius)``).
    """
    gap = float(finite("max_gap_deg", max_gap_deg, minimum=0.0, strict=True, error=ConfigError))
    if gap > 180.0:
        raise ConfigError(f"max_gap_deg={gap} must be at most 180")
    r = int(radius_cells)
    if r != radius_cells or not 1 <= r <= 40:
        raise ConfigError(f"radius_cells={radius_cells!r} must be an integer in 1..40 (12 in the Boeing patent)")
    # first-octant candidates (dj >= di >= 0), as (di, dj) = (rise, run)
    cand = [(di, dj) for dj in range(1, r + 1) for di in range(0, dj + 1) if gcd(di, dj) == 1]
    ang = np.array([np.degrees(np.arctan2(di, dj)) for di, dj in cand])
    order = np.argsort(ang)
    cand = [cand[k] for k in order]
    ang = ang[order]
    length = np.array([np.hypot(di, dj) for di, dj in cand])
    # cand[0] = (0, 1) at 0°, cand[-1] = (1, 1) at 45°: lexicographic (count, length) shortest path
    n = len(cand)
    best_count = np.full(n, np.iinfo(np.int64).max, dtype=np.int64)
    best_len = np.full(n, np.inf)
    prev = np.full(n, -1, dtype=np.int64)
    best_count[0], best_len[0] = 0, 0.0
    for k in range(1, n):
        for p in range(k):
            if ang[k] - ang[p] > gap + _TOL_DEG or best_count[p] == np.iinfo(np.int64).max:
                continue
            c, ln = best_count[p] + 1, best_len[p] + length[k]
            if c < best_count[k] or (c == best_count[k] and ln < best_len[k] - 1e-12):
                best_count[k], best_len[k], prev[k] = c, ln, p
    if prev[n - 1] < 0:
        finest = max(np.diff(ang)) if n > 1 else 45.0
        raise ConfigError(
            f"max_gap_deg={gap} cannot be met with radius_cells={r}: the largest gap between the directions "
            f"available is {finest:.2f} deg; raise radius_cells or max_gap_deg"
        )
    chosen = []
    k = n - 1
    while k >= 0:
        chosen.append(cand[k])
        k = int(prev[k])
    return _make(_symmetric(chosen), f"{gap:g}deg-r{r}")
