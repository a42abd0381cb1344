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
import math
import numbers
import pickle
import socket
import struct
from collections.abc import Callable, Iterator
from typing import Any

from optroute._store import StudyError
from optroute.errors import ConfigError

__all__ = [
    "SCHEDULER_HTTP_ADDRESS",
    "SYNCHRONOUS",
    "SchedulerUnreachable",
    "check_cluster_options",
    "check_picklable",
    "dask_client",
    "import_distributed",
    "probe",
]

#: ``scheduler_address`` that runs every case in this process, one after the other.
SYNCHRONOUS = "synchronous"
#: Where a local cluster's scheduler serves its HTTP routes (health, metrics; no dashboard): any free loopback port.
#: Dask's default, 8787, is taken by the second cluster running at once (another study, a notebook's), and Dask
#: then warns "Port 8787 is already in use".
SCHEDULER_HTTP_ADDRESS = "127.0.0.1:0"


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
            with socket.create_connection((host, port), timeout=timeout_s) as sock:
                if scheme == "tcp":
                    _check_greeting(sock, address, timeout_s)
        except OSError as exc:  # refused, unreachable, or silent for timeout_s (socket.timeout is an OSError)
            raise _unreachable(address, timeout_s, exc) from exc
    if scheme != "tcp":  # TLS needs the caller's security settings; the Client's own timeout applies
        return
    with concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="optroute-probe") as pool:
        job = pool.submit(asyncio.run, asyncio.wait_for(_scheduler_identity(address, timeout_s), timeout_s))
        try:
            identity = job.result()
        except (OSError, TimeoutError) as exc:
            raise _unreachable(address, timeout_s, exc) from exc
        except (ValueError, TypeError, KeyError, IndexError, struct.error, MemoryError, OverflowError) as exc:
            # bytes that are not Dask's, read as its frames (a huge length prefix is a MemoryError)
            why = f"its answer to Dask's handshake does not decode ({type(exc).__name__}: {str(exc)[:160]})"
            raise _not_dask(address, b"", why) from exc
    kind = identity.get("type") if isinstance(identity, dict) else None
    if kind != "Scheduler":
        raise SchedulerUnreachable(
            f"{address!r} answers as a Dask {kind or 'server of unknown kind'}, not a scheduler; give the "
            "scheduler's address (printed by `dask scheduler`, or client.scheduler.address)",
            address,
        )


#: The largest first message a Dask server may greet with [bytes]: its handshake is a few hundred bytes.
_MAX_GREETING_BYTES = 1 << 20


def _check_greeting(sock: socket.socket, address: str, timeout_s: float) -> None:
    """Read the first 8 bytes a Dask server sends on accepting a connection; refuse what is not Dask's.

    A Dask comm (``distributed.comm.core``: both ends write their handshake first, then read)
    starts every message with its length as an 8-byte unsigned integer (``distributed.comm.tcp``,
    ``struct`` format ``"Q"``).  Any other server — HTTP (the dashboard's port), SSH, a database —
    answers with text or nothing: text read as that length asks for exabytes (``distributed``
    then fails allocating it), and silence is a timeout.  Both fail here, before any Dask code
    reads the bytes.

    Raises
    ------
    SchedulerUnreachable
        The server closed the connection, said nothing within ``timeout_s`` (a Dask server greets at
        once), or its first bytes are not a plausible Dask greeting.
    """
    sock.settimeout(timeout_s)
    head = b""
    while len(head) < 8:
        try:
            chunk = sock.recv(8 - len(head))
        except TimeoutError:  # accepts connections but does not greet
            raise _not_dask(address, head, f"it sent nothing within timeout_s={timeout_s:g} s") from None
        if not chunk:
            raise _not_dask(address, head, "it closed the connection")
        head += chunk
    (nbytes,) = struct.unpack("Q", head)
    if not 0 < nbytes <= _MAX_GREETING_BYTES:
        sock.settimeout(min(timeout_s, 0.2))  # a little more of the answer, to name it in the message
        with contextlib.suppress(OSError):
            head += sock.recv(56)
        raise _not_dask(address, head, f"its first 8 bytes give a message length of {nbytes} bytes")


def _not_dask(address: str, head: bytes, why: str) -> SchedulerUnreachable:
    text = head[:64].decode("ascii", "backslashreplace")
    kind = " (an HTTP server: a Dask dashboard, usually port 8787?)" if head.startswith(b"HTTP/") else ""
    return SchedulerUnreachable(
        f"{address!r} answers, but not as a Dask scheduler{kind}: {why}"
        + (f"; it sent {text!r}" if text else "")
        + "; give the scheduler's address (printed by `dask scheduler` as 'Scheduler at: tcp://…', port 8786 by "
        f"default), or pass scheduler_address=None for a local cluster ({SYNCHRONOUS!r} runs in this process)",
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


def check_cluster_options(n_workers: Any, scheduler_address: Any, timeout_s: Any, threads_per_worker: Any = 1) -> None:
    """Where a study or a front runs, checked: :class:`~optroute.errors.ConfigError` naming a bad value and what to give.

    ``n_workers`` an integer >= 0 or None (0 runs in this process), ``scheduler_address`` a string (a Dask
    scheduler's address, or :data:`SYNCHRONOUS`) or None, ``n_workers`` only with a local cluster,
    ``timeout_s`` a positive number of seconds, ``threads_per_worker`` an integer >= 1.
    """
    if (
        isinstance(timeout_s, bool)
        or not isinstance(timeout_s, numbers.Real)
        or not math.isfinite(timeout_s)
        or timeout_s <= 0
    ):
        raise ConfigError(f"timeout_s={timeout_s!r} must be a positive number of seconds, e.g. 10")
    if (
        isinstance(threads_per_worker, bool)
        or not isinstance(threads_per_worker, numbers.Integral)
        or threads_per_worker < 1
    ):
        raise ConfigError(f"threads_per_worker={threads_per_worker!r} must be an integer >= 1")
    if n_workers is not None and (
        isinstance(n_workers, bool) or not isinstance(n_workers, numbers.Integral) or n_workers < 0
    ):
        raise ConfigError(f"n_workers={n_workers!r} must be an integer >= 0 (0 runs in this process), or None")
    if scheduler_address is not None and not isinstance(scheduler_address, str):
        raise ConfigError(
            f"scheduler_address={scheduler_address!r} must be a string such as 'tcp://127.0.0.1:8786', "
            f"{SYNCHRONOUS!r}, or None"
        )
    if scheduler_address not in (None, SYNCHRONOUS) and n_workers is not None:
        raise ConfigError(
            f"n_workers={n_workers} applies to the local cluster only, but scheduler_address={scheduler_address!r} "
            "was given; drop n_workers (the existing cluster has its own workers)"
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
            scheduler_kwargs={"dashboard_address": SCHEDULER_HTTP_ADDRESS},
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
