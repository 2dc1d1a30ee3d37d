"""Executors: how the tasks of a study run (serial, local processes, dask).

An executor is a function ``executor(tasks, on_result, options)`` that runs
every task with :func:`vfs.study.tasks.run_task` and calls
``on_result(task, table)`` in the main process for each; results must not
depend on the executor.  Add one with :func:`register_executor`.
"""

from __future__ import annotations

import multiprocessing
import os
import uuid
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from typing import Any

import pandas as pd

from vfs.errors import ParameterError
from vfs.registry import Registry
from vfs.study.tasks import RunTask, run_task

OnResult = Callable[[RunTask, pd.DataFrame], None]


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
    """

    workers: int
    scheduler: str | None = None
    dask_processes: bool = True


Executor = Callable[[Sequence[RunTask], OnResult, ExecutorOptions], None]


def _run_serial(tasks: Sequence[RunTask], on_result: OnResult,
                options: ExecutorOptions) -> None:
    for task in tasks:
        on_result(task, run_task(task))


def _mp_context() -> Any:
    # not "fork": the parent may hold threads (dask, BLAS); forkserver
    # imports vfs once in its server, workers fork from there
    methods = multiprocessing.get_all_start_methods()
    if "forkserver" in methods:
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["vfs.study.tasks"])
        return ctx
    return multiprocessing.get_context("spawn")


def _run_processes(tasks: Sequence[RunTask], on_result: OnResult,
                   options: ExecutorOptions) -> None:
    pool = ProcessPoolExecutor(max_workers=options.workers, mp_context=_mp_context())
    try:
        futures = {pool.submit(run_task, task): task for task in tasks}
        for future in as_completed(futures):
            on_result(futures[future], future.result())
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def _run_dask(tasks: Sequence[RunTask], on_result: OnResult,
              options: ExecutorOptions) -> None:
    import logging

    try:
        from dask.distributed import Client, LocalCluster
        from dask.distributed import as_completed as dask_completed
    except ImportError as exc:
        raise ParameterError(f"engine 'dask' needs dask.distributed ({exc})") from None
    cluster = None
    if options.scheduler:
        client = Client(options.scheduler)
    else:
        cluster = LocalCluster(n_workers=options.workers, threads_per_worker=1,
                               processes=options.dask_processes, dashboard_address=None,
                               silence_logs=logging.ERROR)
        client = Client(cluster)
    try:
        token = uuid.uuid4().hex[:8]
        futures = {client.submit(run_task, task, pure=False,
                                 key=f"vfs-study-{token}-{task.chunk}-{task.system_index}"): task
                   for task in tasks}
        for future in dask_completed(list(futures)):
            on_result(futures[future], future.result())
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


#: Executors by name (``--engine``); add one with :func:`register_executor`.
EXECUTORS: Registry[Executor] = Registry("executor (engine)", same=lambda old, new: old is new)
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



__all__ = ["EXECUTORS", "Executor", "ExecutorOptions", "OnResult", "cpu_count",
           "register_executor"]
