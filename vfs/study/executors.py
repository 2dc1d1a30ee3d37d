"""Executors: how the tasks of a study run (serial, local processes, dask, your own).

An executor is a function ``executor(tasks, on_result, options)``:

* ``tasks`` is a sequence of :class:`vfs.study.tasks.RunTask` (small, picklable);
* it runs every task with :func:`vfs.study.tasks.run_task` (in any process or
  on any machine where vfs of the same version is installed) and calls
  ``on_result(task, table)`` **in the calling thread**, once per task, in any
  order; ``on_result`` writes the chunk files, so results must not depend on
  the executor;
* it keeps at most ``options.max_in_flight(slots)`` tasks submitted but not
  yet handed to ``on_result`` and drops every reference to a result once
  ``on_result`` has returned, so that memory stays flat with the number of
  cases (:func:`run_windowed` does both for any ``concurrent.futures``-style
  pool);
* ``options`` (:class:`ExecutorOptions`) says how many workers, which
  scheduler and dashboard;
* if a task raises, it stops and raises that error.

Executors are looked up by name (``--engine``) in :data:`EXECUTORS`: the
built-in ``serial``, ``process`` and ``dask``, those added from Python with
:func:`register_executor` and those of other installed packages, declared in
the ``vfs.executors`` entry-point group (:data:`ENTRY_POINT_GROUP`), e.g. in
their ``pyproject.toml``::

    [project.entry-points."vfs.executors"]
    ray = "my_package.executors:run_ray"

``examples/ray_executor.py`` is a complete executor for Ray.
"""

from __future__ import annotations

import contextlib
import importlib.util
import multiprocessing
import multiprocessing.forkserver
import multiprocessing.resource_tracker
import os
import signal
import sys
import threading
import uuid
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from vfs.blas import single_threaded_workers
from vfs.errors import ClusterError, ParameterError
from vfs.registry import Registry
from vfs.study.faults import deferred_signals, raise_if_signalled
from vfs.study.orphans import STUDY_PID_VARIABLE, exit_with_parent
from vfs.study.tasks import RunTask, run_task
from vfs.version import __version__

OnResult = Callable[[RunTask, pd.DataFrame], None]

#: Entry-point group through which other packages add executors (``--engine`` choices).
ENTRY_POINT_GROUP = "vfs.executors"

#: Tasks submitted but not yet consumed, per worker slot (default of ``max_in_flight``).
IN_FLIGHT_PER_SLOT = 2


@dataclass(frozen=True)
class ExecutorOptions:
    """Settings of an executor.

    Attributes
    ----------
    workers : int
        Number of parallel workers (processes or dask workers).
    scheduler : str or None
        Address of a running dask scheduler (``tcp://host:8786``); None
        starts a local cluster.
    dask_processes : bool
        Local dask cluster with worker processes (True) or threads (False).
    dashboard : str or None
        Address of the dashboard of a local dask cluster (``":8787"``,
        ``"127.0.0.1:0"``); None: no dashboard.
    in_flight : int or None
        Tasks submitted but not yet consumed by ``on_result`` at any time;
        None: :data:`IN_FLIGHT_PER_SLOT` per worker slot.
    """

    workers: int
    scheduler: str | None = None
    dask_processes: bool = True
    dashboard: str | None = None
    in_flight: int | None = None

    def max_in_flight(self, slots: int | None = None) -> int:
        """Tasks an executor may have submitted and not yet consumed.

        Parameters
        ----------
        slots : int, optional
            Worker slots (threads) of the cluster; default ``workers``.
        """
        if self.in_flight is not None:
            return max(1, int(self.in_flight))
        return IN_FLIGHT_PER_SLOT * max(1, int(slots or self.workers))


Executor = Callable[[Sequence[RunTask], OnResult, ExecutorOptions], None]


def notify(message: str) -> None:
    """A one-line note of an executor for the user (stderr), e.g. the dashboard's address."""
    print(message, file=sys.stderr, flush=True)


def run_windowed(submit: Callable[[RunTask], Future[pd.DataFrame]], tasks: Iterable[RunTask],
                 on_result: OnResult, limit: int) -> None:
    """Run tasks through a ``concurrent.futures`` pool with at most ``limit`` in flight.

    Each finished future is handed to ``on_result`` and dropped, so no result
    outlives its ``on_result`` call and the pool never holds more than
    ``limit`` tasks (submitting 100,000 tasks at once would keep them all).

    Parameters
    ----------
    submit : callable
        ``submit(task) -> Future`` (e.g. ``lambda t: pool.submit(run_task, t)``).
    tasks : iterable of RunTask
        Submitted in this order.
    on_result : callable
        ``on_result(task, table)``, called in this thread.
    limit : int
        Tasks submitted but not yet consumed.
    """
    queue = iter(tasks)
    pending: dict[Future[pd.DataFrame], RunTask] = {}

    def fill() -> None:
        while len(pending) < limit:
            task = next(queue, None)
            if task is None:
                return
            pending[submit(task)] = task

    fill()
    while pending:
        done, _ = wait(pending, return_when=FIRST_COMPLETED)
        for future in done:
            task = pending.pop(future)
            on_result(task, future.result())
        del done
        fill()


def _run_serial(tasks: Sequence[RunTask], on_result: OnResult,
                options: ExecutorOptions) -> None:
    for task in tasks:
        on_result(task, run_task(task))


@contextlib.contextmanager
def _server_environment() -> Iterator[None]:
    """Start the fork server with SIGINT and SIGTERM blocked and the study's pid in its
    environment (:mod:`vfs.study.forkserver_guard` ignores, then unblocks them).
    """
    signals = (signal.SIGINT, signal.SIGTERM)
    main = threading.current_thread() is threading.main_thread()
    had = os.environ.get(STUDY_PID_VARIABLE)
    if main:
        os.environ[STUDY_PID_VARIABLE] = str(os.getpid())
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, signals)
    try:
        with single_threaded_workers():  # the server's environment is the workers'
            yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, blocked)  # a signal that came is raised now
        if main and had is None:
            os.environ.pop(STUDY_PID_VARIABLE, None)
        elif main and had is not None:
            os.environ[STUDY_PID_VARIABLE] = had


def _mp_context() -> Any:
    # not "fork": the parent may hold threads (dask, BLAS); forkserver
    # imports vfs once in its server, workers fork from there
    methods = multiprocessing.get_all_start_methods()
    if "forkserver" in methods:
        ctx = multiprocessing.get_context("forkserver")
        # the guard first: it ignores the signals the study process handles, and the
        # server dies with this process (vfs.study.forkserver_guard)
        ctx.set_forkserver_preload(["vfs.study.forkserver_guard", "vfs.study.tasks"])
        # the resource tracker first: starting it unblocks SIGINT and SIGTERM again
        multiprocessing.resource_tracker.ensure_running()
        with _server_environment():
            multiprocessing.forkserver.ensure_running()
        return ctx
    return multiprocessing.get_context("spawn")


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Stop a process pool now: cancel what has not started and kill its workers.

    The workers ignore SIGINT and SIGTERM (:func:`vfs.study.orphans.exit_with_parent`;
    the study process alone handles them), hold nothing worth saving (each result
    is written by the study process) and may be inside a long batch: they get
    SIGKILL and are joined, so no worker outlives the study and the interpreter
    does not wait for them at exit.
    """
    processes = list((getattr(pool, "_processes", None) or {}).values())
    # killed and joined before the pool is shut down: shutting it down frees the queues'
    # semaphores, and a worker still being started would then fail to open them and
    # print a traceback
    for process in processes:
        with contextlib.suppress(OSError, ValueError, AttributeError):
            process.kill()
    for process in processes:
        with contextlib.suppress(OSError, ValueError, AssertionError):
            process.join(timeout=10)
    pool.shutdown(wait=False, cancel_futures=True)


def _submit(pool: ProcessPoolExecutor, task: RunTask) -> Future[pd.DataFrame]:
    # a submit may start a worker: Ctrl-C is raised after it, never half-way
    with deferred_signals():
        return pool.submit(run_task, task)


def _run_processes(tasks: Sequence[RunTask], on_result: OnResult,
                   options: ExecutorOptions) -> None:
    # exit_with_parent: the workers die with this process, even after kill -9; they
    # ignore SIGINT, so Ctrl-C is handled here once
    pool = ProcessPoolExecutor(max_workers=options.workers, mp_context=_mp_context(),
                               initializer=exit_with_parent, initargs=(os.getpid(),))
    try:
        with single_threaded_workers():  # "spawn" workers take this process's environment
            run_windowed(lambda task: _submit(pool, task), tasks, on_result,
                         options.max_in_flight())
    except BrokenProcessPool as exc:
        stop_pool(pool)
        raise_if_signalled(exc)  # the workers died of the signal this process also got
        raise
    except BaseException:
        stop_pool(pool)
        raise
    pool.shutdown(wait=True)


def worker_versions() -> dict[str, str]:
    """Versions that must be equal on the client and every worker: vfs and numpy."""
    return {"vfs": __version__, "numpy": np.__version__}


def check_worker_versions(client: Any, expected: dict[str, str] | None = None) -> None:
    """Refuse a dask cluster whose workers run another vfs or numpy than this process.

    Parameters
    ----------
    client : dask.distributed.Client
        Connected client.
    expected : dict, optional
        The versions the workers must have; default :func:`worker_versions`
        of this process.

    Raises
    ------
    ClusterError
        Naming each mismatching worker with its versions (or the error it
        gave, e.g. vfs not installed there).
    """
    expected = worker_versions() if expected is None else expected
    try:
        found = client.run(worker_versions, on_error="return")
    except Exception as exc:  # e.g. a worker that cannot unpickle vfs functions
        raise ClusterError(f"could not ask the dask workers for their vfs version: "
                           f"{type(exc).__name__}: {exc}") from None
    bad = []
    for worker, versions in sorted(found.items()):
        if isinstance(versions, BaseException):
            bad.append(f"{worker} ({type(versions).__name__}: {versions})")
        elif versions != expected:
            diff = ", ".join(f"{k} {versions.get(k)}" for k in expected
                             if versions.get(k) != expected[k])
            bad.append(f"{worker} ({diff})")
    if bad:
        want = ", ".join(f"{k} {v}" for k, v in expected.items())
        raise ClusterError(f"{len(bad)} of {len(found)} dask worker(s) do not run the client's "
                           f"{want}: {'; '.join(bad)}; install the same versions on every "
                           "worker")


def _start_local_cluster(options: ExecutorOptions) -> tuple[Any, Any]:
    import logging

    from dask.distributed import Client, LocalCluster

    dashboard = options.dashboard
    if dashboard and importlib.util.find_spec("bokeh") is None:
        notify("dask dashboard: not available, the bokeh package is not installed "
               "(pip install 'bokeh>=3.1'); running without it")
        dashboard = None
    with single_threaded_workers():
        cluster = LocalCluster(n_workers=options.workers, threads_per_worker=1,
                               processes=options.dask_processes, dashboard_address=dashboard,
                               silence_logs=logging.ERROR)
    client = Client(cluster)
    if dashboard:
        notify(f"dask dashboard: {dashboard_link(client.dashboard_link, dashboard)}")
    return cluster, client


def dashboard_link(link: str, address: str) -> str:
    """The dashboard's link with the host of ``address`` where one is given.

    dask builds the link from the machine's address, which does not answer
    when the dashboard listens on one interface only (``127.0.0.1:8787``).

    >>> dashboard_link("http://10.0.0.5:8787/status", "127.0.0.1:8787")
    'http://127.0.0.1:8787/status'
    >>> dashboard_link("http://10.0.0.5:8787/status", ":8787")
    'http://10.0.0.5:8787/status'
    """
    from urllib.parse import urlsplit, urlunsplit

    host = str(address).rpartition(":")[0].strip("[]")
    parts = urlsplit(link)
    if not host or host in ("0.0.0.0", "::") or parts.port is None:
        return link
    host = f"[{host}]" if ":" in host else host
    return urlunsplit(parts._replace(netloc=f"{host}:{parts.port}"))


def _run_dask(tasks: Sequence[RunTask], on_result: OnResult,
              options: ExecutorOptions) -> None:
    try:
        from dask.distributed import Client, as_completed
    except ImportError as exc:
        raise ParameterError(f"engine 'dask' needs dask.distributed ({exc})") from None
    cluster = None
    if options.scheduler:
        client = Client(options.scheduler)
    else:
        cluster, client = _start_local_cluster(options)
    try:
        check_worker_versions(client)
        limit = options.max_in_flight(sum(client.nthreads().values()))
        token = uuid.uuid4().hex[:8]
        queue = iter(tasks)
        pending: dict[str, RunTask] = {}
        finished = as_completed(loop=client.loop)

        def submit(n: int) -> None:
            for _ in range(n):
                task = next(queue, None)
                if task is None:
                    return
                future = client.submit(run_task, task, pure=False,
                                       key=f"vfs-study-{token}-{task.chunk}-{task.system_index}")
                pending[future.key] = task
                finished.add(future)

        submit(limit)
        for future in finished:
            task = pending.pop(future.key)
            table = future.result()
            future.release()  # the worker forgets the result now, not at the end
            del future
            on_result(task, table)
            del table
            submit(1)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


#: Executors by name (``--engine``): built-in, added with :func:`register_executor`, and those
#: of the ``vfs.executors`` entry-point group (loaded when the registry is first read).
EXECUTORS: Registry[Executor] = Registry("executor (engine)",
                                         entry_point_group=ENTRY_POINT_GROUP,
                                         same=lambda old, new: old is new)
EXECUTORS.add("serial", _run_serial)
EXECUTORS.add("process", _run_processes)
EXECUTORS.add("dask", _run_dask)


def register_executor(name: str, executor: Executor, *, replace: bool = False) -> None:
    """Add an executor ``executor(tasks, on_result, options)`` to :data:`EXECUTORS`.

    Raises
    ------
    ParameterError
        If the name is taken and ``replace`` is False.
    """
    EXECUTORS.add(name, executor, replace=replace)


def cpu_count() -> int:
    """CPUs this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


__all__ = ["ENTRY_POINT_GROUP", "EXECUTORS", "IN_FLIGHT_PER_SLOT",
           "Executor", "ExecutorOptions", "OnResult", "check_worker_versions", "cpu_count",
           "dashboard_link", "notify", "register_executor", "run_windowed", "stop_pool",
           "worker_versions"]
