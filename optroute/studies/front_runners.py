"""Where a front's points run: in this process, or the end solves side by side and each chain as one Dask task.

The chains depend on the ETAs and their count alone (:func:`split_chains`), never on the workers, so
a front is the same serial and on any cluster.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    pass

from optroute.studies.front_points import FrontPoint, FrontSpec, solve_chain, solve_point

__all__ = ["DaskRunner", "SerialRunner", "split_chains"]

# --------------------------------------------------------------------------- execution


class SerialRunner:
    """Runs points in this process."""

    def ends(self, spec: FrontSpec, route: Any, need_slow: bool) -> tuple[FrontPoint, FrontPoint | None]:
        fast = solve_point(spec, None, "minimum_time", None, route)
        slow = solve_point(spec, None, "slow_steaming", None) if need_slow else None
        return fast, slow

    def resolve(self, spec: FrontSpec, eta_h: float, starts: list[FrontPoint | None]) -> list[FrontPoint]:
        return [solve_point(spec, eta_h, "eta", w) for w in starts]

    def chains(
        self,
        spec: FrontSpec,
        chains: list[tuple[list[float], FrontPoint | None]],
        cold: bool,
        report: Callable[[FrontPoint], None],
    ) -> list[FrontPoint]:
        out = []
        for etas, warm in chains:
            for p in solve_chain(spec, etas, warm, cold):
                out.append(p)
                report(p)
        return out


class DaskRunner:
    """Runs the end solves side by side and each chain as one task on a Dask cluster."""

    def __init__(self, client: Any, spec: FrontSpec) -> None:
        self.client = client
        self.spec = client.scatter(spec, broadcast=True, hash=False)
        self.workers = sorted(client.scheduler_info()["workers"])
        self._shipped: Any = None  # the spec naming the chains' latest ETA, once scattered

    def ends(self, spec: FrontSpec, route: Any, need_slow: bool) -> tuple[FrontPoint, FrontPoint | None]:
        fast = self.client.submit(solve_point, self.spec, None, "minimum_time", None, route, pure=False)
        slow = (
            self.client.submit(solve_point, self.spec, None, "slow_steaming", None, pure=False) if need_slow else None
        )
        return fast.result(), slow.result() if slow is not None else None

    def resolve(self, spec: FrontSpec, eta_h: float, starts: list[FrontPoint | None]) -> list[FrontPoint]:
        """Solves of one ETA from several starts, side by side (the workers' prepared corridors serve them)."""
        shipped = self._shipped if self._shipped is not None else self.client.scatter(spec, broadcast=True, hash=False)
        futures = [self.client.submit(solve_point, shipped, eta_h, "eta", w, pure=False) for w in starts]
        return [f.result() for f in futures]

    def chains(
        self,
        spec: FrontSpec,
        chains: list[tuple[list[float], FrontPoint | None]],
        cold: bool,
        report: Callable[[FrontPoint], None],
    ) -> list[FrontPoint]:
        from distributed import as_completed

        # the spec now names the chains' latest ETA: each worker prepares the corridor once for it (and keeps it)
        shipped = self._shipped = self.client.scatter(spec, broadcast=True, hash=False)
        # one task per chain (a chain's points run one after the other anyway): few, long tasks, streamed back
        futures = [self.client.submit(solve_chain, shipped, etas, warm, cold, pure=False) for etas, warm in chains]
        out = []
        for fut in as_completed(futures, loop=self.client.loop):
            for p in fut.result():
                out.append(p)
                report(p)
            fut.release()
        return out


def split_chains(etas: list[float], k: int, from_slow: bool) -> list[list[float]]:
    """``k`` contiguous chains of the ETAs, each in solving order: descending from the slow end with ``from_slow``.

    The chains depend on the ETAs and ``k`` alone, never on the workers: the front is the same serial and
    on any cluster.
    """
    k = max(1, min(k, len(etas)))
    parts = [[float(h) for h in a] for a in np.array_split(np.asarray(etas, dtype=float), k)]
    return [part[::-1] if from_slow else part for part in parts]
