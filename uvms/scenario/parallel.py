"""Running many scenario runs in parallel: local processes (joblib's loky) or a Dask cluster.

The one executor of :mod:`uvms.scenario.sweep` (grid points) and :mod:`uvms.scenario.study` (Monte Carlo
trials). A task is ``function(*arguments)`` returning a row (a dict); the rows come back in completion order and
the caller sorts them by their index, so a table is the same whatever the backend and the number of jobs.

A Dask scheduler runs whatever its clients submit. The local cluster speaks TLS with credentials made for it
(client certificates required: another user of the machine cannot submit to it) and opens no HTTP port (no
dashboard). A remote ``scheduler`` should be ``tls://``, with credentials from Dask's configuration
``distributed.comm.tls.*`` (:data:`TLS_HINT`); a ``tcp://`` one works as in Dask, with a warning. On Dask a
task that raises is retried once (``retries=1``); a worker that dies is replaced by the scheduler.
"""

from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from ..errors import InsecureSchedulerWarning, UVMSError

BACKENDS = ("loky", "dask")
#: Where the credentials of a remote tls:// scheduler come from (Dask's configuration).
TLS_HINT = ("credentials from Dask's configuration distributed.comm.tls.* (DASK_DISTRIBUTED__COMM__TLS__CA_FILE, "
            "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT, DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY)")


def check_backend(backend: str, scheduler: str | None, jobs: int, error: type[UVMSError]) -> None:
    """Refuse an unknown backend, a scheduler without the dask backend, or jobs not >= 1 or -1 (``error``)."""
    if backend not in BACKENDS:
        raise error(f"backend {backend!r} is not valid; valid: {', '.join(BACKENDS)}")
    if scheduler and backend != "dask":
        raise error(f"a scheduler address ({scheduler!r}) needs the dask backend")
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


@contextlib.contextmanager
def dask_client(scheduler: str | None, jobs: int, error: type[UVMSError]) -> Iterator[Any]:
    """A dask.distributed Client on ``scheduler`` (TLS credentials from Dask's configuration; a warning if not
    ``tls://``), or on a local cluster of ``jobs`` workers with TLS credentials of its own and no HTTP port.

    Raises:
        error: dask or cryptography not installed, or the scheduler cannot be reached.
    """
    try:
        import dask
        from dask.distributed import Client, LocalCluster
        from distributed.security import Security
    except ImportError:
        raise error("the dask backend needs `pip install uvms[dask]` (dask.distributed)") from None
    try:
        if scheduler:
            if not scheduler.startswith("tls://"):
                warnings.warn(f"the Dask scheduler {scheduler} is not tls://: neither encrypted nor authenticated, "
                              f"so anyone who can reach it can run code on its workers; prefer a tls:// scheduler "
                              f"with {TLS_HINT}", InsecureSchedulerWarning, stacklevel=3)
            client = Client(scheduler, timeout="20s", security=Security())
        else:
            try:
                security = Security.temporary()
            except ImportError:
                raise error("the local Dask cluster needs the 'cryptography' package for its TLS credentials: "
                            "pip install cryptography") from None
            no_http = {"distributed.scheduler.http.routes": [], "distributed.worker.http.routes": []}
            with dask.config.set(no_http):  # the workers get this configuration too
                cluster = LocalCluster(n_workers=max(jobs, 1), threads_per_worker=1, processes=True, protocol="tls",
                                       security=security, dashboard_address=None, host="127.0.0.1")
            client = Client(cluster, security=security)
            client.run_on_scheduler(stop_http_server)  # Dask always starts one (routes emptied above)
            client.run(stop_http_server)
    except (OSError, TypeError, ValueError) as exc:  # TypeError: a tls:// address without credentials
        message = " ".join(str(exc).split())
        hint = f"; a tls:// scheduler needs {TLS_HINT}" if scheduler and scheduler.startswith("tls://") else ""
        raise error(f"cannot reach the Dask scheduler {scheduler or '(local cluster)'}: {message}{hint}") from None
    try:
        yield client
    finally:
        cluster = client.cluster if not scheduler else None
        client.close()
        if cluster is not None:
            cluster.close()


def stop_http_server(dask_scheduler: Any = None, dask_worker: Any = None) -> None:
    """Close the HTTP port of a Dask scheduler or worker (run in its event loop by ``Client.run``)."""
    server = getattr(dask_scheduler or dask_worker, "http_server", None)
    if server is not None:
        server.stop()


def run_tasks(function: Callable[..., dict], tasks: Sequence[tuple], *, jobs: int, backend: str,
              scheduler: str | None, progress: bool | None, error: type[UVMSError], desc: str = "runs",
              client: Any = None, in_workers: bool = False) -> list[dict]:
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

    Raises:
        BaseException: a worker that died (loky's TerminatedWorkerError, Dask's KilledWorker), Ctrl-C; the
            workers are stopped first.
    """
    from joblib import Parallel, delayed, parallel_config

    from ..io.progress import tqdm

    jobs = worker_count(jobs, len(tasks), remote=bool(scheduler))
    if in_workers and jobs == 1:
        jobs = 2  # joblib runs n_jobs=1 in this process; with 2 and one task, one worker process runs it

    def execute() -> list[dict]:
        parallel = Parallel(n_jobs=jobs, return_as="generator_unordered", batch_size=1)
        results = parallel(delayed(function)(*task) for task in tasks)
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
            stack.enter_context(dask_client(scheduler, jobs, error))
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


__all__ = ["BACKENDS", "TLS_HINT", "check_backend", "dask_client", "run_tasks", "worker_count"]
