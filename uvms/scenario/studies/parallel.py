"""Running many scenario runs in parallel: local processes (joblib's loky) or a Dask cluster.

The one executor of :mod:`uvms.scenario.studies.sweep` (grid points) and :mod:`uvms.scenario.studies.study` (Monte Carlo
trials). A task is ``function(*arguments)`` returning a row (a dict); the rows come back in completion order and
the caller sorts them by their index, so a table is the same whatever the backend and the number of jobs.

A worker process on this machine (loky, the local Dask cluster) watches the uvms process that submitted its
task (:func:`watch_parent`): when that process dies (``kill -9``, the OOM killer), the worker exits within
:data:`PARENT_POLL` seconds, and a study writes no row once its process is gone (:func:`exit_if_orphaned`).

A Dask scheduler runs whatever its clients submit, and a client unpickles whatever results come back. The local
cluster speaks TLS with credentials made for it (client certificates required: another user of the machine cannot
submit to it) and opens no HTTP port (no dashboard). A remote ``scheduler`` must be ``tls://``, with credentials
from Dask's configuration ``distributed.comm.tls.*`` (:data:`TLS_HINT`); any other (``tcp://``) is refused unless
the caller says ``insecure_scheduler=True`` (``--insecure-scheduler``), because anyone who can reach an open
scheduler can join it as a worker and run code on the other workers and, through the pickled results it sends
back, inside this uvms process (:data:`OPEN_SCHEDULER`). Connecting to a remote scheduler, handshake included,
takes at most :data:`CONNECT_TIMEOUT` seconds; a peer that does not speak Dask's protocol is a one-line error. On
Dask a task that raises is retried once (``retries=1``); a worker that dies is replaced by the scheduler.
"""

from __future__ import annotations

import contextlib
import gc
import os
import threading
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from ...errors import InsecureSchedulerWarning, UVMSError

BACKENDS = ("loky", "dask")
#: Where the credentials of a remote tls:// scheduler come from (Dask's configuration).
TLS_HINT = ("credentials from Dask's configuration distributed.comm.tls.* (DASK_DISTRIBUTED__COMM__TLS__CA_FILE, "
            "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT, DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY)")
#: What a scheduler that is not tls:// lets anyone who can reach it do.
OPEN_SCHEDULER = ("neither encrypted nor authenticated: anyone who can reach it can join it as a worker and run any "
                  "code on its workers and, through the pickled results it sends back, inside this uvms process, as "
                  "you")
#: The most time connecting to a remote Dask scheduler may take, its handshake included [s].
CONNECT_TIMEOUT = 20.0
#: How often a worker process checks that the uvms process that submitted its task is alive [s].
PARENT_POLL = 0.1
#: The exit status of a worker process whose uvms process died.
ORPHAN_EXIT = 70
_watched: dict[tuple[int, str | None], bool] = {}  # in a worker process: each watched uvms process -> our parent?


def check_backend(backend: str, scheduler: str | None, jobs: int, error: type[UVMSError],
                  insecure_scheduler: bool = False) -> None:
    """Refuse an unknown backend, a scheduler without the dask backend, a scheduler that is not ``tls://`` (unless
    ``insecure_scheduler``), or jobs not >= 1 or -1 (``error``)."""
    if backend not in BACKENDS:
        raise error(f"backend {backend!r} is not valid; valid: {', '.join(BACKENDS)}")
    if scheduler and backend != "dask":
        raise error(f"a scheduler address ({scheduler!r}) needs the dask backend")
    if scheduler and not scheduler.startswith("tls://") and not insecure_scheduler:
        raise error(f"the Dask scheduler {scheduler} is not tls://, so {OPEN_SCHEDULER}; use a tls:// scheduler with "
                    f"{TLS_HINT}, or, on a network that only you can reach, say so with --insecure-scheduler "
                    f"(insecure_scheduler=True)")
    if not isinstance(jobs, int) or isinstance(jobs, bool) or jobs == 0 or jobs < -1:
        raise error(f"jobs must be >= 1 or -1 (all cores), got {jobs!r}")


def worker_count(jobs: int, points: int, remote: bool = False) -> int:
    """The parallel jobs: ``jobs`` (-1: all cores), at most one per task and, locally, per core."""
    if remote:  # the cluster's size is its own; -1: all its workers
        return jobs if jobs == -1 else min(jobs, points)
    return max(1, min(points, os.cpu_count() or 1, jobs if jobs > 0 else points))


def use_thread_lock_for_progress_bars() -> None:
    """In a worker (no progress bar is shown): give tqdm a thread lock instead of its default semaphore.

    tqdm creates an inter-process semaphore on first use; a worker killed by a Ctrl-C never releases it, and
    the parent's resource tracker would then print a "leaked semaphore" warning after the one-line message.
    """
    import threading

    from tqdm.std import tqdm

    if "_lock" not in vars(tqdm):
        tqdm.set_lock(threading.RLock())


def process_identity(pid: int) -> tuple[int, str | None]:
    """``(pid, start time)``: the start time (clock ticks after boot, from /proc; None elsewhere) tells the
    process from a later one given the same pid."""
    try:
        return pid, Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return pid, None


def parent_alive(parent: tuple[int, str | None], direct: bool) -> bool:
    """Whether the process ``parent`` (:func:`process_identity`) is alive; ``direct``: it is this process's parent
    (then its death re-parents this process at once, before it is reaped)."""
    pid, started = parent
    if direct:
        return os.getppid() == pid
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return fields[0] not in ("Z", "X") and (started is None or fields[19] == started)
    except FileNotFoundError:
        return False
    except (OSError, IndexError):  # no /proc
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        except OSError:
            pass
        return True


def watch_parent(parent: tuple[int, str | None] | None) -> None:
    """In a worker process: exit (:data:`ORPHAN_EXIT`) as soon as the uvms process ``parent`` is gone.

    A daemon thread polls every :data:`PARENT_POLL` seconds; started once per worker process and parent. Nothing
    is done in the uvms process itself (joblib runs one job there) or for a remote cluster (``parent`` None).
    """
    if parent is None or parent[0] == os.getpid() or parent in _watched:
        return
    direct = _watched[parent] = os.getppid() == parent[0]

    def watch() -> None:
        while parent_alive(parent, direct):
            time.sleep(PARENT_POLL)
        os._exit(ORPHAN_EXIT)  # now: no row, no file more; the resumed study runs this trial again

    threading.Thread(target=watch, name="uvms-parent-watch", daemon=True).start()


def exit_if_orphaned() -> None:
    """In a worker process: exit now if a watched uvms process is gone (before writing a result)."""
    for parent, direct in list(_watched.items()):
        if not parent_alive(parent, direct):
            os._exit(ORPHAN_EXIT)


def in_worker(function: Callable[..., dict], parent: tuple[int, str | None] | None, *task: Any) -> dict:
    """``function(*task)`` where joblib runs it; in a worker process, the uvms process ``parent`` watched first and
    the process settled after its first task (:func:`settle_worker`)."""
    watch_parent(parent)
    try:
        return function(*task)
    finally:
        if parent is not None and parent[0] != os.getpid():  # a worker process of ours (never the uvms process)
            settle_worker()


_settled = False  # in a worker process: whether settle_worker has run


def settle_worker() -> None:
    """In a worker process, once, after its first task: collect the garbage, then freeze what survives (the modules,
    numba's registries and kernels, ~1.5e5 objects) out of the garbage collector, whose full collections then walk
    only what later tasks make (each trial of the intervention study ran 1-2 full collections of 0.06 s)."""
    global _settled
    if not _settled:
        _settled = True
        gc.collect()
        gc.freeze()


@contextlib.contextmanager
def dask_client(scheduler: str | None, jobs: int, error: type[UVMSError],
                insecure_scheduler: bool = False) -> Iterator[Any]:
    """A dask.distributed Client on ``scheduler`` (tls://, credentials from Dask's configuration; another scheme
    only with ``insecure_scheduler``, and a warning), or on a local cluster of ``jobs`` workers with TLS credentials
    of its own and no HTTP port.

    Raises:
        error: dask or cryptography not installed, a scheduler that is not tls:// without ``insecure_scheduler``,
            or a scheduler that cannot be reached, does not answer within :data:`CONNECT_TIMEOUT` or does not
            speak Dask's protocol.
    """
    try:
        import dask
        from dask.distributed import Client, LocalCluster
        from distributed.security import Security
    except ImportError:
        raise error("the dask backend needs `pip install uvms[dask]` (dask.distributed)") from None
    if scheduler:
        check_backend("dask", scheduler, jobs, error, insecure_scheduler)
        if not scheduler.startswith("tls://"):
            warnings.warn(f"the Dask scheduler {scheduler} is not tls://: {OPEN_SCHEDULER}; prefer a tls:// "
                          f"scheduler with {TLS_HINT}", InsecureSchedulerWarning, stacklevel=3)
        client = connect(scheduler, Security(), error)
    else:
        try:
            security = Security.temporary()
        except ImportError:
            raise error("the local Dask cluster needs the 'cryptography' package for its TLS credentials: "
                        "pip install cryptography") from None
        no_http = {"distributed.scheduler.http.routes": [], "distributed.worker.http.routes": []}
        try:
            with dask.config.set(no_http):  # the workers get this configuration too
                cluster = LocalCluster(n_workers=max(jobs, 1), threads_per_worker=1, processes=True, protocol="tls",
                                       security=security, dashboard_address=None, host="127.0.0.1")
            client = Client(cluster, security=security)
            client.run_on_scheduler(stop_http_server)  # Dask always starts one (routes emptied above)
            client.run(stop_http_server)
        except (OSError, TypeError, ValueError) as exc:
            raise error(f"cannot start the local Dask cluster: {' '.join(str(exc).split())}") from None
    try:
        yield client
    finally:
        cluster = client.cluster if not scheduler else None
        client.close()
        if cluster is not None:
            cluster.close()


def connect(scheduler: str, security: Any, error: type[UVMSError]) -> Any:
    """A Client on the remote ``scheduler``, its whole start bounded by :data:`CONNECT_TIMEOUT` (Dask bounds the
    TCP connection but not the handshake read after it: a peer that accepts and stays silent would hang).

    Raises:
        error: the scheduler cannot be reached, stays silent, or answers something that is not Dask's protocol.
    """
    from dask.distributed import Client

    timeout = CONNECT_TIMEOUT

    class BoundedClient(Client):
        def start(self, **kwargs: Any) -> None:
            kwargs.setdefault("callback_timeout", timeout)  # distributed.utils.sync: the whole start, bounded
            try:
                super().start(**kwargs)
            except BaseException:
                with contextlib.suppress(Exception):
                    self.close(timeout=1)
                raise

    hint = f"; a tls:// scheduler needs {TLS_HINT}" if scheduler.startswith("tls://") else ""
    try:
        return BoundedClient(scheduler, timeout=timeout, security=security)
    except TimeoutError:
        raise error(f"the Dask scheduler {scheduler} did not answer within {timeout:g} s (something accepts the "
                    f"connection but does not speak Dask's protocol, or the scheduler is overloaded); check the "
                    f"address{hint}") from None
    except (OSError, TypeError) as exc:  # TypeError: a tls:// address without credentials
        message = " ".join(str(exc).split())[:300]
        raise error(f"cannot reach the Dask scheduler {scheduler}: {message}{hint}") from None
    except Exception as exc:  # noqa: BLE001 - a peer that sends anything: struct.error, MemoryError, ValueError...
        message = " ".join(str(exc).split())[:200]
        raise error(f"the Dask scheduler {scheduler} answered with something that is not Dask's protocol "
                    f"({type(exc).__name__}: {message}); check the address{hint}") from None


def stop_http_server(dask_scheduler: Any = None, dask_worker: Any = None) -> None:
    """Close the HTTP port of a Dask scheduler or worker (run in its event loop by ``Client.run``)."""
    server = getattr(dask_scheduler or dask_worker, "http_server", None)
    if server is not None:
        server.stop()


def run_tasks(function: Callable[..., dict], tasks: Sequence[tuple], *, jobs: int, backend: str,
              scheduler: str | None, progress: bool | None, error: type[UVMSError], desc: str = "runs",
              client: Any = None, in_workers: bool = False, insecure_scheduler: bool = False) -> list[dict]:
    """Run ``function(*task)`` for every task through joblib (loky or dask); the rows in completion order.

    Args:
        function: a module-level function (pickled by reference to the workers) returning a dict.
        tasks: the argument tuples.
        jobs: parallel jobs (-1: all cores or all the cluster's workers); 1 on loky runs in this process.
        backend: ``"loky"`` or ``"dask"``.
        scheduler: a Dask scheduler address, or None for the local cluster (dask) or local processes (loky).
        progress: progress bar (None: on a terminal only).
        error: the exception class of the caller (SweepError, StudyError) for a cluster that cannot start.
        desc: the progress bar's label.
        client: an open Dask client (:func:`dask_client`) to reuse; None opens one for this call (dask only).
        in_workers: run in worker processes even with one job or one task (loky runs those in this process).
        insecure_scheduler: accept a ``scheduler`` that is not ``tls://`` (:data:`OPEN_SCHEDULER`).

    Raises:
        BaseException: a worker that died (loky's TerminatedWorkerError, Dask's KilledWorker), Ctrl-C; the
            workers are stopped first.
    """
    from joblib import Parallel, delayed, parallel_config

    from ...io.progress import tqdm

    jobs = worker_count(jobs, len(tasks), remote=bool(scheduler))
    if in_workers and jobs == 1:
        jobs = 2  # joblib runs n_jobs=1 in this process; with 2 and one task, one worker process runs it
    parent = None if scheduler else process_identity(os.getpid())  # a remote cluster's workers are not ours

    def execute() -> list[dict]:
        parallel = Parallel(n_jobs=jobs, return_as="generator_unordered", batch_size=1)
        results = parallel(delayed(in_worker)(function, parent, *task) for task in tasks)
        try:
            return list(tqdm(results, total=len(tasks), desc=desc, unit="run", disable=progress is False,
                             leave=False))
        except BaseException:  # Ctrl-C, a dead worker: no worker may go on writing into the output folder
            stop_workers(results)
            raise

    if backend != "dask":
        with parallel_config(backend="loky"):
            return execute()
    with contextlib.ExitStack() as stack:
        if client is None:
            stack.enter_context(dask_client(scheduler, jobs, error, insecure_scheduler))
        with parallel_config(backend="dask", retries=1):  # a task lost with its worker: submitted again once
            return execute()


def stop_workers(results) -> None:
    """Abort a joblib generator and kill the loky workers (before the caller's output folder is touched).

    Closing the generator makes joblib abort its backend (loky: ``kill_workers=True``, waiting for the workers
    to exit); then any reusable loky executor left is shut down the same way (dask: :func:`dask_client`).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # joblib warns that the generator was exited early: that is the point
        with contextlib.suppress(Exception):
            results.close()
        with contextlib.suppress(Exception):
            from joblib.externals.loky import reusable_executor

            executor = getattr(reusable_executor, "_executor", None)
            if executor is not None:
                executor.shutdown(wait=True, kill_workers=True)


__all__ = ["BACKENDS", "CONNECT_TIMEOUT", "OPEN_SCHEDULER", "TLS_HINT", "check_backend", "dask_client",
           "exit_if_orphaned", "run_tasks", "watch_parent", "worker_count"]
