"""Threads of the numerical libraries (BLAS, OpenMP) under vfs's own jobs.

vfs's numerical work is many small problems (2x2 normal equations, 80x80
eigenproblems of the spline smoothing, vectorised elementwise kernels), for
which a multi-threaded BLAS only adds thread hand-offs: on a loaded 2-core
machine an 80 x 80 ``numpy.linalg.eigh`` took 18 ms with OpenBLAS's
threads against 0.8 ms with one.  The command line and the study's worker
processes therefore run with one thread per library pool
(:func:`single_threaded_blas` in this process, :func:`single_threaded_workers`
for the processes it starts), unless the user chose a thread count with one of
:data:`THREAD_VARIABLES` (kept as given).
"""

from __future__ import annotations

import contextlib
import functools
import os
from collections.abc import Callable, Iterator
from typing import ParamSpec, TypeVar

_P = ParamSpec("_P")
_R = TypeVar("_R")

#: Environment variables by which a user chooses the thread count of a library's pool
#: (BLAS and OpenMP pools; Arrow's CPU pool follows ``OMP_NUM_THREADS``); respected.
THREAD_VARIABLES: tuple[str, ...] = (
    "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS")
#: The environment variable of vfs's own compute threads in a process: the compiled run-out's
#: numba threads and duckdb's (declared, with its range and default, in :mod:`vfs.threads`).
COMPUTE_THREADS_VARIABLE = "VFS_THREADS"
#: What a worker process of a study gets set to 1 (:func:`single_threaded_workers`): the
#: pools above and vfs's own (numba's and duckdb's) through ``VFS_THREADS``. A worker is one
#: single-threaded batch, and W workers with a pool of one thread per core each would
#: oversubscribe the machine.
WORKER_THREAD_VARIABLES: tuple[str, ...] = (*THREAD_VARIABLES, COMPUTE_THREADS_VARIABLE)


@contextlib.contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Run the block with one BLAS thread (threadpoolctl), unless a variable of
    :data:`THREAD_VARIABLES` is set: then the user's choice holds.
    """
    if any(os.environ.get(v) for v in THREAD_VARIABLES):
        yield
        return
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


def one_blas_thread(func: Callable[_P, _R]) -> Callable[_P, _R]:
    """Decorator: ``func`` runs under :func:`single_threaded_blas`.

    For the public entry points of vfs's jobs (:func:`vfs.diagnosis.diagnose.diagnose`,
    :func:`vfs.uncertainty.bands.run_uncertainty`, ...), so that a call from Python (a
    notebook, a script) gets what the command line gets: under load, OpenBLAS's threads
    made the diagnosis's 80 x 80 eigenproblems some 20 times slower (600 generated
    cases, 2 cores at load 3: 139 s CPU from Python against 61 s from the command line;
    ``numpy.linalg.eigh`` 53 s against 2.8 s).  Costs about 0.5 ms per call.
    """
    @functools.wraps(func)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        with single_threaded_blas():
            return func(*args, **kwargs)

    return wrapper


@contextlib.contextmanager
def single_threaded_workers() -> Iterator[None]:
    """Processes started inside this block get :data:`WORKER_THREAD_VARIABLES` = 1.

    Variables the user has set are left alone; those added are removed again on
    exit, so this process's environment is unchanged afterwards.
    """
    added = [name for name in WORKER_THREAD_VARIABLES if name not in os.environ]
    for name in added:
        os.environ[name] = "1"
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


__all__ = ["COMPUTE_THREADS_VARIABLE", "THREAD_VARIABLES", "WORKER_THREAD_VARIABLES",
           "one_blas_thread", "single_threaded_blas", "single_threaded_workers"]
