"""The Dask side of studies: a local cluster or an existing scheduler, reached or refused quickly.

Used by :func:`optroute.studies.study.run_study` and :func:`optroute.studies.tradeoff.tradeoff`:
:func:`dask_client` starts a :class:`distributed.LocalCluster` on the loopback interface for one
call, or connects to ``scheduler_address`` after :func:`probe` has checked, within ``timeout_s``,
that a Dask scheduler answers there (:class:`SchedulerUnreachable` otherwise, naming the address).
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import pickle
import socket
from collections.abc import Callable, Iterator
from typing import Any

from optroute._store import StudyError
from optroute.errors import ConfigError

__all__ = ["SYNCHRONOUS", "SchedulerUnreachable", "check_picklable", "dask_client", "import_distributed", "probe"]

#: ``scheduler_address`` that runs every case in this process, one after the other.
SYNCHRONOUS = "synchronous"


class SchedulerUnreachable(StudyError):
    """The Dask scheduler at ``scheduler_address`` cannot be reached.

    Parameters
    ----------
    message : str
        What was tried and how to fix it.
    address : str
        The address as given.
    """

    def __init__(self, message: str, address: str) -> None:
        super().__init__(message)
        self.address = address


def import_distributed() -> Any:
    try:
        import distributed
    except ImportError as exc:
        raise StudyError(
            "running a study on a Dask cluster needs the 'distributed' package, which is not installed; "
            "install it (pip install 'optroute[dask]' or pip install distributed), "
            f"or pass scheduler_address={SYNCHRONOUS!r} to run in this process"
        ) from exc
    return distributed


def check_picklable(case_fn: Callable[..., Any]) -> None:
    try:
        import cloudpickle
    except ImportError:  # pragma: no cover - cloudpickle comes with distributed
        dumps = pickle.dumps
    else:
        dumps = cloudpickle.dumps
    try:
        dumps(case_fn)
    except (pickle.PicklingError, TypeError, AttributeError, ValueError, RecursionError) as exc:
        raise ConfigError(
            f"case_fn={case_fn!r} cannot be pickled to send it to the Dask workers ({type(exc).__name__}: {exc}); "
            "define it as a module-level function in an importable module and bind fixed arguments with "
            f"functools.partial, or pass scheduler_address={SYNCHRONOUS!r} to run in this process"
        ) from exc


async def _scheduler_identity(address: str, timeout_s: float) -> dict[str, Any]:
    from distributed.core import rpc

    async with rpc(address, timeout=timeout_s) as remote:
        return await remote.identity()


def probe(address: str, timeout_s: float) -> None:
    """Fail within ``timeout_s`` unless a Dask scheduler answers at ``address``.

    A refused TCP connection fails at once.  A port that accepts but does not
    answer like a Dask scheduler (on which :class:`distributed.Client` would
    wait for ever) fails after ``timeout_s``: the identity request runs on a
    fresh event loop in a helper thread, so this also works where an event
    loop is already running (Jupyter).
    """
    distributed = import_distributed()
    try:
        scheme, location = distributed.comm.addressing.parse_address(address)
        host, port = (
            distributed.comm.addressing.parse_host_port(location, default_port=8786)
            if scheme in ("tcp", "tls")
            else (None, None)
        )
    except ValueError as exc:
        raise SchedulerUnreachable(
            f"scheduler_address={address!r} is not a Dask address ({exc}); give one like 'tcp://127.0.0.1:8786', "
            f"or None for a local cluster, or {SYNCHRONOUS!r} to run in this process",
            address,
        ) from exc
    if host is not None:
        try:
            with socket.create_connection((host, port), timeout=timeout_s):
                pass
        except OSError as exc:
            raise _unreachable(address, timeout_s, exc) from exc
    if scheme != "tcp":  # TLS needs the caller's security settings; the Client's own timeout applies
        return
    with concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="optroute-probe") as pool:
        job = pool.submit(asyncio.run, asyncio.wait_for(_scheduler_identity(address, timeout_s), timeout_s))
        try:
            identity = job.result()
        except (OSError, TimeoutError, ValueError, TypeError, KeyError) as exc:
            raise _unreachable(address, timeout_s, exc) from exc
    kind = identity.get("type") if isinstance(identity, dict) else None
    if kind != "Scheduler":
        raise SchedulerUnreachable(
            f"{address!r} answers as a Dask {kind or 'server of unknown kind'}, not a scheduler; give the "
            "scheduler's address (printed by `dask scheduler`, or client.scheduler.address)",
            address,
        )


def _unreachable(address: str, timeout_s: float, exc: BaseException) -> SchedulerUnreachable:
    return SchedulerUnreachable(
        f"cannot reach the Dask scheduler at {address!r} within timeout_s={timeout_s:g} s "
        f"({type(exc).__name__}: {exc}); start one there (`dask scheduler`, then `dask worker {address}`), "
        f"correct the address, or pass scheduler_address=None for a local cluster "
        f"({SYNCHRONOUS!r} runs in this process)",
        address,
    )


@contextlib.contextmanager
def dask_client(
    scheduler_address: str | None, n_workers: int, threads_per_worker: int, timeout_s: float
) -> Iterator[Any]:
    distributed = import_distributed()
    if scheduler_address is None:
        cluster = distributed.LocalCluster(
            n_workers=n_workers,
            threads_per_worker=threads_per_worker,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            worker_dashboard_address=None,
        )
        try:
            client = distributed.Client(cluster, timeout=timeout_s, set_as_default=False)
            try:
                yield client
            finally:
                client.close()
        finally:
            cluster.close()
        return
    probe(scheduler_address, timeout_s)
    try:
        client = distributed.Client(scheduler_address, timeout=timeout_s, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise _unreachable(scheduler_address, timeout_s, exc) from exc
    try:
        try:
            client.wait_for_workers(1, timeout=timeout_s)
        except TimeoutError as exc:
            raise StudyError(
                f"the Dask scheduler at {scheduler_address!r} has no workers after {timeout_s:g} s; "
                f"start some (`dask worker {scheduler_address}`) or raise timeout_s"
            ) from exc
        yield client
    finally:
        client.close()
