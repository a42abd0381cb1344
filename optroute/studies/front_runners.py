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

from optroute.studies.front_points import (
    FrontPoint,
    FrontSpec,
    SpecMissing,
    has_spec,
    install_spec,
    solve_chain,
    solve_chain_by_token,
    solve_point,
    solve_point_by_token,
)

__all__ = ["Chain", "DaskRunner", "SerialRunner", "split_chains"]

#: A chain: its ETAs in solving order, the end point its first ETA starts from, and whether that end is the first
#: ETA's neighbour in the front (:func:`~optroute.studies.front_points.solve_chain`'s ``end_adjacent``).
Chain = tuple[list[float], FrontPoint | None, bool]

# --------------------------------------------------------------------------- execution


class SerialRunner:
    """Runs points in this process."""

    def ends(self, spec: FrontSpec, route: Any, need_slow: bool) -> tuple[FrontPoint, FrontPoint | None]:
        fast = solve_point(spec, None, "minimum_time", None, route)
        slow = solve_point(spec, None, "slow_steaming", None) if need_slow else None
        return fast, slow

    def resolve(
        self, spec: FrontSpec, eta_h: float, starts: list[FrontPoint | None], end_adjacent: bool = False
    ) -> list[FrontPoint]:
        return [solve_point(spec, eta_h, "eta", w, end_adjacent=end_adjacent) for w in starts]

    def chains(
        self,
        spec: FrontSpec,
        chains: list[Chain],
        cold: bool,
        report: Callable[[FrontPoint], None],
        duals: bool = True,
    ) -> list[FrontPoint]:
        out = []
        for etas, warm, adjacent in chains:
            for p in solve_chain(spec, etas, warm, cold, duals, adjacent):
                out.append(p)
                report(p)
        return out


class DaskRunner:
    """Runs the end solves side by side and each chain as one task on a Dask cluster.

    The front's inputs (its weather, tens of MB) travel to each worker once and stay there, keyed by their
    fingerprint (:func:`~optroute.studies.front_points.install_spec`); the tasks carry that token, the ETAs
    and a warm start only, so the next front of the same inputs — a benchmark's repetition, a study's —
    ships nothing again and finds the worker's prepared corridor.
    """

    def __init__(self, client: Any, spec: FrontSpec) -> None:
        self.client = client
        self.token = spec.token
        self._spec = spec
        self.workers: list[str] = []
        self.installed = 0  # workers the inputs were shipped to by this front
        self._install()

    def _install(self) -> None:
        """Ship the inputs to the workers that do not hold them; the workers holding them run the tasks."""
        held = self.client.run(has_spec, self.token)
        missing = sorted(w for w, ok in held.items() if not ok)
        if missing:
            self.client.run(install_spec, self._spec, workers=missing)
            self.installed += len(missing)
        self.workers = sorted(held)

    def _submit(self, fn: Callable[..., Any], *args: Any) -> Any:
        return self.client.submit(fn, self.token, *args, workers=self.workers, allow_other_workers=False, pure=False)

    def _result(self, fut: Any, fn: Callable[..., Any], *args: Any) -> Any:
        """A task's result; a worker that lost the inputs (:class:`SpecMissing`) gets them again, once."""
        try:
            return fut.result()
        except SpecMissing:
            self._install()
            return self._submit(fn, *args).result()

    def ends(self, spec: FrontSpec, route: Any, need_slow: bool) -> tuple[FrontPoint, FrontPoint | None]:
        fast_args = (None, "minimum_time", None, route)
        slow_args = (None, "slow_steaming", None)
        fast = self._submit(solve_point_by_token, *fast_args)
        slow = self._submit(solve_point_by_token, *slow_args) if need_slow else None
        return (
            self._result(fast, solve_point_by_token, *fast_args),
            self._result(slow, solve_point_by_token, *slow_args) if slow is not None else None,
        )

    def resolve(
        self, spec: FrontSpec, eta_h: float, starts: list[FrontPoint | None], end_adjacent: bool = False
    ) -> list[FrontPoint]:
        """Solves of one ETA from several starts, side by side (the workers' prepared corridors serve them)."""
        args = [(eta_h, "eta", w, None, end_adjacent) for w in starts]
        futures = [self._submit(solve_point_by_token, *a) for a in args]
        return [self._result(f, solve_point_by_token, *a) for f, a in zip(futures, args, strict=True)]

    def chains(
        self,
        spec: FrontSpec,
        chains: list[Chain],
        cold: bool,
        report: Callable[[FrontPoint], None],
        duals: bool = True,
    ) -> list[FrontPoint]:
        from distributed import as_completed

        # one task per chain (a chain's points run one after the other anyway): few, long tasks, streamed back.
        # Only as many in flight as the workers have threads, the next given out when one finishes, in the
        # order of ``chains`` (the costliest first): all submitted at once, the scheduler had placed them on the
        # workers in turn before knowing their cost, and the slow end's chain waited behind another on one
        # worker while the other worker ran out of work
        todo = list(chains)
        args: dict[str, tuple[Any, ...]] = {}
        running = as_completed(loop=self.client.loop)

        def submit_next() -> None:
            etas, warm, adjacent = todo.pop(0)
            fut = self._submit(solve_chain_by_token, etas, warm, cold, duals, adjacent)
            args[fut.key] = (etas, warm, cold, duals, adjacent)
            running.add(fut)

        for _ in range(min(self._slots(), len(todo))):
            submit_next()
        out = []
        for fut in running:
            for p in self._result(fut, solve_chain_by_token, *args.pop(fut.key)):
                out.append(p)
                report(p)
            fut.release()
            if todo:
                submit_next()
        return out

    def _slots(self) -> int:
        """The threads of the workers holding the inputs (at least 1)."""
        return max(1, sum(int(n) for n in self.client.nthreads(self.workers).values()))


def split_chains(etas: list[float], k: int) -> list[list[float]]:
    """``k`` contiguous chains of the ETAs, each in solving order: ascending from the fast end.

    The chains depend on the ETAs and ``k`` alone, never on the workers: the front is the same serial and
    on any cluster.
    """
    k = max(1, min(k, len(etas)))
    return [[float(h) for h in a] for a in np.array_split(np.asarray(etas, dtype=float), k)]
