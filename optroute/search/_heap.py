"""A binary min-heap over flat numba arrays, the open set of the compiled label-setting searches.

Entries are compared lexicographically on two float keys ``(k1, k2)`` and carry
one integer ``s`` (a state, or the number of an entry kept elsewhere).  The
heap's arrays are the caller's: :func:`push` does not grow them (test ``n ==
h1.size`` and use :func:`grown` first), so the searches keep their state in
plain arrays that numba can cache.  Used by the grid search
(:mod:`optroute.search.compiled_search`) and the sailing search
(:mod:`optroute.search.sailing_kernel`).
"""

from __future__ import annotations

import numpy as np

from optroute._numba import jit

__all__ = ["grown", "less", "pop", "push"]


@jit(inline="always")
def less(a1, a2, b1, b2):  # pragma: no cover - compiled
    """Whether the key ``(a1, a2)`` comes before ``(b1, b2)``."""
    return a1 < b1 or (a1 == b1 and a2 < b2)


@jit(inline="always")
def _swap(h1, h2, hs, i, j):  # pragma: no cover - compiled
    h1[i], h1[j] = h1[j], h1[i]
    h2[i], h2[j] = h2[j], h2[i]
    hs[i], hs[j] = hs[j], hs[i]


@jit
def push(h1, h2, hs, n, k1, k2, s):  # pragma: no cover - compiled
    """Add ``(k1, k2, s)`` to the heap of ``n`` entries (room for one more); returns the new size."""
    i = n
    h1[i], h2[i], hs[i] = k1, k2, s
    while i > 0:
        p = (i - 1) >> 1
        if less(h1[i], h2[i], h1[p], h2[p]):
            _swap(h1, h2, hs, i, p)
            i = p
        else:
            break
    return n + 1


@jit
def pop(h1, h2, hs, n):  # pragma: no cover - compiled
    """Remove the least entry of the heap of ``n`` (> 0) entries; returns ``(k1, k2, s, new size)``."""
    k1, k2, s = h1[0], h2[0], hs[0]
    n -= 1
    h1[0], h2[0], hs[0] = h1[n], h2[n], hs[n]
    i = 0
    while True:
        c = 2 * i + 1
        if c >= n:
            break
        if c + 1 < n and less(h1[c + 1], h2[c + 1], h1[c], h2[c]):
            c += 1
        if less(h1[c], h2[c], h1[i], h2[i]):
            _swap(h1, h2, hs, i, c)
            i = c
        else:
            break
    return k1, k2, s, n


@jit
def grown(a, n):  # pragma: no cover - compiled
    """A copy of ``a`` twice as long, its first ``n`` values kept."""
    b = np.empty(2 * a.size, dtype=a.dtype)
    # not b[:n] = a[:n]: that compiles numba's shape-mismatch error path (seconds, on every clean clone)
    for i in range(n):
        b[i] = a[i]
    return b
